"""Topics and JSON schemas of a recording (one place, used by the runner and the checker)."""
from __future__ import annotations

from .recorder import number_schema

PLANT_STATE = "/plant/state"
PLANT_SENSE = "/plant/sense"
CONTROLLER_TELEMETRY = "/controller/telemetry"
LINK_FRAMES = "/link/frames"
LINK_STATS = "/link/stats"
EVENTS = "/events"
REFERENCE_PREFIX = "/reference/"

#: plant snapshot fields recorded each cycle (a subset of plant_rt's plant_snapshot_t, same names)
PLANT_SNAPSHOT_FIELDS = (
    "i_a_a", "i_b_a", "i_c_a", "i_alpha_a", "i_beta_a", "i_d_a", "i_q_a",
    "omega_m_rad_s", "omega_e_rad_s", "theta_e_rad", "theta_m_rad",
    "torque_e_nm", "torque_load_nm", "e_alpha_v", "e_beta_v", "v_dc_v",
    "v_a_v", "v_b_v", "v_c_v", "v_alpha_v", "v_beta_v", "v_d_v", "v_q_v",
)
#: value order of a /plant/state message (t_s, the snapshot fields, then derived speed_rpm)
PLANT_STATE_VALUES = ("t_s",) + PLANT_SNAPSHOT_FIELDS + ("speed_rpm",)
PLANT_STATE_SCHEMA = number_schema(
    "hil.PlantState", PLANT_STATE_VALUES,
    description="True plant state at the sampling instant t_k (voltages: averages over the "
                "period that ended at t_k). SI units; speed_rpm mechanical.")

PLANT_SENSE_VALUES = ("t_s", "seq", "i_a_a", "i_b_a", "i_c_a", "v_dc_v", "theta_enc_rad")
PLANT_SENSE_SCHEMA = number_schema(
    "hil.Sense", PLANT_SENSE_VALUES[2:] + ("t_s",), integers=("seq",),
    description="What the controller was sent for cycle seq (after the sensor model and the "
                "wire's fixed-point scaling).")

TELEMETRY_VALUES = ("t_s", "seq", "theta_hat_rad", "omega_hat_rad_s", "speed_hat_rpm", "state",
                    "estimator", "e_alpha_v", "e_beta_v", "i_q_ref_a", "duty_a", "duty_b",
                    "duty_c", "pee_rad")
TELEMETRY_SCHEMA = number_schema(
    "hil.ControllerTelemetry",
    tuple(f for f in TELEMETRY_VALUES if f not in ("seq", "state", "estimator")),
    integers=("seq", "state", "estimator"),
    description="The controller's answer to cycle seq: its estimated electrical angle and speed "
                "(TELEM), EMF (TELEM_EMF, NaN if not sent), duties (DUTY, -1 = leg off) and the "
                "position-estimation error pee_rad = wrap(theta_hat - theta_true).")

FRAMES_VALUES = ("t_s", "seq", "tx", "rx")
FRAMES_SCHEMA = number_schema(
    "hil.CycleFrames", ("t_s",), integers=("seq",), strings=("tx", "rx"),
    description="Every frame of the cycle, as sent (tx) and received (rx): space-separated "
                "candump-style ID#DATA (hex).")

EVENTS_SCHEMA = number_schema(
    "hil.Event", ("t_s", "value"), strings=("kind", "text"),
    description="Scenario events, state changes, faults and link problems.")

LINK_STATS_COUNTERS = (
    "cycles", "frames_tx", "frames_rx", "bytes_tx", "bytes_rx", "frames_ok", "crc_errors",
    "cobs_errors", "length_errors", "overruns", "bytes_discarded", "seq_mismatch", "bad_duties",
    "telem_missing", "unknown_ids", "heartbeats_rx",
    # CAN links (0 on serial links)
    "can_unknown_ids", "error_frames", "bus_state_changes", "send_failures", "remote_frames",
    "rx_malformed",
)
LINK_STATS_SCHEMA = number_schema(
    "hil.LinkStats", ("t_s", "cycle_wall_p50_us", "cycle_wall_p99_us", "cycle_wall_max_us"),
    integers=LINK_STATS_COUNTERS,
    description="Link counters (cumulative) and wall-clock time per lockstep cycle.")

REFERENCE_VALUES = ("t_s", "seq", "theta_hat_rad", "omega_hat_rad_s", "speed_hat_rpm", "e_alpha_v",
                    "e_beta_v", "pee_rad")
REFERENCE_SCHEMA = number_schema(
    "hil.ReferenceEstimator", tuple(f for f in REFERENCE_VALUES if f != "seq"), integers=("seq",),
    description="A reference estimator run on the host on exactly the samples and voltage "
                "commands the controller saw.")
