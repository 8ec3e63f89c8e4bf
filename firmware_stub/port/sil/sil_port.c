/* Software-in-the-loop port of the firmware (sil_port.h). */
#include "sil_port.h"

static void port_send(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    sil_port_t *p = (sil_port_t *)ctx;
    size_t n;
    if (SIL_PORT_TX_OCTETS - p->tx_len < HIL_FRAME_MAX_WIRE) {
        p->tx_overflows++;
        return;
    }
    n = hil_frame_encode(p->tx + p->tx_len, SIL_PORT_TX_OCTETS - p->tx_len, id, data, dlc);
    if (n == 0u) {
        p->tx_overflows++;
        return;
    }
    p->tx_len += n;
}

static void start_session(sil_port_t *p, int64_t now_ns)
{
    hil_port_t port;
    port.ctx = p;
    port.send = port_send;
    hil_session_init(&p->session, &port);
    p->last_cycles = 0u;
    p->last_hb_errors = 0ul;
    p->last_hb_ns = now_ns;
}

void sil_port_init(sil_port_t *p, int hb_always, int64_t now_ns)
{
    hil_deframer_init(&p->deframer);
    p->tx_len = 0u;
    p->hb_always = hb_always;
    p->tx_overflows = 0ul;
    p->restarts = 0ul;
    p->rx_errors_base = 0ul;
    start_session(p, now_ns);
}

static unsigned long deframer_errors(const sil_port_t *p)
{
    return (unsigned long)p->deframer.crc_errors + p->deframer.cobs_errors +
           p->deframer.length_errors + p->deframer.overruns;
}

unsigned long sil_port_rx_errors(const sil_port_t *p)
{
    return deframer_errors(p) - p->rx_errors_base;
}

/* a power cycle of the portable code (CMD RESTART: it said so with a HEARTBEAT_CTRL): the port's
 * counters start over with it, the link (and the octets it holds) stays (port/linux/main.c) */
static void after_restart(sil_port_t *p, int64_t now_ns)
{
    p->restarts = (unsigned long)p->session.restarts;
    p->last_cycles = 0u;
    p->last_hb_errors = 0ul;
    p->last_hb_ns = now_ns;
    p->rx_errors_base = deframer_errors(p);
}

/* What the stub's main loop does after each wake-up (port/linux/main.c): HEARTBEAT_CTRL while no
 * cycles flow; with hb_always also while they flow, and at once when a frame was rejected. */
static void service(sil_port_t *p, int64_t now_ns)
{
    const hil_session_stats_t *st = &p->session.stats;
    const unsigned long errors = sil_port_rx_errors(p) + (unsigned long)st->unknown_ids +
                                 (unsigned long)st->length_errors;
    const int due = now_ns - p->last_hb_ns >= SIL_PORT_HEARTBEAT_NS ||
                    (p->hb_always && errors != p->last_hb_errors);
    if ((p->hb_always || st->cycles == p->last_cycles) && due) {
        hil_session_heartbeat(&p->session, (uint32_t)sil_port_rx_errors(p));
        p->last_hb_ns = now_ns;
        p->last_hb_errors = errors;
    }
    if (st->cycles != p->last_cycles) {
        p->last_cycles = st->cycles;
        if (!p->hb_always) {
            p->last_hb_ns = now_ns;
        }
    }
}

void sil_port_write(sil_port_t *p, const hil_octet_t *data, size_t n, int64_t now_ns)
{
    size_t i;
    for (i = 0u; i < n; ++i) {
        hil_frame_t f;
        if (hil_deframer_push(&p->deframer, data[i], &f) == 1) {
            hil_session_on_frame(&p->session, &f);
            if ((unsigned long)p->session.restarts != p->restarts) {
                after_restart(p, now_ns);
            }
        }
    }
    service(p, now_ns);
}

size_t sil_port_read(sil_port_t *p, hil_octet_t *out, size_t cap, int64_t now_ns)
{
    size_t n, i;
    service(p, now_ns);
    n = p->tx_len < cap ? p->tx_len : cap;
    for (i = 0u; i < n; ++i) {
        out[i] = p->tx[i];
    }
    for (i = n; i < p->tx_len; ++i) {
        p->tx[i - n] = p->tx[i];
    }
    p->tx_len -= n;
    return n;
}
