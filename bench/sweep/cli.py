"""``bench sweep``: its options and what it prints (the sweep itself: hil_bench.sweep.run).

Exit status: 0 every run has a row that is not an ``error``; 1 some rows are errors, or the
sweep stopped (its table could not be written) or its plots could not be written; 2 the sweep
file, the folder's table, the options or the scheduler refused before anything ran."""
from __future__ import annotations

import argparse
from pathlib import Path

from rich.console import Console
from rich.markup import escape

from hil_bench.cluster.options import add_executor_args, positive_seconds


def add_arguments(w: argparse.ArgumentParser) -> None:
    w.add_argument("sweep", help="sweep TOML, or the name of a bundled one (e.g. "
                                 "observers_speed_load)")
    w.add_argument("--out", help="folder of results.parquet, plots/, report.html (default: a new "
                                 "reports/sweeps/<name>-<time>-<pid>); the same sweep's table "
                                 "already there is resumed, another sweep's is refused")
    w.add_argument("--quick", action="store_true", help="the file's coarse [quick] version")
    w.add_argument("--fresh", action="store_true",
                   help="start the table over: the one in --out is kept aside as "
                        "results.replaced-<time>.parquet (never deleted)")
    w.add_argument("--retry-errors", action=argparse.BooleanOptionalAction, default=True,
                   help="run the table's `error` rows again (the bench's failures, e.g. a worker "
                        "that could not run them; default); --no-retry-errors keeps them")
    add_executor_args(w)
    w.add_argument("--time-limit-s", type=positive_seconds, default=None, metavar="S",
                   help="per run, > 0 (default: the file's time_limit_s, else 600 s)")
    w.add_argument("--no-plots", action="store_true", help="the table only")


def main(args: argparse.Namespace) -> int:
    from hil_bench.cluster import ClusterError, Executor
    from hil_bench.installation import require_extra
    from hil_bench.sweep import SweepError, load_sweep
    from hil_bench.sweep.folder import FolderBusy, FolderLock, new_out_dir
    from hil_bench.sweep.run import SweepStopped, describe, error_summary, run_sweep
    from hil_bench.sweep.table import RESULTS, TableError, resume

    err = Console(stderr=True, soft_wrap=True)   # one line per message, piped or not

    def fail(msg: str, code: int) -> int:
        err.print(f"[red]error:[/red] {escape(msg)}")
        return code

    try:
        sw = load_sweep(args.sweep, quick=args.quick)
    except SweepError as exc:
        return fail(str(exc), 2)
    # what the sweep needs, before its folder is made: Dask runs it, pyarrow writes its table,
    # Matplotlib and pandas its plots
    require_extra("bench sweep", "distributed", "pyarrow",
                  *(() if args.no_plots else ("matplotlib", "pandas")))
    if args.time_limit_s is not None:
        sw.time_limit_s = args.time_limit_s
    try:
        if args.out:
            out_dir = Path(args.out)
            out_dir.mkdir(parents=True, exist_ok=True)
        else:
            out_dir = new_out_dir(Path("reports") / "sweeps", sw.name)
    except OSError as exc:
        return fail(f"cannot create the sweep folder {args.out or 'reports/sweeps'}: "
                    f"{exc.strerror or exc}", 2)
    try:
        with FolderLock(out_dir):
            # the folder's table is checked before a cluster starts: another sweep's is refused
            resumed = resume(sw, out_dir, fresh=args.fresh)
            try:
                executor = Executor(args.scheduler, args.workers, progress=not args.no_progress,
                                    console=err, label=sw.name)
            except ClusterError as exc:
                return fail(str(exc), 2)
            with executor:
                err.print(escape(f"{sw.name}: {len(sw.points)} runs over {sw.link} ({sw.method}"
                                 f"{', --quick' if sw.quick else ''}) on the {executor.where}; "
                                 f"folder {out_dir}"))
                rows, did = run_sweep(sw, out_dir, executor, err, retry_errors=args.retry_errors,
                                      resumed=resumed)
    except FolderBusy as exc:
        return fail(str(exc), 2)
    except TableError as exc:
        return fail(str(exc), 2)
    except SweepStopped as exc:
        return fail(str(exc), 1)
    except OSError as exc:          # the lock file, the folder: not writable
        return fail(f"{out_dir}: {exc.strerror or exc}", 2)
    code = 1 if any(r.get("status") == "error" for r in rows) else 0
    paths = []
    if not args.no_plots:
        from hil_bench.sweep.plots import plot_sweep

        try:
            paths = plot_sweep(sw, rows, out_dir, {"wall_s": did["wall_s"],
                                                   "where": executor.where})
        except OSError as exc:
            code = fail(f"cannot write the plots in {out_dir}: {exc.strerror or exc}; the table "
                        f"{out_dir / RESULTS} is complete", 1)
    out = Console(soft_wrap=True)
    retried = f" ({did['retried']} of them rows that were errors)" if did["retried"] else ""
    out.print(escape(f"{did['ran']} runs in {did['wall_s']:.1f} s{retried}, {did['skipped']} "
                     f"already in the table; table {out_dir / RESULTS} ({len(rows)} rows: "
                     f"{describe(rows)})"
                     + (f"; plots {out_dir / 'plots'}, {out_dir / 'report.html'}" if paths else "")))
    for line in error_summary(sw, rows):
        out.print(escape(f"  {line}"))
    if code and any(r.get("status") == "error" for r in rows):
        out.print(escape(f"  the error rows run again with: bench sweep {args.sweep}"
                         f"{' --quick' if args.quick else ''} --out {out_dir}"))
    return code


__all__ = ["add_arguments", "main"]
