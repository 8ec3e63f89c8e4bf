/**
 * @file slcan.c
 * @brief The adapter end of SLCAN (Lawicel CAN232/CANUSB ASCII protocol, with the CANable 2.0 CAN FD
 * extensions) on a tty or pty: the stub behaves like a USB-CAN adapter with the drive behind it, so
 * the host opens it with python-can's slcan interface (or slcand, or any Lawicel tool).
 *
 * Host -> adapter, one command per line ending in CR (LF is ignored):
 *
 *   Sn        bit rate (n = 0..8 Lawicel: 10k 20k 50k 100k 125k 250k 500k 800k 1M; 9 = 83.3k as
 *             python-can sends it); only while closed           -> CR, else BEL
 *   sxxyy     BTR0/BTR1 bit timing (stored, not interpreted)     -> CR (closed), else BEL
 *   Yn        CAN FD data bit rate n Mbit/s (CANable 2.0)        -> CR (closed), else BEL
 *   (empty)   python-can sends an empty line when no data bit rate is set: no-op -> CR
 *   O / L     open the channel (L: listen only)                  -> CR, BEL if already open
 *             (python-can sends O twice: the second BEL is harmless and not an error)
 *   C         close the channel                                  -> CR
 *   tiiiL<data>        classic frame, 11-bit id, L = 0..8 octets -> z CR, BEL if closed/bad
 *   TiiiiiiiiL<data>   29-bit id: transmitted on the bus but the drive only listens to 11-bit
 *                      ids (counted, not delivered)               -> Z CR
 *   riiiL / RiiiiiiiiL remote frames (counted, not delivered)    -> z CR / Z CR
 *   diiiL<data>, biiiL<data>  CAN FD frame (b: bit rate switch), L = DLC code 0..F  -> z CR
 *   DiiiiiiiiL<data>, B...    CAN FD, 29-bit id (counted, not delivered)            -> Z CR
 *   V         version                                           -> V1013 CR (hw 10, sw 13)
 *   N         serial number                                     -> NHIL0 CR
 *   F         status flags (bit 5 error passive, bit 7 bus error; set after bus-off) -> Fxx CR
 *   Zn        time stamps off/on (4 hex digits of ms appended to received frames) -> CR
 *   Mxxxxxxxx, mxxxxxxxx, Un, Qn, Xn   acceptance code/mask, UART rate, auto start, auto poll:
 *             accepted and ignored                               -> CR
 *   anything else, a malformed frame, a line longer than 160     -> BEL (counted in rx_errors)
 *
 * Adapter -> host: every frame the drive sends while the channel is open, as tiiiL<data> CR (or as
 * b/d when the host last addressed the drive in CAN FD; from the channel's opening as b when a
 * data bit rate was set with Yn), hex digits upper case. Nothing is sent
 * while the channel is closed (the adapter is off the bus then), nor after a bus-off.
 */
#define _DEFAULT_SOURCE
#include <errno.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "transport.h"

#define SLCAN_LINE_MAX 160u
#define SLCAN_STATUS_ERROR_PASSIVE 0x20u
#define SLCAN_STATUS_BUS_ERROR 0x80u

typedef struct {
    transport_t base;
    char line[SLCAN_LINE_MAX];
    size_t line_len;
    int discarding;       /* the line overflowed: skip to the next CR */
    int listen_only;
    int timestamps;
    int fd_mode;          /* the host's last frame was CAN FD: answer in CAN FD */
    int brs;              /* ... with bit rate switch */
    int bitrate_code;     /* S0..S9, -1 unset */
    int data_bitrate_mbit;
    unsigned status;      /* F flags */
    unsigned long commands;
    unsigned long rx_ext_ignored;
    unsigned long rx_remote_ignored;
    unsigned long rx_refused;   /* frames while closed, listen-only or bus-off */
    unsigned long declined;     /* commands not allowed in the current state */
} slcan_t;

static slcan_t g_slcan;

static const char k_ok[] = "\r";
static const char k_bel[] = "\a";

static void reply(slcan_t *s, const char *text)
{
    (void)transport_append(&s->base, text, strlen(text));
}

/* malformed input: counted as a receive error */
static void refuse(slcan_t *s)
{
    s->base.rx_errors++;
    reply(s, k_bel);
}

/* well-formed but not allowed in this state (e.g. O while open, which python-can sends twice) */
static void decline(slcan_t *s)
{
    s->declined++;
    reply(s, k_bel);
}

/* Parse "<id hex x id_digits><dlc><data>" starting after the command letter. */
static int parse_frame(const char *p, size_t n, size_t id_digits, int fd, hil_frame_t *f,
                       unsigned long *id_out)
{
    unsigned long id, v;
    unsigned len, i;
    int code;
    if (n < id_digits + 1u || transport_parse_hex(p, id_digits, &id) != 0) {
        return -1;
    }
    code = transport_hex_digit((unsigned char)p[id_digits]);
    if (code < 0 || (!fd && code > 8)) {
        return -1;
    }
    len = fd ? transport_fd_dlc_to_len((unsigned)code) : (unsigned)code;
    if (n != id_digits + 1u + 2u * len) {
        return -1;
    }
    for (i = 0u; i < len; ++i) {
        if (transport_parse_hex(p + id_digits + 1u + 2u * i, 2u, &v) != 0) {
            return -1;
        }
        f->data[i] = (hil_octet_t)v;
    }
    f->dlc = (uint16_t)len;
    *id_out = id;
    return 0;
}

static int parse_remote(const char *p, size_t n, size_t id_digits)
{
    unsigned long id;
    return (n == id_digits + 1u && transport_parse_hex(p, id_digits, &id) == 0 &&
            p[id_digits] >= '0' && p[id_digits] <= '8') ? 0 : -1;
}

static int can_transmit(const slcan_t *s)
{
    return s->base.open && !s->listen_only && !s->base.is_bus_off;
}

static void on_frame_command(slcan_t *s, const char *line, size_t n, transport_rx_fn deliver, void *user)
{
    char c = line[0];
    int extended = (c == 'T' || c == 'R' || c == 'D' || c == 'B');
    int fd = (c == 'd' || c == 'b' || c == 'D' || c == 'B');
    int remote = (c == 'r' || c == 'R');
    size_t id_digits = extended ? 8u : 3u;
    hil_frame_t f;
    unsigned long id = 0u;
    int bad;
    if (remote) {
        bad = parse_remote(line + 1, n - 1u, id_digits);
    } else {
        bad = parse_frame(line + 1, n - 1u, id_digits, fd, &f, &id);
    }
    if (bad || (!extended && id > 0x7FFu) || id > 0x1FFFFFFFu) {
        refuse(s);
        return;
    }
    if (!can_transmit(s)) {
        s->rx_refused++;
        reply(s, k_bel);
        return;
    }

    reply(s, extended ? "Z\r" : "z\r");
    if (remote) {
        s->rx_remote_ignored++;
        return;
    }
    if (extended) {
        s->rx_ext_ignored++;
        return;
    }
    s->fd_mode = fd;
    s->brs = (c == 'b');
    f.id = (uint16_t)id;
    s->base.rx_frames++;
    deliver(user, &f);
}

static void on_line(slcan_t *s, const char *line, size_t n, transport_rx_fn deliver, void *user)
{
    char buf[16];
    unsigned long v;
    s->commands++;
    if (n == 0u) {
        reply(s, k_ok);
        return;
    }
    switch (line[0]) {
    case 'S':
        if (n != 2u || line[1] < '0' || line[1] > '9') {
            refuse(s);
        } else if (s->base.open) {
            decline(s);
        } else {
            s->bitrate_code = line[1] - '0';
            reply(s, k_ok);
        }
        break;
    case 's':
        if (n != 5u || transport_parse_hex(line + 1, 4u, &v) != 0) {
            refuse(s);
        } else if (s->base.open) {
            decline(s);
        } else {
            reply(s, k_ok);
        }
        break;
    case 'Y':
        if (n != 2u || line[1] < '1' || line[1] > '9') {
            refuse(s);
        } else if (s->base.open) {
            decline(s);
        } else {
            s->data_bitrate_mbit = line[1] - '0';
            reply(s, k_ok);
        }
        break;
    case 'O':
    case 'L':
        if (n != 1u) {
            refuse(s);
        } else if (s->base.open) {
            decline(s);
        } else {
            s->base.open = 1;
            s->listen_only = (line[0] == 'L');
            /* a data bit rate set (Yn): the bus is CAN FD with bit rate switch, so the drive's
             * frames before the host's first one (an idle HEARTBEAT_CTRL) are too */
            s->fd_mode = s->brs = s->data_bitrate_mbit > 0;
            reply(s, k_ok);
        }
        break;
    case 'C':
        if (n == 1u) {
            s->base.open = 0;
            s->listen_only = 0;
            reply(s, k_ok);
        } else {
            refuse(s);
        }
        break;
    case 't': case 'T': case 'r': case 'R': case 'd': case 'D': case 'b': case 'B':
        on_frame_command(s, line, n, deliver, user);
        break;
    case 'V':
        reply(s, n == 1u ? "V1013\r" : k_bel);
        break;
    case 'N':
        reply(s, n == 1u ? "NHIL0\r" : k_bel);
        break;
    case 'F':
        if (n == 1u) {
            snprintf(buf, sizeof buf, "F%02X\r", s->status & 0xFFu);
            reply(s, buf);
        } else {
            refuse(s);
        }
        break;
    case 'Z':
        if (n == 2u && (line[1] == '0' || line[1] == '1')) {
            s->timestamps = (line[1] == '1');
            reply(s, k_ok);
        } else {
            refuse(s);
        }
        break;
    case 'M':
    case 'm':
        if (n == 9u && transport_parse_hex(line + 1, 8u, &v) == 0) {
            reply(s, k_ok);
        } else {
            refuse(s);
        }
        break;
    case 'U':
    case 'Q':
    case 'X':
        if (n == 2u && line[1] >= '0' && line[1] <= '9') {
            reply(s, k_ok);
        } else {
            refuse(s);
        }
        break;
    default:
        refuse(s);
        break;
    }
}

static int slcan_read(transport_t *t, transport_rx_fn deliver, void *user)
{
    slcan_t *s = (slcan_t *)t;
    char rx[4096];
    size_t n, i;
    int rc = transport_read_bytes(t, rx, sizeof rx, &n);
    if (rc != 0) {
        return rc;
    }
    for (i = 0; i < n; ++i) {
        char c = rx[i];
        if (c == '\r') {
            if (s->discarding) {
                s->discarding = 0;
                refuse(s);
            } else {
                on_line(s, s->line, s->line_len, deliver, user);
            }
            s->line_len = 0u;
        } else if (c == '\n') {
            continue;
        } else if (s->discarding) {
            continue;
        } else if (s->line_len + 1u >= SLCAN_LINE_MAX) {
            s->discarding = 1;
            s->line_len = 0u;
        } else {
            s->line[s->line_len++] = c;
        }
    }
    return 0;
}

static void slcan_queue(transport_t *t, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    slcan_t *s = (slcan_t *)t;
    static const char hex[] = "0123456789ABCDEF";
    char out[8 + 2u * HIL_FRAME_MAX_DATA + 8];
    size_t n = 0u;
    unsigned i, len = dlc;
    if (!t->open || t->is_bus_off || id > 0x7FFu) {
        t->tx_dropped++;
        return;
    }
    if (s->fd_mode) {
        int code = transport_fd_len_to_dlc(dlc);
        if (code < 0) {
            t->tx_dropped++;
            return;
        }
        len = transport_fd_dlc_to_len((unsigned)code); /* padded with 0 up to a valid FD size */
        out[n++] = s->brs ? 'b' : 'd';
        out[n++] = hex[(id >> 8) & 0xFu];
        out[n++] = hex[(id >> 4) & 0xFu];
        out[n++] = hex[id & 0xFu];
        out[n++] = hex[(unsigned)code & 0xFu];
    } else {
        if (dlc > 8u) {
            t->tx_dropped++;
            return;
        }
        out[n++] = 't';
        out[n++] = hex[(id >> 8) & 0xFu];
        out[n++] = hex[(id >> 4) & 0xFu];
        out[n++] = hex[id & 0xFu];
        out[n++] = (char)('0' + dlc);
    }
    for (i = 0u; i < len; ++i) {
        unsigned b = i < dlc ? (unsigned)(data[i] & 0xFFu) : 0u;
        out[n++] = hex[b >> 4];
        out[n++] = hex[b & 0xFu];
    }
    if (s->timestamps) {
        struct timespec ts;
        unsigned ms;
        clock_gettime(CLOCK_MONOTONIC, &ts);
        ms = (unsigned)(((long long)ts.tv_sec * 1000LL + ts.tv_nsec / 1000000L) % 60000LL);
        out[n++] = hex[(ms >> 12) & 0xFu];
        out[n++] = hex[(ms >> 8) & 0xFu];
        out[n++] = hex[(ms >> 4) & 0xFu];
        out[n++] = hex[ms & 0xFu];
    }
    out[n++] = '\r';
    if (transport_append(t, out, n) == 0) {
        t->tx_frames++;
    }
}

/* Lawicel has no asynchronous error report: the flags show it to an 'F' query, and the adapter
 * stops carrying frames both ways (a bus-off controller takes no part in bus traffic). */
static int slcan_bus_off(transport_t *t)
{
    slcan_t *s = (slcan_t *)t;
    s->status |= SLCAN_STATUS_BUS_ERROR | SLCAN_STATUS_ERROR_PASSIVE;
    t->is_bus_off = 1;
    return 0;
}

static void slcan_print_stats(const transport_t *t, FILE *out)
{
    const slcan_t *s = (const slcan_t *)t;
    fprintf(out, "commands=%lu bad_commands=%lu declined_commands=%lu frames_in=%lu frames_out=%lu "
                 "dropped_out=%lu refused_in=%lu ext_ignored=%lu remote_ignored=%lu bitrate=S%d",
            s->commands, t->rx_errors, s->declined, t->rx_frames, t->tx_frames, t->tx_dropped, s->rx_refused,
            s->rx_ext_ignored, s->rx_remote_ignored, s->bitrate_code);
}

static void slcan_close(transport_t *t)
{
    if (t->fd >= 0) {
        close(t->fd);
    }
    t->fd = t->out_fd = -1;
}

static const transport_ops_t k_slcan_ops = {slcan_read, slcan_queue, slcan_bus_off, NULL,
                                            slcan_print_stats, slcan_close};

transport_t *slcan_transport_open(const char *spec, long baud, char *err, size_t err_size)
{
    slcan_t *s = &g_slcan;
    int fd = transport_open_tty(spec, baud, "SLCAN device", err, err_size);
    if (fd < 0) {
        return NULL;
    }
    transport_init(&s->base, &k_slcan_ops, "slcan");
    s->base.fd = s->base.out_fd = fd;
    s->base.open = 0; /* closed until the host sends O (or L) */
    s->line_len = 0u;
    s->discarding = 0;
    s->listen_only = 0;
    s->timestamps = 0;
    s->fd_mode = 0;
    s->brs = 0;
    s->bitrate_code = -1;
    s->data_bitrate_mbit = 0;
    s->status = 0u;
    s->commands = s->rx_ext_ignored = s->rx_remote_ignored = s->rx_refused = s->declined = 0u;
    snprintf(s->base.name, sizeof s->base.name, "SLCAN adapter on %s", spec);
    return &s->base;
}
