/**
 * @file test_fw_dft.c
 * @brief C tests of est_sdft, est_gsdft and harm_comp: float32 drift over 10^7 samples (modulated
 * form with and without the exact restart, and the papers' direct recursion), normalisation,
 * refusals, SDFT = GSDFT in steady state, and a synthetic 5th/7th extraction.
 *
 * Drift test: M = 24, bin 5, real input x = cos(w_5 n + 0.3) + 0.5 sin(0.0123 n) + 0.2 u(n)
 * (u: uniform noise, so the window never repeats exactly), 10^7 samples. Reference: the window
 * sum in double from the same float inputs, at 1000 checkpoints. Asserted bound for the protected
 * (modulated + resync) SDFT and GSDFT: |P - P_ref| < 2e-6 (about 30 float32 ulps of a unit
 * phasor) at every checkpoint; the unprotected forms are printed beside it.
 */
#include <math.h>
#include <stdio.h>

#include "est_gsdft.h"
#include "est_sdft.h"
#include "harm_comp.h"

#include "check.h"

#define TWO_PI 6.283185307179586
#define DRIFT_N 10000000L
#define DRIFT_CHECKS 1000L
#define DRIFT_M 24
#define DRIFT_K 5
#define DRIFT_BOUND 2e-6

/* ---- deterministic input ------------------------------------------------------------------ */
static unsigned long g_lcg = 12345UL;

static double uniform_pm1(void)
{
    g_lcg = (g_lcg * 1103515245UL + 12345UL) & 0x7fffffffUL;
    return (double)g_lcg / 1073741823.5 - 1.0;
}

static float drift_input(long n)
{
    double ph = TWO_PI * (double)((n * DRIFT_K) % DRIFT_M) / DRIFT_M;
    double slow = fmod(0.0123 * (double)n, TWO_PI);
    return (float)(cos(ph + 0.3) + 0.5 * sin(slow) + 0.2 * uniform_pm1());
}

/* ---- double-precision references from a ring of the last inputs ----------------------------- */
typedef struct {
    float x[DRIFT_M];
    int pos;
} ring_t;

static void ring_push(ring_t *r, float x)
{
    r->x[r->pos] = x;
    r->pos = (r->pos + 1) % DRIFT_M;
}

/* x(n - i), i = 0 newest */
static double ring_get(const ring_t *r, int i)
{
    return (double)r->x[(r->pos - 1 - i + 2 * DRIFT_M) % DRIFT_M];
}

/* window-sum weights: SDFT (2/M) e^{j w i}, i < M; GSDFT 2 e^{j w i} w_i / (L (1 + c_k)), i < 2L */
static void reference_phasor(const ring_t *r, int gsdft, double *re, double *im)
{
    const double w = TWO_PI * DRIFT_K / DRIFT_M;
    const int l = DRIFT_M / 6;
    const int taps = gsdft ? 2 * l : DRIFT_M;
    double ck_re = 0.5, ck_im = (DRIFT_K % 6 == 1 ? 0.5 : -0.5) * sqrt(3.0);
    double sr = 0.0, si = 0.0, g_re, g_im, den_re, den_im, d2;
    int i;
    for (i = 0; i < taps; ++i) {
        double c = cos(w * i), s = sin(w * i), x = ring_get(r, i);
        if (gsdft && i >= l) { /* older half weighted by c_k */
            double tr = c * ck_re - s * ck_im, ti = c * ck_im + s * ck_re;
            c = tr;
            s = ti;
        }
        sr += x * c;
        si += x * s;
    }
    if (!gsdft) {
        *re = 2.0 / DRIFT_M * sr;
        *im = 2.0 / DRIFT_M * si;
        return;
    }
    den_re = l * (1.0 + ck_re);
    den_im = l * ck_im;
    d2 = den_re * den_re + den_im * den_im;
    g_re = 2.0 * den_re / d2;
    g_im = -2.0 * den_im / d2;
    *re = g_re * sr - g_im * si;
    *im = g_re * si + g_im * sr;
}

/* ---- drift ---------------------------------------------------------------------------------- */
typedef struct {
    const char *name;
    int gsdft;
    int form;
    int resync;
    est_sdft_t sdft;
    est_gsdft_t gs;
    double worst;
    double last;
} variant_t;

static void variant_init(variant_t *v)
{
    int rc;
    if (v->gsdft) {
        est_gsdft_config_t c;
        est_gsdft_default_config(&c, DRIFT_M, DRIFT_K);
        c.form = v->form;
        c.resync = v->resync;
        rc = est_gsdft_init(&v->gs, &c);
    } else {
        est_sdft_config_t c;
        est_sdft_default_config(&c, DRIFT_M, DRIFT_K);
        c.form = v->form;
        c.resync = v->resync;
        rc = est_sdft_init(&v->sdft, &c);
    }
    CHECK(rc == 0, "init %s", v->name);
    v->worst = 0.0;
    v->last = 0.0;
}

static est_cplx_t variant_step(variant_t *v, float x)
{
    return v->gsdft ? est_gsdft_step(&v->gs, x, 0.0f)[0] : est_sdft_step(&v->sdft, x, 0.0f)[0];
}

static void test_drift(void)
{
    static const struct {
        const char *name;
        int gsdft, form, resync;
    } spec[6] = {
        {"SDFT modulated + resync (protected)", 0, EST_DFT_FORM_MODULATED, 1},
        {"SDFT modulated, no resync", 0, EST_DFT_FORM_MODULATED, 0},
        {"SDFT direct (paper eq. 22)", 0, EST_DFT_FORM_DIRECT, 0},
        {"GSDFT modulated + resync (protected)", 1, EST_DFT_FORM_MODULATED, 1},
        {"GSDFT modulated, no resync", 1, EST_DFT_FORM_MODULATED, 0},
        {"GSDFT direct (paper eq. 27)", 1, EST_DFT_FORM_DIRECT, 0},
    };
    static variant_t v[6];
    const int nv = 6;
    ring_t ring;
    long n;
    int i;
    for (i = 0; i < DRIFT_M; ++i) {
        ring.x[i] = 0.0f;
    }
    ring.pos = 0;
    for (i = 0; i < nv; ++i) {
        v[i].name = spec[i].name;
        v[i].gsdft = spec[i].gsdft;
        v[i].form = spec[i].form;
        v[i].resync = spec[i].resync;
    }
    for (i = 0; i < nv; ++i) {
        variant_init(&v[i]);
    }
    for (n = 0; n < DRIFT_N; ++n) {
        float x = drift_input(n);
        int check = (n + 1) % (DRIFT_N / DRIFT_CHECKS) == 0;
        ring_push(&ring, x);
        for (i = 0; i < nv; ++i) {
            est_cplx_t p = variant_step(&v[i], x);
            if (check) {
                double re, im, e;
                reference_phasor(&ring, v[i].gsdft, &re, &im);
                e = hypot((double)p.re - re, (double)p.im - im);
                v[i].last = e;
                if (!(e <= v[i].worst)) { /* NaN counts as worst */
                    v[i].worst = e;
                }
            }
        }
    }
    printf("drift over %ld float32 samples (M = %d, bin %d), |P - P_exact| worst / at the end:\n",
           DRIFT_N, DRIFT_M, DRIFT_K);
    for (i = 0; i < nv; ++i) {
        printf("  %-38s %.3e / %.3e\n", v[i].name, v[i].worst, v[i].last);
    }
    CHECK(v[0].worst < DRIFT_BOUND, "protected SDFT drift %.3e >= %.1e", v[0].worst, DRIFT_BOUND);
    CHECK(v[3].worst < DRIFT_BOUND, "protected GSDFT drift %.3e >= %.1e", v[3].worst, DRIFT_BOUND);
    /* the unprotected paper recursion really does drift over the same run */
    CHECK(v[2].last > 100.0 * DRIFT_BOUND, "direct SDFT did not drift: %.3e", v[2].last);
}

/* ---- normalisation, refusals, Y7 ---------------------------------------------------------- */
static void test_normalisation_and_refusals(void)
{
    est_sdft_t s;
    est_gsdft_t g;
    est_sdft_config_t sc;
    est_gsdft_config_t gc;
    int n;
    est_sdft_default_config(&sc, 24, 7);
    CHECK(est_sdft_init(&s, &sc) == 0, "sdft init");
    est_gsdft_default_config(&gc, 24, 7);
    CHECK(est_gsdft_init(&g, &gc) == 0, "gsdft init");
    for (n = 0; n < 100; ++n) {
        double ph = TWO_PI * (double)((7 * n) % 24) / 24.0 + 1.0;
        float x = (float)(2.5 * cos(ph) + 0.7 * cos(TWO_PI * (double)(n % 24) / 24.0));
        est_sdft_step(&s, x, 0.0f);
        est_gsdft_step(&g, x, 0.0f);
    }
    CHECK(fabsf(est_sdft_amplitude(&s, 0) - 2.5f) < 1e-5f, "SDFT amplitude %f",
          (double)est_sdft_amplitude(&s, 0));
    CHECK(fabsf(est_gsdft_amplitude(&g, 0) - 2.5f) < 1e-5f, "GSDFT amplitude %f",
          (double)est_gsdft_amplitude(&g, 0));
    CHECK(fabsf(est_sdft_phase_rad(&s, 0) - est_gsdft_phase_rad(&g, 0)) < 1e-5f, "Y7 phase");
    /* phase at the newest sample n = 99: 7 * 99 mod 24 = 21 -> 2 pi 21/24 + 1 - 2 pi */
    CHECK(fabsf(est_sdft_phase_rad(&s, 0) - (float)(TWO_PI * 21.0 / 24.0 + 1.0 - TWO_PI)) < 1e-5f,
          "phase %f", (double)est_sdft_phase_rad(&s, 0));

    gc.m = 20;
    CHECK(est_gsdft_init(&g, &gc) == -1, "GSDFT M not a multiple of 6 accepted");
    gc.m = 24;
    gc.k[0] = 3;
    CHECK(est_gsdft_init(&g, &gc) == -1, "GSDFT triplen bin accepted");
    gc.k[0] = 6;
    CHECK(est_gsdft_init(&g, &gc) == -1, "GSDFT bin 6 accepted");
    gc.k[0] = -5;
    CHECK(est_gsdft_init(&g, &gc) == 0, "GSDFT bin -5 refused");
    sc.m = EST_DFT_MAX_M + 1;
    CHECK(est_sdft_init(&s, &sc) == -1, "SDFT M too large accepted");
    sc.m = 24;
    sc.k[0] = 24;
    CHECK(est_sdft_init(&s, &sc) == -1, "SDFT k = M accepted");
    sc.k[0] = 1;
    sc.n_bins = 0;
    CHECK(est_sdft_init(&s, &sc) == -1, "SDFT no bins accepted");
}

/* ---- harm_comp on a synthetic current ------------------------------------------------------ */
static void test_harm_comp(void)
{
    harm_comp_t h;
    harm_comp_config_t c;
    const double w = 50.0 * TWO_PI / 60.0 * 4.0; /* 50 rpm, p = 4 */
    const long n = (long)(1.5 * TWO_PI / w / 1e-4);
    const harm_comp_output_t *o = NULL;
    long k;
    int e;
    for (e = 0; e < 2; ++e) {
        harm_comp_default_config(&c, 0.6383f, 2e-3f, 1e-4f);
        c.extractor = e == 0 ? HARM_EXTRACT_GSDFT : HARM_EXTRACT_SDFT;
        CHECK(harm_comp_init(&h, &c) == 0, "harm_comp init");
        for (k = 0; k < n; ++k) {
            double th = 0.2 + w * 1e-4 * (double)k;
            fw_vec2_t i;
            i.x = (float)(5.0 * cos(th + 1.9) + 0.2 * cos(-5.0 * th - 1.0) + 0.21 * cos(7.0 * th + 2.0) + 0.1);
            i.y = (float)(5.0 * sin(th + 1.9) + 0.2 * sin(-5.0 * th - 1.0) + 0.21 * sin(7.0 * th + 2.0) - 0.05);
            o = harm_comp_step(&h, i, (float)fmod(th, TWO_PI), (float)w);
        }
        CHECK(o->valid, "harm_comp valid");
        CHECK(fabsf(o->i5_a - 0.2f) < 2e-4f && fabsf(o->theta5_rad + 1.0f) < 1e-3f,
              "extractor %d: I5 %f theta5 %f", e, (double)o->i5_a, (double)o->theta5_rad);
        CHECK(fabsf(o->i7_a - 0.21f) < 2e-4f && fabsf(o->theta7_rad - 2.0f) < 1e-3f,
              "extractor %d: I7 %f theta7 %f", e, (double)o->i7_a, (double)o->theta7_rad);
    }
    c.m = 100;
    CHECK(harm_comp_init(&h, &c) == -1, "harm_comp M = 100 accepted");
}

int main(void)
{
    test_normalisation_and_refusals();
    test_harm_comp();
    test_drift();
    return check_summary("test_fw_dft");
}
