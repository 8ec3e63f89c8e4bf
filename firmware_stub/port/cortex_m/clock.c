#include "clock.h"

#include "stm32f4_regs.h"
#include "target_stats.h"

#define CLOCK_WAIT_LOOPS 200000u /* about 20 ms at the 16 MHz reset clock: HSE starts in ~2 ms */

static int wait_set(volatile uint32_t *reg, uint32_t mask, uint32_t value)
{
    uint32_t n;
    for (n = 0u; n < CLOCK_WAIT_LOOPS; ++n) {
        if ((*reg & mask) == value) {
            return 0;
        }
    }
    return -1;
}

void hil_clock_init(hil_clock_t *c)
{
    const uint32_t pll_m = HIL_CM_HSE_HZ / 1000000u; /* 1 MHz at the VCO input */
    const uint32_t pll_n = 336u;                     /* VCO 336 MHz */
    const uint32_t pll_p = 2u;                       /* 168 MHz */
    const uint32_t pll_q = 7u;                       /* 48 MHz for USB/SDIO */

    c->flags = 0u;
    c->sysclk_hz = HIL_CM_HSI_HZ;
    c->pclk2_hz = HIL_CM_HSI_HZ;
    if (RCC_CR == 0u) {
        /* the RCC's reset value has HSION and HSIRDY set: reading 0 means there is no RCC here
         * (QEMU's netduinoplus2 leaves it unimplemented and runs at a fixed 168 MHz) */
        c->flags |= HIL_CLOCK_RCC_ABSENT;
        c->sysclk_hz = HIL_CM_EMULATED_SYSCLK_HZ;
        c->pclk2_hz = HIL_CM_EMULATED_SYSCLK_HZ / 2u;
        return;
    }
    RCC_CR |= RCC_CR_HSEON;
    if (wait_set(&RCC_CR, RCC_CR_HSERDY, RCC_CR_HSERDY) != 0) {
        c->flags |= HIL_CLOCK_HSE_TIMEOUT;
        RCC_CR &= ~RCC_CR_HSEON;
        return;
    }
    c->flags |= HIL_CLOCK_HSE_READY;
    RCC_PLLCFGR = pll_m | (pll_n << 6) | (((pll_p / 2u) - 1u) << 16) | RCC_PLLCFGR_SRC_HSE |
                  (pll_q << 24);
    RCC_CR |= RCC_CR_PLLON;
    if (wait_set(&RCC_CR, RCC_CR_PLLRDY, RCC_CR_PLLRDY) != 0) {
        c->flags |= HIL_CLOCK_PLL_TIMEOUT;
        return;
    }
    c->flags |= HIL_CLOCK_PLL_LOCKED;
    /* 5 wait states at 168 MHz and 2.7-3.6 V (RM0090 table 10), before the switch */
    FLASH_ACR = FLASH_ACR_LATENCY_5WS | FLASH_ACR_PRFTEN | FLASH_ACR_ICEN | FLASH_ACR_DCEN;
    RCC_CFGR = (RCC_CFGR & ~0xFCF0u) | RCC_CFGR_PPRE1_DIV4 | RCC_CFGR_PPRE2_DIV2;
    RCC_CFGR = (RCC_CFGR & ~3u) | RCC_CFGR_SW_PLL;
    if (wait_set(&RCC_CFGR, RCC_CFGR_SWS_MASK, RCC_CFGR_SWS_PLL) != 0) {
        c->flags |= HIL_CLOCK_PLL_TIMEOUT;
        return;
    }
    c->sysclk_hz = HIL_CM_SYSCLK_HZ;
    c->pclk2_hz = HIL_CM_SYSCLK_HZ / 2u;
}
