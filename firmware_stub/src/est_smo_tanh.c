#include "est_smo_tanh.h"

#include <math.h>

/* tanh is +-1 to float32 precision beyond |m x| = 9; the clamp only bounds the argument. */
#define TANH_ARG_LIMIT 40.0f
/* 3 sqrt(3) / 2 of eq. 17 */
#define EQ17_FACTOR 2.59807621135332f

/* ZOH coefficients of d i/dt = (-R i + u)/Ls over ts: i+ = f i + g u. */
static void zoh_rl(float rs_ohm, float ls_h, float ts_s, float *f, float *g)
{
    if (rs_ohm > 0.0f) {
        *f = expf(-rs_ohm * ts_s / ls_h);
        *g = (1.0f - *f) / rs_ohm;
    } else {
        *f = 1.0f;
        *g = ts_s / ls_h;
    }
}

float est_smo_tanh_boundary_layer_a(float m_per_a)
{
    return atanhf(0.99f) / m_per_a;
}

float est_smo_tanh_min_f(float m_per_a, float xi_a)
{
    return tanhf(fw_clampf(m_per_a * fabsf(xi_a), 0.0f, TANH_ARG_LIMIT)); /* eq. 16 */
}

float est_smo_tanh_gain_rule_v(float ce, float psi_f_wb, int pole_pairs, float omega_m_max_rad_s,
                               float min_f)
{
    if (!(min_f > 0.0f)) {
        return -1.0f;
    }
    /* eq. 17 */
    return fabsf(EQ17_FACTOR * ce * psi_f_wb * (float)pole_pairs * omega_m_max_rad_s / min_f);
}

float est_smo_tanh_stability_bound_v(float e_max_v, float min_f)
{
    return fabsf(e_max_v) / min_f; /* eq. 14 with |F| = min|F| */
}

float est_smo_tanh_deadbeat_gain_v_per_a(float rs_ohm, float ls_h, float ts_s)
{
    float f, g;
    if (!(ls_h > 0.0f) || !(ts_s > 0.0f) || !(rs_ohm >= 0.0f)) {
        return -1.0f;
    }
    zoh_rl(rs_ohm, ls_h, ts_s, &f, &g);
    return f / g;
}

float est_smo_tanh_xi_deadbeat_a(float ce, float psi_f_wb, int pole_pairs,
                                 float omega_m_max_rad_s, float m_per_a, float rs_ohm, float ls_h,
                                 float ts_s)
{
    /* k m <= F/G with k = c / tanh(m xi), c = 3 sqrt(3) Ce psi_f p w / 2  <=>  tanh(m xi) >= c m G/F */
    float km_max = est_smo_tanh_deadbeat_gain_v_per_a(rs_ohm, ls_h, ts_s);
    float c, need;
    if (!(km_max > 0.0f) || !(m_per_a > 0.0f)) {
        return -1.0f;
    }
    c = fabsf(EQ17_FACTOR * ce * psi_f_wb * (float)pole_pairs * omega_m_max_rad_s);
    need = c * m_per_a / km_max;
    if (!(need < 1.0f)) {
        return -1.0f;
    }
    return atanhf(need) / m_per_a;
}

void est_smo_tanh_default_config(est_smo_tanh_config_t *cfg, float rs_ohm, float ls_h,
                                 float psi_f_wb, float ts_s)
{
    cfg->rs_ohm = rs_ohm;
    cfg->ls_h = ls_h;
    cfg->psi_f_wb = psi_f_wb;
    cfg->ts_s = ts_s;
    cfg->k_v = 0.0f;      /* must be set: eq. 17 (helpers above) */
    cfg->m_per_a = 0.01f; /* Gong section V-A: m = 0.01, BL = 265 A */
    est_pll_gains(150.0f, &cfg->pll_kp, &cfg->pll_ki);
    cfg->speed_lpf_rad_s = 0.0f;
    cfg->dir_speed_rad_s = EST_EMF_DIR_SPEED_RAD_S;
}

static int config_finite(const est_smo_tanh_config_t *c)
{
    return fw_is_finite(c->rs_ohm) && fw_is_finite(c->ls_h) && fw_is_finite(c->psi_f_wb) &&
           fw_is_finite(c->ts_s) && fw_is_finite(c->k_v) && fw_is_finite(c->m_per_a) &&
           fw_is_finite(c->pll_kp) && fw_is_finite(c->pll_ki) && fw_is_finite(c->speed_lpf_rad_s) &&
           fw_is_finite(c->dir_speed_rad_s);
}

int est_smo_tanh_init(est_smo_tanh_t *s, const est_smo_tanh_config_t *cfg)
{
    if (!config_finite(cfg) || !(cfg->ls_h > 0.0f) || !(cfg->ts_s > 0.0f) ||
        !(cfg->rs_ohm >= 0.0f) || !(cfg->k_v > 0.0f) || !(cfg->m_per_a > 0.0f)) {
        return -1;
    }
    s->cfg = *cfg;
    zoh_rl(cfg->rs_ohm, cfg->ls_h, cfg->ts_s, &s->f, &s->g);
    s->a_speed = cfg->speed_lpf_rad_s > 0.0f ? 1.0f - expf(-cfg->speed_lpf_rad_s * cfg->ts_s) : 1.0f;
    est_pll_init(&s->pll, cfg->pll_kp, cfg->pll_ki);
    est_smo_tanh_reset(s);
    return 0;
}

void est_smo_tanh_reset(est_smo_tanh_t *s)
{
    s->i_hat_a.x = s->i_hat_a.y = 0.0f;
    s->e_hat_v.x = s->e_hat_v.y = 0.0f;
    est_pll_reset(&s->pll, 0.0f, 0.0f);
    est_emf_dir_reset(&s->dir);
    s->out.theta_e_rad = 0.0f;
    s->out.omega_e_rad_s = 0.0f;
    s->out.e_alpha_v = 0.0f;
    s->out.e_beta_v = 0.0f;
}

/* F(x) = tanh(m x) (eq. 8) */
static float switching_fn(float x_a, float m_per_a)
{
    return tanhf(fw_clampf(m_per_a * x_a, -TANH_ARG_LIMIT, TANH_ARG_LIMIT));
}

const est_output_t *est_smo_tanh_step(est_smo_tanh_t *s, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v)
{
    const est_smo_tanh_config_t *c = &s->cfg;
    float theta, omega;

    /* propagate the current model over the last period (eq. 3), ZOH of u - k F */
    s->i_hat_a.x = s->f * s->i_hat_a.x + s->g * (v_ab_prev_v.x - s->e_hat_v.x);
    s->i_hat_a.y = s->f * s->i_hat_a.y + s->g * (v_ab_prev_v.y - s->e_hat_v.y);

    /* e^ = k F(i^ - i), no low-pass filter (eq. 6 with eq. 8) */
    s->e_hat_v.x = c->k_v * switching_fn(s->i_hat_a.x - i_ab_a.x, c->m_per_a);
    s->e_hat_v.y = c->k_v * switching_fn(s->i_hat_a.y - i_ab_a.y, c->m_per_a);

    /* position (eq. 18), full quadrant, +pi for w < 0; speed d theta/dt (eq. 19) as the
     * est_common PLL */
    theta = est_emf_angle_step(&s->pll, &s->dir, atan2f(-s->e_hat_v.x, s->e_hat_v.y),
                               c->dir_speed_rad_s, c->ts_s);
    omega = s->pll.omega_rad_s;
    s->out.omega_e_rad_s += s->a_speed * (omega - s->out.omega_e_rad_s);
    s->out.theta_e_rad = theta;
    s->out.e_alpha_v = s->e_hat_v.x;
    s->out.e_beta_v = s->e_hat_v.y;
    return &s->out;
}
