"""Float64 references for the HF-injection estimator (Hou et al. 2021, eq. 8-20, section 3).

* :class:`HfiModel` -- the estimator in float64: eq. 8 injection in the estimated frame, the
  projections on theta^ + pi/4 and theta^ + 3 pi/4, the bin-1 amplitudes as explicit window sums
  over one HF period (no recursion), eq. 15 normalised, PI tracking, IPD (lock, polarity, pi
  correction). Polarity (pure method): per HF period r_i = Re(X2 conj(X1)^2) / |X1|^3 from the
  period's DFT bins 1, 2 as explicit sums, their mean and standard error (numpy, ddof = 1) at the
  sequential test's looks. Same decisions as est_hfi.c, independent arithmetic.
* :class:`StandstillMotor` -- a synthetic machine held at a fixed rotor angle, flux as state,
  with optional d-axis saturation: psi_d = psi_s tanh((psi_f + L_d0 i_d) / psi_s), so the
  incremental d inductance falls when the current points towards N (i_d > 0). L_d0 is chosen so
  the incremental inductance at i_d = 0 equals ld_h. Voltages are held over each period (ZOH);
  RK4 sub-steps. This is the synthetic polarity test until the plant gets saturation.
* ``expected_bias_rad`` -- the resistance-induced steady-state error of the tracking (ellipse tilt).
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np


def expected_bias_rad(rs_ohm: float, ld_h: float, lq_h: float, f_inj_hz: float) -> float:
    """dtheta = theta - theta^ at which eq. 15 is zero when R != 0 (continuous time).

    With Z_d = R + j w L_d, Z_q = R + j w L_q, a = 1/|Z_d|, b = 1/|Z_q| and phi = arg Z:
    |i_d''|^2 - |i_q''|^2 ~ (a^2 - b^2) sin 2dth - 2 a b sin(phi_d - phi_q) cos 2dth.
    """
    w = 2 * math.pi * f_inj_hz
    zd, zq = complex(rs_ohm, w * ld_h), complex(rs_ohm, w * lq_h)
    a, b = 1 / abs(zd), 1 / abs(zq)
    s = math.sin(math.atan2(zd.imag, zd.real) - math.atan2(zq.imag, zq.real))
    return 0.5 * math.atan2(2 * a * b * s, a * a - b * b)


class HfiModel:
    """Float64 HFI estimator mirroring est_hfi (state names as in the C)."""

    def __init__(self, ts_s, kp_rad_s, ki_rad_s2, *, f_inj_hz=1250.0, u_inj_v=6.0,
                 speed_lpf_rad_s=100.0, theta0_rad=0.0, ipd_on_reset=True, lock_tol_rad=0.01,
                 lock_time_s=0.01, ipd_timeout_s=0.5, pol_time_s=0.02, pol_margin=0.001,
                 pol_z=4.0, pol_bias_a=0.0):
        self.ts, self.kp, self.ki = ts_s, kp_rad_s, ki_rad_s2
        self.m = int(round(1.0 / (f_inj_hz * ts_s)))
        self.u = u_inj_v
        self.a_speed = 1 - math.exp(-speed_lpf_rad_s * ts_s) if speed_lpf_rad_s > 0 else 1.0
        self.lock_tol, self.margin, self.bias = lock_tol_rad, pol_margin, pol_bias_a
        self.z = pol_z
        self.lock_n = int(round(lock_time_s / ts_s))
        self.timeout_n = int(round(ipd_timeout_s / ts_s))
        # half up, as the C (Python round() is half-even: 12.5 -> 12)
        self.pol_periods = max(4, 2 * int(math.floor(0.5 * pol_time_s * f_inj_hz + 0.5)))
        m = self.m
        self.w_hf = np.exp(1j * 2 * math.pi * np.arange(m) / m)  # e^{j w_i i}, newest first
        self.win_d = deque([0.0] * m, maxlen=m)   # newest at index 0
        self.win_q = deque([0.0] * m, maxlen=m)
        self.win_i = deque([0j] * m, maxlen=m)
        self.n = 0
        self.inj_idx = 0
        self.theta = theta0_rad % (2 * math.pi)
        self.integ = 0.0
        self.omega = 0.0
        self.state = "IPD_CONVERGE" if ipd_on_reset else "TRACKING"
        self.polarity = "UNKNOWN"
        self.pol_metric = self.pol_se = 0.0
        self._enter(self.state)

    def _enter(self, state):
        self.state = state
        self.t_n = 0
        self.lock_count = 0
        self.i_d_req = 0.0
        self.pol_period = 0
        self.period_x = []            # the projection's samples of this HF period
        self.ratios = []              # per-period r_i (pure method)
        self.look = self.pol_periods  # HF periods at the next look (sequential test)
        self.amp_sum = [0.0, 0.0]
        self.amp_cnt = [0, 0]

    def _bin1(self, win) -> complex:
        """Normalised bin-1 phasor of a real window at the newest sample (explicit sum)."""
        return 2.0 / self.m * complex(np.dot(np.asarray(win), self.w_hf))

    def step(self, i_ab: complex) -> dict:
        th = self.theta
        i_f = i_ab * np.exp(-1j * (th + math.pi / 4))          # d''q'' (eq. 14)
        self.win_d.appendleft(i_f.real)
        self.win_q.appendleft(i_f.imag)
        self.n += 1
        p_d, p_q = self._bin1(self.win_d), self._bin1(self.win_q)
        period_end = self.inj_idx == self.m - 1
        s2 = c2 = 0.0
        out = dict(theta=th, amp_d=0.0, amp_q=0.0, i_fund=i_ab)
        if self.n >= self.m:
            a2d, a2q = abs(p_d) ** 2, abs(p_q) ** 2
            s = a2d + a2q
            s2 = (a2d - a2q) / s                                # eq. 15, normalised
            c2 = -2 * (p_d * p_q.conjugate()).real / s          # eq. 13 (cos 2dtheta)
            out.update(amp_d=abs(p_d), amp_q=abs(p_q),
                       i_fund=i_ab - (p_d.real + 1j * p_q.real) * np.exp(1j * (th + math.pi / 4)))
        flipped = False
        if self.state in ("IPD_CONVERGE", "IPD_POLARITY"):
            flipped = self._ipd(i_ab, th, p_d, p_q, s2, c2, period_end)
        th_inj = th + (math.pi if flipped else 0.0)
        phi = 2 * math.pi * self.inj_idx / self.m
        v_inj = self.u * (math.sin(phi) + 1j * math.cos(phi)) * np.exp(1j * th_inj)  # eq. 8
        self.inj_idx = (self.inj_idx + 1) % self.m
        w = self.integ + self.kp * s2
        self.integ += self.ki * self.ts * s2
        self.theta = (self.theta + w * self.ts) % (2 * math.pi)
        self.omega += self.a_speed * (self.integ - self.omega)
        out.update(err=s2, v_inj=v_inj, omega=self.omega, state=self.state,
                   polarity=self.polarity, pol_metric=self.pol_metric, pol_se=self.pol_se,
                   i_d_req=self.i_d_req)
        return out

    def _ipd(self, i_ab, th, p_d, p_q, s2, c2, period_end) -> bool:
        self.win_i.appendleft(i_ab)
        self.t_n += 1
        if self.state == "IPD_CONVERGE":
            dth = 0.5 * math.atan2(s2, c2)
            self.lock_count = self.lock_count + 1 if abs(dth) < self.lock_tol else 0
            if self.lock_count >= self.lock_n and period_end:
                self._enter("IPD_POLARITY")
            elif self.t_n >= self.timeout_n:
                self._enter("IPD_FAILED")
            return False
        ac = i_ab - np.mean(self.win_i)
        s_ac = (ac * np.exp(-1j * th)).real
        amp_theta = abs(p_d - p_q) / math.sqrt(2)
        half = self.pol_periods // 2
        second = int(self.pol_period >= half)
        self.period_x.append((self.inj_idx, s_ac))
        self.i_d_req = (-self.bias if second else self.bias) if self.bias > 0 else 0.0
        if not period_end:
            return False
        # r_i = B cos(b) / A of x = A cos(phi) + B cos(2 phi + b): the DFT bins 1 and 2 of the
        # period (explicit sums over its samples at their injection phase)
        idx = np.array([k for k, _ in self.period_x])
        x = np.array([v for _, v in self.period_x])
        x1 = complex(np.sum(x * np.exp(-2j * math.pi * idx / self.m)))
        x2 = complex(np.sum(x * np.exp(-4j * math.pi * idx / self.m)))
        self.ratios.append((x2 * x1.conjugate() ** 2).real / abs(x1) ** 3 if abs(x1) > 0 else 0.0)
        self.period_x = []
        if self.pol_period % half >= half // 2:
            self.amp_sum[second] += amp_theta
            self.amp_cnt[second] += 1
        self.pol_period += 1
        final = True
        if self.bias > 0:
            if self.pol_period < self.pol_periods:
                return False
            ap, an = (self.amp_sum[i] / max(self.amp_cnt[i], 1) for i in (0, 1))
            r, se = (ap - an) / (ap + an), 0.0
            decided = abs(r) > self.margin
        else:
            if self.pol_period < self.look:
                return False
            final = 2 * self.look * self.m > self.timeout_n
            rs = np.array(self.ratios)
            r = float(np.mean(rs))
            se = float(np.std(rs, ddof=1) / math.sqrt(len(rs))) if len(rs) > 1 else 0.0
            decided = abs(r) > self.margin and (self.z <= 0 or abs(r) > self.z * se)
        self.pol_metric, self.pol_se = r, se
        if decided and r > 0:
            self.polarity = "KEPT"
            self._enter("TRACKING")
        elif decided:
            self.polarity = "FLIPPED"
            self.theta = (self.theta + math.pi) % (2 * math.pi)
            self.win_d = deque([-x for x in self.win_d], maxlen=self.m)
            self.win_q = deque([-x for x in self.win_q], maxlen=self.m)
            self.inj_idx = (self.inj_idx + self.m // 2) % self.m
            self._enter("TRACKING")
            return True
        elif final or abs(r) + max(self.z, 0.0) * se < self.margin:   # futility: stop undecided
            self._enter("IPD_FAILED")
        else:
            self.look *= 2
        return False


class StandstillMotor:
    """IPMSM held at rotor angle theta_e_rad (omega = 0), optional d-axis saturation.

    psi_s_wb = None: linear (psi_d = psi_f + ld i_d). Otherwise
    psi_d = psi_s tanh((psi_f + L_d0 i_d) / psi_s), L_d0 = ld / (1 - tanh^2(psi_f / psi_s)).
    """

    def __init__(self, theta_e_rad, rs_ohm, ld_h, lq_h, psi_f_wb, ts_s, *, psi_s_wb=None,
                 substeps=8):
        self.theta, self.r, self.ld, self.lq, self.psi_f = theta_e_rad, rs_ohm, ld_h, lq_h, psi_f_wb
        self.ts, self.n_sub, self.psi_s = ts_s, substeps, psi_s_wb
        if psi_s_wb is None:
            self.ld0 = ld_h
            self.psi = np.array([psi_f_wb, 0.0])
        else:
            self.ld0 = ld_h / (1 - math.tanh(psi_f_wb / psi_s_wb) ** 2)
            self.psi = np.array([psi_s_wb * math.tanh(psi_f_wb / psi_s_wb), 0.0])

    def current_dq(self, psi=None) -> np.ndarray:
        pd, pq = self.psi if psi is None else psi
        if self.psi_s is None:
            i_d = (pd - self.psi_f) / self.ld
        else:
            i_d = (self.psi_s * math.atanh(pd / self.psi_s) - self.psi_f) / self.ld0
        return np.array([i_d, pq / self.lq])

    def i_ab(self) -> complex:
        i = self.current_dq()
        return complex(i[0], i[1]) * np.exp(1j * self.theta)

    def incremental_ld_h(self, i_d_a: float) -> float:
        """d psi_d / d i_d at i_d (for the test's expectations)."""
        if self.psi_s is None:
            return self.ld
        return self.ld0 * (1 - math.tanh((self.psi_f + self.ld0 * i_d_a) / self.psi_s) ** 2)

    def step(self, v_ab: complex) -> None:
        """Hold v_ab for one period (RK4)."""
        v = v_ab * np.exp(-1j * self.theta)
        v = np.array([v.real, v.imag])
        h = self.ts / self.n_sub
        f = lambda p: v - self.r * self.current_dq(p)  # noqa: E731
        for _ in range(self.n_sub):
            k1 = f(self.psi)
            k2 = f(self.psi + 0.5 * h * k1)
            k3 = f(self.psi + 0.5 * h * k2)
            k4 = f(self.psi + h * k3)
            self.psi = self.psi + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
