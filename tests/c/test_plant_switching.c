/**
 * @file test_plant_switching.c
 * @brief The switching mode's parts alone and in the plant: the PWM plan (pwm.h: carrier
 *        phase, pulse edges, the three load modes, narrow pulses), the switch-level leg
 *        (inverter.h: dead interval by the current's sign, node slew, its period average
 *        against the averaged leg formula), and the plant (energy balance, the averaged
 *        fallback for disabled legs, parameter checks).
 *
 * Exit status 0 if every check passes. No files are read.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "inverter.h"
#include "plant.h"
#include "pwm.h"

#include "plant_test_util.h"

#define TS 100e-6
#define VDC 310.0

static pwm_t make_pwm(int carrier, int load)
{
    pwm_t pw;
    pwm_config_t c;
    c.ts_s = TS;
    c.carrier_at_start = carrier;
    c.load = load;
    CHECK(pwm_init(&pw, &c) == 0);
    return pw;
}

/* ------------------------------------------------------------------------------------------ */
/* pwm.h                                                                                      */

static void test_pwm_plan(void)
{
    pwm_t pw = make_pwm(PWM_CARRIER_VALLEY, PWM_LOAD_EXTREMUM);
    pwm_plan_t pl;
    const double d[3] = {0.3, 0.5, 0.9};
    const double z[3] = {0.0, 1.0, 0.5};
    pwm_config_t bad;
    int x;
    /* steady duty, valley at t_k: one pulse of d Ts centred on the peak */
    pwm_plan(&pw, d, d, 0.0, &pl);
    for (x = 0; x < 3; ++x) {
        CHECK(pl.leg[x].n == 2);
        CLOSE(pl.leg[x].t_s[0], (1.0 - d[x]) * 0.5 * TS, 1e-20);
        CHECK(pl.leg[x].level[0] == 1);
        CLOSE(pl.leg[x].t_s[1], (1.0 + d[x]) * 0.5 * TS, 1e-20);
        CHECK(pl.leg[x].level[1] == 0);
        CHECK(pl.leg[x].level_end == 0);
    }
    CLOSE(pwm_carrier(&pw, 0.0), 0.0, 0.0);
    CLOSE(pwm_carrier(&pw, 0.5 * TS), 1.0, 1e-15);
    /* duty 0 and 1: no edge; 1 after a period that ended low: one edge at t = 0 */
    pwm_plan(&pw, z, z, 0.0, &pl);
    CHECK(pl.leg[0].n == 0 && pl.leg[0].level_end == 0);
    CHECK(pl.leg[1].n == 1 && pl.leg[1].t_s[0] <= 0.0 && pl.leg[1].level[0] == 1);
    CHECK(pl.leg[1].level_end == 1);
    pwm_commit(&pw, &pl);
    pwm_plan(&pw, z, d, 0.0, &pl); /* leg b was high: falls at t = 0 */
    CHECK(pl.leg[1].n == 3 && pl.leg[1].level[0] == 0 && pl.leg[1].t_s[0] <= 0.0);
    /* peak at t_k: the pulse is split, high from 0 to d Ts/2 and from Ts - d Ts/2 */
    pw = make_pwm(PWM_CARRIER_PEAK, PWM_LOAD_EXTREMUM);
    pwm_plan(&pw, d, d, 0.0, &pl);
    CHECK(pw.level[0] == 1);
    CHECK(pl.leg[0].n == 2 && pl.leg[0].level[0] == 0 && pl.leg[0].level[1] == 1);
    CLOSE(pl.leg[0].t_s[0], 0.3 * 0.5 * TS, 1e-20);
    CLOSE(pl.leg[0].t_s[1], TS - 0.3 * 0.5 * TS, 1e-20);
    CHECK(pl.leg[0].level_end == 1);
    CLOSE(pwm_carrier(&pw, 0.0), 1.0, 0.0);
    /* the load instants */
    pw = make_pwm(PWM_CARRIER_VALLEY, PWM_LOAD_EXTREMUM);
    CLOSE(pwm_load_instant(&pw, 0.0), 0.0, 0.0);
    CLOSE(pwm_load_instant(&pw, 34.1e-6), 0.5 * TS, 0.0);
    CLOSE(pwm_load_instant(&pw, 0.5 * TS), 0.5 * TS, 0.0);
    CLOSE(pwm_load_instant(&pw, 60e-6), TS, 0.0);
    CLOSE(pwm_load_instant(&pw, NAN), 0.0, 0.0);
    pw.cfg.load = PWM_LOAD_PERIOD;
    CLOSE(pwm_load_instant(&pw, 34.1e-6), TS, 0.0);
    CLOSE(pwm_load_instant(&pw, 0.0), 0.0, 0.0);
    pw.cfg.load = PWM_LOAD_IMMEDIATE;
    CLOSE(pwm_load_instant(&pw, 34.1e-6), 34.1e-6, 0.0);
    CLOSE(pwm_load_instant(&pw, 2.0 * TS), TS, 0.0);
    /* extremum: old duty rises, new duty falls (asymmetric pulse) */
    {
        const double d_old[3] = {0.2, 0.2, 0.2};
        const double d_new[3] = {0.6, 0.6, 0.6};
        pw.cfg.load = PWM_LOAD_EXTREMUM;
        pwm_plan(&pw, d_old, d_new, 34.1e-6, &pl);
        CLOSE(pl.t_load_s, 0.5 * TS, 0.0);
        CHECK(pl.leg[0].n == 2);
        CLOSE(pl.leg[0].t_s[0], 0.8 * 0.5 * TS, 1e-20);
        CLOSE(pl.leg[0].t_s[1], 1.6 * 0.5 * TS, 1e-20);
        /* period: the whole period keeps the old duty */
        pw.cfg.load = PWM_LOAD_PERIOD;
        pwm_plan(&pw, d_old, d_new, 34.1e-6, &pl);
        CLOSE(pl.leg[0].t_s[1], 1.2 * 0.5 * TS, 1e-20);
        /* immediate, written at 34.1 us: the new compare (rise at 20 us) is already past, so
         * the level comparison switches the leg at the write instant */
        pw.cfg.load = PWM_LOAD_IMMEDIATE;
        pwm_plan(&pw, d_old, d_new, 34.1e-6, &pl);
        CHECK(pl.leg[0].n == 2);
        CLOSE(pl.leg[0].t_s[0], 34.1e-6, 0.0);
        CHECK(pl.leg[0].level[0] == 1);
        CLOSE(pl.leg[0].t_s[1], 1.6 * 0.5 * TS, 1e-20);
        /* ... and one written before the old edge acts normally */
        pwm_plan(&pw, d_new, d_old, 10e-6, &pl);
        CLOSE(pl.leg[0].t_s[0], 0.8 * 0.5 * TS, 1e-20);
    }
    bad.ts_s = TS;
    bad.carrier_at_start = 2;
    bad.load = 0;
    CHECK(pwm_init(&pw, &bad) == -1);
    bad.carrier_at_start = 0;
    bad.load = 3;
    CHECK(pwm_init(&pw, &bad) == -1);
    bad.load = 0;
    bad.ts_s = 0.0;
    CHECK(pwm_init(&pw, &bad) == -1);
}

/* ------------------------------------------------------------------------------------------ */
/* the switch-level leg                                                                       */

static inverter_t make_inverter(double t_dt, double vs, double vd, double i_c)
{
    inverter_t inv;
    inverter_config_t c;
    inverter_nl_config_t nl;
    c.v_dc_v = VDC;
    CHECK(inverter_init(&inv, &c) == 0);
    memset(&nl, 0, sizeof nl);
    nl.ts_s = TS;
    nl.dead_time_s = t_dt;
    nl.v_switch_drop_v = vs;
    nl.v_diode_drop_v = vd;
    nl.i_cap_band_a = i_c;
    CHECK(inverter_set_nonlinear(&inv, &nl) == 0);
    return inv;
}

/** The exact time integral of the leg's pole voltage over [a, b) at constant current (the
 *  node law is constant or linear between the instants inverter_sw_next_change reports). */
static double leg_integral(const inverter_t *inv, inverter_sw_leg_t *leg, double a, double b,
                           double i)
{
    double area = 0.0;
    double t = a;
    while (t < b) {
        double tn = inverter_sw_next_change(leg, t);
        if (tn > b) tn = b;
        /* trapezoid = exact for a linear law */
        area += 0.5 * (tn - t) * (inverter_sw_pole_voltage(inv, leg, t, i, NULL) +
                                  inverter_sw_pole_voltage(inv, leg, tn - 1e-30, i, NULL));
        t = tn;
        inverter_sw_advance(leg, t);
    }
    return area;
}

/** Average pole voltage of the third of three periods at constant duty and current. */
static double leg_average(const inverter_t *inv, double duty, double i)
{
    pwm_t pw = make_pwm(PWM_CARRIER_VALLEY, PWM_LOAD_EXTREMUM);
    pwm_plan_t pl;
    inverter_sw_leg_t leg;
    const double d3[3] = {duty, duty, duty};
    double area = 0.0;
    int period, e;
    pwm_reset(&pw, d3);
    inverter_sw_leg_reset(&leg, pw.level[0]);
    for (period = 0; period < 3; ++period) {
        double t = 0.0;
        pwm_plan(&pw, d3, d3, 0.0, &pl);
        area = 0.0;
        for (e = 0; e <= pl.leg[0].n; ++e) {
            const double te = (e < pl.leg[0].n) ? pl.leg[0].t_s[e] : TS;
            area += leg_integral(inv, &leg, t, te, i);
            t = te;
            inverter_sw_advance(&leg, t);
            if (e < pl.leg[0].n) inverter_sw_command(inv, &leg, t, pl.leg[0].level[e], i);
        }
        inverter_sw_shift(&leg, TS);
        pwm_commit(&pw, &pl);
    }
    return area / TS;
}

static void test_sw_leg(void)
{
    /* duties with both edges at least a dead time apart (delta = t_dt / Ts = 0.0178) */
    static const double duties[] = {0.02, 0.3, 0.5, 0.9, 0.975};
    static const double currents[] = {-8.0, -0.6, -0.155, -0.05, -1e-3, 0.0, 2e-3, 0.08, 0.155,
                                      0.4, 12.0};
    const double t_dt = 1.78e-6;
    inverter_t inv = make_inverter(t_dt, 0.0, 0.0, 0.155);
    inverter_sw_leg_t leg;
    double worst = 0.0;
    size_t a, b;
    /* without drops, the switch-level leg's average = the averaged model's formula, exactly:
     * dead time, node slew inside and outside the band, both signs */
    for (a = 0; a < sizeof duties / sizeof duties[0]; ++a) {
        for (b = 0; b < sizeof currents / sizeof currents[0]; ++b) {
            const double want = inverter_leg_voltage(&inv, duties[a], currents[b], NULL);
            const double got = leg_average(&inv, duties[a], currents[b]);
            if (fabs(got - want) > worst) worst = fabs(got - want);
            CLOSE(got, want, 1e-9);
        }
    }
    printf("switch-level leg vs averaged formula (no drops): worst %.3g V\n", worst);
    /* a pulse shorter than the dead time never turns its switch on: current out of the leg
     * keeps the lower diode (0 V); current into it charges the node at |i| / C and the upper
     * diode holds it until the lower switch turns on t_dt after the pulse: high for
     * d Ts + t_dt - t_f / 2, t_f = t_dt i_c / |i| (the averaged formula clamps d - delta at 0
     * and is off there: 7.034 V instead of 7.015 V at -8 A) */
    {
        const double t_f = t_dt * 0.155 / 8.0;
        CLOSE(leg_average(&inv, 0.005, 8.0), 0.0, 1e-12);
        CLOSE(leg_average(&inv, 0.005, -8.0), (0.005 * TS + t_dt - 0.5 * t_f) / TS * VDC, 1e-9);
        CLOSE(leg_average(&inv, 0.995, -8.0), VDC, 1e-9);
        CLOSE(leg_average(&inv, 0.995, 8.0), VDC - (0.005 * TS + t_dt - 0.5 * t_f) / TS * VDC, 1e-9);
        CLOSE(leg_average(&inv, 0.005, 0.0), 0.0, 1e-12); /* no current: nothing moves the node */
    }
    /* with drops the averages differ only by the drops during the node's slew: bounded by
     * (v_s + v_d) t_dt / Ts */
    inv = make_inverter(t_dt, 0.8, 0.9, 0.155);
    worst = 0.0;
    for (a = 0; a < sizeof duties / sizeof duties[0]; ++a) {
        for (b = 0; b < sizeof currents / sizeof currents[0]; ++b) {
            const double want = inverter_leg_voltage(&inv, duties[a], currents[b], NULL);
            const double got = leg_average(&inv, duties[a], currents[b]);
            if (fabs(got - want) > worst) worst = fabs(got - want);
            CLOSE(got, want, (0.8 + 0.9) * t_dt / TS);
        }
    }
    printf("switch-level leg vs averaged formula (drops on): worst %.3g V\n", worst);
    /* the dead interval by the current's sign at the edge */
    inv = make_inverter(2e-6, 0.8, 0.9, 0.0); /* i_c = 0: no node capacitance */
    inverter_sw_leg_reset(&leg, 1);
    inverter_sw_command(&inv, &leg, 10e-6, 0, 5.0); /* upper switch carried 5 A: lower diode */
    CHECK(leg.state == INV_SW_DEAD);
    CLOSE(inverter_sw_pole_voltage(&inv, &leg, 11e-6, 5.0, NULL), -0.9, 1e-12);
    CLOSE(inverter_sw_next_change(&leg, 10e-6), 12e-6, 1e-18);
    inverter_sw_advance(&leg, 12e-6);
    CHECK(leg.state == INV_SW_LOW);
    CLOSE(inverter_sw_pole_voltage(&inv, &leg, 13e-6, 5.0, NULL), -0.9, 1e-12); /* lower diode */
    CLOSE(inverter_sw_pole_voltage(&inv, &leg, 13e-6, -5.0, NULL), 0.8, 1e-12); /* lower switch */
    inverter_sw_command(&inv, &leg, 20e-6, 1, -5.0); /* the lower switch carried -5 A */
    CLOSE(inverter_sw_pole_voltage(&inv, &leg, 21e-6, -5.0, NULL), VDC + 0.9, 1e-12);
    inverter_sw_command(&inv, &leg, 21e-6, 0, -5.0); /* inside the dead interval: extends it */
    CLOSE(leg.dead_end_s, 23e-6, 1e-18);
    CLOSE(inverter_sw_pole_voltage(&inv, &leg, 22e-6, 3.0, NULL), VDC + 0.9, 1e-12); /* held */
    /* a diode carrying the current at the edge keeps it: LOW with i > 0 -> lower diode */
    inverter_sw_leg_reset(&leg, 0);
    inverter_sw_command(&inv, &leg, 0.0, 1, 5.0);
    CLOSE(inverter_sw_pole_voltage(&inv, &leg, 1e-6, 5.0, NULL), -0.9, 1e-12);
    /* the slew: from the upper switch at 0.1 A (inside the band), rate i / C */
    inv = make_inverter(2e-6, 0.0, 0.0, 0.2);
    inverter_sw_leg_reset(&leg, 1);
    inverter_sw_command(&inv, &leg, 0.0, 0, 0.1);
    CLOSE(inverter_sw_pole_voltage(&inv, &leg, 1e-6, 0.1, NULL), VDC - 0.1 * 1e-6 / (0.2 * 2e-6 / VDC),
          1e-9);
    CHECK(!(inverter_sw_next_change(&leg, 0.0) < 2e-6)); /* not clamped within the dead time */
    inverter_sw_advance(&leg, 2e-6);
    CHECK(leg.state == INV_SW_LOW);
    /* ... at 1 A it reaches the lower rail after t_dt i_c / i = 0.4 us */
    inverter_sw_leg_reset(&leg, 1);
    inverter_sw_command(&inv, &leg, 0.0, 0, 1.0);
    CLOSE(inverter_sw_next_change(&leg, 0.0), 0.4e-6, 1e-18);
    CLOSE(inverter_sw_pole_voltage(&inv, &leg, 1e-6, 1.0, NULL), 0.0, 1e-12);
}

/* ------------------------------------------------------------------------------------------ */
/* in the plant                                                                               */

static void set_switching(plant_params_t *p, int nonlinear)
{
    p->inverter.inverter = 1;
    p->inverter.inverter_nonlinear = nonlinear;
    p->inverter.dead_time_s = 1.78e-6;
    p->inverter.v_switch_drop_v = 0.8;
    p->inverter.r_switch_ohm = 0.035;
    p->inverter.v_diode_drop_v = 0.9;
    p->inverter.r_diode_ohm = 0.035;
    p->inverter.i_cap_band_a = 0.155;
}

static void test_plant_energy_and_fallback(void)
{
    plant_params_t p = gong_params();
    plant_t pl;
    plant_energy_t e;
    double res_m, res_dc, scale;
    int k;
    set_switching(&p, 1);
    CHECK(plant_init(&pl, &p) == 0);
    for (k = 0; k < 3000; ++k) { /* V/f spin-up, 20 Hz */
        const double t = (double)k * p.ts_s;
        const double th = 2.0 * T_PI * 20.0 * (t < 0.1 ? t * t / 0.2 : t - 0.05);
        const double vmag = 6.0 + 2.0 * T_PI * 20.0 * fmin(t / 0.1, 1.0) * p.psi_f_wb * 4.0;
        double d[3];
        int x;
        for (x = 0; x < 3; ++x) {
            d[x] = 0.5 + vmag / p.v_dc_v * cos(th + 0.5 * T_PI - 2.0 * T_PI / 3.0 * (double)x);
        }
        plant_step(&pl, d);
    }
    CHECK(pl.sw_periods == 3000UL);
    plant_energy(&pl, &e);
    res_m = e.electrical_in_j - (e.copper_loss_j + e.viscous_loss_j + e.load_work_j + e.magnetic_j +
                                 e.kinetic_j);
    res_dc = e.dc_bus_in_j - (e.electrical_in_j + e.inverter_loss_j);
    scale = e.copper_loss_j + e.viscous_loss_j + e.magnetic_j + e.kinetic_j + e.inverter_loss_j;
    printf("switching energy: residual %.3g J of %.3g J moved, inverter loss %.4g J\n", res_m, scale,
           e.inverter_loss_j);
    CHECK(fabs(res_m) < 1e-7 * scale);
    CHECK(fabs(res_dc) < 1e-12 * scale);
    CHECK(e.inverter_loss_j > 0.0);
    /* a disabled leg: that period is integrated on the averaged path, then switching again */
    {
        const double off[3] = {-1.0, 0.5, 0.5};
        const double on[3] = {0.5, 0.5, 0.5};
        const unsigned long before = pl.sw_periods;
        plant_step(&pl, off);
        CHECK(pl.sw_periods == before);
        plant_step(&pl, on); /* the previous duties had a disabled leg: averaged once more */
        CHECK(pl.sw_periods == before);
        plant_step(&pl, on);
        CHECK(pl.sw_periods == before + 1UL);
        CHECK(isfinite(pl.y[0]) && isfinite(pl.y[1]));
    }
    plant_reset(&pl);
    CHECK(pl.sw_periods == 0UL);
    /* the IPMSM too (Ld != Lq): a few periods at switch level stay finite and balanced */
    p = hou_params();
    set_switching(&p, 1);
    CHECK(plant_init(&pl, &p) == 0);
    for (k = 0; k < 200; ++k) {
        const double d[3] = {0.55, 0.45, 0.5};
        plant_step(&pl, d);
    }
    plant_energy(&pl, &e);
    res_m = e.electrical_in_j - (e.copper_loss_j + e.viscous_loss_j + e.load_work_j + e.magnetic_j +
                                 e.kinetic_j);
    CHECK(fabs(res_m) < 1e-7 * (e.copper_loss_j + e.magnetic_j + e.kinetic_j));
}

static void test_plant_checks(void)
{
    plant_params_t p = gong_params();
    const char *msg;
    p.inverter.inverter = 2;
    msg = plant_params_check(&p);
    CHECK(msg != NULL && strcmp(msg, "inverter: must be averaged or switching") == 0);
    p.inverter.inverter = 0;
    p.inverter.carrier_at_start = -1;
    msg = plant_params_check(&p);
    CHECK(msg != NULL && strcmp(msg, "carrier_at_start: must be valley or peak") == 0);
    p.inverter.carrier_at_start = 1;
    p.inverter.pwm_load = 3;
    msg = plant_params_check(&p);
    CHECK(msg != NULL && strcmp(msg, "pwm_load: must be extremum, period or immediate") == 0);
    p.inverter.pwm_load = 2;
    p.sensors.dual_sample_at = 1;
    msg = plant_params_check(&p);
    CHECK(msg != NULL && strcmp(msg, "dual_sample_at: half_period needs inverter = switching") == 0);
    p.inverter.inverter = 1;
    CHECK(plant_params_check(&p) == NULL);
}

int main(void)
{
    test_pwm_plan();
    test_sw_leg();
    test_plant_energy_and_fallback();
    test_plant_checks();
    printf("%d checks, %d failures\n", g_checks, g_failures);
    return g_failures == 0 ? 0 : 1;
}
