#include "est_dft.h"

#include <math.h>

#include "fw_math.h"

/* ---- complex helpers --------------------------------------------------------------------- */
est_cplx_t est_cmul(est_cplx_t a, est_cplx_t b)
{
    est_cplx_t r;
    r.re = a.re * b.re - a.im * b.im;
    r.im = a.re * b.im + a.im * b.re;
    return r;
}

est_cplx_t est_cmul_conj(est_cplx_t a, est_cplx_t b)
{
    est_cplx_t r;
    r.re = a.re * b.re + a.im * b.im;
    r.im = a.re * b.im - a.im * b.re;
    return r;
}

float est_cabs2(est_cplx_t z)
{
    return z.re * z.re + z.im * z.im;
}

float est_cabs(est_cplx_t z)
{
    return sqrtf(est_cabs2(z));
}

float est_carg(est_cplx_t z)
{
    return atan2f(z.im, z.re);
}

void est_dft_twiddles(est_cplx_t *tw, int m)
{
    int i;
    for (i = 0; i < m; ++i) {
        float a = FW_TWO_PI_F * (float)i / (float)m;
        tw[i].re = cosf(a);
        tw[i].im = -sinf(a);
    }
}

int est_dft_norm_bin(int k, int m)
{
    if (k <= -m || k >= m) {
        return -1;
    }
    return k < 0 ? k + m : k;
}

