"""Plots of a sweep's table: per metric a heat map over two axes (or curves over one), one panel
per value of a categorical axis, PNG, and one self-contained HTML page with all of them (the
images inline) and the run counts. A cell averages the runs that share its x and y (the other
axes) and prints its value; a run that did not end "ok" has no value there: a cell without any
is grey and prints what its runs ended in (fault, timeout, ...). Numeric axes are in numeric
order. Every file is written aside and renamed into place (hil_bench.record.atomic)."""
from __future__ import annotations

import base64
import html
from pathlib import Path

from hil_bench.record.atomic import write_text_aside, written_aside

from .spec import Sweep

#: a heat map prints its values when it has at most this many rows and columns (beyond, the
#: text would not fit its cells)
ANNOTATE_MAX = 24
#: what a grey cell prints: the commonest status of its runs
_SHORT = {"controller_fault": "fault", "ended": "ended", "timeout": "timeout", "error": "error"}


def axis_order(sw: Sweep, name: str, values) -> list:
    """An axis's distinct values in order: numeric axes as numbers, the others as the file lists
    them (then as text)."""
    vals = [v for v in dict.fromkeys(values) if v is not None and v == v]
    ax = next((a for a in sw.axes if a.name == name), None)
    if ax is not None and ax.numeric:
        return sorted(vals, key=float)
    listed = {v: i for i, v in enumerate(ax.values or [])} if ax is not None else {}
    return sorted(vals, key=lambda v: (listed.get(v, len(listed)), str(v)))


def _label(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _cell_text(v: float) -> str:
    return f"{v:.3g}"


def _axes_of(sw: Sweep, df) -> tuple[str | None, str | None, str | None]:
    numeric = [a.name for a in sw.axes if a.numeric and df[f"in.{a.name}"].nunique() > 1]
    other = [a.name for a in sw.axes if not a.numeric]
    x = sw.plots.get("x") or (numeric[0] if numeric else None)
    y = sw.plots.get("y") or next((n for n in numeric if n != x), None)
    facet = sw.plots.get("facet") or next((n for n in other if n not in (x, y)), None)
    return x, y, facet


def metric_columns(sw: Sweep, df) -> list[str]:
    cols = [m for m in sw.metrics if m in df.columns]
    cols += [c for c in df.columns if c.endswith(".measured")]
    return cols


def plot_sweep(sw: Sweep, rows: list[dict], out_dir: Path, timing: dict | None = None) -> list[Path]:
    import numpy as np

    from hil_bench.installation import require_extra

    matplotlib = require_extra("bench sweep's plots", "matplotlib", "pandas")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    df = pd.DataFrame(rows)
    if df.empty:
        return []
    plot_dir = out_dir / "plots"
    plot_dir.mkdir(parents=True, exist_ok=True)
    x, y, facet = _axes_of(sw, df)
    facets = axis_order(sw, facet, df[f"in.{facet}"].tolist()) if facet else [None]
    ok = df["status"] == "ok"
    paths = []
    for col in metric_columns(sw, df):
        vals = pd.to_numeric(df[col], errors="coerce").where(ok)
        fig, axs = plt.subplots(1, len(facets), figsize=(4.2 * len(facets) + 1.2, 3.6),
                                squeeze=False, constrained_layout=True)
        finite = vals[np.isfinite(vals)]
        vmin, vmax = (float(finite.min()), float(finite.max())) if len(finite) else (0.0, 1.0)
        image = None
        for ax, fv in zip(axs[0], facets):
            sel = df[f"in.{facet}"] == fv if facet else np.ones(len(df), bool)
            sub = df[sel].assign(_v=vals[sel])
            if x and y and sw.method == "grid":
                xs = axis_order(sw, x, df[f"in.{x}"].tolist())
                ys = axis_order(sw, y, df[f"in.{y}"].tolist())
                grid = sub.groupby([f"in.{y}", f"in.{x}"])["_v"].mean().unstack()
                grid = grid.reindex(index=ys, columns=xs)
                image = ax.imshow(grid.values.astype(float), origin="lower", aspect="auto",
                                  cmap="viridis", vmin=vmin, vmax=vmax)
                ax.set_facecolor("0.8")
                ax.set_xticks(range(len(xs)), [_label(v) for v in xs], rotation=45, fontsize=7)
                ax.set_yticks(range(len(ys)), [_label(v) for v in ys], fontsize=7)
                ax.set_xlabel(x)
                ax.set_ylabel(y)
                if len(xs) <= ANNOTATE_MAX and len(ys) <= ANNOTATE_MAX:
                    _annotate(ax, grid, sub, x, y, image)
            elif x and y:
                image = ax.scatter(sub[f"in.{x}"], sub[f"in.{y}"], c=sub["_v"], cmap="viridis",
                                   vmin=vmin, vmax=vmax, s=18)
                ax.set_xlabel(x)
                ax.set_ylabel(y)
            elif x:
                line = sub.groupby(f"in.{x}")["_v"].mean()
                ax.plot(line.index, line.values, "o-")
                ax.set_xlabel(x)
                ax.set_ylabel(col)
            else:
                ax.bar(range(len(sub)), sub["_v"])
            ax.set_title(f"{facet} = {fv}" if facet else sw.name, fontsize=9)
        if image is not None:
            fig.colorbar(image, ax=list(axs[0]), label=col, shrink=0.9)
        fig.suptitle(f"{sw.name}: {col} (mean over the other axes; grey: no run ended ok)",
                     fontsize=9)
        path = plot_dir / f"{col.replace('/', '_')}.png"
        try:
            with written_aside(path) as tmp:
                fig.savefig(tmp, dpi=110, format="png")
        finally:
            plt.close(fig)
        paths.append(path)
    _html(sw, df, out_dir, paths, timing or {})
    return paths


def _annotate(ax, grid, sub, x: str, y: str, image) -> None:
    """Each cell's value (dark text on light colours, light on dark); a grey cell: what its
    runs ended in."""
    import math

    size = 7 if grid.shape[1] <= 8 else 6 if grid.shape[1] <= 14 else 5
    for i, yv in enumerate(grid.index):
        for j, xv in enumerate(grid.columns):
            v = grid.iat[i, j]
            if v is not None and math.isfinite(v):
                r, g, b, _ = image.cmap(image.norm(v))
                light = 0.299 * r + 0.587 * g + 0.114 * b > 0.5
                ax.text(j, i, _cell_text(v), ha="center", va="center", fontsize=size,
                        color="black" if light else "white")
            else:
                runs = sub[(sub[f"in.{y}"] == yv) & (sub[f"in.{x}"] == xv)]["status"]
                if len(runs):
                    st = runs.value_counts().index[0]
                    ax.text(j, i, _SHORT.get(st, st), ha="center", va="center", fontsize=size,
                            color="0.25")


def _html(sw: Sweep, df, out_dir: Path, paths: list[Path], timing: dict) -> Path:
    e = html.escape
    counts = df["status"].value_counts().to_dict()
    cpu = df["cpu_s"].dropna() if "cpu_s" in df else []
    parts = [f"<!doctype html><meta charset='utf-8'><title>{e(sw.name)}</title>",
             "<style>body{font-family:sans-serif;max-width:1400px;margin:1em auto}"
             "td,th{padding:2px 8px;text-align:left}img{max-width:100%}</style>",
             f"<h1>Sweep {e(sw.name)}</h1><p>{e(sw.description)}</p>",
             f"<p>{len(df)} runs over {e(sw.link)} from {e(sw.base)}"
             + (" (--quick)" if sw.quick else "") + ": "
             + ", ".join(f"{n} {e(str(s))}" for s, n in counts.items())
             + (f"; CPU per run median {float(cpu.median()):.2f} s, total {float(cpu.sum()):.0f} s"
                if len(cpu) else "")
             + (f"; wall {timing['wall_s']:.0f} s on {e(timing.get('where', ''))}"
                if timing.get("wall_s") else "") + ".</p>",
             "<table><tr><th>axis</th><th>keys</th><th>values</th></tr>"]
    for a in sw.axes:
        vals = axis_order(sw, a.name, df[f"in.{a.name}"].tolist())
        shown = ", ".join(_label(v) for v in vals[:12])
        parts.append(f"<tr><td>{e(a.name)}</td><td>{e(', '.join(a.keys))}"
                     f"{' (x base)' if a.relative else ''}{f' (x {a.scale:g})' if a.scale != 1 else ''}"
                     f"</td><td>{e(shown)}{' ...' if len(vals) > 12 else ''}</td></tr>")
    parts.append("</table>")
    for p in paths:
        data = base64.b64encode(p.read_bytes()).decode()
        parts.append(f"<h2>{e(p.stem)}</h2><img src='data:image/png;base64,{data}'>")
    bad = df[df["status"] != "ok"]
    if len(bad):
        parts.append("<h2>Runs that did not end ok</h2><table><tr><th>index</th><th>inputs</th>"
                     "<th>status</th><th>error</th></tr>")
        for _, r in bad.head(200).iterrows():
            ins = ", ".join(f"{a.name}={r[f'in.{a.name}']}" for a in sw.axes)
            err = str(r.get("error") or "")
            parts.append(f"<tr><td>{r['index']}</td><td>{e(ins)}</td><td>{e(str(r['status']))}"
                         f"</td><td>{e(err.splitlines()[0] if err else '')}</td></tr>")
        parts.append("</table>")
    path = out_dir / "report.html"
    write_text_aside(path, "\n".join(parts))
    return path


__all__ = ["plot_sweep", "metric_columns", "axis_order"]
