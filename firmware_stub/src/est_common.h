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

/** Default of the SMOs' dir_speed_rad_s (electrical rad/s). */
#define EST_EMF_DIR_SPEED_RAD_S 1.0f
/** How long the speed must contradict the PLL angle's polarity before it is re-aligned [s]. */
#define EST_EMF_RESYNC_S 0.01f

/** Direction-of-rotation state of est_emf_angle_step. */
typedef struct {
    int dir;        /**< +1 / -1: the EMF's polarity relative to the PLL angle (= direction) */
    int disagree_n; /**< evidence against the PLL angle's polarity, in steps */
} est_emf_dir_t;

void est_emf_dir_reset(est_emf_dir_t *d);

/**
 * The rotor angle from a back-EMF vector, for either direction of rotation, and the speed.
 *
 * e = w psi_f (-sin theta, cos theta): atan2(-e_a, e_b) is theta for w > 0 but theta + pi for
 * w < 0, while the vector turns at w either way. So the PLL tracks that angle modulo pi (an
 * error beyond pi/2 is folded by pi: the EMF reversing never kicks it): its speed is the signed
 * rotor speed and its angle keeps the rotor's polarity by continuity, through a reversal too.
 * Per step:
 *  - dir = the EMF angle's polarity relative to the PLL angle (-1: pi apart);
 *  - where the PLL speed w and its instantaneous frequency w + kp err (lag-free on a speed
 *    ramp) agree in sign and both reach dir_speed_rad_s, the speed's sign is evidence for
 *    (sign = dir) or against the PLL angle's polarity: a counter goes up on evidence against,
 *    down on evidence for, and holds otherwise; when it reaches EST_EMF_RESYNC_S worth of steps
 *    the PLL angle is pi off (a start-up locked the wrong way, a slip at low speed) and is
 *    re-aligned by pi;
 *  - output: the EMF angle + pi for dir < 0 where |w| >= dir_speed_rad_s, the PLL angle below
 *    (where the EMF is too small to trust its angle). dir_speed_rad_s <= 0: no hold band.
 *
 * theta_emf_rad: atan2(-e_a, e_b) plus any lag compensation (signed with w). Returns the angle
 * in [0, 2pi); the speed is pll->omega_rad_s.
 */
float est_emf_angle_step(est_pll_t *pll, est_emf_dir_t *d, float theta_emf_rad,
                         float dir_speed_rad_s, float ts_s);

#endif
