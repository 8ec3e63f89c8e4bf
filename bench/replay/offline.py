"""Mode (a), offline: the reference estimators on the capture's samples and voltage commands."""
from __future__ import annotations

import math

import numpy as np

from hil_bench.papers import metrics
from hil_bench.plant_rt import engine as eng
from hil_bench.record import channels as ch

from .capture import Capture
from .modes import (
    NO_CHANNEL,
    RPM_PER_RAD_S,
    ReplayError,
    ReplayOptions,
    ReplayResult,
    _Out,
    _watch,
    _write_capture_events,
    _write_metadata,
    _write_rows,
    derived_state,
    engine_summary,
    finish,
    make_estimators,
    reference_list,
    replay_live,
    t_delay_of,
)


def run_offline(cap: Capture, opts: ReplayOptions, profile, out, window, pace_s,
                res: ReplayResult) -> None:
    refs_cfg = reference_list(cap, opts, res.notes)
    if not refs_cfg:
        raise ReplayError(f"{cap.path}: no estimators to run: name them with --estimators "
                          f"SMO_SIGN,SMO_TANH:m1 (a recording replays its scenario's own)")
    refs = make_estimators(refs_cfg, profile, cap.ts_s)
    if not cap.has_duty:
        raise ReplayError(f"{cap.path}: the capture has no duties or voltages: the estimators "
                          f"need the voltage the inverter applied")
    # the voltage over the last period: delay-weighted duties, as live (a CSV of measured phase
    # voltages already is that average: no split)
    t_delay = t_delay_of(cap, profile) if cap.voltage_is_duty else 0.0
    o = _Out(cap, "offline", out, opts.force, refs,
             live=replay_live(opts, pace_s), on_live=opts.on_live, reservation=opts.reservation)
    o.pole_pairs = int(profile.pole_pairs)
    e = None
    try:
        _write_metadata(o, cap, "offline", profile, None, refs_cfg, window, opts)
        _write_capture_events(o, cap)
        _write_rows(o, cap, derived_state(cap, int(profile.pole_pairs)))
        e = o.attach(eng.Engine(None, ts_s=cap.ts_s, n_cycles=cap.n, ring=o.rec.ring_mem,
                                channels=o.channels(), source="replay_estimators",
                                replay_cycles=cap.rows,
                                t_delay_s=t_delay, pole_pairs=int(profile.pole_pairs),
                                rpm_per_rad_s=RPM_PER_RAD_S, pace_s=pace_s, stats_every_cycles=0))
        for (_name, kind, est), chan in zip(refs, o.refs):
            e.add_reference(kind, est, chan.index)
        interrupted = _watch(e, o, cap.n, opts.progress)
        engine_summary(e, res, pace_s)
        if interrupted:
            res.error = f"interrupted by the user at cycle {res.cycles}"
    finally:
        finish(o, e, res)
    res.metrics = offline_metrics(res.out, cap, window, int(profile.pole_pairs))


def offline_metrics(path, cap: Capture, window, pole_pairs: int) -> dict[str, dict[str, float]]:
    """Per estimate (each reference, and the recorded controller): position-estimation error
    against the capture's angle, and the estimated speed, over the window."""
    from hil_bench.record.recording import load_recording

    rec = load_recording(path, topics=["/reference/*", ch.CONTROLLER_TELEMETRY, ch.PLANT_STATE])
    st = rec.topics.get(ch.PLANT_STATE, {})
    out: dict[str, dict[str, float]] = {}
    sources = [(t[len(ch.REFERENCE_PREFIX):], t) for t in sorted(rec.topics)
               if t.startswith(ch.REFERENCE_PREFIX)]
    if cap.has_telem:
        sources.append(("controller (recorded)", ch.CONTROLLER_TELEMETRY))
    for name, topic in sources:
        cols = rec.topics[topic]
        t = cols["t_s"]
        m = metrics.window_mask(t, window)
        d: dict[str, float] = {"samples": float(m.sum())}
        sp = np.asarray(cols["speed_hat_rpm"][m], float)
        sp = sp[np.isfinite(sp)]
        d["speed_hat_mean_rpm"] = float(sp.mean()) if sp.size else math.nan
        if st and "theta_e_rad" in st and cap.has_theta:
            idx = np.searchsorted(st["t_s"], t[m])
            ok = idx < len(st["t_s"])
            truth = np.full(int(m.sum()), np.nan)
            truth[ok] = st["theta_e_rad"][idx[ok]]
            err = metrics.angle_error(cols["theta_hat_rad"][m], truth)
            d.update(pee_max_rad=err.max_abs_rad, pee_mean_rad=err.mean_rad,
                     pee_rms_rad=err.rms_rad)
            true_speed = np.asarray(st.get("speed_rpm", np.full(len(st["t_s"]), np.nan)))
            ts = true_speed[idx[ok]]
            ts = ts[np.isfinite(ts)]
            if ts.size:
                d["speed_true_mean_rpm"] = float(ts.mean())
                d["speed_band_rpm"] = metrics.speed_band_rpm(sp, float(ts.mean()))
        out[name] = d
    return out
