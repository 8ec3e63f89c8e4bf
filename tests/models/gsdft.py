"""Float64 reference of the generalized sliding DFT (Yuan eq. 26-27), independent of the C.

* ``paper_gsdft_tf`` -- G_S^k(z) (eq. 27) as (b, a) for scipy.signal.lfilter: the comb
  (1 - z^{-M/6} e^{j pi/3})(1 - z^{-M/6} e^{-j pi/3}) built by np.convolve from its two factors;
* ``paper_gain`` -- its gain at the bin (sqrt(3)/6 in magnitude: not unity);
* ``from_paper_output`` -- the library's normalisation: P = c y / G_S(e^{j w_k}) e^{... } such that a
  unit harmonic reads 1 with the phase of the newest sample (c = 2 for a real input);
* ``gsdft_phasors`` -- the normalised filter evaluated as an explicit FIR over 2L = M/3 taps,
  h_i = e^{j w_k i} w_i / (L (1 + c_k)), w_i = 1 (i < L) or c_k = e^{j w_k L} (L <= i < 2L),
  optionally preceded by the DC block (1 - z^-1) / (1 - e^{-j w_k}).
"""
from __future__ import annotations

import numpy as np
from scipy import signal

from tests.models.sdft import omega_k


def check(m: int, k: int) -> None:
    if m % 6:
        raise ValueError(f"M = {m} is not a multiple of 6")
    if k % 6 not in (1, 5):
        raise ValueError(f"k = {k} is not in the 6h+-1 family")


def paper_gsdft_tf(m: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) of G_S^k(z) (Yuan eq. 27) with the paper's 1/M factor."""
    check(m, k)
    l = m // 6
    f1 = np.zeros(l + 1, dtype=complex)
    f2 = np.zeros(l + 1, dtype=complex)
    f1[0] = f2[0] = 1.0
    f1[l] = -np.exp(1j * np.pi / 3)
    f2[l] = -np.exp(-1j * np.pi / 3)
    w = np.exp(1j * omega_k(m, k))
    return np.convolve(f1, f2) * w / m, np.array([1.0, -w])


def paper_gain(m: int, k: int) -> complex:
    """G_S^k at its own bin, from the transfer function (limit: pole and zero cancel)."""
    b, a = paper_gsdft_tf(m, k)
    _, h = signal.freqz(b, a, worN=[omega_k(m, k) + 1e-9])
    return complex(h[0])


def normalisation(m: int, k: int, real_input: bool, dc_block: bool = False) -> complex:
    """Factor turning the paper's output into the library phasor (unit harmonic reads 1)."""
    c = 2.0 if real_input else 1.0
    l = m // 6
    ck = np.exp(1j * omega_k(m, k) * l)
    g = c * m * np.exp(-1j * omega_k(m, k)) / (l * (1 + ck))
    if dc_block:
        g /= 1.0 - np.exp(-1j * omega_k(m, k))
    return g


def from_paper_output(y: np.ndarray, m: int, k: int, real_input: bool) -> np.ndarray:
    return normalisation(m, k, real_input) * np.asarray(y)


def window_weights(m: int, k: int, real_input: bool, dc_block: bool = False) -> np.ndarray:
    """Taps of the normalised GSDFT as one FIR (M/3 taps, M/3 + 1 with the DC block)."""
    check(m, k)
    l = m // 6
    wk = omega_k(m, k)
    ck = np.exp(1j * wk * l)
    i = np.arange(2 * l)
    h = np.exp(1j * wk * i) * np.where(i < l, 1.0, ck) / (l * (1 + ck))
    if real_input:
        h = 2.0 * h
    if dc_block:
        h = np.convolve(h, [1.0, -1.0]) / (1.0 - np.exp(-1j * wk))
    return h


def gsdft_phasors(x: np.ndarray, m: int, k: int, real_input: bool,
                  dc_block: bool = False) -> np.ndarray:
    """Normalised phasor of bin k after every sample (explicit FIR, zeros before x[0])."""
    x = np.real(x) if real_input else np.asarray(x, dtype=complex)
    return np.convolve(x, window_weights(m, k, real_input, dc_block))[: len(x)]
