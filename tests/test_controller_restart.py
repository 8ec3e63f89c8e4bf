"""A controller restart happens at a defined cycle in lockstep (issue 19, item 6): the bench sends
CMD RESTART with the frames of the fault's cycle, before its SENSE, so the controller restarts
exactly there whatever the timing (it was a SIGUSR1 to the stub, asynchronous: campaign run 13
recorded detection 0.1 vs 0.0 ms and a peak current of 4.27 A vs none between --jobs 1 and 2).
The same restart scenario run twice, once with the CPUs busy, records the same rows."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from hil_bench.loop.runner import run_scenario
from hil_bench.record import channels as ch
from hil_bench.record.fault_outcomes import outcomes
from hil_bench.record.recording import load_recording
from tests.test_faults_engine import scenario

#: what a restart run records that depends on the cycles only (the wall-clock columns of /timing
#: and /link/stats, and the heartbeats the stub sends every 100 ms of wall time, do not)
COMPARED = {ch.PLANT_STATE: None, ch.PLANT_SENSE: None, ch.CONTROLLER_TELEMETRY: None,
            ch.FAULTS: ("t_s", "seq", "index", "target", "kind", "action", "text", "value")}


def _scenario():
    return scenario('[[faults]]\nkind = "controller_reset"\nt_s = 0.2')


def _run(out: Path, link: str = "stub"):
    result = run_scenario(_scenario(), link_spec=link, out_path=out, progress=False,
                          allow_slow_link=True)
    return result, load_recording(out)


def _rows(rec) -> dict:
    out = {}
    for topic, fields in COMPARED.items():
        cols = rec.topic(topic)
        out[topic] = {k: np.asarray(v) for k, v in cols.items() if fields is None or k in fields}
    return out


class _Busy:
    """Every CPU this process may use kept busy by a spinning process (and the stub and the
    engine then compete with them)."""

    def __enter__(self):
        n = len(os.sched_getaffinity(0))
        self.procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                      for _ in range(n)]
        time.sleep(0.2)
        return self

    def __exit__(self, *exc):
        for p in self.procs:
            p.kill()
            p.wait()


def test_a_restart_happens_at_its_cycle_whatever_the_load(tmp_path):
    quiet, rec_a = _run(tmp_path / "a.mcap")
    with _Busy():
        busy, rec_b = _run(tmp_path / "b.mcap")
    for result in (quiet, busy):
        # the controller restarted before it read the SENSE of cycle 2000: that cycle never
        # completes, and the run ends there saying why
        assert result.end == "NO_DUTY" and result.cycles_done == 2000, result.error
        assert "the bench restarted the controller at this cycle" in result.error
        assert "nothing at all" not in result.error
    a, b = _rows(rec_a), _rows(rec_b)
    for topic in COMPARED:
        assert a[topic].keys() == b[topic].keys()
        for k in a[topic]:
            x, y = a[topic][k], b[topic][k]
            assert len(x) == len(y) and (x.dtype.kind in "OUS" and list(x) == list(y)
                                         or np.array_equal(x, y, equal_nan=True)), (topic, k)
    (oa,), (ob,) = outcomes(rec_a), outcomes(rec_b)
    assert oa.detection_s == ob.detection_s == 0.0 and oa.evidence == ob.evidence
    assert "ctrl_resets +1" in oa.evidence
    # no period of the plant ran after the restart (the cycle at which it happened never completed)
    assert np.isnan(oa.peak_current_a) and np.isnan(ob.peak_current_a)


def test_a_restart_is_in_band_on_a_can_link_too(tmp_path):
    """CMD RESTART is an ordinary frame: over the stub's SLCAN link as over serial (and in a port
    that runs the firmware in the bench's own thread, the portable session restarts itself:
    tests/c/test_fw_session.c)."""
    result, rec = _run(tmp_path / "can.mcap", link="stub-slcan")
    assert result.end == "NO_DUTY" and result.cycles_done == 2000, result.error
    f = rec.topic(ch.FAULTS)
    on = [t for a, t in zip(f["action"], f["text"]) if a == "on"]
    assert on and "CMD RESTART" in on[0]
    (o,) = outcomes(rec)
    assert "ctrl_resets +1" in o.evidence


def test_the_stub_still_restarts_on_sigusr1():
    """A reset line of the port's own (SIGUSR1) goes through the same restart as CMD RESTART: the
    session says so with a HEARTBEAT_CTRL at once (counter 0, state IDLE)."""
    import signal

    from hil_bench.loop.host_session import HostSession
    from hil_bench.loop.links import open_link
    from hil_bench.protocol.messages import MESSAGES, Estimator, Mode, State
    from hil_bench.protocol.timing import PATIENCE_S

    hb = MESSAGES["HEARTBEAT_CTRL"]
    opened = open_link("stub", ("--quiet",))
    try:
        HostSession(opened.link).handshake(period_s=1e-4, estimator=int(Estimator.SMO_SIGN),
                                           flags=0, mode=Mode.LOCKSTEP)
        def next_heartbeat() -> dict:
            """The next HEARTBEAT_CTRL, waited for as lockstep waits (PATIENCE_S): a busy host
            makes the stub's idle heartbeats (every 100 ms) late, never absent."""
            m = opened.link.recv_until(lambda fid, p: fid == hb.frame_id, PATIENCE_S,
                                       lambda *a: None)
            assert m is not None, f"no HEARTBEAT_CTRL in {PATIENCE_S} s"
            return hb.unpack(m[1])

        counters = [int(next_heartbeat()["counter"])]
        while max(counters) < 1:                   # idle heartbeats: counter 0, 1, 2 ...
            counters.append(int(next_heartbeat()["counter"]))
        os.kill(opened.stub.proc.pid, signal.SIGUSR1)
        # the restart's own heartbeat (counter 0, IDLE) comes next; one idle heartbeat sent
        # before the signal may still be on its way
        after = [next_heartbeat()]
        if int(after[0]["counter"]) != 0:
            after.append(next_heartbeat())
        v = after[-1]
        assert int(v["counter"]) == 0 and int(v["state"]) == int(State.IDLE), after
    finally:
        opened.close()
