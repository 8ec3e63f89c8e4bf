/**
 * @file target_stats.h
 * @brief What the target measures about itself, at a fixed address for a debugger to read.
 *
 * The block sits at the start of SRAM (0x20000000, section .hil_stats in stm32f405.ld). Under
 * QEMU the bench reads it with the monitor's `xp` before it ends the emulator
 * (bench/loop/links/qemu.py: TargetStats mirrors this layout); on silicon read it with any
 * debugger, e.g. OpenOCD `mdw 0x20000000 43` or gdb `x/43wx 0x20000000`.
 *
 * All fields are uint32_t, in this order; HIL_TARGET_STATS_VERSION changes with the layout.
 */
#ifndef TARGET_STATS_H
#define TARGET_STATS_H

#include <stdint.h>

#define HIL_TARGET_STATS_MAGIC 0x53484948u /* "HILS" little-endian */
#define HIL_TARGET_STATS_VERSION 3u
#define HIL_STACK_PAINT 0xA5A5A5A5u /* every stack word at reset (startup.c) */

/** What counts the ISR's cost (counter_kind). */
#define HIL_COUNTER_NONE 0u
#define HIL_COUNTER_DWT_CYCCNT 1u  /* core clock cycles (silicon) */
#define HIL_COUNTER_SYSTICK 2u     /* SysTick at the core clock; under QEMU with -icount shift=0
                                      one instruction = 1 ns, so ticks * 1e9 / clock_hz =
                                      instructions */

/** clock_flags */
#define HIL_CLOCK_HSE_READY (1u << 0)
#define HIL_CLOCK_PLL_LOCKED (1u << 1)
#define HIL_CLOCK_RCC_ABSENT (1u << 2) /* RCC_CR read 0 (its reset value has HSION|HSIRDY set):
                                          no RCC, an emulator; its fixed clock is assumed */
#define HIL_CLOCK_HSE_TIMEOUT (1u << 3)
#define HIL_CLOCK_PLL_TIMEOUT (1u << 4)

/** state */
#define HIL_TARGET_BOOTING 0u
#define HIL_TARGET_RUNNING 1u
#define HIL_TARGET_HARDFAULT 2u

typedef struct {
    uint32_t magic;
    uint32_t version;
    uint32_t state;
    uint32_t clock_hz;          /**< core clock the firmware runs on (believes it runs on) */
    uint32_t clock_flags;
    uint32_t usart_baud;        /**< baud rate asked for */
    uint32_t usart_brr;         /**< the divider written (USART1 on APB2 = clock_hz / 2) */
    uint32_t stack_size_bytes;  /**< main stack reserved by the linker script */
    uint32_t stack_used_bytes;  /**< high-water mark: painted words overwritten, from the top */
    uint32_t counter_kind;      /**< HIL_COUNTER_* */
    uint32_t isr_count;         /**< control ISRs run (SENSE frames that ran the controller) */
    uint32_t isr_ticks_min;
    uint32_t isr_ticks_max;
    uint32_t isr_ticks_sum_lo;  /**< sum of the ISR's ticks, 64 bits */
    uint32_t isr_ticks_sum_hi;
    uint32_t isr_ticks_last;
    uint32_t rx_bytes;
    uint32_t rx_ring_overflows; /**< octets lost because the receive ring was full */
    uint32_t usart_overruns;    /**< ORE: an octet arrived before the previous one was read */
    uint32_t tx_bytes;
    uint32_t tx_ring_overflows; /**< frames dropped because the transmit ring was full */
    uint32_t frames_ok;         /**< deframer counters (protocol/c/hil_framing.h) */
    uint32_t crc_errors;
    uint32_t cobs_errors;
    uint32_t length_errors;
    uint32_t deframer_overruns;
    uint32_t session_cycles;    /**< hil_session_stats_t.cycles */
    uint32_t unknown_ids;
    uint32_t heartbeats;
    uint32_t fault_cfsr;        /**< on a HardFault: the fault status and where it hit */
    uint32_t fault_hfsr;
    uint32_t fault_pc;
    uint32_t fault_lr;
    uint32_t fault_bfar;
    uint32_t fault_mmfar;
    uint32_t ram_used_bytes;    /**< .data + .bss + .hil_stats (the linker's figures) */
    /* the counter checked at boot on a loop of known length: calib_loops iterations of
     * "subs; bne" (2 instructions each) take calib_ticks - calib_empty_ticks */
    uint32_t calib_loops;
    uint32_t calib_ticks;
    uint32_t calib_empty_ticks; /**< two counter reads with nothing between them */
    uint32_t restarts;          /**< hil_session_t.restarts: CMD RESTART (docs/protocol.md 6.3) */
    /* the footprint, from the linker's symbols (stm32f405.ld); version 3 on */
    uint32_t flash_used_bytes;  /**< the image in flash: vectors, code, constants, .data's copy */
    uint32_t flash_size_bytes;  /**< the part's flash (LENGTH(FLASH)) */
    uint32_t ram_size_bytes;    /**< the part's SRAM (LENGTH(RAM)); the stack is its top
                                     stack_size_bytes */
} hil_target_stats_t;

#define HIL_TARGET_STATS_WORDS (sizeof(hil_target_stats_t) / 4u)

extern volatile hil_target_stats_t g_hil_target_stats;

#endif
