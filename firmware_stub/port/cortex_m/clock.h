/**
 * @file clock.h
 * @brief Core clock set-up of the STM32F405: HSE -> PLL -> 168 MHz, AHB 168, APB1 42, APB2 84 MHz,
 * flash at 5 wait states. Every wait is bounded: a crystal that does not start leaves the part on
 * its 16 MHz HSI and says so (target_stats.h clock_flags) instead of hanging.
 */
#ifndef HIL_CM_CLOCK_H
#define HIL_CM_CLOCK_H

#include <stdint.h>

#ifndef HIL_CM_HSE_HZ
#define HIL_CM_HSE_HZ 25000000u /* the Netduino Plus 2's crystal; an F4 Discovery has 8 MHz */
#endif
#define HIL_CM_HSI_HZ 16000000u
#define HIL_CM_SYSCLK_HZ 168000000u
/* QEMU's netduinoplus2 runs its core and SysTick at a fixed 168 MHz and has no RCC */
#define HIL_CM_EMULATED_SYSCLK_HZ 168000000u

typedef struct {
    uint32_t sysclk_hz;
    uint32_t pclk2_hz; /**< APB2: USART1 */
    uint32_t flags;    /**< HIL_CLOCK_* (target_stats.h) */
} hil_clock_t;

void hil_clock_init(hil_clock_t *c);

#endif
