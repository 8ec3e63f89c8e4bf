/**
 * @file test_firmware.c
 * @brief Unit tests of the portable firmware: transforms, SVPWM, PI, the sign SMO on a known
 * trajectory, and the HIL session driven frame by frame through a capturing port.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "controller.h"
#include "est_smo_sign.h"
#include "fw_math.h"
#include "hil_framing.h"
#include "hil_msgs.h"
#include "hil_session.h"
#include "pi_ctrl.h"
#include "svpwm.h"

#include "check.h"

static float absf(float x) { return x < 0.0f ? -x : x; }

/* ---- transforms ------------------------------------------------------------------------ */
static void test_transforms(void)
{
    int k;
    for (k = 0; k < 36; ++k) {
        float th = (float)k * 0.17453292f; /* 10 deg steps */
        float amp = 3.0f;
        float a = amp * cosf(th), b = amp * cosf(th - 2.0943951f), c = amp * cosf(th + 2.0943951f);
        fw_vec2_t ab = fw_clarke(a, b, c);
        fw_vec2_t dq = fw_park(ab, sinf(th), cosf(th));
        fw_vec2_t back = fw_park_inv(dq, sinf(th), cosf(th));
        float a2, b2, c2;
        CHECK(absf(ab.x - amp * cosf(th)) < 1e-5f && absf(ab.y - amp * sinf(th)) < 1e-5f,
              "clarke of a balanced set at %f rad: (%f, %f)", (double)th, (double)ab.x, (double)ab.y);
        CHECK(absf(dq.x - amp) < 1e-5f && absf(dq.y) < 1e-5f, "park aligns: (%f, %f)",
              (double)dq.x, (double)dq.y);
        CHECK(absf(back.x - ab.x) < 1e-5f && absf(back.y - ab.y) < 1e-5f, "inverse park");
        fw_clarke_inv(ab, &a2, &b2, &c2);
        CHECK(absf(a2 - a) < 1e-5f && absf(b2 - b) < 1e-5f && absf(c2 - c) < 1e-5f, "inverse clarke");
    }
    CHECK(absf(fw_wrap_2pi(-0.1f) - (FW_TWO_PI_F - 0.1f)) < 1e-5f, "wrap negative");
    CHECK(fw_wrap_2pi(FW_TWO_PI_F) < 1e-5f, "wrap 2pi to 0");
    CHECK(absf(fw_wrap_pi(3.5f) - (3.5f - FW_TWO_PI_F)) < 1e-5f, "wrap to [-pi, pi)");
    CHECK(!fw_is_finite(NAN) && !fw_is_finite(INFINITY) && fw_is_finite(1.0f), "is_finite");
}

/* ---- SVPWM ----------------------------------------------------------------------------- */
/* What an averaged inverter makes of the duties: pole voltages minus their common mode. */
static fw_vec2_t realised(const float d[3], float v_dc)
{
    float va = d[0] * v_dc, vb = d[1] * v_dc, vc = d[2] * v_dc;
    float cm = (va + vb + vc) / 3.0f;
    return fw_clarke(va - cm, vb - cm, vc - cm);
}

static void test_svpwm(void)
{
    const float v_dc = 310.0f;
    const float v_lim = v_dc * FW_INV_SQRT3_F;
    int k;
    for (k = 0; k < 72; ++k) {
        float th = (float)k * 0.0872665f;
        float mags[3] = {0.0f, 0.5f * v_lim, 0.999f * v_lim};
        int m;
        for (m = 0; m < 3; ++m) {
            fw_vec2_t v = {mags[m] * cosf(th), mags[m] * sinf(th)};
            float d[3];
            fw_vec2_t out = svpwm_duties(v, v_dc, d);
            fw_vec2_t got = realised(d, v_dc);
            CHECK(d[0] >= 0.0f && d[0] <= 1.0f && d[1] >= 0.0f && d[1] <= 1.0f && d[2] >= 0.0f &&
                  d[2] <= 1.0f, "duties in range");
            CHECK(absf(got.x - v.x) < 1e-3f && absf(got.y - v.y) < 1e-3f,
                  "linear range realised: want (%f, %f) got (%f, %f)", (double)v.x, (double)v.y,
                  (double)got.x, (double)got.y);
            CHECK(absf(out.x - v.x) < 1e-3f && absf(out.y - v.y) < 1e-3f, "reported = commanded");
        }
        {   /* twice the limit: scaled back onto the circle, angle kept */
            fw_vec2_t v = {2.0f * v_lim * cosf(th), 2.0f * v_lim * sinf(th)};
            float d[3];
            fw_vec2_t out = svpwm_duties(v, v_dc, d);
            fw_vec2_t got = realised(d, v_dc);
            float mag = sqrtf(got.x * got.x + got.y * got.y);
            CHECK(absf(mag - v_lim) < 1e-2f, "overmodulated vector on the circle: %f", (double)mag);
            CHECK(absf(out.x - got.x) < 1e-2f && absf(out.y - got.y) < 1e-2f, "reports what it realised");
            CHECK(absf(fw_wrap_pi(atan2f(got.y, got.x) - th)) < 1e-4f, "angle kept");
        }
    }
}

/* ---- PI -------------------------------------------------------------------------------- */
static void test_pi(void)
{
    pi_ctrl_t pi;
    pi_ctrl_config_t cfg = {2.0f, 100.0f, -10.0f, 10.0f};
    int k;
    float u = 0.0f;
    pi_ctrl_init(&pi, &cfg);
    for (k = 0; k < 10000; ++k) { /* long saturation */
        u = pi_ctrl_step(&pi, 100.0f, 1e-3f);
    }
    CHECK(absf(u - 10.0f) < 1e-6f, "saturated at the limit: %f", (double)u);
    CHECK(pi.integ <= 10.0f, "integrator bounded: %f", (double)pi.integ);
    u = pi_ctrl_step(&pi, -1.0f, 1e-3f);
    CHECK(u < 10.0f, "leaves saturation at once when the error reverses: %f", (double)u);
    pi_ctrl_reset(&pi, 0.0f);
    u = pi_ctrl_step(&pi, 1.0f, 1e-3f);
    CHECK(absf(u - (2.0f + 0.1f)) < 1e-6f, "kp*e + ki*Ts*e: %f", (double)u);
}

/* ---- sign SMO on a known trajectory ------------------------------------------------------ */
static void test_smo_sign_tracks_angle(void)
{
    /* SPMSM (Gong Table I) at a constant 500 rpm: the measured current comes from the same
     * discrete RL model the observer uses, driven by a voltage that keeps i_q near 1 A. */
    const float rs = 0.6383f, ls = 2e-3f, psi = 0.085f, ts = 1e-4f;
    const float we = 500.0f * 0.10471976f * 4.0f;
    est_smo_sign_t smo;
    est_smo_sign_config_t cfg;
    fw_vec2_t i = {0.0f, 0.0f}, v_prev = {0.0f, 0.0f};
    float f = expf(-rs * ts / ls), g = (1.0f - f) / rs;
    float th = 0.3f, err_max = 0.0f;
    int k;
    est_smo_sign_default_config(&cfg, rs, ls, psi, ts);
    cfg.k_v = 25.0f;
    cfg.wc_rad_s = 300.0f;
    CHECK(est_smo_sign_init(&smo, &cfg) == 0, "init");
    for (k = 0; k < 3000; ++k) {
        const est_output_t *o = est_smo_sign_step(&smo, i, v_prev);
        fw_vec2_t e = {-we * psi * sinf(th), we * psi * cosf(th)};
        fw_vec2_t v = {e.x - rs * sinf(th) * -1.0f, e.y + rs * cosf(th)}; /* ~ E + R*i_q */
        if (k > 2000) {
            float err = absf(fw_wrap_pi(o->theta_e_rad - th));
            err_max = err > err_max ? err : err_max;
        }
        /* plant: exact ZOH RL step with the back EMF at mid-period */
        {
            float th_mid = th + 0.5f * we * ts;
            fw_vec2_t em = {-we * psi * sinf(th_mid), we * psi * cosf(th_mid)};
            i.x = f * i.x + g * (v.x - em.x);
            i.y = f * i.y + g * (v.y - em.y);
        }
        v_prev = v;
        th = fw_wrap_2pi(th + we * ts);
    }
    printf("sign SMO: angle error max %.4f rad, speed %.1f rad/s (true %.1f)\n", (double)err_max, (double)smo.out.omega_e_rad_s, (double)we);
    CHECK(err_max < 0.1f, "sign SMO angle error after 0.2 s at 500 rpm: %f rad", (double)err_max);
    CHECK(absf(smo.out.omega_e_rad_s - we) < 0.05f * we, "speed estimate %f vs %f",
          (double)smo.out.omega_e_rad_s, (double)we);
    cfg.ls_h = 0.0f;
    CHECK(est_smo_sign_init(&smo, &cfg) == -1, "invalid config refused");
}

/* ---- the session, frame by frame ------------------------------------------------------- */
#define MAX_CAPTURED 32
typedef struct {
    int n;
    uint16_t id[MAX_CAPTURED];
    hil_octet_t data[MAX_CAPTURED][8];
} capture_t;

static void capture_send(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    capture_t *c = (capture_t *)ctx;
    if (c->n < MAX_CAPTURED && dlc <= 8u) {
        c->id[c->n] = id;
        memcpy(c->data[c->n], data, dlc);
        c->n++;
    }
}

static int find(const capture_t *c, uint16_t id)
{
    int k;
    for (k = c->n - 1; k >= 0; --k) {
        if (c->id[k] == id) {
            return k;
        }
    }
    return -1;
}

static void deliver(hil_session_t *s, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    hil_frame_t f;
    f.id = id;
    f.dlc = dlc;
    memcpy(f.data, data, dlc);
    hil_session_on_frame(s, &f);
}

static void send_hello(hil_session_t *s, uint16_t version, uint16_t estimator)
{
    hil_hello_t h;
    hil_octet_t b[8];
    h.proto_version = version;
    h.proto_minor = HIL_PROTO_VERSION_MINOR;
    h.mode = HIL_MODE_LOCKSTEP;
    h.period_us = hil_hello_period_us_encode(100.0f);
    h.estimator = estimator;
    h.flags = HIL_HELLO_FLAG_TELEM_EMF;
    h.session = 0x1234u;
    hil_hello_pack(b, &h, sizeof b);
    deliver(s, HIL_HELLO_FRAME_ID, b, HIL_HELLO_LENGTH);
}

static int send_config(hil_session_t *s, capture_t *cap, unsigned id, float value)
{
    hil_config_t c;
    hil_config_ack_t a;
    hil_octet_t b[8];
    int k;
    c.param_id = (uint16_t)id;
    c.config_seq = 7u;
    c.value = value;
    hil_config_pack(b, &c, sizeof b);
    deliver(s, HIL_CONFIG_FRAME_ID, b, HIL_CONFIG_LENGTH);
    k = find(cap, HIL_CONFIG_ACK_FRAME_ID);
    if (k < 0) {
        return -1;
    }
    hil_config_ack_unpack(&a, cap->data[k], 8u);
    return (int)a.status;
}

static void send_cmd(hil_session_t *s, unsigned command, float value)
{
    hil_cmd_t c;
    hil_octet_t b[8];
    c.command = (uint16_t)command;
    c.seq = 0u;
    c.value = value;
    hil_cmd_pack(b, &c, sizeof b);
    deliver(s, HIL_CMD_FRAME_ID, b, HIL_CMD_LENGTH);
}

static void send_sense(hil_session_t *s, uint16_t seq, float ia, float ib)
{
    hil_sense_t m;
    hil_sense_aux_t a;
    hil_octet_t b[8];
    a.seq = seq;
    a.v_dc = hil_sense_aux_v_dc_encode(310.0f);
    a.theta_enc = 0u;
    a.flags = 0u;
    hil_sense_aux_pack(b, &a, sizeof b);
    deliver(s, HIL_SENSE_AUX_FRAME_ID, b, HIL_SENSE_AUX_LENGTH);
    m.seq = seq;
    m.i_a = hil_sense_i_a_encode(ia);
    m.i_b = hil_sense_i_b_encode(ib);
    m.i_c = hil_sense_i_c_encode(-ia - ib);
    hil_sense_pack(b, &m, sizeof b);
    deliver(s, HIL_SENSE_FRAME_ID, b, HIL_SENSE_LENGTH);
}

static void test_session(void)
{
    static hil_session_t s;
    capture_t cap;
    hil_port_t port;
    hil_hello_ack_t ack;
    hil_duty_t duty;
    hil_telem_t tel;
    int k;
    const struct { unsigned id; float v; } motor[] = {
        {HIL_PARAM_RS_OHM, 0.6383f}, {HIL_PARAM_LD_H, 2e-3f}, {HIL_PARAM_LQ_H, 2e-3f},
        {HIL_PARAM_PSI_F_WB, 0.085f}, {HIL_PARAM_POLE_PAIRS, 4.0f}, {HIL_PARAM_J_KGM2, 0.013f},
        {HIL_PARAM_B_NMS, 0.0035f}, {HIL_PARAM_V_DC_NOM_V, 310.0f}};

    memset(&cap, 0, sizeof cap);
    port.ctx = &cap;
    port.send = capture_send;
    hil_session_init(&s, &port);

    send_sense(&s, 0u, 0.0f, 0.0f);
    CHECK(cap.n == 0 && s.stats.not_ready == 1u, "SENSE before HELLO is ignored and counted");

    send_hello(&s, 99u, HIL_EST_SMO_SIGN);
    k = find(&cap, HIL_HELLO_ACK_FRAME_ID);
    CHECK(k >= 0, "HELLO answered");
    hil_hello_ack_unpack(&ack, cap.data[k], 8u);
    CHECK(ack.status == HIL_HELLO_STATUS_VERSION_MISMATCH, "wrong version refused: %u", ack.status);

    send_hello(&s, HIL_PROTO_VERSION, HIL_EST_HFI_SDFT + 9u);
    hil_hello_ack_unpack(&ack, cap.data[find(&cap, HIL_HELLO_ACK_FRAME_ID)], 8u);
    CHECK(ack.status == HIL_HELLO_STATUS_ESTIMATOR_UNSUPPORTED, "unknown estimator refused");

    send_hello(&s, HIL_PROTO_VERSION, HIL_EST_SMO_SIGN);
    hil_hello_ack_unpack(&ack, cap.data[find(&cap, HIL_HELLO_ACK_FRAME_ID)], 8u);
    CHECK(ack.status == HIL_HELLO_STATUS_OK && ack.session == 0x1234u, "accepted, session echoed");
    CHECK((ack.estimators >> HIL_EST_SMO_SIGN) & 1u, "capability mask lists SMO_SIGN");

    CHECK(send_config(&s, &cap, 999u, 1.0f) == HIL_CONFIG_STATUS_UNKNOWN_PARAM, "unknown param");
    CHECK(send_config(&s, &cap, HIL_PARAM_RS_OHM, -1.0f) == HIL_CONFIG_STATUS_OUT_OF_RANGE,
          "negative resistance refused");
    CHECK(send_config(&s, &cap, HIL_PARAM_LD_H, NAN) == HIL_CONFIG_STATUS_OUT_OF_RANGE, "NaN refused");

    cap.n = 0;
    send_cmd(&s, HIL_CMD_RUN, 0.0f);
    CHECK(find(&cap, HIL_FAULT_CTRL_FRAME_ID) >= 0, "RUN without a motor configuration faults");
    CHECK(s.ctrl.state == CTRL_STATE_FAULT, "state FAULT");
    send_cmd(&s, HIL_CMD_CLEAR_FAULT, 0.0f);

    cap.n = 0;
    send_sense(&s, 1u, 0.5f, -0.25f);
    k = find(&cap, HIL_DUTY_FRAME_ID);
    CHECK(k >= 0, "idle controller still answers SENSE");
    hil_duty_unpack(&duty, cap.data[k], 8u);
    CHECK(duty.d_a == HIL_DUTY_RAW_OFF && duty.d_b == HIL_DUTY_RAW_OFF, "idle: legs OFF");
    CHECK(find(&cap, HIL_TELEM_FRAME_ID) < k && find(&cap, HIL_TELEM_EMF_FRAME_ID) < k,
          "TELEM and TELEM_EMF before DUTY");

    for (k = 0; k < (int)(sizeof motor / sizeof motor[0]); ++k) {
        CHECK(send_config(&s, &cap, motor[k].id, motor[k].v) == HIL_CONFIG_STATUS_OK, "config %u",
              motor[k].id);
    }
    send_cmd(&s, HIL_CMD_SET_SPEED_REF, 10.0f);
    send_cmd(&s, HIL_CMD_RUN, 0.0f);
    CHECK(s.ctrl.state == CTRL_STATE_ALIGN, "RUN starts the alignment: %d", (int)s.ctrl.state);
    CHECK(send_config(&s, &cap, HIL_PARAM_RS_OHM, 1.0f) == HIL_CONFIG_STATUS_LOCKED,
          "no CONFIG while running");

    cap.n = 0;
    send_sense(&s, 2u, 0.0f, 0.0f);
    hil_duty_unpack(&duty, cap.data[find(&cap, HIL_DUTY_FRAME_ID)], 8u);
    hil_telem_unpack(&tel, cap.data[find(&cap, HIL_TELEM_FRAME_ID)], 8u);
    CHECK(duty.seq == 2u && tel.seq == 2u, "seq echoed");
    CHECK(duty.d_a <= 32768u && duty.d_b <= 32768u && duty.d_c <= 32768u, "running: real duties");
    CHECK(tel.state == HIL_STATE_ALIGN, "telemetry state");

    send_sense(&s, 9u, 0.0f, 0.0f);
    CHECK(s.stats.seq_errors == 1u, "a jump in seq is counted");
    {
        hil_octet_t junk[8] = {0};
        deliver(&s, 0x7FFu, junk, 8u);
        CHECK(s.stats.unknown_ids == 1u, "unknown id counted");
        deliver(&s, HIL_SENSE_FRAME_ID, junk, 3u);
        CHECK(s.stats.length_errors == 1u, "short SENSE counted, not decoded");
    }
    cap.n = 0;
    send_sense(&s, 10u, 40.0f, -20.0f);
    CHECK(find(&cap, HIL_FAULT_CTRL_FRAME_ID) >= 0 && s.ctrl.state == CTRL_STATE_FAULT,
          "over-current trips to FAULT and says so");
    hil_duty_unpack(&duty, cap.data[find(&cap, HIL_DUTY_FRAME_ID)], 8u);
    CHECK(duty.d_a == HIL_DUTY_RAW_OFF, "fault: legs OFF");
}

int main(void)
{
    test_transforms();
    test_svpwm();
    test_pi();
    test_smo_sign_tracks_angle();
    test_session();
    return check_summary("test_fw_core");
}
