"""docs/real-drive.md is true (issue 29, item 3): every shell block is either run here or says why not;
each ``# runs here`` block runs as printed, from a scratch folder laid out as the checkout
(tests/doc_blocks.py, which finds the blocks and runs their commands for every page), with the
device replaced by a pty whose other end is the C stub (``/dev/ttyUSB0`` in a ``serial:`` link:
``hil_stub --port fd:N``; ``/dev/ttyACM0`` in a ``can:slcan:`` link: ``hil_stub --slcan fd:N``), and
every command exits as the page says; the page's generated tables are current; the F28335-over-SCI
path runs at 937 500 baud, its real-time claim-set-up scenario among it, and the budget check
accepts it; a G2 run at 1 kHz is never a PASS of G2."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys

import pytest

from tests.doc_blocks import (NOT_RUN, REPO, RUNS_HERE, Block, run_keeping_real_time,
                              scratch_folder, shell_blocks)

DOC = REPO / "docs" / "real-drive.md"
#: the F28335's SCI rate on the page (LSPCLK 37.5 MHz, BRR 4) and the STM32's USART rate
F28335_SCI = "@937500"

BLOCKS = shell_blocks(DOC)
RUNNABLE = [b for b in BLOCKS if b.runs]


def test_every_shell_block_is_run_here_or_says_why_not():
    """Every block under one marker: this page runs a block whole or not at all (the general rule
    and its test: tests/doc_blocks.py, tests/test_docs.py)."""
    mixed = [b.line for b in BLOCKS if len({c.marker for c in b.commands}) != 1 or not b.marker]
    assert not mixed, (f"{DOC.name}: shell blocks at lines {mixed} say neither "
                       f"'{RUNS_HERE}' nor '{NOT_RUN} <why>' on their first line, for all of it")
    assert all(b.commands for b in BLOCKS), "a shell block without a command"
    assert len(RUNNABLE) >= 8 and len(RUNNABLE) < len(BLOCKS)


def test_no_command_hides_outside_the_blocks():
    """A bench command in the prose or an indented block would be neither run nor marked: the page
    keeps every command it gives in a shell block."""
    inside = {n for b in BLOCKS for n in range(b.line, b.line + len(b.lines) + 2)}
    loose = [n for n, ln in enumerate(DOC.read_text().splitlines(), 1)
             if n not in inside and re.search(r"(^\s*|`)\.venv/bin/(bench|python) ", ln)]
    assert not loose, f"{DOC.name}: commands outside a shell block at lines {loose}"


def test_the_generated_tables_are_current():
    proc = subprocess.run([sys.executable, str(REPO / "tools" / "gen_real_drive.py"), "--check"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_the_f28335_sci_path_is_on_the_page_at_the_rate_the_part_makes():
    """The F28335's SCI makes 937 500 baud at its reset LSPCLK (37.5 MHz, BRR 4): the page's
    F28335-over-SCI commands use it, the kit with the G2 estimator, G2 in lockstep and the 1 kHz
    scenario in real time among them."""
    cmds = [c.text for b in RUNNABLE for c in b.commands
            if "serial:/dev/ttyUSB0" + F28335_SCI in c.text]
    assert any("conformance" in c and "--estimator SMO_TANH" in c for c in cmds)
    assert any("run gong_g2_500rpm " in c and "--allow-slow-link" in c for c in cmds)
    assert any("run gong_g2_serial_1mbaud " in c and "--realtime" in c for c in cmds)


# ---- running the blocks -----------------------------------------------------------------------
# (the folder, the pty with the stub for the device: tests/doc_blocks.py)

def _needs(block: Block) -> str | None:
    text = " ".join(c.text for c in block.commands)
    if "pil-qemu" in text or "cortex_m" in text:
        missing = [t for t in ("arm-none-eabi-gcc", "qemu-system-arm") if shutil.which(t) is None]
        if missing and os.environ.get("HIL_REQUIRE_CORTEX_M") != "1":
            return f"{', '.join(missing)} not installed (apt-get install gcc-arm-none-eabi " \
                   f"libnewlib-arm-none-eabi qemu-system-arm)"
    return None


def _expected_g2_figures() -> list[str]:
    """The stub's column of the page's "G2 in lockstep" table (what a drive team compares with)."""
    text = DOC.read_text()
    table = text[text.index("* **G2 in lockstep**"):].split("\n\n")[1]
    return [row.split("|")[3].strip() for row in table.splitlines()[2:] if row.strip()]


def _checks(cmd: str, out: str) -> list[str]:
    """What the page says each kind of command shows, beyond its exit status."""
    said = " ".join(out.split())
    wrong = []
    if "conformance" in cmd and "30 of 30 items pass" not in said:
        wrong.append("the kit: not '30 of 30 items pass' (the page says so)")
    if " --realtime" in cmd:
        if not re.search(r"ran (\d+)/\1 cycles \(realtime\)", said):
            wrong.append("the real-time run did not run all its cycles in real time")
        if "cannot carry" in said:
            wrong.append("the budget check refused the real-time run")
    if "run gong_g2_500rpm " in cmd and "--set" not in cmd:
        verdicts = re.findall(r"│ G2 +│.*?│ (PASS|FAIL|COMPARED|INVALID)", out)
        if not verdicts or set(verdicts) - {"PASS", "COMPARED"}:
            wrong.append(f"G2 in lockstep: verdicts {verdicts}, expected PASS / COMPARED")
        measured = re.findall(r"│ G2 +│[^│]*│[^│]*│ ([^│]*?) +│", out)
        if measured != _expected_g2_figures():
            wrong.append(f"G2 in lockstep: the page's 'what to expect' table says "
                         f"{_expected_g2_figures()}, the run printed {measured}")
    if "--set plant.ts_s=0.001" in cmd:
        rows = re.findall(r"│ (G\d) +│.*?│ (PASS|FAIL|COMPARED|INVALID)", out)
        if not rows or {v for _, v in rows} != {"INVALID"} or "plant.ts_s" not in said:
            wrong.append(f"a paper claim at 1 kHz: rows {rows}, expected every one INVALID naming "
                         f"plant.ts_s")
    if "--latency-ms 16" in cmd and "most often a USB adapter's latency timer" not in said:
        wrong.append("the emulated 16 ms adapter was not named")
    return wrong


@pytest.mark.parametrize("block", RUNNABLE, ids=lambda b: f"line{b.line}")
def test_the_block_runs_as_printed(block, tmp_path):
    why = _needs(block)
    if why:
        pytest.skip(why)
    cwd = scratch_folder(tmp_path)
    for c in block.commands:
        cmd, status = c.text, c.status
        proc = run_keeping_real_time(cmd, cwd)   # (repeated once if the host lost real time)
        said = proc.stdout
        assert proc.returncode == status, (f"{DOC.name}:{c.line}: `{cmd}` exited "
                                           f"{proc.returncode}, the page says {status}\n"
                                           f"{said[-4000:]}")
        wrong = _checks(cmd, said)
        assert not wrong, f"{DOC.name}:{c.line}: `{cmd}`: {'; '.join(wrong)}\n{said[-4000:]}"


# ---- the bundled serial scenario ------------------------------------------------------------------

SERIAL_SCENARIO = "gong_g2_serial_1mbaud"


@pytest.mark.parametrize("link", ["serial:/dev/ttyUSB0@937500", "serial:/dev/ttyUSB0@1000000",
                                  "can:socketcan:can0@1000000"])
def test_the_serial_scenario_fits_the_links_in_real_time(link):
    """The budget check (before any port is opened) accepts the 1 kHz scenario in real time on the
    F28335's SCI rate, a 1 Mbaud UART and classic CAN at 1 Mbit/s."""
    from hil_bench.loop.runner import Runner
    from hil_bench.scenario import load_scenario

    r = Runner(load_scenario(SERIAL_SCENARIO), link, out_path=None, progress=False, realtime=True,
               record=False)
    r._check_budget_of_spec()


def test_a_slower_link_is_refused_in_real_time_naming_its_budget():
    from hil_bench.loop.runner import RunAborted, Runner
    from hil_bench.scenario import load_scenario

    r = Runner(load_scenario(SERIAL_SCENARIO), "serial:/dev/ttyUSB0@460800", out_path=None,
               progress=False, realtime=True, record=False)
    with pytest.raises(RunAborted, match=r"1000 Hz control rate needed .* fits at most 614 Hz"):
        r._check_budget_of_spec()


def test_lockstep_and_real_time_of_the_serial_scenario_are_the_same_physics():
    """Duties from the next period boundary in both modes (plant.full_period_delay in lockstep,
    duty_update next_period in real time), and the drive told the same delay: a real-time run of
    the file differs from its lockstep run by timing only (docs/real-drive.md)."""
    from hil_bench.loop.runner import Runner
    from hil_bench.protocol.messages import Param
    from hil_bench.scenario import load_scenario

    scn = load_scenario(SERIAL_SCENARIO)
    modes = {rt: Runner(scn, "stub", out_path=None, progress=False, realtime=rt, record=False)
             for rt in (False, True)}
    assert scn.realtime.duty_update == "next_period"
    assert modes[False].plant.actuation_delay_s == pytest.approx(1e-3)
    delays = {rt: r.controller_params()[Param.CTRL_DELAY_S] for rt, r in modes.items()}
    assert delays[False] == pytest.approx(1e-3) and delays[True] == pytest.approx(1e-3)
