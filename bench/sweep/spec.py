"""A sweep file (``bench sweep SWEEP.toml``): a base scenario, axes over any of its keys, what to
collect, what to keep. Every error names the file, the table and the field.

    [sweep]
    name = "observers_speed_load"
    base = "gong_g2_500rpm"          # a bundled scenario name or a path
    link = "sil"                     # any --link (default sil)
    time_limit_s = 300               # per run: a run still going is ended and marked
    max_runs = 20000                 # refuse a sweep of more runs (default MAX_RUNS)
    record = "none"                  # none | decimated | failed (keep only what did not pass)
    decimate = 10                    # record = "decimated": every 10th cycle is kept

    [overrides]                      # every run: dotted scenario keys
    "scenario.duration_s" = 2.5

    [[axes]]                         # a list of values
    name = "observer"                # the column (default: the key)
    key = "controller.estimator"
    values = ["SMO_SIGN", "SMO_TANH"]

    [[axes]]                         # a range: [start, stop, num] (linspace; log = true: geomspace)
    name = "speed_rpm"
    key = "controller.speed_ref_rpm"
    range = [5, 3000, 8]
    log = true

    [[axes]]                         # several keys move together; relative: x the base value
    name = "ls_factor"               # (the scenario's, else the profile's for plant.* keys)
    keys = ["plant.ld_h", "plant.lq_h"]
    values = [0.8, 1.0, 1.2]
    relative = true

    [[axes]]                         # scale: the scenario value is the axis value x scale
    name = "load_pct"
    key = "events[1].load_torque_nm"
    values = [0, 50, 100]
    scale = 0.05

    [sampling]                       # grid (default: every combination), or a seeded sample of
    method = "lhs"                   # n points: lhs (Latin hypercube) | sobol (scipy.stats.qmc);
    n = 64                           # a range axis is then continuous in [start, stop], a values
    seed = 1                         # axis picks one of its values

    [collect]
    metrics = ["pee_rms_rad", "speed_est_error_rpm"]   # bench check's summary or claims.METRICS
    claims = ["G2"]                                    # their quantities, measured and verdict

    [quick]                          # --quick: a coarse version
    axes = {speed_rpm = [50, 1000], load_pct = [0, 100]}
    n = 8
    overrides = {"scenario.duration_s" = 1.5}

    [plots]                          # optional: the axes of the heat maps / curves
    x = "speed_rpm"
    y = "load_pct"
    facet = "observer"
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hil_bench.scenario import ScenarioError, check_against_profile, parse_scenario, tomlw
from hil_bench.scenario.scenario import load_scenario, resolve_path

SWEEP_DIR = Path(__file__).resolve().parents[1] / "sweeps"
RECORD_POLICIES = ("none", "decimated", "failed")
METHODS = ("grid", "lhs", "sobol")
#: the most runs a sweep may have unless its file says ``max_runs``: every run's scenario is
#: derived and checked before the first one starts, and 20 000 runs take about 30 s of CPU and
#: a 74 MB process to derive (measured: docs/sweeps.md, "How many runs"); at 0.3 s of CPU per
#: 2 s SIL run (the bundled quick sweep's median) the runs are 1.7 CPU hours. A count far
#: beyond is a typo (``n = 1e9``, a range's num) far more often than a plan, and it would only
#: be found after minutes of deriving
MAX_RUNS = 20_000
SWEEP_FIELDS = ("name", "description", "base", "link", "time_limit_s", "record", "decimate",
                "max_runs")


class SweepError(ValueError):
    """A sweep file that cannot run: the message names the file and the field."""


@dataclass
class Axis:
    name: str
    keys: tuple[str, ...]
    values: list[Any] | None = None      # discrete values
    start: float | None = None           # a range
    stop: float | None = None
    num: int = 0
    log: bool = False
    relative: bool = False
    scale: float = 1.0

    @property
    def count(self) -> int:
        return len(self.values) if self.values is not None else self.num

    @property
    def kind(self) -> str:
        """The type of its column in the table: bool, int, float or text."""
        if self.values is None:
            return "float"
        if all(isinstance(v, bool) for v in self.values):
            return "bool"
        if all(isinstance(v, int) and not isinstance(v, bool) for v in self.values):
            return "int"
        if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in self.values):
            return "float"
        return "text"

    def definition(self) -> dict[str, Any]:
        """What the axis is, for the sweep's identity."""
        return {"name": self.name, "keys": list(self.keys), "values": self.values,
                "range": None if self.values is not None else [self.start, self.stop, self.num],
                "log": self.log, "relative": self.relative, "scale": self.scale}

    def grid(self) -> list[Any]:
        if self.values is not None:
            return list(self.values)
        import numpy as np

        space = np.geomspace if self.log else np.linspace
        return [float(v) for v in space(self.start, self.stop, self.num)]

    def at(self, u: float) -> Any:
        """The axis value at u in [0, 1) (a sample's coordinate)."""
        if self.values is not None:
            return self.values[min(int(u * len(self.values)), len(self.values) - 1)]
        if self.log:
            return float(math.exp(math.log(self.start) + u * (math.log(self.stop) - math.log(self.start))))
        return float(self.start + u * (self.stop - self.start))

    @property
    def numeric(self) -> bool:
        return self.kind in ("int", "float")


@dataclass
class Point:
    """One run of the sweep: its axis values, the derived scenario's text and hash."""
    index: int
    inputs: dict[str, Any]
    scenario_text: str
    scenario_hash: str


@dataclass
class Sweep:
    path: Path
    name: str
    description: str
    base: str
    link: str
    time_limit_s: float
    record: str
    decimate: int
    overrides: dict[str, Any]
    axes: list[Axis]
    method: str
    n: int
    seed: int
    metrics: list[str]
    claims: list[str]
    plots: dict[str, str] = field(default_factory=dict)
    quick: bool = False
    max_runs: int = MAX_RUNS
    points: list[Point] = field(default_factory=list)
    #: hash of the base scenario's content and of the profile it names (set with the points)
    base_hash: str = ""

    @property
    def planned_runs(self) -> int:
        """How many runs the file asks for (before any is derived)."""
        if self.method != "grid":
            return self.n
        return math.prod(a.count for a in self.axes)

    def identity(self) -> dict[str, str]:
        """What makes this sweep this experiment, part by part (each a short hash): two sweeps
        whose parts are all equal run the same runs and collect the same columns. The time
        limit is not a part (each row says the limit it ran under)."""
        parts = {
            "name": self.name,
            "base scenario": self.base_hash,
            "overrides": self.overrides,
            "axes": [a.definition() for a in self.axes],
            "sampling": {"method": self.method} if self.method == "grid" else
                        {"method": self.method, "n": self.n, "seed": self.seed},
            "collect": {"metrics": self.metrics, "claims": self.claims},
            "link": self.link,
            "record": {"record": self.record,
                       "decimate": self.decimate if self.record == "decimated" else None},
        }
        return {k: _digest(v) for k, v in parts.items()}

    @property
    def sweep_id(self) -> str:
        return _digest(self.identity())


def _digest(value: Any) -> str:
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _where(path: Path, table: str) -> str:
    return f"{path}: [{table}]"


def _get(doc: dict, dotted: str) -> Any:
    node: Any = doc
    for p in dotted.split("."):
        m = tomlw._INDEXED.match(p)
        if m:
            items = node.get(m.group(1)) if isinstance(node, dict) else None
            i = int(m.group(2))
            node = items[i] if isinstance(items, list) and i < len(items) else None
        else:
            node = node.get(p) if isinstance(node, dict) else None
        if node is None:
            return None
    return node


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _number(where: str, name: str, v: Any, *, positive: bool = False, integer: bool = False,
            nonnegative: bool = False) -> float | int:
    """A finite number (TOML's nan and inf refused); ``integer``: a whole number, ``1e9`` too."""
    if not _is_number(v) or not math.isfinite(v):
        raise SweepError(f"{where}: {name} = {v!r}: must be a finite number")
    if integer:
        if int(v) != v:
            raise SweepError(f"{where}: {name} = {v!r}: must be a whole number")
        v = int(v)
    if positive and v <= 0:
        raise SweepError(f"{where}: {name} = {v!r}: must be > 0")
    if nonnegative and v < 0:
        raise SweepError(f"{where}: {name} = {v!r}: must be >= 0")
    return v


def _flag(where: str, name: str, v: Any) -> bool:
    if not isinstance(v, bool):
        raise SweepError(f"{where}: {name} = {v!r}: must be true or false")
    return v


def _table(p: Path, doc: dict, name: str) -> dict:
    t = doc.get(name, {})
    if not isinstance(t, dict):
        raise SweepError(f"{p}: {name} must be a table [{name}], got {t!r}")
    return t


def _known(where: str, t: dict, known) -> None:
    unknown = sorted(set(t) - set(known))
    if unknown:
        raise SweepError(f"{where}: unknown field {unknown[0]!r} (fields: {', '.join(sorted(known))})")


def _values(where: str, values: Any) -> list[Any]:
    if not isinstance(values, list) or not values:
        raise SweepError(f"{where}: values must be a non-empty list")
    for v in values:
        if isinstance(v, float) and not math.isfinite(v):
            raise SweepError(f"{where}: values: {v!r} is not a finite number")
        if not isinstance(v, (bool, int, float, str, list, dict)):
            raise SweepError(f"{where}: values: {v!r}: each value must be a number, a string, "
                             f"true/false, an array or a table")
    return list(values)


def _axis(path: Path, i: int, t: dict) -> Axis:
    where = f"{path}: axes[{i}]"
    if not isinstance(t, dict):
        raise SweepError(f"{where}: must be a table [[axes]]")
    known = {"name", "key", "keys", "values", "range", "log", "relative", "scale"}
    _known(where, t, known)
    keys = t.get("keys", [t["key"]] if "key" in t else [])
    if isinstance(keys, str):
        keys = [keys]
    if not isinstance(keys, list) or not keys or not all(isinstance(k, str) and k for k in keys):
        raise SweepError(f"{where}: give key = \"table.field\" (or keys = [...]): the scenario "
                         f"key(s) this axis sets")
    name = t.get("name", keys[0])
    if not isinstance(name, str) or not name:
        raise SweepError(f"{where}: name = {name!r}: must be a non-empty string")
    where = f"{where} ({name})"
    ax = Axis(name=name, keys=tuple(keys), log=_flag(where, "log", t.get("log", False)),
              relative=_flag(where, "relative", t.get("relative", False)),
              scale=float(_number(where, "scale", t.get("scale", 1.0))))
    if ("values" in t) == ("range" in t):
        raise SweepError(f"{where}: give values = [...] or range = [start, stop, num]")
    if "values" in t:
        ax.values = _values(where, t["values"])
    else:
        r = t["range"]
        if not isinstance(r, list) or len(r) != 3:
            raise SweepError(f"{where}: range = [start, stop, num] with num >= 1")
        ax.start = float(_number(where, "range start", r[0]))
        ax.stop = float(_number(where, "range stop", r[1]))
        ax.num = int(_number(where, "range num", r[2], positive=True, integer=True))
        if ax.log and not (ax.start > 0 and ax.stop > 0):
            raise SweepError(f"{where}: log = true needs start and stop > 0")
    if (ax.relative or ax.scale != 1.0) and not ax.numeric:
        raise SweepError(f"{where}: relative / scale need numeric values")
    return ax


def check_link(where: str, link: Any) -> str:
    """A link spec the runs can open (its grammar: hil_bench.loop.links.open_link), checked
    before anything runs; the device itself is opened by each run on its worker."""
    from hil_bench.loop.links import (STUB_CAN_MODES, LinkError, parse_can_spec,
                                      parse_serial_spec, parse_stub_can_spec)

    if not isinstance(link, str):
        raise SweepError(f"{where}: link = {link!r}: must be a string (e.g. \"sil\")")
    m = re.fullmatch(r"([a-z][a-z0-9-]*)(.*)", link, re.S)
    kind, tail = (m.group(1), m.group(2)) if m else ("", link)
    try:
        if kind in ("stub", "sil") and not tail:
            return link
        if kind in STUB_CAN_MODES:
            parse_stub_can_spec(kind, tail, link)
            return link
        if kind == "pil-qemu" and (not tail or (tail.startswith(":") and len(tail) > 1)):
            return link
        if kind == "serial" and tail.startswith(":") and len(tail) > 1:
            parse_serial_spec(tail[1:])
            return link
        if kind == "can" and (not tail or tail[0] in ":@,"):
            parse_can_spec(link)
            return link
    except LinkError as exc:
        raise SweepError(f"{where}: link = {link!r}: {exc}") from None
    raise SweepError(f"{where}: link = {link!r}: unknown link; one of stub, sil, "
                     f"serial:<port>[@baud], can:<interface>:<channel>[@bitrate], stub-slcan, "
                     f"stub-socketcand, stub-socketcan[:<iface>], pil-qemu[:<elf>]")


def load_sweep(path: str | Path, quick: bool = False) -> Sweep:
    """Parse a sweep file and derive (and validate) every run's scenario."""
    p = Path(path)
    if not p.exists() and (SWEEP_DIR / f"{path}.toml").exists():
        p = SWEEP_DIR / f"{path}.toml"
    try:
        doc = tomllib.loads(p.read_text())
    except OSError as exc:
        raise SweepError(f"{p}: cannot read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise SweepError(f"{p}: not a text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"{p}: not valid TOML: {exc}") from None
    known = {"sweep", "overrides", "axes", "sampling", "collect", "quick", "plots"}
    for k in doc:
        if k not in known:
            raise SweepError(f"{p}: unknown table [{k}] (tables: {', '.join(sorted(known))})")
    s = _table(p, doc, "sweep")
    where = _where(p, "sweep")
    _known(where, s, SWEEP_FIELDS)
    if "name" not in s or "base" not in s:
        raise SweepError(f"{where}: needs name and base (a scenario)")
    for k in ("name", "base", "description"):
        if k in s and not (isinstance(s[k], str) and (s[k] or k == "description")):
            raise SweepError(f"{where}: {k} = {s[k]!r}: must be a non-empty string")
    if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", s["name"]):
        raise SweepError(f"{where}: name = {s['name']!r}: letters, digits, _ . - only (it names "
                         f"the sweep's folder and every run's recording)")
    record = s.get("record", "none")
    if record not in RECORD_POLICIES:
        raise SweepError(f"{where}: record = {record!r}: one of "
                         f"{', '.join(RECORD_POLICIES)}")
    axes_doc = doc.get("axes", [])
    if not isinstance(axes_doc, list):
        raise SweepError(f"{p}: axes must be tables [[axes]]")
    axes = [_axis(p, i, t) for i, t in enumerate(axes_doc)]
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise SweepError(f"{p}: two axes named alike ({names}): give each a name")
    sampling = _table(p, doc, "sampling")
    _known(_where(p, "sampling"), sampling, ("method", "n", "seed"))
    method = sampling.get("method", "grid")
    if method not in METHODS:
        raise SweepError(f"{_where(p, 'sampling')}: method = {method!r}: one of {', '.join(METHODS)}")
    collect = _table(p, doc, "collect")
    _known(_where(p, "collect"), collect, ("metrics", "claims"))
    for k in ("metrics", "claims"):
        if k in collect and not (isinstance(collect[k], list)
                                 and all(isinstance(x, str) for x in collect[k])):
            raise SweepError(f"{_where(p, 'collect')}: {k} must be a list of names")
    overrides = _table(p, doc, "overrides")
    plots = _table(p, doc, "plots")
    _known(_where(p, "plots"), plots, ("x", "y", "facet"))
    for k, v in plots.items():
        if v not in names:
            raise SweepError(f"{_where(p, 'plots')}: {k} = {v!r}: not an axis ({', '.join(names)})")
    sw = Sweep(path=p, name=s["name"], description=str(s.get("description", "")),
               base=s["base"], link=check_link(where, s.get("link", "sil")),
               time_limit_s=float(_number(where, "time_limit_s", s.get("time_limit_s", 600.0),
                                          positive=True)),
               record=record,
               decimate=int(_number(where, "decimate", s.get("decimate", 10), positive=True,
                                    integer=True)),
               overrides=dict(overrides), axes=axes, method=method,
               n=int(_number(_where(p, "sampling"), "n", sampling.get("n", 0), integer=True)),
               seed=int(_number(_where(p, "sampling"), "seed", sampling.get("seed", 1),
                                integer=True, nonnegative=True)),
               metrics=list(collect.get("metrics", ["pee_rms_rad", "pee_max_rad"])),
               claims=[str(c).upper() for c in collect.get("claims", [])],
               plots={k: str(v) for k, v in plots.items()}, quick=quick,
               max_runs=int(_number(where, "max_runs", s.get("max_runs", MAX_RUNS),
                                    positive=True, integer=True)))
    if method != "grid" and sw.n < 1:
        raise SweepError(f"{_where(p, 'sampling')}: method = {method!r} needs n >= 1")
    if quick:
        q = _table(p, doc, "quick")
        wq = _where(p, "quick")
        _known(wq, q, ("axes", "n", "overrides"))
        for k in ("axes", "overrides"):
            if not isinstance(q.get(k, {}), dict):
                raise SweepError(f"{wq}: {k} must be a table")
        for name, values in q.get("axes", {}).items():
            ax = next((a for a in axes if a.name == name), None)
            if ax is None:
                raise SweepError(f"{wq}: axes.{name}: no such axis ({', '.join(names)})")
            ax.values, ax.start, ax.stop, ax.num = _values(f"{wq}: axes.{name}", values), None, None, 0
            if (ax.relative or ax.scale != 1.0) and not ax.numeric:
                raise SweepError(f"{wq}: axes.{name}: relative / scale need numeric values")
        if "n" in q:
            sw.n = int(_number(wq, "n", q["n"], positive=True, integer=True))
        sw.overrides.update(q.get("overrides", {}))
    runs = sw.planned_runs
    if runs > sw.max_runs:
        shape = (" x ".join(f"{a.count:,}" for a in axes) + " grid") if method == "grid" else \
            f"[sampling] n = {sw.n:,}"
        raise SweepError(f"{p}: {runs:,} runs ({shape}) is more than the limit of "
                         f"{sw.max_runs:,} runs per sweep (every run's scenario is derived "
                         f"before the first starts: docs/sweeps.md); split the sweep, sample "
                         f"it ([sampling] n), or raise [sweep] max_runs")
    _check_collect(sw)
    sw.points = _points(sw)
    return sw


def _check_collect(sw: Sweep) -> None:
    from hil_bench.claims.registry import CLAIMS
    from hil_bench.papers.claims import METRICS

    summary = {"speed_mean_rpm", "speed_band_true_rpm", "iq_mean_a", "speed_hat_mean_rpm",
               "speed_band_hat_rpm", "pee_max_rad", "pee_mean_rad", "pee_rms_rad"}
    for m in sw.metrics:
        if m not in summary and m not in METRICS:
            raise SweepError(f"{_where(sw.path, 'collect')}: metrics: unknown {m!r}; the summary's "
                             f"({', '.join(sorted(summary))}) or bench claims' metrics "
                             f"({', '.join(sorted(METRICS))})")
    for c in sw.claims:
        if c not in CLAIMS:
            raise SweepError(f"{_where(sw.path, 'collect')}: claims: unknown {c!r} ({', '.join(CLAIMS)})")


def _samples(sw: Sweep) -> list[dict[str, Any]]:
    if not sw.axes:
        return [{}]
    if sw.method == "grid":
        return [dict(zip([a.name for a in sw.axes], combo))
                for combo in itertools.product(*(a.grid() for a in sw.axes))]
    from hil_bench.installation import require_extra

    qmc = require_extra(f"a sweep's [sampling] method = \"{sw.method}\"", "scipy.stats.qmc",
                        extra="cluster")

    d = len(sw.axes)
    if sw.method == "lhs":
        u = qmc.LatinHypercube(d=d, seed=sw.seed).random(sw.n)
    else:
        sob = qmc.Sobol(d=d, scramble=True, seed=sw.seed)
        m = int(math.log2(sw.n))
        u = sob.random_base2(m) if 2 ** m == sw.n else sob.random(sw.n)
    return [{a.name: a.at(float(row[j])) for j, a in enumerate(sw.axes)} for row in u]


def scenario_hash(text: str, link: str, profile_text: str) -> str:
    """What a run's result depends on: the full derived scenario, the profile it names, the link."""
    h = hashlib.sha256()
    for part in (text, profile_text, link):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


def _points(sw: Sweep) -> list[Point]:
    from hil_bench.plant_rt.profile import load_profile

    base_path = resolve_path(sw.base)
    try:
        base = load_scenario(base_path)
    except ScenarioError as exc:
        raise SweepError(f"{sw.path}: [sweep] base = {sw.base!r}: {exc}") from None
    doc = base.raw
    for key, value in sw.overrides.items():
        try:
            doc = tomlw.set_dotted(doc, key, value)
        except ValueError as exc:
            raise SweepError(f"{_where(sw.path, 'overrides')}: {exc}") from None
    profile = load_profile(base.profile)
    profile_text = Path(profile.path).read_text()
    sw.base_hash = scenario_hash(tomlw.dumps(base.raw), "", profile_text)
    points = []
    for i, inputs in enumerate(_samples(sw)):
        d = doc
        for ax in sw.axes:
            v = inputs[ax.name]
            for key in ax.keys:
                value = v
                if ax.relative:
                    ref = _get(d, key)
                    if ref is None and key.startswith("plant."):
                        ref = getattr(profile, key.split(".", 1)[1], None)
                    if not isinstance(ref, (int, float)):
                        raise SweepError(f"{sw.path}: axes {ax.name}: relative: {key} has no base "
                                         f"value in the scenario or its profile")
                    value = float(ref) * float(v)
                elif ax.scale != 1.0:
                    value = float(v) * ax.scale
                try:
                    d = tomlw.set_dotted(d, key, value)
                except ValueError as exc:
                    raise SweepError(f"{sw.path}: axes {ax.name}: {exc}") from None
        d = tomlw.set_dotted(d, "scenario.name", f"{sw.name}_{i:05d}")
        if sw.record == "decimated":
            d = tomlw.set_dotted(d, "recording.decimate", sw.decimate)
        if sw.claims:
            d = tomlw.set_dotted(d, "scenario.claims", list(sw.claims))
        try:
            body = tomlw.dumps(d)
        except (TypeError, ValueError) as exc:
            raise SweepError(f"{sw.path}: run {i} ({json.dumps(inputs)}): {exc}") from None
        text = (f"# sweep {sw.name} ({sw.path.name}), run {i}: "
                + ", ".join(f"{k} = {v!r}" for k, v in inputs.items()) + "\n" + body)
        try:
            scn = parse_scenario(text, base_path.with_name(f"{sw.name}_{i:05d}.toml"))
            check_against_profile(scn)
        except (ScenarioError, ValueError) as exc:
            raise SweepError(f"{sw.path}: run {i} ({json.dumps(inputs)}): {exc}") from None
        points.append(Point(i, inputs, text, scenario_hash(body.replace(
            f"{sw.name}_{i:05d}", sw.name), sw.link, profile_text)))
    return points
