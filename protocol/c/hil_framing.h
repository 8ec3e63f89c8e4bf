/* Serial framing of the hil-bench HIL link (docs/protocol.md, "Serial framing").
 *
 * One frame on the wire:   COBS( id_lo id_hi | dlc | data[dlc] | crc_lo crc_hi ) 0x00
 *   id   11-bit CAN id as a little-endian u16, bits 11..15 zero
 *   dlc  number of data octets, 0..64
 *   crc  CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, xorout 0) over id, dlc and data,
 *        little-endian; check value of "123456789" = 0x29B1
 *   COBS Consistent Overhead Byte Stuffing: the encoded frame holds no 0x00; 0x00 ends every frame.
 *
 * Portable C99, no heap, no 8-bit exact-width types (one octet per hil_octet_t element; octets are read
 * as (value & 0xFF)). Same semantics as protocol/framing.py; both are checked against protocol/vectors/.
 */
#ifndef HIL_FRAMING_H
#define HIL_FRAMING_H

#include <stddef.h>
#include <stdint.h>

#include "hil_msgs.h" /* hil_octet_t */

#ifdef __cplusplus
extern "C" {
#endif

#define HIL_FRAME_MAX_DATA 64u    /* largest dlc */
#define HIL_FRAME_MAX_ID 0x7FFu   /* largest (11-bit) id */
#define HIL_FRAME_OVERHEAD 5u     /* id (2) + dlc (1) + crc (2) */
#define HIL_FRAME_MAX_RAW (HIL_FRAME_MAX_DATA + HIL_FRAME_OVERHEAD)                 /* 69 */
#define HIL_FRAME_MAX_COBS (HIL_FRAME_MAX_RAW + HIL_FRAME_MAX_RAW / 254u + 1u)     /* 70 */
/* Worst-case encoded size of one frame incl. the 0x00 delimiter (71). A frame with dlc n < 250 always
 * takes exactly n + 7 octets on the wire. */
#define HIL_FRAME_MAX_WIRE (HIL_FRAME_MAX_COBS + 1u)
#define HIL_FRAME_WIRE_SIZE(dlc) ((dlc) + HIL_FRAME_OVERHEAD + 2u)

typedef struct {
    uint16_t id;
    uint16_t dlc;
    hil_octet_t data[HIL_FRAME_MAX_DATA];
} hil_frame_t;

/* CRC-16/CCITT-FALSE of len octets. */
uint16_t hil_crc16(const hil_octet_t *data, size_t len);
/* Continue a CRC over more octets (start with crc = 0xFFFF). */
uint16_t hil_crc16_update(uint16_t crc, const hil_octet_t *data, size_t len);

/* Encode one frame into dst. Returns the octets written incl. the trailing 0x00, or 0 if id > 0x7FF,
 * dlc > 64, dst is NULL, data is NULL with dlc > 0, or dst_size < HIL_FRAME_WIRE_SIZE(dlc). */
size_t hil_frame_encode(hil_octet_t *dst, size_t dst_size, uint16_t id, const hil_octet_t *data, size_t dlc);

/* Receiver. A "chunk" is what lies between two 0x00 delimiters. Empty chunks (leading or repeated
 * 0x00) are idle fill and count nowhere. Every other chunk increments exactly one of:
 *   frames_ok      valid frame delivered
 *   overruns       more than HIL_FRAME_MAX_COBS octets without a delimiter (counted at the first extra
 *                  octet); everything up to the next 0x00 is discarded
 *   cobs_errors    a COBS code octet points past the end of the chunk
 *   length_errors  decoded frame < 5 octets, dlc > 64, decoded length != 5 + dlc (truncated frame), or
 *                  (checked after the CRC) an id with bits 11..15 set
 *   crc_errors     CRC mismatch
 * Checks run in the order COBS, length, CRC, id. bytes_discarded adds the octets (delimiters excluded)
 * of every rejected chunk. A rejected chunk is never decoded into *out. */
typedef struct {
    hil_octet_t buf[HIL_FRAME_MAX_COBS]; /* private: the chunk received so far */
    uint16_t len;                        /* private */
    uint16_t discarding;                 /* private: after an overrun, until the next 0x00 */
    uint32_t frames_ok;
    uint32_t crc_errors;
    uint32_t cobs_errors;
    uint32_t length_errors;
    uint32_t overruns;
    uint32_t bytes_discarded;
} hil_deframer_t;

void hil_deframer_init(hil_deframer_t *d);
/* Feed one octet. Returns 1 when it completed a valid frame (then *out holds it), 0 otherwise (nothing
 * yet, idle fill, or a rejected chunk, counted). *out is written only when 1 is returned. */
int hil_deframer_push(hil_deframer_t *d, hil_octet_t byte, hil_frame_t *out);

#ifdef __cplusplus
}
#endif

#endif /* HIL_FRAMING_H */
