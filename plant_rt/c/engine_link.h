/**
 * @file engine_link.h
 * @brief The cycle engine's link I/O on one file descriptor: the serial framing of protocol/c
 * (COBS + CRC-16, docs/protocol.md section 2) on a byte stream (pty, UART, TCP), or CAN frames
 * as SocketCAN exchanges them (struct can_frame / canfd_frame, one per read/write) on a raw
 * SocketCAN socket or on the bench's socketpair bridge to a python-can interface.
 *
 * Received frames are decoded into a queue with their arrival time; the engine pops them in
 * order, so what it does with a frame never depends on how the kernel batched the reads. Every
 * anomaly is counted (framing errors by the deframer; on CAN: error frames, remote frames,
 * 29-bit ids, malformed reads) and nothing is ever decoded from a rejected frame.
 *
 * Or, software in the loop, the same serial framing to a controller in this process
 * (eng_link_peer_t): no descriptor, no system call but the clock.
 *
 * Host-only C99 + POSIX (poll, read, write, clock_gettime). No heap.
 */
#ifndef ENGINE_LINK_H
#define ENGINE_LINK_H

#include <stddef.h>
#include <stdint.h>

#include "hil_framing.h"

typedef enum {
    ENG_LINK_SERIAL = 0, /* COBS/CRC frames on a byte stream */
    ENG_LINK_CAN = 1,    /* struct can_frame (16 octets) per datagram */
    ENG_LINK_CANFD = 2   /* struct canfd_frame (72 octets) per datagram; classic frames accepted */
} eng_link_kind_t;

#define ENG_LINK_RXQ 1024u   /* decoded frames waiting for the engine */
#define ENG_LINK_TXBUF 8192u /* serial octets / CAN frames of one burst */
#define ENG_LINK_TXFRAMES 64u

typedef struct {
    uint16_t id;
    uint16_t dlc;
    uint8_t data[HIL_FRAME_MAX_DATA];
    int64_t t_ns; /* arrival (CLOCK_MONOTONIC) */
} eng_frame_t;

typedef struct {
    uint64_t frames_tx, frames_rx, bytes_tx, bytes_rx;
    /* CAN (0 on serial): frames that are not the protocol's data frames */
    uint64_t error_frames, remote_frames, ext_ids, rx_malformed, send_failures, bus_state_changes;
} eng_link_counters_t;

/**
 * A controller in this process instead of a descriptor (software in the loop, `--link sil`):
 * the serial octets the engine writes go to write(), the octets the controller sent come from
 * read(), both at once on the engine's thread; a controller reset reaches it in band (CMD
 * RESTART among the octets), as on every link. The framing, the queues, the counters and the capture tap are those of a serial descriptor.
 */
typedef struct {
    void *ctx;
    void (*write)(void *ctx, const uint8_t *data, size_t n, int64_t now_ns);
    size_t (*read)(void *ctx, uint8_t *out, size_t cap, int64_t now_ns);
} eng_link_peer_t;

typedef struct {
    int fd;
    eng_link_kind_t kind;
    eng_link_peer_t peer;       /* peer.write != NULL: the in-process controller (fd unused) */
    int fd_brs;                 /* CAN FD: bit rate switch on sent frames */
    hil_deframer_t deframer;    /* serial receiver (its counters are the framing counters) */
    eng_frame_t rxq[ENG_LINK_RXQ];
    unsigned rxq_head, rxq_count;
    uint8_t txbuf[ENG_LINK_TXBUF];
    size_t txlen;               /* serial: octets queued; CAN: frames queued */
    eng_link_counters_t c;
    int bus_off;                /* CAN: the controller reported bus-off */
    int closed;                 /* the peer closed the link (EOF, EIO, hang-up) */
    char error[160];            /* why the link failed ("" while it works) */
    /* serial capture (NULL: none): every octet written (direction 0) or read (direction 1),
     * as it crossed the descriptor, with the time of the write/read (eng_now_ns) */
    void (*tap)(void *ctx, int direction, const uint8_t *data, size_t n, int64_t t_ns);
    void *tap_ctx;
} eng_link_t;

/** Wall clock of the engine: CLOCK_MONOTONIC in ns. */
int64_t eng_now_ns(void);

/** Attach to fd (made non-blocking). kind: eng_link_kind_t. */
void eng_link_init(eng_link_t *l, int fd, int kind);
/** Put an in-process controller on the link (serial framing; replaces any descriptor). */
void eng_link_attach_peer(eng_link_t *l, const eng_link_peer_t *peer);
/** Queue one frame for the next flush. Returns 0, or -1 if the burst is full or the frame invalid. */
int eng_link_queue(eng_link_t *l, uint16_t id, const uint8_t *data, uint16_t dlc);
/** Write everything queued, waiting for room until deadline_ns. Returns 0, or -1 (l->error says
 *  why: peer gone, deadline passed). */
int eng_link_flush(eng_link_t *l, int64_t deadline_ns);
/** Queue raw octets (serial only: line noise for fault injection). */
int eng_link_queue_raw(eng_link_t *l, const uint8_t *data, size_t n);
/**
 * Wait until a frame is queued or deadline_ns passes (deadline <= now: just read what is
 * there), reading and decoding everything available. Returns the frames waiting (>= 0), or -1
 * when the link failed (l->error; frames already queued stay poppable).
 */
int eng_link_poll(eng_link_t *l, int64_t deadline_ns);
/** Serial: octets received before the engine took the link over (the partial frame another
 *  receiver held), decoded as if they had just arrived. */
void eng_link_feed(eng_link_t *l, const uint8_t *data, size_t n);
/** A frame received before the engine took the link over, queued as if it had just arrived. */
void eng_link_push(eng_link_t *l, uint16_t id, const uint8_t *data, uint16_t dlc);
/** Next received frame into *out: 1, or 0 if none is queued. */
int eng_link_pop(eng_link_t *l, eng_frame_t *out);
/** Put a popped frame back at the front (it is handled first next time). */
void eng_link_unpop(eng_link_t *l, const eng_frame_t *f);

#endif
