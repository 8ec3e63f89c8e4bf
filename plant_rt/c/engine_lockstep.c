/* The lockstep loop: the plant advances one period per valid DUTY. */
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

/** Lockstep: why no valid DUTY came, from what arrived during the cycle and what the bench's own
 *  faults did to it (docs/protocol.md 6.5: "cycle 1234: no valid DUTY after 3 retries (0.2 s): 2
 *  frames with a bad CRC, ..."; "nothing at all (the controller is silent)" only when nothing
 *  arrived, the bench injected nothing and no answer came late either). */
static void describe_no_duty(engine_t *e, const cycle_t *c)
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
    if (isfinite(c->late_s)) {
        append(what, sizeof what, &n, "its DUTY came %.3g s after the cycle's first SENSE, after "
               "the host had stopped waiting: the controller answers, late", c->late_s);
    }
    e->end = ENGINE_END_NO_DUTY;
    eng_set_message(e, "at cycle %ld (t = %.4f s): no valid DUTY after %d retries (%.3g s): %s",
                c->k, c->t_s, c->retries,
                (double)(c->retries + 1) * e->cfg.retry_timeout_s,
                n ? what : "nothing at all (the controller is silent)");
}

/* ---- lockstep ---------------------------------------------------------------------------------- */

/** Lockstep, the retries are over without a valid DUTY(k): listen late_grace_s more, only to tell
 *  a late controller from a silent one in the run's message (c->late_s). 0, or -1 when a frame
 *  ends the run (FAULT_CTRL). The run ends either way: the retry rule does not wait this long. */
static int late_answer(engine_t *e, cycle_t *c, int64_t sent_ns)
{
    const int64_t deadline = eng_now_ns() + (int64_t)(e->cfg.late_grace_s * 1e9);
    if (!(e->cfg.late_grace_s > 0.0)) {
        return 0;
    }
    for (;;) {
        eng_frame_t f;
        int r;
        while (eng_pop(e, &f)) {
            r = eng_handle_frame(e, c, &f, 1);
            if (r < 0) {
                return -1;
            }
            if (r == 1) {
                c->late_s = (double)(f.t_ns - sent_ns) * 1e-9;
                c->have_duty = 0;
                return 0;
            }
        }
        if (eng_stop_asked(e) || eng_now_ns() >= deadline || eng_poll(e, deadline) < 0) {
            return 0;
        }
    }
}

/**
 * Lockstep exchange of cycle c: send what is queued, wait for the first valid DUTY(seq), re-send
 * the SENSE group on silence (at most max_retries times). 0, or -1 with e->end set.
 */
int eng_exchange_lockstep(engine_t *e, cycle_t *c, int64_t c0, int64_t *sent_ns)
{
    const engine_config_t *cfg = &e->cfg;
    const int64_t retry_ns = (int64_t)(cfg->retry_timeout_s * 1e9);
    int64_t deadline;
    int done = 0;
    if (eng_flush(e, c0 + NS_PER_S) != 0) {
        eng_fail_link(e, c);
        return -1;
    }
    *sent_ns = eng_now_ns();
    deadline = *sent_ns + retry_ns;
    while (!done) {
        eng_frame_t f;
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
        r = eng_poll(e, deadline);
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
        if (c->retries >= cfg->max_retries) {
            if (late_answer(e, c, *sent_ns) != 0) {
                return -1;
            }
            describe_no_duty(e, c);
            return -1;
        }
        c->retries++;
        e->n.retries++;
        eng_queue_resend(e, c);
        if (eng_flush(e, eng_now_ns() + NS_PER_S) != 0) {
            eng_fail_link(e, c);
            return -1;
        }
        deadline = eng_now_ns() + retry_ns;
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
        eng_apply_events(e, &next_event, &c);
        eng_take_inputs(e, &c);
        if (e->paused) {
            if (eng_hold_while_paused(e, &c) != 0) {
                return e->end;
            }
            c0 = eng_now_ns();
        }
        eng_faults_begin_cycle(e, k);
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
