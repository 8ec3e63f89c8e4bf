/* C checks of the protocol library (protocol/c).
 *
 *   test_protocol_vectors <repo root>   golden vectors of protocol/vectors/ (shared with pytest):
 *       message cases: encode(physical) == raw, pack(raw) == payload == .bin, unpack(payload) == raw,
 *                      decode(raw) == physical within half an LSB, is_in_range(raw);
 *       stream cases:  .bin fed octet by octet -> exactly the expected frames and counters;
 *                      hil_frame_encode(expected frame) == its wire encoding.
 *   test_protocol_vectors --roundtrip   every message: pack/unpack of random raw values, unpack/pack of
 *       random payloads, encode(decode(raw)) == raw, saturation, NaN, ranges; framing: CRC check value,
 *       encoder errors, random frames mixed with garbage through the deframer.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hil_framing.h"
#include "hil_msgs.h"
#include "hil_msgs_reflect.h"
#include "json_mini.h"

#define MAX_TOKS 4096
#define MAX_SIGNALS 16
#define MAX_BIN 4096

static int g_failures = 0;
static long g_checks = 0;
static const char *g_case = "";

#define CHECK(cond, ...)                                                                                \
    do {                                                                                               \
        g_checks++;                                                                                    \
        if (!(cond)) {                                                                                 \
            g_failures++;                                                                              \
            if (g_failures <= 50) {                                                                    \
                fprintf(stderr, "FAIL %s (%s:%d): ", g_case, __FILE__, __LINE__);                      \
                fprintf(stderr, __VA_ARGS__);                                                          \
                fputc('\n', stderr);                                                                   \
            }                                                                                          \
        }                                                                                              \
    } while (0)

/* ------------------------------------------------------------------------------------------------ */
/* helpers                                                                                          */
/* ------------------------------------------------------------------------------------------------ */

static char *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    char *buf;
    long size;
    if (f == NULL) {
        return NULL;
    }
    if (fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) != 0) {
        fclose(f);
        return NULL;
    }
    buf = (char *)malloc((size_t)size + 1u);
    if (buf == NULL) {
        fclose(f);
        return NULL;
    }
    *len = fread(buf, 1u, (size_t)size, f);
    buf[*len] = '\0';
    fclose(f);
    return buf;
}

static int hex_value(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    return -1;
}

/* Hex string token -> octets. Returns the count or -1. */
static int hex_decode(const char *text, const json_tok_t *tok, hil_octet_t *out, size_t size)
{
    size_t n = tok->end - tok->start;
    size_t i;
    if (tok->type != JSON_STRING || n % 2u != 0u || n / 2u > size) {
        return -1;
    }
    for (i = 0u; i < n / 2u; i++) {
        int hi = hex_value(text[tok->start + 2u * i]);
        int lo = hex_value(text[tok->start + 2u * i + 1u]);
        if (hi < 0 || lo < 0) {
            return -1;
        }
        out[i] = (hil_octet_t)(hi * 16 + lo);
    }
    return (int)(n / 2u);
}

static const json_tok_t g_none = {JSON_NONE, 0u, 0u, 0, 0};

/* Leaf member of an object, or an empty token (never an out-of-bounds index). */
static const json_tok_t *member(const char *js, const json_tok_t *t, int obj, const char *key)
{
    int i = json_get(js, t, obj, key);
    return (i >= 0) ? &t[i] : &g_none;
}

/* a == b for doubles without -Wfloat-equal (both are plain numbers here) */
static int deq(double a, double b)
{
    return !(a < b) && !(a > b);
}

static int same_bits(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

static int float_bits_equal(float a, float b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

static int octets_equal(const hil_octet_t *a, const hil_octet_t *b, size_t n)
{
    size_t i;
    for (i = 0u; i < n; i++) {
        if ((a[i] & 0xFFu) != (b[i] & 0xFFu)) {
            return 0;
        }
    }
    return 1;
}

/* Deterministic xorshift32 */
static unsigned long g_rng = 2463534242UL;
static uint32_t rnd32(void)
{
    uint32_t x = (uint32_t)g_rng;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    g_rng = x;
    return x;
}

static double rnd_between(double lo, double hi)
{
    /* an integer in [lo, hi] (both integral, span < 2^32) */
    double span = hi - lo + 1.0;
    double r = (double)rnd32() / 4294967296.0;
    double v = lo + floor(r * span);
    return (v > hi) ? hi : v;
}

static float float_from_bits(uint32_t bits)
{
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

/* ------------------------------------------------------------------------------------------------ */
/* golden vectors                                                                                   */
/* ------------------------------------------------------------------------------------------------ */

static void check_message_case(const char *js, const json_tok_t *t, const hil_octet_t *bin, size_t bin_len)
{
    char name[64];
    const hil_message_info_t *m;
    hil_octet_t payload[64];
    hil_octet_t packed[64];
    double raw[MAX_SIGNALS];
    double raw2[MAX_SIGNALS];
    int n_payload;
    int ok;
    int phys_obj;
    int raw_obj;
    uint16_t i;

    if (json_copy(js, member(js, t, 0, "name"), name, sizeof name) != 0 || name[0] == '\0') {
        CHECK(0, "no message name");
        return;
    }
    m = hil_message_by_name(name);
    CHECK(m != NULL, "unknown message %s", name);
    if (m == NULL) {
        return;
    }
    CHECK(deq(json_number(js, member(js, t, 0, "frame_id"), &ok), (double)m->frame_id) && ok,
          "frame_id of %s", name);
    n_payload = hex_decode(js, member(js, t, 0, "payload_hex"), payload, sizeof payload);
    CHECK(n_payload == (int)m->length, "payload length %d, expected %u", n_payload, (unsigned)m->length);
    CHECK(bin_len == m->length && octets_equal(bin, payload, bin_len), ".bin differs from payload_hex");
    if (n_payload != (int)m->length) {
        return;
    }
    phys_obj = json_get(js, t, 0, "physical");
    raw_obj = json_get(js, t, 0, "raw");
    for (i = 0u; i < m->n_signals; i++) {
        raw[i] = json_number(js, member(js, t, raw_obj, m->signals[i].name), &ok);
        CHECK(ok, "raw %s is missing or not a number", m->signals[i].name);
    }

    /* pack(raw) == payload, unpack(payload) == raw */
    memset(packed, 0xAA, sizeof packed);
    CHECK(hil_reflect_pack(m, raw, packed, sizeof packed) == (int)m->length, "pack failed");
    CHECK(octets_equal(packed, payload, m->length), "pack(raw) != payload");
    CHECK(hil_reflect_unpack(m, raw2, payload, m->length) == 0, "unpack failed");
    for (i = 0u; i < m->n_signals; i++) {
        CHECK(same_bits(raw[i], raw2[i]), "unpack %s: %.17g, expected %.17g", m->signals[i].name, raw2[i], raw[i]);
    }
    CHECK(hil_reflect_pack(m, raw, packed, (size_t)m->length - 1u) == -1, "pack into a short buffer");
    CHECK(hil_reflect_unpack(m, raw2, payload, (size_t)m->length - 1u) == -1, "unpack of a short payload");

    /* per signal: encode, decode, range */
    for (i = 0u; i < m->n_signals; i++) {
        const hil_signal_info_t *s = &m->signals[i];
        int pt = json_get(js, t, phys_obj, s->name);
        double phys;
        double enc = 0.0;
        float dec = 0.0f;
        int in_range = -1;
        if (pt < 0) {
            CHECK(0, "no physical value for %s", s->name);
            continue;
        }
        if (t[pt].type == JSON_STRING) {
            CHECK(json_eq(js, &t[pt], "OFF") && strcmp(name, "DUTY") == 0, "unexpected choice for %s", s->name);
            CHECK(same_bits(raw[i], (double)HIL_DUTY_RAW_OFF), "%s OFF must be raw %u", s->name,
                  (unsigned)HIL_DUTY_RAW_OFF);
            CHECK(hil_reflect_is_in_range(m, i, raw[i], &in_range) == 0 && in_range == 0,
                  "OFF lies outside the duty range");
            continue;
        }
        phys = json_number(js, &t[pt], &ok);
        CHECK(ok, "physical %s is not a number", s->name);
        /* encode takes a float: check it when the value is a binary32 number (all scaled vectors are) */
        if (same_bits((double)(float)phys, phys)) {
            CHECK(hil_reflect_encode(m, i, (float)phys, &enc) == 0, "encode %s", s->name);
            CHECK(same_bits(enc, raw[i]), "encode %s(%.17g) = %.17g, expected %.17g", s->name, phys, enc, raw[i]);
        } else {
            CHECK(s->kind != HIL_SIG_FLOAT && deq(s->scale, 1.0), "%s: physical %.17g is not binary32", s->name, phys);
        }
        CHECK(hil_reflect_decode(m, i, raw[i], &dec) == 0, "decode %s", s->name);
        if (s->kind == HIL_SIG_FLOAT) {
            CHECK(float_bits_equal(dec, (float)phys), "decode %s: %.9g != %.9g", s->name, (double)dec, phys);
        } else {
            double tol = fabs(s->scale) * 0.5 + fabs(phys) * 1.2e-7; /* half an LSB + binary32 rounding */
            double diff = fabs((double)dec - phys);
            if (s->cyclic) { /* an angle: equal modulo one turn (the vector's "wraps") */
                double turn = s->scale * (s->type_max + 1.0);
                diff = fmod(diff, turn);
                diff = diff > 0.5 * turn ? turn - diff : diff;
                tol += 4.0 * 1.2e-7 * turn;
            }
            CHECK(diff <= tol, "decode %s: %.9g, physical %.17g", s->name, (double)dec, phys);
        }
        CHECK(hil_reflect_is_in_range(m, i, raw[i], &in_range) == 0 && in_range == 1, "%s not in range", s->name);
    }
}

static void check_stream_case(const char *js, const json_tok_t *t, const hil_octet_t *bin, size_t bin_len)
{
    static const char *const names[6] = {"frames_ok", "crc_errors", "cobs_errors",
                                         "length_errors", "overruns", "bytes_discarded"};
    hil_deframer_t d;
    hil_frame_t got[32];
    hil_frame_t frame;
    int n_got = 0;
    int frames = json_get(js, t, 0, "frames");
    int counters = json_get(js, t, 0, "counters");
    uint32_t values[6];
    size_t i;
    int k;

    hil_deframer_init(&d);
    for (i = 0u; i < bin_len; i++) {
        if (hil_deframer_push(&d, bin[i], &frame) == 1) {
            if (n_got < 32) {
                got[n_got] = frame;
            }
            n_got++;
        }
    }
    CHECK(frames >= 0 && n_got == t[frames].count, "%d frames, expected %d", n_got, frames >= 0 ? t[frames].count : -1);
    for (k = 0; frames >= 0 && k < t[frames].count && k < n_got && k < 32; k++) {
        int f = json_at(t, frames, k);
        hil_octet_t payload[HIL_FRAME_MAX_DATA];
        hil_octet_t wire[HIL_FRAME_MAX_WIRE];
        hil_octet_t encoded[HIL_FRAME_MAX_WIRE + 8];
        int ok;
        double id = json_number(js, member(js, t, f, "id"), &ok);
        int n = hex_decode(js, member(js, t, f, "payload_hex"), payload, sizeof payload);
        int n_wire = hex_decode(js, member(js, t, f, "wire_hex"), wire, sizeof wire);
        size_t n_enc;
        CHECK(ok && deq((double)got[k].id, id), "frame %d id 0x%X, expected 0x%X", k, (unsigned)got[k].id, (unsigned)id);
        CHECK(n >= 0 && got[k].dlc == (uint16_t)n && octets_equal(got[k].data, payload, (size_t)n),
              "frame %d payload", k);
        n_enc = hil_frame_encode(encoded, sizeof encoded, (uint16_t)id, payload, (size_t)(n < 0 ? 0 : n));
        CHECK(n_wire > 0 && n_enc == (size_t)n_wire && octets_equal(encoded, wire, n_enc),
              "frame %d: hil_frame_encode differs from wire_hex", k);
    }
    values[0] = d.frames_ok;
    values[1] = d.crc_errors;
    values[2] = d.cobs_errors;
    values[3] = d.length_errors;
    values[4] = d.overruns;
    values[5] = d.bytes_discarded;
    for (k = 0; k < 6; k++) {
        int ok;
        double want = json_number(js, member(js, t, counters, names[k]), &ok);
        CHECK(ok && deq((double)values[k], want), "%s = %lu, expected %.0f", names[k], (unsigned long)values[k], want);
    }
}

static int run_vectors(const char *root)
{
    static json_tok_t index_toks[MAX_TOKS];
    static json_tok_t toks[MAX_TOKS];
    char path[1024];
    char name[128];
    size_t len;
    char *index;
    int n;
    int cases;
    int k;
    int n_msg = 0;
    int n_stream = 0;

    snprintf(path, sizeof path, "%s/protocol/vectors/index.json", root);
    index = read_file(path, &len);
    if (index == NULL) {
        fprintf(stderr, "cannot read %s\n", path);
        return 1;
    }
    n = json_parse(index, len, index_toks, MAX_TOKS);
    cases = (n > 0) ? json_get(index, index_toks, 0, "cases") : -1;
    if (cases < 0) {
        fprintf(stderr, "%s: no case list\n", path);
        free(index);
        return 1;
    }
    for (k = 0; k < index_toks[cases].count; k++) {
        char *js;
        char *bin;
        size_t js_len;
        size_t bin_len;
        int kind;
        int at = json_at(index_toks, cases, k);
        if (at < 0 || json_copy(index, &index_toks[at], name, sizeof name) != 0) {
            CHECK(0, "bad case list");
            continue;
        }
        g_case = name;
        snprintf(path, sizeof path, "%s/protocol/vectors/%s.json", root, name);
        js = read_file(path, &js_len);
        snprintf(path, sizeof path, "%s/protocol/vectors/%s.bin", root, name);
        bin = read_file(path, &bin_len);
        CHECK(js != NULL && bin != NULL && bin_len <= MAX_BIN, "cannot read the case files");
        if (js != NULL && bin != NULL) {
            n = json_parse(js, js_len, toks, MAX_TOKS);
            CHECK(n > 0, "JSON parse error %d", n);
            kind = (n > 0) ? json_get(js, toks, 0, "kind") : -1;
            if (kind >= 0 && json_eq(js, &toks[kind], "message")) {
                check_message_case(js, toks, (const hil_octet_t *)(const void *)bin, bin_len);
                n_msg++;
            } else if (kind >= 0 && json_eq(js, &toks[kind], "stream")) {
                check_stream_case(js, toks, (const hil_octet_t *)(const void *)bin, bin_len);
                n_stream++;
            } else {
                CHECK(0, "unknown kind");
            }
        }
        free(js);
        free(bin);
    }
    free(index);
    g_case = "summary";
    CHECK(n_msg > 0 && n_stream > 0, "no cases");
    printf("vectors: %d message cases, %d stream cases\n", n_msg, n_stream);
    return 0;
}

/* ------------------------------------------------------------------------------------------------ */
/* round trips and properties                                                                       */
/* ------------------------------------------------------------------------------------------------ */

static double random_raw(const hil_signal_info_t *s)
{
    if (s->kind == HIL_SIG_FLOAT) {
        return (double)float_from_bits(rnd32()); /* any bit pattern, NaN and infinities included */
    }
    return rnd_between(s->type_min, s->type_max);
}

static void used_bits_mask(const hil_message_info_t *m, hil_octet_t *mask)
{
    uint16_t i;
    uint16_t b;
    memset(mask, 0, 64u * sizeof mask[0]);
    for (i = 0u; i < m->n_signals; i++) {
        for (b = 0u; b < m->signals[i].length_bits; b++) {
            unsigned int bit = (unsigned int)m->signals[i].start_bit + b;
            mask[bit / 8u] = (hil_octet_t)(mask[bit / 8u] | (1u << (bit % 8u)));
        }
    }
}

static void roundtrip_messages(void)
{
    size_t k;
    for (k = 0u; k < hil_message_count; k++) {
        const hil_message_info_t *m = &hil_messages[k];
        hil_octet_t mask[64];
        int iter;
        g_case = m->name;
        used_bits_mask(m, mask);
        for (iter = 0; iter < 2000; iter++) {
            double raw[MAX_SIGNALS];
            double raw2[MAX_SIGNALS];
            hil_octet_t buf[64];
            hil_octet_t buf2[64];
            int nan_seen;
            uint16_t i;
            /* raw -> payload -> raw */
            for (i = 0u; i < m->n_signals; i++) {
                raw[i] = random_raw(&m->signals[i]);
            }
            CHECK(hil_reflect_pack(m, raw, buf, sizeof buf) == (int)m->length, "pack");
            CHECK(hil_reflect_unpack(m, raw2, buf, m->length) == 0, "unpack");
            for (i = 0u; i < m->n_signals; i++) {
                CHECK(same_bits(raw[i], raw2[i]) || (isnan(raw[i]) && isnan(raw2[i])),
                      "%s: %.17g -> %.17g", m->signals[i].name, raw[i], raw2[i]);
            }
            /* random payload -> raw -> payload (padding bits come back as zero) */
            for (i = 0u; i < m->length; i++) {
                buf[i] = (hil_octet_t)(rnd32() & 0xFFu);
            }
            CHECK(hil_reflect_unpack(m, raw, buf, m->length) == 0, "unpack");
            CHECK(hil_reflect_pack(m, raw, buf2, sizeof buf2) == (int)m->length, "pack");
            nan_seen = 0;
            for (i = 0u; i < m->n_signals; i++) {
                nan_seen |= isnan(raw[i]); /* carrying a signalling NaN through a double quiets it */
            }
            for (i = 0u; i < m->length && !nan_seen; i++) {
                CHECK((buf2[i] & 0xFFu) == (buf[i] & mask[i] & 0xFFu), "octet %u", (unsigned)i);
            }
            /* encode(decode(raw)) == raw inside the DBC range (where binary32 can hold the value) */
            for (i = 0u; i < m->n_signals; i++) {
                const hil_signal_info_t *s = &m->signals[i];
                double lo = s->raw_min;
                double hi = s->raw_max;
                double r;
                double back = 0.0;
                float phys = 0.0f;
                int in_range = 0;
                if (s->kind == HIL_SIG_FLOAT) {
                    continue;
                }
                if (hi - lo > 16777216.0) { /* 24-bit mantissa of the float argument */
                    lo = -8388608.0;
                    hi = 8388608.0;
                }
                r = rnd_between(lo, hi);
                CHECK(hil_reflect_decode(m, i, r, &phys) == 0, "decode");
                CHECK(hil_reflect_encode(m, i, phys, &back) == 0, "encode");
                CHECK(same_bits(back, r), "%s: encode(decode(%.0f)) = %.0f", s->name, r, back);
                CHECK(hil_reflect_is_in_range(m, i, r, &in_range) == 0 && in_range == 1, "%s in range", s->name);
            }
        }
    }
}

static void properties_of_signals(void)
{
    size_t k;
    for (k = 0u; k < hil_message_count; k++) {
        const hil_message_info_t *m = &hil_messages[k];
        uint16_t i;
        g_case = m->name;
        for (i = 0u; i < m->n_signals; i++) {
            const hil_signal_info_t *s = &m->signals[i];
            double raw = 0.0;
            int in_range = -1;
            float huge = 3.0e38f;
            double zero_raw = (0.0 < s->raw_min) ? s->raw_min : ((0.0 > s->raw_max) ? s->raw_max : 0.0);
            if (s->kind == HIL_SIG_FLOAT) {
                hil_reflect_encode(m, i, (float)NAN, &raw);
                CHECK(same_bits(raw, 0.0), "%s: NaN encodes as 0", s->name);
                hil_reflect_encode(m, i, (float)INFINITY, &raw);
                CHECK(same_bits(raw, (double)(float)s->maximum), "%s: +inf saturates", s->name);
                hil_reflect_is_in_range(m, i, (double)NAN, &in_range);
                CHECK(in_range == 0, "%s: NaN is not in range", s->name);
                hil_reflect_is_in_range(m, i, (double)INFINITY, &in_range);
                CHECK(in_range == 0, "%s: inf is not in range", s->name);
                continue;
            }
            if (s->cyclic) { /* angles wrap: every finite value lands in the raw range, inf/NaN at 0 */
                hil_reflect_encode(m, i, huge, &raw);
                CHECK(raw >= 0.0 && raw <= s->type_max, "%s: +huge wraps into the range", s->name);
                hil_reflect_encode(m, i, -huge, &raw);
                CHECK(raw >= 0.0 && raw <= s->type_max, "%s: -huge wraps into the range", s->name);
                hil_reflect_encode(m, i, (float)INFINITY, &raw);
                CHECK(same_bits(raw, 0.0), "%s: +inf encodes as 0", s->name);
                hil_reflect_encode(m, i, (float)NAN, &raw);
                CHECK(same_bits(raw, 0.0), "%s: NaN encodes as 0", s->name);
                CHECK(s->raw_min <= 0.0 && s->raw_max >= s->type_max, "%s: one turn is the whole raw range",
                      s->name);
                continue;
            }
            hil_reflect_encode(m, i, huge, &raw);
            CHECK(same_bits(raw, s->scale > 0.0 ? s->raw_max : s->raw_min), "%s: +huge saturates", s->name);
            hil_reflect_encode(m, i, -huge, &raw);
            CHECK(same_bits(raw, s->scale > 0.0 ? s->raw_min : s->raw_max), "%s: -huge saturates", s->name);
            hil_reflect_encode(m, i, (float)INFINITY, &raw);
            CHECK(same_bits(raw, s->scale > 0.0 ? s->raw_max : s->raw_min), "%s: +inf saturates", s->name);
            hil_reflect_encode(m, i, (float)NAN, &raw);
            CHECK(same_bits(raw, zero_raw), "%s: NaN encodes as %.0f, got %.0f", s->name, zero_raw, raw);
            CHECK(hil_reflect_is_in_range(m, i, s->raw_min, &in_range) == 0 && in_range == 1, "%s raw_min", s->name);
            CHECK(hil_reflect_is_in_range(m, i, s->raw_max, &in_range) == 0 && in_range == 1, "%s raw_max", s->name);
            if (s->raw_min > s->type_min) {
                hil_reflect_is_in_range(m, i, s->raw_min - 1.0, &in_range);
                CHECK(in_range == 0, "%s raw_min - 1", s->name);
            }
            if (s->raw_max < s->type_max) {
                hil_reflect_is_in_range(m, i, s->raw_max + 1.0, &in_range);
                CHECK(in_range == 0, "%s raw_max + 1", s->name);
            }
        }
    }
}

static void direct_api(void)
{
    hil_sense_t s;
    hil_sense_t s2;
    hil_duty_t duty;
    hil_hello_t hello;
    hil_octet_t buf[HIL_SENSE_LENGTH];
    g_case = "direct API";
    /* rounding: ties away from zero (0.0625 A = 62.5 LSB); with float math (HIL_MSGS_CALC_FLOAT) the
     * quotient 0.0625f / 0.001f is not exactly 62.5 and may round either way */
#if defined(HIL_TEST_CALC_FLOAT)
    CHECK(abs(hil_sense_i_a_encode(0.0625f) - 63) <= 1, "0.0625 A -> 63 +- 1");
    CHECK(abs(hil_sense_i_a_encode(-0.0625f) + 63) <= 1, "-0.0625 A -> -63 +- 1");
#else
    CHECK(hil_sense_i_a_encode(0.0625f) == 63, "0.0625 A -> 63");
    CHECK(hil_sense_i_a_encode(-0.0625f) == -63, "-0.0625 A -> -63");
#endif
    CHECK(hil_duty_d_a_encode(100.5f / 32768.0f) == 101u, "duty ties are exact in float too");
    CHECK(hil_sense_i_a_encode(1.5f) == 1500, "1.5 A");
    CHECK(hil_sense_i_a_encode(40.0f) == 32767 && hil_sense_i_a_encode(-40.0f) == -32768, "saturation");
    CHECK(hil_duty_d_a_encode(0.5f) == 16384u && hil_duty_d_a_encode(1.0f) == 32768u, "duty 0.5 / 1.0");
    CHECK(hil_duty_d_a_encode(1.5f) == HIL_DUTY_D_A_RAW_MAX && hil_duty_d_a_encode(-0.1f) == 0u, "duty saturation");
    CHECK(hil_duty_d_a_is_in_range(HIL_DUTY_RAW_OFF) == 0 && hil_duty_d_a_is_in_range(32769u) == 0, "duty range");
    CHECK(hil_hello_proto_version_is_in_range(256u) == 0, "an 8-bit signal in a 16-bit field: 256 is out");
    /* angles wrap at 2 pi (raw 65536 is raw 0), also from below */
    CHECK(hil_telem_theta_hat_encode(6.2831853f) == 0u, "2 pi encodes as 0");
    CHECK(hil_telem_theta_hat_encode(6.28317f) == 0u, "2 pi - 1.5e-5 rounds to 65536 = 0");
    CHECK(hil_sense_aux_theta_enc_encode(-0.5f) == 60321u, "-0.5 rad = 2 pi - 0.5: raw 60321, got %u",
          (unsigned)hil_sense_aux_theta_enc_encode(-0.5f));
    CHECK(hil_telem_theta_hat_encode(3.14159265f) == 32768u, "pi = raw 32768");
    CHECK(hil_telem_theta_hat_encode(6.2830894f) == 65535u, "the largest angle = raw 65535");
    CHECK(hil_hello_mode_is_in_range(HIL_MODE_REALTIME) == 1 && hil_hello_mode_is_in_range(2u) == 0, "mode");
    s.seq = 65535u;
    s.i_a = -1;
    s.i_b = (int16_t)-32768;
    s.i_c = 32767;
    CHECK(hil_sense_pack(buf, &s, sizeof buf) == (int)HIL_SENSE_LENGTH, "pack SENSE");
    CHECK((buf[0] & 0xFFu) == 0xFFu && (buf[2] & 0xFFu) == 0xFFu && (buf[5] & 0xFFu) == 0x80u
          && (buf[7] & 0xFFu) == 0x7Fu, "SENSE little-endian layout");
    CHECK(hil_sense_unpack(&s2, buf, sizeof buf) == 0 && s2.seq == s.seq && s2.i_a == s.i_a && s2.i_b == s.i_b
          && s2.i_c == s.i_c, "SENSE round trip");
    CHECK(hil_sense_pack(buf, &s, 7u) == -1 && hil_sense_unpack(&s2, buf, 7u) == -1, "size checks");
    CHECK(hil_sense_pack(NULL, &s, 8u) == -1 && hil_sense_unpack(&s2, NULL, 8u) == -1, "NULL checks");
    duty.seq = 1u;
    duty.d_a = HIL_DUTY_RAW_OFF;
    duty.d_b = hil_duty_d_b_encode(0.5f);
    duty.d_c = 0u;
    CHECK(hil_duty_pack(buf, &duty, sizeof buf) == 8, "pack DUTY");
    CHECK((buf[2] & 0xFFu) == 0xFFu && (buf[3] & 0xFFu) == 0xFFu && (buf[5] & 0xFFu) == 0x40u, "DUTY OFF on the wire");
    hello.proto_version = HIL_PROTO_VERSION;
    hello.proto_minor = HIL_PROTO_VERSION_MINOR;
    hello.mode = HIL_MODE_LOCKSTEP;
    hello.period_us = hil_hello_period_us_encode(50.0f);
    hello.estimator = HIL_EST_SMO_SIGN;
    hello.flags = HIL_HELLO_FLAG_DUAL_SAMPLING | HIL_HELLO_FLAG_TELEM_EMF;
    hello.session = 0xBEEFu;
    CHECK(hello.period_us == 500u && HIL_PARAM_RS_OHM == 1 && HIL_CMD_RUN == 1 && HIL_STATE_STOPPED == 6,
          "constants");
}

static void framing_properties(void)
{
    static const hil_octet_t check[9] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    hil_octet_t data[HIL_FRAME_MAX_DATA];
    hil_octet_t wire[HIL_FRAME_MAX_WIRE];
    hil_octet_t stream[8192];
    uint16_t sent_id[256];
    uint16_t sent_dlc[256];
    hil_octet_t sent_data[256][HIL_FRAME_MAX_DATA];
    hil_deframer_t d;
    hil_frame_t out;
    size_t n;
    size_t len = 0u;
    int n_sent = 0;
    int n_got = 0;
    int k;
    size_t i;
    g_case = "framing";
    CHECK(hil_crc16(check, 9u) == 0x29B1u, "CRC-16/CCITT-FALSE check value");
    CHECK(HIL_FRAME_MAX_WIRE == 71u && HIL_FRAME_MAX_COBS == 70u, "worst-case sizes");
    memset(data, 0, sizeof data);
    CHECK(hil_frame_encode(wire, sizeof wire, 0x800u, data, 8u) == 0u, "id 0x800 rejected");
    CHECK(hil_frame_encode(wire, sizeof wire, 0x100u, data, 65u) == 0u, "dlc 65 rejected");
    CHECK(hil_frame_encode(wire, 14u, 0x100u, data, 8u) == 0u, "short destination rejected");
    CHECK(hil_frame_encode(wire, 15u, 0x100u, data, 8u) == 15u, "exact destination accepted");
    CHECK(hil_frame_encode(wire, sizeof wire, 0x100u, NULL, 1u) == 0u, "NULL data rejected");
    CHECK(hil_frame_encode(wire, sizeof wire, 0x7FFu, NULL, 0u) == 7u, "empty frame");
    for (k = 0; k < 256; k++) {
        CHECK(hil_frame_encode(wire, sizeof wire, 0x7FFu, data, 64u) == HIL_FRAME_MAX_WIRE, "64-octet frame");
        data[0] = (hil_octet_t)k;
    }
    /* random frames, each preceded by random garbage (sometimes containing 0x00) and a delimiter */
    hil_deframer_init(&d);
    while (n_sent < 256) {
        size_t garbage = rnd32() % 24u;
        uint16_t id = (uint16_t)(rnd32() & 0x7FFu);
        uint16_t dlc = (uint16_t)(rnd32() % 65u);
        for (i = 0u; i < garbage; i++) {
            stream[len++] = (hil_octet_t)(rnd32() & 0xFFu);
        }
        stream[len++] = 0u;
        for (i = 0u; i < dlc; i++) {
            sent_data[n_sent][i] = (hil_octet_t)(rnd32() & ((rnd32() & 1u) ? 0xFFu : 0x00u));
        }
        n = hil_frame_encode(stream + len, sizeof stream - len, id, sent_data[n_sent], dlc);
        if (n == 0u) {
            break;
        }
        len += n;
        sent_id[n_sent] = id;
        sent_dlc[n_sent] = dlc;
        n_sent++;
        if (len + 200u > sizeof stream) {
            break;
        }
    }
    for (i = 0u; i < len; i++) {
        if (hil_deframer_push(&d, stream[i], &out) == 1) {
            /* every delivered frame is the next one sent, or garbage that passed COBS+length+CRC+id */
            while (n_got < n_sent && (out.id != sent_id[n_got] || out.dlc != sent_dlc[n_got]
                                      || !octets_equal(out.data, sent_data[n_got], out.dlc))) {
                n_got++;
                CHECK(0, "sent frame %d lost or a garbage frame delivered", n_got);
            }
            n_got++;
        }
    }
    CHECK(n_got == n_sent && d.frames_ok == (uint32_t)n_sent, "%d of %d frames recovered", n_got, n_sent);
    CHECK(len > 1000u, "stream too short");
}

int main(int argc, char **argv)
{
    int rc;
    if (argc == 2 && strcmp(argv[1], "--roundtrip") == 0) {
        roundtrip_messages();
        properties_of_signals();
        direct_api();
        framing_properties();
        printf("roundtrip: %ld checks, %d failures\n", g_checks, g_failures);
        return g_failures == 0 ? 0 : 1;
    }
    if (argc != 2) {
        fprintf(stderr, "usage: %s <repo root> | --roundtrip\n", argv[0]);
        return 2;
    }
    rc = run_vectors(argv[1]);
    printf("vectors: %ld checks, %d failures\n", g_checks, g_failures);
    return (rc == 0 && g_failures == 0) ? 0 : 1;
}
