/**
 * @file inverter.c
 * @brief Averaged VSI with diode freewheeling. See inverter.h.
 */
#include "inverter.h"

#include <math.h>

int inverter_init(inverter_t *inv, const inverter_config_t *cfg)
{
    if (!isfinite(cfg->v_dc_v) || !(cfg->v_dc_v > 0.0)) {
        return -1;
    }
    inv->cfg = *cfg;
    /* Absolute thresholds: far below any current or voltage the bench resolves, far above
     * the rounding noise of the state (|i| ~ 1..100 A -> ulp ~ 1e-14 A). */
    inv->i_zero_a = 1e-9;
    inv->v_tol_v = 1e-9 * cfg->v_dc_v;
    inverter_reset(inv);
    return 0;
}

void inverter_reset(inverter_t *inv)
{
    (void)inv;
}

double inverter_sanitize_duty(double duty)
{
    if (!(duty >= 0.0)) { /* negative or NaN */
        return -1.0;
    }
    return (duty > 1.0) ? 1.0 : duty;
}

int inverter_leg_disabled(double duty)
{
    return !(duty >= 0.0);
}

int inverter_classify(const inverter_t *inv, const double duty[3], const double i_abc_a[3],
                      inverter_leg_mode_t mode[3])
{
    int k;
    int n_open = 0;
    for (k = 0; k < 3; ++k) {
        if (!inverter_leg_disabled(duty[k])) {
            mode[k] = INV_LEG_PWM;
        } else if (i_abc_a[k] > inv->i_zero_a) {
            mode[k] = INV_LEG_DIODE_LOW;
        } else if (i_abc_a[k] < -inv->i_zero_a) {
            mode[k] = INV_LEG_DIODE_HIGH;
        } else {
            mode[k] = INV_LEG_OPEN;
            ++n_open;
        }
    }
    return n_open;
}

void inverter_pole_voltages(const inverter_t *inv, const double duty[3],
                            const inverter_leg_mode_t mode[3], double v_pole_v[3])
{
    int k;
    for (k = 0; k < 3; ++k) {
        switch (mode[k]) {
        case INV_LEG_PWM:
            v_pole_v[k] = inverter_sanitize_duty(duty[k]) * inv->cfg.v_dc_v;
            break;
        case INV_LEG_DIODE_HIGH:
            v_pole_v[k] = inv->cfg.v_dc_v;
            break;
        case INV_LEG_DIODE_LOW:
        case INV_LEG_OPEN:
        default:
            v_pole_v[k] = 0.0;
            break;
        }
    }
}

void inverter_phase_voltages(const double v_pole_v[3], double v_phase_v[3])
{
    const double cm = (v_pole_v[0] + v_pole_v[1] + v_pole_v[2]) / 3.0;
    v_phase_v[0] = v_pole_v[0] - cm;
    v_phase_v[1] = v_pole_v[1] - cm;
    v_phase_v[2] = v_pole_v[2] - cm;
}

int inverter_step(const inverter_t *inv, const double duty[3], const double i_abc_a[3],
                  double v_phase_v[3])
{
    inverter_leg_mode_t mode[3];
    double v_pole[3];
    const int n_open = inverter_classify(inv, duty, i_abc_a, mode);
    inverter_pole_voltages(inv, duty, mode, v_pole);
    inverter_phase_voltages(v_pole, v_phase_v);
    return n_open;
}

inverter_leg_mode_t inverter_open_leg_mode(const inverter_t *inv, double v_open_terminal_v)
{
    if (v_open_terminal_v > inv->cfg.v_dc_v + inv->v_tol_v) {
        return INV_LEG_DIODE_HIGH;
    }
    if (v_open_terminal_v < -inv->v_tol_v) {
        return INV_LEG_DIODE_LOW;
    }
    return INV_LEG_OPEN;
}

double inverter_open_margin(const inverter_t *inv, double v_open_terminal_v)
{
    const double lo = v_open_terminal_v + inv->v_tol_v;
    const double hi = inv->cfg.v_dc_v + inv->v_tol_v - v_open_terminal_v;
    return (lo < hi) ? lo : hi;
}
