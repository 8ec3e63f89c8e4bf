"""tanh-switching SMO without a low-pass filter, float64 (Gong eq. 3, 8, 14-19).

Written from the paper, independently of firmware_stub/src/est_smo_tanh.c:

* observer (eq. 3): d i^/dt = -(Rs/Ls) i^ + u/Ls - (k/Ls) F(i^ - i),
  F(x) = (e^{mx} - e^{-mx}) / (e^{mx} + e^{-mx}) evaluated literally (eq. 8);
* e^ = k F(i~) with no filter (eq. 6 with eq. 8);
* theta = -atan(e^a / e^b) (eq. 18), full quadrant; speed (eq. 19, d theta/dt) by the
  est_common angle-tracking PLL;
* gain rule (eq. 14-17) in float64 for the C helpers' checks.

The current model is discretised with scipy.signal.cont2discrete (ZOH, switching term held).
"""
from __future__ import annotations

import math

import numpy as np

from tests.models.smo_sigmoid import DIR_SPEED_RAD_S, EmfAngle, zoh_first_order


def hyperbolic(x, m_per_a: float):
    """Eq. 8, literally, with the exponent clipped (|m x| > 350 is +-1 in float64 anyway)."""
    mx = np.clip(m_per_a * np.asarray(x, dtype=float), -350.0, 350.0)
    ep, em = np.exp(mx), np.exp(-mx)
    return (ep - em) / (ep + em)


def boundary_layer_a(m_per_a: float) -> float:
    """Gong's BL: the |x| at which F = 0.99 (m = 0.01 -> 265 A)."""
    return math.atanh(0.99) / m_per_a


def min_f(m_per_a: float, xi_a: float) -> float:
    """Eq. 16: min |F| = tanh(m xi) for the error tolerance xi of eq. 15."""
    return float(hyperbolic(xi_a, m_per_a))


def gain_rule_v(ce: float, psi_f_wb: float, pole_pairs: int, omega_m_max_rad_s: float,
                min_abs_f: float) -> float:
    """Eq. 17 read as k = 3 sqrt(3) Ce psi_f p w_m_max / (2 min|F|)."""
    return abs(3.0 * math.sqrt(3.0) * ce * psi_f_wb * pole_pairs * omega_m_max_rad_s
               / (2.0 * min_abs_f))


def stability_bound_v(e_max_v: float, min_abs_f: float) -> float:
    """Eq. 14 with |F| at its minimum: k > e_max / min|F|."""
    return e_max_v / min_abs_f


def deadbeat_gain_v_per_a(rs_ohm: float, ls_h: float, ts_s: float) -> float:
    """k*m at which the sampled, linearised error loop i~+ = (phi - gamma k m) i~ is deadbeat."""
    phi, gamma = zoh_first_order(-rs_ohm / ls_h, 1.0 / ls_h, ts_s)
    return phi / gamma


class SmoTanhModel:
    def __init__(self, rs_ohm, ls_h, psi_f_wb, ts_s, k_v, m_per_a, pll_kp, pll_ki,
                 dir_speed_rad_s=DIR_SPEED_RAD_S):
        del psi_f_wb
        self.f, self.g = zoh_first_order(-rs_ohm / ls_h, 1.0 / ls_h, ts_s)
        self.k, self.m = k_v, m_per_a
        self.angle = EmfAngle(pll_kp, pll_ki, ts_s, dir_speed_rad_s)
        self.pll = self.angle.pll
        self.i_hat = np.zeros(2)
        self.e = np.zeros(2)

    def load_state(self, i_hat, e, pll_theta, pll_omega, direction=(1, 0)):
        self.i_hat, self.e = np.array(i_hat, float), np.array(e, float)
        self.pll.theta, self.pll.omega = float(pll_theta), float(pll_omega)
        self.angle.dir, self.angle.disagree_n = direction

    def step(self, i_ab, v_ab_prev):
        """Returns (theta, omega, e^alpha, e^beta) for the measured i_ab at t_k."""
        self.i_hat = self.f * self.i_hat + self.g * (np.asarray(v_ab_prev, float) - self.e)  # eq. 3
        self.e = self.k * hyperbolic(self.i_hat - np.asarray(i_ab, float), self.m)   # eq. 6, 8
        theta = self.angle.step(math.atan2(-self.e[0], self.e[1]))                   # eq. 18
        omega = self.pll.omega                                                       # eq. 19
        return theta, omega, self.e[0], self.e[1]
