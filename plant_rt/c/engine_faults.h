/**
 * @file engine_faults.h
 * @brief Link faults the cycle engine injects between itself and the controller (issue 12,
 * docs/faults.md "Link faults"): on the frames the bench sends (to the controller), on the
 * frames it receives (from the controller), or both. Seeded and reproducible: the same scenario
 * and seed injects the same faults into the same frames.
 *
 *   DROP       the frame never arrives
 *   DUPLICATE  the frame arrives twice, back to back
 *   REORDER    the frame arrives after the next frame of the same direction
 *   BITFLIP    one bit of the frame is flipped on the wire. Serial: in the COBS/CRC-16 octets,
 *              so the receiver's deframer rejects the frame (a CRC-16 detects every single-bit
 *              error; a flip that makes a 0x00 splits the frame into parts that fail). CAN: the
 *              bus's own CRC catches it, the frame is destroyed and the sending controller
 *              retransmits it automatically: from the controller, the bench counts an error
 *              frame and takes the retransmitted frame; to the controller it cannot be emulated
 *              above the socket (refused at set-up).
 *   DELAY      the frame arrives delay_s (+ uniform [0, jitter_s)) later; a link is FIFO, so a
 *              frame never overtakes the one before it
 *   STALL      nothing crosses the link, either way, for stall_s of wall time
 *   GARBAGE    a burst of seeded random octets (serial) or n frames with ids the protocol does
 *              not use (CAN), once, at cycle_on
 *
 * A fault acts in cycles [cycle_on, cycle_off) (cycle_off <= cycle_on: from cycle_on on), on
 * the frames of frame_id (-1: every frame), each with probability `probability`, at most
 * `count` frames (0: no limit). STALL and GARBAGE happen once, at cycle_on.
 *
 * Host-only C99 + POSIX. No heap: every queue is a fixed array in the state.
 */
#ifndef ENGINE_FAULTS_H
#define ENGINE_FAULTS_H

#include <stddef.h>
#include <stdint.h>

#include "engine_link.h"

#define ENGINE_MAX_LINK_FAULTS 16
#define ELF_QUEUE 256u   /* frames held back (delay lines, reorder) per direction */

typedef enum {
    ELF_DROP = 1,
    ELF_DUPLICATE = 2,
    ELF_REORDER = 3,
    ELF_BITFLIP = 4,
    ELF_DELAY = 5,
    ELF_STALL = 6,
    ELF_GARBAGE = 7
} elf_kind_t;

#define ELF_TO_CONTROLLER 1   /* the frames the bench sends */
#define ELF_FROM_CONTROLLER 2 /* the frames the bench receives */

/** One link fault (engine_add_link_fault). */
typedef struct {
    int kind;                /* elf_kind_t */
    int direction;           /* ELF_TO_CONTROLLER | ELF_FROM_CONTROLLER */
    int frame_id;            /* -1: every frame */
    long cycle_on, cycle_off;
    uint32_t count;          /* 0: no limit */
    double probability;      /* (0, 1] */
    double delay_s, jitter_s;
    double stall_s;
    uint32_t n_garbage;      /* octets (serial) / frames (CAN) */
    uint64_t seed;
} elf_config_t;

/** A frame held back by a fault. */
typedef struct {
    eng_frame_t f;
    int64_t due_ns;
} elf_held_t;

typedef struct {
    elf_held_t q[ELF_QUEUE];
    unsigned head, count;
} elf_queue_t;

/** What the injector reports for each frame it acted on (the engine records it). */
typedef void (*elf_report_fn)(void *ctx, int fault_index, int direction, const char *action,
                              uint16_t id, const uint8_t *data, uint16_t dlc, double value);

typedef struct {
    elf_config_t cfg[ENGINE_MAX_LINK_FAULTS];
    uint64_t seed[ENGINE_MAX_LINK_FAULTS];     /* each fault's seeded state */
    uint64_t rng[ENGINE_MAX_LINK_FAULTS];      /* its draws for the frame at hand (or a burst) */
    uint32_t occ[ENGINE_MAX_LINK_FAULTS][2];   /* frames of this cycle it met, per direction */
    uint32_t place;                            /* the acting frame's place among them (0: first) */
    uint32_t acted[ENGINE_MAX_LINK_FAULTS];    /* frames (or bursts) acted on */
    uint64_t matched[ENGINE_MAX_LINK_FAULTS];  /* frames that met its window, direction and
                                                * message (each one drew against probability) */
    int64_t stall_until_ns[ENGINE_MAX_LINK_FAULTS];
    int once_done[ENGINE_MAX_LINK_FAULTS];     /* STALL / GARBAGE happened */
    int n;
    long cycle;                                /* the engine's present cycle */
    uint16_t seq;                              /* ... and its seq (a replay's is the capture's) */
    /* to the controller: reorder hold, delay line */
    int tx_hold_valid;
    eng_frame_t tx_hold;
    elf_queue_t tx_delay;
    /* from the controller: frames past the faults, waiting to be due */
    int rx_hold_valid;
    eng_frame_t rx_hold;
    elf_queue_t rx_out;
    uint64_t dropped_overflow;                 /* a delay line was full: frame dropped, counted */
    elf_report_fn report;
    void *report_ctx;
} elf_t;

void elf_init(elf_t *f, elf_report_fn report, void *ctx);
/** Add a fault; 0, or -1 with why (too many, bad values, not possible on this link kind). */
int elf_add(elf_t *f, const elf_config_t *cfg, int link_kind, char *why, size_t why_len);
/** The engine starts cycle k, whose frames carry `seq` (STALL starts, GARBAGE goes out at
 *  cycle_on). A per-frame fault acts only on the frames of the present cycle (a cycle message of
 *  another seq: an answer to a re-send of an earlier cycle, a late one, is let through), and draws
 *  for a frame from its seed, the cycle, the direction and the frame's place among the frames of
 *  the cycle it met: the same frames get the same draws in every run with that seed, however many
 *  other frames a busy host's re-sends add (docs/faults.md). */
void elf_begin_cycle(elf_t *f, eng_link_t *l, long k, uint16_t seq, int64_t now_ns);
/** A frame the bench sends: faults applied, then queued on the link (0 or 1, 2 times), held
 *  (reorder) or put on the delay line. 0, or -1 if the link's burst is full. */
int elf_tx(elf_t *f, eng_link_t *l, uint16_t id, const uint8_t *data, uint16_t dlc, int64_t now_ns);
/** Queue the delayed frames now due on the link (the caller flushes). Returns how many. */
int elf_tx_due(elf_t *f, eng_link_t *l, int64_t now_ns);
/** Move the frames the link received through the faults (drop, duplicate, reorder, bit flips,
 *  delay, stall) into the fault layer's receive queue. */
void elf_rx_pump(elf_t *f, eng_link_t *l, int64_t now_ns);
/** Next received frame that is due now: 1, or 0. */
int elf_rx_pop(elf_t *f, eng_frame_t *out, int64_t now_ns);
/** Frames received and due now. */
unsigned elf_rx_ready(const elf_t *f, int64_t now_ns);
/** The earliest instant something held becomes due (INT64_MAX: nothing held). */
int64_t elf_next_due_ns(const elf_t *f);

#endif
