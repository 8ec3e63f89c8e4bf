#include "hil_session.h"

#include "ctrl_params.h"

#define HIL_FW_VERSION 0x0100u

/* The controller's enums are the protocol's value tables: fail the build if they drift. */
typedef char check_state_fault[((int)CTRL_STATE_FAULT == (int)HIL_STATE_FAULT) ? 1 : -1];
typedef char check_state_closed[((int)CTRL_STATE_CLOSED_LOOP == (int)HIL_STATE_CLOSED_LOOP) ? 1 : -1];
typedef char check_state_stopped[((int)CTRL_STATE_STOPPED == (int)HIL_STATE_STOPPED) ? 1 : -1];
typedef char check_est_smo[((int)CTRL_EST_SMO_SIGN == (int)HIL_EST_SMO_SIGN) ? 1 : -1];
typedef char check_est_enc[((int)CTRL_EST_ENCODER == (int)HIL_EST_ENCODER) ? 1 : -1];
typedef char check_est_sta[((int)CTRL_EST_SMO_STA == (int)HIL_EST_SMO_STA) ? 1 : -1];
typedef char check_fault_oc[((int)CTRL_FAULT_OVERCURRENT == (int)HIL_FAULT_OVERCURRENT) ? 1 : -1];
typedef char check_fault_cfg[((int)CTRL_FAULT_CONFIG_INVALID == (int)HIL_FAULT_CONFIG_INVALID) ? 1 : -1];
typedef char check_fault_open[((int)CTRL_FAULT_OPEN_PHASE == (int)HIL_FAULT_OPEN_PHASE) ? 1 : -1];
typedef char check_fault_uv[((int)CTRL_FAULT_UNDERVOLTAGE == (int)HIL_FAULT_UNDERVOLTAGE) ? 1 : -1];
typedef char check_fault_sensor[((int)CTRL_FAULT_SENSOR_FAULT == (int)HIL_FAULT_SENSOR_FAULT) ? 1 : -1];
typedef char check_fault_ov[((int)CTRL_PROTECT_OVERVOLTAGE == (int)HIL_FAULT_OVERVOLTAGE) ? 1 : -1];
typedef char check_fault_link[((int)CTRL_PROTECT_LINK_TIMEOUT == (int)HIL_FAULT_LINK_TIMEOUT) ? 1 : -1];
typedef char check_fault_stall[((int)CTRL_FAULT_STALL == (int)HIL_FAULT_STALL) ? 1 : -1];

uint16_t hil_session_estimators(void)
{
    return hil_session_estimators_of_minor(HIL_PROTO_VERSION_MINOR);
}

/* What each minor version added to the value tables (docs/protocol.md section 10, the changelog;
 * protocol/versions.py records the tables of each version and tests/test_protocol_versions.py checks
 * a stub that claims 1.0 against them) */
#define HIL_EST_SMO_STA_SINCE_MINOR 1u
#define HIL_CMD_RESTART_SINCE_MINOR 1u

uint16_t hil_session_estimators_of_minor(uint16_t minor)
{
    uint16_t mask = (uint16_t)((1u << HIL_EST_SMO_SIGN) | (1u << HIL_EST_SMO_SIGMOID) |
                               (1u << HIL_EST_SMO_TANH) | (1u << HIL_EST_HFI_SDFT) |
                               (1u << HIL_EST_ENCODER));
    if (minor >= HIL_EST_SMO_STA_SINCE_MINOR) {
        mask = (uint16_t)(mask | (1u << HIL_EST_SMO_STA));
    }
    return mask;
}

void hil_session_init(hil_session_t *s, const hil_port_t *port)
{
    s->port = *port;
    ctrl_init(&s->ctrl);
    s->hello_done = 0;
    s->session_id = 0u;
    s->flags = 0u;
    s->mode = 0u;
    s->modes = HIL_SESSION_MODES_DEFAULT;
    s->proto_minor = (uint16_t)HIL_PROTO_VERSION_MINOR;
    s->session_minor = (uint16_t)HIL_PROTO_VERSION_MINOR;
    s->period_min_us = HIL_SESSION_PERIOD_MIN_US;
    s->period_max_us = HIL_SESSION_PERIOD_MAX_US;
    s->aux_seq = 0u;
    s->aux_valid = 0;
    s->aux_flags = 0u;
    s->aux_theta_raw = 0u;
    s->v_dc_v = 0.0f;
    s->have_v_dc = 0;
    s->theta_enc_rad = 0.0f;
    s->dual_seq = 0u;
    s->dual_valid = 0;
    s->i2_abc_a[0] = s->i2_abc_a[1] = s->i2_abc_a[2] = 0.0f;
    s->last_seq = 0u;
    s->have_seq = 0;
    s->cache_n = 0u;
    s->last_cmd_seq = 0u;
    s->have_cmd_seq = 0;
    s->hb_counter = 0u;
    s->stats.frames_rx = 0u;
    s->stats.cycles = 0u;
    s->stats.unknown_ids = 0u;
    s->stats.length_errors = 0u;
    s->stats.seq_errors = 0u;
    s->stats.config_rejected = 0u;
    s->stats.not_ready = 0u;
    s->stats.repeats = 0u;
    s->stats.cmd_seq_gaps = 0u;
    s->restarts = 0u;
}

void hil_session_restart(hil_session_t *s)
{
    const hil_port_t port = s->port;
    const uint16_t modes = s->modes;
    const uint16_t minor = s->proto_minor;
    const float period_min_us = s->period_min_us, period_max_us = s->period_max_us;
    const uint32_t restarts = s->restarts + 1u;
    hil_session_init(s, &port);
    s->modes = modes;
    s->proto_minor = minor;
    s->session_minor = minor;
    s->period_min_us = period_min_us;
    s->period_max_us = period_max_us;
    s->restarts = restarts;
    hil_session_heartbeat(s, 0u);
}

static void send_fault(hil_session_t *s, uint16_t code, uint16_t seq, int32_t detail)
{
    hil_octet_t buf[HIL_FAULT_CTRL_LENGTH];
    hil_fault_ctrl_t m;
    m.code = code;
    m.seq = seq;
    m.detail = detail;
    if (hil_fault_ctrl_pack(buf, &m, sizeof buf) > 0) {
        s->port.send(s->port.ctx, HIL_FAULT_CTRL_FRAME_ID, buf, HIL_FAULT_CTRL_LENGTH);
    }
}

static void on_hello(hil_session_t *s, const hil_octet_t *data, uint16_t dlc)
{
    hil_hello_t h;
    hil_hello_ack_t a;
    hil_octet_t buf[HIL_HELLO_ACK_LENGTH];
    float period_us;
    uint16_t minor, estimators;
    if (hil_hello_unpack(&h, data, dlc) != 0) {
        s->stats.length_errors++;
        return;
    }
    period_us = hil_hello_period_us_decode(h.period_us);
    /* the session speaks the lower of the two minor versions (a 1.0 host sends 0 there) */
    minor = h.proto_minor < s->proto_minor ? h.proto_minor : s->proto_minor;
    estimators = hil_session_estimators_of_minor(minor);
    a.proto_version = (uint16_t)HIL_PROTO_VERSION;
    a.proto_minor = minor;
    a.fw_version = HIL_FW_VERSION;
    a.estimators = estimators;
    a.session = h.session;
    a.status = HIL_HELLO_STATUS_OK;
    /* checked in the order of docs/protocol.md 6.1 */
    if (h.proto_version != HIL_PROTO_VERSION) {
        a.status = HIL_HELLO_STATUS_VERSION_MISMATCH;
    } else if (h.mode >= 16u || (((unsigned)s->modes >> (unsigned)h.mode) & 1u) == 0u) {
        a.status = HIL_HELLO_STATUS_MODE_UNSUPPORTED;
    } else if (h.estimator >= 16u || (((unsigned)estimators >> (unsigned)h.estimator) & 1u) == 0u) {
        a.status = HIL_HELLO_STATUS_ESTIMATOR_UNSUPPORTED;
    } else if (h.estimator == HIL_EST_ENCODER && (h.flags & HIL_HELLO_FLAG_ENCODER_VALID) == 0u) {
        a.status = HIL_HELLO_STATUS_ESTIMATOR_UNSUPPORTED; /* no angle will come (6.8) */
    } else if (!(period_us >= s->period_min_us && period_us <= s->period_max_us)) {
        a.status = HIL_HELLO_STATUS_PERIOD_UNSUPPORTED;
    }
    if (a.status == HIL_HELLO_STATUS_OK) {
        /* a new session starts from a clean controller with default configuration */
        ctrl_init(&s->ctrl);
        s->ctrl.cfg.ts_s = period_us * 1.0e-6f;
        s->ctrl.cfg.estimator = (float)h.estimator;
        s->hello_done = 1;
        s->session_id = h.session;
        s->flags = h.flags;
        s->mode = h.mode;
        s->session_minor = minor;
        s->have_seq = 0;
        s->cache_n = 0u;
        s->aux_valid = 0;
        s->v_dc_v = 0.0f;
        s->have_v_dc = 0;
        s->theta_enc_rad = 0.0f;
        s->have_cmd_seq = 0;
    }
    if (hil_hello_ack_pack(buf, &a, sizeof buf) > 0) {
        s->port.send(s->port.ctx, HIL_HELLO_ACK_FRAME_ID, buf, HIL_HELLO_ACK_LENGTH);
    }
}

static int controller_idle(const hil_session_t *s)
{
    ctrl_state_t st = s->ctrl.state;
    return st == CTRL_STATE_IDLE || st == CTRL_STATE_STOPPED || st == CTRL_STATE_FAULT;
}

static void on_config(hil_session_t *s, const hil_octet_t *data, uint16_t dlc)
{
    hil_config_t c;
    hil_config_ack_t a;
    hil_octet_t buf[HIL_CONFIG_ACK_LENGTH];
    if (hil_config_unpack(&c, data, dlc) != 0) {
        s->stats.length_errors++;
        return;
    }
    a.param_id = c.param_id;
    a.config_seq = c.config_seq;
    if (ctrl_param_since_minor(c.param_id) > (int)s->session_minor) {
        a.status = HIL_CONFIG_STATUS_UNKNOWN_PARAM; /* added after the version of this session */
    } else if (!controller_idle(s)) {
        a.status = HIL_CONFIG_STATUS_LOCKED;
    } else {
        a.status = (uint16_t)ctrl_param_set(&s->ctrl.cfg, c.param_id, c.value);
    }
    if (a.status != HIL_CONFIG_STATUS_OK) {
        s->stats.config_rejected++;
    }
    if (hil_config_ack_pack(buf, &a, sizeof buf) > 0) {
        s->port.send(s->port.ctx, HIL_CONFIG_ACK_FRAME_ID, buf, HIL_CONFIG_ACK_LENGTH);
    }
}

static void on_cmd(hil_session_t *s, const hil_octet_t *data, uint16_t dlc)
{
    hil_cmd_t c;
    if (hil_cmd_unpack(&c, data, dlc) != 0) {
        s->stats.length_errors++;
        return;
    }
    /* executed whatever its seq; a gap means a CMD was lost (6.3) */
    if (s->have_cmd_seq && c.seq != (uint16_t)(s->last_cmd_seq + 1u)) {
        s->stats.cmd_seq_gaps++;
    }
    s->have_cmd_seq = 1;
    s->last_cmd_seq = c.seq;
    switch (c.command) {
    case HIL_CMD_RUN:
        /* a fault stands until CLEAR_FAULT: RUN does not restart from it (6.3) */
        if (s->ctrl.state != CTRL_STATE_FAULT && ctrl_start(&s->ctrl) != 0) {
            send_fault(s, HIL_FAULT_CONFIG_INVALID, c.seq, 0);
        }
        break;
    case HIL_CMD_STOP:
        ctrl_stop(&s->ctrl);
        break;
    case HIL_CMD_CLEAR_FAULT:
        ctrl_clear_fault(&s->ctrl);
        break;
    case HIL_CMD_SET_SPEED_REF:
        ctrl_set_speed_ref(&s->ctrl, c.value);
        break;
    case HIL_CMD_SET_IQ_REF:
        ctrl_set_current_ref(&s->ctrl, s->ctrl.id_cmd_a, c.value);
        break;
    case HIL_CMD_SET_ID_REF:
        ctrl_set_current_ref(&s->ctrl, c.value, s->ctrl.iq_cmd_a);
        break;
    case HIL_CMD_SET_CONTROL_MODE:
        ctrl_set_mode(&s->ctrl, c.value > 0.5f ? CTRL_MODE_CURRENT : CTRL_MODE_SPEED);
        break;
    case HIL_CMD_RESTART:
        if (s->session_minor >= HIL_CMD_RESTART_SINCE_MINOR) {
            hil_session_restart(s);
        }
        break;
    default:
        break;
    }
}

static void on_sense_aux(hil_session_t *s, const hil_octet_t *data, uint16_t dlc)
{
    hil_sense_aux_t m;
    if (hil_sense_aux_unpack(&m, data, dlc) != 0) {
        s->stats.length_errors++;
        return;
    }
    s->aux_seq = m.seq;
    s->aux_valid = 1;
    s->aux_flags = m.flags;
    s->aux_theta_raw = m.theta_enc;
    s->v_dc_v = hil_sense_aux_v_dc_decode(m.v_dc);
    s->have_v_dc = 1;
}

static void on_sense_dual(hil_session_t *s, const hil_octet_t *data, uint16_t dlc)
{
    hil_sense_dual_t m;
    if (hil_sense_dual_unpack(&m, data, dlc) != 0) {
        s->stats.length_errors++;
        return;
    }
    s->dual_seq = m.seq;
    s->dual_valid = 1;
    s->i2_abc_a[0] = hil_sense_dual_i_a2_decode(m.i_a2);
    s->i2_abc_a[1] = hil_sense_dual_i_b2_decode(m.i_b2);
    s->i2_abc_a[2] = hil_sense_dual_i_c2_decode(m.i_c2);
}

static uint16_t duty_raw(float d)
{
    if (d < 0.0f) {
        return (uint16_t)HIL_DUTY_RAW_OFF;
    }
    return hil_duty_d_a_encode(d);
}

/* Send one frame of the answer to SENSE last_seq and keep it in the cache. */
static void answer(hil_session_t *s, uint16_t id, const hil_octet_t *buf, uint16_t dlc)
{
    if (s->cache_n < HIL_SESSION_CACHE_FRAMES && dlc <= 8u) {
        hil_cached_frame_t *c = &s->cache[s->cache_n++];
        uint16_t i;
        c->id = id;
        c->dlc = dlc;
        for (i = 0u; i < dlc; i++) {
            c->data[i] = buf[i];
        }
    }
    s->port.send(s->port.ctx, id, buf, dlc);
}

static void on_sense(hil_session_t *s, const hil_octet_t *data, uint16_t dlc)
{
    hil_sense_t m;
    ctrl_sample_t smp;
    const ctrl_output_t *o;
    ctrl_fault_t fault_before;
    hil_octet_t buf[8];
    uint16_t k;
    if (hil_sense_unpack(&m, data, dlc) != 0) {
        s->stats.length_errors++;
        return;
    }
    if (!s->hello_done) {
        s->stats.not_ready++;
        return;
    }
    if (s->have_seq && m.seq == s->last_seq) {
        /* a retry of the last cycle (6.5): the same answer, the ISR does not run again */
        s->stats.repeats++;
        for (k = 0u; k < s->cache_n; k++) {
            s->port.send(s->port.ctx, s->cache[k].id, s->cache[k].data, s->cache[k].dlc);
        }
        return;
    }
    if (s->have_seq && m.seq != (uint16_t)(s->last_seq + 1u)) {
        s->stats.seq_errors++;
    }
    s->have_seq = 1;
    s->last_seq = m.seq;
    s->cache_n = 0u;
    s->stats.cycles++;

    /* the encoder angle counts only if this cycle's SENSE_AUX says it is valid (6.8); otherwise
     * the controller is told there is no reading (it bridges the gap and times it: an encoder
     * that stays invalid is reported, ctrl_protect.h) */
    smp.theta_enc_valid = (s->flags & HIL_HELLO_FLAG_ENCODER_VALID) != 0u && s->aux_valid &&
                          s->aux_seq == m.seq &&
                          (s->aux_flags & HIL_SENSE_AUX_FLAG_THETA_ENC_VALID) != 0u;
    if (smp.theta_enc_valid) {
        s->theta_enc_rad = hil_sense_aux_theta_enc_decode(s->aux_theta_raw);
    }
    smp.i_a_a = hil_sense_i_a_decode(m.i_a);
    smp.i_b_a = hil_sense_i_b_decode(m.i_b);
    smp.i_c_a = hil_sense_i_c_decode(m.i_c);
    smp.v_dc_v = s->v_dc_v; /* latest SENSE_AUX; the nominal bus is used until one arrives */
    smp.v_dc_valid = s->have_v_dc;
    smp.theta_enc_rad = s->theta_enc_rad;
    /* the second sample only counts if it was sent for this very cycle */
    smp.have_i2 = s->dual_valid && s->dual_seq == m.seq;
    smp.i2_abc_a[0] = s->i2_abc_a[0];
    smp.i2_abc_a[1] = s->i2_abc_a[1];
    smp.i2_abc_a[2] = s->i2_abc_a[2];

    fault_before = s->ctrl.fault;
    o = ctrl_step(&s->ctrl, &smp);
    if (o->fault != CTRL_FAULT_NONE && fault_before == CTRL_FAULT_NONE) {
        send_fault(s, (uint16_t)o->fault, m.seq, (int32_t)o->fault_detail);
    }

    {
        hil_telem_t t;
        t.seq = m.seq;
        t.theta_hat = hil_telem_theta_hat_encode(o->theta_hat_rad);
        t.omega_hat = hil_telem_omega_hat_encode(o->omega_hat_rad_s);
        t.state = (uint16_t)o->state;
        t.estimator = (uint16_t)s->ctrl.cfg.estimator;
        if (hil_telem_pack(buf, &t, sizeof buf) > 0) {
            answer(s, HIL_TELEM_FRAME_ID, buf, HIL_TELEM_LENGTH);
        }
    }
    if (s->flags & HIL_HELLO_FLAG_TELEM_EMF) {
        hil_telem_emf_t e;
        e.seq = m.seq;
        e.e_alpha = hil_telem_emf_e_alpha_encode(o->e_alpha_v);
        e.e_beta = hil_telem_emf_e_beta_encode(o->e_beta_v);
        e.i_q_ref = hil_telem_emf_i_q_ref_encode(o->i_q_ref_a);
        if (hil_telem_emf_pack(buf, &e, sizeof buf) > 0) {
            answer(s, HIL_TELEM_EMF_FRAME_ID, buf, HIL_TELEM_EMF_LENGTH);
        }
    }
    {
        hil_duty_t d;
        d.seq = m.seq;
        d.d_a = duty_raw(o->duty_abc[0]);
        d.d_b = duty_raw(o->duty_abc[1]);
        d.d_c = duty_raw(o->duty_abc[2]);
        if (hil_duty_pack(buf, &d, sizeof buf) > 0) {
            answer(s, HIL_DUTY_FRAME_ID, buf, HIL_DUTY_LENGTH);
        }
    }
}

void hil_session_on_frame(hil_session_t *s, const hil_frame_t *f)
{
    s->stats.frames_rx++;
    switch (f->id) {
    case HIL_SENSE_FRAME_ID:
        on_sense(s, f->data, f->dlc);
        break;
    case HIL_SENSE_AUX_FRAME_ID:
        on_sense_aux(s, f->data, f->dlc);
        break;
    case HIL_SENSE_DUAL_FRAME_ID:
        on_sense_dual(s, f->data, f->dlc);
        break;
    case HIL_HELLO_FRAME_ID:
        on_hello(s, f->data, f->dlc);
        break;
    case HIL_CONFIG_FRAME_ID:
        on_config(s, f->data, f->dlc);
        break;
    case HIL_CMD_FRAME_ID:
        on_cmd(s, f->data, f->dlc);
        break;
    case HIL_HEARTBEAT_PLANT_FRAME_ID:
        break;
    case HIL_FAULT_PLANT_FRAME_ID:
        /* the host ended the run: stop as on CMD STOP (state STOPPED, all legs OFF; a FAULT stays);
         * SENSE is still answered and the heartbeat goes on while no cycles flow (6.7) */
        ctrl_stop(&s->ctrl);
        break;
    default:
        s->stats.unknown_ids++;
        break;
    }
}

void hil_session_heartbeat(hil_session_t *s, uint32_t link_rx_errors)
{
    hil_heartbeat_ctrl_t h;
    hil_octet_t buf[HIL_HEARTBEAT_CTRL_LENGTH];
    uint32_t errors = link_rx_errors + s->stats.unknown_ids + s->stats.length_errors;
    h.counter = s->hb_counter++;
    h.state = (uint16_t)s->ctrl.state;
    h.rx_errors = (uint16_t)(errors > 0xFFFFu ? 0xFFFFu : errors);
    h.rx_frames = (uint16_t)(s->stats.frames_rx & 0xFFFFu);
    if (hil_heartbeat_ctrl_pack(buf, &h, sizeof buf) > 0) {
        s->port.send(s->port.ctx, HIL_HEARTBEAT_CTRL_FRAME_ID, buf, HIL_HEARTBEAT_CTRL_LENGTH);
    }
}
