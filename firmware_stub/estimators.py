"""Python bindings of the reference estimator library (the same C the stub and the DSP run).

Each class wraps one ``est_*`` module: it is built from SI parameters, and ``step`` takes the
currents sampled at t_k and the alpha-beta voltage applied over the previous period, exactly as
the controller's ISR calls it. Outputs are float32 values promoted to Python floats.

``REFERENCE_ESTIMATORS`` maps the names a scenario uses to a factory taking the motor profile.
"""
from __future__ import annotations

from typing import Any, Callable

from ._binding import EstimatorOutput
from .est_hfi import hfi_for
from .est_smo import SmoSign, smo_sigmoid_for, smo_sta_for, smo_tanh_for


def smo_sign_for(profile, ts_s: float, **config: float) -> SmoSign:
    """A sign SMO for a motor profile (Ls = Lq: for an IPMSM the q-axis inductance)."""
    return SmoSign(profile.rs_ohm, profile.lq_h, profile.psi_f_wb, ts_s, **config)


#: scenario name -> factory(profile, ts_s, **config); a scenario may list the same estimator
#: several times as NAME:label with a configuration each (e.g. "SMO_TANH:m1")
REFERENCE_ESTIMATORS: dict[str, Callable[..., Any]] = {
    "SMO_SIGN": smo_sign_for, "SMO_SIGMOID": smo_sigmoid_for, "SMO_TANH": smo_tanh_for,
    "HFI_SDFT": hfi_for, "SMO_STA": smo_sta_for,
}

__all__ = ["EstimatorOutput", "SmoSign", "REFERENCE_ESTIMATORS", "smo_sign_for"]
