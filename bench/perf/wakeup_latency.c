/**
 * @file wakeup_latency.c
 * @brief How late this machine wakes a periodic thread: the floor under the engine's real time.
 *
 *   wakeup_latency [period_us] [periods] [priority] [spin_us]
 *
 * The loop the engine runs in real time, with nothing else in it (cyclictest's measurement,
 * plus the engine's spin): sleep until deadline_k - spin_us (clock_nanosleep, TIMER_ABSTIME,
 * timer slack 1 ns), then spin on CLOCK_MONOTONIC up to deadline_k. Prints one JSON object:
 *
 *   wake_*_us   how late the sleep returned against deadline_k - spin_us (the kernel's and the
 *               hypervisor's timer latency: what a spin of that length has to cover);
 *   start_*_us  how late the period actually started against deadline_k (what the engine
 *               reports as jitter): 0 when the wake-up came inside the spin;
 *   throttled   periods whose start was more than one period late.
 *
 * priority > 0 asks for SCHED_FIFO (root); the answer says whether it was granted. Defaults:
 * 100 us, 100000 periods (10 s), priority 80, spin 30 us (the engine's defaults).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <time.h>

static long long now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a;
    const double y = *(const double *)b;
    return (x > y) - (x < y);
}

static double pct(const double *sorted, long n, double p)
{
    long i = (long)(p * (double)(n - 1) + 0.5);
    return sorted[i];
}

int main(int argc, char **argv)
{
    const long period_ns = (argc > 1 ? atol(argv[1]) : 100) * 1000L;
    const long n = argc > 2 ? atol(argv[2]) : 100000L;
    const int prio = argc > 3 ? atoi(argv[3]) : 80;
    const long spin_ns = (argc > 4 ? atol(argv[4]) : 30) * 1000L;
    if (period_ns <= 0 || n < 10 || prio < 0 || prio > 99 || spin_ns < 0) {
        fprintf(stderr, "usage: wakeup_latency [period_us>0] [periods>=10] [priority 0..99] "
                        "[spin_us>=0]\n");
        return 2;
    }
    double *wake = malloc(sizeof(double) * (size_t)n);
    double *start = malloc(sizeof(double) * (size_t)n);
    if (wake == NULL || start == NULL) {
        fprintf(stderr, "wakeup_latency: out of memory for %ld periods\n", n);
        return 1;
    }
    int fifo = 0;
    const char *why = "";
    if (prio > 0) {
        struct sched_param sp;
        memset(&sp, 0, sizeof sp);
        sp.sched_priority = prio;
        if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0) {
            fifo = 1;
        } else {
            why = strerror(errno);
        }
    }
    (void)prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
    long throttled = 0;
    const long long t0 = now_ns() + 1000000LL;
    for (long k = 0; k < n; ++k) {
        const long long deadline = t0 + k * (long long)period_ns;
        const long long wake_at = deadline - spin_ns;
        long long t = now_ns();
        if (wake_at > t) {
            struct timespec ts = {(time_t)(wake_at / 1000000000LL), (long)(wake_at % 1000000000LL)};
            while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
            }
            t = now_ns();
        }
        wake[k] = (double)(t - wake_at) / 1e3;
        while ((t = now_ns()) < deadline) {
        }
        start[k] = (double)(t - deadline) / 1e3;
        if (t - deadline > period_ns) {
            ++throttled;
        }
    }
    qsort(wake, (size_t)n, sizeof(double), cmp_double);
    qsort(start, (size_t)n, sizeof(double), cmp_double);
    printf("{\"period_us\": %ld, \"periods\": %ld, \"priority\": %d, \"fifo\": %s, "
           "\"fifo_error\": \"%s\", \"spin_us\": %ld, "
           "\"wake_p50_us\": %.2f, \"wake_p99_us\": %.2f, \"wake_p999_us\": %.2f, "
           "\"wake_max_us\": %.2f, \"start_p50_us\": %.2f, \"start_p99_us\": %.2f, "
           "\"start_p999_us\": %.2f, \"start_max_us\": %.2f, \"throttled\": %ld}\n",
           period_ns / 1000L, n, prio, fifo ? "true" : "false", why, spin_ns / 1000L,
           pct(wake, n, 0.5), pct(wake, n, 0.99), pct(wake, n, 0.999), wake[n - 1],
           pct(start, n, 0.5), pct(start, n, 0.99), pct(start, n, 0.999), start[n - 1],
           throttled);
    free(wake);
    free(start);
    return 0;
}
