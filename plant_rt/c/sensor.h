/**
 * @file sensor.h
 * @brief Current/bus-voltage ADC model and its portable, seeded random-number generator.
 *
 * Random numbers. xoshiro256** 1.0 (Blackman & Vigna, public domain reference algorithm),
 * seeded through splitmix64 from one 64-bit seed, so a seed gives the same stream on every
 * platform (integer arithmetic only). Uniform doubles: the top 53 bits of a draw times 2^-53,
 * in [0, 1). Gaussian: Marsaglia's polar method (rejection; both deviates of an accepted pair
 * are used, the second is cached). The uniform and integer streams are bit-exact across
 * platforms; the Gaussian deviates go through log() and sqrt(), so across C libraries they can
 * differ in the last bits (identical on the same platform).
 *
 * ADC (one converter per phase current, one for the bus voltage):
 *     analog  x_meas = (1 + gain_err) * x_true + offset + noise_rms * N(0, 1)
 *     current (bipolar, full scale +-FS):  LSB = FS / 2^(bits-1),
 *             code = clamp(floor(x_meas / LSB + 0.5) + 2^(bits-1), 0, 2^bits - 1),
 *             value = (code - 2^(bits-1)) * LSB          (range [-FS, FS - LSB])
 *     voltage (unipolar, 0 .. FS):         LSB = FS / 2^bits,
 *             code = clamp(floor(x_meas / LSB + 0.5), 0, 2^bits - 1), value = code * LSB
 * The value is what a controller computes from the code with the nominal scaling (it does not
 * know the gain and offset errors). Double precision, no heap, no clock.
 */
#ifndef SENSOR_H
#define SENSOR_H

#include <stdint.h>

/** xoshiro256** state + the cached second Gaussian deviate of the polar method. */
typedef struct sensor_rng {
    uint64_t s[4];
    double cached_normal;
    int has_cached;
} sensor_rng_t;

/** Seed through splitmix64 (any seed, including 0, gives a valid non-zero state). */
void sensor_rng_seed(sensor_rng_t *rng, uint64_t seed);
/** Next 64-bit output of xoshiro256**. */
uint64_t sensor_rng_next_u64(sensor_rng_t *rng);
/** Uniform double in [0, 1) (53 random bits). */
double sensor_rng_uniform(sensor_rng_t *rng);
/** Standard normal deviate (polar method). */
double sensor_rng_normal(sensor_rng_t *rng);

/** One ADC channel. */
typedef struct sensor_adc_config {
    int bits;            /**< resolution, 1..24 */
    int bipolar;         /**< 1: range [-FS, FS) (currents), 0: [0, FS) (bus voltage) */
    double full_scale;   /**< FS [A or V], > 0 */
    double gain_err;     /**< relative gain error (0.01 = reads 1 % high), > -1 */
    double offset;       /**< offset [A or V] */
    double noise_rms;    /**< Gaussian noise before quantisation [A or V rms], >= 0 */
} sensor_adc_config_t;

/**
 * Convert a true value: draws exactly one Gaussian deviate from rng (also when noise_rms = 0,
 * so the stream does not depend on the noise setting). Returns the measured value [A or V];
 * *code_out (if not NULL) receives the raw code.
 */
double sensor_adc_convert(const sensor_adc_config_t *cfg, sensor_rng_t *rng, double x_true,
                          int *code_out);
/** The same conversion with a given standard-normal deviate n (sensor_adc_convert draws it). */
double sensor_adc_convert_noise(const sensor_adc_config_t *cfg, double x_true, double n,
                                int *code_out);

#endif
