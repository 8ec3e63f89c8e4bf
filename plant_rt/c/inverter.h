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

/** Config + derived threshold (caller owns the memory). The inverter itself has no state. */
typedef struct inverter {
    inverter_config_t cfg;
    double i_zero_a; /**< |i| at or below this is "zero" for diode conduction [A] */
    double v_tol_v;  /**< slack when comparing an open terminal voltage with the rails [V] */
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

#endif
