/* Operator inputs of the live view (live.h): taken at the start of a cycle, applied or
 * refused, each an /events row; a lockstep run held while an operator paused it. */
#include "engine_internal.h"

#include <stdio.h>
#include <string.h>

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
    eng_record_event(e, c->t_s, "operator_refused", text, in->value);
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
        eng_queue_cmd(e, (int)HIL_CMD_SET_SPEED_REF, in->value);
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
        eng_record_event(e, c->t_s, "operator_pause", text, 0.0);
        return;
    case LIVE_IN_RESUME:
        if (!e->paused) {
            operator_refused(e, c, in, "the run is not paused");
            return;
        }
        e->paused = 0;
        snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
        eng_record_event(e, c->t_s, "operator_resume", text, 0.0);
        return;
    case LIVE_IN_REFUSED:
        operator_refused(e, c, in, NULL);
        return;
    default:
        operator_refused(e, c, in, "unknown input kind");
        return;
    }
    e->n.operator_inputs++;
    eng_full_rate_from_now(e, e->cfg.post_trigger_cycles);
    snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
    eng_record_event(e, c->t_s, "operator", text, in->value);
}

/** Every operator input pending now, applied at cycle c. */
void eng_take_inputs(engine_t *e, const cycle_t *c)
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

/**
 * Lockstep, paused by an operator before cycle c's SENSE: read the link (heartbeats, a
 * FAULT_CTRL ends the run as ever) and the mailbox every few ms until a resume or a stop.
 * 0, or -1 with e->end set.
 */
int eng_hold_while_paused(engine_t *e, cycle_t *c)
{
    const int64_t t0 = eng_now_ns();
    while (e->paused) {
        int completed = 0;
        if (eng_stop_asked(e)) {
            e->end = ENGINE_END_STOPPED;
            eng_set_message(e, "stopped at cycle %ld while paused by the operator", c->k);
            return -1;
        }
        if (eng_poll(e, eng_now_ns() + 5000000LL) < 0) {
            eng_fail_link(e, c);
            return -1;
        }
        if (eng_drain_frames(e, c, 0, &completed) != 0) {
            return -1;
        }
        eng_take_inputs(e, c);
    }
    e->paused_ns += eng_now_ns() - t0;
    return 0;
}
