"""Scenario files (TOML): what to run, on which motor, with which controller settings and events.

A scenario names a motor profile (``plant_rt/profiles``), the run length, the controller's estimator
and parameters (protocol ``param_id`` names, SI units), a timeline of events (speed reference,
load torque, current references), the reference estimators to run on the host beside the
controller, the metrics window, and the paper claims it reproduces.

Every problem is reported as :class:`ScenarioError` naming the file, the line (where TOML has one), the
dotted field and the allowed range, when the scenario is loaded: before any process or device is touched.
Ranges come from physics (a run needs at least one control period) and from the wire: a value the
protocol cannot carry (a speed reference beyond what TELEM.omega_hat can report, a current beyond
SENSE.i_a, a parameter that is not a binary32 of its kind) is refused here, with the DBC signal it
comes from, instead of failing mid-run.

``parse_scenario`` checks what the text alone can say (``bench check`` re-parses the scenario attached
to a recording with it); ``load_scenario`` also checks the scenario against its motor profile (control
period, pole pairs, plant overrides: ``check_against_profile``).

``[controller.inverter_comp]`` switches the drive's inverter-error feed-forward on
(firmware_stub/src/inv_comp.h, docs/inverter_comp.md) with the drive's estimate of the plant's
inverter set by a residual: ``residual`` = the fraction of the plant's dead time and device drops
the estimate leaves (estimate = (1 - residual) x the plant's values; 0 exact, 0.03 = 3 % under,
negative = over-compensation); ``current = "vector" (default: the current-vector method) | "predicted" | "sampled" |
"reference"``, ``shape = "capacitive" |
"linear"``, ``band_a`` (default: the plant's i_cap_band_a), ``current_bw_rad_s`` (the
current-vector filter of ``current = "vector"``). The runner turns it into the CONFIG
parameters INV_COMP_* and writes truth, estimate and residual into the recording's metadata.

Keys for the protocol-1.0 link behaviour (docs/protocol.md 6.4, 6.5, 6.8, 6.9), read by the host's cycle
engine: ``[scenario] mode = "lockstep" | "realtime"``; ``[realtime] duty_update = "on_arrival" |
"next_period"``, ``max_consecutive_misses`` (10), ``cpu``; ``[link] retry_timeout_s`` (the first re-send
of an unanswered lockstep cycle, 0.05: ``hil_bench.protocol.timing``), ``patience_s`` (10: the controller
has answered nothing this long, the run ends), ``allow = {counter = n, ...}``; ``[controller]
send_encoder_angle`` (false).
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hil_bench.errors import did_you_mean
from hil_bench.protocol import params as param_info
from hil_bench.protocol.messages import MESSAGES, Estimator, HelloFlag, Param
from hil_bench.protocol.timing import LOCKSTEP_ANSWER_S, PATIENCE_S

from .faults import PLANT_KINDS, check_faults_can_act, parse_faults, parse_recording
from .fields import Fields, ScenarioError, line_of

SCENARIO_DIR = Path(__file__).resolve().parents[1] / "scenarios"
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)
#: the longest run a scenario may ask for (a recording of 10 kHz cycles grows by ~tens of MB per second)
MAX_DURATION_S = 3600.0
#: a scenario name becomes a file name in the recordings folder: no path separators, no leading dot
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.@-]{0,99}\Z")
#: a bundled profile's name (plant_rt/profiles/<name>.toml); anything else must be a .toml path
PROFILE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,99}\Z")
FLOAT32_MAX = 3.4028234663852886e38
DUTY_UPDATES = ("on_arrival", "next_period")
MODES = ("lockstep", "realtime")


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

    def actions(self) -> list[tuple[str, float]]:
        """What the event does, in the order the engine applies it: ("speed_ref", rad/s),
        ("iq_ref", A), ("id_ref", A), ("control_mode", 0 speed / 1 current) -- each a CMD to the
        controller -- and ("load", N m), the plant's load torque. One engine event each."""
        out: list[tuple[str, float]] = []
        if self.speed_ref_rad_s is not None:
            out.append(("speed_ref", self.speed_ref_rad_s))
        if self.iq_ref_a is not None:
            out.append(("iq_ref", self.iq_ref_a))
        if self.id_ref_a is not None:
            out.append(("id_ref", self.id_ref_a))
        if self.control_mode is not None:
            out.append(("control_mode", 1.0 if self.control_mode == "current" else 0.0))
        if self.load_torque_nm is not None:
            out.append(("load", self.load_torque_nm))
        return out

    @property
    def sends_cmd(self) -> bool:
        """The event sends at least one CMD frame (with the frames of its cycle)."""
        return any(name != "load" for name, _ in self.actions())

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
class RealtimeSettings:
    """``[realtime]``: how the real-time engine paces and applies duties (docs/protocol.md 6.4,
    plant_rt/c/engine.h). Used when ``[scenario] mode = "realtime"`` or ``bench run --realtime``."""

    duty_update: str = "on_arrival"         # "on_arrival" (ePWM immediate) | "next_period" (shadow)
    max_consecutive_misses: int = 10        # then all legs OFF, FAULT_PLANT, and the run ends
    cpu: int | None = None                  # the engine's CPU (None: the last allowed; realtime_cpus)
    priority: int = 80                      # SCHED_FIFO priority asked for (0: do not ask)
    mlock: bool = True                      # mlockall when allowed
    spin_us: float = 30.0                   # spin this long before each deadline
    guard_us: float = 10.0                  # on_arrival: DUTY due by the period end - guard
    busy_wait: bool = False                 # engine (and stub) poll without sleeping while a
                                            # frame is due: no wake-up latency, a CPU each
    # the C stub as the controller (--link stub...): what fires its ISR, its priority and CPU
    stub_isr: str = "sense"                 # "sense" (on SENSE arrival) | "timer" (free-running)
    stub_phase_us: float | None = None      # timer: first tick this long after the first SENSE
    stub_priority: int = 70                 # SCHED_FIFO priority asked for the stub (0: none)
    stub_cpu: int | None = None             # None: the first allowed CPU that is not the engine's


@dataclass(frozen=True)
class LinkSettings:
    """``[link]``: the lockstep wait (docs/protocol.md 6.5) and integrity allowances (6.9)."""

    retry_timeout_s: float = LOCKSTEP_ANSWER_S   # first re-send of an unanswered cycle after this long
    patience_s: float = PATIENCE_S               # nothing answered this long: the run ends
    allow: dict[str, int] = field(default_factory=dict)   # link counter -> allowed count


#: [controller.inverter_comp] current = ... -> INV_COMP_ENABLE value
INV_COMP_CURRENTS = {"predicted": 1, "sampled": 2, "reference": 3, "vector": 4}
#: [controller.inverter_comp] shape = ... -> INV_COMP_SHAPE value
INV_COMP_SHAPES = {"linear": 0, "capacitive": 1}


@dataclass(frozen=True)
class InverterComp:
    """``[controller.inverter_comp]``: the drive's inverter-error feed-forward, its estimate of
    the plant's inverter given as a residual (docs/inverter_comp.md)."""

    residual: float                 # estimate = (1 - residual) x the plant's dead time and drops
    current: str = "vector"         # INV_COMP_CURRENTS
    shape: str = "capacitive"       # INV_COMP_SHAPES
    band_a: float | None = None     # zero-crossing current; None: the plant's i_cap_band_a
    current_bw_rad_s: float | None = None   # current = "vector": the filter (None: the drive's)


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
    send_encoder_angle: bool = False        # [controller]: send theta_enc also to a sensorless estimator
    realtime: RealtimeSettings = field(default_factory=RealtimeSettings)
    link: LinkSettings = field(default_factory=LinkSettings)
    faults: tuple = ()                      # hil_bench.scenario.faults.FaultSpec, [[faults]] (docs/faults.md)
    recording: Any = None                   # hil_bench.scenario.faults.RecordingSettings ([recording])
    post_trip_s: float = 0.0                # a FAULT_CTRL ends the run this long after it
    inverter_comp: InverterComp | None = None   # [controller.inverter_comp]
    live_inputs: bool = False               # [live] inputs: a viewer may publish operator inputs
                                            # (bench run --live; docs/foxglove.md)

    @property
    def display_path(self) -> str:
        return _display(self.path)

    @property
    def encoder_angle_sent(self) -> bool:
        """The plant's angle goes to the controller (SENSE_AUX.theta_enc, HELLO flag ENCODER_VALID, SENSE_AUX
        flag THETA_ENC_VALID) only for the ENCODER estimator or when the scenario asks (section 6.8)."""
        return self.estimator is Estimator.ENCODER or self.send_encoder_angle

    def hello_flags(self, dual_sampling: bool) -> int:
        """HELLO.flags of this scenario (``dual_sampling``: the plant's setting, from the profile)."""
        flags = HelloFlag(0)
        if dual_sampling:
            flags |= HelloFlag.DUAL_SAMPLING
        if self.telemetry_emf:
            flags |= HelloFlag.TELEM_EMF
        if self.encoder_angle_sent:
            flags |= HelloFlag.ENCODER_VALID
        return int(flags)


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


def _plant_value(fields: Fields, key: str):
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


def _estimator(fields: Fields, key: str) -> Estimator:
    name = fields.string(key, "SMO_SIGN").upper()
    try:
        return Estimator[name]
    except KeyError:
        names = [e.name for e in Estimator]
        raise fields.fail(key, f"unknown estimator {name!r}{did_you_mean(name, names)} (known: "
                               f"{', '.join(names)})") from None


def _inverter_comp(c: Fields, params: dict[Param, float]) -> InverterComp | None:
    """[controller.inverter_comp], or None if absent. Refused beside explicit INV_COMP_* CONFIG
    parameters: one scenario, one statement of the drive's estimate."""
    if "inverter_comp" not in c.table:
        return None
    t = c.table_of("inverter_comp")
    given = sorted(p.name for p in params if p.name.startswith("INV_COMP_"))
    if given:
        raise t.fail("residual", f"the drive's estimate is given twice: here and as "
                                 f"controller.params {', '.join(given)}; keep one")
    residual = t.number("residual")
    t.within("residual", residual, -1.0, 1.0, "",
             "the fraction of the plant's dead time and drops the drive's estimate leaves "
             "(-1 .. 1: 0 exact, 1 no compensation, < 0 over-compensation)")
    current = t.string("current", "vector")
    if current not in INV_COMP_CURRENTS:
        raise t.fail("current", f"must be one of {', '.join(INV_COMP_CURRENTS)}, got {current!r}")
    shape = t.string("shape", "capacitive")
    if shape not in INV_COMP_SHAPES:
        raise t.fail("shape", f"must be one of {', '.join(INV_COMP_SHAPES)}, got {shape!r}")
    band = t.number("band_a", min_value=1e-6) if "band_a" in t.table else None
    bw = None
    if "current_bw_rad_s" in t.table:
        if current != "vector":
            raise t.fail("current_bw_rad_s", 'filters the current vector: only with current = "vector"')
        bw = t.number("current_bw_rad_s", min_value=1.0)
    t.reject_unknown()
    return InverterComp(residual, current, shape, band, bw)


def _controller_params(fields: Fields) -> dict[Param, float]:
    out: dict[Param, float] = {}
    for key in list(fields.table):
        try:
            param = Param[key.upper()]
        except KeyError:
            names = [p.name for p in Param]
            raise fields.fail(key, f"unknown controller parameter"
                                   f"{did_you_mean(key.upper(), names)} (known: "
                                   f"{', '.join(names)})") from None
        value = fields.number(key)
        problem = param_info.BY_NAME[param.name].check(value)
        if problem:   # docs/protocol.md 6.2: how integer, boolean and enum parameters travel
            raise fields.fail(key, f"{problem} (CONFIG.value, docs/protocol.md 6.2)")
        out[param] = value
    return out


def _bundled_profiles() -> str:
    from hil_bench.plant_rt.profile import available_profiles

    return ", ".join(available_profiles())


def _wire_range(message: str, signal: str) -> tuple[float, float]:
    s = MESSAGES[message].signal(signal)
    return float(s.minimum), float(s.maximum)


#: current references travel as CMD.value but are measured back through SENSE.i_a..i_c
CURRENT_RANGE_A = _wire_range("SENSE", "i_a")


def _float32(f: Fields, key: str, v: float, what: str) -> float:
    if abs(v) > FLOAT32_MAX:
        raise f.fail(key, f"{v:g} does not fit the binary32 {what} ([-3.4e38, 3.4e38], docs/protocol.md 3)")
    return v


def _current(f: Fields, key: str) -> float:
    v = f.number(key)
    lo, hi = CURRENT_RANGE_A
    return f.within(key, v, lo, hi, "A", "the range SENSE.i_a..i_c can report, protocol/hil.dbc")


def _speed_rpm(f: Fields, key: str, default: float | None = None) -> float:
    v = f.number(key, default)
    if abs(v / RPM_PER_RAD_S) > FLOAT32_MAX:
        raise f.fail(key, f"{v:g} rpm ({v / RPM_PER_RAD_S:.4g} rad/s) does not fit the binary32 CMD.value "
                          f"([-3.4e38, 3.4e38] rad/s, docs/protocol.md 3)")
    return v


def _events(where: str, items: Any, duration_s: float, text: str = "") -> tuple[Event, ...]:
    if not isinstance(items, list):
        raise ScenarioError(f"{where}: events: must be an array of tables ([[events]])")
    events = []
    for i, item in enumerate(items):
        f = Fields(where, item, f"events[{i}]", text)
        t_s = f.number("t_s", min_value=0.0)
        if t_s > duration_s:
            raise f.fail("t_s", f"{t_s:g} s is after the end of the run ({duration_s:g} s)")
        speed = _speed_rpm(f, "speed_ref_rpm") if "speed_ref_rpm" in item else None
        mode = f.string("control_mode") if "control_mode" in item else None
        if mode is not None and mode not in ("speed", "current"):
            raise f.fail("control_mode", f"must be 'speed' or 'current', got {mode!r}")
        ev = Event(
            t_s=t_s,
            speed_ref_rad_s=None if speed is None else speed / RPM_PER_RAD_S,
            load_torque_nm=f.number("load_torque_nm") if "load_torque_nm" in item else None,
            iq_ref_a=_current(f, "iq_ref_a") if "iq_ref_a" in item else None,
            id_ref_a=_current(f, "id_ref_a") if "id_ref_a" in item else None,
            control_mode=mode,
            label=f.string("label", ""),
        )
        f.reject_unknown()
        if ev.describe() == "" or ev.describe().startswith(" ("):
            raise ScenarioError(f"{f._at(None)}: events[{i}]: does nothing (give speed_ref_rpm, "
                                f"load_torque_nm, iq_ref_a, id_ref_a or control_mode)")
        events.append(ev)
    return tuple(sorted(events, key=lambda e: e.t_s))


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load and validate a scenario, also against its motor profile; raises ScenarioError naming the
    file, line and field."""
    path = resolve_path(name_or_path)
    where = _display(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        names = sorted(p.stem for p in SCENARIO_DIR.glob("*.toml"))
        given = Path(name_or_path)
        if given.suffix != ".toml" and len(given.parts) == 1:   # a bare name
            raise ScenarioError(f"{name_or_path}: no bundled scenario of that name and no such "
                                f"file{did_you_mean(str(name_or_path), names)} (bundled: "
                                f"{', '.join(names)}; `bench scenarios` lists them)") from None
        raise ScenarioError(f"{where}: no such scenario file{did_you_mean(given.stem, names)} "
                            f"(bundled scenarios: {', '.join(names)})") from None
    except OSError as exc:
        raise ScenarioError(f"{where}: cannot read: {exc.strerror}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise ScenarioError(f"{where}:{line}: not a scenario file: octet 0x{data[exc.start]:02X} at offset "
                            f"{exc.start} is not UTF-8 text (a scenario is a TOML text file)") from None
    scn = parse_scenario(text, path)
    check_against_profile(scn)
    return scn


def _realtime(top: Fields, mode: str) -> RealtimeSettings:
    """The [realtime] table; a lockstep scenario may carry one for `bench run --realtime`."""
    d = RealtimeSettings()
    r = top.table_of("realtime")
    duty_update = r.string("duty_update", d.duty_update)
    if duty_update not in DUTY_UPDATES:
        raise r.fail("duty_update", f"must be one of {', '.join(DUTY_UPDATES)}, got {duty_update!r}")
    misses = r.integer("max_consecutive_misses", d.max_consecutive_misses, 1, 1_000_000)
    cpu = r.integer("cpu", -1, 0, 4095) if "cpu" in r.table else None
    priority = r.integer("priority", d.priority, 0, 99)
    mlock = r.boolean("mlock", d.mlock)
    spin_us = r.number("spin_us", d.spin_us, min_value=0.0)
    guard_us = r.number("guard_us", d.guard_us, min_value=0.0)
    busy_wait = r.boolean("busy_wait", d.busy_wait)
    stub_isr = r.string("stub_isr", d.stub_isr)
    if stub_isr not in ("sense", "timer"):
        raise r.fail("stub_isr", f"must be 'sense' or 'timer', got {stub_isr!r}")
    stub_phase_us = r.number("stub_phase_us", min_value=0.0) if "stub_phase_us" in r.table else None
    stub_priority = r.integer("stub_priority", d.stub_priority, 0, 99)
    stub_cpu = r.integer("stub_cpu", -1, 0, 4095) if "stub_cpu" in r.table else None
    r.reject_unknown()
    return RealtimeSettings(duty_update, misses, cpu, priority, mlock, spin_us, guard_us, busy_wait,
                            stub_isr, stub_phase_us, stub_priority, stub_cpu)


def parse_link_allow(a: Fields) -> dict[str, int]:
    """``allow = {counter = n, ...}`` of a scenario's ``[link]`` or a campaign run: the link problems
    (docs/protocol.md 6.9) a run may show, each up to n."""
    from hil_bench.record.integrity import ALLOWABLE_COUNTERS, LINK_COUNTERS, TIMING_COUNTERS

    allow = {}
    for counter in list(a.table):
        if counter in TIMING_COUNTERS:
            raise a.fail(counter, f"is not a link problem (late is not lost: a re-sent cycle whose "
                                  f"answers all came is timing, docs/protocol.md 6.5), so there is "
                                  f"nothing to allow; allow lost_frames for frames that never "
                                  f"arrived")
        if counter not in LINK_COUNTERS:
            raise a.fail(counter, f"not a link counter; known: {', '.join(ALLOWABLE_COUNTERS)}")
        if counter not in ALLOWABLE_COUNTERS:
            raise a.fail(counter, "cannot be allowed: a run whose controller reported another estimator "
                                  "has INVALID claims (docs/protocol.md 6.8)")
        allow[counter] = a.integer(counter, 0, 0, 2**62)
    return allow


def _link(top: Fields) -> LinkSettings:
    k = top.table_of("link")
    retry_timeout_s = k.number("retry_timeout_s", LOCKSTEP_ANSWER_S)
    k.within("retry_timeout_s", retry_timeout_s, 0.001, 10.0, "s", "docs/protocol.md 6.5")
    patience_s = k.number("patience_s", PATIENCE_S)
    k.within("patience_s", patience_s, 0.1, 3600.0, "s", "docs/protocol.md 6.5")
    if patience_s <= retry_timeout_s:
        raise k.fail("patience_s", f"{patience_s:g} s is not longer than retry_timeout_s = "
                                   f"{retry_timeout_s:g} s: the host would give up before its first "
                                   f"re-send (docs/protocol.md 6.5)")
    if "max_retries" in k.table:
        raise k.fail("max_retries", "is gone: the host re-sends an unanswered lockstep cycle with "
                                    "back-off for as long as the controller is there, and ends the "
                                    "run after patience_s without an answer (docs/protocol.md 6.5); "
                                    "set patience_s instead")
    allow = parse_link_allow(k.table_of("allow"))
    k.reject_unknown()
    return LinkSettings(retry_timeout_s, patience_s, allow)


def parse_scenario(text: str, path: Path) -> Scenario:
    """Validate scenario TOML text; ``path`` names it in errors (and resolves nothing)."""
    where = _display(path)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{where}: not valid TOML: {exc}") from None

    top = Fields(where, raw, "", text)
    s = top.table_of("scenario")
    name = s.string("name", path.stem)
    if not NAME_PATTERN.match(name):
        raise s.fail("name", f"{name!r} must be 1-100 letters, digits, '_', '-', '@' or '.', not starting with "
                             f"'.' or '-' (it names the recording file)")
    description = s.string("description", "")
    profile = s.string("profile")
    if not (PROFILE_NAME.match(profile) or (profile.endswith(".toml") and len(profile) > 5)):
        raise s.fail("profile", f"{profile!r}: give the name of a bundled motor profile ({_bundled_profiles()}) "
                                f"or the path of a .toml profile file")
    duration_s = s.number("duration_s", positive=True)
    s.within("duration_s", duration_s, 0.0, MAX_DURATION_S, "s", "the longest run the bench records")
    mode = s.string("mode", "lockstep")
    if mode not in MODES:
        raise s.fail("mode", f"must be one of {', '.join(MODES)}, got {mode!r}")
    claims = s.strings("claims")
    has_faults = bool(raw.get("faults"))
    post_trip_s = s.number("post_trip_s", 0.05 if has_faults else 0.0, min_value=0.0)
    s.within("post_trip_s", post_trip_s, 0.0, 10.0, "s",
             "how long the run records the controller's reaction after its FAULT_CTRL")
    from hil_bench.claims.registry import CLAIMS

    for claim in claims:
        if claim not in CLAIMS:
            raise s.fail("claims", f"unknown claim {claim!r}{did_you_mean(claim, CLAIMS)} "
                                   f"(known: {', '.join(CLAIMS)}; bench claims)")
    s.reject_unknown()

    p = top.table_of("plant")
    initial_theta = p.number("initial_theta_e_rad", 0.0)
    p.within("initial_theta_e_rad", initial_theta, -2.0 * math.pi, 2.0 * math.pi, "rad",
             "an electrical angle, at most one turn either way; SENSE_AUX.theta_enc carries 0 .. 2 pi")
    initial_speed = p.number("initial_speed_rpm", 0.0) / RPM_PER_RAD_S
    initial_load = p.number("load_torque_nm", 0.0)
    plant_overrides = {k: _plant_value(p, k) for k in p.table
                       if k not in ("initial_theta_e_rad", "initial_speed_rpm", "load_torque_nm")}

    c = top.table_of("controller")
    estimator = _estimator(c, "estimator")
    speed_ref = _speed_rpm(c, "speed_ref_rpm", 0.0) / RPM_PER_RAD_S
    telemetry_emf = c.boolean("telemetry_emf", True)
    send_encoder = c.boolean("send_encoder_angle", False)
    if estimator is Estimator.ENCODER and "send_encoder_angle" in c.table and not send_encoder:
        raise c.fail("send_encoder_angle", "the ENCODER estimator needs the encoder angle: drop the key or "
                                           "set it to true (docs/protocol.md 6.8)")
    params = _controller_params(c.table_of("params"))
    inverter_comp = _inverter_comp(c, params)
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
    events = _events(where, raw.get("events", []), duration_s, text)
    realtime = _realtime(top, mode)
    link = _link(top)
    faults = parse_faults(top, duration_s)
    recording = parse_recording(top)
    lv = top.table_of("live")
    live_inputs = lv.boolean("inputs", False)
    lv.reject_unknown()
    top.reject_unknown()

    return Scenario(
        path=path, name=name, description=description, profile=profile, duration_s=duration_s,
        mode=mode, estimator=estimator, speed_ref_rad_s=speed_ref, controller_params=params,
        plant_overrides=plant_overrides, initial_theta_e_rad=initial_theta,
        initial_speed_rad_s=initial_speed, initial_load_torque_nm=initial_load, events=events,
        reference_estimators=reference, reference_config=reference_config,
        metrics_window_s=(w0, w1), claims=claims,
        telemetry_emf=telemetry_emf, raw=raw, text=text,
        send_encoder_angle=send_encoder, realtime=realtime, link=link,
        faults=faults, recording=recording, post_trip_s=post_trip_s,
        inverter_comp=inverter_comp, live_inputs=live_inputs,
    )


#: TELEM.omega_hat carries the electrical speed: a mechanical speed beyond max / pole pairs cannot be reported
OMEGA_HAT_RANGE_RAD_S = _wire_range("TELEM", "omega_hat")
#: HELLO.period_us: 0.1 us resolution, at most 6553.5 us
PERIOD_US = MESSAGES["HELLO"].signal("period_us")


def check_against_profile(scn: Scenario) -> None:
    """What only the motor profile can tell: the control period (HELLO.period_us must carry it, the run
    must last at least one period) and the pole pairs (speeds must fit TELEM.omega_hat); the plant
    overrides are checked by building the plant. Raises ScenarioError naming file, line and field."""
    from hil_bench.plant_rt.plant import Plant
    from hil_bench.plant_rt.profile import ProfileError, available_profiles, load_profile

    text, where = scn.text, scn.display_path

    def fail(table: str, key: str, why: str) -> ScenarioError:
        line = line_of(text, table, key)
        dotted = f"{table}.{key}" if table else key
        return ScenarioError(f"{where}:{line}: {dotted}: {why}" if line else f"{where}: {dotted}: {why}")

    if PROFILE_NAME.match(scn.profile) and scn.profile not in available_profiles():
        raise fail("scenario", "profile", f"no bundled motor profile {scn.profile!r} (bundled: "
                                          f"{_bundled_profiles()}; or give the path of a .toml file)")
    try:
        profile = load_profile(scn.profile)
    except ProfileError as exc:
        raise fail("scenario", "profile", str(exc)) from None
    try:
        plant = Plant(profile, **scn.plant_overrides)
    except (ProfileError, TypeError, ValueError) as exc:
        # the key the error names: "overrides.<key>" (the profile's own words), else the first
        # override whose name is a whole word of the message
        named = re.search(r"overrides\.([A-Za-z0-9_]+)", str(exc))
        bad = (named.group(1) if named and named.group(1) in scn.plant_overrides else
               next((k for k in scn.plant_overrides if re.search(rf"\b{re.escape(k)}\b", str(exc))),
                    None))
        raise (fail("plant", bad, str(exc)) if bad else ScenarioError(f"{where}: plant: {exc}")) from None
    ts_s = float(plant.params.ts_s)
    ts_key = ("plant", "ts_s") if "ts_s" in scn.plant_overrides else ("scenario", "profile")
    ts_text = f"Ts = {ts_s * 1e6:g} us" + (f" from profile {profile.name}" if ts_key[0] == "scenario" else "")
    period_raw = ts_s * 1e6 / PERIOD_US.scale
    if not 1 <= round(period_raw) <= PERIOD_US.raw_max or abs(period_raw - round(period_raw)) > 1e-6:
        raise fail(*ts_key, f"{ts_text}: HELLO.period_us carries 0.1 .. {PERIOD_US.maximum:g} us in steps "
                            f"of 0.1 us (protocol/hil.dbc)")
    if scn.duration_s < ts_s * (1 - 1e-9):
        raise fail("scenario", "duration_s", f"{scn.duration_s:g} s is shorter than one control period "
                                             f"({ts_text}): the run would have no cycle")
    w0, w1 = scn.metrics_window_s
    if w1 - w0 < ts_s * (1 - 1e-9):
        raise fail("metrics", "window_s", f"[{w0:g}, {w1:g}] holds no control period ({ts_text})")
    pp = int(plant.params.pole_pairs)
    lo, hi = OMEGA_HAT_RANGE_RAD_S
    max_rpm = min(-lo, hi) / pp * RPM_PER_RAD_S
    why = (f"|speed| <= {max_rpm:.0f} rpm: TELEM.omega_hat carries [{lo:g}, {hi:g}] rad/s electrical, "
           f"{pp} pole pairs")
    speeds = [("controller", "speed_ref_rpm", scn.speed_ref_rad_s),
              ("plant", "initial_speed_rpm", scn.initial_speed_rad_s)]
    speeds += [(f"events[{i}]", "speed_ref_rpm", float(item["speed_ref_rpm"]) / RPM_PER_RAD_S)
               for i, item in enumerate(scn.raw.get("events", [])) if "speed_ref_rpm" in item]
    if "dyno_speed_rad_s" in scn.plant_overrides:
        speeds.append(("plant", "dyno_speed_rad_s", float(scn.plant_overrides["dyno_speed_rad_s"])))
    for table, key, w in speeds:
        if abs(w * RPM_PER_RAD_S) > max_rpm:
            raise fail(table, key, f"{w * RPM_PER_RAD_S:g} rpm is outside the range the protocol carries ({why})")
    for fs in scn.faults:   # each plant fault alone on this plant (the C check names the reason)
        if fs.target != "plant":
            continue
        try:
            plant.set_fault(PLANT_KINDS[fs.kind][0], phase=fs.phase, phase2=fs.phase2,
                            level=fs.level, value=fs.value)
        except ValueError as exc:
            raise fail(f"faults[{fs.index}]", "kind", f"this plant cannot take it: {exc}") from None
        plant.clear_faults()
    check_faults_can_act(scn, ts_s, max(1, round(scn.duration_s / ts_s)),
                         bool(plant.params.dual_sampling), fail)
    _check_plant_values(scn, plant, profile.name, fail, max_rpm / RPM_PER_RAD_S)
    if scn.reference_estimators:
        try:
            from hil_bench.firmware_stub.estimators import REFERENCE_ESTIMATORS
        except ImportError:   # not built yet: the runner says so when it builds them
            return
        for entry in scn.reference_estimators:
            if entry.partition(":")[0] not in REFERENCE_ESTIMATORS:
                raise fail("reference", "estimators", f"unknown estimator {entry!r}; available: "
                                                      f"{', '.join(REFERENCE_ESTIMATORS)} (optionally NAME:label)")


#: SENSE_AUX.v_dc: the bus voltage the plant can send
V_DC_RANGE_V = _wire_range("SENSE_AUX", "v_dc")


def load_torque_limit_nm(params, duration_s: float, max_speed_rad_s: float) -> float:
    """The largest load torque (N m, either sign) a run can have: one that could not, against the most
    torque the motor can make with the largest current SENSE.i_a carries (1.5 p (psi_f i + |ld - lq| i^2/2),
    an upper bound of PMSM torque at |i| <= i_max), drive the rotor (inertia J) past the speed TELEM.omega_hat
    carries within the run. Beyond it the run cannot end with a speed the protocol can report."""
    i_max = min(-CURRENT_RANGE_A[0], CURRENT_RANGE_A[1])
    p = float(params.pole_pairs)
    t_motor = 1.5 * p * (float(params.psi_f_wb) * i_max + abs(float(params.ld_h) - float(params.lq_h)) * i_max ** 2 / 2)
    return t_motor + float(params.j_kgm2) * max_speed_rad_s / duration_s


def _check_plant_values(scn: Scenario, plant, profile_name: str, fail, max_speed_rad_s: float) -> None:
    """The plant's values against their wire and physical ranges (ranges from protocol/hil.dbc): the bus
    voltage SENSE_AUX.v_dc must carry (as the ADC model reports it, when on), every load torque (the scenario's, its
    events', a load profile's) within ``load_torque_limit_nm``."""
    par = plant.params

    def source(key: str) -> tuple[str, str, str]:
        """(table, key, where the value comes from) of a plant parameter."""
        if key in scn.plant_overrides:
            return "plant", key, ""
        return "scenario", "profile", f" (plant.{key} of profile {profile_name})"

    lo, hi = V_DC_RANGE_V
    v_dc = float(par.v_dc_v)
    checks = [("v_dc_v", v_dc, f"{v_dc:g} V")]
    if bool(getattr(par, "adc_model", False)):   # what the ADC reports of it, noise aside
        sensed = v_dc * (1.0 + float(par.adc_vdc_gain_err)) + float(par.adc_vdc_offset_v)
        key = next((k for k in ("adc_vdc_gain_err", "adc_vdc_offset_v") if k in scn.plant_overrides), "v_dc_v")
        checks.append((key, sensed, f"the sensed {sensed:g} V (v_dc_v {v_dc:g} V with adc_vdc_gain_err "
                                    f"{float(par.adc_vdc_gain_err):g}, adc_vdc_offset_v {float(par.adc_vdc_offset_v):g} V)"))
    for key, v, text in checks:
        if not lo < v <= hi:
            table, k, whence = source(key)
            raise fail(table, k, f"{text}{whence} is outside ({lo:g}, {hi:g}] V: the bus voltage "
                                 f"SENSE_AUX.v_dc carries (protocol/hil.dbc)")

    limit = load_torque_limit_nm(par, scn.duration_s, max_speed_rad_s)
    why = (f"|load| <= {limit:.4g} N m: a larger load drives the rotor past the speed TELEM.omega_hat carries "
           f"({max_speed_rad_s:.4g} rad/s) within the {scn.duration_s:g} s run even against the most torque the "
           f"motor makes at the largest current SENSE.i_a carries ({CURRENT_RANGE_A[1]:g} A)")
    torques = [("plant", "load_torque_nm", scn.initial_load_torque_nm)]
    torques += [(f"events[{i}]", "load_torque_nm", float(item["load_torque_nm"]))
                for i, item in enumerate(scn.raw.get("events", [])) if "load_torque_nm" in item]
    for key in ("load_torque0_nm", "load_torque1_nm"):
        if key in scn.plant_overrides:
            torques.append(("plant", key, float(scn.plant_overrides[key])))
    if "load_table_nm" in scn.plant_overrides:
        torques += [("plant", "load_table_nm", float(v)) for v in scn.plant_overrides["load_table_nm"]]
    for table, key, t in torques:
        if not abs(t) <= limit:
            raise fail(table, key, f"{t:g} N m is outside the load a run can have ({why})")


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
    try:
        scn = parse_scenario(text, path.with_name(f"{name}.toml"))
        check_against_profile(scn)
    except ScenarioError as exc:
        raise _override_error(exc, base_scn.display_path, overrides, note) from None
    return scn


_LOCATED = re.compile(r"(?P<where>.*?)(?::(?P<line>\d+))?: (?P<field>[A-Za-z0-9_.\[\]-]+): (?P<why>.*)\Z",
                      re.S)


def _override_error(exc: ScenarioError, base: str, overrides, note: str) -> ScenarioError:
    """An error of a derived scenario said against the override that caused it (``bench run
    --set plant.nosuch=1: ...``), or against the base file and the overrides: the derived text's
    line numbers are no line of any file the user has."""
    origin = note or "override"
    m = _LOCATED.match(str(exc))
    if m:
        field, why = m.group("field"), m.group("why")
        for key, value in overrides:
            if key == field or key.startswith(field + ".") or field.startswith(key + "."):
                return ScenarioError(f"{origin} {key}={value!r}: {field}: {why}")
        keys = ", ".join(k for k, _ in overrides)
        return ScenarioError(f"{base} with {origin} {keys}: {field}: {why}")
    return exc


def scenario_of(rec) -> Scenario:
    """The scenario attached to a recording (hil_bench.record.recording.Recording), parsed;
    RecordingError if it has none or it is invalid."""
    from hil_bench.record.recording import NotABenchRecording, RecordingError

    found = rec.attachment_text("scenario/")
    if found is None:
        intact = rec.has_footer and not rec.truncated and not rec.damage and not rec.unreadable_chunks
        if intact and "run" not in rec.metadata:
            topics = sorted(rec.counts or rec.topics)
            raise NotABenchRecording(
                f"{rec.path}: a valid MCAP file, but not a recording of this bench: it has no "
                f"run metadata and no scenario attached ({rec.messages} messages"
                + (f" on {', '.join(topics[:6])}" + (", ..." if len(topics) > 6 else "")
                   if topics else "") + "); `bench replay` reads other captures (docs/replay.md)")
        raise RecordingError(f"{rec.path}: no scenario attached"
                             + ("" if intact else " (the file is damaged: its summary or the "
                                                  "records after the damage are not read)"),
                             damaged=not intact)
    name, text = found
    try:
        return parse_scenario(text, Path(f"{rec.path}#{name}"))
    except ScenarioError as exc:
        raise RecordingError(f"{rec.path}: attached scenario is invalid: {exc}") from None


def operator_limits(params, duration_s: float) -> dict:
    """The scenario's limits of an operator input (the live view's, hil_bench.record.live_view
    LiveOptions fields): a speed the
    protocol can report (TELEM.omega_hat / pole pairs), a load torque the scenario check allows
    (``scenario.load_torque_limit_nm``: the same rule as the scenario's own loads)."""
    lo, hi = OMEGA_HAT_RANGE_RAD_S
    pp = int(params.pole_pairs)
    max_rad_s = min(-lo, hi) / pp
    load = load_torque_limit_nm(params, duration_s, max_rad_s)
    return dict(
        speed_max_rpm=max_rad_s * RPM_PER_RAD_S,
        speed_why=(f"TELEM.omega_hat carries [{lo:g}, {hi:g}] rad/s electrical, {pp} pole "
                   f"pairs: the scenario's speed limit"),
        load_max_nm=load,
        load_why=("the scenario's load limit: a larger load drives the rotor past the speed the "
                  "protocol reports within the run, against the most torque the motor makes"))
