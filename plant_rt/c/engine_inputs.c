/* Inputs through the mailbox (live.h): a live view's operator inputs and a script's
 * (hil_bench.Session). Taken at the start of a cycle, after its scenario events, applied or
 * refused, each an /events row and an answer on the mailbox; a lockstep run held while an
 * operator paused it or before the cycle a script named. */
#include "engine_internal.h"

#include <stdio.h>
#include <string.h>

/* e->paused: who holds the run */
#define PAUSED_BY_OPERATOR 1
#define PAUSED_BY_SCRIPT 2

/** While held, the link is read and the mailbox looked at at least this often [ns]. */
#define HOLD_POLL_NS 5000000LL

static int from_script(const live_input_t *in)
{
    return in->origin == LIVE_FROM_SCRIPT;
}

static void refuse(engine_t *e, const cycle_t *c, const live_input_t *in, const char *why)
{
    char text[LIVE_INPUT_TEXT + 160];
    if (why != NULL) {
        snprintf(text, sizeof text, "%s: refused: %s (cycle %ld)", in->text, why, c->k);
    } else {
        snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
    }
    if (from_script(in)) {
        eng_record_event(e, c->t_s, "script_refused", text, in->value);
    } else {
        e->n.operator_refused++;
        eng_record_event(e, c->t_s, "operator_refused", text, in->value);
    }
    live_inbox_answer(e->inbox, text);
}

/** What the run changes (an /events row "operator" or "script" naming the cycle). */
static void applied(engine_t *e, const cycle_t *c, const live_input_t *in)
{
    char text[LIVE_INPUT_TEXT + 64];
    if (!from_script(in)) {
        e->n.operator_inputs++;
    }
    eng_full_rate_from_now(e, e->cfg.post_trigger_cycles);
    snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
    eng_record_event(e, c->t_s, from_script(in) ? "script" : "operator", text, in->value);
    live_inbox_answer(e->inbox, NULL);
}

/** A CMD for the controller with the cycle's SENSE frames. */
static void command(engine_t *e, const cycle_t *c, const live_input_t *in, int cmd,
                    const char *not_finite)
{
    if (!isfinite(in->value)) {
        refuse(e, c, in, not_finite);
        return;
    }
    eng_queue_cmd(e, cmd, in->value);
    applied(e, c, in);
}

/** A script's hold: before cycle in->value (< 0: none), lockstep only. */
static void hold_at(engine_t *e, const cycle_t *c, const live_input_t *in)
{
    if (e->cfg.mode != ENGINE_LOCKSTEP) {
        refuse(e, c, in, "a real-time run cannot hold: the controller runs on its own clock");
        return;
    }
    if (!isfinite(in->value) || floor(in->value) < in->value || in->value > 9.0e18) {
        refuse(e, c, in, "not a cycle number");
        return;
    }
    e->hold_armed = in->value >= 0.0;
    e->hold_at = e->hold_armed ? (long)in->value : 0L;
    if (e->paused == PAUSED_BY_SCRIPT && (!e->hold_armed || e->hold_at > c->k)) {
        e->paused = 0;
    }
    live_inbox_answer(e->inbox, NULL); /* a hold changes nothing of the run: no /events row */
}

static void fault_on(engine_t *e, const cycle_t *c, const live_input_t *in)
{
    plant_fault_t pf;
    pf.kind = in->arg[0];
    pf.phase = in->arg[1];
    pf.phase2 = in->arg[2];
    pf.level = in->arg[3];
    pf.value = in->value;
    if (plant_set_fault(e->plant, &pf) != 0) {
        const char *why = plant_fault_check(e->plant, &pf);
        refuse(e, c, in, why != NULL ? why : "refused by the plant");
        return;
    }
    applied(e, c, in);
}

static void fault_off(engine_t *e, const cycle_t *c, const live_input_t *in)
{
    if (in->arg[0] <= PLANT_FAULT_NONE || in->arg[0] >= PLANT_FAULT_KIND_COUNT) {
        refuse(e, c, in, "not a plant fault kind");
        return;
    }
    plant_clear_fault(e->plant, in->arg[0], in->arg[1]);
    applied(e, c, in);
}

static void pause_resume(engine_t *e, const cycle_t *c, const live_input_t *in)
{
    char text[LIVE_INPUT_TEXT + 64];
    if (in->kind == LIVE_IN_PAUSE) {
        if (e->cfg.mode != ENGINE_LOCKSTEP) {
            refuse(e, c, in, "a real-time run cannot pause: the controller runs on its own clock");
            return;
        }
        if (e->paused) {
            refuse(e, c, in, "the run is paused already");
            return;
        }
        e->paused = PAUSED_BY_OPERATOR;
    } else {
        if (e->paused == PAUSED_BY_SCRIPT) {
            refuse(e, c, in, "the run is held by a script (hil_bench.Session)");
            return;
        }
        if (!e->paused) {
            refuse(e, c, in, "the run is not paused");
            return;
        }
        e->paused = 0;
    }
    snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
    eng_record_event(e, c->t_s, in->kind == LIVE_IN_PAUSE ? "operator_pause" : "operator_resume",
                     text, 0.0);
    live_inbox_answer(e->inbox, NULL);
}

/** One input, applied at cycle c (before its SENSE). */
static void apply_input(engine_t *e, const cycle_t *c, const live_input_t *in)
{
    char text[LIVE_INPUT_TEXT + 64];
    if (e->cfg.source != ENGINE_SOURCE_PLANT && in->kind != LIVE_IN_REFUSED) {
        /* a replay plays the capture's own inputs (the live view refuses before; this holds
         * whatever a producer pushes) */
        refuse(e, c, in, "a replay plays the capture's own inputs");
        return;
    }
    switch (in->kind) {
    case LIVE_IN_SPEED_REF:
        command(e, c, in, (int)HIL_CMD_SET_SPEED_REF, "not a finite speed");
        return;
    case LIVE_IN_IQ_REF:
        command(e, c, in, (int)HIL_CMD_SET_IQ_REF, "not a finite current");
        return;
    case LIVE_IN_ID_REF:
        command(e, c, in, (int)HIL_CMD_SET_ID_REF, "not a finite current");
        return;
    case LIVE_IN_CONTROL_MODE:
        if (!(in->value <= 0.0 && in->value >= 0.0) && !(in->value <= 1.0 && in->value >= 1.0)) {
            refuse(e, c, in, "the control mode is 0 (speed loop) or 1 (current mode)");
            return;
        }
        command(e, c, in, (int)HIL_CMD_SET_CONTROL_MODE, NULL);
        return;
    case LIVE_IN_LOAD:
        if (!isfinite(in->value)) {
            refuse(e, c, in, "not a finite torque");
            return;
        }
        plant_set_load_torque(e->plant, in->value);
        applied(e, c, in);
        return;
    case LIVE_IN_FAULT_ON:
        fault_on(e, c, in);
        return;
    case LIVE_IN_FAULT_OFF:
        fault_off(e, c, in);
        return;
    case LIVE_IN_HOLD_AT:
        hold_at(e, c, in);
        return;
    case LIVE_IN_PAUSE:
    case LIVE_IN_RESUME:
        pause_resume(e, c, in);
        return;
    case LIVE_IN_NOTE:
        snprintf(text, sizeof text, "%s (cycle %ld)", in->text, c->k);
        eng_record_event(e, c->t_s, "script_note", text, in->value);
        live_inbox_answer(e->inbox, NULL);
        return;
    case LIVE_IN_REFUSED:
        refuse(e, c, in, NULL);
        return;
    default:
        refuse(e, c, in, "unknown input kind");
        return;
    }
}

/** Every input pending now, applied at cycle c; then a script's hold due at c (lockstep). When
 *  nothing is pending and no script holds the run: one acquire load and a compare. */
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
    if (e->hold_armed && !e->paused && c->k >= e->hold_at) {
        e->paused = PAUSED_BY_SCRIPT;
    }
}

/**
 * Lockstep, held before cycle c's SENSE (an operator's pause, a script's hold): read the link
 * (heartbeats, a FAULT_CTRL ends the run as ever) every HOLD_POLL_NS and take every input the
 * moment it is pushed (the mailbox's wake word), until a resume, a later hold or a stop.
 * 0, or -1 with e->end set.
 */
int eng_hold_while_paused(engine_t *e, cycle_t *c)
{
    const int64_t t0 = eng_now_ns();
    if (e->inbox == NULL) {   /* cannot be: only an input holds a run */
        e->paused = 0;
        return 0;
    }
    live_inbox_set_held(e->inbox, c->k);
    while (e->paused) {
        const uint32_t seen = live_inbox_wake_word(e->inbox);
        int completed = 0;
        if (eng_stop_asked(e)) {
            e->end = ENGINE_END_STOPPED;
            eng_set_message(e, "stopped at cycle %ld while %s", c->k,
                            e->paused == PAUSED_BY_SCRIPT ? "held by the script (hil_bench.Session)"
                                                          : "paused by the operator");
            live_inbox_set_held(e->inbox, -1);
            return -1;
        }
        if (eng_poll(e, eng_now_ns()) < 0) {
            eng_fail_link(e, c);
            live_inbox_set_held(e->inbox, -1);
            return -1;
        }
        if (eng_drain_frames(e, c, 0, &completed) != 0) {
            live_inbox_set_held(e->inbox, -1);
            return -1;
        }
        eng_take_inputs(e, c);
        if (e->paused) {
            (void)live_inbox_wait(e->inbox, LIVE_WORD_WAKE, seen, HOLD_POLL_NS);
        }
    }
    live_inbox_set_held(e->inbox, -1);
    e->paused_ns += eng_now_ns() - t0;
    return 0;
}
