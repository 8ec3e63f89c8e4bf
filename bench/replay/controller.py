"""Mode (b): the capture's uplink frames to a live controller in lockstep; its answers against the
recorded ones (the first divergence and statistics of the differences)."""
from __future__ import annotations

import math

import numpy as np

from hil_bench.loop.host_session import HostSession
from hil_bench.loop.links import LinkError, open_link
from hil_bench.loop.links.engine_fd import engine_link_for
from hil_bench.plant_rt import engine as eng
from hil_bench.protocol.messages import MESSAGES, Command, Estimator, HelloFlag, Mode, Param
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
    replay_live,
)

_CMD = MESSAGES["CMD"]
#: fields compared (name, recorded column, live column of /replay/controller, kind): the DUTY
#: duties, TELEM's angle, speed, state and estimator, TELEM_EMF's EMF and current reference
COMPARED = (("duty_a", "duty_a_rec", "duty_a", "value"), ("duty_b", "duty_b_rec", "duty_b", "value"),
            ("duty_c", "duty_c_rec", "duty_c", "value"),
            ("theta_hat", "theta_hat_rec_rad", "theta_hat_rad", "angle"),
            ("omega_hat", "omega_hat_rec_rad_s", "omega_hat_rad_s", "value"),
            ("state", "state_rec", "state", "code"), ("estimator", "estimator_rec", "estimator", "code"),
            ("e_alpha", "e_alpha_rec_v", "e_alpha_v", "value"),
            ("e_beta", "e_beta_rec_v", "e_beta_v", "value"),
            ("i_q_ref", "i_q_ref_rec_a", "i_q_ref_a", "value"))


def run_controller(cap: Capture, opts: ReplayOptions, profile, out, window, pace_s,
                   res: ReplayResult) -> None:
    if cap.frames is None or not cap.rows["n_frames"].any():
        raise ReplayError(f"{cap.path}: the capture holds no frames to send (a {cap.kind} capture"
                          f"{' without /link/frames' if cap.kind == 'mcap' else ''}): replay "
                          f"into a controller needs the recorded SENSE frames")
    if cap.hello is None:
        raise ReplayError(f"{cap.path}: no HELLO in the capture: its period, estimator and flags "
                          f"are unknown (the capture starts after the handshake)")
    params = dict(cap.config)
    if not params:
        res.notes.append("no CONFIG in the capture: the controller keeps its defaults")
    params.update(opts.set_params)
    for p, v in opts.set_params.items():
        res.notes.append(f"CONFIG {p.name} = {v:g} (capture: "
                         f"{cap.config.get(p, float('nan')):g})")
    o = _Out(cap, "controller", out, opts.force, [], ch.REPLAY_CONTROLLER,
             live=replay_live(opts, pace_s), on_live=opts.on_live, reservation=opts.reservation)
    o.pole_pairs = int(profile.pole_pairs)
    opened = None
    link = None
    e = None
    try:
        cap_cfg = cap.config
        cap.config = params      # the run metadata says what the controller was told
        _write_metadata(o, cap, "controller", profile, None, {}, window, opts)
        cap.config = cap_cfg
        _write_capture_events(o, cap)
        _write_rows(o, cap, derived_state(cap, int(profile.pole_pairs)), sense=False,
                    telem=False, frames=False)
        try:
            opened = open_link(opts.link, opts.stub_args)
            stub = opened.stub
            setup: list[tuple[str, int, bytes]] = []
            session = HostSession(opened.link, on_frame=lambda d, i, p: setup.append((d, i, p)),
                                  alive=(stub.alive if stub else None),
                                  death_message=(stub.death_message if stub else None))
            h = cap.hello
            try:
                session.handshake(period_s=h["period_us"] * 1e-6, estimator=h["estimator"],
                                  flags=h["flags"], mode=Mode.LOCKSTEP)
                served = session.serve(params)   # an older controller: what its version knows (6.1)
                if served != params:
                    res.notes.append(f"the controller speaks protocol {session.version_text}: served without "
                                     f"{', '.join(session.features_off)}")
                session.configure(served)
                # the capture's commands before its first cycle (speed reference, RUN), as sent
                pre = [(fid, data) for d, fid, data in cap.setup_frames if fid == _CMD.frame_id]
                if pre:
                    session.send(pre)
                else:
                    res.notes.append("no CMD before the first cycle in the capture: RUN sent")
                    session.command(Command.RUN)
            finally:
                tx = " ".join(f"{f:03X}#{p.hex().upper()}" for d, f, p in setup if d == "tx")
                rx = " ".join(f"{f:03X}#{p.hex().upper()}" for d, f, p in setup if d == "rx")
                o.frames.write_values(0.0, (0.0, -1, tx, rx))
            link = engine_link_for(opened.link)
            e = o.attach(eng.Engine(None, ts_s=cap.ts_s, n_cycles=cap.n, link_fd=link.fd,
                                    link_kind=link.kind, ring=o.rec.ring_mem,
                                    channels=o.channels(ch_state=NO_CHANNEL),
                                    source="replay_controller", replay_cycles=cap.rows,
                                    replay_frames=cap.frames,
                                    pole_pairs=int(profile.pole_pairs),
                                    rpm_per_rad_s=RPM_PER_RAD_S,
                                    estimator_expected=int(h["estimator"]), pace_s=pace_s))
            py = opened.link
            deframer = getattr(py, "deframer", None)
            pending = list(getattr(py, "_pending", []))
            py._pending = []
            e.hand_over(bytes(getattr(deframer, "_pending", b"")) if deframer else b"", pending)
            interrupted = _watch(e, o, cap.n, opts.progress)
            engine_summary(e, res, pace_s)
            if interrupted:
                res.error = f"interrupted by the user at cycle {res.cycles}"
            e.send(*session.command_frame(Command.STOP, 0.0))
            link.settle()
        except LinkError as exc:
            res.error = str(exc)
    finally:
        if link is not None:
            link.close()
        if opened is not None:
            code = opened.close()
            if opened.stub is not None and code not in (0, None) and res.error is None:
                res.error = f"after the replay: {opened.stub.death_message()}"
        finish(o, e, res)
    res.compare = compare_controller(res.out)


def compare_controller(path, tol: float = 0.0) -> dict:
    """The live controller's answers against the recorded, from /replay/controller: the first
    cycle where they differ and, per field, in how many cycles it was compared (those where the
    capture recorded it), how many differ and by how much. A cycle where the capture has the
    value and the controller did not answer it differs. The wire values are compared exactly
    (tol 0): the same build answers the same octets."""
    from hil_bench.record.recording import load_recording

    rec = load_recording(path, topics=[ch.REPLAY_CONTROLLER])
    cols = rec.topics.get(ch.REPLAY_CONTROLLER)
    if not cols or not len(cols["t_s"]):
        return {"cycles": 0}
    n = len(cols["t_s"])
    out: dict = {"cycles": n, "fields": {}}
    first = None
    for name, rec_col, now_col, kind in COMPARED:
        if rec_col not in cols:          # a recording of an older layout
            continue
        a = np.asarray(cols[rec_col], float)
        b = np.asarray(cols[now_col], float)
        recorded = (a >= 0) if kind == "code" else np.isfinite(a)
        if kind == "code":
            b = np.where(b >= 0, b, np.nan)
        diff = (b - a + math.pi) % (2 * math.pi) - math.pi if kind == "angle" else b - a
        same = np.abs(diff) <= tol            # NaN (no answer now) is not the same
        bad = np.flatnonzero(recorded & ~same)
        fin = recorded & np.isfinite(diff)
        out["fields"][name] = {
            "compared": int(recorded.sum()),
            "differ": int(bad.size),
            "max_abs": float(np.max(np.abs(diff[fin]))) if fin.any() else math.nan,
            "rms": float(np.sqrt(np.mean(diff[fin] ** 2))) if fin.any() else math.nan,
        }
        if bad.size and (first is None or bad[0] < first[0]):
            i = int(bad[0])
            first = (i, name, float(a[i]), float(b[i]))
    if first is not None:
        i, name, was, now = first
        out["first_divergence"] = {"row": i, "cycle_seq": int(cols["seq"][i]),
                                   "t_s": float(cols["t_s"][i]), "field": name,
                                   "recorded": was, "now": now}
    return out
