/**
 * @file transport_serial.c
 * @brief Serial link: HIL frames in COBS/CRC-16 framing (docs/protocol.md section 2) on a UART,
 * a pty slave, a FIFO or an inherited descriptor ("fd:N").
 */
#define _DEFAULT_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <termios.h>
#include <unistd.h>

#include "transport.h"

typedef struct {
    transport_t base;
    hil_deframer_t deframer;
} serial_t;

static serial_t g_serial;

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

static int serial_read(transport_t *t, transport_rx_fn deliver, void *user)
{
    serial_t *s = (serial_t *)t;
    hil_octet_t rx[4096];
    hil_frame_t frame;
    size_t n, i;
    int rc = transport_read_bytes(t, rx, sizeof rx, &n);
    if (rc != 0) {
        return rc;
    }
    for (i = 0; i < n; ++i) {
        if (hil_deframer_push(&s->deframer, rx[i], &frame) == 1) {
            t->rx_frames++;
            deliver(user, &frame);
        }
    }
    t->rx_errors = (unsigned long)s->deframer.crc_errors + s->deframer.cobs_errors +
                   s->deframer.length_errors + s->deframer.overruns;
    return 0;
}

static void serial_queue(transport_t *t, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    hil_octet_t buf[HIL_FRAME_MAX_WIRE];
    size_t n = hil_frame_encode(buf, sizeof buf, id, data, dlc);
    if (n == 0u) {
        t->tx_dropped++;
        return;
    }
    if (transport_append(t, buf, n) == 0) {
        t->tx_frames++;
    }
}

static void serial_noise(transport_t *t)
{
    static const unsigned char noise[8] = {0x13u, 0x37u, 0xFFu, 0x01u, 0x00u, 0x42u, 0x99u, 0x05u};
    (void)transport_append(t, noise, sizeof noise);
}

static int serial_bus_off(transport_t *t)
{
    (void)t;
    return -1;
}

static void serial_print_stats(const transport_t *t, FILE *out)
{
    const serial_t *s = (const serial_t *)t;
    fprintf(out, "frames_ok=%lu crc_errors=%lu cobs_errors=%lu length_errors=%lu overruns=%lu",
            (unsigned long)s->deframer.frames_ok, (unsigned long)s->deframer.crc_errors,
            (unsigned long)s->deframer.cobs_errors, (unsigned long)s->deframer.length_errors,
            (unsigned long)s->deframer.overruns);
}

static void serial_close(transport_t *t)
{
    if (t->fd >= 0) {
        close(t->fd);
    }
    t->fd = t->out_fd = -1;
}

static const transport_ops_t k_serial_ops = {serial_read, serial_queue, serial_bus_off, serial_noise,
                                             serial_print_stats, serial_close};

static int configure_port(int fd, long baud)
{
    struct termios tio;
    if (!isatty(fd)) {
        return 0; /* a FIFO or socket: nothing to configure */
    }
    if (tcgetattr(fd, &tio) != 0) {
        return -1;
    }
    cfmakeraw(&tio);
    tio.c_cflag |= (tcflag_t)(CLOCAL | CREAD);
    tio.c_cc[VMIN] = 1;
    tio.c_cc[VTIME] = 0;
    if (baud > 0) {
        speed_t sp = baud_constant(baud);
        if (sp == 0) {
            errno = EINVAL;
            return -1;
        }
        cfsetispeed(&tio, sp);
        cfsetospeed(&tio, sp);
    }
    return tcsetattr(fd, TCSANOW, &tio);
}

int transport_open_tty(const char *spec, long baud, const char *what, char *err, size_t err_size)
{
    int fd = -1;
    int r = transport_parse_fd(spec, &fd);
    if (r < 0) {
        snprintf(err, err_size, "%s %s: not a descriptor number", what, spec);
        return -1;
    }
    if (r == 0) {
        fd = open(spec, O_RDWR | O_NOCTTY);
        if (fd < 0) {
            snprintf(err, err_size, "cannot open %s %s: %s", what, spec, strerror(errno));
            return -1;
        }
    } else if (fcntl(fd, F_GETFD) < 0) {
        snprintf(err, err_size, "%s %s: descriptor not open (%s)", what, spec, strerror(errno));
        return -1;
    }
    if (configure_port(fd, baud) != 0) {
        if (baud > 0 && baud_constant(baud) == 0) {
            snprintf(err, err_size, "%s %s: unsupported baud rate %ld", what, spec, baud);
        } else {
            snprintf(err, err_size, "cannot configure %s %s: %s", what, spec, strerror(errno));
        }
        close(fd);
        return -1;
    }
    return fd;
}

transport_t *serial_transport_open(const char *path, long baud, char *err, size_t err_size)
{
    serial_t *s = &g_serial;
    int fd = transport_open_tty(path, baud, "serial port", err, err_size);
    if (fd < 0) {
        return NULL;
    }
    transport_init(&s->base, &k_serial_ops, "serial");
    hil_deframer_init(&s->deframer);
    s->base.fd = s->base.out_fd = fd;
    s->base.open = 1; /* a UART carries frames as soon as it is open */
    snprintf(s->base.name, sizeof s->base.name, "serial %s", path);
    return &s->base;
}
