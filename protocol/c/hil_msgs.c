/* GENERATED FROM hil.dbc BY protocol/gen_c.py -- DO NOT EDIT.
 * Regenerate with `python protocol/gen_c.py`; `--check` verifies the committed copy. */

#include "hil_msgs.h"

#include <float.h>
#include <math.h>

/* Wire floats are IEEE-754 binary32: refuse to build anywhere else. */
typedef char hil_float_is_binary32[(sizeof(float) == sizeof(uint32_t) && FLT_MANT_DIG == 24
                                    && FLT_MAX_EXP == 128 && FLT_RADIX == 2) ? 1 : -1];

#if defined(HIL_MSGS_CALC_FLOAT)
typedef float hil_calc_t;  /* cheaper on an FPU without double; may differ by 1 LSB next to a tie */
#define HIL_CALC_FMOD fmodf
#else
typedef double hil_calc_t; /* the reference: identical to protocol/messages.py */
#define HIL_CALC_FMOD fmod
#endif

static uint32_t hil_f32_to_bits(float value)
{
    union { float f; uint32_t u; } pun;
    pun.f = value;
    return pun.u;
}

static float hil_f32_from_bits(uint32_t bits)
{
    union { float f; uint32_t u; } pun;
    pun.u = bits;
    return pun.f;
}

static float hil_f32_clamp(float value, float lo, float hi)
{
    if (isnan(value)) {
        value = 0.0f;
    }
    if (value < lo) {
        return lo;
    }
    if (value > hi) {
        return hi;
    }
    return value;
}

/* Two's complement of a `bits`-wide field (1..32) to int32_t, without implementation-defined casts. */
static int32_t hil_sign_extend(uint32_t u, uint32_t bits)
{
    uint32_t sign = (uint32_t)1u << (bits - 1u);
    uint32_t mask = (bits >= 32u) ? UINT32_C(0xFFFFFFFF) : ((sign << 1) - 1u);
    u &= mask;
    if ((u & sign) != 0u) {
        return -(int32_t)((~u) & mask) - 1;
    }
    return (int32_t)u;
}

/* Round q to nearest, ties away from zero, saturated to [lo, hi]; NaN counts as 0.
 * Truncation then an exact remainder test: no reliance on the FPU rounding mode or on lround(). */
static int32_t hil_round_sat_s32(hil_calc_t q, int32_t lo, int32_t hi)
{
    int32_t r;
    hil_calc_t frac;
    if (isnan(q)) {
        q = (hil_calc_t)0;
    }
    if (q <= (hil_calc_t)lo) {
        return lo;
    }
    if (q >= (hil_calc_t)hi) {
        return hi;
    }
    r = (int32_t)q;
    frac = q - (hil_calc_t)r;
    if (frac >= (hil_calc_t)0.5) {
        r++;
    } else if (frac <= (hil_calc_t)-0.5) {
        r--;
    }
    return r;
}

/* Raw value of an angle whose raw range is one turn (2^bits values, bits <= 24): q rounded to nearest,
 * ties away from zero, modulo 2^bits, for any finite q. fmod is exact and keeps the sign of q, so the
 * tie rule is that of q itself. NaN and infinities encode as 0. */
static uint32_t hil_round_turn(hil_calc_t q, uint32_t bits)
{
    int32_t n = (int32_t)((uint32_t)1u << bits);
    int32_t r;
    hil_calc_t frac;
    if (isnan(q) || isinf(q)) {
        return 0u;
    }
    q = HIL_CALC_FMOD(q, (hil_calc_t)n);
    r = (int32_t)q;
    frac = q - (hil_calc_t)r;
    if (frac >= (hil_calc_t)0.5) {
        r++;
    } else if (frac <= (hil_calc_t)-0.5) {
        r--;
    }
    if (r < 0) {
        r += n;
    }
    if (r >= n) {
        r -= n;
    }
    return (uint32_t)r;
}

/* ---- FAULT_PLANT ---- */
int hil_fault_plant_pack(hil_octet_t *dst, const hil_fault_plant_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_FAULT_PLANT_LENGTH) {
        return -1;
    }
    u = (uint32_t)src->code;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->seq;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->detail;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    dst[6] = (hil_octet_t)((u >> 16) & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 24) & 0xFFu);
    return (int)HIL_FAULT_PLANT_LENGTH;
}

int hil_fault_plant_unpack(hil_fault_plant_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_FAULT_PLANT_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->code = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->seq = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8)
        | (((uint32_t)src[6] & 0xFFu) << 16)
        | (((uint32_t)src[7] & 0xFFu) << 24);
    dst->detail = (int32_t)hil_sign_extend(u, 32u);
    return 0;
}

uint16_t hil_fault_plant_code_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_fault_plant_code_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_fault_plant_code_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_fault_plant_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_fault_plant_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_fault_plant_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

int32_t hil_fault_plant_detail_encode(float value)
{
    return (int32_t)hil_round_sat_s32((hil_calc_t)value, (-INT32_C(2147483647) - 1), INT32_C(2147483647));
}

float hil_fault_plant_detail_decode(int32_t raw)
{
    return (float)raw;
}

int hil_fault_plant_detail_is_in_range(int32_t raw)
{
    (void)raw;
    return 1;
}

/* ---- FAULT_CTRL ---- */
int hil_fault_ctrl_pack(hil_octet_t *dst, const hil_fault_ctrl_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_FAULT_CTRL_LENGTH) {
        return -1;
    }
    u = (uint32_t)src->code;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->seq;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->detail;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    dst[6] = (hil_octet_t)((u >> 16) & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 24) & 0xFFu);
    return (int)HIL_FAULT_CTRL_LENGTH;
}

int hil_fault_ctrl_unpack(hil_fault_ctrl_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_FAULT_CTRL_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->code = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->seq = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8)
        | (((uint32_t)src[6] & 0xFFu) << 16)
        | (((uint32_t)src[7] & 0xFFu) << 24);
    dst->detail = (int32_t)hil_sign_extend(u, 32u);
    return 0;
}

uint16_t hil_fault_ctrl_code_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_fault_ctrl_code_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_fault_ctrl_code_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_fault_ctrl_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_fault_ctrl_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_fault_ctrl_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

int32_t hil_fault_ctrl_detail_encode(float value)
{
    return (int32_t)hil_round_sat_s32((hil_calc_t)value, (-INT32_C(2147483647) - 1), INT32_C(2147483647));
}

float hil_fault_ctrl_detail_decode(int32_t raw)
{
    return (float)raw;
}

int hil_fault_ctrl_detail_is_in_range(int32_t raw)
{
    (void)raw;
    return 1;
}

/* ---- HELLO ---- */
int hil_hello_pack(hil_octet_t *dst, const hil_hello_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_HELLO_LENGTH) {
        return -1;
    }
    dst[5] = 0u;
    u = (uint32_t)src->proto_version;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    u = (uint32_t)src->mode;
    dst[1] = (hil_octet_t)(u & 0xFFu);
    u = (uint32_t)src->period_us;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->estimator;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    u = (uint32_t)src->flags;
    dst[5] = (hil_octet_t)(dst[5] | (u & 0xFu));
    u = (uint32_t)src->proto_minor;
    dst[5] = (hil_octet_t)(dst[5] | ((u & 0xFu) << 4));
    u = (uint32_t)src->session;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 8) & 0xFFu);
    return (int)HIL_HELLO_LENGTH;
}

int hil_hello_unpack(hil_hello_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_HELLO_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu);
    dst->proto_version = (uint16_t)u;
    u = ((uint32_t)src[1] & 0xFFu);
    dst->mode = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->period_us = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu);
    dst->estimator = (uint16_t)u;
    u = (((uint32_t)src[5] & 0xFFu) & 0xFu);
    dst->flags = (uint16_t)u;
    u = ((((uint32_t)src[5] & 0xFFu) >> 4) & 0xFu);
    dst->proto_minor = (uint16_t)u;
    u = ((uint32_t)src[6] & 0xFFu)
        | (((uint32_t)src[7] & 0xFFu) << 8);
    dst->session = (uint16_t)u;
    return 0;
}

uint16_t hil_hello_proto_version_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_hello_proto_version_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_proto_version_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HELLO_PROTO_VERSION_RAW_MAX) ? 1 : 0;
}

uint16_t hil_hello_mode_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(1));
}

float hil_hello_mode_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_mode_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HELLO_MODE_RAW_MAX) ? 1 : 0;
}

uint16_t hil_hello_period_us_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.1, INT32_C(0), INT32_C(65535));
}

float hil_hello_period_us_decode(uint16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.1);
}

int hil_hello_period_us_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_hello_estimator_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_hello_estimator_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_estimator_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HELLO_ESTIMATOR_RAW_MAX) ? 1 : 0;
}

uint16_t hil_hello_flags_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(15));
}

float hil_hello_flags_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_flags_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HELLO_FLAGS_RAW_MAX) ? 1 : 0;
}

uint16_t hil_hello_proto_minor_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(15));
}

float hil_hello_proto_minor_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_proto_minor_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HELLO_PROTO_MINOR_RAW_MAX) ? 1 : 0;
}

uint16_t hil_hello_session_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_hello_session_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_session_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

/* ---- HELLO_ACK ---- */
int hil_hello_ack_pack(hil_octet_t *dst, const hil_hello_ack_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_HELLO_ACK_LENGTH) {
        return -1;
    }
    dst[1] = 0u;
    u = (uint32_t)src->proto_version;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    u = (uint32_t)src->status;
    dst[1] = (hil_octet_t)(dst[1] | (u & 0xFu));
    u = (uint32_t)src->proto_minor;
    dst[1] = (hil_octet_t)(dst[1] | ((u & 0xFu) << 4));
    u = (uint32_t)src->fw_version;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->estimators;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->session;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 8) & 0xFFu);
    return (int)HIL_HELLO_ACK_LENGTH;
}

int hil_hello_ack_unpack(hil_hello_ack_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_HELLO_ACK_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu);
    dst->proto_version = (uint16_t)u;
    u = (((uint32_t)src[1] & 0xFFu) & 0xFu);
    dst->status = (uint16_t)u;
    u = ((((uint32_t)src[1] & 0xFFu) >> 4) & 0xFu);
    dst->proto_minor = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->fw_version = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8);
    dst->estimators = (uint16_t)u;
    u = ((uint32_t)src[6] & 0xFFu)
        | (((uint32_t)src[7] & 0xFFu) << 8);
    dst->session = (uint16_t)u;
    return 0;
}

uint16_t hil_hello_ack_proto_version_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_hello_ack_proto_version_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_ack_proto_version_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HELLO_ACK_PROTO_VERSION_RAW_MAX) ? 1 : 0;
}

uint16_t hil_hello_ack_status_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(15));
}

float hil_hello_ack_status_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_ack_status_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HELLO_ACK_STATUS_RAW_MAX) ? 1 : 0;
}

uint16_t hil_hello_ack_proto_minor_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(15));
}

float hil_hello_ack_proto_minor_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_ack_proto_minor_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HELLO_ACK_PROTO_MINOR_RAW_MAX) ? 1 : 0;
}

uint16_t hil_hello_ack_fw_version_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_hello_ack_fw_version_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_ack_fw_version_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_hello_ack_estimators_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_hello_ack_estimators_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_ack_estimators_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_hello_ack_session_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_hello_ack_session_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_hello_ack_session_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

/* ---- CONFIG ---- */
int hil_config_pack(hil_octet_t *dst, const hil_config_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_CONFIG_LENGTH) {
        return -1;
    }
    u = (uint32_t)src->param_id;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->config_seq;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = hil_f32_to_bits(src->value);
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    dst[6] = (hil_octet_t)((u >> 16) & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 24) & 0xFFu);
    return (int)HIL_CONFIG_LENGTH;
}

int hil_config_unpack(hil_config_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_CONFIG_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->param_id = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->config_seq = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8)
        | (((uint32_t)src[6] & 0xFFu) << 16)
        | (((uint32_t)src[7] & 0xFFu) << 24);
    dst->value = hil_f32_from_bits(u);
    return 0;
}

uint16_t hil_config_param_id_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_config_param_id_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_config_param_id_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_config_config_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_config_config_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_config_config_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

float hil_config_value_encode(float value)
{
    return hil_f32_clamp(value, -3.4e+38f, 3.4e+38f);
}

float hil_config_value_decode(float raw)
{
    return raw;
}

int hil_config_value_is_in_range(float raw)
{
    return (raw >= -3.4e+38f && raw <= 3.4e+38f) ? 1 : 0;
}

/* ---- CONFIG_ACK ---- */
int hil_config_ack_pack(hil_octet_t *dst, const hil_config_ack_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_CONFIG_ACK_LENGTH) {
        return -1;
    }
    dst[5] = 0u;
    dst[6] = 0u;
    dst[7] = 0u;
    u = (uint32_t)src->param_id;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->config_seq;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->status;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    return (int)HIL_CONFIG_ACK_LENGTH;
}

int hil_config_ack_unpack(hil_config_ack_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_CONFIG_ACK_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->param_id = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->config_seq = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu);
    dst->status = (uint16_t)u;
    return 0;
}

uint16_t hil_config_ack_param_id_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_config_ack_param_id_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_config_ack_param_id_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_config_ack_config_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_config_ack_config_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_config_ack_config_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_config_ack_status_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_config_ack_status_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_config_ack_status_is_in_range(uint16_t raw)
{
    return (raw <= HIL_CONFIG_ACK_STATUS_RAW_MAX) ? 1 : 0;
}

/* ---- CMD ---- */
int hil_cmd_pack(hil_octet_t *dst, const hil_cmd_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_CMD_LENGTH) {
        return -1;
    }
    dst[1] = 0u;
    u = (uint32_t)src->command;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    u = (uint32_t)src->seq;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = hil_f32_to_bits(src->value);
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    dst[6] = (hil_octet_t)((u >> 16) & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 24) & 0xFFu);
    return (int)HIL_CMD_LENGTH;
}

int hil_cmd_unpack(hil_cmd_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_CMD_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu);
    dst->command = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->seq = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8)
        | (((uint32_t)src[6] & 0xFFu) << 16)
        | (((uint32_t)src[7] & 0xFFu) << 24);
    dst->value = hil_f32_from_bits(u);
    return 0;
}

uint16_t hil_cmd_command_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_cmd_command_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_cmd_command_is_in_range(uint16_t raw)
{
    return (raw <= HIL_CMD_COMMAND_RAW_MAX) ? 1 : 0;
}

uint16_t hil_cmd_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_cmd_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_cmd_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

float hil_cmd_value_encode(float value)
{
    return hil_f32_clamp(value, -3.4e+38f, 3.4e+38f);
}

float hil_cmd_value_decode(float raw)
{
    return raw;
}

int hil_cmd_value_is_in_range(float raw)
{
    return (raw >= -3.4e+38f && raw <= 3.4e+38f) ? 1 : 0;
}

/* ---- HEARTBEAT_PLANT ---- */
int hil_heartbeat_plant_pack(hil_octet_t *dst, const hil_heartbeat_plant_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_HEARTBEAT_PLANT_LENGTH) {
        return -1;
    }
    dst[3] = 0u;
    u = (uint32_t)src->counter;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->state;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    u = (uint32_t)src->rx_errors;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->rx_frames;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 8) & 0xFFu);
    return (int)HIL_HEARTBEAT_PLANT_LENGTH;
}

int hil_heartbeat_plant_unpack(hil_heartbeat_plant_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_HEARTBEAT_PLANT_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->counter = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu);
    dst->state = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8);
    dst->rx_errors = (uint16_t)u;
    u = ((uint32_t)src[6] & 0xFFu)
        | (((uint32_t)src[7] & 0xFFu) << 8);
    dst->rx_frames = (uint16_t)u;
    return 0;
}

uint16_t hil_heartbeat_plant_counter_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_heartbeat_plant_counter_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_heartbeat_plant_counter_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_heartbeat_plant_state_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_heartbeat_plant_state_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_heartbeat_plant_state_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HEARTBEAT_PLANT_STATE_RAW_MAX) ? 1 : 0;
}

uint16_t hil_heartbeat_plant_rx_errors_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_heartbeat_plant_rx_errors_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_heartbeat_plant_rx_errors_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_heartbeat_plant_rx_frames_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_heartbeat_plant_rx_frames_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_heartbeat_plant_rx_frames_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

/* ---- HEARTBEAT_CTRL ---- */
int hil_heartbeat_ctrl_pack(hil_octet_t *dst, const hil_heartbeat_ctrl_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_HEARTBEAT_CTRL_LENGTH) {
        return -1;
    }
    dst[3] = 0u;
    u = (uint32_t)src->counter;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->state;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    u = (uint32_t)src->rx_errors;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->rx_frames;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 8) & 0xFFu);
    return (int)HIL_HEARTBEAT_CTRL_LENGTH;
}

int hil_heartbeat_ctrl_unpack(hil_heartbeat_ctrl_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_HEARTBEAT_CTRL_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->counter = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu);
    dst->state = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8);
    dst->rx_errors = (uint16_t)u;
    u = ((uint32_t)src[6] & 0xFFu)
        | (((uint32_t)src[7] & 0xFFu) << 8);
    dst->rx_frames = (uint16_t)u;
    return 0;
}

uint16_t hil_heartbeat_ctrl_counter_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_heartbeat_ctrl_counter_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_heartbeat_ctrl_counter_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_heartbeat_ctrl_state_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_heartbeat_ctrl_state_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_heartbeat_ctrl_state_is_in_range(uint16_t raw)
{
    return (raw <= HIL_HEARTBEAT_CTRL_STATE_RAW_MAX) ? 1 : 0;
}

uint16_t hil_heartbeat_ctrl_rx_errors_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_heartbeat_ctrl_rx_errors_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_heartbeat_ctrl_rx_errors_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_heartbeat_ctrl_rx_frames_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_heartbeat_ctrl_rx_frames_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_heartbeat_ctrl_rx_frames_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

/* ---- SENSE ---- */
int hil_sense_pack(hil_octet_t *dst, const hil_sense_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_SENSE_LENGTH) {
        return -1;
    }
    u = (uint32_t)src->seq;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->i_a;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->i_b;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->i_c;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 8) & 0xFFu);
    return (int)HIL_SENSE_LENGTH;
}

int hil_sense_unpack(hil_sense_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_SENSE_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->seq = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->i_a = (int16_t)hil_sign_extend(u, 16u);
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8);
    dst->i_b = (int16_t)hil_sign_extend(u, 16u);
    u = ((uint32_t)src[6] & 0xFFu)
        | (((uint32_t)src[7] & 0xFFu) << 8);
    dst->i_c = (int16_t)hil_sign_extend(u, 16u);
    return 0;
}

uint16_t hil_sense_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_sense_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_sense_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_sense_i_a_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.001, INT32_C(-32768), INT32_C(32767));
}

float hil_sense_i_a_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.001);
}

int hil_sense_i_a_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_sense_i_b_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.001, INT32_C(-32768), INT32_C(32767));
}

float hil_sense_i_b_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.001);
}

int hil_sense_i_b_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_sense_i_c_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.001, INT32_C(-32768), INT32_C(32767));
}

float hil_sense_i_c_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.001);
}

int hil_sense_i_c_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}

/* ---- SENSE_AUX ---- */
int hil_sense_aux_pack(hil_octet_t *dst, const hil_sense_aux_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_SENSE_AUX_LENGTH) {
        return -1;
    }
    dst[7] = 0u;
    u = (uint32_t)src->seq;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->v_dc;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->theta_enc;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->flags;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    return (int)HIL_SENSE_AUX_LENGTH;
}

int hil_sense_aux_unpack(hil_sense_aux_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_SENSE_AUX_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->seq = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->v_dc = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8);
    dst->theta_enc = (uint16_t)u;
    u = ((uint32_t)src[6] & 0xFFu);
    dst->flags = (uint16_t)u;
    return 0;
}

uint16_t hil_sense_aux_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_sense_aux_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_sense_aux_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_sense_aux_v_dc_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.01, INT32_C(0), INT32_C(65535));
}

float hil_sense_aux_v_dc_decode(uint16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.01);
}

int hil_sense_aux_v_dc_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_sense_aux_theta_enc_encode(float value)
{
    return (uint16_t)hil_round_turn((hil_calc_t)value / (hil_calc_t)9.587379924285257e-05, 16u);
}

float hil_sense_aux_theta_enc_decode(uint16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)9.587379924285257e-05);
}

int hil_sense_aux_theta_enc_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_sense_aux_flags_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_sense_aux_flags_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_sense_aux_flags_is_in_range(uint16_t raw)
{
    return (raw <= HIL_SENSE_AUX_FLAGS_RAW_MAX) ? 1 : 0;
}

/* ---- SENSE_DUAL ---- */
int hil_sense_dual_pack(hil_octet_t *dst, const hil_sense_dual_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_SENSE_DUAL_LENGTH) {
        return -1;
    }
    u = (uint32_t)src->seq;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->i_a2;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->i_b2;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->i_c2;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 8) & 0xFFu);
    return (int)HIL_SENSE_DUAL_LENGTH;
}

int hil_sense_dual_unpack(hil_sense_dual_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_SENSE_DUAL_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->seq = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->i_a2 = (int16_t)hil_sign_extend(u, 16u);
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8);
    dst->i_b2 = (int16_t)hil_sign_extend(u, 16u);
    u = ((uint32_t)src[6] & 0xFFu)
        | (((uint32_t)src[7] & 0xFFu) << 8);
    dst->i_c2 = (int16_t)hil_sign_extend(u, 16u);
    return 0;
}

uint16_t hil_sense_dual_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_sense_dual_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_sense_dual_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_sense_dual_i_a2_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.001, INT32_C(-32768), INT32_C(32767));
}

float hil_sense_dual_i_a2_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.001);
}

int hil_sense_dual_i_a2_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_sense_dual_i_b2_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.001, INT32_C(-32768), INT32_C(32767));
}

float hil_sense_dual_i_b2_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.001);
}

int hil_sense_dual_i_b2_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_sense_dual_i_c2_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.001, INT32_C(-32768), INT32_C(32767));
}

float hil_sense_dual_i_c2_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.001);
}

int hil_sense_dual_i_c2_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}

/* ---- DUTY ---- */
int hil_duty_pack(hil_octet_t *dst, const hil_duty_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_DUTY_LENGTH) {
        return -1;
    }
    u = (uint32_t)src->seq;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->d_a;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->d_b;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->d_c;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 8) & 0xFFu);
    return (int)HIL_DUTY_LENGTH;
}

int hil_duty_unpack(hil_duty_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_DUTY_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->seq = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->d_a = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8);
    dst->d_b = (uint16_t)u;
    u = ((uint32_t)src[6] & 0xFFu)
        | (((uint32_t)src[7] & 0xFFu) << 8);
    dst->d_c = (uint16_t)u;
    return 0;
}

uint16_t hil_duty_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_duty_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_duty_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_duty_d_a_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)3.0517578125e-05, INT32_C(0), INT32_C(32768));
}

float hil_duty_d_a_decode(uint16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)3.0517578125e-05);
}

int hil_duty_d_a_is_in_range(uint16_t raw)
{
    return (raw <= HIL_DUTY_D_A_RAW_MAX) ? 1 : 0;
}

uint16_t hil_duty_d_b_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)3.0517578125e-05, INT32_C(0), INT32_C(32768));
}

float hil_duty_d_b_decode(uint16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)3.0517578125e-05);
}

int hil_duty_d_b_is_in_range(uint16_t raw)
{
    return (raw <= HIL_DUTY_D_B_RAW_MAX) ? 1 : 0;
}

uint16_t hil_duty_d_c_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)3.0517578125e-05, INT32_C(0), INT32_C(32768));
}

float hil_duty_d_c_decode(uint16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)3.0517578125e-05);
}

int hil_duty_d_c_is_in_range(uint16_t raw)
{
    return (raw <= HIL_DUTY_D_C_RAW_MAX) ? 1 : 0;
}

/* ---- TELEM ---- */
int hil_telem_pack(hil_octet_t *dst, const hil_telem_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_TELEM_LENGTH) {
        return -1;
    }
    u = (uint32_t)src->seq;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->theta_hat;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->omega_hat;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->state;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    u = (uint32_t)src->estimator;
    dst[7] = (hil_octet_t)(u & 0xFFu);
    return (int)HIL_TELEM_LENGTH;
}

int hil_telem_unpack(hil_telem_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_TELEM_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->seq = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->theta_hat = (uint16_t)u;
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8);
    dst->omega_hat = (int16_t)hil_sign_extend(u, 16u);
    u = ((uint32_t)src[6] & 0xFFu);
    dst->state = (uint16_t)u;
    u = ((uint32_t)src[7] & 0xFFu);
    dst->estimator = (uint16_t)u;
    return 0;
}

uint16_t hil_telem_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_telem_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_telem_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_telem_theta_hat_encode(float value)
{
    return (uint16_t)hil_round_turn((hil_calc_t)value / (hil_calc_t)9.587379924285257e-05, 16u);
}

float hil_telem_theta_hat_decode(uint16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)9.587379924285257e-05);
}

int hil_telem_theta_hat_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_telem_omega_hat_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.1, INT32_C(-32768), INT32_C(32767));
}

float hil_telem_omega_hat_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.1);
}

int hil_telem_omega_hat_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}

uint16_t hil_telem_state_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_telem_state_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_telem_state_is_in_range(uint16_t raw)
{
    return (raw <= HIL_TELEM_STATE_RAW_MAX) ? 1 : 0;
}

uint16_t hil_telem_estimator_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(255));
}

float hil_telem_estimator_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_telem_estimator_is_in_range(uint16_t raw)
{
    return (raw <= HIL_TELEM_ESTIMATOR_RAW_MAX) ? 1 : 0;
}

/* ---- TELEM_EMF ---- */
int hil_telem_emf_pack(hil_octet_t *dst, const hil_telem_emf_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_TELEM_EMF_LENGTH) {
        return -1;
    }
    u = (uint32_t)src->seq;
    dst[0] = (hil_octet_t)(u & 0xFFu);
    dst[1] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->e_alpha;
    dst[2] = (hil_octet_t)(u & 0xFFu);
    dst[3] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->e_beta;
    dst[4] = (hil_octet_t)(u & 0xFFu);
    dst[5] = (hil_octet_t)((u >> 8) & 0xFFu);
    u = (uint32_t)src->i_q_ref;
    dst[6] = (hil_octet_t)(u & 0xFFu);
    dst[7] = (hil_octet_t)((u >> 8) & 0xFFu);
    return (int)HIL_TELEM_EMF_LENGTH;
}

int hil_telem_emf_unpack(hil_telem_emf_t *dst, const hil_octet_t *src, size_t size)
{
    uint32_t u;
    if (dst == NULL || src == NULL || size < HIL_TELEM_EMF_LENGTH) {
        return -1;
    }
    u = ((uint32_t)src[0] & 0xFFu)
        | (((uint32_t)src[1] & 0xFFu) << 8);
    dst->seq = (uint16_t)u;
    u = ((uint32_t)src[2] & 0xFFu)
        | (((uint32_t)src[3] & 0xFFu) << 8);
    dst->e_alpha = (int16_t)hil_sign_extend(u, 16u);
    u = ((uint32_t)src[4] & 0xFFu)
        | (((uint32_t)src[5] & 0xFFu) << 8);
    dst->e_beta = (int16_t)hil_sign_extend(u, 16u);
    u = ((uint32_t)src[6] & 0xFFu)
        | (((uint32_t)src[7] & 0xFFu) << 8);
    dst->i_q_ref = (int16_t)hil_sign_extend(u, 16u);
    return 0;
}

uint16_t hil_telem_emf_seq_encode(float value)
{
    return (uint16_t)hil_round_sat_s32((hil_calc_t)value, INT32_C(0), INT32_C(65535));
}

float hil_telem_emf_seq_decode(uint16_t raw)
{
    return (float)raw;
}

int hil_telem_emf_seq_is_in_range(uint16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_telem_emf_e_alpha_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.01, INT32_C(-32768), INT32_C(32767));
}

float hil_telem_emf_e_alpha_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.01);
}

int hil_telem_emf_e_alpha_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_telem_emf_e_beta_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.01, INT32_C(-32768), INT32_C(32767));
}

float hil_telem_emf_e_beta_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.01);
}

int hil_telem_emf_e_beta_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}

int16_t hil_telem_emf_i_q_ref_encode(float value)
{
    return (int16_t)hil_round_sat_s32((hil_calc_t)value / (hil_calc_t)0.001, INT32_C(-32768), INT32_C(32767));
}

float hil_telem_emf_i_q_ref_decode(int16_t raw)
{
    return (float)((hil_calc_t)raw * (hil_calc_t)0.001);
}

int hil_telem_emf_i_q_ref_is_in_range(int16_t raw)
{
    (void)raw;
    return 1;
}
