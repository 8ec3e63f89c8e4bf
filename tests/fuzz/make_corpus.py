"""Write the seed corpora of the libFuzzer harnesses (tests/fuzz/corpus/<harness>/) from the
shared golden vectors (protocol/vectors/) and one scripted session. Deterministic: re-running
it rewrites the same files.

    .venv/bin/python tests/fuzz/make_corpus.py
"""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

from hil_bench.protocol.messages import MESSAGES, PROTO_VERSION, Command, Estimator, Param

ROOT = Path(__file__).resolve().parents[2]
VECTORS = ROOT / "protocol" / "vectors"
CORPUS = Path(__file__).resolve().parent / "corpus"
# fuzz_msgs.c: selector byte -> message
MSG_ORDER = ["FAULT_PLANT", "FAULT_CTRL", "HELLO", "HELLO_ACK", "CONFIG", "CONFIG_ACK", "CMD",
             "HEARTBEAT_PLANT", "HEARTBEAT_CTRL", "SENSE", "SENSE_AUX", "SENSE_DUAL", "DUTY",
             "TELEM", "TELEM_EMF"]
# fuzz_session.c: selector -> frame (9: raw octets)
SESSION_IDS = ["HELLO", "CONFIG", "CMD", "SENSE", "SENSE_AUX", "SENSE_DUAL", "HEARTBEAT_PLANT",
               "FAULT_PLANT"]


def write(harness: str, data: bytes) -> None:
    d = CORPUS / harness
    d.mkdir(parents=True, exist_ok=True)
    (d / hashlib.sha1(data).hexdigest()[:16]).write_bytes(data)


def record(name: str, payload: bytes, flags: int = 0) -> bytes:
    assert len(payload) == 8
    return bytes([SESSION_IDS.index(name), flags]) + payload


def session(estimator: Estimator, n_cycles: int, amp_a: float, extra: list[bytes] = ()) -> bytes:
    """HELLO, the Gong motor's CONFIG, RUN, speed reference, then cycles of rotating currents."""
    out = [record("HELLO", MESSAGES["HELLO"].pack(proto_version=PROTO_VERSION, proto_minor=1, mode=0, period_us=100.0,
                                                   estimator=int(estimator), flags=0, session=7))]
    cfg = {Param.RS_OHM: 0.6383, Param.LD_H: 2e-3, Param.LQ_H: 2e-3, Param.PSI_F_WB: 0.085,
           Param.POLE_PAIRS: 4, Param.J_KGM2: 0.013, Param.B_NMS: 0.0035, Param.V_DC_NOM_V: 310.0}
    for seq, (p, v) in enumerate(cfg.items()):
        out.append(record("CONFIG", MESSAGES["CONFIG"].pack(param_id=int(p), config_seq=seq, value=v)))
    out.append(record("CMD", MESSAGES["CMD"].pack(command=int(Command.SET_SPEED_REF), seq=1, value=52.3)))
    out.append(record("CMD", MESSAGES["CMD"].pack(command=int(Command.RUN), seq=2, value=0.0)))
    out += list(extra)
    for k in range(n_cycles):
        th = 0.02 * k
        i = [amp_a * math.cos(th - j * 2.0 * math.pi / 3.0) for j in range(3)]
        out.append(record("SENSE_AUX", MESSAGES["SENSE_AUX"].pack(seq=k, v_dc=310.0, theta_enc=th % 6.28,
                                                                   flags=1)))
        out.append(record("SENSE", MESSAGES["SENSE"].pack(seq=k, i_a=i[0], i_b=i[1], i_c=i[2])))
    return b"".join(out)


def main() -> None:
    for old in CORPUS.glob("*/*"):
        old.unlink()
    index = json.loads((VECTORS / "index.json").read_text())
    for case in index["cases"]:
        meta = json.loads((VECTORS / f"{case}.json").read_text())
        blob = (VECTORS / f"{case}.bin").read_bytes()
        if meta.get("kind") == "message":
            write("msgs", bytes([MSG_ORDER.index(meta["name"])]) + blob)
        else:
            write("deframer", blob)
    write("session", session(Estimator.SMO_SIGN, 40, 2.0))
    write("session", session(Estimator.ENCODER, 40, 32.0))          # over-current trip (30 A)
    write("session", session(Estimator.HFI_SDFT, 30, 0.5))
    write("session", session(Estimator.SMO_TANH, 20, 1.0, [
        record("CMD", MESSAGES["CMD"].pack(command=int(Command.CLEAR_FAULT), seq=3, value=0.0)),
        bytes([9, 0]) + b"\x00\x11\x22\x00\x33\x44\x55\x00"]))     # garbage between frames
    print(f"corpus: {sum(1 for _ in CORPUS.glob('*/*'))} files in {CORPUS}")


if __name__ == "__main__":
    main()
