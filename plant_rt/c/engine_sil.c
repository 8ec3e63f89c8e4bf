/* Software in the loop: the firmware's SIL port as the engine's in-process controller. */
#include "engine_sil.h"

/* hil_octet_t is the host's octet (uint8_t) here; the casts only adapt the signatures. */
static void sil_write(void *ctx, const uint8_t *data, size_t n, int64_t now_ns)
{
    sil_port_write((sil_port_t *)ctx, (const hil_octet_t *)data, n, now_ns);
}

static size_t sil_read(void *ctx, uint8_t *out, size_t cap, int64_t now_ns)
{
    return sil_port_read((sil_port_t *)ctx, (hil_octet_t *)out, cap, now_ns);
}

void engine_sil_peer(sil_port_t *p, eng_link_peer_t *peer)
{
    peer->ctx = p;
    peer->write = sil_write;
    peer->read = sil_read;
}
