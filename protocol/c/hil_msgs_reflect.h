/* GENERATED FROM hil.dbc BY protocol/gen_c.py -- DO NOT EDIT.
 * Regenerate with `python protocol/gen_c.py`; `--check` verifies the committed copy. */
#ifndef HIL_MSGS_REFLECT_H
#define HIL_MSGS_REFLECT_H

/* Table-driven view of the generated codec, for tests and tools on the host (uses double).
 * Raw values travel as double: exact for integers of up to 32 bits and for binary32 floats. */

#include "hil_msgs.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum { HIL_SIG_UNSIGNED = 0, HIL_SIG_SIGNED = 1, HIL_SIG_FLOAT = 2 } hil_sig_kind_t;

typedef struct {
    const char *name;
    hil_sig_kind_t kind;
    uint16_t start_bit;
    uint16_t length_bits;
    double scale;
    double offset;
    double minimum;   /* DBC [min|max], physical */
    double maximum;
    double raw_min;   /* the same range as raw values */
    double raw_max;
    double type_min;  /* range of the raw field type */
    double type_max;
    int cyclic;       /* an angle: encode wraps modulo one turn instead of saturating */
} hil_signal_info_t;

typedef struct {
    const char *name;
    uint16_t frame_id;
    uint16_t length;
    uint16_t n_signals;
    const hil_signal_info_t *signals;
} hil_message_info_t;

extern const hil_message_info_t hil_messages[];
extern const size_t hil_message_count;

const hil_message_info_t *hil_message_by_name(const char *name);
const hil_message_info_t *hil_message_by_id(uint16_t frame_id);
int hil_signal_index(const hil_message_info_t *msg, const char *name); /* -1 if unknown */

/* raw[] in signal order; -1 if a raw value is outside its field type or size is too small. */
int hil_reflect_pack(const hil_message_info_t *msg, const double *raw, hil_octet_t *dst, size_t size);
int hil_reflect_unpack(const hil_message_info_t *msg, double *raw, const hil_octet_t *src, size_t size);
/* The per-signal functions of hil_msgs.h, by index: 0 on success, -1 on a bad index or raw value. */
int hil_reflect_encode(const hil_message_info_t *msg, size_t sig, float value, double *raw);
int hil_reflect_decode(const hil_message_info_t *msg, size_t sig, double raw, float *value);
int hil_reflect_is_in_range(const hil_message_info_t *msg, size_t sig, double raw, int *in_range);

#ifdef __cplusplus
}
#endif

#endif /* HIL_MSGS_REFLECT_H */
