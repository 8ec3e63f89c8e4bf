/**
 * @file est_sdft.h
 * @brief Sliding DFT: the phasor of chosen bins k of the last M samples, updated per sample.
 *
 * Yuan et al. 2020, eq. (19)-(25); Hou et al. 2021, eq. (16)-(20):
 *
 *   I_m(k) = [I_{m-1}(k) - i(m-1) + i(m+M-1)] e^{j 2 pi k / M}                       (Yuan 22, Hou 20)
 *   G^k(z) = (1 - z^-M) / (1 - z^-1 e^{j 2 pi k/M}) * (1/M) e^{j 2 pi k/M}               (Yuan 24)
 *
 * Output (normalisation). The phasor of bin k referred to the NEWEST sample n:
 *
 *   P_k(n) = (c / M) * sum_{i=0}^{M-1} x(n-i) e^{+j w_k i},   w_k = 2 pi k / M
 *
 * so that x(n) = A cos(w_k n + phi) (real input, c = 2) or x(n) = A e^{j(w_k n + phi)} (complex input,
 * c = 1) reads P_k(n) = A e^{j(w_k n + phi)}: amplitude A, phase = the harmonic's phase at sample n.
 * (For real input and k = 0 or k = M/2, c = 1: a DC level A reads A.) Against the paper's G^k(z):
 * P_k = c e^{-j w_k} y_paper; the paper's e^{j w_k} refers its output to one sample ahead.
 *
 * Drift protection (float32). The paper's recursion has its pole ON the unit circle and rounds the
 * twiddle e^{j w_k} to float32: |w| != 1 by ~6e-8 and w^M != 1, so errors accumulate without bound
 * (EST_DFT_FORM_DIRECT; kept for the benchmark and the drift test, not for a drive). The default
 * EST_DFT_FORM_MODULATED is the modulated SDFT (Duda 2010): the input is demodulated by an exact
 * M-periodic table W^{-kn} = e^{-j w_k n} and summed, so the pole is exactly z = 1 (a plain running
 * sum), and the output is re-modulated. The running sum's own rounding (a random walk) is removed
 * by an exact restart: a second accumulator sums the demodulated samples of the current block of M
 * samples; when the block is complete it IS the window sum, computed fresh, and replaces the running
 * sum (resync = 1). Error bound: a few M float32 roundings of the window sum, independent of the run
 * length. Cost over the direct form: one extra complex multiply-add per bin per sample (the block
 * accumulator) and the output re-modulation; no burst (the restart is a copy).
 *
 * Memory: the caller owns est_sdft_t (EST_DFT_MAX_M complex delay line + twiddle table).
 */
#ifndef EST_SDFT_H
#define EST_SDFT_H

#include "est_dft.h"

typedef struct {
    int m;                    /**< window length [samples], 2..EST_DFT_MAX_M */
    int n_bins;               /**< 1..EST_DFT_MAX_BINS */
    int k[EST_DFT_MAX_BINS];  /**< bins, -m < k < m (negative: negative frequency, complex input) */
    int real_input;           /**< 1: imaginary input ignored, phasors scaled so a unit cosine reads 1 */
    int form;                 /**< est_dft_form_t */
    int resync;               /**< MODULATED only: 1 = exact block restart every m samples */
} est_sdft_config_t;

typedef struct {
    est_sdft_config_t cfg;
    est_cplx_t tw[EST_DFT_MAX_M]; /**< tw[i] = e^{-j 2 pi i / m} */
    est_cplx_t x[EST_DFT_MAX_M];  /**< delay line, x[pos] is the oldest sample */
    int pos;
    int blk;                      /**< samples in the current resync block */
    int filled;                   /**< samples received since reset, saturates at m */
    est_dft_bin_t bin[EST_DFT_MAX_BINS];
    est_cplx_t out[EST_DFT_MAX_BINS]; /**< phasors P_k(n) of the newest sample, normalised */
} est_sdft_t;

/* ---- SDFT --------------------------------------------------------------------------------- */
/** Window m, one bin k, real input, modulated form with resync. */
void est_sdft_default_config(est_sdft_config_t *cfg, int m, int k);
/** 0 on success, -1 if the configuration is not usable (m, n_bins, k out of range, bad form). */
int est_sdft_init(est_sdft_t *s, const est_sdft_config_t *cfg);
/** Empty window (zeros), sample index 0. */
void est_sdft_reset(est_sdft_t *s);
/** One sample; returns the n_bins phasors P_k(n) of the newest sample (x_im ignored if real). */
const est_cplx_t *est_sdft_step(est_sdft_t *s, float x_re, float x_im);
/** Non-zero once m samples have been received since reset (the window holds no start-up zeros). */
int est_sdft_valid(const est_sdft_t *s);
/** Amplitude |P| of bin number b (0..n_bins-1) [input units]. */
float est_sdft_amplitude(const est_sdft_t *s, int b);
/** Phase arg P of bin number b at the newest sample [rad], [-pi, pi]. */
float est_sdft_phase_rad(const est_sdft_t *s, int b);
/** Negate the window and the outputs, as if every sample so far had been negated (O(m)). */
void est_sdft_negate(est_sdft_t *s);

#endif
