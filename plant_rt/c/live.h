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
 *    A script (hil_bench.Session, bench/session.py) is the other producer a run can have
 *    (never both: one producer per mailbox). Its inputs say what a scenario's events can say
 *    (speed and current references, control mode, load torque, plant faults on and off, the bus
 *    voltage as the plant's bus fault) and where the lockstep run holds (LIVE_IN_HOLD_AT: the
 *    engine checks the cycle it holds before with the inputs, a plain compare per cycle). While
 *    it holds, the engine sleeps on the mailbox's `wake` word (a futex: an input wakes it at
 *    once) and reads the link every few ms; it answers every input it takes (applied or refused,
 *    with the reason) and each hold it begins on the `news` word the script sleeps on. Nothing of
 *    this is on the per-cycle path of a run that is not held: the engine makes a system call only
 *    while it holds, when it answers an input, and when it begins a hold.
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
    LIVE_IN_REFUSED = 5,   /* nothing applied: an /events row (operator_refused) says why */
    /* a script's (hil_bench.Session) */
    LIVE_IN_HOLD_AT = 6,   /* value: a cycle k: lockstep, hold the run before cycle k's SENSE
                            * (after its events and inputs); a held run goes on if k is later
                            * than the cycle it holds before; k < 0: hold no more */
    LIVE_IN_IQ_REF = 7,    /* value: q current reference [A] -> CMD SET_IQ_REF */
    LIVE_IN_ID_REF = 8,    /* value: d current reference [A] -> CMD SET_ID_REF */
    LIVE_IN_CONTROL_MODE = 9, /* value: 0 speed loop, 1 current mode -> CMD SET_CONTROL_MODE */
    LIVE_IN_FAULT_ON = 10, /* arg: plant_fault_t kind, phase, phase2, level; value: its value ->
                            * plant_set_fault (the plant may refuse it: plant_fault_check) */
    LIVE_IN_FAULT_OFF = 11, /* arg[0]: plant fault kind, arg[1]: phase (-1: every one) */
    LIVE_IN_NOTE = 12      /* nothing applied: an /events row (kind script_note) with the text */
} live_input_kind_t;

/** Who pushed an input: the /events kinds are "operator..." or "script...". */
#define LIVE_FROM_VIEWER 0
#define LIVE_FROM_SCRIPT 1
#define LIVE_INPUT_ARGS 4
#define LIVE_REFUSED_TEXT 384

typedef struct {
    int32_t kind;                /* live_input_kind_t */
    int32_t client;              /* the viewer's client id (the WebSocket server's); -1: a script */
    double value;                /* SI: rad/s, A, N m, V; a cycle (LIVE_IN_HOLD_AT) */
    int32_t origin;              /* LIVE_FROM_VIEWER or LIVE_FROM_SCRIPT */
    int32_t arg[LIVE_INPUT_ARGS];/* LIVE_IN_FAULT_*: the fault's kind, phase, phase2, level */
    int32_t pad_;
    char text[LIVE_INPUT_TEXT];  /* what and who, for the /events row (NUL-terminated) */
} live_input_t;

typedef struct live_inbox {
    uint64_t magic;
    uint64_t head;               /* producer: inputs published (monotonic) */
    uint8_t pad_head_[48];
    uint64_t tail;               /* consumer: inputs taken (monotonic) */
    uint8_t pad_tail_[56];
    /* a script's session: */
    uint32_t wake;               /* producer: bumped with every input (a held engine sleeps
                                  * on it) */
    uint8_t pad_wake_[60];
    uint32_t news;               /* consumer: bumped after each input answered and each hold
                                  * begun (a script sleeps on it); what is below is written first */
    uint32_t pad_news_;
    int64_t held_k;              /* consumer: the cycle the run holds before; -1 while it runs */
    uint64_t answered;           /* consumer: inputs applied or refused (monotonic) */
    uint64_t refused;            /* consumer: of those, refused */
    char refused_text[LIVE_REFUSED_TEXT]; /* the last refusal: what and why */
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
/** Producer: publish one input with its origin and arguments (args: LIVE_INPUT_ARGS values or
 *  NULL), then wake a held engine. 0, or -1 when the mailbox is full (nothing published). */
int live_inbox_push_input(live_inbox_t *b, int kind, int origin, double value,
                          const int32_t *args, const char *text);
/** Consumer: the oldest pending input into *out: 1, or 0 if none is pending. */
int live_inbox_take(live_inbox_t *b, live_input_t *out);
/** Inputs published and not yet taken. */
uint64_t live_inbox_pending(const live_inbox_t *b);

/* ---- holds and answers (a script's session) ---- */

/** Consumer: an input taken was applied (why == NULL) or refused (why: what and why). */
void live_inbox_answer(live_inbox_t *b, const char *why);
/** Consumer: the run holds before cycle k (k >= 0: news, a script waiting wakes) or runs again
 *  (k < 0). */
void live_inbox_set_held(live_inbox_t *b, int64_t k);
/** The `wake` word (consumer: read it before looking for inputs, then sleep on it). */
uint32_t live_inbox_wake_word(const live_inbox_t *b);
/** The `news` word with what it covers: the cycle held before (-1: running), the inputs answered
 *  and refused (each may be NULL). */
uint32_t live_inbox_news(const live_inbox_t *b, int64_t *held_k, uint64_t *answered,
                         uint64_t *refused);
/** Sleep until the word (LIVE_WORD_WAKE or LIVE_WORD_NEWS) is no longer `seen`, at most
 *  timeout_ns. 1 if it changed, 0 if not (time-out, a spurious wake-up). */
int live_inbox_wait(live_inbox_t *b, int word, uint32_t seen, int64_t timeout_ns);
/** Wake a held engine without an input (after engine_request_stop: it stops at once). */
void live_inbox_kick(live_inbox_t *b);

#define LIVE_WORD_WAKE 0
#define LIVE_WORD_NEWS 1

/* ---- reading a held run's records back (a script's window) ---- */

/** The recording ring's head counter (rec_ring.h), acquire. */
uint64_t live_ring_head(const void *ring_mem);
/**
 * Copy the records the ring in ring_mem (a formatted mapping of mapping_size octets) published
 * between head counters from and to into out[0..cap), pads skipped: rec_ring_read's format. It
 * reads behind the consumer (the recorder process drains the same records into the file), so
 * only while the producer writes nothing (the run holds, or ended) and only a window still in the
 * ring (to - from <= capacity). Returns the octets copied, or -1 (not in the ring any more, from
 * and to not record boundaries, or out too small).
 */
long live_ring_window(const void *ring_mem, size_t mapping_size, uint64_t from, uint64_t to,
                      uint8_t *out, size_t cap);

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
