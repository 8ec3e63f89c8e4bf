#include "est_hfi.h"

#include <math.h>

#define HFI_INV_SQRT2_F 0.707106781186548f

void est_hfi_expected_amplitudes(const est_hfi_config_t *cfg, float *i0_a, float *i1_a)
{
    float l_sum = 0.5f * (cfg->ld_h + cfg->lq_h);
    float l_dif = 0.5f * (cfg->lq_h - cfg->ld_h);
    float w_i = FW_TWO_PI_F * cfg->f_inj_hz;
    float den = w_i * (l_sum * l_sum - l_dif * l_dif);
    *i0_a = den > 0.0f ? cfg->u_inj_v * l_sum / den : 0.0f;
    *i1_a = den > 0.0f ? cfg->u_inj_v * l_dif / den : 0.0f;
}

void est_hfi_set_bandwidth(est_hfi_config_t *cfg, float wn_rad_s)
{
    float slope; /* de / d(dtheta) at dtheta = 0 */
    float i0, i1;
    est_hfi_expected_amplitudes(cfg, &i0, &i1);
    if (cfg->normalise) {
        float s = i0 * i0 + i1 * i1;
        slope = s > 0.0f ? 2.0f * (2.0f * i0 * i1 / s) : 1.0f;
    } else {
        slope = 8.0f * i0 * i1;
    }
    if (!(slope > 0.0f)) {
        slope = 1.0f;
    }
    cfg->kp_rad_s = 2.0f * wn_rad_s / slope;
    cfg->ki_rad_s2 = wn_rad_s * wn_rad_s / slope;
}

void est_hfi_default_config(est_hfi_config_t *cfg, float rs_ohm, float ld_h, float lq_h, float ts_s)
{
    cfg->ts_s = ts_s;
    cfg->f_inj_hz = 1250.0f;
    cfg->u_inj_v = 6.0f;
    cfg->rs_ohm = rs_ohm;
    cfg->ld_h = ld_h;
    cfg->lq_h = lq_h;
    cfg->normalise = 1;
    cfg->speed_lpf_rad_s = 100.0f;
    cfg->theta0_rad = 0.0f;
    cfg->ipd_on_reset = 1;
    cfg->lock_tol_rad = 0.01f;
    cfg->lock_time_s = 0.01f;
    cfg->ipd_timeout_s = 0.5f;
    cfg->pol_time_s = 0.02f;
    cfg->pol_margin = 0.001f;
    cfg->pol_z = EST_HFI_POL_Z_DEFAULT;
    cfg->pol_bias_a = 0.0f;
    est_hfi_set_bandwidth(cfg, 150.0f);
}

static int samples_per_hf_period(const est_hfi_config_t *cfg)
{
    float m_f = 1.0f / (cfg->f_inj_hz * cfg->ts_s);
    int m = (int)(m_f + 0.5f);
    if (!fw_is_finite(m_f) || m < 4 || m > EST_DFT_MAX_M || (m % 2) != 0 ||
        fabsf(m_f - (float)m) > 1e-3f) {
        return -1;
    }
    return m;
}

static int init_sdft(est_sdft_t *sd, int m, int k, int real_input)
{
    est_sdft_config_t c;
    est_sdft_default_config(&c, m, k);
    c.real_input = real_input;
    return est_sdft_init(sd, &c);
}

int est_hfi_init(est_hfi_t *s, const est_hfi_config_t *cfg)
{
    int m;
    if (!(cfg->ts_s > 0.0f) || !(cfg->f_inj_hz > 0.0f) || !(cfg->u_inj_v > 0.0f) ||
        !(cfg->ld_h > 0.0f) || !(cfg->lq_h > cfg->ld_h) || !(cfg->rs_ohm >= 0.0f) ||
        !fw_is_finite(cfg->kp_rad_s) || !fw_is_finite(cfg->ki_rad_s2) || !(cfg->pol_time_s > 0.0f)) {
        return -1;
    }
    m = samples_per_hf_period(cfg);
    if (m < 0) {
        return -1;
    }
    s->cfg = *cfg;
    s->m = m;
    if (init_sdft(&s->sd_d, m, 1, 1) != 0 || init_sdft(&s->sd_q, m, 1, 1) != 0 ||
        init_sdft(&s->sd_mean, m, 0, 0) != 0) {
        return -1;
    }
    s->a_speed = cfg->speed_lpf_rad_s > 0.0f ? 1.0f - expf(-cfg->speed_lpf_rad_s * cfg->ts_s) : 1.0f;
    s->lock_n = (long)(cfg->lock_time_s / cfg->ts_s + 0.5f);
    s->timeout_n = (long)(cfg->ipd_timeout_s / cfg->ts_s + 0.5f);
    s->pol_periods = 2 * (int)(0.5f * cfg->pol_time_s * cfg->f_inj_hz + 0.5f);
    if (s->pol_periods < 4) {
        s->pol_periods = 4;
    }
    est_hfi_reset(s);
    return 0;
}

static void clear_polarity_test(est_hfi_t *s)
{
    s->pol_period = 0;
    s->x1.re = s->x1.im = s->x2.re = s->x2.im = 0.0f;
    s->r_mean = s->r_m2 = 0.0f;
    s->pol_look = s->pol_periods;
    s->amp_sum_a[0] = s->amp_sum_a[1] = 0.0f;
    s->amp_cnt[0] = s->amp_cnt[1] = 0;
}

static void enter_ipd_state(est_hfi_t *s, int state)
{
    s->out.ipd_state = state;
    s->t_n = 0;
    s->lock_count = 0;
    s->out.i_d_req_a = 0.0f;
    clear_polarity_test(s);
}

void est_hfi_set_angle(est_hfi_t *s, float theta_rad, float omega_rad_s)
{
    s->theta_rad = fw_wrap_2pi(theta_rad);
    s->integ_rad_s = omega_rad_s;
    s->out.est.omega_e_rad_s = omega_rad_s;
    s->out.est.theta_e_rad = s->theta_rad;
    enter_ipd_state(s, EST_HFI_TRACKING);
}

void est_hfi_start_ipd(est_hfi_t *s)
{
    s->out.polarity = EST_HFI_POL_UNKNOWN;
    s->out.pol_metric = 0.0f;
    s->out.pol_se = 0.0f;
    s->out.pol_time_s = 0.0f;
    enter_ipd_state(s, EST_HFI_IPD_CONVERGE);
}

void est_hfi_reset(est_hfi_t *s)
{
    est_sdft_reset(&s->sd_d);
    est_sdft_reset(&s->sd_q);
    est_sdft_reset(&s->sd_mean);
    s->inj_idx = 0;
    s->out.v_inj_ab_v.x = s->out.v_inj_ab_v.y = 0.0f;
    s->out.i_fund_ab_a.x = s->out.i_fund_ab_a.y = 0.0f;
    s->out.amp_d_a = s->out.amp_q_a = s->out.err = s->out.dtheta_est_rad = 0.0f;
    s->out.est.e_alpha_v = s->out.est.e_beta_v = 0.0f;
    s->out.polarity = EST_HFI_POL_UNKNOWN;
    s->out.pol_metric = 0.0f;
    s->out.pol_se = 0.0f;
    s->out.pol_time_s = 0.0f;
    est_hfi_set_angle(s, s->cfg.theta0_rad, 0.0f);
    if (s->cfg.ipd_on_reset) {
        est_hfi_start_ipd(s);
    }
}

/* Amplitudes and the tracking error (eq. 15) from the bin-1 phasors of the d'' and q'' axes. */
static void amplitudes_and_error(est_hfi_t *s, est_cplx_t p_d, est_cplx_t p_q, float *s2, float *c2)
{
    float a2d = est_cabs2(p_d), a2q = est_cabs2(p_q);
    float sum = a2d + a2q;
    /* projection on theta^ minus on theta^ + pi/2: -2 Re(P_d conj P_q) = 4 I0 I1 cos(2 dtheta) (13) */
    float cross = -2.0f * (p_d.re * p_q.re + p_d.im * p_q.im);
    s->out.amp_d_a = sqrtf(a2d);
    s->out.amp_q_a = sqrtf(a2q);
    if (s->cfg.normalise) {
        float inv = sum > 1e-12f ? 1.0f / sum : 0.0f;
        *s2 = (a2d - a2q) * inv;
        *c2 = cross * inv;
    } else {
        *s2 = a2d - a2q;
        *c2 = cross;
    }
}

/* PI on e; the output is the speed and integrates to theta^ for the next sample. */
static void track(est_hfi_t *s, float e)
{
    const est_hfi_config_t *c = &s->cfg;
    float w = s->integ_rad_s + c->kp_rad_s * e;
    s->integ_rad_s += c->ki_rad_s2 * c->ts_s * e;
    s->theta_rad = fw_wrap_2pi(s->theta_rad + w * c->ts_s);
    s->out.est.omega_e_rad_s += s->a_speed * (s->integ_rad_s - s->out.est.omega_e_rad_s);
}

/* theta^ += pi. The projections change sign: negate the windows instead of refilling them; the
 * injection phase moves by half a period so that the injected alpha-beta voltage is continuous. */
static void flip_polarity(est_hfi_t *s)
{
    s->theta_rad = fw_wrap_2pi(s->theta_rad + FW_PI_F);
    est_sdft_negate(&s->sd_d);
    est_sdft_negate(&s->sd_q);
    s->inj_idx += s->m / 2;
    if (s->inj_idx >= s->m) {
        s->inj_idx -= s->m;
    }
}

/* The polarity decision at a look of the test. final: no later look; undecided -> FAILED.
 * Returns 1 if the test ended. */
static int decide_polarity(est_hfi_t *s, int final)
{
    float r, se = 0.0f;
    int decided;
    if (s->cfg.pol_bias_a > 0.0f) {
        float ap = s->amp_cnt[0] > 0 ? s->amp_sum_a[0] / (float)s->amp_cnt[0] : 0.0f;
        float an = s->amp_cnt[1] > 0 ? s->amp_sum_a[1] / (float)s->amp_cnt[1] : 0.0f;
        r = (ap + an) > 0.0f ? (ap - an) / (ap + an) : 0.0f;
    } else {
        float n = (float)s->pol_period;
        r = s->r_mean;
        se = n > 1.0f ? sqrtf(s->r_m2 / ((n - 1.0f) * n)) : 0.0f;   /* s / sqrt(n) */
    }
    s->out.pol_metric = r;
    s->out.pol_se = se;
    s->out.pol_time_s = (float)(s->pol_period * s->m) * s->cfg.ts_s;
    decided = fabsf(r) > s->cfg.pol_margin &&
              (s->cfg.pol_bias_a > 0.0f || !(s->cfg.pol_z > 0.0f) || fabsf(r) > s->cfg.pol_z * se);
    if (decided && r > 0.0f) {
        s->out.polarity = EST_HFI_POL_KEPT;
        enter_ipd_state(s, EST_HFI_TRACKING);
    } else if (decided) {
        flip_polarity(s);
        s->out.polarity = EST_HFI_POL_FLIPPED;
        enter_ipd_state(s, EST_HFI_TRACKING);
    } else if (final || fabsf(r) + fmaxf(s->cfg.pol_z, 0.0f) * se < s->cfg.pol_margin) {
        /* no later look, or no decision possible: the whole confidence interval inside the
         * margin (no saturation signal to find; more periods only shrink se) */
        enter_ipd_state(s, EST_HFI_IPD_FAILED);
    } else {
        return 0;
    }
    return 1;
}

/* Polarity test, one sample. s_ac: AC current projected on theta^; amp_theta: HF amplitude along
 * theta^; period_end: this sample closes an HF period. The pure method's per-period ratio
 *   r_i = (max - |min|) / (max + |min|) of x = A cos(phi) + B cos(2 phi + b):  B cos(b) / A
 *       = Re(X2 conj(X1)^2) / |X1|^3   (X1, X2: the period's DFT bins 1 and 2 of x)
 * to first order in B / A: Hou's amplitude towards theta^ against towards theta^ + pi, read by a
 * DFT of the period's M samples ("which also can be realized by SDFT", section 3) instead of
 * two peak samples: all M samples average the noise, and no sample has to fall on a peak. */
static void polarity_sample(est_hfi_t *s, float s_ac, float amp_theta, int period_end)
{
    int half = s->pol_periods / 2;
    int second = s->pol_period >= half;
    const est_cplx_t *tw = s->sd_d.tw; /* tw[i] = e^{-j 2 pi i / m} */
    int k1 = s->inj_idx, k2 = (2 * s->inj_idx) % s->m;
    s->x1.re += s_ac * tw[k1].re;
    s->x1.im += s_ac * tw[k1].im;
    s->x2.re += s_ac * tw[k2].re;
    s->x2.im += s_ac * tw[k2].im;
    s->out.i_d_req_a = s->cfg.pol_bias_a > 0.0f ? (second ? -s->cfg.pol_bias_a : s->cfg.pol_bias_a)
                                                 : 0.0f;
    if (!period_end) {
        return;
    }
    {   /* this period's ratio into the running mean and spread (Welford) */
        const est_cplx_t a = s->x1, b = s->x2;
        float m1 = est_cabs2(a);
        /* Re(b conj(a)^2) = b.re (a.re^2 - a.im^2) + 2 b.im a.re a.im */
        float num = b.re * (a.re * a.re - a.im * a.im) + 2.0f * b.im * a.re * a.im;
        float ri = m1 > 0.0f ? num / (m1 * sqrtf(m1)) : 0.0f;
        float d = ri - s->r_mean;
        s->r_mean += d / (float)(s->pol_period + 1);
        s->r_m2 += d * (ri - s->r_mean);
    }
    s->x1.re = s->x1.im = s->x2.re = s->x2.im = 0.0f;
    if ((s->pol_period % half) >= half / 2) { /* settled half of each half-window (bias method) */
        s->amp_sum_a[second] += amp_theta;
        s->amp_cnt[second] += 1;
    }
    ++s->pol_period;
    if (s->cfg.pol_bias_a > 0.0f) {
        if (s->pol_period >= s->pol_periods) {
            (void)decide_polarity(s, 1);
        }
    } else if (s->pol_period >= s->pol_look) {
        /* sequential test: looks at pol_time_s x 1, 2, 4, ... while within ipd_timeout_s */
        long next_n = 2L * (long)s->pol_look * (long)s->m;
        if (decide_polarity(s, next_n > s->timeout_n) == 0) {
            s->pol_look *= 2;
        }
    }
}

/* IPD state machine, one sample. Returns 1 if theta^ was flipped by pi. */
static int ipd_step(est_hfi_t *s, fw_vec2_t i_ab_a, float sin_t, float cos_t, est_cplx_t p_d,
                     est_cplx_t p_q, float s2, float c2, int period_end)
{
    const est_cplx_t *mean = est_sdft_step(&s->sd_mean, i_ab_a.x, i_ab_a.y);
    int st = s->out.ipd_state;
    ++s->t_n;
    if (st == EST_HFI_IPD_CONVERGE) {
        s->out.dtheta_est_rad = 0.5f * atan2f(s2, c2);
        s->lock_count = fabsf(s->out.dtheta_est_rad) < s->cfg.lock_tol_rad ? s->lock_count + 1 : 0;
        if (s->lock_count >= s->lock_n && period_end) {
            enter_ipd_state(s, EST_HFI_IPD_POLARITY);
        } else if (s->t_n >= s->timeout_n) {
            enter_ipd_state(s, EST_HFI_IPD_FAILED);
        }
    } else if (st == EST_HFI_IPD_POLARITY) {
        float ac_x = i_ab_a.x - mean[0].re, ac_y = i_ab_a.y - mean[0].im;
        float s_ac = ac_x * cos_t + ac_y * sin_t;
        est_cplx_t along; /* HF phasor along theta^ = (P_d - P_q) / sqrt(2) */
        along.re = (p_d.re - p_q.re) * HFI_INV_SQRT2_F;
        along.im = (p_d.im - p_q.im) * HFI_INV_SQRT2_F;
        polarity_sample(s, s_ac, est_cabs(along), period_end);
        return s->out.polarity == EST_HFI_POL_FLIPPED;
    }
    return 0;
}

/* Injection voltage (eq. 8) for the period that starts now, in the frame at theta^ (sin_t, cos_t). */
static void injection(est_hfi_t *s, float sin_t, float cos_t)
{
    const est_cplx_t *tw = s->sd_d.tw; /* tw[i] = e^{-j 2 pi i / m} = cos phi_i - j sin phi_i */
    fw_vec2_t v;
    v.x = -s->cfg.u_inj_v * tw[s->inj_idx].im; /* u_d' = U sin phi */
    v.y = s->cfg.u_inj_v * tw[s->inj_idx].re;  /* u_q' = U cos phi */
    s->out.v_inj_ab_v = fw_park_inv(v, sin_t, cos_t);
    if (++s->inj_idx >= s->m) {
        s->inj_idx = 0;
    }
}

const est_hfi_output_t *est_hfi_step(est_hfi_t *s, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v)
{
    float sin_t = sinf(s->theta_rad), cos_t = cosf(s->theta_rad);
    /* d'' axis at theta^ + pi/4 (eq. 14) */
    float sin_f = (sin_t + cos_t) * HFI_INV_SQRT2_F, cos_f = (cos_t - sin_t) * HFI_INV_SQRT2_F;
    fw_vec2_t i_f = fw_park(i_ab_a, sin_f, cos_f);
    est_cplx_t p_d = est_sdft_step(&s->sd_d, i_f.x, 0.0f)[0];
    est_cplx_t p_q = est_sdft_step(&s->sd_q, i_f.y, 0.0f)[0];
    int period_end = (s->inj_idx == s->m - 1); /* the last sample of an HF period of injection */
    float s2 = 0.0f, c2 = 0.0f;
    (void)v_ab_prev_v;

    s->out.est.theta_e_rad = s->theta_rad;
    s->out.dtheta_est_rad = 0.0f;
    if (est_sdft_valid(&s->sd_d)) {
        fw_vec2_t hf_f, hf_ab;
        amplitudes_and_error(s, p_d, p_q, &s2, &c2);
        hf_f.x = p_d.re; /* the bin-1 HF at this sample, in the d''q'' frame */
        hf_f.y = p_q.re;
        hf_ab = fw_park_inv(hf_f, sin_f, cos_f);
        s->out.i_fund_ab_a.x = i_ab_a.x - hf_ab.x;
        s->out.i_fund_ab_a.y = i_ab_a.y - hf_ab.y;
    } else {
        s->out.i_fund_ab_a = i_ab_a;
    }
    s->out.err = s2;
    if (s->out.ipd_state != EST_HFI_TRACKING && s->out.ipd_state != EST_HFI_IPD_FAILED) {
        if (ipd_step(s, i_ab_a, sin_t, cos_t, p_d, p_q, s2, c2, period_end)) {
            sin_t = -sin_t; /* inject in the corrected frame */
            cos_t = -cos_t;
        }
    }
    injection(s, sin_t, cos_t);
    track(s, s2);
    return &s->out;
}
