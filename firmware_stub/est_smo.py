"""Python bindings of the SMO-family estimators beyond the sign SMO (same C as the stub and DSP).

* :class:`SmoSigmoid` - Yuan's improved SMO (sigmoid switching, intermediate variable H),
  ``firmware_stub/src/est_smo_sigmoid.[ch]``;
* :class:`SmoTanh` - Gong's tanh SMO without LPF, ``est_smo_tanh.[ch]``;
* :class:`SmoSta` - the super-twisting (second-order) SMO, Hou's comparator ("the improved SMO
  method mentioned in [8]") without [8]'s online resistance estimate, ``est_smo_sta.[ch]``;
* :class:`DelayComp` - Gong's dual-sampling delay estimate and current pre-compensation,
  ``est_delay_comp.[ch]``;
* factories :func:`smo_sigmoid_for`, :func:`smo_tanh_for`, :func:`smo_sta_for` (profile, ts_s,
  **config), with the gains derived from the profile by the papers' rules when not given.

The SMOs' ``step`` takes the currents sampled at t_k and the alpha-beta voltage applied over
the previous period and returns :class:`hil_bench.firmware_stub.estimators.EstimatorOutput`. Outputs are
float32 values promoted to Python floats. Equations, discretisation and parameter choices:
docs/estimators_smo.md.
"""
from __future__ import annotations

from typing import Any, NamedTuple, Sequence

from ._binding import EstimatorOutput, ffi, lib
from ._binding import configure as _configure

#: lag_comp values of SmoSigmoid (EST_SMO_SIGMOID_LAG_*)
LAG_NONE = lib.EST_SMO_SIGMOID_LAG_NONE
LAG_EQ15 = lib.EST_SMO_SIGMOID_LAG_EQ15
LAG_EFFECTIVE = lib.EST_SMO_SIGMOID_LAG_EFFECTIVE

#: Margin over Yuan eq. 18 (K > 2 psi_f w_e,max) the factory applies at the profile's rated speed.
SIGMOID_GAIN_MARGIN = 1.5


class _Smo:
    """Common part of the SMO wrappers: config, init, step on a C module named ``est_<c_name>``."""

    name = ""
    _c_name = ""
    _invalid_hint = " (k_v must be set > 0: see the gain rules)"

    def __init__(self, rs_ohm: float, ls_h: float, psi_f_wb: float, ts_s: float,
                 **config: float):
        cls = type(self).__name__
        self._cfg = ffi.new(f"est_{self._c_name}_config_t *")
        getattr(lib, f"est_{self._c_name}_default_config")(self._cfg, rs_ohm, ls_h, psi_f_wb,
                                                            ts_s)
        _configure(self._cfg, config, cls)
        self._s = ffi.new(f"est_{self._c_name}_t *")
        if getattr(lib, f"est_{self._c_name}_init")(self._s, self._cfg) != 0:
            fields = ", ".join(f"{k}={getattr(self._cfg, k)}" for k, _ in
                               ffi.typeof(f"est_{self._c_name}_config_t").fields)
            hint = self._invalid_hint if not getattr(self._cfg, "k_v", 1.0) > 0 else ""
            raise ValueError(f"{cls}: invalid configuration{hint} ({fields})")
        self._step_c = getattr(lib, f"est_{self._c_name}_step")
        self._reset_c = getattr(lib, f"est_{self._c_name}_reset")
        self._i = ffi.new("fw_vec2_t *")
        self._v = ffi.new("fw_vec2_t *")

    @property
    def state(self) -> Any:
        """The live C state struct (read-only use)."""
        return self._s

    @property
    def config(self) -> dict[str, float]:
        """The configuration in use (a copy)."""
        c = self._s.cfg
        return {k: getattr(c, k) for k, _ in ffi.typeof(f"est_{self._c_name}_config_t").fields}

    def reset(self) -> None:
        self._reset_c(self._s)

    def step(self, i_alpha_a: float, i_beta_a: float, v_alpha_prev_v: float,
             v_beta_prev_v: float) -> EstimatorOutput:
        """One period: currents at t_k, voltage applied over [t_{k-1}, t_k]."""
        i, v = self._i, self._v
        i.x, i.y, v.x, v.y = i_alpha_a, i_beta_a, v_alpha_prev_v, v_beta_prev_v
        o = self._step_c(self._s, i[0], v[0])
        return EstimatorOutput(o.theta_e_rad, o.omega_e_rad_s, o.e_alpha_v, o.e_beta_v)


class SmoSign(_Smo):
    """Conventional sign SMO with LPF and atan(w/wc) compensation (Yuan eq. 4-10, Gong eq. 3-7).
    ``k_v`` <= 0 (default) selects the adaptive gain k = max(k_min_v, k_factor |w^| psi_f)."""

    name = "SMO_SIGN"
    _c_name = "smo_sign"
    _invalid_hint = ""


class SmoSigmoid(_Smo):
    """Improved SMO with sigmoid switching and H (Yuan eq. 11-18); E^ = H/2 is the EMF output.

    Required: ``k_v`` (eq. 18, see :func:`sigmoid_min_gain_v`). ``a_per_a`` <= 0 (default) takes
    the deadbeat slope :func:`sigmoid_max_slope_per_a`; ``lag_comp`` LAG_EQ15 (default, eq. 15 as
    printed), LAG_EFFECTIVE (atan(2 w/wc)) or LAG_NONE.
    """

    name = "SMO_SIGMOID"
    _c_name = "smo_sigmoid"

    @property
    def a_used_per_a(self) -> float:
        """The sigmoid slope in use (configured or derived)."""
        return self._s.a_used_per_a


class SmoTanh(_Smo):
    """tanh SMO without LPF (Gong eq. 3, 8, 14-19). Required: ``k_v``; ``m_per_a`` defaults to
    the paper's 0.01. Gain rule helpers: :func:`tanh_gain_rule_v` and friends."""

    name = "SMO_TANH"
    _c_name = "smo_tanh"


class SmoSta(_Smo):
    """Super-twisting SMO (Hou's comparator, his ref. [8], without [8]'s resistance estimate).
    ``k1_v``, ``k2_v_s`` <= 0 (default) select the speed-adaptive gains of the STA's condition
    (:func:`sta_gains`)."""

    name = "SMO_STA"
    _c_name = "smo_sta"
    _invalid_hint = ""


class DelayCompOutput(NamedTuple):
    """Compensated currents of period k and the delay figures after the period's samples."""

    i_a_a: float          # i'_a(k) (eq. 22)
    i_b_a: float
    i_c_a: float
    i_alpha_a: float      # Clarke of the compensated currents
    i_beta_a: float
    t_d_used_s: float     # delay the compensation of period k used
    t_d_last_s: float     # last per-period estimate (eq. 20), after this period's second sample
    t_d_mean_s: float     # recursive mean of the per-period estimates
    n_valid: int          # periods that gave an estimate so far


class DelayComp:
    """Dual-sampling delay estimate (Gong eq. 20) and current pre-compensation (eq. 21-22).

    ``DelayComp(ts_s, t_d_fixed_s=0.0, estimate_on=True, **config)``; config fields:
    compensate_on, min_step_a, t_d_max_s, avg_n_max (see est_delay_comp.h).
    """

    name = "DELAY_COMP"

    def __init__(self, ts_s: float, t_d_fixed_s: float = 0.0, estimate_on: bool = True,
                 **config: float):
        self._cfg = ffi.new("est_delay_comp_config_t *")
        lib.est_delay_comp_default_config(self._cfg, ts_s)
        self._cfg.t_d_fixed_s = t_d_fixed_s
        self._cfg.estimate_on = 1 if estimate_on else 0
        _configure(self._cfg, config, "DelayComp")
        self._s = ffi.new("est_delay_comp_t *")
        if lib.est_delay_comp_init(self._s, self._cfg) != 0:
            c = self._cfg
            raise ValueError(f"DelayComp: invalid configuration (ts_s={c.ts_s}, "
                             f"t_d_fixed_s={c.t_d_fixed_s}, t_d_max_s={c.t_d_max_s}, "
                             f"min_step_a={c.min_step_a}, avg_n_max={c.avg_n_max})")
        self._i1 = ffi.new("float[3]")
        self._i2 = ffi.new("float[3]")

    @property
    def state(self) -> Any:
        """The live C state struct (read-only use)."""
        return self._s

    def reset(self) -> None:
        lib.est_delay_comp_reset(self._s)

    @property
    def t_d_s(self) -> float:
        """Delay the next compensation will use."""
        return lib.est_delay_comp_t_d_s(self._s)

    def sample1(self, i1_abc_a: Sequence[float]) -> DelayCompOutput:
        """First sample of period k (t_k): the compensated currents of period k."""
        self._i1[0:3] = list(i1_abc_a)
        return self._output(lib.est_delay_comp_sample1(self._s, self._i1))

    def sample2(self, i2_abc_a: Sequence[float]) -> None:
        """Second sample of period k (t_k + t_d): updates the delay estimate."""
        self._i2[0:3] = list(i2_abc_a)
        lib.est_delay_comp_sample2(self._s, self._i2)

    def step(self, i1_abc_a: Sequence[float], i2_abc_a: Sequence[float]) -> DelayCompOutput:
        """Both samples of period k; the estimate fields include this period's eq. 20."""
        self._i1[0:3] = list(i1_abc_a)
        self._i2[0:3] = list(i2_abc_a)
        return self._output(lib.est_delay_comp_step(self._s, self._i1, self._i2))

    def _output(self, o: Any) -> DelayCompOutput:
        s = self._s
        return DelayCompOutput(o.i_a_a, o.i_b_a, o.i_c_a, o.i_ab_a.x, o.i_ab_a.y, o.t_d_s,
                               s.t_d_last_s, s.t_d_mean_s, int(s.n_valid))


# -- gain rules (the C helpers) ----------------------------------------------------------------
def sigmoid_min_gain_v(psi_f_wb: float, omega_e_max_rad_s: float) -> float:
    """Yuan eq. 18: the K the sigmoid SMO needs to exceed, 2 psi_f w_e,max [V]."""
    return lib.est_smo_sigmoid_min_gain_v(psi_f_wb, omega_e_max_rad_s)


def sigmoid_max_slope_per_a(rs_ohm: float, ls_h: float, ts_s: float, k_v: float) -> float:
    """Deadbeat slope a = 2 F/(G K) of the sampled, linearised error loop [1/A]."""
    return lib.est_smo_sigmoid_max_slope_per_a(rs_ohm, ls_h, ts_s, k_v)


def tanh_boundary_layer_a(m_per_a: float) -> float:
    """Gong's BL = atanh(0.99)/m [A]."""
    return lib.est_smo_tanh_boundary_layer_a(m_per_a)


def tanh_min_f(m_per_a: float, xi_a: float) -> float:
    """Gong eq. 16: min|F| = tanh(m xi)."""
    return lib.est_smo_tanh_min_f(m_per_a, xi_a)


def tanh_gain_rule_v(ce: float, psi_f_wb: float, pole_pairs: int, omega_m_max_rad_s: float,
                     min_f: float) -> float:
    """Gong eq. 17: k = 3 sqrt(3) Ce psi_f p w_m,max / (2 min|F|) [V]."""
    return lib.est_smo_tanh_gain_rule_v(ce, psi_f_wb, pole_pairs, omega_m_max_rad_s, min_f)


def tanh_stability_bound_v(e_max_v: float, min_f: float) -> float:
    """Gong eq. 14 at min|F|: e_max / min|F| [V]."""
    return lib.est_smo_tanh_stability_bound_v(e_max_v, min_f)


def tanh_deadbeat_gain_v_per_a(rs_ohm: float, ls_h: float, ts_s: float) -> float:
    """k m at which the sampled, linearised error loop is deadbeat, F/G [V/A]."""
    return lib.est_smo_tanh_deadbeat_gain_v_per_a(rs_ohm, ls_h, ts_s)


def tanh_xi_deadbeat_a(ce: float, psi_f_wb: float, pole_pairs: int, omega_m_max_rad_s: float,
                       m_per_a: float, rs_ohm: float, ls_h: float, ts_s: float) -> float:
    """Smallest eq.-15 tolerance xi whose eq.-17 k keeps k m <= F/G [A]; -1 if none."""
    return lib.est_smo_tanh_xi_deadbeat_a(ce, psi_f_wb, pole_pairs, omega_m_max_rad_s, m_per_a,
                                          rs_ohm, ls_h, ts_s)


def sta_gains(rs_ohm: float, ls_h: float, psi_f_wb: float, ts_s: float, omega_e_rad_s: float,
              **config: float) -> tuple[float, float]:
    """The STA SMO's adaptive gains (k1 [V/sqrt(A)], k2 [V/s]) at an electrical speed."""
    cfg = ffi.new("est_smo_sta_config_t *")
    lib.est_smo_sta_default_config(cfg, rs_ohm, ls_h, psi_f_wb, ts_s)
    _configure(cfg, config, "sta_gains")
    k1, k2 = ffi.new("float *"), ffi.new("float *")
    lib.est_smo_sta_gains(cfg, omega_e_rad_s, k1, k2)
    return k1[0], k2[0]


# -- factories ---------------------------------------------------------------------------------
def _rated_omega_m(profile: Any) -> float:
    return float(profile.rated["speed_rad_s"])


def sigmoid_gain_for(profile: Any) -> float:
    """K for a profile: SIGMOID_GAIN_MARGIN x eq. 18 at the rated speed."""
    return SIGMOID_GAIN_MARGIN * sigmoid_min_gain_v(profile.psi_f_wb,
                                                    profile.pole_pairs * _rated_omega_m(profile))


def tanh_gain_for(profile: Any, ts_s: float, m_per_a: float = 0.01) -> float:
    """k for a profile: eq. 17 at the rated speed with xi = tanh_xi_deadbeat_a (docs).

    Ce is the profile's rated.voltage_constant_ce (Gong Table I: 1.67), 1.0 if the profile has
    none. With that xi, eq. 17 gives k = F/(G m) whatever Ce is; Ce only decides whether such a
    xi exists. If none does (large m: the rule's k m exceeds F/G for every xi), k = F/(G m) too,
    the largest gain the sampled loop takes without ringing.
    """
    ce = float(profile.rated.get("voltage_constant_ce", 1.0))
    w = _rated_omega_m(profile)
    xi = tanh_xi_deadbeat_a(ce, profile.psi_f_wb, profile.pole_pairs, w, m_per_a,
                            profile.rs_ohm, profile.lq_h, ts_s)
    if xi > 0.0:
        return tanh_gain_rule_v(ce, profile.psi_f_wb, profile.pole_pairs, w,
                                tanh_min_f(m_per_a, xi))
    return tanh_deadbeat_gain_v_per_a(profile.rs_ohm, profile.lq_h, ts_s) / m_per_a


def smo_sigmoid_for(profile: Any, ts_s: float, **config: float) -> SmoSigmoid:
    """An improved (sigmoid) SMO for a motor profile (Ls = Lq). Unless given: k_v from
    sigmoid_gain_for, a_per_a the deadbeat slope for it, the C defaults for the rest."""
    config.setdefault("k_v", sigmoid_gain_for(profile))
    return SmoSigmoid(profile.rs_ohm, profile.lq_h, profile.psi_f_wb, ts_s, **config)


def smo_tanh_for(profile: Any, ts_s: float, **config: float) -> SmoTanh:
    """A tanh SMO for a motor profile (Ls = Lq). Unless given: m_per_a = 0.01 (the paper),
    k_v from tanh_gain_for at that m."""
    config.setdefault("m_per_a", 0.01)
    config.setdefault("k_v", tanh_gain_for(profile, ts_s, config["m_per_a"]))
    return SmoTanh(profile.rs_ohm, profile.lq_h, profile.psi_f_wb, ts_s, **config)


def smo_sta_for(profile: Any, ts_s: float, **config: float) -> SmoSta:
    """Hou's comparator for a motor profile (Ls = Lq, the extended-EMF form): the C defaults
    (speed-adaptive gains with margin 1.5) unless given."""
    return SmoSta(profile.rs_ohm, profile.lq_h, profile.psi_f_wb, ts_s, **config)


__all__ = ["SmoSign", "SmoSigmoid", "SmoTanh", "SmoSta", "smo_sta_for", "sta_gains", "DelayComp", "DelayCompOutput", "EstimatorOutput",
           "smo_sigmoid_for", "smo_tanh_for", "sigmoid_gain_for", "tanh_gain_for",
           "sigmoid_min_gain_v", "sigmoid_max_slope_per_a", "tanh_boundary_layer_a",
           "tanh_min_f", "tanh_gain_rule_v", "tanh_stability_bound_v",
           "tanh_deadbeat_gain_v_per_a", "tanh_xi_deadbeat_a", "LAG_NONE", "LAG_EQ15",
           "LAG_EFFECTIVE", "SIGMOID_GAIN_MARGIN"]
