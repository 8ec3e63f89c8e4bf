/**
 * @file pwm.c
 * @brief Centre-aligned PWM timing of one period. See pwm.h.
 */
#include "pwm.h"

#include <math.h>

int pwm_init(pwm_t *pwm, const pwm_config_t *cfg)
{
    static const double half[3] = {0.5, 0.5, 0.5};
    if (!isfinite(cfg->ts_s) || !(cfg->ts_s > 0.0) ||
        (cfg->carrier_at_start != PWM_CARRIER_VALLEY && cfg->carrier_at_start != PWM_CARRIER_PEAK) ||
        (cfg->load != PWM_LOAD_EXTREMUM && cfg->load != PWM_LOAD_PERIOD &&
         cfg->load != PWM_LOAD_IMMEDIATE)) {
        return -1;
    }
    pwm->cfg = *cfg;
    pwm_reset(pwm, half);
    return 0;
}

void pwm_reset(pwm_t *pwm, const double duty[3])
{
    int k;
    for (k = 0; k < 3; ++k) {
        /* the level just before t = Ts: valley there -> high only at d >= 1; peak -> high
         * unless d <= 0 */
        if (pwm->cfg.carrier_at_start == PWM_CARRIER_VALLEY) {
            pwm->level[k] = (duty[k] >= 1.0) ? 1 : 0;
        } else {
            pwm->level[k] = (duty[k] > 0.0) ? 1 : 0;
        }
    }
}

double pwm_load_instant(const pwm_t *pwm, double t_write_s)
{
    const double ts = pwm->cfg.ts_s;
    double tw = t_write_s;
    if (!(tw > 0.0)) {
        return 0.0; /* also NaN: the write is taken at the event at t_k */
    }
    if (tw > ts) tw = ts;
    switch (pwm->cfg.load) {
    case PWM_LOAD_IMMEDIATE:
        return tw;
    case PWM_LOAD_PERIOD:
        return ts;
    case PWM_LOAD_EXTREMUM:
    default:
        return (tw <= 0.5 * ts) ? 0.5 * ts : ts;
    }
}

double pwm_carrier(const pwm_t *pwm, double t_s)
{
    const double ts = pwm->cfg.ts_s;
    const double up = (t_s <= 0.5 * ts) ? 2.0 * t_s / ts : 2.0 - 2.0 * t_s / ts;
    return (pwm->cfg.carrier_at_start == PWM_CARRIER_VALLEY) ? up : 1.0 - up;
}

static void add_edge(pwm_leg_plan_t *lp, double t, int level)
{
    if (lp->n < PWM_MAX_EDGES) {
        lp->t_s[lp->n] = t;
        lp->level[lp->n] = level;
        ++lp->n;
    }
}

void pwm_plan(const pwm_t *pwm, const double duty_old[3], const double duty_new[3],
              double t_write_s, pwm_plan_t *out)
{
    const double ts = pwm->cfg.ts_s;
    const double mid = 0.5 * ts;
    const int valley = (pwm->cfg.carrier_at_start == PWM_CARRIER_VALLEY);
    const double t_l = pwm_load_instant(pwm, t_write_s);
    double cut[4];
    int n_cut = 0;
    int x, j;
    /* piece boundaries: 0, the load instant and Ts/2 in order, then Ts */
    cut[n_cut++] = 0.0;
    if (t_l > 0.0 && t_l < mid) cut[n_cut++] = t_l;
    cut[n_cut++] = mid;
    if (t_l > mid && t_l < ts) cut[n_cut++] = t_l;
    out->t_load_s = t_l;
    for (x = 0; x < 3; ++x) {
        pwm_leg_plan_t *lp = &out->leg[x];
        int cur = pwm->level[x];
        lp->n = 0;
        for (j = 0; j < n_cut; ++j) {
            const double a = cut[j];
            const double b = (j + 1 < n_cut) ? cut[j + 1] : ts;
            const double d = (a < t_l) ? duty_old[x] : duty_new[x];
            /* rising carrier on this half: valley start and first half, or peak start and
             * second half; the half starts at h0 with c(h0) = 0 (rising) or 1 (falling) */
            const int rising = (a < mid) ? valley : !valley;
            const double h0 = (a < mid) ? 0.0 : mid;
            int lv0, crosses = 0;
            double tc = 0.0;
            if (d >= 1.0) {
                lv0 = 1;
            } else if (d <= 0.0) {
                lv0 = 0;
            } else {
                /* c(tc) = 1 - d: rising c = 2(t - h0)/Ts, falling c = 1 - 2(t - h0)/Ts */
                tc = rising ? h0 + (1.0 - d) * mid : h0 + d * mid;
                if (rising) {
                    lv0 = (tc <= a) ? 1 : 0;
                } else {
                    lv0 = (tc <= a) ? 0 : 1;
                }
                crosses = (tc > a && tc < b);
            }
            if (lv0 != cur) {
                add_edge(lp, a, lv0);
                cur = lv0;
            }
            if (crosses) {
                cur = !cur;
                add_edge(lp, tc, cur);
            }
        }
        lp->level_end = cur;
    }
}

void pwm_commit(pwm_t *pwm, const pwm_plan_t *plan)
{
    int k;
    for (k = 0; k < 3; ++k) {
        pwm->level[k] = plan->leg[k].level_end;
    }
}
