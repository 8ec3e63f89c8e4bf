"""Fault campaigns (``bench campaign``): many runs of a scenario with faults, each judged on its
detection and reaction. A scenario's own ``[[faults]]`` table is hil_bench.scenario.faults; the
engine applies it (hil_bench.loop.fault_events); a recording tells what became of it
(hil_bench.record.fault_outcomes)."""
