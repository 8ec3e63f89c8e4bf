"""A claim measured on variants of its own runs: the machinery the studies share that run a
claim's runs again with one setting changed through the scenario's CONFIG overrides (the
inverter-compensation residual study, residual.py; the estimator-bandwidth sweeps,
bandwidth.py). A variant is an ordinary claim run (a bundled scenario with dotted-key overrides,
hil_bench.claims.model.Run), so its recording's CONFIG says what ran and the report checks it
against its own conditions (conditions.py).
"""
from __future__ import annotations

import dataclasses
from typing import Callable

from hil_bench.claims.model import Claim, Run

#: the verdicts under which a claim holds at a point of a study (PARTLY: every pass/fail row
#: passed, some rows had no verdict of their own, e.g. NOT RESOLVED)
HOLDS = ("PASS", "COMPARED", "PARTLY")

#: how the report judges one claim on the runs' outcomes: (verdict, rows); the report hands its
#: own (report.judge_claim), so the studies do not import the report that imports them
Judge = Callable[[Claim, dict], tuple[str, list]]


class Holds:
    """A point of a study: the claim's verdict there (report.claim_verdict), holding or not."""

    verdict: str

    @property
    def holds(self) -> bool:
        return self.verdict in HOLDS


def base_runs(c: Claim) -> list[Run]:
    """The runs the claim's non-diagnostic quantities read (its verdict's runs)."""
    want: list[str] = []
    for q in c.quantities:
        if q.diagnostic or q.study or q.calibration:
            continue
        for rid in q.runs:
            if rid not in want:
                want.append(rid)
    return [c.run(rid) for rid in want]


def derived_run(run: Run, prefix: str, overrides: tuple, label: str) -> Run:
    """``run`` again with ``overrides`` added, as the run ``<prefix>.<run id>``."""
    return Run(f"{prefix}.{run.id}", run.scenario, run.overrides + tuple(overrides),
               (run.label + ", " if run.label else "") + label)


def claim_on(c: Claim, variant: Callable[[Run], Run]) -> Claim:
    """The claim measured on ``variant(run)`` of each of its verdict's runs: its non-diagnostic
    quantities (reading the variants) and the relations between them. A variant may be the run
    itself (a run the study leaves as it is)."""
    runs = [variant(run) for run in base_runs(c)]
    ids = {run.id: new.id for run, new in zip(base_runs(c), runs)}

    def remap(q):
        if not q.runs:
            return q
        new = tuple(ids[x] for x in q.runs)
        return dataclasses.replace(q, run=new[0] if isinstance(q.run, str) else new)

    qs = tuple(remap(q) for q in c.quantities if not q.diagnostic and not q.study
               and not q.calibration)
    keys = {q.key for q in qs}
    rels = tuple(rel for rel in c.relations if not rel.diagnostic
                 and all(k in keys or k.startswith("#") for k in rel.keys))
    return dataclasses.replace(c, quantities=qs, relations=rels, runs=tuple(runs))
