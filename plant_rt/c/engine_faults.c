/* Link faults the cycle engine injects (engine_faults.h). */
#include "engine_faults.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "hil_framing.h"

#define NS_PER_S_F 1e9

/* ---- seeded random numbers (splitmix64 to seed, xorshift64* to draw) -------------------------- */

static uint64_t splitmix64(uint64_t x)
{
    x += 0x9E3779B97F4A7C15ULL;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
    return x ^ (x >> 31);
}

static uint64_t next_u64(uint64_t *s)
{
    uint64_t x = *s;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *s = x;
    return x * 0x2545F4914F6CDD1DULL;
}

/** Uniform in [0, 1). */
static double next_unit(uint64_t *s)
{
    return (double)(next_u64(s) >> 11) * (1.0 / 9007199254740992.0);
}

/* ---- queues ---------------------------------------------------------------------------------- */

static int q_push(elf_queue_t *q, const eng_frame_t *fr, int64_t due_ns)
{
    elf_held_t *h;
    if (q->count >= ELF_QUEUE) {
        return -1;
    }
    h = &q->q[(q->head + q->count) % ELF_QUEUE];
    h->f = *fr;
    h->due_ns = due_ns;
    q->count++;
    return 0;
}

static const elf_held_t *q_peek(const elf_queue_t *q)
{
    return q->count ? &q->q[q->head] : NULL;
}

static void q_pop(elf_queue_t *q)
{
    if (q->count) {
        q->head = (q->head + 1u) % ELF_QUEUE;
        q->count--;
    }
}

static int64_t q_last_due(const elf_queue_t *q)
{
    return q->count ? q->q[(q->head + q->count - 1u) % ELF_QUEUE].due_ns : INT64_MIN;
}

/* ---- set-up ---------------------------------------------------------------------------------- */

void elf_init(elf_t *f, elf_report_fn report, void *ctx)
{
    memset(f, 0, sizeof *f);
    f->report = report;
    f->report_ctx = ctx;
}

int elf_add(elf_t *f, const elf_config_t *cfg, int link_kind, char *why, size_t why_len)
{
    const char *bad = NULL;
    if (f->n >= ENGINE_MAX_LINK_FAULTS) {
        bad = "too many link faults";
    } else if (cfg->kind < ELF_DROP || cfg->kind > ELF_GARBAGE) {
        bad = "unknown link fault kind";
    } else if ((cfg->direction & (ELF_TO_CONTROLLER | ELF_FROM_CONTROLLER)) == 0 ||
               (cfg->direction & ~(ELF_TO_CONTROLLER | ELF_FROM_CONTROLLER)) != 0) {
        bad = "direction must be to the controller, from it, or both";
    } else if (!(cfg->probability > 0.0 && cfg->probability <= 1.0)) {
        bad = "probability must be in (0, 1]";
    } else if (cfg->cycle_on < 0) {
        bad = "the fault starts before the run";
    } else if (cfg->kind == ELF_DELAY && !(cfg->delay_s >= 0.0 && cfg->jitter_s >= 0.0 &&
                                           cfg->delay_s + cfg->jitter_s > 0.0 &&
                                           cfg->delay_s + cfg->jitter_s <= 10.0)) {
        bad = "a delay needs delay_s + jitter_s in (0, 10] s";
    } else if (cfg->kind == ELF_STALL && !(cfg->stall_s > 0.0 && cfg->stall_s <= 60.0)) {
        bad = "a stall needs stall_s in (0, 60] s";
    } else if (cfg->kind == ELF_GARBAGE && (cfg->n_garbage < 1u || cfg->n_garbage > 4096u)) {
        bad = "a garbage burst needs 1 .. 4096 octets (serial) or frames (CAN)";
    } else if (cfg->kind == ELF_GARBAGE && link_kind != ENG_LINK_SERIAL &&
               cfg->n_garbage > ENG_LINK_TXFRAMES / 2u) {
        bad = "a CAN garbage burst is at most 32 frames";
    } else if (cfg->kind == ELF_BITFLIP && link_kind != ENG_LINK_SERIAL &&
               (cfg->direction & ELF_TO_CONTROLLER)) {
        bad = "on CAN a corrupted frame is destroyed by the bus's CRC and retransmitted by the "
              "sender's controller: a bit flip towards the controller cannot be emulated above "
              "the socket (inject it from the controller: the bench counts the error frame)";
    }
    if (bad != NULL) {
        if (why != NULL && why_len > 0u) {
            snprintf(why, why_len, "%s", bad);
        }
        return -1;
    }
    f->cfg[f->n] = *cfg;
    f->seed[f->n] = splitmix64(cfg->seed ^ (0x51ED2700ULL + (uint64_t)(unsigned)f->n));
    f->rng[f->n] = f->seed[f->n] != 0u ? f->seed[f->n] : 1u;
    f->n++;
    return 0;
}

/* ---- which fault acts on a frame --------------------------------------------------------------- */

static int in_window(const elf_config_t *c, long k)
{
    return k >= c->cycle_on && (c->cycle_off <= c->cycle_on || k < c->cycle_off);
}

/** Is this a frame of another cycle than the present one (a cycle message, 0x100..0x1FF, whose
 *  seq, its first two octets, is not the cycle's)? */
static int other_cycle(const elf_t *f, uint16_t id, const uint8_t *data, uint16_t dlc)
{
    return id >= 0x100u && id < 0x200u && dlc >= 2u &&
           (uint16_t)((unsigned)data[0] | ((unsigned)data[1] << 8)) != f->seq;
}

/** The first per-frame fault of direction dir that acts on this frame (its probability drawn),
 *  or -1. Every matching fault draws, so the draws do not depend on which one acts; each draw
 *  (and the fault's further draws for this frame: a bit's place, a delay's jitter) comes from the
 *  fault's seed, the cycle, the direction and the frame's place among the frames of this cycle
 *  the fault met, never from how many frames came before (elf_begin_cycle). */
static int acting_fault(elf_t *f, int dir, uint16_t id, const uint8_t *data, uint16_t dlc)
{
    int i, acting = -1;
    if (other_cycle(f, id, data, dlc)) {
        return -1;
    }
    for (i = 0; i < f->n; ++i) {
        const elf_config_t *c = &f->cfg[i];
        const int d = dir == ELF_TO_CONTROLLER ? 0 : 1;
        double u;
        if (c->kind == ELF_STALL || c->kind == ELF_GARBAGE || !(c->direction & dir) ||
            (c->frame_id >= 0 && (uint16_t)c->frame_id != id) || !in_window(c, f->cycle) ||
            (c->count != 0u && f->acted[i] >= c->count)) {
            continue;
        }
        f->rng[i] = splitmix64(f->seed[i] ^ splitmix64((uint64_t)f->cycle) ^
                               ((uint64_t)(unsigned)d << 62) ^ ((uint64_t)f->occ[i][d]++ << 32));
        if (f->rng[i] == 0u) {
            f->rng[i] = 1u;
        }
        u = next_unit(&f->rng[i]);
        f->matched[i]++;
        if (acting < 0 && u < c->probability) {
            acting = i;
            f->place = f->occ[i][d] - 1u;
        }
    }
    if (acting >= 0) {
        f->acted[acting]++;
    }
    return acting;
}

static void report(elf_t *f, int i, int dir, const char *action, const eng_frame_t *fr, double v)
{
    if (f->report != NULL) {
        f->report(f->report_ctx, i, dir, action, fr ? fr->id : 0u, fr ? fr->data : NULL,
                  fr ? fr->dlc : 0u, v);
    }
}

static int stall_index(const elf_t *f, int64_t now_ns, int dir)
{
    int i;
    for (i = 0; i < f->n; ++i) {
        if (f->cfg[i].kind == ELF_STALL && f->once_done[i] && now_ns < f->stall_until_ns[i] &&
            (f->cfg[i].direction & dir)) {
            return i;
        }
    }
    return -1;
}

/* ---- the cycle --------------------------------------------------------------------------------- */

void elf_begin_cycle(elf_t *f, eng_link_t *l, long k, uint16_t seq, int64_t now_ns)
{
    int i;
    f->cycle = k;
    f->seq = seq;
    memset(f->occ, 0, sizeof f->occ);
    for (i = 0; i < f->n; ++i) {
        elf_config_t *c = &f->cfg[i];
        if (f->once_done[i] || k < c->cycle_on) {
            continue;
        }
        if (c->kind == ELF_STALL) {
            f->once_done[i] = 1;
            f->matched[i]++;
            f->acted[i]++;
            f->stall_until_ns[i] = now_ns + (int64_t)llround(c->stall_s * NS_PER_S_F);
            report(f, i, c->direction, "stall", NULL, c->stall_s);
        } else if (c->kind == ELF_GARBAGE) {
            uint8_t junk[4096];
            uint32_t n = c->n_garbage, j;
            f->once_done[i] = 1;
            f->matched[i]++;
            f->acted[i]++;
            report(f, i, c->direction, "garbage", NULL, (double)n);
            if (l->kind == ENG_LINK_SERIAL) {
                for (j = 0u; j < n; ++j) {
                    junk[j] = (uint8_t)(next_u64(&f->rng[i]) >> 56);
                }
                if (c->direction & ELF_TO_CONTROLLER) {
                    size_t room = ENG_LINK_TXBUF - l->txlen;
                    (void)eng_link_queue_raw(l, junk, n < room ? n : room);
                }
                if (c->direction & ELF_FROM_CONTROLLER) {
                    eng_link_feed(l, junk, n);
                }
            } else {
                for (j = 0u; j < n; ++j) {
                    uint8_t data[8];
                    /* 0x600..0x6FF: no message of protocol/hil.dbc lives there */
                    const uint16_t id = (uint16_t)(0x600u + (uint16_t)(next_u64(&f->rng[i]) >> 56));
                    uint64_t r = next_u64(&f->rng[i]);
                    memcpy(data, &r, 8u);
                    if (c->direction & ELF_TO_CONTROLLER) {
                        (void)eng_link_queue(l, id, data, 8u);
                    }
                    if (c->direction & ELF_FROM_CONTROLLER) {
                        eng_link_push(l, id, data, 8u);
                    }
                }
            }
        }
    }
}

/* ---- to the controller ----------------------------------------------------------------------- */

static int emit_tx(elf_t *f, eng_link_t *l, const eng_frame_t *fr, int64_t now_ns)
{
    if (f->tx_delay.count) {   /* FIFO: nothing overtakes a delayed frame */
        if (q_push(&f->tx_delay, fr, q_last_due(&f->tx_delay) > now_ns ?
                                          q_last_due(&f->tx_delay) : now_ns) != 0) {
            f->dropped_overflow++;
        }
        return 0;
    }
    return eng_link_queue(l, fr->id, fr->data, fr->dlc);
}

int elf_tx(elf_t *f, eng_link_t *l, uint16_t id, const uint8_t *data, uint16_t dlc, int64_t now_ns)
{
    eng_frame_t fr;
    int i, rc = 0;
    memset(&fr, 0, sizeof fr);
    fr.id = id;
    fr.dlc = dlc > HIL_FRAME_MAX_DATA ? (uint16_t)HIL_FRAME_MAX_DATA : dlc;
    if (fr.dlc) {
        memcpy(fr.data, data, fr.dlc);
    }
    fr.t_ns = now_ns;
    if ((i = stall_index(f, now_ns, ELF_TO_CONTROLLER)) >= 0) {
        report(f, i, ELF_TO_CONTROLLER, "stall_drop", &fr, 0.0);
        return 0;
    }
    i = acting_fault(f, ELF_TO_CONTROLLER, id, data, dlc);
    if (i >= 0) {
        const elf_config_t *c = &f->cfg[i];
        switch (c->kind) {
        case ELF_DROP:
            report(f, i, ELF_TO_CONTROLLER, "drop", &fr, (double)f->place);
            return 0;
        case ELF_DUPLICATE:
            report(f, i, ELF_TO_CONTROLLER, "duplicate", &fr, (double)f->place);
            rc = emit_tx(f, l, &fr, now_ns);
            rc |= emit_tx(f, l, &fr, now_ns);
            return rc;
        case ELF_REORDER:
            if (!f->tx_hold_valid) {
                report(f, i, ELF_TO_CONTROLLER, "reorder", &fr, (double)f->place);
                f->tx_hold = fr;
                f->tx_hold_valid = 1;
                return 0;
            }
            break; /* one frame held at a time: this one goes as it is */
        case ELF_BITFLIP: {
            size_t before = l->txlen, bit;
            if (f->tx_delay.count || eng_link_queue(l, id, fr.data, fr.dlc) != 0) {
                break; /* behind a delayed frame: not flipped (said by not reporting it) */
            }
            /* a bit of the frame's octets, not its final delimiter */
            bit = (size_t)(next_u64(&f->rng[i]) % (uint64_t)((l->txlen - before - 1u) * 8u));
            l->txbuf[before + bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
            report(f, i, ELF_TO_CONTROLLER, "bitflip", &fr, (double)bit);
            goto release_hold;
        }
        case ELF_DELAY: {
            const double d = c->delay_s + c->jitter_s * next_unit(&f->rng[i]);
            int64_t due = now_ns + (int64_t)llround(d * NS_PER_S_F);
            if (q_last_due(&f->tx_delay) > due) {
                due = q_last_due(&f->tx_delay);
            }
            report(f, i, ELF_TO_CONTROLLER, "delay", &fr, d);
            if (q_push(&f->tx_delay, &fr, due) != 0) {
                f->dropped_overflow++;
            }
            goto release_hold;
        }
        default:
            break;
        }
    }
    rc = emit_tx(f, l, &fr, now_ns);
release_hold:
    if (f->tx_hold_valid) { /* the frame held back for a reorder goes after this one */
        const eng_frame_t held = f->tx_hold;
        f->tx_hold_valid = 0;
        rc |= emit_tx(f, l, &held, now_ns);
    }
    return rc;
}

int elf_tx_due(elf_t *f, eng_link_t *l, int64_t now_ns)
{
    int n = 0;
    const elf_held_t *h;
    while ((h = q_peek(&f->tx_delay)) != NULL && h->due_ns <= now_ns) {
        if (eng_link_queue(l, h->f.id, h->f.data, h->f.dlc) != 0) {
            break; /* the burst is full: the rest next time */
        }
        q_pop(&f->tx_delay);
        n++;
    }
    return n;
}

/* ---- from the controller ------------------------------------------------------------------- */

static void emit_rx(elf_t *f, eng_frame_t *fr, int64_t due_ns)
{
    const int64_t last = q_last_due(&f->rx_out);
    if (last > due_ns) {
        due_ns = last; /* FIFO */
    }
    fr->t_ns = due_ns;
    if (q_push(&f->rx_out, fr, due_ns) != 0) {
        f->dropped_overflow++;
    }
}

/** Serial bit flip on receive: the frame's octets with one bit flipped go through a deframer of
 *  their own (so a partial frame the link's deframer holds is not disturbed); its verdict is
 *  added to the link's framing counters. Returns 1 if (against all odds) a frame came out. */
static int flip_rx_serial(elf_t *f, int i, eng_link_t *l, eng_frame_t *fr)
{
    uint8_t wire[HIL_FRAME_MAX_WIRE];
    hil_deframer_t d;
    hil_frame_t out;
    size_t n = hil_frame_encode(wire, sizeof wire, fr->id, fr->data, fr->dlc), k, bit;
    int got = 0;
    if (n < 2u) {
        return 0;
    }
    bit = (size_t)(next_u64(&f->rng[i]) % (uint64_t)((n - 1u) * 8u));
    wire[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
    /* said before the receiver's verdict is counted: the trace starts from the counters as they
     * were before the fault acted */
    report(f, i, ELF_FROM_CONTROLLER, "bitflip", fr, (double)bit);
    hil_deframer_init(&d);
    for (k = 0u; k < n; ++k) {
        if (hil_deframer_push(&d, wire[k], &out) == 1) {
            got = 1;
            fr->id = out.id;
            fr->dlc = out.dlc;
            memcpy(fr->data, out.data, out.dlc);
        }
    }
    l->deframer.crc_errors += d.crc_errors;
    l->deframer.cobs_errors += d.cobs_errors;
    l->deframer.length_errors += d.length_errors;
    l->deframer.overruns += d.overruns;
    l->deframer.bytes_discarded += d.bytes_discarded;
    return got;
}

void elf_rx_pump(elf_t *f, eng_link_t *l, int64_t now_ns)
{
    eng_frame_t fr;
    (void)now_ns;
    while (eng_link_pop(l, &fr)) {
        int i = stall_index(f, fr.t_ns, ELF_FROM_CONTROLLER);
        int64_t due = fr.t_ns;
        if (i >= 0) {
            report(f, i, ELF_FROM_CONTROLLER, "stall_drop", &fr, 0.0);
            continue;
        }
        i = acting_fault(f, ELF_FROM_CONTROLLER, fr.id, fr.data, fr.dlc);
        if (i >= 0) {
            const elf_config_t *c = &f->cfg[i];
            switch (c->kind) {
            case ELF_DROP:
                report(f, i, ELF_FROM_CONTROLLER, "drop", &fr, (double)f->place);
                continue;
            case ELF_DUPLICATE:
                report(f, i, ELF_FROM_CONTROLLER, "duplicate", &fr, (double)f->place);
                emit_rx(f, &fr, due);
                break; /* and once more below */
            case ELF_REORDER:
                if (!f->rx_hold_valid) {
                    report(f, i, ELF_FROM_CONTROLLER, "reorder", &fr, (double)f->place);
                    f->rx_hold = fr;
                    f->rx_hold_valid = 1;
                    continue;
                }
                break;
            case ELF_BITFLIP:
                if (l->kind == ENG_LINK_SERIAL) {
                    if (!flip_rx_serial(f, i, l, &fr)) {
                        continue; /* rejected by the deframer, counted there */
                    }
                } else {
                    /* the bus destroyed the frame (error frame) and the controller's CAN
                     * controller sent it again */
                    report(f, i, ELF_FROM_CONTROLLER, "bitflip", &fr, 0.0);
                    l->c.error_frames++;
                }
                break;
            case ELF_DELAY: {
                const double d = c->delay_s + c->jitter_s * next_unit(&f->rng[i]);
                report(f, i, ELF_FROM_CONTROLLER, "delay", &fr, d);
                due = fr.t_ns + (int64_t)llround(d * NS_PER_S_F);
                break;
            }
            default:
                break;
            }
        }
        emit_rx(f, &fr, due);
        if (f->rx_hold_valid) {
            eng_frame_t held = f->rx_hold;
            f->rx_hold_valid = 0;
            emit_rx(f, &held, due);
        }
    }
}

unsigned elf_rx_ready(const elf_t *f, int64_t now_ns)
{
    unsigned n = 0u, k;
    for (k = 0u; k < f->rx_out.count; ++k) {
        if (f->rx_out.q[(f->rx_out.head + k) % ELF_QUEUE].due_ns > now_ns) {
            break;
        }
        n++;
    }
    return n;
}

int elf_rx_pop(elf_t *f, eng_frame_t *out, int64_t now_ns)
{
    const elf_held_t *h = q_peek(&f->rx_out);
    if (h == NULL || h->due_ns > now_ns) {
        return 0;
    }
    *out = h->f;
    q_pop(&f->rx_out);
    return 1;
}

int64_t elf_next_due_ns(const elf_t *f)
{
    int64_t t = INT64_MAX;
    const elf_held_t *h;
    if ((h = q_peek(&f->tx_delay)) != NULL && h->due_ns < t) {
        t = h->due_ns;
    }
    if ((h = q_peek(&f->rx_out)) != NULL && h->due_ns < t) {
        t = h->due_ns;
    }
    return t;
}
