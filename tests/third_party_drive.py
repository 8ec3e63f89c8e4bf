#!/usr/bin/env python3
"""An independent controller written from docs/protocol.md alone, as a drive team outside the project would.

It is a drive of **protocol 1.0**, built against the DBC of that release (``protocol/versions/1.0.dbc``,
as a drive team's copy of last month's table would be): it knows the 62 parameters, the estimators and the
commands of 1.0, answers UNKNOWN_PARAM to a parameter added since, and sends 0 in the bits of HELLO_ACK that
1.1 uses for its minor version. Today's host serves it as 1.0 (docs/protocol.md 6.1, section 10).

It shares no code with the bench: its own COBS, CRC-16 and deframer (docs/protocol.md section 2), stock
cantools on that DBC for the payloads (section 4), and its own sensorless FOC: Clarke/Park, a
sign sliding-mode observer with a low-pass filter and a PLL, an alignment and I-f start-up, speed and
current PI, SVPWM (textbook; the parameters come over CONFIG, section 6.2). It follows the session rules
of section 6: HELLO statuses (it runs lockstep only and answers MODE_UNSUPPORTED to real time), CONFIG
acknowledged for every parameter of the table, TELEM + TELEM_EMF + DUTY per SENSE, the answer cache for
a repeated SENSE, the encoder angle only with THETA_ENC_VALID, HEARTBEAT_CTRL while idle, RUN refused in FAULT until
CLEAR_FAULT (back to IDLE), FAULT_PLANT answered by stopping.

    python tests/third_party_drive.py --fd N          # a pty master (or any byte stream) passed as fd N
    python tests/third_party_drive.py --port PATH     # a tty / pty slave
        [--cheat encoder|lie] [--report FILE.json] [--heartbeat-s S]

``--cheat encoder``: closes its loop on SENSE_AUX.theta_enc whenever it gets one while asked for a
sensorless estimator, and says so in TELEM.estimator (ENCODER). ``--cheat lie``: the same, but reports
the requested estimator. ``--report``: at exit, a JSON file with what the drive saw (cycles, cycles with
a valid encoder angle, the HELLO it accepted, retries answered from the cache, frames rejected).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import select
import sys
import time
from pathlib import Path

import cantools

#: the DBC this drive was built against: protocol 1.0's, as released
DBC = Path(__file__).resolve().parents[1] / "protocol" / "versions" / "1.0.dbc"
TWO_PI = 2.0 * math.pi
SQRT3 = math.sqrt(3.0)
ANGLE_SCALE = TWO_PI / 65536.0

# value tables of the spec (section 5)
ST_IDLE, ST_ALIGN, ST_OPEN_LOOP, ST_CLOSED_LOOP, ST_FAULT, ST_STOPPED = 0, 1, 2, 3, 4, 6
EST_SMO_SIGN, EST_ENCODER = 1, 5
FLAG_TELEM_EMF, FLAG_ENCODER_VALID = 0x02, 0x04
AUX_THETA_ENC_VALID = 0x02
CMD_RUN, CMD_STOP, CMD_CLEAR_FAULT, CMD_SET_SPEED_REF = 1, 2, 3, 4
FAULT_OVERCURRENT, FAULT_CONFIG_INVALID = 4, 8
INTEGER_PARAMS = {"POLE_PAIRS", "SPEED_LOOP_DIV", "HARM_GSDFT_M"}
CHOICE_PARAMS = {"HARM_COMP_ENABLE": {0, 1}, "SMO_LAG_COMP": {0, 1, 2}, "DELAY_COMP_ENABLE": {0, 1, 2},
                 "HARM_EXTRACTOR": {0, 1}}


# ---------------------------------------------------------------------------------------------------------
# Framing (docs/protocol.md section 2), written from the spec
# ---------------------------------------------------------------------------------------------------------

def crc16_ccitt_false(data: bytes) -> int:
    crc = 0xFFFF
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def cobs_encode(data: bytes) -> bytes:
    out = bytearray([0])
    code_at, code = 0, 1
    for b in data:
        if b == 0:
            out[code_at] = code
            code_at = len(out)
            out.append(0)
            code = 1
        else:
            out.append(b)
            code += 1
            if code == 0xFF:
                out[code_at] = code
                code_at = len(out)
                out.append(0)
                code = 1
    out[code_at] = code
    return bytes(out)


def cobs_decode(chunk: bytes) -> bytes | None:
    out = bytearray()
    i = 0
    while i < len(chunk):
        code = chunk[i]
        if code == 0 or i + code > len(chunk):
            return None
        out += chunk[i + 1:i + code]
        i += code
        if code != 0xFF and i < len(chunk):
            out.append(0)
    return bytes(out)


def encode_frame(frame_id: int, data: bytes) -> bytes:
    body = bytes((frame_id & 0xFF, frame_id >> 8, len(data))) + data
    crc = crc16_ccitt_false(body)
    return cobs_encode(body + bytes((crc & 0xFF, crc >> 8))) + b"\x00"


class Deframer:
    """Section 2.4: chunks between 0x00 delimiters; every rejected chunk counts one error."""

    def __init__(self):
        self.buf = bytearray()
        self.errors = 0
        self.frames = 0
        self.overrun = False

    def feed(self, data: bytes) -> list[tuple[int, bytes]]:
        out = []
        for b in data:
            if b != 0:
                if len(self.buf) >= 70:
                    if not self.overrun:
                        self.errors += 1
                        self.overrun = True
                    continue
                self.buf.append(b)
                continue
            chunk, self.buf = bytes(self.buf), bytearray()
            if self.overrun:
                self.overrun = False
                continue
            if not chunk:
                continue
            raw = cobs_decode(chunk)
            if raw is None or len(raw) < 5 or raw[2] > 64 or len(raw) != 5 + raw[2]:
                self.errors += 1
                continue
            if crc16_ccitt_false(raw[:-2]) != raw[-2] | raw[-1] << 8:
                self.errors += 1
                continue
            fid = raw[0] | raw[1] << 8
            if fid > 0x7FF:
                self.errors += 1
                continue
            self.frames += 1
            out.append((fid, raw[3:-2]))
        return out


# ---------------------------------------------------------------------------------------------------------
# The drive
# ---------------------------------------------------------------------------------------------------------

def round_half_away(x: float) -> int:
    """Section 3: to the nearest integer, ties away from zero (Python's round() goes to even)."""
    return int(math.floor(x + 0.5)) if x >= 0 else -int(math.floor(-x + 0.5))


def clamp(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


def wrap_pi(x: float) -> float:
    return (x + math.pi) % TWO_PI - math.pi


class Pi:
    def __init__(self, kp: float, ki: float, limit: float):
        self.kp, self.ki, self.limit, self.integ = kp, ki, limit, 0.0

    def step(self, err: float, ts: float) -> float:
        self.integ = clamp(self.integ + self.ki * err * ts, -self.limit, self.limit)
        return clamp(self.kp * err + self.integ, -self.limit, self.limit)


class Drive:
    def __init__(self, write, cheat: str | None):
        self.db = cantools.database.load_file(str(DBC))
        self.msg = {m.name: m for m in self.db.messages}
        self.by_id = {m.frame_id: m for m in self.db.messages}
        self.param_names = {int(k): str(v) for k, v in
                            self.msg["CONFIG"].get_signal_by_name("param_id").choices.items()}
        self.write = write
        self.cheat = cheat
        self.session_ok = False
        self.flags = 0
        self.estimator = EST_SMO_SIGN
        self.ts = 1e-4
        self.params: dict[str, float] = {}
        self.state = ST_IDLE
        self.speed_ref_m = 0.0
        self.last_seq: int | None = None
        self.cache: list[tuple[int, bytes]] = []
        self.aux: dict | None = None
        self.hb_counter = 0
        self.rx_rejected = 0
        self.report = {"cycles": 0, "encoder_valid_cycles": 0, "retries_answered": 0, "hello": None,
                       "frames_rejected": 0}

    # -- sending ---------------------------------------------------------------------------------------
    def send(self, name: str, values: dict, scaling: bool = True) -> bytes:
        m = self.msg[name]
        data = m.encode(values, scaling=scaling, strict=True)
        self.write(encode_frame(m.frame_id, data))
        return data

    def heartbeat(self, deframer_errors: int, frames: int) -> None:
        self.send("HEARTBEAT_CTRL", {"counter": self.hb_counter & 0xFFFF, "state": self.state,
                                     "rx_errors": min(deframer_errors + self.rx_rejected, 0xFFFF),
                                     "rx_frames": frames & 0xFFFF})
        self.hb_counter += 1

    # -- receiving ---------------------------------------------------------------------------------------
    def on_frame(self, fid: int, data: bytes) -> None:
        m = self.by_id.get(fid)
        if m is None or len(data) != m.length:
            self.rx_rejected += 1
            return
        v = m.decode(data, decode_choices=False, scaling=True)
        handler = getattr(self, "on_" + m.name.lower(), None)
        if handler is not None:
            handler(v)

    def on_hello(self, v: dict) -> None:
        status = 0
        if v["proto_version"] != 1:
            status = 1                                       # VERSION_MISMATCH
        elif v["mode"] != 0:
            status = 5                                       # MODE_UNSUPPORTED: lockstep only
        elif v["estimator"] not in (EST_SMO_SIGN, EST_ENCODER) or (
                v["estimator"] == EST_ENCODER and not int(v["flags"]) & FLAG_ENCODER_VALID):
            status = 2                                       # ESTIMATOR_UNSUPPORTED
        elif not v["period_us"] >= 10.0:
            status = 4                                       # PERIOD_UNSUPPORTED
        self.send("HELLO_ACK", {"proto_version": 1, "status": status, "fw_version": 0x0001,
                                "estimators": (1 << EST_SMO_SIGN) | (1 << EST_ENCODER), "session": v["session"]})
        if status == 0:
            self.session_ok = True
            self.flags = int(v["flags"])
            self.estimator = int(v["estimator"])
            self.ts = float(v["period_us"]) * 1e-6
            self.params = {}
            self.state = ST_IDLE
            self.last_seq, self.cache, self.aux = None, [], None
            self.report["hello"] = {"estimator": self.estimator, "flags": self.flags, "period_us": v["period_us"]}

    def on_config(self, v: dict) -> None:
        pid, value = int(v["param_id"]), float(v["value"])
        name = self.param_names.get(pid)
        if self.state not in (ST_IDLE, ST_STOPPED, ST_FAULT):
            status = 3                                       # LOCKED
        elif name is None:
            status = 1                                       # UNKNOWN_PARAM
        elif not math.isfinite(value) or (name in INTEGER_PARAMS and value != int(value)) or \
                (name in CHOICE_PARAMS and value not in CHOICE_PARAMS[name]):
            status = 2                                       # OUT_OF_RANGE
        else:
            status = 0
            self.params[name] = value                        # also those this drive does not use
        self.send("CONFIG_ACK", {"param_id": pid, "config_seq": v["config_seq"], "status": status})

    def on_cmd(self, v: dict) -> None:
        c = int(v["command"])
        if c == CMD_SET_SPEED_REF:
            self.speed_ref_m = float(v["value"])
        elif c == CMD_RUN and self.state != ST_FAULT:      # 6.3: a fault stands until CLEAR_FAULT
            self.start(int(v["seq"]))
        elif c == CMD_STOP and self.state != ST_FAULT:
            self.state = ST_STOPPED
        elif c == CMD_CLEAR_FAULT and self.state == ST_FAULT:
            self.state = ST_IDLE

    def on_sense_aux(self, v: dict) -> None:
        self.aux = v

    def on_fault_plant(self, v: dict) -> None:
        """6.7: the host ended the run; stop as on CMD STOP (SENSE still answered, heartbeats go on)."""
        if self.state != ST_FAULT:
            self.state = ST_STOPPED

    def fault(self, code: int, seq: int) -> None:
        self.state = ST_FAULT
        self.send("FAULT_CTRL", {"code": code, "seq": seq, "detail": 0})

    # -- control --------------------------------------------------------------------------------------------
    def p(self, name: str, default: float) -> float:
        return self.params.get(name, default)

    def start(self, seq: int) -> None:
        need = ("RS_OHM", "LQ_H", "PSI_F_WB", "POLE_PAIRS", "J_KGM2", "V_DC_NOM_V")
        if any(self.params.get(n, 0.0) <= 0.0 for n in need):
            self.fault(FAULT_CONFIG_INVALID, seq)
            return
        p = self.p
        self.rs, self.ls, self.psi = p("RS_OHM", 0), p("LQ_H", 0), p("PSI_F_WB", 0)
        self.pp = int(p("POLE_PAIRS", 1))
        self.td = p("CTRL_DELAY_S", 0.0)
        bw_i = TWO_PI / (20.0 * self.ts)                     # current loop at 1/20 of the PWM rate
        self.vmax = p("V_DC_NOM_V", 0) / SQRT3 * 0.98
        self.pi_d = Pi(self.ls * bw_i, self.rs * bw_i, self.vmax)
        self.pi_q = Pi(self.ls * bw_i, self.rs * bw_i, self.vmax)
        kt, bw_s = 1.5 * self.pp * self.psi, 2 * math.pi * 10
        iq_max = p("IQ_MAX_A", 5.0)
        self.pi_w = Pi(p("J_KGM2", 0) * bw_s / kt, p("J_KGM2", 0) * bw_s / kt * bw_s / 4, iq_max)
        self.k_smo = p("SMO_K_V", 0.0) or 1.5 * self.psi * self.pp * 200.0
        self.wc = p("SMO_WC_RAD_S", 0.0) or 1000.0
        wn = 150.0
        self.pll_kp, self.pll_ki = 2 * 0.707 * wn, wn * wn
        self.i_hat = [0.0, 0.0]
        self.z = [0.0, 0.0]
        self.e = [0.0, 0.0]
        self.th_pll, self.w_pll = 0.0, 0.0
        self.v_prev, self.v_older = (0.0, 0.0), (0.0, 0.0)
        self.th_ol, self.w_ol_m = 0.0, 0.0
        self.t_state = 0.0
        self.id_ref = self.iq_ref = 0.0
        self.state = ST_ALIGN

    def observe(self, i_al: float, i_be: float) -> None:
        """Sign SMO: advance the current model over the last period with the voltage that acted (the
        older duties for t_d, the newer for the rest: section 6.4), then switch on the new error."""
        w = self.td / self.ts
        v = [w * self.v_older[j] + (1 - w) * self.v_prev[j] for j in range(2)]
        i = (i_al, i_be)
        for j in range(2):
            self.i_hat[j] += self.ts / self.ls * (v[j] - self.rs * self.i_hat[j] - self.z[j])
            self.z[j] = self.k_smo * (1.0 if self.i_hat[j] > i[j] else -1.0 if self.i_hat[j] < i[j] else 0.0)
            self.e[j] += self.ts * self.wc * (self.z[j] - self.e[j])
        th = math.atan2(-self.e[0], self.e[1]) + math.atan2(self.w_pll, self.wc)   # LPF lag compensated
        err = wrap_pi(th - self.th_pll)
        self.w_pll += self.pll_ki * err * self.ts
        self.th_pll = (self.th_pll + (self.w_pll + self.pll_kp * err) * self.ts) % TWO_PI

    def isr(self, seq: int, ia: float, ib: float, ic: float) -> tuple[list[float], float, float]:
        """One control period: duties (None = leg OFF), the angle and electrical speed reported."""
        if self.state in (ST_IDLE, ST_STOPPED, ST_FAULT):
            return [None, None, None], getattr(self, "th_pll", 0.0), getattr(self, "w_pll", 0.0)
        if max(abs(ia), abs(ib), abs(ic)) > self.p("I_MAX_TRIP_A", 30.0):
            self.fault(FAULT_OVERCURRENT, seq)
            return [None, None, None], self.th_pll, self.w_pll
        vdc = self.aux["v_dc"] if self.aux and self.aux["v_dc"] > 1.0 else self.p("V_DC_NOM_V", 0)
        i_al, i_be = (2 * ia - ib - ic) / 3.0, (ib - ic) / SQRT3
        self.observe(i_al, i_be)
        enc = self.encoder_angle(seq)
        cheating = self.cheat is not None and enc is not None
        p, ts = self.p, self.ts
        self.t_state += ts
        if cheating:
            th, w_e = enc, self.w_pll
            if self.state != ST_CLOSED_LOOP:
                self.state, self.pi_w.integ = ST_CLOSED_LOOP, 0.0
        elif self.state == ST_ALIGN:
            th, w_e = 0.0, 0.0
            self.id_ref, self.iq_ref = p("ALIGN_I_A", 2.0) * min(1.0, self.t_state / 0.05), 0.0
            if self.t_state >= p("ALIGN_TIME_S", 0.2):
                self.state, self.t_state = ST_OPEN_LOOP, 0.0
        elif self.state == ST_OPEN_LOOP:
            self.w_ol_m += p("IF_ACCEL_RAD_S2", 50.0) * ts
            self.th_ol = (self.th_ol + self.w_ol_m * self.pp * ts) % TWO_PI
            th, w_e = self.th_ol, self.w_ol_m * self.pp
            self.id_ref = p("ALIGN_I_A", 2.0) * max(0.0, 1.0 - self.t_state / 0.05)
            self.iq_ref = p("IF_I_A", 2.0)
            if self.w_ol_m >= p("HANDOVER_SPEED_RAD_S", 20.0):
                # hand over: the current vector stays where it is in the estimator's frame
                d = wrap_pi(self.th_ol - self.th_pll)
                self.id_ref, iq = -self.iq_ref * math.sin(d), self.iq_ref * math.cos(d)
                self.pi_w.integ, self.iq_ref = iq, iq
                self.state, self.t_state = ST_CLOSED_LOOP, 0.0
                self.id_fade = self.id_ref
        if self.state == ST_CLOSED_LOOP and not cheating:
            th, w_e = self.th_pll, self.w_pll
            self.id_ref = getattr(self, "id_fade", 0.0) * max(0.0, 1.0 - self.t_state / p("HANDOVER_TIME_S", 0.05))
        if self.state == ST_CLOSED_LOOP:
            self.iq_ref = self.pi_w.step(self.speed_ref_m - w_e / self.pp, ts)
        # currents in the angle's frame, PI with decoupling
        c, s = math.cos(th), math.sin(th)
        i_d, i_q = c * i_al + s * i_be, -s * i_al + c * i_be
        vd = self.pi_d.step(self.id_ref - i_d, ts) - w_e * self.ls * i_q
        vq = self.pi_q.step(self.iq_ref - i_q, ts) + w_e * (self.ls * i_d + self.psi)
        mag = math.hypot(vd, vq)
        vmax = vdc / SQRT3 * 0.98
        if mag > vmax:
            vd, vq = vd * vmax / mag, vq * vmax / mag
        # the voltage acts from t_k + t_d for one period: advance the angle to its middle
        thp = th + w_e * (self.td + ts / 2)
        c, s = math.cos(thp), math.sin(thp)
        v_al, v_be = c * vd - s * vq, s * vd + c * vq
        va, vb, vc = v_al, -0.5 * v_al + SQRT3 / 2 * v_be, -0.5 * v_al - SQRT3 / 2 * v_be
        vo = -(max(va, vb, vc) + min(va, vb, vc)) / 2
        duties = [clamp(0.5 + (x + vo) / vdc, 0.0, 1.0) for x in (va, vb, vc)]
        self.v_older = self.v_prev
        self.v_prev = ((2 * duties[0] - duties[1] - duties[2]) * vdc / 3, (duties[1] - duties[2]) * vdc / SQRT3)
        return duties, (th if cheating else self.th_pll), (w_e if cheating else self.w_pll)

    def encoder_angle(self, seq: int) -> float | None:
        """Section 6.8: only with THETA_ENC_VALID in the SENSE_AUX of this very seq."""
        if self.aux is None or int(self.aux["seq"]) != seq or not int(self.aux["flags"]) & AUX_THETA_ENC_VALID:
            return None
        self.report["encoder_valid_cycles"] += 1
        return float(self.aux["theta_enc"])

    def on_sense(self, v: dict) -> None:
        if not self.session_ok:
            return
        seq = int(v["seq"])
        if seq == self.last_seq:                            # a retry (6.5): the same answer, no ISR
            self.report["retries_answered"] += 1
            for fid, data in self.cache:
                self.write(encode_frame(fid, data))
            return
        self.last_seq = seq
        self.report["cycles"] += 1
        duties, th, w_e = self.isr(seq, v["i_a"], v["i_b"], v["i_c"])
        reported = EST_ENCODER if (self.cheat == "encoder" and self.report["encoder_valid_cycles"]) \
            else self.estimator
        raw_th = round_half_away((th % TWO_PI) / ANGLE_SCALE) % 65536   # section 3: wraps at 2 pi
        self.cache = []
        telem = self.send("TELEM", {"seq": seq, "theta_hat": raw_th, "omega_hat": round_half_away(clamp(w_e, -3276.8, 3276.7) * 10),
                                    "state": self.state, "estimator": reported}, scaling=False)
        self.cache.append((self.msg["TELEM"].frame_id, telem))
        if self.flags & FLAG_TELEM_EMF:
            e = getattr(self, "e", [0.0, 0.0])
            emf = self.send("TELEM_EMF", {"seq": seq, "e_alpha": clamp(e[0], -327.68, 327.67),
                                          "e_beta": clamp(e[1], -327.68, 327.67),
                                          "i_q_ref": clamp(getattr(self, "iq_ref", 0.0), -32.768, 32.767)})
            self.cache.append((self.msg["TELEM_EMF"].frame_id, emf))
        # cantools truncates toward zero where the spec rounds (section 3): round the raw duty ourselves
        raw = {f"d_{x}": 65535 if d is None else round_half_away(d * 32768) for x, d in zip("abc", duties)}
        duty = self.send("DUTY", {"seq": seq, **raw}, scaling=False)
        self.cache.append((self.msg["DUTY"].frame_id, duty))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    where = ap.add_mutually_exclusive_group(required=True)
    where.add_argument("--fd", type=int, help="an open byte-stream descriptor (e.g. a pty master)")
    where.add_argument("--port", help="a tty or pty slave path")
    ap.add_argument("--cheat", choices=("encoder", "lie"), default=None)
    ap.add_argument("--report", type=Path, default=None)
    ap.add_argument("--idle-exit-s", type=float, default=30.0, help="exit after this long without a frame")
    ap.add_argument("--heartbeat-s", type=float, default=0.1,
                    help="HEARTBEAT_CTRL period (section 6.7: 0.1; another value makes a drive that breaks it)")
    args = ap.parse_args(argv)
    if args.fd is not None:
        fd = args.fd
    else:
        import tty

        fd = os.open(args.port, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(fd)

    def write(data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]

    drive = Drive(write, args.cheat)
    deframer = Deframer()
    last_rx = last_hb = last_cycle = time.monotonic()
    cycles_seen = 0
    try:
        while True:
            r, _, _ = select.select([fd], [], [], 0.02)
            now = time.monotonic()
            if r:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    break                                    # the host closed the link
                if not data:
                    break
                last_rx = now
                for fid, payload in deframer.feed(data):
                    drive.on_frame(fid, payload)
            if drive.report["cycles"] != cycles_seen:
                cycles_seen, last_cycle = drive.report["cycles"], now
            if now - last_cycle >= 0.1 and now - last_hb >= args.heartbeat_s:   # 6.7: while no cycles flow
                drive.heartbeat(deframer.errors, deframer.frames)
                last_hb = now
            if now - last_rx > args.idle_exit_s:
                break
    finally:
        drive.report["frames_rejected"] = deframer.errors + drive.rx_rejected
        if args.report is not None:
            args.report.write_text(json.dumps(drive.report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
