"""``bench sweep SWEEP.toml``: a base scenario over axes of any of its keys, every run on the
executor (hil_bench.cluster: a local Dask cluster, or --scheduler), one Parquet table, plots.
The file format: hil_bench.sweep.spec; the table: hil_bench.sweep.table; docs/sweeps.md.

Its names are imported when first used (``bench``'s parser imports hil_bench.sweep.cli only)."""

__all__ = ["Sweep", "SweepError", "load_sweep"]


def __getattr__(name: str):
    if name in __all__:
        from . import spec

        return getattr(spec, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
