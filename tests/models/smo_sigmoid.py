"""Improved SMO with sigmoid switching and the intermediate variable H, float64 (Yuan eq. 11-18).

Written from the paper, independently of firmware_stub/src/est_smo_sigmoid.c:

* observer (eq. 11): d i^/dt = -(R/Ls) i^ + u/Ls - (K/Ls) sigmoid(i^ - i) + H/(2 Ls),
  sigmoid(x) = 2/(1 + exp(-a x)) - 1 evaluated literally (the C uses the identity tanh(a x/2));
* H = wc/(s + wc) {K sigmoid(i^ - i)} (eq. 11), E^ = H/2 (eq. 14);
* theta = atan(-Ha/Hb) + atan(w^/wc) (eq. 15), full quadrant; lag_comp = 2 uses atan(2 w^/wc)
  (the lag H really has, see docs/estimators_smo.md), lag_comp = 0 none;
* speed: the angle-tracking PLL of est_common (kp, ki), run on theta.

Both continuous blocks are discretised with scipy.signal.cont2discrete (zero-order hold): the
current model with the input u - z + H/2 held over the period, the LPF with z held.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import signal

TWO_PI = 2.0 * math.pi


def zoh_first_order(a: float, b: float, ts_s: float) -> tuple[float, float]:
    """ZOH discretisation of x' = a x + b u: returns (phi, gamma) with x+ = phi x + gamma u."""
    ad, bd, _, _, _ = signal.cont2discrete((np.array([[a]]), np.array([[b]]), np.array([[1.0]]),
                                            np.array([[0.0]])), ts_s, method="zoh")
    return float(ad[0, 0]), float(bd[0, 0])


def sigmoid(x, a_per_a: float):
    """Yuan's switching function 2/(1 + exp(-a x)) - 1 (argument clipped to avoid overflow)."""
    arg = np.clip(-a_per_a * np.asarray(x, dtype=float), -700.0, 700.0)
    return 2.0 / (1.0 + np.exp(arg)) - 1.0


def min_gain_v(psi_f_wb: float, omega_e_max_rad_s: float) -> float:
    """Eq. 18 with the EMF amplitude of eq. 2: K > max|2E| = 2 psi_f omega_e_max."""
    return 2.0 * psi_f_wb * abs(omega_e_max_rad_s)


def wrap_2pi(x: float) -> float:
    return x % TWO_PI


def wrap_pi(x: float) -> float:
    return (x + math.pi) % TWO_PI - math.pi


class Pll:
    """The est_common angle-tracking PLL (type 2), float64."""

    def __init__(self, kp: float, ki: float, ts_s: float):
        self.kp, self.ki, self.ts = kp, ki, ts_s
        self.theta = 0.0
        self.omega = 0.0

    def step(self, theta_in: float) -> float:
        return self.step_error(wrap_pi(theta_in - self.theta))

    def step_error(self, err: float) -> float:
        self.omega += self.ki * self.ts * err
        self.theta = wrap_2pi(self.theta + (self.omega + self.kp * err) * self.ts)
        return self.omega


#: default |electrical speed| below which the direction is held (EST_EMF_DIR_SPEED_RAD_S)
DIR_SPEED_RAD_S = 1.0


#: how long the speed must contradict the PLL angle's polarity before it is re-aligned [s]
RESYNC_S = 0.01


class EmfAngle:
    """The rotor angle from a back-EMF angle for both directions of rotation, float64.

    Specification (docs/estimators_smo.md, "Negative speed and reversal"): e = w psi_f (-sin, cos),
    so atan2(-e_a, e_b) is theta + pi when w < 0. The PLL tracks that angle modulo pi (errors
    folded into [-pi/2, pi/2]), so its speed is the signed rotor speed and its angle keeps the
    polarity by continuity. dir is the EMF angle's polarity relative to the PLL angle. Where the
    PLL speed w and w + kp err agree in sign and both reach dir_speed, a counter rises when the
    speed's sign contradicts dir and falls when it confirms it; at RESYNC_S worth of steps the
    PLL angle is moved by pi. Output: EMF angle (+ pi for dir < 0) where
    |w| >= dir_speed, the PLL angle below (dir_speed <= 0: never).
    """

    def __init__(self, kp: float, ki: float, ts_s: float, dir_speed_rad_s: float = DIR_SPEED_RAD_S):
        self.pll = Pll(kp, ki, ts_s)
        self.dir = 1
        self.disagree_n = 0
        self.dir_speed = dir_speed_rad_s
        self.ts = ts_s

    def step(self, theta_emf: float) -> float:
        w = self.pll.omega
        err = wrap_pi(theta_emf - self.pll.theta)
        flipped = abs(err) > math.pi / 2
        if flipped:
            err = wrap_pi(err + math.pi)
        self.dir = -1 if flipped else 1
        f = w + self.pll.kp * err
        if abs(w) >= self.dir_speed and abs(f) >= self.dir_speed and (w < 0) == (f < 0) and w != 0:
            if (w < 0) != flipped:          # evidence against the PLL angle's polarity
                self.disagree_n += 1
                if self.disagree_n * self.ts >= RESYNC_S - 1e-12:
                    self.pll.theta = wrap_2pi(self.pll.theta + math.pi)
                    self.dir = -self.dir
                    self.disagree_n = 0
            elif self.disagree_n > 0:       # evidence for it
                self.disagree_n -= 1
        self.pll.step_error(err)
        if abs(w) >= self.dir_speed:
            return wrap_2pi(theta_emf + (math.pi if self.dir < 0 else 0.0))
        return self.pll.theta


class SmoSigmoidModel:
    def __init__(self, rs_ohm, ls_h, psi_f_wb, ts_s, k_v, a_per_a, wc_rad_s, lag_comp,
                 pll_kp, pll_ki, dir_speed_rad_s=DIR_SPEED_RAD_S):
        del psi_f_wb  # not used by the observer itself (only by the gain rule)
        self.f, self.g = zoh_first_order(-rs_ohm / ls_h, 1.0 / ls_h, ts_s)
        self.lpf_a, self.lpf_b = zoh_first_order(-wc_rad_s, wc_rad_s, ts_s)
        self.k, self.a, self.wc, self.lag_comp = k_v, a_per_a, wc_rad_s, lag_comp
        self.angle = EmfAngle(pll_kp, pll_ki, ts_s, dir_speed_rad_s)
        self.pll = self.angle.pll
        self.i_hat = np.zeros(2)
        self.z = np.zeros(2)
        self.h = np.zeros(2)
        self.omega = 0.0

    def load_state(self, i_hat, z, h, pll_theta, pll_omega, omega_out, direction=(1, 0)):
        """Start the next step from a given state (one-step comparisons)."""
        self.i_hat, self.z, self.h = (np.array(i_hat, float), np.array(z, float),
                                      np.array(h, float))
        self.pll.theta, self.pll.omega = float(pll_theta), float(pll_omega)
        self.omega = float(omega_out)
        self.angle.dir, self.angle.disagree_n = direction

    def lag_rad(self, omega: float) -> float:
        if self.lag_comp == 1:
            return math.atan(omega / self.wc)
        if self.lag_comp == 2:
            return math.atan(2.0 * omega / self.wc)
        return 0.0

    def step(self, i_ab, v_ab_prev):
        """Returns (theta, omega, E^alpha, E^beta) for the measured i_ab at t_k."""
        u = np.asarray(v_ab_prev, float) - self.z + 0.5 * self.h                     # eq. 11
        self.i_hat = self.f * self.i_hat + self.g * u
        self.z = self.k * sigmoid(self.i_hat - np.asarray(i_ab, float), self.a)       # eq. 11
        self.h = self.lpf_a * self.h + self.lpf_b * self.z                            # H
        theta = self.angle.step(math.atan2(-self.h[0], self.h[1])
                                + self.lag_rad(self.omega))                       # eq. 15
        self.omega = self.pll.omega
        return theta, self.omega, 0.5 * self.h[0], 0.5 * self.h[1]                  # eq. 14
