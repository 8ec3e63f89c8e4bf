/**
 * @file test_fw_session.c
 * @brief The portable HIL session against docs/protocol.md 1.1: the answer cache for repeated SENSE
 * (6.5), HELLO statuses MODE_UNSUPPORTED / ESTIMATOR_UNSUPPORTED / PERIOD_UNSUPPORTED (6.1, 6.8)
 * with a port's narrower periods, the encoder-angle rule (6.8), CMD seq gaps (6.3), CMD RESTART
 * (6.3), whole-number parameters (6.2) and the minor version a session speaks (6.1, 10). Driven
 * frame by frame through a capturing port.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ctrl_params.h"
#include "hil_msgs.h"
#include "hil_session.h"

#include "check.h"

#define MAX_CAPTURED 64

typedef struct {
    int n;
    uint16_t id[MAX_CAPTURED];
    uint16_t dlc[MAX_CAPTURED];
    hil_octet_t data[MAX_CAPTURED][8];
} capture_t;

static void capture_send(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    capture_t *c = (capture_t *)ctx;
    if (c->n < MAX_CAPTURED && dlc <= 8u) {
        c->id[c->n] = id;
        c->dlc[c->n] = dlc;
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

static uint16_t hello_period(hil_session_t *s, capture_t *cap, uint16_t mode, uint16_t estimator,
                             uint16_t flags, float period_us)
{
    hil_hello_t h;
    hil_hello_ack_t a;
    hil_octet_t b[8];
    int k;
    h.proto_version = HIL_PROTO_VERSION;
    h.proto_minor = HIL_PROTO_VERSION_MINOR;
    h.mode = mode;
    h.period_us = hil_hello_period_us_encode(period_us);
    h.estimator = estimator;
    h.flags = flags;
    h.session = 0x4242u;
    hil_hello_pack(b, &h, sizeof b);
    deliver(s, HIL_HELLO_FRAME_ID, b, HIL_HELLO_LENGTH);
    k = find(cap, HIL_HELLO_ACK_FRAME_ID);
    if (k < 0) {
        return 0xFFFFu;
    }
    hil_hello_ack_unpack(&a, cap->data[k], 8u);
    return a.status;
}

static uint16_t hello(hil_session_t *s, capture_t *cap, uint16_t mode, uint16_t estimator, uint16_t flags)
{
    return hello_period(s, cap, mode, estimator, flags, 100.0f);
}

static int config(hil_session_t *s, capture_t *cap, unsigned id, float value)
{
    hil_config_t c;
    hil_config_ack_t a;
    hil_octet_t b[8];
    int k;
    c.param_id = (uint16_t)id;
    c.config_seq = 1u;
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

static void cmd(hil_session_t *s, unsigned command, uint16_t seq, float value)
{
    hil_cmd_t c;
    hil_octet_t b[8];
    c.command = (uint16_t)command;
    c.seq = seq;
    c.value = value;
    hil_cmd_pack(b, &c, sizeof b);
    deliver(s, HIL_CMD_FRAME_ID, b, HIL_CMD_LENGTH);
}

static void sense_aux_vdc(hil_session_t *s, uint16_t seq, float theta, uint16_t flags, float v_dc)
{
    hil_sense_aux_t a;
    hil_octet_t b[8];
    a.seq = seq;
    a.v_dc = hil_sense_aux_v_dc_encode(v_dc);
    a.theta_enc = hil_sense_aux_theta_enc_encode(theta);
    a.flags = flags;
    hil_sense_aux_pack(b, &a, sizeof b);
    deliver(s, HIL_SENSE_AUX_FRAME_ID, b, HIL_SENSE_AUX_LENGTH);
}

static void sense_aux(hil_session_t *s, uint16_t seq, float theta, uint16_t flags)
{
    sense_aux_vdc(s, seq, theta, flags, 310.0f);
}

static void sense(hil_session_t *s, uint16_t seq, float ia, float ib)
{
    hil_sense_t m;
    hil_octet_t b[8];
    m.seq = seq;
    m.i_a = hil_sense_i_a_encode(ia);
    m.i_b = hil_sense_i_b_encode(ib);
    m.i_c = hil_sense_i_c_encode(-ia - ib);
    hil_sense_pack(b, &m, sizeof b);
    deliver(s, HIL_SENSE_FRAME_ID, b, HIL_SENSE_LENGTH);
}

static void configure_motor(hil_session_t *s, capture_t *cap)
{
    const struct { unsigned id; float v; } motor[] = {
        {HIL_PARAM_RS_OHM, 0.6383f}, {HIL_PARAM_LD_H, 2e-3f}, {HIL_PARAM_LQ_H, 2e-3f},
        {HIL_PARAM_PSI_F_WB, 0.085f}, {HIL_PARAM_POLE_PAIRS, 4.0f}, {HIL_PARAM_J_KGM2, 0.013f},
        {HIL_PARAM_B_NMS, 0.0035f}, {HIL_PARAM_V_DC_NOM_V, 310.0f}, {HIL_PARAM_ALIGN_TIME_S, 0.001f}};
    size_t k;
    for (k = 0u; k < sizeof motor / sizeof motor[0]; ++k) {
        CHECK(config(s, cap, motor[k].id, motor[k].v) == HIL_CONFIG_STATUS_OK, "config %u", motor[k].id);
    }
}

/* 6.5: a repeated SENSE is answered from the cache, byte for byte, and the ISR does not run. */
static void test_retry_is_answered_from_the_cache(void)
{
    static hil_session_t s;
    static controller_t before;
    capture_t cap;
    hil_port_t port;
    capture_t first;
    int k, j;
    uint16_t seq;

    memset(&cap, 0, sizeof cap);
    port.ctx = &cap;
    port.send = capture_send;
    hil_session_init(&s, &port);
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, HIL_HELLO_FLAG_TELEM_EMF) ==
          HIL_HELLO_STATUS_OK, "HELLO accepted");
    configure_motor(&s, &cap);
    cmd(&s, HIL_CMD_SET_SPEED_REF, 1u, 50.0f);
    cmd(&s, HIL_CMD_RUN, 2u, 0.0f);
    CHECK(s.ctrl.state == CTRL_STATE_ALIGN, "running");

    for (seq = 0u; seq < 40u; seq++) { /* through the alignment into the open-loop ramp */
        sense_aux(&s, seq, 0.0f, 0u);
        sense(&s, seq, 0.3f * sinf((float)seq * 0.1f), 0.2f);
    }
    CHECK(s.stats.cycles == 40u && s.stats.repeats == 0u && s.stats.seq_errors == 0u, "40 cycles");

    cap.n = 0;
    sense_aux(&s, 40u, 0.0f, 0u);
    sense(&s, 40u, 1.0f, -0.5f);
    CHECK(cap.n == 3 && cap.id[0] == HIL_TELEM_FRAME_ID && cap.id[1] == HIL_TELEM_EMF_FRAME_ID &&
              cap.id[2] == HIL_DUTY_FRAME_ID, "TELEM, TELEM_EMF, DUTY: %d frames", cap.n);
    first = cap;
    before = s.ctrl;

    for (j = 1; j <= 3; j++) { /* the host retries three times (same frames, same seq) */
        cap.n = 0;
        sense_aux(&s, 40u, 0.0f, 0u);
        sense(&s, 40u, 1.0f, -0.5f);
        CHECK(cap.n == first.n, "retry %d: %d frames, expected %d", j, cap.n, first.n);
        for (k = 0; k < cap.n && k < first.n; k++) {
            CHECK(cap.id[k] == first.id[k] && cap.dlc[k] == first.dlc[k] &&
                      memcmp(cap.data[k], first.data[k], first.dlc[k]) == 0,
                  "retry %d frame %d is the cached one byte for byte", j, k);
        }
        CHECK(memcmp(&before, &s.ctrl, sizeof before) == 0, "retry %d: the ISR did not run (state unchanged)", j);
    }
    CHECK(s.stats.cycles == 41u && s.stats.repeats == 3u, "cycles %u repeats %u", (unsigned)s.stats.cycles,
          (unsigned)s.stats.repeats);

    /* even different currents in a repeated seq are not a new cycle */
    cap.n = 0;
    sense(&s, 40u, 5.0f, 5.0f);
    CHECK(cap.n == 3 && memcmp(cap.data[2], first.data[2], 8u) == 0, "a repeated seq is the cache, whatever it holds");

    /* the next seq runs the ISR again, no seq error */
    cap.n = 0;
    sense_aux(&s, 41u, 0.0f, 0u);
    sense(&s, 41u, 1.0f, -0.5f);
    CHECK(s.stats.cycles == 42u && s.stats.seq_errors == 0u, "next cycle runs");
    CHECK(memcmp(&before, &s.ctrl, sizeof before) != 0, "and changes the controller");
    {
        hil_duty_t d;
        hil_duty_unpack(&d, cap.data[find(&cap, HIL_DUTY_FRAME_ID)], 8u);
        CHECK(d.seq == 41u, "DUTY 41");
    }

    /* a jump is counted (not a repeat) */
    sense(&s, 45u, 0.0f, 0.0f);
    CHECK(s.stats.seq_errors == 1u && s.stats.cycles == 43u, "jump counted and run");

    /* wrap: 65535 then 0 is +1 */
    sense(&s, 65535u, 0.0f, 0.0f);
    sense(&s, 0u, 0.0f, 0.0f);
    CHECK(s.stats.seq_errors == 2u, "65535 -> 0 is not an error (only 45 -> 65535 is)");

    /* an accepted HELLO empties the cache: the same seq then runs the ISR */
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_OK, "new session");
    k = (int)s.stats.cycles;
    cap.n = 0;
    sense(&s, 0u, 0.0f, 0.0f);
    CHECK((int)s.stats.cycles == k + 1 && cap.n == 2, "first SENSE of a session runs (TELEM, DUTY: %d)", cap.n);
    cap.n = 0;
    sense(&s, 0u, 0.0f, 0.0f);
    CHECK((int)s.stats.cycles == k + 1 && cap.n == 2 && find(&cap, HIL_TELEM_EMF_FRAME_ID) < 0,
          "its retry is cached, without TELEM_EMF (not asked for in this session)");
}

/* 6.1: statuses in order; real-time mode can be switched off by a port. */
static void test_hello_statuses(void)
{
    static hil_session_t s;
    capture_t cap;
    hil_port_t port;
    memset(&cap, 0, sizeof cap);
    port.ctx = &cap;
    port.send = capture_send;
    hil_session_init(&s, &port);
    CHECK(hello(&s, &cap, 2u, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_MODE_UNSUPPORTED,
          "mode 2 is not in the Mode table");
    CHECK(hello(&s, &cap, HIL_MODE_REALTIME, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_OK, "real time accepted");
    s.modes = (uint16_t)(1u << HIL_MODE_LOCKSTEP);
    CHECK(hello(&s, &cap, HIL_MODE_REALTIME, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_MODE_UNSUPPORTED,
          "a lockstep-only drive refuses real time");
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_OK, "lockstep still OK");
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_ENCODER, 0u) == HIL_HELLO_STATUS_ESTIMATOR_UNSUPPORTED,
          "ENCODER without ENCODER_VALID: no angle will come");
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_ENCODER, HIL_HELLO_FLAG_ENCODER_VALID) ==
          HIL_HELLO_STATUS_OK, "ENCODER with ENCODER_VALID");
    CHECK(hello(&s, &cap, 7u, 99u, 0u) == HIL_HELLO_STATUS_MODE_UNSUPPORTED, "mode is checked before the estimator");
}

/* 6.1: PERIOD_UNSUPPORTED outside the periods the drive runs; a port narrows them to its timer's
 * (port/c2000: the ePWM's), the period of an accepted HELLO is the controller's Ts, and a restart
 * keeps the port's limits. */
static void test_a_port_narrows_the_periods(void)
{
    static hil_session_t s;
    capture_t cap;
    hil_port_t port;
    memset(&cap, 0, sizeof cap);
    port.ctx = &cap;
    port.send = capture_send;
    hil_session_init(&s, &port);
    CHECK(hello_period(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u, 5.0f) ==
              HIL_HELLO_STATUS_PERIOD_UNSUPPORTED, "below 10 us by default");
    CHECK(hello_period(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u, 6553.5f) == HIL_HELLO_STATUS_OK,
          "the wire's largest period by default");
    s.period_min_us = 100.0f;
    s.period_max_us = 1000.0f;
    CHECK(hello_period(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u, 50.0f) ==
              HIL_HELLO_STATUS_PERIOD_UNSUPPORTED, "below the port's minimum");
    CHECK(hello_period(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u, 1000.1f) ==
              HIL_HELLO_STATUS_PERIOD_UNSUPPORTED, "above the port's maximum");
    CHECK(hello_period(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u, 250.0f) == HIL_HELLO_STATUS_OK &&
              fabsf(s.ctrl.cfg.ts_s - 250.0e-6f) < 1e-9f, "accepted: Ts = 250 us");
    CHECK(hello_period(&s, &cap, 7u, HIL_EST_SMO_SIGN, 0u, 50.0f) == HIL_HELLO_STATUS_MODE_UNSUPPORTED,
          "the mode is checked before the period");
    hil_session_restart(&s);
    CHECK(s.period_min_us >= 100.0f && s.period_max_us <= 1000.0f, "a restart keeps the port's periods");
    CHECK(hello_period(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u, 50.0f) ==
              HIL_HELLO_STATUS_PERIOD_UNSUPPORTED, "still refused after the restart");
}

/* 6.8: theta_enc counts only with THETA_ENC_VALID in the SENSE_AUX of the same seq. */
static void test_encoder_angle_rule(void)
{
    static hil_session_t s;
    capture_t cap;
    hil_port_t port;
    memset(&cap, 0, sizeof cap);
    port.ctx = &cap;
    port.send = capture_send;
    hil_session_init(&s, &port);
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_ENCODER, HIL_HELLO_FLAG_ENCODER_VALID) ==
          HIL_HELLO_STATUS_OK, "ENCODER session");
    sense_aux(&s, 0u, 1.0f, HIL_SENSE_AUX_FLAG_THETA_ENC_VALID);
    sense(&s, 0u, 0.0f, 0.0f);
    CHECK(fabsf(s.theta_enc_rad - 1.0f) < 1e-4f, "valid angle taken: %f", (double)s.theta_enc_rad);
    sense_aux(&s, 1u, 2.0f, 0u);
    sense(&s, 1u, 0.0f, 0.0f);
    CHECK(fabsf(s.theta_enc_rad - 1.0f) < 1e-4f, "THETA_ENC_VALID clear: last valid angle held");
    sense_aux(&s, 7u, 3.0f, HIL_SENSE_AUX_FLAG_THETA_ENC_VALID);
    sense(&s, 2u, 0.0f, 0.0f);
    CHECK(fabsf(s.theta_enc_rad - 1.0f) < 1e-4f, "SENSE_AUX of another seq: held");
    sense_aux(&s, 3u, 3.0f, HIL_SENSE_AUX_FLAG_THETA_ENC_VALID);
    sense(&s, 3u, 0.0f, 0.0f);
    CHECK(fabsf(s.theta_enc_rad - 3.0f) < 1e-4f, "valid again");

    /* a sensorless session never takes the angle, even if a SENSE_AUX claims it is valid */
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_OK, "SMO session");
    CHECK(s.theta_enc_rad < 1e-6f && s.theta_enc_rad > -1e-6f, "HELLO resets the held angle");
    sense_aux(&s, 0u, 2.5f, HIL_SENSE_AUX_FLAG_THETA_ENC_VALID);
    sense(&s, 0u, 0.0f, 0.0f);
    CHECK(s.theta_enc_rad < 1e-6f && s.theta_enc_rad > -1e-6f, "HELLO had no ENCODER_VALID: angle ignored");
}

/* FAULT_CTRL with the code and detail of the last fault the port sent; -1 if none */
static int last_fault(const capture_t *cap, int32_t *detail)
{
    hil_fault_ctrl_t f;
    int k = find(cap, HIL_FAULT_CTRL_FRAME_ID);
    if (k < 0) {
        return -1;
    }
    hil_fault_ctrl_unpack(&f, cap->data[k], 8u);
    *detail = f.detail;
    return (int)f.code;
}

/* The session tells the controller what it does not know: no SENSE_AUX yet (nominal bus, no bus
 * check) versus a measured collapse (under-voltage), and an encoder that stopped reporting a
 * valid angle (SENSOR_FAULT after 1 ms, not a silently held angle). */
static void test_bus_and_encoder_reach_the_protection(void)
{
    static hil_session_t s;
    capture_t cap;
    hil_port_t port;
    int32_t detail = 0;
    int code = -1;
    uint16_t seq;
    memset(&cap, 0, sizeof cap);
    port.ctx = &cap;
    port.send = capture_send;
    hil_session_init(&s, &port);
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_ENCODER, HIL_HELLO_FLAG_ENCODER_VALID) ==
          HIL_HELLO_STATUS_OK, "ENCODER session");
    configure_motor(&s, &cap);
    cmd(&s, HIL_CMD_RUN, 1u, 0.0f);
    CHECK(s.ctrl.state == CTRL_STATE_CLOSED_LOOP, "running");
    /* 50 cycles without any SENSE_AUX: no bus reading, and no angle either (lost after 10) */
    for (seq = 0u; seq < 50u && code < 0; seq++) {
        cap.n = 0;
        sense(&s, seq, 0.0f, 0.0f);
        code = last_fault(&cap, &detail);
    }
    CHECK(code == HIL_FAULT_SENSOR_FAULT && seq == 10u && detail == 40001000L,
          "no angle for 1 ms: SENSOR_FAULT (encoder lost) at cycle %u, code %d detail %ld",
          (unsigned)seq, code, (long)detail);
    CHECK(s.ctrl.state == CTRL_STATE_FAULT, "in FAULT");

    /* a valid angle every cycle (at rest, where the PLL starts: the controller applies no
     * voltage to these synthetic zero currents), the bus from SENSE_AUX: runs; then the bus
     * collapses to 0.5 V */
    cmd(&s, HIL_CMD_CLEAR_FAULT, 2u, 0.0f);
    cmd(&s, HIL_CMD_RUN, 3u, 0.0f);
    code = -1;
    for (seq = 100u; seq < 150u && code < 0; seq++) {
        cap.n = 0;
        sense_aux(&s, seq, 0.0f, HIL_SENSE_AUX_FLAG_THETA_ENC_VALID);
        sense(&s, seq, 0.0f, 0.0f);
        code = last_fault(&cap, &detail);
    }
    CHECK(s.ctrl.state == CTRL_STATE_CLOSED_LOOP && code < 0, "healthy: %d", code);
    for (seq = 150u; seq < 200u && code < 0; seq++) {
        cap.n = 0;
        sense_aux_vdc(&s, seq, 0.0f, HIL_SENSE_AUX_FLAG_THETA_ENC_VALID, 0.5f);
        sense(&s, seq, 0.0f, 0.0f);
        code = last_fault(&cap, &detail);
    }
    CHECK(code == HIL_FAULT_UNDERVOLTAGE && seq == 160u && detail == 500L,
          "a 0.5 V bus is an under-voltage after 1 ms: cycle %u, code %d detail %ld", (unsigned)seq,
          code, (long)detail);

    /* the encoder's valid flag clears while the bus is fine: bridged, then reported */
    cmd(&s, HIL_CMD_CLEAR_FAULT, 4u, 0.0f);
    cmd(&s, HIL_CMD_RUN, 5u, 0.0f);
    code = -1;
    for (seq = 200u; seq < 300u && code < 0; seq++) {
        cap.n = 0;
        sense_aux(&s, seq, 0.0f, seq < 250u ? HIL_SENSE_AUX_FLAG_THETA_ENC_VALID : 0u);
        sense(&s, seq, 0.0f, 0.0f);
        code = last_fault(&cap, &detail);
    }
    CHECK(code == HIL_FAULT_SENSOR_FAULT && seq == 260u && detail / 10000000L == 4,
          "THETA_ENC_VALID cleared at 250: SENSOR_FAULT at %u (code %d, %ld)", (unsigned)seq, code,
          (long)detail);

    /* a new session forgets the bus reading: no SENSE_AUX again means the nominal bus */
    cap.n = 0;
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_OK, "SMO session");
    CHECK(s.have_v_dc == 0, "HELLO forgets the bus reading");
}

/* 6.3 and 6.2 */
static void test_cmd_seq_and_whole_parameters(void)
{
    static hil_session_t s;
    capture_t cap;
    hil_port_t port;
    memset(&cap, 0, sizeof cap);
    port.ctx = &cap;
    port.send = capture_send;
    hil_session_init(&s, &port);
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_OK, "session");
    cmd(&s, HIL_CMD_NOP, 1u, 0.0f);
    cmd(&s, HIL_CMD_NOP, 2u, 0.0f);
    CHECK(s.stats.cmd_seq_gaps == 0u, "1, 2: no gap");
    cmd(&s, HIL_CMD_SET_SPEED_REF, 4u, 12.0f);
    CHECK(s.stats.cmd_seq_gaps == 1u, "2 -> 4: one gap");
    CHECK(fabsf(s.ctrl.speed_ref_rad_s - 12.0f) < 1e-6f, "a CMD after a gap is still executed");
    CHECK(config(&s, &cap, HIL_PARAM_POLE_PAIRS, 4.5f) == HIL_CONFIG_STATUS_OUT_OF_RANGE, "4.5 pole pairs");
    CHECK(config(&s, &cap, HIL_PARAM_POLE_PAIRS, 4.0f) == HIL_CONFIG_STATUS_OK, "4 pole pairs");
    CHECK(config(&s, &cap, HIL_PARAM_HARM_COMP_ENABLE, 0.5f) == HIL_CONFIG_STATUS_OUT_OF_RANGE, "boolean 0.5");
    CHECK(config(&s, &cap, HIL_PARAM_HARM_COMP_ENABLE, 1.0f) == HIL_CONFIG_STATUS_OK, "boolean 1");
    CHECK(config(&s, &cap, HIL_PARAM_DELAY_COMP_ENABLE, 2.0f) == HIL_CONFIG_STATUS_OK, "enum 2");
    CHECK(config(&s, &cap, HIL_PARAM_DELAY_COMP_ENABLE, 1.25f) == HIL_CONFIG_STATUS_OUT_OF_RANGE, "enum 1.25");
    CHECK(config(&s, &cap, HIL_PARAM_SPEED_LOOP_DIV, 10.0f) == HIL_CONFIG_STATUS_OK, "integer 10");
    CHECK(config(&s, &cap, HIL_PARAM_RS_OHM, 0.123f) == HIL_CONFIG_STATUS_OK, "a real parameter takes fractions");
    CHECK(config(&s, &cap, HIL_PARAM_HFI_U_V, 3.0f) == HIL_CONFIG_STATUS_OK, "a parameter SMO does not use: OK");
    CHECK(config(&s, &cap, 999u, 1.0f) == HIL_CONFIG_STATUS_UNKNOWN_PARAM, "an id outside the table");
}

/* 6.3: CMD RESTART restarts the session and the controller as from power-up before the next frame
 * is read, in the portable code (a port running the firmware in the bench's own thread needs
 * nothing of its own): the SENSE right behind it is not answered, a HEARTBEAT_CTRL with counter 0
 * and state IDLE says so at once, `restarts` counts it, and a new HELLO starts over. */
static void test_cmd_restart_is_a_power_cycle_in_band(void)
{
    static hil_session_t s;
    capture_t cap;
    hil_port_t port;
    hil_heartbeat_ctrl_t hb;
    uint16_t seq;
    int k;
    memset(&cap, 0, sizeof cap);
    port.ctx = &cap;
    port.send = capture_send;
    hil_session_init(&s, &port);
    s.modes = (uint16_t)(1u << HIL_MODE_LOCKSTEP); /* a port's narrowing survives the restart */
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_OK, "session");
    configure_motor(&s, &cap);
    cmd(&s, HIL_CMD_SET_SPEED_REF, 1u, 50.0f);
    cmd(&s, HIL_CMD_RUN, 2u, 0.0f);
    for (seq = 0u; seq < 10u; seq++) {
        sense_aux(&s, seq, 0.0f, 0u);
        sense(&s, seq, 0.3f, 0.2f);
    }
    hil_session_heartbeat(&s, 0u);
    hil_session_heartbeat(&s, 0u);
    CHECK(s.stats.cycles == 10u && s.hb_counter == 2u && s.ctrl.state != CTRL_STATE_IDLE, "running");

    /* cycle 10's frames: CMD RESTART first, then SENSE_AUX and SENSE */
    cap.n = 0;
    cmd(&s, HIL_CMD_RESTART, 3u, 0.0f);
    sense_aux(&s, 10u, 0.0f, 0u);
    sense(&s, 10u, 0.3f, 0.2f);
    CHECK(s.restarts == 1u && !s.hello_done && s.ctrl.state == CTRL_STATE_IDLE, "restarted");
    CHECK(s.stats.cycles == 0u && s.stats.not_ready == 1u, "SENSE 10 not run (no session)");
    CHECK(cap.n == 1 && cap.id[0] == HIL_HEARTBEAT_CTRL_FRAME_ID, "only a heartbeat: %d frames", cap.n);
    k = find(&cap, HIL_HEARTBEAT_CTRL_FRAME_ID);
    CHECK(k >= 0 && hil_heartbeat_ctrl_unpack(&hb, cap.data[k >= 0 ? k : 0], 8u) == 0 &&
              hb.counter == 0u && hb.state == HIL_STATE_IDLE && hb.rx_errors == 0u,
          "HEARTBEAT_CTRL counter 0, IDLE, no errors");
    CHECK(s.modes == (uint16_t)(1u << HIL_MODE_LOCKSTEP), "the port's modes kept");
    CHECK(hello(&s, &cap, HIL_MODE_REALTIME, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_MODE_UNSUPPORTED,
          "still lockstep only");
    CHECK(hello(&s, &cap, HIL_MODE_LOCKSTEP, HIL_EST_SMO_SIGN, 0u) == HIL_HELLO_STATUS_OK, "a new session");
    CHECK(s.restarts == 1u, "a HELLO is not a restart");
}

/* 6.1, 10: HELLO_ACK.proto_minor is the lower of the host's and the controller's; a session of 1.0
 * knows only 1.0: no SMO_STA, UNKNOWN_PARAM to a 1.1 parameter, CMD RESTART ignored. */
static void hello_minor(hil_session_t *s, capture_t *cap, uint16_t minor, uint16_t estimator,
                        hil_hello_ack_t *ack)
{
    hil_hello_t h;
    hil_octet_t b[8];
    int k;
    h.proto_version = HIL_PROTO_VERSION;
    h.proto_minor = minor;
    h.mode = HIL_MODE_LOCKSTEP;
    h.period_us = hil_hello_period_us_encode(100.0f);
    h.estimator = estimator;
    h.flags = 0u;
    h.session = 0x1111u;
    hil_hello_pack(b, &h, sizeof b);
    deliver(s, HIL_HELLO_FRAME_ID, b, HIL_HELLO_LENGTH);
    k = find(cap, HIL_HELLO_ACK_FRAME_ID);
    memset(ack, 0, sizeof *ack);
    if (k >= 0) {
        hil_hello_ack_unpack(ack, cap->data[k], 8u);
    }
}

static void test_the_session_speaks_the_lower_minor_version(void)
{
    static hil_session_t s;
    capture_t cap;
    hil_port_t port;
    hil_hello_ack_t a;
    memset(&cap, 0, sizeof cap);
    port.ctx = &cap;
    port.send = capture_send;
    hil_session_init(&s, &port);
    CHECK(HIL_PROTO_VERSION_MINOR == 1u && s.proto_minor == 1u, "this firmware speaks 1.1");
    hello_minor(&s, &cap, 1u, HIL_EST_SMO_STA, &a);
    CHECK(a.status == HIL_HELLO_STATUS_OK && a.proto_minor == 1u && (a.estimators >> HIL_EST_SMO_STA) & 1u,
          "a 1.1 host: 1.1, SMO_STA offered");
    CHECK(config(&s, &cap, HIL_PARAM_LOOP_ANGLE, 1.0f) == HIL_CONFIG_STATUS_OK, "LOOP_ANGLE known in 1.1");
    hello_minor(&s, &cap, 0u, HIL_EST_SMO_STA, &a);
    CHECK(a.status == HIL_HELLO_STATUS_ESTIMATOR_UNSUPPORTED && a.proto_minor == 0u &&
              ((a.estimators >> HIL_EST_SMO_STA) & 1u) == 0u, "a 1.0 host: a 1.0 session, no SMO_STA");
    hello_minor(&s, &cap, 0u, HIL_EST_SMO_SIGN, &a);
    CHECK(a.status == HIL_HELLO_STATUS_OK && a.proto_minor == 0u, "1.0 session");
    CHECK(config(&s, &cap, HIL_PARAM_LOOP_ANGLE, 0.0f) == HIL_CONFIG_STATUS_UNKNOWN_PARAM,
          "a 1.1 parameter in a 1.0 session: UNKNOWN_PARAM");
    CHECK(config(&s, &cap, HIL_PARAM_INV_COMP_ENABLE, 0.0f) == HIL_CONFIG_STATUS_UNKNOWN_PARAM, "INV_COMP too");
    CHECK(config(&s, &cap, HIL_PARAM_RS_OHM, 0.5f) == HIL_CONFIG_STATUS_OK, "a 1.0 parameter: OK");
    cmd(&s, HIL_CMD_RESTART, 1u, 0.0f);
    CHECK(s.restarts == 0u && s.hello_done, "CMD RESTART is not a 1.0 command: ignored");
    /* a drive claiming 1.0 (the Linux stub's --proto 1.0) answers a 1.1 host as 1.0 */
    s.proto_minor = 0u;
    hello_minor(&s, &cap, 1u, HIL_EST_SMO_SIGN, &a);
    CHECK(a.status == HIL_HELLO_STATUS_OK && a.proto_minor == 0u, "a 1.0 drive answers 1.0 to a 1.1 host");
    cmd(&s, HIL_CMD_RESTART, 1u, 0.0f);
    CHECK(s.restarts == 0u, "and ignores RESTART");
    s.proto_minor = 1u;
    hello_minor(&s, &cap, 1u, HIL_EST_SMO_SIGN, &a);
    cmd(&s, HIL_CMD_RESTART, 1u, 0.0f);
    CHECK(s.restarts == 1u && s.proto_minor == 1u, "in 1.1 RESTART restarts, the version kept");
    /* the ranges are the DBC's: RS_OHM above 0 since 1.1 */
    CHECK(config(&s, &cap, HIL_PARAM_RS_OHM, 0.0f) == HIL_CONFIG_STATUS_OUT_OF_RANGE, "RS_OHM 0 refused");
    CHECK(ctrl_param_since_minor(HIL_PARAM_LOOP_ANGLE) == 1 && ctrl_param_since_minor(HIL_PARAM_RS_OHM) == 0 &&
              ctrl_param_since_minor(999u) == -1, "since minor from the DBC");
}

int main(void)
{
    test_retry_is_answered_from_the_cache();
    test_hello_statuses();
    test_a_port_narrows_the_periods();
    test_encoder_angle_rule();
    test_bus_and_encoder_reach_the_protection();
    test_cmd_seq_and_whole_parameters();
    test_cmd_restart_is_a_power_cycle_in_band();
    test_the_session_speaks_the_lower_minor_version();
    return check_summary("test_fw_session");
}
