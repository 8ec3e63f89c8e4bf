"""cffi API-mode builder for the C plant: module ``hil_bench.plant_rt._plant_c``.

CMake compiles ``ffibuilder`` (cmake/cffi_modules.cmake through cmake/cffi_emit.py): into the
wheel, or for development (``make build``) into build/ and next to this file.
``make_builder(sanitize=True)`` is the same module built with AddressSanitizer +
UndefinedBehaviorSanitizer (``make sanitize``: build-asan/, imported from build-asan/python/,
never next to this file). The cdef below mirrors ``plant_rt/c/plant.h`` (and the
parts' headers for their stand-alone functions); the structs are declared field by field, so cffi checks their layout against the real header
when it compiles the module (a field added to the header without updating this file fails
the build).
"""
from __future__ import annotations

from pathlib import Path

from cffi import FFI

C_DIR = Path(__file__).resolve().parent / "c"
SOURCES = ("pmsm_machine.c", "inverter.c", "pwm.c", "mechanics.c", "sensor.c", "plant.c", "plant_fault.c",
           # the cycle engine and the recording ring / schema (engine.h, rec_ring.h, rec_schema.h)
           "engine.c", "engine_cycle.c", "engine_rx.c", "engine_lockstep.c", "engine_realtime.c",
           "engine_replay.c", "engine_inputs.c", "engine_io.c", "engine_trace.c", "engine_record.c",
           "engine_faults.c", "engine_link.c", "engine_refs.c", "engine_sil.c", "live.c",
           "rec_ring.c", "rec_schema.c", "rec_mcap.c")
ROOT = C_DIR.parents[1]
FW_SRC = ROOT / "firmware_stub" / "src"
PROTOCOL_C = ROOT / "protocol" / "c"
SIL_PORT = ROOT / "firmware_stub" / "port" / "sil"   # software in the loop (--link sil)

CDEF = """
#define MECH_LOAD_TABLE_MAX 32

typedef struct plant_inverter_params {
    int inverter_nonlinear;
    double dead_time_s, v_switch_drop_v, r_switch_ohm, v_diode_drop_v, r_diode_ohm, i_cap_band_a;
    int inverter;
    int carrier_at_start;
    int pwm_load;
} plant_inverter_params_t;

typedef struct plant_magnetics_params {
    int saturation;
    double sat_l_inf_ratio, sat_i_scale_a, sat_i_knee_a;
} plant_magnetics_params_t;

typedef struct plant_sensor_params {
    int adc_model;
    int adc_bits;
    double adc_full_scale_a;
    double adc_gain_err_ia, adc_gain_err_ib, adc_gain_err_ic;
    double adc_offset_ia_a, adc_offset_ib_a, adc_offset_ic_a;
    double adc_noise_a_rms;
    double adc_vdc_full_scale_v;
    double adc_vdc_gain_err, adc_vdc_offset_v, adc_vdc_noise_v_rms;
    uint64_t adc_seed;
    int dual_sampling;
    int dual_sample_at;
} plant_sensor_params_t;

typedef struct plant_mechanics_params {
    double coulomb_nm, coulomb_band_rad_s;
    int load_profile;
    double load_t0_s, load_t1_s, load_torque0_nm, load_torque1_nm;
    int load_table_n;
    double load_table_t_s[32];
    double load_table_nm[32];
    int dyno;
    double dyno_speed_rad_s, dyno_accel_rad_s2;
} plant_mechanics_params_t;

typedef struct plant_params {
    double rs_ohm, ld_h, lq_h, psi_f_wb; int pole_pairs;
    double j_kgm2, b_nms;
    double v_dc_v;
    double ts_s;
    double t_delay_s;
    int substeps;
    int full_period_delay;
    plant_inverter_params_t inverter;
    plant_magnetics_params_t magnetics;
    plant_sensor_params_t sensors;
    plant_mechanics_params_t mechanics;
} plant_params_t;

typedef struct plant_snapshot {
    double t_s;
    double i_a_a, i_b_a, i_c_a, i_alpha_a, i_beta_a, i_d_a, i_q_a;
    double omega_m_rad_s, omega_e_rad_s, theta_e_rad, theta_m_rad;
    double torque_e_nm, torque_load_nm;
    double e_alpha_v, e_beta_v;
    double v_dc_v;
    double v_a_v, v_b_v, v_c_v, v_alpha_v, v_beta_v, v_d_v, v_q_v;
    double duty_a, duty_b, duty_c;
    double psi_alpha_wb, psi_beta_wb;
    double torque_friction_nm;
} plant_snapshot_t;

typedef struct plant_sample {
    double t_s;
    double i_a_a, i_b_a, i_c_a;
    double v_dc_v;
    double t2_s;
    double i2_a_a, i2_b_a, i2_c_a;
    int code_a, code_b, code_c, code_vdc;
    int code2_a, code2_b, code2_c;
    int dual_valid;
    double theta_enc_rad;
    int enc_valid;
} plant_sample_t;

typedef struct plant_energy {
    double electrical_in_j, copper_loss_j, viscous_loss_j, load_work_j, magnetic_j, kinetic_j;
    double coulomb_loss_j, inverter_loss_j, dc_bus_in_j;
    double short_loss_j, fault_absorbed_j;
} plant_energy_t;

typedef struct plant_fault {
    int kind; int phase; int phase2; int level; double value;
} plant_fault_t;
typedef struct plant_fault_status {
    unsigned active;
    double i_short_a;
    double i_leg_a_a, i_leg_b_a, i_leg_c_a;
    double v_dc_v;
    double absorbed_j;
    unsigned long short_fallbacks;
} plant_fault_status_t;

typedef struct plant_trace {
    int n;
    double *i_alpha_a, *i_beta_a;
    double *v_alpha_v, *v_beta_v;
    double *theta_e_rad;
} plant_trace_t;
typedef struct plant { double t_s; unsigned long events; unsigned long sw_periods; ...; } plant_t;
int plant_step_trace(plant_t *pl, const double duty_abc[3], const plant_trace_t *tr);
/* read-only: time, diode events, periods integrated at switch level */

const char *plant_params_check(const plant_params_t *p);
int  plant_init(plant_t *pl, const plant_params_t *p);
void plant_reset(plant_t *pl);
void plant_set_initial(plant_t *pl, double theta_e_rad, double omega_m_rad_s);
void plant_set_load_torque(plant_t *pl, double torque_nm);
void plant_step(plant_t *pl, const double duty_abc[3]);
void plant_snapshot(const plant_t *pl, plant_snapshot_t *out);
void plant_step_abc(plant_t *pl, double duty_a, double duty_b, double duty_c);
void plant_step_split(plant_t *pl, const double duty_abc[3], double t_split_s);
void plant_run(plant_t *pl, const double *duties_abc, size_t n, plant_snapshot_t *out);
void plant_energy(const plant_t *pl, plant_energy_t *out);
void plant_sample(const plant_t *pl, plant_sample_t *out);
void plant_set_dyno_speed(plant_t *pl, double omega_m_rad_s);
double plant_actuation_delay(const plant_t *pl);
double plant_load_torque_at(const plant_t *pl, double t_s);
const char *plant_fault_check(const plant_t *pl, const plant_fault_t *f);
int plant_set_fault(plant_t *pl, const plant_fault_t *f);
void plant_clear_fault(plant_t *pl, int kind, int phase);
void plant_clear_faults(plant_t *pl);
unsigned plant_faults_active(const plant_t *pl);
void plant_fault_status(const plant_t *pl, plant_fault_status_t *out);

/* parts, for tests of each part alone */
typedef struct sensor_rng { uint64_t s[4]; double cached_normal; int has_cached; } sensor_rng_t;
void sensor_rng_seed(sensor_rng_t *rng, uint64_t seed);
uint64_t sensor_rng_next_u64(sensor_rng_t *rng);
double sensor_rng_uniform(sensor_rng_t *rng);
double sensor_rng_normal(sensor_rng_t *rng);
typedef struct sensor_adc_config {
    int bits; int bipolar; double full_scale; double gain_err; double offset; double noise_rms;
} sensor_adc_config_t;
double sensor_adc_convert(const sensor_adc_config_t *cfg, sensor_rng_t *rng, double x_true,
                          int *code_out);

typedef struct inverter_config { double v_dc_v; } inverter_config_t;
typedef struct inverter_nl_config {
    double dead_time_s, ts_s, v_switch_drop_v, r_switch_ohm, v_diode_drop_v, r_diode_ohm,
           i_cap_band_a;
} inverter_nl_config_t;
typedef struct inverter { ...; } inverter_t;
int inverter_init(inverter_t *inv, const inverter_config_t *cfg);
int inverter_set_nonlinear(inverter_t *inv, const inverter_nl_config_t *cfg);
double inverter_smooth_sign(const inverter_t *inv, double i_a);
double inverter_leg_voltage(const inverter_t *inv, double duty, double i_a, double *f_hi);
typedef struct inverter_sw_leg {
    int state; int command; double dead_end_s, t0_s, v0_v, rate_v_s, t_clamp_s, v_clamp_v, f_clamp;
} inverter_sw_leg_t;
void inverter_sw_leg_reset(inverter_sw_leg_t *leg, int command);
void inverter_sw_command(const inverter_t *inv, inverter_sw_leg_t *leg, double t_s, int command,
                         double i_a);
void inverter_sw_advance(inverter_sw_leg_t *leg, double t_s);
double inverter_sw_next_change(const inverter_sw_leg_t *leg, double t_s);
double inverter_sw_pole_voltage(const inverter_t *inv, const inverter_sw_leg_t *leg, double t_s,
                                double i_a, double *f_hi);
void inverter_sw_shift(inverter_sw_leg_t *leg, double ts_s);

typedef struct pwm_config { double ts_s; int carrier_at_start; int load; } pwm_config_t;
typedef struct pwm_leg_plan { int n; double t_s[6]; int level[6]; int level_end; } pwm_leg_plan_t;
typedef struct pwm_plan { double t_load_s; pwm_leg_plan_t leg[3]; } pwm_plan_t;
typedef struct pwm { pwm_config_t cfg; int level[3]; } pwm_t;
int pwm_init(pwm_t *pwm, const pwm_config_t *cfg);
void pwm_reset(pwm_t *pwm, const double duty[3]);
double pwm_load_instant(const pwm_t *pwm, double t_write_s);
double pwm_carrier(const pwm_t *pwm, double t_s);
void pwm_plan(const pwm_t *pwm, const double duty_old[3], const double duty_new[3],
              double t_write_s, pwm_plan_t *out);
void pwm_commit(pwm_t *pwm, const pwm_plan_t *plan);

typedef struct pmsm_machine_config {
    double rs_ohm, ld_h, lq_h, psi_f_wb; int pole_pairs;
} pmsm_machine_config_t;
typedef struct pmsm_saturation_config { double l_inf_ratio, i_scale_a, i_knee_a; } pmsm_saturation_config_t;
typedef struct pmsm_machine { ...; } pmsm_machine_t;
int pmsm_machine_init(pmsm_machine_t *m, const pmsm_machine_config_t *cfg);
int pmsm_machine_set_saturation(pmsm_machine_t *m, const pmsm_saturation_config_t *sat);
double pmsm_machine_psi_d(const pmsm_machine_t *m, double i_d_a);
double pmsm_machine_ld_inc(const pmsm_machine_t *m, double i_d_a);
double pmsm_machine_stored_energy(const pmsm_machine_t *m, double i_d_a, double i_q_a);
double pmsm_machine_torque(const pmsm_machine_t *m, double i_d_a, double i_q_a);

typedef struct mechanics_load_profile {
    int kind; double t0_s, t1_s, torque0_nm, torque1_nm; int table_n;
    double table_t_s[32]; double table_nm[32];
} mechanics_load_profile_t;
const char *mechanics_load_profile_check(const mechanics_load_profile_t *lp);
double mechanics_load_profile_at(const mechanics_load_profile_t *lp, double t_s);
double mechanics_load_profile_mean(const mechanics_load_profile_t *lp, double t_a_s, double t_b_s);
"""

# The cycle engine (plant_rt/c/engine.h) and the recording ring and schema (rec_ring.h,
# rec_schema.h). Structs are partial (...;): the header fixes the layout, the fields below are
# the ones Python touches.
ENGINE_CDEF = """
typedef struct { uint64_t magic; uint64_t capacity; uint64_t head; uint64_t tail;
                 uint64_t records_written; uint64_t records_dropped; uint64_t bytes_dropped;
                 uint32_t producer_closed; ...; } rec_ring_header_t;
typedef struct { rec_ring_header_t *hdr; ...; } rec_ring_t;
size_t rec_ring_mapping_size(size_t capacity);
int rec_ring_format(void *mem, size_t mapping_size);
int rec_ring_attach(rec_ring_t *r, void *mem, size_t mapping_size);
int rec_ring_write(rec_ring_t *r, uint16_t channel, int64_t t_ns, const void *payload, size_t len);
void rec_ring_close(rec_ring_t *r);
uint64_t rec_ring_pending(const rec_ring_t *r);
size_t rec_ring_read(rec_ring_t *r, uint8_t *out, size_t cap);
#define REC_RING_HEADER_SIZE 256
#define REC_RING_RECORD_HEADER 16

const char *rec_schema_layout(void);
typedef struct { uint64_t offset; uint64_t log_time; uint16_t channel_id; uint16_t pad_[3]; }
    rec_mcap_entry_t;
typedef struct { size_t in_used; size_t out_len; size_t n_entries; size_t raw_len;
                 int stopped_at_limit; } rec_mcap_result_t;
void rec_to_mcap(const uint8_t *in, size_t n_in, const int32_t *channel_map, size_t n_map,
                 uint32_t *seqs, int64_t start_ns, size_t limit, uint8_t *out, size_t out_cap,
                 rec_mcap_entry_t *entries, size_t entries_cap, uint8_t *raw_out, size_t raw_cap,
                 rec_mcap_result_t *res);
typedef struct { double t_s; const char *kind; const char *text; double value; } rec_event_t;
typedef struct { double t_s; int32_t seq; const char *tx; const char *rx; } rec_frames_t;
size_t rec_encode_event(uint8_t *out, size_t cap, const rec_event_t *m);
size_t rec_encode_frames(uint8_t *out, size_t cap, const rec_frames_t *m);

#define ENGINE_MAX_EVENTS ...
#define ENGINE_MAX_LINK_FAULTS ...
#define ENGINE_MAX_TRACES ...
typedef struct { double scale, offset, raw_min, raw_max; } engine_signal_t;
typedef struct {
    void *ctx;
    void (*write)(void *ctx, const uint8_t *data, size_t n, int64_t now_ns);
    size_t (*read)(void *ctx, uint8_t *out, size_t cap, int64_t now_ns);
} eng_link_peer_t;
typedef struct { uint16_t id, dlc; uint8_t data[64]; } engine_replay_frame_t;
typedef struct {
    double t_s; uint32_t first_frame; uint32_t n_frames; uint32_t seq;
    int32_t has_duty, has_telem, has_theta;
    double i_abc_a[3]; double v_dc_v; double theta_rad; uint32_t duty_raw[3];
    double theta_hat_rad; double omega_hat_rad_s;
    int32_t state, estimator; int32_t has_emf; double e_alpha_v, e_beta_v, i_q_ref_a;
} engine_replay_cycle_t;
typedef struct {
    int mode; int duty_update; long n_cycles; double ts_s; double t_delay_s;
    int pole_pairs; double rpm_per_rad_s; int dual_sampling; int send_encoder; int telem_emf;
    int estimator_expected; uint16_t cmd_seq_start;
    int link_kind; int link_fd; eng_link_peer_t link_peer; int can_brs; double retry_timeout_s; double resend_max_s; double patience_s;
    int max_consecutive_bad_duties; int max_consecutive_misses; double guard_s;
    int rt_priority; int rt_cpu; int rt_mlock; double spin_s; int busy_wait;
    double recorder_stall_s; int stats_every_cycles; int record_frames;
    uint16_t ch_state, ch_sense, ch_telem, ch_frames, ch_events, ch_timing, ch_stats;
    engine_signal_t sig_i, sig_i2, sig_vdc, sig_theta;
    double scale_theta_hat, scale_omega_hat, scale_e, scale_iq_ref;
    uint32_t duty_raw_full, duty_raw_off;
    uint16_t aux_flag_theta_valid, aux_flag_dual_follows;
    char state_names[16][24];
    int source; const engine_replay_cycle_t *replay_cycles;
    const engine_replay_frame_t *replay_frames; long replay_n_frames; double pace_s;
    uint16_t ch_replay;
    int capture_serial; uint16_t ch_serial_raw;
    uint16_t ch_faults; long post_trip_cycles;
    long record_every; long pre_trigger_cycles, post_trigger_cycles;
    ...;
} engine_config_t;
typedef struct {
    long cycle; int kind; int command; double value; int record; double record_value;
    char text[96];
    int fault_kind, fault_phase, fault_phase2, fault_level, fault_index;
    char fault_name[24];
    double detect_within_s;
    ...;
} engine_event_t;
typedef struct {
    int kind; int direction; int frame_id; long cycle_on, cycle_off; uint32_t count;
    double probability; double delay_s, jitter_s; double stall_s; uint32_t n_garbage;
    uint64_t seed;
} elf_config_t;
typedef struct {
    elf_config_t lf; int fault_index; char name[24]; double detect_within_s;
} engine_link_fault_t;
typedef struct {
    int state; char name[24]; char target[12]; long first_k, close_k, seen_k;
    long window_cycles; double delay_s; uint64_t rtt_seen;
    int planned; int refused; long acted_k, evidence_k; uint32_t windows, untraced_windows;
    uint64_t matched, acted; uint64_t rtt_n, rtt_c; double rtt_p, rtt_var; ...;
} engine_trace_t;
typedef struct {
    uint64_t seq_mismatch, bad_duties, telem_missing, unknown_ids, heartbeats_rx, length_errors;
    uint64_t duplicates, stale_frames, retries, late_duty, missed_duty, estimator_mismatch;
    uint64_t rows_dropped, rt_overruns;
    uint64_t ctrl_rx_errors, ctrl_resets, ctrl_faults, duties_after_trip;
    uint64_t faults_injected, faults_untraced;
    uint64_t faults_acted, faults_traced;
    uint64_t state_rows;
    uint64_t operator_inputs, operator_refused, ring_waits;
    uint64_t late_answers, lost_frames, resend_answers;
} engine_counters_t;
typedef struct {
    uint64_t frames_tx, frames_rx, bytes_tx, bytes_rx;
    uint64_t error_frames, remote_frames, ext_ids, rx_malformed, send_failures, bus_state_changes;
} eng_link_counters_t;
typedef struct { uint32_t frames_ok, crc_errors, cobs_errors, length_errors, overruns,
                 bytes_discarded; ...; } hil_deframer_t;
typedef struct { int fd; hil_deframer_t deframer; eng_link_counters_t c; int bus_off;
                 int closed; char error[160]; ...; } eng_link_t;
typedef struct { uint64_t n; double max_us; ...; } engine_hist_t;
typedef struct engine {
    engine_config_t cfg; eng_link_t link;
    volatile int stop_requested; volatile long cycles_done; volatile double speed_rpm;
    int end; char message[768]; engine_counters_t n;
    int fault_code, fault_seq; long fault_detail; int fault_dlc;
    int rt_fifo, rt_mlock, rt_pinned; char rt_notes[256];
    engine_hist_t hist_cycle, hist_jitter;
    uint16_t cmd_seq;
    double duties[3];
    engine_trace_t traces[64];
    long trip_cycle;
    int paused; int64_t paused_ns;
    int64_t late_max_ns;
    ...;
} engine_t;
void engine_default_config(engine_config_t *cfg);
int engine_init(engine_t *e, const engine_config_t *cfg, plant_t *plant, void *ring_mem,
                size_t ring_size);
int engine_add_reference(engine_t *e, int kind, const void *config, size_t config_size,
                         uint16_t channel);
int engine_add_event(engine_t *e, const engine_event_t *ev);
int engine_add_link_fault(engine_t *e, const engine_link_fault_t *f);
int engine_run(engine_t *e);
void engine_request_stop(engine_t *e);
int engine_add_full_rate(engine_t *e, long from_k, long to_k);
int engine_attach_inbox(engine_t *e, void *mem, size_t size);

/* the live view (live.h): operator inputs' mailbox, the recorder's picker */
#define LIVE_INBOX_SLOTS 64
#define LIVE_INPUT_TEXT 192
#define LIVE_SKIP 0
#define LIVE_LAST 1
#define LIVE_EVERY 2
#define LIVE_PICK_MAX_CHANNELS 1024
#define LIVE_IN_SPEED_REF 1
#define LIVE_IN_LOAD 2
#define LIVE_IN_PAUSE 3
#define LIVE_IN_RESUME 4
#define LIVE_IN_REFUSED 5
#define LIVE_IN_HOLD_AT 6
#define LIVE_IN_IQ_REF 7
#define LIVE_IN_ID_REF 8
#define LIVE_IN_CONTROL_MODE 9
#define LIVE_IN_FAULT_ON 10
#define LIVE_IN_FAULT_OFF 11
#define LIVE_IN_NOTE 12
#define LIVE_FROM_VIEWER 0
#define LIVE_FROM_SCRIPT 1
#define LIVE_INPUT_ARGS 4
#define LIVE_REFUSED_TEXT 384
#define LIVE_WORD_WAKE 0
#define LIVE_WORD_NEWS 1
typedef struct { int32_t kind; int32_t client; double value; int32_t origin; int32_t arg[4];
                 char text[192]; ...; } live_input_t;
typedef struct live_inbox { uint64_t magic; uint64_t head; uint64_t tail;
                            char refused_text[384]; ...; } live_inbox_t;
size_t live_inbox_size(void);
int live_inbox_format(void *mem, size_t size);
live_inbox_t *live_inbox_attach(void *mem, size_t size);
int live_inbox_push(live_inbox_t *b, int kind, int client, double value, const char *text);
int live_inbox_push_input(live_inbox_t *b, int kind, int origin, double value,
                          const int32_t *args, const char *text);
int live_inbox_take(live_inbox_t *b, live_input_t *out);
uint64_t live_inbox_pending(const live_inbox_t *b);
void live_inbox_answer(live_inbox_t *b, const char *why);
void live_inbox_set_held(live_inbox_t *b, int64_t k);
uint32_t live_inbox_wake_word(const live_inbox_t *b);
uint32_t live_inbox_news(const live_inbox_t *b, int64_t *held_k, uint64_t *answered,
                         uint64_t *refused);
int live_inbox_wait(live_inbox_t *b, int word, uint32_t seen, int64_t timeout_ns);
void live_inbox_kick(live_inbox_t *b);
uint64_t live_ring_head(const void *ring_mem);
long live_ring_window(const void *ring_mem, size_t mapping_size, uint64_t from, uint64_t to,
                      uint8_t *out, size_t cap);
typedef struct { uint64_t offset; uint32_t length; uint16_t channel; uint16_t pad_; int64_t t_ns; }
    live_pick_t;
size_t live_pick(const uint8_t *in, size_t n_in, const int32_t *mode, size_t n_mode,
                 live_pick_t *picks, size_t cap, uint64_t *cut);
double engine_hist_percentile(const engine_hist_t *h, double q);
void engine_write_stats(engine_t *e, double t_s, const eng_link_counters_t *extra);
int engine_send(engine_t *e, uint16_t id, const uint8_t *data, uint16_t dlc);
size_t eng_ref_config_size(int kind);
void eng_link_feed(eng_link_t *l, const uint8_t *data, size_t n);
void eng_link_push(eng_link_t *l, uint16_t id, const uint8_t *data, uint16_t dlc);

/* software in the loop (firmware_stub/port/sil/sil_port.h, engine_sil.h) */
typedef struct {
    uint32_t frames_rx, cycles, unknown_ids, length_errors, seq_errors, config_rejected,
             not_ready, repeats, cmd_seq_gaps;
} hil_session_stats_t;
typedef struct { int hello_done; hil_session_stats_t stats; ...; } hil_session_t;
typedef struct { hil_session_t session; hil_deframer_t deframer; size_t tx_len; int hb_always;
                 unsigned long tx_overflows, restarts; ...; } sil_port_t;
void sil_port_init(sil_port_t *p, int hb_always, int64_t now_ns);
void sil_port_write(sil_port_t *p, const uint8_t *data, size_t n, int64_t now_ns);
size_t sil_port_read(sil_port_t *p, uint8_t *out, size_t cap, int64_t now_ns);
unsigned long sil_port_rx_errors(const sil_port_t *p);
void engine_sil_peer(sil_port_t *p, eng_link_peer_t *peer);
"""

#: compile and link flags of the sanitized build (tools/build_native.py --sanitize)
SANITIZE_COMPILE_ARGS = ["-O1", "-g", "-std=c99", "-ffp-contract=off", "-fno-omit-frame-pointer",
                         "-fsanitize=address,undefined", "-fno-sanitize-recover=undefined"]
SANITIZE_LINK_ARGS = ["-fsanitize=address,undefined"]


def make_builder(sanitize: bool = False) -> FFI:
    """The module's builder; ``sanitize``: -fsanitize=address,undefined instead of -O3 -flto."""
    builder = FFI()
    builder.cdef(CDEF + ENGINE_CDEF)
    builder.set_source(
        "hil_bench.plant_rt._plant_c",
        '#include "plant.h"\n#include "engine.h"\n#include "engine_sil.h"\n#include "rec_mcap.h"\n',
        sources=[str(C_DIR / name) for name in SOURCES]
        # the reference estimators are the firmware's own library; the engine frames with the
        # protocol's codec
        + sorted(str(p) for p in FW_SRC.glob("*.c"))
        + [str(PROTOCOL_C / "hil_msgs.c"), str(PROTOCOL_C / "hil_framing.c"),
           str(SIL_PORT / "sil_port.c")],
        include_dirs=[str(C_DIR), str(FW_SRC), str(PROTOCOL_C), str(SIL_PORT)],
        # ISO C (-std=c99): no FMA contraction, so -O3 and LTO give the same results as -O2;
        # -flto=auto: LTO's link step in parallel under make's jobserver (plain -flto warns
        # "using serial compilation")
        extra_compile_args=(SANITIZE_COMPILE_ARGS if sanitize
                            else ["-O3", "-std=c99", "-flto=auto", "-ffp-contract=off",
                                  "-fno-semantic-interposition"]),
        # -fno-semantic-interposition: calls between the module's own C files inline under LTO
        # (nothing outside the module interposes them); no effect on floating-point results
        extra_link_args=(SANITIZE_LINK_ARGS if sanitize
                         else ["-O3", "-flto=auto", "-fno-semantic-interposition"]),
        libraries=["m"],
    )
    return builder


ffibuilder = make_builder()

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
