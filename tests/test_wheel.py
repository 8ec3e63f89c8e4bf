"""The wheel `pip wheel .` builds (scikit-build-core over CMakeLists.txt): one import namespace,
every package and data file of the checkout, the compiled parts inside, and a bench that runs
from it alone.

``$HIL_WHEEL`` names a built wheel (``make test`` builds one with ``make wheel``, .ci/run installs
the same file into a fresh environment); without it the test builds one first (about 1.5 min).
"""
from __future__ import annotations

import email
import os
import stat
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path, PurePosixPath

import pytest

from tests.test_house import namespace_folders

ROOT = Path(__file__).resolve().parents[1]
SOABI = sysconfig.get_config_var("SOABI")
MODULES = (f"hil_bench/plant_rt/_plant_c.{SOABI}.so", f"hil_bench/firmware_stub/_fw_c.{SOABI}.so")
EXECUTABLES = ("hil_bench/bin/hil_stub", "hil_bench/bin/pty_pingpong",
               "hil_bench/bin/wakeup_latency")


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    given = os.environ.get("HIL_WHEEL")
    if given:
        return Path(given)
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(out),
                    str(ROOT)], check=True, timeout=1200)
    return next(out.glob("hil_bench-*.whl"))


@pytest.fixture(scope="module")
def names(wheel) -> set[str]:
    with zipfile.ZipFile(wheel) as z:
        return set(z.namelist())


def test_one_import_namespace_and_no_generic_top_level_name(names):
    top = {n.split("/")[0] for n in names}
    dist_info = {t for t in top if t.endswith(".dist-info")}
    assert top - dist_info == {"hil_bench"}
    for generic in ("bench", "protocol", "plant_rt", "firmware_stub"):
        assert not any(n.startswith(f"{generic}/") for n in names)


def test_the_compiled_parts_are_inside_and_executable(wheel, names):
    assert set(MODULES) <= names
    with zipfile.ZipFile(wheel) as z:
        for exe in EXECUTABLES:
            mode = z.getinfo(exe).external_attr >> 16
            assert stat.S_ISREG(mode) and mode & 0o111, f"{exe}: mode {oct(mode)}"


def _tracked(folder: Path) -> list[Path]:
    """The files git tracks or would track (not ignored) under ``folder``."""
    out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard",
                          "--", str(folder)], cwd=ROOT,
                         capture_output=True, check=True).stdout.decode()
    return [ROOT / p for p in out.split("\0") if p]


def _excluded(rel: PurePosixPath) -> bool:
    """pyproject.toml's wheel.exclude: the C, the CMake fragments, the builders, the ports."""
    return (rel.suffix in (".c", ".h", ".cmake") or rel.name == "_build_cffi.py"
            or rel.as_posix().startswith(("hil_bench/firmware_stub/cdef/",
                                          "hil_bench/firmware_stub/port/")))


def test_every_tracked_file_of_the_namespace_is_in_the_wheel_and_nothing_else(names):
    """Packages are found, not listed: every file of the mapped folders git does not ignore
    (modules, scenarios, campaigns, profiles, the DBC, the vectors) but the C sources is in the wheel,
    under its namespace name; the wheel adds only the compiled parts and its metadata."""
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout (an sdist): nothing to compare with")
    expected = set()
    for name, folder in namespace_folders().items():
        for path in _tracked(folder):
            rel = PurePosixPath(name.replace(".", "/")) / path.relative_to(folder).as_posix()
            if not _excluded(rel):
                expected.add(rel.as_posix())
    inside = {n for n in names if n.startswith("hil_bench/")}
    assert sorted(expected - inside) == []
    assert sorted(inside - expected) == sorted([*MODULES, *EXECUTABLES])


def test_metadata_entry_points_and_license(wheel, names):
    with zipfile.ZipFile(wheel) as z:
        dist = next(n.split("/")[0] for n in names if n.endswith(".dist-info/METADATA"))
        meta = email.message_from_bytes(z.read(f"{dist}/METADATA"))
        entry_points = z.read(f"{dist}/entry_points.txt").decode()
        license_text = z.read(f"{dist}/licenses/LICENSE").decode()
    assert meta["Name"] == "hil-bench" and meta["License-Expression"] == "MIT"
    requires = meta.get_all("Requires-Dist")
    # the core and its extras (README "As a package", tests/test_installation.py)
    assert "numpy>=1.26" in requires and 'pandas>=2.0; extra == "data"' in requires
    assert not [r for r in requires if r.startswith(("pandas", "dask", "pyarrow", "scipy",
                                                     "matplotlib", "foxglove")) and ";" not in r]
    assert set(meta.get_all("Provides-Extra")) == {"data", "cluster", "report", "analysis",
                                                   "live", "all", "test"}
    assert "bench = hil_bench.cli:main" in entry_points
    assert "[pytest11]" in entry_points and "hil_bench = hil_bench.pytest_plugin" in entry_points
    assert license_text.startswith("MIT License")


def _unpacked(wheel: Path, tmp_path: Path):
    """The unpacked wheel first on the path, this environment's dependencies behind it, no site
    hooks (the checkout's editable install stays out), run from a directory that is not the
    checkout: (site folder, work folder, bench(*args) -> CompletedProcess)."""
    unpacked = tmp_path / "site"
    with zipfile.ZipFile(wheel) as z:
        z.extractall(unpacked)
        for info in z.infolist():                   # zipfile drops the mode bits
            mode = info.external_attr >> 16
            if mode:
                os.chmod(unpacked / info.filename, mode)
    deps = sysconfig.get_paths()["purelib"]
    env = dict(os.environ, PYTHONPATH=f"{unpacked}{os.pathsep}{deps}")
    for var in ("HIL_STUB", "HIL_QEMU_ELF"):
        env.pop(var, None)
    work = tmp_path / "elsewhere"
    work.mkdir()

    def bench(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-S", "-m", "hil_bench", *args], cwd=work,
                              env=env, capture_output=True, text=True, timeout=600)

    return unpacked, work, bench


def test_the_wheel_alone_runs_a_scenario_from_another_directory(wheel, tmp_path):
    """The bench finds its stub, modules, scenarios and profiles inside the package, from a
    directory that is not the checkout."""
    unpacked, work, bench = _unpacked(wheel, tmp_path)

    version = bench("--version")
    assert version.returncode == 0, version.stderr
    assert f"from {unpacked / 'hil_bench'} " in version.stdout and "C built" in version.stdout
    ran = bench("run", "gong_g2_500rpm", "--no-progress", "--out", "x.mcap",
                "--set", "scenario.duration_s=0.2", "--set", "metrics.window_s=[0.1, 0.2]")
    assert "ran 2000/2000 cycles" in ran.stdout, ran.stderr
    assert (work / "x.mcap").is_file()
    from hil_bench.record.recording import read_header

    run = read_header(work / "x.mcap").run
    assert run["controller"] == f"hil_stub {unpacked / 'hil_bench' / 'bin' / 'hil_stub'}"
    assert run["git_revision"] == "none (installed package)"


def test_the_wheel_finds_campaigns_by_name_and_says_what_needs_a_checkout(wheel, tmp_path):
    """Bundled campaigns resolve by name from the package as sweeps do (before: `bench campaign
    g2_protection` was "no such campaign file" from a wheel), and pil-qemu, which builds the
    Cortex-M port from the checkout's sources, says so (before: a CMake error)."""
    _, _, bench = _unpacked(wheel, tmp_path)
    typo = bench("campaign", "g2_protectio", "--no-progress")
    assert typo.returncode == 2 and "did you mean 'g2_protection'" in typo.stderr, typo.stderr
    listed = subprocess.run(
        [sys.executable, "-S", "-c", "from hil_bench.faults.campaign import load_campaign; "
                                     "c = load_campaign('g2_protection'); print(c.name, len(c.cases))"],
        cwd=tmp_path / "elsewhere", env=dict(os.environ, PYTHONPATH=f"{tmp_path / 'site'}"
                                                                  f"{os.pathsep}"
                                                                  f"{sysconfig.get_paths()['purelib']}"),
        capture_output=True, text=True, timeout=120)
    assert listed.stdout.split() == ["g2_protection", "18"], listed.stderr
    pil = bench("conformance", "--link", "pil-qemu")
    assert pil.returncode == 2
    assert "needs a checkout of hil-bench (firmware_stub/port/cortex_m" in pil.stdout + pil.stderr
    assert "CMake" not in pil.stdout + pil.stderr
