"""The command-line options of every command that spreads runs on the executor, checked where
they are parsed (argparse: one line naming the option)."""
from __future__ import annotations

import argparse
import math


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not >= 1")
    return value


def positive_seconds(text: str) -> float:
    """argparse type: a finite number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text} is not a finite number of seconds > 0")
    return value


def add_executor_args(p: argparse.ArgumentParser) -> None:
    """Where the runs go (hil_bench.cluster): the same options on every command that spreads runs."""
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="an existing Dask scheduler (its workers need hil-bench installed; "
                        "docs/sweeps.md); default: a local cluster, one worker per core")
    p.add_argument("--workers", type=positive_int, default=None, metavar="N",
                   help="local cluster: worker processes, >= 1 (default: one per core)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


__all__ = ["add_executor_args", "positive_int", "positive_seconds"]
