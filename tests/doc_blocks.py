"""The shell blocks of the docs, the commands in them and what their markers say; and how a
test runs one of those commands here (tests/test_docs.py: every page; tests/test_real_drive.py:
docs/real-drive.md, with the checks of that page).

A **shell block** is a fenced block of README.md, docs/*.md or examples/*/README.md whose language
is ``sh``, ``bash``, ``shell`` or ``console``, or an untagged one whose first line is a command
(``$ ...``, ``.venv/bin/...``, ``bench ...``, ``pip ...``, ...); a ``text`` block is never one (a
synopsis, an output). A command outside any
fence (an indented code block) is reported too: fence it, so it is run or marked.

A **marker** is a comment line of its own in a block:

``# runs here``
    the commands after it run as printed, in a fresh temporary folder (below);
``# runs here as: COMMAND``
    the one command after it runs as COMMAND, a shortened variant of it: the same command with
    only the changes of ``SHORTENINGS`` (one claim instead of all, fewer repeats, a free port...),
    which the test checks;
``# not run here: WHY``
    the commands after it are not run, for WHY (a drive, an adapter, a viewer, root, minutes).

A marker holds for the commands after it until the next marker (``runs here as`` for one command
only); the first line of a block is its marker. A command line may end in ``# exits N: why``: the
status it exits with (else 0), or in ``# -> TEXT``: a line it prints (matched as below). In a
``console`` block each ``$ COMMAND`` line is followed by the
output the page shows: the test compares the command's output with it line by line, ``...`` for
lines or text left out, and every timing figure (a number of s, ms, us, cycles/s, MB, ...) taken
as any number (``output_matches``).

**Where a command runs**: a fresh temporary folder laid out as the checkout, each tracked file
a symbolic link to the checkout's and ``.venv`` a link (``scratch_folder``), so
``.venv/bin/bench`` is the checkout's and relative paths (``bench/scenarios/...``,
``examples/captures``) are there, and what a command writes (recordings, reports, builds) lands
in the folder, never in the checkout. ``bench``, ``python`` and ``pytest`` without a path are the
checkout's .venv's. A device the page means a drive on is a pty with the C stub on the other end
(``DEVICE``: ``/dev/ttyUSB0`` in a ``serial:`` link is ``hil_stub --port fd:N``, ``/dev/ttyACM0``
in a ``can:slcan:`` link is ``hil_stub --slcan fd:N``; tests/drive_on_pty.py). A ``cd`` moves the
commands after it.
"""
from __future__ import annotations

import glob
import os
import re
import shlex
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

RUNS_HERE = "# runs here"
RUNS_AS = "# runs here as:"
NOT_RUN = "# not run here:"
SHELL_LANGS = ("sh", "bash", "shell", "console")
#: an untagged block whose first line starts like this is a shell block
COMMAND_START = re.compile(r"^(\$ |\S*\.venv/bin/|bench [a-z-]+\b|pip |python3? |pytest\b|make |"
                           r"cd |dask |tests/\S+\.sh|tools/\S+|cmake |ctest |apt-get |sudo )")
#: a command the page expects to fail says so: ``... # exits 1: why``
EXITS = re.compile(r"#\s*exits (\d+)\b")
#: a line the command prints, shown in its trailing comment: ``bench --version   # -> bench ...``
SHOWN = re.compile(r"\s#\s*->\s*(.+)$")
#: the device names the pages use, and the stub that stands in for each kind of link
DEVICE = re.compile(r"(serial|can:slcan):(/dev/tty(?:USB|ACM)\d+)")

#: What a ``# runs here as:`` variant may change in its command, and why each is a shortening:
#: (what, the option and its value as one regular expression over the command's words). The
#: variant with these removed must be the command with these removed, word for word.
SHORTENINGS = (
    ("one claim (or a few) instead of all 19", r"--only [\w,]+"),
    ("no study beyond the papers", r"--no-beyond"),
    ("the coarse grid of the studies and sweeps", r"--quick"),
    ("a shorter run: less plant time, or fewer repeats", r"--set scenario\.duration_s=[\d.]+|"
                                                         r"--set metrics\.window_s=\[[\d., ]+\]|"
                                                         r"--(?:runs|repeats|n) \d+"),
    ("a free port instead of the default one (tests run side by side)", r"--live(?: 0)?"),
    ("make's build step left out: the checkout the tests run in is built", r"-o build"),
    ("no progress bar (a log, not a terminal)", r"--no-progress"),
)


@dataclass
class Command:
    doc: str                     # the page, relative to the checkout
    line: int                    # the line of its first line in the page (1-based)
    text: str                    # as printed, continuation lines joined (its trailing comment kept)
    status: int = 0              # the exit status the page expects
    marker: str = ""             # RUNS_HERE, RUNS_AS, NOT_RUN or "" (none)
    why: str = ""                # NOT_RUN: the reason; RUNS_AS: the variant
    output: list[str] = field(default_factory=list)   # console blocks: the lines shown after it

    @property
    def where(self) -> str:
        return f"{self.doc}:{self.line}"

    @property
    def runs(self) -> bool:
        return self.marker in (RUNS_HERE, RUNS_AS)

    @property
    def to_run(self) -> str:
        """The command line the test runs: the variant, or the command as printed."""
        return self.why if self.marker == RUNS_AS else self.text


@dataclass
class Block:
    doc: str
    line: int                    # its opening fence (1-based)
    lang: str
    lines: list[str]
    commands: list[Command] = field(default_factory=list)

    @property
    def where(self) -> str:
        return f"{self.doc}:{self.line}"

    @property
    def marker(self) -> str:
        """The block's own marker: its first line's."""
        first = next((ln.strip() for ln in self.lines if ln.strip()), "")
        return _marker(first)[0]

    @property
    def runs(self) -> bool:
        return any(c.runs for c in self.commands)


def pages() -> list[Path]:
    """README.md, docs/*.md, examples/*/README.md."""
    return [REPO / "README.md", *sorted((REPO / "docs").glob("*.md")),
            *sorted((REPO / "examples").glob("*/README.md"))]


def _marker(stripped: str) -> tuple[str, str]:
    """(marker, its text) of a comment line, ("", "") if it is none; a marker without its reason
    or variant is none."""
    for m in (RUNS_AS, NOT_RUN):
        if stripped.startswith(m):
            rest = stripped[len(m):].strip()
            return (m, rest) if rest else ("", "")
    if stripped == RUNS_HERE:
        return RUNS_HERE, ""
    return "", ""


def strip_comment(cmd: str) -> str:
    """The command without its trailing shell comment (a ``#`` that starts a word, unquoted)."""
    quote, prev = "", " "
    for i, ch in enumerate(cmd):
        if quote:
            if ch == quote:
                quote = ""
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and prev.isspace():
            return cmd[:i].rstrip()
        prev = ch
    return cmd.rstrip()


def _is_shell(lang: str, lines: list[str]) -> bool:
    if lang in SHELL_LANGS:
        return True
    if lang:                        # ``text``: a synopsis or an output, by its author's word
        return False
    first = next((ln.strip() for ln in lines if ln.strip()), "")
    return bool(COMMAND_START.match(first))


def _commands(block: Block) -> list[Command]:
    console = block.lang == "console" or any(ln.lstrip().startswith("$ ") for ln in block.lines)
    out: list[Command] = []
    marker, why = "", ""            # the marker in force
    once: tuple[str, str] | None = None
    parts: list[str] = []
    start = 0
    for n, raw in enumerate(block.lines, block.line + 1):
        stripped = raw.strip()
        if parts:                                           # a continuation line
            parts.append(stripped.removesuffix("\\").strip())
            if not stripped.endswith("\\"):
                out.append(_command(block, start, " ".join(parts), *(once or (marker, why))))
                once, parts = None, []
            continue
        if console and not stripped.startswith("$ "):
            if out and not stripped.startswith("#"):
                out[-1].output.append(raw)
            elif stripped.startswith("#"):
                m = _marker(stripped)
                if m[0] == RUNS_AS:
                    once = m
                elif m[0]:
                    marker, why = m
            continue
        if not stripped:
            continue
        if stripped.startswith("#"):
            m = _marker(stripped)
            if m[0] == RUNS_AS:
                once = m
            elif m[0]:
                marker, why = m
            continue
        text = stripped[2:] if console else stripped
        if text.endswith("\\"):
            parts, start = [text.removesuffix("\\").strip()], n
            continue
        out.append(_command(block, n, text, *(once or (marker, why))))
        once = None
    return out


def _command(block: Block, line: int, text: str, marker: str, why: str) -> Command:
    m = EXITS.search(text)
    shown = SHOWN.search(text)
    return Command(block.doc, line, text, int(m.group(1)) if m else 0, marker, why,
                   [shown.group(1)] if shown else [])


def fenced_blocks(path: Path) -> list[Block]:
    """Every fenced block of a page, whatever its language (fences may be indented, inside a
    list item; the block's lines without that indent)."""
    doc = path.relative_to(REPO).as_posix()
    blocks, current, indent = [], None, 0
    for n, raw in enumerate(path.read_text().splitlines(), 1):
        stripped = raw.strip()
        if current is None:
            if stripped.startswith("```"):
                current = Block(doc, n, stripped[3:].strip(), [])
                indent = len(raw) - len(raw.lstrip())
            continue
        if stripped == "```":
            blocks.append(current)
            current = None
            continue
        current.lines.append(raw[indent:] if raw[:indent].strip() == "" else raw)
    assert current is None, f"{doc}:{current.line}: a fenced block is not closed"
    return blocks


def shell_blocks(path: Path) -> list[Block]:
    """Every shell block of a page, with its commands and their markers."""
    shell = [b for b in fenced_blocks(path) if _is_shell(b.lang, b.lines)]
    for b in shell:
        b.commands = _commands(b)
    return shell


def loose_commands(path: Path) -> list[tuple[int, str]]:
    """Command lines outside any fenced block (an indented code block): (line, text)."""
    doc_lines = path.read_text().splitlines()
    inside, fenced = set(), False
    for n, raw in enumerate(doc_lines, 1):
        if raw.strip().startswith("```"):
            fenced = not fenced
            inside.add(n)
        elif fenced:
            inside.add(n)
    loose = []
    for n, raw in enumerate(doc_lines, 1):
        if n in inside or not raw.startswith("    "):
            continue
        prev = doc_lines[n - 2] if n > 1 else ""
        indented_code = not prev.strip() or prev.startswith("    ")
        listed = raw.lstrip().startswith(("* ", "- "))
        if indented_code and COMMAND_START.match(raw.strip()) and not listed:
            loose.append((n, raw.strip()))
    return loose


# ---- the variant of a ``# runs here as`` ------------------------------------------------------

def _without_shortenings(cmd: str) -> tuple[str, list[str]]:
    """The command's words with every SHORTENINGS change taken out, and what was taken out."""
    words = " ".join(shlex.split(strip_comment(cmd)))
    found = []
    for what, pattern in SHORTENINGS:
        words, n = re.subn(rf"(?<!\S)(?:{pattern})(?!\S)", " ", words)
        if n:
            found.append(what)
    return " ".join(words.split()), found


def variant_problem(cmd: Command) -> str | None:
    """Why a ``# runs here as`` variant is not its command shortened (None: it is)."""
    printed, _ = _without_shortenings(cmd.text)
    variant, found = _without_shortenings(cmd.why)
    if printed != variant:
        return (f"`{cmd.why}` is not `{strip_comment(cmd.text)}` shortened: with the shortenings "
                f"taken out they read `{variant}` and `{printed}`")
    if not found or strip_comment(cmd.text) == strip_comment(cmd.why):
        return f"`{cmd.why}` is the command itself: say `{RUNS_HERE}`"
    return None


# ---- the output a console block shows ---------------------------------------------------------

#: a timing figure in shown output: any number before a unit of time, rate or size
TIMING = re.compile(r"\d[\d.,]*(?=\s?(?:s|ms|us|µs|min|cycles/s|runs/min|MB|kB|KB|GB|kbytes)\b)"
                    r"|(?<=\s)\d+:\d+(?:\.\d+)?|(?<=: )\d[\d.]*(?=$)")


def _line_pattern(shown: str) -> re.Pattern:
    """A shown line as a pattern: ``...`` any text, a timing figure any number, a run of spaces
    any run of spaces (rich pads its tables to what they hold)."""
    out, pos = [], 0
    text = " ".join(shown.split())
    for m in re.finditer(r"\.\.\.|" + TIMING.pattern, text):
        out.append(re.escape(text[pos:m.start()]))
        out.append(".*?" if m.group() == "..." else r"[\d.,:]+")
        pos = m.end()
    out.append(re.escape(text[pos:]))
    return re.compile("".join(out).replace(r"\ ", r"\s*") + r"\s*$")


def output_matches(shown: list[str], said: str) -> str | None:
    """Whether the command's output has the shown lines, in order (the first anywhere; then a
    line that is ``...`` alone: any lines in between, otherwise each shown line is the next line
    of output); None if it does, else what was not found."""
    lines = [" ".join(ln.split()) for ln in said.splitlines()]
    shown = [s for s in shown if s.strip() and not s.strip().startswith("# ")]
    i, gap = 0, True
    for s in shown:
        if s.strip() == "...":
            gap = True
            continue
        pat = _line_pattern(s)
        while i < len(lines) and not pat.match(lines[i]):
            if not gap:
                return f"expected {s.strip()!r}, got {lines[i]!r}"
            i += 1
        if i == len(lines):
            return f"not in the output: {s.strip()!r}"
        i, gap = i + 1, False
    return None


# ---- running one command here -----------------------------------------------------------------

#: what is not a tracked file but a command needs: linked as a whole (nothing writes into it)
LINKED_WHOLE = (".venv",)


def _tracked_files() -> list[str]:
    """The checkout's files, as git tracks them (or every file outside the build folders)."""
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True,
                             check=True).stdout.decode()
        return [p for p in out.split("\0") if p]
    except (OSError, subprocess.CalledProcessError):
        skip = {".git", ".venv", "build", "build-asan", "dist", "recordings", "reports"}
        return [p.relative_to(REPO).as_posix() for p in REPO.rglob("*")
                if p.is_file() and not skip & set(p.relative_to(REPO).parts)]


def scratch_folder(tmp_path: Path) -> Path:
    """A fresh folder that looks like the checkout's root to a page's commands: its folders made
    anew, each tracked file in them a symbolic link to the checkout's, ``.venv`` a link. What a
    command writes lands in the folder (a file the bench replaces is written aside and renamed
    over the link, never through it), so the checkout is never written and each test starts
    without recordings, reports or builds."""
    for rel in _tracked_files():
        dest = tmp_path / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.symlink_to(REPO / rel)
    for name in LINKED_WHOLE:
        if (REPO / name).exists():
            (tmp_path / name).symlink_to(REPO / name)
    return tmp_path


def _stub_args(cmd: str) -> tuple[str, ...]:
    """A real-time run's stub as the bench would start its own (docs/realtime.md): SCHED_FIFO, on
    the first CPU (the engine takes the last); a drive has a CPU of its own."""
    if "--realtime" not in cmd:
        return ()
    cpus = sorted(os.sched_getaffinity(0))
    return ("--rt-priority", "70") + (("--cpu", str(cpus[0])) if len(cpus) > 1 else ())


#: a real-time run that ended early after losing more than this fraction of its periods (missed
#: DUTY or periods the bench itself lost: the "lost rate" it prints) was ended by the host, not by
#: the loop: the watchdog, or the drive tripping on duties held too long (tests/test_realtime.py,
#: LOST_PERIODS_LIMIT: on a shared VM the hypervisor stops the guest for milliseconds at a time)
LOST_PERIODS_LIMIT = 0.01
LOST_RATE = re.compile(r"lost rate ([0-9.e+-]+)")
#: the watchdog's end: N consecutive periods without a DUTY, whatever the run's lost rate (a
#: stub the host stopped for 1 ms at 10 kHz trips it)
WATCHDOG_END = re.compile(r"at cycle (\d+) \(t = [^)]*\): \d+ consecutive periods without a DUTY")


def host_lost_real_time(cmd: str, proc: subprocess.CompletedProcess) -> bool:
    """A real-time run that ended early with more than LOST_PERIODS_LIMIT of its periods lost,
    or by the watchdog."""
    if " --realtime" not in cmd or proc.returncode == 0:
        return False
    rates = [float(r) for r in LOST_RATE.findall(" ".join(proc.stdout.split()))]
    return (bool(rates) and max(rates) > LOST_PERIODS_LIMIT) or watchdog_cycle(proc) is not None


def watchdog_cycle(proc: subprocess.CompletedProcess) -> int | None:
    """The cycle at which the watchdog ended the run, if it did."""
    m = WATCHDOG_END.search(" ".join(proc.stdout.split()))
    return int(m.group(1)) if m else None


def run_command(cmd: str, cwd: Path, env: dict[str, str] | None = None,
                timeout_s: float = 900) -> subprocess.CompletedProcess:
    """One command of a page with bash in ``cwd``, its device replaced by a pty with the stub on
    it; rich's tables at 250 columns (a log's width, nothing wrapped). Its stdout and stderr in
    one stream, in the order a terminal shows them (``.stdout``)."""
    from tests.drive_on_pty import StubOnPty

    env = {**os.environ, "COLUMNS": "250",
           "PATH": f"{REPO / '.venv' / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}",
           **(env or {})}
    m = DEVICE.search(cmd)
    if m is None:
        return subprocess.run(["bash", "-c", cmd], cwd=cwd, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, env=env, timeout=timeout_s)
    mode = "serial" if m.group(1) == "serial" else "slcan"
    with StubOnPty(mode, _stub_args(cmd)) as drive:
        return subprocess.run(["bash", "-c", cmd.replace(m.group(2), drive.path)], cwd=cwd,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                              timeout=timeout_s)


def run_keeping_real_time(cmd: str, cwd: Path, env: dict[str, str] | None = None
                          ) -> subprocess.CompletedProcess:
    """``run_command``; a real-time run the host could not keep (``host_lost_real_time``) is
    repeated once, its first attempt's recording removed (``--out`` and its side files), then
    skipped with its figures: the machine, not the command. A watchdog end at the same cycle
    both times is the loop's (a host's stalls do not repeat to the period): returned, to fail."""
    import pytest

    proc = run_command(cmd, cwd, env)
    if not host_lost_real_time(cmd, proc):
        return proc
    out = re.search(r"--out\s+(\S+)", strip_comment(cmd))
    if out:                        # X.mcap and its side files X.serial.bin, X.log, .X.mcap.*
        first = cwd / out.group(1)
        stem = glob.escape(first.name.removesuffix(".mcap"))
        for pattern in (f"{stem}.*", f".{glob.escape(first.name)}.*"):
            for path in first.parent.glob(pattern):
                path.unlink()
    first_trip = watchdog_cycle(proc)
    proc = run_command(cmd, cwd, env)
    if first_trip is not None and watchdog_cycle(proc) == first_trip:
        return proc              # the same cycle twice: the loop tripped, not a host's stall
    if host_lost_real_time(cmd, proc):
        figures = [ln for ln in proc.stdout.splitlines() if "real time:" in ln]
        trips = [str(c) for c in (first_trip, watchdog_cycle(proc)) if c is not None]
        pytest.skip(f"this machine could not keep real time (twice the run lost more than "
                    f"{LOST_PERIODS_LIMIT:.0%} of its periods or the watchdog ended it"
                    f"{' at cycle ' + ' and '.join(trips) if trips else ''}): "
                    f"{' '.join(figures[:1])}")
    return proc


def all_blocks() -> list[Block]:
    return [b for p in pages() for b in shell_blocks(p)]
