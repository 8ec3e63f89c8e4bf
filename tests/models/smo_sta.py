"""Super-twisting SMO in float64 (Hou's comparator, his [8], without [8]'s resistance estimate).

Written from the algorithm (Levant's super-twisting: z = k1 |e|^1/2 sign e + w, w' = k2 sign e)
and the gain condition of docs/estimators_smo.md, not from the C: the current model is
discretised with scipy.signal.cont2discrete (zero-order hold), the gains from the condition
k2/L = 2 m delta, (k1/L)^2 = 12 m^2 delta with delta = w^2 psi / L.

``gamma_r`` > 0 adds the resistance law a Lyapunov function of the current error gives,
R^' = gamma i~ . i^ (R^ kept within [0.5, 2] R), which the C does not have: the test that shows
it drifting in the sampled STA uses it (docs/estimators_smo.md, "Hou's comparator").
"""
from __future__ import annotations

import math

import numpy as np
from scipy import signal

from tests.models.smo_sigmoid import DIR_SPEED_RAD_S, EmfAngle


def zoh(r_ohm: float, ls_h: float, ts_s: float) -> tuple[float, float]:
    a, b, _, _, _ = signal.cont2discrete((np.array([[-r_ohm / ls_h]]), np.array([[1.0 / ls_h]]),
                                          np.array([[1.0]]), np.array([[0.0]])), ts_s, method="zoh")
    return float(a[0, 0]), float(b[0, 0])


def gains(psi_f_wb: float, ls_h: float, omega_e: float, margin: float, omega_min: float):
    w = max(abs(omega_e), omega_min)
    delta = w * w * psi_f_wb / ls_h
    return margin * ls_h * math.sqrt(12.0 * delta), 2.0 * margin * ls_h * delta


class SmoStaModel:
    def __init__(self, rs_ohm, ls_h, psi_f_wb, ts_s, pll_kp, pll_ki, k1_v=0.0, k2_v_s=0.0,
                 k_margin=1.5, omega_min_rad_s=2 * math.pi * 5.0, dir_speed_rad_s=DIR_SPEED_RAD_S,
                 gamma_r=0.0):
        self.ls, self.psi, self.ts = ls_h, psi_f_wb, ts_s
        self.gamma, self.r_hat, self.r_lim = gamma_r, rs_ohm, (0.5 * rs_ohm, 2.0 * rs_ohm)
        self.fixed = (k1_v, k2_v_s) if k1_v > 0 and k2_v_s > 0 else None
        self.margin, self.w_min = k_margin, omega_min_rad_s
        self.angle = EmfAngle(pll_kp, pll_ki, ts_s, dir_speed_rad_s)
        self.f, self.g = zoh(rs_ohm, ls_h, ts_s)
        self.i_hat, self.w, self.z = np.zeros(2), np.zeros(2), np.zeros(2)
        self.k1, self.k2 = self.fixed or gains(psi_f_wb, ls_h, 0.0, k_margin, omega_min_rad_s)

    @property
    def omega(self) -> float:
        return self.angle.pll.omega

    def load_state(self, i_hat, w, z, k1, k2, pll_theta, omega, direction=(1, 0)):
        self.i_hat, self.w, self.z = (np.array(x, float) for x in (i_hat, w, z))
        self.k1, self.k2 = float(k1), float(k2)
        self.angle.pll.theta, self.angle.pll.omega = float(pll_theta), float(omega)
        self.angle.dir, self.angle.disagree_n = direction

    def step(self, i_ab, v_ab_prev):
        i_ab = np.asarray(i_ab, float)
        self.i_hat = self.f * self.i_hat + self.g * (np.asarray(v_ab_prev, float) - self.z)
        e = self.i_hat - i_ab
        self.z = self.k1 * np.sqrt(np.abs(e)) * np.sign(e) + self.w
        self.w = self.w + self.ts * self.k2 * np.sign(e)
        theta = self.angle.step(math.atan2(-self.z[0], self.z[1]))
        if self.gamma > 0:
            self.r_hat = min(max(self.r_hat + self.ts * self.gamma * float(e @ self.i_hat),
                                 self.r_lim[0]), self.r_lim[1])
            self.f = math.exp(-self.r_hat * self.ts / self.ls)     # ZOH, closed form (speed)
            self.g = (1.0 - self.f) / self.r_hat
        if self.fixed is None:
            w_emf = 2.0 * math.hypot(*self.z) / self.psi
            self.k1, self.k2 = gains(self.psi, self.ls, min(abs(self.omega), w_emf), self.margin,
                                     self.w_min)
        return theta, self.omega, self.z[0], self.z[1]
