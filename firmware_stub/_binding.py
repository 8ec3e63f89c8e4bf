"""What every estimator wrapper shares: the compiled module and the common output type."""
from __future__ import annotations

from typing import Any, NamedTuple

try:
    from ._fw_c import ffi, lib
except ImportError as exc:  # pragma: no cover - exercised only without a build
    raise ImportError("hil_bench.firmware_stub._fw_c is not built: run `make build` "
                      f"(tools/build_native.py) first ({exc})") from None


class EstimatorOutput(NamedTuple):
    theta_e_rad: float
    omega_e_rad_s: float
    e_alpha_v: float
    e_beta_v: float


def configure(cfg: Any, overrides: dict[str, float], where: str) -> None:
    """Set fields of a C config struct by name; an unknown name is an error naming it."""
    for key, value in overrides.items():
        if not hasattr(cfg, key):
            raise ValueError(f"{where}: unknown configuration field {key!r}")
        setattr(cfg, key, value)


__all__ = ["ffi", "lib", "EstimatorOutput", "configure"]
