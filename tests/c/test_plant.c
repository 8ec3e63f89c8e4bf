/**
 * @file test_plant.c
 * @brief Unit tests of the plant parts alone (transforms, inverter, machine, mechanics) and of
 *        the assembled plant against analytic solutions (RL step, coast-down, energy balance).
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

#include "plant_test_util.h"

/* ------------------------------------------------------------------------------------------ */

static void test_transforms(void)
{
    const double amp = 7.5;
    const double phi = 0.8;
    const double th = 2.1;
    double a, b, c, al, be, d, q, al2, be2, a2, b2, c2;
    a = amp * cos(phi);
    b = amp * cos(phi - 2.0 * T_PI / 3.0);
    c = amp * cos(phi + 2.0 * T_PI / 3.0);
    pmsm_clarke(a, b, c, &al, &be);
    /* amplitude-invariant: a balanced set of amplitude A is a vector of length A */
    CLOSE(al, amp * cos(phi), 1e-12);
    CLOSE(be, amp * sin(phi), 1e-12);
    /* i_beta = (i_a + 2 i_b)/sqrt(3) for a zero-sum set */
    CLOSE(be, (a + 2.0 * b) / T_SQRT3, 1e-12);
    /* zero sequence is discarded */
    pmsm_clarke(a + 3.0, b + 3.0, c + 3.0, &al2, &be2);
    CLOSE(al2, al, 1e-12);
    CLOSE(be2, be, 1e-12);
    pmsm_inv_clarke(al, be, &a2, &b2, &c2);
    CLOSE(a2, a, 1e-12);
    CLOSE(b2, b, 1e-12);
    CLOSE(c2, c, 1e-12);
    /* Park with the d-axis angle: a vector along the d axis has q = 0 */
    pmsm_park(amp * cos(th), amp * sin(th), th, &d, &q);
    CLOSE(d, amp, 1e-12);
    CLOSE(q, 0.0, 1e-12);
    pmsm_inv_park(1.25, -0.5, th, &al2, &be2);
    pmsm_park(al2, be2, th, &d, &q);
    CLOSE(d, 1.25, 1e-12);
    CLOSE(q, -0.5, 1e-12);
}

static void test_inverter(void)
{
    inverter_t inv;
    inverter_config_t cfg;
    const double duty[3] = {0.9, 0.2, 0.4};
    const double shifted[3] = {0.8, 0.1, 0.3};
    const inverter_leg_mode_t pwm[3] = {INV_LEG_PWM, INV_LEG_PWM, INV_LEG_PWM};
    double vp[3], vph[3], vph2[3];
    inverter_leg_mode_t mode[3];
    double dis[3] = {-1.0, -1.0, 0.5};
    double cur[3] = {2.0, -2.0, 0.0};
    cfg.v_dc_v = 300.0;
    CHECK(inverter_init(&inv, &cfg) == 0);
    cfg.v_dc_v = -1.0;
    CHECK(inverter_init(&inv, &cfg) != 0);
    cfg.v_dc_v = 300.0;
    CHECK(inverter_init(&inv, &cfg) == 0);

    {
        const double i_any[3] = {1.0, -3.0, 2.0};
        double v_step[3];
        CHECK(inverter_step(&inv, duty, i_any, v_step) == 0);
        CLOSE(v_step[0], 120.0, 1e-12);
        CLOSE(v_step[1], -90.0, 1e-12);
        CLOSE(v_step[2], -30.0, 1e-12);
    }
    inverter_pole_voltages(&inv, duty, pwm, vp);
    CLOSE(vp[0], 270.0, 1e-12);
    CLOSE(vp[1], 60.0, 1e-12);
    CLOSE(vp[2], 120.0, 1e-12);
    inverter_phase_voltages(vp, vph);
    /* common mode (v_aN + v_bN + v_cN)/3 = 150 V removed */
    CLOSE(vph[0], 120.0, 1e-12);
    CLOSE(vph[1], -90.0, 1e-12);
    CLOSE(vph[2], -30.0, 1e-12);
    CLOSE(vph[0] + vph[1] + vph[2], 0.0, 1e-12);
    /* a common duty offset changes only the (removed) common mode */
    inverter_pole_voltages(&inv, shifted, pwm, vp);
    inverter_phase_voltages(vp, vph2);
    CLOSE(vph2[0], vph[0], 1e-12);
    CLOSE(vph2[1], vph[1], 1e-12);
    CLOSE(vph2[2], vph[2], 1e-12);

    CLOSE(inverter_sanitize_duty(-0.1), -1.0, 0.0);
    CLOSE(inverter_sanitize_duty(NAN), -1.0, 0.0);
    CLOSE(inverter_sanitize_duty(1.5), 1.0, 0.0);
    CLOSE(inverter_sanitize_duty(0.3), 0.3, 0.0);
    CLOSE(inverter_sanitize_duty(0.0), 0.0, 0.0);
    CHECK(inverter_leg_disabled(-1.0));
    CHECK(!inverter_leg_disabled(0.0));

    /* disabled legs: the diode follows the current sign; no current -> open candidate */
    CHECK(inverter_classify(&inv, dis, cur, mode) == 0);
    CHECK(mode[0] == INV_LEG_DIODE_LOW);  /* i > 0 -> lower diode, 0 V */
    CHECK(mode[1] == INV_LEG_DIODE_HIGH); /* i < 0 -> upper diode, V_dc */
    CHECK(mode[2] == INV_LEG_PWM);
    inverter_pole_voltages(&inv, dis, mode, vp);
    CLOSE(vp[0], 0.0, 0.0);
    CLOSE(vp[1], 300.0, 0.0);
    CLOSE(vp[2], 150.0, 1e-12);
    cur[0] = 0.0;
    CHECK(inverter_classify(&inv, dis, cur, mode) == 1);
    CHECK(mode[0] == INV_LEG_OPEN);
    CHECK(inverter_open_leg_mode(&inv, 301.0) == INV_LEG_DIODE_HIGH);
    CHECK(inverter_open_leg_mode(&inv, -1.0) == INV_LEG_DIODE_LOW);
    CHECK(inverter_open_leg_mode(&inv, 150.0) == INV_LEG_OPEN);
    CHECK(inverter_open_margin(&inv, 10.0) > 9.99);
    CHECK(inverter_open_margin(&inv, 310.0) < 0.0);
}

static void test_machine_open_phase(void)
{
    /* With i_x = 0 the constrained derivative keeps d(i_x)/dt = 0, and equals the free
     * derivative under the phase voltages it reports (lambda on the open phase). */
    plant_params_t hp = hou_params();
    pmsm_machine_config_t mc;
    pmsm_machine_t m;
    int x;
    mc.rs_ohm = hp.rs_ohm;
    mc.ld_h = hp.ld_h;
    mc.lq_h = hp.lq_h;
    mc.psi_f_wb = hp.psi_f_wb;
    mc.pole_pairs = hp.pole_pairs;
    CHECK(pmsm_machine_init(&m, &mc) == 0);
    for (x = 0; x < 3; ++x) {
        const double th = 0.7 + 1.3 * (double)x;
        const double we = 310.0;
        const double v_yz = 123.0;
        static const double ux[3] = {1.0, -0.5, -0.5};
        static const double uy[3] = {0.0, 0.5 * T_SQRT3, -0.5 * T_SQRT3};
        /* a current orthogonal to phase x: i_alphabeta = 4 A * (-uy, ux) */
        const double ia = -4.0 * uy[x];
        const double ib = 4.0 * ux[x];
        double id, iq, did, diq, lam, dia, dib, v[3], va, vb, vd, vq, did2, diq2;
        const int y = (x + 1) % 3;
        const int z = (x + 2) % 3;
        pmsm_park(ia, ib, th, &id, &iq);
        pmsm_machine_derivs_open_phase(&m, id, iq, th, we, x, v_yz, &did, &diq, &lam);
        /* d/dt i_alphabeta = P(th) di_dq + we J P(th) i_dq */
        pmsm_inv_park(did, diq, th, &dia, &dib);
        dia += -we * ib;
        dib += we * ia;
        CLOSE(ux[x] * dia + uy[x] * dib, 0.0, 1e-9 * (fabs(did) + fabs(diq)));
        v[x] = lam;
        v[y] = 0.5 * (v_yz - lam);
        v[z] = 0.5 * (-v_yz - lam);
        CLOSE(v[y] - v[z], v_yz, 1e-12);
        pmsm_clarke(v[0], v[1], v[2], &va, &vb);
        pmsm_park(va, vb, th, &vd, &vq);
        pmsm_machine_derivs(&m, id, iq, vd, vq, we, &did2, &diq2);
        CLOSE(did2, did, 1e-9 * fabs(did) + 1e-9);
        CLOSE(diq2, diq, 1e-9 * fabs(diq) + 1e-9);
    }
}

static void test_machine_locked_rotor(void)
{
    /* omega = 0: d and q axes are decoupled first-order RL circuits with L_d != L_q. */
    plant_params_t hp = hou_params();
    pmsm_machine_config_t mc;
    pmsm_machine_t m;
    const double v = 10.0;
    const double dt = 1e-5;
    int k;
    double worst_d = 0.0, worst_q = 0.0;
    mc.rs_ohm = hp.rs_ohm;
    mc.ld_h = hp.ld_h;
    mc.lq_h = hp.lq_h;
    mc.psi_f_wb = hp.psi_f_wb;
    mc.pole_pairs = hp.pole_pairs;
    CHECK(pmsm_machine_init(&m, &mc) == 0);
    mc.ld_h = -1.0;
    {
        pmsm_machine_t bad;
        CHECK(pmsm_machine_init(&bad, &mc) != 0);
    }
    for (k = 1; k <= 3000; ++k) {
        const double t = (double)k * dt;
        pmsm_machine_step(&m, v, 0.5 * v, 0.0, dt);
        worst_d = fmax(worst_d, fabs(m.i_d_a - v / hp.rs_ohm * (1.0 - exp(-t * hp.rs_ohm / hp.ld_h))));
        worst_q = fmax(worst_q, fabs(m.i_q_a - 0.5 * v / hp.rs_ohm * (1.0 - exp(-t * hp.rs_ohm / hp.lq_h))));
    }
    CHECK(worst_d < 1e-9);
    CHECK(worst_q < 1e-9);
    /* torque with saliency: 1.5 p (psi i_q + (Ld - Lq) i_d i_q) */
    CLOSE(pmsm_machine_torque(&m, -2.0, 3.0),
          1.5 * 3.0 * (0.303 * 3.0 + (2.5e-3 - 8.5e-3) * -2.0 * 3.0), 1e-12);
}

static void test_mechanics(void)
{
    mechanics_t mech;
    mechanics_config_t cfg;
    const double w0 = 200.0;
    const double tau = 0.013 / 0.0035;
    int k;
    cfg.j_kgm2 = 0.013;
    cfg.b_nms = 0.0035;
    cfg.pole_pairs = 4;
    CHECK(mechanics_init(&mech, &cfg) == 0);
    mech.omega_m_rad_s = w0;
    for (k = 0; k < 1000; ++k) {
        mechanics_step(&mech, 0.0, 0.0, 1e-3);
    }
    CLOSE(mech.omega_m_rad_s, w0 * exp(-1.0 / tau), 1e-10 * w0);
    CLOSE(mech.theta_m_rad, w0 * tau * (1.0 - exp(-1.0 / tau)), 1e-9 * w0);
    /* positive load torque opposes positive rotation */
    CHECK(mechanics_accel(&mech, 0.0, 0.0, 1.0) < 0.0);
    CLOSE(mechanics_accel(&mech, 10.0, 2.0, 0.5), (2.0 - 0.035 - 0.5) / 0.013, 1e-12);
    /* B = 0: uniform acceleration */
    cfg.b_nms = 0.0;
    CHECK(mechanics_init(&mech, &cfg) == 0);
    mechanics_step(&mech, 0.13, 0.0, 2.0);
    CLOSE(mech.omega_m_rad_s, 20.0, 1e-12);
    CLOSE(mech.theta_m_rad, 20.0, 1e-12);
    cfg.j_kgm2 = 0.0;
    CHECK(mechanics_init(&mech, &cfg) != 0);
}

static void test_params_check(void)
{
    plant_params_t p = gong_params();
    plant_t pl;
    const char *msg;
    CHECK(plant_params_check(&p) == NULL);
    CHECK(plant_params_check(NULL) != NULL);
#define BAD(field, value, prefix)                                                                  \
    do {                                                                                           \
        plant_params_t q = gong_params();                                                          \
        q.field = value;                                                                           \
        msg = plant_params_check(&q);                                                              \
        check_true(msg != NULL && strncmp(msg, prefix, strlen(prefix)) == 0, prefix, __LINE__);   \
        check_true(plant_init(&pl, &q) == -1, "plant_init rejects " prefix, __LINE__);            \
    } while (0)
    BAD(rs_ohm, -0.1, "rs_ohm: must be >= 0");
    BAD(rs_ohm, NAN, "rs_ohm: must be finite");
    BAD(ld_h, -0.002, "ld_h: must be > 0");
    BAD(ld_h, 0.0, "ld_h: must be > 0");
    BAD(lq_h, INFINITY, "lq_h: must be finite");
    BAD(lq_h, 0.0, "lq_h: must be > 0");
    BAD(psi_f_wb, -0.01, "psi_f_wb: must be >= 0");
    BAD(pole_pairs, 0, "pole_pairs: must be >= 1");
    BAD(j_kgm2, 0.0, "j_kgm2: must be > 0");
    BAD(j_kgm2, -1.0, "j_kgm2: must be > 0");
    BAD(b_nms, -1e-3, "b_nms: must be >= 0");
    BAD(v_dc_v, 0.0, "v_dc_v: must be > 0");
    BAD(ts_s, 0.0, "ts_s: must be > 0");
    BAD(t_delay_s, 2e-4, "t_delay_s: must be <= ts_s");
    BAD(t_delay_s, -1e-6, "t_delay_s: must be >= 0");
    BAD(substeps, 0, "substeps: must be >= 1");
#undef BAD
    CHECK(plant_init(&pl, &p) == 0);
}

static void test_plant_init_state(void)
{
    plant_params_t p = gong_params();
    plant_t pl;
    plant_snapshot_t s;
    CHECK(plant_init(&pl, &p) == 0);
    plant_snapshot(&pl, &s);
    CLOSE(s.t_s, 0.0, 0.0);
    CLOSE(s.i_a_a, 0.0, 0.0);
    CLOSE(s.omega_m_rad_s, 0.0, 0.0);
    CLOSE(s.duty_a, 0.5, 0.0);
    CLOSE(s.v_dc_v, 310.0, 0.0);
    /* zero voltage at 0.5 duties: nothing moves */
    plant_step_abc(&pl, 0.5, 0.5, 0.5);
    plant_snapshot(&pl, &s);
    CLOSE(s.t_s, 100e-6, 1e-18);
    CLOSE(s.i_a_a, 0.0, 0.0);
    CLOSE(s.v_a_v, 0.0, 1e-12);
    plant_set_initial(&pl, -0.5, 12.0);
    plant_snapshot(&pl, &s);
    CLOSE(s.theta_e_rad, 2.0 * T_PI - 0.5, 1e-12);
    CLOSE(s.theta_m_rad, (2.0 * T_PI - 0.5) / 4.0, 1e-12);
    CLOSE(s.omega_e_rad_s, 48.0, 1e-12);
    CLOSE(s.e_alpha_v, -48.0 * 0.085 * sin(2.0 * T_PI - 0.5), 1e-12);
    CLOSE(s.e_beta_v, 48.0 * 0.085 * cos(2.0 * T_PI - 0.5), 1e-12);
    plant_set_load_torque(&pl, 1.5);
    plant_reset(&pl);
    plant_snapshot(&pl, &s);
    CLOSE(s.t_s, 0.0, 0.0);
    CLOSE(s.omega_m_rad_s, 0.0, 0.0);
    CLOSE(s.torque_load_nm, 0.0, 0.0);
    CLOSE(s.duty_b, 0.5, 0.0);
}

/* Duties that put phase voltage v along alpha: v_a = m V_dc, v_b = v_c = -m V_dc / 2. */
static void alpha_duties(double m, double d[3])
{
    d[0] = 0.5 + m;
    d[1] = 0.5 - 0.5 * m;
    d[2] = 0.5 - 0.5 * m;
}

static void test_plant_delay_and_averages(void)
{
    /* the new duty acts from t_delay on: the first period's average is (Ts - td)/Ts of it */
    const double tds[3] = {0.0, 34.1e-6, 100e-6};
    int k;
    for (k = 0; k < 3; ++k) {
        plant_params_t p = gong_params();
        plant_t pl;
        plant_snapshot_t s;
        double d[3];
        const double m = 0.1;
        const double v_new = m * p.v_dc_v;
        p.t_delay_s = tds[k];
        p.j_kgm2 = 1e9; /* locked rotor */
        CHECK(plant_init(&pl, &p) == 0);
        alpha_duties(m, d);
        plant_step(&pl, d);
        plant_snapshot(&pl, &s);
        CLOSE(s.v_a_v, v_new * (p.ts_s - p.t_delay_s) / p.ts_s, 1e-12);
        CLOSE(s.v_alpha_v, s.v_a_v, 1e-12);
        CLOSE(s.v_beta_v, 0.0, 1e-12);
        CLOSE(s.v_a_v + s.v_b_v + s.v_c_v, 0.0, 1e-12);
        CLOSE(s.v_d_v, s.v_a_v, 1e-9); /* theta = 0, rotor locked */
        CLOSE(s.duty_a, d[0], 0.0);
        plant_step(&pl, d);
        plant_snapshot(&pl, &s);
        CLOSE(s.v_a_v, v_new, 1e-12);
    }
}

static void test_plant_rl_step(void)
{
    /* Locked rotor, voltage step along the d axis (SPMSM) and along the q axis (IPMSM):
     * i(t) = V/R (1 - exp(-(t - t_delay) R / L)) with L = L_d resp. L_q. */
    int axis;
    for (axis = 0; axis < 2; ++axis) {
        plant_params_t p = (axis == 0) ? gong_params() : hou_params();
        const double l = (axis == 0) ? p.ld_h : p.lq_h;
        const double m = 0.02;
        const double v = m * p.v_dc_v;
        plant_t pl;
        plant_snapshot_t s;
        double d[3];
        double worst = 0.0, worst_other = 0.0;
        int k;
        p.j_kgm2 = 1e12; /* hold the rotor */
        CHECK(plant_init(&pl, &p) == 0);
        /* d axis at theta = 0 is alpha; for the q axis put theta = -pi/2 (q along alpha) */
        plant_set_initial(&pl, (axis == 0) ? 0.0 : -0.5 * T_PI, 0.0);
        alpha_duties(m, d);
        for (k = 1; k <= 400; ++k) {
            const double t = (double)k * p.ts_s - p.t_delay_s;
            const double want = v / p.rs_ohm * (1.0 - exp(-t * p.rs_ohm / l));
            plant_step(&pl, d);
            plant_snapshot(&pl, &s);
            worst = fmax(worst, fabs(((axis == 0) ? s.i_d_a : s.i_q_a) - want));
            worst_other = fmax(worst_other, fabs((axis == 0) ? s.i_q_a : s.i_d_a));
        }
        /* RK4 with h*R/L <= 0.008: local error ~ (hR/L)^5/120 ~ 3e-13 relative */
        check_true(worst < 1e-9 * v / p.rs_ohm, "RL step matches the exponential", __LINE__);
        check_true(worst_other < 1e-6, "other axis stays at zero", __LINE__);
    }
}

static void test_plant_coast_down(void)
{
    /* All legs disabled, back EMF far below V_dc: no current, exponential coast-down. */
    plant_params_t p = gong_params();
    plant_t pl;
    plant_snapshot_t s;
    const double w0 = 50.0; /* line EMF peak sqrt(3)*200*0.085 = 29 V << 310 V */
    const double tau = p.j_kgm2 / p.b_nms;
    double worst_i = 0.0;
    int k;
    p.t_delay_s = 0.0; /* else the first 34 us short the windings (previous duties 0.5) */
    CHECK(plant_init(&pl, &p) == 0);
    plant_set_initial(&pl, 0.3, w0);
    for (k = 1; k <= 20000; ++k) {
        plant_step_abc(&pl, -1.0, -1.0, -1.0);
        plant_snapshot(&pl, &s);
        worst_i = fmax(worst_i, fabs(s.i_a_a) + fabs(s.i_b_a) + fabs(s.i_c_a));
    }
    CLOSE(worst_i, 0.0, 0.0);
    CLOSE(s.omega_m_rad_s, w0 * exp(-s.t_s / tau), 1e-10 * w0);
    CLOSE(s.theta_m_rad - 0.3 / 4.0, w0 * tau * (1.0 - exp(-s.t_s / tau)), 1e-9 * w0);
    /* open terminals show the back EMF */
    CLOSE(s.torque_e_nm, 0.0, 0.0);
    CHECK(s.duty_a < 0.0);
}

static void test_plant_one_open_phase(void)
{
    /* Leg a disabled, b and c switching at standstill (SPMSM): i_a stays exactly 0 and the
     * b-c loop is 2R, 2L in series: i_b = V_bc/(2R) (1 - exp(-t R/L)). Phase a sees no
     * voltage (no coupling in an SPMSM at standstill), terminal a floats at (v_bN + v_cN)/2. */
    plant_params_t p = gong_params();
    plant_t pl;
    plant_snapshot_t s;
    const double dbc = 0.05;
    const double v_bc = 2.0 * dbc * p.v_dc_v;
    double worst = 0.0, worst_a = 0.0;
    int k;
    p.j_kgm2 = 1e12;
    p.t_delay_s = 0.0;
    CHECK(plant_init(&pl, &p) == 0);
    for (k = 1; k <= 300; ++k) {
        const double t = (double)k * p.ts_s;
        plant_step_abc(&pl, -1.0, 0.5 + dbc, 0.5 - dbc);
        plant_snapshot(&pl, &s);
        worst = fmax(worst, fabs(s.i_b_a - v_bc / (2.0 * p.rs_ohm) * (1.0 - exp(-t * p.rs_ohm / p.ld_h))));
        worst_a = fmax(worst_a, fabs(s.i_a_a));
    }
    CHECK(worst < 1e-9 * v_bc / p.rs_ohm);
    CHECK(worst_a < 1e-12);
    CLOSE(s.v_a_v, 0.0, 1e-9);
    CLOSE(s.v_b_v - s.v_c_v, v_bc, 1e-9);
}

/* stored0: magnetic + kinetic energy when the bookkeeping started (e.g. after set_initial) */
static void energy_residual(const plant_t *pl, double stored0, double *residual, double *scale)
{
    plant_energy_t e;
    plant_energy(pl, &e);
    *residual = e.electrical_in_j - (e.magnetic_j + e.kinetic_j - stored0 + e.copper_loss_j +
                                     e.viscous_loss_j + e.load_work_j);
    *scale = fabs(e.electrical_in_j) + e.copper_loss_j + e.kinetic_j + fabs(e.load_work_j);
}

static void test_plant_energy(void)
{
    /* Open-loop rotating voltage (V/f ramp) on the IPMSM with a load step: the energy
     * delivered by the inverter equals stored magnetic + kinetic energy + losses + load work. */
    plant_params_t p = hou_params();
    plant_t pl;
    double res, scale;
    int k;
    CHECK(plant_init(&pl, &p) == 0);
    for (k = 0; k < 4000; ++k) {
        const double t = (double)k * p.ts_s;
        const double we = 2.0 * T_PI * 40.0 * fmin(t / 0.3, 1.0);                   /* up to 40 Hz */
        const double th = 2.0 * T_PI * 40.0 * (t < 0.3 ? t * t / 0.6 : t - 0.15); /* int we dt */
        const double vmag = 3.0 + we * p.psi_f_wb;
        double d[3];
        int x;
        for (x = 0; x < 3; ++x) {
            d[x] = 0.5 + vmag / p.v_dc_v * cos(th + 0.5 * T_PI - 2.0 * T_PI / 3.0 * (double)x);
        }
        if (k == 2500) plant_set_load_torque(&pl, 2.0);
        plant_step(&pl, d);
    }
    energy_residual(&pl, 0.0, &res, &scale);
    check_true(scale > 1.0, "scenario moves energy", __LINE__);
    check_true(fabs(res) < 1e-9 * scale, "energy balance (PWM)", __LINE__);

    /* Diode braking: all legs off at a speed whose line EMF exceeds V_dc: energy flows into
     * the bus (electrical_in < 0) and the balance still holds. */
    p = gong_params();
    p.v_dc_v = 100.0;
    CHECK(plant_init(&pl, &p) == 0);
    plant_set_initial(&pl, 0.0, 200.0); /* line EMF peak sqrt(3)*800*0.085 = 118 V > 100 V */
    for (k = 0; k < 2000; ++k) {
        plant_step_abc(&pl, -1.0, -1.0, -1.0);
    }
    energy_residual(&pl, 0.5 * p.j_kgm2 * 200.0 * 200.0, &res, &scale);
    {
        plant_energy_t e;
        plant_energy(&pl, &e);
        check_true(e.electrical_in_j < -1e-3, "braking returns energy to the bus", __LINE__);
        check_true(e.copper_loss_j > 0.0, "braking current flows", __LINE__);
    }
    check_true(pl.events > 0UL, "diode events were located", __LINE__);
    check_true(fabs(res) < 1e-7 * scale, "energy balance (diodes)", __LINE__);
}

static void test_plant_run(void)
{
    plant_params_t p = gong_params();
    plant_t a, b;
    plant_snapshot_t sa, out[3];
    const double duties[9] = {0.6, 0.4, 0.5, 0.7, 0.3, 0.5, -1.0, 0.2, 0.8};
    int k;
    CHECK(plant_init(&a, &p) == 0);
    CHECK(plant_init(&b, &p) == 0);
    plant_run(&b, duties, 3, out);
    for (k = 0; k < 3; ++k) {
        plant_step(&a, &duties[3 * k]);
        plant_snapshot(&a, &sa);
        CHECK(memcmp(&sa, &out[k], sizeof sa) == 0);
    }
    CLOSE(out[2].duty_a, -1.0, 0.0);
}

/* deterministic pseudo-random numbers in [0, 1) (LCG; no libc rand state) */
static double lcg_uniform(unsigned long long *state)
{
    *state = (*state * 6364136223846793005ULL + 1442695040888963407ULL);
    return (double)((*state >> 11) & 0x1FFFFFFFFFFFFFULL) / 9007199254740992.0;
}

static void test_plant_random_leg_patterns(void)
{
    /* Every combination of PWM / disabled legs, both rotation directions, buses below and
     * above the line EMF: the state stays finite, the averaged phase voltages stay within
     * +-2/3 V_dc and the energy balance holds. Mainly exercises the diode event logic under
     * the sanitizers. */
    unsigned long long rng = 12345ULL;
    int trial;
    for (trial = 0; trial < 60; ++trial) {
        plant_params_t p = (trial % 2 == 0) ? gong_params() : hou_params();
        plant_t pl;
        plant_snapshot_t s;
        plant_energy_t e;
        double d[3] = {0.5, 0.5, 0.5};
        double w0, res, scale, kin0;
        int k, x, ok = 1;
        p.v_dc_v = (trial % 3 == 0) ? 60.0 : ((trial % 3 == 1) ? 150.0 : 400.0);
        p.t_delay_s = lcg_uniform(&rng) * p.ts_s;
        p.substeps = 1 + trial % 4;
        CHECK(plant_init(&pl, &p) == 0);
        w0 = 600.0 * (lcg_uniform(&rng) - 0.5);
        plant_set_initial(&pl, 6.0 * lcg_uniform(&rng), w0);
        plant_set_load_torque(&pl, 2.0 * (lcg_uniform(&rng) - 0.5));
        kin0 = 0.5 * p.j_kgm2 * w0 * w0;
        for (k = 0; k < 200; ++k) {
            if (k % 10 == 0) {
                for (x = 0; x < 3; ++x) {
                    d[x] = (lcg_uniform(&rng) < 0.4) ? -1.0 : 0.3 + 0.4 * lcg_uniform(&rng);
                }
            }
            plant_step(&pl, d);
            plant_snapshot(&pl, &s);
            ok = ok && isfinite(s.i_d_a) && isfinite(s.i_q_a) && isfinite(s.omega_m_rad_s) &&
                 isfinite(s.theta_e_rad) && s.theta_e_rad >= 0.0 && s.theta_e_rad < 2.0 * T_PI &&
                 fabs(s.v_a_v) <= 2.0 / 3.0 * p.v_dc_v * (1.0 + 1e-12) &&
                 fabs(s.v_b_v) <= 2.0 / 3.0 * p.v_dc_v * (1.0 + 1e-12) &&
                 fabs(s.v_c_v) <= 2.0 / 3.0 * p.v_dc_v * (1.0 + 1e-12);
        }
        check_true(ok, "random pattern: finite, wrapped angle, |v_x| <= 2/3 V_dc", __LINE__);
        plant_energy(&pl, &e);
        res = e.electrical_in_j - (e.magnetic_j + e.kinetic_j - kin0 + e.copper_loss_j +
                                   e.viscous_loss_j + e.load_work_j);
        scale = fabs(e.electrical_in_j) + e.copper_loss_j + kin0 + fabs(e.load_work_j);
        check_true(fabs(res) < 1e-5 * scale, "random pattern: energy balance", __LINE__);
    }
}

int main(void)
{
    test_transforms();
    test_inverter();
    test_machine_open_phase();
    test_machine_locked_rotor();
    test_mechanics();
    test_params_check();
    test_plant_init_state();
    test_plant_delay_and_averages();
    test_plant_rl_step();
    test_plant_coast_down();
    test_plant_one_open_phase();
    test_plant_energy();
    test_plant_run();
    test_plant_random_leg_patterns();
    printf("test_plant: %d checks, %d failures\n", g_checks, g_failures);
    return g_failures == 0 ? 0 : 1;
}
