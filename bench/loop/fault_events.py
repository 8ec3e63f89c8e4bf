"""How the cycle engine applies a scenario's ``[[faults]]`` (hil_bench.scenario.faults): link
faults go onto the engine's injector, plant faults and controller restarts become engine events
at the first period starting at or after their time (docs/faults.md)."""
from __future__ import annotations

from hil_bench.scenario.faults import PLANT_KINDS, FaultSpec, first_cycle_at


def schedule(engine, faults: tuple[FaultSpec, ...], ts_s: float) -> list[tuple[int, dict]]:
    """Put the scenario's link faults on the engine's injector, and return the plant faults and
    controller resets as (cycle, keyword arguments of Engine.add_fault_event), in cycle order:
    the caller merges them with the scenario's other events (the engine takes events in cycle
    order). A controller reset is CMD RESTART with the frames of its cycle (in band: the
    controller restarts at that cycle, before it reads the cycle's SENSE)."""
    from hil_bench.plant_rt import engine as eng
    from hil_bench.plant_rt.plant import FAULT_KINDS

    events: list[tuple[int, int, dict]] = []
    for fs in faults:
        k_on = first_cycle_at(fs.t_s, ts_s)
        if fs.target == "plant":
            plant_name = PLANT_KINDS[fs.kind][0]
            common = dict(index=fs.index, name=fs.kind, fault_kind=FAULT_KINDS[plant_name],
                          phase=fs.phase, phase2=fs.phase2, level=fs.level, value=fs.value,
                          detect_within_s=fs.detect_within_s)
            events.append((k_on, 0, dict(kind=eng.EV_PLANT_FAULT, text=fs.describe(), **common)))
            if fs.until_s is not None:
                events.append((first_cycle_at(fs.until_s, ts_s), 1,
                               dict(kind=eng.EV_PLANT_FAULT_CLEAR, text=f"{fs.kind} cleared",
                                    **common)))
        elif fs.target == "controller":
            events.append((k_on, 0, dict(kind=eng.EV_CONTROLLER_RESET, index=fs.index,
                                         name=fs.kind, detect_within_s=fs.detect_within_s,
                                         text=fs.describe())))
        else:
            engine.add_link_fault(
                index=fs.index, name=fs.kind, kind=fs.kind, direction=fs.direction,
                frame_id=fs.frame_id, cycle_on=k_on,
                cycle_off=first_cycle_at(fs.until_s, ts_s) if fs.until_s is not None else 0,
                count=fs.count, probability=fs.probability, delay_s=fs.delay_s,
                jitter_s=fs.jitter_s, stall_s=fs.stall_periods * ts_s, n_garbage=fs.burst,
                seed=fs.seed, detect_within_s=fs.detect_within_s)
    events.sort(key=lambda e: (e[0], e[1]))
    return [(k, kw) for k, _, kw in events]


def account(faults: tuple[FaultSpec, ...], states: list[dict], ts_s: float,
            n_cycles: int) -> list[dict]:
    """Each [[faults]] entry of the run with the engine's own account of it (Engine.fault_states:
    the cycle it first acted at, -1 if never; its first evidence; windows with and without
    evidence; what a link fault met and acted on) and what a reader needs to say why one never
    acted: its periods and, for a link fault on frames, which frames it waited for. The runner
    writes it into the run_result record (``faults``); bench/record/integrity.py judges it."""
    from hil_bench.scenario.faults import DIRECTION_WORDS

    by_index = {s["index"]: s for s in states}
    out = []
    for fs in faults:
        k_on = first_cycle_at(fs.t_s, ts_s)
        k_off = min(first_cycle_at(fs.until_s, ts_s), n_cycles) if fs.until_s is not None else n_cycles
        st = by_index.get(fs.index, {})
        entry = {"index": fs.index, "kind": fs.kind, "target": fs.target, "what": fs.describe(),
                 "cycle_on": k_on, "cycle_off": k_off,
                 "window": (f"from {k_on * ts_s:.6g} s to " +
                            (f"{k_off * ts_s:.6g} s" if k_off < n_cycles else "the end of the run")),
                 "acted_cycle": int(st.get("acted_cycle", -1)),
                 "evidence_cycle": int(st.get("evidence_cycle", -1)),
                 "windows": int(st.get("windows", 0)),
                 "untraced_windows": int(st.get("untraced_windows", 0)),
                 "refused": bool(st.get("refused", False))}
        if fs.target == "link" and fs.kind not in ("stall", "garbage"):
            entry.update(frames=(f"{fs.message} frames " if fs.message != "any" else "frames ") +
                         DIRECTION_WORDS[fs.direction],
                         probability=fs.probability, matched=int(st.get("matched", 0)),
                         acted=int(st.get("acted", 0)))
        out.append(entry)
    return out
