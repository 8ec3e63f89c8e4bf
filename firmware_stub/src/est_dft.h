/**
 * @file est_dft.h
 * @brief Types and helpers shared by the sliding DFTs (est_sdft, est_gsdft) and their users:
 * a float32 complex type, the per-bin state, the twiddle table and a few complex operations.
 */
#ifndef EST_DFT_H
#define EST_DFT_H

#ifndef EST_DFT_MAX_M
#define EST_DFT_MAX_M 96 /**< largest window [samples]; override with -DEST_DFT_MAX_M=... */
#endif
#ifndef EST_DFT_MAX_BINS
#define EST_DFT_MAX_BINS 4 /**< bins per instance (they share the delay line and the table) */
#endif

/** Complex number (float32). */
typedef struct {
    float re;
    float im;
} est_cplx_t;

/** Implementation of the recursion (same transfer function, different float32 behaviour). */
typedef enum {
    EST_DFT_FORM_MODULATED = 0, /**< modulated SDFT, pole exactly at z = 1 (default) */
    EST_DFT_FORM_DIRECT = 1     /**< the papers' recursion with a float32 twiddle: drifts */
} est_dft_form_t;

/** Per-bin state (shared by the SDFT and the GSDFT). */
typedef struct {
    int k;            /**< bin normalised to [0, m) */
    int idx;          /**< (k * n) mod m: table index of e^{-j w_k n} for the next sample */
    est_cplx_t s;     /**< MODULATED: demodulated window sum; DIRECT: resonator state */
    est_cplx_t f;     /**< MODULATED + resync: demodulated sum of the current block */
    est_cplx_t f_prev;/**< GSDFT resync: sum of the previous block */
    est_cplx_t w;     /**< DIRECT: e^{+j w_k} rounded to float32 */
    est_cplx_t gain;  /**< output normalisation (complex for the GSDFT) */
    est_cplx_t c_k;   /**< GSDFT: e^{j w_k M/6} (= e^{+-j pi/3}) */
} est_dft_bin_t;

/** tw[i] = e^{-j 2 pi i / m}, i = 0..m-1. */
void est_dft_twiddles(est_cplx_t *tw, int m);
/** Bin k in (-m, m) normalised to [0, m); -1 if out of range. */
int est_dft_norm_bin(int k, int m);
/** a * b */
est_cplx_t est_cmul(est_cplx_t a, est_cplx_t b);
/** conj(a) * b */
est_cplx_t est_cmul_conj(est_cplx_t a, est_cplx_t b);
/** |z|^2 */
float est_cabs2(est_cplx_t z);
/** |z| */
float est_cabs(est_cplx_t z);
/** arg z in [-pi, pi] */
float est_carg(est_cplx_t z);

#endif
