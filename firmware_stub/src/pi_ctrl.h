/**
 * @file pi_ctrl.h
 * @brief Discrete PI controller with output clamp and conditional-integration anti-windup.
 *
 * Parallel form: u = kp*e + ki*integral(e). Backward-Euler integral, Ts is a step input.
 * The integrator is frozen while the output is saturated in the direction of the error
 * (clamping anti-windup), so a long saturation does not wind it up.
 */
#ifndef PI_CTRL_H
#define PI_CTRL_H

typedef struct {
    float kp;      /**< proportional gain [output unit / input unit] */
    float ki;      /**< integral gain [output unit / (input unit * s)] */
    float out_min; /**< lower output limit */
    float out_max; /**< upper output limit */
} pi_ctrl_config_t;

typedef struct {
    pi_ctrl_config_t cfg;
    float integ; /**< integrator state, in output units */
    float out;   /**< last output */
} pi_ctrl_t;

void pi_ctrl_init(pi_ctrl_t *pi, const pi_ctrl_config_t *cfg);
void pi_ctrl_reset(pi_ctrl_t *pi, float integ);
/** One step with error e = ref - meas and period ts_s; returns the clamped output. */
float pi_ctrl_step(pi_ctrl_t *pi, float error, float ts_s);
/** Change the output limits at run time (e.g. voltage limit follows the bus). */
void pi_ctrl_set_limits(pi_ctrl_t *pi, float out_min, float out_max);

#endif
