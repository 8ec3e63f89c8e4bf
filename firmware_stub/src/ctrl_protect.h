/**
 * @file ctrl_protect.h
 * @brief Drive protection of the controller: over-current, open phase by current imbalance,
 * current-sensor plausibility (sum and stuck value), bus under/over-voltage, link timeout.
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
 *   UNDERVOLTAGE  measured bus (> 1 V, i.e. measured) below vdc_uv_ratio * V_dc,nom for
 *                 vdc_time_s;
 *   OVERVOLTAGE   above vdc_ov_ratio * V_dc,nom for vdc_time_s; detail = bus [mV].
 *   LINK_TIMEOUT  (free-running port only) ctrl_protect_link_tick: no SENSE for
 *                 link_timeout_periods periods; detail = time since the last SENSE [us].
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

/** `detail` of a phase fault: phase * CTRL_PROTECT_DETAIL_PHASE + value in milli-units. */
#define CTRL_PROTECT_DETAIL_PHASE 10000000L
#define CTRL_PROTECT_DETAIL_MAX_MILLI 9999999L

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
} ctrl_protect_config_t;

/** What one period gives the protection. */
typedef struct {
    float i_abc_a[3];      /**< phase currents sampled at t_k [A] */
    float i_ref_abc_a[3];  /**< currents the loop tracked over the last period [A] (0: none) */
    float v_dc_v;          /**< measured bus [V]; <= 1 V: not measured */
} ctrl_protect_input_t;

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
/** Link timer of a free-running port: dt_s since the last call. Returns
 *  CTRL_PROTECT_LINK_TIMEOUT once the SENSE gap exceeds link_timeout_periods * ts_s (latched),
 *  else 0. ctrl_protect_step restarts the gap (a SENSE arrived). */
int ctrl_protect_link_tick(ctrl_protect_t *p, float dt_s);

#endif
