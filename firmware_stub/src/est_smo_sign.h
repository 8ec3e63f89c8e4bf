/**
 * @file est_smo_sign.h
 * @brief Conventional sliding-mode observer with sign switching and a low-pass filter.
 *
 * Yuan et al., IEEE Access 2020, eq. (4)-(10); Gong et al., IEEE TIE, eq. (3)-(7).
 *
 *   d/dt i^ = -(R/Ls) i^ + u/Ls - (k/Ls) sign(i^ - i)         (Yuan 4, Gong 3-4)
 *   E^     = LPF_wc{ k sign(i^ - i) }                          (Yuan 7, Gong 6 + Fig. 2)
 *   theta^ = -atan(E^a / E^b) + atan(w^e / wc)                 (Yuan 8-9, Gong 7), full quadrant
 *   w^e    = sqrt(E^a^2 + E^b^2) / psi_f                       (Yuan 10)  [speed_from_emf = 1]
 *            or the speed of a PLL tracking theta^             [speed_from_emf = 0, default]
 *
 * Discretisation: the current model is integrated exactly over one period with the voltage and
 * switching term held (zero-order hold): i^[k+1] = F i^[k] + G (u - z), F = exp(-R Ts/Ls),
 * G = (1 - F)/R. The LPF is the ZOH equivalent of wc/(s + wc). The gain k follows eq. (5):
 * k >= max|e|; with k_v <= 0 it adapts as
 *   k = max(k_min_v, k_factor * min(|w^e| psi_f, 2 |E^| sqrt(1 + (w^e/wc)^2)))
 * i.e. |e| from the speed estimate, capped by the EMF the observer sees (LPF attenuation undone):
 * near zero speed a stray PLL speed must not raise the gain (a positive feedback, see the .c).
 *
 * Step inputs: the currents sampled at t_k and the voltage applied over [t_{k-1}, t_k].
 */
#ifndef EST_SMO_SIGN_H
#define EST_SMO_SIGN_H

#include "est_common.h"
#include "fw_math.h"

typedef struct {
    float rs_ohm;          /**< stator resistance */
    float ls_h;            /**< stator inductance (SPMSM: Ld = Lq) */
    float psi_f_wb;        /**< PM flux linkage (for eq. 10 and the adaptive gain) */
    float ts_s;            /**< step period */
    float k_v;             /**< switching gain k; <= 0 selects the adaptive gain */
    float k_factor;        /**< adaptive gain: k = k_factor * |w^e| * psi_f (capped, above) ... */
    float k_min_v;         /**< ... but not below k_min_v */
    float wc_rad_s;        /**< LPF cut-off */
    int speed_from_emf;    /**< 1: Yuan eq. 10; 0: PLL on the angle */
    float pll_kp;          /**< PLL proportional gain [1/s] (speed_from_emf = 0) */
    float pll_ki;          /**< PLL integral gain [1/s^2] */
    float speed_lpf_rad_s; /**< first-order filter on the speed output; <= 0 disables */
    float dir_speed_rad_s; /**< |electrical speed| below which the direction of rotation is held
                              and the PLL angle is output (est_emf_angle_step); default
                              EST_EMF_DIR_SPEED_RAD_S */
} est_smo_sign_config_t;

typedef struct {
    est_smo_sign_config_t cfg;
    /* derived coefficients */
    float f;       /**< exp(-R Ts / Ls) */
    float g;       /**< (1 - f) / R  [A/V], or Ts/Ls if R = 0 */
    float a_lpf;   /**< 1 - exp(-wc Ts) */
    float a_speed; /**< 1 - exp(-w_lpf Ts), 1 if disabled */
    /* state */
    fw_vec2_t i_hat_a; /**< estimated current at the current step */
    fw_vec2_t z_v;     /**< switching term k*sign(err) of the last step */
    fw_vec2_t e_hat_v; /**< filtered EMF */
    float k_now_v;     /**< gain in use */
    est_pll_t pll;
    est_emf_dir_t dir; /**< direction of rotation (est_emf_angle_step) */
    est_output_t out;
} est_smo_sign_t;

/** Fill a configuration with neutral defaults for a motor (caller still sets gains). */
void est_smo_sign_default_config(est_smo_sign_config_t *cfg, float rs_ohm, float ls_h,
                                 float psi_f_wb, float ts_s);
/** 0 on success, -1 if the configuration is not usable (non-positive Ls, Ts, wc). */
int est_smo_sign_init(est_smo_sign_t *s, const est_smo_sign_config_t *cfg);
void est_smo_sign_reset(est_smo_sign_t *s);
/** One step: measured i_ab at t_k, voltage applied over the previous period. */
const est_output_t *est_smo_sign_step(est_smo_sign_t *s, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v);

#endif
