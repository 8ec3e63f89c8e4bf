"""``bench replay CAPTURE [--mode offline|controller|plant] ...`` (docs/replay.md)."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from hil_bench.console import console


def add_parser(sub) -> None:
    r = sub.add_parser("replay", help="replay a capture offline, into a controller or into the plant",
                       description="Replay a logged capture: a bench recording (.mcap), a CAN log "
                                   "(.log .asc .blf .trc .csv .mf4, optionally .gz), a serial "
                                   "byte capture (.serial.bin) or a scope/DAQ CSV with --mapping. "
                                   "See docs/replay.md.")
    r.add_argument("capture", type=Path)
    r.add_argument("--mode", choices=("offline", "controller", "plant"), default="offline",
                   help="offline: reference estimators on the recorded samples (default); "
                        "controller: the recorded SENSE frames to a live controller, its answers "
                        "compared; plant: the recorded duties drive the plant, its currents "
                        "compared")
    r.add_argument("--out", type=Path, default=None, help="the new recording (.mcap)")
    r.add_argument("--force", action="store_true", help="replace an existing --out file")
    r.add_argument("--estimators", default=None,
                   help="offline/plant: comma-separated NAME or NAME:label (SMO_SIGN, SMO_SIGMOID, "
                        "SMO_TANH, HFI_SDFT); default: a recording's own [reference]")
    r.add_argument("--est-config", action="append", default=[], metavar="ENTRY.key=value",
                   help="an estimator setting, e.g. SMO_TANH:m1.m_per_a=0.02 (repeatable)")
    r.add_argument("--profile", default=None,
                   help="motor profile (name or path); a recording's own by default")
    r.add_argument("--mapping", type=Path, default=None, help="CSV: the mapping file (TOML)")
    r.add_argument("--ts-us", type=float, default=None,
                   help="control period when the capture does not say it (no HELLO)")
    r.add_argument("--rate", type=float, default=None,
                   help="pace the replay at this multiple of the recorded rate (1.0 = as "
                        "recorded) from absolute deadlines; default: as fast as possible")
    r.add_argument("--live", type=int, nargs="?", const=8765, default=None, metavar="PORT",
                   help="serve the new recording's channels live over the Foxglove WebSocket "
                        "protocol on PORT (default 8765; 0: any free port) of 127.0.0.1 "
                        "(--live-host: another address) while the "
                        "replay goes on; a viewer's operator inputs are refused (docs/foxglove.md)")
    r.add_argument("--live-rate", type=float, default=50.0, metavar="HZ",
                   help="--live: messages per second per per-cycle channel sent to a viewer "
                        "(default 50); pace the replay for watching with --rate 1")
    r.add_argument("--live-host", default=None, metavar="ADDR",
                   help="--live: the address to listen on (default 127.0.0.1, this machine "
                        "only; 0.0.0.0: every interface, with a warning); implies --live")
    r.add_argument("--link", default="stub", help="controller mode: the link (as bench run --link)")
    r.add_argument("--set", action="append", default=[], metavar="PARAM=value",
                   help="controller mode: a CONFIG parameter other than the capture's, e.g. "
                        "SMO_K_V=30 (repeatable)")
    r.add_argument("--window", default=None, metavar="T0,T1",
                   help="metrics window [s] (default: the recording's, else the second half)")
    r.add_argument("--strict", action="store_true",
                   help="exit 1 if the capture has anomalies or (controller/plant) the answers "
                        "differ from the recorded")
    r.set_defaults(func=cmd_replay)


def _parse_kv(items: list[str], what: str) -> list[tuple[str, str]]:
    out = []
    for it in items:
        k, eq, v = it.partition("=")
        if not eq or not k.strip():
            raise ValueError(f"{what} {it!r}: use KEY=VALUE")
        out.append((k.strip(), v.strip()))
    return out


def build_options(args: argparse.Namespace):
    from hil_bench.protocol.messages import Param

    from .modes import ReplayError, ReplayOptions

    est = [e.strip() for e in args.estimators.split(",") if e.strip()] if args.estimators else None
    cfg: dict[str, dict[str, float]] = {}
    for k, v in _parse_kv(args.est_config, "--est-config"):
        entry, dot, key = k.rpartition(".")
        if not dot:
            raise ValueError(f"--est-config {k}={v}: use ENTRY.key=value, e.g. SMO_SIGN.k_v=25")
        cfg.setdefault(entry, {})[key] = float(v)
    params = {}
    for k, v in _parse_kv(args.set, "--set"):
        try:
            params[Param[k.upper()]] = float(v)
        except KeyError:
            raise ValueError(f"--set {k}: unknown CONFIG parameter; known: "
                             f"{', '.join(p.name for p in Param)}") from None
    window = None
    if args.window is not None:
        from .modes import check_window

        a, sep, b = args.window.partition(",")
        try:
            window = check_window((a, b) if sep else (args.window,), shown=args.window)
        except ReplayError as exc:
            raise ValueError(str(exc)) from None
    from hil_bench.record.live_cli import live_options, said_listening

    err = console(stderr=True)
    live = live_options(args, err) if hasattr(args, "live") else None   # ValueError: bad values
    return ReplayOptions(mode=args.mode, out=args.out, force=args.force, estimators=est,
                         est_config=cfg, profile=args.profile, rate=args.rate, link=args.link,
                         set_params=params, window_s=window, live=live,
                         on_live=lambda port: said_listening(err, live, port))


def cmd_replay(args: argparse.Namespace) -> int:
    from hil_bench.record.recorder import RecorderError

    from .capture import CaptureError
    from .modes import ReplayError
    from .readers import read_capture
    from .run import run_replay

    out, err = console(), console(stderr=True)
    try:
        if args.out is not None:   # never over one of its inputs, before any is read
            from hil_bench.record.atomic import refuse_output_is_input

            profile_file = Path(args.profile) if args.profile else None
            refuse_output_is_input([args.out], [
                ("capture", args.capture), ("mapping file", args.mapping),
                ("motor profile", profile_file if profile_file and profile_file.is_file() else None)])
        opts = build_options(args)
        profile = None
        if args.profile:
            from hil_bench.plant_rt.profile import load_profile

            profile = load_profile(args.profile)
        cap = read_capture(args.capture, ts_s=args.ts_us * 1e-6 if args.ts_us else None,
                           mapping=args.mapping, profile=profile)
    except (CaptureError, ValueError) as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    out.print(escape(cap.describe()))
    for p in cap.problems:
        err.print(f"[yellow]damaged capture:[/yellow] {escape(p)}")
    out.print(f"capture anomalies: {escape(cap.anomalies.summary())}")
    for n in cap.notes:
        out.print(f"[dim]note: {escape(n)}[/dim]")
    if cap.resampling:
        rs = cap.resampling
        out.print(f"resampled {rs['samples']} samples at {rs['daq_rate_hz']:.6g} Hz onto "
                  f"{rs['control_rate_hz']:.6g} Hz: {escape(rs['method'])}")
    try:
        res = run_replay(cap, opts)
    except (ReplayError, RecorderError, CaptureError) as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    print_result(res, out, err)
    if res.error:
        return 1
    if args.strict:
        an = {k: v for k, v in cap.anomalies.as_dict().items() if v}
        if an or cap.problems or res.compare.get("first_divergence"):
            return 1
        if res.mode == "plant" and any(p["rms_error_a"] > 0 for p in
                                       res.compare.get("phases", {}).values()):
            return 1
    return 0


def _f(v, unit="") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    return f"{v:.4g} {unit}".strip()


def print_result(res, out: Console, err: Console) -> None:
    out.print(f"replayed {res.cycles}/{res.capture.n} cycles ({res.mode}) in {res.wall_s:.2f} s "
              f"({res.cycles / max(res.wall_s, 1e-9):.0f} cycles/s); recording {escape(str(res.out))}")
    p = res.pacing
    if "start_err_p99_us" in p:
        out.print(f"paced at {res.capture.ts_s / p['pace_s']:g} x the recorded rate (each cycle "
                  f"at its recorded time / rate, absolute deadlines): pacing error p50 "
                  f"{p['start_err_p50_us']:.1f} us, p99 {p['start_err_p99_us']:.1f} us, max "
                  f"{p['start_err_max_us']:.1f} us")
    for n in res.notes:
        out.print(f"[dim]note: {escape(n)}[/dim]")
    if res.live_stats is not None:
        from hil_bench.record.live_view import stats_line

        err.print(escape(stats_line(res.live_stats)))
    if res.error:
        err.print(f"[red]replay ended early:[/red] {escape(res.error)}")
    if res.metrics:
        w0, w1 = res.window_s
        t = Table(title=f"estimates over {w0:g}..{w1:g} s against the capture's angle "
                        f"({escape(res.capture.theta_source or 'none: no angle in the capture')})")
        for c in ("estimate", "PEE max", "PEE mean", "PEE RMS", "speed mean", "speed band"):
            t.add_column(c)
        for name, m in res.metrics.items():
            t.add_row(escape(name), _f(m.get("pee_max_rad"), "rad"), _f(m.get("pee_mean_rad"), "rad"),
                      _f(m.get("pee_rms_rad"), "rad"), _f(m.get("speed_hat_mean_rpm"), "rpm"),
                      _f(m.get("speed_band_rpm"), "rpm"))
        out.print(t)
    c = res.compare
    if res.mode == "controller" and c.get("cycles"):
        fd = c.get("first_divergence")
        if fd:
            out.print(f"[yellow]first divergence[/yellow] at cycle seq {fd['cycle_seq']} (row "
                      f"{fd['row']}, t = {fd['t_s']:.6g} s): {escape(str(fd['field']))} recorded "
                      f"{fd['recorded']:.9g}, now {fd['now']:.9g}")
        else:
            fields = [n for n, s in c["fields"].items() if s["compared"]]
            out.print(f"[green]the controller's answers equal the recorded ones[/green] in all "
                      f"{c['cycles']} cycles ({', '.join(fields)}, wherever the capture has them)")
        t = Table(title="controller now - recorded (in the cycles the capture recorded the field)")
        for col in ("field", "cycles compared", "cycles differing", "max |diff|", "RMS diff"):
            t.add_column(col)
        for name, s in c["fields"].items():
            t.add_row(name, str(s["compared"]), str(s["differ"]), _f(s["max_abs"]), _f(s["rms"]))
        out.print(t)
    if res.mode == "plant" and c.get("cycles"):
        t = Table(title=f"plant currents - recorded over {c['cycles']} cycles")
        for col in ("phase", "RMS error", "max |error|", "RMS recorded"):
            t.add_column(col)
        for ph, s in c["phases"].items():
            t.add_row(ph, _f(s["rms_error_a"], "A"), _f(s["max_abs_error_a"], "A"),
                      _f(s["rms_recorded_a"], "A"))
        out.print(t)
