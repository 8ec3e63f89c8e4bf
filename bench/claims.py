"""The papers' published numbers: per claim, the runs that reproduce it, the metric of each
quantity, the paper's value and an acceptance rule taken from the paper.

A claim (``Y1`` .. ``G8``, /work/shared/papers/README.md) has

* **runs**: recordings of bundled scenarios (``bench/scenarios``), possibly with overrides (a
  speed, an angle, an effect switched off) - each run has a name and its scenario is attached
  to its recording, so ``bench check`` works on it;
* **quantities**: a metric (``METRICS``) of one run (or of several, aggregated), the estimate it
  is computed on (``source``: the controller's telemetry or ``reference:<label>``), the window,
  the paper's value and a **rule**:

  - ``at_most(x)`` - the paper states a bound ("within +-0.1 rad", "+-x rpm", "< 0.2 rad"): a
    measured value <= x passes;
  - ``within(lo, hi)`` - the paper's own statement of its measurement gives the interval (the
    scatter of Table II; "approximately two cycles" read in whole cycles);
  - ``compared()`` - the paper reports a value without a bound and says nothing about its
    measurement's resolution or scatter: the value is compared, no pass/fail (verdict COMPARED);

* **relations** between two quantities the paper ranks ("the improved SMO's error is smaller"),
  checked as stated.

Every rule carries its source (section, table, the paper's words). A quantity may be marked
``diagnostic`` (a run that is not the paper's setup, e.g. the same run without dead time, to
locate a failure) or ``not_reproducible`` (with the reason the paper's number cannot come out of
this bench); its measured value is shown all the same.

Verdicts: PASS, FAIL, COMPARED (value compared, no pass/fail), INVALID (the bench could not
measure: the run broke, the window is empty), NOT REPRODUCIBLE (reason given). A claim that does
not reproduce is a result to show, never something to tune away.
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from . import channels as ch
from . import metrics
from .recording import Recording

RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)
VERDICTS = ("PASS", "FAIL", "COMPARED", "INVALID", "NOT REPRODUCIBLE")


class MetricUnavailable(Exception):
    """The recording lacks what this metric needs (e.g. no EMF telemetry, an empty window)."""


class MetricAtLeast(Exception):
    """The quantity did not settle inside the window: it is at least ``value`` (reported as a
    lower bound, e.g. a response time longer than the window)."""

    def __init__(self, value: float, why: str):
        super().__init__(why)
        self.value = value


# -- context: what a metric sees ------------------------------------------------------------------

@dataclass(frozen=True)
class Context:
    """A recording, a window, the speed reference in it, the estimate the metric is computed on."""

    rec: Recording
    window_s: tuple[float, float]
    speed_ref_rpm: float
    pole_pairs: int
    ts_s: float
    source: str = "controller"
    speed_ref_at: Callable[[float], float] | None = None   # t_s -> rpm

    def with_window(self, window_s: tuple[float, float]) -> "Context":
        ref = self.speed_ref_at(window_s[0]) if self.speed_ref_at else self.speed_ref_rpm
        return dataclasses.replace(self, window_s=window_s, speed_ref_rpm=ref)

    def with_source(self, source: str) -> "Context":
        return dataclasses.replace(self, source=source)

    @property
    def estimate_topic(self) -> str:
        if self.source == "controller":
            return ch.CONTROLLER_TELEMETRY
        if self.source.startswith("reference:"):
            return ch.REFERENCE_PREFIX + self.source.split(":", 1)[1]
        raise ValueError(f"unknown estimate source {self.source!r}")

    def column(self, topic: str, field: str) -> tuple[np.ndarray, np.ndarray]:
        """(t_s, values) of a whole topic column."""
        if topic not in self.rec.topics:
            raise MetricUnavailable(f"no {topic} in the recording")
        cols = self.rec.topics[topic]
        if field not in cols:
            raise MetricUnavailable(f"{topic} has no field {field}")
        return np.asarray(cols["t_s"], float), np.asarray(cols[field], float)

    def windowed(self, topic: str, field: str) -> np.ndarray:
        t, v = self.column(topic, field)
        values = v[metrics.window_mask(t, self.window_s)]
        if values.size == 0:
            raise MetricUnavailable(f"no {topic} samples in the window {self.window_s} "
                                    f"(recording ends at {t[-1] if t.size else 0:.3g} s)")
        return values

    def estimate_and_truth(self, field: str, truth_field: str) -> tuple[np.ndarray, np.ndarray]:
        """An estimate's field and the plant truth at the same cycles (matched by time)."""
        topic = self.estimate_topic
        est_t = self.windowed(topic, "t_s")
        est = self.windowed(topic, field)
        st, truth = self.column(ch.PLANT_STATE, truth_field)
        idx = np.clip(np.searchsorted(st, est_t), 0, len(st) - 1)
        return est, truth[idx]

    def electrical_hz(self) -> float:
        w = self.windowed(ch.PLANT_STATE, "omega_e_rad_s")
        return float(abs(np.mean(w))) / (2.0 * math.pi)

    @property
    def plant_params(self) -> dict:
        return json.loads(self.rec.run.get("plant_params", "{}"))


# -- metrics (name -> unit, definition, function(ctx, **params) -> float) --------------------------

def _speed_band_hat(c: Context) -> float:
    return metrics.speed_band_rpm(c.windowed(c.estimate_topic, "speed_hat_rpm"), c.speed_ref_rpm)


def _speed_band_true(c: Context) -> float:
    return metrics.speed_band_rpm(c.windowed(ch.PLANT_STATE, "speed_rpm"), c.speed_ref_rpm)


def _speed_est_error(c: Context) -> float:
    est, truth = c.estimate_and_truth("speed_hat_rpm", "speed_rpm")
    v = metrics.speed_error_band_rpm(est, truth)
    if not math.isfinite(v):
        raise MetricUnavailable("no finite speed estimate in the window")
    return v


def _pee_max(c: Context) -> float:
    est, truth = c.estimate_and_truth("theta_hat_rad", "theta_e_rad")
    return metrics.angle_error(est, truth).max_abs_rad


def _pee_mean(c: Context) -> float:
    est, truth = c.estimate_and_truth("theta_hat_rad", "theta_e_rad")
    return metrics.angle_error(est, truth).mean_rad


def _emf_spectrum(c: Context, field: str = "e_alpha_v") -> metrics.Spectrum:
    e = c.windowed(c.estimate_topic, field)
    if not np.all(np.isfinite(e)):
        raise MetricUnavailable(f"{c.source} reported no EMF in the window")
    return metrics.harmonic_spectrum(e, 1.0 / c.ts_s, c.electrical_hz())


def _emf_thd(c: Context) -> float:
    return _emf_spectrum(c).thd_n_percent


def _emf_amplitude(c: Context) -> float:
    return _emf_spectrum(c).fundamental_amplitude


def _current_spectrum(c: Context) -> metrics.Spectrum:
    return metrics.harmonic_spectrum(c.windowed(ch.PLANT_STATE, "i_a_a"), 1.0 / c.ts_s,
                                     c.electrical_hz())


def _phase_current_amp(c: Context) -> float:
    return _current_spectrum(c).fundamental_amplitude


def _current_thd(c: Context) -> float:
    return _current_spectrum(c).thd_percent


def _current_h5(c: Context) -> float:
    return _current_spectrum(c).harmonic_percent(5)


def _current_h7(c: Context) -> float:
    return _current_spectrum(c).harmonic_percent(7)


def _iq_mean(c: Context) -> float:
    return float(np.mean(c.windowed(ch.PLANT_STATE, "i_q_a")))


def _speed_min_true(c: Context) -> float:
    return float(np.min(c.windowed(ch.PLANT_STATE, "speed_rpm")))


def _speed_dev_true(c: Context) -> float:
    return float(np.max(np.abs(c.windowed(ch.PLANT_STATE, "speed_rpm") - c.speed_ref_rpm)))


def _speed_error_series(c: Context) -> tuple[np.ndarray, np.ndarray]:
    t_all, _ = c.column(c.estimate_topic, "t_s")
    est_t, est = c.column(c.estimate_topic, "speed_hat_rpm")
    st, truth = c.column(ch.PLANT_STATE, "speed_rpm")
    idx = np.clip(np.searchsorted(st, est_t), 0, len(st) - 1)
    m = metrics.window_mask(est_t, c.window_s)
    if not np.any(m):
        raise MetricUnavailable(f"no estimate in the window {c.window_s}")
    return est_t[m], est[m] - truth[idx][m]


def _response_time_ms(c: Context, t_event_s: float, pre_window_s: float = 0.1) -> float:
    """Estimator response: the speed-estimation error back inside its pre-event band."""
    t, err = _speed_error_series(c)
    v = metrics.response_time_s(t, err, t_event_s, pre_window_s=pre_window_s)
    if not math.isfinite(v):
        raise MetricAtLeast(1e3 * (c.window_s[1] - t_event_s),
                            "the estimation error is not back in its pre-event band by the end "
                            "of the window: a lower bound")
    return 1e3 * v


def _speed_dip_true(c: Context, t_event_s: float, sign: float = 1.0) -> float:
    t, n = c.column(ch.PLANT_STATE, "speed_rpm")
    m = metrics.window_mask(t, c.window_s)
    return metrics.speed_dip(t[m], n[m], t_event_s, c.speed_ref_at(t_event_s) if c.speed_ref_at
                             else c.speed_ref_rpm, band=1.0, sign=sign).depth


def _step_overshoot(c: Context, t_step_s: float, field: str = "speed_rpm") -> float:
    t, n = c.column(ch.PLANT_STATE, field)
    m = metrics.window_mask(t, (c.window_s[0] - 0.05, c.window_s[1]))
    final = c.speed_ref_at(t_step_s + 1e-6) if c.speed_ref_at else c.speed_ref_rpm
    return metrics.step_response(t[m], n[m], t_step_s, final, band=5.0,
                                 t_end_s=c.window_s[1]).overshoot


def _settling_time_s(c: Context, t_step_s: float, band_rpm: float) -> float:
    t, n = c.column(ch.PLANT_STATE, "speed_rpm")
    m = metrics.window_mask(t, (c.window_s[0] - 0.05, c.window_s[1]))
    final = c.speed_ref_at(t_step_s + 1e-6) if c.speed_ref_at else c.speed_ref_rpm
    v = metrics.step_response(t[m], n[m], t_step_s, final, band=band_rpm).settling_s
    if not math.isfinite(v):
        raise MetricAtLeast(c.window_s[1] - t_step_s, "the speed does not settle in the window: "
                            "a lower bound")
    return v


def _ipd_error_deg(c: Context) -> float:
    """Initial position: the mean error of the estimate over the window (after the procedure),
    wrapped; a wrong N/S polarity reads about 180 deg."""
    est, truth = c.estimate_and_truth("theta_hat_rad", "theta_e_rad")
    e = metrics.wrap_pi(est - truth)
    e = e[np.isfinite(e)]
    if not e.size:
        raise MetricUnavailable("no angle estimate in the window")
    # mean of a wrapped angle: through the unit vector
    return math.degrees(math.atan2(np.mean(np.sin(e)), np.mean(np.cos(e))))


def _chattering_a(c: Context, estimator: str, **config: float) -> float:
    from firmware_stub.estimators import REFERENCE_ESTIMATORS
    from plant_rt.profile import load_profile

    from .estimator_trace import replay
    profile = load_profile(c.rec.run.get("profile", ""))
    est = REFERENCE_ESTIMATORS[estimator](profile, c.ts_s, **config)
    r = replay(c.rec, est, window_s=c.window_s)
    w_e = 2.0 * math.pi * c.electrical_hz()
    return metrics.chattering_index_a(r.i_hat_alpha_a, r.i_hat_beta_a, r.i_alpha_a, r.i_beta_a,
                                      r.t_s, w_e)


def dual_samples(rec: Recording) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t_s, i1 (n, 3), i2 (n, 3)): the first sample of cycle k (/plant/sense) and the second
    sample of the same period, taken at t_k + t_d, which reaches the controller with cycle k + 1
    (the SENSE_DUAL frame in /link/frames; NaN where there is none)."""
    from protocol.messages import MESSAGES
    dual = MESSAGES["SENSE_DUAL"]
    prefix = f"{dual.frame_id:03X}#"
    sense = rec.topic(ch.PLANT_SENSE)
    frames = rec.topic(ch.LINK_FRAMES)
    by_seq: dict[int, tuple[float, float, float]] = {}
    for tx in frames["tx"]:
        for item in str(tx).split():
            if item.startswith(prefix):
                v = dual.unpack_values(bytes.fromhex(item[len(prefix):]))
                by_seq[int(v[0])] = (float(v[1]), float(v[2]), float(v[3]))
    t = np.asarray(sense["t_s"], float)
    seq = np.asarray(sense["seq"], int)
    i1 = np.stack([np.asarray(sense[f], float) for f in ("i_a_a", "i_b_a", "i_c_a")], axis=1)
    i2 = np.full_like(i1, np.nan)
    for k in range(len(seq) - 1):
        nxt = by_seq.get(int(seq[k + 1]))
        if nxt is not None:
            i2[k] = nxt
    return t, i1, i2


def _delay_estimate_us(c: Context) -> float:
    if not c.plant_params.get("dual_sampling"):
        raise MetricUnavailable("dual sampling is off in this recording")
    t, i1, i2 = dual_samples(c.rec)
    m = metrics.window_mask(t, c.window_s)
    est = metrics.delay_estimates_s(i1[m], i2[m], c.ts_s)
    est = est[np.isfinite(est)]
    if not est.size:
        raise MetricUnavailable("no period with a usable current change in the window")
    return 1e6 * float(np.mean(est))


_EXTRACTION_CACHE: dict = {}


def _harmonic_extraction_pp(c: Context, order: int, extractor: str, m: int = 96) -> float:
    """Yuan Table 3: the 5th or 7th harmonic of the phase current as extracted by the controller's
    angle-synchronous SDFT/GSDFT (harm_comp, M samples per electrical period, true angle), in %
    of the fundamental (FFT over the window), the extractor's output at the end of the window."""
    key = (str(c.rec.path), c.window_s, extractor, m)
    if key not in _EXTRACTION_CACHE:
        _EXTRACTION_CACHE.clear()     # one recording at a time
        _EXTRACTION_CACHE[key] = _extract(c, extractor, m)
    i5, i7 = _EXTRACTION_CACHE[key]
    fund = _current_spectrum(c).fundamental_amplitude
    return 100.0 * (i5 if order == 5 else i7) / fund


def _extract(c: Context, extractor: str, m: int) -> tuple[float, float]:
    from firmware_stub.est_dft import HarmComp
    t, ia = c.column(ch.PLANT_STATE, "i_alpha_a")
    _, ib = c.column(ch.PLANT_STATE, "i_beta_a")
    _, th = c.column(ch.PLANT_STATE, "theta_e_rad")
    _, w = c.column(ch.PLANT_STATE, "omega_e_rad_s")
    pp = c.plant_params
    h = HarmComp(pp["rs_ohm"], pp["ld_h"], c.ts_s, extractor=extractor, m=m)
    last = None
    for k in np.nonzero(t <= c.window_s[1])[0]:
        o = h.step(float(ia[k]), float(ib[k]), float(th[k]), float(w[k]))
        if o.valid:
            last = o
    if last is None:
        raise MetricUnavailable(f"{extractor} extraction not valid in the window")
    return last.i5_a, last.i7_a


METRICS: dict[str, tuple[str, str, Callable[..., float]]] = {
    # name: (unit, definition, function)
    "speed_band_hat_rpm": ("rpm", "max |n_hat - n_ref| of the estimated speed in the window",
                           _speed_band_hat),
    "speed_band_true_rpm": ("rpm", "max |n - n_ref| of the true rotor speed in the window",
                            _speed_band_true),
    "speed_est_error_rpm": ("rpm", "max |n_hat - n| (estimated minus true speed, same cycles) in "
                                   "the window", _speed_est_error),
    "pee_max_rad": ("rad", "max |wrap(theta_hat - theta)| in the window", _pee_max),
    "pee_mean_rad": ("rad", "mean wrap(theta_hat - theta) in the window (the lag or lead)",
                     _pee_mean),
    "emf_thd_percent": ("%", "distortion of the estimated e_alpha: everything but DC and the "
                             "fundamental (THD+N: the chattering too, up to Nyquist) over the "
                             "fundamental, by FFT over the longest whole number of electrical "
                             "periods ending at the window's end (rectangular window)", _emf_thd),
    "emf_amplitude_v": ("V", "fundamental amplitude of the estimated e_alpha (same FFT)",
                        _emf_amplitude),
    "phase_current_amp_a": ("A", "fundamental amplitude of the true phase-a current (same FFT)",
                            _phase_current_amp),
    "current_thd_percent": ("%", "THD (harmonics 2..50) of the true phase-a current (same FFT)",
                            _current_thd),
    "current_h5_percent": ("%", "5th harmonic of the true phase-a current / fundamental",
                           _current_h5),
    "current_h7_percent": ("%", "7th harmonic of the true phase-a current / fundamental",
                           _current_h7),
    "iq_mean_a": ("A", "mean true q-axis current in the window", _iq_mean),
    "speed_min_true_rpm": ("rpm", "lowest true speed in the window", _speed_min_true),
    "speed_dev_true_rpm": ("rpm", "max |n - n_ref| of the true speed in the window",
                           _speed_dev_true),
    "response_time_ms": ("ms", "estimator response to an event at t_event_s: until |n_hat - n| is "
                               "back, for good, inside its own band of the pre_window_s before "
                               "the event", _response_time_ms),
    "speed_dip_rpm": ("rpm", "largest excursion of the true speed from its reference after an "
                             "event at t_event_s (sign +1: below, a load; -1: above, an unload)",
                      _speed_dip_true),
    "step_overshoot_rpm": ("rpm", "overshoot of the true speed beyond the new reference after a "
                                  "step at t_step_s, in the step's direction", _step_overshoot),
    "settling_time_s": ("s", "time after a speed step at t_step_s until the true speed stays "
                             "within band_rpm of the new reference", _settling_time_s),
    "ipd_error_deg": ("deg", "initial-position error: the mean of wrap(theta_hat - theta) over "
                             "the window after the procedure (wrong polarity: about 180)",
                      _ipd_error_deg),
    "chattering_a": ("A", "RMS of i_hat - i (alpha-beta) of an observer replayed on the "
                          "recording's samples, its DC and fundamental removed (Yuan Fig. 17: "
                          "the width of the band about the trajectory)",
                     _chattering_a),
    "delay_estimate_us": ("us", "mean of Gong's eq. 20 per-period estimates from the recorded "
                                "dual samples in the window (guards of est_delay_comp)",
                          _delay_estimate_us),
    "harmonic_extraction_pp": ("%", "5th/7th of the phase current as extracted by harm_comp's "
                                    "angle-synchronous SDFT or GSDFT, % of the fundamental",
                               _harmonic_extraction_pp),
}


# -- rules -------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Rule:
    kind: str                      # "at_most" | "within" | "compared"
    source: str                    # where the rule comes from: the paper's words, section, table
    lo: float = -math.inf
    hi: float = math.inf

    def verdict(self, measured: float) -> str:
        if self.kind == "compared":
            return "COMPARED"
        if not math.isfinite(measured):
            return "FAIL"
        if self.kind == "at_most":
            return "PASS" if measured <= self.hi else "FAIL"
        if self.kind == "within":
            return "PASS" if self.lo <= measured < self.hi else "FAIL"
        raise ValueError(f"unknown rule {self.kind!r}")

    def text(self) -> str:
        if self.kind == "at_most":
            return f"<= {self.hi:g}"
        if self.kind == "within":
            return f"[{self.lo:g}, {self.hi:g})"
        return "value compared, no pass/fail"


def at_most(bound: float, source: str) -> Rule:
    return Rule("at_most", source, hi=bound)


def within(lo: float, hi: float, source: str) -> Rule:
    return Rule("within", source, lo=lo, hi=hi)


def compared(source: str) -> Rule:
    return Rule("compared", source)


# -- claims ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Run:
    """One recording of a claim: a bundled scenario, optionally with overrides of its TOML
    (dotted keys, e.g. ``plant.inverter_nonlinear``, ``controller.params.HFI_POL_BIAS_A``)."""

    id: str
    scenario: str
    overrides: tuple[tuple[str, Any], ...] = ()
    label: str = ""

    @property
    def name(self) -> str:
        """The scenario name of the recording (the scenario's own, or derived)."""
        return self.scenario if not self.overrides else f"{self.scenario}@{self.id}"


@dataclass(frozen=True)
class Quantity:
    key: str
    what: str
    metric: str
    paper_value: float | str
    rule: Rule
    run: str | tuple[str, ...] | None = None    # run id(s); None: any recording of the claim
    source: str = "controller"                   # or "reference:<label>"
    window_s: tuple[float, float] | None = None  # None: the scenario's metrics window
    params: tuple[tuple[str, Any], ...] = ()     # metric keyword arguments
    at_speed_rpm: float | None = None            # the operating point the window must hold
    at_speed_window_s: tuple[float, float] | None = None   # where (default: window_s)
    aggregate: str = ""                          # several runs: "max_abs" | "polarity_failures"
    study: str = ""                              # a study's value instead of a recording's
    diagnostic: bool = False                     # not the paper's setup: shown, no claim verdict
    not_reproducible: str = ""                   # why the paper's number cannot come out here

    @property
    def runs(self) -> tuple[str, ...]:
        if self.run is None:
            return ()
        return (self.run,) if isinstance(self.run, str) else tuple(self.run)

    @property
    def unit(self) -> str:
        if self.aggregate == "polarity_failures":
            return "trials"
        if self.metric in METRICS:
            return METRICS[self.metric][0]
        return dict(self.params).get("unit", "")

    def verdict(self, measured: float) -> str:
        """The rule's verdict alone (no run state, no operating point)."""
        if self.not_reproducible:
            return "NOT REPRODUCIBLE"
        return self.rule.verdict(measured)

    def rule_text(self) -> str:
        return self.rule.text()


@dataclass(frozen=True)
class Relation:
    """The paper ranks two of its quantities (or a chain): checked as stated."""

    key: str
    what: str
    keys: tuple[str, ...]        # quantity keys in the order of the relation ("#x": the number x)
    op: str                      # "<": keys[0] < keys[1] < ...; ">": decreasing; "=": |a - b| < tol
    paper: str                   # the paper's statement
    source: str
    diagnostic: bool = False
    tol: float = 0.0


@dataclass(frozen=True)
class Claim:
    id: str
    paper: str
    text: str
    quantities: tuple[Quantity, ...]
    runs: tuple[Run, ...] = ()
    relations: tuple[Relation, ...] = ()
    studies: tuple[str, ...] = ()
    setup: str = ""               # what the runs switch on, which estimator closes the loop
    notes: str = ""

    @property
    def scenarios(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(r.scenario for r in self.runs))

    def run(self, run_id: str) -> Run:
        for r in self.runs:
            if r.id == run_id:
                return r
        raise KeyError(f"{self.id}: no run {run_id!r}")


@dataclass(frozen=True)
class QuantityResult:
    claim: Claim
    quantity: Quantity
    measured: float
    verdict: str
    note: str = ""


@dataclass(frozen=True)
class RelationResult:
    claim: Claim
    relation: Relation
    measured: tuple[float, ...]
    verdict: str
    note: str = ""


def applicable(claim: Claim, scenario_name: str) -> list[Quantity]:
    """The quantities of a claim measured in one recording of ``scenario_name`` alone."""
    names = {r.id: r.name for r in claim.runs}
    out = []
    for q in claim.quantities:
        if q.study or q.aggregate or q.metric == "derived":
            continue
        if not q.runs or any(names.get(r) == scenario_name for r in q.runs):
            out.append(q)
    return out


def operating_point_note(ctx: Context, ref_rpm: float) -> str:
    """'' if the true speed held the operating point in the window, else why not. The drive
    holds it when its mean is within 10 % + 0.5 rpm of the reference (a validity condition of
    the measurement, not a tolerance on the claim)."""
    try:
        n = ctx.windowed(ch.PLANT_STATE, "speed_rpm")
    except MetricUnavailable as exc:
        return str(exc)
    mean = float(np.mean(n))
    if abs(mean - ref_rpm) <= 0.1 * abs(ref_rpm) + 0.5:
        return ""
    return (f"the drive did not hold {ref_rpm:g} rpm: true speed {mean:.3g} rpm in the window "
            f"(range {float(np.min(n)):.3g}..{float(np.max(n)):.3g})")


#: metrics that re-run an observer from the start of the run (they need every row up to their
#: window's end)
NEEDS_HISTORY = frozenset({"chattering_a"})
#: rows kept before a window: a metric may look back (response time: 0.1 s before its event;
#: step responses: 0.05 s)
WINDOW_LEAD_S = 0.2


def windows_needed(scn) -> list[tuple[float, float]]:
    """The time windows the claims of a scenario (and the summary) read, each with its lead:
    what `bench check` keeps of a recording's per-cycle topics."""
    out = [scn.metrics_window_s]
    for claim_id in scn.claims:
        claim = CLAIMS.get(claim_id)
        if claim is None:
            continue
        for q in applicable(claim, scn.name):
            w = q.window_s or scn.metrics_window_s
            out.append((0.0, w[1]) if q.metric in NEEDS_HISTORY else w)
            if q.at_speed_window_s is not None:
                out.append(q.at_speed_window_s)
    return [(max(0.0, w0 - WINDOW_LEAD_S), w1) for w0, w1 in out]


def run_failure(rec: Recording) -> tuple[str, str]:
    """('', '') for a complete run; ('FAIL', why) when the controller under test faulted (the
    method's own failure); ('INVALID', why) when the bench broke (link, stub, interrupt)."""
    result = rec.metadata.get("run_result", {})
    err = str(result.get("error", ""))
    if not err:
        return "", ""
    if "controller reported fault" in err:
        return "FAIL", f"the run ended early: {err}"
    return "INVALID", f"the run ended early: {err}"


def measure(q: Quantity, ctx: Context) -> tuple[float, str, str]:
    """(value, verdict, note) of one quantity on one recording's context."""
    kind, why = run_failure(ctx.rec)
    unit, _definition, fn = METRICS[q.metric]
    qctx = ctx.with_source(q.source)
    if q.window_s is not None:
        qctx = qctx.with_window(q.window_s)
    at_least = ""
    try:
        value = float(fn(qctx, **dict(q.params)))
    except MetricAtLeast as exc:
        value, at_least = exc.value, str(exc)
    except MetricUnavailable as exc:
        if kind:
            return math.nan, kind, why
        return math.nan, "INVALID", str(exc)
    except (ValueError, KeyError) as exc:
        return math.nan, "INVALID", f"cannot compute: {exc}"
    if kind == "INVALID":
        return value, kind, why
    if at_least:
        why = (why + "; " if why else "") + at_least
    if kind == "FAIL" and not math.isfinite(value):
        return value, "FAIL", why            # the drive faulted before the window
    if q.not_reproducible:
        return value, "NOT REPRODUCIBLE", q.not_reproducible
    if q.at_speed_rpm is not None:
        octx = qctx.with_window(q.at_speed_window_s) if q.at_speed_window_s else qctx
        why_op = operating_point_note(octx, q.at_speed_rpm)
        if why_op:
            return (value, "FAIL" if q.rule.kind != "compared" else "COMPARED",
                    why_op + ("; " + why if why else ""))
    if kind == "FAIL":
        return value, "FAIL" if q.rule.kind != "compared" else "COMPARED", why
    if at_least and q.rule.kind == "at_most":
        return value, "FAIL", why            # already beyond its bound
    return value, q.rule.verdict(value), why


def evaluate(claim: Claim, ctx: Context, scenario_name: str | None = None) -> list[QuantityResult]:
    """The quantities of ``claim`` measurable in this one recording (``bench check``)."""
    quantities = claim.quantities if scenario_name is None else applicable(claim, scenario_name)
    out = []
    for q in quantities:
        if q.study or q.aggregate or q.metric == "derived":
            continue
        value, verdict, note = measure(q, ctx)
        out.append(QuantityResult(claim, q, value, verdict, note))
    return out


def relate(rel: Relation, values: dict[str, float], not_reproducible: frozenset = frozenset(),
           off_point: frozenset = frozenset()) -> tuple[tuple[float, ...], str, str]:
    """Check a relation on the measured values; a relation over a quantity that is NOT
    REPRODUCIBLE is not reproducible either."""
    vals = tuple(float(k[1:]) if k.startswith("#") else values.get(k, math.nan) for k in rel.keys)
    nr = [k for k in rel.keys if k in not_reproducible]
    if nr:
        return vals, "NOT REPRODUCIBLE", f"{', '.join(nr)} not reproducible on this bench"
    off = [k for k in rel.keys if k in off_point]
    if off:
        return vals, "FAIL", (f"{', '.join(off)}: the drive did not hold the operating point, so "
                              "the comparison does not hold either")
    if not all(math.isfinite(v) for v in vals):
        missing = [k for k, v in zip(rel.keys, vals) if not math.isfinite(v)]
        return vals, "FAIL", f"no measured value for {', '.join(missing)}"
    pairs = list(zip(vals, vals[1:]))
    if rel.op == "<":
        ok = all(a < b for a, b in pairs)
    elif rel.op == ">":
        ok = all(a > b for a, b in pairs)
    elif rel.op == "=":
        ok = all(abs(a - b) < rel.tol for a, b in pairs)
    else:
        raise ValueError(f"{rel.key}: unknown relation {rel.op!r}")
    return vals, "PASS" if ok else "FAIL", ""


def derive(q: Quantity, values: dict[str, float]) -> float:
    """A quantity computed from two others (metric "derived"): op "diff" a - b, "pct" the
    percent change from b to a."""
    p = dict(q.params)
    a, b = values.get(p["a"], math.nan), values.get(p["b"], math.nan)
    if p["op"] == "diff":
        return a - b
    if p["op"] == "pct":
        return metrics.percent_change(b, a)
    raise ValueError(f"{q.key}: unknown derivation {p['op']!r}")


# -- the claims ----------------------------------------------------------------------------------------
# Windows and event times follow the scenario files (each explains its time base).

def _nodt(run: Run) -> Run:
    """The same run with the inverter's dead time and drops off (a diagnostic, not the paper)."""
    return Run(run.id + ".nodt", run.scenario,
               run.overrides + (("plant.inverter_nonlinear", False),),
               (run.label + ", " if run.label else "") + "dead time off (diagnostic)")


def _q(key, what, metric, paper, rule, run=None, **kw) -> Quantity:
    return Quantity(key, what, metric, paper, rule, run, **kw)


YUAN_DT = ("Yuan's hardware had dead time; this bench's improved SMO takes the commanded voltage, "
           "whose dead-time error (about 8 V of fundamental at 10.9 A: (4/pi)(t_dt/Ts V_dc + "
           "drops)) is 25x the 0.32 V back EMF at 10 rpm and 5x the 1.6 V at 50 rpm")

# Yuan Y1 -----------------------------------------------------------------------------------------
_Y1_RUNS = (Run("Y1.improved", "yuan_y1_improved", label="improved SMO closes the loop"),
            Run("Y1.conventional", "yuan_y1_conventional", label="sign SMO closes the loop"))
_Y1_SRC = "Yuan IV.B.1: 'the estimation errors are within +-6 rpm and +-3 rpm ... +-4 rpm and +-1.5 rpm'"


def _y1_quantities() -> tuple[Quantity, ...]:
    out = []
    for run, tag, b50, b10 in (("Y1.improved", "improved", 3.0, 1.5),
                               ("Y1.conventional", "conventional", 6.0, 4.0)):
        for diag in (False, True):
            rid = run + (".nodt" if diag else "")
            sfx = " [dead time off: diagnostic]" if diag else ""
            out.append(_q(f"{rid}.50", f"{tag} SMO: speed-estimation error at 50 rpm{sfx}",
                          "speed_est_error_rpm", b50, at_most(b50, _Y1_SRC), rid,
                          window_s=(3.8, 4.3), at_speed_rpm=50.0, diagnostic=diag))
            out.append(_q(f"{rid}.10", f"{tag} SMO: speed-estimation error at 10 rpm{sfx}",
                          "speed_est_error_rpm", b10, at_most(b10, _Y1_SRC), rid,
                          window_s=(2.8, 3.3), at_speed_rpm=10.0, diagnostic=diag))
    return tuple(out)


# Yuan Y8 -----------------------------------------------------------------------------------------
Y8_SPEEDS = ((50.0, 3.0), (10.0, 1.5), (9.0, 2.0), (8.0, 2.0), (5.0, 2.0))


def _y8_run(rpm: float, diag: bool = False) -> Run:
    handover_rpm = min(rpm, 10.0)
    t_handover = 0.2 + handover_rpm * 2 * math.pi / 60 / 0.5
    dur = round(t_handover + (2.0 if rpm > 10 else 1.5), 2)
    ov: tuple = (("controller.speed_ref_rpm", rpm),
                 ("controller.params.HANDOVER_SPEED_RAD_S", handover_rpm * 2 * math.pi / 60),
                 ("scenario.duration_s", dur), ("metrics.window_s", [dur - 1.0, dur]))
    run = Run(f"Y8.{rpm:g}rpm", "yuan_y8_speeds", ov, f"improved SMO at {rpm:g} rpm")
    return _nodt(run) if diag else run


def _y8_quantities() -> tuple[Quantity, ...]:
    src = "Yuan Table 4, column dn (rpm): the band of the speed-estimation error (Y1's +-3 / +-1.5 rpm)"
    out = []
    for rpm, dn in Y8_SPEEDS:
        for diag in (False, True):
            run = _y8_run(rpm, diag)
            out.append(_q(f"{run.id}", f"improved SMO: speed-estimation error at {rpm:g} rpm"
                          + (" [dead time off: diagnostic]" if diag else ""),
                          "speed_est_error_rpm", dn, at_most(dn, src), run.id,
                          at_speed_rpm=rpm, diagnostic=diag))
    return tuple(out)


# Hou H3 ------------------------------------------------------------------------------------------
H3_ANGLES_DEG = (0, 45, 90, 135, 180)


def _h3_run(angle_deg: float, method: str, diag: bool = False) -> Run:
    ov: tuple = (("plant.initial_theta_e_rad", math.radians(angle_deg)),)
    if method == "bias":
        ov += (("controller.params.HFI_POL_BIAS_A", 2.4),)
    run = Run(f"H3.{method}.{angle_deg:g}deg", "hou_h3_ipd", ov,
              f"{angle_deg:g} deg, {'d-bias' if method == 'bias' else 'HF-only'} polarity test")
    return _nodt(run) if diag else run


def _h3_quantities() -> tuple[Quantity, ...]:
    src = "Hou 4.3: 'the estimation error is within +-1 deg' (Fig. 12, five angles)"
    src_pol = "Hou 4.3: the initial positions 'are well identified' at all five angles (N/S right)"
    out = []
    for method, diag, tag in (("pure", False, "Hou's HF-only polarity test"),
                              ("pure", True, "HF-only test, dead time off [diagnostic]"),
                              ("bias", False, "d-bias polarity test [option, not Hou's]"),
                              ("bias", True, "d-bias test, dead time off [diagnostic]")):
        runs = tuple(_h3_run(a, method, diag).id for a in H3_ANGLES_DEG)
        d = diag or method == "bias"
        sfx = ".nodt" if diag else ""
        out.append(_q(f"H3.{method}{sfx}.error", f"{tag}: largest |error| over 0..180 deg "
                      "(trials with the right polarity)", "ipd_error_deg", 1.0, at_most(1.0, src),
                      runs, aggregate="max_abs", diagnostic=d))
        out.append(_q(f"H3.{method}{sfx}.polarity", f"{tag}: trials with the wrong or no N/S "
                      "polarity (of 5)", "ipd_error_deg", 0.0, at_most(0.0, src_pol), runs,
                      aggregate="polarity_failures", diagnostic=d))
    return tuple(out)


# Gong G6/G7 ----------------------------------------------------------------------------------------

def _g67_run(rpm: float, comp: bool) -> Run:
    dur = {500.0: 1.5, 2000.0: 2.2, 3000.0: 2.8}[rpm]
    ov = (("controller.speed_ref_rpm", rpm), ("controller.params.DELAY_COMP_ENABLE", 2 if comp else 0),
          ("scenario.duration_s", dur), ("metrics.window_s", [dur - 0.5, dur]))
    return Run(f"G67.{rpm:g}.{'on' if comp else 'off'}", "gong_g67_delay_comp", ov,
               f"{rpm:g} rpm, pre-compensation {'on' if comp else 'off'}")


G5_PLANT = ("a limitation of this bench's plant: the inverter is averaged (no PWM ripple), so at no "
            "load the current changes by about w_e I Ts = 7.5 mA per period at 500 rpm, under one "
            "LSB of the 12-bit ADC (9.8 mA): eq. 20's numerator is mostly quantisation (a third "
            "of the periods read 0 us). Gong's hardware current has its PWM ripple, which eq. 20 "
            "relies on (assumption 1: linear current while a vector acts)")

G1_MS = ((1.0, 41.5), (0.25, 18.6), (0.1, 9.5), (0.01, 1.7))
G1_UNSTABLE = ("at 10 kHz the sampled observer's error loop i~[k] = (F - G k m) i~[k-1] needs "
               "k m < (1 + F)/G = 40 V/A to converge; eq. 17 gives k >= 463 V for any xi, so "
               "k m >= 463 m V/A: unstable for m > 0.086 (docs/estimators_smo.md). The "
               "observer chatters without tracking; the paper's value needs a simulation step "
               "it does not give")


def _claims() -> tuple[Claim, ...]:
    y_src4 = "Yuan IV.C: THD from ... to ... (no bound, no scatter)"
    y4_runs = (Run("Y4.10.off", "yuan_y4_10rpm"), Run("Y4.10.on", "yuan_y4_10rpm_comp"),
               Run("Y4.50.off", "yuan_y4_50rpm"), Run("Y4.50.on", "yuan_y4_50rpm_comp"))
    y4_q = []
    y4_rel = []
    for rpm, off, on in ((10, (8.06, 4.08, 4.11), (6.01, 2.18, 2.61)),
                         (50, (7.03, 4.62, 4.36), (3.87, 1.71, 1.77))):
        for state, vals in (("off", off), ("on", on)):
            for metric, val, name in zip(("current_thd_percent", "current_h5_percent",
                                          "current_h7_percent"), vals, ("THD", "5th", "7th")):
                note = ""
                if rpm == 10 and state == "off" and name == "THD":
                    note = ("calibration point: the plant's dead time (1.78 us) is fitted to this "
                            "number (plant_rt/README.md), so this row cannot test anything")
                y4_q.append(_q(f"Y4.{rpm}.{state}.{name}",
                               f"{rpm} rpm {name} {'with' if state == 'on' else 'without'} "
                               "compensation", metric, val,
                               compared(note or y_src4), f"Y4.{rpm}.{state}"))
        for name in ("THD", "5th", "7th"):
            y4_rel.append(Relation(f"Y4.{rpm}.{name}", f"{rpm} rpm: {name} falls with the "
                                   "compensation", (f"Y4.{rpm}.on.{name}", f"Y4.{rpm}.off.{name}"),
                                   "<", "decreases", "Yuan IV.C: 'significantly decrease'"))

    y8_runs = tuple(_y8_run(rpm, d) for rpm, _ in Y8_SPEEDS for d in (False, True))
    h3_runs = tuple(_h3_run(a, m, d) for m in ("pure", "bias") for d in (False, True)
                    for a in H3_ANGLES_DEG)
    g67_runs = tuple(_g67_run(rpm, c) for rpm in (500.0, 2000.0, 3000.0) for c in (False, True))
    h1_runs = (Run("H1.hfi", "hou_h1_hfi", label="HFI + SDFT closes the loop"),
               Run("H1.smo", "hou_h1_smo", label="sign SMO closes the loop"))
    h2_runs = (Run("H2.hfi", "hou_h2_hfi"), Run("H2.smo", "hou_h2_smo"))
    y2_runs = (Run("Y2.improved", "yuan_y2_improved"), Run("Y2.conventional", "yuan_y2_conventional"))

    def pair_rel(prefix, a, b, what, paper, source, diag=False):
        return Relation(prefix, what, (a, b), "<", paper, source, diag)

    gong_iq_src = ("Gong V-B: 'reduces by 0.04 A (4.6%)', '6.1% smaller', '7.5% lower' "
                   "(no scatter given)")
    g6_q = []
    for rpm, lag, iq in ((500.0, None, -4.6), (2000.0, 0.03, -6.1), (3000.0, 0.045, -7.5)):
        w = {500.0: (1.0, 1.5), 2000.0: (1.7, 2.2), 3000.0: (2.3, 2.8)}[rpm]
        for state in ("off", "on"):
            g6_q.append(_q(f"G6.{rpm:g}.{state}.pee_mean", f"{rpm:g} rpm mean angle error, "
                           f"compensation {state}", "pee_mean_rad", "(Fig. 15: a lag)",
                           compared("Gong Fig. 15 (the difference is the claim)"),
                           f"G67.{rpm:g}.{state}", window_s=w, at_speed_rpm=rpm))
            g6_q.append(_q(f"G6.{rpm:g}.{state}.iq", f"{rpm:g} rpm mean i_q, compensation {state}",
                           "iq_mean_a", {500.0: "0.87 A (from '0.04 A (4.6%)')", 2000.0: "1.15 A",
                                         3000.0: "(not given)"}[rpm] if state == "off" else
                           {500.0: "-0.04 A", 2000.0: "1.08 A", 3000.0: "(not given)"}[rpm],
                           compared(gong_iq_src), f"G67.{rpm:g}.{state}", window_s=w,
                           at_speed_rpm=rpm))
    td_s = 34.1e-6
    for rpm, lag in ((2000.0, 0.03), (3000.0, 0.045)):
        wtd = rpm / 60 * 2 * math.pi * 4 * td_s
        g6_q.append(_q(f"G6.{rpm:g}.lag", f"{rpm:g} rpm: lag removed (mean PEE with - without; "
                       f"w t_d = {wtd:.4f} rad)", "derived", lag,
                       compared("Gong Fig. 15 / VI: 'about 0.03 and 0.045 rad' (no bound)"),
                       params=(("op", "diff"), ("a", f"G6.{rpm:g}.on.pee_mean"),
                               ("b", f"G6.{rpm:g}.off.pee_mean"), ("unit", "rad"))))
    for rpm, iq in ((500.0, -4.6), (2000.0, -6.1), (3000.0, -7.5)):
        g6_q.append(_q(f"G6.{rpm:g}.iq_change", f"{rpm:g} rpm: i_q change with compensation",
                       "derived", iq, compared(gong_iq_src),
                       params=(("op", "pct"), ("a", f"G6.{rpm:g}.on.iq"),
                               ("b", f"G6.{rpm:g}.off.iq"), ("unit", "%"))))
    return (
        Claim("Y1", "Yuan (000), IV.B.1, Fig. 13-14",
              "speed step 10 -> 50 rpm with full load: speed-estimation error conventional SMO "
              "+-4 rpm (10 rpm) / +-6 rpm (50 rpm), improved SMO +-1.5 / +-3 rpm",
              _y1_quantities(), _Y1_RUNS + tuple(_nodt(r) for r in _Y1_RUNS),
              (pair_rel("Y1.50", "Y1.improved.50", "Y1.conventional.50",
                        "50 rpm: improved error < conventional", "3 < 6 rpm", _Y1_SRC),
               pair_rel("Y1.10", "Y1.improved.10", "Y1.conventional.10",
                        "10 rpm: improved error < conventional", "1.5 < 4 rpm", _Y1_SRC),
               pair_rel("Y1.50.nodt", "Y1.improved.nodt.50", "Y1.conventional.nodt.50",
                        "50 rpm, dead time off [diagnostic]", "3 < 6 rpm", _Y1_SRC, True),
               pair_rel("Y1.10.nodt", "Y1.improved.nodt.10", "Y1.conventional.nodt.10",
                        "10 rpm, dead time off [diagnostic]", "1.5 < 4 rpm", _Y1_SRC, True)),
              setup="yuan2020 (reconstructed), dead time + drops, 12-bit ADC, 34.1 us delay; full "
                    "load = rated 5 N m as a brake; each SMO closes the loop in its own run",
              notes=YUAN_DT + ". The diagnostic rows run the same drive without dead time."),
        Claim("Y2", "Yuan (000), IV.B.2, Fig. 15-16",
              "load step 0 -> rated at 10 rpm: estimator response time 6.5 ms (conventional) vs "
              "4.1 ms (improved)",
              tuple(_q(f"{rid}.resp", f"{tag}: estimator response time{sfx}", "response_time_ms",
                       val, compared("Yuan IV.B.2: 'the dynamic response times are 6.5 ms and "
                                     "4.1 ms' (no bound, figures lost)"), rid,
                       window_s=(1.0, 1.6), params=(("t_event_s", 1.2),), at_speed_rpm=10.0,
                       at_speed_window_s=(0.9, 1.2), diagnostic=bool(sfx))
                    for rid0, tag, val in (("Y2.improved", "improved SMO", 4.1),
                                           ("Y2.conventional", "conventional SMO", 6.5))
                    for rid, sfx in ((rid0, ""), (rid0 + ".nodt", " [dead time off: diagnostic]"))),
              y2_runs + tuple(_nodt(r) for r in y2_runs),
              (pair_rel("Y2.rel", "Y2.improved.resp", "Y2.conventional.resp",
                        "improved responds faster", "4.1 < 6.5 ms", "Yuan IV.B.2"),
               pair_rel("Y2.rel.nodt", "Y2.improved.nodt.resp", "Y2.conventional.nodt.resp",
                        "improved faster, dead time off [diagnostic]", "4.1 < 6.5 ms",
                        "Yuan IV.B.2", True)),
              setup="yuan2020, dead time + drops, ADC, delay; 10 rpm no load, then an active "
                    "5 N m step (dyno in torque mode) at 1.2 s",
              notes=YUAN_DT),
        Claim("Y3", "Yuan (000), IV.B.3, Fig. 17",
              "chattering: the trajectory of estimated vs measured current is tighter for the "
              "improved SMO",
              (_q("Y3.conventional", "sign SMO: RMS distance from the sliding surface",
                  "chattering_a", "(Fig. 17, no number)", compared("Yuan Fig. 17 (trajectory)"),
                  "Y3", params=(("estimator", "SMO_SIGN"),)),
               _q("Y3.improved", "improved SMO: RMS distance from the sliding surface",
                  "chattering_a", "(Fig. 17, no number)", compared("Yuan Fig. 17 (trajectory)"),
                  "Y3", params=(("estimator", "SMO_SIGMOID"),))),
              (Run("Y3", "yuan_y3_chattering"),),
              (pair_rel("Y3.rel", "Y3.improved", "Y3.conventional",
                        "improved SMO chatters less", "'improved considerably'",
                        "Yuan IV.B.3"),),
              setup="encoder loop at 50 rpm full load (brake), dead time, ADC, delay; both SMOs "
                    "(library settings) replayed on the same samples"),
        Claim("Y4", "Yuan (000), IV.C, Fig. 18-21",
              "phase-current THD without -> with GSDFT compensation: 10 rpm 8.06 -> 6.01 % "
              "(5th 4.08 -> 2.18, 7th 4.11 -> 2.61); 50 rpm 7.03 -> 3.87 % (5th 4.62 -> 1.71, "
              "7th 4.36 -> 1.77)",
              tuple(y4_q), y4_runs, tuple(y4_rel),
              setup="yuan2020, dead time + drops (calibrated at 10 rpm), encoder loop at the "
                    "calibration point (50 Hz current loop, 0.5 N m)",
              notes="The dead time is fitted to the 10 rpm uncompensated THD (declared; that row "
                    "cannot test anything). Independent of the fit: the 50 rpm rows, the 5th/7th "
                    "split and every compensated row. The loop closes on the encoder: with dead "
                    "time the improved SMO does not hold 10 rpm (Y1)."),
        Claim("Y5", "Yuan (000), IV.A.1, Fig. 11-12",
              "input sin(500 pi t), amplitude 1 -> 2 at 0.2 s: GSDFT tracks in about 2 cycles, "
              "SDFT in about 5",
              tuple(_q(f"Y5.{name}.{phase}", f"{name} tracking time, {phase}", "study",
                       paper, within(paper - 0.5, paper + 0.5, "Yuan IV.A.1: 'approximately two "
                                     "cycles ... approximately five cycles', read in whole "
                                     "cycles: [N - 0.5, N + 0.5)"),
                       study="Y5", params=(("key", f"{name}.{phase}"), ("unit", "cycles")))
                    for name, paper in (("GSDFT", 2.0), ("SDFT", 5.0))
                    for phase in ("start", "step"))
              + tuple(_q(f"Y5.{name}.window", f"{name} exactly settled (window full)", "study",
                         paper, compared("the FIR's taps: M/3 and M samples; settled M/3 - 1 and "
                                         "M - 1 samples after the first new one"), study="Y5",
                         params=(("key", f"{name}.window"), ("unit", "cycles")))
                      for name, paper in (("GSDFT", 2.0), ("SDFT", 5.0))),
              relations=(Relation("Y5.rel", "GSDFT tracks faster than SDFT",
                                  ("Y5.GSDFT.step", "Y5.SDFT.step"), "<", "2 < 5 cycles",
                                  "Yuan IV.A.1"),),
              studies=("Y5",),
              setup="the C library's SDFT and GSDFT (bin k = 5 of M = 24: the tone is the 5th "
                    "harmonic of a window spanning one 50 Hz period, fs = 1200 Hz, the paper's "
                    "M = 24, k = 5 example); tracking = within 2 % of the final amplitude for good"),
        Claim("Y6", "Yuan (000), IV.A.1, Table 2",
              "execution time of the 5th + 7th extraction: GSDFT about 44.82 % less than SDFT",
              (_q("Y6.saving", "GSDFT saving vs SDFT (protected form, real input)", "study",
                  44.82, compared("Yuan Table 2 (DSP timings, lost)"), study="Y6",
                  params=(("key", "saving_protected"), ("unit", "%"))),
               _q("Y6.saving.direct", "GSDFT saving vs SDFT (papers' direct recursion)", "study",
                  44.82, compared("Yuan Table 2 (DSP timings, lost)"), study="Y6",
                  params=(("key", "saving_direct"), ("unit", "%")))),
              relations=(Relation("Y6.rel", "GSDFT cheaper than SDFT",
                                  ("#0", "Y6.saving"), "<", "saving 44.82 % > 0",
                                  "Yuan Table 2"),),
              studies=("Y6",),
              setup="x86-64 instructions per sample by callgrind (python -m bench.perf.estimators),"
                    " not C28x cycles",
              notes="The bench counts host instructions of this library's C; the paper timed its "
                    "own DSP code. The relation (GSDFT cheaper) is what carries over."),
        Claim("Y7", "Yuan (000), IV.A.2, Table 3",
              "steady-state extraction results of GSDFT and SDFT identical",
              tuple(_q(f"Y7.{ext}.{h}", f"{h}th by {ext.upper()} (harm_comp, M = 96)",
                       "harmonic_extraction_pp", "(Table 3 lost)",
                       compared("Yuan Table 3 (lost)"), "Y4.10.off", window_s=(0.9, 4.0),
                       params=(("order", h), ("extractor", ext)))
                    for h in (5, 7) for ext in ("sdft", "gsdft")),
              (Run("Y4.10.off", "yuan_y4_10rpm"),),
              (Relation("Y7.5", "5th: SDFT and GSDFT equal to 2 decimals",
                        ("Y7.sdft.5", "Y7.gsdft.5"), "=", "identical",
                        "Yuan IV.A.2 'identical'; read at the paper's print precision for "
                        "harmonic percentages (two decimals: |difference| < 0.005 points)",
                        tol=0.005),
               Relation("Y7.7", "7th: SDFT and GSDFT equal to 2 decimals",
                        ("Y7.sdft.7", "Y7.gsdft.7"), "=", "identical",
                        "Yuan IV.A.2 'identical'; two decimals", tol=0.005)),
              setup="the 10 rpm phase current of yuan_y4_10rpm (the paper's example is the "
                    "current of its Fig. 2, the same operating point)"),
        Claim("Y8", "Yuan (000), IV.C, Table 4",
              "improved SMO speed-estimation error: 50 rpm 3, 10 rpm 1.5, 9 rpm 2, 8 rpm 2, "
              "5 rpm 2 rpm - still works at 5 rpm",
              _y8_quantities(), y8_runs,
              setup="as Y1 (improved SMO closes the loop, full load as a brake, dead time, ADC, "
                    "delay), one constant speed per run",
              notes=YUAN_DT),
        Claim("H1", "Hou (001), 4.2, Fig. 7-8",
              "0 -> 10 rpm with full load, 10 -> 50 rpm: SMO error +-4 rpm at 10 and +-6 at 50; "
              "HF injection + SDFT +-1.5 and +-3 rpm",
              tuple(_q(f"{rid}.{rpm}", f"{tag}: speed-estimation error at {rpm} rpm{sfx}",
                       "speed_est_error_rpm", b, at_most(b, "Hou 4.2: 'the estimation errors "
                                                             "are about +-6 rpm and +-4 rpm ... "
                                                             "+-3 rpm and +-1.5 rpm'"), rid,
                       window_s=w, at_speed_rpm=float(rpm), diagnostic=bool(sfx))
                    for rid0, tag, wins in (("H1.hfi", "HFI + SDFT", ((10, 1.5, (2.0, 2.4)),
                                                                     (50, 3.0, (2.8, 3.2)))),
                                            ("H1.smo", "SMO", ((10, 4.0, (2.9, 3.3)),
                                                               (50, 6.0, (3.7, 4.1)))))
                    for rid, sfx in ((rid0, ""), (rid0 + ".nodt", " [dead time off: diagnostic]"))
                    for rpm, b, w in wins),
              h1_runs + tuple(_nodt(r) for r in h1_runs),
              (pair_rel("H1.10", "H1.hfi.10", "H1.smo.10", "10 rpm: HFI error < SMO",
                        "1.5 < 4 rpm", "Hou 4.2"),
               pair_rel("H1.50", "H1.hfi.50", "H1.smo.50", "50 rpm: HFI error < SMO",
                        "3 < 6 rpm", "Hou 4.2"),
               pair_rel("H1.10.nodt", "H1.hfi.nodt.10", "H1.smo.nodt.10",
                        "10 rpm, dead time off [diagnostic]", "1.5 < 4 rpm", "Hou 4.2", True),
               pair_rel("H1.50.nodt", "H1.hfi.nodt.50", "H1.smo.nodt.50",
                        "50 rpm, dead time off [diagnostic]", "3 < 6 rpm", "Hou 4.2", True)),
              setup="hou2021, saturation, dead time + drops, 12-bit ADC, 34.1 us delay; full "
                    "load = 6.5 N m as a brake; HFI (Hou's HF-only polarity test) and the sign "
                    "SMO (Ls = Lq, for Hou's [8]) each close the loop in their own run",
              notes="Hou's numbers for H1 and H2 are Yuan's Y1/Y2 numbers (+-6/+-4, +-3/+-1.5 rpm, "
                    "6.5/4.1 ms; Yuan is Hou's ref. [14])."),
        Claim("H2", "Hou (001), 4.2, Fig. 9-10",
              "load step 0 -> rated at 10 rpm: response 6.5 ms (SMO) vs 4.1 ms (HFI); speed drop "
              "2 rpm vs 1.2 rpm",
              tuple(_q(f"{rid}.resp", f"{tag}: estimator response time{sfx}", "response_time_ms",
                       resp, compared("Hou 4.2: 'the dynamic response times are 6.5 ms and "
                                      "4.1 ms' (no bound)"), rid, window_s=(0.6, 1.2),
                       params=(("t_event_s", 0.8),), at_speed_rpm=10.0,
                       at_speed_window_s=(0.5, 0.8), diagnostic=bool(sfx))
                    for rid0, tag, resp, _ in (("H2.hfi", "HFI", 4.1, 1.2),
                                               ("H2.smo", "SMO", 6.5, 2.0))
                    for rid, sfx in ((rid0, ""), (rid0 + ".nodt", " [dead time off: diagnostic]")))
              + tuple(_q(f"{rid}.drop", f"{tag}: speed drop after the load step{sfx}",
                         "speed_dip_rpm", drop,
                         compared("Hou 4.2: 'the speed drop is about 2 rpm and 1.2 rpm' (no "
                                  "bound)"), rid, window_s=(0.8, 1.2),
                         params=(("t_event_s", 0.8),), at_speed_rpm=10.0,
                         at_speed_window_s=(0.5, 0.8), diagnostic=bool(sfx),
                         not_reproducible=("6.5 N m on Table 1's J = 0.00107 kg m^2 decelerates "
                                           "at 6075 rad/s^2: the dip is about (T_L/J) t_r/2 = "
                                           "119 rpm for the paper's own t_r = 4.1 ms (10 rpm "
                                           "stops in 0.17 ms); 1.2 rpm needs J >= 0.1 kg m^2 "
                                           "(docs/claims.md)") if not sfx else "")
                      for rid0, tag, _, drop in (("H2.hfi", "HFI", 4.1, 1.2),
                                                 ("H2.smo", "SMO", 6.5, 2.0))
                      for rid, sfx in ((rid0, ""), (rid0 + ".nodt",
                                                    " [dead time off: diagnostic]"))),
              h2_runs + tuple(_nodt(r) for r in h2_runs),
              (pair_rel("H2.resp", "H2.hfi.resp", "H2.smo.resp", "HFI responds faster",
                        "4.1 < 6.5 ms", "Hou 4.2"),
               pair_rel("H2.drop", "H2.hfi.drop", "H2.smo.drop", "HFI drops less",
                        "1.2 < 2 rpm", "Hou 4.2"),
               pair_rel("H2.resp.nodt", "H2.hfi.nodt.resp", "H2.smo.nodt.resp",
                        "HFI faster, dead time off [diagnostic]", "4.1 < 6.5 ms", "Hou 4.2",
                        True),
               pair_rel("H2.drop.nodt", "H2.hfi.nodt.drop", "H2.smo.nodt.drop",
                        "HFI drops less, dead time off [diagnostic]", "1.2 < 2 rpm",
                        "Hou 4.2", True)),
              setup="hou2021, saturation, dead time + drops, ADC, delay; 10 rpm no load, active "
                    "6.5 N m step (dyno in torque mode) at 0.8 s"),
        Claim("H3", "Hou (001), 4.3, Fig. 11-12",
              "initial position at 0, 45, 90, 135, 180 deg: error within +-1 deg, N/S polarity "
              "right",
              _h3_quantities(), h3_runs,
              setup="hou2021, saturation, dead time + drops, 12-bit ADC, delay; standstill HF "
                    "injection (6 V, 1250 Hz); one run per angle",
              notes="Hou's test compares the HF current along theta^ and theta^ + pi with the HF "
                    "current alone: the N/S difference is second order in the HF amplitude "
                    "(0.7 % here, plant_rt/README.md). The d-bias test is first order (1.2x)."),
        Claim("G1", "Gong (002), V-A-a, Fig. 7",
              "tanh SMO at the corner speed, THD of the estimated EMF vs m: 41.5 % (m = 1), "
              "18.6 % (0.25), 9.5 % (0.1), 1.7 % (0.01); the EMF amplitude falls as m falls",
              tuple(_q(f"G1.m{m:g}.thd", f"m = {m:g}: THD of the estimated EMF", "emf_thd_percent",
                       thd, compared("Gong V-A-a (no bound)"), "G1",
                       source=f"reference:SMO_TANH:m{m:g}",
                       not_reproducible=G1_UNSTABLE if m >= 0.1 else "")
                    for m, thd in G1_MS)
              + tuple(_q(f"G1.m{m:g}.amp", f"m = {m:g}: amplitude of the estimated EMF",
                         "emf_amplitude_v", "(falls as m falls)",
                         compared("Gong V-A-a, Fig. 7(e)"), "G1",
                         source=f"reference:SMO_TANH:m{m:g}",
                         not_reproducible=G1_UNSTABLE if m >= 0.1 else "") for m, _ in G1_MS),
              (Run("G1", "gong_g1_boundary_layer"),),
              (Relation("G1.thd", "THD falls as m falls (1 > 0.25 > 0.1 > 0.01)",
                        tuple(f"G1.m{m:g}.thd" for m, _ in G1_MS), ">",
                        "41.5 > 18.6 > 9.5 > 1.7 %", "Gong V-A-a"),
               Relation("G1.amp", "EMF amplitude falls as m falls",
                        tuple(f"G1.m{m:g}.amp" for m, _ in G1_MS), ">", "'goes down'",
                        "Gong V-A-a")),
              setup="gong2020 ideal plant, no calculation delay (the paper's simulation); m = 0.01 "
                    "closes the loop at 500 rpm, the four observers (k by eq. 17, xi = 23.98 A) "
                    "run as host references on the same samples"),
        Claim("G2", "Gong (002), V-A-b, Fig. 8, Table III",
              "500 rpm steady state: speed fluctuation +-7.5 rpm, PEE within +-0.1 rad, EMF THD "
              "1.7 %, no-load phase current about 0.5 A",
              (_q("G2.sf", "speed fluctuation (estimated speed)", "speed_band_hat_rpm", 7.5,
                  at_most(7.5, "Gong V-A-b: 'slight fluctuations of +-7.5 rpm'"), "G2",
                  at_speed_rpm=500.0),
               _q("G2.pee", "position-estimation error", "pee_max_rad", 0.1,
                  at_most(0.1, "Gong V-A-b: 'within +-0.1 rad'"), "G2"),
               _q("G2.thd", "THD of the estimated back EMF", "emf_thd_percent", 1.7,
                  compared("Gong V-A-b / Table III (no bound)"), "G2"),
               _q("G2.current", "no-load phase current amplitude", "phase_current_amp_a", 0.5,
                  compared("Gong V-A-b: 'about 0.5 A'"), "G2")),
              (Run("G2", "gong_g2_500rpm"),),
              setup="gong2020 ideal plant, no calculation delay; tanh SMO (m = 0.01) closes the "
                    "loop",
              notes="The ideal averaged plant has no PWM ripple, noise or quantisation, so the "
                    "EMF THD comes only from the sampled observer (a plant limitation). Table I's "
                    "B gives i_q = B w / (1.5 p psi_f) = 0.359 A at 500 rpm, not 0.5 A."),
        Claim("G3", "Gong (002), V-A-b, Fig. 9, Table III",
              "2000 rpm: speed fluctuation +-24 rpm, EMF THD 0.8 %, PEE within +-0.05 rad",
              (_q("G3.sf", "speed fluctuation (estimated speed)", "speed_band_hat_rpm", 24.0,
                  at_most(24.0, "Gong V-A-b: 'the speed fluctuation becomes +-24 rpm'"), "G3",
                  at_speed_rpm=2000.0),
               _q("G3.pee", "position-estimation error", "pee_max_rad", 0.05,
                  at_most(0.05, "Gong V-A-b: 'approximately within +-0.05 rad'"), "G3"),
               _q("G3.thd", "THD of the estimated back EMF", "emf_thd_percent", 0.8,
                  compared("Gong V-A-b / Table III (no bound)"), "G3")),
              (Run("G3", "gong_g3_2000rpm"),),
              setup="gong2020 ideal plant, no calculation delay; tanh SMO (m = 0.01)"),
        Claim("G4", "Gong (002), V-A-c, Fig. 10",
              "1000 -> 1200 rpm at 0.15 s and back at 0.25 s (overshoot 55 and 42 rpm); 2 N m "
              "load at 0.1 s, removed at 0.2 s; PEE up to 0.25 rad while accelerating",
              (_q("G4.up", "overshoot 1000 -> 1200 rpm", "step_overshoot_rpm", 55.0,
                  compared("Gong V-A-c: 'overshoot is 55 rpm (4.6%)' (no bound)"), "G4",
                  window_s=(1.65, 1.75), params=(("t_step_s", 1.65),)),
               _q("G4.down", "overshoot 1200 -> 1000 rpm", "step_overshoot_rpm", 42.0,
                  compared("Gong V-A-c: '42 (4.2%) rpm' (no bound)"), "G4",
                  window_s=(1.75, 2.0), params=(("t_step_s", 1.75),)),
               _q("G4.pee", "PEE while accelerating (1.65..1.75 s)", "pee_max_rad", 0.25,
                  at_most(0.25, "Gong V-A-c: 'an obvious growth up to 0.25 rad'"), "G4",
                  window_s=(1.65, 1.75))),
              (Run("G4", "gong_g4_dynamics"),),
              setup="gong2020 ideal plant, no calculation delay; tanh SMO; the paper's events "
                    "shifted by 1.5 s (the bench starts from standstill)",
              notes="The overshoots are the speed loop's (the paper's is not given) more than the "
                    "observer's."),
        Claim("G5", "Gong (002), V-B, Table II",
              "dual-sampling estimate of the computation delay: about 34.1 us (15 periods)",
              (_q("G5.td", "eq. 20 delay estimate (mean over the window)", "delay_estimate_us",
                  34.1, within(33.2, 35.3 + 1e-9, "Gong Table II: the 15 per-period values span "
                               "33.2 .. 35.3 us"), "G5", at_speed_rpm=500.0,
                  not_reproducible=G5_PLANT),
               _q("G5.exact.td", "eq. 20 delay estimate, ADC off (exact samples) [diagnostic]",
                  "delay_estimate_us", 34.1, within(33.2, 35.3 + 1e-9, "Gong Table II"),
                  "G5.exact", at_speed_rpm=500.0, diagnostic=True)),
              (Run("G5", "gong_g5_delay"),
               Run("G5.exact", "gong_g5_delay", (("plant.adc_model", False),),
                   "ADC off: exact samples (diagnostic)")),
              setup="gong2020, dead time + drops, ADC, dual sampling, 34.1 us delay; tanh SMO "
                    "without pre-compensation at 500 rpm no load",
              notes="The plant's delay is set to Table II's mean (the profile): this row tests "
                    "whether eq. 20 recovers it from the samples, not the paper's hardware."),
        Claim("G6", "Gong (002), V-B, Fig. 12-15",
              "delay pre-compensation removes a position lag of about 0.03 rad at 2000 rpm and "
              "0.045 rad at 3000 rpm; i_q falls 4.6 % (500 rpm), 6.1 % (2000), 7.5 % (3000)",
              tuple(g6_q), g67_runs,
              (Relation("G6.lag2000", "2000 rpm: compensation advances the angle (lag removed)",
                        ("G6.2000.off.pee_mean", "G6.2000.on.pee_mean"), "<", "about 0.03 rad",
                        "Gong Fig. 15"),
               Relation("G6.lag3000", "3000 rpm: compensation advances the angle",
                        ("G6.3000.off.pee_mean", "G6.3000.on.pee_mean"), "<", "about 0.045 rad",
                        "Gong Fig. 15")),
              setup="gong2020, dead time + drops, ADC, dual sampling, 34.1 us delay; tanh SMO "
                    "closes the loop without / with pre-compensation (eq. 20 estimate)",
              notes="Derived rows (report): the lag removed = mean PEE with - without, beside "
                    "w t_d; the i_q change in %. At no load the steady torque is B w + friction "
                    "whatever the angle estimate, so i_q can only change through 1/cos(PEE): "
                    "< 0.5 % for |PEE| < 0.1 rad (docs/claims.md, G6)."),
        Claim("G7", "Gong (002), V-B, Table III",
              "500 rpm SF 35 / 33 rpm, EMF THD 1.25 / 1.23 %, PEE < 0.2 rad; 2000 rpm SF 54 / "
              "51 rpm, THD 0.64 / 0.62 %, PEE < 0.1 rad (without / with compensation)",
              tuple(q for rpm, sfs, thds, pee in ((500.0, (35.0, 33.0), (1.25, 1.23), 0.2),
                                                  (2000.0, (54.0, 51.0), (0.64, 0.62), 0.1))
                    for state, sf, thd in (("off", sfs[0], thds[0]), ("on", sfs[1], thds[1]))
                    for q in (
                        _q(f"G7.{rpm:g}.{state}.sf", f"{rpm:g} rpm SF, compensation {state}",
                           "speed_band_hat_rpm", sf, at_most(sf, "Gong Table III: SF (rpm)"),
                           f"G67.{rpm:g}.{state}", window_s=_g67_window(rpm),
                           at_speed_rpm=rpm),
                        _q(f"G7.{rpm:g}.{state}.thd", f"{rpm:g} rpm EMF THD, compensation {state}",
                           "emf_thd_percent", thd, compared("Gong Table III (no bound)"),
                           f"G67.{rpm:g}.{state}", window_s=_g67_window(rpm)),
                        _q(f"G7.{rpm:g}.{state}.pee", f"{rpm:g} rpm PEE, compensation {state}",
                           "pee_max_rad", pee, at_most(pee, f"Gong Table III: PEE < {pee:g} rad"),
                           f"G67.{rpm:g}.{state}", window_s=_g67_window(rpm)))),
              g67_runs[:4],
              tuple(Relation(f"G7.{rpm:g}.{m}", f"{rpm:g} rpm: {m.upper()} with <= without",
                             (f"G7.{rpm:g}.on.{m}", f"G7.{rpm:g}.off.{m}"), "<",
                             "33 < 35, 51 < 54 rpm; 1.23 < 1.25, 0.62 < 0.64 %",
                             "Gong Table III")
                    for rpm in (500.0, 2000.0) for m in ("sf", "thd")),
              setup="as G6, at 500 and 2000 rpm"),
        Claim("G8", "Gong (002), V-B, Fig. 16",
              "2 N m load at 1000 rpm: dip to about 977 rpm; +18 rpm on unload; 1000 -> 1200 rpm "
              "settles in about 0.1 s with about 10 rpm overshoot (6 rpm on the way back)",
              (_q("G8.dip", "speed dip on the 2 N m load", "speed_dip_rpm", 23.0,
                  compared("Gong V-B: 'decreases to 977 from 1000 rpm' (no bound)"), "G8",
                  window_s=(1.6, 2.0), params=(("t_event_s", 1.6),)),
               _q("G8.rise", "speed rise on unload", "speed_dip_rpm", 18.0,
                  compared("Gong V-B: 'a rise of 18 rpm' (no bound)"), "G8",
                  window_s=(2.0, 2.4), params=(("t_event_s", 2.0), ("sign", -1.0))),
               _q("G8.settle", "1000 -> 1200 rpm settling time (+-1 % of 1200 rpm)",
                  "settling_time_s", 0.1, compared("Gong V-B: 'about 0.1 s' (no bound)"), "G8",
                  window_s=(2.4, 2.8), params=(("t_step_s", 2.4), ("band_rpm", 12.0))),
               _q("G8.up", "overshoot 1000 -> 1200 rpm", "step_overshoot_rpm", 10.0,
                  compared("Gong V-B: 'only 10 rpm' (no bound)"), "G8", window_s=(2.4, 2.8),
                  params=(("t_step_s", 2.4),)),
               _q("G8.down", "overshoot 1200 -> 1000 rpm", "step_overshoot_rpm", 6.0,
                  compared("Gong V-B: 'an overshoot of 6 rpm' (no bound)"), "G8",
                  window_s=(2.8, 3.2), params=(("t_step_s", 2.8),)),
               _q("G8.pee", "PEE after the speed settled (3.0..3.2 s)", "pee_max_rad", 0.15,
                  at_most(0.15, "Gong V-B: 'the estimation accuracy will resume ... (within "
                                "0.15 rad)'"), "G8", window_s=(3.0, 3.2))),
              (Run("G8", "gong_g8_dynamics"),),
              setup="gong2020, dead time + drops, ADC, dual sampling, 34.1 us delay; tanh SMO + "
                    "pre-compensation; events 0.4 s apart (the paper gives no times)",
              notes="Dip, rise and overshoots are the speed loop's (not given in the paper)."),
    )


def _g67_window(rpm: float) -> tuple[float, float]:
    dur = {500.0: 1.5, 2000.0: 2.2, 3000.0: 2.8}[rpm]
    return (dur - 0.5, dur)


CLAIMS: dict[str, Claim] = {c.id: c for c in _claims()}


def all_runs(claim_ids=None) -> dict[str, Run]:
    """Every run the claims need, by run id (a run shared by two claims appears once)."""
    out: dict[str, Run] = {}
    for c in CLAIMS.values():
        if claim_ids is not None and c.id not in claim_ids:
            continue
        for r in c.runs:
            out.setdefault(r.id, r)
    return out
