/* GENERATED FROM hil.dbc BY protocol/gen_c.py -- DO NOT EDIT.
 * Regenerate with `python protocol/gen_c.py`; `--check` verifies the committed copy. */

#ifndef HIL_MSGS_H
#define HIL_MSGS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* hil-bench protocol 1.1: message set of the hil-bench HIL link.
 * Structs hold RAW wire integers (IEEE float signals: float). Signals are little-endian.
 * encode: physical -> raw = (value - offset) / scale rounded to nearest, ties away from zero,
 *         evaluated in double (float if HIL_MSGS_CALC_FLOAT is defined; where double is
 *         binary32, e.g. TI C28x COFF ABI, both agree and may differ by 1 LSB next to a tie from
 *         the binary64 reference), saturated to the valid range (the DBC range, or up to the
 *         attribute HilValidMax); NaN encodes as 0 clamped into that range. Angles (rad, one
 *         turn over the raw range) wrap: raw = round(value / scale) mod 2^bits; NaN and
 *         infinities encode as 0. Float signals: clamped to [min, max], NaN -> 0.
 * decode: raw -> physical = raw * scale + offset (sentinels such as HIL_DUTY_RAW_OFF are not
 *         decoded: test the raw value first).
 * pack returns the message length or -1 (NULL pointer, size too small); unpack returns 0 or -1.
 * Octets of hil_octet_t are read as (octet & 0xFF). */

#define HIL_PROTO_VERSION 1u /* major: HELLO.proto_version */
#define HIL_PROTO_VERSION_MINOR 1u /* HELLO.proto_minor, HELLO_ACK.proto_minor */

/* One wire octet (0..255) per element; uint_least8_t is 16 bits wide on TI C28x. */
typedef uint_least8_t hil_octet_t;

/* ---- value tables ---- */
/* CONFIG.param_id, CONFIG_ACK.param_id */
typedef enum {
    HIL_PARAM_RS_OHM = 1,
    HIL_PARAM_LD_H = 2,
    HIL_PARAM_LQ_H = 3,
    HIL_PARAM_PSI_F_WB = 4,
    HIL_PARAM_POLE_PAIRS = 5,
    HIL_PARAM_J_KGM2 = 6,
    HIL_PARAM_B_NMS = 7,
    HIL_PARAM_V_DC_NOM_V = 8,
    HIL_PARAM_CUR_KP_V_A = 20,
    HIL_PARAM_CUR_KI_V_AS = 21,
    HIL_PARAM_SPD_KP_A_RAD_S = 22,
    HIL_PARAM_SPD_KI_A_RAD = 23,
    HIL_PARAM_IQ_MAX_A = 24,
    HIL_PARAM_SPEED_LOOP_DIV = 25,
    HIL_PARAM_I_MAX_TRIP_A = 26,
    HIL_PARAM_ALIGN_I_A = 30,
    HIL_PARAM_ALIGN_TIME_S = 31,
    HIL_PARAM_IF_I_A = 32,
    HIL_PARAM_IF_ACCEL_RAD_S2 = 33,
    HIL_PARAM_HANDOVER_SPEED_RAD_S = 34,
    HIL_PARAM_HANDOVER_TIME_S = 35,
    HIL_PARAM_CTRL_DELAY_S = 36,
    HIL_PARAM_LOOP_ANGLE = 37,
    HIL_PARAM_SMO_K_V = 40,
    HIL_PARAM_SMO_WC_RAD_S = 41,
    HIL_PARAM_SMO_M_PER_A = 42,
    HIL_PARAM_SMO_SIGMOID_A_PER_A = 43,
    HIL_PARAM_PLL_KP = 44,
    HIL_PARAM_PLL_KI = 45,
    HIL_PARAM_SPEED_LPF_RAD_S = 46,
    HIL_PARAM_SMO_K_FACTOR = 47,
    HIL_PARAM_SMO_K_MIN_V = 48,
    HIL_PARAM_SMO_LAG_COMP = 49,
    HIL_PARAM_HFI_U_V = 50,
    HIL_PARAM_HFI_F_HZ = 51,
    HIL_PARAM_HFI_BW_RAD_S = 52,
    HIL_PARAM_HFI_PI_KP = 53,
    HIL_PARAM_HFI_PI_KI = 54,
    HIL_PARAM_IPD_TIME_S = 55,
    HIL_PARAM_HFI_POL_BIAS_A = 56,
    HIL_PARAM_HFI_LOCK_TOL_RAD = 57,
    HIL_PARAM_DELAY_COMP_ENABLE = 60,
    HIL_PARAM_DELAY_COMP_TD_S = 61,
    HIL_PARAM_HARM_COMP_ENABLE = 62,
    HIL_PARAM_HARM_GSDFT_M = 63,
    HIL_PARAM_HARM_COMP_GAIN = 64,
    HIL_PARAM_HARM_EXTRACTOR = 65,
    HIL_PARAM_PROT_OPEN_I_MIN_A = 70,
    HIL_PARAM_PROT_OPEN_RATIO = 71,
    HIL_PARAM_PROT_OPEN_TIME_S = 72,
    HIL_PARAM_PROT_SUM_MAX_A = 73,
    HIL_PARAM_PROT_SUM_TAU_S = 74,
    HIL_PARAM_PROT_STUCK_TIME_S = 75,
    HIL_PARAM_PROT_STUCK_DELTA_A = 76,
    HIL_PARAM_PROT_VDC_UV_RATIO = 77,
    HIL_PARAM_PROT_VDC_OV_RATIO = 78,
    HIL_PARAM_PROT_VDC_TIME_S = 79,
    HIL_PARAM_PROT_LINK_TIMEOUT_PERIODS = 80,
    HIL_PARAM_PROT_ENC_LOST_TIME_S = 81,
    HIL_PARAM_PROT_ENC_EMF_RATIO = 82,
    HIL_PARAM_PROT_ENC_FROZEN_TIME_S = 83,
    HIL_PARAM_PROT_STALL_TIME_S = 84,
    HIL_PARAM_PROT_STALL_SPEED_RAD_S = 85,
    HIL_PARAM_SMO_STA_K1_V = 86,
    HIL_PARAM_SMO_STA_K2_V_S = 87,
    HIL_PARAM_INV_COMP_ENABLE = 90,
    HIL_PARAM_INV_COMP_DEAD_TIME_S = 91,
    HIL_PARAM_INV_COMP_V_SWITCH_V = 92,
    HIL_PARAM_INV_COMP_R_SWITCH_OHM = 93,
    HIL_PARAM_INV_COMP_V_DIODE_V = 94,
    HIL_PARAM_INV_COMP_R_DIODE_OHM = 95,
    HIL_PARAM_INV_COMP_BAND_A = 96,
    HIL_PARAM_INV_COMP_SHAPE = 97,
    HIL_PARAM_INV_COMP_I_BW_RAD_S = 98
} hil_param_t;

/* HELLO.estimator, TELEM.estimator */
typedef enum {
    HIL_EST_NONE = 0,
    HIL_EST_SMO_SIGN = 1,
    HIL_EST_SMO_SIGMOID = 2,
    HIL_EST_SMO_TANH = 3,
    HIL_EST_HFI_SDFT = 4,
    HIL_EST_ENCODER = 5,
    HIL_EST_SMO_STA = 6
} hil_estimator_t;

/* HEARTBEAT_PLANT.state, HEARTBEAT_CTRL.state, TELEM.state */
typedef enum {
    HIL_STATE_IDLE = 0,
    HIL_STATE_ALIGN = 1,
    HIL_STATE_OPEN_LOOP = 2,
    HIL_STATE_CLOSED_LOOP = 3,
    HIL_STATE_FAULT = 4,
    HIL_STATE_INITIAL_POSITION = 5,
    HIL_STATE_STOPPED = 6
} hil_state_t;

/* FAULT_PLANT.code, FAULT_CTRL.code */
typedef enum {
    HIL_FAULT_NONE = 0,
    HIL_FAULT_LINK_TIMEOUT = 1,
    HIL_FAULT_CRC_ERRORS = 2,
    HIL_FAULT_BAD_SEQUENCE = 3,
    HIL_FAULT_OVERCURRENT = 4,
    HIL_FAULT_INVALID_DUTY = 5,
    HIL_FAULT_PROTOCOL_VERSION = 6,
    HIL_FAULT_WATCHDOG = 7,
    HIL_FAULT_CONFIG_INVALID = 8,
    HIL_FAULT_OVERVOLTAGE = 9,
    HIL_FAULT_STARTUP_FAILED = 10,
    HIL_FAULT_UNKNOWN_MESSAGE = 11,
    HIL_FAULT_BUS_BUDGET = 12,
    HIL_FAULT_HOST_ABORT = 13,
    HIL_FAULT_OPEN_PHASE = 14,
    HIL_FAULT_UNDERVOLTAGE = 15,
    HIL_FAULT_SENSOR_FAULT = 16,
    HIL_FAULT_STALL = 17
} hil_fault_t;

/* CMD.command */
typedef enum {
    HIL_CMD_NOP = 0,
    HIL_CMD_RUN = 1,
    HIL_CMD_STOP = 2,
    HIL_CMD_CLEAR_FAULT = 3,
    HIL_CMD_SET_SPEED_REF = 4,
    HIL_CMD_SET_IQ_REF = 5,
    HIL_CMD_SET_ID_REF = 6,
    HIL_CMD_SET_CONTROL_MODE = 7,
    HIL_CMD_RESTART = 8
} hil_command_t;

/* HELLO_ACK.status */
typedef enum {
    HIL_HELLO_STATUS_OK = 0,
    HIL_HELLO_STATUS_VERSION_MISMATCH = 1,
    HIL_HELLO_STATUS_ESTIMATOR_UNSUPPORTED = 2,
    HIL_HELLO_STATUS_BUSY = 3,
    HIL_HELLO_STATUS_PERIOD_UNSUPPORTED = 4,
    HIL_HELLO_STATUS_MODE_UNSUPPORTED = 5
} hil_hello_status_t;

/* CONFIG_ACK.status */
typedef enum {
    HIL_CONFIG_STATUS_OK = 0,
    HIL_CONFIG_STATUS_UNKNOWN_PARAM = 1,
    HIL_CONFIG_STATUS_OUT_OF_RANGE = 2,
    HIL_CONFIG_STATUS_LOCKED = 3
} hil_config_status_t;

/* HELLO.mode */
typedef enum {
    HIL_MODE_LOCKSTEP = 0,
    HIL_MODE_REALTIME = 1
} hil_mode_t;

/* DUTY.{d_a, d_b, d_c} raw 65535 = OFF (outside the DBC range). */
#define HIL_DUTY_RAW_OFF 65535u

/* HELLO.flags bits */
#define HIL_HELLO_FLAG_DUAL_SAMPLING 0x01u /* bit0: dual sampling: the host sends SENSE_DUAL every cycle */
#define HIL_HELLO_FLAG_TELEM_EMF 0x02u /* bit1: the controller sends TELEM_EMF every cycle */
#define HIL_HELLO_FLAG_ENCODER_VALID 0x04u /* bit2: the host sends the plant's encoder angle in SENSE_AUX.theta_enc in this session (only when the estimator is ENCODER or the scenario asks for it); each cycle's SENSE_AUX flag THETA_ENC_VALID decides whether that cycle's angle is valid */

/* SENSE_AUX.flags bits */
#define HIL_SENSE_AUX_FLAG_DUAL_FOLLOWS 0x01u /* bit0: SENSE_DUAL of this seq was sent before SENSE */
#define HIL_SENSE_AUX_FLAG_THETA_ENC_VALID 0x02u /* bit1: theta_enc of this seq carries the plant's encoder angle; the per-cycle flag decides (set only in sessions whose HELLO had ENCODER_VALID, and clear in a cycle whose encoder the plant reports faulty) */

/* ---- CONFIG parameters: one multiplexed signal of CONFIG each (DBC attributes HilParamKind,
 * HilParamDefault, HilParamRequired, HilSince; range = the signal's [min|max], what the reference
 * drive accepts). Values travel as binary32 in CONFIG.value. ---- */
#define HIL_PARAM_KIND_REAL 0u
#define HIL_PARAM_KIND_INTEGER 1u
#define HIL_PARAM_KIND_BOOLEAN 2u
#define HIL_PARAM_KIND_ENUM 3u
/* RS_OHM (ohm): real */
#define HIL_PARAM_RS_OHM_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_RS_OHM_MIN 1e-06f
#define HIL_PARAM_RS_OHM_MAX 100.0f
#define HIL_PARAM_RS_OHM_REQUIRED 1u
#define HIL_PARAM_RS_OHM_DEFAULT 0.0f /* none: required */
#define HIL_PARAM_RS_OHM_SINCE_MINOR 0u
/* LD_H (H): real */
#define HIL_PARAM_LD_H_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_LD_H_MIN 1e-07f
#define HIL_PARAM_LD_H_MAX 10.0f
#define HIL_PARAM_LD_H_REQUIRED 1u
#define HIL_PARAM_LD_H_DEFAULT 0.0f /* none: required */
#define HIL_PARAM_LD_H_SINCE_MINOR 0u
/* LQ_H (H): real */
#define HIL_PARAM_LQ_H_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_LQ_H_MIN 1e-07f
#define HIL_PARAM_LQ_H_MAX 10.0f
#define HIL_PARAM_LQ_H_REQUIRED 1u
#define HIL_PARAM_LQ_H_DEFAULT 0.0f /* none: required */
#define HIL_PARAM_LQ_H_SINCE_MINOR 0u
/* PSI_F_WB (Wb): real */
#define HIL_PARAM_PSI_F_WB_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PSI_F_WB_MIN 1e-06f
#define HIL_PARAM_PSI_F_WB_MAX 100.0f
#define HIL_PARAM_PSI_F_WB_REQUIRED 1u
#define HIL_PARAM_PSI_F_WB_DEFAULT 0.0f /* none: required */
#define HIL_PARAM_PSI_F_WB_SINCE_MINOR 0u
/* POLE_PAIRS (-): integer */
#define HIL_PARAM_POLE_PAIRS_KIND HIL_PARAM_KIND_INTEGER
#define HIL_PARAM_POLE_PAIRS_MIN 1.0f
#define HIL_PARAM_POLE_PAIRS_MAX 64.0f
#define HIL_PARAM_POLE_PAIRS_REQUIRED 1u
#define HIL_PARAM_POLE_PAIRS_DEFAULT 0.0f /* none: required */
#define HIL_PARAM_POLE_PAIRS_SINCE_MINOR 0u
/* J_KGM2 (kg m^2): real */
#define HIL_PARAM_J_KGM2_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_J_KGM2_MIN 1e-09f
#define HIL_PARAM_J_KGM2_MAX 10000.0f
#define HIL_PARAM_J_KGM2_REQUIRED 1u
#define HIL_PARAM_J_KGM2_DEFAULT 0.0f /* none: required */
#define HIL_PARAM_J_KGM2_SINCE_MINOR 0u
/* B_NMS (N m s/rad): real */
#define HIL_PARAM_B_NMS_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_B_NMS_MIN 0.0f
#define HIL_PARAM_B_NMS_MAX 1000.0f
#define HIL_PARAM_B_NMS_REQUIRED 0u
#define HIL_PARAM_B_NMS_DEFAULT 0.0f
#define HIL_PARAM_B_NMS_SINCE_MINOR 0u
/* V_DC_NOM_V (V): real */
#define HIL_PARAM_V_DC_NOM_V_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_V_DC_NOM_V_MIN 1.0f
#define HIL_PARAM_V_DC_NOM_V_MAX 2000.0f
#define HIL_PARAM_V_DC_NOM_V_REQUIRED 1u
#define HIL_PARAM_V_DC_NOM_V_DEFAULT 0.0f /* none: required */
#define HIL_PARAM_V_DC_NOM_V_SINCE_MINOR 0u
/* CUR_KP_V_A (V/A): real */
#define HIL_PARAM_CUR_KP_V_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_CUR_KP_V_A_MIN 0.0f
#define HIL_PARAM_CUR_KP_V_A_MAX 10000.0f
#define HIL_PARAM_CUR_KP_V_A_REQUIRED 0u
#define HIL_PARAM_CUR_KP_V_A_DEFAULT 0.0f
#define HIL_PARAM_CUR_KP_V_A_SINCE_MINOR 0u
/* CUR_KI_V_AS (V/(A s)): real */
#define HIL_PARAM_CUR_KI_V_AS_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_CUR_KI_V_AS_MIN 0.0f
#define HIL_PARAM_CUR_KI_V_AS_MAX 100000000.0f
#define HIL_PARAM_CUR_KI_V_AS_REQUIRED 0u
#define HIL_PARAM_CUR_KI_V_AS_DEFAULT 0.0f
#define HIL_PARAM_CUR_KI_V_AS_SINCE_MINOR 0u
/* SPD_KP_A_RAD_S (A/(rad/s)): real */
#define HIL_PARAM_SPD_KP_A_RAD_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SPD_KP_A_RAD_S_MIN 0.0f
#define HIL_PARAM_SPD_KP_A_RAD_S_MAX 10000.0f
#define HIL_PARAM_SPD_KP_A_RAD_S_REQUIRED 0u
#define HIL_PARAM_SPD_KP_A_RAD_S_DEFAULT 0.0f
#define HIL_PARAM_SPD_KP_A_RAD_S_SINCE_MINOR 0u
/* SPD_KI_A_RAD (A/rad): real */
#define HIL_PARAM_SPD_KI_A_RAD_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SPD_KI_A_RAD_MIN 0.0f
#define HIL_PARAM_SPD_KI_A_RAD_MAX 1000000.0f
#define HIL_PARAM_SPD_KI_A_RAD_REQUIRED 0u
#define HIL_PARAM_SPD_KI_A_RAD_DEFAULT 0.0f
#define HIL_PARAM_SPD_KI_A_RAD_SINCE_MINOR 0u
/* IQ_MAX_A (A): real */
#define HIL_PARAM_IQ_MAX_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_IQ_MAX_A_MIN 0.0f
#define HIL_PARAM_IQ_MAX_A_MAX 1000.0f
#define HIL_PARAM_IQ_MAX_A_REQUIRED 0u
#define HIL_PARAM_IQ_MAX_A_DEFAULT 5.0f
#define HIL_PARAM_IQ_MAX_A_SINCE_MINOR 0u
/* SPEED_LOOP_DIV (-): integer */
#define HIL_PARAM_SPEED_LOOP_DIV_KIND HIL_PARAM_KIND_INTEGER
#define HIL_PARAM_SPEED_LOOP_DIV_MIN 1.0f
#define HIL_PARAM_SPEED_LOOP_DIV_MAX 1000.0f
#define HIL_PARAM_SPEED_LOOP_DIV_REQUIRED 0u
#define HIL_PARAM_SPEED_LOOP_DIV_DEFAULT 1.0f
#define HIL_PARAM_SPEED_LOOP_DIV_SINCE_MINOR 0u
/* I_MAX_TRIP_A (A): real */
#define HIL_PARAM_I_MAX_TRIP_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_I_MAX_TRIP_A_MIN 0.0f
#define HIL_PARAM_I_MAX_TRIP_A_MAX 1000.0f
#define HIL_PARAM_I_MAX_TRIP_A_REQUIRED 0u
#define HIL_PARAM_I_MAX_TRIP_A_DEFAULT 30.0f
#define HIL_PARAM_I_MAX_TRIP_A_SINCE_MINOR 0u
/* ALIGN_I_A (A): real */
#define HIL_PARAM_ALIGN_I_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_ALIGN_I_A_MIN 0.0f
#define HIL_PARAM_ALIGN_I_A_MAX 1000.0f
#define HIL_PARAM_ALIGN_I_A_REQUIRED 0u
#define HIL_PARAM_ALIGN_I_A_DEFAULT 2.0f
#define HIL_PARAM_ALIGN_I_A_SINCE_MINOR 0u
/* ALIGN_TIME_S (s): real */
#define HIL_PARAM_ALIGN_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_ALIGN_TIME_S_MIN 0.0f
#define HIL_PARAM_ALIGN_TIME_S_MAX 100.0f
#define HIL_PARAM_ALIGN_TIME_S_REQUIRED 0u
#define HIL_PARAM_ALIGN_TIME_S_DEFAULT 0.2f
#define HIL_PARAM_ALIGN_TIME_S_SINCE_MINOR 0u
/* IF_I_A (A): real */
#define HIL_PARAM_IF_I_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_IF_I_A_MIN 0.0f
#define HIL_PARAM_IF_I_A_MAX 1000.0f
#define HIL_PARAM_IF_I_A_REQUIRED 0u
#define HIL_PARAM_IF_I_A_DEFAULT 2.0f
#define HIL_PARAM_IF_I_A_SINCE_MINOR 0u
/* IF_ACCEL_RAD_S2 (rad/s^2): real */
#define HIL_PARAM_IF_ACCEL_RAD_S2_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_IF_ACCEL_RAD_S2_MIN 0.0f
#define HIL_PARAM_IF_ACCEL_RAD_S2_MAX 1000000.0f
#define HIL_PARAM_IF_ACCEL_RAD_S2_REQUIRED 0u
#define HIL_PARAM_IF_ACCEL_RAD_S2_DEFAULT 50.0f
#define HIL_PARAM_IF_ACCEL_RAD_S2_SINCE_MINOR 0u
/* HANDOVER_SPEED_RAD_S (rad/s): real */
#define HIL_PARAM_HANDOVER_SPEED_RAD_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HANDOVER_SPEED_RAD_S_MIN 0.0f
#define HIL_PARAM_HANDOVER_SPEED_RAD_S_MAX 100000.0f
#define HIL_PARAM_HANDOVER_SPEED_RAD_S_REQUIRED 0u
#define HIL_PARAM_HANDOVER_SPEED_RAD_S_DEFAULT 20.0f
#define HIL_PARAM_HANDOVER_SPEED_RAD_S_SINCE_MINOR 0u
/* HANDOVER_TIME_S (s): real */
#define HIL_PARAM_HANDOVER_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HANDOVER_TIME_S_MIN 0.0f
#define HIL_PARAM_HANDOVER_TIME_S_MAX 100.0f
#define HIL_PARAM_HANDOVER_TIME_S_REQUIRED 0u
#define HIL_PARAM_HANDOVER_TIME_S_DEFAULT 0.05f
#define HIL_PARAM_HANDOVER_TIME_S_SINCE_MINOR 0u
/* CTRL_DELAY_S (s): real */
#define HIL_PARAM_CTRL_DELAY_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_CTRL_DELAY_S_MIN 0.0f
#define HIL_PARAM_CTRL_DELAY_S_MAX 1.0f
#define HIL_PARAM_CTRL_DELAY_S_REQUIRED 0u
#define HIL_PARAM_CTRL_DELAY_S_DEFAULT 0.0f
#define HIL_PARAM_CTRL_DELAY_S_SINCE_MINOR 0u
/* LOOP_ANGLE (-): enum, 0 = the observer's EMF angle (atan2 of the estimated EMF, lag-compensated), 1 = the PLL's angle that tracks it (type 2; the EMF angle's noise filtered at the PLL's bandwidth) */
#define HIL_PARAM_LOOP_ANGLE_KIND HIL_PARAM_KIND_ENUM
#define HIL_PARAM_LOOP_ANGLE_MIN 0.0f
#define HIL_PARAM_LOOP_ANGLE_MAX 1.0f
#define HIL_PARAM_LOOP_ANGLE_REQUIRED 0u
#define HIL_PARAM_LOOP_ANGLE_DEFAULT 0.0f
#define HIL_PARAM_LOOP_ANGLE_SINCE_MINOR 1u
/* SMO_K_V (V): real */
#define HIL_PARAM_SMO_K_V_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SMO_K_V_MIN 0.0f
#define HIL_PARAM_SMO_K_V_MAX 10000.0f
#define HIL_PARAM_SMO_K_V_REQUIRED 0u
#define HIL_PARAM_SMO_K_V_DEFAULT 0.0f
#define HIL_PARAM_SMO_K_V_SINCE_MINOR 0u
/* SMO_WC_RAD_S (rad/s): real */
#define HIL_PARAM_SMO_WC_RAD_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SMO_WC_RAD_S_MIN 0.0f
#define HIL_PARAM_SMO_WC_RAD_S_MAX 1000000.0f
#define HIL_PARAM_SMO_WC_RAD_S_REQUIRED 0u
#define HIL_PARAM_SMO_WC_RAD_S_DEFAULT 1000.0f
#define HIL_PARAM_SMO_WC_RAD_S_SINCE_MINOR 0u
/* SMO_M_PER_A (1/A): real */
#define HIL_PARAM_SMO_M_PER_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SMO_M_PER_A_MIN 1e-06f
#define HIL_PARAM_SMO_M_PER_A_MAX 1000.0f
#define HIL_PARAM_SMO_M_PER_A_REQUIRED 0u
#define HIL_PARAM_SMO_M_PER_A_DEFAULT 0.01f
#define HIL_PARAM_SMO_M_PER_A_SINCE_MINOR 0u
/* SMO_SIGMOID_A_PER_A (1/A): real */
#define HIL_PARAM_SMO_SIGMOID_A_PER_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SMO_SIGMOID_A_PER_A_MIN 0.0f
#define HIL_PARAM_SMO_SIGMOID_A_PER_A_MAX 1000000.0f
#define HIL_PARAM_SMO_SIGMOID_A_PER_A_REQUIRED 0u
#define HIL_PARAM_SMO_SIGMOID_A_PER_A_DEFAULT 0.0f
#define HIL_PARAM_SMO_SIGMOID_A_PER_A_SINCE_MINOR 0u
/* PLL_KP (1/s): real */
#define HIL_PARAM_PLL_KP_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PLL_KP_MIN 0.0f
#define HIL_PARAM_PLL_KP_MAX 1000000.0f
#define HIL_PARAM_PLL_KP_REQUIRED 0u
#define HIL_PARAM_PLL_KP_DEFAULT 0.0f
#define HIL_PARAM_PLL_KP_SINCE_MINOR 0u
/* PLL_KI (1/s^2): real */
#define HIL_PARAM_PLL_KI_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PLL_KI_MIN 0.0f
#define HIL_PARAM_PLL_KI_MAX 10000000000.0f
#define HIL_PARAM_PLL_KI_REQUIRED 0u
#define HIL_PARAM_PLL_KI_DEFAULT 0.0f
#define HIL_PARAM_PLL_KI_SINCE_MINOR 0u
/* SPEED_LPF_RAD_S (rad/s): real */
#define HIL_PARAM_SPEED_LPF_RAD_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SPEED_LPF_RAD_S_MIN 0.0f
#define HIL_PARAM_SPEED_LPF_RAD_S_MAX 1000000.0f
#define HIL_PARAM_SPEED_LPF_RAD_S_REQUIRED 0u
#define HIL_PARAM_SPEED_LPF_RAD_S_DEFAULT 0.0f
#define HIL_PARAM_SPEED_LPF_RAD_S_SINCE_MINOR 0u
/* SMO_K_FACTOR (-): real */
#define HIL_PARAM_SMO_K_FACTOR_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SMO_K_FACTOR_MIN 0.0f
#define HIL_PARAM_SMO_K_FACTOR_MAX 100.0f
#define HIL_PARAM_SMO_K_FACTOR_REQUIRED 0u
#define HIL_PARAM_SMO_K_FACTOR_DEFAULT 1.5f
#define HIL_PARAM_SMO_K_FACTOR_SINCE_MINOR 0u
/* SMO_K_MIN_V (V): real */
#define HIL_PARAM_SMO_K_MIN_V_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SMO_K_MIN_V_MIN 0.0f
#define HIL_PARAM_SMO_K_MIN_V_MAX 10000.0f
#define HIL_PARAM_SMO_K_MIN_V_REQUIRED 0u
#define HIL_PARAM_SMO_K_MIN_V_DEFAULT 5.0f
#define HIL_PARAM_SMO_K_MIN_V_SINCE_MINOR 0u
/* SMO_LAG_COMP (-): enum, 0 = none, 1 = Yuan eq. 15, 2 = effective */
#define HIL_PARAM_SMO_LAG_COMP_KIND HIL_PARAM_KIND_ENUM
#define HIL_PARAM_SMO_LAG_COMP_MIN 0.0f
#define HIL_PARAM_SMO_LAG_COMP_MAX 2.0f
#define HIL_PARAM_SMO_LAG_COMP_REQUIRED 0u
#define HIL_PARAM_SMO_LAG_COMP_DEFAULT 1.0f
#define HIL_PARAM_SMO_LAG_COMP_SINCE_MINOR 0u
/* HFI_U_V (V): real */
#define HIL_PARAM_HFI_U_V_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HFI_U_V_MIN 0.0f
#define HIL_PARAM_HFI_U_V_MAX 1000.0f
#define HIL_PARAM_HFI_U_V_REQUIRED 0u
#define HIL_PARAM_HFI_U_V_DEFAULT 6.0f
#define HIL_PARAM_HFI_U_V_SINCE_MINOR 0u
/* HFI_F_HZ (Hz): real */
#define HIL_PARAM_HFI_F_HZ_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HFI_F_HZ_MIN 1.0f
#define HIL_PARAM_HFI_F_HZ_MAX 1000000.0f
#define HIL_PARAM_HFI_F_HZ_REQUIRED 0u
#define HIL_PARAM_HFI_F_HZ_DEFAULT 1250.0f
#define HIL_PARAM_HFI_F_HZ_SINCE_MINOR 0u
/* HFI_BW_RAD_S (rad/s): real */
#define HIL_PARAM_HFI_BW_RAD_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HFI_BW_RAD_S_MIN 1.0f
#define HIL_PARAM_HFI_BW_RAD_S_MAX 100000.0f
#define HIL_PARAM_HFI_BW_RAD_S_REQUIRED 0u
#define HIL_PARAM_HFI_BW_RAD_S_DEFAULT 150.0f
#define HIL_PARAM_HFI_BW_RAD_S_SINCE_MINOR 0u
/* HFI_PI_KP (1/s): real */
#define HIL_PARAM_HFI_PI_KP_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HFI_PI_KP_MIN 0.0f
#define HIL_PARAM_HFI_PI_KP_MAX 1000000.0f
#define HIL_PARAM_HFI_PI_KP_REQUIRED 0u
#define HIL_PARAM_HFI_PI_KP_DEFAULT 0.0f
#define HIL_PARAM_HFI_PI_KP_SINCE_MINOR 0u
/* HFI_PI_KI (1/s^2): real */
#define HIL_PARAM_HFI_PI_KI_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HFI_PI_KI_MIN 0.0f
#define HIL_PARAM_HFI_PI_KI_MAX 10000000000.0f
#define HIL_PARAM_HFI_PI_KI_REQUIRED 0u
#define HIL_PARAM_HFI_PI_KI_DEFAULT 0.0f
#define HIL_PARAM_HFI_PI_KI_SINCE_MINOR 0u
/* IPD_TIME_S (s): real */
#define HIL_PARAM_IPD_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_IPD_TIME_S_MIN 0.0f
#define HIL_PARAM_IPD_TIME_S_MAX 100.0f
#define HIL_PARAM_IPD_TIME_S_REQUIRED 0u
#define HIL_PARAM_IPD_TIME_S_DEFAULT 0.5f
#define HIL_PARAM_IPD_TIME_S_SINCE_MINOR 0u
/* HFI_POL_BIAS_A (A): real */
#define HIL_PARAM_HFI_POL_BIAS_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HFI_POL_BIAS_A_MIN 0.0f
#define HIL_PARAM_HFI_POL_BIAS_A_MAX 1000.0f
#define HIL_PARAM_HFI_POL_BIAS_A_REQUIRED 0u
#define HIL_PARAM_HFI_POL_BIAS_A_DEFAULT 0.0f
#define HIL_PARAM_HFI_POL_BIAS_A_SINCE_MINOR 0u
/* HFI_LOCK_TOL_RAD (rad): real */
#define HIL_PARAM_HFI_LOCK_TOL_RAD_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HFI_LOCK_TOL_RAD_MIN 0.0001f
#define HIL_PARAM_HFI_LOCK_TOL_RAD_MAX 1.0f
#define HIL_PARAM_HFI_LOCK_TOL_RAD_REQUIRED 0u
#define HIL_PARAM_HFI_LOCK_TOL_RAD_DEFAULT 0.05f
#define HIL_PARAM_HFI_LOCK_TOL_RAD_SINCE_MINOR 0u
/* DELAY_COMP_ENABLE (-): enum, 0 = off, 1 = with DELAY_COMP_TD_S, 2 = t_d estimated from the dual samples */
#define HIL_PARAM_DELAY_COMP_ENABLE_KIND HIL_PARAM_KIND_ENUM
#define HIL_PARAM_DELAY_COMP_ENABLE_MIN 0.0f
#define HIL_PARAM_DELAY_COMP_ENABLE_MAX 2.0f
#define HIL_PARAM_DELAY_COMP_ENABLE_REQUIRED 0u
#define HIL_PARAM_DELAY_COMP_ENABLE_DEFAULT 0.0f
#define HIL_PARAM_DELAY_COMP_ENABLE_SINCE_MINOR 0u
/* DELAY_COMP_TD_S (s): real */
#define HIL_PARAM_DELAY_COMP_TD_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_DELAY_COMP_TD_S_MIN 0.0f
#define HIL_PARAM_DELAY_COMP_TD_S_MAX 1.0f
#define HIL_PARAM_DELAY_COMP_TD_S_REQUIRED 0u
#define HIL_PARAM_DELAY_COMP_TD_S_DEFAULT 0.0f
#define HIL_PARAM_DELAY_COMP_TD_S_SINCE_MINOR 0u
/* HARM_COMP_ENABLE (-): boolean */
#define HIL_PARAM_HARM_COMP_ENABLE_KIND HIL_PARAM_KIND_BOOLEAN
#define HIL_PARAM_HARM_COMP_ENABLE_MIN 0.0f
#define HIL_PARAM_HARM_COMP_ENABLE_MAX 1.0f
#define HIL_PARAM_HARM_COMP_ENABLE_REQUIRED 0u
#define HIL_PARAM_HARM_COMP_ENABLE_DEFAULT 0.0f
#define HIL_PARAM_HARM_COMP_ENABLE_SINCE_MINOR 0u
/* HARM_GSDFT_M (-): integer */
#define HIL_PARAM_HARM_GSDFT_M_KIND HIL_PARAM_KIND_INTEGER
#define HIL_PARAM_HARM_GSDFT_M_MIN 6.0f
#define HIL_PARAM_HARM_GSDFT_M_MAX 96.0f
#define HIL_PARAM_HARM_GSDFT_M_REQUIRED 0u
#define HIL_PARAM_HARM_GSDFT_M_DEFAULT 96.0f
#define HIL_PARAM_HARM_GSDFT_M_SINCE_MINOR 0u
/* HARM_COMP_GAIN (-): real */
#define HIL_PARAM_HARM_COMP_GAIN_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_HARM_COMP_GAIN_MIN 0.0f
#define HIL_PARAM_HARM_COMP_GAIN_MAX 10.0f
#define HIL_PARAM_HARM_COMP_GAIN_REQUIRED 0u
#define HIL_PARAM_HARM_COMP_GAIN_DEFAULT 1.0f
#define HIL_PARAM_HARM_COMP_GAIN_SINCE_MINOR 0u
/* HARM_EXTRACTOR (-): enum, 0 = GSDFT, 1 = SDFT */
#define HIL_PARAM_HARM_EXTRACTOR_KIND HIL_PARAM_KIND_ENUM
#define HIL_PARAM_HARM_EXTRACTOR_MIN 0.0f
#define HIL_PARAM_HARM_EXTRACTOR_MAX 1.0f
#define HIL_PARAM_HARM_EXTRACTOR_REQUIRED 0u
#define HIL_PARAM_HARM_EXTRACTOR_DEFAULT 0.0f
#define HIL_PARAM_HARM_EXTRACTOR_SINCE_MINOR 0u
/* PROT_OPEN_I_MIN_A (A): real */
#define HIL_PARAM_PROT_OPEN_I_MIN_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_OPEN_I_MIN_A_MIN 0.0f
#define HIL_PARAM_PROT_OPEN_I_MIN_A_MAX 1000.0f
#define HIL_PARAM_PROT_OPEN_I_MIN_A_REQUIRED 0u
#define HIL_PARAM_PROT_OPEN_I_MIN_A_DEFAULT 1.0f
#define HIL_PARAM_PROT_OPEN_I_MIN_A_SINCE_MINOR 0u
/* PROT_OPEN_RATIO (-): real */
#define HIL_PARAM_PROT_OPEN_RATIO_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_OPEN_RATIO_MIN 0.0f
#define HIL_PARAM_PROT_OPEN_RATIO_MAX 1.0f
#define HIL_PARAM_PROT_OPEN_RATIO_REQUIRED 0u
#define HIL_PARAM_PROT_OPEN_RATIO_DEFAULT 0.2f
#define HIL_PARAM_PROT_OPEN_RATIO_SINCE_MINOR 0u
/* PROT_OPEN_TIME_S (s): real */
#define HIL_PARAM_PROT_OPEN_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_OPEN_TIME_S_MIN 0.0f
#define HIL_PARAM_PROT_OPEN_TIME_S_MAX 100.0f
#define HIL_PARAM_PROT_OPEN_TIME_S_REQUIRED 0u
#define HIL_PARAM_PROT_OPEN_TIME_S_DEFAULT 0.02f
#define HIL_PARAM_PROT_OPEN_TIME_S_SINCE_MINOR 0u
/* PROT_SUM_MAX_A (A): real */
#define HIL_PARAM_PROT_SUM_MAX_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_SUM_MAX_A_MIN 0.0f
#define HIL_PARAM_PROT_SUM_MAX_A_MAX 1000.0f
#define HIL_PARAM_PROT_SUM_MAX_A_REQUIRED 0u
#define HIL_PARAM_PROT_SUM_MAX_A_DEFAULT 1.0f
#define HIL_PARAM_PROT_SUM_MAX_A_SINCE_MINOR 0u
/* PROT_SUM_TAU_S (s): real */
#define HIL_PARAM_PROT_SUM_TAU_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_SUM_TAU_S_MIN 0.0f
#define HIL_PARAM_PROT_SUM_TAU_S_MAX 10.0f
#define HIL_PARAM_PROT_SUM_TAU_S_REQUIRED 0u
#define HIL_PARAM_PROT_SUM_TAU_S_DEFAULT 0.005f
#define HIL_PARAM_PROT_SUM_TAU_S_SINCE_MINOR 0u
/* PROT_STUCK_TIME_S (s): real */
#define HIL_PARAM_PROT_STUCK_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_STUCK_TIME_S_MIN 0.0f
#define HIL_PARAM_PROT_STUCK_TIME_S_MAX 100.0f
#define HIL_PARAM_PROT_STUCK_TIME_S_REQUIRED 0u
#define HIL_PARAM_PROT_STUCK_TIME_S_DEFAULT 0.1f
#define HIL_PARAM_PROT_STUCK_TIME_S_SINCE_MINOR 0u
/* PROT_STUCK_DELTA_A (A): real */
#define HIL_PARAM_PROT_STUCK_DELTA_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_STUCK_DELTA_A_MIN 0.0f
#define HIL_PARAM_PROT_STUCK_DELTA_A_MAX 1000.0f
#define HIL_PARAM_PROT_STUCK_DELTA_A_REQUIRED 0u
#define HIL_PARAM_PROT_STUCK_DELTA_A_DEFAULT 0.5f
#define HIL_PARAM_PROT_STUCK_DELTA_A_SINCE_MINOR 0u
/* PROT_VDC_UV_RATIO (-): real */
#define HIL_PARAM_PROT_VDC_UV_RATIO_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_VDC_UV_RATIO_MIN 0.0f
#define HIL_PARAM_PROT_VDC_UV_RATIO_MAX 1.0f
#define HIL_PARAM_PROT_VDC_UV_RATIO_REQUIRED 0u
#define HIL_PARAM_PROT_VDC_UV_RATIO_DEFAULT 0.7f
#define HIL_PARAM_PROT_VDC_UV_RATIO_SINCE_MINOR 0u
/* PROT_VDC_OV_RATIO (-): real */
#define HIL_PARAM_PROT_VDC_OV_RATIO_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_VDC_OV_RATIO_MIN 0.0f
#define HIL_PARAM_PROT_VDC_OV_RATIO_MAX 10.0f
#define HIL_PARAM_PROT_VDC_OV_RATIO_REQUIRED 0u
#define HIL_PARAM_PROT_VDC_OV_RATIO_DEFAULT 1.25f
#define HIL_PARAM_PROT_VDC_OV_RATIO_SINCE_MINOR 0u
/* PROT_VDC_TIME_S (s): real */
#define HIL_PARAM_PROT_VDC_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_VDC_TIME_S_MIN 0.0f
#define HIL_PARAM_PROT_VDC_TIME_S_MAX 10.0f
#define HIL_PARAM_PROT_VDC_TIME_S_REQUIRED 0u
#define HIL_PARAM_PROT_VDC_TIME_S_DEFAULT 0.001f
#define HIL_PARAM_PROT_VDC_TIME_S_SINCE_MINOR 0u
/* PROT_LINK_TIMEOUT_PERIODS (periods): integer */
#define HIL_PARAM_PROT_LINK_TIMEOUT_PERIODS_KIND HIL_PARAM_KIND_INTEGER
#define HIL_PARAM_PROT_LINK_TIMEOUT_PERIODS_MIN 0.0f
#define HIL_PARAM_PROT_LINK_TIMEOUT_PERIODS_MAX 1000000.0f
#define HIL_PARAM_PROT_LINK_TIMEOUT_PERIODS_REQUIRED 0u
#define HIL_PARAM_PROT_LINK_TIMEOUT_PERIODS_DEFAULT 10.0f
#define HIL_PARAM_PROT_LINK_TIMEOUT_PERIODS_SINCE_MINOR 0u
/* PROT_ENC_LOST_TIME_S (s): real */
#define HIL_PARAM_PROT_ENC_LOST_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_ENC_LOST_TIME_S_MIN 0.0f
#define HIL_PARAM_PROT_ENC_LOST_TIME_S_MAX 10.0f
#define HIL_PARAM_PROT_ENC_LOST_TIME_S_REQUIRED 0u
#define HIL_PARAM_PROT_ENC_LOST_TIME_S_DEFAULT 0.001f
#define HIL_PARAM_PROT_ENC_LOST_TIME_S_SINCE_MINOR 0u
/* PROT_ENC_EMF_RATIO (-): real */
#define HIL_PARAM_PROT_ENC_EMF_RATIO_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_ENC_EMF_RATIO_MIN 0.0f
#define HIL_PARAM_PROT_ENC_EMF_RATIO_MAX 10.0f
#define HIL_PARAM_PROT_ENC_EMF_RATIO_REQUIRED 0u
#define HIL_PARAM_PROT_ENC_EMF_RATIO_DEFAULT 0.1f
#define HIL_PARAM_PROT_ENC_EMF_RATIO_SINCE_MINOR 0u
/* PROT_ENC_FROZEN_TIME_S (s): real */
#define HIL_PARAM_PROT_ENC_FROZEN_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_ENC_FROZEN_TIME_S_MIN 0.0f
#define HIL_PARAM_PROT_ENC_FROZEN_TIME_S_MAX 10.0f
#define HIL_PARAM_PROT_ENC_FROZEN_TIME_S_REQUIRED 0u
#define HIL_PARAM_PROT_ENC_FROZEN_TIME_S_DEFAULT 0.002f
#define HIL_PARAM_PROT_ENC_FROZEN_TIME_S_SINCE_MINOR 0u
/* PROT_STALL_TIME_S (s): real */
#define HIL_PARAM_PROT_STALL_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_STALL_TIME_S_MIN 0.0f
#define HIL_PARAM_PROT_STALL_TIME_S_MAX 100.0f
#define HIL_PARAM_PROT_STALL_TIME_S_REQUIRED 0u
#define HIL_PARAM_PROT_STALL_TIME_S_DEFAULT 0.1f
#define HIL_PARAM_PROT_STALL_TIME_S_SINCE_MINOR 0u
/* PROT_STALL_SPEED_RAD_S (rad/s): real */
#define HIL_PARAM_PROT_STALL_SPEED_RAD_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_PROT_STALL_SPEED_RAD_S_MIN 0.0f
#define HIL_PARAM_PROT_STALL_SPEED_RAD_S_MAX 100000.0f
#define HIL_PARAM_PROT_STALL_SPEED_RAD_S_REQUIRED 0u
#define HIL_PARAM_PROT_STALL_SPEED_RAD_S_DEFAULT 1.0f
#define HIL_PARAM_PROT_STALL_SPEED_RAD_S_SINCE_MINOR 0u
/* SMO_STA_K1_V (V/A^0.5): real */
#define HIL_PARAM_SMO_STA_K1_V_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SMO_STA_K1_V_MIN 0.0f
#define HIL_PARAM_SMO_STA_K1_V_MAX 100000.0f
#define HIL_PARAM_SMO_STA_K1_V_REQUIRED 0u
#define HIL_PARAM_SMO_STA_K1_V_DEFAULT 0.0f
#define HIL_PARAM_SMO_STA_K1_V_SINCE_MINOR 1u
/* SMO_STA_K2_V_S (V/s): real */
#define HIL_PARAM_SMO_STA_K2_V_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_SMO_STA_K2_V_S_MIN 0.0f
#define HIL_PARAM_SMO_STA_K2_V_S_MAX 1000000000.0f
#define HIL_PARAM_SMO_STA_K2_V_S_REQUIRED 0u
#define HIL_PARAM_SMO_STA_K2_V_S_DEFAULT 0.0f
#define HIL_PARAM_SMO_STA_K2_V_S_SINCE_MINOR 1u
/* INV_COMP_ENABLE (-): enum, 0 = off, 1 = on, currents extrapolated to the middle of the interval the duties act on, 2 = on, sampled currents, 3 = on, the current loop's reference currents, 4 = on, current-vector method: the measured vector low-passed in the rotating frame (with HF injection plus the injection's current, predicted at its frequency) */
#define HIL_PARAM_INV_COMP_ENABLE_KIND HIL_PARAM_KIND_ENUM
#define HIL_PARAM_INV_COMP_ENABLE_MIN 0.0f
#define HIL_PARAM_INV_COMP_ENABLE_MAX 4.0f
#define HIL_PARAM_INV_COMP_ENABLE_REQUIRED 0u
#define HIL_PARAM_INV_COMP_ENABLE_DEFAULT 0.0f
#define HIL_PARAM_INV_COMP_ENABLE_SINCE_MINOR 1u
/* INV_COMP_DEAD_TIME_S (s): real */
#define HIL_PARAM_INV_COMP_DEAD_TIME_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_INV_COMP_DEAD_TIME_S_MIN 0.0f
#define HIL_PARAM_INV_COMP_DEAD_TIME_S_MAX 0.001f
#define HIL_PARAM_INV_COMP_DEAD_TIME_S_REQUIRED 0u
#define HIL_PARAM_INV_COMP_DEAD_TIME_S_DEFAULT 0.0f
#define HIL_PARAM_INV_COMP_DEAD_TIME_S_SINCE_MINOR 1u
/* INV_COMP_V_SWITCH_V (V): real */
#define HIL_PARAM_INV_COMP_V_SWITCH_V_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_INV_COMP_V_SWITCH_V_MIN 0.0f
#define HIL_PARAM_INV_COMP_V_SWITCH_V_MAX 50.0f
#define HIL_PARAM_INV_COMP_V_SWITCH_V_REQUIRED 0u
#define HIL_PARAM_INV_COMP_V_SWITCH_V_DEFAULT 0.0f
#define HIL_PARAM_INV_COMP_V_SWITCH_V_SINCE_MINOR 1u
/* INV_COMP_R_SWITCH_OHM (ohm): real */
#define HIL_PARAM_INV_COMP_R_SWITCH_OHM_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_INV_COMP_R_SWITCH_OHM_MIN 0.0f
#define HIL_PARAM_INV_COMP_R_SWITCH_OHM_MAX 10.0f
#define HIL_PARAM_INV_COMP_R_SWITCH_OHM_REQUIRED 0u
#define HIL_PARAM_INV_COMP_R_SWITCH_OHM_DEFAULT 0.0f
#define HIL_PARAM_INV_COMP_R_SWITCH_OHM_SINCE_MINOR 1u
/* INV_COMP_V_DIODE_V (V): real */
#define HIL_PARAM_INV_COMP_V_DIODE_V_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_INV_COMP_V_DIODE_V_MIN 0.0f
#define HIL_PARAM_INV_COMP_V_DIODE_V_MAX 50.0f
#define HIL_PARAM_INV_COMP_V_DIODE_V_REQUIRED 0u
#define HIL_PARAM_INV_COMP_V_DIODE_V_DEFAULT 0.0f
#define HIL_PARAM_INV_COMP_V_DIODE_V_SINCE_MINOR 1u
/* INV_COMP_R_DIODE_OHM (ohm): real */
#define HIL_PARAM_INV_COMP_R_DIODE_OHM_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_INV_COMP_R_DIODE_OHM_MIN 0.0f
#define HIL_PARAM_INV_COMP_R_DIODE_OHM_MAX 10.0f
#define HIL_PARAM_INV_COMP_R_DIODE_OHM_REQUIRED 0u
#define HIL_PARAM_INV_COMP_R_DIODE_OHM_DEFAULT 0.0f
#define HIL_PARAM_INV_COMP_R_DIODE_OHM_SINCE_MINOR 1u
/* INV_COMP_BAND_A (A): real */
#define HIL_PARAM_INV_COMP_BAND_A_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_INV_COMP_BAND_A_MIN 1e-06f
#define HIL_PARAM_INV_COMP_BAND_A_MAX 1000.0f
#define HIL_PARAM_INV_COMP_BAND_A_REQUIRED 0u
#define HIL_PARAM_INV_COMP_BAND_A_DEFAULT 0.1f
#define HIL_PARAM_INV_COMP_BAND_A_SINCE_MINOR 1u
/* INV_COMP_SHAPE (-): enum, 0 = linear band, 1 = capacitive commutation (the plant's model) */
#define HIL_PARAM_INV_COMP_SHAPE_KIND HIL_PARAM_KIND_ENUM
#define HIL_PARAM_INV_COMP_SHAPE_MIN 0.0f
#define HIL_PARAM_INV_COMP_SHAPE_MAX 1.0f
#define HIL_PARAM_INV_COMP_SHAPE_REQUIRED 0u
#define HIL_PARAM_INV_COMP_SHAPE_DEFAULT 1.0f
#define HIL_PARAM_INV_COMP_SHAPE_SINCE_MINOR 1u
/* INV_COMP_I_BW_RAD_S (rad/s): real */
#define HIL_PARAM_INV_COMP_I_BW_RAD_S_KIND HIL_PARAM_KIND_REAL
#define HIL_PARAM_INV_COMP_I_BW_RAD_S_MIN 1.0f
#define HIL_PARAM_INV_COMP_I_BW_RAD_S_MAX 100000.0f
#define HIL_PARAM_INV_COMP_I_BW_RAD_S_REQUIRED 0u
#define HIL_PARAM_INV_COMP_I_BW_RAD_S_DEFAULT 628.3f
#define HIL_PARAM_INV_COMP_I_BW_RAD_S_SINCE_MINOR 1u

/* ---- FAULT_PLANT: 0x010, 8 octets, sent by PLANT ---- */
/* Fault raised by the plant side (host). code: see value table. */
#define HIL_FAULT_PLANT_FRAME_ID 0x010u
#define HIL_FAULT_PLANT_LENGTH 8u
typedef struct {
    uint16_t code; /* physical = raw; DBC [0, 65535] = raw 0..65535; 0 = NONE, 1 = LINK_TIMEOUT, 2 = CRC_ERRORS, 3 = BAD_SEQUENCE, 4 = OVERCURRENT, 5 = INVALID_DUTY, 6 = PROTOCOL_VERSION, 7 = WATCHDOG, 8 = CONFIG_INVALID, 9 = OVERVOLTAGE, 10 = STARTUP_FAILED, 11 = UNKNOWN_MESSAGE, 12 = BUS_BUDGET, 13 = HOST_ABORT, 14 = OPEN_PHASE, 15 = UNDERVOLTAGE, 16 = SENSOR_FAULT, 17 = STALL */
    uint16_t seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    int32_t detail; /* physical = raw; DBC [-2147483648, 2147483647] = raw -2147483648..2147483647 */
} hil_fault_plant_t;
int hil_fault_plant_pack(hil_octet_t *dst, const hil_fault_plant_t *src, size_t size);
int hil_fault_plant_unpack(hil_fault_plant_t *dst, const hil_octet_t *src, size_t size);
#define HIL_FAULT_PLANT_CODE_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_FAULT_PLANT_CODE_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_fault_plant_code_encode(float value);
float hil_fault_plant_code_decode(uint16_t raw);
int hil_fault_plant_code_is_in_range(uint16_t raw);
#define HIL_FAULT_PLANT_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_FAULT_PLANT_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_fault_plant_seq_encode(float value);
float hil_fault_plant_seq_decode(uint16_t raw);
int hil_fault_plant_seq_is_in_range(uint16_t raw);
#define HIL_FAULT_PLANT_DETAIL_RAW_MIN ((int32_t)(-INT32_C(2147483647) - 1))
#define HIL_FAULT_PLANT_DETAIL_RAW_MAX ((int32_t)INT32_C(2147483647))
int32_t hil_fault_plant_detail_encode(float value);
float hil_fault_plant_detail_decode(int32_t raw);
int hil_fault_plant_detail_is_in_range(int32_t raw);

/* ---- FAULT_CTRL: 0x011, 8 octets, sent by CTRL ---- */
/* Fault raised by the controller; ends the run. code: see value table. */
#define HIL_FAULT_CTRL_FRAME_ID 0x011u
#define HIL_FAULT_CTRL_LENGTH 8u
typedef struct {
    uint16_t code; /* physical = raw; DBC [0, 65535] = raw 0..65535; 0 = NONE, 1 = LINK_TIMEOUT, 2 = CRC_ERRORS, 3 = BAD_SEQUENCE, 4 = OVERCURRENT, 5 = INVALID_DUTY, 6 = PROTOCOL_VERSION, 7 = WATCHDOG, 8 = CONFIG_INVALID, 9 = OVERVOLTAGE, 10 = STARTUP_FAILED, 11 = UNKNOWN_MESSAGE, 12 = BUS_BUDGET, 13 = HOST_ABORT, 14 = OPEN_PHASE, 15 = UNDERVOLTAGE, 16 = SENSOR_FAULT, 17 = STALL */
    uint16_t seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    int32_t detail; /* physical = raw; DBC [-2147483648, 2147483647] = raw -2147483648..2147483647 */
} hil_fault_ctrl_t;
int hil_fault_ctrl_pack(hil_octet_t *dst, const hil_fault_ctrl_t *src, size_t size);
int hil_fault_ctrl_unpack(hil_fault_ctrl_t *dst, const hil_octet_t *src, size_t size);
#define HIL_FAULT_CTRL_CODE_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_FAULT_CTRL_CODE_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_fault_ctrl_code_encode(float value);
float hil_fault_ctrl_code_decode(uint16_t raw);
int hil_fault_ctrl_code_is_in_range(uint16_t raw);
#define HIL_FAULT_CTRL_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_FAULT_CTRL_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_fault_ctrl_seq_encode(float value);
float hil_fault_ctrl_seq_decode(uint16_t raw);
int hil_fault_ctrl_seq_is_in_range(uint16_t raw);
#define HIL_FAULT_CTRL_DETAIL_RAW_MIN ((int32_t)(-INT32_C(2147483647) - 1))
#define HIL_FAULT_CTRL_DETAIL_RAW_MAX ((int32_t)INT32_C(2147483647))
int32_t hil_fault_ctrl_detail_encode(float value);
float hil_fault_ctrl_detail_decode(int32_t raw);
int hil_fault_ctrl_detail_is_in_range(int32_t raw);

/* ---- HELLO: 0x020, 8 octets, sent by PLANT ---- */
/* Handshake request. Host sends it every 100 ms until the HELLO_ACK echoing its session arrives. */
#define HIL_HELLO_FRAME_ID 0x020u
#define HIL_HELLO_LENGTH 8u
typedef struct {
    uint16_t proto_version; /* physical = raw; DBC [0, 255] = raw 0..255 */
    uint16_t mode; /* physical = raw; DBC [0, 1] = raw 0..1; 0 = LOCKSTEP, 1 = REALTIME */
    uint16_t period_us; /* physical = raw * 0.1 us; DBC [0, 6553.5] = raw 0..65535 */
    uint16_t estimator; /* physical = raw; DBC [0, 255] = raw 0..255; 0 = NONE, 1 = SMO_SIGN, 2 = SMO_SIGMOID, 3 = SMO_TANH, 4 = HFI_SDFT, 5 = ENCODER, 6 = SMO_STA */
    uint16_t flags; /* physical = raw; DBC [0, 15] = raw 0..15; 0 = NONE, 1 = DUAL_SAMPLING, 2 = TELEM_EMF, 3 = DUAL_SAMPLING+TELEM_EMF, 4 = ENCODER_VALID, 5 = DUAL_SAMPLING+ENCODER_VALID, 6 = TELEM_EMF+ENCODER_VALID, 7 = DUAL_SAMPLING+TELEM_EMF+ENCODER_VALID */
    uint16_t proto_minor; /* physical = raw; DBC [0, 15] = raw 0..15 */
    uint16_t session; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
} hil_hello_t;
int hil_hello_pack(hil_octet_t *dst, const hil_hello_t *src, size_t size);
int hil_hello_unpack(hil_hello_t *dst, const hil_octet_t *src, size_t size);
#define HIL_HELLO_PROTO_VERSION_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_PROTO_VERSION_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_hello_proto_version_encode(float value);
float hil_hello_proto_version_decode(uint16_t raw);
int hil_hello_proto_version_is_in_range(uint16_t raw);
#define HIL_HELLO_MODE_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_MODE_RAW_MAX ((uint16_t)UINT32_C(1))
uint16_t hil_hello_mode_encode(float value);
float hil_hello_mode_decode(uint16_t raw);
int hil_hello_mode_is_in_range(uint16_t raw);
#define HIL_HELLO_PERIOD_US_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_PERIOD_US_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_hello_period_us_encode(float value);
float hil_hello_period_us_decode(uint16_t raw);
int hil_hello_period_us_is_in_range(uint16_t raw);
#define HIL_HELLO_ESTIMATOR_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_ESTIMATOR_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_hello_estimator_encode(float value);
float hil_hello_estimator_decode(uint16_t raw);
int hil_hello_estimator_is_in_range(uint16_t raw);
#define HIL_HELLO_FLAGS_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_FLAGS_RAW_MAX ((uint16_t)UINT32_C(15))
uint16_t hil_hello_flags_encode(float value);
float hil_hello_flags_decode(uint16_t raw);
int hil_hello_flags_is_in_range(uint16_t raw);
#define HIL_HELLO_PROTO_MINOR_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_PROTO_MINOR_RAW_MAX ((uint16_t)UINT32_C(15))
uint16_t hil_hello_proto_minor_encode(float value);
float hil_hello_proto_minor_decode(uint16_t raw);
int hil_hello_proto_minor_is_in_range(uint16_t raw);
#define HIL_HELLO_SESSION_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_SESSION_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_hello_session_encode(float value);
float hil_hello_session_decode(uint16_t raw);
int hil_hello_session_is_in_range(uint16_t raw);

/* ---- HELLO_ACK: 0x021, 8 octets, sent by CTRL ---- */
/* Handshake answer to every HELLO. status 0 = accepted. */
#define HIL_HELLO_ACK_FRAME_ID 0x021u
#define HIL_HELLO_ACK_LENGTH 8u
typedef struct {
    uint16_t proto_version; /* physical = raw; DBC [0, 255] = raw 0..255 */
    uint16_t status; /* physical = raw; DBC [0, 15] = raw 0..15; 0 = OK, 1 = VERSION_MISMATCH, 2 = ESTIMATOR_UNSUPPORTED, 3 = BUSY, 4 = PERIOD_UNSUPPORTED, 5 = MODE_UNSUPPORTED */
    uint16_t proto_minor; /* physical = raw; DBC [0, 15] = raw 0..15 */
    uint16_t fw_version; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t estimators; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t session; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
} hil_hello_ack_t;
int hil_hello_ack_pack(hil_octet_t *dst, const hil_hello_ack_t *src, size_t size);
int hil_hello_ack_unpack(hil_hello_ack_t *dst, const hil_octet_t *src, size_t size);
#define HIL_HELLO_ACK_PROTO_VERSION_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_ACK_PROTO_VERSION_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_hello_ack_proto_version_encode(float value);
float hil_hello_ack_proto_version_decode(uint16_t raw);
int hil_hello_ack_proto_version_is_in_range(uint16_t raw);
#define HIL_HELLO_ACK_STATUS_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_ACK_STATUS_RAW_MAX ((uint16_t)UINT32_C(15))
uint16_t hil_hello_ack_status_encode(float value);
float hil_hello_ack_status_decode(uint16_t raw);
int hil_hello_ack_status_is_in_range(uint16_t raw);
#define HIL_HELLO_ACK_PROTO_MINOR_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_ACK_PROTO_MINOR_RAW_MAX ((uint16_t)UINT32_C(15))
uint16_t hil_hello_ack_proto_minor_encode(float value);
float hil_hello_ack_proto_minor_decode(uint16_t raw);
int hil_hello_ack_proto_minor_is_in_range(uint16_t raw);
#define HIL_HELLO_ACK_FW_VERSION_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_ACK_FW_VERSION_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_hello_ack_fw_version_encode(float value);
float hil_hello_ack_fw_version_decode(uint16_t raw);
int hil_hello_ack_fw_version_is_in_range(uint16_t raw);
#define HIL_HELLO_ACK_ESTIMATORS_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_ACK_ESTIMATORS_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_hello_ack_estimators_encode(float value);
float hil_hello_ack_estimators_decode(uint16_t raw);
int hil_hello_ack_estimators_is_in_range(uint16_t raw);
#define HIL_HELLO_ACK_SESSION_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HELLO_ACK_SESSION_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_hello_ack_session_encode(float value);
float hil_hello_ack_session_decode(uint16_t raw);
int hil_hello_ack_session_is_in_range(uint16_t raw);

/* ---- CONFIG: 0x030, 8 octets, sent by PLANT ---- */
/* Set one controller parameter (SI units, see param_id table). Only accepted while the controller is IDLE, STOPPED or FAULT (otherwise CONFIG_ACK status LOCKED). */
#define HIL_CONFIG_FRAME_ID 0x030u
#define HIL_CONFIG_LENGTH 8u
typedef struct {
    uint16_t param_id; /* physical = raw; DBC [0, 65535] = raw 0..65535; 1 = RS_OHM, 2 = LD_H, 3 = LQ_H, 4 = PSI_F_WB, 5 = POLE_PAIRS, 6 = J_KGM2, 7 = B_NMS, 8 = V_DC_NOM_V, 20 = CUR_KP_V_A, 21 = CUR_KI_V_AS, 22 = SPD_KP_A_RAD_S, 23 = SPD_KI_A_RAD, 24 = IQ_MAX_A, 25 = SPEED_LOOP_DIV, 26 = I_MAX_TRIP_A, 30 = ALIGN_I_A, 31 = ALIGN_TIME_S, 32 = IF_I_A, 33 = IF_ACCEL_RAD_S2, 34 = HANDOVER_SPEED_RAD_S, 35 = HANDOVER_TIME_S, 36 = CTRL_DELAY_S, 37 = LOOP_ANGLE, 40 = SMO_K_V, 41 = SMO_WC_RAD_S, 42 = SMO_M_PER_A, 43 = SMO_SIGMOID_A_PER_A, 44 = PLL_KP, 45 = PLL_KI, 46 = SPEED_LPF_RAD_S, 47 = SMO_K_FACTOR, 48 = SMO_K_MIN_V, 49 = SMO_LAG_COMP, 50 = HFI_U_V, 51 = HFI_F_HZ, 52 = HFI_BW_RAD_S, 53 = HFI_PI_KP, 54 = HFI_PI_KI, 55 = IPD_TIME_S, 56 = HFI_POL_BIAS_A, 57 = HFI_LOCK_TOL_RAD, 60 = DELAY_COMP_ENABLE, 61 = DELAY_COMP_TD_S, 62 = HARM_COMP_ENABLE, 63 = HARM_GSDFT_M, 64 = HARM_COMP_GAIN, 65 = HARM_EXTRACTOR, 70 = PROT_OPEN_I_MIN_A, 71 = PROT_OPEN_RATIO, 72 = PROT_OPEN_TIME_S, 73 = PROT_SUM_MAX_A, 74 = PROT_SUM_TAU_S, 75 = PROT_STUCK_TIME_S, 76 = PROT_STUCK_DELTA_A, 77 = PROT_VDC_UV_RATIO, 78 = PROT_VDC_OV_RATIO, 79 = PROT_VDC_TIME_S, 80 = PROT_LINK_TIMEOUT_PERIODS, 81 = PROT_ENC_LOST_TIME_S, 82 = PROT_ENC_EMF_RATIO, 83 = PROT_ENC_FROZEN_TIME_S, 84 = PROT_STALL_TIME_S, 85 = PROT_STALL_SPEED_RAD_S, 86 = SMO_STA_K1_V, 87 = SMO_STA_K2_V_S, 90 = INV_COMP_ENABLE, 91 = INV_COMP_DEAD_TIME_S, 92 = INV_COMP_V_SWITCH_V, 93 = INV_COMP_R_SWITCH_OHM, 94 = INV_COMP_V_DIODE_V, 95 = INV_COMP_R_DIODE_OHM, 96 = INV_COMP_BAND_A, 97 = INV_COMP_SHAPE, 98 = INV_COMP_I_BW_RAD_S */
    uint16_t config_seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    float value; /* IEEE binary32, DBC range [-3.4e+38, 3.4e+38] */
} hil_config_t;
int hil_config_pack(hil_octet_t *dst, const hil_config_t *src, size_t size);
int hil_config_unpack(hil_config_t *dst, const hil_octet_t *src, size_t size);
#define HIL_CONFIG_PARAM_ID_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_CONFIG_PARAM_ID_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_config_param_id_encode(float value);
float hil_config_param_id_decode(uint16_t raw);
int hil_config_param_id_is_in_range(uint16_t raw);
#define HIL_CONFIG_CONFIG_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_CONFIG_CONFIG_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_config_config_seq_encode(float value);
float hil_config_config_seq_decode(uint16_t raw);
int hil_config_config_seq_is_in_range(uint16_t raw);
float hil_config_value_encode(float value);
float hil_config_value_decode(float raw);
int hil_config_value_is_in_range(float raw);

/* ---- CONFIG_ACK: 0x031, 8 octets, sent by CTRL ---- */
/* Answer to every CONFIG, also for parameters the controller does not use. status 0 = stored. */
#define HIL_CONFIG_ACK_FRAME_ID 0x031u
#define HIL_CONFIG_ACK_LENGTH 8u
typedef struct {
    uint16_t param_id; /* physical = raw; DBC [0, 65535] = raw 0..65535; 1 = RS_OHM, 2 = LD_H, 3 = LQ_H, 4 = PSI_F_WB, 5 = POLE_PAIRS, 6 = J_KGM2, 7 = B_NMS, 8 = V_DC_NOM_V, 20 = CUR_KP_V_A, 21 = CUR_KI_V_AS, 22 = SPD_KP_A_RAD_S, 23 = SPD_KI_A_RAD, 24 = IQ_MAX_A, 25 = SPEED_LOOP_DIV, 26 = I_MAX_TRIP_A, 30 = ALIGN_I_A, 31 = ALIGN_TIME_S, 32 = IF_I_A, 33 = IF_ACCEL_RAD_S2, 34 = HANDOVER_SPEED_RAD_S, 35 = HANDOVER_TIME_S, 36 = CTRL_DELAY_S, 37 = LOOP_ANGLE, 40 = SMO_K_V, 41 = SMO_WC_RAD_S, 42 = SMO_M_PER_A, 43 = SMO_SIGMOID_A_PER_A, 44 = PLL_KP, 45 = PLL_KI, 46 = SPEED_LPF_RAD_S, 47 = SMO_K_FACTOR, 48 = SMO_K_MIN_V, 49 = SMO_LAG_COMP, 50 = HFI_U_V, 51 = HFI_F_HZ, 52 = HFI_BW_RAD_S, 53 = HFI_PI_KP, 54 = HFI_PI_KI, 55 = IPD_TIME_S, 56 = HFI_POL_BIAS_A, 57 = HFI_LOCK_TOL_RAD, 60 = DELAY_COMP_ENABLE, 61 = DELAY_COMP_TD_S, 62 = HARM_COMP_ENABLE, 63 = HARM_GSDFT_M, 64 = HARM_COMP_GAIN, 65 = HARM_EXTRACTOR, 70 = PROT_OPEN_I_MIN_A, 71 = PROT_OPEN_RATIO, 72 = PROT_OPEN_TIME_S, 73 = PROT_SUM_MAX_A, 74 = PROT_SUM_TAU_S, 75 = PROT_STUCK_TIME_S, 76 = PROT_STUCK_DELTA_A, 77 = PROT_VDC_UV_RATIO, 78 = PROT_VDC_OV_RATIO, 79 = PROT_VDC_TIME_S, 80 = PROT_LINK_TIMEOUT_PERIODS, 81 = PROT_ENC_LOST_TIME_S, 82 = PROT_ENC_EMF_RATIO, 83 = PROT_ENC_FROZEN_TIME_S, 84 = PROT_STALL_TIME_S, 85 = PROT_STALL_SPEED_RAD_S, 86 = SMO_STA_K1_V, 87 = SMO_STA_K2_V_S, 90 = INV_COMP_ENABLE, 91 = INV_COMP_DEAD_TIME_S, 92 = INV_COMP_V_SWITCH_V, 93 = INV_COMP_R_SWITCH_OHM, 94 = INV_COMP_V_DIODE_V, 95 = INV_COMP_R_DIODE_OHM, 96 = INV_COMP_BAND_A, 97 = INV_COMP_SHAPE, 98 = INV_COMP_I_BW_RAD_S */
    uint16_t config_seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t status; /* physical = raw; DBC [0, 255] = raw 0..255; 0 = OK, 1 = UNKNOWN_PARAM, 2 = OUT_OF_RANGE, 3 = LOCKED */
} hil_config_ack_t;
int hil_config_ack_pack(hil_octet_t *dst, const hil_config_ack_t *src, size_t size);
int hil_config_ack_unpack(hil_config_ack_t *dst, const hil_octet_t *src, size_t size);
#define HIL_CONFIG_ACK_PARAM_ID_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_CONFIG_ACK_PARAM_ID_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_config_ack_param_id_encode(float value);
float hil_config_ack_param_id_decode(uint16_t raw);
int hil_config_ack_param_id_is_in_range(uint16_t raw);
#define HIL_CONFIG_ACK_CONFIG_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_CONFIG_ACK_CONFIG_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_config_ack_config_seq_encode(float value);
float hil_config_ack_config_seq_decode(uint16_t raw);
int hil_config_ack_config_seq_is_in_range(uint16_t raw);
#define HIL_CONFIG_ACK_STATUS_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_CONFIG_ACK_STATUS_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_config_ack_status_encode(float value);
float hil_config_ack_status_decode(uint16_t raw);
int hil_config_ack_status_is_in_range(uint16_t raw);

/* ---- CMD: 0x040, 8 octets, sent by PLANT ---- */
/* Command to the controller (run, stop, set reference, restart); value in SI units. No acknowledgement. */
#define HIL_CMD_FRAME_ID 0x040u
#define HIL_CMD_LENGTH 8u
typedef struct {
    uint16_t command; /* physical = raw; DBC [0, 255] = raw 0..255; 0 = NOP, 1 = RUN, 2 = STOP, 3 = CLEAR_FAULT, 4 = SET_SPEED_REF, 5 = SET_IQ_REF, 6 = SET_ID_REF, 7 = SET_CONTROL_MODE, 8 = RESTART */
    uint16_t seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    float value; /* IEEE binary32, DBC range [-3.4e+38, 3.4e+38] */
} hil_cmd_t;
int hil_cmd_pack(hil_octet_t *dst, const hil_cmd_t *src, size_t size);
int hil_cmd_unpack(hil_cmd_t *dst, const hil_octet_t *src, size_t size);
#define HIL_CMD_COMMAND_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_CMD_COMMAND_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_cmd_command_encode(float value);
float hil_cmd_command_decode(uint16_t raw);
int hil_cmd_command_is_in_range(uint16_t raw);
#define HIL_CMD_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_CMD_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_cmd_seq_encode(float value);
float hil_cmd_seq_decode(uint16_t raw);
int hil_cmd_seq_is_in_range(uint16_t raw);
float hil_cmd_value_encode(float value);
float hil_cmd_value_decode(float raw);
int hil_cmd_value_is_in_range(float raw);

/* ---- HEARTBEAT_PLANT: 0x050, 8 octets, sent by PLANT ---- */
/* Host heartbeat: every 100 ms while no control cycles flow (handshake, configuration). A controller may ignore it. */
#define HIL_HEARTBEAT_PLANT_FRAME_ID 0x050u
#define HIL_HEARTBEAT_PLANT_LENGTH 8u
#define HIL_HEARTBEAT_PLANT_CYCLE_TIME_MS 100u /* GenMsgCycleTime */
typedef struct {
    uint16_t counter; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t state; /* physical = raw; DBC [0, 255] = raw 0..255; 0 = IDLE, 1 = ALIGN, 2 = OPEN_LOOP, 3 = CLOSED_LOOP, 4 = FAULT, 5 = INITIAL_POSITION, 6 = STOPPED */
    uint16_t rx_errors; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t rx_frames; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
} hil_heartbeat_plant_t;
int hil_heartbeat_plant_pack(hil_octet_t *dst, const hil_heartbeat_plant_t *src, size_t size);
int hil_heartbeat_plant_unpack(hil_heartbeat_plant_t *dst, const hil_octet_t *src, size_t size);
#define HIL_HEARTBEAT_PLANT_COUNTER_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HEARTBEAT_PLANT_COUNTER_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_heartbeat_plant_counter_encode(float value);
float hil_heartbeat_plant_counter_decode(uint16_t raw);
int hil_heartbeat_plant_counter_is_in_range(uint16_t raw);
#define HIL_HEARTBEAT_PLANT_STATE_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HEARTBEAT_PLANT_STATE_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_heartbeat_plant_state_encode(float value);
float hil_heartbeat_plant_state_decode(uint16_t raw);
int hil_heartbeat_plant_state_is_in_range(uint16_t raw);
#define HIL_HEARTBEAT_PLANT_RX_ERRORS_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HEARTBEAT_PLANT_RX_ERRORS_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_heartbeat_plant_rx_errors_encode(float value);
float hil_heartbeat_plant_rx_errors_decode(uint16_t raw);
int hil_heartbeat_plant_rx_errors_is_in_range(uint16_t raw);
#define HIL_HEARTBEAT_PLANT_RX_FRAMES_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HEARTBEAT_PLANT_RX_FRAMES_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_heartbeat_plant_rx_frames_encode(float value);
float hil_heartbeat_plant_rx_frames_decode(uint16_t raw);
int hil_heartbeat_plant_rx_frames_is_in_range(uint16_t raw);

/* ---- HEARTBEAT_CTRL: 0x051, 8 octets, sent by CTRL ---- */
/* Controller heartbeat: every 100 ms while no control cycles flow. */
#define HIL_HEARTBEAT_CTRL_FRAME_ID 0x051u
#define HIL_HEARTBEAT_CTRL_LENGTH 8u
#define HIL_HEARTBEAT_CTRL_CYCLE_TIME_MS 100u /* GenMsgCycleTime */
typedef struct {
    uint16_t counter; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t state; /* physical = raw; DBC [0, 255] = raw 0..255; 0 = IDLE, 1 = ALIGN, 2 = OPEN_LOOP, 3 = CLOSED_LOOP, 4 = FAULT, 5 = INITIAL_POSITION, 6 = STOPPED */
    uint16_t rx_errors; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t rx_frames; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
} hil_heartbeat_ctrl_t;
int hil_heartbeat_ctrl_pack(hil_octet_t *dst, const hil_heartbeat_ctrl_t *src, size_t size);
int hil_heartbeat_ctrl_unpack(hil_heartbeat_ctrl_t *dst, const hil_octet_t *src, size_t size);
#define HIL_HEARTBEAT_CTRL_COUNTER_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HEARTBEAT_CTRL_COUNTER_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_heartbeat_ctrl_counter_encode(float value);
float hil_heartbeat_ctrl_counter_decode(uint16_t raw);
int hil_heartbeat_ctrl_counter_is_in_range(uint16_t raw);
#define HIL_HEARTBEAT_CTRL_STATE_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HEARTBEAT_CTRL_STATE_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_heartbeat_ctrl_state_encode(float value);
float hil_heartbeat_ctrl_state_decode(uint16_t raw);
int hil_heartbeat_ctrl_state_is_in_range(uint16_t raw);
#define HIL_HEARTBEAT_CTRL_RX_ERRORS_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HEARTBEAT_CTRL_RX_ERRORS_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_heartbeat_ctrl_rx_errors_encode(float value);
float hil_heartbeat_ctrl_rx_errors_decode(uint16_t raw);
int hil_heartbeat_ctrl_rx_errors_is_in_range(uint16_t raw);
#define HIL_HEARTBEAT_CTRL_RX_FRAMES_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_HEARTBEAT_CTRL_RX_FRAMES_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_heartbeat_ctrl_rx_frames_encode(float value);
float hil_heartbeat_ctrl_rx_frames_decode(uint16_t raw);
int hil_heartbeat_ctrl_rx_frames_is_in_range(uint16_t raw);

/* ---- SENSE: 0x100, 8 octets, sent by PLANT ---- */
/* Phase currents sampled at the start of PWM period seq. Sent last of the cycle's uplink frames: its arrival triggers the control ISR. A SENSE repeating the seq of the last SENSE run is a retry: answered from the cache, the ISR does not run again. */
#define HIL_SENSE_FRAME_ID 0x100u
#define HIL_SENSE_LENGTH 8u
typedef struct {
    uint16_t seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    int16_t i_a; /* physical = raw * 0.001 A; DBC [-32.768, 32.767] = raw -32768..32767 */
    int16_t i_b; /* physical = raw * 0.001 A; DBC [-32.768, 32.767] = raw -32768..32767 */
    int16_t i_c; /* physical = raw * 0.001 A; DBC [-32.768, 32.767] = raw -32768..32767 */
} hil_sense_t;
int hil_sense_pack(hil_octet_t *dst, const hil_sense_t *src, size_t size);
int hil_sense_unpack(hil_sense_t *dst, const hil_octet_t *src, size_t size);
#define HIL_SENSE_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_SENSE_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_sense_seq_encode(float value);
float hil_sense_seq_decode(uint16_t raw);
int hil_sense_seq_is_in_range(uint16_t raw);
#define HIL_SENSE_I_A_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_SENSE_I_A_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_sense_i_a_encode(float value);
float hil_sense_i_a_decode(int16_t raw);
int hil_sense_i_a_is_in_range(int16_t raw);
#define HIL_SENSE_I_B_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_SENSE_I_B_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_sense_i_b_encode(float value);
float hil_sense_i_b_decode(int16_t raw);
int hil_sense_i_b_is_in_range(int16_t raw);
#define HIL_SENSE_I_C_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_SENSE_I_C_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_sense_i_c_encode(float value);
float hil_sense_i_c_decode(int16_t raw);
int hil_sense_i_c_is_in_range(int16_t raw);

/* ---- SENSE_AUX: 0x101, 8 octets, sent by PLANT ---- */
/* Bus voltage and encoder angle of cycle seq, sent before SENSE every cycle. */
#define HIL_SENSE_AUX_FRAME_ID 0x101u
#define HIL_SENSE_AUX_LENGTH 8u
typedef struct {
    uint16_t seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t v_dc; /* physical = raw * 0.01 V; DBC [0, 655.35] = raw 0..65535 */
    uint16_t theta_enc; /* physical = raw * 9.587379924285257e-05 rad; an angle: raw = round(value / scale) mod 65536 (wraps at 2 pi) */
    uint16_t flags; /* physical = raw; DBC [0, 255] = raw 0..255; 0 = NONE, 1 = DUAL_FOLLOWS, 2 = THETA_ENC_VALID, 3 = DUAL_FOLLOWS+THETA_ENC_VALID */
} hil_sense_aux_t;
int hil_sense_aux_pack(hil_octet_t *dst, const hil_sense_aux_t *src, size_t size);
int hil_sense_aux_unpack(hil_sense_aux_t *dst, const hil_octet_t *src, size_t size);
#define HIL_SENSE_AUX_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_SENSE_AUX_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_sense_aux_seq_encode(float value);
float hil_sense_aux_seq_decode(uint16_t raw);
int hil_sense_aux_seq_is_in_range(uint16_t raw);
#define HIL_SENSE_AUX_V_DC_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_SENSE_AUX_V_DC_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_sense_aux_v_dc_encode(float value);
float hil_sense_aux_v_dc_decode(uint16_t raw);
int hil_sense_aux_v_dc_is_in_range(uint16_t raw);
#define HIL_SENSE_AUX_THETA_ENC_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_SENSE_AUX_THETA_ENC_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_sense_aux_theta_enc_encode(float value);
float hil_sense_aux_theta_enc_decode(uint16_t raw);
int hil_sense_aux_theta_enc_is_in_range(uint16_t raw);
#define HIL_SENSE_AUX_FLAGS_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_SENSE_AUX_FLAGS_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_sense_aux_flags_encode(float value);
float hil_sense_aux_flags_decode(uint16_t raw);
int hil_sense_aux_flags_is_in_range(uint16_t raw);

/* ---- SENSE_DUAL: 0x102, 8 octets, sent by PLANT ---- */
/* Second current sample, taken at the actuation instant of the previous period (dual sampling). Sent before SENSE every cycle when HELLO flag DUAL_SAMPLING is set. */
#define HIL_SENSE_DUAL_FRAME_ID 0x102u
#define HIL_SENSE_DUAL_LENGTH 8u
typedef struct {
    uint16_t seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    int16_t i_a2; /* physical = raw * 0.001 A; DBC [-32.768, 32.767] = raw -32768..32767 */
    int16_t i_b2; /* physical = raw * 0.001 A; DBC [-32.768, 32.767] = raw -32768..32767 */
    int16_t i_c2; /* physical = raw * 0.001 A; DBC [-32.768, 32.767] = raw -32768..32767 */
} hil_sense_dual_t;
int hil_sense_dual_pack(hil_octet_t *dst, const hil_sense_dual_t *src, size_t size);
int hil_sense_dual_unpack(hil_sense_dual_t *dst, const hil_octet_t *src, size_t size);
#define HIL_SENSE_DUAL_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_SENSE_DUAL_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_sense_dual_seq_encode(float value);
float hil_sense_dual_seq_decode(uint16_t raw);
int hil_sense_dual_seq_is_in_range(uint16_t raw);
#define HIL_SENSE_DUAL_I_A2_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_SENSE_DUAL_I_A2_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_sense_dual_i_a2_encode(float value);
float hil_sense_dual_i_a2_decode(int16_t raw);
int hil_sense_dual_i_a2_is_in_range(int16_t raw);
#define HIL_SENSE_DUAL_I_B2_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_SENSE_DUAL_I_B2_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_sense_dual_i_b2_encode(float value);
float hil_sense_dual_i_b2_decode(int16_t raw);
int hil_sense_dual_i_b2_is_in_range(int16_t raw);
#define HIL_SENSE_DUAL_I_C2_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_SENSE_DUAL_I_C2_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_sense_dual_i_c2_encode(float value);
float hil_sense_dual_i_c2_decode(int16_t raw);
int hil_sense_dual_i_c2_is_in_range(int16_t raw);

/* ---- DUTY: 0x180, 8 octets, sent by CTRL ---- */
/* Duties computed from SENSE seq (0 = low side on, 1 = high side on). The plant applies them at the sampling instant of seq plus the computation delay t_d, inside period seq, until the next duties take effect. Sent last of the cycle's downlink frames: its arrival completes the cycle. */
#define HIL_DUTY_FRAME_ID 0x180u
#define HIL_DUTY_LENGTH 8u
typedef struct {
    uint16_t seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t d_a; /* physical = raw * 3.0517578125e-05; valid [0, 1] = raw 0..32768 (DBC declares [0, 1.999969482421875]); 65535 = OFF */
    uint16_t d_b; /* physical = raw * 3.0517578125e-05; valid [0, 1] = raw 0..32768 (DBC declares [0, 1.999969482421875]); 65535 = OFF */
    uint16_t d_c; /* physical = raw * 3.0517578125e-05; valid [0, 1] = raw 0..32768 (DBC declares [0, 1.999969482421875]); 65535 = OFF */
} hil_duty_t;
int hil_duty_pack(hil_octet_t *dst, const hil_duty_t *src, size_t size);
int hil_duty_unpack(hil_duty_t *dst, const hil_octet_t *src, size_t size);
#define HIL_DUTY_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_DUTY_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_duty_seq_encode(float value);
float hil_duty_seq_decode(uint16_t raw);
int hil_duty_seq_is_in_range(uint16_t raw);
#define HIL_DUTY_D_A_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_DUTY_D_A_RAW_MAX ((uint16_t)UINT32_C(32768))
uint16_t hil_duty_d_a_encode(float value);
float hil_duty_d_a_decode(uint16_t raw);
int hil_duty_d_a_is_in_range(uint16_t raw);
#define HIL_DUTY_D_B_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_DUTY_D_B_RAW_MAX ((uint16_t)UINT32_C(32768))
uint16_t hil_duty_d_b_encode(float value);
float hil_duty_d_b_decode(uint16_t raw);
int hil_duty_d_b_is_in_range(uint16_t raw);
#define HIL_DUTY_D_C_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_DUTY_D_C_RAW_MAX ((uint16_t)UINT32_C(32768))
uint16_t hil_duty_d_c_encode(float value);
float hil_duty_d_c_decode(uint16_t raw);
int hil_duty_d_c_is_in_range(uint16_t raw);

/* ---- TELEM: 0x181, 8 octets, sent by CTRL ---- */
/* Controller telemetry of cycle seq: estimated electrical angle and speed, controller state, active estimator. Mandatory every cycle, before DUTY. */
#define HIL_TELEM_FRAME_ID 0x181u
#define HIL_TELEM_LENGTH 8u
typedef struct {
    uint16_t seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    uint16_t theta_hat; /* physical = raw * 9.587379924285257e-05 rad; an angle: raw = round(value / scale) mod 65536 (wraps at 2 pi) */
    int16_t omega_hat; /* physical = raw * 0.1 rad/s; DBC [-3276.8, 3276.7] = raw -32768..32767 */
    uint16_t state; /* physical = raw; DBC [0, 255] = raw 0..255; 0 = IDLE, 1 = ALIGN, 2 = OPEN_LOOP, 3 = CLOSED_LOOP, 4 = FAULT, 5 = INITIAL_POSITION, 6 = STOPPED */
    uint16_t estimator; /* physical = raw; DBC [0, 255] = raw 0..255; 0 = NONE, 1 = SMO_SIGN, 2 = SMO_SIGMOID, 3 = SMO_TANH, 4 = HFI_SDFT, 5 = ENCODER, 6 = SMO_STA */
} hil_telem_t;
int hil_telem_pack(hil_octet_t *dst, const hil_telem_t *src, size_t size);
int hil_telem_unpack(hil_telem_t *dst, const hil_octet_t *src, size_t size);
#define HIL_TELEM_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_TELEM_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_telem_seq_encode(float value);
float hil_telem_seq_decode(uint16_t raw);
int hil_telem_seq_is_in_range(uint16_t raw);
#define HIL_TELEM_THETA_HAT_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_TELEM_THETA_HAT_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_telem_theta_hat_encode(float value);
float hil_telem_theta_hat_decode(uint16_t raw);
int hil_telem_theta_hat_is_in_range(uint16_t raw);
#define HIL_TELEM_OMEGA_HAT_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_TELEM_OMEGA_HAT_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_telem_omega_hat_encode(float value);
float hil_telem_omega_hat_decode(int16_t raw);
int hil_telem_omega_hat_is_in_range(int16_t raw);
#define HIL_TELEM_STATE_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_TELEM_STATE_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_telem_state_encode(float value);
float hil_telem_state_decode(uint16_t raw);
int hil_telem_state_is_in_range(uint16_t raw);
#define HIL_TELEM_ESTIMATOR_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_TELEM_ESTIMATOR_RAW_MAX ((uint16_t)UINT32_C(255))
uint16_t hil_telem_estimator_encode(float value);
float hil_telem_estimator_decode(uint16_t raw);
int hil_telem_estimator_is_in_range(uint16_t raw);

/* ---- TELEM_EMF: 0x182, 8 octets, sent by CTRL ---- */
/* Estimated back EMF in alpha-beta and q-axis current reference of cycle seq. Sent every cycle before DUTY when HELLO flag TELEM_EMF is set, never otherwise. */
#define HIL_TELEM_EMF_FRAME_ID 0x182u
#define HIL_TELEM_EMF_LENGTH 8u
typedef struct {
    uint16_t seq; /* physical = raw; DBC [0, 65535] = raw 0..65535 */
    int16_t e_alpha; /* physical = raw * 0.01 V; DBC [-327.68, 327.67] = raw -32768..32767 */
    int16_t e_beta; /* physical = raw * 0.01 V; DBC [-327.68, 327.67] = raw -32768..32767 */
    int16_t i_q_ref; /* physical = raw * 0.001 A; DBC [-32.768, 32.767] = raw -32768..32767 */
} hil_telem_emf_t;
int hil_telem_emf_pack(hil_octet_t *dst, const hil_telem_emf_t *src, size_t size);
int hil_telem_emf_unpack(hil_telem_emf_t *dst, const hil_octet_t *src, size_t size);
#define HIL_TELEM_EMF_SEQ_RAW_MIN ((uint16_t)UINT32_C(0))
#define HIL_TELEM_EMF_SEQ_RAW_MAX ((uint16_t)UINT32_C(65535))
uint16_t hil_telem_emf_seq_encode(float value);
float hil_telem_emf_seq_decode(uint16_t raw);
int hil_telem_emf_seq_is_in_range(uint16_t raw);
#define HIL_TELEM_EMF_E_ALPHA_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_TELEM_EMF_E_ALPHA_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_telem_emf_e_alpha_encode(float value);
float hil_telem_emf_e_alpha_decode(int16_t raw);
int hil_telem_emf_e_alpha_is_in_range(int16_t raw);
#define HIL_TELEM_EMF_E_BETA_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_TELEM_EMF_E_BETA_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_telem_emf_e_beta_encode(float value);
float hil_telem_emf_e_beta_decode(int16_t raw);
int hil_telem_emf_e_beta_is_in_range(int16_t raw);
#define HIL_TELEM_EMF_I_Q_REF_RAW_MIN ((int16_t)INT32_C(-32768))
#define HIL_TELEM_EMF_I_Q_REF_RAW_MAX ((int16_t)INT32_C(32767))
int16_t hil_telem_emf_i_q_ref_encode(float value);
float hil_telem_emf_i_q_ref_decode(int16_t raw);
int hil_telem_emf_i_q_ref_is_in_range(int16_t raw);

#ifdef __cplusplus
}
#endif

#endif /* HIL_MSGS_H */
