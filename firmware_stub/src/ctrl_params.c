#include "ctrl_params.h"

#include <stddef.h>

#include "fw_math.h"
#include "hil_msgs.h"

typedef struct {
    unsigned id;
    size_t offset;  /* of the float field in ctrl_config_t */
    float min;      /* accepted range, inclusive */
    float max;
    int whole;      /* integer, boolean and enum parameters: only whole values (docs/protocol.md 6.2) */
} param_entry_t;

#define P(ID, FIELD, MIN, MAX) { (unsigned)(ID), offsetof(ctrl_config_t, FIELD), (MIN), (MAX), 0 }
/* integer / boolean / enum: a whole number in [MIN, MAX] (the enums' values are 0..MAX) */
#define W(ID, FIELD, MIN, MAX) { (unsigned)(ID), offsetof(ctrl_config_t, FIELD), (MIN), (MAX), 1 }

static const param_entry_t k_params[] = {
    P(HIL_PARAM_RS_OHM, rs_ohm, 1e-6f, 100.0f),
    P(HIL_PARAM_LD_H, ld_h, 1e-7f, 10.0f),
    P(HIL_PARAM_LQ_H, lq_h, 1e-7f, 10.0f),
    P(HIL_PARAM_PSI_F_WB, psi_f_wb, 1e-6f, 100.0f),
    W(HIL_PARAM_POLE_PAIRS, pole_pairs, 1.0f, 64.0f),
    P(HIL_PARAM_J_KGM2, j_kgm2, 1e-9f, 1e4f),
    P(HIL_PARAM_B_NMS, b_nms, 0.0f, 1e3f),
    P(HIL_PARAM_V_DC_NOM_V, v_dc_nom_v, 1.0f, 2000.0f),
    P(HIL_PARAM_CUR_KP_V_A, cur_kp_v_a, 0.0f, 1e4f),
    P(HIL_PARAM_CUR_KI_V_AS, cur_ki_v_as, 0.0f, 1e8f),
    P(HIL_PARAM_SPD_KP_A_RAD_S, spd_kp_a_rad_s, 0.0f, 1e4f),
    P(HIL_PARAM_SPD_KI_A_RAD, spd_ki_a_rad, 0.0f, 1e6f),
    P(HIL_PARAM_IQ_MAX_A, iq_max_a, 0.0f, 1e3f),
    W(HIL_PARAM_SPEED_LOOP_DIV, speed_loop_div, 1.0f, 1000.0f),
    P(HIL_PARAM_I_MAX_TRIP_A, i_trip_a, 0.0f, 1e3f),
    P(HIL_PARAM_ALIGN_I_A, align_i_a, 0.0f, 1e3f),
    P(HIL_PARAM_ALIGN_TIME_S, align_time_s, 0.0f, 100.0f),
    P(HIL_PARAM_IF_I_A, if_i_a, 0.0f, 1e3f),
    P(HIL_PARAM_IF_ACCEL_RAD_S2, if_accel_rad_s2, 0.0f, 1e6f),
    P(HIL_PARAM_HANDOVER_SPEED_RAD_S, handover_speed_rad_s, 0.0f, 1e5f),
    P(HIL_PARAM_HANDOVER_TIME_S, handover_time_s, 0.0f, 100.0f),
    P(HIL_PARAM_CTRL_DELAY_S, t_act_delay_s, 0.0f, 1.0f),
    W(HIL_PARAM_LOOP_ANGLE, loop_angle, 0.0f, 1.0f),
    P(HIL_PARAM_SMO_K_V, smo_k_v, 0.0f, 1e4f),
    P(HIL_PARAM_SMO_WC_RAD_S, smo_wc_rad_s, 0.0f, 1e6f),
    P(HIL_PARAM_SMO_K_FACTOR, smo_k_factor, 0.0f, 100.0f),
    P(HIL_PARAM_SMO_K_MIN_V, smo_k_min_v, 0.0f, 1e4f),
    P(HIL_PARAM_SMO_M_PER_A, smo_m_per_a, 1e-6f, 1e3f),
    P(HIL_PARAM_SMO_SIGMOID_A_PER_A, smo_sigmoid_a_per_a, 0.0f, 1e6f),
    W(HIL_PARAM_SMO_LAG_COMP, smo_lag_comp, 0.0f, 2.0f),
    P(HIL_PARAM_PLL_KP, pll_kp, 0.0f, 1e6f),
    P(HIL_PARAM_PLL_KI, pll_ki, 0.0f, 1e10f),
    P(HIL_PARAM_SPEED_LPF_RAD_S, speed_lpf_rad_s, 0.0f, 1e6f),
    P(HIL_PARAM_HFI_U_V, hfi_u_v, 0.0f, 1e3f),
    P(HIL_PARAM_HFI_F_HZ, hfi_f_hz, 1.0f, 1e6f),
    P(HIL_PARAM_HFI_BW_RAD_S, hfi_bw_rad_s, 1.0f, 1e5f),
    P(HIL_PARAM_HFI_PI_KP, hfi_kp, 0.0f, 1e6f),
    P(HIL_PARAM_HFI_PI_KI, hfi_ki, 0.0f, 1e10f),
    P(HIL_PARAM_IPD_TIME_S, hfi_ipd_timeout_s, 0.0f, 100.0f),
    P(HIL_PARAM_HFI_POL_BIAS_A, hfi_pol_bias_a, 0.0f, 1e3f),
    P(HIL_PARAM_HFI_LOCK_TOL_RAD, hfi_lock_tol_rad, 1e-4f, 1.0f),
    W(HIL_PARAM_DELAY_COMP_ENABLE, delay_comp_mode, 0.0f, 2.0f),
    P(HIL_PARAM_DELAY_COMP_TD_S, delay_comp_td_s, 0.0f, 1.0f),
    W(HIL_PARAM_HARM_COMP_ENABLE, harm_comp_enable, 0.0f, 1.0f),
    W(HIL_PARAM_HARM_GSDFT_M, harm_m, 6.0f, 96.0f),
    P(HIL_PARAM_HARM_COMP_GAIN, harm_k_comp, 0.0f, 10.0f),
    W(HIL_PARAM_HARM_EXTRACTOR, harm_extractor, 0.0f, 1.0f),
    /* protection (ctrl_protect.h); 0 switches a check off */
    P(HIL_PARAM_PROT_OPEN_I_MIN_A, prot.open_i_min_a, 0.0f, 1e3f),
    P(HIL_PARAM_PROT_OPEN_RATIO, prot.open_ratio, 0.0f, 1.0f),
    P(HIL_PARAM_PROT_OPEN_TIME_S, prot.open_time_s, 0.0f, 100.0f),
    P(HIL_PARAM_PROT_SUM_MAX_A, prot.sum_max_a, 0.0f, 1e3f),
    P(HIL_PARAM_PROT_SUM_TAU_S, prot.sum_tau_s, 0.0f, 10.0f),
    P(HIL_PARAM_PROT_STUCK_TIME_S, prot.stuck_time_s, 0.0f, 100.0f),
    P(HIL_PARAM_PROT_STUCK_DELTA_A, prot.stuck_delta_a, 0.0f, 1e3f),
    P(HIL_PARAM_PROT_VDC_UV_RATIO, prot.vdc_uv_ratio, 0.0f, 1.0f),
    P(HIL_PARAM_PROT_VDC_OV_RATIO, prot.vdc_ov_ratio, 0.0f, 10.0f),
    P(HIL_PARAM_PROT_VDC_TIME_S, prot.vdc_time_s, 0.0f, 10.0f),
    W(HIL_PARAM_PROT_LINK_TIMEOUT_PERIODS, prot.link_timeout_periods, 0.0f, 1e6f),
    P(HIL_PARAM_PROT_ENC_LOST_TIME_S, prot.enc_lost_time_s, 0.0f, 10.0f),
    P(HIL_PARAM_PROT_ENC_EMF_RATIO, prot.enc_emf_ratio, 0.0f, 10.0f),
    P(HIL_PARAM_PROT_ENC_FROZEN_TIME_S, prot.enc_frozen_time_s, 0.0f, 10.0f),
    P(HIL_PARAM_PROT_STALL_TIME_S, prot.stall_time_s, 0.0f, 100.0f),
    P(HIL_PARAM_PROT_STALL_SPEED_RAD_S, prot.stall_speed_rad_s, 0.0f, 1e5f),
    /* super-twisting SMO (est_smo_sta.h) */
    P(HIL_PARAM_SMO_STA_K1_V, smo_sta_k1_v, 0.0f, 1e5f),
    P(HIL_PARAM_SMO_STA_K2_V_S, smo_sta_k2_v_s, 0.0f, 1e9f),
    /* inverter-error feed-forward (inv_comp.h); t_dt < Ts/2 is checked at start */
    W(HIL_PARAM_INV_COMP_ENABLE, inv_comp_mode, 0.0f, 4.0f),
    P(HIL_PARAM_INV_COMP_DEAD_TIME_S, inv_comp_dead_time_s, 0.0f, 1e-3f),
    P(HIL_PARAM_INV_COMP_V_SWITCH_V, inv_comp_v_switch_v, 0.0f, 50.0f),
    P(HIL_PARAM_INV_COMP_R_SWITCH_OHM, inv_comp_r_switch_ohm, 0.0f, 10.0f),
    P(HIL_PARAM_INV_COMP_V_DIODE_V, inv_comp_v_diode_v, 0.0f, 50.0f),
    P(HIL_PARAM_INV_COMP_R_DIODE_OHM, inv_comp_r_diode_ohm, 0.0f, 10.0f),
    P(HIL_PARAM_INV_COMP_BAND_A, inv_comp_band_a, 1e-6f, 1e3f),
    W(HIL_PARAM_INV_COMP_SHAPE, inv_comp_shape, 0.0f, 1.0f),
    P(HIL_PARAM_INV_COMP_I_BW_RAD_S, inv_comp_i_bw_rad_s, 1.0f, 1e5f),
};

static const param_entry_t *find(unsigned param_id)
{
    size_t i;
    for (i = 0u; i < sizeof k_params / sizeof k_params[0]; ++i) {
        if (k_params[i].id == param_id) {
            return &k_params[i];
        }
    }
    return NULL;
}

int ctrl_param_get(const ctrl_config_t *cfg, unsigned param_id, float *value)
{
    const param_entry_t *e = find(param_id);
    if (e == NULL) {
        return HIL_CONFIG_STATUS_UNKNOWN_PARAM;
    }
    *value = *(const float *)(const void *)((const char *)cfg + e->offset);
    return HIL_CONFIG_STATUS_OK;
}

int ctrl_param_set(ctrl_config_t *cfg, unsigned param_id, float value)
{
    size_t i;
    for (i = 0u; i < sizeof k_params / sizeof k_params[0]; ++i) {
        if (k_params[i].id == param_id) {
            float *field = (float *)(void *)((char *)cfg + k_params[i].offset);
            if (!fw_is_finite(value) || value < k_params[i].min || value > k_params[i].max) {
                return HIL_CONFIG_STATUS_OUT_OF_RANGE;
            }
            if (k_params[i].whole) {
                float whole = (float)(long)value; /* in range: |value| <= 1000 */
                if (value < whole || value > whole) {
                    return HIL_CONFIG_STATUS_OUT_OF_RANGE;
                }
            }
            *field = value;
            return HIL_CONFIG_STATUS_OK;
        }
    }
    return HIL_CONFIG_STATUS_UNKNOWN_PARAM;
}
