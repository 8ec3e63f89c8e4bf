/**
 * @file svpwm.h
 * @brief Space-vector PWM by min-max (common-mode) injection, center-aligned.
 *
 * Equivalent to classic seven-segment SVPWM. The linear range is |v_ab| <= v_dc/sqrt(3);
 * a longer vector is scaled back to the hexagon's inscribed circle keeping its angle.
 */
#ifndef SVPWM_H
#define SVPWM_H

#include "fw_math.h"

/**
 * Duties (fraction of the period the high side is on, [0, 1]) for the alpha-beta voltage
 * command v_ab_v on a bus of v_dc_v. Returns the voltage vector actually realised (after the
 * limit), which is what an observer should be fed.
 */
fw_vec2_t svpwm_duties(fw_vec2_t v_ab_v, float v_dc_v, float duty_abc[3]);

#endif
