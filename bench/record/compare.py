"""Two recordings of the same scenario, compared cycle by cycle: what the controller reported
(TELEM angle and speed) and where the plant went, e.g. the firmware on the target (``pil-qemu``,
float32 on a Cortex-M4F, newlib's libm) against the host build (``stub``, glibc's libm).

In lockstep both runs see the same plant at cycle 0; every difference after that is the
controllers' arithmetic, fed back through the plant.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import channels as ch
from .recording import load_recording


@dataclass
class RunDifference:
    cycles: int                   # cycles compared (the shorter run's)
    theta_hat_max_rad: float      # max |wrap(theta_hat_a - theta_hat_b)|
    theta_hat_rms_rad: float
    speed_hat_max_rpm: float      # max |speed_hat_a - speed_hat_b| (TELEM omega_hat)
    speed_hat_rms_rpm: float
    speed_max_rpm: float          # the plant's true speed
    first_cycle: int | None       # first cycle whose TELEM angle or speed differ (None: never)

    def text(self) -> str:
        first = "never" if self.first_cycle is None else f"from cycle {self.first_cycle}"
        return (f"{self.cycles} cycles: TELEM angle max {self.theta_hat_max_rad:.2e} rad "
                f"(rms {self.theta_hat_rms_rad:.2e}), TELEM speed max {self.speed_hat_max_rpm:.3g} "
                f"rpm (rms {self.speed_hat_rms_rpm:.2g}), plant speed max {self.speed_max_rpm:.3g} "
                f"rpm; the TELEM differ {first}")


def compare_recordings(a: Path, b: Path, t0_s: float = 0.0) -> RunDifference:
    """Differences of ``a`` - ``b`` over the cycles both recorded from ``t0_s`` on."""
    ra, rb = load_recording(a), load_recording(b)
    ta, tb = ra.topic(ch.CONTROLLER_TELEMETRY), rb.topic(ch.CONTROLLER_TELEMETRY)
    sa, sb = ra.topic(ch.PLANT_STATE), rb.topic(ch.PLANT_STATE)
    n = min(len(ta["t_s"]), len(tb["t_s"]), len(sa["t_s"]), len(sb["t_s"]))
    if n == 0:
        raise ValueError(f"{a} / {b}: no cycle recorded in both")
    if not np.array_equal(ta["seq"][:n], tb["seq"][:n]):
        raise ValueError(f"{a} / {b}: the TELEM rows are not the same cycles (decimated "
                         f"differently?)")
    keep = ta["t_s"][:n] >= t0_s
    dth = np.angle(np.exp(1j * (ta["theta_hat_rad"][:n] - tb["theta_hat_rad"][:n])))[keep]
    dsp = (ta["speed_hat_rpm"][:n] - tb["speed_hat_rpm"][:n])[keep]
    dpl = (sa["speed_rpm"][:n] - sb["speed_rpm"][:n])[keep]
    differ = np.flatnonzero((np.abs(dth) > 0) | (np.abs(dsp) > 0))
    seq = ta["seq"][:n][keep]
    return RunDifference(
        cycles=int(keep.sum()),
        theta_hat_max_rad=float(np.max(np.abs(dth))), theta_hat_rms_rad=float(np.sqrt(np.mean(dth**2))),
        speed_hat_max_rpm=float(np.max(np.abs(dsp))), speed_hat_rms_rpm=float(np.sqrt(np.mean(dsp**2))),
        speed_max_rpm=float(np.max(np.abs(dpl))),
        first_cycle=int(seq[differ[0]]) if differ.size else None)
