/**
 * @file c2000_port.h
 * @brief Skeleton port of the firmware to a TI TMS320F28335 (C28x + FPU32, 150 MHz): the HIL link
 * on eCAN-A (a mailbox per DBC id) or SCI-A (COBS framing), the control ISR on the ADC's end of
 * sequence started by ePWM1's SOCA at counter zero, duties into the ePWM compare shadows, loaded
 * at the next counter zero (the bench's "next_period" duty-update model, docs/realtime.md).
 *
 * The control period comes from HELLO.period_us: the ePWM time base is programmed when a HELLO is
 * accepted, and a period outside HIL_C2000_PERIOD_MIN_US..MAX_US is refused (PERIOD_UNSUPPORTED).
 *
 * Compiled and tested on the host against a small mock of TI's register headers
 * (mock/DSP2833x_Device.h, mock/DSP2833x_Examples.h; tests/c/test_c2000_port.c, built once per
 * link). NOT run on a C28x: docs/ports.md says how to build it with TI's compiler and what that
 * leaves to check on the part.
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
/* LOSPCP = 2: LSPCLK = SYSCLKOUT / 4 = 37.5 MHz, SPRS439Q's nominal ("Clocking and Nomenclature": 75
 * MHz at most, where no standard rate near 1 Mbaud comes within 2 % either: 1 041 667 at BRR 8) */
#define HIL_C2000_LSPCLK_HZ (HIL_C2000_SYSCLK_HZ / 4UL)
#define HIL_C2000_SCI_MAX_ERROR_PPM 20000UL     /* 2 %: the design margin of an 8N1 link */

/* The HIL link, chosen at build time: --define=HIL_C2000_LINK=HIL_C2000_LINK_CAN (cl2000; gcc:
 * -DHIL_C2000_LINK=HIL_C2000_LINK_CAN) for eCAN-A, else SCI-A with the COBS/CRC framing. Both
 * drivers are compiled; main.c sets up the chosen one's pins and hands it to hil_c2000_init. The
 * host build makes and tests both (firmware_stub/port/c2000/c2000.cmake). */
#define HIL_C2000_LINK_CAN 0
#define HIL_C2000_LINK_SCI 1
#ifndef HIL_C2000_LINK
#define HIL_C2000_LINK HIL_C2000_LINK_SCI
#endif
#if HIL_C2000_LINK != HIL_C2000_LINK_CAN && HIL_C2000_LINK != HIL_C2000_LINK_SCI
#error "HIL_C2000_LINK must be HIL_C2000_LINK_CAN or HIL_C2000_LINK_SCI"
#endif
typedef int hil_c2000_link_t;

/* The control periods this port runs, from HELLO.period_us (PERIOD_UNSUPPORTED outside).
 * Minimum: the period the port is written and budgeted for (10 kHz, the papers' rate). The
 * portable control ISR takes 4 700 Cortex-M4F instructions on G2 (docs/ports.md); its C28x time is
 * not measured here: measure it on the part (a GPIO toggled around hil_c2000_adc_isr, or TBCTR read
 * at its end) and lower the minimum with -DHIL_C2000_PERIOD_MIN_US=... if the ISR and the link's
 * traffic fit. Maximum: the wire's largest period (HELLO.period_us raw 65535 = 6553.5 us), which
 * the ePWM makes with TBCLK = SYSCLKOUT / 8 (hil_c2000_epwm_timebase). */
#ifndef HIL_C2000_PERIOD_MIN_US
#define HIL_C2000_PERIOD_MIN_US 100.0f
#endif
#define HIL_C2000_PERIOD_MAX_US 6553.5f

/** One eCAN-A mailbox of the HIL message set: its standard id and whether the drive receives it. */
typedef struct {
    uint16_t id;
    uint16_t receive; /**< 1: the plant sends it (CANMD bit set), 0: the drive sends it */
} hil_c2000_mbox_t;

typedef struct {
    uint32_t sci_baud, sci_brr;  /**< SCI-A: the baud rate chosen and BRR */
    uint32_t period_ns;          /**< the control (PWM) period the ePWM makes; 0 before a HELLO */
    uint32_t tbprd, clkdiv;      /**< its time base: TBPRD and TBCTL.CLKDIV (TBCLK = SYSCLKOUT / 2^clkdiv) */
    uint32_t period_changes;     /**< accepted HELLOs that (re)programmed the ePWM */
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

/** The ePWM time base of an up-down count for a control period: TBPRD and the smallest CLKDIV
 * (TBCLK = SYSCLKOUT / 2^clkdiv, HSPCLKDIV 1) with TBPRD = period * TBCLK / 2 <= 65535, rounded.
 * 0, or -1 when no CLKDIV makes it. */
int hil_c2000_epwm_timebase(float period_s, Uint16 *tbprd, Uint16 *clkdiv);

/** Peripherals and the session: ePWM1-3 frozen with their outputs low until a HELLO gives the
 * period (the session accepts HIL_C2000_PERIOD_MIN_US..MAX_US), ADC SEQ1 on SOCA, the link. */
void hil_c2000_init(hil_c2000_link_t link);
/** Main loop: received frames to the session (SENSE is latched for the control ISR). */
void hil_c2000_poll(void);
/** The control ISR (PIE group 1, ADCINT): the latest SENSE through the session, duties to the
 * compare shadows. */
HIL_C2000_INTERRUPT void hil_c2000_adc_isr(void);
/** Every 100 ms (CPU timer 0): HEARTBEAT_CTRL while no cycles flow. */
void hil_c2000_tick_100ms(void);

/** main.c: the start-up of the part (TI's InitSysCtrl: PLL to 150 MHz; LSPCLK = SYSCLKOUT; the
 * chosen link's pins; PIE vectors for ADCINT and TINT0; ADC; CPU timer 0 at 100 ms; the port; the
 * interrupts on). TI's main() calls it, then hil_c2000_poll() forever; the host test calls it
 * against the mock. */
void hil_c2000_start(void);
/** main.c: CPU timer 0's interrupt (PIE 1.7): hil_c2000_tick_100ms. */
HIL_C2000_INTERRUPT void hil_c2000_timer0_isr(void);

hil_session_t *hil_c2000_session(void);
const hil_c2000_stats_t *hil_c2000_stats(void);

#endif
