"""``bench sweep SWEEP.toml``: a base scenario over axes of any of its keys, every run on the
executor (hil_bench.cluster: a local Dask cluster, or --scheduler), one Parquet table, plots.
The file format: hil_bench.sweep.spec; docs/sweeps.md."""
from .spec import Sweep, SweepError, load_sweep

__all__ = ["Sweep", "SweepError", "load_sweep"]
