/**
 * @file plant.h
 * @brief PMSM + inverter + mechanics plant, stepped one PWM period per control cycle.
 *
 * Composition (each part testable alone): pmsm_machine (dq electrical model, Ld != Lq),
 * inverter (averaged two-level VSI, diodes on disabled legs), mechanics (rigid rotor).
 * The plant owns the state vector y = (i_d, i_q, omega_m, theta_e) and integrates it.
 *
 * Timing. Period k runs from t_k to t_k + Ts. The currents are sampled at t_k (what
 * plant_snapshot reports after the previous plant_step). The duties commanded for period k
 * take effect at t_k + t_delay_s; before that the previous duties hold. One plant_step
 * integrates [t_k, t_k + t_delay) with the old duties and [t_k + t_delay, t_k + Ts) with the
 * new ones; the split falls exactly on the delay instant.
 *
 * Integration method. Classical fixed-step 4th-order Runge-Kutta on (i_d, i_q, omega_m,
 * theta_e). Each of the two intervals (length t_delay and Ts - t_delay) is cut into
 * ceil(substeps * length / Ts) equal steps, so every step is h <= Ts/substeps and a period
 * costs substeps or substeps + 1 RK4 steps. The inputs are constant within each interval, so
 * the method keeps its full order: global error O(h^4).
 * Error bound (measured, plant_rt/error_study.py: C plant vs solve_ivp rtol 1e-10, rotor at
 * 2x rated speed, zero-current start into a rated-current operating point, 50 ms; worst of
 * gong2020 / hou2021 / yuan2020 and of t_delay = profile / 0 -- t_delay = 0 gives the longest
 * steps, h = Ts/substeps):
 *     max |current error| / rated current ~= 3.0e-4 * substeps^-4
 *     substeps 1: 3.0e-4   2: 1.8e-5   4: 1.1e-6   8: 7.0e-8   16: 4.4e-9
 * (speed error ~1.0e-6 rad/s, electrical angle error ~1.1e-8 rad at substeps 4). The
 * profiles use substeps = 4: < 1e-4 of rated current with a ~90x margin (substeps 2 meets it
 * with a 5x margin, which the omega_e^4 growth of the error uses up at ~3x rated speed).
 * Diode events (a disabled leg's current reaching zero, an open phase's terminal voltage
 * reaching a rail) are located inside the RK4 step by root finding (Illinois, to 1e-15 of the
 * step) and the step is restarted there; at most PLANT_MAX_EVENTS events are located per RK4
 * step, later ones in that step are handled at its end.
 *
 * Conventions: SI units, amplitude-invariant Clarke/Park (see pmsm_machine.h), theta_e of the
 * d axis (PM north), positive load torque opposes positive rotation. Double precision, host
 * only, no heap, no clock: time advances only through plant_step. Needs IEEE semantics (NaN
 * duties disable a leg, non-finite parameters are rejected): do not build with -ffast-math.
 */
#ifndef PLANT_H
#define PLANT_H

#include <stddef.h>

#include "inverter.h"
#include "mechanics.h"
#include "pmsm_machine.h"

/** Largest accepted substeps. */
#define PLANT_MAX_SUBSTEPS 100000
/** Diode events located per RK4 step before the rest of that step is taken in one piece. */
#define PLANT_MAX_EVENTS 8

typedef struct plant_params {
    double rs_ohm, ld_h, lq_h, psi_f_wb; int pole_pairs;   /* machine */
    double j_kgm2, b_nms;                                    /* mechanics (viscous B in N m s/rad) */
    double v_dc_v;                                           /* DC bus */
    double ts_s;        /* control (PWM) period */
    double t_delay_s;   /* sampling instant -> new duties take effect; 0 <= t_delay_s <= ts_s */
    int substeps;       /* RK4 sub-steps per period, >= 1 */
} plant_params_t;

typedef struct plant_snapshot {
    double t_s;
    double i_a_a, i_b_a, i_c_a, i_alpha_a, i_beta_a, i_d_a, i_q_a;
    double omega_m_rad_s, omega_e_rad_s, theta_e_rad /* wrapped [0,2pi) */, theta_m_rad /* unwrapped */;
    double torque_e_nm, torque_load_nm;
    double e_alpha_v, e_beta_v;   /* true back EMF: -w_e psi_f sin(theta_e), w_e psi_f cos(theta_e) */
    double v_dc_v;
    double v_a_v, v_b_v, v_c_v, v_alpha_v, v_beta_v, v_d_v, v_q_v;  /* applied phase voltages averaged over the last completed period (d/q: averaged in the rotating frame) */
    double duty_a, duty_b, duty_c; /* duties in effect at the end of the last period */
} plant_snapshot_t;

/** Energy bookkeeping since plant_init/plant_reset [J]. */
typedef struct plant_energy {
    double electrical_in_j; /**< int sum_x v_x i_x dt, delivered by the inverter (< 0 when braking into the bus) */
    double copper_loss_j;   /**< int 1.5 R (i_d^2 + i_q^2) dt */
    double viscous_loss_j;  /**< int B omega_m^2 dt */
    double load_work_j;     /**< int T_load omega_m dt, work done against the load */
    double magnetic_j;      /**< present 0.75 (L_d i_d^2 + L_q i_q^2) */
    double kinetic_j;       /**< present 0.5 J omega_m^2 */
} plant_energy_t;

/**
 * The system object. The caller owns the memory; treat the fields as private (t_s and events
 * may be read). The parts' own state fields mirror the plant state after every step.
 */
typedef struct plant {
    plant_params_t params;
    pmsm_machine_t machine;
    inverter_t inverter;
    mechanics_t mech;
    /* derived timing: segment 0 = [t_k, t_k+t_delay), segment 1 = [t_k+t_delay, t_k+Ts) */
    int seg_steps[2];
    double seg_h_s[2];
    /* state */
    double t_s;
    unsigned long period;
    double y[4];           /* i_d [A], i_q [A], omega_m [rad/s], theta_e [rad, wrapped] */
    double theta_m_rad;    /* unwrapped mechanical angle */
    double torque_load_nm;
    double duty_prev[3];   /* sanitised duties in effect before the delay instant */
    double duty_now[3];    /* sanitised duties commanded for the last period */
    double v_avg[5];       /* last-period averages: v_a, v_b, v_c, v_d, v_q [V] */
    double energy[4];      /* electrical_in, copper, viscous, load [J] */
    unsigned long events;  /* diode events located since reset (diagnostic) */
} plant_t;

/** NULL if valid, else "field: reason" (static string), e.g. "ld_h: must be > 0". */
const char *plant_params_check(const plant_params_t *p);
/** 0, or -1 if params invalid; zero state, t=0, previous duties = 0.5 (zero voltage). */
int plant_init(plant_t *pl, const plant_params_t *p);
/** Back to the state right after plant_init (zero currents and speed, t = 0, no load torque). */
void plant_reset(plant_t *pl);
/** Set rotor angle (wrapped into [0, 2pi); theta_m = theta_e/p) and speed; currents and t untouched. */
void plant_set_initial(plant_t *pl, double theta_e_rad, double omega_m_rad_s);
/** Load torque [N m] from now on; positive opposes positive rotation. */
void plant_set_load_torque(plant_t *pl, double torque_nm);
/** Advance exactly one period. duty in [0,1] = high-side on-time fraction; < 0 or NaN disables the leg; > 1 is clamped. */
void plant_step(plant_t *pl, const double duty_abc[3]);
/** Instantaneous state at the current t (= the next sampling instant) plus last-period averages. */
void plant_snapshot(const plant_t *pl, plant_snapshot_t *out);

/* ---- additions (not needed by a minimal client) ---- */

/** plant_step with the duties as three arguments (cheaper through an FFI). */
void plant_step_abc(plant_t *pl, double duty_a, double duty_b, double duty_c);
/**
 * n periods in one call: duties_abc holds n rows of (a, b, c). If out is not NULL, out[k] is
 * the snapshot after period k (taken at t_{k+1}).
 */
void plant_run(plant_t *pl, const double *duties_abc, size_t n, plant_snapshot_t *out);
/** Energy bookkeeping (see plant_energy_t). */
void plant_energy(const plant_t *pl, plant_energy_t *out);

#endif
