/**
 * @file transport.c
 * @brief Common part of the Linux port's host links (transport.h): tx buffer, helpers.
 */
#define _DEFAULT_SOURCE
#include "transport.h"

#include <errno.h>
#include <limits.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static const unsigned k_fd_lengths[16] = {0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 12u, 16u, 20u, 24u, 32u, 48u, 64u};

void transport_init(transport_t *t, const transport_ops_t *ops, const char *kind)
{
    memset(t, 0, sizeof *t);
    t->ops = ops;
    t->kind = kind;
    t->fd = -1;
    t->out_fd = -1;
}

int transport_read_bytes(transport_t *t, void *buf, size_t size, size_t *n)
{
    ssize_t r = read(t->fd, buf, size);
    *n = 0u;
    if (r == 0) {
        return 1;
    }
    if (r < 0) {
        if (errno == EINTR || errno == EAGAIN) {
            return 0;
        }
        if (errno == EIO) {
            return 1; /* pty: the host closed its end */
        }
        snprintf(t->error, sizeof t->error, "read from %s failed: %s", t->name, strerror(errno));
        return -1;
    }
    *n = (size_t)r;
    return 0;
}

int transport_flush(transport_t *t)
{
    size_t off = 0u;
    if (t->tx_len == 0u) {
        return 0;
    }
    if (t->out_fd < 0) {
        t->tx_len = 0u;
        return 0;
    }
    while (off < t->tx_len) {
        ssize_t n = write(t->out_fd, t->tx + off, t->tx_len - off);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            if (errno == EAGAIN || errno == EWOULDBLOCK) {
                struct pollfd p;
                p.fd = t->out_fd;
                p.events = POLLOUT;
                p.revents = 0;
                (void)poll(&p, 1, 100);
                continue;
            }
            t->write_errno = errno;
            snprintf(t->error, sizeof t->error, "write to %s failed: %s", t->name, strerror(errno));
            t->tx_len = 0u;
            return -1;
        }
        off += (size_t)n;
    }
    t->tx_len = 0u;
    return 0;
}

int transport_append(transport_t *t, const void *data, size_t n)
{
    if (n > TRANSPORT_TX_SIZE) {
        t->tx_overflows++;
        return -1;
    }
    if (TRANSPORT_TX_SIZE - t->tx_len < n && transport_flush(t) != 0) {
        t->tx_overflows++;
        return -1;
    }
    memcpy(t->tx + t->tx_len, data, n);
    t->tx_len += n;
    return 0;
}

int transport_parse_fd(const char *spec, int *fd)
{
    char *end = NULL;
    long v;
    if (strncmp(spec, "fd:", 3) != 0) {
        return 0;
    }
    errno = 0;
    v = strtol(spec + 3, &end, 10);
    if (errno != 0 || end == spec + 3 || *end != '\0' || v < 0 || v > INT_MAX) {
        return -1;
    }
    *fd = (int)v;
    return 1;
}

void transport_wall_time(long *sec, long *usec)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    *sec = (long)ts.tv_sec;
    *usec = ts.tv_nsec / 1000L;
}

int transport_hex_digit(int c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    return -1;
}

int transport_parse_hex(const char *s, size_t n, unsigned long *out)
{
    unsigned long v = 0u;
    size_t i;
    for (i = 0u; i < n; ++i) {
        int d = transport_hex_digit((unsigned char)s[i]);
        if (d < 0) {
            return -1;
        }
        v = (v << 4) | (unsigned long)d;
    }
    *out = v;
    return 0;
}

unsigned transport_fd_dlc_to_len(unsigned code)
{
    return k_fd_lengths[code & 0xFu];
}

int transport_fd_len_to_dlc(unsigned len)
{
    int code;
    for (code = 0; code < 16; ++code) {
        if (k_fd_lengths[code] >= len) {
            return code;
        }
    }
    return -1;
}
