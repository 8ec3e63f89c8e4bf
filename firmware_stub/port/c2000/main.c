/**
 * @file main.c
 * @brief The F28335's start-up and main loop. TI's DSP2833x common code sets the PLL to 150 MHz,
 * the PIE vector table and CPU timer 0; the link (SCI-A or eCAN-A) is chosen at build time
 * (HIL_C2000_LINK, c2000_port.h). main() exists for TI's compiler only (cl2000 defines
 * __TMS320C2000__); hil_c2000_start() is compiled and run on the host too, against the mock of
 * TI's headers (tests/c/test_c2000_port.c).
 */
#include "DSP2833x_Device.h"
#include "DSP2833x_Examples.h" /* InitSysCtrl, InitPieCtrl, InitCpuTimers, ConfigCpuTimer ... */

#include "c2000_port.h"

HIL_C2000_INTERRUPT void hil_c2000_timer0_isr(void)
{
    hil_c2000_tick_100ms();
    PieCtrlRegs.PIEACK.all = PIEACK_GROUP1;
}

void hil_c2000_start(void)
{
    InitSysCtrl();               /* PLL: 30 MHz x 10 / 2 = 150 MHz; peripheral clocks on */
    EALLOW;
    SysCtrlRegs.LOSPCP.all = 2u; /* LSPCLK = SYSCLKOUT / 4 = 37.5 MHz, the data sheet's nominal
                                  * (75 MHz at most): SCI-A at 937.5 kbaud (c2000_port.h) */
    EDIS;
#if HIL_C2000_LINK == HIL_C2000_LINK_CAN
    InitECanaGpio();             /* GPIO30 = CANRXA, GPIO31 = CANTXA (docs/ports.md) */
#else
    InitSciaGpio();              /* GPIO28 = SCIRXDA, GPIO29 = SCITXDA (docs/ports.md) */
#endif
    DINT;
    InitPieCtrl();
    IER = 0x0000u;
    IFR = 0x0000u;
    InitPieVectTable();
    EALLOW;
    PieVectTable.ADCINT = &hil_c2000_adc_isr;
    PieVectTable.TINT0 = &hil_c2000_timer0_isr;
    EDIS;
    InitAdc();
    InitCpuTimers();
    ConfigCpuTimer(&CpuTimer0, 150.0f, 100000.0f); /* 100 ms */
    hil_c2000_init(HIL_C2000_LINK); /* the ePWM waits, frozen, for HELLO's period */
    PieCtrlRegs.PIEIER1.bit.INTx6 = 1u; /* ADCINT */
    PieCtrlRegs.PIEIER1.bit.INTx7 = 1u; /* TINT0 */
    IER |= M_INT1;
    CpuTimer0Regs.TCR.all = 0x4000u; /* TIE set, TSS clear: the timer runs and interrupts */
    EINT;
    ERTM;
}

#ifdef __TMS320C2000__
void main(void)
{
    hil_c2000_start();
    for (;;) {
        hil_c2000_poll();
    }
}
#endif
