/**
 * @file est_delay_comp.h
 * @brief Calculation-delay estimation by dual sampling and current pre-compensation.
 *
 * Gong, Hu, Gao, Wang, Yan, IEEE TIE, section IV, eq. (20)-(22). Per period k, phase x:
 *   i_x_1(k): first sample, at t_k (start of the period, what the ISR starts from);
 *   i_x_2(k): second sample, at the actuation instant t_k + t_d (new duties take effect).
 * Assumption of the paper: the current is linear while one voltage vector is applied, i.e. on
 * [t_{k-1} + t_d, t_k + t_d), and t_d is constant.
 *
 *   t_d      = |i_x_2(k) - i_x_1(k)| / |i_x_2(k) - i_x_2(k-1)| * Ts              (eq. 20)
 *   Delta_i  = (i_x_1(k) - i_x_2(k-1)) / (Ts - t_d) * t_d                         (eq. 21)
 *   i'_x(k)  = i_x_1(k) + Delta_i                                                  (eq. 22)
 * then i'_ab = Clarke(i'_a, i'_b, i'_c): the current at t_k + t_d predicted at t_k, for the SMO
 * and the current loop.
 *
 * Estimation (estimate_on = 1): a phase's eq.-20 value is used only when the denominator
 * |i_x_2(k) - i_x_2(k-1)| >= min_step_a (guard against dividing by a current that hardly moved,
 * e.g. at a current peak) and the value lies in [0, t_d_max_s]. The per-period estimate
 * (t_d_last_s) is the mean of the valid phases of that period; periods without a valid phase are
 * skipped. t_d_mean_s is the recursive mean of the per-period estimates: the plain mean of the
 * first avg_n_max valid periods, then exponential forgetting with weight 1/avg_n_max.
 * Compensation uses t_d_mean_s once a period was valid, t_d_fixed_s before that and whenever
 * estimation is off.
 *
 * Calling order per period: sample1 at t_k (returns the compensated currents of period k, from
 * i_1(k) and the stored i_2(k-1)), then sample2 at t_k + t_d (updates the estimate, stores
 * i_2(k)). est_delay_comp_step does both with the two samples of one period.
 */
#ifndef EST_DELAY_COMP_H
#define EST_DELAY_COMP_H

#include "fw_math.h"

typedef struct {
    float ts_s;        /**< control / PWM period Ts */
    float t_d_fixed_s; /**< delay used when estimation is off (and until the first estimate) */
    int estimate_on;   /**< 1: estimate t_d by eq. 20 and compensate with the mean estimate */
    int compensate_on; /**< 1: output i' = i_1 + Delta_i (eq. 21-22); 0: output i_1 unchanged */
    float min_step_a;  /**< eq.-20 guard on |i_2(k) - i_2(k-1)| [A]; > 0 */
    float t_d_max_s;   /**< largest plausible delay; (0, Ts). Bounds eq. 21's gain t_d/(Ts - t_d) */
    int avg_n_max;     /**< recursive mean over up to this many periods, then forgetting; >= 1 */
} est_delay_comp_config_t;

typedef struct {
    float i_a_a; /**< compensated phase currents i'(k) (eq. 22) */
    float i_b_a;
    float i_c_a;
    fw_vec2_t i_ab_a; /**< Clarke of the compensated currents */
    float t_d_s;      /**< delay the compensation used */
} est_delay_comp_output_t;

typedef struct {
    est_delay_comp_config_t cfg;
    /* state */
    float i1_a[3];      /**< first sample of the present period */
    float i2_prev_a[3]; /**< second sample of the previous period */
    int have_i1;        /**< a first sample was taken since reset */
    int have_i2_prev;   /**< a second sample was taken since reset */
    float t_d_last_s;   /**< last per-period estimate (eq. 20, mean of the valid phases) */
    float t_d_mean_s;   /**< recursive mean of the per-period estimates */
    long n_valid;       /**< periods that gave an estimate since reset */
    int phases_valid;   /**< phases that passed the guards in the last sample2 (0..3) */
    est_delay_comp_output_t out;
} est_delay_comp_t;

/** Defaults: t_d fixed 0, estimation and compensation on, min_step 1 mA, t_d_max 0.9 Ts,
 *  mean over up to 1000 periods. */
void est_delay_comp_default_config(est_delay_comp_config_t *cfg, float ts_s);
/** 0 on success, -1 if unusable (Ts <= 0, t_d_max not in (0, Ts), t_d_fixed not in
 *  [0, t_d_max], min_step <= 0, avg_n_max < 1, non-finite). */
int est_delay_comp_init(est_delay_comp_t *s, const est_delay_comp_config_t *cfg);
void est_delay_comp_reset(est_delay_comp_t *s);
/** First sample of period k (t_k): compensated currents of period k (eq. 21-22). */
const est_delay_comp_output_t *est_delay_comp_sample1(est_delay_comp_t *s, const float i1_abc_a[3]);
/** Second sample of period k (t_k + t_d): delay estimate (eq. 20). */
void est_delay_comp_sample2(est_delay_comp_t *s, const float i2_abc_a[3]);
/** Both samples of period k: sample1 then sample2; returns sample1's output. */
const est_delay_comp_output_t *est_delay_comp_step(est_delay_comp_t *s, const float i1_abc_a[3],
                                                   const float i2_abc_a[3]);
/** Delay the next compensation will use [s]. */
float est_delay_comp_t_d_s(const est_delay_comp_t *s);

#endif
