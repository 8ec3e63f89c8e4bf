"""Conventional sign SMO in float64 (Yuan eq. 4-10, Gong eq. 3-7).

The current model d i^/dt = (-R i^ + u - z)/Ls and the LPF wc/(s + wc) are discretised with
scipy.signal.cont2discrete (zero-order hold), independently of the C's closed-form exp().
"""
from __future__ import annotations

import math

import numpy as np
from scipy import signal

from tests.models.smo_sigmoid import DIR_SPEED_RAD_S, EmfAngle


def _ss(a: float, b: float):
    """First-order state space x' = a x + b u, y = x, as scipy arrays."""
    return (np.array([[a]]), np.array([[b]]), np.array([[1.0]]), np.array([[0.0]]))


class SmoSignModel:
    def __init__(self, rs_ohm, ls_h, psi_f_wb, ts_s, k_v, wc_rad_s, pll_kp, pll_ki,
                 dir_speed_rad_s=DIR_SPEED_RAD_S):
        a, b, _, _, _ = signal.cont2discrete(_ss(-rs_ohm / ls_h, 1.0 / ls_h), ts_s, method="zoh")
        self.f, self.g = float(a[0, 0]), float(b[0, 0])
        al, bl, _, _, _ = signal.cont2discrete(_ss(-wc_rad_s, wc_rad_s), ts_s, method="zoh")
        self.lpf_a, self.lpf_b = float(al[0, 0]), float(bl[0, 0])
        self.k, self.wc, self.ts = k_v, wc_rad_s, ts_s
        self.angle = EmfAngle(pll_kp, pll_ki, ts_s, dir_speed_rad_s)
        self.i_hat = np.zeros(2)
        self.z = np.zeros(2)
        self.e = np.zeros(2)

    @property
    def omega(self) -> float:
        return self.angle.pll.omega

    def load_state(self, i_hat, z, e, pll_theta, omega, direction=(1, 0)):
        """Start the next step from a given state (one-step comparisons)."""
        self.i_hat, self.z, self.e = np.array(i_hat, float), np.array(z, float), np.array(e, float)
        self.angle.pll.theta, self.angle.pll.omega = float(pll_theta), float(omega)
        self.angle.dir, self.angle.disagree_n = direction

    def step(self, i_ab, v_ab_prev):
        self.i_hat = self.f * self.i_hat + self.g * (np.asarray(v_ab_prev) - self.z)   # eq. 4
        self.z = self.k * np.sign(self.i_hat - np.asarray(i_ab))                      # eq. 6
        self.e = self.lpf_a * self.e + self.lpf_b * self.z                            # LPF
        theta = math.atan2(-self.e[0], self.e[1]) + math.atan(self.omega / self.wc)   # eq. 8-9
        theta = self.angle.step(theta)                     # direction of rotation, speed (PLL)
        return theta, self.omega, self.e[0], self.e[1]
