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
 * the method keeps its full order: global error O(h^4). (sin/cos of the stage angles: one
 * libm call per RK4 step, rotated by each stage's small offset; exact to rounding.) With the
 * inverter non-linearity on, the right-hand side has kinks at the current zero crossings and
 * RK4 loses order there: measured 3.9e-6 of rated current at substeps 4 (plant_rt/README.md).
 * Error bound (measured, plant_rt/verify/error_study.py: C plant vs solve_ivp rtol 1e-10, rotor at
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
 *
 * Non-idealities (each switchable; a zero-initialised group is off, and with every group off
 * the plant is bit-for-bit the ideal plant described above):
 *   inverter   dead time, switch/diode drops, smooth current sign (inverter.h)
 *   magnetics  d-axis saturation psi_d(i_d) with L_inc(0) = L_d (pmsm_machine.h)
 *   sensors    12-bit (adc_bits) ADC with gain/offset errors and seeded Gaussian noise, and
 *              dual sampling (sensor.h, plant_sample below)
 *   mechanics  Coulomb friction, load-torque profile, dynamometer mode (mechanics.h)
 *   delay      full_period_delay: the new duties act from the next period boundary
 *              (identical to t_delay_s = ts_s; the flag lets a scenario ask for it without
 *              knowing Ts)
 *   switching  inverter.inverter = 1: the period integrated over its PWM segments (below)
 * Zero-initialise plant_params_t (= {0} or memset) before filling it in: every new field is
 * then off. Fields of a group that is off are not checked by plant_params_check.
 *
 * Sampling (plant_sample). The controller's ADC samples at the start of every period,
 * t_k = k Ts (the centre of the zero vector of centre-aligned PWM, where the averaged current
 * equals the instantaneous one). With dual sampling it samples a second time at the actuation
 * instant of each period, t_k + t_d (t_d = t_delay_s, or ts_s with full_period_delay): the
 * instant the new duties take effect. The second sample of period k is taken after the
 * controller's computation for period k has finished, so the controller that runs at t_k
 * knows the second sample of period k-1 (taken at t_{k-1} + t_d), not that of period k.
 * plant_sample() after the k-th plant_step (i.e. at t_k) therefore returns
 *     i_*_a  = ADC(i(t_k))                 first sample of period k      (Gong's i_x_1(k))
 *     i2_*_a = ADC(i(t_{k-1} + t_d))       second sample of period k-1   (Gong's i_x_2(k-1))
 * so Gong's eq. (21) Delta i(k) = (i_1(k) - i_2(k-1)) t_d / (Ts - t_d) can be evaluated at
 * t_k, and eq. (20) t_d = |i_2(k) - i_1(k)| / |i_2(k) - i_2(k-1)| Ts one period later (the
 * controller keeps i_1(k) and i_2(k-1) and receives i_2(k) at t_{k+1}). Before the first
 * period there is no previous actuation instant: dual_valid = 0. The samples are drawn when
 * the plant reaches the sampling instant (inside plant_step / at init and reset), so reading
 * them never changes the random stream: a seed gives the same noise whoever reads what.
 *
 * Switching mode (inverter.inverter = 1; plant_rt/README.md "Switching mode"). Centre-aligned
 * PWM with one carrier period per control period (pwm.h: the valley, or with carrier_at_start
 * the peak, at t_k); the compare values written at t_k + t_d act from the load instant of
 * pwm_load (next carrier extremum, next period, or at once: plant_actuation_delay); each leg at
 * switch level (inverter.h inverter_sw_*: dead-band gates, the dead interval decided by the
 * current's sign at its start, node slew, drops by the current's direction). The period is cut
 * at every command transition, dead-interval end and node clamp, and at the second-sample
 * instant (t_k + t_d, or t_k + Ts/2 with dual_sample_at); RK4 inside each segment in steps of
 * at most Ts/substeps, shorter while a conducting leg's current is near the drops' threshold
 * band. Measured against an independent solve_ivp model: 4.9e-7 (ideal switches) and 5.3e-7
 * (dead time and drops) of rated current at substeps 4, 2x rated speed. A period whose old or
 * new duties disable a leg, or with an open-phase / phase-short fault, takes the averaged path.
 */
#ifndef PLANT_H
#define PLANT_H

#include <stddef.h>
#include <stdint.h>

#include "inverter.h"
#include "mechanics.h"
#include "plant_fault.h"
#include "pmsm_machine.h"
#include "pwm.h"
#include "sensor.h"

/** Largest accepted substeps. */
#define PLANT_MAX_SUBSTEPS 100000
/** Diode events located per RK4 step before the rest of that step is taken in one piece. */
#define PLANT_MAX_EVENTS 8

/** Inverter non-idealities (inverter.h). */
typedef struct plant_inverter_params {
    int inverter_nonlinear;   /* 0/1 */
    double dead_time_s;       /* per commutation, 0 <= dead_time_s < ts_s / 2 */
    double v_switch_drop_v;   /* switch on-state threshold [V] */
    double r_switch_ohm;      /* switch on-state slope [ohm] */
    double v_diode_drop_v;    /* diode forward threshold [V] */
    double r_diode_ohm;       /* diode slope [ohm] */
    double i_cap_band_a;      /* parasitic-capacitance current C_node V_dc / t_dt [A], > 0 */
    /* additions (switching mode, pwm.h): 0 = the averaged inverter of above */
    int inverter;             /* 0 averaged over the period, 1 switching (PWM segments) */
    int carrier_at_start;     /* pwm_carrier_t: 0 valley, 1 peak at the period start t_k */
    int pwm_load;             /* pwm_load_t: 0 every carrier extremum, 1 once per period, 2 immediate */
} plant_inverter_params_t;

/** d-axis saturation (pmsm_machine.h). */
typedef struct plant_magnetics_params {
    int saturation;           /* 0/1 */
    double sat_l_inf_ratio;   /* L_inc far in saturation / L_d, (0, 1] */
    double sat_i_scale_a;     /* I_s > 0 [A] */
    double sat_i_knee_a;      /* i_0 in [-3 I_s, 0] [A]: where L_inc peaks */
} plant_magnetics_params_t;

/** Current and bus-voltage ADCs (sensor.h), dual sampling. */
typedef struct plant_sensor_params {
    int adc_model;            /* 0: ideal sensors (exact values); 1: ADC model below */
    int adc_bits;             /* 1..24 (12 for the F28335) */
    double adc_full_scale_a;  /* currents read [-FS, FS) */
    double adc_gain_err_ia, adc_gain_err_ib, adc_gain_err_ic;   /* relative, > -1 */
    double adc_offset_ia_a, adc_offset_ib_a, adc_offset_ic_a;   /* [A] */
    double adc_noise_a_rms;   /* Gaussian, before quantisation [A rms] */
    double adc_vdc_full_scale_v;  /* bus voltage read [0, FS) */
    double adc_vdc_gain_err, adc_vdc_offset_v, adc_vdc_noise_v_rms;
    uint64_t adc_seed;        /* seed of the noise generator (xoshiro256** via splitmix64) */
    int dual_sampling;        /* 0/1: second current sample at the actuation instant */
    int dual_sample_at;       /* 0: at t_k + t_d (the write instant); 1: at t_k + Ts/2 (switching) */
} plant_sensor_params_t;

/** Friction, load profile, dynamometer (mechanics.h). */
typedef struct plant_mechanics_params {
    double coulomb_nm;            /* T_c >= 0 (0: none) */
    double coulomb_band_rad_s;    /* omega_c > 0 of T_c tanh(omega/omega_c) */
    int load_profile;             /* mechanics_load_kind_t: 0 none, 1 step, 2 ramp, 3 table */
    double load_t0_s, load_t1_s, load_torque0_nm, load_torque1_nm;
    int load_table_n;
    double load_table_t_s[MECH_LOAD_TABLE_MAX];
    double load_table_nm[MECH_LOAD_TABLE_MAX];
    int dyno;                     /* 0/1: speed imposed by a dynamometer */
    double dyno_speed_rad_s;      /* initial set speed (plant_set_dyno_speed changes it) */
    double dyno_accel_rad_s2;     /* slew rate towards the set speed; 0 = steps at a period start */
} plant_mechanics_params_t;

/** A fine trace of one switching-mode period (plant_step_trace): caller-owned arrays of n. */
typedef struct plant_trace {
    int n;                /* instants t_k + (j + 1) Ts / n, j = 0 .. n-1; n >= 1 */
    double *i_alpha_a, *i_beta_a;   /* stator currents at those instants [A] */
    double *v_alpha_v, *v_beta_v;   /* phase voltages averaged over the Ts / n before each [V] */
    double *theta_e_rad;            /* rotor angle at those instants [rad, wrapped] */
} plant_trace_t;

typedef struct plant_params {
    double rs_ohm, ld_h, lq_h, psi_f_wb; int pole_pairs;   /* machine */
    double j_kgm2, b_nms;                                    /* mechanics (viscous B in N m s/rad) */
    double v_dc_v;                                           /* DC bus */
    double ts_s;        /* control (PWM) period */
    double t_delay_s;   /* sampling instant -> new duties take effect; 0 <= t_delay_s <= ts_s */
    int substeps;       /* RK4 sub-steps per period, >= 1 */
    /* ---- non-idealities (zero = off) ---- */
    int full_period_delay;   /* 0/1: new duties act from t_k + ts_s (t_delay_s is then ignored) */
    plant_inverter_params_t inverter;
    plant_magnetics_params_t magnetics;
    plant_sensor_params_t sensors;
    plant_mechanics_params_t mechanics;
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
    /* additions (ground truth for flux observers, friction) */
    double psi_alpha_wb, psi_beta_wb; /* stator flux linkage (PM + stator currents, saturation included) */
    double torque_friction_nm;        /* B omega_m + Coulomb */
} plant_snapshot_t;

/**
 * What the controller's ADC measured for the period just begun (see "Sampling" above).
 * With adc_model = 0 the values are exact and the codes are -1.
 */
typedef struct plant_sample {
    double t_s;                     /* t_k: first sampling instant */
    double i_a_a, i_b_a, i_c_a;     /* phase currents at t_k [A] */
    double v_dc_v;                  /* bus voltage at t_k [V] */
    double t2_s;                    /* t_{k-1} + t_d: instant of the second sample */
    double i2_a_a, i2_b_a, i2_c_a;  /* phase currents at t2_s [A] (0 unless dual_valid) */
    int code_a, code_b, code_c, code_vdc;   /* raw ADC codes of the first sample */
    int code2_a, code2_b, code2_c;          /* raw ADC codes of the second sample */
    int dual_valid;                 /* 1: dual sampling on and k >= 1 */
    /* additions (faults) */
    double theta_enc_rad;           /* encoder angle at t_k (electrical, [0, 2pi)): theta_e unless
                                       an encoder fault is on */
    int enc_valid;                  /* 0 with ENCODER_LOSS */
} plant_sample_t;

/** Energy bookkeeping since plant_init/plant_reset [J]. */
typedef struct plant_energy {
    double electrical_in_j; /**< int sum_x v_x i_x dt, delivered by the inverter (< 0 when braking into the bus) */
    double copper_loss_j;   /**< int 1.5 R (i_d^2 + i_q^2) dt */
    double viscous_loss_j;  /**< int B omega_m^2 dt */
    double load_work_j;     /**< int T_load omega_m dt, work done against the load */
    double magnetic_j;      /**< present field energy of the stator currents (0.75 (L_d i_d^2 + L_q i_q^2) when linear) */
    double kinetic_j;       /**< present 0.5 J omega_m^2 */
    /* additions */
    double coulomb_loss_j;  /**< int T_c tanh(omega/omega_c) omega_m dt */
    double inverter_loss_j; /**< int sum_x (f_x V_dc - v_xN) i_x dt: conduction losses (0 when ideal) */
    double dc_bus_in_j;     /**< int V_dc i_dc dt = electrical_in_j + inverter_loss_j (+ short_loss_j) */
    /* additions (faults, plant_fault.h) */
    double short_loss_j;    /**< int R_f i_f^2 dt in a phase-to-phase short (delivered by the inverter) */
    double fault_absorbed_j;/**< magnetic energy released when an open-phase fault cut a current */
} plant_energy_t;
/* Balance: electrical_in = copper + viscous + coulomb + load_work + fault_absorbed
 *          + (magnetic + kinetic) - (their values at the start);
 *          dc_bus_in = electrical_in + inverter_loss + short_loss.
 * In dynamometer mode load_work is the work done on the dynamometer (int T_dyno omega_m dt,
 * including the kinetic energy of a speed step, booked at the step). */

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
    double energy[7];      /* electrical_in, copper, viscous, load, coulomb, inverter loss, short loss [J] */
    unsigned long events;  /* diode events located since reset (diagnostic) */
    /* non-idealities */
    double t_delay_eff_s;  /* t_delay_s, or ts_s with full_period_delay */
    double t_act_offset_s; /* actuation instant of the last period after its start */
    mechanics_load_profile_t load;
    double torque_load_period_nm; /* set torque + profile mean over the present period */
    double dyno_target_rad_s;
    double dyno_accel_now_rad_s2; /* imposed acceleration over the present/last period */
    sensor_rng_t rng;
    sensor_adc_config_t adc_i[3], adc_vdc;
    plant_sample_t sample;        /* what plant_sample returns */
    /* faults (plant_fault.h) */
    plant_fault_state_t faults;
    double sample_noise[4];       /* Gaussian deviates of the first sample (a, b, c, bus) */
    /* switching mode (params.inverter.inverter = 1) */
    pwm_t pwm;                    /* carrier, compare loading; the command levels at t_k */
    inverter_sw_leg_t sw_leg[3];  /* each leg's gates and dead interval at t_k */
    double t2_offset_s;           /* instant of the last second sample after its period's start */
    double sw_l_min_h;            /* smallest inductance (the current's fastest slope) [H] */
    unsigned long sw_periods;     /* periods integrated at switch level since reset (diagnostic) */
    const plant_trace_t *trace;   /* plant_step_trace: where the period's fine trace goes */
} plant_t;

/** NULL if valid, else "field: reason" (static string), e.g. "ld_h: must be > 0". */
const char *plant_params_check(const plant_params_t *p);
/** The part of plant_params_check for the non-ideality groups (called by it, last). */
const char *plant_params_check_nonideal(const plant_params_t *p);
/** The load profile described by the mechanics group (for stand-alone use of mechanics.h). */
void plant_load_profile_from_params(const plant_mechanics_params_t *me, mechanics_load_profile_t *lp);
/** 0, or -1 if params invalid; zero state, t=0, previous duties = 0.5 (zero voltage). */
int plant_init(plant_t *pl, const plant_params_t *p);
/**
 * Back to the state right after plant_init (zero currents and speed, t = 0, no load torque,
 * noise generator reseeded, the first sample of period 0 drawn; in dyno mode the speed is the
 * dyno's initial set speed).
 */
void plant_reset(plant_t *pl);
/** Set rotor angle (wrapped into [0, 2pi); theta_m = theta_e/p) and speed; currents and t untouched. */
void plant_set_initial(plant_t *pl, double theta_e_rad, double omega_m_rad_s);
/** Load torque [N m] from now on, added to the load profile; positive opposes positive
 *  rotation. The load acting over a period is the set torque + the profile's exact mean over
 *  that period. Ignored in dyno mode. */
void plant_set_load_torque(plant_t *pl, double torque_nm);
/** Advance exactly one period. duty in [0,1] = high-side on-time fraction; < 0 or NaN disables the leg; > 1 is clamped. */
void plant_step(plant_t *pl, const double duty_abc[3]);
/** Instantaneous state at the current t (= the next sampling instant) plus last-period averages. */
void plant_snapshot(const plant_t *pl, plant_snapshot_t *out);

/* ---- additions (not needed by a minimal client) ---- */

/**
 * plant_step with the actuation instant given for this period: the previous duties act over
 * [t_k, t_k + t_split_s), the new ones over [t_k + t_split_s, t_k + Ts) (t_split_s clamped to
 * [0, Ts]; NaN = 0). The real-time engine passes the measured DUTY arrival (on-arrival update)
 * or 0 (shadow load at the period boundary). Same integration rule and error bound as
 * plant_step; the second (dual) sample is taken at the split.
 */
void plant_step_split(plant_t *pl, const double duty_abc[3], double t_split_s);
/**
 * plant_step that also records the period at the tr->n instants of tr (analysis: what a
 * continuous-time observer or a fast ADC would see of the PWM ripple). Switching mode only:
 * returns 0 if the period was integrated at switch level and tr filled, -1 otherwise (averaged
 * mode, or a period on the averaged path: the step is taken, tr is left untouched). The trace
 * adds segment boundaries only: the state at the period end agrees with plant_step's to the
 * integrator's accuracy (its RK4 steps are cut differently).
 */
int plant_step_trace(plant_t *pl, const double duty_abc[3], const plant_trace_t *tr);
/** plant_step with the duties as three arguments (cheaper through an FFI). */
void plant_step_abc(plant_t *pl, double duty_a, double duty_b, double duty_c);
/**
 * n periods in one call: duties_abc holds n rows of (a, b, c). If out is not NULL, out[k] is
 * the snapshot after period k (taken at t_{k+1}).
 */
void plant_run(plant_t *pl, const double *duties_abc, size_t n, plant_snapshot_t *out);
/** Energy bookkeeping (see plant_energy_t). */
void plant_energy(const plant_t *pl, plant_energy_t *out);

/* ---- non-idealities ---- */

/**
 * What the controller's ADC measured for the period that starts at the present time t_k
 * (first sample at t_k, and with dual sampling the second sample of period k-1 at
 * t_{k-1} + t_d). Pure read: the samples were drawn when the plant reached those instants.
 */
void plant_sample(const plant_t *pl, plant_sample_t *out);
/**
 * When the duties commanded for a period start acting, after its start [s]: t_delay_s (ts_s
 * with full_period_delay) in the averaged mode; in the switching mode the compare values
 * written then act from the load instant of pwm.h (the next carrier extremum with
 * pwm_load = extremum, the next period start with period, at once with immediate). What a
 * controller's delay compensation must assume.
 */
double plant_actuation_delay(const plant_t *pl);
/** Dynamometer set speed [rad/s, mechanical] (dyno mode; ignored otherwise). */
void plant_set_dyno_speed(plant_t *pl, double omega_m_rad_s);
/** Total load torque the plant applies at time t [N m]: set torque + profile(t) (not the dyno). */
double plant_load_torque_at(const plant_t *pl, double t_s);

/* ---- faults (plant_fault.c; physics and timing in plant_fault.h) ---- */

/** NULL if the fault can be set on this plant now, else "field: reason" (static string). */
const char *plant_fault_check(const plant_t *pl, const plant_fault_t *f);
/** Switch a fault on (replacing one of the same kind, or of the same kind and phase for
 *  LEG_STUCK and SENSOR_*: one sensor fault per phase). 0, or -1 (nothing changed) if
 *  plant_fault_check refuses it. */
int plant_set_fault(plant_t *pl, const plant_fault_t *f);
/** Switch a fault kind off; phase selects the leg / sensor for LEG_STUCK and SENSOR_* (-1: all
 *  phases; ignored for the other kinds). Clearing a kind that is off does nothing. */
void plant_clear_fault(plant_t *pl, int kind, int phase);
/** Every fault off (plant_reset does this too). */
void plant_clear_faults(plant_t *pl);
/** Bitmask of the kinds that are on (bit 1u << kind). */
unsigned plant_faults_active(const plant_t *pl);
/** What the faults do at the present time (short current, leg currents, bus, diagnostics). */
void plant_fault_status(const plant_t *pl, plant_fault_status_t *out);

#endif
