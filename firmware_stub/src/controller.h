/**
 * @file controller.h
 * @brief The control ISR of the firmware stub: sensorless FOC with start-up and a selectable
 * angle estimator. Portable C99, float32, no heap, no OS calls. One call per PWM period.
 *
 * Per period: Clarke -> estimator (currents at t_k, voltage applied over the last period) ->
 * state machine (IDLE, ALIGN, OPEN_LOOP (I-f), CLOSED_LOOP, FAULT, STOPPED) -> speed PI (every
 * speed_loop_div periods) -> d/q current PI with decoupling -> inverse Park -> SVPWM ->
 * inverter-error feed-forward (inv_comp.h, when on: the duties then realise the command, and the
 * observers are fed the voltage the compensation's inverter model says the duties make).
 */
#ifndef CONTROLLER_H
#define CONTROLLER_H

#include "ctrl_protect.h"
#include "est_common.h"
#include "est_delay_comp.h"
#include "est_hfi.h"
#include "est_smo_sigmoid.h"
#include "est_smo_sign.h"
#include "est_smo_sta.h"
#include "est_smo_tanh.h"
#include "fw_math.h"
#include "harm_comp.h"
#include "inv_comp.h"
#include "pi_ctrl.h"

/** Controller states; the numbers are the protocol's `state` value table (protocol/hil.dbc). */
typedef enum {
    CTRL_STATE_IDLE = 0,
    CTRL_STATE_ALIGN = 1,
    CTRL_STATE_OPEN_LOOP = 2,
    CTRL_STATE_CLOSED_LOOP = 3,
    CTRL_STATE_FAULT = 4,
    CTRL_STATE_INITIAL_POSITION = 5,
    CTRL_STATE_STOPPED = 6
} ctrl_state_t;

/** Angle sources; the numbers are the protocol's `estimator` value table. */
typedef enum {
    CTRL_EST_NONE = 0,
    CTRL_EST_SMO_SIGN = 1,
    CTRL_EST_SMO_SIGMOID = 2,
    CTRL_EST_SMO_TANH = 3,
    CTRL_EST_HFI_SDFT = 4,
    CTRL_EST_ENCODER = 5,
    CTRL_EST_SMO_STA = 6
} ctrl_estimator_t;

/** Fault causes; the numbers are the protocol's fault `code` value table. */
typedef enum {
    CTRL_FAULT_NONE = 0,
    CTRL_FAULT_LINK_TIMEOUT = CTRL_PROTECT_LINK_TIMEOUT,
    CTRL_FAULT_OVERCURRENT = 4,
    CTRL_FAULT_INVALID_DUTY = 5,
    CTRL_FAULT_CONFIG_INVALID = 8,
    CTRL_FAULT_OVERVOLTAGE = CTRL_PROTECT_OVERVOLTAGE,
    CTRL_FAULT_STARTUP_FAILED = 10,
    CTRL_FAULT_OPEN_PHASE = CTRL_PROTECT_OPEN_PHASE,
    CTRL_FAULT_UNDERVOLTAGE = CTRL_PROTECT_UNDERVOLTAGE,
    CTRL_FAULT_SENSOR_FAULT = CTRL_PROTECT_SENSOR_FAULT,
    CTRL_FAULT_STALL = CTRL_PROTECT_STALL
} ctrl_fault_t;

typedef enum { CTRL_MODE_SPEED = 0, CTRL_MODE_CURRENT = 1 } ctrl_mode_t;

/** Which estimate of the angle the closed loop's Park transforms use (an SMO's; HF injection and
 * the encoder have one angle). OBSERVER: the EMF angle itself (atan2 of the estimated EMF with
 * the lag compensation), which carries the EMF estimate's noise sample by sample; PLL: the
 * angle of the PLL that tracks it (type 2, the estimate's speed), the angle a production
 * sensorless drive turns its frames with at low speed (the EMF angle's noise filtered at the
 * PLL's bandwidth, no lag on a speed ramp). */
typedef enum { CTRL_LOOP_ANGLE_OBSERVER = 0, CTRL_LOOP_ANGLE_PLL = 1 } ctrl_loop_angle_t;

/** Bandwidth of the low-pass on the I-f current (open-loop frame) that seeds the speed loop at
 * the hand-over [rad/s]: a 20 ms time constant, the 12-bit ADC's noise averaged over 200
 * samples at 10 kHz, short against the I-f ramp (seconds). */
#define CTRL_HANDOVER_I_LPF_RAD_S 50.0f

/** Everything the host can configure (SI units). Zero gains mean "derive from the motor". */
typedef struct {
    /* motor */
    float rs_ohm, ld_h, lq_h, psi_f_wb, pole_pairs, j_kgm2, b_nms, v_dc_nom_v;
    float ts_s;               /**< PWM / control period */
    /* current loop (d and q use the same bandwidth; kp scales with L) */
    float cur_kp_v_a;         /**< q-axis kp; <= 0: Lq * cur_bw_rad_s */
    float cur_ki_v_as;        /**< ki; <= 0: Rs * cur_bw_rad_s */
    float cur_bw_rad_s;       /**< current-loop bandwidth for the derived gains */
    /* speed loop */
    float spd_kp_a_rad_s;     /**< A per (rad/s mechanical); <= 0: J*w_sc/Kt */
    float spd_ki_a_rad;       /**< <= 0: kp * w_sc / 4 */
    float spd_bw_rad_s;       /**< speed-loop bandwidth for the derived gains */
    float iq_max_a;           /**< speed-loop output limit */
    float speed_loop_div;     /**< the speed loop runs every N periods */
    float i_trip_a;           /**< over-current trip on any phase */
    float t_act_delay_s;      /**< computation delay t_d the firmware assumes: sampling -> new
                                   duties take effect. Used to advance the PWM angle to the middle
                                   of the interval the voltage acts on (t_d + Ts/2), and to give
                                   the estimators the voltage that acted over the last period
                                   (t_d/Ts of the older command, the rest of the newer one). */
    /* start-up */
    float align_i_a, align_time_s;
    float if_i_a;             /**< I-f current magnitude */
    float if_accel_rad_s2;    /**< open-loop acceleration (mechanical) */
    float handover_speed_rad_s; /**< open-loop speed (mechanical) at which the estimator takes over */
    float handover_time_s;    /**< d-current ramp-down time after the hand-over */
    /* estimator */
    float estimator;          /**< ctrl_estimator_t */
    float smo_k_v, smo_k_factor, smo_k_min_v, smo_wc_rad_s;
    float smo_m_per_a;        /**< tanh SMO slope m (Gong eq. 8) */
    float smo_sigmoid_a_per_a; /**< sigmoid slope a (Yuan eq. 11); <= 0: deadbeat slope */
    float smo_lag_comp;       /**< sigmoid SMO phase compensation: 0 none, 1 eq. 15, 2 effective */
    float smo_sta_k1_v, smo_sta_k2_v_s; /**< super-twisting SMO gains; <= 0: adaptive */
    float pll_kp, pll_ki, speed_lpf_rad_s;
    float loop_angle;         /**< ctrl_loop_angle_t: the angle the current loop turns with once
                                   an SMO closes it (the observer's, or its PLL's) */
    /* HF injection (Hou): amplitude, frequency, tracking loop, polarity test */
    float hfi_u_v, hfi_f_hz, hfi_bw_rad_s, hfi_kp, hfi_ki, hfi_ipd_timeout_s, hfi_pol_bias_a;
    float hfi_lock_tol_rad;   /**< IPD: |2 dtheta|/2 below this (for the lock time) counts as
                                   converged; above the noise of a 12-bit ADC (~0.03 rad) */
    /* calculation-delay pre-compensation (Gong eq. 20-22): 0 off, 1 with delay_comp_td_s,
     * 2 estimate t_d from the dual samples (eq. 20) and compensate with the estimate */
    float delay_comp_mode, delay_comp_td_s;
    /* inverter-nonlinearity compensation (Yuan eq. 28-37) */
    float harm_comp_enable, harm_m, harm_k_comp, harm_extractor;
    /* inverter-error feed-forward (inv_comp.h): inv_comp_mode 0 off, or the phase currents it
     * uses: 1 the last two samples extrapolated to the middle of the interval the duties act on
     * (t_act_delay_s + Ts/2 after the sample), 2 the sample, 3 the current loop's reference,
     * 4 the current-vector method (the measured vector low-passed at inv_comp_i_bw_rad_s in the
     * rotating frame, turned to that middle; with HF injection plus the injection's current,
     * its mean over that interval predicted as a sampled tone of the injection frequency); the
     * drive's estimates of the inverter */
    float inv_comp_mode, inv_comp_dead_time_s, inv_comp_v_switch_v, inv_comp_r_switch_ohm,
          inv_comp_v_diode_v, inv_comp_r_diode_ohm, inv_comp_band_a, inv_comp_shape,
          inv_comp_i_bw_rad_s;
    /* protection thresholds (ctrl_protect.h; prot.i_trip_a is set from i_trip_a at start) */
    ctrl_protect_config_t prot;
} ctrl_config_t;

typedef struct {
    float i_a_a, i_b_a, i_c_a; /**< phase currents sampled at t_k */
    float v_dc_v;              /**< bus voltage */
    int v_dc_valid;            /**< v_dc_v is a measurement (the port has received one, whatever
                                    it reads); 0: none yet: the nominal bus modulates, no bus
                                    check */
    float theta_enc_rad;       /**< encoder angle (ENCODER estimator only) */
    int theta_enc_valid;       /**< theta_enc_rad is a valid reading of this period; 0: none
                                    (encoder lost, or no reading arrived for this period): the
                                    controller extrapolates with its speed estimate and the
                                    protection times the gap (ctrl_protect.h) */
    int have_i2;               /**< the second (dual) sample of the previous period is valid */
    float i2_abc_a[3];         /**< second sample of period k-1, taken at t_(k-1) + t_d */
} ctrl_sample_t;

typedef struct {
    float duty_abc[3];   /**< [0,1]; a negative value means the leg is OFF (both switches off) */
    float theta_hat_rad; /**< estimator angle */
    float omega_hat_rad_s; /**< estimator electrical speed */
    float e_alpha_v, e_beta_v;
    float i_q_ref_a;
    float t_d_est_s;     /**< delay-compensation estimate in use (0 when off) */
    ctrl_state_t state;
    ctrl_fault_t fault;
    int32_t fault_detail; /**< FAULT_CTRL detail of the fault (ctrl_protect.h), 0 if none */
} ctrl_output_t;

typedef struct {
    ctrl_config_t cfg;
    ctrl_state_t state;
    ctrl_fault_t fault;
    ctrl_mode_t mode;
    float speed_ref_rad_s;   /**< mechanical */
    float iq_cmd_a, id_cmd_a; /**< current-mode references */
    /* derived */
    float kt_nm_a;
    /* loops */
    pi_ctrl_t pi_d, pi_q, pi_speed;
    unsigned speed_div_count;
    float iq_ref_a, id_ref_a;
    /* start-up */
    float t_state_s;
    float theta_ol_rad, omega_ol_rad_s; /* open-loop angle and electrical speed */
    float id_handover_a;
    fw_vec2_t i_ol_dq_f_a;   /* I-f current in the open-loop frame, low-passed (hand-over seed) */
    float i_ol_lpf;          /* its coefficient 1 - exp(-w Ts) */
    /* estimator: only the selected one is live */
    union {
        est_smo_sign_t sign;
        est_smo_sigmoid_t sigmoid;
        est_smo_tanh_t tanh_smo;
        est_smo_sta_t sta;
        est_hfi_t hfi;
        est_pll_t encoder_pll;
    } est_state;
    const est_hfi_output_t *hfi_out; /**< last HFI output (HFI_SDFT only) */
    est_delay_comp_t delay_comp;
    harm_comp_t harm;
    inv_comp_t inv;
    float inv_i_prev_a[3];      /**< phase currents of the last period (inv_comp_predict) */
    int inv_i_prev_valid;
    fw_vec2_t inv_i_dq_f_a;     /**< current-vector method: low-passed i_dq of the loop's frame */
    float inv_i_lpf_a;          /**< its coefficient 1 - exp(-w Ts) */
    fw_vec2_t inv_hf_s1_a, inv_hf_s2_a; /**< observed HF injection current x_k, x_k-1 (alpha-beta) */
    float inv_hf_cos, inv_hf_l1, inv_hf_l2; /**< its observer (cos w Ts, gains) */
    float inv_hf_c1, inv_hf_c0; /**< its mean over the next interval from x_k, x_k-1 */
    est_output_t est;
    /* voltage commands (for the estimator's next step) */
    fw_vec2_t v_ab_applied_v;   /**< command of the last ISR, as realised by SVPWM */
    fw_vec2_t v_ab_older_v;     /**< command of the ISR before */
    fw_vec2_t v_ab_acted_v;     /**< what acted over the last period (delay-weighted) */
    /* protection: the current references of the last period at the angle of t_k */
    ctrl_protect_t prot;
    int prot_ref_valid;
    float prot_id_ref_a, prot_iq_ref_a, prot_theta_rad;
    fw_vec2_t prot_i_prev_ab;   /**< currents of the last period (back-EMF of the voltage balance) */
    int prot_i_prev_valid;
    float prot_emf_v;           /**< that back-EMF magnitude of the last period [V] (diagnostic) */
    int32_t fault_detail;
    ctrl_output_t out;
} controller_t;

/** Defaults for every field (gains zero = derived at start). */
void ctrl_config_defaults(ctrl_config_t *cfg);
void ctrl_init(controller_t *c);
/** Validate the configuration and derive coefficients. 0 = ok; -1 = invalid (state FAULT). */
int ctrl_start(controller_t *c);
void ctrl_stop(controller_t *c);
void ctrl_clear_fault(controller_t *c);
void ctrl_set_speed_ref(controller_t *c, float speed_ref_rad_s);
void ctrl_set_current_ref(controller_t *c, float id_a, float iq_a);
void ctrl_set_mode(controller_t *c, ctrl_mode_t mode);
/** The ISR. */
const ctrl_output_t *ctrl_step(controller_t *c, const ctrl_sample_t *s);
/**
 * Link timer of a free-running port (no SENSE -> no ISR): call it from the port's timer with
 * the time since the last call. Returns CTRL_FAULT_LINK_TIMEOUT when it trips now (the
 * controller is then in FAULT with its outputs off: send FAULT_CTRL with out.fault_detail),
 * else CTRL_FAULT_NONE. Acts only while the controller is running.
 */
ctrl_fault_t ctrl_link_tick(controller_t *c, float dt_s);

#endif
