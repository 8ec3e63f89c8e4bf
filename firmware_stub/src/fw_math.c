#include "fw_math.h"

#include <math.h>

fw_vec2_t fw_clarke(float a, float b, float c)
{
    fw_vec2_t ab;
    ab.x = (2.0f * a - b - c) * (1.0f / 3.0f);
    ab.y = (b - c) * FW_INV_SQRT3_F;
    return ab;
}

void fw_clarke_inv(fw_vec2_t ab, float *a, float *b, float *c)
{
    *a = ab.x;
    *b = -0.5f * ab.x + 0.5f * FW_SQRT3_F * ab.y;
    *c = -0.5f * ab.x - 0.5f * FW_SQRT3_F * ab.y;
}

fw_vec2_t fw_park(fw_vec2_t ab, float sin_th, float cos_th)
{
    fw_vec2_t dq;
    dq.x = ab.x * cos_th + ab.y * sin_th;
    dq.y = -ab.x * sin_th + ab.y * cos_th;
    return dq;
}

fw_vec2_t fw_park_inv(fw_vec2_t dq, float sin_th, float cos_th)
{
    fw_vec2_t ab;
    ab.x = dq.x * cos_th - dq.y * sin_th;
    ab.y = dq.x * sin_th + dq.y * cos_th;
    return ab;
}

float fw_wrap_2pi(float angle_rad)
{
    float a = fmodf(angle_rad, FW_TWO_PI_F);
    if (a < 0.0f) {
        a += FW_TWO_PI_F;
    }
    if (a >= FW_TWO_PI_F) { /* fmodf of a tiny negative number can round up to 2pi */
        a = 0.0f;
    }
    return a;
}

float fw_wrap_pi(float angle_rad)
{
    float a = fw_wrap_2pi(angle_rad + FW_PI_F) - FW_PI_F;
    return a;
}

float fw_signf(float x)
{
    if (x > 0.0f) {
        return 1.0f;
    }
    if (x < 0.0f) {
        return -1.0f;
    }
    return 0.0f;
}

float fw_clampf(float x, float lo, float hi)
{
    if (x < lo) {
        return lo;
    }
    if (x > hi) {
        return hi;
    }
    return x;
}

int fw_is_finite(float x)
{
    /* x - x is 0 for finite x, NaN for inf and NaN; NaN compares unequal to itself. */
    float d = x - x;
    return (d >= 0.0f) && (d <= 0.0f);
}
