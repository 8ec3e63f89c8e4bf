/* The engine's link through the injected link faults (engine_faults.h): send, flush, poll
 * and pop as engine_link.h does them, with drops, delays, stalls and noise in between. */
#include "engine_internal.h"

#include <stdio.h>
#include <string.h>

/* ---- the link through the faults ------------------------------------------------------------- */

int eng_has_link_faults(const engine_t *e)
{
    return e->lf.n > 0;
}

int eng_xmit(engine_t *e, uint16_t id, const uint8_t *data, uint16_t dlc)
{
    if (!eng_has_link_faults(e)) {
        return eng_link_queue(&e->link, id, data, dlc);
    }
    return elf_tx(&e->lf, &e->link, id, data, dlc, eng_now_ns());
}

int eng_flush(engine_t *e, int64_t deadline_ns)
{
    if (eng_has_link_faults(e)) {
        (void)elf_tx_due(&e->lf, &e->link, eng_now_ns());
    }
    return eng_link_flush(&e->link, deadline_ns);
}

int eng_pop(engine_t *e, eng_frame_t *f)
{
    int64_t now;
    if (!eng_has_link_faults(e)) {
        return eng_link_pop(&e->link, f);
    }
    now = eng_now_ns();
    elf_rx_pump(&e->lf, &e->link, now);
    return elf_rx_pop(&e->lf, f, now);
}

/** eng_link_poll through the faults: frames held back (delays) become due, delayed frames to
 *  the controller go out when due. Returns the frames due now (>= 0), or -1 (link failed). */
int eng_poll(engine_t *e, int64_t deadline_ns)
{
    if (!eng_has_link_faults(e)) {
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
void eng_link_fault_acted(void *ctx, int i, int dir, const char *action, uint16_t id,
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
    eng_record_fault(e, seq, lf->fault_index, "link", lf->name, direction_name(dir), action, text,
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
        eng_trace_act(e, lf->fault_index, extra);
    }
    eng_full_rate_from_now(e, e->cfg.post_trigger_cycles + extra);
}

/** The start of cycle k, after its scenario events: link faults that start now. */
void eng_faults_begin_cycle(engine_t *e, long k, uint16_t seq)
{
    if (eng_has_link_faults(e)) {
        elf_begin_cycle(&e->lf, &e->link, k, seq, eng_now_ns());
    }
}
