"""The metrics a claim's quantity names, computed on a recording: the ``Context`` a metric sees
(a recording, a window, the speed reference, the estimate it is computed on), one function per
metric name of hil_bench.claims.model.METRIC_DEFINITIONS (``METRICS``: name -> unit,
definition, function), and the resolution of what a metric was measured from (one LSB of the
controller's telemetry, ``resolution``).
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from hil_bench.claims.model import METRIC_DEFINITIONS
from hil_bench.record import channels as ch
from hil_bench.record.recording import Recording

from . import metrics

RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


def _wire_lsb(message: str, signal: str) -> float:
    from hil_bench.protocol.messages import MESSAGES
    return float(MESSAGES[message].signal(signal).scale)


#: resolution of the controller's telemetry (docs/protocol.md): what a value measured from it
#: can resolve. The host reference estimators and the plant state are recorded in float64.
TELEM_OMEGA_LSB_RAD_S = _wire_lsb("TELEM", "omega_hat")      # electrical
TELEM_THETA_LSB_RAD = _wire_lsb("TELEM", "theta_hat")
TELEM_EMF_LSB_V = _wire_lsb("TELEM_EMF", "e_alpha")
TELEM_IQ_LSB_A = _wire_lsb("TELEM_EMF", "i_q_ref")


def speed_lsb_rpm(pole_pairs: int) -> float:
    """One LSB of TELEM.omega_hat (0.1 rad/s electrical) as a mechanical speed in rpm."""
    return TELEM_OMEGA_LSB_RAD_S / pole_pairs * RPM_PER_RAD_S


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
    """The estimated EMF's harmonics locked to the rotor: least squares on the plant's true
    electrical angle at the estimate's own cycles (metrics.locked_spectrum)."""
    e, theta = c.estimate_and_truth(field, "theta_e_rad")
    if not np.all(np.isfinite(e)):
        raise MetricUnavailable(f"{c.source} reported no EMF in the window")
    return metrics.locked_spectrum(e, theta, 1.0 / c.ts_s)


def _emf_thd(c: Context) -> float:
    return _emf_spectrum(c).thd_n_percent


def _emf_amplitude(c: Context) -> float:
    return _emf_spectrum(c).fundamental_amplitude


def _current_spectrum(c: Context) -> metrics.Spectrum:
    """The true phase-a current's harmonics locked to the rotor (least squares on the true
    electrical angle of the same cycles, metrics.locked_spectrum)."""
    return metrics.locked_spectrum(c.windowed(ch.PLANT_STATE, "i_a_a"),
                                   c.windowed(ch.PLANT_STATE, "theta_e_rad"), 1.0 / c.ts_s)


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


def _iq_ctrl_mean(c: Context) -> float:
    """The controller's q current: its i_q reference (TELEM_EMF), which its PI current loop holds
    its measured i_q on in steady state - in the controller's (estimated) frame, what Gong's
    DSP computes and plots."""
    v = c.windowed(ch.CONTROLLER_TELEMETRY, "i_q_ref_a")
    v = v[np.isfinite(v)]
    if not v.size:
        raise MetricUnavailable("the controller reported no i_q reference (TELEM_EMF off?)")
    return float(np.mean(v))


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
    e = metrics.mean_angle_rad(est - truth)         # a wrapped angle's mean (unit vectors)
    if not math.isfinite(e):
        raise MetricUnavailable("no angle estimate in the window")
    return math.degrees(e)


def _chattering_a(c: Context, estimator: str, **config: float) -> float:
    from hil_bench.firmware_stub.estimators import REFERENCE_ESTIMATORS
    from hil_bench.plant_rt.profile import load_profile

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
    from hil_bench.protocol.messages import MESSAGES
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
    of the fundamental (locked to the rotor over the window), the extractor's output at the end of the window."""
    key = (str(c.rec.path), c.window_s, extractor, m)
    if key not in _EXTRACTION_CACHE:
        _EXTRACTION_CACHE.clear()     # one recording at a time
        _EXTRACTION_CACHE[key] = _extract(c, extractor, m)
    i5, i7 = _EXTRACTION_CACHE[key]
    fund = _current_spectrum(c).fundamental_amplitude
    return 100.0 * (i5 if order == 5 else i7) / fund


def _extract(c: Context, extractor: str, m: int) -> tuple[float, float]:
    from hil_bench.firmware_stub.est_dft import HarmComp
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



_FUNCTIONS: dict[str, Callable[..., float]] = {
    "speed_band_hat_rpm": _speed_band_hat,
    "speed_band_true_rpm": _speed_band_true,
    "speed_est_error_rpm": _speed_est_error,
    "pee_max_rad": _pee_max,
    "pee_mean_rad": _pee_mean,
    "emf_thd_percent": _emf_thd,
    "emf_amplitude_v": _emf_amplitude,
    "phase_current_amp_a": _phase_current_amp,
    "current_thd_percent": _current_thd,
    "current_h5_percent": _current_h5,
    "current_h7_percent": _current_h7,
    "iq_mean_a": _iq_mean,
    "iq_ctrl_mean_a": _iq_ctrl_mean,
    "speed_min_true_rpm": _speed_min_true,
    "speed_dev_true_rpm": _speed_dev_true,
    "response_time_ms": _response_time_ms,
    "speed_dip_rpm": _speed_dip_true,
    "step_overshoot_rpm": _step_overshoot,
    "settling_time_s": _settling_time_s,
    "ipd_error_deg": _ipd_error_deg,
    "chattering_a": _chattering_a,
    "delay_estimate_us": _delay_estimate_us,
    "harmonic_extraction_pp": _harmonic_extraction_pp,
}
if set(_FUNCTIONS) != set(METRIC_DEFINITIONS):      # one function per defined metric name
    raise ImportError(f"metric functions {sorted(_FUNCTIONS)} != definitions "
                      f"{sorted(METRIC_DEFINITIONS)}")
#: name -> (unit, definition, function(ctx, **params) -> float)
METRICS: dict[str, tuple[str, str, Callable[..., float]]] = {
    name: (unit, definition, _FUNCTIONS[name])
    for name, (unit, definition) in METRIC_DEFINITIONS.items()}


#: metrics computed from the estimated speed (one LSB of TELEM.omega_hat when from telemetry)
SPEED_HAT_METRICS = frozenset({"speed_band_hat_rpm", "speed_est_error_rpm"})


def resolution(metric: str, ctx: Context) -> float:
    """The smallest difference of ``metric`` its source can resolve: one LSB of the controller's
    telemetry where the metric is computed from it (docs/protocol.md: omega_hat 0.1 rad/s
    electrical, theta_hat 2 pi / 65536, e_alpha 0.01 V, i_q_ref 1 mA), 0 for the float64 host
    references and the plant state. For a THD+N from telemetry: the THD+N of the quantisation
    noise alone, (LSB / sqrt 12) / (A / sqrt 2), A the fundamental amplitude."""
    if metric == "response_time_ms":
        return 1e3 * ctx.ts_s              # one control period, whatever the source
    if ctx.source != "controller":
        return 0.0
    if metric in SPEED_HAT_METRICS:
        return speed_lsb_rpm(ctx.pole_pairs)
    if metric in ("pee_max_rad", "pee_mean_rad"):
        return TELEM_THETA_LSB_RAD
    if metric == "ipd_error_deg":
        return math.degrees(TELEM_THETA_LSB_RAD)
    if metric == "emf_amplitude_v":
        return TELEM_EMF_LSB_V
    if metric == "emf_thd_percent":
        try:
            amp = _emf_spectrum(ctx).fundamental_amplitude
        except (MetricUnavailable, ValueError):
            return 0.0
        return 100.0 * (TELEM_EMF_LSB_V / math.sqrt(12.0)) / (amp / math.sqrt(2.0)) if amp > 0 \
            else 0.0
    if metric == "iq_ctrl_mean_a":
        return TELEM_IQ_LSB_A
    return 0.0
