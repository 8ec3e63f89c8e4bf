#!/usr/bin/env python3
"""Compile the cffi API-mode extension modules in place (next to their Python package).

Each package that has C bindings exposes an ``ffibuilder`` in ``<package>/_build_cffi.py``.
Intermediate files go to ``build/cffi/<package>``; only the extension module is copied into the
package directory. Run from the repository root: ``python tools/build_native.py``.
"""
from __future__ import annotations

import importlib
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("plant_rt", "firmware_stub")


def build(package: str) -> Path:
    sys.path.insert(0, str(ROOT))
    module = importlib.import_module(f"{package}._build_cffi")
    tmpdir = ROOT / "build" / "cffi" / package
    tmpdir.mkdir(parents=True, exist_ok=True)
    built = Path(module.ffibuilder.compile(tmpdir=str(tmpdir), verbose=False))
    target = ROOT / package / built.name
    # write beside it and rename: a process that has the old module loaded keeps its (unlinked)
    # file instead of seeing its code change under it
    tmp = target.with_suffix(".tmp")
    shutil.copy2(built, tmp)
    tmp.replace(target)
    return target


def main() -> int:
    for package in PACKAGES:
        if not (ROOT / package / "_build_cffi.py").exists():
            continue
        print(f"built {build(package).relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
