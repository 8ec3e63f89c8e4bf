"""Record the golden of tests/test_engine_equivalence.py (tests/golden/g2_engine_regression.npz).

History: first recorded at commit f6614b9 by the Python lockstep loop (``bench/loop/runner.py:
LockstepRunner._loop``, the last commit with it); the C engine reproduced it bit for bit through
commit 343d327. The merge of the paper-claims work (8605a34) changed the firmware (the SMOs'
direction handling, the controller's delay handling), so the stub's answers changed; the golden
was then re-recorded by the engine itself with this script (and renamed from g2_python_loop.npz,
which is kept in git at a9084b6). From the repository root:

    .venv/bin/python tests/golden/make_g2_golden.py

It runs ``tests/golden/g2_equivalence.toml`` (a frozen copy of ``gong_g2_500rpm``) against the stub
and stores, for every recorded numeric field, the SHA-256 of its float64 column (bit identity), and
the full columns of the quantities the test compares within a tolerance when the hashes differ.
"""
from __future__ import annotations

import hashlib
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from hil_bench.loop.runner import run_scenario
from hil_bench.record.recording import load_recording
from hil_bench.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]

TOPICS = ("/plant/state", "/plant/sense", "/controller/telemetry", "/reference/SMO_SIGN")
FULL = {"/plant/state": ("theta_e_rad", "omega_m_rad_s", "i_a_a", "i_b_a", "i_d_a", "i_q_a"),
        "/controller/telemetry": ("theta_hat_rad", "omega_hat_rad_s", "duty_a", "duty_b", "duty_c"),
        "/reference/SMO_SIGN": ("theta_hat_rad", "omega_hat_rad_s", "e_alpha_v", "e_beta_v")}


def main() -> int:
    scn = load_scenario(ROOT / "tests" / "golden" / "g2_equivalence.toml")
    with tempfile.TemporaryDirectory() as tmp:
        res = run_scenario(scn, out_path=Path(tmp) / "g2.mcap", progress=False)
        assert res.ok, res.error
        rec = load_recording(Path(tmp) / "g2.mcap")
    out: dict[str, np.ndarray] = {}
    hashes = []
    for topic in TOPICS:
        cols = rec.topic(topic)
        for name, col in sorted(cols.items()):
            if col.dtype.kind not in "fiu":
                continue   # text columns; integers (seq, state, estimator) are exact in binary64
            col = np.ascontiguousarray(col, dtype="<f8")
            hashes.append(f"{topic}:{name}:{len(col)}:{hashlib.sha256(col.tobytes()).hexdigest()}")
            if name in FULL.get(topic, ()):
                out[f"{topic}:{name}"] = col
    rev = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                         text=True).stdout.strip()
    np.savez_compressed(ROOT / "tests" / "golden" / "g2_engine_regression.npz",
                        hashes=np.array(hashes), revision=np.array(rev), **out)
    print(f"{len(hashes)} column hashes, {len(out)} full columns, revision {rev}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
