"""``bench conformance --link SPEC``: check a controller against docs/protocol.md with a scripted session.

For drive teams: point it at a drive (``--link serial:/dev/ttyUSB0@3000000``, ``--link can:...``) or at
the stub (``--link stub``) and it prints, item by item, what the controller got right and wrong, each
item tied to a section of docs/protocol.md. It is a test tool, not the bench's cycle loop: it drives the
link directly (``hil_bench.loop.links.open_link``), one frame at a time, with a plant (``plant_rt``) supplying the
currents so the controller runs its real start-up.

The session: idle heartbeats; HELLO with a wrong version, an unknown mode, ENCODER without the encoder
flag, then a good one; CONFIG of an unknown parameter, of a fractional integer parameter, of NaN, then of
every parameter of the Param table (protocol/params.py: each must be acknowledged, never UNKNOWN_PARAM);
a new HELLO (back to the defaults), the parameters of a run (with a short alignment, so that the start-up
moves within the cycles); RUN, then CONFIG while running; a few hundred cycles (TELEM, TELEM_EMF, DUTY in
order, seq echoed, valid duties, the requested estimator, each DUTY within the lockstep answer deadline);
a repeated SENSE while the outputs change (I-f ramp or closed loop: the cached answer, byte for byte); a
SENSE with a bad CRC (serial links: ignored, then the good one answered); STOP; a reference session that
runs the same cycles without the repeat (the cycles after the repeat must answer exactly as there: the
ISR did not run again); a session without TELEM_EMF, in which RUN without the motor's parameters faults
(CONFIG_INVALID), RUN in FAULT is ignored, CLEAR_FAULT returns to IDLE with the configuration kept, and
FAULT_PLANT stops the controller as STOP does; heartbeats again (state STOPPED), counting the bad frame.

Every wait is in ``hil_bench.protocol.timing`` (the table of docs/protocol.md section 6). The kit judges the
controller, not the host's scheduler: the answer-time item holds the median and the 90th percentile of the
session's answer times, each less the host's own loopback time at that quantile (``hil_bench.host_loopback``:
an echo through the same kind of link in this process, measured cycle by cycle in the same run), to
``KIT_ANSWER_LIMIT_S``; one answer the host saw late because it was itself stalled moves neither. The
heartbeat item estimates the period robustly (Theil-Sen) over a window of heartbeats. A missing answer is
diagnosed by what came instead, one line per cause (a frame that failed its CRC, nothing at all, a DUTY of
another seq, named with the frames that came); a late one with its time. An item the session never got to
(the controller stopped answering earlier: that item fails) is n/a, not a second FAIL, and so is an item
about answers when none came.

Versions (docs/protocol.md 6.1, section 10): the kit asks in the host's version; a controller of an older
minor is checked against that version (its parameter table, the run's parameters it knows), as the host
serves it, and the report says so.

Exit status 0 if every applicable item passes, 1 otherwise, 2 if the session could not run at all.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import struct
import time
from dataclasses import dataclass, field

from hil_bench.host_loopback import HostLoopback
from hil_bench.loop.host_session import PROTO_MINOR
from hil_bench.protocol import params as param_info
from hil_bench.protocol import versions
from hil_bench.protocol.framing import cobs_encode, crc16
from hil_bench.protocol.messages import (
    DUTY_RAW_OFF,
    MESSAGES,
    PROTO_VERSION,
    Command,
    ConfigStatus,
    Estimator,
    Fault,
    HelloFlag,
    HelloStatus,
    Mode,
    Param,
    SenseAuxFlag,
    State,
)
from hil_bench.protocol.timing import (
    CONFIG_TIMEOUT_S,
    HEARTBEAT_GAP_MAX_S,
    HEARTBEAT_GAP_MIN_S,
    HEARTBEAT_PERIOD_S,
    HELLO_TIMEOUT_S,
    KIT_ANSWER_LIMIT_S,
    KIT_ANSWER_PATIENCE_S,
    KIT_ANSWER_QUANTILES,
    KIT_HEARTBEAT_MIN_COUNT,
    KIT_HEARTBEAT_WINDOW_S,
    KIT_SILENCE_S,
)

AFTER_REPEAT = 8            # cycles after the repeated SENSE compared with the reference session
ALIGN_SHARE = 0.25          # the alignment lasts at most this share of the cycles (the repeat comes later)
#: a frame that must not be answered (a SENSE with a bad CRC) is given this long to be answered
SILENCE_S = KIT_SILENCE_S
HEARTBEAT_WAIT_S = 1.5      # for the heartbeats after FAULT_PLANT (a drive may still be stopping)
DUTY_RAW_FULL = 32768
#: the fewest cycles whose session reaches the repeated SENSE (from cycles // 2 up to cycles - 20)
MIN_CYCLES = 2 * (AFTER_REPEAT + 12)

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
    #: the protocol version the session spoke, and what of the host's newer version it left out
    version_note: str = ""
    #: what the link found out about itself (a USB adapter holding the answers: serial_link.py)
    link_notes: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return self.aborted is None and all(i.ok is not False for i in self.items)

    def text(self) -> str:
        lines = [f"protocol conformance of the controller on {self.link} (docs/protocol.md "
                 f"{PROTO_VERSION}.{PROTO_MINOR})"]
        if self.version_note:
            lines.append(f"  {self.version_note}")
        for i in self.items:
            lines.append(f"  {i.verdict:4s}  {i.section:5s} {i.text}" + (f": {i.detail}" if i.detail else ""))
        if self.aborted:
            lines.append(f"  ABORTED: {self.aborted}")
        lines += [f"  link: {n}" for n in self.link_notes]
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

    def heartbeat_window(self, window_s: float) -> list[tuple[float, dict]]:
        """Every HEARTBEAT_CTRL (arrival time, values) that arrives within ``window_s``."""
        out: list[tuple[float, dict]] = []
        end = time.monotonic() + window_s
        while time.monotonic() < end:
            for f, p in self.recv(max(end - time.monotonic(), 0.0)):
                if _ok(f, p, "HEARTBEAT_CTRL"):
                    out.append((time.monotonic(), M["HEARTBEAT_CTRL"].unpack(p)))
        return out

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


def _hello(s: _Session, *, version=PROTO_VERSION, mode=Mode.LOCKSTEP, estimator=1, flags=0, period_s=100e-6,
           minor=PROTO_MINOR):
    s.session_id = (s.session_id + 0x1111) & 0xFFFF or 1
    s.send([(M["HELLO"].frame_id, M["HELLO"].pack_raw((version, int(mode), round(period_s * 1e7), estimator,
                                                        flags, minor, s.session_id)))])
    sid = s.session_id
    match, _ = s.wait_for(lambda f, p: _ok(f, p, "HELLO_ACK") and M["HELLO_ACK"].unpack(p)["session"] == sid,
                          HELLO_TIMEOUT_S)
    return None if match is None else M["HELLO_ACK"].unpack(match[1])


def _config(s: _Session, seq: int, param_id: int, value: float):
    # struct, not the codec: the codec refuses NaN, which the conformance kit sends on purpose
    s.send([(M["CONFIG"].frame_id, struct.pack("<HHf", param_id, seq, value))])
    match, _ = s.wait_for(lambda f, p: _ok(f, p, "CONFIG_ACK") and M["CONFIG_ACK"].unpack(p)["config_seq"] == seq,
                          CONFIG_TIMEOUT_S)
    return None if match is None else M["CONFIG_ACK"].unpack(match[1])


def run_params(profile, plant, scn, ts_s: float, cycles: int) -> dict[Param, float]:
    """The parameters the kit runs with: what ``bench run`` sends for the scenario in lockstep
    (docs/protocol.md 6.2, ``hil_bench.loop.runner.controller_params``), with the alignment shortened to
    at most ALIGN_SHARE of the cycles so that the outputs move (I-f ramp, then closed loop) by the time
    the SENSE is repeated."""
    from hil_bench.loop.runner import controller_params

    params = controller_params(scn, profile, plant.params, ts_s,
                               actuation_delay_s=plant.actuation_delay_s)
    align_s = ALIGN_SHARE * cycles * ts_s
    if float(params.get(Param.ALIGN_TIME_S, math.inf)) > align_s:
        params[Param.ALIGN_TIME_S] = align_s
    return params


def neutral_value(pid: Param) -> float:
    """A value of the parameter's kind that asks for nothing: 0 (off, or 'derive it') for real,
    boolean and enum parameters, 1 for integers (every count and divider starts at 1)."""
    return 1.0 if param_info.BY_NAME[pid.name].kind == "integer" else 0.0


def _status(table, value) -> str:
    try:
        return table(int(value)).name
    except ValueError:
        return f"{int(value)} (not in the {table.__name__} table)"


def run_conformance(link_spec: str = "stub", stub_args: tuple[str, ...] = (), cycles: int = 300,
                    estimator: str = "SMO_SIGN", scenario: str = "gong_g2_500rpm") -> Result:
    """Run the scripted session against the controller on ``link_spec``; never raises for a bad controller."""
    from hil_bench.loop.links import LinkError, open_link
    from hil_bench.loop.links.serial_link import SerialLink
    from hil_bench.plant_rt.plant import Plant
    from hil_bench.plant_rt.profile import load_profile
    from hil_bench.scenario import load_scenario

    if cycles < MIN_CYCLES:
        raise ValueError(f"--cycles {cycles}: the session needs at least {MIN_CYCLES} cycles to reach the "
                         f"repeated SENSE (docs/protocol.md 6.5)")
    result = Result(link_spec)
    est = Estimator[estimator]
    scn = dataclasses.replace(load_scenario(scenario), estimator=est)   # what the kit asks for
    profile = load_profile(scn.profile)
    def plant_factory():
        return Plant(profile, **scn.plant_overrides)

    ts_s = float(plant_factory().params.ts_s)
    try:
        opened = open_link(link_spec, stub_args)
    except LinkError as exc:
        result.aborted = str(exc)
        return result
    result.link = opened.link.description
    s = _Session(opened.link, opened.stub)
    add = result.items.append
    try:
        _script(s, add, plant_factory, profile, scn, est, ts_s, cycles, isinstance(opened.link, SerialLink),
                note=lambda text: setattr(result, "version_note", text),
                loopback_kind="pty" if isinstance(opened.link, SerialLink) or "slcan" in link_spec else "socket")
    except _Abort as exc:
        result.aborted = str(exc)
    except LinkError as exc:
        result.aborted = f"the link failed: {exc}"
    finally:
        result.link_notes = list(getattr(opened.link, "notes", ()))
        opened.close()
    return result


def _script(s: _Session, add, plant_factory, profile, scn, est: Estimator, ts_s: float, cycles: int,
            serial: bool, note=lambda text: None, loopback_kind: str = "pty"):
    plant = plant_factory()
    # -- idle heartbeats (6.7) ---------------------------------------------------------------------------
    beats = s.heartbeat_window(KIT_HEARTBEAT_WINDOW_S)
    add(heartbeat_item(beats))

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
    # an encoder drive is asked with ENCODER_VALID and gets the plant's angle in every SENSE_AUX (6.8)
    enc = est == Estimator.ENCODER
    enc_flag = int(HelloFlag.ENCODER_VALID) if enc else 0
    flags = int(HelloFlag.TELEM_EMF) | enc_flag
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
    minor = int(ack["proto_minor"])
    add(Item("6.1", f"HELLO_ACK.proto_minor: the session's version, at most the host's {PROTO_MINOR}",
             minor <= PROTO_MINOR, f"protocol {PROTO_VERSION}.{minor}"))
    minor = min(minor, PROTO_MINOR)
    know = versions.known(PROTO_VERSION, minor)

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
    params = run_params(profile, plant, scn, ts_s, cycles)
    try:
        params, off = versions.serve(params, PROTO_VERSION, minor)
    except versions.NeedsNewerVersion as exc:
        raise _Abort(str(exc)) from None
    if minor < PROTO_MINOR:
        left = sorted((set(param_info.BY_NAME) - set(know.params)))
        note(f"the controller speaks protocol {PROTO_VERSION}.{minor}: checked against that version's "
                    f"tables (the {len(left)} parameters added since are not sent"
                    + (f"; the run leaves out {', '.join(o.split(' (')[0] for o in off)} at their defaults" if off else "")
                    + ")")
    # every parameter of the table (6.0 item 2): the run's value where the run has one, else a neutral
    # one of its kind (0: off / derived; integers 1); a drive may refuse a value it cannot take
    # (OUT_OF_RANGE), never the parameter (UNKNOWN_PARAM), and answers every one
    bad, refused = [], []
    table = [Param[p.name] for p in param_info.PARAMS if p.name in know.params]
    for pid in table:
        value = float(params.get(pid, neutral_value(pid)))
        a = config(int(pid), value)
        if a is None or a["param_id"] != int(pid):
            bad.append(f"{pid.name}: " + ("no CONFIG_ACK" if a is None else f"param_id {a['param_id']} echoed"))
        elif a["status"] == ConfigStatus.OUT_OF_RANGE and pid not in params:
            refused.append(f"{pid.name} = {value:g}")
        elif a["status"] != ConfigStatus.OK:
            bad.append(f"{pid.name} = {value:g}: status {_status(ConfigStatus, a['status'])}")
    add(Item("6.2", f"CONFIG of every parameter of the table ({len(table)}, protocol {PROTO_VERSION}.{minor}): each acknowledged with param_id and "
                    f"config_seq echoed, never UNKNOWN_PARAM (6.0 item 2), the run's values OK",
             not bad, "; ".join(bad[:6]) + (f" (+{len(bad) - 6} more)" if len(bad) > 6 else "")
             + ("; " if bad and refused else "")
             + (f"neutral values refused as OUT_OF_RANGE (allowed): {', '.join(refused)}" if refused else "")))

    # a new session: the controller returns to its default configuration (6.1), then the run's parameters
    ack = _hello(s, estimator=int(est), flags=flags, period_s=ts_s)
    if ack is None or ack["status"] != HelloStatus.OK:
        raise _Abort("no HELLO_ACK OK to a second, identical HELLO")
    seq = 0
    bad = []
    for pid, value in params.items():
        a = config(int(pid), float(value))
        if a is None or a["status"] != ConfigStatus.OK or a["param_id"] != int(pid):
            bad.append(f"{pid.name}: " + ("no CONFIG_ACK" if a is None else
                                          f"status {_status(ConfigStatus, a['status'])}, param_id {a['param_id']}"))
    add(Item("6.2", f"CONFIG of the {len(params)} parameters of a run (CTRL_DELAY_S too) in a new session: each "
                    f"acknowledged OK, param_id and config_seq echoed", not bad, "; ".join(bad)))

    # -- commands and LOCKED (6.3, 6.2) -----------------------------------------------------------------
    cmd = M["CMD"]

    def start_running() -> None:
        s.send([(cmd.frame_id, cmd.pack(command=int(Command.SET_SPEED_REF), seq=1, value=scn.speed_ref_rad_s)),
                (cmd.frame_id, cmd.pack(command=int(Command.RUN), seq=2, value=0.0))])

    start_running()
    a = config(int(Param.RS_OHM), float(profile.rs_ohm))
    add(Item("6.2", "CONFIG while running: LOCKED", a is not None and a["status"] == ConfigStatus.LOCKED,
             "no CONFIG_ACK" if a is None else f"status {_status(ConfigStatus, a['status'])}"))

    # -- cycles (6.4, 6.5, 6.6, 6.8) ------------------------------------------------------------------------
    plant.set_initial(scn.initial_theta_e_rad, scn.initial_speed_rad_s)
    stats = {"answered": 0, "order": 0, "emf": 0, "duty_ok": 0, "estimator": 0, "stray": 0, "fault": 0}
    states: list[int] = []
    problems: list[str] = []
    answers: list[list[tuple[int, bytes]]] = []      # per cycle, the frames of its answer
    moving = (State.OPEN_LOOP, State.CLOSED_LOOP)
    repeat_from, repeat_last = cycles // 2, cycles - AFTER_REPEAT - 12
    repeat_at = crc_at = None
    repeat_moving = False
    retry_item = crc_item = None

    def cycle_frames(pl, k: int) -> list[tuple[int, bytes]]:
        smp = pl.sample()
        valid = enc and bool(smp.enc_valid)
        aux = (k, smp.v_dc_v, smp.theta_enc_rad if valid else 0.0,
               int(SenseAuxFlag.THETA_ENC_VALID) if valid else 0)
        return [(M["SENSE_AUX"].frame_id, M["SENSE_AUX"].pack_values(aux)),
                (M["SENSE"].frame_id, M["SENSE"].pack_values((k, smp.i_a_a, smp.i_b_a, smp.i_c_a), saturate=True))]

    late: list[tuple[int, float]] = []          # (seq, s) of the DUTYs that came after the limit
    times: list[float] = []                      # answer time of every answered cycle of the main session [s]
    host: list[float] = []                       # the host's own loopback, one per answered cycle [s]
    sent = {"seq": -1}                           # the last SENSE seq sent in this session
    missing = {"why": ""}                        # why the last DUTY did not come (one line per cause)

    def answer(k: int, frames, timed: bool = False) -> list[tuple[int, bytes]] | None:
        """DUTY(k) and what came before it, waiting up to KIT_ANSWER_PATIENCE_S (a later answer than
        KIT_ANSWER_LIMIT_S is late, a timing figure); None if it did not come, and ``missing['why']``
        says what came instead. ``timed``: the main session's cycles, whose times the kit judges."""
        before = _rx_error_counters(s.link)
        t0 = time.monotonic()
        s.send(frames)
        sent["seq"] = k
        duty, seen = s.wait_for(lambda f, p: _ok(f, p, "DUTY") and M["DUTY"].unpack_raw(p)[0] == k,
                                KIT_ANSWER_PATIENCE_S)
        if duty is None:
            missing["why"] = diagnose_missing(k, seen, before, _rx_error_counters(s.link))
            return None
        dt = time.monotonic() - t0
        if timed:
            times.append(dt)
            if dt > KIT_ANSWER_LIMIT_S:
                late.append((k, dt))
            rt = loopback.round_trip_s(_wire_octets(frames), _wire_octets(seen + [duty]))
            if rt is not None:
                host.append(rt)
        return seen + [duty]

    def step(pl, got) -> None:
        raw = M["DUTY"].unpack_raw(got[-1][1])
        pl.step(*(-1.0 if r == DUTY_RAW_OFF else r / DUTY_RAW_FULL for r in raw[1:]))

    prepared: list[tuple[int, bytes]] | None = None
    loopback = HostLoopback(loopback_kind)
    try:
        for k in range(cycles):
            frames = prepared or cycle_frames(plant, k)
            prepared = None
            got = answer(k, frames, timed=True)
            if got is None:
                problems.append(f"no DUTY for seq {k}: {missing['why']}")
                break
            stats["answered"] += 1
            cyc = [(f, p) for f, p in got if f != M["HEARTBEAT_CTRL"].frame_id]
            answers.append(cyc)
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
            # the same SENSE again, once the outputs move (6.5): the cached answer, byte for byte
            if repeat_at is None and repeat_from <= k <= repeat_last:
                changed = len(answers) > 1 and answers[-1][-1][1][2:] != answers[-2][-1][1][2:]
                repeat_moving = bool(telem) and telem[0][3] in moving and changed
                if repeat_moving or k == repeat_last:
                    repeat_at, crc_at = k, k + AFTER_REPEAT + 2
                    again = answer(k, frames)
                    same = again is not None and [(f, p) for f, p in again if f != M["HEARTBEAT_CTRL"].frame_id] == cyc
                    state = _status(State, telem[0][3]) if telem else "?"
                    retry_item = Item("6.5", f"SENSE {k} sent again while the outputs change (state {state}): the "
                                             f"same TELEM, TELEM_EMF, DUTY byte for byte (answered from the cache)",
                                      same and repeat_moving,
                                      "no answer" if again is None else ("a different answer" if not same else
                                                                         "" if repeat_moving else
                                                                         "the outputs never changed from one cycle "
                                                                         "to the next: a repeat proves nothing"))
            step(plant, got)
            if crc_at is not None and k + 1 == crc_at and serial:   # its SENSE with a bad CRC first (2.4, 6.0 item 9)
                prepared = cycle_frames(plant, k + 1)
                sense_id, sense = prepared[1]
                body = bytes((sense_id & 0xFF, sense_id >> 8, len(sense))) + sense
                crc = crc16(body) ^ 0x0001
                s.send([prepared[0]])
                s.link.transport.write(cobs_encode(body + bytes((crc & 0xFF, crc >> 8))) + b"\x00")
                stray, _ = s.wait_for(lambda f, p: _ok(f, p, "DUTY"), SILENCE_S)
                crc_item = Item("2.4", "a SENSE with a bad CRC is dropped (no answer); the good one, sent next, "
                                       "is answered", stray is None, "" if stray is None else "a frame with a bad CRC "
                                                                                              "was answered")
    finally:
        loopback.close()
    n = stats["answered"]
    #: the controller stopped answering at this cycle (that item fails); what comes after and gets no
    #: answer either was never really reached: n/a, not a second FAIL
    silent_at = n if n < cycles else None
    gone = (f"not reached: no answer since cycle {silent_at} (the item 'every SENSE answered')"
            if silent_at is not None else "")
    missing_line = next((pr for pr in problems if pr.startswith("no DUTY for seq")), "")
    add(Item("6.4", "every SENSE answered with a DUTY of its seq", n == cycles,
             f"{n}/{cycles} cycles" + (f"; {missing_line}" if n < cycles and missing_line else "")))
    #: the items about the answers have nothing to judge when no cycle was answered: n/a, not FAIL "0/0"
    none_answered = "not reached: no cycle was answered (the item 'every SENSE answered')"
    add(answer_time_item(times, host, late))
    add(Item("6.4", "TELEM, then TELEM_EMF (asked for), then DUTY, nothing else, seq echoed",
             None if n == 0 else stats["order"] == n and stats["emf"] == n,
             none_answered if n == 0 else
             f"{stats['order']}/{n} in order, {stats['emf']}/{n} with every frame of the right seq and length"
             + (f"; {'; '.join(pr for pr in problems[:3] if not pr.startswith('no DUTY'))}"
                if stats["order"] < n else "")))
    add(Item("6.6", "duties in 0..1 (raw 0..32768) or OFF (65535)", None if n == 0 else stats["duty_ok"] == n,
             none_answered if n == 0 else f"{stats['duty_ok']}/{n}"))
    add(Item("6.4", f"TELEM.estimator = {est.name} (the estimator asked for) in every cycle",
             None if n == 0 else stats["estimator"] == n, none_answered if n == 0 else f"{stats['estimator']}/{n}"))
    seen_states = sorted({State(x).name if x in {st.value for st in State} else str(x) for x in states})
    add(Item("6.4", "TELEM.state in the State table; no FAULT_CTRL",
             None if n == 0 else all(x in {st.value for st in State} for x in states) and stats["fault"] == 0,
             none_answered if n == 0 else f"states seen: {', '.join(seen_states)}" + (f"; {stats['fault']} FAULT_CTRL" if stats["fault"] else "")))
    # never reached: the cycles stopped before (MIN_CYCLES makes a session that runs them all reach both)
    add(retry_item or Item("6.5", "a repeated SENSE is answered from the cache", None, gone))
    add(crc_item or Item("2.4", "a SENSE with a bad CRC is dropped", None,
                         "CAN link: the bus checks CRCs" if not serial else gone))

    #: the verdict of a probe that gets no answer: FAIL, or n/a once the controller had gone silent
    no_answer = None if silent_at is not None else False

    # -- STOP (6.3) ----------------------------------------------------------------------------------------
    kk = (sent["seq"] + 1) & 0xFFFF     # a new cycle: the last seq again would be a retry (6.5)
    s.send([(cmd.frame_id, cmd.pack(command=int(Command.STOP), seq=3, value=0.0))])
    got = answer(kk, cycle_frames(plant, kk))
    add(_state_item("6.3", "after CMD STOP: state STOPPED, all legs OFF", got, {State.STOPPED}, no_answer, gone))

    # -- the same cycles again without the repeat: the ISR did not run twice (6.5) ------------------------------
    text = (f"the {AFTER_REPEAT} cycles after the repeated SENSE answer exactly as in a session without the "
            f"repeat (the controller's state advanced once for that cycle)")
    if repeat_at is None or len(answers) < repeat_at + 1 + AFTER_REPEAT:
        add(Item("6.5", text, None, gone or "the repeat was not reached"))
    else:
        ref_plant = plant_factory()
        ref_plant.set_initial(scn.initial_theta_e_rad, scn.initial_speed_rad_s)
        ack = _hello(s, estimator=int(est), flags=flags, period_s=ts_s)
        seq = 0
        configured = ack is not None and ack["status"] == HelloStatus.OK and all(
            (a := config(int(pid), float(value))) is not None and a["status"] == ConfigStatus.OK
            for pid, value in params.items())
        if configured:
            start_running()
        ref: list[list[tuple[int, bytes]]] = []
        for k in range(repeat_at + 1 + AFTER_REPEAT if configured else 0):
            got = answer(k, cycle_frames(ref_plant, k))
            if got is None:
                break
            ref.append([(f, p) for f, p in got if f != M["HEARTBEAT_CTRL"].frame_id])
            step(ref_plant, got)
        s.send([(cmd.frame_id, cmd.pack(command=int(Command.STOP), seq=3, value=0.0))])
        s.wait_for(lambda f, p: False, SILENCE_S)   # let a late answer pass
        before = ref[:repeat_at + 1] == answers[:repeat_at + 1]
        after = [k for k in range(repeat_at + 1, repeat_at + 1 + AFTER_REPEAT)
                 if k < len(ref) and ref[k] != answers[k]]
        if not configured or len(ref) < repeat_at + 1 + AFTER_REPEAT:
            add(Item("6.5", text, False, "the reference session did not run "
                                         f"({'not configured' if not configured else f'{len(ref)} cycles answered'})"))
        elif not before:
            first = next(k for k in range(repeat_at + 1) if ref[k] != answers[k])
            add(Item("6.5", text, None, f"inconclusive: the controller does not repeat a session exactly "
                                        f"(answers differ from cycle {first}, before the repeat)"))
        else:
            add(Item("6.5", text, not after,
                     f"cycles {repeat_at + 1}..{repeat_at + AFTER_REPEAT} identical" if not after else
                     f"cycle {after[0]} differs from the session without the repeat: the repeated SENSE ran the "
                     f"ISR again"))

    # -- a session without TELEM_EMF (6.1, 6.4, 6.5); RUN without the motor, RUN in FAULT, CLEAR_FAULT (6.3);
    # -- FAULT_PLANT (6.7) -----------------------------------------------------------------------------------
    fin = plant_factory()
    fin.set_initial(scn.initial_theta_e_rad, scn.initial_speed_rad_s)
    ack = _hello(s, estimator=int(est), flags=enc_flag, period_s=ts_s)
    ok2 = ack is not None and ack["status"] == HelloStatus.OK
    gone2 = gone or ("" if ok2 else "not reached: the HELLO of this session was not accepted")
    no_answer2 = None if silent_at is not None or not ok2 else False
    k2, cmd_seq = 0, 0

    def command(c: Command, value: float = 0.0) -> None:
        nonlocal cmd_seq
        cmd_seq += 1
        s.send([(cmd.frame_id, cmd.pack(command=int(c), seq=cmd_seq, value=value))])

    def cycle2() -> list[tuple[int, bytes]] | None:
        nonlocal k2
        if not ok2:
            return None
        got = answer(k2, cycle_frames(fin, k2))
        k2 += 1
        if got is not None:
            step(fin, got)
        return got

    emf_seen, answered2 = 0, 0
    for _ in range(3):
        got = cycle2()
        if got is None:
            break
        answered2 += 1
        emf_seen += sum(1 for f, _ in got if f == M["TELEM_EMF"].frame_id)
    add(Item("6.4", "a new session without the flag TELEM_EMF: TELEM and DUTY, never TELEM_EMF; seq 0 runs again",
             ok2 and answered2 == 3 and emf_seen == 0,
             f"HELLO {'OK' if ok2 else 'refused'}, {answered2}/3 answered, {emf_seen} TELEM_EMF"))

    command(Command.RUN)                     # nothing configured in this session: no motor parameters
    got = cycle2()
    st, off, faults = _answer_state(got)
    add(Item("6.3", "RUN with an incomplete configuration (a new session, no CONFIG: no motor parameters): "
                    "FAULT_CTRL CONFIG_INVALID, state FAULT, all legs OFF",
             no_answer2 if got is None else (st == State.FAULT and off and int(Fault.CONFIG_INVALID) in faults),
             (gone2 or "no answer") if got is None else
             f"state {_state_name(st)}, legs OFF: {off}, FAULT_CTRL: "
             f"{', '.join(_status(Fault, c) for c in faults) or 'none'}"))
    seq = 0
    refused = [pid.name for pid, value in params.items()
               if ok2 and ((a := config(int(pid), float(value))) is None or a["status"] != ConfigStatus.OK)]
    command(Command.SET_SPEED_REF, scn.speed_ref_rad_s)
    command(Command.RUN)
    got = cycle2()
    st, off, _ = _answer_state(got)
    add(Item("6.3", "in FAULT, CONFIG is accepted and RUN ignored (the controller stays in FAULT until "
                    "CLEAR_FAULT): state FAULT, all legs OFF",
             no_answer2 if got is None else (st == State.FAULT and off and not refused),
             (gone2 or "no answer") if got is None else
             f"state {_state_name(st)}, legs OFF: {off}" + (f"; CONFIG refused: {', '.join(refused)}"
                                                             if refused else "")))
    command(Command.CLEAR_FAULT)
    add(_state_item("6.3", "CLEAR_FAULT: state IDLE, all legs OFF", cycle2(), {State.IDLE}, no_answer2, gone2))
    command(Command.RUN)
    run3 = [cycle2() for _ in range(3)]
    started = [_answer_state(g) for g in run3 if g is not None]
    moving_states = {State.ALIGN, State.INITIAL_POSITION, State.OPEN_LOOP, State.CLOSED_LOOP}
    add(Item("6.3", "RUN after CLEAR_FAULT starts with the configuration sent before it (kept): a start-up or "
                    "running state, no FAULT_CTRL",
             no_answer2 if len(started) < 3 else all(x[0] in moving_states and not x[2] for x in started),
             (gone2 or f"{len(started)}/3 answered") if len(started) < 3 else
             "states " + ", ".join(_state_name(x[0]) for x in started)
             + ("; FAULT_CTRL " + ", ".join(_status(Fault, c) for x in started for c in x[2])
                if any(x[2] for x in started) else "")))
    fp = M["FAULT_PLANT"]
    s.send([(fp.frame_id, fp.pack(code=int(Fault.HOST_ABORT), seq=max(k2 - 1, 0) & 0xFFFF, detail=0))])
    got = cycle2()
    add(_state_item("6.7", "FAULT_PLANT: the controller stops as on CMD STOP: state STOPPED, all legs OFF", got,
                    {State.STOPPED}, no_answer2, gone2))
    stopped = got is not None

    # -- heartbeats again, after FAULT_PLANT, counting the bad frame (6.7) ---------------------------------------
    beats = [b for _, b in s.heartbeats(2, HEARTBEAT_WAIT_S)]
    counted = bool(beats) and int(beats[-1]["rx_errors"]) >= 1
    state_ok = not stopped or (bool(beats) and int(beats[-1]["state"]) == State.STOPPED)
    bad_crc_sent = serial and crc_item is not None
    add(Item("6.7", "HEARTBEAT_CTRL again once cycles stop" + (", after FAULT_PLANT too (state STOPPED)" if stopped
                                                                else "")
             + ("; rx_errors counts the bad-CRC frame" if bad_crc_sent else ""),
             bool(beats) and state_ok and (counted or not bad_crc_sent),
             f"{len(beats)} heartbeats" + (f", state {_state_name(int(beats[-1]['state']))}, rx_errors "
                                           f"{int(beats[-1]['rx_errors'])}" if beats else "")))


# ---------------------------------------------------------------------------------------------------------
# The items' verdicts and diagnoses
# ---------------------------------------------------------------------------------------------------------

_RX_ERRORS = ("crc_errors", "cobs_errors", "length_errors", "overruns", "rx_malformed")


def _rx_error_counters(link) -> dict[str, int]:
    """The link's counters of what it received and rejected (serial: section 2.4; CAN: malformed lines)."""
    try:
        stats = link.stats()
    except Exception:   # a link without counters: nothing to say about rejected frames
        return {}
    return {k: int(stats.get(k, 0)) for k in _RX_ERRORS}


def _wire_octets(frames: list[tuple[int, bytes]]) -> int:
    """Octets those frames take on a serial link (section 2.1: dlc + 7 each)."""
    return sum(len(p) + 7 for _, p in frames)


def _frame_text(fid: int, payload: bytes) -> str:
    m = _IDS.get(fid)
    if m is None:
        return f"id 0x{fid:03X} (not in the DBC)"
    if len(payload) != m.length:
        return f"{m.name} with {len(payload)} octets (expected {m.length})"
    if "seq" in m.signal_names:
        return f"{m.name} seq {int(m.unpack_raw(payload)[m.signal_names.index('seq')])}"
    return m.name


def diagnose_missing(k: int, seen: list[tuple[int, bytes]], before: dict[str, int], after: dict[str, int]) -> str:
    """Why DUTY(k) did not come, one clause per cause: frames the link rejected (a bad CRC, ...), a DUTY of
    another seq or length (named, with the frames that came), or nothing at all."""
    causes = []
    rejected = {k2: after.get(k2, 0) - before.get(k2, 0) for k2 in after if after.get(k2, 0) > before.get(k2, 0)}
    if rejected.get("crc_errors"):
        causes.append(f"{rejected['crc_errors']} frame(s) failed the CRC check (section 2.4): an answer damaged "
                      f"on the way")
    other = {c: n for c, n in rejected.items() if c != "crc_errors"}
    if other:
        causes.append("frames rejected by the link: " + ", ".join(f"{c} +{n}" for c, n in other.items()))
    duties = [(fid, p) for fid, p in seen if fid == M["DUTY"].frame_id]
    wrong_seq = [int(M["DUTY"].unpack_raw(p)[0]) for fid, p in duties if len(p) == M["DUTY"].length]
    if wrong_seq:
        causes.append(f"a DUTY came with seq {', '.join(map(str, wrong_seq[:4]))}, expected {k}")
    short = [len(p) for fid, p in duties if len(p) != M["DUTY"].length]
    if short:
        causes.append(f"a DUTY came with {short[0]} octets (expected {M['DUTY'].length})")
    came = [_frame_text(fid, p) for fid, p in seen if fid != M["HEARTBEAT_CTRL"].frame_id]
    beats = sum(1 for fid, _ in seen if fid == M["HEARTBEAT_CTRL"].frame_id)
    if not causes:
        if came:
            causes.append("its DUTY never came (lost: nothing was rejected)")
        else:
            causes.append(f"nothing came within {KIT_ANSWER_PATIENCE_S:g} s (the controller is silent"
                          + (f"; {beats} HEARTBEAT_CTRL: it is alive" if beats else "") + ")")
    if came:
        causes.append("frames that came: " + ", ".join(came[:6]) + (f" (+{len(came) - 6})" if len(came) > 6 else ""))
    return "; ".join(causes)


def _quantile(xs: list[float], q: float) -> float:
    """The q-quantile by linear interpolation between order statistics (numpy's default)."""
    ys = sorted(xs)
    pos = q * (len(ys) - 1)
    lo = int(math.floor(pos))
    hi = min(lo + 1, len(ys) - 1)
    return ys[lo] + (ys[hi] - ys[lo]) * (pos - lo)


def answer_time_item(times: list[float], host: list[float], late: list[tuple[int, float]]) -> Item:
    """6.4: the median and p90 of the answer times, each less the host's loopback at that quantile, within
    KIT_ANSWER_LIMIT_S; the late answers (beyond the limit) named with their times."""
    labels = {0.5: "median", 0.9: "p90"}
    text = (f"answer time: the {' and the '.join(labels.get(q, f'p{q * 100:g}') for q in KIT_ANSWER_QUANTILES)} "
            f"of SENSE(k) -> DUTY(k), less the host's own loopback, within {KIT_ANSWER_LIMIT_S * 1e3:g} ms "
            f"(section 9)")
    if not times:
        return Item("6.4", text, None, "not reached: no cycle was answered (the item 'every SENSE answered')")
    parts, ok = [], True
    for q in KIT_ANSWER_QUANTILES:
        a = _quantile(times, q)
        h = _quantile(host, q) if host else 0.0
        net = max(a - h, 0.0)
        ok = ok and net <= KIT_ANSWER_LIMIT_S
        parts.append(f"{labels.get(q, q)} {a * 1e3:.2f} ms - host {h * 1e3:.2f} ms = {net * 1e3:.2f} ms")
    detail = (f"{len(times)} answers: " + ", ".join(parts) + f"; slowest {max(times) * 1e3:.1f} ms"
              + (f"; {len(late)} late (beyond {KIT_ANSWER_LIMIT_S * 1e3:g} ms): "
                 + ", ".join(f"seq {k} {dt * 1e3:.0f} ms" for k, dt in late[:5]) if late else ""))
    return Item("6.4", text, ok, detail)


def _theil_sen(xs: list[float], ys: list[float]) -> float:
    """The median of the pairwise slopes (y_j - y_i) / (x_j - x_i): robust to 29 % of outliers."""
    slopes = [(ys[j] - ys[i]) / (xs[j] - xs[i]) for i in range(len(xs)) for j in range(i + 1, len(xs))
              if xs[j] != xs[i]]
    return _quantile(slopes, 0.5) if slopes else math.nan


def heartbeat_item(beats: list[tuple[float, dict]]) -> Item:
    """6.7: at least KIT_HEARTBEAT_MIN_COUNT HEARTBEAT_CTRL in KIT_HEARTBEAT_WINDOW_S, the counter +1 each, the
    period (Theil-Sen slope of arrival time over counter: a host stall that bunches arrivals does not move it)
    above HEARTBEAT_GAP_MIN_S and below HEARTBEAT_GAP_MAX_S."""
    text = (f"HEARTBEAT_CTRL every {HEARTBEAT_PERIOD_S * 1e3:g} ms while idle: over {KIT_HEARTBEAT_WINDOW_S:g} s "
            f"at least {KIT_HEARTBEAT_MIN_COUNT}, counter +1 each, their period (robust fit) above "
            f"{HEARTBEAT_GAP_MIN_S * 1e3:g} and below {HEARTBEAT_GAP_MAX_S * 1e3:g} ms")
    counters = [int(b["counter"]) for _, b in beats]
    steps = [(b - a) & 0xFFFF for a, b in zip(counters, counters[1:])]
    unwrapped = [0]
    for st in steps:
        unwrapped.append(unwrapped[-1] + st)
    period = _theil_sen([float(c) for c in unwrapped], [t for t, _ in beats]) if len(beats) >= 2 else math.nan
    gaps = [b[0] - a[0] for a, b in zip(beats, beats[1:])]
    causes = []
    if len(beats) < KIT_HEARTBEAT_MIN_COUNT:
        causes.append(f"only {len(beats)} in {KIT_HEARTBEAT_WINDOW_S:g} s")
    if any(st != 1 for st in steps):
        causes.append(f"counter steps {sorted(set(steps))} (+1 expected)")
    if not HEARTBEAT_GAP_MIN_S < period < HEARTBEAT_GAP_MAX_S:
        causes.append(f"period {period * 1e3:.0f} ms" if period == period else "no period")
    detail = (f"{len(beats)} heartbeats, counters {counters[:3]}..{counters[-1:]}, period {period * 1e3:.1f} ms"
              if beats else "none")
    if gaps:
        detail += f" (gaps {min(gaps) * 1e3:.0f} .. {max(gaps) * 1e3:.0f} ms as the host saw them)"
    if causes:
        detail += "; " + "; ".join(causes)
    return Item("6.7", text, not causes, detail)


def _answer_state(got) -> tuple[int | None, bool, list[int]]:
    """An answer's TELEM.state (None: no TELEM), whether its DUTY has every leg OFF, and the codes of the
    FAULT_CTRL frames that came with it."""
    if got is None:
        return None, False, []
    telem = [M["TELEM"].unpack_raw(p) for f, p in got if _ok(f, p, "TELEM")]
    off = all(r == DUTY_RAW_OFF for r in M["DUTY"].unpack_raw(got[-1][1])[1:])
    faults = [int(M["FAULT_CTRL"].unpack_raw(p)[0]) for f, p in got if _ok(f, p, "FAULT_CTRL")]
    return (int(telem[0][3]) if telem else None), off, faults


def _state_name(state: int | None) -> str:
    return "? (no TELEM)" if state is None else _status(State, state)


def _state_item(section: str, text: str, got, states: set[State], no_answer: bool | None, gone: str) -> Item:
    """An item that a cycle's answer is in one of ``states`` with every leg OFF."""
    if got is None:
        return Item(section, text, no_answer, gone or "no answer")
    st, off, _ = _answer_state(got)
    return Item(section, text, st in states and off, f"state {_state_name(st)}, legs OFF: {off}")


def main(args: argparse.Namespace) -> int:
    """``bench conformance`` (see ``bench/cli.py``)."""
    from hil_bench.scenario import ScenarioError

    try:
        result = run_conformance(args.link, cycles=args.cycles, estimator=args.estimator.upper())
    except (ScenarioError, KeyError, ValueError) as exc:
        print(f"error: {exc}")
        return 2
    print(result.text())
    if result.aborted:
        return 2 if not result.items else 1
    return 0 if result.passed else 1
