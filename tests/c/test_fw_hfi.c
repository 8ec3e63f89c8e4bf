/**
 * @file test_fw_hfi.c
 * @brief C tests of est_hfi on a synthetic standstill IPMSM (linear, flux as state, RK4, hou2021
 * values): the injection is eq. 8 in the estimated frame, the initial-position procedure converges
 * 2 dtheta -> 0 from 8 angles (error modulo pi < 1 deg), the polarity stays undecided on a linear
 * machine, the fundamental current output has the HF removed, bad configurations are refused.
 */
#include <math.h>
#include <stdio.h>

#include "est_hfi.h"

#include "check.h"

#define PI_D 3.141592653589793
#define R_OHM 0.78
#define LD_H 2.5e-3
#define LQ_H 8.5e-3
#define TS_S 1e-4

/* Linear IPMSM at standstill: d psi_dq / dt = v_dq - R i_dq, i = (psi - psi_f e_d) / L. */
typedef struct {
    double theta, psi_d, psi_q; /* psi relative to psi_f on d */
} motor_t;

static void motor_current(const motor_t *m, double *ia, double *ib)
{
    double id = m->psi_d / LD_H, iq = m->psi_q / LQ_H;
    *ia = id * cos(m->theta) - iq * sin(m->theta);
    *ib = id * sin(m->theta) + iq * cos(m->theta);
}

static void motor_step(motor_t *m, double va, double vb)
{
    const int sub = 8;
    const double h = TS_S / sub;
    double vd = va * cos(m->theta) + vb * sin(m->theta);
    double vq = -va * sin(m->theta) + vb * cos(m->theta);
    int k;
    for (k = 0; k < sub; ++k) { /* linear: RK4 = exact to h^5 */
        double d1 = vd - R_OHM * m->psi_d / LD_H, q1 = vq - R_OHM * m->psi_q / LQ_H;
        double d2 = vd - R_OHM * (m->psi_d + 0.5 * h * d1) / LD_H;
        double q2 = vq - R_OHM * (m->psi_q + 0.5 * h * q1) / LQ_H;
        double d3 = vd - R_OHM * (m->psi_d + 0.5 * h * d2) / LD_H;
        double q3 = vq - R_OHM * (m->psi_q + 0.5 * h * q2) / LQ_H;
        double d4 = vd - R_OHM * (m->psi_d + h * d3) / LD_H;
        double q4 = vq - R_OHM * (m->psi_q + h * q3) / LQ_H;
        m->psi_d += h / 6.0 * (d1 + 2.0 * d2 + 2.0 * d3 + d4);
        m->psi_q += h / 6.0 * (q1 + 2.0 * q2 + 2.0 * q3 + q4);
    }
}

static double wrap_half_pi(double x)
{
    double y = fmod(x + 0.5 * PI_D, PI_D);
    return (y < 0.0 ? y + PI_D : y) - 0.5 * PI_D;
}

static void make(est_hfi_t *s, int ipd)
{
    est_hfi_config_t c;
    est_hfi_default_config(&c, (float)R_OHM, (float)LD_H, (float)LQ_H, (float)TS_S);
    c.ipd_on_reset = ipd;
    CHECK(est_hfi_init(s, &c) == 0, "init");
}

static void test_initial_position(void)
{
    int a;
    for (a = 0; a < 8; ++a) {
        est_hfi_t s;
        motor_t m = {0.0, 0.0, 0.0};
        const est_hfi_output_t *o = NULL;
        double hf_raw = 0.0, hf_fund = 0.0;
        int k;
        m.theta = (double)a * PI_D / 4.0 + 0.1;
        make(&s, 1);
        for (k = 0; k < 3000; ++k) {
            double ia, ib;
            fw_vec2_t i, v = {0.0f, 0.0f};
            motor_current(&m, &ia, &ib);
            i.x = (float)ia;
            i.y = (float)ib;
            o = est_hfi_step(&s, i, v);
            if (k >= 2000) { /* HF left in the fundamental output vs in the measurement */
                double ph = 2.0 * PI_D * (double)(k % 8) / 8.0;
                hf_raw += (ia * cos(ph) + ib * sin(ph)) / 1000.0;
                hf_fund += ((double)o->i_fund_ab_a.x * cos(ph) + (double)o->i_fund_ab_a.y * sin(ph)) / 1000.0;
            }
            motor_step(&m, (double)o->v_inj_ab_v.x, (double)o->v_inj_ab_v.y);
        }
        {
            double err = wrap_half_pi((double)o->est.theta_e_rad - m.theta);
            CHECK(fabs(err) < PI_D / 180.0, "angle %d: error mod pi %.3f deg", a, err * 180.0 / PI_D);
            CHECK(o->ipd_state == EST_HFI_IPD_FAILED && o->polarity == EST_HFI_POL_UNKNOWN,
                  "angle %d: linear machine must leave the polarity undecided (state %d, r %g)", a,
                  o->ipd_state, (double)o->pol_metric);
            CHECK(fabs(hf_fund) < 0.01 * fabs(hf_raw) && fabs(hf_raw) > 0.02,
                  "angle %d: HF in fundamental output %g vs raw %g", a, hf_fund, hf_raw);
        }
    }
}

static void test_injection(void)
{
    est_hfi_t s;
    int k;
    make(&s, 0);
    est_hfi_set_angle(&s, 0.7f, 0.0f);
    for (k = 0; k < 16; ++k) {
        fw_vec2_t i = {0.0f, 0.0f}, v = {0.0f, 0.0f};
        const est_hfi_output_t *o = est_hfi_step(&s, i, v);
        fw_vec2_t dq = fw_park(o->v_inj_ab_v, sinf(0.7f), cosf(0.7f));
        double phi = 2.0 * PI_D * (double)(k % 8) / 8.0;
        CHECK(fabs((double)dq.x - 6.0 * sin(phi)) < 1e-5 && fabs((double)dq.y - 6.0 * cos(phi)) < 1e-5,
              "eq. 8 at k = %d: (%f, %f)", k, (double)dq.x, (double)dq.y);
    }
}

static void test_refusals(void)
{
    est_hfi_t s;
    est_hfi_config_t c;
    est_hfi_default_config(&c, (float)R_OHM, (float)LD_H, (float)LQ_H, (float)TS_S);
    c.f_inj_hz = 1300.0f;
    CHECK(est_hfi_init(&s, &c) == -1, "non-integer samples per HF period accepted");
    c.f_inj_hz = 10000.0f / 7.0f;
    CHECK(est_hfi_init(&s, &c) == -1, "odd samples per HF period accepted");
    c.f_inj_hz = 1250.0f;
    c.lq_h = c.ld_h;
    CHECK(est_hfi_init(&s, &c) == -1, "no saliency accepted");
}

int main(void)
{
    test_injection();
    test_initial_position();
    test_refusals();
    return check_summary("test_fw_hfi");
}
