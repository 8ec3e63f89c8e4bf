"""Python bindings of the sliding-DFT modules of the estimator library (the same C as the DSP).

* :class:`Sdft` -- ``est_sdft`` (Yuan eq. 19-25, Hou eq. 16-20): phasors of chosen bins of an
  M-sample window, normalised so a unit-amplitude harmonic reads 1, phase at the newest sample.
* :class:`Gsdft` -- ``est_gsdft`` (Yuan eq. 26-27): the same for 6h+-1 bins with an M/3 window.
* :class:`HarmComp` -- ``harm_comp`` (Yuan eq. 28-37): angle-synchronous 5th/7th extraction and
  the compensation voltages.

Phasors come back as Python complex numbers (float32 values promoted). ``form`` is
``"modulated"`` (default, drift-protected) or ``"direct"`` (the papers' recursion, drifts in
float32; for comparisons only).
"""
from __future__ import annotations

from typing import Iterable, NamedTuple, Sequence

import numpy as np

from ._binding import ffi, lib

FORMS = {"modulated": 0, "direct": 1}
MAX_M = int(lib.EST_DFT_MAX_M)
MAX_BINS = int(lib.EST_DFT_MAX_BINS)


def _form(form: str, where: str) -> int:
    if form not in FORMS:
        raise ValueError(f"{where}: form must be one of {sorted(FORMS)}, got {form!r}")
    return FORMS[form]


def _set_bins(cfg, bins: Sequence[int], where: str) -> None:
    if not 1 <= len(bins) <= MAX_BINS:
        raise ValueError(f"{where}: 1..{MAX_BINS} bins, got {len(bins)}")
    cfg.n_bins = len(bins)
    for i, k in enumerate(bins):
        cfg.k[i] = int(k)


class _SlidingDft:
    """Common wrapper: ``step(x)`` one sample (real or complex) -> tuple of complex phasors."""

    _prefix = ""

    def __init__(self):
        self._step = getattr(lib, f"{self._prefix}_step")
        self._n = 0

    @property
    def state(self):
        """The live C state struct (read-only use)."""
        return self._s

    @property
    def n_bins(self) -> int:
        return self._n

    def reset(self) -> None:
        getattr(lib, f"{self._prefix}_reset")(self._s)

    def valid(self) -> bool:
        """True once a full window has been received since reset."""
        return bool(getattr(lib, f"{self._prefix}_valid")(self._s))

    def step(self, x: complex | float) -> tuple[complex, ...]:
        """One sample; returns the phasors of the newest sample, one per bin."""
        p = self._step(self._s, float(np.real(x)), float(np.imag(x)))
        return tuple(complex(p[b].re, p[b].im) for b in range(self._n))

    def run(self, x: Iterable[complex | float]) -> np.ndarray:
        """Step through x; returns an (n, n_bins) complex array of the phasors after each sample."""
        xs = np.asarray(list(x) if not isinstance(x, np.ndarray) else x)
        out = np.empty((len(xs), self._n), dtype=complex)
        re, im = np.real(xs).astype(float), np.imag(xs).astype(float)
        step, s, n = self._step, self._s, self._n
        for i in range(len(xs)):
            p = step(s, re[i], im[i])
            for b in range(n):
                out[i, b] = complex(p[b].re, p[b].im)
        return out


class Sdft(_SlidingDft):
    """Sliding DFT over m samples at bins ``bins`` (Yuan eq. 22, Hou eq. 20)."""

    _prefix = "est_sdft"

    def __init__(self, m: int, bins: Sequence[int] = (1,), *, real_input: bool = True,
                 form: str = "modulated", resync: bool = True):
        super().__init__()
        cfg = ffi.new("est_sdft_config_t *")
        lib.est_sdft_default_config(cfg, int(m), int(bins[0]) if bins else 0)
        _set_bins(cfg, bins, "Sdft")
        cfg.real_input = int(real_input)
        cfg.form = _form(form, "Sdft")
        cfg.resync = int(resync)
        self._s = ffi.new("est_sdft_t *")
        if lib.est_sdft_init(self._s, cfg) != 0:
            raise ValueError(f"Sdft: invalid configuration (m={m} must be 2..{MAX_M}, "
                             f"bins={list(bins)} must satisfy -m < k < m)")
        self._n = len(bins)
        self.m = int(m)


class Gsdft(_SlidingDft):
    """Generalized SDFT (Yuan eq. 27): m a multiple of 6, bins in the 6h+-1 family."""

    _prefix = "est_gsdft"

    def __init__(self, m: int, bins: Sequence[int] = (1,), *, real_input: bool = True,
                 dc_block: bool = False, form: str = "modulated", resync: bool = True):
        super().__init__()
        cfg = ffi.new("est_gsdft_config_t *")
        lib.est_gsdft_default_config(cfg, int(m), int(bins[0]) if bins else 1)
        _set_bins(cfg, bins, "Gsdft")
        cfg.real_input = int(real_input)
        cfg.dc_block = int(dc_block)
        cfg.form = _form(form, "Gsdft")
        cfg.resync = int(resync)
        self._s = ffi.new("est_gsdft_t *")
        if lib.est_gsdft_init(self._s, cfg) != 0:
            raise ValueError(f"Gsdft: invalid configuration (m={m} must be a multiple of 6 in "
                             f"6..{MAX_M}; bins={list(bins)} must be 6h+-1 with -m < k < m)")
        self._n = len(bins)
        self.m = int(m)

    @property
    def window(self) -> int:
        """Window length in samples (M/3, +1 with the DC block)."""
        return int(lib.est_gsdft_window(self._s))


class HarmOutput(NamedTuple):
    valid: bool
    n_samples: int
    i5_a: float
    theta5_rad: float
    i7_a: float
    theta7_rad: float
    i_dq5_a: complex    # I5 e^{j theta5}: the 5th in its harmonic frame (eq. 32)
    i_dq7_a: complex
    u5_dq5_v: complex   # eq. 36 (times k_comp)
    u7_dq7_v: complex   # eq. 37 (times k_comp)


EXTRACTORS = {"gsdft": 0, "sdft": 1}


class HarmComp:
    """5th/7th extraction by angle-synchronous GSDFT/SDFT and eq. 36-37 (harm_comp)."""

    def __init__(self, rs_ohm: float, ls_h: float, ts_s: float, *, extractor: str = "gsdft",
                 **config: float):
        if extractor not in EXTRACTORS:
            raise ValueError(f"HarmComp: extractor must be one of {sorted(EXTRACTORS)}, "
                             f"got {extractor!r}")
        cfg = ffi.new("harm_comp_config_t *")
        lib.harm_comp_default_config(cfg, rs_ohm, ls_h, ts_s)
        cfg.extractor = EXTRACTORS[extractor]
        for key, value in config.items():
            if not hasattr(cfg, key):
                raise ValueError(f"HarmComp: unknown configuration field {key!r}")
            setattr(cfg, key, value)
        self._s = ffi.new("harm_comp_t *")
        if lib.harm_comp_init(self._s, cfg) != 0:
            raise ValueError(f"HarmComp: invalid configuration (m={cfg.m} must be a multiple of 6 "
                             f"<= {MAX_M}, ls_h={cfg.ls_h} > 0, 0 < omega_min_rad_s="
                             f"{cfg.omega_min_rad_s} < omega_max_rad_s={cfg.omega_max_rad_s})")
        self._i = ffi.new("fw_vec2_t *")

    @property
    def state(self):
        return self._s

    @property
    def config(self):
        return self._s.cfg

    def reset(self) -> None:
        lib.harm_comp_reset(self._s)

    def step(self, i_alpha_a: float, i_beta_a: float, theta_e_rad: float,
             omega_e_rad_s: float) -> HarmOutput:
        i = self._i
        i.x, i.y = i_alpha_a, i_beta_a
        o = lib.harm_comp_step(self._s, i[0], theta_e_rad, omega_e_rad_s)
        return HarmOutput(bool(o.valid), int(o.n_samples), o.i5_a, o.theta5_rad, o.i7_a,
                          o.theta7_rad, complex(o.i_dq5_a.x, o.i_dq5_a.y),
                          complex(o.i_dq7_a.x, o.i_dq7_a.y), complex(o.u5_dq5_v.x, o.u5_dq5_v.y),
                          complex(o.u7_dq7_v.x, o.u7_dq7_v.y))

    def voltage_dq(self, theta_e_rad: float) -> complex:
        """Compensation voltage u_d + j u_q at theta_e_rad (add to the current-loop output)."""
        u = lib.harm_comp_voltage_dq(self._s, theta_e_rad)
        return complex(u.x, u.y)


def harm_comp_for(profile, ts_s: float, **config) -> HarmComp:
    """harm_comp for a motor profile (L_s = L_d; the paper's machine is an SPMSM)."""
    return HarmComp(profile.rs_ohm, profile.ld_h, ts_s, **config)
