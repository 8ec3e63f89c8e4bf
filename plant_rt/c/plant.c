/**
 * @file plant.c
 * @brief The plant system object: RK4 over sub-steps, computation-delay split, diode events.
 *
 * Integration state s (per period): the dynamic states y = (i_d, i_q, omega_m, theta_e) plus
 * quadrature channels integrated by the same RK4 stages (voltage averages, mechanical angle,
 * energies); the quadratures start at 0 each period.
 *
 * Disabled legs (inverter.h). Before every RK4 step the leg modes are resolved from the state
 * (resolve_mode) and held for the step:
 *   - no open phase: all three legs are voltage sources (PWM or a conducting diode);
 *   - one open phase x: the other two are sources, i_x = 0 is kept exactly by the
 *     constrained machine dynamics (pmsm_machine_derivs_open_phase) and re-projection;
 *   - two or three open phases: all currents are zero (isolated star) and only the rotor moves.
 * A phase is open only if its disabled leg carries no current and the terminal voltage it
 * would float to stays inside [0, V_dc]; otherwise the corresponding diode conducts. The
 * step's end state is checked against the mode's guards (a conducting diode's current must
 * keep its sign; an open terminal must stay between the rails); if a guard is crossed, the
 * crossing instant is found by Illinois regula falsi on the RK4 step length, the state is
 * advanced to just past it, the mode is re-resolved and the rest of the step is integrated.
 * Approximations: ideal diodes (no forward drop, no reverse recovery), a stiff DC bus, the
 * PWM averaged over the period (no ripple, no dead time), no commutation of the PWM carrier
 * with the diode intervals (a disabled leg is off for the whole interval its duty applies).
 *
 * Non-idealities (plant.h): with the inverter non-linearity on, the pole voltages depend on
 * the phase currents and are evaluated at every RK4 stage (inverter_pole_voltages_i); with
 * saturation on, pmsm_machine_* use psi_d(i_d) and L_inc(i_d); the load torque of a period is
 * the set torque + the exact mean of the load profile over the period (held constant inside
 * it); in dyno mode the speed derivative is the imposed acceleration of the period. Every
 * effect that is off leaves the arithmetic of the ideal plant unchanged (bit for bit).
 */
#include "plant.h"
#include "plant_fault_internal.h"

#include <math.h>
#include <string.h>

#define PL_TWO_PI 6.283185307179586477
#define PL_SQRT3 1.7320508075688772935
#define PL_INV_SQRT3 0.57735026918962576451

/* integration state layout */
enum {
    S_ID, S_IQ, S_WM, S_TH,                 /* dynamic states */
    Q_VA, Q_VB, Q_VC, Q_VD, Q_VQ,           /* int v dt [V s] */
    Q_THM,                                  /* int omega_m dt [rad] */
    Q_EIN, Q_ECU, Q_EVISC, Q_ELOAD,         /* energies [J] */
    Q_ECOUL, Q_EINV,                        /* Coulomb friction loss, inverter loss [J] */
    Q_ESHORT,                               /* phase-to-phase short loss [J] (faults) */
    S_N
};

/** Leg modes held over one RK4 step. */
typedef struct step_mode {
    inverter_leg_mode_t leg[3];
    double duty[3];     /* sanitised duties in effect */
    double v_pole_v[3]; /* pole voltages of the source legs (ideal inverter) */
    double v_phase_v[3];           /* ideal inverter, no open phase: phase voltages ... */
    double v_alpha_v, v_beta_v;    /* ... and their alpha-beta components (constant over the step) */
    int n_open;         /* 0, 1 (open_phase open) or >= 2 (all currents zero) */
    int open_phase;
    int has_disabled;   /* any disabled leg: guards must be watched */
    int short_on;       /* fault PHASE_SHORT: the network of plant_fault.c replaces the above */
    plant_short_mode_t sh;
    /* switching mode with the non-linearity: the legs at switch level (NULL: averaged) */
    const inverter_sw_leg_t *sw_leg;
    double t0_s;        /* time of the RK4 step's start from the period start */
} step_mode_t;

/* A phase disconnected by an OPEN_PHASE fault: always open, its terminal not clamped. */
#define FORCED_OPEN(pl, k) (((pl)->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_OPEN_PHASE)) && \
                            (pl)->faults.open_phase == (k))

/* ------------------------------------------------------------------------------------------ */
/* parameters                                                                                 */

const char *plant_params_check(const plant_params_t *p)
{
    if (p == NULL) {
        return "params: NULL";
    }
    if (!isfinite(p->rs_ohm)) return "rs_ohm: must be finite";
    if (p->rs_ohm < 0.0) return "rs_ohm: must be >= 0";
    if (!isfinite(p->ld_h)) return "ld_h: must be finite";
    if (!(p->ld_h > 0.0)) return "ld_h: must be > 0";
    if (!isfinite(p->lq_h)) return "lq_h: must be finite";
    if (!(p->lq_h > 0.0)) return "lq_h: must be > 0";
    if (!isfinite(p->psi_f_wb)) return "psi_f_wb: must be finite";
    if (p->psi_f_wb < 0.0) return "psi_f_wb: must be >= 0";
    if (p->pole_pairs < 1) return "pole_pairs: must be >= 1";
    if (!isfinite(p->j_kgm2)) return "j_kgm2: must be finite";
    if (!(p->j_kgm2 > 0.0)) return "j_kgm2: must be > 0";
    if (!isfinite(p->b_nms)) return "b_nms: must be finite";
    if (p->b_nms < 0.0) return "b_nms: must be >= 0";
    if (!isfinite(p->v_dc_v)) return "v_dc_v: must be finite";
    if (!(p->v_dc_v > 0.0)) return "v_dc_v: must be > 0";
    if (!isfinite(p->ts_s)) return "ts_s: must be finite";
    if (!(p->ts_s > 0.0)) return "ts_s: must be > 0";
    if (!isfinite(p->t_delay_s)) return "t_delay_s: must be finite";
    if (p->t_delay_s < 0.0) return "t_delay_s: must be >= 0";
    if (p->t_delay_s > p->ts_s) return "t_delay_s: must be <= ts_s";
    if (p->substeps < 1) return "substeps: must be >= 1";
    if (p->substeps > PLANT_MAX_SUBSTEPS) return "substeps: must be <= 100000";
    return plant_params_check_nonideal(p);
}

/* The new groups, in this order (plant_rt/profile.py mirrors it rule by rule). */
static const char *check_flag(int v, const char *msg)
{
    return (v == 0 || v == 1) ? NULL : msg;
}

const char *plant_params_check_nonideal(const plant_params_t *p)
{
    const plant_inverter_params_t *iv = &p->inverter;
    const plant_magnetics_params_t *mg = &p->magnetics;
    const plant_sensor_params_t *se = &p->sensors;
    const plant_mechanics_params_t *me = &p->mechanics;
    const double h = p->ts_s / (double)p->substeps; /* longest RK4 step */
    double l_min;
    const char *msg;
    if ((msg = check_flag(p->full_period_delay, "full_period_delay: must be 0 or 1")) != NULL) return msg;
    /* magnetics first: the inverter's stability rule needs the smallest inductance */
    if ((msg = check_flag(mg->saturation, "saturation: must be 0 or 1")) != NULL) return msg;
    if (mg->saturation) {
        if (!isfinite(mg->sat_l_inf_ratio)) return "sat_l_inf_ratio: must be finite";
        if (!(mg->sat_l_inf_ratio > 0.0)) return "sat_l_inf_ratio: must be > 0";
        if (!(mg->sat_l_inf_ratio <= 1.0)) return "sat_l_inf_ratio: must be <= 1";
        if (!isfinite(mg->sat_i_scale_a)) return "sat_i_scale_a: must be finite";
        if (!(mg->sat_i_scale_a > 0.0)) return "sat_i_scale_a: must be > 0";
        if (!isfinite(mg->sat_i_knee_a)) return "sat_i_knee_a: must be finite";
        if (!(mg->sat_i_knee_a <= 0.0)) return "sat_i_knee_a: must be <= 0";
        if (!(mg->sat_i_knee_a >= -3.0 * mg->sat_i_scale_a)) return "sat_i_knee_a: must be >= -3 sat_i_scale_a";
    }
    l_min = fmin(p->ld_h * (mg->saturation ? mg->sat_l_inf_ratio : 1.0), p->lq_h);
    if (iv->inverter != 0 && iv->inverter != 1) return "inverter: must be averaged or switching";
    if (iv->carrier_at_start != PWM_CARRIER_VALLEY && iv->carrier_at_start != PWM_CARRIER_PEAK) {
        return "carrier_at_start: must be valley or peak";
    }
    if (iv->pwm_load != PWM_LOAD_EXTREMUM && iv->pwm_load != PWM_LOAD_PERIOD &&
        iv->pwm_load != PWM_LOAD_IMMEDIATE) {
        return "pwm_load: must be extremum, period or immediate";
    }
    if ((msg = check_flag(iv->inverter_nonlinear, "inverter_nonlinear: must be 0 or 1")) != NULL) return msg;
    if (iv->inverter_nonlinear) {
        if (!isfinite(iv->dead_time_s)) return "dead_time_s: must be finite";
        if (!(iv->dead_time_s >= 0.0)) return "dead_time_s: must be >= 0";
        if (!(2.0 * iv->dead_time_s < p->ts_s)) return "dead_time_s: must be < ts_s / 2";
        if (!isfinite(iv->v_switch_drop_v)) return "v_switch_drop_v: must be finite";
        if (!(iv->v_switch_drop_v >= 0.0)) return "v_switch_drop_v: must be >= 0";
        if (!isfinite(iv->r_switch_ohm)) return "r_switch_ohm: must be finite";
        if (!(iv->r_switch_ohm >= 0.0)) return "r_switch_ohm: must be >= 0";
        if (!isfinite(iv->v_diode_drop_v)) return "v_diode_drop_v: must be finite";
        if (!(iv->v_diode_drop_v >= 0.0)) return "v_diode_drop_v: must be >= 0";
        if (!isfinite(iv->r_diode_ohm)) return "r_diode_ohm: must be finite";
        if (!(iv->r_diode_ohm >= 0.0)) return "r_diode_ohm: must be >= 0";
        if (!isfinite(iv->i_cap_band_a)) return "i_cap_band_a: must be finite";
        /* > 0: a hard sign makes the right-hand side discontinuous at i = 0, where the fixed-
         * step RK4 chatters (zero-current clamping) and loses the energy balance */
        if (!(iv->i_cap_band_a > 0.0)) return "i_cap_band_a: must be > 0";
        {
            /* slope of the pole voltage across the band, as a resistance (dead time:
             * delta V_dc / (2 i_c); drop onset: at most max(v_s, v_d) / i_c; bounded by
             * (delta V_dc + 2 (v_s + v_d)) / (2 i_c)): RK4 stays stable (and accurate) while
             * h * slope / L_min <= 2 */
            const double slope_ohm = (iv->dead_time_s / p->ts_s * p->v_dc_v +
                                      2.0 * (iv->v_switch_drop_v + iv->v_diode_drop_v)) /
                                     (2.0 * iv->i_cap_band_a);
            if (!(h * slope_ohm <= 2.0 * l_min)) {
                return "i_cap_band_a: too small for the RK4 step (raise it or substeps)";
            }
        }
    }
    if ((msg = check_flag(se->adc_model, "adc_model: must be 0 or 1")) != NULL) return msg;
    if ((msg = check_flag(se->dual_sampling, "dual_sampling: must be 0 or 1")) != NULL) return msg;
    if (se->dual_sample_at != 0 && se->dual_sample_at != 1) return "dual_sample_at: must be delay or half_period";
    if (se->dual_sample_at == 1 && iv->inverter != 1) {
        return "dual_sample_at: half_period needs inverter = switching";
    }
    if (se->adc_model) {
        if (se->adc_bits < 1 || se->adc_bits > 24) return "adc_bits: must be 1 .. 24";
        if (!isfinite(se->adc_full_scale_a)) return "adc_full_scale_a: must be finite";
        if (!(se->adc_full_scale_a > 0.0)) return "adc_full_scale_a: must be > 0";
        if (!isfinite(se->adc_gain_err_ia) || !(se->adc_gain_err_ia > -1.0)) return "adc_gain_err_ia: must be finite and > -1";
        if (!isfinite(se->adc_gain_err_ib) || !(se->adc_gain_err_ib > -1.0)) return "adc_gain_err_ib: must be finite and > -1";
        if (!isfinite(se->adc_gain_err_ic) || !(se->adc_gain_err_ic > -1.0)) return "adc_gain_err_ic: must be finite and > -1";
        if (!isfinite(se->adc_offset_ia_a)) return "adc_offset_ia_a: must be finite";
        if (!isfinite(se->adc_offset_ib_a)) return "adc_offset_ib_a: must be finite";
        if (!isfinite(se->adc_offset_ic_a)) return "adc_offset_ic_a: must be finite";
        if (!isfinite(se->adc_noise_a_rms)) return "adc_noise_a_rms: must be finite";
        if (!(se->adc_noise_a_rms >= 0.0)) return "adc_noise_a_rms: must be >= 0";
        if (!isfinite(se->adc_vdc_full_scale_v)) return "adc_vdc_full_scale_v: must be finite";
        if (!(se->adc_vdc_full_scale_v > 0.0)) return "adc_vdc_full_scale_v: must be > 0";
        if (!isfinite(se->adc_vdc_gain_err) || !(se->adc_vdc_gain_err > -1.0)) return "adc_vdc_gain_err: must be finite and > -1";
        if (!isfinite(se->adc_vdc_offset_v)) return "adc_vdc_offset_v: must be finite";
        if (!isfinite(se->adc_vdc_noise_v_rms)) return "adc_vdc_noise_v_rms: must be finite";
        if (!(se->adc_vdc_noise_v_rms >= 0.0)) return "adc_vdc_noise_v_rms: must be >= 0";
    }
    if (!isfinite(me->coulomb_nm)) return "coulomb_nm: must be finite";
    if (!(me->coulomb_nm >= 0.0)) return "coulomb_nm: must be >= 0";
    if (me->coulomb_nm > 0.0) {
        if (!isfinite(me->coulomb_band_rad_s)) return "coulomb_band_rad_s: must be finite";
        if (!(me->coulomb_band_rad_s > 0.0)) return "coulomb_band_rad_s: must be > 0";
        /* d(friction)/d(omega) / J at zero speed: RK4 stable while h * rate <= 2 */
        if (!(h * me->coulomb_nm <= 2.0 * p->j_kgm2 * me->coulomb_band_rad_s)) {
            return "coulomb_band_rad_s: too small for the RK4 step (raise it or substeps)";
        }
    }
    {
        mechanics_load_profile_t lp;
        if (me->load_profile < 0 || me->load_profile > 3) return "load_profile: must be none, step, ramp or table";
        plant_load_profile_from_params(me, &lp);
        if ((msg = mechanics_load_profile_check(&lp)) != NULL) return msg;
    }
    if ((msg = check_flag(me->dyno, "dyno: must be 0 or 1")) != NULL) return msg;
    if (me->dyno) {
        if (!isfinite(me->dyno_speed_rad_s)) return "dyno_speed_rad_s: must be finite";
        if (!isfinite(me->dyno_accel_rad_s2)) return "dyno_accel_rad_s2: must be finite";
        if (!(me->dyno_accel_rad_s2 >= 0.0)) return "dyno_accel_rad_s2: must be >= 0";
    }
    return NULL;
}

void plant_load_profile_from_params(const plant_mechanics_params_t *me, mechanics_load_profile_t *lp)
{
    int k, n;
    memset(lp, 0, sizeof *lp);
    lp->kind = me->load_profile;
    lp->t0_s = me->load_t0_s;
    lp->t1_s = me->load_t1_s;
    lp->torque0_nm = me->load_torque0_nm;
    lp->torque1_nm = me->load_torque1_nm;
    lp->table_n = me->load_table_n;
    n = (me->load_table_n < 0) ? 0 : ((me->load_table_n > MECH_LOAD_TABLE_MAX) ? MECH_LOAD_TABLE_MAX : me->load_table_n);
    for (k = 0; k < n; ++k) {
        lp->table_t_s[k] = me->load_table_t_s[k];
        lp->table_nm[k] = me->load_table_nm[k];
    }
}

/* ------------------------------------------------------------------------------------------ */
/* small helpers                                                                              */

static double wrap_2pi(double x)
{
    double r;
    /* the usual case, one turn at most past either end: the subtraction is exact (Sterbenz for
     * [2pi, 4pi); for [-2pi, 0) it is the same operation fmod's result gets below) */
    if (x >= 0.0 && x < PL_TWO_PI) {
        return x;
    }
    if (x >= PL_TWO_PI && x < 2.0 * PL_TWO_PI) {
        return x - PL_TWO_PI;
    }
    r = fmod(x, PL_TWO_PI);
    if (r < 0.0) {
        r += PL_TWO_PI;
    }
    if (r >= PL_TWO_PI) { /* -tiny + 2pi rounds to 2pi */
        r = 0.0;
    }
    return r;
}

static void currents_abc(const double *s, double i_abc[3])
{
    double ia, ib;
    pmsm_inv_park(s[S_ID], s[S_IQ], s[S_TH], &ia, &ib);
    pmsm_inv_clarke(ia, ib, &i_abc[0], &i_abc[1], &i_abc[2]);
}

/** Remove phase x's current (project i_alphabeta onto the line orthogonal to phase x's axis). */
static void clamp_phase_current(double *s, int x)
{
    static const double ux[3] = {1.0, -0.5, -0.5};
    static const double uy[3] = {0.0, 0.5 * PL_SQRT3, -0.5 * PL_SQRT3};
    double ia, ib, d, q, ix;
    pmsm_inv_park(s[S_ID], s[S_IQ], s[S_TH], &ia, &ib);
    ix = ux[x] * ia + uy[x] * ib;
    ia -= ix * ux[x];
    ib -= ix * uy[x];
    pmsm_park(ia, ib, s[S_TH], &d, &q);
    s[S_ID] = d;
    s[S_IQ] = q;
}

/** Phase back EMF [V] (amplitude-invariant: e_x = u_x . e_alphabeta). */
static void emf_abc(const plant_t *pl, const double *s, double e_abc[3])
{
    const double we = (double)pl->params.pole_pairs * s[S_WM];
    const double ea = -we * pl->params.psi_f_wb * sin(s[S_TH]);
    const double eb = we * pl->params.psi_f_wb * cos(s[S_TH]);
    pmsm_inv_clarke(ea, eb, &e_abc[0], &e_abc[1], &e_abc[2]);
}

/**
 * Pole voltages [V] of the mode's source legs at state s (and, if f_hi is not NULL, the
 * fraction of time each leg ties its phase to the + rail). Ideal inverter: the mode's
 * precomputed voltages (they do not depend on the currents).
 */
static void pole_voltages_at(const plant_t *pl, const step_mode_t *mode, const double *s,
                             double v_pole[3], double f_hi[3])
{
    double i_abc[3];
    if (!pl->inverter.nonlinear) {
        v_pole[0] = mode->v_pole_v[0];
        v_pole[1] = mode->v_pole_v[1];
        v_pole[2] = mode->v_pole_v[2];
        if (f_hi != NULL) {
            int k;
            for (k = 0; k < 3; ++k) {
                f_hi[k] = (mode->leg[k] == INV_LEG_PWM) ? mode->duty[k]
                          : ((mode->leg[k] == INV_LEG_DIODE_HIGH) ? 1.0 : 0.0);
            }
        }
        return;
    }
    currents_abc(s, i_abc);
    inverter_pole_voltages_i(&pl->inverter, mode->duty, mode->leg, i_abc, v_pole, f_hi);
}

/* With one phase open, a conducting leg z fixes the star point: v_nN = v_zN - e_z. Returns
 * v_nN and the leg used. */
static double neutral_from_source_leg(const plant_t *pl, const step_mode_t *mode, const double *s,
                                      const double e[3], int *z_out)
{
    int k, z = 0;
    double vp[3];
    for (k = 0; k < 3; ++k) {
        if (mode->leg[k] != INV_LEG_OPEN) z = k;
    }
    pole_voltages_at(pl, mode, s, vp, NULL);
    *z_out = z;
    return vp[z] - e[z];
}

/** Inverter loss power [W]: sum_x (f_x V_dc - v_xN) i_x. */
static double inverter_loss_power(const plant_t *pl, const double v_pole[3], const double f_hi[3],
                                  const double i_abc[3])
{
    const double vdc = pl->params.v_dc_v;
    return (f_hi[0] * vdc - v_pole[0]) * i_abc[0] + (f_hi[1] * vdc - v_pole[1]) * i_abc[1] +
           (f_hi[2] * vdc - v_pole[2]) * i_abc[2];
}

/** Terminal voltage v_xN [V] the open phase floats to, for mode->n_open == 1. */
static double open_terminal_voltage(const plant_t *pl, const step_mode_t *mode, const double *s)
{
    const int x = mode->open_phase;
    const int y = (x + 1) % 3;
    const int z = (x + 2) % 3;
    double did, diq, lam, vp[3];
    pole_voltages_at(pl, mode, s, vp, NULL);
    pmsm_machine_derivs_open_phase(&pl->machine, s[S_ID], s[S_IQ], s[S_TH],
                                   (double)pl->params.pole_pairs * s[S_WM], x,
                                   vp[y] - vp[z], &did, &diq, &lam);
    return 0.5 * (vp[y] + vp[z]) + 1.5 * lam;
}

/* ------------------------------------------------------------------------------------------ */
/* leg modes                                                                                  */

static void finish_mode(const plant_t *pl, const double duty[3], step_mode_t *mode)
{
    int k;
    mode->n_open = 0;
    mode->open_phase = -1;
    mode->has_disabled = 0;
    mode->short_on = 0;
    mode->sw_leg = NULL;
    mode->t0_s = 0.0;
    for (k = 0; k < 3; ++k) {
        mode->duty[k] = duty[k];
        if (mode->leg[k] == INV_LEG_OPEN) {
            ++mode->n_open;
            mode->open_phase = k;
        }
        if (mode->leg[k] != INV_LEG_PWM) {
            mode->has_disabled = 1;
        }
    }
    inverter_pole_voltages(&pl->inverter, duty, mode->leg, mode->v_pole_v);
    inverter_phase_voltages(mode->v_pole_v, mode->v_phase_v);
    mode->v_alpha_v = mode->v_phase_v[0];
    mode->v_beta_v = (mode->v_phase_v[0] + 2.0 * mode->v_phase_v[1]) * PL_INV_SQRT3;
}

/**
 * Leg modes for the state s; clamps the currents of open phases to exactly zero.
 * duty: sanitised duties in effect.
 */
static void resolve_mode(const plant_t *pl, const double duty[3], double *s, step_mode_t *mode)
{
    const inverter_t *inv = &pl->inverter;
    double i_abc[3];
    int iter;
    mode->sw_leg = NULL;
    mode->t0_s = 0.0;
    if (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_PHASE_SHORT)) {
        plant_short_resolve((plant_t *)(void *)pl, duty, s, &mode->sh); /* counts fallbacks */
        mode->short_on = 1;
        mode->has_disabled = 1;
        mode->n_open = 0;
        return;
    }
    currents_abc(s, i_abc);
    (void)inverter_classify(inv, duty, i_abc, mode->leg);
    if (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_OPEN_PHASE)) {
        mode->leg[pl->faults.open_phase] = INV_LEG_OPEN;
    }
    for (iter = 0; iter < 4; ++iter) {
        finish_mode(pl, duty, mode);
        if (mode->n_open == 0) {
            return;
        }
        if (mode->n_open == 1) {
            const int x = mode->open_phase;
            clamp_phase_current(s, x);
            if (FORCED_OPEN(pl, x)) {
                return; /* disconnected: no diode can clamp the floating terminal */
            }
            mode->leg[x] = inverter_open_leg_mode(inv, open_terminal_voltage(pl, mode, s));
            finish_mode(pl, duty, mode);
            return;
        }
        /* Two or three phases without current: no current can flow anywhere (isolated star)
         * unless the back EMF forces a diode on. */
        {
            double e[3];
            int k;
            s[S_ID] = 0.0;
            s[S_IQ] = 0.0;
            emf_abc(pl, s, e);
            if (mode->n_open == 3) {
                int kmax = -1;
                int kmin = -1;
                for (k = 0; k < 3; ++k) {
                    if (FORCED_OPEN(pl, k)) continue; /* the line EMF of the connected pair */
                    if (kmax < 0 || e[k] > e[kmax]) kmax = k;
                    if (kmin < 0 || e[k] < e[kmin]) kmin = k;
                }
                if (e[kmax] - e[kmin] > inv->cfg.v_dc_v + 2.0 * inv->nl.v_diode_drop_v + inv->v_tol_v) {
                    mode->leg[kmax] = INV_LEG_DIODE_HIGH; /* current leaves the machine there */
                    mode->leg[kmin] = INV_LEG_DIODE_LOW;
                    continue; /* the middle phase is decided as a single open phase */
                }
                return;
            } else {
                /* one source leg z fixes the neutral: v_nN = v_zN - e_z */
                int z;
                int worst = -1;
                double worst_margin = 0.0;
                const double v_n = neutral_from_source_leg(pl, mode, s, e, &z);
                for (k = 0; k < 3; ++k) {
                    if (k != z && !FORCED_OPEN(pl, k)) {
                        const double m = inverter_open_margin(inv, v_n + e[k]);
                        if (m < worst_margin) {
                            worst_margin = m;
                            worst = k;
                        }
                    }
                }
                if (worst < 0) {
                    return;
                }
                mode->leg[worst] = inverter_open_leg_mode(inv, v_n + e[worst]);
                /* loop: one open phase left */
            }
        }
    }
    finish_mode(pl, duty, mode);
}

/** Smallest guard margin of the mode at state s (>= 0: the mode is still consistent). */
static double mode_margin(const plant_t *pl, const step_mode_t *mode, const double *s)
{
    const inverter_t *inv = &pl->inverter;
    double margin = HUGE_VAL;
    double i_abc[3];
    int k;
    if (mode->short_on) {
        return plant_short_margin(pl, &mode->sh, s);
    }
    currents_abc(s, i_abc);
    for (k = 0; k < 3; ++k) {
        if (mode->leg[k] == INV_LEG_DIODE_LOW && i_abc[k] < margin) {
            margin = i_abc[k];
        } else if (mode->leg[k] == INV_LEG_DIODE_HIGH && -i_abc[k] < margin) {
            margin = -i_abc[k];
        }
    }
    if (mode->n_open == 1) {
        if (!FORCED_OPEN(pl, mode->open_phase)) {
            const double m = inverter_open_margin(inv, open_terminal_voltage(pl, mode, s));
            if (m < margin) margin = m;
        }
    } else if (mode->n_open >= 2) {
        double e[3];
        emf_abc(pl, s, e);
        if (mode->n_open == 3) {
            double emax = fmax(e[0], fmax(e[1], e[2]));
            double emin = fmin(e[0], fmin(e[1], e[2]));
            double m;
            if (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_OPEN_PHASE)) {
                /* the line EMF of the two connected phases */
                const int y = (pl->faults.open_phase + 1) % 3;
                const int z = (pl->faults.open_phase + 2) % 3;
                emax = fmax(e[y], e[z]);
                emin = fmin(e[y], e[z]);
            }
            m = inv->cfg.v_dc_v + 2.0 * inv->nl.v_diode_drop_v + inv->v_tol_v - (emax - emin);
            if (m < margin) margin = m;
        } else {
            int z;
            const double v_n = neutral_from_source_leg(pl, mode, s, e, &z);
            for (k = 0; k < 3; ++k) {
                if (k != z && !FORCED_OPEN(pl, k)) {
                    const double m = inverter_open_margin(inv, v_n + e[k]);
                    if (m < margin) margin = m;
                }
            }
        }
    }
    return margin;
}

/** After a step: diode currents that crossed zero are cut to zero; open phases stay at zero. */
static void enforce_mode(const step_mode_t *mode, double *s)
{
    double i_abc[3];
    int k;
    if (mode->short_on) {
        plant_short_enforce(&mode->sh, s);
        return;
    }
    if (mode->n_open >= 2) {
        s[S_ID] = 0.0;
        s[S_IQ] = 0.0;
        return;
    }
    currents_abc(s, i_abc);
    for (k = 0; k < 3; ++k) {
        if ((mode->leg[k] == INV_LEG_OPEN) ||
            (mode->leg[k] == INV_LEG_DIODE_LOW && i_abc[k] < 0.0) ||
            (mode->leg[k] == INV_LEG_DIODE_HIGH && i_abc[k] > 0.0)) {
            clamp_phase_current(s, k);
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* right-hand side and RK4                                                                    */

/**
 * Right-hand side at state s; sn, cs = sin and cos of s[S_TH] (the caller has them: rk4
 * rotates the step's start angle by each stage's small offset); tau = the stage's time after
 * the step's start (read only by the switching mode's dead intervals).
 */
static void deriv(const plant_t *pl, const step_mode_t *mode, const double *s, double sn, double cs,
                  double tau, double *ds)
{
    const plant_params_t *p = &pl->params;
    const double id = s[S_ID];
    const double iq = s[S_IQ];
    const double wm = s[S_WM];
    const double we = (double)p->pole_pairs * wm;
    double v[3];
    double valpha, vbeta, vd, vq, did, diq, te, tl, accel;
    double p_inv = 0.0;
    double p_short = 0.0;

    if (mode->short_on) {
        plant_short_out_t o;
        plant_short_solve(pl, &mode->sh, s, sn, cs, &o);
        did = o.did;
        diq = o.diq;
        v[0] = o.v_phase_v[0];
        v[1] = o.v_phase_v[1];
        v[2] = o.v_phase_v[2];
        valpha = v[0];
        vbeta = (v[0] + 2.0 * v[1]) * PL_INV_SQRT3;
        vd = valpha * cs + vbeta * sn;
        vq = -valpha * sn + vbeta * cs;
        p_short = mode->sh.r_ohm * o.i_f_a * o.i_f_a;
    } else if (mode->n_open == 0) {
        if (pl->inverter.nonlinear) {
            double i_abc[3], vp[3], f[3];
            const double ia = id * cs - iq * sn;
            const double ib = id * sn + iq * cs;
            i_abc[0] = ia;
            i_abc[1] = -0.5 * ia + 0.5 * PL_SQRT3 * ib;
            i_abc[2] = -0.5 * ia - 0.5 * PL_SQRT3 * ib;
            if (mode->sw_leg != NULL) { /* switching mode: the legs at switch level */
                const double t = mode->t0_s + tau;
                int x;
                for (x = 0; x < 3; ++x) {
                    vp[x] = inverter_sw_pole_voltage(&pl->inverter, &mode->sw_leg[x], t, i_abc[x], &f[x]);
                }
            } else {
                inverter_pole_voltages_i(&pl->inverter, mode->duty, mode->leg, i_abc, vp, f);
            }
            inverter_phase_voltages(vp, v);
            p_inv = inverter_loss_power(pl, vp, f, i_abc);
            valpha = v[0];
            vbeta = (v[0] + 2.0 * v[1]) * PL_INV_SQRT3;
        } else { /* constant over the step: computed once in finish_mode */
            v[0] = mode->v_phase_v[0];
            v[1] = mode->v_phase_v[1];
            v[2] = mode->v_phase_v[2];
            valpha = mode->v_alpha_v;
            vbeta = mode->v_beta_v;
        }
        vd = valpha * cs + vbeta * sn;
        vq = -valpha * sn + vbeta * cs;
        pmsm_machine_derivs(&pl->machine, id, iq, vd, vq, we, &did, &diq);
    } else if (mode->n_open == 1) {
        const int x = mode->open_phase;
        const int y = (x + 1) % 3;
        const int z = (x + 2) % 3;
        double vp[3], f[3], d_yz, lam;
        pole_voltages_at(pl, mode, s, vp, f);
        d_yz = vp[y] - vp[z];
        pmsm_machine_derivs_open_phase(&pl->machine, id, iq, s[S_TH], we, x, d_yz, &did, &diq,
                                       &lam);
        if (pl->inverter.nonlinear) {
            double i_abc[3];
            currents_abc(s, i_abc);
            i_abc[x] = 0.0;
            p_inv = inverter_loss_power(pl, vp, f, i_abc);
        }
        v[x] = lam;
        v[y] = 0.5 * (d_yz - lam);
        v[z] = 0.5 * (-d_yz - lam);
        valpha = v[0];
        vbeta = (v[0] + 2.0 * v[1]) * PL_INV_SQRT3;
        vd = valpha * cs + vbeta * sn;
        vq = -valpha * sn + vbeta * cs;
    } else {
        /* no current: the terminals show the back EMF */
        const double ea = -we * p->psi_f_wb * sn;
        const double eb = we * p->psi_f_wb * cs;
        pmsm_inv_clarke(ea, eb, &v[0], &v[1], &v[2]);
        vd = 0.0;
        vq = we * p->psi_f_wb;
        did = 0.0;
        diq = 0.0;
    }
    te = pmsm_machine_torque(&pl->machine, id, iq);
    if (p->mechanics.dyno) {
        /* speed imposed: the dynamometer supplies whatever torque that takes */
        accel = pl->dyno_accel_now_rad_s2;
        tl = te - mechanics_friction_torque(&pl->mech, wm) - p->j_kgm2 * accel;
    } else {
        tl = pl->torque_load_period_nm;
        accel = mechanics_accel(&pl->mech, wm, te, tl);
    }
    ds[S_ID] = did;
    ds[S_IQ] = diq;
    ds[S_WM] = accel;
    ds[S_TH] = we;
    ds[Q_VA] = v[0];
    ds[Q_VB] = v[1];
    ds[Q_VC] = v[2];
    ds[Q_VD] = vd;
    ds[Q_VQ] = vq;
    ds[Q_THM] = wm;
    ds[Q_EIN] = 1.5 * (vd * id + vq * iq);
    ds[Q_ECU] = 1.5 * p->rs_ohm * (id * id + iq * iq);
    ds[Q_EVISC] = p->b_nms * wm * wm;
    ds[Q_ELOAD] = tl * wm;
    ds[Q_ECOUL] = (pl->mech.coulomb_nm > 0.0)
                      ? pl->mech.coulomb_nm * tanh(wm * pl->mech.inv_coulomb_band) * wm
                      : 0.0;
    ds[Q_EINV] = p_inv;
    ds[Q_ESHORT] = p_short;
}

/**
 * sin and cos of (theta0 + d) from s0 = sin(theta0), c0 = cos(theta0): the stages of an RK4
 * step are a small angle d (= omega_e * stage time, |d| <~ 0.1 rad) away from its start, so the
 * step needs one sin/cos pair and a rotation (Taylor series of sin d and cos d to d^13 / d^12:
 * truncation < 1e-17 for |d| <= 0.5; beyond that libm is used). Accurate to about 1 ulp.
 */
static void rotate_angle(double s0, double c0, double theta0, double d, double *s, double *c)
{
    const double d2 = d * d;
    double sd, cd;
    if (!(fabs(d) <= 0.5)) {
        *s = sin(theta0 + d);
        *c = cos(theta0 + d);
        return;
    }
    /* Horner in d^2 with the factorials' reciprocals (multiplications only) */
    sd = d + d * d2 * (-1.0 / 6.0 + d2 * (1.0 / 120.0 + d2 * (-1.0 / 5040.0 + d2 * (1.0 / 362880.0 +
             d2 * (-1.0 / 39916800.0 + d2 * (1.0 / 6227020800.0))))));
    cd = 1.0 + d2 * (-0.5 + d2 * (1.0 / 24.0 + d2 * (-1.0 / 720.0 + d2 * (1.0 / 40320.0 +
             d2 * (-1.0 / 3628800.0 + d2 * (1.0 / 479001600.0))))));
    *s = s0 * cd + c0 * sd;
    *c = c0 * cd - s0 * sd;
}

/* The derivatives depend on the dynamic states only (S_ID .. S_TH, the first N_DYN entries),
 * never on the quadrature channels: the stages advance just those. */
#define N_DYN 4

static void rk4(const plant_t *pl, const step_mode_t *mode, const double *s0, double h, double *s1)
{
    double k1[S_N], k2[S_N], k3[S_N], k4[S_N], tmp[N_DYN];
    const double h2 = 0.5 * h;
    const double h6 = h / 6.0;
    const double th0 = s0[S_TH];
    const double sn0 = sin(th0);
    const double cs0 = cos(th0);
    double sn, cs;
    int i;
    deriv(pl, mode, s0, sn0, cs0, 0.0, k1);
    for (i = 0; i < N_DYN; ++i) tmp[i] = s0[i] + h2 * k1[i];
    rotate_angle(sn0, cs0, th0, h2 * k1[S_TH], &sn, &cs);
    deriv(pl, mode, tmp, sn, cs, h2, k2);
    for (i = 0; i < N_DYN; ++i) tmp[i] = s0[i] + h2 * k2[i];
    rotate_angle(sn0, cs0, th0, h2 * k2[S_TH], &sn, &cs);
    deriv(pl, mode, tmp, sn, cs, h2, k3);
    for (i = 0; i < N_DYN; ++i) tmp[i] = s0[i] + h * k3[i];
    rotate_angle(sn0, cs0, th0, h * k3[S_TH], &sn, &cs);
    deriv(pl, mode, tmp, sn, cs, h, k4);
    for (i = 0; i < S_N; ++i) s1[i] = s0[i] + h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
}

/**
 * One RK4 step of length h with diode-event location. s is advanced in place.
 */
static void substep(plant_t *pl, const double duty[3], double h, double *s)
{
    double s1[S_N], s_hi[S_N];
    double t_rem = h;
    int events = 0;
    step_mode_t mode;
    for (;;) {
        double lo, hi, glo, ghi;
        int it, side;
        resolve_mode(pl, duty, s, &mode);
        rk4(pl, &mode, s, t_rem, s1);
        if (!mode.has_disabled) {
            memcpy(s, s1, sizeof s1);
            return;
        }
        ghi = mode_margin(pl, &mode, s1);
        if (ghi >= 0.0 || events >= PLANT_MAX_EVENTS) {
            memcpy(s, s1, sizeof s1);
            enforce_mode(&mode, s);
            return;
        }
        /* A guard was crossed inside the step: locate it (Illinois regula falsi on the
         * fraction tau of the step; g(tau) = guard margin after an RK4 step of tau * t_rem). */
        lo = 0.0;
        hi = 1.0;
        glo = fmax(mode_margin(pl, &mode, s), 0.0);
        memcpy(s_hi, s1, sizeof s1);
        side = 0;
        for (it = 0; it < 64 && (hi - lo) * t_rem > 1e-15 * h; ++it) {
            double tau = (glo > 0.0) ? hi - ghi * (hi - lo) / (ghi - glo) : 0.5 * (lo + hi);
            double g;
            if (!(tau > lo && tau < hi)) {
                tau = 0.5 * (lo + hi);
            }
            rk4(pl, &mode, s, tau * t_rem, s1);
            g = mode_margin(pl, &mode, s1);
            if (g < 0.0) {
                hi = tau;
                ghi = g;
                memcpy(s_hi, s1, sizeof s1);
                if (side == -1) glo *= 0.5;
                side = -1;
            } else {
                lo = tau;
                glo = g;
                if (side == 1) ghi *= 0.5;
                side = 1;
            }
        }
        /* continue from just past the event */
        memcpy(s, s_hi, sizeof s_hi);
        enforce_mode(&mode, s);
        t_rem *= (1.0 - hi);
        ++events;
        ++pl->events;
        if (!(t_rem > 0.0)) {
            return;
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* public API                                                                                 */

/** Convert the three phase currents (and, if vdc_code != NULL, the bus voltage) as the ADC would. */
static void adc_currents(plant_t *pl, const double i_abc[3], double out[3], int code[3])
{
    int k;
    if (!pl->params.sensors.adc_model) {
        for (k = 0; k < 3; ++k) {
            out[k] = i_abc[k];
            code[k] = -1;
        }
        return;
    }
    for (k = 0; k < 3; ++k) {
        out[k] = sensor_adc_convert(&pl->adc_i[k], &pl->rng, i_abc[k], &code[k]);
    }
}

/** adc_currents for the first sample, keeping the noise deviates (plant_fault_sample reuses
 *  them when a fault changes what the sensors see at t_k). ADC model on. */
static void adc_currents_keep(plant_t *pl, const double i_abc[3], double out[3], int code[3])
{
    int k;
    for (k = 0; k < 3; ++k) {
        pl->sample_noise[k] = sensor_rng_normal(&pl->rng);
        out[k] = sensor_adc_convert_noise(&pl->adc_i[k], i_abc[k], pl->sample_noise[k], &code[k]);
    }
}

/**
 * The first sample of the period starting now (t_s), from the state y. Ideal sensors: nothing
 * to draw, plant_sample computes the exact values when asked.
 */
static void take_first_sample(plant_t *pl)
{
    plant_sample_t *sm = &pl->sample;
    double i_abc[3], meas[3];
    int code[3];
    pl->faults.resample = 0;
    if (!pl->params.sensors.adc_model) {
        return;
    }
    if (pl->faults.active & PLANT_FAULT_SENSE_BITS) {
        plant_fault_sensed_currents(pl, pl->duty_prev, pl->y, i_abc);
    } else {
        currents_abc(pl->y, i_abc);
    }
    adc_currents_keep(pl, i_abc, meas, code);
    sm->t_s = pl->t_s;
    sm->i_a_a = meas[0];
    sm->i_b_a = meas[1];
    sm->i_c_a = meas[2];
    sm->code_a = code[0];
    sm->code_b = code[1];
    sm->code_c = code[2];
    if (pl->params.sensors.adc_model) {
        pl->sample_noise[3] = sensor_rng_normal(&pl->rng);
        sm->v_dc_v = sensor_adc_convert_noise(&pl->adc_vdc, pl->params.v_dc_v, pl->sample_noise[3],
                                              &sm->code_vdc);
    } else {
        sm->v_dc_v = pl->params.v_dc_v;
        sm->code_vdc = -1;
    }
}

/** The second sample of the present period, at its actuation instant (state s, duties that
 *  take effect then). */
static void take_second_sample(plant_t *pl, const double *s, const double duty[3])
{
    plant_sample_t *sm = &pl->sample;
    double i_abc[3], meas[3];
    int code[3];
    const int dual = pl->params.sensors.dual_sampling;
    if (!dual && !pl->params.sensors.adc_model) {
        return; /* nothing to record, no random draws to keep in step */
    }
    if (pl->faults.active & PLANT_FAULT_SENSE_BITS) {
        plant_fault_sensed_currents(pl, duty, s, i_abc);
    } else {
        currents_abc(s, i_abc);
    }
    adc_currents(pl, i_abc, meas, code); /* draws even without dual sampling: same stream */
    sm->i2_a_a = dual ? meas[0] : 0.0;
    sm->i2_b_a = dual ? meas[1] : 0.0;
    sm->i2_c_a = dual ? meas[2] : 0.0;
    sm->code2_a = dual ? code[0] : -1;
    sm->code2_b = dual ? code[1] : -1;
    sm->code2_c = dual ? code[2] : -1;
    sm->dual_valid = dual;
}

static void sync_parts(plant_t *pl)
{
    pl->machine.i_d_a = pl->y[S_ID];
    pl->machine.i_q_a = pl->y[S_IQ];
    pl->mech.omega_m_rad_s = pl->y[S_WM];
    pl->mech.theta_m_rad = pl->theta_m_rad;
}

/** Cut the period [0, ts) at td into two segments of RK4 steps, each step <= ts/n. */
static void split_period(int n, double td, double ts, int steps[2], double h[2])
{
    const double frac = td / ts;
    if (!(td > 0.0)) {
        steps[0] = 0;
        steps[1] = n;
    } else if (!(td < ts)) {
        steps[0] = n;
        steps[1] = 0;
    } else {
        steps[0] = (int)ceil((double)n * frac - 1e-9);
        steps[1] = (int)ceil((double)n * (1.0 - frac) - 1e-9);
        if (steps[0] < 1) steps[0] = 1;
        if (steps[1] < 1) steps[1] = 1;
    }
    h[0] = (steps[0] > 0) ? td / (double)steps[0] : 0.0;
    h[1] = (steps[1] > 0) ? (ts - td) / (double)steps[1] : 0.0;
}

static void sw_reset_legs(plant_t *pl, const double duty[3]);

int plant_init(plant_t *pl, const plant_params_t *p)
{
    pmsm_machine_config_t mc;
    inverter_config_t ic;
    mechanics_config_t kc;
    double td;
    int k;
    if (pl == NULL || plant_params_check(p) != NULL) {
        return -1;
    }
    memset(pl, 0, sizeof *pl);
    pl->params = *p;
    mc.rs_ohm = p->rs_ohm;
    mc.ld_h = p->ld_h;
    mc.lq_h = p->lq_h;
    mc.psi_f_wb = p->psi_f_wb;
    mc.pole_pairs = p->pole_pairs;
    ic.v_dc_v = p->v_dc_v;
    kc.j_kgm2 = p->j_kgm2;
    kc.b_nms = p->b_nms;
    kc.pole_pairs = p->pole_pairs;
    if (pmsm_machine_init(&pl->machine, &mc) != 0 || inverter_init(&pl->inverter, &ic) != 0 ||
        mechanics_init(&pl->mech, &kc) != 0) {
        return -1;
    }
    /* non-idealities */
    if (p->inverter.inverter_nonlinear) {
        inverter_nl_config_t nl;
        nl.dead_time_s = p->inverter.dead_time_s;
        nl.ts_s = p->ts_s;
        nl.v_switch_drop_v = p->inverter.v_switch_drop_v;
        nl.r_switch_ohm = p->inverter.r_switch_ohm;
        nl.v_diode_drop_v = p->inverter.v_diode_drop_v;
        nl.r_diode_ohm = p->inverter.r_diode_ohm;
        nl.i_cap_band_a = p->inverter.i_cap_band_a;
        if (inverter_set_nonlinear(&pl->inverter, &nl) != 0) return -1;
    }
    {
        pwm_config_t pc;
        pc.ts_s = p->ts_s;
        pc.carrier_at_start = p->inverter.carrier_at_start;
        pc.load = p->inverter.pwm_load;
        if (pwm_init(&pl->pwm, &pc) != 0) return -1;
    }
    if (p->magnetics.saturation) {
        pmsm_saturation_config_t sc;
        sc.l_inf_ratio = p->magnetics.sat_l_inf_ratio;
        sc.i_scale_a = p->magnetics.sat_i_scale_a;
        sc.i_knee_a = p->magnetics.sat_i_knee_a;
        if (pmsm_machine_set_saturation(&pl->machine, &sc) != 0) return -1;
    }
    if (p->mechanics.coulomb_nm > 0.0 &&
        mechanics_set_coulomb(&pl->mech, p->mechanics.coulomb_nm, p->mechanics.coulomb_band_rad_s) != 0) {
        return -1;
    }
    plant_load_profile_from_params(&p->mechanics, &pl->load);
    for (k = 0; k < 3; ++k) {
        pl->adc_i[k].bits = p->sensors.adc_bits;
        pl->adc_i[k].bipolar = 1;
        pl->adc_i[k].full_scale = p->sensors.adc_full_scale_a;
        pl->adc_i[k].noise_rms = p->sensors.adc_noise_a_rms;
    }
    pl->adc_i[0].gain_err = p->sensors.adc_gain_err_ia;
    pl->adc_i[1].gain_err = p->sensors.adc_gain_err_ib;
    pl->adc_i[2].gain_err = p->sensors.adc_gain_err_ic;
    pl->adc_i[0].offset = p->sensors.adc_offset_ia_a;
    pl->adc_i[1].offset = p->sensors.adc_offset_ib_a;
    pl->adc_i[2].offset = p->sensors.adc_offset_ic_a;
    pl->adc_vdc.bits = p->sensors.adc_bits;
    pl->adc_vdc.bipolar = 0;
    pl->adc_vdc.full_scale = p->sensors.adc_vdc_full_scale_v;
    pl->adc_vdc.gain_err = p->sensors.adc_vdc_gain_err;
    pl->adc_vdc.offset = p->sensors.adc_vdc_offset_v;
    pl->adc_vdc.noise_rms = p->sensors.adc_vdc_noise_v_rms;
    /* split the period at the delay instant; every step <= ts/substeps */
    td = p->full_period_delay ? p->ts_s : p->t_delay_s;
    pl->t_delay_eff_s = td;
    pl->t_act_offset_s = td;
    pl->sw_l_min_h = fmin(p->ld_h * (p->magnetics.saturation ? p->magnetics.sat_l_inf_ratio : 1.0), p->lq_h);
    split_period(p->substeps, td, p->ts_s, pl->seg_steps, pl->seg_h_s);
    plant_reset(pl);
    return 0;
}

void plant_reset(plant_t *pl)
{
    int k;
    plant_fault_reset(pl); /* first: restores what a fault replaced (bus, mechanics) */
    pmsm_machine_reset(&pl->machine);
    inverter_reset(&pl->inverter);
    mechanics_reset(&pl->mech);
    pl->t_s = 0.0;
    pl->period = 0UL;
    for (k = 0; k < 4; ++k) pl->y[k] = 0.0;
    pl->theta_m_rad = 0.0;
    pl->torque_load_nm = 0.0;
    for (k = 0; k < 3; ++k) {
        pl->duty_prev[k] = 0.5;
        pl->duty_now[k] = 0.5;
    }
    for (k = 0; k < 5; ++k) pl->v_avg[k] = 0.0;
    for (k = 0; k < 7; ++k) pl->energy[k] = 0.0;
    pl->events = 0UL;
    sw_reset_legs(pl, pl->duty_now);
    pl->sw_periods = 0UL;
    pl->t2_offset_s = pl->t_delay_eff_s;
    pl->torque_load_period_nm = 0.0;
    pl->dyno_accel_now_rad_s2 = 0.0;
    pl->dyno_target_rad_s = pl->params.mechanics.dyno_speed_rad_s;
    if (pl->params.mechanics.dyno) {
        pl->y[S_WM] = pl->dyno_target_rad_s;
        pl->mech.omega_m_rad_s = pl->y[S_WM];
    }
    /* sensors: reseed, first sample of period 0, no second sample yet */
    sensor_rng_seed(&pl->rng, pl->params.sensors.adc_seed);
    memset(&pl->sample, 0, sizeof pl->sample);
    pl->sample.code2_a = -1;
    pl->sample.code2_b = -1;
    pl->sample.code2_c = -1;
    take_first_sample(pl);
}

void plant_set_initial(plant_t *pl, double theta_e_rad, double omega_m_rad_s)
{
    pl->y[S_TH] = wrap_2pi(theta_e_rad);
    pl->y[S_WM] = omega_m_rad_s;
    pl->theta_m_rad = pl->y[S_TH] / (double)pl->params.pole_pairs;
    pl->mech.omega_m_rad_s = omega_m_rad_s;
    pl->mech.theta_m_rad = pl->theta_m_rad;
}

void plant_set_load_torque(plant_t *pl, double torque_nm)
{
    pl->torque_load_nm = torque_nm;
}

double plant_actuation_delay(const plant_t *pl)
{
    if (pl->params.inverter.inverter == 1) {
        return pwm_load_instant(&pl->pwm, pl->t_delay_eff_s);
    }
    return pl->t_delay_eff_s;
}

void plant_set_dyno_speed(plant_t *pl, double omega_m_rad_s)
{
    pl->dyno_target_rad_s = omega_m_rad_s;
}

double plant_load_torque_at(const plant_t *pl, double t_s)
{
    return pl->torque_load_nm + mechanics_load_profile_at(&pl->load, t_s);
}

/** Start of a period: the load it sees, or the dynamometer's imposed acceleration. */
static void begin_period_mechanics(plant_t *pl)
{
    const plant_params_t *p = &pl->params;
    if (p->mechanics.dyno) {
        const double w0 = pl->y[S_WM];
        const double dw = pl->dyno_target_rad_s - w0;
        const double a_max = p->mechanics.dyno_accel_rad_s2;
        if (!(a_max > 0.0)) {
            if (dw > 0.0 || dw < 0.0) { /* speed step: the dyno supplies the kinetic energy */
                const double w1 = pl->dyno_target_rad_s;
                pl->energy[3] -= 0.5 * p->j_kgm2 * (w1 * w1 - w0 * w0);
                pl->y[S_WM] = w1;
                pl->mech.omega_m_rad_s = w1;
            }
            pl->dyno_accel_now_rad_s2 = 0.0;
        } else {
            double a = dw / p->ts_s;
            if (a > a_max) a = a_max;
            if (a < -a_max) a = -a_max;
            pl->dyno_accel_now_rad_s2 = a;
        }
    } else if (pl->load.kind == MECH_LOAD_NONE) {
        pl->torque_load_period_nm = pl->torque_load_nm;
    } else {
        pl->torque_load_period_nm =
            pl->torque_load_nm + mechanics_load_profile_mean(&pl->load, pl->t_s, pl->t_s + p->ts_s);
    }
    if (!p->mechanics.dyno && (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_LOAD_TORQUE))) {
        pl->torque_load_period_nm += pl->faults.load_extra_nm;
    }
}

static void step_segments(plant_t *pl, const double duty_abc[3], const int seg_steps[2],
                          const double seg_h_s[2]);

/* ------------------------------------------------------------------------------------------ */
/* switching mode                                                                             */

/** Legs and carrier as after a steady period at these (sanitised) duties; disabled = low. */
static void sw_reset_legs(plant_t *pl, const double duty[3])
{
    int k;
    pwm_reset(&pl->pwm, duty);
    for (k = 0; k < 3; ++k) {
        inverter_sw_leg_reset(&pl->sw_leg[k], pl->pwm.level[k]);
    }
}

/**
 * The next RK4 step inside a segment, at most `room` long: Ts / substeps; and with device drops,
 * if a conducting leg's current may reach its threshold band (|i| < 3 i_c, where tanh(|i| /
 * i_c) bends) within the step, the time the current needs to move 4 i_c at the largest slope
 * the circuit allows, (V_dc + |e| + R |i|) / L_min: RK4 then resolves the bend instead of
 * stepping over it. Measured (error_study --switching --nonlinear, 2x rated speed): 5.3e-7 of
 * rated current, against 4.4e-4 with Ts / substeps alone; 8 i_c: 4.6e-6. (Steps from the
 * segment's actual slope instead of this bound were tried: 1.2e-6 at 1 i_c per step for 25 %
 * less time, 4.9e-5 at 4 i_c; not worth the extra right-hand side per step.)
 */
static double sw_step_length(const plant_t *pl, const double *s, double room)
{
    const plant_params_t *p = &pl->params;
    const inverter_t *inv = &pl->inverter;
    double h = fmin(p->ts_s / (double)p->substeps, room);
    if (inv->nonlinear && (inv->nl.v_switch_drop_v > 0.0 || inv->nl.v_diode_drop_v > 0.0) &&
        inv->nl.i_cap_band_a > 0.0) {
        const double ic = inv->nl.i_cap_band_a;
        double i_abc[3], i_max, didt;
        int x;
        currents_abc(s, i_abc);
        i_max = fmax(fabs(i_abc[0]), fmax(fabs(i_abc[1]), fabs(i_abc[2])));
        didt = (inv->cfg.v_dc_v + fabs((double)p->pole_pairs * s[S_WM]) * p->psi_f_wb +
                p->rs_ohm * i_max) / pl->sw_l_min_h;
        for (x = 0; x < 3; ++x) {
            if (pl->sw_leg[x].state != INV_SW_DEAD && fabs(i_abc[x]) < 3.0 * ic + didt * h) {
                h = fmin(h, 4.0 * ic / didt);
                break;
            }
        }
    }
    return h;
}

/** Integrate [t0, t0 + len) of the period, where no leg changes its state or node law, in RK4
 *  steps of sw_step_length (equal steps of Ts / substeps away from the drops' band). */
static void sw_segment(plant_t *pl, double *s, double t0, double len)
{
    step_mode_t mode;
    double duty[3], s1[S_N];
    double done = 0.0;
    int k;
    if (!(len > 0.0)) {
        return;
    }
    for (k = 0; k < 3; ++k) {
        mode.leg[k] = INV_LEG_PWM;
        /* ideal switches: a conducting leg is a constant source, the averaged code's duty 0/1 */
        duty[k] = (pl->sw_leg[k].state == INV_SW_HIGH) ? 1.0 : 0.0;
    }
    finish_mode(pl, duty, &mode);
    if (pl->inverter.nonlinear) {
        mode.sw_leg = pl->sw_leg;
    }
    while (done < len) {
        const double room = len - done;
        double h;
        mode.t0_s = t0 + done;
        h = sw_step_length(pl, s, room);
        if (room - h < 1e-3 * h) {
            h = room; /* no sliver of a step at the segment's end */
        } else {
            /* equal steps over what is left at this length */
            h = room / ceil(room / h - 1e-9);
        }
        rk4(pl, &mode, s, h, s1);
        memcpy(s, s1, sizeof s1);
        s[S_TH] = wrap_2pi(s[S_TH]);
        done = (room - h < 1e-3 * h) ? len : done + h;
    }
}

/**
 * One period at switch level (plant.h "Switching mode"): the PWM plan of the period (pwm.h),
 * then segment by segment between the instants where a leg's state or node law changes
 * (command transitions, ends of dead intervals, the node's clamp), the second-sample instant
 * and the period end. Command transitions are applied with the phase current at that instant.
 */
static void step_switching(plant_t *pl, const double duty_new[3], double *s)
{
    const double ts = pl->params.ts_s;
    const double t_write = pl->t_act_offset_s;
    const double t_smp = (pl->params.sensors.dual_sample_at == 1) ? 0.5 * ts : t_write;
    const plant_trace_t *tr = pl->trace;
    pwm_plan_t plan;
    int cursor[3] = {0, 0, 0};
    int sampled = 0;
    int x;
    int j_tr = 0;
    double t = 0.0;
    double t_tr = (tr != NULL) ? ts / (double)tr->n : HUGE_VAL;
    double q_last[2] = {0.0, 0.0};
    pwm_plan(&pl->pwm, pl->duty_prev, duty_new, t_write, &plan);
    for (;;) {
        double t_next = ts;
        int have_i = 0;
        double i_abc[3] = {0.0, 0.0, 0.0};
        for (x = 0; x < 3; ++x) {
            const pwm_leg_plan_t *lp = &plan.leg[x];
            inverter_sw_advance(&pl->sw_leg[x], t);
            while (cursor[x] < lp->n && lp->t_s[cursor[x]] <= t) {
                if (!have_i) {
                    currents_abc(s, i_abc);
                    have_i = 1;
                }
                inverter_sw_command(&pl->inverter, &pl->sw_leg[x], t, lp->level[cursor[x]], i_abc[x]);
                ++cursor[x];
            }
        }
        if (!sampled && t >= t_smp) {
            take_second_sample(pl, s, duty_new);
            sampled = 1;
        }
        if (tr != NULL && j_tr < tr->n && t >= t_tr) {
            const double dt = ts / (double)tr->n;
            const double va = (s[Q_VA] - q_last[0]) / dt;
            const double vb = (s[Q_VB] - q_last[1]) / dt;
            pmsm_inv_park(s[S_ID], s[S_IQ], s[S_TH], &tr->i_alpha_a[j_tr], &tr->i_beta_a[j_tr]);
            tr->v_alpha_v[j_tr] = va;
            tr->v_beta_v[j_tr] = (va + 2.0 * vb) * PL_INV_SQRT3;
            tr->theta_e_rad[j_tr] = s[S_TH];
            q_last[0] = s[Q_VA];
            q_last[1] = s[Q_VB];
            ++j_tr;
            t_tr = (j_tr + 1 < tr->n) ? ts * (double)(j_tr + 1) / (double)tr->n : ts;
        }
        if (!(t < ts)) {
            break;
        }
        for (x = 0; x < 3; ++x) {
            const pwm_leg_plan_t *lp = &plan.leg[x];
            double c = inverter_sw_next_change(&pl->sw_leg[x], t);
            if (cursor[x] < lp->n && lp->t_s[cursor[x]] < c) c = lp->t_s[cursor[x]];
            if (c < t_next) t_next = c;
        }
        if (!sampled && t_smp < t_next) t_next = t_smp;
        if (tr != NULL && j_tr < tr->n && t_tr < t_next) t_next = t_tr;
        sw_segment(pl, s, t, t_next - t);
        t = t_next;
    }
    for (x = 0; x < 3; ++x) {
        inverter_sw_shift(&pl->sw_leg[x], ts);
    }
    pwm_commit(&pl->pwm, &plan);
    pl->t2_offset_s = t_smp;
    ++pl->sw_periods;
}

void plant_step(plant_t *pl, const double duty_abc[3])
{
    pl->t_act_offset_s = pl->t_delay_eff_s;
    step_segments(pl, duty_abc, pl->seg_steps, pl->seg_h_s);
}

void plant_step_split(plant_t *pl, const double duty_abc[3], double t_split_s)
{
    int steps[2];
    double h[2];
    double td = t_split_s;
    if (!(td > 0.0)) td = 0.0; /* NaN: the new duties act from the start */
    if (td > pl->params.ts_s) td = pl->params.ts_s;
    split_period(pl->params.substeps, td, pl->params.ts_s, steps, h);
    pl->t_act_offset_s = td;
    step_segments(pl, duty_abc, steps, h);
}

static void step_segments(plant_t *pl, const double duty_abc[3], const int seg_steps[2],
                          const double seg_h_s[2])
{
    double s[S_N];
    double duty_new[3];
    int seg, k, i, switched;
    for (k = 0; k < 3; ++k) {
        duty_new[k] = inverter_sanitize_duty(duty_abc[k]);
    }
    if (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_LEG_STUCK)) {
        plant_fault_apply_stuck(pl, duty_new);
    }
    begin_period_mechanics(pl);
    for (i = 0; i < S_N; ++i) s[i] = 0.0;
    for (i = 0; i < 4; ++i) s[i] = pl->y[i];
    if (pl->params.inverter.inverter == 1 && !inverter_leg_disabled(pl->duty_prev[0]) &&
        !inverter_leg_disabled(pl->duty_prev[1]) && !inverter_leg_disabled(pl->duty_prev[2]) &&
        !inverter_leg_disabled(duty_new[0]) && !inverter_leg_disabled(duty_new[1]) &&
        !inverter_leg_disabled(duty_new[2]) && (pl->faults.active & PLANT_FAULT_TOPOLOGY_BITS) == 0u) {
        step_switching(pl, duty_new, s);
        switched = 1;
        seg = 2; /* the averaged segments below are skipped */
    } else {
        switched = 0;
        seg = 0;
        pl->t2_offset_s = pl->t_act_offset_s;
    }
    for (; seg < 2; ++seg) {
        const double *duty = (seg == 0) ? pl->duty_prev : duty_new;
        const double h = seg_h_s[seg];
        const int any_disabled = inverter_leg_disabled(duty[0]) ||
                                 inverter_leg_disabled(duty[1]) || inverter_leg_disabled(duty[2]) ||
                                 (pl->faults.active & PLANT_FAULT_TOPOLOGY_BITS) != 0u;
        step_mode_t pwm;
        if (!any_disabled) { /* fast path: three PWM legs, no events possible */
            pwm.leg[0] = INV_LEG_PWM;
            pwm.leg[1] = INV_LEG_PWM;
            pwm.leg[2] = INV_LEG_PWM;
            finish_mode(pl, duty, &pwm);
        }
        for (k = 0; k < seg_steps[seg]; ++k) {
            if (any_disabled) {
                substep(pl, duty, h, s);
            } else {
                double s1[S_N];
                rk4(pl, &pwm, s, h, s1);
                memcpy(s, s1, sizeof s1);
            }
            s[S_TH] = wrap_2pi(s[S_TH]);
        }
        if (seg == 0) {
            take_second_sample(pl, s, duty_new); /* the actuation instant t_k + t_d */
        }
    }
    for (i = 0; i < 4; ++i) pl->y[i] = s[i];
    for (k = 0; k < 5; ++k) pl->v_avg[k] = s[Q_VA + k] / pl->params.ts_s;
    for (k = 0; k < 7; ++k) pl->energy[k] += s[Q_EIN + k];
    pl->theta_m_rad += s[Q_THM];
    /* mirror the state into the parts (their own fields serve stand-alone use and debugging) */
    sync_parts(pl);
    for (k = 0; k < 3; ++k) {
        pl->duty_prev[k] = duty_new[k];
        pl->duty_now[k] = duty_new[k];
    }
    if (pl->params.inverter.inverter == 1 && !switched) {
        sw_reset_legs(pl, duty_new); /* a period on the averaged path: steady legs after it */
    }
    ++pl->period;
    pl->t_s = (double)pl->period * pl->params.ts_s;
    take_first_sample(pl);
}

int plant_step_trace(plant_t *pl, const double duty_abc[3], const plant_trace_t *tr)
{
    const unsigned long before = pl->sw_periods;
    if (tr == NULL || tr->n < 1) {
        plant_step(pl, duty_abc);
        return -1;
    }
    pl->trace = tr;
    plant_step(pl, duty_abc);
    pl->trace = NULL;
    return (pl->sw_periods > before) ? 0 : -1;
}

void plant_step_abc(plant_t *pl, double duty_a, double duty_b, double duty_c)
{
    double d[3];
    d[0] = duty_a;
    d[1] = duty_b;
    d[2] = duty_c;
    plant_step(pl, d);
}

void plant_snapshot(const plant_t *pl, plant_snapshot_t *out)
{
    const plant_params_t *p = &pl->params;
    const double th = pl->y[S_TH];
    const double wm = pl->y[S_WM];
    const double we = (double)p->pole_pairs * wm;
    out->t_s = pl->t_s;
    out->i_d_a = pl->y[S_ID];
    out->i_q_a = pl->y[S_IQ];
    pmsm_inv_park(out->i_d_a, out->i_q_a, th, &out->i_alpha_a, &out->i_beta_a);
    pmsm_inv_clarke(out->i_alpha_a, out->i_beta_a, &out->i_a_a, &out->i_b_a, &out->i_c_a);
    out->omega_m_rad_s = wm;
    out->omega_e_rad_s = we;
    out->theta_e_rad = th;
    out->theta_m_rad = pl->theta_m_rad;
    out->torque_e_nm = pmsm_machine_torque(&pl->machine, out->i_d_a, out->i_q_a);
    out->torque_friction_nm = mechanics_friction_torque(&pl->mech, wm);
    if (p->mechanics.dyno) {
        out->torque_load_nm =
            out->torque_e_nm - out->torque_friction_nm - p->j_kgm2 * pl->dyno_accel_now_rad_s2;
    } else if (pl->load.kind == MECH_LOAD_NONE) {
        out->torque_load_nm = pl->torque_load_nm;
    } else {
        out->torque_load_nm = plant_load_torque_at(pl, pl->t_s);
    }
    if (!p->mechanics.dyno && (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_LOAD_TORQUE))) {
        out->torque_load_nm += pl->faults.load_extra_nm;
    }
    out->e_alpha_v = -we * p->psi_f_wb * sin(th);
    out->e_beta_v = we * p->psi_f_wb * cos(th);
    out->v_dc_v = p->v_dc_v;
    out->v_a_v = pl->v_avg[0];
    out->v_b_v = pl->v_avg[1];
    out->v_c_v = pl->v_avg[2];
    pmsm_clarke(out->v_a_v, out->v_b_v, out->v_c_v, &out->v_alpha_v, &out->v_beta_v);
    out->v_d_v = pl->v_avg[3];
    out->v_q_v = pl->v_avg[4];
    out->duty_a = pl->duty_now[0];
    out->duty_b = pl->duty_now[1];
    out->duty_c = pl->duty_now[2];
    pmsm_inv_park(pmsm_machine_psi_d(&pl->machine, out->i_d_a), p->lq_h * out->i_q_a, th,
                  &out->psi_alpha_wb, &out->psi_beta_wb);
}

void plant_run(plant_t *pl, const double *duties_abc, size_t n, plant_snapshot_t *out)
{
    size_t k;
    for (k = 0; k < n; ++k) {
        plant_step(pl, &duties_abc[3 * k]);
        if (out != NULL) {
            plant_snapshot(pl, &out[k]);
        }
    }
}

void plant_energy(const plant_t *pl, plant_energy_t *out)
{
    out->electrical_in_j = pl->energy[0];
    out->copper_loss_j = pl->energy[1];
    out->viscous_loss_j = pl->energy[2];
    out->load_work_j = pl->energy[3];
    out->magnetic_j = pmsm_machine_stored_energy(&pl->machine, pl->y[S_ID], pl->y[S_IQ]);
    out->kinetic_j = 0.5 * pl->params.j_kgm2 * pl->y[S_WM] * pl->y[S_WM];
    out->coulomb_loss_j = pl->energy[4];
    out->inverter_loss_j = pl->energy[5];
    out->dc_bus_in_j = pl->energy[0] + pl->energy[5];
    out->short_loss_j = pl->energy[6];
    out->fault_absorbed_j = pl->faults.absorbed_j;
    if (pl->faults.short_used) {
        out->dc_bus_in_j += pl->energy[6];
    }
}

void plant_sample(const plant_t *pl, plant_sample_t *out)
{
    *out = pl->sample;
    out->t_s = pl->t_s;
    out->t2_s = pl->t_s - pl->params.ts_s + pl->t2_offset_s;
    if (!pl->params.sensors.adc_model) { /* ideal sensors: the exact values at t_k */
        double i_abc[3];
        currents_abc(pl->y, i_abc);
        out->i_a_a = i_abc[0];
        out->i_b_a = i_abc[1];
        out->i_c_a = i_abc[2];
        out->v_dc_v = pl->params.v_dc_v;
        out->code_a = -1;
        out->code_b = -1;
        out->code_c = -1;
        out->code_vdc = -1;
    }
    out->theta_enc_rad = pl->y[S_TH];
    out->enc_valid = 1;
    if (pl->faults.active || pl->faults.resample) {
        plant_fault_sample(pl, out);
    }
}
