/**
 * @file test_plant_fault.c
 * @brief Plant faults (plant_fault.h) in C: switching them off leaves the plant bit for bit
 * the plant without faults; open-phase current and loop flux; short losses; sensor faults
 * through the ADC; locked rotor; energy balance with each electrical fault; refusals.
 * (The comparison with the independent circuit model is tests/test_plant_faults.py.)
 */
#include "plant_test_util.h"

static const double k_pi23 = 2.0943951023931954923;

/* a rotor-synchronous voltage (v_d, v_q) as duties, rotor at a constant speed */
static void sync_duty(const plant_params_t *p, int k, double w_m, double vd, double vq, double d[3])
{
    const double th = 0.3 + (double)p->pole_pairs * w_m * ((double)k * p->ts_s + p->t_delay_s + 0.5 * p->ts_s);
    const double va = vd * cos(th) - vq * sin(th);
    const double vb = vd * sin(th) + vq * cos(th);
    double v[3], mx, mn;
    int j;
    v[0] = va;
    v[1] = -0.5 * va + 0.5 * T_SQRT3 * vb;
    v[2] = -0.5 * va - 0.5 * T_SQRT3 * vb;
    mx = fmax(v[0], fmax(v[1], v[2]));
    mn = fmin(v[0], fmin(v[1], v[2]));
    for (j = 0; j < 3; ++j) d[j] = 0.5 + (v[j] - 0.5 * (mx + mn)) / p->v_dc_v;
}

static void start(plant_t *pl, const plant_params_t *p, double w_m)
{
    CHECK(plant_init(pl, p) == 0);
    plant_set_initial(pl, 0.3, w_m);
}

static void run(plant_t *pl, int k0, int n, double w_m, double id, double iq, int off_from)
{
    const plant_params_t *p = &pl->params;
    const double we = (double)p->pole_pairs * w_m;
    const double vd = p->rs_ohm * id - we * p->lq_h * iq;
    const double vq = p->rs_ohm * iq + we * (p->ld_h * id + p->psi_f_wb);
    int k;
    for (k = k0; k < k0 + n; ++k) {
        double d[3];
        sync_duty(p, k, w_m, vd, vq, d);
        if (off_from >= 0 && k >= off_from) d[0] = d[1] = d[2] = -1.0;
        plant_step(pl, d);
    }
}

static double energy_residual(const plant_t *pl, double kin0)
{
    plant_energy_t e;
    double rhs, scale;
    plant_energy(pl, &e);
    rhs = e.copper_loss_j + e.viscous_loss_j + e.coulomb_loss_j + e.load_work_j + e.fault_absorbed_j +
          e.magnetic_j + e.kinetic_j - kin0;
    scale = fmax(fabs(e.electrical_in_j), fmax(e.copper_loss_j, fabs(e.kinetic_j - kin0)));
    return fabs(e.electrical_in_j - rhs) / scale;
}

static plant_fault_t fault(int kind, int phase, int phase2, int level, double value)
{
    plant_fault_t f;
    f.kind = kind;
    f.phase = phase;
    f.phase2 = phase2;
    f.level = level;
    f.value = value;
    return f;
}

/* every kind switched on and off again before the plant moves: nothing may change */
static void test_off_is_bit_for_bit(void)
{
    const plant_params_t p = hou_params();
    plant_t a, b;
    plant_snapshot_t sa, sb;
    plant_sample_t ma, mb;
    plant_energy_t ea, eb;
    int kind;
    start(&a, &p, 50.0);
    start(&b, &p, 50.0);
    run(&a, 0, 40, 50.0, 0.0, 2.0, -1);
    run(&b, 0, 40, 50.0, 0.0, 2.0, -1);
    for (kind = PLANT_FAULT_LEG_STUCK; kind < PLANT_FAULT_KIND_COUNT; ++kind) {
        plant_fault_t f = fault(kind, 1, 2, 1, kind == PLANT_FAULT_VDC ? 200.0 : 1.5);
        CHECK(plant_set_fault(&a, &f) == 0);
        CHECK(plant_faults_active(&a) == PLANT_FAULT_BIT(kind));
        plant_clear_fault(&a, kind, -1);
        CHECK(plant_faults_active(&a) == 0u);
    }
    run(&a, 40, 100, 50.0, 0.0, 2.0, 120);
    run(&b, 40, 100, 50.0, 0.0, 2.0, 120);
    plant_snapshot(&a, &sa);
    plant_snapshot(&b, &sb);
    plant_sample(&a, &ma);
    plant_sample(&b, &mb);
    plant_energy(&a, &ea);
    plant_energy(&b, &eb);
    CHECK(memcmp(&sa, &sb, sizeof sa) == 0);
    CHECK(memcmp(&ma, &mb, sizeof ma) == 0);
    CHECK(memcmp(&ea, &eb, sizeof ea) == 0);
}

static void test_open_phase(void)
{
    plant_params_t p = hou_params();
    plant_t pl;
    plant_snapshot_t s;
    double lam0, lam1, kin0;
    int x;
    for (x = 0; x < 3; ++x) {
        const double ang = (double)x * k_pi23;
        const double nal = -sin(ang), nbe = cos(ang); /* J u_x */
        plant_fault_t f = fault(PLANT_FAULT_OPEN_PHASE, x, 0, 0, 0.0);
        start(&pl, &p, 100.0);
        kin0 = 0.5 * p.j_kgm2 * 100.0 * 100.0;
        run(&pl, 0, 50, 100.0, -1.0, 3.0, -1);
        plant_snapshot(&pl, &s);
        lam0 = nal * s.psi_alpha_wb + nbe * s.psi_beta_wb;
        CHECK(plant_set_fault(&pl, &f) == 0);
        plant_snapshot(&pl, &s);
        lam1 = nal * s.psi_alpha_wb + nbe * s.psi_beta_wb;
        CLOSE(lam1, lam0, 1e-15);
        CLOSE((x == 0 ? s.i_a_a : (x == 1 ? s.i_b_a : s.i_c_a)), 0.0, 1e-13);
        run(&pl, 50, 150, 100.0, -1.0, 3.0, 120);
        plant_snapshot(&pl, &s);
        CLOSE((x == 0 ? s.i_a_a : (x == 1 ? s.i_b_a : s.i_c_a)), 0.0, 1e-12);
        CHECK(energy_residual(&pl, kin0) < 1e-7);
    }
}

static void test_short_driven_loss(void)
{
    plant_params_t p = gong_params();
    plant_t pl;
    plant_energy_t e;
    plant_fault_t f = fault(PLANT_FAULT_PHASE_SHORT, 0, 2, 0, 2.0);
    double prev[3] = {0.5, 0.5, 0.5}, want = 0.0;
    int k;
    start(&pl, &p, 0.0);
    CHECK(plant_set_fault(&pl, &f) == 0);
    for (k = 0; k < 50; ++k) {
        double d[3];
        d[0] = 0.5 + 0.3 * sin(0.1 * k);
        d[1] = 0.5;
        d[2] = 0.5 - 0.2 * cos(0.07 * k);
        want += pow((prev[0] - prev[2]) * p.v_dc_v, 2) / 2.0 * p.t_delay_s +
                pow((d[0] - d[2]) * p.v_dc_v, 2) / 2.0 * (p.ts_s - p.t_delay_s);
        memcpy(prev, d, sizeof prev);
        plant_step(&pl, d);
    }
    plant_energy(&pl, &e);
    CLOSE(e.short_loss_j, want, 1e-12 * want);
    CLOSE(e.dc_bus_in_j, e.electrical_in_j + e.short_loss_j, 1e-12 * e.dc_bus_in_j);
}

static void test_short_all_off_energy(void)
{
    plant_params_t p = gong_params();
    plant_t pl;
    plant_energy_t e;
    plant_fault_status_t st;
    plant_fault_t f = fault(PLANT_FAULT_PHASE_SHORT, 1, 2, 0, 0.5);
    start(&pl, &p, 100.0);
    run(&pl, 0, 60, 100.0, 0.0, 3.0, -1);
    CHECK(plant_set_fault(&pl, &f) == 0);
    run(&pl, 60, 200, 100.0, 0.0, 3.0, 100);
    plant_energy(&pl, &e);
    plant_fault_status(&pl, &st);
    CHECK(e.short_loss_j > 1.0);
    CHECK(st.short_fallbacks == 0UL);
    CHECK(fabs(st.i_short_a) > 0.1);    /* still braking into the short */
    CHECK(energy_residual(&pl, 0.5 * p.j_kgm2 * 1e4) < 1e-7);
}

static void test_sensor_faults_with_adc(void)
{
    plant_params_t p = gong_params();
    plant_t pl;
    plant_sample_t m0, m1;
    plant_fault_t f;
    const double lsb = 20.0 / 2048.0;
    p.sensors.adc_model = 1;
    p.sensors.adc_bits = 12;
    p.sensors.adc_full_scale_a = 20.0;
    p.sensors.adc_noise_a_rms = 0.0;
    p.sensors.adc_vdc_full_scale_v = 500.0;
    start(&pl, &p, 100.0);
    run(&pl, 0, 30, 100.0, 0.0, 3.0, -1);
    plant_sample(&pl, &m0);
    f = fault(PLANT_FAULT_SENSOR_STUCK, 0, 0, 0, 3.0);
    CHECK(plant_set_fault(&pl, &f) == 0);
    plant_sample(&pl, &m1);
    CLOSE(m1.i_a_a, 3.0, 0.5 * lsb);
    CHECK(m1.code_a == 2048 + (int)floor(3.0 / lsb + 0.5));
    CHECK(m1.code_b == m0.code_b && m1.code_c == m0.code_c && m1.code_vdc == m0.code_vdc);
    f = fault(PLANT_FAULT_SENSOR_DROPOUT, 0, 0, 0, 0.0);
    CHECK(plant_set_fault(&pl, &f) == 0); /* replaces the stuck sensor of phase a */
    plant_sample(&pl, &m1);
    CHECK(m1.code_a == 2048 && !(fabs(m1.i_a_a) > 0.0));
    CHECK(plant_faults_active(&pl) == PLANT_FAULT_BIT(PLANT_FAULT_SENSOR_DROPOUT));
    plant_clear_fault(&pl, PLANT_FAULT_SENSOR_DROPOUT, 0);
    plant_sample(&pl, &m1);
    CHECK(memcmp(&m0, &m1, sizeof m0) == 0);
}

static void test_lock_and_refusals(void)
{
    plant_params_t p = gong_params();
    plant_t pl;
    plant_snapshot_t s;
    plant_fault_t f;
    start(&pl, &p, 100.0);
    f = fault(PLANT_FAULT_LOCKED_ROTOR, 0, 0, 0, 0.0);
    CHECK(plant_set_fault(&pl, &f) == 0);
    run(&pl, 0, 20, 100.0, 0.0, 3.0, -1);
    plant_snapshot(&pl, &s);
    CHECK(!(fabs(s.omega_m_rad_s) > 0.0) && s.theta_m_rad > 0.0);
    plant_reset(&pl);
    CHECK(plant_faults_active(&pl) == 0u && pl.params.mechanics.dyno == 0);
    f = fault(PLANT_FAULT_PHASE_SHORT, 1, 1, 0, 1.0);
    CHECK(plant_fault_check(&pl, &f) != NULL && plant_set_fault(&pl, &f) == -1);
    f = fault(PLANT_FAULT_VDC, 0, 0, 0, -5.0);
    CHECK(plant_fault_check(&pl, &f) != NULL);
    f = fault(PLANT_FAULT_SENSOR_GAIN, 3, 0, 0, 0.0);
    CHECK(plant_fault_check(&pl, &f) != NULL);
    f = fault(99, 0, 0, 0, 0.0);
    CHECK(plant_fault_check(&pl, &f) != NULL);
    f = fault(PLANT_FAULT_LOAD_TORQUE, 0, 0, 0, NAN);
    CHECK(plant_fault_check(&pl, &f) != NULL);
    CHECK(plant_faults_active(&pl) == 0u);
}

int main(void)
{
    test_off_is_bit_for_bit();
    test_open_phase();
    test_short_driven_loss();
    test_short_all_off_energy();
    test_sensor_faults_with_adc();
    test_lock_and_refusals();
    printf("plant_fault: %d checks, %d failures\n", g_checks, g_failures);
    return g_failures == 0 ? 0 : 1;
}
