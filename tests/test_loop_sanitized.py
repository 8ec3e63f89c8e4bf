"""The closed loop with AddressSanitizer + UndefinedBehaviorSanitizer on BOTH sides: the cycle
engine, the plant, the recorder's ring and the host's reference estimators (the cffi module
hil_bench.plant_rt._plant_c built by ``tools/build_native.py --sanitize`` into build-asan/python/) and the
firmware stub (build-asan/bin/hil_stub). ``make sanitize`` (part of ``make test``) builds both.

The bench runs in a subprocess: the interpreter is not instrumented, so ASan's runtime has to be
loaded before it (LD_PRELOAD of gcc's libasan.so), with leak detection off (CPython keeps memory
until exit by design; tests/test_loop.py runs the stub alone with leak detection on). Any report
of either sanitizer in the engine or the stub fails the test, as does a run that did not finish.

Skips only when gcc has no libasan.so (then nothing can load an ASan module into Python), with
that reason; a missing sanitized build is a failure, not a skip, so CI cannot go green without
running it.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ASAN_STUB = REPO / "build-asan" / "bin" / "hil_stub"
SANITIZED_PYTHON = REPO / "build-asan" / "python"
SANITIZER_MARKS = ("runtime error", "AddressSanitizer", "UndefinedBehaviorSanitizer",
                   "LeakSanitizer", "SUMMARY: ")

# gong_g2_500rpm shortened to 0.8 s: alignment, I-f, hand-over to the tanh SMO at ~0.53 s, closed
# loop; the host's SMO_TANH reference runs in the engine on every cycle
SCENARIO = (REPO / "bench" / "scenarios" / "gong_g2_500rpm.toml").read_text() \
    .replace("duration_s = 1.5", "duration_s = 0.8") \
    .replace("window_s = [1.0, 1.5]", "window_s = [0.6, 0.8]") \
    .replace('name = "gong_g2_500rpm"', 'name = "gong_g2_500rpm_sanitized"')

# the bench's CLI, after checking that the sanitized engine is the module this process loaded
RUN_BENCH = """
import runpy, sys
assert "libasan" in open("/proc/self/maps").read(), "ASan's runtime is not loaded"
import hil_bench.plant_rt._plant_c as engine
import hil_bench.firmware_stub._fw_c as fw
for m in (engine, fw):
    assert "build-asan" in m.__file__, "not the sanitized build: " + m.__file__
print("engine module:", engine.__file__, flush=True)
sys.argv = ["bench"] + sys.argv[1:]
runpy.run_module("hil_bench", run_name="__main__", alter_sys=True)
"""


def libasan() -> str | None:
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    path = subprocess.run([gcc, "-print-file-name=libasan.so"], capture_output=True, text=True,
                          check=False).stdout.strip()
    return path if os.path.isabs(path) and os.path.exists(path) else None


def sanitized_env(asan: str) -> dict[str, str]:
    env = dict(os.environ)
    env.update(LD_PRELOAD=asan, PYTHONPATH=str(SANITIZED_PYTHON), HIL_STUB=str(ASAN_STUB),
               ASAN_OPTIONS="detect_leaks=0:abort_on_error=1",
               UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1")
    return env


def test_closed_loop_with_the_sanitized_engine_and_stub(tmp_path):
    asan = libasan()
    if asan is None:
        pytest.skip("gcc has no libasan.so (gcc -print-file-name=libasan.so): an ASan-built "
                    "engine cannot be loaded into Python here")
    missing = [str(p.relative_to(REPO)) for p in (ASAN_STUB, SANITIZED_PYTHON / "hil_bench" / "plant_rt",
                                                  SANITIZED_PYTHON / "hil_bench" / "firmware_stub")
               if not p.exists()]
    assert not missing, f"sanitized build missing ({', '.join(missing)}): run `make sanitize`"
    scn = tmp_path / "g2_sanitized.toml"
    scn.write_text(SCENARIO)
    out = tmp_path / "g2_sanitized.mcap"
    # cwd outside the repository, so that nothing of the checkout comes before build-asan/python
    proc = subprocess.run([sys.executable, "-c", RUN_BENCH, "run", str(scn), "--out", str(out),
                           "--no-progress"], cwd=tmp_path, env=sanitized_env(asan),
                          capture_output=True, text=True, timeout=900, check=False)
    text = proc.stdout + proc.stderr
    reports = [line for line in text.splitlines() if any(m in line for m in SANITIZER_MARKS)]
    assert not reports, "sanitizer report:\n" + "\n".join(reports[:20]) + "\n" + proc.stderr[-4000:]
    assert proc.returncode == 0, text[-4000:]
    assert "engine module:" in proc.stdout and "build-asan" in proc.stdout
    flat = " ".join(text.split())
    assert "ran 8000/8000 cycles (lockstep)" in flat, text[-4000:]
    # the sanitized stub answered (the report names the controller from its HELLO_ACK, then
    # the process the bench started for it)
    assert "controller: fw 0x0100 " in flat and f": hil_stub {ASAN_STUB}," in flat
    assert "ended early" not in text, text[-4000:]
    assert out.exists()
