#include "est_sdft.h"

/* ---- SDFT --------------------------------------------------------------------------------- */
void est_sdft_default_config(est_sdft_config_t *cfg, int m, int k)
{
    int b;
    cfg->m = m;
    cfg->n_bins = 1;
    for (b = 0; b < EST_DFT_MAX_BINS; ++b) {
        cfg->k[b] = 0;
    }
    cfg->k[0] = k;
    cfg->real_input = 1;
    cfg->form = EST_DFT_FORM_MODULATED;
    cfg->resync = 1;
}

/* Output scale c/M: 2/M for a real input unless the bin is its own mirror (k = 0, k = M/2). */
static float sdft_scale(const est_sdft_config_t *cfg, int k_norm)
{
    int self_mirror = (k_norm == 0) || (2 * k_norm == cfg->m);
    float c = (cfg->real_input && !self_mirror) ? 2.0f : 1.0f;
    return c / (float)cfg->m;
}

int est_sdft_init(est_sdft_t *s, const est_sdft_config_t *cfg)
{
    int b;
    if (cfg->m < 2 || cfg->m > EST_DFT_MAX_M || cfg->n_bins < 1 || cfg->n_bins > EST_DFT_MAX_BINS ||
        (cfg->form != EST_DFT_FORM_MODULATED && cfg->form != EST_DFT_FORM_DIRECT)) {
        return -1;
    }
    for (b = 0; b < cfg->n_bins; ++b) {
        if (est_dft_norm_bin(cfg->k[b], cfg->m) < 0) {
            return -1;
        }
    }
    s->cfg = *cfg;
    est_dft_twiddles(s->tw, cfg->m);
    for (b = 0; b < cfg->n_bins; ++b) {
        est_dft_bin_t *bn = &s->bin[b];
        bn->k = est_dft_norm_bin(cfg->k[b], cfg->m);
        bn->w.re = s->tw[bn->k].re; /* e^{+j w_k} = conj(tw[k]) */
        bn->w.im = -s->tw[bn->k].im;
        bn->gain.re = sdft_scale(cfg, bn->k);
        bn->gain.im = 0.0f;
        bn->c_k.re = 1.0f;
        bn->c_k.im = 0.0f;
    }
    est_sdft_reset(s);
    return 0;
}

void est_sdft_reset(est_sdft_t *s)
{
    int i, b;
    const est_cplx_t zero = {0.0f, 0.0f};
    for (i = 0; i < s->cfg.m; ++i) {
        s->x[i] = zero;
    }
    s->pos = 0;
    s->blk = 0;
    s->filled = 0;
    for (b = 0; b < s->cfg.n_bins; ++b) {
        s->bin[b].idx = 0;
        s->bin[b].s = zero;
        s->bin[b].f = zero;
        s->bin[b].f_prev = zero;
        s->out[b] = zero;
    }
}

/* Modulated SDFT, one bin: S += (x_new - x_old) W^{-kn}; F += x_new W^{-kn}; P = gain W^{+kn} S. */
static void sdft_bin_modulated(est_dft_bin_t *bn, const est_cplx_t *tw, int m, est_cplx_t d,
                               est_cplx_t x_new, int resync, est_cplx_t *out)
{
    est_cplx_t w = tw[bn->idx];
    est_cplx_t dw = est_cmul(d, w);
    bn->s.re += dw.re;
    bn->s.im += dw.im;
    if (resync) {
        est_cplx_t xw = est_cmul(x_new, w);
        bn->f.re += xw.re;
        bn->f.im += xw.im;
    }
    *out = est_cmul_conj(w, bn->s);          /* re-modulate: e^{+j w_k n} S */
    out->re *= bn->gain.re;
    out->im *= bn->gain.re;
    bn->idx += bn->k;
    if (bn->idx >= m) {
        bn->idx -= m;
    }
}

/* The papers' recursion (twiddle before the add, so no output rotation): r = w r + (x_new - x_old). */
static void sdft_bin_direct(est_dft_bin_t *bn, est_cplx_t d, est_cplx_t *out)
{
    est_cplx_t r = est_cmul(bn->w, bn->s);
    bn->s.re = r.re + d.re;
    bn->s.im = r.im + d.im;
    out->re = bn->gain.re * bn->s.re;
    out->im = bn->gain.re * bn->s.im;
}

const est_cplx_t *est_sdft_step(est_sdft_t *s, float x_re, float x_im)
{
    const est_sdft_config_t *c = &s->cfg;
    est_cplx_t x_new, d;
    int b;
    x_new.re = x_re;
    x_new.im = c->real_input ? 0.0f : x_im;
    d.re = x_new.re - s->x[s->pos].re; /* comb 1 - z^-M (eq. 25) */
    d.im = x_new.im - s->x[s->pos].im;
    s->x[s->pos] = x_new;
    if (++s->pos >= c->m) {
        s->pos = 0;
    }
    for (b = 0; b < c->n_bins; ++b) {
        if (c->form == EST_DFT_FORM_DIRECT) {
            sdft_bin_direct(&s->bin[b], d, &s->out[b]);
        } else {
            sdft_bin_modulated(&s->bin[b], s->tw, c->m, d, x_new, c->resync, &s->out[b]);
        }
    }
    if (c->form == EST_DFT_FORM_MODULATED && c->resync && ++s->blk >= c->m) {
        /* the block accumulator now covers exactly the window: restart from it */
        const est_cplx_t zero = {0.0f, 0.0f};
        for (b = 0; b < c->n_bins; ++b) {
            s->bin[b].s = s->bin[b].f;
            s->bin[b].f = zero;
        }
        s->blk = 0;
    }
    if (s->filled < c->m) {
        ++s->filled;
    }
    return s->out;
}

int est_sdft_valid(const est_sdft_t *s)
{
    return s->filled >= s->cfg.m;
}

float est_sdft_amplitude(const est_sdft_t *s, int b)
{
    return est_cabs(s->out[b]);
}

float est_sdft_phase_rad(const est_sdft_t *s, int b)
{
    return est_carg(s->out[b]);
}

static void cneg(est_cplx_t *z)
{
    z->re = -z->re;
    z->im = -z->im;
}

void est_sdft_negate(est_sdft_t *s)
{
    int i, b;
    for (i = 0; i < s->cfg.m; ++i) {
        cneg(&s->x[i]);
    }
    for (b = 0; b < s->cfg.n_bins; ++b) {
        cneg(&s->bin[b].s);
        cneg(&s->bin[b].f);
        cneg(&s->bin[b].f_prev);
        cneg(&s->out[b]);
    }
}
