/* Reference estimators of the cycle engine (engine_refs.h). */
#include "engine_refs.h"

#include <string.h>

size_t eng_ref_config_size(int kind)
{
    switch (kind) {
    case ENG_REF_SMO_SIGN: return sizeof(est_smo_sign_config_t);
    case ENG_REF_SMO_SIGMOID: return sizeof(est_smo_sigmoid_config_t);
    case ENG_REF_SMO_TANH: return sizeof(est_smo_tanh_config_t);
    case ENG_REF_HFI_SDFT: return sizeof(est_hfi_config_t);
    case ENG_REF_SMO_STA: return sizeof(est_smo_sta_config_t);
    default: return 0u;
    }
}

int eng_ref_init(eng_ref_t *r, int kind, const void *config, size_t config_size)
{
    const size_t want = eng_ref_config_size(kind);
    int rc;
    if (want == 0u || config == NULL || config_size != want) {
        return -1;
    }
    memset(r, 0, sizeof *r);
    r->kind = kind;
    switch (kind) {
    case ENG_REF_SMO_SIGN: {
        est_smo_sign_config_t c;
        memcpy(&c, config, sizeof c);
        rc = est_smo_sign_init(&r->s.sign, &c);
        break;
    }
    case ENG_REF_SMO_SIGMOID: {
        est_smo_sigmoid_config_t c;
        memcpy(&c, config, sizeof c);
        rc = est_smo_sigmoid_init(&r->s.sigmoid, &c);
        break;
    }
    case ENG_REF_SMO_TANH: {
        est_smo_tanh_config_t c;
        memcpy(&c, config, sizeof c);
        rc = est_smo_tanh_init(&r->s.tanh_, &c);
        break;
    }
    case ENG_REF_SMO_STA: {
        est_smo_sta_config_t c;
        memcpy(&c, config, sizeof c);
        rc = est_smo_sta_init(&r->s.sta, &c);
        break;
    }
    default: {
        est_hfi_config_t c;
        memcpy(&c, config, sizeof c);
        rc = est_hfi_init(&r->s.hfi, &c);
        break;
    }
    }
    return rc == 0 ? 0 : -2;
}

const est_output_t *eng_ref_step(eng_ref_t *r, fw_vec2_t i_ab_a, fw_vec2_t v_ab_prev_v)
{
    switch (r->kind) {
    case ENG_REF_SMO_SIGN: return est_smo_sign_step(&r->s.sign, i_ab_a, v_ab_prev_v);
    case ENG_REF_SMO_SIGMOID: return est_smo_sigmoid_step(&r->s.sigmoid, i_ab_a, v_ab_prev_v);
    case ENG_REF_SMO_TANH: return est_smo_tanh_step(&r->s.tanh_, i_ab_a, v_ab_prev_v);
    case ENG_REF_SMO_STA: return est_smo_sta_step(&r->s.sta, i_ab_a, v_ab_prev_v);
    default: return &est_hfi_step(&r->s.hfi, i_ab_a, v_ab_prev_v)->est;
    }
}
