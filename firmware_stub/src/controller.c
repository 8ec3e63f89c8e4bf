#include "controller.h"

#include <math.h>
#include <stddef.h>

#include "svpwm.h"

#define CTRL_VOLTAGE_MARGIN 0.98f /* use 98 % of the linear SVPWM range */
/* pole radius of the compensation's observer of the HF injection current: the ADC noise is
 * averaged over about 1 / (1 - r) = 10 samples (1.25 periods of a 1250 Hz injection at 10 kHz) */
#define INV_HF_OBS_RADIUS 0.9f

static const est_pll_t *smo_pll(const controller_t *c);

void ctrl_config_defaults(ctrl_config_t *cfg)
{
    /* motor: must come from the host; zeros fail ctrl_start's validation */
    cfg->rs_ohm = 0.0f;
    cfg->ld_h = 0.0f;
    cfg->lq_h = 0.0f;
    cfg->psi_f_wb = 0.0f;
    cfg->pole_pairs = 0.0f;
    cfg->j_kgm2 = 0.0f;
    cfg->b_nms = 0.0f;
    cfg->v_dc_nom_v = 0.0f;
    cfg->ts_s = 1.0e-4f;
    cfg->cur_kp_v_a = 0.0f;
    cfg->cur_ki_v_as = 0.0f;
    cfg->cur_bw_rad_s = 0.0f;
    cfg->spd_kp_a_rad_s = 0.0f;
    cfg->spd_ki_a_rad = 0.0f;
    cfg->spd_bw_rad_s = 62.83f;
    cfg->iq_max_a = 5.0f;
    cfg->speed_loop_div = 1.0f;
    cfg->i_trip_a = 30.0f;
    cfg->t_act_delay_s = 0.0f;
    cfg->align_i_a = 2.0f;
    cfg->align_time_s = 0.2f;
    cfg->if_i_a = 2.0f;
    cfg->if_accel_rad_s2 = 50.0f;
    cfg->handover_speed_rad_s = 20.0f;
    cfg->handover_time_s = 0.05f;
    cfg->estimator = (float)CTRL_EST_SMO_SIGN;
    cfg->smo_k_v = 0.0f;
    cfg->smo_k_factor = 1.5f;
    cfg->smo_k_min_v = 5.0f;
    cfg->smo_wc_rad_s = 1000.0f;
    cfg->smo_m_per_a = 0.01f;
    cfg->smo_sigmoid_a_per_a = 0.0f;
    cfg->smo_lag_comp = (float)EST_SMO_SIGMOID_LAG_EQ15;
    cfg->smo_sta_k1_v = 0.0f;      /* 0: the STA's adaptive gains */
    cfg->smo_sta_k2_v_s = 0.0f;
    cfg->pll_kp = 0.0f;
    cfg->pll_ki = 0.0f;
    cfg->speed_lpf_rad_s = 0.0f;
    cfg->loop_angle = (float)CTRL_LOOP_ANGLE_OBSERVER;
    cfg->hfi_u_v = 6.0f;           /* Hou section 4: 6 V ... */
    cfg->hfi_f_hz = 1250.0f;       /* ... at 1250 Hz */
    cfg->hfi_bw_rad_s = 150.0f;
    cfg->hfi_kp = 0.0f;            /* 0: from hfi_bw_rad_s */
    cfg->hfi_ki = 0.0f;
    cfg->hfi_ipd_timeout_s = 0.5f;
    cfg->hfi_pol_bias_a = 0.0f;    /* 0: Hou's method (HF current alone) */
    cfg->hfi_lock_tol_rad = 0.05f;
    cfg->delay_comp_mode = 0.0f;
    cfg->delay_comp_td_s = 0.0f;
    cfg->harm_comp_enable = 0.0f;
    cfg->harm_m = 96.0f;
    cfg->harm_k_comp = 1.0f;
    cfg->harm_extractor = (float)HARM_EXTRACT_GSDFT;
    cfg->inv_comp_mode = 0.0f;     /* off: a scenario opts in (docs/inverter_comp.md) */
    cfg->inv_comp_dead_time_s = 0.0f;
    cfg->inv_comp_v_switch_v = 0.0f;
    cfg->inv_comp_r_switch_ohm = 0.0f;
    cfg->inv_comp_v_diode_v = 0.0f;
    cfg->inv_comp_r_diode_ohm = 0.0f;
    cfg->inv_comp_band_a = 0.1f;
    cfg->inv_comp_shape = (float)INV_COMP_SHAPE_CAPACITIVE;
    cfg->inv_comp_i_bw_rad_s = 628.3f;   /* 100 Hz */
    ctrl_protect_default_config(&cfg->prot);
}

static void set_outputs_off(controller_t *c)
{
    c->out.duty_abc[0] = c->out.duty_abc[1] = c->out.duty_abc[2] = -1.0f;
    c->v_ab_applied_v.x = c->v_ab_applied_v.y = 0.0f;
    c->v_ab_older_v = c->v_ab_applied_v;
    c->v_ab_acted_v = c->v_ab_applied_v;
}

void ctrl_init(controller_t *c)
{
    ctrl_config_defaults(&c->cfg);
    c->state = CTRL_STATE_IDLE;
    c->fault = CTRL_FAULT_NONE;
    c->mode = CTRL_MODE_SPEED;
    c->speed_ref_rad_s = 0.0f;
    c->iq_cmd_a = 0.0f;
    c->id_cmd_a = 0.0f;
    c->est.theta_e_rad = c->est.omega_e_rad_s = c->est.e_alpha_v = c->est.e_beta_v = 0.0f;
    c->hfi_out = NULL;
    c->out.t_d_est_s = 0.0f;
    c->out.theta_hat_rad = c->out.omega_hat_rad_s = 0.0f;
    c->out.e_alpha_v = c->out.e_beta_v = c->out.i_q_ref_a = 0.0f;
    set_outputs_off(c);
    c->out.state = c->state;
    c->out.fault = c->fault;
    c->fault_detail = 0;
    c->out.fault_detail = 0;
    c->prot_ref_valid = 0;
    c->prot_i_prev_valid = 0;
    c->prot_emf_v = 0.0f;
    c->inv_i_prev_valid = 0;
}

static void enter_fault(controller_t *c, ctrl_fault_t fault)
{
    c->state = CTRL_STATE_FAULT;
    c->fault = fault;
    set_outputs_off(c);
}

/* protection (ctrl_protect.h): the sample and the currents the loop tracked; 1 = tripped */
static int protect(controller_t *c, const ctrl_sample_t *s)
{
    ctrl_protect_input_t in;
    int code;
    in.i_abc_a[0] = s->i_a_a;
    in.i_abc_a[1] = s->i_b_a;
    in.i_abc_a[2] = s->i_c_a;
    in.i_ref_abc_a[0] = in.i_ref_abc_a[1] = in.i_ref_abc_a[2] = 0.0f;
    if (c->prot_ref_valid) {
        fw_vec2_t dq, ab;
        dq.x = c->prot_id_ref_a;
        dq.y = c->prot_iq_ref_a;
        ab = fw_park_inv(dq, sinf(c->prot_theta_rad), cosf(c->prot_theta_rad));
        in.i_ref_abc_a[0] = ab.x;
        in.i_ref_abc_a[1] = -0.5f * ab.x + 0.5f * FW_SQRT3_F * ab.y;
        in.i_ref_abc_a[2] = -0.5f * ab.x - 0.5f * FW_SQRT3_F * ab.y;
    }
    in.v_dc_v = s->v_dc_v;
    in.v_dc_valid = s->v_dc_valid;
    code = ctrl_protect_step(&c->prot, &in);
    if (code != CTRL_PROTECT_NONE) {
        enter_fault(c, (ctrl_fault_t)code);
        c->fault_detail = c->prot.detail;
        return 1;
    }
    return 0;
}

/* motion checks (encoder, stall) after the current loop; 1 = tripped */
static int protect_motion(controller_t *c, const ctrl_sample_t *s, fw_vec2_t i_ab)
{
    const ctrl_config_t *k = &c->cfg;
    ctrl_protect_motion_t m;
    int code;
    m.speed_control = c->state == CTRL_STATE_CLOSED_LOOP && c->mode == CTRL_MODE_SPEED;
    m.i_q_limit_a = k->iq_max_a;
    m.i_q_ref_a = c->iq_ref_a;
    m.i_mag_a = sqrtf(i_ab.x * i_ab.x + i_ab.y * i_ab.y);
    m.omega_m_hat_rad_s = c->est.omega_e_rad_s / k->pole_pairs;
    m.speed_err_rad_s = c->speed_ref_rad_s - m.omega_m_hat_rad_s;
    m.encoder_used = (int)k->estimator == CTRL_EST_ENCODER && c->state == CTRL_STATE_CLOSED_LOOP;
    m.enc_valid = s->theta_enc_valid;
    m.theta_enc_rad = s->theta_enc_rad;
    m.emf_v = 0.0f;
    /* the back-EMF observer's own EMF against the EMF its speed stands for (the stall check) */
    m.emf_hat_v = smo_pll(c) != NULL ? sqrtf(c->est.e_alpha_v * c->est.e_alpha_v +
                                             c->est.e_beta_v * c->est.e_beta_v) : -1.0f;
    m.emf_of_speed_v = fabsf(c->est.omega_e_rad_s) * k->psi_f_wb;
    if (m.encoder_used && c->prot_i_prev_valid) {
        /* back-EMF of the last period from the voltage balance: v - R i - L di/dt (mean L) */
        const float ls = 0.5f * (k->ld_h + k->lq_h);
        fw_vec2_t e;
        e.x = c->v_ab_acted_v.x - k->rs_ohm * 0.5f * (i_ab.x + c->prot_i_prev_ab.x) -
              ls * (i_ab.x - c->prot_i_prev_ab.x) / k->ts_s;
        e.y = c->v_ab_acted_v.y - k->rs_ohm * 0.5f * (i_ab.y + c->prot_i_prev_ab.y) -
              ls * (i_ab.y - c->prot_i_prev_ab.y) / k->ts_s;
        m.emf_v = sqrtf(e.x * e.x + e.y * e.y);
    }
    c->prot_emf_v = m.emf_v;
    c->prot_i_prev_ab = i_ab;
    c->prot_i_prev_valid = 1;
    code = ctrl_protect_motion_step(&c->prot, &m);
    if (code != CTRL_PROTECT_NONE) {
        enter_fault(c, (ctrl_fault_t)code);
        c->fault_detail = c->prot.detail;
        return 1;
    }
    return 0;
}

ctrl_fault_t ctrl_link_tick(controller_t *c, float dt_s)
{
    if (c->state == CTRL_STATE_IDLE || c->state == CTRL_STATE_STOPPED ||
        c->state == CTRL_STATE_FAULT) {
        return CTRL_FAULT_NONE;
    }
    if (ctrl_protect_link_tick(&c->prot, dt_s) == CTRL_PROTECT_LINK_TIMEOUT) {
        enter_fault(c, CTRL_FAULT_LINK_TIMEOUT);
        c->fault_detail = c->prot.detail;
        c->out.state = c->state;
        c->out.fault = c->fault;
        c->out.fault_detail = c->fault_detail;
        return CTRL_FAULT_LINK_TIMEOUT;
    }
    return CTRL_FAULT_NONE;
}

static int config_valid(const ctrl_config_t *k)
{
    /* the motor's parameters have no default (docs/protocol.md 6.2: "required"): 0 = not set */
    return k->rs_ohm > 0.0f && k->ld_h > 0.0f && k->lq_h > 0.0f && k->psi_f_wb > 0.0f &&
           k->pole_pairs >= 1.0f && k->j_kgm2 > 0.0f && k->b_nms >= 0.0f && k->v_dc_nom_v > 0.0f &&
           k->ts_s > 0.0f && k->iq_max_a > 0.0f && k->i_trip_a > 0.0f && k->speed_loop_div >= 1.0f &&
           k->if_accel_rad_s2 > 0.0f && k->handover_speed_rad_s > 0.0f;
}

static int estimator_init(controller_t *c)
{
    const ctrl_config_t *k = &c->cfg;
    float kp, ki;
    est_pll_gains(150.0f, &kp, &ki);
    if (k->pll_kp > 0.0f) {
        kp = k->pll_kp;
    }
    if (k->pll_ki > 0.0f) {
        ki = k->pll_ki;
    }
    switch ((int)k->estimator) {
    case CTRL_EST_SMO_SIGN: {
        est_smo_sign_config_t sc;
        est_smo_sign_default_config(&sc, k->rs_ohm, k->lq_h, k->psi_f_wb, k->ts_s);
        sc.k_v = k->smo_k_v;
        sc.k_factor = k->smo_k_factor;
        sc.k_min_v = k->smo_k_min_v;
        sc.wc_rad_s = k->smo_wc_rad_s;
        sc.pll_kp = kp;
        sc.pll_ki = ki;
        sc.speed_lpf_rad_s = k->speed_lpf_rad_s;
        return est_smo_sign_init(&c->est_state.sign, &sc);
    }
    case CTRL_EST_SMO_SIGMOID: {
        est_smo_sigmoid_config_t sc;
        est_smo_sigmoid_default_config(&sc, k->rs_ohm, k->lq_h, k->psi_f_wb, k->ts_s);
        sc.k_v = k->smo_k_v;          /* must be set by the host (eq. 18); 0 is refused */
        sc.a_per_a = k->smo_sigmoid_a_per_a;
        sc.wc_rad_s = k->smo_wc_rad_s;
        sc.lag_comp = (int)k->smo_lag_comp;
        sc.pll_kp = kp;
        sc.pll_ki = ki;
        sc.speed_lpf_rad_s = k->speed_lpf_rad_s;
        return est_smo_sigmoid_init(&c->est_state.sigmoid, &sc);
    }
    case CTRL_EST_SMO_TANH: {
        est_smo_tanh_config_t sc;
        est_smo_tanh_default_config(&sc, k->rs_ohm, k->lq_h, k->psi_f_wb, k->ts_s);
        sc.k_v = k->smo_k_v;          /* must be set by the host (eq. 17); 0 is refused */
        sc.m_per_a = k->smo_m_per_a;
        sc.pll_kp = kp;
        sc.pll_ki = ki;
        sc.speed_lpf_rad_s = k->speed_lpf_rad_s;
        return est_smo_tanh_init(&c->est_state.tanh_smo, &sc);
    }
    case CTRL_EST_SMO_STA: {
        est_smo_sta_config_t sc;
        est_smo_sta_default_config(&sc, k->rs_ohm, k->lq_h, k->psi_f_wb, k->ts_s);
        sc.k1_v = k->smo_sta_k1_v;
        sc.k2_v_s = k->smo_sta_k2_v_s;
        sc.pll_kp = kp;
        sc.pll_ki = ki;
        sc.speed_lpf_rad_s = k->speed_lpf_rad_s;
        return est_smo_sta_init(&c->est_state.sta, &sc);
    }
    case CTRL_EST_HFI_SDFT: {
        est_hfi_config_t hc;
        est_hfi_default_config(&hc, k->rs_ohm, k->ld_h, k->lq_h, k->ts_s);
        hc.u_inj_v = k->hfi_u_v;
        hc.f_inj_hz = k->hfi_f_hz;
        est_hfi_set_bandwidth(&hc, k->hfi_bw_rad_s);
        if (k->hfi_kp > 0.0f) {
            hc.kp_rad_s = k->hfi_kp;
        }
        if (k->hfi_ki > 0.0f) {
            hc.ki_rad_s2 = k->hfi_ki;
        }
        hc.ipd_on_reset = 1;
        hc.ipd_timeout_s = k->hfi_ipd_timeout_s;
        hc.pol_bias_a = k->hfi_pol_bias_a;
        hc.lock_tol_rad = k->hfi_lock_tol_rad;
        if (k->speed_lpf_rad_s > 0.0f) {
            hc.speed_lpf_rad_s = k->speed_lpf_rad_s;
        }
        c->hfi_out = NULL;
        return est_hfi_init(&c->est_state.hfi, &hc);
    }
    case CTRL_EST_ENCODER:
        est_pll_init(&c->est_state.encoder_pll, kp, ki);
        return 0;
    default:
        return -1;
    }
}

/* Delay pre-compensation and harmonic compensation: optional blocks around the estimator. */
static int extras_init(controller_t *c)
{
    const ctrl_config_t *k = &c->cfg;
    if (k->delay_comp_mode > 0.5f) {
        est_delay_comp_config_t dc;
        est_delay_comp_default_config(&dc, k->ts_s);
        dc.t_d_fixed_s = k->delay_comp_td_s;
        dc.estimate_on = k->delay_comp_mode > 1.5f;
        dc.compensate_on = 1;
        if (est_delay_comp_init(&c->delay_comp, &dc) != 0) {
            return -1;
        }
    }
    if (k->harm_comp_enable > 0.5f) {
        harm_comp_config_t hc;
        harm_comp_default_config(&hc, k->rs_ohm, k->lq_h, k->ts_s);
        hc.m = (int)k->harm_m;
        hc.k_comp = k->harm_k_comp;
        hc.extractor = (int)k->harm_extractor;
        if (harm_comp_init(&c->harm, &hc) != 0) {
            return -1;
        }
    }
    if (k->inv_comp_mode > 0.5f) {
        inv_comp_config_t ic;
        inv_comp_default_config(&ic, k->ts_s);
        ic.dead_time_s = k->inv_comp_dead_time_s;
        ic.v_switch_v = k->inv_comp_v_switch_v;
        ic.r_switch_ohm = k->inv_comp_r_switch_ohm;
        ic.v_diode_v = k->inv_comp_v_diode_v;
        ic.r_diode_ohm = k->inv_comp_r_diode_ohm;
        ic.i_band_a = k->inv_comp_band_a;
        ic.shape = (int)k->inv_comp_shape;
        if (inv_comp_init(&c->inv, &ic) != 0 || !(k->inv_comp_i_bw_rad_s > 0.0f)) {
            return -1;
        }
        c->inv_i_lpf_a = 1.0f - expf(-k->inv_comp_i_bw_rad_s * k->ts_s);
        {   /* the injection's current averaged over the interval the duties act on,
             * [t_k + t_d, t_k+1 + t_d], from its last two samples. The voltage is held between
             * actuation instants, so the current ramps between its values y_k at t_k + t_d; a
             * sample falls on a ramp, i_k = a y_k-1 + (1 - a) y_k (a = t_d / Ts), and the
             * interval's mean is (y_k + y_k+1) / 2. For a tone of the injection frequency
             * (phasors, x_k-1 = e^{-j th} x_k, th = w Ts) that is the gain
             * G = (1 + e^{j th}) / (2 (1 - a + a e^{-j th})) on the sampled tone, realised as
             * A x_k + B x_k-1: A + B e^{-j th} = G */
            const float th = FW_TWO_PI_F * k->hfi_f_hz * k->ts_s;
            const float sn = sinf(th), cs = cosf(th);
            const float a = fw_clampf(k->t_act_delay_s / k->ts_s, 0.0f, 1.0f);
            const float nr = 0.5f * (1.0f + cs), ni = 0.5f * sn;   /* numerator / 2 */
            const float dr = 1.0f - a + a * cs, di = -a * sn;      /* denominator */
            const float dd = dr * dr + di * di;
            const float gr = (nr * dr + ni * di) / dd, gi = (ni * dr - nr * di) / dd;
            const float r = INV_HF_OBS_RADIUS;
            if (fabsf(sn) > 0.05f && dd > 1e-6f) {
                c->inv_hf_c0 = -gi / sn;
                c->inv_hf_c1 = gr - c->inv_hf_c0 * cs;
            } else {
                c->inv_hf_c1 = 1.0f;   /* near 0 or fs/2: the sample as it is */
                c->inv_hf_c0 = 0.0f;
            }
            /* tone observer gains: error dynamics (I - L C) A with trace 2 r cos(th), det r^2 */
            c->inv_hf_cos = cs;
            c->inv_hf_l1 = 1.0f - r * r;
            c->inv_hf_l2 = 2.0f * cs * r * (1.0f - r);
        }
    }
    c->inv_i_prev_valid = 0;
    return 0;
}

int ctrl_start(controller_t *c)
{
    ctrl_config_t *k = &c->cfg;
    pi_ctrl_config_t pc;
    float bw, kp_q, ki, vmax;

    c->hfi_out = NULL;
    k->prot.i_trip_a = k->i_trip_a;
    if (!config_valid(k) || estimator_init(c) != 0 || extras_init(c) != 0 ||
        ctrl_protect_init(&c->prot, &k->prot, k->ts_s, k->v_dc_nom_v) != 0) {
        enter_fault(c, CTRL_FAULT_CONFIG_INVALID);
        return -1;
    }
    c->kt_nm_a = 1.5f * k->pole_pairs * k->psi_f_wb;

    bw = k->cur_bw_rad_s > 0.0f ? k->cur_bw_rad_s : FW_TWO_PI_F / (20.0f * k->ts_s);
    kp_q = k->cur_kp_v_a > 0.0f ? k->cur_kp_v_a : k->lq_h * bw;
    ki = k->cur_ki_v_as > 0.0f ? k->cur_ki_v_as : k->rs_ohm * bw;
    vmax = CTRL_VOLTAGE_MARGIN * k->v_dc_nom_v * FW_INV_SQRT3_F;
    pc.kp = kp_q * k->ld_h / k->lq_h;
    pc.ki = ki;
    pc.out_min = -vmax;
    pc.out_max = vmax;
    pi_ctrl_init(&c->pi_d, &pc);
    pc.kp = kp_q;
    pi_ctrl_init(&c->pi_q, &pc);

    bw = k->spd_bw_rad_s > 0.0f ? k->spd_bw_rad_s : 62.83f;
    pc.kp = k->spd_kp_a_rad_s > 0.0f ? k->spd_kp_a_rad_s : k->j_kgm2 * bw / c->kt_nm_a;
    pc.ki = k->spd_ki_a_rad > 0.0f ? k->spd_ki_a_rad : pc.kp * bw * 0.25f;
    pc.out_min = -k->iq_max_a;
    pc.out_max = k->iq_max_a;
    pi_ctrl_init(&c->pi_speed, &pc);

    c->speed_div_count = 0u;
    c->iq_ref_a = c->id_ref_a = 0.0f;
    c->t_state_s = 0.0f;
    c->theta_ol_rad = 0.0f;
    c->omega_ol_rad_s = 0.0f;
    c->id_handover_a = 0.0f;
    c->i_ol_dq_f_a.x = c->i_ol_dq_f_a.y = 0.0f;
    c->i_ol_lpf = 1.0f - expf(-CTRL_HANDOVER_I_LPF_RAD_S * k->ts_s);
    c->v_ab_applied_v.x = c->v_ab_applied_v.y = 0.0f;
    c->v_ab_older_v = c->v_ab_applied_v;
    c->v_ab_acted_v = c->v_ab_applied_v;
    c->fault = CTRL_FAULT_NONE;
    c->fault_detail = 0;
    c->prot_ref_valid = 0;
    c->prot_i_prev_valid = 0;
    /* with an encoder there is nothing to start open loop: close the loop at once; HF injection
     * finds the initial position at standstill first (Hou section 3) */
    if ((int)k->estimator == CTRL_EST_ENCODER) {
        c->state = CTRL_STATE_CLOSED_LOOP;
    } else if ((int)k->estimator == CTRL_EST_HFI_SDFT) {
        c->state = CTRL_STATE_INITIAL_POSITION;
    } else {
        c->state = CTRL_STATE_ALIGN;
    }
    return 0;
}

void ctrl_stop(controller_t *c)
{
    if (c->state != CTRL_STATE_FAULT) {
        c->state = CTRL_STATE_STOPPED;
    }
    set_outputs_off(c);
}

void ctrl_clear_fault(controller_t *c)
{
    if (c->state == CTRL_STATE_FAULT) {
        c->state = CTRL_STATE_IDLE;
        c->fault = CTRL_FAULT_NONE;
        c->fault_detail = 0;
        ctrl_protect_reset(&c->prot);
    }
}

/* A non-finite reference (a NaN in a CMD frame: found by tests/fuzz/fuzz_session.c) would
 * turn every duty into NaN: it is ignored, the previous reference holds. */
void ctrl_set_speed_ref(controller_t *c, float speed_ref_rad_s)
{
    if (fw_is_finite(speed_ref_rad_s)) {
        c->speed_ref_rad_s = speed_ref_rad_s;
    }
}

void ctrl_set_current_ref(controller_t *c, float id_a, float iq_a)
{
    if (fw_is_finite(id_a) && fw_is_finite(iq_a)) {
        c->id_cmd_a = id_a;
        c->iq_cmd_a = iq_a;
    }
}

void ctrl_set_mode(controller_t *c, ctrl_mode_t mode)
{
    c->mode = mode;
}

static void run_estimator(controller_t *c, fw_vec2_t i_ab, const ctrl_sample_t *s)
{
    switch ((int)c->cfg.estimator) {
    case CTRL_EST_SMO_SIGN:
        c->est = *est_smo_sign_step(&c->est_state.sign, i_ab, c->v_ab_acted_v);
        break;
    case CTRL_EST_SMO_SIGMOID:
        c->est = *est_smo_sigmoid_step(&c->est_state.sigmoid, i_ab, c->v_ab_acted_v);
        break;
    case CTRL_EST_SMO_TANH:
        c->est = *est_smo_tanh_step(&c->est_state.tanh_smo, i_ab, c->v_ab_acted_v);
        break;
    case CTRL_EST_SMO_STA:
        c->est = *est_smo_sta_step(&c->est_state.sta, i_ab, c->v_ab_acted_v);
        break;
    case CTRL_EST_HFI_SDFT:
        c->hfi_out = est_hfi_step(&c->est_state.hfi, i_ab, c->v_ab_acted_v);
        c->est = c->hfi_out->est;
        break;
    case CTRL_EST_ENCODER:
        if (s->theta_enc_valid && fw_is_finite(s->theta_enc_rad)) {
            c->est.theta_e_rad = fw_wrap_2pi(s->theta_enc_rad);
            c->est.omega_e_rad_s = est_pll_step(&c->est_state.encoder_pll, c->est.theta_e_rad,
                                                c->cfg.ts_s);
        } else {
            /* no reading this period: extrapolate with the speed estimate (the protection
             * reports the encoder lost after enc_lost_time_s) */
            est_pll_t *pll = &c->est_state.encoder_pll;
            pll->theta_rad = fw_wrap_2pi(pll->theta_rad + pll->omega_rad_s * c->cfg.ts_s);
            c->est.theta_e_rad = fw_wrap_2pi(c->est.theta_e_rad + pll->omega_rad_s * c->cfg.ts_s);
            c->est.omega_e_rad_s = pll->omega_rad_s;
        }
        c->est.e_alpha_v = 0.0f;
        c->est.e_beta_v = 0.0f;
        break;
    default:
        break;
    }
}

/* The PLL of the selected SMO (NULL for HF injection, the encoder, none). */
static const est_pll_t *smo_pll(const controller_t *c)
{
    switch ((int)c->cfg.estimator) {
    case CTRL_EST_SMO_SIGN:
        return &c->est_state.sign.pll;
    case CTRL_EST_SMO_SIGMOID:
        return &c->est_state.sigmoid.pll;
    case CTRL_EST_SMO_TANH:
        return &c->est_state.tanh_smo.pll;
    case CTRL_EST_SMO_STA:
        return &c->est_state.sta.pll;
    default:
        return NULL;
    }
}

/* The angle the closed loop turns its frames with (ctrl_loop_angle_t): the estimator's, or the
 * PLL's that tracks an SMO's EMF angle. */
static float loop_angle_rad(const controller_t *c)
{
    const est_pll_t *pll = smo_pll(c);
    if (pll != NULL && (int)c->cfg.loop_angle == CTRL_LOOP_ANGLE_PLL) {
        return pll->theta_rad;
    }
    return c->est.theta_e_rad;
}

/* Gong's current pre-compensation is on: the currents (and so the estimate) refer to t_k + t_d. */
static int delay_compensating(const controller_t *c)
{
    return c->cfg.delay_comp_mode > 0.5f;
}

/* Re-express the current-loop integrators (voltages) in a frame rotated by delta_rad. */
static void rotate_current_integrators(controller_t *c, float delta_rad)
{
    fw_vec2_t v;
    float sd = sinf(delta_rad), cd = cosf(delta_rad);
    v.x = c->pi_d.integ;
    v.y = c->pi_q.integ;
    v = fw_park(v, sd, cd);
    pi_ctrl_reset(&c->pi_d, v.x);
    pi_ctrl_reset(&c->pi_q, v.y);
}

/* Inverter-error feed-forward (inv_comp.h) on the SVPWM duties: the phase currents the period's
 * error depends on (mode 1: the last two samples extrapolated to the middle of the interval the
 * duties act on; mode 2: the sample), the compensated duties out, and the observers' voltage of
 * the next period = what the compensation's inverter model says the duties make. */
/* The injection's current as a sampled tone, x_k+1 = 2 cos(w Ts) x_k - x_k-1, observed from its
 * noisy samples: state (x_k, x_k-1), observer poles at INV_HF_OBS_RADIUS e^{+-j w Ts} (the
 * ADC's noise averaged over ~1 / (1 - r) samples instead of entering the compensation raw). */
static void tone_observer_step(controller_t *c, fw_vec2_t y)
{
    const float cw = c->inv_hf_cos, l1 = c->inv_hf_l1, l2 = c->inv_hf_l2;
    fw_vec2_t p, e;
    p.x = 2.0f * cw * c->inv_hf_s1_a.x - c->inv_hf_s2_a.x;   /* predicted x_k */
    p.y = 2.0f * cw * c->inv_hf_s1_a.y - c->inv_hf_s2_a.y;
    e.x = y.x - p.x;
    e.y = y.y - p.y;
    c->inv_hf_s2_a.x = c->inv_hf_s1_a.x + l2 * e.x;
    c->inv_hf_s2_a.y = c->inv_hf_s1_a.y + l2 * e.y;
    c->inv_hf_s1_a.x = p.x + l1 * e.x;
    c->inv_hf_s1_a.y = p.y + l1 * e.y;
}

static void inverter_feed_forward(controller_t *c, const ctrl_sample_t *s, float v_dc,
                                  float theta_pwm, fw_vec2_t i_dq)
{
    const ctrl_config_t *k = &c->cfg;
    float i_now[3], i_use[3];
    i_now[0] = s->i_a_a;
    i_now[1] = s->i_b_a;
    i_now[2] = s->i_c_a;
    if (k->inv_comp_mode > 3.5f) {
        /* current-vector method: the measured current vector low-passed in the controller's
         * rotating frame (no lag on the fundamental, the ADC noise filtered out), then turned to
         * the angle of the middle of the interval the duties act on */
        fw_vec2_t ab;
        if (!c->inv_i_prev_valid) {
            c->inv_i_dq_f_a = i_dq;
        }
        c->inv_i_dq_f_a.x += c->inv_i_lpf_a * (i_dq.x - c->inv_i_dq_f_a.x);
        c->inv_i_dq_f_a.y += c->inv_i_lpf_a * (i_dq.y - c->inv_i_dq_f_a.y);
        ab = fw_park_inv(c->inv_i_dq_f_a, sinf(theta_pwm), cosf(theta_pwm));
        if (c->hfi_out != NULL) {
            /* HF injection: the injection's current is no part of the filtered fundamental;
             * its mean over the interval the duties act on, from its last two samples (a
             * sampled tone of the known injection frequency, ctrl_start) */
            const fw_vec2_t i_ab = fw_clarke(i_now[0], i_now[1], i_now[2]);
            fw_vec2_t hf;
            hf.x = i_ab.x - c->hfi_out->i_fund_ab_a.x;
            hf.y = i_ab.y - c->hfi_out->i_fund_ab_a.y;
            if (!c->inv_i_prev_valid) {
                c->inv_hf_s1_a = hf;
                c->inv_hf_s2_a = hf;
            }
            tone_observer_step(c, hf);
            ab.x += c->inv_hf_c1 * c->inv_hf_s1_a.x + c->inv_hf_c0 * c->inv_hf_s2_a.x;
            ab.y += c->inv_hf_c1 * c->inv_hf_s1_a.y + c->inv_hf_c0 * c->inv_hf_s2_a.y;
        }
        fw_clarke_inv(ab, &i_use[0], &i_use[1], &i_use[2]);
    } else if (k->inv_comp_mode > 2.5f) {
        /* the current loop's reference at the angle of the middle of the interval the duties
         * act on (no measurement noise in the zero-crossing band) */
        fw_vec2_t dq, ab;
        dq.x = c->id_ref_a;
        dq.y = c->iq_ref_a;
        ab = fw_park_inv(dq, sinf(theta_pwm), cosf(theta_pwm));
        fw_clarke_inv(ab, &i_use[0], &i_use[1], &i_use[2]);
    } else if (k->inv_comp_mode < 1.5f && c->inv_i_prev_valid) {
        inv_comp_predict(i_now, c->inv_i_prev_a, (k->t_act_delay_s + 0.5f * k->ts_s) / k->ts_s,
                         i_use);
    } else {
        i_use[0] = i_now[0];
        i_use[1] = i_now[1];
        i_use[2] = i_now[2];
    }
    c->v_ab_applied_v = inv_comp_step(&c->inv, c->out.duty_abc, i_use, v_dc);
    c->out.duty_abc[0] = c->inv.duty_abc[0];
    c->out.duty_abc[1] = c->inv.duty_abc[1];
    c->out.duty_abc[2] = c->inv.duty_abc[2];
    c->inv_i_prev_a[0] = i_now[0];
    c->inv_i_prev_a[1] = i_now[1];
    c->inv_i_prev_a[2] = i_now[2];
    c->inv_i_prev_valid = 1;
}

/* From I-f to the estimator's angle: the current-loop integrators and the compensation's filtered
 * current re-expressed in the estimator's frame, and the speed loop seeded with the q current
 * that flowed: the I-f current low-passed in the open-loop frame (CTRL_HANDOVER_I_LPF_RAD_S),
 * turned into the estimator's frame. One raw sample would carry the ADC's noise into the torque
 * the drive holds its load with at the instant it hands over (a 9.3 A seed for 10.7 A flowing
 * was seen under Yuan's full load: the rotor fell from 8 to 0.5 rpm in 15 ms). */
static void handover(controller_t *c)
{
    const float th = loop_angle_rad(c);
    const float d = fw_wrap_pi(th - c->theta_ol_rad);
    const fw_vec2_t i_dq = fw_park(c->i_ol_dq_f_a, sinf(d), cosf(d));
    rotate_current_integrators(c, d);
    /* the compensation's filtered current vector too (current-vector method) */
    c->inv_i_dq_f_a = fw_park(c->inv_i_dq_f_a, sinf(d), cosf(d));
    pi_ctrl_reset(&c->pi_speed, i_dq.y);
    c->iq_ref_a = c->pi_speed.integ;
    c->id_handover_a = i_dq.x;
    c->state = CTRL_STATE_CLOSED_LOOP;
    c->t_state_s = 0.0f;
}

const ctrl_output_t *ctrl_step(controller_t *c, const ctrl_sample_t *s)
{
    const ctrl_config_t *k = &c->cfg;
    fw_vec2_t i_ab, i_ab_meas, i_dq, v_dq, v_ab;
    float theta, omega_e, sin_t, cos_t, v_dc, vmax, ff_d, ff_q, vq_lim, theta_pwm;

    if (c->state == CTRL_STATE_IDLE || c->state == CTRL_STATE_STOPPED ||
        c->state == CTRL_STATE_FAULT) {
        set_outputs_off(c);
        goto finish;
    }
    if (protect(c, s)) { /* over-current, open phase, sensors, bus (ctrl_protect.h) */
        goto finish;
    }
    i_ab = fw_clarke(s->i_a_a, s->i_b_a, s->i_c_a);
    i_ab_meas = i_ab;
    /* the measured bus once one has arrived (a collapsed bus modulates as it is; the protection
     * reports it), the nominal bus before */
    v_dc = (s->v_dc_valid && fw_is_finite(s->v_dc_v)) ? s->v_dc_v : k->v_dc_nom_v;
    if (k->delay_comp_mode > 0.5f) {
        /* Gong eq. 20-22: the second sample of the previous period first (delay estimate), then
         * this period's first sample, predicted to the actuation instant; the estimator and the
         * current loop both use the predicted currents */
        const est_delay_comp_output_t *dco;
        float i1[3];
        i1[0] = s->i_a_a;
        i1[1] = s->i_b_a;
        i1[2] = s->i_c_a;
        if (s->have_i2) {
            est_delay_comp_sample2(&c->delay_comp, s->i2_abc_a);
        }
        dco = est_delay_comp_sample1(&c->delay_comp, i1);
        i_ab = dco->i_ab_a;
        c->out.t_d_est_s = dco->t_d_s;
    }

    {   /* the voltage that acted over [t_(k-1), t_k]: the older command until t_d, then the newer.
         * With Gong's pre-compensation the currents are predicted at t_k + t_d, so the interval the
         * estimator propagates over is [t_(k-1) + t_d, t_k + t_d], where the newer command acted
         * alone (w = 0). */
        float w = delay_compensating(c) ? 0.0f : fw_clampf(k->t_act_delay_s / k->ts_s, 0.0f, 1.0f);
        c->v_ab_acted_v.x = w * c->v_ab_older_v.x + (1.0f - w) * c->v_ab_applied_v.x;
        c->v_ab_acted_v.y = w * c->v_ab_older_v.y + (1.0f - w) * c->v_ab_applied_v.y;
    }
    run_estimator(c, i_ab, s);
    c->t_state_s += k->ts_s;
    if (c->state == CTRL_STATE_ALIGN || c->state == CTRL_STATE_OPEN_LOOP) {
        /* the current that flows in the open-loop frame, low-passed: the hand-over's seed */
        const fw_vec2_t i_ol = fw_park(i_ab, sinf(c->theta_ol_rad), cosf(c->theta_ol_rad));
        c->i_ol_dq_f_a.x += c->i_ol_lpf * (i_ol.x - c->i_ol_dq_f_a.x);
        c->i_ol_dq_f_a.y += c->i_ol_lpf * (i_ol.y - c->i_ol_dq_f_a.y);
    }

    switch (c->state) {
    case CTRL_STATE_ALIGN:
        /* d-axis current ramps up over the first half, holds for the second (rotor to 0 rad) */
        c->theta_ol_rad = 0.0f;
        c->omega_ol_rad_s = 0.0f;
        c->id_ref_a = k->align_i_a * fw_clampf(2.0f * c->t_state_s / k->align_time_s, 0.0f, 1.0f);
        c->iq_ref_a = 0.0f;
        if (c->t_state_s >= k->align_time_s) {
            c->state = CTRL_STATE_OPEN_LOOP;
            c->t_state_s = 0.0f;
        }
        break;
    case CTRL_STATE_OPEN_LOOP: {
        /* I-f: current of fixed magnitude on the d axis of a frame accelerated open loop;
         * the rotor follows with a load angle (self-stabilising). */
        float w_mech = c->omega_ol_rad_s / k->pole_pairs + k->if_accel_rad_s2 * k->ts_s;
        float w_target = k->handover_speed_rad_s;
        if (w_mech > w_target) {
            w_mech = w_target;
        }
        c->omega_ol_rad_s = w_mech * k->pole_pairs;
        c->theta_ol_rad = fw_wrap_2pi(c->theta_ol_rad + c->omega_ol_rad_s * k->ts_s);
        c->id_ref_a = k->if_i_a;
        c->iq_ref_a = 0.0f;
        if (w_mech >= w_target && (int)k->estimator != CTRL_EST_NONE) {
            handover(c);
        }
        break;
    }
    case CTRL_STATE_INITIAL_POSITION:
        /* HF injection at standstill: 2 dtheta -> 0, then the N/S test (Hou section 3); the
         * current loop holds zero current except the d-bias the polarity test may ask for */
        c->id_ref_a = c->hfi_out != NULL ? c->hfi_out->i_d_req_a : 0.0f;
        c->iq_ref_a = 0.0f;
        if (c->hfi_out != NULL && c->hfi_out->ipd_state == EST_HFI_TRACKING) {
            pi_ctrl_reset(&c->pi_speed, 0.0f);
            c->id_handover_a = 0.0f;
            c->state = CTRL_STATE_CLOSED_LOOP;
            c->t_state_s = 0.0f;
        } else if (c->hfi_out != NULL && c->hfi_out->ipd_state == EST_HFI_IPD_FAILED) {
            enter_fault(c, CTRL_FAULT_STARTUP_FAILED);   /* polarity undecided: never guess */
            goto finish;
        }
        break;
    default:
        break;
    }

    if (c->state == CTRL_STATE_CLOSED_LOOP || c->state == CTRL_STATE_INITIAL_POSITION) {
        float id_fade = 1.0f - (k->handover_time_s > 0.0f ? c->t_state_s / k->handover_time_s : 1.0f);
        theta = loop_angle_rad(c);
        omega_e = c->est.omega_e_rad_s;
        if (c->state == CTRL_STATE_INITIAL_POSITION) {
            /* references set above; the rotor is at standstill while the estimate converges:
             * no speed-dependent feed-forward or angle advance from a speed not yet known */
            omega_e = 0.0f;
        } else if (c->mode == CTRL_MODE_SPEED) {
            c->id_ref_a = c->id_handover_a * fw_clampf(id_fade, 0.0f, 1.0f);
            c->speed_div_count++;
            if ((float)c->speed_div_count >= k->speed_loop_div) {
                float w_m = omega_e / k->pole_pairs;
                c->speed_div_count = 0u;
                c->iq_ref_a = pi_ctrl_step(&c->pi_speed, c->speed_ref_rad_s - w_m,
                                           k->ts_s * k->speed_loop_div);
            }
        } else {
            c->id_ref_a = c->id_handover_a * fw_clampf(id_fade, 0.0f, 1.0f) + c->id_cmd_a;
            c->iq_ref_a = fw_clampf(c->iq_cmd_a, -k->iq_max_a, k->iq_max_a);
        }
    } else {
        theta = c->theta_ol_rad;
        omega_e = c->omega_ol_rad_s;
    }

    /* current loop with decoupling feed-forward and a circular voltage limit (d first) */
    sin_t = sinf(theta);
    cos_t = cosf(theta);
    /* with HF injection the loop sees the fundamental only, and leaves room for the injection */
    i_dq = fw_park(c->hfi_out != NULL ? c->hfi_out->i_fund_ab_a : i_ab, sin_t, cos_t);
    vmax = CTRL_VOLTAGE_MARGIN * v_dc * FW_INV_SQRT3_F;
    if (c->hfi_out != NULL) {
        vmax = fmaxf(vmax - k->hfi_u_v, 0.0f);
    }
    ff_d = -omega_e * k->lq_h * i_dq.y;
    ff_q = omega_e * (k->ld_h * i_dq.x + k->psi_f_wb);
    pi_ctrl_set_limits(&c->pi_d, -vmax - ff_d, vmax - ff_d);
    v_dq.x = pi_ctrl_step(&c->pi_d, c->id_ref_a - i_dq.x, k->ts_s) + ff_d;
    vq_lim = sqrtf(fmaxf(vmax * vmax - v_dq.x * v_dq.x, 0.0f));
    pi_ctrl_set_limits(&c->pi_q, -vq_lim - ff_q, vq_lim - ff_q);
    v_dq.y = pi_ctrl_step(&c->pi_q, c->iq_ref_a - i_dq.y, k->ts_s) + ff_q;
    c->prot_ref_valid = 1; /* what the loop tracks, at the angle of the next sample */
    c->prot_id_ref_a = c->id_ref_a;
    c->prot_iq_ref_a = c->iq_ref_a;
    c->prot_theta_rad = theta + omega_e * k->ts_s;
    if (protect_motion(c, s, i_ab_meas)) { /* encoder plausibility, stall (ctrl_protect.h) */
        goto finish;
    }

    /* the voltage acts from t_k + delay on: advance the angle to the middle of its action */
    /* (with the pre-compensation the angle already refers to t_k + t_d: only the half period) */
    theta_pwm = theta + omega_e * ((delay_compensating(c) ? 0.0f : k->t_act_delay_s) + 0.5f * k->ts_s);
    if (k->harm_comp_enable > 0.5f) {
        /* Yuan eq. 28-37: 5th/7th extracted from the measured current, compensation voltages
         * added to the current-loop output */
        fw_vec2_t dv;
        (void)harm_comp_step(&c->harm, i_ab, theta, omega_e);
        dv = harm_comp_voltage_dq(&c->harm, theta_pwm);
        v_dq.x += dv.x;
        v_dq.y += dv.y;
    }
    v_ab = fw_park_inv(v_dq, sinf(theta_pwm), cosf(theta_pwm));
    if (c->hfi_out != NULL) {
        v_ab.x += c->hfi_out->v_inj_ab_v.x;
        v_ab.y += c->hfi_out->v_inj_ab_v.y;
    }
    c->v_ab_older_v = c->v_ab_applied_v;
    c->v_ab_applied_v = svpwm_duties(v_ab, v_dc, c->out.duty_abc);
    if (k->inv_comp_mode > 0.5f) {
        inverter_feed_forward(c, s, v_dc, theta_pwm, i_dq);
    }

finish:
    c->out.theta_hat_rad = loop_angle_rad(c);   /* the angle the drive turns its frames with */
    c->out.omega_hat_rad_s = c->est.omega_e_rad_s;
    c->out.e_alpha_v = c->est.e_alpha_v;
    c->out.e_beta_v = c->est.e_beta_v;
    c->out.i_q_ref_a = c->iq_ref_a;
    c->out.state = c->state;
    c->out.fault = c->fault;
    c->out.fault_detail = c->fault_detail;
    return &c->out;
}
