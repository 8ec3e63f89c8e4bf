/**
 * @file engine.h
 * @brief The cycle engine: everything the bench does once per control cycle, in C.
 *
 * Per cycle k: the scenario events due at k (CMD frames, load torque), the sensor model and
 * the SENSE_AUX / SENSE_DUAL / SENSE frames, link I/O on one file descriptor (engine_link.h),
 * DUTY decoding and validation, the plant step, the reference estimators (engine_refs.h) on
 * the same inputs the controller saw, and the recorded rows (rec_schema.h) written into the
 * shared-memory ring (rec_ring.h) that the recorder process drains. Python sets a run up
 * (scenario, handshake, CONFIG), calls engine_run() from a thread of its own and reads the
 * result; nothing on the per-cycle path allocates, calls Python, or makes a system call other
 * than the link's I/O and the clock (and, in lockstep only, a short sleep while the recorder
 * frees room in the ring: at most recorder_stall_s once; a recorder that made no room in that
 * time is not waited for again until it does, and every row it cannot take is counted).
 *
 * Two timing modes (docs/architecture.md "Timing of one period"):
 *
 * LOCKSTEP: the plant advances one period per valid DUTY. The duties of DUTY(k) act from
 *   t_k + t_delay (the plant's emulated computation delay). Late is not lost (the rule is at the
 *   top of engine_lockstep.c): no valid DUTY(k) within retry_timeout_s, the SENSE frames of
 *   cycle k are sent again with the same seq (the controller answers a repeated seq from its
 *   cache), with back-off up to resend_max_s; the run ends only when the controller is gone
 *   (link failed, restarted, FAULT_CTRL) or DUTY(k) has not come patience_s after SENSE(k),
 *   naming what arrived instead (nothing, bad CRC, wrong seq, wrong length, heartbeats).
 *
 * REALTIME: the plant advances on CLOCK_MONOTONIC, one period per ts_s from an absolute
 *   deadline (clock_nanosleep to deadline - spin_s, then a spin). SENSE(k) leaves at the start
 *   of period k. Duty update models, as PWM modules load their compare registers:
 *     ON_ARRIVAL   DUTY(k) acts from the instant it arrived (the real computation delay): the
 *                  plant integrates the old duties up to the arrival and the new ones after.
 *     NEXT_PERIOD  DUTY(k) acts from the next period boundary t_{k+1} (shadow load).
 *   A DUTY(k) that has not arrived by t_{k+1} - guard_s (on arrival) or t_{k+1} (next period)
 *   is a deadline miss: counted, the last duties held; if it arrives later it is counted late
 *   and discarded. If the bench itself falls a whole period or more behind the clock (it was
 *   descheduled), the lost periods are integrated with the held duties without an exchange and
 *   counted as overruns (rt_overruns): the bench's timing failure, not the controller's. After max_consecutive_misses misses in a row the inverter goes to its safe
 *   state (all legs off: the diodes conduct), FAULT_PLANT (WATCHDOG) is sent and the run ends.
 *
 * OPERATOR INPUTS (live view, live.h, docs/foxglove.md): with a mailbox attached, every input a
 *   viewer published is taken at the start of the next cycle, after that cycle's scenario events,
 *   and applied in it: a speed reference as a CMD frame sent with the cycle's SENSE frames, a
 *   load torque into the plant before its sample; each writes an /events row naming the cycle
 *   (kind "operator", or "operator_refused" with the reason). Lockstep only: a pause holds the
 *   run before the cycle's SENSE (the link is still read: heartbeats, a FAULT_CTRL) until a
 *   resume or a stop; the pause leaves no trace in the rows but its /events rows. A replay
 *   (bench replay --live) takes them too, at the start of each replayed row, and refuses every
 *   one (an "operator_refused" row at that row's time): it plays the capture's own inputs.
 *   A script (hil_bench.Session) pushes the same kinds and more (live.h) into the same mailbox,
 *   recorded as kind "script" / "script_refused" / "script_note", and holds a lockstep run
 *   before a cycle it names (LIVE_IN_HOLD_AT), checked with the inputs at each cycle's start.
 *
 * Frame rules, both modes (docs/protocol.md section 6): frames are handled in arrival order, one
 * at a time, so the outcome never depends on how reads were batched. The first valid DUTY(k)
 * completes cycle k; frames behind it wait for the next cycle. A DUTY for an already completed
 * cycle is a duplicate; for any other seq a seq mismatch. A second TELEM/TELEM_EMF of the cycle
 * is a duplicate, one of the cycle before is stale (ignored), any other seq a seq mismatch; a
 * cycle without its TELEM (or the TELEM_EMF HELLO asked for) counts once in telem_missing. A
 * frame of a cycle message with the wrong length is never decoded (length error).
 * TELEM.estimator other than the requested estimator is counted every cycle. FAULT_CTRL ends
 * the run. An out-of-range DUTY is never applied (bad duty: previous duties held); after
 * max_consecutive_bad_duties in a row the run ends.
 */
#ifndef ENGINE_H
#define ENGINE_H

#include <stddef.h>
#include <stdint.h>

#include "engine_faults.h"
#include "engine_link.h"
#include "engine_refs.h"
#include "live.h"
#include "plant.h"
#include "rec_ring.h"
#include "rec_schema.h"

#define ENGINE_MAX_REFS 8
/** A channel index that records nothing (e.g. /plant/state in a replay without a plant). */
#define ENGINE_NO_CHANNEL 0xFFFFu
#define ENGINE_MAX_EVENTS 256
#define ENGINE_EVENT_TEXT 96
#define ENGINE_STATE_NAMES 16
#define ENGINE_MESSAGE 768
/** How far back (periods) a DUTY still counts as the late answer to a missed period; older or
 * never-asked sequence numbers are seq_mismatch (docs/protocol.md 6.5). A power of two. */
#ifndef ENGINE_LATE_WINDOW
#define ENGINE_LATE_WINDOW 1024
#endif
/* lockstep: cycles whose SENSE group was re-sent, kept until their answers are counted (the
 * answers to the re-sends, from the controller's cache, come after the cycle completed; on an
 * in-order link before the next cycle's DUTY): docs/protocol.md 6.5 */
#define ENGINE_RESENT_WINDOW 64
#define ENGINE_FRAMES_TEXT 2048
/* histogram of wall times: 0.1 us bins below 1 ms, 10 us bins up to 100 ms, then overflow */
#define ENGINE_HIST_FINE 10000
#define ENGINE_HIST_COARSE 9900
#define ENGINE_HIST_BINS (ENGINE_HIST_FINE + ENGINE_HIST_COARSE + 1)

typedef enum { ENGINE_LOCKSTEP = 0, ENGINE_REALTIME = 1 } engine_mode_t;
typedef enum { ENGINE_DUTY_ON_ARRIVAL = 0, ENGINE_DUTY_NEXT_PERIOD = 1 } engine_duty_update_t;

/** Why engine_run returned. */
typedef enum {
    ENGINE_END_DONE = 0,             /* every planned cycle ran */
    ENGINE_END_STOPPED = 1,          /* engine_request_stop (Ctrl-C, the bench's watchdog) */
    ENGINE_END_LINK = 2,             /* the link failed: peer gone, write blocked, bus-off */
    ENGINE_END_NO_DUTY = 3,          /* lockstep: no valid DUTY after every retry */
    ENGINE_END_CONTROLLER_FAULT = 4, /* FAULT_CTRL received (fault_* fields) */
    ENGINE_END_BAD_DUTIES = 5,       /* too many out-of-range DUTY in a row */
    ENGINE_END_WATCHDOG = 6,         /* real time: too many deadline misses in a row */
    ENGINE_END_PLANT = 7,            /* the plant state or a sample became non-finite */
    ENGINE_END_CONFIG = 8,           /* the engine was not set up correctly */
    ENGINE_END_PROTOCOL = 9          /* a frame the host cannot interpret (short FAULT_CTRL) */
} engine_end_t;

typedef enum {
    ENGINE_EV_CMD = 0,        /* send CMD (command, value) with the SENSE frames of the cycle */
    ENGINE_EV_LOAD = 1,       /* plant load torque [N m] from this cycle on */
    ENGINE_EV_DYNO_SPEED = 2, /* dynamometer set speed [rad/s mechanical] */
    ENGINE_EV_NOTE = 3,       /* only the /events row */
    ENGINE_EV_PLANT_FAULT = 4,       /* plant_set_fault(fault_kind, phase, phase2, level, value) */
    ENGINE_EV_PLANT_FAULT_CLEAR = 5, /* plant_clear_fault(fault_kind, fault_phase) */
    ENGINE_EV_CONTROLLER_RESET = 6   /* CMD RESTART with the frames of this cycle (in band: the
                                      * controller restarts before it reads this cycle's SENSE) */
} engine_event_kind_t;

typedef struct {
    long cycle;       /* applied at the start of this cycle */
    int kind;         /* engine_event_kind_t */
    int command;      /* CMD command (Command table) */
    double value;     /* CMD value / torque / speed */
    int record;       /* 1: write an /events row (kind "scenario") with text, record_value */
    double record_value;
    char text[ENGINE_EVENT_TEXT];
    /* plant faults (ENGINE_EV_PLANT_FAULT*): plant_fault_t fields; fault_index: the scenario's
     * [[faults]] entry (the /faults rows name it); fault_name: its kind's name */
    int fault_kind, fault_phase, fault_phase2, fault_level, fault_index;
    char fault_name[24];
    double detect_within_s;   /* a fault's evidence counts until this long after it is set */
} engine_event_t;

#define ENGINE_MAX_TRACES 64
#define ENGINE_TRACE_COUNTERS 23

/** What became of one fault: evidence in the counters (engine_trace.c trace_counters). */
typedef struct {
    int state;                /* 0: nothing yet; 1: collecting; 2: closed (its row written) */
    char name[24];
    char target[12];          /* "plant", "link", "controller" */
    long first_k, close_k, seen_k;  /* this window: first action, end, first evidence (-1: none) */
    long window_cycles;       /* detection window after an action */
    double delay_s;           /* DELAY: the fault's delay_s (0: not a delay) */
    uint64_t rtt_seen;        /* DELAY: the delayed cycles that showed it, once that count is beyond
                               * what the fault-free cycles show (0 until then; engine_trace.c
                               * rtt_evidence) */
    uint64_t snap[ENGINE_TRACE_COUNTERS];
    /* the whole run (the bench checks every scenario fault against these: integrity.py) */
    int planned;              /* set up (a [[faults]] entry of the run) */
    int refused;              /* the plant refused it when it was due */
    long acted_k, evidence_k; /* first action of the run, first evidence of the run (-1: none) */
    uint32_t windows, untraced_windows;   /* detection windows closed, those without evidence */
    uint64_t matched, acted;  /* link faults: frames that met its window and message, acted on */
    /* DELAY: the round trip of the cycles it delayed (engine_trace.c eng_rtt_evidence) */
    long delay_k;             /* the last cycle it delayed a frame of */
    double delay_d_s;         /* the largest delay drawn in that cycle */
    uint64_t rtt_n, rtt_c;    /* delayed cycles measured, those at least the fault-free minimum
                               * round trip + the delay */
    double rtt_p, rtt_var;    /* sum of p, of p (1 - p): p = the fraction of fault-free cycles
                               * whose round trip reached the same threshold */
} engine_trace_t;

/** A link fault (engine_faults.h) with what the bench records of it. */
typedef struct {
    elf_config_t lf;
    int fault_index;          /* the scenario's [[faults]] entry */
    char name[24];            /* kind name for /faults rows */
    double detect_within_s;   /* evidence counts until this long after the last action */
} engine_link_fault_t;

/**
 * Replay (bench replay, docs/replay.md). What the engine steps on instead of, or beside, the live
 * loop: one row per recorded cycle, and the frames of a capture.
 *   ENGINE_SOURCE_PLANT              the live loop: plant -> SENSE -> controller -> DUTY -> plant
 *   ENGINE_SOURCE_REPLAY_CONTROLLER  the recorded frames of each cycle go to a live controller
 *                                    (lockstep, retries as live); its DUTY/TELEM are compared with
 *                                    the recorded ones (/replay/controller); no plant
 *   ENGINE_SOURCE_REPLAY_PLANT       the recorded duties drive the plant open loop, no link; the
 *                                    plant's sampled currents are compared with the recorded ones
 *                                    (/replay/plant); reference estimators on the plant's samples
 *   ENGINE_SOURCE_REPLAY_ESTIMATORS  the reference estimators on the recorded samples and duties
 *                                    (offline), no link, no plant
 */
typedef enum {
    ENGINE_SOURCE_PLANT = 0,
    ENGINE_SOURCE_REPLAY_CONTROLLER = 1,
    ENGINE_SOURCE_REPLAY_PLANT = 2,
    ENGINE_SOURCE_REPLAY_ESTIMATORS = 3
} engine_source_t;

typedef struct {
    uint16_t id, dlc;
    uint8_t data[64];
} engine_replay_frame_t;

typedef struct {
    double t_s;                 /* recorded time of the cycle (the capture's clock, from 0) */
    uint32_t first_frame;       /* replay into a controller: frames[first_frame + 0..n_frames) */
    uint32_t n_frames;          /* go out this cycle, in order (CMD, SENSE_AUX, ..., SENSE) */
    uint32_t seq;               /* the cycle's seq (its SENSE) */
    int32_t has_duty, has_telem, has_theta;
    double i_abc_a[3];          /* the currents the controller was sent (wire values) */
    double v_dc_v;              /* the bus voltage it was sent */
    double theta_rad;           /* encoder / true angle when the capture has one */
    uint32_t duty_raw[3];       /* the recorded DUTY */
    double theta_hat_rad;       /* the recorded TELEM (has_telem) */
    double omega_hat_rad_s;
    int32_t state, estimator;   /* the recorded TELEM's state and estimator (has_telem) */
    int32_t has_emf;            /* the recorded TELEM_EMF: */
    double e_alpha_v, e_beta_v, i_q_ref_a;
} engine_replay_cycle_t;

/** Linear wire scaling of one signal (from the DBC): raw = round((phys - offset) / scale). */
typedef struct {
    double scale, offset, raw_min, raw_max;
} engine_signal_t;

typedef struct {
    /* timing */
    int mode;                  /* engine_mode_t */
    int duty_update;           /* engine_duty_update_t (real time) */
    long n_cycles;
    double ts_s;
    double t_delay_s;          /* plant's emulated delay (lockstep) */
    /* the controller */
    int pole_pairs;
    double rpm_per_rad_s;
    int dual_sampling;         /* send SENSE_DUAL */
    int send_encoder;          /* theta_enc and THETA_ENC_VALID in SENSE_AUX */
    int telem_emf;             /* HELLO asked for TELEM_EMF every cycle */
    int estimator_expected;    /* TELEM.estimator the scenario asked for */
    uint16_t cmd_seq_start;    /* CMD.seq continues from the handshake's */
    /* the link */
    int link_kind;             /* eng_link_kind_t */
    int link_fd;
    eng_link_peer_t link_peer; /* software in the loop: the controller in this process (its
                                * write != NULL; link_fd unused, serial framing); a controller
                                * reset reaches it in band (CMD RESTART), as on every link */
    int can_brs;
    double retry_timeout_s;    /* lockstep: the first re-send of a cycle's SENSE group this long
                                * after it was sent; each later one after twice the interval
                                * before, at most resend_max_s (docs/protocol.md 6.5) */
    double resend_max_s;       /* lockstep: the longest interval between two re-sends */
    double patience_s;         /* lockstep: DUTY(k) has not come this long after SENSE(k) was
                                * first sent (and nothing is waiting to be read): the run ends */
    int max_consecutive_bad_duties;
    int max_consecutive_misses;
    double guard_s;            /* real time, on arrival: DUTY must arrive by t_{k+1} - guard */
    /* real time process setup */
    int rt_priority;           /* SCHED_FIFO priority (0: do not ask) */
    int rt_cpu;                /* pin the engine thread to this CPU (-1: do not) */
    int rt_mlock;              /* mlockall(MCL_CURRENT | MCL_FUTURE) */
    double spin_s;             /* spin this long before each deadline */
    int busy_wait;             /* poll the link without sleeping while DUTY(k) is due */
    /* recording */
    double recorder_stall_s;   /* lockstep: a recorder that drained nothing this long while the
                                * engine waited for ring space is stalled (rows then dropped) */
    int stats_every_cycles;
    int record_frames;         /* /link/frames rows */
    uint16_t ch_state, ch_sense, ch_telem, ch_frames, ch_events, ch_timing, ch_stats;
    /* wire constants from the DBC (protocol/hil.dbc) */
    engine_signal_t sig_i;     /* SENSE.i_a/b/c */
    engine_signal_t sig_i2;    /* SENSE_DUAL.i_a2/b2/c2 */
    engine_signal_t sig_vdc;   /* SENSE_AUX.v_dc */
    engine_signal_t sig_theta; /* SENSE_AUX.theta_enc */
    double scale_theta_hat, scale_omega_hat, scale_e, scale_iq_ref;
    uint32_t duty_raw_full, duty_raw_off;
    uint16_t aux_flag_theta_valid, aux_flag_dual_follows;
    char state_names[ENGINE_STATE_NAMES][24];
    /* replay (n_cycles = replay rows) */
    int source;                                  /* engine_source_t */
    const engine_replay_cycle_t *replay_cycles;
    const engine_replay_frame_t *replay_frames;
    long replay_n_frames;
    double pace_s;              /* replay: wall time per ts_s of recorded time (Ts / rate): row k
                                 * starts pace_s / ts_s x (its t_s - row 0's) after the start
                                 * (absolute deadlines); lockstep: cycle k starts k pace_s after
                                 * the first (plus the time the run was paused), for a viewer
                                 * (bench run --pace); 0: as fast as possible */
    uint16_t ch_replay;         /* /replay/controller or /replay/plant */
    /* serial byte capture (docs/replay.md): every octet of a serial link as a ring record on
     * ch_serial_raw: payload = direction (0 written, 1 read) then the octets; time = eng_now_ns */
    int capture_serial;
    uint16_t ch_serial_raw;
    /* faults (docs/faults.md): /faults rows; a FAULT_CTRL ends the run post_trip_cycles after it
     * (0: at once), the cycles between record the controller's reaction */
    uint16_t ch_faults;
    long post_trip_cycles;
    /* decimated recording: the per-cycle rows of every record_every-th cycle only, except within
     * pre_trigger_cycles before and post_trigger_cycles after each fault (and after a trip),
     * where every cycle is recorded (1: every cycle) */
    long record_every;
    long pre_trigger_cycles, post_trigger_cycles;
} engine_config_t;

typedef struct {
    uint64_t seq_mismatch, bad_duties, telem_missing, unknown_ids, heartbeats_rx, length_errors;
    uint64_t duplicates, stale_frames, retries, late_duty, missed_duty, estimator_mismatch;
    uint64_t rows_dropped;
    uint64_t rt_overruns;   /* real time: periods the bench itself lost (it fell behind) */
    uint64_t ctrl_rx_errors, ctrl_resets, ctrl_faults, duties_after_trip;
    uint64_t faults_injected, faults_untraced;
    uint64_t faults_acted;  /* [[faults]] entries that acted at least once (set at the run's end) */
    uint64_t faults_traced; /* of those, the ones every detection window of which had evidence */
    uint64_t state_rows;    /* /plant/state rows the engine wrote (decimation: fewer than cycles) */
    uint64_t operator_inputs;   /* live view: operator inputs applied that change the run (a
                                 * speed reference, a load torque): no claim of the run can PASS */
    uint64_t operator_refused;  /* live view: operator inputs refused (an /events row each) */
    uint64_t ring_waits;        /* lockstep: times a row waited for room in the recording ring
                                 * (the recorder had fallen a whole ring behind) */
    /* lockstep, by what arrived (docs/protocol.md 6.5): of the cycles whose SENSE group was
     * re-sent (retries), those every SENSE group of which was answered (late_answers: a timing
     * statistic, never a link problem), and the frames that never arrived (lost_frames: answers
     * missing, less the corrupt chunks received while the cycle was open, which are counted as
     * corrupt); resend_answers: DUTY frames of a re-sent cycle after the one that completed it
     * (the controller's cache answering the re-sends) */
    uint64_t late_answers, lost_frames, resend_answers;
} engine_counters_t;

/** Lockstep: a cycle whose SENSE group was re-sent, its answers still being counted. */
typedef struct {
    long k;
    uint16_t seq;
    uint32_t sends;           /* SENSE groups sent for it: 1 + its re-sends */
    uint32_t answers[3];      /* DUTY, TELEM, TELEM_EMF frames received for it so far */
    uint64_t corrupt;         /* corrupt serial chunks received while it was open */
} engine_resent_t;

typedef struct {
    uint32_t bins[ENGINE_HIST_BINS];
    uint64_t n;
    double max_us;
} engine_hist_t;

typedef struct engine {
    engine_config_t cfg;
    plant_t *plant;
    rec_ring_t ring;
    int have_ring;
    eng_link_t link;
    eng_ref_t refs[ENGINE_MAX_REFS];
    uint16_t ref_channel[ENGINE_MAX_REFS];
    int n_refs;
    engine_event_t events[ENGINE_MAX_EVENTS];
    int n_events;
    /* link faults (engine_faults.h) */
    elf_t lf;
    engine_link_fault_t lfc[ENGINE_MAX_LINK_FAULTS];
    /* the trace of every fault of the scenario (by its [[faults]] index): the counters that
     * moved between the fault's first action and the end of its detection window */
    engine_trace_t traces[ENGINE_MAX_TRACES];
    int n_traces;                /* traces[0..n_traces) may be set up */
    int faults_started;          /* a fault has acted: the fault-free part of the run is over */
    engine_hist_t rtt_free;      /* round trips [us] of the cycles before any fault acted */
    uint32_t rtt_tail[ENGINE_HIST_BINS];  /* at the first action: rtt_free's cycles in bins >= b */
    long rtt_min_bin;            /* the lowest bin of rtt_free (-1: empty) */
    /* what the bench's own faults did in the present cycle (the run's message names them) */
    uint32_t cyc_drop, cyc_stall_drop, cyc_delay, cyc_restart;
    int cyc_drop_fault, cyc_stall_fault, cyc_delay_fault, cyc_restart_fault;
    uint64_t resets_at_cycle;    /* ctrl_resets when the present cycle began */
    /* full-rate recording windows [start, end) in cycles (faults), and after a trip */
    long full_rate[ENGINE_MAX_EVENTS + ENGINE_MAX_LINK_FAULTS][2];
    int n_full_rate;
    long full_rate_until;
    long trip_cycle;             /* the controller's first FAULT_CTRL (-1: none) */
    int hb_have;
    uint16_t hb_counter;
    uint64_t hb_rx_base;         /* rx_errors reported before the controller's last restart */
    uint16_t hb_rx_last;
    int hb_state;                /* the state of the controller's last HEARTBEAT_CTRL */
    long cur_k;                  /* the cycle running now */
    double cur_t_s;
    /* operator inputs of the live view (live.h; NULL: none) */
    live_inbox_t *inbox;
    int paused;                  /* lockstep: held by an operator's pause (1) or a script (2) */
    int hold_armed;              /* lockstep: a script (hil_bench.Session) holds the run before */
    long hold_at;                /* cycle hold_at (LIVE_IN_HOLD_AT; engine_inputs.c) */
    int64_t paused_ns;           /* lockstep: wall time the run spent paused */
    /* live (read by the bench while it runs) */
    volatile int stop_requested;
    volatile long cycles_done;
    volatile double speed_rpm;
    /* result */
    int end;                    /* engine_end_t */
    char message[ENGINE_MESSAGE];
    engine_counters_t n;
    int fault_code, fault_seq;
    long fault_detail;
    int fault_dlc;
    int rt_fifo, rt_mlock, rt_pinned;  /* what the real-time setup obtained (1) or not (0) */
    char rt_notes[256];                /* why not, once */
    engine_hist_t hist_cycle;          /* lockstep: whole cycle; real time: SENSE -> DUTY */
    engine_hist_t hist_jitter;         /* real time: period start error */
    /* private */
    uint16_t cmd_seq;
    int64_t t0_ns;
    double duties[3];
    int consecutive_bad, consecutive_miss;
    int prev_had_duty;
    /* real time: per seq (mod ENGINE_LATE_WINDOW) 1 = the period ended without its DUTY,
     * 2 = its late DUTY came; 0 = no such period (cleared as each period begins) */
    uint8_t late_state[ENGINE_LATE_WINDOW];
    int recorder_stalled;       /* lockstep: the recorder made no room within recorder_stall_s */
    /* lockstep: cycles whose SENSE group was re-sent and whose answers are still being counted
     * (a ring of ENGINE_RESENT_WINDOW, oldest first), and the slowest late answer so far */
    engine_resent_t resent[ENGINE_RESENT_WINDOW];
    unsigned resent_head, resent_count;
    int64_t late_max_ns;
    unsigned length_error_said; /* ids (low 2 bits) whose wrong length was said */
    int last_state;
    char tx_text[ENGINE_FRAMES_TEXT];
    char rx_text[ENGINE_FRAMES_TEXT];
    size_t tx_len, rx_len;
} engine_t;

/** Defaults for everything but the link, the plant and the DBC constants. */
void engine_default_config(engine_config_t *cfg);
/**
 * Set up an engine over a plant (stepped in place: set its initial state first) and, if
 * ring_mem is not NULL, a formatted recording ring. Returns 0, or -1 with e->message.
 */
int engine_init(engine_t *e, const engine_config_t *cfg, plant_t *plant, void *ring_mem,
                 size_t ring_size);
/** Add a reference estimator (engine_refs.h) recorded on ring channel `channel`. 0 or -1. */
int engine_add_reference(engine_t *e, int kind, const void *config, size_t config_size,
                         uint16_t channel);
/** Add a scheduled event; events must be added in cycle order. 0 or -1 (full, out of order). */
int engine_add_event(engine_t *e, const engine_event_t *ev);
/** Record cycles [from_k, to_k) in full in a decimated recording (record_every > 1; else a
 *  no-op): the windows the metrics read. 0, or -1 (full). */
int engine_add_full_rate(engine_t *e, long from_k, long to_k);
/** Take operator inputs from a live view's mailbox in `mem` (live.h, formatted): every pending
 *  input at the start of each cycle of the live loop (lockstep and real time), or of each
 *  replayed row (a replay refuses them all). 0, or -1 with
 *  e->message (not formatted). */
int engine_attach_inbox(engine_t *e, void *mem, size_t size);
/** Add a link fault (engine_faults.h). 0, or -1 with e->message (bad values, full, not possible
 *  on this link). */
int engine_add_link_fault(engine_t *e, const engine_link_fault_t *f);
/** Run every cycle (or until something ends the run). Returns engine_end_t. */
int engine_run(engine_t *e);
/** Ask a running engine to stop at the end of the present cycle (any thread). */
void engine_request_stop(engine_t *e);
/** Percentile q in [0, 1] of a histogram [us] (0 if empty). */
double engine_hist_percentile(const engine_hist_t *h, double q);
/** Send one frame on the engine's link now (for the bench after engine_run: CMD STOP), counted
 *  with the run's frames. 0, or -1 if the link failed. */
int engine_send(engine_t *e, uint16_t id, const uint8_t *data, uint16_t dlc);
/** Write a /link/stats row now (for the bench after engine_run). */
void engine_write_stats(engine_t *e, double t_s, const eng_link_counters_t *extra);

#endif
