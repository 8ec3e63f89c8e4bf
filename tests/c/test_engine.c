/**
 * @file test_engine.c
 * @brief The cycle engine in C alone: the recording ring, the protobuf row encoders, the link
 * layer, and closed loops between the engine and the firmware's own HIL session (the stub's
 * portable part) in a second thread over a socketpair -- lockstep and real time, a silent and a
 * noisy controller; and the same session in the engine's own thread (software in the loop,
 * engine_sil.h). Built and run under ASan + UBSan by `make sanitize` like every C test, so the
 * whole per-cycle path of both sides runs under the sanitizers.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "check.h"
#include "engine.h"
#include "engine_sil.h"
#include "hil_framing.h"
#include "hil_msgs.h"
#include "hil_session.h"

/* ---- the ring --------------------------------------------------------------------------------- */

static void test_ring(void)
{
    const size_t map = rec_ring_mapping_size(8192u);
    void *mem = calloc(1u, map);
    rec_ring_t w, r;
    uint8_t out[4096], payload[600];
    size_t i, got, total = 0u;
    unsigned next_read = 0u, written = 0u;
    CHECK(rec_ring_format(mem, map) == 0, "format");
    CHECK(rec_ring_attach(&w, mem, map) == 0 && rec_ring_attach(&r, mem, map) == 0, "attach");
    for (i = 0; i < sizeof payload; ++i) {
        payload[i] = (uint8_t)i;
    }
    /* write until full, read, repeat: records of varying size wrap around many times */
    for (i = 0; i < 2000u; ++i) {
        const size_t len = 1u + (i * 37u) % 500u;
        payload[0] = (uint8_t)written;
        if (rec_ring_write(&w, (uint16_t)(i % 7u), (int64_t)i, payload, len) == 0) {
            written++;
        } else {
            /* full: drain everything, checking order and content */
            do {
                size_t off = 0u;
                got = rec_ring_read(&r, out, sizeof out);
                while (off < got) {
                    rec_ring_record_t h;
                    memcpy(&h, out + off, sizeof h);
                    CHECK(out[off + 16u] == (uint8_t)next_read, "record %u in order", next_read);
                    CHECK(h.length >= 1u && h.length <= 500u && h.channel < 7u, "header sane");
                    next_read++;
                    off += 16u + ((h.length + 7u) & ~7u);
                    total++;
                }
            } while (got > 0u);
            CHECK(rec_ring_pending(&r) == 0u, "drained");
        }
    }
    CHECK(((rec_ring_header_t *)mem)->records_dropped > 0u, "full ring counted its drops");
    CHECK(total > 1000u, "%zu records through an 8 kB ring", total);
    CHECK(rec_ring_begin(&w, 5000u) == NULL, "a record larger than half the ring never fits");
    free(mem);
}

/* ---- the row encoders --------------------------------------------------------------------------- */

static void test_schema(void)
{
    rec_sense_t s;
    rec_frames_t f;
    uint8_t buf[256];
    size_t n;
    double d;
    const char *layout = rec_schema_layout();
    s.t_s = 0.25;
    s.seq = 7u;
    s.i_a_a = 1.5;
    s.i_b_a = -0.75;
    s.i_c_a = -0.75;
    s.v_dc_v = 310.0;
    s.theta_enc_rad = NAN;
    n = rec_encode_sense(buf, sizeof buf, &s);
    /* 6 doubles (1 + 8) and one fixed32 (1 + 4): one layout for every message */
    CHECK(n == 6u * 9u + 5u, "sense is %zu octets", n);
    CHECK(buf[0] == 0x09u && buf[9] == 0x15u && buf[10] == 7u, "tags: field 1 double, 2 fixed32");
    memcpy(&d, buf + 1, 8u);
    CHECK(memcmp(&d, &s.t_s, 8u) == 0, "t_s little-endian double");
    CHECK(rec_encode_sense(buf, 20u, &s) == 0u, "too small a buffer encodes nothing");
    f.t_s = 0.0;
    f.seq = -1;
    f.tx = "100#0100DC0512FD12FD";
    f.rx = NULL;
    n = rec_encode_frames(buf, sizeof buf, &f);
    CHECK(n == 9u + 5u + 2u + 20u + 2u, "frames %zu octets (empty rx is a zero-length string)", n);
    CHECK(strstr(layout, "SENSE hil.Sense F64:t_s U32:seq") == layout + strcspn(layout, "S") ||
              strstr(layout, "\nSENSE hil.Sense F64:t_s U32:seq F64:i_a_a") != NULL,
          "layout names the sense channel");
    CHECK(strstr(layout, "LINK_STATS hil.LinkStats F64:t_s CNT:cycles") != NULL, "stats layout");
}

/* ---- a controller in a thread: the firmware's session over one end of a socketpair ------------- */

typedef struct {
    int fd;
    hil_session_t session;
    long silent_from;    /* stop answering from this cycle (-1: never) */
    long noisy_from;     /* from this cycle, line noise before every answer (-1: never) */
    long late_at;        /* the answer to this cycle's SENSE 300 ms late (-1: never) */
    long lose_sense_at;  /* this cycle's first SENSE never reaches the session (-1: never) */
    int late_done, lost_done;
    hil_octet_t tx[4096];
    size_t tx_len;
    int setup;           /* 1 while the test configures it: answers go nowhere */
} ctrl_thread_t;

static void ctrl_send(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    ctrl_thread_t *c = (ctrl_thread_t *)ctx;
    if (c->setup) {
        return;
    }
    c->tx_len += hil_frame_encode(c->tx + c->tx_len, sizeof c->tx - c->tx_len, id, data, dlc);
}

static void ctrl_frame(ctrl_thread_t *c, uint16_t id, const hil_octet_t *data)
{
    hil_frame_t f;
    f.id = id;
    f.dlc = 8u;
    memcpy(f.data, data, 8u);
    hil_session_on_frame(&c->session, &f);
}

typedef void (*frame_sink_t)(void *ctx, uint16_t id, const hil_octet_t *data);

/* The bench's set-up of a run (HELLO, CONFIG, SET_SPEED_REF, RUN), frame by frame into sink. */
static void setup_frames(frame_sink_t sink, void *ctx, uint16_t mode)
{
    static const struct { unsigned id; float v; } params[] = {
        {HIL_PARAM_RS_OHM, 0.6383f}, {HIL_PARAM_LD_H, 2e-3f}, {HIL_PARAM_LQ_H, 2e-3f},
        {HIL_PARAM_PSI_F_WB, 0.085f}, {HIL_PARAM_POLE_PAIRS, 4.0f}, {HIL_PARAM_J_KGM2, 0.013f},
        {HIL_PARAM_B_NMS, 0.0035f}, {HIL_PARAM_V_DC_NOM_V, 310.0f}, {HIL_PARAM_IQ_MAX_A, 6.0f},
        {HIL_PARAM_ALIGN_I_A, 3.0f}, {HIL_PARAM_ALIGN_TIME_S, 0.05f}, {HIL_PARAM_IF_I_A, 3.0f},
        {HIL_PARAM_IF_ACCEL_RAD_S2, 200.0f}, {HIL_PARAM_HANDOVER_SPEED_RAD_S, 20.0f},
        {HIL_PARAM_CTRL_DELAY_S, 34.1e-6f}, {HIL_PARAM_SMO_K_V, 25.0f},
        {HIL_PARAM_SMO_WC_RAD_S, 300.0f}};
    hil_octet_t buf[8];
    hil_hello_t h;
    hil_cmd_t cmd;
    size_t i;
    h.proto_version = (uint16_t)HIL_PROTO_VERSION;
    h.proto_minor = (uint16_t)HIL_PROTO_VERSION_MINOR;
    h.mode = mode;
    h.period_us = hil_hello_period_us_encode(100.0f);
    h.estimator = (uint16_t)HIL_EST_SMO_SIGN;
    h.flags = 0u;
    h.session = 0x1234u;
    (void)hil_hello_pack(buf, &h, sizeof buf);
    sink(ctx, HIL_HELLO_FRAME_ID, buf);
    for (i = 0u; i < sizeof params / sizeof params[0]; ++i) {
        hil_config_t cf;
        cf.param_id = (uint16_t)params[i].id;
        cf.config_seq = (uint16_t)(i + 1u);
        cf.value = params[i].v;
        (void)hil_config_pack(buf, &cf, sizeof buf);
        sink(ctx, HIL_CONFIG_FRAME_ID, buf);
    }
    cmd.command = (uint16_t)HIL_CMD_SET_SPEED_REF;
    cmd.seq = 1u;
    cmd.value = 300.0f / 9.5492966f;
    (void)hil_cmd_pack(buf, &cmd, sizeof buf);
    sink(ctx, HIL_CMD_FRAME_ID, buf);
    cmd.command = (uint16_t)HIL_CMD_RUN;
    cmd.seq = 2u;
    (void)hil_cmd_pack(buf, &cmd, sizeof buf);
    sink(ctx, HIL_CMD_FRAME_ID, buf);
}

static void ctrl_sink(void *ctx, uint16_t id, const hil_octet_t *data)
{
    ctrl_frame((ctrl_thread_t *)ctx, id, data);
}

static void ctrl_configure(ctrl_thread_t *c, uint16_t mode)
{
    hil_port_t port;
    port.ctx = c;
    port.send = ctrl_send;
    hil_session_init(&c->session, &port);
    c->setup = 1;
    setup_frames(ctrl_sink, c, mode);
    c->setup = 0;
}

static void *ctrl_main(void *arg)
{
    ctrl_thread_t *c = (ctrl_thread_t *)arg;
    hil_deframer_t d;
    uint8_t buf[4096];
    hil_deframer_init(&d);
    for (;;) {
        ssize_t n = read(c->fd, buf, sizeof buf), i;
        if (n <= 0) {
            break; /* the engine closed its end */
        }
        for (i = 0; i < n; ++i) {
            hil_frame_t f;
            if (hil_deframer_push(&d, buf[i], &f) == 1) {
                const long cycle = (long)c->session.stats.cycles;
                if (f.id == HIL_SENSE_FRAME_ID && c->noisy_from >= 0 && cycle >= c->noisy_from) {
                    static const uint8_t noise[] = {0x13u, 0x37u, 0xFFu, 0x02u, 0x00u};
                    memcpy(c->tx + c->tx_len, noise, sizeof noise);
                    c->tx_len += sizeof noise;
                }
                if (f.id == HIL_SENSE_FRAME_ID && c->silent_from >= 0 && cycle >= c->silent_from) {
                    continue;
                }
                if (f.id == HIL_SENSE_FRAME_ID && cycle == c->lose_sense_at && !c->lost_done) {
                    c->lost_done = 1;   /* lost on the way: the host's re-send recovers it */
                    continue;
                }
                if (f.id == HIL_SENSE_FRAME_ID && cycle == c->late_at && !c->late_done) {
                    const struct timespec late = {0, 300000000L};
                    c->late_done = 1;   /* a controller stalled 300 ms: the host must wait */
                    nanosleep(&late, NULL);
                }
                hil_session_on_frame(&c->session, &f);
            }
        }
        if (c->tx_len > 0u) {
            size_t off = 0u;
            while (off < c->tx_len) {
                ssize_t w = write(c->fd, c->tx + off, c->tx_len - off);
                if (w <= 0) {
                    return NULL;
                }
                off += (size_t)w;
            }
            c->tx_len = 0u;
        }
    }
    return NULL;
}

static void wire_constants(engine_config_t *cfg)
{
    /* protocol/hil.dbc (the Python side fills these from the DBC itself: plant_rt/engine.py) */
    const engine_signal_t i = {0.001, 0.0, -32768.0, 32767.0};
    const engine_signal_t vdc = {0.01, 0.0, 0.0, 65535.0};
    const engine_signal_t th = {6.283185307179586 / 65536.0, 0.0, 0.0, 65535.0};
    cfg->sig_i = i;
    cfg->sig_i2 = i;
    cfg->sig_vdc = vdc;
    cfg->sig_theta = th;
    cfg->scale_theta_hat = th.scale;
    cfg->scale_omega_hat = 0.1;
    cfg->scale_e = 0.01;
    cfg->scale_iq_ref = 0.001;
    cfg->duty_raw_full = 32768u;
    cfg->duty_raw_off = 65535u;
    cfg->aux_flag_theta_valid = 1u;
    cfg->aux_flag_dual_follows = 2u;
    strcpy(cfg->state_names[3], "CLOSED_LOOP");
}

static void plant_params(plant_params_t *p)
{
    memset(p, 0, sizeof *p);
    p->rs_ohm = 0.6383;
    p->ld_h = p->lq_h = 2e-3;
    p->psi_f_wb = 0.085;
    p->pole_pairs = 4;
    p->j_kgm2 = 0.013;
    p->b_nms = 0.0035;
    p->v_dc_v = 310.0;
    p->ts_s = 1e-4;
    p->t_delay_s = 34.1e-6;
    p->substeps = 4;
}

typedef struct {
    int end;
    long cycles;
    double speed_rpm;
    engine_counters_t n;
    uint64_t records;
    char message[ENGINE_MESSAGE];
} loop_result_t;

static void loop_config(engine_config_t *cfg, int mode, long n_cycles, const plant_params_t *pp)
{
    engine_default_config(cfg);
    wire_constants(cfg);
    cfg->mode = mode;
    cfg->n_cycles = n_cycles;
    cfg->ts_s = pp->ts_s;
    cfg->t_delay_s = pp->t_delay_s;
    cfg->pole_pairs = 4;
    cfg->estimator_expected = HIL_EST_SMO_SIGN;
    cfg->link_kind = ENG_LINK_SERIAL;
    cfg->rt_priority = 0;
    cfg->rt_mlock = 0;
    cfg->max_consecutive_misses = 100000;
    cfg->ch_state = 0;
    cfg->ch_sense = 1;
    cfg->ch_telem = 2;
    cfg->ch_frames = 3;
    cfg->ch_events = 4;
    cfg->ch_timing = 5;
    cfg->ch_stats = 6;
}

static loop_result_t closed_loop_ex(int mode, long n_cycles, long silent_from, long noisy_from,
                                    long late_at, long lose_sense_at, double patience_s)
{
    static plant_t plant;
    static engine_t eng;
    plant_params_t pp;
    engine_config_t cfg;
    ctrl_thread_t *ctrl = (ctrl_thread_t *)calloc(1u, sizeof *ctrl);
    int sv[2];
    pthread_t th;
    const size_t map = rec_ring_mapping_size(8u << 20);
    void *ring = calloc(1u, map);
    rec_ring_t reader;
    uint8_t *drain = (uint8_t *)malloc(1u << 20);
    loop_result_t res;
    memset(&res, 0, sizeof res);
    CHECK(socketpair(AF_UNIX, SOCK_STREAM, 0, sv) == 0, "socketpair");
    plant_params(&pp);
    CHECK(plant_init(&plant, &pp) == 0, "plant");
    ctrl->fd = sv[1];
    ctrl->silent_from = silent_from;
    ctrl->noisy_from = noisy_from;
    ctrl->late_at = late_at;
    ctrl->lose_sense_at = lose_sense_at;
    ctrl_configure(ctrl, (uint16_t)mode);
    CHECK(ctrl->session.ctrl.state != CTRL_STATE_IDLE, "the controller runs");
    pthread_create(&th, NULL, ctrl_main, ctrl);
    loop_config(&cfg, mode, n_cycles, &pp);
    cfg.link_fd = sv[0];
    if (patience_s > 0.0) {
        cfg.patience_s = patience_s;
    }
    CHECK(rec_ring_format(ring, map) == 0, "ring");
    CHECK(engine_init(&eng, &cfg, &plant, ring, map) == 0, "engine_init: %s", eng.message);
    res.end = engine_run(&eng);
    res.cycles = eng.cycles_done;
    res.speed_rpm = plant.y[2] * 60.0 / 6.283185307179586;
    res.n = eng.n;
    memcpy(res.message, eng.message, sizeof res.message);
    CHECK(rec_ring_attach(&reader, ring, map) == 0, "reader");
    {
        size_t got;
        while ((got = rec_ring_read(&reader, drain, 1u << 20)) > 0u) {
            size_t off = 0u;
            while (off < got) {
                rec_ring_record_t h;
                memcpy(&h, drain + off, sizeof h);
                off += 16u + ((h.length + 7u) & ~7u);
                res.records++;
            }
        }
    }
    close(sv[0]);
    pthread_join(th, NULL);
    close(sv[1]);
    free(ctrl);
    free(ring);
    free(drain);
    return res;
}

static loop_result_t closed_loop(int mode, long n_cycles, long silent_from, long noisy_from)
{
    /* a silent controller is found after its patience: half a second here (the default, 10 s, is
     * what a run against a live controller gets; this is a test of the silence itself) */
    return closed_loop_ex(mode, n_cycles, silent_from, noisy_from, -1, -1, 0.5);
}

static void test_lockstep_closed_loop(void)
{
    loop_result_t r = closed_loop(ENGINE_LOCKSTEP, 5000, -1, -1);
    CHECK(r.end == ENGINE_END_DONE, "end %d: %s", r.end, r.message);
    CHECK(r.cycles == 5000, "cycles %ld", r.cycles);
    CHECK(r.speed_rpm > 100.0, "the rotor turns under the stub's control: %.1f rpm", r.speed_rpm);
    CHECK(r.n.telem_missing == 0u && r.n.seq_mismatch == 0u && r.n.retries == 0u &&
              r.n.estimator_mismatch == 0u && r.n.bad_duties == 0u,
          "a clean run counts nothing");
    /* state, sense, telemetry, frames, timing every cycle; stats every 1000 */
    CHECK(r.records >= 5u * 5000u + 5u, "%llu records", (unsigned long long)r.records);
}

static void test_silent_controller_is_named(void)
{
    loop_result_t r = closed_loop(ENGINE_LOCKSTEP, 2000, 300, -1);
    CHECK(r.end == ENGINE_END_NO_DUTY, "end %d", r.end);
    CHECK(r.cycles == 300, "cycles %ld", r.cycles);
    CHECK(r.n.retries == 3u, "the SENSE of cycle 300 re-sent at 0.05, 0.15, 0.35 s within the "
          "0.5 s patience: %llu", (unsigned long long)r.n.retries);
    CHECK(strstr(r.message, "no DUTY(300) 0.5 s (patience_s) after its SENSE and 3 re-sends: "
                            "nothing at all (the controller is silent)") != NULL,
          "%s", r.message);
}

static void test_late_is_not_lost(void)
{
    /* docs/protocol.md 6.5: a controller that answers cycle 300 300 ms late, intact, is waited
     * for (the default patience): the run completes with the same trajectory as a prompt one;
     * the cycle counts as late (every SENSE group sent for it answered: the original and the
     * re-sends at 50 and 150 ms, from the cache), never lost, never a duplicate */
    loop_result_t a = closed_loop_ex(ENGINE_LOCKSTEP, 1000, -1, -1, -1, -1, 0.0);
    loop_result_t r = closed_loop_ex(ENGINE_LOCKSTEP, 1000, -1, -1, 300, -1, 0.0);
    CHECK(r.end == ENGINE_END_DONE && r.cycles == 1000, "end %d after %ld: %s", r.end, r.cycles,
          r.message);
    CHECK(r.n.retries == 2u && r.n.late_answers == 1u && r.n.resend_answers == 2u,
          "2 re-sends, 1 late cycle, 2 answers to re-sends: %llu, %llu, %llu",
          (unsigned long long)r.n.retries, (unsigned long long)r.n.late_answers,
          (unsigned long long)r.n.resend_answers);
    CHECK(r.n.lost_frames == 0u && r.n.duplicates == 0u && r.n.seq_mismatch == 0u &&
              r.n.stale_frames == 0u, "nothing lost, nothing duplicated");
    CHECK(memcmp(&a.speed_rpm, &r.speed_rpm, sizeof a.speed_rpm) == 0,
          "late is not different: %.17g vs %.17g rpm", a.speed_rpm, r.speed_rpm);
}

static void test_a_lost_sense_is_lost(void)
{
    /* the first SENSE of cycle 300 never reaches the controller: the re-send recovers the cycle
     * and its answer is the only one (it completes the cycle; no second DUTY follows): one lost
     * frame, a link problem (6.9) */
    loop_result_t r = closed_loop_ex(ENGINE_LOCKSTEP, 1000, -1, -1, -1, 300, 0.0);
    CHECK(r.end == ENGINE_END_DONE && r.cycles == 1000, "end %d: %s", r.end, r.message);
    CHECK(r.n.retries == 1u && r.n.lost_frames == 1u && r.n.late_answers == 0u &&
              r.n.resend_answers == 0u && r.n.duplicates == 0u,
          "retries %llu, lost %llu, late %llu, resend answers %llu, duplicates %llu",
          (unsigned long long)r.n.retries, (unsigned long long)r.n.lost_frames,
          (unsigned long long)r.n.late_answers, (unsigned long long)r.n.resend_answers,
          (unsigned long long)r.n.duplicates);
}

static void test_what_arrived_instead_is_named(void)
{
    /* line noise answers the SENSE of cycle 300 and its 3 re-sends, and no DUTY comes */
    loop_result_t r = closed_loop(ENGINE_LOCKSTEP, 2000, 300, 290);
    CHECK(r.end == ENGINE_END_NO_DUTY, "end %d", r.end);
    CHECK(strstr(r.message, "after its SENSE and 3 re-sends: 4 chunks that are not valid COBS")
              != NULL, "%s", r.message);
}

static void test_line_noise_is_counted_and_survived(void)
{
    loop_result_t r = closed_loop(ENGINE_LOCKSTEP, 1000, -1, 500);
    CHECK(r.end == ENGINE_END_DONE, "end %d: %s", r.end, r.message);
    CHECK(r.cycles == 1000, "cycles %ld", r.cycles);
}

static void test_realtime_closed_loop(void)
{
    /* the engine on the wall clock at 10 kHz with the session answering in a thread: asserts
     * the loop, not the timing (a loaded machine may miss deadlines; they are counted) */
    loop_result_t r = closed_loop(ENGINE_REALTIME, 3000, -1, -1);
    const double lost = (double)(r.n.missed_duty + r.n.rt_overruns) / (double)(r.cycles ? r.cycles : 1);
    if (r.end != ENGINE_END_DONE && (lost > 0.01 || strstr(r.message, "clock jumped") != NULL)) {
        /* as tests/test_realtime.py: a run the machine could not keep in real time says nothing
         * about the loop (the benchmark measures the machine: python -m hil_bench.perf.loop) */
        printf("test_realtime_closed_loop: skipped: this machine could not keep real time "
               "(%.1f %% of %ld periods lost: %llu missed, %llu overruns): %s\n", 100.0 * lost,
               r.cycles, (unsigned long long)r.n.missed_duty,
               (unsigned long long)r.n.rt_overruns, r.message);
        return;
    }
    CHECK(r.end == ENGINE_END_DONE, "end %d: %s", r.end, r.message);
    CHECK(r.cycles == 3000, "cycles %ld", r.cycles);
    CHECK(r.speed_rpm > 20.0, "the rotor turns: %.1f rpm", r.speed_rpm);
}

/* ---- software in the loop: the same session called from the engine's thread (engine_sil.h) --- */

static void sil_sink(void *ctx, uint16_t id, const hil_octet_t *data)
{
    hil_octet_t wire[HIL_FRAME_MAX_WIRE];
    const size_t n = hil_frame_encode(wire, sizeof wire, id, data, 8u);
    sil_port_write((sil_port_t *)ctx, wire, n, eng_now_ns());
}

static loop_result_t sil_loop(int mode, long n_cycles, long reset_at)
{
    static plant_t plant;
    static engine_t eng;
    static sil_port_t sil;
    plant_params_t pp;
    engine_config_t cfg;
    loop_result_t res;
    hil_octet_t answers[4096];
    size_t n, i;
    int acks = 0;
    hil_deframer_t d;
    memset(&res, 0, sizeof res);
    plant_params(&pp);
    CHECK(plant_init(&plant, &pp) == 0, "plant");
    /* the set-up through the serial framing, as the bench's Python does before the run */
    sil_port_init(&sil, 0, eng_now_ns());
    setup_frames(sil_sink, &sil, (uint16_t)mode);
    n = sil_port_read(&sil, answers, sizeof answers, eng_now_ns());
    hil_deframer_init(&d);
    for (i = 0u; i < n; ++i) {
        hil_frame_t f;
        if (hil_deframer_push(&d, answers[i], &f) == 1 &&
            (f.id == HIL_HELLO_ACK_FRAME_ID || f.id == HIL_CONFIG_ACK_FRAME_ID)) {
            acks++;
        }
    }
    CHECK(acks == 18, "HELLO_ACK and 17 CONFIG_ACK come back framed: %d", acks);
    CHECK(sil.session.ctrl.state != CTRL_STATE_IDLE, "the in-process controller runs");
    loop_config(&cfg, mode, n_cycles, &pp);
    engine_sil_peer(&sil, &cfg.link_peer);
    CHECK(engine_init(&eng, &cfg, &plant, NULL, 0u) == 0, "engine_init: %s", eng.message);
    if (reset_at >= 0) {
        engine_event_t ev;
        memset(&ev, 0, sizeof ev);
        ev.cycle = reset_at;
        ev.kind = ENGINE_EV_CONTROLLER_RESET;
        ev.command = 0; /* no process: the in-process controller's restart */
        strcpy(ev.fault_name, "controller_reset");
        ev.detect_within_s = 0.2;
        CHECK(engine_add_event(&eng, &ev) == 0, "reset event: %s", eng.message);
    }
    res.end = engine_run(&eng);
    res.cycles = eng.cycles_done;
    res.speed_rpm = plant.y[2] * 60.0 / 6.283185307179586;
    res.n = eng.n;
    memcpy(res.message, eng.message, sizeof res.message);
    CHECK(mode != ENGINE_LOCKSTEP ||
              sil.session.stats.cycles == (uint32_t)(reset_at >= 0 ? 0 : n_cycles),
          "the firmware ran the cycles: %lu", (unsigned long)sil.session.stats.cycles);
    return res;
}

static void test_sil_closed_loop_is_the_threaded_one(void)
{
    /* the same firmware behind a socketpair in a thread, and in the engine's thread: the same
     * plant trajectory to the bit (both lockstep; the timing of the exchange does not matter) */
    loop_result_t a = closed_loop(ENGINE_LOCKSTEP, 3000, -1, -1);
    loop_result_t b = sil_loop(ENGINE_LOCKSTEP, 3000, -1);
    CHECK(b.end == ENGINE_END_DONE, "end %d: %s", b.end, b.message);
    CHECK(b.cycles == 3000 && b.n.retries == 0u && b.n.seq_mismatch == 0u &&
              b.n.telem_missing == 0u, "a clean run");
    CHECK(memcmp(&a.speed_rpm, &b.speed_rpm, sizeof a.speed_rpm) == 0,
          "same speed to the bit: %.17g vs %.17g rpm", a.speed_rpm, b.speed_rpm);
    CHECK(b.speed_rpm > 100.0, "the rotor turns: %.1f rpm", b.speed_rpm);
}

static void test_sil_restart_at_its_cycle(void)
{
    /* the power cycle happens before the SENSE of cycle 1000: no session, no answer, the run
     * ends there naming silence, and the heartbeat with its counter from 0 is seen */
    loop_result_t r = sil_loop(ENGINE_LOCKSTEP, 3000, 1000);
    CHECK(r.end == ENGINE_END_NO_DUTY, "end %d: %s", r.end, r.message);
    CHECK(r.cycles == 1000, "cycles %ld", r.cycles);
    CHECK(r.n.ctrl_resets == 1u, "restart counted: %llu (heartbeats %llu)", (unsigned long long)r.n.ctrl_resets, (unsigned long long)r.n.heartbeats_rx);
}

static void test_sil_realtime(void)
{
    loop_result_t r = sil_loop(ENGINE_REALTIME, 2000, -1);
    const double lost = (double)(r.n.missed_duty + r.n.rt_overruns) / (double)(r.cycles ? r.cycles : 1);
    if (r.end != ENGINE_END_DONE || lost > 0.01) {
        /* the controller answers within the engine's cycle: what is lost here is the machine's
         * (periods the engine itself was descheduled through), not the loop's */
        printf("test_sil_realtime: skipped: this machine could not keep real time (%.1f %% of "
               "%ld periods lost): %s\n", 100.0 * lost, r.cycles, r.message);
        return;
    }
    CHECK(r.cycles == 2000 && r.speed_rpm > 20.0, "the rotor turns: %.1f rpm", r.speed_rpm);
}

/* ---- a script's session (live.h): the run held before named cycles, inputs at them ----------- */

typedef struct {
    engine_t *e;
    int end;
} engine_thread_t;

static void *engine_main(void *arg)
{
    engine_thread_t *t = (engine_thread_t *)arg;
    t->end = engine_run(t->e);
    return NULL;
}

/** Wait (at most ~60 s of wall time: a hang fails, it does not block the suite) until the run
 *  holds before cycle k; 1 if it does. */
static int wait_held(live_inbox_t *b, int64_t k)
{
    int i;
    for (i = 0; i < 60000; ++i) {
        int64_t held;
        const uint32_t w = live_inbox_news(b, &held, NULL, NULL);
        if (held == k) {
            return 1;
        }
        (void)live_inbox_wait(b, LIVE_WORD_NEWS, w, 1000000LL);
    }
    return 0;
}

static int wait_answered(live_inbox_t *b, uint64_t n)
{
    int i;
    for (i = 0; i < 60000; ++i) {
        uint64_t answered;
        const uint32_t w = live_inbox_news(b, NULL, &answered, NULL);
        if (answered >= n) {
            return 1;
        }
        (void)live_inbox_wait(b, LIVE_WORD_NEWS, w, 1000000LL);
    }
    return 0;
}

#define SCRIPT_CYCLES 3000L
#define SCRIPT_STEP_AT 1200L

/**
 * The firmware in the engine's thread (SIL), 3000 cycles; at cycle 0 a speed reference and at
 * cycle SCRIPT_STEP_AT a load torque: scheduled as engine events (scripted = 0), or pushed by a
 * script while the run holds before those cycles (scripted = 1). Returns the plant's final state.
 */
static loop_result_t sil_script_loop(int scripted, double y_out[4], uint64_t *refused,
                                     char *refusal, size_t refusal_cap)
{
    static plant_t plant;
    static engine_t eng;
    static sil_port_t sil;
    plant_params_t pp;
    engine_config_t cfg;
    loop_result_t res;
    hil_octet_t answers[4096];
    void *box_mem = calloc(1u, live_inbox_size());
    live_inbox_t *box;
    engine_thread_t th;
    pthread_t tid;
    const double speed_rad_s = 400.0 / 9.5492966;
    const double load_nm = 0.2;
    memset(&res, 0, sizeof res);
    plant_params(&pp);
    CHECK(plant_init(&plant, &pp) == 0, "plant");
    sil_port_init(&sil, 0, eng_now_ns());
    setup_frames(sil_sink, &sil, (uint16_t)ENGINE_LOCKSTEP);
    (void)sil_port_read(&sil, answers, sizeof answers, eng_now_ns());
    loop_config(&cfg, ENGINE_LOCKSTEP, SCRIPT_CYCLES, &pp);
    cfg.cmd_seq_start = 3u;
    engine_sil_peer(&sil, &cfg.link_peer);
    CHECK(engine_init(&eng, &cfg, &plant, NULL, 0u) == 0, "engine_init: %s", eng.message);
    CHECK(live_inbox_format(box_mem, live_inbox_size()) == 0, "mailbox");
    box = live_inbox_attach(box_mem, live_inbox_size());
    CHECK(engine_attach_inbox(&eng, box_mem, live_inbox_size()) == 0, "attach: %s", eng.message);
    if (!scripted) {
        engine_event_t ev;
        memset(&ev, 0, sizeof ev);
        ev.cycle = 0;
        ev.kind = ENGINE_EV_CMD;
        ev.command = (int)HIL_CMD_SET_SPEED_REF;
        ev.value = speed_rad_s;
        CHECK(engine_add_event(&eng, &ev) == 0, "event: %s", eng.message);
        ev.cycle = SCRIPT_STEP_AT;
        ev.kind = ENGINE_EV_LOAD;
        ev.command = 0;
        ev.value = load_nm;
        CHECK(engine_add_event(&eng, &ev) == 0, "event: %s", eng.message);
        res.end = engine_run(&eng);
    } else {
        const int32_t bad_fault[4] = {99, 0, 0, 0};
        uint64_t pushed = 0u;
        /* held before cycle 0 (taken as the run starts), then the script's inputs there */
        CHECK(live_inbox_push_input(box, LIVE_IN_HOLD_AT, LIVE_FROM_SCRIPT, 0.0, NULL, "hold") == 0,
              "push");
        pushed++;
        th.e = &eng;
        th.end = -1;
        pthread_create(&tid, NULL, engine_main, &th);
        CHECK(wait_held(box, 0), "the run holds before cycle 0");
        CHECK(eng.cycles_done == 0, "nothing ran: %ld", eng.cycles_done);
        CHECK(live_inbox_push_input(box, LIVE_IN_SPEED_REF, LIVE_FROM_SCRIPT, speed_rad_s, NULL,
                                    "script: speed reference 400 rpm") == 0, "push");
        pushed++;
        CHECK(live_inbox_push_input(box, LIVE_IN_FAULT_ON, LIVE_FROM_SCRIPT, 0.0, bad_fault,
                                    "script: fault 99") == 0, "push");
        pushed++;
        CHECK(wait_answered(box, pushed), "both answered while held");
        CHECK(eng.cycles_done == 0, "still held: %ld", eng.cycles_done);
        CHECK(live_inbox_push_input(box, LIVE_IN_HOLD_AT, LIVE_FROM_SCRIPT,
                                    (double)SCRIPT_STEP_AT, NULL, "hold") == 0, "push");
        pushed++;
        CHECK(wait_held(box, SCRIPT_STEP_AT), "the run holds before cycle %ld", SCRIPT_STEP_AT);
        CHECK(eng.cycles_done == SCRIPT_STEP_AT, "ran to the hold: %ld", eng.cycles_done);
        CHECK(live_inbox_push_input(box, LIVE_IN_LOAD, LIVE_FROM_SCRIPT, load_nm, NULL,
                                    "script: load") == 0, "push");
        pushed++;
        CHECK(live_inbox_push_input(box, LIVE_IN_HOLD_AT, LIVE_FROM_SCRIPT, -1.0, NULL,
                                    "hold no more") == 0, "push");
        pushed++;
        pthread_join(tid, NULL);
        res.end = th.end;
        CHECK(wait_answered(box, pushed), "every input answered");
        (void)live_inbox_news(box, NULL, NULL, refused);
        snprintf(refusal, refusal_cap, "%s", box->refused_text);
    }
    res.cycles = eng.cycles_done;
    res.n = eng.n;
    memcpy(res.message, eng.message, sizeof res.message);
    memcpy(y_out, plant.y, 4u * sizeof y_out[0]);
    free(box_mem);
    return res;
}

static void test_sil_script_holds_and_steers(void)
{
    /* inputs a script pushes while the run holds act exactly as the same changes scheduled as
     * events at those cycles: the same plant state to the bit, whatever the holds lasted */
    double ya[4], yb[4];
    uint64_t refused = 0u;
    char refusal[LIVE_REFUSED_TEXT];
    loop_result_t a = sil_script_loop(0, ya, &refused, refusal, sizeof refusal);
    loop_result_t b = sil_script_loop(1, yb, &refused, refusal, sizeof refusal);
    CHECK(a.end == ENGINE_END_DONE && a.cycles == SCRIPT_CYCLES, "events: end %d: %s", a.end,
          a.message);
    CHECK(b.end == ENGINE_END_DONE && b.cycles == SCRIPT_CYCLES, "script: end %d: %s", b.end,
          b.message);
    CHECK(memcmp(ya, yb, sizeof ya) == 0, "same plant state to the bit: speed %.17g vs %.17g",
          ya[2], yb[2]);
    CHECK(ya[2] * 60.0 / 6.283185307179586 > 100.0, "the rotor turns: %.1f rpm",
          ya[2] * 60.0 / 6.283185307179586);
    CHECK(refused == 1u && strstr(refusal, "script: fault 99: refused:") == refusal,
          "the plant refused the unknown fault, and said so: %llu, %s",
          (unsigned long long)refused, refusal);
    CHECK(b.n.operator_inputs == 0u && b.n.operator_refused == 0u,
          "a script's inputs are not an operator's");
}

int main(void)
{
    /* the controller thread may answer after a run ended and the engine closed its end of the
     * socket: its write then fails with EPIPE (it stops), not with a SIGPIPE that kills the test
     * (seen under load, when the real-time run ends early) */
    signal(SIGPIPE, SIG_IGN);
    test_ring();
    test_schema();
    test_lockstep_closed_loop();
    test_silent_controller_is_named();
    test_what_arrived_instead_is_named();
    test_late_is_not_lost();
    test_a_lost_sense_is_lost();
    test_line_noise_is_counted_and_survived();
    test_realtime_closed_loop();
    test_sil_closed_loop_is_the_threaded_one();
    test_sil_restart_at_its_cycle();
    test_sil_realtime();
    test_sil_script_holds_and_steers();
    return check_summary("engine");
}
