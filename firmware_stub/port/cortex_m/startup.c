/**
 * @file startup.c
 * @brief Reset and the vector table of the STM32F405 (Cortex-M4F), in C: copy .data, zero .bss,
 * switch the FPU on, paint the stack for the high-water mark, call main(). Faults are written to
 * the stats block (target_stats.h) where a debugger, or the bench through QEMU, reads them.
 */
#include <stdint.h>

#include "stm32f4_regs.h"
#include "target_stats.h"

#define HIL_PAINT_MARGIN_WORDS 16u /* words below the reset handler's own frame left unpainted */

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _sstack, _estack;

int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void HardFault_Handler(void);
void hil_fault_record(const uint32_t *frame, uint32_t exc_return);

void NMI_Handler(void) __attribute__((weak, alias("Default_Handler")));
void MemManage_Handler(void) __attribute__((weak, alias("HardFault_Handler")));
void BusFault_Handler(void) __attribute__((weak, alias("HardFault_Handler")));
void UsageFault_Handler(void) __attribute__((weak, alias("HardFault_Handler")));
void SVC_Handler(void) __attribute__((weak, alias("Default_Handler")));
void PendSV_Handler(void) __attribute__((weak, alias("Default_Handler")));
void SysTick_Handler(void) __attribute__((weak, alias("Default_Handler")));
void ADC_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void USART1_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));

typedef void (*hil_vector_t)(void);

/* Every entry has a handler (an unexpected interrupt lands in Default_Handler, which records its
 * number, instead of jumping to address 0). Positional: 16 system entries, then IRQ 0..81. */
#define DH Default_Handler
#define DH2 DH, DH
#define DH4 DH2, DH2
#define DH16 DH4, DH4, DH4, DH4
__attribute__((section(".isr_vector"), used)) static const hil_vector_t g_vectors[16u + IRQ_COUNT] = {
    (hil_vector_t)(uintptr_t)&_estack, Reset_Handler, NMI_Handler, HardFault_Handler,
    MemManage_Handler, BusFault_Handler, UsageFault_Handler, DH, DH, DH, DH, SVC_Handler, DH, DH,
    PendSV_Handler, SysTick_Handler,
    DH16, DH2,              /* IRQ 0..17 */
    ADC_IRQHandler,         /* IRQ 18 */
    DH16, DH2,              /* IRQ 19..36 */
    USART1_IRQHandler,      /* IRQ 37 */
    DH16, DH16, DH4, DH4, DH4, /* IRQ 38..81 */
};
typedef char check_adc_irq[IRQ_ADC == 18u ? 1 : -1];
typedef char check_usart1_irq[IRQ_USART1 == 37u ? 1 : -1];
typedef char check_irq_count[IRQ_COUNT == 82u ? 1 : -1];

void Reset_Handler(void)
{
    uint32_t *dst;
    const uint32_t *src;
    uint32_t sp;
    volatile uint32_t *w;
    uint32_t i;

    for (src = &_sidata, dst = &_sdata; dst < &_edata;) {
        *dst++ = *src++;
    }
    for (dst = &_sbss; dst < &_ebss;) {
        *dst++ = 0u;
    }
    for (i = 0u; i < HIL_TARGET_STATS_WORDS; ++i) {
        ((volatile uint32_t *)&g_hil_target_stats)[i] = 0u;
    }
    /* CP10/CP11 full access: the FPU is off at reset and the first VFP instruction would fault */
    SCB_CPACR |= SCB_CPACR_CP10_CP11_FULL;
    hil_dsb_isb();
    /* paint the stack below this frame: the high-water mark is the lowest overwritten word */
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    for (w = &_sstack; (uint32_t)(uintptr_t)w < sp - 4u * HIL_PAINT_MARGIN_WORDS; ++w) {
        *w = HIL_STACK_PAINT;
    }
    (void)main();
    for (;;) {
        hil_wfi();
    }
}

/* The exception frame the core pushed (r0-r3, r12, lr, pc, xpsr): where the fault hit. */
void hil_fault_record(const uint32_t *frame, uint32_t exc_return)
{
    (void)exc_return;
    g_hil_target_stats.fault_cfsr = SCB_CFSR;
    g_hil_target_stats.fault_hfsr = SCB_HFSR;
    g_hil_target_stats.fault_bfar = SCB_BFAR;
    g_hil_target_stats.fault_mmfar = SCB_MMFAR;
    g_hil_target_stats.fault_lr = frame[5];
    g_hil_target_stats.fault_pc = frame[6];
    g_hil_target_stats.state = HIL_TARGET_HARDFAULT;
    hil_irq_disable();
    for (;;) {
        hil_wfi(); /* the bench sees a silent controller; the stats say why */
    }
}

__attribute__((naked)) void HardFault_Handler(void)
{
    __asm__ volatile(
        "tst lr, #4\n\t"
        "ite eq\n\t"
        "mrseq r0, msp\n\t"
        "mrsne r0, psp\n\t"
        "mov r1, lr\n\t"
        "b hil_fault_record\n\t");
}

void Default_Handler(void)
{
    uint32_t ipsr;
    __asm__ volatile("mrs %0, ipsr" : "=r"(ipsr));
    g_hil_target_stats.fault_pc = 0u;
    g_hil_target_stats.fault_hfsr = ipsr; /* an exception nobody handles: its number */
    g_hil_target_stats.state = HIL_TARGET_HARDFAULT;
    hil_irq_disable();
    for (;;) {
        hil_wfi();
    }
}
