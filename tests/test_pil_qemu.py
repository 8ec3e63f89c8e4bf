"""The firmware cross-compiled for a Cortex-M4F and run in QEMU (``--link pil-qemu``, issue 21):
it builds with no heap from every portable source, passes the conformance kit, closes a shortened
G2 with the host stub's verdicts and measured differences to it, reports its own figures, and the
bench owns the emulator (reaped at the end, named when it dies).

Without qemu-system-arm or the cross-compiled ELF these tests skip, saying why; with
HIL_REQUIRE_CORTEX_M=1 (.ci/run) they fail instead.
"""
from __future__ import annotations

import os
import re
import shutil
import signal
import struct
import subprocess
import time
from pathlib import Path

import pytest

from hil_bench.loop.links import LinkError
from hil_bench.loop.links.qemu import BUILD_DIR, ELF_NAME, QemuProcess, TargetStats, firmware_elf
from tests.kit_items import passes_its_rules

REPO = Path(__file__).resolve().parents[1]
#: G2 (Gong, 500 rpm) cut to 1.0 s: steady at 500 rpm from 0.8 s on (the full run's speed is
#: 501.7 rpm at 0.8 s, 500.15 at 0.9 s), so the claims are read over [0.8, 1.0] s
#: (the link's defaults: a late answer is timing, never INVALID, docs/protocol.md 6.5)
G2_SHORT = (("scenario.duration_s", 1.0), ("metrics.window_s", [0.8, 1.0]))


def _need_target() -> Path:
    why = None
    if shutil.which("qemu-system-arm") is None:
        why = "qemu-system-arm not installed"
    else:
        try:
            return firmware_elf()
        except LinkError as exc:
            why = str(exc)
    if os.environ.get("HIL_REQUIRE_CORTEX_M") == "1":
        pytest.fail(f"HIL_REQUIRE_CORTEX_M=1 but the Cortex-M target cannot run: {why}")
    pytest.skip(why)


@pytest.fixture(scope="module")
def elf() -> Path:
    return _need_target()


@pytest.fixture(scope="module")
def g2_runs(elf, tmp_path_factory):
    """The shortened G2 on the host stub and on the target (the same scenario, lockstep)."""
    from hil_bench.loop.runner import run_scenario
    from hil_bench.scenario import derive_scenario

    scn = derive_scenario("gong_g2_500rpm", "gong_g2_500rpm", G2_SHORT,
                          note="shortened to 1.0 s for CI")
    out = {}
    for link in ("stub", "pil-qemu"):
        path = tmp_path_factory.mktemp(link) / "g2.mcap"
        result = run_scenario(scn, link_spec=link, out_path=path, progress=False)
        assert result.ok, f"{link}: {result.error}"
        out[link] = (path, result)
    return out


def test_the_port_builds_every_portable_source_with_no_heap(elf):
    objects = {p.name.removesuffix(".c.obj")
               for p in (BUILD_DIR / "CMakeFiles" / "hil_fw_cm4.dir").rglob("*.c.obj")}
    portable = {p.stem for p in (REPO / "firmware_stub" / "src").glob("*.c")}
    assert portable <= objects, f"not in the Cortex-M build: {sorted(portable - objects)}"
    assert {"hil_msgs", "hil_framing", "startup", "main", "usart", "clock"} <= objects
    syms = subprocess.run(["arm-none-eabi-nm", str(elf)], capture_output=True, text=True,
                          check=True).stdout
    names = {line.split()[-1] for line in syms.splitlines() if line.strip()}
    assert not names & {"malloc", "_malloc_r", "free", "_sbrk", "_sbrk_r", "calloc", "realloc"}
    # the single-precision FPU: no double arithmetic in soft-float (the codec uses float)
    assert not {n for n in names if re.fullmatch(r"__aeabi_d(add|sub|mul|div)", n)}
    assert "g_hil_target_stats" in names


def test_the_conformance_kit_passes_on_the_target(elf):
    from hil_bench.conformance import run_conformance

    result = run_conformance("pil-qemu")
    assert passes_its_rules(result), result.text()


def test_g2_on_the_target_has_the_host_stubs_verdicts(g2_runs):
    from hil_bench.papers.check import check_recording

    verdicts, pee = {}, {}
    for link, (path, _) in g2_runs.items():
        report = check_recording(path)
        assert report.integrity.ok, f"{link}: {report.integrity}"
        verdicts[link] = {r.quantity.key: r.verdict for r in report.results}
        pee[link] = report.summary["pee_max_rad"]
    assert verdicts["stub"] and verdicts["pil-qemu"] == verdicts["stub"]
    # shortened for CI, the run is not G2's set-up (its window): INVALID on both, never PASS;
    # the window's PEE itself is within the paper's 0.1 rad on both
    assert verdicts["stub"]["G2.pee"] == "INVALID"
    assert pee["stub"] < 0.1 and pee["pil-qemu"] < 0.1


def test_g2_differences_to_the_host_build_are_float32_sized(g2_runs):
    """Measured (docs/ports.md): over [0.8, 1.0] s the target's TELEM angle differs from the
    host's by at most 2.6e-3 rad and its speed by one telemetry LSB (0.239 rpm); the plants by
    0.004 rpm. Bounds here at about 4x."""
    from hil_bench.record.compare import compare_recordings

    d = compare_recordings(g2_runs["pil-qemu"][0], g2_runs["stub"][0], t0_s=0.8)
    assert d.cycles == 2000
    assert d.theta_hat_max_rad < 0.01, d.text()
    assert d.speed_hat_max_rpm <= 2 * 0.239 + 1e-6, d.text()
    assert d.speed_max_rpm < 0.02, d.text()


def test_the_target_reports_its_own_figures(g2_runs):
    path, result = g2_runs["pil-qemu"]
    t = result.target
    assert t["state_name"] == "running" and t["counter"] == "SysTick ticks"
    assert int(t["isr_count"]) == int(t["session_cycles"]) == result.cycles_done == 10000
    assert 0 < int(t["stack_used_bytes"]) < int(t["stack_size_bytes"])
    for k in ("crc_errors", "cobs_errors", "length_errors", "usart_overruns",
              "rx_ring_overflows", "tx_ring_overflows", "unknown_ids"):
        assert t[k] == "0", k
    # the counter is right: the boot-time loop of 2 x 10000 instructions counts as that
    assert t["calibration"].startswith("20000 instructions counted for 20000 executed"), t
    assert 1000 < float(t["isr_instructions_mean"]) < 20000
    # the footprint the firmware reports is its ELF's (the linker's symbols against its sections)
    from hil_bench.perf.target import footprint

    fp = footprint(firmware_elf())
    assert int(t["flash_used_bytes"]) == fp["flash_bytes"]
    assert int(t["flash_size_bytes"]) == 1 << 20 and int(t["ram_size_bytes"]) == 128 << 10
    assert int(t["stack_size_bytes"]) == fp["stack_bytes"]
    assert len(t["elf_sha256"]) == 64 and float(t["emulator_cpu_s"]) > 0
    from hil_bench.record.recording import load_recording

    meta = load_recording(path).metadata["target"]
    assert meta["isr_count"] == "10000" and meta["flash_used_bytes"] == t["flash_used_bytes"]


def test_the_docs_figures_are_the_targets(g2_runs):
    """docs/ports.md's footprint block is what `python -m hil_bench.perf.target --write-docs`
    makes of today's ELF, and its G2 row is this run's ISR count (the same cut: instructions under
    -icount are the firmware's, up to a SysTick or a host heartbeat landing inside an ISR)."""
    from hil_bench.perf import target as perf_target

    assert perf_target.main(["--check-docs"]) == 0, "run: python -m hil_bench.perf.target --write-docs"
    block = perf_target.generated_block(perf_target.DOC.read_text(), "target_isr")
    row = next(line for line in block.splitlines() if "`gong_g2_500rpm`" in line)
    documented = float(row.split("|")[2].replace(" ", ""))
    measured = float(g2_runs["pil-qemu"][1].target["isr_instructions_mean"])
    assert abs(documented - measured) <= 0.005 * measured, (documented, measured)


def test_bench_run_prints_the_targets_figures(elf, tmp_path):
    out = tmp_path / "g2.mcap"
    r = subprocess.run([str(REPO / ".venv" / "bin" / "bench"), "run", "gong_g2_500rpm", "--link",
                        "pil-qemu", "--set", "scenario.duration_s=0.05", "--set",
                        "metrics.window_s=[0.04, 0.05]", "--out", str(out), "--no-progress"],
                       capture_output=True, text=True, cwd=tmp_path)
    assert out.exists(), r.stdout + r.stderr
    text = r.stdout
    target = text[text.index("target: hil_fw_cm4.elf"):]
    assert re.search(r"control ISR: [\d ]+ instructions mean, [\d ]+ max, [\d ]+ min over 500 ISRs",
                     target), target
    assert re.search(r"stack: [\d ]+ B used of 8 192 B; flash [\d ]+ B of 1 048 576 B; RAM [\d ]+ B "
                     r"static \+ 8 192 B stack of 131 072 B", target), target
    check = subprocess.run([str(REPO / ".venv" / "bin" / "bench"), "check", str(out)],
                           capture_output=True, text=True)
    assert target.splitlines()[1] in check.stdout      # bench check prints them from the file


def test_every_octet_value_crosses_the_link(elf):
    """QEMU's multiplexer sits between the socket and USART1 (qemu.py): its escape character is
    set beyond a byte, so Ctrl-A then `x` (quit) or `c` (switch to the monitor) in a frame are just
    octets. HELLOs whose session number puts those pairs on the wire are each answered."""
    from hil_bench.protocol.framing import encode_frame
    from hil_bench.loop.host_session import PROTO_MINOR
    from hil_bench.protocol.messages import MESSAGES

    hello, ack = MESSAGES["HELLO"], MESSAGES["HELLO_ACK"]
    q = QemuProcess(elf)
    try:
        deadline = time.monotonic() + 10
        while not any(fid == MESSAGES["HEARTBEAT_CTRL"].frame_id for fid, _ in q.link.recv(0.1)):
            assert time.monotonic() < deadline, "no HEARTBEAT_CTRL: the firmware did not start"
        for session in (0x7801, 0x6301, 0x0101, 0x7878):     # 01 'x', 01 'c', 01 01, 'x' 'x'
            payload = hello.pack(proto_version=1, proto_minor=PROTO_MINOR, mode=0, period_us=100.0,
                                 estimator=3, flags=0, session=session)
            assert bytes([session & 0xFF, session >> 8]) in encode_frame(hello.frame_id, payload)
            q.link.send([(hello.frame_id, payload)])
            frame = q.link.recv_until(lambda fid, p: fid == ack.frame_id, 5.0)
            assert frame is not None and ack.unpack(frame[1])["session"] == session, hex(session)
        assert q.alive()
    finally:
        q.stop()


def test_the_emulator_is_reaped_after_the_run(g2_runs):
    from hil_bench.record.recording import load_recording

    link = load_recording(g2_runs["pil-qemu"][0]).run["link"]
    pid = int(re.search(r"pid (\d+)", link).group(1))
    assert not Path(f"/proc/{pid}").exists() or "qemu" not in Path(f"/proc/{pid}/cmdline").read_text()


def test_a_dead_emulator_is_named_and_reaped(elf):
    q = QemuProcess(elf)
    try:
        os.kill(q.proc.pid, signal.SIGKILL)
        with pytest.raises(LinkError, match="peer closed"):
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline:
                q.link.recv(0.1)
        deadline = time.monotonic() + 2    # the socket closes a moment before the exit
        while q.alive() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert not q.alive()
        assert "qemu-system-arm killed by signal 9" in q.death_message()
    finally:
        code = q.stop()
    assert code == -signal.SIGKILL and q.proc.poll() is not None


def test_real_time_on_the_emulator_is_refused(elf):
    from hil_bench.loop.runner import RunAborted, Runner
    from hil_bench.scenario import load_scenario

    with pytest.raises(RunAborted, match="lockstep only"):
        Runner(load_scenario("gong_g2_500rpm"), link_spec="pil-qemu", realtime=True)


def _block(**values) -> bytes:
    words = {f: 0 for f in TargetStats.__dataclass_fields__ if f not in TargetStats.NOT_IN_BLOCK}
    assert len(words) == TargetStats.words()
    words.update({"magic": TargetStats.MAGIC, "version": TargetStats.VERSION, **values})
    return struct.pack(f"<{len(words)}I", *words.values())


def test_the_stats_block_is_read_field_for_field():
    st = TargetStats.from_bytes(_block(counter_kind=2, clock_hz=168_000_000, isr_count=4,
                                       isr_ticks_sum_lo=4 * 840, isr_ticks_min=168,
                                       isr_ticks_max=1680), icount_shift=0)
    assert st.isr_instructions() == {"mean": 5000.0, "min": 1000.0, "max": 10000.0}
    no_icount = TargetStats.from_bytes(_block(counter_kind=2, clock_hz=168_000_000, isr_count=1))
    assert no_icount.isr_instructions() is None     # host wall-clock ticks are no instructions
    fault = TargetStats.from_bytes(_block(state=2, fault_pc=0x08001234, fault_cfsr=0x8200))
    assert "HardFault at PC 0x08001234" in fault.fault_text() and ELF_NAME in fault.fault_text()
    with pytest.raises(ValueError, match="magic"):
        TargetStats.from_bytes(b"\0" * 4 * TargetStats.words())
    with pytest.raises(ValueError, match="layout version"):
        TargetStats.from_bytes(_block(version=99))


def test_a_controller_restart_is_taken_in_band_by_the_target(elf, tmp_path):
    """CMD RESTART (the controller_reset fault, docs/protocol.md 6.3) reaches the firmware in
    QEMU like the stub: the portable session restarts before the fault cycle's SENSE, the cycle
    never completes, the HEARTBEAT_CTRL it sends says so (ctrl_resets +1), and the port counts
    the restart in its own figures."""
    from hil_bench.loop.runner import run_scenario
    from hil_bench.record import channels as ch
    from hil_bench.record.fault_outcomes import outcomes
    from hil_bench.record.recording import load_recording
    from tests.test_controller_restart import _scenario

    out = tmp_path / "restart.mcap"
    result = run_scenario(_scenario(), link_spec="pil-qemu", out_path=out, progress=False)
    assert result.end == "NO_DUTY" and result.cycles_done == 2000, result.error
    assert "the bench restarted the controller at this cycle" in result.error
    assert result.target["restarts"] == "1" and result.target["state_name"] == "running"
    assert int(result.target["isr_count"]) == 2000
    rec = load_recording(out)
    f = rec.topic(ch.FAULTS)
    assert any(a == "on" and "CMD RESTART" in t for a, t in zip(f["action"], f["text"]))
    (o,) = outcomes(rec)
    assert o.detection_s == 0.0 and "ctrl_resets +1" in o.evidence, o
