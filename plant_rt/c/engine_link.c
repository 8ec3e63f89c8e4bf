/* The cycle engine's link I/O (engine_link.h). */
#define _GNU_SOURCE
#include "engine_link.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <linux/can.h>
#include <linux/can/error.h>

int64_t eng_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + (int64_t)ts.tv_nsec;
}

void eng_link_init(eng_link_t *l, int fd, int kind)
{
    int flags;
    memset(l, 0, sizeof *l);
    l->fd = fd;
    l->kind = (eng_link_kind_t)kind;
    hil_deframer_init(&l->deframer);
    flags = fcntl(fd, F_GETFL);
    if (flags >= 0) {
        (void)fcntl(fd, F_SETFL, flags | O_NONBLOCK);
    }
}

void eng_link_attach_peer(eng_link_t *l, const eng_link_peer_t *peer)
{
    l->peer = *peer;
    l->fd = -1;
    l->kind = ENG_LINK_SERIAL;
}

static void fail(eng_link_t *l, const char *what, int err)
{
    if (l->error[0] == '\0') {
        if (err == EIO || err == EPIPE || err == ECONNRESET || err == 0) {
            snprintf(l->error, sizeof l->error, "peer closed the link (%s)",
                     err == 0 ? "EOF" : strerror(err));
            l->closed = 1;
        } else {
            snprintf(l->error, sizeof l->error, "%s failed: %s", what, strerror(err));
        }
    }
}

int eng_link_queue(eng_link_t *l, uint16_t id, const uint8_t *data, uint16_t dlc)
{
    if (dlc > HIL_FRAME_MAX_DATA || id > HIL_FRAME_MAX_ID) {
        return -1;
    }
    if (l->kind == ENG_LINK_SERIAL) {
        size_t n;
        if (ENG_LINK_TXBUF - l->txlen < HIL_FRAME_MAX_WIRE) {
            return -1;
        }
        n = hil_frame_encode(l->txbuf + l->txlen, ENG_LINK_TXBUF - l->txlen, id, data, dlc);
        if (n == 0u) {
            return -1;
        }
        l->txlen += n;
    } else {
        struct canfd_frame *f;
        if (l->txlen >= ENG_LINK_TXFRAMES || (l->kind == ENG_LINK_CAN && dlc > 8u)) {
            return -1;
        }
        f = (struct canfd_frame *)(void *)l->txbuf + l->txlen;
        memset(f, 0, sizeof *f);
        f->can_id = id;
        f->len = (uint8_t)dlc;
        if (l->kind == ENG_LINK_CANFD && l->fd_brs) {
            f->flags = CANFD_BRS;
        }
        if (dlc > 0u) {
            memcpy(f->data, data, dlc);
        }
        l->txlen++;
    }
    l->c.frames_tx++;
    return 0;
}

int eng_link_queue_raw(eng_link_t *l, const uint8_t *data, size_t n)
{
    if (l->kind != ENG_LINK_SERIAL || ENG_LINK_TXBUF - l->txlen < n) {
        return -1;
    }
    memcpy(l->txbuf + l->txlen, data, n);
    l->txlen += n;
    return 0;
}

/* Wait for POLLOUT until deadline; 0 ready, -1 deadline/failure. */
static int wait_writable(eng_link_t *l, int64_t deadline_ns)
{
    struct pollfd p;
    int64_t left = deadline_ns - eng_now_ns();
    int ms;
    if (left <= 0) {
        snprintf(l->error, sizeof l->error, "link did not accept the frames in time (write blocked)");
        return -1;
    }
    ms = (int)(left / 1000000LL) + 1;
    p.fd = l->fd;
    p.events = POLLOUT;
    p.revents = 0;
    if (poll(&p, 1, ms) < 0 && errno != EINTR) {
        fail(l, "poll", errno);
        return -1;
    }
    if (p.revents & (POLLERR | POLLHUP)) {
        fail(l, "write", EIO);
        return -1;
    }
    return 0;
}

int eng_link_flush(eng_link_t *l, int64_t deadline_ns)
{
    if (l->error[0] != '\0') {
        l->txlen = 0u;
        return -1;
    }
    if (l->peer.write != NULL) {
        /* software in the loop: the controller takes the octets now, on this thread */
        const int64_t now = eng_now_ns();
        if (l->txlen > 0u) {
            l->peer.write(l->peer.ctx, l->txbuf, l->txlen, now);
            if (l->tap != NULL) {
                l->tap(l->tap_ctx, 0, l->txbuf, l->txlen, now);
            }
            l->c.bytes_tx += l->txlen;
        }
    } else if (l->kind == ENG_LINK_SERIAL) {
        size_t off = 0u;
        while (off < l->txlen) {
            ssize_t n = write(l->fd, l->txbuf + off, l->txlen - off);
            if (n > 0) {
                if (l->tap != NULL) {
                    l->tap(l->tap_ctx, 0, l->txbuf + off, (size_t)n, eng_now_ns());
                }
                off += (size_t)n;
                continue;
            }
            if (n < 0 && errno == EINTR) {
                continue;
            }
            if (n < 0 && errno == EAGAIN) {
                if (wait_writable(l, deadline_ns) != 0) {
                    l->txlen = 0u;
                    return -1;
                }
                continue;
            }
            fail(l, "write", n < 0 ? errno : EIO);
            l->txlen = 0u;
            return -1;
        }
        l->c.bytes_tx += off;
    } else {
        size_t i;
        const size_t mtu = (l->kind == ENG_LINK_CANFD) ? CANFD_MTU : CAN_MTU;
        for (i = 0u; i < l->txlen; ++i) {
            const struct canfd_frame *f = (const struct canfd_frame *)(const void *)l->txbuf + i;
            /* a classic frame goes out as struct can_frame even on an FD socket */
            const size_t len = (l->kind == ENG_LINK_CANFD && f->len > 8u) ? mtu : CAN_MTU;
            for (;;) {
                ssize_t n = write(l->fd, f, len);
                if (n == (ssize_t)len) {
                    l->c.bytes_tx += f->len;
                    break;
                }
                if (n < 0 && errno == EINTR) {
                    continue;
                }
                if (n < 0 && (errno == EAGAIN || errno == ENOBUFS)) {
                    if (wait_writable(l, deadline_ns) != 0) {
                        l->c.send_failures++;
                        l->error[0] = '\0'; /* a full CAN queue loses this frame, not the link */
                        break;
                    }
                    continue;
                }
                fail(l, "write", n < 0 ? errno : EIO);
                l->txlen = 0u;
                return -1;
            }
        }
    }
    l->txlen = 0u;
    return 0;
}

static void rxq_push(eng_link_t *l, uint16_t id, uint16_t dlc, const uint8_t *data, int64_t t_ns)
{
    eng_frame_t *f = &l->rxq[(l->rxq_head + l->rxq_count) % ENG_LINK_RXQ];
    f->id = id;
    f->dlc = dlc;
    if (dlc > 0u) {
        memcpy(f->data, data, dlc);
    }
    f->t_ns = t_ns;
    l->rxq_count++;
    l->c.frames_rx++;
}

/* Read what is available (never blocks). 0 ok (maybe nothing), -1 failure. */
static int read_available(eng_link_t *l)
{
    for (;;) {
        const unsigned room = ENG_LINK_RXQ - l->rxq_count;
        int64_t now;
        if (l->kind == ENG_LINK_SERIAL) {
            uint8_t buf[4096];
            size_t max = (size_t)room * 7u; /* the shortest frame is 7 octets on the wire */
            ssize_t n, i;
            if (room < 16u) {
                return 0; /* let the engine drain the queue first */
            }
            if (max > sizeof buf) {
                max = sizeof buf;
            }
            if (l->peer.read != NULL) {
                now = eng_now_ns();
                n = (ssize_t)l->peer.read(l->peer.ctx, buf, max, now);
                if (n == 0) {
                    return 0;
                }
            } else {
                n = read(l->fd, buf, max);
                if (n < 0) {
                    if (errno == EINTR) {
                        continue;
                    }
                    if (errno == EAGAIN) {
                        return 0;
                    }
                    fail(l, "read", errno);
                    return -1;
                }
                if (n == 0) {
                    fail(l, "read", 0);
                    return -1;
                }
                now = eng_now_ns();
            }
            if (l->tap != NULL) {
                l->tap(l->tap_ctx, 1, buf, (size_t)n, now);
            }
            l->c.bytes_rx += (uint64_t)n;
            for (i = 0; i < n; ++i) {
                hil_frame_t fr;
                if (hil_deframer_push(&l->deframer, buf[i], &fr) == 1) {
                    rxq_push(l, fr.id, fr.dlc, fr.data, now);
                }
            }
            if ((size_t)n < max) {
                return 0;
            }
        } else {
            struct canfd_frame f;
            ssize_t n;
            if (room == 0u) {
                return 0;
            }
            n = read(l->fd, &f, sizeof f);
            if (n < 0) {
                if (errno == EINTR) {
                    continue;
                }
                if (errno == EAGAIN) {
                    return 0;
                }
                fail(l, "read", errno);
                return -1;
            }
            if (n == 0) {
                fail(l, "read", 0);
                return -1;
            }
            now = eng_now_ns();
            if ((n != (ssize_t)CAN_MTU && n != (ssize_t)CANFD_MTU) ||
                (n == (ssize_t)CAN_MTU && f.len > 8u) || f.len > 64u) {
                l->c.rx_malformed++;
                continue;
            }
            if (f.can_id & CAN_ERR_FLAG) {
                l->c.error_frames++;
                if (f.can_id & CAN_ERR_BUSOFF) {
                    l->bus_off = 1;
                    snprintf(l->error, sizeof l->error, "CAN bus-off reported (error frame 0x%03X)",
                             (unsigned)(f.can_id & CAN_ERR_MASK));
                    return -1;
                }
                if (f.can_id & CAN_ERR_CRTL) {
                    l->c.bus_state_changes++;
                }
                continue;
            }
            if (f.can_id & CAN_RTR_FLAG) {
                l->c.remote_frames++;
                continue;
            }
            if (f.can_id & CAN_EFF_FLAG) {
                l->c.ext_ids++;
                continue;
            }
            l->c.bytes_rx += f.len;
            rxq_push(l, (uint16_t)(f.can_id & CAN_SFF_MASK), f.len, f.data, now);
        }
    }
}

/* Software in the loop: what the controller sent is there at once; if nothing is, nothing will
 * come before the deadline but a heartbeat, so sleep until it (as ppoll on a silent descriptor
 * would) and look once more. */
static int peer_poll(eng_link_t *l, int64_t deadline_ns)
{
    int slept = 0;
    for (;;) {
        struct timespec ts;
        if (l->rxq_count == 0u && l->error[0] == '\0') {
            (void)read_available(l);
        }
        if (l->rxq_count > 0u) {
            return (int)l->rxq_count;
        }
        if (l->error[0] != '\0') {
            return -1;
        }
        if (slept || eng_now_ns() >= deadline_ns) {
            return 0;
        }
        ts.tv_sec = (time_t)(deadline_ns / 1000000000LL);
        ts.tv_nsec = (long)(deadline_ns % 1000000000LL);
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
        }
        slept = 1;
    }
}

int eng_link_poll(eng_link_t *l, int64_t deadline_ns)
{
    if (l->peer.read != NULL) {
        return peer_poll(l, deadline_ns);
    }
    for (;;) {
        struct pollfd p;
        struct timespec ts;
        int64_t left;
        int r;
        if (l->rxq_count > 0u) {
            return (int)l->rxq_count;
        }
        if (l->error[0] != '\0') {
            return -1;
        }
        left = deadline_ns - eng_now_ns();
        if (left < 0) {
            left = 0;
        }
        p.fd = l->fd;
        p.events = POLLIN;
        p.revents = 0;
        ts.tv_sec = (time_t)(left / 1000000000LL);
        ts.tv_nsec = (long)(left % 1000000000LL);
        r = ppoll(&p, 1, &ts, NULL);
        if (r < 0) {
            if (errno == EINTR) {
                continue;
            }
            fail(l, "poll", errno);
            return -1;
        }
        if (r > 0) {
            if (read_available(l) != 0 && l->rxq_count == 0u) {
                return -1;
            }
            if (l->rxq_count == 0u && (p.revents & (POLLHUP | POLLERR)) && !(p.revents & POLLIN)) {
                fail(l, "read", EIO);
                return -1;
            }
            continue;
        }
        return (int)l->rxq_count; /* deadline passed */
    }
}

void eng_link_feed(eng_link_t *l, const uint8_t *data, size_t n)
{
    const int64_t now = eng_now_ns();
    size_t i;
    for (i = 0u; i < n && l->rxq_count < ENG_LINK_RXQ; ++i) {
        hil_frame_t fr;
        if (hil_deframer_push(&l->deframer, data[i], &fr) == 1) {
            rxq_push(l, fr.id, fr.dlc, fr.data, now);
        }
    }
}

void eng_link_push(eng_link_t *l, uint16_t id, const uint8_t *data, uint16_t dlc)
{
    if (l->rxq_count < ENG_LINK_RXQ && dlc <= HIL_FRAME_MAX_DATA) {
        rxq_push(l, id, dlc, data, eng_now_ns());
    }
}

int eng_link_pop(eng_link_t *l, eng_frame_t *out)
{
    if (l->rxq_count == 0u) {
        return 0;
    }
    *out = l->rxq[l->rxq_head];
    l->rxq_head = (l->rxq_head + 1u) % ENG_LINK_RXQ;
    l->rxq_count--;
    return 1;
}

void eng_link_unpop(eng_link_t *l, const eng_frame_t *f)
{
    if (l->rxq_count >= ENG_LINK_RXQ) {
        return;
    }
    l->rxq_head = (l->rxq_head + ENG_LINK_RXQ - 1u) % ENG_LINK_RXQ;
    l->rxq[l->rxq_head] = *f;
    l->rxq_count++;
}
