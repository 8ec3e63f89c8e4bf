/**
 * @file ctrl_params.h
 * @brief CONFIG parameter ids (protocol/hil.dbc `param_id` table) -> controller configuration.
 */
#ifndef CTRL_PARAMS_H
#define CTRL_PARAMS_H

#include "controller.h"

/**
 * Protection thresholds (ctrl_protect.h). Not in protocol/hil.dbc's param_id table yet: these
 * ids are proposed for it (the CONFIG frame carries any 16-bit id).
 */
#define CTRL_PARAM_PROT_OPEN_I_MIN_A 70u
#define CTRL_PARAM_PROT_OPEN_RATIO 71u
#define CTRL_PARAM_PROT_OPEN_TIME_S 72u
#define CTRL_PARAM_PROT_SUM_MAX_A 73u
#define CTRL_PARAM_PROT_SUM_TAU_S 74u
#define CTRL_PARAM_PROT_STUCK_TIME_S 75u
#define CTRL_PARAM_PROT_STUCK_DELTA_A 76u
#define CTRL_PARAM_PROT_VDC_UV_RATIO 77u
#define CTRL_PARAM_PROT_VDC_OV_RATIO 78u
#define CTRL_PARAM_PROT_VDC_TIME_S 79u
#define CTRL_PARAM_PROT_LINK_TIMEOUT_PERIODS 80u

/** Store one parameter; returns the protocol's CONFIG_ACK status (0 = OK, 1 = unknown, 2 = out of range). */
int ctrl_param_set(ctrl_config_t *cfg, unsigned param_id, float value);

#endif
