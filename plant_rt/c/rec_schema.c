/* Protobuf encoders and the layout string of the recorded channels (rec_schema.h). */
#include "rec_schema.h"

#include <string.h>

/* ---- protobuf primitives: write at p if it fits before end, else return NULL --------------- */

static uint8_t *put_varint(uint8_t *p, const uint8_t *end, uint64_t v)
{
    if (p == NULL) {
        return NULL;
    }
    do {
        if (p >= end) {
            return NULL;
        }
        *p++ = (uint8_t)((v & 0x7Fu) | (v > 0x7Fu ? 0x80u : 0u));
        v >>= 7;
    } while (v != 0u);
    return p;
}

static uint8_t *put_le(uint8_t *p, const uint8_t *end, uint64_t v, unsigned n)
{
    unsigned i;
    if (p == NULL || (size_t)(end - p) < n) {
        return NULL;
    }
    for (i = 0u; i < n; ++i) {
        p[i] = (uint8_t)(v >> (8u * i));
    }
    return p + n;
}

static uint8_t *put_F64(uint8_t *p, const uint8_t *end, unsigned field, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    return put_le(put_varint(p, end, ((uint64_t)field << 3) | 1u), end, bits, 8u);
}

static uint8_t *put_CNT(uint8_t *p, const uint8_t *end, unsigned field, uint64_t v)
{
    return put_F64(p, end, field, (double)v);
}

static uint8_t *put_U32(uint8_t *p, const uint8_t *end, unsigned field, uint32_t v)
{
    return put_le(put_varint(p, end, ((uint64_t)field << 3) | 5u), end, v, 4u);
}

static uint8_t *put_I32(uint8_t *p, const uint8_t *end, unsigned field, int32_t v)
{
    return put_U32(p, end, field, (uint32_t)v);
}

static uint8_t *put_STR(uint8_t *p, const uint8_t *end, unsigned field, const char *s)
{
    size_t n = (s != NULL) ? strlen(s) : 0u;
    p = put_varint(put_varint(p, end, ((uint64_t)field << 3) | 2u), end, (uint64_t)n);
    if (p == NULL || (size_t)(end - p) < n) {
        return NULL;
    }
    if (n > 0u) {
        memcpy(p, s, n);
    }
    return p + n;
}

/* ---- one encoder per channel, from its field list ---------------------------------------- */

#define REC_ENUM_(P, T, name) P##_##name,
#define REC_PUT_(P, T, name) p = put_##T(p, end, (unsigned)(P##_##name + 1), m->name);

#define REC_DEFINE_ENCODER(fn, type, LIST, P)                                                  \
    enum { LIST(REC_ENUM_, P) P##_COUNT_ };                                                    \
    size_t fn(uint8_t *out, size_t cap, const type *m)                                         \
    {                                                                                          \
        uint8_t *p = out;                                                                      \
        const uint8_t *end = out + cap;                                                        \
        LIST(REC_PUT_, P)                                                                      \
        return (p != NULL) ? (size_t)(p - out) : 0u;                                           \
    }

REC_DEFINE_ENCODER(rec_encode_plant_state, rec_plant_state_t, REC_PLANT_STATE, PS)
REC_DEFINE_ENCODER(rec_encode_sense, rec_sense_t, REC_SENSE, SE)
REC_DEFINE_ENCODER(rec_encode_telemetry, rec_telemetry_t, REC_TELEMETRY, TE)
REC_DEFINE_ENCODER(rec_encode_reference, rec_reference_t, REC_REFERENCE, RE)
REC_DEFINE_ENCODER(rec_encode_frames, rec_frames_t, REC_FRAMES, FR)
REC_DEFINE_ENCODER(rec_encode_event, rec_event_t, REC_EVENT, EV)
REC_DEFINE_ENCODER(rec_encode_timing, rec_timing_t, REC_TIMING, TI)
REC_DEFINE_ENCODER(rec_encode_link_stats, rec_link_stats_t, REC_LINK_STATS, LS)
REC_DEFINE_ENCODER(rec_encode_replay_controller, rec_replay_controller_t, REC_REPLAY_CONTROLLER, RC)
REC_DEFINE_ENCODER(rec_encode_replay_plant, rec_replay_plant_t, REC_REPLAY_PLANT, RP)
REC_DEFINE_ENCODER(rec_encode_fault, rec_fault_t, REC_FAULT, FA)

/* ---- the layout string --------------------------------------------------------------------- */

#define REC_DESC_(P, T, name) " " #T ":" #name
#define REC_LINE_(K, schema, LIST) #K " " schema LIST(REC_DESC_, x) "\n"

const char *rec_schema_layout(void)
{
    static const char layout[] = REC_CHANNELS(REC_LINE_);
    return layout;
}
