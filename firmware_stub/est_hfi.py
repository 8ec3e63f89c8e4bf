"""Python binding of ``est_hfi``: rotating HF injection + SDFT + PI tracking + polarity / initial
position (Hou et al. 2021, eq. 8-20 and section 3).

Per step, like the controller's ISR: the currents sampled at t_k and the alpha-beta voltage applied
over the previous period (unused by HFI, kept for a uniform estimator API). The output carries,
beside the angle and speed, the injection voltage to ADD to the FOC voltage command of this
period, the fundamental (HF-free) current for the current loop and the IPD status.
"""
from __future__ import annotations

from typing import NamedTuple

from ._binding import ffi, lib

IPD_STATES = {0: "TRACKING", 1: "IPD_CONVERGE", 2: "IPD_POLARITY", 3: "IPD_FAILED"}
POLARITY = {0: "UNKNOWN", 1: "KEPT", 2: "FLIPPED"}


class HfiOutput(NamedTuple):
    theta_e_rad: float
    omega_e_rad_s: float
    e_alpha_v: float          # 0: HFI has no back EMF
    e_beta_v: float
    v_inj_alpha_v: float      # add to the alpha-beta command of this period
    v_inj_beta_v: float
    i_fund_alpha_a: float     # measured minus reconstructed HF
    i_fund_beta_a: float
    i_d_req_a: float          # d current asked for by the polarity test (bias method)
    amp_d_a: float            # |i_d''|
    amp_q_a: float            # |i_q''|
    err: float                # eq. 15 error (normalised by default)
    dtheta_est_rad: float     # IPD only
    ipd_state: str            # IPD_STATES value
    polarity: str             # POLARITY value
    pol_metric: float         # r of the last polarity test
    pol_se: float             # its standard error (pure method's sequential test)
    pol_time_s: float         # how long that test ran


class Hfi:
    """HF-injection estimator for an IPMSM (Ld < Lq)."""

    name = "HFI_SDFT"

    def __init__(self, rs_ohm: float, ld_h: float, lq_h: float, ts_s: float, *,
                 bandwidth_rad_s: float | None = None, **config: float):
        self._cfg = ffi.new("est_hfi_config_t *")
        lib.est_hfi_default_config(self._cfg, rs_ohm, ld_h, lq_h, ts_s)
        for key, value in config.items():
            if not hasattr(self._cfg, key):
                raise ValueError(f"Hfi: unknown configuration field {key!r}")
            setattr(self._cfg, key, value)
        if bandwidth_rad_s is not None:
            lib.est_hfi_set_bandwidth(self._cfg, bandwidth_rad_s)
        self._s = ffi.new("est_hfi_t *")
        if lib.est_hfi_init(self._s, self._cfg) != 0:
            m = 1.0 / (self._cfg.f_inj_hz * ts_s) if self._cfg.f_inj_hz * ts_s > 0 else float("nan")
            raise ValueError(f"Hfi: invalid configuration (1/(f_inj_hz*ts_s) = {m:.4g} must be an "
                             f"even integer 4..{int(lib.EST_DFT_MAX_M)}; need 0 < ld_h={ld_h} < "
                             f"lq_h={lq_h}, u_inj_v > 0)")
        self._i = ffi.new("fw_vec2_t *")
        self._v = ffi.new("fw_vec2_t *")

    @property
    def state(self):
        """The live C state struct (read-only use)."""
        return self._s

    @property
    def samples_per_hf_period(self) -> int:
        return int(self._s.m)

    def expected_amplitudes(self) -> tuple[float, float]:
        """(I0, I1) of eq. 11 [A] for this configuration (ideal, R = 0)."""
        i0, i1 = ffi.new("float *"), ffi.new("float *")
        lib.est_hfi_expected_amplitudes(ffi.addressof(self._s, "cfg"), i0, i1)
        return i0[0], i1[0]

    def reset(self) -> None:
        lib.est_hfi_reset(self._s)

    def start_ipd(self) -> None:
        lib.est_hfi_start_ipd(self._s)

    def set_angle(self, theta_rad: float, omega_rad_s: float = 0.0) -> None:
        lib.est_hfi_set_angle(self._s, theta_rad, omega_rad_s)

    def step(self, i_alpha_a: float, i_beta_a: float, v_alpha_prev_v: float = 0.0,
             v_beta_prev_v: float = 0.0) -> HfiOutput:
        i, v = self._i, self._v
        i.x, i.y, v.x, v.y = i_alpha_a, i_beta_a, v_alpha_prev_v, v_beta_prev_v
        o = lib.est_hfi_step(self._s, i[0], v[0])
        return HfiOutput(o.est.theta_e_rad, o.est.omega_e_rad_s, o.est.e_alpha_v, o.est.e_beta_v,
                         o.v_inj_ab_v.x, o.v_inj_ab_v.y, o.i_fund_ab_a.x, o.i_fund_ab_a.y,
                         o.i_d_req_a, o.amp_d_a, o.amp_q_a, o.err, o.dtheta_est_rad,
                         IPD_STATES[o.ipd_state], POLARITY[o.polarity], o.pol_metric,
                         o.pol_se, o.pol_time_s)


def hfi_for(profile, ts_s: float, **config) -> Hfi:
    """An HFI estimator for a motor profile (needs Ld < Lq, e.g. hou2021)."""
    return Hfi(profile.rs_ohm, profile.ld_h, profile.lq_h, ts_s, **config)
