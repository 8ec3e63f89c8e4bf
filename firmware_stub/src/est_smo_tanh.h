/**
 * @file est_smo_tanh.h
 * @brief Sliding-mode observer with hyperbolic-tangent switching and no low-pass filter.
 *
 * Gong, Hu, Gao, Wang, Yan, IEEE TIE, eq. (3), (8), (14)-(19):
 *
 *   d/dt i^ = -(Rs/Ls) i^ + u/Ls - (k/Ls) F(i^ - i)                    (eq. 3)
 *   F(x)    = tanh(m x), m [1/A]; boundary layer BL = atanh(0.99)/m     (eq. 8, Fig. 3)
 *   e^      = k F(i~), no filter                                        (eq. 6 with eq. 8)
 *   theta^  = -atan(e^a / e^b), full quadrant, no lag compensation      (eq. 18)
 *   w^e     = d theta^/dt, realised as the est_common angle-tracking PLL (eq. 19)
 *   gain    k > max|e / F(i~)| (eq. 14); with min|F| = tanh(m xi) (eq. 15-16):
 *           k = 3 sqrt(3) Ce psi_f p w_m,max / (2 min|F|)               (eq. 17)
 *
 * The tolerance xi of eq. 15 is not given in the paper. est_smo_tanh_xi_deadbeat_a() picks the
 * smallest xi whose eq.-17 gain does not over-drive the sampled error loop (k m <= F/G, see
 * est_smo_tanh_deadbeat_gain_v_per_a); docs/estimators_smo.md gives the reasoning and numbers.
 *
 * Discretisation (as est_smo_sign): the current model is integrated exactly over one period with
 * u and the switching term held (zero-order hold): i^[k] = F i^[k-1] + G (u[k-1] - e^[k-1]),
 * F = exp(-Rs Ts/Ls), G = (1 - F)/Rs.
 *
 * Step inputs: the currents sampled at t_k and the voltage applied over [t_{k-1}, t_k].
 */
#ifndef EST_SMO_TANH_H
#define EST_SMO_TANH_H

#include "est_common.h"
#include "fw_math.h"

typedef struct {
    float rs_ohm;          /**< stator resistance */
    float ls_h;            /**< stator inductance (Ld = Lq) */
    float psi_f_wb;        /**< PM flux linkage (for the gain helpers; not used by the step) */
    float ts_s;            /**< step period */
    float k_v;             /**< observer gain k (eq. 14, 17); must be > 0 */
    float m_per_a;         /**< tanh slope m (eq. 8); the paper's final choice is 0.01 */
    float pll_kp;          /**< PLL proportional gain [1/s] */
    float pll_ki;          /**< PLL integral gain [1/s^2] */
    float speed_lpf_rad_s; /**< first-order filter on the speed output; <= 0 disables */
    float dir_speed_rad_s; /**< |electrical speed| below which the direction of rotation is held
                              and the PLL angle is output (est_emf_angle_step); default
                              EST_EMF_DIR_SPEED_RAD_S */
} est_smo_tanh_config_t;

typedef struct {
    est_smo_tanh_config_t cfg;
    /* derived coefficients */
    float f;       /**< exp(-R Ts / Ls) */
    float g;       /**< (1 - f) / R  [A/V], or Ts/Ls if R = 0 */
    float a_speed; /**< 1 - exp(-w_lpf Ts), 1 if disabled */
    /* state */
    fw_vec2_t i_hat_a; /**< estimated current at the current step */
    fw_vec2_t e_hat_v; /**< e^ = k F(i~) of the last step (also the injection of the next) */
    est_pll_t pll;
    est_emf_dir_t dir; /**< direction of rotation (est_emf_angle_step) */
    est_output_t out;
} est_smo_tanh_t;

/** Neutral defaults for a motor (m = 0.01 as the paper); the caller must still set k_v. */
void est_smo_tanh_default_config(est_smo_tanh_config_t *cfg, float rs_ohm, float ls_h,
                                 float psi_f_wb, float ts_s);
/** 0 on success, -1 if the configuration is not usable (Ls, Ts, k, m <= 0, R < 0, non-finite). */
int est_smo_tanh_init(est_smo_tanh_t *s, const est_smo_tanh_config_t *cfg);
void est_smo_tanh_reset(est_smo_tanh_t *s);
/** One step: measured i_ab at t_k, voltage applied over the previous period. */
const est_output_t *est_smo_tanh_step(est_smo_tanh_t *s, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v);

/** Gong's boundary layer: the |i~| at which F = 0.99, atanh(0.99)/m [A] (m = 0.01: 265 A). */
float est_smo_tanh_boundary_layer_a(float m_per_a);
/** Eq. 16: min|F| = tanh(m xi). */
float est_smo_tanh_min_f(float m_per_a, float xi_a);
/** Eq. 17: k = 3 sqrt(3) Ce psi_f p w_m,max / (2 min|F|) [V] (the sqrt covers the 3 only: a
 *  square root of volts would not be a voltage). Returns -1 if min_f <= 0. */
float est_smo_tanh_gain_rule_v(float ce, float psi_f_wb, int pole_pairs, float omega_m_max_rad_s,
                               float min_f);
/** Eq. 14 at the worst point: e_max / min|F| [V], the lower bound k must exceed. */
float est_smo_tanh_stability_bound_v(float e_max_v, float min_f);
/** k m at which the sampled, linearised error loop i~[k] = (F - G k m) i~[k-1] is deadbeat:
 *  F/G [V/A]. Up to (1 + F)/G it rings but decays; above, it chatters. -1 if unusable. */
float est_smo_tanh_deadbeat_gain_v_per_a(float rs_ohm, float ls_h, float ts_s);
/** The smallest tolerance xi (eq. 15) for which the eq.-17 gain keeps k m <= F/G:
 *  xi = atanh(3 sqrt(3) Ce psi_f p w_m,max m G / (2 F)) / m [A]; -1 if no xi can (the rule's k m
 *  exceeds F/G for every xi, e.g. m = 1 on Gong's Table I) or the arguments are unusable. */
float est_smo_tanh_xi_deadbeat_a(float ce, float psi_f_wb, int pole_pairs,
                                 float omega_m_max_rad_s, float m_per_a, float rs_ohm, float ls_h,
                                 float ts_s);

#endif
