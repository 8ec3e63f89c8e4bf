"""The definitions of the papers' claims: per claim, the runs that reproduce it, the metric of
each quantity, the paper's value and an acceptance rule taken from the paper. The claims
themselves are data (bench/claims/*.toml, read by registry.py); their verdicts are computed by
hil_bench.papers.claims.

A claim (``Y1`` .. ``G8``, /work/shared/papers/README.md) has

* **runs**: recordings of bundled scenarios (``bench/scenarios``), possibly with overrides (a
  speed, an angle, an effect switched off) - each run has a name and its scenario is attached
  to its recording, so ``bench check`` works on it;
* **quantities**: a metric (``METRIC_DEFINITIONS``) of one run (or of several, aggregated), the estimate it
  is computed on (``source``: the controller's telemetry or ``reference:<label>``), the window,
  the paper's value and a **rule**:

  - ``at_most(x)`` - the paper states a bound ("within +-0.1 rad", "+-x rpm", "< 0.2 rad"): a
    measured value <= x passes;
  - ``within(lo, hi)`` - the paper's own statement of its measurement gives the interval (the
    scatter of Table II; "approximately two cycles" read in whole cycles);
  - ``compared()`` - the paper reports a value without a bound and says nothing about its
    measurement's resolution or scatter: the value is compared, no pass/fail (verdict COMPARED);

* **relations** between two quantities the paper ranks ("the improved SMO's error is smaller"),
  checked as stated; where the paper only reports both values and calls the difference
  "slight" (``compared = true``), the ordering is shown and the verdict is COMPARED.

Every rule carries its source (section, table, the paper's words). A quantity may be marked
``diagnostic`` (a run that is not the paper's setup, e.g. the same run without dead time, to
locate a failure) or ``not_reproducible`` (with the reason the paper's number cannot come out of
this bench); its measured value is shown all the same.

Verdicts: PASS, FAIL, COMPARED (value compared, no pass/fail), INVALID (the bench could not
measure: the run broke, the window is empty), NOT REPRODUCIBLE (reason given), NOT RESOLVED (a
relation whose difference is below the resolution of what it was measured from, e.g. one LSB of
the controller's telemetry), CALIBRATION (the plant was fitted to this number: the row is the
calibration's input, shown, no verdict). A claim that does not reproduce is a result to show,
never something to tune away.

Where a row's measurement rests on a definition of this bench rather than of the paper (the
operating-point check, a settling band, the response-time definition), the row says so
(``Quantity.definition``, shown as "bench definition" in the report).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

#: the metrics a quantity can name: unit and definition (the functions that compute them on a
#: recording: hil_bench.papers.claim_metrics)
METRIC_DEFINITIONS: dict[str, tuple[str, str]] = {
    # name: (unit, definition)
    "speed_band_hat_rpm": ("rpm", "max |n_hat - n_ref| of the estimated speed in the window"),
    "speed_band_true_rpm": ("rpm", "max |n - n_ref| of the true rotor speed in the window"),
    "speed_est_error_rpm": ("rpm", "max |n_hat - n| (estimated minus true speed, same cycles) in "
                                   "the window"),
    "pee_max_rad": ("rad", "max |wrap(theta_hat - theta)| in the window"),
    "pee_mean_rad": ("rad", "mean wrap(theta_hat - theta) in the window (the lag or lead)"),
    "emf_thd_percent": ("%", "distortion of the estimated e_alpha: everything but DC and the "
                             "fundamental (THD+N: the chattering too, up to Nyquist) over the "
                             "fundamental, by least squares on the true electrical angle over "
                             "the longest whole number of revolutions ending at the window's end "
                             "(locked to the rotor: no leakage when the speed drifts)"),
    "emf_amplitude_v": ("V", "fundamental amplitude of the estimated e_alpha (same fit)"),
    "phase_current_amp_a": ("A", "fundamental amplitude of the true phase-a current (same fit)"),
    "current_thd_percent": ("%", "THD (harmonics 2..50) of the true phase-a current (same fit)"),
    "current_h5_percent": ("%", "5th harmonic of the true phase-a current / fundamental"),
    "current_h7_percent": ("%", "7th harmonic of the true phase-a current / fundamental"),
    "iq_mean_a": ("A", "mean true q-axis current in the window (the plant's frame)"),
    "iq_ctrl_mean_a": ("A", "mean of the controller's i_q reference (TELEM_EMF) in the window: the "
                            "q current in the controller's estimated frame"),
    "speed_min_true_rpm": ("rpm", "lowest true speed in the window"),
    "speed_dev_true_rpm": ("rpm", "max |n - n_ref| of the true speed in the window"),
    "response_time_ms": ("ms", "estimator response to an event at t_event_s: until |n_hat - n| is "
                               "back, for good, inside its own band of the pre_window_s before "
                               "the event"),
    "speed_dip_rpm": ("rpm", "largest excursion of the true speed from its reference after an "
                             "event at t_event_s (sign +1: below, a load; -1: above, an unload)"),
    "step_overshoot_rpm": ("rpm", "overshoot of the true speed beyond the new reference after a "
                                  "step at t_step_s, in the step's direction"),
    "settling_time_s": ("s", "time after a speed step at t_step_s until the true speed stays "
                             "within band_rpm of the new reference"),
    "ipd_error_deg": ("deg", "initial-position error: the mean of wrap(theta_hat - theta) over "
                             "the window after the procedure (wrong polarity: about 180)"),
    "chattering_a": ("A", "RMS of i_hat - i (alpha-beta) of an observer replayed on the "
                          "recording's samples, its DC and fundamental removed (Yuan Fig. 17: "
                          "the width of the band about the trajectory)"),
    "delay_estimate_us": ("us", "mean of Gong's eq. 20 per-period estimates from the recorded "
                                "dual samples in the window (guards of est_delay_comp)"),
    "harmonic_extraction_pp": ("%", "5th/7th of the phase current as extracted by harm_comp's "
                                    "angle-synchronous SDFT or GSDFT, % of the fundamental"),
}


#: the metrics that describe a steady state: measured only on a window whose speed is steady
#: (hil_bench.papers.metrics.steadiness), unless the row is a transient by design (``transient``)
#: or the metric reads an event (its params name t_event_s / t_step_s)
STEADY_METRICS = frozenset({
    "speed_band_hat_rpm", "speed_band_true_rpm", "speed_est_error_rpm", "pee_max_rad",
    "pee_mean_rad", "emf_thd_percent", "emf_amplitude_v", "phase_current_amp_a",
    "current_thd_percent", "current_h5_percent", "current_h7_percent", "iq_mean_a",
    "iq_ctrl_mean_a", "chattering_a", "delay_estimate_us", "harmonic_extraction_pp"})

#: the two metric names that are no recording's: a study's value, a value derived from two rows
PSEUDO_METRICS = ("study", "derived")


# -- rules -------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Rule:
    kind: str                      # "at_most" | "within" | "compared"
    source: str                    # where the rule comes from: the paper's words, section, table
    lo: float = -math.inf
    hi: float = math.inf
    words: str = ""                # the entry of the words table it reads (bench/claims/common.toml)

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


def at_most(bound: float, source: str, words: str = "") -> Rule:
    return Rule("at_most", source, hi=bound, words=words)


def within(lo: float, hi: float, source: str, words: str = "") -> Rule:
    return Rule("within", source, lo=lo, hi=hi, words=words)


def compared(source: str, words: str = "") -> Rule:
    return Rule("compared", source, words=words)


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
    definition: str = ""                         # a bench definition the measurement rests on
    calibration: str = ""                        # the plant was fitted to this number: how
    transient: bool = False                      # the window is a transient by the paper's
                                                 # design (no steady-state check)
    comparator: str = ""                         # the row measures the bench's reconstruction of
                                                 # a method the paper only compares against (its
                                                 # run's ``comparator`` text): it decides the
                                                 # claim only through the relations

    @property
    def runs(self) -> tuple[str, ...]:
        if self.run is None:
            return ()
        return (self.run,) if isinstance(self.run, str) else tuple(self.run)

    @property
    def unit(self) -> str:
        if self.aggregate == "polarity_failures":
            return "trials"
        if self.metric in METRIC_DEFINITIONS:
            return METRIC_DEFINITIONS[self.metric][0]
        return dict(self.params).get("unit", "")

    @property
    def needs_steady(self) -> bool:
        """Whether the row's window must be steady state (``STEADY_METRICS``)."""
        p = dict(self.params)
        return (self.metric in STEADY_METRICS and not self.transient
                and "t_event_s" not in p and "t_step_s" not in p)

    def verdict(self, measured: float) -> str:
        """The rule's verdict alone (no run state, no operating point)."""
        if self.calibration:
            return "CALIBRATION"
        if self.not_reproducible:
            return "NOT REPRODUCIBLE"
        return self.rule.verdict(measured)

    def rule_text(self) -> str:
        """The rule as the listing (`bench claims`) shows it, with what is the bench's own."""
        if self.calibration:
            return "no verdict: calibration input (the plant was fitted to this number)"
        out = self.rule.text()
        if self.definition:
            out += f"; {self.definition}"
        if self.at_speed_rpm is not None:
            out += "; operating point checked (bench definition)"
        return out


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
    compared: bool = False       # the ordering is shown, no pass/fail (verdict COMPARED)
    words: str = ""              # the entry of the words table it reads (common.toml [[words]])
    min_fall: float = 0.0        # a sized ordering ("significantly decrease from a to b"): the
                                 # relative change each step of the chain must reach (0..1)
    min_fall_source: str = ""    # where that size comes from

    def __post_init__(self):
        # the label must say what the operator tests ("<=" under a "<" would pass a tie)
        if self.op in ("<", ">") and ("<=" in self.what or ">=" in self.what):
            raise ValueError(f"{self.key}: label {self.what!r} does not match operator {self.op!r}")
        if self.min_fall and (self.op not in ("<", ">") or not self.min_fall_source):
            raise ValueError(f"{self.key}: a size to reach (min_fall) needs an ordering and "
                             "min_fall_source")


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
    plant: str = ""               # which plant and which compensation decide the claim, and why

    @property
    def scenarios(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(r.scenario for r in self.runs))

    def run(self, run_id: str) -> Run:
        for r in self.runs:
            if r.id == run_id:
                return r
        raise KeyError(f"{self.id}: no run {run_id!r}")

