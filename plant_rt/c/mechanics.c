/**
 * @file mechanics.c
 * @brief Rigid-rotor mechanics. See mechanics.h.
 */
#include "mechanics.h"

#include <math.h>

int mechanics_init(mechanics_t *mech, const mechanics_config_t *cfg)
{
    if (!isfinite(cfg->j_kgm2) || !(cfg->j_kgm2 > 0.0)) {
        return -1;
    }
    if (!isfinite(cfg->b_nms) || cfg->b_nms < 0.0 || cfg->pole_pairs < 1) {
        return -1;
    }
    mech->cfg = *cfg;
    mech->inv_j = 1.0 / cfg->j_kgm2;
    mech->coulomb_nm = 0.0;
    mech->inv_coulomb_band = 0.0;
    mechanics_reset(mech);
    return 0;
}

void mechanics_reset(mechanics_t *mech)
{
    mech->omega_m_rad_s = 0.0;
    mech->theta_m_rad = 0.0;
}

double mechanics_accel(const mechanics_t *mech, double omega_m_rad_s, double torque_e_nm,
                       double torque_load_nm)
{
    if (mech->coulomb_nm > 0.0) {
        return (torque_e_nm - mechanics_friction_torque(mech, omega_m_rad_s) - torque_load_nm) *
               mech->inv_j;
    }
    return (torque_e_nm - mech->cfg.b_nms * omega_m_rad_s - torque_load_nm) * mech->inv_j;
}

int mechanics_set_coulomb(mechanics_t *mech, double coulomb_nm, double coulomb_band_rad_s)
{
    if (!isfinite(coulomb_nm) || !(coulomb_nm >= 0.0)) {
        return -1;
    }
    if (coulomb_nm > 0.0 && (!isfinite(coulomb_band_rad_s) || !(coulomb_band_rad_s > 0.0))) {
        return -1;
    }
    mech->coulomb_nm = coulomb_nm;
    mech->inv_coulomb_band = (coulomb_nm > 0.0) ? 1.0 / coulomb_band_rad_s : 0.0;
    return 0;
}

double mechanics_friction_torque(const mechanics_t *mech, double omega_m_rad_s)
{
    double t = mech->cfg.b_nms * omega_m_rad_s;
    if (mech->coulomb_nm > 0.0) {
        t += mech->coulomb_nm * tanh(omega_m_rad_s * mech->inv_coulomb_band);
    }
    return t;
}

/* ---- load-torque profile ---- */

const char *mechanics_load_profile_check(const mechanics_load_profile_t *lp)
{
    int k;
    switch (lp->kind) {
    case MECH_LOAD_NONE:
        return 0;
    case MECH_LOAD_STEP:
    case MECH_LOAD_RAMP:
        if (!isfinite(lp->t0_s)) return "load_t0_s: must be finite";
        if (!isfinite(lp->torque0_nm)) return "load_torque0_nm: must be finite";
        if (!isfinite(lp->torque1_nm)) return "load_torque1_nm: must be finite";
        if (lp->kind == MECH_LOAD_RAMP) {
            if (!isfinite(lp->t1_s)) return "load_t1_s: must be finite";
            if (!(lp->t1_s > lp->t0_s)) return "load_t1_s: must be > load_t0_s for a ramp";
        }
        return 0;
    case MECH_LOAD_TABLE:
        if (lp->table_n < 1 || lp->table_n > MECH_LOAD_TABLE_MAX) {
            return "load_table_t_s: must have 1 to 32 points";
        }
        for (k = 0; k < lp->table_n; ++k) {
            if (!isfinite(lp->table_t_s[k])) return "load_table_t_s: must be finite";
            if (!isfinite(lp->table_nm[k])) return "load_table_nm: must be finite";
            if (k > 0 && !(lp->table_t_s[k] > lp->table_t_s[k - 1])) {
                return "load_table_t_s: must be strictly increasing";
            }
        }
        return 0;
    default:
        return "load_profile: must be none, step, ramp or table";
    }
}

/** Points of a RAMP (2) or TABLE (n) as a piecewise-linear function. */
static int pl_points(const mechanics_load_profile_t *lp, const double **t, const double **v,
                     double ramp_t[2], double ramp_v[2])
{
    if (lp->kind == MECH_LOAD_RAMP) {
        ramp_t[0] = lp->t0_s;
        ramp_t[1] = lp->t1_s;
        ramp_v[0] = lp->torque0_nm;
        ramp_v[1] = lp->torque1_nm;
        *t = ramp_t;
        *v = ramp_v;
        return 2;
    }
    *t = lp->table_t_s;
    *v = lp->table_nm;
    return lp->table_n;
}

static double pl_value(const double *t, const double *v, int n, double x)
{
    int k;
    if (x <= t[0]) return v[0];
    if (x >= t[n - 1]) return v[n - 1];
    for (k = 1; k < n; ++k) {
        if (x <= t[k]) {
            const double f = (x - t[k - 1]) / (t[k] - t[k - 1]);
            return v[k - 1] + f * (v[k] - v[k - 1]);
        }
    }
    return v[n - 1];
}

double mechanics_load_profile_at(const mechanics_load_profile_t *lp, double t_s)
{
    const double *t, *v;
    double rt[2], rv[2];
    int n;
    switch (lp->kind) {
    case MECH_LOAD_STEP:
        return (t_s < lp->t0_s) ? lp->torque0_nm : lp->torque1_nm;
    case MECH_LOAD_RAMP:
    case MECH_LOAD_TABLE:
        n = pl_points(lp, &t, &v, rt, rv);
        return pl_value(t, v, n, t_s);
    default:
        return 0.0;
    }
}

double mechanics_load_profile_mean(const mechanics_load_profile_t *lp, double t_a_s, double t_b_s)
{
    const double *t, *v;
    double rt[2], rv[2];
    double area = 0.0;
    double x0;
    int n, k;
    if (lp->kind == MECH_LOAD_NONE) {
        return 0.0;
    }
    if (!(t_b_s > t_a_s)) {
        return mechanics_load_profile_at(lp, t_a_s);
    }
    if (lp->kind == MECH_LOAD_STEP) {
        if (t_b_s <= lp->t0_s) return lp->torque0_nm;
        if (t_a_s >= lp->t0_s) return lp->torque1_nm;
        return (lp->torque0_nm * (lp->t0_s - t_a_s) + lp->torque1_nm * (t_b_s - lp->t0_s)) /
               (t_b_s - t_a_s);
    }
    /* piecewise linear: trapezoids between t_a, the breakpoints inside (t_a, t_b), and t_b */
    n = pl_points(lp, &t, &v, rt, rv);
    x0 = t_a_s;
    for (k = 0; k < n; ++k) {
        if (t[k] > x0 && t[k] < t_b_s) {
            area += 0.5 * (t[k] - x0) * (pl_value(t, v, n, x0) + v[k]);
            x0 = t[k];
        }
    }
    area += 0.5 * (t_b_s - x0) * (pl_value(t, v, n, x0) + pl_value(t, v, n, t_b_s));
    return area / (t_b_s - t_a_s);
}

void mechanics_step(mechanics_t *mech, double torque_e_nm, double torque_load_nm, double dt_s)
{
    const double tau_net = torque_e_nm - torque_load_nm;
    const double w0 = mech->omega_m_rad_s;
    if (mech->cfg.b_nms > 0.0) {
        /* omega(t) = w_inf + (w0 - w_inf) exp(-t/tau_m), tau_m = J/B. */
        const double tau_m = mech->cfg.j_kgm2 / mech->cfg.b_nms;
        const double w_inf = tau_net / mech->cfg.b_nms;
        const double em1 = expm1(-dt_s / tau_m); /* exp(-t/tau) - 1, accurate for small t */
        mech->omega_m_rad_s = w0 + (w0 - w_inf) * em1;
        mech->theta_m_rad += w_inf * dt_s - (w0 - w_inf) * tau_m * em1;
    } else {
        const double a = tau_net * mech->inv_j;
        mech->omega_m_rad_s = w0 + a * dt_s;
        mech->theta_m_rad += w0 * dt_s + 0.5 * a * dt_s * dt_s;
    }
}
