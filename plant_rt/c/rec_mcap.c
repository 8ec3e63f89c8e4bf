/* The recorder's fast path (rec_mcap.h). */
#include "rec_mcap.h"

#include <string.h>

#include "rec_ring.h"

static uint8_t *put_le(uint8_t *p, uint64_t v, unsigned n)
{
    unsigned i;
    for (i = 0u; i < n; ++i) {
        p[i] = (uint8_t)(v >> (8u * i));
    }
    return p + n;
}

void rec_to_mcap(const uint8_t *in, size_t n_in, const int32_t *channel_map, size_t n_map,
                 uint32_t *seqs, int64_t start_ns, size_t limit, uint8_t *out, size_t out_cap,
                 rec_mcap_entry_t *entries, size_t entries_cap, uint8_t *raw_out, size_t raw_cap,
                 rec_mcap_result_t *res)
{
    size_t off = 0u;
    memset(res, 0, sizeof *res);
    while (off + sizeof(rec_ring_record_t) <= n_in) {
        rec_ring_record_t h;
        const uint8_t *payload;
        size_t next;
        int32_t map;
        memcpy(&h, in + off, sizeof h);
        next = off + sizeof h + (((size_t)h.length + 7u) & ~(size_t)7u);
        if (next > n_in) {
            break; /* a record cut by the batch (cannot happen: rec_ring_read copies whole ones) */
        }
        payload = in + off + sizeof h;
        map = (h.channel < n_map) ? channel_map[h.channel] : REC_MCAP_SKIP;
        if (map == REC_MCAP_RAW) {
            const size_t need = 13u + (h.length ? (size_t)h.length - 1u : 0u);
            uint8_t *p;
            if (h.length == 0u) {
                off = next;
                continue;
            }
            if (res->raw_len + need > raw_cap) {
                break;
            }
            p = raw_out + res->raw_len;
            p = put_le(p, (uint64_t)h.t_ns, 8u);
            *p++ = payload[0];                        /* direction */
            p = put_le(p, (uint64_t)(h.length - 1u), 4u);
            memcpy(p, payload + 1, (size_t)h.length - 1u);
            res->raw_len += need;
        } else if (map >= 0) {
            const size_t need = REC_MCAP_MESSAGE_OVERHEAD + (size_t)h.length;
            const uint64_t t = (uint64_t)(start_ns + h.t_ns);
            uint8_t *p;
            rec_mcap_entry_t *e;
            if (res->out_len + need > out_cap || res->n_entries >= entries_cap) {
                break;
            }
            p = out + res->out_len;
            e = &entries[res->n_entries++];
            e->offset = res->out_len;
            e->log_time = t;
            e->channel_id = (uint16_t)map;
            e->pad_[0] = e->pad_[1] = e->pad_[2] = 0u;
            *p++ = 0x05u;                                        /* opcode: Message */
            p = put_le(p, 22u + (uint64_t)h.length, 8u);         /* record length */
            p = put_le(p, (uint64_t)(uint16_t)map, 2u);
            p = put_le(p, (uint64_t)seqs[h.channel]++, 4u);
            p = put_le(p, t, 8u);                                 /* log time */
            p = put_le(p, t, 8u);                                 /* publish time */
            memcpy(p, payload, h.length);
            res->out_len += need;
        }
        off = next;
        if (res->out_len > limit) {
            res->stopped_at_limit = 1;
            break;
        }
    }
    res->in_used = off;
}
