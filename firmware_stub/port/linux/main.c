/**
 * @file main.c
 * @brief Linux host port of the firmware stub: the controller under test in CI.
 *
 * Runs the portable HIL session behind one host link (transport.h) and answers every SENSE frame
 * with the control ISR's output. Everything portable lives in firmware_stub/src; this file and its
 * transports are only I/O, time and signals.
 *
 *   hil_stub --port PATH [--baud N]          serial: COBS/CRC framing on a UART or pty slave
 *   hil_stub --slcan PATH|fd:N [--baud N]    SLCAN adapter end on a tty/pty (python-can "slcan")
 *   hil_stub --socketcand [HOST:]PORT|fd:N [--bus NAME]
 *                                            socketcand server (python-can "socketcand"), bus hil0
 *   hil_stub --socketcan IFACE               raw SocketCAN socket (can0, vcan0)
 *            [--idle-timeout-s S] [--quiet] [--echo] [--inject KIND@CYCLE]
 *
 * "fd:N" is a descriptor the bench opened and passed on (a pty master, a listening TCP socket).
 *
 * --inject makes the stub misbehave on purpose from control cycle CYCLE on (CYCLE = number of
 * SENSE frames answered before), so the bench's handling of a bad controller can be tested:
 *   silent       stops answering
 *   crash        abort() on the next SENSE
 *   garbage      noise before every answer: line noise on serial; on CAN (where the controller
 *                hardware does the framing) a frame with an id outside the DBC (0x7E5)
 *   bad-duty     one DUTY with an out-of-range raw duty (40000 > 32768), once
 *   unknown-id   a frame with an id outside the DBC (0x7E5) before every TELEM
 *   wrong-dlc    one TELEM with 6 octets instead of 8, once
 *   bus-off      the controller goes bus-off: reported the way the link can (socketcand
 *                "< error 040 ... >", a SocketCAN error frame, SLCAN status flags) and silent after
 * --echo sends every received frame straight back instead of running the controller (a loopback
 * for testing the link codecs byte for byte).
 *
 * Exits 0 when the host closes the link (EOF/HUP), on SIGINT/SIGTERM, or after the idle timeout;
 * prints link and session counters to stderr.
 */
#define _DEFAULT_SOURCE
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "hil_framing.h"
#include "hil_session.h"
#include "transport.h"

#define HEARTBEAT_PERIOD_MS 100
#define JUNK_FRAME_ID 0x7E5u
#define SHORT_TELEM_DLC 6u

typedef enum {
    INJECT_NONE,
    INJECT_SILENT,
    INJECT_CRASH,
    INJECT_GARBAGE,
    INJECT_BAD_DUTY,
    INJECT_UNKNOWN_ID,
    INJECT_WRONG_DLC,
    INJECT_BUS_OFF
} inject_t;

typedef struct {
    transport_t *link;
    hil_session_t session;
    inject_t inject;
    unsigned long inject_cycle;
    int active;    /* the injection applies to the frame being handled */
    int echo;
    int off_bus;   /* after an injected bus-off: no frame leaves the controller */
    unsigned long echoed;
} app_t;

static volatile sig_atomic_t g_stop = 0;

static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

static long long now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000LL + ts.tv_nsec / 1000000L;
}

static void queue_unknown_id(app_t *a)
{
    static const hil_octet_t junk[8] = {0xDEu, 0xADu, 0xBEu, 0xEFu, 0x00u, 0x11u, 0x22u, 0x33u};
    a->link->ops->queue(a->link, (uint16_t)JUNK_FRAME_ID, junk, 8u);
}

/* hil_port_t.send: frames are queued and written in one syscall after the input is processed */
static void port_send(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    app_t *a = (app_t *)ctx;
    if (a->active && a->inject == INJECT_UNKNOWN_ID && id == HIL_TELEM_FRAME_ID) {
        queue_unknown_id(a);
    }
    if (a->active && a->inject == INJECT_WRONG_DLC && id == HIL_TELEM_FRAME_ID) {
        a->inject = INJECT_NONE;
        dlc = SHORT_TELEM_DLC;
    }
    if (a->active && a->inject == INJECT_BAD_DUTY && id == HIL_DUTY_FRAME_ID) {
        hil_duty_t d;
        hil_octet_t buf[HIL_DUTY_LENGTH];
        a->inject = INJECT_NONE;
        if (hil_duty_unpack(&d, data, dlc) == 0) {
            d.d_a = 40000u; /* > 32768 (duty 1.0) and not the OFF sentinel */
            if (hil_duty_pack(buf, &d, sizeof buf) > 0) {
                a->link->ops->queue(a->link, id, buf, HIL_DUTY_LENGTH);
                return;
            }
        }
    }
    a->link->ops->queue(a->link, id, data, dlc);
}

static void on_frame(void *user, const hil_frame_t *frame)
{
    app_t *a = (app_t *)user;
    if (a->echo) {
        a->echoed++;
        a->link->ops->queue(a->link, frame->id, frame->data, frame->dlc);
        return;
    }
    a->active = a->inject != INJECT_NONE && a->session.stats.cycles >= a->inject_cycle;
    if (a->active && a->inject == INJECT_CRASH && frame->id == HIL_SENSE_FRAME_ID) {
        fprintf(stderr, "hil_stub: injected crash at cycle %lu\n", (unsigned long)a->session.stats.cycles);
        abort();
    }
    if (a->active && a->inject == INJECT_BUS_OFF && frame->id == HIL_SENSE_FRAME_ID) {
        fprintf(stderr, "hil_stub: injected bus-off at cycle %lu (%s)\n",
                (unsigned long)a->session.stats.cycles,
                a->link->ops->bus_off(a->link) == 0 ? "reported to the host"
                                                    : "this link cannot report it: silent");
        a->inject = INJECT_SILENT;
        a->inject_cycle = 0u;
        a->off_bus = 1;
    }
    if (a->active && a->inject == INJECT_SILENT) {
        return;
    }
    if (a->active && a->inject == INJECT_GARBAGE) {
        if (a->link->ops->noise != NULL) {
            a->link->ops->noise(a->link);
        } else {
            queue_unknown_id(a);
        }
    }
    hil_session_on_frame(&a->session, frame);
    a->active = 0;
}

static void usage(void)
{
    fprintf(stderr,
            "usage: hil_stub (--port PATH [--baud N] | --slcan PATH|fd:N [--baud N] | "
            "--socketcand [HOST:]PORT|fd:N [--bus NAME] | --socketcan IFACE)\n"
            "                [--idle-timeout-s S] [--quiet] [--echo]\n"
            "                [--inject silent|crash|garbage|bad-duty|unknown-id|wrong-dlc|bus-off@CYCLE]\n");
}

static int parse_inject(const char *arg, inject_t *kind, unsigned long *cycle)
{
    static const struct {
        const char *name;
        inject_t kind;
    } kinds[] = {{"silent", INJECT_SILENT},       {"crash", INJECT_CRASH},
                 {"garbage", INJECT_GARBAGE},     {"bad-duty", INJECT_BAD_DUTY},
                 {"unknown-id", INJECT_UNKNOWN_ID}, {"wrong-dlc", INJECT_WRONG_DLC},
                 {"bus-off", INJECT_BUS_OFF}};
    const char *at = strchr(arg, '@');
    char *end = NULL;
    size_t n, i;
    if (at == NULL || at[1] < '0' || at[1] > '9') {
        return -1;
    }
    n = (size_t)(at - arg);
    *cycle = strtoul(at + 1, &end, 10);
    if (*end != '\0') {
        return -1;
    }
    for (i = 0u; i < sizeof kinds / sizeof kinds[0]; ++i) {
        if (strlen(kinds[i].name) == n && strncmp(arg, kinds[i].name, n) == 0) {
            *kind = kinds[i].kind;
            return 0;
        }
    }
    return -1;
}

int main(int argc, char **argv)
{
    const char *port_path = NULL, *slcan_spec = NULL, *scd_spec = NULL, *sc_iface = NULL;
    const char *bus = "hil0";
    long baud = 0;
    double idle_timeout_s = 0.0;
    int quiet = 0;
    int i, rc = 0, links = 0;
    static app_t app;   /* static: large buffers off the stack */
    hil_port_t port;
    char err[256];
    long long last_rx_ms, last_hb_ms;
    uint32_t last_cycles = 0u;
    int was_open = 0;
    const char *exit_reason = "host closed the link";
    transport_t *t;

    app.inject = INJECT_NONE;
    for (i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--port") == 0 && i + 1 < argc) {
            port_path = argv[++i];
            links++;
        } else if (strcmp(argv[i], "--slcan") == 0 && i + 1 < argc) {
            slcan_spec = argv[++i];
            links++;
        } else if (strcmp(argv[i], "--socketcand") == 0 && i + 1 < argc) {
            scd_spec = argv[++i];
            links++;
        } else if (strcmp(argv[i], "--socketcan") == 0 && i + 1 < argc) {
            sc_iface = argv[++i];
            links++;
        } else if (strcmp(argv[i], "--bus") == 0 && i + 1 < argc) {
            bus = argv[++i];
        } else if (strcmp(argv[i], "--baud") == 0 && i + 1 < argc) {
            baud = strtol(argv[++i], NULL, 10);
        } else if (strcmp(argv[i], "--idle-timeout-s") == 0 && i + 1 < argc) {
            idle_timeout_s = strtod(argv[++i], NULL);
        } else if (strcmp(argv[i], "--quiet") == 0) {
            quiet = 1;
        } else if (strcmp(argv[i], "--echo") == 0) {
            app.echo = 1;
        } else if (strcmp(argv[i], "--inject") == 0 && i + 1 < argc) {
            if (parse_inject(argv[++i], &app.inject, &app.inject_cycle) != 0) {
                fprintf(stderr, "hil_stub: bad --inject '%s'\n", argv[i]);
                usage();
                return 2;
            }
        } else {
            fprintf(stderr, "hil_stub: unknown or incomplete option '%s'\n", argv[i]);
            usage();
            return 2;
        }
    }
    if (links != 1) {
        fprintf(stderr, "hil_stub: give exactly one link (--port, --slcan, --socketcand or --socketcan)\n");
        usage();
        return 2;
    }

    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    signal(SIGPIPE, SIG_IGN);

    err[0] = '\0';
    if (port_path != NULL) {
        t = serial_transport_open(port_path, baud, err, sizeof err);
    } else if (slcan_spec != NULL) {
        t = slcan_transport_open(slcan_spec, baud, err, sizeof err);
    } else if (scd_spec != NULL) {
        t = socketcand_transport_open(scd_spec, bus, err, sizeof err);
    } else {
        t = socketcan_transport_open(sc_iface, err, sizeof err);
    }
    if (t == NULL) {
        fprintf(stderr, "hil_stub: %s\n", err);
        return 1;
    }
    app.link = t;
    port.ctx = &app;
    port.send = port_send;
    hil_session_init(&app.session, &port);
    last_rx_ms = last_hb_ms = now_ms();
    if (!quiet) {
        fprintf(stderr, "hil_stub: listening on %s%s\n", t->name, app.echo ? " (echo)" : "");
    }

    while (!g_stop) {
        struct pollfd p;
        int pr;
        long long now;
        p.fd = t->fd;
        p.events = POLLIN;
        p.revents = 0;
        pr = poll(&p, 1, HEARTBEAT_PERIOD_MS);
        now = now_ms();
        if (pr < 0) {
            if (errno == EINTR) {
                continue;
            }
            exit_reason = "poll failed";
            rc = 1;
            break;
        }
        if (pr > 0 && (p.revents & (POLLIN | POLLHUP | POLLERR))) {
            int r = t->ops->read(t, on_frame, &app);
            if (transport_flush(t) != 0 && r == 0) {
                exit_reason = t->error;
                /* the host hung up while we answered: the end of a run, not a failure */
                rc = (t->write_errno == EIO || t->write_errno == EPIPE ||
                      t->write_errno == ECONNRESET) ? 0 : 1;
                break;
            }
            if (r > 0) {
                if (t->error[0] != '\0') {
                    exit_reason = t->error;
                }
                break; /* EOF or hang-up: the host closed its end */
            }
            if (r < 0) {
                exit_reason = t->error;
                rc = 1;
                break;
            }
            last_rx_ms = now;
        }
        if (t->open && !was_open) {
            last_hb_ms = now; /* no frame right behind the channel-open answer */
        }
        was_open = t->open;
        /* heartbeat while no cycles flow */
        if (t->open && !app.echo && app.session.stats.cycles == last_cycles &&
            now - last_hb_ms >= HEARTBEAT_PERIOD_MS && !app.off_bus) {
            hil_session_heartbeat(&app.session, (uint32_t)t->rx_errors);
            (void)transport_flush(t);
            last_hb_ms = now;
        }
        if (app.session.stats.cycles != last_cycles) {
            last_cycles = app.session.stats.cycles;
            last_hb_ms = now;
        }
        if (idle_timeout_s > 0.0 && (double)(now - last_rx_ms) > idle_timeout_s * 1000.0) {
            exit_reason = "idle timeout";
            break;
        }
    }
    if (g_stop) {
        exit_reason = "signal";
    }
    if (!quiet) {
        fprintf(stderr,
                "hil_stub: exit (%s): cycles=%lu unknown_ids=%lu length_errors=%lu seq_errors=%lu "
                "config_rejected=%lu tx_overflows=%lu echoed=%lu; %s: ",
                exit_reason, (unsigned long)app.session.stats.cycles,
                (unsigned long)app.session.stats.unknown_ids,
                (unsigned long)app.session.stats.length_errors,
                (unsigned long)app.session.stats.seq_errors,
                (unsigned long)app.session.stats.config_rejected, t->tx_overflows, app.echoed, t->kind);
        t->ops->print_stats(t, stderr);
        fputc('\n', stderr);
    }
    t->ops->close(t);
    return rc;
}
