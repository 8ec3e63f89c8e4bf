"""Python side of the C cycle engine (plant_rt/c/engine.h): set a run up, start it, read it.

    eng = Engine(plant, ts_s=1e-4, n_cycles=15000, link_fd=fd, ...)
    eng.add_reference(Estimator.SMO_SIGN, est)       # a firmware_stub estimator wrapper
    eng.add_event(cycle, kind, ...)
    eng.start()                                       # a thread; the GIL is released in C
    while eng.running(): ... eng.cycles_done ...
    eng.join(); eng.end, eng.message, eng.counters()

Everything per cycle happens in C; this module only fills the configuration (with the wire
constants read from the DBC, so the engine encodes exactly what protocol/messages.py encodes)
and reads the results.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass

from hil_bench.protocol.messages import DUTY_RAW_OFF, MESSAGES, Fault, SenseAuxFlag, State

from ._plant_c import ffi, lib

LOCKSTEP, REALTIME = 0, 1
#: engine_source_t: the live loop, or a replay (plant_rt/c/engine.h)
SOURCE = {"plant": 0, "replay_controller": 1, "replay_plant": 2, "replay_estimators": 3}
DUTY_UPDATE = {"on_arrival": 0, "next_period": 1}
LINK_KIND = {"serial": 0, "can": 1, "canfd": 2}
EV_CMD, EV_LOAD, EV_DYNO_SPEED, EV_NOTE = 0, 1, 2, 3
EV_PLANT_FAULT, EV_PLANT_FAULT_CLEAR, EV_CONTROLLER_RESET = 4, 5, 6
#: link faults (plant_rt/c/engine_faults.h): kinds and directions
LINK_FAULT_KIND = {"drop": 1, "duplicate": 2, "reorder": 3, "bitflip": 4, "delay": 5, "stall": 6,
                   "garbage": 7}

#: what one engine holds (plant_rt/c/engine.h): scheduled events (a scenario event is one per
#: thing it sets, a plant fault one, two with until_s, a controller reset one), link faults, and
#: faults with a trace (every [[faults]] entry)
MAX_EVENTS = int(lib.ENGINE_MAX_EVENTS)
MAX_LINK_FAULTS = int(lib.ENGINE_MAX_LINK_FAULTS)
MAX_TRACES = int(lib.ENGINE_MAX_TRACES)

END_NAMES = {0: "DONE", 1: "STOPPED", 2: "LINK", 3: "NO_DUTY", 4: "CONTROLLER_FAULT",
             5: "BAD_DUTIES", 6: "WATCHDOG", 7: "PLANT", 8: "CONFIG", 9: "PROTOCOL"}
END_DONE, END_STOPPED, END_CONTROLLER_FAULT, END_WATCHDOG = 0, 1, 4, 6

COUNTERS = ("seq_mismatch", "bad_duties", "telem_missing", "unknown_ids", "heartbeats_rx",
            "length_errors", "duplicates", "stale_frames", "retries", "late_duty", "missed_duty",
            "estimator_mismatch", "rows_dropped", "rt_overruns", "ctrl_rx_errors", "ctrl_resets",
            "ctrl_faults", "duties_after_trip", "faults_injected", "faults_untraced",
            "faults_acted", "faults_traced", "state_rows", "late_answers", "lost_frames",
            "resend_answers")


def _signal(cfg_sig, msg: str, name: str) -> None:
    s = MESSAGES[msg].signal(name)
    cfg_sig.scale = float(s.scale)
    cfg_sig.offset = float(s.offset)
    cfg_sig.raw_min = float(s.raw_min)
    cfg_sig.raw_max = float(s.raw_max)


def _fill_wire_constants(cfg) -> None:
    """Scaling and ranges of the signals the engine encodes/decodes, from the DBC."""
    _signal(cfg.sig_i, "SENSE", "i_a")
    _signal(cfg.sig_i2, "SENSE_DUAL", "i_a2")
    _signal(cfg.sig_vdc, "SENSE_AUX", "v_dc")
    _signal(cfg.sig_theta, "SENSE_AUX", "theta_enc")
    for attr, (msg, sig) in {"scale_theta_hat": ("TELEM", "theta_hat"),
                             "scale_omega_hat": ("TELEM", "omega_hat"),
                             "scale_e": ("TELEM_EMF", "e_alpha"),
                             "scale_iq_ref": ("TELEM_EMF", "i_q_ref")}.items():
        setattr(cfg, attr, float(MESSAGES[msg].signal(sig).scale))
    for a, b in (("SENSE", "i_b"), ("SENSE", "i_c")):
        assert MESSAGES[a].signal(b).scale == MESSAGES["SENSE"].signal("i_a").scale
    duty = MESSAGES["DUTY"].signal("d_a")
    cfg.duty_raw_full = int(round(1.0 / duty.scale))
    cfg.duty_raw_off = int(DUTY_RAW_OFF)
    cfg.aux_flag_theta_valid = int(SenseAuxFlag.THETA_ENC_VALID)
    cfg.aux_flag_dual_follows = int(SenseAuxFlag.DUAL_FOLLOWS)
    for st in State:
        if 0 <= st.value < 16:
            cfg.state_names[st.value] = st.name.encode()[:23]


def _struct_dtype(ctype: str):
    """numpy dtype with the exact memory layout of a C struct of the engine."""
    import numpy as np

    names, formats, offsets = [], [], []
    for name, f in ffi.typeof(ctype).fields:
        t = f.type
        shape = ()
        if t.kind == "array":
            shape = (t.length,)
            t = t.item
        base = {"double": "<f8", "uint32_t": "<u4", "int32_t": "<i4", "uint16_t": "<u2",
                "uint8_t": "u1"}[t.cname]
        names.append(name)
        formats.append((base, shape) if shape else base)
        offsets.append(f.offset)
    return np.dtype({"names": names, "formats": formats, "offsets": offsets,
                     "itemsize": ffi.sizeof(ctype)})


#: numpy layouts of engine_replay_cycle_t / engine_replay_frame_t (fill them, hand them over)
REPLAY_CYCLE_DTYPE = _struct_dtype("engine_replay_cycle_t")
REPLAY_FRAME_DTYPE = _struct_dtype("engine_replay_frame_t")


@dataclass
class EngineResult:
    end: int
    end_name: str
    message: str
    cycles_done: int
    counters: dict[str, int]
    fault_code: int
    fault_seq: int
    fault_detail: int
    rt_fifo: bool
    rt_mlock: bool
    rt_pinned: bool
    rt_notes: str

    def end_text(self) -> str:
        """The engine's end message; for a controller fault with the fault's name, the cycle
        (seq) the controller reported it in and its detail (FAULT_CTRL)."""
        if self.end != END_CONTROLLER_FAULT:
            return self.message
        try:
            name = Fault(self.fault_code).name
        except ValueError:
            name = f"unknown code {self.fault_code}"
        return (f"{self.message}: controller reported fault {name} at seq {self.fault_seq} "
                f"(detail {self.fault_detail})")


class Engine:
    """One run of the C cycle engine over a plant and a link file descriptor."""

    def __init__(self, plant, *, ts_s: float, n_cycles: int, link_fd: int = -1,
                 link_kind: str = "serial", mode: int = LOCKSTEP, ring=None,
                 channels: dict[str, int] | None = None, source: str = "plant",
                 replay_cycles=None, replay_frames=None, sil=None, **options):
        """``plant``: a plant_rt Plant (None for the replays without one). ``sil``: a
        ``sil_port_t *`` (bench/loop/links/sil.py): the controller runs in this process, on the
        engine's thread, instead of behind ``link_fd``. ``source`` and
        the replay arrays (REPLAY_CYCLE_DTYPE / REPLAY_FRAME_DTYPE): see engine.h "Replay";
        with a replay, n_cycles is the number of rows."""
        cfg = ffi.new("engine_config_t *")
        lib.engine_default_config(cfg)
        _fill_wire_constants(cfg)
        cfg.mode = mode
        cfg.ts_s = ts_s
        cfg.n_cycles = n_cycles
        cfg.link_fd = link_fd
        cfg.link_kind = LINK_KIND[link_kind]
        if sil is not None:
            lib.engine_sil_peer(sil, ffi.addressof(cfg, "link_peer"))
        for key, value in options.items():
            if key == "duty_update":
                value = DUTY_UPDATE[value]
            if not hasattr(cfg, key):
                raise TypeError(f"engine: unknown option {key!r}")
            setattr(cfg, key, value)
        for name, index in (channels or {}).items():
            setattr(cfg, name, index)
        cfg.source = SOURCE[source]
        self._replay = []
        if replay_cycles is not None:
            if replay_cycles.dtype != REPLAY_CYCLE_DTYPE or len(replay_cycles) < n_cycles:
                raise ValueError("replay_cycles: need REPLAY_CYCLE_DTYPE rows, one per cycle")
            self._replay.append(replay_cycles)
            cfg.replay_cycles = ffi.cast("const engine_replay_cycle_t *",
                                         ffi.from_buffer(replay_cycles))
        if replay_frames is not None:
            if replay_frames.dtype != REPLAY_FRAME_DTYPE:
                raise ValueError("replay_frames: need REPLAY_FRAME_DTYPE rows")
            self._replay.append(replay_frames)
            cfg.replay_frames = ffi.cast("const engine_replay_frame_t *",
                                         ffi.from_buffer(replay_frames))
            cfg.replay_n_frames = len(replay_frames)
        self._cfg = cfg
        self._sil = sil
        self._plant = plant
        self._e = ffi.new("engine_t *")
        self._ring = ring
        ring_mem = ffi.NULL
        ring_size = 0
        if ring is not None:
            ring_mem = ffi.from_buffer(ring)
            ring_size = len(ring)
        self._ring_mem = ring_mem
        c_plant = plant.c_plant if plant is not None else ffi.NULL
        if lib.engine_init(self._e, cfg, c_plant, ring_mem, ring_size) != 0:
            raise ValueError(ffi.string(self._e.message).decode())
        self._thread: threading.Thread | None = None
        self._keep: list = []

    @property
    def c(self):
        """The live engine_t (counters while it runs)."""
        return self._e

    def add_reference(self, kind: int, estimator, channel: int) -> None:
        """A firmware_stub estimator wrapper's configuration, run by the engine on its own state."""
        from hil_bench.firmware_stub._binding import ffi as fw_ffi

        cfg = estimator._cfg
        data = bytes(fw_ffi.buffer(cfg))
        if lib.eng_ref_config_size(kind) != len(data):
            raise ValueError(f"reference estimator kind {kind}: configuration size {len(data)} "
                             f"does not match the engine's ({lib.eng_ref_config_size(kind)})")
        if lib.engine_add_reference(self._e, kind, data, len(data), channel) != 0:
            raise ValueError(ffi.string(self._e.message).decode())

    def add_event(self, cycle: int, kind: int, *, command: int = 0, value: float = 0.0,
                  text: str | None = None, record_value: float = 0.0) -> None:
        """An event at a cycle; with ``text`` it also writes an /events row (record_value)."""
        ev = ffi.new("engine_event_t *")
        ev.cycle = cycle
        ev.kind = kind
        ev.command = command
        ev.value = value
        ev.record = 1 if text is not None else 0
        ev.record_value = record_value
        ev.text = (text or "").encode()[:95]
        if lib.engine_add_event(self._e, ev) != 0:
            raise ValueError(ffi.string(self._e.message).decode())

    def add_fault_event(self, cycle: int, kind: int, *, index: int, name: str,
                        fault_kind: int = 0, phase: int = 0, phase2: int = 0, level: int = 0,
                        value: float = 0.0, detect_within_s: float = 0.2,
                        text: str = "") -> None:
        """A plant fault switched on (EV_PLANT_FAULT) or off (EV_PLANT_FAULT_CLEAR), or a
        controller reset (EV_CONTROLLER_RESET: CMD RESTART with the frames of that cycle), at a
        cycle; ``index`` is the scenario's [[faults]] entry, whose trace the engine records on
        /faults."""
        ev = ffi.new("engine_event_t *")
        ev.cycle = cycle
        ev.kind = kind
        ev.command = 0
        ev.value = value
        ev.record = 0
        ev.text = text.encode()[:95]
        ev.fault_kind = fault_kind
        ev.fault_phase = phase
        ev.fault_phase2 = phase2
        ev.fault_level = level
        ev.fault_index = index
        ev.fault_name = name.encode()[:23]
        ev.detect_within_s = detect_within_s
        if lib.engine_add_event(self._e, ev) != 0:
            raise ValueError(ffi.string(self._e.message).decode())

    def attach_inbox(self, mem) -> None:
        """Take operator inputs from a live view's mailbox (``mem``: a formatted MAP_SHARED
        mapping, live.h), at the start of each cycle. The mapping must outlive the run."""
        self._inbox_mem = mem
        if lib.engine_attach_inbox(self._e, ffi.from_buffer(mem), len(mem)) != 0:
            raise ValueError(ffi.string(self._e.message).decode())

    def add_full_rate(self, from_cycle: int, to_cycle: int) -> None:
        """Cycles [from_cycle, to_cycle) recorded in full in a decimated recording."""
        if lib.engine_add_full_rate(self._e, int(from_cycle), int(to_cycle)) != 0:
            raise ValueError(ffi.string(self._e.message).decode())

    def add_link_fault(self, *, index: int, name: str, kind: str, direction: int,
                       frame_id: int = -1, cycle_on: int, cycle_off: int = 0, count: int = 0,
                       probability: float = 1.0, delay_s: float = 0.0, jitter_s: float = 0.0,
                       stall_s: float = 0.0, n_garbage: int = 0, seed: int = 1,
                       detect_within_s: float = 0.2) -> None:
        """A link fault the engine injects (plant_rt/c/engine_faults.h)."""
        f = ffi.new("engine_link_fault_t *")
        f.lf.kind = LINK_FAULT_KIND[kind]
        f.lf.direction = direction
        f.lf.frame_id = frame_id
        f.lf.cycle_on = cycle_on
        f.lf.cycle_off = cycle_off
        f.lf.count = count
        f.lf.probability = probability
        f.lf.delay_s = delay_s
        f.lf.jitter_s = jitter_s
        f.lf.stall_s = stall_s
        f.lf.n_garbage = n_garbage
        f.lf.seed = seed
        f.fault_index = index
        f.name = name.encode()[:23]
        f.detect_within_s = detect_within_s
        if lib.engine_add_link_fault(self._e, f) != 0:
            raise ValueError(ffi.string(self._e.message).decode())

    def preload_link_counters(self, deframer: dict[str, int] | None = None,
                              link: dict[str, int] | None = None) -> None:
        """Counters of the set-up phase (handshake, CONFIG), so the engine's are cumulative."""
        for k, v in (deframer or {}).items():
            setattr(self._e.link.deframer, k, int(v))
        for k, v in (link or {}).items():
            if hasattr(self._e.link.c, k):
                setattr(self._e.link.c, k, int(v))

    def hand_over(self, partial_bytes: bytes = b"", frames=()) -> None:
        """What the Python link had received but not used when the engine takes over: the
        partial frame its deframer held (serial) and frames it had decoded."""
        link = ffi.addressof(self._e, "link")
        for fid, payload in frames:
            lib.eng_link_push(link, fid, bytes(payload), len(payload))
        if partial_bytes:
            lib.eng_link_feed(link, partial_bytes, len(partial_bytes))

    # -- running ---------------------------------------------------------------------------
    def run(self) -> int:
        """Run in this thread (blocks; the GIL is released while C runs)."""
        return lib.engine_run(self._e)

    def start(self) -> None:
        self._thread = threading.Thread(target=self.run, name="hil-engine", daemon=True)
        self._thread.start()

    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def join(self, timeout: float | None = None) -> bool:
        if self._thread is not None:
            self._thread.join(timeout)
            return not self._thread.is_alive()
        return True

    def request_stop(self) -> None:
        lib.engine_request_stop(self._e)

    @property
    def cycles_done(self) -> int:
        return int(self._e.cycles_done)

    @property
    def speed_rpm(self) -> float:
        return float(self._e.speed_rpm)

    def send(self, frame_id: int, payload: bytes) -> bool:
        """One frame on the engine's link after the run (counted with the run's frames)."""
        return lib.engine_send(self._e, frame_id, payload, len(payload)) == 0

    def write_stats(self, t_s: float, extra: dict[str, int] | None = None) -> None:
        ex = ffi.NULL
        if extra:
            ex = ffi.new("eng_link_counters_t *")
            for k, v in extra.items():
                if hasattr(ex, k):
                    setattr(ex, k, int(v))
        lib.engine_write_stats(self._e, t_s, ex)

    def counters(self) -> dict[str, int]:
        e = self._e
        out = {k: int(getattr(e.n, k)) for k in COUNTERS}
        d = e.link.deframer
        for k in ("frames_ok", "crc_errors", "cobs_errors", "overruns", "bytes_discarded"):
            out[k] = int(getattr(d, k))
        out["length_errors"] += int(d.length_errors)
        for k in ("frames_tx", "frames_rx", "bytes_tx", "bytes_rx", "error_frames",
                  "remote_frames", "rx_malformed", "send_failures", "bus_state_changes"):
            out[k] = int(getattr(e.link.c, k))
        out["can_unknown_ids"] = int(e.link.c.ext_ids)
        return out

    def fault_states(self) -> list[dict]:
        """What became of each fault of the run (the engine's own account, engine_trace_t): the
        first action's cycle (-1: it never acted), the first evidence's (-1: none), the detection
        windows closed and those without evidence, whether the plant refused it, and for a link
        fault the frames that met its window and message and those it acted on."""
        out = []
        for index in range(MAX_TRACES):
            t = self._e.traces[index]
            if not t.planned:
                continue
            out.append({"index": index, "name": ffi.string(t.name).decode(errors="replace"),
                        "target": ffi.string(t.target).decode(errors="replace"),
                        "acted_cycle": int(t.acted_k), "evidence_cycle": int(t.evidence_k),
                        "windows": int(t.windows), "untraced_windows": int(t.untraced_windows),
                        "refused": bool(t.refused), "matched": int(t.matched),
                        "acted": int(t.acted)})
        return out

    def percentile(self, which: str, q: float) -> float:
        h = self._e.hist_cycle if which == "cycle" else self._e.hist_jitter
        return float(lib.engine_hist_percentile(ffi.addressof(h), q))

    def hist_max(self, which: str) -> float:
        h = self._e.hist_cycle if which == "cycle" else self._e.hist_jitter
        return float(h.max_us)

    def result(self) -> EngineResult:
        e = self._e
        return EngineResult(
            end=int(e.end), end_name=END_NAMES.get(int(e.end), str(int(e.end))),
            message=ffi.string(e.message).decode(errors="replace"),
            cycles_done=int(e.cycles_done), counters=self.counters(),
            fault_code=int(e.fault_code), fault_seq=int(e.fault_seq),
            fault_detail=int(e.fault_detail), rt_fifo=bool(e.rt_fifo),
            rt_mlock=bool(e.rt_mlock), rt_pinned=bool(e.rt_pinned),
            rt_notes=ffi.string(e.rt_notes).decode(errors="replace"))

    @property
    def cmd_seq(self) -> int:
        return int(self._e.cmd_seq)
