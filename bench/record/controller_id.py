"""Which controller answered a run: what its HELLO_ACK said, on which link, started by whom.

A run's report and the pytest plugin's JUnit properties name the controller from what it sent
(docs/protocol.md 6.1: HELLO_ACK's ``fw_version``, ``proto_version``, ``estimators`` mask), not
from the link spec the run was given: ``--link serial:...`` names a port, not what sits behind
it. The runner records it as the ``controller`` metadata right after the handshake; a recording
without it had no controller answering (or predates this record).
"""
from __future__ import annotations

from collections.abc import Mapping


def identity(ack: Mapping[str, object], link: str, process: str,
             version: str | None = None) -> dict[str, str]:
    """The ``controller`` metadata record: the HELLO_ACK's fields, the link it came over, and
    the process the bench started for it (``process``; "" for a drive it did not start).
    ``version``: the protocol version the session speaks (``1.1``; default the ACK's major)."""
    return {"fw_version": f"0x{int(ack['fw_version']):04X}",
            "proto_version": version or str(int(ack["proto_version"])),
            "estimators": f"0x{int(ack['estimators']):04X}",
            "session": f"0x{int(ack['session']):04X}",
            "link": link, "process": process}


def describe(metadata: Mapping[str, Mapping[str, str]]) -> str:
    """One line: the controller that answered, as recorded."""
    run = metadata.get("run") or {}
    ctl = metadata.get("controller")
    if not ctl:
        if run.get("run_id"):
            return f"none answered on {run.get('link', '?')} (no HELLO_ACK recorded)"
        return str(run.get("controller", "?"))      # a recording from before this record
    who = ctl.get("process") or "a drive the bench did not start"
    return (f"fw {ctl.get('fw_version', '?')} (protocol {ctl.get('proto_version', '?')}, "
            f"estimators {ctl.get('estimators', '?')}) on {ctl.get('link', '?')}: {who}")
