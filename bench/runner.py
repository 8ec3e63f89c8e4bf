"""Lockstep runner: the plant advances one PWM period per DUTY frame the controller returns.

One cycle k (docs/architecture.md):
  plant state at t_k -> sensor model -> SENSE_AUX(k), SENSE(k) -> controller ISR ->
  TELEM(k) [TELEM_EMF(k)] DUTY(k) -> validate duties -> plant.step (the new duties act from
  t_k + t_delay) -> record.

Every exit path (normal end, controller fault, dead or silent stub, Ctrl-C) finalises the MCAP
recording and returns a RunResult that says what happened.
"""
from __future__ import annotations

import json
import math
import operator
import platform
import subprocess
import sys
import time
import traceback
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from plant_rt.plant import Plant
from plant_rt.profile import load_profile
from protocol.messages import (DUTY_RAW_OFF, MESSAGES, Command, Estimator, HelloFlag, Param,
                               SenseAuxFlag, State)

from . import channels as ch
from .host_session import HostSession, fault_from_payload
from .links import LinkError, OpenedLink, open_link
from .recorder import ProcessRecorder
from .scenario import RPM_PER_RAD_S, Scenario

REPO_ROOT = Path(__file__).resolve().parents[1]
CYCLE_TIMEOUT_S = 0.5       # a controller silent this long ends the run (well within 1 s)
POLL_SLICE_S = 0.05         # how often a wait checks that the stub is still alive
MAX_CONSECUTIVE_BAD_DUTIES = 10
STATS_EVERY_CYCLES = 1000
TWO_PI = 2.0 * math.pi

_SENSE = MESSAGES["SENSE"]
_SENSE_AUX = MESSAGES["SENSE_AUX"]
_SENSE_DUAL = MESSAGES["SENSE_DUAL"]
_DUTY = MESSAGES["DUTY"]
_TELEM = MESSAGES["TELEM"]
_TELEM_EMF = MESSAGES["TELEM_EMF"]
_FAULT_CTRL = MESSAGES["FAULT_CTRL"]
_HEARTBEAT_CTRL = MESSAGES["HEARTBEAT_CTRL"]
#: DBC length of every frame the loop decodes: a frame of another length is counted, not decoded
CYCLE_LENGTHS = {m.frame_id: m.length for m in (_DUTY, _TELEM, _TELEM_EMF, _FAULT_CTRL)}
DUTY_RAW_FULL = 32768   # raw value of duty 1.0 (scale 1/32768)


class RunAborted(RuntimeError):
    """The run could not continue; the message says why and where."""


@dataclass
class RunResult:
    scenario: str
    recording: Path
    cycles_done: int
    cycles_planned: int
    error: str | None = None
    interrupted: bool = False
    wall_s: float = 0.0
    link_stats: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.error is None and not self.interrupted


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
    from firmware_stub.est_smo import smo_sigmoid_for, smo_tanh_for

    factory = smo_sigmoid_for if estimator is Estimator.SMO_SIGMOID else smo_tanh_for
    chosen = {f: given[p] for f, p in SMO_CONFIG_PARAMS.items() if p in given}
    config = factory(profile, ts_s, **chosen).config
    return {p: float(config[f]) for f, p in SMO_CONFIG_PARAMS.items()
            if f in config and p not in given}


def git_revision() -> str:
    try:
        rev = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO_ROOT, capture_output=True,
                             text=True, timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=REPO_ROOT, capture_output=True, text=True,
                               timeout=5).stdout.strip()
        return (rev or "unknown") + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def default_recording_path(scenario: Scenario) -> Path:
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path("recordings") / f"{scenario.name}-{stamp}.mcap"


def _wrap_pi(x: float) -> float:
    return (x + math.pi) % TWO_PI - math.pi


INV_SQRT3 = 1.0 / math.sqrt(3.0)


def _duties_to_alphabeta(duties: tuple[float, float, float],
                         v_dc_v: float) -> tuple[float, float] | None:
    """Alpha-beta voltage an averaged inverter realises from duties (None if a leg is off)."""
    da, db, dc = duties
    if da < 0.0 or db < 0.0 or dc < 0.0:
        return None
    return ((2.0 * da - db - dc) * (v_dc_v / 3.0), (db - dc) * (v_dc_v * INV_SQRT3))


def _frames_text(frames: list[tuple[int, bytes]]) -> str:
    return " ".join(f"{fid:03X}#{payload.hex().upper()}" for fid, payload in frames)


class LockstepRunner:
    def __init__(self, scenario: Scenario, link_spec: str = "stub", out_path: Path | None = None,
                 progress: bool = True, stub_args: tuple[str, ...] = (),
                 allow_slow_link: bool = False):
        self.scn = scenario
        self.allow_slow_link = allow_slow_link
        self.link_spec = link_spec
        self.out_path = Path(out_path) if out_path else default_recording_path(scenario)
        self.progress = progress
        self.stub_args = stub_args
        self.profile = load_profile(scenario.profile)
        self.plant = Plant(self.profile, **scenario.plant_overrides)
        self.ts_s = float(self.plant.params.ts_s)
        self.n_cycles = int(round(scenario.duration_s / self.ts_s))
        self.counters = {k: 0 for k in ("seq_mismatch", "bad_duties", "telem_missing",
                                        "unknown_ids", "heartbeats_rx", "length_errors")}
        self.cycle_wall_ns = np.zeros(self.n_cycles, dtype=np.int64)
        self.references = self._make_references()

    def _make_references(self) -> list[tuple[str, object]]:
        """The reference estimators the scenario names, built from the same C library."""
        if not self.scn.reference_estimators:
            return []
        from firmware_stub.estimators import REFERENCE_ESTIMATORS

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
            out.append((entry, est))
        return out

    # -- controller configuration -----------------------------------------------------------
    def controller_params(self) -> dict[Param, float]:
        params = motor_params(self.profile)
        # the stub stands for a DSP whose computation delay is the one the plant emulates
        params[Param.CTRL_DELAY_S] = float(self.plant.params.t_delay_s)
        params.update(estimator_defaults(self.scn.estimator, self.profile, self.ts_s,
                                         self.scn.controller_params))
        params.update(self.scn.controller_params)
        return params

    def hello_flags(self) -> int:
        flags = HelloFlag.ENCODER_VALID
        if self.plant.params.dual_sampling:
            flags |= HelloFlag.DUAL_SAMPLING
        if self.scn.telemetry_emf:
            flags |= HelloFlag.TELEM_EMF
        return int(flags)

    # -- the run --------------------------------------------------------------------------
    def run(self) -> RunResult:
        scn = self.scn
        result = RunResult(scn.name, self.out_path, 0, self.n_cycles)
        t0 = time.monotonic()
        opened: OpenedLink | None = None
        with ProcessRecorder(self.out_path) as rec:
            self._open_channels(rec)
            try:
                opened = open_link(self.link_spec, self.stub_args,
                                   capture_path=self.out_path.with_suffix(".log"))
                self._check_budget(opened)
                self._write_metadata(rec, opened)
                self._start_controller(opened)
                self._loop(opened, result)
            except KeyboardInterrupt:
                result.interrupted = True
                result.error = f"interrupted by the user at cycle {result.cycles_done}"
            except (LinkError, RunAborted) as exc:
                result.error = str(exc)
            except Exception as exc:  # noqa: BLE001 - a bug must still leave a readable recording
                traceback.print_exc()
                result.error = (f"internal error at cycle {result.cycles_done}: "
                                f"{type(exc).__name__}: {exc}")
            finally:
                t_end = result.cycles_done * self.ts_s
                if result.error:
                    self.ch_events.write(t_end, {"t_s": t_end, "kind": "error",
                                                 "text": result.error, "value": 0.0})
                if opened is not None:
                    self._shutdown(opened, result)
                    result.link_stats = self._write_stats(t_end, opened, result.cycles_done)
                result.wall_s = time.monotonic() - t0
                rec.metadata("run_result", {
                    "cycles_done": result.cycles_done, "cycles_planned": result.cycles_planned,
                    "error": result.error or "", "interrupted": result.interrupted,
                    "wall_s": f"{result.wall_s:.3f}"})
        return result

    def _open_channels(self, rec: ProcessRecorder) -> None:
        self.rec = rec
        self.ch_state = rec.channel(ch.PLANT_STATE, ch.PLANT_STATE_SCHEMA, ch.PLANT_STATE_VALUES)
        self.ch_sense = rec.channel(ch.PLANT_SENSE, ch.PLANT_SENSE_SCHEMA, ch.PLANT_SENSE_VALUES)
        self.ch_telem = rec.channel(ch.CONTROLLER_TELEMETRY, ch.TELEMETRY_SCHEMA,
                                    ch.TELEMETRY_VALUES)
        self.ch_frames = rec.channel(ch.LINK_FRAMES, ch.FRAMES_SCHEMA, ch.FRAMES_VALUES)
        self.ch_refs = [rec.channel(ch.REFERENCE_PREFIX + name, ch.REFERENCE_SCHEMA,
                                    ch.REFERENCE_VALUES) for name, _ in self.references]
        self.ch_stats = rec.channel(ch.LINK_STATS, ch.LINK_STATS_SCHEMA)
        self.ch_events = rec.channel(ch.EVENTS, ch.EVENTS_SCHEMA)
        self._setup_frames: list[tuple[str, int, bytes]] = []

    def _check_budget(self, opened: OpenedLink) -> None:
        rate_hz = 1.0 / self.ts_s
        max_hz = opened.link.max_cycle_rate_hz(self.hello_flags())
        if rate_hz > max_hz:
            if self.allow_slow_link:
                # lockstep does not need the link to keep up: the run is slower than real time
                self.ch_events.write(0.0, {
                    "t_s": 0.0, "kind": "link_budget", "value": max_hz,
                    "text": f"{opened.link.description} fits at most {max_hz:.0f} Hz; lockstep "
                            f"at {rate_hz:.0f} Hz runs slower than real time"})
                return
            raise RunAborted(
                f"{opened.link.description} cannot carry this scenario: {rate_hz:.0f} Hz control "
                f"rate needed (Ts = {self.ts_s * 1e6:g} us) but the link fits at most "
                f"{max_hz:.0f} Hz with these frames; use a faster link or a longer period "
                f"(or, in lockstep, --allow-slow-link to run slower than real time)")

    def _write_metadata(self, rec: ProcessRecorder, opened: OpenedLink) -> None:
        import cffi
        import mcap

        scn, prof = self.scn, self.profile
        stub = opened.stub
        rec.metadata("run", {
            "scenario": scn.name,
            "scenario_path": scn.display_path,
            "profile": prof.name,
            "profile_path": str(prof.path),
            "mode": scn.mode,
            "link": opened.link.description,
            "controller": f"hil_stub {stub.executable}" if stub is not None else self.link_spec,
            "git_revision": git_revision(),
            "python": platform.python_version(),
            "numpy": np.__version__,
            "mcap": getattr(mcap, "__version__", "?"),
            "cffi": cffi.__version__,
            "host": platform.node(),
            "start_utc": datetime.utcnow().isoformat(timespec="seconds") + "Z",
            "ts_s": repr(self.ts_s),
            "cycles_planned": str(self.n_cycles),
            "plant_params": json.dumps(self.plant.params.as_dict()),
            "controller_params": json.dumps({p.name: v for p, v in
                                             self.controller_params().items()}),
            "estimator": scn.estimator.name,
            "reference_estimators": json.dumps({n: scn.reference_config.get(n, {})
                                                for n in scn.reference_estimators}),
            "metrics_window_s": json.dumps(list(scn.metrics_window_s)),
            "claims": json.dumps(list(scn.claims)),
        })
        rec.attachment(f"scenario/{scn.path.name}", "application/toml", scn.text.encode())
        rec.attachment(f"profile/{Path(prof.path).name}", "application/toml",
                       Path(prof.path).read_bytes())

    def _log_setup_frame(self, direction: str, fid: int, payload: bytes) -> None:
        self._setup_frames.append((direction, fid, payload))

    def _start_controller(self, opened: OpenedLink) -> None:
        stub = opened.stub
        self.session = HostSession(
            opened.link, on_frame=self._log_setup_frame,
            alive=(stub.alive if stub is not None else None),
            death_message=(stub.death_message if stub is not None else None))
        ack = self.session.handshake(period_s=self.ts_s, estimator=int(self.scn.estimator),
                                     flags=self.hello_flags())
        self.ch_events.write(0.0, {"t_s": 0.0, "kind": "handshake",
                                   "text": f"controller fw 0x{int(ack['fw_version']):04X}, "
                                           f"estimators mask 0x{int(ack['estimators']):04X}",
                                   "value": float(ack["fw_version"])})
        self.session.configure(self.controller_params())
        self.session.command(Command.SET_SPEED_REF, self.scn.speed_ref_rad_s)
        self.session.command(Command.RUN)
        setup = [f"{d}:{fid:03X}#{p.hex().upper()}" for d, fid, p in self._setup_frames]
        self.ch_frames.write_values(0.0, (0.0, -1, " ".join(
            s[3:] for s in setup if s.startswith("tx:")), " ".join(
            s[3:] for s in setup if s.startswith("rx:"))))
        self.session.on_frame = lambda d, i, p: None

    def _apply_event(self, ev, t_s: float, pending_cmds: list) -> None:
        cmd = self.session.command_frame
        if ev.speed_ref_rad_s is not None:
            pending_cmds.append(cmd(Command.SET_SPEED_REF, ev.speed_ref_rad_s))
        if ev.iq_ref_a is not None:
            pending_cmds.append(cmd(Command.SET_IQ_REF, ev.iq_ref_a))
        if ev.id_ref_a is not None:
            pending_cmds.append(cmd(Command.SET_ID_REF, ev.id_ref_a))
        if ev.control_mode is not None:
            pending_cmds.append(cmd(Command.SET_CONTROL_MODE,
                                    1.0 if ev.control_mode == "current" else 0.0))
        if ev.load_torque_nm is not None:
            self.plant.set_load_torque(ev.load_torque_nm)
        self.ch_events.write(t_s, {"t_s": t_s, "kind": "scenario", "text": ev.describe(),
                                   "value": ev.speed_ref_rad_s if ev.speed_ref_rad_s is not None
                                   else (ev.load_torque_nm or 0.0)})

    def _loop(self, opened: OpenedLink, result: RunResult) -> None:
        scn, plant, link = self.scn, self.plant, opened.link
        stub = opened.stub
        ts = self.ts_s
        pole_pairs = self.profile.pole_pairs
        rpm_per_rad_s = RPM_PER_RAD_S
        counters = self.counters
        sense_aux_pack, sense_pack = _SENSE_AUX.pack_values, _SENSE.pack_values
        sense_unpack = _SENSE.unpack_values
        duty_raw, telem_values, emf_values = _DUTY.unpack_raw, _TELEM.unpack_values, \
            _TELEM_EMF.unpack_values
        SENSE_ID, AUX_ID = _SENSE.frame_id, _SENSE_AUX.frame_id
        DUTY_ID, TELEM_ID, EMF_ID = _DUTY.frame_id, _TELEM.frame_id, _TELEM_EMF.frame_id
        FAULT_ID, HB_ID = _FAULT_CTRL.frame_id, _HEARTBEAT_CTRL.frame_id
        w_state, w_sense = self.ch_state.write_values, self.ch_sense.write_values
        w_telem, w_frames = self.ch_telem.write_values, self.ch_frames.write_values
        snap_values = operator.attrgetter(*ch.PLANT_SNAPSHOT_FIELDS)
        refs = self.references
        ref_writers = [c.write_values for c in self.ch_refs]
        v_ab_prev: tuple[float, float] | None = None
        v_ab_older: tuple[float, float] | None = None
        w_delay = float(self.plant.params.t_delay_s) / ts
        events = list(scn.events)
        plant.set_initial(scn.initial_theta_e_rad, scn.initial_speed_rad_s)
        plant.set_load_torque(scn.initial_load_torque_nm)
        snap = plant.snapshot()
        duties = (0.5, 0.5, 0.5)
        consecutive_bad = 0
        last_state = -1
        aux_flags = int(SenseAuxFlag.THETA_ENC_VALID)
        dual_flag = int(SenseAuxFlag.DUAL_FOLLOWS)
        dual = bool(self.plant.params.dual_sampling)
        dual_pack, DUAL_ID = _SENSE_DUAL.pack_values, _SENSE_DUAL.frame_id
        theta_enc_max = TWO_PI - 0.5 * _SENSE_AUX.signal("theta_enc").scale
        nan = math.nan
        progress = _Progress(self.n_cycles, scn.name) if self.progress else None
        perf_ns = time.perf_counter_ns
        try:
            for k in range(self.n_cycles):
                c0 = perf_ns()
                t_s = k * ts
                pending_cmds: list[tuple[int, bytes]] = []
                while events and events[0].t_s <= t_s + 0.5 * ts:
                    self._apply_event(events.pop(0), t_s, pending_cmds)

                # what the controller's ADC measured (plant sensor model: 12-bit, gain, offset,
                # noise when the scenario turns it on), then the wire's 1 mA / 10 mV scaling
                seq = k & 0xFFFF
                smp = plant.sample()
                v_dc = smp.v_dc_v
                theta = snap.theta_e_rad
                theta_enc = theta if theta < theta_enc_max else 0.0   # 16-bit encoder wraps
                if dual and smp.dual_valid:
                    aux = sense_aux_pack((seq, v_dc, theta_enc, aux_flags | dual_flag))
                    tx = pending_cmds + [(AUX_ID, aux), (DUAL_ID, dual_pack(
                        (seq, smp.i2_a_a, smp.i2_b_a, smp.i2_c_a), saturate=True))]
                else:
                    aux = sense_aux_pack((seq, v_dc, theta_enc, aux_flags))
                    tx = pending_cmds + [(AUX_ID, aux)]
                sense = sense_pack((seq, smp.i_a_a, smp.i_b_a, smp.i_c_a), saturate=True)
                tx.append((SENSE_ID, sense))
                try:
                    link.send(tx)
                except LinkError as exc:
                    raise RunAborted(f"at cycle {k} (t = {t_s:.4f} s): "
                                     + self._link_failure(stub, exc)) from None

                # wait for this cycle's DUTY
                duty = None
                telem = emf = None
                rx: list[tuple[int, bytes]] = []
                deadline = time.monotonic() + CYCLE_TIMEOUT_S
                while duty is None:
                    remaining = deadline - time.monotonic()
                    if remaining <= 0:
                        if stub is not None and not stub.alive():
                            raise RunAborted(f"at cycle {k} (t = {t_s:.4f} s): "
                                             + stub.death_message())
                        raise RunAborted(f"at cycle {k} (t = {t_s:.4f} s): no DUTY from the "
                                         f"controller within {CYCLE_TIMEOUT_S:g} s on "
                                         f"{link.description}")
                    try:
                        frames = link.recv(min(remaining, POLL_SLICE_S))
                    except LinkError as exc:
                        raise RunAborted(f"at cycle {k} (t = {t_s:.4f} s): "
                                         + self._link_failure(stub, exc)) from None
                    if not frames:
                        if stub is not None and not stub.alive():
                            raise RunAborted(f"at cycle {k} (t = {t_s:.4f} s): "
                                             + stub.death_message())
                        continue
                    for fid, payload in frames:
                        rx.append((fid, payload))
                        if fid in CYCLE_LENGTHS and len(payload) != CYCLE_LENGTHS[fid]:
                            counters["length_errors"] += 1    # never decoded, never applied
                            continue
                        if fid == DUTY_ID:
                            raw = duty_raw(payload)
                            if raw[0] != seq:
                                counters["seq_mismatch"] += 1
                                continue
                            duty = raw
                        elif fid == TELEM_ID:
                            v = telem_values(payload)
                            if v[0] == seq:
                                telem = v
                        elif fid == EMF_ID:
                            v = emf_values(payload)
                            if v[0] == seq:
                                emf = v
                        elif fid == FAULT_ID:
                            w_frames(t_s, (t_s, seq, _frames_text(tx), _frames_text(rx)))
                            raise fault_from_payload(payload)
                        elif fid == HB_ID:
                            counters["heartbeats_rx"] += 1
                        else:
                            counters["unknown_ids"] += 1

                # validate the duties: OFF legs allowed, anything else out of range is refused
                new = []
                bad = False
                for r in duty[1:]:
                    if r == DUTY_RAW_OFF:
                        new.append(-1.0)
                    elif 0 <= r <= DUTY_RAW_FULL:
                        new.append(r / DUTY_RAW_FULL)
                    else:
                        bad = True
                if bad:
                    counters["bad_duties"] += 1
                    consecutive_bad += 1
                    self.ch_events.write(t_s, {"t_s": t_s, "kind": "bad_duty",
                                               "text": f"DUTY seq {seq} raw {list(duty[1:])} out "
                                                       f"of range; previous duties held",
                                               "value": float(seq)})
                    if consecutive_bad >= MAX_CONSECUTIVE_BAD_DUTIES:
                        raise RunAborted(f"at cycle {k}: {consecutive_bad} consecutive DUTY "
                                         f"frames out of range; inverter disabled, run ended")
                else:
                    consecutive_bad = 0
                    duties = (new[0], new[1], new[2])

                # record cycle k (state at t_k, what was sent, what came back)
                w_state(t_s, (t_s, *snap_values(snap), snap.omega_m_rad_s * rpm_per_rad_s))
                s_vals = sense_unpack(sense)
                w_sense(t_s, (t_s, seq, s_vals[1], s_vals[2], s_vals[3], v_dc, theta))
                if telem is None:
                    counters["telem_missing"] += 1
                    th_hat = w_hat = nan
                    st = est = -1
                else:
                    th_hat, w_hat, st, est = telem[1], telem[2], int(telem[3]), int(telem[4])
                e_a, e_b, iq_ref = (emf[1], emf[2], emf[3]) if emf is not None else (nan, nan, nan)
                w_telem(t_s, (t_s, seq, th_hat, w_hat, w_hat / pole_pairs * rpm_per_rad_s, st, est,
                              e_a, e_b, iq_ref, duties[0], duties[1], duties[2],
                              _wrap_pi(th_hat - theta)))
                w_frames(t_s, (t_s, seq, _frames_text(tx), _frames_text(rx)))
                if st != last_state and st >= 0:
                    try:
                        name = State(st).name
                    except ValueError:
                        name = str(st)
                    self.ch_events.write(t_s, {"t_s": t_s, "kind": "controller_state",
                                               "text": name, "value": float(st)})
                    last_state = st

                # reference estimators: the currents the controller was sent and the voltage
                # that acted over the last period (the duties of k-2 until t_d, then those of
                # k-1: the plant's computation delay)
                if refs:
                    i_al = (2.0 * s_vals[1] - s_vals[2] - s_vals[3]) * (1.0 / 3.0)
                    i_be = (s_vals[2] - s_vals[3]) * INV_SQRT3
                    if v_ab_prev is not None and v_ab_older is not None:
                        v_al = w_delay * v_ab_older[0] + (1.0 - w_delay) * v_ab_prev[0]
                        v_be = w_delay * v_ab_older[1] + (1.0 - w_delay) * v_ab_prev[1]
                        for (_, est), w_ref in zip(refs, ref_writers):
                            o = est.step(i_al, i_be, v_al, v_be)
                            w_ref(t_s, (t_s, seq, o[0], o[1], o[1] / pole_pairs * rpm_per_rad_s,
                                        o[2], o[3], _wrap_pi(o[0] - theta)))
                    # (legs off: no known voltage, the estimators wait)
                    v_ab_older = v_ab_prev
                    v_ab_prev = _duties_to_alphabeta(duties, v_dc)

                plant.step(*duties)
                snap = plant.snapshot()
                result.cycles_done = k + 1
                self.cycle_wall_ns[k] = perf_ns() - c0
                if (k + 1) % STATS_EVERY_CYCLES == 0:
                    self._write_stats((k + 1) * ts, opened, k + 1)
                    if progress is not None:
                        progress.update(k + 1, snap.omega_m_rad_s * rpm_per_rad_s)
                if not math.isfinite(snap.omega_m_rad_s):
                    raise RunAborted(f"at cycle {k}: plant state became non-finite")
        finally:
            if progress is not None:
                progress.close(result.cycles_done)

    @staticmethod
    def _link_failure(stub, exc: LinkError) -> str:
        """Explain a failed link: if the stub died, say so (it is the cause), else the error."""
        if stub is None:
            return str(exc)
        deadline = time.monotonic() + 0.5
        while stub.alive() and time.monotonic() < deadline:
            time.sleep(0.01)
        return str(exc) if stub.alive() else stub.death_message()

    def _shutdown(self, opened: OpenedLink, result: RunResult) -> None:
        try:
            if hasattr(self, "session"):
                self.session.command(Command.STOP)
        except LinkError:
            pass
        code = opened.close()
        if opened.stub is not None and code not in (0, None):
            t_end = result.cycles_done * self.ts_s
            message = opened.stub.death_message()
            self.ch_events.write(t_end, {"t_s": t_end, "kind": "stub_exit", "text": message,
                                         "value": float(code)})
            if result.error is None:   # e.g. a sanitizer report at exit: never a silent pass
                result.error = f"after the run: {message}"

    def _write_stats(self, t_s: float, opened: OpenedLink, cycles: int) -> dict:
        stats = {k: 0 for k in ch.LINK_STATS_COUNTERS}
        stats.update(opened.link.stats())
        for key, value in self.counters.items():   # the loop's counts add to the link's own
            stats[key] = stats.get(key, 0) + value
        stats["cycles"] = cycles
        walls = self.cycle_wall_ns[:cycles]
        if cycles:
            p50, p99 = np.percentile(walls, [50, 99])
            stats.update(cycle_wall_p50_us=p50 / 1e3, cycle_wall_p99_us=p99 / 1e3,
                         cycle_wall_max_us=float(walls.max()) / 1e3)
        else:
            stats.update(cycle_wall_p50_us=0.0, cycle_wall_p99_us=0.0, cycle_wall_max_us=0.0)
        msg = {k: (int(v) if k in ch.LINK_STATS_COUNTERS else float(v)) for k, v in stats.items()
               if k in ch.LINK_STATS_SCHEMA["properties"]}
        msg["t_s"] = t_s
        self.ch_stats.write(t_s, msg)
        return stats


class _Progress:
    """A rich progress bar on stderr (silent when stderr is not a terminal)."""

    def __init__(self, total: int, name: str):
        from rich.console import Console
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeElapsedColumn)

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


def run_scenario(scenario: Scenario, link_spec: str = "stub", out_path: Path | None = None,
                 progress: bool = True, stub_args: tuple[str, ...] = (),
                 allow_slow_link: bool = False) -> RunResult:
    """Run a scenario in lockstep against the controller on ``link_spec`` and record it."""
    if scenario.mode != "lockstep":
        raise RunAborted(f"{scenario.display_path}: mode {scenario.mode!r} is not implemented")
    return LockstepRunner(scenario, link_spec, out_path, progress, stub_args,
                          allow_slow_link).run()


if __name__ == "__main__":  # pragma: no cover
    sys.exit("use: python -m bench run SCENARIO")
