"""Run a scenario: set the run up in Python, run every cycle in the C cycle engine, record it.

Once per run, here: validate, open the link (start the stub), start the recorder, write the
metadata, handshake and CONFIG (``host_session.py``), schedule the scenario's events, start the
engine (``plant_rt/engine.py``) and watch it; at the end STOP, the final statistics, the
result. Once per cycle, in C (``plant_rt/c/engine.h``): events, sensor model and SENSE, link
I/O, DUTY validation, plant step, reference estimators, recorded rows. Lockstep and real time
run on the same engine.

Every exit path (normal end, controller fault, dead or silent stub, Ctrl-C, a failed recorder)
finalises the MCAP recording and returns a RunResult that says what happened.
"""
from __future__ import annotations

import contextlib
import json
import math
import mmap
import os
import platform
import re
import subprocess
import sys
import time
import traceback
import uuid
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

from hil_bench.cluster.limits import expired
from hil_bench.errors import BenchError
from hil_bench.installation import checkout_root, version
from hil_bench.plant_rt import engine as eng
from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import load_profile
from hil_bench.protocol.messages import PROTO_VERSION, Command, Estimator, HelloFlag, Mode, Param
from hil_bench.protocol.timing import RESEND_MAX_INTERVAL_S
from hil_bench.record import channels as ch
from hil_bench.record.atomic import refuse_output_is_input
from hil_bench.record.controller_id import identity as controller_identity
from hil_bench.record.recorder import (
    SIDE_SUFFIXES,
    ProcessRecorder,
    RecorderError,
    Reservation,
    check_target,
    recording_stamp,
    reserve_recording,
)
from hil_bench.scenario import INV_COMP_CURRENTS, INV_COMP_SHAPES, RPM_PER_RAD_S, Scenario

from .host_session import PROTO_MINOR, HostSession
from .links import STUB_CAN_MODES, LinkError, OpenedLink, check_link_spec, open_link
from .links.engine_fd import engine_link_for

RECORDINGS_DIR = Path("recordings")
MAX_CONSECUTIVE_BAD_DUTIES = 10
STATS_EVERY_CYCLES = 1000
WATCH_PERIOD_S = 0.1


class RunAborted(BenchError, RuntimeError):
    """The run could not continue; the message says why and where."""


class DeferredInterrupts:
    """While a run is being closed (the engine stopping after a first Ctrl-C, the final statistics,
    the run_result record, the recorder finalising the file) a further Ctrl-C is counted, not
    raised: the recording is finalised whatever the user presses. Re-entrant; a no-op outside the
    main thread (only it receives signals)."""

    def __init__(self):
        self.count = 0
        self._depth = 0
        self._held = 0
        self._previous = None

    def _note(self, signum, frame) -> None:   # noqa: ARG002 - a signal handler's signature
        self.count += 1

    def __enter__(self) -> "DeferredInterrupts":
        import signal
        import threading

        if self._depth == 0 and threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._note)
        self._depth += 1
        return self

    def __exit__(self, *exc) -> None:
        import signal

        self._depth -= 1
        if self._depth == 0 and self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
            self._previous = None

    def hold(self) -> None:
        """From the first Ctrl-C on: deferred until release() (the run is being closed)."""
        self.__enter__()
        self._held += 1

    def release(self) -> None:
        while self._held:
            self._held -= 1
            self.__exit__(None, None, None)


@dataclass
class RunResult:
    scenario: str
    recording: Path
    cycles_done: int
    cycles_planned: int
    error: str | None = None
    interrupted: bool = False
    wall_s: float = 0.0
    engine_s: float = 0.0          # wall time of the engine alone (first to last cycle)
    mode: str = "lockstep"
    end: str = ""
    link_stats: dict = field(default_factory=dict)
    timing: dict = field(default_factory=dict)
    realtime_notes: str = ""
    #: the controller speaks an older protocol version: which features the session left out
    protocol_note: str = ""
    #: what the link found out about itself (a USB adapter's latency timer: links/serial_link.py)
    link_notes: list[str] = field(default_factory=list)
    ts_s: float = 0.0              # the control period [s]
    target: dict = field(default_factory=dict)   # pil-qemu: the target's own figures (qemu.py)
    #: --live: the viewer's end-of-run figures (record/live_view.py LiveView.stats), else None
    live_stats: dict | None = None
    timed_out: bool = False        # ended by the executor's per-run time limit
    interrupts_while_closing: int = 0   # Ctrl-C pressed while the recording was being finalised

    @property
    def ok(self) -> bool:
        return self.error is None and not self.interrupted


@dataclass
class OpenedRun:
    """A run set up to its engine (``Runner.opened_run``): what the block that drives it needs."""

    engine: eng.Engine | None      #: None: the run failed before (``result.error``)
    rec: ProcessRecorder
    opened: OpenedLink
    link: object                   #: the engine's side of the link (links/engine_fd.py)
    result: RunResult


def motor_params(profile) -> dict[Param, float]:
    """What the controller is told about the motor (from the profile; a scenario may override)."""
    return {
        Param.RS_OHM: profile.rs_ohm, Param.LD_H: profile.ld_h, Param.LQ_H: profile.lq_h,
        Param.PSI_F_WB: profile.psi_f_wb, Param.POLE_PAIRS: float(profile.pole_pairs),
        Param.J_KGM2: profile.j_kgm2, Param.B_NMS: profile.b_nms,
        Param.V_DC_NOM_V: profile.v_dc_v,
    }


#: estimator C config field <-> CONFIG parameter (the SMO family)
SMO_CONFIG_PARAMS = {
    "k_v": Param.SMO_K_V, "wc_rad_s": Param.SMO_WC_RAD_S, "a_per_a": Param.SMO_SIGMOID_A_PER_A,
    "lag_comp": Param.SMO_LAG_COMP, "m_per_a": Param.SMO_M_PER_A, "pll_kp": Param.PLL_KP,
    "pll_ki": Param.PLL_KI, "speed_lpf_rad_s": Param.SPEED_LPF_RAD_S,
}


def estimator_defaults(estimator: Estimator, profile, ts_s: float,
                       given: dict[Param, float]) -> dict[Param, float]:
    """The controller's estimator settings the scenario leaves open, filled by the same rules the
    host reference estimators use (firmware_stub/est_smo.py factories), so both sides run the
    same observer. Settings the scenario gives go into the rules (e.g. m decides k)."""
    if estimator not in (Estimator.SMO_SIGMOID, Estimator.SMO_TANH):
        return {}
    from hil_bench.firmware_stub.est_smo import smo_sigmoid_for, smo_tanh_for

    factory = smo_sigmoid_for if estimator is Estimator.SMO_SIGMOID else smo_tanh_for
    # only the settings this observer has: SMO_WC_RAD_S given to SMO_TANH (which has no filter,
    # docs/estimators.md) goes to the controller, which ignores it, not into the reference's rules
    known = set(factory(profile, ts_s).config)
    chosen = {f: given[p] for f, p in SMO_CONFIG_PARAMS.items() if p in given and f in known}
    config = factory(profile, ts_s, **chosen).config
    return {p: float(config[f]) for f, p in SMO_CONFIG_PARAMS.items()
            if f in config and p not in given}


#: the plant's inverter keys (plant_rt/README.md) -> the drive's INV_COMP_* estimate of each
INV_COMP_FROM_PLANT = (("dead_time_s", Param.INV_COMP_DEAD_TIME_S),
                       ("v_switch_drop_v", Param.INV_COMP_V_SWITCH_V),
                       ("r_switch_ohm", Param.INV_COMP_R_SWITCH_OHM),
                       ("v_diode_drop_v", Param.INV_COMP_V_DIODE_V),
                       ("r_diode_ohm", Param.INV_COMP_R_DIODE_OHM))
#: the drive's zero-crossing current when the plant's leg has a hard sign (i_cap_band_a = 0)
INV_COMP_MIN_BAND_A = 1e-3


def inverter_comp_settings(comp, plant_params: dict) -> tuple[dict[Param, float], dict]:
    """CONFIG parameters and recording metadata of ``[controller.inverter_comp]``: the drive's
    estimate = (1 - residual) x the plant's dead time and drops (zero when the plant's inverter is
    ideal: nothing to compensate). ``comp`` None: off, ({}, {"on": False}).
    """
    if comp is None:
        return {}, {"on": False}
    on = bool(plant_params.get("inverter_nonlinear", False))
    truth = {k: (float(plant_params[k]) if on else 0.0) for k, _ in INV_COMP_FROM_PLANT}
    plant_band = float(plant_params.get("i_cap_band_a", 0.0))
    band = comp.band_a if comp.band_a is not None else max(plant_band, INV_COMP_MIN_BAND_A)
    params = {Param.INV_COMP_ENABLE: float(INV_COMP_CURRENTS[comp.current]),
              Param.INV_COMP_SHAPE: float(INV_COMP_SHAPES[comp.shape]),
              Param.INV_COMP_BAND_A: band}
    if comp.current_bw_rad_s is not None:
        params[Param.INV_COMP_I_BW_RAD_S] = comp.current_bw_rad_s
    estimate = {}
    for key, param in INV_COMP_FROM_PLANT:
        estimate[key] = (1.0 - comp.residual) * truth[key]
        params[param] = estimate[key]
    meta = {"on": True, "residual": comp.residual, "current": comp.current, "shape": comp.shape,
            "plant_inverter_nonlinear": on, "plant": dict(truth, i_cap_band_a=plant_band),
            "drive": dict(estimate, band_a=band)}
    return params, meta


def controller_params(scn, profile, plant_params, ts_s: float, mode: str = "lockstep",
                      actuation_delay_s: float | None = None) -> dict[Param, float]:
    """Every parameter the host sends the controller (docs/protocol.md 6.2, "What the host sends"; the
    conformance kit sends the same), in this order, a later one replacing an earlier: the motor's,
    CTRL_DELAY_S, the reference estimator's observer settings (SMO_SIGMOID, SMO_TANH), the trip below
    the ADC's full scale, [controller.inverter_comp]'s INV_COMP_* estimate, the scenario's
    [controller.params]. Nothing else."""
    params = motor_params(profile)
    # The delay from sampling to the new duties acting, which the controller compensates
    # (angle advance, the voltage its observer is fed). Lockstep: the computation delay the
    # plant emulates. Real time with a shadow-loaded PWM (next_period): one whole period.
    # Real time on arrival: the link's real round trip, unknown before the run; the profile's
    # delay stands for it (a scenario can set CTRL_DELAY_S in [controller.params]).
    # actuation_delay_s: the plant's own (Plant.actuation_delay_s: its computation delay; with the
    # switching inverter, the instant the compare values it writes then are loaded); default
    # plant_params.t_delay_s.
    if mode == "realtime" and scn.realtime.duty_update == "next_period":
        params[Param.CTRL_DELAY_S] = ts_s
    elif actuation_delay_s is not None:
        params[Param.CTRL_DELAY_S] = float(actuation_delay_s)
    else:
        params[Param.CTRL_DELAY_S] = float(plant_params.t_delay_s)
    params.update(estimator_defaults(scn.estimator, profile, ts_s,
                                     scn.controller_params))
    pp = plant_params
    if bool(pp.adc_model) and float(pp.adc_full_scale_a) > 0.0:
        # a drive's over-current trip sits below its ADC's full scale: a clipped reading is
        # not a measurement (and the current-sum check would call it a sensor fault). 2 %
        # below: 40 LSB of a 12-bit ADC, far above its noise (docs/claims.md, finding 1).
        trip = 0.98 * float(pp.adc_full_scale_a)
        params[Param.I_MAX_TRIP_A] = min(params.get(Param.I_MAX_TRIP_A, trip), trip)
    params.update(inverter_comp_settings(scn.inverter_comp, plant_params.as_dict())[0])
    params.update(scn.controller_params)
    return params


def git_revision() -> str:
    """The checkout's git revision (``-dirty`` with local changes); an installed package has
    none (its version is recorded beside it: ``hil_bench_version``), and a virtual environment
    that happens to sit inside some git work tree must not lend it that tree's revision."""
    root = checkout_root()
    if root is None:
        return "none (installed package)"
    try:
        rev = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True,
                             text=True, timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=root, capture_output=True, text=True,
                               timeout=5).stdout.strip()
        return (rev or "unknown") + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


_UNSAFE_RUN = re.compile(r"[^A-Za-z0-9_+@-]+")


def default_recording_path(scenario: Scenario) -> Path:
    """recordings/<name>-<stamp>.mcap; the name cannot leave the recordings folder."""
    name = _UNSAFE_RUN.sub("_", scenario.name).strip("_") or "run"
    return RECORDINGS_DIR / f"{name}-{recording_stamp()}.mcap"


def event_cycles(scenario: Scenario, ts_s: float) -> list[tuple[int, object]]:
    """Each scenario event with the cycle it applies at: the first k with t_ev <= (k + 1/2) Ts."""
    out = []
    k = 0
    for ev in scenario.events:   # sorted by time
        k = max(k, int(math.ceil((ev.t_s - 0.5 * ts_s) / ts_s)) - 1, 0)
        while not ev.t_s <= k * ts_s + 0.5 * ts_s:
            k += 1
        out.append((k, ev))
    return out


def _is_qemu_link(link_spec: str) -> bool:
    return link_spec == "pil-qemu" or link_spec.startswith("pil-qemu:")


def _is_stub_link(link_spec: str) -> bool:
    """The firmware stub is the controller (``stub`` on a pty, ``stub-<can mode>``)."""
    return link_spec == "stub" or link_spec.startswith("stub-")


def _is_sil_link(link_spec: str) -> bool:
    """The firmware in this process (``sil``: software in the loop, links/sil.py)."""
    return link_spec == "sil"


def realtime_cpus(engine_cpu: int | None, stub_cpu: int | None) -> tuple[int | None, int | None]:
    """The CPU layout of a real-time run (docs/realtime.md): the engine (and the recorder, below
    it) on the last CPU this process may use, the stub on the first; the kernel's workers that
    carry the link's bytes take whatever the sleeping stub leaves of its CPU. What the scenario
    or the command line set is kept. On one CPU nothing is pinned."""
    allowed = sorted(os.sched_getaffinity(0))
    if len(allowed) < 2:
        return engine_cpu, stub_cpu
    if engine_cpu is None:
        engine_cpu = allowed[-1] if stub_cpu != allowed[-1] else allowed[0]
    if stub_cpu is None:
        others = [c for c in allowed if c != engine_cpu]
        stub_cpu = others[0] if others else None
    return engine_cpu, stub_cpu


class Runner:
    """One run of a scenario against the controller on a link (lockstep or real time)."""

    def __init__(self, scenario: Scenario, link_spec: str = "stub", out_path: Path | None = None,
                 progress: bool = True, stub_args: tuple[str, ...] = (),
                 allow_slow_link: bool = False, force: bool = False,
                 realtime: bool | None = None, record: bool = True, cpu: int | None = None,
                 ring_bytes: int | None = None, recorder_cpus: tuple[int, ...] | None = None,
                 full_rate_s: tuple[tuple[float, float], ...] = (), live=None,
                 pace: float | None = None, scripted: bool = False):
        """``recorder_cpus``: overrides where the recorder runs (hil_bench.perf.loop compares).
        ``full_rate_s``: time windows [s] recorded in full when the scenario's recording is
        decimated (the windows its metrics read: hil_bench.sweep). ``live``: a
        :class:`hil_bench.record.live_view.LiveOptions` (``bench run --live``: the recorder
        serves the channels to Foxglove). ``pace``: lockstep, wall seconds per second of plant
        time (1.0: as fast as real time, to watch; None: as fast as the link goes). Every run
        waits for its controller by the same rule, the scenario's ``[link]`` (docs/protocol.md
        6.5: late is not lost; the run ends only when the controller is gone or silent for
        ``patience_s``), whatever the controller and whoever runs it. ``scripted``: a script
        drives the run through the engine's mailbox (hil_bench.Session: ``opened_run``,
        lockstep)."""
        self.scripted = scripted
        if live is not None:
            import dataclasses

            live = dataclasses.replace(live, inputs=scenario.live_inputs)   # [live] inputs
            if pace is not None:
                live = dataclasses.replace(live, background=False)   # a run paced for watching
        self.live = live
        self.live_port: int | None = None
        #: called with the live view's port once it listens (the CLI prints the URL)
        self.on_live = None
        #: called with each note the link makes about itself, when it makes it (the CLI prints it)
        self.on_link_note = None
        self._link_notes_said: list[str] = []
        if pace is not None and not pace > 0:
            raise RunAborted(f"--pace {pace:g}: the pace is > 0 (1.0: real time)")
        self.pace = pace
        self.full_rate_s = tuple(full_rate_s)
        self.scn = scenario
        self._recorder_cpus_override = recorder_cpus
        self.mode = "realtime" if (realtime if realtime is not None else
                                   scenario.mode == "realtime") else "lockstep"
        if scripted and (self.mode == "realtime" or live is not None):
            raise RunAborted(f"{scenario.display_path}: a scripted session runs in lockstep "
                             f"without a live view: "
                             + ("the scenario runs in real time (mode = \"realtime\"), where "
                                "the controller keeps its own clock and no script can hold it"
                                if self.mode == "realtime" else "a viewer's inputs and a "
                                "script's would share one mailbox"))
        if pace is not None and self.mode == "realtime":
            raise RunAborted(f"--pace {pace:g}: a real-time run is paced by its own clock "
                             f"(--pace is for lockstep runs)")
        self.allow_slow_link = allow_slow_link
        self.link_spec = link_spec
        #: a default name (none given) that is taken becomes the next free one
        self.pick_free_name = not out_path
        self.out_path = Path(out_path) if out_path else default_recording_path(scenario)
        #: this run's id: in the recording's metadata and its side files (bench check compares)
        self.run_id = uuid.uuid4().hex
        self.force = force
        self.progress = progress
        self.stub_args = tuple(stub_args)
        self.record = record
        self.ring_bytes = ring_bytes
        self.cpu = cpu if cpu is not None else scenario.realtime.cpu
        stub_cpu = scenario.realtime.stub_cpu
        if self.mode == "realtime":
            allowed = sorted(os.sched_getaffinity(0))
            for what, asked in (("engine", self.cpu), ("stub", stub_cpu)):
                if asked is not None and asked not in allowed:
                    origin = ("--cpu" if what == "engine" and cpu is not None else
                              f"{scenario.display_path}: realtime.{'cpu' if what == 'engine' else 'stub_cpu'}")
                    raise RunAborted(f"{origin} = {asked}: this process may run on CPUs "
                                     f"{', '.join(map(str, allowed))} only; a real-time run "
                                     f"pinned elsewhere would not be what was asked for")
            self.cpu, stub_cpu = realtime_cpus(self.cpu, stub_cpu)
        if self.mode == "realtime" and _is_stub_link(link_spec):
            rt = scenario.realtime
            isr = rt.stub_isr + (f":{rt.stub_phase_us:g}" if rt.stub_phase_us is not None else "")
            self.stub_args += ("--isr", isr, "--rt-priority", str(rt.stub_priority))
            if rt.busy_wait:
                self.stub_args += ("--busy-poll",)
            if stub_cpu is not None:
                self.stub_args += ("--cpu", str(stub_cpu))
        if self.mode == "realtime" and _is_qemu_link(link_spec):
            raise RunAborted(f"{scenario.display_path}: --link {link_spec} runs in lockstep only: "
                             f"QEMU executes the firmware as fast as the host lets it, not at the "
                             f"target's clock, so real-time figures would describe the emulator "
                             f"(docs/ports.md)")
        self._check_faults_fit_the_link(scenario, link_spec)
        if scenario.faults and (_is_stub_link(link_spec) or _is_sil_link(link_spec)):
            # the stub reports its receive errors while cycles flow (HEARTBEAT_CTRL, protocol
            # 6.7 "may"): faults on the frames it receives then leave a trace on the bench
            self.stub_args += ("--heartbeat-always",)
        self.profile = load_profile(scenario.profile)
        self.plant = Plant(self.profile, **scenario.plant_overrides)
        self.ts_s = float(self.plant.params.ts_s)
        n = round(scenario.duration_s / self.ts_s)
        if not 1 <= n <= 2**40:
            raise RunAborted(f"{scenario.display_path}: scenario.duration_s = "
                             f"{scenario.duration_s:g} s is {n} periods of {self.ts_s * 1e6:g} us; "
                             f"need at least one")
        self.n_cycles = int(n)
        if self.live is not None:   # a viewer's inputs: the scenario's limits; a pause in lockstep
            import dataclasses

            from hil_bench.scenario import operator_limits

            self.live = dataclasses.replace(self.live, can_pause=self.mode == "lockstep",
                                            **operator_limits(self.plant.params,
                                                              scenario.duration_s))
        self.references = self._make_references()
        self._setup_frames: list[tuple[str, int, bytes]] = []

    @staticmethod
    def _check_faults_fit_the_link(scn: Scenario, link_spec: str) -> None:
        """Faults this link cannot carry are refused before any process or device is touched."""
        is_can = link_spec.startswith(("can:", *STUB_CAN_MODES))
        for fs in scn.faults:
            where = f"{scn.display_path}: faults[{fs.index}] ({fs.kind})"
            if fs.kind == "bitflip" and is_can and fs.direction & 1:
                raise RunAborted(f"{where}: on CAN a corrupted frame is destroyed by the bus's CRC "
                                 f"and retransmitted by the sender's controller: a bit flip towards "
                                 f"the controller cannot be emulated above the socket (inject it "
                                 f"from the controller: the bench counts the error frame)")
            if fs.kind == "garbage" and is_can and fs.burst > 32:
                raise RunAborted(f"{where}: a CAN garbage burst is at most 32 frames")

    def _make_references(self) -> list[tuple[str, Estimator, object]]:
        """The reference estimators the scenario names, configured by the library's rules."""
        if not self.scn.reference_estimators:
            return []
        from hil_bench.firmware_stub.estimators import REFERENCE_ESTIMATORS

        out = []
        for entry in self.scn.reference_estimators:
            name = entry.partition(":")[0]
            factory = REFERENCE_ESTIMATORS.get(name)
            if factory is None:
                raise RunAborted(f"{self.scn.display_path}: reference.estimators: unknown "
                                 f"estimator {name!r}; available: "
                                 f"{', '.join(REFERENCE_ESTIMATORS)} (optionally NAME:label)")
            try:
                est = factory(self.profile, self.ts_s, **self.scn.reference_config.get(entry, {}))
            except (ValueError, TypeError) as exc:
                raise RunAborted(f"{self.scn.display_path}: reference.{entry}: {exc}") from None
            out.append((entry, Estimator[name], est))
        return out

    # -- what the controller is told ----------------------------------------------------------
    def controller_params(self) -> dict[Param, float]:
        return controller_params(self.scn, self.profile, self.plant.params, self.ts_s, self.mode,
                                 actuation_delay_s=self.plant.actuation_delay_s)

    def inverter_comp_metadata(self) -> dict:
        """What the recording says about the drive's inverter-error feed-forward: from the
        scenario's residual (truth, estimate, residual), from explicit INV_COMP_* parameters (the
        estimate and the plant's values beside it), or off."""
        _, meta = inverter_comp_settings(self.scn.inverter_comp, self.plant.params.as_dict())
        given = {p.name: v for p, v in self.scn.controller_params.items()
                 if p.name.startswith("INV_COMP_")}
        if self.scn.inverter_comp is None and given.get("INV_COMP_ENABLE", 0.0) > 0.0:
            pp = self.plant.params.as_dict()
            on = bool(pp.get("inverter_nonlinear", False))
            meta = {"on": True, "residual": None, "source": "controller.params", "drive": given,
                    "plant_inverter_nonlinear": on,
                    "plant": {k: (float(pp[k]) if on else 0.0) for k, _ in INV_COMP_FROM_PLANT}}
        return meta

    def hello_flags(self) -> int:
        return self.scn.hello_flags(bool(self.plant.params.dual_sampling))

    # -- the run --------------------------------------------------------------------------
    def _stub_rt_notes(self) -> str:
        """What the stub (the controller in CI) could not get of its real-time set-up: its
        'cannot pin' / 'SCHED_FIFO not permitted' lines, said with the engine's."""
        stub = getattr(getattr(self, "opened", None), "stub", None)
        if self.mode != "realtime" or stub is None:
            return ""
        lines = [ln.removeprefix("hil_stub: ") for ln in list(stub.stderr_tail)
                 if "cannot pin" in ln or "not permitted" in ln]
        return "; ".join(f"controller stub: {ln}" for ln in lines)

    def _throttling_note(self) -> str:
        """A real-time run that spins through the whole period under the kernel's RT throttling
        loses 50 ms of every second to it (docs/realtime.md)."""
        if self.mode != "realtime":
            return ""
        rt = self.scn.realtime
        ts_s = self.ts_s
        if rt.priority <= 0 or not (rt.busy_wait or rt.spin_us * 1e-6 >= 0.9 * ts_s):
            return ""
        try:
            runtime = int(Path("/proc/sys/kernel/sched_rt_runtime_us").read_text())
            period = int(Path("/proc/sys/kernel/sched_rt_period_us").read_text())
        except (OSError, ValueError):
            return ""
        if runtime < 0 or runtime >= period:
            return ""
        return (f"RT throttling on (sched_rt_runtime_us {runtime} of {period}): the engine "
                f"never sleeps with busy_wait or spin_us near the period, so the kernel stops it "
                f"for {(period - runtime) / 1000:.0f} ms every {period / 1e6:g} s "
                f"(docs/realtime.md)")

    def run(self) -> RunResult:
        with self.opened_run() as opened:
            if opened.engine is not None:
                self.watch(opened.engine, opened.rec, opened.opened, opened.link, opened.result)
        return opened.result

    @contextlib.contextmanager
    def opened_run(self) -> Iterator[OpenedRun]:
        """The run set up to its engine, which the block starts and watches (``run``: ``_watch``;
        a script: hil_bench.Session). Whatever the block raises is handled as in a run (Ctrl-C:
        interrupted; a link, recorder or run error: the run's error), and leaving the block
        ends the run: STOP, the final statistics, the run_result record, the recording
        finalised. A run that failed before its engine existed yields ``engine`` None with the
        recording already finalised and ``result.error`` saying why."""
        scn = self.scn
        # never over one of its own inputs (the scenario, the motor profile), with or without
        # --force; then the target as such, before any process or device is touched
        refuse_output_is_input([self.out_path, *(self.out_path.with_suffix(sfx)
                                                 for sfx, _ in SIDE_SUFFIXES)],
                               [("scenario file", scn.path), ("motor profile", self.profile.path)])
        if not self.pick_free_name:
            check_target(self.out_path, self.force)
        check_link_spec(self.link_spec)               # a bad spec, a port that is not there
        self._check_budget_of_spec()
        # the name taken (its partial file created exclusively) and, with --force, the previous
        # recording and its side files moved aside: from here on nothing at out_path is an
        # older run's (recorder.reserve_recording)
        res = self.reservation = reserve_recording(self.out_path, force=self.force,
                                                   pick_free=self.pick_free_name)
        self.out_path = res.path
        result = RunResult(scn.name, self.out_path, 0, self.n_cycles, mode=self.mode,
                           ts_s=self.ts_s)
        t0 = time.monotonic()
        try:
            opened = self.opened = open_link(self.link_spec, self.stub_args,
                                             capture_path=self.out_path.with_suffix(".log"))
        except BaseException as exc:
            res.release()
            raise _with_replaced(exc, res) from None
        try:
            self._check_budget(opened)
            self.live_inbox = None
            if self.live is not None or self.scripted:
                self.live_inbox = new_live_inbox()
            rec = ProcessRecorder(self.out_path, force=self.force, cpus=self._recorder_cpus(),
                                  background=self.mode == "realtime", reservation=res,
                                  live=self.live, live_inbox=self.live_inbox,
                                  **({"ring_capacity": self.ring_bytes} if self.ring_bytes else {}))
            self.live_port = rec.live_port
            if self.live_port is not None and self.on_live is not None:
                self.on_live(self.live_port)
        except BaseException as exc:
            opened.close()
            res.release()
            raise _with_replaced(exc, res) from None
        engine = None
        engine_link = None
        yielded = False
        closing = self._closing = DeferredInterrupts()
        try:
            try:
                self._open_channels(rec)
                self._start_serial_capture(rec, opened)
                self._write_metadata(rec, opened)
            except BaseException:   # e.g. the recorder died: no run, but the link (stub) is closed
                opened.close()
                raise
            try:
                self._wait_for_viewer(rec)
                self._start_controller(opened)
                engine_link = engine_link_for(opened.link)
                engine = self._make_engine(rec, opened, engine_link)
                yielded = True
                yield OpenedRun(engine, rec, opened, engine_link, result)
            except KeyboardInterrupt:
                closing.hold()
                result.interrupted = True
                result.error = f"interrupted by the user at cycle {result.cycles_done}"
            except (LinkError, RunAborted, RecorderError) as exc:
                result.error = str(exc)
            except Exception as exc:  # noqa: BLE001 - a bug must still leave a readable recording
                traceback.print_exc()
                result.error = (f"internal error at cycle {result.cycles_done}: "
                                f"{type(exc).__name__}: {exc}")
            finally:
                with closing:
                    self._finish(rec, opened, engine, engine_link, result, t0)
        finally:
            with closing:
                try:
                    rec.close()
                except RecorderError as exc:
                    result.error = result.error or str(exc)
            result.interrupts_while_closing = closing.count
            closing.release()
            result.recording = rec.final_path or self.out_path
            if result.error and rec.final_path != self.out_path and res.replaced \
                    and res.replaced_text() not in result.error:
                result.error += res.replaced_text()
            result.live_stats = rec.live_stats
            if result.cycles_done == 0 and result.error and rec.final_path:
                result.error += (f" (no cycle ran; the recording of the attempt, with its "
                                 f"handshake frames, is {rec.final_path})")
        if not yielded:
            yield OpenedRun(None, rec, opened, engine_link, result)

    def _wait_for_viewer(self, rec: ProcessRecorder) -> None:
        """--live-wait: the run starts once a viewer has subscribed (its channels are advertised
        by now), before the controller's handshake; none within the time is an error."""
        live = self.live
        if live is None or live.wait_s is None or rec.live_port is None:
            return
        if not rec.wait_for_viewer(live.wait_s):
            from hil_bench.record.live_view import no_viewer_error

            raise RunAborted(no_viewer_error(rec.live_port, live.host, live.wait_s))

    def _stub_cpu(self) -> int | None:
        args = self.stub_args
        return int(args[args.index("--cpu") + 1]) if "--cpu" in args else None

    def _recorder_cpus(self) -> tuple[int, ...]:
        """In real time the recorder shares the engine's CPU, below it: the SCHED_FIFO engine
        preempts it at once, while on a CPU of its own the recorder's MCAP and zstd bursts
        would hold off the kernel's workers that carry the link's bytes (docs/realtime.md)."""
        if self._recorder_cpus_override is not None:
            return tuple(self._recorder_cpus_override)
        if self.mode != "realtime" or self.cpu is None:
            return ()
        return (int(self.cpu),)

    def _open_channels(self, rec: ProcessRecorder) -> None:
        self.rec = rec
        self.ch_state = rec.channel(ch.PLANT_STATE)
        self.ch_sense = rec.channel(ch.PLANT_SENSE)
        self.ch_telem = rec.channel(ch.CONTROLLER_TELEMETRY)
        self.ch_frames = rec.channel(ch.LINK_FRAMES)
        self.ch_stats = rec.channel(ch.LINK_STATS)
        self.ch_events = rec.channel(ch.EVENTS)
        self.ch_timing = rec.channel(ch.TIMING)
        self.ch_refs = [rec.channel(ch.REFERENCE_PREFIX + name, "REFERENCE")
                        for name, _, _ in self.references]
        self.ch_faults = (rec.channel(ch.FAULTS) if self.scn.faults or self.scn.post_trip_s > 0
                          else None)

    def _start_serial_capture(self, rec: ProcessRecorder, opened: OpenedLink) -> None:
        """A serial link: every octet both ways into <recording>.serial.bin (docs/replay.md):
        the handshake's from the Python link, the run's from the engine (capture_serial)."""
        from .links.serial_link import SerialLink

        self.ch_serial_raw = None
        if not isinstance(opened.link, SerialLink):
            return
        self.serial_capture_path = self.out_path.with_suffix(".serial.bin")
        index = self.ch_serial_raw = rec.raw_capture(self.serial_capture_path, self.run_id)
        opened.link.tap = lambda direction, data: rec.write_raw(
            index, time.monotonic_ns(), bytes((direction,)) + bytes(data))

    def _event(self, t_s: float, kind: str, text: str, value: float = 0.0) -> None:
        self.ch_events.write_values(t_s, (t_s, kind, text, value))

    def _check_budget_of_spec(self) -> None:
        """The link spec alone tells the budget (serial baud, CAN bit rates): refuse before the
        port is opened. The stub's links are checked once open (_check_budget)."""
        from .links import LinkError, spec_max_cycle_rate_hz

        try:
            known = spec_max_cycle_rate_hz(self.link_spec, self.hello_flags())
        except (LinkError, ValueError):
            return   # a malformed spec: open_link names what is wrong with it
        if known is not None:
            self._refuse_over_budget(known[1], known[0])

    def _check_budget(self, opened: OpenedLink) -> None:
        self._refuse_over_budget(opened.link.description,
                                 opened.link.max_cycle_rate_hz(self.hello_flags()))

    def _refuse_over_budget(self, description: str, max_hz: float) -> None:
        rate_hz = 1.0 / self.ts_s
        if rate_hz <= max_hz:
            return
        if self.mode == "lockstep" and self.allow_slow_link:
            self._slow_link_note = (f"{description} fits at most {max_hz:.0f} Hz; "
                                    f"lockstep at {rate_hz:.0f} Hz runs slower than real time")
            return
        extra = (" (or, in lockstep, --allow-slow-link to run slower than real time)"
                 if self.mode == "lockstep" else " (a real-time run cannot be slowed down)")
        raise RunAborted(
            f"{description} cannot carry this scenario: {rate_hz:.0f} Hz control "
            f"rate needed (Ts = {self.ts_s * 1e6:g} us) but the link fits at most "
            f"{max_hz:.0f} Hz with these frames; use a faster link or a longer period{extra}")

    def _write_metadata(self, rec: ProcessRecorder, opened: OpenedLink) -> None:
        import cffi
        import mcap
        import numpy as np

        scn, prof = self.scn, self.profile
        stub = opened.stub
        rec.metadata("run", {
            "scenario": scn.name,
            "scenario_path": scn.display_path,
            "profile": prof.name,
            "profile_path": str(prof.path),
            "mode": self.mode,
            "duty_update": scn.realtime.duty_update if self.mode == "realtime" else "",
            "realtime_cpus": (json.dumps({"engine": self.cpu, "recorder": self._recorder_cpus(),
                                          "stub": self._stub_cpu()})
                              if self.mode == "realtime" else ""),
            "run_id": self.run_id,
            "link": opened.link.description,
            "retry_timeout_s": repr(self.scn.link.retry_timeout_s),
            "patience_s": repr(self.scn.link.patience_s),
            "controller": (stub.controller if stub is not None else
                           "firmware_stub/src in process (software in the loop)"
                           if _is_sil_link(self.link_spec) else self.link_spec),
            "git_revision": git_revision(),
            "hil_bench_version": version(),
            "python": platform.python_version(),
            "numpy": np.__version__,
            "mcap": getattr(mcap, "__version__", "?"),
            "cffi": cffi.__version__,
            "host": platform.node(),
            "start_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "ts_s": repr(self.ts_s),
            "cycles_planned": str(self.n_cycles),
            "plant_params": json.dumps(self.plant.params.as_dict()),
            "controller_params": json.dumps({p.name: v for p, v in
                                             self.controller_params().items()}),
            "inverter_comp": json.dumps(self.inverter_comp_metadata()),
            "estimator": scn.estimator.name,
            "encoder_angle_sent": str(scn.encoder_angle_sent).lower(),
            "reference_estimators": json.dumps({n: scn.reference_config.get(n, {})
                                                for n in scn.reference_estimators}),
            "metrics_window_s": json.dumps(list(scn.metrics_window_s)),
            "claims": json.dumps(list(scn.claims)),
            "link_allow": json.dumps(scn.link.allow),
        })
        rec.attachment(f"scenario/{scn.path.name}", "application/toml", scn.text.encode())
        rec.attachment(f"profile/{Path(prof.path).name}", "application/toml",
                       Path(prof.path).read_bytes())
        note = getattr(self, "_slow_link_note", None)
        if note:
            self._event(0.0, "link_budget", note, 1.0 / self.ts_s)

    def _log_setup_frame(self, direction: str, fid: int, payload: bytes) -> None:
        self._setup_frames.append((direction, fid, payload))

    def _say_link_notes(self, opened: OpenedLink) -> None:
        """Each new note of the link (links/serial_link.py: a USB adapter holding the drive's
        answers) into the recording and, at once, to ``on_link_note`` (the CLI prints it before
        the cycles start: a held link makes every lockstep cycle slow)."""
        for note in getattr(opened.link, "notes", ()):
            if note not in self._link_notes_said:
                self._link_notes_said.append(note)
                self._event(0.0, "link_latency", note)
                if self.on_link_note is not None:
                    self.on_link_note(note)

    def _start_controller(self, opened: OpenedLink) -> None:
        stub = opened.stub
        self.session = HostSession(
            opened.link, on_frame=self._log_setup_frame,
            alive=(stub.alive if stub is not None else None),
            death_message=(stub.death_message if stub is not None else None),
            patience_s=self.scn.link.patience_s, retry_timeout_s=self.scn.link.retry_timeout_s)
        mode = Mode.REALTIME if self.mode == "realtime" else Mode.LOCKSTEP
        try:
            ack = self.session.handshake(period_s=self.ts_s, estimator=int(self.scn.estimator),
                                         flags=self.hello_flags(), mode=mode)
            self._event(0.0, "handshake",
                        f"controller fw 0x{int(ack['fw_version']):04X}, estimators mask "
                        f"0x{int(ack['estimators']):04X}", float(ack["fw_version"]))
            # who answered (record/controller_id.py): the report and the pytest plugin name it
            self.rec.metadata("controller", controller_identity(
                ack, opened.link.description,
                stub.controller if stub is not None else
                "firmware_stub/src in process (software in the loop)"
                if _is_sil_link(self.link_spec) else "",
                version=self.session.version_text))
            params = self.session.serve(self.controller_params(), needs_commands={
                "RESTART": f"faults[{fs.index}] controller_reset"
                for fs in self.scn.faults if fs.kind == "controller_reset"})
            if self.session.session_minor < PROTO_MINOR:
                self.protocol_note = (f"the controller speaks protocol {self.session.version_text} (the bench "
                                      f"{PROTO_VERSION}.{PROTO_MINOR}): served as {self.session.version_text}"
                                      + (f", without {', '.join(self.session.features_off)}"
                                         if self.session.features_off else ", nothing of the run left out"))
                self._event(0.0, "protocol", self.protocol_note, float(self.session.session_minor))
            self._say_link_notes(opened)     # the adapter's latency timer, read when opened
            self.session.configure(params)
            self._say_link_notes(opened)     # the set-up's round trips are judged by now
            self.session.command(Command.SET_SPEED_REF, self.scn.speed_ref_rad_s)
            self.session.command(Command.RUN)
        finally:
            tx = " ".join(f"{fid:03X}#{p.hex().upper()}" for d, fid, p in self._setup_frames
                          if d == "tx")
            rx = " ".join(f"{fid:03X}#{p.hex().upper()}" for d, fid, p in self._setup_frames
                          if d == "rx")
            self.ch_frames.write_values(0.0, (0.0, -1, tx, rx))
        self.session.on_frame = lambda d, i, p: None

    def _make_engine(self, rec: ProcessRecorder, opened: OpenedLink, link) -> eng.Engine:
        scn = self.scn
        rt = scn.realtime
        self.plant.set_initial(scn.initial_theta_e_rad, scn.initial_speed_rad_s)
        self.plant.set_load_torque(scn.initial_load_torque_nm)
        options = dict(
            t_delay_s=float(self.plant.params.t_delay_s),
            pole_pairs=int(self.profile.pole_pairs),
            rpm_per_rad_s=RPM_PER_RAD_S,
            dual_sampling=int(bool(self.plant.params.dual_sampling)),
            send_encoder=int(scn.encoder_angle_sent),
            telem_emf=int(scn.telemetry_emf),
            estimator_expected=int(scn.estimator),
            cmd_seq_start=self.session.next_cmd_seq(),   # the engine numbers the run's CMDs on
            retry_timeout_s=scn.link.retry_timeout_s,
            resend_max_s=RESEND_MAX_INTERVAL_S,
            patience_s=scn.link.patience_s,
            max_consecutive_bad_duties=MAX_CONSECUTIVE_BAD_DUTIES,
            max_consecutive_misses=rt.max_consecutive_misses,
            duty_update=rt.duty_update,
            guard_s=rt.guard_us * 1e-6,
            spin_s=rt.spin_us * 1e-6,
            busy_wait=int(rt.busy_wait),
            rt_priority=rt.priority,
            rt_mlock=int(rt.mlock),
            rt_cpu=-1 if self.cpu is None else int(self.cpu),
            stats_every_cycles=STATS_EVERY_CYCLES,
            can_brs=int(bool(getattr(getattr(opened.link, "spec", None), "data_bitrate", None))),
        )
        if getattr(self, "ch_serial_raw", None) is not None and self.record:
            options.update(capture_serial=1, ch_serial_raw=self.ch_serial_raw)
        rs = scn.recording
        options.update(post_trip_cycles=int(round(scn.post_trip_s / self.ts_s)),
                       record_every=rs.decimate,
                       pre_trigger_cycles=int(math.ceil(rs.pre_trigger_s / self.ts_s)),
                       post_trigger_cycles=int(math.ceil(rs.post_trigger_s / self.ts_s)))
        if self.ch_faults is not None:
            options.update(ch_faults=self.ch_faults.index)
        if self.pace is not None and self.mode == "lockstep":
            options.update(pace_s=self.pace * self.ts_s)
        channels = {"ch_state": self.ch_state.index, "ch_sense": self.ch_sense.index,
                    "ch_telem": self.ch_telem.index, "ch_frames": self.ch_frames.index,
                    "ch_events": self.ch_events.index, "ch_timing": self.ch_timing.index,
                    "ch_stats": self.ch_stats.index}
        e = eng.Engine(self.plant, ts_s=self.ts_s, n_cycles=self.n_cycles, link_fd=link.fd,
                       link_kind=link.kind,
                       mode=eng.REALTIME if self.mode == "realtime" else eng.LOCKSTEP,
                       ring=rec.ring_mem if self.record else None, channels=channels,
                       sil=link.sil, **options)
        for (_, kind, est), chan in zip(self.references, self.ch_refs):
            e.add_reference(int(kind), est, chan.index)
        for t0_s, t1_s in self.full_rate_s:
            e.add_full_rate(max(0, math.floor(t0_s / self.ts_s) - 1), math.ceil(t1_s / self.ts_s) + 1)
        self._schedule_events(e)
        if getattr(self, "live_inbox", None) is not None:
            e.attach_inbox(self.live_inbox)
        # what the Python link received but did not use: the engine continues from there
        py_link = opened.link
        stats = py_link.stats()
        deframer = getattr(py_link, "deframer", None)
        e.preload_link_counters(
            deframer=deframer.counters() if deframer is not None else None,
            link={k: stats.get(k, 0) for k in ("frames_tx", "frames_rx", "bytes_tx", "bytes_rx")})
        pending = list(getattr(py_link, "_pending", []))
        py_link._pending = []
        partial = bytes(getattr(deframer, "_pending", b"")) if deframer is not None else b""
        e.hand_over(partial, pending)
        return e

    def _schedule_events(self, e: eng.Engine) -> None:
        from .fault_events import schedule

        try:
            fault_events = schedule(e, self.scn.faults, self.ts_s)
        except ValueError as exc:
            raise RunAborted(f"{self.scn.display_path}: {exc}") from None
        # the engine takes events in cycle order: the scenario's and the faults' merged
        adders = [(k, 0, i, lambda ev=ev, k=k: self._add_scenario_event(e, k, ev))
                  for i, (k, ev) in enumerate(event_cycles(self.scn, self.ts_s))]
        adders += [(k, 1, i, lambda kw=kw, k=k: e.add_fault_event(k, **kw))
                   for i, (k, kw) in enumerate(fault_events)]
        for *_, add in sorted(adders, key=lambda a: a[:3]):
            try:
                add()
            except ValueError as exc:
                raise RunAborted(f"{self.scn.display_path}: {exc}") from None

    def _add_scenario_event(self, e: eng.Engine, k: int, ev) -> None:
        commands = {"speed_ref": Command.SET_SPEED_REF, "iq_ref": Command.SET_IQ_REF,
                    "id_ref": Command.SET_ID_REF, "control_mode": Command.SET_CONTROL_MODE}
        subs = [(eng.EV_LOAD, 0, v) if name == "load" else (eng.EV_CMD, int(commands[name]), v)
                for name, v in ev.actions()] or [(eng.EV_NOTE, 0, 0.0)]
        value = (ev.speed_ref_rad_s if ev.speed_ref_rad_s is not None
                 else (ev.load_torque_nm or 0.0))
        for i, (kind, command, v) in enumerate(subs):
            last = i == len(subs) - 1
            e.add_event(k, kind, command=command, value=v,
                        text=ev.describe() if last else None, record_value=value)

    def start_engine(self, e: eng.Engine) -> None:
        """Start the engine's thread (the run's engine time counts from here)."""
        self.engine = e
        self._engine_t0 = time.perf_counter()
        e.start()

    def watch(self, e: eng.Engine, rec: ProcessRecorder, opened: OpenedLink, link,
              result: RunResult, started: bool = False) -> None:
        """Start the engine (unless ``started``) and watch it to its end: progress, Ctrl-C, a
        recorder that dies, the executor's time limit; then what the engine's end says."""
        progress = _Progress(self.n_cycles, self.scn.name) if self.progress else None
        if not started:
            self.start_engine(e)
        try:
            while e.running():
                try:
                    e.join(WATCH_PERIOD_S)
                except KeyboardInterrupt:
                    self._closing.hold()    # from here on the run is being closed: a further
                    e.request_stop()        # Ctrl-C must not leave the engine running or the
                    e.join()                # recording unfinished
                    result.interrupted = True
                    break
                result.cycles_done = e.cycles_done
                limit_s = expired()
                if limit_s is not None:
                    # the executor's per-run time limit (hil_bench.cluster): a hung run ends
                    e.request_stop()
                    e.join()
                    result.timed_out = True
                    break
                if progress is not None:
                    progress.update(result.cycles_done, e.speed_rpm)
                if not rec.alive():
                    e.request_stop()
                    e.join()
                    raise RecorderError(rec.death_message())
        finally:
            if progress is not None:
                progress.close(e.cycles_done)
        self.engine_ended(e, opened, link, result)

    def engine_ended(self, e: eng.Engine, opened: OpenedLink, link, result: RunResult) -> None:
        """The engine has returned: its time, cycles, end and what its end means for the run."""
        result.engine_s = time.perf_counter() - self._engine_t0
        r = e.result()
        result.cycles_done = r.cycles_done
        result.end = r.end_name
        result.protocol_note = getattr(self, "protocol_note", "")
        result.realtime_notes = "; ".join(n for n in (r.rt_notes, self._throttling_note(),
                                                      self._stub_rt_notes()) if n)
        if result.timed_out:
            result.error = (f"time limit of {expired():g} s per run exceeded at cycle "
                            f"{r.cycles_done}: the run was ended")
        elif result.interrupted:
            result.error = f"interrupted by the user at cycle {r.cycles_done}"
        elif r.end != eng.END_DONE:
            result.error = r.end_text()
            if r.end == 2:   # the link: say what is behind it
                if link.error:
                    result.error = f"{r.message.split(': ', 1)[0]}: {link.error}"
                elif opened.stub is not None:
                    why = _stub_failure(opened.stub)
                    if why:
                        result.error = f"{r.message.split(': ', 1)[0]}: {why}"
            elif r.end == 3 and opened.stub is not None and not opened.stub.alive():
                result.error = f"{r.message} -- {opened.stub.death_message()}"

    def _finish(self, rec: ProcessRecorder, opened: OpenedLink, e: eng.Engine | None, link,
                result: RunResult, t0: float) -> None:
        """After the run: final statistics, the error, STOP, the link closed, run_result."""
        t_end = result.cycles_done * self.ts_s
        result.link_notes = list(getattr(opened.link, "notes", ()))   # said even if the set-up failed
        stopped = False
        if e is not None and e.running():   # interrupted before the engine was stopped
            e.request_stop()
            e.join()
            result.cycles_done = e.cycles_done
        rec.foreground()   # real time is over: the recorder finishes the file at normal priority
        if e is not None and hasattr(self, "session"):
            # STOP through the engine's link, counted with the run's frames
            stopped = e.send(*self.session.command_frame(Command.STOP, 0.0, seq=e.cmd_seq))
            if link is not None:
                link.settle()
        extra = link.extra_counters() if link is not None else {}
        faults = "[]"
        if e is not None:
            from .fault_events import account

            faults = json.dumps(account(self.scn.faults, e.fault_states(), self.ts_s,
                                        self.n_cycles))
            e.write_stats(t_end, extra)
            result.link_stats = e.counters()
            for k, v in extra.items():
                key = "can_unknown_ids" if k == "ext_ids" else k
                result.link_stats[key] = result.link_stats.get(key, 0) + v
            result.link_stats["rows_dropped"] = rec.dropped
            result.link_stats["cycles"] = e.cycles_done
            result.timing = self._timing_summary(e)
            if result.realtime_notes and self.mode == "realtime":
                self._event(t_end, "realtime_setup", result.realtime_notes, 0.0)
        if result.error:
            self._event(t_end, "error", result.error, 0.0)
        if link is not None:
            link.close()
        try:
            if hasattr(self, "session") and not stopped:
                self.session.command(Command.STOP)
        except (LinkError, OSError):
            pass
        code = opened.close()
        capture = getattr(opened.link, "capture_written", None)   # CAN: the candump log
        if capture is not None:
            rec.metadata("sidecar.log", dict(capture, run_id=self.run_id))
        stats = getattr(opened.stub, "target_stats", None)
        if stats is not None:
            result.target = stats.as_metadata()
            rec.metadata("target", result.target)
        if opened.stub is not None and code not in (0, None):
            message = opened.stub.death_message()
            self._event(t_end, "stub_exit", message, float(code))
            if result.error is None:   # e.g. a sanitizer report at exit: never a silent pass
                result.error = f"after the run: {message}"
        result.wall_s = time.monotonic() - t0
        rec.metadata("run_result", {
            "cycles_done": result.cycles_done, "cycles_planned": result.cycles_planned,
            "error": result.error or "", "interrupted": result.interrupted,
            "end": result.end, "wall_s": f"{result.wall_s:.3f}",
            "rows_dropped": rec.dropped,
            "timing": json.dumps(result.timing),
            "counters": json.dumps(result.link_stats),
            "faults": faults})

    def _timing_summary(self, e: eng.Engine) -> dict:
        out = {"cycle_p50_us": e.percentile("cycle", 0.5), "cycle_p99_us": e.percentile("cycle", 0.99),
               "cycle_p999_us": e.percentile("cycle", 0.999), "cycle_max_us": e.hist_max("cycle")}
        if self.mode == "realtime":
            c = e.counters()
            out.update(jitter_p50_us=e.percentile("jitter", 0.5),
                       jitter_p99_us=e.percentile("jitter", 0.99),
                       jitter_p999_us=e.percentile("jitter", 0.999),
                       jitter_max_us=e.hist_max("jitter"),
                       missed=c["missed_duty"], late=c["late_duty"],
                       overruns=c["rt_overruns"],
                       miss_rate=c["missed_duty"] / max(e.cycles_done, 1),
                       lost_rate=(c["missed_duty"] + c["rt_overruns"]) / max(e.cycles_done, 1))
        return out


def _with_replaced(exc: BaseException, res: Reservation) -> BaseException:
    """``exc`` with what a --force run did with the previous recording (moved aside: a run that
    fails never leaves it at --out) appended to its message, when it is the bench's own error."""
    if not res.replaced or not isinstance(exc, BenchError):
        return exc
    try:
        return type(exc)(f"{exc}{res.replaced_text()}")
    except Exception:  # noqa: BLE001 - an error type with another signature: as it is
        return exc


def _stub_failure(stub) -> str | None:
    """If the stub died, that is the cause of a failed link (give it a moment)."""
    deadline = time.monotonic() + 0.5
    while stub.alive() and time.monotonic() < deadline:
        time.sleep(0.01)
    return None if stub.alive() else stub.death_message()


class _Progress:
    """A rich progress bar on stderr (silent when stderr is not a terminal)."""

    def __init__(self, total: int, name: str):
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
        )

        console = Console(stderr=True)
        self.enabled = console.is_terminal
        self.progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(),
                                 MofNCompleteColumn(), TextColumn("{task.fields[speed]}"),
                                 TimeElapsedColumn(), console=console, transient=True,
                                 disable=not self.enabled)
        self.progress.start()
        self.task = self.progress.add_task(name, total=total, speed="")

    def update(self, done: int, speed_rpm: float) -> None:
        self.progress.update(self.task, completed=done, speed=f"{speed_rpm:7.1f} rpm")

    def close(self, done: int) -> None:
        self.progress.update(self.task, completed=done)
        self.progress.stop()


def new_live_inbox() -> mmap.mmap:
    """The operator inputs' mailbox (live.h): shared with the recorder process (its live view
    pushes what a viewer published), read by the engine at the start of each cycle."""
    from hil_bench.plant_rt._plant_c import ffi as _ffi, lib as _lib

    mem = mmap.mmap(-1, int(_lib.live_inbox_size()))   # MAP_SHARED | MAP_ANONYMOUS: survives fork
    if _lib.live_inbox_format(_ffi.from_buffer(mem), len(mem)) != 0:
        raise RunAborted("cannot format the operator inputs' mailbox")
    return mem


def run_scenario(scenario: Scenario, link_spec: str = "stub", out_path: Path | None = None,
                 progress: bool = True, stub_args: tuple[str, ...] = (),
                 allow_slow_link: bool = False, force: bool = False,
                 realtime: bool | None = None, cpu: int | None = None,
                 record: bool = True, live=None, pace: float | None = None,
                 on_live=None, on_link_note=None) -> RunResult:
    """Run a scenario against the controller on ``link_spec`` and record it (lockstep, or real
    time when the scenario or ``realtime=True`` asks). ``live``, ``pace``: see
    :class:`Runner`; ``on_live(port)`` is called once the live view listens,
    ``on_link_note(text)`` with each note the link makes about itself (RunResult.link_notes)."""
    runner = Runner(scenario, link_spec, out_path, progress, stub_args, allow_slow_link, force,
                    realtime, record, cpu, live=live, pace=pace)
    runner.on_live = on_live
    runner.on_link_note = on_link_note
    return runner.run()


if __name__ == "__main__":  # pragma: no cover
    sys.exit("use: python -m hil_bench run SCENARIO")
