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
 *            [--isr sense|timer[:PHASE_US]] [--rt-priority N] [--cpu N] [--heartbeat-always]
 *            [--proto 1.MINOR]
 *
 * --isr chooses what fires the control ISR, as on a DSP drive (docs/protocol.md 6.4):
 *   sense (default)  the arrival of SENSE (the bench's frame is the ADC-complete interrupt);
 *                    the lockstep mode, and real time with a drive that runs off the link
 *   timer            the stub's own PWM timer (timerfd, CLOCK_MONOTONIC) every HELLO period_us,
 *                    free-running like a drive's ePWM interrupt: each tick runs the ISR on the
 *                    latest SENSE received; a tick with no new SENSE since the last one runs
 *                    nothing (the PWM keeps its duties) and is counted (isr_stale). The first
 *                    tick is PHASE_US (default 20 % of the period) after the first SENSE; then
 *                    the timer never re-synchronises (a crystal of its own).
 * --busy-poll: poll the link without sleeping (a CPU of its own, no wake-up latency: a DSP's
 * receive interrupt answers within microseconds; a sleeping Linux process does not).
 * --rt-priority N / --cpu N: SCHED_FIFO priority and CPU of the stub (real-time runs); said once
 * on stderr if not permitted, and the stub carries on.
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
 *   slow         every answer 1.5 control periods late (a controller that overruns its ISR:
 *                in real time its DUTY frames arrive after their period)
 *   late         the answer to every 500th new SENSE 300 ms late, intact (a controller stalled
 *                now and then; the host's re-sends of that SENSE are answered from the cache)
 *   bus-off      the controller goes bus-off: reported the way the link can (socketcand
 *                "< error 040 ... >", a SocketCAN error frame, SLCAN status flags) and silent after
 * --heartbeat-always: HEARTBEAT_CTRL every 100 ms also while cycles flow (docs/protocol.md 6.7
 * "may"), and at once after a rejected frame, so the frames the controller rejected (rx_errors)
 * reach the bench during a run: a fault on the frames the bench sends then leaves a trace there
 * (docs/faults.md).
 * CMD RESTART (the bench's controller_reset fault, in band: docs/protocol.md 6.3) or SIGUSR1
 * restarts the controller as a power cycle would (hil_session_restart: the session and the
 * controller back to their state at power-up, no handshake, no configuration, heartbeat counter
 * from 0, a HEARTBEAT_CTRL at once); the port's own state (the ISR timer, the heartbeat timing,
 * the link's error count) starts over with it.
 *
 * --proto 1.MINOR: speak an older minor version of the protocol, as a drive built against it would
 * (docs/protocol.md 10): HELLO_ACK says that minor, parameters, estimators and commands added after it
 * are unknown (UNKNOWN_PARAM, ESTIMATOR_UNSUPPORTED, ignored). `--proto 1.0` is a 1.0 drive; the bench's
 * tests run it against today's host.
 *
 * --echo sends every received frame straight back instead of running the controller (a loopback
 * for testing the link codecs byte for byte).
 *
 * Exits 0 when the host closes the link (EOF/HUP), on SIGINT/SIGTERM, or after the idle timeout;
 * prints link and session counters to stderr.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include "hil_framing.h"
#include "hil_session.h"
#include "transport.h"

#define HEARTBEAT_PERIOD_MS ((long long)HIL_HEARTBEAT_CTRL_CYCLE_TIME_MS) /* the DBC's GenMsgCycleTime */
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
    INJECT_BUS_OFF,
    INJECT_SLOW,
    INJECT_LATE
} inject_t;

/* --inject late: the answer to every LATE_EVERY-th new SENSE comes LATE_S late (a controller
 * stalled now and then: a lockstep host must wait for it, not end the run) */
#define LATE_EVERY 500ul
#define LATE_S 0.3

typedef struct {
    int timer;             /* 1: ISR on the stub's own timer, 0: on SENSE arrival */
    double phase_us;       /* first tick after the first SENSE (< 0: 20 % of the period) */
    int fd;                /* timerfd (-1 until the first SENSE) */
    int have_sense;        /* a SENSE arrived since the last tick */
    hil_frame_t sense;     /* the latest SENSE */
    unsigned long ticks, stale;
} isr_timer_t;

typedef struct {
    transport_t *link;
    hil_session_t session;
    isr_timer_t isr;
    inject_t inject;
    unsigned long inject_cycle;
    int active;    /* the injection applies to the frame being handled */
    int echo;
    int off_bus;   /* after an injected bus-off: no frame leaves the controller */
    unsigned long late_cycle;  /* --inject late: the cycle last held back (+1; 0: none yet) */
    unsigned long echoed;
} app_t;

static volatile sig_atomic_t g_stop = 0;
static volatile sig_atomic_t g_reset = 0;

static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

static void on_reset_signal(int sig)
{
    (void)sig;
    g_reset = 1;
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

/** Arm the ISR timer: first tick phase after now (the first SENSE), then every period. */
static void isr_timer_start(app_t *a)
{
    struct itimerspec its;
    struct timespec now;
    const double period_s = (double)a->session.ctrl.cfg.ts_s;
    double phase_s = a->isr.phase_us >= 0.0 ? a->isr.phase_us * 1e-6 : 0.2 * period_s;
    long long first_ns, period_ns = (long long)(period_s * 1e9 + 0.5);
    if (period_ns <= 0) {
        return;
    }
    a->isr.fd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    if (a->isr.fd < 0) {
        fprintf(stderr, "hil_stub: timerfd_create failed (%s): ISR stays on SENSE arrival\n",
                strerror(errno));
        a->isr.timer = 0;
        return;
    }
    clock_gettime(CLOCK_MONOTONIC, &now);
    first_ns = (long long)now.tv_sec * 1000000000LL + now.tv_nsec + (long long)(phase_s * 1e9);
    its.it_value.tv_sec = (time_t)(first_ns / 1000000000LL);
    its.it_value.tv_nsec = (long)(first_ns % 1000000000LL);
    its.it_interval.tv_sec = (time_t)(period_ns / 1000000000LL);
    its.it_interval.tv_nsec = (long)(period_ns % 1000000000LL);
    if (timerfd_settime(a->isr.fd, TFD_TIMER_ABSTIME, &its, NULL) != 0) {
        fprintf(stderr, "hil_stub: timerfd_settime failed (%s): ISR stays on SENSE arrival\n",
                strerror(errno));
        close(a->isr.fd);
        a->isr.fd = -1;
        a->isr.timer = 0;
    }
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
    if (a->active && a->inject == INJECT_SLOW && frame->id == HIL_SENSE_FRAME_ID) {
        const double delay_s = 1.5 * (double)a->session.ctrl.cfg.ts_s;
        struct timespec ts;
        ts.tv_sec = (time_t)delay_s;
        ts.tv_nsec = (long)((delay_s - (double)ts.tv_sec) * 1e9);
        nanosleep(&ts, NULL);
    }
    if (a->active && a->inject == INJECT_LATE && frame->id == HIL_SENSE_FRAME_ID &&
        (a->session.stats.cycles - a->inject_cycle) % LATE_EVERY == 0u &&
        a->late_cycle != a->session.stats.cycles + 1u) {
        /* once per cycle: the host's re-sends of this SENSE are answered from the cache */
        struct timespec ts;
        ts.tv_sec = (time_t)LATE_S;
        ts.tv_nsec = (long)((LATE_S - (double)ts.tv_sec) * 1e9);
        a->late_cycle = a->session.stats.cycles + 1u;
        nanosleep(&ts, NULL);
    }
    if (a->active && a->inject == INJECT_GARBAGE) {
        if (a->link->ops->noise != NULL) {
            a->link->ops->noise(a->link);
        } else {
            queue_unknown_id(a);
        }
    }
    if (a->isr.timer && frame->id == HIL_SENSE_FRAME_ID && a->session.hello_done) {
        /* free-running ISR: SENSE is the latest "ADC" reading; the timer runs the ISR */
        a->isr.sense = *frame;
        a->isr.have_sense = 1;
        if (a->isr.fd < 0) {
            isr_timer_start(a);
        }
        a->active = 0;
        return;
    }
    hil_session_on_frame(&a->session, frame);
    a->active = 0;
}

/** One tick of the free-running ISR: run it on the latest SENSE, or count a stale tick. */
static void isr_tick(app_t *a)
{
    uint64_t expirations = 0u;
    if (read(a->isr.fd, &expirations, sizeof expirations) != (ssize_t)sizeof expirations) {
        return;
    }
    a->isr.ticks += expirations;
    if (!a->isr.have_sense) {
        /* no SENSE since the last tick: the PWM keeps its duties; the controller's link timer
         * (ctrl_protect) decides when that is a LINK_TIMEOUT fault */
        a->isr.stale += expirations;
        if (ctrl_link_tick(&a->session.ctrl, a->session.ctrl.cfg.ts_s * (float)expirations) ==
            CTRL_FAULT_LINK_TIMEOUT) {
            hil_fault_ctrl_t m;
            hil_octet_t buf[HIL_FAULT_CTRL_LENGTH];
            m.code = (uint16_t)HIL_FAULT_LINK_TIMEOUT;
            m.seq = a->session.last_seq;
            m.detail = a->session.ctrl.out.fault_detail;
            if (hil_fault_ctrl_pack(buf, &m, sizeof buf) > 0) {
                a->link->ops->queue(a->link, HIL_FAULT_CTRL_FRAME_ID, buf, HIL_FAULT_CTRL_LENGTH);
            }
            fprintf(stderr, "hil_stub: LINK_TIMEOUT: no SENSE for %lu timer ticks\n",
                    (unsigned long)expirations);
        }
        return;
    }
    a->isr.stale += expirations - 1u; /* ticks the stub slept through */
    a->isr.have_sense = 0;
    a->active = a->inject != INJECT_NONE && a->session.stats.cycles >= a->inject_cycle;
    if (a->active && (a->inject == INJECT_SILENT)) {
        a->active = 0;
        return;
    }
    hil_session_on_frame(&a->session, &a->isr.sense);
    a->active = 0;
}

static void usage(void)
{
    fprintf(stderr,
            "usage: hil_stub (--port PATH [--baud N] | --slcan PATH|fd:N [--baud N] | "
            "--socketcand [HOST:]PORT|fd:N [--bus NAME] | --socketcan IFACE)\n"
            "                [--idle-timeout-s S] [--quiet] [--echo]\n"
            "                [--inject silent|crash|garbage|bad-duty|unknown-id|wrong-dlc|bus-off|slow|late@CYCLE]\n"
            "                [--isr sense|timer[:PHASE_US]] [--rt-priority N] [--cpu N] [--busy-poll]\n"
            "                [--heartbeat-always] [--proto 1.MINOR]\n");
}

static int parse_inject(const char *arg, inject_t *kind, unsigned long *cycle)
{
    static const struct {
        const char *name;
        inject_t kind;
    } kinds[] = {{"silent", INJECT_SILENT},       {"crash", INJECT_CRASH},
                 {"garbage", INJECT_GARBAGE},     {"bad-duty", INJECT_BAD_DUTY},
                 {"unknown-id", INJECT_UNKNOWN_ID}, {"wrong-dlc", INJECT_WRONG_DLC},
                 {"bus-off", INJECT_BUS_OFF},     {"slow", INJECT_SLOW},
                 {"late", INJECT_LATE}};
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
    int rt_priority = 0, rt_cpu = -1, busy_poll = 0, hb_always = 0, proto_minor = -1;
    unsigned long last_hb_errors = 0ul;
    uint32_t last_restarts = 0u;
    long long last_busy_ms = 0;

    app.inject = INJECT_NONE;
    app.isr.fd = -1;
    app.isr.phase_us = -1.0;
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
        } else if (strcmp(argv[i], "--isr") == 0 && i + 1 < argc) {
            const char *v = argv[++i];
            if (strcmp(v, "sense") == 0) {
                app.isr.timer = 0;
            } else if (strncmp(v, "timer", 5) == 0 && (v[5] == '\0' || v[5] == ':')) {
                app.isr.timer = 1;
                if (v[5] == ':') {
                    char *end = NULL;
                    app.isr.phase_us = strtod(v + 6, &end);
                    if (end == v + 6 || *end != '\0' || !(app.isr.phase_us >= 0.0)) {
                        fprintf(stderr, "hil_stub: bad --isr '%s'\n", v);
                        return 2;
                    }
                }
            } else {
                fprintf(stderr, "hil_stub: bad --isr '%s' (sense or timer[:PHASE_US])\n", v);
                return 2;
            }
        } else if (strcmp(argv[i], "--rt-priority") == 0 && i + 1 < argc) {
            rt_priority = (int)strtol(argv[++i], NULL, 10);
        } else if (strcmp(argv[i], "--busy-poll") == 0) {
            busy_poll = 1;
        } else if (strcmp(argv[i], "--heartbeat-always") == 0) {
            hb_always = 1;
        } else if (strcmp(argv[i], "--cpu") == 0 && i + 1 < argc) {
            rt_cpu = (int)strtol(argv[++i], NULL, 10);
        } else if (strcmp(argv[i], "--proto") == 0 && i + 1 < argc) {
            const char *v = argv[++i];
            char *end = NULL;
            long major = strtol(v, &end, 10);
            long minor = (end != NULL && *end == '.') ? strtol(end + 1, &end, 10) : -1;
            if (major != (long)HIL_PROTO_VERSION || minor < 0 || minor > (long)HIL_PROTO_VERSION_MINOR ||
                end == NULL || *end != '\0') {
                fprintf(stderr, "hil_stub: --proto '%s': this stub speaks protocol %u.0 to %u.%u\n", v,
                        (unsigned)HIL_PROTO_VERSION, (unsigned)HIL_PROTO_VERSION,
                        (unsigned)HIL_PROTO_VERSION_MINOR);
                return 2;
            }
            proto_minor = (int)minor;
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
    signal(SIGUSR1, on_reset_signal);
    signal(SIGPIPE, SIG_IGN);
    if (rt_cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET((size_t)rt_cpu, &set);
        if (sched_setaffinity(0, sizeof set, &set) != 0) {
            fprintf(stderr, "hil_stub: cannot pin to CPU %d (%s); running unpinned\n", rt_cpu,
                    strerror(errno));
        }
    }
    if (rt_priority > 0) {
        struct sched_param sp;
        memset(&sp, 0, sizeof sp);
        sp.sched_priority = rt_priority;
        if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0) {
            fprintf(stderr, "hil_stub: SCHED_FIFO %d not permitted (%s); running as a normal "
                    "process\n", rt_priority, strerror(errno));
        }
    }

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
    if (proto_minor >= 0) {
        app.session.proto_minor = (uint16_t)proto_minor;
        app.session.session_minor = (uint16_t)proto_minor;
    }
    last_rx_ms = last_hb_ms = now_ms();
    if (!quiet) {
        fprintf(stderr, "hil_stub: listening on %s%s\n", t->name, app.echo ? " (echo)" : "");
    }

    while (!g_stop) {
        struct pollfd pf[2];
        if (g_reset) {
            g_reset = 0;
            hil_session_restart(&app.session);
            (void)transport_flush(t);
        }
        struct pollfd p;
        int pr;
        nfds_t nfds = 1u;
        long long now;
        pf[0].fd = t->fd;
        pf[0].events = POLLIN;
        pf[0].revents = 0;
        if (app.isr.fd >= 0) {
            pf[1].fd = app.isr.fd;
            pf[1].events = POLLIN;
            pf[1].revents = 0;
            nfds = 2u;
        }
        if (busy_poll) {
            /* spin on the descriptors; the heartbeat bookkeeping below runs once a millisecond */
            do {
                pr = poll(pf, nfds, 0);
            } while (pr == 0 && !g_stop && now_ms() - last_busy_ms < 1);
            last_busy_ms = now_ms();
        } else {
            pr = poll(pf, nfds, HEARTBEAT_PERIOD_MS);
        }
        p = pf[0];
        now = now_ms();
        if (pr > 0 && nfds == 2u && (pf[1].revents & POLLIN)) {
            isr_tick(&app);
            if (transport_flush(t) != 0) {
                exit_reason = t->error;
                rc = (t->write_errno == EIO || t->write_errno == EPIPE ||
                      t->write_errno == ECONNRESET) ? 0 : 1;
                break;
            }
        }
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
        if (app.session.restarts != last_restarts) {
            /* a power cycle: the portable code started over (CMD RESTART or SIGUSR1) and said so
             * (HEARTBEAT_CTRL); the port's own state starts over with it, the link stays */
            last_restarts = app.session.restarts;
            app.isr.have_sense = 0;
            if (app.isr.fd >= 0) {
                close(app.isr.fd);
                app.isr.fd = -1;
            }
            t->rx_errors = 0u;
            last_hb_errors = 0ul;
            last_cycles = 0u;
            last_hb_ms = now_ms();
            fprintf(stderr, "hil_stub: restart %lu: session and controller back to power-up\n",
                    (unsigned long)last_restarts);
        }
        if (t->open && !was_open) {
            last_hb_ms = now; /* no frame right behind the channel-open answer */
        }
        was_open = t->open;
        /* heartbeat while no cycles flow; with --heartbeat-always also while they flow, and at
         * once when a frame was rejected (the bench sees the error within the cycle) */
        {
            const unsigned long errors = (unsigned long)t->rx_errors +
                                         (unsigned long)app.session.stats.unknown_ids +
                                         (unsigned long)app.session.stats.length_errors;
            const int due = now - last_hb_ms >= HEARTBEAT_PERIOD_MS ||
                            (hb_always && errors != last_hb_errors);
            if (t->open && !app.echo && (hb_always || app.session.stats.cycles == last_cycles) &&
                due && !app.off_bus) {
                hil_session_heartbeat(&app.session, (uint32_t)t->rx_errors);
                (void)transport_flush(t);
                last_hb_ms = now;
                last_hb_errors = errors;
            }
        }
        if (app.session.stats.cycles != last_cycles) {
            last_cycles = app.session.stats.cycles;
            if (!hb_always) {
                last_hb_ms = now;
            }
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
                "config_rejected=%lu repeats=%lu cmd_seq_gaps=%lu tx_overflows=%lu echoed=%lu "
                "isr_ticks=%lu isr_stale=%lu; %s: ",
                exit_reason, (unsigned long)app.session.stats.cycles,
                (unsigned long)app.session.stats.unknown_ids,
                (unsigned long)app.session.stats.length_errors,
                (unsigned long)app.session.stats.seq_errors,
                (unsigned long)app.session.stats.config_rejected,
                (unsigned long)app.session.stats.repeats, (unsigned long)app.session.stats.cmd_seq_gaps,
                t->tx_overflows, app.echoed, app.isr.ticks, app.isr.stale, t->kind);
        t->ops->print_stats(t, stderr);
        fputc('\n', stderr);
    }
    if (app.isr.fd >= 0) {
        close(app.isr.fd);
    }
    t->ops->close(t);
    return rc;
}
