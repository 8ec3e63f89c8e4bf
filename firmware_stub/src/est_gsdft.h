/**
 * @file est_gsdft.h
 * @brief Generalized sliding DFT (Yuan et al. 2020, eq. 26-27): the SDFT's M-sample comb replaced
 * by one that only nulls the 6h +- 1 bins, so the window is M/3 samples instead of M.
 *
 *   H_c(z) = (1 - z^{-M/6} e^{j pi/3}) (1 - z^{-M/6} e^{-j pi/3}) = 1 - z^{-L} + z^{-2L},  L = M/6  (26)
 *   G_S^k(z) = H_c(z) / (1 - z^-1 e^{j w_k}) * (1/M) e^{j w_k},  w_k = 2 pi k / M                  (27)
 *
 * Rules the equations impose (refused by est_gsdft_init otherwise):
 *  - M must be a multiple of 6 (the comb delay is M/6 samples);
 *  - k must be in the 6h +- 1 family (k mod 6 = 1 or 5): only there does a comb zero cancel the
 *    resonator pole, which is what makes G_S an FIR filter of 2L = M/3 taps. Elsewhere the pole
 *    on the unit circle is uncancelled and the filter is unstable.
 *
 * Normalisation. With the paper's 1/M the gain at the bin is L (1 + c_k) e^{j w_k} / M with
 * c_k = e^{j w_k L} = e^{+-j pi/3}, i.e. |G| = sqrt(3)/6 = 0.2887 (not unity). The phasor returned is
 * the paper's output times M e^{-j w_k} / (L (1 + c_k)) (times 2 for a real input), so a unit
 * harmonic at bin k reads amplitude 1, phase referred to the newest sample, as est_sdft does:
 * in steady state the two give the same phasor (Yuan claim Y7). In window terms:
 *   P_k(n) = c * sum_{i<L} x(n-i) e^{j w_k i} + c_k * sum_{L<=i<2L} x(n-i) e^{j w_k i},  c = 1/(L(1+c_k))
 *
 * What the comb passes. It nulls only 6h +- 1 (relative to M samples per fundamental period): DC,
 * the triplen (3, 9, ..) and the even harmonics (2, 4, ..) reach the output attenuated but not
 * nulled (DC: 0.12 of the bin gain for k = 5, M = 24). They must be absent from the input or
 * removed first. Here: (a) on the complex alpha-beta current of a three-phase machine (complex
 * input) the triplens are zero-sequence and vanish, the dead-time harmonics are all 6h + 1, and the
 * even ones are absent for half-wave-symmetric currents; (b) DC (current-sensor offsets survive the
 * Clarke transform) is removed by dc_block = 1: a first difference 1 - z^-1 ahead of the comb (one
 * more tap, window M/3 + 1), normalised at the bin by 1 / (1 - e^{-j w_k}).
 *
 * Implementation: the same modulated form with an exact restart as est_sdft (see there), with the
 * restart on blocks of L samples: at a block boundary the window sum is the newest block sum plus
 * c_k times the previous one, both computed fresh.
 */
#ifndef EST_GSDFT_H
#define EST_GSDFT_H

#include "est_sdft.h"

typedef struct {
    int m;                   /**< samples per fundamental period, a multiple of 6, 6..EST_DFT_MAX_M */
    int n_bins;              /**< 1..EST_DFT_MAX_BINS */
    int k[EST_DFT_MAX_BINS]; /**< bins in the 6h +- 1 family, -m < k < m */
    int real_input;          /**< 1: imaginary input ignored, unit cosine reads 1 */
    int dc_block;            /**< 1: first difference ahead of the comb (nulls DC) */
    int form;                /**< est_dft_form_t */
    int resync;              /**< MODULATED only: exact restart every M/6 samples */
} est_gsdft_config_t;

typedef struct {
    est_gsdft_config_t cfg;
    int l;                            /**< M/6 */
    est_cplx_t tw[EST_DFT_MAX_M];     /**< tw[i] = e^{-j 2 pi i / m} */
    est_cplx_t v[EST_DFT_MAX_M / 3];  /**< delay line of the comb input (2L), v[pos] the oldest */
    est_cplx_t x_prev;                /**< dc_block: previous raw input */
    int pos;
    int blk;
    int filled;                       /**< samples since reset, saturates at the window length */
    est_dft_bin_t bin[EST_DFT_MAX_BINS];
    est_cplx_t out[EST_DFT_MAX_BINS]; /**< normalised phasors of the newest sample */
} est_gsdft_t;

/** m samples per period, one bin k, real input, no DC block, modulated with resync. */
void est_gsdft_default_config(est_gsdft_config_t *cfg, int m, int k);
/** 0 on success; -1 if m is not a multiple of 6 in range, a bin is not 6h +- 1, or counts are bad. */
int est_gsdft_init(est_gsdft_t *s, const est_gsdft_config_t *cfg);
void est_gsdft_reset(est_gsdft_t *s);
/** One sample; returns the n_bins normalised phasors of the newest sample. */
const est_cplx_t *est_gsdft_step(est_gsdft_t *s, float x_re, float x_im);
/** Window length [samples]: M/3, or M/3 + 1 with dc_block. */
int est_gsdft_window(const est_gsdft_t *s);
/** Non-zero once a full window has been received since reset. */
int est_gsdft_valid(const est_gsdft_t *s);
float est_gsdft_amplitude(const est_gsdft_t *s, int b);
float est_gsdft_phase_rad(const est_gsdft_t *s, int b);

#endif
