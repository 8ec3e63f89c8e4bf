/**
 * @file engine_sil.h
 * @brief Software in the loop: the firmware's SIL port (firmware_stub/port/sil/sil_port.h) as
 * the cycle engine's in-process controller (eng_link_peer_t). The engine's serial octets go to
 * sil_port_write(), the firmware's come from sil_port_read(), on the engine's own thread.
 */
#ifndef ENGINE_SIL_H
#define ENGINE_SIL_H

#include "engine_link.h"
#include "sil_port.h"

/** Fill *peer so that the engine's link talks to the SIL port p. */
void engine_sil_peer(sil_port_t *p, eng_link_peer_t *peer);

#endif
