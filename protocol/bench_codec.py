#!/usr/bin/env python3
"""Micro-benchmark of the per-cycle Python path: message codec and serial framing.

    python protocol/bench_codec.py [--number 20000] [--repeat 7]

Prints the best (and median) time per operation in microseconds over ``repeat`` runs of ``number``
calls. Targets: SENSE pack_values + unpack_values well under 5 us; encode_frame + Deframer.feed of one
8-octet frame under about 5 us. cantools is timed for comparison.
"""
from __future__ import annotations

import argparse
import platform
import statistics
import sys
import timeit

from hil_bench.protocol import dbc
from hil_bench.protocol.framing import Deframer, encode_frame
from hil_bench.protocol.messages import MESSAGES


def cases() -> dict[str, object]:
    sense, duty = MESSAGES["SENSE"], MESSAGES["DUTY"]
    values = (1234, 1.234, -2.5, 1.266)
    payload = sense.pack_values(values)
    duty_values = (1234, 0.25, 0.5, 0.75)
    duty_payload = duty.pack_values(duty_values)
    wire = encode_frame(sense.frame_id, payload)
    deframer = Deframer()
    ct = dbc.database().get_message_by_name("SENSE")
    ct_values = dict(zip(sense.signal_names, values))
    return {
        "SENSE pack_values + unpack_values": lambda: sense.unpack_values(sense.pack_values(values)),
        "SENSE pack_values": lambda: sense.pack_values(values),
        "SENSE unpack_values": lambda: sense.unpack_values(payload),
        "DUTY pack_values + unpack_raw": lambda: duty.unpack_raw(duty.pack_values(duty_values)),
        "DUTY unpack_values": lambda: duty.unpack_values(duty_payload),
        "encode_frame (8 octets)": lambda: encode_frame(0x100, payload),
        "Deframer.feed (one 15-octet frame)": lambda: deframer.feed(wire),
        "encode_frame + Deframer.feed": lambda: deframer.feed(encode_frame(0x100, payload)),
        "SENSE pack + frame + deframe + unpack": lambda: [
            sense.unpack_values(p) for _, p in deframer.feed(encode_frame(0x100, sense.pack_values(values)))],
        "cantools SENSE encode + decode (reference)": lambda: ct.decode(ct.encode(ct_values)),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--number", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args(argv)
    print(f"Python {platform.python_version()} on {platform.machine()}, "
          f"best / median of {args.repeat} x {args.number} calls, microseconds per call")
    for name, fn in cases().items():
        number = args.number // 10 if name.startswith("cantools") else args.number
        runs = [t / number * 1e6 for t in timeit.repeat(fn, number=number, repeat=args.repeat)]  # type: ignore[arg-type]
        print(f"  {name:45s} {min(runs):7.2f}  {statistics.median(runs):7.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
