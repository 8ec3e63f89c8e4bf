"""Motor profiles: the shipped files equal the papers' tables; bad files give ProfileError
naming the file and the dotted field; Python and C parameter validation agree."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from hil_bench.plant_rt.profile import (
    BASE_FIELDS,
    PARAM_FIELDS,
    PROFILE_DIR,
    ProfileError,
    available_profiles,
    c_check_params,
    check_params,
    load_profile,
)

GONG_TEXT = (PROFILE_DIR / "gong2020.toml").read_text()
BASE_KEYS = {f"{BASE_FIELDS[k][0]}.{k}" for k in BASE_FIELDS} | {"rated.current_a", "rated.speed_rad_s", "rated.torque_nm"}
RPM = 2.0 * math.pi / 60.0


# ------------------------------------------------------------------------------------------------
# shipped profiles vs the papers (values typed here from the tables, not from the files)

def test_three_profiles_ship():
    assert {"gong2020", "hou2021", "yuan2020"} <= set(available_profiles())


def test_gong_equals_table_i_and_ii():
    p = load_profile("gong2020")
    assert p.kind == "SPMSM"
    table_i = dict(rs_ohm=0.6383, ld_h=2e-3, lq_h=2e-3, pole_pairs=4, j_kgm2=0.013, b_nms=0.0035,
                   psi_f_wb=0.085, v_dc_v=310.0, ts_s=0.0001)
    for key, value in table_i.items():
        assert getattr(p, key) == pytest.approx(value, rel=1e-12), key
    assert p.rated["speed_rad_s"] == 314.0
    assert p.rated["torque_nm"] == 5.0
    assert p.rated["bus_current_a"] == 6.0
    assert p.rated["corner_speed_rad_s"] == 52.3
    assert p.rated["voltage_constant_ce"] == 1.67
    # Table II: fifteen measured delays, mean 0.0341 ms
    table_ii_ms = [0.0334, 0.0332, 0.0343, 0.0343, 0.0340, 0.0353, 0.0346, 0.0333,
                   0.0338, 0.0346, 0.0352, 0.0336, 0.0342, 0.0342, 0.0336]
    assert p.t_delay_s == pytest.approx(sum(table_ii_ms) / 15 * 1e-3, abs=0.05e-6)
    # derived rated current: rated torque at i_d = 0
    assert p.rated["current_a"] == pytest.approx(5.0 / (1.5 * 4 * 0.085), rel=1e-3)
    # the paper's own back-EMF numbers: ~18 V at 500 rpm, ~70 V at 2000 rpm
    assert p.psi_f_wb * p.pole_pairs * 500 * RPM == pytest.approx(18, abs=0.5)
    assert p.psi_f_wb * p.pole_pairs * 2000 * RPM == pytest.approx(70, abs=2)


def test_hou_equals_table_1():
    p = load_profile("hou2021")
    assert p.kind == "IPMSM"
    table_1 = dict(rs_ohm=0.78, ld_h=2.5e-3, lq_h=8.5e-3, pole_pairs=3, psi_f_wb=0.303, j_kgm2=0.00107)
    for key, value in table_1.items():
        assert getattr(p, key) == pytest.approx(value, rel=1e-12), key
    assert p.rated["power_w"] == 1360.0
    assert p.rated["speed_rpm"] == 2000.0
    assert p.rated["speed_rad_s"] == pytest.approx(2000 * RPM, rel=1e-12)
    assert p.rated["torque_nm"] == 6.5
    assert p.rated["current_a"] == pytest.approx(6.5 / (1.5 * 3 * 0.303), rel=1e-3)
    # not in the paper: must be declared as assumptions
    for key in ("drive.v_dc_v", "drive.ts_s", "drive.t_delay_s", "mechanics.b_nms"):
        assert p.cite[key].startswith("assumption"), key
    # the chosen bus must exceed the line-to-line back EMF peak at rated speed
    assert p.v_dc_v > math.sqrt(3) * p.psi_f_wb * p.pole_pairs * p.rated["speed_rad_s"]


def test_yuan_flux_from_table_4():
    p = load_profile("yuan2020")
    assert p.kind == "SPMSM"
    assert p.pole_pairs == 4
    table_4 = {50: 1.6, 10: 0.32, 9: 0.288, 8: 0.256, 5: 0.16}  # rpm -> back EMF [V]
    for rpm, emf in table_4.items():
        # peak phase EMF = omega_e psi_f (the paper's eq. 2 convention)
        assert p.pole_pairs * rpm * RPM * p.psi_f_wb == pytest.approx(emf, rel=1e-6), rpm
    # everything else is Gong's SPMSM, declared as assumptions
    gong = load_profile("gong2020")
    for key in ("rs_ohm", "ld_h", "lq_h", "j_kgm2", "b_nms", "v_dc_v", "ts_s", "t_delay_s"):
        assert getattr(p, key) == getattr(gong, key), key
        section = PARAM_FIELDS[key][0]
        assert p.cite[f"{section}.{key}"].startswith("assumption"), key


@pytest.mark.parametrize("name", ["gong2020", "hou2021", "yuan2020"])
def test_every_value_is_cited_and_assumptions_explained(name):
    p = load_profile(name)
    keys = [f"{PARAM_FIELDS[k][0]}.{k}" for k in PARAM_FIELDS] + [f"rated.{k}" for k in p.rated]
    # every value has its own entry or its section's "<section>.*" entry; nothing else is cited
    for key in keys:
        assert key in p.cite or f"{key.split('.')[0]}.*" in p.cite, key
    wildcards = [k for k in p.cite if k.endswith(".*")]
    assert sorted(set(p.cite) - set(wildcards)) == sorted(k for k in p.cite if k in keys)
    for w in wildcards:  # a wildcard covers only the non-ideality sections' new keys
        assert w.split(".")[0] in ("drive", "mechanics", "inverter", "magnetics", "sensors"), w
    text = " ".join(p.assumptions)
    for key, source in p.cite.items():
        assert source.strip()
        if source.startswith("assumption") and key in BASE_KEYS:
            assert key.split(".")[-1] in text, f"{key} is an assumption but not explained"
    assert p.source and p.path == PROFILE_DIR / f"{name}.toml"
    assert p.raw["motor"]["rs_ohm"] == p.rs_ohm


def test_load_by_path_equals_load_by_name():
    assert load_profile(PROFILE_DIR / "hou2021.toml") == load_profile("hou2021")


# ------------------------------------------------------------------------------------------------
# bad profiles

def _write(tmp_path: Path, text: str, name: str = "bad.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _expect(path: Path, pattern: str) -> str:
    with pytest.raises(ProfileError) as err:
        load_profile(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: "), msg          # names the file
    assert re.search(pattern, msg), msg               # names the field / problem
    return msg


def test_missing_file(tmp_path):
    _expect(tmp_path / "nope.toml", r"no such profile file")


def test_missing_bare_name_lists_available():
    with pytest.raises(ProfileError, match=r"plant_rt/profiles/nope\.toml: no such profile file "
                                           r"\(available: .*gong2020"):
        load_profile("nope")


def test_syntax_error_names_line(tmp_path):
    text = GONG_TEXT.replace("ld_h = 2.0e-3", "ld_h = = 2.0e-3")
    line = text.splitlines().index("ld_h = = 2.0e-3") + 1
    _expect(_write(tmp_path, text), rf"TOML syntax error: .*line {line}")


def test_missing_field(tmp_path):
    text = GONG_TEXT.replace("ld_h = 2.0e-3\n", "")
    _expect(_write(tmp_path, text), r": motor\.ld_h: missing$")


def test_missing_section(tmp_path):
    text = GONG_TEXT.replace("[simulation]\nsubsteps = 4\n", "")
    _expect(_write(tmp_path, text), r": simulation: missing section")


def test_negative_inductance(tmp_path):
    text = GONG_TEXT.replace("ld_h = 2.0e-3", "ld_h = -0.002").replace("lq_h = 2.0e-3", "lq_h = -0.002")
    msg = _expect(_write(tmp_path, text), r": motor\.ld_h: must be > 0, got -0\.002$")
    assert msg == f"{tmp_path / 'bad.toml'}: motor.ld_h: must be > 0, got -0.002"


def test_zero_inertia(tmp_path):
    text = GONG_TEXT.replace("j_kgm2 = 0.013", "j_kgm2 = 0.0")
    _expect(_write(tmp_path, text), r": mechanics\.j_kgm2: must be > 0, got 0\.0$")


def test_delay_longer_than_period(tmp_path):
    text = GONG_TEXT.replace("t_delay_s = 34.1e-6", "t_delay_s = 150e-6")
    _expect(_write(tmp_path, text), r": drive\.t_delay_s: must be <= ts_s, got 0\.00015$")


def test_unknown_key_typo(tmp_path):
    text = GONG_TEXT.replace("psi_f_wb = 0.085", "psi_f_wb = 0.085\nlq_hh = 0.002")
    _expect(_write(tmp_path, text), r": motor\.lq_hh: unknown key \(did you mean 'lq_h'\?\)")


def test_unknown_section(tmp_path):
    _expect(_write(tmp_path, GONG_TEXT + "\n[motr]\nx = 1\n"), r": motr: unknown key")


def test_wrong_types(tmp_path):
    _expect(_write(tmp_path, GONG_TEXT.replace("pole_pairs = 4", "pole_pairs = 4.0"), "a.toml"),
            r": motor\.pole_pairs: must be an integer, got 4\.0")
    _expect(_write(tmp_path, GONG_TEXT.replace("rs_ohm = 0.6383", 'rs_ohm = "0.6383"'), "b.toml"),
            r": motor\.rs_ohm: must be a number")
    _expect(_write(tmp_path, GONG_TEXT.replace("substeps = 4", "substeps = true"), "c.toml"),
            r": simulation\.substeps: must be an integer")


def test_non_finite_and_other_rules(tmp_path):
    _expect(_write(tmp_path, GONG_TEXT.replace("rs_ohm = 0.6383", "rs_ohm = nan"), "a.toml"),
            r": motor\.rs_ohm: must be finite")
    _expect(_write(tmp_path, GONG_TEXT.replace("substeps = 4", "substeps = 0"), "b.toml"),
            r": simulation\.substeps: must be >= 1, got 0")
    _expect(_write(tmp_path, GONG_TEXT.replace("pole_pairs = 4", "pole_pairs = 0"), "c.toml"),
            r": motor\.pole_pairs: must be >= 1")


def test_kind_consistency(tmp_path):
    _expect(_write(tmp_path, GONG_TEXT.replace("lq_h = 2.0e-3", "lq_h = 3.0e-3")),
            r": motor\.lq_h: an SPMSM has lq_h == ld_h")
    text = GONG_TEXT.replace('kind = "SPMSM"', 'kind = "IPMSM"')
    _expect(_write(tmp_path, text, "b.toml"), r": motor\.lq_h: an IPMSM has lq_h > ld_h")
    _expect(_write(tmp_path, GONG_TEXT.replace('kind = "SPMSM"', 'kind = "BLDC"'), "c.toml"),
            r": profile\.kind: must be one of")


def test_every_value_needs_a_citation(tmp_path):
    text = re.sub(r'"motor\.ld_h" = .*\n', "", GONG_TEXT)
    _expect(_write(tmp_path, text), r": cite\.motor\.ld_h: missing")
    text = GONG_TEXT + '"motor.flux" = "Table I"\n'
    _expect(_write(tmp_path, text, "b.toml"), r": cite\.motor\.flux: unknown key")


def test_rated_section_rules(tmp_path):
    _expect(_write(tmp_path, GONG_TEXT.replace("torque_nm = 5.0\n", "")), r": rated\.torque_nm: missing")
    _expect(_write(tmp_path, GONG_TEXT.replace("torque_nm = 5.0", "torque_nm = -5.0"), "b.toml"),
            r": rated\.torque_nm: must be finite and > 0")


# ------------------------------------------------------------------------------------------------
# Python rules == C plant_params_check

GOOD = load_profile("gong2020").plant_params()
MUTATIONS = [
    ("rs_ohm", -1e-3), ("rs_ohm", 0.0), ("rs_ohm", math.inf), ("ld_h", 0.0), ("ld_h", -2e-3),
    ("ld_h", math.nan), ("lq_h", -1.0), ("lq_h", 1e-9), ("psi_f_wb", -0.1), ("psi_f_wb", 0.0),
    ("pole_pairs", 0), ("pole_pairs", -3), ("pole_pairs", 1), ("j_kgm2", 0.0), ("j_kgm2", -1.0),
    ("j_kgm2", math.inf), ("b_nms", -1e-6), ("b_nms", 0.0), ("v_dc_v", 0.0), ("v_dc_v", -310.0),
    ("ts_s", 0.0), ("ts_s", -1e-4), ("ts_s", math.nan), ("t_delay_s", -1e-9), ("t_delay_s", 1e-4),
    ("t_delay_s", 1.0000001e-4), ("t_delay_s", 0.0), ("substeps", 0), ("substeps", 1),
    ("substeps", 100_000), ("substeps", 100_001),
]


@pytest.mark.parametrize("field,value", MUTATIONS)
def test_python_and_c_validation_agree(field, value):
    params = dict(GOOD, **{field: value})
    py = check_params(params)
    c = c_check_params(params)
    assert (None if py is None else f"{py[0]}: {py[1]}") == c
