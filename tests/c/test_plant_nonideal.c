/**
 * @file test_plant_nonideal.c
 * @brief The plant's non-idealities, each part alone and in the assembled plant:
 *        inverter leg average (dead time, drops, capacitance sign), d-axis saturation,
 *        PRNG + ADC, friction and load profiles, dynamometer, sampling, parameter checks,
 *        energy balance with every effect on, and "all off" == the ideal plant bit for bit.
 *
 * Exit status 0 if every check passes. No files are read.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "inverter.h"
#include "mechanics.h"
#include "plant.h"
#include "pmsm_machine.h"
#include "sensor.h"

#include "plant_test_util.h"

static void set_inverter(plant_params_t *p)
{
    p->inverter.inverter_nonlinear = 1;
    p->inverter.dead_time_s = 2e-6;
    p->inverter.v_switch_drop_v = 0.8;
    p->inverter.r_switch_ohm = 0.035;
    p->inverter.v_diode_drop_v = 0.9;
    p->inverter.r_diode_ohm = 0.035;
    p->inverter.i_cap_band_a = 0.155;
}

static void set_saturation(plant_params_t *p)
{
    p->magnetics.saturation = 1;
    p->magnetics.sat_l_inf_ratio = 0.7;
    p->magnetics.sat_i_scale_a = 6.1;
    p->magnetics.sat_i_knee_a = -3.0;
}

/* ------------------------------------------------------------------------------------------ */
/* inverter leg                                                                               */

static void test_inverter_leg(void)
{
    inverter_config_t cfg;
    inverter_nl_config_t nl;
    inverter_t inv;
    const double vdc = 310.0;
    const double delta = 2e-6 / 1e-4;
    double f, v;
    cfg.v_dc_v = vdc;
    CHECK(inverter_init(&inv, &cfg) == 0);
    /* ideal: d V_dc, f = d */
    CLOSE(inverter_leg_voltage(&inv, 0.3, 5.0, &f), 0.3 * vdc, 1e-12);
    CLOSE(f, 0.3, 0.0);
    memset(&nl, 0, sizeof nl);
    nl.ts_s = 1e-4;
    nl.dead_time_s = 2e-6;
    CHECK(inverter_set_nonlinear(&inv, &nl) == 0); /* i_cap = 0: hard sign (stand-alone use) */
    /* dead time only, hard sign: -sign(i) t_dt/Ts V_dc */
    CLOSE(inverter_leg_voltage(&inv, 0.3, 5.0, &f), (0.3 - delta) * vdc, 1e-12);
    CLOSE(f, 0.3 - delta, 1e-15);
    CLOSE(inverter_leg_voltage(&inv, 0.3, -5.0, &f), (0.3 + delta) * vdc, 1e-12);
    CLOSE(f, 0.3 + delta, 1e-15);
    CLOSE(inverter_leg_voltage(&inv, 0.3, 0.0, NULL), 0.3 * vdc, 1e-12); /* sign(0) = 0 */
    /* the fractions clamp at the rails */
    CLOSE(inverter_leg_voltage(&inv, 0.01, 5.0, &f), 0.0, 1e-12);
    CLOSE(f, 0.0, 0.0);
    CLOSE(inverter_leg_voltage(&inv, 0.995, -5.0, &f), vdc, 1e-12);
    /* drops: i > 0: f (V_dc - V_s) - (1 - f) V_d; i < 0: f (V_dc + V_d) + (1 - f) V_s */
    nl.v_switch_drop_v = 1.1;
    nl.r_switch_ohm = 0.05;
    nl.v_diode_drop_v = 0.9;
    nl.r_diode_ohm = 0.04;
    CHECK(inverter_set_nonlinear(&inv, &nl) == 0);
    {
        const double fp = 0.6 - delta;
        const double fn = 0.6 + delta;
        const double vs = 1.1 + 0.05 * 4.0;
        const double vd = 0.9 + 0.04 * 4.0;
        CLOSE(inverter_leg_voltage(&inv, 0.6, 4.0, NULL), fp * (vdc - vs) - (1.0 - fp) * vd, 1e-12);
        CLOSE(inverter_leg_voltage(&inv, 0.6, -4.0, NULL), fn * (vdc + vd) + (1.0 - fn) * vs, 1e-12);
    }
    /* capacitance sign: g(i) = i/(2 ic) inside, 1 - ic/(2|i|) outside, C1 at ic */
    nl.v_switch_drop_v = 0.0;
    nl.r_switch_ohm = 0.0;
    nl.v_diode_drop_v = 0.0;
    nl.r_diode_ohm = 0.0;
    nl.i_cap_band_a = 0.2;
    CHECK(inverter_set_nonlinear(&inv, &nl) == 0);
    CLOSE(inverter_smooth_sign(&inv, 0.1), 0.25, 1e-15);
    CLOSE(inverter_smooth_sign(&inv, -0.1), -0.25, 1e-15);
    CLOSE(inverter_smooth_sign(&inv, 0.2), 0.5, 1e-15);
    CLOSE(inverter_smooth_sign(&inv, 0.8), 1.0 - 0.125, 1e-15);
    CLOSE(inverter_smooth_sign(&inv, 0.0), 0.0, 0.0);
    {
        const double h = 1e-7;
        const double left = (inverter_smooth_sign(&inv, 0.2) - inverter_smooth_sign(&inv, 0.2 - h)) / h;
        const double right = (inverter_smooth_sign(&inv, 0.2 + h) - inverter_smooth_sign(&inv, 0.2)) / h;
        CLOSE(left, right, 1e-5); /* continuous slope at the band edge */
    }
    v = inverter_leg_voltage(&inv, 0.5, 0.1, NULL);
    CLOSE(v, 0.5 * vdc - 0.25 * delta * vdc, 1e-12);
    /* bad configurations are refused (and leave the inverter as it was) */
    nl.dead_time_s = 0.5e-4; /* = Ts/2 */
    CHECK(inverter_set_nonlinear(&inv, &nl) == -1);
    nl.dead_time_s = 2e-6;
    nl.v_diode_drop_v = -0.1;
    CHECK(inverter_set_nonlinear(&inv, &nl) == -1);
    nl.v_diode_drop_v = NAN;
    CHECK(inverter_set_nonlinear(&inv, &nl) == -1);
    CHECK(inverter_set_nonlinear(&inv, NULL) == 0);
    CHECK(inv.nonlinear == 0);
    CLOSE(inverter_leg_voltage(&inv, 0.3, 5.0, NULL), 0.3 * vdc, 1e-12);
}

/* ------------------------------------------------------------------------------------------ */
/* saturation                                                                                 */

static void test_saturation(void)
{
    pmsm_machine_config_t mc;
    pmsm_saturation_config_t sc;
    pmsm_machine_t m;
    double x, e_num, prev_l;
    int k;
    mc.rs_ohm = 0.78;
    mc.ld_h = 2.5e-3;
    mc.lq_h = 8.5e-3;
    mc.psi_f_wb = 0.303;
    mc.pole_pairs = 3;
    CHECK(pmsm_machine_init(&m, &mc) == 0);
    CLOSE(pmsm_machine_psi_d(&m, 2.0), 0.303 + 2.5e-3 * 2.0, 1e-15);
    CLOSE(pmsm_machine_ld_inc(&m, 2.0), 2.5e-3, 0.0);
    sc.l_inf_ratio = 0.7;
    sc.i_scale_a = 6.1;
    sc.i_knee_a = -3.0;
    CHECK(pmsm_machine_set_saturation(&m, &sc) == 0);
    /* small signal at zero current: the profile values */
    CLOSE(pmsm_machine_psi_d(&m, 0.0), 0.303, 1e-15);
    CLOSE(pmsm_machine_ld_inc(&m, 0.0), 2.5e-3, 1e-15);
    /* L_inc is the derivative of psi_d (central differences) */
    for (x = -12.0; x <= 12.0; x += 1.5) {
        const double h = 1e-4;
        const double d = (pmsm_machine_psi_d(&m, x + h) - pmsm_machine_psi_d(&m, x - h)) / (2.0 * h);
        CLOSE(pmsm_machine_ld_inc(&m, x), d, 1e-10);
    }
    /* falls monotonically for every positive i_d, rises towards the knee for negative i_d */
    prev_l = pmsm_machine_ld_inc(&m, 0.0);
    for (k = 1; k <= 40; ++k) {
        const double l = pmsm_machine_ld_inc(&m, 0.5 * (double)k);
        CHECK(l < prev_l);
        prev_l = l;
    }
    CHECK(pmsm_machine_ld_inc(&m, -3.0) > pmsm_machine_ld_inc(&m, -1.0));
    CHECK(pmsm_machine_ld_inc(&m, -1.0) > pmsm_machine_ld_inc(&m, 0.0));
    CLOSE(pmsm_machine_ld_inc(&m, 4.767) / 2.5e-3, 0.80, 0.01); /* the profile's targets */
    CLOSE(pmsm_machine_ld_inc(&m, -4.767) / 2.5e-3, 1.05, 0.01);
    CHECK(pmsm_machine_ld_inc(&m, 1e3) > 0.7 * 2.5e-3 * 0.999);
    /* stored energy = 1.5 int_0^i x L_inc(x) dx (+ q axis), trapezoid with 20000 panels */
    for (x = -9.0; x <= 9.0; x += 4.5) {
        const int n = 20000;
        double acc = 0.0;
        for (k = 0; k < n; ++k) {
            const double a = x * (double)k / n;
            const double b = x * (double)(k + 1) / n;
            acc += 0.5 * (b - a) * (a * pmsm_machine_ld_inc(&m, a) + b * pmsm_machine_ld_inc(&m, b));
        }
        e_num = 1.5 * acc + 0.75 * 8.5e-3 * 2.0 * 2.0;
        CLOSE(pmsm_machine_stored_energy(&m, x, 2.0), e_num, 1e-9 * (1.0 + fabs(e_num)));
    }
    /* torque: 1.5 p (psi_d i_q - L_q i_d i_q) */
    CLOSE(pmsm_machine_torque(&m, 3.0, 2.0), 4.5 * (pmsm_machine_psi_d(&m, 3.0) * 2.0 - 8.5e-3 * 6.0), 1e-12);
    /* refusals */
    sc.i_knee_a = 1.0;
    CHECK(pmsm_machine_set_saturation(&m, &sc) == -1);
    CHECK(m.saturated == 0);
    sc.i_knee_a = -3.0;
    sc.l_inf_ratio = 0.0;
    CHECK(pmsm_machine_set_saturation(&m, &sc) == -1);
    sc.l_inf_ratio = 0.7;
    sc.i_scale_a = 0.0;
    CHECK(pmsm_machine_set_saturation(&m, &sc) == -1);
}

/* ------------------------------------------------------------------------------------------ */
/* PRNG and ADC                                                                               */

static void test_rng_and_adc(void)
{
    sensor_rng_t r;
    sensor_adc_config_t c;
    double sum = 0.0, sum2 = 0.0;
    int k, code;
    /* xoshiro256** seeded by splitmix64: values from an independent Python implementation */
    sensor_rng_seed(&r, 0);
    CHECK(sensor_rng_next_u64(&r) == UINT64_C(0x99ec5f36cb75f2b4));
    CHECK(sensor_rng_next_u64(&r) == UINT64_C(0xbf6e1f784956452a));
    CHECK(sensor_rng_next_u64(&r) == UINT64_C(0x1a5f849d4933e6e0));
    sensor_rng_seed(&r, 12345);
    CHECK(sensor_rng_next_u64(&r) == UINT64_C(0xbe6a36374160d49b));
    CHECK(sensor_rng_next_u64(&r) == UINT64_C(0x214aaa0637a688c6));
    /* Gaussian: mean 0, variance 1 (200000 draws: 5 sigma bounds) */
    sensor_rng_seed(&r, 7);
    for (k = 0; k < 200000; ++k) {
        const double g = sensor_rng_normal(&r);
        sum += g;
        sum2 += g * g;
    }
    CLOSE(sum / 200000.0, 0.0, 5.0 / sqrt(200000.0));
    CLOSE(sum2 / 200000.0, 1.0, 5.0 * sqrt(2.0 / 200000.0));
    /* ADC: 12 bit bipolar +-20 A, LSB = 20/2048 */
    memset(&c, 0, sizeof c);
    c.bits = 12;
    c.bipolar = 1;
    c.full_scale = 20.0;
    sensor_rng_seed(&r, 1);
    CLOSE(sensor_adc_convert(&c, &r, 1.0, &code), 102.0 * 20.0 / 2048.0, 1e-15); /* round(102.4) */
    CHECK(code == 2048 + 102);
    CLOSE(sensor_adc_convert(&c, &r, -30.0, &code), -20.0, 1e-15); /* clamps */
    CHECK(code == 0);
    CLOSE(sensor_adc_convert(&c, &r, 30.0, &code), 20.0 - 20.0 / 2048.0, 1e-15);
    CHECK(code == 4095);
    c.gain_err = 0.02;
    c.offset = 0.1;
    CLOSE(sensor_adc_convert(&c, &r, 5.0, &code), floor((1.02 * 5.0 + 0.1) / (20.0 / 2048.0) + 0.5) * 20.0 / 2048.0, 1e-12);
    /* unipolar bus voltage: 0..500 V */
    memset(&c, 0, sizeof c);
    c.bits = 12;
    c.full_scale = 500.0;
    CLOSE(sensor_adc_convert(&c, &r, 310.0, &code), floor(310.0 / (500.0 / 4096.0) + 0.5) * 500.0 / 4096.0, 1e-12);
    CLOSE(sensor_adc_convert(&c, &r, -5.0, &code), 0.0, 0.0);
}

/* ------------------------------------------------------------------------------------------ */
/* mechanics                                                                                  */

static void test_mechanics_parts(void)
{
    mechanics_config_t cfg;
    mechanics_t m;
    mechanics_load_profile_t lp;
    cfg.j_kgm2 = 0.01;
    cfg.b_nms = 0.002;
    cfg.pole_pairs = 4;
    CHECK(mechanics_init(&m, &cfg) == 0);
    CHECK(mechanics_set_coulomb(&m, 0.1, 0.5) == 0);
    CLOSE(mechanics_friction_torque(&m, 2.0), 0.004 + 0.1 * tanh(4.0), 1e-15);
    CLOSE(mechanics_friction_torque(&m, -2.0), -(0.004 + 0.1 * tanh(4.0)), 1e-15);
    CLOSE(mechanics_accel(&m, 2.0, 1.0, 0.3), (1.0 - 0.004 - 0.1 * tanh(4.0) - 0.3) / 0.01, 1e-12);
    CHECK(mechanics_set_coulomb(&m, 0.1, 0.0) == -1);
    CHECK(mechanics_set_coulomb(&m, -0.1, 1.0) == -1);
    /* profiles: value and exact period mean */
    memset(&lp, 0, sizeof lp);
    lp.kind = MECH_LOAD_STEP;
    lp.t0_s = 0.10005;
    lp.torque0_nm = 1.0;
    lp.torque1_nm = 3.0;
    CHECK(mechanics_load_profile_check(&lp) == NULL);
    CLOSE(mechanics_load_profile_at(&lp, 0.1), 1.0, 0.0);
    CLOSE(mechanics_load_profile_at(&lp, 0.10005), 3.0, 0.0);
    CLOSE(mechanics_load_profile_mean(&lp, 0.1, 0.1001), 2.0, 1e-9);
    CLOSE(mechanics_load_profile_mean(&lp, 0.2, 0.2001), 3.0, 0.0);
    lp.kind = MECH_LOAD_RAMP;
    lp.t0_s = 1.0;
    lp.t1_s = 3.0;
    CHECK(mechanics_load_profile_check(&lp) == NULL);
    CLOSE(mechanics_load_profile_at(&lp, 2.0), 2.0, 1e-15);
    CLOSE(mechanics_load_profile_mean(&lp, 0.0, 4.0), (1.0 * 1.0 + 2.0 * 2.0 + 3.0 * 1.0) / 4.0, 1e-14);
    CLOSE(mechanics_load_profile_mean(&lp, 2.0, 2.5), 2.25, 1e-14);
    lp.t1_s = 1.0;
    CHECK(mechanics_load_profile_check(&lp) != NULL);
    lp.kind = MECH_LOAD_TABLE;
    lp.table_n = 3;
    lp.table_t_s[0] = 0.0;
    lp.table_t_s[1] = 1.0;
    lp.table_t_s[2] = 2.0;
    lp.table_nm[0] = 0.0;
    lp.table_nm[1] = 2.0;
    lp.table_nm[2] = -2.0;
    CHECK(mechanics_load_profile_check(&lp) == NULL);
    CLOSE(mechanics_load_profile_at(&lp, 1.5), 0.0, 1e-15);
    CLOSE(mechanics_load_profile_at(&lp, 5.0), -2.0, 0.0);
    CLOSE(mechanics_load_profile_mean(&lp, 0.0, 2.0), 0.5, 1e-14); /* areas 1 + 0 over 2 s */
    CLOSE(mechanics_load_profile_mean(&lp, 0.5, 1.5), 1.25, 1e-14); /* 0.75 + 0.5 over 1 s */
    lp.table_t_s[2] = 1.0;
    CHECK(mechanics_load_profile_check(&lp) != NULL);
    lp.table_n = 0;
    CHECK(mechanics_load_profile_check(&lp) != NULL);
}

/* ------------------------------------------------------------------------------------------ */
/* assembled plant                                                                            */

static void test_params_check(void)
{
    plant_params_t p = gong_params();
    CHECK(plant_params_check(&p) == NULL);
    /* a disabled group is not checked */
    p.inverter.dead_time_s = -1.0;
    CHECK(plant_params_check(&p) == NULL);
    set_inverter(&p);
    CHECK(plant_params_check(&p) == NULL);
    p.inverter.dead_time_s = 60e-6;
    CHECK(strcmp(plant_params_check(&p), "dead_time_s: must be < ts_s / 2") == 0);
    p.inverter.dead_time_s = 2e-6;
    p.inverter.i_cap_band_a = 0.0;
    CHECK(strcmp(plant_params_check(&p), "i_cap_band_a: must be > 0") == 0);
    p.inverter.i_cap_band_a = 1e-3;
    CHECK(strcmp(plant_params_check(&p), "i_cap_band_a: too small for the RK4 step (raise it or substeps)") == 0);
    p.substeps = 400; /* a finer step makes the same band integrable */
    CHECK(plant_params_check(&p) == NULL);
    p = gong_params();
    p.inverter.inverter_nonlinear = 2;
    CHECK(strcmp(plant_params_check(&p), "inverter_nonlinear: must be 0 or 1") == 0);
    p = gong_params();
    p.magnetics.saturation = 1;
    CHECK(strcmp(plant_params_check(&p), "sat_l_inf_ratio: must be > 0") == 0);
    p = gong_params();
    p.sensors.adc_model = 1;
    CHECK(strcmp(plant_params_check(&p), "adc_bits: must be 1 .. 24") == 0);
    p.sensors.adc_bits = 12;
    CHECK(strcmp(plant_params_check(&p), "adc_full_scale_a: must be > 0") == 0);
    p = gong_params();
    p.mechanics.coulomb_nm = 0.1;
    CHECK(strcmp(plant_params_check(&p), "coulomb_band_rad_s: must be > 0") == 0);
    p.mechanics.coulomb_band_rad_s = 1e-9;
    CHECK(strcmp(plant_params_check(&p), "coulomb_band_rad_s: too small for the RK4 step (raise it or substeps)") == 0);
    p = gong_params();
    p.mechanics.load_profile = 2;
    p.mechanics.load_t0_s = 1.0;
    CHECK(strcmp(plant_params_check(&p), "load_t1_s: must be > load_t0_s for a ramp") == 0);
    p.mechanics.load_profile = 7;
    CHECK(strcmp(plant_params_check(&p), "load_profile: must be none, step, ramp or table") == 0);
    p = gong_params();
    p.mechanics.dyno = 1;
    p.mechanics.dyno_accel_rad_s2 = -1.0;
    CHECK(strcmp(plant_params_check(&p), "dyno_accel_rad_s2: must be >= 0") == 0);
    p = gong_params();
    p.full_period_delay = 3;
    CHECK(strcmp(plant_params_check(&p), "full_period_delay: must be 0 or 1") == 0);
}

/** The same open-loop run on two plants; returns max |difference| of every state. */
static double run_pair_diff(const plant_params_t *pa, const plant_params_t *pb, int n)
{
    plant_t a, b;
    plant_snapshot_t sa, sb;
    double worst = 0.0;
    int k;
    if (plant_init(&a, pa) != 0 || plant_init(&b, pb) != 0) {
        return HUGE_VAL;
    }
    plant_set_initial(&a, 0.3, 20.0);
    plant_set_initial(&b, 0.3, 20.0);
    for (k = 0; k < n; ++k) {
        const double th = 0.3 + 80.0 * (double)k * 1e-4;
        double d[3];
        int x;
        for (x = 0; x < 3; ++x) {
            d[x] = 0.5 + 0.05 * cos(th + 0.5 * T_PI - 2.0 * T_PI / 3.0 * (double)x);
        }
        if (k % 97 == 50) d[1] = -1.0;
        plant_step(&a, d);
        plant_step(&b, d);
        plant_snapshot(&a, &sa);
        plant_snapshot(&b, &sb);
        worst = fmax(worst, fabs(sa.i_a_a - sb.i_a_a) + fabs(sa.i_b_a - sb.i_b_a) +
                                fabs(sa.omega_m_rad_s - sb.omega_m_rad_s) +
                                fabs(sa.theta_m_rad - sb.theta_m_rad));
    }
    return worst;
}

static void test_off_is_ideal(void)
{
    /* group parameters set but switches off: exactly the ideal plant */
    plant_params_t a = hou_params();
    plant_params_t b = hou_params();
    set_inverter(&b);
    set_saturation(&b);
    b.inverter.inverter_nonlinear = 0;
    b.magnetics.saturation = 0;
    b.sensors.adc_bits = 12;
    b.sensors.adc_full_scale_a = 10.0;
    b.sensors.dual_sampling = 1; /* sampling does not change the dynamics */
    CHECK(!(run_pair_diff(&a, &b, 2000) > 0.0)); /* exactly equal */
    /* full_period_delay == t_delay_s = ts_s */
    a = gong_params();
    b = gong_params();
    a.t_delay_s = a.ts_s;
    b.full_period_delay = 1;
    CHECK(!(run_pair_diff(&a, &b, 2000) > 0.0)); /* exactly equal */
    /* and a switched-on effect does change them (the comparison can fail) */
    b = hou_params();
    set_saturation(&b);
    a = hou_params();
    CHECK(run_pair_diff(&a, &b, 2000) > 1e-3);
}

static void energy_residuals(const plant_t *pl, double kin0, double *res_machine, double *res_dc,
                             double *scale)
{
    plant_energy_t e;
    plant_energy(pl, &e);
    *res_machine = e.electrical_in_j - (e.copper_loss_j + e.viscous_loss_j + e.coulomb_loss_j +
                                        e.load_work_j + e.magnetic_j + e.kinetic_j - kin0);
    *res_dc = e.dc_bus_in_j - (e.electrical_in_j + e.inverter_loss_j);
    *scale = fabs(e.copper_loss_j) + fabs(e.viscous_loss_j) + fabs(e.coulomb_loss_j) +
             fabs(e.load_work_j) + fabs(e.magnetic_j) + fabs(e.kinetic_j) + fabs(e.inverter_loss_j);
}

static void test_energy_all_effects(void)
{
    /* V/f spin-up of the IPMSM with dead time, drops, saturation, Coulomb friction and a load
     * ramp: the energy drawn from the bus = inverter loss + copper + friction + load work +
     * stored energy */
    plant_params_t p = hou_params();
    plant_t pl;
    plant_energy_t e;
    double rm, rd, scale;
    int k;
    set_inverter(&p);
    set_saturation(&p);
    p.mechanics.coulomb_nm = 0.05;
    p.mechanics.coulomb_band_rad_s = 0.5;
    p.mechanics.load_profile = MECH_LOAD_RAMP;
    p.mechanics.load_t0_s = 0.2;
    p.mechanics.load_t1_s = 0.3;
    p.mechanics.load_torque1_nm = 1.5;
    CHECK(plant_init(&pl, &p) == 0);
    for (k = 0; k < 4000; ++k) {
        const double t = (double)k * p.ts_s;
        const double th = 2.0 * T_PI * 30.0 * (t < 0.2 ? t * t / 0.4 : t - 0.1);
        const double vmag = 8.0 + 2.0 * T_PI * 30.0 * fmin(t / 0.2, 1.0) * p.psi_f_wb;
        double d[3];
        int x;
        for (x = 0; x < 3; ++x) {
            d[x] = 0.5 + vmag / p.v_dc_v * cos(th + 0.5 * T_PI - 2.0 * T_PI / 3.0 * (double)x);
        }
        plant_step(&pl, d);
    }
    plant_energy(&pl, &e);
    energy_residuals(&pl, 0.0, &rm, &rd, &scale);
    CHECK(e.inverter_loss_j > 1e-3 && e.coulomb_loss_j > 1e-3 && e.load_work_j > 1e-3);
    /* measured 2.8e-8 of the energy moved: the RK4 truncation error at the kinks of |i| and the
     * C1 (not C2) capacitance sign; the ideal plant closes to 1e-9 (test_plant.c) */
    printf("energy, all effects: residual %.3g J of %.3g J moved\n", rm, scale);
    CHECK(fabs(rm) < 1e-7 * scale);
    CHECK(fabs(rd) < 1e-12 * scale);
}

static void test_dyno_and_sampling(void)
{
    plant_params_t p = gong_params();
    plant_t pl;
    plant_snapshot_t s;
    plant_sample_t m;
    double rm, rd, scale;
    int k;
    /* dyno: the speed follows the set speed at the slew rate; the reported torque balances */
    p.mechanics.dyno = 1;
    p.mechanics.dyno_speed_rad_s = 50.0;
    p.mechanics.dyno_accel_rad_s2 = 200.0;
    p.sensors.dual_sampling = 1;
    CHECK(plant_init(&pl, &p) == 0);
    plant_snapshot(&pl, &s);
    CLOSE(s.omega_m_rad_s, 50.0, 0.0);
    plant_sample(&pl, &m);
    CHECK(m.dual_valid == 0 && m.code_a == -1);
    plant_set_dyno_speed(&pl, 60.0);
    for (k = 0; k < 100; ++k) {
        plant_step_abc(&pl, 0.52, 0.49, 0.49);
    }
    plant_snapshot(&pl, &s);
    CLOSE(s.omega_m_rad_s, 50.0 + 200.0 * 100e-4, 1e-9); /* still slewing: 0.02 rad/s per period */
    CLOSE(s.torque_load_nm, s.torque_e_nm - s.torque_friction_nm - p.j_kgm2 * 200.0, 1e-12);
    for (k = 0; k < 1000; ++k) {
        plant_step_abc(&pl, 0.52, 0.49, 0.49);
    }
    plant_snapshot(&pl, &s);
    CLOSE(s.omega_m_rad_s, 60.0, 1e-9);
    CLOSE(s.torque_load_nm, s.torque_e_nm - s.torque_friction_nm, 1e-12);
    energy_residuals(&pl, 0.5 * p.j_kgm2 * 2500.0, &rm, &rd, &scale);
    CHECK(fabs(rm) < 1e-8 * scale);
    /* a speed step (slew 0) books the kinetic energy jump as dyno work */
    p.mechanics.dyno_accel_rad_s2 = 0.0;
    CHECK(plant_init(&pl, &p) == 0);
    plant_set_dyno_speed(&pl, 80.0);
    for (k = 0; k < 200; ++k) {
        plant_step_abc(&pl, 0.52, 0.49, 0.49);
    }
    plant_snapshot(&pl, &s);
    CLOSE(s.omega_m_rad_s, 80.0, 0.0);
    energy_residuals(&pl, 0.5 * p.j_kgm2 * 2500.0, &rm, &rd, &scale);
    CHECK(fabs(rm) < 1e-8 * scale);

    /* second sample: the state at t_{k-1} + t_d; with t_d = 0 it is the previous first sample */
    p = gong_params();
    p.sensors.dual_sampling = 1;
    p.t_delay_s = 0.0;
    CHECK(plant_init(&pl, &p) == 0);
    plant_set_initial(&pl, 0.2, 30.0);
    for (k = 0; k < 5; ++k) {
        double prev_a, prev_b;
        plant_sample(&pl, &m);
        prev_a = m.i_a_a;
        prev_b = m.i_b_a;
        plant_step_abc(&pl, 0.6, 0.45, 0.45);
        plant_sample(&pl, &m);
        CHECK(m.dual_valid == 1);
        CLOSE(m.i2_a_a, prev_a, 0.0);
        CLOSE(m.i2_b_a, prev_b, 0.0);
        CLOSE(m.t2_s, pl.t_s - p.ts_s, 1e-18);
    }
    /* with the full-period delay it is the present first sample (same instant) */
    p.full_period_delay = 1;
    CHECK(plant_init(&pl, &p) == 0);
    for (k = 0; k < 5; ++k) {
        plant_step_abc(&pl, 0.6, 0.45, 0.45);
        plant_sample(&pl, &m);
        plant_snapshot(&pl, &s);
        CLOSE(m.i2_a_a, s.i_a_a, 0.0);
        CLOSE(m.t2_s, s.t_s, 1e-18);
    }
}

static void test_adc_in_plant(void)
{
    plant_params_t p = gong_params();
    plant_t a, b;
    plant_sample_t ma, mb;
    plant_snapshot_t s;
    int k;
    p.sensors.adc_model = 1;
    p.sensors.adc_bits = 12;
    p.sensors.adc_full_scale_a = 20.0;
    p.sensors.adc_vdc_full_scale_v = 500.0;
    p.sensors.adc_seed = 42;
    CHECK(plant_init(&a, &p) == 0);
    p.sensors.dual_sampling = 1;
    CHECK(plant_init(&b, &p) == 0);
    for (k = 0; k < 50; ++k) { /* a few amperes, inside the +-20 A full scale */
        plant_step_abc(&a, 0.51, 0.495, 0.495);
        plant_step_abc(&b, 0.51, 0.495, 0.495);
        plant_sample(&a, &ma);
        plant_sample(&b, &mb);
        /* same seed: the first samples do not depend on the dual-sampling switch */
        CHECK(ma.code_a == mb.code_a && ma.code_b == mb.code_b && ma.code_vdc == mb.code_vdc);
        plant_snapshot(&a, &s);
        /* no noise: within half an LSB of the truth */
        CLOSE(ma.i_a_a, s.i_a_a, 0.5 * 20.0 / 2048.0 + 1e-12);
        CLOSE(ma.v_dc_v, 310.0, 0.5 * 500.0 / 4096.0 + 1e-12);
        CHECK(ma.code_a == (int)floor(s.i_a_a / (20.0 / 2048.0) + 0.5) + 2048);
        CHECK(k < 10 || (fabs(s.i_a_a) > 0.5 && fabs(s.i_a_a) < 19.0));
    }
}

int main(void)
{
    test_inverter_leg();
    test_saturation();
    test_rng_and_adc();
    test_mechanics_parts();
    test_params_check();
    test_off_is_ideal();
    test_energy_all_effects();
    test_dyno_and_sampling();
    test_adc_in_plant();
    printf("%d checks, %d failures\n", g_checks, g_failures);
    return g_failures == 0 ? 0 : 1;
}
