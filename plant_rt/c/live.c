/* The live view's mailbox and the recorder's picker (live.h). */
#include "live.h"

#include <string.h>

#include "rec_ring.h"

size_t live_inbox_size(void)
{
    return sizeof(live_inbox_t);
}

int live_inbox_format(void *mem, size_t size)
{
    live_inbox_t *b = (live_inbox_t *)mem;
    if (mem == NULL || size < sizeof *b) {
        return -1;
    }
    memset(b, 0, sizeof *b);
    __atomic_store_n(&b->magic, LIVE_INBOX_MAGIC, __ATOMIC_RELEASE);
    return 0;
}

live_inbox_t *live_inbox_attach(void *mem, size_t size)
{
    live_inbox_t *b = (live_inbox_t *)mem;
    if (mem == NULL || size < sizeof *b ||
        __atomic_load_n(&b->magic, __ATOMIC_ACQUIRE) != LIVE_INBOX_MAGIC) {
        return NULL;
    }
    return b;
}

int live_inbox_push(live_inbox_t *b, int kind, int client, double value, const char *text)
{
    const uint64_t head = b->head; /* only this producer writes it */
    const uint64_t tail = __atomic_load_n(&b->tail, __ATOMIC_ACQUIRE);
    live_input_t *slot;
    if (head - tail >= LIVE_INBOX_SLOTS) {
        return -1;
    }
    slot = &b->slots[head & (LIVE_INBOX_SLOTS - 1u)];
    slot->kind = (int32_t)kind;
    slot->client = (int32_t)client;
    slot->value = value;
    {
        size_t len = (text != NULL) ? strlen(text) : 0u;
        if (len > sizeof slot->text - 1u) {
            len = sizeof slot->text - 1u;
        }
        if (len > 0u) {
            memcpy(slot->text, text, len);
        }
        slot->text[len] = '\0';
    }
    __atomic_store_n(&b->head, head + 1u, __ATOMIC_RELEASE);
    return 0;
}

int live_inbox_take(live_inbox_t *b, live_input_t *out)
{
    const uint64_t tail = b->tail; /* only this consumer writes it */
    if (__atomic_load_n(&b->head, __ATOMIC_ACQUIRE) == tail) {
        return 0;
    }
    *out = b->slots[tail & (LIVE_INBOX_SLOTS - 1u)];
    out->text[sizeof out->text - 1u] = '\0';
    __atomic_store_n(&b->tail, tail + 1u, __ATOMIC_RELEASE);
    return 1;
}

uint64_t live_inbox_pending(const live_inbox_t *b)
{
    return __atomic_load_n(&b->head, __ATOMIC_ACQUIRE) -
           __atomic_load_n(&b->tail, __ATOMIC_ACQUIRE);
}

/** Each record of a batch in turn: its header into *h and where the next one starts; 0 at the
 *  end (or at a record the batch cuts, which rec_ring_read never does). */
static int next_record(const uint8_t *in, size_t n_in, size_t off, rec_ring_record_t *h,
                       size_t *next)
{
    if (off + sizeof *h > n_in) {
        return 0;
    }
    memcpy(h, in + off, sizeof *h);
    *next = off + sizeof *h + (((size_t)h->length + 7u) & ~(size_t)7u);
    return *next <= n_in;
}

size_t live_pick(const uint8_t *in, size_t n_in, const int32_t *mode, size_t n_mode,
                 live_pick_t *picks, size_t cap, uint64_t *cut)
{
    /* where the last record of each LIVE_LAST channel starts (+1; 0: none in this batch) */
    uint64_t last[LIVE_PICK_MAX_CHANNELS];
    rec_ring_record_t h;
    size_t off = 0u, next = 0u, n = 0u, c;
    int any_last = 0;
    if (n_mode > LIVE_PICK_MAX_CHANNELS) {
        n_mode = LIVE_PICK_MAX_CHANNELS;
    }
    for (c = 0u; c < n_mode; ++c) {
        last[c] = 0u;
        any_last |= (mode[c] == LIVE_LAST);
    }
    while (any_last && next_record(in, n_in, off, &h, &next)) {
        if (h.channel < n_mode && mode[h.channel] == LIVE_LAST) {
            last[h.channel] = (uint64_t)off + 1u;
        }
        off = next;
    }
    off = 0u;
    while (next_record(in, n_in, off, &h, &next)) {
        const int32_t m = (h.channel < n_mode) ? mode[h.channel] : LIVE_SKIP;
        if (m == LIVE_EVERY || (m == LIVE_LAST && last[h.channel] == (uint64_t)off + 1u)) {
            if (n < cap) {
                live_pick_t *p = &picks[n++];
                p->offset = (uint64_t)(off + sizeof h);
                p->length = h.length;
                p->channel = h.channel;
                p->pad_ = 0u;
                p->t_ns = h.t_ns;
            } else if (cut != NULL) {
                (*cut)++;
            }
        }
        off = next;
    }
    return n;
}
