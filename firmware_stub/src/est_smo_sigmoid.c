#include "est_smo_sigmoid.h"

#include <math.h>

/* tanh of an argument beyond this is 1 to float32 precision; the clamp only keeps tanhf on the
 * cheap path of some libms. */
#define SIGMOID_ARG_LIMIT 40.0f

float est_smo_sigmoid_fn(float x_a, float a_per_a)
{
    /* 2/(1 + exp(-a x)) - 1 = (1 - exp(-a x))/(1 + exp(-a x)) = tanh(a x / 2): the tanh form
     * neither overflows for large -a x nor loses the small values near x = 0 to cancellation. */
    float arg = fw_clampf(0.5f * a_per_a * x_a, -SIGMOID_ARG_LIMIT, SIGMOID_ARG_LIMIT);
    return tanhf(arg);
}

float est_smo_sigmoid_min_gain_v(float psi_f_wb, float omega_e_max_rad_s)
{
    /* eq. 18: K > max|2E|, |E| = w_e psi_f (eq. 2) */
    return 2.0f * fabsf(psi_f_wb * omega_e_max_rad_s);
}

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

float est_smo_sigmoid_max_slope_per_a(float rs_ohm, float ls_h, float ts_s, float k_v)
{
    float f, g;
    if (!(ls_h > 0.0f) || !(ts_s > 0.0f) || !(k_v > 0.0f) || !(rs_ohm >= 0.0f)) {
        return -1.0f;
    }
    zoh_rl(rs_ohm, ls_h, ts_s, &f, &g);
    return 2.0f * f / (g * k_v);
}

void est_smo_sigmoid_default_config(est_smo_sigmoid_config_t *cfg, float rs_ohm, float ls_h,
                                    float psi_f_wb, float ts_s)
{
    cfg->rs_ohm = rs_ohm;
    cfg->ls_h = ls_h;
    cfg->psi_f_wb = psi_f_wb;
    cfg->ts_s = ts_s;
    cfg->k_v = 0.0f;     /* must be set: eq. 18 at the highest speed, with margin */
    cfg->a_per_a = 0.0f; /* derived: the deadbeat slope for k_v */
    cfg->wc_rad_s = 2000.0f;
    cfg->lag_comp = EST_SMO_SIGMOID_LAG_EQ15;
    est_pll_gains(150.0f, &cfg->pll_kp, &cfg->pll_ki);
    cfg->speed_lpf_rad_s = 0.0f;
    cfg->dir_speed_rad_s = EST_EMF_DIR_SPEED_RAD_S;
}

static int config_finite(const est_smo_sigmoid_config_t *c)
{
    return fw_is_finite(c->rs_ohm) && fw_is_finite(c->ls_h) && fw_is_finite(c->psi_f_wb) &&
           fw_is_finite(c->ts_s) && fw_is_finite(c->k_v) && fw_is_finite(c->a_per_a) &&
           fw_is_finite(c->wc_rad_s) && fw_is_finite(c->pll_kp) && fw_is_finite(c->pll_ki) &&
           fw_is_finite(c->speed_lpf_rad_s) &&
           fw_is_finite(c->dir_speed_rad_s);
}

int est_smo_sigmoid_init(est_smo_sigmoid_t *s, const est_smo_sigmoid_config_t *cfg)
{
    if (!config_finite(cfg) || !(cfg->ls_h > 0.0f) || !(cfg->ts_s > 0.0f) ||
        !(cfg->wc_rad_s > 0.0f) || !(cfg->rs_ohm >= 0.0f) || !(cfg->k_v > 0.0f) ||
        cfg->lag_comp < EST_SMO_SIGMOID_LAG_NONE || cfg->lag_comp > EST_SMO_SIGMOID_LAG_EFFECTIVE) {
        return -1;
    }
    s->cfg = *cfg;
    zoh_rl(cfg->rs_ohm, cfg->ls_h, cfg->ts_s, &s->f, &s->g);
    s->a_used_per_a = cfg->a_per_a > 0.0f
                          ? cfg->a_per_a
                          : est_smo_sigmoid_max_slope_per_a(cfg->rs_ohm, cfg->ls_h, cfg->ts_s,
                                                            cfg->k_v);
    s->a_lpf = 1.0f - expf(-cfg->wc_rad_s * cfg->ts_s);
    s->a_speed = cfg->speed_lpf_rad_s > 0.0f ? 1.0f - expf(-cfg->speed_lpf_rad_s * cfg->ts_s) : 1.0f;
    est_pll_init(&s->pll, cfg->pll_kp, cfg->pll_ki);
    est_smo_sigmoid_reset(s);
    return 0;
}

void est_smo_sigmoid_reset(est_smo_sigmoid_t *s)
{
    s->i_hat_a.x = s->i_hat_a.y = 0.0f;
    s->z_v.x = s->z_v.y = 0.0f;
    s->h_v.x = s->h_v.y = 0.0f;
    est_pll_reset(&s->pll, 0.0f, 0.0f);
    est_emf_dir_reset(&s->dir);
    s->out.theta_e_rad = 0.0f;
    s->out.omega_e_rad_s = 0.0f;
    s->out.e_alpha_v = 0.0f;
    s->out.e_beta_v = 0.0f;
}

/* Phase lag of H behind E to add back, for the speed estimate w_e. */
static float lag_rad(const est_smo_sigmoid_config_t *c, float omega_e_rad_s)
{
    switch (c->lag_comp) {
    case EST_SMO_SIGMOID_LAG_EQ15:
        return atanf(omega_e_rad_s / c->wc_rad_s);        /* eq. 15 */
    case EST_SMO_SIGMOID_LAG_EFFECTIVE:
        return atanf(2.0f * omega_e_rad_s / c->wc_rad_s); /* H = wc/(s + wc/2) E, from eq. 13 */
    default:
        return 0.0f;
    }
}

const est_output_t *est_smo_sigmoid_step(est_smo_sigmoid_t *s, fw_vec2_t i_ab_a,
                                         fw_vec2_t v_ab_prev_v)
{
    const est_smo_sigmoid_config_t *c = &s->cfg;
    float theta, omega;

    /* propagate the current model over the last period (eq. 11), ZOH of u - z + H/2 */
    s->i_hat_a.x = s->f * s->i_hat_a.x + s->g * (v_ab_prev_v.x - s->z_v.x + 0.5f * s->h_v.x);
    s->i_hat_a.y = s->f * s->i_hat_a.y + s->g * (v_ab_prev_v.y - s->z_v.y + 0.5f * s->h_v.y);

    /* switching term on the new error: K sigmoid(i^ - i) (eq. 11) */
    s->z_v.x = c->k_v * est_smo_sigmoid_fn(s->i_hat_a.x - i_ab_a.x, s->a_used_per_a);
    s->z_v.y = c->k_v * est_smo_sigmoid_fn(s->i_hat_a.y - i_ab_a.y, s->a_used_per_a);

    /* H = wc/(s + wc){K sigmoid} (eq. 11), ZOH */
    s->h_v.x += s->a_lpf * (s->z_v.x - s->h_v.x);
    s->h_v.y += s->a_lpf * (s->z_v.y - s->h_v.y);

    /* position from H (eq. 15), full quadrant, lag compensation with the last speed estimate */
    theta = atan2f(-s->h_v.x, s->h_v.y) + lag_rad(c, s->out.omega_e_rad_s);

    /* direction of rotation (+pi for w < 0) and speed: est_common */
    theta = est_emf_angle_step(&s->pll, &s->dir, theta, c->dir_speed_rad_s, c->ts_s);
    omega = s->pll.omega_rad_s;
    s->out.omega_e_rad_s += s->a_speed * (omega - s->out.omega_e_rad_s);
    s->out.theta_e_rad = theta;
    s->out.e_alpha_v = 0.5f * s->h_v.x; /* eq. 14 */
    s->out.e_beta_v = 0.5f * s->h_v.y;
    return &s->out;
}
