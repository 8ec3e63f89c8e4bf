/*
 * The lockstep loop: the plant advances one period per valid DUTY. The wait for that DUTY is
 * this file's rule (docs/protocol.md 6.5), the same for every controller and every kind of run:
 *
 *   LATE IS NOT LOST. A lockstep run's rows are a function of what arrived, never of when: the
 *   host waits for DUTY(k) as long as the controller is there. It re-sends the cycle's SENSE
 *   group (the same octets) when no DUTY(k) has come retry_timeout_s after the send, then after
 *   twice the interval before, at most resend_max_s apart (so a slow answer costs a handful of
 *   frames, not a storm): a re-send is how a lossy serial link recovers a lost frame. What a
 *   cycle was is decided by what arrived, once its answers are counted (eng_resent_settle): a
 *   cycle every SENSE group of which was answered was LATE (a timing statistic: late_answers,
 *   the /timing row's retries and round trip; never a link problem); a SENSE group that got no
 *   answer is a LOST frame (lost_frames), unless a corrupt chunk arrived while the cycle was
 *   open (a frame that failed its CRC or framing is CORRUPT, counted by the deframer). Only
 *   lost and corrupt frames are link problems (docs/protocol.md 6.9).
 *
 *   THE RUN ENDS only when the controller is gone: its link failed (process exited, port closed,
 *   emulator died: at once), it restarted (its heartbeat started over: a restarted controller
 *   answers no SENSE before a new HELLO; at once), it sent FAULT_CTRL, or DUTY(k) has not come
 *   patience_s after SENSE(k) was first sent (and nothing is waiting to be read: a host that was
 *   itself descheduled reads what came meanwhile first). One bound, whatever else arrives:
 *   heartbeats, telemetry or noise without the DUTY do not extend it.
 *
 * Real time (engine_realtime.c) keeps its deadlines: there lateness is what is measured.
 */
#include "engine_internal.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static void append(char *buf, size_t cap, int *n, const char *fmt, ...)
{
    va_list ap;
    if (*n >= (int)cap - 1) {
        return;
    }
    if (*n > 0) {
        *n += snprintf(buf + *n, cap - (size_t)*n, "; ");
    }
    va_start(ap, fmt);
    *n += vsnprintf(buf + *n, cap - (size_t)*n, fmt, ap);
    va_end(ap);
    if (*n > (int)cap - 1) {
        *n = (int)cap - 1;
    }
}

/** Lockstep, the run ends without DUTY(k): what arrived during the cycle and what the bench's own
 *  faults did to it (docs/protocol.md 6.5: "at cycle 1234 (t = 0.1234 s): no DUTY(1234) 10 s
 *  (patience_s) after its SENSE and 13 re-sends: 2 frames with a bad CRC,
 *  ..."; "nothing at all (the controller is silent)" only when nothing arrived and the bench
 *  injected nothing). `ended_by`: what ended the wait before the patience did (a restart), or
 *  NULL. */
static void describe_no_duty(engine_t *e, const cycle_t *c, const char *ended_by)
{
    const hil_deframer_t *d = &e->link.deframer;
    char what[640];
    int n = 0;
    unsigned long k;
    what[0] = '\0';
    if ((k = (unsigned long)(d->crc_errors - c->crc0)) > 0u) {
        append(what, sizeof what, &n, "%lu %s with a bad CRC", k, k == 1u ? "frame" : "frames");
    }
    if ((k = (unsigned long)(d->cobs_errors - c->cobs0)) > 0u) {
        append(what, sizeof what, &n, "%lu %s not valid COBS", k,
               k == 1u ? "chunk that is" : "chunks that are");
    }
    if ((k = (unsigned long)(d->length_errors + c->len_bad - c->len0)) > 0u) {
        append(what, sizeof what, &n, "%lu %s of the wrong length", k, k == 1u ? "frame" : "frames");
    }
    if ((k = (unsigned long)(d->overruns - c->over0)) > 0u) {
        append(what, sizeof what, &n, "%lu %s (more than 70 octets without a delimiter)", k,
               k == 1u ? "overrun" : "overruns");
    }
    if (c->seq_bad > 0u) {
        append(what, sizeof what, &n, "%lu %s with seq %u", (unsigned long)c->seq_bad,
               c->seq_bad == 1u ? "DUTY or TELEM" : "DUTY or TELEM frames", (unsigned)c->bad_seq);
    }
    if (c->stale > 0u) {
        append(what, sizeof what, &n, "%lu TELEM of the cycle before", (unsigned long)c->stale);
    }
    if (e->cyc_restart > 0u) {
        append(what, sizeof what, &n, "the bench restarted the controller at this cycle "
               "(faults[%d] controller_reset: CMD RESTART before this cycle's SENSE)",
               e->cyc_restart_fault);
    }
    if (e->n.ctrl_resets > e->resets_at_cycle) {
        append(what, sizeof what, &n, "the controller restarted (its HEARTBEAT_CTRL started "
               "over): a restarted controller answers no SENSE before a new HELLO");
    } else if ((k = (unsigned long)(e->n.heartbeats_rx - c->hb0)) > 0u) {
        append(what, sizeof what, &n, "%lu HEARTBEAT_CTRL (the controller is alive, state %s): "
               "it answers no SENSE", k,
               e->hb_state >= 0 && e->hb_state < ENGINE_STATE_NAMES &&
                       e->cfg.state_names[e->hb_state][0] ? e->cfg.state_names[e->hb_state]
                                                          : "?");
    }
    if (e->cyc_drop > 0u) {
        append(what, sizeof what, &n, "the bench's own drop fault faults[%d] dropped %lu "
               "frame(s) of this cycle", e->cyc_drop_fault, (unsigned long)e->cyc_drop);
    }
    if (e->cyc_stall_drop > 0u) {
        append(what, sizeof what, &n, "the bench's own stall faults[%d] let %lu frame(s) of this "
               "cycle not cross", e->cyc_stall_fault, (unsigned long)e->cyc_stall_drop);
    }
    if (e->cyc_delay > 0u) {
        append(what, sizeof what, &n, "the bench's own delay fault faults[%d] delayed %lu "
               "frame(s) of this cycle by up to %.3g s", e->cyc_delay_fault,
               (unsigned long)e->cyc_delay, e->traces[e->cyc_delay_fault].delay_d_s);
    }
    e->end = ENGINE_END_NO_DUTY;
    if (ended_by != NULL) {
        eng_set_message(e, "at cycle %ld (t = %.4f s): %s while the host waited for DUTY(%u) "
                        "(%d re-sends): %s", c->k, c->t_s, ended_by, (unsigned)c->seq,
                        c->retries, n ? what : "nothing else arrived");
        return;
    }
    eng_set_message(e, "at cycle %ld (t = %.4f s): no DUTY(%u) %.3g s (patience_s) after its SENSE "
                    "and %d re-sends: %s", c->k, c->t_s, (unsigned)c->seq,
                    e->cfg.patience_s, c->retries,
                    n ? what : "nothing at all (the controller is silent)");
}

/* ---- the answers of re-sent cycles ----------------------------------------------------------- */

static uint64_t corrupt_chunks(const engine_t *e)
{
    const hil_deframer_t *d = &e->link.deframer;
    return (uint64_t)d->crc_errors + d->cobs_errors + d->length_errors + d->overruns;
}

/** What a re-sent cycle was, now that its answers are counted: late, or frames lost. */
static void settle(engine_t *e, const engine_resent_t *r)
{
    const uint64_t missing = r->sends > r->answers[0] ? (uint64_t)(r->sends - r->answers[0]) : 0u;
    if (missing == 0u) {
        e->n.late_answers++;
    } else if (missing > r->corrupt) {
        e->n.lost_frames += missing - r->corrupt;
    }
}

void eng_resent_settle(engine_t *e, long before_k)
{
    while (e->resent_count > 0u) {
        const engine_resent_t *r = &e->resent[e->resent_head];
        if (r->k >= before_k) {
            break;
        }
        settle(e, r);
        e->resent_head = (e->resent_head + 1u) % ENGINE_RESENT_WINDOW;
        e->resent_count--;
    }
}

/** Cycle c completed after re-sends: keep counting its answers (the cache's answers to the
 *  re-sends come after the one that completed it). */
static void resent_open(engine_t *e, const cycle_t *c, uint64_t corrupt0)
{
    engine_resent_t *r;
    if (e->resent_count == ENGINE_RESENT_WINDOW) {
        eng_resent_settle(e, e->resent[e->resent_head].k + 1);
    }
    r = &e->resent[(e->resent_head + e->resent_count) % ENGINE_RESENT_WINDOW];
    e->resent_count++;
    r->k = c->k;
    r->seq = c->seq;
    r->sends = (uint32_t)c->retries + 1u;
    memcpy(r->answers, c->answers, sizeof r->answers);
    r->corrupt = corrupt_chunks(e) - corrupt0;
}

int eng_lockstep_answer(engine_t *e, cycle_t *c, uint16_t seq, int which)
{
    uint32_t *n = NULL, sends = 0u;
    unsigned i;
    if (seq == c->seq) {
        if (!c->sent) {
            return -1;   /* its SENSE has not gone out yet (paused before it) */
        }
        n = &c->answers[which];
        sends = (uint32_t)c->retries + 1u;
    } else {
        for (i = 0u; i < e->resent_count; ++i) {
            engine_resent_t *r = &e->resent[(e->resent_head + i) % ENGINE_RESENT_WINDOW];
            if (r->seq == seq) {
                n = &r->answers[which];
                sends = r->sends;
            }
        }
    }
    if (n == NULL) {
        return -1;
    }
    if (*n < sends) {
        (*n)++;
        if (which == 0) {
            e->n.resend_answers++;
        }
        return 1;
    }
    e->n.duplicates++;
    return 0;
}

/* ---- the wait ------------------------------------------------------------------------------- */

/**
 * Lockstep exchange of cycle c: send what is queued, wait for the first valid DUTY(seq),
 * re-sending the SENSE group with back-off while the controller is there (the rule at the top
 * of this file). 0, or -1 with e->end set.
 */
int eng_exchange_lockstep(engine_t *e, cycle_t *c, int64_t c0, int64_t *sent_ns)
{
    const engine_config_t *cfg = &e->cfg;
    const int64_t max_ns = (int64_t)(cfg->resend_max_s * 1e9);
    const uint64_t corrupt0 = corrupt_chunks(e);
    int64_t interval_ns = (int64_t)(cfg->retry_timeout_s * 1e9);
    int64_t resend_at, give_up_at;
    int done = 0;
    if (eng_flush(e, c0 + NS_PER_S) != 0) {
        eng_fail_link(e, c);
        return -1;
    }
    *sent_ns = eng_now_ns();
    c->sent = 1;
    resend_at = *sent_ns + interval_ns;
    give_up_at = *sent_ns + (int64_t)(cfg->patience_s * 1e9);
    for (;;) {
        eng_frame_t f;
        int64_t now;
        int r;
        while (!done && eng_pop(e, &f)) {
            r = eng_handle_frame(e, c, &f, 1);
            if (r < 0) {
                return -1;
            }
            done = r;
        }
        if (done) {
            break;
        }
        if (e->n.ctrl_resets > e->resets_at_cycle) {
            describe_no_duty(e, c, "the controller restarted");
            return -1;
        }
        /* read what is there (a host that was itself descheduled finds the answers that came
         * meanwhile before it judges anything), else wait for the next re-send or the end */
        r = eng_poll(e, resend_at < give_up_at ? resend_at : give_up_at);
        if (r < 0) {
            eng_fail_link(e, c);
            return -1;
        }
        if (r > 0) {
            continue;
        }
        if (eng_stop_asked(e)) {
            e->end = ENGINE_END_STOPPED;
            eng_set_message(e, "stopped at cycle %ld while waiting for DUTY", c->k);
            return -1;
        }
        now = eng_now_ns();
        if (now >= give_up_at) {
            describe_no_duty(e, c, NULL);
            return -1;
        }
        if (now >= resend_at) {
            c->retries++;
            e->n.retries++;
            eng_queue_resend(e, c);
            if (eng_flush(e, now + NS_PER_S) != 0) {
                eng_fail_link(e, c);
                return -1;
            }
            interval_ns = 2 * interval_ns < max_ns ? 2 * interval_ns : max_ns;
            resend_at = eng_now_ns() + interval_ns;
        }
    }
    if (c->retries > 0) {
        const int64_t took_ns = c->duty_t_ns - *sent_ns;
        if (took_ns > e->late_max_ns) {
            e->late_max_ns = took_ns;
        }
        resent_open(e, c, corrupt0);
    }
    return 0;
}

/** Lockstep paced for a viewer (pace_s > 0): cycle k starts k pace_s after the first, plus the
 *  time the run was paused (absolute deadlines, no spin: the engine sleeps). The start error
 *  goes to the jitter histogram and the /timing row. Returns the cycle's start. */
static int64_t lockstep_pace(engine_t *e, long k, int64_t *start_err_ns)
{
    int64_t deadline, now;
    *start_err_ns = 0;
    if (!(e->cfg.pace_s > 0.0)) {
        return eng_now_ns();
    }
    if (k == 0) {
        e->t0_ns = eng_now_ns();
    }
    deadline = e->t0_ns + e->paused_ns + (int64_t)llround((double)k * e->cfg.pace_s * 1e9);
    now = eng_wait_until(deadline, 0);
    *start_err_ns = now - deadline;
    eng_hist_add(&e->hist_jitter, (double)*start_err_ns * 1e-3);
    return now;
}

int eng_run_lockstep(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    ref_voltage_t rv;
    int next_event = 0;
    long k;
    memset(&rv, 0, sizeof rv);
    rv.w_split = cfg->t_delay_s / cfg->ts_s;
    for (k = 0; k < cfg->n_cycles; ++k) {
        cycle_t c;
        int64_t c0, sent_ns, start_err_ns;
        if (eng_stop_asked(e)) {
            e->end = ENGINE_END_STOPPED;
            eng_set_message(e, "stopped at cycle %ld", k);
            return e->end;
        }
        c0 = lockstep_pace(e, k, &start_err_ns);
        eng_begin_cycle(e, &c, k);
        eng_resent_settle(e, k - 1);   /* cycle k - 1 completed: k - 2's answers are in */
        eng_apply_events(e, &next_event, &c);
        eng_take_inputs(e, &c);
        if (e->paused) {
            if (eng_hold_while_paused(e, &c) != 0) {
                return e->end;
            }
            c0 = eng_now_ns();
        }
        eng_faults_begin_cycle(e, k, c.seq);
        if (eng_build_sense(e, &c) != 0) {
            return e->end;
        }
        eng_queue_sense_group(e, &c);
        if (eng_exchange_lockstep(e, &c, c0, &sent_ns) != 0) {
            return e->end;
        }
        eng_rtt_evidence(e, &c, sent_ns);
        if (eng_take_duties(e, &c) < 0) {
            return e->end;
        }
        eng_after_telemetry(e, &c);
        eng_record_cycle(e, &c);
        eng_step_references(e, &c, &rv, 1);
        plant_step(e->plant, e->duties);
        e->prev_had_duty = 1;
        {
            const int64_t c1 = eng_now_ns();
            rec_timing_t t;
            eng_hist_add(&e->hist_cycle, (double)(c1 - c0) * 1e-3);
            if (e->have_ring && eng_record_full(e, k)) {
                t.t_s = c.t_s;
                t.seq = c.seq;
                t.start_err_us = (cfg->pace_s > 0.0) ? (double)start_err_ns * 1e-3 : (double)NAN;
                t.rtt_us = (double)(c.duty_t_ns - sent_ns) * 1e-3;
                t.arrival_us = (double)NAN;
                t.cycle_us = (double)(c1 - c0) * 1e-3;
                t.missed = 0u;
                t.retries = (uint32_t)c.retries;
                t.late_total = e->n.late_duty;
                t.missed_total = e->n.missed_duty;
                t.overrun = 0u;
                RECORD(e, cfg->ch_timing, c.t_s, REC_MAX_FIXED_SIZE, rec_encode_timing, &t);
            }
        }
        __atomic_store_n(&e->cycles_done, k + 1, __ATOMIC_RELEASE);
        e->speed_rpm = e->plant->y[2] * cfg->rpm_per_rad_s;
        if (cfg->stats_every_cycles > 0 && (k + 1) % cfg->stats_every_cycles == 0) {
            engine_write_stats(e, (double)(k + 1) * cfg->ts_s, NULL);
        }
        if (!eng_plant_finite(e, &c)) {
            return e->end;
        }
        eng_traces_step(e);
        if (eng_trip_over(e, &c)) {
            return e->end;
        }
    }
    return ENGINE_END_DONE;
}
