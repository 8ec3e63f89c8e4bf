"""Faults of a scenario: the ``[[faults]]`` table and the ``[recording]`` table of a run with
faults (docs/faults.md). How the cycle engine applies them is ``hil_bench.loop.fault_events``;
what became of them, read back from a recording, ``hil_bench.record.fault_outcomes``.

Three targets, one table::

    [[faults]]                       # the plant (plant_rt/c/plant_fault.h)
    kind = "open_phase"
    phase = "b"
    t_s = 1.2                        # switched on at the first period starting at or after t_s
    until_s = 1.5                    # optional: switched off again

    [[faults]]                       # the link (plant_rt/c/engine_faults.h)
    kind = "drop"
    direction = "from_controller"    # to_controller | from_controller | both
    message = "DUTY"                 # a message of protocol/hil.dbc, or "any"
    t_s = 1.0
    count = 1                        # frames acted on (0: every matching frame until until_s)

    [[faults]]                       # the controller: CMD RESTART with that cycle's frames
    kind = "controller_reset"
    t_s = 1.0

Every fault has a detection window (``detect_within_s``, default 0.2 s): the engine snapshots its
counters when the fault first acts and writes, when the window closes, a ``/faults`` "trace" row
with the counters that moved. A fault that never acted or left no trace makes the run INVALID
(bench/record/integrity.py): the bench cannot tell what the run tested; one that can never act
is refused at load (``check_faults_can_act``, with the plant's period).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from hil_bench.protocol.messages import MESSAGES

from .fields import Fields, ScenarioError

#: plant fault kinds: scenario name -> (plant_rt FAULT_KINDS name, value key, unit, what)
PLANT_KINDS: dict[str, tuple[str, str | None, str, str]] = {
    "open_phase": ("open_phase", None, "", "the phase's wire disconnected"),
    "leg_stuck": ("leg_stuck", None, "", "a switch shorted: the leg tied to a rail"),
    "phase_short": ("phase_short", "resistance_ohm", "ohm", "two machine terminals shorted"),
    "sensor_stuck": ("sensor_stuck", "reading_a", "A", "a current sensor reads a constant"),
    "sensor_offset": ("sensor_offset", "offset_a", "A", "a current sensor offset"),
    "sensor_gain": ("sensor_gain", "gain_error", "", "a current sensor gain error (relative)"),
    "sensor_dropout": ("sensor_dropout", None, "", "a current sensor reads 0 A"),
    "bus_voltage": ("vdc", "v_dc_v", "V", "the bus voltage sags or steps to v_dc_v"),
    "encoder_loss": ("encoder_loss", None, "", "the encoder angle becomes invalid"),
    "encoder_stuck": ("encoder_stuck", None, "", "the encoder angle freezes"),
    "locked_rotor": ("locked_rotor", None, "", "the rotor is held at standstill"),
    "load_torque": ("load_torque", "torque_nm", "N m", "an extra load torque (a spike)"),
}
PHASED = ("open_phase", "leg_stuck", "phase_short", "sensor_stuck", "sensor_offset", "sensor_gain",
          "sensor_dropout")
LINK_KINDS = ("drop", "duplicate", "reorder", "bitflip", "delay", "stall", "garbage")
CONTROLLER_KINDS = ("controller_reset",)
ALL_KINDS = tuple(PLANT_KINDS) + LINK_KINDS + CONTROLLER_KINDS
DIRECTIONS = {"to_controller": 1, "from_controller": 2, "both": 3}
_PHASES = {"a": 0, "b": 1, "c": 2}

#: the wire's current range (SENSE.i_a): a stuck or offset reading must be one the wire carries
_I = MESSAGES["SENSE"].signal("i_a")
#: the wire's bus voltage range (SENSE_AUX.v_dc)
_VDC = MESSAGES["SENSE_AUX"].signal("v_dc")


@dataclass(frozen=True)
class FaultSpec:
    """One validated [[faults]] entry (SI units)."""

    index: int
    kind: str
    t_s: float
    until_s: float | None = None
    phase: int = 0
    phase2: int = 1
    level: int = 1
    value: float = 0.0
    direction: int = 0
    frame_id: int = -1
    message: str = "any"
    count: int = 0
    probability: float = 1.0
    delay_s: float = 0.0
    jitter_s: float = 0.0
    stall_periods: int = 0
    burst: int = 0
    seed: int = 1
    detect_within_s: float = 0.2
    label: str = ""

    @property
    def target(self) -> str:
        if self.kind in PLANT_KINDS:
            return "plant"
        return "link" if self.kind in LINK_KINDS else "controller"

    def describe(self) -> str:
        parts = [self.kind]
        if self.kind in PHASED:
            parts.append(f"phase {'abc'[self.phase]}")
        if self.kind == "phase_short":
            parts.append(f"to {'abc'[self.phase2]} through {self.value:g} ohm")
        if self.kind == "leg_stuck":
            parts.append("high" if self.level else "low")
        key = PLANT_KINDS.get(self.kind, (None, None, "", ""))
        if key[1] is not None and self.kind != "phase_short":
            parts.append(f"{self.value:g} {key[2]}".strip())
        if self.target == "link":
            parts.append({1: "to the controller", 2: "from the controller", 3: "both ways"}
                         [self.direction])
            if self.kind not in ("stall", "garbage"):
                parts.append(f"{self.message} frames")
            if self.kind == "delay":
                parts.append(f"{self.delay_s * 1e6:g} us" + (f" + {self.jitter_s * 1e6:g} us jitter"
                                                          if self.jitter_s else ""))
            if self.kind == "stall":
                parts.append(f"{self.stall_periods} periods")
            if self.kind == "garbage":
                parts.append(f"{self.burst} octets/frames")
            if self.count:
                parts.append(f"{self.count} frame(s)")
            if self.probability < 1.0:
                parts.append(f"p = {self.probability:g}")
        parts.append(f"at {self.t_s:g} s" + (f" until {self.until_s:g} s" if self.until_s else ""))
        return ", ".join(parts) + (f" ({self.label})" if self.label else "")


@dataclass(frozen=True)
class RecordingSettings:
    """``[recording]``: decimation outside the full-rate windows around faults (VeriStand-style
    pre- and post-trigger logging)."""

    decimate: int = 1              # record every N-th cycle outside the windows (1: all)
    pre_trigger_s: float = 0.02    # full rate this long before each fault
    post_trigger_s: float = 0.05   # and this long after each fault action and the trip


def parse_faults(top, duration_s: float) -> tuple[FaultSpec, ...]:
    """The [[faults]] array of a scenario (``top``: Fields of the whole file)."""
    top.used.add("faults")
    items = top.table.get("faults", [])
    if not isinstance(items, list):
        raise ScenarioError(f"{top.where}: faults: must be an array of tables ([[faults]])")
    out = []
    for i, item in enumerate(items):
        f = Fields(top.where, item, f"faults[{i}]", top.text)
        out.append(_one(f, i, duration_s))
        f.reject_unknown()
    if len(out) > 64:
        raise ScenarioError(f"{top.where}: faults: {len(out)} entries, at most 64")
    return tuple(out)


def _one(f, index: int, duration_s: float) -> FaultSpec:
    kind = f.string("kind")
    if kind not in ALL_KINDS:
        raise f.fail("kind", f"unknown fault {kind!r}; plant: {', '.join(PLANT_KINDS)}; link: "
                             f"{', '.join(LINK_KINDS)}; controller: {', '.join(CONTROLLER_KINDS)}")
    t_s = f.number("t_s", min_value=0.0)
    if t_s >= duration_s:
        raise f.fail("t_s", f"{t_s:g} s is not before the end of the run ({duration_s:g} s)")
    until_s = None
    if "until_s" in f.table:
        if kind in ("stall", "garbage", "controller_reset"):
            raise f.fail("until_s", f"a {kind} happens once (its length is "
                                    f"{'stall_periods' if kind == 'stall' else 'fixed'})")
        until_s = f.number("until_s")
        if not t_s < until_s <= duration_s:
            raise f.fail("until_s", f"must satisfy t_s < until_s <= duration_s ({duration_s:g}), "
                                    f"got {until_s:g}")
    kw: dict[str, Any] = dict(index=index, kind=kind, t_s=t_s, until_s=until_s,
                              label=f.string("label", ""),
                              detect_within_s=f.number("detect_within_s", 0.2, min_value=0.0))
    f.within("detect_within_s", kw["detect_within_s"], 0.0, 60.0, "s",
             "the window in which the fault's evidence counts")
    if kind in PLANT_KINDS:
        _plant_fields(f, kind, kw)
    elif kind in LINK_KINDS:
        _link_fields(f, kind, kw)
    return FaultSpec(**kw)


def _phase(f, key: str, default: str | None = None) -> int:
    v = f.string(key, default)
    if v.lower() not in _PHASES:
        raise f.fail(key, f"must be 'a', 'b' or 'c', got {v!r}")
    return _PHASES[v.lower()]


def _plant_fields(f, kind: str, kw: dict) -> None:
    _, key, unit, _what = PLANT_KINDS[kind]
    if kind in PHASED:
        kw["phase"] = _phase(f, "phase")
    if kind == "phase_short":
        kw["phase2"] = _phase(f, "phase2")
        if kw["phase2"] == kw["phase"]:
            raise f.fail("phase2", "must be another phase than phase")
    if kind == "leg_stuck":
        level = f.string("level")
        if level not in ("high", "low"):
            raise f.fail("level", f"must be 'high' (upper switch shorted, + rail) or 'low' "
                                  f"(lower switch, - rail), got {level!r}")
        kw["level"] = 1 if level == "high" else 0
    if key is None:
        return
    v = f.number(key)
    if kind == "phase_short" and not v > 0.0:
        raise f.fail(key, f"must be > 0 ohm (a resistive short), got {v:g}")
    if kind in ("sensor_stuck", "sensor_offset"):
        f.within(key, v, _I.minimum, _I.maximum, "A",
                 "the range SENSE.i_a..i_c carries, protocol/hil.dbc")
    if kind == "sensor_gain" and not v > -1.0:
        raise f.fail(key, f"must be > -1 (the sensor reads (1 + gain_error) i), got {v:g}")
    if kind == "bus_voltage":
        f.within(key, v, 1e-3, _VDC.maximum, "V",
                 "a bus above 0 V that SENSE_AUX.v_dc carries, protocol/hil.dbc")
    if kind == "load_torque" and not math.isfinite(v):
        raise f.fail(key, "must be finite")
    kw["value"] = v


def _link_fields(f, kind: str, kw: dict) -> None:
    default_dir = "both" if kind == "stall" else None
    d = f.string("direction", default_dir)
    if d not in DIRECTIONS:
        raise f.fail("direction", f"must be one of {', '.join(DIRECTIONS)}, got {d!r}")
    kw["direction"] = DIRECTIONS[d]
    if kind in ("stall", "garbage"):
        if "message" in f.table or "count" in f.table or "probability" in f.table:
            bad = next(k for k in ("message", "count", "probability") if k in f.table)
            raise f.fail(bad, f"a {kind} acts on the link, not on chosen frames")
    else:
        msg = f.string("message", "any")
        if msg != "any":
            if msg not in MESSAGES:
                raise f.fail("message", f"unknown message {msg!r}; protocol/hil.dbc has "
                                        f"{', '.join(MESSAGES)} (or 'any')")
            kw["frame_id"] = MESSAGES[msg].frame_id
        kw["message"] = msg
        kw["count"] = f.integer("count", 0, 0, 10_000_000)
        kw["probability"] = f.number("probability", 1.0)
        if not 0.0 < kw["probability"] <= 1.0:
            raise f.fail("probability", f"must be in (0, 1], got {kw['probability']:g}")
        if kw["count"] == 0 and kw["probability"] == 1.0 and kw["until_s"] is None:
            raise f.fail("kind", f"a {kind} of every matching frame from t_s to the end of the run: "
                                 f"give count, probability < 1 or until_s")
    if kind == "delay":
        kw["delay_s"] = f.number("delay_s", 0.0, min_value=0.0)
        kw["jitter_s"] = f.number("jitter_s", 0.0, min_value=0.0)
        if not 0.0 < kw["delay_s"] + kw["jitter_s"] <= 10.0:
            raise f.fail("delay_s", "delay_s + jitter_s must be in (0, 10] s")
    if kind == "stall":
        kw["stall_periods"] = f.integer("stall_periods", 0, 1, 600_000)
        if kw["stall_periods"] == 0:
            raise f.fail("stall_periods", "missing (required): how many periods nothing crosses")
    if kind == "garbage":
        kw["burst"] = f.integer("burst", 0, 1, 4096)
        if kw["burst"] == 0:
            raise f.fail("burst", "missing (required): octets (serial) or frames (CAN) of garbage")
    kw["seed"] = f.integer("seed", kw["index"] + 1, 0, 2**63 - 1)


# ---- can the fault act? (checked with the plant's period: scenario.check_against_profile) -------

def first_cycle_at(t_s: float, ts_s: float) -> int:
    """The first period that starts at or after t_s (half a period of tolerance for rounding):
    the cycle at which a fault switches on (and, for until_s, off)."""
    return max(0, int(math.ceil(t_s / ts_s - 0.5 + 1e-9)))


#: messages that cross only before the first cycle (handshake, configuration): the cycle engine,
#: which injects the link faults, never carries one (docs/protocol.md 6.1, 6.2, 6.7)
SETUP_ONLY = ("HELLO", "HELLO_ACK", "CONFIG", "CONFIG_ACK", "HEARTBEAT_PLANT")
#: messages the controller (or the bench) sends only when something happens: a fault on them may
#: act, the bench cannot count on it (a run where it did not act is INVALID: integrity)
OCCASIONAL = ("HEARTBEAT_CTRL", "FAULT_CTRL", "FAULT_PLANT")
DIRECTION_WORDS = {1: "to the controller", 2: "from the controller", 3: "either way"}


def _sender_direction(message: str) -> int:
    """1: the bench sends it (to the controller), 2: the controller sends it (protocol/hil.dbc)."""
    return 1 if MESSAGES[message].spec.sender == "PLANT" else 2


def _sure_per_cycle(message: str, direction: int, telemetry_emf: bool, dual: bool) -> int:
    """Frames of ``message`` ("any": every message) crossing in ``direction`` that every cycle of
    the run carries: SENSE_AUX, SENSE_DUAL (dual sampling), SENSE to the controller; TELEM,
    TELEM_EMF (if asked for), DUTY from it (docs/protocol.md 6.4). CMD is counted apart."""
    per = {"SENSE_AUX": 1, "SENSE_DUAL": int(dual), "SENSE": 1, "TELEM": 1,
           "TELEM_EMF": int(telemetry_emf), "DUTY": 1}
    names = list(per) if message == "any" else [message]
    return sum(per.get(m, 0) for m in names if _sender_direction(m) & direction)


def check_faults_can_act(scn, ts_s: float, n_cycles: int, dual_sampling: bool, fail) -> None:
    """Refuse, before anything starts, every [[faults]] entry that can never act in this run, and
    more faults or events than the cycle engine holds. ``fail(table, key, why)`` makes the located
    ScenarioError. The rules (docs/faults.md "Faults that cannot act"):

    * a fault switches on at its period ``first_cycle_at(t_s)``: that period must be one of the
      run's (0 .. n_cycles - 1); with until_s, at least one period must start in [t_s, until_s);
    * a link fault on a message: the message must travel in the fault's direction (its sender in
      protocol/hil.dbc), cross during the cycles (not only in the handshake or configuration), and
      be sent in this run (TELEM_EMF only when asked for, SENSE_DUAL only with dual sampling, CMD
      only when an event or a controller restart sends one in the fault's window);
    * with probability < 1 the run must expect at least one action: probability x the matching
      frames the window is sure to carry (one per period of each cycle message, the CMDs of the
      window) >= 1; frames the controller sends only when something happens (HEARTBEAT_CTRL,
      FAULT_CTRL) and FAULT_PLANT count for nothing.
    """
    from hil_bench.plant_rt import engine as eng

    where = scn.display_path
    last = n_cycles - 1
    cmd_cycles = [first_cycle_at(ev.t_s, ts_s) for ev in scn.events if ev.sends_cmd]
    cmd_cycles += [first_cycle_at(f.t_s, ts_s) for f in scn.faults if f.kind == "controller_reset"]
    n_link = 0
    n_events = sum(len(ev.actions()) for ev in scn.events)
    for fs in scn.faults:
        table = f"faults[{fs.index}]"
        k_on = first_cycle_at(fs.t_s, ts_s)
        if k_on > last:
            raise fail(table, "t_s", f"{fs.t_s:g} s is period {k_on} (a fault acts from the first "
                                     f"period starting at or after t_s, half a period of rounding; "
                                     f"Ts = {ts_s * 1e6:g} us); the run's last period is {last} "
                                     f"(t = {last * ts_s:.6g} s): it would never act")
        k_off = n_cycles
        if fs.until_s is not None:
            k_off = min(first_cycle_at(fs.until_s, ts_s), n_cycles)
            if k_off <= k_on:
                raise fail(table, "until_s", f"no period starts between t_s = {fs.t_s:g} s and "
                                             f"until_s = {fs.until_s:g} s (both round to period "
                                             f"{k_on}, Ts = {ts_s * 1e6:g} us): it would never act")
        if fs.target == "plant":
            n_events += 1 if fs.until_s is None else 2
        elif fs.target == "controller":
            n_events += 1
        else:
            n_link += 1
            if n_link > eng.MAX_LINK_FAULTS:
                raise fail(table, "kind", f"{sum(1 for f in scn.faults if f.target == 'link')} link "
                                          f"faults: the cycle engine holds at most "
                                          f"{eng.MAX_LINK_FAULTS} (plant_rt/c/engine_faults.h)")
            if fs.kind not in ("stall", "garbage"):
                _check_link_message(scn, fs, ts_s, k_on, k_off, dual_sampling, cmd_cycles, fail)
    if len(scn.faults) > eng.MAX_TRACES:
        raise ScenarioError(f"{where}: faults: {len(scn.faults)} entries: the cycle engine traces "
                            f"at most {eng.MAX_TRACES}")
    if n_events > eng.MAX_EVENTS:
        raise ScenarioError(f"{where}: events and faults: {n_events} engine events (one per thing "
                            f"an [[events]] entry sets, one per plant fault and two with until_s, "
                            f"one per controller restart): the cycle engine holds at most "
                            f"{eng.MAX_EVENTS} (plant_rt/c/engine.h)")


def _check_link_message(scn, fs: FaultSpec, ts_s: float, k_on: int, k_off: int, dual: bool,
                        cmd_cycles: list[int], fail) -> None:
    table = f"faults[{fs.index}]"
    m = fs.message
    window = (f"between {fs.t_s:g} s and " +
              (f"{fs.until_s:g} s" if fs.until_s is not None else "the end of the run"))
    if m != "any":
        sender = _sender_direction(m)
        if not sender & fs.direction:
            raise fail(table, "direction",
                       f"{m} travels only {DIRECTION_WORDS[sender]} (protocol/hil.dbc: sent by "
                       f"{MESSAGES[m].spec.sender}); a {fs.kind} {DIRECTION_WORDS[fs.direction]} "
                       f"never meets one")
        if m in SETUP_ONLY:
            raise fail(table, "message",
                       f"{m} crosses only during the handshake and configuration, before the "
                       f"first cycle; link faults act from the first cycle on (docs/faults.md)")
        if m == "TELEM_EMF" and not scn.telemetry_emf:
            raise fail(table, "message", "TELEM_EMF crosses only when [controller] telemetry_emf "
                                         "is true (HELLO flag TELEM_EMF); this scenario sets it false")
        if m == "SENSE_DUAL" and not dual:
            raise fail(table, "message", "SENSE_DUAL crosses only with dual sampling (the plant's "
                                         "dual_sampling), which this scenario's plant does not use")
    cmds = 0
    if fs.direction & 1 and m in ("CMD", "any"):
        cmds = sum(1 for k in cmd_cycles if k_on <= k < k_off)
    if m == "CMD" and cmds == 0:
        raise fail(table, "message",
                   f"no CMD crosses to the controller {window}: a CMD goes with the cycle of each "
                   f"[[events]] entry that sets a reference or the control mode, and of each "
                   f"controller_reset; none falls in that window")
    if fs.probability < 1.0:
        sure = (k_off - k_on) * _sure_per_cycle(m, fs.direction, scn.telemetry_emf, dual) + cmds
        expected = fs.probability * sure
        if expected < 1.0:
            what = "frames" if m == "any" else f"{m} frames"
            raise fail(table, "probability",
                       f"p = {fs.probability:g} on the {sure} {what} "
                       f"{DIRECTION_WORDS[fs.direction]} the run is sure to carry {window} expects {expected:.2g} action(s): the run "
                       f"cannot expect the fault to act (rule: probability x matching frames >= 1; "
                       f"one frame per period of each cycle message, the window's CMDs; "
                       f"{', '.join(OCCASIONAL)}: none counted, the controller sends them when it "
                       f"likes) -- raise probability, widen the window or give count")


def parse_recording(top) -> RecordingSettings:
    d = RecordingSettings()
    r = top.table_of("recording")
    decimate = r.integer("decimate", d.decimate, 1, 100_000)
    pre = r.number("pre_trigger_s", d.pre_trigger_s, min_value=0.0)
    post = r.number("post_trigger_s", d.post_trigger_s, min_value=0.0)
    r.reject_unknown()
    return RecordingSettings(decimate, pre, post)
