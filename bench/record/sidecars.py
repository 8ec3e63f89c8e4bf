"""Are the files beside a recording this run's? (``bench check``; docs/replay.md "Serial byte capture")

A run writes ``X.serial.bin`` (serial links) or ``X.log`` (CAN links, candump) beside ``X.mcap``
and records in ``X.mcap`` each one's size and SHA-256 with the run's id (metadata
``sidecar.serial.bin`` / ``sidecar.log``; the serial capture's end record also names the run).
A side file that is there but is not the one the run wrote (another run's, a half-written one)
would have a reader replay or inspect the wrong bytes next to this recording's verdicts: it is an
integrity problem of kind ``sidecar``, so ``bench check --strict`` fails. A recording without a
run id (written before runs had one) has nothing to compare; a side file that was not copied
along is no problem.
"""
from __future__ import annotations

import hashlib
from collections.abc import Mapping
from pathlib import Path

#: files a run writes beside its recording X.mcap (the same as recorder.SIDE_SUFFIXES, without
#: importing the recorder's compiled parts)
SIDE_SUFFIXES: tuple[tuple[str, str], ...] = ((".serial.bin", "serial byte capture"),
                                              (".log", "CAN log"))


def _sha256(path: Path) -> str:
    sha = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            sha.update(block)
    return sha.hexdigest()


def sidecar_problems(path: Path, metadata: Mapping[str, Mapping[str, str]]) -> list[tuple[str, str]]:
    """``(suffix, text)`` for each side file beside the recording at ``path`` that is not the
    one its run wrote."""
    path = Path(path)
    run_id = str((metadata.get("run") or {}).get("run_id", ""))
    if not run_id or path.suffix != ".mcap":
        return []
    out = []
    for suffix, what in SIDE_SUFFIXES:
        side = path.with_suffix(suffix)
        try:
            size = side.stat().st_size
        except OSError:
            continue                      # not there (not copied along): nothing to compare
        wrote = metadata.get("sidecar" + suffix)
        if not wrote:
            out.append((suffix, f"{side} is not this run's {what}: the run (id {run_id}) wrote "
                                f"none, so it is another run's"))
            continue
        try:
            same = size == int(wrote.get("bytes", -1)) and _sha256(side) == wrote.get("sha256")
        except (OSError, ValueError) as exc:
            out.append((suffix, f"{side}: cannot read it to compare ({exc})"))
            continue
        if not same:
            out.append((suffix, f"{side} is not this run's {what}: {size} octets that differ from "
                                f"the {wrote.get('bytes', '?')} the run (id {run_id}) wrote "
                                f"(SHA-256 {str(wrote.get('sha256', '?'))[:12]}...)"))
    return out
