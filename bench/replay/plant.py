"""Mode (c): the capture's duties drive the plant open loop; its sampled currents against the
recorded (a check of the plant model against a drive's log)."""
from __future__ import annotations

import math

import numpy as np

from hil_bench.plant_rt import engine as eng
from hil_bench.plant_rt.plant import Plant
from hil_bench.record import channels as ch

from .capture import Capture
from .modes import (
    RPM_PER_RAD_S,
    ReplayError,
    ReplayOptions,
    ReplayResult,
    _Out,
    _watch,
    _write_capture_events,
    _write_metadata,
    derived_state,
    engine_summary,
    finish,
    make_estimators,
    plant_overrides,
    reference_list,
    replay_live,
)


def run_plant(cap: Capture, opts: ReplayOptions, profile, out, window, pace_s,
              res: ReplayResult) -> None:
    from hil_bench.plant_rt.profile import ProfileError

    if not cap.has_duty:
        raise ReplayError(f"{cap.path}: the capture has no duties: nothing to drive the plant")
    if not cap.voltage_is_duty:
        raise ReplayError(f"{cap.path}: the capture has measured phase voltages, not duties: "
                          f"replay into the plant needs the duties the controller sent")
    try:
        plant = Plant(profile, **plant_overrides(cap, profile))
    except (ProfileError, ValueError) as exc:
        raise ReplayError(str(exc)) from None
    if abs(plant.params.ts_s - cap.ts_s) > 1e-12:
        raise ReplayError(f"the plant's period {plant.params.ts_s} s differs from the capture's "
                          f"{cap.ts_s} s")
    # the initial state: the recording's truth, else the encoder angle and its speed
    st = derived_state(cap, int(profile.pole_pairs))
    theta0 = float(st["theta_e_rad"][0]) if np.isfinite(st["theta_e_rad"][0]) else 0.0
    w0 = float(st["omega_m_rad_s"][0]) if np.isfinite(st["omega_m_rad_s"][0]) else 0.0
    plant.set_initial(theta0, w0)
    refs_cfg = reference_list(cap, opts, res.notes) if opts.estimators else {}
    refs = make_estimators(refs_cfg, profile, cap.ts_s)
    o = _Out(cap, "plant", out, opts.force, refs, ch.REPLAY_PLANT,
             live=replay_live(opts, pace_s), on_live=opts.on_live, reservation=opts.reservation)
    e = None
    try:
        _write_metadata(o, cap, "plant", profile, plant, refs_cfg, window, opts)
        _write_capture_events(o, cap)
        load = st.get("torque_load_nm")
        e = o.attach(eng.Engine(plant, ts_s=cap.ts_s, n_cycles=cap.n, ring=o.rec.ring_mem,
                                channels=o.channels(), source="replay_plant",
                                replay_cycles=cap.rows,
                                t_delay_s=float(plant.params.t_delay_s),
                                pole_pairs=int(profile.pole_pairs), rpm_per_rad_s=RPM_PER_RAD_S,
                                pace_s=pace_s, record_frames=0))
        if load is not None and np.isfinite(load).any():
            # the recorded load torque, from the cycle it changes (the recording's truth)
            plant.set_load_torque(float(np.nan_to_num(load[0])))
            changes = np.flatnonzero(np.diff(np.nan_to_num(load)) != 0) + 1
            if len(changes) > 200:
                res.notes.append(f"the recorded load changes {len(changes)} times; the first 200 "
                                 f"are applied")
            # the engine counts the plant's own steps (a gap in the capture is stepped through)
            step = np.rint((cap.rows["t_s"] - cap.rows["t_s"][0]) / cap.ts_s).astype(np.int64)
            for k in changes[:200]:
                e.add_event(int(step[k]), eng.EV_LOAD, value=float(load[k]))
        else:
            res.notes.append("the capture does not say the load torque: the plant runs without "
                             "load (profile load_profile only)")
        for (_n, kind, est), chan in zip(refs, o.refs):
            e.add_reference(kind, est, chan.index)
        gap_cycles = int(np.sum(np.maximum(np.rint(np.diff(cap.rows["t_s"]) / cap.ts_s) - 1, 0)))
        if gap_cycles:
            res.notes.append(f"{gap_cycles} cycle(s) missing in the capture: the plant steps "
                             f"through them with the last duties held (counted as missed duties; "
                             f"/replay/plant has no recorded currents there)")
        interrupted = _watch(e, o, cap.n, opts.progress)
        engine_summary(e, res, pace_s)
        if interrupted:
            res.error = f"interrupted by the user at cycle {res.cycles}"
    finally:
        finish(o, e, res)
    res.compare = compare_plant(res.out)


def compare_plant(path) -> dict:
    """RMS error of the plant's sampled currents against the recorded, per phase, over the run."""
    from hil_bench.record.recording import load_recording

    rec = load_recording(path, topics=[ch.REPLAY_PLANT])
    cols = rec.topics.get(ch.REPLAY_PLANT)
    if not cols or not len(cols["t_s"]):
        return {"cycles": 0}
    out: dict = {"cycles": int(len(cols["t_s"])), "phases": {}}
    for ph in ("a", "b", "c"):
        r = np.asarray(cols[f"i_{ph}_rec_a"], float)
        p = np.asarray(cols[f"i_{ph}_a"], float)
        ok = np.isfinite(r) & np.isfinite(p)
        d = p[ok] - r[ok]
        out["phases"][ph] = {
            "rms_error_a": float(np.sqrt(np.mean(d * d))) if d.size else math.nan,
            "max_abs_error_a": float(np.max(np.abs(d))) if d.size else math.nan,
            "rms_recorded_a": float(np.sqrt(np.mean(r[ok] ** 2))) if d.size else math.nan,
        }
    return out
