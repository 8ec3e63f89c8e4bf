/**
 * @file usart.h
 * @brief USART1 (PA9 TX, PA10 RX, AF7) as the HIL link: 8N1, interrupt receive into a ring,
 * interrupt transmit from a ring. No blocking anywhere: a full receive ring drops the octet and
 * counts it (the deframer then rejects the frame: a CRC or COBS error the bench sees); a full
 * transmit ring drops the whole frame and counts it.
 *
 * QEMU's model (hw/char/stm32f2xx_usart.c) stores BRR but does not pace by it: octets move as
 * fast as the emulator's character device takes them. It holds one received octet in DR and
 * takes the next from the host only once DR was read (RXNE clear), so it never overruns; TXE is
 * always set and a write to DR goes out at once. QEMU 7.2 (Debian 12) interrupts on RXNE only,
 * never on TXE: the writer starts every transmission itself (usart.c tx_pump).
 */
#ifndef HIL_CM_USART_H
#define HIL_CM_USART_H

#include <stddef.h>
#include <stdint.h>

#define HIL_USART_RX_RING 1024u /* power of two */
#define HIL_USART_TX_RING 1024u /* power of two */

typedef struct {
    uint32_t rx_bytes, rx_ring_overflows, overruns, tx_bytes, tx_ring_overflows;
} hil_usart_stats_t;

/** 8N1 at baud from an APB2 clock of pclk2_hz; returns the BRR written. */
uint32_t hil_usart_init(uint32_t pclk2_hz, uint32_t baud);
/** Next received octet into *b: 1, or 0 when the ring is empty. Main loop only. */
int hil_usart_read(uint_least8_t *b);
/** Nothing received and not yet read. */
int hil_usart_rx_empty(void);
/** Queue n octets as one unit (all or none): 0, or -1 when the ring has no room. Any context. */
int hil_usart_write(const uint_least8_t *octets, size_t n);
const volatile hil_usart_stats_t *hil_usart_stats(void);
/** While held, writes only queue (the control ISR's own cost is measured without the transmit);
 * releasing starts the transmission. */
void hil_usart_hold(int hold);

#endif
