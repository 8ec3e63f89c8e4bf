"""The plant's switching inverter mode (plant_rt/README.md "Switching mode").

* the C plant against the independent switch-level reference (plant_rt/verify/switching_ref.py:
  solve_ivp restarted at every switching instant, command instants by root finding, gates from
  the dead-band definition): ideal inverter, dead time + drops with the current crossing zero
  inside periods, large currents, the three load modes, both carrier phases, both second-sample
  instants, the IPMSM;
* each effect alone, with a test that fails without it: the ripple at a sampling instant (closed
  form, R = 0 locked rotor), the dead interval by the current's sign at each edge, the load
  instant of each pwm_load mode, the second-sample instants;
* the averaged path is untouched by the new keys; bad values name their key.

Tolerances (C vs reference, max |current difference|):
* ideal inverter: 1e-6 A (1e-7 of the gong2020 rated 9.8 A). Inside a segment the inputs are
  constant and RK4 keeps its order; measured 7e-10 A over 100 periods (the reference's own
  rtol 1e-10 is below that).
* with dead time and drops: 1e-4 A (1e-5 of rated, the bound the averaged plant's reference
  tests use for its inverter non-linearity). The drops' thresholds switch on over the band
  tanh(|i| / i_c) and the slope resistances act on |i|, so the right-hand side bends inside the
  band and has a kink at i = 0, where RK4 loses its order; the plant shortens its steps while a
  conducting leg's current is near the band (plant.c sw_step_length), and the measured
  difference is 4.3e-6 A at no load (the current always in the band) and 5e-7 .. 1.7e-5 A at 2-10 A.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hil_bench.plant_rt.plant import Plant, ffi, lib
from hil_bench.plant_rt.profile import ProfileError, load_profile
from hil_bench.plant_rt.verify import openloop, switching_ref

GONG = load_profile("gong2020")
HOU = load_profile("hou2021")
TS = GONG.ts_s
VDC = GONG.v_dc_v
W500 = 500.0 / 60.0 * 2.0 * math.pi       # mechanical rad/s
TOL_IDEAL_A = 1e-6
TOL_NL_A = 1e-4


def _sync_duties(prof, n, rpm, i_q_a, theta0=0.3, v_extra_q=0.0):
    we = prof.pole_pairs * rpm / 60.0 * 2.0 * math.pi
    vd, vq = openloop.operating_point_voltage(prof, we, 0.0, i_q_a)
    return openloop.synchronous(prof, n, theta_e0_rad=theta0, omega_e_rad_s=we, v_d_v=vd,
                                v_q_v=vq + v_extra_q)


def _run_c(plant, duties, theta0, wm0):
    plant.set_initial(theta0, wm0)
    i, i2, t2, w, v = [], [], [], [], []
    for d in duties:
        plant.step(*d)
        s, m = plant.snapshot(), plant.sample()
        i.append((s.i_a_a, s.i_b_a, s.i_c_a))
        i2.append((m.i2_a_a, m.i2_b_a, m.i2_c_a))
        t2.append(m.t2_s)
        w.append(s.omega_m_rad_s)
        v.append((s.v_a_v, s.v_b_v, s.v_c_v))
    return {k: np.array(x) for k, x in (("i", i), ("i2", i2), ("t2", t2), ("w", w), ("v", v))}


def _compare(prof, duties, theta0=0.3, wm0=W500, **ov):
    plant = Plant(prof, inverter="switching", dual_sampling=True, **ov)
    got = _run_c(plant, duties, theta0, wm0)
    ref = switching_ref.simulate(plant.params, duties, theta_e0=theta0, omega_m0=wm0,
                                 options=plant.params)
    assert plant.sw_periods == len(duties)
    err = {
        "i": float(np.max(np.abs(got["i"] - ref.i_abc_a[1:]))),
        "i2": float(np.max(np.abs(got["i2"] - ref.i2_abc_a))),
        "w": float(np.max(np.abs(got["w"] - ref.omega_m_rad_s[1:]))),
        "v": float(np.max(np.abs(got["v"] - ref.v_abc_avg_v))),
    }
    # the second sample's instant, as plant_sample reports it (t_{k-1} + offset)
    np.testing.assert_allclose(got["t2"], ref.t2_s, rtol=0, atol=1e-15)
    return err, got, ref


# ------------------------------------------------------------------------------------------------
# against the independent reference

@pytest.mark.parametrize("carrier,load,sample", [
    ("valley", "extremum", "delay"),
    ("peak", "period", "half_period"),
    ("valley", "immediate", "half_period"),
])
def test_ideal_inverter_matches_the_reference(carrier, load, sample):
    duties = _sync_duties(GONG, 60, 500.0, 4.0)
    err, got, _ = _compare(GONG, duties, carrier_at_start=carrier, pwm_load=load,
                           dual_sample_at=sample)
    assert np.max(np.abs(got["i"])) > 1.0  # a real operating point, not zero current
    assert err["i"] < TOL_IDEAL_A and err["i2"] < TOL_IDEAL_A, err
    assert err["w"] < 1e-8 and err["v"] < 1e-8, err


def test_ipmsm_matches_the_reference():
    duties = _sync_duties(HOU, 50, 300.0, 2.0)
    err, got, _ = _compare(HOU, duties, wm0=300.0 / 60.0 * 2.0 * math.pi)
    assert np.max(np.abs(got["i"])) > 0.5
    assert err["i"] < TOL_IDEAL_A and err["i2"] < TOL_IDEAL_A, err


def test_dead_time_and_drops_with_sign_changes_inside_periods_match_the_reference():
    """No load at 500 rpm: 0.1-0.3 A of fundamental and 0.3-0.4 A peak to peak of ripple, so a
    phase's current often has opposite signs at the two edges of its pulse (checked on the
    reference's record of the edges): each edge's dead interval goes its own way."""
    duties = _sync_duties(GONG, 30, 500.0, 2.0)
    err, got, ref = _compare(GONG, duties, inverter_nonlinear=True)
    assert err["i"] < TOL_NL_A and err["i2"] < TOL_NL_A, err
    assert err["v"] < 1e-3, err      # the period's average voltages (measured 4e-5 V)
    # the edges of one pulse with opposite current signs, in how many periods
    by_period: dict[tuple[int, int], list[float]] = {}
    for leg, t_rel, _level, i_e, k in ref.edge_currents:
        by_period.setdefault((k, leg), []).append(i_e)
    mixed = sum(1 for v in by_period.values() if min(v) < 0.0 < max(v))
    assert mixed >= 10, mixed


def test_dead_time_and_drops_at_large_current_match_the_reference():
    """Locked rotor (no back EMF), 6-8 A: far outside the capacitance band."""
    n = 30
    th = 0.4
    v = 20.0
    duties = openloop.duties_from_alphabeta(np.full(n, v * math.cos(th)), np.full(n, v * math.sin(th)), VDC)
    err, got, _ = _compare(GONG, duties, theta0=0.0, wm0=0.0, inverter_nonlinear=True,
                           pwm_load="immediate")
    assert np.max(np.abs(got["i"])) > 3.0
    assert err["i"] < TOL_NL_A and err["i2"] < TOL_NL_A, err


# ------------------------------------------------------------------------------------------------
# each effect, against a closed form

def _locked_r0(**ov):
    """gong2020 with R = 0 and the rotor held (dyno at 0): L di/dt = v exactly."""
    return Plant(GONG, rs_ohm=0.0, dyno=True, dyno_speed_rad_s=0.0, inverter="switching",
                 dual_sampling=True, t_delay_s=34.1e-6, pwm_load="immediate", **ov)


def test_ripple_at_the_sampling_instant():
    """Duties (0.9, 0.5, 0.1) held for a period, the second sample at t_d = 34.1 us: phase a's
    pole is high from (1 - 0.9) Ts/2 = 5 us, b's from 25 us, c's from 45 us, so
    i_a(t_k + t_d) = i_a(t_k) + (1/L) int_0^t_d v_a dt with v_a = v_aN - mean(v_N), exactly
    (R = 0, rotor held); the averaged plant's current is the straight line
    (d_a - mean d) V_dc t_d / L instead. At t_k + Ts both give (d_a - mean d) V_dc Ts / L (the
    zero vector at the valley: the period-start sample sees no ripple)."""
    d = (0.9, 0.5, 0.1)
    lq = GONG.lq_h
    td = 34.1e-6
    p = _locked_r0()
    p.step(*d)                      # the duties act from 34.1 us in this first period
    i1 = p.snapshot().i_a_a
    p.step(*d)                      # ... and over the whole of this one
    m = p.sample()                  # the second sample of the period just run
    rise = [(1.0 - x) * TS / 2.0 for x in d]
    area_pole = np.array([VDC * max(0.0, td - r) for r in rise])
    want_i2 = i1 + (area_pole[0] - area_pole.mean()) / lq
    assert m.t2_s == pytest.approx(TS + td, abs=1e-18)
    assert m.i2_a_a == pytest.approx(want_i2, abs=1e-9)
    straight = i1 + (d[0] - np.mean(d)) * VDC * td / lq
    assert abs(want_i2 - straight) > 0.4   # the ripple: 0.42 A here
    assert p.snapshot().i_a_a == pytest.approx(i1 + (d[0] - np.mean(d)) * VDC * TS / lq, abs=1e-9)
    # the averaged plant: the straight line at t_d
    q = Plant(GONG, rs_ohm=0.0, dyno=True, dyno_speed_rad_s=0.0, dual_sampling=True, t_delay_s=td)
    q.step(*d)
    j1 = q.snapshot().i_a_a
    q.step(*d)
    assert q.sample().i2_a_a == pytest.approx(j1 + (d[0] - np.mean(d)) * VDC * td / lq, abs=1e-9)


def test_second_sample_at_the_half_period_and_the_peak_start():
    """dual_sample_at = half_period: i2 at t_k + Ts/2, the centre of the 111 vector with the
    valley at t_k (every pole high from (1 - d) Ts/2 to Ts/2). carrier_at_start = peak: t_k
    is the centre of 111 and t_k + Ts/2 of 000 (every pole high from t_k to d Ts/2): the same
    volt-seconds by then."""
    d = (0.8, 0.6, 0.3)
    lq = GONG.lq_h
    area = np.array([VDC * x * TS / 2.0 for x in d])
    for carrier in ("valley", "peak"):
        p = _locked_r0(dual_sample_at="half_period", carrier_at_start=carrier)
        p.step(*d)
        i1 = p.snapshot().i_a_a
        p.step(*d)
        m = p.sample()
        assert m.t2_s == pytest.approx(TS + 0.5 * TS, abs=1e-18)
        assert m.i2_a_a == pytest.approx(i1 + (area[0] - area.mean()) / lq, abs=1e-9), carrier


def _leg(i_c=0.0, t_dt=2e-6):
    inv = ffi.new("inverter_t *")
    assert lib.inverter_init(inv, ffi.new("inverter_config_t *", {"v_dc_v": VDC})) == 0
    nl = {"dead_time_s": t_dt, "ts_s": TS, "v_switch_drop_v": 0.0, "r_switch_ohm": 0.0,
          "v_diode_drop_v": 0.0, "r_diode_ohm": 0.0, "i_cap_band_a": i_c}
    assert lib.inverter_set_nonlinear(inv, ffi.new("inverter_nl_config_t *", nl)) == 0
    return inv


def _pulse_area(inv, i_rise, i_fall, t_r=30e-6, t_f=70e-6):
    """Volt-seconds of one leg over a period with a command pulse [t_r, t_f), the current at
    the rising edge i_rise and at the falling edge i_fall (no capacitance: levels only)."""
    leg = ffi.new("inverter_sw_leg_t *")
    lib.inverter_sw_leg_reset(leg, 0)
    area, t = 0.0, 0.0
    events = [(t_r, 1, i_rise), (t_f, 0, i_fall)]
    while t < TS:
        nxt = min([e[0] for e in events if e[0] > t] + [lib.inverter_sw_next_change(leg, t), TS])
        area += lib.inverter_sw_pole_voltage(inv, leg, t, 0.0, ffi.NULL) * (nxt - t)
        t = nxt
        lib.inverter_sw_advance(leg, t)
        for te, lvl, ie in events:
            if te == t:
                lib.inverter_sw_command(inv, leg, t, lvl, ie)
    return area


def test_dead_interval_follows_the_current_sign_at_each_edge():
    """Same sign at both edges: the pulse loses (i > 0) or gains (i < 0) one dead time;
    opposite signs: the rising edge (i > 0) loses it and the falling edge (i < 0) gains it
    back, so the pulse keeps its width (an averaged model, with one current per period, has
    no such case)."""
    inv = _leg()
    width = 40e-6
    t_dt = 2e-6
    assert _pulse_area(inv, 3.0, 3.0) == pytest.approx(VDC * (width - t_dt), rel=1e-12)
    assert _pulse_area(inv, -3.0, -3.0) == pytest.approx(VDC * (width + t_dt), rel=1e-12)
    assert _pulse_area(inv, 3.0, -3.0) == pytest.approx(VDC * width, rel=1e-12)
    assert _pulse_area(inv, -3.0, 3.0) == pytest.approx(VDC * width, rel=1e-12)
    # and the ideal leg has no dead interval at all
    ideal = ffi.new("inverter_t *")
    lib.inverter_init(ideal, ffi.new("inverter_config_t *", {"v_dc_v": VDC}))
    assert _pulse_area(ideal, 3.0, 3.0) == pytest.approx(VDC * width, rel=1e-12)


@pytest.mark.parametrize("load,expect_high_fraction", [
    ("extremum", 0.5 * (0.3 + 0.7)),   # rises on the old compare, falls on the new one
    ("period", 0.3),                   # the whole period on the old compare
    ("immediate", None),               # computed below: the new compare acts from t_w
])
def test_each_load_mode_acts_from_its_instant(load, expect_high_fraction):
    """A duty step 0.3 -> 0.7 on phase a written at t_w = 34.1 us; b and c at 0.5. The period's
    average phase voltage (snapshot v_a) = (2/3) (f_a - 0.5) V_dc, f_a the high fraction."""
    p = Plant(GONG, inverter="switching", t_delay_s=34.1e-6, pwm_load=load, dyno=True,
              dyno_speed_rad_s=0.0)
    p.step(0.3, 0.5, 0.5)
    p.step(0.3, 0.5, 0.5)
    p.step(0.7, 0.5, 0.5)
    if expect_high_fraction is None:
        # old rise at 35 us is after the write: the new compare (rise at 15 us, already past)
        # switches the leg on at 34.1 us; it falls on the new compare at 85 us
        expect_high_fraction = (0.85 - 0.341)
    assert p.snapshot().v_a_v == pytest.approx(2.0 / 3.0 * (expect_high_fraction - 0.5) * VDC, abs=1e-9)
    assert p.actuation_delay_s == pytest.approx({"extremum": 0.5 * TS, "period": TS,
                                                 "immediate": 34.1e-6}[load], abs=1e-18)


def test_trace_records_the_ripple_and_does_not_change_the_step():
    duties = _sync_duties(GONG, 20, 500.0, 2.0)
    a = Plant(GONG, inverter="switching")
    b = Plant(GONG, inverter="switching")
    for p in (a, b):
        p.set_initial(0.3, W500)
    for d in duties:
        a.step(*d)
        tr = b.step_trace(*d, n=100)
    assert tr is not None
    s_a, s_b = a.snapshot(), b.snapshot()
    assert s_b.i_a_a == pytest.approx(s_a.i_a_a, abs=1e-9)
    assert tr["i_alpha_a"][-1] == pytest.approx(s_b.i_alpha_a, abs=1e-12)
    # the ripple: the current moves by volts x microseconds / L between the trace instants
    assert np.ptp(tr["i_alpha_a"]) > 0.2
    # the trace's voltage averages add up to the period's average
    assert np.mean(tr["v_alpha_v"]) == pytest.approx(s_b.v_alpha_v, abs=1e-9)
    assert Plant(GONG).step_trace(0.5, 0.5, 0.5, n=10) is None   # averaged mode: no trace


# ------------------------------------------------------------------------------------------------
# the averaged path and the switching path beside each other

def test_switching_values_do_not_touch_the_averaged_plant():
    duties = _sync_duties(GONG, 300, 500.0, 2.0)
    a = Plant(GONG, inverter_nonlinear=True)
    b = Plant(GONG, inverter_nonlinear=True, carrier_at_start="peak", pwm_load="immediate")
    for p in (a, b):
        p.set_initial(0.3, W500)
    ra, rb = a.run(duties), b.run(duties)
    assert np.array_equal(ra, rb)
    assert a.sw_periods == 0 and b.sw_periods == 0
    assert a.actuation_delay_s == GONG.t_delay_s


def test_the_fundamental_agrees_with_the_averaged_plant_outside_the_band():
    """Locked rotor at 2-5.4 A per phase with dead time and drops: the period-average voltage of the switching
    plant equals the averaged plant's to the drops-during-slew bound (v_s + v_d) t_dt / Ts =
    0.03 V per leg, so the DC current agrees to well under 1 %."""
    n = 400
    th = 1.0
    duties = openloop.duties_from_alphabeta(np.full(n, 12.0 * math.cos(th)), np.full(n, 12.0 * math.sin(th)), VDC)
    out = {}
    for inv in ("averaged", "switching"):
        p = Plant(GONG, inverter=inv, inverter_nonlinear=True, dyno=True, dyno_speed_rad_s=0.0)
        out[inv] = p.run(duties)
    for ph in ("i_a_a", "i_b_a", "i_c_a"):
        i_avg, i_sw = out["averaged"][ph][-1], out["switching"][ph][-1]
        assert abs(i_avg) > 2.0, ph        # every phase far outside the 0.155 A band
        assert i_sw == pytest.approx(i_avg, rel=5e-3), ph   # measured <= 3e-4 relative
    for v in ("v_alpha_v", "v_beta_v"):
        assert out["switching"][v][-1] == pytest.approx(out["averaged"][v][-1], abs=0.06), v


def test_a_disabled_leg_takes_the_averaged_path_for_that_period():
    p = Plant(GONG, inverter="switching", inverter_nonlinear=True)
    p.set_initial(0.0, W500)
    for _ in range(5):
        p.step(0.6, 0.4, 0.5)
    assert p.sw_periods == 5
    p.step(-1.0, 0.4, 0.5)          # leg a off
    p.step(0.6, 0.4, 0.5)           # its previous duties had the leg off
    assert p.sw_periods == 5
    p.step(0.6, 0.4, 0.5)
    assert p.sw_periods == 6
    p.set_fault("open_phase", phase="b")
    p.step(0.6, 0.4, 0.5)
    assert p.sw_periods == 6
    p.clear_faults()
    p.step(0.6, 0.4, 0.5)
    assert p.sw_periods == 7 and math.isfinite(p.snapshot().i_a_a)


# ------------------------------------------------------------------------------------------------
# bad input

def test_bad_values_name_the_key():
    with pytest.raises(ProfileError, match=r"inverter\.inverter: must be one of averaged, switching"):
        Plant(GONG, inverter="pwm")
    with pytest.raises(ProfileError, match=r"inverter\.pwm_load: must be one of extremum, period, immediate"):
        Plant(GONG, pwm_load="zero")
    with pytest.raises(ProfileError, match=r"inverter\.carrier_at_start: must be one of valley, peak"):
        Plant(GONG, carrier_at_start=3)
    with pytest.raises(ProfileError, match=r"sensors\.dual_sample_at: half_period needs inverter = switching"):
        Plant(GONG, dual_sample_at="half_period")
    with pytest.raises(ValueError, match="n: must be >= 1"):
        Plant(GONG, inverter="switching").step_trace(0.5, 0.5, 0.5, n=0)
    # names and their codes (a bench [plant] table may carry either)
    p = Plant(GONG, inverter=1.0, pwm_load=2, carrier_at_start="peak")
    assert (p.params.inverter, p.params.pwm_load, p.params.carrier_at_start) == ("switching", "immediate", "peak")


# ------------------------------------------------------------------------------------------------
# in the closed loop: `bench run --set plant.inverter=switching`

def test_bench_run_set_switches_the_plant(tmp_path):
    import json
    import subprocess
    import sys
    from pathlib import Path

    from hil_bench.record.recording import read_header

    repo = Path(__file__).resolve().parents[1]
    out = tmp_path / "g2sw.mcap"
    cmd = [sys.executable, "-m", "hil_bench", "run", "gong_g2_500rpm", "--out", str(out),
           "--no-progress", "--set", "plant.inverter=switching", "--set", "scenario.duration_s=0.3",
           "--set", "metrics.window_s=[0.2, 0.3]"]
    proc = subprocess.run(cmd, cwd=repo, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    rec = read_header(out)
    params = json.loads(rec.metadata["run"]["plant_params"])
    assert params["inverter"] == "switching"
    assert json.loads(rec.metadata["run"]["controller_params"])["CTRL_DELAY_S"] == 0.0  # t_d = 0
    _, text = rec.attachment_text("scenario/")
    assert 'inverter = "switching"' in text and "bench run --set" in text
    assert rec.metadata["run_result"]["cycles_done"] == "3000"
    bad = subprocess.run(cmd[:-6] + ["--set", "plant.inverter=pwm"], cwd=repo, capture_output=True,
                         text=True, timeout=120)
    assert bad.returncode == 2
    assert "inverter.inverter: must be one of averaged, switching" in " ".join(bad.stderr.split())
