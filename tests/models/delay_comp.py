"""Dual-sampling delay estimate and current pre-compensation, float64 (Gong eq. 20-22).

Written from the paper, independently of firmware_stub/src/est_delay_comp.c, vectorised over a
whole record: i1[k, x] is phase x sampled at t_k, i2[k, x] at t_k + t_d.

* eq. 20: t_d(k, x) = |i2(k) - i1(k)| / |i2(k) - i2(k-1)| * Ts, kept where the denominator is at
  least min_step_a and the value is in [0, t_d_max_s]; the per-period estimate is the mean of
  the kept phases; the running estimate is the mean of the per-period ones (the plain mean of
  the first avg_n_max, then exponential forgetting with weight 1/avg_n_max);
* eq. 21-22: i'(k) = i1(k) + (i1(k) - i2(k-1)) / (Ts - t_d) * t_d, with the t_d known before
  period k (the running estimate of periods < k, t_d_fixed before the first).
"""
from __future__ import annotations

import math

import numpy as np


def per_period_estimates(i1: np.ndarray, i2: np.ndarray, ts_s: float, min_step_a: float,
                         t_d_max_s: float) -> np.ndarray:
    """Eq. 20 per period (NaN where no phase passes the guards; period 0 has no i2(k-1))."""
    num = np.abs(i2[1:] - i1[1:])
    den = np.abs(i2[1:] - i2[:-1])
    with np.errstate(divide="ignore", invalid="ignore"):
        td = num / den * ts_s
    ok = (den >= min_step_a) & (td <= t_d_max_s)
    td = np.where(ok, td, np.nan)
    out = np.full(len(i1), np.nan)
    with np.errstate(invalid="ignore"):
        counts = ok.sum(axis=1)
        sums = np.nansum(td, axis=1)
    out[1:] = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    return out


def running_mean(per_period: np.ndarray, avg_n_max: int) -> np.ndarray:
    """Running estimate after each period (NaN before the first valid one)."""
    out = np.full(len(per_period), np.nan)
    mean, n = math.nan, 0
    for k, x in enumerate(per_period):
        if not math.isnan(x):
            n += 1
            w = min(n, avg_n_max)
            mean = x if n == 1 else mean + (x - mean) / w
        out[k] = mean
    return out


def compensate(i1: np.ndarray, i2: np.ndarray, ts_s: float, t_d_s: np.ndarray) -> np.ndarray:
    """Eq. 21-22 for every period k >= 1 with the delay t_d_s[k]; period 0 is passed through."""
    out = np.array(i1, dtype=float, copy=True)
    td = np.asarray(t_d_s, dtype=float)[1:, None]
    out[1:] = i1[1:] + (i1[1:] - i2[:-1]) / (ts_s - td) * td
    return out


def clarke(abc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude-invariant Clarke of (n, 3) phase values (all three phases used)."""
    a, b, c = abc[:, 0], abc[:, 1], abc[:, 2]
    return (2.0 * a - b - c) / 3.0, (b - c) / math.sqrt(3.0)


def run(i1: np.ndarray, i2: np.ndarray, ts_s: float, t_d_fixed_s: float = 0.0,
        estimate_on: bool = True, min_step_a: float = 1e-3, t_d_max_s: float | None = None,
        avg_n_max: int = 1000) -> dict[str, np.ndarray]:
    """Whole-record model: per-period and running estimates, compensated currents."""
    t_d_max = 0.9 * ts_s if t_d_max_s is None else t_d_max_s
    per = per_period_estimates(i1, i2, ts_s, min_step_a, t_d_max)
    mean = running_mean(per, avg_n_max) if estimate_on else np.full(len(i1), np.nan)
    # the delay known at the start of period k: the running estimate after period k-1
    used = np.full(len(i1), t_d_fixed_s)
    known = np.concatenate([[np.nan], mean[:-1]])
    used = np.where(np.isnan(known), used, known)
    comp = compensate(i1, i2, ts_s, used)
    ia, ib = clarke(comp)
    return dict(t_d_period_s=per, t_d_mean_s=mean, t_d_used_s=used, i_comp_abc_a=comp,
                i_alpha_a=ia, i_beta_a=ib)
