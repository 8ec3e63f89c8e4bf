/**
 * @file transport.h
 * @brief Host links of the Linux port: how HIL frames (id + payload) travel between the bench and
 * the stub. One interface, four implementations:
 *
 *   serial      COBS/CRC-16 framing on a UART or pty (docs/protocol.md section 2)   transport_serial.c
 *   slcan       the adapter end of the SLCAN (Lawicel ASCII) protocol on a tty/pty:
 *               the stub behaves like a USB-CAN adapter with the drive behind it       slcan.c
 *   socketcand  the server end of socketcand's TCP protocol (raw mode)                 socketcand.c
 *   socketcan   a raw AF_CAN socket on a Linux CAN interface (can0, vcan0)             socketcan.c
 *
 * The portable hil_session never sees any of this: frames come in through the deliver callback
 * and go out through ops->queue(). Everything here is Linux/POSIX, not firmware.
 */
#ifndef HIL_PORT_TRANSPORT_H
#define HIL_PORT_TRANSPORT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "hil_framing.h"

#define TRANSPORT_TX_SIZE 8192u

/** The CAN error class bit of a bus-off (linux/can/error.h CAN_ERR_BUSOFF). */
#define TRANSPORT_CAN_ERR_BUSOFF 0x040u

typedef struct transport transport_t;

/** Called once per complete frame received from the host. */
typedef void (*transport_rx_fn)(void *user, const hil_frame_t *frame);

typedef struct {
    /** Read what is available on t->fd and deliver each complete frame.
     *  Returns 0 to go on, 1 when the host closed the link (t->error may say more), -1 on an I/O
     *  error (t->error says what failed). */
    int (*read)(transport_t *t, transport_rx_fn deliver, void *user);
    /** Queue one frame for the host (sent by transport_flush). Frames the link cannot carry now
     *  (CAN channel not open, bus-off, dlc not representable) are counted in tx_dropped. */
    void (*queue)(transport_t *t, uint16_t id, const hil_octet_t *data, uint16_t dlc);
    /** Tell the host the controller went bus-off, the way this link can. 0 done, -1 unsupported. */
    int (*bus_off)(transport_t *t);
    /** Append line noise to the output (serial only; NULL where the link has framing in hardware). */
    void (*noise)(transport_t *t);
    /** Link-specific counters, one line, no newline. */
    void (*print_stats)(const transport_t *t, FILE *out);
    void (*close)(transport_t *t);
} transport_ops_t;

struct transport {
    const transport_ops_t *ops;
    const char *kind;           /**< "serial", "slcan", "socketcand", "socketcan" */
    char name[160];             /**< what and where, for messages */
    int fd;                     /**< polled for input */
    int out_fd;                 /**< transport_flush writes here (-1: nothing to write to yet) */
    int open;                   /**< 1 when frames flow to the host (the CAN channel is open) */
    int is_bus_off;
    unsigned char tx[TRANSPORT_TX_SIZE];
    size_t tx_len;
    unsigned long rx_frames;    /**< frames delivered */
    unsigned long rx_errors;    /**< malformed input (framing errors, bad commands, bad frames) */
    unsigned long tx_frames;
    unsigned long tx_dropped;   /**< frames not sent (channel closed, bus-off, not representable) */
    unsigned long tx_overflows; /**< tx buffer full and the flush failed */
    char error[200];
    int write_errno;          /* errno of the last failed write (0: none) */
};

/** Initialise the common part. */
void transport_init(transport_t *t, const transport_ops_t *ops, const char *kind);
/** Append raw octets to the tx buffer (flushing first when full). 0 ok, -1 lost (counted). */
int transport_append(transport_t *t, const void *data, size_t n);
/** Write the tx buffer out (waiting with poll while the peer is slow). 0 ok, -1 failed (t->error). */
/** read() with the conventions every byte-stream transport shares: returns 0 with *n bytes read
 *  (*n = 0: nothing yet, EINTR/EAGAIN), 1 if the peer closed (EOF, or EIO on a pty whose host
 *  end closed), -1 on an error (t->error says which). */
int transport_read_bytes(transport_t *t, void *buf, size_t size, size_t *n);
int transport_flush(transport_t *t);
/** "fd:N" -> 1 and *fd = N (a descriptor inherited from the bench); 0 if spec is not of that
 *  form; -1 if it is but N is not a valid number. */
int transport_parse_fd(const char *spec, int *fd);
/** Open a tty/FIFO path, or take an inherited descriptor ("fd:N"), and put a tty in raw mode
 *  (baud 0: leave the speed). Returns the descriptor, or -1 with err naming what failed. */
int transport_open_tty(const char *spec, long baud, const char *what, char *err, size_t err_size);
/** Wall-clock time (CLOCK_REALTIME) as seconds and microseconds, for CAN timestamps. */
void transport_wall_time(long *sec, long *usec);
/** Value of one hex digit, or -1. */
int transport_hex_digit(int c);
/** Parse exactly n hex digits of s into *out. 0 ok, -1 not hex. */
int transport_parse_hex(const char *s, size_t n, unsigned long *out);
/** CAN FD: payload length of DLC code 0..15, and the smallest code holding len octets (-1: > 64). */
unsigned transport_fd_dlc_to_len(unsigned code);
int transport_fd_len_to_dlc(unsigned len);

/* Constructors. Each returns NULL and writes a message naming what failed and where into err. */
transport_t *serial_transport_open(const char *path, long baud, char *err, size_t err_size);
transport_t *slcan_transport_open(const char *spec, long baud, char *err, size_t err_size);
transport_t *socketcand_transport_open(const char *spec, const char *bus, char *err, size_t err_size);
transport_t *socketcan_transport_open(const char *iface, char *err, size_t err_size);

#endif
