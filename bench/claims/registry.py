"""The claims registry: the papers' claims read from the TOML files beside this module, one per
paper (``yuan2020.toml``, ``hou2021.toml``, ``gong2020.toml``; shared texts in ``common.toml``),
and expanded by the named rules of ``expand.py``. Format: docs/claims.md, "The registry".

    python -m hil_bench.claims.registry --dump   # the whole registry as JSON
    python -m hil_bench.claims.registry --words  # the words table (docs/claims.md) as markdown
    python -m hil_bench.claims.registry --dump > tests/golden/claims_registry.json

The golden dump is what tests/test_claims_registry.py compares with: a change of a claim, a rule,
a run or a window shows up as a diff of that file, reviewed with the change.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import re
import tomllib
from pathlib import Path
from typing import Any

from . import expand
from .model import METRIC_DEFINITIONS, PSEUDO_METRICS, Claim, Quantity, Relation, Run

HERE = Path(__file__).resolve().parent
#: the files, in the order of the claims (papers 000, 001, 002); common.toml holds texts only
FILES = ("common.toml", "yuan2020.toml", "hou2021.toml", "gong2020.toml")

_TEXT_REF = re.compile(r"\{([A-Z][A-Z0-9_]*)\}")
_CLAIM_FIELDS = ("paper", "plant", "text", "setup", "notes", "studies", "variants", "runs",
                 "quantities", "relations", "switching")
_RUN_FIELDS = ("id", "scenario", "overrides", "label", "sign_smo", "comparator")
_TUPLE_FIELDS = ("window_s", "at_speed_window_s")
_QUANTITY_FIELDS = tuple(f.name for f in dataclasses.fields(Quantity)
                         if f.name not in ("rule",)) + expand.RULE_FIELDS
_RELATION_FIELDS = tuple(f.name for f in dataclasses.fields(Relation))


class RegistryError(ValueError):
    """A claims file that cannot be read: names the file, the claim and the field."""


@dataclasses.dataclass(frozen=True)
class Words:
    """An entry of the words table (common.toml [[words]]): the papers' words, the shape of the
    statement they make, the rule (or relation test) every row reading them has, and why."""

    id: str
    shape: str
    rule: str          # at_most | within | compared (a row) ; ordering | sized | equal (a relation)
    reading: str


#: the rules a words entry may give: a row's rule kinds, then a relation's tests
WORD_RULES = ("at_most", "within", "compared", "ordering", "sized", "equal")
_WORD_FIELDS = ("id", "shape", "rule", "reading")


def _words(docs: dict[str, dict]) -> dict[str, Words]:
    out: dict[str, Words] = {}
    for name, doc in docs.items():
        for i, t in enumerate(doc.get("words", ())):
            where = f"{name} [[words]][{i}]"
            _check(t, _WORD_FIELDS, where)
            missing = [f for f in _WORD_FIELDS if not isinstance(t.get(f), str) or not t.get(f)]
            if missing:
                raise RegistryError(f"{where}: {', '.join(missing)} missing")
            if t["rule"] not in WORD_RULES:
                raise RegistryError(f"{where}: rule must be one of {', '.join(WORD_RULES)}, got "
                                    f"{t['rule']!r}")
            if t["id"] in out:
                raise RegistryError(f"{where}: words {t['id']!r} defined twice")
            out[t["id"]] = Words(**t)
    return out


def relation_test(rel: Relation) -> str:
    """What a relation tests, in the words table's terms: equal, sized, ordering or compared."""
    if rel.op == "=":
        return "equal"
    if rel.compared:
        return "compared"
    return "sized" if rel.min_fall else "ordering"


def check_words(claims: dict[str, "Claim"], words: dict[str, Words]) -> None:
    """Every row and relation names an entry of the words table, and has the rule (the test)
    that entry gives: the same words get the same rule in every paper."""
    for c in claims.values():
        for q in c.quantities:
            w = words.get(q.rule.words)
            if w is None:
                raise RegistryError(f"{c.id} {q.key}: words {q.rule.words!r} is no entry of the "
                                    f"words table (common.toml [[words]]: "
                                    f"{', '.join(sorted(words))})")
            if w.rule != q.rule.kind:
                raise RegistryError(f"{c.id} {q.key}: the words {w.id!r} give the rule {w.rule}, "
                                    f"the row has {q.rule.kind}")
            _check_rule_numbers(c.id, q)
        for rel in c.relations:
            w = words.get(rel.words)
            if w is None:
                raise RegistryError(f"{c.id} relation {rel.key}: words {rel.words!r} is no entry "
                                    "of the words table (common.toml [[words]])")
            if w.rule != relation_test(rel):
                raise RegistryError(f"{c.id} relation {rel.key}: the words {w.id!r} give the test "
                                    f"{w.rule}, the relation has {relation_test(rel)}")


def _check_rule_numbers(cid: str, q) -> None:
    """The numbers of a rule are the paper's: a bound is the paper's number itself (every bound
    word reads "x bounds the value"), a range quotes both its ends in its source. A bound set
    apart from the number the paper prints is a tolerance nobody can source."""
    r = q.rule
    if r.kind == "at_most":
        pv = q.paper_value
        if isinstance(pv, bool) or not isinstance(pv, (int, float)) or not math.isclose(
                float(pv), r.hi, rel_tol=1e-12, abs_tol=1e-15):
            raise RegistryError(f"{cid} {q.key}: the bound {r.hi:g} is not the paper's number "
                                f"{pv!r}: the words {r.words!r} read the paper's x as the bound")
    elif r.kind == "within":
        ends = [f"{r.lo:g}", f"{round(r.hi, 9):g}"]
        missing = [e for e in ends if e not in r.source]
        if missing:
            raise RegistryError(f"{cid} {q.key}: the range [{ends[0]}, {ends[1]}] is not quoted "
                                f"in its source ({r.source!r} lacks {', '.join(missing)})")


def _texts(docs: dict[str, dict]) -> dict[str, str]:
    out: dict[str, str] = {}
    for name, doc in docs.items():
        for k, v in doc.get("texts", {}).items():
            if k in out:
                raise RegistryError(f"{name}: [texts] {k} is defined twice")
            out[k] = v
    return out


def _substitute(value: Any, texts: dict[str, str], where: str) -> Any:
    """Every ``{NAME}`` in a string replaced by the text of that name ([texts])."""
    if isinstance(value, str):
        def one(m: re.Match) -> str:
            if m.group(1) not in texts:
                raise RegistryError(f"{where}: unknown text {{{m.group(1)}}} (not in any [texts])")
            return texts[m.group(1)]
        return _TEXT_REF.sub(one, value)
    if isinstance(value, list):
        return [_substitute(v, texts, where) for v in value]
    if isinstance(value, dict):
        return {k: _substitute(v, texts, where) for k, v in value.items()}
    return value


def _check(table: dict, known: tuple[str, ...], where: str) -> None:
    left = sorted(set(table) - set(known))
    if left:
        raise RegistryError(f"{where}: unknown field(s) {', '.join(left)}; known: {', '.join(known)}")


def _run(t: dict, where: str) -> tuple[Run, str]:
    _check(t, _RUN_FIELDS, where)
    try:
        run = Run(t["id"], t["scenario"], tuple(t.get("overrides", {}).items()), t.get("label", ""))
    except KeyError as exc:
        raise RegistryError(f"{where}: {exc.args[0]} missing") from None
    return run, t.get("sign_smo", "")


def _quantity(t: dict, where: str) -> Quantity:
    _check(t, _QUANTITY_FIELDS, where)
    kw = {k: v for k, v in t.items() if k not in expand.RULE_FIELDS}
    try:
        rule = expand.rule_of(t, t.get("paper_value"), where)
        if isinstance(kw.get("run"), list):
            kw["run"] = tuple(kw["run"])
        for k in _TUPLE_FIELDS:
            if k in kw:
                kw[k] = tuple(kw[k])
        if "params" in kw:
            kw["params"] = tuple(kw["params"].items())
        return Quantity(rule=rule, **kw)
    except TypeError as exc:            # a required field missing
        raise RegistryError(f"{where}: {exc}") from None
    except ValueError as exc:
        raise RegistryError(str(exc)) from None


def _relation(t: dict, where: str) -> Relation:
    _check(t, _RELATION_FIELDS, where)
    sized = [k for k in ("min_fall", "min_fall_source") if k in t]
    if sized:
        raise RegistryError(f"{where}: {', '.join(sized)} cannot be written in a claims file: a "
                            "relation's size comes from the paper's own table "
                            "(expand.compensation_table reads it from the numbers it quotes)")
    try:
        return Relation(**{k: tuple(v) if k == "keys" else v for k, v in t.items()})
    except (TypeError, ValueError) as exc:
        raise RegistryError(f"{where}: {exc}") from None


def _claim(cid: str, t: dict, where: str) -> Claim:
    """One claim: its plain runs and their variants, its plain rows (each row on a run measured
    on the run's variants too, run by run), its relations, then its expansion tables, then the
    switching-inverter twins of the runs its ``[ID.switching]`` names (expand.switching)."""
    _check(t, _CLAIM_FIELDS + tuple(expand.TABLES), where)
    variants = tuple(t.get("variants", ()))
    for v in variants:
        if v not in expand.VARIANTS:
            raise RegistryError(f"{where}: unknown variant {v!r}; known: {', '.join(expand.VARIANTS)}")
    base: list[tuple[Run, str]] = [_run(r, f"{where}.runs[{i}]") for i, r in enumerate(t.get("runs", ()))]
    comparators = {r["id"]: r["comparator"] for r in t.get("runs", ()) if r.get("comparator")}
    sign_smo = {r.id: s for r, s in base}
    runs = [r for r, _ in base] + [expand.vary_run(r, v, s) for v in variants for r, s in base
                                   if expand.applies(v, s)]
    plain = [_quantity(q, f"{where}.quantities[{i}]") for i, q in enumerate(t.get("quantities", ()))]
    quantities: list[Quantity] = []
    i = 0
    while i < len(plain):                       # consecutive rows of one run: one block
        j = i + 1
        run = plain[i].run
        while j < len(plain) and isinstance(run, str) and plain[j].run == run:
            j += 1
        block = plain[i:j]
        quantities += block
        if isinstance(run, str) and run in sign_smo:
            for v in variants:
                if expand.applies(v, sign_smo[run]):
                    quantities += [expand.vary_quantity(q, run, v) for q in block]
        i = j
    relations = [_relation(r, f"{where}.relations[{i}]") for i, r in enumerate(t.get("relations", ()))]
    if comparators:                     # rows on a comparator run and on its variants
        def comparator_of(q: Quantity) -> str:
            for rid in q.runs:
                for base_id, text in comparators.items():
                    if rid == base_id or rid.startswith(base_id + "."):
                        return text
            return ""
        quantities = [dataclasses.replace(q, comparator=comparator_of(q)) for q in quantities]
    for name, fn in expand.TABLES.items():
        if name in t:
            try:
                more = fn(expand.Spec(t[name], f"{where}.{name}", variants))
            except (KeyError, TypeError, ValueError) as exc:
                raise RegistryError(f"{where}.{name}: {exc}") from None
            runs += more[0]
            quantities += more[1]
            relations += more[2]
    setup = t.get("setup", "")
    if "switching" in t:
        try:
            more, also = expand.switching(expand.Spec(t["switching"], f"{where}.switching", variants),
                                          runs, quantities, relations)
        except ValueError as exc:               # names the field itself
            raise RegistryError(str(exc)) from None
        except (KeyError, TypeError) as exc:
            raise RegistryError(f"{where}.switching: {exc}") from None
        runs += more[0]
        quantities += more[1]
        relations += more[2]
        setup = f"{setup}; {also}" if setup else also
    try:
        return Claim(cid, t["paper"], t["text"], tuple(quantities), tuple(runs), tuple(relations),
                     tuple(t.get("studies", ())), setup, t.get("notes", ""), t.get("plant", ""))
    except KeyError as exc:
        raise RegistryError(f"{where}: {exc.args[0]} missing") from None


def _validate(claims: dict[str, Claim]) -> None:
    """What a claim must hold together: unique ids, runs and keys; rows name known metrics and
    runs of their claim; relations name rows of their claim."""
    run_ids: dict[str, Run] = {}
    for c in claims.values():
        ids = [r.id for r in c.runs]
        if len(set(ids)) != len(ids):
            raise RegistryError(f"{c.id}: a run id appears twice")
        for r in c.runs:
            if run_ids.setdefault(r.id, r) != r:
                raise RegistryError(f"{c.id}: run {r.id} differs from the run of that id in "
                                    "another claim")
        keys = [q.key for q in c.quantities]
        dup = sorted({k for k in keys if keys.count(k) > 1})
        if dup:
            raise RegistryError(f"{c.id}: quantity key(s) {', '.join(dup)} appear twice")
        for q in c.quantities:
            if q.metric not in METRIC_DEFINITIONS and q.metric not in PSEUDO_METRICS:
                raise RegistryError(f"{c.id} {q.key}: unknown metric {q.metric!r}")
            missing = [r for r in q.runs if r not in ids]
            if missing:
                raise RegistryError(f"{c.id} {q.key}: no run {', '.join(missing)} in the claim")
        for rel in c.relations:
            bad = [k for k in rel.keys if not k.startswith("#") and k not in keys]
            if bad:
                raise RegistryError(f"{c.id} relation {rel.key}: no quantity {', '.join(bad)}")


def load(folder: Path = HERE) -> dict[str, Claim]:
    """Every claim, by id, in the order of the files."""
    docs: dict[str, dict] = {}
    for name in FILES:
        path = folder / name
        try:
            docs[name] = tomllib.loads(path.read_text())
        except tomllib.TOMLDecodeError as exc:
            raise RegistryError(f"{path}: {exc}") from None
    texts = _texts(docs)
    words = _words(docs)
    claims: dict[str, Claim] = {}
    for name, doc in docs.items():
        for cid, t in doc.items():
            if cid in ("texts", "words"):
                continue
            if cid in claims:
                raise RegistryError(f"{name}: claim {cid} is defined twice")
            where = f"{name} [{cid}]"
            claims[cid] = _claim(cid, _substitute(t, texts, where), where)
    _validate(claims)
    check_words(claims, words)
    return claims


def load_words(folder: Path = HERE) -> dict[str, Words]:
    """The words table (common.toml [[words]]), by id, in its order."""
    docs = {name: tomllib.loads((folder / name).read_text()) for name in FILES}
    return _words(docs)


CLAIMS: dict[str, Claim] = load()
WORDS: dict[str, Words] = load_words()


def all_runs(claim_ids=None) -> dict[str, Run]:
    """Every run the claims need, by run id (a run shared by two claims appears once)."""
    out: dict[str, Run] = {}
    for c in CLAIMS.values():
        if claim_ids is not None and c.id not in claim_ids:
            continue
        for r in c.runs:
            out.setdefault(r.id, r)
    return out


def _table(claim: str, name: str) -> dict:
    return tomllib.loads((HERE / _FILE_OF[claim[0]]).read_text())[claim][name]


_FILE_OF = {"Y": "yuan2020.toml", "H": "hou2021.toml", "G": "gong2020.toml"}
#: the families' parameters, for the report's plots: Y8's (speed rpm, paper dn rpm), H3's angles,
#: G1's (m, paper THD %) and the host-observer steps of the G1 study (us)
Y8_SPEEDS = tuple((r["rpm"], r["paper_value"]) for r in _table("Y8", "speed_table")["rows"])
H3_ANGLES_DEG = tuple(_table("H3", "angle_table")["angles_deg"])
G1_MS = tuple((r["m"], r["thd_percent"]) for r in _table("G1", "boundary_layer_table")["rows"])
G1_STEPS_US = tuple(_table("G1", "boundary_layer_table")["study_steps_us"])


def _plain(v: Any) -> Any:
    if dataclasses.is_dataclass(v):
        return {f.name: _plain(getattr(v, f.name)) for f in dataclasses.fields(v)}
    if isinstance(v, (tuple, list)):
        return [_plain(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return repr(v)
    return v


def dump(claims: dict[str, Claim] | None = None) -> str:
    """The whole registry as JSON: every claim, run (with its overrides), quantity (every field,
    its rule's kind, bounds and source) and relation, in order."""
    return json.dumps([_plain(c) for c in (claims or CLAIMS).values()], indent=1) + "\n"


_RULE_TEXT = {"at_most": "bound: PASS if measured <= x", "within": "PASS if a <= measured <= b",
              "compared": "COMPARED: shown beside, no pass/fail",
              "ordering": "the ordering checked (PASS / FAIL / NOT RESOLVED)",
              "sized": "the ordering checked and its relative size must reach the paper's",
              "equal": "PASS if |a - b| < the stated tolerance"}


def _clean(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def words_quotes(claims: dict[str, Claim] | None = None) -> dict[str, list[tuple[str, str]]]:
    """Per words entry the quotes of the rows and relations that read them (claim ids, source),
    the paper's rows only (no diagnostic copy), each distinct source once, in registry order."""
    out: dict[str, dict[str, list[str]]] = {}
    for c in (claims or CLAIMS).values():
        items = [(q.rule.words, q.rule.source) for q in c.quantities if not q.diagnostic]
        items += [(r.words, r.source) for r in c.relations if not r.diagnostic]
        for w, src in items:
            ids = out.setdefault(w, {}).setdefault(_clean(src), [])
            if c.id not in ids:
                ids.append(c.id)
    return {w: [(", ".join(ids), src) for src, ids in d.items()] for w, d in out.items()}


def words_table(claims: dict[str, Claim] | None = None,
                words: dict[str, Words] | None = None) -> str:
    """docs/claims.md's table 'One reading of the papers' words', from the registry: per entry of
    the words table its shape, rule and reading, and the quotes of every row that reads it."""
    quotes = words_quotes(claims)
    lines = ["| the papers' words | shape | rule | reading | where (claims: the rule's source) |",
             "|---|---|---|---|---|"]
    for w in (words or WORDS).values():
        where = "; ".join(f"{ids}: {src}" for ids, src in quotes.get(w.id, [])) or "(no row)"
        lines.append(f"| {_clean(w.id)} | {_clean(w.shape)} | {_clean(_RULE_TEXT[w.rule])} | "
                     f"{_clean(w.reading)} | {where} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dump", action="store_true", help="print the whole registry as JSON")
    ap.add_argument("--words", action="store_true",
                    help="print the words table as markdown (docs/claims.md)")
    args = ap.parse_args(argv)
    if args.words:
        print(words_table(), end="")
    elif args.dump:
        print(dump(), end="")
    else:
        for c in CLAIMS.values():
            print(f"{c.id:3s} {len(c.runs):3d} runs {len(c.quantities):3d} rows "
                  f"{len(c.relations):3d} relations  {c.paper}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
