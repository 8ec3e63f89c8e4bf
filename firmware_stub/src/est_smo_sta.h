/**
 * @file est_smo_sta.h
 * @brief Second-order (super-twisting) sliding-mode observer: the comparator Hou et al. cite,
 * "the improved SMO method mentioned in [8]" = D. Liang, J. Li, R. Qu, "Sensorless control of
 * permanent magnet synchronous machine based on second-order sliding-mode observer with online
 * resistance estimation", IEEE TIA 53(4), 2017 - without [8]'s online resistance estimate.
 *
 * Hou gives no equation of it; [8]'s title fixes the structure (a second-order SMO, i.e. the
 * super-twisting algorithm, plus an online resistance estimate). This module writes the STA from
 * its standard form (Levant 1993; the gain condition of Levant 1998 / Moreno & Osorio 2012), not
 * from [8]'s text, which the bench does not have: [8]'s own gains may differ. The resistance law
 * is not recoverable from the citation, and the one a Lyapunov function of the current error
 * gives (R^' = gamma i~.i^) drifts to its limit in the sampled STA (in the sliding mode i~ is the
 * chattering, not the resistance's signature; measured in docs/estimators_smo.md, "Hou's
 * comparator"): R is the nameplate value here.
 *
 * Current model in alpha-beta (extended-EMF form with Ls = Lq, as est_smo_sign; exact for an
 * IPMSM at i_d = 0 in steady state):
 *   Ls d i^/dt = -R i^ + u - z,      i~ = i^ - i
 *   z = k1 |i~|^{1/2} sign(i~) + w,  dw/dt = k2 sign(i~)        (super-twisting)
 *   E^ = z                                                      (continuous: no low-pass, no lag)
 *   theta^ = atan2(-E^a, E^b) by est_emf_angle_step (direction), speed from its PLL
 *
 * Gains. With x = i~, the error dynamics are the STA with the perturbation rho = e'/Ls, |rho| <=
 * delta = |w^|^2 psi_f / Ls (e = w psi_f at constant speed). The sufficient condition
 * k2/Ls > delta, (k1/Ls)^2 >= 4 delta (k2/Ls + delta)/(k2/Ls - delta) is met with margin m by
 *   k2 = 2 m Ls delta,   k1 = m Ls sqrt(12 delta)
 * (k2/Ls = 2 delta gives (k1/Ls)^2 >= 12 delta). With k1_v, k2_v_s <= 0 the gains follow the
 * speed estimate: delta at max(min(|w^|, 2 |E^| / psi_f), omega_min_rad_s) (the speed capped by
 * what the observed EMF supports, as est_smo_sign's gain; omega_min keeps the observer able to
 * catch a start from standstill).
 *
 * Discretisation: the current model exactly over one period with the voltage and z held (ZOH):
 * i^[k+1] = F i^[k] + G (u - z), F = exp(-R Ts/Ls), G = (1 - F)/R; w by forward Euler.
 * Step inputs: the currents sampled at t_k and the voltage applied over [t_{k-1}, t_k].
 */
#ifndef EST_SMO_STA_H
#define EST_SMO_STA_H

#include "est_common.h"
#include "fw_math.h"

typedef struct {
    float rs_ohm;          /**< stator resistance */
    float ls_h;            /**< Lq (extended-EMF form) */
    float psi_f_wb;        /**< PM flux linkage (the adaptive gains) */
    float ts_s;            /**< step period */
    float k1_v;            /**< STA proportional gain [V/sqrt(A)]; <= 0: adaptive (above) */
    float k2_v_s;          /**< STA integral gain [V/s]; <= 0: adaptive */
    float k_margin;        /**< m of the adaptive gains, >= 1 */
    float omega_min_rad_s; /**< adaptive gains at no less than this electrical speed */
    float pll_kp;          /**< PLL proportional gain [1/s] */
    float pll_ki;          /**< PLL integral gain [1/s^2] */
    float speed_lpf_rad_s; /**< first-order filter on the speed output; <= 0 disables */
    float dir_speed_rad_s; /**< est_emf_angle_step's hold band (EST_EMF_DIR_SPEED_RAD_S) */
} est_smo_sta_config_t;

typedef struct {
    est_smo_sta_config_t cfg;
    float a_speed;     /**< 1 - exp(-w_lpf Ts), 1 if disabled */
    float f, g;        /**< current model: exp(-R Ts/Ls), (1 - f)/R [A/V] */
    /* state */
    fw_vec2_t i_hat_a; /**< estimated current */
    fw_vec2_t w_v;     /**< STA integral term */
    fw_vec2_t z_v;     /**< STA output of the last step (= E^) */
    float k1_now, k2_now; /**< gains in use */
    est_pll_t pll;
    est_emf_dir_t dir;
    est_output_t out;
} est_smo_sta_t;

/** Defaults for a motor: adaptive gains (margin 1.5, omega_min 2 pi 5 Hz electrical). */
void est_smo_sta_default_config(est_smo_sta_config_t *cfg, float rs_ohm, float ls_h,
                                float psi_f_wb, float ts_s);
/** 0, or -1 if unusable (Ls, Ts <= 0, R < 0, margin < 1, non-finite gains). */
int est_smo_sta_init(est_smo_sta_t *s, const est_smo_sta_config_t *cfg);
void est_smo_sta_reset(est_smo_sta_t *s);
/** One step: measured i_ab at t_k, voltage applied over the previous period. */
const est_output_t *est_smo_sta_step(est_smo_sta_t *s, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v);
/** The adaptive gains at electrical speed omega_e_rad_s (k1 [V/sqrt(A)], k2 [V/s]). */
void est_smo_sta_gains(const est_smo_sta_config_t *cfg, float omega_e_rad_s, float *k1_v,
                       float *k2_v_s);

#endif
