#include "usart.h"

#include "stm32f4_regs.h"

typedef char check_rx_pow2[(HIL_USART_RX_RING & (HIL_USART_RX_RING - 1u)) == 0u ? 1 : -1];
typedef char check_tx_pow2[(HIL_USART_TX_RING & (HIL_USART_TX_RING - 1u)) == 0u ? 1 : -1];

/* one octet per element, the type of protocol/c's hil_octet_t */
static volatile uint_least8_t g_rx[HIL_USART_RX_RING];
static volatile uint32_t g_rx_head, g_rx_tail; /* head: ISR writes; tail: main loop */
static volatile uint_least8_t g_tx[HIL_USART_TX_RING];
static volatile uint32_t g_tx_head, g_tx_tail; /* head: writers (PRIMASK held); tail: ISR */
static volatile hil_usart_stats_t g_stats;
static volatile int g_hold;
/* CR1 as last written: the driver is CR1's only writer, so its reads come from here (on QEMU every
 * register read of the USART is a trip through the emulator's device model) */
static volatile uint32_t g_cr1;

static void cr1_write(uint32_t cr1)
{
    g_cr1 = cr1;
    USART1_CR1 = cr1;
}

uint32_t hil_usart_init(uint32_t pclk2_hz, uint32_t baud)
{
    /* oversampling by 16: BRR = fck / baud, rounded (mantissa.fraction in 12.4) */
    const uint32_t brr = (pclk2_hz + baud / 2u) / baud;
    RCC_AHB1ENR |= RCC_AHB1ENR_GPIOAEN;
    RCC_APB2ENR |= RCC_APB2ENR_USART1EN;
    /* PA9, PA10: alternate function 7, high speed, pull-up on RX */
    GPIOA_MODER = (GPIOA_MODER & ~(0xFu << 18)) | (0xAu << 18);
    GPIOA_OSPEEDR |= (0xFu << 18);
    GPIOA_PUPDR = (GPIOA_PUPDR & ~(0xFu << 18)) | (0x4u << 18);
    GPIOA_AFRH = (GPIOA_AFRH & ~(0xFFu << 4)) | (0x77u << 4);
    cr1_write(0u);
    USART1_BRR = brr;
    USART1_CR2 = 0u; /* 1 stop bit */
    USART1_CR3 = 0u; /* no flow control */
    cr1_write(USART_CR1_UE | USART_CR1_TE | USART_CR1_RE | USART_CR1_RXNEIE);
    return brr;
}

int hil_usart_read(uint_least8_t *b)
{
    const uint32_t tail = g_rx_tail;
    if (tail == g_rx_head) {
        return 0;
    }
    *b = g_rx[tail & (HIL_USART_RX_RING - 1u)];
    g_rx_tail = tail + 1u;
    return 1;
}

int hil_usart_rx_empty(void)
{
    return g_rx_tail == g_rx_head;
}

/* Write while there is something to send and the data register is empty. On silicon that is one
 * octet (TXE clears until the shift register takes it) and the TXE interrupt sends the rest.
 * QEMU 7.2's model raises its interrupt for RXNE only (observed: CR1 = UE|TE|RE|RXNEIE|TXEIE with
 * SR = TXE|TC pends nothing) and keeps TXE set, so there the writer drains the ring itself,
 * synchronously. The ring is looked at before SR: no register read when there is nothing to send.
 * Called with PRIMASK held or from the USART interrupt. */
static void tx_pump(void)
{
    while (g_tx_tail != g_tx_head && (USART1_SR & USART_SR_TXE)) {
        USART1_DR = g_tx[g_tx_tail & (HIL_USART_TX_RING - 1u)];
        g_tx_tail = g_tx_tail + 1u;
        g_stats.tx_bytes++;
    }
}

/* Pump, then leave the TXE interrupt on only while octets are left for it. */
static void tx_start(void)
{
    tx_pump();
    if (g_tx_tail != g_tx_head) {
        if ((g_cr1 & USART_CR1_TXEIE) == 0u) {
            cr1_write(g_cr1 | USART_CR1_TXEIE); /* the TXE interrupt carries on with the rest */
        }
    } else if (g_cr1 & USART_CR1_TXEIE) {
        cr1_write(g_cr1 & ~USART_CR1_TXEIE);
    }
}

int hil_usart_write(const uint_least8_t *octets, size_t n)
{
    size_t i;
    const uint32_t m = hil_primask_save();
    uint32_t head = g_tx_head;
    if ((size_t)(HIL_USART_TX_RING - (head - g_tx_tail)) < n) {
        g_stats.tx_ring_overflows++;
        hil_primask_restore(m);
        return -1;
    }
    for (i = 0u; i < n; ++i) {
        g_tx[head & (HIL_USART_TX_RING - 1u)] = octets[i];
        head++;
    }
    g_tx_head = head;
    if (!g_hold) {
        tx_start();
    }
    hil_primask_restore(m);
    return 0;
}

void hil_usart_hold(int hold)
{
    const uint32_t m = hil_primask_save();
    g_hold = hold;
    if (!hold && g_tx_tail != g_tx_head) {
        tx_start();
    }
    hil_primask_restore(m);
}

const volatile hil_usart_stats_t *hil_usart_stats(void)
{
    return &g_stats;
}

void USART1_IRQHandler(void);
void USART1_IRQHandler(void)
{
    /* receive: every octet the data register holds, read SR then DR (which clears RXNE and ORE),
     * until SR says no more. On silicon at 3 Mbaud an octet takes 3.3 us, so this is mostly one;
     * QEMU hands over the octets its character device has buffered one after the other as DR is
     * read (`-chardev ...,mux=on`: bench/loop/links/qemu.py), and QEMU 7.2 lowers the interrupt
     * line after a DR read even when the next octet came with it, so a handler that read one
     * octet per entry would leave that one unread until the next interrupt. Every read of SR or
     * DR wakes QEMU's main loop (stm32f2xx_usart.c: qemu_chr_fe_accept_input): two per octet,
     * no more. */
    uint32_t sr = USART1_SR;
    while (sr & (USART_SR_RXNE | USART_SR_ORE)) {
        const uint32_t b = USART1_DR & 0xFFu;
        const uint32_t head = g_rx_head;
        if (sr & USART_SR_ORE) {
            g_stats.overruns++;
        }
        if (head - g_rx_tail < HIL_USART_RX_RING) {
            g_rx[head & (HIL_USART_RX_RING - 1u)] = (uint_least8_t)b;
            g_rx_head = head + 1u;
            g_stats.rx_bytes++;
        } else {
            g_stats.rx_ring_overflows++;
        }
        sr = USART1_SR;
    }
    /* transmit: what TXE lets through (no FIFO on the F4) */
    if (g_cr1 & USART_CR1_TXEIE) {
        tx_start();
    }
}
