/**
 * @file socketcand.c
 * @brief The server end of socketcand's protocol (github.com/linux-can/socketcand, doc/protocol.md)
 * on TCP: the stub is a socketcand serving one CAN bus with the drive on it, so the host connects with
 * python-can's socketcand interface (or any socketcand client). One client; the stub exits when it
 * disconnects, as it does when a serial host closes the link.
 *
 *   server: < hi >                          on accept (mode NO_BUS)
 *   client: < open BUS >   -> < ok >        BUS must be the served bus (--bus, default hil0);
 *                                           otherwise < error could not open bus > and the
 *                                           connection ends (as socketcand does)
 *   client: < rawmode >    -> < ok >        (mode BCM -> RAW; only RAW mode carries frames)
 *   client: < bcmmode >    -> < ok >        (RAW -> BCM)
 *   client: < echo >       -> < echo >
 *   client: < send ID LEN B0 B1 ... >       one classic frame (ID 3 hex digits = 11-bit, 8 = 29-bit;
 *                                           LEN 0..8; bytes hex): delivered to the drive
 *   client: < fdsend ID FLAGS LEN B0 ... >  one CAN FD frame (LEN 0..64)
 *   server: < frame ID SEC.USEC DATA >      every frame of the drive in RAW mode, DATA = 2 hex
 *                                           digits per octet without spaces (as socketcand sends)
 *   server: < fdframe ID FLAGS SEC.USEC DATA >  the same in CAN FD once the client used fdsend
 *   server: < error CLASS SEC.USEC >        an error frame (class 040 = bus-off)
 *   anything else -> < error unknown command >; a malformed send is counted and ignored.
 *
 * The listening socket is a TCP port ("[HOST:]PORT", default host 127.0.0.1) or a listening
 * socket inherited from the bench ("fd:N", no port race).
 */
#define _DEFAULT_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "transport.h"

#define SCD_ELEMENT_MAX 512u
#define SCD_MAX_TOKENS 72

typedef enum { SCD_LISTEN, SCD_NO_BUS, SCD_BCM, SCD_RAW } scd_mode_t;

typedef struct {
    transport_t base;
    int listen_fd;
    scd_mode_t mode;
    char bus[32];
    char element[SCD_ELEMENT_MAX];
    size_t element_len;
    int in_element;
    int fd_mode;
    unsigned fd_flags;
    unsigned long commands;
    unsigned long rx_ext_ignored;
    unsigned long rx_refused;  /* frames outside RAW mode or after bus-off */
    unsigned long junk;        /* octets outside < > */
} socketcand_t;

static socketcand_t g_scd;

static void say(socketcand_t *s, const char *text)
{
    (void)transport_append(&s->base, text, strlen(text));
}

static int tokenize(char *text, char **tok, int max)
{
    int n = 0;
    char *save = NULL;
    char *p = strtok_r(text, " \t\r\n", &save);
    while (p != NULL && n < max) {
        tok[n++] = p;
        p = strtok_r(NULL, " \t\r\n", &save);
    }
    return p == NULL ? n : -1;
}

static int parse_hex_token(const char *tok, unsigned long max, unsigned long *out)
{
    size_t n = strlen(tok);
    if (n == 0u || n > 8u || transport_parse_hex(tok, n, out) != 0 || *out > max) {
        return -1;
    }
    return 0;
}

static int parse_dec_token(const char *tok, unsigned long max, unsigned long *out)
{
    char *end = NULL;
    unsigned long v;
    if (tok[0] < '0' || tok[0] > '9') {
        return -1;
    }
    errno = 0;
    v = strtoul(tok, &end, 10);
    if (errno != 0 || *end != '\0' || v > max) {
        return -1;
    }
    *out = v;
    return 0;
}

/* tok: "<" cmd ID [FLAGS] LEN data... ">" */
static void on_send(socketcand_t *s, char **tok, int ntok, int fd, transport_rx_fn deliver, void *user)
{
    hil_frame_t f;
    unsigned long id, len, flags = 0u, v;
    int first = fd ? 5 : 4;
    int i;
    size_t id_digits;
    if (ntok < first + 1 || parse_hex_token(tok[2], 0x1FFFFFFFu, &id) != 0 ||
        (fd && parse_hex_token(tok[3], 0xFFu, &flags) != 0) ||
        parse_dec_token(tok[first - 1], fd ? 64u : 8u, &len) != 0 ||
        ntok != first + (int)len + 1) {
        s->base.rx_errors++;
        return;
    }
    for (i = 0; i < (int)len; ++i) {
        if (parse_hex_token(tok[first + i], 0xFFu, &v) != 0 || strlen(tok[first + i]) > 2u) {
            s->base.rx_errors++;
            return;
        }
        f.data[i] = (hil_octet_t)v;
    }
    if (s->base.is_bus_off) {
        s->rx_refused++;
        return;
    }
    id_digits = strlen(tok[2]);
    if (id_digits == 8u || id > 0x7FFu) {
        s->rx_ext_ignored++; /* on the bus, but the drive only listens to 11-bit ids */
        return;
    }
    s->fd_mode = fd;
    s->fd_flags = (unsigned)flags;
    f.id = (uint16_t)id;
    f.dlc = (uint16_t)len;
    s->base.rx_frames++;
    deliver(user, &f);
}

/* One element "< ... >". Returns 1 if the connection must end. */
static int on_element(socketcand_t *s, transport_rx_fn deliver, void *user)
{
    char *tok[SCD_MAX_TOKENS];
    int n;
    const char *cmd;
    s->commands++;
    n = tokenize(s->element, tok, SCD_MAX_TOKENS);
    if (n < 3 || strcmp(tok[0], "<") != 0 || strcmp(tok[n - 1], ">") != 0) {
        s->base.rx_errors++;
        say(s, "< error syntax >");
        return 0;
    }
    cmd = tok[1];
    if (strcmp(cmd, "echo") == 0 && n == 3) {
        say(s, "< echo >");
        return 0;
    }
    switch (s->mode) {
    case SCD_NO_BUS:
        if (strcmp(cmd, "open") == 0 && n == 4) {
            if (strcmp(tok[2], s->bus) == 0) {
                s->mode = SCD_BCM;
                say(s, "< ok >");
                return 0;
            }
            say(s, "< error could not open bus >");
            snprintf(s->base.error, sizeof s->base.error,
                     "the client asked for bus '%.40s'; this stub serves '%.31s' (--bus)", tok[2], s->bus);
            return 1;
        }
        break;
    case SCD_BCM:
    case SCD_RAW:
        if (strcmp(cmd, "rawmode") == 0 && n == 3) {
            s->mode = SCD_RAW;
            s->base.open = 1;
            say(s, "< ok >");
            return 0;
        }
        if (strcmp(cmd, "bcmmode") == 0 && n == 3) {
            s->mode = SCD_BCM;
            s->base.open = 0;
            say(s, "< ok >");
            return 0;
        }
        if (strcmp(cmd, "send") == 0) {
            on_send(s, tok, n, 0, deliver, user);
            return 0;
        }
        if (strcmp(cmd, "fdsend") == 0) {
            on_send(s, tok, n, 1, deliver, user);
            return 0;
        }
        break;
    case SCD_LISTEN:
        break;
    }
    s->base.rx_errors++;
    say(s, "< error unknown command >");
    return 0;
}

static int accept_client(socketcand_t *s)
{
    int one = 1;
    int c = accept(s->listen_fd, NULL, NULL);
    if (c < 0) {
        if (errno == EINTR || errno == EAGAIN || errno == ECONNABORTED) {
            return 0;
        }
        snprintf(s->base.error, sizeof s->base.error, "accept on %s failed: %s", s->base.name,
                 strerror(errno));
        return -1;
    }
    (void)setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    close(s->listen_fd); /* one client per run */
    s->listen_fd = -1;
    s->base.fd = s->base.out_fd = c;
    s->mode = SCD_NO_BUS;
    say(s, "< hi >");
    return 0;
}

static int scd_read(transport_t *t, transport_rx_fn deliver, void *user)
{
    socketcand_t *s = (socketcand_t *)t;
    char rx[4096];
    ssize_t n, i;
    if (s->mode == SCD_LISTEN) {
        return accept_client(s);
    }
    n = recv(t->fd, rx, sizeof rx, 0);
    if (n == 0) {
        return 1;
    }
    if (n < 0) {
        if (errno == EINTR || errno == EAGAIN) {
            return 0;
        }
        if (errno == ECONNRESET) {
            return 1;
        }
        snprintf(t->error, sizeof t->error, "recv from %s failed: %s", t->name, strerror(errno));
        return -1;
    }
    for (i = 0; i < n; ++i) {
        char c = rx[i];
        if (!s->in_element) {
            if (c == '<') {
                s->in_element = 1;
                s->element_len = 0u;
                s->element[s->element_len++] = c;
            } else if (c != ' ' && c != '\t' && c != '\r' && c != '\n') {
                s->junk++;
            }
            continue;
        }
        if (s->element_len + 1u >= SCD_ELEMENT_MAX) {
            s->in_element = 0;
            t->rx_errors++;
            say(s, "< error command too long >");
            continue;
        }
        s->element[s->element_len++] = c;
        if (c == '>') {
            s->element[s->element_len] = '\0';
            s->in_element = 0;
            if (on_element(s, deliver, user)) {
                (void)transport_flush(t);
                return 1;
            }
        }
    }
    return 0;
}

static void scd_queue(transport_t *t, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    socketcand_t *s = (socketcand_t *)t;
    static const char hex[] = "0123456789ABCDEF";
    char out[64 + 2u * HIL_FRAME_MAX_DATA];
    long sec, usec;
    int n;
    unsigned i;
    size_t len;
    if (s->mode != SCD_RAW || t->is_bus_off || id > 0x7FFu || dlc > (s->fd_mode ? 64u : 8u)) {
        t->tx_dropped++;
        return;
    }
    transport_wall_time(&sec, &usec);
    if (s->fd_mode) {
        n = snprintf(out, sizeof out, "< fdframe %03X %02X %ld.%06ld ", (unsigned)id, s->fd_flags, sec,
                     usec);
    } else {
        n = snprintf(out, sizeof out, "< frame %03X %ld.%06ld ", (unsigned)id, sec, usec);
    }
    if (n < 0 || (size_t)n >= sizeof out) {
        t->tx_dropped++;
        return;
    }
    len = (size_t)n;
    for (i = 0u; i < dlc; ++i) {
        out[len++] = hex[(data[i] >> 4) & 0xFu];
        out[len++] = hex[data[i] & 0xFu];
    }
    out[len++] = ' ';
    out[len++] = '>';
    if (transport_append(t, out, len) == 0) {
        t->tx_frames++;
    }
}

static int scd_bus_off(transport_t *t)
{
    socketcand_t *s = (socketcand_t *)t;
    char out[64];
    long sec, usec;
    if (s->mode != SCD_RAW) {
        return -1;
    }
    transport_wall_time(&sec, &usec);
    snprintf(out, sizeof out, "< error %03X %ld.%06ld >", TRANSPORT_CAN_ERR_BUSOFF, sec, usec);
    say(s, out);
    t->is_bus_off = 1;
    return 0;
}

static void scd_print_stats(const transport_t *t, FILE *out)
{
    const socketcand_t *s = (const socketcand_t *)t;
    fprintf(out, "commands=%lu bad_commands=%lu frames_in=%lu frames_out=%lu dropped_out=%lu "
                 "refused_in=%lu ext_ignored=%lu junk_octets=%lu",
            s->commands, t->rx_errors, t->rx_frames, t->tx_frames, t->tx_dropped, s->rx_refused,
            s->rx_ext_ignored, s->junk);
}

static void scd_close(transport_t *t)
{
    socketcand_t *s = (socketcand_t *)t;
    if (t->fd >= 0 && t->fd != s->listen_fd) {
        close(t->fd);
    }
    if (s->listen_fd >= 0) {
        close(s->listen_fd);
        s->listen_fd = -1;
    }
    t->fd = t->out_fd = -1;
}

static const transport_ops_t k_scd_ops = {scd_read, scd_queue, scd_bus_off, NULL, scd_print_stats,
                                          scd_close};

static int listen_on(const char *spec, char *err, size_t err_size)
{
    char host[64] = "127.0.0.1";
    const char *port_text = spec;
    const char *colon = strrchr(spec, ':');
    struct sockaddr_in addr;
    unsigned long port;
    int one = 1;
    int fd;
    if (colon != NULL) {
        size_t hn = (size_t)(colon - spec);
        if (hn == 0u || hn >= sizeof host) {
            snprintf(err, err_size, "socketcand address %s: bad host", spec);
            return -1;
        }
        memcpy(host, spec, hn);
        host[hn] = '\0';
        port_text = colon + 1;
    }
    if (parse_dec_token(port_text, 65535u, &port) != 0) {
        snprintf(err, err_size, "socketcand address %s: port must be a number 0..65535", spec);
        return -1;
    }
    memset(&addr, 0, sizeof addr);
    addr.sin_family = AF_INET;
    addr.sin_port = htons((uint16_t)port);
    if (inet_pton(AF_INET, host, &addr.sin_addr) != 1) {
        snprintf(err, err_size, "socketcand address %s: host must be an IPv4 address", spec);
        return -1;
    }
    fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) {
        snprintf(err, err_size, "socketcand: cannot create a TCP socket: %s", strerror(errno));
        return -1;
    }
    (void)setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (bind(fd, (struct sockaddr *)&addr, sizeof addr) != 0 || listen(fd, 1) != 0) {
        snprintf(err, err_size, "socketcand: cannot listen on %s:%lu: %s", host, port, strerror(errno));
        close(fd);
        return -1;
    }
    return fd;
}

transport_t *socketcand_transport_open(const char *spec, const char *bus, char *err, size_t err_size)
{
    socketcand_t *s = &g_scd;
    struct sockaddr_in addr;
    socklen_t alen = sizeof addr;
    int fd = -1;
    int r = transport_parse_fd(spec, &fd);
    if (strlen(bus) == 0u || strlen(bus) >= sizeof s->bus) {
        snprintf(err, err_size, "socketcand bus name '%s': 1..%u characters", bus,
                 (unsigned)sizeof s->bus - 1u);
        return NULL;
    }
    if (r < 0) {
        snprintf(err, err_size, "socketcand %s: not a descriptor number", spec);
        return NULL;
    }
    if (r == 0) {
        fd = listen_on(spec, err, err_size);
        if (fd < 0) {
            return NULL;
        }
    }
    transport_init(&s->base, &k_scd_ops, "socketcand");
    s->listen_fd = fd;
    s->base.fd = fd;
    s->base.out_fd = -1;
    s->base.open = 0;
    s->mode = SCD_LISTEN;
    strcpy(s->bus, bus);
    s->element_len = 0u;
    s->in_element = 0;
    s->fd_mode = 0;
    s->fd_flags = 0u;
    s->commands = s->rx_ext_ignored = s->rx_refused = s->junk = 0u;
    if (getsockname(fd, (struct sockaddr *)&addr, &alen) != 0) {
        snprintf(err, err_size, "socketcand %s: not a socket (%s)", spec, strerror(errno));
        close(fd);
        return NULL;
    }
    snprintf(s->base.name, sizeof s->base.name, "socketcand server on %.16s:%u bus %.31s",
             inet_ntoa(addr.sin_addr), (unsigned)ntohs(addr.sin_port), s->bus);
    return &s->base;
}
