"""Figures and verdicts the docs quote from a command, checked against what the command gives
today (issue 30.8: counts that drifted). Each test reads the sentence from the doc and the figure
from the bench; a change to either that leaves them apart fails here."""
from __future__ import annotations

import re
from pathlib import Path

import hil_bench
from hil_bench.faults.campaign import load_campaign

REPO = Path(__file__).resolve().parents[1]
PACKAGE = Path(hil_bench.__file__).resolve().parent


def _text(rel: str) -> str:
    """A doc's text with every run of white space one space (sentences wrap anywhere)."""
    return " ".join((REPO / rel).read_text().split())


def test_the_campaigns_run_count_in_the_docs_is_the_campaigns():
    """README and docs/faults.md: `bench campaign g2_protection ... N runs`."""
    cases = len(load_campaign(PACKAGE / "campaigns" / "g2_protection.toml").cases)
    quoted = []
    for rel in ("README.md", "docs/faults.md"):
        quoted += [(rel, int(n)) for n in
                   re.findall(r"bench campaign g2_protection\b[^`]*?# [^`]*?\b(\d+) runs",
                              _text(rel))]
    assert {rel for rel, _ in quoted} == {"README.md", "docs/faults.md"}, quoted
    assert all(n == cases for _, n in quoted), (cases, quoted)


def test_g2_at_1000_rpm_is_what_docs_api_says(tmp_path):
    """docs/api.md: G2's scenario at 1000 rpm makes every G2 quantity <VERDICT> with the note
    "<NOTE>"."""
    m = re.search(r'run at 1000 rpm \(`overrides= \{"controller.speed_ref_rpm": 1000\}`\) makes '
                  r'every G2 quantity (\w+) with the note "([^"]+)"', _text("docs/api.md"))
    assert m, "docs/api.md no longer says what G2 at 1000 rpm gives"
    verdict, note = m.groups()
    r = hil_bench.run("gong_g2_500rpm", overrides={"controller.speed_ref_rpm": 1000},
                      out=tmp_path / "g2_1000.mcap")
    g2 = [c for c in r.claims if c.claim == "G2"]
    assert g2 and {c.verdict for c in g2} == {verdict}, [(c.quantity, c.verdict) for c in g2]
    assert all(note in " ".join(c.note.split()) for c in g2), [c.note for c in g2]
