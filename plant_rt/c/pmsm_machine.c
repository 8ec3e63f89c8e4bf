/**
 * @file pmsm_machine.c
 * @brief PMSM dq model, open-phase dynamics, transforms. See pmsm_machine.h.
 */
#include "pmsm_machine.h"

#include <math.h>

#define PM_SQRT3 1.7320508075688772935
#define PM_INV_SQRT3 0.57735026918962576451
#define PM_TWO_PI_3 2.0943951023931954923

int pmsm_machine_init(pmsm_machine_t *m, const pmsm_machine_config_t *cfg)
{
    if (!isfinite(cfg->rs_ohm) || cfg->rs_ohm < 0.0) {
        return -1;
    }
    if (!isfinite(cfg->ld_h) || !(cfg->ld_h > 0.0) || !isfinite(cfg->lq_h) || !(cfg->lq_h > 0.0)) {
        return -1;
    }
    if (!isfinite(cfg->psi_f_wb) || cfg->psi_f_wb < 0.0 || cfg->pole_pairs < 1) {
        return -1;
    }
    m->cfg = *cfg;
    m->inv_ld = 1.0 / cfg->ld_h;
    m->inv_lq = 1.0 / cfg->lq_h;
    m->k_torque = 1.5 * (double)cfg->pole_pairs;
    m->saturated = 0;
    m->sat_ls_h = cfg->ld_h;
    m->sat_k_h = 0.0;
    m->sat_is_a = 1.0;
    m->sat_i0_a = 0.0;
    m->sat_t0 = 0.0;
    m->sat_j0 = 0.0;
    pmsm_machine_reset(m);
    return 0;
}

/* ---- saturation ---- */

/** ln cosh(u) without overflow. */
static double log_cosh(double u)
{
    const double a = fabs(u);
    return a + log1p(exp(-2.0 * a)) - 0.69314718055994530942;
}

/** Primitive of x sech^2((x - i0)/Is) [A^2]: Is^2 (u tanh u - ln cosh u) + i0 Is tanh u. */
static double sat_primitive(const pmsm_machine_t *m, double i_d_a)
{
    const double is = m->sat_is_a;
    const double u = (i_d_a - m->sat_i0_a) / is;
    const double th = tanh(u);
    return is * is * (u * th - log_cosh(u)) + m->sat_i0_a * is * th;
}

int pmsm_machine_set_saturation(pmsm_machine_t *m, const pmsm_saturation_config_t *sat)
{
    double c;
    m->saturated = 0;
    if (sat == 0) {
        return 0;
    }
    if (!isfinite(sat->l_inf_ratio) || !(sat->l_inf_ratio > 0.0) || !(sat->l_inf_ratio <= 1.0) ||
        !isfinite(sat->i_scale_a) || !(sat->i_scale_a > 0.0) || !isfinite(sat->i_knee_a) ||
        !(sat->i_knee_a <= 0.0) || !(sat->i_knee_a >= -3.0 * sat->i_scale_a)) {
        return -1;
    }
    c = cosh(sat->i_knee_a / sat->i_scale_a);
    m->sat_ls_h = sat->l_inf_ratio * m->cfg.ld_h;
    m->sat_k_h = (m->cfg.ld_h - m->sat_ls_h) * c * c;
    m->sat_is_a = sat->i_scale_a;
    m->sat_i0_a = sat->i_knee_a;
    m->sat_t0 = tanh(sat->i_knee_a / sat->i_scale_a);
    m->saturated = 1;
    m->sat_j0 = sat_primitive(m, 0.0);
    return 0;
}

double pmsm_machine_psi_d(const pmsm_machine_t *m, double i_d_a)
{
    if (!m->saturated) {
        return m->cfg.ld_h * i_d_a + m->cfg.psi_f_wb;
    }
    return m->cfg.psi_f_wb + m->sat_ls_h * i_d_a +
           m->sat_k_h * m->sat_is_a * (tanh((i_d_a - m->sat_i0_a) / m->sat_is_a) + m->sat_t0);
}

void pmsm_machine_flux_d(const pmsm_machine_t *m, double i_d_a, double *psi_d_wb, double *ld_inc_h)
{
    double th;
    if (!m->saturated) {
        *psi_d_wb = m->cfg.ld_h * i_d_a + m->cfg.psi_f_wb;
        *ld_inc_h = m->cfg.ld_h;
        return;
    }
    th = tanh((i_d_a - m->sat_i0_a) / m->sat_is_a);
    *psi_d_wb = m->cfg.psi_f_wb + m->sat_ls_h * i_d_a + m->sat_k_h * m->sat_is_a * (th + m->sat_t0);
    *ld_inc_h = m->sat_ls_h + m->sat_k_h * (1.0 - th) * (1.0 + th); /* sech^2 = 1 - tanh^2 */
}

double pmsm_machine_ld_inc(const pmsm_machine_t *m, double i_d_a)
{
    double c;
    if (!m->saturated) {
        return m->cfg.ld_h;
    }
    c = cosh((i_d_a - m->sat_i0_a) / m->sat_is_a);
    return m->sat_ls_h + m->sat_k_h / (c * c);
}

void pmsm_machine_reset(pmsm_machine_t *m)
{
    m->i_d_a = 0.0;
    m->i_q_a = 0.0;
}

void pmsm_machine_derivs(const pmsm_machine_t *m, double i_d_a, double i_q_a, double v_d_v,
                         double v_q_v, double omega_e_rad_s, double *di_d, double *di_q)
{
    const pmsm_machine_config_t *c = &m->cfg;
    if (m->saturated) {
        double psi_d, ld_inc;
        pmsm_machine_flux_d(m, i_d_a, &psi_d, &ld_inc);
        *di_d = (v_d_v - c->rs_ohm * i_d_a + omega_e_rad_s * c->lq_h * i_q_a) / ld_inc;
        *di_q = (v_q_v - c->rs_ohm * i_q_a - omega_e_rad_s * psi_d) * m->inv_lq;
        return;
    }
    *di_d = (v_d_v - c->rs_ohm * i_d_a + omega_e_rad_s * c->lq_h * i_q_a) * m->inv_ld;
    *di_q = (v_q_v - c->rs_ohm * i_q_a - omega_e_rad_s * (c->ld_h * i_d_a + c->psi_f_wb)) * m->inv_lq;
}

void pmsm_machine_derivs_open_phase(const pmsm_machine_t *m, double i_d_a, double i_q_a,
                                    double theta_e_rad, double omega_e_rad_s, int open_phase,
                                    double v_yz_v, double *di_d, double *di_q, double *v_open_v)
{
    const pmsm_machine_config_t *c = &m->cfg;
    /* u_x = phase-x axis in alpha-beta; w = the same axis seen in dq (rotated by -theta). */
    const double axis = (open_phase == 0) ? 0.0 : ((open_phase == 1) ? PM_TWO_PI_3 : -PM_TWO_PI_3);
    const double phi = axis - theta_e_rad;
    const double wd = cos(phi);
    const double wq = sin(phi);
    /* Known voltage component along n = J u_x (J w in dq, = (-wq, wd)). */
    const double a_n = v_yz_v * PM_INV_SQRT3;
    double psi_d, ld_inc, inv_ld, bd, bq, jw_dot_i, w_linv_w, lambda;
    /* d-axis flux and inverse incremental inductance (linear: L_d i_d + psi_f, 1/L_d) */
    pmsm_machine_flux_d(m, i_d_a, &psi_d, &ld_inc);
    inv_ld = m->saturated ? 1.0 / ld_inc : m->inv_ld;
    /* Unconstrained right-hand side without the unknown open-phase voltage. */
    bd = -a_n * wq - c->rs_ohm * i_d_a + omega_e_rad_s * c->lq_h * i_q_a;
    bq = a_n * wd - c->rs_ohm * i_q_a - omega_e_rad_s * psi_d;
    /* d/dt (w . i) = dw/dt . i + w . di/dt = 0 with dw/dt = -omega J w. */
    jw_dot_i = -wq * i_d_a + wd * i_q_a;
    w_linv_w = wd * wd * inv_ld + wq * wq * m->inv_lq;
    lambda = (omega_e_rad_s * jw_dot_i - (wd * bd * inv_ld + wq * bq * m->inv_lq)) / w_linv_w;
    *di_d = (bd + lambda * wd) * inv_ld;
    *di_q = (bq + lambda * wq) * m->inv_lq;
    *v_open_v = lambda;
}

double pmsm_machine_torque(const pmsm_machine_t *m, double i_d_a, double i_q_a)
{
    const pmsm_machine_config_t *c = &m->cfg;
    if (m->saturated) {
        return m->k_torque * (pmsm_machine_psi_d(m, i_d_a) * i_q_a - c->lq_h * i_d_a * i_q_a);
    }
    return m->k_torque * (c->psi_f_wb * i_q_a + (c->ld_h - c->lq_h) * i_d_a * i_q_a);
}

double pmsm_machine_stored_energy(const pmsm_machine_t *m, double i_d_a, double i_q_a)
{
    if (m->saturated) {
        const double wd = 0.5 * m->sat_ls_h * i_d_a * i_d_a +
                          m->sat_k_h * (sat_primitive(m, i_d_a) - m->sat_j0);
        return 1.5 * (wd + 0.5 * m->cfg.lq_h * i_q_a * i_q_a);
    }
    return 0.75 * (m->cfg.ld_h * i_d_a * i_d_a + m->cfg.lq_h * i_q_a * i_q_a);
}

void pmsm_machine_step(pmsm_machine_t *m, double v_d_v, double v_q_v, double omega_e_rad_s,
                       double dt_s)
{
    double k1d, k1q, k2d, k2q, k3d, k3q, k4d, k4q;
    const double id = m->i_d_a;
    const double iq = m->i_q_a;
    const double h2 = 0.5 * dt_s;
    pmsm_machine_derivs(m, id, iq, v_d_v, v_q_v, omega_e_rad_s, &k1d, &k1q);
    pmsm_machine_derivs(m, id + h2 * k1d, iq + h2 * k1q, v_d_v, v_q_v, omega_e_rad_s, &k2d, &k2q);
    pmsm_machine_derivs(m, id + h2 * k2d, iq + h2 * k2q, v_d_v, v_q_v, omega_e_rad_s, &k3d, &k3q);
    pmsm_machine_derivs(m, id + dt_s * k3d, iq + dt_s * k3q, v_d_v, v_q_v, omega_e_rad_s, &k4d,
                        &k4q);
    m->i_d_a = id + dt_s / 6.0 * (k1d + 2.0 * k2d + 2.0 * k3d + k4d);
    m->i_q_a = iq + dt_s / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q);
}

void pmsm_clarke(double a, double b, double c, double *alpha, double *beta)
{
    /* Remove the zero sequence first so the result does not depend on it. */
    const double z = (a + b + c) / 3.0;
    const double a0 = a - z;
    const double b0 = b - z;
    *alpha = a0;
    *beta = (a0 + 2.0 * b0) * PM_INV_SQRT3;
}

void pmsm_inv_clarke(double alpha, double beta, double *a, double *b, double *c)
{
    *a = alpha;
    *b = -0.5 * alpha + 0.5 * PM_SQRT3 * beta;
    *c = -0.5 * alpha - 0.5 * PM_SQRT3 * beta;
}

void pmsm_park(double alpha, double beta, double theta_e_rad, double *d, double *q)
{
    const double s = sin(theta_e_rad);
    const double co = cos(theta_e_rad);
    *d = alpha * co + beta * s;
    *q = -alpha * s + beta * co;
}

void pmsm_inv_park(double d, double q, double theta_e_rad, double *alpha, double *beta)
{
    const double s = sin(theta_e_rad);
    const double co = cos(theta_e_rad);
    *alpha = d * co - q * s;
    *beta = d * s + q * co;
}
