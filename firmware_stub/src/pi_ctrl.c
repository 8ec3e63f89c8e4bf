#include "pi_ctrl.h"

#include "fw_math.h"

void pi_ctrl_init(pi_ctrl_t *pi, const pi_ctrl_config_t *cfg)
{
    pi->cfg = *cfg;
    pi_ctrl_reset(pi, 0.0f);
}

void pi_ctrl_reset(pi_ctrl_t *pi, float integ)
{
    pi->integ = fw_clampf(integ, pi->cfg.out_min, pi->cfg.out_max);
    pi->out = pi->integ;
}

void pi_ctrl_set_limits(pi_ctrl_t *pi, float out_min, float out_max)
{
    pi->cfg.out_min = out_min;
    pi->cfg.out_max = out_max;
    pi->integ = fw_clampf(pi->integ, out_min, out_max);
}

float pi_ctrl_step(pi_ctrl_t *pi, float error, float ts_s)
{
    float p = pi->cfg.kp * error;
    float integ_next = pi->integ + pi->cfg.ki * ts_s * error;
    float u = p + integ_next;
    if (u > pi->cfg.out_max) {
        u = pi->cfg.out_max;
        if (error < 0.0f) {
            pi->integ = integ_next; /* integrating pulls the output back inside */
        }
    } else if (u < pi->cfg.out_min) {
        u = pi->cfg.out_min;
        if (error > 0.0f) {
            pi->integ = integ_next;
        }
    } else {
        pi->integ = integ_next;
    }
    pi->integ = fw_clampf(pi->integ, pi->cfg.out_min, pi->cfg.out_max);
    pi->out = u;
    return u;
}
