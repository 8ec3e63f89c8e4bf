/**
 * @file pwm.h
 * @brief Centre-aligned PWM timing of one control period: triangular carrier, compare values,
 *        shadow loading -> the high-side command of each leg (no physics; see inverter.h for
 *        what a leg does with the command, plant.c for the integration).
 *
 * One carrier period per control period Ts (an up-down counter, as a C2000 ePWM in up-down
 * count or an STM32 timer in centre-aligned mode). Time t is measured from the period start
 * t_k, the instant the controller's ADC samples and its interrupt starts.
 *
 * Carrier (normalised, 0 at the valley, 1 at the peak):
 *     carrier_at_start = PWM_CARRIER_VALLEY: c(t) = 2t/Ts on [0, Ts/2], 2 - 2t/Ts on [Ts/2, Ts]
 *         (the counter's zero at t_k: low-side shunts sample there, all lower switches on);
 *     carrier_at_start = PWM_CARRIER_PEAK: shifted by Ts/2 (c(0) = 1: all upper switches on).
 * Command of leg x: high (upper switch wanted) while c(t) > 1 - d(t), d the compare value
 * (duty) in effect; d >= 1 is high and d <= 0 low for the whole period. With the valley at t_k
 * a duty d gives one high pulse of d Ts centred on the peak, t in ((1-d) Ts/2, (1+d) Ts/2);
 * both carrier extrema fall in zero vectors (000 at the valley, 111 at the peak).
 *
 * Duty update. The controller writes the new compare values at t_w (its computation delay,
 * t_delay_s, or the measured arrival in real time). They act from the load instant t_l:
 *     PWM_LOAD_EXTREMUM  shadow registers loaded at every carrier extremum (C2000 ePWM
 *                        LOADAMODE = CTR_ZERO_PRD; STM32 preload with an update event at
 *                        every over- and underflow, RCR = 0): t_l = the first of 0, Ts/2, Ts
 *                        at or after t_w;
 *     PWM_LOAD_PERIOD    loaded once per period, at the period start (C2000 CTR_ZERO with the
 *                        valley at t_k): t_l = 0 if t_w = 0, else Ts (the next period);
 *     PWM_LOAD_IMMEDIATE no shadow: the new values act from t_l = t_w (the averaged plant's
 *                        timing); the comparison is a level comparison, so a compare value
 *                        written past the carrier can switch the leg at t_w itself (a C2000 in
 *                        immediate mode acts on compare EVENTS and would miss that edge).
 * A write at t_w = 0 is taken at the event at t_k itself in every mode (a controller without
 * computation delay). The transitions of the command are exact (the carrier is piecewise
 * linear): at most one per monotone piece of [0, Ts) cut at Ts/2 and t_l, plus one at t = 0
 * (against the level the previous period ended with) and one at t_l.
 */
#ifndef PWM_H
#define PWM_H

/** Command transitions of one leg in one period, at most: t = 0, t_l, one per piece. */
#define PWM_MAX_EDGES 6

typedef enum { PWM_CARRIER_VALLEY = 0, PWM_CARRIER_PEAK = 1 } pwm_carrier_t;
typedef enum { PWM_LOAD_EXTREMUM = 0, PWM_LOAD_PERIOD = 1, PWM_LOAD_IMMEDIATE = 2 } pwm_load_t;

typedef struct pwm_config {
    double ts_s;          /**< carrier (= control) period [s], > 0 */
    int carrier_at_start; /**< pwm_carrier_t */
    int load;             /**< pwm_load_t */
} pwm_config_t;

/** The command of one leg over one period. */
typedef struct pwm_leg_plan {
    int n;                        /**< transitions in [0, Ts) */
    double t_s[PWM_MAX_EDGES];    /**< their instants, ascending, from the period start [s] */
    int level[PWM_MAX_EDGES];     /**< the command after each (1: high side) */
    int level_end;                /**< the command at the end of the period */
} pwm_leg_plan_t;

typedef struct pwm_plan {
    double t_load_s;              /**< the load instant t_l [s] */
    pwm_leg_plan_t leg[3];
} pwm_plan_t;

/** Config + state: the command level each leg ended the last period with. */
typedef struct pwm {
    pwm_config_t cfg;
    int level[3];
} pwm_t;

/** 0, or -1 if ts_s is not finite and > 0 or a mode is out of range. */
int pwm_init(pwm_t *pwm, const pwm_config_t *cfg);
/** The levels a period run at these (sanitised, [0, 1]) duties ends with. */
void pwm_reset(pwm_t *pwm, const double duty[3]);
/** The load instant t_l [s] for a write at t_w (clamped to [0, Ts]; NaN = 0). */
double pwm_load_instant(const pwm_t *pwm, double t_write_s);
/** The carrier c(t) in [0, 1] at t in [0, Ts]. */
double pwm_carrier(const pwm_t *pwm, double t_s);
/**
 * The command over one period: duty_old acts before the load instant, duty_new from it
 * (duties sanitised to [0, 1]). Pure: the state moves on with pwm_commit.
 */
void pwm_plan(const pwm_t *pwm, const double duty_old[3], const double duty_new[3],
              double t_write_s, pwm_plan_t *out);
/** The period of `plan` is over: keep the levels it ended with. */
void pwm_commit(pwm_t *pwm, const pwm_plan_t *plan);

#endif
