/**
 * @file c2000_port.c
 * @brief TMS320F28335 port skeleton: eCAN-A / SCI-A link, ePWM1-3 with shadowed compares at the
 * period HELLO gives, ADC SEQ1 started by ePWM1 SOCA; the control ISR runs on the ADC interrupt
 * with the latest SENSE. See c2000_port.h. Register and field names are TI's (DSP2833x headers).
 */
#include "c2000_port.h"

#include "hil_framing.h"

#define NUM_LEGS 3u
#define SCI_TX_RING 512u /* power of two */

/* The HIL message set on eCAN-A: what the plant sends is received, what the drive sends is
 * transmitted. The ids are the generated codec's (protocol/hil.dbc); tests/test_c2000_port.py
 * checks the directions against the DBC's senders. */
static const hil_c2000_mbox_t k_mboxes[] = {
    {HIL_FAULT_PLANT_FRAME_ID, 1u},     {HIL_HELLO_FRAME_ID, 1u},
    {HIL_CONFIG_FRAME_ID, 1u},          {HIL_CMD_FRAME_ID, 1u},
    {HIL_HEARTBEAT_PLANT_FRAME_ID, 1u}, {HIL_SENSE_FRAME_ID, 1u},
    {HIL_SENSE_AUX_FRAME_ID, 1u},       {HIL_SENSE_DUAL_FRAME_ID, 1u},
    {HIL_FAULT_CTRL_FRAME_ID, 0u},      {HIL_HELLO_ACK_FRAME_ID, 0u},
    {HIL_CONFIG_ACK_FRAME_ID, 0u},      {HIL_HEARTBEAT_CTRL_FRAME_ID, 0u},
    {HIL_DUTY_FRAME_ID, 0u},            {HIL_TELEM_FRAME_ID, 0u},
    {HIL_TELEM_EMF_FRAME_ID, 0u},
};
#define NUM_MBOXES ((uint16_t)(sizeof k_mboxes / sizeof k_mboxes[0]))
typedef char check_mboxes_fit[NUM_MBOXES <= 32u ? 1 : -1];

static const uint32_t k_std_bauds[] = {3000000UL, 2000000UL, 1500000UL, 1000000UL, 921600UL,
                                       500000UL, 460800UL, 230400UL, 115200UL};

static hil_session_t g_session;
static hil_c2000_link_t g_link;
static hil_c2000_stats_t g_stats;
static hil_deframer_t g_deframer;
static hil_frame_t g_sense;
static volatile int g_have_sense;
static Uint16 g_tbprd;
static uint32_t g_last_cycles;
static hil_octet_t g_sci_tx[SCI_TX_RING];
static uint32_t g_sci_head, g_sci_tail;

const hil_c2000_mbox_t *hil_c2000_mboxes(uint16_t *count)
{
    *count = NUM_MBOXES;
    return k_mboxes;
}

uint32_t hil_c2000_sci_pick(uint32_t lspclk_hz, uint32_t *brr)
{
    uint16_t i;
    for (i = 0u; i < sizeof k_std_bauds / sizeof k_std_bauds[0]; ++i) {
        const uint32_t baud = k_std_bauds[i];
        /* BRR = LSPCLK / (8 baud) - 1, rounded; the rate made is LSPCLK / ((BRR + 1) 8) */
        const uint32_t div = (lspclk_hz + 4u * baud) / (8u * baud);
        uint32_t made, err;
        if (div < 1u || div > 65536u) {
            continue;
        }
        made = lspclk_hz / (8u * div);
        err = made > baud ? made - baud : baud - made;
        if ((uint64_t)err * 1000000u <= (uint64_t)HIL_C2000_SCI_MAX_ERROR_PPM * baud) {
            *brr = div - 1u;
            return baud;
        }
    }
    *brr = 0u;
    return 0u;
}

Uint16 hil_c2000_cmpa(float duty, Uint16 tbprd)
{
    const float d = duty < 0.0f ? 0.0f : (duty > 1.0f ? 1.0f : duty);
    return (Uint16)(d * (float)tbprd + 0.5f);
}

#define CLKDIV_MAX 7u /* TBCTL.CLKDIV: /1 .. /128 */

int hil_c2000_epwm_timebase(float period_s, Uint16 *tbprd, Uint16 *clkdiv)
{
    Uint16 k;
    if (!(period_s > 0.0f)) {
        return -1;
    }
    for (k = 0u; k <= CLKDIV_MAX; ++k) {
        /* up-down: period = 2 TBPRD / TBCLK */
        const float counts = period_s * ((float)HIL_C2000_SYSCLK_HZ / (float)(1u << k)) * 0.5f + 0.5f;
        if (counts < 65536.0f) {
            if (counts < 2.0f) {
                return -1; /* below what the counter resolves */
            }
            *tbprd = (Uint16)counts;
            *clkdiv = k;
            return 0;
        }
    }
    return -1;
}

static volatile struct MBOX *mbox(uint16_t n)
{
    return &(&ECanaMboxes.MBOX0)[n];
}

/* ---- link: eCAN-A ------------------------------------------------------------------------- */
#define CANMC_DBO ((uint32_t)1u << 10)
#define CANMC_CCR ((uint32_t)1u << 12)
#define CANMC_SCB ((uint32_t)1u << 13)
#define CANES_CCE ((uint32_t)1u << 4)
#define CCE_WAIT_LOOPS 100000u

/* CANES.CCE follows CANMC.CCR once the module is bus-idle; bounded (the mock never sets it) */
static void wait_cce(int set)
{
    uint32_t n;
    for (n = 0u; n < CCE_WAIT_LOOPS; ++n) {
        if (((ECanaRegs.CANES.all & CANES_CCE) != 0u) == (set != 0)) {
            return;
        }
    }
    g_stats.can_config_timeouts++;
}

static void ecan_init(void)
{
    uint16_t n;
    uint32_t me = 0u, md = 0u;
    /* the eCAN's control registers take 32-bit accesses only: whole words, no bit fields */
    EALLOW;
    ECanaRegs.CANMC.all = ECanaRegs.CANMC.all | CANMC_CCR; /* configuration change request */
    wait_cce(1);
    /* 1 Mbit/s from SYSCLKOUT / 2 = 75 MHz: BRP 5 -> 15 TQ per bit, TSEG1 11, TSEG2 3 (80 %) */
    ECanaRegs.CANBTC.all = ((uint32_t)4u << 16) | ((uint32_t)1u << 8) | ((uint32_t)10u << 3) | 2u;
    /* eCAN mode (32 mailboxes), byte 0 in MDL bits 7..0, configuration done */
    ECanaRegs.CANMC.all = (ECanaRegs.CANMC.all | CANMC_SCB | CANMC_DBO) & ~CANMC_CCR;
    wait_cce(0);
    EDIS;
    ECanaRegs.CANME.all = 0u; /* MSGID is written only while a mailbox is disabled */
    for (n = 0u; n < NUM_MBOXES; ++n) {
        mbox(n)->MSGID.all = (uint32_t)k_mboxes[n].id << 18; /* standard id, IDE = 0 */
        mbox(n)->MSGCTRL.all = 8u;
        if (k_mboxes[n].receive) {
            md |= ((uint32_t)1u << n);
        }
        me |= ((uint32_t)1u << n);
    }
    ECanaRegs.CANMD.all = md;
    ECanaRegs.CANOPC.all = 0u; /* a newer frame overwrites: the latest SENSE counts */
    ECanaRegs.CANME.all = me;
}

static void ecan_send(uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    uint16_t n, i;
    uint32_t lo = 0u, hi = 0u;
    for (n = 0u; n < NUM_MBOXES; ++n) {
        if (!k_mboxes[n].receive && k_mboxes[n].id == id) {
            break;
        }
    }
    if (n == NUM_MBOXES || dlc > 8u) {
        return;
    }
    if (ECanaRegs.CANTRS.all & (((uint32_t)1u << n))) {
        g_stats.tx_busy++; /* the previous frame of this id is still on its way */
        return;
    }
    for (i = 0u; i < dlc; ++i) {
        const uint32_t octet = (uint32_t)(data[i] & 0xFFu);
        if (i < 4u) {
            lo |= octet << (8u * i);
        } else {
            hi |= octet << (8u * (i - 4u));
        }
    }
    mbox(n)->MSGCTRL.all = dlc;
    mbox(n)->MDL.all = lo;
    mbox(n)->MDH.all = hi;
    HIL_C2000_W1C(ECanaRegs.CANTA, ((uint32_t)1u << n));  /* an old acknowledge cleared */
    HIL_C2000_W1S(ECanaRegs.CANTRS, ((uint32_t)1u << n)); /* transmission requested */
}

static void set_period(float period_s);

static void dispatch(const hil_frame_t *f)
{
    if (f->id == HIL_SENSE_FRAME_ID) {
        g_sense = *f; /* the control ISR runs on it at the next ADC interrupt */
        g_have_sense = 1;
    } else {
        hil_session_on_frame(&g_session, f);
        if (f->id == HIL_HELLO_FRAME_ID && g_session.hello_done) {
            /* a session runs at the period it asked for: the session checked it against this
             * port's limits (PERIOD_UNSUPPORTED outside), its Ts is the period */
            set_period(g_session.ctrl.cfg.ts_s);
        }
    }
}

static void ecan_poll(void)
{
    const uint32_t pending = ECanaRegs.CANRMP.all;
    const uint32_t lost = ECanaRegs.CANRML.all;
    uint16_t n, i;
    for (n = 0u; n < NUM_MBOXES; ++n) {
        const uint32_t bit = ((uint32_t)1u << n);
        hil_frame_t f;
        uint32_t lo, hi;
        if (!k_mboxes[n].receive || !(pending & bit)) {
            continue;
        }
        if (lost & bit) {
            g_stats.rx_lost++;
        }
        f.id = k_mboxes[n].id;
        f.dlc = (uint16_t)(mbox(n)->MSGCTRL.all & 0xFu);
        lo = mbox(n)->MDL.all;
        hi = mbox(n)->MDH.all;
        HIL_C2000_W1C(ECanaRegs.CANRMP, bit); /* read: the mailbox may take the next frame */
        if (f.dlc > 8u) {
            continue;
        }
        for (i = 0u; i < f.dlc; ++i) {
            f.data[i] = (hil_octet_t)((i < 4u ? lo >> (8u * i) : hi >> (8u * (i - 4u))) & 0xFFu);
        }
        dispatch(&f);
    }
}

/* ---- link: SCI-A, COBS/CRC framing ------------------------------------------------------- */
static void sci_init(void)
{
    uint32_t brr;
    g_stats.sci_baud = hil_c2000_sci_pick(HIL_C2000_LSPCLK_HZ, &brr);
    g_stats.sci_brr = brr;
    SciaRegs.SCICCR.all = 0x0007u;  /* 1 stop bit, no parity, 8 data bits, idle-line mode */
    SciaRegs.SCICTL1.all = 0x0003u; /* TX and RX enabled, held in reset */
    SciaRegs.SCIHBAUD = (Uint16)((brr >> 8) & 0xFFu);
    SciaRegs.SCILBAUD = (Uint16)(brr & 0xFFu);
    SciaRegs.SCIFFTX.all = 0xE040u; /* FIFOs on */
    SciaRegs.SCIFFRX.all = 0x2044u;
    SciaRegs.SCICTL1.all = 0x0023u; /* out of reset */
}

static void sci_pump(void)
{
    while (g_sci_tail != g_sci_head && SciaRegs.SCIFFTX.bit.TXFFST < 16u) {
        SciaRegs.SCITXBUF = (Uint16)(g_sci_tx[g_sci_tail & (SCI_TX_RING - 1u)] & 0xFFu);
        g_sci_tail++;
    }
}

static void sci_send(uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    hil_octet_t wire[HIL_FRAME_MAX_WIRE];
    const size_t n = hil_frame_encode(wire, sizeof wire, id, data, dlc);
    size_t i;
    if (n == 0u) {
        return;
    }
    if ((size_t)(SCI_TX_RING - (g_sci_head - g_sci_tail)) < n) {
        g_stats.sci_tx_overflows++;
        return;
    }
    for (i = 0u; i < n; ++i) {
        g_sci_tx[g_sci_head & (SCI_TX_RING - 1u)] = wire[i];
        g_sci_head++;
    }
    sci_pump();
}

static void sci_poll(void)
{
    while (SciaRegs.SCIFFRX.bit.RXFFST > 0u) {
        hil_frame_t f;
        const hil_octet_t b = (hil_octet_t)(SciaRegs.SCIRXBUF.all & 0xFFu);
        if (hil_deframer_push(&g_deframer, b, &f) == 1) {
            dispatch(&f);
        }
    }
    sci_pump();
}

static void port_send(void *ctx, uint16_t id, const hil_octet_t *data, uint16_t dlc)
{
    (void)ctx;
    if (g_link == HIL_C2000_LINK_CAN) {
        ecan_send(id, data, dlc);
    } else {
        sci_send(id, data, dlc);
    }
}

/* ---- ePWM and ADC ------------------------------------------------------------------------- */
/* Frozen, outputs forced low: no period (and no control ISR) until a HELLO sets one. */
static void epwm_init(volatile struct EPWM_REGS *p, int master)
{
    p->TBCTL.bit.CTRMODE = TB_FREEZE;
    p->TBPRD = 0u;
    p->TBCTR = 0u;
    p->TBCTL.bit.PHSEN = (Uint16)(master ? 0u : 1u); /* ePWM2, 3 follow ePWM1's sync */
    p->TBCTL.bit.PRDLD = TB_SHADOW;
    p->TBCTL.bit.SYNCOSEL = (Uint16)(master ? 1u : 0u); /* master: sync out at CTR = 0 */
    p->TBCTL.bit.HSPCLKDIV = 0u;
    p->TBCTL.bit.CLKDIV = 0u;
    /* the compare is shadowed and loaded at CTR = 0: a duty written in the ISR of period k acts
     * from the start of period k + 1 (the bench's next_period model) */
    p->CMPCTL.bit.SHDWAMODE = CC_SHADOW;
    p->CMPCTL.bit.LOADAMODE = CC_CTR_ZERO;
    p->CMPA.half.CMPA = 0u;
    p->AQCTLA.bit.CAU = AQ_CLEAR; /* high while CTR < CMPA: duty = CMPA / TBPRD */
    p->AQCTLA.bit.CAD = AQ_SET;
    p->AQCSFRC.all = 0x5u;        /* both outputs forced low until a duty arrives */
}

/* The time base of one ePWM: at once while frozen (a frozen counter never reaches the zero that
 * loads the shadow), else through the shadow at the next counter zero (no shortened period). */
static void epwm_timebase(volatile struct EPWM_REGS *p, Uint16 tbprd, Uint16 clkdiv)
{
    if (p->TBCTL.bit.CTRMODE == TB_FREEZE) {
        p->TBCTL.bit.PRDLD = TB_IMMEDIATE;
        p->TBPRD = tbprd;
        p->TBCTL.bit.PRDLD = TB_SHADOW;
    } else {
        p->TBPRD = tbprd;
    }
    p->TBCTL.bit.CLKDIV = clkdiv;
}

static void set_period(float period_s)
{
    Uint16 tbprd, clkdiv;
    if (hil_c2000_epwm_timebase(period_s, &tbprd, &clkdiv) != 0) {
        return; /* not reached: the session accepts HIL_C2000_PERIOD_MIN_US..MAX_US only */
    }
    if (tbprd == g_tbprd && (uint32_t)clkdiv == g_stats.clkdiv && g_stats.period_ns != 0u) {
        return; /* the same period again (a new session at the same rate) */
    }
    epwm_timebase(&EPwm1Regs, tbprd, clkdiv);
    epwm_timebase(&EPwm2Regs, tbprd, clkdiv);
    epwm_timebase(&EPwm3Regs, tbprd, clkdiv);
    g_tbprd = tbprd;
    g_stats.tbprd = tbprd;
    g_stats.clkdiv = clkdiv;
    g_stats.period_ns = (uint32_t)(2.0f * (float)tbprd * (float)(1u << clkdiv) *
                                   (1.0e9f / (float)HIL_C2000_SYSCLK_HZ) + 0.5f);
    g_stats.period_changes++;
    /* the three counters start together (ePWM2, 3 synchronised to ePWM1 at its zero) */
    EPwm1Regs.TBCTL.bit.CTRMODE = TB_COUNT_UPDOWN;
    EPwm2Regs.TBCTL.bit.CTRMODE = TB_COUNT_UPDOWN;
    EPwm3Regs.TBCTL.bit.CTRMODE = TB_COUNT_UPDOWN;
}

static void set_duty(volatile struct EPWM_REGS *p, float duty)
{
    if (duty < 0.0f) {
        p->AQCSFRC.all = 0x5u; /* the leg OFF: both switches off */
    } else {
        p->CMPA.half.CMPA = hil_c2000_cmpa(duty, g_tbprd);
        p->AQCSFRC.all = 0u;
    }
}

void hil_c2000_init(hil_c2000_link_t link)
{
    hil_port_t port;
    g_link = link;
    g_tbprd = 0u;
    g_stats.period_ns = 0u;
    g_stats.tbprd = 0u;
    g_stats.clkdiv = 0u;
    epwm_init(&EPwm1Regs, 1);
    epwm_init(&EPwm2Regs, 0);
    epwm_init(&EPwm3Regs, 0);
    /* ePWM1 starts the ADC's sequence 1 at counter zero: the phase currents sampled at the
     * period's start, the control ISR at its end of conversion */
    EPwm1Regs.ETSEL.bit.SOCASEL = ET_CTR_ZERO;
    EPwm1Regs.ETPS.bit.SOCAPRD = ET_1ST;
    EPwm1Regs.ETSEL.bit.SOCAEN = 1u;
    AdcRegs.ADCMAXCONV.all = 2u;          /* three conversions: i_a, i_b, i_c */
    AdcRegs.ADCCHSELSEQ1.all = 0x0210u;
    AdcRegs.ADCTRL2.bit.EPWM_SOCA_SEQ1 = 1u;
    AdcRegs.ADCTRL2.bit.INT_ENA_SEQ1 = 1u;
    AdcRegs.ADCTRL2.bit.INT_MOD_SEQ1 = 0u;
    if (link == HIL_C2000_LINK_CAN) {
        ecan_init();
    } else {
        sci_init();
    }
    hil_deframer_init(&g_deframer);
    port.ctx = 0;
    port.send = port_send;
    hil_session_init(&g_session, &port);
    /* what the ePWM and the ISR make (never below the session's own floor, which the ePWM makes) */
    g_session.period_min_us = HIL_C2000_PERIOD_MIN_US > HIL_SESSION_PERIOD_MIN_US ?
                                  HIL_C2000_PERIOD_MIN_US : HIL_SESSION_PERIOD_MIN_US;
    g_session.period_max_us = HIL_C2000_PERIOD_MAX_US;
}

void hil_c2000_poll(void)
{
    if (g_link == HIL_C2000_LINK_CAN) {
        ecan_poll();
    } else {
        sci_poll();
    }
}

HIL_C2000_INTERRUPT void hil_c2000_adc_isr(void)
{
    /* In HIL the currents come in SENSE (the ADC results are the drive's own, unused here) */
    g_stats.isr_runs++;
    if (g_have_sense) {
        g_have_sense = 0;
        hil_session_on_frame(&g_session, &g_sense);
        set_duty(&EPwm1Regs, g_session.ctrl.out.duty_abc[0]);
        set_duty(&EPwm2Regs, g_session.ctrl.out.duty_abc[1]);
        set_duty(&EPwm3Regs, g_session.ctrl.out.duty_abc[2]);
    } else {
        g_stats.isr_stale++; /* no SENSE since the last period: the duties hold */
    }
    AdcRegs.ADCTRL2.bit.RST_SEQ1 = 1u;
    AdcRegs.ADCST.bit.INT_SEQ1_CLR = 1u;
    PieCtrlRegs.PIEACK.all = PIEACK_GROUP1;
}

void hil_c2000_tick_100ms(void)
{
    if (g_session.stats.cycles == g_last_cycles) {
        hil_session_heartbeat(&g_session, g_deframer.crc_errors + g_deframer.cobs_errors +
                                              g_deframer.length_errors + g_deframer.overruns);
    }
    g_last_cycles = g_session.stats.cycles;
}

hil_session_t *hil_c2000_session(void)
{
    return &g_session;
}

const hil_c2000_stats_t *hil_c2000_stats(void)
{
    return &g_stats;
}
