#include "est_smo_sta.h"

#include <math.h>

void est_smo_sta_default_config(est_smo_sta_config_t *cfg, float rs_ohm, float ls_h,
                                float psi_f_wb, float ts_s)
{
    cfg->rs_ohm = rs_ohm;
    cfg->ls_h = ls_h;
    cfg->psi_f_wb = psi_f_wb;
    cfg->ts_s = ts_s;
    cfg->k1_v = 0.0f;
    cfg->k2_v_s = 0.0f;
    cfg->k_margin = 1.5f;
    cfg->omega_min_rad_s = FW_TWO_PI_F * 5.0f;
    est_pll_gains(150.0f, &cfg->pll_kp, &cfg->pll_ki);
    cfg->speed_lpf_rad_s = 0.0f;
    cfg->dir_speed_rad_s = EST_EMF_DIR_SPEED_RAD_S;
}

void est_smo_sta_gains(const est_smo_sta_config_t *cfg, float omega_e_rad_s, float *k1_v,
                       float *k2_v_s)
{
    const float w = fmaxf(fabsf(omega_e_rad_s), cfg->omega_min_rad_s);
    const float delta = w * w * cfg->psi_f_wb / cfg->ls_h;   /* bound of e'/Ls [A/s^2] */
    *k1_v = cfg->k_margin * cfg->ls_h * sqrtf(12.0f * delta);
    *k2_v_s = 2.0f * cfg->k_margin * cfg->ls_h * delta;
}

int est_smo_sta_init(est_smo_sta_t *s, const est_smo_sta_config_t *cfg)
{
    if (!(cfg->ls_h > 0.0f) || !(cfg->ts_s > 0.0f) || !(cfg->rs_ohm >= 0.0f) ||
        !(cfg->psi_f_wb >= 0.0f) || !(cfg->k_margin >= 1.0f) || !(cfg->omega_min_rad_s >= 0.0f) ||
        !fw_is_finite(cfg->k1_v) || !fw_is_finite(cfg->k2_v_s)) {
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
    s->a_speed = cfg->speed_lpf_rad_s > 0.0f ? 1.0f - expf(-cfg->speed_lpf_rad_s * cfg->ts_s) : 1.0f;
    est_pll_init(&s->pll, cfg->pll_kp, cfg->pll_ki);
    est_smo_sta_reset(s);
    return 0;
}

void est_smo_sta_reset(est_smo_sta_t *s)
{
    s->i_hat_a.x = s->i_hat_a.y = 0.0f;
    s->w_v.x = s->w_v.y = 0.0f;
    s->z_v.x = s->z_v.y = 0.0f;
    if (s->cfg.k1_v > 0.0f && s->cfg.k2_v_s > 0.0f) {
        s->k1_now = s->cfg.k1_v;
        s->k2_now = s->cfg.k2_v_s;
    } else {
        est_smo_sta_gains(&s->cfg, 0.0f, &s->k1_now, &s->k2_now);
    }
    est_pll_reset(&s->pll, 0.0f, 0.0f);
    est_emf_dir_reset(&s->dir);
    s->out.theta_e_rad = 0.0f;
    s->out.omega_e_rad_s = 0.0f;
    s->out.e_alpha_v = 0.0f;
    s->out.e_beta_v = 0.0f;
}

/* k1 |x|^{1/2} sign(x) */
static float sqrt_term(float k1, float x)
{
    return k1 * sqrtf(fabsf(x)) * fw_signf(x);
}

const est_output_t *est_smo_sta_step(est_smo_sta_t *s, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v)
{
    const est_smo_sta_config_t *c = &s->cfg;
    fw_vec2_t err;
    float theta_raw;

    /* propagate the current model over the last period with the STA output held (ZOH) */
    s->i_hat_a.x = s->f * s->i_hat_a.x + s->g * (v_ab_prev_v.x - s->z_v.x);
    s->i_hat_a.y = s->f * s->i_hat_a.y + s->g * (v_ab_prev_v.y - s->z_v.y);
    err.x = s->i_hat_a.x - i_ab_a.x;
    err.y = s->i_hat_a.y - i_ab_a.y;

    /* super-twisting: z = k1 |e|^1/2 sign(e) + w, w += Ts k2 sign(e) */
    s->z_v.x = sqrt_term(s->k1_now, err.x) + s->w_v.x;
    s->z_v.y = sqrt_term(s->k1_now, err.y) + s->w_v.y;
    s->w_v.x += c->ts_s * s->k2_now * fw_signf(err.x);
    s->w_v.y += c->ts_s * s->k2_now * fw_signf(err.y);

    /* the STA output is the EMF (no filter, no lag): angle, direction and speed */
    theta_raw = atan2f(-s->z_v.x, s->z_v.y);
    s->out.theta_e_rad = est_emf_angle_step(&s->pll, &s->dir, theta_raw, c->dir_speed_rad_s,
                                            c->ts_s);
    s->out.omega_e_rad_s += s->a_speed * (s->pll.omega_rad_s - s->out.omega_e_rad_s);
    s->out.e_alpha_v = s->z_v.x;
    s->out.e_beta_v = s->z_v.y;

    /* gains for the next step: from the speed estimate, but not above twice the speed the
     * observed EMF supports (near zero speed a stray PLL speed must not raise the gains, which
     * would raise the chattering and so the stray speed: est_smo_sign.h) */
    if (c->k1_v > 0.0f && c->k2_v_s > 0.0f) {
        s->k1_now = c->k1_v;
        s->k2_now = c->k2_v_s;
    } else {
        float w = fabsf(s->out.omega_e_rad_s);
        if (c->psi_f_wb > 0.0f) {
            const float w_emf = 2.0f * sqrtf(s->z_v.x * s->z_v.x + s->z_v.y * s->z_v.y) /
                                c->psi_f_wb;
            w = w < w_emf ? w : w_emf;
        }
        est_smo_sta_gains(c, w, &s->k1_now, &s->k2_now);
    }
    return &s->out;
}
