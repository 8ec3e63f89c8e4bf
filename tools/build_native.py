#!/usr/bin/env python3
"""Compile the cffi API-mode extension modules in place (next to their Python package).

Each package that has C bindings exposes an ``ffibuilder`` in ``<package>/_build_cffi.py``.
Intermediate files go to ``build/cffi/<package>``; only the extension module is copied into the
package directory. Run from the repository root: ``python tools/build_native.py``.

``--sanitize`` builds the same modules with AddressSanitizer + UndefinedBehaviorSanitizer
(``<package>/_build_cffi.py``'s ``make_builder(sanitize=True)``) into a separate import root,
``build-asan/python/hil_bench/``: the installed layout (``hil_bench`` = bench/, with
``plant_rt``, ``firmware_stub`` and ``protocol`` inside it) as directories of symlinks to the
repository's files, with the sanitized extensions in place of the normal ones, so the normal
build is untouched. A process uses it with (``make sanitize`` builds it;
tests/test_loop_sanitized.py runs the closed loop on it)::

    LD_PRELOAD=$(gcc -print-file-name=libasan.so) ASAN_OPTIONS=detect_leaks=0 \\
    UBSAN_OPTIONS=halt_on_error=1 PYTHONPATH=build-asan/python python ...

(from the repository root, or with an absolute PYTHONPATH from anywhere: the root holds no
``hil_bench`` that could come first on ``sys.path``). The interpreter is not instrumented:
ASan's runtime must be loaded first (LD_PRELOAD), and leak detection is off because CPython
keeps memory until exit by design.
"""
from __future__ import annotations

import argparse
import importlib.util
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("plant_rt", "firmware_stub")
SANITIZED_ROOT = ROOT / "build-asan" / "python"


def _builder(package: str, sanitize: bool):
    # by path: the builder needs only cffi, not the package (which needs the built module)
    spec = importlib.util.spec_from_file_location(f"_build_cffi_{package}",
                                                  ROOT / package / "_build_cffi.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.make_builder(sanitize=True) if sanitize else module.ffibuilder


def _install(built: Path, target: Path) -> Path:
    # write beside it and rename: a process that has the old module loaded keeps its (unlinked)
    # file instead of seeing its code change under it
    tmp = target.with_suffix(".tmp")
    shutil.copy2(built, tmp)
    tmp.replace(target)
    return target


def build(package: str) -> Path:
    tmpdir = ROOT / "build" / "cffi" / package
    tmpdir.mkdir(parents=True, exist_ok=True)
    built = Path(_builder(package, False).compile(tmpdir=str(tmpdir), verbose=False))
    return _install(built, ROOT / package / built.name)


def _farm(source: Path, farm: Path, skip) -> None:
    """``farm``: a directory of symlinks to ``source``'s entries (stale links removed) but those
    ``skip`` names."""
    farm.mkdir(parents=True, exist_ok=True)
    for old in farm.iterdir():                               # stale links and modules
        if old.is_symlink() or old.suffix in (".so", ".tmp"):
            old.unlink()
    for entry in sorted(source.iterdir()):
        if entry.name == "__pycache__" or entry.suffix == ".tmp" or skip(entry):
            continue
        (farm / entry.name).symlink_to(entry)


def build_sanitized(package: str) -> Path:
    """build-asan/python/hil_bench/<package>/: symlinks to the package's entries, the sanitized
    module; hil_bench itself (bench/) and protocol/ as symlinks."""
    tmpdir = ROOT / "build-asan" / "cffi" / package
    tmpdir.mkdir(parents=True, exist_ok=True)
    built = Path(_builder(package, True).compile(tmpdir=str(tmpdir), verbose=False))
    ext_prefix = built.name.split(".", 1)[0] + "."          # e.g. "_plant_c."
    top = SANITIZED_ROOT / "hil_bench"
    _farm(ROOT / "bench", top, lambda e: e.name in ("plant_rt", "firmware_stub", "protocol"))
    for sub in ("plant_rt", "firmware_stub", "protocol"):
        if sub != package and not (top / sub).exists():
            (top / sub).symlink_to(ROOT / sub)
    if (top / package).is_symlink():
        (top / package).unlink()
    farm = top / package
    _farm(ROOT / package, farm,
          lambda e: e.name.startswith(ext_prefix) and e.suffix == ".so")
    return _install(built, farm / built.name)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sanitize", action="store_true",
                    help="ASan + UBSan build into build-asan/python/ (the normal build untouched)")
    args = ap.parse_args(argv)
    for package in PACKAGES:
        if not (ROOT / package / "_build_cffi.py").exists():
            continue
        target = build_sanitized(package) if args.sanitize else build(package)
        print(f"built {target.relative_to(ROOT)}{' (ASan + UBSan)' if args.sanitize else ''}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
