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
 */
#include "plant.h"

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
    S_N
};

/** Leg modes held over one RK4 step. */
typedef struct step_mode {
    inverter_leg_mode_t leg[3];
    double v_pole_v[3]; /* pole voltages of the source legs */
    int n_open;         /* 0, 1 (open_phase open) or >= 2 (all currents zero) */
    int open_phase;
    int has_disabled;   /* any disabled leg: guards must be watched */
} step_mode_t;

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
    return NULL;
}

/* ------------------------------------------------------------------------------------------ */
/* small helpers                                                                              */

static double wrap_2pi(double x)
{
    double r = fmod(x, PL_TWO_PI);
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

/** Terminal voltage v_xN [V] the open phase floats to, for mode->n_open == 1. */
static double open_terminal_voltage(const plant_t *pl, const step_mode_t *mode, const double *s)
{
    const int x = mode->open_phase;
    const int y = (x + 1) % 3;
    const int z = (x + 2) % 3;
    double did, diq, lam;
    pmsm_machine_derivs_open_phase(&pl->machine, s[S_ID], s[S_IQ], s[S_TH],
                                   (double)pl->params.pole_pairs * s[S_WM], x,
                                   mode->v_pole_v[y] - mode->v_pole_v[z], &did, &diq, &lam);
    return 0.5 * (mode->v_pole_v[y] + mode->v_pole_v[z]) + 1.5 * lam;
}

/* ------------------------------------------------------------------------------------------ */
/* leg modes                                                                                  */

static void finish_mode(const plant_t *pl, const double duty[3], step_mode_t *mode)
{
    int k;
    mode->n_open = 0;
    mode->open_phase = -1;
    mode->has_disabled = 0;
    for (k = 0; k < 3; ++k) {
        if (mode->leg[k] == INV_LEG_OPEN) {
            ++mode->n_open;
            mode->open_phase = k;
        }
        if (mode->leg[k] != INV_LEG_PWM) {
            mode->has_disabled = 1;
        }
    }
    inverter_pole_voltages(&pl->inverter, duty, mode->leg, mode->v_pole_v);
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
    currents_abc(s, i_abc);
    (void)inverter_classify(inv, duty, i_abc, mode->leg);
    for (iter = 0; iter < 4; ++iter) {
        finish_mode(pl, duty, mode);
        if (mode->n_open == 0) {
            return;
        }
        if (mode->n_open == 1) {
            const int x = mode->open_phase;
            clamp_phase_current(s, x);
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
                int kmax = 0;
                int kmin = 0;
                for (k = 1; k < 3; ++k) {
                    if (e[k] > e[kmax]) kmax = k;
                    if (e[k] < e[kmin]) kmin = k;
                }
                if (e[kmax] - e[kmin] > inv->cfg.v_dc_v + inv->v_tol_v) {
                    mode->leg[kmax] = INV_LEG_DIODE_HIGH; /* current leaves the machine there */
                    mode->leg[kmin] = INV_LEG_DIODE_LOW;
                    continue; /* the middle phase is decided as a single open phase */
                }
                return;
            } else {
                /* one source leg z fixes the neutral: v_nN = v_zN - e_z */
                int z = 0;
                int worst = -1;
                double worst_margin = 0.0;
                double v_n;
                for (k = 0; k < 3; ++k) {
                    if (mode->leg[k] != INV_LEG_OPEN) z = k;
                }
                v_n = mode->v_pole_v[z] - e[z];
                for (k = 0; k < 3; ++k) {
                    if (k != z) {
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
    currents_abc(s, i_abc);
    for (k = 0; k < 3; ++k) {
        if (mode->leg[k] == INV_LEG_DIODE_LOW && i_abc[k] < margin) {
            margin = i_abc[k];
        } else if (mode->leg[k] == INV_LEG_DIODE_HIGH && -i_abc[k] < margin) {
            margin = -i_abc[k];
        }
    }
    if (mode->n_open == 1) {
        const double m = inverter_open_margin(inv, open_terminal_voltage(pl, mode, s));
        if (m < margin) margin = m;
    } else if (mode->n_open >= 2) {
        double e[3];
        emf_abc(pl, s, e);
        if (mode->n_open == 3) {
            const double emax = fmax(e[0], fmax(e[1], e[2]));
            const double emin = fmin(e[0], fmin(e[1], e[2]));
            const double m = inv->cfg.v_dc_v + inv->v_tol_v - (emax - emin);
            if (m < margin) margin = m;
        } else {
            int z = 0;
            double v_n;
            for (k = 0; k < 3; ++k) {
                if (mode->leg[k] != INV_LEG_OPEN) z = k;
            }
            v_n = mode->v_pole_v[z] - e[z];
            for (k = 0; k < 3; ++k) {
                if (k != z) {
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

static void deriv(const plant_t *pl, const step_mode_t *mode, const double *s, double *ds)
{
    const plant_params_t *p = &pl->params;
    const double id = s[S_ID];
    const double iq = s[S_IQ];
    const double wm = s[S_WM];
    const double we = (double)p->pole_pairs * wm;
    const double sn = sin(s[S_TH]);
    const double cs = cos(s[S_TH]);
    double v[3];
    double valpha, vbeta, vd, vq, did, diq, te;

    if (mode->n_open == 0) {
        inverter_phase_voltages(mode->v_pole_v, v);
        valpha = v[0];
        vbeta = (v[0] + 2.0 * v[1]) * PL_INV_SQRT3;
        vd = valpha * cs + vbeta * sn;
        vq = -valpha * sn + vbeta * cs;
        pmsm_machine_derivs(&pl->machine, id, iq, vd, vq, we, &did, &diq);
    } else if (mode->n_open == 1) {
        const int x = mode->open_phase;
        const int y = (x + 1) % 3;
        const int z = (x + 2) % 3;
        const double d_yz = mode->v_pole_v[y] - mode->v_pole_v[z];
        double lam;
        pmsm_machine_derivs_open_phase(&pl->machine, id, iq, s[S_TH], we, x, d_yz, &did, &diq,
                                       &lam);
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
    ds[S_ID] = did;
    ds[S_IQ] = diq;
    ds[S_WM] = mechanics_accel(&pl->mech, wm, te, pl->torque_load_nm);
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
    ds[Q_ELOAD] = pl->torque_load_nm * wm;
}

static void rk4(const plant_t *pl, const step_mode_t *mode, const double *s0, double h, double *s1)
{
    double k1[S_N], k2[S_N], k3[S_N], k4[S_N], tmp[S_N];
    const double h2 = 0.5 * h;
    const double h6 = h / 6.0;
    int i;
    deriv(pl, mode, s0, k1);
    for (i = 0; i < S_N; ++i) tmp[i] = s0[i] + h2 * k1[i];
    deriv(pl, mode, tmp, k2);
    for (i = 0; i < S_N; ++i) tmp[i] = s0[i] + h2 * k2[i];
    deriv(pl, mode, tmp, k3);
    for (i = 0; i < S_N; ++i) tmp[i] = s0[i] + h * k3[i];
    deriv(pl, mode, tmp, k4);
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

int plant_init(plant_t *pl, const plant_params_t *p)
{
    pmsm_machine_config_t mc;
    inverter_config_t ic;
    mechanics_config_t kc;
    double frac;
    int n;
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
    /* split the period at the delay instant; every step <= ts/substeps */
    n = p->substeps;
    frac = p->t_delay_s / p->ts_s;
    if (!(p->t_delay_s > 0.0)) {
        pl->seg_steps[0] = 0;
        pl->seg_steps[1] = n;
    } else if (!(p->t_delay_s < p->ts_s)) {
        pl->seg_steps[0] = n;
        pl->seg_steps[1] = 0;
    } else {
        pl->seg_steps[0] = (int)ceil((double)n * frac - 1e-9);
        pl->seg_steps[1] = (int)ceil((double)n * (1.0 - frac) - 1e-9);
        if (pl->seg_steps[0] < 1) pl->seg_steps[0] = 1;
        if (pl->seg_steps[1] < 1) pl->seg_steps[1] = 1;
    }
    pl->seg_h_s[0] = (pl->seg_steps[0] > 0) ? p->t_delay_s / (double)pl->seg_steps[0] : 0.0;
    pl->seg_h_s[1] = (pl->seg_steps[1] > 0) ? (p->ts_s - p->t_delay_s) / (double)pl->seg_steps[1] : 0.0;
    plant_reset(pl);
    return 0;
}

void plant_reset(plant_t *pl)
{
    int k;
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
    for (k = 0; k < 4; ++k) pl->energy[k] = 0.0;
    pl->events = 0UL;
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

void plant_step(plant_t *pl, const double duty_abc[3])
{
    double s[S_N];
    double duty_new[3];
    int seg, k, i;
    for (k = 0; k < 3; ++k) {
        duty_new[k] = inverter_sanitize_duty(duty_abc[k]);
    }
    for (i = 0; i < S_N; ++i) s[i] = 0.0;
    for (i = 0; i < 4; ++i) s[i] = pl->y[i];
    for (seg = 0; seg < 2; ++seg) {
        const double *duty = (seg == 0) ? pl->duty_prev : duty_new;
        const double h = pl->seg_h_s[seg];
        const int any_disabled = inverter_leg_disabled(duty[0]) ||
                                 inverter_leg_disabled(duty[1]) || inverter_leg_disabled(duty[2]);
        step_mode_t pwm;
        if (!any_disabled) { /* fast path: three PWM legs, no events possible */
            pwm.leg[0] = INV_LEG_PWM;
            pwm.leg[1] = INV_LEG_PWM;
            pwm.leg[2] = INV_LEG_PWM;
            finish_mode(pl, duty, &pwm);
        }
        for (k = 0; k < pl->seg_steps[seg]; ++k) {
            if (any_disabled) {
                substep(pl, duty, h, s);
            } else {
                double s1[S_N];
                rk4(pl, &pwm, s, h, s1);
                memcpy(s, s1, sizeof s1);
            }
            s[S_TH] = wrap_2pi(s[S_TH]);
        }
    }
    for (i = 0; i < 4; ++i) pl->y[i] = s[i];
    for (k = 0; k < 5; ++k) pl->v_avg[k] = s[Q_VA + k] / pl->params.ts_s;
    for (k = 0; k < 4; ++k) pl->energy[k] += s[Q_EIN + k];
    pl->theta_m_rad += s[Q_THM];
    /* mirror the state into the parts (their own fields serve stand-alone use and debugging) */
    pl->machine.i_d_a = s[S_ID];
    pl->machine.i_q_a = s[S_IQ];
    pl->mech.omega_m_rad_s = s[S_WM];
    pl->mech.theta_m_rad = pl->theta_m_rad;
    for (k = 0; k < 3; ++k) {
        pl->duty_prev[k] = duty_new[k];
        pl->duty_now[k] = duty_new[k];
    }
    ++pl->period;
    pl->t_s = (double)pl->period * pl->params.ts_s;
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
    out->torque_load_nm = pl->torque_load_nm;
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
}
