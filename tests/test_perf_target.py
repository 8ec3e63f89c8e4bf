"""The target benchmark's tools that need no emulator (bench/perf/target.py): the row-by-row
comparison of two recordings it uses to show a change left a run's rows as they were, and the text
of the target's figures `bench run --link pil-qemu` prints (bench/loop/links/qemu.py)."""
from __future__ import annotations

from pathlib import Path

import pytest

from hil_bench.loop.links.qemu import target_summary
from hil_bench.perf.target import compare_rows, render_docs

SHORT = (("scenario.duration_s", 0.02), ("metrics.window_s", [0.01, 0.02]))


def _run(tmp: Path, name: str, extra: tuple = ()) -> Path:
    from hil_bench.loop.runner import run_scenario
    from hil_bench.scenario import derive_scenario

    scn = derive_scenario("gong_g2_500rpm", "gong_g2_500rpm", SHORT + extra, note="test")
    path = tmp / f"{name}.mcap"
    result = run_scenario(scn, link_spec="stub", out_path=path, progress=False)
    assert result.ok, result.error
    return path


def test_two_runs_of_a_scenario_have_the_same_rows_and_a_change_shows(tmp_path):
    a, b = _run(tmp_path, "a"), _run(tmp_path, "b")
    same, lines = compare_rows(a, b)
    assert same, lines
    assert any(line.startswith("/plant/state: 200 rows identical") for line in lines), lines
    assert any("/timing" in line and "identical" in line for line in lines)   # wall clock left out
    c = _run(tmp_path, "c", (("plant.initial_theta_e_rad", 1.0),))
    same, lines = compare_rows(a, c)
    assert not same
    assert any(line.startswith("/controller/telemetry: 200 rows DIFFER") for line in lines), lines


META = {"elf": "hil_fw_cm4.elf", "state_name": "running", "clock_hz": "168000000",
        "isr_instructions_mean": "4731.4", "isr_instructions_max": "5042", "isr_instructions_min":
        "3714", "isr_count": "15000", "icount_shift": "0", "stack_used_bytes": "872",
        "stack_size_bytes": "8192", "flash_used_bytes": "43284", "flash_size_bytes": "1048576",
        "ram_used_bytes": "13608", "ram_size_bytes": "131072", "rx_bytes": "450345",
        "tx_bytes": "675345", "crc_errors": "0", "cobs_errors": "2", "emulator_cpu_s": "10.93"}


def test_the_targets_figures_as_printed():
    lines = target_summary(META)
    assert lines[0].startswith("target: hil_fw_cm4.elf on qemu-system-arm netduinoplus2")
    assert lines[1] == "  control ISR: 4 731 instructions mean, 5 042 max, 3 714 min over 15 000 ISRs"
    assert "-icount shift=0; not core cycles" in lines[2]
    assert lines[3] == ("  stack: 872 B used of 8 192 B; flash 43 284 B of 1 048 576 B; RAM 13 608 B "
                        "static + 8 192 B stack of 131 072 B")
    assert lines[4] == ("  link: 450 345 octets in, 675 345 out, 2 errors seen by the target; the "
                        "emulator used 10.9 s of CPU")
    # a run without -icount, and a firmware that predates the footprint fields: said, not invented
    old = {k: v for k, v in META.items() if not k.startswith(("isr_instr", "flash", "ram_size"))}
    lines = target_summary(old)
    assert "no instruction count" in lines[1]
    assert "flash not reported" in lines[2] and "of 131 072 B" not in lines[2]
    assert target_summary({**META, "isr_count": "x"}) == [
        "target: its figures in the recording's metadata are not numbers "
        "(invalid literal for int() with base 10: 'x')"]


def test_the_docs_blocks_are_filled_between_their_markers():
    text = ("a\n<!-- BEGIN GENERATED: target_isr -->\nold\n<!-- END GENERATED: target_isr -->\n"
            "<!-- BEGIN GENERATED: other -->\nkept\n<!-- END GENERATED: other -->\n")
    out = render_docs(text, {"target_isr": "new\n"})
    assert "new\n<!-- END GENERATED: target_isr -->" in out and "old" not in out and "kept" in out
    with pytest.raises(SystemExit, match="target_footprint"):
        render_docs(text, {"target_footprint": "x"})
