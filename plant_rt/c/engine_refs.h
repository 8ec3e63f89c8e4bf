/**
 * @file engine_refs.h
 * @brief Reference estimators in the cycle engine: the firmware's own estimator library (the
 * same C the stub and the DSP run), one instance per `[reference]` entry of a scenario, stepped
 * on exactly the samples and voltages the controller saw.
 *
 * Kinds are the protocol's Estimator values (protocol/hil.dbc): 1 SMO_SIGN, 2 SMO_SIGMOID,
 * 3 SMO_TANH, 4 HFI_SDFT, 6 SMO_STA. The configuration is the module's own config struct, filled on the
 * Python side by the same gain rules the controller's settings come from
 * (firmware_stub/est_smo.py), and copied in as bytes (its size is checked).
 */
#ifndef ENGINE_REFS_H
#define ENGINE_REFS_H

#include <stddef.h>

#include "est_hfi.h"
#include "est_smo_sigmoid.h"
#include "est_smo_sign.h"
#include "est_smo_sta.h"
#include "est_smo_tanh.h"

typedef enum {
    ENG_REF_SMO_SIGN = 1,
    ENG_REF_SMO_SIGMOID = 2,
    ENG_REF_SMO_TANH = 3,
    ENG_REF_HFI_SDFT = 4,
    ENG_REF_SMO_STA = 6
} eng_ref_kind_t;

typedef struct {
    int kind;
    union {
        est_smo_sign_t sign;
        est_smo_sigmoid_t sigmoid;
        est_smo_tanh_t tanh_;
        est_smo_sta_t sta;
        est_hfi_t hfi;
    } s;
} eng_ref_t;

/** Size of the config struct of a kind (0 if the kind is unknown). */
size_t eng_ref_config_size(int kind);
/** 0, -1 unknown kind or wrong config size, -2 the module refused the configuration. */
int eng_ref_init(eng_ref_t *r, int kind, const void *config, size_t config_size);
/** One step: currents at t_k, alpha-beta voltage that acted over the last period. */
const est_output_t *eng_ref_step(eng_ref_t *r, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v);

#endif
