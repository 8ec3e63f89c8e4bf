/* The live view's mailbox and the recorder's picker (live.h). */
#define _GNU_SOURCE /* syscall(): the futex words of a script's session */
#include "live.h"

#include <string.h>
#include <time.h>

#include "rec_ring.h"

#ifdef __linux__
#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

/* ---- futex words (shared between processes: the mapping is MAP_SHARED, so no PRIVATE flag) -- */

static void word_bump_and_wake(uint32_t *word)
{
    __atomic_add_fetch(word, 1u, __ATOMIC_RELEASE);
#ifdef __linux__
    (void)syscall(SYS_futex, word, FUTEX_WAKE, 0x7fffffff, NULL, NULL, 0);
#endif
}

static int word_wait(uint32_t *word, uint32_t seen, int64_t timeout_ns)
{
    struct timespec ts;
    if (__atomic_load_n(word, __ATOMIC_ACQUIRE) != seen) {
        return 1;
    }
    if (timeout_ns <= 0) {
        return 0;
    }
    ts.tv_sec = (time_t)(timeout_ns / 1000000000LL);
    ts.tv_nsec = (long)(timeout_ns % 1000000000LL);
#ifdef __linux__
    /* returns at once if the word is no longer `seen` (EAGAIN), on a wake, a signal, a time-out */
    (void)syscall(SYS_futex, word, FUTEX_WAIT, seen, &ts, NULL, 0);
#else
    (void)nanosleep(&ts, NULL);
#endif
    return __atomic_load_n(word, __ATOMIC_ACQUIRE) != seen;
}

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
    b->held_k = -1;
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

static int push(live_inbox_t *b, int kind, int client, int origin, double value,
                const int32_t *args, const char *text)
{
    const uint64_t head = b->head; /* only this producer writes it */
    const uint64_t tail = __atomic_load_n(&b->tail, __ATOMIC_ACQUIRE);
    live_input_t *slot;
    int i;
    if (head - tail >= LIVE_INBOX_SLOTS) {
        return -1;
    }
    slot = &b->slots[head & (LIVE_INBOX_SLOTS - 1u)];
    slot->kind = (int32_t)kind;
    slot->client = (int32_t)client;
    slot->value = value;
    slot->origin = (int32_t)origin;
    for (i = 0; i < LIVE_INPUT_ARGS; ++i) {
        slot->arg[i] = (args != NULL) ? args[i] : 0;
    }
    slot->pad_ = 0;
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
    word_bump_and_wake(&b->wake);
    return 0;
}

int live_inbox_push(live_inbox_t *b, int kind, int client, double value, const char *text)
{
    return push(b, kind, client, LIVE_FROM_VIEWER, value, NULL, text);
}

int live_inbox_push_input(live_inbox_t *b, int kind, int origin, double value,
                          const int32_t *args, const char *text)
{
    return push(b, kind, origin == LIVE_FROM_SCRIPT ? -1 : 0, origin, value, args, text);
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

/* ---- holds and answers ---- */

void live_inbox_answer(live_inbox_t *b, const char *why)
{
    if (why != NULL) {
        size_t len = strlen(why);
        if (len > sizeof b->refused_text - 1u) {
            len = sizeof b->refused_text - 1u;
        }
        memcpy(b->refused_text, why, len);
        b->refused_text[len] = '\0';
        __atomic_store_n(&b->refused, b->refused + 1u, __ATOMIC_RELAXED);
    }
    __atomic_store_n(&b->answered, b->answered + 1u, __ATOMIC_RELAXED);
    word_bump_and_wake(&b->news); /* release: the answer is visible with the news */
}

void live_inbox_set_held(live_inbox_t *b, int64_t k)
{
    __atomic_store_n(&b->held_k, k < 0 ? -1 : k, __ATOMIC_RELAXED);
    if (k >= 0) {
        word_bump_and_wake(&b->news);
    }
}

uint32_t live_inbox_wake_word(const live_inbox_t *b)
{
    return __atomic_load_n(&b->wake, __ATOMIC_ACQUIRE);
}

uint32_t live_inbox_news(const live_inbox_t *b, int64_t *held_k, uint64_t *answered,
                         uint64_t *refused)
{
    const uint32_t news = __atomic_load_n(&b->news, __ATOMIC_ACQUIRE);
    if (held_k != NULL) {
        *held_k = __atomic_load_n(&b->held_k, __ATOMIC_RELAXED);
    }
    if (answered != NULL) {
        *answered = __atomic_load_n(&b->answered, __ATOMIC_RELAXED);
    }
    if (refused != NULL) {
        *refused = __atomic_load_n(&b->refused, __ATOMIC_RELAXED);
    }
    return news;
}

int live_inbox_wait(live_inbox_t *b, int word, uint32_t seen, int64_t timeout_ns)
{
    return word_wait(word == LIVE_WORD_NEWS ? &b->news : &b->wake, seen, timeout_ns);
}

void live_inbox_kick(live_inbox_t *b)
{
    word_bump_and_wake(&b->wake);
}

/* ---- a held run's records ---- */

uint64_t live_ring_head(const void *ring_mem)
{
    const rec_ring_header_t *h = (const rec_ring_header_t *)ring_mem;
    return __atomic_load_n(&h->head, __ATOMIC_ACQUIRE);
}

long live_ring_window(const void *ring_mem, size_t mapping_size, uint64_t from, uint64_t to,
                      uint8_t *out, size_t cap)
{
    const rec_ring_header_t *h = (const rec_ring_header_t *)ring_mem;
    const uint8_t *data;
    uint64_t rcap, head, at = from;
    size_t copied = 0u;
    if (ring_mem == NULL || mapping_size < REC_RING_HEADER_SIZE ||
        __atomic_load_n(&h->magic, __ATOMIC_ACQUIRE) != REC_RING_MAGIC) {
        return -1;
    }
    rcap = h->capacity;
    if (rcap == 0u || rcap + REC_RING_HEADER_SIZE > mapping_size) {
        return -1;
    }
    data = (const uint8_t *)ring_mem + REC_RING_HEADER_SIZE;
    head = __atomic_load_n(&h->head, __ATOMIC_ACQUIRE);
    if (from > to || to > head || head - from > rcap) {
        return -1;
    }
    while (at < to) {
        const uint64_t pos = at % rcap;
        const uint64_t to_end = rcap - pos;
        rec_ring_record_t rec;
        uint64_t len;
        if (to_end < REC_RING_RECORD_HEADER) {
            at += to_end; /* the producer wrapped before a tail too short for a header */
            continue;
        }
        memcpy(&rec, data + pos, sizeof rec);
        len = (((uint64_t)rec.length + 7u) & ~(uint64_t)7u) + REC_RING_RECORD_HEADER;
        if (len > to_end || at + len > to) {
            return -1; /* from is not where a record starts */
        }
        if (rec.channel != REC_RING_PAD_CHANNEL) {
            if (copied + len > cap) {
                return -1;
            }
            memcpy(out + copied, data + pos, (size_t)len);
            copied += (size_t)len;
        }
        at += len;
    }
    return (long)copied;
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
