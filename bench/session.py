"""Scripted tests: a lockstep run driven step by step from Python (docs/api.md, "Scripted tests").

    import hil_bench
    from hil_bench import signals

    with hil_bench.Session("gong_g2_500rpm", overrides={"scenario.duration_s": 2.0}) as s:
        s.run_until("speed_rpm > 450", timeout_s=1.0)     # simulated time
        s.run_for(0.3)
        s.set_speed_ref_rpm(800)                           # a CMD with the next cycle's SENSE
        w = s.capture(0.5)                                 # DataFrame indexed by t_s [s]
        signals.settles(w.speed_rpm, 800, band=16, by_s=s.t_s - 0.5 + 0.4)
    result = s.result                                      # as hil_bench.run: claims, integrity

The run is ``bench run``'s (hil_bench.loop.runner.Runner: the same link, handshake, CONFIG,
engine, recorder process and check), in lockstep, held by the engine before the cycle the script
names (plant_rt/c/engine_inputs.c). Between holds the script reads the records the run wrote
(the very messages of the recording, out of its ring: hil_bench.record.ring_window) and pushes
inputs; the engine applies each at the cycle it holds before and records it on /events (kind
``script``, with the cycle), so the recording replays and ``bench check`` judges it: the claims of
a run whose inputs changed it are INVALID, as for a live view's operator inputs. Where the run
holds decides nothing but where the script's inputs land, so the same script gives the same rows.

Time-outs of a script are simulated time (``run_until(..., timeout_s=)``: a ConditionNotMet, an
AssertionError, says where and by how much). Every call also has a wall-clock safety bound
(``wall_timeout_s``): exceeding it is a SessionTimeout error naming it, never a result.
"""
from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hil_bench.errors import ArgumentError, BenchError

if TYPE_CHECKING:
    import pandas

    from hil_bench.api import Result
    from hil_bench.scenario import Scenario

__all__ = ["Session", "SessionError", "SessionTimeout", "InputRefused", "ConditionNotMet",
           "Window"]

#: run_until looks at the run this often [s of simulated time] unless told (``every_s``)
DEFAULT_EVERY_S = 1e-3
#: each call's wall-clock safety bound [s] unless told (``wall_timeout_s``)
DEFAULT_WALL_TIMEOUT_S = 600.0
#: a piece of a long step is at most a quarter of the recording ring (measured octets per cycle)
RING_SHARE = 4
#: octets per cycle assumed before the first piece is measured (a G2 cycle writes ~700)
FIRST_GUESS_OCTETS_PER_CYCLE = 4096

#: telemetry fields renamed in a window: the controller's estimate beside the plant's truth
TELEMETRY_RENAMES = {"e_alpha_v": "e_alpha_hat_v", "e_beta_v": "e_beta_hat_v"}


class SessionError(BenchError, RuntimeError):
    """The run cannot do what the script asked (the message says what, where and why)."""


class SessionTimeout(SessionError):
    """A call exceeded its wall-clock safety bound: an error, never a pass."""


class InputRefused(SessionError):
    """The engine or the plant refused an input (recorded as ``script_refused`` on /events)."""


class ConditionNotMet(BenchError, AssertionError):
    """``run_until``: the condition was not met within its time-out of simulated time."""


@dataclass
class Window:
    """The rows a stretch of the run wrote (``Session.window()``): ``frame`` (the plant's state
    and the controller's telemetry, one row per recorded cycle, indexed by ``t_s`` [s]) and
    ``events`` (the /events rows), filled when the block ends."""

    t0_s: float
    parts: list = field(default_factory=list, repr=False)
    event_parts: list = field(default_factory=list, repr=False)
    frame: pandas.DataFrame | None = None
    events: pandas.DataFrame | None = None


class Session:
    """A scripted lockstep run of a scenario on a link; see the module's documentation.

    scenario        a bundled scenario's name, a scenario file, or a Scenario (as hil_bench.run)
    link            as ``bench run --link``: stub, sil, pil-qemu, serial:..., can:..., stub-slcan
    overrides       dotted scenario keys and their values (``{"scenario.duration_s": 2.0}``)
    out, force      the recording's path (default recordings/<name>-<time>.mcap); replace it
    every_s         how often ``run_until`` looks at the run [s of simulated time]: its inputs
                    after a condition land at most this late (default 1 ms)
    wall_timeout_s  each call's wall-clock safety bound [s] (default 600)
    """

    def __init__(self, scenario: str | Path | Scenario, *, link: str = "stub",
                 overrides: Mapping[str, Any] | None = None, out: str | Path | None = None,
                 name: str | None = None, force: bool = False, allow_slow_link: bool = False,
                 every_s: float = DEFAULT_EVERY_S,
                 wall_timeout_s: float = DEFAULT_WALL_TIMEOUT_S, progress: bool = False):
        from hil_bench.api import _scenario
        from hil_bench.installation import require_extra, require_modules

        require_modules()
        # its windows, looks and events are DataFrames: said before the run starts
        require_extra("hil_bench.Session", "pandas")
        from hil_bench.loop.mailbox import HOLD_AT, ScriptMailbox
        from hil_bench.loop.runner import Runner
        from hil_bench.record import channels as ch
        from hil_bench.record.ring_window import RingWindow

        self.every_s = _positive("every_s", every_s)
        self.wall_timeout_s = _positive("wall_timeout_s", wall_timeout_s)
        self.link = link
        self.scenario = _scenario(scenario, overrides, name)
        self._runner = Runner(self.scenario, link, None if out is None else Path(out),
                              progress=progress, allow_slow_link=allow_slow_link, force=force,
                              scripted=True)
        self.ts_s = float(self._runner.ts_s)
        self.cycles_planned = int(self._runner.n_cycles)
        self.cycle = 0                   #: the cycle the run holds before (its next cycle)
        self.result: Result | None = None   #: the checked run, once closed
        self.closed = False
        self._ended = ""                 # why the run can go no further ("" : it can)
        self._latest = None
        self._windows: list[Window] = []
        self._events: list = []
        self._octets_per_cycle = float(FIRST_GUESS_OCTETS_PER_CYCLE)
        self._measured = False
        self._cm = self._runner.opened_run()
        self._open = self._cm.__enter__()
        _track(self)
        if self._open.engine is None:
            self._cm.__exit__(None, None, None)
            self.closed = True
            raise SessionError(f"{self.scenario.name} on {link}: the run could not start: "
                               f"{self._open.result.error}")
        try:
            self._box = ScriptMailbox(self._runner.live_inbox)
            r = self._runner
            self._ring = RingWindow(self._open.rec.ring_mem, {
                r.ch_state.index: ch.PLANT_STATE, r.ch_telem.index: ch.CONTROLLER_TELEMETRY,
                r.ch_events.index: ch.EVENTS})
            self._mark = 0
            self._box.push(HOLD_AT, 0.0, "script: hold before cycle 0")   # taken at cycle 0
            r.start_engine(self._open.engine)
            self._wait_held(0, "opening the session")
            self._read()
        except BaseException as exc:
            self._abort(exc)
            raise

    # -- what the run is now ----------------------------------------------------------------
    @property
    def t_s(self) -> float:
        """The simulated time of the cycle the run holds before [s]."""
        return self.cycle * self.ts_s

    @property
    def duration_s(self) -> float:
        """The run's planned length [s] (the scenario's ``duration_s``)."""
        return self.cycles_planned * self.ts_s

    @property
    def recording(self) -> Path:
        return Path(self._open.result.recording)

    @property
    def latest(self) -> pandas.Series:
        """The last recorded row (plant state and controller telemetry), indexed by name."""
        if self._latest is None:
            raise SessionError("no cycle has run yet")
        return self._latest.last().iloc[-1]

    @property
    def controller_state(self) -> str:
        """The controller's state in its last telemetry (IDLE, ALIGN, ..., CLOSED_LOOP, FAULT)."""
        return str(self.latest["state"])

    @property
    def events(self) -> pandas.DataFrame:
        """Every /events row of the run so far (scenario events, the script's, faults, ...)."""
        import pandas as pd

        if not self.closed and (not self._open.engine.running() or self._held()):
            self._read()      # what the inputs answered while it holds wrote
        return _concat_events(self._events) if self._events else pd.DataFrame(
            columns=["kind", "text", "value"], index=pd.Index([], name="t_s"))

    def __repr__(self) -> str:
        state = "closed" if self.closed else (self._ended or "held")
        return (f"<Session {self.scenario.name} on {self.link}: cycle {self.cycle} of "
                f"{self.cycles_planned} (t = {self.t_s:.6g} s), {state}>")

    # -- running ----------------------------------------------------------------------------
    def step(self, cycles: int) -> None:
        """Run ``cycles`` control periods and hold again."""
        if isinstance(cycles, bool) or not isinstance(cycles, int) or cycles < 0:
            raise ArgumentError(f"step: cycles is a whole number >= 0, got {cycles!r}")
        self._step(cycles, f"step({cycles})", f"script: step {cycles} cycles to cycle "
                                              f"{self.cycle + cycles}")

    def _step(self, cycles: int, what: str, note: str) -> None:
        self._usable(what)
        target = self.cycle + cycles
        self._check_target(target, what)
        if cycles:
            self._note(note)
        deadline = time.monotonic() + self.wall_timeout_s
        while self.cycle < target:
            self._advance(min(target, self.cycle + self._piece()), deadline, what)

    def run_for(self, duration_s: float) -> None:
        """Run ``duration_s`` of simulated time (rounded to whole periods) and hold again."""
        cycles = self._cycles("run_for", duration_s)
        self._step(cycles, f"run_for({duration_s:g})", f"script: run_for {duration_s:g} s "
                                                       f"({cycles} cycles) to cycle "
                                                       f"{self.cycle + cycles}")

    def run_until(self, condition: str | Callable[[pandas.DataFrame], Any], *,
                  timeout_s: float, hold_for_s: float = 0.0,
                  every_s: float | None = None) -> float:
        """Run until ``condition`` holds on the recorded rows (and has held ``hold_for_s``),
        looking every ``every_s`` of simulated time; returns the time it was met [s] (the run
        then holds at the end of that look, at most ``every_s`` later).

        condition  an expression over a window's columns and ``t_s`` (``"speed_rpm > 450"``,
                   ``"abs(pee_rad) < 0.05 and state == 'CLOSED_LOOP'"``: _Expression says what
                   it may hold), or a callable taking the rows of one look (a DataFrame) and
                   returning a boolean per row (or one boolean for the look's last row)
        timeout_s  simulated time [s] from now within which it must be met: else
                   ConditionNotMet (an AssertionError) saying where the run was
        """
        self._usable("run_until")
        timeout_s = _positive("timeout_s", timeout_s)
        if not (isinstance(hold_for_s, (int, float)) and hold_for_s >= 0):
            raise ArgumentError(f"run_until: hold_for_s is a time >= 0 [s], got {hold_for_s!r}")
        every = self.every_s if every_s is None else _positive("every_s", every_s)
        what = condition if isinstance(condition, str) else getattr(condition, "__name__",
                                                                    "condition")
        if isinstance(condition, str):
            expression = _Expression(condition)
        elif callable(condition):
            expression = None
        else:
            raise ArgumentError(f"run_until: the condition is an expression (str) or a callable, "
                            f"got {type(condition).__name__}")
        chunk = max(1, int(round(every / self.ts_s)))
        t0 = self.t_s
        limit = min(self.cycle + int(math.ceil(timeout_s / self.ts_s - 1e-9)), self.cycles_planned)
        deadline = time.monotonic() + self.wall_timeout_s
        streak_t = None          # when the condition last became true (hold_for_s)
        last = None
        while True:
            if self.cycle >= limit:
                self._note(f"script: run_until {what}: not met within {timeout_s:g} s")
                raise ConditionNotMet(_not_met_text(what, t0, self.t_s, timeout_s, last,
                                                    self._ended))
            rows = self._advance(min(limit, self.cycle + chunk), deadline, f"run_until({what})")
            if len(rows) == 0:
                continue
            last = rows
            if expression is not None:
                mask = expression.evaluate(rows, what)
            else:
                mask = _evaluate(condition, rows.frame(), what)
            met, streak_t = _first_met(rows.t, mask, streak_t, float(hold_for_s))
            if met is not None:
                self._note(f"script: run_until {what}: met at t = {met:.6g} s, held at cycle "
                           f"{self.cycle}", met)
                return met

    def capture(self, duration_s: float) -> pandas.DataFrame:
        """Run ``duration_s`` of simulated time and return its rows: the plant's state and the
        controller's telemetry (state and estimator by name), indexed by ``t_s`` [s]."""
        cycles = self._cycles("capture", duration_s)
        with self.window() as w:
            self._step(cycles, f"capture({duration_s:g})",
                       f"script: capture {cycles} cycles from cycle {self.cycle}")
        return w.frame

    def window(self) -> _WindowBlock:
        """``with s.window() as w: ...``: every row the block's steps wrote, in ``w.frame`` and
        ``w.events`` once it ends."""
        return _WindowBlock(self)

    # -- inputs (each applied at the cycle the run holds before, recorded on /events) ------------
    def set_speed_ref_rpm(self, rpm: float) -> None:
        """The speed reference [rpm, mechanical] (CMD SET_SPEED_REF)."""
        from hil_bench.loop.mailbox import SPEED_REF
        from hil_bench.scenario import RPM_PER_RAD_S

        rpm = _finite("set_speed_ref_rpm", rpm)
        self._input(SPEED_REF, rpm / RPM_PER_RAD_S, f"script: speed reference {rpm:g} rpm")

    def set_speed_ref_rad_s(self, rad_s: float) -> None:
        """The speed reference [rad/s, mechanical] (CMD SET_SPEED_REF)."""
        from hil_bench.loop.mailbox import SPEED_REF
        from hil_bench.scenario import RPM_PER_RAD_S

        rad_s = _finite("set_speed_ref_rad_s", rad_s)
        self._input(SPEED_REF, rad_s, f"script: speed reference {rad_s * RPM_PER_RAD_S:g} rpm")

    def set_iq_ref_a(self, amps: float) -> None:
        """The q current reference [A] (CMD SET_IQ_REF; acts in current mode)."""
        from hil_bench.loop.mailbox import IQ_REF

        amps = _finite("set_iq_ref_a", amps)
        self._input(IQ_REF, amps, f"script: q current reference {amps:g} A")

    def set_id_ref_a(self, amps: float) -> None:
        """The d current reference [A] (CMD SET_ID_REF)."""
        from hil_bench.loop.mailbox import ID_REF

        amps = _finite("set_id_ref_a", amps)
        self._input(ID_REF, amps, f"script: d current reference {amps:g} A")

    def set_control_mode(self, mode: str) -> None:
        """``"speed"`` (the speed loop makes i_q) or ``"current"`` (SET_IQ_REF / SET_ID_REF drive
        the current loops): CMD SET_CONTROL_MODE."""
        from hil_bench.loop.mailbox import CONTROL_MODE

        if mode not in ("speed", "current"):
            raise ArgumentError(f"set_control_mode: 'speed' or 'current', got {mode!r}")
        self._input(CONTROL_MODE, 1.0 if mode == "current" else 0.0,
                    f"script: control mode {mode}")

    def set_load_torque_nm(self, torque_nm: float) -> None:
        """The plant's load torque [N m] from this cycle on (as a scenario event's ``load``)."""
        from hil_bench.loop.mailbox import LOAD

        torque_nm = _finite("set_load_torque_nm", torque_nm)
        self._input(LOAD, torque_nm, f"script: load torque {torque_nm:g} N m")

    def set_bus_voltage_v(self, v_dc_v: float) -> None:
        """The DC bus voltage [V] from this cycle on: the plant's bus fault (``bus_voltage``,
        docs/faults.md); ``restore_bus_voltage()`` ends it."""
        self.fault_on("bus_voltage", v_dc_v=v_dc_v)

    def restore_bus_voltage(self) -> None:
        """The profile's bus voltage again (the bus fault off)."""
        self.fault_off("bus_voltage")

    def fault_on(self, kind: str, **fields: Any) -> None:
        """Switch a plant fault on, given as a scenario's ``[[faults]]`` entry without its times
        (docs/faults.md): ``fault_on("open_phase", phase="b")``, ``fault_on("sensor_offset",
        phase="a", offset_a=0.5)``, ``fault_on("leg_stuck", phase="a", level="high")``."""
        from hil_bench.loop.mailbox import FAULT_ON

        spec = self._fault_spec("fault_on", kind, fields)
        what = spec.describe().rsplit(", at ", 1)[0]      # from the cycle it holds before
        self._input(FAULT_ON, spec.value, f"script: fault on: {what}",
                    args=self._fault_args(spec))

    def fault_off(self, kind: str, phase: str | None = None) -> None:
        """Switch a plant fault off (``phase``: that phase's only; default every phase)."""
        from hil_bench.loop.mailbox import FAULT_OFF
        from hil_bench.plant_rt.plant import FAULT_KINDS
        from hil_bench.scenario.faults import PLANT_KINDS

        self._fault_kind("fault_off", kind)
        phases = {"a": 0, "b": 1, "c": 2}
        if phase is not None and str(phase).lower() not in phases:
            raise ArgumentError(f"fault_off: phase is 'a', 'b' or 'c', got {phase!r}")
        p = -1 if phase is None else phases[str(phase).lower()]
        self._input(FAULT_OFF, 0.0, f"script: fault off: {kind}"
                    + (f" phase {str(phase).lower()}" if phase is not None else ""),
                    args=(FAULT_KINDS[PLANT_KINDS[kind][0]], p, 0, 0))

    def set_param(self, name: str, value: float) -> None:
        """A CONFIG parameter at run time. docs/protocol.md 6.2: a controller takes CONFIG only
        while IDLE, STOPPED or FAULT (a running one answers LOCKED), so no parameter can change
        while the run goes; this names the parameter's scenario key instead."""
        from hil_bench.protocol.messages import Param

        if name not in Param.__members__:
            import difflib

            near = difflib.get_close_matches(str(name), list(Param.__members__), n=1)
            raise ArgumentError(f"set_param: no CONFIG parameter {name!r}"
                             + (f" (did you mean {near[0]}?)" if near else "")
                             + " (docs/protocol.md 6.2, the Param table)")
        value = _finite("set_param", value)
        raise SessionError(
            f"set_param({name}, {value:g}): docs/protocol.md 6.2 lets a controller take CONFIG "
            f"only in IDLE, STOPPED or FAULT (a running controller answers LOCKED), so a run "
            f"cannot change {name} while it goes; set it before the run: "
            f"overrides={{'controller.params.{name}': {value:g}}}")

    def note(self, text: str) -> None:
        """An /events row (kind ``script_note``) at the cycle the run holds before."""
        self._usable("note")
        self._note(f"script: {text}")

    # -- the end -----------------------------------------------------------------------------
    def close(self) -> Result:
        """Run the rest of the scenario's cycles (the script's holds end), then end the run as
        ``bench run`` does (STOP, statistics, recording finalised) and check the recording:
        returns (and keeps in ``result``) the hil_bench.Result, as hil_bench.run's."""
        if self.closed:
            if self.result is None:
                raise SessionError(f"the session was closed without a result: "
                                   f"{self._open.result.error or 'see its recording'}")
            return self.result
        from hil_bench.loop.mailbox import HOLD_AT

        try:
            if not self._ended and self._open.engine.running():
                self._note(f"script: close: the run goes on to its end (cycle "
                           f"{self.cycles_planned})")
                self._box.push(HOLD_AT, -1.0, "script: hold no more")
                self._runner.watch(self._open.engine, self._open.rec, self._open.opened,
                                   self._open.link, self._open.result, started=True)
            else:
                self._join_engine()
        except BaseException as exc:
            self._abort(exc)
            raise
        self._cm.__exit__(None, None, None)
        self.closed = True
        if self._open.result.interrupted:   # Ctrl-C while it ran to its end: finalised, then said
            raise KeyboardInterrupt(self._open.result.error)
        return self._check()

    def stop(self, reason: str = "the script stopped the run") -> None:
        """End the run at the cycle it holds before (its recording is then incomplete: its claims
        are INVALID) and finalise it; ``result`` is not computed."""
        if self.closed:
            return
        self._abort(None, reason)

    def __enter__(self) -> Session:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc is None:
            self.close()
        elif not self.closed:
            self._abort(exc)
        return False

    # -- internals ----------------------------------------------------------------------------
    def _held(self) -> bool:
        """The engine holds (before ``cycle``): it writes nothing but its answers' rows."""
        return not self.closed and self._box.news().held_k == self.cycle

    def _usable(self, what: str) -> None:
        if self.closed:
            raise SessionError(f"{what}: the session is closed")
        if self._ended:
            raise SessionError(f"{what}: {self._ended}")

    def _cycles(self, what: str, duration_s: float) -> int:
        duration_s = _finite(what, duration_s)
        if duration_s < 0:
            raise ArgumentError(f"{what}: a duration >= 0 [s], got {duration_s!r}")
        return int(round(duration_s / self.ts_s))

    def _check_target(self, target: int, what: str) -> None:
        if target > self.cycles_planned:
            raise SessionError(
                f"{what} at cycle {self.cycle}: the run has {self.cycles_planned} cycles "
                f"({self.duration_s:g} s, the scenario's duration_s); give the Session a longer "
                f"one (overrides={{'scenario.duration_s': ...}})")

    def _piece(self) -> int:
        """Cycles per piece of a long step: a quarter of the recording ring at the octets per
        cycle measured so far (where it holds changes nothing of the run)."""
        return max(1, int(self._ring.capacity // (RING_SHARE * self._octets_per_cycle)))

    def _look_around(self, what: str) -> None:
        from hil_bench.cluster.limits import expired

        e = self._open.engine
        if not e.running():
            raise _EngineEnded()
        if not self._open.rec.alive():
            self._ended = f"the recorder died: {self._open.rec.death_message()}"
            raise SessionError(f"{what} at cycle {e.cycles_done}: {self._ended}")
        limit_s = expired()
        if limit_s is not None:
            self._ended = f"the executor's time limit of {limit_s:g} s per run was exceeded"
            raise SessionError(f"{what} at cycle {e.cycles_done}: {self._ended}")

    def _on_wall(self, what: str) -> None:
        e = self._open.engine
        self._ended = (f"the wall-clock safety bound of {self.wall_timeout_s:g} s "
                       f"(Session(wall_timeout_s=...)) was exceeded")
        raise SessionTimeout(
            f"{what}: {self._ended} at cycle {e.cycles_done} (t = {e.cycles_done * self.ts_s:.6g} "
            f"s of simulated time): the run goes slower than that, or the controller stalls. "
            f"This is an error, not a result")

    def _wait_held(self, target: int, what: str, deadline: float | None = None) -> None:
        from hil_bench.loop.mailbox import wait_until

        deadline = time.monotonic() + self.wall_timeout_s if deadline is None else deadline
        try:
            wait_until(self._box, lambda n: n.held_k == target,
                       lambda: self._look_around(what), deadline, lambda: self._on_wall(what))
        except _EngineEnded:
            ended = True
        else:
            ended = False
        if ended:
            self._engine_ended(target, what)
            return
        self.cycle = target

    def _engine_ended(self, target: int, what: str) -> None:
        """The engine returned while the script waited for it to hold before ``target``."""
        e = self._open.engine
        e.join()
        r = e.result()
        self.cycle = r.cycles_done
        if r.end == 0 and target >= self.cycles_planned:
            self._ended = f"the run has ended (all {self.cycles_planned} cycles ran)"
            return
        self._ended = f"the run ended at cycle {r.cycles_done}: {r.end_text()}"
        raise SessionError(f"{what}: {self._ended}")

    def _advance(self, target: int, deadline: float, what: str) -> _Rows:
        """Let the run go on to ``target`` (held before it, or ended there), read its rows."""
        from hil_bench.loop.mailbox import HOLD_AT

        start_cycle, start_head = self.cycle, self._mark
        self._box.push(HOLD_AT, float(target), f"script: hold before cycle {target}")
        try:
            self._wait_held(target, what, deadline)
        except SessionError:
            if not self._open.engine.running():   # the rows up to its end, for the next reader
                self._read()
            raise
        rows = self._read()
        ran = self.cycle - start_cycle
        if ran > 0:   # the largest measured (the first replaces the guess)
            measured = (self._mark - start_head) / ran
            self._octets_per_cycle = (max(self._octets_per_cycle, measured) if self._measured
                                      else measured)
            self._measured = True
        return rows

    def _read(self) -> _Rows:
        """The rows the run wrote since the last read (out of the recording ring)."""
        from hil_bench.record import channels as ch

        head = self._ring.head()
        cols = self._ring.read(self._mark, head)
        self._mark = head
        rows = _Rows(cols.get(ch.PLANT_STATE), cols.get(ch.CONTROLLER_TELEMETRY))
        events = cols.get(ch.EVENTS)
        if events is not None and len(events.get("t_s", ())):
            self._events.append(events)
            for w in self._windows:
                w.event_parts.append(events)
        if len(rows):
            self._latest = rows
            for w in self._windows:
                w.parts.append(rows)
        return rows

    def _input(self, kind: int, value: float, text: str,
               args: tuple[int, int, int, int] = (0, 0, 0, 0)) -> None:
        from hil_bench.loop.mailbox import wait_until

        self._usable(text.removeprefix("script: "))
        before = self._box.news().refused
        n = self._box.push(kind, value, text, args)
        deadline = time.monotonic() + self.wall_timeout_s
        try:
            news = wait_until(self._box, lambda nw: nw.answered >= n,
                              lambda: self._look_around(text), deadline,
                              lambda: self._on_wall(text))
        except _EngineEnded:
            news = None
        if news is None:
            self._engine_ended(-1, text)     # raises: the run ended under a held script
            return
        if news.refused > before:
            raise InputRefused(f"{self._box.last_refusal} (t = {self.t_s:.6g} s)")

    def _note(self, text: str, value: float = 0.0) -> None:
        from hil_bench.loop.mailbox import NOTE

        if not self._ended and not self.closed:
            self._input(NOTE, value, text)

    def _fault_kind(self, what: str, kind: str) -> None:
        from hil_bench.scenario.faults import ALL_KINDS, PLANT_KINDS

        if kind in PLANT_KINDS:
            return
        if kind in ALL_KINDS:
            raise ArgumentError(f"{what}: {kind} is a link or controller fault: the engine sets "
                             f"those up before the run ([[faults]] of the scenario, "
                             f"docs/faults.md); a script switches plant faults: "
                             f"{', '.join(PLANT_KINDS)}")
        import difflib

        near = difflib.get_close_matches(str(kind), list(PLANT_KINDS), n=1)
        raise ArgumentError(f"{what}: unknown plant fault {kind!r}"
                         + (f" (did you mean {near[0]}?)" if near else "")
                         + f"; plant faults: {', '.join(PLANT_KINDS)}")

    def _fault_spec(self, what: str, kind: str, fields: dict):
        from hil_bench.scenario.faults import _one
        from hil_bench.scenario.fields import Fields

        self._fault_kind(what, kind)
        for key in ("t_s", "until_s", "detect_within_s", "kind", "label"):
            if key in fields:
                raise ArgumentError(f"{what}: {key} is not for a script (the fault acts from the "
                                 f"cycle the run holds before until fault_off)")
        f = Fields(f"Session.{what}({kind!r})", {"kind": kind, "t_s": 0.0, **fields}, "")
        spec = _one(f, 0, math.inf)
        f.reject_unknown()
        return spec

    @staticmethod
    def _fault_args(spec) -> tuple[int, int, int, int]:
        from hil_bench.plant_rt.plant import FAULT_KINDS
        from hil_bench.scenario.faults import PLANT_KINDS

        return (FAULT_KINDS[PLANT_KINDS[spec.kind][0]], spec.phase, spec.phase2, spec.level)

    def _join_engine(self) -> None:
        """Stop the engine where it is (if it runs), wait for it, and let the runner read its
        end (a run the session had given up on says why)."""
        e = self._open.engine
        stopped = e.running()
        if stopped:
            e.request_stop()
            self._box.kick()
        e.join()
        self._runner.engine_ended(e, self._open.opened, self._open.link, self._open.result)
        if stopped and self._ended:
            self._open.result.error = f"at cycle {e.cycles_done}: {self._ended}"

    def _abort(self, exc: BaseException | None, reason: str | None = None) -> None:
        """End the run where it is and finalise its recording (Ctrl-C: as bench run's)."""
        if self.closed:
            return
        self.closed = True
        result = self._open.result
        if isinstance(exc, KeyboardInterrupt):
            self._cm.__exit__(type(exc), exc, exc.__traceback__)   # the runner's Ctrl-C path
            return
        try:
            self._join_engine()
        finally:
            why = reason or (f"{type(exc).__name__}: {exc}".strip() if exc is not None else "")
            ended_here = (f"the script ended the run at cycle {self.cycle} (t = {self.t_s:.6g} "
                          f"s) of {self.cycles_planned}: {why}")
            if result.error is None or "held by the script" in result.error:
                result.error = ended_here.splitlines()[0]
            self._cm.__exit__(None, None, None)

    def _check(self) -> Result:
        from hil_bench.api import RunFailed, RunInfo, _result
        from hil_bench.papers.check import check_recording

        done = self._open.result
        info = RunInfo(cycles_done=done.cycles_done, cycles_planned=done.cycles_planned,
                       wall_s=done.wall_s, mode=done.mode, link=self.link, error=done.error,
                       interrupted=done.interrupted, timing=dict(done.timing))
        if done.cycles_done == 0:
            raise RunFailed(f"{self.scenario.name}: no cycle ran ({done.error or 'interrupted'}); "
                            f"recording {done.recording}")
        self.result = _result(check_recording(done.recording), info)
        return self.result


_OPEN: Any = None


def _track(session: Session) -> None:
    """Sessions still open when the interpreter exits are ended there (their recordings
    finalised): before multiprocessing's own exit handler waits for their recorder processes."""
    global _OPEN
    if _OPEN is None:
        import atexit
        import weakref

        _OPEN = weakref.WeakSet()
        atexit.register(_end_open_sessions)
    _OPEN.add(session)


def _end_open_sessions() -> None:
    for s in list(_OPEN or ()):
        if not s.closed:
            try:
                s.stop("the script ended without closing the session")
            except Exception:  # noqa: BLE001 - at exit: the next session still gets its turn
                pass


class _EngineEnded(Exception):
    """The engine returned while the script waited (looked at where it is raised)."""


class _WindowBlock:
    def __init__(self, session: Session):
        self.session = session
        self.window = Window(session.t_s)

    def __enter__(self) -> Window:
        self.session._windows.append(self.window)
        return self.window

    def __exit__(self, *exc) -> None:
        import pandas as pd

        w = self.window
        self.session._windows.remove(w)
        w.frame = _Rows.concat(w.parts).frame()
        w.events = _concat_events(w.event_parts) if w.event_parts else \
            pd.DataFrame(columns=["kind", "text", "value"], index=pd.Index([], name="t_s"))
        w.parts, w.event_parts = [], []


def _positive(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0 or not math.isfinite(v):
        raise ArgumentError(f"{name}: a time > 0 [s], got {v!r}")
    return float(v)


def _finite(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ArgumentError(f"{name}: a finite number, got {v!r}")
    return float(v)


class _Rows:
    """The rows of a stretch of the run as read (columns of /plant/state and
    /controller/telemetry); a DataFrame only when one is asked for."""

    def __init__(self, state: dict | None, telem: dict | None):
        import numpy as np

        self.state = state or {}
        self.telem = telem or {}
        self.t = np.asarray(self.state.get("t_s", ()), float)

    def __len__(self) -> int:
        return len(self.t)

    def frame(self) -> pandas.DataFrame:
        """The rows as a DataFrame (``_frame``)."""
        return _frame(self.state, self.telem)

    def arrays(self, names: list[str]) -> dict[str, Any]:
        """The columns ``names`` as numpy arrays (state and estimator: their names), t_s too."""
        out = _arrays(self.state, self.telem, names)
        out["t_s"] = self.t
        return out

    def last(self) -> pandas.DataFrame:
        return _Rows({k: v[-1:] for k, v in self.state.items()},
                     {k: v[-1:] for k, v in self.telem.items()}).frame()

    @staticmethod
    def concat(parts: list[_Rows]) -> _Rows:
        import numpy as np

        def join(dicts: list[dict]) -> dict:
            dicts = [d for d in dicts if d]
            return {k: np.concatenate([np.asarray(d[k]) for d in dicts]) for k in dicts[0]} \
                if dicts else {}

        return _Rows(join([p.state for p in parts]), join([p.telem for p in parts]))


def _names_in(expression: str) -> list[str]:
    """The window's columns an expression names (the others are not built for it)."""
    from hil_bench.record import channels as ch

    known = set(ch.PLANT_STATE_VALUES) | {TELEMETRY_RENAMES.get(n, n)
                                          for n in ch.TELEMETRY_VALUES}
    return [n for n in dict.fromkeys(_NAME.findall(expression)) if n in known and n != "t_s"]


def _frame(state: dict | None, telem: dict | None) -> pandas.DataFrame:
    """One row per recorded cycle, indexed by t_s [s]: the plant's state, then the controller's
    telemetry of the same cycle (its EMF estimate as e_alpha_hat_v / e_beta_hat_v), each as
    ``load_recording`` gives its channel (hil_bench.record.tables: state and estimator as
    categoricals named by the DBC, NaN in a cycle without telemetry; units in
    ``attrs["units"]``)."""
    from hil_bench.installation import require_extra
    from hil_bench.record import channels as ch
    from hil_bench.record import tables

    require_extra("a Session's rows as a DataFrame", "pandas")
    plant = tables.channel_frame(ch.PLANT_STATE, state or {})
    tel = tables.channel_frame(ch.CONTROLLER_TELEMETRY, telem or {})
    units = {**plant.attrs.get("units", {}),
             **{TELEMETRY_RENAMES.get(c, c): u for c, u in tel.attrs.get("units", {}).items()}}
    df = plant.join(tel.rename(columns=TELEMETRY_RENAMES), how="left")
    df.attrs = {"units": {c: units.get(c, "") for c in ("t_s", *df.columns)},
                "description": "the plant's state and the controller's telemetry of each "
                               "recorded cycle (hil_bench.Session)"}
    return df


def _arrays(state: dict, telem: dict, names: list[str]) -> dict[str, Any]:
    """The columns ``names`` as numpy arrays, the telemetry aligned on the state's rows (NaN,
    or "" for state and estimator, in a cycle without telemetry); state and estimator as their
    names (a value the DBC's table lacks: its decimal text, as tables.categorical does)."""
    import numpy as np

    from hil_bench.record import channels as ch

    t = np.asarray(state.get("t_s", ()), float)
    out: dict[str, Any] = {n: np.asarray(state[n]) for n in names if n in ch.PLANT_STATE_VALUES}
    wanted = {TELEMETRY_RENAMES.get(n, n): n for n in ch.TELEMETRY_VALUES}
    tel_names = [n for n in names if n in wanted and n not in out]
    if not tel_names:
        return out
    n = len(t)
    have = np.zeros(n, bool)
    at = np.zeros(n, np.intp)
    if telem and len(telem.get("t_s", ())) and n:
        tt = np.asarray(telem["t_s"], float)
        at = np.minimum(np.searchsorted(tt, t), len(tt) - 1)
        have = tt[at] == t
    tables = _enum_names()
    for key in tel_names:
        field = wanted[key]
        if field in tables:
            v = np.full(n, "", dtype=object)
            if have.any():
                raw = np.asarray(telem[field], np.int64)[at[have]]
                v[have] = [tables[field].get(int(r), str(int(r))) for r in raw]
        else:
            v = np.full(n, np.nan)
            if have.any():
                v[have] = np.asarray(telem[field], float)[at[have]]
        out[key] = v
    return out


def _enum_names() -> dict[str, dict[int, str]]:
    from hil_bench.protocol.messages import Estimator, State

    return {"state": {int(m): m.name for m in State},
            "estimator": {int(m): m.name for m in Estimator}}


def _concat_events(parts: list) -> pandas.DataFrame:
    import numpy as np
    import pandas as pd

    t = np.concatenate([np.asarray(p["t_s"], float) for p in parts])
    return pd.DataFrame({k: np.concatenate([np.asarray(p[k]) for p in parts])
                         for k in ("kind", "text", "value")},
                        index=pd.Index(t, name="t_s"))


_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class _Expression:
    """A condition written as an expression over a window's columns (``"speed_rpm > 450 and
    state == 'CLOSED_LOOP'"``): comparisons, arithmetic, ``and`` / ``or`` / ``not`` (element by
    element), numbers and strings, the columns and ``t_s``, and the functions of FUNCTIONS.
    Checked when given (an unknown column says which, with the nearest name), then evaluated
    on each look's numpy columns: no DataFrame is built for it."""

    FUNCTIONS = {"abs": "absolute", "sqrt": "sqrt", "sin": "sin", "cos": "cos", "exp": "exp",
                 "log": "log", "hypot": "hypot", "minimum": "minimum", "maximum": "maximum"}
    CONSTANTS = {"pi": math.pi}
    _NODES = ("Expression", "BoolOp", "BinOp", "UnaryOp", "Compare", "Call", "Name", "Constant",
              "Load", "And", "Or", "Not", "Add", "Sub", "Mult", "Div", "Mod", "Pow", "USub",
              "UAdd", "Eq", "NotEq", "Lt", "LtE", "Gt", "GtE")

    def __init__(self, text: str):
        import ast

        self.text = text
        try:
            tree = ast.parse(text.strip(), mode="eval")
        except SyntaxError as exc:
            raise ArgumentError(f"run_until({text!r}): not an expression: {exc.msg}") from None
        known = set(_names_in(" ".join(_ALL_COLUMNS()))) | {"t_s"}
        names = []
        for node in ast.walk(tree):
            kind = type(node).__name__
            if kind not in self._NODES:
                raise ArgumentError(f"run_until({text!r}): {kind} is not allowed in a condition "
                                 f"(columns, numbers, strings, comparisons, arithmetic, and/or/"
                                 f"not, {', '.join(self.FUNCTIONS)})")
            if kind == "Call" and not (isinstance(node.func, ast.Name) and
                                       node.func.id in self.FUNCTIONS and not node.keywords):
                raise ArgumentError(f"run_until({text!r}): only the functions "
                                 f"{', '.join(self.FUNCTIONS)} can be called")
            if kind == "Name" and node.id not in self.FUNCTIONS and node.id not in self.CONSTANTS:
                if node.id not in known:
                    import difflib

                    near = difflib.get_close_matches(node.id, sorted(known), n=1)
                    raise ArgumentError(f"run_until({text!r}): no column {node.id!r}"
                                     + (f" (did you mean {near[0]}?)" if near else "")
                                     + "; the columns are /plant/state's and "
                                       "/controller/telemetry's (docs/api.md)")
                names.append(node.id)
        self.names = [n for n in dict.fromkeys(names) if n != "t_s"]
        tree = _Elementwise().visit(tree)
        ast.fix_missing_locations(tree)
        self.code = compile(tree, "<run_until>", "eval")

    def evaluate(self, rows: _Rows, what: str):
        import numpy as np

        env = {k: getattr(np, v) for k, v in self.FUNCTIONS.items()}
        env.update(self.CONSTANTS, _and=np.logical_and, _or=np.logical_or,
                   _not=np.logical_not)
        env.update(rows.arrays(self.names))
        try:
            out = eval(self.code, {"__builtins__": {}}, env)   # noqa: S307 - checked above
        except Exception as exc:  # noqa: BLE001 - say which condition and why
            raise SessionError(f"run_until({what}): the condition failed on the rows from t = "
                               f"{rows.t[0]:.6g} s: {type(exc).__name__}: {exc}") from exc
        out = np.broadcast_to(np.asarray(out, dtype=bool), rows.t.shape)
        return np.array(out)


def _elementwise_class():
    import ast

    class Elementwise(ast.NodeTransformer):
        """``and`` / ``or`` / ``not`` and chained comparisons, element by element."""

        def visit_BoolOp(self, node):
            self.generic_visit(node)
            fn = "_and" if isinstance(node.op, ast.And) else "_or"
            out = node.values[0]
            for v in node.values[1:]:
                out = ast.Call(func=ast.Name(id=fn, ctx=ast.Load()), args=[out, v], keywords=[])
            return out

        def visit_UnaryOp(self, node):
            self.generic_visit(node)
            if isinstance(node.op, ast.Not):
                return ast.Call(func=ast.Name(id="_not", ctx=ast.Load()), args=[node.operand],
                                keywords=[])
            return node

        def visit_Compare(self, node):
            self.generic_visit(node)
            if len(node.ops) == 1:
                return node
            parts, left = [], node.left
            for op, right in zip(node.ops, node.comparators):
                parts.append(ast.Compare(left=left, ops=[op], comparators=[right]))
                left = right
            out = parts[0]
            for p in parts[1:]:
                out = ast.Call(func=ast.Name(id="_and", ctx=ast.Load()), args=[out, p],
                               keywords=[])
            return out

    return Elementwise


def _Elementwise():   # noqa: N802 - builds the transformer (ast imported on use)
    return _elementwise_class()()


def _ALL_COLUMNS() -> list[str]:   # noqa: N802
    from hil_bench.record import channels as ch

    return list(ch.PLANT_STATE_VALUES) + [TELEMETRY_RENAMES.get(n, n)
                                          for n in ch.TELEMETRY_VALUES]


def _evaluate(condition, frame, what: str):
    import numpy as np

    try:
        out = condition(frame)
    except Exception as exc:  # noqa: BLE001 - the script's own condition: say which and why
        raise SessionError(f"run_until({what}): the condition failed on the rows from t = "
                           f"{frame.index[0]:.6g} s: {type(exc).__name__}: {exc}") from exc
    arr = np.asarray(out)
    if arr.ndim == 0:
        mask = np.zeros(len(frame), bool)
        mask[-1] = bool(arr)
        return mask
    if arr.shape != (len(frame),):
        raise SessionError(f"run_until({what}): the condition gave {arr.shape} values for "
                           f"{len(frame)} rows (one boolean per row, or one for the last)")
    return arr.astype(bool)


def _first_met(t, mask, streak_t, hold_for_s: float):
    """The first time in ``t`` at which ``mask`` has been true for ``hold_for_s`` (carrying the
    start of a streak from the looks before: ``streak_t``), and the streak start to carry on."""
    import numpy as np

    n = len(t)
    idx = np.arange(n)
    last_false = np.maximum.accumulate(np.where(~mask, idx, -1))
    start = np.where(last_false + 1 < n, t[np.minimum(last_false + 1, n - 1)], np.inf)
    if streak_t is not None:
        start = np.where(last_false < 0, streak_t, start)
    ok = mask & (t - start >= hold_for_s - 1e-12)
    hit = np.flatnonzero(ok)
    if hit.size:
        return float(t[hit[0]]), None
    if mask[-1]:
        return None, float(start[-1])
    return None, None


def _not_met_text(what: str, t0_s: float, t1_s: float, timeout_s: float, last, ended: str) -> str:
    """Where the run was when a condition was not met: the last row's values of the columns the
    expression names."""
    values = ""
    if last is not None and len(last):
        cols = _names_in(what)
        row = last.last().iloc[-1]
        values = ", ".join(f"{c} = {row[c]:.6g}" if isinstance(row[c], float) else
                           f"{c} = {row[c]}" for c in cols)
        values = f"; at t = {last.t[-1]:.6g} s: {values}" if values else ""
    end = f" ({ended})" if ended else ""
    return (f"run_until({what}): not met within {timeout_s:g} s of simulated time (t = "
            f"{t0_s:.6g} s to {t1_s:.6g} s){end}{values}")
