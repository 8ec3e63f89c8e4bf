/**
 * @file ctrl_protect.h
 * @brief Drive protection of the controller: over-current, open phase by current imbalance,
 * current-sensor plausibility (sum and stuck value), bus under/over-voltage, link timeout,
 * encoder plausibility (lost, frozen while the rotor turns) and stall.
 *
 * Portable C99, float32, no heap, no clock (time enters as the period ts_s and as dt_s of the
 * link timer), no 8-bit types. State struct + config + init/reset/step. One step per control
 * period (the ISR), with the sample of t_k and the current references the current loop was
 * tracking. A trip latches: ctrl_protect_step keeps returning the code until
 * ctrl_protect_reset. Thresholds and why (docs/faults.md):
 *
 *   OVERCURRENT   |i_x| > i_trip_a on any phase, or a non-finite current: instantaneous
 *                 (one sample). detail = phase * 10^7 + |i| [mA] (9999999: not finite).
 *   OPEN_PHASE    phase x: |i_ref_x| >= open_i_min_a (the loop asks for current there) and
 *                 |i_x| < open_ratio |i_ref_x| (it does not flow) and max(|i_y|, |i_z|) >=
 *                 open_i_min_a (the others do), without a contradicting sample for
 *                 open_time_s. Near the reference's zero crossings (|i_ref_x| small) the timer
 *                 holds; a sample with |i_x| >= open_ratio |i_ref_x| resets it. Against the
 *                 reference, not only against the other phases: at standstill a current vector
 *                 normal to phase x (i_x = 0, the others +-) is healthy, and a pure imbalance
 *                 test cannot tell it from an open phase. detail = phase * 10^7 + |i_ref_x| [mA].
 *   SENSOR_FAULT  (a) plausibility of three sensors: low-pass (time constant sum_tau_s) of
 *                 |i_a + i_b + i_c| > sum_max_a; detail = 3 * 10^7 + filtered |sum| [mA].
 *                 (b) stuck value: a phase reads exactly the same value for stuck_time_s while
 *                 another phase moves by more than stuck_delta_a in that time;
 *                 detail = phase * 10^7 + |reading| [mA].
 *   UNDERVOLTAGE  measured bus (v_dc_valid: a reading has arrived, whatever its value) below
 *                 vdc_uv_ratio * V_dc,nom for vdc_time_s;
 *   OVERVOLTAGE   above vdc_ov_ratio * V_dc,nom for vdc_time_s; detail = bus [mV].
 *   LINK_TIMEOUT  (free-running port only) ctrl_protect_link_tick: no SENSE for
 *                 link_timeout_periods periods; detail = time since the last SENSE [us].
 * Motion checks (ctrl_protect_motion_step, after the current loop of the same period):
 *   SENSOR_FAULT  encoder (only while the angle comes from the encoder):
 *                 (c) lost: no valid reading for enc_lost_time_s (the controller bridges the
 *                 gap with the speed estimate meanwhile); detail = 4 * 10^7 + time [us].
 *                 (d) frozen: the reading stands exactly still for enc_frozen_time_s while the
 *                 back-EMF of the voltage balance (v - R i - L di/dt, averaged over that time)
 *                 exceeds enc_emf_ratio * V_dc,nom / sqrt(3): the rotor turns, the encoder does
 *                 not. detail = 5 * 10^7 + mean |EMF| [mV]. A locked rotor has no EMF: STALL.
 *   STALL         speed control: the speed loop at its current limit for stall_time_s, the
 *                 measured current's magnitude |i_alpha_beta| averaged over that window at
 *                 >= CTRL_PROTECT_STALL_I_RATIO of the limit (the current is delivered: not a
 *                 voltage limit), and the speed error shrank by less than stall_speed_rad_s
 *                 (locked rotor, a load beyond the drive's torque). The magnitude, not the q
 *                 component, and its mean, not every sample: both are frame-free, so the check
 *                 holds when a sensorless observer's frame swings on a locked rotor (its q
 *                 current then dips below the limit in 20-50 % of the periods).
 *                 Or, with a back-EMF observer closing the loop: the observer's own EMF
 *                 magnitude |E^|, low-passed with the time constant stall_time_s / 4, falls
 *                 below CTRL_PROTECT_STALL_EMF_RATIO of the EMF its speed estimate stands for
 *                 (|w^| psi_f, low-passed alike), the rule having been active (speed control,
 *                 |w^| psi_f >= CTRL_PROTECT_STALL_EMF_MIN_RATIO * V_dc,nom / sqrt(3)) for
 *                 stall_time_s: the rotor has stopped (a locked rotor has no EMF) but
 *                 the PLL's speed, fed an angle of noise, holds its last value, so the current
 *                 need not sit at the limit (measured on Gong's motor locked at 500 rpm: |E^|
 *                 0.01 V against |w^| psi_f = 17 V, i_q reference swinging between the limits).
 *                 detail = speed estimate [mrad/s, mechanical, signed].
 * A threshold of 0 switches its check off (i_trip_a excepted).
 */
#ifndef CTRL_PROTECT_H
#define CTRL_PROTECT_H

#include <stdint.h>

/** Fault codes: the protocol's FAULT_CTRL `code` value table (protocol/hil.dbc VAL_ 17). This
 *  module does not depend on the protocol; hil_session.c fails the build if they drift. */
#define CTRL_PROTECT_NONE 0
#define CTRL_PROTECT_LINK_TIMEOUT 1
#define CTRL_PROTECT_OVERCURRENT 4
#define CTRL_PROTECT_OVERVOLTAGE 9
#define CTRL_PROTECT_OPEN_PHASE 14
#define CTRL_PROTECT_UNDERVOLTAGE 15
#define CTRL_PROTECT_SENSOR_FAULT 16
#define CTRL_PROTECT_STALL 17

/** `detail` of a phase fault: phase * CTRL_PROTECT_DETAIL_PHASE + value in milli-units. */
#define CTRL_PROTECT_DETAIL_PHASE 10000000L
#define CTRL_PROTECT_DETAIL_MAX_MILLI 9999999L
/** `detail` slots of SENSOR_FAULT beyond the phases 0..2: the sum (3), the encoder (4, 5). */
#define CTRL_PROTECT_DETAIL_SUM 3
#define CTRL_PROTECT_DETAIL_ENC_LOST 4
#define CTRL_PROTECT_DETAIL_ENC_FROZEN 5
/** Stall: the measured current magnitude, averaged over the window, must reach this fraction of
 *  the limit (the current loop delivers what the speed loop asks: a rotor held at the voltage
 *  limit is not stalled). */
#define CTRL_PROTECT_STALL_I_RATIO 0.9f
/** Stall by the EMF: the observer's mean |E^| below this fraction of |w^| psi_f. An LPF'd EMF
 *  (the sign SMO's, cut-off wc) reads 1 / sqrt(1 + (w / wc)^2) of it: 0.1 allows w up to ~10 wc;
 *  a locked rotor reads ~0. */
#define CTRL_PROTECT_STALL_EMF_RATIO 0.1f
/** ... judged only where |w^| psi_f is at least this fraction of V_dc,nom / sqrt(3) (5 %: 9 V at
 *  310 V): below, the EMF is too small against the inverter's error to tell. */
#define CTRL_PROTECT_STALL_EMF_MIN_RATIO 0.05f

/** Thresholds (SI). A zero switches that check off (see the top of this file). */
typedef struct {
    float i_trip_a;            /**< over-current [A], > 0 (the controller's i_trip_a) */
    float open_i_min_a;        /**< open phase: reference and other phases at least this [A] */
    float open_ratio;          /**< open phase: measured below this fraction of the reference */
    float open_time_s;         /**< open phase: for this long [s] */
    float sum_max_a;           /**< plausibility: filtered |i_a + i_b + i_c| above this [A] */
    float sum_tau_s;           /**< plausibility: filter time constant [s] */
    float stuck_time_s;        /**< stuck sensor: same reading for this long [s] */
    float stuck_delta_a;       /**< stuck sensor: while another phase moves by this much [A] */
    float vdc_uv_ratio;        /**< under-voltage threshold / nominal bus [-] */
    float vdc_ov_ratio;        /**< over-voltage threshold / nominal bus [-] */
    float vdc_time_s;          /**< bus: beyond the threshold for this long [s] */
    float link_timeout_periods; /**< link: no SENSE for this many periods (free-running) */
    float enc_lost_time_s;     /**< encoder: no valid reading for this long [s] */
    float enc_emf_ratio;       /**< encoder frozen: back-EMF above this * V_dc,nom / sqrt(3) ... */
    float enc_frozen_time_s;   /**< ... while the reading stands still for this long [s] */
    float stall_time_s;        /**< stall: at the current limit for this long [s] ... */
    float stall_speed_rad_s;   /**< ... with the speed error shrinking by less [rad/s, mech] */
} ctrl_protect_config_t;

/** What one period gives the protection. */
typedef struct {
    float i_abc_a[3];      /**< phase currents sampled at t_k [A] */
    float i_ref_abc_a[3];  /**< currents the loop tracked over the last period [A] (0: none) */
    float v_dc_v;          /**< measured bus [V] */
    int v_dc_valid;        /**< v_dc_v is a measurement (0: none has arrived: no bus check) */
} ctrl_protect_input_t;

/** What the motion checks get, after the current loop of the period. */
typedef struct {
    int speed_control;     /**< closed-loop speed control: the stall check applies */
    float i_q_limit_a;     /**< the speed loop's output limit [A] */
    float i_q_ref_a;       /**< the speed loop's output [A] */
    float i_mag_a;         /**< |i_alpha_beta| measured this period [A] (frame-free) */
    float speed_err_rad_s; /**< speed reference - estimate [rad/s, mechanical] */
    float omega_m_hat_rad_s; /**< speed estimate [rad/s, mechanical] (detail) */
    int encoder_used;      /**< the angle comes from the encoder: the encoder checks apply */
    int enc_valid;         /**< a valid encoder reading arrived for this period */
    float theta_enc_rad;   /**< that reading */
    float emf_v;           /**< |back-EMF| of the voltage balance over the last period [V] */
    float emf_hat_v;       /**< |E^| of the back-EMF observer closing the loop [V]; < 0: none */
    float emf_of_speed_v;  /**< |w^_e| psi_f: the EMF the speed estimate stands for [V] */
} ctrl_protect_motion_t;

typedef struct {
    ctrl_protect_config_t cfg;
    float ts_s;
    float vdc_uv_v, vdc_ov_v;  /**< derived thresholds [V] (0: off) */
    /* state */
    float t_open_s[3];
    float sum_filt_a;
    float stuck_val_a[3];      /**< reading being timed */
    float t_stuck_s[3];
    float stuck_ref_a[3][2];   /**< the two other phases when x's reading was taken */
    float stuck_max_a[3];      /**< their largest excursion since [A] */
    int stuck_armed;           /**< a previous sample exists */
    float t_uv_s, t_ov_s;
    float t_since_sense_s;
    float enc_emf_v;           /**< derived frozen-encoder EMF threshold [V] (0: off) */
    float t_enc_lost_s;
    float enc_prev_rad;        /**< last valid reading */
    int enc_armed;             /**< enc_prev_rad is set */
    float t_enc_frozen_s;
    float enc_emf_int_vs;      /**< integral of |EMF| while frozen [V s] */
    float t_stall_s;
    int stall_dir;             /**< +1 / -1: at the upper / lower limit, 0: not at the limit */
    float stall_err0_rad_s;    /**< speed error at the start of the stall window */
    float stall_i_int_as;      /**< integral of |i| over the stall window [A s] */
    float stall_emf_min_v;     /**< derived: the EMF rule's floor [V] */
    float t_emf_s;             /**< EMF rule: time it has been active [s] */
    float emf_hat_f_v;         /**< |E^| low-passed (time constant stall_time_s / 4) [V] */
    float emf_speed_f_v;       /**< |w^| psi_f low-passed alike [V] */
    int code;                  /**< latched fault (CTRL_PROTECT_*), 0 = none */
    int32_t detail;
} ctrl_protect_t;

/** Defaults that keep the bundled scenarios fault-free (docs/faults.md). */
void ctrl_protect_default_config(ctrl_protect_config_t *cfg);
/** 0, or -1 if a value is negative / not finite, i_trip_a, ts_s or v_dc_nom_v <= 0, or
 *  vdc_ov_ratio in (0, 1]. */
int ctrl_protect_init(ctrl_protect_t *p, const ctrl_protect_config_t *cfg, float ts_s,
                      float v_dc_nom_v);
/** Clear the timers, filters and a latched trip. */
void ctrl_protect_reset(ctrl_protect_t *p);
/** One period. Returns the latched fault code (0 = none); detail in p->detail. */
int ctrl_protect_step(ctrl_protect_t *p, const ctrl_protect_input_t *in);
/** Motion checks of one period (encoder, stall), after ctrl_protect_step and the current
 *  loop. Returns the latched fault code (0 = none); detail in p->detail. */
int ctrl_protect_motion_step(ctrl_protect_t *p, const ctrl_protect_motion_t *in);
/** Link timer of a free-running port: dt_s since the last call. Returns
 *  CTRL_PROTECT_LINK_TIMEOUT once the SENSE gap exceeds link_timeout_periods * ts_s (latched),
 *  else 0. ctrl_protect_step restarts the gap (a SENSE arrived). */
int ctrl_protect_link_tick(ctrl_protect_t *p, float dt_s);

#endif
