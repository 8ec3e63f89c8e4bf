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
    inv->nonlinear = 0;
    inv->nl.dead_time_s = 0.0;
    inv->nl.ts_s = 1.0;
    inv->nl.v_switch_drop_v = 0.0;
    inv->nl.r_switch_ohm = 0.0;
    inv->nl.v_diode_drop_v = 0.0;
    inv->nl.r_diode_ohm = 0.0;
    inv->nl.i_cap_band_a = 0.0;
    inv->delta = 0.0;
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
    const double vd = inv->nl.v_diode_drop_v; /* 0 when ideal */
    if (v_open_terminal_v > inv->cfg.v_dc_v + vd + inv->v_tol_v) {
        return INV_LEG_DIODE_HIGH;
    }
    if (v_open_terminal_v < -vd - inv->v_tol_v) {
        return INV_LEG_DIODE_LOW;
    }
    return INV_LEG_OPEN;
}

double inverter_open_margin(const inverter_t *inv, double v_open_terminal_v)
{
    const double vd = inv->nl.v_diode_drop_v;
    const double lo = v_open_terminal_v + vd + inv->v_tol_v;
    const double hi = inv->cfg.v_dc_v + vd + inv->v_tol_v - v_open_terminal_v;
    return (lo < hi) ? lo : hi;
}

/* ------------------------------------------------------------------------------------------ */
/* non-idealities                                                                             */

int inverter_set_nonlinear(inverter_t *inv, const inverter_nl_config_t *cfg)
{
    if (cfg == 0) {
        const double v_dc = inv->cfg.v_dc_v;
        inverter_config_t keep;
        keep.v_dc_v = v_dc;
        return inverter_init(inv, &keep);
    }
    if (!isfinite(cfg->ts_s) || !(cfg->ts_s > 0.0) || !isfinite(cfg->dead_time_s) ||
        !(cfg->dead_time_s >= 0.0) || !(2.0 * cfg->dead_time_s < cfg->ts_s)) {
        return -1;
    }
    if (!(cfg->v_switch_drop_v >= 0.0) || !isfinite(cfg->v_switch_drop_v) ||
        !(cfg->r_switch_ohm >= 0.0) || !isfinite(cfg->r_switch_ohm) ||
        !(cfg->v_diode_drop_v >= 0.0) || !isfinite(cfg->v_diode_drop_v) ||
        !(cfg->r_diode_ohm >= 0.0) || !isfinite(cfg->r_diode_ohm) ||
        !(cfg->i_cap_band_a >= 0.0) || !isfinite(cfg->i_cap_band_a)) {
        return -1;
    }
    inv->nl = *cfg;
    inv->delta = cfg->dead_time_s / cfg->ts_s;
    inv->nonlinear = 1;
    return 0;
}

double inverter_smooth_sign(const inverter_t *inv, double i_a)
{
    const double ic = inv->nl.i_cap_band_a;
    const double x = fabs(i_a);
    double g;
    if (!(ic > 0.0)) {
        return (i_a > 0.0) ? 1.0 : ((i_a < 0.0) ? -1.0 : 0.0);
    }
    g = (x <= ic) ? 0.5 * x / ic : 1.0 - 0.5 * ic / x;
    return (i_a < 0.0) ? -g : g;
}

static double clamp01(double x)
{
    return (x < 0.0) ? 0.0 : ((x > 1.0) ? 1.0 : x);
}

double inverter_leg_voltage(const inverter_t *inv, double duty, double i_a, double *f_hi)
{
    const double vdc = inv->cfg.v_dc_v;
    double ai, onset, vs, vd, fp, fn, w, f, drop;
    if (!inv->nonlinear) {
        if (f_hi != 0) *f_hi = duty;
        return duty * vdc;
    }
    /* + rail fraction: the dead interval is lost (i > 0) or gained (i < 0), blended across the
     * capacitance band */
    fp = clamp01(duty - inv->delta);
    fn = clamp01(duty + inv->delta);
    w = 0.5 * (1.0 + inverter_smooth_sign(inv, i_a));
    f = w * fp + (1.0 - w) * fn;
    /* conduction drop of the devices that carry the current (direction = sign of i): threshold
     * rising smoothly from zero current, tanh(|i| / i_c), plus the slope resistance */
    ai = fabs(i_a);
    if (!(inv->nl.i_cap_band_a > 0.0)) {
        onset = (ai > 0.0) ? 1.0 : 0.0;
    } else if (ai < 20.0 * inv->nl.i_cap_band_a) {
        onset = tanh(ai / inv->nl.i_cap_band_a);
    } else {
        onset = 1.0; /* tanh(x) rounds to 1 for x > 19.1 */
    }
    vs = inv->nl.v_switch_drop_v * onset + inv->nl.r_switch_ohm * ai;
    vd = inv->nl.v_diode_drop_v * onset + inv->nl.r_diode_ohm * ai;
    if (i_a > 0.0) {
        drop = fp * vs + (1.0 - fp) * vd;     /* upper switch, lower diode */
    } else if (i_a < 0.0) {
        drop = -(fn * vd + (1.0 - fn) * vs);  /* upper diode, lower switch */
    } else {
        drop = 0.0;
    }
    if (f_hi != 0) *f_hi = f;
    return f * vdc - drop;
}

void inverter_pole_voltages_i(const inverter_t *inv, const double duty[3],
                              const inverter_leg_mode_t mode[3], const double i_abc_a[3],
                              double v_pole_v[3], double f_hi[3])
{
    int k;
    for (k = 0; k < 3; ++k) {
        const double vd = inv->nl.v_diode_drop_v + inv->nl.r_diode_ohm * fabs(i_abc_a[k]);
        double f = 0.0;
        switch (mode[k]) {
        case INV_LEG_PWM:
            v_pole_v[k] = inverter_leg_voltage(inv, inverter_sanitize_duty(duty[k]), i_abc_a[k], &f);
            break;
        case INV_LEG_DIODE_HIGH:
            v_pole_v[k] = inv->cfg.v_dc_v + vd;
            f = 1.0;
            break;
        case INV_LEG_DIODE_LOW:
            v_pole_v[k] = -vd;
            break;
        case INV_LEG_OPEN:
        default:
            v_pole_v[k] = 0.0;
            break;
        }
        if (f_hi != 0) f_hi[k] = f;
    }
}

/* ------------------------------------------------------------------------------------------ */
/* switch level                                                                               */

/** Switch and diode drops [V] of the devices carrying i (thresholds on over the band). */
static void sw_drops(const inverter_t *inv, double i_a, double *v_sw, double *v_di)
{
    const double ai = fabs(i_a);
    double onset;
    if (!(inv->nl.i_cap_band_a > 0.0)) {
        onset = (ai > 0.0) ? 1.0 : 0.0;
    } else if (ai < 20.0 * inv->nl.i_cap_band_a) {
        onset = tanh(ai / inv->nl.i_cap_band_a);
    } else {
        onset = 1.0;
    }
    *v_sw = inv->nl.v_switch_drop_v * onset + inv->nl.r_switch_ohm * ai;
    *v_di = inv->nl.v_diode_drop_v * onset + inv->nl.r_diode_ohm * ai;
}

void inverter_sw_leg_reset(inverter_sw_leg_t *leg, int command)
{
    leg->command = command ? 1 : 0;
    leg->state = command ? INV_SW_HIGH : INV_SW_LOW;
    leg->dead_end_s = 0.0;
    leg->t0_s = 0.0;
    leg->v0_v = 0.0;
    leg->rate_v_s = 0.0;
    leg->t_clamp_s = 0.0;
    leg->v_clamp_v = 0.0;
    leg->f_clamp = 0.0;
}

void inverter_sw_command(const inverter_t *inv, inverter_sw_leg_t *leg, double t_s, int command,
                         double i_a)
{
    const double vdc = inv->cfg.v_dc_v;
    double vs, vd, rate;
    leg->command = command ? 1 : 0;
    if (!inv->nonlinear || !(inv->nl.dead_time_s > 0.0)) {
        leg->state = leg->command ? INV_SW_HIGH : INV_SW_LOW;
        return;
    }
    leg->dead_end_s = t_s + inv->nl.dead_time_s;
    if (leg->state == INV_SW_DEAD) {
        return; /* a transition inside a dead interval extends it; the node law goes on */
    }
    sw_drops(inv, i_a, &vs, &vd);
    /* slew rate i / C with C = i_c t_dt / V_dc; C = 0 (i_c = 0): clamped at once */
    rate = (inv->nl.i_cap_band_a > 0.0) ? fabs(i_a) * vdc / (inv->nl.i_cap_band_a * inv->nl.dead_time_s)
                                        : HUGE_VAL;
    if (leg->state == INV_SW_HIGH) {
        if (i_a > 0.0) { /* the upper switch carried it: the node falls to the lower diode */
            leg->v0_v = vdc - vs;
            leg->v_clamp_v = -vd;
            leg->rate_v_s = -rate;
            leg->f_clamp = 0.0;
        } else {         /* the upper diode carried it (or nothing): it keeps the node */
            leg->v0_v = vdc + vd;
            leg->v_clamp_v = leg->v0_v;
            leg->rate_v_s = 0.0;
            leg->f_clamp = 1.0;
        }
    } else {
        if (i_a < 0.0) { /* the lower switch carried it: the node rises to the upper diode */
            leg->v0_v = vs;
            leg->v_clamp_v = vdc + vd;
            leg->rate_v_s = rate;
            leg->f_clamp = 1.0;
        } else {
            leg->v0_v = -vd;
            leg->v_clamp_v = leg->v0_v;
            leg->rate_v_s = 0.0;
            leg->f_clamp = 0.0;
        }
    }
    leg->t0_s = t_s;
    if (leg->rate_v_s > 0.0 || leg->rate_v_s < 0.0) {
        leg->t_clamp_s = t_s + (leg->v_clamp_v - leg->v0_v) / leg->rate_v_s; /* +-inf rate: t_s */
    } else {
        leg->t_clamp_s = t_s;
    }
    leg->state = INV_SW_DEAD;
}

void inverter_sw_advance(inverter_sw_leg_t *leg, double t_s)
{
    if (leg->state == INV_SW_DEAD && t_s >= leg->dead_end_s) {
        leg->state = leg->command ? INV_SW_HIGH : INV_SW_LOW;
    }
}

double inverter_sw_next_change(const inverter_sw_leg_t *leg, double t_s)
{
    double t = HUGE_VAL;
    if (leg->state == INV_SW_DEAD) {
        if (leg->t_clamp_s > t_s) t = leg->t_clamp_s;
        if (leg->dead_end_s > t_s && leg->dead_end_s < t) t = leg->dead_end_s;
    }
    return t;
}

double inverter_sw_pole_voltage(const inverter_t *inv, const inverter_sw_leg_t *leg, double t_s,
                                double i_a, double *f_hi)
{
    const double vdc = inv->cfg.v_dc_v;
    double v, f, vs, vd;
    switch (leg->state) {
    case INV_SW_HIGH:
        f = 1.0;
        if (!inv->nonlinear) {
            v = vdc;
            break;
        }
        sw_drops(inv, i_a, &vs, &vd);
        v = (i_a > 0.0) ? vdc - vs : ((i_a < 0.0) ? vdc + vd : vdc);
        break;
    case INV_SW_LOW:
        f = 0.0;
        if (!inv->nonlinear) {
            v = 0.0;
            break;
        }
        sw_drops(inv, i_a, &vs, &vd);
        v = (i_a > 0.0) ? -vd : ((i_a < 0.0) ? vs : 0.0);
        break;
    case INV_SW_DEAD:
    default:
        if (t_s >= leg->t_clamp_s) {
            v = leg->v_clamp_v;
            f = leg->f_clamp;
        } else {
            v = leg->v0_v + leg->rate_v_s * (t_s - leg->t0_s);
            f = v / vdc;
            f = (f < 0.0) ? 0.0 : ((f > 1.0) ? 1.0 : f);
        }
        break;
    }
    if (f_hi != 0) *f_hi = f;
    return v;
}

void inverter_sw_shift(inverter_sw_leg_t *leg, double ts_s)
{
    leg->dead_end_s -= ts_s;
    leg->t0_s -= ts_s;
    leg->t_clamp_s -= ts_s;
}
