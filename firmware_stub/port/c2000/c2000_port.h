/**
 * @file c2000_port.h
 * @brief Skeleton port of the firmware to a TI TMS320F28335 (C28x + FPU32, 150 MHz): the HIL link
 * on eCAN-A (a mailbox per DBC id) or SCI-A (COBS framing), the control ISR on the ADC's end of
 * sequence started by ePWM1's SOCA at counter zero, duties into the ePWM compare shadows, loaded
 * at the next counter zero (the bench's "next_period" duty-update model, docs/realtime.md).
 *
 * Compiled and tested on the host against a small mock of TI's register headers
 * (mock/DSP2833x_Device.h; tests/c/test_c2000_port.c). NOT run on a C28x: docs/ports.md says how
 * to build it with TI's compiler and what that leaves to check on the part.
 */
#ifndef HIL_C2000_PORT_H
#define HIL_C2000_PORT_H

#include <stdint.h>

#include "DSP2833x_Device.h"
#include "hil_session.h"

#ifdef __TMS320C2000__
#define HIL_C2000_INTERRUPT __interrupt
#else
#define HIL_C2000_INTERRUPT
#endif

/* eCAN registers with write-1-to-set (CANTRS) and write-1-to-clear (CANRMP, CANTA) bits are
 * written as whole words with only the bits meant (never read-modify-write: a mailbox that
 * completes between the read and the write would be requested again). The host mock emulates
 * the hardware's semantics by defining these first. */
#ifndef HIL_C2000_W1S
#define HIL_C2000_W1S(reg, bits) ((reg).all = (bits))
#define HIL_C2000_W1C(reg, bits) ((reg).all = (bits))
#endif

#define HIL_C2000_SYSCLK_HZ 150000000UL
#define HIL_C2000_LSPCLK_HZ HIL_C2000_SYSCLK_HZ /* LOSPCP = 0: LSPCLK = SYSCLKOUT / 1 */
#define HIL_C2000_SCI_MAX_ERROR_PPM 20000UL     /* 2 %: the design margin of an 8N1 link */

typedef enum { HIL_C2000_LINK_CAN = 0, HIL_C2000_LINK_SCI = 1 } hil_c2000_link_t;

/** One eCAN-A mailbox of the HIL message set: its standard id and whether the drive receives it. */
typedef struct {
    uint16_t id;
    uint16_t receive; /**< 1: the plant sends it (CANMD bit set), 0: the drive sends it */
} hil_c2000_mbox_t;

typedef struct {
    uint32_t sci_baud, sci_brr;  /**< SCI-A: the baud rate chosen and BRR */
    uint32_t isr_runs, isr_stale; /**< control ISRs; those with no new SENSE since the last */
    uint32_t rx_lost;            /**< eCAN: a mailbox overwritten before it was read (CANRML) */
    uint32_t tx_busy;            /**< eCAN: a frame dropped, its mailbox still transmitting */
    uint32_t sci_tx_overflows;   /**< SCI: a frame dropped, the transmit ring full */
    uint32_t can_config_timeouts; /**< eCAN: CANES.CCE did not follow CANMC.CCR */
} hil_c2000_stats_t;

/** The mailbox table (from the generated codec's ids, hil_msgs.h); mailbox n = entry n. */
const hil_c2000_mbox_t *hil_c2000_mboxes(uint16_t *count);

/** The highest standard baud rate SCI-A makes from lspclk_hz within 2 %: BRR = LSPCLK/(8 baud) - 1.
 * Returns the baud (0 if none) and writes BRR. */
uint32_t hil_c2000_sci_pick(uint32_t lspclk_hz, uint32_t *brr);

/** ePWM compare value of a duty in [0, 1] for an up-down counter of period tbprd. */
Uint16 hil_c2000_cmpa(float duty, Uint16 tbprd);

/** Peripherals and the session: ePWM1-3 at the control period, ADC SEQ1 on SOCA, the link. */
void hil_c2000_init(hil_c2000_link_t link, float period_s);
/** Main loop: received frames to the session (SENSE is latched for the control ISR). */
void hil_c2000_poll(void);
/** The control ISR (PIE group 1, ADCINT): the latest SENSE through the session, duties to the
 * compare shadows. */
HIL_C2000_INTERRUPT void hil_c2000_adc_isr(void);
/** Every 100 ms (CPU timer 0): HEARTBEAT_CTRL while no cycles flow. */
void hil_c2000_tick_100ms(void);

hil_session_t *hil_c2000_session(void);
const hil_c2000_stats_t *hil_c2000_stats(void);

#endif
