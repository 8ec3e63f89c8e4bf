/**
 * @file engine_internal.h
 * @brief What the cycle engine's files share (engine.h is the API; this is not): the cycle's
 * working state, the recording macro and the functions each file offers the others.
 *
 *   engine.c           set-up (configuration, events, faults, references) and engine_run
 *   engine_cycle.c     one cycle's pieces: events, SENSE, duties, rows, reference estimators
 *   engine_rx.c        what arrives from the controller, frame by frame (docs/protocol.md 6.5)
 *   engine_lockstep.c  the lockstep wait (its rule at the top) and the lockstep loop
 *   engine_realtime.c  the real-time loop on the wall clock
 *   engine_replay.c    replays: into a controller, into the plant, offline estimators
 *   engine_inputs.c    inputs through the mailbox (live.h): a live view's, a script's; holds
 *   engine_io.c        the link through the injected link faults (engine_faults.h)
 *   engine_trace.c     the evidence each scenario fault left in the counters
 *   engine_record.c    rows into the recording ring, statistics, the frames' text
 *
 * Host-only C99 + POSIX. No heap.
 */
#ifndef ENGINE_INTERNAL_H
#define ENGINE_INTERNAL_H

#include <math.h>
#include <stdint.h>

#include "engine.h"
#include "hil_msgs.h"

#define TWO_PI (2.0 * 3.14159265358979323846)
#define PI_ 3.14159265358979323846
#define NS_PER_S 1000000000LL

static inline int64_t eng_t_to_ns(double t_s)
{
    return (int64_t)llround(t_s * 1e9);
}

static inline int eng_stop_asked(engine_t *e)
{
    return __atomic_load_n(&e->stop_requested, __ATOMIC_ACQUIRE);
}

/** One record on `channel` (ENGINE_NO_CHANNEL: none) at t_s, encoded by `encoder` from `row`
 *  into at most `max` octets of the ring (eng_ring_begin: lockstep waits for room, real time
 *  never does). */
#define RECORD(e, channel, t_s, max, encoder, row)                                             \
    do {                                                                                       \
        uint8_t *p_ = ((channel) == ENGINE_NO_CHANNEL) ? NULL : eng_ring_begin((e), (max));        \
        if (p_ != NULL) {                                                                      \
            size_t n_ = encoder(p_, (max), (row));                                             \
            if (n_ > 0u) {                                                                     \
                rec_ring_commit(&(e)->ring, (channel), eng_t_to_ns(t_s), n_);                      \
            }                                                                                  \
        }                                                                                      \
    } while (0)

/* ---- one cycle's pieces ---------------------------------------------------------------------- */

typedef struct {
    long k;
    uint16_t seq;
    double t_s;
    plant_sample_t smp;
    plant_snapshot_t snap;
    double s_i[3];         /* currents as the wire carries them (decoded) */
    double theta_enc;      /* NaN if not sent */
    /* what came back */
    int have_duty, have_telem, have_emf;
    uint32_t duty_raw[3];
    int64_t duty_t_ns;
    double th_hat, w_hat, e_a, e_b, iq_ref;
    int st, est;
    int retries;
    /* what went wrong while waiting (for the message when nothing valid comes) */
    uint64_t crc0, cobs0, len0, over0, seq_bad, len_bad, stale;
    uint16_t bad_seq;      /* the last wrong seq seen */
    uint64_t hb0;          /* heartbeats_rx when the cycle began */
    int sent;              /* lockstep: its SENSE group went out */
    uint32_t answers[3];   /* lockstep: DUTY, TELEM, TELEM_EMF frames of this seq received */
    /* the frames of the SENSE group, for re-sending */
    uint8_t aux[8], dual[8], sense[8];
    int have_dual;
    const engine_replay_cycle_t *replay; /* replay into a controller: the recorded frames */
} cycle_t;

typedef struct {
    int have_prev, have_older;
    double prev[2], older[2];  /* alpha-beta voltage of the last two duty sets */
    double w_split;            /* fraction of the last period the older duties acted */
} ref_voltage_t;

/* engine.c: set-up */
void eng_set_message(engine_t *e, const char *fmt, ...);
plant_fault_t eng_event_plant_fault(const engine_event_t *ev);

/* engine_record.c: the recording ring's rows, statistics, the frames' text */
long eng_hist_bin(double us);
double eng_hist_bin_lower_us(long b);
void eng_hist_add(engine_hist_t *h, double us);
void eng_text_reset(char *buf, size_t *len);
void eng_text_frame(char *buf, size_t *len, uint16_t id, const uint8_t *data, uint16_t dlc);
uint8_t *eng_ring_begin(engine_t *e, size_t max);
void eng_record_event(engine_t *e, double t_s, const char *kind, const char *text, double value);
int eng_record_full(const engine_t *e, long k);
void eng_full_rate_from_now(engine_t *e, long cycles);
void eng_record_fault(engine_t *e, int32_t seq, int index, const char *target, const char *kind,
                      const char *direction, const char *action, const char *text, double value);
void eng_serial_tap(void *ctx, int direction, const uint8_t *data, size_t n, int64_t t_ns);

/* engine_trace.c: the evidence each fault left */
void eng_trace_act(engine_t *e, int index, long extra_cycles);
void eng_traces_step(engine_t *e);
void eng_rtt_evidence(engine_t *e, const cycle_t *c, int64_t sent_ns);
void eng_traces_end(engine_t *e);

/* engine_io.c: the link through the injected link faults */
int eng_has_link_faults(const engine_t *e);
int eng_xmit(engine_t *e, uint16_t id, const uint8_t *data, uint16_t dlc);
int eng_flush(engine_t *e, int64_t deadline_ns);
int eng_pop(engine_t *e, eng_frame_t *f);
int eng_poll(engine_t *e, int64_t deadline_ns);
void eng_link_fault_acted(void *ctx, int i, int dir, const char *action, uint16_t id,
                          const uint8_t *data, uint16_t dlc, double value);
void eng_faults_begin_cycle(engine_t *e, long k, uint16_t seq);

/* engine_cycle.c: one cycle's pieces */
void eng_begin_cycle(engine_t *e, cycle_t *c, long k);
void eng_apply_events(engine_t *e, int *next_event, const cycle_t *c);
int eng_build_sense(engine_t *e, cycle_t *c);
void eng_queue_frame(engine_t *e, uint16_t id, const uint8_t *data);
void eng_queue_sense_group(engine_t *e, const cycle_t *c);
void eng_queue_resend(engine_t *e, const cycle_t *c);
void eng_queue_cmd(engine_t *e, int command, double value);
int eng_take_duties(engine_t *e, const cycle_t *c);
void eng_after_telemetry(engine_t *e, const cycle_t *c);
void eng_record_cycle(engine_t *e, cycle_t *c);
int eng_duties_to_ab(const double d[3], double v_dc, double out[2]);
void eng_step_references(engine_t *e, const cycle_t *c, ref_voltage_t *v, int shift);
int eng_plant_finite(engine_t *e, const cycle_t *c);
void eng_fail_link(engine_t *e, const cycle_t *c);
int eng_trip_over(engine_t *e, const cycle_t *c);

/* engine_rx.c: what arrives from the controller */
double eng_duty_of_raw(const engine_t *e, uint32_t raw);
int eng_handle_frame(engine_t *e, cycle_t *c, const eng_frame_t *f, int cycle_open);
int eng_drain_frames(engine_t *e, cycle_t *c, int cycle_open, int *completed);

/* engine_inputs.c: inputs of a live view or a script (live.h), holds */
void eng_take_inputs(engine_t *e, const cycle_t *c);
int eng_hold_while_paused(engine_t *e, cycle_t *c);

/* engine_lockstep.c: the lockstep wait and the lockstep loop */
int eng_exchange_lockstep(engine_t *e, cycle_t *c, int64_t c0, int64_t *sent_ns);
/** A DUTY (which 0), TELEM (1) or TELEM_EMF (2) of `seq` beyond the first: an answer to a re-send
 *  of that cycle (1, counted), one more than the cycle's SENSE groups (0, a duplicate), or not a
 *  cycle still being counted (-1). */
int eng_lockstep_answer(engine_t *e, cycle_t *c, uint16_t seq, int which);
/** Settle the re-sent cycles before cycle before_k: late, or frames lost (LONG_MAX: all). */
void eng_resent_settle(engine_t *e, long before_k);
int eng_run_lockstep(engine_t *e);

/* engine_replay.c */
int eng_run_replay_controller(engine_t *e);
int eng_run_replay_plant(engine_t *e);
int eng_run_replay_estimators(engine_t *e);

/* engine_realtime.c */
void eng_rt_setup(engine_t *e);
void eng_rt_teardown(engine_t *e);
int64_t eng_wait_until(int64_t deadline_ns, int64_t spin_ns);
int eng_run_realtime(engine_t *e);

#endif
