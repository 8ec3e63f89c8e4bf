"""How the cycle engine applies a scenario's ``[[faults]]`` (hil_bench.scenario.faults): link
faults go onto the engine's injector, plant faults and controller restarts become engine events
at the first period starting at or after their time (docs/faults.md)."""
from __future__ import annotations

import math

from hil_bench.scenario.faults import PLANT_KINDS, FaultSpec


def first_cycle_at(t_s: float, ts_s: float) -> int:
    """The first period that starts at or after t_s (half a period of tolerance for rounding)."""
    return max(0, int(math.ceil(t_s / ts_s - 0.5 + 1e-9)))


def schedule(engine, faults: tuple[FaultSpec, ...], ts_s: float, *,
             controller_pid: int | None) -> list[tuple[int, dict]]:
    """Put the scenario's link faults on the engine's injector, and return the plant faults and
    controller resets as (cycle, keyword arguments of Engine.add_fault_event), in cycle order:
    the caller merges them with the scenario's other events (the engine takes events in cycle
    order). ``controller_pid``: the stub's process (SIGUSR1 restarts it), 0 for the firmware in
    this process (``--link sil``: the engine restarts it by a call), None for a real drive."""
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
            if controller_pid is None:
                raise ValueError(f"faults[{fs.index}]: a controller_reset needs the firmware stub "
                                 f"as the controller (--link stub... or --link sil): the bench "
                                 f"restarts it; a real drive has no such line")
            events.append((k_on, 0, dict(kind=eng.EV_CONTROLLER_RESET, index=fs.index,
                                         name=fs.kind, pid=controller_pid,
                                         detect_within_s=fs.detect_within_s,
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
