"""The claims registry as data (bench/claims/*.toml read by bench/claims/registry.py, families
written by the named rules of bench/claims/expand.py).

The golden dump (tests/golden/claims_registry.json) was made from the registry before it became
data (the 570-line function of bench/papers/claims.py at 8a5d6d5) and is identical to what the
TOML gives: every claim, run with its overrides, quantity with every field and its rule, and
relation. A change of a rule, a value, a window or a run must show up as a diff of that file:
regenerate it with ``python -m hil_bench.claims.registry --dump > tests/golden/claims_registry.json``
and review the diff with the change. The other tests: a bad claims file is refused naming the
file, the claim and the field, and the expansion rules do what the format says."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from hil_bench.claims import expand, registry
from hil_bench.claims.model import Run

GOLDEN = Path(__file__).resolve().parent / "golden" / "claims_registry.json"


def test_the_registry_is_the_golden_dump():
    """Every field of every claim as the golden file has it (made before the registry was
    data): no claim, rule, value, window, run or verdict input changed."""
    assert registry.dump() == GOLDEN.read_text()


def test_the_dump_tool_prints_the_dump():
    out = subprocess.run([sys.executable, "-m", "hil_bench.claims.registry", "--dump"],
                         capture_output=True, text=True, check=True).stdout
    assert json.loads(out) == json.loads(GOLDEN.read_text())


def _copy(tmp_path: Path) -> Path:
    for name in registry.FILES:
        shutil.copy(registry.HERE / name, tmp_path / name)
    return tmp_path


def _edit(folder: Path, name: str, old: str, new: str) -> None:
    p = folder / name
    text = p.read_text()
    assert text.count(old) == 1, old
    p.write_text(text.replace(old, new))


def test_a_row_added_is_one_table(tmp_path):
    """Adding a claim row is one [[ID.quantities]] table, read as written."""
    folder = _copy(tmp_path)
    p = folder / "gong2020.toml"
    p.write_text(p.read_text().replace("[[G3.quantities]]", '''[[G3.quantities]]
key = "G3.speed"
what = "true speed band"
metric = "speed_band_true_rpm"
paper_value = 24.0
rule = "at_most"
words = "±x"
rule_source = "a test"
run = "G3"

[[G3.quantities]]''', 1))
    claims = registry.load(folder)
    q = claims["G3"].quantities[0]
    assert (q.key, q.metric, q.rule.kind, q.rule.hi, q.runs) == \
        ("G3.speed", "speed_band_true_rpm", "at_most", 24.0, ("G3",))
    # G3's runs also run on the switching inverter ([G3.switching]): the new row has its twin
    assert [x.key for x in claims["G3"].quantities[1:]] == \
        [x.key for x in registry.CLAIMS["G3"].quantities if not x.key.endswith(".sw")] + \
        ["G3.speed.sw"] + [x.key for x in registry.CLAIMS["G3"].quantities if x.key.endswith(".sw")]


def test_a_rule_changed_is_one_line(tmp_path):
    """Changing a family's rule (Y8's at_most to compared) is one line of its table."""
    folder = _copy(tmp_path)
    _edit(folder, "yuan2020.toml", 'rule = "at_most"\nwords = "band in a table"\nrule_source = '
          '"Yuan Table 4', 'rule = "compared"\nwords = "approximately x"\nrule_source = "Yuan Table 4')
    rows = registry.load(folder)["Y8"].quantities
    assert {q.rule.kind for q in rows} == {"compared"} and len(rows) == 15   # + switching twins


@pytest.mark.parametrize("name, old, new, message", [
    ("gong2020.toml", 'key = "G2.pee"', 'key = "G2.pee"\nwindw_s = [0.0, 1.0]',
     "gong2020.toml [G2].quantities[2]: unknown field(s) windw_s"),
    ("gong2020.toml", 'key = "G2.pee"\nwhat = "position-estimation error"\nmetric = "pee_max_rad"',
     'key = "G2.pee"\nwhat = "position-estimation error"\nmetric = "pee_max_radians"',
     "G2 G2.pee: unknown metric 'pee_max_radians'"),
    ("gong2020.toml", 'rule_source = "Gong V-A-b: \'within +-0.1 rad\'"\n', "",
     "gong2020.toml [G2].quantities[2]: rule_source missing"),
    ("gong2020.toml", 'rule_source = "Gong V-A-b: \'within +-0.1 rad\'"\n',
     'rule_source = "{NO_SUCH_TEXT}"\n', "gong2020.toml [G2]: unknown text {NO_SUCH_TEXT}"),
    ("yuan2020.toml", 'variants = ["stubloop"]', 'variants = ["stub_loop"]',
     "yuan2020.toml [Y4]: unknown variant 'stub_loop'"),
    ("hou2021.toml", 'bias_a = 2.4', 'bias_a = 2.4\nbias_v = 1.0',
     "hou2021.toml [H3].angle_table: unknown field(s) bias_v"),
    ("gong2020.toml", 'keys = ["G1.m1.thd",', 'keys = ["G1.m2.thd",',
     "G1 relation G1.thd: no quantity G1.m2.thd"),
    ("gong2020.toml", 'run = "G2"\nat_speed_rpm = 500.0\ndiagnostic = true',
     'run = "G2.x"\nat_speed_rpm = 500.0\ndiagnostic = true', "G2 G2.sf.telemetry: no run G2.x"),
    ("gong2020.toml", 'rule = "at_most"\nwords = "within ±x"\nrule_source = "Gong V-A-b: \'within',
     'rule = "below"\nwords = "within ±x"\nrule_source = "Gong V-A-b: \'within',
     "rule must be at_most, within or compared, got 'below'"),
    # one reading of the papers' words: a row's rule is the one its words give
    ("gong2020.toml", 'rule = "at_most"\nwords = "within ±x"\nrule_source = "Gong V-A-b: \'within',
     'rule = "compared"\nwords = "within ±x"\nrule_source = "Gong V-A-b: \'within',
     "G2 G2.pee: the words 'within ±x' give the rule at_most, the row has compared"),
    ("gong2020.toml", 'rule = "at_most"\nwords = "within ±x"\nrule_source = "Gong V-A-b: \'within',
     'rule = "at_most"\nwords = "inside ±x"\nrule_source = "Gong V-A-b: \'within',
     "G2 G2.pee: words 'inside ±x' is no entry of the words table"),
    ("hou2021.toml", 'keys = ["H1.hfi.10", "H1.smo.10"]\nop = "<"\npaper = "1.5 < 4 rpm"\n'
     'source = "Hou 4.2"\nwords = "better / faster / less / falls"',
     'keys = ["H1.hfi.10", "H1.smo.10"]\nop = "<"\npaper = "1.5 < 4 rpm"\n'
     'source = "Hou 4.2"\nwords = "identical"',
     "H1 relation H1.10: the words 'identical' give the test equal, the relation has ordering"),
    ("common.toml", 'id = "about ±x"\nshape = "a band, read off a figure"\nrule = "at_most"',
     'id = "about ±x"\nshape = "a band, read off a figure"\nrule = "compared"',
     "the words 'about ±x' give the rule compared, the row has at_most"),
    # the numbers of a rule are the paper's (review of issue 27: a bound of 25 rpm for Hou's
    # "about +-1.5 rpm" loaded, and H1's 21.7 rpm read PASS)
    ("hou2021.toml", 'paper_value = 1.5\nrule = "at_most"\nwords = "about ±x"\n',
     'paper_value = 1.5\nrule = "at_most"\nbound = 25.0\nwords = "about ±x"\n',
     "H1 H1.hfi.10: the bound 25 is not the paper's number 1.5"),
    ("gong2020.toml", 'range = [33.2, 35.3]\ninclusive = true\nrule_source = "Gong Table II: '
     'the 15 per-period values span 33.2 .. 35.3 us"\nrun = "G5"\n',
     'range = [30.0, 35.3]\ninclusive = true\nrule_source = "Gong Table II: '
     'the 15 per-period values span 33.2 .. 35.3 us"\nrun = "G5"\n',
     "G5 G5.td: the range [30, 35.3] is not quoted in its source"),
    ("hou2021.toml", 'keys = ["H1.hfi.10", "H1.smo.10"]\nop = "<"\npaper = "1.5 < 4 rpm"\n'
     'source = "Hou 4.2"\nwords = "better / faster / less / falls"',
     'keys = ["H1.hfi.10", "H1.smo.10"]\nop = "<"\npaper = "1.5 < 4 rpm"\n'
     'source = "Hou 4.2"\nwords = "better / faster / less / falls"\nmin_fall = 0.01\n'
     'min_fall_source = "mine"', "min_fall, min_fall_source cannot be written in a claims file"),
])
def test_a_bad_file_is_refused_naming_where(tmp_path, name, old, new, message):
    folder = _copy(tmp_path)
    _edit(folder, name, old, new)
    with pytest.raises(registry.RegistryError) as exc:
        registry.load(folder)
    assert message in str(exc.value)


def test_a_toml_syntax_error_names_the_file_and_line(tmp_path):
    folder = _copy(tmp_path)
    _edit(folder, "hou2021.toml", "[H3]\n", "[H3\n")
    with pytest.raises(registry.RegistryError, match=r"hou2021.toml: .*line \d+"):
        registry.load(folder)


def test_variants_follow_their_names():
    """A variant's run is the run with each change of its name in order; the eq. 5 floor only
    where the sign SMO closes the loop; a row on the run is measured on each copy."""
    base = Run("X.smo", "yuan_y2_conventional", (("a", 1),), "sign SMO")
    both = expand.vary_run(base, "nodt.keq5", "yuan2020")
    assert both.id == "X.smo.nodt.keq5"
    assert both.overrides == (("a", 1), ("plant.inverter_nonlinear", False),
                              ("controller.params.SMO_K_MIN_V", 0.48))
    assert both.label == ("sign SMO, dead time off (diagnostic), sign SMO gain floor 0.48 V by "
                          "eq. 5 (diagnostic)")
    assert not expand.applies("keq5", "") and expand.applies("nodt.dyno", "")
    h2 = registry.CLAIMS["H2"]
    smo = [q.key for q in h2.quantities if q.key.startswith("H2.smo")]
    assert smo == ["H2.smo.resp", "H2.smo.drop", "H2.smo.nodt.resp", "H2.smo.nodt.drop",
                   "H2.smo.nodt.dyno.resp", "H2.smo.nodt.dyno.drop", "H2.smo.resp.sw",
                   "H2.smo.drop.sw"]
    drop = {q.key: q for q in h2.quantities}
    # the paper's row says why its number cannot come out here; its diagnostic copies do not
    assert drop["H2.smo.drop.sw"].not_reproducible and not drop["H2.smo.nodt.dyno.drop"].not_reproducible
    assert all(q.diagnostic for k, q in drop.items() if ".nodt" in k)
    # the switching twins decide, the averaged rows are diagnostic; the comparator's rows say so
    assert drop["H2.smo.drop"].diagnostic and not drop["H2.smo.drop.sw"].diagnostic
    assert drop["H2.smo.drop.sw"].comparator and not drop["H2.hfi.drop.sw"].comparator


def test_the_registry_follows_the_words_table():
    """issue 27, 2: every row and relation names an entry of the words table (common.toml), and
    has the rule (the relation test) that entry gives, in all three papers."""
    words = registry.WORDS
    for c in registry.CLAIMS.values():
        for q in c.quantities:
            assert words[q.rule.words].rule == q.rule.kind, (c.id, q.key)
        for r in c.relations:
            assert words[r.words].rule == registry.relation_test(r), (c.id, r.key)
    by_words: dict[str, set] = {}
    for c in registry.CLAIMS.values():
        for q in c.quantities:
            by_words.setdefault(q.rule.words, set()).add(q.rule.kind)
    assert all(len(kinds) == 1 for kinds in by_words.values()), by_words
    # the bands read off figures ('about', 'approximately within') are bands like '+-x'
    for w in ("±x", "within ±x", "about ±x", "approximately within ±x", "can be ensured within ±x"):
        assert words[w].rule == "at_most"
    assert words["approximately x"].rule == "compared"
    assert words["significantly decrease from a to b"].rule == "sized"


def test_the_words_table_in_the_docs_is_the_registrys():
    """docs/claims.md carries the table generated from the registry (python -m
    hil_bench.claims.registry --words), verbatim: one reading, written once."""
    docs = (Path(__file__).resolve().parents[1] / "docs" / "claims.md").read_text()
    assert registry.words_table() in docs
    out = subprocess.run([sys.executable, "-m", "hil_bench.claims.registry", "--words"],
                         capture_output=True, text=True, check=True).stdout
    assert out == registry.words_table()


def test_the_families_keep_their_tables():
    """The report's plots read the families' parameters from the same tables."""
    assert registry.Y8_SPEEDS == ((50.0, 3.0), (10.0, 1.5), (9.0, 2.0), (8.0, 2.0), (5.0, 2.0))
    assert registry.H3_ANGLES_DEG == (0, 45, 90, 135, 180)
    assert [m for m, _ in registry.G1_MS] == [1.0, 0.25, 0.1, 0.01]
    y8 = [q for q in registry.CLAIMS["Y8"].quantities if not q.diagnostic]
    assert [(q.at_speed_rpm, q.paper_value) for q in y8] == list(registry.Y8_SPEEDS)
