"""SMO_TANH and its angle step, written from docs/estimators.md (sections 1-3) alone.

What a drive team outside the project would write from the spec: plain Python floats (binary64) and the
``math`` module, no code of the stub, of its bindings or of the project's float64 models. It is held to
the reference vectors and to the stub's G2 speed fluctuation by tests/test_estimator_spec.py.
"""
from __future__ import annotations

import math

TWO_PI = 2.0 * math.pi


def wrap_2pi(a: float) -> float:
    """docs/estimators.md section 3: fmod(a, 2 pi), plus 2 pi if negative, 0 if that rounds to 2 pi."""
    r = math.fmod(a, TWO_PI)
    if r < 0.0:
        r += TWO_PI
    return 0.0 if r >= TWO_PI else r


def wrap_pi(a: float) -> float:
    return wrap_2pi(a + math.pi) - math.pi


class AngleStep:
    """Section 3: the type-2 PLL on the EMF angle, its phase detector folded modulo pi, the polarity."""

    W_DIR_RAD_S = 1.0
    T_RESYNC_S = 0.01

    def __init__(self, kp: float, ki: float, ts_s: float):
        self.kp, self.ki, self.ts = kp, ki, ts_s
        self.theta_pll = 0.0
        self.omega_pll = 0.0
        self.dir = 1
        self.n = 0

    def step(self, theta_emf: float) -> tuple[float, float]:
        w = self.omega_pll
        err = wrap_pi(theta_emf - self.theta_pll)
        flipped = abs(err) > math.pi / 2.0
        if flipped:
            err = wrap_pi(err + math.pi)
        self.dir = -1 if flipped else 1
        f = w + self.kp * err
        if abs(w) >= self.W_DIR_RAD_S and abs(f) >= self.W_DIR_RAD_S and (w < 0.0) == (f < 0.0):
            if (w < 0.0) != flipped:
                self.n += 1
                if self.n * self.ts >= self.T_RESYNC_S:
                    self.theta_pll = wrap_2pi(self.theta_pll + math.pi)
                    self.dir = -self.dir
                    self.n = 0
            elif self.n > 0:
                self.n -= 1
        self.omega_pll += self.ki * self.ts * err
        self.theta_pll = wrap_2pi(self.theta_pll + (self.omega_pll + self.kp * err) * self.ts)
        if abs(w) >= self.W_DIR_RAD_S:
            theta_out = wrap_2pi(theta_emf + (math.pi if self.dir < 0 else 0.0))
        else:
            theta_out = self.theta_pll
        return theta_out, self.omega_pll


class SmoTanh:
    """Section 2: the tanh SMO without a filter, its current model discretised by zero-order hold."""

    def __init__(self, rs_ohm: float, lq_h: float, ts_s: float, k_v: float, m_per_a: float,
                 pll_kp: float = 0.0, pll_ki: float = 0.0, speed_lpf_rad_s: float = 0.0):
        self.f = math.exp(-rs_ohm * ts_s / lq_h) if rs_ohm > 0 else 1.0
        self.g = (1.0 - self.f) / rs_ohm if rs_ohm > 0 else ts_s / lq_h
        self.k, self.m = k_v, m_per_a
        wn = 150.0
        self.angle = AngleStep(pll_kp if pll_kp > 0 else 2.0 * wn, pll_ki if pll_ki > 0 else wn * wn, ts_s)
        self.a_s = 1.0 - math.exp(-speed_lpf_rad_s * ts_s) if speed_lpf_rad_s > 0 else 1.0
        self.i_hat = [0.0, 0.0]
        self.e_hat = [0.0, 0.0]
        self.omega_out = 0.0

    def step(self, i_alpha: float, i_beta: float, v_alpha: float, v_beta: float
             ) -> tuple[float, float, float, float]:
        """(theta_out, omega_out, e^_alpha, e^_beta) for the currents of this step and the voltage that
        acted over the period before it."""
        self.i_hat[0] = self.f * self.i_hat[0] + self.g * (v_alpha - self.e_hat[0])
        self.i_hat[1] = self.f * self.i_hat[1] + self.g * (v_beta - self.e_hat[1])
        for j, i in enumerate((i_alpha, i_beta)):
            x = max(-40.0, min(40.0, self.m * (self.i_hat[j] - i)))
            self.e_hat[j] = self.k * math.tanh(x)
        theta_emf = math.atan2(-self.e_hat[0], self.e_hat[1])
        theta_out, omega_pll = self.angle.step(theta_emf)
        self.omega_out += self.a_s * (omega_pll - self.omega_out)
        return theta_out, self.omega_out, self.e_hat[0], self.e_hat[1]
