/* Serial framing: COBS + CRC-16/CCITT-FALSE, 0x00 delimited. See hil_framing.h and docs/protocol.md. */
#include "hil_framing.h"

/* CRC-16/CCITT-FALSE, one nibble at a time: 16-entry table (32 octets of flash), two look-ups per octet.
 * hil_crc_nibble[i] = CRC register after shifting the 4-bit value i through poly 0x1021. */
static const uint16_t hil_crc_nibble[16] = {
    0x0000u, 0x1021u, 0x2042u, 0x3063u, 0x4084u, 0x50A5u, 0x60C6u, 0x70E7u,
    0x8108u, 0x9129u, 0xA14Au, 0xB16Bu, 0xC18Cu, 0xD1ADu, 0xE1CEu, 0xF1EFu,
};

uint16_t hil_crc16_update(uint16_t crc, const hil_octet_t *data, size_t len)
{
    size_t i;
    for (i = 0u; i < len; i++) {
        unsigned int octet = (unsigned int)data[i] & 0xFFu;
        unsigned int hi = ((unsigned int)crc >> 12) ^ (octet >> 4);
        crc = (uint16_t)((((uint32_t)crc << 4) ^ hil_crc_nibble[hi & 0xFu]) & 0xFFFFu);
        hi = ((unsigned int)crc >> 12) ^ (octet & 0xFu);
        crc = (uint16_t)((((uint32_t)crc << 4) ^ hil_crc_nibble[hi & 0xFu]) & 0xFFFFu);
    }
    return crc;
}

uint16_t hil_crc16(const hil_octet_t *data, size_t len)
{
    return hil_crc16_update(0xFFFFu, data, len);
}

/* COBS-encode n octets of src into dst (which must hold n + n / 254 + 1 octets). Returns the length. */
static size_t hil_cobs_encode(hil_octet_t *dst, const hil_octet_t *src, size_t n)
{
    size_t out = 1u;
    size_t code_at = 0u;
    unsigned int code = 1u;
    size_t i;
    for (i = 0u; i < n; i++) {
        unsigned int octet = (unsigned int)src[i] & 0xFFu;
        if (octet == 0u) {
            dst[code_at] = (hil_octet_t)code;
            code_at = out++;
            code = 1u;
        } else {
            dst[out++] = (hil_octet_t)octet;
            code++;
            if (code == 0xFFu) {
                dst[code_at] = (hil_octet_t)code;
                code_at = out++;
                code = 1u;
            }
        }
    }
    dst[code_at] = (hil_octet_t)code;
    return out;
}

size_t hil_frame_encode(hil_octet_t *dst, size_t dst_size, uint16_t id, const hil_octet_t *data, size_t dlc)
{
    hil_octet_t raw[HIL_FRAME_MAX_RAW];
    size_t n;
    size_t i;
    uint16_t crc;
    if (dst == NULL || id > HIL_FRAME_MAX_ID || dlc > HIL_FRAME_MAX_DATA || (data == NULL && dlc > 0u)) {
        return 0u;
    }
    if (dst_size < HIL_FRAME_WIRE_SIZE(dlc)) {
        return 0u;
    }
    raw[0] = (hil_octet_t)(id & 0xFFu);
    raw[1] = (hil_octet_t)((id >> 8) & 0xFFu);
    raw[2] = (hil_octet_t)dlc;
    for (i = 0u; i < dlc; i++) {
        raw[3u + i] = (hil_octet_t)((unsigned int)data[i] & 0xFFu);
    }
    crc = hil_crc16(raw, 3u + dlc);
    raw[3u + dlc] = (hil_octet_t)(crc & 0xFFu);
    raw[4u + dlc] = (hil_octet_t)((crc >> 8) & 0xFFu);
    n = hil_cobs_encode(dst, raw, dlc + HIL_FRAME_OVERHEAD);
    dst[n] = 0u;
    return n + 1u;
}

void hil_deframer_init(hil_deframer_t *d)
{
    size_t i;
    for (i = 0u; i < HIL_FRAME_MAX_COBS; i++) {
        d->buf[i] = 0u;
    }
    d->len = 0u;
    d->discarding = 0u;
    d->frames_ok = 0u;
    d->crc_errors = 0u;
    d->cobs_errors = 0u;
    d->length_errors = 0u;
    d->overruns = 0u;
    d->bytes_discarded = 0u;
}

/* Decode a COBS chunk (no 0x00 inside) in place. Returns 0 and the decoded length, or -1. */
static int hil_cobs_decode_in_place(hil_octet_t *buf, size_t n, size_t *decoded)
{
    size_t r = 0u;
    size_t w = 0u;
    while (r < n) {
        unsigned int code = (unsigned int)buf[r] & 0xFFu;
        size_t end = r + code;
        if (code == 0u || end > n) {
            return -1;
        }
        r++;
        while (r < end) {
            buf[w++] = buf[r++]; /* w < r: a code octet was consumed for every implicit zero */
        }
        if (code != 0xFFu && r < n) {
            buf[w++] = 0u;
        }
    }
    *decoded = w;
    return 0;
}

enum { HIL_CHUNK_OK, HIL_CHUNK_COBS, HIL_CHUNK_LENGTH, HIL_CHUNK_CRC };

/* Validate the chunk in d->buf (destroys it). On success fills *out. */
static int hil_check_chunk(hil_deframer_t *d, hil_frame_t *out)
{
    size_t n = 0u;
    size_t dlc;
    size_t i;
    uint16_t id;
    uint16_t crc;
    if (hil_cobs_decode_in_place(d->buf, d->len, &n) != 0) {
        return HIL_CHUNK_COBS;
    }
    if (n < HIL_FRAME_OVERHEAD) {
        return HIL_CHUNK_LENGTH;
    }
    dlc = (size_t)((unsigned int)d->buf[2] & 0xFFu);
    if (dlc > HIL_FRAME_MAX_DATA || n != dlc + HIL_FRAME_OVERHEAD) {
        return HIL_CHUNK_LENGTH;
    }
    crc = (uint16_t)(((unsigned int)d->buf[n - 2u] & 0xFFu) | (((unsigned int)d->buf[n - 1u] & 0xFFu) << 8));
    if (hil_crc16(d->buf, n - 2u) != crc) {
        return HIL_CHUNK_CRC;
    }
    id = (uint16_t)(((unsigned int)d->buf[0] & 0xFFu) | (((unsigned int)d->buf[1] & 0xFFu) << 8));
    if (id > HIL_FRAME_MAX_ID) {
        return HIL_CHUNK_LENGTH;
    }
    if (out != NULL) {
        out->id = id;
        out->dlc = (uint16_t)dlc;
        for (i = 0u; i < dlc; i++) {
            out->data[i] = d->buf[3u + i];
        }
    }
    return HIL_CHUNK_OK;
}

int hil_deframer_push(hil_deframer_t *d, hil_octet_t byte, hil_frame_t *out)
{
    unsigned int octet = (unsigned int)byte & 0xFFu;
    uint16_t len;
    if (d == NULL) {
        return 0;
    }
    if (octet != 0u) {
        if (d->discarding != 0u) {
            d->bytes_discarded++;
        } else if (d->len >= HIL_FRAME_MAX_COBS) {
            d->overruns++;
            d->bytes_discarded += (uint32_t)d->len + 1u;
            d->len = 0u;
            d->discarding = 1u;
        } else {
            d->buf[d->len++] = (hil_octet_t)octet;
        }
        return 0;
    }
    /* a delimiter */
    if (d->discarding != 0u) {
        d->discarding = 0u;
        return 0;
    }
    len = d->len;
    if (len == 0u) {
        return 0;
    }
    switch (hil_check_chunk(d, out)) {
    case HIL_CHUNK_OK:
        d->len = 0u;
        d->frames_ok++;
        return 1;
    case HIL_CHUNK_COBS:
        d->cobs_errors++;
        break;
    case HIL_CHUNK_LENGTH:
        d->length_errors++;
        break;
    default:
        d->crc_errors++;
        break;
    }
    d->len = 0u;
    d->bytes_discarded += len;
    return 0;
}
