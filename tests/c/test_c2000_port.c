/**
 * Host test of the C2000 (TMS320F28335) port skeleton against the mock of TI's headers
 * (firmware_stub/port/c2000/mock): main.c's start-up for the link this build chose
 * (HIL_C2000_LINK: built once with SCI-A, once with eCAN-A), SCI-A baud choice, compare values, the
 * ePWM time base from HELLO's period (frozen before, refused outside the port's limits), the ADC
 * set-up (shadow load at zero, SOCA at zero starting SEQ1), the eCAN mailboxes, and a session over
 * them: HELLO -> HELLO_ACK, a control ISR with no SENSE (stale), SENSE latched and answered at the
 * next ADC interrupt with TELEM and DUTY of its seq, a busy transmit mailbox counted.
 *
 *   test_c2000_port           run the checks (exit 1 on a failure)
 *   test_c2000_port --table   print the mailbox table (tests/test_c2000_port.py checks it
 *                             against the DBC's senders)
 *   test_c2000_port --link    print the link this build chose (SCI or CAN)
 */
#include <stdio.h>
#include <string.h>

#include "DSP2833x_Examples.h" /* the mock: which start-up functions ran */
#include "c2000_port.h"
#include "hil_msgs.h"

static int failures;
#define CHECK(cond, what)                                                                  \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            failures++;                                                                    \
            fprintf(stderr, "FAIL %s:%d: %s\n", __FILE__, __LINE__, what);                 \
        }                                                                                  \
    } while (0)

static int mailbox_of(uint16_t id, uint16_t receive)
{
    uint16_t n, count;
    const hil_c2000_mbox_t *t = hil_c2000_mboxes(&count);
    for (n = 0u; n < count; ++n) {
        if (t[n].id == id && t[n].receive == receive) {
            return (int)n;
        }
    }
    return -1;
}

/* the plant's frame arrives in its receive mailbox */
static void put_frame(uint16_t id, const hil_octet_t *d, uint16_t dlc)
{
    const int n = mailbox_of(id, 1u);
    volatile struct MBOX *m = &(&ECanaMboxes.MBOX0)[n];
    uint32_t lo = 0u, hi = 0u;
    uint16_t i;
    for (i = 0u; i < dlc; ++i) {
        if (i < 4u) {
            lo |= (uint32_t)d[i] << (8u * i);
        } else {
            hi |= (uint32_t)d[i] << (8u * (i - 4u));
        }
    }
    m->MSGCTRL.all = dlc;
    m->MDL.all = lo;
    m->MDH.all = hi;
    ECanaRegs.CANRMP.all |= ((uint32_t)1u << n);
}

/* the drive's frame, if its mailbox asked to transmit; the bus then sends it */
static int take_frame(uint16_t id, hil_octet_t *d)
{
    const int n = mailbox_of(id, 0u);
    volatile struct MBOX *m = &(&ECanaMboxes.MBOX0)[n];
    uint16_t i, dlc;
    if (n < 0 || !(ECanaRegs.CANTRS.all & (((uint32_t)1u << n)))) {
        return -1;
    }
    dlc = (uint16_t)(m->MSGCTRL.all & 0xFu);
    for (i = 0u; i < dlc; ++i) {
        const uint32_t w = i < 4u ? m->MDL.all : m->MDH.all;
        d[i] = (hil_octet_t)((w >> (8u * (i % 4u))) & 0xFFu);
    }
    ECanaRegs.CANTRS.all &= ~(((uint32_t)1u << n));
    ECanaRegs.CANTA.all |= ((uint32_t)1u << n);
    return dlc;
}

static uint16_t hello(float period_us, uint16_t session)
{
    hil_hello_t h;
    hil_hello_ack_t a;
    hil_octet_t buf[8], out[8];
    memset(&h, 0, sizeof h);
    h.proto_version = HIL_PROTO_VERSION;
    h.proto_minor = HIL_PROTO_VERSION_MINOR;
    h.mode = HIL_MODE_LOCKSTEP;
    h.period_us = hil_hello_period_us_encode(period_us);
    h.estimator = HIL_EST_SMO_SIGN;
    h.session = session;
    CHECK(hil_hello_pack(buf, &h, sizeof buf) > 0, "HELLO packs");
    put_frame(HIL_HELLO_FRAME_ID, buf, HIL_HELLO_LENGTH);
    hil_c2000_poll();
    CHECK(ECanaRegs.CANRMP.all == 0u, "the receive mailbox acknowledged");
    if (take_frame(HIL_HELLO_ACK_FRAME_ID, out) != (int)HIL_HELLO_ACK_LENGTH ||
        hil_hello_ack_unpack(&a, out, HIL_HELLO_ACK_LENGTH) != 0 || a.session != session) {
        return 0xFFFFu;
    }
    return a.status;
}

static void send_sense(uint16_t seq)
{
    hil_sense_t s;
    hil_octet_t buf[8];
    memset(&s, 0, sizeof s);
    s.seq = seq;
    CHECK(hil_sense_pack(buf, &s, sizeof buf) > 0, "SENSE packs");
    put_frame(HIL_SENSE_FRAME_ID, buf, HIL_SENSE_LENGTH);
}

int main(int argc, char **argv)
{
    uint32_t brr = 0u;
    uint16_t n, count;
    const hil_c2000_mbox_t *table = hil_c2000_mboxes(&count);
    hil_octet_t out[8];

    if (argc > 1 && strcmp(argv[1], "--link") == 0) {
        printf("%s\n", HIL_C2000_LINK == HIL_C2000_LINK_CAN ? "CAN" : "SCI");
        return 0;
    }
    if (argc > 1 && strcmp(argv[1], "--table") == 0) {
        for (n = 0u; n < count; ++n) {
            printf("%u 0x%03X %s\n", (unsigned)n, (unsigned)table[n].id,
                   table[n].receive ? "receive" : "transmit");
        }
        return 0;
    }

    /* SCI-A: 1 Mbaud is the highest standard rate within 2 % at LSPCLK = 150 MHz (BRR 18: 986.8
     * kbaud, -1.3 %); at the reset LSPCLK of 37.5 MHz it is 921 600 (BRR 4: 937.5 kbaud, +1.7 %) */
    CHECK(hil_c2000_sci_pick(150000000UL, &brr) == 1000000UL && brr == 18u, "SCI at 150 MHz");
    CHECK(hil_c2000_sci_pick(37500000UL, &brr) == 921600UL && brr == 4u, "SCI at 37.5 MHz");
    CHECK(hil_c2000_cmpa(0.5f, 7500u) == 3750u, "CMPA of 0.5");
    CHECK(hil_c2000_cmpa(-0.1f, 7500u) == 0u && hil_c2000_cmpa(1.5f, 7500u) == 7500u, "clamped");

    {   /* main.c's start-up: the pins of the link this build chose, vectors, timer, interrupts */
        hil_c2000_start();
        CHECK(hil_mock_calls.sys_ctrl == 1 && hil_mock_calls.pie_ctrl == 1 &&
                  hil_mock_calls.pie_vect == 1 && hil_mock_calls.adc == 1, "TI's start-up ran");
        CHECK(SysCtrlRegs.LOSPCP.all == 2u, "LSPCLK = SYSCLKOUT / 4 = 37.5 MHz (the data sheet's nominal)");
#if HIL_C2000_LINK == HIL_C2000_LINK_CAN
        CHECK(hil_mock_calls.ecana_gpio == 1 && hil_mock_calls.scia_gpio == 0, "eCAN-A pins only");
        CHECK((ECanaRegs.CANMC.all & 0x3400u) == 0x2400u, "eCAN-A set up");
#else
        CHECK(hil_mock_calls.scia_gpio == 1 && hil_mock_calls.ecana_gpio == 0, "SCI-A pins only");
        CHECK(SciaRegs.SCILBAUD == 4u && SciaRegs.SCIHBAUD == 0u && SciaRegs.SCICTL1.all == 0x0023u,
              "SCI-A set up at 937.5 kbaud (BRR 4)");
#endif
        CHECK(PieVectTable.ADCINT == &hil_c2000_adc_isr && PieVectTable.TINT0 == &hil_c2000_timer0_isr,
              "ADCINT and TINT0 vectors");
        CHECK(PieCtrlRegs.PIEIER1.bit.INTx6 == 1u && PieCtrlRegs.PIEIER1.bit.INTx7 == 1u &&
                  (IER & M_INT1) != 0u && hil_mock_intm == 0, "PIE 1.6, 1.7 and INT1 enabled");
        CHECK(CpuTimer0Regs.PRD.all == 15000000u, "CPU timer 0 at 100 ms");
        CHECK(EPwm1Regs.TBCTL.bit.CTRMODE == TB_FREEZE && EPwm1Regs.AQCSFRC.all == 0x5u &&
                  hil_c2000_stats()->period_ns == 0u, "no period, outputs low, before a HELLO");
    }

    /* the ePWM time base of a period: the smallest clock divider that fits TBPRD in 16 bits */
    {
        Uint16 tbprd = 0u, clkdiv = 0u;
        CHECK(hil_c2000_epwm_timebase(100e-6f, &tbprd, &clkdiv) == 0 && tbprd == 7500u && clkdiv == 0u,
              "10 kHz: TBPRD 7500 at 150 MHz");
        CHECK(hil_c2000_epwm_timebase(600e-6f, &tbprd, &clkdiv) == 0 && tbprd == 45000u && clkdiv == 0u,
              "1.67 kHz (the CAN scenarios): TBPRD 45000");
        CHECK(hil_c2000_epwm_timebase(1000e-6f, &tbprd, &clkdiv) == 0 && tbprd == 37500u && clkdiv == 1u,
              "1 kHz: /2, TBPRD 37500");
        CHECK(hil_c2000_epwm_timebase(6553.5e-6f, &tbprd, &clkdiv) == 0 && tbprd == 61439u && clkdiv == 3u,
              "the wire's largest period: /8");
        CHECK(hil_c2000_epwm_timebase(0.0f, &tbprd, &clkdiv) != 0, "no period");
    }

    hil_c2000_init(HIL_C2000_LINK_SCI);
    CHECK(hil_c2000_stats()->sci_baud == 921600UL && SciaRegs.SCILBAUD == 4u &&
              SciaRegs.SCIHBAUD == 0u, "SCI-A BRR written: 4 at LSPCLK 37.5 MHz (937.5 kbaud)");

    hil_c2000_init(HIL_C2000_LINK_CAN);
    CHECK(EPwm1Regs.TBCTL.bit.CTRMODE == TB_FREEZE, "frozen until a HELLO");
    CHECK(EPwm1Regs.CMPCTL.bit.SHDWAMODE == CC_SHADOW && EPwm1Regs.CMPCTL.bit.LOADAMODE == CC_CTR_ZERO,
          "compare shadowed, loaded at zero (next_period)");
    CHECK(EPwm1Regs.ETSEL.bit.SOCAEN == 1u && EPwm1Regs.ETSEL.bit.SOCASEL == ET_CTR_ZERO,
          "SOCA at counter zero");
    CHECK(AdcRegs.ADCTRL2.bit.EPWM_SOCA_SEQ1 == 1u && AdcRegs.ADCTRL2.bit.INT_ENA_SEQ1 == 1u,
          "SEQ1 started by SOCA, interrupting");
    for (n = 0u; n < count; ++n) {
        CHECK(((ECanaRegs.CANMD.all >> n) & 1u) == table[n].receive, "mailbox direction");
        CHECK((&ECanaMboxes.MBOX0)[n].MSGID.all == (uint32_t)table[n].id << 18, "mailbox id");
    }
    CHECK(ECanaRegs.CANME.all == ((uint32_t)1u << count) - 1u, "mailboxes enabled");
    CHECK((ECanaRegs.CANMC.all & 0x3400u) == 0x2400u, "eCAN mode, little-endian bytes, CCR released");
    CHECK(hil_c2000_stats()->can_config_timeouts >= 1u, "the mock never sets CCE: the wait is bounded");

    /* the handshake sets the period: refused outside the port's limits, the ePWM left frozen */
    CHECK(hello(50.0f, 0x1111u) == HIL_HELLO_STATUS_PERIOD_UNSUPPORTED, "50 us: below the port's minimum");
    CHECK(EPwm1Regs.TBCTL.bit.CTRMODE == TB_FREEZE && hil_c2000_stats()->period_ns == 0u,
          "a refused HELLO leaves the ePWM frozen");
    CHECK(hello(1000.0f, 0x2222u) == HIL_HELLO_STATUS_OK, "1 ms accepted");
    CHECK(EPwm1Regs.TBPRD == 37500u && EPwm2Regs.TBPRD == 37500u && EPwm3Regs.TBPRD == 37500u &&
              EPwm1Regs.TBCTL.bit.CLKDIV == 1u && EPwm1Regs.TBCTL.bit.CTRMODE == TB_COUNT_UPDOWN &&
              EPwm3Regs.TBCTL.bit.CTRMODE == TB_COUNT_UPDOWN && EPwm1Regs.TBCTL.bit.PRDLD == TB_SHADOW,
          "1 ms: TBPRD 37500 at /2 on the three legs, counting, later changes through the shadow");
    CHECK(hil_c2000_stats()->period_ns == 1000000u, "the period made: 1 ms");
    CHECK(hil_c2000_session()->ctrl.cfg.ts_s > 0.99e-3f && hil_c2000_session()->ctrl.cfg.ts_s < 1.01e-3f,
          "the controller's Ts is HELLO's period");
    CHECK(hello(100.0f, 0x1234u) == HIL_HELLO_STATUS_OK, "a new session at 10 kHz");
    CHECK(EPwm1Regs.TBPRD == 7500u && EPwm1Regs.TBCTL.bit.CLKDIV == 0u &&
              hil_c2000_stats()->period_ns == 100000u && hil_c2000_stats()->period_changes == 2u,
          "reprogrammed: TBPRD 7500, /1, 100 us");
    CHECK(hello(20.0f, 0x3333u) == HIL_HELLO_STATUS_PERIOD_UNSUPPORTED, "20 us refused");
    CHECK(EPwm1Regs.TBPRD == 7500u && hil_c2000_stats()->period_changes == 2u &&
              hil_c2000_session()->session_id == 0x1234u,
          "a refused HELLO keeps the running session and its period");

    hil_c2000_adc_isr();
    CHECK(hil_c2000_stats()->isr_stale == 1u, "an ADC interrupt with no SENSE holds the duties");

    {   /* one control cycle: SENSE latched by the main loop, run by the next ADC interrupt */
        hil_telem_t t;
        hil_duty_t d;
        send_sense(0u);
        hil_c2000_poll();
        CHECK(take_frame(HIL_TELEM_FRAME_ID, out) < 0, "no answer before the control ISR");
        hil_c2000_adc_isr();
        CHECK(take_frame(HIL_TELEM_FRAME_ID, out) == (int)HIL_TELEM_LENGTH &&
                  hil_telem_unpack(&t, out, HIL_TELEM_LENGTH) == 0 && t.seq == 0u, "TELEM(0)");
        CHECK(take_frame(HIL_DUTY_FRAME_ID, out) == (int)HIL_DUTY_LENGTH &&
                  hil_duty_unpack(&d, out, HIL_DUTY_LENGTH) == 0 && d.seq == 0u, "DUTY(0)");
        CHECK(d.d_a == HIL_DUTY_RAW_OFF && EPwm1Regs.AQCSFRC.all == 0x5u,
              "an idle controller's legs OFF: both outputs forced low");
        CHECK(hil_c2000_session()->stats.cycles == 1u, "one cycle ran");
    }

    {   /* TELEM(1) and DUTY(1) left on the bus: the answers to SENSE 2 find their mailboxes busy */
        send_sense(1u);
        hil_c2000_poll();
        hil_c2000_adc_isr();
        send_sense(2u);
        hil_c2000_poll();
        hil_c2000_adc_isr();
        CHECK(hil_c2000_stats()->tx_busy >= 2u, "frames to a still-busy mailbox counted, dropped");
    }

    if (failures) {
        fprintf(stderr, "%d check(s) failed\n", failures);
        return 1;
    }
    printf("c2000 port: all checks passed\n");
    return 0;
}
