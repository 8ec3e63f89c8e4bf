/**
 * @file est_smo_sigmoid.h
 * @brief Improved sliding-mode observer: sigmoid switching and the intermediate variable H.
 *
 * Yuan, Yang, Wu, Wu, IEEE Access 8, 2020, eq. (11)-(18):
 *
 *   d/dt i^ = -(R/Ls) i^ + u/Ls - (K/Ls) sigmoid(i^ - i) + H/(2 Ls)      (eq. 11)
 *   sigmoid(x) = 2/(1 + exp(-a x)) - 1                                    (eq. 11, a [1/A])
 *   H       = wc/(s + wc) { K sigmoid(i^ - i) }                           (eq. 11)
 *   E^      = H/2                                                          (eq. 14), reported as EMF
 *   theta^  = atan(-Ha/Hb) + atan(w^e/wc)                                  (eq. 15), full quadrant
 *   K       > max(|2 Ea|, |2 Eb|)                                          (eq. 18)
 *   w^e     = speed of the est_common angle-tracking PLL run on theta^ (not in the paper)
 *
 * Signs: (11) - (3) gives (12) exactly, (12) = 0 gives (13) and, for w << wc, (14): the equivalent
 * control K sigmoid(i~) tends to 2E and H to 2E, consistent with (17)-(18). But the lag of H
 * behind E is not the LPF's atan(w/wc): from (13), H = wc/(s + wc/2) E, a first-order lag with
 * the cut-off wc/2, i.e. atan(2 w/wc). lag_comp selects eq. 15 as printed (default), the
 * effective atan(2 w/wc), or none (docs/estimators_smo.md).
 *
 * Discretisation (as est_smo_sign): the current model is integrated exactly over one period with
 * u, the switching term z = K sigmoid(i~) and H held (zero-order hold):
 * i^[k] = F i^[k-1] + G (u[k-1] - z[k-1] + H[k-1]/2), F = exp(-R Ts/Ls), G = (1 - F)/R; the LPF is
 * the ZOH equivalent of wc/(s + wc): H[k] = H[k-1] + (1 - exp(-wc Ts)) (z[k] - H[k-1]).
 *
 * Step inputs: the currents sampled at t_k and the voltage applied over [t_{k-1}, t_k].
 */
#ifndef EST_SMO_SIGMOID_H
#define EST_SMO_SIGMOID_H

#include "est_common.h"
#include "fw_math.h"

/** Phase-lag compensation added to atan(-Ha/Hb). */
#define EST_SMO_SIGMOID_LAG_NONE 0      /**< none */
#define EST_SMO_SIGMOID_LAG_EQ15 1      /**< atan(w^/wc): Yuan eq. 15 as printed (default) */
#define EST_SMO_SIGMOID_LAG_EFFECTIVE 2 /**< atan(2 w^/wc): the lag H = wc/(s + wc/2) E has */

typedef struct {
    float rs_ohm;          /**< stator resistance */
    float ls_h;            /**< stator inductance (SPMSM: Ld = Lq) */
    float psi_f_wb;        /**< PM flux linkage (for the gain helper; not used by the step) */
    float ts_s;            /**< step period */
    float k_v;             /**< sliding gain K (eq. 18: K > 2 psi_f w_e,max); must be > 0 */
    float a_per_a;         /**< sigmoid slope a; <= 0 selects est_smo_sigmoid_max_slope_per_a */
    float wc_rad_s;        /**< cut-off of the LPF that makes H */
    int lag_comp;          /**< EST_SMO_SIGMOID_LAG_* */
    float pll_kp;          /**< PLL proportional gain [1/s] */
    float pll_ki;          /**< PLL integral gain [1/s^2] */
    float speed_lpf_rad_s; /**< first-order filter on the speed output; <= 0 disables */
    float dir_speed_rad_s; /**< |electrical speed| below which the direction of rotation is held
                              and the PLL angle is output (est_emf_angle_step); default
                              EST_EMF_DIR_SPEED_RAD_S */
} est_smo_sigmoid_config_t;

typedef struct {
    est_smo_sigmoid_config_t cfg;
    /* derived coefficients */
    float f;          /**< exp(-R Ts / Ls) */
    float g;          /**< (1 - f) / R  [A/V], or Ts/Ls if R = 0 */
    float a_lpf;      /**< 1 - exp(-wc Ts) */
    float a_speed;    /**< 1 - exp(-w_lpf Ts), 1 if disabled */
    float a_used_per_a; /**< sigmoid slope in use (cfg.a_per_a or the derived one) */
    /* state */
    fw_vec2_t i_hat_a; /**< estimated current at the current step */
    fw_vec2_t z_v;     /**< switching term K sigmoid(i~) of the last step */
    fw_vec2_t h_v;     /**< intermediate variable H (eq. 11), ~ 2 E */
    est_pll_t pll;
    est_emf_dir_t dir; /**< direction of rotation (est_emf_angle_step) */
    est_output_t out;  /**< e_alpha_v/e_beta_v = H/2 (eq. 14) */
} est_smo_sigmoid_t;

/** Neutral defaults for a motor; the caller must still set k_v (eq. 18, see the helper). */
void est_smo_sigmoid_default_config(est_smo_sigmoid_config_t *cfg, float rs_ohm, float ls_h,
                                    float psi_f_wb, float ts_s);
/** 0 on success, -1 if the configuration is not usable (Ls, Ts, wc, K <= 0, R < 0, bad lag_comp,
 *  non-finite values). */
int est_smo_sigmoid_init(est_smo_sigmoid_t *s, const est_smo_sigmoid_config_t *cfg);
void est_smo_sigmoid_reset(est_smo_sigmoid_t *s);
/** One step: measured i_ab at t_k, voltage applied over the previous period. */
const est_output_t *est_smo_sigmoid_step(est_smo_sigmoid_t *s, fw_vec2_t i_ab_a,
                                         fw_vec2_t v_ab_prev_v);

/** Yuan eq. 11: sigmoid(x) = 2/(1 + exp(-a x)) - 1 (computed as tanh(a x / 2), the same value). */
float est_smo_sigmoid_fn(float x_a, float a_per_a);
/** Eq. 18 with eq. 2: the bound K must exceed, 2 psi_f w_e,max [V]. */
float est_smo_sigmoid_min_gain_v(float psi_f_wb, float omega_e_max_rad_s);
/** Largest slope a for gain K that keeps the sampled, linearised error loop from overshooting:
 *  G K a/2 = F (deadbeat), a = 2 F / (G K) [1/A]; beyond 2 (1 + F)/(G K) it chatters.
 *  Returns -1 for unusable arguments. */
float est_smo_sigmoid_max_slope_per_a(float rs_ohm, float ls_h, float ts_s, float k_v);

#endif
