/**
 * @file mechanics.h
 * @brief Rigid rotor: J d(omega_m)/dt = T_e - B omega_m - T_load;  d(theta_e)/dt = p omega_m.
 *
 * Sign convention: positive T_load opposes positive rotation (a motoring load). T_load is an
 * active torque (held constant whatever the speed), not a friction: a positive T_load at
 * standstill drives the rotor backwards. B is viscous friction [N m s/rad].
 *
 * Optional Coulomb friction (mechanics_set_coulomb): T_c tanh(omega_m / omega_c) is added to
 * the friction torque. The tanh makes it smooth near zero speed (continuous right-hand side
 * for the integrator); it cannot hold the rotor: below |T| < T_c an applied torque makes the
 * rotor creep at omega = omega_c atanh(T / T_c) instead of sticking (no stiction model).
 *
 * Load-torque profile (mechanics_load_profile_*): a torque that is a function of time, for a
 * real-time engine that must not call back into Python each cycle:
 *   STEP   T0 for t < t0, T1 from t0 on;
 *   RAMP   T0 up to t0, linear to T1 at t1 (> t0), T1 after;
 *   TABLE  piecewise linear through (t_i, T_i), t_i strictly increasing, constant outside.
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
    double coulomb_nm;    /**< T_c [N m] (0: no Coulomb friction) */
    double inv_coulomb_band; /**< 1 / omega_c [s/rad] */
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

/**
 * Coulomb friction T_c tanh(omega / omega_c): coulomb_nm >= 0 (0 = off), band > 0 when
 * coulomb_nm > 0. Returns 0 or -1 (unchanged). mechanics_step holds the Coulomb torque at its
 * start-of-step value (the exact solution is for the linear part only).
 */
int mechanics_set_coulomb(mechanics_t *mech, double coulomb_nm, double coulomb_band_rad_s);
/** Friction torque B omega + T_c tanh(omega/omega_c) [N m] (opposes rotation). */
double mechanics_friction_torque(const mechanics_t *mech, double omega_m_rad_s);

/* ---- load-torque profile ---- */

/** Largest number of (t, T) points of a TABLE profile. */
#define MECH_LOAD_TABLE_MAX 32

typedef enum mechanics_load_kind {
    MECH_LOAD_NONE = 0,
    MECH_LOAD_STEP = 1,
    MECH_LOAD_RAMP = 2,
    MECH_LOAD_TABLE = 3
} mechanics_load_kind_t;

typedef struct mechanics_load_profile {
    int kind;                               /**< mechanics_load_kind_t */
    double t0_s, t1_s;                      /**< STEP: t0; RAMP: t0 < t1 */
    double torque0_nm, torque1_nm;          /**< STEP/RAMP: before / after */
    int table_n;                            /**< TABLE: 1 .. MECH_LOAD_TABLE_MAX points */
    double table_t_s[MECH_LOAD_TABLE_MAX];  /**< strictly increasing */
    double table_nm[MECH_LOAD_TABLE_MAX];
} mechanics_load_profile_t;

/** NULL if valid, else "field: reason" naming the plant_params field (load_*). */
const char *mechanics_load_profile_check(const mechanics_load_profile_t *lp);
/** Profile torque at time t [N m] (0 for NONE); positive opposes positive rotation. */
double mechanics_load_profile_at(const mechanics_load_profile_t *lp, double t_s);
/** Exact mean of the profile over [t_a, t_b] [N m] (the value at t_a if t_b <= t_a). */
double mechanics_load_profile_mean(const mechanics_load_profile_t *lp, double t_a_s, double t_b_s);

#endif
