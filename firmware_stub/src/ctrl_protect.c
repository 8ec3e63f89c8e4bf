#include "ctrl_protect.h"

#include <math.h>

#include "fw_math.h"

void ctrl_protect_default_config(ctrl_protect_config_t *cfg)
{
    cfg->i_trip_a = 30.0f;
    cfg->open_i_min_a = 1.0f;
    cfg->open_ratio = 0.2f;
    cfg->open_time_s = 0.02f;
    cfg->sum_max_a = 1.0f;
    cfg->sum_tau_s = 0.005f;
    cfg->stuck_time_s = 0.1f;
    cfg->stuck_delta_a = 0.5f;
    cfg->vdc_uv_ratio = 0.7f;
    cfg->vdc_ov_ratio = 1.25f;
    cfg->vdc_time_s = 0.001f;
    cfg->link_timeout_periods = 10.0f;
    cfg->enc_lost_time_s = 0.001f;
    cfg->enc_emf_ratio = 0.1f;
    cfg->enc_frozen_time_s = 0.002f;
    cfg->stall_time_s = 0.1f;
    cfg->stall_speed_rad_s = 1.0f;
}

static int nonneg(float x)
{
    return fw_is_finite(x) && x >= 0.0f;
}

int ctrl_protect_init(ctrl_protect_t *p, const ctrl_protect_config_t *cfg, float ts_s,
                      float v_dc_nom_v)
{
    const ctrl_protect_config_t *k = cfg;
    if (!(fw_is_finite(k->i_trip_a) && k->i_trip_a > 0.0f) || !(fw_is_finite(ts_s) && ts_s > 0.0f) ||
        !(fw_is_finite(v_dc_nom_v) && v_dc_nom_v > 0.0f) || !nonneg(k->open_i_min_a) ||
        !nonneg(k->open_ratio) || !nonneg(k->open_time_s) || !nonneg(k->sum_max_a) ||
        !nonneg(k->sum_tau_s) || !nonneg(k->stuck_time_s) || !nonneg(k->stuck_delta_a) ||
        !nonneg(k->vdc_uv_ratio) || !nonneg(k->vdc_ov_ratio) || !nonneg(k->vdc_time_s) ||
        !nonneg(k->link_timeout_periods) || !nonneg(k->enc_lost_time_s) ||
        !nonneg(k->enc_emf_ratio) || !nonneg(k->enc_frozen_time_s) || !nonneg(k->stall_time_s) ||
        !nonneg(k->stall_speed_rad_s) || (k->vdc_ov_ratio > 0.0f && k->vdc_ov_ratio <= 1.0f)) {
        return -1;
    }
    p->cfg = *cfg;
    p->ts_s = ts_s;
    p->vdc_uv_v = k->vdc_uv_ratio * v_dc_nom_v;
    p->vdc_ov_v = k->vdc_ov_ratio * v_dc_nom_v;
    p->enc_emf_v = k->enc_emf_ratio * v_dc_nom_v * FW_INV_SQRT3_F;
    p->stall_emf_min_v = CTRL_PROTECT_STALL_EMF_MIN_RATIO * v_dc_nom_v * FW_INV_SQRT3_F;
    ctrl_protect_reset(p);
    return 0;
}
/* Timers count whole periods: a time t is reached at the sample where the accumulated float
 * sum is within half a period of it (10 x 1e-4f adds up to 0.99999994e-3, not 1e-3). */

void ctrl_protect_reset(ctrl_protect_t *p)
{
    int k;
    for (k = 0; k < 3; ++k) {
        p->t_open_s[k] = 0.0f;
        p->stuck_val_a[k] = 0.0f;
        p->t_stuck_s[k] = 0.0f;
        p->stuck_ref_a[k][0] = p->stuck_ref_a[k][1] = 0.0f;
        p->stuck_max_a[k] = 0.0f;
    }
    p->sum_filt_a = 0.0f;
    p->stuck_armed = 0;
    p->t_uv_s = 0.0f;
    p->t_ov_s = 0.0f;
    p->t_since_sense_s = 0.0f;
    p->t_enc_lost_s = 0.0f;
    p->enc_prev_rad = 0.0f;
    p->enc_armed = 0;
    p->t_enc_frozen_s = 0.0f;
    p->enc_emf_int_vs = 0.0f;
    p->t_stall_s = 0.0f;
    p->stall_dir = 0;
    p->stall_err0_rad_s = 0.0f;
    p->stall_i_int_as = 0.0f;
    p->t_emf_s = 0.0f;
    p->emf_hat_f_v = 0.0f;
    p->emf_speed_f_v = 0.0f;
    p->code = CTRL_PROTECT_NONE;
    p->detail = 0;
}

/** phase * 10^7 + |value| in milli-units, saturated. */
static int32_t detail_of(int phase, float value)
{
    float milli = fabsf(value) * 1000.0f;
    long m;
    if (!fw_is_finite(milli) || milli > (float)CTRL_PROTECT_DETAIL_MAX_MILLI) {
        m = CTRL_PROTECT_DETAIL_MAX_MILLI;
    } else {
        m = (long)(milli + 0.5f);
    }
    return (int32_t)((long)phase * CTRL_PROTECT_DETAIL_PHASE + m);
}

static int trip(ctrl_protect_t *p, int code, int32_t detail)
{
    p->code = code;
    p->detail = detail;
    return code;
}

static int same(float a, float b)
{
    return !(fabsf(a - b) > 0.0f);
}

int ctrl_protect_step(ctrl_protect_t *p, const ctrl_protect_input_t *in)
{
    const ctrl_protect_config_t *k = &p->cfg;
    const float ts = p->ts_s;
    const float *i = in->i_abc_a;
    int x;
    p->t_since_sense_s = 0.0f; /* a SENSE arrived */
    if (p->code != CTRL_PROTECT_NONE) {
        return p->code;
    }
    /* over-current: one sample */
    for (x = 0; x < 3; ++x) {
        if (!fw_is_finite(i[x])) {
            return trip(p, CTRL_PROTECT_OVERCURRENT,
                        (int32_t)((long)x * CTRL_PROTECT_DETAIL_PHASE + CTRL_PROTECT_DETAIL_MAX_MILLI));
        }
    }
    for (x = 0; x < 3; ++x) {
        if (fabsf(i[x]) > k->i_trip_a) {
            return trip(p, CTRL_PROTECT_OVERCURRENT, detail_of(x, i[x]));
        }
    }
    /* open phase: the loop asks for current in x, x carries none, the others do */
    if (k->open_i_min_a > 0.0f && k->open_time_s > 0.0f) {
        for (x = 0; x < 3; ++x) {
            const float ref = fabsf(fw_is_finite(in->i_ref_abc_a[x]) ? in->i_ref_abc_a[x] : 0.0f);
            const float others = fmaxf(fabsf(i[(x + 1) % 3]), fabsf(i[(x + 2) % 3]));
            if (ref >= k->open_i_min_a) {
                if (fabsf(i[x]) < k->open_ratio * ref && others >= k->open_i_min_a) {
                    p->t_open_s[x] += ts;
                    if (p->t_open_s[x] >= k->open_time_s - 0.5f * ts) {
                        return trip(p, CTRL_PROTECT_OPEN_PHASE, detail_of(x, ref));
                    }
                } else if (fabsf(i[x]) >= k->open_ratio * ref) {
                    p->t_open_s[x] = 0.0f;
                }
            }
        }
    }
    /* three sensors must add up to zero (isolated star) */
    if (k->sum_max_a > 0.0f) {
        const float s = fabsf(i[0] + i[1] + i[2]);
        const float a = (k->sum_tau_s > ts) ? ts / k->sum_tau_s : 1.0f;
        p->sum_filt_a += a * (s - p->sum_filt_a);
        if (p->sum_filt_a > k->sum_max_a) {
            return trip(p, CTRL_PROTECT_SENSOR_FAULT, detail_of(3, p->sum_filt_a));
        }
    }
    /* a sensor stuck at one reading while another phase moves */
    if (k->stuck_time_s > 0.0f) {
        for (x = 0; x < 3; ++x) {
            const int y = (x + 1) % 3, z = (x + 2) % 3;
            if (p->stuck_armed && same(i[x], p->stuck_val_a[x])) {
                p->t_stuck_s[x] += ts;
                p->stuck_max_a[x] = fmaxf(p->stuck_max_a[x], fmaxf(fabsf(i[y] - p->stuck_ref_a[x][0]),
                                                                   fabsf(i[z] - p->stuck_ref_a[x][1])));
                if (p->t_stuck_s[x] >= k->stuck_time_s - 0.5f * ts &&
                    p->stuck_max_a[x] > k->stuck_delta_a) {
                    return trip(p, CTRL_PROTECT_SENSOR_FAULT, detail_of(x, i[x]));
                }
            } else { /* a new reading: time it from here, the others' excursion from here */
                p->stuck_val_a[x] = i[x];
                p->t_stuck_s[x] = 0.0f;
                p->stuck_ref_a[x][0] = i[y];
                p->stuck_ref_a[x][1] = i[z];
                p->stuck_max_a[x] = 0.0f;
            }
        }
        p->stuck_armed = 1;
    }
    /* bus: once a reading has arrived, whatever it reads (a collapse to 0 V is an under-voltage) */
    if (in->v_dc_valid && fw_is_finite(in->v_dc_v)) {
        const int32_t mv = (int32_t)(fminf(fmaxf(in->v_dc_v, -2.0e6f), 2.0e6f) * 1000.0f);
        if (p->vdc_uv_v > 0.0f && in->v_dc_v < p->vdc_uv_v) {
            p->t_uv_s += ts;
            if (p->t_uv_s >= k->vdc_time_s - 0.5f * ts) return trip(p, CTRL_PROTECT_UNDERVOLTAGE, mv);
        } else {
            p->t_uv_s = 0.0f;
        }
        if (p->vdc_ov_v > 0.0f && in->v_dc_v > p->vdc_ov_v) {
            p->t_ov_s += ts;
            if (p->t_ov_s >= k->vdc_time_s - 0.5f * ts) return trip(p, CTRL_PROTECT_OVERVOLTAGE, mv);
        } else {
            p->t_ov_s = 0.0f;
        }
    }
    return CTRL_PROTECT_NONE;
}

/** slot * 10^7 + value, value saturated to 0 .. CTRL_PROTECT_DETAIL_MAX_MILLI */
static int32_t detail_slot(int slot, float value)
{
    long m;
    if (!fw_is_finite(value) || value > (float)CTRL_PROTECT_DETAIL_MAX_MILLI) {
        m = CTRL_PROTECT_DETAIL_MAX_MILLI;
    } else {
        m = (value > 0.0f) ? (long)(value + 0.5f) : 0L;
    }
    return (int32_t)((long)slot * CTRL_PROTECT_DETAIL_PHASE + m);
}

static void encoder_reset(ctrl_protect_t *p)
{
    p->t_enc_lost_s = 0.0f;
    p->enc_armed = 0;
    p->t_enc_frozen_s = 0.0f;
    p->enc_emf_int_vs = 0.0f;
}

int ctrl_protect_motion_step(ctrl_protect_t *p, const ctrl_protect_motion_t *in)
{
    const ctrl_protect_config_t *k = &p->cfg;
    const float ts = p->ts_s;
    if (p->code != CTRL_PROTECT_NONE) {
        return p->code;
    }
    /* encoder plausibility */
    if (!in->encoder_used) {
        encoder_reset(p);
    } else if (!in->enc_valid || !fw_is_finite(in->theta_enc_rad)) {
        /* no reading this period: neither frozen nor moving; the controller extrapolates */
        p->t_enc_lost_s += ts;
        if (k->enc_lost_time_s > 0.0f && p->t_enc_lost_s >= k->enc_lost_time_s - 0.5f * ts) {
            return trip(p, CTRL_PROTECT_SENSOR_FAULT,
                        detail_slot(CTRL_PROTECT_DETAIL_ENC_LOST, p->t_enc_lost_s * 1.0e6f));
        }
    } else {
        p->t_enc_lost_s = 0.0f;
        if (p->enc_armed && same(in->theta_enc_rad, p->enc_prev_rad) && p->enc_emf_v > 0.0f &&
            k->enc_frozen_time_s > 0.0f) {
            const float e = fw_is_finite(in->emf_v) ? fabsf(in->emf_v) : 0.0f;
            p->t_enc_frozen_s += ts;
            p->enc_emf_int_vs += e * ts;
            if (p->t_enc_frozen_s >= k->enc_frozen_time_s - 0.5f * ts) {
                const float mean_v = p->enc_emf_int_vs / p->t_enc_frozen_s;
                if (mean_v > p->enc_emf_v) {
                    return trip(p, CTRL_PROTECT_SENSOR_FAULT,
                                detail_slot(CTRL_PROTECT_DETAIL_ENC_FROZEN, mean_v * 1000.0f));
                }
                p->t_enc_frozen_s = 0.0f; /* at standstill: judge the next window afresh */
                p->enc_emf_int_vs = 0.0f;
            }
        } else {
            p->t_enc_frozen_s = 0.0f;
            p->enc_emf_int_vs = 0.0f;
        }
        p->enc_prev_rad = in->theta_enc_rad;
        p->enc_armed = 1;
    }
    /* stall: at the current limit, that current delivered (on average over the window, by its
     * magnitude: frame-free), and the speed does not come closer to its reference */
    if (in->speed_control && k->stall_time_s > 0.0f && in->i_q_limit_a > 0.0f &&
        fw_is_finite(in->i_q_ref_a) && fw_is_finite(in->i_mag_a) && fw_is_finite(in->speed_err_rad_s)) {
        const float lim = in->i_q_limit_a * 0.9999f;
        const int dir = (in->i_q_ref_a >= lim) ? 1 : ((in->i_q_ref_a <= -lim) ? -1 : 0);
        if (dir != 0 && dir == p->stall_dir) {
            p->t_stall_s += ts;
            p->stall_i_int_as += fabsf(in->i_mag_a) * ts;
            if (p->t_stall_s >= k->stall_time_s - 0.5f * ts) {
                const float mean_i = p->stall_i_int_as / p->t_stall_s;
                /* progress toward the reference over the window (the error's sign is dir's) */
                const float progress = (float)dir * (p->stall_err0_rad_s - in->speed_err_rad_s);
                if (mean_i >= CTRL_PROTECT_STALL_I_RATIO * in->i_q_limit_a &&
                    progress < k->stall_speed_rad_s) {
                    const float w = fminf(fmaxf(in->omega_m_hat_rad_s * 1000.0f, -2.0e9f), 2.0e9f);
                    return trip(p, CTRL_PROTECT_STALL, fw_is_finite(w) ? (int32_t)w : 0);
                }
                /* accelerating, or the current not delivered (a voltage limit): judge the next
                 * window from here */
                p->t_stall_s = 0.0f;
                p->stall_i_int_as = 0.0f;
                p->stall_err0_rad_s = in->speed_err_rad_s;
            }
        } else {
            p->stall_dir = dir;        /* reached (or left) the limit: a window starts here */
            p->t_stall_s = 0.0f;
            p->stall_i_int_as = 0.0f;
            p->stall_err0_rad_s = in->speed_err_rad_s;
        }
    } else {
        p->stall_dir = 0;
        p->t_stall_s = 0.0f;
        p->stall_i_int_as = 0.0f;
    }
    /* stall by the EMF: the observer sees no EMF where its speed estimate says there is one.
     * Both magnitudes low-passed (time constant stall_time_s / 4); judged once the rule has been
     * active for stall_time_s: a locked rotor is found some 2.3 time constants after it stopped */
    if (in->speed_control && k->stall_time_s > 0.0f && in->emf_hat_v >= 0.0f &&
        fw_is_finite(in->emf_hat_v) && fw_is_finite(in->emf_of_speed_v) &&
        in->emf_of_speed_v >= p->stall_emf_min_v && p->stall_emf_min_v > 0.0f) {
        const float a = fminf(4.0f * ts / k->stall_time_s, 1.0f);
        if (p->t_emf_s <= 0.0f) {
            p->emf_hat_f_v = in->emf_hat_v;
            p->emf_speed_f_v = in->emf_of_speed_v;
        }
        p->t_emf_s += ts;
        p->emf_hat_f_v += a * (in->emf_hat_v - p->emf_hat_f_v);
        p->emf_speed_f_v += a * (in->emf_of_speed_v - p->emf_speed_f_v);
        if (p->t_emf_s >= k->stall_time_s - 0.5f * ts &&
            p->emf_hat_f_v < CTRL_PROTECT_STALL_EMF_RATIO * p->emf_speed_f_v) {
            const float w = fminf(fmaxf(in->omega_m_hat_rad_s * 1000.0f, -2.0e9f), 2.0e9f);
            return trip(p, CTRL_PROTECT_STALL, fw_is_finite(w) ? (int32_t)w : 0);
        }
    } else {
        p->t_emf_s = 0.0f;
    }
    return CTRL_PROTECT_NONE;
}

int ctrl_protect_link_tick(ctrl_protect_t *p, float dt_s)
{
    const float limit = p->cfg.link_timeout_periods * p->ts_s;
    if (p->code != CTRL_PROTECT_NONE) {
        return (p->code == CTRL_PROTECT_LINK_TIMEOUT) ? p->code : CTRL_PROTECT_NONE;
    }
    if (fw_is_finite(dt_s) && dt_s > 0.0f) {
        p->t_since_sense_s += dt_s;
    }
    if (limit > 0.0f && p->t_since_sense_s > limit) {
        const float us = fminf(p->t_since_sense_s * 1.0e6f, 2.0e9f);
        return trip(p, CTRL_PROTECT_LINK_TIMEOUT, (int32_t)us);
    }
    return CTRL_PROTECT_NONE;
}
