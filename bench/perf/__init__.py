"""Benchmarks: scripts that print measured figures (python -m hil_bench.perf.<name>), never timed
unit tests (docs/performance.md)."""
