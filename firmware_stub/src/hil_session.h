/**
 * @file hil_session.h
 * @brief Controller side of the HIL link session (docs/protocol.md): handshake, CONFIG, CMD,
 * the per-cycle SENSE -> ISR -> TELEM/DUTY exchange, heartbeats and faults.
 *
 * Portable: frames come in through hil_session_on_frame() and go out through the port's send
 * hook, so the same code runs behind a serial deframer, a CAN driver or a test harness.
 */
#ifndef HIL_SESSION_H
#define HIL_SESSION_H

#include <stdint.h>

#include "controller.h"
#include "hil_framing.h"
#include "hil_msgs.h"

/** I/O injected by the port (libcanard-style vtable). */
typedef struct {
    void *ctx;
    void (*send)(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc);
} hil_port_t;

/** Counters kept by the session; exposed in HEARTBEAT_CTRL and by the Linux port at exit. */
typedef struct {
    uint32_t frames_rx;
    uint32_t cycles;
    uint32_t unknown_ids;
    uint32_t length_errors;
    uint32_t seq_errors;     /**< SENSE seq not previous + 1 */
    uint32_t config_rejected;
    uint32_t not_ready;      /**< SENSE before a completed handshake */
} hil_session_stats_t;

typedef struct {
    hil_port_t port;
    controller_t ctrl;
    int hello_done;
    uint16_t session_id;
    uint16_t flags;   /**< HELLO flags */
    uint16_t mode;    /**< HELLO mode */
    /* per-cycle auxiliary data latched before SENSE */
    uint16_t aux_seq;
    int aux_valid;
    float v_dc_v;
    float theta_enc_rad;
    uint16_t dual_seq;   /**< seq of the latched SENSE_DUAL */
    int dual_valid;
    float i2_abc_a[3];   /**< SENSE_DUAL(k): second sample of period k-1 */
    uint16_t last_seq;
    int have_seq;
    uint16_t hb_counter;
    hil_session_stats_t stats;
} hil_session_t;

/** Bitmask of estimators this firmware implements (bit n = estimator id n). */
uint16_t hil_session_estimators(void);
void hil_session_init(hil_session_t *s, const hil_port_t *port);
void hil_session_on_frame(hil_session_t *s, const hil_frame_t *f);
/** Send HEARTBEAT_CTRL (the port calls it every 100 ms while no cycles flow). */
void hil_session_heartbeat(hil_session_t *s, uint32_t link_rx_errors);

#endif
