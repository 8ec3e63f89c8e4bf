"""The three replays, each a run of the C cycle engine (plant_rt/c/engine.h "Replay") that writes
a new recording with the topics of a live run (docs/replay.md "Modes"):

* ``offline``    the reference estimators on the capture's samples and voltage commands
                 (``replay_estimators``); metrics against the capture's angle where it has one;
* ``controller`` the capture's uplink frames (CMD, SENSE_AUX, [SENSE_DUAL], SENSE) to a live
                 controller in lockstep (``replay_controller``) after the handshake and CONFIG with
                 the capture's controller parameters; its DUTY and TELEM against the recorded;
* ``plant``      the capture's duties drive the plant open loop (``replay_plant``); its sampled
                 currents against the recorded.

As fast as possible by default; ``rate`` paces each cycle at its recorded time / rate from
absolute deadlines (``pace_s`` = Ts / rate of wall time per recorded period, so a gap in the
capture is a pause of its recorded length), and the pacing error's p99 is reported.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from hil_bench.errors import BenchError
from hil_bench.plant_rt import engine as eng
from hil_bench.protocol.messages import MESSAGES, Command, Estimator, Param
from hil_bench.record import channels as ch
from hil_bench.record.recorder import ProcessRecorder, RecorderError, recording_stamp

from .capture import TELEM_FIELDS, Capture, CaptureError

MODES = ("offline", "controller", "plant")
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)
#: the engine records nothing on this channel index (ENGINE_NO_CHANNEL, plant_rt/c/engine.h)
NO_CHANNEL = 0xFFFF
WATCH_PERIOD_S = 0.1
_CMD = MESSAGES["CMD"]


class ReplayError(BenchError, RuntimeError):
    """The replay cannot run (the message says why and what to give)."""


@dataclass
class ReplayOptions:
    mode: str = "offline"
    out: Path | None = None
    force: bool = False
    estimators: list[str] | None = None          # NAME or NAME:label
    est_config: dict[str, dict[str, float]] = field(default_factory=dict)
    profile: str | None = None
    rate: float | None = None                    # None: as fast as possible
    link: str = "stub"
    set_params: dict[Param, float] = field(default_factory=dict)
    window_s: tuple[float, float] | None = None
    progress: bool = False
    stub_args: tuple[str, ...] = ()
    #: --live: a hil_bench.record.live_view.LiveOptions (the replay's recording served to
    #: Foxglove while it is written; operator inputs refused); on_live(port) once it listens
    live: object | None = None
    on_live: object | None = None
    #: the recording's name, taken by run_replay (hil_bench.record.recorder.reserve_recording)
    reservation: object | None = None


@dataclass
class ReplayResult:
    capture: Capture
    mode: str
    out: Path
    cycles: int = 0
    end: str = ""
    message: str = ""
    error: str | None = None
    wall_s: float = 0.0
    pacing: dict = field(default_factory=dict)
    metrics: dict[str, dict[str, float]] = field(default_factory=dict)
    compare: dict = field(default_factory=dict)
    window_s: tuple[float, float] = (0.0, 0.0)
    notes: list[str] = field(default_factory=list)
    live_stats: dict | None = None     # --live: the viewer's end-of-run figures

    @property
    def ok(self) -> bool:
        return self.error is None


# -- what the replay needs besides the capture -------------------------------------------------

def resolve_profile(cap: Capture, name: str | None):
    """--profile, else the profile attached to a bench recording."""
    from hil_bench.plant_rt.profile import ProfileError, load_profile, parse_profile

    try:
        if name:
            return load_profile(name)
    except ProfileError as exc:
        raise ReplayError(str(exc)) from None
    rec = cap.recording
    if rec is not None:
        found = rec.attachment_text("profile/")
        if found is not None:
            import tomllib

            att, text = found
            try:
                return parse_profile(tomllib.loads(text), Path(f"{cap.path}#{att}"))
            except (ProfileError, tomllib.TOMLDecodeError) as exc:
                raise ReplayError(f"{cap.path}: attached profile is invalid: {exc}") from None
        try:
            return load_profile(rec.run.get("profile", ""))
        except ProfileError:
            pass
    raise ReplayError(f"{cap.path}: a {cap.kind} capture does not say which motor it ran: give "
                      f"--profile NAME (plant_rt/profiles: gong2020, hou2021, yuan2020) or a path")


def plant_overrides(cap: Capture, profile) -> dict:
    """The plant parameters of the capture: a recording's own; else the profile's with the
    capture's period and (if captured) the delay the controller was told."""
    from hil_bench.plant_rt.profile import PARAM_FIELDS

    if cap.plant_params:
        return {k: v for k, v in cap.plant_params.items() if k in PARAM_FIELDS}
    out = {"ts_s": cap.ts_s}
    if Param.CTRL_DELAY_S in cap.config:
        out["t_delay_s"] = t_delay_of(cap, profile)
    if Param.V_DC_NOM_V in cap.config:
        out["v_dc_v"] = float(cap.config[Param.V_DC_NOM_V])
    return out


def t_delay_of(cap: Capture, profile) -> float:
    if cap.plant_params and "t_delay_s" in cap.plant_params:
        return float(cap.plant_params["t_delay_s"])
    if Param.CTRL_DELAY_S in cap.config:
        told = float(cap.config[Param.CTRL_DELAY_S])
        # CONFIG carries binary32: the profile's value when the two agree to that precision
        if abs(told - profile.t_delay_s) <= 1e-6 * abs(profile.t_delay_s):
            return float(profile.t_delay_s)
        return told
    return float(profile.t_delay_s)


#: CONFIG parameter -> reference estimator setting, for the estimator the captured controller ran:
#: what the firmware's controller does with each (firmware_stub/src/controller.c, the estimator
#: set-up); PLL gains only when set (> 0: the controller's own default otherwise)
CONFIG_TO_REFERENCE: dict[str, dict[Param, str]] = {
    "SMO_SIGN": {Param.SMO_K_V: "k_v", Param.SMO_K_FACTOR: "k_factor",
                 Param.SMO_K_MIN_V: "k_min_v", Param.SMO_WC_RAD_S: "wc_rad_s",
                 Param.SPEED_LPF_RAD_S: "speed_lpf_rad_s", Param.PLL_KP: "pll_kp",
                 Param.PLL_KI: "pll_ki"},
    "SMO_SIGMOID": {Param.SMO_K_V: "k_v", Param.SMO_SIGMOID_A_PER_A: "a_per_a",
                    Param.SMO_WC_RAD_S: "wc_rad_s", Param.SMO_LAG_COMP: "lag_comp",
                    Param.SPEED_LPF_RAD_S: "speed_lpf_rad_s", Param.PLL_KP: "pll_kp",
                    Param.PLL_KI: "pll_ki"},
    "SMO_TANH": {Param.SMO_K_V: "k_v", Param.SMO_M_PER_A: "m_per_a",
                 Param.SPEED_LPF_RAD_S: "speed_lpf_rad_s", Param.PLL_KP: "pll_kp",
                 Param.PLL_KI: "pll_ki"},
}
_INT_SETTINGS = {"lag_comp"}


def captured_estimator(cap: Capture) -> str | None:
    """The estimator the captured controller ran (HELLO), if the capture says."""
    if cap.hello is None:
        return None
    try:
        return Estimator(int(cap.hello["estimator"])).name
    except ValueError:
        return None


def reference_list(cap: Capture, opts: ReplayOptions,
                   notes: list[str] | None = None) -> dict[str, dict[str, float]]:
    """Estimator entry -> configuration: --estimators (+ --est-config), else the recording's.

    An entry of the estimator the captured controller ran (HELLO) takes the settings --est-config
    does not give from the capture's CONFIG frames (the values that controller was told, see
    CONFIG_TO_REFERENCE): it then runs as the controller did. Every other setting is the
    estimator's own default for the profile. ``notes`` gets a line per entry saying which."""
    if opts.estimators:
        out = {e: dict(opts.est_config.get(e, {})) for e in opts.estimators}
        for key in opts.est_config:
            if key not in out:
                raise ReplayError(f"--est-config {key}: {key!r} is not in --estimators "
                                  f"({', '.join(out)})")
        ran = captured_estimator(cap)
        for entry, cfg in out.items():
            name = entry.partition(":")[0]
            given = sorted(cfg)
            taken = []
            if name == ran:
                for param, key in CONFIG_TO_REFERENCE.get(name, {}).items():
                    if key in cfg or param not in cap.config:
                        continue
                    v = float(cap.config[param])
                    if param in (Param.PLL_KP, Param.PLL_KI) and not v > 0:
                        continue
                    cfg[key] = int(round(v)) if key in _INT_SETTINGS else v
                    taken.append(f"{key} = {v:.7g}")
            if notes is not None:
                parts = []
                if given:
                    parts.append("--est-config " + ", ".join(f"{k} = {cfg[k]:g}" for k in given))
                if taken:
                    parts.append("the capture's CONFIG: " + ", ".join(taken))
                if parts:
                    parts.append("the rest: its defaults for the profile")
                else:
                    why = ("the capture names no estimator" if ran is None else
                           f"the captured controller ran {ran}" if ran != name else
                           "the capture has no CONFIG for it")
                    parts.append(f"its defaults for the profile ({why}; no --est-config)")
                notes.append(f"{entry}: " + "; ".join(parts))
        return out
    if cap.recording is not None:
        try:
            out = {k: dict(v) for k, v in json.loads(
                cap.recording.run.get("reference_estimators", "{}")).items()}
        except ValueError:
            return {}
        if notes is not None and out:
            notes.append("estimators: the recording's own [reference], with its settings: "
                         + "; ".join(f"{e} ({', '.join(f'{k} = {v:g}' for k, v in c.items()) or 'defaults'})"
                                     for e, c in out.items()))
        return out
    return {}


def make_estimators(entries: dict[str, dict[str, float]], profile, ts_s: float):
    from hil_bench.firmware_stub.estimators import REFERENCE_ESTIMATORS

    out = []
    for entry, config in entries.items():
        name = entry.partition(":")[0]
        factory = REFERENCE_ESTIMATORS.get(name)
        if factory is None:
            raise ReplayError(f"--estimators: unknown estimator {name!r}; available: "
                              f"{', '.join(REFERENCE_ESTIMATORS)} (optionally NAME:label)")
        try:
            est = factory(profile, ts_s, **config)
        except (ValueError, TypeError) as exc:
            raise ReplayError(f"--est-config {entry}: {exc}") from None
        out.append((entry, int(Estimator[name]), est))
    return out


def default_out(cap: Capture, mode: str) -> Path:
    """recordings/<capture>-replay-<mode>-<date>-<time>-<ms>-<pid>.mcap (a name that is taken
    anyway becomes the next free one: run_replay)."""
    stem = re.sub(r"[^A-Za-z0-9_+-]+", "_", cap.path.name.split(".")[0]).strip("_") or "capture"
    return Path("recordings") / f"{stem}-replay-{mode}-{recording_stamp()}.mcap"


# -- what a capture without a recording's metadata still needs for `bench check` -------------

def scenario_text(cap: Capture, profile, mode: str, refs: dict[str, dict[str, float]],
                  window: tuple[float, float]) -> tuple[str, str]:
    """(attachment name, TOML) of the scenario: the recording's own, or one that says what is
    known of the capture (bench check reads its metrics window and speed reference)."""
    rec = cap.recording
    if rec is not None:
        found = rec.attachment_text("scenario/")
        if found is not None:
            return found
    duration = max(float(cap.rows["t_s"][-1]) + cap.ts_s, cap.ts_s)
    speed_cmds = [v for (_k, c, v) in cap.commands if c == int(Command.SET_SPEED_REF)]
    est = "NONE"
    if cap.hello is not None:
        try:
            est = Estimator(cap.hello["estimator"]).name
        except ValueError:
            pass
    lines = [
        f"# written by bench replay: what is known of {cap.path.name} ({cap.kind} capture)",
        "[scenario]",
        f'name = "replay-{re.sub(r"[^A-Za-z0-9_+-]+", "_", cap.path.name)}"',
        f'description = "{cap.kind} capture {cap.path.name} replayed ({mode})"',
        f'profile = "{profile.name}"',
        f"duration_s = {duration!r}",
        "claims = []",
        "[plant]",
        f"ts_s = {cap.ts_s!r}",
        "[controller]",
        f'estimator = "{est if est in Estimator.__members__ else "NONE"}"',
        f"speed_ref_rpm = {(speed_cmds[0] if speed_cmds else 0.0) * RPM_PER_RAD_S!r}",
        "[reference]",
        "estimators = [" + ", ".join(f'"{e}"' for e in refs) + "]",
    ]
    for e, cfg in refs.items():
        if cfg:
            lines.append(f'[reference."{e}"]')
            lines.extend(f"{k} = {float(v)!r}" for k, v in cfg.items())
    lines += ["[metrics]", f"window_s = [{window[0]!r}, {min(window[1], duration)!r}]"]
    return f"scenario/replay-{cap.path.stem}.toml", "\n".join(lines) + "\n"


def derived_state(cap: Capture, pole_pairs: int) -> dict[str, np.ndarray] | None:
    """/plant/state of a capture that has an encoder angle but no plant truth: the angle, the
    speed from its unwrapped derivative (central difference), the measured currents in alpha-beta
    and d-q (Park with the encoder angle), the bus voltage and the voltage the duties applied.
    Torque, load and EMF are unknown (NaN). The recorded truth of a bench recording is used as
    it is."""
    if cap.state is not None:
        return cap.state
    r = cap.rows
    n = cap.n
    nan = np.full(n, np.nan)
    out = {name: nan.copy() for name in ch.PLANT_STATE_VALUES}
    out["t_s"] = r["t_s"].astype(float)
    i = r["i_abc_a"]
    out["i_a_a"], out["i_b_a"], out["i_c_a"] = i[:, 0], i[:, 1], i[:, 2]
    ial = (2 * i[:, 0] - i[:, 1] - i[:, 2]) / 3.0
    ibe = (i[:, 1] - i[:, 2]) / math.sqrt(3.0)
    out["i_alpha_a"], out["i_beta_a"] = ial, ibe
    out["v_dc_v"] = r["v_dc_v"].astype(float)
    if not cap.has_theta:
        return out
    th = np.where(r["has_theta"] == 1, r["theta_rad"], np.nan)
    out["theta_e_rad"] = th
    c, s = np.cos(th), np.sin(th)
    out["i_d_a"] = c * ial + s * ibe
    out["i_q_a"] = -s * ial + c * ibe
    good = np.isfinite(th)
    if good.sum() >= 3:
        t = out["t_s"]
        un = np.full(n, np.nan)
        un[good] = np.unwrap(th[good])
        w = np.full(n, np.nan)
        w[good] = np.gradient(un[good], t[good])
        out["omega_e_rad_s"] = w
        out["omega_m_rad_s"] = w / pole_pairs
        out["speed_rpm"] = out["omega_m_rad_s"] * RPM_PER_RAD_S
        out["theta_m_rad"] = np.mod(un / pole_pairs, 2 * math.pi)
    return out


# -- running ------------------------------------------------------------------------------------

def _pace(cap: Capture, rate: float | None) -> float:
    if rate is None:
        return 0.0
    if not rate > 0:
        raise ReplayError(f"--rate {rate!r}: must be > 0 (1.0 = the recorded rate)")
    return cap.ts_s / rate


def check_window(window, option: str = "--window", shown: str | None = None) -> tuple[float, float]:
    """(t0, t1) of a metrics window [s]: two finite times, t0 < t1; else ReplayError saying so
    (``shown``: the window as the user wrote it)."""
    try:
        w0, w1 = (float(v) for v in window)
    except (TypeError, ValueError):
        raise ReplayError(f"{option} {shown if shown is not None else window!r}: two times in "
                          f"seconds, T0,T1 (e.g. 1.0,2.0)") from None
    if not (math.isfinite(w0) and math.isfinite(w1)):
        raise ReplayError(f"{option} {w0:g},{w1:g}: the times must be finite numbers of seconds")
    if not w0 < w1:
        raise ReplayError(f"{option} {w0:g},{w1:g}: T0 must come before T1 (T0,T1 in seconds)")
    if w0 < 0:
        raise ReplayError(f"{option} {w0:g},{w1:g}: T0 must be >= 0 s")
    return w0, w1


def _window(cap: Capture, opts: ReplayOptions) -> tuple[float, float]:
    t = cap.rows["t_s"]
    if opts.window_s is not None:
        w0, w1 = check_window(opts.window_s)
        if len(t) and (w1 <= float(t[0]) or w0 >= float(t[-1])):
            raise ReplayError(f"--window {w0:g},{w1:g}: outside the capture, which covers "
                              f"{float(t[0]):g} .. {float(t[-1]):g} s")
        return w0, w1
    if cap.recording is not None:
        try:
            w = json.loads(cap.recording.run.get("metrics_window_s", ""))
            return float(w[0]), float(w[1])
        except (ValueError, IndexError, TypeError):
            pass
    return float(t[0] + 0.5 * (t[-1] - t[0])), float(t[-1])


#: why a viewer's operator input is refused in a replay (its /events row)
REPLAY_REFUSES = ("a replay plays the capture's own inputs (bench run --live takes operator "
                  "inputs where the scenario says [live] inputs = true)")


def replay_live(opts: ReplayOptions, pace_s: float):
    """The live view's options for a replay (None without --live): no operator input is taken,
    and the recorder keeps its background priority unless the replay is paced (--rate), as a run
    paced for watching does."""
    import dataclasses

    if opts.live is None:
        return None
    return dataclasses.replace(opts.live, inputs=False, refused_why=REPLAY_REFUSES,
                               background=not pace_s > 0)


class _Out:
    """The new recording: channels, metadata, the rows Python writes; with ``live`` (see
    :func:`replay_live`) served to Foxglove while it is written."""

    def __init__(self, cap: Capture, mode: str, path: Path, force: bool, refs, extra_kind=None,
                 live=None, on_live=None, reservation=None):
        self.inbox = None
        if live is not None:
            from hil_bench.loop.runner import new_live_inbox

            self.inbox = new_live_inbox()   # the viewer's inputs: refused, each on /events
        self.rec = ProcessRecorder(path, force=force, live=live, live_inbox=self.inbox,
                                   reservation=reservation)
        if self.rec.live_port is not None and on_live is not None:
            on_live(self.rec.live_port)
        r = self.rec
        self.state = r.channel(ch.PLANT_STATE)
        self.sense = r.channel(ch.PLANT_SENSE)
        self.telem = r.channel(ch.CONTROLLER_TELEMETRY)
        self.frames = r.channel(ch.LINK_FRAMES)
        self.stats = r.channel(ch.LINK_STATS)
        self.events = r.channel(ch.EVENTS)
        self.timing = r.channel(ch.TIMING)
        self.refs = [r.channel(ch.REFERENCE_PREFIX + name, "REFERENCE") for name, _, _ in refs]
        self.replay = r.channel(extra_kind) if extra_kind else None

    def channels(self, **pad) -> dict[str, int]:
        out = {"ch_state": self.state.index, "ch_sense": self.sense.index,
               "ch_telem": self.telem.index, "ch_frames": self.frames.index,
               "ch_events": self.events.index, "ch_timing": self.timing.index,
               "ch_stats": self.stats.index}
        if self.replay is not None:
            out["ch_replay"] = self.replay.index
        out.update(pad)
        return out

    def event(self, t_s: float, kind: str, text: str, value: float = 0.0) -> None:
        self.events.write_values(t_s, (t_s, kind, text, value))

    def attach(self, e: eng.Engine) -> eng.Engine:
        """The engine takes the viewer's inputs (to refuse them at the row they arrive)."""
        if self.inbox is not None:
            e.attach_inbox(self.inbox)
        return e


def _write_metadata(o: _Out, cap: Capture, mode: str, profile, plant, refs_cfg, window,
                    opts: ReplayOptions) -> None:
    from hil_bench.loop.runner import git_revision

    run = dict(cap.recording.run) if cap.recording is not None else {}
    if plant is None and not cap.plant_params:
        # offline / controller on a frame or CSV capture: the plant the run's figures refer to
        # is the profile's with the capture's period (and delay, bus voltage where captured),
        # written as a live run writes it (bench check reads pole pairs and Ts from it)
        from hil_bench.plant_rt.plant import Plant
        from hil_bench.plant_rt.profile import ProfileError

        try:
            plant = Plant(profile, **plant_overrides(cap, profile))
        except (ProfileError, ValueError) as exc:
            raise ReplayError(f"{cap.path}: the profile's plant with the capture's period: "
                              f"{exc}") from None
    params = plant.params.as_dict() if plant is not None else {}
    run.update({
        "scenario": run.get("scenario", f"replay-{cap.path.name}"),
        "profile": profile.name, "profile_path": str(profile.path),
        "mode": f"replay-{mode}",
        "git_revision": git_revision(),
        "ts_s": repr(cap.ts_s),
        "cycles_planned": str(cap.n),
        "plant_params": json.dumps(cap.plant_params or params),
        "controller_params": json.dumps({p.name: v for p, v in cap.config.items()}),
        "reference_estimators": json.dumps(refs_cfg),
        "metrics_window_s": json.dumps(list(window)),
        "claims": run.get("claims", "[]"),
        "start_utc": datetime.now().astimezone().isoformat(timespec="seconds"),
    })
    if "estimator" not in run and cap.hello is not None:
        try:
            run["estimator"] = Estimator(cap.hello["estimator"]).name
        except ValueError:
            pass
    o.rec.metadata("run", run)
    o.rec.metadata("replay", {
        "source": str(cap.path), "source_kind": cap.kind, "mode": mode,
        "ts_source": cap.ts_source, "cycles": str(cap.n),
        "angle": cap.theta_source or "", "rate": "" if opts.rate is None else repr(opts.rate),
        "anomalies": json.dumps(cap.anomalies.as_dict()),
        "unknown_ids": json.dumps({f"0x{k:03X}": v for k, v in
                                   cap.anomalies.unknown_id_counts.items()}),
        "wrong_length": json.dumps({f"0x{k:03X}": v for k, v in
                                    cap.anomalies.wrong_length_counts.items()}),
        "problems": json.dumps(cap.problems),
        "resampling": json.dumps(cap.resampling or {}),
        "notes": json.dumps(cap.notes),
    })
    name, text = scenario_text(cap, profile, mode, refs_cfg, window)
    o.rec.attachment(name, "application/toml", text.encode())
    try:
        o.rec.attachment(f"profile/{Path(profile.path).name}", "application/toml",
                         Path(profile.path).read_bytes())
    except OSError:
        if cap.recording is not None:
            found = cap.recording.attachment_text("profile/")
            if found:
                o.rec.attachment(found[0], "application/toml", found[1].encode())


def _write_capture_events(o: _Out, cap: Capture) -> None:
    o.event(0.0, "replay", cap.describe(), float(cap.n))
    for kind, v in cap.anomalies.as_dict().items():
        if v:
            o.event(0.0, f"capture_{kind}", f"{v} {kind.replace('_', ' ')} in {cap.path.name}",
                    float(v))
    for kind, t_s, text in cap.anomalies.details:
        o.event(t_s if math.isfinite(t_s) else 0.0, f"capture_{kind}", text, 0.0)
    for p in cap.problems:
        o.event(0.0, "capture_damage", p, 0.0)


def _write_rows(o: _Out, cap: Capture, state: dict | None, *, sense=True, telem=True,
                frames=True) -> None:
    r = cap.rows
    t = r["t_s"]
    if sense:
        th_enc = np.where(r["has_theta"] == 1, r["theta_rad"], np.nan) \
            if cap.kind != "mcap" else np.full(cap.n, np.nan)
        for i in range(cap.n):
            o.sense.write_values(float(t[i]), (t[i], int(r["seq"][i]), *r["i_abc_a"][i],
                                               r["v_dc_v"][i], th_enc[i]))
    if state is not None:
        cols = [state[n] for n in ch.PLANT_STATE_VALUES]
        for i in range(cap.n):
            o.state.write_values(float(t[i]), [c[i] for c in cols])
    if telem:
        te = cap.telem
        pp = getattr(o, "pole_pairs", 1)
        truth = np.where(r["has_theta"] == 1, r["theta_rad"], np.nan)
        pee = (te["theta_hat_rad"] - truth + math.pi) % (2 * math.pi) - math.pi
        for i in range(cap.n):
            w = te["omega_hat_rad_s"][i]
            o.telem.write_values(float(t[i]), (
                t[i], int(r["seq"][i]), te["theta_hat_rad"][i], w, w / pp * RPM_PER_RAD_S,
                int(te["state"][i]), int(te["estimator"][i]), te["e_alpha_v"][i],
                te["e_beta_v"][i], te["i_q_ref_a"][i], te["duty_a"][i], te["duty_b"][i],
                te["duty_c"][i], pee[i]))
    if frames:
        if cap.setup_frames:
            tx = " ".join(f"{f:03X}#{d.hex().upper()}" for dd, f, d in cap.setup_frames
                          if dd == "tx")
            rx = " ".join(f"{f:03X}#{d.hex().upper()}" for dd, f, d in cap.setup_frames
                          if dd == "rx")
            o.frames.write_values(0.0, (0.0, -1, tx, rx))
        if cap.frames_text is not None:
            up, down = cap.frames_text
            for i in range(cap.n):
                o.frames.write_values(float(t[i]), (t[i], int(r["seq"][i]), up[i], down[i]))


def _watch(e: eng.Engine, o: _Out, n: int, progress: bool) -> bool:
    """Run the engine in its thread; Ctrl-C stops it at the end of a cycle. True if interrupted."""
    interrupted = False
    e.start()
    while e.running():
        try:
            e.join(WATCH_PERIOD_S)
        except KeyboardInterrupt:
            e.request_stop()
            e.join()
            interrupted = True
            break
        if not o.rec.alive():
            e.request_stop()
            e.join()
            raise RecorderError(o.rec.death_message())
    return interrupted


def engine_summary(e: eng.Engine, res: ReplayResult, pace_s: float) -> None:
    r = e.result()
    res.cycles = r.cycles_done
    res.end = r.end_name
    res.message = r.message
    if r.end != eng.END_DONE:
        res.error = r.end_text()
    res.pacing = {"cycle_p50_us": e.percentile("cycle", 0.5),
                  "cycle_p99_us": e.percentile("cycle", 0.99)}
    if pace_s > 0:
        res.pacing.update(pace_s=pace_s, start_err_p50_us=e.percentile("jitter", 0.5),
                          start_err_p99_us=e.percentile("jitter", 0.99),
                          start_err_max_us=e.hist_max("jitter"))


def finish(o: _Out, e: eng.Engine | None, res: ReplayResult, extra: dict | None = None) -> None:
    t_end = float(res.capture.rows["t_s"][min(max(res.cycles - 1, 0), res.capture.n - 1)])
    if e is not None:
        e.write_stats(t_end)
    if res.error:
        o.event(t_end, "error", res.error, 0.0)
    o.rec.metadata("run_result", {
        "cycles_done": res.cycles, "cycles_planned": res.capture.n, "error": res.error or "",
        "interrupted": False, "end": res.end, "wall_s": f"{res.wall_s:.3f}",
        "rows_dropped": o.rec.dropped, "timing": json.dumps(res.pacing),
        "counters": json.dumps(e.counters() if e is not None else {}),
        **({k: json.dumps(v) for k, v in (extra or {}).items()})})
    try:
        o.rec.close()
    finally:
        res.live_stats = o.rec.live_stats
    res.out = o.rec.final_path or res.out
