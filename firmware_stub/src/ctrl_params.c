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
    unsigned since_minor; /* the protocol's minor version that added it (DBC attribute HilSince) */
} param_entry_t;

/* Range, kind and version of each parameter come from protocol/hil.dbc (the multiplexed signals of
 * CONFIG, generated into hil_msgs.h as HIL_PARAM_<NAME>_MIN/_MAX/_KIND/_SINCE_MINOR): one source for
 * the stub, the host and the spec. Integer, boolean and enum parameters take whole numbers only (the
 * enums' values are 0..MAX). */
#define P(NAME, FIELD) { (unsigned)HIL_PARAM_##NAME, offsetof(ctrl_config_t, FIELD), HIL_PARAM_##NAME##_MIN, \
                         HIL_PARAM_##NAME##_MAX, HIL_PARAM_##NAME##_KIND != HIL_PARAM_KIND_REAL, \
                         HIL_PARAM_##NAME##_SINCE_MINOR }

static const param_entry_t k_params[] = {
    P(RS_OHM, rs_ohm),
    P(LD_H, ld_h),
    P(LQ_H, lq_h),
    P(PSI_F_WB, psi_f_wb),
    P(POLE_PAIRS, pole_pairs),
    P(J_KGM2, j_kgm2),
    P(B_NMS, b_nms),
    P(V_DC_NOM_V, v_dc_nom_v),
    P(CUR_KP_V_A, cur_kp_v_a),
    P(CUR_KI_V_AS, cur_ki_v_as),
    P(SPD_KP_A_RAD_S, spd_kp_a_rad_s),
    P(SPD_KI_A_RAD, spd_ki_a_rad),
    P(IQ_MAX_A, iq_max_a),
    P(SPEED_LOOP_DIV, speed_loop_div),
    P(I_MAX_TRIP_A, i_trip_a),
    P(ALIGN_I_A, align_i_a),
    P(ALIGN_TIME_S, align_time_s),
    P(IF_I_A, if_i_a),
    P(IF_ACCEL_RAD_S2, if_accel_rad_s2),
    P(HANDOVER_SPEED_RAD_S, handover_speed_rad_s),
    P(HANDOVER_TIME_S, handover_time_s),
    P(CTRL_DELAY_S, t_act_delay_s),
    P(LOOP_ANGLE, loop_angle),
    P(SMO_K_V, smo_k_v),
    P(SMO_WC_RAD_S, smo_wc_rad_s),
    P(SMO_K_FACTOR, smo_k_factor),
    P(SMO_K_MIN_V, smo_k_min_v),
    P(SMO_M_PER_A, smo_m_per_a),
    P(SMO_SIGMOID_A_PER_A, smo_sigmoid_a_per_a),
    P(SMO_LAG_COMP, smo_lag_comp),
    P(PLL_KP, pll_kp),
    P(PLL_KI, pll_ki),
    P(SPEED_LPF_RAD_S, speed_lpf_rad_s),
    P(HFI_U_V, hfi_u_v),
    P(HFI_F_HZ, hfi_f_hz),
    P(HFI_BW_RAD_S, hfi_bw_rad_s),
    P(HFI_PI_KP, hfi_kp),
    P(HFI_PI_KI, hfi_ki),
    P(IPD_TIME_S, hfi_ipd_timeout_s),
    P(HFI_POL_BIAS_A, hfi_pol_bias_a),
    P(HFI_LOCK_TOL_RAD, hfi_lock_tol_rad),
    P(DELAY_COMP_ENABLE, delay_comp_mode),
    P(DELAY_COMP_TD_S, delay_comp_td_s),
    P(HARM_COMP_ENABLE, harm_comp_enable),
    P(HARM_GSDFT_M, harm_m),
    P(HARM_COMP_GAIN, harm_k_comp),
    P(HARM_EXTRACTOR, harm_extractor),
    /* protection (ctrl_protect.h); 0 switches a check off */
    P(PROT_OPEN_I_MIN_A, prot.open_i_min_a),
    P(PROT_OPEN_RATIO, prot.open_ratio),
    P(PROT_OPEN_TIME_S, prot.open_time_s),
    P(PROT_SUM_MAX_A, prot.sum_max_a),
    P(PROT_SUM_TAU_S, prot.sum_tau_s),
    P(PROT_STUCK_TIME_S, prot.stuck_time_s),
    P(PROT_STUCK_DELTA_A, prot.stuck_delta_a),
    P(PROT_VDC_UV_RATIO, prot.vdc_uv_ratio),
    P(PROT_VDC_OV_RATIO, prot.vdc_ov_ratio),
    P(PROT_VDC_TIME_S, prot.vdc_time_s),
    P(PROT_LINK_TIMEOUT_PERIODS, prot.link_timeout_periods),
    P(PROT_ENC_LOST_TIME_S, prot.enc_lost_time_s),
    P(PROT_ENC_EMF_RATIO, prot.enc_emf_ratio),
    P(PROT_ENC_FROZEN_TIME_S, prot.enc_frozen_time_s),
    P(PROT_STALL_TIME_S, prot.stall_time_s),
    P(PROT_STALL_SPEED_RAD_S, prot.stall_speed_rad_s),
    /* super-twisting SMO (est_smo_sta.h) */
    P(SMO_STA_K1_V, smo_sta_k1_v),
    P(SMO_STA_K2_V_S, smo_sta_k2_v_s),
    /* inverter-error feed-forward (inv_comp.h); t_dt < Ts/2 is checked at start */
    P(INV_COMP_ENABLE, inv_comp_mode),
    P(INV_COMP_DEAD_TIME_S, inv_comp_dead_time_s),
    P(INV_COMP_V_SWITCH_V, inv_comp_v_switch_v),
    P(INV_COMP_R_SWITCH_OHM, inv_comp_r_switch_ohm),
    P(INV_COMP_V_DIODE_V, inv_comp_v_diode_v),
    P(INV_COMP_R_DIODE_OHM, inv_comp_r_diode_ohm),
    P(INV_COMP_BAND_A, inv_comp_band_a),
    P(INV_COMP_SHAPE, inv_comp_shape),
    P(INV_COMP_I_BW_RAD_S, inv_comp_i_bw_rad_s),
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

int ctrl_param_since_minor(unsigned param_id)
{
    const param_entry_t *e = find(param_id);
    return e == NULL ? -1 : (int)e->since_minor;
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
