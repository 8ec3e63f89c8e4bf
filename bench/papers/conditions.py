"""What a claim's verdict is about, checked on what ran (issue 19, point 1): a claim applies to a
recording because of the estimator that closed the loop, the plant's set-up, the drive's inverter
compensation and the operating point and window of the claim's run, never because of a file's
name.

Each run of a claim (hil_bench.claims.model.Run: a bundled scenario with overrides) defines its
**conditions** by what a run of it writes in its recording: ``expected(run)`` builds the run's
scenario and the bench's Runner for it (nothing is started) and takes the plant's parameters, the
CONFIG parameters and the compensation metadata exactly as the runner records them. A recording
is then compared with them (``failed``), condition by condition:

* ``estimator``: the estimator the controller *reported* closing the loop (TELEM.estimator over
  the whole run), not the one the scenario asked for; a recording without telemetry fails it;
* ``timing``: lockstep, or real time with its duty update (``on_arrival``: the duties act when
  they arrive, after the link's round trip; ``next_period``): a claim's run is lockstep, where the
  duties act at the emulated computation delay; a real-time run of the same scenario has another
  delay, so it is not a run of the claim;
* ``profile``: the motor profile;
* ``plant.<key>``: every plant parameter (the non-idealities on/off and their values; the
  values of a group that is off on both sides do not matter; the ADC's noise seed never does);
* ``inverter_comp``: the drive's feed-forward on/off and its residual, current and shape (the
  recording's ``inverter_comp`` metadata);
* ``controller.<PARAM>``: the estimator's and the compensations' CONFIG parameters (SMO_*,
  PLL_*, SPEED_LPF_*, HFI_*, IPD_*, DELAY_COMP_*, HARM_*, INV_COMP_*, CTRL_DELAY_S) and every
  parameter any run of the claim overrides (what the claim tells its runs apart by);
* ``speed reference`` / ``load`` / ``current reference`` / ``control mode``: the operating
  point, as a timeline up to the end of the run's last window (every change, its time and value);
* ``window``: the recording lasts to the end of every window the run's rows read;
* ``scenario <key>``: any other key a run of the claim overrides (an initial rotor angle).

``match(claim, rec, scn)`` picks the claim's run a recording is: the run whose conditions all
hold (the one of the recording's own name first, if several do), else the nearest run with the
conditions that failed; its rows are then INVALID, saying which condition failed and what ran
instead. Metric windows are the run's (``window_of``), not the recording's scenario's.
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from typing import Any

from hil_bench.claims.model import Claim, Quantity, Run

#: CONFIG parameters that set the estimator or a compensation: conditions of every claim run
ESTIMATOR_PARAM_PREFIXES = ("SMO_", "PLL_", "SPEED_LPF_", "HFI_", "IPD_", "DELAY_COMP_", "HARM_",
                            "INV_COMP_")
#: ... and the delay the controller compensates (what its observer takes as the voltage's time)
ESTIMATOR_PARAMS = ("CTRL_DELAY_S",)
#: plant parameters that matter only when their switch is on (switch, prefix or names)
_GROUPS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("inverter_nonlinear", ("dead_time_s", "v_switch_drop_v", "r_switch_ohm", "v_diode_drop_v",
                            "r_diode_ohm", "i_cap_band_a")),
    ("saturation", ("sat_",)),
    ("adc_model", ("adc_bits", "adc_full_scale_a", "adc_gain_", "adc_offset_", "adc_noise_",
                   "adc_vdc_")),
    ("dyno", ("dyno_",)),
)
#: plant parameters that are not the claim's set-up (the ADC noise generator's seed)
_IGNORED_PLANT = ("adc_seed",)
#: the compensation metadata compared
_COMP_KEYS = ("on", "residual", "current", "shape")
#: override keys checked by another condition (the timeline, the window)
_COVERED = ("controller.speed_ref_rpm", "scenario.duration_s", "metrics.window_s")
#: relative tolerance of a number's equality: the metadata are JSON float64 of the same values;
#: CONFIG parameters travel as float32 (docs/protocol.md), so two values one float32 rounding
#: apart (2^-24 relative) are the same parameter for the controller
_REL_TOL = 1e-9
_REL_TOL_F32 = 2.0 ** -23


@dataclass(frozen=True)
class Failed:
    """One condition of a claim's run that a recording does not meet."""

    name: str          # "estimator", "plant.inverter_nonlinear", "speed reference", ...
    expected: str
    actual: str

    def text(self) -> str:
        return f"{self.name}: the claim's run {self.expected}; this run: {self.actual}"


@dataclass(frozen=True)
class Setup:
    """What a run of a claim's scenario records about itself (or what a recording says)."""

    estimator: str
    profile: str
    plant: dict[str, Any]
    controller: dict[str, float]
    inverter_comp: dict[str, Any]
    timeline: dict[str, tuple[tuple[float, float], ...]]   # action -> ((t_s, value), ...)
    initial: dict[str, float]                               # action -> value at t = 0
    duration_s: float
    metrics_window_s: tuple[float, float]
    raw: dict[str, Any]
    timing: str = "lockstep"   # "lockstep", or "realtime (on_arrival)" / "realtime (next_period)"


def _timeline(scn) -> tuple[dict[str, tuple], dict[str, float]]:
    out: dict[str, list] = {}
    for ev in scn.events:
        for action, value in ev.actions():
            out.setdefault(action, []).append((float(ev.t_s), float(value)))
    initial = {"speed_ref": float(scn.speed_ref_rad_s), "load": float(scn.initial_load_torque_nm)}
    return {k: tuple(v) for k, v in out.items()}, initial


def _setup_of_scenario(scn, plant: dict, controller: dict, comp: dict, estimator: str,
                       profile: str) -> Setup:
    timeline, initial = _timeline(scn)
    return Setup(estimator, profile, plant, controller, comp, timeline, initial,
                 float(scn.duration_s), tuple(scn.metrics_window_s), dict(scn.raw))


def scenario_for(run: Run):
    """The scenario of a claim's run: the bundled scenario with the run's overrides."""
    from hil_bench.scenario import derive_scenario, load_scenario
    if not run.overrides:
        return load_scenario(run.scenario)
    return derive_scenario(run.scenario, run.name, run.overrides, note=run.label)


_EXPECTED: dict[str, Setup] = {}


def expected(run: Run) -> Setup:
    """The conditions of a claim's run: what a run of its scenario records (the Runner's own
    plant parameters, CONFIG and compensation metadata; nothing is started)."""
    key = repr((run.scenario, run.name, run.overrides))
    if key not in _EXPECTED:
        _EXPECTED[key] = _expected(run)
    return _EXPECTED[key]


def _expected(run: Run) -> Setup:
    from hil_bench.loop.runner import Runner

    scn = scenario_for(run)
    r = Runner(scn, "stub", out_path=None, progress=False, realtime=False, record=False)
    controller = {p.name: float(v) for p, v in r.controller_params().items()}
    setup = _setup_of_scenario(scn, dict(r.plant.params.as_dict()), controller,
                               dict(r.inverter_comp_metadata()), scn.estimator.name,
                               r.profile.name)
    return dataclasses.replace(setup, timing=_timing(scn.mode, scn.realtime.duty_update))


def reported_estimators(rec) -> dict[str, int]:
    """Cycles per estimator the controller reported (TELEM.estimator over the whole run; the
    streaming count of `bench check` when there is one)."""
    from hil_bench.protocol.messages import Estimator
    from hil_bench.record import channels as ch

    counts = getattr(rec, "estimator_counts", None)
    if counts is None:
        import numpy as np
        telem = rec.topics.get(ch.CONTROLLER_TELEMETRY, {})
        est = telem.get("estimator") if telem else None
        if est is None:
            return {}
        est = np.asarray(est, dtype=float)
        est = est[np.isfinite(est)].astype(int)
        vals, cnts = np.unique(est, return_counts=True)
        counts = dict(zip(vals.tolist(), cnts.tolist()))
    out: dict[str, int] = {}
    for v, c in counts.items():
        if int(v) < 0:
            continue
        try:
            name = Estimator(int(v)).name
        except ValueError:
            name = f"estimator {int(v)}"
        out[name] = out.get(name, 0) + int(c)
    return out


def actual(rec, scn) -> Setup:
    """What a recording says ran: its metadata (plant, CONFIG, compensation, profile) and the
    attached scenario's timeline; the estimator is checked on the telemetry (``failed``)."""
    run = rec.run

    def js(key: str) -> dict:
        try:
            v = json.loads(run.get(key, "{}") or "{}")
        except ValueError:
            return {}
        return v if isinstance(v, dict) else {}

    setup = _setup_of_scenario(scn, js("plant_params"), js("controller_params"),
                               js("inverter_comp") or {"on": False}, str(run.get("estimator", "")),
                               str(run.get("profile", "")))
    return dataclasses.replace(setup, timing=_timing(str(run.get("mode", "lockstep") or "lockstep"),
                                                     str(run.get("duty_update", "") or "")))


def _timing(mode: str, duty_update: str) -> str:
    return "lockstep" if mode != "realtime" else f"realtime ({duty_update or 'on_arrival'})"


def _same(a: Any, b: Any, rel_tol: float = _REL_TOL) -> bool:
    if isinstance(a, bool) or isinstance(b, bool) or a is None or b is None:
        return a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        a, b = float(a), float(b)
        return a == b or math.isclose(a, b, rel_tol=rel_tol, abs_tol=1e-15)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y, rel_tol) for x, y in zip(a, b))
    return a == b


def _fmt(v: Any) -> str:
    if v is None:
        return "none"
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


def _plant_keys(exp: dict, act: dict) -> list[str]:
    keys = [k for k in dict.fromkeys(list(exp) + list(act)) if k not in _IGNORED_PLANT]
    out = []
    for k in keys:
        skip = False
        for switch, members in _GROUPS:
            if k != switch and any(k == m or (m.endswith("_") and k.startswith(m))
                                   for m in members):
                skip = not exp.get(switch) and not act.get(switch)
        if k.startswith("load_") and k != "load_profile":
            skip = exp.get("load_profile") in (None, "none") and act.get("load_profile") in (
                None, "none")
        if not skip:
            out.append(k)
    return out


def _dotted(raw: dict, key: str) -> Any:
    cur: Any = raw
    for part in key.split("."):
        if not isinstance(cur, dict) or part not in cur:
            return None
        cur = cur[part]
    return cur


#: the operating point's actions (Event.actions) and how a condition names them
_ACTIONS = {"speed_ref": ("speed reference", "rpm"), "load": ("load", "N m"),
            "iq_ref": ("current reference i_q", "A"), "id_ref": ("current reference i_d", "A"),
            "control_mode": ("control mode", "")}


def _value_at(setup: Setup, action: str, t_s: float) -> float:
    v = setup.initial.get(action, math.nan)
    for t, x in setup.timeline.get(action, ()):
        if t <= t_s:
            v = x
    return v


def _show(action: str, v: float) -> str:
    from hil_bench.scenario import RPM_PER_RAD_S
    if not math.isfinite(v):
        return "none"
    if action == "speed_ref":
        return f"{v * RPM_PER_RAD_S:.6g} rpm"
    if action == "control_mode":
        return "current" if v else "speed"
    return f"{v:.6g} {_ACTIONS[action][1]}".strip()


def _operating_point(exp: Setup, act: Setup, t_end_s: float) -> list[Failed]:
    out = []
    for action, (name, _unit) in _ACTIONS.items():
        times = sorted({0.0} | {t for s in (exp, act) for t, _ in s.timeline.get(action, ())
                                if t <= t_end_s})
        for t in times:
            a, b = _value_at(exp, action, t), _value_at(act, action, t)
            if not (_same(a, b) or (math.isnan(a) and math.isnan(b))):
                out.append(Failed(name, f"has {_show(action, a)} from t = {t:g} s",
                                  f"{_show(action, b)}"))
                break
    return out


def windows_of(claim: Claim, run: Run) -> list[tuple[float, float]]:
    """Every window the claim's rows on ``run`` read (a row without its own: the run's metrics
    window)."""
    exp = expected(run)
    out = []
    for q in rows_on(claim, run):
        out.append(tuple(q.window_s) if q.window_s is not None else exp.metrics_window_s)
        if q.at_speed_window_s is not None:
            out.append(tuple(q.at_speed_window_s))
    return out or [exp.metrics_window_s]


def rows_on(claim: Claim, run: Run) -> list[Quantity]:
    """The rows of a claim measured in one recording of ``run`` alone (no study, aggregate or
    derived row)."""
    return [q for q in claim.quantities
            if not (q.study or q.aggregate or q.metric == "derived")
            and (not q.runs or run.id in q.runs)]


def window_of(q: Quantity, run: Run) -> Quantity:
    """The row with its window made explicit: the run's metrics window where it has none."""
    if q.window_s is not None:
        return q
    return dataclasses.replace(q, window_s=expected(run).metrics_window_s)


def failed(run: Run, rec, scn, claim: Claim | None = None, estimator: bool = True) -> list[Failed]:
    """The conditions of ``run`` that the recording (its metadata ``rec.run``, telemetry and
    attached scenario ``scn``) does not meet; [] when it is a run of the claim. ``estimator``
    False: the reported estimator is not checked (a header read, before the telemetry)."""
    exp, act = expected(run), actual(rec, scn)
    out: list[Failed] = []
    if estimator:
        reported = reported_estimators(rec)
        other = {k: c for k, c in reported.items() if k != exp.estimator}
        if not reported:
            out.append(Failed("estimator", f"closes the loop with {exp.estimator}",
                              "no telemetry reports the estimator that closed the loop"))
        elif other:
            total = sum(reported.values())
            out.append(Failed("estimator", f"closes the loop with {exp.estimator}",
                              "the controller reported " + ", ".join(
                                  f"{k} in {c} of {total} cycles" for k, c in other.items())))
    if exp.profile != act.profile:
        out.append(Failed("profile", f"is {exp.profile}", act.profile or "none recorded"))
    if exp.timing != act.timing:
        out.append(Failed("timing", f"runs {exp.timing}", act.timing))
    if not act.plant:
        out.append(Failed("plant", "records its plant", "none recorded"))
    else:
        for k in _plant_keys(exp.plant, act.plant):
            if not _same(exp.plant.get(k), act.plant.get(k)):
                out.append(Failed(f"plant.{k}", f"has {_fmt(exp.plant.get(k))}",
                                  f"{_fmt(act.plant.get(k))}"))
    ec, ac = exp.inverter_comp, act.inverter_comp
    diff = [k for k in _COMP_KEYS if not _same(ec.get(k, False if k == "on" else None),
                                               ac.get(k, False if k == "on" else None))]
    if diff:
        def comp(m: dict) -> str:
            if not m.get("on"):
                return "inverter compensation off"
            r = m.get("residual")
            return ("inverter compensation on" + (f", residual {100 * r:g} %" if r is not None
                                                  else " (explicit parameters)")
                    + f", {m.get('current', '?')} current, {m.get('shape', '?')} shape")
        out.append(Failed("inverter_comp", f"has {comp(ec)}", comp(ac)))
    # the keys any run of the claim overrides: what the claim tells its runs apart by
    keys = list(dict.fromkeys(k for r in (claim.runs if claim is not None else (run,))
                              for k, _ in r.overrides))
    over = {k.split(".", 2)[2] for k in keys if k.startswith("controller.params.")}
    names = [n for n in dict.fromkeys(list(exp.controller) + list(act.controller))
             if n.startswith(ESTIMATOR_PARAM_PREFIXES) or n in ESTIMATOR_PARAMS or n in over]
    differ = [n for n in names
              if not _same(exp.controller.get(n), act.controller.get(n), _REL_TOL_F32)]
    if differ:
        def params(m: dict) -> str:
            return ", ".join(f"{n} {_fmt(m[n]) if n in m else 'not set'}" for n in differ)
        out.append(Failed("controller parameters", f"has {params(exp.controller)}",
                          params(act.controller)))
    windows = windows_of(claim, run) if claim is not None else [exp.metrics_window_s]
    t_end = max(w[1] for w in windows)
    out += _operating_point(exp, act, t_end)
    if act.duration_s < t_end - 1e-9:
        out.append(Failed("window", f"reads windows up to {t_end:g} s",
                          f"lasts {act.duration_s:g} s"))
    for k in keys:
        if k in _COVERED or k.startswith(("controller.params.", "controller.inverter_comp.")):
            continue
        head, _, rest = k.partition(".")
        if head == "plant" and rest in exp.plant:
            continue          # a plant parameter: compared above
        a, b = _dotted(exp.raw, k), _dotted(act.raw, k)
        if not _same(a, b):
            out.append(Failed(f"scenario {k}", f"has {_fmt(a)}", _fmt(b)))
    return out


@dataclass(frozen=True)
class Match:
    """The claim's run a recording is (``failed`` empty), or the nearest one and why not."""

    claim: Claim
    run: Run
    failed: tuple[Failed, ...]

    @property
    def ok(self) -> bool:
        return not self.failed

    def note(self) -> str:
        """Why the claim's rows are INVALID on this recording (in full)."""
        return (f"not the set-up of {self.claim.id}'s run {self.run.id} ({self.run.name}): "
                + "; ".join(f.text() for f in self.failed))

    def short(self) -> str:
        """The conditions that failed, by name (a table cell)."""
        return (f"not {self.claim.id}'s set-up (run {self.run.id}): "
                + ", ".join(f.name for f in self.failed) + " differ")


def match(claim: Claim, rec, scn, estimator: bool = True) -> Match | None:
    """The run of ``claim`` that this recording is (by what ran), or the nearest run with the
    conditions that failed; None for a claim without runs."""
    best: tuple[int, int, int, Run, list[Failed]] | None = None
    for i, run in enumerate(claim.runs):
        f = failed(run, rec, scn, claim, estimator)
        key = (len(f), 0 if run.name == scn.name else 1, i)
        if best is None or key < best[:3]:
            best = (*key, run, f)
        if not f and run.name == scn.name:
            break
    if best is None:
        return None
    return Match(claim, best[3], tuple(best[4]))
