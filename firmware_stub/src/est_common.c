#include "est_common.h"

#include "fw_math.h"

void est_pll_init(est_pll_t *pll, float kp, float ki)
{
    pll->kp = kp;
    pll->ki = ki;
    est_pll_reset(pll, 0.0f, 0.0f);
}

void est_pll_reset(est_pll_t *pll, float theta_rad, float omega_rad_s)
{
    pll->theta_rad = fw_wrap_2pi(theta_rad);
    pll->omega_rad_s = omega_rad_s;
}

float est_pll_step(est_pll_t *pll, float theta_in_rad, float ts_s)
{
    float err = fw_wrap_pi(theta_in_rad - pll->theta_rad);
    pll->omega_rad_s += pll->ki * ts_s * err;
    pll->theta_rad = fw_wrap_2pi(pll->theta_rad + (pll->omega_rad_s + pll->kp * err) * ts_s);
    return pll->omega_rad_s;
}

void est_pll_gains(float wn_rad_s, float *kp, float *ki)
{
    *kp = 2.0f * wn_rad_s;
    *ki = wn_rad_s * wn_rad_s;
}
