/**
 * @file main.c
 * @brief Bare-metal Cortex-M4F port of the firmware stub (STM32F405; QEMU's netduinoplus2).
 *
 * The whole port is this file, startup.c, clock.c, usart.c and stm32f405.ld; everything else is
 * the portable core (firmware_stub/src, protocol/c), built unchanged.
 *
 *   USART1 RX interrupt ──► receive ring ──► main loop: COBS/CRC deframer ──► frame
 *       SENSE      ──► the control ISR (ADC_IRQHandler), pended by software: in lockstep the
 *                      SENSE frame is the ADC's end of conversion; on a drive the ADC's EOC
 *                      interrupt runs the same handler
 *       any other  ──► hil_session_on_frame() in the main loop (HELLO, CONFIG, CMD, SENSE_AUX ...)
 *   hil_port_t.send ──► COBS/CRC frame ──► transmit ring ──► USART1 TXE interrupt
 *   SysTick 1 kHz: HEARTBEAT_CTRL every 100 ms while no cycles flow (docs/protocol.md 6.7)
 *   CMD RESTART (the bench's controller_reset fault, docs/protocol.md 6.3): the portable code
 *       restarts as from power-up (hil_session_restart) and says so with a HEARTBEAT_CTRL; the
 *       port's own state (heartbeat timing, the link's error count) starts over with it, as
 *       port/linux/main.c does; the link, the rings and the target's own figures stay
 *
 * Priorities: USART1 (1) above SysTick (2) above the control ISR (3) above the main loop. No heap
 * (the link has no _sbrk), no OS, float32 on the FPU (-mfloat-abi=hard, lazy stacking).
 *
 * What the target measures about itself (the control ISR's cost in DWT cycles on silicon or
 * SysTick ticks under QEMU, the stack's high-water mark from the paint, link counters, the fault
 * that stopped it) is kept in g_hil_target_stats at 0x20000000 (target_stats.h).
 */
#include <stdint.h>

#include "clock.h"
#include "hil_framing.h"
#include "hil_session.h"
#include "stm32f4_regs.h"
#include "target_stats.h"
#include "usart.h"

#ifndef HIL_CM_BAUD
#define HIL_CM_BAUD 3000000u /* the bench's default serial rate (bench/loop/links) */
#endif
#define HEARTBEAT_PERIOD_MS 100u
#define PRIO_USART 1u
#define PRIO_SYSTICK 2u
#define PRIO_CONTROL 3u
#define PRIO_SHIFT 4u /* the STM32F4 implements the top 4 priority bits */
#define HIL_CALIB_LOOPS 10000u

extern uint32_t _sstack, _estack, _ebss, _sflash, _eflash, _flash_size, _ram_size;

__attribute__((section(".hil_stats"), used)) volatile hil_target_stats_t g_hil_target_stats;

static hil_session_t g_session;
static hil_deframer_t g_deframer;
static hil_frame_t g_sense;            /* the SENSE the control ISR runs on */
static volatile uint32_t g_isr_ran;    /* the control ISR ran since the main loop last looked */
static volatile uint32_t g_ms;         /* SysTick milliseconds */
static uint32_t g_systick_reload;
static uint32_t g_counter_kind;
static uint64_t g_isr_ticks_sum;
static uint32_t g_rx_errors_base;      /* link errors before the last restart */

void SysTick_Handler(void);
void ADC_IRQHandler(void);

void SysTick_Handler(void)
{
    g_ms = g_ms + 1u;
}

/* ---- the ISR's cost: DWT cycles where the core has them, else SysTick ticks --------------- */
static void counter_init(uint32_t sysclk_hz)
{
    uint32_t c0, i;
    g_systick_reload = sysclk_hz / 1000u - 1u;
    SYST_RVR = g_systick_reload;
    SYST_CVR = 0u;
    SYST_CSR = SYST_CSR_ENABLE | SYST_CSR_TICKINT | SYST_CSR_CLKSOURCE_CPU;
    DEMCR |= DEMCR_TRCENA;
    g_counter_kind = HIL_COUNTER_SYSTICK;
    if ((DWT_CTRL & DWT_CTRL_NOCYCCNT) == 0u) {
        DWT_CYCCNT = 0u;
        DWT_CTRL |= DWT_CTRL_CYCCNTENA;
        c0 = DWT_CYCCNT;
        for (i = 0u; i < 100u; ++i) {
            __asm__ volatile("nop");
        }
        if (DWT_CYCCNT != c0) {
            g_counter_kind = HIL_COUNTER_DWT_CYCCNT; /* silicon; QEMU reads the DWT as zero */
        }
    }
}

static uint32_t counter_now(void)
{
    uint32_t ms, v;
    if (g_counter_kind == HIL_COUNTER_DWT_CYCCNT) {
        return DWT_CYCCNT;
    }
    do { /* SysTick outranks the caller: a wrap between the reads shows in g_ms */
        ms = g_ms;
        v = SYST_CVR;
    } while (ms != g_ms);
    return ms * (g_systick_reload + 1u) + (g_systick_reload - v);
}

/** The counter on a loop of known length: the bench checks ticks -> instructions with it. */
static void counter_calibrate(void)
{
    uint32_t n = HIL_CALIB_LOOPS, t0, t1;
    t0 = counter_now();
    t1 = counter_now();
    g_hil_target_stats.calib_empty_ticks = t1 - t0;
    t0 = counter_now();
    __asm__ volatile("1: subs %0, %0, #1\n\tbne 1b" : "+r"(n)::"cc");
    t1 = counter_now();
    g_hil_target_stats.calib_ticks = t1 - t0;
    g_hil_target_stats.calib_loops = HIL_CALIB_LOOPS;
}

/* ---- the session's port ------------------------------------------------------------------- */
static void port_send(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    hil_octet_t wire[HIL_FRAME_MAX_WIRE];
    const size_t n = hil_frame_encode(wire, sizeof wire, id, data, dlc);
    (void)ctx;
    if (n > 0u) {
        (void)hil_usart_write(wire, n); /* a full ring counts the frame as dropped */
    }
}

/** The control ISR: what a drive's ADC end-of-conversion interrupt runs. */
void ADC_IRQHandler(void)
{
    const uint32_t cycles_before = g_session.stats.cycles;
    uint32_t t0, dt;
    hil_usart_hold(1); /* the answer is queued; it leaves once the cost is taken */
    t0 = counter_now();
    hil_session_on_frame(&g_session, &g_sense);
    dt = counter_now() - t0;
    hil_usart_hold(0);
    if (g_session.stats.cycles != cycles_before) { /* the controller ran (not a retry) */
        volatile hil_target_stats_t *st = &g_hil_target_stats;
        st->isr_count++;
        st->isr_ticks_last = dt;
        if (dt < st->isr_ticks_min) {
            st->isr_ticks_min = dt;
        }
        if (dt > st->isr_ticks_max) {
            st->isr_ticks_max = dt;
        }
        g_isr_ticks_sum += dt;
        g_isr_ran = 1u;
    }
}

static void on_frame(const hil_frame_t *f)
{
    if (f->id == HIL_SENSE_FRAME_ID) {
        g_sense = *f;
        NVIC_STIR = IRQ_ADC; /* taken before the next instruction: the frames keep their order */
        hil_dsb_isb();
    } else {
        hil_session_on_frame(&g_session, f);
    }
}

/* ---- what the target says about itself ---------------------------------------------------- */
static void stack_high_water(void)
{
    const uint32_t *w = &_sstack;
    const uint32_t *top = &_estack;
    while (w < top && *w == HIL_STACK_PAINT) {
        ++w;
    }
    g_hil_target_stats.stack_used_bytes = (uint32_t)((uintptr_t)top - (uintptr_t)w);
}

static uint32_t link_rx_errors_total(void)
{
    const volatile hil_usart_stats_t *u = hil_usart_stats();
    return g_deframer.crc_errors + g_deframer.cobs_errors + g_deframer.length_errors +
           g_deframer.overruns + u->overruns + u->rx_ring_overflows;
}

/** The frames the controller rejected since it (last) started: HEARTBEAT_CTRL's rx_errors. */
static uint32_t link_rx_errors(void)
{
    return link_rx_errors_total() - g_rx_errors_base;
}

static void publish_stats(void)
{
    volatile hil_target_stats_t *st = &g_hil_target_stats;
    const volatile hil_usart_stats_t *u = hil_usart_stats();
    uint32_t m = hil_primask_save();
    st->isr_ticks_sum_lo = (uint32_t)(g_isr_ticks_sum & 0xFFFFFFFFu);
    st->isr_ticks_sum_hi = (uint32_t)(g_isr_ticks_sum >> 32);
    hil_primask_restore(m);
    st->rx_bytes = u->rx_bytes;
    st->rx_ring_overflows = u->rx_ring_overflows;
    st->usart_overruns = u->overruns;
    st->tx_bytes = u->tx_bytes;
    st->tx_ring_overflows = u->tx_ring_overflows;
    st->frames_ok = g_deframer.frames_ok;
    st->crc_errors = g_deframer.crc_errors;
    st->cobs_errors = g_deframer.cobs_errors;
    st->length_errors = g_deframer.length_errors;
    st->deframer_overruns = g_deframer.overruns;
    st->session_cycles = g_session.stats.cycles;
    st->unknown_ids = g_session.stats.unknown_ids;
    st->restarts = g_session.restarts;
}

static void nvic_enable(uint32_t irq, uint32_t prio)
{
    NVIC_IPR_BYTE(irq) = (uint8_t)(prio << PRIO_SHIFT);
    NVIC_ISER(irq / 32u) = 1u << (irq % 32u);
}

int main(void)
{
    hil_clock_t clk;
    hil_port_t port;
    uint32_t last_hb_ms = 0u, last_cycles = 0u, last_restarts = 0u;
    volatile hil_target_stats_t *st = &g_hil_target_stats;

    st->magic = HIL_TARGET_STATS_MAGIC;
    st->version = HIL_TARGET_STATS_VERSION;
    st->state = HIL_TARGET_BOOTING;
    st->isr_ticks_min = 0xFFFFFFFFu;
    st->stack_size_bytes = (uint32_t)((uintptr_t)&_estack - (uintptr_t)&_sstack);
    st->ram_used_bytes = (uint32_t)((uintptr_t)&_ebss - (uintptr_t)&g_hil_target_stats);
    st->flash_used_bytes = (uint32_t)((uintptr_t)&_eflash - (uintptr_t)&_sflash);
    st->flash_size_bytes = (uint32_t)(uintptr_t)&_flash_size; /* linker constants: their address */
    st->ram_size_bytes = (uint32_t)(uintptr_t)&_ram_size;
    SCB_SHCSR |= SCB_SHCSR_FAULTS_EN;

    hil_clock_init(&clk);
    st->clock_hz = clk.sysclk_hz;
    st->clock_flags = clk.flags;
    SCB_SHPR3 = (SCB_SHPR3 & 0x00FFFFFFu) | ((PRIO_SYSTICK << PRIO_SHIFT) << 24);
    counter_init(clk.sysclk_hz);
    st->counter_kind = g_counter_kind;
    counter_calibrate();
    st->usart_baud = HIL_CM_BAUD;
    st->usart_brr = hil_usart_init(clk.pclk2_hz, HIL_CM_BAUD);

    port.ctx = 0;
    port.send = port_send;
    hil_session_init(&g_session, &port);
    hil_deframer_init(&g_deframer);
    nvic_enable(IRQ_ADC, PRIO_CONTROL);
    nvic_enable(IRQ_USART1, PRIO_USART);
    st->state = HIL_TARGET_RUNNING;
    stack_high_water();

    for (;;) {
        uint_least8_t b;
        hil_frame_t f;
        uint32_t now;
        while (hil_usart_read(&b)) {
            if (hil_deframer_push(&g_deframer, b, &f) == 1) {
                on_frame(&f);
            }
        }
        now = g_ms;
        if (g_session.restarts != last_restarts) {
            /* a power cycle of the portable code (CMD RESTART; it sent its HEARTBEAT_CTRL): the
             * port's own state starts over with it, the link stays (port/linux/main.c) */
            last_restarts = g_session.restarts;
            last_cycles = g_session.stats.cycles;
            last_hb_ms = now;
            g_rx_errors_base = link_rx_errors_total();
        }
        if (g_session.stats.cycles != last_cycles) {
            last_cycles = g_session.stats.cycles;
            last_hb_ms = now;
        } else if (now - last_hb_ms >= HEARTBEAT_PERIOD_MS) {
            hil_session_heartbeat(&g_session, link_rx_errors());
            last_hb_ms = now;
            st->heartbeats++;
        }
        if (g_isr_ran) {
            g_isr_ran = 0u;
            stack_high_water();
        }
        publish_stats();
        {
            /* sleep only if nothing came: checked with interrupts masked, so an octet that
             * arrives after the check still ends the WFI (a pending interrupt wakes the core
             * through PRIMASK) and is taken once PRIMASK is restored. Unmasked, an interrupt
             * taken between the check and the WFI would leave its octet in the ring until the
             * next interrupt: the next octet or SysTick, up to 1 ms later. */
            const uint32_t m = hil_primask_save();
            if (hil_usart_rx_empty()) {
                hil_wfi();
            }
            hil_primask_restore(m);
        }
    }
}
