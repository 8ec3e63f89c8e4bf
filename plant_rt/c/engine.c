/* The cycle engine (engine.h): its set-up and engine_run. The loops and their pieces are in
 * the other engine_*.c files (engine_internal.h lists them). */
#define _GNU_SOURCE
#include "engine_internal.h"

#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* ---- small helpers ------------------------------------------------------------------------- */

void eng_set_message(engine_t *e, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(e->message, sizeof e->message, fmt, ap);
    va_end(ap);
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
    cfg->resend_max_s = 1.0;
    cfg->patience_s = 10.0;
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
            eng_set_message(e, "engine: incomplete configuration (plant, ts_s, link fd, replay rows, "
                        "DBC constants)");
            return -1;
        }
    }
    if (cfg->source == ENGINE_SOURCE_REPLAY_CONTROLLER) {
        long k;
        for (k = 0; k < cfg->n_cycles; ++k) {
            const engine_replay_cycle_t *row = &cfg->replay_cycles[k];
            if ((long)row->first_frame + (long)row->n_frames > cfg->replay_n_frames) {
                eng_set_message(e, "engine: replay row %ld names frames beyond the capture", k);
                return -1;
            }
        }
    }
    if (cfg->mode != ENGINE_LOCKSTEP && cfg->mode != ENGINE_REALTIME) {
        eng_set_message(e, "engine: unknown mode %d", cfg->mode);
        return -1;
    }
    if (ring_mem != NULL) {
        if (rec_ring_attach(&e->ring, ring_mem, ring_size) != 0) {
            eng_set_message(e, "engine: the recording ring is not formatted");
            return -1;
        }
        e->have_ring = 1;
    }
    if (cfg->link_peer.write != NULL) {
        if (cfg->link_peer.read == NULL || cfg->link_kind != ENG_LINK_SERIAL) {
            eng_set_message(e, "engine: an in-process controller needs read and write, on the serial "
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
        e->link.tap = eng_serial_tap;
        e->link.tap_ctx = e;
    }
    e->duties[0] = e->duties[1] = e->duties[2] = 0.5;
    e->cmd_seq = cfg->cmd_seq_start;
    e->trip_cycle = -1;
    e->rtt_min_bin = -1;
    elf_init(&e->lf, eng_link_fault_acted, e);
    e->end = ENGINE_END_DONE;
    return 0;
}

int engine_attach_inbox(engine_t *e, void *mem, size_t size)
{
    live_inbox_t *b = live_inbox_attach(mem, size);
    if (b == NULL) {
        eng_set_message(e, "engine: the operator inputs' mailbox is not formatted");
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
        eng_set_message(e, "engine: more than %d reference estimators", ENGINE_MAX_REFS);
        return -1;
    }
    rc = eng_ref_init(&e->refs[e->n_refs], kind, config, config_size);
    if (rc != 0) {
        eng_set_message(e, "engine: reference estimator kind %d: %s", kind,
                    rc == -1 ? "unknown kind or wrong configuration size" :
                               "the estimator refused its configuration");
        return -1;
    }
    e->ref_channel[e->n_refs] = channel;
    e->n_refs++;
    return 0;
}

/** The plant fault an ENGINE_EV_PLANT_FAULT event switches on. */
plant_fault_t eng_event_plant_fault(const engine_event_t *ev)
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
        eng_set_message(e, "engine: fault index %d out of [0, %d) or a negative detection window",
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
        eng_set_message(e, "engine: too many full-rate windows, or one that ends before it starts");
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
        eng_set_message(e, "engine: too many events or events out of order");
        return -1;
    }
    if (ev->kind == ENGINE_EV_PLANT_FAULT) {
        const plant_fault_t pf = eng_event_plant_fault(ev);
        const char *why = plant_fault_check(e->plant, &pf);
        if (why != NULL) {
            eng_set_message(e, "engine: plant fault %s at cycle %ld: %s", ev->fault_name, ev->cycle, why);
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
        eng_set_message(e, "engine: link faults need a link (a live run or a replay into a controller)");
        return -1;
    }
    if (elf_add(&e->lf, &f->lf, (int)e->link.kind, why, sizeof why) != 0) {
        eng_set_message(e, "engine: link fault %s: %s", f->name, why);
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
        e->end = eng_run_replay_controller(e);
    } else if (e->cfg.source == ENGINE_SOURCE_REPLAY_PLANT) {
        e->end = eng_run_replay_plant(e);
    } else if (e->cfg.source == ENGINE_SOURCE_REPLAY_ESTIMATORS) {
        e->end = eng_run_replay_estimators(e);
    } else if (e->cfg.mode == ENGINE_REALTIME) {
        eng_rt_setup(e);
        e->end = eng_run_realtime(e);
        eng_rt_teardown(e);
    } else {
        e->end = eng_run_lockstep(e);
    }
    if (e->end == ENGINE_END_DONE) {
        eng_set_message(e, "ran %ld/%ld cycles", (long)e->cycles_done, e->cfg.n_cycles);
    }
    eng_resent_settle(e, LONG_MAX); /* the answers of the last re-sent cycles are in */
    eng_traces_end(e);
    return e->end;
}
