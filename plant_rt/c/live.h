/**
 * @file live.h
 * @brief The live view's two paths (docs/foxglove.md "Watching a run live"), host only.
 *
 * 1. Operator inputs into the cycle engine: a single-producer single-consumer mailbox in a
 *    MAP_SHARED mapping the bench creates before it forks the recorder. The live view in the
 *    recorder process (bench/live/server.py, a Foxglove WebSocket server) pushes what a viewer
 *    published; the engine takes every pending input at the start of a cycle, after the
 *    scenario's events of that cycle, and applies it in that cycle (engine_inputs.c eng_take_inputs). When
 *    nothing is pending that costs the engine one acquire load per cycle: no system call, no
 *    Python, nothing that waits for the viewer. The producer never waits either: a full mailbox
 *    refuses the input (the live view tells the viewer why).
 *
 *    Ordering: the producer fills a slot, then publishes it with a release store of head; the
 *    consumer reads head with acquire, copies the slot, then releases tail (as rec_ring.h).
 *
 * 2. Records for the viewer out of a batch the recorder drained from the recording ring
 *    (live_pick): per channel, nothing, the last record of the batch (a per-cycle channel
 *    decimated to the viewer's rate), or every record (events, faults, link statistics). The
 *    recorder calls it once per batch, in C, so the per-message work of the live view is only
 *    for the few records it forwards.
 */
#ifndef LIVE_H
#define LIVE_H

#include <stddef.h>
#include <stdint.h>

#define LIVE_INBOX_MAGIC 0x314556494C4C4948ull /* "HILLIVE1" little-endian */
#define LIVE_INBOX_SLOTS 64u                   /* a power of two */
#define LIVE_INPUT_TEXT 192

/** What an operator input asks for. */
typedef enum {
    LIVE_IN_SPEED_REF = 1, /* value: speed reference [rad/s mechanical] -> CMD SET_SPEED_REF */
    LIVE_IN_LOAD = 2,      /* value: load torque [N m] -> the plant, from this cycle on */
    LIVE_IN_PAUSE = 3,     /* lockstep: hold the run before this cycle's SENSE */
    LIVE_IN_RESUME = 4,    /* lockstep: go on */
    LIVE_IN_REFUSED = 5    /* nothing applied: an /events row (operator_refused) says why */
} live_input_kind_t;

typedef struct {
    int32_t kind;                /* live_input_kind_t */
    int32_t client;              /* the viewer's client id (the WebSocket server's) */
    double value;                /* SI: rad/s, N m */
    char text[LIVE_INPUT_TEXT];  /* what and who, for the /events row (NUL-terminated) */
} live_input_t;

typedef struct live_inbox {
    uint64_t magic;
    uint64_t head;               /* producer: inputs published (monotonic) */
    uint8_t pad_head_[48];
    uint64_t tail;               /* consumer: inputs taken (monotonic) */
    uint8_t pad_tail_[56];
    live_input_t slots[LIVE_INBOX_SLOTS];
} live_inbox_t;

/** Octets of a mapping that holds an inbox. */
size_t live_inbox_size(void);
/** Format a fresh mapping of `size` octets. 0, or -1 if it is too small. */
int live_inbox_format(void *mem, size_t size);
/** The inbox in a formatted mapping, or NULL (too small, not formatted). */
live_inbox_t *live_inbox_attach(void *mem, size_t size);
/** Producer: publish one input (text is cut to LIVE_INPUT_TEXT - 1 octets). 0, or -1 when the
 *  mailbox is full (nothing published). */
int live_inbox_push(live_inbox_t *b, int kind, int client, double value, const char *text);
/** Consumer: the oldest pending input into *out: 1, or 0 if none is pending. */
int live_inbox_take(live_inbox_t *b, live_input_t *out);
/** Inputs published and not yet taken. */
uint64_t live_inbox_pending(const live_inbox_t *b);

/* ---- the viewer's records out of a drained batch ---- */

#define LIVE_SKIP 0   /* mode: nothing of this channel */
#define LIVE_LAST 1   /* mode: the last record of the batch */
#define LIVE_EVERY 2  /* mode: every record */
#define LIVE_PICK_MAX_CHANNELS 1024

/** One record picked: its channel, time and payload (offset into the batch, length). */
typedef struct {
    uint64_t offset;
    uint32_t length;
    uint16_t channel;
    uint16_t pad_;
    int64_t t_ns;
} live_pick_t;

/**
 * Walk the ring records in in[0..n_in) (rec_ring_read's output) and pick, by mode[channel]
 * (channels >= n_mode: LIVE_SKIP), the last record of each LIVE_LAST channel and every record of
 * each LIVE_EVERY channel, in batch order (a LIVE_LAST pick at its last record's place). At
 * most `cap` picks: the records beyond are counted in *cut. Returns the picks made.
 */
size_t live_pick(const uint8_t *in, size_t n_in, const int32_t *mode, size_t n_mode,
                 live_pick_t *picks, size_t cap, uint64_t *cut);

#endif
