#!/usr/bin/env python3
"""The import graph of hil_bench, read from the source (every ``import``, also those inside
functions), so a circle shows whether or not it bites at import time.

    python tools/import_graph.py            # modules and packages in a cycle, if any (exit 1)
    python tools/import_graph.py --layers   # each sub-package and the sub-packages it imports

The house's rule (docs/architecture.md, "The house"): no module imports one that imports it back,
directly or around a circle, and no sub-package of hil_bench does either; nothing in plant_rt,
protocol or firmware_stub imports the bench above them. tests/test_house.py runs this.
"""
from __future__ import annotations

import argparse
import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the repository folder of each top-level part of the namespace (pyproject.toml's folder map,
#: [tool.scikit-build] wheel.force-include and wheel.packages: tests/test_house.py holds them equal)
FOLDERS = {"hil_bench": ROOT / "bench", "hil_bench.plant_rt": ROOT / "plant_rt",
           "hil_bench.protocol": ROOT / "protocol", "hil_bench.firmware_stub": ROOT / "firmware_stub"}


def modules() -> dict[str, Path]:
    """Every module of the namespace: dotted name -> file."""
    out: dict[str, Path] = {}
    for prefix, folder in FOLDERS.items():
        for path in folder.rglob("*.py"):
            rel = path.relative_to(folder).with_suffix("")
            parts = [p for p in rel.parts]
            if parts[0] in ("plant_rt", "protocol", "firmware_stub") and prefix == "hil_bench":
                continue
            if any(p.startswith(("_build", "test")) or p == "vectors" for p in parts[:-1]):
                continue
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join([prefix] + parts)] = path
    return out


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """The namespace's modules ``name`` imports (a ``from P import x`` where P.x is a module
    counts as importing P.x)."""
    tree = ast.parse(path.read_text(), str(path))
    is_pkg = path.name == "__init__.py"
    package = name if is_pkg else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)] if node.level > 1 else base
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            subs = [f"{mod}.{a.name}" for a in node.names]
            # `from P import m` of submodules runs P's __init__ too, but counting that arrow would
            # make every __init__ that re-exports its own modules a circle (P -> P.m -> P), which
            # Python resolves; an arrow into another package's __init__ is seen by package_graph
            targets = subs if all(t in known for t in subs) else [mod] + subs
        else:
            continue
        for t in targets:
            if t in known and t != name:
                out.add(t)
    return out


def graph() -> dict[str, set[str]]:
    mods = modules()
    known = set(mods)
    return {m: imports_of(m, p, known) for m, p in mods.items()}


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def package_of(module: str) -> str:
    """The sub-package a module belongs to: hil_bench.<sub> (or hil_bench itself for a module at
    the top)."""
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 1 else parts[0]


def package_graph(g: dict[str, set[str]]) -> dict[str, set[str]]:
    """The module graph folded onto sub-packages (package_of); a module at the top of hil_bench
    (cli, conformance, __main__) is a node of its own."""
    out: dict[str, set[str]] = {}
    for m, deps in g.items():
        pm = package_of(m)
        out.setdefault(pm, set()).update(pd for pd in map(package_of, deps) if pd != pm)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--layers", action="store_true", help="print the sub-package graph")
    args = ap.parse_args(argv)
    g = graph()
    if not g:
        print(f"no module found under {', '.join(str(f) for f in FOLDERS.values())}")
        return 2
    pg = package_graph(g)
    if args.layers:
        for p in sorted(pg):
            print(f"{p:32s} -> {', '.join(sorted(pg[p])) or '-'}")
    bad = 0
    for comp in cycles(g):
        bad += 1
        print("module cycle:", " <-> ".join(comp))
    for comp in cycles(pg):
        bad += 1
        print("package cycle:", " <-> ".join(comp))
    lower = ("hil_bench.plant_rt", "hil_bench.protocol", "hil_bench.firmware_stub")
    for m, deps in sorted(g.items()):
        if m.startswith(lower):
            up = sorted(d for d in deps if not d.startswith(lower))
            if up:
                bad += 1
                print(f"{m} imports the bench above it: {', '.join(up)}")
    if not bad:
        print(f"{len(g)} modules, {len(pg)} packages: no import cycle")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
