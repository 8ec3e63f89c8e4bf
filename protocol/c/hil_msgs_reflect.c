/* GENERATED FROM hil.dbc BY protocol/gen_c.py -- DO NOT EDIT.
 * Regenerate with `python protocol/gen_c.py`; `--check` verifies the committed copy. */

#include "hil_msgs_reflect.h"

#include <string.h>

static const hil_signal_info_t hil_fault_plant_signals[] = {
    {"code", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"seq", HIL_SIG_UNSIGNED, 16u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"detail", HIL_SIG_SIGNED, 32u, 32u, 1.0, 0.0, -2147483648.0, 2147483647.0, -2147483648.0, 2147483647.0, -2147483648.0, 2147483647.0, 0},
};
static const hil_signal_info_t hil_fault_ctrl_signals[] = {
    {"code", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"seq", HIL_SIG_UNSIGNED, 16u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"detail", HIL_SIG_SIGNED, 32u, 32u, 1.0, 0.0, -2147483648.0, 2147483647.0, -2147483648.0, 2147483647.0, -2147483648.0, 2147483647.0, 0},
};
static const hil_signal_info_t hil_hello_signals[] = {
    {"proto_version", HIL_SIG_UNSIGNED, 0u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
    {"mode", HIL_SIG_UNSIGNED, 8u, 8u, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 255.0, 0},
    {"period_us", HIL_SIG_UNSIGNED, 16u, 16u, 0.1, 0.0, 0.0, 6553.5, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"estimator", HIL_SIG_UNSIGNED, 32u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
    {"flags", HIL_SIG_UNSIGNED, 40u, 4u, 1.0, 0.0, 0.0, 15.0, 0.0, 15.0, 0.0, 15.0, 0},
    {"proto_minor", HIL_SIG_UNSIGNED, 44u, 4u, 1.0, 0.0, 0.0, 15.0, 0.0, 15.0, 0.0, 15.0, 0},
    {"session", HIL_SIG_UNSIGNED, 48u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
};
static const hil_signal_info_t hil_hello_ack_signals[] = {
    {"proto_version", HIL_SIG_UNSIGNED, 0u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
    {"status", HIL_SIG_UNSIGNED, 8u, 4u, 1.0, 0.0, 0.0, 15.0, 0.0, 15.0, 0.0, 15.0, 0},
    {"proto_minor", HIL_SIG_UNSIGNED, 12u, 4u, 1.0, 0.0, 0.0, 15.0, 0.0, 15.0, 0.0, 15.0, 0},
    {"fw_version", HIL_SIG_UNSIGNED, 16u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"estimators", HIL_SIG_UNSIGNED, 32u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"session", HIL_SIG_UNSIGNED, 48u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
};
static const hil_signal_info_t hil_config_signals[] = {
    {"param_id", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"config_seq", HIL_SIG_UNSIGNED, 16u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"value", HIL_SIG_FLOAT, 32u, 32u, 1.0, 0.0, -3.4e+38, 3.4e+38, -3.4e+38, 3.4e+38, -3.4028234663852886e+38, 3.4028234663852886e+38, 0},
};
static const hil_signal_info_t hil_config_ack_signals[] = {
    {"param_id", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"config_seq", HIL_SIG_UNSIGNED, 16u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"status", HIL_SIG_UNSIGNED, 32u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
};
static const hil_signal_info_t hil_cmd_signals[] = {
    {"command", HIL_SIG_UNSIGNED, 0u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
    {"seq", HIL_SIG_UNSIGNED, 16u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"value", HIL_SIG_FLOAT, 32u, 32u, 1.0, 0.0, -3.4e+38, 3.4e+38, -3.4e+38, 3.4e+38, -3.4028234663852886e+38, 3.4028234663852886e+38, 0},
};
static const hil_signal_info_t hil_heartbeat_plant_signals[] = {
    {"counter", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"state", HIL_SIG_UNSIGNED, 16u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
    {"rx_errors", HIL_SIG_UNSIGNED, 32u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"rx_frames", HIL_SIG_UNSIGNED, 48u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
};
static const hil_signal_info_t hil_heartbeat_ctrl_signals[] = {
    {"counter", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"state", HIL_SIG_UNSIGNED, 16u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
    {"rx_errors", HIL_SIG_UNSIGNED, 32u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"rx_frames", HIL_SIG_UNSIGNED, 48u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
};
static const hil_signal_info_t hil_sense_signals[] = {
    {"seq", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"i_a", HIL_SIG_SIGNED, 16u, 16u, 0.001, 0.0, -32.768, 32.767, -32768.0, 32767.0, -32768.0, 32767.0, 0},
    {"i_b", HIL_SIG_SIGNED, 32u, 16u, 0.001, 0.0, -32.768, 32.767, -32768.0, 32767.0, -32768.0, 32767.0, 0},
    {"i_c", HIL_SIG_SIGNED, 48u, 16u, 0.001, 0.0, -32.768, 32.767, -32768.0, 32767.0, -32768.0, 32767.0, 0},
};
static const hil_signal_info_t hil_sense_aux_signals[] = {
    {"seq", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"v_dc", HIL_SIG_UNSIGNED, 16u, 16u, 0.01, 0.0, 0.0, 655.35, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"theta_enc", HIL_SIG_UNSIGNED, 32u, 16u, 9.587379924285257e-05, 0.0, 0.0, 6.2830894333803435, 0.0, 65535.0, 0.0, 65535.0, 1},
    {"flags", HIL_SIG_UNSIGNED, 48u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
};
static const hil_signal_info_t hil_sense_dual_signals[] = {
    {"seq", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"i_a2", HIL_SIG_SIGNED, 16u, 16u, 0.001, 0.0, -32.768, 32.767, -32768.0, 32767.0, -32768.0, 32767.0, 0},
    {"i_b2", HIL_SIG_SIGNED, 32u, 16u, 0.001, 0.0, -32.768, 32.767, -32768.0, 32767.0, -32768.0, 32767.0, 0},
    {"i_c2", HIL_SIG_SIGNED, 48u, 16u, 0.001, 0.0, -32.768, 32.767, -32768.0, 32767.0, -32768.0, 32767.0, 0},
};
static const hil_signal_info_t hil_duty_signals[] = {
    {"seq", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"d_a", HIL_SIG_UNSIGNED, 16u, 16u, 3.0517578125e-05, 0.0, 0.0, 1.0, 0.0, 32768.0, 0.0, 65535.0, 0},
    {"d_b", HIL_SIG_UNSIGNED, 32u, 16u, 3.0517578125e-05, 0.0, 0.0, 1.0, 0.0, 32768.0, 0.0, 65535.0, 0},
    {"d_c", HIL_SIG_UNSIGNED, 48u, 16u, 3.0517578125e-05, 0.0, 0.0, 1.0, 0.0, 32768.0, 0.0, 65535.0, 0},
};
static const hil_signal_info_t hil_telem_signals[] = {
    {"seq", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"theta_hat", HIL_SIG_UNSIGNED, 16u, 16u, 9.587379924285257e-05, 0.0, 0.0, 6.2830894333803435, 0.0, 65535.0, 0.0, 65535.0, 1},
    {"omega_hat", HIL_SIG_SIGNED, 32u, 16u, 0.1, 0.0, -3276.8, 3276.7, -32768.0, 32767.0, -32768.0, 32767.0, 0},
    {"state", HIL_SIG_UNSIGNED, 48u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
    {"estimator", HIL_SIG_UNSIGNED, 56u, 8u, 1.0, 0.0, 0.0, 255.0, 0.0, 255.0, 0.0, 255.0, 0},
};
static const hil_signal_info_t hil_telem_emf_signals[] = {
    {"seq", HIL_SIG_UNSIGNED, 0u, 16u, 1.0, 0.0, 0.0, 65535.0, 0.0, 65535.0, 0.0, 65535.0, 0},
    {"e_alpha", HIL_SIG_SIGNED, 16u, 16u, 0.01, 0.0, -327.68, 327.67, -32768.0, 32767.0, -32768.0, 32767.0, 0},
    {"e_beta", HIL_SIG_SIGNED, 32u, 16u, 0.01, 0.0, -327.68, 327.67, -32768.0, 32767.0, -32768.0, 32767.0, 0},
    {"i_q_ref", HIL_SIG_SIGNED, 48u, 16u, 0.001, 0.0, -32.768, 32.767, -32768.0, 32767.0, -32768.0, 32767.0, 0},
};

const hil_message_info_t hil_messages[] = {
    {"FAULT_PLANT", 0x010u, 8u, 3u, hil_fault_plant_signals},
    {"FAULT_CTRL", 0x011u, 8u, 3u, hil_fault_ctrl_signals},
    {"HELLO", 0x020u, 8u, 7u, hil_hello_signals},
    {"HELLO_ACK", 0x021u, 8u, 6u, hil_hello_ack_signals},
    {"CONFIG", 0x030u, 8u, 3u, hil_config_signals},
    {"CONFIG_ACK", 0x031u, 8u, 3u, hil_config_ack_signals},
    {"CMD", 0x040u, 8u, 3u, hil_cmd_signals},
    {"HEARTBEAT_PLANT", 0x050u, 8u, 4u, hil_heartbeat_plant_signals},
    {"HEARTBEAT_CTRL", 0x051u, 8u, 4u, hil_heartbeat_ctrl_signals},
    {"SENSE", 0x100u, 8u, 4u, hil_sense_signals},
    {"SENSE_AUX", 0x101u, 8u, 4u, hil_sense_aux_signals},
    {"SENSE_DUAL", 0x102u, 8u, 4u, hil_sense_dual_signals},
    {"DUTY", 0x180u, 8u, 4u, hil_duty_signals},
    {"TELEM", 0x181u, 8u, 5u, hil_telem_signals},
    {"TELEM_EMF", 0x182u, 8u, 4u, hil_telem_emf_signals},
};

const size_t hil_message_count = sizeof hil_messages / sizeof hil_messages[0];

const hil_message_info_t *hil_message_by_name(const char *name)
{
    size_t i;
    for (i = 0u; i < hil_message_count; i++) {
        if (strcmp(hil_messages[i].name, name) == 0) {
            return &hil_messages[i];
        }
    }
    return NULL;
}

const hil_message_info_t *hil_message_by_id(uint16_t frame_id)
{
    size_t i;
    for (i = 0u; i < hil_message_count; i++) {
        if (hil_messages[i].frame_id == frame_id) {
            return &hil_messages[i];
        }
    }
    return NULL;
}

int hil_signal_index(const hil_message_info_t *msg, const char *name)
{
    uint16_t i;
    for (i = 0u; i < msg->n_signals; i++) {
        if (strcmp(msg->signals[i].name, name) == 0) {
            return (int)i;
        }
    }
    return -1;
}

static int hil_raw_ok(const hil_signal_info_t *s, double raw)
{
    double frac;
    if (s->kind == HIL_SIG_FLOAT) {
        return 1; /* any double converts; the range check is the codec's job */
    }
    if (!(raw >= s->type_min && raw <= s->type_max)) {
        return 0;
    }
    frac = raw - (double)(int64_t)raw;
    return (frac <= 0.0 && frac >= 0.0) ? 1 : 0; /* an integer (no == on doubles: -Wfloat-equal) */
}

static int hil_raws_ok(const hil_message_info_t *msg, const double *raw)
{
    uint16_t i;
    for (i = 0u; i < msg->n_signals; i++) {
        if (!hil_raw_ok(&msg->signals[i], raw[i])) {
            return 0;
        }
    }
    return 1;
}

int hil_reflect_pack(const hil_message_info_t *msg, const double *raw, hil_octet_t *dst, size_t size)
{
    if (msg == NULL || raw == NULL || !hil_raws_ok(msg, raw)) {
        return -1;
    }
    switch (msg->frame_id) {
    case HIL_FAULT_PLANT_FRAME_ID: {
        hil_fault_plant_t m;
        m.code = (uint16_t)raw[0];
        m.seq = (uint16_t)raw[1];
        m.detail = (int32_t)raw[2];
        return hil_fault_plant_pack(dst, &m, size);
    }
    case HIL_FAULT_CTRL_FRAME_ID: {
        hil_fault_ctrl_t m;
        m.code = (uint16_t)raw[0];
        m.seq = (uint16_t)raw[1];
        m.detail = (int32_t)raw[2];
        return hil_fault_ctrl_pack(dst, &m, size);
    }
    case HIL_HELLO_FRAME_ID: {
        hil_hello_t m;
        m.proto_version = (uint16_t)raw[0];
        m.mode = (uint16_t)raw[1];
        m.period_us = (uint16_t)raw[2];
        m.estimator = (uint16_t)raw[3];
        m.flags = (uint16_t)raw[4];
        m.proto_minor = (uint16_t)raw[5];
        m.session = (uint16_t)raw[6];
        return hil_hello_pack(dst, &m, size);
    }
    case HIL_HELLO_ACK_FRAME_ID: {
        hil_hello_ack_t m;
        m.proto_version = (uint16_t)raw[0];
        m.status = (uint16_t)raw[1];
        m.proto_minor = (uint16_t)raw[2];
        m.fw_version = (uint16_t)raw[3];
        m.estimators = (uint16_t)raw[4];
        m.session = (uint16_t)raw[5];
        return hil_hello_ack_pack(dst, &m, size);
    }
    case HIL_CONFIG_FRAME_ID: {
        hil_config_t m;
        m.param_id = (uint16_t)raw[0];
        m.config_seq = (uint16_t)raw[1];
        m.value = (float)raw[2];
        return hil_config_pack(dst, &m, size);
    }
    case HIL_CONFIG_ACK_FRAME_ID: {
        hil_config_ack_t m;
        m.param_id = (uint16_t)raw[0];
        m.config_seq = (uint16_t)raw[1];
        m.status = (uint16_t)raw[2];
        return hil_config_ack_pack(dst, &m, size);
    }
    case HIL_CMD_FRAME_ID: {
        hil_cmd_t m;
        m.command = (uint16_t)raw[0];
        m.seq = (uint16_t)raw[1];
        m.value = (float)raw[2];
        return hil_cmd_pack(dst, &m, size);
    }
    case HIL_HEARTBEAT_PLANT_FRAME_ID: {
        hil_heartbeat_plant_t m;
        m.counter = (uint16_t)raw[0];
        m.state = (uint16_t)raw[1];
        m.rx_errors = (uint16_t)raw[2];
        m.rx_frames = (uint16_t)raw[3];
        return hil_heartbeat_plant_pack(dst, &m, size);
    }
    case HIL_HEARTBEAT_CTRL_FRAME_ID: {
        hil_heartbeat_ctrl_t m;
        m.counter = (uint16_t)raw[0];
        m.state = (uint16_t)raw[1];
        m.rx_errors = (uint16_t)raw[2];
        m.rx_frames = (uint16_t)raw[3];
        return hil_heartbeat_ctrl_pack(dst, &m, size);
    }
    case HIL_SENSE_FRAME_ID: {
        hil_sense_t m;
        m.seq = (uint16_t)raw[0];
        m.i_a = (int16_t)raw[1];
        m.i_b = (int16_t)raw[2];
        m.i_c = (int16_t)raw[3];
        return hil_sense_pack(dst, &m, size);
    }
    case HIL_SENSE_AUX_FRAME_ID: {
        hil_sense_aux_t m;
        m.seq = (uint16_t)raw[0];
        m.v_dc = (uint16_t)raw[1];
        m.theta_enc = (uint16_t)raw[2];
        m.flags = (uint16_t)raw[3];
        return hil_sense_aux_pack(dst, &m, size);
    }
    case HIL_SENSE_DUAL_FRAME_ID: {
        hil_sense_dual_t m;
        m.seq = (uint16_t)raw[0];
        m.i_a2 = (int16_t)raw[1];
        m.i_b2 = (int16_t)raw[2];
        m.i_c2 = (int16_t)raw[3];
        return hil_sense_dual_pack(dst, &m, size);
    }
    case HIL_DUTY_FRAME_ID: {
        hil_duty_t m;
        m.seq = (uint16_t)raw[0];
        m.d_a = (uint16_t)raw[1];
        m.d_b = (uint16_t)raw[2];
        m.d_c = (uint16_t)raw[3];
        return hil_duty_pack(dst, &m, size);
    }
    case HIL_TELEM_FRAME_ID: {
        hil_telem_t m;
        m.seq = (uint16_t)raw[0];
        m.theta_hat = (uint16_t)raw[1];
        m.omega_hat = (int16_t)raw[2];
        m.state = (uint16_t)raw[3];
        m.estimator = (uint16_t)raw[4];
        return hil_telem_pack(dst, &m, size);
    }
    case HIL_TELEM_EMF_FRAME_ID: {
        hil_telem_emf_t m;
        m.seq = (uint16_t)raw[0];
        m.e_alpha = (int16_t)raw[1];
        m.e_beta = (int16_t)raw[2];
        m.i_q_ref = (int16_t)raw[3];
        return hil_telem_emf_pack(dst, &m, size);
    }
    default:
        return -1;
    }
}

int hil_reflect_unpack(const hil_message_info_t *msg, double *raw, const hil_octet_t *src, size_t size)
{
    if (msg == NULL || raw == NULL) {
        return -1;
    }
    switch (msg->frame_id) {
    case HIL_FAULT_PLANT_FRAME_ID: {
        hil_fault_plant_t m;
        if (hil_fault_plant_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.code;
        raw[1] = (double)m.seq;
        raw[2] = (double)m.detail;
        return 0;
    }
    case HIL_FAULT_CTRL_FRAME_ID: {
        hil_fault_ctrl_t m;
        if (hil_fault_ctrl_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.code;
        raw[1] = (double)m.seq;
        raw[2] = (double)m.detail;
        return 0;
    }
    case HIL_HELLO_FRAME_ID: {
        hil_hello_t m;
        if (hil_hello_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.proto_version;
        raw[1] = (double)m.mode;
        raw[2] = (double)m.period_us;
        raw[3] = (double)m.estimator;
        raw[4] = (double)m.flags;
        raw[5] = (double)m.proto_minor;
        raw[6] = (double)m.session;
        return 0;
    }
    case HIL_HELLO_ACK_FRAME_ID: {
        hil_hello_ack_t m;
        if (hil_hello_ack_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.proto_version;
        raw[1] = (double)m.status;
        raw[2] = (double)m.proto_minor;
        raw[3] = (double)m.fw_version;
        raw[4] = (double)m.estimators;
        raw[5] = (double)m.session;
        return 0;
    }
    case HIL_CONFIG_FRAME_ID: {
        hil_config_t m;
        if (hil_config_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.param_id;
        raw[1] = (double)m.config_seq;
        raw[2] = (double)m.value;
        return 0;
    }
    case HIL_CONFIG_ACK_FRAME_ID: {
        hil_config_ack_t m;
        if (hil_config_ack_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.param_id;
        raw[1] = (double)m.config_seq;
        raw[2] = (double)m.status;
        return 0;
    }
    case HIL_CMD_FRAME_ID: {
        hil_cmd_t m;
        if (hil_cmd_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.command;
        raw[1] = (double)m.seq;
        raw[2] = (double)m.value;
        return 0;
    }
    case HIL_HEARTBEAT_PLANT_FRAME_ID: {
        hil_heartbeat_plant_t m;
        if (hil_heartbeat_plant_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.counter;
        raw[1] = (double)m.state;
        raw[2] = (double)m.rx_errors;
        raw[3] = (double)m.rx_frames;
        return 0;
    }
    case HIL_HEARTBEAT_CTRL_FRAME_ID: {
        hil_heartbeat_ctrl_t m;
        if (hil_heartbeat_ctrl_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.counter;
        raw[1] = (double)m.state;
        raw[2] = (double)m.rx_errors;
        raw[3] = (double)m.rx_frames;
        return 0;
    }
    case HIL_SENSE_FRAME_ID: {
        hil_sense_t m;
        if (hil_sense_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.seq;
        raw[1] = (double)m.i_a;
        raw[2] = (double)m.i_b;
        raw[3] = (double)m.i_c;
        return 0;
    }
    case HIL_SENSE_AUX_FRAME_ID: {
        hil_sense_aux_t m;
        if (hil_sense_aux_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.seq;
        raw[1] = (double)m.v_dc;
        raw[2] = (double)m.theta_enc;
        raw[3] = (double)m.flags;
        return 0;
    }
    case HIL_SENSE_DUAL_FRAME_ID: {
        hil_sense_dual_t m;
        if (hil_sense_dual_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.seq;
        raw[1] = (double)m.i_a2;
        raw[2] = (double)m.i_b2;
        raw[3] = (double)m.i_c2;
        return 0;
    }
    case HIL_DUTY_FRAME_ID: {
        hil_duty_t m;
        if (hil_duty_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.seq;
        raw[1] = (double)m.d_a;
        raw[2] = (double)m.d_b;
        raw[3] = (double)m.d_c;
        return 0;
    }
    case HIL_TELEM_FRAME_ID: {
        hil_telem_t m;
        if (hil_telem_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.seq;
        raw[1] = (double)m.theta_hat;
        raw[2] = (double)m.omega_hat;
        raw[3] = (double)m.state;
        raw[4] = (double)m.estimator;
        return 0;
    }
    case HIL_TELEM_EMF_FRAME_ID: {
        hil_telem_emf_t m;
        if (hil_telem_emf_unpack(&m, src, size) != 0) {
            return -1;
        }
        raw[0] = (double)m.seq;
        raw[1] = (double)m.e_alpha;
        raw[2] = (double)m.e_beta;
        raw[3] = (double)m.i_q_ref;
        return 0;
    }
    default:
        return -1;
    }
}

int hil_reflect_encode(const hil_message_info_t *msg, size_t sig, float value, double *raw)
{
    if (msg == NULL || sig >= msg->n_signals) {
        return -1;
    }
    switch (msg->frame_id) {
    case HIL_FAULT_PLANT_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_fault_plant_code_encode(value); return 0;
        case 1u: *raw = (double)hil_fault_plant_seq_encode(value); return 0;
        case 2u: *raw = (double)hil_fault_plant_detail_encode(value); return 0;
        default: return -1;
        }
    case HIL_FAULT_CTRL_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_fault_ctrl_code_encode(value); return 0;
        case 1u: *raw = (double)hil_fault_ctrl_seq_encode(value); return 0;
        case 2u: *raw = (double)hil_fault_ctrl_detail_encode(value); return 0;
        default: return -1;
        }
    case HIL_HELLO_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_hello_proto_version_encode(value); return 0;
        case 1u: *raw = (double)hil_hello_mode_encode(value); return 0;
        case 2u: *raw = (double)hil_hello_period_us_encode(value); return 0;
        case 3u: *raw = (double)hil_hello_estimator_encode(value); return 0;
        case 4u: *raw = (double)hil_hello_flags_encode(value); return 0;
        case 5u: *raw = (double)hil_hello_proto_minor_encode(value); return 0;
        case 6u: *raw = (double)hil_hello_session_encode(value); return 0;
        default: return -1;
        }
    case HIL_HELLO_ACK_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_hello_ack_proto_version_encode(value); return 0;
        case 1u: *raw = (double)hil_hello_ack_status_encode(value); return 0;
        case 2u: *raw = (double)hil_hello_ack_proto_minor_encode(value); return 0;
        case 3u: *raw = (double)hil_hello_ack_fw_version_encode(value); return 0;
        case 4u: *raw = (double)hil_hello_ack_estimators_encode(value); return 0;
        case 5u: *raw = (double)hil_hello_ack_session_encode(value); return 0;
        default: return -1;
        }
    case HIL_CONFIG_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_config_param_id_encode(value); return 0;
        case 1u: *raw = (double)hil_config_config_seq_encode(value); return 0;
        case 2u: *raw = (double)hil_config_value_encode(value); return 0;
        default: return -1;
        }
    case HIL_CONFIG_ACK_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_config_ack_param_id_encode(value); return 0;
        case 1u: *raw = (double)hil_config_ack_config_seq_encode(value); return 0;
        case 2u: *raw = (double)hil_config_ack_status_encode(value); return 0;
        default: return -1;
        }
    case HIL_CMD_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_cmd_command_encode(value); return 0;
        case 1u: *raw = (double)hil_cmd_seq_encode(value); return 0;
        case 2u: *raw = (double)hil_cmd_value_encode(value); return 0;
        default: return -1;
        }
    case HIL_HEARTBEAT_PLANT_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_heartbeat_plant_counter_encode(value); return 0;
        case 1u: *raw = (double)hil_heartbeat_plant_state_encode(value); return 0;
        case 2u: *raw = (double)hil_heartbeat_plant_rx_errors_encode(value); return 0;
        case 3u: *raw = (double)hil_heartbeat_plant_rx_frames_encode(value); return 0;
        default: return -1;
        }
    case HIL_HEARTBEAT_CTRL_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_heartbeat_ctrl_counter_encode(value); return 0;
        case 1u: *raw = (double)hil_heartbeat_ctrl_state_encode(value); return 0;
        case 2u: *raw = (double)hil_heartbeat_ctrl_rx_errors_encode(value); return 0;
        case 3u: *raw = (double)hil_heartbeat_ctrl_rx_frames_encode(value); return 0;
        default: return -1;
        }
    case HIL_SENSE_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_sense_seq_encode(value); return 0;
        case 1u: *raw = (double)hil_sense_i_a_encode(value); return 0;
        case 2u: *raw = (double)hil_sense_i_b_encode(value); return 0;
        case 3u: *raw = (double)hil_sense_i_c_encode(value); return 0;
        default: return -1;
        }
    case HIL_SENSE_AUX_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_sense_aux_seq_encode(value); return 0;
        case 1u: *raw = (double)hil_sense_aux_v_dc_encode(value); return 0;
        case 2u: *raw = (double)hil_sense_aux_theta_enc_encode(value); return 0;
        case 3u: *raw = (double)hil_sense_aux_flags_encode(value); return 0;
        default: return -1;
        }
    case HIL_SENSE_DUAL_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_sense_dual_seq_encode(value); return 0;
        case 1u: *raw = (double)hil_sense_dual_i_a2_encode(value); return 0;
        case 2u: *raw = (double)hil_sense_dual_i_b2_encode(value); return 0;
        case 3u: *raw = (double)hil_sense_dual_i_c2_encode(value); return 0;
        default: return -1;
        }
    case HIL_DUTY_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_duty_seq_encode(value); return 0;
        case 1u: *raw = (double)hil_duty_d_a_encode(value); return 0;
        case 2u: *raw = (double)hil_duty_d_b_encode(value); return 0;
        case 3u: *raw = (double)hil_duty_d_c_encode(value); return 0;
        default: return -1;
        }
    case HIL_TELEM_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_telem_seq_encode(value); return 0;
        case 1u: *raw = (double)hil_telem_theta_hat_encode(value); return 0;
        case 2u: *raw = (double)hil_telem_omega_hat_encode(value); return 0;
        case 3u: *raw = (double)hil_telem_state_encode(value); return 0;
        case 4u: *raw = (double)hil_telem_estimator_encode(value); return 0;
        default: return -1;
        }
    case HIL_TELEM_EMF_FRAME_ID:
        switch (sig) {
        case 0u: *raw = (double)hil_telem_emf_seq_encode(value); return 0;
        case 1u: *raw = (double)hil_telem_emf_e_alpha_encode(value); return 0;
        case 2u: *raw = (double)hil_telem_emf_e_beta_encode(value); return 0;
        case 3u: *raw = (double)hil_telem_emf_i_q_ref_encode(value); return 0;
        default: return -1;
        }
    default:
        return -1;
    }
}

int hil_reflect_decode(const hil_message_info_t *msg, size_t sig, double raw, float *value)
{
    if (msg == NULL || sig >= msg->n_signals) {
        return -1;
    }
    if (!hil_raw_ok(&msg->signals[sig], raw)) {
        return -1;
    }
    switch (msg->frame_id) {
    case HIL_FAULT_PLANT_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_fault_plant_code_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_fault_plant_seq_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_fault_plant_detail_decode((int32_t)raw); return 0;
        default: return -1;
        }
    case HIL_FAULT_CTRL_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_fault_ctrl_code_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_fault_ctrl_seq_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_fault_ctrl_detail_decode((int32_t)raw); return 0;
        default: return -1;
        }
    case HIL_HELLO_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_hello_proto_version_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_hello_mode_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_hello_period_us_decode((uint16_t)raw); return 0;
        case 3u: *value = hil_hello_estimator_decode((uint16_t)raw); return 0;
        case 4u: *value = hil_hello_flags_decode((uint16_t)raw); return 0;
        case 5u: *value = hil_hello_proto_minor_decode((uint16_t)raw); return 0;
        case 6u: *value = hil_hello_session_decode((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_HELLO_ACK_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_hello_ack_proto_version_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_hello_ack_status_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_hello_ack_proto_minor_decode((uint16_t)raw); return 0;
        case 3u: *value = hil_hello_ack_fw_version_decode((uint16_t)raw); return 0;
        case 4u: *value = hil_hello_ack_estimators_decode((uint16_t)raw); return 0;
        case 5u: *value = hil_hello_ack_session_decode((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_CONFIG_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_config_param_id_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_config_config_seq_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_config_value_decode((float)raw); return 0;
        default: return -1;
        }
    case HIL_CONFIG_ACK_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_config_ack_param_id_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_config_ack_config_seq_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_config_ack_status_decode((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_CMD_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_cmd_command_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_cmd_seq_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_cmd_value_decode((float)raw); return 0;
        default: return -1;
        }
    case HIL_HEARTBEAT_PLANT_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_heartbeat_plant_counter_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_heartbeat_plant_state_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_heartbeat_plant_rx_errors_decode((uint16_t)raw); return 0;
        case 3u: *value = hil_heartbeat_plant_rx_frames_decode((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_HEARTBEAT_CTRL_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_heartbeat_ctrl_counter_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_heartbeat_ctrl_state_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_heartbeat_ctrl_rx_errors_decode((uint16_t)raw); return 0;
        case 3u: *value = hil_heartbeat_ctrl_rx_frames_decode((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_SENSE_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_sense_seq_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_sense_i_a_decode((int16_t)raw); return 0;
        case 2u: *value = hil_sense_i_b_decode((int16_t)raw); return 0;
        case 3u: *value = hil_sense_i_c_decode((int16_t)raw); return 0;
        default: return -1;
        }
    case HIL_SENSE_AUX_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_sense_aux_seq_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_sense_aux_v_dc_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_sense_aux_theta_enc_decode((uint16_t)raw); return 0;
        case 3u: *value = hil_sense_aux_flags_decode((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_SENSE_DUAL_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_sense_dual_seq_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_sense_dual_i_a2_decode((int16_t)raw); return 0;
        case 2u: *value = hil_sense_dual_i_b2_decode((int16_t)raw); return 0;
        case 3u: *value = hil_sense_dual_i_c2_decode((int16_t)raw); return 0;
        default: return -1;
        }
    case HIL_DUTY_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_duty_seq_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_duty_d_a_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_duty_d_b_decode((uint16_t)raw); return 0;
        case 3u: *value = hil_duty_d_c_decode((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_TELEM_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_telem_seq_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_telem_theta_hat_decode((uint16_t)raw); return 0;
        case 2u: *value = hil_telem_omega_hat_decode((int16_t)raw); return 0;
        case 3u: *value = hil_telem_state_decode((uint16_t)raw); return 0;
        case 4u: *value = hil_telem_estimator_decode((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_TELEM_EMF_FRAME_ID:
        switch (sig) {
        case 0u: *value = hil_telem_emf_seq_decode((uint16_t)raw); return 0;
        case 1u: *value = hil_telem_emf_e_alpha_decode((int16_t)raw); return 0;
        case 2u: *value = hil_telem_emf_e_beta_decode((int16_t)raw); return 0;
        case 3u: *value = hil_telem_emf_i_q_ref_decode((int16_t)raw); return 0;
        default: return -1;
        }
    default:
        return -1;
    }
}

int hil_reflect_is_in_range(const hil_message_info_t *msg, size_t sig, double raw, int *in_range)
{
    if (msg == NULL || sig >= msg->n_signals) {
        return -1;
    }
    if (!hil_raw_ok(&msg->signals[sig], raw)) {
        return -1;
    }
    switch (msg->frame_id) {
    case HIL_FAULT_PLANT_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_fault_plant_code_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_fault_plant_seq_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_fault_plant_detail_is_in_range((int32_t)raw); return 0;
        default: return -1;
        }
    case HIL_FAULT_CTRL_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_fault_ctrl_code_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_fault_ctrl_seq_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_fault_ctrl_detail_is_in_range((int32_t)raw); return 0;
        default: return -1;
        }
    case HIL_HELLO_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_hello_proto_version_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_hello_mode_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_hello_period_us_is_in_range((uint16_t)raw); return 0;
        case 3u: *in_range = hil_hello_estimator_is_in_range((uint16_t)raw); return 0;
        case 4u: *in_range = hil_hello_flags_is_in_range((uint16_t)raw); return 0;
        case 5u: *in_range = hil_hello_proto_minor_is_in_range((uint16_t)raw); return 0;
        case 6u: *in_range = hil_hello_session_is_in_range((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_HELLO_ACK_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_hello_ack_proto_version_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_hello_ack_status_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_hello_ack_proto_minor_is_in_range((uint16_t)raw); return 0;
        case 3u: *in_range = hil_hello_ack_fw_version_is_in_range((uint16_t)raw); return 0;
        case 4u: *in_range = hil_hello_ack_estimators_is_in_range((uint16_t)raw); return 0;
        case 5u: *in_range = hil_hello_ack_session_is_in_range((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_CONFIG_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_config_param_id_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_config_config_seq_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_config_value_is_in_range((float)raw); return 0;
        default: return -1;
        }
    case HIL_CONFIG_ACK_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_config_ack_param_id_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_config_ack_config_seq_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_config_ack_status_is_in_range((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_CMD_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_cmd_command_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_cmd_seq_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_cmd_value_is_in_range((float)raw); return 0;
        default: return -1;
        }
    case HIL_HEARTBEAT_PLANT_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_heartbeat_plant_counter_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_heartbeat_plant_state_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_heartbeat_plant_rx_errors_is_in_range((uint16_t)raw); return 0;
        case 3u: *in_range = hil_heartbeat_plant_rx_frames_is_in_range((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_HEARTBEAT_CTRL_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_heartbeat_ctrl_counter_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_heartbeat_ctrl_state_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_heartbeat_ctrl_rx_errors_is_in_range((uint16_t)raw); return 0;
        case 3u: *in_range = hil_heartbeat_ctrl_rx_frames_is_in_range((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_SENSE_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_sense_seq_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_sense_i_a_is_in_range((int16_t)raw); return 0;
        case 2u: *in_range = hil_sense_i_b_is_in_range((int16_t)raw); return 0;
        case 3u: *in_range = hil_sense_i_c_is_in_range((int16_t)raw); return 0;
        default: return -1;
        }
    case HIL_SENSE_AUX_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_sense_aux_seq_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_sense_aux_v_dc_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_sense_aux_theta_enc_is_in_range((uint16_t)raw); return 0;
        case 3u: *in_range = hil_sense_aux_flags_is_in_range((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_SENSE_DUAL_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_sense_dual_seq_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_sense_dual_i_a2_is_in_range((int16_t)raw); return 0;
        case 2u: *in_range = hil_sense_dual_i_b2_is_in_range((int16_t)raw); return 0;
        case 3u: *in_range = hil_sense_dual_i_c2_is_in_range((int16_t)raw); return 0;
        default: return -1;
        }
    case HIL_DUTY_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_duty_seq_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_duty_d_a_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_duty_d_b_is_in_range((uint16_t)raw); return 0;
        case 3u: *in_range = hil_duty_d_c_is_in_range((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_TELEM_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_telem_seq_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_telem_theta_hat_is_in_range((uint16_t)raw); return 0;
        case 2u: *in_range = hil_telem_omega_hat_is_in_range((int16_t)raw); return 0;
        case 3u: *in_range = hil_telem_state_is_in_range((uint16_t)raw); return 0;
        case 4u: *in_range = hil_telem_estimator_is_in_range((uint16_t)raw); return 0;
        default: return -1;
        }
    case HIL_TELEM_EMF_FRAME_ID:
        switch (sig) {
        case 0u: *in_range = hil_telem_emf_seq_is_in_range((uint16_t)raw); return 0;
        case 1u: *in_range = hil_telem_emf_e_alpha_is_in_range((int16_t)raw); return 0;
        case 2u: *in_range = hil_telem_emf_e_beta_is_in_range((int16_t)raw); return 0;
        case 3u: *in_range = hil_telem_emf_i_q_ref_is_in_range((int16_t)raw); return 0;
        default: return -1;
        }
    default:
        return -1;
    }
}
