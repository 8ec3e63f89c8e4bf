#include "inv_comp.h"

#include <math.h>

void inv_comp_default_config(inv_comp_config_t *cfg, float ts_s)
{
    cfg->ts_s = ts_s;
    cfg->dead_time_s = 0.0f;
    cfg->v_switch_v = 0.0f;
    cfg->r_switch_ohm = 0.0f;
    cfg->v_diode_v = 0.0f;
    cfg->r_diode_ohm = 0.0f;
    cfg->i_band_a = 0.1f;
    cfg->shape = (int)INV_COMP_SHAPE_CAPACITIVE;
}

static int nonneg(float x)
{
    return fw_is_finite(x) && x >= 0.0f;
}

int inv_comp_init(inv_comp_t *s, const inv_comp_config_t *cfg)
{
    if (!fw_is_finite(cfg->ts_s) || !(cfg->ts_s > 0.0f) || !nonneg(cfg->dead_time_s) ||
        !(2.0f * cfg->dead_time_s < cfg->ts_s) || !nonneg(cfg->v_switch_v) ||
        !nonneg(cfg->r_switch_ohm) || !nonneg(cfg->v_diode_v) || !nonneg(cfg->r_diode_ohm) ||
        !fw_is_finite(cfg->i_band_a) || !(cfg->i_band_a > 0.0f) ||
        (cfg->shape != (int)INV_COMP_SHAPE_LINEAR && cfg->shape != (int)INV_COMP_SHAPE_CAPACITIVE)) {
        return -1;
    }
    s->cfg = *cfg;
    s->delta = cfg->dead_time_s / cfg->ts_s;
    s->inv_band = 1.0f / cfg->i_band_a;
    inv_comp_reset(s);
    return 0;
}

void inv_comp_reset(inv_comp_t *s)
{
    int k;
    for (k = 0; k < 3; ++k) {
        s->duty_abc[k] = -1.0f;
        s->v_err_abc_v[k] = 0.0f;
    }
    s->v_ab_v.x = s->v_ab_v.y = 0.0f;
    s->clamped = 0;
}

float inv_comp_sign(const inv_comp_t *s, float i_a)
{
    const float x = fabsf(i_a) * s->inv_band;   /* |i| / i_band */
    float g;
    if (s->cfg.shape == (int)INV_COMP_SHAPE_LINEAR) {
        g = x < 1.0f ? x : 1.0f;
    } else {
        g = x <= 1.0f ? 0.5f * x : 1.0f - 0.5f / x;
    }
    return i_a < 0.0f ? -g : g;
}

/* onset q(|i|) of the threshold drops */
static float drop_onset(const inv_comp_t *s, float abs_i_a)
{
    const float x = abs_i_a * s->inv_band;
    if (s->cfg.shape == (int)INV_COMP_SHAPE_LINEAR) {
        return x < 1.0f ? x : 1.0f;
    }
    return x < 20.0f ? tanhf(x) : 1.0f;   /* tanh rounds to 1 beyond 9 in float32 */
}

static float clamp01(float x)
{
    return x < 0.0f ? 0.0f : (x > 1.0f ? 1.0f : x);
}

float inv_comp_leg_voltage(const inv_comp_t *s, float duty, float i_a, float v_dc_v)
{
    const inv_comp_config_t *c = &s->cfg;
    const float ai = fabsf(i_a);
    const float q = drop_onset(s, ai);
    const float vs = c->v_switch_v * q + c->r_switch_ohm * ai;
    const float vd = c->v_diode_v * q + c->r_diode_ohm * ai;
    const float fp = clamp01(duty - s->delta);
    const float fn = clamp01(duty + s->delta);
    const float w = 0.5f * (1.0f + inv_comp_sign(s, i_a));
    const float f = w * fp + (1.0f - w) * fn;
    float h = 0.0f;
    if (i_a > 0.0f) {
        h = fp * vs + (1.0f - fp) * vd;
    } else if (i_a < 0.0f) {
        h = -(fn * vd + (1.0f - fn) * vs);
    }
    return f * v_dc_v - h;
}

float inv_comp_leg_duty(const inv_comp_t *s, float duty, float i_a, float v_dc_v, int *clamped)
{
    /* v_xN(d') is continuous, non-decreasing and piecewise linear in d' with breaks where the
     * dead interval meets a rail, d' = D and d' = 1 - D (w, V_s, V_d depend on i alone): find the
     * piece that holds the target and interpolate in it, which is exact */
    float x[4], v[4];
    const float target = duty * v_dc_v;
    int k;
    if (!(v_dc_v > 0.0f)) {
        return duty;
    }
    x[0] = 0.0f;
    x[1] = s->delta < 0.5f ? s->delta : 0.5f;
    x[2] = 1.0f - x[1];
    x[3] = 1.0f;
    for (k = 0; k < 4; ++k) {
        v[k] = inv_comp_leg_voltage(s, x[k], i_a, v_dc_v);
    }
    if (target <= v[0] || target >= v[3]) {
        if (clamped != 0 && (target < v[0] || target > v[3])) {
            *clamped = 1;
        }
        return target <= v[0] ? 0.0f : 1.0f;
    }
    k = 0;
    while (k < 2 && target > v[k + 1]) {
        ++k;
    }
    if (!(v[k + 1] > v[k])) {
        return x[k];   /* a flat piece: every duty in it makes the target */
    }
    return x[k] + (x[k + 1] - x[k]) * (target - v[k]) / (v[k + 1] - v[k]);
}

fw_vec2_t inv_comp_step(inv_comp_t *s, const float duty_abc[3], const float i_abc_a[3],
                        float v_dc_v)
{
    float v_pole[3];
    int k, off = 0;
    s->clamped = 0;
    for (k = 0; k < 3; ++k) {
        int cl = 0;
        if (!(duty_abc[k] >= 0.0f)) {   /* OFF (or NaN): untouched */
            s->duty_abc[k] = duty_abc[k];
            s->v_err_abc_v[k] = 0.0f;
            v_pole[k] = 0.0f;
            off = 1;
            continue;
        }
        s->duty_abc[k] = inv_comp_leg_duty(s, duty_abc[k], i_abc_a[k], v_dc_v, &cl);
        s->clamped += cl;
        v_pole[k] = inv_comp_leg_voltage(s, s->duty_abc[k], i_abc_a[k], v_dc_v);
        s->v_err_abc_v[k] = v_pole[k] - s->duty_abc[k] * v_dc_v;
    }
    if (off) {
        s->v_ab_v.x = s->v_ab_v.y = 0.0f;
    } else {
        s->v_ab_v = fw_clarke(v_pole[0], v_pole[1], v_pole[2]);
    }
    return s->v_ab_v;
}

void inv_comp_predict(const float i_now_a[3], const float i_prev_a[3], float horizon,
                      float out_a[3])
{
    int k;
    for (k = 0; k < 3; ++k) {
        out_a[k] = i_now_a[k] + horizon * (i_now_a[k] - i_prev_a[k]);
    }
}
