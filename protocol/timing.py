"""The session's timing (docs/protocol.md section 6): one place for the host, the conformance kit and
the spec.

The host (``hil_bench.loop.host_session``, the scenario defaults of ``[link]``) waits this long, the
conformance kit (``hil_bench.conformance``) gives a controller exactly the same time, and
``python protocol/gen_docs.py`` writes the table of docs/protocol.md section 6 from ``TIMING``.
The heartbeat period is the DBC's (``GenMsgCycleTime`` of HEARTBEAT_CTRL and HEARTBEAT_PLANT).
"""
from __future__ import annotations

from dataclasses import dataclass

from .dbc import message_specs


def _heartbeat_period_s() -> float:
    periods = {m.name: m.cycle_time_ms for m in message_specs() if m.name.startswith("HEARTBEAT_")}
    if len(set(periods.values())) != 1 or not all(periods.values()):
        raise RuntimeError(f"protocol/hil.dbc: the heartbeats' GenMsgCycleTime differ or are missing: {periods}")
    return next(iter(periods.values())) / 1000.0


#: HEARTBEAT_CTRL / HEARTBEAT_PLANT period while no cycles flow (DBC GenMsgCycleTime) [s]
HEARTBEAT_PERIOD_S = _heartbeat_period_s()
#: a gap between two HEARTBEAT_CTRL below half the period is a controller sending at twice the rate
HEARTBEAT_GAP_MIN_S = 0.5 * HEARTBEAT_PERIOD_S
#: a gap of two periods or more is a heartbeat that was not sent
HEARTBEAT_GAP_MAX_S = 2.0 * HEARTBEAT_PERIOD_S
#: the host repeats HELLO this often until the HELLO_ACK of its session arrives [s]
HELLO_RETRY_S = 0.1
#: lockstep: the host re-sends a cycle's SENSE group (and the handshake a CONFIG) when its answer
#: has not come this long after it was sent: how a lossy link recovers a lost frame. The default
#: of ``[link] retry_timeout_s`` [s]
LOCKSTEP_ANSWER_S = 0.05
#: ... then after twice the interval before, at most this far apart (back-off: a slow answer costs
#: a handful of frames, not a storm) [s]
RESEND_MAX_INTERVAL_S = 1.0
#: the host ends a run (or the handshake) only when the answer it waits for (DUTY(k), HELLO_ACK,
#: CONFIG_ACK) has not come this long after it first asked: a controller descheduled by a busy host,
#: a debugger breakpoint, a USB adapter's latency are all far shorter; a process that exited, a
#: closed port or a dead emulator are found at once. The default of ``[link] patience_s`` [s]
PATIENCE_S = 10.0
#: no HELLO_ACK of the session: the host gives up (the patience) [s]
HELLO_TIMEOUT_S = PATIENCE_S
#: no CONFIG_ACK (re-sent like a SENSE group): the host gives up (the patience) [s]
CONFIG_TIMEOUT_S = PATIENCE_S
#: the longest the host waits for an answer before it ends a lockstep run (the patience; kept for
#: the conformance kit) [s]
LOCKSTEP_GIVE_UP_S = PATIENCE_S


def resend_times_s(retry_timeout_s: float = LOCKSTEP_ANSWER_S, until_s: float = PATIENCE_S,
                   max_interval_s: float = RESEND_MAX_INTERVAL_S) -> list[float]:
    """When the host re-sends an unanswered cycle, in seconds after the first send (the engine's
    schedule, plant_rt/c/engine_lockstep.c): retry_timeout_s, then each interval twice the one
    before, at most max_interval_s, while the patience lasts."""
    out, t, interval = [], 0.0, retry_timeout_s
    while t + interval < until_s:
        t += interval
        out.append(t)
        interval = min(2 * interval, max_interval_s)
    return out


@dataclass(frozen=True)
class Timing:
    what: str
    value: str
    name: str


TIMING: tuple[Timing, ...] = (
    Timing("HEARTBEAT_CTRL and HEARTBEAT_PLANT period while no cycles flow (DBC `GenMsgCycleTime`)",
           f"{HEARTBEAT_PERIOD_S * 1e3:g} ms", "HEARTBEAT_PERIOD_S"),
    Timing("gap between two HEARTBEAT_CTRL the conformance kit accepts: above half the period (not "
           "twice the rate), below two periods (none missed)",
           f"{HEARTBEAT_GAP_MIN_S * 1e3:g} .. {HEARTBEAT_GAP_MAX_S * 1e3:g} ms, exclusive",
           "HEARTBEAT_GAP_MIN_S, HEARTBEAT_GAP_MAX_S"),
    Timing("HELLO repeated until the HELLO_ACK of its session arrives", f"every {HELLO_RETRY_S * 1e3:g} ms",
           "HELLO_RETRY_S"),
    Timing("lockstep: the first re-send of a SENSE group (or CONFIG) whose answer has not come (6.5)",
           f"{LOCKSTEP_ANSWER_S * 1e3:g} ms after it was sent (`[link] retry_timeout_s`)", "LOCKSTEP_ANSWER_S"),
    Timing("... each next re-send after twice the interval before, at most",
           f"{RESEND_MAX_INTERVAL_S:g} s apart: "
           + ", ".join(f"{t:g}" for t in resend_times_s()[:7]) + ", ... s", "RESEND_MAX_INTERVAL_S"),
    Timing("**patience**: DUTY(k) (or HELLO_ACK, CONFIG_ACK) has not come this long after the host "
           "first asked for it: the host ends the run (6.5)",
           f"{PATIENCE_S:g} s (`[link] patience_s`)", "PATIENCE_S"),
)


def markdown_table() -> str:
    """The timing table of docs/protocol.md section 6 (written by protocol/gen_docs.py)."""
    out = ["| what | value | `hil_bench.protocol.timing` |", "|---|---|---|"]
    out += [f"| {t.what} | {t.value} | `{t.name}` |" for t in TIMING]
    return "\n".join(out) + "\n"


# -- the conformance kit (docs/protocol.md section 9): it judges the controller, not the host ------------------
#: the kit's answer-time limit: the median and the 90th percentile of a controller's answer times in lockstep
#: (SENSE(k) sent -> DUTY(k) received), each less the host's own loopback time at the same quantile, are at
#: most this. Its source is the spec's requirement on a lockstep controller (6.0 item 4: DUTY(k) within
#: 50 ms of SENSE(k)), judged on a statistic that a host stall of a few cycles cannot move, as a drive is
#: judged on its typical and its slow answers, not on the one the host was descheduled in.
KIT_ANSWER_LIMIT_S = 0.05
#: the quantiles of the answer times the kit judges
KIT_ANSWER_QUANTILES = (0.5, 0.9)
#: the kit waits this long for one DUTY before it calls it missing (an answer that comes later than the
#: limit but within this is a late answer: a timing figure, not a lost frame) [s]
KIT_ANSWER_PATIENCE_S = 2.0
#: the kit collects HEARTBEAT_CTRL this long while idle and estimates their period as the Theil-Sen slope of
#: arrival time over counter (the median of the pairwise slopes): an arrival the host saw late because it was
#: itself stalled moves the median only when more than 29 % of them are displaced (a stall of up to 400 ms
#: of the 1.5 s window). The period must lie within HEARTBEAT_GAP_MIN_S .. HEARTBEAT_GAP_MAX_S.
KIT_HEARTBEAT_WINDOW_S = 1.5
#: ... with at least this many heartbeats in the window (a drive still starting may miss the first ones)
KIT_HEARTBEAT_MIN_COUNT = 6
#: a frame that must not be answered (a SENSE with a bad CRC, section 2.4) is given this long to be answered;
#: longer than any answer of a controller that passes the answer-time item, at its p90 [s]
KIT_SILENCE_S = 0.2

TIMING += (
    Timing("conformance kit: the median and the p90 of a controller's lockstep answer times, each less the host's "
           "own loopback at that quantile, at most (section 9)", f"{KIT_ANSWER_LIMIT_S * 1e3:g} ms",
           "KIT_ANSWER_LIMIT_S"),
    Timing("conformance kit: an answer not there this long after its SENSE is missing (later than the limit "
           "but within this: late)", f"{KIT_ANSWER_PATIENCE_S:g} s", "KIT_ANSWER_PATIENCE_S"),
    Timing("conformance kit: HEARTBEAT_CTRL collected while idle, their period estimated robustly (Theil-Sen) "
           "and held to the heartbeat gap above", f"{KIT_HEARTBEAT_WINDOW_S:g} s, at least "
           f"{KIT_HEARTBEAT_MIN_COUNT}", "KIT_HEARTBEAT_WINDOW_S, KIT_HEARTBEAT_MIN_COUNT"),
)
