"""The recordings open in Foxglove: every channel parses and every message decodes by the rules of
Foxglove's own parser (tools/foxglove_check/check.mjs: @mcap/core + @mcap/support + protobufjs,
restating packages/mcap-support/src/parseChannel.ts / parseProtobufSchema.ts), and the decoded
values are the ones the bench's own reader gets. The layout in docs/foxglove/ names only topics
and fields the demo's recording (`make demo`: gong_g2_500rpm) has.

Without Node.js/npm the parser tests skip, saying why; with HIL_REQUIRE_FOXGLOVE=1 (set by .ci/run,
which installs Node.js) they fail instead, so CI cannot go green without them.
"""
from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from hil_bench.loop.runner import run_scenario
from hil_bench.record import channels as ch
from hil_bench.record.recording import load_recording
from hil_bench.scenario import load_scenario

REPO = Path(__file__).resolve().parents[1]
CHECKER = REPO / "tools" / "foxglove_check"
LAYOUT = REPO / "docs" / "foxglove" / "hil_bench_layout.json"


def _checker_missing() -> str | None:
    if shutil.which("node") is None:
        return "node is not installed (Foxglove's parser runs on Node.js)"
    if not (CHECKER / "node_modules" / "@mcap" / "core").is_dir():
        return "tools/foxglove_check/node_modules missing: run `make build` (npm ci)"
    return None


def _require_checker() -> Path:
    """The checker's folder; skips (fails under HIL_REQUIRE_FOXGLOVE=1) when it cannot run."""
    why = _checker_missing()
    if why is not None:
        if os.environ.get("HIL_REQUIRE_FOXGLOVE") == "1":
            pytest.fail(f"HIL_REQUIRE_FOXGLOVE=1 but the Foxglove check cannot run: {why}")
        pytest.skip(why)
    return CHECKER


@pytest.fixture
def checker() -> Path:
    return _require_checker()


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("fg") / "g2.mcap"
    scn = load_scenario("gong_g2_500rpm")
    res = run_scenario(scn, out_path=out, progress=False)
    assert res.ok, res.error
    return out


def test_every_channel_parses_and_every_message_decodes_with_foxgloves_rules(checker, recording):
    proc = subprocess.run(["node", str(checker / "check.mjs"), str(recording)],
                          capture_output=True, text=True, timeout=300)
    report = json.loads(proc.stdout)
    assert proc.returncode == 0 and report["errors"] == [], report["errors"]
    rec = load_recording(recording)
    assert set(report["channels"]) == set(rec.counts)
    for topic, entry in report["channels"].items():
        assert entry["messages"] == rec.counts[topic], topic
        # every scalar is a protobuf scalar Foxglove plots as a number
        kind = ch.kind_of_topic(topic)
        assert [n for n, _ in entry["fields"]] == list(ch.LAYOUTS[kind].names)
        cols = rec.topic(topic)
        for name, total in entry["sums"].items():
            values = np.asarray(cols[name], dtype=float)
            ours = float(np.sum(values[np.isfinite(values)]))
            assert math.isclose(total, ours, rel_tol=1e-9, abs_tol=1e-6), (topic, name)


def test_the_checker_refuses_what_foxglove_refuses(checker, tmp_path):
    """The old recordings' schemas ("type": ["number", "null"]) are what Foxglove rejects."""
    from mcap.writer import Writer

    bad = tmp_path / "json_list_type.mcap"
    with open(bad, "wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema(name="X", encoding="jsonschema", data=json.dumps(
            {"type": "object", "properties": {"v": {"type": ["number", "null"]}}}).encode())
        cid = w.register_channel(topic="/x", message_encoding="json", schema_id=sid)
        w.add_message(channel_id=cid, log_time=0, publish_time=0, data=b'{"v": 1}')
        w.finish()
    proc = subprocess.run(["node", str(checker / "check.mjs"), str(bad)], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 1 and "Unsupported type" in proc.stdout


def test_without_node_the_test_skips_or_fails_as_asked(monkeypatch):
    """The switch itself: no node -> skip normally, fail under HIL_REQUIRE_FOXGLOVE=1."""
    monkeypatch.setattr(shutil, "which", lambda name: None)
    monkeypatch.delenv("HIL_REQUIRE_FOXGLOVE", raising=False)
    with pytest.raises(pytest.skip.Exception, match="node is not installed"):
        _require_checker()
    monkeypatch.setenv("HIL_REQUIRE_FOXGLOVE", "1")
    with pytest.raises(pytest.fail.Exception, match="HIL_REQUIRE_FOXGLOVE=1 but the Foxglove check cannot run"):
        _require_checker()


def test_the_layout_names_only_topics_and_fields_of_the_demo_recording(recording):
    """Every series of the layout is in the demo's recording (a reference estimator's topic depends
    on the scenario: the layout plots the demo's, /reference/SMO_TANH; README says so)."""
    topics = set(load_recording(recording, topics=()).counts)
    layout = json.loads(LAYOUT.read_text())
    paths = []
    for panel_id, cfg in layout["configById"].items():
        for p in cfg.get("paths", []):
            paths.append(p["value"])
        if "topicPath" in cfg:
            assert ch.kind_of_topic(cfg["topicPath"]) is not None, cfg["topicPath"]
    assert paths
    for path in paths:
        topic, _, field = path.rpartition(".")
        kind = ch.kind_of_topic(topic)
        assert kind is not None, path
        assert field in ch.LAYOUTS[kind].names, path
        assert topic in topics, f"{path}: the demo recording has no {topic} (has {sorted(topics)})"
    # every panel placed in the mosaic exists, and every panel is placed
    placed = set()

    def walk(node):
        if isinstance(node, str):
            placed.add(node)
        else:
            walk(node["first"])
            walk(node["second"])

    walk(layout["layout"])
    assert placed == set(layout["configById"])


def test_the_faults_channel_parses_with_foxgloves_rules(checker, tmp_path):
    """A run with [[faults]] adds /faults (strings and a double per row): Foxglove's rules take
    it like every other channel."""
    from hil_bench.scenario import derive_scenario

    scn = derive_scenario("gong_g2_500rpm", "fg_faults", [
        ("scenario.duration_s", 0.3), ("metrics.window_s", [0.1, 0.3]),
        ("faults", [{"kind": "drop", "direction": "from_controller", "message": "DUTY",
                     "count": 1, "t_s": 0.2}])])
    out = tmp_path / "faults.mcap"
    assert run_scenario(scn, out_path=out, progress=False).ok
    proc = subprocess.run(["node", str(checker / "check.mjs"), str(out)],
                          capture_output=True, text=True, timeout=300)
    report = json.loads(proc.stdout)
    assert proc.returncode == 0 and report["errors"] == [], report["errors"]
    assert report["channels"][ch.FAULTS]["messages"] == load_recording(out).counts[ch.FAULTS] >= 2
