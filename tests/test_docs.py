"""The docs are run (issue 30, item 9): every shell block of README.md, docs/*.md and
examples/*/README.md is either run here or says why not, and the figures the pages quote from a
command are what that command prints.

* ``test_every_shell_block_is_run_here_or_says_why_not``: every command of every shell block is
  under a marker (``# runs here``, ``# runs here as: <shortened variant>``, ``# not run here:
  <why>``: tests/doc_blocks.py), every variant is its command shortened only as
  ``doc_blocks.SHORTENINGS`` allows, and no command sits outside a fenced block. It lists each
  command that is not, with its page and line.
* ``test_the_block_runs_as_printed[<page>:<line>]``, one per block that runs here: its commands in
  order, in a fresh folder laid out as the checkout (``doc_blocks.scratch_folder``), each exiting
  as the page says (0, or ``# exits N``), its shown output matched line by line (timing figures
  aside), and the figures of ``FIGURES`` that quote it equal to what it printed. What a block
  needs that the page names but does not make is made first (``PLACEHOLDERS``, ``FOLDERS``): a
  recording for ``recordings/X.mcap``, the page's own test file for its ``pytest``, the example
  project. ``pip install <hil-bench>`` installs the wheel ``$HIL_WHEEL`` (``make test`` builds it)
  into a fresh virtual environment, its dependencies from this checkout's .venv, and the block's
  later commands run with that environment's ``bench``, ``python`` and ``pytest``.
  docs/real-drive.md's blocks run in tests/test_real_drive.py, with that page's checks.
* ``test_the_python_block_runs[<page>:<line>]``: a ``python`` block marked ``# runs here`` runs
  with the .venv's Python in a fresh folder, and each ``# -> figure`` comment is what its line
  gives (a number to the digits printed, text with ``...`` for what is left out).
"""
from __future__ import annotations

import ast
import contextlib
import io
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import pytest

from tests.doc_blocks import (NOT_RUN, REPO, RUNS_AS, RUNS_HERE, Block, Command, all_blocks,
                              fenced_blocks, loose_commands, output_matches, pages,
                              run_keeping_real_time, scratch_folder, strip_comment,
                              variant_problem)

BLOCKS = all_blocks()
#: pages whose blocks another test runs, with that page's own checks
OWN_TEST = {"docs/real-drive.md": "tests/test_real_drive.py"}
RUN_HERE = [b for b in BLOCKS if b.runs and b.doc not in OWN_TEST]


def _python_blocks() -> list[Block]:
    out = []
    for page in pages():
        for b in fenced_blocks(page):
            first = next((ln.strip() for ln in b.lines if ln.strip()), "")
            if b.lang == "python" and first == RUNS_HERE:
                out.append(b)
    return out


PYTHON_BLOCKS = _python_blocks()


def test_every_shell_block_is_run_here_or_says_why_not():
    problems = []
    for b in BLOCKS:
        if not b.commands:
            problems.append(f"{b.where}: a shell block without a command (a synopsis or output: "
                            f"```text)")
        for c in b.commands:
            if not c.marker:
                problems.append(f"{c.where}: `{strip_comment(c.text)}`: under no marker "
                                f"('{RUNS_HERE}', '{RUNS_AS} <variant>' or '{NOT_RUN} <why>')")
            elif c.marker == RUNS_AS and (why := variant_problem(c)):
                problems.append(f"{c.where}: {why}")
    for page in pages():
        for n, text in loose_commands(page):
            problems.append(f"{page.relative_to(REPO)}:{n}: `{text}` is outside a fenced block: "
                            f"fence it (```sh) and mark it")
    assert not problems, (f"{len(problems)} command(s) neither run nor marked:\n"
                          + "\n".join(problems))


def test_the_markers_are_read_as_written():
    """The marker rules on a block of each kind (a test of tests/doc_blocks.py itself)."""
    from tests.doc_blocks import _commands

    block = Block("x.md", 1, "sh", [
        "# runs here",
        ".venv/bin/bench scenarios            # a comment",
        "# runs here as: .venv/bin/bench claims --only G2 --run",
        ".venv/bin/bench claims --run",
        ".venv/bin/bench run gong_g2_500rpm --link serial:/dev/ttyUSB0@3000000 \\",
        "    --allow-slow-link   # exits 1: why",
        "# not run here: a drive",
        ".venv/bin/bench run x --link can",
    ])
    cmds = _commands(block)
    assert [(c.line, c.marker, c.status) for c in cmds] == [
        (3, RUNS_HERE, 0), (5, RUNS_AS, 0), (6, RUNS_HERE, 1), (9, NOT_RUN, 0)]
    assert cmds[1].to_run == ".venv/bin/bench claims --only G2 --run"
    assert variant_problem(cmds[1]) is None
    assert cmds[2].text.startswith(".venv/bin/bench run gong_g2_500rpm --link serial:/dev/ttyUSB0@"
                                   "3000000 --allow-slow-link")
    assert cmds[3].why == "a drive"
    bad = Command("x.md", 1, ".venv/bin/bench claims --run", marker=RUNS_AS,
                  why=".venv/bin/bench claims --only G2 --run --set plant.ts_s=0.001")
    assert "not `.venv/bin/bench claims --run` shortened" in variant_problem(bad)
    console = _commands(Block("x.md", 1, "console", [
        "# runs here", "$ make demo", "ran 15000/15000 cycles in 3.2 s (4700 cycles/s)", "..."]))
    assert console[0].output == ["ran 15000/15000 cycles in 3.2 s (4700 cycles/s)", "..."]
    assert output_matches(console[0].output, "ran 15000/15000 cycles in 1.05 s (14000 cycles/s)\n"
                                             "more\n") is None
    assert output_matches(console[0].output, "ran 1500/15000 cycles in 1.05 s (140 cycles/s)\n")


def test_a_real_time_run_the_host_lost_is_repeated_on_a_clean_slate(tmp_path, monkeypatch):
    """The repeat of a real-time run the host could not keep starts without the first attempt's
    recording (before, in tests/test_real_drive.py, it failed: "--out ...: file exists")."""
    from tests import doc_blocks

    seen = []

    def lost(cmd, cwd, env=None):
        seen.append(sorted(p.name for p in cwd.iterdir()))
        for name in ("rt.mcap", "rt.serial.bin", ".rt.mcap.partial"):
            (cwd / name).write_text("")
        return subprocess.CompletedProcess(cmd, 1, "real time: ...; lost rate 5.00e-02\n")

    (tmp_path / "rt_other.mcap").write_text("")     # another command's: kept
    monkeypatch.setattr(doc_blocks, "run_command", lost)
    with pytest.raises(pytest.skip.Exception, match="could not keep real time"):
        run_keeping_real_time(".venv/bin/bench run g2 --realtime --out rt.mcap", tmp_path)
    assert seen == [["rt_other.mcap"], ["rt_other.mcap"]]


def test_a_watchdog_end_is_the_hosts_only_if_it_does_not_repeat_at_the_same_cycle(tmp_path,
                                                                                 monkeypatch):
    """A stub the host stopped for 1 ms trips the watchdog with a lost rate far under 1 %: the run
    is repeated, and skipped when the second trips elsewhere; a trip at the same cycle twice is
    the loop's, returned to fail."""
    from tests import doc_blocks

    def tripped(*cycles):
        it = iter(cycles)

        def run(cmd, cwd, env=None):
            k = next(it)
            return subprocess.CompletedProcess(
                cmd, 1, f"run ended early: at cycle {k} (t = {k / 1e4:.4f} s): 10 consecutive "
                        f"periods without a DUTY in time: inverter disabled\nreal time: ...; "
                        f"lost rate 5.84e-03\n")
        return run

    cmd = ".venv/bin/bench run g2 --realtime"
    monkeypatch.setattr(doc_blocks, "run_command", tripped(1710, 4210))
    with pytest.raises(pytest.skip.Exception, match="watchdog ended it at cycle 1710 and 4210"):
        run_keeping_real_time(cmd, tmp_path)
    monkeypatch.setattr(doc_blocks, "run_command", tripped(1710, 1710))
    assert run_keeping_real_time(cmd, tmp_path).returncode == 1


# ---- what a block needs -----------------------------------------------------------------------

def _example_recording(dest: Path) -> None:
    dest.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(REPO / "examples" / "captures" / "example.mcap", dest)


def _damaged_recording(dest: Path) -> None:
    """The example recording cut short in the middle, as a run killed while writing leaves it."""
    data = (REPO / "examples" / "captures" / "example.mcap").read_bytes()
    dest.write_bytes(data[:len(data) // 2])


#: files the pages' commands name as placeholders, and how the test makes each before the block
PLACEHOLDERS: dict[str, Callable[[Path], None]] = {
    "recordings/X.mcap": _example_recording,      # "a recording": the example capture's run
    "DAMAGED.mcap": _damaged_recording,
}


def _page_test_file(doc: str) -> str:
    """The page's python block that is a pytest test file (it defines ``test_...``)."""
    for b in fenced_blocks(REPO / doc):
        if b.lang == "python" and any(ln.startswith("def test_") for ln in b.lines):
            return "\n".join(b.lines) + "\n"
    raise AssertionError(f"{doc}: no python block with a test for its pytest block to run")


def _api_project(work: Path) -> Path:
    """docs/api.md's pytest commands run in a project holding the page's test file."""
    project = work / "drive_tests"
    project.mkdir()
    (project / "test_drive.py").write_text(_page_test_file("docs/api.md"))
    return project


def _example_project(work: Path) -> Path:
    """examples/firmware_ci/README.md's commands run in a copy of the project; its team's own
    firmware build (``build/host/drive_fw``) is the bundled stub, built for the Linux port."""
    from hil_bench.loop.links.stub import stub_path

    project = work / "firmware_ci"
    shutil.copytree(REPO / "examples" / "firmware_ci", project, symlinks=False)
    (project / "build" / "host").mkdir(parents=True)
    shutil.copy2(stub_path(), project / "build" / "host" / "drive_fw")
    return project


#: pages whose commands run in a folder of their own (what "here" is for them)
FOLDERS: dict[str, Callable[[Path], Path]] = {
    "docs/api.md": _api_project,
    "examples/firmware_ci/README.md": _example_project,
}
#: the pages whose bare ``pytest`` needs that folder (elsewhere a block runs at the root)
PYTEST_PAGES = set(FOLDERS)


# ---- pip install: the wheel in a fresh environment ---------------------------------------------

PIP_INSTALL = re.compile(r"^pip install\s+(.*)$")
HIL_BENCH_SPEC = re.compile(r"hil[-_]bench")


def _install_the_wheel(env_dir: Path, names: list[str]) -> dict[str, str]:
    """``pip install <hil-bench> [pytest]`` as a user makes it, from ``$HIL_WHEEL``: a fresh
    virtual environment with the wheel installed by pip (its console scripts, its pytest11 entry
    point, no editable hook), the dependencies those of this checkout's .venv (on the path behind
    the environment's own site-packages: a .pth line, whose folder's own .pth files stay
    unread), so no package index is asked. The environment variables to run with it."""
    wheel = os.environ.get("HIL_WHEEL")
    if not wheel:
        pytest.skip("`pip install` of hil-bench runs with the wheel: set HIL_WHEEL to one "
                    "(`make wheel`; `make test` does both)")
    py = env_dir / "bin" / "python"
    if not py.exists():                            # (a second `pip install` of it: an extra)
        subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], check=True)
        subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q",
                        "--no-deps", "--no-index", "--disable-pip-version-check", wheel],
                       check=True, capture_output=True, timeout=600)
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()"
                                          "['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    Path(site, "_checkout_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    if any(n.split("[")[0].split(">")[0].split("=")[0] == "pytest" for n in names):
        script = env_dir / "bin" / "pytest"
        script.write_text(f"#!{py}\nimport sys\nfrom pytest import console_main\n"
                          f"sys.exit(console_main())\n")
        script.chmod(0o755)
    where = subprocess.run([str(py), "-c", "import hil_bench; print(hil_bench.__file__)"],
                           capture_output=True, text=True, cwd=env_dir).stdout.strip()
    assert where.startswith(site), f"hil_bench is imported from {where!r}, not the fresh {site}"
    path = os.environ.get("PATH", "").split(os.pathsep)
    path = [p for p in path if Path(p).resolve() != (REPO / ".venv" / "bin").resolve()]
    return {"PATH": os.pathsep.join([str(env_dir / "bin"), *path]), "VIRTUAL_ENV": str(env_dir),
            "HIL_STUB": "", "PYTHONPATH": ""}


# ---- figures the pages quote from a command -----------------------------------------------------

WORDS = {"two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8}


@dataclass
class Figure:
    """A figure a page quotes (``quote``: its first group) that a command prints (``command``
    matched on the command line that runs; ``printed``: the figure from its output)."""
    what: str
    page: str
    quote: str
    command: str
    printed: Callable[[str], str | None]

    def quoted(self) -> list[str]:
        text = " ".join((REPO / self.page).read_text().split())
        found = [m.group(1) for m in re.finditer(self.quote, text)]
        return [str(WORDS.get(f, f)) for f in found]


def _group(pattern: str, flags: int = 0) -> Callable[[str], str | None]:
    def printed(out: str) -> str | None:
        m = re.search(pattern, out, flags)
        return m.group(1) if m else None
    return printed


def _claims_listed(out: str) -> str:
    return str(len(re.findall(r"^[A-Z]\d+ {2}", out, re.M)))


def _divergence(out: str) -> str | None:
    m = re.search(r"first divergence at cycle (?:seq )?(\d+) .*?: (\w+) recorded", out)
    return f"{m.group(1)} ({m.group(2)})" if m else None


CAMPAIGN = r"bench campaign g2_protection\b"
EXAMPLE_TESTS = r"^pytest --junitxml"
FIGURES = [
    Figure("the papers' claims `bench claims` lists", "README.md", r"reproduce all (\d+)",
           r"bench claims$", _claims_listed),
    Figure("the papers' claims `bench claims` lists", "docs/claims.md", r"all (\d+) claims",
           r"bench claims$", _claims_listed),
    Figure("the bundled campaign's runs", "README.md", r"or a file\): (\d+) runs", CAMPAIGN,
           _group(r"^(\d+) runs, \d+ PASS", re.M)),
    Figure("the bundled campaign's runs", "docs/faults.md", r"or a file\): (\d+) runs", CAMPAIGN,
           _group(r"^(\d+) runs, \d+ PASS", re.M)),
    Figure("the bundled campaign's PASS", "docs/faults.md", r"\*\*(\d+) PASS", CAMPAIGN,
           _group(r"^\d+ runs, (\d+) PASS", re.M)),
    Figure("the example project's tests", "examples/firmware_ci/README.md",
           r"`pytest` runs the (\w+) tests", EXAMPLE_TESTS, _group(r"\b(\d+) passed")),
    Figure("the example project's tests", "docs/api.md", r"its own pyproject.toml and (\w+) tests",
           EXAMPLE_TESTS, _group(r"\b(\d+) passed")),
    Figure("the controller replay's first divergence", "README.md",
           r"first divergence at cycle (\d+ \(\w+\))",
           r"replay example\.serial\.bin --mode controller",
           _divergence),
]


def _figures_of(cmd: str, doc: str) -> list[Figure]:
    return [f for f in FIGURES if re.search(f.command, strip_comment(cmd).replace("../../", ""))
            and (f.command != EXAMPLE_TESTS or doc == "examples/firmware_ci/README.md")]


def test_every_figure_is_quoted_and_its_command_runs_here():
    """A figure the page no longer quotes, or whose command no block runs, checks nothing."""
    runs = [(b.doc, c.to_run) for b in RUN_HERE for c in b.commands if c.runs]
    for f in FIGURES:
        assert f.quoted(), f"{f.page}: no `{f.quote}` ({f.what}) any more: update FIGURES"
        assert any(f in _figures_of(cmd, doc) for doc, cmd in runs), \
            f"{f.what}: no block that runs here runs `{f.command}`"


# ---- running a block --------------------------------------------------------------------------

def _needs(block: Block) -> str | None:
    text = " ".join(c.to_run for c in block.commands if c.runs)
    if "pil-qemu" in text or "cortex_m" in text:
        missing = [t for t in ("arm-none-eabi-gcc", "qemu-system-arm") if shutil.which(t) is None]
        if missing and os.environ.get("HIL_REQUIRE_CORTEX_M") != "1":
            return (f"{', '.join(missing)} not installed (apt-get install gcc-arm-none-eabi "
                    f"libnewlib-arm-none-eabi qemu-system-arm)")
    return None


@pytest.mark.parametrize("block", RUN_HERE, ids=lambda b: b.where)
def test_the_block_runs_as_printed(block, tmp_path):
    why = _needs(block)
    if why:
        pytest.skip(why)
    work = scratch_folder(tmp_path / "work")
    cwd, env = work, {}
    if block.doc in FOLDERS and any(re.match(r"pytest\b|pip ", c.text) for c in block.commands):
        cwd = FOLDERS[block.doc](work)
    text = " ".join(c.to_run for c in block.commands)
    for name, make in PLACEHOLDERS.items():
        if name in text:
            make(cwd / name)
    for c in block.commands:
        cmd = strip_comment(c.to_run)
        if c.runs and cmd.startswith("cd "):
            cwd = cwd / shlex.split(cmd)[1]
            continue
        if not c.runs:
            continue
        pip = PIP_INSTALL.match(cmd)
        if pip and HIL_BENCH_SPEC.search(pip.group(1)):
            env.update(_install_the_wheel(tmp_path / "env", shlex.split(pip.group(1))))
            continue
        proc = run_keeping_real_time(c.to_run, cwd, env)
        said = proc.stdout
        assert proc.returncode == c.status, (f"{c.where}: `{c.to_run}` exited {proc.returncode}, "
                                             f"the page says {c.status}\n{said[-4000:]}")
        if c.output:
            wrong = output_matches(c.output, said)
            assert wrong is None, (f"{c.where}: `{c.to_run}` does not print what the page shows: "
                                   f"{wrong}\n{said[-4000:]}")
        for f in _figures_of(c.to_run, block.doc):
            printed = f.printed(said)
            assert printed is not None, (f"{c.where}: `{c.to_run}` printed no {f.what}\n"
                                         f"{said[-3000:]}")
            assert set(f.quoted()) == {printed}, (f"{f.page}: {f.what}: the page says "
                                                  f"{f.quoted()}, `{c.to_run}` prints {printed}")


# ---- python blocks and their figures ----------------------------------------------------------

FIGURE_COMMENT = re.compile(r"#\s*->\s*(.+)$")


def _matches_figure(value, said: str, shown: str) -> str | None:
    """Whether a line's value (``said``: what it printed, for a print call) is the figure shown:
    numbers to the digits shown (half a unit of the last digit), else the text with ``...`` for
    what is left out."""
    numbers = re.findall(r"-?\d+(?:\.\d+)?", shown.split("(")[0] if not shown.startswith("(")
                         else shown[:shown.index(")") + 1])
    if isinstance(value, (int, float)) or (isinstance(value, tuple) and value
                                           and all(isinstance(v, (int, float)) for v in value)):
        got = list(value) if isinstance(value, tuple) else [value]
        if len(numbers) != len(got):
            return f"shows {numbers}, the line gives {got}"
        for n, g in zip(numbers, got):
            digits = len(n.split(".")[1]) if "." in n else 0
            if abs(float(n) - float(g)) > 0.5 * 10 ** -digits + 1e-12:
                return f"shows {n}, the line gives {g!r}"
        return None
    return output_matches([shown], said)


#: a failure a page shows (a ```text block starting ``<Exception>: ``) and the call of its worked
#: example that raises it: (page, the call as the page quotes it, evaluated after the python block
#: that defines its names)
FAILURES = [("docs/api.md", "signals.settles(step.speed_rpm, 800, band=8, within_s=0.15)")]


def _shown_failure(doc: str, call: str, namespace: dict) -> str | None:
    """What is wrong with the failure the page shows for ``call`` (None: it is what it raises)."""
    text = (REPO / doc).read_text()
    assert f"`{call}`" in text, f"{doc}: the call of its shown failure, `{call}`, is not quoted"
    shown = [b for b in fenced_blocks(REPO / doc)
             if b.lang == "text" and re.match(r"\w+: ", b.lines[0] if b.lines else "")]
    assert len(shown) == 1, f"{doc}: {len(shown)} shown failures, FAILURES has one"
    try:
        eval(call, namespace)
    except Exception as exc:  # noqa: BLE001 - the page shows what it raises
        said = f"{type(exc).__name__}: {exc}"
    else:
        return f"`{call}` raised nothing"
    page = " ".join(" ".join(shown[0].lines).split())
    if page == " ".join(said.split()):
        return None
    return f"the page shows {page!r}, it raises {said!r}"


@pytest.mark.parametrize("block", PYTHON_BLOCKS, ids=lambda b: b.where)
def test_the_python_block_runs(block, tmp_path, monkeypatch):
    work = scratch_folder(tmp_path / "work")
    monkeypatch.chdir(work)
    source = "\n".join(block.lines) + "\n"
    figures: dict[int, tuple[str, object, str]] = {}

    def figure(line: int, shown: str, value_or_call):
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            value = value_or_call()
        figures[line] = (shown, value, out.getvalue())
        sys.stdout.write(out.getvalue())
        return value

    tree = ast.parse(source)
    lines = source.splitlines()

    class Wrap(ast.NodeTransformer):
        def visit_Expr(self, node):
            m = FIGURE_COMMENT.search(lines[node.end_lineno - 1])
            if not m:
                return node
            call = ast.Call(ast.Name("_figure", ast.Load()),
                            [ast.Constant(node.end_lineno), ast.Constant(m.group(1).strip()),
                             ast.Lambda(ast.arguments([], [], None, [], [], None, []), node.value)],
                            [])
            return ast.copy_location(ast.Expr(call), node)

    tree = ast.fix_missing_locations(Wrap().visit(tree))
    namespace = {"_figure": figure, "__name__": "__doc_block__"}
    exec(compile(tree, f"{block.doc}:{block.line}", "exec"), namespace)
    shown = [n for n, ln in enumerate(lines, 1) if FIGURE_COMMENT.search(ln)]
    missing = [block.line + n for n in shown if n not in figures]
    assert not missing, f"{block.doc}: the figures at lines {missing} were not reached"
    wrong = []
    for n, (fig, value, said) in sorted(figures.items()):
        why = _matches_figure(value, said, fig)
        if why:
            wrong.append(f"{block.doc}:{block.line + n}: `{lines[n - 1].strip()}`: {why}")
    for doc, call in FAILURES:
        names = set(re.findall(r"\b([a-z_]\w*)\.", call))
        if doc == block.doc and names <= set(namespace):
            why = _shown_failure(doc, call, namespace)
            if why:
                wrong.append(f"{doc}: {why}")
    assert not wrong, "\n".join(wrong)


# ---- docs/api.md's figures of a whole G2 recording ----------------------------------------------

#: how far a size the page quotes may be from what the command gives today (pandas', pyarrow's and
#: zstd's versions move them a little; a figure that drifted further is stale)
SIZE_TOLERANCE = 0.10
API_FIGURES = {
    "cycles": r"A whole 1\.5 s G2 recording \(([\d ]+) cycles,",
    "file_mb": r"G2 recording \([\d ]+ cycles, ([\d.]+) MB\)",
    "frames_mb": r"into ([\d.]+) MB of DataFrames",
    "link_frames_mb": r"MB of DataFrames, ([\d.]+) MB of them the",
    "frames": r"MB of them the ([\d ]+) decoded frames",
    "parquet_mb": r"([\d.]+) MB of Parquet in",
    "parquet_files": r"MB of Parquet in (\d+) files",
    "csv_mb": r"\(([\d.]+) MB as CSV\)",
}


def test_the_figures_of_a_whole_g2_recording_in_api_md(tmp_path):
    """docs/api.md's sizes and counts of the whole G2 recording, its DataFrames and its export:
    counts exactly, sizes within SIZE_TOLERANCE (MB = 10^6 bytes)."""
    import hil_bench

    text = " ".join((REPO / "docs" / "api.md").read_text().split())
    quoted = {}
    for key, pattern in API_FIGURES.items():
        m = re.search(pattern, text)
        assert m, f"docs/api.md: no {key} figure (`{pattern}`): update API_FIGURES"
        quoted[key] = float(m.group(1).replace(" ", ""))
    result = hil_bench.run("gong_g2_500rpm", out=tmp_path / "g2.mcap")
    rec = hil_bench.load_recording(result.recording)
    got = {"cycles": result.integrity.cycles_done,
           "file_mb": result.recording.stat().st_size / 1e6,
           "frames_mb": sum(df.memory_usage(deep=True).sum() for _, df in rec.items()) / 1e6,
           "link_frames_mb": rec["/link/frames"].memory_usage(deep=True).sum() / 1e6,
           "frames": len(rec["/link/frames"])}
    for fmt, folder in (("parquet", tmp_path / "pq"), ("csv", tmp_path / "csv")):
        proc = subprocess.run([sys.executable, "-m", "hil_bench", "export", str(result.recording),
                               "--format", fmt, "--out", str(folder)], capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        files = sorted(folder.glob(f"*.{fmt}"))
        got[f"{fmt}_mb"] = sum(f.stat().st_size for f in files) / 1e6
        if fmt == "parquet":
            got["parquet_files"] = len(files)
    # the frames on the wire are the run's frames exactly when no cycle was re-sent; a busy host
    # that re-sends a late cycle adds its frames (the rows stay the same: issue 26)
    resent = int(rec["/link/stats"]["retries"].iloc[-1])
    if resent and got["frames"] > quoted["frames"]:
        got["frames"] = quoted["frames"]
    wrong = []
    for key, value in quoted.items():
        exact = key in ("cycles", "frames", "parquet_files")
        if (value != got[key]) if exact else abs(value - got[key]) > SIZE_TOLERANCE * got[key]:
            wrong.append(f"{key}: the page says {value:g}, today {got[key]:.4g}")
    assert not wrong, "docs/api.md: " + "; ".join(wrong)


# ---- README's figures that no block prints --------------------------------------------------------

def test_the_example_captures_are_the_size_the_readme_says():
    quoted = re.search(r"one 0\.3 s bench run in each format, (\d+) kB together",
                       " ".join((REPO / "README.md").read_text().split()))
    assert quoted, "README.md: the example captures' size is not quoted any more"
    size_kb = sum(p.stat().st_size for p in (REPO / "examples" / "captures").glob("example*")) / 1e3
    assert round(size_kb) == int(quoted.group(1)), f"README.md says {quoted.group(1)} kB, {size_kb:.1f}"


def test_the_claims_runs_the_readme_counts(monkeypatch, tmp_path):
    """`bench claims --run` prints how many runs it starts before it starts them ("N runs (J in
    parallel) for claims ..."): README's count is that one, taken from the command's own code with
    the runs themselves left out (the residual study adds runs at its flips after those)."""
    from hil_bench.papers import report

    class Planned(Exception):
        pass

    def execute(runs, *args, **kwargs):
        raise Planned(len(runs))

    monkeypatch.setattr(report, "execute", execute)
    with pytest.raises(Planned) as planned:
        report.run_report(tmp_path / "claims")
    quoted = re.search(r"`\.venv/bin/bench claims --run` \(([\d ]+) runs",
                       " ".join((REPO / "README.md").read_text().split()))
    assert quoted, "README.md: the count of `bench claims --run`'s runs is not quoted any more"
    assert int(quoted.group(1).replace(" ", "")) == planned.value.args[0]
