/**
 * @file fuzz_session.c
 * @brief libFuzzer harness: the firmware's receive path down to ctrl_step. Bytes -> serial
 * deframer -> hil_session_on_frame -> (SENSE) ctrl_step -> TELEM/DUTY through the port.
 *
 * Input: records of 10 octets [selector, flags, payload[8]]. The selector picks a frame id
 * (HELLO, CONFIG, CMD, SENSE, SENSE_AUX, SENSE_DUAL, HEARTBEAT_PLANT, FAULT_PLANT, an unknown
 * id) that is framed with hil_frame_encode (dlc cut by the flags: length errors) and fed octet
 * by octet through the deframer, or (selector 9) the 8 octets go in raw (garbage, resync). The
 * fuzzer thus drives whole sessions: handshake, any CONFIG value, RUN, and SENSE with any
 * currents, bus voltage and encoder angle.
 *
 * Checks, besides ASan/UBSan: every DUTY the session sends has each raw duty in 0..32768 or
 * the OFF value 65535; the controller's duties are finite and either < 0 (off) or in [0, 1]
 * (a NaN turned into a valid-looking raw by the encoder's saturation would pass the wire
 * check: this catches it); every frame sent fits its message length.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "hil_framing.h"
#include "hil_msgs.h"
#include "hil_session.h"

#define REQUIRE(c) do { if (!(c)) abort(); } while (0)

static unsigned long g_duties;

static void check_send(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    (void)ctx;
    REQUIRE(dlc <= 8u && data != NULL);
    if (id == HIL_DUTY_FRAME_ID) {
        hil_duty_t d;
        REQUIRE(hil_duty_unpack(&d, data, dlc) == 0);
        REQUIRE(d.d_a <= 32768u || d.d_a == HIL_DUTY_RAW_OFF);
        REQUIRE(d.d_b <= 32768u || d.d_b == HIL_DUTY_RAW_OFF);
        REQUIRE(d.d_c <= 32768u || d.d_c == HIL_DUTY_RAW_OFF);
        ++g_duties;
    }
}

static void check_outputs(const hil_session_t *s)
{
    int k;
    for (k = 0; k < 3; ++k) {
        const float d = s->ctrl.out.duty_abc[k];
        REQUIRE(isfinite(d));
        REQUIRE(d < 0.0f || (d >= 0.0f && d <= 1.0f));
    }
}

static const uint16_t k_ids[9] = {
    HIL_HELLO_FRAME_ID, HIL_CONFIG_FRAME_ID, HIL_CMD_FRAME_ID, HIL_SENSE_FRAME_ID,
    HIL_SENSE_AUX_FRAME_ID, HIL_SENSE_DUAL_FRAME_ID, HIL_HEARTBEAT_PLANT_FRAME_ID,
    HIL_FAULT_PLANT_FRAME_ID, 0x7FFu};

static void feed(hil_session_t *s, hil_deframer_t *d, const hil_octet_t *bytes, size_t n)
{
    size_t k;
    hil_frame_t f;
    for (k = 0; k < n; ++k) {
        if (hil_deframer_push(d, bytes[k], &f)) {
            hil_session_on_frame(s, &f);
            check_outputs(s);
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static hil_session_t s; /* large: keep it off the stack */
    hil_deframer_t d;
    hil_port_t port;
    size_t pos;
    port.ctx = NULL;
    port.send = check_send;
    hil_session_init(&s, &port);
    hil_deframer_init(&d);
    for (pos = 0; pos + 10u <= size; pos += 10u) {
        const unsigned sel = data[pos] % 10u;
        const unsigned flags = data[pos + 1];
        hil_octet_t payload[8];
        size_t k;
        for (k = 0; k < 8u; ++k) payload[k] = (hil_octet_t)data[pos + 2 + k];
        if (sel == 9u) {
            feed(&s, &d, payload, 8u);
        } else {
            hil_octet_t wire[HIL_FRAME_MAX_WIRE];
            const uint16_t id = (sel == 8u) ? (uint16_t)(0x100u + flags) : k_ids[sel];
            const size_t dlc = (flags & 0x80u) ? (size_t)(flags & 7u) : 8u;
            const size_t n = hil_frame_encode(wire, sizeof wire, id, payload, dlc);
            REQUIRE(n == HIL_FRAME_WIRE_SIZE(dlc));
            feed(&s, &d, wire, n);
        }
    }
    return 0;
}
