"""The Python API: run a scenario, check a recording, read a recording into tables (docs/api.md).

    import hil_bench
    result = hil_bench.run("gong_g2_500rpm", overrides={"controller.params.SMO_K_V": 30})
    print(result.claims)                       # paper vs measured, one row per claim quantity
    result.assert_claims()                     # AssertionError with that table unless all pass
    rec = hil_bench.load_recording(result.recording)
    rec["/plant/state"].speed_rpm.plot()        # indexed by t_s, the plant's time in s

``run`` is ``bench run`` (the same runner, recording and check); ``check`` is ``bench check``;
both return a :class:`Result`. ``load_recording`` gives each channel as a pandas DataFrame.
Everything heavy is imported when called: ``import hil_bench`` stays cheap.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hil_bench.errors import ArgumentError, BenchError, NoSuchFile, OutputIsInput, did_you_mean

if TYPE_CHECKING:
    import pandas

    from hil_bench.papers.check import CheckReport
    from hil_bench.record.fault_outcomes import FaultOutcome
    from hil_bench.scenario import Scenario

__all__ = ["run", "check", "load_recording", "Result", "RunInfo", "ClaimVerdict", "ClaimTable",
           "Integrity", "RecordingData", "ClaimsNotReproduced", "RunFailed", "BenchError",
           "ArgumentError", "NoSuchFile", "OutputIsInput"]

#: verdicts that count as reproduced (COMPARED: a figure the paper gives without a rule)
PASSING = ("PASS", "COMPARED")


class RunFailed(BenchError, RuntimeError):
    """The run recorded no cycle: there is nothing to check (the message says why)."""


class ClaimsNotReproduced(BenchError, AssertionError):
    """``Result.assert_claims``: a claim did not reproduce or the run is not intact; the message
    is the paper-vs-measured table with the integrity problems and the recording's path."""


@dataclass(frozen=True)
class ClaimVerdict:
    """One quantity of one paper claim, measured on this recording."""

    claim: str                  #: claim id (``G2``, ``Y1``, ...)
    quantity: str               #: the quantity's key (``G2.pee``; ``bench claims`` lists them)
    what: str                   #: what is measured, in words
    paper: float | str          #: the paper's value (a number, or the paper's words)
    measured: float             #: the bench's value (NaN when it could not be measured)
    unit: str
    rule: str                   #: the acceptance rule, from the paper's own words
    verdict: str                #: PASS, FAIL, COMPARED, NOT REPRODUCIBLE, INVALID, ...
    note: str = ""
    diagnostic: bool = False    #: not the paper's set-up: shown, never a claim verdict

    @property
    def passed(self) -> bool:
        return self.verdict in PASSING


class ClaimTable(list):
    """A list of :class:`ClaimVerdict` that prints as the paper-vs-measured table."""

    def __str__(self) -> str:
        return format_claims(self)


@dataclass(frozen=True)
class Integrity:
    """Was the run complete, the file undamaged, the link clean (or its errors allowed), and
    did the estimator under test close the loop? (hil_bench.record.integrity)"""

    ok: bool
    cycles_done: int | None
    cycles_planned: int | None
    problems: tuple[str, ...]           #: the problems the scenario does not allow
    allowed: tuple[str, ...]            #: link errors the scenario allows (``[link] allow``)
    counters: Mapping[str, int]


@dataclass(frozen=True)
class RunInfo:
    """How the run went (``run`` only; ``check`` reads a finished recording)."""

    cycles_done: int
    cycles_planned: int
    wall_s: float
    mode: str                           #: lockstep or realtime
    link: str                           #: the link spec it ran on (what was asked for)
    error: str | None                   #: why it ended early, if it did
    interrupted: bool
    timing: Mapping[str, float]         #: cycle time and, in real time, jitter and misses


@dataclass
class Result:
    """A checked recording: what ``hil_bench.run`` and ``hil_bench.check`` return."""

    scenario: str
    recording: Path
    metrics: dict[str, float]           #: headline numbers of the metrics window
    claims: ClaimTable                  #: one row per claim quantity of the scenario
    integrity: Integrity
    faults: list[FaultOutcome] = field(default_factory=list)   #: one per ``[[faults]]`` entry
    run: RunInfo | None = None
    report: CheckReport | None = field(default=None, repr=False)   #: everything bench check has
    #: the controller that answered, as recorded from its HELLO_ACK (firmware version, protocol,
    #: estimators) with the link and the process behind it (hil_bench.record.controller_id)
    controller: str = ""

    @property
    def passed(self) -> bool:
        """Every claim quantity (diagnostics aside) reproduced, the run is intact and ran to its
        end: what ``bench run --strict`` exits 0 on."""
        ran = self.run is None or (self.run.error is None and not self.run.interrupted)
        return ran and self.integrity.ok and all(
            c.passed for c in self.claims if not c.diagnostic)

    def measured(self, quantity: str) -> float:
        """The measured value of a claim quantity by its key (``result.measured("G2.pee")``)."""
        for c in self.claims:
            if c.quantity == quantity:
                return c.measured
        have = ", ".join(c.quantity for c in self.claims) or "none"
        raise KeyError(f"{self.scenario} measured no {quantity!r} (it has: {have})")

    def summary(self) -> str:
        """The claims table, the integrity problems and the recording's path, as text."""
        lines = [f"{self.scenario}: recording {self.recording}"]
        if self.controller:
            lines.append(f"controller: {self.controller}")
        if self.run is not None and self.run.error:
            lines.append(f"run ended early: {self.run.error}")
        integ = self.integrity
        done = "?" if integ.cycles_done is None else integ.cycles_done
        planned = "?" if integ.cycles_planned is None else integ.cycles_planned
        lines.append(f"integrity: {'ok' if integ.ok else 'NOT OK'} ({done}/{planned} cycles)")
        lines += [f"  problem: {p}" for p in integ.problems]
        lines += [f"  allowed: {p}" for p in integ.allowed]
        lines.append(str(self.claims) if self.claims else "(the scenario names no claim)")
        return "\n".join(lines)

    def assert_claims(self, only: str | list[str] | None = None) -> None:
        """Raise :class:`ClaimsNotReproduced` (an AssertionError) with :meth:`summary` unless
        every claim quantity (of the claims ``only`` names, if given; diagnostics aside)
        reproduced on an intact run that ran to its end."""
        __tracebackhide__ = True   # a failure points at the test that asserted, not here
        if only is not None and not isinstance(only, str) and not (
                isinstance(only, (list, tuple, set)) and all(isinstance(c, str) for c in only)):
            raise ArgumentError(f"assert_claims(only={only!r}): a claim id or a list of them, "
                                f"e.g. 'G2' or ['G2', 'G3']")
        wanted = [only] if isinstance(only, str) else only
        if wanted is not None:
            unknown = sorted(set(wanted) - {c.claim for c in self.claims})
            if unknown:
                raise ClaimsNotReproduced(f"{self.scenario} measures no claim {unknown} "
                                          f"(it names: {sorted({c.claim for c in self.claims})})")
        rows = [c for c in self.claims if not c.diagnostic
                and (wanted is None or c.claim in wanted)]
        ran = self.run is None or (self.run.error is None and not self.run.interrupted)
        if not rows and wanted is None:
            raise ClaimsNotReproduced(f"{self.scenario} names no claim to assert\n{self.summary()}")
        if ran and self.integrity.ok and all(c.passed for c in rows):
            return
        bad = [f"{c.quantity} {c.verdict}" for c in rows if not c.passed]
        head = "; ".join(bad) or ("run not intact" if not self.integrity.ok else "run ended early")
        raise ClaimsNotReproduced(f"claims not reproduced: {head}\n{self.summary()}")

    def as_dict(self) -> dict[str, Any]:
        """Everything above as plain JSON-able values (``bench check --json``): non-finite
        numbers as None, paths as strings."""
        import dataclasses
        import math

        def plain(v):
            if isinstance(v, float) or type(v).__name__ in ("float64", "float32"):
                return float(v) if math.isfinite(float(v)) else None
            if type(v).__name__ in ("int64", "int32", "uint64", "uint32", "bool_"):
                return v.item()
            if isinstance(v, Path):
                return str(v)
            if dataclasses.is_dataclass(v) and not isinstance(v, type):
                return {f.name: plain(getattr(v, f.name)) for f in dataclasses.fields(v)}
            if isinstance(v, Mapping):
                return {str(k): plain(x) for k, x in v.items()}
            if isinstance(v, (list, tuple, set)):
                return [plain(x) for x in v]
            return v

        return {"scenario": self.scenario, "recording": str(self.recording),
                "controller": self.controller, "passed": self.passed,
                "integrity": plain(self.integrity), "metrics": plain(self.metrics),
                "claims": [dict(plain(c), passed=c.passed) for c in self.claims],
                "faults": plain(self.faults), "run": plain(self.run)}


def format_claims(rows: list[ClaimVerdict]) -> str:
    """Plain-text table: claim, quantity, paper, measured, rule, verdict (bench check's table),
    each verdict's note as a numbered footnote below it."""
    from hil_bench.papers.check import fmt_value

    notes: list[str] = []

    def verdict(c: ClaimVerdict) -> str:
        if not c.note:
            return c.verdict
        if c.note not in notes:
            notes.append(c.note)
        return f"{c.verdict} [{notes.index(c.note) + 1}]"

    head = ("claim", "quantity", "paper", "measured", "rule", "verdict")
    body = [(c.claim, c.what or c.quantity,
             c.paper if isinstance(c.paper, str) else fmt_value(c.paper, c.unit),
             fmt_value(c.measured, c.unit), c.rule, verdict(c)) for c in rows]
    widths = [max(len(str(r[i])) for r in [head, *body]) for i in range(len(head))]

    def line(r) -> str:
        return "  ".join(str(v).ljust(w) for v, w in zip(r, widths)).rstrip()

    return "\n".join([line(head), line(tuple("-" * w for w in widths)), *map(line, body),
                      *(f"[{i}] {n}" for i, n in enumerate(notes, 1))])


def _verdicts(report: CheckReport) -> ClaimTable:
    return ClaimTable(
        ClaimVerdict(claim=r.claim.id, quantity=r.quantity.key, what=r.quantity.what,
                     paper=r.quantity.paper_value, measured=float(r.measured),
                     unit=r.quantity.unit, rule=r.quantity.rule_text(), verdict=r.verdict,
                     note=r.note, diagnostic=bool(r.quantity.diagnostic))
        for r in report.results)


def _integrity(report: CheckReport) -> Integrity:
    integ = report.integrity
    problems = [f"{p.kind}: {p.text}" for p in integ.unallowed]
    if integ.estimator_mismatch:
        problems.append(f"estimator: {integ.estimator_text}")
    return Integrity(ok=integ.ok, cycles_done=integ.cycles_done,
                     cycles_planned=integ.cycles_planned, problems=tuple(problems),
                     allowed=tuple(f"{p.kind}: {p.text}" for p in integ.allowed),
                     counters=dict(integ.counters))


def _result(report: CheckReport, run_info: RunInfo | None) -> Result:
    from hil_bench.record.controller_id import describe

    return Result(scenario=report.scenario.name, recording=Path(report.recording.path),
                  metrics=dict(report.summary), claims=_verdicts(report),
                  integrity=_integrity(report), faults=list(report.faults), run=run_info,
                  report=report, controller=describe(report.recording.metadata))


def check_result(report: CheckReport) -> Result:
    """The :class:`Result` of a ``bench check`` report (hil_bench.papers.check.check_recording)."""
    return _result(report, None)


def _path(value: object, name: str) -> Path:
    """A path argument: a non-empty str or os.PathLike, else ArgumentError naming it."""
    import os

    if isinstance(value, (str, os.PathLike)) and str(os.fspath(value)).strip():
        return Path(value)
    raise ArgumentError(f"{name}: a file path (str or pathlib.Path), got {value!r}"
                        + (f" ({type(value).__name__})" if value is not None else ""))


def _flag(value: object, name: str) -> bool:
    if isinstance(value, bool):
        return value
    raise ArgumentError(f"{name}: True or False, got {value!r} ({type(value).__name__})")


def check(path: str | Path) -> Result:
    """``bench check``: metrics, claim verdicts and integrity recomputed from the recording alone.

    Raises NoSuchFile (a FileNotFoundError) for a path with no file, RecordingError (a
    ValueError) for a file that is not a readable recording of this bench, ArgumentError (a
    TypeError) for a path that is no path: all BenchErrors."""
    from hil_bench.installation import require_modules

    path = _path(path, "check(path)")
    require_modules()
    from hil_bench.papers.check import check_recording

    if not path.is_file():
        raise NoSuchFile(f"{path}: no such recording" + (" (a directory)" if path.is_dir() else ""))
    return _result(check_recording(path), None)


_TOML_SCALARS = (bool, int, float, str)


def _overrides(overrides: object) -> list[tuple[str, Any]]:
    """``{"dotted.key": value}`` checked: keys non-empty dotted strings, values TOML values
    (bool, int, float, str, or lists of those); else ArgumentError naming the entry."""
    if overrides is None:
        return []
    if not isinstance(overrides, Mapping):
        raise ArgumentError(f"overrides: a mapping of dotted keys to values (scenario keys), e.g. "
                            f"{{'plant.inverter_nonlinear': True}}; got {overrides!r} "
                            f"({type(overrides).__name__})")

    def toml_value(v: object) -> bool:
        if isinstance(v, (list, tuple)):
            return all(toml_value(x) for x in v)
        return isinstance(v, _TOML_SCALARS)

    out = []
    for key, value in overrides.items():
        if not isinstance(key, str) or not key.strip() or any(not p.strip() for p in key.split(".")):
            raise ArgumentError(f"overrides: the key {key!r} is not a dotted scenario key (a "
                                f"string such as 'controller.speed_ref_rpm')")
        if not toml_value(value):
            raise ArgumentError(f"overrides[{key!r}] = {value!r}: a scenario value is a bool, "
                                f"number, string or a list of those, not {type(value).__name__}")
        out.append((key, list(value) if isinstance(value, tuple) else value))
    return out


def _scenario(scenario: str | Path | Scenario, overrides: Mapping[str, Any] | None,
              name: str | None) -> Scenario:
    import os

    from hil_bench.scenario import Scenario, ScenarioError, derive_scenario, load_scenario

    pairs = _overrides(overrides)
    if name is not None and (not isinstance(name, str) or not name.strip()):
        raise ArgumentError(f"name: the derived scenario's name, a string; got {name!r}")
    if isinstance(scenario, Scenario):
        if not pairs and name is None:
            return scenario
        if scenario.path is None or not Path(scenario.path).is_file():
            raise ScenarioError(f"{scenario.name}: overrides need a scenario file (give its "
                                f"name or path instead of a Scenario read from elsewhere)")
        scenario = scenario.path
    elif not isinstance(scenario, (str, os.PathLike)) or not str(os.fspath(scenario)).strip():
        raise ArgumentError(f"scenario: a bundled scenario's name (e.g. 'gong_g2_500rpm'), a "
                            f"scenario file or a hil_bench.scenario.Scenario; got {scenario!r}"
                            + (f" ({type(scenario).__name__})" if scenario is not None else ""))
    if not pairs and name is None:
        return load_scenario(scenario)
    base = load_scenario(scenario)
    return derive_scenario(scenario, name or base.name, pairs, note="hil_bench.run overrides")


def run(scenario: str | Path | Scenario, *, link: str = "stub",
        overrides: Mapping[str, Any] | None = None, out: str | Path | None = None,
        name: str | None = None, realtime: bool | None = None, cpu: int | None = None,
        allow_slow_link: bool = False, force: bool = False, progress: bool = False) -> Result:
    """``bench run``: run a scenario against a controller, record it, check it.

    scenario   a bundled scenario's name (``"gong_g2_500rpm"``), a scenario file, or a Scenario
    link       ``"stub"`` (the bundled C firmware stub on a pty), ``"stub-slcan"``,
               ``"serial:/dev/ttyUSB0@3000000"``, ``"can:pcan:PCAN_USBBUS1@1M"``, ``"can"``
               (python-can's own configuration) ... as ``bench run --link`` (docs/protocol.md)
    overrides  dotted scenario keys and their values, as ``bench run --set`` and campaigns:
               ``{"plant.inverter_nonlinear": True, "controller.params.SMO_K_V": 30.0}``
    out        the recording's path (default ``recordings/<name>-<time>.mcap`` under the
               working directory); ``force`` replaces an existing one
    name       the derived scenario's name (default: the scenario's own)
    realtime   pace the plant by the wall clock (default: the scenario's mode)

    Errors before anything runs raise with a message naming what and where: ScenarioError
    (file, line, field), LinkError, NativeMissing (what to build). A run that recorded no cycle
    raises RunFailed; a run cut short still returns a Result (``run.error`` says why, its claims
    are INVALID) with its recording finalised.
    """
    from hil_bench.installation import require_modules

    if not isinstance(link, str):
        raise ArgumentError(f"link: a link spec string such as 'stub', 'sil' or "
                            f"'serial:/dev/ttyUSB0@3000000'; got {link!r}")
    out_path = None if out is None else _path(out, "out")
    for flag, value in (("allow_slow_link", allow_slow_link), ("force", force),
                        ("progress", progress)):
        _flag(value, flag)
    if realtime is not None:
        _flag(realtime, "realtime")
    if cpu is not None and (isinstance(cpu, bool) or not isinstance(cpu, int) or cpu < 0):
        raise ArgumentError(f"cpu: a CPU number (int >= 0) or None, got {cpu!r}")
    from hil_bench.loop.links import check_link_spec

    check_link_spec(link, option="link")   # LinkError with "did you mean" before anything runs
    require_modules()          # before importing what needs them: the message says what to run
    from hil_bench.loop.runner import run_scenario
    from hil_bench.papers.check import check_recording

    scn = _scenario(scenario, overrides, name)
    done = run_scenario(scn, link_spec=link, out_path=out_path,
                        progress=progress, allow_slow_link=allow_slow_link, force=force,
                        realtime=realtime, cpu=cpu)
    info = RunInfo(cycles_done=done.cycles_done, cycles_planned=done.cycles_planned,
                   wall_s=done.wall_s, mode=done.mode, link=link, error=done.error,
                   interrupted=done.interrupted, timing=dict(done.timing))
    if done.cycles_done == 0:
        raise RunFailed(f"{scn.name}: no cycle ran ({done.error or 'interrupted'}); recording "
                        f"{done.recording}")
    return _result(check_recording(done.recording), info)


@dataclass
class RecordingData(Mapping):
    """A recording read back for analysis: a mapping of channel (topic) -> pandas DataFrame
    indexed by the plant's time ``t_s`` (s), one column per field, units in ``df.attrs["units"]``,
    enumerations as categoricals, ``/link/frames`` decoded by the DBC (hil_bench.record.tables);
    plus the run's metadata and the scenario it ran. ``list(rec)``, ``rec.keys()``,
    ``rec.items()``, ``len(rec)`` and ``topic in rec`` go over the channels, sorted by name."""

    path: Path
    channels: dict[str, pandas.DataFrame]
    metadata: dict[str, dict[str, str]]
    scenario_toml: str | None
    damage: str                     #: what of the file could not be read ("" if nothing)
    message_counts: dict[str, int]  #: messages per topic in the whole file

    def __getitem__(self, topic: str) -> pandas.DataFrame:
        try:
            return self.channels[topic]
        except KeyError:
            raise KeyError(f"{self.path}: no channel {topic!r} (has: "
                           f"{', '.join(sorted(self.channels)) or 'none'})") from None

    def __iter__(self):
        return iter(self.topics)

    def __len__(self) -> int:
        return len(self.channels)

    def __contains__(self, topic: object) -> bool:
        return topic in self.channels

    @property
    def topics(self) -> list[str]:
        return sorted(self.channels)

    @property
    def run(self) -> dict[str, str]:
        """The run's metadata (scenario, link, controller, versions, plant parameters, ...)."""
        return self.metadata.get("run", {})

    def frames(self, message: str) -> pandas.DataFrame:
        """One DBC message's frames from ``/link/frames``, its signals by their plain names:
        ``rec.frames("DUTY").d_a`` (indexed by ``t_s``, with ``seq`` and ``direction``)."""
        from hil_bench.record.tables import message_frame

        return message_frame(self["/link/frames"], message)


def load_recording(path: str | Path, channels: list[str] | None = None) -> RecordingData:
    """Every channel of a recording (or those ``channels`` names; ``"/reference/*"``: every
    reference estimator) as pandas DataFrames indexed by ``t_s``, for notebooks
    (:class:`RecordingData`); a channel the file does not have is an ArgumentError naming those
    it has. The whole selection is held in memory (a 1.5 s run at 10 kHz: about 40 MB with its
    decoded frames); ``bench check`` reads large files in bounded memory instead. A damaged file
    reads up to the damage (``damage`` says what was lost)."""
    from hil_bench.installation import require_extra, require_modules

    path = _path(path, "load_recording(path)")
    if isinstance(channels, str):
        channels = [channels]
    if channels is not None:
        try:
            channels = list(channels)
        except TypeError:
            channels = [channels]
        if not all(isinstance(c, str) and c for c in channels):
            raise ArgumentError(f"channels: topic names such as '/plant/state' (or "
                                f"'/reference/*'), got {channels!r}")
    require_modules()
    from hil_bench.record.recording import load_recording as read
    from hil_bench.record.tables import channel_frame

    require_extra("hil_bench.load_recording", "pandas")
    if not path.is_file():
        raise NoSuchFile(f"{path}: no such recording" + (" (a directory)" if path.is_dir() else ""))
    rec = read(path, topics=channels)
    if channels is not None:
        have = sorted(rec.counts)
        for topic in channels:
            found = (topic in rec.counts or topic == "/reference/*" and
                     any(t.startswith("/reference/") for t in have))
            if not found:
                raise ArgumentError(f"{path}: no channel {topic!r}{did_you_mean(topic, have)} "
                                    f"(has: {', '.join(have) or 'none'})")
    frames = {topic: channel_frame(topic, cols) for topic, cols in rec.topics.items()}
    found = rec.attachment_text("scenario/")
    return RecordingData(path=path, channels=frames, metadata=rec.metadata,
                         scenario_toml=found[1] if found else None, damage=rec.damage_text(),
                         message_counts=dict(rec.counts))
