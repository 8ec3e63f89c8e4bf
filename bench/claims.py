"""The papers' published numbers, each with the metric that measures it and an acceptance rule.

A claim (e.g. ``G2``) has quantities. Each quantity names

* a metric computed from a recording (``METRICS``),
* the estimate it is computed on (``source``: ``"controller"`` — the controller's telemetry — or
  ``"reference:<label>"`` — a host reference estimator),
* optionally its own time window and the scenario it belongs to (a claim such as Y4 compares
  two runs: each quantity is measured in the recording of its own scenario),
* the paper's value and how the two compare:

  - ``"<="`` — the paper states a bound ("within +-0.1 rad"): measured <= paper passes;
  - ``"~"``  — the paper states a value: |measured - paper| <= tol * |paper| passes.

The measured value is always reported beside the paper's, pass or not: a claim that does not
reproduce is a finding to show, never something to tune away.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import channels as ch
from . import metrics
from .recording import Recording

RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


class MetricUnavailable(Exception):
    """The recording lacks what this metric needs (e.g. no EMF telemetry)."""


@dataclass(frozen=True)
class Context:
    """What a metric sees: the recording, a window, the speed reference in it, the estimate."""

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

    def windowed(self, topic: str, field: str) -> np.ndarray:
        if topic not in self.rec.topics:
            raise MetricUnavailable(f"no {topic} in the recording")
        cols = self.rec.topics[topic]
        if field not in cols:
            raise MetricUnavailable(f"{topic} has no field {field}")
        mask = metrics.window_mask(cols["t_s"], self.window_s)
        values = np.asarray(cols[field][mask], dtype=float)
        if values.size == 0:
            raise MetricUnavailable(f"no {topic} samples in the window {self.window_s}")
        return values

    def estimate_and_truth(self, field: str, truth_field: str) -> tuple[np.ndarray, np.ndarray]:
        """An estimate's field and the plant truth at the same cycles (matched by time)."""
        topic = self.estimate_topic
        est_t = self.windowed(topic, "t_s")
        est = self.windowed(topic, field)
        state = self.rec.topic(ch.PLANT_STATE)
        idx = np.searchsorted(state["t_s"], est_t)
        idx = np.clip(idx, 0, len(state["t_s"]) - 1)
        return est, np.asarray(state[truth_field][idx], dtype=float)

    def electrical_hz(self) -> float:
        w = self.windowed(ch.PLANT_STATE, "omega_e_rad_s")
        return float(abs(np.mean(w))) / (2.0 * math.pi)


# -- metrics (name -> function(Context) -> float) --------------------------------------------

def _speed_band_hat(c: Context) -> float:
    return metrics.speed_band_rpm(c.windowed(c.estimate_topic, "speed_hat_rpm"), c.speed_ref_rpm)


def _speed_band_true(c: Context) -> float:
    return metrics.speed_band_rpm(c.windowed(ch.PLANT_STATE, "speed_rpm"), c.speed_ref_rpm)


def _speed_est_error(c: Context) -> float:
    est, truth = c.estimate_and_truth("speed_hat_rpm", "speed_rpm")
    err = est - truth
    err = err[np.isfinite(err)]
    if not err.size:
        raise MetricUnavailable("no finite speed estimate in the window")
    return float(np.max(np.abs(err)))


def _pee_max(c: Context) -> float:
    est, truth = c.estimate_and_truth("theta_hat_rad", "theta_e_rad")
    return metrics.angle_error(est, truth).max_abs_rad


def _pee_mean(c: Context) -> float:
    est, truth = c.estimate_and_truth("theta_hat_rad", "theta_e_rad")
    return metrics.angle_error(est, truth).mean_rad


def _emf_spectrum(c: Context) -> metrics.Spectrum:
    e = c.windowed(c.estimate_topic, "e_alpha_v")
    if not np.all(np.isfinite(e)):
        raise MetricUnavailable(f"{c.source} reported no EMF in the window")
    return metrics.harmonic_spectrum(e, 1.0 / c.ts_s, c.electrical_hz())


def _emf_thd(c: Context) -> float:
    return _emf_spectrum(c).thd_percent


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


def _speed_overshoot_true(c: Context) -> float:
    return float(np.max(np.abs(c.windowed(ch.PLANT_STATE, "speed_rpm") - c.speed_ref_rpm)))


METRICS: dict[str, tuple[str, str, Callable[[Context], float]]] = {
    # name: (unit, definition, function)
    "speed_band_hat_rpm": ("rpm", "max |n_hat - n_ref| of the estimated speed in the window",
                           _speed_band_hat),
    "speed_band_true_rpm": ("rpm", "max |n - n_ref| of the true rotor speed in the window",
                            _speed_band_true),
    "speed_est_error_rpm": ("rpm", "max |n_hat - n| (estimated minus true speed) in the window",
                            _speed_est_error),
    "pee_max_rad": ("rad", "max |wrap(theta_hat - theta)| in the window", _pee_max),
    "pee_mean_rad": ("rad", "mean wrap(theta_hat - theta) in the window (the lag or lead)",
                     _pee_mean),
    "emf_thd_percent": ("%", "THD (harmonics 2..50, FFT over whole periods) of the estimated "
                             "e_alpha in the window", _emf_thd),
    "emf_amplitude_v": ("V", "fundamental amplitude of the estimated e_alpha", _emf_amplitude),
    "phase_current_amp_a": ("A", "fundamental amplitude of the true phase-a current",
                            _phase_current_amp),
    "current_thd_percent": ("%", "THD (harmonics 2..50) of the true phase-a current",
                            _current_thd),
    "current_h5_percent": ("%", "5th harmonic of the true phase-a current / fundamental",
                           _current_h5),
    "current_h7_percent": ("%", "7th harmonic of the true phase-a current / fundamental",
                           _current_h7),
    "iq_mean_a": ("A", "mean true q-axis current in the window", _iq_mean),
    "speed_min_true_rpm": ("rpm", "lowest true speed in the window", _speed_min_true),
    "speed_dev_true_rpm": ("rpm", "max |n - n_ref| of the true speed in the window (overshoot, "
                                  "dip)", _speed_overshoot_true),
}


@dataclass(frozen=True)
class Quantity:
    metric: str
    paper_value: float
    rule: str             # "<=" or "~"
    tolerance: float = 0.0
    what: str = ""
    source: str = "controller"                  # or "reference:<label>"
    window_s: tuple[float, float] | None = None  # None: the scenario's metrics window
    scenario: str | None = None                 # None: any recording that names the claim

    def verdict(self, measured: float) -> str:
        if not math.isfinite(measured):
            return "N/A"
        if self.rule == "<=":
            return "PASS" if measured <= self.paper_value else "DIFFERS"
        if self.rule == "~":
            ok = abs(measured - self.paper_value) <= self.tolerance * abs(self.paper_value)
            return "PASS" if ok else "DIFFERS"
        raise ValueError(f"unknown rule {self.rule!r}")

    def rule_text(self) -> str:
        if self.rule == "<=":
            return f"<= {self.paper_value:g}"
        return f"{self.paper_value:g} +-{self.tolerance * 100:.0f}%"


@dataclass(frozen=True)
class Claim:
    id: str
    paper: str
    text: str
    quantities: tuple[Quantity, ...]
    scenarios: tuple[str, ...]
    notes: str = ""


CLAIMS: dict[str, Claim] = {c.id: c for c in (
    Claim("G2", "Gong (002), simulation, Fig. 8 / Table III",
          "500 rpm steady state: speed fluctuation +-7.5 rpm, PEE within +-0.1 rad, EMF THD 1.7 %, "
          "no-load phase current about 0.5 A",
          (Quantity("speed_band_hat_rpm", 7.5, "<=", what="speed fluctuation (estimated speed)"),
           Quantity("pee_max_rad", 0.1, "<=", what="position-estimation error"),
           Quantity("emf_thd_percent", 1.7, "~", 0.5, what="THD of the estimated back EMF"),
           Quantity("phase_current_amp_a", 0.5, "~", 0.5, what="no-load phase current amplitude")),
          ("gong_g2_500rpm",),
          "The paper closes the loop with its tanh SMO (m = 0.01); gong_g2_500rpm uses the "
          "conventional sign SMO (eq. 3-7)."),
    Claim("G3", "Gong (002), simulation, Fig. 9 / Table III",
          "2000 rpm steady state: speed fluctuation +-24 rpm, EMF THD 0.8 %, PEE within +-0.05 rad",
          (Quantity("speed_band_hat_rpm", 24.0, "<=", what="speed fluctuation (estimated speed)"),
           Quantity("pee_max_rad", 0.05, "<=", what="position-estimation error"),
           Quantity("emf_thd_percent", 0.8, "~", 0.5, what="THD of the estimated back EMF")),
          ("gong_g3_2000rpm",),
          "The paper closes the loop with its tanh SMO (m = 0.01); gong_g3_2000rpm uses the "
          "conventional sign SMO (eq. 3-7)."),
    Claim("Y4", "Yuan (000), Fig. 18-19, section IV.C",
          "phase-current THD from inverter nonlinearity at 10 rpm, without -> with GSDFT "
          "compensation: 8.06 % -> 6.01 % (5th 4.08 -> 2.18 %, 7th 4.11 -> 2.61 %)",
          (Quantity("current_thd_percent", 8.06, "~", 0.25, what="THD without compensation",
                    scenario="yuan_y4_10rpm"),
           Quantity("current_h5_percent", 4.08, "~", 0.25, what="5th without compensation",
                    scenario="yuan_y4_10rpm"),
           Quantity("current_h7_percent", 4.11, "~", 0.25, what="7th without compensation",
                    scenario="yuan_y4_10rpm"),
           Quantity("current_thd_percent", 6.01, "~", 0.25, what="THD with compensation",
                    scenario="yuan_y4_10rpm_comp"),
           Quantity("current_h5_percent", 2.18, "~", 0.25, what="5th with compensation",
                    scenario="yuan_y4_10rpm_comp"),
           Quantity("current_h7_percent", 2.61, "~", 0.25, what="7th with compensation",
                    scenario="yuan_y4_10rpm_comp")),
          ("yuan_y4_10rpm", "yuan_y4_10rpm_comp"),
          "The plant's dead time is calibrated on the uncompensated THD at this operating point "
          "(plant_rt/README.md), so the first three rows reproduce by construction; the "
          "compensated rows are the test. The loop closes on the ideal encoder angle: the "
          "harmonics are the inverter's."),
    Claim("H1", "Hou (001), Fig. 7-8, section 4.2",
          "0 -> 10 rpm with full load, 10 -> 50 rpm: speed-estimation error SMO +-4 rpm at 10 and "
          "+-6 rpm at 50; HF injection + SDFT +-1.5 rpm and +-3 rpm",
          (Quantity("speed_est_error_rpm", 1.5, "<=", what="HFI speed-estimation error at 10 rpm",
                    window_s=(0.3, 0.4)),
           Quantity("speed_est_error_rpm", 3.0, "<=", what="HFI speed-estimation error at 50 rpm",
                    window_s=(0.55, 0.7)),
           Quantity("speed_est_error_rpm", 4.0, "<=", what="SMO speed-estimation error at 10 rpm",
                    source="reference:SMO_SIGN", window_s=(0.3, 0.4)),
           Quantity("speed_est_error_rpm", 6.0, "<=", what="SMO speed-estimation error at 50 rpm",
                    source="reference:SMO_SIGN", window_s=(0.55, 0.7)),
           Quantity("pee_max_rad", math.radians(5.0), "<=", what="HFI position error at 50 rpm "
                    "(not a paper number: 5 deg sanity bound)", window_s=(0.55, 0.7))),
          ("hou_h1_hfi",),
          "HFI closes the loop; the SMO (sign, Ls = Lq, which ignores the saliency) runs as a host "
          "reference on the same samples. The initial-position detection shifts the time base by "
          "about 60 ms; full load arrives as a 50 ms ramp (see the scenario)."),
    Claim("H3", "Hou (001), Fig. 11-12, section 4.3",
          "initial position at 0, 45, 90, 135, 180 deg: estimation error within +-1 deg, N/S "
          "polarity right",
          (Quantity("pee_max_rad", math.radians(1.0), "<=",
                    what="initial-position error after the procedure (a polarity error reads pi)"),),
          ("hou_h3_ipd",),
          "One recording per initial angle (the test suite runs all five)."),
)}


@dataclass(frozen=True)
class QuantityResult:
    claim: Claim
    quantity: Quantity
    measured: float
    verdict: str
    note: str = ""


def applicable(claim: Claim, scenario_name: str) -> list[Quantity]:
    """The quantities of a claim measured in a recording of ``scenario_name``."""
    return [q for q in claim.quantities if q.scenario in (None, scenario_name)]


def evaluate(claim: Claim, ctx: Context, scenario_name: str | None = None) -> list[QuantityResult]:
    out = []
    quantities = claim.quantities if scenario_name is None else applicable(claim, scenario_name)
    for q in quantities:
        unit, definition, fn = METRICS[q.metric]
        qctx = ctx.with_source(q.source)
        if q.window_s is not None:
            qctx = qctx.with_window(q.window_s)
        try:
            value = float(fn(qctx))
            note = ""
        except MetricUnavailable as exc:
            value, note = math.nan, str(exc)
        except ValueError as exc:
            value, note = math.nan, f"cannot compute: {exc}"
        out.append(QuantityResult(claim, q, value, q.verdict(value), note))
    return out
