/**
 * @file inv_comp.h
 * @brief Inverter-error (dead-time and device-drop) feed-forward compensation: what a production
 * drive applies to its PWM duties, and the voltage its observers are fed. Portable C99, float32.
 *
 * The inverter error of one leg x over a PWM period (centre-aligned, averaged; the form of the
 * bench's plant, plant_rt/c/inverter.h, and of Choi & Sul 1995 / Urasaki et al. 2005):
 *   v_xN(d, i) = f V_dc - h(d, i),
 *   f = w (d - D) + (1 - w)(d + D),  D = t_dt / Ts,  w = (1 + g(i)) / 2
 *   h = +( f_p V_s + (1 - f_p) V_d )     i > 0   (upper switch for f_p = d - D, lower diode)
 *       -( f_n V_d + (1 - f_n) V_s )     i < 0   (upper diode for f_n = d + D, lower switch)
 *   V_s = v_switch q(i) + r_switch |i|,  V_d = v_diode q(i) + r_diode |i|
 * g(i) in [-1, 1] is the current's smoothed sign (the zero-crossing region), q(i) in [0, 1] the
 * onset of the threshold drops. Two shapes (inv_comp_shape_t):
 *  - INV_COMP_SHAPE_CAPACITIVE: the commutation of the leg's node capacitance C by the phase
 *    current inside the dead interval (Choi & Sul, IEEE TIA 31(5), 1995: the "zero current
 *    clamping" of low currents); with i_c = C V_dc / t_dt (i_band_a):
 *      g = i / (2 i_c)  for |i| <= i_c,   sign(i) (1 - i_c / (2 |i|))  beyond;  q = tanh(|i| / i_c)
 *    This is the plant's own model (plant_rt/README.md derives it): a drive whose compensation was
 *    commissioned on its inverter (a measured error-vs-current table) follows this curve, so with
 *    exact parameters the compensation cancels the plant's error.
 *  - INV_COMP_SHAPE_LINEAR: g = q = clamp(i / i_band, -1, 1): the linear band of the simple
 *    feed-forward (full compensation outside +-i_band, proportional inside).
 *
 * Compensation: for each active leg, the duty d' whose modelled output equals the commanded d:
 * v_xN(d', i) = d V_dc. v_xN is continuous, non-decreasing and piecewise linear in d' (w, V_s,
 * V_d depend on i alone) with breaks where the dead interval meets a rail (d' = D, 1 - D), so
 * d' is exact by interpolation in the piece that holds the target: 4 evaluations of the model,
 * no iteration. A target beyond the leg's range gives d' = 0 or 1 (near the limits a leg cannot
 * make every voltage: the model says what it makes).
 * The voltage handed to the observers is the model's output for the duties sent,
 * Clarke{ v_xN(d', i) }: the commanded voltage wherever d' was not clamped.
 *
 * The current i is the phase current the period's error depends on: the caller passes the
 * current it expects over the interval the duties act on (the controller extrapolates its last
 * two samples to the middle of that interval, inv_comp_predict).
 * A leg with a negative duty (OFF) passes through unchanged and contributes no voltage.
 */
#ifndef INV_COMP_H
#define INV_COMP_H

#include "fw_math.h"

typedef enum {
    INV_COMP_SHAPE_LINEAR = 0,
    INV_COMP_SHAPE_CAPACITIVE = 1
} inv_comp_shape_t;

typedef struct {
    float ts_s;          /**< PWM period [s] */
    float dead_time_s;   /**< the drive's estimate of the effective dead time t_dt [s], 0 <= t_dt < ts_s/2 */
    float v_switch_v;    /**< switch on-state threshold drop [V] */
    float r_switch_ohm;  /**< switch slope resistance [ohm] */
    float v_diode_v;     /**< diode threshold drop [V] */
    float r_diode_ohm;   /**< diode slope resistance [ohm] */
    float i_band_a;      /**< zero-crossing current [A]: i_c (capacitive) or the band (linear); > 0 */
    int shape;           /**< inv_comp_shape_t */
} inv_comp_config_t;

typedef struct {
    inv_comp_config_t cfg;
    float delta;            /**< t_dt / Ts */
    float inv_band;         /**< 1 / i_band_a */
    /* outputs of the last step */
    float duty_abc[3];      /**< compensated duties (negative: leg OFF, as given) */
    float v_err_abc_v[3];   /**< modelled leg error v_xN(d', i) - d' V_dc [V] (0 for an OFF leg) */
    fw_vec2_t v_ab_v;       /**< alpha-beta voltage the model says the duties make [V] */
    int clamped;            /**< legs whose d' was clamped to [0, 1] in the last step */
} inv_comp_t;

/** Zero parameters (no compensation), shape CAPACITIVE, band 0.1 A, for period ts_s. */
void inv_comp_default_config(inv_comp_config_t *cfg, float ts_s);
/** 0, or -1 if a value is out of range (Ts <= 0, t_dt outside [0, Ts/2), negative drops,
 *  band <= 0, unknown shape). */
int inv_comp_init(inv_comp_t *s, const inv_comp_config_t *cfg);
void inv_comp_reset(inv_comp_t *s);

/** The smoothed current sign g(i) of the configured shape, in [-1, 1]. */
float inv_comp_sign(const inv_comp_t *s, float i_a);
/** Modelled leg output v_xN(duty, i) [V] for a duty in [0, 1] (forward model, above). */
float inv_comp_leg_voltage(const inv_comp_t *s, float duty, float i_a, float v_dc_v);
/** The duty d' in [0, 1] whose modelled output is duty * v_dc_v (clamped; *clamped set if so). */
float inv_comp_leg_duty(const inv_comp_t *s, float duty, float i_a, float v_dc_v, int *clamped);

/**
 * Compensate three duties (from SVPWM, [0, 1]; negative = leg OFF) for the phase currents
 * i_abc_a [A] on a bus of v_dc_v [V]. Fills s->duty_abc, s->v_err_abc_v, s->v_ab_v and returns
 * the alpha-beta voltage the model says the compensated duties make (the observers' voltage).
 */
fw_vec2_t inv_comp_step(inv_comp_t *s, const float duty_abc[3], const float i_abc_a[3],
                        float v_dc_v);

/**
 * Linear extrapolation of sampled phase currents by `horizon` periods:
 * out = i_now + horizon (i_now - i_prev).
 */
void inv_comp_predict(const float i_now_a[3], const float i_prev_a[3], float horizon,
                      float out_a[3]);

#endif
