#include "est_delay_comp.h"

#include <math.h>

void est_delay_comp_default_config(est_delay_comp_config_t *cfg, float ts_s)
{
    cfg->ts_s = ts_s;
    cfg->t_d_fixed_s = 0.0f;
    cfg->estimate_on = 1;
    cfg->compensate_on = 1;
    cfg->min_step_a = 1e-3f;
    cfg->t_d_max_s = 0.9f * ts_s;
    cfg->avg_n_max = 1000;
}

int est_delay_comp_init(est_delay_comp_t *s, const est_delay_comp_config_t *cfg)
{
    if (!fw_is_finite(cfg->ts_s) || !fw_is_finite(cfg->t_d_fixed_s) ||
        !fw_is_finite(cfg->min_step_a) || !fw_is_finite(cfg->t_d_max_s) || !(cfg->ts_s > 0.0f) ||
        !(cfg->t_d_max_s > 0.0f) || !(cfg->t_d_max_s < cfg->ts_s) || !(cfg->t_d_fixed_s >= 0.0f) ||
        !(cfg->t_d_fixed_s <= cfg->t_d_max_s) || !(cfg->min_step_a > 0.0f) || cfg->avg_n_max < 1) {
        return -1;
    }
    s->cfg = *cfg;
    est_delay_comp_reset(s);
    return 0;
}

void est_delay_comp_reset(est_delay_comp_t *s)
{
    int x;
    for (x = 0; x < 3; ++x) {
        s->i1_a[x] = 0.0f;
        s->i2_prev_a[x] = 0.0f;
    }
    s->have_i1 = 0;
    s->have_i2_prev = 0;
    s->t_d_last_s = 0.0f;
    s->t_d_mean_s = 0.0f;
    s->n_valid = 0;
    s->phases_valid = 0;
    s->out.i_a_a = s->out.i_b_a = s->out.i_c_a = 0.0f;
    s->out.i_ab_a.x = s->out.i_ab_a.y = 0.0f;
    s->out.t_d_s = s->cfg.t_d_fixed_s;
}

float est_delay_comp_t_d_s(const est_delay_comp_t *s)
{
    return (s->cfg.estimate_on && s->n_valid > 0) ? s->t_d_mean_s : s->cfg.t_d_fixed_s;
}

/* eq. 21: the current change over t_d, extrapolated with the slope of [t_{k-1} + t_d, t_k]. */
static float delta_i_a(float i1_a, float i2_prev_a, float ts_s, float t_d_s)
{
    return (i1_a - i2_prev_a) / (ts_s - t_d_s) * t_d_s;
}

const est_delay_comp_output_t *est_delay_comp_sample1(est_delay_comp_t *s, const float i1_abc_a[3])
{
    float t_d = est_delay_comp_t_d_s(s);
    float comp[3];
    int x;
    for (x = 0; x < 3; ++x) {
        s->i1_a[x] = i1_abc_a[x];
        comp[x] = i1_abc_a[x];
        if (s->cfg.compensate_on && s->have_i2_prev) {
            comp[x] += delta_i_a(i1_abc_a[x], s->i2_prev_a[x], s->cfg.ts_s, t_d); /* eq. 22 */
        }
    }
    s->have_i1 = 1;
    s->out.i_a_a = comp[0];
    s->out.i_b_a = comp[1];
    s->out.i_c_a = comp[2];
    s->out.i_ab_a = fw_clarke(comp[0], comp[1], comp[2]);
    s->out.t_d_s = t_d;
    return &s->out;
}

/* eq. 20 for one phase; returns 1 and the delay when the guards pass. */
static int phase_delay(const est_delay_comp_t *s, int x, float i2_a, float *t_d_s)
{
    float num = fabsf(i2_a - s->i1_a[x]);
    float den = fabsf(i2_a - s->i2_prev_a[x]);
    float t_d;
    if (!(den >= s->cfg.min_step_a)) {
        return 0;
    }
    t_d = num / den * s->cfg.ts_s;
    if (!(t_d <= s->cfg.t_d_max_s)) {
        return 0;
    }
    *t_d_s = t_d;
    return 1;
}

static void update_mean(est_delay_comp_t *s, float t_d_period_s)
{
    long n_weight;
    s->n_valid += 1;
    n_weight = s->n_valid < (long)s->cfg.avg_n_max ? s->n_valid : (long)s->cfg.avg_n_max;
    s->t_d_mean_s += (t_d_period_s - s->t_d_mean_s) / (float)n_weight;
}

void est_delay_comp_sample2(est_delay_comp_t *s, const float i2_abc_a[3])
{
    int x;
    s->phases_valid = 0;
    if (s->cfg.estimate_on && s->have_i1 && s->have_i2_prev) {
        float sum = 0.0f;
        int n = 0;
        for (x = 0; x < 3; ++x) {
            float t_d;
            if (phase_delay(s, x, i2_abc_a[x], &t_d)) {
                sum += t_d;
                ++n;
            }
        }
        s->phases_valid = n;
        if (n > 0) {
            s->t_d_last_s = sum / (float)n;
            update_mean(s, s->t_d_last_s);
        }
    }
    for (x = 0; x < 3; ++x) {
        s->i2_prev_a[x] = i2_abc_a[x];
    }
    s->have_i2_prev = 1;
}

const est_delay_comp_output_t *est_delay_comp_step(est_delay_comp_t *s, const float i1_abc_a[3],
                                                   const float i2_abc_a[3])
{
    const est_delay_comp_output_t *o = est_delay_comp_sample1(s, i1_abc_a);
    est_delay_comp_sample2(s, i2_abc_a);
    return o;
}
