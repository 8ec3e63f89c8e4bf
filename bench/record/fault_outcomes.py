"""What became of a run's faults, read back from its recording: each fault's first action,
the evidence it left (its /faults trace row), the controller's trip, the detection time and the
plant's peaks after it (docs/faults.md)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class FaultOutcome:
    """One fault of a run, read back from its recording."""

    index: int
    kind: str
    target: str
    t_on_s: float | None            # first action (None: it never acted)
    evidence: str = ""              # the trace row's text
    evidence_s: float | None = None  # first evidence after the first action [s]
    trip_s: float | None = None     # the controller's first FAULT_CTRL after it [s]
    trip_code: str = ""
    detection_s: float | None = None  # injected -> first of FAULT_CTRL / evidence
    peak_current_a: float = math.nan  # max |i_abc| of the plant from t_on to the end
    peak_torque_nm: float = math.nan  # max |T_e| likewise
    duties_after_trip: int = 0
    state_after: str = ""           # the controller's state at the end of the run
    notes: list[str] = field(default_factory=list)

    @property
    def detected(self) -> bool:
        return self.detection_s is not None

    @property
    def detected_by(self) -> str:
        """The controller's FAULT_CTRL (when it came first, within a period; for a plant fault
        always: only the drive detects the machine's faults), else the counters that moved."""
        if not self.detected:
            return ""
        if self.trip_s is not None and self.trip_s <= self.detection_s + 1e-6:
            return f"FAULT_CTRL {self.trip_code}"
        return self.evidence.split("; the run ended")[0] or self.evidence

    @property
    def untraced(self) -> bool:
        return self.t_on_s is not None and self.evidence.startswith("no trace")


def outcomes(rec) -> list[FaultOutcome]:
    """Every fault of a recording (its /faults rows) with its detection and the plant's peaks."""
    import numpy as np

    from hil_bench.protocol.messages import Fault, State

    from . import channels as ch
    from .integrity import run_result_counters

    try:
        rows = rec.topic(ch.FAULTS)
    except Exception:  # noqa: BLE001 - no /faults channel: a run without faults
        return []
    if not len(rows.get("t_s", ())):
        return []
    state = rec.topic(ch.PLANT_STATE)
    t_state = np.asarray(state["t_s"])
    i_abs = np.max(np.abs(np.vstack([state["i_a_a"], state["i_b_a"], state["i_c_a"]])), axis=0)
    torque = np.abs(np.asarray(state["torque_e_nm"]))
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    trips = [(float(t), float(v)) for t, a, v in zip(rows["t_s"], rows["action"], rows["value"])
             if a == "trip"]
    after_trip = sum(1 for a in rows["action"] if a == "duty_after_trip")
    try:
        after_trip = int(run_result_counters(rec).get("duties_after_trip", after_trip))
    except (ValueError, TypeError):
        pass
    last_state = ""
    if len(telem.get("state", ())):
        st = int(np.asarray(telem["state"])[-1])
        try:
            last_state = State(st).name
        except ValueError:
            last_state = str(st)
    out: dict[int, FaultOutcome] = {}
    for t, idx, target, kind, action, text, value in zip(
            rows["t_s"], rows["index"], rows["target"], rows["kind"], rows["action"],
            rows["text"], rows["value"]):
        idx = int(idx)
        if idx < 0:
            continue
        o = out.setdefault(idx, FaultOutcome(idx, str(kind), str(target), None))
        if action == "trace":
            o.evidence = str(text)
            o.evidence_s = None if not math.isfinite(float(value)) else float(value)
        elif action in ("refused",):
            o.notes.append(f"refused: {text}")
        elif action != "off" and o.t_on_s is None:
            o.t_on_s = float(t)
    starts = sorted(o.t_on_s for o in out.values() if o.t_on_s is not None)
    for o in out.values():
        if o.t_on_s is None:
            continue
        # the plant's peaks are this fault's from its first action to the next fault's
        t_end = next((t for t in starts if t > o.t_on_s), math.inf)
        later = [(t, c) for t, c in trips if t >= o.t_on_s - 1e-12]
        if later:
            o.trip_s = later[0][0] - o.t_on_s
            try:
                o.trip_code = Fault(int(later[0][1])).name
            except ValueError:
                o.trip_code = str(int(later[0][1]))
        if o.target == "plant":
            # a fault of the machine or the inverter is detected by the drive: its FAULT_CTRL.
            # The link's counters that moved after it (retries, duplicates, stale frames) are the
            # host's, and move as well when a loaded host answers late (measured: a locked rotor
            # "detected after 20.8 ms by retries +2" at load 12, its STALL trip at 115.8 ms)
            o.detection_s = o.trip_s
            if o.trip_s is None and o.evidence_s is not None:
                o.notes.append(f"the drive reported no fault; the link's counters moved: "
                               f"{o.evidence.split('; the run ended')[0]}")
        else:
            candidates = [x for x in (o.trip_s, o.evidence_s) if x is not None]
            o.detection_s = min(candidates) if candidates else None
        window = (t_state >= o.t_on_s - 1e-12) & (t_state < t_end)
        if window.any():
            o.peak_current_a = float(np.max(i_abs[window]))
            o.peak_torque_nm = float(np.max(torque[window]))
        o.duties_after_trip = after_trip if o.trip_s is not None else 0
        o.state_after = last_state
    return [out[k] for k in sorted(out)]
