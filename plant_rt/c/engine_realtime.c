/* The real-time loop: the plant paced by the wall clock from absolute deadlines; a DUTY not
 * back by its deadline is a miss, the held duties act, and a watchdog ends the run. */
#define _GNU_SOURCE
#include "engine_internal.h"

#include <errno.h>
#include <sched.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <time.h>

/* ---- real time --------------------------------------------------------------------------------- */

static void rt_note(engine_t *e, const char *what, int err)
{
    size_t n = strlen(e->rt_notes);
    if (n + 8u < sizeof e->rt_notes) {
        snprintf(e->rt_notes + n, sizeof e->rt_notes - n, "%s%s: %s", n ? "; " : "", what,
                 strerror(err));
    }
}

void eng_rt_setup(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    (void)prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL); /* wake at the deadline, not 50 us later */
    if (cfg->rt_mlock) {
        if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
            e->rt_mlock = 1;
        } else {
            rt_note(e, "mlockall", errno);
        }
    }
    if (cfg->rt_priority > 0) {
        struct sched_param sp;
        memset(&sp, 0, sizeof sp);
        sp.sched_priority = cfg->rt_priority;
        if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0) {
            e->rt_fifo = 1;
        } else {
            rt_note(e, "SCHED_FIFO", errno);
        }
    }
    if (cfg->rt_cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET((size_t)cfg->rt_cpu, &set);
        if (sched_setaffinity(0, sizeof set, &set) == 0) {
            e->rt_pinned = 1;
        } else {
            rt_note(e, "CPU pinning", errno);
        }
    }
}

/** One real-time period's /link/timing row (start error, round trip, arrival, miss). */
static void rt_record_timing(engine_t *e, const cycle_t *c, int64_t start_err_ns, int completed,
                             int64_t sent_ns, int64_t t_k)
{
    rec_timing_t t;
    if (!e->have_ring || !eng_record_full(e, c->k)) {
        return;
    }
    t.t_s = c->t_s;
    t.seq = c->seq;
    t.start_err_us = (double)start_err_ns * 1e-3;
    t.rtt_us = completed ? (double)(c->duty_t_ns - sent_ns) * 1e-3 : (double)NAN;
    t.arrival_us = completed ? (double)(c->duty_t_ns - t_k) * 1e-3 : (double)NAN;
    t.cycle_us = (double)(eng_now_ns() - t_k) * 1e-3;
    t.missed = completed ? 0u : 1u;
    t.retries = 0u;
    t.late_total = e->n.late_duty;
    t.missed_total = e->n.missed_duty;
    t.overrun = 0u;
    RECORD(e, e->cfg.ch_timing, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_timing, &t);
}

/** The /link/timing row of a period the bench lost (it woke late_ns after the period's start,
 *  a whole period or more): no SENSE, no DUTY, the held duties acted. */
static void rt_record_lost(engine_t *e, const cycle_t *c, int64_t late_ns)
{
    rec_timing_t t;
    if (!e->have_ring || !eng_record_full(e, c->k)) {
        return;
    }
    t.t_s = c->t_s;
    t.seq = c->seq;
    t.start_err_us = (double)late_ns * 1e-3;
    t.rtt_us = (double)NAN;
    t.arrival_us = (double)NAN;
    t.cycle_us = (double)NAN;
    t.missed = 0u;
    t.retries = 0u;
    t.late_total = e->n.late_duty;
    t.missed_total = e->n.missed_duty;
    t.overrun = 1u;
    RECORD(e, e->cfg.ch_timing, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_timing, &t);
}

void eng_rt_teardown(engine_t *e)
{
    if (e->rt_fifo) {
        struct sched_param sp;
        memset(&sp, 0, sizeof sp);
        (void)sched_setscheduler(0, SCHED_OTHER, &sp);
    }
    if (e->rt_mlock) {
        (void)munlockall();
    }
}

/** Sleep to deadline - spin, then spin to the deadline. Returns the time it is now. */
int64_t eng_wait_until(int64_t deadline_ns, int64_t spin_ns)
{
    int64_t now = eng_now_ns();
    if (deadline_ns - now > spin_ns) {
        struct timespec ts;
        const int64_t wake = deadline_ns - spin_ns;
        ts.tv_sec = (time_t)(wake / NS_PER_S);
        ts.tv_nsec = (long)(wake % NS_PER_S);
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
        }
    }
    do {
        now = eng_now_ns();
    } while (now < deadline_ns);
    return now;
}

int eng_run_realtime(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    const int64_t ts_ns = (int64_t)llround(cfg->ts_s * 1e9);
    const int64_t spin_ns = (int64_t)(cfg->spin_s * 1e9);
    const int64_t guard_ns = (cfg->duty_update == ENGINE_DUTY_ON_ARRIVAL)
                                 ? (int64_t)(cfg->guard_s * 1e9) : 0;
    const int64_t clock_jump_ns = 100LL * ts_ns + 100000000LL;
    ref_voltage_t rv;
    int next_event = 0;
    long k;
    double latched[3];
    memset(&rv, 0, sizeof rv);
    rv.w_split = 0.0;
    latched[0] = latched[1] = latched[2] = 0.5;
    e->t0_ns = eng_now_ns() + 2000000LL; /* first period 2 ms from now */
    for (k = 0; k < cfg->n_cycles; ++k) {
        cycle_t c;
        const int64_t t_k = e->t0_ns + k * ts_ns;
        const int64_t t_next = t_k + ts_ns;
        int64_t start, sent_ns;
        int completed = 0;
        double split_s;
        if (eng_stop_asked(e)) {
            e->end = ENGINE_END_STOPPED;
            eng_set_message(e, "stopped at cycle %ld", k);
            return e->end;
        }
        eng_begin_cycle(e, &c, k);
        start = eng_wait_until(t_k, spin_ns);
        if (start - t_k > clock_jump_ns) {
            e->end = ENGINE_END_CONFIG;
            eng_set_message(e, "at cycle %ld: the clock jumped or the engine was suspended: period "
                        "start %.3f ms late (more than 100 periods); a real-time run cannot "
                        "continue", k, (double)(start - t_k) * 1e-6);
            return e->end;
        }
        if (start - t_k >= ts_ns) {
            /* The bench itself fell a whole period or more behind (descheduled): those periods
             * are gone. The plant still lives through them, with the held duties and no
             * exchange with the controller, and the engine rejoins the clock at the next
             * deadline. Counted as overruns: the bench's timing failure, not the controller's. */
            long skip = (long)((start - t_k) / ts_ns);
            long i;
            char text[160];
            if (k + skip > cfg->n_cycles) {
                skip = cfg->n_cycles - k;
            }
            for (i = 0; i < skip; ++i) {
                /* each lost period: its start error (>= one period) in the jitter statistics
                 * and a /timing row, so percentiles and rates are never computed over the
                 * periods that went well only */
                const int64_t late_ns = (start - t_k) - i * ts_ns;
                cycle_t lost;
                eng_begin_cycle(e, &lost, k + i);
                eng_hist_add(&e->hist_jitter, (double)late_ns * 1e-3);
                rt_record_lost(e, &lost, late_ns);
                plant_step_split(e->plant, e->duties, 0.0);
                e->n.rt_overruns++;
                __atomic_store_n(&e->cycles_done, k + i + 1, __ATOMIC_RELEASE);
                /* a /link/stats row falls due in a lost period too: readers take deltas
                 * between rows at known cycles */
                if (cfg->stats_every_cycles > 0 && (k + i + 1) % cfg->stats_every_cycles == 0) {
                    engine_write_stats(e, (double)(k + i + 1) * cfg->ts_s, NULL);
                }
            }
            rv.have_prev = rv.have_older = 0;
            e->prev_had_duty = 0;
            snprintf(text, sizeof text, "the bench fell %.0f us behind the clock: %ld period(s) "
                     "integrated with the held duties, no SENSE sent", (double)(start - t_k) * 1e-3,
                     skip);
            eng_record_event(e, c.t_s, "overrun", text, (double)skip);
            k += skip - 1;
            __atomic_store_n(&e->cycles_done, k + 1, __ATOMIC_RELEASE);
            if (!eng_plant_finite(e, &c)) {
                return e->end;
            }
            continue;
        }
        eng_apply_events(e, &next_event, &c);
        eng_take_inputs(e, &c);
        eng_faults_begin_cycle(e, k, c.seq);
        if (eng_build_sense(e, &c) != 0) {
            return e->end;
        }
        eng_queue_sense_group(e, &c);
        if (eng_flush(e, t_next) != 0) {
            eng_fail_link(e, &c);
            return e->end;
        }
        sent_ns = eng_now_ns();
        eng_hist_add(&e->hist_jitter, (double)(start - t_k) * 1e-3); /* the period start (wake-up) */
        /* the duties acting in period k: in NEXT_PERIOD those DUTY(k-1) set, known now */
        if (cfg->duty_update == ENGINE_DUTY_NEXT_PERIOD) {
            e->duties[0] = latched[0];
            e->duties[1] = latched[1];
            e->duties[2] = latched[2];
        }
        /* wait for DUTY(k) until its deadline */
        while (!completed) {
            int r;
            if (eng_drain_frames(e, &c, 1, &completed) != 0) {
                return e->end;
            }
            if (completed) {
                break;
            }
            /* busy_wait: read without sleeping until the DUTY or the deadline (the thread
             * never leaves the CPU, so it sees the DUTY the moment it lands) */
            r = eng_poll(e, cfg->busy_wait ? eng_now_ns() : t_next - guard_ns);
            if (cfg->busy_wait && r == 0 && eng_now_ns() < t_next - guard_ns) {
                continue;
            }
            if (r < 0) {
                eng_fail_link(e, &c);
                return e->end;
            }
            if (r == 0) {
                break; /* deadline */
            }
        }
        if (completed) {
            int applied;
            e->consecutive_miss = 0;
            if (cfg->duty_update == ENGINE_DUTY_NEXT_PERIOD) {
                const double held[3] = {e->duties[0], e->duties[1], e->duties[2]};
                applied = eng_take_duties(e, &c);
                if (applied < 0) {
                    return e->end;
                }
                latched[0] = e->duties[0];
                latched[1] = e->duties[1];
                latched[2] = e->duties[2];
                e->duties[0] = held[0];
                e->duties[1] = held[1];
                e->duties[2] = held[2];
                split_s = 0.0;
            } else {
                applied = eng_take_duties(e, &c);
                if (applied < 0) {
                    return e->end;
                }
                split_s = (double)(c.duty_t_ns - t_k) * 1e-9;
                if (split_s < 0.0) {
                    split_s = 0.0;
                }
                if (split_s > cfg->ts_s) {
                    split_s = cfg->ts_s;
                }
            }
            eng_hist_add(&e->hist_cycle, (double)(c.duty_t_ns - sent_ns) * 1e-3);
            eng_rtt_evidence(e, &c, sent_ns);
        } else {
            e->n.missed_duty++;
            e->late_state[c.seq & (ENGINE_LATE_WINDOW - 1)] = 1; /* its DUTY may still come */
            e->consecutive_miss++;
            split_s = 0.0;
            if (e->consecutive_miss >= cfg->max_consecutive_misses) {
                /* watchdog: all gates off, tell the controller, end the run */
                hil_fault_plant_t m;
                uint8_t buf[8];
                e->duties[0] = e->duties[1] = e->duties[2] = -1.0;
                m.code = (uint16_t)HIL_FAULT_WATCHDOG;
                m.seq = c.seq;
                m.detail = e->consecutive_miss;
                if (hil_fault_plant_pack(buf, &m, sizeof buf) > 0) {
                    eng_queue_frame(e, (uint16_t)HIL_FAULT_PLANT_FRAME_ID, buf);
                    (void)eng_flush(e, eng_now_ns() + 100000000LL);
                }
                eng_after_telemetry(e, &c);
                eng_record_cycle(e, &c);
                rt_record_timing(e, &c, start - t_k, 0, sent_ns, t_k);
                plant_step_split(e->plant, e->duties, 0.0);
                eng_record_event(e, c.t_s, "watchdog",
                             "inverter safe state (all legs off), FAULT_PLANT WATCHDOG sent",
                             (double)e->consecutive_miss);
                e->end = ENGINE_END_WATCHDOG;
                eng_set_message(e, "at cycle %ld (t = %.4f s): %d consecutive periods without a "
                            "DUTY in time: inverter disabled (all legs off), FAULT_PLANT "
                            "WATCHDOG sent, run ended", k, c.t_s, e->consecutive_miss);
                __atomic_store_n(&e->cycles_done, k + 1, __ATOMIC_RELEASE);
                return e->end;
            }
        }
        eng_after_telemetry(e, &c);
        eng_record_cycle(e, &c);
        eng_step_references(e, &c, &rv, 0); /* voltage of period k-1, split at rv.w_split */
        plant_step_split(e->plant, e->duties, split_s);
        e->prev_had_duty = completed;
        /* the references of cycle k+1 see the voltage of period k: older -> newer at split */
        rv.w_split = split_s / cfg->ts_s;
        rv.have_older = rv.have_prev;
        rv.older[0] = rv.prev[0];
        rv.older[1] = rv.prev[1];
        rv.have_prev = eng_duties_to_ab(e->duties, c.smp.v_dc_v, rv.prev);
        if (!eng_plant_finite(e, &c)) {
            return e->end;
        }
        rt_record_timing(e, &c, start - t_k, completed, sent_ns, t_k);
        __atomic_store_n(&e->cycles_done, k + 1, __ATOMIC_RELEASE);
        e->speed_rpm = e->plant->y[2] * cfg->rpm_per_rad_s;
        if (cfg->stats_every_cycles > 0 && (k + 1) % cfg->stats_every_cycles == 0) {
            engine_write_stats(e, (double)(k + 1) * cfg->ts_s, NULL);
        }
        eng_traces_step(e);
        if (eng_trip_over(e, &c)) {
            return e->end;
        }
        /* until the next period: late frames, heartbeats, faults */
        for (;;) {
            int dummy = 1, r;
            if (eng_drain_frames(e, &c, 0, &dummy) != 0) {
                return e->end;
            }
            if (eng_now_ns() >= t_next - spin_ns) {
                break;
            }
            r = eng_poll(e, t_next - spin_ns);
            if (r < 0) {
                eng_fail_link(e, &c);
                return e->end;
            }
            if (r == 0) {
                break;
            }
        }
    }
    return ENGINE_END_DONE;
}
