"""The house's rules (docs/architecture.md, "The house"), read from the source by
tools/import_graph.py: no import circle between modules nor between sub-packages, nothing in
plant_rt, protocol or firmware_stub imports the bench above it, and the claims registry
(hil_bench.claims) imports nothing of the bench."""
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


def test_no_sub_package_imports_itself_around_a_circle():
    """Sub-packages form layers: scenario asks the claims registry (hil_bench.claims, below it)
    whether a claim id exists, never papers, which imports scenario."""
    ig = _tool()
    assert ig.cycles(ig.package_graph(ig.graph())) == []


def test_the_claims_registry_imports_nothing_of_the_bench():
    """hil_bench.claims (definitions, data, loader) sits below scenario, loop and papers."""
    ig = _tool()
    up = {m: sorted(d for d in deps if not d.startswith("hil_bench.claims"))
          for m, deps in ig.graph().items() if m.startswith("hil_bench.claims")}
    assert {m: d for m, d in up.items() if d} == {}


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
    assert "hil_bench.claims.registry" in mods and "hil_bench.papers.claims" in mods
    # an import inside a function counts: scenario asks the claims registry lazily
    assert "hil_bench.claims.registry" in ig.graph()["hil_bench.scenario.scenario"]
