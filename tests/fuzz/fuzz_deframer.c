/**
 * @file fuzz_deframer.c
 * @brief libFuzzer harness: any byte stream through the C deframer (protocol/c/hil_framing.c).
 *
 * Checks, besides ASan/UBSan: every non-empty chunk is counted exactly once (frames_ok +
 * crc/cobs/length errors + overruns); a delivered frame has dlc <= 64 and an 11-bit id; it
 * re-encodes (hil_frame_encode) into a stream that a fresh deframer turns into the same frame.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "hil_framing.h"

#define REQUIRE(c) do { if (!(c)) abort(); } while (0)

static void check_roundtrip(const hil_frame_t *f)
{
    hil_octet_t wire[HIL_FRAME_MAX_WIRE];
    hil_deframer_t d2;
    hil_frame_t g;
    size_t n, k;
    int got = 0;
    REQUIRE(f->dlc <= HIL_FRAME_MAX_DATA && f->id <= HIL_FRAME_MAX_ID);
    n = hil_frame_encode(wire, sizeof wire, f->id, f->data, f->dlc);
    REQUIRE(n == HIL_FRAME_WIRE_SIZE(f->dlc));
    hil_deframer_init(&d2);
    for (k = 0; k < n; ++k) {
        REQUIRE((wire[k] & 0xFFu) != 0u || k == n - 1);
        if (hil_deframer_push(&d2, wire[k], &g)) {
            ++got;
            REQUIRE(g.id == f->id && g.dlc == f->dlc && memcmp(g.data, f->data, f->dlc) == 0);
        }
    }
    REQUIRE(got == 1 && d2.frames_ok == 1u);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    hil_deframer_t d;
    hil_frame_t f;
    size_t k, chunk = 0, chunks = 0;
    unsigned long counted;
    hil_deframer_init(&d);
    for (k = 0; k < size; ++k) {
        const hil_octet_t b = (hil_octet_t)data[k];
        if (hil_deframer_push(&d, b, &f)) {
            check_roundtrip(&f);
        }
        if (data[k] == 0u) {
            if (chunk > 0u) ++chunks;
            chunk = 0;
        } else {
            ++chunk;
        }
    }
    counted = (unsigned long)d.frames_ok + d.crc_errors + d.cobs_errors + d.length_errors + d.overruns;
    /* an unterminated chunk is counted only if it already overran */
    REQUIRE(counted == chunks + (chunk > HIL_FRAME_MAX_COBS ? 1u : 0u));
    return 0;
}
