"""The C2000 (TMS320F28335) port skeleton (issue 21 item 4, issue 29 item 3): its host build against
the mock of TI's headers runs its checks (tests/c/test_c2000_port.c, also CTests), once for each
link a build can choose (SCI-A with the COBS framing, eCAN-A: HIL_C2000_LINK), main.c's start-up
included; the period comes from HELLO; and its eCAN mailbox table is the DBC's message set, each
message received or transmitted as the DBC's sender says."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from hil_bench.protocol import dbc

BIN = Path(__file__).resolve().parents[1] / "build" / "bin"
BUILDS = {"SCI": BIN / "test_c2000_port", "CAN": BIN / "test_c2000_port_can"}


@pytest.fixture(scope="module", params=sorted(BUILDS))
def build(request) -> tuple[str, Path]:
    exe = BUILDS[request.param]
    if not exe.exists():
        pytest.fail(f"{exe} not built: run `make build`")
    return request.param, exe


def test_each_link_build_passes_its_checks(build):
    link, exe = build
    r = subprocess.run([str(exe)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "all checks passed" in r.stdout
    chosen = subprocess.run([str(exe), "--link"], capture_output=True, text=True, check=True)
    assert chosen.stdout.strip() == link


def test_one_mailbox_per_dbc_message_in_the_senders_direction(build):
    out = subprocess.run([str(build[1]), "--table"], capture_output=True, text=True,
                         check=True).stdout
    table = {int(fid, 16): way for _, fid, way in (line.split() for line in out.splitlines())}
    expected = {m.frame_id: ("receive" if m.senders == ["PLANT"] else "transmit")
                for m in dbc.database().messages}
    assert {m.senders[0] for m in dbc.database().messages} == {"PLANT", "CTRL"}
    assert table == expected
