/**
 * @file pty_pingpong.c
 * @brief Raw pty round trip between two C processes: the floor under a lockstep cycle.
 *
 *   pty_pingpong [iterations] [bytes_up] [bytes_down]
 *
 * The parent writes one message of bytes_up on the pty master, the child (on the slave) reads
 * it and writes bytes_down back (default: bytes_up), the parent reads them: one round trip, like
 * one lockstep cycle's uplink (SENSE_AUX, SENSE) and downlink (TELEM, TELEM_EMF, DUTY) frames.
 * Prints round trips per second and latency percentiles.
 */
#define _DEFAULT_SOURCE
#include <fcntl.h>
#include <pty.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

static long long now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

static int read_exact(int fd, unsigned char *buf, size_t n)
{
    size_t got = 0u;
    while (got < n) {
        ssize_t r = read(fd, buf + got, n - got);
        if (r <= 0) {
            return -1;
        }
        got += (size_t)r;
    }
    return 0;
}

static int cmp_ll(const void *a, const void *b)
{
    long long x = *(const long long *)a, y = *(const long long *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    int iterations = argc > 1 ? atoi(argv[1]) : 20000;
    size_t nbytes = argc > 2 ? (size_t)atoi(argv[2]) : 30u;
    size_t nback = argc > 3 ? (size_t)atoi(argv[3]) : nbytes;
    int master, slave, i;
    struct termios t;
    pid_t pid;
    unsigned char buf[4096];
    long long *lat, t0, total;

    if (iterations <= 0 || nbytes == 0u || nbytes > sizeof buf || nback == 0u || nback > sizeof buf) {
        fprintf(stderr, "usage: pty_pingpong [iterations>0] [bytes_up 1..4096] [bytes_down 1..4096]\n");
        return 2;
    }
    if (openpty(&master, &slave, NULL, NULL, NULL) != 0) {
        perror("openpty");
        return 1;
    }
    tcgetattr(slave, &t);
    cfmakeraw(&t);
    tcsetattr(slave, TCSANOW, &t);
    tcgetattr(master, &t);
    cfmakeraw(&t);
    tcsetattr(master, TCSANOW, &t);

    pid = fork();
    if (pid < 0) {
        perror("fork");
        return 1;
    }
    if (pid == 0) { /* child: echo N bytes back, like the stub answering a SENSE */
        close(master);
        for (;;) {
            if (read_exact(slave, buf, nbytes) != 0) {
                _exit(0);
            }
            if (write(slave, buf, nback) != (ssize_t)nback) {
                _exit(1);
            }
        }
    }
    close(slave);
    lat = (long long *)malloc(sizeof(long long) * (size_t)iterations);
    if (lat == NULL) {
        return 1;
    }
    memset(buf, 0x55, sizeof buf);
    t0 = now_ns();
    for (i = 0; i < iterations; ++i) {
        long long s = now_ns();
        if (write(master, buf, nbytes) != (ssize_t)nbytes || read_exact(master, buf, nback) != 0) {
            fprintf(stderr, "pty_pingpong: link failed at iteration %d\n", i);
            return 1;
        }
        lat[i] = now_ns() - s;
    }
    total = now_ns() - t0;
    close(master);
    waitpid(pid, NULL, 0);
    qsort(lat, (size_t)iterations, sizeof lat[0], cmp_ll);
    printf("{\"iterations\": %d, \"bytes_up\": %zu, \"bytes_down\": %zu, \"round_trips_per_s\": %.1f, "
           "\"p50_us\": %.2f, \"p99_us\": %.2f, \"max_us\": %.2f}\n",
           iterations, nbytes, nback, (double)iterations * 1e9 / (double)total,
           (double)lat[iterations / 2] / 1e3, (double)lat[(iterations * 99) / 100] / 1e3,
           (double)lat[iterations - 1] / 1e3);
    free(lat);
    return 0;
}
