"""What a Yuan Y1/Y8 recording shows about closing the loop at low speed under full load
(docs/claims.md, "The residual study"): the observer's EMF against the plant's, the angle error
and its spread, and whether the drive held its speed.

    .venv/bin/bench run yuan_y1_improved --out r0.mcap \\
        --set controller.inverter_comp.residual=0.0            # compensation exact
    .venv/bin/bench run yuan_y1_improved --out nodt.mcap \\
        --set plant.inverter_nonlinear=false --set plant.adc_seed=2
    .venv/bin/python tools/y1_diagnosis.py r0.mcap nodt.mcap [--handover-s 2.29]

Per recording, in the I-f window before the hand-over (1.5 s .. HANDOVER) and the 20 ms after it:
the true EMF's mean magnitude, the observer's EMF error (rms of the complex difference, and its
mean components along and across the true EMF), the angle error's mean and standard deviation;
then, per speed window of Yuan's scenario (2.8-3.3 s at 10 rpm, 3.8-4.3 s at 50 rpm), the true
mean speed and the largest |estimated - true| speed. A window after the run ended says so.
Diagnostic figures (float64 from the recording), not a verdict: the claims' rules are in
``bench claims``.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

SPEED_WINDOWS_S = ((2.8, 3.3), (3.8, 4.3))   # yuan_y1_improved: 10 rpm, then 50 rpm


def _wrap_deg(x: np.ndarray) -> np.ndarray:
    return np.degrees(np.angle(np.exp(1j * x)))


def describe(path: str, handover_s: float) -> list[str]:
    from hil_bench.record.recording import load_recording

    rec = load_recording(path, topics=["/plant/state", "/controller/telemetry"])
    p, c = rec.topic("/plant/state"), rec.topic("/controller/telemetry")
    n = min(len(p["t_s"]), len(c["t_s"]))
    t = np.asarray(p["t_s"][:n])
    e_hat = np.asarray(c["e_alpha_v"][:n]) + 1j * np.asarray(c["e_beta_v"][:n])
    e_true = np.asarray(p["e_alpha_v"][:n]) + 1j * np.asarray(p["e_beta_v"][:n])
    theta = np.asarray(p["theta_e_rad"][:n])
    # E = j w psi_f e^{j theta}: rotated by -(theta + pi/2) the true EMF lies on the real axis
    err_frame = (e_hat - e_true) * np.exp(-1j * (theta + np.pi / 2))
    ang_err = _wrap_deg(np.asarray(c["theta_hat_rad"][:n]) - theta)
    lines = [f"{path}: {n} cycles, to t = {t[-1]:.4f} s"]
    for a, b in ((1.5, handover_s), (handover_s, handover_s + 0.02)):
        m = (t >= a) & (t < b)
        if not m.any():
            lines.append(f"  [{a:.3f}, {b:.3f}) s: no cycles")
            continue
        rms = float(np.sqrt(np.mean(np.abs(e_hat[m] - e_true[m]) ** 2)))
        lines.append(f"  [{a:.3f}, {b:.3f}) s: |E| {np.abs(e_true[m]).mean():.3f} V, EMF error rms "
                     f"{rms:.3f} V (mean along {err_frame[m].real.mean():+.3f}, across "
                     f"{err_frame[m].imag.mean():+.3f} V), angle error mean "
                     f"{ang_err[m].mean():+.1f} deg, std {ang_err[m].std():.1f} deg")
    for a, b in SPEED_WINDOWS_S:
        m = (t >= a) & (t < b)
        if m.sum() < 10:
            lines.append(f"  speed window {a}-{b} s: the run had ended")
            continue
        true = np.asarray(p["speed_rpm"][:n])[m]
        err = np.asarray(c["speed_hat_rpm"][:n])[m] - true
        lines.append(f"  speed window {a}-{b} s: true mean {true.mean():.2f} rpm, "
                     f"max |error| {np.abs(err).max():.2f} rpm")
    return lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+")
    ap.add_argument("--handover-s", type=float, default=2.29,
                    help="the I-f to closed-loop hand-over time of the scenario [s]")
    args = ap.parse_args()
    for path in args.recordings:
        print("\n".join(describe(path, args.handover_s)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
