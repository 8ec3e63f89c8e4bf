"""The fast subset of ``bench claims --run``: G3 (one closed-loop run), Y5 (a study) and Y7 (a
metric computed from another claim's recording is not in it: the subset keeps to one run) end to
end: the report folder has report.md, a self-contained report.html and the plots, and every row
shows the paper's value beside a measured one. The full command (all 19 claims and the studies
beyond the papers) is documented in docs/claims.md with its wall time."""
import re

import pytest

from bench.report import run_report


@pytest.fixture(scope="module")
def rep(tmp_path_factory):
    return run_report(tmp_path_factory.mktemp("claims"), only=["G3", "Y5"], jobs=1, beyond=False)


def test_report_files(rep):
    md = (rep.out_dir / "report.md").read_text()
    html = (rep.out_dir / "report.html").read_text()
    assert "## G3" in md and "## Y5" in md
    assert (rep.out_dir / "plots" / "G3.png").stat().st_size > 10_000
    assert (rep.out_dir / "plots" / "Y5.png").stat().st_size > 10_000
    # self-contained: every image inlined, nothing fetched from elsewhere
    imgs = re.findall(r"<img [^>]*src=\"([^\"]*)\"", html)
    assert len(imgs) >= 2 and all(s.startswith("data:image/png;base64,") for s in imgs)
    assert "http://" not in html and "https://" not in html


def test_every_row_has_both_numbers_and_a_verdict(rep):
    assert rep.rows
    for r in rep.rows:
        assert r.paper not in ("", "n/a"), r
        assert r.measured not in ("", "n/a"), r
        assert r.verdict in ("PASS", "FAIL", "COMPARED", "INVALID", "NOT REPRODUCIBLE"), r
        assert r.source


def test_g3_closed_by_the_tanh_smo_reproduces_its_bounds(rep):
    rows = {r.key: r for r in rep.rows}
    assert rep.outcomes["G3"].ok
    assert rows["G3.pee"].verdict == "PASS"         # the paper's +-0.05 rad
    assert rows["G3.sf"].verdict == "PASS"
    assert rows["G3.thd"].verdict == "COMPARED"     # no bound in the paper


def test_y5_as_the_paper_set_it_up(rep):
    """M = 24, k = 5 (the tone is the 5th harmonic of a one-period window, fs = 1200 Hz): the
    SDFT takes about 4.8 cycles, the GSDFT about 1.5 (both exactly when their window is full)."""
    rows = {r.key: r for r in rep.rows}
    assert rows["Y5.SDFT.step"].value == pytest.approx(4.79, abs=0.01)
    assert rows["Y5.GSDFT.step"].value == pytest.approx(1.46, abs=0.01)
    assert rows["Y5.SDFT.window"].value == pytest.approx(23 / 4.8)
    assert rows["Y5.GSDFT.window"].value == pytest.approx(7 / 4.8)
    assert rows["Y5.rel"].verdict == "PASS"
