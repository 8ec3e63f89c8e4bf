#include "harm_comp.h"

#include <math.h>

#define HARM_BIN5 (-5) /* the 5th in complex alpha-beta: negative sequence */
#define HARM_BIN7 7    /* the 7th: positive sequence */
#define HARM_MAX_CROSSINGS 2

void harm_comp_default_config(harm_comp_config_t *cfg, float rs_ohm, float ls_h, float ts_s)
{
    float w_interp, w_cross;
    cfg->rs_ohm = rs_ohm;
    cfg->ls_h = ls_h;
    cfg->ts_s = ts_s;
    cfg->m = 96;
    cfg->extractor = HARM_EXTRACT_GSDFT;
    cfg->dc_block = 1;
    cfg->omega_min_rad_s = 0.5f;
    cfg->k_comp = 1.0f;
    /* linear interpolation of the 7th within ~1 %: (7 w Ts)^2 / 8 < 0.01 */
    w_interp = ts_s > 0.0f ? 0.2828f / (7.0f * ts_s) : 0.0f;
    /* at most HARM_MAX_CROSSINGS grid angles per control period */
    w_cross = ts_s > 0.0f ? (float)HARM_MAX_CROSSINGS * FW_TWO_PI_F / ((float)cfg->m * ts_s) : 0.0f;
    cfg->omega_max_rad_s = w_interp < w_cross ? w_interp : w_cross;
}

static int init_extractor(harm_comp_t *h)
{
    const harm_comp_config_t *c = &h->cfg;
    if (c->extractor == HARM_EXTRACT_GSDFT) {
        est_gsdft_config_t g;
        est_gsdft_default_config(&g, c->m, HARM_BIN5);
        g.n_bins = 2;
        g.k[1] = HARM_BIN7;
        g.real_input = 0;
        g.dc_block = c->dc_block;
        return est_gsdft_init(&h->gsdft, &g);
    }
    if (c->extractor == HARM_EXTRACT_SDFT) {
        est_sdft_config_t s;
        est_sdft_default_config(&s, c->m, HARM_BIN5);
        s.n_bins = 2;
        s.k[1] = HARM_BIN7;
        s.real_input = 0;
        return est_sdft_init(&h->sdft, &s);
    }
    return -1;
}

int harm_comp_init(harm_comp_t *h, const harm_comp_config_t *cfg)
{
    if (cfg->m < 6 || cfg->m > EST_DFT_MAX_M || cfg->m % 6 != 0 || !(cfg->rs_ohm >= 0.0f) ||
        !(cfg->ls_h > 0.0f) || !(cfg->ts_s > 0.0f) || !(cfg->omega_min_rad_s > 0.0f) ||
        !(cfg->omega_max_rad_s > cfg->omega_min_rad_s) || !fw_is_finite(cfg->k_comp)) {
        return -1;
    }
    h->cfg = *cfg;
    if (init_extractor(h) != 0) {
        return -1;
    }
    h->dtheta_grid_rad = FW_TWO_PI_F / (float)cfg->m;
    est_dft_twiddles(h->tw, cfg->m);
    harm_comp_reset(h);
    return 0;
}

static void clear_output(harm_comp_output_t *o)
{
    o->valid = 0;
    o->i5_a = o->theta5_rad = o->i7_a = o->theta7_rad = 0.0f;
    o->i_dq5_a.x = o->i_dq5_a.y = o->i_dq7_a.x = o->i_dq7_a.y = 0.0f;
    o->u5_dq5_v.x = o->u5_dq5_v.y = o->u7_dq7_v.x = o->u7_dq7_v.y = 0.0f;
}

/* Stop sampling; the next in-range step starts an empty window. */
static void stop_sampling(harm_comp_t *h)
{
    h->have_prev = 0;
    clear_output(&h->out);
}

void harm_comp_reset(harm_comp_t *h)
{
    stop_sampling(h);
    h->out.n_samples = 0;
    h->grid_next = 0;
}

static void start_sampling(harm_comp_t *h, fw_vec2_t i_ab_a, float theta_rad)
{
    int g = (int)ceilf(theta_rad / h->dtheta_grid_rad);
    h->grid_next = g >= h->cfg.m ? g - h->cfg.m : g;
    h->theta_prev_rad = theta_rad;
    h->i_prev_a = i_ab_a;
    h->have_prev = 1;
    if (h->cfg.extractor == HARM_EXTRACT_GSDFT) {
        est_gsdft_reset(&h->gsdft);
    } else {
        est_sdft_reset(&h->sdft);
    }
}

/* The phasors of the newest grid sample j rotated into the harmonic frames (eq. 32-33). */
static void to_harmonic_frames(harm_comp_t *h, const est_cplx_t *p, int valid, int j)
{
    int m = h->cfg.m;
    est_cplx_t i5, i7;
    /* e^{+j5 theta_j} = conj(tw[5j mod m]); e^{-j7 theta_j} = tw[7j mod m] */
    i5 = est_cmul_conj(h->tw[(5 * j) % m], p[0]);
    i7 = est_cmul(h->tw[(7 * j) % m], p[1]);
    h->out.valid = valid;
    h->out.i_dq5_a.x = i5.re;
    h->out.i_dq5_a.y = i5.im;
    h->out.i_dq7_a.x = i7.re;
    h->out.i_dq7_a.y = i7.im;
    h->out.i5_a = est_cabs(i5);
    h->out.theta5_rad = est_carg(i5);
    h->out.i7_a = est_cabs(i7);
    h->out.theta7_rad = est_carg(i7);
}

/* One angle-synchronous sample at grid index j. */
static void take_sample(harm_comp_t *h, fw_vec2_t x, int j)
{
    const est_cplx_t *p;
    int valid;
    if (h->cfg.extractor == HARM_EXTRACT_GSDFT) {
        p = est_gsdft_step(&h->gsdft, x.x, x.y);
        valid = est_gsdft_valid(&h->gsdft);
    } else {
        p = est_sdft_step(&h->sdft, x.x, x.y);
        valid = est_sdft_valid(&h->sdft);
    }
    ++h->out.n_samples;
    to_harmonic_frames(h, p, valid, j);
}

/* Grid angles crossed in (theta_prev, theta]: interpolate and sample each. -1 if too many. */
static int sample_crossings(harm_comp_t *h, fw_vec2_t i_ab_a, float dtheta_rad)
{
    int n;
    if (!(dtheta_rad > 0.0f)) {
        return 0;
    }
    for (n = 0; n <= HARM_MAX_CROSSINGS; ++n) {
        float g = (float)h->grid_next * h->dtheta_grid_rad;
        float ahead = fw_wrap_2pi(g - h->theta_prev_rad);
        float f;
        fw_vec2_t x;
        if (ahead > dtheta_rad) {
            return 0;
        }
        if (n == HARM_MAX_CROSSINGS) {
            return -1;
        }
        f = ahead / dtheta_rad;
        x.x = h->i_prev_a.x + f * (i_ab_a.x - h->i_prev_a.x);
        x.y = h->i_prev_a.y + f * (i_ab_a.y - h->i_prev_a.y);
        take_sample(h, x, h->grid_next);
        if (++h->grid_next >= h->cfg.m) {
            h->grid_next = 0;
        }
    }
    return -1; /* not reached */
}

/* eq. 36-37 with the present speed: u_h = -k (R + j h' w L) i_h, h' = -5 (5th), +7 (7th). */
static void compensation(harm_comp_t *h, float omega_e_rad_s)
{
    harm_comp_output_t *o = &h->out;
    float r = h->cfg.rs_ohm, k = h->cfg.k_comp;
    float x5 = 5.0f * omega_e_rad_s * h->cfg.ls_h, x7 = 7.0f * omega_e_rad_s * h->cfg.ls_h;
    if (!o->valid) {
        o->u5_dq5_v.x = o->u5_dq5_v.y = o->u7_dq7_v.x = o->u7_dq7_v.y = 0.0f;
        return;
    }
    o->u5_dq5_v.x = -k * (r * o->i_dq5_a.x + x5 * o->i_dq5_a.y);
    o->u5_dq5_v.y = -k * (r * o->i_dq5_a.y - x5 * o->i_dq5_a.x);
    o->u7_dq7_v.x = -k * (r * o->i_dq7_a.x - x7 * o->i_dq7_a.y);
    o->u7_dq7_v.y = -k * (r * o->i_dq7_a.y + x7 * o->i_dq7_a.x);
}

const harm_comp_output_t *harm_comp_step(harm_comp_t *h, fw_vec2_t i_ab_a, float theta_e_rad,
                                         float omega_e_rad_s)
{
    float theta = fw_wrap_2pi(theta_e_rad);
    if (!(omega_e_rad_s >= h->cfg.omega_min_rad_s) || !(omega_e_rad_s <= h->cfg.omega_max_rad_s)) {
        stop_sampling(h);
        return &h->out;
    }
    if (!h->have_prev) {
        start_sampling(h, i_ab_a, theta);
    } else {
        float dtheta = fw_wrap_pi(theta - h->theta_prev_rad);
        if (dtheta < -h->dtheta_grid_rad || sample_crossings(h, i_ab_a, dtheta) != 0) {
            stop_sampling(h); /* reversal or too fast for the grid: restart next step */
            return &h->out;
        }
        if (dtheta > 0.0f) {
            h->theta_prev_rad = theta;
            h->i_prev_a = i_ab_a;
        }
    }
    compensation(h, omega_e_rad_s);
    return &h->out;
}

fw_vec2_t harm_comp_voltage_dq(const harm_comp_t *h, float theta_e_rad)
{
    /* u_dq = u5_dq5 e^{-j6 theta} + u7_dq7 e^{+j6 theta} */
    float s6 = sinf(6.0f * theta_e_rad), c6 = cosf(6.0f * theta_e_rad);
    /* fw_park(x, sin a, cos a) = x e^{-ja}: a = 6 theta for the 5th, a = -6 theta for the 7th */
    fw_vec2_t a = fw_park(h->out.u5_dq5_v, s6, c6);
    fw_vec2_t b = fw_park(h->out.u7_dq7_v, -s6, c6);
    fw_vec2_t u;
    u.x = a.x + b.x;
    u.y = a.y + b.y;
    return u;
}
