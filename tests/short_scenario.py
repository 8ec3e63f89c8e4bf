"""The short scenario the loop's plumbing tests share.

A gong2020 plant under SMO_SIGN at 300 rpm, aligned for 0.05 s and ramped I/f at 200 rad/s^2:
the smallest run that exercises the whole loop (HELLO, CONFIG, cycles, recording, verdicts).
The tests that use it are about the bench (recordings, links, integrity), not the observer, so
its duration and any extra TOML tables ([link], [[faults]], [reference]) are theirs to set.
"""

from __future__ import annotations

from pathlib import Path

from hil_bench.scenario import parse_scenario

SHORT_TOML = """
[scenario]
name = "{name}"
profile = "gong2020"
duration_s = {duration_s}
[controller]
estimator = "SMO_SIGN"
speed_ref_rpm = 300
[controller.params]
ALIGN_TIME_S = 0.05
IF_ACCEL_RAD_S2 = 200.0
[metrics]
window_s = [0.0, {duration_s}]
"""


def short_scenario_text(duration_s: float = 0.1, name: str = "short", extra: str = "") -> str:
    """The scenario's TOML: `extra` (whole tables) is appended after [metrics]."""
    return SHORT_TOML.format(duration_s=duration_s, name=name) + extra


def short_scenario(duration_s: float = 0.1, name: str = "short", extra: str = "",
                   source: str = "short.toml"):
    """The parsed scenario; `source` is the file name its errors are reported against."""
    return parse_scenario(short_scenario_text(duration_s, name, extra), Path(source))
