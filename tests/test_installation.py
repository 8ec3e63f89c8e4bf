"""The lean core and its extras (README "Install", pyproject.toml): the core install runs, checks,
replays and conformance-tests; each command or API call that needs an extra says in one line
which one to install, before it writes anything.

The extras' packages are blocked by an import hook in a subprocess (as a core-only install has
none of them); the installed core itself is measured in tools/ci_installed_wheel.sh."""
from __future__ import annotations

import json
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from hil_bench.installation import EXTRAS, OPTIONAL, ExtraMissing, require_extra

REPO = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
#: a distribution in pyproject.toml -> the module it installs, where the names differ
MODULE_OF = {"dask": "distributed", "foxglove-sdk": "foxglove"}   # dask[distributed]: Client


def _module(requirement: str) -> str:
    name = re.match(r"[A-Za-z0-9_.-]+", requirement).group(0).lower()
    return MODULE_OF.get(name, name.replace("-", "_"))


def _extras_of(requirement: str) -> list[str]:
    """``hil-bench[a,b]`` -> [a, b] (a self-reference), else []."""
    m = re.match(r"hil-bench\[([a-z,]+)\]", requirement)
    return m.group(1).split(",") if m else []


def test_extras_table_is_pyprojects():
    """installation.EXTRAS (what the messages name) is pyproject.toml's optional dependencies;
    the core has none of their packages; [all] is every extra and [test] includes [all]."""
    optional = PYPROJECT["optional-dependencies"]
    for extra, modules in EXTRAS.items():
        assert sorted(_module(r) for r in optional[extra]) == sorted(modules), extra
    assert set(optional) == set(EXTRAS) | {"all", "test"}
    assert _extras_of(optional["all"][0]) == list(EXTRAS) and len(optional["all"]) == 1
    assert "all" in [e for r in optional["test"] for e in _extras_of(r)]
    core = {_module(r) for r in PYPROJECT["dependencies"]}
    assert not core & {m for mods in EXTRAS.values() for m in mods}
    assert core >= {"numpy", "cffi", "mcap", "zstandard", "protobuf", "python_can", "pyserial",
                    "cantools", "rich"}
    for module, (_name, extra) in OPTIONAL.items():          # a module's own extra installs it
        assert module in EXTRAS[extra] or (module, extra) == ("dask", "cluster")


def test_require_extra_names_what_is_missing_and_the_smallest_extras(monkeypatch):
    import numpy

    assert require_extra("x", "numpy") is numpy
    monkeypatch.setitem(sys.modules, "distributed", None)    # import distributed fails
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)   # (imported by an earlier test)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(ExtraMissing) as e:
        require_extra("bench sweep", "distributed")
    assert str(e.value) == "bench sweep needs Dask: pip install 'hil-bench[cluster]'"
    with pytest.raises(ExtraMissing) as e:                  # [data] is inside [cluster]
        require_extra("bench sweep", "distributed", "pyarrow", "matplotlib", "numpy")
    assert str(e.value) == ("bench sweep needs Dask, pyarrow and Matplotlib: "
                            "pip install 'hil-bench[cluster,report]'")
    with pytest.raises(ExtraMissing, match=r"needs pyarrow: pip install 'hil-bench\[data\]'$"):
        require_extra("hil_bench.load_recording", "pyarrow.parquet")
    with pytest.raises(ExtraMissing, match=r"needs pyarrow: pip install 'hil-bench\[cluster\]'$"):
        require_extra("a sweep", "pyarrow", extra="cluster")


def test_an_extra_installed_but_broken_says_so(monkeypatch):
    """A package that is there but fails its own import (a shared library, a version clash) is
    not called missing: the line says what its import said."""
    class Broken:
        def find_spec(self, name, path=None, target=None):
            if name == "matplotlib":
                raise ImportError("libfreetype.so.6: cannot open shared object file")

    monkeypatch.delitem(sys.modules, "matplotlib", raising=False)
    monkeypatch.setattr(sys, "meta_path", [Broken(), *sys.meta_path])
    with pytest.raises(ExtraMissing) as e:
        require_extra("bench sweep's plots", "matplotlib")
    assert str(e.value) == ("bench sweep's plots needs Matplotlib (installed, but: "
                            "libfreetype.so.6: cannot open shared object file): "
                            "pip install 'hil-bench[report]'")


#: a core-only install, in a subprocess: every extra's package fails to import; then each
#: command (CLI main() or an API call) runs in turn and its exit status and output are printed
CORE_ONLY = r"""
import contextlib, io, json, sys
BLOCKED = {"dask", "distributed", "pyarrow", "pandas", "matplotlib", "scipy", "foxglove"}
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, Block())
if __name__ == "__main__":
    import hil_bench
    import numpy as np
    from hil_bench.cli import main
    #: a 50 Hz tone sampled at 10 kHz, its times [s]
    t = np.arange(1000) * 1e-4
    tone = np.sin(2 * np.pi * 50.0 * t)
    for step in json.loads(sys.argv[1]):
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                if step[0] == "api":
                    rc = 0
                    print(eval(step[1], {"hil_bench": hil_bench, "t": t, "tone": tone}))
                else:
                    rc = main(step)
            except Exception as exc:
                import traceback
                rc = "raised"
                print(f"{type(exc).__name__}: {exc}", file=sys.stderr)
                traceback.print_exc()
        print(json.dumps({"step": step, "rc": rc, "out": out.getvalue(), "err": err.getvalue(),
                          "loaded": sorted(BLOCKED & {m.split(".")[0] for m in sys.modules})}),
              flush=True)
"""


@pytest.fixture(scope="module")
def core_only(tmp_path_factory):
    """Every command and API call of a core-only install, run once (one subprocess)."""
    tmp = tmp_path_factory.mktemp("core")
    examples = REPO / "examples" / "captures"
    steps = {
        "run": ["run", "gong_g2_500rpm", "--out", "g2.mcap", "--no-progress"],
        "check": ["check", "g2.mcap"],
        "replay": ["replay", "g2.mcap", "--out", "replayed.mcap"],
        "conformance": ["conformance", "--link", "stub"],
        "recover": ["recover", "g2.mcap", "--out", "recovered.mcap"],
        "layout": ["layout", "gong_g2_500rpm", "--out", "layout.json"],
        "scenarios": ["scenarios"],
        "claims": ["claims"],
        "api.run": ["api", "hil_bench.run('gong_g2_500rpm', out='api.mcap', overrides={"
                           "'scenario.duration_s': 0.3, 'metrics.window_s': [0.1, 0.3]})"
                           ".run.cycles_done"],
        "api.check": ["api", "hil_bench.check('g2.mcap').passed"],
        "signals": ["api", "hil_bench.signals.stays_within(tone, -1.0, 1.0, t=t)"],
        # the extras
        "load_recording": ["api", "hil_bench.load_recording('g2.mcap')"],
        "session": ["api", "hil_bench.Session('gong_g2_500rpm', out='session.mcap')"],
        "signals.frequency": ["api", "hil_bench.signals.frequency(tone, t=t)"],
        "export": ["export", "g2.mcap", "--out", "exported"],
        "export.csv": ["export", "g2.mcap", "--format", "csv", "--out", "exported"],
        "sweep": ["sweep", "observers_speed_load", "--out", "sweep"],
        "sweep.no_plots": ["sweep", "observers_speed_load", "--out", "sweep", "--no-plots"],
        "campaign": ["campaign", "g2_protection", "--out", "campaign"],
        "claims.run": ["claims", "--run", "--only", "G2", "--out", "claims"],
        "claims.run.link": ["claims", "--run", "--only", "G2", "--link", "sil", "--out",
                            "claims"],
        "live": ["run", "gong_g2_500rpm", "--live", "0", "--out", "live.mcap", "--no-progress"],
        "replay.daq": ["replay", str(examples / "example_daq.csv"), "--mapping",
                       str(examples / "example_daq.toml"), "--profile", "gong2020",
                       "--out", "daq.mcap"],
    }
    proc = subprocess.run([sys.executable, "-c", CORE_ONLY, json.dumps(list(steps.values()))],
                          capture_output=True, text=True, cwd=tmp, timeout=900)
    results = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    assert len(results) == len(steps), proc.stderr[-3000:]
    return tmp, dict(zip(steps, results))


CORE = ("run", "check", "replay", "conformance", "recover", "layout", "scenarios", "claims",
        "api.run", "api.check", "signals")


@pytest.mark.parametrize("step", CORE)
def test_the_core_runs_checks_and_replays_without_any_extra(core_only, step):
    tmp, results = core_only
    r = results[step]
    assert r["rc"] == 0, f"{r['step']}: {r['rc']}\n{r['err'][-3000:]}"
    assert r["loaded"] == []                     # and imported none of the extras' packages
    assert "Traceback" not in r["err"]


def test_what_the_core_commands_did(core_only):
    tmp, results = core_only
    assert "ran 15000/15000 cycles" in results["run"]["out"]
    assert re.search(r"(\d+) of \1 items pass", results["conformance"]["out"])
    assert results["api.run"]["out"].strip() == "3000"
    assert results["signals"]["out"].strip() == "(-1.0, 1.0)"
    for name in ("g2.mcap", "replayed.mcap", "recovered.mcap", "layout.json", "api.mcap"):
        assert (tmp / name).is_file(), name


#: each command that needs an extra: (the start of its one error line, the extra(s) it names)
NEEDS = {
    "load_recording": ("ExtraMissing: hil_bench.load_recording needs pandas", "data"),
    "session": ("ExtraMissing: hil_bench.Session needs pandas", "data"),
    "signals.frequency": ("ExtraMissing: signals.frequency needs SciPy", "analysis"),
    "export": ("error: bench export --format parquet needs pandas and pyarrow", "data"),
    "export.csv": ("error: bench export --format csv needs pandas", "data"),
    "sweep": ("error: bench sweep needs Dask, pyarrow, Matplotlib and pandas", "cluster,report"),
    "sweep.no_plots": ("error: bench sweep needs Dask and pyarrow", "cluster"),
    "campaign": ("error: bench campaign needs Dask", "cluster"),
    "claims.run": ("error: bench claims --run needs Dask and Matplotlib", "cluster,report"),
    "claims.run.link": ("error: bench claims --run needs Dask", "cluster"),
    "live": ("error: --live (the Foxglove live view) needs foxglove-sdk", "live"),
    "replay.daq": ("error: bench replay of a scope/DAQ CSV export", "analysis"),
}


@pytest.mark.parametrize("step", list(NEEDS))
def test_a_command_without_its_extra_says_which_to_install(core_only, step):
    tmp, results = core_only
    r = results[step]
    first, extra = NEEDS[step]
    api = r["step"][0] == "api"
    assert r["rc"] == ("raised" if api else 2), r["err"][-3000:]
    line = r["err"].splitlines()[0]
    assert line.startswith(first) and line.endswith(f": pip install 'hil-bench[{extra}]'"), line
    if not api:                                  # the API raises; the CLI prints one line
        assert r["err"].count("\n") == 1 and "Traceback" not in r["err"]
    assert r["loaded"] == []


def test_a_command_without_its_extra_writes_nothing(core_only):
    tmp, _ = core_only
    for name in ("exported", "sweep", "campaign", "claims", "live.mcap", "daq.mcap",
                 "session.mcap"):
        assert not (tmp / name).exists(), name
