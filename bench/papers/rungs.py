"""Every claim against any controller: ``bench claims --run --link LINK``.

The claims' scenarios run twice, on the host stub (the reference rung) and on the controller
behind ``LINK`` (the firmware in QEMU, ``pil-qemu``; a drive on ``serial:...`` or ``can:...``),
and each quantity's verdict is set beside the host stub's. A verdict that differs between the
rungs is a finding (float32 on the target, its libm, the port, the link's timing), listed as such,
never averaged away.

A link that is one device (a drive on a serial port or a CAN adapter) runs one scenario at a
time; the emulator and the stub's own links start a controller per run and run in parallel.
Studies (quantities computed on the host, not from a recording) are the same for both rungs and
say so. ``rungs.md`` in the output folder is the report; the recordings of both rungs are kept
under ``recordings/stub/`` and ``recordings/<link>/``.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from pathlib import Path

from rich.console import Console

from .claims import CLAIMS
from .report import RunOutcome, Row, default_jobs, execute, measure_claims

#: link kinds that start their own controller per run (parallel runs do not share a device)
PARALLEL_KINDS = ("stub", "sil", "pil-qemu")


@dataclass
class Rungs:
    out_dir: Path
    link: str
    ids: list[str]
    rows: dict[str, list[Row]] = field(default_factory=dict)            # rung -> rows
    outcomes: dict[str, dict[str, RunOutcome]] = field(default_factory=dict)
    wall_s: dict[str, float] = field(default_factory=dict)
    jobs: dict[str, int] = field(default_factory=dict)

    def pairs(self) -> list[tuple[Row, Row | None]]:
        theirs = {(r.claim, r.key): r for r in self.rows[self.link]}
        return [(r, theirs.get((r.claim, r.key))) for r in self.rows["stub"]]

    def differences(self) -> list[tuple[Row, Row | None]]:
        return [(a, b) for a, b in self.pairs() if b is None or a.verdict != b.verdict]


def slug(link: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", link).strip("_") or "link"


def jobs_for(link: str, jobs: int | None) -> int:
    if not link.startswith(PARALLEL_KINDS):
        return 1              # one device: one run at a time
    return jobs or default_jobs()


def run_rungs(out_dir: Path, link: str, only: list[str] | None = None, jobs: int | None = None,
              reuse: bool = False, console: Console | None = None,
              scheduler: str | None = None) -> Rungs:
    """Both rungs on the executor (hil_bench.cluster); ``scheduler``: an existing Dask cluster,
    only for links that start their controller where the run is (a device is on this machine)."""
    console = console or Console(stderr=True)
    out_dir = Path(out_dir)
    if scheduler and not link.startswith(PARALLEL_KINDS):
        raise ValueError(f"--scheduler with --link {link}: the device is on this machine, its "
                         f"runs cannot go to a cluster's workers; run without --scheduler")
    ids = list(CLAIMS) if not only else only
    unknown = [c for c in ids if c not in CLAIMS]
    if unknown:
        raise ValueError(f"unknown claim(s) {', '.join(unknown)}; known: {', '.join(CLAIMS)}")
    claims = [CLAIMS[c] for c in ids]
    runs = {}
    for c in claims:
        for r in c.runs:
            runs.setdefault(r.id, r)
    studies, study_errors = _studies(claims)
    rg = Rungs(out_dir, link, ids)
    for rung in ("stub", link):
        n_jobs = jobs_for(rung, jobs)
        rg.jobs[rung] = n_jobs
        console.print(f"{rung}: {len(runs)} runs ({n_jobs} at a time) for claims {', '.join(ids)}")
        t0 = time.monotonic()
        rg.outcomes[rung] = execute(runs, out_dir / "recordings" / slug(rung), n_jobs, console,
                                    reuse=reuse, link=rung,
                                    scheduler=scheduler if rung.startswith(PARALLEL_KINDS) else None)
        rg.wall_s[rung] = time.monotonic() - t0
        rg.rows[rung] = measure_claims(claims, rg.outcomes[rung], studies, study_errors)
    write_markdown(rg, claims)
    return rg


def _studies(claims) -> tuple[dict, dict]:
    from .studies import STUDIES

    studies, errors = {}, {}
    for c in claims:
        for s in c.studies:
            if s in studies or s in errors:
                continue
            try:
                studies[s] = STUDIES[s]()
            except Exception as exc:  # noqa: BLE001 - reported in the row
                errors[s] = f"{type(exc).__name__}: {exc}"
    return studies, errors


def _target_cells(outcome: RunOutcome | None) -> str:
    """The target's own figures of a run (pil-qemu), from the recording's metadata."""
    if outcome is None or not outcome.recording.exists():
        return ""
    from hil_bench.record.recording import RecordingError, read_header

    try:
        t = read_header(outcome.recording).metadata.get("target", {})
    except RecordingError:
        return ""
    if not t.get("isr_instructions_mean"):
        return ""
    return (f"{float(t['isr_instructions_mean']):.0f} / {float(t['isr_instructions_max']):.0f} "
            f"| {t.get('stack_used_bytes', '?')}")


def write_markdown(rg: Rungs, claims) -> Path:
    from .claims import CLAIMS as ALL

    link = rg.link
    lines = [f"# Claims on `{link}` beside the host stub", "",
             f"`bench claims --run --link {link} --only {','.join(rg.ids)}`: "
             f"{len(rg.outcomes['stub'])} runs per rung; host stub {rg.wall_s['stub']:.0f} s "
             f"({rg.jobs['stub']} at a time), `{link}` {rg.wall_s[link]:.0f} s "
             f"({rg.jobs[link]} at a time).", ""]
    diffs = rg.differences()
    pairs = rg.pairs()
    lines += [f"**{len(pairs) - len(diffs)} of {len(pairs)} verdicts the same on both rungs.**"
              + (" Every difference is a finding (below)." if diffs else ""), ""]
    lines += ["| claim | quantity | paper | host stub | verdict | " + link + " | verdict | same |",
              "|---|---|---|---|---|---|---|---|"]
    for a, b in pairs:
        q = next((q for q in ALL[a.claim].quantities if q.key == a.key), None)
        study = " (host study: the same for both)" if q is not None and q.study else ""
        lines.append(f"| {a.claim} | {a.what}{study} | {a.paper} | {a.measured} | {a.verdict} | "
                     f"{b.measured if b else '-'} | {b.verdict if b else 'missing'} | "
                     f"{'yes' if b is not None and a.verdict == b.verdict else '**no**'} |")
    if diffs:
        lines += ["", "## Differences (findings)", ""]
        for a, b in diffs:
            lines.append(f"* {a.claim} {a.what}: host stub {a.verdict} ({a.measured}), `{link}` "
                         f"{b.verdict if b else 'no row'} ({b.measured if b else '-'})"
                         + (f" -- {b.note}" if b is not None and b.note else ""))
    lines += ["", "## Runs", "", f"| run | host stub | `{link}` | ISR instructions mean / max "
              f"| stack B |", "|---|---|---|---|---|"]
    for rid, o in rg.outcomes["stub"].items():
        t = rg.outcomes[link].get(rid)
        cells = _target_cells(t) or "- | -"
        lines.append(f"| {rid} | {'ok' if o.ok else 'ended: ' + o.error.splitlines()[0]} | "
                     f"{'ok' if t is not None and t.ok else ('ended: ' + t.error.splitlines()[0] if t else '-')} "
                     f"| {cells} |")
    path = rg.out_dir / "rungs.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    from .report import _write_aside
    _write_aside(path, "\n".join(lines) + "\n")
    return path
