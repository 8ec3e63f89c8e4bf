/* The evidence each scenario fault left (docs/faults.md): the counters that moved in its
 * detection window, and for a delay the round trips beyond the fault-free ones. */
#include "engine_internal.h"

#include <stdio.h>
#include <string.h>

/* ---- fault traces: the evidence a fault left in the counters ------------------------------------ */

static const char *const TRACE_NAMES[ENGINE_TRACE_COUNTERS] = {
    "crc_errors", "cobs_errors", "length_errors", "overruns", "bytes_discarded", "seq_mismatch",
    "bad_duties", "telem_missing", "unknown_ids", "duplicates", "stale_frames", "retries",
    "late_duty", "missed_duty", "error_frames", "can_unknown_ids", "rx_malformed",
    "ctrl_rx_errors", "ctrl_resets", "ctrl_faults", "rtt_over_delay", "lost_frames",
    "late_answers"};

/* Timing statistics, not link problems (docs/protocol.md 6.5): a busy host that answers a cycle
 * late moves them whatever fault is active, so they are evidence only of a fault that acts on
 * time itself (a delay); a dropped or stalled frame shows as lost_frames. */
static const unsigned char TRACE_TIMING[ENGINE_TRACE_COUNTERS] = {
    [11] = 1u /* retries */, [22] = 1u /* late_answers */};

/** Whether counter `i` is evidence for the fault of trace `t`. */
static int trace_counts(const engine_trace_t *t, int i)
{
    return !TRACE_TIMING[i] || t->delay_s > 0.0;
}

static void trace_counters(const engine_t *e, const engine_trace_t *t,
                           uint64_t v[ENGINE_TRACE_COUNTERS])
{
    const hil_deframer_t *d = &e->link.deframer;
    v[0] = d->crc_errors;
    v[1] = d->cobs_errors;
    v[2] = d->length_errors + e->n.length_errors;
    v[3] = d->overruns;
    v[4] = d->bytes_discarded;
    v[5] = e->n.seq_mismatch;
    v[6] = e->n.bad_duties;
    v[7] = e->n.telem_missing;
    v[8] = e->n.unknown_ids;
    v[9] = e->n.duplicates;
    v[10] = e->n.stale_frames;
    v[11] = e->n.retries;
    v[12] = e->n.late_duty;
    v[13] = e->n.missed_duty;
    v[14] = e->link.c.error_frames;
    v[15] = e->link.c.ext_ids;
    v[16] = e->link.c.rx_malformed;
    v[17] = e->n.ctrl_rx_errors;
    v[18] = e->n.ctrl_resets;
    v[19] = e->n.ctrl_faults;
    v[20] = t->rtt_seen;
    v[21] = e->n.lost_frames;
    v[22] = e->n.late_answers;
}

static void trace_close(engine_t *e, int index, const char *ended);

/** The first action of any fault ends the fault-free part of the run: its round trips become the
 *  baseline a delay's round trips are judged against (eng_rtt_evidence). */
static void freeze_rtt_baseline(engine_t *e)
{
    long b;
    uint32_t acc = 0u;
    e->faults_started = 1;
    e->rtt_min_bin = -1;
    for (b = ENGINE_HIST_BINS - 1; b >= 0; --b) {
        acc += e->rtt_free.bins[b];
        e->rtt_tail[b] = acc;
        if (e->rtt_free.bins[b] != 0u) {
            e->rtt_min_bin = b;
        }
    }
}

/** Fault `index` acted now: start (or extend) its detection window. The windows of other faults
 *  that already have their evidence close now, so what this fault causes is not booked to them;
 *  one still waiting for evidence stays open (its rows then name both: docs/faults.md). */
void eng_trace_act(engine_t *e, int index, long extra_cycles)
{
    engine_trace_t *t;
    int i;
    if (index < 0 || index >= ENGINE_MAX_TRACES) {
        return;
    }
    if (!e->faults_started) {
        freeze_rtt_baseline(e);
    }
    for (i = 0; i < e->n_traces; ++i) {
        if (i != index && e->traces[i].state == 1 && e->traces[i].seen_k >= 0 &&
            e->traces[i].seen_k < e->cur_k) {
            trace_close(e, i, NULL);
        }
    }
    t = &e->traces[index];
    if (t->acted_k < 0) {
        t->acted_k = e->cur_k;
    }
    if (t->state != 1) {
        t->state = 1;
        t->first_k = e->cur_k;
        t->seen_k = -1;
        t->rtt_seen = 0u;
        t->rtt_n = t->rtt_c = 0u;
        t->rtt_p = t->rtt_var = 0.0;
        trace_counters(e, t, t->snap);
        t->close_k = e->cur_k;
    }
    if (e->cur_k + t->window_cycles + extra_cycles > t->close_k) {
        t->close_k = e->cur_k + t->window_cycles + extra_cycles;
    }
}

/** Close trace `index`: one /faults "trace" row with the counters that moved. `ended`: the run
 *  ended while the window was open, for this reason (itself evidence, if not NULL). */
static void trace_close(engine_t *e, int index, const char *ended)
{
    engine_trace_t *t = &e->traces[index];
    uint64_t now[ENGINE_TRACE_COUNTERS];
    char text[ENGINE_MESSAGE];
    int n = 0, i, moved = 0;
    trace_counters(e, t, now);
    text[0] = '\0';
    for (i = 0; i < ENGINE_TRACE_COUNTERS; ++i) {
        if (trace_counts(t, i) && now[i] > t->snap[i] && n < (int)sizeof text - 48) {
            n += snprintf(text + n, sizeof text - (size_t)n, "%s%s +%llu", moved ? ", " : "",
                          TRACE_NAMES[i], (unsigned long long)(now[i] - t->snap[i]));
            moved = 1;
        }
    }
    if (!moved && ended == NULL) {
        t->seen_k = -1;   /* a round trip that looked beyond the baseline and then did not */
    }
    if (ended != NULL && n < (int)sizeof text - 16) {
        n += snprintf(text + n, sizeof text - (size_t)n, "%sthe run ended: %s",
                      moved ? "; " : "", ended);
        if (t->seen_k < 0) {
            t->seen_k = e->cur_k;
        }
    }
    if (!moved && ended == NULL) {
        n = snprintf(text, sizeof text, "no trace: no counter moved within %.4g s of the last "
                     "action", (double)t->window_cycles * e->cfg.ts_s);
        e->n.faults_untraced++;
        t->untraced_windows++;
    }
    if (t->delay_s > 0.0 && n > 0 && n < (int)sizeof text - 200) {
        const double base_n = (double)e->rtt_free.n;
        snprintf(text + n, sizeof text - (size_t)n,
                 " (round trip: %llu of %llu delayed cycles at least the fault-free minimum "
                 "%.1f us + the delay; the %.0f fault-free cycles before any fault make %.3g of "
                 "them expected, evidence from %.3g)",
                 (unsigned long long)t->rtt_c, (unsigned long long)t->rtt_n,
                 e->rtt_min_bin >= 0 ? eng_hist_bin_lower_us(e->rtt_min_bin) : (double)NAN, base_n,
                 t->rtt_p, t->rtt_p + 3.0 * sqrt(t->rtt_var));
    }
    if (t->seen_k >= 0 && (t->evidence_k < 0 || t->seen_k < t->evidence_k)) {
        t->evidence_k = t->seen_k;
    }
    t->windows++;
    eng_record_fault(e, -1, index, t->target, t->name, "", "trace", text,
                 t->seen_k >= 0 ? (double)(t->seen_k - t->first_k) * e->cfg.ts_s : (double)NAN);
    t->state = 2;
}

/** End of the present cycle: first evidence, windows that closed. */
void eng_traces_step(engine_t *e)
{
    int i;
    for (i = 0; i < e->n_traces; ++i) {
        engine_trace_t *t = &e->traces[i];
        if (t->state != 1) {
            continue;
        }
        if (t->seen_k < 0) {
            uint64_t now[ENGINE_TRACE_COUNTERS];
            int j;
            trace_counters(e, t, now);
            for (j = 0; j < ENGINE_TRACE_COUNTERS; ++j) {
                if (trace_counts(t, j) && now[j] > t->snap[j]) {
                    t->seen_k = e->cur_k;
                    break;
                }
            }
        }
        if (e->cur_k >= t->close_k) {
            trace_close(e, i, NULL);
        }
    }
}

/** At least this many fault-free round trips before a delay can be judged by the round trip. */
#define RTT_BASELINE_MIN 100u

/**
 * DELAY faults: does the round trip show the delay beyond what the run shows without it?
 * Before any fault acts, every cycle's SENSE -> DUTY round trip goes into a histogram (the
 * fault-free baseline). Each cycle a delay fault delayed a frame of (its largest drawn delay d)
 * is measured: it shows the delay if its round trip reaches r_min + d, r_min the shortest
 * fault-free round trip; p = the fraction of fault-free cycles that reached that threshold
 * (1 with fewer than RTT_BASELINE_MIN of them). The delayed cycles that showed it, c of n, are
 * evidence (the trace counter rtt_over_delay) only when c > sum p + 3 sqrt(sum p (1 - p)):
 * more than the fault-free cycles make likely (docs/faults.md). A 1 ns delay: every fault-free
 * cycle but those of r_min's bin reaches r_min + 1 ns, c never exceeds the bound.
 */
void eng_rtt_evidence(engine_t *e, const cycle_t *c, int64_t sent_ns)
{
    int i;
    double rtt_us;
    if (!eng_has_link_faults(e) || !c->have_duty) {
        return;
    }
    rtt_us = (double)(c->duty_t_ns - sent_ns) * 1e-3;
    if (!e->faults_started) {
        eng_hist_add(&e->rtt_free, rtt_us);
        return;
    }
    for (i = 0; i < e->n_traces; ++i) {
        engine_trace_t *t = &e->traces[i];
        double p = 1.0;
        long bx;
        if (t->state != 1 || !(t->delay_s > 0.0) || t->delay_k != c->k) {
            continue;
        }
        bx = eng_hist_bin((e->rtt_min_bin >= 0 ? eng_hist_bin_lower_us(e->rtt_min_bin) : 0.0) +
                      t->delay_d_s * 1e6);
        if (e->rtt_free.n >= RTT_BASELINE_MIN) {
            p = (double)e->rtt_tail[bx] / (double)e->rtt_free.n;
        }
        t->rtt_n++;
        t->rtt_p += p;
        t->rtt_var += p * (1.0 - p);
        if (eng_hist_bin(rtt_us) >= bx) {
            t->rtt_c++;
        }
        t->rtt_seen = (double)t->rtt_c > t->rtt_p + 3.0 * sqrt(t->rtt_var) ? t->rtt_c : 0u;
    }
}

/** The run ended: every trace still collecting is closed; an end that is itself a reaction to
 *  the fault (the controller faulted, went silent, the watchdog, a link failure) is evidence. */
void eng_traces_end(engine_t *e)
{
    int i;
    const int evidence = e->end == ENGINE_END_NO_DUTY || e->end == ENGINE_END_CONTROLLER_FAULT ||
                         e->end == ENGINE_END_WATCHDOG || e->end == ENGINE_END_LINK ||
                         e->end == ENGINE_END_BAD_DUTIES || e->end == ENGINE_END_PROTOCOL;
    for (i = 0; i < e->n_traces; ++i) {
        if (e->traces[i].state == 1) {
            trace_close(e, i, evidence ? e->message : NULL);
        }
    }
    /* the run's account of its faults: which acted, which left a trace in every window */
    for (i = 0; i < e->lf.n; ++i) {
        const int idx = e->lfc[i].fault_index;
        if (idx >= 0 && idx < ENGINE_MAX_TRACES) {
            e->traces[idx].matched = e->lf.matched[i];
            e->traces[idx].acted = e->lf.acted[i];
        }
    }
    e->n.faults_acted = e->n.faults_traced = 0u;
    for (i = 0; i < ENGINE_MAX_TRACES; ++i) {
        const engine_trace_t *t = &e->traces[i];
        if (t->planned && t->acted_k >= 0) {
            e->n.faults_acted++;
            if (t->untraced_windows == 0u && t->windows > 0u) {
                e->n.faults_traced++;
            }
        }
    }
}
