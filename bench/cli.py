"""Command line: ``bench run``, ``bench check``, ``bench scenarios``, ``bench claims``, ``bench recover``,
``bench export`` (bench/record/export.py), ``bench conformance``, ``bench campaign`` (bench/faults/campaign.py), ``bench sweep``
(bench/sweep/), ``bench replay`` (bench/replay/cli.py)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rich.console import Console
from rich.markup import escape

from hil_bench.cluster.options import positive_int
from hil_bench.console import console
from hil_bench.errors import BenchError
from hil_bench.record.live_cli import add_live_hand_options, live_options, said_listening


class _PressOnce:
    """Ctrl-C for ``bench run``: a press raises KeyboardInterrupt once (the runner stops the run
    and finalises its recording, deferring further presses while it does: DeferredInterrupts);
    from then on presses are counted, not raised, except while wait_for waits on the check after
    the run (the next press ends the command). Deciding in the handler, not in ``except`` blocks,
    leaves no window where a quick second press escapes as a traceback while the first is being
    handled. A no-op outside the main thread (only it receives signals)."""

    def __init__(self):
        self.armed = True
        self.count = 0
        self._previous = None

    def __call__(self, signum, frame) -> None:   # noqa: ARG002 - a signal handler's signature
        self.count += 1
        if self.armed:
            self.armed = False
            raise KeyboardInterrupt

    def wait_for(self, fn, *args):
        """fn(*args) in a worker thread while the main thread only waits, armed: a press ends
        the wait at once with KeyboardInterrupt (the worker, a daemon reading a finalised file,
        is left to the interpreter's exit). In the main thread itself a press could land in a
        library's weakref or GC callback, where Python prints it ("Exception ignored") and
        swallows it."""
        import threading

        box: dict = {}

        def work() -> None:
            try:
                box["value"] = fn(*args)
            except BaseException as exc:   # noqa: BLE001 - handed to the main thread as is
                box["error"] = exc

        worker = threading.Thread(target=work, name="bench-check", daemon=True)
        worker.start()
        self.armed = True
        try:
            while worker.is_alive():
                worker.join(0.05)
        finally:
            self.armed = False
        if "error" in box:
            raise box["error"]
        return box["value"]

    def __enter__(self) -> "_PressOnce":
        import signal
        import threading

        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self)
        return self

    def __exit__(self, *exc) -> None:
        import signal

        if self._previous is not None:
            # pressed: the command is ending interrupted, and a press on the way out must not
            # become a KeyboardInterrupt at interpreter shutdown (main() does the same for 130)
            signal.signal(signal.SIGINT, signal.SIG_IGN if self.count else self._previous)
            self._previous = None


def _cmd_run(args: argparse.Namespace) -> int:
    with _PressOnce() as presses:
        return _run_and_check(args, presses)


def _run_and_check(args: argparse.Namespace, presses: _PressOnce) -> int:
    from hil_bench.loop.links import LinkError
    from hil_bench.loop.runner import RunAborted, run_scenario
    from hil_bench.papers.check import check_recording, print_report
    from hil_bench.record.recorder import RecorderError
    from hil_bench.record.recording import RecordingError
    from hil_bench.scenario import ScenarioError, derive_scenario, load_scenario

    out = console()
    err = console(stderr=True)
    try:
        live = live_options(args, err)
    except ValueError as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2

    def said_live(port: int) -> None:
        said_listening(err, live, port)

    said_notes: list[str] = []

    def say_link_note(note: str) -> None:
        said_notes.append(note)
        err.print(f"[yellow]link:[/yellow] {escape(note)}")

    try:
        scn = (derive_scenario(args.scenario, load_scenario(args.scenario).name, args.set,
                               note="bench run --set") if args.set else load_scenario(args.scenario))
        result = run_scenario(scn, link_spec=args.link, out_path=args.out,
                              progress=not args.no_progress, allow_slow_link=args.allow_slow_link,
                              force=args.force, realtime=True if args.realtime else None,
                              cpu=args.cpu, live=live, pace=args.pace, on_live=said_live,
                              on_link_note=say_link_note)
    except (ScenarioError, LinkError, RunAborted, RecorderError) as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    except ValueError as exc:  # e.g. ProfileError
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    tm = result.timing
    if result.protocol_note:
        err.print(f"[yellow]protocol:[/yellow] {escape(result.protocol_note)}")
    for note in result.link_notes:
        if note not in said_notes:     # the set-up failed before the run said it
            say_link_note(note)
    out.print(f"ran {result.cycles_done}/{result.cycles_planned} cycles ({result.mode}) in "
              f"{result.wall_s:.2f} s ({result.cycles_done / max(result.wall_s, 1e-9):.0f} "
              f"cycles/s); recording {escape(str(result.recording))}")
    if result.mode == "realtime" and tm:
        out.print(f"real time: period start error p50 {tm['jitter_p50_us']:.1f} us, p99 "
                  f"{tm['jitter_p99_us']:.1f} us, p99.9 {tm['jitter_p999_us']:.1f} us, max "
                  f"{tm['jitter_max_us']:.1f} us; SENSE->DUTY p50 {tm['cycle_p50_us']:.1f} us, "
                  f"p99 {tm['cycle_p99_us']:.1f} us; {tm['missed']} missed "
                  f"(rate {tm['miss_rate']:.2e}), {tm['late']} late, {tm['overruns']} periods "
                  f"lost by the bench (overruns); lost rate {tm['lost_rate']:.2e}")
        if result.realtime_notes:
            err.print(f"[yellow]real-time setup:[/yellow] {escape(result.realtime_notes)} "
                      f"(the run went on without it: timing figures are best effort)")
    elif tm:
        out.print(f"cycle time p50 {tm['cycle_p50_us']:.1f} us, p99 {tm['cycle_p99_us']:.1f} us, "
                  f"max {tm['cycle_max_us']:.1f} us")
    if result.live_stats is not None:
        from hil_bench.record.live_view import stats_line

        err.print(escape(stats_line(result.live_stats)))
    if result.error:
        err.print(f"[red]run ended early:[/red] {escape(result.error)}")
    if result.cycles_done == 0:
        _print_target(result.target, out)
        return 130 if result.interrupted else 1   # nothing ran: nothing to check
    if result.interrupts_while_closing and not result.interrupted:
        err.print(f"interrupted while the recording was being finalised (it is complete): "
                  f"`bench check {escape(str(result.recording))}` checks it")
        return 130
    try:
        report = presses.wait_for(check_recording, result.recording)
        print_report(report, out)
        _print_target(result.target, out)
        note = _window_note(args.set, report)
        if note:
            err.print(f"[yellow]note:[/yellow] {escape(note)}")
    except RecordingError as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    except KeyboardInterrupt:
        err.print(f"interrupted while checking the recording (it is finalised): "
                  f"`bench check {escape(str(result.recording))}` checks it again")
        return 130
    if result.interrupted:
        return 130
    if result.error:
        return 1
    return 1 if (args.strict and not report.all_pass) else 0


def _print_target(target: dict[str, str], out: Console) -> None:
    """The target's own figures (``--link pil-qemu``; recorded as metadata ``target``)."""
    if target:
        from hil_bench.loop.links.qemu import target_summary

        for line in target_summary(target):
            out.print(escape(line), highlight=False, soft_wrap=True)


def _window_note(overrides, report) -> str | None:
    """``--set metrics.window_s=...``: which figures the new window moved and which claim
    quantities kept a window of their own (bench/claims/*.toml ``window_s``)."""
    if not any(k == "metrics.window_s" or k.startswith("metrics.window_s[") for k, _ in overrides):
        return None
    w0, w1 = report.context.window_s
    own = [(r.quantity.key, r.quantity.window_s) for r in report.results
           if r.quantity.window_s is not None]
    text = f"--set metrics.window_s: the metrics above are over {w0:g}..{w1:g} s"
    if own:
        by_window: dict[tuple[float, float], list[str]] = {}
        for key, window in own:
            by_window.setdefault(tuple(window), []).append(key)
        kept = "; ".join(f"{', '.join(keys)} {'keeps its' if len(keys) == 1 else 'keep their'} "
                         f"claim's own window {a:g}..{b:g} s" for (a, b), keys in by_window.items())
        return f"{text}; {kept} (bench claims lists each claim's window)"
    if report.results:
        return (text + ", and so are the claims; a claim's verdict also checks that the window "
                       "is its paper's set-up (INVALID when it is not)")
    return text


def _cmd_check(args: argparse.Namespace) -> int:
    from hil_bench.papers.check import check_recording, print_report
    from hil_bench.record.recording import RecordingError

    err = console(stderr=True)
    path = Path(args.recording)
    if not path.exists():
        err.print(f"[red]error:[/red] {escape(str(path))}: no such file")
        return 2
    if path.is_dir():
        err.print(f"[red]error:[/red] {escape(str(path))}: is a directory, not a recording")
        return 2
    try:
        report = check_recording(path)
    except RecordingError as exc:
        hint = (f"\n(a damaged recording: `bench recover {path} -o FIXED.mcap` copies every "
                f"intact chunk)") if exc.damaged else ""
        err.print(f"[red]error:[/red] {escape(str(exc) + hint)}")
        return 2
    except KeyboardInterrupt:
        err.print("interrupted by the user")
        return 130
    if args.json:
        import json

        from hil_bench.api import check_result

        print(json.dumps(check_result(report).as_dict(), indent=2))
        return 1 if (args.strict and not report.all_pass) else 0
    out = console()
    print_report(report, out)
    from hil_bench.record.recording import read_header

    _print_target(read_header(path).metadata.get("target", {}), out)
    return 1 if (args.strict and not report.all_pass) else 0


def _cmd_recover(args: argparse.Namespace) -> int:
    from hil_bench.errors import OutputIsInput
    from hil_bench.record.recover import RecoverError, recover

    try:
        report = recover(args.recording, args.out, force=args.force)
    except (RecoverError, OutputIsInput) as exc:
        console(stderr=True).print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    print(report.text())
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from hil_bench.record.export import ExportError, export

    err = console(stderr=True)
    chosen = [c.strip() for part in args.channels for c in part.split(",") if c.strip()]
    try:
        done = export(args.recording, args.out, args.format, channels=chosen or None,
                      force=args.force)
    except (ExportError, ImportError) as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}", highlight=False)
        return 2
    except OSError as exc:
        err.print(f"[red]error:[/red] cannot write {escape(str(args.out))}: "
                  f"{escape(exc.strerror or str(exc))}", highlight=False)
        return 2
    for topic, path, rows in done.files:
        print(f"{topic:24s} {rows:8d} rows  {path}")
    print(f"exported {len(done.files)} channel(s) of {done.source} as {done.fmt}")
    if done.damage:
        err.print(f"[yellow]damaged recording:[/yellow] {escape(done.damage)}; exported what "
                  f"was readable (each file's metadata says so)", highlight=False)
        return 1
    return 0


def _cmd_layout(args: argparse.Namespace) -> int:
    import json

    from hil_bench.record.layout import make_layout
    from hil_bench.scenario import ScenarioError, load_scenario

    err = console(stderr=True)
    try:
        scn = load_scenario(args.scenario)
    except ScenarioError as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    layout = make_layout(tuple(scn.reference_estimators), telemetry_emf=bool(scn.telemetry_emf),
                         faults=bool(scn.faults) or scn.post_trip_s > 0)
    text = json.dumps(layout, indent=2) + "\n"
    if args.out is None:
        print(text, end="")
        return 0
    from hil_bench.errors import OutputIsInput
    from hil_bench.record.atomic import refuse_output_is_input, write_text_aside

    try:
        refuse_output_is_input([args.out], [("scenario file", scn.path)])
        if args.out.is_dir():
            raise IsADirectoryError(21, "is a directory")
        write_text_aside(args.out, text, replace=args.force)   # never half a layout
    except OutputIsInput as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    except FileExistsError:
        err.print(f"[red]error:[/red] {escape(str(args.out))} exists; --force replaces it")
        return 2
    except OSError as exc:
        err.print(f"[red]error:[/red] cannot write {escape(str(args.out))}: {exc.strerror or exc}")
        return 2
    print(f"layout for {scn.name}: {args.out} (Foxglove or Lichtblick: Layouts, Import from file)")
    return 0


def _cmd_conformance(args: argparse.Namespace) -> int:
    from hil_bench.conformance import main as conformance_main

    return conformance_main(args)


def _cmd_scenarios(args: argparse.Namespace) -> int:
    from hil_bench.scenario import SCENARIO_DIR, ScenarioError, load_scenario

    for path in sorted(SCENARIO_DIR.glob("*.toml")):
        try:
            scn = load_scenario(path)
            print(f"{scn.name:28s} {scn.duration_s:5.2f} s  claims {','.join(scn.claims) or '-':8s}"
                  f" {scn.description}")
        except ScenarioError as exc:
            print(f"{path.stem:28s} INVALID: {exc}")
    return 0


def _cmd_campaign(args: argparse.Namespace) -> int:
    import time

    from hil_bench.faults.campaign import CampaignError, load_campaign, run_campaign, write_report
    from hil_bench.installation import require_extra
    from hil_bench.loop.links import check_link_spec
    from hil_bench.record.atomic import refuse_output_is_input

    err = console(stderr=True)
    try:
        camp = load_campaign(args.campaign)
    except CampaignError as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    require_extra("bench campaign", "distributed")   # its runs go to a Dask cluster
    default_dir = Path("reports") / "campaigns" / camp.name
    out_dir = Path(args.out) if args.out else default_dir
    refuse_output_is_input([out_dir, out_dir / "results.md", out_dir / "results.csv",
                            out_dir / "recordings"],
                           [("campaign file", camp.path), ("base scenario", camp.base_path)])
    if args.link is not None:
        check_link_spec(args.link)
    from hil_bench.sweep.folder import FolderBusy, claim_folder

    try:   # one campaign per folder: a second one started beside it takes a folder of its own
        out_dir, lock, note = claim_folder(Path(args.out) if args.out else None, default_dir,
                                           "bench campaign")
    except (FolderBusy, OSError) as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}")
        return 2
    if note:
        err.print(escape(note))
    t0 = time.monotonic()
    with lock:
        results = run_campaign(camp, out_dir, jobs=args.jobs, link=args.link,
                               keep_all=args.keep_all, console=err, scheduler=args.scheduler,
                               progress=not args.no_progress)
        md = write_report(camp, results, out_dir, time.monotonic() - t0)
    out = console()
    for r in results:
        colour = {"PASS": "green", "FAIL": "red"}.get(r.verdict, "yellow")
        faults = ", ".join((f"{o.kind} detected after {o.detection_s * 1e3:.1f} ms by "
                            f"{o.detected_by}") if o.detected else f"{o.kind} NOT detected"
                           for o in r.outcomes) or r.run_error
        out.print(f"{escape(r.case.name):40s} [{colour}]{r.verdict:7s}[/{colour}] {escape(faults)}"
                  + (f" -- {escape('; '.join(r.reasons))}" if r.reasons else ""))
    n_bad = sum(1 for r in results if r.verdict != "PASS")
    out.print(f"{len(results)} runs, {len(results) - n_bad} PASS; table {escape(str(md))}, "
              f"{escape(str(md.with_name('results.csv')))}")
    return 1 if n_bad else 0


def _cmd_sweep(args: argparse.Namespace) -> int:
    from hil_bench.sweep.cli import main as sweep_main

    if args.out:   # never the sweep file itself (nor a link to it), whatever the folder holds
        from hil_bench.record.atomic import refuse_output_is_input

        refuse_output_is_input([Path(args.out)], [("sweep file", Path(args.sweep))])
    return sweep_main(args)


def _claim_ids(text: str) -> list[str] | None:
    """``--only G2,g3`` -> ["G2", "G3"]; an unknown id is a BenchError with "did you mean"."""
    from hil_bench.claims.registry import CLAIMS
    from hil_bench.errors import ArgumentError, did_you_mean

    if not text:
        return None
    ids = [c.strip().upper() for c in text.split(",") if c.strip()]
    bad = [cid for cid in ids if cid not in CLAIMS]
    if bad:
        raise ArgumentError(f"--only {text}: unknown claim(s) {', '.join(bad)}"
                            f"{did_you_mean(bad[0], CLAIMS)} (claims: {', '.join(CLAIMS)}; "
                            f"`bench claims` lists them)")
    return ids or None


#: ``bench claims --run``'s report folder without ``--out`` (another one beside it while a claims
#: run writes it: sweep.folder.claim_folder)
CLAIMS_DEFAULT_OUT = Path("reports/claims")


def _claims_out_checked(out: Path) -> None:
    """The report folder is not one of the claims' own inputs (the registry, the scenarios)."""
    from hil_bench.claims import registry
    from hil_bench.record.atomic import refuse_output_is_input
    from hil_bench.scenario import SCENARIO_DIR

    reg_dir = Path(registry.__file__).resolve().parent
    inputs = [("claims registry folder", reg_dir), ("bundled scenarios folder", SCENARIO_DIR)]
    inputs += [("claims registry file", p) for p in reg_dir.glob("*.toml")]
    inputs += [("bundled scenario", p) for p in SCENARIO_DIR.glob("*.toml")]
    refuse_output_is_input([out, out / "report.md", out / "report.html", out / "recordings"],
                           inputs)


def _cmd_claims(args: argparse.Namespace) -> int:
    only = _claim_ids(args.only)
    args.out_given = args.out
    if args.out is None:
        args.out = CLAIMS_DEFAULT_OUT
    if args.run:   # the runs go to a Dask cluster; the report of the stub's runs has plots
        from hil_bench.installation import require_extra

        require_extra("bench claims --run", "distributed",
                      *(("matplotlib",) if args.link == "stub" else ()))
        _claims_out_checked(Path(args.out))
    # --no-progress: a console that is not a terminal shows no progress bar (hil_bench.cluster)
    progress_console = console(stderr=True)
    if args.no_progress:
        from rich.console import Console

        progress_console = Console(stderr=True, force_terminal=False, force_interactive=False,
                                   width=progress_console.width, soft_wrap=True)

    lock = None
    if args.run:   # one claims run per folder: a second one beside it takes a folder of its own
        from hil_bench.sweep.folder import FolderBusy, claim_folder

        try:
            args.out, lock, note = claim_folder(args.out_given, Path(args.out), "bench claims")
        except (FolderBusy, OSError) as exc:
            console(stderr=True).print(f"[red]error:[/red] {escape(str(exc))}")
            return 2
        if note:
            progress_console.print(escape(note))
    try:
        return _claims_run_or_list(args, only, progress_console)
    finally:
        if lock is not None:
            lock.__exit__()


def _claims_run_or_list(args: argparse.Namespace, only, progress_console) -> int:
    from hil_bench.claims.model import METRIC_DEFINITIONS
    from hil_bench.claims.registry import CLAIMS

    if args.run and args.link != "stub":
        from hil_bench.papers.rungs import run_rungs

        try:
            rg = run_rungs(args.out, args.link, only=only, jobs=args.jobs, reuse=args.reuse,
                           scheduler=args.scheduler, console=progress_console)
        except ValueError as exc:
            console(stderr=True).print(f"[red]error:[/red] {escape(str(exc))}")
            return 2
        out = console()
        for a, b in rg.pairs():
            same = b is not None and a.verdict == b.verdict
            out.print(escape(f"{a.claim:3s} {a.key:24s} stub {a.verdict:17s} {args.link} "
                             f"{b.verdict if b else 'missing':17s}{'' if same else '  DIFFERS'}"))
        out.print(f"report: {rg.out_dir / 'rungs.md'}")
        return 0
    if args.run:
        from hil_bench.papers.report import run_report

        try:
            import shlex
            rep = run_report(args.out, only=only, jobs=args.jobs,
                             beyond=False if args.no_beyond else (args.beyond or not only),
                             reuse=args.reuse, beyond_quick=args.quick, scheduler=args.scheduler,
                             residual=not args.no_residual, bandwidth=not args.no_bandwidth,
                             command=".venv/bin/bench " + shlex.join(args.argv),
                             console=progress_console)
        except ValueError as exc:
            console(stderr=True).print(f"[red]error:[/red] {escape(str(exc))}")
            return 2
        from hil_bench.papers.report import summary_row
        out = console()
        for c in rep.claims:
            verdict, _assumption, _paper, _measured, reason = summary_row(
                rep, c, [r for r in rep.rows if r.claim == c.id])
            out.print(escape(f"{c.id:3s} {verdict:17s} {reason}"))
        if rep.residual:
            from hil_bench.papers.residual import summary
            out.print("inverter-compensation residual: " + ", ".join(
                f"{cid} holds up to " + ("none" if r is None else f"{100 * r:g} %")
                for cid, r in summary(rep.residual).items()))
        if rep.bandwidth:
            from hil_bench.papers.bandwidth import summary as bandwidth_summary
            for key, text in bandwidth_summary(rep.bandwidth).items():
                out.print(escape(f"bandwidth {key}: {text}"))
        out.print(escape(f"report: {rep.out_dir / 'report.md'}, {rep.out_dir / 'report.html'} "
                         f"({rep.wall_s:.0f} s)"))
        return 0
    for c in CLAIMS.values():
        if only and c.id not in only:
            continue
        print(f"{c.id}  {c.paper}: {c.text}")
        for q in c.quantities:
            unit = q.unit
            definition = (METRIC_DEFINITIONS[q.metric][1] if q.metric in METRIC_DEFINITIONS
                          else q.metric)
            tag = " [diagnostic]" if q.diagnostic else ""
            print(f"      {q.key}{tag}: paper {q.paper_value} {unit}; rule {q.rule_text()} "
                  f"({q.rule.source}); {definition}")
        for r in c.relations:
            print(f"      relation {r.key}: {r.what} ({r.paper}; {r.source})")
        runs = ", ".join(r.name for r in c.runs) or "-"
        print(f"      runs: {runs}" + (f"; studies: {', '.join(c.studies)}" if c.studies else ""))
    return 0


def _override(text: str) -> tuple[str, object]:
    """``KEY=VALUE`` of ``bench run --set``: VALUE as a TOML value, else as a plain string."""
    import tomllib

    key, eq, value = text.partition("=")
    key = key.strip()
    if not eq or not key or any(not part.strip() for part in key.split(".")):
        raise argparse.ArgumentTypeError(f"{text!r}: use KEY=VALUE with a dotted scenario key, "
                                         f"e.g. plant.inverter_nonlinear=true")
    try:
        return key, tomllib.loads(f"v = {value.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        return key, value.strip()


def _version() -> str:
    """pip's form: version, where it runs from, the Python; and whether the C parts are there."""
    import platform

    from hil_bench.installation import checkout_root, missing_modules, version

    where = Path(__file__).resolve().parent
    built = "C parts missing: " + ", ".join(missing_modules()) if missing_modules() else "C built"
    origin = f"checkout {checkout_root()}" if checkout_root() else str(where)
    return (f"bench (hil-bench) {version()} from {origin} (python "
            f"{platform.python_version()}; {built})")


class _VersionAction(argparse.Action):
    """``--version``: the text is made only when asked for (it looks for the compiled parts)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help=None):  # noqa: A002 - argparse's keyword
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(_version())
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="bench", description="HIL bench for sensorless PMSM firmware")
    p.add_argument("--version", action=_VersionAction, help="show the version, where hil-bench "
                   "runs from and whether its C parts are built, then exit")
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("run", help="run a scenario against a controller and record it")
    r.add_argument("scenario", help="scenario file or bundled scenario name")
    r.add_argument("--link", default="stub",
                   help="'stub' (default: the C firmware stub on a new pty), 'sil' (the "
                        "firmware's C in this process: software in the loop), "
                        "'stub-slcan' / 'stub-socketcand' (the stub behind python-can's slcan or "
                        "socketcand interface), 'serial:<port-or-url>[@baud]' or "
                        "'can:<interface>:<channel>[@bitrate][,fd]' for a real drive")
    r.add_argument("--out", type=Path, default=None, help="recording path (.mcap)")
    r.add_argument("--set", metavar="KEY=VALUE", type=_override, action="append", default=[],
                   help="override a scenario value by its dotted key (as campaigns do), e.g. "
                        "--set plant.inverter_nonlinear=true --set controller.params.SMO_K_V=30 "
                        "--set controller.estimator=SMO_TANH; VALUE is read as TOML (a number, "
                        "true/false, [array], \"string\"), else as a plain string; repeatable")
    r.add_argument("--force", action="store_true",
                   help="replace an existing --out file and the run's side files beside it "
                        "(<out>.serial.bin, <out>.log)")
    r.add_argument("--realtime", action="store_true",
                   help="pace the plant by the wall clock (as [scenario] mode = \"realtime\")")
    r.add_argument("--cpu", type=int, default=None,
                   help="real time: pin the engine thread to this CPU")
    r.add_argument("--live", type=int, nargs="?", const=8765, default=None, metavar="PORT",
                   help="serve the recording's channels live over the Foxglove WebSocket "
                        "protocol on PORT (default 8765; 0: any free port) of 127.0.0.1 "
                        "(--live-host: another address) while the "
                        "run goes on (docs/foxglove.md)")
    r.add_argument("--live-rate", type=float, default=50.0, metavar="HZ",
                   help="--live: messages per second per per-cycle channel sent to a viewer "
                        "(default 50; /events, /faults, /link/stats go out whole)")
    add_live_hand_options(r, "run")
    r.add_argument("--pace", type=float, default=None, metavar="FACTOR",
                   help="lockstep: wall seconds per second of plant time (1.0: real time, to "
                        "watch with --live; 2: half speed); default: as fast as the link goes")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--allow-slow-link", action="store_true",
                   help="lockstep only: run even if the link cannot carry the control rate in "
                        "real time (the run is then slower than real time, results unchanged)")
    r.add_argument("--strict", action="store_true",
                   help="exit 1 if any paper claim does not reproduce")
    r.set_defaults(func=_cmd_run)

    lay = sub.add_parser("layout", help="write a Foxglove / Lichtblick layout for a scenario's "
                                        "recording or live view")
    lay.add_argument("scenario", help="scenario file or bundled scenario name")
    lay.add_argument("-o", "--out", type=Path, default=None,
                     help="layout file (.json); default: print it")
    lay.add_argument("--force", action="store_true", help="replace an existing --out file")
    lay.set_defaults(func=_cmd_layout)

    c = sub.add_parser("check", help="recompute metrics and paper claims from a recording")
    c.add_argument("recording", type=Path)
    c.add_argument("--strict", action="store_true",
                   help="exit 1 if any paper claim does not reproduce")
    c.add_argument("--json", action="store_true",
                   help="print the check as JSON (hil_bench.Result.as_dict: scenario, recording, "
                        "controller, integrity, metrics, claims, faults, passed) instead of tables")
    c.set_defaults(func=_cmd_check)

    v = sub.add_parser("recover", help="copy every intact chunk of a damaged recording into a new file")
    v.add_argument("recording", type=Path)
    v.add_argument("-o", "--out", type=Path, default=None,
                   help="output (default: <recording>.recovered.mcap beside it); an existing "
                        "file is refused unless --force")
    v.add_argument("--force", action="store_true", help="replace an existing output file")
    v.set_defaults(func=_cmd_recover)

    x = sub.add_parser("export", help="write a recording's channels as Parquet or CSV tables "
                                      "(t_s first, units in the metadata)")
    x.add_argument("recording", type=Path)
    x.add_argument("--format", choices=("parquet", "csv"), default="parquet",
                   help="parquet (default: units in each column's metadata) or csv (units in a "
                        "sidecar <file>.json)")
    x.add_argument("--channels", action="append", default=[], metavar="TOPIC[,TOPIC...]",
                   help="the channels to export (default: all), e.g. /plant/state,/link/frames; "
                        "/reference/* for every reference estimator; repeatable")
    x.add_argument("--out", type=Path, required=True,
                   help="a folder (one file per channel, named after the topic: "
                        "plant_state.parquet, ...), or a .parquet / .csv file for one channel")
    x.add_argument("--force", action="store_true", help="replace existing output files")
    x.set_defaults(func=_cmd_export)

    f = sub.add_parser("conformance", help="check a controller against docs/protocol.md (scripted session)")
    f.add_argument("--link", default="stub", help="as for `bench run` (default: the C firmware stub)")
    f.add_argument("--cycles", type=int, default=300, help="control cycles to run (default 300)")
    f.add_argument("--estimator", default="SMO_SIGN", help="estimator to ask for (default SMO_SIGN)")
    f.set_defaults(func=_cmd_conformance)

    g = sub.add_parser("campaign", help="run a fault campaign: one run per fault, a table of "
                                        "detection and reaction against the file's limits")
    g.add_argument("campaign", help="a bundled campaign's name (g2_protection) or a campaign "
                                    "TOML file")
    g.add_argument("--out", help="report folder (default reports/campaigns/<name>, or a new "
                                 "<name>-<time>-<pid> beside it while another campaign writes it)")
    g.add_argument("--jobs", type=positive_int, default=None,
                   help="local Dask cluster: worker processes (default: one per core)")
    g.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="run on an existing Dask scheduler instead (docs/sweeps.md)")
    g.add_argument("--link", default=None, help="link of every run (default: the file's, or stub)")
    g.add_argument("--keep-all", action="store_true",
                   help="keep every run's recording (default: only the runs that did not PASS)")
    g.add_argument("--no-progress", action="store_true", help="no progress bar")
    g.set_defaults(func=_cmd_campaign)
    w = sub.add_parser("sweep", help="run a base scenario over axes of its keys on a Dask cluster "
                                     "(local by default): one Parquet table, plots")
    from hil_bench.sweep.cli import add_arguments as add_sweep_arguments

    add_sweep_arguments(w)
    w.set_defaults(func=_cmd_sweep)
    s = sub.add_parser("scenarios", help="list the bundled scenarios")
    s.set_defaults(func=_cmd_scenarios)
    k = sub.add_parser("claims", help="list the paper claims; --run: reproduce them all and "
                                      "write a report with plots")
    k.add_argument("--run", action="store_true",
                   help="run every claim's scenarios (in parallel) and write report.md/.html")
    k.add_argument("--only", default="",
                   help="comma-separated claim ids (default: all 19): only their runs (and "
                        "their residual and bandwidth studies), no study beyond the papers "
                        "unless --beyond")
    k.add_argument("--link", default="stub",
                   help="with --run: run the claims' scenarios against this controller too "
                        "(pil-qemu, serial:..., can:...) and set each verdict beside the host "
                        "stub's in <out>/rungs.md (one run at a time on a single device)")
    k.add_argument("--out", type=Path, default=None,
                   help="report folder (default reports/claims, or a new reports/claims-<time>-"
                        "<pid> beside it while another claims run writes it)")
    k.add_argument("--jobs", type=positive_int, default=None,
                   help="local Dask cluster: worker processes (default: the number of cores, "
                        "at most 4)")
    k.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="run on an existing Dask scheduler instead (docs/sweeps.md)")
    studies = k.add_mutually_exclusive_group()
    studies.add_argument("--beyond", action="store_true",
                         help="also run the studies beyond the papers with --only (without "
                              "--only they run by default)")
    studies.add_argument("--no-beyond", action="store_true",
                         help="skip the studies beyond the papers (error vs speed, initial "
                              "position over 360 deg, parameter sensitivity, speed reversal); "
                              "with --only they are skipped unless --beyond")
    k.add_argument("--quick", action="store_true",
                   help="the studies beyond the papers and the bandwidth sweeps on a coarse grid "
                        "(fewer runs)")
    k.add_argument("--no-residual", action="store_true",
                   help="skip the inverter-compensation residual study of Y1, Y2, Y8, H1, H2, H3 "
                        "(each claim's runs at residuals 0 .. 100 %%, docs/inverter_comp.md)")
    k.add_argument("--no-bandwidth", action="store_true",
                   help="skip the estimator-bandwidth sweeps of Y1, Y2, Y8, H1, H2 (each chosen "
                        "PLL / HFI tracking bandwidth / SMO EMF cut-off at 0.25 .. 4 x; --quick: "
                        "0.5 .. 2 x; bench/papers/bandwidth.py)")
    k.add_argument("--reuse", action="store_true",
                   help="reuse recordings already in <out>/recordings (development)")
    k.add_argument("--no-progress", action="store_true", help="no progress bar")
    k.set_defaults(func=_cmd_claims)

    try:
        from hil_bench.replay.cli import add_parser as add_replay_parser
    except ImportError as exc:   # its options come from the C engine: --help/--version still work
        from hil_bench.installation import is_native_import_error

        if not is_native_import_error(exc):
            raise
        q = sub.add_parser("replay", help="rerun a logged capture (needs the compiled C)")
        q.set_defaults(func=_native_missing(exc))
    else:
        add_replay_parser(sub)
    return p


def _native_missing_exit(exc: ImportError) -> int:
    from hil_bench.installation import how_to_build

    console(stderr=True).print(f"[red]error:[/red] hil-bench's compiled C is missing "
                               f"({exc.name or exc}): {how_to_build()}", highlight=False)
    return 2


def _native_missing(exc: ImportError):
    def fail(args: argparse.Namespace) -> int:
        raise exc
    return fail


def main(argv: list[str] | None = None) -> int:
    import signal

    try:
        # (the parser itself may need the compiled C: the live view's options, replay's modes)
        parser = build_parser()
    except ImportError as exc:
        from hil_bench.installation import is_native_import_error

        if not is_native_import_error(exc):
            raise
        return _native_missing_exit(exc)
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)   # the exact command (reports)
    try:
        rc = args.func(args)
    except KeyboardInterrupt:
        # a run's recording is finalised by the runner whatever is pressed (DeferredInterrupts);
        # anywhere else a Ctrl-C ends the command, without a traceback
        console(stderr=True).print("interrupted by the user")
        rc = 130
    except BenchError as exc:
        # every error the bench raises on purpose is one line (a command that did not catch its
        # own: never a traceback)
        if isinstance(exc, ImportError):
            from hil_bench.installation import is_native_import_error

            if is_native_import_error(exc):
                return _native_missing_exit(exc)
        console(stderr=True).print(f"[red]error:[/red] {escape(str(exc))}")
        rc = 2
    except ImportError as exc:
        from hil_bench.installation import is_native_import_error

        if not is_native_import_error(exc):
            raise
        return _native_missing_exit(exc)
    if rc == 130:
        # the command ends because the user interrupted it: a further Ctrl-C (the user pressing
        # again) must not turn the exit into a KeyboardInterrupt at interpreter shutdown
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    return rc


if __name__ == "__main__":
    sys.exit(main())
