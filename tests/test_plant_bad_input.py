"""Bad input: physically impossible or numerically unusable parameters give a clear error naming
the field at load time (a profile file or Plant(profile, **overrides)), never a NaN later; the
Python rules and the C plant_params_check agree on every non-ideality rule."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import (
    PARAM_FIELDS,
    PROFILE_DIR,
    ProfileError,
    c_check_params,
    check_params,
    load_profile,
)

YUAN_TEXT = (PROFILE_DIR / "yuan2020.toml").read_text()
HOU = load_profile("hou2021")


def _file(tmp_path: Path, old: str, new: str) -> Path:
    assert old in YUAN_TEXT, old
    path = tmp_path / "bad.toml"
    path.write_text(YUAN_TEXT.replace(old, new, 1))
    return path


@pytest.mark.parametrize("old,new,message", [
    # the three of the issue
    ("ld_h = 2.0e-3\nlq_h = 2.0e-3", "ld_h = -2.0e-3\nlq_h = -2.0e-3", r"motor\.ld_h: must be > 0, got -0\.002$"),
    ("j_kgm2 = 0.013", "j_kgm2 = 0.0", r"mechanics\.j_kgm2: must be > 0, got 0\.0$"),
    ("dead_time_s = 1.78e-6", "dead_time_s = 150e-6", r"inverter\.dead_time_s: must be < ts_s / 2, got 0\.00015$"),
    # a value of an effect that is switched off is still checked
    ("dead_time_s = 1.78e-6", "dead_time_s = -1e-6", r"inverter\.dead_time_s: must be >= 0"),
    ("v_diode_drop_v = 0.9", "v_diode_drop_v = -0.9", r"inverter\.v_diode_drop_v: must be >= 0"),
    ("i_cap_band_a = 0.155", "i_cap_band_a = 0.0", r"inverter\.i_cap_band_a: must be > 0"),
    ("sat_l_inf_ratio = 1.0", "sat_l_inf_ratio = 1.5", r"magnetics\.sat_l_inf_ratio: must be <= 1"),
    ("sat_i_knee_a = 0.0", "sat_i_knee_a = 2.0", r"magnetics\.sat_i_knee_a: must be <= 0"),
    ("sat_i_scale_a = 10.0", "sat_i_scale_a = 0.0", r"magnetics\.sat_i_scale_a: must be > 0"),
    ("adc_bits = 12", "adc_bits = 0", r"sensors\.adc_bits: must be 1 \.\. 24"),
    ("adc_full_scale_a = 20.0", "adc_full_scale_a = -20.0", r"sensors\.adc_full_scale_a: must be > 0"),
    ("adc_noise_a_rms = 0.01", "adc_noise_a_rms = -0.01", r"sensors\.adc_noise_a_rms: must be >= 0"),
    ("adc_gain_err_ib = 0.0", "adc_gain_err_ib = -1.0", r"sensors\.adc_gain_err_ib: must be finite and > -1"),
    ("coulomb_nm = 0.0", "coulomb_nm = -0.1", r"mechanics\.coulomb_nm: must be >= 0"),
    ("dyno_accel_rad_s2 = 0.0", "dyno_accel_rad_s2 = -5.0", r"mechanics\.dyno_accel_rad_s2: must be >= 0"),
    ('load_profile = "none"', 'load_profile = "ramp"\nload_t1_s = -1.0', r"TOML syntax error"),  # duplicate key
    # types
    ("adc_model = false", 'adc_model = "no"', r"sensors\.adc_model: must be a boolean"),
    ('load_profile = "none"', 'load_profile = "sine"', r"mechanics\.load_profile: must be one of none, step, ramp, table"),
    ('inverter = "averaged"', 'inverter = "pwm"', r"inverter\.inverter: must be one of averaged, switching"),
    ('dual_sample_at = "delay"', 'dual_sample_at = "half_period"',
     r"sensors\.dual_sample_at: half_period needs inverter = switching"),
    ("load_table_t_s = []", 'load_table_t_s = "0, 1"', r"mechanics\.load_table_t_s: must be a list of numbers"),
    ("adc_seed = 1", "adc_seed = 1.5", r"sensors\.adc_seed: must be an integer"),
    ("dead_time_s = 1.78e-6", "dead_time_s = nan", r"inverter\.dead_time_s: must be finite"),
    ("dead_time_s = 1.78e-6", "dead_tme_s = 1.78e-6", r"inverter\.dead_tme_s: unknown key \(did you mean 'dead_time_s'\?\)"),
])
def test_profile_file_errors_name_the_field(tmp_path, old, new, message):
    path = _file(tmp_path, old, new)
    with pytest.raises(ProfileError) as err:
        load_profile(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: "), msg
    assert re.search(message, msg), msg


def test_load_table_rules(tmp_path):
    text = YUAN_TEXT.replace('load_profile = "none"', 'load_profile = "table"')
    cases = [
        ("load_table_t_s = []", "load_table_t_s = [0.0, 1.0]", r"mechanics\.load_table_nm: must have as many points"),
        ("load_table_t_s = []\nload_table_nm = []", "load_table_t_s = [0.0, 0.0]\nload_table_nm = [1.0, 2.0]",
         r"mechanics\.load_table_t_s: must be strictly increasing"),
        ("load_table_t_s = []\nload_table_nm = []", "load_table_t_s = []\nload_table_nm = []",
         r"mechanics\.load_table_t_s: must have 1 to 32 points"),
        ("load_table_t_s = []\nload_table_nm = []",
         f"load_table_t_s = {list(range(40))}\nload_table_nm = {[0.0] * 40}", r"must have 1 to 32 points"),
    ]
    for k, (old, new, message) in enumerate(cases):
        path = tmp_path / f"t{k}.toml"
        path.write_text(text.replace(old, new, 1))
        with pytest.raises(ProfileError, match=message):
            load_profile(path)


def test_override_errors_name_the_field():
    with pytest.raises(ProfileError, match=r"\(with overrides\): inverter\.dead_time_s: must be < ts_s / 2, got 6e-05"):
        Plant(HOU, inverter_nonlinear=True, dead_time_s=60e-6)
    with pytest.raises(ProfileError, match=r"inverter\.dead_time_s: must be < ts_s / 2"):
        Plant(HOU, dead_time_s=60e-6)  # effect off: still refused
    with pytest.raises(ProfileError, match=r"overrides\.adc_noise_rms: unknown key \(did you mean 'adc_noise_a_rms'\?\)"):
        Plant(HOU, adc_noise_rms=0.1)
    with pytest.raises(ProfileError, match=r"mechanics\.dyno: must be a boolean"):
        Plant(HOU, dyno=2)
    with pytest.raises(ProfileError, match=r"mechanics\.load_t1_s: must be > load_t0_s for a ramp"):
        Plant(HOU, load_profile="ramp", load_t0_s=1.0, load_t1_s=0.5)
    with pytest.raises(ProfileError, match=r"mechanics\.coulomb_band_rad_s: too small for the RK4 step"):
        Plant(HOU, coulomb_nm=1.0, coulomb_band_rad_s=1e-6)
    with pytest.raises(ProfileError, match=r"inverter\.i_cap_band_a: too small for the RK4 step"):
        Plant(HOU, inverter_nonlinear=True, i_cap_band_a=1e-3)
    # the step limit of an effect that is off does not stand in the way (it depends on V_dc
    # and substeps, which a scenario may change): the same band with the inverter ideal is fine
    Plant(HOU, i_cap_band_a=1e-3)
    Plant(HOU, substeps=1, v_dc_v=1000.0)


def test_bench_style_numeric_overrides_are_accepted():
    """A bench scenario's [plant] table arrives as floats: flags 0/1, load kind 0..3, integers
    as integral floats."""
    p = Plant(HOU, inverter_nonlinear=1.0, saturation=0.0, load_profile=1.0, load_t0_s=0.1,
              adc_model=1.0, adc_bits=12.0, adc_seed=7.0, dual_sampling=1.0)
    assert p.params.inverter_nonlinear is True and p.params.saturation is False
    assert p.params.load_profile == "step" and p.params.adc_bits == 12 and p.params.adc_seed == 7
    import json
    json.dumps(p.params.as_dict())  # the bench stores the parameters as JSON


# ------------------------------------------------------------------------------------------------
# Python rules == C plant_params_check for the new fields (with the effect on)

ON = dict(load_profile("yuan2020").plant_params(), inverter_nonlinear=True, saturation=True,
          sat_l_inf_ratio=0.7, sat_i_knee_a=-2.0, adc_model=True, dual_sampling=True,
          coulomb_nm=0.1, coulomb_band_rad_s=0.5, dyno=True)
MUTATIONS = [
    ("full_period_delay", 2), ("inverter_nonlinear", 2), ("dead_time_s", -1e-9), ("dead_time_s", 5e-5),
    ("dead_time_s", 4.9e-5), ("dead_time_s", math.nan), ("v_switch_drop_v", -0.1), ("r_switch_ohm", math.inf),
    ("v_diode_drop_v", -1.0), ("r_diode_ohm", -0.01), ("i_cap_band_a", 0.0), ("i_cap_band_a", 0.002),
    ("i_cap_band_a", 0.02), ("saturation", 3), ("sat_l_inf_ratio", 0.0), ("sat_l_inf_ratio", 1.0),
    ("sat_l_inf_ratio", 1.01), ("sat_i_scale_a", -1.0), ("sat_i_knee_a", 0.1), ("sat_i_knee_a", -30.1),
    ("sat_i_knee_a", -30.0), ("adc_model", -1), ("dual_sampling", 5), ("adc_bits", 0), ("adc_bits", 24),
    ("adc_bits", 25), ("adc_full_scale_a", 0.0), ("adc_gain_err_ia", -1.0), ("adc_gain_err_ic", math.nan),
    ("adc_offset_ib_a", math.inf), ("adc_noise_a_rms", -1e-3), ("adc_vdc_full_scale_v", -1.0),
    ("adc_vdc_gain_err", -2.0), ("adc_vdc_offset_v", math.nan), ("adc_vdc_noise_v_rms", -0.5),
    ("coulomb_nm", -0.1), ("coulomb_nm", 0.0), ("coulomb_band_rad_s", 0.0), ("coulomb_band_rad_s", 1e-5),
    ("load_profile", 5), ("load_profile", "ramp"), ("load_profile", "step"), ("load_profile", "table"),
    ("dyno", 2), ("dyno_speed_rad_s", math.inf), ("dyno_accel_rad_s2", -1.0),
    ("inverter", 2), ("inverter", "switching"), ("carrier_at_start", 2), ("carrier_at_start", "peak"),
    ("pwm_load", 3), ("pwm_load", "immediate"), ("dual_sample_at", 2), ("dual_sample_at", "half_period"),
]


@pytest.mark.parametrize("field,value", MUTATIONS)
def test_python_and_c_validation_agree_on_new_fields(field, value):
    params = dict(ON, **{field: value})
    py = check_params(params)
    c = c_check_params(params)
    assert (None if py is None else f"{py[0]}: {py[1]}") == c


def test_every_new_field_is_in_the_c_struct():
    from hil_bench.plant_rt.plant import ffi

    c_fields = {name for name, _ in ffi.typeof("plant_params_t").fields}
    for group in ("inverter", "magnetics", "sensors", "mechanics"):
        c_fields |= {name for name, _ in ffi.typeof(f"plant_{group if group != 'sensors' else 'sensor'}_params_t").fields}
    for key in PARAM_FIELDS:
        assert key in c_fields, key
