/**
 * @file sil_port.h
 * @brief Software-in-the-loop port of the firmware: the portable HIL session (controller,
 * estimators, protection; firmware_stub/src) behind an in-memory UART, for a host that links it
 * into its own process and calls it from its own thread (the bench's cycle engine, `--link sil`).
 *
 * The third port of the same portable code, beside the Linux stub (port/linux: a pty, CAN) and a
 * DSP's: the session sees exactly what it sees on the stub's serial link. Octets the host writes
 * go through the serial deframer (COBS + CRC-16, docs/protocol.md section 2) into
 * hil_session_on_frame(); every frame the session sends is encoded into the port's transmit
 * octets, which the host reads and deframes in turn. No thread, no descriptor, no heap, no
 * system call: time is an input (now_ns, the host's CLOCK_MONOTONIC), and the port does what
 * the stub's main loop does with it (HEARTBEAT_CTRL every 100 ms while no cycles flow; with
 * hb_always also while they flow and at once after a rejected frame).
 *
 * A restart (sil_port_restart) is the stub's power cycle: session and controller back to their
 * state at power-up, the link kept, a HEARTBEAT_CTRL with its counter from 0 at once.
 */
#ifndef SIL_PORT_H
#define SIL_PORT_H

#include <stddef.h>
#include <stdint.h>

#include "hil_framing.h"
#include "hil_session.h"

/** Transmit octets held until the host reads them (a UART's FIFO, generously sized: one
 * cycle's answer is under 60 octets). */
#define SIL_PORT_TX_OCTETS 4096u
#define SIL_PORT_HEARTBEAT_NS 100000000LL

typedef struct {
    hil_session_t session;
    hil_deframer_t deframer;        /**< octets from the host */
    hil_octet_t tx[SIL_PORT_TX_OCTETS];
    size_t tx_len;
    int hb_always;                  /**< the stub's --heartbeat-always */
    int64_t last_hb_ns;
    uint32_t last_cycles;
    unsigned long last_hb_errors;
    unsigned long tx_overflows;     /**< frames lost: the host did not read (counted) */
    unsigned long restarts;         /**< power cycles (CMD RESTART) seen */
    unsigned long rx_errors_base;   /**< framing errors counted before the last restart */
} sil_port_t;

/** Power-up at now_ns; hb_always as the stub's --heartbeat-always. */
void sil_port_init(sil_port_t *p, int hb_always, int64_t now_ns);
/** Octets from the host: deframed and handled at once (the ISR runs on SENSE). A CMD RESTART
 *  among them (the bench's controller_reset) power-cycles the session (hil_session_restart); the
 *  port's own state starts over with it, as port/linux/main.c's does. */
void sil_port_write(sil_port_t *p, const hil_octet_t *data, size_t n, int64_t now_ns);
/** Move up to cap transmit octets to out (oldest first); the heartbeat is serviced first.
 *  Returns the octets moved. */
size_t sil_port_read(sil_port_t *p, hil_octet_t *out, size_t cap, int64_t now_ns);
/** Framing errors of the received octets (the stub's transport rx_errors). */
unsigned long sil_port_rx_errors(const sil_port_t *p);

#endif
