"""Yuan's 10 rpm operating point through the whole bench: the calibrated inverter nonlinearity
(plant_rt/profiles/yuan2020.toml) makes the phase-current THD the paper reports without
compensation, and Yuan's 5th/7th compensation (eq. 28-37, GSDFT extraction) in the stub's
current loop acts on it. Measured: 8.6 % without, 8.3 % with (paper 8.06 -> 6.01 %): the
compensation law adds about R*I_h, tens of millivolts against a dead-time harmonic voltage of
about a volt at this speed — a finding the Y4 claim reports."""
import pytest

from hil_bench.loop.runner import run_scenario
from hil_bench.papers import metrics
from hil_bench.record import channels as ch
from hil_bench.record.recording import load_recording
from hil_bench.scenario import load_scenario


def spectrum(path, window_s=(0.9, 4.0)):
    rec = load_recording(path)
    st = rec.topic(ch.PLANT_STATE)
    m = metrics.window_mask(st["t_s"], window_s)
    f_e = abs(st["omega_e_rad_s"][m].mean()) / (2 * 3.141592653589793)
    return metrics.harmonic_spectrum(st["i_a_a"][m], 1e4, f_e)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for name in ("yuan_y4_10rpm", "yuan_y4_10rpm_comp"):
        path = tmp_path_factory.mktemp(name) / f"{name}.mcap"
        result = run_scenario(load_scenario(name), link_spec="sil", out_path=path, progress=False)
        assert result.ok, result.error
        out[name] = spectrum(path)
    return out


def test_uncompensated_thd_is_near_the_papers(runs):
    s = runs["yuan_y4_10rpm"]
    assert 6.0 < s.thd_percent < 11.0          # paper 8.06 %; the plant is calibrated on it
    assert 3.0 < s.harmonic_percent(5) < 5.5   # paper 4.08 %


def test_compensation_reduces_the_5th_and_7th(runs):
    before, after = runs["yuan_y4_10rpm"], runs["yuan_y4_10rpm_comp"]
    assert after.harmonic_percent(5) < before.harmonic_percent(5)
    assert after.harmonic_percent(7) < before.harmonic_percent(7)
    assert after.thd_percent < before.thd_percent
