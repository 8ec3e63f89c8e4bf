"""``bench conformance --link SPEC``: check a controller against docs/protocol.md with a scripted session.

For drive teams: point it at a drive (``--link serial:/dev/ttyUSB0@3000000``, ``--link can:...``) or at
the stub (``--link stub``) and it prints, item by item, what the controller got right and wrong, each
item tied to a section of docs/protocol.md. It is a test tool, not the bench's cycle loop: it drives the
link directly (``bench.links.open_link``), one frame at a time, with a plant (``plant_rt``) supplying the
currents so the controller runs its real start-up.

The session: idle heartbeats; HELLO with a wrong version, an unknown mode, ENCODER without the encoder
flag, then a good one; CONFIG of an unknown parameter, of a fractional integer parameter, of NaN, then
every parameter of a run; RUN, then CONFIG while running; a few hundred cycles (TELEM, TELEM_EMF, DUTY in
order, seq echoed, valid duties, the requested estimator); a repeated SENSE (the cached answer, byte for
byte); a SENSE with a bad CRC (serial links: ignored, then the good one answered); STOP; a second session
without TELEM_EMF; heartbeats again, counting the bad frame.

Exit status 0 if every applicable item passes, 1 otherwise, 2 if the session could not run at all.
"""
from __future__ import annotations

import argparse
import math
import struct
import time
from dataclasses import dataclass, field

from protocol.framing import cobs_encode, crc16
from protocol.messages import (DUTY_RAW_OFF, MESSAGES, PROTO_VERSION, Command, ConfigStatus, Estimator,
                               HelloFlag, HelloStatus, Mode, Param, State)

ANSWER_TIMEOUT_S = 0.5      # the host's patience for an answer (docs/protocol.md 6.1-6.5)
SILENCE_S = 0.1             # how long a frame that must not be answered is given
HEARTBEAT_WAIT_S = 1.5      # for three heartbeats (a drive may still be starting when the link opens)
DUTY_RAW_FULL = 32768

M = MESSAGES
_IDS = {m.frame_id: m for m in MESSAGES.values()}


@dataclass
class Item:
    section: str
    text: str
    ok: bool | None            # None: not applicable on this link
    detail: str = ""

    @property
    def verdict(self) -> str:
        return "n/a" if self.ok is None else ("PASS" if self.ok else "FAIL")


@dataclass
class Result:
    link: str
    items: list[Item] = field(default_factory=list)
    aborted: str | None = None

    @property
    def passed(self) -> bool:
        return self.aborted is None and all(i.ok is not False for i in self.items)

    def text(self) -> str:
        lines = [f"protocol conformance of the controller on {self.link} (docs/protocol.md {PROTO_VERSION}.0)"]
        for i in self.items:
            lines.append(f"  {i.verdict:4s}  {i.section:5s} {i.text}" + (f": {i.detail}" if i.detail else ""))
        if self.aborted:
            lines.append(f"  ABORTED: {self.aborted}")
        failed = sum(1 for i in self.items if i.ok is False)
        lines.append(f"{len(self.items) - failed} of {len(self.items)} items pass" if not self.aborted
                     else "the session could not be completed")
        return "\n".join(lines)


class _Abort(Exception):
    pass


class _Session:
    def __init__(self, link, stub):
        self.link = link
        self.stub = stub
        self.pending: list[tuple[int, bytes]] = []
        self.session_id = 0x5A5A

    def send(self, frames):
        self.link.send(frames)

    def recv(self, timeout_s: float) -> list[tuple[int, bytes]]:
        if self.pending:
            out, self.pending = self.pending, []
            return out
        return self.link.recv(timeout_s)

    def wait_for(self, predicate, timeout_s: float) -> tuple[tuple[int, bytes] | None, list[tuple[int, bytes]]]:
        """The first frame that matches and every frame that came before it."""
        seen: list[tuple[int, bytes]] = []
        end = time.monotonic() + timeout_s
        while True:
            for i, (fid, p) in enumerate(batch := self.recv(max(end - time.monotonic(), 0.0))):
                if predicate(fid, p):
                    self.pending = batch[i + 1:] + self.pending
                    return (fid, p), seen
                seen.append((fid, p))
            if time.monotonic() >= end:
                return None, seen
            if self.stub is not None and not self.stub.alive():
                raise _Abort(self.stub.death_message())

    def heartbeats(self, n: int, timeout_s: float) -> list[tuple[float, dict]]:
        """Up to ``n`` HEARTBEAT_CTRL (arrival time, values), waiting at most ``timeout_s``."""
        out: list[tuple[float, dict]] = []
        end = time.monotonic() + timeout_s
        while len(out) < n and time.monotonic() < end:
            for f, p in self.recv(end - time.monotonic()):
                if _ok(f, p, "HEARTBEAT_CTRL"):
                    out.append((time.monotonic(), M["HEARTBEAT_CTRL"].unpack(p)))
        return out


def _ok(fid: int, payload: bytes, name: str) -> bool:
    return fid == M[name].frame_id and len(payload) == M[name].length


def _hello(s: _Session, *, version=PROTO_VERSION, mode=Mode.LOCKSTEP, estimator=1, flags=0, period_s=100e-6):
    s.session_id = (s.session_id + 0x1111) & 0xFFFF or 1
    s.send([(M["HELLO"].frame_id, M["HELLO"].pack_raw((version, int(mode), round(period_s * 1e7), estimator,
                                                        flags, s.session_id)))])
    sid = s.session_id
    match, _ = s.wait_for(lambda f, p: _ok(f, p, "HELLO_ACK") and M["HELLO_ACK"].unpack(p)["session"] == sid,
                          ANSWER_TIMEOUT_S)
    return None if match is None else M["HELLO_ACK"].unpack(match[1])


def _config(s: _Session, seq: int, param_id: int, value: float):
    # struct, not the codec: the codec refuses NaN, which the conformance kit sends on purpose
    s.send([(M["CONFIG"].frame_id, struct.pack("<HHf", param_id, seq, value))])
    match, _ = s.wait_for(lambda f, p: _ok(f, p, "CONFIG_ACK") and M["CONFIG_ACK"].unpack(p)["config_seq"] == seq,
                          ANSWER_TIMEOUT_S)
    return None if match is None else M["CONFIG_ACK"].unpack(match[1])


def _status(table, value) -> str:
    try:
        return table(int(value)).name
    except ValueError:
        return f"{int(value)} (not in the {table.__name__} table)"


def run_conformance(link_spec: str = "stub", stub_args: tuple[str, ...] = (), cycles: int = 300,
                    estimator: str = "SMO_SIGN", scenario: str = "gong_g2_500rpm") -> Result:
    """Run the scripted session against the controller on ``link_spec``; never raises for a bad controller."""
    from plant_rt.plant import Plant
    from plant_rt.profile import load_profile

    from .links import LinkError, open_link
    from .links.serial_link import SerialLink
    from .scenario import load_scenario

    result = Result(link_spec)
    scn = load_scenario(scenario)
    est = Estimator[estimator]
    profile = load_profile(scn.profile)
    plant = Plant(profile, **scn.plant_overrides)
    ts_s = float(plant.params.ts_s)
    try:
        opened = open_link(link_spec, stub_args)
    except LinkError as exc:
        result.aborted = str(exc)
        return result
    result.link = opened.link.description
    s = _Session(opened.link, opened.stub)
    add = result.items.append
    try:
        _script(s, add, plant, profile, scn, est, ts_s, cycles, isinstance(opened.link, SerialLink))
    except _Abort as exc:
        result.aborted = str(exc)
    except LinkError as exc:
        result.aborted = f"the link failed: {exc}"
    finally:
        opened.close()
    return result


def _script(s: _Session, add, plant, profile, scn, est: Estimator, ts_s: float, cycles: int, serial: bool):
    # -- idle heartbeats (6.7) ---------------------------------------------------------------------------
    beats = s.heartbeats(3, HEARTBEAT_WAIT_S)
    counters = [int(b["counter"]) for _, b in beats]
    gaps = [round((b[0] - a[0]) * 1e3) for a, b in zip(beats, beats[1:])]
    add(Item("6.7", "HEARTBEAT_CTRL every 100 ms while idle, counter +1 each",
             len(beats) == 3 and all((b - a) & 0xFFFF == 1 for a, b in zip(counters, counters[1:]))
             and all(50 <= g <= 250 for g in gaps),
             f"{len(beats)} within {HEARTBEAT_WAIT_S:g} s, counters {counters}, {gaps} ms apart"))

    # -- handshake (6.1) -------------------------------------------------------------------------------
    ack = _hello(s, version=99, estimator=int(est), period_s=ts_s)
    add(Item("6.1", "HELLO with proto_version 99: VERSION_MISMATCH, session echoed",
             ack is not None and ack["status"] == HelloStatus.VERSION_MISMATCH,
             "no answer" if ack is None else f"status {_status(HelloStatus, ack['status'])}"))
    ack = _hello(s, mode=7, estimator=int(est), period_s=ts_s)
    add(Item("6.1", "HELLO with mode 7 (not in the Mode table): MODE_UNSUPPORTED",
             ack is not None and ack["status"] == HelloStatus.MODE_UNSUPPORTED,
             "no answer" if ack is None else f"status {_status(HelloStatus, ack['status'])}"))
    ack = _hello(s, estimator=int(Estimator.ENCODER), period_s=ts_s)
    add(Item("6.8", "HELLO asking for ENCODER without the flag ENCODER_VALID: ESTIMATOR_UNSUPPORTED",
             ack is not None and ack["status"] == HelloStatus.ESTIMATOR_UNSUPPORTED,
             "no answer" if ack is None else f"status {_status(HelloStatus, ack['status'])}"))
    flags = int(HelloFlag.TELEM_EMF)
    ack = _hello(s, estimator=int(est), flags=flags, period_s=ts_s)
    if ack is None:
        add(Item("6.1", f"HELLO (lockstep, {est.name}, TELEM_EMF): HELLO_ACK OK", False, "no HELLO_ACK"))
        raise _Abort("no HELLO_ACK to a valid HELLO: nothing more can be checked")
    add(Item("6.1", f"HELLO (lockstep, {est.name}, TELEM_EMF): HELLO_ACK OK, proto_version {PROTO_VERSION}",
             ack["status"] == HelloStatus.OK and ack["proto_version"] == PROTO_VERSION,
             f"status {_status(HelloStatus, ack['status'])}, proto_version {ack['proto_version']}"))
    if ack["status"] != HelloStatus.OK:
        raise _Abort(f"the controller refused the HELLO ({_status(HelloStatus, ack['status'])})")
    add(Item("6.1", f"HELLO_ACK.estimators lists {est.name}", bool((int(ack["estimators"]) >> int(est)) & 1),
             f"mask 0x{int(ack['estimators']):04X}"))

    # -- configuration (6.2) ---------------------------------------------------------------------------
    seq = 0

    def config(pid, value):
        nonlocal seq
        seq += 1
        return _config(s, seq, pid, value)

    a = config(999, 1.0)
    add(Item("6.2", "CONFIG of param_id 999 (not in the table): UNKNOWN_PARAM",
             a is not None and a["status"] == ConfigStatus.UNKNOWN_PARAM and a["param_id"] == 999,
             "no CONFIG_ACK" if a is None else f"status {_status(ConfigStatus, a['status'])}"))
    a = config(int(Param.POLE_PAIRS), 4.5)
    add(Item("6.2", "CONFIG POLE_PAIRS = 4.5 (an integer parameter): OUT_OF_RANGE",
             a is not None and a["status"] == ConfigStatus.OUT_OF_RANGE,
             "no CONFIG_ACK" if a is None else f"status {_status(ConfigStatus, a['status'])}"))
    a = config(int(Param.RS_OHM), math.nan)
    add(Item("6.2", "CONFIG RS_OHM = NaN: OUT_OF_RANGE",
             a is not None and a["status"] == ConfigStatus.OUT_OF_RANGE,
             "no CONFIG_ACK" if a is None else f"status {_status(ConfigStatus, a['status'])}"))
    params = {
        Param.RS_OHM: profile.rs_ohm, Param.LD_H: profile.ld_h, Param.LQ_H: profile.lq_h,
        Param.PSI_F_WB: profile.psi_f_wb, Param.POLE_PAIRS: float(profile.pole_pairs),
        Param.J_KGM2: profile.j_kgm2, Param.B_NMS: profile.b_nms, Param.V_DC_NOM_V: profile.v_dc_v,
        Param.CTRL_DELAY_S: float(plant.params.t_delay_s), **scn.controller_params}
    bad = []
    for pid, value in params.items():
        a = config(int(pid), float(value))
        if a is None or a["status"] != ConfigStatus.OK or a["param_id"] != int(pid):
            bad.append(f"{pid.name}: " + ("no CONFIG_ACK" if a is None else
                                          f"status {_status(ConfigStatus, a['status'])}, param_id {a['param_id']}"))
    add(Item("6.2", f"CONFIG of the {len(params)} parameters of a run (CTRL_DELAY_S too): each acknowledged OK, "
                    f"param_id and config_seq echoed", not bad, "; ".join(bad)))

    # -- commands and LOCKED (6.3, 6.2) -----------------------------------------------------------------
    cmd = M["CMD"]
    s.send([(cmd.frame_id, cmd.pack(command=int(Command.SET_SPEED_REF), seq=1, value=scn.speed_ref_rad_s)),
            (cmd.frame_id, cmd.pack(command=int(Command.RUN), seq=2, value=0.0))])
    a = config(int(Param.RS_OHM), float(profile.rs_ohm))
    add(Item("6.2", "CONFIG while running: LOCKED", a is not None and a["status"] == ConfigStatus.LOCKED,
             "no CONFIG_ACK" if a is None else f"status {_status(ConfigStatus, a['status'])}"))

    # -- cycles (6.4, 6.6, 6.8) --------------------------------------------------------------------------
    plant.set_initial(scn.initial_theta_e_rad, scn.initial_speed_rad_s)
    stats = {"answered": 0, "order": 0, "emf": 0, "duty_ok": 0, "estimator": 0, "stray": 0, "fault": 0}
    states: list[int] = []
    problems: list[str] = []
    retry_at, crc_at = cycles // 2, cycles // 2 + 10
    retry_item = crc_item = None

    def cycle_frames(k: int) -> list[tuple[int, bytes]]:
        smp = plant.sample()
        return [(M["SENSE_AUX"].frame_id, M["SENSE_AUX"].pack_values((k, smp.v_dc_v, 0.0, 0))),
                (M["SENSE"].frame_id, M["SENSE"].pack_values((k, smp.i_a_a, smp.i_b_a, smp.i_c_a), saturate=True))]

    def answer(k: int, frames) -> list[tuple[int, bytes]] | None:
        s.send(frames)
        duty, seen = s.wait_for(lambda f, p: _ok(f, p, "DUTY") and M["DUTY"].unpack_raw(p)[0] == k, ANSWER_TIMEOUT_S)
        return None if duty is None else seen + [duty]

    prepared: list[tuple[int, bytes]] | None = None
    for k in range(cycles):
        frames = prepared or cycle_frames(k)
        prepared = None
        got = answer(k, frames)
        if got is None:
            problems.append(f"no DUTY for seq {k} within {ANSWER_TIMEOUT_S:g} s")
            break
        stats["answered"] += 1
        cyc = [(f, p) for f, p in got if f != M["HEARTBEAT_CTRL"].frame_id]
        ids = [f for f, _ in cyc if f != M["FAULT_CTRL"].frame_id]
        if any(f == M["FAULT_CTRL"].frame_id for f, _ in cyc):
            stats["fault"] += 1
        if ids == [M["TELEM"].frame_id, M["TELEM_EMF"].frame_id, M["DUTY"].frame_id]:
            stats["order"] += 1
        else:
            stats["stray"] += 1
            if len(problems) < 5:
                problems.append(f"seq {k}: frames {[f'0x{f:03X}' for f in ids]}")
        seqs_ok = all(len(p) == _IDS[f].length and _IDS[f].unpack_raw(p)[0] == k
                      for f, p in cyc if f in (M["TELEM"].frame_id, M["TELEM_EMF"].frame_id, M["DUTY"].frame_id))
        stats["emf"] += seqs_ok and any(f == M["TELEM_EMF"].frame_id for f, _ in cyc)
        raw = M["DUTY"].unpack_raw(got[-1][1])
        if all(0 <= r <= DUTY_RAW_FULL or r == DUTY_RAW_OFF for r in raw[1:]):
            stats["duty_ok"] += 1
        telem = [M["TELEM"].unpack_raw(p) for f, p in cyc if _ok(f, p, "TELEM")]
        if telem and telem[0][4] == int(est):
            stats["estimator"] += 1
        if telem:
            states.append(int(telem[0][3]))
        d = [(-1.0 if r == DUTY_RAW_OFF else r / DUTY_RAW_FULL) for r in raw[1:]]
        if k == retry_at:   # the same SENSE again: the cached answer, byte for byte (6.5)
            again = answer(k, frames)
            same = again is not None and [(f, p) for f, p in again if f != M["HEARTBEAT_CTRL"].frame_id] == cyc
            retry_item = Item("6.5", f"SENSE {k} sent again: the same TELEM, TELEM_EMF, DUTY byte for byte "
                                     f"(answered from the cache, ISR not run again)", same,
                              "no answer" if again is None else ("" if same else "a different answer"))
        plant.step(*(x if x >= 0 else -1.0 for x in d))
        if k + 1 == crc_at and serial:   # next cycle: its SENSE with a bad CRC first (2.4, 6.0 item 9)
            prepared = cycle_frames(k + 1)
            sense_id, sense = prepared[1]
            body = bytes((sense_id & 0xFF, sense_id >> 8, len(sense))) + sense
            crc = crc16(body) ^ 0x0001
            s.send([prepared[0]])
            s.link.transport.write(cobs_encode(body + bytes((crc & 0xFF, crc >> 8))) + b"\x00")
            stray, _ = s.wait_for(lambda f, p: _ok(f, p, "DUTY"), SILENCE_S)
            crc_item = Item("2.4", "a SENSE with a bad CRC is dropped (no answer); the good one, sent next, "
                                   "is answered", stray is None, "" if stray is None else "a frame with a bad CRC "
                                                                                          "was answered")
    n = stats["answered"]
    add(Item("6.4", "every SENSE answered with a DUTY of its seq", n == cycles,
             f"{n}/{cycles} cycles" + (f"; {problems[0]}" if n < cycles and problems else "")))
    add(Item("6.4", "TELEM, then TELEM_EMF (asked for), then DUTY, nothing else, seq echoed",
             stats["order"] == n and stats["emf"] == n and n > 0,
             f"{stats['order']}/{n} in order, {stats['emf']}/{n} with every frame of the right seq and length"
             + (f"; {'; '.join(problems[:3])}" if stats["order"] < n else "")))
    add(Item("6.6", "duties in 0..1 (raw 0..32768) or OFF (65535)", stats["duty_ok"] == n and n > 0,
             f"{stats['duty_ok']}/{n}"))
    add(Item("6.4", f"TELEM.estimator = {est.name} (the estimator asked for) in every cycle",
             stats["estimator"] == n and n > 0, f"{stats['estimator']}/{n}"))
    seen_states = sorted({State(x).name if x in {st.value for st in State} else str(x) for x in states})
    add(Item("6.4", "TELEM.state in the State table; no FAULT_CTRL",
             all(x in {st.value for st in State} for x in states) and stats["fault"] == 0,
             f"states seen: {', '.join(seen_states)}" + (f"; {stats['fault']} FAULT_CTRL" if stats["fault"] else "")))
    add(retry_item or Item("6.5", "a repeated SENSE is answered from the cache", False,
                           f"not reached (cycles {n} < {retry_at + 1})"))
    add(crc_item or Item("2.4", "a SENSE with a bad CRC is dropped", None if not serial else False,
                         "CAN link: the bus checks CRCs" if not serial else f"not reached (cycles {n})"))

    # -- STOP (6.3) ----------------------------------------------------------------------------------------
    kk = n
    s.send([(cmd.frame_id, cmd.pack(command=int(Command.STOP), seq=3, value=0.0))])
    got = answer(kk, cycle_frames(kk))
    telem = [M["TELEM"].unpack_raw(p) for f, p in (got or []) if _ok(f, p, "TELEM")]
    off = got is not None and all(r == DUTY_RAW_OFF for r in M["DUTY"].unpack_raw(got[-1][1])[1:])
    add(Item("6.3", "after CMD STOP: state STOPPED, all legs OFF",
             bool(telem) and telem[0][3] == State.STOPPED and off,
             "no answer" if got is None else f"state {telem[0][3] if telem else '?'}, legs OFF: {off}"))

    # -- a second session without TELEM_EMF (6.1, 6.4, 6.5) --------------------------------------------------
    ack = _hello(s, estimator=int(est), flags=0, period_s=ts_s)
    ok2 = ack is not None and ack["status"] == HelloStatus.OK
    emf_seen, answered2 = 0, 0
    for k2 in range(3):
        got = answer(k2, cycle_frames(k2)) if ok2 else None
        if got is None:
            break
        answered2 += 1
        emf_seen += sum(1 for f, _ in got if f == M["TELEM_EMF"].frame_id)
    add(Item("6.4", "a new session without the flag TELEM_EMF: TELEM and DUTY, never TELEM_EMF; seq 0 runs again",
             ok2 and answered2 == 3 and emf_seen == 0,
             f"HELLO {'OK' if ok2 else 'refused'}, {answered2}/3 answered, {emf_seen} TELEM_EMF"))

    # -- heartbeats again, counting the bad frame (6.7) ---------------------------------------------------------
    beats = [b for _, b in s.heartbeats(2, HEARTBEAT_WAIT_S)]
    counted = bool(beats) and int(beats[-1]["rx_errors"]) >= 1
    add(Item("6.7", "HEARTBEAT_CTRL again once cycles stop" + ("; rx_errors counts the bad-CRC frame" if serial
                                                                 else ""),
             bool(beats) and (counted or not serial),
             f"{len(beats)} heartbeats" + (f", rx_errors {int(beats[-1]['rx_errors'])}" if beats else "")))


def main(args: argparse.Namespace) -> int:
    """``bench conformance`` (see ``bench/cli.py``)."""
    from .scenario import ScenarioError

    try:
        result = run_conformance(args.link, cycles=args.cycles, estimator=args.estimator.upper())
    except (ScenarioError, KeyError) as exc:
        print(f"error: {exc}")
        return 2
    print(result.text())
    if result.aborted:
        return 2 if not result.items else 1
    return 0 if result.passed else 1
