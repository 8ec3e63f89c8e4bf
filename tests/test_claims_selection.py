"""Which runs ``bench claims --run`` plans (issue 30.5): ``--only`` runs only those claims' runs,
the studies beyond the papers join with ``--beyond`` (and by default when no claim is picked);
``--no-beyond`` keeps working. The runs are counted where they are handed to the executor, which
is stopped there: nothing runs."""
from __future__ import annotations

import pytest

from hil_bench.claims.registry import CLAIMS
from hil_bench.cli import main as cli_main


class Planned(Exception):
    """Raised where the report hands its runs to the executor: the plan is complete."""


def planned(monkeypatch, tmp_path, *args: str) -> dict:
    from hil_bench.papers import report

    seen: dict = {}

    def execute(runs, *rest, **kwargs):
        seen.update(runs)
        raise Planned

    monkeypatch.setattr(report, "execute", execute)
    with pytest.raises(Planned):
        cli_main(["claims", "--run", "--out", str(tmp_path / "claims"), "--jobs", "1", *args])
    return seen


def _beyond_ids() -> set[str]:
    from hil_bench.papers import beyond

    return {r.id for r in beyond.plan().runs}


def test_only_runs_only_the_claims_it_names(monkeypatch, tmp_path):
    runs = planned(monkeypatch, tmp_path, "--only", "G2,G3")
    assert sorted(runs) == ["G2", "G2.sw", "G3", "G3.sw"]
    assert sorted(runs) == sorted(r.id for c in ("G2", "G3") for r in CLAIMS[c].runs)
    assert len(runs) == 4


def test_only_with_beyond_adds_the_studies(monkeypatch, tmp_path):
    runs = planned(monkeypatch, tmp_path, "--only", "G2,G3", "--beyond")
    beyond = _beyond_ids()
    assert len(beyond) > 100
    assert set(runs) == {"G2", "G2.sw", "G3", "G3.sw"} | beyond


def test_without_only_the_studies_run_unless_no_beyond(monkeypatch, tmp_path):
    every_claim = {r.id for c in CLAIMS.values() for r in c.runs}
    runs = planned(monkeypatch, tmp_path)
    assert every_claim | _beyond_ids() <= set(runs)
    runs = planned(monkeypatch, tmp_path, "--no-beyond")
    assert every_claim <= set(runs) and not _beyond_ids() & (set(runs) - every_claim)


def test_beyond_and_no_beyond_exclude_each_other(capsys):
    with pytest.raises(SystemExit) as info:
        cli_main(["claims", "--run", "--only", "G2", "--beyond", "--no-beyond"])
    assert info.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err


def test_the_report_command_line_carries_beyond():
    from pathlib import Path

    from hil_bench.papers.report import command_of

    line = command_of(Path("o"), ["G2", "G3"], 1, True, False, False, None, True)
    assert line.endswith("--only G2,G3 --jobs 1 --beyond")
    assert command_of(Path("o"), None, 1, False, False, False, None, True).endswith(
        "--no-beyond")
