#!/usr/bin/env python3
"""Build the cffi extension modules for development, with CMake, where Python imports them from.

CMake builds every module from its package's ``_build_cffi.py`` (cmake/cffi_modules.cmake; the
same build makes the wheel's modules). ``make build`` configures build/ with
``HIL_PYTHON_INPLACE=ON``, so each build also puts the module next to its package's sources,
where the development install (an editable install of the Python alone) imports it from; after
editing a .c file, ``make build`` (or ``cmake --build build``) rebuilds what changed and puts the
new module in place. ``python tools/build_native.py`` does the same for the modules alone
(configuring build/ first if needed). Run from anywhere; the interpreter running it is the one
the modules are built for.

``--sanitize`` builds the same modules with AddressSanitizer + UndefinedBehaviorSanitizer
(``make_builder(sanitize=True)``, CMake's ``HIL_SANITIZE``) in build-asan/ and makes a separate
import root, ``build-asan/python/hil_bench/``: the installed layout (``hil_bench`` = bench/, with
``plant_rt``, ``firmware_stub`` and ``protocol`` inside it) as directories of symlinks to the
repository's files, with the sanitized extensions in place of the normal ones, so the normal
build is untouched. A process uses it with (``make sanitize`` builds it;
tests/test_loop_sanitized.py runs the closed loop on it)::

    LD_PRELOAD=$(gcc -print-file-name=libasan.so) ASAN_OPTIONS=detect_leaks=0 \\
    UBSAN_OPTIONS=halt_on_error=1 PYTHONPATH=build-asan/python python ...

(from the repository root, or with an absolute PYTHONPATH from anywhere: the root holds no
``hil_bench`` that could come first on ``sys.path``). The editable install's import redirect
(scikit-build-core's, first on ``sys.meta_path``) would still serve ``hil_bench`` from the
checkout: the import root's ``sitecustomize.py``, which Python runs at start-up from
PYTHONPATH, takes it out. The interpreter is not instrumented:
ASan's runtime must be loaded first (LD_PRELOAD), and leak detection is off because CPython
keeps memory until exit by design.
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SANITIZED_ROOT = ROOT / "build-asan" / "python"
SUBPACKAGES = ("plant_rt", "firmware_stub", "protocol")   # folders installed inside hil_bench


def packages_with_modules() -> list[str]:
    """The repository folders that have a cffi builder (one extension module each)."""
    return sorted(p.parent.name for p in ROOT.glob("*/_build_cffi.py"))


def cmake_build(build_dir: Path, sanitize: bool) -> None:
    """Configure ``build_dir`` for the modules if it is not yet, then build their targets."""
    cache = build_dir / "CMakeCache.txt"
    lines = set(cache.read_text().splitlines()) if cache.exists() else set()
    wanted = {"HIL_PYTHON_MODULES:BOOL=ON", f"Python_EXECUTABLE:FILEPATH={sys.executable}"}
    wanted |= ({"CMAKE_BUILD_TYPE:STRING=Debug", "HIL_SANITIZE:BOOL=ON"} if sanitize else
               {"HIL_PYTHON_INPLACE:BOOL=ON"})
    if not wanted <= lines:
        build_type = "Debug" if sanitize else "RelWithDebInfo"
        args = ["cmake", "-S", str(ROOT), "-B", str(build_dir), f"-DCMAKE_BUILD_TYPE={build_type}"]
        args += sorted("-D" + w.replace(":BOOL", "").replace(":FILEPATH", "").replace(":STRING", "")
                       for w in wanted if not w.startswith("CMAKE_BUILD_TYPE"))
        subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    targets = [f"cffi_{p}" for p in packages_with_modules()]
    subprocess.run(["cmake", "--build", str(build_dir), "-j2", "--target", *targets], check=True)


def built_module(build_dir: Path, package: str) -> Path:
    """The module CMake built for ``package`` (build_dir/cffi/<package>/<name>.<SOABI>.so)."""
    found = sorted((build_dir / "cffi" / package).glob("*.so"))
    if len(found) != 1:
        raise SystemExit(f"expected one extension module in {build_dir / 'cffi' / package}, "
                         f"found {[p.name for p in found]}")
    return found[0]


def _install(built: Path, target: Path) -> Path:
    # write beside it and rename: a process that has the old module loaded keeps its (unlinked)
    # file instead of seeing its code change under it
    tmp = target.with_suffix(".tmp")
    shutil.copy2(built, tmp)
    tmp.replace(target)
    return target


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


def sanitized_farm(package: str) -> Path:
    """build-asan/python/hil_bench/<package>/: symlinks to the package's entries, the sanitized
    module; hil_bench itself (bench/) and the other sub-packages as symlinks."""
    built = built_module(ROOT / "build-asan", package)
    ext_prefix = built.name.split(".", 1)[0] + "."          # e.g. "_plant_c."
    top = SANITIZED_ROOT / "hil_bench"
    _farm(ROOT / "bench", top, lambda e: e.name in SUBPACKAGES)
    for sub in SUBPACKAGES:
        if sub != package and not (top / sub).exists():
            (top / sub).symlink_to(ROOT / sub)
    if (top / package).is_symlink():
        (top / package).unlink()
    farm = top / package
    _farm(ROOT / package, farm,
          lambda e: e.name.startswith(ext_prefix) and e.suffix == ".so")
    return _install(built, farm / built.name)


SITECUSTOMIZE = '''"""build-asan/python/ (tools/build_native.py --sanitize): this import root's hil_bench, with
the sanitized modules, must be the one imported. Python runs this at start-up when
PYTHONPATH=build-asan/python; it takes the checkout's editable-install import redirect (which
maps hil_bench onto the checkout's folders, ahead of PYTHONPATH) out of sys.meta_path."""
import sys

sys.meta_path[:] = [f for f in sys.meta_path
                    if not type(f).__module__.startswith("_editable_skbc_hil_bench")]
'''


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sanitize", action="store_true",
                    help="ASan + UBSan build into build-asan/python/ (the normal build untouched)")
    args = ap.parse_args(argv)
    build_dir = ROOT / ("build-asan" if args.sanitize else "build")
    cmake_build(build_dir, args.sanitize)
    if args.sanitize:
        SANITIZED_ROOT.mkdir(parents=True, exist_ok=True)
        (SANITIZED_ROOT / "sitecustomize.py").write_text(SITECUSTOMIZE)
    for package in packages_with_modules():
        if args.sanitize:
            target = sanitized_farm(package)
        else:
            built = built_module(build_dir, package)
            target = ROOT / package / built.name          # put there by the POST_BUILD step
        print(f"built {target.relative_to(ROOT)}{' (ASan + UBSan)' if args.sanitize else ''}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
