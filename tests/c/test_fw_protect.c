/**
 * @file test_fw_protect.c
 * @brief The controller's protection (ctrl_protect.h) alone and in the controller: each check
 * trips on its fault with its code and detail, stays quiet on healthy signals that a naive
 * check would flag (standstill vector normal to a phase, slow zero crossings, noise), latches,
 * and the controller turns its outputs off and stays in FAULT until CLEAR_FAULT.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "controller.h"
#include "ctrl_params.h"
#include "ctrl_protect.h"
#include "hil_msgs.h"

#include "check.h"

#define TS 1.0e-4f
#define VDC 310.0f
static const float k_pi23 = 2.0943951f;

static void init(ctrl_protect_t *p)
{
    ctrl_protect_config_t cfg;
    ctrl_protect_default_config(&cfg);
    cfg.i_trip_a = 30.0f;
    CHECK(ctrl_protect_init(p, &cfg, TS, VDC) == 0, "init");
}

/* balanced currents of amplitude amp at angle th; ref the same (healthy tracking) */
static void balanced(ctrl_protect_input_t *in, float amp, float th)
{
    int k;
    for (k = 0; k < 3; ++k) {
        in->i_abc_a[k] = amp * cosf(th - (float)k * k_pi23);
        in->i_ref_abc_a[k] = in->i_abc_a[k];
    }
    in->v_dc_v = VDC;
}

/* steps of a rotating balanced set at omega_e; returns the first tripping step or -1 */
static int rotate(ctrl_protect_t *p, float amp, float omega_e, int n, int open_phase,
                  int stuck_phase, float offset_b)
{
    ctrl_protect_input_t in;
    float held = 0.0f;
    int k;
    for (k = 0; k < n; ++k) {
        balanced(&in, amp, 0.4f + omega_e * TS * (float)k);
        if (open_phase >= 0) { /* ref unchanged (the loop asks); one loop through y and z */
            const int y = (open_phase + 1) % 3, z = (open_phase + 2) % 3;
            const float i_loop = 0.5f * (in.i_abc_a[y] - in.i_abc_a[z]);
            in.i_abc_a[open_phase] = 0.0f;
            in.i_abc_a[y] = i_loop;
            in.i_abc_a[z] = -i_loop;
        }
        if (stuck_phase >= 0) {
            if (k == 0) held = in.i_abc_a[stuck_phase];
            in.i_abc_a[stuck_phase] = held;
        }
        in.i_abc_a[1] += offset_b;
        if (ctrl_protect_step(p, &in) != CTRL_PROTECT_NONE) return k;
    }
    return -1;
}

static void test_overcurrent(void)
{
    ctrl_protect_t p;
    ctrl_protect_input_t in;
    int x;
    for (x = 0; x < 3; ++x) {
        init(&p);
        balanced(&in, 5.0f, 0.0f);
        CHECK(ctrl_protect_step(&p, &in) == CTRL_PROTECT_NONE, "healthy");
        in.i_abc_a[x] = -30.5f;
        CHECK(ctrl_protect_step(&p, &in) == CTRL_PROTECT_OVERCURRENT, "one sample trips");
        CHECK(p.detail == (int32_t)(x * 10000000L + 30500L), "detail %ld", (long)p.detail);
        balanced(&in, 1.0f, 0.0f);
        CHECK(ctrl_protect_step(&p, &in) == CTRL_PROTECT_OVERCURRENT, "latched");
        ctrl_protect_reset(&p);
        CHECK(ctrl_protect_step(&p, &in) == CTRL_PROTECT_NONE, "reset clears");
    }
    in.i_abc_a[2] = NAN;
    CHECK(ctrl_protect_step(&p, &in) == CTRL_PROTECT_OVERCURRENT && p.detail == 29999999L,
          "non-finite current: %ld", (long)p.detail);
    balanced(&in, 29.9f, 0.0f);
    ctrl_protect_reset(&p);
    CHECK(ctrl_protect_step(&p, &in) == CTRL_PROTECT_NONE, "just below");
}

static void test_open_phase(void)
{
    ctrl_protect_t p;
    ctrl_protect_input_t in;
    int k, x, hit;
    /* healthy at speeds from 0.5 to 2000 rad/s electrical, 2 electrical periods (or 5 s) */
    const float speeds[] = {0.5f, 2.0f, 20.0f, 209.0f, 2000.0f};
    for (k = 0; k < 5; ++k) {
        int n = (int)(2.0f * 6.2831853f / speeds[k] / TS);
        if (n > 50000) n = 50000;
        init(&p);
        hit = rotate(&p, 5.0f, speeds[k], n, -1, -1, 0.0f);
        CHECK(hit < 0, "healthy at %f rad/s tripped at step %d (code %d)", (double)speeds[k], hit, p.code);
    }
    /* standstill, current vector normal to phase a: i_a = 0, i_b = -i_c: healthy */
    init(&p);
    balanced(&in, 5.0f, 0.5f * 3.14159265f);
    for (k = 0; k < 20000; ++k) {
        CHECK(ctrl_protect_step(&p, &in) == CTRL_PROTECT_NONE, "standstill normal vector");
        if (p.code) break;
    }
    /* an open phase trips at every speed, within open_time_s + the reference's hold near zero */
    for (x = 0; x < 3; ++x) {
        for (k = 0; k < 5; ++k) {
            int n = (int)(2.0f * 6.2831853f / speeds[k] / TS) + 400;
            if (n > 50000) n = 50000;
            init(&p);
            hit = rotate(&p, 5.0f, speeds[k], n, x, -1, 0.0f);
            CHECK(hit >= 0 && p.code == CTRL_PROTECT_OPEN_PHASE, "open %d at %f: %d code %d", x,
                  (double)speeds[k], hit, p.code);
            CHECK(p.detail / 10000000L == x, "phase in detail %ld", (long)p.detail);
            /* the timer runs while the reference asks for >= 1 A in x AND the loop current
             * is >= 1 A: at 5 A that is ~70 % of the period (the loop current is zero where
             * the reference peaks), so 20 ms of evidence take <= 30 ms at speed */
            if (speeds[k] >= 209.0f) {
                CHECK(hit >= 199 && (float)hit * TS <= 0.030f, "20 ms of evidence: %d", hit);
            } else if (speeds[k] >= 20.0f) {
                CHECK((float)hit * TS <= 6.2831853f / speeds[k] + 0.021f, "within a period: %d", hit);
            }
        }
    }
    /* below open_i_min_a no open-phase judgement (no-load current); the phase then reads
     * exactly 0 A while the others move: the stuck-sensor check reports it after 0.1 s */
    init(&p);
    hit = rotate(&p, 0.9f, 209.0f, 5000, 0, -1, 0.0f);
    CHECK(p.code == CTRL_PROTECT_SENSOR_FAULT && hit >= 999 && hit <= 1001 && p.detail == 0,
          "below the floor: %d code %d detail %ld", hit, p.code, (long)p.detail);
}

static void test_sensor_plausibility(void)
{
    ctrl_protect_t p;
    ctrl_protect_input_t in;
    unsigned lcg = 1u;
    int k, hit;
    /* healthy with +-40 mA uniform noise on every sensor */
    init(&p);
    for (k = 0; k < 20000; ++k) {
        int x;
        balanced(&in, 8.0f, 0.4f + 209.0f * TS * (float)k);
        for (x = 0; x < 3; ++x) {
            lcg = lcg * 1664525u + 1013904223u;
            in.i_abc_a[x] += 0.08f * ((float)(lcg >> 8) / 16777216.0f - 0.5f);
        }
        if (ctrl_protect_step(&p, &in) != CTRL_PROTECT_NONE) break;
    }
    CHECK(p.code == CTRL_PROTECT_NONE, "noise tripped at %d", k);
    /* an offset of 2 A: the filtered sum passes 1 A after tau ln 2 = 3.5 ms */
    init(&p);
    hit = rotate(&p, 5.0f, 209.0f, 2000, -1, -1, 2.0f);
    CHECK(p.code == CTRL_PROTECT_SENSOR_FAULT && hit >= 30 && hit <= 40, "offset: %d", hit);
    CHECK(p.detail / 10000000L == 3, "sum detail %ld", (long)p.detail);
    /* a stuck sensor (phase c) while the machine turns: the sum catches it first ... */
    init(&p);
    hit = rotate(&p, 5.0f, 209.0f, 5000, -1, 2, 0.0f);
    CHECK(p.code == CTRL_PROTECT_SENSOR_FAULT && hit > 0, "stuck: %d", hit);
    /* ... and with the sum check off the stuck-value check does, after stuck_time_s */
    init(&p);
    p.cfg.sum_max_a = 0.0f;
    hit = rotate(&p, 5.0f, 209.0f, 5000, -1, 2, 0.0f);
    CHECK(p.code == CTRL_PROTECT_SENSOR_FAULT && hit >= 999 && hit <= 1001, "stuck timer: %d", hit);
    CHECK(p.detail / 10000000L == 2, "stuck detail %ld", (long)p.detail);
    /* at standstill every reading is constant: not a stuck sensor */
    init(&p);
    p.cfg.sum_max_a = 0.0f;
    CHECK(rotate(&p, 5.0f, 0.0f, 5000, -1, -1, 0.0f) < 0, "standstill constant readings");
}

static void test_bus(void)
{
    ctrl_protect_t p;
    ctrl_protect_input_t in;
    int k;
    init(&p);
    balanced(&in, 1.0f, 0.0f);
    in.v_dc_v = 0.69f * VDC;
    for (k = 0; k < 10 && ctrl_protect_step(&p, &in) == CTRL_PROTECT_NONE; ++k) {
    }
    CHECK(p.code == CTRL_PROTECT_UNDERVOLTAGE && k == 9, "uv after 1 ms: %d", k);
    CHECK(p.detail == (int32_t)(0.69f * VDC * 1000.0f), "uv detail %ld", (long)p.detail);
    init(&p);
    in.v_dc_v = 1.26f * VDC;
    for (k = 0; k < 10 && ctrl_protect_step(&p, &in) == CTRL_PROTECT_NONE; ++k) {
    }
    CHECK(p.code == CTRL_PROTECT_OVERVOLTAGE, "ov");
    init(&p);
    in.v_dc_v = 0.0f; /* not measured (no SENSE_AUX yet) */
    for (k = 0; k < 100; ++k) CHECK(ctrl_protect_step(&p, &in) == CTRL_PROTECT_NONE, "no bus reading");
    init(&p);
    for (k = 0; k < 100; ++k) { /* a glitch shorter than vdc_time_s */
        in.v_dc_v = (k % 5 == 0) ? 0.5f * VDC : VDC;
        CHECK(ctrl_protect_step(&p, &in) == CTRL_PROTECT_NONE, "glitch");
    }
}

static void test_link(void)
{
    ctrl_protect_t p;
    ctrl_protect_input_t in;
    int k;
    init(&p);
    balanced(&in, 1.0f, 0.0f);
    for (k = 0; k < 100; ++k) { /* a SENSE every period: never */
        CHECK(ctrl_protect_link_tick(&p, 0.5f * TS) == 0 && ctrl_protect_link_tick(&p, 0.5f * TS) == 0, "fed");
        (void)ctrl_protect_step(&p, &in);
    }
    for (k = 0; k < 10; ++k) CHECK(ctrl_protect_link_tick(&p, TS * 0.999f) == 0, "up to 10 periods");
    CHECK(ctrl_protect_link_tick(&p, 0.02f * TS) == CTRL_PROTECT_LINK_TIMEOUT, "timeout");
    CHECK(p.detail >= 999 && p.detail <= 1003, "gap in us: %ld", (long)p.detail);
}

static void test_config_and_params(void)
{
    ctrl_protect_t p;
    ctrl_protect_config_t cfg;
    ctrl_config_t cc;
    ctrl_protect_default_config(&cfg);
    cfg.open_ratio = -0.1f;
    CHECK(ctrl_protect_init(&p, &cfg, TS, VDC) == -1, "negative refused");
    ctrl_protect_default_config(&cfg);
    cfg.vdc_ov_ratio = 0.9f;
    CHECK(ctrl_protect_init(&p, &cfg, TS, VDC) == -1, "ov below nominal refused");
    ctrl_config_defaults(&cc);
    CHECK(ctrl_param_set(&cc, HIL_PARAM_PROT_OPEN_TIME_S, 0.05f) == HIL_CONFIG_STATUS_OK &&
          fabsf(cc.prot.open_time_s - 0.05f) < 1e-9f, "param stored");
    CHECK(ctrl_param_set(&cc, HIL_PARAM_PROT_OPEN_RATIO, 1.5f) == HIL_CONFIG_STATUS_OUT_OF_RANGE, "range");
    CHECK(ctrl_param_set(&cc, HIL_PARAM_PROT_LINK_TIMEOUT_PERIODS, 4.0f) == HIL_CONFIG_STATUS_OK &&
          fabsf(cc.prot.link_timeout_periods - 4.0f) < 1e-9f, "link periods");
}

/* the controller: encoder angle source (closed loop at once), a trip turns the outputs off */
static void test_in_controller(void)
{
    controller_t c;
    ctrl_sample_t s;
    const ctrl_output_t *o;
    int k;
    ctrl_init(&c);
    c.cfg.rs_ohm = 0.6383f;
    c.cfg.ld_h = c.cfg.lq_h = 2e-3f;
    c.cfg.psi_f_wb = 0.085f;
    c.cfg.pole_pairs = 4.0f;
    c.cfg.j_kgm2 = 0.013f;
    c.cfg.b_nms = 0.0035f;
    c.cfg.v_dc_nom_v = VDC;
    c.cfg.ts_s = TS;
    c.cfg.estimator = (float)CTRL_EST_ENCODER;
    CHECK(ctrl_start(&c) == 0, "start");
    memset(&s, 0, sizeof s);
    s.v_dc_v = VDC;
    for (k = 0; k < 10; ++k) {
        o = ctrl_step(&c, &s);
        CHECK(o->state == CTRL_STATE_CLOSED_LOOP && o->fault == CTRL_FAULT_NONE, "running");
    }
    s.v_dc_v = 150.0f; /* under-voltage for 1 ms */
    for (k = 0; k < 12; ++k) o = ctrl_step(&c, &s);
    CHECK(o->state == CTRL_STATE_FAULT && o->fault == CTRL_FAULT_UNDERVOLTAGE, "uv trip");
    CHECK(o->fault_detail == 150000, "detail %ld", (long)o->fault_detail);
    CHECK(o->duty_abc[0] < 0.0f && o->duty_abc[1] < 0.0f && o->duty_abc[2] < 0.0f, "outputs off");
    s.v_dc_v = VDC;
    for (k = 0; k < 10; ++k) o = ctrl_step(&c, &s);
    CHECK(o->state == CTRL_STATE_FAULT && o->duty_abc[0] < 0.0f, "stays in FAULT");
    ctrl_clear_fault(&c);
    o = ctrl_step(&c, &s);
    CHECK(o->state == CTRL_STATE_IDLE && o->fault == CTRL_FAULT_NONE && o->fault_detail == 0, "cleared");
    CHECK(ctrl_start(&c) == 0, "restart");
    o = ctrl_step(&c, &s);
    CHECK(o->state == CTRL_STATE_CLOSED_LOOP, "running again");
    s.i_b_a = 31.0f;
    o = ctrl_step(&c, &s);
    CHECK(o->fault == CTRL_FAULT_OVERCURRENT && o->fault_detail == 10000000L + 31000L,
          "oc detail %ld", (long)o->fault_detail);
    /* link timer of a free-running port */
    ctrl_clear_fault(&c);
    CHECK(ctrl_start(&c) == 0, "restart");
    s.i_b_a = 0.0f;
    o = ctrl_step(&c, &s);
    for (k = 0; k < 10; ++k) CHECK(ctrl_link_tick(&c, TS) == CTRL_FAULT_NONE, "within 10 periods");
    CHECK(ctrl_link_tick(&c, 0.1f * TS) == CTRL_FAULT_LINK_TIMEOUT, "link timeout");
    CHECK(c.state == CTRL_STATE_FAULT && c.out.duty_abc[0] < 0.0f, "off after the timeout");
    CHECK(ctrl_link_tick(&c, TS) == CTRL_FAULT_NONE, "reported once");
}

int main(void)
{
    test_overcurrent();
    test_open_phase();
    test_sensor_plausibility();
    test_bus();
    test_link();
    test_config_and_params();
    test_in_controller();
    return check_summary("fw_protect");
}
