"""Python bindings of the reference estimator library (the same C the stub and the DSP run).

Each class wraps one ``est_*`` module: it is built from SI parameters, and ``step`` takes the
currents sampled at t_k and the alpha-beta voltage applied over the previous period, exactly as
the controller's ISR calls it. Outputs are float32 values promoted to Python floats.

``REFERENCE_ESTIMATORS`` maps the names a scenario uses to a factory taking the motor profile.
"""
from __future__ import annotations

from typing import Any, Callable

from ._binding import EstimatorOutput, configure as _configure, ffi, lib


def _vec(x: float, y: float):
    v = ffi.new("fw_vec2_t *")
    v.x = x
    v.y = y
    return v[0]


def _configure(cfg: Any, overrides: dict[str, float], where: str) -> None:
    for key, value in overrides.items():
        if not hasattr(cfg, key):
            raise ValueError(f"{where}: unknown configuration field {key!r}")
        setattr(cfg, key, value)


class SmoSign:
    """Conventional sign SMO with LPF and atan(w/wc) compensation (Yuan eq. 4-10, Gong eq. 3-7)."""

    name = "SMO_SIGN"

    def __init__(self, rs_ohm: float, ls_h: float, psi_f_wb: float, ts_s: float, **config: float):
        self._cfg = ffi.new("est_smo_sign_config_t *")
        lib.est_smo_sign_default_config(self._cfg, rs_ohm, ls_h, psi_f_wb, ts_s)
        _configure(self._cfg, config, "SmoSign")
        self._s = ffi.new("est_smo_sign_t *")
        if lib.est_smo_sign_init(self._s, self._cfg) != 0:
            raise ValueError(f"SmoSign: invalid configuration (ls_h={ls_h}, ts_s={ts_s}, "
                             f"wc_rad_s={self._cfg.wc_rad_s})")
        self._i = ffi.new("fw_vec2_t *")
        self._v = ffi.new("fw_vec2_t *")

    @property
    def state(self):
        """The live C state struct (read-only use)."""
        return self._s

    def reset(self) -> None:
        lib.est_smo_sign_reset(self._s)

    def step(self, i_alpha_a: float, i_beta_a: float, v_alpha_prev_v: float,
             v_beta_prev_v: float) -> EstimatorOutput:
        i, v = self._i, self._v
        i.x, i.y, v.x, v.y = i_alpha_a, i_beta_a, v_alpha_prev_v, v_beta_prev_v
        o = lib.est_smo_sign_step(self._s, i[0], v[0])
        return EstimatorOutput(o.theta_e_rad, o.omega_e_rad_s, o.e_alpha_v, o.e_beta_v)


def smo_sign_for(profile, ts_s: float, **config: float) -> SmoSign:
    """A sign SMO for a motor profile (Ls = Lq: for an IPMSM the q-axis inductance)."""
    return SmoSign(profile.rs_ohm, profile.lq_h, profile.psi_f_wb, ts_s, **config)


def _registry() -> dict[str, Callable[..., Any]]:
    from .est_hfi import hfi_for
    from .est_smo import smo_sigmoid_for, smo_tanh_for

    return {"SMO_SIGN": smo_sign_for, "SMO_SIGMOID": smo_sigmoid_for, "SMO_TANH": smo_tanh_for,
            "HFI_SDFT": hfi_for}


#: scenario name -> factory(profile, ts_s, **config); a scenario may list the same estimator
#: several times as NAME:label with a configuration each (e.g. "SMO_TANH:m1")
REFERENCE_ESTIMATORS: dict[str, Callable[..., Any]] = _registry()
