"""Independent double-precision reference of the plant, for tests only.

Written from the physics, not from the C code: the same machine (dq model, Ld != Lq), inverter
averaging, computation-delay split and mechanics, but

* default formulation in the STATIONARY frame with the stator flux linkage as state
  (psi_alphabeta' = v_alphabeta - R i_alphabeta, i = L(theta)^-1 (psi - psi_f e^{j theta}),
  L(theta) = L0 I + L2 [[cos 2th, sin 2th], [sin 2th, -cos 2th]], L0 = (Ld+Lq)/2,
  L2 = (Ld-Lq)/2, torque 1.5 p (psi_alpha i_beta - psi_beta i_alpha)), which is the dq model
  seen from the stator; ``frame="dq"`` integrates the textbook dq current equations instead
  (the two must agree, which checks the reference itself);
* transforms as explicit matrices (amplitude-invariant, 2/3 scaling);
* a disabled leg's diodes as a smooth, stiff characteristic of its phase current
  v_xN = V_dc/2 (1 - tanh(i_x / i0)) (i0 = ``diode_i0_a``) instead of mode logic: a phase
  whose terminal voltage sits between the rails carries |i| ~ i0 (open), a conducting diode
  pins the terminal to a rail; solved with the implicit Radau method;
* ``scipy.integrate.solve_ivp`` restarted at every input discontinuity (the delay instant and
  the period boundaries), rtol 1e-10 by default.

Non-idealities (same definitions as plant_rt/c, re-derived here, not translated):

* d-axis saturation: the state stays the stationary flux linkage; the currents follow by
  inverting psi_d(i_d) numerically (Newton on the documented flux curve, with bisection
  fallback) instead of integrating di_d/dt = .../L_inc(i_d) as the C plant does;
* inverter: each enabled leg's average pole voltage from the conduction intervals of the two
  current directions (dead interval spent on the lower diode for i > 0, on the upper diode
  for i < 0), blended by the parasitic-capacitance sign; disabled legs' diodes with their drop;
* friction B w + T_c tanh(w / w_c); the load profile in CONTINUOUS time (``load_mode=
  "continuous"``, the physical profile; the plant holds each period's exact mean) or as the
  plant's per-period mean (``"period_mean"``); the dynamometer's imposed speed;
* the state at the actuation instants t_k + t_d (the plant's second samples).

``leg_average_switched`` is a third, switch-level model of one inverter leg (gate timing, dead
time, node capacitance, device drops) that the averaged leg formula is checked against.

Duty semantics (same contract as the plant): duties[k] (a, b, c) are commanded for period k
(t_k = k Ts); they act from t_k + t_delay; before that the previous duties act (0.5 before
the first period). duty < 0 (or NaN) disables the leg, duty > 1 acts as 1.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
from scipy.integrate import solve_ivp

_S3 = math.sqrt(3.0)
# amplitude-invariant Clarke (abc -> alpha beta) and its right inverse (alpha beta -> abc)
CLARKE = (2.0 / 3.0) * np.array([[1.0, -0.5, -0.5], [0.0, _S3 / 2.0, -_S3 / 2.0]])
INV_CLARKE = np.array([[1.0, 0.0], [-0.5, _S3 / 2.0], [-0.5, -_S3 / 2.0]])


@dataclass(frozen=True)
class RefParams:
    """Plant constants (SI) used by the reference (non-idealities default to off)."""

    rs_ohm: float
    ld_h: float
    lq_h: float
    psi_f_wb: float
    pole_pairs: int
    j_kgm2: float
    b_nms: float
    v_dc_v: float
    ts_s: float
    t_delay_s: float
    full_period_delay: bool = False
    inverter_nonlinear: bool = False
    dead_time_s: float = 0.0
    v_switch_drop_v: float = 0.0
    r_switch_ohm: float = 0.0
    v_diode_drop_v: float = 0.0
    r_diode_ohm: float = 0.0
    i_cap_band_a: float = 0.0
    saturation: bool = False
    sat_l_inf_ratio: float = 1.0
    sat_i_scale_a: float = 1.0
    sat_i_knee_a: float = 0.0
    coulomb_nm: float = 0.0
    coulomb_band_rad_s: float = 1.0
    load_profile: str = "none"
    load_t0_s: float = 0.0
    load_t1_s: float = 0.0
    load_torque0_nm: float = 0.0
    load_torque1_nm: float = 0.0
    load_table_t_s: tuple = ()
    load_table_nm: tuple = ()
    dyno: bool = False
    dyno_speed_rad_s: float = 0.0
    dyno_accel_rad_s2: float = 0.0

    @classmethod
    def of(cls, obj: Any) -> "RefParams":
        """From a mapping or any object with these attributes (MotorProfile, Plant.params);
        missing non-ideality fields are off."""
        fields_ = cls.__dataclass_fields__
        if isinstance(obj, Mapping):
            return cls(**{f: obj[f] for f in fields_ if f in obj})
        return cls(**{f: getattr(obj, f) for f in fields_ if hasattr(obj, f)})

    @property
    def t_act_s(self) -> float:
        """Sampling instant -> actuation instant."""
        return self.ts_s if self.full_period_delay else self.t_delay_s


# ---------------------------------------------------------------------------------------------
# non-ideality building blocks (written from the physics, see the module doc)

def psi_d_curve(p: RefParams, i_d: float) -> float:
    """d-axis flux linkage [Wb]: psi_f + L_s i + K I_s [tanh((i - i0)/I_s) + tanh(i0/I_s)]."""
    if not p.saturation:
        return p.psi_f_wb + p.ld_h * i_d
    l_s = p.sat_l_inf_ratio * p.ld_h
    k = (p.ld_h - l_s) * math.cosh(p.sat_i_knee_a / p.sat_i_scale_a) ** 2
    return (p.psi_f_wb + l_s * i_d + k * p.sat_i_scale_a
            * (math.tanh((i_d - p.sat_i_knee_a) / p.sat_i_scale_a) + math.tanh(p.sat_i_knee_a / p.sat_i_scale_a)))


def ld_inc_curve(p: RefParams, i_d: float) -> float:
    """Incremental d-axis inductance [H] (derivative of psi_d_curve)."""
    if not p.saturation:
        return p.ld_h
    l_s = p.sat_l_inf_ratio * p.ld_h
    k = (p.ld_h - l_s) * math.cosh(p.sat_i_knee_a / p.sat_i_scale_a) ** 2
    return l_s + k / math.cosh((i_d - p.sat_i_knee_a) / p.sat_i_scale_a) ** 2


def i_d_of_psi(p: RefParams, psi_d: float, guess: float = 0.0) -> float:
    """Invert psi_d_curve (strictly increasing): Newton from guess, bisection safeguard."""
    x = guess
    for _ in range(60):
        f = psi_d_curve(p, x) - psi_d
        step = f / ld_inc_curve(p, x)
        x -= step
        if abs(step) <= 1e-15 * (1.0 + abs(x)):
            return x
    lo, hi = -1e4, 1e4  # pragma: no cover - Newton converges on this monotone curve
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if psi_d_curve(p, mid) < psi_d:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def capacitance_sign(i: float, i_c: float) -> float:
    """Average of the dead-time error of a leg whose node capacitance C is slewed by the phase
    current, normalised: 0 at i = 0, +-1 far away; i_c = C V_dc / t_dt (module doc)."""
    if i_c <= 0.0:
        return float(np.sign(i))
    a = abs(i)
    g = a / (2.0 * i_c) if a <= i_c else 1.0 - i_c / (2.0 * a)
    return math.copysign(g, i) if a > 0.0 else 0.0


def leg_average(p: RefParams, duty: float, i: float) -> tuple[float, float]:
    """(average pole voltage [V], fraction of the period tied to the + rail) of an enabled leg
    with the non-idealities, from the conduction intervals of the current's direction."""
    vdc = p.v_dc_v
    delta = p.dead_time_s / p.ts_s
    # + rail time: current out of the leg loses the dead interval of the rising edge (lower
    # diode), current into the leg gains the one of the falling edge (upper diode); across the
    # capacitance band the node slews, which blends the two
    up_out = min(max(duty - delta, 0.0), 1.0)
    up_in = min(max(duty + delta, 0.0), 1.0)
    share_out = 0.5 * (1.0 + capacitance_sign(i, p.i_cap_band_a))
    up = share_out * up_out + (1.0 - share_out) * up_in
    # conduction drops of the devices carrying i; thresholds switch on over the band
    onset = math.tanh(abs(i) / p.i_cap_band_a) if p.i_cap_band_a > 0.0 else float(i != 0.0)
    v_sw = p.v_switch_drop_v * onset + p.r_switch_ohm * abs(i)
    v_di = p.v_diode_drop_v * onset + p.r_diode_ohm * abs(i)
    if i > 0.0:    # upper switch (up_out of the period), lower diode (the rest)
        drop = up_out * v_sw + (1.0 - up_out) * v_di
    elif i < 0.0:  # upper diode, lower switch; both lift the node
        drop = -(up_in * v_di + (1.0 - up_in) * v_sw)
    else:
        drop = 0.0
    return up * vdc - drop, up


def load_profile_value(p: RefParams, t: float) -> float:
    """The load profile at time t [N m] (continuous time, module doc of mechanics.h)."""
    kind = p.load_profile
    if kind == "none":
        return 0.0
    if kind == "step":
        return p.load_torque0_nm if t < p.load_t0_s else p.load_torque1_nm
    if kind == "ramp":
        ts, vs = (p.load_t0_s, p.load_t1_s), (p.load_torque0_nm, p.load_torque1_nm)
    else:
        ts, vs = tuple(p.load_table_t_s), tuple(p.load_table_nm)
    return float(np.interp(t, ts, vs))


def load_profile_breaks(p: RefParams) -> list[float]:
    """Instants where the profile (or its slope) jumps."""
    if p.load_profile in ("step",):
        return [p.load_t0_s]
    if p.load_profile == "ramp":
        return [p.load_t0_s, p.load_t1_s]
    if p.load_profile == "table":
        return list(p.load_table_t_s)
    return []


def load_profile_period_mean(p: RefParams, t0: float, t1: float, n: int = 2001) -> float:
    """Mean of the profile over [t0, t1], by dense quadrature split at the breakpoints."""
    pts = sorted({t0, t1, *[b for b in load_profile_breaks(p) if t0 < b < t1]})
    area = 0.0
    for a, b in zip(pts[:-1], pts[1:]):
        # the profile is linear between breakpoints: the trapezoid on the open interval is exact
        eps = 1e-12 * (b - a)
        area += 0.5 * (b - a) * (load_profile_value(p, a + eps) + load_profile_value(p, b - eps))
    return area / (t1 - t0)


def leg_average_switched(v_dc_v: float, ts_s: float, duty: float, i_a: float, *,
                         dead_time_s: float = 0.0, c_node_f: float = 0.0,
                         v_switch_drop_v: float = 0.0, v_diode_drop_v: float = 0.0) -> float:
    """Average pole voltage over one PWM period of ONE leg, modelled at switch level.

    Centre-aligned PWM: the high-side command is on for duty*Ts centred in the period, the
    low-side command is its complement. Each switch turns on dead_time_s after its command
    rises (turn-off is immediate). The phase current i_a (> 0 out of the leg) is constant over
    the period. With a gate on, the node sits at the conducting device's terminal: upper
    switch V_dc - V_sw (i > 0) or upper diode V_dc + V_d (i < 0); lower diode -V_d (i > 0) or
    lower switch +V_sw (i < 0). With both gates off (dead intervals) the current slews the
    node capacitance, dv/dt = -i / C, until a diode clamps it at -V_d or V_dc + V_d (C = 0:
    clamped at once). Integrated exactly, segment by segment.
    """
    v_top, v_bot = v_dc_v + v_diode_drop_v, -v_diode_drop_v
    hi_level = v_dc_v - v_switch_drop_v if i_a > 0.0 else v_top
    lo_level = v_bot if i_a > 0.0 else v_switch_drop_v
    t_on, t_off = 0.5 * ts_s * (1.0 - duty), 0.5 * ts_s * (1.0 + duty)
    # gate windows (clipped to the period); the low gate is on from 0 to t_on and again from
    # t_off + dead to Ts; the high gate from t_on + dead to t_off
    events = sorted({0.0, ts_s, *[x for x in (t_on, t_on + dead_time_s, t_off, t_off + dead_time_s)
                                   if 0.0 < x < ts_s]})

    def gate(tm: float) -> str:
        if t_on + dead_time_s <= tm < t_off:
            return "hi"
        if tm < t_on or tm >= t_off + dead_time_s:
            return "lo"
        return "dead"

    v = lo_level if duty < 1.0 else hi_level  # node voltage at t = 0 (steady PWM)
    area = 0.0
    for a, b in zip(events[:-1], events[1:]):
        length = b - a
        g = gate(0.5 * (a + b))
        if g == "hi":
            v = hi_level
            area += v * length
        elif g == "lo":
            v = lo_level
            area += v * length
        else:
            bound = v_bot if i_a > 0.0 else v_top
            if c_node_f <= 0.0 or i_a == 0.0:
                if c_node_f <= 0.0 and i_a != 0.0:
                    v = bound
                area += v * length
                continue
            rate = -i_a / c_node_f
            t_c = (bound - v) / rate  # >= 0: the node moves towards the clamping diode
            if t_c >= length:
                area += v * length + 0.5 * rate * length * length
                v += rate * length
            else:
                area += v * t_c + 0.5 * rate * t_c * t_c + bound * (length - t_c)
                v = bound
    return area / ts_s


@dataclass
class ReferenceResult:
    """Solution at the sampling instants t_k = k Ts, k = 0..n (n + 1 rows); ``i_abc_act_a``
    at the actuation instants t_k + t_d, k = 0..n-1 (n rows)."""

    t_s: np.ndarray
    i_abc_a: np.ndarray       # (n+1, 3)
    i_alpha_a: np.ndarray
    i_beta_a: np.ndarray
    i_d_a: np.ndarray
    i_q_a: np.ndarray
    omega_m_rad_s: np.ndarray
    theta_e_rad: np.ndarray   # wrapped [0, 2 pi)
    theta_m_rad: np.ndarray   # unwrapped, theta_m(0) = theta_e0 / p
    torque_e_nm: np.ndarray
    i_abc_act_a: np.ndarray | None = None   # (n, 3) at t_k + t_d
    torque_dyno_nm: np.ndarray | None = None  # dyno mode: T_e - friction - J a (n+1)


class _Model:
    def __init__(self, p: RefParams, frame: str, diode_i0_a: float, load_mode: str = "continuous"):
        self.p = p
        self.frame = frame
        self.i0 = diode_i0_a
        self.m0 = 0.5 * (1.0 / p.ld_h + 1.0 / p.lq_h)
        self.m2 = 0.5 * (1.0 / p.ld_h - 1.0 / p.lq_h)
        self.duty = np.full(3, 0.5)
        self.enabled = np.ones(3, dtype=bool)
        self.load_nm = 0.0
        self.load_mode = load_mode
        self.t_offset = 0.0        # absolute time of the segment start (solve_ivp runs from 0)
        self.dyno_accel = 0.0
        self._id_guess = 0.0
        if frame == "dq" and p.saturation:
            raise ValueError("the dq formulation of the reference is linear; use 'alphabeta'")

    def set_inputs(self, duty: np.ndarray, load_nm: float) -> None:
        d = np.asarray(duty, dtype=float)
        self.enabled = d >= 0.0  # NaN compares False -> disabled
        self.duty = np.where(self.enabled, np.minimum(d, 1.0), 0.0)
        self.load_nm = float(load_nm)

    def load_torque(self, t_abs: float) -> float:
        """Set torque + profile (continuous time, or the period's mean set by simulate)."""
        if self.load_mode == "continuous":
            return self.load_nm + load_profile_value(self.p, t_abs)
        return self.load_nm

    @property
    def has_disabled(self) -> bool:
        return not bool(self.enabled.all())

    # -- currents from the state ---------------------------------------------------------------
    def currents_ab(self, x: np.ndarray) -> np.ndarray:
        """alpha-beta currents [A] of state x."""
        p = self.p
        th = x[3]
        if self.frame == "dq":
            c, s = math.cos(th), math.sin(th)
            return np.array([c * x[0] - s * x[1], s * x[0] + c * x[1]])
        if p.saturation:
            c, s = math.cos(th), math.sin(th)
            psi_d = c * x[0] + s * x[1]
            psi_q = -s * x[0] + c * x[1]
            i_d = i_d_of_psi(p, psi_d, self._id_guess)
            self._id_guess = i_d
            i_q = psi_q / p.lq_h
            return np.array([c * i_d - s * i_q, s * i_d + c * i_q])
        c2, s2 = math.cos(2.0 * th), math.sin(2.0 * th)
        lam = np.array([x[0] - p.psi_f_wb * math.cos(th), x[1] - p.psi_f_wb * math.sin(th)])
        linv = np.array([[self.m0 + self.m2 * c2, self.m2 * s2], [self.m2 * s2, self.m0 - self.m2 * c2]])
        return linv @ lam

    def phase_voltages_ab(self, i_ab: np.ndarray) -> np.ndarray:
        """alpha-beta phase voltages [V] from the inverter legs (isolated star)."""
        p = self.p
        vdc = p.v_dc_v
        v_pole = self.duty * vdc
        i_abc = INV_CLARKE @ i_ab
        if p.inverter_nonlinear:
            v_pole = np.array([leg_average(p, self.duty[k], i_abc[k])[0] for k in range(3)])
        if self.has_disabled:
            th = np.tanh(i_abc / self.i0)
            drop = (p.v_diode_drop_v + p.r_diode_ohm * np.abs(i_abc)) if p.inverter_nonlinear else 0.0
            diode = 0.5 * vdc * (1.0 - th) - drop * th
            v_pole = np.where(self.enabled, v_pole, diode)
        v_phase = v_pole - v_pole.mean()
        return CLARKE @ v_phase

    # -- right-hand side -----------------------------------------------------------------------
    def rhs(self, _t: float, x: np.ndarray) -> np.ndarray:
        p = self.p
        th, wm = x[3], x[2]
        we = p.pole_pairs * wm
        i_ab = self.currents_ab(x)
        v_ab = self.phase_voltages_ab(i_ab)
        c, s = math.cos(th), math.sin(th)
        if self.frame == "dq":
            i_d, i_q = x[0], x[1]
            v_d = c * v_ab[0] + s * v_ab[1]
            v_q = -s * v_ab[0] + c * v_ab[1]
            d0 = (v_d - p.rs_ohm * i_d + we * p.lq_h * i_q) / p.ld_h
            d1 = (v_q - p.rs_ohm * i_q - we * (p.ld_h * i_d + p.psi_f_wb)) / p.lq_h
            te = 1.5 * p.pole_pairs * (p.psi_f_wb * i_q + (p.ld_h - p.lq_h) * i_d * i_q)
        else:
            d0, d1 = v_ab - p.rs_ohm * i_ab
            te = 1.5 * p.pole_pairs * (x[0] * i_ab[1] - x[1] * i_ab[0])
        if p.dyno:
            dw = self.dyno_accel
        else:
            friction = p.b_nms * wm + p.coulomb_nm * math.tanh(wm / p.coulomb_band_rad_s) \
                if p.coulomb_nm > 0.0 else p.b_nms * wm
            dw = (te - friction - self.load_torque(self.t_offset + _t)) / p.j_kgm2
        return np.array([d0, d1, dw, we])

    def initial_state(self, theta_e0: float, omega_m0: float) -> np.ndarray:
        if self.frame == "dq":
            return np.array([0.0, 0.0, omega_m0, theta_e0])
        p = self.p
        return np.array([p.psi_f_wb * math.cos(theta_e0), p.psi_f_wb * math.sin(theta_e0), omega_m0, theta_e0])


def simulate(params: Any, duties: np.ndarray, *, theta_e0: float = 0.0, omega_m0: float = 0.0,
             load_torque_nm: float | np.ndarray = 0.0, frame: str = "alphabeta",
             rtol: float = 1e-10, atol: np.ndarray | None = None,
             diode_i0_a: float = 1e-6, load_mode: str = "continuous",
             dyno_targets_rad_s: np.ndarray | None = None,
             method: str | None = None) -> ReferenceResult:
    """Integrate n = len(duties) periods from zero current at (theta_e0, omega_m0).

    params: mapping/object with the plant constants (RefParams fields; e.g. a MotorProfile).
    duties: (n, 3) duties commanded for each period (see module doc).
    load_torque_nm: constant, or (n,) per period (changes at the period start t_k); the load
    profile of params is added (load_mode "continuous": the profile in continuous time;
    "period_mean": its mean over each period, as the plant applies it).
    dyno_targets_rad_s: dyno mode, (n,) set speed per period (default: params.dyno_speed_rad_s;
    the rotor starts at it, as the plant after reset, unless omega_m0 is given explicitly).
    method: solve_ivp method (default DOP853, Radau when a leg is disabled).
    Returns the state at t_0..t_n.
    """
    p = RefParams.of(params)
    if frame not in ("alphabeta", "dq"):
        raise ValueError(f"frame must be 'alphabeta' or 'dq', got {frame!r}")
    if load_mode not in ("continuous", "period_mean"):
        raise ValueError(f"load_mode must be 'continuous' or 'period_mean', got {load_mode!r}")
    duties = np.asarray(duties, dtype=float)
    if duties.ndim != 2 or duties.shape[1] != 3:
        raise ValueError(f"duties must have shape (n, 3), got {duties.shape}")
    n = duties.shape[0]
    load = np.broadcast_to(np.asarray(load_torque_nm, dtype=float), (n,))
    model = _Model(p, frame, diode_i0_a, load_mode)
    if atol is None:
        flux_or_current = 1e-13 if frame == "alphabeta" else 1e-10
        atol = np.array([flux_or_current, flux_or_current, 1e-10, 1e-12])
    targets = (np.full(n, p.dyno_speed_rad_s) if dyno_targets_rad_s is None
               else np.broadcast_to(np.asarray(dyno_targets_rad_s, dtype=float), (n,)))

    x = model.initial_state(theta_e0 % (2.0 * math.pi), omega_m0)
    theta_unwrapped = theta_e0 % (2.0 * math.pi)
    theta_m0 = theta_unwrapped / p.pole_pairs
    out = np.empty((n + 1, 4))
    theta_unw = np.empty(n + 1)
    act = np.empty((n, 3))
    accel = np.zeros(n + 1)
    out[0] = x
    theta_unw[0] = theta_unwrapped
    prev = np.full(3, 0.5)
    t_act = p.t_act_s
    segments = ((t_act, True), (p.ts_s - t_act, False))
    breaks = load_profile_breaks(p) if load_mode == "continuous" else []
    for k in range(n):
        t_k = k * p.ts_s
        if p.dyno:
            dw = targets[k] - x[2]
            if p.dyno_accel_rad_s2 > 0.0:
                model.dyno_accel = float(np.clip(dw / p.ts_s, -p.dyno_accel_rad_s2, p.dyno_accel_rad_s2))
            else:
                model.dyno_accel = 0.0
                x = np.array([x[0], x[1], targets[k], x[3]])
            accel[k + 1] = model.dyno_accel
        extra = load[k]
        if load_mode == "period_mean" and p.load_profile != "none":
            extra = load[k] + load_profile_period_mean(p, t_k, t_k + p.ts_s)
        t_seg = t_k
        for length, old in segments:
            if length <= 0.0:
                if old:
                    act[k] = (INV_CLARKE @ model.currents_ab(x))
                continue
            model.set_inputs(prev if old else duties[k], extra)
            meth = method or ("Radau" if model.has_disabled else "DOP853")
            # split at load-profile breakpoints inside the segment (continuous load)
            cuts = [t_seg] + [b for b in breaks if t_seg < b < t_seg + length] + [t_seg + length]
            for a, b in zip(cuts[:-1], cuts[1:]):
                th_start = x[3] % (2.0 * math.pi)  # keep theta small: its rtol is then absolute
                x = np.array([x[0], x[1], x[2], th_start])
                model.t_offset = a
                sol = solve_ivp(model.rhs, (0.0, b - a), x, method=meth, rtol=rtol, atol=atol)
                if not sol.success:
                    raise RuntimeError(f"reference: solve_ivp failed in period {k}: {sol.message}")
                x = sol.y[:, -1]
                theta_unwrapped += x[3] - th_start
            t_seg += length
            if old:
                act[k] = INV_CLARKE @ model.currents_ab(x)
        prev = duties[k]
        out[k + 1] = x
        theta_unw[k + 1] = theta_unwrapped

    i_ab = np.array([model.currents_ab(row) for row in out])
    th = out[:, 3]
    i_d = np.cos(th) * i_ab[:, 0] + np.sin(th) * i_ab[:, 1]
    i_q = -np.sin(th) * i_ab[:, 0] + np.cos(th) * i_ab[:, 1]
    if p.saturation:
        psi_d = np.array([psi_d_curve(p, v) for v in i_d])
        te = 1.5 * p.pole_pairs * (psi_d * i_q - p.lq_h * i_q * i_d)
    else:
        te = 1.5 * p.pole_pairs * (p.psi_f_wb * i_q + (p.ld_h - p.lq_h) * i_d * i_q)
    torque_dyno = None
    if p.dyno:
        w = out[:, 2]
        fr = p.b_nms * w + (p.coulomb_nm * np.tanh(w / p.coulomb_band_rad_s) if p.coulomb_nm > 0 else 0.0)
        torque_dyno = te - fr - p.j_kgm2 * accel
    return ReferenceResult(
        t_s=np.arange(n + 1) * p.ts_s,
        i_abc_a=i_ab @ INV_CLARKE.T,
        i_alpha_a=i_ab[:, 0],
        i_beta_a=i_ab[:, 1],
        i_d_a=i_d,
        i_q_a=i_q,
        omega_m_rad_s=out[:, 2],
        theta_e_rad=np.mod(th, 2.0 * math.pi),
        theta_m_rad=theta_m0 + (theta_unw - theta_unw[0]) / p.pole_pairs,
        torque_e_nm=te,
        i_abc_act_a=act,
        torque_dyno_nm=torque_dyno,
    )


# ---------------------------------------------------------------------------------------------
# faults (plant_rt/c/plant_fault.h): the circuit written out, independently of the C network code

@dataclass
class FaultResult:
    """Fault reference at t_k = k Ts, k = 0..n: machine phase currents, leg currents (what the
    inverter carries; differs from the machine's in a phase short), the short current
    (x -> y, averaged model), speed and angle."""

    t_s: np.ndarray
    i_abc_a: np.ndarray        # (n+1, 3) machine phase currents
    i_leg_abc_a: np.ndarray    # (n+1, 3) inverter leg currents
    i_short_a: np.ndarray      # (n+1,)
    omega_m_rad_s: np.ndarray
    theta_e_rad: np.ndarray


class _FaultModel(_Model):
    """The machine as phase circuits with a faulted terminal network.

    Full state: (psi_alpha, psi_beta, omega_m, theta_e) as in _Model. With an open wire at
    phase x the machine is ONE circuit through phases y and z (i_y = -i_z = i, i_x = 0): the
    state is the loop's flux linkage lambda = psi_y - psi_z (psi_abc = INV_CLARKE psi_ab),
    lambda' = (u_y - u_z) - 2 R i, i = (lambda - psi_f q.e(theta)) / (q.L(theta) w) with
    q = u_y - u_z the loop's axis and w = CLARKE (e_y - e_z) its current direction; the loop's
    flux is continuous when the wire opens (the C plant's interruption rule, derived here from
    the loop equation). A phase short R_f between terminals x and y: i_f = (u_x - u_y)/R_f,
    leg currents l_x = i_x + i_f, l_y = i_y - i_f; a disabled leg's terminal is the smooth diode
    u = V_dc/2 (1 - tanh(l/i0)) of its LEG current, so the terminals of disabled legs in the
    short solve an implicit equation (monotone: brentq). A stuck leg's terminal is a rail.
    """

    def __init__(self, p: RefParams, diode_i0_a: float):
        super().__init__(p, "alphabeta", diode_i0_a, "continuous")
        if p.inverter_nonlinear or p.saturation:
            raise ValueError("the fault reference models the ideal inverter and linear magnetics")
        self.open_phase: int | None = None
        self.stuck: dict[int, int] = {}
        self.short: tuple[int, int, float] | None = None
        self.v_dc = p.v_dc_v
        self.extra_load = 0.0

    # -- terminals -----------------------------------------------------------------------------
    def diode(self, l: float) -> float:
        return 0.5 * self.v_dc * (1.0 - math.tanh(l / self.i0))

    def source(self, k: int) -> float | None:
        """Terminal voltage of a leg that is a voltage source, None for a disabled leg."""
        if k in self.stuck:
            return self.v_dc if self.stuck[k] else 0.0
        if self.enabled[k]:
            return float(self.duty[k]) * self.v_dc
        return None

    def terminals(self, i_abc: np.ndarray) -> tuple[np.ndarray, float]:
        """Terminal voltages u (w.r.t. the - rail) and the short current for machine currents."""
        from scipy.optimize import brentq
        u = np.empty(3)
        src = [self.source(k) for k in range(3)]
        if self.short is None:
            for k in range(3):
                u[k] = src[k] if src[k] is not None else self.diode(i_abc[k])
            return u, 0.0
        x, y, r = self.short
        z = 3 - x - y
        u[z] = src[z] if src[z] is not None else self.diode(i_abc[z])
        vdc = self.v_dc
        if src[x] is not None and src[y] is not None:
            u[x], u[y] = src[x], src[y]
        elif src[y] is not None:
            u[y] = src[y]
            u[x] = brentq(lambda ux: ux - self.diode(i_abc[x] + (ux - u[y]) / r),
                          -vdc, 2.0 * vdc, xtol=1e-13, rtol=1e-15, maxiter=500)
        elif src[x] is not None:
            u[x] = src[x]
            u[y] = brentq(lambda uy: uy - self.diode(i_abc[y] - (u[x] - uy) / r),
                          -vdc, 2.0 * vdc, xtol=1e-13, rtol=1e-15, maxiter=500)
        else:
            def f(vf: float) -> float:
                return vf - self.diode(i_abc[x] + vf / r) + self.diode(i_abc[y] - vf / r)
            vf = brentq(f, -2.0 * vdc, 2.0 * vdc, xtol=1e-13, rtol=1e-15, maxiter=500)
            u[x] = self.diode(i_abc[x] + vf / r)
            u[y] = self.diode(i_abc[y] - vf / r)
        return u, (u[x] - u[y]) / r

    # -- open wire: the loop through the two other phases ----------------------------------------
    def loop_vectors(self) -> tuple[np.ndarray, np.ndarray, int, int]:
        x = self.open_phase
        y, z = (x + 1) % 3, (x + 2) % 3
        q = INV_CLARKE[y] - INV_CLARKE[z]
        w = CLARKE[:, y] - CLARKE[:, z]
        return q, w, y, z

    def inductance_ab(self, th: float) -> np.ndarray:
        p = self.p
        l0, l2 = 0.5 * (p.ld_h + p.lq_h), 0.5 * (p.ld_h - p.lq_h)
        c2, s2 = math.cos(2.0 * th), math.sin(2.0 * th)
        return np.array([[l0 + l2 * c2, l2 * s2], [l2 * s2, l0 - l2 * c2]])

    def loop_current(self, lam: float, th: float) -> float:
        q, w, _, _ = self.loop_vectors()
        e = np.array([math.cos(th), math.sin(th)])
        return (lam - self.p.psi_f_wb * float(q @ e)) / float(q @ self.inductance_ab(th) @ w)

    def to_loop(self, x_full: np.ndarray) -> np.ndarray:
        q, _, _, _ = self.loop_vectors()
        return np.array([float(q @ x_full[:2]), x_full[2], x_full[3]])

    def to_full(self, x_loop: np.ndarray) -> np.ndarray:
        _, w, _, _ = self.loop_vectors()
        th = x_loop[2]
        i_ab = self.loop_current(x_loop[0], th) * w
        psi = self.inductance_ab(th) @ i_ab + self.p.psi_f_wb * np.array([math.cos(th), math.sin(th)])
        return np.array([psi[0], psi[1], x_loop[1], th])

    # -- right-hand sides ----------------------------------------------------------------------
    def mech(self, te: float, wm: float) -> float:
        p = self.p
        return (te - p.b_nms * wm - self.load_nm - self.extra_load) / p.j_kgm2

    def rhs_full(self, _t: float, x: np.ndarray) -> np.ndarray:
        p = self.p
        i_ab = self.currents_ab(x)
        u, _ = self.terminals(INV_CLARKE @ i_ab)
        v_ab = CLARKE @ (u - u.mean())
        d = v_ab - p.rs_ohm * i_ab
        te = 1.5 * p.pole_pairs * (x[0] * i_ab[1] - x[1] * i_ab[0])
        return np.array([d[0], d[1], self.mech(te, x[2]), p.pole_pairs * x[2]])

    def rhs_loop(self, _t: float, x: np.ndarray) -> np.ndarray:
        p = self.p
        lam, wm, th = x
        i = self.loop_current(lam, th)
        q, w, y, z = self.loop_vectors()
        i_abc = np.zeros(3)
        i_abc[y], i_abc[z] = i, -i
        u, _ = self.terminals(i_abc)
        i_ab = i * w
        psi = self.inductance_ab(th) @ i_ab + p.psi_f_wb * np.array([math.cos(th), math.sin(th)])
        te = 1.5 * p.pole_pairs * (psi[0] * i_ab[1] - psi[1] * i_ab[0])
        return np.array([u[y] - u[z] - 2.0 * p.rs_ohm * i, self.mech(te, wm), p.pole_pairs * wm])

    def observe(self, x_full: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """Machine currents, leg currents, short current at a full state."""
        i_abc = INV_CLARKE @ self.currents_ab(x_full)
        if self.open_phase is not None:
            i_abc[self.open_phase] = 0.0
        u, i_f = self.terminals(i_abc)
        leg = i_abc.copy()
        if self.short is not None:
            x, y, _ = self.short
            leg[x] += i_f
            leg[y] -= i_f
        return i_abc, leg, i_f


def simulate_faults(params: Any, duties: np.ndarray, faults: list[dict[str, Any]], *,
                    theta_e0: float = 0.0, omega_m0: float = 0.0, load_torque_nm: float = 0.0,
                    rtol: float = 1e-10, diode_i0_a: float = 1e-6) -> FaultResult:
    """Integrate len(duties) periods with faults switched at period starts.

    faults: dicts {kind, k_on, k_off (None: never), phase, phase2, level, value} with kind one
    of "open_phase", "leg_stuck", "phase_short", "vdc", "load_torque" (same meaning as
    hil_bench.plant_rt.plant.FAULT_KINDS). Ideal inverter, linear magnetics. Duty semantics as simulate().
    """
    p = RefParams.of(params)
    duties = np.asarray(duties, dtype=float)
    n = duties.shape[0]
    model = _FaultModel(p, diode_i0_a)
    model.load_nm = float(load_torque_nm)
    x = model.initial_state(theta_e0 % (2.0 * math.pi), omega_m0)   # full state
    t_act = p.t_act_s
    out_i = np.empty((n + 1, 3))
    out_leg = np.empty((n + 1, 3))
    out_if = np.empty(n + 1)
    out_w = np.empty(n + 1)
    out_th = np.empty(n + 1)
    prev = np.full(3, 0.5)

    def record(k: int) -> None:
        i_abc, leg, i_f = model.observe(x)
        out_i[k], out_leg[k], out_if[k] = i_abc, leg, i_f
        out_w[k], out_th[k] = x[2], x[3] % (2.0 * math.pi)

    def apply(k: int) -> None:
        nonlocal x
        for f in faults:
            on = f["k_on"] <= k and (f.get("k_off") is None or k < f["k_off"])
            kind = f["kind"]
            if kind == "open_phase":
                if on and model.open_phase is None:
                    model.open_phase = int(f["phase"])
                    x = model.to_full(model.to_loop(x))   # the loop's flux is continuous
                elif not on and model.open_phase == int(f["phase"]):
                    model.open_phase = None
            elif kind == "leg_stuck":
                if on:
                    model.stuck[int(f["phase"])] = int(f.get("level", 1))
                else:
                    model.stuck.pop(int(f["phase"]), None)
            elif kind == "phase_short":
                model.short = (int(f["phase"]), int(f["phase2"]), float(f["value"])) if on else None
            elif kind == "vdc":
                model.v_dc = float(f["value"]) if on else p.v_dc_v
            elif kind == "load_torque":
                model.extra_load = float(f["value"]) if on else 0.0
            else:
                raise ValueError(f"fault kind {kind!r} is not in the reference")

    apply(0)
    model.set_inputs(prev, model.load_nm)
    record(0)
    for k in range(n):
        apply(k)
        for length, old in ((t_act, True), (p.ts_s - t_act, False)):
            if length <= 0.0:
                continue
            model.set_inputs(prev if old else duties[k], model.load_nm)
            if model.open_phase is not None:
                y0 = model.to_loop(x)
                y0[2] %= 2.0 * math.pi
                sol = solve_ivp(model.rhs_loop, (0.0, length), y0, method="Radau", rtol=rtol,
                                atol=np.array([1e-13, 1e-10, 1e-12]))
                x = model.to_full(sol.y[:, -1])
            else:
                x0 = np.array([x[0], x[1], x[2], x[3] % (2.0 * math.pi)])
                meth = "Radau" if (model.has_disabled or model.short is not None) else "DOP853"
                sol = solve_ivp(model.rhs_full, (0.0, length), x0, method=meth, rtol=rtol,
                                atol=np.array([1e-13, 1e-13, 1e-10, 1e-12]))
                x = sol.y[:, -1]
            if not sol.success:
                raise RuntimeError(f"fault reference: solve_ivp failed in period {k}: {sol.message}")
        prev = duties[k]
        model.set_inputs(prev, model.load_nm)
        record(k + 1)
    return FaultResult(t_s=np.arange(n + 1) * p.ts_s, i_abc_a=out_i, i_leg_abc_a=out_leg,
                       i_short_a=out_if, omega_m_rad_s=out_w, theta_e_rad=out_th)
