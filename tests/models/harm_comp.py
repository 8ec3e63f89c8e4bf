"""Float64 reference of harm_comp (Yuan eq. 28-37), independent of the C.

* ``synthetic_current`` -- complex alpha-beta current sum_h I_h e^{j(h theta + phi_h)} (h = 1, -5,
  7, -11, 13, ...: the 5th is h = -5 because it is negative sequence), plus an optional DC offset;
* ``angle_synchronous`` -- the grid angles 2 pi j / M crossed by an unwrapped angle trajectory and
  the current linearly interpolated there (np.interp on the angle), vectorised;
* ``extract`` -- bins -5 and +7 of those samples by the direct-FIR models of the SDFT / GSDFT;
* ``harmonic_frames`` -- eq. 32-33: i_dq5 = P_-5 e^{+j5 theta_j}, i_dq7 = P_+7 e^{-j7 theta_j};
* ``compensation`` -- eq. 36-37 written term by term as printed in the paper;
* ``voltage_dq`` -- eq. 36-37 rotated back to dq: u5 e^{-j6 theta} + u7 e^{+j6 theta}.
"""
from __future__ import annotations

import numpy as np

from tests.models.gsdft import gsdft_phasors
from tests.models.sdft import sdft_phasors


def synthetic_current(theta_e_rad: np.ndarray, harmonics: dict[int, tuple[float, float]],
                      dc_a: complex = 0.0) -> np.ndarray:
    """i_ab = dc + sum_h I_h e^{j(h theta + phi_h)}; harmonics maps h -> (I_h [A], phi_h [rad])."""
    th = np.asarray(theta_e_rad, dtype=float)
    i = np.full(th.shape, complex(dc_a))
    for h, (amp, ph) in harmonics.items():
        i = i + amp * np.exp(1j * (h * th + ph))
    return i


def angle_synchronous(theta_unwrapped_rad: np.ndarray, i_ab: np.ndarray, m: int):
    """Grid crossings of a forward trajectory: (samples, grid index j, control step k) per crossing.

    A grid angle G is sampled at the first control step k with theta_k >= G (G >= theta_0),
    interpolated linearly in angle between steps k-1 and k, as harm_comp_step does.
    """
    th = np.asarray(theta_unwrapped_rad, dtype=float)
    dg = 2 * np.pi / m
    g_idx = np.arange(int(np.ceil(th[0] / dg)), int(np.floor(th[-1] / dg)) + 1)
    g = g_idx * dg
    x = np.interp(g, th, np.real(i_ab)) + 1j * np.interp(g, th, np.imag(i_ab))
    k = np.searchsorted(th, g, side="left")
    return x, np.mod(g_idx, m), k


def extract(samples: np.ndarray, m: int, extractor: str, dc_block: bool = True):
    """Phasors of bins -5 and +7 after every sample (complex input)."""
    if extractor == "gsdft":
        return (gsdft_phasors(samples, m, -5, False, dc_block),
                gsdft_phasors(samples, m, 7, False, dc_block))
    return sdft_phasors(samples, m, -5, False), sdft_phasors(samples, m, 7, False)


def harmonic_frames(p5: np.ndarray, p7: np.ndarray, grid_j: np.ndarray, m: int):
    """eq. 32-33 applied to the newest sample's phasors: (i_dq5, i_dq7)."""
    th = 2 * np.pi * np.asarray(grid_j) / m
    return p5 * np.exp(5j * th), p7 * np.exp(-7j * th)


def compensation(i5_a, theta5_rad, i7_a, theta7_rad, rs_ohm, ls_h, omega_e_rad_s, k_comp=1.0):
    """eq. 36 and 37 as printed: returns (u_d5 + j u_q5, u_d7 + j u_q7) [V]."""
    r, l, w = rs_ohm, ls_h, omega_e_rad_s
    u_d5 = -r * i5_a * np.cos(theta5_rad) - 5 * w * l * i5_a * np.sin(theta5_rad)
    u_q5 = -r * i5_a * np.sin(theta5_rad) + 5 * w * l * i5_a * np.cos(theta5_rad)
    u_d7 = -r * i7_a * np.cos(theta7_rad) + 7 * w * l * i7_a * np.sin(theta7_rad)
    u_q7 = -r * i7_a * np.sin(theta7_rad) - 7 * w * l * i7_a * np.cos(theta7_rad)
    return k_comp * (u_d5 + 1j * u_q5), k_comp * (u_d7 + 1j * u_q7)


def voltage_dq(u5_dq5, u7_dq7, theta_e_rad):
    """Compensation in dq: C_dq->dq5^-1 u5 + C_dq->dq7^-1 u7 (eq. 32-33 inverted)."""
    return u5_dq5 * np.exp(-6j * theta_e_rad) + u7_dq7 * np.exp(6j * theta_e_rad)
