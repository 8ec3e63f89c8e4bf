"""Scenario files (TOML): what to run, on which motor, with which controller settings and events.

A scenario names a motor profile (``plant_rt/profiles``), the run length, the controller's estimator
and parameters (protocol ``param_id`` names, SI units), a timeline of events (speed reference,
load torque, current references), the reference estimators to run on the host beside the
controller, the metrics window, and the paper claims it reproduces.

Every problem is reported as :class:`ScenarioError` naming the file and the dotted field.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from protocol.messages import Estimator, Param

SCENARIO_DIR = Path(__file__).resolve().parent / "scenarios"
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


class ScenarioError(ValueError):
    """A scenario file is missing, malformed or asks for something impossible."""


@dataclass(frozen=True)
class Event:
    """One timeline entry. Exactly the fields that were given are set (others are None)."""

    t_s: float
    speed_ref_rad_s: float | None = None
    load_torque_nm: float | None = None
    iq_ref_a: float | None = None
    id_ref_a: float | None = None
    control_mode: str | None = None  # "speed" | "current"
    label: str = ""

    def describe(self) -> str:
        parts = []
        if self.speed_ref_rad_s is not None:
            parts.append(f"speed_ref={self.speed_ref_rad_s * RPM_PER_RAD_S:g} rpm")
        if self.load_torque_nm is not None:
            parts.append(f"load={self.load_torque_nm:g} N m")
        if self.iq_ref_a is not None:
            parts.append(f"iq_ref={self.iq_ref_a:g} A")
        if self.id_ref_a is not None:
            parts.append(f"id_ref={self.id_ref_a:g} A")
        if self.control_mode is not None:
            parts.append(f"mode={self.control_mode}")
        return ", ".join(parts) + (f" ({self.label})" if self.label else "")


@dataclass(frozen=True)
class Scenario:
    path: Path
    name: str
    description: str
    profile: str
    duration_s: float
    mode: str                      # "lockstep" (real-time mode comes with the real-time engine)
    estimator: Estimator
    speed_ref_rad_s: float
    controller_params: dict[Param, float]   # explicit overrides, SI
    plant_overrides: dict[str, object]      # plant_rt override keys (plant_rt/README.md)
    initial_theta_e_rad: float
    initial_speed_rad_s: float
    initial_load_torque_nm: float
    events: tuple[Event, ...]
    reference_estimators: tuple[str, ...]
    reference_config: dict[str, dict[str, float]]   # estimator -> C config field -> value
    metrics_window_s: tuple[float, float]
    claims: tuple[str, ...]
    telemetry_emf: bool
    raw: dict[str, Any] = field(repr=False, default_factory=dict)
    text: str = field(repr=False, default="")

    @property
    def display_path(self) -> str:
        return _display(self.path)


def _display(path: Path) -> str:
    try:
        return str(path.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def resolve_path(name_or_path: str | Path) -> Path:
    """A bare name resolves to ``bench/scenarios/<name>.toml``."""
    p = Path(name_or_path)
    if p.suffix != ".toml" and not p.exists():
        p = SCENARIO_DIR / f"{name_or_path}.toml"
    return p


class _Fields:
    """Typed access to one TOML table that remembers the dotted path and rejects unknown keys."""

    def __init__(self, where: str, table: Any, prefix: str):
        if not isinstance(table, dict):
            raise ScenarioError(f"{where}: {prefix}: must be a table, got {type(table).__name__}")
        self.where = where
        self.table = table
        self.prefix = prefix
        self.used: set[str] = set()

    def _name(self, key: str) -> str:
        return f"{self.prefix}.{key}" if self.prefix else key

    def fail(self, key: str, why: str) -> ScenarioError:
        return ScenarioError(f"{self.where}: {self._name(key)}: {why}")

    def number(self, key: str, default: float | None = None, *, min_value: float | None = None,
               positive: bool = False) -> float:
        self.used.add(key)
        if key not in self.table:
            if default is None:
                raise self.fail(key, "missing (required)")
            return default
        v = self.table[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(key, f"must be a number, got {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise self.fail(key, f"must be finite, got {v!r}")
        if positive and not v > 0:
            raise self.fail(key, f"must be > 0, got {v!r}")
        if min_value is not None and v < min_value:
            raise self.fail(key, f"must be >= {min_value:g}, got {v!r}")
        return v

    def string(self, key: str, default: str | None = None) -> str:
        self.used.add(key)
        if key not in self.table:
            if default is None:
                raise self.fail(key, "missing (required)")
            return default
        v = self.table[key]
        if not isinstance(v, str):
            raise self.fail(key, f"must be a string, got {v!r}")
        return v

    def boolean(self, key: str, default: bool) -> bool:
        self.used.add(key)
        v = self.table.get(key, default)
        if not isinstance(v, bool):
            raise self.fail(key, f"must be true or false, got {v!r}")
        return v

    def strings(self, key: str) -> tuple[str, ...]:
        self.used.add(key)
        v = self.table.get(key, [])
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise self.fail(key, f"must be a list of strings, got {v!r}")
        return tuple(v)

    def table_of(self, key: str) -> "_Fields":
        self.used.add(key)
        return _Fields(self.where, self.table.get(key, {}), self._name(key))

    def reject_unknown(self, allowed_extra: set[str] = frozenset()) -> None:
        unknown = set(self.table) - self.used - set(allowed_extra)
        if unknown:
            key = sorted(unknown)[0]
            raise self.fail(key, "unknown key (typo?)")


def _plant_value(fields: _Fields, key: str):
    """A plant override: a number, a switch (true/false), a name (load_profile) or a list of
    numbers (load tables); the plant validates the value itself (ProfileError names the key)."""
    fields.used.add(key)
    v = fields.table[key]
    if isinstance(v, bool):
        return int(v)
    if isinstance(v, (int, float)):
        return fields.number(key)
    if isinstance(v, str):
        return v
    if isinstance(v, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                   for x in v):
        return [float(x) for x in v]
    raise fields.fail(key, f"must be a number, true/false, a name or a list of numbers, got {v!r}")


def _estimator(fields: _Fields, key: str) -> Estimator:
    name = fields.string(key, "SMO_SIGN").upper()
    try:
        return Estimator[name]
    except KeyError:
        raise fields.fail(key, f"unknown estimator {name!r}; known: "
                               f"{', '.join(e.name for e in Estimator)}") from None


def _controller_params(fields: _Fields) -> dict[Param, float]:
    out: dict[Param, float] = {}
    for key in list(fields.table):
        try:
            param = Param[key.upper()]
        except KeyError:
            raise fields.fail(key, f"unknown controller parameter; known: "
                                   f"{', '.join(p.name for p in Param)}") from None
        out[param] = fields.number(key)
    return out


def _events(where: str, items: Any, duration_s: float) -> tuple[Event, ...]:
    if not isinstance(items, list):
        raise ScenarioError(f"{where}: events: must be an array of tables ([[events]])")
    events = []
    for i, item in enumerate(items):
        f = _Fields(where, item, f"events[{i}]")
        t_s = f.number("t_s", min_value=0.0)
        if t_s > duration_s:
            raise f.fail("t_s", f"{t_s:g} s is after the end of the run ({duration_s:g} s)")
        speed = f.number("speed_ref_rpm", math.nan) if "speed_ref_rpm" in item else None
        mode = f.string("control_mode") if "control_mode" in item else None
        if mode is not None and mode not in ("speed", "current"):
            raise f.fail("control_mode", f"must be 'speed' or 'current', got {mode!r}")
        ev = Event(
            t_s=t_s,
            speed_ref_rad_s=None if speed is None else speed / RPM_PER_RAD_S,
            load_torque_nm=f.number("load_torque_nm") if "load_torque_nm" in item else None,
            iq_ref_a=f.number("iq_ref_a") if "iq_ref_a" in item else None,
            id_ref_a=f.number("id_ref_a") if "id_ref_a" in item else None,
            control_mode=mode,
            label=f.string("label", ""),
        )
        f.reject_unknown()
        if ev.describe() == "" or ev.describe().startswith(" ("):
            raise ScenarioError(f"{where}: events[{i}]: does nothing (give speed_ref_rpm, "
                                f"load_torque_nm, iq_ref_a, id_ref_a or control_mode)")
        events.append(ev)
    return tuple(sorted(events, key=lambda e: e.t_s))


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load and validate a scenario; raises ScenarioError naming the file and field."""
    path = resolve_path(name_or_path)
    where = _display(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        known = ", ".join(sorted(p.stem for p in SCENARIO_DIR.glob("*.toml")))
        raise ScenarioError(f"{where}: no such scenario file (bundled scenarios: {known})") from None
    except OSError as exc:
        raise ScenarioError(f"{where}: cannot read: {exc.strerror}") from None
    return parse_scenario(text, path)


def parse_scenario(text: str, path: Path) -> Scenario:
    """Validate scenario TOML text; ``path`` names it in errors (and resolves nothing)."""
    where = _display(path)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{where}: not valid TOML: {exc}") from None

    top = _Fields(where, raw, "")
    s = top.table_of("scenario")
    name = s.string("name", path.stem)
    description = s.string("description", "")
    profile = s.string("profile")
    duration_s = s.number("duration_s", positive=True)
    mode = s.string("mode", "lockstep")
    if mode != "lockstep":
        raise s.fail("mode", f"only 'lockstep' is implemented, got {mode!r}")
    claims = s.strings("claims")
    s.reject_unknown()

    p = top.table_of("plant")
    initial_theta = p.number("initial_theta_e_rad", 0.0)
    initial_speed = p.number("initial_speed_rpm", 0.0) / RPM_PER_RAD_S
    initial_load = p.number("load_torque_nm", 0.0)
    plant_overrides = {k: _plant_value(p, k) for k in p.table
                       if k not in ("initial_theta_e_rad", "initial_speed_rpm", "load_torque_nm")}

    c = top.table_of("controller")
    estimator = _estimator(c, "estimator")
    speed_ref = c.number("speed_ref_rpm", 0.0) / RPM_PER_RAD_S
    telemetry_emf = c.boolean("telemetry_emf", True)
    params = _controller_params(c.table_of("params"))
    c.reject_unknown()

    r = top.table_of("reference")
    reference = r.strings("estimators")
    reference_config: dict[str, dict[str, float]] = {}
    for key in list(r.table):
        if key == "estimators":
            continue
        if key not in reference:
            raise r.fail(key, f"configuration for an estimator not listed in "
                              f"reference.estimators {list(reference)}")
        sub = r.table_of(key)
        reference_config[key] = {k: sub.number(k) for k in sub.table}
    r.reject_unknown()

    m = top.table_of("metrics")
    top.used.add("metrics")
    window = m.table.get("window_s", [duration_s * 0.5, duration_s])
    m.used.add("window_s")
    if (not isinstance(window, list) or len(window) != 2
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in window)):
        raise m.fail("window_s", f"must be [start_s, end_s], got {window!r}")
    w0, w1 = float(window[0]), float(window[1])
    if not 0.0 <= w0 < w1 <= duration_s:
        raise m.fail("window_s", f"must satisfy 0 <= start < end <= duration_s "
                                 f"({duration_s:g}), got [{w0:g}, {w1:g}]")
    m.reject_unknown()

    top.used.add("events")
    events = _events(where, raw.get("events", []), duration_s)
    top.reject_unknown()

    return Scenario(
        path=path, name=name, description=description, profile=profile, duration_s=duration_s,
        mode=mode, estimator=estimator, speed_ref_rad_s=speed_ref, controller_params=params,
        plant_overrides=plant_overrides, initial_theta_e_rad=initial_theta,
        initial_speed_rad_s=initial_speed, initial_load_torque_nm=initial_load, events=events,
        reference_estimators=reference, reference_config=reference_config,
        metrics_window_s=(w0, w1), claims=claims,
        telemetry_emf=telemetry_emf, raw=raw, text=text,
    )


def speed_ref_at(scn: Scenario, t_s: float) -> float:
    """The speed reference (rad/s mechanical) in force at time t_s."""
    ref = scn.speed_ref_rad_s
    for ev in scn.events:
        if ev.t_s <= t_s and ev.speed_ref_rad_s is not None:
            ref = ev.speed_ref_rad_s
    return ref


def derive_scenario(base: str | Path, name: str, overrides: tuple[tuple[str, Any], ...] | list,
                    note: str = "") -> Scenario:
    """A bundled (or any) scenario with dotted-key overrides (``plant.inverter_nonlinear``,
    ``controller.params.HFI_POL_BIAS_A``, ``metrics.window_s`` ...) and the scenario name
    ``name``. The derived TOML (what a recording attaches) starts with a comment naming the base
    and the overrides; errors name the base file and the field as for any scenario."""
    from . import tomlw

    path = resolve_path(base)
    base_scn = load_scenario(path)
    doc = base_scn.raw
    for key, value in overrides:
        doc = tomlw.set_dotted(doc, key, value)
    doc = tomlw.set_dotted(doc, "scenario.name", name)
    header = [f"# derived from {base_scn.display_path}" + (f": {note}" if note else "")]
    header += [f"#   {k} = {v!r}" for k, v in overrides]
    text = "\n".join(header) + "\n" + tomlw.dumps(doc)
    return parse_scenario(text, path.with_name(f"{name}.toml"))
