/* The engine's rows into the recording ring (lockstep waits for room, bounded; real time
 * never), its statistics (histograms, /link/stats) and the frames' candump text. */
#define _GNU_SOURCE
#include "engine_internal.h"

#include <stdio.h>
#include <string.h>
#include <time.h>

/** The histogram bin of a wall time [us]. */
long eng_hist_bin(double us)
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
double eng_hist_bin_lower_us(long b)
{
    return b < ENGINE_HIST_FINE ? (double)b * 0.1 : 1000.0 + (double)(b - ENGINE_HIST_FINE) * 10.0;
}

void eng_hist_add(engine_hist_t *h, double us)
{
    const long b = eng_hist_bin(us);
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

void eng_text_reset(char *buf, size_t *len)
{
    buf[0] = '\0';
    *len = 0u;
}

/** Append " ID#DATA" (candump style, hex upper case) to a frames text. */
void eng_text_frame(char *buf, size_t *len, uint16_t id, const uint8_t *data, uint16_t dlc)
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

/* ---- recording -------------------------------------------------------------------------------- */

/** Room for a record: in lockstep wait for the recorder while it makes progress; in real time
 *  never wait. A lockstep run waits as long as the recorder drains something at least every
 *  recorder_stall_s (a busy host starves it, it does not lose it: the rows stay the run's); one
 *  that drained nothing for that long is stalled: its rows are counted as dropped and it is not
 *  waited for again until it makes room by itself. */
uint8_t *eng_ring_begin(engine_t *e, size_t max)
{
    uint8_t *p;
    int64_t give_up = 0;
    uint64_t tail = 0u;
    if (!e->have_ring) {
        return NULL;
    }
    p = rec_ring_begin(&e->ring, max);
    if (p != NULL) {
        e->recorder_stalled = 0;
        return p;
    }
    if (e->cfg.mode == ENGINE_REALTIME || e->recorder_stalled) {
        /* real time never waits; nor does lockstep for a recorder that stalled once */
        rec_ring_count_drop(&e->ring, max);
        e->n.rows_dropped++;
        return NULL;
    }
    e->n.ring_waits++;
    while (p == NULL) {
        struct timespec ts = {0, 100000L};
        const int64_t now = eng_now_ns();
        const uint64_t seen = __atomic_load_n(&e->ring.hdr->tail, __ATOMIC_ACQUIRE);
        if (give_up == 0 || seen != tail) {
            tail = seen;   /* the recorder drained something: it is working */
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

void eng_record_event(engine_t *e, double t_s, const char *kind, const char *text,
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
int eng_record_full(const engine_t *e, long k)
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

void eng_full_rate_from_now(engine_t *e, long cycles)
{
    if (e->cur_k + cycles > e->full_rate_until) {
        e->full_rate_until = e->cur_k + cycles;
    }
}

/** A /faults row at the present cycle's time. */
void eng_record_fault(engine_t *e, int32_t seq, int index, const char *target,
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
    s.late_answers = e->n.late_answers;
    s.lost_frames = e->n.lost_frames;
    s.resend_answers = e->n.resend_answers;
    RECORD(e, e->cfg.ch_stats, t_s, REC_MAX_FIXED_SIZE, rec_encode_link_stats, &s);
}

/** Link tap: the octets of a serial link into the ring (engine_config_t.capture_serial). */
void eng_serial_tap(void *ctx, int direction, const uint8_t *data, size_t n, int64_t t_ns)
{
    engine_t *e = (engine_t *)ctx;
    uint8_t *p = eng_ring_begin(e, n + 1u);
    if (p != NULL) {
        p[0] = (uint8_t)direction;
        memcpy(p + 1, data, n);
        rec_ring_commit(&e->ring, e->cfg.ch_serial_raw, t_ns, n + 1u);
    }
}
