#include "est_gsdft.h"

#include "fw_math.h"

void est_gsdft_default_config(est_gsdft_config_t *cfg, int m, int k)
{
    int b;
    cfg->m = m;
    cfg->n_bins = 1;
    for (b = 0; b < EST_DFT_MAX_BINS; ++b) {
        cfg->k[b] = 1;
    }
    cfg->k[0] = k;
    cfg->real_input = 1;
    cfg->dc_block = 0;
    cfg->form = EST_DFT_FORM_MODULATED;
    cfg->resync = 1;
}

/* 1 / (L (1 + c_k)) [/ (1 - e^{-j w_k}) with the DC block] [* 2 for a real input]. */
static est_cplx_t gsdft_gain(const est_gsdft_config_t *cfg, int l, const est_dft_bin_t *bn,
                             est_cplx_t e_minus_jwk)
{
    est_cplx_t den, g;
    float mag2;
    den.re = (float)l * (1.0f + bn->c_k.re);
    den.im = (float)l * bn->c_k.im;
    if (cfg->dc_block) {
        est_cplx_t db;
        db.re = 1.0f - e_minus_jwk.re;
        db.im = -e_minus_jwk.im;
        den = est_cmul(den, db);
    }
    mag2 = est_cabs2(den);
    g.re = den.re / mag2;
    g.im = -den.im / mag2;
    if (cfg->real_input) {
        g.re *= 2.0f;
        g.im *= 2.0f;
    }
    return g;
}

int est_gsdft_init(est_gsdft_t *s, const est_gsdft_config_t *cfg)
{
    int b;
    if (cfg->m < 6 || cfg->m > EST_DFT_MAX_M || cfg->m % 6 != 0 || cfg->n_bins < 1 ||
        cfg->n_bins > EST_DFT_MAX_BINS ||
        (cfg->form != EST_DFT_FORM_MODULATED && cfg->form != EST_DFT_FORM_DIRECT)) {
        return -1;
    }
    for (b = 0; b < cfg->n_bins; ++b) {
        int kn = est_dft_norm_bin(cfg->k[b], cfg->m);
        if (kn < 0 || (kn % 6 != 1 && kn % 6 != 5)) {
            return -1; /* m is a multiple of 6, so k mod 6 is the family of the normalised bin too */
        }
    }
    s->cfg = *cfg;
    s->l = cfg->m / 6;
    est_dft_twiddles(s->tw, cfg->m);
    for (b = 0; b < cfg->n_bins; ++b) {
        est_dft_bin_t *bn = &s->bin[b];
        bn->k = est_dft_norm_bin(cfg->k[b], cfg->m);
        bn->w.re = s->tw[bn->k].re;
        bn->w.im = -s->tw[bn->k].im;
        /* c_k = e^{j w_k L} = e^{j pi k / 3}: e^{+j pi/3} for k = 6h+1, e^{-j pi/3} for 6h-1 */
        bn->c_k.re = 0.5f;
        bn->c_k.im = (bn->k % 6 == 1 ? 0.5f : -0.5f) * FW_SQRT3_F;
        bn->gain = gsdft_gain(cfg, s->l, bn, s->tw[bn->k]);
    }
    est_gsdft_reset(s);
    return 0;
}

void est_gsdft_reset(est_gsdft_t *s)
{
    int i, b;
    const est_cplx_t zero = {0.0f, 0.0f};
    for (i = 0; i < 2 * s->l; ++i) {
        s->v[i] = zero;
    }
    s->x_prev = zero;
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

int est_gsdft_window(const est_gsdft_t *s)
{
    return 2 * s->l + (s->cfg.dc_block ? 1 : 0);
}

/* Modulated form: T += c(n) W^{-kn} with the real comb c = v - v_L + v_2L; P = gain W^{+kn} T. */
static void gsdft_bin_modulated(est_dft_bin_t *bn, const est_cplx_t *tw, int m, est_cplx_t comb,
                                est_cplx_t v_new, int resync, est_cplx_t *out)
{
    est_cplx_t w = tw[bn->idx];
    est_cplx_t cw = est_cmul(comb, w);
    bn->s.re += cw.re;
    bn->s.im += cw.im;
    if (resync) {
        est_cplx_t vw = est_cmul(v_new, w);
        bn->f.re += vw.re;
        bn->f.im += vw.im;
    }
    *out = est_cmul(bn->gain, est_cmul_conj(w, bn->s));
    bn->idx += bn->k;
    if (bn->idx >= m) {
        bn->idx -= m;
    }
}

/* The paper's structure: comb, then the resonator r = e^{j w_k} r + c(n); P = gain r. */
static void gsdft_bin_direct(est_dft_bin_t *bn, est_cplx_t comb, est_cplx_t *out)
{
    est_cplx_t r = est_cmul(bn->w, bn->s);
    bn->s.re = r.re + comb.re;
    bn->s.im = r.im + comb.im;
    *out = est_cmul(bn->gain, bn->s);
}

/* Block of L samples complete: window sum = newest block + c_k * previous block, both fresh. */
static void gsdft_restart(est_gsdft_t *s)
{
    const est_cplx_t zero = {0.0f, 0.0f};
    int b;
    for (b = 0; b < s->cfg.n_bins; ++b) {
        est_dft_bin_t *bn = &s->bin[b];
        est_cplx_t older = est_cmul(bn->c_k, bn->f_prev);
        bn->s.re = bn->f.re + older.re;
        bn->s.im = bn->f.im + older.im;
        bn->f_prev = bn->f;
        bn->f = zero;
    }
    s->blk = 0;
}

const est_cplx_t *est_gsdft_step(est_gsdft_t *s, float x_re, float x_im)
{
    const est_gsdft_config_t *c = &s->cfg;
    int two_l = 2 * s->l;
    int pos_l = s->pos + s->l;
    est_cplx_t x_new, v_new, comb;
    int b;
    x_new.re = x_re;
    x_new.im = c->real_input ? 0.0f : x_im;
    v_new = x_new;
    if (c->dc_block) {
        v_new.re -= s->x_prev.re;
        v_new.im -= s->x_prev.im;
        s->x_prev = x_new;
    }
    if (pos_l >= two_l) {
        pos_l -= two_l;
    }
    /* comb 1 - z^-L + z^-2L (eq. 26 multiplied out); v[pos] is v(n-2L), v[pos_l] is v(n-L) */
    comb.re = v_new.re - s->v[pos_l].re + s->v[s->pos].re;
    comb.im = v_new.im - s->v[pos_l].im + s->v[s->pos].im;
    s->v[s->pos] = v_new;
    if (++s->pos >= two_l) {
        s->pos = 0;
    }
    for (b = 0; b < c->n_bins; ++b) {
        if (c->form == EST_DFT_FORM_DIRECT) {
            gsdft_bin_direct(&s->bin[b], comb, &s->out[b]);
        } else {
            gsdft_bin_modulated(&s->bin[b], s->tw, c->m, comb, v_new, c->resync, &s->out[b]);
        }
    }
    if (c->form == EST_DFT_FORM_MODULATED && c->resync && ++s->blk >= s->l) {
        gsdft_restart(s);
    }
    if (s->filled < est_gsdft_window(s)) {
        ++s->filled;
    }
    return s->out;
}

int est_gsdft_valid(const est_gsdft_t *s)
{
    return s->filled >= est_gsdft_window(s);
}

float est_gsdft_amplitude(const est_gsdft_t *s, int b)
{
    return est_cabs(s->out[b]);
}

float est_gsdft_phase_rad(const est_gsdft_t *s, int b)
{
    return est_carg(s->out[b]);
}
