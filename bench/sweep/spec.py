"""A sweep file (``bench sweep SWEEP.toml``): a base scenario, axes over any of its keys, what to
collect, what to keep. Every error names the file, the table and the field.

    [sweep]
    name = "observers_speed_load"
    base = "gong_g2_500rpm"          # a bundled scenario name or a path
    link = "sil"                     # any --link (default sil)
    time_limit_s = 300               # per run: a run still going is ended and marked
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
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hil_bench.scenario import ScenarioError, check_against_profile, parse_scenario, tomlw
from hil_bench.scenario.scenario import load_scenario, resolve_path

SWEEP_DIR = Path(__file__).resolve().parents[1] / "sweeps"
RECORD_POLICIES = ("none", "decimated", "failed")
METHODS = ("grid", "lhs", "sobol")


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
        return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in self.grid())


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
    points: list[Point] = field(default_factory=list)


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


def _axis(path: Path, i: int, t: dict) -> Axis:
    where = f"{path}: axes[{i}]"
    known = {"name", "key", "keys", "values", "range", "log", "relative", "scale"}
    unknown = sorted(set(t) - known)
    if unknown:
        raise SweepError(f"{where}: unknown field {unknown[0]!r} (fields: {', '.join(sorted(known))})")
    keys = t.get("keys", [t["key"]] if "key" in t else [])
    if isinstance(keys, str):
        keys = [keys]
    if not keys or not all(isinstance(k, str) and k for k in keys):
        raise SweepError(f"{where}: give key = \"table.field\" (or keys = [...]): the scenario "
                         f"key(s) this axis sets")
    name = t.get("name", keys[0])
    ax = Axis(name=str(name), keys=tuple(keys), log=bool(t.get("log", False)),
              relative=bool(t.get("relative", False)), scale=float(t.get("scale", 1.0)))
    if ("values" in t) == ("range" in t):
        raise SweepError(f"{where} ({name}): give values = [...] or range = [start, stop, num]")
    if "values" in t:
        if not isinstance(t["values"], list) or not t["values"]:
            raise SweepError(f"{where} ({name}): values must be a non-empty list")
        ax.values = list(t["values"])
    else:
        r = t["range"]
        if (not isinstance(r, list) or len(r) != 3 or not all(isinstance(v, (int, float)) for v in r)
                or int(r[2]) != r[2] or r[2] < 1):
            raise SweepError(f"{where} ({name}): range = [start, stop, num] with num >= 1")
        ax.start, ax.stop, ax.num = float(r[0]), float(r[1]), int(r[2])
        if ax.log and not (ax.start > 0 and ax.stop > 0):
            raise SweepError(f"{where} ({name}): log = true needs start and stop > 0")
    if (ax.relative or ax.scale != 1.0) and not ax.numeric:
        raise SweepError(f"{where} ({name}): relative / scale need numeric values")
    return ax


def load_sweep(path: str | Path, quick: bool = False) -> Sweep:
    """Parse a sweep file and derive (and validate) every run's scenario."""
    p = Path(path)
    if not p.exists() and (SWEEP_DIR / f"{path}.toml").exists():
        p = SWEEP_DIR / f"{path}.toml"
    try:
        doc = tomllib.loads(p.read_text())
    except OSError as exc:
        raise SweepError(f"{p}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"{p}: not valid TOML: {exc}") from None
    known = {"sweep", "overrides", "axes", "sampling", "collect", "quick", "plots"}
    for k in doc:
        if k not in known:
            raise SweepError(f"{p}: unknown table [{k}] (tables: {', '.join(sorted(known))})")
    s = doc.get("sweep", {})
    if "name" not in s or "base" not in s:
        raise SweepError(f"{_where(p, 'sweep')}: needs name and base (a scenario)")
    record = s.get("record", "none")
    if record not in RECORD_POLICIES:
        raise SweepError(f"{_where(p, 'sweep')}: record = {record!r}: one of "
                         f"{', '.join(RECORD_POLICIES)}")
    axes = [_axis(p, i, t) for i, t in enumerate(doc.get("axes", []))]
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise SweepError(f"{p}: two axes named alike ({names}): give each a name")
    sampling = doc.get("sampling", {})
    method = sampling.get("method", "grid")
    if method not in METHODS:
        raise SweepError(f"{_where(p, 'sampling')}: method = {method!r}: one of {', '.join(METHODS)}")
    collect = doc.get("collect", {})
    sw = Sweep(path=p, name=str(s["name"]), description=str(s.get("description", "")),
               base=str(s["base"]), link=str(s.get("link", "sil")),
               time_limit_s=float(s.get("time_limit_s", 600.0)), record=record,
               decimate=int(s.get("decimate", 10)), overrides=dict(doc.get("overrides", {})),
               axes=axes, method=method, n=int(sampling.get("n", 0)),
               seed=int(sampling.get("seed", 1)),
               metrics=list(collect.get("metrics", ["pee_rms_rad", "pee_max_rad"])),
               claims=[str(c).upper() for c in collect.get("claims", [])],
               plots={k: str(v) for k, v in doc.get("plots", {}).items()}, quick=quick)
    if method != "grid" and sw.n < 1:
        raise SweepError(f"{_where(p, 'sampling')}: method = {method!r} needs n >= 1")
    if quick:
        q = doc.get("quick", {})
        for name, values in q.get("axes", {}).items():
            ax = next((a for a in axes if a.name == name), None)
            if ax is None:
                raise SweepError(f"{_where(p, 'quick')}: axes.{name}: no such axis ({', '.join(names)})")
            ax.values, ax.start, ax.stop, ax.num = list(values), None, None, 0
        sw.n = int(q.get("n", sw.n))
        sw.overrides.update(q.get("overrides", {}))
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
    from scipy.stats import qmc

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
        body = tomlw.dumps(d)
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
