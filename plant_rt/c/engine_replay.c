/* Replays (docs/replay.md): the recorded frames into a live controller, the recorded duties
 * into the plant, the reference estimators offline on the recorded samples. */
#include "engine_internal.h"

#include <stdio.h>
#include <string.h>

/* ---- replay ------------------------------------------------------------------------------------ */

/** Replay rows as fast as possible, or paced: row k starts at t0 + (its recorded time - the
 *  first row's) * pace_s / ts_s (absolute deadlines; pace_s = Ts / rate), so a gap in the
 *  capture is a pause of its recorded length, not one period. The pacing error of each row goes
 *  to the jitter histogram. */
static int64_t replay_pace(engine_t *e, long k, int64_t *start_err_ns)
{
    int64_t now;
    if (!(e->cfg.pace_s > 0.0)) {
        *start_err_ns = 0;
        return eng_now_ns();
    }
    if (k == 0) {
        e->t0_ns = eng_now_ns() + 1000000LL;
    }
    {
        const double dt_rec = e->cfg.replay_cycles[k].t_s - e->cfg.replay_cycles[0].t_s;
        const int64_t deadline =
            e->t0_ns + (int64_t)llround(dt_rec * (e->cfg.pace_s / e->cfg.ts_s) * 1e9);
        now = eng_wait_until(deadline, (int64_t)(e->cfg.spin_s * 1e9));
        *start_err_ns = now - deadline;
        eng_hist_add(&e->hist_jitter, (double)*start_err_ns * 1e-3);
    }
    return now;
}

static void replay_timing_row(engine_t *e, const cycle_t *c, int64_t c0, int64_t sent_ns,
                              int64_t start_err_ns)
{
    const int64_t c1 = eng_now_ns();
    rec_timing_t t;
    eng_hist_add(&e->hist_cycle, (double)(c1 - c0) * 1e-3);
    if (!e->have_ring) {
        return;
    }
    t.t_s = c->t_s;
    t.seq = c->seq;
    t.start_err_us = (e->cfg.pace_s > 0.0) ? (double)start_err_ns * 1e-3 : (double)NAN;
    t.rtt_us = (sent_ns > 0 && c->have_duty) ? (double)(c->duty_t_ns - sent_ns) * 1e-3
                                              : (double)NAN;
    t.arrival_us = (double)NAN;
    t.cycle_us = (double)(c1 - c0) * 1e-3;
    t.missed = 0u;
    t.retries = (uint32_t)c->retries;
    t.late_total = e->n.late_duty;
    t.missed_total = e->n.missed_duty;
    t.overrun = 0u;
    RECORD(e, e->cfg.ch_timing, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_timing, &t);
}

/** Start replayed cycle k: stop request, pacing, the cycle with the row's time, seq, samples
 *  and angle. 0, or -1 with e->end set (stopped). */
static int replay_begin(engine_t *e, cycle_t *c, long k, int64_t *c0, int64_t *start_err)
{
    const engine_replay_cycle_t *row = &e->cfg.replay_cycles[k];
    if (eng_stop_asked(e)) {
        e->end = ENGINE_END_STOPPED;
        eng_set_message(e, "stopped at replayed cycle %ld", k);
        return -1;
    }
    *c0 = replay_pace(e, k, start_err);
    eng_begin_cycle(e, c, k);
    c->t_s = row->t_s;
    e->cur_t_s = c->t_s;
    c->seq = (uint16_t)row->seq;
    c->s_i[0] = row->i_abc_a[0];
    c->s_i[1] = row->i_abc_a[1];
    c->s_i[2] = row->i_abc_a[2];
    c->smp.v_dc_v = row->v_dc_v;
    c->snap.theta_e_rad = row->has_theta ? row->theta_rad : (double)NAN;
    c->theta_enc = (double)NAN;
    eng_take_inputs(e, c);   /* bench replay --live: a viewer's inputs, every one refused on /events */
    return 0;
}

/** The recorded DUTY of a row, validated as a live one; without one the last duties hold. */
static int take_recorded_duties(engine_t *e, cycle_t *c, const engine_replay_cycle_t *row)
{
    if (!row->has_duty) {
        e->n.missed_duty++;
        return 0;
    }
    c->have_duty = 1;
    c->duty_raw[0] = row->duty_raw[0];
    c->duty_raw[1] = row->duty_raw[1];
    c->duty_raw[2] = row->duty_raw[2];
    return eng_take_duties(e, c) < 0 ? -1 : 0;
}

/** End replayed cycle k: its timing row, progress, statistics. */
static void replay_end(engine_t *e, const cycle_t *c, long k, int64_t c0, int64_t sent_ns,
                       int64_t start_err)
{
    replay_timing_row(e, c, c0, sent_ns, start_err);
    __atomic_store_n(&e->cycles_done, k + 1, __ATOMIC_RELEASE);
    if (e->cfg.stats_every_cycles > 0 && (k + 1) % e->cfg.stats_every_cycles == 0) {
        engine_write_stats(e, c->t_s, NULL);
    }
}

/** The recorded frames of each cycle to a live controller; its answers beside the recorded. */
int eng_run_replay_controller(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    long k;
    for (k = 0; k < cfg->n_cycles; ++k) {
        const engine_replay_cycle_t *row = &cfg->replay_cycles[k];
        cycle_t c;
        int64_t start_err, c0, sent_ns = 0;
        uint32_t i;
        if (replay_begin(e, &c, k, &c0, &start_err) != 0) {
            return e->end;
        }
        c.replay = row;
        eng_resent_settle(e, k - 1);
        eng_faults_begin_cycle(e, k, c.seq);
        for (i = 0u; i < row->n_frames; ++i) {
            const engine_replay_frame_t *f = &cfg->replay_frames[row->first_frame + i];
            (void)eng_xmit(e, f->id, f->data, f->dlc);
            if (cfg->record_frames) {
                eng_text_frame(e->tx_text, &e->tx_len, f->id, f->data, f->dlc);
            }
        }
        if (eng_exchange_lockstep(e, &c, c0, &sent_ns) != 0 || eng_take_duties(e, &c) < 0) {
            return e->end;
        }
        eng_after_telemetry(e, &c);
        eng_record_cycle(e, &c);
        if (e->have_ring) {
            rec_replay_controller_t r;
            r.t_s = c.t_s;
            r.seq = c.seq;
            r.duty_a_rec = row->has_duty ? eng_duty_of_raw(e, row->duty_raw[0]) : (double)NAN;
            r.duty_b_rec = row->has_duty ? eng_duty_of_raw(e, row->duty_raw[1]) : (double)NAN;
            r.duty_c_rec = row->has_duty ? eng_duty_of_raw(e, row->duty_raw[2]) : (double)NAN;
            r.duty_a = eng_duty_of_raw(e, c.duty_raw[0]);
            r.duty_b = eng_duty_of_raw(e, c.duty_raw[1]);
            r.duty_c = eng_duty_of_raw(e, c.duty_raw[2]);
            r.theta_hat_rec_rad = row->has_telem ? row->theta_hat_rad : (double)NAN;
            r.omega_hat_rec_rad_s = row->has_telem ? row->omega_hat_rad_s : (double)NAN;
            r.theta_hat_rad = c.have_telem ? c.th_hat : (double)NAN;
            r.omega_hat_rad_s = c.have_telem ? c.w_hat : (double)NAN;
            r.state_rec = row->has_telem ? row->state : -1;
            r.estimator_rec = row->has_telem ? row->estimator : -1;
            r.state = c.have_telem ? c.st : -1;
            r.estimator = c.have_telem ? c.est : -1;
            r.e_alpha_rec_v = row->has_emf ? row->e_alpha_v : (double)NAN;
            r.e_beta_rec_v = row->has_emf ? row->e_beta_v : (double)NAN;
            r.i_q_ref_rec_a = row->has_emf ? row->i_q_ref_a : (double)NAN;
            r.e_alpha_v = c.have_emf ? c.e_a : (double)NAN;
            r.e_beta_v = c.have_emf ? c.e_b : (double)NAN;
            r.i_q_ref_a = c.have_emf ? c.iq_ref : (double)NAN;
            RECORD(e, cfg->ch_replay, c.t_s, REC_MAX_FIXED_SIZE, rec_encode_replay_controller, &r);
        }
        e->prev_had_duty = 1;
        replay_end(e, &c, k, c0, sent_ns, start_err);
        eng_traces_step(e);
    }
    return ENGINE_END_DONE;
}

/** The plant's part of a replayed cycle: its sampled currents beside the recorded ones (NaN for a
 *  cycle the capture misses). */
static void replay_plant_row(engine_t *e, const cycle_t *c, const engine_replay_cycle_t *row)
{
    rec_replay_plant_t r;
    if (!e->have_ring) {
        return;
    }
    r.t_s = c->t_s;
    r.seq = c->seq;
    r.i_a_rec_a = row != NULL ? row->i_abc_a[0] : (double)NAN;
    r.i_b_rec_a = row != NULL ? row->i_abc_a[1] : (double)NAN;
    r.i_c_rec_a = row != NULL ? row->i_abc_a[2] : (double)NAN;
    r.i_a_a = c->s_i[0];
    r.i_b_a = c->s_i[1];
    r.i_c_a = c->s_i[2];
    RECORD(e, e->cfg.ch_replay, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_replay_plant, &r);
}

/** The recorded duties drive the plant open loop (no link); its currents beside the recorded,
 *  reference estimators on its samples. The plant keeps its own time (step * Ts): a cycle the
 *  capture misses (a gap in the rows' times) is stepped through with the last duties held, as
 *  a drive whose DUTY did not come (counted in missed_duty), and recorded without recorded
 *  currents beside it. */
int eng_run_replay_plant(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    ref_voltage_t rv;
    int next_event = 0;
    long k, step = 0;
    memset(&rv, 0, sizeof rv);
    rv.w_split = cfg->t_delay_s / cfg->ts_s;
    for (k = 0; k < cfg->n_cycles; ++k) {
        const engine_replay_cycle_t *row = &cfg->replay_cycles[k];
        cycle_t c;
        int64_t start_err, c0;
        long missing = (k == 0) ? 0 : (long)llround((row->t_s - row[-1].t_s) / cfg->ts_s) - 1;
        if (replay_begin(e, &c, k, &c0, &start_err) != 0) {
            return e->end;
        }
        for (; missing > 0; --missing, ++step) {
            cycle_t g;
            eng_begin_cycle(e, &g, step);
            eng_apply_events(e, &next_event, &g);
            if (eng_build_sense(e, &g) != 0) {
                return e->end;
            }
            e->n.missed_duty++;
            eng_record_cycle(e, &g);
            replay_plant_row(e, &g, NULL);
            eng_step_references(e, &g, &rv, 1);
            plant_step(e->plant, e->duties);
            if (!eng_plant_finite(e, &g)) {
                return e->end;
            }
        }
        c.k = step;
        c.t_s = (double)step * cfg->ts_s;       /* the plant's own time */
        ++step;
        eng_apply_events(e, &next_event, &c);
        if (eng_build_sense(e, &c) != 0 || take_recorded_duties(e, &c, row) != 0) {
            return e->end;
        }
        eng_record_cycle(e, &c);
        replay_plant_row(e, &c, row);
        eng_step_references(e, &c, &rv, 1);
        plant_step(e->plant, e->duties);
        e->speed_rpm = e->plant->y[2] * cfg->rpm_per_rad_s;
        replay_end(e, &c, k, c0, 0, start_err);
        if (!eng_plant_finite(e, &c)) {
            return e->end;
        }
    }
    return ENGINE_END_DONE;
}

/** Offline: the reference estimators on the recorded samples and the voltage the recorded
 *  duties applied -- the same eng_step_references the live loop uses, so a recording replayed
 *  gives bit-identical estimates with the same build. */
int eng_run_replay_estimators(engine_t *e)
{
    const engine_config_t *cfg = &e->cfg;
    ref_voltage_t rv;
    long k;
    memset(&rv, 0, sizeof rv);
    rv.w_split = cfg->t_delay_s / cfg->ts_s;
    for (k = 0; k < cfg->n_cycles; ++k) {
        cycle_t c;
        int64_t start_err, c0;
        if (replay_begin(e, &c, k, &c0, &start_err) != 0 ||
            take_recorded_duties(e, &c, &cfg->replay_cycles[k]) != 0) {
            return e->end;
        }
        eng_step_references(e, &c, &rv, 1);
        replay_end(e, &c, k, c0, 0, start_err);
    }
    return ENGINE_END_DONE;
}
