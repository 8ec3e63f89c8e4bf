/**
 * @file inverter.h
 * @brief Averaged three-phase two-level voltage-source inverter, center-aligned PWM, with
 *        freewheeling diodes for disabled legs (the inverter's safe state).
 *
 * Active leg x (duty 0 <= d_x <= 1, the fraction of the period the high-side switch is on):
 *     pole voltage v_xN = d_x * V_dc, averaged over the PWM period (the intra-period ripple is
 *     not modelled; duties above 1 are clamped to 1).
 * Disabled leg (d_x < 0, or NaN; both switches off): only the diodes can conduct,
 *     i_x > 0 (out of the leg into the machine)  -> lower diode, v_xN = 0,
 *     i_x < 0                                    -> upper diode, v_xN = V_dc,
 *     i_x = 0 with the open terminal voltage inside [0, V_dc] -> the phase is open (no current).
 * Isolated star point: phase-to-neutral voltages v_x = v_xN - (v_aN + v_bN + v_cN)/3 when all
 * three phases carry current (an open phase's voltage is set by the machine; see plant.c).
 *
 * This module classifies legs and makes pole and phase voltages; which phase is open and what
 * voltage appears on it needs the machine model and is resolved by the plant (plant.c).
 *
 * Non-idealities (inverter_set_nonlinear; off after inverter_init): an average-value model of
 * each leg over one PWM period with dead time, device on-state drops and a current sign that
 * is smooth near zero (parasitic capacitance). Per active leg, with d the commanded high-side
 * fraction, delta = t_dt / Ts and i the phase current (> 0 out of the leg):
 *
 *   + rail fraction. i > 0: the dead interval at the rising edge of the high-side command is
 *          spent on the lower diode: f_p = clamp(d - delta, 0, 1); i < 0: the dead interval at
 *          the falling edge is spent on the upper diode: f_n = clamp(d + delta, 0, 1);
 *          f = w f_p + (1 - w) f_n,  w = (1 + g(i)) / 2,
 *          g(i) = sign(i) * ( |i|/(2 i_c)        for |i| <= i_c
 *                             1 - i_c/(2|i|)     for |i| >  i_c ).
 *   drops. The devices that carry i conduct: i > 0 the upper switch for f_p and the lower
 *          diode for 1 - f_p, i < 0 the upper diode for f_n and the lower switch for 1 - f_n:
 *          h(i) = +(f_p V_s + (1 - f_p) V_d)   (i > 0),   -(f_n V_d + (1 - f_n) V_s)   (i < 0),
 *          V_s = v_switch q(i) + r_switch |i|,  V_d = v_diode q(i) + r_diode |i|,
 *          q(i) = tanh(|i| / i_c): the threshold rises smoothly from zero current (a real
 *          device's drop also starts at 0 V; the threshold is a linearisation at larger
 *          currents), so h is continuous at i = 0.
 *   v_xN = f V_dc - h(i).
 *
 * Without drops this is v_xN = d V_dc - g(i) (t_dt/Ts) V_dc: the classical dead-time voltage
 * error -sign(i) t_dt/Ts V_dc (e.g. Choi & Sul 1995; Urasaki et al. 2005, ref. [24] of Yuan
 * et al.) with the sign replaced by g. g is the exact average over one period of a leg whose
 * output node capacitance C (both devices' C_oss, snubbers, cable) is slewed by the phase
 * current during the dead intervals: the node moves at i/C, and i_c = C V_dc / t_dt is the
 * current that slews it rail to rail in exactly t_dt (derivation in plant_rt/README.md; checked
 * against a switch-level single-leg model in tests/test_plant_inverter_nl.py). g is
 * continuous with a continuous slope. Far outside the band (|i| >> i_c, q = 1, g -> +-1):
 *   i > 0: v_xN = f_p (V_dc - V_s) - (1 - f_p) V_d,   i < 0: f_n (V_dc + V_d) + (1 - f_n) V_s.
 * The bus current is i_dc = sum_x f_x i_x (energy drawn from the DC link); the leg's loss is
 * (f_x V_dc - v_xN) i_x = h(i_x) i_x >= 0 (conduction loss; the dead time itself is lossless).
 * Disabled legs: a conducting diode adds its drop (DIODE_LOW: v_xN = -(v_diode + r_diode |i|),
 * DIODE_HIGH: V_dc + v_diode + r_diode |i|) and an open terminal must leave
 * [-v_diode, V_dc + v_diode] to conduct.
 * Not modelled: minimum-pulse suppression (a duty of exactly 0 or 1 is treated like any other),
 * turn-on/off delays other than the dead time, the PWM ripple.
 */
#ifndef INVERTER_H
#define INVERTER_H

/** What a leg does over an integration step. */
typedef enum inverter_leg_mode {
    INV_LEG_PWM = 0,        /**< active: v_xN = d_x V_dc */
    INV_LEG_DIODE_LOW = 1,  /**< disabled, lower diode conducts (i_x > 0): v_xN = 0 */
    INV_LEG_DIODE_HIGH = 2, /**< disabled, upper diode conducts (i_x < 0): v_xN = V_dc */
    INV_LEG_OPEN = 3        /**< disabled, no diode conducts: i_x = 0, v_xN set by the machine */
} inverter_leg_mode_t;

/** Constants. */
typedef struct inverter_config {
    double v_dc_v; /**< DC-link voltage [V], > 0, stiff (ideal source/sink) */
} inverter_config_t;

/** Non-idealities of the legs (see the top of this file). All zero = ideal. */
typedef struct inverter_nl_config {
    double dead_time_s;      /**< t_dt per commutation [s], 0 <= t_dt < ts_s / 2 */
    double ts_s;             /**< PWM period [s], > 0 */
    double v_switch_drop_v;  /**< switch on-state threshold drop [V], >= 0 */
    double r_switch_ohm;     /**< switch on-state slope resistance [ohm], >= 0 */
    double v_diode_drop_v;   /**< diode forward threshold drop [V], >= 0 */
    double r_diode_ohm;      /**< diode slope resistance [ohm], >= 0 */
    double i_cap_band_a;     /**< i_c = C_node V_dc / t_dt [A], >= 0; 0 = hard sign */
} inverter_nl_config_t;

/** Config + derived threshold (caller owns the memory). The inverter itself has no state. */
typedef struct inverter {
    inverter_config_t cfg;
    double i_zero_a; /**< |i| at or below this is "zero" for diode conduction [A] */
    double v_tol_v;  /**< slack when comparing an open terminal voltage with the rails [V] */
    int nonlinear;   /**< 1 after inverter_set_nonlinear with a non-NULL config */
    inverter_nl_config_t nl;
    double delta;    /**< t_dt / Ts */
} inverter_t;

/** Returns 0, or -1 if v_dc_v is not finite and > 0. */
int inverter_init(inverter_t *inv, const inverter_config_t *cfg);
/** No state; present for the module convention. */
void inverter_reset(inverter_t *inv);

/** The duty the inverter applies: NaN or < 0 -> -1 (disabled), > 1 -> 1, else unchanged. */
double inverter_sanitize_duty(double duty);

/** 1 if the (sanitised or raw) duty disables its leg. */
int inverter_leg_disabled(double duty);

/**
 * First-pass leg modes from duties and phase currents [A]: PWM for active legs, DIODE_LOW /
 * DIODE_HIGH for a disabled leg carrying current, OPEN for a disabled leg with |i| <= i_zero_a
 * (a candidate: the plant confirms it with the machine's open terminal voltage). Returns the
 * number of OPEN legs.
 */
int inverter_classify(const inverter_t *inv, const double duty[3], const double i_abc_a[3],
                      inverter_leg_mode_t mode[3]);

/**
 * Pole voltages v_xN [V] of the legs that act as voltage sources (PWM and DIODE_*);
 * OPEN legs get NaN-free 0 and must not be used.
 */
void inverter_pole_voltages(const inverter_t *inv, const double duty[3],
                            const inverter_leg_mode_t mode[3], double v_pole_v[3]);

/** Phase-to-neutral voltages of an isolated star: v_x = v_xN - mean(v_N) (common mode removed). */
void inverter_phase_voltages(const double v_pole_v[3], double v_phase_v[3]);

/**
 * Stand-alone use (all legs carrying current): classify the legs, make the pole voltages and
 * the phase-to-neutral voltages v_phase_v [V] of the isolated star. Returns the number of
 * open-candidate legs; if it is not 0, v_phase_v is not meaningful (the open phase's voltage
 * depends on the machine: the plant resolves it).
 */
int inverter_step(const inverter_t *inv, const double duty[3], const double i_abc_a[3],
                  double v_phase_v[3]);

/**
 * Decide an open-candidate leg from the terminal voltage it would have if open [V]:
 * above V_dc (+tol) -> DIODE_HIGH, below 0 (-tol) -> DIODE_LOW, else OPEN.
 */
inverter_leg_mode_t inverter_open_leg_mode(const inverter_t *inv, double v_open_terminal_v);

/** Margin [V] by which an open terminal voltage is inside the rails (negative = outside). */
double inverter_open_margin(const inverter_t *inv, double v_open_terminal_v);

/* ---- non-idealities ---- */

/**
 * Switch the leg non-idealities on (cfg != NULL) or off (NULL: the ideal averaged inverter).
 * Returns 0, or -1 (and leaves the inverter ideal) if a value is out of range.
 */
int inverter_set_nonlinear(inverter_t *inv, const inverter_nl_config_t *cfg);

/** The smooth current sign g(i) in [-1, 1] (sign(i) if i_cap_band_a = 0). */
double inverter_smooth_sign(const inverter_t *inv, double i_a);

/**
 * Average pole voltage v_xN [V] of an active leg over the interval its duty acts on, for
 * sanitised duty in [0, 1] and phase current i_a [A]; *f_hi (if not NULL) receives the
 * fraction of the period the leg connects the phase to the + rail (bus current = f_hi i).
 * Ideal inverter: duty * V_dc and f_hi = duty.
 */
double inverter_leg_voltage(const inverter_t *inv, double duty, double i_a, double *f_hi);

/**
 * Pole voltages of all legs for the given modes and phase currents, with the non-idealities
 * (reduces to inverter_pole_voltages when ideal); f_hi (may be NULL) as in
 * inverter_leg_voltage (DIODE_HIGH: 1, DIODE_LOW and OPEN: 0).
 */
void inverter_pole_voltages_i(const inverter_t *inv, const double duty[3],
                              const inverter_leg_mode_t mode[3], const double i_abc_a[3],
                              double v_pole_v[3], double f_hi[3]);

/* ---- switch level (the plant's switching mode; pwm.h makes the commands) ---- */

/**
 * One leg at switch level, driven by its high-side command (pwm.h) and the phase current i
 * (> 0 out of the leg). Times are from the period start [s].
 *
 * Gates: each switch turns on dead_time_s after its command rises and off at once (the
 * dead-band generator of a C2000 ePWM / an STM32 advanced timer), so the leg has both gates
 * off for dead_time_s after every command transition (longer when transitions come closer
 * than that: a command pulse shorter than the dead time never turns its switch on).
 * With a gate on, the node sits at the conducting device (the current decides which one of
 * the pair, continuously in time):
 *     HIGH: i > 0 upper switch, v_xN = V_dc - V_s(i);   i < 0 upper diode, V_dc + V_d(i)
 *     LOW:  i > 0 lower diode,  v_xN = -V_d(i);         i < 0 lower switch, +V_s(i)
 * with V_s, V_d as in the averaged model (thresholds on over the band: tanh(|i|/i_c)), so the
 * pole voltage of a conducting leg is continuous in i.
 * Dead interval (both gates off): decided at its start by the sign of the current AT THAT
 * INSTANT, i_e, and held until the incoming switch turns on:
 *     the current flowed in the outgoing leg's diode (HIGH with i_e <= 0, LOW with i_e >= 0):
 *         that diode keeps conducting: V_dc + V_d(i_e) or -V_d(i_e);
 *     it flowed in the outgoing switch: it slews the node capacitance C = i_c t_dt / V_dc
 *         (the averaged model's band, inverter.h top) at i_e / C towards the opposite diode,
 *         which clamps it there (after C |dv| / |i_e|, i.e. within the dead time when
 *         |i_e| > i_c); the incoming switch turns on at the end of the dead time wherever the
 *         node is (hard switching).
 * Without the non-linearity (inverter_set_nonlinear not called) the leg has no dead time and
 * no drops: HIGH = V_dc, LOW = 0. Approximations: the current is frozen at i_e for the dead
 * interval's decisions (a current that reverses inside it keeps the diode conducting:
 * bounded by the dead time), the node capacitance is linear and only acts in dead intervals.
 * Averaged over a period at a constant current, with drops off, this leg gives exactly the
 * averaged leg voltage (tests/c/test_plant_switching.c, tests/test_plant_switching.py).
 */
typedef enum { INV_SW_LOW = 0, INV_SW_HIGH = 1, INV_SW_DEAD = 2 } inverter_sw_state_t;

typedef struct inverter_sw_leg {
    int state;            /**< inverter_sw_state_t */
    int command;          /**< the latest command (1: high side); the state after a dead interval */
    double dead_end_s;    /**< DEAD: the incoming switch turns on here */
    double t0_s;          /**< DEAD: start of the node's slew */
    double v0_v;          /**< DEAD: node voltage at t0_s */
    double rate_v_s;      /**< DEAD: slew rate (0: a diode holds the node) */
    double t_clamp_s;     /**< DEAD: the opposite diode clamps the node from here */
    double v_clamp_v;     /**< DEAD: ... at this voltage */
    double f_clamp;       /**< DEAD: + rail fraction once clamped (1 upper diode, 0 lower) */
} inverter_sw_leg_t;

/** A leg whose gate follows `command` (no dead interval running). */
void inverter_sw_leg_reset(inverter_sw_leg_t *leg, int command);

/** A command transition at t_s with phase current i_a: starts (or extends) the dead interval. */
void inverter_sw_command(const inverter_t *inv, inverter_sw_leg_t *leg, double t_s, int command,
                         double i_a);

/** Move the leg's state to the instant t_s (a dead interval that ended by then is over). */
void inverter_sw_advance(inverter_sw_leg_t *leg, double t_s);

/** The next instant after t_s at which the leg's state or node law changes (HUGE_VAL: none). */
double inverter_sw_next_change(const inverter_sw_leg_t *leg, double t_s);

/**
 * Pole voltage v_xN [V] at time t_s (inside the present segment) for phase current i_a [A];
 * *f_hi (if not NULL): the fraction tying the node to the + rail (bus current f_hi i; in a
 * slew the node's position between the rails, so the slew itself is lossless as in the
 * averaged model).
 */
double inverter_sw_pole_voltage(const inverter_t *inv, const inverter_sw_leg_t *leg, double t_s,
                                double i_a, double *f_hi);

/** Shift the leg's times by -ts_s (the next period starts). */
void inverter_sw_shift(inverter_sw_leg_t *leg, double ts_s);

#endif
