"""Claims measured without a closed-loop run: the papers' own signal-processing experiments.

* ``y5()`` - Yuan IV.A.1, Fig. 11-12: the input sin(500 pi t), amplitude 1 -> 2 at 0.2 s,
  through the C library's SDFT and GSDFT as the paper sets them up: M = 24 and k = 5 (its
  pole-zero example, Fig. 5 and 7). The 250 Hz tone is then the 5th harmonic of a window that
  spans one 50 Hz period, so fs = 24 x 50 Hz = 1200 Hz. Tracking time: from the start (or the
  step) until the extracted amplitude stays within 2 % of its final value. Both are FIRs (M and
  M/3 taps): exactly settled once the window holds only new samples, M - 1 = 23 and 7 samples
  after the first new one, 4.79 and 1.46 cycles; the 2 % criterion gives the same.
* ``y6()`` - Yuan Table 2: the cost of the 5th + 7th extraction per sample, GSDFT against SDFT,
  counted by callgrind (x86-64 instructions of this library's C, bench/perf/estimators.py).
* ``y6_ops()`` - Yuan Y6 on the paper's own recursions (eq. 24-27): operations per sample,
  the verdict's basis; the library's instructions (``y6``) are reported beside.
* ``g1()`` - Gong V-A-a, Fig. 7: the four tanh SMOs of claim G1 (m = 1, 0.25, 0.1, 0.01, k by
  eq. 17 as in gong_g1_boundary_layer) stepped on the host at Ts = 100, 10 and 1 us on an exact
  500 rpm no-load trajectory of the gong2020 motor: does a finer simulation step give the
  paper's THDs (the bench's 10 kHz cannot: the sampled loop needs k m < (1 + F)/G)?
* ``g1_switching()`` - the same four observers stepped at 1 and 10 us on the switching plant's
  500 rpm no-load trajectory (PWM ripple in the currents; the commanded or the switched voltage):
  does the ripple give the paper's THDs and their rise with m?

Each returns a dict: scalar results by key plus arrays for the report's plots.
"""
from __future__ import annotations

import math
import shutil

import numpy as np

Y5_FS_HZ = 1200.0       # 24 samples per 50 Hz period
Y5_M = 24
Y5_BIN = 5              # 250 Hz is the 5th harmonic of 50 Hz
Y5_TONE_HZ = 250.0


def tracking_samples(amp: np.ndarray, start: int, final: float, tol: float) -> int:
    """Samples from ``start`` until |amp - final| <= tol final holds to the end."""
    bad = np.nonzero(np.abs(amp[start:] - final) > tol * final)[0]
    return int(bad[-1] + 1) if bad.size else 0


def y5() -> dict:
    from hil_bench.firmware_stub.est_dft import Gsdft, Sdft

    t = np.arange(int(round(0.5 * Y5_FS_HZ))) / Y5_FS_HZ
    amp_in = np.where(t < 0.2, 1.0, 2.0)
    x = amp_in * np.sin(2 * math.pi * Y5_TONE_HZ * t)
    i_step = int(np.argmax(t >= 0.2))
    per_cycle = Y5_FS_HZ / Y5_TONE_HZ          # 4.8 samples per cycle of the tone
    out: dict = {"t_s": t, "x": x, "amp_in": amp_in}
    for name, est, window in (("SDFT", Sdft(Y5_M, [Y5_BIN]), Y5_M),
                              ("GSDFT", Gsdft(Y5_M, [Y5_BIN]), Y5_M // 3)):
        # window: the FIR is exactly settled (window - 1) samples after the first new sample
        amp = np.abs(est.run(x)[:, 0])
        out[f"{name}.amp"] = amp
        out[f"{name}.start"] = tracking_samples(amp[:i_step], 0, 1.0, 0.02) / per_cycle
        out[f"{name}.step"] = tracking_samples(amp, i_step, 2.0, 0.02) / per_cycle
        out[f"{name}.window"] = (window - 1) / per_cycle
    return out


def y6(n: int = 20000) -> dict:
    """Instructions per sample for the 5th + 7th extraction (M = 24), protected and direct
    forms, real input; savings in % (positive: the GSDFT is cheaper)."""
    if shutil.which("valgrind") is None:
        raise RuntimeError("valgrind not found: the Y6 count needs callgrind "
                           "(apt-get install valgrind)")
    from hil_bench.perf import estimators as perf

    try:
        exe, _notes = perf.build(perf.OPTIONAL)
        per = {}
        for case in ("empty", "sdft_57_real_mod", "gsdft_57_real_mod", "sdft_57_real_direct",
                     "gsdft_57_real_direct"):
            ir = perf.instructions(exe, case, n)
            if ir is None:
                raise RuntimeError(f"callgrind case {case} not in the build")
            per[case] = ir / n
    except SystemExit as exc:         # the benchmark exits on a failed build or run
        raise RuntimeError(f"callgrind benchmark failed: {exc}") from None
    o = per["empty"]
    out = {f"{k}": v - o for k, v in per.items() if k != "empty"}
    out["saving_protected"] = 100.0 * (1.0 - out["gsdft_57_real_mod"] / out["sdft_57_real_mod"])
    out["saving_direct"] = 100.0 * (1.0 - out["gsdft_57_real_direct"] / out["sdft_57_real_direct"])
    out["n"] = n
    return out


#: Yuan's recursions for a real input, per sample, as (multiplications, additions): the comb
#: (shared by the harmonics extracted together) and, per harmonic, the resonator
#: 1/(1 - z^-1 e^{j 2 pi k/M}) (a complex product: 4 mul + 2 add; the real input into its real
#: part: 1 add) and the gain (1/M) e^{j 2 pi k/M} (a complex constant: 4 mul + 2 add).
#: SDFT eq. 24-25: comb 1 - z^-M (1 add); SDFT's time-domain form eq. 22-23 counts the same
#: (two real adds and a rotation, then the output rotation by the twiddle with 1/M folded in).
#: GSDFT eq. 26-27: comb (1 - z^-M/6 e^{j pi/3})(1 - z^-M/6 e^{-j pi/3}) = 1 - z^-M/6 + z^-M/3
#: (y6_ops checks the expansion): 2 adds, no multiplication.
Y6_COMB_OPS = {"SDFT": (0, 1), "GSDFT": (0, 2)}
Y6_PER_HARMONIC_OPS = (4 + 4, 3 + 2)
Y6_HARMONICS = (5, 7)


def y6_comb_taps(m: int = Y5_M) -> np.ndarray:
    """The GSDFT comb of eq. 26-27 multiplied out, coefficients of z^0 .. z^-M/3."""
    d = m // 6
    f1 = np.zeros(d + 1, complex)
    f1[0], f1[d] = 1.0, -np.exp(1j * math.pi / 3)
    f2 = np.zeros(d + 1, complex)
    f2[0], f2[d] = 1.0, -np.exp(-1j * math.pi / 3)
    return np.convolve(f1, f2)


def y6_ops() -> dict:
    """Yuan Y6 judged on the paper's own recursions: operations per sample for the 5th + 7th
    extraction, SDFT against GSDFT (counted from eq. 24-27, ``Y6_COMB_OPS``), every operation
    one (a C28x FPU multiply and add both take one pipelined instruction). The GSDFT's comb has
    real taps (1, -1, 1) - checked here on the product of eq. 26's two factors - so it costs
    one add more than the SDFT's and nothing else differs: no weighting of mul against add
    makes the GSDFT cheaper."""
    taps = y6_comb_taps()
    d = Y5_M // 6
    want = np.zeros(2 * d + 1)
    want[0], want[d], want[2 * d] = 1.0, -1.0, 1.0
    if not np.allclose(taps, want, atol=1e-12):
        raise RuntimeError(f"GSDFT comb does not expand to 1 - z^-M/6 + z^-M/3: {taps}")
    out: dict = {}
    for name, (cm, ca) in Y6_COMB_OPS.items():
        mul = cm + len(Y6_HARMONICS) * Y6_PER_HARMONIC_OPS[0]
        add = ca + len(Y6_HARMONICS) * Y6_PER_HARMONIC_OPS[1]
        out[f"{name.lower()}_mul"], out[f"{name.lower()}_add"] = mul, add
        out[f"{name.lower()}_ops"] = mul + add
    out["saving_ops"] = 100.0 * (1.0 - out["gsdft_ops"] / out["sdft_ops"])
    return out


#: G1: the gains of gong_g1_boundary_layer's references (eq. 17, xi = 23.98 A)
G1_K_V = {1.0: 463.2089, 0.25: 463.2147, 0.1: 470.9220, 0.01: 1968.2533}
G1_RPM = 500.0
G1_IQ_A = 0.359          # no-load i_q = B w_m / (1.5 p psi_f) (Table I's B)


def g1_trajectory(ts_s: float, n: int, rpm: float = G1_RPM, i_q_a: float = G1_IQ_A,
                  theta0_rad: float = 0.3):
    """An exact constant-speed trajectory of the gong2020 motor (Table I) sampled every ts_s:
    currents i = i_q (-sin, cos)(theta) at t_k and the voltage averaged over [t_k-1, t_k]
    (R i + L di/dt + e: the sinusoidal parts averaged exactly, L di/dt as the exact difference
    of the current). Returns (i_alpha, i_beta, v_alpha, v_beta, omega_e)."""
    from hil_bench.plant_rt.profile import load_profile
    prof = load_profile("gong2020")
    w = rpm / 60.0 * 2.0 * math.pi * prof.pole_pairs
    k = np.arange(n + 1)
    th = w * ts_s * k + theta0_rad
    ia, ib = -i_q_a * np.sin(th), i_q_a * np.cos(th)
    avg = math.sin(w * ts_s / 2) / (w * ts_s / 2)
    thm = th - w * ts_s / 2
    amp = (prof.rs_ohm * i_q_a + w * prof.psi_f_wb) * avg
    dia = np.diff(ia, prepend=ia[0]) / ts_s
    dib = np.diff(ib, prepend=ib[0]) / ts_s
    va = -amp * np.sin(thm) + prof.lq_h * dia
    vb = amp * np.cos(thm) + prof.lq_h * dib
    return ia, ib, va, vb, w


def g1(steps_us=(100.0, 10.0, 1.0), settle_s: float = 0.1, periods: int = 2) -> dict:
    """THD+N (as emf_thd_percent) and amplitude of e_alpha of each G1 observer, per step: keys
    ``ts<us>.m<m>.thd`` and ``.amp``; the spectrum over the last ``periods`` electrical periods
    after ``settle_s`` (hil_bench.papers.metrics.harmonic_spectrum)."""
    from hil_bench.firmware_stub.est_smo import SmoTanh
    from hil_bench.plant_rt.profile import load_profile

    from . import metrics
    prof = load_profile("gong2020")
    out: dict = {}
    for ts_us in steps_us:
        ts = ts_us * 1e-6
        w = G1_RPM / 60.0 * 2.0 * math.pi * prof.pole_pairs
        period_s = 2.0 * math.pi / w
        n = int(round((settle_s + periods * period_s) / ts))
        ia, ib, va, vb, w = g1_trajectory(ts, n)
        keep = int(round(periods * period_s / ts))
        for m, k_v in G1_K_V.items():
            est = SmoTanh(prof.rs_ohm, prof.lq_h, prof.psi_f_wb, ts, m_per_a=m, k_v=k_v)
            ea = np.empty(n + 1)
            ea[0] = 0.0
            for j in range(1, n + 1):
                ea[j] = est.step(ia[j], ib[j], va[j], vb[j]).e_alpha_v
            spec = metrics.harmonic_spectrum(ea[-keep:], 1.0 / ts, w / (2.0 * math.pi))
            out[f"ts{ts_us:g}.m{m:g}.thd"] = spec.thd_n_percent
            out[f"ts{ts_us:g}.m{m:g}.amp"] = spec.fundamental_amplitude
    return out


def g1_switching_trajectory(sub: int, n_periods: int, rpm: float = G1_RPM,
                            i_q_a: float = G1_IQ_A, theta0_rad: float = 0.3) -> dict:
    """The gong2020 motor on the switching plant (ideal inverter, no calculation delay: Gong's
    simulation) held at ``rpm`` by the dynamometer, driven open loop by the steady-state
    voltage of a no-load operating point (i_d = 0, i_q = ``i_q_a``) as min-max SVPWM, recorded
    ``sub`` times per PWM period (Plant.step_trace): ``i_alpha_a, i_beta_a`` (with the PWM
    ripple), ``v_alpha_v, v_beta_v`` (the switched phase voltage averaged over each sub-step)
    and ``v_cmd_alpha_v, v_cmd_beta_v`` (the period's commanded voltage, held: what a
    controller's observer is given)."""
    from hil_bench.plant_rt.plant import Plant
    from hil_bench.plant_rt.profile import load_profile
    from hil_bench.plant_rt.verify import openloop
    prof = load_profile("gong2020")
    w_e = rpm / 60.0 * 2.0 * math.pi * prof.pole_pairs
    plant = Plant(prof, inverter="switching", t_delay_s=0.0, dyno=True,
                  dyno_speed_rad_s=w_e / prof.pole_pairs)
    v_d, v_q = openloop.operating_point_voltage(prof, w_e, 0.0, i_q_a)
    duties = openloop.synchronous(plant.params, n_periods, theta_e0_rad=theta0_rad,
                                  omega_e_rad_s=w_e, v_d_v=v_d, v_q_v=v_q)
    plant.set_initial(theta0_rad, w_e / prof.pole_pairs)
    keys = ("i_alpha_a", "i_beta_a", "v_alpha_v", "v_beta_v")
    out = {k: np.empty(n_periods * sub) for k in keys}
    vdc = prof.v_dc_v
    v_phase = (duties - duties.mean(axis=1, keepdims=True)) * vdc
    cmd_a = v_phase[:, 0]
    cmd_b = (v_phase[:, 0] + 2.0 * v_phase[:, 1]) / math.sqrt(3.0)
    for k in range(n_periods):
        tr = plant.step_trace(*duties[k], n=sub)
        if tr is None:  # pragma: no cover - every leg is enabled
            raise RuntimeError("g1_switching_trajectory: a period was not integrated at switch level")
        for key in keys:
            out[key][k * sub:(k + 1) * sub] = tr[key]
    out["v_cmd_alpha_v"] = np.repeat(cmd_a, sub)
    out["v_cmd_beta_v"] = np.repeat(cmd_b, sub)
    out["omega_e_rad_s"] = w_e
    return out


def g1_switching(sub_steps_us=(1.0, 10.0), settle_s: float = 0.1, periods: int = 2) -> dict:
    """The G1 observers on the switching plant's ripple (hypothesis of docs/claims.md finding 5:
    Gong's THDs come from the PWM ripple his simulation has and an averaged trajectory has
    not): each observer stepped every ``sub`` us on the trajectory of g1_switching_trajectory,
    fed the instantaneous currents (with the ripple) and either the commanded voltage (``cmd``:
    as a controller's observer) or the switched voltage (``sw``: an observer that also sees the
    PWM pulses). Keys ``sw<us>.<cmd|sw>.m<m>.thd`` (THD+N of e_alpha) and ``.amp``; the spectrum
    over the last ``periods`` electrical periods after ``settle_s``."""
    from hil_bench.firmware_stub.est_smo import SmoTanh
    from hil_bench.plant_rt.profile import load_profile

    from . import metrics
    prof = load_profile("gong2020")
    ts_pwm = prof.ts_s
    w = G1_RPM / 60.0 * 2.0 * math.pi * prof.pole_pairs
    period_s = 2.0 * math.pi / w
    n_periods = int(math.ceil((settle_s + periods * period_s) / ts_pwm))
    out: dict = {}
    for step_us in sub_steps_us:
        sub = int(round(ts_pwm / (step_us * 1e-6)))
        if abs(sub * step_us * 1e-6 - ts_pwm) > 1e-12:
            raise ValueError(f"g1_switching: {step_us} us does not divide the PWM period")
        tr = g1_switching_trajectory(sub, n_periods)
        ts = ts_pwm / sub
        n = len(tr["i_alpha_a"])
        keep = int(round(periods * period_s / ts))
        for volt in ("cmd", "sw"):
            va = tr["v_cmd_alpha_v"] if volt == "cmd" else tr["v_alpha_v"]
            vb = tr["v_cmd_beta_v"] if volt == "cmd" else tr["v_beta_v"]
            for m, k_v in G1_K_V.items():
                est = SmoTanh(prof.rs_ohm, prof.lq_h, prof.psi_f_wb, ts, m_per_a=m, k_v=k_v)
                ea = np.empty(n)
                ia, ib = tr["i_alpha_a"], tr["i_beta_a"]
                for j in range(n):
                    ea[j] = est.step(ia[j], ib[j], va[j], vb[j]).e_alpha_v
                spec = metrics.harmonic_spectrum(ea[-keep:], 1.0 / ts, w / (2.0 * math.pi))
                out[f"sw{step_us:g}.{volt}.m{m:g}.thd"] = spec.thd_n_percent
                out[f"sw{step_us:g}.{volt}.m{m:g}.thd_h50"] = spec.thd_percent
                out[f"sw{step_us:g}.{volt}.m{m:g}.amp"] = spec.fundamental_amplitude
        spec_i = metrics.harmonic_spectrum(tr["i_alpha_a"][-keep:], 1.0 / ts, w / (2.0 * math.pi))
        out[f"sw{step_us:g}.current.thd"] = spec_i.thd_n_percent
        out[f"sw{step_us:g}.current.amp"] = spec_i.fundamental_amplitude
    return out


STUDIES = {"Y5": y5, "Y6": y6, "Y6ops": y6_ops, "G1": g1, "G1.sw": g1_switching}
