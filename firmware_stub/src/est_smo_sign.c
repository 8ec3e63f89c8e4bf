#include "est_smo_sign.h"

#include <math.h>

/** The adaptive gain's |e| may exceed the observed |E^| (LPF undone) by this factor at most. */
#define EST_SMO_SIGN_EMF_CAP 2.0f

void est_smo_sign_default_config(est_smo_sign_config_t *cfg, float rs_ohm, float ls_h,
                                 float psi_f_wb, float ts_s)
{
    cfg->rs_ohm = rs_ohm;
    cfg->ls_h = ls_h;
    cfg->psi_f_wb = psi_f_wb;
    cfg->ts_s = ts_s;
    cfg->k_v = 0.0f;
    cfg->k_factor = 1.5f;
    cfg->k_min_v = 5.0f;
    cfg->wc_rad_s = 1000.0f;
    cfg->speed_from_emf = 0;
    est_pll_gains(150.0f, &cfg->pll_kp, &cfg->pll_ki);
    cfg->speed_lpf_rad_s = 0.0f;
    cfg->dir_speed_rad_s = EST_EMF_DIR_SPEED_RAD_S;
}

int est_smo_sign_init(est_smo_sign_t *s, const est_smo_sign_config_t *cfg)
{
    if (!(cfg->ls_h > 0.0f) || !(cfg->ts_s > 0.0f) || !(cfg->wc_rad_s > 0.0f) ||
        !(cfg->rs_ohm >= 0.0f)) {
        return -1;
    }
    s->cfg = *cfg;
    if (cfg->rs_ohm > 0.0f) {
        s->f = expf(-cfg->rs_ohm * cfg->ts_s / cfg->ls_h);
        s->g = (1.0f - s->f) / cfg->rs_ohm;
    } else {
        s->f = 1.0f;
        s->g = cfg->ts_s / cfg->ls_h;
    }
    s->a_lpf = 1.0f - expf(-cfg->wc_rad_s * cfg->ts_s);
    s->a_speed = cfg->speed_lpf_rad_s > 0.0f ? 1.0f - expf(-cfg->speed_lpf_rad_s * cfg->ts_s) : 1.0f;
    est_pll_init(&s->pll, cfg->pll_kp, cfg->pll_ki);
    est_smo_sign_reset(s);
    return 0;
}

void est_smo_sign_reset(est_smo_sign_t *s)
{
    s->i_hat_a.x = s->i_hat_a.y = 0.0f;
    s->z_v.x = s->z_v.y = 0.0f;
    s->e_hat_v.x = s->e_hat_v.y = 0.0f;
    s->k_now_v = s->cfg.k_v > 0.0f ? s->cfg.k_v : s->cfg.k_min_v;
    est_pll_reset(&s->pll, 0.0f, 0.0f);
    est_emf_dir_reset(&s->dir);
    s->out.theta_e_rad = 0.0f;
    s->out.omega_e_rad_s = 0.0f;
    s->out.e_alpha_v = 0.0f;
    s->out.e_beta_v = 0.0f;
}

const est_output_t *est_smo_sign_step(est_smo_sign_t *s, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v)
{
    const est_smo_sign_config_t *c = &s->cfg;
    float theta_raw, omega, e_mag;

    /* propagate the current model over the last period (eq. 4 / Gong 3), ZOH */
    s->i_hat_a.x = s->f * s->i_hat_a.x + s->g * (v_ab_prev_v.x - s->z_v.x);
    s->i_hat_a.y = s->f * s->i_hat_a.y + s->g * (v_ab_prev_v.y - s->z_v.y);

    /* switching term on the new error (eq. 6 / Gong 4) */
    s->z_v.x = s->k_now_v * fw_signf(s->i_hat_a.x - i_ab_a.x);
    s->z_v.y = s->k_now_v * fw_signf(s->i_hat_a.y - i_ab_a.y);

    /* equivalent control through the LPF (eq. 7 / Gong 6 + LPF) */
    s->e_hat_v.x += s->a_lpf * (s->z_v.x - s->e_hat_v.x);
    s->e_hat_v.y += s->a_lpf * (s->z_v.y - s->e_hat_v.y);

    /* position (eq. 8) with the LPF phase-lag compensation (eq. 9 / Gong 7) */
    theta_raw = atan2f(-s->e_hat_v.x, s->e_hat_v.y);
    theta_raw += atanf(s->out.omega_e_rad_s / c->wc_rad_s);

    /* direction of rotation (+pi for w < 0) and speed: est_common */
    theta_raw = est_emf_angle_step(&s->pll, &s->dir, theta_raw, c->dir_speed_rad_s, c->ts_s);
    e_mag = sqrtf(s->e_hat_v.x * s->e_hat_v.x + s->e_hat_v.y * s->e_hat_v.y);
    omega = s->pll.omega_rad_s;
    if (c->speed_from_emf && c->psi_f_wb > 0.0f) {
        /* eq. 10 gives the magnitude; the direction is the PLL's */
        float mag = e_mag / c->psi_f_wb;
        omega = omega < 0.0f ? -mag : mag;
    }
    s->out.omega_e_rad_s += s->a_speed * (omega - s->out.omega_e_rad_s);
    s->out.theta_e_rad = theta_raw;
    s->out.e_alpha_v = s->e_hat_v.x;
    s->out.e_beta_v = s->e_hat_v.y;

    /* gain for the next step (eq. 5: k >= max|e|). The EMF |e| = |w| psi_f is taken from the
     * speed estimate, but not above twice what the observer's own EMF supports (|E^| with the
     * LPF's attenuation undone; twice: at speed |E^| ripples some 20 % about |e| and must not
     * modulate the gain). Near zero speed the PLL follows the angle of the chattering, its speed
     * can stray far above the true one, and a gain following it would make the chattering - and
     * so the stray speed - grow: a positive feedback that held the drive at zero speed in a
     * reversal (docs/estimators_smo.md). */
    if (c->k_v > 0.0f) {
        s->k_now_v = c->k_v;
    } else {
        const float w_over_wc = s->out.omega_e_rad_s / c->wc_rad_s;
        const float e_speed = fabsf(s->out.omega_e_rad_s) * c->psi_f_wb;
        const float e_obs = EST_SMO_SIGN_EMF_CAP * e_mag * sqrtf(1.0f + w_over_wc * w_over_wc);
        const float k = c->k_factor * (e_speed < e_obs ? e_speed : e_obs);
        s->k_now_v = k > c->k_min_v ? k : c->k_min_v;
    }
    return &s->out;
}
