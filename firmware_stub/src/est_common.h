/**
 * @file est_common.h
 * @brief What every angle estimator gives: the same outputs an encoder interface would,
 * so FOC holds a pointer to an est_output_t and does not know how it was produced.
 */
#ifndef EST_COMMON_H
#define EST_COMMON_H

typedef struct {
    float theta_e_rad;   /**< estimated electrical angle of the d axis, [0, 2pi) */
    float omega_e_rad_s; /**< estimated electrical angular speed */
    float e_alpha_v;     /**< estimated back EMF, alpha axis (0 if the method has none) */
    float e_beta_v;      /**< estimated back EMF, beta axis */
} est_output_t;

/** Angle-tracking PLL used to turn an angle into a speed (a type-2 loop: zero lag on a ramp). */
typedef struct {
    float kp;       /**< proportional gain [1/s] (2*zeta*wn) */
    float ki;       /**< integral gain [1/s^2] (wn^2) */
    float theta_rad;
    float omega_rad_s;  /**< integrator = speed estimate */
} est_pll_t;

void est_pll_init(est_pll_t *pll, float kp, float ki);
void est_pll_reset(est_pll_t *pll, float theta_rad, float omega_rad_s);
/** One step tracking theta_in_rad; returns the speed estimate. */
float est_pll_step(est_pll_t *pll, float theta_in_rad, float ts_s);

/** Gains of a critically damped PLL of natural frequency wn_rad_s. */
void est_pll_gains(float wn_rad_s, float *kp, float *ki);

#endif
