#include "est_common.h"

#include <math.h>

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

void est_emf_dir_reset(est_emf_dir_t *d)
{
    d->dir = 1;
    d->disagree_n = 0;
}

float est_emf_angle_step(est_pll_t *pll, est_emf_dir_t *d, float theta_emf_rad,
                         float dir_speed_rad_s, float ts_s)
{
    float w = pll->omega_rad_s;
    float err = fw_wrap_pi(theta_emf_rad - pll->theta_rad);
    int flipped = fabsf(err) > FW_HALF_PI_F;
    float f;
    if (flipped) {
        err = fw_wrap_pi(err + FW_PI_F);   /* modulo pi */
    }
    d->dir = flipped ? -1 : 1;             /* the EMF's polarity relative to the PLL angle */
    f = w + pll->kp * err;                 /* the PLL's instantaneous frequency: no ramp lag */
    if (fabsf(w) >= dir_speed_rad_s && fabsf(f) >= dir_speed_rad_s && (w < 0.0f) == (f < 0.0f)
        && fabsf(w) > 0.0f) {
        /* the speed's sign is clear: evidence for or against the PLL angle's polarity. When the
         * evidence against has outweighed the evidence for by EST_EMF_RESYNC_S worth of steps,
         * the PLL angle is pi off (locked the wrong way at a start-up or a slip at low speed):
         * re-align it. Never on a single noisy sample. */
        if ((w < 0.0f) != flipped) {
            d->disagree_n += 1;
            if ((float)d->disagree_n * ts_s >= EST_EMF_RESYNC_S) {
                pll->theta_rad = fw_wrap_2pi(pll->theta_rad + FW_PI_F);
                d->dir = -d->dir;
                d->disagree_n = 0;
            }
        } else if (d->disagree_n > 0) {
            d->disagree_n -= 1;
        }
    }
    pll->omega_rad_s += pll->ki * ts_s * err;
    pll->theta_rad = fw_wrap_2pi(pll->theta_rad + (pll->omega_rad_s + pll->kp * err) * ts_s);
    if (fabsf(w) >= dir_speed_rad_s) {
        return fw_wrap_2pi(theta_emf_rad + (d->dir < 0 ? FW_PI_F : 0.0f));
    }
    return pll->theta_rad;
}
