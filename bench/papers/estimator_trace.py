"""Run an estimator of the C library again, on the host, over a recording, with its internals.

``bench replay --mode offline`` (bench/replay/) re-runs reference estimators on the cycle engine and
records what a live run records; this module steps one estimator from Python instead, so that its
internal state can be read after every step (the claims' plots and Y3 need the observer's current
estimate, which no recording carries).

The inputs are rebuilt from the recorded topics exactly as the lockstep loop feeds its reference
estimators (docs/architecture.md): the phase currents the controller was sent (/plant/sense) and
the voltage that acted over the last period, i.e. the duties of cycle k-2 until the computation
delay t_d, then those of k-1 (/controller/telemetry duties, /plant/sense bus voltage, t_d from
the run metadata). A replay therefore reproduces a recorded /reference/<name> topic, and gives
what a recording does not carry: the observer's internal current estimate i_hat (Yuan's Fig. 17,
claim Y3), or an estimator with another configuration on the same samples.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from hil_bench.record import channels as ch
from hil_bench.record.recording import Recording, RecordingError

INV_SQRT3 = 1.0 / math.sqrt(3.0)


@dataclass
class Replay:
    t_s: np.ndarray
    theta_hat_rad: np.ndarray
    omega_hat_rad_s: np.ndarray
    e_alpha_v: np.ndarray
    e_beta_v: np.ndarray
    i_alpha_a: np.ndarray        # the measured current the estimator was given
    i_beta_a: np.ndarray
    i_hat_alpha_a: np.ndarray    # the observer's current estimate after the step (NaN if none)
    i_hat_beta_a: np.ndarray


def estimator_inputs(rec: Recording) -> dict[str, np.ndarray]:
    """Per cycle: t_s, measured i_alpha/i_beta and the acted v_alpha/v_beta (NaN until two
    commands are known, and while a leg is off), as the lockstep loop computes them."""
    sense = rec.topic(ch.PLANT_SENSE)
    telem = rec.topic(ch.CONTROLLER_TELEMETRY)
    try:
        plant = json.loads(rec.run["plant_params"])
        ts = float(rec.run["ts_s"])
        td = float(plant["t_delay_s"])
    except (KeyError, ValueError) as exc:
        raise RecordingError(f"{rec.path}: run metadata incomplete ({exc})") from None
    n = min(len(sense["t_s"]), len(telem["t_s"]))
    ia, ib, ic = (np.asarray(sense[f][:n], float) for f in ("i_a_a", "i_b_a", "i_c_a"))
    i_al = (2.0 * ia - ib - ic) / 3.0
    i_be = (ib - ic) * INV_SQRT3
    da, db, dc = (np.asarray(telem[f][:n], float) for f in ("duty_a", "duty_b", "duty_c"))
    vdc = np.asarray(sense["v_dc_v"][:n], float)
    off = (da < 0) | (db < 0) | (dc < 0)
    va = np.where(off, np.nan, (2.0 * da - db - dc) * (vdc / 3.0))
    vb = np.where(off, np.nan, (db - dc) * (vdc * INV_SQRT3))
    w = td / ts
    v_al = np.full(n, np.nan)
    v_be = np.full(n, np.nan)
    # cycle k uses the commands of k-2 (older) and k-1 (prev)
    v_al[2:] = w * va[:-2] + (1.0 - w) * va[1:-1]
    v_be[2:] = w * vb[:-2] + (1.0 - w) * vb[1:-1]
    return {"t_s": np.asarray(sense["t_s"][:n], float), "i_alpha_a": i_al, "i_beta_a": i_be,
            "v_alpha_v": v_al, "v_beta_v": v_be}


def replay(rec: Recording, estimator: Any, i_hat: Callable[[Any], tuple[float, float]] | None = None,
           window_s: tuple[float, float] | None = None) -> Replay:
    """Step ``estimator`` (an object with ``step(i_a, i_b, v_a, v_b)`` returning an
    EstimatorOutput, e.g. from hil_bench.firmware_stub.estimators.REFERENCE_ESTIMATORS) over the recording.
    ``i_hat(estimator)`` reads the observer's current estimate after a step (default: the C
    state's ``i_hat_a`` if it has one). Outputs outside ``window_s`` are computed (the observer
    must run from the start) but returned only inside it."""
    x = estimator_inputs(rec)
    n = len(x["t_s"])
    out = np.full((n, 6), np.nan)
    state = getattr(estimator, "state", None)
    if i_hat is None and state is not None and hasattr(state, "i_hat_a"):
        def i_hat(_est):   # noqa: E306 - the C state of the SMO wrappers
            return state.i_hat_a.x, state.i_hat_a.y
    ia, ib, va, vb = x["i_alpha_a"], x["i_beta_a"], x["v_alpha_v"], x["v_beta_v"]
    for k in range(n):
        if not (math.isfinite(va[k]) and math.isfinite(vb[k])):
            continue          # no known voltage (start, legs off): the estimator waits
        o = estimator.step(float(ia[k]), float(ib[k]), float(va[k]), float(vb[k]))
        hx, hy = i_hat(estimator) if i_hat is not None else (math.nan, math.nan)
        out[k] = (o.theta_e_rad, o.omega_e_rad_s, o.e_alpha_v, o.e_beta_v, hx, hy)
    m = np.ones(n, bool) if window_s is None else (x["t_s"] >= window_s[0]) & (x["t_s"] <= window_s[1])
    return Replay(x["t_s"][m], out[m, 0], out[m, 1], out[m, 2], out[m, 3], ia[m], ib[m],
                  out[m, 4], out[m, 5])
