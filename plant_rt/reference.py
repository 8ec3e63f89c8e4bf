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
    """Plant constants (SI) used by the reference."""

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

    @classmethod
    def of(cls, obj: Any) -> "RefParams":
        """From a mapping or any object with these attributes (MotorProfile, Plant.params)."""
        get = obj.__getitem__ if isinstance(obj, Mapping) else lambda k: getattr(obj, k)
        return cls(**{f: get(f) for f in cls.__dataclass_fields__})


@dataclass
class ReferenceResult:
    """Solution at the sampling instants t_k = k Ts, k = 0..n (n + 1 rows)."""

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


class _Model:
    def __init__(self, p: RefParams, frame: str, diode_i0_a: float):
        self.p = p
        self.frame = frame
        self.i0 = diode_i0_a
        self.m0 = 0.5 * (1.0 / p.ld_h + 1.0 / p.lq_h)
        self.m2 = 0.5 * (1.0 / p.ld_h - 1.0 / p.lq_h)
        self.duty = np.full(3, 0.5)
        self.enabled = np.ones(3, dtype=bool)
        self.load_nm = 0.0

    def set_inputs(self, duty: np.ndarray, load_nm: float) -> None:
        d = np.asarray(duty, dtype=float)
        self.enabled = d >= 0.0  # NaN compares False -> disabled
        self.duty = np.where(self.enabled, np.minimum(d, 1.0), 0.0)
        self.load_nm = float(load_nm)

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
        c2, s2 = math.cos(2.0 * th), math.sin(2.0 * th)
        lam = np.array([x[0] - p.psi_f_wb * math.cos(th), x[1] - p.psi_f_wb * math.sin(th)])
        linv = np.array([[self.m0 + self.m2 * c2, self.m2 * s2], [self.m2 * s2, self.m0 - self.m2 * c2]])
        return linv @ lam

    def phase_voltages_ab(self, i_ab: np.ndarray) -> np.ndarray:
        """alpha-beta phase voltages [V] from the inverter legs (isolated star)."""
        vdc = self.p.v_dc_v
        v_pole = self.duty * vdc
        if self.has_disabled:
            i_abc = INV_CLARKE @ i_ab
            diode = 0.5 * vdc * (1.0 - np.tanh(i_abc / self.i0))
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
        dw = (te - p.b_nms * wm - self.load_nm) / p.j_kgm2
        return np.array([d0, d1, dw, we])

    def initial_state(self, theta_e0: float, omega_m0: float) -> np.ndarray:
        if self.frame == "dq":
            return np.array([0.0, 0.0, omega_m0, theta_e0])
        p = self.p
        return np.array([p.psi_f_wb * math.cos(theta_e0), p.psi_f_wb * math.sin(theta_e0), omega_m0, theta_e0])


def simulate(params: Any, duties: np.ndarray, *, theta_e0: float = 0.0, omega_m0: float = 0.0,
             load_torque_nm: float | np.ndarray = 0.0, frame: str = "alphabeta",
             rtol: float = 1e-10, atol: np.ndarray | None = None,
             diode_i0_a: float = 1e-6) -> ReferenceResult:
    """Integrate n = len(duties) periods from zero current at (theta_e0, omega_m0).

    params: mapping/object with the plant constants (RefParams fields; e.g. a MotorProfile).
    duties: (n, 3) duties commanded for each period (see module doc).
    load_torque_nm: constant, or (n,) per period (changes at the period start t_k).
    Returns the state at t_0..t_n.
    """
    p = RefParams.of(params)
    if frame not in ("alphabeta", "dq"):
        raise ValueError(f"frame must be 'alphabeta' or 'dq', got {frame!r}")
    duties = np.asarray(duties, dtype=float)
    if duties.ndim != 2 or duties.shape[1] != 3:
        raise ValueError(f"duties must have shape (n, 3), got {duties.shape}")
    n = duties.shape[0]
    load = np.broadcast_to(np.asarray(load_torque_nm, dtype=float), (n,))
    model = _Model(p, frame, diode_i0_a)
    if atol is None:
        flux_or_current = 1e-13 if frame == "alphabeta" else 1e-10
        atol = np.array([flux_or_current, flux_or_current, 1e-10, 1e-12])

    x = model.initial_state(theta_e0 % (2.0 * math.pi), omega_m0)
    theta_unwrapped = theta_e0 % (2.0 * math.pi)
    theta_m0 = theta_unwrapped / p.pole_pairs
    out = np.empty((n + 1, 4))
    theta_unw = np.empty(n + 1)
    out[0] = x
    theta_unw[0] = theta_unwrapped
    prev = np.full(3, 0.5)
    segments = ((p.t_delay_s, True), (p.ts_s - p.t_delay_s, False))
    for k in range(n):
        for length, old in segments:
            if length <= 0.0:
                continue
            model.set_inputs(prev if old else duties[k], load[k])
            method = "Radau" if model.has_disabled else "DOP853"
            th_start = x[3] % (2.0 * math.pi)  # keep theta small: its rtol is then absolute
            x = np.array([x[0], x[1], x[2], th_start])
            sol = solve_ivp(model.rhs, (0.0, length), x, method=method, rtol=rtol, atol=atol)
            if not sol.success:
                raise RuntimeError(f"reference: solve_ivp failed in period {k}: {sol.message}")
            x = sol.y[:, -1]
            theta_unwrapped += x[3] - th_start
        prev = duties[k]
        out[k + 1] = x
        theta_unw[k + 1] = theta_unwrapped

    i_ab = np.array([model.currents_ab(row) for row in out])
    th = out[:, 3]
    i_d = np.cos(th) * i_ab[:, 0] + np.sin(th) * i_ab[:, 1]
    i_q = -np.sin(th) * i_ab[:, 0] + np.cos(th) * i_ab[:, 1]
    te = 1.5 * p.pole_pairs * (p.psi_f_wb * i_q + (p.ld_h - p.lq_h) * i_d * i_q)
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
    )
