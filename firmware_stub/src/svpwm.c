#include "svpwm.h"

#include <math.h>

fw_vec2_t svpwm_duties(fw_vec2_t v_ab_v, float v_dc_v, float duty_abc[3])
{
    float va, vb, vc, vmax, vmin, offset;
    float v_lim = v_dc_v * FW_INV_SQRT3_F;
    float mag = sqrtf(v_ab_v.x * v_ab_v.x + v_ab_v.y * v_ab_v.y);
    fw_vec2_t v = v_ab_v;
    float inv_vdc;

    if (v_dc_v <= 0.0f) {
        duty_abc[0] = duty_abc[1] = duty_abc[2] = 0.5f;
        v.x = 0.0f;
        v.y = 0.0f;
        return v;
    }
    if (mag > v_lim) {
        float k = v_lim / mag;
        v.x *= k;
        v.y *= k;
    }
    fw_clarke_inv(v, &va, &vb, &vc);
    vmax = va > vb ? (va > vc ? va : vc) : (vb > vc ? vb : vc);
    vmin = va < vb ? (va < vc ? va : vc) : (vb < vc ? vb : vc);
    offset = -0.5f * (vmax + vmin);
    inv_vdc = 1.0f / v_dc_v;
    duty_abc[0] = fw_clampf(0.5f + (va + offset) * inv_vdc, 0.0f, 1.0f);
    duty_abc[1] = fw_clampf(0.5f + (vb + offset) * inv_vdc, 0.0f, 1.0f);
    duty_abc[2] = fw_clampf(0.5f + (vc + offset) * inv_vdc, 0.0f, 1.0f);
    return v;
}
