"""A busy host makes a lockstep run slower, never different (docs/protocol.md 6.5, issue 26).

The same short G2 run, once on a quiet host and once beside two CPU-bound processes per CPU with
the controller's process stopped for 50-500 ms now and then (tests/host_load.py, the harness of
``python tools/load.py``): the recorded plant and controller rows are equal value for value, and
``--strict``'s integrity is clean, at the link's defaults (no longer wait anywhere). The stub also
answers every 500th cycle 300 ms late (``--inject late``), so the late path is taken whatever the
machine does. The full battery (10 G2 runs, SLCAN, pil-qemu, the example project) is
``python tools/load.py check`` (docs/performance.md).
"""
from __future__ import annotations

import numpy as np
import pytest

from hil_bench.loop.runner import Runner
from hil_bench.papers.check import check_recording
from hil_bench.record import channels as ch
from hil_bench.record.recording import load_recording
from hil_bench.scenario import derive_scenario
from tests.host_load import CONTROLLER_PATTERN, HostLoad

SHORT_G2 = [("scenario.duration_s", 0.6), ("metrics.window_s", [0.4, 0.6])]


def _run(tmp_path, name: str, link: str, stub_args=()) -> object:
    scn = derive_scenario("gong_g2_500rpm", f"g2_{name}", SHORT_G2)
    out = tmp_path / f"{name}.mcap"
    result = Runner(scn, link_spec=link, out_path=out, progress=False, stub_args=stub_args).run()
    assert result.ok, result.error
    return out


def _same_rows(a, b) -> None:
    ra, rb = load_recording(a), load_recording(b)
    for topic in (ch.PLANT_STATE, ch.CONTROLLER_TELEMETRY):
        for col, values in ra.topic(topic).items():
            np.testing.assert_array_equal(values, rb.topic(topic)[col], err_msg=f"{topic}.{col}")


@pytest.mark.parametrize("link", ["stub", "sil"])
def test_a_loaded_host_gives_the_rows_of_a_quiet_one(tmp_path, link):
    quiet = _run(tmp_path, "quiet", link)
    late = ("--inject", "late@1000") if link == "stub" else ()
    # SIL: the controller is in this very process; the load is the CPU hogs (a pause of this
    # process would stop the pauser with it)
    with HostLoad(pause_pattern=CONTROLLER_PATTERN if link == "stub" else None,
                  every_s=(0.05, 0.5)) as load:
        busy = _run(tmp_path, "busy", link, stub_args=late)
    print(load.summary())
    _same_rows(quiet, busy)
    integrity = check_recording(busy).integrity
    assert integrity.ok and not integrity.problems, integrity.problems
    if late:
        assert integrity.timing["late_answers"] >= 5   # cycles 1000, 1500, ..., 5500 at least
