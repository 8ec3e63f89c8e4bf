/**
 * @file stm32f4_regs.h
 * @brief The few STM32F405 / Cortex-M4 registers this port touches, by address (RM0090 and the
 * ARMv7-M Architecture Reference Manual). A product port would include ST's CMSIS device header
 * instead; this one keeps the port free of vendor files so that it builds with Debian's
 * arm-none-eabi toolchain alone.
 */
#ifndef STM32F4_REGS_H
#define STM32F4_REGS_H

#include <stdint.h>

#define HIL_REG32(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

/* ---- Cortex-M4 system control space ---------------------------------------------------- */
#define SCB_VTOR HIL_REG32(0xE000ED08u)
#define SCB_AIRCR HIL_REG32(0xE000ED0Cu)
#define SCB_SHPR3 HIL_REG32(0xE000ED20u)  /* SysTick (bits 31:24) and PendSV priority */
#define SCB_SHCSR HIL_REG32(0xE000ED24u)
#define SCB_CFSR HIL_REG32(0xE000ED28u)
#define SCB_HFSR HIL_REG32(0xE000ED2Cu)
#define SCB_MMFAR HIL_REG32(0xE000ED34u)
#define SCB_BFAR HIL_REG32(0xE000ED38u)
#define SCB_CPACR HIL_REG32(0xE000ED88u)
#define SCB_CPACR_CP10_CP11_FULL (0xFu << 20)
#define FPU_FPCCR HIL_REG32(0xE000EF34u)
#define FPU_FPCCR_ASPEN_LSPEN (3u << 30)  /* automatic, lazy FP context save (reset value) */
#define SCB_SHCSR_FAULTS_EN ((1u << 16) | (1u << 17) | (1u << 18)) /* Mem, Bus, Usage faults */

#define SYST_CSR HIL_REG32(0xE000E010u)
#define SYST_RVR HIL_REG32(0xE000E014u)
#define SYST_CVR HIL_REG32(0xE000E018u)
#define SYST_CSR_ENABLE (1u << 0)
#define SYST_CSR_TICKINT (1u << 1)
#define SYST_CSR_CLKSOURCE_CPU (1u << 2)
#define SYST_CSR_COUNTFLAG (1u << 16)

#define NVIC_ISER(n) HIL_REG32(0xE000E100u + 4u * (uint32_t)(n))
#define NVIC_ISPR(n) HIL_REG32(0xE000E200u + 4u * (uint32_t)(n))
#define NVIC_IPR_BYTE(irq) (*(volatile uint8_t *)(uintptr_t)(0xE000E400u + (uint32_t)(irq)))
#define NVIC_STIR HIL_REG32(0xE000EF00u)

#define DEMCR HIL_REG32(0xE000EDFCu)
#define DEMCR_TRCENA (1u << 24)
#define DWT_CTRL HIL_REG32(0xE0001000u)
#define DWT_CYCCNT HIL_REG32(0xE0001004u)
#define DWT_CTRL_CYCCNTENA (1u << 0)
#define DWT_CTRL_NOCYCCNT (1u << 25)

/* ---- STM32F405 peripherals (RM0090 memory map) ------------------------------------------ */
#define RCC_BASE 0x40023800u
#define RCC_CR HIL_REG32(RCC_BASE + 0x00u)
#define RCC_PLLCFGR HIL_REG32(RCC_BASE + 0x04u)
#define RCC_CFGR HIL_REG32(RCC_BASE + 0x08u)
#define RCC_AHB1ENR HIL_REG32(RCC_BASE + 0x30u)
#define RCC_APB2ENR HIL_REG32(RCC_BASE + 0x44u)
#define RCC_CR_HSION (1u << 0)
#define RCC_CR_HSIRDY (1u << 1)
#define RCC_CR_HSEON (1u << 16)
#define RCC_CR_HSERDY (1u << 17)
#define RCC_CR_PLLON (1u << 24)
#define RCC_CR_PLLRDY (1u << 25)
#define RCC_PLLCFGR_SRC_HSE (1u << 22)
#define RCC_CFGR_SW_PLL 2u
#define RCC_CFGR_SWS_MASK (3u << 2)
#define RCC_CFGR_SWS_PLL (2u << 2)
#define RCC_CFGR_PPRE1_DIV4 (5u << 10)
#define RCC_CFGR_PPRE2_DIV2 (4u << 13)
#define RCC_AHB1ENR_GPIOAEN (1u << 0)
#define RCC_APB2ENR_USART1EN (1u << 4)

#define FLASH_ACR HIL_REG32(0x40023C00u)
#define FLASH_ACR_LATENCY_5WS 5u
#define FLASH_ACR_PRFTEN (1u << 8)
#define FLASH_ACR_ICEN (1u << 9)
#define FLASH_ACR_DCEN (1u << 10)

#define GPIOA_BASE 0x40020000u
#define GPIOA_MODER HIL_REG32(GPIOA_BASE + 0x00u)
#define GPIOA_OSPEEDR HIL_REG32(GPIOA_BASE + 0x08u)
#define GPIOA_PUPDR HIL_REG32(GPIOA_BASE + 0x0Cu)
#define GPIOA_AFRH HIL_REG32(GPIOA_BASE + 0x24u)

#define USART1_BASE 0x40011000u
#define USART1_SR HIL_REG32(USART1_BASE + 0x00u)
#define USART1_DR HIL_REG32(USART1_BASE + 0x04u)
#define USART1_BRR HIL_REG32(USART1_BASE + 0x08u)
#define USART1_CR1 HIL_REG32(USART1_BASE + 0x0Cu)
#define USART1_CR2 HIL_REG32(USART1_BASE + 0x10u)
#define USART1_CR3 HIL_REG32(USART1_BASE + 0x14u)
#define USART_SR_ORE (1u << 3)
#define USART_SR_RXNE (1u << 5)
#define USART_SR_TXE (1u << 7)
#define USART_CR1_RE (1u << 2)
#define USART_CR1_TE (1u << 3)
#define USART_CR1_RXNEIE (1u << 5)
#define USART_CR1_TXEIE (1u << 7)
#define USART_CR1_UE (1u << 13)

/* ---- interrupt numbers (RM0090 table 61) ------------------------------------------------ */
#define IRQ_ADC 18u     /* the control ISR: ADC end of conversion on a drive, pended by the
                           port when a SENSE arrives in lockstep */
#define IRQ_USART1 37u
#define IRQ_COUNT 82u   /* vector table entries after the 16 system exceptions */

static inline void hil_irq_disable(void) { __asm__ volatile("cpsid i" ::: "memory"); }
static inline void hil_irq_enable(void) { __asm__ volatile("cpsie i" ::: "memory"); }
static inline void hil_dsb_isb(void) { __asm__ volatile("dsb\n\tisb" ::: "memory"); }
static inline void hil_wfi(void) { __asm__ volatile("wfi" ::: "memory"); }
static inline uint32_t hil_primask_save(void)
{
    uint32_t m;
    __asm__ volatile("mrs %0, primask\n\tcpsid i" : "=r"(m)::"memory");
    return m;
}
static inline void hil_primask_restore(uint32_t m)
{
    __asm__ volatile("msr primask, %0" ::"r"(m) : "memory");
}

#endif
