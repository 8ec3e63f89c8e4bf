/**
 * @file est_hfi.h
 * @brief Rotating high-frequency voltage injection with SDFT amplitude extraction, PI angle
 * tracking, N/S polarity identification and the standstill initial-position procedure
 * (Hou, Tan, Ling 2021, eq. 1-20 and section 3).
 *
 * Injection (eq. 8), in the estimated frame d'q' at theta^:
 *   u_d' = U_i sin(w_i t),  u_q' = U_i cos(w_i t)
 * held for one control period; w_i Ts = 2 pi / M with M an integer (1250 Hz at Ts = 100 us: M = 8).
 * The induced HF current traces an ellipse whose long axis is the d axis (Ld < Lq). Its projection
 * on an axis at angle theta_f oscillates at w_i with squared amplitude (eq. 12)
 *   |i_f|^2 = I0^2 + I1^2 + 2 I0 I1 cos(2 (theta - theta_f)),
 *   I0 = U_i L_sum / (w_i (L_sum^2 - L_dif^2)),  I1 = U_i L_dif / (w_i (L_sum^2 - L_dif^2))   (11)
 * With the axes d'' = theta^ + pi/4 and q'' = theta^ + 3 pi/4 (the pi/4 shift of eq. 14):
 *   |i_d''|^2 - |i_q''|^2 = 4 I0 I1 sin(2 dtheta),   dtheta = theta - theta^                 (15)
 * (our derivation; eq. 14 as printed is ambiguous about the direction of the shift).
 *
 * Amplitude extraction (eq. 16-20): one real-input est_sdft per axis, window M = one HF period.
 * Hou's "k = 0": the HF current is at w_i, i.e. bin k = 1 of an M = 8 window of the raw projection;
 * it is at k = 0 only after demodulation by the injection phase (a rotation by -w_i t, his
 * "transformation"), and a k = 0 SDFT is then a moving average over one HF period. The modulated
 * SDFT used here is literally that (demodulate by the exact table e^{-j w_i n}, sum over M
 * samples), so both readings are the same computation: bin 1 of the projection = bin 0 of the
 * demodulated projection.
 *
 * Tracking: e = (|i_d''|^2 - |i_q''|^2) / (|i_d''|^2 + |i_q''|^2) (normalise = 1, default; the sum
 * is 2 (I0^2 + I1^2), independent of dtheta, so the loop gain does not depend on U_i, w_i, L, the
 * DC bus) or Hou's raw eq. 15 [A^2] (normalise = 0). A PI drives e to 0 and its output is the speed:
 *   w^ = kp e + ki int e dt,  theta^ += w^ Ts   (type 2: no steady-state lag on a speed ramp)
 * Small-signal e = 2 g dtheta, g = 2 I0 I1 / (I0^2 + I1^2) = 2 L_sum L_dif / (L_sum^2 + L_dif^2).
 * Bias: the resistance tilts the ellipse; theta^ settles at dtheta ~ -0.5 deg (electrical) on the
 * hou2021 machine at 1250 Hz (R / (w_i L) = 0.04 / 0.012).
 *
 * Polarity (section 3): with saturation the HF current is larger when its vector points along the
 * N pole. Pure method (pol_bias_a = 0): the AC current (minus its one-HF-period mean) is projected
 * on theta^; over pol_time_s the per-HF-period maxima (towards theta^) and minima (towards
 * theta^ + pi) are summed: r = (sum max - sum |min|) / (sum max + sum |min|). The saturation's
 * asymmetry is ~1e-3 of a 0.3 A current, the ADC's noise a few mA per sample: the test is
 * sequential. At pol_time_s and at every doubling of it (while it fits in ipd_timeout_s) r is
 * compared with its standard error se = s / sqrt(n), s the spread of the per-HF-period ratios
 * r_i = (max_i - |min_i|) / (max_i + |min_i|) over the n periods (independent: the noise is
 * white, the injection periodic). |r| > pol_margin and |r| > pol_z se: theta^ is N (r > 0) or
 * theta^ += pi (r < 0); neither at the last look, or |r| + pol_z se < pol_margin at any look (no
 * decision possible: more periods only shrink se): undecided (IPD_FAILED). A wrong decision needs
 * the mean beyond pol_z se on the wrong side at one of K looks: probability <= K Phi(-pol_z).
 * Optional bias method
 * (pol_bias_a > 0, needs the current loop): i_d_req_a = +bias then -bias along theta^, and r
 * compares the HF amplitude along theta^ in the second half of each half-window.
 *
 * Initial position at standstill (ipd_on_reset = 1 or est_hfi_start_ipd): CONVERGE (track until
 * |dtheta estimate| < lock_tol_rad for lock_time_s; dtheta estimate = 0.5 atan2(s2, c2) from the
 * sin and cos of 2 dtheta, so the unstable equilibrium dtheta = pi/2 is not taken for a lock),
 * POLARITY (as above), then TRACKING with the result in `polarity`, or FAILED (timeout, undecided);
 * tracking goes on in FAILED (theta^ is then right modulo pi).
 *
 * Per step (the controller's ISR): i_ab at t_k and the voltage applied over the last period (not
 * used: the injection is known here). Returns est_output_t plus the injection voltage to ADD to
 * the FOC alpha-beta command of this period, the fundamental (HF-free) current for the current
 * loop (measured minus the reconstructed bin-1 HF; low-frequency group delay ~1 sample), the
 * d-current the polarity test asks for, and the IPD status.
 */
#ifndef EST_HFI_H
#define EST_HFI_H

#include "est_common.h"
#include "est_sdft.h"
#include "fw_math.h"

/** Default pol_z: a wrong polarity at one of the (at most 5 with the defaults) looks needs the
 *  mean 4 standard errors on the wrong side, P <= 5 Phi(-4) = 1.6e-4 per start. */
#define EST_HFI_POL_Z_DEFAULT 4.0f

typedef enum {
    EST_HFI_TRACKING = 0,      /**< normal tracking (no IPD, or IPD finished) */
    EST_HFI_IPD_CONVERGE = 1,  /**< IPD step 1: 2 dtheta -> 0 */
    EST_HFI_IPD_POLARITY = 2,  /**< IPD step 2: N/S test */
    EST_HFI_IPD_FAILED = 3     /**< timeout or undecided polarity; tracking continues (mod pi) */
} est_hfi_ipd_t;

typedef enum {
    EST_HFI_POL_UNKNOWN = 0,
    EST_HFI_POL_KEPT = 1,      /**< theta^ was on the N pole */
    EST_HFI_POL_FLIPPED = 2    /**< theta^ was on the S pole: pi added */
} est_hfi_pol_t;

typedef struct {
    float ts_s;             /**< control period */
    float f_inj_hz;         /**< injection frequency; 1 / (f_inj Ts) must be an integer M */
    float u_inj_v;          /**< injection amplitude U_i */
    float rs_ohm;           /**< for the expected amplitudes (diagnostics) */
    float ld_h;             /**< d-axis inductance (small-signal) */
    float lq_h;             /**< q-axis inductance */
    float kp_rad_s;         /**< PI: rad/s per unit error */
    float ki_rad_s2;        /**< PI: rad/s^2 per unit error */
    int normalise;          /**< 1: e normalised by |i_d''|^2 + |i_q''|^2; 0: raw eq. 15 [A^2] */
    float speed_lpf_rad_s;  /**< first-order filter on the speed output; <= 0: none */
    float theta0_rad;       /**< theta^ after reset */
    int ipd_on_reset;       /**< 1: reset starts the initial-position detection */
    float lock_tol_rad;     /**< IPD: |dtheta estimate| below this counts as locked */
    float lock_time_s;      /**< IPD: ... for this long */
    float ipd_timeout_s;    /**< IPD: no lock within this time -> FAILED */
    float pol_time_s;       /**< polarity test length (whole HF periods) */
    float pol_margin;       /**< |r| needed to decide (a floor for systematic bias) */
    float pol_z;            /**< pure method: |r| must also exceed pol_z standard errors of the
                             *   per-HF-period r (sequential test, est_hfi.c); <= 0: not used */
    float pol_bias_a;       /**< > 0: bias method (asks the current loop for +-bias on d) */
} est_hfi_config_t;

typedef struct {
    est_output_t est;        /**< theta^ at t_k, speed; e_alpha = e_beta = 0 */
    fw_vec2_t v_inj_ab_v;    /**< ADD to the alpha-beta voltage command of this period */
    fw_vec2_t i_fund_ab_a;   /**< measured current minus the HF: for the current loop */
    float i_d_req_a;         /**< d-current asked for (polarity bias), 0 otherwise */
    float amp_d_a;           /**< |i_d''| */
    float amp_q_a;           /**< |i_q''| */
    float err;               /**< tracking error e (eq. 15, normalised if cfg.normalise) */
    float dtheta_est_rad;    /**< 0.5 atan2(sin 2dth, cos 2dth) estimate (IPD only, else 0) */
    int ipd_state;           /**< est_hfi_ipd_t */
    int polarity;            /**< est_hfi_pol_t */
    float pol_metric;        /**< r of the last polarity test */
    float pol_se;            /**< its standard error from the per-HF-period spread (pure method) */
    float pol_time_s;        /**< how long the last polarity test ran */
} est_hfi_output_t;

typedef struct {
    est_hfi_config_t cfg;
    /* derived */
    int m;                 /**< samples per HF period */
    float a_speed;         /**< speed filter coefficient (1: none) */
    long lock_n;           /**< lock_time in steps */
    long timeout_n;        /**< ipd_timeout in steps */
    int pol_periods;       /**< polarity test length in HF periods (even) */
    /* extraction */
    est_sdft_t sd_d;       /**< bin 1 of the d'' projection */
    est_sdft_t sd_q;       /**< bin 1 of the q'' projection */
    est_sdft_t sd_mean;    /**< bin 0 of the complex current (IPD: AC part) */
    int inj_idx;           /**< injection phase index, 0..m-1 */
    /* tracking */
    float theta_rad;       /**< theta^ at the present sample */
    float integ_rad_s;     /**< PI integrator = speed */
    /* IPD */
    long t_n;              /**< steps in the present IPD phase */
    long lock_count;
    int pol_period;        /**< HF periods into the polarity test */
    est_cplx_t x1, x2;     /**< pure method: this HF period's DFT bins 1, 2 of the projection */
    float r_mean, r_m2;    /**< pure method: running mean and sum of squared deviations of the
                            *   per-HF-period r (Welford) */
    int pol_look;          /**< HF periods at the next look of the sequential test */
    float amp_sum_a[2];
    int amp_cnt[2];
    est_hfi_output_t out;
} est_hfi_t;

/** Hou's injection (1250 Hz, 6 V), normalised error, 150 rad/s loop, IPD on reset. */
void est_hfi_default_config(est_hfi_config_t *cfg, float rs_ohm, float ld_h, float lq_h, float ts_s);
/** Set kp, ki for a critically damped loop of natural frequency wn_rad_s (uses ld_h, lq_h, and
 *  for normalise = 0 also u_inj_v, f_inj_hz). */
void est_hfi_set_bandwidth(est_hfi_config_t *cfg, float wn_rad_s);
/** Expected HF amplitudes I0, I1 of eq. 11 [A] for the configuration (ideal, R = 0). */
void est_hfi_expected_amplitudes(const est_hfi_config_t *cfg, float *i0_a, float *i1_a);
/** 0 on success; -1 if 1/(f_inj Ts) is not an even integer in 4..EST_DFT_MAX_M or a value is unusable
 *  (Ld >= Lq: no saliency to track). */
int est_hfi_init(est_hfi_t *s, const est_hfi_config_t *cfg);
/** theta^ = theta0, speed 0, empty windows; IPD if ipd_on_reset. */
void est_hfi_reset(est_hfi_t *s);
/** Restart the initial-position detection from the present theta^. */
void est_hfi_start_ipd(est_hfi_t *s);
/** Track from a known angle and speed (no IPD). */
void est_hfi_set_angle(est_hfi_t *s, float theta_rad, float omega_rad_s);
/** One step: measured i_ab at t_k, voltage applied over the previous period (unused). */
const est_hfi_output_t *est_hfi_step(est_hfi_t *s, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v);

#endif
