/**
 * @file est_callgrind.c
 * @brief Driver for bench/perf/estimators.py: `est_callgrind CASE N` initialises one estimator,
 * warms it up, precomputes N inputs, then calls its step N times inside bench_run(), the only
 * function callgrind collects (--toggle-collect=bench_run). Instructions per call = Ir / N.
 * Built with the firmware's flags by the Python script (the optional estimators of other modules
 * are compiled in when the script finds them: -DHAVE_EST_SMO_SIGMOID etc.).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "est_gsdft.h"
#include "est_hfi.h"
#include "est_sdft.h"
#include "est_smo_sign.h"
#include "harm_comp.h"
#ifdef HAVE_EST_SMO_SIGMOID
#include "est_smo_sigmoid.h"
#endif
#ifdef HAVE_EST_SMO_TANH
#include "est_smo_tanh.h"
#endif
#ifdef HAVE_EST_DELAY_COMP
#include "est_delay_comp.h"
#endif

#define MAX_N 100000L
#define TS 1e-4f

static fw_vec2_t g_i[MAX_N];
static fw_vec2_t g_v[MAX_N];
static float g_th[MAX_N];
static float g_abc1[MAX_N][3];
static float g_abc2[MAX_N][3];
static volatile float g_sink;

/* one union of all estimator states, so every case has the same static storage */
static union {
    est_smo_sign_t smo_sign;
    est_sdft_t sdft;
    est_gsdft_t gsdft;
    harm_comp_t harm;
    est_hfi_t hfi;
#ifdef HAVE_EST_SMO_SIGMOID
    est_smo_sigmoid_t smo_sigmoid;
#endif
#ifdef HAVE_EST_SMO_TANH
    est_smo_tanh_t smo_tanh;
#endif
#ifdef HAVE_EST_DELAY_COMP
    est_delay_comp_t delay_comp;
#endif
} g_s;

typedef void (*step_fn)(long k);

/* ---- inputs: a 500 rpm-like rotating current and voltage (gong2020 scale) -------------------- */
static void make_inputs(long n, float w_e_rad_s)
{
    long k;
    for (k = 0; k < n; ++k) {
        float th = fmodf(0.3f + w_e_rad_s * TS * (float)k, 6.2831853f);
        g_th[k] = th;
        g_i[k].x = 2.0f * cosf(th + 1.6f) + 0.05f * cosf(-5.0f * th) + 0.001f * (float)(k % 7);
        g_i[k].y = 2.0f * sinf(th + 1.6f) + 0.05f * sinf(-5.0f * th);
        g_v[k].x = -15.0f * sinf(th);
        g_v[k].y = 15.0f * cosf(th);
        g_abc1[k][0] = g_i[k].x;
        g_abc1[k][1] = -0.5f * g_i[k].x + 0.866f * g_i[k].y;
        g_abc1[k][2] = -g_abc1[k][0] - g_abc1[k][1];
        g_abc2[k][0] = 1.001f * g_abc1[k][0];
        g_abc2[k][1] = 1.001f * g_abc1[k][1];
        g_abc2[k][2] = 1.001f * g_abc1[k][2];
    }
}

/* ---- steps ------------------------------------------------------------------------------------ */
static void st_empty(long k) { g_sink = g_i[k].x; }
static void st_smo_sign(long k) { g_sink = est_smo_sign_step(&g_s.smo_sign, g_i[k], g_v[k])->theta_e_rad; }
static void st_sdft(long k) { g_sink = est_sdft_step(&g_s.sdft, g_i[k].x, g_i[k].y)[0].re; }
static void st_gsdft(long k) { g_sink = est_gsdft_step(&g_s.gsdft, g_i[k].x, g_i[k].y)[0].re; }
static void st_harm(long k)
{
    const harm_comp_output_t *o = harm_comp_step(&g_s.harm, g_i[k], g_th[k], 209.44f);
    fw_vec2_t u = harm_comp_voltage_dq(&g_s.harm, g_th[k]);
    g_sink = o->u5_dq5_v.x + u.x;
}
static void st_hfi(long k) { g_sink = est_hfi_step(&g_s.hfi, g_i[k], g_v[k])->est.theta_e_rad; }
#ifdef HAVE_EST_SMO_SIGMOID
static void st_smo_sigmoid(long k) { g_sink = est_smo_sigmoid_step(&g_s.smo_sigmoid, g_i[k], g_v[k])->theta_e_rad; }
#endif
#ifdef HAVE_EST_SMO_TANH
static void st_smo_tanh(long k) { g_sink = est_smo_tanh_step(&g_s.smo_tanh, g_i[k], g_v[k])->theta_e_rad; }
#endif
#ifdef HAVE_EST_DELAY_COMP
static void st_delay_comp(long k) { g_sink = est_delay_comp_step(&g_s.delay_comp, g_abc1[k], g_abc2[k])->i_a_a; }
#endif

/* ---- set-ups ----------------------------------------------------------------------------------- */
static int dft_config(const char *name, int gsdft, int bins, int real_input, int form, int dc_block)
{
    if (gsdft) {
        est_gsdft_config_t c;
        est_gsdft_default_config(&c, 24, bins == 1 ? 5 : -5);
        c.n_bins = bins;
        c.k[1] = 7;
        c.real_input = real_input;
        c.form = form;
        c.dc_block = dc_block;
        if (real_input && bins == 2) {
            c.k[0] = 5;
        }
        return est_gsdft_init(&g_s.gsdft, &c);
    } else {
        est_sdft_config_t c;
        est_sdft_default_config(&c, 24, bins == 1 ? 5 : -5);
        c.n_bins = bins;
        c.k[1] = 7;
        c.real_input = real_input;
        c.form = form;
        if (real_input && bins == 2) {
            c.k[0] = 5;
        }
        (void)name;
        return est_sdft_init(&g_s.sdft, &c);
    }
}

static step_fn setup(const char *c, float *w_e)
{
    *w_e = 209.44f; /* 500 rpm, p = 4 */
    if (!strcmp(c, "empty")) {
        return st_empty;
    }
    if (!strcmp(c, "smo_sign")) {
        est_smo_sign_config_t k;
        est_smo_sign_default_config(&k, 0.6383f, 2e-3f, 0.085f, TS);
        k.k_v = 25.0f;
        return est_smo_sign_init(&g_s.smo_sign, &k) == 0 ? st_smo_sign : NULL;
    }
#ifdef HAVE_EST_SMO_SIGMOID
    if (!strcmp(c, "smo_sigmoid")) {
        est_smo_sigmoid_config_t k;
        est_smo_sigmoid_default_config(&k, 0.6383f, 2e-3f, 0.085f, TS);
        k.k_v = 25.0f;
        return est_smo_sigmoid_init(&g_s.smo_sigmoid, &k) == 0 ? st_smo_sigmoid : NULL;
    }
#endif
#ifdef HAVE_EST_SMO_TANH
    if (!strcmp(c, "smo_tanh")) {
        est_smo_tanh_config_t k;
        est_smo_tanh_default_config(&k, 0.6383f, 2e-3f, 0.085f, TS);
        k.k_v = 25.0f;
        return est_smo_tanh_init(&g_s.smo_tanh, &k) == 0 ? st_smo_tanh : NULL;
    }
#endif
#ifdef HAVE_EST_DELAY_COMP
    if (!strcmp(c, "delay_comp")) {
        est_delay_comp_config_t k;
        est_delay_comp_default_config(&k, TS);
        return est_delay_comp_init(&g_s.delay_comp, &k) == 0 ? st_delay_comp : NULL;
    }
#endif
    if (!strcmp(c, "hfi_tracking") || !strcmp(c, "hfi_ipd")) {
        est_hfi_config_t k;
        est_hfi_default_config(&k, 0.78f, 2.5e-3f, 8.5e-3f, TS);
        k.ipd_on_reset = !strcmp(c, "hfi_ipd");
        k.ipd_timeout_s = 100.0f; /* stay in IPD_CONVERGE for the whole run */
        k.lock_tol_rad = 0.0f;
        *w_e = 0.0f;
        return est_hfi_init(&g_s.hfi, &k) == 0 ? st_hfi : NULL;
    }
    if (!strcmp(c, "harm_comp_gsdft_50rpm") || !strcmp(c, "harm_comp_sdft_50rpm")) {
        harm_comp_config_t k;
        harm_comp_default_config(&k, 0.6383f, 2e-3f, TS);
        k.extractor = strstr(c, "_sdft") ? HARM_EXTRACT_SDFT : HARM_EXTRACT_GSDFT;
        *w_e = 20.944f; /* 50 rpm, p = 4: one grid sample per ~30 control periods */
        return harm_comp_init(&g_s.harm, &k) == 0 ? st_harm : NULL;
    }
    {
        /* DFT cases: <sdft|gsdft>_<1bin|57>_<real|cplx>_<mod|direct>[_dc] */
        int gsdft = !strncmp(c, "gsdft_", 6);
        int bins = strstr(c, "_57_") ? 2 : 1;
        int real_input = strstr(c, "_real_") != NULL;
        int form = strstr(c, "_direct") ? EST_DFT_FORM_DIRECT : EST_DFT_FORM_MODULATED;
        int dc = strstr(c, "_dc") != NULL;
        if ((gsdft || !strncmp(c, "sdft_", 5)) && dft_config(c, gsdft, bins, real_input, form, dc) == 0) {
            return gsdft ? st_gsdft : st_sdft;
        }
    }
    return NULL;
}

/* The measured region: nothing else runs inside. */
void bench_run(step_fn f, long first, long n);
void bench_run(step_fn f, long first, long n)
{
    long k;
    for (k = first; k < first + n; ++k) {
        f(k);
    }
}

int main(int argc, char **argv)
{
    long n, warm = 2000, k;
    float w_e;
    step_fn f;
    if (argc < 3) {
        fprintf(stderr, "usage: %s CASE N\n", argv[0]);
        return 2;
    }
    n = atol(argv[2]);
    if (n < 1 || n + warm > MAX_N) {
        fprintf(stderr, "N must be 1..%ld\n", MAX_N - warm);
        return 2;
    }
    f = setup(argv[1], &w_e);
    if (f == NULL) {
        fprintf(stderr, "unknown or unbuilt case %s\n", argv[1]);
        return 2;
    }
    make_inputs(n + warm, w_e);
    for (k = 0; k < warm; ++k) {
        f(k);
    }
    {
        /* called through a volatile pointer so it is never inlined into main */
        void (*volatile run)(step_fn, long, long) = bench_run;
        run(f, warm, n); /* the inputs continue where the warm-up stopped */
    }
    printf("%s %ld %g\n", argv[1], n, (double)g_sink);
    return 0;
}
