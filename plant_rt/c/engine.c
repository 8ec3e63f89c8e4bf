/* The cycle engine (engine.h). */
#define _GNU_SOURCE
#include "engine.h"

#include <errno.h>
#include <math.h>
#include <sched.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/types.h>
#include <time.h>
#include <unistd.h>

#include "hil_msgs.h"

#define TWO_PI (2.0 * 3.14159265358979323846)
#define PI_ 3.14159265358979323846
#define NS_PER_S 1000000000LL

/* ---- small helpers ------------------------------------------------------------------------- */

static void set_message(engine_t *e, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(e->message, sizeof e->message, fmt, ap);
    va_end(ap);
}

/** Python's float modulo (the result has the sign of y), as bench/loop/runner.py used it. */
static double py_mod(double x, double y)
{
    double m = fmod(x, y);
    if (isnan(m) || m < 0.0 || m > 0.0) {
        if ((y < 0.0) != (m < 0.0)) {
            m += y;
        }
    } else {
        m = copysign(0.0, y);
    }
    return m;
}

static double wrap_pi(double x)
{
    return py_mod(x + PI_, TWO_PI) - PI_;
}

/**
 * physical -> raw by docs/protocol.md section 3 (binary64, ties away from zero), exactly as
 * protocol/messages.py does it. 0 ok; -1 NaN; -2 out of range (only without saturate).
 */
static int encode_signal(const engine_signal_t *s, double v, int saturate, long *raw)
{
    double q;
    if (isnan(v)) {
        return -1;
    }
    q = (s->offset < 0.0 || s->offset > 0.0) ? (v - s->offset) / s->scale : v / s->scale;
    if (q > s->raw_min - 0.5 && q < s->raw_max + 0.5) {
        long r = (long)q; /* truncates toward zero, like Python's int() */
        double f = q - (double)r;
        if (f >= 0.5) {
            r += 1;
        } else if (f <= -0.5) {
            r -= 1;
        }
        *raw = r;
        return 0;
    }
    if (!saturate) {
        return -2;
    }
    *raw = (long)((q < s->raw_min) ? s->raw_min : s->raw_max);
    return 0;
}

/** The histogram bin of a wall time [us]. */
static long hist_bin(double us)
{
    long b;
    if (!(us >= 0.0)) {
        us = 0.0;
    }
    if (us < 1000.0) {
        b = (long)(us * 10.0);
    } else if (us < 100000.0) {
        b = ENGINE_HIST_FINE + (long)((us - 1000.0) / 10.0);
    } else {
        b = ENGINE_HIST_BINS - 1;
    }
    return b >= ENGINE_HIST_BINS ? ENGINE_HIST_BINS - 1 : b;
}

/** The lower edge [us] of histogram bin b. */
static double hist_bin_lower_us(long b)
{
    return b < ENGINE_HIST_FINE ? (double)b * 0.1 : 1000.0 + (double)(b - ENGINE_HIST_FINE) * 10.0;
}

static void hist_add(engine_hist_t *h, double us)
{
    const long b = hist_bin(us);
    if (!(us >= 0.0)) {
        us = 0.0;
    }
    h->bins[b]++;
    h->n++;
    if (us > h->max_us) {
        h->max_us = us;
    }
}

double engine_hist_percentile(const engine_hist_t *h, double q)
{
    uint64_t target, acc = 0u;
    long b;
    if (h->n == 0u) {
        return 0.0;
    }
    target = (uint64_t)ceil(q * (double)h->n);
    if (target < 1u) {
        target = 1u;
    }
    for (b = 0; b < ENGINE_HIST_BINS; ++b) {
        acc += h->bins[b];
        if (acc >= target) {
            double upper;
            if (b < ENGINE_HIST_FINE) {
                upper = (double)(b + 1) * 0.1;
            } else if (b < ENGINE_HIST_BINS - 1) {
                upper = 1000.0 + (double)(b - ENGINE_HIST_FINE + 1) * 10.0;
            } else {
                upper = h->max_us;
            }
            return upper < h->max_us ? upper : h->max_us;
        }
    }
    return h->max_us;
}

static void text_reset(char *buf, size_t *len)
{
    buf[0] = '\0';
    *len = 0u;
}

/** Append " ID#DATA" (candump style, hex upper case) to a frames text. */
static void text_frame(char *buf, size_t *len, uint16_t id, const uint8_t *data, uint16_t dlc)
{
    static const char hex[] = "0123456789ABCDEF";
    size_t need = 1u + 4u + 2u * dlc + 1u;
    size_t n = *len;
    uint16_t i;
    if (n + need + 4u >= ENGINE_FRAMES_TEXT) {
        if (n + 4u < ENGINE_FRAMES_TEXT && (n < 3u || strcmp(buf + n - 3u, "...") != 0)) {
            memcpy(buf + n, n ? " ..." : "...", n ? 5u : 4u);
            *len = n + (n ? 4u : 3u);
        }
        return;
    }
    if (n > 0u) {
        buf[n++] = ' ';
    }
    buf[n++] = hex[(id >> 8) & 0xFu];
    buf[n++] = hex[(id >> 4) & 0xFu];
    buf[n++] = hex[id & 0xFu];
    buf[n++] = '#';
    for (i = 0u; i < dlc; ++i) {
        buf[n++] = hex[(data[i] >> 4) & 0xFu];
        buf[n++] = hex[data[i] & 0xFu];
    }
    buf[n] = '\0';
    *len = n;
}

static int64_t t_to_ns(double t_s)
{
    return (int64_t)llround(t_s * 1e9);
}

/* ---- recording -------------------------------------------------------------------------------- */

/** Room for a record: in lockstep wait (bounded) for the recorder; in real time never wait. */
static uint8_t *ring_begin(engine_t *e, size_t max)
{
    uint8_t *p;
    int64_t give_up = 0;
    if (!e->have_ring) {
        return NULL;
    }
    p = rec_ring_begin(&e->ring, max);
    if (p != NULL) {
        e->recorder_stalled = 0;
        return p;
    }
    if (e->cfg.mode == ENGINE_REALTIME || e->recorder_stalled) {
        /* real time never waits; nor does lockstep for a recorder that made no room once */
        rec_ring_count_drop(&e->ring, max);
        e->n.rows_dropped++;
        return NULL;
    }
    e->n.ring_waits++;
    while (p == NULL) {
        struct timespec ts = {0, 100000L};
        int64_t now = eng_now_ns();
        if (give_up == 0) {
            give_up = now + (int64_t)(e->cfg.recorder_stall_s * 1e9);
        } else if (now > give_up) {
            e->recorder_stalled = 1;
            rec_ring_count_drop(&e->ring, max);
            e->n.rows_dropped++;
            return NULL;
        }
        nanosleep(&ts, NULL);
        p = rec_ring_begin(&e->ring, max);
    }
    return p;
}

#define RECORD(e, channel, t_s, max, encoder, row)                                             \
    do {                                                                                       \
        uint8_t *p_ = ((channel) == ENGINE_NO_CHANNEL) ? NULL : ring_begin((e), (max));        \
        if (p_ != NULL) {                                                                      \
            size_t n_ = encoder(p_, (max), (row));                                             \
            if (n_ > 0u) {                                                                     \
                rec_ring_commit(&(e)->ring, (channel), t_to_ns(t_s), n_);                      \
            }                                                                                  \
        }                                                                                      \
    } while (0)

static void record_event(engine_t *e, double t_s, const char *kind, const char *text,
                         double value)
{
    rec_event_t ev;
    ev.t_s = t_s;
    ev.kind = kind;
    ev.text = text;
    ev.value = value;
    RECORD(e, e->cfg.ch_events, t_s, 64u + strlen(kind) + strlen(text), rec_encode_event, &ev);
}

/** Is cycle k recorded in full (not decimated away)? */
static int record_full(const engine_t *e, long k)
{
    int i;
    if (e->cfg.record_every <= 1 || k % e->cfg.record_every == 0 || k < e->full_rate_until) {
        return 1;
    }
    for (i = 0; i < e->n_full_rate; ++i) {
        if (k >= e->full_rate[i][0] && k < e->full_rate[i][1]) {
            return 1;
        }
    }
    return 0;
}

static void full_rate_from_now(engine_t *e, long cycles)
{
    if (e->cur_k + cycles > e->full_rate_until) {
        e->full_rate_until = e->cur_k + cycles;
    }
}

/** A /faults row at the present cycle's time. */
static void record_fault(engine_t *e, int32_t seq, int index, const char *target,
                         const char *kind, const char *direction, const char *action,
                         const char *text, double value)
{
    rec_fault_t r;
    r.t_s = e->cur_t_s;
    r.seq = seq;
    r.index = index;
    r.target = target;
    r.kind = kind;
    r.direction = direction;
    r.action = action;
    r.text = text;
    r.value = value;
    RECORD(e, e->cfg.ch_faults, r.t_s, 96u + strlen(target) + strlen(kind) + strlen(direction) +
               strlen(action) + strlen(text), rec_encode_fault, &r);
}

/* ---- fault traces: the evidence a fault left in the counters ------------------------------------ */

static const char *const TRACE_NAMES[ENGINE_TRACE_COUNTERS] = {
    "crc_errors", "cobs_errors", "length_errors", "overruns", "bytes_discarded", "seq_mismatch",
    "bad_duties", "telem_missing", "unknown_ids", "duplicates", "stale_frames", "retries",
    "late_duty", "missed_duty", "error_frames", "can_unknown_ids", "rx_malformed",
    "ctrl_rx_errors", "ctrl_resets", "ctrl_faults", "rtt_over_delay"};

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
}

static void trace_close(engine_t *e, int index, const char *ended);

/** The first action of any fault ends the fault-free part of the run: its round trips become the
 *  baseline a delay's round trips are judged against (rtt_evidence). */
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
static void trace_act(engine_t *e, int index, long extra_cycles)
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
        if (now[i] > t->snap[i] && n < (int)sizeof text - 48) {
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
                 e->rtt_min_bin >= 0 ? hist_bin_lower_us(e->rtt_min_bin) : (double)NAN, base_n,
                 t->rtt_p, t->rtt_p + 3.0 * sqrt(t->rtt_var));
    }
    if (t->seen_k >= 0 && (t->evidence_k < 0 || t->seen_k < t->evidence_k)) {
        t->evidence_k = t->seen_k;
    }
    t->windows++;
    record_fault(e, -1, index, t->target, t->name, "", "trace", text,
                 t->seen_k >= 0 ? (double)(t->seen_k - t->first_k) * e->cfg.ts_s : (double)NAN);
    t->state = 2;
}

/** End of the present cycle: first evidence, windows that closed. */
static void traces_step(engine_t *e)
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
                if (now[j] > t->snap[j]) {
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

/* ---- the link through the faults ------------------------------------------------------------- */

static int has_link_faults(const engine_t *e)
{
    return e->lf.n > 0;
}

static int link_tx(engine_t *e, uint16_t id, const uint8_t *data, uint16_t dlc)
{
    if (!has_link_faults(e)) {
        return eng_link_queue(&e->link, id, data, dlc);
    }
    return elf_tx(&e->lf, &e->link, id, data, dlc, eng_now_ns());
}

static int link_flush(engine_t *e, int64_t deadline_ns)
{
    if (has_link_faults(e)) {
        (void)elf_tx_due(&e->lf, &e->link, eng_now_ns());
    }
    return eng_link_flush(&e->link, deadline_ns);
}

static int link_pop(engine_t *e, eng_frame_t *f)
{
    int64_t now;
    if (!has_link_faults(e)) {
        return eng_link_pop(&e->link, f);
    }
    now = eng_now_ns();
    elf_rx_pump(&e->lf, &e->link, now);
    return elf_rx_pop(&e->lf, f, now);
}

/** eng_link_poll through the faults: frames held back (delays) become due, delayed frames to
 *  the controller go out when due. Returns the frames due now (>= 0), or -1 (link failed). */
static int link_poll(engine_t *e, int64_t deadline_ns)
{
    if (!has_link_faults(e)) {
        return eng_link_poll(&e->link, deadline_ns);
    }
    for (;;) {
        const int64_t now = eng_now_ns();
        int64_t next, wake;
        unsigned ready;
        if (elf_tx_due(&e->lf, &e->link, now) > 0 &&
            eng_link_flush(&e->link, now + 100000000LL) != 0) {
            return -1;
        }
        elf_rx_pump(&e->lf, &e->link, now);
        ready = elf_rx_ready(&e->lf, now);
        if (ready > 0u) {
            return (int)ready;
        }
        if (now >= deadline_ns) {
            return 0;
        }
        next = elf_next_due_ns(&e->lf);
        wake = next < deadline_ns ? next : deadline_ns;
        if (eng_link_poll(&e->link, wake) < 0) {
            elf_rx_pump(&e->lf, &e->link, eng_now_ns());
            return -1;
        }
    }
}

static const char *direction_name(int dir)
{
    return dir == (ELF_TO_CONTROLLER | ELF_FROM_CONTROLLER) ? "both"
           : dir == ELF_TO_CONTROLLER                      ? "to_controller"
                                                           : "from_controller";
}

/** The link-fault injector acted on a frame (or started a stall / a garbage burst). */
static void link_fault_acted(void *ctx, int i, int dir, const char *action, uint16_t id,
                             const uint8_t *data, uint16_t dlc, double value)
{
    engine_t *e = (engine_t *)ctx;
    const engine_link_fault_t *lf = &e->lfc[i];
    char text[128];
    int32_t seq = -1;
    long extra = 0;
    if (data != NULL && dlc >= 2u && id >= 0x100u && id < 0x200u) {
        seq = (int32_t)((unsigned)data[0] | ((unsigned)data[1] << 8)); /* cycle frames: seq first */
    }
    if (data != NULL) {
        snprintf(text, sizeof text, "%s of frame 0x%03X%s", action, (unsigned)id,
                 seq >= 0 ? " (cycle message, seq in the frame)" : "");
    } else {
        snprintf(text, sizeof text, "%s", action);
    }
    e->n.faults_injected++;
    record_fault(e, seq, lf->fault_index, "link", lf->name, direction_name(dir), action, text,
                 value);
    if (strcmp(action, "drop") == 0) {
        e->cyc_drop++;
        e->cyc_drop_fault = lf->fault_index;
    } else if (strcmp(action, "stall_drop") == 0) {
        e->cyc_stall_drop++;
        e->cyc_stall_fault = lf->fault_index;
    } else if (strcmp(action, "delay") == 0) {
        engine_trace_t *t = &e->traces[lf->fault_index];
        e->cyc_delay++;
        e->cyc_delay_fault = lf->fault_index;
        if (t->delay_k != e->cur_k || value > t->delay_d_s) {
            t->delay_d_s = value;
        }
        t->delay_k = e->cur_k;
    }
    if (lf->lf.kind == ELF_STALL) {
        extra = (long)ceil(lf->lf.stall_s / e->cfg.ts_s);
    } else if (lf->lf.kind == ELF_DELAY) {
        extra = (long)ceil(value / e->cfg.ts_s);
    }
    if (strcmp(action, "stall_drop") != 0) {   /* the stall itself opened the trace */
        trace_act(e, lf->fault_index, extra);
    }
    full_rate_from_now(e, e->cfg.post_trigger_cycles + extra);
}

void engine_write_stats(engine_t *e, double t_s, const eng_link_counters_t *extra)
{
    rec_link_stats_t s;
    const eng_link_counters_t *c = &e->link.c;
    const hil_deframer_t *d = &e->link.deframer;
    memset(&s, 0, sizeof s);
    s.t_s = t_s;
    s.cycles = (uint64_t)e->cycles_done;
    s.frames_tx = c->frames_tx;
    s.frames_rx = c->frames_rx;
    s.bytes_tx = c->bytes_tx;
    s.bytes_rx = c->bytes_rx;
    s.frames_ok = (e->link.kind == ENG_LINK_SERIAL) ? d->frames_ok : c->frames_rx;
    s.crc_errors = d->crc_errors;
    s.cobs_errors = d->cobs_errors;
    s.length_errors = d->length_errors + e->n.length_errors;
    s.overruns = d->overruns;
    s.bytes_discarded = d->bytes_discarded;
    s.seq_mismatch = e->n.seq_mismatch;
    s.bad_duties = e->n.bad_duties;
    s.telem_missing = e->n.telem_missing;
    s.unknown_ids = e->n.unknown_ids;
    s.heartbeats_rx = e->n.heartbeats_rx;
    s.duplicates = e->n.duplicates;
    s.stale_frames = e->n.stale_frames;
    s.retries = e->n.retries;
    s.late_duty = e->n.late_duty;
    s.missed_duty = e->n.missed_duty;
    s.estimator_mismatch = e->n.estimator_mismatch;
    s.rt_overruns = e->n.rt_overruns;
    s.ctrl_rx_errors = e->n.ctrl_rx_errors;
    s.ctrl_resets = e->n.ctrl_resets;
    s.ctrl_faults = e->n.ctrl_faults;
    s.duties_after_trip = e->n.duties_after_trip;
    s.faults_injected = e->n.faults_injected;
    s.faults_untraced = e->n.faults_untraced;
    s.rows_dropped = e->have_ring ? e->ring.hdr->records_dropped : 0u;
    s.error_frames = c->error_frames;
    s.remote_frames = c->remote_frames;
    s.can_unknown_ids = c->ext_ids;
    s.rx_malformed = c->rx_malformed;
    s.send_failures = c->send_failures;
    s.bus_state_changes = c->bus_state_changes;
    if (extra != NULL) { /* a bridged interface's own counters (python-can side) */
        s.error_frames += extra->error_frames;
        s.remote_frames += extra->remote_frames;
        s.can_unknown_ids += extra->ext_ids;
        s.rx_malformed += extra->rx_malformed;
        s.send_failures += extra->send_failures;
        s.bus_state_changes += extra->bus_state_changes;
    }
    s.cycle_wall_p50_us = engine_hist_percentile(&e->hist_cycle, 0.5);
    s.cycle_wall_p99_us = engine_hist_percentile(&e->hist_cycle, 0.99);
    s.cycle_wall_max_us = e->hist_cycle.max_us;
    s.jitter_p50_us = engine_hist_percentile(&e->hist_jitter, 0.5);
    s.jitter_p99_us = engine_hist_percentile(&e->hist_jitter, 0.99);
    s.jitter_p999_us = engine_hist_percentile(&e->hist_jitter, 0.999);
    s.jitter_max_us = e->hist_jitter.max_us;
    RECORD(e, e->cfg.ch_stats, t_s, REC_MAX_FIXED_SIZE, rec_encode_link_stats, &s);
}

/** Link tap: the octets of a serial link into the ring (engine_config_t.capture_serial). */
static void serial_tap(void *ctx, int direction, const uint8_t *data, size_t n, int64_t t_ns)
{
    engine_t *e = (engine_t *)ctx;
    uint8_t *p = ring_begin(e, n + 1u);
    if (p != NULL) {
        p[0] = (uint8_t)direction;
        memcpy(p + 1, data, n);
        rec_ring_commit(&e->ring, e->cfg.ch_serial_raw, t_ns, n + 1u);
    }
}

/* ---- set-up -------------------------------------------------------------------------------- */

void engine_default_config(engine_config_t *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->mode = ENGINE_LOCKSTEP;
    cfg->duty_update = ENGINE_DUTY_ON_ARRIVAL;
    cfg->pole_pairs = 1;
    cfg->rpm_per_rad_s = 60.0 / TWO_PI;
    cfg->estimator_expected = -1;
    cfg->retry_timeout_s = 0.05;
    cfg->max_retries = 3;
    cfg->max_consecutive_bad_duties = 10;
    cfg->max_consecutive_misses = 10;
    cfg->guard_s = 10e-6;
    cfg->rt_cpu = -1;
    cfg->spin_s = 30e-6;
    cfg->recorder_stall_s = 2.0;
    cfg->stats_every_cycles = 1000;
    cfg->record_frames = 1;
    cfg->link_fd = -1;
    cfg->ch_faults = ENGINE_NO_CHANNEL;
    cfg->record_every = 1;
    cfg->late_grace_s = 1.0;
}

int engine_init(engine_t *e, const engine_config_t *cfg, plant_t *plant, void *ring_mem,
                size_t ring_size)
{
    memset(e, 0, sizeof *e);
    e->cfg = *cfg;
    e->plant = plant;
    e->last_state = -1;
    e->end = ENGINE_END_CONFIG;
    {
        const int needs_link = cfg->source == ENGINE_SOURCE_PLANT ||
                               cfg->source == ENGINE_SOURCE_REPLAY_CONTROLLER;
        const int needs_plant = cfg->source == ENGINE_SOURCE_PLANT ||
                                cfg->source == ENGINE_SOURCE_REPLAY_PLANT;
        const int needs_rows = cfg->source != ENGINE_SOURCE_PLANT;
        if ((needs_plant && plant == NULL) || !(cfg->ts_s > 0.0) || cfg->n_cycles < 0 ||
            (needs_link && cfg->link_fd < 0 && cfg->link_peer.write == NULL) ||
            (needs_rows && cfg->replay_cycles == NULL) ||
            (cfg->source == ENGINE_SOURCE_REPLAY_CONTROLLER && cfg->replay_frames == NULL) ||
            cfg->source < ENGINE_SOURCE_PLANT || cfg->source > ENGINE_SOURCE_REPLAY_ESTIMATORS ||
            !(cfg->sig_i.scale > 0.0) || !(cfg->sig_vdc.scale > 0.0) || cfg->duty_raw_full == 0u) {
            set_message(e, "engine: incomplete configuration (plant, ts_s, link fd, replay rows, "
                        "DBC constants)");
            return -1;
        }
    }
    if (cfg->source == ENGINE_SOURCE_REPLAY_CONTROLLER) {
        long k;
        for (k = 0; k < cfg->n_cycles; ++k) {
            const engine_replay_cycle_t *row = &cfg->replay_cycles[k];
            if ((long)row->first_frame + (long)row->n_frames > cfg->replay_n_frames) {
                set_message(e, "engine: replay row %ld names frames beyond the capture", k);
                return -1;
            }
        }
    }
    if (cfg->mode != ENGINE_LOCKSTEP && cfg->mode != ENGINE_REALTIME) {
        set_message(e, "engine: unknown mode %d", cfg->mode);
        return -1;
    }
    if (ring_mem != NULL) {
        if (rec_ring_attach(&e->ring, ring_mem, ring_size) != 0) {
            set_message(e, "engine: the recording ring is not formatted");
            return -1;
        }
        e->have_ring = 1;
    }
    if (cfg->link_peer.write != NULL) {
        if (cfg->link_peer.read == NULL || cfg->link_kind != ENG_LINK_SERIAL) {
            set_message(e, "engine: an in-process controller needs read and write, on the serial "
                        "framing");
            return -1;
        }
        hil_deframer_init(&e->link.deframer);
        eng_link_attach_peer(&e->link, &cfg->link_peer);
    } else if (cfg->link_fd >= 0) {
        eng_link_init(&e->link, cfg->link_fd, cfg->link_kind);
    } else {
        hil_deframer_init(&e->link.deframer);
        e->link.fd = -1;
    }
    e->link.fd_brs = cfg->can_brs;
    if (!e->have_ring) {
        e->cfg.record_frames = 0; /* the frames' text is only ever recorded */
    }
    if (cfg->capture_serial && e->have_ring &&
        (cfg->link_fd >= 0 || cfg->link_peer.write != NULL) &&
        cfg->link_kind == ENG_LINK_SERIAL) {
        e->link.tap = serial_tap;
        e->link.tap_ctx = e;
    }
    e->duties[0] = e->duties[1] = e->duties[2] = 0.5;
    e->cmd_seq = cfg->cmd_seq_start;
    e->trip_cycle = -1;
    e->rtt_min_bin = -1;
    elf_init(&e->lf, link_fault_acted, e);
    e->end = ENGINE_END_DONE;
    return 0;
}

int engine_attach_inbox(engine_t *e, void *mem, size_t size)
{
    live_inbox_t *b = live_inbox_attach(mem, size);
    if (b == NULL) {
        set_message(e, "engine: the operator inputs' mailbox is not formatted");
        return -1;
    }
    e->inbox = b;
    return 0;
}

int engine_add_reference(engine_t *e, int kind, const void *config, size_t config_size,
                         uint16_t channel)
{
    int rc;
    if (e->n_refs >= ENGINE_MAX_REFS) {
        set_message(e, "engine: more than %d reference estimators", ENGINE_MAX_REFS);
        return -1;
    }
    rc = eng_ref_init(&e->refs[e->n_refs], kind, config, config_size);
    if (rc != 0) {
        set_message(e, "engine: reference estimator kind %d: %s", kind,
                    rc == -1 ? "unknown kind or wrong configuration size" :
                               "the estimator refused its configuration");
        return -1;
    }
    e->ref_channel[e->n_refs] = channel;
    e->n_refs++;
    return 0;
}

/** The plant fault an ENGINE_EV_PLANT_FAULT event switches on. */
static plant_fault_t event_plant_fault(const engine_event_t *ev)
{
    plant_fault_t pf;
    pf.kind = ev->fault_kind;
    pf.phase = ev->fault_phase;
    pf.phase2 = ev->fault_phase2;
    pf.level = ev->fault_level;
    pf.value = ev->value;
    return pf;
}

/** Name a fault's trace and its detection window. */
static int trace_setup(engine_t *e, int index, const char *name, const char *target,
                       double detect_within_s, double delay_s)
{
    engine_trace_t *t;
    if (index < 0 || index >= ENGINE_MAX_TRACES || !(detect_within_s >= 0.0)) {
        set_message(e, "engine: fault index %d out of [0, %d) or a negative detection window",
                    index, ENGINE_MAX_TRACES);
        return -1;
    }
    t = &e->traces[index];
    if (index >= e->n_traces) {
        e->n_traces = index + 1;
    }
    snprintf(t->name, sizeof t->name, "%s", name);
    snprintf(t->target, sizeof t->target, "%s", target);
    t->window_cycles = (long)ceil(detect_within_s / e->cfg.ts_s);
    t->delay_s = delay_s;
    t->seen_k = -1;
    t->planned = 1;
    t->acted_k = t->evidence_k = -1;
    t->delay_k = -1;
    return 0;
}

static void add_full_rate_window(engine_t *e, long from, long to)
{
    if (e->cfg.record_every > 1 && e->n_full_rate < ENGINE_MAX_EVENTS + ENGINE_MAX_LINK_FAULTS) {
        e->full_rate[e->n_full_rate][0] = from - e->cfg.pre_trigger_cycles;
        e->full_rate[e->n_full_rate][1] = to + e->cfg.post_trigger_cycles;
        e->n_full_rate++;
    }
}

int engine_add_full_rate(engine_t *e, long from_k, long to_k)
{
    if (e->cfg.record_every <= 1) {
        return 0; /* every cycle is recorded anyway */
    }
    if (e->n_full_rate >= ENGINE_MAX_EVENTS + ENGINE_MAX_LINK_FAULTS || to_k < from_k) {
        set_message(e, "engine: too many full-rate windows, or one that ends before it starts");
        return -1;
    }
    e->full_rate[e->n_full_rate][0] = from_k;
    e->full_rate[e->n_full_rate][1] = to_k;
    e->n_full_rate++;
    return 0;
}

int engine_add_event(engine_t *e, const engine_event_t *ev)
{
    const int is_fault = ev->kind == ENGINE_EV_PLANT_FAULT ||
                         ev->kind == ENGINE_EV_PLANT_FAULT_CLEAR ||
                         ev->kind == ENGINE_EV_CONTROLLER_RESET;
    if (e->n_events >= ENGINE_MAX_EVENTS ||
        (e->n_events > 0 && ev->cycle < e->events[e->n_events - 1].cycle)) {
        set_message(e, "engine: too many events or events out of order");
        return -1;
    }
    if (ev->kind == ENGINE_EV_PLANT_FAULT) {
        const plant_fault_t pf = event_plant_fault(ev);
        const char *why = plant_fault_check(e->plant, &pf);
        if (why != NULL) {
            set_message(e, "engine: plant fault %s at cycle %ld: %s", ev->fault_name, ev->cycle, why);
            return -1;
        }
    }
    if (is_fault) {
        if (ev->kind != ENGINE_EV_PLANT_FAULT_CLEAR &&
            trace_setup(e, ev->fault_index, ev->fault_name,
                        ev->kind == ENGINE_EV_CONTROLLER_RESET ? "controller" : "plant",
                        ev->detect_within_s, 0.0) != 0) {
            return -1;
        }
        add_full_rate_window(e, ev->cycle, ev->cycle);
    }
    e->events[e->n_events] = *ev;
    e->events[e->n_events].text[ENGINE_EVENT_TEXT - 1] = '\0';
    e->events[e->n_events].fault_name[sizeof ev->fault_name - 1] = '\0';
    e->n_events++;
    return 0;
}

int engine_add_link_fault(engine_t *e, const engine_link_fault_t *f)
{
    char why[320];
    if (e->cfg.source != ENGINE_SOURCE_PLANT && e->cfg.source != ENGINE_SOURCE_REPLAY_CONTROLLER) {
        set_message(e, "engine: link faults need a link (a live run or a replay into a controller)");
        return -1;
    }
    if (elf_add(&e->lf, &f->lf, (int)e->link.kind, why, sizeof why) != 0) {
        set_message(e, "engine: link fault %s: %s", f->name, why);
        return -1;
    }
    e->lfc[e->lf.n - 1] = *f;
    e->lfc[e->lf.n - 1].name[sizeof f->name - 1] = '\0';
    if (trace_setup(e, f->fault_index, f->name, "link", f->detect_within_s,
                    f->lf.kind == ELF_DELAY ? f->lf.delay_s + f->lf.jitter_s : 0.0) != 0) {
        e->lf.n--;
        return -1;
    }
    add_full_rate_window(e, f->lf.cycle_on,
                         f->lf.cycle_off > f->lf.cycle_on ? f->lf.cycle_off : f->lf.cycle_on);
    return 0;
}

void engine_request_stop(engine_t *e)
{
    __atomic_store_n(&e->stop_requested, 1, __ATOMIC_RELEASE);
}

static int stop_asked(engine_t *e)
{
    return __atomic_load_n(&e->stop_requested, __ATOMIC_ACQUIRE);
}

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
    double late_s;         /* lockstep: a DUTY(k) after the retries, this long after the first
                            * send (NaN: none within late_grace_s) */
    /* the frames of the SENSE group, for re-sending */
    uint8_t aux[8], dual[8], sense[8];
    int have_dual;
    const engine_replay_cycle_t *replay; /* replay into a controller: the recorded frames */
} cycle_t;

static void queue_frame(engine_t *e, uint16_t id, const uint8_t *data)
{
    (void)link_tx(e, id, data, 8u);
    if (e->cfg.record_frames) {
        text_frame(e->tx_text, &e->tx_len, id, data, 8u);
    }
}

static void queue_sense_group(engine_t *e, const cycle_t *c)
{
    queue_frame(e, (uint16_t)HIL_SENSE_AUX_FRAME_ID, c->aux);
    if (c->have_dual) {
        queue_frame(e, (uint16_t)HIL_SENSE_DUAL_FRAME_ID, c->dual);
    }
    queue_frame(e, (uint16_t)HIL_SENSE_FRAME_ID, c->sense);
}

/** The SENSE group again (lockstep retry): the recorded one in a replay. */
static void queue_resend(engine_t *e, const cycle_t *c)
{
    if (c->replay != NULL) {
        uint32_t i;
        for (i = 0u; i < c->replay->n_frames; ++i) {
            const engine_replay_frame_t *f = &e->cfg.replay_frames[c->replay->first_frame + i];
            if (f->id == HIL_SENSE_AUX_FRAME_ID || f->id == HIL_SENSE_DUAL_FRAME_ID ||
                f->id == HIL_SENSE_FRAME_ID) {
                (void)link_tx(e, f->id, f->data, f->dlc);
                if (e->cfg.record_frames) {
                    text_frame(e->tx_text, &e->tx_len, f->id, f->data, f->dlc);
                }
            }
        }
        return;
    }
    queue_sense_group(e, c);
}

/** A CMD frame (the run's next CMD seq) sent with this cycle's SENSE frames. */
static void queue_cmd(engine_t *e, int command, double value)
{
    hil_cmd_t m;
    uint8_t buf[8];
    m.command = (uint16_t)command;
    m.seq = e->cmd_seq++;
    m.value = (float)value;
    if (hil_cmd_pack(buf, &m, sizeof buf) > 0) {
        queue_frame(e, (uint16_t)HIL_CMD_FRAME_ID, buf);
    }
}

/** Events due at cycle k: CMD frames queued, plant inputs set, /events rows. */
static void apply_events(engine_t *e, int *next_event, const cycle_t *c)
{
    while (*next_event < e->n_events && e->events[*next_event].cycle <= c->k) {
        const engine_event_t *ev = &e->events[(*next_event)++];
        switch (ev->kind) {
        case ENGINE_EV_CMD:
            queue_cmd(e, ev->command, ev->value);
            break;
        case ENGINE_EV_LOAD:
            plant_set_load_torque(e->plant, ev->value);
            break;
        case ENGINE_EV_DYNO_SPEED:
            plant_set_dyno_speed(e->plant, ev->value);
            break;
        case ENGINE_EV_PLANT_FAULT: {
            const plant_fault_t pf = event_plant_fault(ev);
            char text[160];
            if (plant_set_fault(e->plant, &pf) != 0) {
                const char *why = plant_fault_check(e->plant, &pf);
                snprintf(text, sizeof text, "refused by the plant: %s",
                         why != NULL ? why : "(no reason)");
                if (ev->fault_index >= 0 && ev->fault_index < ENGINE_MAX_TRACES) {
                    e->traces[ev->fault_index].refused = 1;
                }
                record_fault(e, (int32_t)c->seq, ev->fault_index, "plant", ev->fault_name, "",
                             "refused", text, ev->value);
            } else {
                snprintf(text, sizeof text, "%s", ev->text[0] ? ev->text : ev->fault_name);
                record_fault(e, (int32_t)c->seq, ev->fault_index, "plant", ev->fault_name, "",
                             "on", text, ev->value);
                trace_act(e, ev->fault_index, 0);
            }
            full_rate_from_now(e, e->cfg.post_trigger_cycles);
            break;
        }
        case ENGINE_EV_PLANT_FAULT_CLEAR:
            plant_clear_fault(e->plant, ev->fault_kind, ev->fault_phase);
            record_fault(e, (int32_t)c->seq, ev->fault_index, "plant", ev->fault_name, "", "off",
                         ev->text[0] ? ev->text : ev->fault_name, ev->value);
            full_rate_from_now(e, e->cfg.post_trigger_cycles);
            break;
        case ENGINE_EV_CONTROLLER_RESET: {
            /* in band: CMD RESTART goes out with this cycle's frames, before its SENSE_AUX and
             * SENSE, so the controller restarts at a defined cycle whatever the timing (and a
             * port running the firmware in the engine's thread sees the same) */
            hil_cmd_t m;
            uint8_t buf[8];
            char text[128];
            m.command = (uint16_t)HIL_CMD_RESTART;
            m.seq = e->cmd_seq++;
            m.value = 0.0f;
            if (hil_cmd_pack(buf, &m, sizeof buf) > 0) {
                queue_frame(e, (uint16_t)HIL_CMD_FRAME_ID, buf);
            }
            snprintf(text, sizeof text, "CMD RESTART (CMD seq %u) sent with the frames of cycle "
                     "%ld, before its SENSE", (unsigned)m.seq, c->k);
            record_fault(e, (int32_t)c->seq, ev->fault_index, "controller", ev->fault_name, "",
                         "on", text, 0.0);
            e->cyc_restart++;
            e->cyc_restart_fault = ev->fault_index;
            trace_act(e, ev->fault_index, 0);
            full_rate_from_now(e, e->cfg.post_trigger_cycles);
            break;
        }
        default:
            break;
        }
        if (ev->record) {
            record_event(e, c->t_s, "scenario", ev->text, ev->record_value);
        }
    }
}

/* ---- operator inputs (live.h) ----------------------------------------------------------------- */

static void operator_refused(engine_t *e, const cycle_t *c, const live_input_t *in,
                             const char *why)
{
    char text[LIVE_INPUT_TEXT + 160];
    if (why != NULL) {
        snprintf(text, sizeof text, "%s: refused: %s (cycle %ld)", in->text, why, c->k);
    } else {
        snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
    }
    e->n.operator_refused++;
    record_event(e, c->t_s, "operator_refused", text, in->value);
}

/** One operator input, applied at cycle c (before its SENSE). */
static void apply_input(engine_t *e, const cycle_t *c, const live_input_t *in)
{
    char text[LIVE_INPUT_TEXT + 64];
    const int lockstep = e->cfg.mode == ENGINE_LOCKSTEP;
    if (e->cfg.source != ENGINE_SOURCE_PLANT && in->kind != LIVE_IN_REFUSED) {
        /* a replay plays the capture's own inputs (the live view refuses before; this holds
         * whatever a producer pushes) */
        operator_refused(e, c, in, "a replay plays the capture's own inputs");
        return;
    }
    switch (in->kind) {
    case LIVE_IN_SPEED_REF:
        if (!isfinite(in->value)) {
            operator_refused(e, c, in, "not a finite speed");
            return;
        }
        queue_cmd(e, (int)HIL_CMD_SET_SPEED_REF, in->value);
        break;
    case LIVE_IN_LOAD:
        if (!isfinite(in->value)) {
            operator_refused(e, c, in, "not a finite torque");
            return;
        }
        plant_set_load_torque(e->plant, in->value);
        break;
    case LIVE_IN_PAUSE:
        if (!lockstep) {
            operator_refused(e, c, in, "a real-time run cannot pause: the controller runs on its "
                                       "own clock");
            return;
        }
        if (e->paused) {
            operator_refused(e, c, in, "the run is paused already");
            return;
        }
        e->paused = 1;
        snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
        record_event(e, c->t_s, "operator_pause", text, 0.0);
        return;
    case LIVE_IN_RESUME:
        if (!e->paused) {
            operator_refused(e, c, in, "the run is not paused");
            return;
        }
        e->paused = 0;
        snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
        record_event(e, c->t_s, "operator_resume", text, 0.0);
        return;
    case LIVE_IN_REFUSED:
        operator_refused(e, c, in, NULL);
        return;
    default:
        operator_refused(e, c, in, "unknown input kind");
        return;
    }
    e->n.operator_inputs++;
    full_rate_from_now(e, e->cfg.post_trigger_cycles);
    snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
    record_event(e, c->t_s, "operator", text, in->value);
}

/** Every operator input pending now, applied at cycle c. */
static void take_inputs(engine_t *e, const cycle_t *c)
{
    live_input_t in;
    unsigned n = 0u;
    if (e->inbox == NULL) {
        return;
    }
    while (n++ < LIVE_INBOX_SLOTS && live_inbox_take(e->inbox, &in)) {
        apply_input(e, c, &in);
    }
}

static int drain_frames(engine_t *e, cycle_t *c, int cycle_open, int *completed);
static void link_failed(engine_t *e, const cycle_t *c);

/**
 * Lockstep, paused by an operator before cycle c's SENSE: read the link (heartbeats, a
 * FAULT_CTRL ends the run as ever) and the mailbox every few ms until a resume or a stop.
 * 0, or -1 with e->end set.
 */
static int hold_while_paused(engine_t *e, cycle_t *c)
{
    const int64_t t0 = eng_now_ns();
    while (e->paused) {
        int completed = 0;
        if (stop_asked(e)) {
            e->end = ENGINE_END_STOPPED;
            set_message(e, "stopped at cycle %ld while paused by the operator", c->k);
            return -1;
        }
        if (link_poll(e, eng_now_ns() + 5000000LL) < 0) {
            link_failed(e, c);
            return -1;
        }
        if (drain_frames(e, c, 0, &completed) != 0) {
            return -1;
        }
        take_inputs(e, c);
    }
    e->paused_ns += eng_now_ns() - t0;
    return 0;
}

/** Sample the plant (it is at t_k), encode the SENSE group. 0, or -1 (ENGINE_END_PLANT set). */
static int build_sense(engine_t *e, cycle_t *c)
{
    const engine_config_t *cfg = &e->cfg;
    hil_sense_aux_t aux;
    hil_sense_t sense;
    long raw[3], r;
    double theta_max;
    int k;
    plant_sample(e->plant, &c->smp);
    plant_snapshot(e->plant, &c->snap);
    /* SENSE_AUX: bus voltage and (only when asked) the encoder angle, which wraps at 2 pi */
    aux.seq = c->seq;
    if (encode_signal(&cfg->sig_vdc, c->smp.v_dc_v, 0, &r) != 0) {
        e->end = ENGINE_END_PLANT;
        set_message(e, "at cycle %ld (t = %.4f s): bus voltage %g V cannot be sent (SENSE_AUX.v_dc "
                    "range [%g, %g] V)", c->k, c->t_s, c->smp.v_dc_v,
                    cfg->sig_vdc.raw_min * cfg->sig_vdc.scale, cfg->sig_vdc.raw_max * cfg->sig_vdc.scale);
        return -1;
    }
    aux.v_dc = (uint16_t)r;
    aux.flags = 0u;
    aux.theta_enc = 0u;
    c->theta_enc = (double)NAN;
    if (cfg->send_encoder && c->smp.enc_valid) {
        /* the plant's encoder (theta_e, unless an encoder fault holds or drops it); the 16-bit
         * angle wraps at 2 pi (docs/protocol.md 3) */
        theta_max = TWO_PI - 0.5 * cfg->sig_theta.scale;
        c->theta_enc = (c->smp.theta_enc_rad < theta_max) ? c->smp.theta_enc_rad : 0.0;
        if (encode_signal(&cfg->sig_theta, c->theta_enc, 0, &r) != 0) {
            e->end = ENGINE_END_PLANT;
            set_message(e, "at cycle %ld: encoder angle %g rad is not finite", c->k,
                        c->smp.theta_enc_rad);
            return -1;
        }
        aux.theta_enc = (uint16_t)r;
        aux.flags = cfg->aux_flag_theta_valid;
    }
    c->have_dual = cfg->dual_sampling && c->smp.dual_valid;
    if (c->have_dual) {
        hil_sense_dual_t d;
        const double i2[3] = {c->smp.i2_a_a, c->smp.i2_b_a, c->smp.i2_c_a};
        aux.flags = (uint16_t)(aux.flags | cfg->aux_flag_dual_follows);
        for (k = 0; k < 3; ++k) {
            if (encode_signal(&cfg->sig_i2, i2[k], 1, &raw[k]) != 0) {
                e->end = ENGINE_END_PLANT;
                set_message(e, "at cycle %ld (t = %.4f s): second current sample is not finite",
                            c->k, c->t_s);
                return -1;
            }
        }
        d.seq = c->seq;
        d.i_a2 = (int16_t)raw[0];
        d.i_b2 = (int16_t)raw[1];
        d.i_c2 = (int16_t)raw[2];
        (void)hil_sense_dual_pack(c->dual, &d, sizeof c->dual);
    }
    (void)hil_sense_aux_pack(c->aux, &aux, sizeof c->aux);
    {
        const double i1[3] = {c->smp.i_a_a, c->smp.i_b_a, c->smp.i_c_a};
        for (k = 0; k < 3; ++k) {
            if (encode_signal(&cfg->sig_i, i1[k], 1, &raw[k]) != 0) {
                e->end = ENGINE_END_PLANT;
                set_message(e, "at cycle %ld (t = %.4f s): phase current sample is not finite "
                            "(plant state diverged)", c->k, c->t_s);
                return -1;
            }
            c->s_i[k] = (double)raw[k] * cfg->sig_i.scale;
        }
    }
    sense.seq = c->seq;
    sense.i_a = (int16_t)raw[0];
    sense.i_b = (int16_t)raw[1];
    sense.i_c = (int16_t)raw[2];
    (void)hil_sense_pack(c->sense, &sense, sizeof c->sense);
    return 0;
}

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
        record_event(e, c->t_s, "length_error", text, (double)f->id);
    }
}

/** A DUTY's raw duty as the plant takes it: -1 OFF (the leg disabled), 0..1 the high-side on
 *  fraction, NaN out of range (a bad duty, docs/protocol.md 6.6). */
static double duty_of_raw(const engine_t *e, uint32_t raw)
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
        if (isnan(duty_of_raw(e, raw[k]))) {
            char text[160];
            e->n.bad_duties++;
            snprintf(text, sizeof text, "DUTY seq %u raw [%u, %u, %u] out of range, and late "
                     "(its period had ended): never applied", (unsigned)d->seq,
                     (unsigned)raw[0], (unsigned)raw[1], (unsigned)raw[2]);
            record_event(e, c->t_s, "bad_duty", text, (double)d->seq);
            return;
        }
    }
}

/**
 * Handle one received frame while cycle c waits (lockstep and real time alike).
 * Returns 1 if it completed the cycle (the first valid DUTY(k)), 0 otherwise, -1 if it ends
 * the run (FAULT_CTRL; e->end set).
 */
static int handle_frame(engine_t *e, cycle_t *c, const eng_frame_t *f, int cycle_open)
{
    const uint16_t prev_seq = (uint16_t)(c->seq - 1u);
    if (e->cfg.record_frames) {
        text_frame(e->rx_text, &e->rx_len, f->id, f->data, f->dlc);
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
            return 1;
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
            c->th_hat = (double)t.theta_hat * e->cfg.scale_theta_hat;
            c->w_hat = (double)t.omega_hat * e->cfg.scale_omega_hat;
            c->st = (int)t.state;
            c->est = (int)t.estimator;
        } else {
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
            c->e_a = (double)m.e_alpha * e->cfg.scale_e;
            c->e_b = (double)m.e_beta * e->cfg.scale_e;
            c->iq_ref = (double)m.i_q_ref * e->cfg.scale_iq_ref;
        } else {
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
            set_message(e, "at cycle %ld (t = %.4f s): FAULT_CTRL with %u octets (expected %u): "
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
            record_fault(e, (int32_t)m.seq, -1, "controller", "fault_ctrl", "", "trip", text,
                         (double)m.code);
            record_event(e, c->t_s, "controller_fault", text, (double)m.code);
            if (e->trip_cycle < 0) {
                e->trip_cycle = c->k;
                full_rate_from_now(e, e->cfg.post_trip_cycles + e->cfg.post_trigger_cycles);
            }
            return 0;
        }
        e->end = ENGINE_END_CONTROLLER_FAULT;
        set_message(e, "at cycle %ld (t = %.4f s): controller fault", c->k, c->t_s);
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
                record_event(e, c->t_s, "controller_restart", "HEARTBEAT_CTRL counter started "
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
    set_message(e, "at cycle %ld (t = %.4f s): no valid DUTY after %d retries (%.3g s): %s",
                c->k, c->t_s, c->retries,
                (double)(c->retries + 1) * e->cfg.retry_timeout_s,
                n ? what : "nothing at all (the controller is silent)");
}

/** Validate DUTY(k): 1 applied, 0 held (bad duty, counted), -1 too many bad in a row. */
static int take_duties(engine_t *e, const cycle_t *c)
{
    double d[3];
    int k, bad = 0;
    for (k = 0; k < 3; ++k) {
        d[k] = duty_of_raw(e, c->duty_raw[k]);
        if (isnan(d[k])) {
            bad = 1;
            d[k] = 0.0;
        }
    }
    if (bad) {
        char text[128];
        e->n.bad_duties++;
        e->consecutive_bad++;
        snprintf(text, sizeof text, "DUTY seq %u raw [%u, %u, %u] out of range; previous duties held",
                 (unsigned)c->seq, (unsigned)c->duty_raw[0], (unsigned)c->duty_raw[1],
                 (unsigned)c->duty_raw[2]);
        record_event(e, c->t_s, "bad_duty", text, (double)c->seq);
        if (e->consecutive_bad >= e->cfg.max_consecutive_bad_duties) {
            e->end = ENGINE_END_BAD_DUTIES;
            set_message(e, "at cycle %ld: %d consecutive DUTY frames out of range; inverter "
                        "disabled, run ended", c->k, e->consecutive_bad);
            return -1;
        }
        return 0;
    }
    e->consecutive_bad = 0;
    if (e->trip_cycle >= 0 && c->k >= e->trip_cycle && !(d[0] < 0.0 && d[1] < 0.0 && d[2] < 0.0)) {
        /* the controller declared a fault but drives the inverter: the plant sees it */
        if (e->n.duties_after_trip++ == 0u) {
            char text[128];
            snprintf(text, sizeof text, "DUTY seq %u [%.4f, %.4f, %.4f] after the controller's "
                     "FAULT_CTRL: not all legs off", (unsigned)c->seq, d[0], d[1], d[2]);
            record_fault(e, (int32_t)c->seq, -1, "controller", "fault_ctrl", "",
                         "duty_after_trip", text, (double)c->k);
        }
    }
    e->duties[0] = d[0];
    e->duties[1] = d[1];
    e->duties[2] = d[2];
    return 1;
}

/** Rows of cycle k: state at t_k, what was sent, what came back, frames, state changes. */
static void record_cycle(engine_t *e, cycle_t *c)
{
    const engine_config_t *cfg = &e->cfg;
    const plant_snapshot_t *s = &c->snap;
    const double theta = s->theta_e_rad;
    if (!e->have_ring) {
        text_reset(e->rx_text, &e->rx_len);
        if (c->have_telem && c->st >= 0) {
            e->last_state = c->st; /* a restart is told by it, recorded or not */
        }
        return;
    }
    if (!record_full(e, c->k)) {
        goto state_change; /* decimated away: only what changed state is recorded */
    }
    e->n.state_rows++;
    {
        rec_plant_state_t r;
        r.t_s = c->t_s;
        r.i_a_a = s->i_a_a; r.i_b_a = s->i_b_a; r.i_c_a = s->i_c_a;
        r.i_alpha_a = s->i_alpha_a; r.i_beta_a = s->i_beta_a;
        r.i_d_a = s->i_d_a; r.i_q_a = s->i_q_a;
        r.omega_m_rad_s = s->omega_m_rad_s; r.omega_e_rad_s = s->omega_e_rad_s;
        r.theta_e_rad = s->theta_e_rad; r.theta_m_rad = s->theta_m_rad;
        r.torque_e_nm = s->torque_e_nm; r.torque_load_nm = s->torque_load_nm;
        r.e_alpha_v = s->e_alpha_v; r.e_beta_v = s->e_beta_v; r.v_dc_v = s->v_dc_v;
        r.v_a_v = s->v_a_v; r.v_b_v = s->v_b_v; r.v_c_v = s->v_c_v;
        r.v_alpha_v = s->v_alpha_v; r.v_beta_v = s->v_beta_v; r.v_d_v = s->v_d_v; r.v_q_v = s->v_q_v;
        r.speed_rpm = s->omega_m_rad_s * cfg->rpm_per_rad_s;
        RECORD(e, cfg->ch_state, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_plant_state, &r);
    }
    {
        rec_sense_t r;
        r.t_s = c->t_s;
        r.seq = c->seq;
        r.i_a_a = c->s_i[0]; r.i_b_a = c->s_i[1]; r.i_c_a = c->s_i[2];
        r.v_dc_v = c->smp.v_dc_v;
        r.theta_enc_rad = c->theta_enc;
        RECORD(e, cfg->ch_sense, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_sense, &r);
    }
    {
        rec_telemetry_t r;
        r.t_s = c->t_s;
        r.seq = c->seq;
        if (c->have_telem) {
            r.theta_hat_rad = c->th_hat;
            r.omega_hat_rad_s = c->w_hat;
            r.state = c->st;
            r.estimator = c->est;
        } else {
            r.theta_hat_rad = r.omega_hat_rad_s = (double)NAN;
            r.state = r.estimator = -1;
        }
        r.speed_hat_rpm = r.omega_hat_rad_s / (double)cfg->pole_pairs * cfg->rpm_per_rad_s;
        r.e_alpha_v = c->have_emf ? c->e_a : (double)NAN;
        r.e_beta_v = c->have_emf ? c->e_b : (double)NAN;
        r.i_q_ref_a = c->have_emf ? c->iq_ref : (double)NAN;
        r.duty_a = e->duties[0]; r.duty_b = e->duties[1]; r.duty_c = e->duties[2];
        r.pee_rad = wrap_pi(r.theta_hat_rad - theta);
        RECORD(e, cfg->ch_telem, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_telemetry, &r);
    }
    if (cfg->record_frames) {
        rec_frames_t r;
        r.t_s = c->t_s;
        r.seq = (int32_t)c->seq;
        r.tx = e->tx_text;
        r.rx = e->rx_text;
        RECORD(e, cfg->ch_frames, c->t_s, 64u + e->tx_len + e->rx_len, rec_encode_frames, &r);
    }
state_change:
    text_reset(e->rx_text, &e->rx_len);
    if (c->have_telem && c->st != e->last_state && c->st >= 0) {
        const char *name = (c->st < ENGINE_STATE_NAMES && cfg->state_names[c->st][0] != '\0')
                               ? cfg->state_names[c->st] : "?";
        record_event(e, c->t_s, "controller_state", name, (double)c->st);
        e->last_state = c->st;
    }
}

typedef struct {
    int have_prev, have_older;
    double prev[2], older[2];  /* alpha-beta voltage of the last two duty sets */
    double w_split;            /* fraction of the last period the older duties acted */
} ref_voltage_t;

/** Alpha-beta voltage an averaged inverter realises from duties (0 if a leg is off). */
static int duties_to_ab(const double d[3], double v_dc, double out[2])
{
    if (d[0] < 0.0 || d[1] < 0.0 || d[2] < 0.0) {
        return 0;
    }
    out[0] = (2.0 * d[0] - d[1] - d[2]) * (v_dc / 3.0);
    out[1] = (d[1] - d[2]) * (v_dc * (1.0 / sqrt(3.0)));
    return 1;
}

/**
 * Reference estimators of cycle k: the currents the controller was sent and the voltage that
 * acted over the last period (the older duties for the first w_split of it, then the newer).
 * Then remember the duties that act next (applied = the set in effect after this cycle).
 */
static void step_references(engine_t *e, const cycle_t *c, ref_voltage_t *v, int shift)
{
    const engine_config_t *cfg = &e->cfg;
    const double inv_sqrt3 = 1.0 / sqrt(3.0);
    int i;
    if (e->n_refs == 0 || !e->have_ring) {
        return; /* a reference's only output is its recorded rows: unrecorded, nobody reads it */
    }
    if (v->have_prev && v->have_older) {
        const double i_al = (2.0 * c->s_i[0] - c->s_i[1] - c->s_i[2]) * (1.0 / 3.0);
        const double i_be = (c->s_i[1] - c->s_i[2]) * inv_sqrt3;
        const double w = v->w_split;
        const double v_al = w * v->older[0] + (1.0 - w) * v->prev[0];
        const double v_be = w * v->older[1] + (1.0 - w) * v->prev[1];
        fw_vec2_t iv, vv;
        iv.x = (float)i_al;
        iv.y = (float)i_be;
        vv.x = (float)v_al;
        vv.y = (float)v_be;
        const int full = record_full(e, c->k);
        for (i = 0; i < e->n_refs; ++i) {
            const est_output_t *o = eng_ref_step(&e->refs[i], iv, vv);
            rec_reference_t r;
            if (!full) {
                continue; /* the estimator steps every cycle; its row is decimated away */
            }
            r.t_s = c->t_s;
            r.seq = c->seq;
            r.theta_hat_rad = (double)o->theta_e_rad;
            r.omega_hat_rad_s = (double)o->omega_e_rad_s;
            r.speed_hat_rpm = r.omega_hat_rad_s / (double)cfg->pole_pairs * cfg->rpm_per_rad_s;
            r.e_alpha_v = (double)o->e_alpha_v;
            r.e_beta_v = (double)o->e_beta_v;
            r.pee_rad = wrap_pi(r.theta_hat_rad - c->snap.theta_e_rad);
            RECORD(e, e->ref_channel[i], c->t_s, REC_MAX_FIXED_SIZE, rec_encode_reference, &r);
        }
    }
    if (shift) {
        v->have_older = v->have_prev;
        v->older[0] = v->prev[0];
        v->older[1] = v->prev[1];
        v->have_prev = duties_to_ab(e->duties, c->smp.v_dc_v, v->prev);
    }
}

static void begin_cycle(engine_t *e, cycle_t *c, long k)
{
    const hil_deframer_t *d = &e->link.deframer;
    memset(c, 0, sizeof *c);
    c->k = k;
    c->seq = (uint16_t)(k & 0xFFFF);
    e->late_state[c->seq & (ENGINE_LATE_WINDOW - 1)] = 0; /* this seq's earlier lap is over */
    c->t_s = (double)k * e->cfg.ts_s;
    e->cur_k = k;
    e->cur_t_s = c->t_s;
    c->st = c->est = -1;
    c->crc0 = d->crc_errors;
    c->cobs0 = d->cobs_errors;
    c->len0 = d->length_errors;
    c->over0 = d->overruns;
    c->hb0 = e->n.heartbeats_rx;
    c->late_s = (double)NAN;
    e->cyc_drop = e->cyc_stall_drop = e->cyc_delay = e->cyc_restart = 0u;
    e->resets_at_cycle = e->n.ctrl_resets;
    text_reset(e->tx_text, &e->tx_len);
    /* rx_text is not reset here: frames that arrive after a real-time period's rows were
     * written (late DUTY, heartbeats) belong in the next row's rx (record_cycle resets it) */
}

static void after_telemetry(engine_t *e, const cycle_t *c)
{
    if (!c->have_telem || (e->cfg.telem_emf && !c->have_emf)) {
        e->n.telem_missing++; /* at most once a cycle: TELEM, or the TELEM_EMF HELLO asked for */
    }
    if (c->have_telem && e->cfg.estimator_expected >= 0 && c->est != e->cfg.estimator_expected) {
        e->n.estimator_mismatch++;
    }
}

static int plant_finite(engine_t *e, const cycle_t *c)
{
    const double w = e->plant->y[2];
    if (!isfinite(w) || !isfinite(e->plant->y[0]) || !isfinite(e->plant->y[1])) {
        e->end = ENGINE_END_PLANT;
        set_message(e, "at cycle %ld: plant state became non-finite", c->k);
        return 0;
    }
    return 1;
}

static void link_failed(engine_t *e, const cycle_t *c)
{
    e->end = ENGINE_END_LINK;
    set_message(e, "at cycle %ld (t = %.4f s): %s", c->k, c->t_s,
                e->link.error[0] ? e->link.error : "link failed");
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
static void rtt_evidence(engine_t *e, const cycle_t *c, int64_t sent_ns)
{
    int i;
    double rtt_us;
    if (!has_link_faults(e) || !c->have_duty) {
        return;
    }
    rtt_us = (double)(c->duty_t_ns - sent_ns) * 1e-3;
    if (!e->faults_started) {
        hist_add(&e->rtt_free, rtt_us);
        return;
    }
    for (i = 0; i < e->n_traces; ++i) {
        engine_trace_t *t = &e->traces[i];
        double p = 1.0;
        long bx;
        if (t->state != 1 || !(t->delay_s > 0.0) || t->delay_k != c->k) {
            continue;
        }
        bx = hist_bin((e->rtt_min_bin >= 0 ? hist_bin_lower_us(e->rtt_min_bin) : 0.0) +
                      t->delay_d_s * 1e6);
        if (e->rtt_free.n >= RTT_BASELINE_MIN) {
            p = (double)e->rtt_tail[bx] / (double)e->rtt_free.n;
        }
        t->rtt_n++;
        t->rtt_p += p;
        t->rtt_var += p * (1.0 - p);
        if (hist_bin(rtt_us) >= bx) {
            t->rtt_c++;
        }
        t->rtt_seen = (double)t->rtt_c > t->rtt_p + 3.0 * sqrt(t->rtt_var) ? t->rtt_c : 0u;
    }
}

/** A fault run: the controller tripped post_trip_cycles ago; its reaction is recorded, the run
 *  ends now. 1 (e->end set) or 0. */
static int trip_over(engine_t *e, const cycle_t *c)
{
    if (e->trip_cycle < 0 || c->k < e->trip_cycle + e->cfg.post_trip_cycles) {
        return 0;
    }
    e->end = ENGINE_END_CONTROLLER_FAULT;
    set_message(e, "at cycle %ld (t = %.4f s): controller fault (its reaction recorded for %ld "
                "cycles after the FAULT_CTRL)", e->trip_cycle,
                (double)e->trip_cycle * e->cfg.ts_s, c->k - e->trip_cycle);
    return 1;
}

/** The start of cycle k, after its scenario events: link faults that start now. */
static void faults_begin_cycle(engine_t *e, long k)
{
    if (has_link_faults(e)) {
        elf_begin_cycle(&e->lf, &e->link, k, eng_now_ns());
    }
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
        while (link_pop(e, &f)) {
            r = handle_frame(e, c, &f, 1);
            if (r < 0) {
                return -1;
            }
            if (r == 1) {
                c->late_s = (double)(f.t_ns - sent_ns) * 1e-9;
                c->have_duty = 0;
                return 0;
            }
        }
        if (stop_asked(e) || eng_now_ns() >= deadline || link_poll(e, deadline) < 0) {
            return 0;
        }
    }
}

/**
 * Lockstep exchange of cycle c: send what is queued, wait for the first valid DUTY(seq), re-send
 * the SENSE group on silence (at most max_retries times). 0, or -1 with e->end set.
 */
static int exchange_lockstep(engine_t *e, cycle_t *c, int64_t c0, int64_t *sent_ns)
{
    const engine_config_t *cfg = &e->cfg;
    const int64_t retry_ns = (int64_t)(cfg->retry_timeout_s * 1e9);
    int64_t deadline;
    int done = 0;
    if (link_flush(e, c0 + NS_PER_S) != 0) {
        link_failed(e, c);
        return -1;
    }
    *sent_ns = eng_now_ns();
    deadline = *sent_ns + retry_ns;
    while (!done) {
        eng_frame_t f;
        int r;
        while (!done && link_pop(e, &f)) {
            r = handle_frame(e, c, &f, 1);
            if (r < 0) {
                return -1;
            }
            done = r;
        }
        if (done) {
            break;
        }
        r = link_poll(e, deadline);
        if (r < 0) {
            link_failed(e, c);
            return -1;
        }
        if (r > 0) {
            continue;
        }
        if (stop_asked(e)) {
            e->end = ENGINE_END_STOPPED;
            set_message(e, "stopped at cycle %ld while waiting for DUTY", c->k);
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
        queue_resend(e, c);
        if (link_flush(e, eng_now_ns() + NS_PER_S) != 0) {
            link_failed(e, c);
            return -1;
        }
        deadline = eng_now_ns() + retry_ns;
    }
    return 0;
}


static int64_t wait_until(int64_t deadline_ns, int64_t spin_ns);

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
    now = wait_until(deadline, 0);
    *start_err_ns = now - deadline;
    hist_add(&e->hist_jitter, (double)*start_err_ns * 1e-3);
    return now;
}

static int run_lockstep(engine_t *e)
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
        if (stop_asked(e)) {
            e->end = ENGINE_END_STOPPED;
            set_message(e, "stopped at cycle %ld", k);
            return e->end;
        }
        c0 = lockstep_pace(e, k, &start_err_ns);
        begin_cycle(e, &c, k);
        apply_events(e, &next_event, &c);
        take_inputs(e, &c);
        if (e->paused) {
            if (hold_while_paused(e, &c) != 0) {
                return e->end;
            }
            c0 = eng_now_ns();
        }
        faults_begin_cycle(e, k);
        if (build_sense(e, &c) != 0) {
            return e->end;
        }
        queue_sense_group(e, &c);
        if (exchange_lockstep(e, &c, c0, &sent_ns) != 0) {
            return e->end;
        }
        rtt_evidence(e, &c, sent_ns);
        if (take_duties(e, &c) < 0) {
            return e->end;
        }
        after_telemetry(e, &c);
        record_cycle(e, &c);
        step_references(e, &c, &rv, 1);
        plant_step(e->plant, e->duties);
        e->prev_had_duty = 1;
        {
            const int64_t c1 = eng_now_ns();
            rec_timing_t t;
            hist_add(&e->hist_cycle, (double)(c1 - c0) * 1e-3);
            if (e->have_ring && record_full(e, k)) {
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
        if (!plant_finite(e, &c)) {
            return e->end;
        }
        traces_step(e);
        if (trip_over(e, &c)) {
            return e->end;
        }
    }
    return ENGINE_END_DONE;
}

/* ---- replay ------------------------------------------------------------------------------------ */

/** Replay rows as fast as possible, or paced: row k starts at t0 + (its recorded time - the
 *  first row's) * pace_s / ts_s (absolute deadlines; pace_s = Ts / rate), so a gap in the
 *  capture is a pause of its recorded length, not one period. The pacing error of each row goes
 *  to the jitter histogram. */
static int64_t replay_pace(engine_t *e, long k, int64_t *start_err_ns)
{
    int64_t now;
    if (!(e->cfg.pace_s > 0.0)) {
        *start_err_ns = 0;
        return eng_now_ns();
    }
    if (k == 0) {
        e->t0_ns = eng_now_ns() + 1000000LL;
    }
    {
        const double dt_rec = e->cfg.replay_cycles[k].t_s - e->cfg.replay_cycles[0].t_s;
        const int64_t deadline =
            e->t0_ns + (int64_t)llround(dt_rec * (e->cfg.pace_s / e->cfg.ts_s) * 1e9);
        now = wait_until(deadline, (int64_t)(e->cfg.spin_s * 1e9));
        *start_err_ns = now - deadline;
        hist_add(&e->hist_jitter, (double)*start_err_ns * 1e-3);
    }
    return now;
}

static void replay_timing_row(engine_t *e, const cycle_t *c, int64_t c0, int64_t sent_ns,
                              int64_t start_err_ns)
{
    const int64_t c1 = eng_now_ns();
    rec_timing_t t;
    hist_add(&e->hist_cycle, (double)(c1 - c0) * 1e-3);
    if (!e->have_ring) {
        return;
    }
    t.t_s = c->t_s;
    t.seq = c->seq;
    t.start_err_us = (e->cfg.pace_s > 0.0) ? (double)start_err_ns * 1e-3 : (double)NAN;
    t.rtt_us = (sent_ns > 0 && c->have_duty) ? (double)(c->duty_t_ns - sent_ns) * 1e-3
                                              : (double)NAN;
    t.arrival_us = (double)NAN;
    t.cycle_us = (double)(c1 - c0) * 1e-3;
    t.missed = 0u;
    t.retries = (uint32_t)c->retries;
    t.late_total = e->n.late_duty;
    t.missed_total = e->n.missed_duty;
    t.overrun = 0u;
    RECORD(e, e->cfg.ch_timing, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_timing, &t);
}

/** Start replayed cycle k: stop request, pacing, the cycle with the row's time, seq, samples
 *  and angle. 0, or -1 with e->end set (stopped). */
static int replay_begin(engine_t *e, cycle_t *c, long k, int64_t *c0, int64_t *start_err)
{
    const engine_replay_cycle_t *row = &e->cfg.replay_cycles[k];
    if (stop_asked(e)) {
        e->end = ENGINE_END_STOPPED;
        set_message(e, "stopped at replayed cycle %ld", k);
        return -1;
    }
    *c0 = replay_pace(e, k, start_err);
    begin_cycle(e, c, k);
    c->t_s = row->t_s;
    e->cur_t_s = c->t_s;
    c->seq = (uint16_t)row->seq;
    c->s_i[0] = row->i_abc_a[0];
    c->s_i[1] = row->i_abc_a[1];
    c->s_i[2] = row->i_abc_a[2];
    c->smp.v_dc_v = row->v_dc_v;
    c->snap.theta_e_rad = row->has_theta ? row->theta_rad : (double)NAN;
    c->theta_enc = (double)NAN;
    take_inputs(e, c);   /* bench replay --live: a viewer's inputs, every one refused on /events */
    return 0;
}

/** The recorded DUTY of a row, validated as a live one; without one the last duties hold. */
static int take_recorded_duties(engine_t *e, cycle_t *c, const engine_replay_cycle_t *row)
{
    if (!row->has_duty) {
        e->n.missed_duty++;
        return 0;
    }
    c->have_duty = 1;
    c->duty_raw[0] = row->duty_raw[0];
    c->duty_raw[1] = row->duty_raw[1];
    c->duty_raw[2] = row->duty_raw[2];
    return take_duties(e, c) < 0 ? -1 : 0;
}

/** End replayed cycle k: its timing row, progress, statistics. */
static void replay_end(engine_t *e, const cycle_t *c, long k, int64_t c0, int64_t sent_ns,
                       int64_t start_err)
{
    replay_timing_row(e, c, c0, sent_ns, start_err);
    __atomic_store_n(&e->cycles_done, k + 1, __ATOMIC_RELEASE);
    if (e->cfg.stats_every_cycles > 0 && (k + 1) % e->cfg.stats_every_cycles == 0) {
        engine_write_stats(e, c->t_s, NULL);
    }
}

/** The recorded frames of each cycle to a live controller; its answers beside the recorded. */
static int run_replay_controller(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    long k;
    for (k = 0; k < cfg->n_cycles; ++k) {
        const engine_replay_cycle_t *row = &cfg->replay_cycles[k];
        cycle_t c;
        int64_t start_err, c0, sent_ns = 0;
        uint32_t i;
        if (replay_begin(e, &c, k, &c0, &start_err) != 0) {
            return e->end;
        }
        c.replay = row;
        faults_begin_cycle(e, k);
        for (i = 0u; i < row->n_frames; ++i) {
            const engine_replay_frame_t *f = &cfg->replay_frames[row->first_frame + i];
            (void)link_tx(e, f->id, f->data, f->dlc);
            if (cfg->record_frames) {
                text_frame(e->tx_text, &e->tx_len, f->id, f->data, f->dlc);
            }
        }
        if (exchange_lockstep(e, &c, c0, &sent_ns) != 0 || take_duties(e, &c) < 0) {
            return e->end;
        }
        after_telemetry(e, &c);
        record_cycle(e, &c);
        if (e->have_ring) {
            rec_replay_controller_t r;
            r.t_s = c.t_s;
            r.seq = c.seq;
            r.duty_a_rec = row->has_duty ? duty_of_raw(e, row->duty_raw[0]) : (double)NAN;
            r.duty_b_rec = row->has_duty ? duty_of_raw(e, row->duty_raw[1]) : (double)NAN;
            r.duty_c_rec = row->has_duty ? duty_of_raw(e, row->duty_raw[2]) : (double)NAN;
            r.duty_a = duty_of_raw(e, c.duty_raw[0]);
            r.duty_b = duty_of_raw(e, c.duty_raw[1]);
            r.duty_c = duty_of_raw(e, c.duty_raw[2]);
            r.theta_hat_rec_rad = row->has_telem ? row->theta_hat_rad : (double)NAN;
            r.omega_hat_rec_rad_s = row->has_telem ? row->omega_hat_rad_s : (double)NAN;
            r.theta_hat_rad = c.have_telem ? c.th_hat : (double)NAN;
            r.omega_hat_rad_s = c.have_telem ? c.w_hat : (double)NAN;
            r.state_rec = row->has_telem ? row->state : -1;
            r.estimator_rec = row->has_telem ? row->estimator : -1;
            r.state = c.have_telem ? c.st : -1;
            r.estimator = c.have_telem ? c.est : -1;
            r.e_alpha_rec_v = row->has_emf ? row->e_alpha_v : (double)NAN;
            r.e_beta_rec_v = row->has_emf ? row->e_beta_v : (double)NAN;
            r.i_q_ref_rec_a = row->has_emf ? row->i_q_ref_a : (double)NAN;
            r.e_alpha_v = c.have_emf ? c.e_a : (double)NAN;
            r.e_beta_v = c.have_emf ? c.e_b : (double)NAN;
            r.i_q_ref_a = c.have_emf ? c.iq_ref : (double)NAN;
            RECORD(e, cfg->ch_replay, c.t_s, REC_MAX_FIXED_SIZE, rec_encode_replay_controller, &r);
        }
        e->prev_had_duty = 1;
        replay_end(e, &c, k, c0, sent_ns, start_err);
        traces_step(e);
    }
    return ENGINE_END_DONE;
}

/** The plant's part of a replayed cycle: its sampled currents beside the recorded ones (NaN for a
 *  cycle the capture misses). */
static void replay_plant_row(engine_t *e, const cycle_t *c, const engine_replay_cycle_t *row)
{
    rec_replay_plant_t r;
    if (!e->have_ring) {
        return;
    }
    r.t_s = c->t_s;
    r.seq = c->seq;
    r.i_a_rec_a = row != NULL ? row->i_abc_a[0] : (double)NAN;
    r.i_b_rec_a = row != NULL ? row->i_abc_a[1] : (double)NAN;
    r.i_c_rec_a = row != NULL ? row->i_abc_a[2] : (double)NAN;
    r.i_a_a = c->s_i[0];
    r.i_b_a = c->s_i[1];
    r.i_c_a = c->s_i[2];
    RECORD(e, e->cfg.ch_replay, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_replay_plant, &r);
}

/** The recorded duties drive the plant open loop (no link); its currents beside the recorded,
 *  reference estimators on its samples. The plant keeps its own time (step * Ts): a cycle the
 *  capture misses (a gap in the rows' times) is stepped through with the last duties held, as
 *  a drive whose DUTY did not come (counted in missed_duty), and recorded without recorded
 *  currents beside it. */
static int run_replay_plant(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    ref_voltage_t rv;
    int next_event = 0;
    long k, step = 0;
    memset(&rv, 0, sizeof rv);
    rv.w_split = cfg->t_delay_s / cfg->ts_s;
    for (k = 0; k < cfg->n_cycles; ++k) {
        const engine_replay_cycle_t *row = &cfg->replay_cycles[k];
        cycle_t c;
        int64_t start_err, c0;
        long missing = (k == 0) ? 0 : (long)llround((row->t_s - row[-1].t_s) / cfg->ts_s) - 1;
        if (replay_begin(e, &c, k, &c0, &start_err) != 0) {
            return e->end;
        }
        for (; missing > 0; --missing, ++step) {
            cycle_t g;
            begin_cycle(e, &g, step);
            apply_events(e, &next_event, &g);
            if (build_sense(e, &g) != 0) {
                return e->end;
            }
            e->n.missed_duty++;
            record_cycle(e, &g);
            replay_plant_row(e, &g, NULL);
            step_references(e, &g, &rv, 1);
            plant_step(e->plant, e->duties);
            if (!plant_finite(e, &g)) {
                return e->end;
            }
        }
        c.k = step;
        c.t_s = (double)step * cfg->ts_s;       /* the plant's own time */
        ++step;
        apply_events(e, &next_event, &c);
        if (build_sense(e, &c) != 0 || take_recorded_duties(e, &c, row) != 0) {
            return e->end;
        }
        record_cycle(e, &c);
        replay_plant_row(e, &c, row);
        step_references(e, &c, &rv, 1);
        plant_step(e->plant, e->duties);
        e->speed_rpm = e->plant->y[2] * cfg->rpm_per_rad_s;
        replay_end(e, &c, k, c0, 0, start_err);
        if (!plant_finite(e, &c)) {
            return e->end;
        }
    }
    return ENGINE_END_DONE;
}

/** Offline: the reference estimators on the recorded samples and the voltage the recorded
 *  duties applied -- the same step_references the live loop uses, so a recording replayed
 *  gives bit-identical estimates with the same build. */
static int run_replay_estimators(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    ref_voltage_t rv;
    long k;
    memset(&rv, 0, sizeof rv);
    rv.w_split = cfg->t_delay_s / cfg->ts_s;
    for (k = 0; k < cfg->n_cycles; ++k) {
        cycle_t c;
        int64_t start_err, c0;
        if (replay_begin(e, &c, k, &c0, &start_err) != 0 ||
            take_recorded_duties(e, &c, &cfg->replay_cycles[k]) != 0) {
            return e->end;
        }
        step_references(e, &c, &rv, 1);
        replay_end(e, &c, k, c0, 0, start_err);
    }
    return ENGINE_END_DONE;
}

/* ---- real time --------------------------------------------------------------------------------- */

static void rt_note(engine_t *e, const char *what, int err)
{
    size_t n = strlen(e->rt_notes);
    if (n + 8u < sizeof e->rt_notes) {
        snprintf(e->rt_notes + n, sizeof e->rt_notes - n, "%s%s: %s", n ? "; " : "", what,
                 strerror(err));
    }
}

static void rt_setup(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    (void)prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL); /* wake at the deadline, not 50 us later */
    if (cfg->rt_mlock) {
        if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
            e->rt_mlock = 1;
        } else {
            rt_note(e, "mlockall", errno);
        }
    }
    if (cfg->rt_priority > 0) {
        struct sched_param sp;
        memset(&sp, 0, sizeof sp);
        sp.sched_priority = cfg->rt_priority;
        if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0) {
            e->rt_fifo = 1;
        } else {
            rt_note(e, "SCHED_FIFO", errno);
        }
    }
    if (cfg->rt_cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET((size_t)cfg->rt_cpu, &set);
        if (sched_setaffinity(0, sizeof set, &set) == 0) {
            e->rt_pinned = 1;
        } else {
            rt_note(e, "CPU pinning", errno);
        }
    }
}

/** One real-time period's /link/timing row (start error, round trip, arrival, miss). */
static void rt_record_timing(engine_t *e, const cycle_t *c, int64_t start_err_ns, int completed,
                             int64_t sent_ns, int64_t t_k)
{
    rec_timing_t t;
    if (!e->have_ring || !record_full(e, c->k)) {
        return;
    }
    t.t_s = c->t_s;
    t.seq = c->seq;
    t.start_err_us = (double)start_err_ns * 1e-3;
    t.rtt_us = completed ? (double)(c->duty_t_ns - sent_ns) * 1e-3 : (double)NAN;
    t.arrival_us = completed ? (double)(c->duty_t_ns - t_k) * 1e-3 : (double)NAN;
    t.cycle_us = (double)(eng_now_ns() - t_k) * 1e-3;
    t.missed = completed ? 0u : 1u;
    t.retries = 0u;
    t.late_total = e->n.late_duty;
    t.missed_total = e->n.missed_duty;
    t.overrun = 0u;
    RECORD(e, e->cfg.ch_timing, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_timing, &t);
}

/** The /link/timing row of a period the bench lost (it woke late_ns after the period's start,
 *  a whole period or more): no SENSE, no DUTY, the held duties acted. */
static void rt_record_lost(engine_t *e, const cycle_t *c, int64_t late_ns)
{
    rec_timing_t t;
    if (!e->have_ring || !record_full(e, c->k)) {
        return;
    }
    t.t_s = c->t_s;
    t.seq = c->seq;
    t.start_err_us = (double)late_ns * 1e-3;
    t.rtt_us = (double)NAN;
    t.arrival_us = (double)NAN;
    t.cycle_us = (double)NAN;
    t.missed = 0u;
    t.retries = 0u;
    t.late_total = e->n.late_duty;
    t.missed_total = e->n.missed_duty;
    t.overrun = 1u;
    RECORD(e, e->cfg.ch_timing, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_timing, &t);
}

static void rt_teardown(engine_t *e)
{
    if (e->rt_fifo) {
        struct sched_param sp;
        memset(&sp, 0, sizeof sp);
        (void)sched_setscheduler(0, SCHED_OTHER, &sp);
    }
    if (e->rt_mlock) {
        (void)munlockall();
    }
}

/** Sleep to deadline - spin, then spin to the deadline. Returns the time it is now. */
static int64_t wait_until(int64_t deadline_ns, int64_t spin_ns)
{
    int64_t now = eng_now_ns();
    if (deadline_ns - now > spin_ns) {
        struct timespec ts;
        const int64_t wake = deadline_ns - spin_ns;
        ts.tv_sec = (time_t)(wake / NS_PER_S);
        ts.tv_nsec = (long)(wake % NS_PER_S);
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
        }
    }
    do {
        now = eng_now_ns();
    } while (now < deadline_ns);
    return now;
}

/** Handle the frames that are queued now; cycle_open: DUTY(k) may still complete cycle k. */
static int drain_frames(engine_t *e, cycle_t *c, int cycle_open, int *completed)
{
    eng_frame_t f;
    while (link_pop(e, &f)) {
        const int r = handle_frame(e, c, &f, cycle_open && !*completed);
        if (r < 0) {
            return -1;
        }
        if (r == 1) {
            *completed = 1;
        }
    }
    return 0;
}

static int run_realtime(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    const int64_t ts_ns = (int64_t)llround(cfg->ts_s * 1e9);
    const int64_t spin_ns = (int64_t)(cfg->spin_s * 1e9);
    const int64_t guard_ns = (cfg->duty_update == ENGINE_DUTY_ON_ARRIVAL)
                                 ? (int64_t)(cfg->guard_s * 1e9) : 0;
    const int64_t clock_jump_ns = 100LL * ts_ns + 100000000LL;
    ref_voltage_t rv;
    int next_event = 0;
    long k;
    double latched[3];
    memset(&rv, 0, sizeof rv);
    rv.w_split = 0.0;
    latched[0] = latched[1] = latched[2] = 0.5;
    e->t0_ns = eng_now_ns() + 2000000LL; /* first period 2 ms from now */
    for (k = 0; k < cfg->n_cycles; ++k) {
        cycle_t c;
        const int64_t t_k = e->t0_ns + k * ts_ns;
        const int64_t t_next = t_k + ts_ns;
        int64_t start, sent_ns;
        int completed = 0;
        double split_s;
        if (stop_asked(e)) {
            e->end = ENGINE_END_STOPPED;
            set_message(e, "stopped at cycle %ld", k);
            return e->end;
        }
        begin_cycle(e, &c, k);
        start = wait_until(t_k, spin_ns);
        if (start - t_k > clock_jump_ns) {
            e->end = ENGINE_END_CONFIG;
            set_message(e, "at cycle %ld: the clock jumped or the engine was suspended: period "
                        "start %.3f ms late (more than 100 periods); a real-time run cannot "
                        "continue", k, (double)(start - t_k) * 1e-6);
            return e->end;
        }
        if (start - t_k >= ts_ns) {
            /* The bench itself fell a whole period or more behind (descheduled): those periods
             * are gone. The plant still lives through them, with the held duties and no
             * exchange with the controller, and the engine rejoins the clock at the next
             * deadline. Counted as overruns: the bench's timing failure, not the controller's. */
            long skip = (long)((start - t_k) / ts_ns);
            long i;
            char text[160];
            if (k + skip > cfg->n_cycles) {
                skip = cfg->n_cycles - k;
            }
            for (i = 0; i < skip; ++i) {
                /* each lost period: its start error (>= one period) in the jitter statistics
                 * and a /timing row, so percentiles and rates are never computed over the
                 * periods that went well only */
                const int64_t late_ns = (start - t_k) - i * ts_ns;
                cycle_t lost;
                begin_cycle(e, &lost, k + i);
                hist_add(&e->hist_jitter, (double)late_ns * 1e-3);
                rt_record_lost(e, &lost, late_ns);
                plant_step_split(e->plant, e->duties, 0.0);
            }
            e->n.rt_overruns += (uint64_t)skip;
            rv.have_prev = rv.have_older = 0;
            e->prev_had_duty = 0;
            snprintf(text, sizeof text, "the bench fell %.0f us behind the clock: %ld period(s) "
                     "integrated with the held duties, no SENSE sent", (double)(start - t_k) * 1e-3,
                     skip);
            record_event(e, c.t_s, "overrun", text, (double)skip);
            k += skip - 1;
            __atomic_store_n(&e->cycles_done, k + 1, __ATOMIC_RELEASE);
            if (!plant_finite(e, &c)) {
                return e->end;
            }
            continue;
        }
        apply_events(e, &next_event, &c);
        take_inputs(e, &c);
        faults_begin_cycle(e, k);
        if (build_sense(e, &c) != 0) {
            return e->end;
        }
        queue_sense_group(e, &c);
        if (link_flush(e, t_next) != 0) {
            link_failed(e, &c);
            return e->end;
        }
        sent_ns = eng_now_ns();
        hist_add(&e->hist_jitter, (double)(start - t_k) * 1e-3); /* the period start (wake-up) */
        /* the duties acting in period k: in NEXT_PERIOD those DUTY(k-1) set, known now */
        if (cfg->duty_update == ENGINE_DUTY_NEXT_PERIOD) {
            e->duties[0] = latched[0];
            e->duties[1] = latched[1];
            e->duties[2] = latched[2];
        }
        /* wait for DUTY(k) until its deadline */
        while (!completed) {
            int r;
            if (drain_frames(e, &c, 1, &completed) != 0) {
                return e->end;
            }
            if (completed) {
                break;
            }
            /* busy_wait: read without sleeping until the DUTY or the deadline (the thread
             * never leaves the CPU, so it sees the DUTY the moment it lands) */
            r = link_poll(e, cfg->busy_wait ? eng_now_ns() : t_next - guard_ns);
            if (cfg->busy_wait && r == 0 && eng_now_ns() < t_next - guard_ns) {
                continue;
            }
            if (r < 0) {
                link_failed(e, &c);
                return e->end;
            }
            if (r == 0) {
                break; /* deadline */
            }
        }
        if (completed) {
            int applied;
            e->consecutive_miss = 0;
            if (cfg->duty_update == ENGINE_DUTY_NEXT_PERIOD) {
                const double held[3] = {e->duties[0], e->duties[1], e->duties[2]};
                applied = take_duties(e, &c);
                if (applied < 0) {
                    return e->end;
                }
                latched[0] = e->duties[0];
                latched[1] = e->duties[1];
                latched[2] = e->duties[2];
                e->duties[0] = held[0];
                e->duties[1] = held[1];
                e->duties[2] = held[2];
                split_s = 0.0;
            } else {
                applied = take_duties(e, &c);
                if (applied < 0) {
                    return e->end;
                }
                split_s = (double)(c.duty_t_ns - t_k) * 1e-9;
                if (split_s < 0.0) {
                    split_s = 0.0;
                }
                if (split_s > cfg->ts_s) {
                    split_s = cfg->ts_s;
                }
            }
            hist_add(&e->hist_cycle, (double)(c.duty_t_ns - sent_ns) * 1e-3);
            rtt_evidence(e, &c, sent_ns);
        } else {
            e->n.missed_duty++;
            e->late_state[c.seq & (ENGINE_LATE_WINDOW - 1)] = 1; /* its DUTY may still come */
            e->consecutive_miss++;
            split_s = 0.0;
            if (e->consecutive_miss >= cfg->max_consecutive_misses) {
                /* watchdog: all gates off, tell the controller, end the run */
                hil_fault_plant_t m;
                uint8_t buf[8];
                e->duties[0] = e->duties[1] = e->duties[2] = -1.0;
                m.code = (uint16_t)HIL_FAULT_WATCHDOG;
                m.seq = c.seq;
                m.detail = e->consecutive_miss;
                if (hil_fault_plant_pack(buf, &m, sizeof buf) > 0) {
                    queue_frame(e, (uint16_t)HIL_FAULT_PLANT_FRAME_ID, buf);
                    (void)link_flush(e, eng_now_ns() + 100000000LL);
                }
                after_telemetry(e, &c);
                record_cycle(e, &c);
                rt_record_timing(e, &c, start - t_k, 0, sent_ns, t_k);
                plant_step_split(e->plant, e->duties, 0.0);
                record_event(e, c.t_s, "watchdog",
                             "inverter safe state (all legs off), FAULT_PLANT WATCHDOG sent",
                             (double)e->consecutive_miss);
                e->end = ENGINE_END_WATCHDOG;
                set_message(e, "at cycle %ld (t = %.4f s): %d consecutive periods without a "
                            "DUTY in time: inverter disabled (all legs off), FAULT_PLANT "
                            "WATCHDOG sent, run ended", k, c.t_s, e->consecutive_miss);
                __atomic_store_n(&e->cycles_done, k + 1, __ATOMIC_RELEASE);
                return e->end;
            }
        }
        after_telemetry(e, &c);
        record_cycle(e, &c);
        step_references(e, &c, &rv, 0); /* voltage of period k-1, split at rv.w_split */
        plant_step_split(e->plant, e->duties, split_s);
        e->prev_had_duty = completed;
        /* the references of cycle k+1 see the voltage of period k: older -> newer at split */
        rv.w_split = split_s / cfg->ts_s;
        rv.have_older = rv.have_prev;
        rv.older[0] = rv.prev[0];
        rv.older[1] = rv.prev[1];
        rv.have_prev = duties_to_ab(e->duties, c.smp.v_dc_v, rv.prev);
        if (!plant_finite(e, &c)) {
            return e->end;
        }
        rt_record_timing(e, &c, start - t_k, completed, sent_ns, t_k);
        __atomic_store_n(&e->cycles_done, k + 1, __ATOMIC_RELEASE);
        e->speed_rpm = e->plant->y[2] * cfg->rpm_per_rad_s;
        if (cfg->stats_every_cycles > 0 && (k + 1) % cfg->stats_every_cycles == 0) {
            engine_write_stats(e, (double)(k + 1) * cfg->ts_s, NULL);
        }
        traces_step(e);
        if (trip_over(e, &c)) {
            return e->end;
        }
        /* until the next period: late frames, heartbeats, faults */
        for (;;) {
            int dummy = 1, r;
            if (drain_frames(e, &c, 0, &dummy) != 0) {
                return e->end;
            }
            if (eng_now_ns() >= t_next - spin_ns) {
                break;
            }
            r = link_poll(e, t_next - spin_ns);
            if (r < 0) {
                link_failed(e, &c);
                return e->end;
            }
            if (r == 0) {
                break;
            }
        }
    }
    return ENGINE_END_DONE;
}

/** The run ended: every trace still collecting is closed; an end that is itself a reaction to
 *  the fault (the controller faulted, went silent, the watchdog, a link failure) is evidence. */
static void traces_end(engine_t *e)
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

int engine_send(engine_t *e, uint16_t id, const uint8_t *data, uint16_t dlc)
{
    if (eng_link_queue(&e->link, id, data, dlc) != 0) {
        return -1;
    }
    return eng_link_flush(&e->link, eng_now_ns() + 200000000LL);
}

int engine_run(engine_t *e)
{
    if (e->end != ENGINE_END_DONE) {
        return e->end; /* init failed */
    }
    e->message[0] = '\0';
    if (e->cfg.source == ENGINE_SOURCE_REPLAY_CONTROLLER) {
        e->end = run_replay_controller(e);
    } else if (e->cfg.source == ENGINE_SOURCE_REPLAY_PLANT) {
        e->end = run_replay_plant(e);
    } else if (e->cfg.source == ENGINE_SOURCE_REPLAY_ESTIMATORS) {
        e->end = run_replay_estimators(e);
    } else if (e->cfg.mode == ENGINE_REALTIME) {
        rt_setup(e);
        e->end = run_realtime(e);
        rt_teardown(e);
    } else {
        e->end = run_lockstep(e);
    }
    if (e->end == ENGINE_END_DONE) {
        set_message(e, "ran %ld/%ld cycles", (long)e->cycles_done, e->cfg.n_cycles);
    }
    traces_end(e);
    return e->end;
}
