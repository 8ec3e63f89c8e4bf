/**
 * @file test_fw_smo.c
 * @brief Unit tests of the SMO-family estimators: the improved sigmoid SMO (Yuan), the tanh SMO
 * without LPF (Gong), the dual-sampling delay estimate and pre-compensation (Gong): convergence
 * on synthetic data, gain helpers against hand-computed values, invalid configurations refused.
 */
#include <math.h>
#include <stdio.h>

#include "est_delay_comp.h"
#include "est_smo_sigmoid.h"
#include "est_smo_tanh.h"
#include "fw_math.h"

#include "check.h"

static float absf(float x) { return x < 0.0f ? -x : x; }

/* Gong Table I */
#define RS_OHM 0.6383f
#define LS_H 2e-3f
#define PSI_WB 0.085f
#define TS_S 1e-4f
#define RPM_TO_RAD_S 0.10471976f

/* ---- synthetic plant: exact ZOH RL step, back EMF at mid-period, voltage ~ E + R i_q ---- */
typedef struct {
    float f, g, we, th;
    fw_vec2_t i;
} synth_t;

static void synth_init(synth_t *p, float rpm)
{
    p->f = expf(-RS_OHM * TS_S / LS_H);
    p->g = (1.0f - p->f) / RS_OHM;
    p->we = rpm * RPM_TO_RAD_S * 4.0f;
    p->th = 0.3f;
    p->i.x = p->i.y = 0.0f;
}

/* The voltage for the coming period (i_q about 1 A), then the plant over that period. */
static fw_vec2_t synth_step(synth_t *p)
{
    float th_mid = p->th + 0.5f * p->we * TS_S;
    fw_vec2_t v = {-p->we * PSI_WB * sinf(th_mid) - RS_OHM * sinf(th_mid),
                   p->we * PSI_WB * cosf(th_mid) + RS_OHM * cosf(th_mid)};
    fw_vec2_t em = {-p->we * PSI_WB * sinf(th_mid), p->we * PSI_WB * cosf(th_mid)};
    p->i.x = p->f * p->i.x + p->g * (v.x - em.x);
    p->i.y = p->f * p->i.y + p->g * (v.y - em.y);
    p->th = fw_wrap_2pi(p->th + p->we * TS_S);
    return v;
}

/* ---- improved sigmoid SMO ---------------------------------------------------------------- */
static float run_sigmoid(int lag_comp, float rpm, float *speed_rad_s)
{
    est_smo_sigmoid_t smo;
    est_smo_sigmoid_config_t cfg;
    synth_t p;
    fw_vec2_t v_prev = {0.0f, 0.0f};
    float err_sum = 0.0f;
    int k, n = 0;
    synth_init(&p, rpm);
    est_smo_sigmoid_default_config(&cfg, RS_OHM, LS_H, PSI_WB, TS_S);
    cfg.k_v = 320.0f;
    cfg.lag_comp = lag_comp;
    CHECK(est_smo_sigmoid_init(&smo, &cfg) == 0, "sigmoid init");
    for (k = 0; k < 4000; ++k) {
        const est_output_t *o = est_smo_sigmoid_step(&smo, p.i, v_prev);
        if (k >= 2000) {
            err_sum += fw_wrap_pi(o->theta_e_rad - p.th);
            ++n;
        }
        v_prev = synth_step(&p);
    }
    *speed_rad_s = smo.out.omega_e_rad_s;
    return err_sum / (float)n;
}

static void test_sigmoid_converges(void)
{
    const float rpms[2] = {500.0f, 2000.0f};
    int r;
    for (r = 0; r < 2; ++r) {
        float we = rpms[r] * RPM_TO_RAD_S * 4.0f, w_eff, w_15;
        float e_eff = run_sigmoid(EST_SMO_SIGMOID_LAG_EFFECTIVE, rpms[r], &w_eff);
        float e_15 = run_sigmoid(EST_SMO_SIGMOID_LAG_EQ15, rpms[r], &w_15);
        /* eq. 15 leaves atan(2w/wc) - atan(w/wc) uncompensated (wc = 2000 rad/s by default) */
        float residual = atanf(2.0f * we / 2000.0f) - atanf(we / 2000.0f);
        printf("sigmoid SMO %.0f rpm: mean angle error %.4f rad (effective lag comp), %.4f rad "
               "(eq. 15, predicted %.4f); speed %.1f rad/s (true %.1f)\n", (double)rpms[r],
               (double)e_eff, (double)e_15, (double)-residual, (double)w_eff, (double)we);
        CHECK(absf(e_eff) < 0.03f, "effective lag comp: mean angle error %f rad", (double)e_eff);
        CHECK(absf(e_15 + residual) < 0.03f, "eq. 15: error %f vs predicted %f", (double)e_15,
              (double)-residual);
        CHECK(absf(w_eff - we) < 0.01f * we, "speed %f vs %f", (double)w_eff, (double)we);
    }
}

static void test_sigmoid_helpers_and_config(void)
{
    est_smo_sigmoid_t smo;
    est_smo_sigmoid_config_t cfg;
    /* eq. 18: 2 psi_f w_e,max, 3000 rpm on Gong's machine: 2 * 0.085 * 4 * 314.159 = 213.628 V */
    float kmin = est_smo_sigmoid_min_gain_v(PSI_WB, 3000.0f * RPM_TO_RAD_S * 4.0f);
    /* deadbeat slope 2F/(G K): F = 0.9685889, G = 0.04921055 A/V, K = 320 V -> 0.1230166 /A */
    float a = est_smo_sigmoid_max_slope_per_a(RS_OHM, LS_H, TS_S, 320.0f);
    CHECK(absf(kmin - 213.628f) < 1e-2f, "min gain %f", (double)kmin);
    CHECK(absf(a - 0.1230166f) < 1e-6f, "max slope %f", (double)a);
    CHECK(est_smo_sigmoid_max_slope_per_a(RS_OHM, 0.0f, TS_S, 320.0f) < 0.0f, "slope: bad Ls");
    CHECK(est_smo_sigmoid_max_slope_per_a(RS_OHM, LS_H, TS_S, 0.0f) < 0.0f, "slope: bad K");
    /* sigmoid(x) = 2/(1 + exp(-a x)) - 1: a x = 2 -> 2/(1 + e^-2) - 1 = 0.7615942 */
    CHECK(absf(est_smo_sigmoid_fn(2.0f, 1.0f) - 0.7615942f) < 1e-6f, "sigmoid(2)");
    CHECK(absf(est_smo_sigmoid_fn(-2.0f, 1.0f) + 0.7615942f) < 1e-6f, "sigmoid odd");
    CHECK(est_smo_sigmoid_fn(1e30f, 1.0f) <= 1.0f && est_smo_sigmoid_fn(-1e30f, 1.0f) >= -1.0f &&
              fw_is_finite(est_smo_sigmoid_fn(-1e30f, 1.0f)),
          "sigmoid saturates without overflow");

    est_smo_sigmoid_default_config(&cfg, RS_OHM, LS_H, PSI_WB, TS_S);
    CHECK(est_smo_sigmoid_init(&smo, &cfg) == -1, "K unset refused");
    cfg.k_v = 320.0f;
    CHECK(est_smo_sigmoid_init(&smo, &cfg) == 0, "valid config");
    CHECK(absf(smo.a_used_per_a - a) < 1e-6f, "derived slope %f", (double)smo.a_used_per_a);
    cfg.lag_comp = 3;
    CHECK(est_smo_sigmoid_init(&smo, &cfg) == -1, "bad lag_comp refused");
    cfg.lag_comp = EST_SMO_SIGMOID_LAG_EQ15;
    cfg.wc_rad_s = 0.0f;
    CHECK(est_smo_sigmoid_init(&smo, &cfg) == -1, "wc = 0 refused");
    cfg.wc_rad_s = 2000.0f;
    cfg.ls_h = 0.0f;
    CHECK(est_smo_sigmoid_init(&smo, &cfg) == -1, "Ls = 0 refused");
    cfg.ls_h = LS_H;
    cfg.k_v = NAN;
    CHECK(est_smo_sigmoid_init(&smo, &cfg) == -1, "NaN refused");
}

/* ---- tanh SMO --------------------------------------------------------------------------- */
static void test_tanh_converges(void)
{
    const float rpms[2] = {500.0f, 2000.0f};
    int r;
    for (r = 0; r < 2; ++r) {
        est_smo_tanh_t smo;
        est_smo_tanh_config_t cfg;
        synth_t p;
        fw_vec2_t v_prev = {0.0f, 0.0f};
        float err_max = 0.0f, we;
        int k;
        synth_init(&p, rpms[r]);
        we = p.we;
        est_smo_tanh_default_config(&cfg, RS_OHM, LS_H, PSI_WB, TS_S);
        cfg.k_v = 1968.25f;
        CHECK(est_smo_tanh_init(&smo, &cfg) == 0, "tanh init");
        for (k = 0; k < 4000; ++k) {
            const est_output_t *o = est_smo_tanh_step(&smo, p.i, v_prev);
            if (k >= 2000) {
                float err = absf(fw_wrap_pi(o->theta_e_rad - p.th));
                err_max = err > err_max ? err : err_max;
            }
            v_prev = synth_step(&p);
        }
        /* no compensation: the EMF of the last period, i.e. w Ts / 2 behind (0.042 at 2000 rpm) */
        printf("tanh SMO %.0f rpm: angle error max %.4f rad (w Ts/2 = %.4f), speed %.1f rad/s "
               "(true %.1f)\n", (double)rpms[r], (double)err_max, (double)(0.5f * we * TS_S),
               (double)smo.out.omega_e_rad_s, (double)we);
        CHECK(err_max < 0.5f * we * TS_S + 0.01f, "tanh angle error %f rad", (double)err_max);
        CHECK(absf(smo.out.omega_e_rad_s - we) < 0.01f * we, "speed %f vs %f",
              (double)smo.out.omega_e_rad_s, (double)we);
    }
}

static void test_tanh_helpers_and_config(void)
{
    est_smo_tanh_t smo;
    est_smo_tanh_config_t cfg;
    float xi, minf, k, bound;
    /* BL = atanh(0.99)/0.01 = 264.665 A (the paper: 265) */
    CHECK(absf(est_smo_tanh_boundary_layer_a(0.01f) - 264.665f) < 0.01f, "BL");
    /* eq. 17 with min|F| = 1: 3 sqrt(3)/2 * 1.67 * 0.085 * 4 * 314 = 463.209 V */
    k = est_smo_tanh_gain_rule_v(1.67f, PSI_WB, 4, 314.0f, 1.0f);
    CHECK(absf(k - 463.209f) < 0.01f, "eq. 17 numerator %f", (double)k);
    CHECK(est_smo_tanh_gain_rule_v(1.67f, PSI_WB, 4, 314.0f, 0.0f) < 0.0f, "min|F| = 0");
    /* deadbeat k m = F/G = 19.6825 V/A */
    CHECK(absf(est_smo_tanh_deadbeat_gain_v_per_a(RS_OHM, LS_H, TS_S) - 19.6825f) < 1e-3f,
          "deadbeat gain");
    /* xi = atanh(463.209 * 0.01 / 19.6825)/0.01 = atanh(0.235341)/0.01 = 23.98 A */
    xi = est_smo_tanh_xi_deadbeat_a(1.67f, PSI_WB, 4, 314.0f, 0.01f, RS_OHM, LS_H, TS_S);
    CHECK(absf(xi - 23.98f) < 0.01f, "xi %f", (double)xi);
    minf = est_smo_tanh_min_f(0.01f, xi); /* eq. 16: tanh(0.2398) = 0.235341 */
    CHECK(absf(minf - 0.235341f) < 1e-5f, "min|F| %f", (double)minf);
    k = est_smo_tanh_gain_rule_v(1.67f, PSI_WB, 4, 314.0f, minf);
    CHECK(absf(k - 1968.25f) < 0.2f, "eq. 17 k %f", (double)k);
    /* eq. 14 with e_max = psi_f p w = 106.76 V: 106.76 / 0.235341 = 453.6 V */
    bound = est_smo_tanh_stability_bound_v(PSI_WB * 4.0f * 314.0f, minf);
    CHECK(absf(bound - 453.6f) < 0.5f, "eq. 14 bound %f", (double)bound);
    printf("tanh gain rule, Gong Table I, m = 0.01: xi %.2f A, min|F| %.4f, k %.1f V, eq. 14 "
           "bound %.1f V\n", (double)xi, (double)minf, (double)k, (double)bound);
    CHECK(est_smo_tanh_xi_deadbeat_a(1.67f, PSI_WB, 4, 314.0f, 1.0f, RS_OHM, LS_H, TS_S) < 0.0f,
          "no xi for m = 1");

    est_smo_tanh_default_config(&cfg, RS_OHM, LS_H, PSI_WB, TS_S);
    CHECK(absf(cfg.m_per_a - 0.01f) < 1e-9f, "paper's m by default");
    CHECK(est_smo_tanh_init(&smo, &cfg) == -1, "k unset refused");
    cfg.k_v = 1968.25f;
    CHECK(est_smo_tanh_init(&smo, &cfg) == 0, "valid config");
    cfg.m_per_a = 0.0f;
    CHECK(est_smo_tanh_init(&smo, &cfg) == -1, "m = 0 refused");
    cfg.m_per_a = 0.01f;
    cfg.ts_s = -1e-4f;
    CHECK(est_smo_tanh_init(&smo, &cfg) == -1, "Ts < 0 refused");
    cfg.ts_s = TS_S;
    cfg.rs_ohm = INFINITY;
    CHECK(est_smo_tanh_init(&smo, &cfg) == -1, "inf refused");
}

/* ---- delay estimate and pre-compensation ----------------------------------------------- */
/* Phase currents linear on each [t_{k-1} + t_d, t_k + t_d), slope changing per period. */
static void test_delay_comp_synthetic(void)
{
    const float t_d = 34.1e-6f;
    est_delay_comp_t dc;
    est_delay_comp_config_t cfg;
    float level[3] = {1.0f, -0.3f, -0.7f};
    float err_td = 0.0f, err_i = 0.0f;
    int k, x;
    est_delay_comp_default_config(&cfg, TS_S);
    CHECK(est_delay_comp_init(&dc, &cfg) == 0, "delay init");
    for (k = 0; k < 200; ++k) {
        /* slope of the vector of period k-1, A/s: a deterministic, sign-changing sequence */
        float sa = 3000.0f * sinf(0.7f * (float)k + 0.2f);
        float sb = 2500.0f * cosf(1.3f * (float)k);
        float slope[3] = {sa, sb, -sa - sb};
        float i1[3], i2[3];
        const est_delay_comp_output_t *o;
        for (x = 0; x < 3; ++x) {
            if (k > 0) {
                level[x] += slope[x] * TS_S;
            }
            i2[x] = level[x];
            i1[x] = level[x] - slope[x] * t_d;
        }
        o = est_delay_comp_step(&dc, i1, i2);
        if (k >= 2) {
            float d = absf(o->i_a_a - i2[0]) + absf(o->i_b_a - i2[1]) + absf(o->i_c_a - i2[2]);
            err_i = d > err_i ? d : err_i;
        }
        if (dc.phases_valid > 0) {
            float d = absf(dc.t_d_last_s - t_d);
            err_td = d > err_td ? d : err_td;
        }
    }
    printf("delay estimate on linear currents: mean %.4f us (true 34.1), worst period %.2e us, "
           "compensated current error %.2e A\n", (double)(dc.t_d_mean_s * 1e6f),
           (double)(err_td * 1e6f), (double)err_i);
    CHECK(absf(dc.t_d_mean_s - t_d) < 0.005e-6f, "mean delay %f us", (double)(dc.t_d_mean_s * 1e6f));
    CHECK(err_td < 0.01e-6f, "per-period delay error %f us", (double)(err_td * 1e6f));
    CHECK(err_i < 1e-5f, "compensated current error %f A", (double)err_i);
    CHECK(dc.n_valid >= 190, "valid periods %ld", dc.n_valid);
}

/* Periods whose eq.-20 denominator is below min_step, or whose value exceeds t_d_max, are skipped. */
static void test_delay_comp_guards(void)
{
    est_delay_comp_t dc;
    est_delay_comp_config_t cfg;
    const float a1[3] = {1.0f, 0.0f, -1.0f}, a2[3] = {1.0f, 0.0f, -1.0f};
    /* moved 5 mA < min_step 10 mA */
    const float b1[3] = {1.002f, 0.0f, -1.002f}, b2[3] = {1.005f, 0.0f, -1.005f};
    /* phase a: 0.04/0.05 Ts = 80 us, phase c: 0.05/0.06 Ts = 83.3 us: both <= 90 us */
    const float c1[3] = {1.015f, 0.0f, -1.015f}, c2[3] = {1.055f, 0.0f, -1.065f};
    /* phase a: 0.099/0.1 Ts = 99 us > t_d_max 90 us */
    const float d1[3] = {1.056f, 0.0f, -1.065f}, d2[3] = {1.155f, 0.0f, -1.065f};
    est_delay_comp_default_config(&cfg, TS_S);
    cfg.min_step_a = 0.01f;
    CHECK(est_delay_comp_init(&dc, &cfg) == 0, "guard config");
    est_delay_comp_step(&dc, a1, a2);
    est_delay_comp_step(&dc, b1, b2);
    CHECK(dc.n_valid == 0 && dc.phases_valid == 0, "flat period skipped: %ld", dc.n_valid);
    est_delay_comp_step(&dc, c1, c2);
    CHECK(dc.n_valid == 1 && dc.phases_valid == 2, "two phases valid: %d", dc.phases_valid);
    CHECK(absf(dc.t_d_last_s - 0.5f * (80e-6f + 83.333333e-6f)) < 1e-9f, "per-period mean %f us",
          (double)(dc.t_d_last_s * 1e6f));
    est_delay_comp_step(&dc, d1, d2);
    CHECK(dc.n_valid == 1 && dc.phases_valid == 0, "implausible period rejected");
}

static void test_delay_comp_config(void)
{
    est_delay_comp_t dc;
    est_delay_comp_config_t cfg;
    const float i1[3] = {1.0f, 0.0f, -1.0f}, i2[3] = {1.1f, 0.0f, -1.1f};
    const est_delay_comp_output_t *o;
    est_delay_comp_default_config(&cfg, TS_S);
    cfg.estimate_on = 0;
    cfg.t_d_fixed_s = 25e-6f;
    CHECK(est_delay_comp_init(&dc, &cfg) == 0, "fixed delay config");
    est_delay_comp_step(&dc, i1, i2);
    /* second period: i1 = 1.2, i2(k-1) = 1.1: delta = 0.1 / 75 us * 25 us = 0.0333 A */
    {
        const float j1[3] = {1.2f, 0.0f, -1.2f}, j2[3] = {1.3f, 0.0f, -1.3f};
        o = est_delay_comp_step(&dc, j1, j2);
    }
    CHECK(absf(o->i_a_a - (1.2f + 0.1f / 75e-6f * 25e-6f)) < 1e-5f, "eq. 21-22: %f", (double)o->i_a_a);
    CHECK(absf(o->t_d_s - 25e-6f) < 1e-12f && dc.n_valid == 0, "fixed delay used, no estimate");
    CHECK(absf(o->i_ab_a.x - o->i_a_a) < 1e-6f, "Clarke alpha = a for a balanced set");

    est_delay_comp_default_config(&cfg, TS_S);
    cfg.t_d_fixed_s = TS_S;
    CHECK(est_delay_comp_init(&dc, &cfg) == -1, "t_d_fixed >= t_d_max refused");
    est_delay_comp_default_config(&cfg, TS_S);
    cfg.t_d_max_s = TS_S;
    CHECK(est_delay_comp_init(&dc, &cfg) == -1, "t_d_max = Ts refused (eq. 21 divides by Ts - t_d)");
    est_delay_comp_default_config(&cfg, TS_S);
    cfg.min_step_a = 0.0f;
    CHECK(est_delay_comp_init(&dc, &cfg) == -1, "min_step = 0 refused");
    est_delay_comp_default_config(&cfg, TS_S);
    cfg.avg_n_max = 0;
    CHECK(est_delay_comp_init(&dc, &cfg) == -1, "avg_n_max = 0 refused");
    est_delay_comp_default_config(&cfg, 0.0f);
    CHECK(est_delay_comp_init(&dc, &cfg) == -1, "Ts = 0 refused");
    est_delay_comp_default_config(&cfg, TS_S);
    cfg.t_d_fixed_s = NAN;
    CHECK(est_delay_comp_init(&dc, &cfg) == -1, "NaN refused");
}

int main(void)
{
    test_sigmoid_converges();
    test_sigmoid_helpers_and_config();
    test_tanh_converges();
    test_tanh_helpers_and_config();
    test_delay_comp_synthetic();
    test_delay_comp_guards();
    test_delay_comp_config();
    return check_summary("test_fw_smo");
}
