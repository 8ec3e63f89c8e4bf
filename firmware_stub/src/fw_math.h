/**
 * @file fw_math.h
 * @brief Reference-frame transforms and small numeric helpers (float32, portable C99).
 *
 * Conventions (docs/architecture.md): amplitude-invariant Clarke, alpha axis on phase a,
 * Park with the electrical angle of the d axis (PM north). Angles in rad, [0, 2pi) after wrap.
 */
#ifndef FW_MATH_H
#define FW_MATH_H

#define FW_PI_F 3.14159265358979f
#define FW_TWO_PI_F 6.28318530717959f
#define FW_HALF_PI_F 1.57079632679490f
#define FW_SQRT3_F 1.73205080756888f
#define FW_INV_SQRT3_F 0.577350269189626f

/** Two-axis quantity (alpha-beta or d-q). */
typedef struct {
    float x;
    float y;
} fw_vec2_t;

/** Clarke transform of three phase quantities (uses all three; robust to a common offset). */
fw_vec2_t fw_clarke(float a, float b, float c);
/** Inverse Clarke: alpha-beta to phases a, b, c. */
void fw_clarke_inv(fw_vec2_t ab, float *a, float *b, float *c);
/** Park transform alpha-beta -> d-q with sin/cos of the d-axis angle given. */
fw_vec2_t fw_park(fw_vec2_t ab, float sin_th, float cos_th);
/** Inverse Park d-q -> alpha-beta. */
fw_vec2_t fw_park_inv(fw_vec2_t dq, float sin_th, float cos_th);
/** Wrap an angle to [0, 2pi). */
float fw_wrap_2pi(float angle_rad);
/** Wrap an angle difference to [-pi, pi). */
float fw_wrap_pi(float angle_rad);
/** -1, 0 or +1 by the sign of x (the sliding-mode switching function). */
float fw_signf(float x);
/** Clamp x to [lo, hi]. */
float fw_clampf(float x, float lo, float hi);
/** Non-zero if x is a finite float (not NaN, not +-inf). */
int fw_is_finite(float x);

#endif
