/**
 * @file rec_schema.h
 * @brief The recorded channels: one definition of every message of a recording, shared by C and
 * Python.
 *
 * Each channel is an X-macro list of (type, field) pairs. From it come the C row struct the
 * cycle engine fills, the protobuf encoder that turns a row into the message bytes written to
 * MCAP, and a layout string (rec_schema_layout) from which Python builds the protobuf schema
 * (bench/record/channels.py) and the fast fixed-layout decoder (bench/record/recording.py). Field n of the
 * list (counting from 1) is protobuf field number n; nothing else assigns numbers, so the two
 * sides cannot drift.
 *
 * Types and their protobuf encoding (proto3, every field written every time, in field order):
 *   F64  double   wire type 1 (8 octets, little-endian)   NaN = not available
 *   U32  fixed32  wire type 5 (4 octets)
 *   I32  sfixed32 wire type 5 (4 octets)                  -1 = not available where stated
 *   CNT  double   wire type 1: a count (uint64_t in C), sent as a double so that every viewer
 *                 plots it as a number (exact below 2^53)
 *   STR  string   wire type 2 (varint length + UTF-8 octets)
 * A channel of fixed-width fields only has one byte layout for every message, which is what
 * lets a reader decode a whole chunk of them with one numpy call (bench/record/recording.py).
 *
 * Host-only C99 (the engine runs on the Linux host); no heap.
 */
#ifndef REC_SCHEMA_H
#define REC_SCHEMA_H

#include <stddef.h>
#include <stdint.h>

/* ---- the channels ------------------------------------------------------------------------ */

/** /plant/state, hil.PlantState: true plant state at the sampling instant t_k (voltages:
 *  averages over the period that ended at t_k). SI units; speed_rpm mechanical. */
#define REC_PLANT_STATE(X, P)                                                                  \
    X(P, F64, t_s) X(P, F64, i_a_a) X(P, F64, i_b_a) X(P, F64, i_c_a) X(P, F64, i_alpha_a)     \
    X(P, F64, i_beta_a) X(P, F64, i_d_a) X(P, F64, i_q_a) X(P, F64, omega_m_rad_s)             \
    X(P, F64, omega_e_rad_s) X(P, F64, theta_e_rad) X(P, F64, theta_m_rad)                     \
    X(P, F64, torque_e_nm) X(P, F64, torque_load_nm) X(P, F64, e_alpha_v) X(P, F64, e_beta_v)  \
    X(P, F64, v_dc_v) X(P, F64, v_a_v) X(P, F64, v_b_v) X(P, F64, v_c_v) X(P, F64, v_alpha_v)  \
    X(P, F64, v_beta_v) X(P, F64, v_d_v) X(P, F64, v_q_v) X(P, F64, speed_rpm)

/** /plant/sense, hil.Sense: what the controller was sent for cycle seq (after the sensor model
 *  and the wire's fixed-point scaling); theta_enc_rad NaN when the encoder angle is not sent. */
#define REC_SENSE(X, P)                                                                        \
    X(P, F64, t_s) X(P, U32, seq) X(P, F64, i_a_a) X(P, F64, i_b_a) X(P, F64, i_c_a)           \
    X(P, F64, v_dc_v) X(P, F64, theta_enc_rad)

/** /controller/telemetry, hil.ControllerTelemetry: the controller's answer to cycle seq: its
 *  estimated electrical angle and speed (TELEM; NaN and state = estimator = -1 if missing), EMF
 *  (TELEM_EMF, NaN if not sent), the duties applied (DUTY, -1 = leg off) and the
 *  position-estimation error pee_rad = wrap(theta_hat - theta_true). */
#define REC_TELEMETRY(X, P)                                                                    \
    X(P, F64, t_s) X(P, U32, seq) X(P, F64, theta_hat_rad) X(P, F64, omega_hat_rad_s)          \
    X(P, F64, speed_hat_rpm) X(P, I32, state) X(P, I32, estimator) X(P, F64, e_alpha_v)        \
    X(P, F64, e_beta_v) X(P, F64, i_q_ref_a) X(P, F64, duty_a) X(P, F64, duty_b)               \
    X(P, F64, duty_c) X(P, F64, pee_rad)

/** /reference/<name>, hil.ReferenceEstimator: a reference estimator run on the host on exactly
 *  the samples and voltages the controller saw. */
#define REC_REFERENCE(X, P)                                                                    \
    X(P, F64, t_s) X(P, U32, seq) X(P, F64, theta_hat_rad) X(P, F64, omega_hat_rad_s)          \
    X(P, F64, speed_hat_rpm) X(P, F64, e_alpha_v) X(P, F64, e_beta_v) X(P, F64, pee_rad)

/** /link/frames, hil.CycleFrames: every frame of the cycle as sent (tx) and received (rx),
 *  space-separated candump-style ID#DATA (hex); seq -1 for frames outside the cycles. */
#define REC_FRAMES(X, P) X(P, F64, t_s) X(P, I32, seq) X(P, STR, tx) X(P, STR, rx)

/** /events, hil.Event: scenario events, state changes, faults and link problems. */
#define REC_EVENT(X, P) X(P, F64, t_s) X(P, STR, kind) X(P, STR, text) X(P, F64, value)

/** /timing, hil.Timing: wall-clock timing of cycle seq. start_err_us: when SENSE left minus
 *  the period's deadline (real time; NaN in lockstep); rtt_us: SENSE sent -> DUTY received;
 *  arrival_us: DUTY arrival after the period start (real time); cycle_us: wall time of the
 *  whole cycle; missed: this period ended without its DUTY (0 or 1; real time);
 *  retries: SENSE re-sends this cycle (lockstep); late_total: DUTY frames that arrived after
 *  their period so far; missed_total: periods without their DUTY so far; overrun: 1 for a
 *  period the bench itself lost (real time: it woke a whole period or more late, so no SENSE
 *  left in this period and the plant ran it on the held duties; start_err_us is then how late
 *  this period's start would have been, >= one period). Every period has one row. */
#define REC_TIMING(X, P)                                                                       \
    X(P, F64, t_s) X(P, U32, seq) X(P, F64, start_err_us) X(P, F64, rtt_us)                    \
    X(P, F64, arrival_us) X(P, F64, cycle_us) X(P, U32, missed)                                \
    X(P, U32, retries) X(P, CNT, late_total) X(P, CNT, missed_total) X(P, U32, overrun)

/** /link/stats, hil.LinkStats: cumulative counters of the link, the cycle engine and the
 *  recorder, and wall-clock percentiles of the cycle time (lockstep) / period-start error
 *  (real time) so far. ctrl_rx_errors: the frames the controller rejected, as its last
 *  HEARTBEAT_CTRL reported; ctrl_resets: times its heartbeat counter started over (it
 *  restarted); ctrl_faults: FAULT_CTRL frames received; duties_after_trip: duties applied
 *  after the controller's FAULT_CTRL that were not all legs OFF; faults_injected /
 *  faults_untraced: link-fault actions taken, and link faults that left no trace (/faults).
 *  Lockstep (docs/protocol.md 6.5): retries = SENSE groups re-sent; late_answers = re-sent cycles
 *  every SENSE group of which was answered (timing, not a problem); lost_frames = frames that
 *  never arrived, recovered by a re-send; resend_answers = DUTY frames of a re-sent cycle after the one that completed it (the
 *  controller's cache answering the re-sends). */
#define REC_LINK_STATS(X, P)                                                                   \
    X(P, F64, t_s) X(P, CNT, cycles) X(P, CNT, frames_tx) X(P, CNT, frames_rx)                 \
    X(P, CNT, bytes_tx) X(P, CNT, bytes_rx) X(P, CNT, frames_ok) X(P, CNT, crc_errors)         \
    X(P, CNT, cobs_errors) X(P, CNT, length_errors) X(P, CNT, overruns)                        \
    X(P, CNT, bytes_discarded) X(P, CNT, seq_mismatch) X(P, CNT, bad_duties)                   \
    X(P, CNT, telem_missing) X(P, CNT, unknown_ids) X(P, CNT, heartbeats_rx)                   \
    X(P, CNT, duplicates) X(P, CNT, stale_frames) X(P, CNT, retries) X(P, CNT, late_duty)      \
    X(P, CNT, missed_duty) X(P, CNT, estimator_mismatch) X(P, CNT, rows_dropped)               \
    X(P, CNT, rt_overruns)                                                                     \
    X(P, CNT, can_unknown_ids) X(P, CNT, error_frames) X(P, CNT, bus_state_changes)            \
    X(P, CNT, send_failures) X(P, CNT, remote_frames) X(P, CNT, rx_malformed)                  \
    X(P, CNT, ctrl_rx_errors) X(P, CNT, ctrl_resets) X(P, CNT, ctrl_faults)                    \
    X(P, CNT, duties_after_trip) X(P, CNT, faults_injected) X(P, CNT, faults_untraced)         \
    X(P, F64, cycle_wall_p50_us) X(P, F64, cycle_wall_p99_us) X(P, F64, cycle_wall_max_us)     \
    X(P, F64, jitter_p50_us) X(P, F64, jitter_p99_us) X(P, F64, jitter_p999_us)                \
    X(P, F64, jitter_max_us)                                                                   \
    X(P, CNT, late_answers) X(P, CNT, lost_frames) X(P, CNT, resend_answers)

/** /replay/controller, hil.ReplayController: a live controller's answer to a recorded cycle
 *  beside the recorded answer: DUTY (-1 = leg off, NaN = no DUTY), TELEM (angle, speed: NaN,
 *  state, estimator: -1 = no TELEM), TELEM_EMF (NaN = none). */
#define REC_REPLAY_CONTROLLER(X, P)                                                            \
    X(P, F64, t_s) X(P, U32, seq) X(P, F64, duty_a_rec) X(P, F64, duty_a) X(P, F64, duty_b_rec) \
    X(P, F64, duty_b) X(P, F64, duty_c_rec) X(P, F64, duty_c) X(P, F64, theta_hat_rec_rad)      \
    X(P, F64, theta_hat_rad) X(P, F64, omega_hat_rec_rad_s) X(P, F64, omega_hat_rad_s)         \
    X(P, I32, state_rec) X(P, I32, state) X(P, I32, estimator_rec) X(P, I32, estimator)        \
    X(P, F64, e_alpha_rec_v) X(P, F64, e_alpha_v) X(P, F64, e_beta_rec_v) X(P, F64, e_beta_v)  \
    X(P, F64, i_q_ref_rec_a) X(P, F64, i_q_ref_a)

/** /replay/plant, hil.ReplayPlant: the plant driven by the recorded duties; its sampled phase
 *  currents (wire values) beside the recorded ones. */
#define REC_REPLAY_PLANT(X, P)                                                                 \
    X(P, F64, t_s) X(P, U32, seq) X(P, F64, i_a_rec_a) X(P, F64, i_a_a) X(P, F64, i_b_rec_a)    \
    X(P, F64, i_b_a) X(P, F64, i_c_rec_a) X(P, F64, i_c_a)

/** /faults, hil.Fault: every fault the run injected and what came of it (docs/faults.md).
 *  target: "plant", "link" or "controller"; kind: the fault's kind (open_phase, drop, ...);
 *  direction: "to_controller" / "from_controller" / "both" (link faults), "" otherwise;
 *  action: "on", "off" (plant faults switched), "drop", "duplicate", ... (a link fault acting on
 *  one frame, whose id and seq the text names; drop / duplicate / reorder: value = the frame's
 *  place among the frames of its cycle the fault met, 0 = the cycle's first, 1 and on = a
 *  re-send or its answer), "trip" (the controller's FAULT_CTRL: value =
 *  its code), "trace" (a link fault's evidence once its detection window closed: the counters
 *  that moved, value = seconds from the first injection to the first evidence, NaN = none);
 *  index: the fault's number in the scenario's [[faults]] (-1: none). */
#define REC_FAULT(X, P)                                                                        \
    X(P, F64, t_s) X(P, I32, seq) X(P, I32, index) X(P, STR, target) X(P, STR, kind)           \
    X(P, STR, direction) X(P, STR, action) X(P, STR, text) X(P, F64, value)

/** Every channel: X(P, kind, schema name, field list macro). Kind ids are the order below. */
#define REC_CHANNELS(C)                                                                        \
    C(PLANT_STATE, "hil.PlantState", REC_PLANT_STATE)                                          \
    C(SENSE, "hil.Sense", REC_SENSE)                                                           \
    C(TELEMETRY, "hil.ControllerTelemetry", REC_TELEMETRY)                                     \
    C(REFERENCE, "hil.ReferenceEstimator", REC_REFERENCE)                                      \
    C(FRAMES, "hil.CycleFrames", REC_FRAMES)                                                   \
    C(EVENT, "hil.Event", REC_EVENT)                                                           \
    C(TIMING, "hil.Timing", REC_TIMING)                                                        \
    C(LINK_STATS, "hil.LinkStats", REC_LINK_STATS)                                             \
    C(REPLAY_CONTROLLER, "hil.ReplayController", REC_REPLAY_CONTROLLER)                        \
    C(REPLAY_PLANT, "hil.ReplayPlant", REC_REPLAY_PLANT)                                       \
    C(FAULT, "hil.Fault", REC_FAULT)

/* ---- generated from the lists ------------------------------------------------------------- */

#define REC_CTYPE_F64 double
#define REC_CTYPE_U32 uint32_t
#define REC_CTYPE_I32 int32_t
#define REC_CTYPE_CNT uint64_t
#define REC_CTYPE_STR const char *

#define REC_STRUCT_FIELD_(P, T, name) REC_CTYPE_##T name;
#define REC_ENUM_FIELD_(P, T, name) P##_##name,

typedef enum {
#define REC_KIND_ENUM_(K, schema, LIST) REC_KIND_##K,
    REC_CHANNELS(REC_KIND_ENUM_)
#undef REC_KIND_ENUM_
    REC_KIND_COUNT
} rec_kind_t;

/* rec_<kind>_t row structs and REC_<KIND>_<field> indices (0-based; protobuf field = index + 1) */
typedef struct { REC_PLANT_STATE(REC_STRUCT_FIELD_, x) } rec_plant_state_t;
typedef struct { REC_SENSE(REC_STRUCT_FIELD_, x) } rec_sense_t;
typedef struct { REC_TELEMETRY(REC_STRUCT_FIELD_, x) } rec_telemetry_t;
typedef struct { REC_REFERENCE(REC_STRUCT_FIELD_, x) } rec_reference_t;
typedef struct { REC_FRAMES(REC_STRUCT_FIELD_, x) } rec_frames_t;
typedef struct { REC_EVENT(REC_STRUCT_FIELD_, x) } rec_event_t;
typedef struct { REC_TIMING(REC_STRUCT_FIELD_, x) } rec_timing_t;
typedef struct { REC_LINK_STATS(REC_STRUCT_FIELD_, x) } rec_link_stats_t;
typedef struct { REC_REPLAY_CONTROLLER(REC_STRUCT_FIELD_, x) } rec_replay_controller_t;
typedef struct { REC_REPLAY_PLANT(REC_STRUCT_FIELD_, x) } rec_replay_plant_t;
typedef struct { REC_FAULT(REC_STRUCT_FIELD_, x) } rec_fault_t;

/** Largest encoded size of a row whose strings total str_len octets. */
#define REC_MAX_FIXED_SIZE 512u

/* Encoders: the protobuf message of one row into out[0..cap). Return the octets written, or 0
 * if cap is too small (nothing useful is left in out then). Strings: NUL-terminated; NULL is
 * an empty string. */
size_t rec_encode_plant_state(uint8_t *out, size_t cap, const rec_plant_state_t *m);
size_t rec_encode_sense(uint8_t *out, size_t cap, const rec_sense_t *m);
size_t rec_encode_telemetry(uint8_t *out, size_t cap, const rec_telemetry_t *m);
size_t rec_encode_reference(uint8_t *out, size_t cap, const rec_reference_t *m);
size_t rec_encode_frames(uint8_t *out, size_t cap, const rec_frames_t *m);
size_t rec_encode_event(uint8_t *out, size_t cap, const rec_event_t *m);
size_t rec_encode_timing(uint8_t *out, size_t cap, const rec_timing_t *m);
size_t rec_encode_link_stats(uint8_t *out, size_t cap, const rec_link_stats_t *m);
size_t rec_encode_replay_controller(uint8_t *out, size_t cap, const rec_replay_controller_t *m);
size_t rec_encode_replay_plant(uint8_t *out, size_t cap, const rec_replay_plant_t *m);
size_t rec_encode_fault(uint8_t *out, size_t cap, const rec_fault_t *m);

/**
 * Layout of every channel, one line per kind in rec_kind_t order:
 *   "<KIND> <schema name> <TYPE>:<field> <TYPE>:<field> ...\n"
 * e.g. "SENSE hil.Sense F64:t_s U32:seq F64:i_a_a ...". Python builds the protobuf descriptors
 * and decoders from it.
 */
const char *rec_schema_layout(void);

#endif
