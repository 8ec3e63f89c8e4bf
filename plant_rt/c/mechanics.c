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
    return (torque_e_nm - mech->cfg.b_nms * omega_m_rad_s - torque_load_nm) * mech->inv_j;
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
