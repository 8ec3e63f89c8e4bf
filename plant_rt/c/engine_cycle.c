/* One cycle's pieces, shared by the loops: begin, scenario events, the SENSE group, the
 * duties, the rows of the cycle and the reference estimators on the same samples. */
#include "engine_internal.h"

#include <stdio.h>
#include <string.h>

/** Python's float modulo (the result has the sign of y), as bench/loop/runner.py used it. */
static double py_mod(double x, double y)
{
    double m = fmod(x, y);
    if (isnan(m) || m < 0.0 || m > 0.0) {
        if ((y < 0.0) != (m < 0.0)) {
            m += y;
        }
    } else {
        m = copysign(0.0, y);
    }
    return m;
}

static double wrap_pi(double x)
{
    return py_mod(x + PI_, TWO_PI) - PI_;
}

/**
 * physical -> raw by docs/protocol.md section 3 (binary64, ties away from zero), exactly as
 * protocol/messages.py does it. 0 ok; -1 NaN; -2 out of range (only without saturate).
 */
static int encode_signal(const engine_signal_t *s, double v, int saturate, long *raw)
{
    double q;
    if (isnan(v)) {
        return -1;
    }
    q = (s->offset < 0.0 || s->offset > 0.0) ? (v - s->offset) / s->scale : v / s->scale;
    if (q > s->raw_min - 0.5 && q < s->raw_max + 0.5) {
        long r = (long)q; /* truncates toward zero, like Python's int() */
        double f = q - (double)r;
        if (f >= 0.5) {
            r += 1;
        } else if (f <= -0.5) {
            r -= 1;
        }
        *raw = r;
        return 0;
    }
    if (!saturate) {
        return -2;
    }
    *raw = (long)((q < s->raw_min) ? s->raw_min : s->raw_max);
    return 0;
}

void eng_queue_frame(engine_t *e, uint16_t id, const uint8_t *data)
{
    (void)eng_xmit(e, id, data, 8u);
    if (e->cfg.record_frames) {
        eng_text_frame(e->tx_text, &e->tx_len, id, data, 8u);
    }
}

void eng_queue_sense_group(engine_t *e, const cycle_t *c)
{
    eng_queue_frame(e, (uint16_t)HIL_SENSE_AUX_FRAME_ID, c->aux);
    if (c->have_dual) {
        eng_queue_frame(e, (uint16_t)HIL_SENSE_DUAL_FRAME_ID, c->dual);
    }
    eng_queue_frame(e, (uint16_t)HIL_SENSE_FRAME_ID, c->sense);
}

/** The SENSE group again (lockstep retry): the recorded one in a replay. */
void eng_queue_resend(engine_t *e, const cycle_t *c)
{
    if (c->replay != NULL) {
        uint32_t i;
        for (i = 0u; i < c->replay->n_frames; ++i) {
            const engine_replay_frame_t *f = &e->cfg.replay_frames[c->replay->first_frame + i];
            if (f->id == HIL_SENSE_AUX_FRAME_ID || f->id == HIL_SENSE_DUAL_FRAME_ID ||
                f->id == HIL_SENSE_FRAME_ID) {
                (void)eng_xmit(e, f->id, f->data, f->dlc);
                if (e->cfg.record_frames) {
                    eng_text_frame(e->tx_text, &e->tx_len, f->id, f->data, f->dlc);
                }
            }
        }
        return;
    }
    eng_queue_sense_group(e, c);
}

/** A CMD frame (the run's next CMD seq) sent with this cycle's SENSE frames. */
void eng_queue_cmd(engine_t *e, int command, double value)
{
    hil_cmd_t m;
    uint8_t buf[8];
    m.command = (uint16_t)command;
    m.seq = e->cmd_seq++;
    m.value = (float)value;
    if (hil_cmd_pack(buf, &m, sizeof buf) > 0) {
        eng_queue_frame(e, (uint16_t)HIL_CMD_FRAME_ID, buf);
    }
}

/** Events due at cycle k: CMD frames queued, plant inputs set, /events rows. */
void eng_apply_events(engine_t *e, int *next_event, const cycle_t *c)
{
    while (*next_event < e->n_events && e->events[*next_event].cycle <= c->k) {
        const engine_event_t *ev = &e->events[(*next_event)++];
        switch (ev->kind) {
        case ENGINE_EV_CMD:
            eng_queue_cmd(e, ev->command, ev->value);
            break;
        case ENGINE_EV_LOAD:
            plant_set_load_torque(e->plant, ev->value);
            break;
        case ENGINE_EV_DYNO_SPEED:
            plant_set_dyno_speed(e->plant, ev->value);
            break;
        case ENGINE_EV_PLANT_FAULT: {
            const plant_fault_t pf = eng_event_plant_fault(ev);
            char text[160];
            if (plant_set_fault(e->plant, &pf) != 0) {
                const char *why = plant_fault_check(e->plant, &pf);
                snprintf(text, sizeof text, "refused by the plant: %s",
                         why != NULL ? why : "(no reason)");
                if (ev->fault_index >= 0 && ev->fault_index < ENGINE_MAX_TRACES) {
                    e->traces[ev->fault_index].refused = 1;
                }
                eng_record_fault(e, (int32_t)c->seq, ev->fault_index, "plant", ev->fault_name, "",
                             "refused", text, ev->value);
            } else {
                snprintf(text, sizeof text, "%s", ev->text[0] ? ev->text : ev->fault_name);
                eng_record_fault(e, (int32_t)c->seq, ev->fault_index, "plant", ev->fault_name, "",
                             "on", text, ev->value);
                eng_trace_act(e, ev->fault_index, 0);
            }
            eng_full_rate_from_now(e, e->cfg.post_trigger_cycles);
            break;
        }
        case ENGINE_EV_PLANT_FAULT_CLEAR:
            plant_clear_fault(e->plant, ev->fault_kind, ev->fault_phase);
            eng_record_fault(e, (int32_t)c->seq, ev->fault_index, "plant", ev->fault_name, "", "off",
                         ev->text[0] ? ev->text : ev->fault_name, ev->value);
            eng_full_rate_from_now(e, e->cfg.post_trigger_cycles);
            break;
        case ENGINE_EV_CONTROLLER_RESET: {
            /* in band: CMD RESTART goes out with this cycle's frames, before its SENSE_AUX and
             * SENSE, so the controller restarts at a defined cycle whatever the timing (and a
             * port running the firmware in the engine's thread sees the same) */
            hil_cmd_t m;
            uint8_t buf[8];
            char text[128];
            m.command = (uint16_t)HIL_CMD_RESTART;
            m.seq = e->cmd_seq++;
            m.value = 0.0f;
            if (hil_cmd_pack(buf, &m, sizeof buf) > 0) {
                eng_queue_frame(e, (uint16_t)HIL_CMD_FRAME_ID, buf);
            }
            snprintf(text, sizeof text, "CMD RESTART (CMD seq %u) sent with the frames of cycle "
                     "%ld, before its SENSE", (unsigned)m.seq, c->k);
            eng_record_fault(e, (int32_t)c->seq, ev->fault_index, "controller", ev->fault_name, "",
                         "on", text, 0.0);
            e->cyc_restart++;
            e->cyc_restart_fault = ev->fault_index;
            eng_trace_act(e, ev->fault_index, 0);
            eng_full_rate_from_now(e, e->cfg.post_trigger_cycles);
            break;
        }
        default:
            break;
        }
        if (ev->record) {
            eng_record_event(e, c->t_s, "scenario", ev->text, ev->record_value);
        }
    }
}

/** Sample the plant (it is at t_k), encode the SENSE group. 0, or -1 (ENGINE_END_PLANT set). */
int eng_build_sense(engine_t *e, cycle_t *c)
{
    const engine_config_t *cfg = &e->cfg;
    hil_sense_aux_t aux;
    hil_sense_t sense;
    long raw[3], r;
    double theta_max;
    int k;
    plant_sample(e->plant, &c->smp);
    plant_snapshot(e->plant, &c->snap);
    /* SENSE_AUX: bus voltage and (only when asked) the encoder angle, which wraps at 2 pi */
    aux.seq = c->seq;
    if (encode_signal(&cfg->sig_vdc, c->smp.v_dc_v, 0, &r) != 0) {
        e->end = ENGINE_END_PLANT;
        eng_set_message(e, "at cycle %ld (t = %.4f s): bus voltage %g V cannot be sent (SENSE_AUX.v_dc "
                    "range [%g, %g] V)", c->k, c->t_s, c->smp.v_dc_v,
                    cfg->sig_vdc.raw_min * cfg->sig_vdc.scale, cfg->sig_vdc.raw_max * cfg->sig_vdc.scale);
        return -1;
    }
    aux.v_dc = (uint16_t)r;
    aux.flags = 0u;
    aux.theta_enc = 0u;
    c->theta_enc = (double)NAN;
    if (cfg->send_encoder && c->smp.enc_valid) {
        /* the plant's encoder (theta_e, unless an encoder fault holds or drops it); the 16-bit
         * angle wraps at 2 pi (docs/protocol.md 3) */
        theta_max = TWO_PI - 0.5 * cfg->sig_theta.scale;
        c->theta_enc = (c->smp.theta_enc_rad < theta_max) ? c->smp.theta_enc_rad : 0.0;
        if (encode_signal(&cfg->sig_theta, c->theta_enc, 0, &r) != 0) {
            e->end = ENGINE_END_PLANT;
            eng_set_message(e, "at cycle %ld: encoder angle %g rad is not finite", c->k,
                        c->smp.theta_enc_rad);
            return -1;
        }
        aux.theta_enc = (uint16_t)r;
        aux.flags = cfg->aux_flag_theta_valid;
    }
    c->have_dual = cfg->dual_sampling && c->smp.dual_valid;
    if (c->have_dual) {
        hil_sense_dual_t d;
        const double i2[3] = {c->smp.i2_a_a, c->smp.i2_b_a, c->smp.i2_c_a};
        aux.flags = (uint16_t)(aux.flags | cfg->aux_flag_dual_follows);
        for (k = 0; k < 3; ++k) {
            if (encode_signal(&cfg->sig_i2, i2[k], 1, &raw[k]) != 0) {
                e->end = ENGINE_END_PLANT;
                eng_set_message(e, "at cycle %ld (t = %.4f s): second current sample is not finite",
                            c->k, c->t_s);
                return -1;
            }
        }
        d.seq = c->seq;
        d.i_a2 = (int16_t)raw[0];
        d.i_b2 = (int16_t)raw[1];
        d.i_c2 = (int16_t)raw[2];
        (void)hil_sense_dual_pack(c->dual, &d, sizeof c->dual);
    }
    (void)hil_sense_aux_pack(c->aux, &aux, sizeof c->aux);
    {
        const double i1[3] = {c->smp.i_a_a, c->smp.i_b_a, c->smp.i_c_a};
        for (k = 0; k < 3; ++k) {
            if (encode_signal(&cfg->sig_i, i1[k], 1, &raw[k]) != 0) {
                e->end = ENGINE_END_PLANT;
                eng_set_message(e, "at cycle %ld (t = %.4f s): phase current sample is not finite "
                            "(plant state diverged)", c->k, c->t_s);
                return -1;
            }
            c->s_i[k] = (double)raw[k] * cfg->sig_i.scale;
        }
    }
    sense.seq = c->seq;
    sense.i_a = (int16_t)raw[0];
    sense.i_b = (int16_t)raw[1];
    sense.i_c = (int16_t)raw[2];
    (void)hil_sense_pack(c->sense, &sense, sizeof c->sense);
    return 0;
}

/** Validate DUTY(k): 1 applied, 0 held (bad duty, counted), -1 too many bad in a row. */
int eng_take_duties(engine_t *e, const cycle_t *c)
{
    double d[3];
    int k, bad = 0;
    for (k = 0; k < 3; ++k) {
        d[k] = eng_duty_of_raw(e, c->duty_raw[k]);
        if (isnan(d[k])) {
            bad = 1;
            d[k] = 0.0;
        }
    }
    if (bad) {
        char text[128];
        e->n.bad_duties++;
        e->consecutive_bad++;
        snprintf(text, sizeof text, "DUTY seq %u raw [%u, %u, %u] out of range; previous duties held",
                 (unsigned)c->seq, (unsigned)c->duty_raw[0], (unsigned)c->duty_raw[1],
                 (unsigned)c->duty_raw[2]);
        eng_record_event(e, c->t_s, "bad_duty", text, (double)c->seq);
        if (e->consecutive_bad >= e->cfg.max_consecutive_bad_duties) {
            e->end = ENGINE_END_BAD_DUTIES;
            eng_set_message(e, "at cycle %ld: %d consecutive DUTY frames out of range; inverter "
                        "disabled, run ended", c->k, e->consecutive_bad);
            return -1;
        }
        return 0;
    }
    e->consecutive_bad = 0;
    if (e->trip_cycle >= 0 && c->k >= e->trip_cycle && !(d[0] < 0.0 && d[1] < 0.0 && d[2] < 0.0)) {
        /* the controller declared a fault but drives the inverter: the plant sees it */
        if (e->n.duties_after_trip++ == 0u) {
            char text[128];
            snprintf(text, sizeof text, "DUTY seq %u [%.4f, %.4f, %.4f] after the controller's "
                     "FAULT_CTRL: not all legs off", (unsigned)c->seq, d[0], d[1], d[2]);
            eng_record_fault(e, (int32_t)c->seq, -1, "controller", "fault_ctrl", "",
                         "duty_after_trip", text, (double)c->k);
        }
    }
    e->duties[0] = d[0];
    e->duties[1] = d[1];
    e->duties[2] = d[2];
    return 1;
}

/** Rows of cycle k: state at t_k, what was sent, what came back, frames, state changes. */
void eng_record_cycle(engine_t *e, cycle_t *c)
{
    const engine_config_t *cfg = &e->cfg;
    const plant_snapshot_t *s = &c->snap;
    const double theta = s->theta_e_rad;
    if (!e->have_ring) {
        eng_text_reset(e->rx_text, &e->rx_len);
        if (c->have_telem && c->st >= 0) {
            e->last_state = c->st; /* a restart is told by it, recorded or not */
        }
        return;
    }
    if (!eng_record_full(e, c->k)) {
        goto state_change; /* decimated away: only what changed state is recorded */
    }
    e->n.state_rows++;
    {
        rec_plant_state_t r;
        r.t_s = c->t_s;
        r.i_a_a = s->i_a_a; r.i_b_a = s->i_b_a; r.i_c_a = s->i_c_a;
        r.i_alpha_a = s->i_alpha_a; r.i_beta_a = s->i_beta_a;
        r.i_d_a = s->i_d_a; r.i_q_a = s->i_q_a;
        r.omega_m_rad_s = s->omega_m_rad_s; r.omega_e_rad_s = s->omega_e_rad_s;
        r.theta_e_rad = s->theta_e_rad; r.theta_m_rad = s->theta_m_rad;
        r.torque_e_nm = s->torque_e_nm; r.torque_load_nm = s->torque_load_nm;
        r.e_alpha_v = s->e_alpha_v; r.e_beta_v = s->e_beta_v; r.v_dc_v = s->v_dc_v;
        r.v_a_v = s->v_a_v; r.v_b_v = s->v_b_v; r.v_c_v = s->v_c_v;
        r.v_alpha_v = s->v_alpha_v; r.v_beta_v = s->v_beta_v; r.v_d_v = s->v_d_v; r.v_q_v = s->v_q_v;
        r.speed_rpm = s->omega_m_rad_s * cfg->rpm_per_rad_s;
        RECORD(e, cfg->ch_state, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_plant_state, &r);
    }
    {
        rec_sense_t r;
        r.t_s = c->t_s;
        r.seq = c->seq;
        r.i_a_a = c->s_i[0]; r.i_b_a = c->s_i[1]; r.i_c_a = c->s_i[2];
        r.v_dc_v = c->smp.v_dc_v;
        r.theta_enc_rad = c->theta_enc;
        RECORD(e, cfg->ch_sense, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_sense, &r);
    }
    {
        rec_telemetry_t r;
        r.t_s = c->t_s;
        r.seq = c->seq;
        if (c->have_telem) {
            r.theta_hat_rad = c->th_hat;
            r.omega_hat_rad_s = c->w_hat;
            r.state = c->st;
            r.estimator = c->est;
        } else {
            r.theta_hat_rad = r.omega_hat_rad_s = (double)NAN;
            r.state = r.estimator = -1;
        }
        r.speed_hat_rpm = r.omega_hat_rad_s / (double)cfg->pole_pairs * cfg->rpm_per_rad_s;
        r.e_alpha_v = c->have_emf ? c->e_a : (double)NAN;
        r.e_beta_v = c->have_emf ? c->e_b : (double)NAN;
        r.i_q_ref_a = c->have_emf ? c->iq_ref : (double)NAN;
        r.duty_a = e->duties[0]; r.duty_b = e->duties[1]; r.duty_c = e->duties[2];
        r.pee_rad = wrap_pi(r.theta_hat_rad - theta);
        RECORD(e, cfg->ch_telem, c->t_s, REC_MAX_FIXED_SIZE, rec_encode_telemetry, &r);
    }
    if (cfg->record_frames) {
        rec_frames_t r;
        r.t_s = c->t_s;
        r.seq = (int32_t)c->seq;
        r.tx = e->tx_text;
        r.rx = e->rx_text;
        RECORD(e, cfg->ch_frames, c->t_s, 64u + e->tx_len + e->rx_len, rec_encode_frames, &r);
    }
state_change:
    eng_text_reset(e->rx_text, &e->rx_len);
    if (c->have_telem && c->st != e->last_state && c->st >= 0) {
        const char *name = (c->st < ENGINE_STATE_NAMES && cfg->state_names[c->st][0] != '\0')
                               ? cfg->state_names[c->st] : "?";
        eng_record_event(e, c->t_s, "controller_state", name, (double)c->st);
        e->last_state = c->st;
    }
}

/** Alpha-beta voltage an averaged inverter realises from duties (0 if a leg is off). */
int eng_duties_to_ab(const double d[3], double v_dc, double out[2])
{
    if (d[0] < 0.0 || d[1] < 0.0 || d[2] < 0.0) {
        return 0;
    }
    out[0] = (2.0 * d[0] - d[1] - d[2]) * (v_dc / 3.0);
    out[1] = (d[1] - d[2]) * (v_dc * (1.0 / sqrt(3.0)));
    return 1;
}

/**
 * Reference estimators of cycle k: the currents the controller was sent and the voltage that
 * acted over the last period (the older duties for the first w_split of it, then the newer).
 * Then remember the duties that act next (applied = the set in effect after this cycle).
 */
void eng_step_references(engine_t *e, const cycle_t *c, ref_voltage_t *v, int shift)
{
    const engine_config_t *cfg = &e->cfg;
    const double inv_sqrt3 = 1.0 / sqrt(3.0);
    int i;
    if (e->n_refs == 0 || !e->have_ring) {
        return; /* a reference's only output is its recorded rows: unrecorded, nobody reads it */
    }
    if (v->have_prev && v->have_older) {
        const double i_al = (2.0 * c->s_i[0] - c->s_i[1] - c->s_i[2]) * (1.0 / 3.0);
        const double i_be = (c->s_i[1] - c->s_i[2]) * inv_sqrt3;
        const double w = v->w_split;
        const double v_al = w * v->older[0] + (1.0 - w) * v->prev[0];
        const double v_be = w * v->older[1] + (1.0 - w) * v->prev[1];
        fw_vec2_t iv, vv;
        iv.x = (float)i_al;
        iv.y = (float)i_be;
        vv.x = (float)v_al;
        vv.y = (float)v_be;
        const int full = eng_record_full(e, c->k);
        for (i = 0; i < e->n_refs; ++i) {
            const est_output_t *o = eng_ref_step(&e->refs[i], iv, vv);
            rec_reference_t r;
            if (!full) {
                continue; /* the estimator steps every cycle; its row is decimated away */
            }
            r.t_s = c->t_s;
            r.seq = c->seq;
            r.theta_hat_rad = (double)o->theta_e_rad;
            r.omega_hat_rad_s = (double)o->omega_e_rad_s;
            r.speed_hat_rpm = r.omega_hat_rad_s / (double)cfg->pole_pairs * cfg->rpm_per_rad_s;
            r.e_alpha_v = (double)o->e_alpha_v;
            r.e_beta_v = (double)o->e_beta_v;
            r.pee_rad = wrap_pi(r.theta_hat_rad - c->snap.theta_e_rad);
            RECORD(e, e->ref_channel[i], c->t_s, REC_MAX_FIXED_SIZE, rec_encode_reference, &r);
        }
    }
    if (shift) {
        v->have_older = v->have_prev;
        v->older[0] = v->prev[0];
        v->older[1] = v->prev[1];
        v->have_prev = eng_duties_to_ab(e->duties, c->smp.v_dc_v, v->prev);
    }
}

void eng_begin_cycle(engine_t *e, cycle_t *c, long k)
{
    const hil_deframer_t *d = &e->link.deframer;
    memset(c, 0, sizeof *c);
    c->k = k;
    c->seq = (uint16_t)(k & 0xFFFF);
    e->late_state[c->seq & (ENGINE_LATE_WINDOW - 1)] = 0; /* this seq's earlier lap is over */
    c->t_s = (double)k * e->cfg.ts_s;
    e->cur_k = k;
    e->cur_t_s = c->t_s;
    c->st = c->est = -1;
    c->crc0 = d->crc_errors;
    c->cobs0 = d->cobs_errors;
    c->len0 = d->length_errors;
    c->over0 = d->overruns;
    c->hb0 = e->n.heartbeats_rx;
    e->cyc_drop = e->cyc_stall_drop = e->cyc_delay = e->cyc_restart = 0u;
    e->resets_at_cycle = e->n.ctrl_resets;
    eng_text_reset(e->tx_text, &e->tx_len);
    /* rx_text is not reset here: frames that arrive after a real-time period's rows were
     * written (late DUTY, heartbeats) belong in the next row's rx (eng_record_cycle resets it) */
}

void eng_after_telemetry(engine_t *e, const cycle_t *c)
{
    if (!c->have_telem || (e->cfg.telem_emf && !c->have_emf)) {
        e->n.telem_missing++; /* at most once a cycle: TELEM, or the TELEM_EMF HELLO asked for */
    }
    if (c->have_telem && e->cfg.estimator_expected >= 0 && c->est != e->cfg.estimator_expected) {
        e->n.estimator_mismatch++;
    }
}

int eng_plant_finite(engine_t *e, const cycle_t *c)
{
    const double w = e->plant->y[2];
    if (!isfinite(w) || !isfinite(e->plant->y[0]) || !isfinite(e->plant->y[1])) {
        e->end = ENGINE_END_PLANT;
        eng_set_message(e, "at cycle %ld: plant state became non-finite", c->k);
        return 0;
    }
    return 1;
}

void eng_fail_link(engine_t *e, const cycle_t *c)
{
    e->end = ENGINE_END_LINK;
    eng_set_message(e, "at cycle %ld (t = %.4f s): %s", c->k, c->t_s,
                e->link.error[0] ? e->link.error : "link failed");
}

/** A fault run: the controller tripped post_trip_cycles ago; its reaction is recorded, the run
 *  ends now. 1 (e->end set) or 0. */
int eng_trip_over(engine_t *e, const cycle_t *c)
{
    if (e->trip_cycle < 0 || c->k < e->trip_cycle + e->cfg.post_trip_cycles) {
        return 0;
    }
    e->end = ENGINE_END_CONTROLLER_FAULT;
    eng_set_message(e, "at cycle %ld (t = %.4f s): controller fault (its reaction recorded for %ld "
                "cycles after the FAULT_CTRL)", e->trip_cycle,
                (double)e->trip_cycle * e->cfg.ts_s, c->k - e->trip_cycle);
    return 1;
}
