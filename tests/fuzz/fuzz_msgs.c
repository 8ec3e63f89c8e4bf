/**
 * @file fuzz_msgs.c
 * @brief libFuzzer harness: every generated message decoder (hil_*_unpack in
 * protocol/c/hil_msgs.c) on arbitrary payloads of arbitrary size.
 *
 * Input: byte 0 selects the message, the rest is the payload. Checks, besides ASan/UBSan: a
 * payload shorter than the message is refused and a NULL buffer too; an accepted payload packs
 * back to the same struct (unpack o pack o unpack = unpack) and to the raw values the
 * table-driven reflection decodes; every signal decodes to a finite number (FLOAT signals
 * excepted: they carry any binary32) and its encoder accepts that number without UB.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "hil_msgs.h"
#include "hil_msgs_reflect.h"

#define REQUIRE(c) do { if (!(c)) abort(); } while (0)

/* unpack -> pack -> unpack; struct equality; raw agreement with the reflection table */
#define ROUNDTRIP(T, NAME, LEN)                                                                 \
    do {                                                                                        \
        T m1, m2;                                                                               \
        hil_octet_t buf[LEN];                                                                   \
        memset(&m1, 0, sizeof m1);                                                              \
        memset(&m2, 0, sizeof m2);                                                              \
        REQUIRE(hil_##NAME##_unpack(&m1, NULL, size) == -1);                                    \
        if (hil_##NAME##_unpack(&m1, payload, size) != 0) {                                     \
            REQUIRE(size < (LEN));                                                              \
            break;                                                                              \
        }                                                                                       \
        REQUIRE(size >= (LEN));                                                                 \
        REQUIRE(hil_##NAME##_pack(buf, &m1, sizeof buf) >= 0);                                  \
        REQUIRE(hil_##NAME##_unpack(&m2, buf, sizeof buf) == 0);                                \
        REQUIRE(memcmp(&m1, &m2, sizeof m1) == 0);                                              \
        REQUIRE(hil_##NAME##_pack(buf, &m1, (LEN) - 1u) < 0);                                   \
        check_reflect(LEN, buf, payload);                                                       \
    } while (0)

static uint16_t g_frame_id;

/* the reflection decodes the same raw values from the input and from the re-packed bytes */
static void check_reflect(size_t len, const hil_octet_t *repacked, const hil_octet_t *orig)
{
    const hil_message_info_t *m = hil_message_by_id(g_frame_id);
    double r1[16], r2[16];
    size_t s;
    (void)len;
    REQUIRE(m != NULL && m->n_signals <= 16u);
    REQUIRE(hil_reflect_unpack(m, r1, orig, m->length) == 0);
    REQUIRE(hil_reflect_unpack(m, r2, repacked, m->length) == 0);
    for (s = 0; s < m->n_signals; ++s) {
        float v;
        double raw_back;
        REQUIRE(memcmp(&r1[s], &r2[s], sizeof r1[s]) == 0);
        REQUIRE(hil_reflect_decode(m, s, r1[s], &v) == 0);
        if (m->signals[s].kind != HIL_SIG_FLOAT) {
            REQUIRE(isfinite(v));
        }
        (void)hil_reflect_encode(m, s, v, &raw_back); /* any decoded value encodes without UB */
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    hil_octet_t payload[80];
    size_t k;
    unsigned sel;
    if (size < 1u) return 0;
    sel = data[0] % 15u;
    size -= 1u;
    if (size > sizeof payload) size = sizeof payload;
    for (k = 0; k < size; ++k) payload[k] = (hil_octet_t)data[1 + k];
    switch (sel) {
    case 0: g_frame_id = (uint16_t)HIL_FAULT_PLANT_FRAME_ID; ROUNDTRIP(hil_fault_plant_t, fault_plant, HIL_FAULT_PLANT_LENGTH); break;
    case 1: g_frame_id = (uint16_t)HIL_FAULT_CTRL_FRAME_ID; ROUNDTRIP(hil_fault_ctrl_t, fault_ctrl, HIL_FAULT_CTRL_LENGTH); break;
    case 2: g_frame_id = (uint16_t)HIL_HELLO_FRAME_ID; ROUNDTRIP(hil_hello_t, hello, HIL_HELLO_LENGTH); break;
    case 3: g_frame_id = (uint16_t)HIL_HELLO_ACK_FRAME_ID; ROUNDTRIP(hil_hello_ack_t, hello_ack, HIL_HELLO_ACK_LENGTH); break;
    case 4: g_frame_id = (uint16_t)HIL_CONFIG_FRAME_ID; ROUNDTRIP(hil_config_t, config, HIL_CONFIG_LENGTH); break;
    case 5: g_frame_id = (uint16_t)HIL_CONFIG_ACK_FRAME_ID; ROUNDTRIP(hil_config_ack_t, config_ack, HIL_CONFIG_ACK_LENGTH); break;
    case 6: g_frame_id = (uint16_t)HIL_CMD_FRAME_ID; ROUNDTRIP(hil_cmd_t, cmd, HIL_CMD_LENGTH); break;
    case 7: g_frame_id = (uint16_t)HIL_HEARTBEAT_PLANT_FRAME_ID; ROUNDTRIP(hil_heartbeat_plant_t, heartbeat_plant, HIL_HEARTBEAT_PLANT_LENGTH); break;
    case 8: g_frame_id = (uint16_t)HIL_HEARTBEAT_CTRL_FRAME_ID; ROUNDTRIP(hil_heartbeat_ctrl_t, heartbeat_ctrl, HIL_HEARTBEAT_CTRL_LENGTH); break;
    case 9: g_frame_id = (uint16_t)HIL_SENSE_FRAME_ID; ROUNDTRIP(hil_sense_t, sense, HIL_SENSE_LENGTH); break;
    case 10: g_frame_id = (uint16_t)HIL_SENSE_AUX_FRAME_ID; ROUNDTRIP(hil_sense_aux_t, sense_aux, HIL_SENSE_AUX_LENGTH); break;
    case 11: g_frame_id = (uint16_t)HIL_SENSE_DUAL_FRAME_ID; ROUNDTRIP(hil_sense_dual_t, sense_dual, HIL_SENSE_DUAL_LENGTH); break;
    case 12: g_frame_id = (uint16_t)HIL_DUTY_FRAME_ID; ROUNDTRIP(hil_duty_t, duty, HIL_DUTY_LENGTH); break;
    case 13: g_frame_id = (uint16_t)HIL_TELEM_FRAME_ID; ROUNDTRIP(hil_telem_t, telem, HIL_TELEM_LENGTH); break;
    default: g_frame_id = (uint16_t)HIL_TELEM_EMF_FRAME_ID; ROUNDTRIP(hil_telem_emf_t, telem_emf, HIL_TELEM_EMF_LENGTH); break;
    }
    return 0;
}
