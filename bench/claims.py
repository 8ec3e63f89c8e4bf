"""The papers' published numbers, each with the metric that measures it and an acceptance rule.

A claim (e.g. ``G2``) has quantities; each quantity names a metric computed from a recording,
the paper's value and how the two are compared:

* ``"<="`` — the paper states a bound ("within +-0.1 rad"): measured <= paper passes.
* ``"~"``  — the paper states a value: |measured - paper| <= tol * |paper| passes.

The measured value is always reported beside the paper's, pass or not: a claim that does not
reproduce is a finding to show, never something to tune away.
"""
from __future__ import annotations

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
    """What a metric sees: the recording and the steady-state window of its scenario."""

    rec: Recording
    window_s: tuple[float, float]
    speed_ref_rpm: float
    pole_pairs: int
    ts_s: float

    def windowed(self, topic: str, field: str) -> np.ndarray:
        cols = self.rec.topic(topic)
        if field not in cols:
            raise MetricUnavailable(f"{topic} has no field {field}")
        mask = metrics.window_mask(cols["t_s"], self.window_s)
        values = np.asarray(cols[field][mask], dtype=float)
        if values.size == 0:
            raise MetricUnavailable(f"no {topic} samples in the window {self.window_s}")
        return values

    def electrical_hz(self) -> float:
        w = self.windowed(ch.PLANT_STATE, "omega_e_rad_s")
        return float(abs(np.mean(w))) / (2.0 * math.pi)


# -- metrics (name -> function(Context) -> float) --------------------------------------------

def _speed_band_hat(c: Context) -> float:
    return metrics.speed_band_rpm(c.windowed(ch.CONTROLLER_TELEMETRY, "speed_hat_rpm"),
                                  c.speed_ref_rpm)


def _speed_band_true(c: Context) -> float:
    return metrics.speed_band_rpm(c.windowed(ch.PLANT_STATE, "speed_rpm"), c.speed_ref_rpm)


def _pee_max(c: Context) -> float:
    return metrics.angle_error(c.windowed(ch.CONTROLLER_TELEMETRY, "theta_hat_rad"),
                               c.windowed(ch.PLANT_STATE, "theta_e_rad")).max_abs_rad


def _emf_thd(c: Context) -> float:
    e = c.windowed(ch.CONTROLLER_TELEMETRY, "e_alpha_v")
    if not np.all(np.isfinite(e)):
        raise MetricUnavailable("controller sent no EMF telemetry (TELEM_EMF)")
    return metrics.harmonic_spectrum(e, 1.0 / c.ts_s, c.electrical_hz()).thd_percent


def _phase_current_amp(c: Context) -> float:
    return metrics.fundamental_amplitude(c.windowed(ch.PLANT_STATE, "i_a_a"), 1.0 / c.ts_s,
                                         c.electrical_hz())


METRICS: dict[str, tuple[str, str, Callable[[Context], float]]] = {
    # name: (unit, definition, function)
    "speed_band_hat_rpm": ("rpm", "max |n_hat - n_ref| of the controller's estimated speed in the "
                                  "window", _speed_band_hat),
    "speed_band_true_rpm": ("rpm", "max |n - n_ref| of the true rotor speed in the window",
                            _speed_band_true),
    "pee_max_rad": ("rad", "max |wrap(theta_hat - theta)| of the controller in the window",
                    _pee_max),
    "emf_thd_percent": ("%", "THD (harmonics 2..50, FFT over whole periods) of the controller's "
                             "estimated e_alpha in the window", _emf_thd),
    "phase_current_amp_a": ("A", "fundamental amplitude of the true phase-a current",
                            _phase_current_amp),
}


@dataclass(frozen=True)
class Quantity:
    metric: str
    paper_value: float
    rule: str             # "<=" or "~"
    tolerance: float = 0.0
    what: str = ""

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
)}


@dataclass(frozen=True)
class QuantityResult:
    claim: Claim
    quantity: Quantity
    measured: float
    verdict: str
    note: str = ""


def evaluate(claim: Claim, ctx: Context) -> list[QuantityResult]:
    out = []
    for q in claim.quantities:
        unit, definition, fn = METRICS[q.metric]
        try:
            value = float(fn(ctx))
            note = ""
        except MetricUnavailable as exc:
            value, note = math.nan, str(exc)
        except ValueError as exc:
            value, note = math.nan, f"cannot compute: {exc}"
        out.append(QuantityResult(claim, q, value, q.verdict(value), note))
    return out
