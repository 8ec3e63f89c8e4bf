"""The house's rules (docs/architecture.md, "The house"), read from the source by
tools/import_graph.py: no import circle between modules or between sub-packages, nothing in
plant_rt, protocol or firmware_stub imports the bench above it, and the claims registry
(hil_bench.claims) imports nothing of the bench; pyproject.toml maps the namespace over the same
folders the graph reads (the wheel holds every package of them and their data files:
tests/test_wheel.py); and no module hides the API's names (hil_bench.run, .check,
.load_recording)."""
from __future__ import annotations

import importlib.util
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def ig():
    spec = importlib.util.spec_from_file_location("import_graph", ROOT / "tools" / "import_graph.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def graph(ig):
    return ig.graph()


def test_no_module_imports_itself_around_a_circle(ig, graph):
    assert ig.cycles(graph) == []


def test_no_sub_package_imports_itself_around_a_circle(ig, graph):
    """Sub-packages form layers: scenario asks the claims registry (hil_bench.claims, below it)
    whether a claim id exists, never papers, which imports scenario."""
    assert ig.cycles(ig.package_graph(graph)) == []


def test_the_claims_registry_imports_nothing_of_the_bench(graph):
    """hil_bench.claims (definitions, data, loader) sits below scenario, loop and papers."""
    up = {m: sorted(d for d in deps if not d.startswith("hil_bench.claims"))
          for m, deps in graph.items() if m.startswith("hil_bench.claims")}
    assert "hil_bench.claims.registry" in up and {m: d for m, d in up.items() if d} == {}


def test_the_lower_layers_import_nothing_of_the_bench(graph):
    lower = ("hil_bench.plant_rt", "hil_bench.protocol", "hil_bench.firmware_stub")
    up = {m: sorted(d for d in deps if not d.startswith(lower))
          for m, deps in graph.items() if m.startswith(lower)}
    assert {m: d for m, d in up.items() if d} == {}


def namespace_folders() -> dict[str, Path]:
    """pyproject.toml's map of the namespace onto the repository's folders (scikit-build-core:
    bench/ by force-include, the others by wheel.packages): dotted name -> folder."""
    wheel = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["scikit-build"]["wheel"]
    pairs = [(dest, src) for src, dest in wheel["force-include"].items()]
    pairs += list(wheel["packages"].items())
    return {dest.replace("/", "."): ROOT / src for dest, src in pairs}


def _package_dirs() -> dict[str, Path]:
    """Every package of the namespace on disk (a folder with an __init__.py under the mapped
    folders): dotted name -> folder."""
    out: dict[str, Path] = {}
    for name, folder in namespace_folders().items():
        for init in folder.rglob("__init__.py"):
            rel = init.parent.relative_to(folder).parts
            out[".".join((name,) + rel)] = init.parent
    return out


def test_pyproject_maps_the_folders_the_import_graph_reads(ig):
    """Packages are found, not listed (every folder is copied whole into the wheel): what must
    agree is the map of the namespace onto folders, here and in tools/import_graph.py."""
    assert namespace_folders() == ig.FOLDERS


def test_the_api_names_are_not_hidden_by_modules():
    """``hil_bench.run`` is the API's function: a sub-package or module named run, check or
    load_recording would replace it as an attribute once imported."""
    names = {name.split(".")[1] for name in _package_dirs() if name.count(".") >= 1}
    names |= {p.stem for p in namespace_folders()["hil_bench"].glob("*.py")}
    assert names.isdisjoint({"run", "check", "load_recording"})


def test_the_graph_sees_every_module_of_the_namespace(ig, graph):
    """A module the tool misses would hide its imports: every module of every package is in the
    graph, under its installed name and from its own file."""
    on_disk: dict[str, Path] = {}
    for name, folder in _package_dirs().items():
        on_disk[name] = folder / "__init__.py"
        on_disk.update({f"{name}.{p.stem}": p for p in folder.glob("*.py") if p.stem != "__init__"})
    mods = ig.modules()
    assert {m: mods.get(m) for m in on_disk} == on_disk
    assert set(graph) == set(mods)
    # an import inside a function counts: scenario asks the claims registry lazily
    assert "hil_bench.claims.registry" in graph["hil_bench.scenario.scenario"]
