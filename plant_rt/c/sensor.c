/**
 * @file sensor.c
 * @brief xoshiro256** + polar Gaussian, ADC quantisation. See sensor.h.
 */
#include "sensor.h"

#include <math.h>

static uint64_t rotl64(uint64_t x, int k)
{
    return (x << k) | (x >> (64 - k));
}

static uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

void sensor_rng_seed(sensor_rng_t *rng, uint64_t seed)
{
    uint64_t x = seed;
    int k;
    for (k = 0; k < 4; ++k) {
        rng->s[k] = splitmix64(&x);
    }
    rng->cached_normal = 0.0;
    rng->has_cached = 0;
}

uint64_t sensor_rng_next_u64(sensor_rng_t *rng)
{
    uint64_t *s = rng->s;
    const uint64_t result = rotl64(s[1] * 5U, 7) * 9U;
    const uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl64(s[3], 45);
    return result;
}

double sensor_rng_uniform(sensor_rng_t *rng)
{
    return (double)(sensor_rng_next_u64(rng) >> 11) * 0x1.0p-53;
}

double sensor_rng_normal(sensor_rng_t *rng)
{
    double u, v, r2, f;
    if (rng->has_cached) {
        rng->has_cached = 0;
        return rng->cached_normal;
    }
    do {
        u = 2.0 * sensor_rng_uniform(rng) - 1.0;
        v = 2.0 * sensor_rng_uniform(rng) - 1.0;
        r2 = u * u + v * v;
    } while (!(r2 < 1.0) || !(r2 > 0.0));
    f = sqrt(-2.0 * log(r2) / r2);
    rng->cached_normal = v * f;
    rng->has_cached = 1;
    return u * f;
}

double sensor_adc_convert(const sensor_adc_config_t *cfg, sensor_rng_t *rng, double x_true,
                          int *code_out)
{
    return sensor_adc_convert_noise(cfg, x_true, sensor_rng_normal(rng), code_out);
}

double sensor_adc_convert_noise(const sensor_adc_config_t *cfg, double x_true, double n,
                                int *code_out)
{
    const double x = (1.0 + cfg->gain_err) * x_true + cfg->offset + cfg->noise_rms * n;
    const double levels = ldexp(1.0, cfg->bits);          /* 2^bits */
    const double mid = cfg->bipolar ? 0.5 * levels : 0.0;  /* code of zero */
    const double lsb = cfg->bipolar ? cfg->full_scale / mid : cfg->full_scale / levels;
    double c = floor(x / lsb + 0.5) + mid;
    int code;
    if (!(c >= 0.0)) { /* also NaN */
        c = 0.0;
    } else if (c > levels - 1.0) {
        c = levels - 1.0;
    }
    code = (int)c;
    if (code_out != 0) {
        *code_out = code;
    }
    return (c - mid) * lsb;
}
