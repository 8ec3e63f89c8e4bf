"""Motor profiles: TOML files in ``plant_rt/profiles/`` -> validated :class:`MotorProfile`.

File layout (every key is required unless marked optional; unknown keys are errors)::

    [profile]     name, kind ("SPMSM" | "IPMSM"), source (citation), assumptions (list of str)
    [motor]       rs_ohm [ohm], ld_h [H], lq_h [H], psi_f_wb [Wb, peak phase], pole_pairs [-]
    [mechanics]   j_kgm2 [kg m^2], b_nms [N m s/rad],
                  coulomb_nm [N m], coulomb_band_rad_s [rad/s],
                  load_profile ("none" | "step" | "ramp" | "table"), load_t0_s, load_t1_s [s],
                  load_torque0_nm, load_torque1_nm [N m], load_table_t_s [s], load_table_nm [N m]
                  (lists, <= 32 points), dyno (bool), dyno_speed_rad_s, dyno_accel_rad_s2
    [drive]       v_dc_v [V], ts_s [s] (PWM = control period), t_delay_s [s] (sampling -> new duties),
                  full_period_delay (bool: the new duties act from the next period boundary)
    [inverter]    inverter_nonlinear (bool), dead_time_s [s], v_switch_drop_v [V], r_switch_ohm [ohm],
                  v_diode_drop_v [V], r_diode_ohm [ohm], i_cap_band_a [A],
                  inverter ("averaged" | "switching"), carrier_at_start ("valley" | "peak"),
                  pwm_load ("extremum" | "period" | "immediate")
    [magnetics]   saturation (bool), sat_l_inf_ratio [-], sat_i_scale_a [A], sat_i_knee_a [A]
    [sensors]     adc_model (bool), adc_bits, adc_full_scale_a [A], adc_gain_err_ia/_ib/_ic [-],
                  adc_offset_ia_a/_ib_a/_ic_a [A], adc_noise_a_rms [A], adc_vdc_full_scale_v [V],
                  adc_vdc_gain_err [-], adc_vdc_offset_v [V], adc_vdc_noise_v_rms [V], adc_seed,
                  dual_sampling (bool), dual_sample_at ("delay" | "half_period")
    [simulation]  substeps [-] (RK4 steps per period)
    [rated]       speed_rad_s [rad/s, mechanical], torque_nm [N m], current_a [A, peak phase];
                  optional: power_w, speed_rpm, bus_current_a, corner_speed_rad_s, voltage_constant_ce
    [cite]        "<section>.<key>" = "where the value comes from" for every value above
                  (a paper table, or "assumption: why"); "<section>.*" covers the values of that
                  section that have no entry of their own

The keys are flat and unique across sections: ``Plant(profile, **overrides)`` takes any of them
(a scenario's [plant] table). Booleans also accept 0/1 (numbers), load_profile also accepts its
code 0..3, and the other named choices (CHOICES) their index. Each non-ideality group has a switch (inverter_nonlinear, saturation, adc_model,
dual_sampling, full_period_delay, dyno; Coulomb friction and the load profile are off at 0 /
"none"); the shipped profiles keep every switch off, so a scenario turns on what it needs and
gets the profile's values. Every value is also checked as if its switch were on (a physically
impossible value is an error even while its effect is off; the integrator's step limits, which
depend on V_dc and substeps, only when the effect is on).

Every problem raises :class:`ProfileError` whose message names the file and the dotted field,
e.g. ``plant_rt/profiles/x.toml: motor.ld_h: must be > 0, got -0.002``. The physical rules are
the same as the C ``plant_params_check`` (which is called too when the C module is built).
"""
from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

PROFILE_DIR = Path(__file__).resolve().parent / "profiles"
_REPO_ROOT = Path(__file__).resolve().parents[1]

#: Kinds of values besides float and int.
BOOL = "bool"            # TOML true/false (or 0/1); C int 0/1
LOAD_KIND = "load_kind"  # "none" | "step" | "ramp" | "table" (or 0..3); C int
FLOAT_LIST = "float_list"  # list of numbers; C array + count
LOAD_KINDS = ("none", "step", "ramp", "table")
LOAD_TABLE_MAX = 32      # MECH_LOAD_TABLE_MAX in mechanics.h
CHOICE = "choice"        # one of the names in CHOICES[key] (or its index); C int = the index
#: The names of the CHOICE keys, in the order of their C codes (the first is the "off" value).
CHOICES: dict[str, tuple[str, ...]] = {
    "inverter": ("averaged", "switching"),            # plant.h "Switching mode"
    "carrier_at_start": ("valley", "peak"),           # pwm_carrier_t
    "pwm_load": ("extremum", "period", "immediate"),  # pwm_load_t
    "dual_sample_at": ("delay", "half_period"),       # second sample at t_k + t_d or t_k + Ts/2
}

#: The 11 base plant_params_t fields, in C order -> (section in the TOML file, python type)
BASE_FIELDS: dict[str, tuple[str, Any]] = {
    "rs_ohm": ("motor", float),
    "ld_h": ("motor", float),
    "lq_h": ("motor", float),
    "psi_f_wb": ("motor", float),
    "pole_pairs": ("motor", int),
    "j_kgm2": ("mechanics", float),
    "b_nms": ("mechanics", float),
    "v_dc_v": ("drive", float),
    "ts_s": ("drive", float),
    "t_delay_s": ("drive", float),
    "substeps": ("simulation", int),
}

#: Non-ideality fields (flat key = C field name) -> (TOML section, python type, C group
#: inside plant_params_t or None for a top-level field). Order = C order.
NONIDEAL_FIELDS: dict[str, tuple[str, Any, str | None]] = {
    "full_period_delay": ("drive", BOOL, None),
    "inverter_nonlinear": ("inverter", BOOL, "inverter"),
    "dead_time_s": ("inverter", float, "inverter"),
    "v_switch_drop_v": ("inverter", float, "inverter"),
    "r_switch_ohm": ("inverter", float, "inverter"),
    "v_diode_drop_v": ("inverter", float, "inverter"),
    "r_diode_ohm": ("inverter", float, "inverter"),
    "i_cap_band_a": ("inverter", float, "inverter"),
    "inverter": ("inverter", CHOICE, "inverter"),
    "carrier_at_start": ("inverter", CHOICE, "inverter"),
    "pwm_load": ("inverter", CHOICE, "inverter"),
    "saturation": ("magnetics", BOOL, "magnetics"),
    "sat_l_inf_ratio": ("magnetics", float, "magnetics"),
    "sat_i_scale_a": ("magnetics", float, "magnetics"),
    "sat_i_knee_a": ("magnetics", float, "magnetics"),
    "adc_model": ("sensors", BOOL, "sensors"),
    "adc_bits": ("sensors", int, "sensors"),
    "adc_full_scale_a": ("sensors", float, "sensors"),
    "adc_gain_err_ia": ("sensors", float, "sensors"),
    "adc_gain_err_ib": ("sensors", float, "sensors"),
    "adc_gain_err_ic": ("sensors", float, "sensors"),
    "adc_offset_ia_a": ("sensors", float, "sensors"),
    "adc_offset_ib_a": ("sensors", float, "sensors"),
    "adc_offset_ic_a": ("sensors", float, "sensors"),
    "adc_noise_a_rms": ("sensors", float, "sensors"),
    "adc_vdc_full_scale_v": ("sensors", float, "sensors"),
    "adc_vdc_gain_err": ("sensors", float, "sensors"),
    "adc_vdc_offset_v": ("sensors", float, "sensors"),
    "adc_vdc_noise_v_rms": ("sensors", float, "sensors"),
    "adc_seed": ("sensors", int, "sensors"),
    "dual_sampling": ("sensors", BOOL, "sensors"),
    "dual_sample_at": ("sensors", CHOICE, "sensors"),
    "coulomb_nm": ("mechanics", float, "mechanics"),
    "coulomb_band_rad_s": ("mechanics", float, "mechanics"),
    "load_profile": ("mechanics", LOAD_KIND, "mechanics"),
    "load_t0_s": ("mechanics", float, "mechanics"),
    "load_t1_s": ("mechanics", float, "mechanics"),
    "load_torque0_nm": ("mechanics", float, "mechanics"),
    "load_torque1_nm": ("mechanics", float, "mechanics"),
    "load_table_t_s": ("mechanics", FLOAT_LIST, "mechanics"),
    "load_table_nm": ("mechanics", FLOAT_LIST, "mechanics"),
    "dyno": ("mechanics", BOOL, "mechanics"),
    "dyno_speed_rad_s": ("mechanics", float, "mechanics"),
    "dyno_accel_rad_s2": ("mechanics", float, "mechanics"),
}

#: Every flat parameter key -> (section in the TOML file, python type); base fields first.
PARAM_FIELDS: dict[str, tuple[str, Any]] = {
    **BASE_FIELDS,
    **{k: (sec, kind) for k, (sec, kind, _) in NONIDEAL_FIELDS.items()},
}

#: The switches, forced on when a profile's values are checked ("as if on").
SWITCHES = ("full_period_delay", "inverter_nonlinear", "saturation", "adc_model", "dual_sampling", "dyno")
MAX_SUBSTEPS = 100_000  # PLANT_MAX_SUBSTEPS in plant.h

RATED_REQUIRED = ("speed_rad_s", "torque_nm", "current_a")
RATED_OPTIONAL = ("power_w", "speed_rpm", "bus_current_a", "corner_speed_rad_s", "voltage_constant_ce")
PROFILE_KEYS = ("name", "kind", "source", "assumptions")
KINDS = ("SPMSM", "IPMSM")
SECTIONS = ("profile", "motor", "mechanics", "drive", "inverter", "magnetics", "sensors",
            "simulation", "rated", "cite")


class ProfileError(ValueError):
    """A motor profile (file or override) is missing, malformed or non-physical."""


@dataclass(frozen=True)
class MotorProfile:
    """A validated motor + drive profile (SI units; see the module docstring for the file)."""

    name: str
    path: Path
    kind: str                      # "SPMSM" or "IPMSM"
    source: str                    # citation of the paper the values come from
    rs_ohm: float                  # stator phase resistance [ohm]
    ld_h: float                    # d-axis inductance [H]
    lq_h: float                    # q-axis inductance [H]
    psi_f_wb: float                # PM flux linkage, peak per phase [Wb]
    pole_pairs: int                # [-]
    j_kgm2: float                  # inertia [kg m^2]
    b_nms: float                   # viscous friction [N m s/rad]
    v_dc_v: float                  # DC-link voltage [V]
    ts_s: float                    # PWM / control period [s]
    t_delay_s: float               # sampling instant -> new duties take effect [s]
    substeps: int                  # RK4 sub-steps per period [-]
    rated: dict[str, float]        # speed_rad_s, torque_nm, current_a, ... (see module doc)
    assumptions: list[str]         # every value not from the paper, with its reason
    cite: dict[str, str] = field(default_factory=dict)  # "section.key" -> source of the value
    raw: dict[str, Any] = field(default_factory=dict)   # the parsed TOML document
    nonideal: dict[str, Any] = field(default_factory=dict)  # NONIDEAL_FIELDS values (flat)

    def plant_params(self) -> dict[str, Any]:
        """Every plant parameter, flat (C order): the 11 base fields, then the non-idealities."""
        base = {name: getattr(self, name) for name in BASE_FIELDS}
        return {**base, **{k: self.nonideal[k] for k in NONIDEAL_FIELDS}}

    def __getattr__(self, name: str) -> Any:  # profile.dead_time_s etc.
        nonideal = self.__dict__.get("nonideal", {})
        if name in nonideal:
            return nonideal[name]
        raise AttributeError(name)


# ---------------------------------------------------------------------------------------------
# physical rules (mirror plant_params_check in plant_rt/c/plant.c, same order, same reasons)

def _finite(x: float) -> bool:
    return math.isfinite(x)


_RULES: list[tuple[str, Callable[[Mapping[str, Any]], bool], str]] = [
    ("rs_ohm", lambda p: _finite(p["rs_ohm"]), "must be finite"),
    ("rs_ohm", lambda p: p["rs_ohm"] >= 0.0, "must be >= 0"),
    ("ld_h", lambda p: _finite(p["ld_h"]), "must be finite"),
    ("ld_h", lambda p: p["ld_h"] > 0.0, "must be > 0"),
    ("lq_h", lambda p: _finite(p["lq_h"]), "must be finite"),
    ("lq_h", lambda p: p["lq_h"] > 0.0, "must be > 0"),
    ("psi_f_wb", lambda p: _finite(p["psi_f_wb"]), "must be finite"),
    ("psi_f_wb", lambda p: p["psi_f_wb"] >= 0.0, "must be >= 0"),
    ("pole_pairs", lambda p: p["pole_pairs"] >= 1, "must be >= 1"),
    ("j_kgm2", lambda p: _finite(p["j_kgm2"]), "must be finite"),
    ("j_kgm2", lambda p: p["j_kgm2"] > 0.0, "must be > 0"),
    ("b_nms", lambda p: _finite(p["b_nms"]), "must be finite"),
    ("b_nms", lambda p: p["b_nms"] >= 0.0, "must be >= 0"),
    ("v_dc_v", lambda p: _finite(p["v_dc_v"]), "must be finite"),
    ("v_dc_v", lambda p: p["v_dc_v"] > 0.0, "must be > 0"),
    ("ts_s", lambda p: _finite(p["ts_s"]), "must be finite"),
    ("ts_s", lambda p: p["ts_s"] > 0.0, "must be > 0"),
    ("t_delay_s", lambda p: _finite(p["t_delay_s"]), "must be finite"),
    ("t_delay_s", lambda p: p["t_delay_s"] >= 0.0, "must be >= 0"),
    ("t_delay_s", lambda p: p["t_delay_s"] <= p["ts_s"], "must be <= ts_s"),
    ("substeps", lambda p: p["substeps"] >= 1, "must be >= 1"),
    ("substeps", lambda p: p["substeps"] <= MAX_SUBSTEPS, f"must be <= {MAX_SUBSTEPS}"),
]


def _flag(name: str):
    return (name, lambda p: p[name] in (0, 1), "must be 0 or 1")


def _when(cond: Callable[[Mapping[str, Any]], bool], name: str,
          ok: Callable[[Mapping[str, Any]], bool], reason: str):
    """A rule that applies only when cond(p) holds (the group's switch is on)."""
    return (name, lambda p: (not cond(p)) or ok(p), reason)


def _sat(p: Mapping[str, Any]) -> bool:
    return bool(p["saturation"])


def _inv(p: Mapping[str, Any]) -> bool:
    return bool(p["inverter_nonlinear"])


def _adc(p: Mapping[str, Any]) -> bool:
    return bool(p["adc_model"])


def _l_min(p: Mapping[str, Any]) -> float:
    return min(p["ld_h"] * (p["sat_l_inf_ratio"] if p["saturation"] else 1.0), p["lq_h"])


def _band_ok(p: Mapping[str, Any]) -> bool:
    """RK4 stability across the dead-time band (plant_params_check_nonideal)."""
    h = p["ts_s"] / p["substeps"]
    slope = (p["dead_time_s"] / p["ts_s"] * p["v_dc_v"]
             + 2.0 * (p["v_switch_drop_v"] + p["v_diode_drop_v"])) / (2.0 * p["i_cap_band_a"])
    return h * slope <= 2.0 * _l_min(p)


def _coulomb_ok(p: Mapping[str, Any]) -> bool:
    h = p["ts_s"] / p["substeps"]
    return h * p["coulomb_nm"] <= 2.0 * p["j_kgm2"] * p["coulomb_band_rad_s"]


def _load_code(p: Mapping[str, Any]) -> int:
    v = p["load_profile"]
    return LOAD_KINDS.index(v) if isinstance(v, str) and v in LOAD_KINDS else v


def _choice_code(p: Mapping[str, Any], key: str) -> int:
    """C code of a CHOICE value (a name or its index); -1 for anything else."""
    v = p[key]
    if isinstance(v, str):
        return CHOICES[key].index(v) if v in CHOICES[key] else -1
    if isinstance(v, (int, float)) and not isinstance(v, bool) and float(v).is_integer():
        return int(v)
    return -1


def _choice_rule(key: str):
    names = CHOICES[key]
    said = " or ".join(names) if len(names) == 2 else ", ".join(names[:-1]) + " or " + names[-1]
    return (key, lambda p: 0 <= _choice_code(p, key) < len(names), f"must be {said}")


def _kind_is(*codes: int):
    return lambda p: _load_code(p) in codes


def _table_first_bad(p: Mapping[str, Any]) -> str | None:
    """The table rules are per point in C (finite t, finite T, increasing, point by point)."""
    t, v = list(p["load_table_t_s"]), list(p["load_table_nm"])
    for k in range(min(len(t), len(v))):
        if not _finite(t[k]):
            return "load_table_t_s: must be finite"
        if not _finite(v[k]):
            return "load_table_nm: must be finite"
        if k > 0 and not t[k] > t[k - 1]:
            return "load_table_t_s: must be strictly increasing"
    return None


_NONIDEAL_RULES: list[tuple[str, Callable[[Mapping[str, Any]], bool], str]] = [
    _flag("full_period_delay"),
    _flag("saturation"),
    _when(_sat, "sat_l_inf_ratio", lambda p: _finite(p["sat_l_inf_ratio"]), "must be finite"),
    _when(_sat, "sat_l_inf_ratio", lambda p: p["sat_l_inf_ratio"] > 0.0, "must be > 0"),
    _when(_sat, "sat_l_inf_ratio", lambda p: p["sat_l_inf_ratio"] <= 1.0, "must be <= 1"),
    _when(_sat, "sat_i_scale_a", lambda p: _finite(p["sat_i_scale_a"]), "must be finite"),
    _when(_sat, "sat_i_scale_a", lambda p: p["sat_i_scale_a"] > 0.0, "must be > 0"),
    _when(_sat, "sat_i_knee_a", lambda p: _finite(p["sat_i_knee_a"]), "must be finite"),
    _when(_sat, "sat_i_knee_a", lambda p: p["sat_i_knee_a"] <= 0.0, "must be <= 0"),
    _when(_sat, "sat_i_knee_a", lambda p: p["sat_i_knee_a"] >= -3.0 * p["sat_i_scale_a"],
          "must be >= -3 sat_i_scale_a"),
    _choice_rule("inverter"),
    _choice_rule("carrier_at_start"),
    _choice_rule("pwm_load"),
    _flag("inverter_nonlinear"),
    _when(_inv, "dead_time_s", lambda p: _finite(p["dead_time_s"]), "must be finite"),
    _when(_inv, "dead_time_s", lambda p: p["dead_time_s"] >= 0.0, "must be >= 0"),
    _when(_inv, "dead_time_s", lambda p: 2.0 * p["dead_time_s"] < p["ts_s"], "must be < ts_s / 2"),
    *[r for name in ("v_switch_drop_v", "r_switch_ohm", "v_diode_drop_v", "r_diode_ohm")
      for r in (_when(_inv, name, (lambda n: lambda p: _finite(p[n]))(name), "must be finite"),
                _when(_inv, name, (lambda n: lambda p: p[n] >= 0.0)(name), "must be >= 0"))],
    _when(_inv, "i_cap_band_a", lambda p: _finite(p["i_cap_band_a"]), "must be finite"),
    _when(_inv, "i_cap_band_a", lambda p: p["i_cap_band_a"] > 0.0, "must be > 0"),
    _when(_inv, "i_cap_band_a", _band_ok, "too small for the RK4 step (raise it or substeps)"),
    _flag("adc_model"),
    _flag("dual_sampling"),
    _choice_rule("dual_sample_at"),
    ("dual_sample_at", lambda p: _choice_code(p, "dual_sample_at") != 1 or _choice_code(p, "inverter") == 1,
     "half_period needs inverter = switching"),
    _when(_adc, "adc_bits", lambda p: 1 <= p["adc_bits"] <= 24, "must be 1 .. 24"),
    _when(_adc, "adc_full_scale_a", lambda p: _finite(p["adc_full_scale_a"]), "must be finite"),
    _when(_adc, "adc_full_scale_a", lambda p: p["adc_full_scale_a"] > 0.0, "must be > 0"),
    *[_when(_adc, n, (lambda n: lambda p: _finite(p[n]) and p[n] > -1.0)(n), "must be finite and > -1")
      for n in ("adc_gain_err_ia", "adc_gain_err_ib", "adc_gain_err_ic")],
    *[_when(_adc, n, (lambda n: lambda p: _finite(p[n]))(n), "must be finite")
      for n in ("adc_offset_ia_a", "adc_offset_ib_a", "adc_offset_ic_a")],
    _when(_adc, "adc_noise_a_rms", lambda p: _finite(p["adc_noise_a_rms"]), "must be finite"),
    _when(_adc, "adc_noise_a_rms", lambda p: p["adc_noise_a_rms"] >= 0.0, "must be >= 0"),
    _when(_adc, "adc_vdc_full_scale_v", lambda p: _finite(p["adc_vdc_full_scale_v"]), "must be finite"),
    _when(_adc, "adc_vdc_full_scale_v", lambda p: p["adc_vdc_full_scale_v"] > 0.0, "must be > 0"),
    _when(_adc, "adc_vdc_gain_err", lambda p: _finite(p["adc_vdc_gain_err"]) and p["adc_vdc_gain_err"] > -1.0,
          "must be finite and > -1"),
    _when(_adc, "adc_vdc_offset_v", lambda p: _finite(p["adc_vdc_offset_v"]), "must be finite"),
    _when(_adc, "adc_vdc_noise_v_rms", lambda p: _finite(p["adc_vdc_noise_v_rms"]), "must be finite"),
    _when(_adc, "adc_vdc_noise_v_rms", lambda p: p["adc_vdc_noise_v_rms"] >= 0.0, "must be >= 0"),
    ("coulomb_nm", lambda p: _finite(p["coulomb_nm"]), "must be finite"),
    ("coulomb_nm", lambda p: p["coulomb_nm"] >= 0.0, "must be >= 0"),
    _when(lambda p: p["coulomb_nm"] > 0.0, "coulomb_band_rad_s", lambda p: _finite(p["coulomb_band_rad_s"]),
          "must be finite"),
    _when(lambda p: p["coulomb_nm"] > 0.0, "coulomb_band_rad_s", lambda p: p["coulomb_band_rad_s"] > 0.0,
          "must be > 0"),
    _when(lambda p: p["coulomb_nm"] > 0.0, "coulomb_band_rad_s", _coulomb_ok,
          "too small for the RK4 step (raise it or substeps)"),
    ("load_profile", lambda p: _load_code(p) in (0, 1, 2, 3), "must be none, step, ramp or table"),
    _when(_kind_is(1, 2), "load_t0_s", lambda p: _finite(p["load_t0_s"]), "must be finite"),
    _when(_kind_is(1, 2), "load_torque0_nm", lambda p: _finite(p["load_torque0_nm"]), "must be finite"),
    _when(_kind_is(1, 2), "load_torque1_nm", lambda p: _finite(p["load_torque1_nm"]), "must be finite"),
    _when(_kind_is(2), "load_t1_s", lambda p: _finite(p["load_t1_s"]), "must be finite"),
    _when(_kind_is(2), "load_t1_s", lambda p: p["load_t1_s"] > p["load_t0_s"], "must be > load_t0_s for a ramp"),
    # Python only (C has one count): both lists must have the same length
    _when(_kind_is(3), "load_table_nm", lambda p: len(p["load_table_nm"]) == len(p["load_table_t_s"]),
          "must have as many points as load_table_t_s"),
    _when(_kind_is(3), "load_table_t_s", lambda p: 1 <= len(p["load_table_t_s"]) <= LOAD_TABLE_MAX,
          f"must have 1 to {LOAD_TABLE_MAX} points"),
    # per point, as C: reported by _table_first_bad (see check_params)
    _flag("dyno"),
    _when(lambda p: bool(p["dyno"]), "dyno_speed_rad_s", lambda p: _finite(p["dyno_speed_rad_s"]), "must be finite"),
    _when(lambda p: bool(p["dyno"]), "dyno_accel_rad_s2", lambda p: _finite(p["dyno_accel_rad_s2"]), "must be finite"),
    _when(lambda p: bool(p["dyno"]), "dyno_accel_rad_s2", lambda p: p["dyno_accel_rad_s2"] >= 0.0, "must be >= 0"),
]
_TABLE_RULES_AFTER = "load_table_t_s"  # the per-point table rules run right after this rule name


STEP_LIMIT_REASON = "too small for the RK4 step (raise it or substeps)"


def check_params(params: Mapping[str, Any], *, step_limits: bool = True) -> tuple[str, str] | None:
    """First violated rule as (field, reason), or None. Same rules/order as plant_params_check.

    ``params`` holds the 11 base fields and, optionally, the non-ideality fields (missing ones
    take their "off" defaults, as a zero-initialised plant_params_t). step_limits=False skips
    the integrator's stability limits (they depend on V_dc and substeps, not on physics).
    """
    for name, ok, reason in _RULES:
        if not ok(params):
            return name, reason
    p = {**NONIDEAL_DEFAULTS, **params}
    for name, ok, reason in _NONIDEAL_RULES:
        if not step_limits and reason == STEP_LIMIT_REASON:
            continue
        if not ok(p):
            return name, reason
        if name == _TABLE_RULES_AFTER and _load_code(p) == 3:
            bad = _table_first_bad(p)
            if bad is not None:
                field_, _, why = bad.partition(": ")
                return field_, why
    return None


#: keys added after profiles were first attached to recordings (the switching inverter): a
#: profile without them (a recording made before, replayed) reads them as what the plant did then
#: (the averaged inverter; the switching-only keys at their bundled values). Every bundled profile
#: states them.
LATER_KEYS: dict[str, str] = {"inverter": "averaged", "carrier_at_start": "valley",
                              "pwm_load": "extremum", "dual_sample_at": "delay"}


#: "Off" values of the non-ideality fields = a zero-initialised plant_params_t.
NONIDEAL_DEFAULTS: dict[str, Any] = {
    k: (False if kind == BOOL else "none" if kind == LOAD_KIND else () if kind == FLOAT_LIST
        else CHOICES[k][0] if kind == CHOICE else 0 if kind is int else 0.0)
    for k, (_, kind, _) in NONIDEAL_FIELDS.items()
}


def switches_on(params: Mapping[str, Any]) -> dict[str, Any]:
    """params with every non-ideality switch on (to check values "as if on")."""
    return {**params, **{k: True for k in SWITCHES}}


def c_struct(params: Mapping[str, Any]) -> dict[str, Any]:
    """The flat parameters as the nested initialiser of a C ``plant_params_t`` (cffi)."""
    p = {**NONIDEAL_DEFAULTS, **params}
    out: dict[str, Any] = {k: p[k] for k in BASE_FIELDS}
    groups: dict[str, dict[str, Any]] = {}
    for key, (_, kind, group) in NONIDEAL_FIELDS.items():
        value = p[key]
        if kind == BOOL:
            value = int(value) if value in (0, 1) else value  # keep bad values bad (checked in C)
        elif kind == LOAD_KIND:
            value = _load_code(p)
            value = value if isinstance(value, int) else -1
        elif kind == FLOAT_LIST:
            value = [float(x) for x in list(value)[:LOAD_TABLE_MAX]]
        elif kind == CHOICE:
            value = _choice_code(p, key)
        if group is None:
            out[key] = value
        else:
            groups.setdefault(group, {})[key] = value
    mech = groups["mechanics"]
    n_t, n_v = len(p["load_table_t_s"]), len(p["load_table_nm"])
    mech["load_table_n"] = n_t if n_t != n_v else n_t
    if n_t != n_v:
        mech["load_table_n"] = min(n_t, n_v)
    out.update(groups)
    return out


def c_check_params(params: Mapping[str, Any]) -> str | None:
    """``plant_params_check`` of the compiled C plant ("field: reason" or None).

    Raises ImportError if the C module is not built.
    """
    from ._plant_c import ffi, lib  # noqa: PLC0415 (optional dependency)

    cp = ffi.new("plant_params_t *", c_struct(params))
    msg = lib.plant_params_check(cp)
    return None if msg == ffi.NULL else ffi.string(msg).decode()


def _c_check_or_none(params: Mapping[str, Any]) -> str | None:
    try:
        return c_check_params(params)
    except ImportError:
        return None  # not built yet: the Python rules above are the same


def display_path(path: Path | str) -> str:
    """Path as shown in messages: relative to the repository root when inside it."""
    p = Path(path)
    try:
        return str(p.resolve().relative_to(_REPO_ROOT))
    except ValueError:
        return str(p)


def validate_params(params: Mapping[str, Any], where: str, qualify: Callable[[str], str]) -> None:
    """Raise ProfileError "<where>: <qualified field>: <reason>, got <value>" if non-physical.

    Applies the Python rules, then the C ``plant_params_check`` (if built); they must agree.
    Then the values of the effects that are off are checked as if their switches were on, so a
    physically impossible value is reported even while its effect is off (not the integrator's
    step limits, which depend on V_dc and substeps and matter only when the effect runs).
    """
    bad = check_params(params)
    if bad is not None:
        name, reason = bad
        raise ProfileError(f"{where}: {qualify(name)}: {reason}, got {params[name]!r}")
    c_msg = _c_check_or_none(params)
    if c_msg is not None:  # the rules diverged: report the C verdict anyway
        name, _, reason = c_msg.partition(": ")
        raise ProfileError(f"{where}: {qualify(name)}: {reason}, got {params.get(name)!r} "
                           "(plant_params_check)")
    if any(k in params for k in NONIDEAL_FIELDS):
        on = switches_on(params)
        bad = check_params(on, step_limits=False)
        if bad is not None:
            name, reason = bad
            raise ProfileError(f"{where}: {qualify(name)}: {reason}, got {on[name]!r}")


# ---------------------------------------------------------------------------------------------
# loading

def resolve_profile_path(name_or_path: str | Path) -> Path:
    """A bare name ("gong2020") -> plant_rt/profiles/gong2020.toml; anything else is a path."""
    s = str(name_or_path)
    if isinstance(name_or_path, Path) or "/" in s or "\\" in s or s.endswith(".toml"):
        return Path(name_or_path)
    return PROFILE_DIR / f"{s}.toml"


def available_profiles() -> list[str]:
    """Names of the profiles shipped in plant_rt/profiles/."""
    return sorted(p.stem for p in PROFILE_DIR.glob("*.toml"))


def unknown_key_error(where: str, dotted: str, key: str, allowed: list[str] | tuple[str, ...]) -> ProfileError:
    """ProfileError for an unknown key, with the closest known key as a hint."""
    close = difflib.get_close_matches(key, allowed, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else f" (expected one of: {', '.join(allowed)})"
    return ProfileError(f"{where}: {dotted}: unknown key{hint}")


def coerce_value(where: str, dotted: str, value: Any, kind: Any) -> Any:
    """A parameter value of any kind (see PARAM_FIELDS) in its canonical Python form:
    float, int, bool (BOOL: true/false or 0/1), load-profile name (LOAD_KIND: name or 0..3),
    tuple of floats (FLOAT_LIST)."""
    if kind == BOOL:
        if isinstance(value, bool):
            return value
        if isinstance(value, (int, float)) and value in (0, 1):
            return bool(value)
        raise ProfileError(f"{where}: {dotted}: must be a boolean (true/false or 0/1), got {value!r}")
    if kind == LOAD_KIND:
        if isinstance(value, str) and value in LOAD_KINDS:
            return value
        if (isinstance(value, (int, float)) and not isinstance(value, bool)
                and float(value).is_integer() and 0 <= value <= 3):
            return LOAD_KINDS[int(value)]
        raise ProfileError(f"{where}: {dotted}: must be one of {', '.join(LOAD_KINDS)} (or 0..3), "
                           f"got {value!r}")
    if kind == CHOICE:
        names = CHOICES[dotted.rpartition(".")[2]]
        if isinstance(value, str) and value in names:
            return value
        if (isinstance(value, (int, float)) and not isinstance(value, bool)
                and float(value).is_integer() and 0 <= value < len(names)):
            return names[int(value)]
        raise ProfileError(f"{where}: {dotted}: must be one of {', '.join(names)} "
                           f"(or 0..{len(names) - 1}), got {value!r}")
    if kind == FLOAT_LIST:
        if not isinstance(value, (list, tuple)):
            raise ProfileError(f"{where}: {dotted}: must be a list of numbers, got {value!r}")
        return tuple(coerce_number(where, f"{dotted}[{k}]", x, float) for k, x in enumerate(value))
    if (kind is int and isinstance(value, float) and value.is_integer()
            and dotted.rpartition(".")[2] in NONIDEAL_FIELDS):
        return int(value)  # the new integer keys also take 12.0 (a bench [plant] table is floats)
    return coerce_number(where, dotted, value, kind)


def coerce_number(where: str, dotted: str, value: Any, kind: type) -> float | int:
    """value as int (kind int: bool/float rejected) or float (kind float: int accepted)."""
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ProfileError(f"{where}: {dotted}: must be an integer, got {value!r} "
                               f"({type(value).__name__})")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ProfileError(f"{where}: {dotted}: must be a number, got {value!r} "
                           f"({type(value).__name__})")
    return float(value)


def _table(doc: Mapping[str, Any], where: str, section: str) -> Mapping[str, Any]:
    if section not in doc:
        raise ProfileError(f"{where}: {section}: missing section [{section}]")
    tab = doc[section]
    if not isinstance(tab, dict):
        raise ProfileError(f"{where}: {section}: must be a table, got {tab!r}")
    return tab


def _string(where: str, dotted: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ProfileError(f"{where}: {dotted}: must be a non-empty string, got {value!r}")
    return value


def parse_profile(doc: Mapping[str, Any], path: Path) -> MotorProfile:
    """Validate a parsed TOML document; ``path`` is used in messages and kept in the profile."""
    where = display_path(path)
    for section in doc:
        if section not in SECTIONS:
            raise unknown_key_error(where, section, section, SECTIONS)

    # [profile]
    prof = _table(doc, where, "profile")
    for key in prof:
        if key not in PROFILE_KEYS:
            raise unknown_key_error(where, f"profile.{key}", key, PROFILE_KEYS)
    for key in PROFILE_KEYS:
        if key not in prof:
            raise ProfileError(f"{where}: profile.{key}: missing")
    name = _string(where, "profile.name", prof["name"])
    kind = _string(where, "profile.kind", prof["kind"])
    if kind not in KINDS:
        raise ProfileError(f"{where}: profile.kind: must be one of {KINDS}, got {kind!r}")
    source = _string(where, "profile.source", prof["source"])
    assumptions = prof["assumptions"]
    if not isinstance(assumptions, list) or not all(isinstance(a, str) for a in assumptions):
        raise ProfileError(f"{where}: profile.assumptions: must be a list of strings, got {assumptions!r}")

    # plant parameters, section by section
    params: dict[str, Any] = {}
    sections: dict[str, list[str]] = {}
    for pname, (section, _) in PARAM_FIELDS.items():
        sections.setdefault(section, []).append(pname)
    for section, names in sections.items():
        tab = _table(doc, where, section)
        for key in tab:
            if key not in names:
                raise unknown_key_error(where, f"{section}.{key}", key, names)
        for pname in names:
            if pname not in tab and pname in LATER_KEYS:
                params[pname] = LATER_KEYS[pname]   # a profile written before the key existed
                continue
            if pname not in tab:
                raise ProfileError(f"{where}: {section}.{pname}: missing")
            params[pname] = coerce_value(where, f"{section}.{pname}", tab[pname], PARAM_FIELDS[pname][1])

    def qualify(pname: str) -> str:
        return f"{PARAM_FIELDS[pname][0]}.{pname}" if pname in PARAM_FIELDS else pname

    validate_params(params, where, qualify)
    if kind == "SPMSM" and not math.isclose(params["ld_h"], params["lq_h"], rel_tol=1e-12):
        raise ProfileError(f"{where}: motor.lq_h: an SPMSM has lq_h == ld_h, got "
                           f"{params['lq_h']!r} != {params['ld_h']!r}")
    if kind == "IPMSM" and not params["lq_h"] > params["ld_h"]:
        raise ProfileError(f"{where}: motor.lq_h: an IPMSM has lq_h > ld_h, got "
                           f"{params['lq_h']!r} <= {params['ld_h']!r}")

    # [rated]
    rated_tab = _table(doc, where, "rated")
    rated: dict[str, float] = {}
    for key in rated_tab:
        if key not in RATED_REQUIRED + RATED_OPTIONAL:
            raise unknown_key_error(where, f"rated.{key}", key, RATED_REQUIRED + RATED_OPTIONAL)
    for key in RATED_REQUIRED:
        if key not in rated_tab:
            raise ProfileError(f"{where}: rated.{key}: missing")
    for key, value in rated_tab.items():
        v = coerce_number(where, f"rated.{key}", value, float)
        if not (math.isfinite(v) and v > 0.0):
            raise ProfileError(f"{where}: rated.{key}: must be finite and > 0, got {value!r}")
        rated[key] = v

    # [cite]: one entry per value (or a "<section>.*" entry for the rest of a section)
    cite_tab = _table(doc, where, "cite")
    valued = [f"{PARAM_FIELDS[p][0]}.{p}" for p in PARAM_FIELDS] + [f"rated.{k}" for k in rated]
    wildcards = sorted({f"{PARAM_FIELDS[p][0]}.*" for p in NONIDEAL_FIELDS})
    for key, value in cite_tab.items():
        if key not in valued and key not in wildcards:
            raise unknown_key_error(where, f"cite.{key}", key, valued + wildcards)
        _string(where, f"cite.{key}", value)
    for key in valued:
        if key not in cite_tab and f"{key.split('.')[0]}.*" not in cite_tab:
            raise ProfileError(f"{where}: cite.{key}: missing (every value needs a source or "
                               "'assumption: why')")

    base = {k: params[k] for k in BASE_FIELDS}
    nonideal = {k: params[k] for k in NONIDEAL_FIELDS}
    return MotorProfile(name=name, path=Path(path), kind=kind, source=source,
                        rated=rated, assumptions=list(assumptions), cite=dict(cite_tab),
                        raw=dict(doc), nonideal=nonideal, **base)  # type: ignore[arg-type]


def load_profile(name_or_path: str | Path) -> MotorProfile:
    """Load and validate a profile: a bare name resolves to plant_rt/profiles/<name>.toml."""
    path = resolve_profile_path(name_or_path)
    where = display_path(path)
    if not path.is_file():
        extra = f" (available: {', '.join(available_profiles())})" if path.resolve().parent == PROFILE_DIR else ""
        raise ProfileError(f"{where}: no such profile file{extra}")
    try:
        with path.open("rb") as fh:
            doc = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"{where}: TOML syntax error: {exc}") from exc
    except OSError as exc:
        raise ProfileError(f"{where}: cannot read: {exc.strerror}") from exc
    return parse_profile(doc, path)
