"""Claims measured without a closed-loop run: the papers' own signal-processing experiments.

* ``y5()`` - Yuan IV.A.1, Fig. 11-12: the input sin(500 pi t), amplitude 1 -> 2 at 0.2 s,
  through the C library's SDFT and GSDFT as the paper sets them up: M = 24 and k = 5 (its
  pole-zero example, Fig. 5 and 7). The 250 Hz tone is then the 5th harmonic of a window that
  spans one 50 Hz period, so fs = 24 x 50 Hz = 1200 Hz. Tracking time: from the start (or the
  step) until the extracted amplitude stays within 2 % of its final value. Both are FIRs (M and
  M/3 taps): exactly settled once the window holds only new samples, M - 1 = 23 and 7 samples
  after the first new one, 4.79 and 1.46 cycles; the 2 % criterion gives the same.
* ``y6()`` - Yuan Table 2: the cost of the 5th + 7th extraction per sample, GSDFT against SDFT,
  counted by callgrind (x86-64 instructions of this library's C, bench/perf/estimators.py).

Each returns a dict: scalar results by key plus arrays for the report's plots.
"""
from __future__ import annotations

import math
import shutil

import numpy as np

Y5_FS_HZ = 1200.0       # 24 samples per 50 Hz period
Y5_M = 24
Y5_BIN = 5              # 250 Hz is the 5th harmonic of 50 Hz
Y5_TONE_HZ = 250.0


def tracking_samples(amp: np.ndarray, start: int, final: float, tol: float) -> int:
    """Samples from ``start`` until |amp - final| <= tol final holds to the end."""
    bad = np.nonzero(np.abs(amp[start:] - final) > tol * final)[0]
    return int(bad[-1] + 1) if bad.size else 0


def y5() -> dict:
    from firmware_stub.est_dft import Gsdft, Sdft

    t = np.arange(int(round(0.5 * Y5_FS_HZ))) / Y5_FS_HZ
    amp_in = np.where(t < 0.2, 1.0, 2.0)
    x = amp_in * np.sin(2 * math.pi * Y5_TONE_HZ * t)
    i_step = int(np.argmax(t >= 0.2))
    per_cycle = Y5_FS_HZ / Y5_TONE_HZ          # 4.8 samples per cycle of the tone
    out: dict = {"t_s": t, "x": x, "amp_in": amp_in}
    for name, est, window in (("SDFT", Sdft(Y5_M, [Y5_BIN]), Y5_M),
                              ("GSDFT", Gsdft(Y5_M, [Y5_BIN]), Y5_M // 3)):
        # window: the FIR is exactly settled (window - 1) samples after the first new sample
        amp = np.abs(est.run(x)[:, 0])
        out[f"{name}.amp"] = amp
        out[f"{name}.start"] = tracking_samples(amp[:i_step], 0, 1.0, 0.02) / per_cycle
        out[f"{name}.step"] = tracking_samples(amp, i_step, 2.0, 0.02) / per_cycle
        out[f"{name}.window"] = (window - 1) / per_cycle
    return out


def y6(n: int = 20000) -> dict:
    """Instructions per sample for the 5th + 7th extraction (M = 24), protected and direct
    forms, real input; savings in % (positive: the GSDFT is cheaper)."""
    if shutil.which("valgrind") is None:
        raise RuntimeError("valgrind not found: the Y6 count needs callgrind "
                           "(apt-get install valgrind)")
    from .perf import estimators as perf

    try:
        exe, _notes = perf.build(perf.OPTIONAL)
        per = {}
        for case in ("empty", "sdft_57_real_mod", "gsdft_57_real_mod", "sdft_57_real_direct",
                     "gsdft_57_real_direct"):
            ir = perf.instructions(exe, case, n)
            if ir is None:
                raise RuntimeError(f"callgrind case {case} not in the build")
            per[case] = ir / n
    except SystemExit as exc:         # the benchmark exits on a failed build or run
        raise RuntimeError(f"callgrind benchmark failed: {exc}") from None
    o = per["empty"]
    out = {f"{k}": v - o for k, v in per.items() if k != "empty"}
    out["saving_protected"] = 100.0 * (1.0 - out["gsdft_57_real_mod"] / out["sdft_57_real_mod"])
    out["saving_direct"] = 100.0 * (1.0 - out["gsdft_57_real_direct"] / out["sdft_57_real_direct"])
    out["n"] = n
    return out


STUDIES = {"Y5": y5, "Y6": y6}
