"""The reference drive's angle path (firmware_stub/src/controller.c, CONFIG LOOP_ANGLE) and its
hand-over from I-f, in one process: the C plant and the control ISR close the loop without a link.

* LOOP_ANGLE = 1: the loop turns its frames with the angle of the PLL that tracks the SMO's EMF
  angle. Checked against an independent float64 type-2 PLL (est_common.h: the error folded modulo
  pi, kp = 2 w_n, ki = w_n^2, w_n = 150 rad/s) fed the observer's own angle sample by sample:
  the C loop angle (TELEMETRY's theta_hat) is that PLL's angle within 1e-4 rad (float32 against
  float64 over 2000 steps of a stable loop). And it is the quieter angle: its step-to-step
  jitter (the second difference, the rotation itself removed) is below a third of the observer
  angle's, on the same run with the 12-bit ADC and its noise on.
* LOOP_ANGLE = 0 (the default): the loop angle is the observer's angle itself.
* The hand-over seeds the speed loop with the I-f current low-passed in the open-loop frame
  (CTRL_HANDOVER_I_LPF_RAD_S), turned into the loop's frame: the q-current reference of the
  hand-over step is a float64 replica of that filter (fed the same samples in the open-loop
  frame) turned by the angle difference, within 1e-3 A (float32), and within 0.15 A of the
  20 ms mean of the q current that flowed (a single sample was 0.07-0.1 A off it here).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import load_profile
from hil_bench.protocol.messages import Param

fw = pytest.importorskip("hil_bench.firmware_stub._fw_c")
from tests.inproc_loop import InProcessLoop  # noqa: E402  (after the skip: it imports the cffi module)

SMO_SIGN = 1.0
STATE_OPEN_LOOP, STATE_CLOSED_LOOP = 2, 3
PLL_WN_RAD_S = 150.0          # est_pll_gains(150, ...): the controller's default PLL


def _wrap_pi(x: float) -> float:
    return (x + math.pi) % (2.0 * math.pi) - math.pi


class SmoLoop(InProcessLoop):
    """Gong's motor, the sign SMO, align -> I-f (6 A) -> hand-over at 20 rad/s -> 30 rad/s, an
    active 0.6 N m, dead time and the ADC on. speed_kp > 0: the speed loop's kp (its ki follows:
    kp w / 4); a negligible one makes the q-current reference of the hand-over step its seed."""

    def __init__(self, loop_angle: int, adc_seed: int = 3, load_nm: float = 0.6, speed_kp: float = 0.0):
        prof = load_profile("gong2020")
        plant = Plant(prof, inverter_nonlinear=True, adc_model=1, adc_seed=adc_seed)
        plant.set_load_torque(load_nm)
        params = {Param.LOOP_ANGLE: loop_angle, Param.IF_I_A: 6.0}
        if speed_kp > 0.0:
            params[Param.SPD_KP_A_RAD_S] = speed_kp
        super().__init__(prof, plant, estimator=SMO_SIGN, iq_max_a=9.0, speed_ref_rad_s=30.0,
                         params=params)


def test_the_loop_angle_is_a_type2_pll_of_the_observer_angle():
    loop = SmoLoop(loop_angle=1)
    while loop.k * loop.prof.ts_s < 1.2:
        out = loop.step()
    assert out.state == STATE_CLOSED_LOOP and out.fault == 0
    kp, ki, ts = 2.0 * PLL_WN_RAD_S, PLL_WN_RAD_S ** 2, loop.prof.ts_s
    th, om = float(out.theta_hat_rad), float(out.omega_hat_rad_s)   # the C PLL's state now
    worst = 0.0
    obs, used = [], []
    for _ in range(2000):
        out = loop.step()
        err = _wrap_pi(float(loop.c.est.theta_e_rad) - th)
        if abs(err) > math.pi / 2:                      # folded modulo pi (est_emf_angle_step)
            err = _wrap_pi(err + math.pi)
        om += ki * ts * err
        th = (th + (om + kp * err) * ts) % (2.0 * math.pi)
        worst = max(worst, abs(_wrap_pi(float(out.theta_hat_rad) - th)))
        obs.append(float(loop.c.est.theta_e_rad))
        used.append(float(out.theta_hat_rad))
    assert out.state == STATE_CLOSED_LOOP
    assert worst < 1e-4, f"C loop angle vs the float64 PLL: {worst:.2e} rad"
    jit = lambda a: np.std(np.diff(np.unwrap(np.asarray(a)), 2))   # noqa: E731
    assert jit(used) < jit(obs) / 3.0, (jit(used), jit(obs))


def test_the_default_loop_angle_is_the_observer_angle():
    loop = SmoLoop(loop_angle=0)
    while loop.k * loop.prof.ts_s < 1.0:
        out = loop.step()
    assert out.state == STATE_CLOSED_LOOP
    for _ in range(200):
        out = loop.step()
        assert out.theta_hat_rad == loop.c.est.theta_e_rad


@pytest.mark.parametrize("loop_angle", [0, 1])
def test_the_hand_over_seeds_the_speed_loop_with_the_filtered_if_current(loop_angle):
    # a speed loop of negligible gain: the reference of the hand-over step is the seed itself
    loop = SmoLoop(loop_angle=loop_angle, speed_kp=1e-6)
    ts = loop.prof.ts_s
    a = 1.0 - math.exp(-50.0 * ts)             # CTRL_HANDOVER_I_LPF_RAD_S
    f = np.zeros(2)
    i_ol = []                                   # the sampled current in the open-loop frame
    out = loop.step()
    while True:
        assert loop.k * ts < 1.0, "no hand-over within 1 s"
        th_ol = float(loop.c.theta_ol_rad)      # the frame the next sample is taken in
        m = loop.plant.sample()
        i_al = (2.0 * m.i_a_a - m.i_b_a - m.i_c_a) / 3.0
        i_be = (m.i_b_a - m.i_c_a) / math.sqrt(3.0)
        v = np.array([i_al * math.cos(th_ol) + i_be * math.sin(th_ol),
                      -i_al * math.sin(th_ol) + i_be * math.cos(th_ol)])
        f += a * (v - f)
        i_ol.append(v)
        out = loop.step()
        if out.state == STATE_CLOSED_LOOP:
            break
    # the seed: the filtered vector turned from the open-loop frame into the loop's
    d = _wrap_pi(float(out.theta_hat_rad) - float(loop.c.theta_ol_rad))
    seed_q = -f[0] * math.sin(d) + f[1] * math.cos(d)
    assert abs(out.i_q_ref_a - seed_q) < 1e-3, (out.i_q_ref_a, seed_q)
    # and that is the q current that flowed: the 20 ms mean of the samples, in the same frame
    n = int(0.02 / ts)
    mean = np.mean(i_ol[-n:], axis=0)
    mean_q = -mean[0] * math.sin(d) + mean[1] * math.cos(d)
    raw_q = -i_ol[-1][0] * math.sin(d) + i_ol[-1][1] * math.cos(d)
    assert abs(out.i_q_ref_a - mean_q) < 0.15, (out.i_q_ref_a, mean_q, raw_q)
