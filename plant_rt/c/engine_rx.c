/* What arrives from the controller, frame by frame, while a cycle waits (docs/protocol.md
 * 6.5): the frame that completes the cycle, and every other one counted by what it is. */
#include "engine_internal.h"

#include <stdio.h>
#include <string.h>

/** Real time: the late state of `seq` (0 none, 1 its period ended without its DUTY, 2 its late
 *  DUTY came) if it is within ENGINE_LATE_WINDOW periods before cycle c, else 0. */
static int late_state_of(const engine_t *e, const cycle_t *c, uint16_t seq)
{
    return ((uint16_t)(c->seq - seq) < ENGINE_LATE_WINDOW)
               ? (int)e->late_state[seq & (ENGINE_LATE_WINDOW - 1)] : 0;
}

/** TELEM / TELEM_EMF that is not this cycle's first (docs/protocol.md 6.5): a second one of
 *  this cycle is a duplicate, one of the cycle before or of a missed period in the late window
 *  is stale (ignored, counted apart), any other seq is a sequence mismatch. */
static void telem_other_seq(engine_t *e, cycle_t *c, uint16_t seq)
{
    if (seq == c->seq) {
        e->n.duplicates++;
    } else if (seq == (uint16_t)(c->seq - 1u) || late_state_of(e, c, seq) != 0) {
        /* the cycle before, or (real time) a late answer to a period that ended without its
         * DUTY: the telemetry of a cycle that is over */
        e->n.stale_frames++;
        c->stale++;
    } else {
        e->n.seq_mismatch++;
        c->seq_bad++;
        c->bad_seq = seq;
    }
}

/** A cycle frame of the wrong length: counted, never decoded, said once per id. */
static void length_error(engine_t *e, cycle_t *c, const eng_frame_t *f, const char *name,
                         unsigned expected)
{
    unsigned bit = (unsigned)(f->id & 0x3u);
    e->n.length_errors++;
    c->len_bad++;
    if (!(e->length_error_said & (1u << bit))) {
        char text[160];
        e->length_error_said |= 1u << bit;
        snprintf(text, sizeof text, "%s (0x%03X) with %u octets, the DBC says %u: not decoded "
                 "(further ones only counted in length_errors)", name, (unsigned)f->id,
                 (unsigned)f->dlc, expected);
        eng_record_event(e, c->t_s, "length_error", text, (double)f->id);
    }
}

/** A DUTY's raw duty as the plant takes it: -1 OFF (the leg disabled), 0..1 the high-side on
 *  fraction, NaN out of range (a bad duty, docs/protocol.md 6.6). */
double eng_duty_of_raw(const engine_t *e, uint32_t raw)
{
    if (raw == e->cfg.duty_raw_off) {
        return -1.0;
    }
    return (raw <= e->cfg.duty_raw_full) ? (double)raw / (double)e->cfg.duty_raw_full : (double)NAN;
}

/** A late DUTY is never applied, but an out-of-range one is still a controller that sent
 *  garbage: counted in bad_duties with its /events row (not in the consecutive count, which is
 *  about duties the bench had to hold in place of one it would have applied). */
static void late_duty_in_range(engine_t *e, const cycle_t *c, const hil_duty_t *d)
{
    const uint32_t raw[3] = {d->d_a, d->d_b, d->d_c};
    int k;
    for (k = 0; k < 3; ++k) {
        if (isnan(eng_duty_of_raw(e, raw[k]))) {
            char text[160];
            e->n.bad_duties++;
            snprintf(text, sizeof text, "DUTY seq %u raw [%u, %u, %u] out of range, and late "
                     "(its period had ended): never applied", (unsigned)d->seq,
                     (unsigned)raw[0], (unsigned)raw[1], (unsigned)raw[2]);
            eng_record_event(e, c->t_s, "bad_duty", text, (double)d->seq);
            return;
        }
    }
}

/**
 * Handle one received frame while cycle c waits (lockstep and real time alike).
 * Returns 1 if it completed the cycle (the first valid DUTY(k)), 0 otherwise, -1 if it ends
 * the run (FAULT_CTRL; e->end set).
 */
int eng_handle_frame(engine_t *e, cycle_t *c, const eng_frame_t *f, int cycle_open)
{
    const uint16_t prev_seq = (uint16_t)(c->seq - 1u);
    if (e->cfg.record_frames) {
        eng_text_frame(e->rx_text, &e->rx_len, f->id, f->data, f->dlc);
    }
    switch (f->id) {
    case HIL_DUTY_FRAME_ID: {
        hil_duty_t d;
        if (f->dlc != HIL_DUTY_LENGTH || hil_duty_unpack(&d, f->data, f->dlc) != 0) {
            length_error(e, c, f, "DUTY", HIL_DUTY_LENGTH);
            return 0;
        }
        if (d.seq == c->seq && cycle_open && !c->have_duty) {
            c->have_duty = 1;
            c->duty_raw[0] = d.d_a;
            c->duty_raw[1] = d.d_b;
            c->duty_raw[2] = d.d_c;
            c->duty_t_ns = f->t_ns;
            c->answers[0] = 1u;
            return 1;
        }
        if (e->cfg.mode == ENGINE_LOCKSTEP) {
            /* an answer to a re-send of this cycle or of a re-sent one still being counted
             * (late is not lost: engine_lockstep.c), else as below */
            if (eng_lockstep_answer(e, c, d.seq, 0) >= 0) {
                return 0;
            }
        }
        if ((d.seq == c->seq && c->have_duty) || (d.seq == prev_seq && e->prev_had_duty)) {
            e->n.duplicates++; /* a second answer to a completed cycle (e.g. a cached re-send) */
        } else if (late_state_of(e, c, d.seq) == 1) {
            /* real time: the answer to a period that ended without it (however many periods
             * ago, up to the window: after a stall of the host the answers come in a burst) */
            e->late_state[d.seq & (ENGINE_LATE_WINDOW - 1)] = 2;
            e->n.late_duty++;
            late_duty_in_range(e, c, &d);
        } else if (late_state_of(e, c, d.seq) == 2) {
            e->n.duplicates++; /* a second late answer to the same period */
        } else {
            e->n.seq_mismatch++;
            c->seq_bad++;
            c->bad_seq = d.seq;
        }
        return 0;
    }
    case HIL_TELEM_FRAME_ID: {
        hil_telem_t t;
        if (f->dlc != HIL_TELEM_LENGTH || hil_telem_unpack(&t, f->data, f->dlc) != 0) {
            length_error(e, c, f, "TELEM", HIL_TELEM_LENGTH);
            return 0;
        }
        if (t.seq == c->seq && !c->have_telem) {
            c->have_telem = 1;
            c->answers[1] = 1u;
            c->th_hat = (double)t.theta_hat * e->cfg.scale_theta_hat;
            c->w_hat = (double)t.omega_hat * e->cfg.scale_omega_hat;
            c->st = (int)t.state;
            c->est = (int)t.estimator;
        } else if (e->cfg.mode != ENGINE_LOCKSTEP || eng_lockstep_answer(e, c, t.seq, 1) < 0) {
            telem_other_seq(e, c, t.seq);
        }
        return 0;
    }
    case HIL_TELEM_EMF_FRAME_ID: {
        hil_telem_emf_t m;
        if (f->dlc != HIL_TELEM_EMF_LENGTH || hil_telem_emf_unpack(&m, f->data, f->dlc) != 0) {
            length_error(e, c, f, "TELEM_EMF", HIL_TELEM_EMF_LENGTH);
            return 0;
        }
        if (m.seq == c->seq && !c->have_emf) {
            c->have_emf = 1;
            c->answers[2] = 1u;
            c->e_a = (double)m.e_alpha * e->cfg.scale_e;
            c->e_b = (double)m.e_beta * e->cfg.scale_e;
            c->iq_ref = (double)m.i_q_ref * e->cfg.scale_iq_ref;
        } else if (e->cfg.mode != ENGINE_LOCKSTEP || eng_lockstep_answer(e, c, m.seq, 2) < 0) {
            telem_other_seq(e, c, m.seq);
        }
        return 0;
    }
    case HIL_FAULT_CTRL_FRAME_ID: {
        hil_fault_ctrl_t m;
        e->fault_dlc = (int)f->dlc;
        if (f->dlc != HIL_FAULT_CTRL_LENGTH || hil_fault_ctrl_unpack(&m, f->data, f->dlc) != 0) {
            e->n.length_errors++;
            e->end = ENGINE_END_PROTOCOL;
            eng_set_message(e, "at cycle %ld (t = %.4f s): FAULT_CTRL with %u octets (expected %u): "
                        "the controller reports a fault but its code, seq and detail are "
                        "unreadable", c->k, c->t_s, (unsigned)f->dlc, (unsigned)HIL_FAULT_CTRL_LENGTH);
            return -1;
        }
        e->n.ctrl_faults++;
        if (e->trip_cycle < 0) {
            e->fault_code = (int)m.code;
            e->fault_seq = (int)m.seq;
            e->fault_detail = (long)m.detail;
        }
        if (e->cfg.post_trip_cycles > 0) {
            /* a fault run: record the trip, keep running to see the controller's reaction */
            char text[160];
            snprintf(text, sizeof text, "FAULT_CTRL code %u seq %u detail %ld",
                     (unsigned)m.code, (unsigned)m.seq, (long)m.detail);
            eng_record_fault(e, (int32_t)m.seq, -1, "controller", "fault_ctrl", "", "trip", text,
                         (double)m.code);
            eng_record_event(e, c->t_s, "controller_fault", text, (double)m.code);
            if (e->trip_cycle < 0) {
                e->trip_cycle = c->k;
                eng_full_rate_from_now(e, e->cfg.post_trip_cycles + e->cfg.post_trigger_cycles);
            }
            return 0;
        }
        e->end = ENGINE_END_CONTROLLER_FAULT;
        eng_set_message(e, "at cycle %ld (t = %.4f s): controller fault", c->k, c->t_s);
        return -1;
    }
    case HIL_HEARTBEAT_CTRL_FRAME_ID: {
        hil_heartbeat_ctrl_t h;
        e->n.heartbeats_rx++;
        if (f->dlc == HIL_HEARTBEAT_CTRL_LENGTH &&
            hil_heartbeat_ctrl_unpack(&h, f->data, f->dlc) == 0) {
            const uint16_t back = (uint16_t)(e->hb_counter - h.counter);
            /* the controller restarted: its heartbeat counter started over (not a wrap), or it
             * says IDLE after its TELEM said it was running (a restart loses the session) */
            const int running = e->last_state == (int)HIL_STATE_ALIGN ||
                                e->last_state == (int)HIL_STATE_OPEN_LOOP ||
                                e->last_state == (int)HIL_STATE_CLOSED_LOOP ||
                                e->last_state == (int)HIL_STATE_INITIAL_POSITION;
            if ((e->hb_have && h.counter < e->hb_counter && back < 0x8000u) ||
                (running && h.state == (uint16_t)HIL_STATE_IDLE)) {
                e->last_state = (int)HIL_STATE_IDLE;
                e->n.ctrl_resets++;
                e->hb_rx_base += e->hb_rx_last;
                eng_record_event(e, c->t_s, "controller_restart", "HEARTBEAT_CTRL counter started "
                             "over: the controller restarted", (double)h.counter);
            }
            e->hb_rx_last = h.rx_errors;
            e->hb_state = (int)h.state;
            e->n.ctrl_rx_errors = e->hb_rx_base + h.rx_errors;
            e->hb_counter = h.counter;
            e->hb_have = 1;
        }
        return 0;
    }
    default:
        e->n.unknown_ids++;
        return 0;
    }
}

/** Handle the frames that are queued now; cycle_open: DUTY(k) may still complete cycle k. */
int eng_drain_frames(engine_t *e, cycle_t *c, int cycle_open, int *completed)
{
    eng_frame_t f;
    while (eng_pop(e, &f)) {
        const int r = eng_handle_frame(e, c, &f, cycle_open && !*completed);
        if (r < 0) {
            return -1;
        }
        if (r == 1) {
            *completed = 1;
        }
    }
    return 0;
}
