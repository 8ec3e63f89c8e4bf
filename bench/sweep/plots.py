"""Plots of a sweep's table: per metric a heat map over two axes (or curves over one), one panel
per value of a categorical axis, PNG, and one self-contained HTML page with all of them (the
images inline) and the run counts. A cell averages the runs that share its x and y (the other
axes); a run that did not end "ok" has no value there: a cell without any is grey."""
from __future__ import annotations

import base64
import html
from pathlib import Path

from .spec import Sweep


def _axes_of(sw: Sweep, df) -> tuple[str | None, str | None, str | None]:
    numeric = [a.name for a in sw.axes if a.numeric and df[f"in.{a.name}"].nunique() > 1]
    other = [a.name for a in sw.axes if not a.numeric]
    x = sw.plots.get("x") or (numeric[0] if numeric else None)
    y = sw.plots.get("y") or next((n for n in numeric if n != x), None)
    facet = sw.plots.get("facet") or (other[0] if other else None)
    return x, y, facet


def metric_columns(sw: Sweep, df) -> list[str]:
    cols = [m for m in sw.metrics if m in df.columns]
    cols += [c for c in df.columns if c.endswith(".measured")]
    return cols


def plot_sweep(sw: Sweep, rows: list[dict], out_dir: Path, timing: dict | None = None) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    import pandas as pd

    df = pd.DataFrame(rows)
    if df.empty:
        return []
    plot_dir = out_dir / "plots"
    plot_dir.mkdir(parents=True, exist_ok=True)
    x, y, facet = _axes_of(sw, df)
    facets = sorted(df[f"in.{facet}"].dropna().unique(), key=str) if facet else [None]
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
                grid = sub.groupby([f"in.{y}", f"in.{x}"])["_v"].mean().unstack()
                image = ax.imshow(grid.values.astype(float), origin="lower", aspect="auto",
                                  cmap="viridis", vmin=vmin, vmax=vmax)
                ax.set_facecolor("0.8")
                ax.set_xticks(range(len(grid.columns)), [f"{v:g}" for v in grid.columns],
                              rotation=45, fontsize=7)
                ax.set_yticks(range(len(grid.index)), [f"{v:g}" for v in grid.index], fontsize=7)
                ax.set_xlabel(x)
                ax.set_ylabel(y)
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
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    _html(sw, df, out_dir, paths, timing or {})
    return paths


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
        vals = sorted(df[f"in.{a.name}"].dropna().unique(), key=str)
        shown = ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in vals[:12])
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
    path.write_text("\n".join(parts))
    return path


__all__ = ["plot_sweep", "metric_columns"]
