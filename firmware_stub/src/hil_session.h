/**
 * @file hil_session.h
 * @brief Controller side of the HIL link session (docs/protocol.md): handshake, CONFIG, CMD,
 * the per-cycle SENSE -> ISR -> TELEM/DUTY exchange, heartbeats and faults.
 *
 * Portable: frames come in through hil_session_on_frame() and go out through the port's send
 * hook, so the same code runs behind a serial deframer, a CAN driver or a test harness.
 *
 * Restart (docs/protocol.md 6.3): CMD RESTART restarts the session and the controller as from
 * power-up (hil_session_restart) before the next frame is read: no handshake, no configuration,
 * heartbeat counter from 0; the session says so at once with a HEARTBEAT_CTRL (counter 0, state
 * IDLE). `restarts` counts them across restarts, so a port that keeps state of its own (a timer,
 * its link's error count) sees one happened.
 *
 * Versions (docs/protocol.md 6.1, 10): HELLO carries the host's protocol version (major
 * proto_version, proto_minor), HELLO_ACK the one the session speaks: the major, and the lower of the
 * host's minor and `proto_minor` (this controller's own: HIL_PROTO_VERSION_MINOR, which a port may
 * lower after init to behave as an older drive, e.g. the Linux stub's --proto 1.0). In a session of
 * an older minor the controller knows only what that version knows: a parameter added later is
 * UNKNOWN_PARAM, an estimator added later is not in `estimators` (ESTIMATOR_UNSUPPORTED), a command
 * added later is ignored like any command it does not know.
 *
 * Retries (docs/protocol.md 6.5): the session keeps the TELEM, TELEM_EMF and DUTY frames it sent for
 * the last SENSE it ran. A SENSE repeating that seq is answered from this cache, byte for byte, and
 * the control ISR does not run again. An accepted HELLO empties the cache.
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
    uint32_t cycles;         /**< SENSE frames that ran the control ISR */
    uint32_t unknown_ids;
    uint32_t length_errors;
    uint32_t seq_errors;     /**< SENSE seq neither previous + 1 nor a repeat of the previous */
    uint32_t config_rejected;
    uint32_t not_ready;      /**< SENSE before a completed handshake */
    uint32_t repeats;        /**< SENSE retries answered from the cache (the ISR did not run) */
    uint32_t cmd_seq_gaps;   /**< CMD seq not previous + 1 (a CMD was lost) */
} hil_session_stats_t;

/** One frame of the answer cache. */
typedef struct {
    uint16_t id;
    uint16_t dlc;
    hil_octet_t data[8];
} hil_cached_frame_t;

#define HIL_SESSION_CACHE_FRAMES 3u /* TELEM, TELEM_EMF, DUTY */

/** HELLO modes this firmware runs (bit n = mode value n): both by default. */
#define HIL_SESSION_MODES_DEFAULT ((uint16_t)((1u << HIL_MODE_LOCKSTEP) | (1u << HIL_MODE_REALTIME)))
/** HELLO periods accepted by default: from 10 us to the wire's largest (HELLO.period_us raw 65535) */
#define HIL_SESSION_PERIOD_MIN_US 10.0f
#define HIL_SESSION_PERIOD_MAX_US 6553.5f

typedef struct {
    hil_port_t port;
    controller_t ctrl;
    int hello_done;
    uint16_t session_id;
    uint16_t flags;   /**< HELLO flags */
    uint16_t mode;    /**< HELLO mode */
    uint16_t modes;   /**< HELLO modes accepted (bit n = mode n); a port may narrow it after init */
    uint16_t proto_minor;   /**< this controller's minor protocol version; a port may lower it after init */
    uint16_t session_minor; /**< the minor version the session speaks (HELLO_ACK.proto_minor) */
    /** HELLO periods accepted, [min, max] in us (PERIOD_UNSUPPORTED outside): a port narrows them
     *  after init to what its timer and its control ISR make (port/c2000); kept across restarts */
    float period_min_us;
    float period_max_us;
    /* per-cycle auxiliary data latched before SENSE */
    uint16_t aux_seq;
    int aux_valid;
    uint16_t aux_flags;      /**< SENSE_AUX.flags of aux_seq */
    uint16_t aux_theta_raw;  /**< SENSE_AUX.theta_enc of aux_seq */
    float v_dc_v;            /**< bus of the latest SENSE_AUX */
    int have_v_dc;           /**< a SENSE_AUX has arrived in this session (v_dc_v is a reading) */
    float theta_enc_rad;     /**< last valid encoder angle (THETA_ENC_VALID in the SENSE_AUX of the cycle) */
    uint16_t dual_seq;   /**< seq of the latched SENSE_DUAL */
    int dual_valid;
    float i2_abc_a[3];   /**< SENSE_DUAL(k): second sample of period k-1 */
    uint16_t last_seq;
    int have_seq;
    hil_cached_frame_t cache[HIL_SESSION_CACHE_FRAMES]; /**< answer to SENSE last_seq */
    uint16_t cache_n;
    uint16_t last_cmd_seq;
    int have_cmd_seq;
    uint16_t hb_counter;
    hil_session_stats_t stats;
    uint32_t restarts;   /**< restarts since hil_session_init (CMD RESTART or the port's own) */
} hil_session_t;

/** Bitmask of estimators this firmware implements (bit n = estimator id n). */
uint16_t hil_session_estimators(void);
/** The estimators of a session of protocol 1.`minor` (those added in a later minor left out). */
uint16_t hil_session_estimators_of_minor(uint16_t minor);
void hil_session_init(hil_session_t *s, const hil_port_t *port);
void hil_session_on_frame(hil_session_t *s, const hil_frame_t *f);
/** Restart as from power-up (CMD RESTART; a port may call it for a reset line of its own): the
 *  session and the controller re-initialised, the port, the modes and periods it allows and its
 *  protocol version kept, `restarts` + 1, and a HEARTBEAT_CTRL sent at once (counter 0, state
 *  IDLE, no errors: a port resets its link's error count with it). */
void hil_session_restart(hil_session_t *s);
/** Send HEARTBEAT_CTRL (the port calls it every 100 ms while no cycles flow). */
void hil_session_heartbeat(hil_session_t *s, uint32_t link_rx_errors);

#endif
