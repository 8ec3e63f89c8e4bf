/**
 * @file mechanics.h
 * @brief Rigid rotor: J d(omega_m)/dt = T_e - B omega_m - T_load;  d(theta_e)/dt = p omega_m.
 *
 * Sign convention: positive T_load opposes positive rotation (a motoring load). T_load is an
 * active torque (held constant whatever the speed), not a friction: a positive T_load at
 * standstill drives the rotor backwards. B is viscous friction [N m s/rad].
 */
#ifndef MECHANICS_H
#define MECHANICS_H

/** Constants (SI). */
typedef struct mechanics_config {
    double j_kgm2;  /**< rotor + load inertia [kg m^2], > 0 */
    double b_nms;   /**< viscous friction [N m s/rad], >= 0 */
    int pole_pairs; /**< p [-], >= 1 */
} mechanics_config_t;

/** Config, derived coefficients and state (caller owns the memory). */
typedef struct mechanics {
    mechanics_config_t cfg;
    double inv_j;         /**< 1/J [1/(kg m^2)] */
    double omega_m_rad_s; /**< mechanical speed [rad/s] */
    double theta_m_rad;   /**< mechanical angle, unwrapped [rad] */
} mechanics_t;

/** Returns 0, or -1 if J <= 0, B < 0, p < 1 or non-finite. */
int mechanics_init(mechanics_t *mech, const mechanics_config_t *cfg);
/** Standstill at angle 0. */
void mechanics_reset(mechanics_t *mech);

/** d(omega_m)/dt [rad/s^2] for speed [rad/s], electromagnetic and load torques [N m]. */
double mechanics_accel(const mechanics_t *mech, double omega_m_rad_s, double torque_e_nm,
                       double torque_load_nm);

/**
 * Stand-alone use: advance speed and angle by dt_s [s] with constant torques, using the exact
 * solution of the linear ODE (exponential for B > 0, uniform acceleration for B = 0).
 */
void mechanics_step(mechanics_t *mech, double torque_e_nm, double torque_load_nm, double dt_s);

#endif
