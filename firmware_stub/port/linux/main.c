/**
 * @file main.c
 * @brief Linux host port of the firmware stub: the controller under test in CI.
 *
 * Opens a serial device (a pty slave in CI, or a real UART), runs the portable HIL session
 * behind the COBS/CRC deframer, and answers every SENSE frame with the control ISR's output.
 * Everything portable lives in firmware_stub/src; this file is only I/O, time and signals.
 *
 *   hil_stub --port /dev/pts/3 [--baud 3000000] [--idle-timeout-s 0] [--quiet]
 *            [--inject KIND@CYCLE]
 *
 * --inject makes the stub misbehave on purpose from control cycle CYCLE on, so the bench's
 * handling of a bad controller can be tested: silent (stops answering), crash (abort()),
 * garbage (noise bytes before every answer), bad-duty (one DUTY with an out-of-range raw value).
 *
 * Exits 0 when the host closes the link (EOF/HUP), on SIGINT/SIGTERM, or after the idle
 * timeout; prints link and session counters to stderr.
 */
#define _DEFAULT_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "hil_framing.h"
#include "hil_session.h"

#define TX_BUF_SIZE 4096u
#define HEARTBEAT_PERIOD_MS 100

typedef enum { INJECT_NONE, INJECT_SILENT, INJECT_CRASH, INJECT_GARBAGE, INJECT_BAD_DUTY } inject_t;

typedef struct {
    int fd;
    hil_octet_t tx[TX_BUF_SIZE];
    size_t tx_len;
    unsigned long tx_overflows;
} linux_link_t;

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

static int flush_tx(linux_link_t *l)
{
    size_t off = 0u;
    while (off < l->tx_len) {
        ssize_t n = write(l->fd, l->tx + off, l->tx_len - off);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            if (errno == EAGAIN) {
                struct pollfd p;
                p.fd = l->fd;
                p.events = POLLOUT;
                p.revents = 0;
                (void)poll(&p, 1, 100);
                continue;
            }
            return -1;
        }
        off += (size_t)n;
    }
    l->tx_len = 0u;
    return 0;
}

/* hil_port_t.send: frames are queued and written in one syscall after the input is processed */
static void port_send(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    linux_link_t *l = (linux_link_t *)ctx;
    size_t n;
    if (TX_BUF_SIZE - l->tx_len < HIL_FRAME_MAX_WIRE) {
        if (flush_tx(l) != 0) {
            l->tx_overflows++;
            return;
        }
    }
    n = hil_frame_encode(l->tx + l->tx_len, TX_BUF_SIZE - l->tx_len, id, data, dlc);
    l->tx_len += n;
}

static speed_t baud_constant(long baud)
{
    switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 921600: return B921600;
    case 1000000: return B1000000;
    case 2000000: return B2000000;
    case 3000000: return B3000000;
    case 4000000: return B4000000;
    default: return 0;
    }
}

static int configure_port(int fd, long baud)
{
    struct termios t;
    if (!isatty(fd)) {
        return 0; /* a FIFO or socket: nothing to configure */
    }
    if (tcgetattr(fd, &t) != 0) {
        return -1;
    }
    cfmakeraw(&t);
    t.c_cflag |= (tcflag_t)(CLOCAL | CREAD);
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
    if (baud > 0) {
        speed_t s = baud_constant(baud);
        if (s == 0) {
            fprintf(stderr, "hil_stub: unsupported baud rate %ld\n", baud);
            return -1;
        }
        cfsetispeed(&t, s);
        cfsetospeed(&t, s);
    }
    return tcsetattr(fd, TCSANOW, &t);
}

static void usage(void)
{
    fprintf(stderr, "usage: hil_stub --port PATH [--baud N] [--idle-timeout-s S] [--quiet] "
                    "[--inject silent|crash|garbage|bad-duty@CYCLE]\n");
}

static int parse_inject(const char *arg, inject_t *kind, unsigned long *cycle)
{
    const char *at = strchr(arg, '@');
    size_t n = at ? (size_t)(at - arg) : 0u;
    if (at == NULL) {
        return -1;
    }
    *cycle = strtoul(at + 1, NULL, 10);
    if (n == 6u && strncmp(arg, "silent", n) == 0) {
        *kind = INJECT_SILENT;
    } else if (n == 5u && strncmp(arg, "crash", n) == 0) {
        *kind = INJECT_CRASH;
    } else if (n == 7u && strncmp(arg, "garbage", n) == 0) {
        *kind = INJECT_GARBAGE;
    } else if (n == 8u && strncmp(arg, "bad-duty", n) == 0) {
        *kind = INJECT_BAD_DUTY;
    } else {
        return -1;
    }
    return 0;
}

/* Replace the DUTY frame queued last in the tx buffer by one with an out-of-range raw duty. */
static void corrupt_last_duty(linux_link_t *l, uint16_t seq)
{
    hil_octet_t buf[HIL_DUTY_LENGTH];
    hil_duty_t d;
    size_t n;
    d.seq = seq;
    d.d_a = 40000u; /* > 32768 (duty 1.0) and not the OFF sentinel */
    d.d_b = 16384u;
    d.d_c = 16384u;
    if (hil_duty_pack(buf, &d, sizeof buf) > 0) {
        n = hil_frame_encode(l->tx + l->tx_len, TX_BUF_SIZE - l->tx_len, HIL_DUTY_FRAME_ID, buf,
                             HIL_DUTY_LENGTH);
        l->tx_len += n;
    }
}

int main(int argc, char **argv)
{
    const char *path = NULL;
    long baud = 0;
    double idle_timeout_s = 0.0;
    int quiet = 0;
    int i, rc = 0;
    static linux_link_t link;   /* static: large buffers off the stack */
    static hil_session_t session;
    hil_deframer_t deframer;
    hil_port_t port;
    hil_frame_t frame;
    long long last_rx_ms, last_hb_ms;
    uint32_t last_cycles = 0u;
    const char *exit_reason = "host closed the link";
    inject_t inject = INJECT_NONE;
    unsigned long inject_cycle = 0u;

    for (i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--port") == 0 && i + 1 < argc) {
            path = argv[++i];
        } else if (strcmp(argv[i], "--baud") == 0 && i + 1 < argc) {
            baud = strtol(argv[++i], NULL, 10);
        } else if (strcmp(argv[i], "--idle-timeout-s") == 0 && i + 1 < argc) {
            idle_timeout_s = strtod(argv[++i], NULL);
        } else if (strcmp(argv[i], "--quiet") == 0) {
            quiet = 1;
        } else if (strcmp(argv[i], "--inject") == 0 && i + 1 < argc) {
            if (parse_inject(argv[++i], &inject, &inject_cycle) != 0) {
                usage();
                return 2;
            }
        } else {
            usage();
            return 2;
        }
    }
    if (path == NULL) {
        usage();
        return 2;
    }

    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    signal(SIGPIPE, SIG_IGN);

    link.fd = open(path, O_RDWR | O_NOCTTY);
    if (link.fd < 0) {
        fprintf(stderr, "hil_stub: cannot open %s: %s\n", path, strerror(errno));
        return 1;
    }
    if (configure_port(link.fd, baud) != 0) {
        fprintf(stderr, "hil_stub: cannot configure %s: %s\n", path, strerror(errno));
        close(link.fd);
        return 1;
    }
    link.tx_len = 0u;
    link.tx_overflows = 0u;

    port.ctx = &link;
    port.send = port_send;
    hil_session_init(&session, &port);
    hil_deframer_init(&deframer);
    last_rx_ms = last_hb_ms = now_ms();
    if (!quiet) {
        fprintf(stderr, "hil_stub: listening on %s\n", path);
    }

    while (!g_stop) {
        struct pollfd p;
        int pr;
        long long t;
        p.fd = link.fd;
        p.events = POLLIN;
        p.revents = 0;
        pr = poll(&p, 1, HEARTBEAT_PERIOD_MS);
        t = now_ms();
        if (pr < 0) {
            if (errno == EINTR) {
                continue;
            }
            exit_reason = "poll failed";
            rc = 1;
            break;
        }
        if (pr > 0 && (p.revents & POLLIN)) {
            hil_octet_t rx[4096];
            ssize_t n = read(link.fd, rx, sizeof rx);
            if (n <= 0) {
                if (n < 0 && (errno == EINTR || errno == EAGAIN)) {
                    continue;
                }
                break; /* EOF or EIO: the host closed its end */
            }
            for (i = 0; i < (int)n; ++i) {
                if (hil_deframer_push(&deframer, rx[i], &frame) == 1) {
                    int active = inject != INJECT_NONE && session.stats.cycles >= inject_cycle;
                    if (active && inject == INJECT_CRASH && frame.id == HIL_SENSE_FRAME_ID) {
                        fprintf(stderr, "hil_stub: injected crash at cycle %lu\n",
                                (unsigned long)session.stats.cycles);
                        abort();
                    }
                    if (active && inject == INJECT_SILENT) {
                        continue;
                    }
                    if (active && inject == INJECT_GARBAGE && link.tx_len + 8u < TX_BUF_SIZE) {
                        static const hil_octet_t noise[8] = {0x13u, 0x37u, 0xFFu, 0x01u,
                                                             0x00u, 0x42u, 0x99u, 0x05u};
                        memcpy(link.tx + link.tx_len, noise, sizeof noise);
                        link.tx_len += sizeof noise;
                    }
                    hil_session_on_frame(&session, &frame);
                    if (active && inject == INJECT_BAD_DUTY && frame.id == HIL_SENSE_FRAME_ID) {
                        /* drop the good answer, send an out-of-range DUTY once */
                        link.tx_len = 0u;
                        corrupt_last_duty(&link, session.last_seq);
                        inject = INJECT_NONE;
                    }
                }
            }
            if (flush_tx(&link) != 0) {
                exit_reason = "write failed";
                rc = 1;
                break;
            }
            last_rx_ms = t;
        } else if (pr > 0 && (p.revents & (POLLHUP | POLLERR))) {
            break;
        }
        /* heartbeat while no cycles flow */
        if (session.stats.cycles == last_cycles && t - last_hb_ms >= HEARTBEAT_PERIOD_MS) {
            uint32_t link_errors = deframer.crc_errors + deframer.cobs_errors +
                                   deframer.length_errors + deframer.overruns;
            hil_session_heartbeat(&session, link_errors);
            (void)flush_tx(&link);
            last_hb_ms = t;
        }
        if (session.stats.cycles != last_cycles) {
            last_cycles = session.stats.cycles;
            last_hb_ms = t;
        }
        if (idle_timeout_s > 0.0 && (double)(t - last_rx_ms) > idle_timeout_s * 1000.0) {
            exit_reason = "idle timeout";
            break;
        }
    }
    if (g_stop) {
        exit_reason = "signal";
    }
    if (!quiet) {
        fprintf(stderr,
                "hil_stub: exit (%s): cycles=%lu frames_ok=%lu crc_errors=%lu cobs_errors=%lu "
                "length_errors=%lu overruns=%lu unknown_ids=%lu seq_errors=%lu "
                "config_rejected=%lu tx_overflows=%lu\n",
                exit_reason, (unsigned long)session.stats.cycles,
                (unsigned long)deframer.frames_ok, (unsigned long)deframer.crc_errors,
                (unsigned long)deframer.cobs_errors, (unsigned long)deframer.length_errors,
                (unsigned long)deframer.overruns, (unsigned long)session.stats.unknown_ids,
                (unsigned long)session.stats.seq_errors,
                (unsigned long)session.stats.config_rejected, link.tx_overflows);
    }
    close(link.fd);
    return rc;
}
