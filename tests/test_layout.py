"""bench layout: a Foxglove / Lichtblick layout made for each scenario's recording."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from hil_bench.record import channels as ch
from hil_bench.record.layout import TITLE_KEYS, layout_topics, make_layout
from hil_bench.scenario import SCENARIO_DIR, load_scenario


def _placed(node, out):
    if isinstance(node, str):
        out.append(node)
    else:
        _placed(node["first"], out)
        _placed(node["second"], out)
    return out


@pytest.mark.parametrize("name", sorted(p.stem for p in SCENARIO_DIR.glob("*.toml")))
def test_every_series_is_a_field_of_the_scenarios_recording(name):
    scn = load_scenario(name)
    layout = make_layout(tuple(scn.reference_estimators), telemetry_emf=scn.telemetry_emf,
                         faults=bool(scn.faults) or scn.post_trip_s > 0)
    refs = {ch.REFERENCE_PREFIX + e for e in scn.reference_estimators}
    seen_refs = set()
    for topic, field in layout_topics(layout):
        kind = ch.kind_of_topic(topic)
        assert kind is not None, topic
        if field:
            assert field in ch.LAYOUTS[kind].names, (topic, field)
        if topic.startswith(ch.REFERENCE_PREFIX):
            seen_refs.add(topic)
    assert seen_refs == refs   # the scenario's own references, every one, no other
    for pid, cfg in layout["configById"].items():
        assert all(cfg.get(k) for k in TITLE_KEYS), pid    # the keys the viewers read
        assert "title" not in cfg, pid
    placed = _placed(layout["layout"], [])
    assert sorted(placed) == sorted(layout["configById"])


def test_the_shipped_layout_is_the_demos_made_by_bench_layout():
    from pathlib import Path

    shipped = Path(__file__).resolve().parents[1] / "docs" / "foxglove" / "hil_bench_layout.json"
    scn = load_scenario("gong_g2_500rpm")
    assert json.loads(shipped.read_text()) == make_layout(
        tuple(scn.reference_estimators), telemetry_emf=scn.telemetry_emf,
        faults=bool(scn.faults) or scn.post_trip_s > 0), \
        "regenerate: bench layout gong_g2_500rpm -o docs/foxglove/hil_bench_layout.json --force"


def test_bench_layout_writes_refuses_to_replace_and_names_a_bad_scenario(tmp_path):
    out = tmp_path / "l.json"
    cmd = [sys.executable, "-m", "hil_bench", "layout", "beyond_smo_speed", "-o", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    layout = json.loads(out.read_text())
    assert len({t for t, _ in layout_topics(layout) if t.startswith(ch.REFERENCE_PREFIX)}) == \
        len(load_scenario("beyond_smo_speed").reference_estimators) > 1
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "exists" in r.stderr and "Traceback" not in r.stderr
    r = subprocess.run(cmd[:3] + ["no_such_scenario", "-o", str(tmp_path / "m.json")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "no_such_scenario" in r.stderr and "Traceback" not in r.stderr
