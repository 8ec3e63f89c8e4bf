"""Independent switch-level reference of the plant's switching mode, for tests only.

Written from the circuit, not from plant_rt/c (pwm.c, inverter.c's switch-level leg, plant.c's
segment loop): the same machine as ``reference.py`` (stationary-frame flux linkage, its
``_Model.currents_ab``), driven by three inverter legs described by their definitions:

* carrier: a triangle of period Ts, 0 at the valley and 1 at the peak, the valley (or, with
  ``carrier_at_start = "peak"``, the peak) at every period start t_k;
* command of a leg: high while carrier(t) > 1 - d(t), d the compare value in effect, which
  changes from the old to the new duty at the load instant (the first carrier extremum at or
  after the write instant t_k + t_w for "extremum", the next period start for "period", the
  write instant itself for "immediate"); the instants where the command changes are found by
  root finding (``brentq``) on carrier(t) - (1 - d) over each monotone piece, not from a
  closed form;
* gates through a dead-band: a switch is on iff its command has held for the last t_dt, i.e.
  the leg is dead at t iff a command change lies in (t - t_dt, t] (changes of the previous
  period count too);
* a conducting leg's node: upper gate on -> V_dc - V_s(i) (i > 0, switch) or V_dc + V_d(i)
  (i < 0, diode); lower gate on -> -V_d(i) (i > 0, diode) or +V_s(i) (i < 0, switch);
  V_s = v_s q + r_s |i|, V_d = v_d q + r_d |i|, q = tanh(|i| / i_c);
* a dead leg's node, from the phase current i_e at the start of the dead interval and the
  device that carried it just before: a diode keeps conducting (node at its rail with its
  drop at i_e); a switch's current moves the node capacitance C = i_c t_dt / V_dc as
  dv/dt = -i_e / C until the opposite diode clamps it (node voltage integrated in closed form);
* isolated star: v_x = v_xN - mean(v_N).

``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10 by default) restarts at every instant where a
leg's state or node law changes (found as above, the clamp instants as they become known) and
at the sampling instants. Ideal inverter (inverter_nonlinear false): no dead time, no drops.

Duty semantics as the plant's (``reference.py``): duties[k] are written at t_k + t_w (t_w =
t_delay_s, or Ts with full_period_delay), 0.5 before the first period, all legs enabled.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from .reference import CLARKE, INV_CLARKE, RefParams, _Model


@dataclass(frozen=True)
class SwitchingOptions:
    """The switching mode's settings (plant keys of the same names)."""

    carrier_at_start: str = "valley"    # "valley" | "peak"
    pwm_load: str = "extremum"          # "extremum" | "period" | "immediate"
    dual_sample_at: str = "delay"       # "delay" (t_k + t_w) | "half_period" (t_k + Ts/2)

    @classmethod
    def of(cls, obj: Any) -> "SwitchingOptions":
        get = obj.get if isinstance(obj, dict) else (lambda k, d: getattr(obj, k, d))
        return cls(get("carrier_at_start", "valley"), get("pwm_load", "extremum"),
                   get("dual_sample_at", "delay"))


@dataclass
class SwitchingResult:
    """At t_k = k Ts, k = 0..n: ``i_abc_a`` (n+1, 3), ``omega_m_rad_s``, ``theta_e_rad``;
    per period k = 0..n-1: the second sample ``i2_abc_a`` (n, 3) at ``t2_s``, the period's
    average phase voltages ``v_abc_avg_v`` (n, 3) and the command changes ``edge_currents``
    (list of (leg, t_s from the period start, level after, phase current then, period k))."""

    t_s: np.ndarray
    i_abc_a: np.ndarray
    omega_m_rad_s: np.ndarray
    theta_e_rad: np.ndarray
    t2_s: np.ndarray
    i2_abc_a: np.ndarray
    v_abc_avg_v: np.ndarray
    edge_currents: list


class _Leg:
    """One leg: its command changes and the node law of a running dead interval."""

    def __init__(self, level: int):
        self.level = level                  # command now
        self.changes: list[float] = []      # absolute instants of command changes (recent)
        self.dead_law: tuple[float, float, float, float, float] | None = None
        # (t_start, v_start, rate, t_clamp, v_clamp) of the dead interval in progress


class SwitchingReference:
    """The circuit above; ``simulate`` drives it period by period."""

    def __init__(self, p: RefParams, opt: SwitchingOptions):
        if p.saturation and p.ld_h != p.lq_h:
            pass  # saturation is handled by _Model.currents_ab (flux-curve inversion)
        self.p = p
        self.opt = opt
        self.machine = _Model(p, "alphabeta", 1e-6)
        self.nl = bool(p.inverter_nonlinear)
        self.t_dt = p.dead_time_s if self.nl else 0.0
        self.c_node = p.i_cap_band_a * p.dead_time_s / p.v_dc_v if self.nl else 0.0

    # -- the carrier and the command ------------------------------------------------------------
    def carrier(self, t_in: float) -> float:
        ts = self.p.ts_s
        u = (t_in / ts) % 1.0
        if self.opt.carrier_at_start == "peak":
            u = (u + 0.5) % 1.0
        return 2.0 * u if u <= 0.5 else 2.0 - 2.0 * u

    def load_instant(self, t_w: float) -> float:
        ts = self.p.ts_s
        if t_w <= 0.0:
            return 0.0
        if self.opt.pwm_load == "immediate":
            return min(t_w, ts)
        if self.opt.pwm_load == "period":
            return ts
        return 0.5 * ts if t_w <= 0.5 * ts else ts

    @staticmethod
    def _cmd(c: float, d: float) -> int:
        return int(c > 1.0 - d)

    def command_changes(self, d_old: np.ndarray, d_new: np.ndarray, t_l: float,
                        levels: list[int]) -> list[list[tuple[float, int]]]:
        """Per leg, the (t, level) changes in [0, Ts) (t from the period start)."""
        ts = self.p.ts_s
        cuts = sorted({0.0, 0.5 * ts, ts, *([t_l] if 0.0 < t_l < ts else [])})
        out: list[list[tuple[float, int]]] = [[], [], []]
        for x in range(3):
            cur = levels[x]
            for a, b in zip(cuts[:-1], cuts[1:]):
                d = float(d_old[x] if a < t_l else d_new[x])
                eps = 1e-9 * (b - a)
                # the level just after a: the sign of carrier - (1 - d) right of a
                if d >= 1.0:
                    lv = 1
                elif d <= 0.0:
                    lv = 0
                else:
                    lv = self._cmd(self.carrier(a + eps), d)
                if lv != cur:
                    out[x].append((a, lv))
                    cur = lv
                if 0.0 < d < 1.0:
                    f = lambda t, d=d: self.carrier(t) - (1.0 - d)  # noqa: E731
                    fa, fb = f(a + eps), f(b - eps)
                    if fa * fb < 0.0:
                        tc = brentq(f, a + eps, b - eps, xtol=1e-20, rtol=1e-15, maxiter=200)
                        cur = 1 - cur
                        out[x].append((tc, cur))
        return out

    # -- the leg's node ------------------------------------------------------------------------
    def drops(self, i: float) -> tuple[float, float]:
        p = self.p
        q = math.tanh(abs(i) / p.i_cap_band_a) if p.i_cap_band_a > 0.0 else float(i != 0.0)
        return (p.v_switch_drop_v * q + p.r_switch_ohm * abs(i),
                p.v_diode_drop_v * q + p.r_diode_ohm * abs(i))

    def conducting_level(self, upper: bool, i: float) -> float:
        vdc = self.p.v_dc_v
        if not self.nl:
            return vdc if upper else 0.0
        vs, vd = self.drops(i)
        if upper:
            return vdc - vs if i > 0.0 else (vdc + vd if i < 0.0 else vdc)
        return -vd if i > 0.0 else (vs if i < 0.0 else 0.0)

    def dead_law(self, t0: float, was_upper: bool, i_e: float) -> tuple[float, float, float, float, float]:
        """Node law of a dead interval starting at t0 (absolute) after the upper (or lower)
        gate conducted, current i_e: (t0, v0, rate, t_clamp, v_clamp)."""
        vdc = self.p.v_dc_v
        vs, vd = self.drops(i_e)
        top, bottom = vdc + vd, -vd
        if was_upper and i_e > 0.0:        # the upper switch carried it: discharge to the bottom
            v0, target = vdc - vs, bottom
        elif not was_upper and i_e < 0.0:  # the lower switch carried it: charge to the top
            v0, target = vs, top
        else:                              # a diode carried it (or nothing): it keeps the node
            v0 = top if was_upper else bottom
            return (t0, v0, 0.0, t0, v0)
        if self.c_node <= 0.0:
            return (t0, target, 0.0, t0, target)
        rate = -i_e / self.c_node
        return (t0, v0, rate, t0 + (target - v0) / rate, target)

    @staticmethod
    def node_voltage(law, t: float) -> float:
        t0, v0, rate, t_clamp, v_clamp = law
        return v_clamp if t >= t_clamp else v0 + rate * (t - t0)

    # -- integration ---------------------------------------------------------------------------
    def rhs(self, t: float, x: np.ndarray, legs: list[_Leg], t_abs0: float) -> np.ndarray:
        p = self.p
        m = self.machine
        i_ab = m.currents_ab(x[:4])
        i_abc = INV_CLARKE @ i_ab
        v_pole = np.empty(3)
        for k, leg in enumerate(legs):
            if leg.dead_law is not None:
                v_pole[k] = self.node_voltage(leg.dead_law, t_abs0 + t)
            else:
                v_pole[k] = self.conducting_level(bool(leg.level), float(i_abc[k]))
        v_ph = v_pole - v_pole.mean()
        v_ab = CLARKE @ v_ph
        d_psi = v_ab - p.rs_ohm * i_ab
        te = 1.5 * p.pole_pairs * (x[0] * i_ab[1] - x[1] * i_ab[0])
        wm = x[2]
        dw = (te - p.b_nms * wm - m.load_nm) / p.j_kgm2
        return np.array([d_psi[0], d_psi[1], dw, p.pole_pairs * wm, v_ph[0], v_ph[1], v_ph[2]])


def simulate(params: Any, duties: np.ndarray, *, theta_e0: float = 0.0, omega_m0: float = 0.0,
             load_torque_nm: float = 0.0, options: Any = None, rtol: float = 1e-10,
             t_write_s: float | None = None) -> SwitchingResult:
    """Integrate len(duties) periods from zero current at (theta_e0, omega_m0).

    params: plant constants (RefParams fields; a MotorProfile or Plant.params); options: the
    switching settings (SwitchingOptions, a mapping or Plant.params; default valley / extremum /
    delay); t_write_s: the write instant (default t_delay_s, or Ts with full_period_delay).
    """
    p = RefParams.of(params)
    opt = options if isinstance(options, SwitchingOptions) else SwitchingOptions.of(options or {})
    ref = SwitchingReference(p, opt)
    m = ref.machine
    m.load_nm = float(load_torque_nm)
    duties = np.asarray(duties, dtype=float)
    if duties.ndim != 2 or duties.shape[1] != 3 or not np.all(duties >= 0.0):
        raise ValueError("duties must have shape (n, 3), every leg enabled")
    duties = np.minimum(duties, 1.0)
    n = duties.shape[0]
    ts = p.ts_s
    t_w = p.t_act_s if t_write_s is None else float(t_write_s)
    t_l = ref.load_instant(t_w)
    t_smp = 0.5 * ts if opt.dual_sample_at == "half_period" else t_w
    atol = np.array([1e-13, 1e-13, 1e-10, 1e-12, 1e-12, 1e-12, 1e-12])

    # steady command levels at the end of a period at d = 0.5
    prev = np.full(3, 0.5)
    first = ref.command_changes(prev, prev, 0.0, [0, 0, 0])
    end_levels = [lvl[-1][1] if lvl else 0 for lvl in first]
    legs = [_Leg(end_levels[k]) for k in range(3)]

    x = np.concatenate([m.initial_state(theta_e0 % (2.0 * math.pi), omega_m0), np.zeros(3)])
    out = np.empty((n + 1, 4))
    i2 = np.empty((n, 3))
    v_avg = np.empty((n, 3))
    out[0] = x[:4]
    all_edges: list = []

    def currents(state: np.ndarray) -> np.ndarray:
        return INV_CLARKE @ m.currents_ab(state[:4])

    for k in range(n):
        t_k = k * ts
        changes = ref.command_changes(prev, duties[k], t_l, [lg.level for lg in legs])
        pending = sorted((t_k + t, leg, lvl) for leg in range(3) for t, lvl in changes[leg])
        x[4:] = 0.0
        t = t_k
        t_end = t_k + ts
        sampled = False
        while True:
            # the legs' state at t: dead intervals that ended, command changes due now
            for leg in legs:
                if leg.dead_law is not None and leg.changes and t >= leg.changes[-1] + ref.t_dt:
                    leg.dead_law = None
            while pending and pending[0][0] <= t:
                tc, kk, lvl = pending.pop(0)
                leg = legs[kk]
                i_e = float(currents(x)[kk])
                all_edges.append((kk, tc - t_k, lvl, i_e, k))
                if ref.t_dt > 0.0 and leg.dead_law is None:
                    was_upper = bool(leg.level)
                    leg.dead_law = ref.dead_law(tc, was_upper, i_e)
                leg.level = lvl
                leg.changes = [c for c in leg.changes if c > tc - ref.t_dt] + [tc]
            if not sampled and t >= t_k + t_smp:
                i2[k] = currents(x)
                sampled = True
            if t >= t_end:
                break
            nxt = [t_end]
            if pending:
                nxt.append(pending[0][0])
            if not sampled:
                nxt.append(t_k + t_smp)
            for leg in legs:
                if leg.dead_law is not None:
                    nxt.append(leg.changes[-1] + ref.t_dt)
                    if leg.dead_law[3] > t:
                        nxt.append(leg.dead_law[3])
            t_next = min(v for v in nxt if v > t) if any(v > t for v in nxt) else t_end
            x0 = x.copy()
            x0[3] %= 2.0 * math.pi
            sol = solve_ivp(ref.rhs, (0.0, t_next - t), x0, method="DOP853", rtol=rtol,
                            atol=atol, args=(legs, t))
            if not sol.success:
                raise RuntimeError(f"switching reference: solve_ivp failed in period {k}: {sol.message}")
            x = sol.y[:, -1]
            t = t_next
        v_avg[k] = x[4:] / ts
        prev = duties[k]
        out[k + 1] = x[:4]

    i_ab = np.array([m.currents_ab(row) for row in out])
    return SwitchingResult(
        t_s=np.arange(n + 1) * ts, i_abc_a=i_ab @ INV_CLARKE.T, omega_m_rad_s=out[:, 2],
        theta_e_rad=np.mod(out[:, 3], 2.0 * math.pi), t2_s=np.arange(n) * ts + t_smp,
        i2_abc_a=i2, v_abc_avg_v=v_avg, edge_currents=all_edges)
