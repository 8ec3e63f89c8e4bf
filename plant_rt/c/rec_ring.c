/* Single-producer single-consumer ring of recorded messages (rec_ring.h). */
#include "rec_ring.h"

#include <string.h>

#define ALIGN8(n) (((n) + 7u) & ~(uint64_t)7u)

static uint64_t load_acquire(const uint64_t *p)
{
    return __atomic_load_n(p, __ATOMIC_ACQUIRE);
}

static void store_release(uint64_t *p, uint64_t v)
{
    __atomic_store_n(p, v, __ATOMIC_RELEASE);
}

size_t rec_ring_mapping_size(size_t capacity)
{
    return REC_RING_HEADER_SIZE + (size_t)ALIGN8((uint64_t)capacity);
}

int rec_ring_format(void *mem, size_t mapping_size)
{
    rec_ring_header_t *h = (rec_ring_header_t *)mem;
    if (mem == NULL || mapping_size < REC_RING_HEADER_SIZE + 4096u) {
        return -1;
    }
    memset(h, 0, sizeof *h);
    h->capacity = (uint64_t)(mapping_size - REC_RING_HEADER_SIZE) & ~(uint64_t)7u;
    store_release(&h->magic, REC_RING_MAGIC);
    return 0;
}

int rec_ring_attach(rec_ring_t *r, void *mem, size_t mapping_size)
{
    rec_ring_header_t *h = (rec_ring_header_t *)mem;
    if (mem == NULL || mapping_size < REC_RING_HEADER_SIZE || h->magic != REC_RING_MAGIC ||
        h->capacity + REC_RING_HEADER_SIZE > mapping_size) {
        return -1;
    }
    r->hdr = h;
    r->data = (uint8_t *)mem + REC_RING_HEADER_SIZE;
    r->reserve_pos = 0u;
    r->reserve_len = 0u;
    return 0;
}

uint8_t *rec_ring_begin(rec_ring_t *r, size_t max_payload)
{
    rec_ring_header_t *h = r->hdr;
    const uint64_t cap = h->capacity;
    const uint64_t need = ALIGN8((uint64_t)max_payload) + REC_RING_RECORD_HEADER;
    const uint64_t head = h->head; /* only this producer writes it */
    const uint64_t tail = load_acquire(&h->tail);
    const uint64_t pos = head % cap;
    const uint64_t to_end = cap - pos;
    uint64_t skip = 0u;
    if (need > cap / 2u) {
        return NULL;
    }
    if (to_end < need) {
        skip = to_end; /* the record would cross the end: pad to it and start at 0 */
    }
    if (head + skip + need - tail > cap) {
        return NULL;
    }
    if (skip > 0u) {
        if (skip >= REC_RING_RECORD_HEADER) {
            rec_ring_record_t pad;
            pad.length = (uint32_t)(skip - REC_RING_RECORD_HEADER);
            pad.channel = REC_RING_PAD_CHANNEL;
            pad.flags = 0u;
            pad.t_ns = 0;
            memcpy(r->data + pos, &pad, sizeof pad);
        }
        /* publish the pad on its own: the consumer may skip it before the record is ready */
        store_release(&h->head, head + skip);
    }
    r->reserve_pos = head + skip;
    r->reserve_len = need;
    return r->data + (r->reserve_pos % cap) + REC_RING_RECORD_HEADER;
}

void rec_ring_commit(rec_ring_t *r, uint16_t channel, int64_t t_ns, size_t payload_len)
{
    rec_ring_header_t *h = r->hdr;
    rec_ring_record_t rec;
    const uint64_t len = ALIGN8((uint64_t)payload_len) + REC_RING_RECORD_HEADER;
    rec.length = (uint32_t)payload_len;
    rec.channel = channel;
    rec.flags = 0u;
    rec.t_ns = t_ns;
    memcpy(r->data + (r->reserve_pos % h->capacity), &rec, sizeof rec);
    h->records_written++;
    store_release(&h->head, r->reserve_pos + (len < r->reserve_len ? len : r->reserve_len));
    r->reserve_len = 0u;
}

void rec_ring_count_drop(rec_ring_t *r, size_t len)
{
    r->hdr->records_dropped++;
    r->hdr->bytes_dropped += (uint64_t)len;
}

int rec_ring_write(rec_ring_t *r, uint16_t channel, int64_t t_ns, const void *payload, size_t len)
{
    uint8_t *p = rec_ring_begin(r, len);
    if (p == NULL) {
        rec_ring_count_drop(r, len);
        return -1;
    }
    if (len > 0u) {
        memcpy(p, payload, len);
    }
    rec_ring_commit(r, channel, t_ns, len);
    return 0;
}

void rec_ring_close(rec_ring_t *r)
{
    __atomic_store_n(&r->hdr->producer_closed, 1u, __ATOMIC_RELEASE);
}

uint64_t rec_ring_pending(const rec_ring_t *r)
{
    return load_acquire(&r->hdr->head) - r->hdr->tail;
}

size_t rec_ring_read(rec_ring_t *r, uint8_t *out, size_t cap)
{
    rec_ring_header_t *h = r->hdr;
    const uint64_t rcap = h->capacity;
    const uint64_t head = load_acquire(&h->head);
    uint64_t tail = h->tail;
    size_t copied = 0u;
    while (tail < head) {
        const uint64_t pos = tail % rcap;
        const uint64_t to_end = rcap - pos;
        rec_ring_record_t rec;
        uint64_t len;
        if (to_end < REC_RING_RECORD_HEADER) {
            tail += to_end; /* a tail too short for a header: the producer wrapped */
            continue;
        }
        memcpy(&rec, r->data + pos, sizeof rec);
        len = ALIGN8((uint64_t)rec.length) + REC_RING_RECORD_HEADER;
        if (rec.channel == REC_RING_PAD_CHANNEL) {
            tail += len;
            continue;
        }
        if (copied + len > cap) {
            break;
        }
        memcpy(out + copied, r->data + pos, (size_t)len);
        copied += (size_t)len;
        tail += len;
    }
    store_release(&h->tail, tail);
    return copied;
}
