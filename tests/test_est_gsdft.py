"""C float32 est_gsdft vs the paper's G_S(z) (Yuan eq. 27) through scipy.signal.lfilter and vs the
float64 explicit FIR (tests/models/gsdft.py); SDFT = GSDFT in steady state (claim Y7); the tracking
time of both for Yuan's sin(500 pi t) amplitude step (claim Y5), printed beside the paper's.

Tolerances: 2e-6 absolute on unit-RMS inputs (float32 rounding of M/3-term window sums); Y7:
the two phasors agree within 2e-6 once both windows are full.
"""
import numpy as np
import pytest
from scipy import signal

from hil_bench.firmware_stub.est_dft import Gsdft, Sdft
from tests.models.gsdft import (
    from_paper_output,
    gsdft_phasors,
    normalisation,
    paper_gain,
    paper_gsdft_tf,
    window_weights,
)
from tests.models.sdft import tracking_time_samples

RNG = np.random.default_rng(7)


def f32(x):
    if np.iscomplexobj(x):
        return np.real(x).astype(np.float32).astype(float) + 1j * np.imag(x).astype(np.float32)
    return np.asarray(x).astype(np.float32).astype(float)


def test_paper_gain_at_the_bin_is_not_unity_and_the_normalisation_makes_it_one():
    for m, k in ((24, 5), (24, 7), (24, 1), (36, -5), (96, 7)):
        g = paper_gain(m, k)
        assert abs(abs(g) - np.sqrt(3) / 6) < 1e-6          # window M/3 with 1/M: sqrt(3)/6
        # complex input: normalised gain exactly 1 (no phase shift at the newest sample)
        assert abs(g * normalisation(m, k, real_input=False) - 1.0) < 1e-6


@pytest.mark.parametrize("m,k", [(24, 1), (24, 5), (24, 7), (24, 11), (36, 13), (96, 5)])
def test_real_input_matches_paper_transfer_function(m, k):
    x = f32(RNG.standard_normal(3000))
    c = Gsdft(m, [k]).run(x)[:, 0]
    b, a = paper_gsdft_tf(m, k)
    ref = from_paper_output(signal.lfilter(b, a, x), m, k, real_input=True)
    assert np.max(np.abs(c - ref)) < 2e-6
    assert np.max(np.abs(c - gsdft_phasors(x, m, k, True))) < 2e-6


@pytest.mark.parametrize("k", [-5, 7, 1, -11])
@pytest.mark.parametrize("dc_block", [False, True])
def test_complex_input_matches_paper_and_model(k, dc_block):
    m = 24
    x = f32(RNG.standard_normal(2000) + 1j * RNG.standard_normal(2000))
    c = Gsdft(m, [k], real_input=False, dc_block=dc_block).run(x)[:, 0]
    b, a = paper_gsdft_tf(m, k)
    if dc_block:
        b = np.convolve(b, [1.0, -1.0])                     # G_S(z) (1 - z^-1)
    ref = normalisation(m, k, False, dc_block) * signal.lfilter(b, a, x)
    # the DC block's normalisation 1/|1 - e^{-j w_k}| (3.8 at k = 1, M = 24) scales the rounding
    tol = 2e-6 / (abs(1 - np.exp(-2j * np.pi * k / m)) if dc_block else 1.0)
    assert np.max(np.abs(c - ref)) < max(tol, 2e-6)
    assert np.max(np.abs(c - gsdft_phasors(x, m, k, False, dc_block))) < max(tol, 2e-6)


def test_direct_form_is_the_same_filter():
    m, k = 24, 5
    x = f32(RNG.standard_normal(2000))
    d = Gsdft(m, [k], form="direct").run(x)[:, 0]
    assert np.max(np.abs(d - gsdft_phasors(x, m, k, True))) < 5e-5


def test_window_is_a_third_of_the_sdft_window():
    g = Gsdft(24, [5])
    assert g.window == 8
    assert Gsdft(24, [5], dc_block=True).window == 9
    x = f32(RNG.standard_normal(30))
    g.run(x[:7])
    assert not g.valid()
    g.run(x[7:8])
    assert g.valid()


def bin_response(m, k, h, *, real_input=False, dc_block=False, n=400):
    """|phasor| in steady state for a unit complex exponential at harmonic h (M samples/period)."""
    t = np.arange(n)
    x = np.exp(2j * np.pi * h * t / m)
    return abs(Gsdft(m, [k], real_input=real_input, dc_block=dc_block).run(x)[-1, 0])


def test_what_the_comb_nulls_and_what_it_passes():
    m, k = 24, -5
    # nulled: every 6h+-1 bin except the one extracted
    for h in (1, -1, 5, 7, -7, 11, -11, 13):
        assert bin_response(m, k, h) < 1e-5, h
    assert abs(bin_response(m, k, -5) - 1.0) < 1e-5
    # passed (attenuated, not nulled): DC, triplen, even -- the leak the model predicts
    for h in (0, 2, -2, 3, -3, 4, 6):
        hz = window_weights(m, k, False)
        predicted = abs(np.sum(hz * np.exp(-2j * np.pi * h * np.arange(len(hz)) / m)))
        measured = bin_response(m, k, h)
        assert measured > 0.05 and abs(measured - predicted) < 1e-5, (h, measured, predicted)
    # the DC block removes DC (and only adds a zero there)
    assert bin_response(m, k, 0, dc_block=True) < 1e-6
    assert abs(bin_response(m, k, -5, dc_block=True) - 1.0) < 1e-5


def test_y7_steady_state_sdft_equals_gsdft():
    """Claim Y7 (Yuan Table 3): same extraction results in steady state."""
    m, n = 24, np.arange(600)
    # a phase current with 6h+-1 harmonics (the dead-time family), real input, bins 5 and 7
    x = (5.0 * np.cos(2 * np.pi * n / m + 0.2) + 0.20 * np.cos(2 * np.pi * 5 * n / m - 1.0)
         + 0.21 * np.cos(2 * np.pi * 7 * n / m + 2.0) + 0.05 * np.cos(2 * np.pi * 11 * n / m))
    sd = Sdft(m, [5, 7]).run(x)
    gs = Gsdft(m, [5, 7]).run(x)
    late = slice(m, None)
    assert np.max(np.abs(sd[late] - gs[late])) < 2e-6
    assert abs(abs(gs[-1, 0]) - 0.20) < 1e-5 and abs(abs(gs[-1, 1]) - 0.21) < 1e-5
    # complex alpha-beta with a sensor offset: SDFT nulls DC, the GSDFT needs its DC block
    iab = (5.0 * np.exp(1j * 2 * np.pi * n / m) + 0.2 * np.exp(-1j * (2 * np.pi * 5 * n / m - 1.0))
           + 0.21 * np.exp(1j * (2 * np.pi * 7 * n / m + 2.0)) + (0.1 - 0.05j))
    sd = Sdft(m, [-5, 7], real_input=False).run(iab)
    gs = Gsdft(m, [-5, 7], real_input=False, dc_block=True).run(iab)
    assert np.max(np.abs(sd[late] - gs[late])) < 2e-6
    leaky = Gsdft(m, [-5, 7], real_input=False).run(iab)
    assert np.max(np.abs(leaky[late] - sd[late])) > 0.005   # without the block DC leaks


def y5_signal(fs_hz=1200.0, t_end_s=0.5):
    t = np.arange(int(round(t_end_s * fs_hz))) / fs_hz
    amp = np.where(t < 0.2, 1.0, 2.0)
    return t, amp * np.sin(500 * np.pi * t)


def test_y5_tracking_time_sdft_vs_gsdft(capsys):
    """Claim Y5 as the paper sets it up: sin(500 pi t), amplitude 1 -> 2 A at 0.2 s, read as the
    5th harmonic (k = 5) of an M = 24 window spanning one 50 Hz period (fs = 1200 Hz: the paper's
    M = 24, k = 5 pole-zero example, Fig. 5 and 7). Tracking time = until |amplitude - final|
    stays within 2 %, in cycles of 250 Hz (4.8 samples each). Both are FIRs of M and M/3 taps:
    exactly settled once the window holds only new samples, M - 1 = 23 and M/3 - 1 = 7 samples
    after the step's first sample, i.e. 4.79 and 1.46 cycles (the 2 % criterion changes nothing).
    Yuan: about 5 and about 2 cycles (bench/papers/studies.py, claim Y5)."""
    m, k = 24, 5
    t, x = y5_signal()
    per_cycle = 1200.0 / 250.0
    i_step = int(np.argmax(t >= 0.2))
    rows = []
    results = {}
    for name, est, paper in (("SDFT", Sdft(m, [k]), 5), ("GSDFT", Gsdft(m, [k]), 2)):
        amp = np.abs(est.run(x)[:, 0])
        start2 = tracking_time_samples(amp[:i_step], 0, 1.0, 0.02) / per_cycle
        step2 = tracking_time_samples(amp, i_step, 2.0, 0.02) / per_cycle
        step0 = tracking_time_samples(amp, i_step, 2.0, 1e-5) / per_cycle
        results[name] = (start2, step2, step0)
        rows.append(f"{name:6s} start-up {start2:5.2f}  step(2%) {step2:5.2f}  settled "
                    f"{step0:5.2f}  cycles   paper ~{paper}")
    with capsys.disabled():
        print("\nY5 tracking time, fs = 1.2 kHz, M = 24, k = 5, cycles of 250 Hz:\n  "
              + "\n  ".join(rows))
    assert results["SDFT"][1] == pytest.approx(23 / per_cycle)      # 4.79 cycles
    assert results["GSDFT"][1] == pytest.approx(7 / per_cycle)      # 1.46 cycles
    assert results["SDFT"][2] == results["SDFT"][1]                 # exact: the window is full
    assert results["GSDFT"][2] == results["GSDFT"][1]
    assert results["SDFT"][0] == results["SDFT"][1] and results["GSDFT"][0] == results["GSDFT"][1]


@pytest.mark.parametrize("kwargs", [dict(m=20, bins=[1]), dict(m=24, bins=[3]),
                                    dict(m=24, bins=[6]), dict(m=24, bins=[0]),
                                    dict(m=24, bins=[2]), dict(m=102, bins=[1]),
                                    dict(m=24, bins=[5, 4])])
def test_bad_configuration_is_refused(kwargs):
    with pytest.raises(ValueError, match="Gsdft"):
        Gsdft(**kwargs)
