"""The house's rules (docs/architecture.md, "The house"), read from the source by
tools/import_graph.py: no import circle between modules, and nothing in plant_rt, protocol or
firmware_stub imports the bench above it."""
from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _tool():
    spec = importlib.util.spec_from_file_location("import_graph", ROOT / "tools" / "import_graph.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_no_module_imports_itself_around_a_circle():
    ig = _tool()
    assert ig.cycles(ig.graph()) == []


def test_the_lower_layers_import_nothing_of_the_bench():
    ig = _tool()
    lower = ("hil_bench.plant_rt", "hil_bench.protocol", "hil_bench.firmware_stub")
    up = {m: sorted(d for d in deps if not d.startswith(lower))
          for m, deps in ig.graph().items() if m.startswith(lower)}
    assert {m: d for m, d in up.items() if d} == {}


def test_the_graph_sees_every_module_of_the_namespace():
    """A module the tool misses would hide its imports: every .py of the four folders that is
    part of the package is in the graph."""
    ig = _tool()
    mods = ig.modules()
    assert "hil_bench.loop.runner" in mods and "hil_bench.plant_rt.plant" in mods
    assert "hil_bench.protocol.messages" in mods and "hil_bench.firmware_stub.est_smo" in mods
    # an import inside a function counts: scenario asks the claims registry lazily
    assert "hil_bench.papers.claims" in ig.graph()["hil_bench.scenario.scenario"]
