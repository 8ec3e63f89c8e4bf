"""The C cycle engine reproduces the Python lockstep loop it replaced (issue 8, item 3).

The golden (tests/golden/g2_python_loop.npz) was recorded by the Python loop
(``bench/runner.py: Runner._loop`` at commit f6614b9, the last with it) on a frozen copy of
``gong_g2_500rpm`` (tests/golden/g2_equivalence.toml) with tests/golden/make_g2_golden.py. It
holds the SHA-256 of every recorded numeric column (plant state, what the controller was sent,
telemetry and duties, the host reference SMO) and full copies of the key ones.

The claim is bit identity: the engine evaluates every expression of the old loop in the same
order in binary64 (no FMA contraction: -ffp-contract=off), encodes the wire with the DBC's
rounding rule, and steps the same plant and estimator C. One column legitimately differs by
definition: /plant/sense theta_enc_rad, which the old loop filled with the true angle while the
engine records the angle actually sent (it differs only where the 16-bit encoder wraps to 0).

If a later, deliberate change of the firmware or the plant changes the G2 run, this test fails:
re-record the golden (make_g2_golden.py) and say in the commit which change moved it.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

from bench.recording import load_recording
from bench.runner import run_scenario
from bench.scenario import load_scenario

GOLDEN = Path(__file__).parent / "golden"
BY_DEFINITION = {"/plant/sense:theta_enc_rad"}


@pytest.fixture(scope="module")
def engine_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("equiv") / "g2.mcap"
    res = run_scenario(load_scenario(GOLDEN / "g2_equivalence.toml"), out_path=out,
                       progress=False)
    assert res.ok, res.error
    return load_recording(out)


def test_engine_is_bit_identical_to_the_python_loop(engine_run):
    golden = np.load(GOLDEN / "g2_python_loop.npz")
    mismatches = []
    for line in golden["hashes"]:
        topic, name, n, digest = str(line).rsplit(":", 3)
        col = np.ascontiguousarray(engine_run.topic(topic)[name], dtype="<f8")
        assert len(col) == int(n), f"{topic}:{name}: {len(col)} rows, golden {n}"
        if hashlib.sha256(col.tobytes()).hexdigest() != digest:
            mismatches.append(f"{topic}:{name}")
    assert set(mismatches) <= BY_DEFINITION, f"columns not bit-identical: {mismatches}"


def test_full_columns_agree_exactly(engine_run):
    golden = np.load(GOLDEN / "g2_python_loop.npz")
    for key in golden.files:
        if ":" not in key:
            continue
        topic, name = key.split(":")
        got = engine_run.topic(topic)[name]
        np.testing.assert_array_equal(got, golden[key], err_msg=key)
