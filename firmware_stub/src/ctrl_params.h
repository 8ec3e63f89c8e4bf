/**
 * @file ctrl_params.h
 * @brief CONFIG parameter ids (protocol/hil.dbc `param_id` table) -> controller configuration.
 */
#ifndef CTRL_PARAMS_H
#define CTRL_PARAMS_H

#include "controller.h"

/** Store one parameter; returns the protocol's CONFIG_ACK status (0 = OK, 1 = unknown, 2 = out of range). */
int ctrl_param_set(ctrl_config_t *cfg, unsigned param_id, float value);
/** Read one parameter back (its value now: the default until CONFIG set it); 0 = OK, 1 = unknown. */
int ctrl_param_get(const ctrl_config_t *cfg, unsigned param_id, float *value);

/** The protocol minor version that added the parameter (0: protocol 1.0), -1 if unknown. */
int ctrl_param_since_minor(unsigned param_id);

#endif
