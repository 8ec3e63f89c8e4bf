"""The C2000 (TMS320F28335) port skeleton (issue 21, item 4): its host build against the mock of
TI's register headers runs its checks (tests/c/test_c2000_port.c, also a CTest), and its eCAN
mailbox table is the DBC's message set, each message received or transmitted as the DBC's
sender says."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from hil_bench.protocol import dbc

EXE = Path(__file__).resolve().parents[1] / "build" / "bin" / "test_c2000_port"


@pytest.fixture(scope="module")
def exe() -> Path:
    if not EXE.exists():
        pytest.fail(f"{EXE} not built: run `make build`")
    return EXE


def test_the_host_build_passes_its_checks(exe):
    r = subprocess.run([str(exe)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "all checks passed" in r.stdout


def test_one_mailbox_per_dbc_message_in_the_senders_direction(exe):
    out = subprocess.run([str(exe), "--table"], capture_output=True, text=True, check=True).stdout
    table = {int(fid, 16): way for _, fid, way in (line.split() for line in out.splitlines())}
    expected = {m.frame_id: ("receive" if m.senders == ["PLANT"] else "transmit")
                for m in dbc.database().messages}
    assert {m.senders[0] for m in dbc.database().messages} == {"PLANT", "CTRL"}
    assert table == expected
