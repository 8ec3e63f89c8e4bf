"""The claims registry: the papers' claims read from the TOML files beside this module, one per
paper (``yuan2020.toml``, ``hou2021.toml``, ``gong2020.toml``; shared texts in ``common.toml``),
and expanded by the named rules of ``expand.py``. Format: docs/claims.md, "The registry".

    python -m hil_bench.claims.registry --dump   # the whole registry as JSON
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
_CLAIM_FIELDS = ("paper", "text", "setup", "notes", "studies", "variants", "runs", "quantities",
                 "relations")
_RUN_FIELDS = ("id", "scenario", "overrides", "label", "sign_smo")
_TUPLE_FIELDS = ("window_s", "at_speed_window_s")
_QUANTITY_FIELDS = tuple(f.name for f in dataclasses.fields(Quantity)
                         if f.name not in ("rule",)) + expand.RULE_FIELDS
_RELATION_FIELDS = tuple(f.name for f in dataclasses.fields(Relation))


class RegistryError(ValueError):
    """A claims file that cannot be read: names the file, the claim and the field."""


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
    try:
        return Relation(**{k: tuple(v) if k == "keys" else v for k, v in t.items()})
    except (TypeError, ValueError) as exc:
        raise RegistryError(f"{where}: {exc}") from None


def _claim(cid: str, t: dict, where: str) -> Claim:
    """One claim: its plain runs and their variants, its plain rows (each row on a run measured
    on the run's variants too, run by run), its relations, then its expansion tables in file
    order."""
    _check(t, _CLAIM_FIELDS + tuple(expand.TABLES), where)
    variants = tuple(t.get("variants", ()))
    for v in variants:
        if v not in expand.VARIANTS:
            raise RegistryError(f"{where}: unknown variant {v!r}; known: {', '.join(expand.VARIANTS)}")
    base: list[tuple[Run, str]] = [_run(r, f"{where}.runs[{i}]") for i, r in enumerate(t.get("runs", ()))]
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
    for name, fn in expand.TABLES.items():
        if name in t:
            try:
                more = fn(expand.Spec(t[name], f"{where}.{name}", variants))
            except (KeyError, TypeError, ValueError) as exc:
                raise RegistryError(f"{where}.{name}: {exc}") from None
            runs += more[0]
            quantities += more[1]
            relations += more[2]
    try:
        return Claim(cid, t["paper"], t["text"], tuple(quantities), tuple(runs), tuple(relations),
                     tuple(t.get("studies", ())), t.get("setup", ""), t.get("notes", ""))
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
    claims: dict[str, Claim] = {}
    for name, doc in docs.items():
        for cid, t in doc.items():
            if cid == "texts":
                continue
            if cid in claims:
                raise RegistryError(f"{name}: claim {cid} is defined twice")
            where = f"{name} [{cid}]"
            claims[cid] = _claim(cid, _substitute(t, texts, where), where)
    _validate(claims)
    return claims


CLAIMS: dict[str, Claim] = load()


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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dump", action="store_true", help="print the whole registry as JSON")
    args = ap.parse_args(argv)
    if args.dump:
        print(dump(), end="")
    else:
        for c in CLAIMS.values():
            print(f"{c.id:3s} {len(c.runs):3d} runs {len(c.quantities):3d} rows "
                  f"{len(c.relations):3d} relations  {c.paper}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
