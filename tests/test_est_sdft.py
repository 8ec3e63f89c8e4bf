"""C float32 est_sdft vs the papers' G(z) (Yuan eq. 24) through scipy.signal.lfilter and vs the
float64 direct window sum (tests/models/sdft.py), on the same float32-representable inputs.

Tolerances (absolute, inputs of unit RMS, M <= 48, 2000-4000 samples):
* modulated form with resync: 2e-6 (float32 rounding of a window sum of M terms);
* direct (paper) form: 5e-5 over 4000 samples -- it drifts; the 10^7-sample behaviour is the C
  test tests/c/test_fw_dft.c.
"""
import numpy as np
import pytest
from scipy import signal

from hil_bench.firmware_stub._fw_c import lib
from hil_bench.firmware_stub.est_dft import Sdft
from tests.models.sdft import from_paper_output, paper_sdft_tf, sdft_phasors

RNG = np.random.default_rng(20240611)


def f32(x):
    """Round to float32 (what the C receives) and back to float64."""
    if np.iscomplexobj(x):
        return np.real(x).astype(np.float32).astype(float) + 1j * np.imag(x).astype(np.float32)
    return np.asarray(x).astype(np.float32).astype(float)


@pytest.mark.parametrize("m,k", [(24, 1), (24, 5), (24, 7), (24, 11), (8, 1), (48, 3), (24, 0)])
def test_real_input_matches_paper_transfer_function(m, k):
    x = f32(RNG.standard_normal(3000))
    c = Sdft(m, [k]).run(x)[:, 0]
    b, a = paper_sdft_tf(m, k)
    ref = from_paper_output(signal.lfilter(b, a, x), m, k, real_input=True)
    assert np.max(np.abs(c - ref)) < 2e-6
    assert np.max(np.abs(c - sdft_phasors(x, m, k, True))) < 2e-6


@pytest.mark.parametrize("k", [1, -1, 5, -5, 7, -7])
def test_complex_input_matches_paper_and_model(k):
    m = 24
    x = f32(RNG.standard_normal(2000) + 1j * RNG.standard_normal(2000))
    c = Sdft(m, [k], real_input=False).run(x)[:, 0]
    b, a = paper_sdft_tf(m, k)
    ref = from_paper_output(signal.lfilter(b, a, x), m, k, real_input=False)
    assert np.max(np.abs(c - ref)) < 2e-6
    assert np.max(np.abs(c - sdft_phasors(x, m, k, False))) < 2e-6


def test_two_bins_share_the_window():
    m = 24
    x = f32(RNG.standard_normal(1500) + 1j * RNG.standard_normal(1500))
    both = Sdft(m, [-5, 7], real_input=False).run(x)
    for col, k in enumerate((-5, 7)):
        assert np.max(np.abs(both[:, col] - sdft_phasors(x, m, k, False))) < 2e-6


def test_unit_harmonic_reads_unit_amplitude_and_its_phase_at_the_newest_sample():
    m, k, amp, phi = 24, 5, 1.7, 0.4
    n = np.arange(200)
    x = amp * np.cos(2 * np.pi * k * n / m + phi) + 0.3 * np.cos(2 * np.pi * 7 * n / m)
    s = Sdft(m, [k])
    p = s.run(x)[-1, 0]
    assert abs(abs(p) - amp) < 1e-5
    expected_phase = (2 * np.pi * k * n[-1] / m + phi + np.pi) % (2 * np.pi) - np.pi
    assert abs(np.angle(p) - expected_phase) < 1e-5
    # the real part of the phasor is the harmonic's present value
    assert abs(p.real - amp * np.cos(2 * np.pi * k * n[-1] / m + phi)) < 1e-5
    assert s.valid()


def test_direct_form_agrees_short_term_and_drifts():
    m, k = 24, 5
    x = f32(RNG.standard_normal(4000))
    ref = sdft_phasors(x, m, k, True)
    mod = Sdft(m, [k]).run(x)[:, 0]
    direct = Sdft(m, [k], form="direct").run(x)[:, 0]
    err_mod, err_dir = np.abs(mod - ref), np.abs(direct - ref)
    assert np.max(err_mod) < 2e-6
    assert np.max(err_dir) < 5e-5
    # the direct form's error grows; the modulated one's does not
    assert np.max(err_dir[-500:]) > 5 * np.max(err_mod[-500:])


def test_negate_is_the_same_as_negated_history():
    m, k = 8, 1
    x = f32(RNG.standard_normal(100))
    a, b = Sdft(m, [k]), Sdft(m, [k])
    a.run(x[:50])
    b.run(-x[:50])
    lib.est_sdft_negate(a.state)
    pa, pb = a.run(-x[50:]), b.run(-x[50:])
    assert np.max(np.abs(pa - pb)) < 1e-6


@pytest.mark.parametrize("kwargs", [dict(m=1, bins=[0]), dict(m=200, bins=[1]),
                                    dict(m=24, bins=[24]), dict(m=24, bins=[-24]),
                                    dict(m=24, bins=[]), dict(m=24, bins=[1, 2, 3, 4, 5])])
def test_bad_configuration_is_refused(kwargs):
    with pytest.raises(ValueError, match="Sdft"):
        Sdft(**kwargs)
    with pytest.raises(ValueError, match="form"):
        Sdft(24, [1], form="fast")
