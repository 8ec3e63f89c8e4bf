/**
 * @file socketcan.c
 * @brief SocketCAN link: a raw AF_CAN socket on a Linux CAN interface (can0 on a real adapter,
 * vcan0 in CI where the kernel has the vcan module). Always compiled; on a kernel without CAN the
 * constructor fails with a message saying so.
 *
 * Classic and CAN FD frames are received (CAN_RAW_FD_FRAMES where the interface supports it); the
 * drive answers in the format the host last used. Error frames are counted; 29-bit ids and remote
 * frames are counted and ignored (the drive only listens to 11-bit data frames). SocketCAN has no
 * end of stream: the stub runs until it is stopped (signal or --idle-timeout-s).
 */
#define _DEFAULT_SOURCE
#include <errno.h>
#include <net/if.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>

#include "transport.h"

typedef struct {
    transport_t base;
    int fd_capable;
    int fd_mode;
    unsigned char fd_flags;
    unsigned long rx_error_frames;
    unsigned long rx_ext_ignored;
    unsigned long rx_remote_ignored;
    unsigned long tx_failed;
} socketcan_t;

static socketcan_t g_sc;

typedef char check_busoff_class[(TRANSPORT_CAN_ERR_BUSOFF == CAN_ERR_BUSOFF) ? 1 : -1];

static int sc_read(transport_t *t, transport_rx_fn deliver, void *user)
{
    socketcan_t *s = (socketcan_t *)t;
    struct canfd_frame fr;
    hil_frame_t f;
    unsigned i;
    ssize_t n = read(t->fd, &fr, sizeof fr);
    if (n < 0) {
        if (errno == EINTR || errno == EAGAIN) {
            return 0;
        }
        snprintf(t->error, sizeof t->error, "read from %s failed: %s", t->name, strerror(errno));
        return -1;
    }
    if (n != (ssize_t)CAN_MTU && n != (ssize_t)CANFD_MTU) {
        t->rx_errors++;
        return 0;
    }
    if (fr.can_id & CAN_ERR_FLAG) {
        s->rx_error_frames++;
        return 0;
    }
    if (fr.can_id & CAN_RTR_FLAG) {
        s->rx_remote_ignored++;
        return 0;
    }
    if (fr.can_id & CAN_EFF_FLAG) {
        s->rx_ext_ignored++;
        return 0;
    }
    if (fr.len > (n == (ssize_t)CANFD_MTU ? CANFD_MAX_DLEN : CAN_MAX_DLEN)) {
        t->rx_errors++;
        return 0;
    }
    s->fd_mode = (n == (ssize_t)CANFD_MTU);
    s->fd_flags = fr.flags;
    f.id = (uint16_t)(fr.can_id & CAN_SFF_MASK);
    f.dlc = fr.len;
    for (i = 0u; i < fr.len; ++i) {
        f.data[i] = fr.data[i];
    }
    t->rx_frames++;
    deliver(user, &f);
    return 0;
}

static void sc_write(socketcan_t *s, const void *frame, size_t size)
{
    int tries;
    for (tries = 0; tries < 50; ++tries) {
        ssize_t n = write(s->base.fd, frame, size);
        if (n == (ssize_t)size) {
            s->base.tx_frames++;
            return;
        }
        if (n < 0 && (errno == EINTR || errno == EAGAIN || errno == ENOBUFS)) {
            usleep(100); /* tx queue full: the bus is busy */
            continue;
        }
        break;
    }
    s->tx_failed++;
    s->base.tx_dropped++;
}

static void sc_queue(transport_t *t, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    socketcan_t *s = (socketcan_t *)t;
    struct canfd_frame fr;
    unsigned i;
    if (t->is_bus_off || id > CAN_SFF_MASK || dlc > (s->fd_mode ? CANFD_MAX_DLEN : CAN_MAX_DLEN)) {
        t->tx_dropped++;
        return;
    }
    memset(&fr, 0, sizeof fr);
    fr.can_id = id;
    fr.len = (unsigned char)dlc;
    for (i = 0u; i < dlc; ++i) {
        fr.data[i] = (unsigned char)(data[i] & 0xFFu);
    }
    if (s->fd_mode) {
        int code = transport_fd_len_to_dlc(dlc);
        fr.len = (unsigned char)transport_fd_dlc_to_len((unsigned)code); /* zero padded */
        fr.flags = s->fd_flags;
        sc_write(s, &fr, CANFD_MTU);
    } else {
        sc_write(s, &fr, CAN_MTU);
    }
}

/* On vcan an error frame written by one socket reaches the others (python-can receives it as an
 * error frame); on real hardware the controller itself reports the bus-off. */
static int sc_bus_off(transport_t *t)
{
    socketcan_t *s = (socketcan_t *)t;
    struct can_frame fr;
    memset(&fr, 0, sizeof fr);
    fr.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
    fr.len = CAN_ERR_DLC;
    sc_write(s, &fr, CAN_MTU);
    t->is_bus_off = 1;
    return 0;
}

static void sc_print_stats(const transport_t *t, FILE *out)
{
    const socketcan_t *s = (const socketcan_t *)t;
    fprintf(out, "frames_in=%lu frames_out=%lu dropped_out=%lu bad_in=%lu error_frames_in=%lu "
                 "ext_ignored=%lu remote_ignored=%lu tx_failed=%lu",
            t->rx_frames, t->tx_frames, t->tx_dropped, t->rx_errors, s->rx_error_frames,
            s->rx_ext_ignored, s->rx_remote_ignored, s->tx_failed);
}

static void sc_close(transport_t *t)
{
    if (t->fd >= 0) {
        close(t->fd);
    }
    t->fd = t->out_fd = -1;
}

static const transport_ops_t k_sc_ops = {sc_read, sc_queue, sc_bus_off, NULL, sc_print_stats, sc_close};

transport_t *socketcan_transport_open(const char *iface, char *err, size_t err_size)
{
    socketcan_t *s = &g_sc;
    struct sockaddr_can addr;
    struct ifreq ifr;
    can_err_mask_t err_mask = CAN_ERR_BUSOFF | CAN_ERR_CRTL;
    int on = 1;
    int fd;
    if (strlen(iface) == 0u || strlen(iface) >= IFNAMSIZ) {
        snprintf(err, err_size, "SocketCAN interface name '%s': 1..%d characters", iface, IFNAMSIZ - 1);
        return NULL;
    }
    fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (fd < 0) {
        snprintf(err, err_size,
                 "SocketCAN unavailable: cannot create an AF_CAN raw socket (%s); this kernel has no "
                 "CAN support (modules can, can_raw; vcan for a virtual bus)", strerror(errno));
        return NULL;
    }
    memset(&ifr, 0, sizeof ifr);
    strcpy(ifr.ifr_name, iface);
    if (ioctl(fd, SIOCGIFINDEX, &ifr) < 0) {
        snprintf(err, err_size,
                 "no CAN interface %s (%s); for a virtual bus: ip link add dev %s type vcan && "
                 "ip link set up %s", iface, strerror(errno), iface, iface);
        close(fd);
        return NULL;
    }
    transport_init(&s->base, &k_sc_ops, "socketcan");
    s->fd_capable = setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) == 0;
    (void)setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask);
    memset(&addr, 0, sizeof addr);
    addr.can_family = AF_CAN;
    addr.can_ifindex = ifr.ifr_ifindex;
    if (bind(fd, (struct sockaddr *)&addr, sizeof addr) != 0) {
        snprintf(err, err_size, "cannot bind a CAN socket to %s: %s", iface, strerror(errno));
        close(fd);
        return NULL;
    }
    s->base.fd = s->base.out_fd = fd;
    s->base.open = 1;
    s->fd_mode = 0;
    s->fd_flags = 0u;
    s->rx_error_frames = s->rx_ext_ignored = s->rx_remote_ignored = s->tx_failed = 0u;
    snprintf(s->base.name, sizeof s->base.name, "SocketCAN %s%s", iface,
             s->fd_capable ? " (CAN FD capable)" : "");
    return &s->base;
}
