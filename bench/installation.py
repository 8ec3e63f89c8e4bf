"""This installation of hil_bench: its version, whether it runs from a checkout, where its
compiled parts are and what to run when they are missing.

An installed wheel carries them inside the package: the cffi modules next to their Python
(``hil_bench/plant_rt/_plant_c*.so``, ``hil_bench/firmware_stub/_fw_c*.so``) and the executables
in ``hil_bench/bin/`` (``hil_stub``, ``pty_pingpong``, ``wakeup_latency``). A checkout built with
``make build`` has the modules in place and the executables in ``build/bin/``. ``$HIL_STUB``
names another stub executable (a sanitized build, a drive team's own host build of its firmware).

The core install runs, checks, replays and conformance-tests; the heavier libraries are extras
(pyproject.toml's ``[project.optional-dependencies]``, :data:`EXTRAS`), imported only by what
needs them, through :func:`require_extra`, which names the extra to install when one is missing.
"""
from __future__ import annotations

import importlib
import importlib.resources
import importlib.util
import os
from pathlib import Path
from types import ModuleType

from hil_bench.errors import BenchError

#: the extension modules (built from plant_rt/_build_cffi.py and firmware_stub/_build_cffi.py)
MODULES = ("hil_bench.plant_rt._plant_c", "hil_bench.firmware_stub._fw_c")

_HERE = Path(__file__).resolve().parent


#: the extras (pyproject.toml's optional dependencies, tests/test_installation.py holds the two
#: together): extra -> the modules it makes importable (for what: README "As a package")
EXTRAS: dict[str, tuple[str, ...]] = {
    "data": ("pandas", "pyarrow"),              # load_recording, bench export, Session
    "cluster": ("distributed", "pandas", "pyarrow", "scipy"),   # sweep, campaign, claims --run
    "report": ("matplotlib",),                  # the plots of claims --run and sweeps
    "analysis": ("scipy",),                     # replaying a DAQ CSV export, signals.frequency
    "live": ("foxglove",),                      # bench run / replay --live
}

#: an optional module -> its name in a message, the smallest extra that installs it
OPTIONAL: dict[str, tuple[str, str]] = {
    "distributed": ("Dask", "cluster"), "dask": ("Dask", "cluster"),
    "pandas": ("pandas", "data"), "pyarrow": ("pyarrow", "data"),
    "matplotlib": ("Matplotlib", "report"), "scipy": ("SciPy", "analysis"),
    "foxglove": ("foxglove-sdk", "live"),
}


class ExtraMissing(BenchError, ImportError):
    """An optional dependency is not installed (or does not import); the message is one line
    naming the feature, what it needs and the extra to install (the CLI prints it as its error
    line, as every BenchError)."""


def version() -> str:
    """The installed distribution's version (pyproject.toml's), "unknown" without metadata."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as dist_version

    try:
        return dist_version("hil-bench")
    except PackageNotFoundError:
        return "unknown"


class NativeMissing(BenchError, ImportError):
    """A compiled part of hil_bench is not there; the message says what to run."""


def checkout_root() -> Path | None:
    """The repository this package runs from (bench/ in a checkout with its CMakeLists.txt), or
    None for an installed package."""
    root = _HERE.parent
    if _HERE.name == "bench" and (root / "CMakeLists.txt").is_file():
        return root
    return None


def how_to_build() -> str:
    """What to run to get the compiled parts, for this installation."""
    root = checkout_root()
    if root is not None:
        return (f"in the checkout {root}: run `make build` (CMake builds the C, the cffi "
                f"modules in place and build/bin/hil_stub), or `pip install {root}` for a full "
                f"install")
    return ("this installation of hil-bench has no compiled parts (built without CMake?): "
            "reinstall it from a checkout with `pip install <checkout>` (or a wheel from "
            "`pip wheel <checkout>`) on a machine with a C compiler and CMake >= 3.16")


def missing_modules() -> list[str]:
    """The extension modules that cannot be found (not imported: finding is cheap)."""
    out = []
    for name in MODULES:
        try:
            found = importlib.util.find_spec(name) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            out.append(name)
    return out


def require_modules() -> None:
    """NativeMissing naming the missing modules and what to run, if any is missing."""
    missing = missing_modules()
    if missing:
        raise NativeMissing(f"{', '.join(missing)} not built: {how_to_build()}")


def is_native_import_error(exc: BaseException) -> bool:
    """True for the ImportError of a missing extension module (however deep it was raised)."""
    while exc is not None:
        if isinstance(exc, NativeMissing) or (isinstance(exc, ImportError)
                                              and getattr(exc, "name", None) in MODULES):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def _installed_bin() -> Path | None:
    try:
        path = importlib.resources.files("hil_bench").joinpath("bin")
    except (ModuleNotFoundError, TypeError):
        return None
    return Path(str(path)) if path.is_dir() else None


def executable_candidates(name: str) -> list[Path]:
    """Where executable ``name`` is looked for, in order: the installed package's bin/, then the
    checkout's build/bin/."""
    out = []
    installed = _installed_bin()
    if installed is not None:
        out.append(installed / name)
    root = checkout_root()
    if root is not None:
        out.append(root / "build" / "bin" / name)
    return out


def find_executable(name: str, env: str | None = None) -> Path:
    """The path of a bundled executable (``$env`` first, when given and set); FileNotFoundError
    naming where it looked and what to run."""
    given = os.environ.get(env) if env else None
    if given:
        path = Path(given)
        if path.is_file() and os.access(path, os.X_OK):
            return path
        raise FileNotFoundError(f"${env} = {given}: no executable there")
    looked = executable_candidates(name)
    for path in looked:
        if path.is_file() and os.access(path, os.X_OK):
            return path
    where = ", ".join(str(p) for p in looked) or "nowhere (no package bin/, no checkout)"
    hint = f" (or point ${env} at one)" if env else ""
    raise FileNotFoundError(f"{name} not found (looked in {where}): {how_to_build()}{hint}")


def require_extra(feature: str, *modules: str, extra: str | None = None) -> ModuleType:
    """Import ``modules`` (dotted names; the first is returned) for ``feature`` ("bench sweep"),
    or raise ExtraMissing, one line: "bench sweep needs Dask: pip install 'hil-bench[cluster]'".
    The extra named is ``extra`` when given, else the smallest that installs each module that
    failed (:data:`OPTIONAL`), leaving out one that another named extra contains."""
    if not modules:
        raise TypeError("require_extra: name at least one module")
    found: list[ModuleType] = []
    failed: dict[str, str | None] = {}     # top-level module -> None (not installed) or why
    for name in modules:
        top = name.split(".", 1)[0]
        try:
            found.append(importlib.import_module(name))
        except ImportError as exc:
            gone = isinstance(exc, ModuleNotFoundError) and (exc.name or "").split(".")[0] == top
            # else it is there but its own import fails (a shared library, a version clash)
            failed.setdefault(top, None if gone else str(exc))
    if not failed:
        return found[0]
    wanted = [extra] if extra else list(dict.fromkeys(OPTIONAL.get(t, (t, "all"))[1]
                                                      for t in failed))
    wanted = [e for e in wanted if not any(
        f != e and set(EXTRAS.get(e, ())) <= set(EXTRAS.get(f, ())) for f in wanted)]
    install = f"pip install 'hil-bench[{','.join(wanted)}]'"
    said = [OPTIONAL.get(t, (t,))[0] + (f" (installed, but: {why})" if why else "")
            for t, why in failed.items()]
    names = " and ".join(filter(None, (", ".join(said[:-1]), said[-1])))
    raise ExtraMissing(f"{feature} needs {names}: {install}")
