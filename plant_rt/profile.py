"""Motor profiles: TOML files in ``plant_rt/profiles/`` -> validated :class:`MotorProfile`.

File layout (every key is required unless marked optional; unknown keys are errors)::

    [profile]     name, kind ("SPMSM" | "IPMSM"), source (citation), assumptions (list of str)
    [motor]       rs_ohm [ohm], ld_h [H], lq_h [H], psi_f_wb [Wb, peak phase], pole_pairs [-]
    [mechanics]   j_kgm2 [kg m^2], b_nms [N m s/rad]
    [drive]       v_dc_v [V], ts_s [s] (PWM = control period), t_delay_s [s] (sampling -> new duties)
    [simulation]  substeps [-] (RK4 steps per period)
    [rated]       speed_rad_s [rad/s, mechanical], torque_nm [N m], current_a [A, peak phase];
                  optional: power_w, speed_rpm, bus_current_a, corner_speed_rad_s, voltage_constant_ce
    [cite]        "<section>.<key>" = "where the value comes from" for every value above
                  (a paper table, or "assumption: why")

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

#: plant_params_t fields in C order -> (section in the TOML file, python type)
PARAM_FIELDS: dict[str, tuple[str, type]] = {
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
MAX_SUBSTEPS = 100_000  # PLANT_MAX_SUBSTEPS in plant.h

RATED_REQUIRED = ("speed_rad_s", "torque_nm", "current_a")
RATED_OPTIONAL = ("power_w", "speed_rpm", "bus_current_a", "corner_speed_rad_s", "voltage_constant_ce")
PROFILE_KEYS = ("name", "kind", "source", "assumptions")
KINDS = ("SPMSM", "IPMSM")
SECTIONS = ("profile", "motor", "mechanics", "drive", "simulation", "rated", "cite")


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

    def plant_params(self) -> dict[str, float | int]:
        """The 11 ``plant_params_t`` fields (C order) as a dict."""
        return {name: getattr(self, name) for name in PARAM_FIELDS}


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


def check_params(params: Mapping[str, Any]) -> tuple[str, str] | None:
    """First violated rule as (field, reason), or None. Same rules/order as plant_params_check."""
    for name, ok, reason in _RULES:
        if not ok(params):
            return name, reason
    return None


def c_check_params(params: Mapping[str, Any]) -> str | None:
    """``plant_params_check`` of the compiled C plant ("field: reason" or None).

    Raises ImportError if the C module is not built.
    """
    from plant_rt._plant_c import ffi, lib  # noqa: PLC0415 (optional dependency)

    cp = ffi.new("plant_params_t *", {k: params[k] for k in PARAM_FIELDS})
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
    params: dict[str, float | int] = {}
    sections: dict[str, list[str]] = {}
    for pname, (section, _) in PARAM_FIELDS.items():
        sections.setdefault(section, []).append(pname)
    for section, names in sections.items():
        tab = _table(doc, where, section)
        for key in tab:
            if key not in names:
                raise unknown_key_error(where, f"{section}.{key}", key, names)
        for pname in names:
            if pname not in tab:
                raise ProfileError(f"{where}: {section}.{pname}: missing")
            params[pname] = coerce_number(where, f"{section}.{pname}", tab[pname], PARAM_FIELDS[pname][1])

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

    # [cite]: one entry per value, no more, no less
    cite_tab = _table(doc, where, "cite")
    valued = [f"{PARAM_FIELDS[p][0]}.{p}" for p in PARAM_FIELDS] + [f"rated.{k}" for k in rated]
    for key, value in cite_tab.items():
        if key not in valued:
            raise unknown_key_error(where, f"cite.{key}", key, valued)
        _string(where, f"cite.{key}", value)
    for key in valued:
        if key not in cite_tab:
            raise ProfileError(f"{where}: cite.{key}: missing (every value needs a source or "
                               "'assumption: why')")

    return MotorProfile(name=name, path=Path(path), kind=kind, source=source,
                        rated=rated, assumptions=list(assumptions), cite=dict(cite_tab),
                        raw=dict(doc), **params)  # type: ignore[arg-type]


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
