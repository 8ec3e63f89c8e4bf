"""What every capture reader produces: the cycles of a capture, its frames, and its anomalies.

A *capture* is one logged run of a drive: a bench recording (MCAP), a CAN log, a raw serial byte
capture or a scope/DAQ CSV export (``bench/replay/readers.py``). Whatever the input, it becomes a
:class:`Capture`: one row per control cycle (``hil_bench.plant_rt.engine.REPLAY_CYCLE_DTYPE``: the currents
and bus voltage the controller was sent, the duties it answered, its telemetry, the encoder or
true angle where the capture has one), the uplink frames of each cycle (for replay into a
controller), the recorded controller answers, and every anomaly of the capture counted per kind.

Frames become cycles by the protocol's rules (docs/protocol.md 6.4): the uplink of cycle k is
[CMD...] SENSE_AUX(k) [SENSE_DUAL(k)] SENSE(k), and SENSE closes it; the downlink is TELEM(k)
[TELEM_EMF(k)] DUTY(k). :class:`CycleAssembler` applies them to frames in capture order and never
reorders anything: a frame that does not fit where it stands is counted and left out.

Anomaly kinds (docs/replay.md "Anomalies"):

==================  ===========================================================================
``gaps``            places where whole cycles are missing (the SENSE seq jumps forward);
                    ``cycles_missing`` is how many cycles they hold
``drops``           frames missing from a cycle that is there (no SENSE_AUX, TELEM or DUTY;
                    an uplink group whose SENSE never came)
``duplicates``      a frame of a cycle seen again (lockstep retries re-send SENSE; cached
                    answers); the first one is used
``out_of_order``    a frame that is not where the protocol puts it (a late frame of an earlier
                    cycle, a SENSE seq going backwards, TELEM after DUTY, time going
                    backwards: one event per step back, each frame against the one before
                    it); late frames are left out, never moved
``unknown_ids``     frames whose id is not in protocol/hil.dbc (per id in ``unknown_id_counts``)
``wrong_length``    frames of a known id with another length (never decoded)
``not_protocol``    CAN frames that cannot be the protocol's: 29-bit ids, remote and error frames
``damaged``         octets or records of the file itself that could not be read (serial: CRC,
                    COBS, length errors and overruns of the deframer; CAN logs: bad lines, a
                    cut line, cut or corrupt compression, a short BLF: bench/replay/canlog.py),
                    and a time stamp that jumps forward more than IMPLAUSIBLE_JUMP_S
==================  ===========================================================================
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hil_bench.errors import BenchError
from hil_bench.plant_rt.engine import REPLAY_CYCLE_DTYPE, REPLAY_FRAME_DTYPE
from hil_bench.protocol.messages import BY_ID, DUTY_RAW_OFF, MESSAGES, Command, Param, SenseAuxFlag
from hil_bench.protocol.timing import PATIENCE_S

ANOMALY_KINDS = ("gaps", "cycles_missing", "drops", "duplicates", "out_of_order", "unknown_ids",
                 "wrong_length", "not_protocol", "damaged")
MAX_DETAILS = 50          #: anomalies described one by one (all are counted)
#: a step forward in time between two frames, once the cycles run, that no session makes: lockstep
#: ends a run when the controller answered nothing for patience_s (10 s by default,
#: hil_bench.protocol.timing.PATIENCE_S), a real-time drive sends every Ts. Six times that is a
#: corrupt time stamp or a logger that stopped: damaged.
IMPLAUSIBLE_JUMP_S = 6 * PATIENCE_S

_SENSE = MESSAGES["SENSE"]
_AUX = MESSAGES["SENSE_AUX"]
_DUAL = MESSAGES["SENSE_DUAL"]
_TELEM = MESSAGES["TELEM"]
_EMF = MESSAGES["TELEM_EMF"]
_DUTY = MESSAGES["DUTY"]
_HELLO = MESSAGES["HELLO"]
_CONFIG = MESSAGES["CONFIG"]
_CMD = MESSAGES["CMD"]
UPLINK_CYCLE = {_AUX.frame_id, _DUAL.frame_id, _SENSE.frame_id}
DOWNLINK_CYCLE = {_TELEM.frame_id, _EMF.frame_id, _DUTY.frame_id}
DUTY_RAW_FULL = int(round(1.0 / _DUTY.signal("d_a").scale))
_VDC_DECIMALS = max(0, -int(math.floor(math.log10(float(_AUX.signal("v_dc").scale)) + 1e-9)))

#: recorded controller answer per cycle (NaN / -1 where the capture has none)
TELEM_FIELDS = ("theta_hat_rad", "omega_hat_rad_s", "state", "estimator", "e_alpha_v", "e_beta_v",
                "i_q_ref_a", "duty_a", "duty_b", "duty_c")


class CaptureError(BenchError, ValueError):
    """A capture cannot be replayed at all (the message names the file and the position)."""


@dataclass
class Anomalies:
    """Counts per kind, and the first MAX_DETAILS described with their position."""

    counts: Counter = field(default_factory=Counter)
    details: list[tuple[str, float, str]] = field(default_factory=list)   # kind, t_s, text
    unknown_id_counts: Counter = field(default_factory=Counter)
    wrong_length_counts: Counter = field(default_factory=Counter)

    def add(self, kind: str, text: str, t_s: float = math.nan, n: int = 1) -> None:
        self.counts[kind] += n
        if len(self.details) < MAX_DETAILS:
            self.details.append((kind, t_s, text))

    def as_dict(self) -> dict[str, int]:
        out = {k: int(self.counts.get(k, 0)) for k in ANOMALY_KINDS}
        for k, v in self.counts.items():
            out.setdefault(k, int(v))
        return out

    def summary(self) -> str:
        d = {k: v for k, v in self.as_dict().items() if v}
        if not d:
            return "none"
        text = ", ".join(f"{k} {v}" for k, v in d.items())
        if self.unknown_id_counts:
            text += " (unknown ids: " + ", ".join(
                f"0x{i:03X} x{n}" for i, n in sorted(self.unknown_id_counts.items())) + ")"
        if self.wrong_length_counts:
            text += " (wrong length: " + ", ".join(
                f"{BY_ID[i].name} x{n}" for i, n in sorted(self.wrong_length_counts.items())) + ")"
        return text


@dataclass
class Capture:
    """One capture, ready to replay (see the module docstring)."""

    path: Path
    kind: str                               # "mcap" | "can" | "serial" | "csv"
    ts_s: float
    ts_source: str                          # where Ts came from (said in the report)
    rows: np.ndarray                        # REPLAY_CYCLE_DTYPE
    telem: dict[str, np.ndarray]            # TELEM_FIELDS per row
    frames: np.ndarray | None = None        # REPLAY_FRAME_DTYPE (uplink, per row)
    frames_text: tuple[list[str], list[str]] | None = None   # per row: up, down (candump style)
    setup_frames: list[tuple[str, int, bytes]] = field(default_factory=list)
    hello: dict | None = None
    config: dict[Param, float] = field(default_factory=dict)
    commands: list[tuple[int, int, float]] = field(default_factory=list)   # cycle, command, value
    anomalies: Anomalies = field(default_factory=Anomalies)
    problems: list[str] = field(default_factory=list)   # damage: file, position, what; replayed anyway
    theta_source: str | None = None         # what the angle of the rows is, if any
    state: dict[str, np.ndarray] | None = None   # MCAP: the recorded /plant/state per row
    recording: object | None = None          # MCAP: the hil_bench.record.recording.Recording
    voltage_is_duty: bool = True            # False: the rows' duties stand for measured voltages
    sessions: int = 1
    notes: list[str] = field(default_factory=list)
    plant_params: dict | None = None        # MCAP: the recorded plant parameters
    resampling: dict | None = None          # CSV: method and figures (said in the report)

    @property
    def n(self) -> int:
        return len(self.rows)

    @property
    def has_theta(self) -> bool:
        return bool(self.n and self.rows["has_theta"].any())

    @property
    def has_duty(self) -> bool:
        return bool(self.n and self.rows["has_duty"].any())

    @property
    def has_telem(self) -> bool:
        return bool(self.n and self.rows["has_telem"].any())

    def describe(self) -> str:
        t_end = float(self.rows["t_s"][-1]) if self.n else 0.0
        return (f"{self.path}: {self.kind} capture, {self.n} cycles, Ts = {self.ts_s * 1e6:g} us "
                f"({self.ts_source}), t = {float(self.rows['t_s'][0]) if self.n else 0.0:g} .. "
                f"{t_end:g} s; angle: {self.theta_source or 'none'}; duties: "
                f"{'yes' if self.has_duty else 'no'}; controller telemetry: "
                f"{'yes' if self.has_telem else 'no'}")


def empty_telem(n: int) -> dict[str, np.ndarray]:
    out = {k: np.full(n, np.nan) for k in TELEM_FIELDS}
    out["state"] = np.full(n, -1, dtype=np.int64)
    out["estimator"] = np.full(n, -1, dtype=np.int64)
    return out


def duty_raw_of(d: np.ndarray) -> np.ndarray:
    """Recorded duties (fraction; < 0 = leg off) -> DUTY raw values, as the engine decodes them."""
    d = np.asarray(d, dtype=float)
    raw = np.where(d < 0, DUTY_RAW_OFF, np.rint(np.clip(np.nan_to_num(d, nan=0.5), 0.0, 1.0)
                                                 * DUTY_RAW_FULL))
    return raw.astype(np.uint32)


def duty_of_raw(raw: int) -> float:
    if raw == DUTY_RAW_OFF:
        return -1.0
    return raw / DUTY_RAW_FULL if raw <= DUTY_RAW_FULL else math.nan


def frame_text(fid: int, data: bytes) -> str:
    return f"{fid:03X}#{bytes(data).hex().upper()}"


@dataclass
class _Cycle:
    k: int
    seq: int
    t_s: float
    up: list[tuple[int, bytes]]
    down: list[tuple[int, bytes]] = field(default_factory=list)
    aux: dict | None = None
    sense: tuple = ()
    telem: dict | None = None
    emf: dict | None = None
    duty: tuple | None = None
    duty_before_telem: bool = False


class CycleAssembler:
    """Frames in capture order -> cycles (docs/protocol.md 6.4), counting every anomaly.

    ``feed(fid, data, t_s, where)``: one frame; ``where`` names its position in the file (said
    in the anomaly details). ``finish()``: the cycles. Direction comes from the id (the DBC
    says who sends each message), so a log without direction (candump) needs none.
    """

    def __init__(self, anomalies: Anomalies, ts_hint_s: float | None = None):
        self.an = anomalies
        self.cycles: list[_Cycle] = []
        self.pending_up: list[tuple[int, bytes, int | None]] = []   # fid, data, seq (None: CMD)
        self.pending_down: list[tuple[int, bytes, float, str]] = []  # answers logged early
        self.setup: list[tuple[str, int, bytes]] = []
        self.hello: dict | None = None
        self.config: dict[Param, float] = {}
        self.commands: list[tuple[int, int, float]] = []
        self.sessions = 0
        self.last_t: float | None = None
        self.ignored_sessions_frames = 0
        self._current: _Cycle | None = None

    # -- helpers --------------------------------------------------------------------------------
    def _cycle_seq_delta(self, seq: int) -> int:
        return (seq - self._current.seq) & 0xFFFF

    def feed(self, fid: int, data: bytes, t_s: float, where: str) -> None:
        if self.sessions > 1:
            self.ignored_sessions_frames += 1
            return
        if self.last_t is not None and t_s < self.last_t:
            # one event per step backwards: each frame is compared with the one before it, so
            # one corrupt time stamp costs one event (and its jump forward one), not thousands
            self.an.add("out_of_order", f"{where}: time goes backwards ({t_s:.6f} s after "
                                        f"{self.last_t:.6f} s); kept in capture order", t_s)
        elif (self.last_t is not None and self.cycles
              and t_s - self.last_t > IMPLAUSIBLE_JUMP_S):
            self.an.add("damaged", f"{where}: time jumps forward {t_s - self.last_t:.6g} s "
                                   f"(from {self.last_t:.6f} s) within the cycles: a corrupt time "
                                   f"stamp or a logger that stopped; the frame is used (cycles "
                                   f"take their time from the SENSE seq)", t_s)
        self.last_t = t_s
        msg = BY_ID.get(fid)
        if msg is None:
            self.an.unknown_id_counts[fid] += 1
            self.an.add("unknown_ids", f"{where}: id 0x{fid:03X} is not in protocol/hil.dbc", t_s)
            return
        if len(data) != msg.length:
            self.an.wrong_length_counts[fid] += 1
            self.an.add("wrong_length", f"{where}: {msg.name} (0x{fid:03X}) with {len(data)} "
                                        f"octets, the DBC says {msg.length}: not decoded", t_s)
            return
        data = bytes(data)
        if fid == _HELLO.frame_id:
            if self.cycles:
                self.sessions += 1
                self.an.add("out_of_order", f"{where}: HELLO after {len(self.cycles)} cycles: a "
                                            f"new session; only the first session is replayed",
                            t_s)
                self.sessions = 2
                return
            self.sessions = 1
            v = _HELLO.unpack(data)
            self.hello = {"period_us": float(v["period_us"]), "estimator": int(v["estimator"]),
                          "flags": int(v["flags"]), "mode": int(v["mode"])}
        if fid in UPLINK_CYCLE:
            self._uplink(fid, data, t_s, where)
        elif fid in DOWNLINK_CYCLE:
            self._downlink(fid, data, t_s, where)
        else:
            self._other(fid, data, t_s)

    def _other(self, fid: int, data: bytes, t_s: float) -> None:
        direction = "tx" if BY_ID[fid].spec.sender == "PLANT" else "rx"
        if fid == _CONFIG.frame_id and not self.cycles:
            v = _CONFIG.unpack(data)
            try:
                self.config[Param(int(v["param_id"]))] = float(v["value"])
            except ValueError:
                pass
        if fid == _CMD.frame_id:
            v = _CMD.unpack(data)
            k = (self._current.k + 1) if self._current is not None else 0
            self.commands.append((k, int(v["command"]), float(v["value"])))
            if self.cycles:
                self.pending_up.append((fid, data, None))
                return
        if not self.cycles:
            self.setup.append((direction, fid, data))
        # heartbeats, faults, acks during the cycles: neither uplink nor downlink of a cycle

    def _uplink(self, fid: int, data: bytes, t_s: float, where: str) -> None:
        seq = int(_SENSE.unpack_raw(data)[0]) if fid == _SENSE.frame_id else int(
            BY_ID[fid].unpack_raw(data)[0])
        if fid != _SENSE.frame_id:
            stale = [p for p in self.pending_up if p[2] is not None and p[2] != seq]
            if stale:
                for p in stale:
                    self.an.add("drops", f"{where}: {BY_ID[p[0]].name}(seq {p[2]}) was never "
                                         f"followed by its SENSE", t_s)
                self.pending_up = [p for p in self.pending_up if p not in stale]
            if any(p[0] == fid and p[2] == seq for p in self.pending_up):
                self.an.add("duplicates", f"{where}: {BY_ID[fid].name}(seq {seq}) again", t_s)
                return
            if self._current is not None and self._cycle_seq_delta(seq) == 0:
                self.an.add("duplicates", f"{where}: {BY_ID[fid].name}(seq {seq}) of the cycle "
                                          f"already closed (a re-send)", t_s)
                return
            self.pending_up.append((fid, data, seq))
            return
        # SENSE: closes the uplink of a cycle
        if self._current is not None:
            delta = self._cycle_seq_delta(seq)
            if delta == 0:
                self.an.add("duplicates", f"{where}: SENSE(seq {seq}) again (a re-send)", t_s)
                return
            if delta >= 0x8000:
                self.an.add("out_of_order", f"{where}: SENSE(seq {seq}) after seq "
                                            f"{self._current.seq}: going backwards; left out", t_s)
                return
            if delta > 1:
                self.an.add("gaps", f"{where}: SENSE seq jumps {self._current.seq} -> {seq}: "
                                    f"{delta - 1} cycle(s) missing", t_s)
                self.an.counts["cycles_missing"] += delta - 1
            k = self._current.k + delta
            self._close(where, t_s)
        else:
            k = seq
        group = [p for p in self.pending_up if p[2] is None or p[2] == seq]
        for p in self.pending_up:
            if p not in group:
                self.an.add("drops", f"{where}: {BY_ID[p[0]].name}(seq {p[2]}) was never "
                                     f"followed by its SENSE", t_s)
        self.pending_up = []
        cyc = _Cycle(k=k, seq=seq, t_s=t_s, up=[(f, d) for f, d, _ in group] + [(fid, data)])
        early, self.pending_down = self.pending_down, []
        raw = _SENSE.unpack_raw(data)
        cyc.sense = tuple(float(r) * _SENSE.signal("i_a").scale for r in raw[1:4])
        for f, d, _ in group:
            if f == _AUX.frame_id:
                r = _AUX.unpack_raw(d)
                # the bus voltage in the decimal steps the DBC gives it (10 mV): the decimal the
                # raw value stands for, not raw * 0.01 in binary (which is 1 ulp off 310.0)
                cyc.aux = {"v_dc": round(float(r[1]) * _AUX.signal("v_dc").scale, _VDC_DECIMALS),
                           "theta": float(r[2]) * _AUX.signal("theta_enc").scale,
                           "flags": int(r[3])}
        if cyc.aux is None:
            self.an.add("drops", f"{where}: SENSE(seq {seq}) without its SENSE_AUX (bus voltage "
                                 f"held from the cycle before)", t_s)
        self.cycles.append(cyc)
        self._current = cyc
        for f, d, t2, w2 in early:
            if int(BY_ID[f].unpack_raw(d)[0]) == seq:
                self._downlink(f, d, t2, w2)
            else:
                self.an.add("drops", f"{w2}: {BY_ID[f].name} answers a SENSE that is not in the "
                                     f"capture; left out", t2)

    def _downlink(self, fid: int, data: bytes, t_s: float, where: str) -> None:
        name = BY_ID[fid].name
        seq = int(BY_ID[fid].unpack_raw(data)[0])
        cyc = self._current
        if cyc is None:
            self.an.add("out_of_order", f"{where}: {name}(seq {seq}) before any SENSE; left out",
                        t_s)
            return
        delta = self._cycle_seq_delta(seq)
        if delta == 1:
            # an answer logged before the SENSE it answers (a logger that writes both directions
            # from two threads does that): counted, and attached to its cycle when SENSE comes
            self.an.add("out_of_order", f"{where}: {name}(seq {seq}) before its SENSE(seq {seq}) "
                                        f"in the capture; attached to that cycle", t_s)
            self.pending_down.append((fid, data, t_s, where))
            return
        if delta != 0:
            if delta >= 0x8000:
                self.an.add("out_of_order", f"{where}: {name}(seq {seq}) arrives during cycle "
                                            f"{cyc.seq}: late; left out", t_s)
            else:
                self.an.add("drops", f"{where}: {name}(seq {seq}) answers a SENSE that is not in "
                                     f"the capture; left out", t_s)
            return
        if fid == _DUTY.frame_id:
            if cyc.duty is not None:
                self.an.add("duplicates", f"{where}: DUTY(seq {seq}) again", t_s)
                return
            cyc.duty = tuple(int(x) for x in _DUTY.unpack_raw(data)[1:4])
        elif fid == _TELEM.frame_id:
            if cyc.telem is not None:
                self.an.add("duplicates", f"{where}: TELEM(seq {seq}) again", t_s)
                return
            if cyc.duty is not None:
                self.an.add("out_of_order", f"{where}: TELEM(seq {seq}) after its DUTY (the "
                                            f"protocol sends it before); used", t_s)
            r = _TELEM.unpack_raw(data)
            cyc.telem = {"theta_hat_rad": float(r[1]) * _TELEM.signal("theta_hat").scale,
                         "omega_hat_rad_s": float(r[2]) * _TELEM.signal("omega_hat").scale,
                         "state": int(r[3]), "estimator": int(r[4])}
        else:
            if cyc.emf is not None:
                self.an.add("duplicates", f"{where}: TELEM_EMF(seq {seq}) again", t_s)
                return
            r = _EMF.unpack_raw(data)
            cyc.emf = {"e_alpha_v": float(r[1]) * _EMF.signal("e_alpha").scale,
                       "e_beta_v": float(r[2]) * _EMF.signal("e_beta").scale,
                       "i_q_ref_a": float(r[3]) * _EMF.signal("i_q_ref").scale}
        cyc.down.append((fid, data))

    def _close(self, where: str, t_s: float) -> None:
        cyc = self._current
        if cyc is not None and cyc.duty is None:
            self.an.add("drops", f"before {where}: cycle seq {cyc.seq} has no DUTY in the "
                                 f"capture (the last duties held)", cyc.t_s)
        if cyc is not None and cyc.telem is None:
            self.an.add("drops", f"before {where}: cycle seq {cyc.seq} has no TELEM", cyc.t_s)

    def finish(self, where_end: str) -> None:
        for f, _d, s in self.pending_up:
            if s is not None:
                self.an.add("drops", f"{where_end}: {BY_ID[f].name}(seq {s}) at the end of the "
                                     f"capture without its SENSE", math.nan)
        self.pending_up = []
        if self._current is not None and self._current.duty is None:
            # the capture ends inside the last cycle: said, not counted as a drop
            pass
        elif self._current is not None:
            self._close(where_end, math.nan)

    # -- the result -------------------------------------------------------------------------------
    def build(self, ts_s: float) -> tuple[np.ndarray, dict, np.ndarray,
                                          tuple[list[str], list[str]]]:
        """rows, telem, frames (uplink per row), frames text."""
        cycles = self.cycles
        n = len(cycles)
        rows = np.zeros(n, dtype=REPLAY_CYCLE_DTYPE)
        telem = empty_telem(n)
        n_frames = sum(len(c.up) for c in cycles)
        frames = np.zeros(n_frames, dtype=REPLAY_FRAME_DTYPE)
        up_text, down_text = [], []
        pos = 0
        v_dc = next((c.aux["v_dc"] for c in cycles if c.aux is not None), math.nan)
        duties = (0.5, 0.5, 0.5)
        for i, c in enumerate(cycles):
            r = rows[i]
            r["t_s"] = c.k * ts_s      # cycle k of the session (seq unwrapped) at k Ts
            r["seq"] = c.seq
            r["i_abc_a"] = c.sense
            if c.aux is not None:
                v_dc = c.aux["v_dc"]
                if c.aux["flags"] & int(SenseAuxFlag.THETA_ENC_VALID):
                    r["theta_rad"] = c.aux["theta"]
                    r["has_theta"] = 1
            r["v_dc_v"] = v_dc
            if c.duty is not None:
                r["duty_raw"] = c.duty
                r["has_duty"] = 1
                duties = tuple(duty_of_raw(x) for x in c.duty)
            telem["duty_a"][i], telem["duty_b"][i], telem["duty_c"][i] = duties
            if c.telem is not None:
                r["has_telem"] = 1
                for key in ("theta_hat_rad", "omega_hat_rad_s", "state", "estimator"):
                    r[key] = telem[key][i] = c.telem[key]
            if c.emf is not None:
                r["has_emf"] = 1
                for key, v in c.emf.items():
                    telem[key][i] = v
                    r[key] = v
            r["first_frame"] = pos
            r["n_frames"] = len(c.up)
            for fid, data in c.up:
                frames[pos]["id"] = fid
                frames[pos]["dlc"] = len(data)
                frames[pos]["data"][:len(data)] = np.frombuffer(data, dtype=np.uint8)
                pos += 1
            up_text.append(" ".join(frame_text(f, d) for f, d in c.up))
            down_text.append(" ".join(frame_text(f, d) for f, d in c.down))
        return rows, telem, frames, (up_text, down_text)
