"""Float64 reference of the sliding DFT (Yuan eq. 19-25, Hou eq. 16-20), independent of the C.

Two independent evaluations of the same thing:
* ``paper_sdft_tf`` -- the paper's transfer function G^k(z) (Yuan eq. 24) as (b, a) for
  scipy.signal.lfilter, and ``from_paper_output`` -- the normalisation that turns its output into
  the library's phasor (unit harmonic reads 1, phase at the newest sample): P = c e^{-j w_k} y;
* ``sdft_phasors`` -- the window sum evaluated directly as an FIR (np.convolve), no recursion:
  P_k(n) = (c/M) sum_{i<M} x(n-i) e^{+j w_k i}, with zeros before the first sample.
c = 2 for a real input (k != 0, M/2), else 1.
"""
from __future__ import annotations

import numpy as np


def omega_k(m: int, k: int) -> float:
    """Bin frequency w_k = 2 pi k / M [rad/sample]."""
    return 2.0 * np.pi * k / m


def real_scale(m: int, k: int, real_input: bool) -> float:
    """c: 2 for a real input unless the bin is its own mirror (k = 0 or M/2)."""
    kk = k % m
    return 2.0 if real_input and kk != 0 and 2 * kk != m else 1.0


def paper_sdft_tf(m: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) of G^k(z) = (1 - z^-M) e^{j w_k} / (M (1 - z^-1 e^{j w_k}))  (Yuan eq. 24)."""
    w = np.exp(1j * omega_k(m, k))
    b = np.zeros(m + 1, dtype=complex)
    b[0], b[m] = 1.0, -1.0
    return b * w / m, np.array([1.0, -w])


def from_paper_output(y: np.ndarray, m: int, k: int, real_input: bool) -> np.ndarray:
    """The library's phasor from the paper's SDFT output: c e^{-j w_k} y."""
    return real_scale(m, k, real_input) * np.exp(-1j * omega_k(m, k)) * np.asarray(y)


def window_weights(m: int, k: int, real_input: bool) -> np.ndarray:
    """FIR taps h_i = (c/M) e^{j w_k i}, i = 0..M-1."""
    i = np.arange(m)
    return real_scale(m, k, real_input) / m * np.exp(1j * omega_k(m, k) * i)


def sdft_phasors(x: np.ndarray, m: int, k: int, real_input: bool) -> np.ndarray:
    """Phasor of bin k after every sample of x (direct window sum, zeros before x[0])."""
    x = np.real(x) if real_input else np.asarray(x, dtype=complex)
    return np.convolve(x, window_weights(m, k, real_input))[: len(x)]


def tracking_time_samples(amplitude: np.ndarray, start: int, final: float, band: float) -> int:
    """Samples from ``start`` until |amplitude - final| stays within band * |final| for good."""
    outside = np.nonzero(np.abs(amplitude[start:] - final) > band * abs(final))[0]
    return 0 if len(outside) == 0 else int(outside[-1]) + 1
