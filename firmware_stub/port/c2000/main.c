/**
 * @file main.c
 * @brief The F28335 entry point, built only by TI's compiler (cl2000 defines __TMS320C2000__):
 * TI's DSP2833x_common code sets the PLL to 150 MHz, the PIE vector table and CPU timer 0.
 */
#ifdef __TMS320C2000__
#include "DSP2833x_Device.h"
#include "DSP2833x_Examples.h" /* InitSysCtrl, InitPieCtrl, InitCpuTimers, ConfigCpuTimer */

#include "c2000_port.h"

#define HIL_C2000_CONTROL_PERIOD_S 100e-6f /* the bench's HELLO period_us must match it */

__interrupt void cpu_timer0_isr(void)
{
    hil_c2000_tick_100ms();
    PieCtrlRegs.PIEACK.all = PIEACK_GROUP1;
}

void main(void)
{
    InitSysCtrl();           /* PLL: 30 MHz x 10 / 2 = 150 MHz; peripheral clocks on */
    EALLOW;
    SysCtrlRegs.LOSPCP.all = 0u; /* LSPCLK = SYSCLKOUT: SCI-A at 1 Mbaud (c2000_port.h) */
    EDIS;
    InitECanaGpio();
    InitSciaGpio();
    DINT;
    InitPieCtrl();
    IER = 0x0000u;
    IFR = 0x0000u;
    InitPieVectTable();
    EALLOW;
    PieVectTable.ADCINT = &hil_c2000_adc_isr;
    PieVectTable.TINT0 = &cpu_timer0_isr;
    EDIS;
    InitAdc();
    InitCpuTimers();
    ConfigCpuTimer(&CpuTimer0, 150.0f, 100000.0f); /* 100 ms */
    hil_c2000_init(HIL_C2000_LINK_CAN, HIL_C2000_CONTROL_PERIOD_S);
    PieCtrlRegs.PIEIER1.bit.INTx6 = 1u; /* ADCINT */
    PieCtrlRegs.PIEIER1.bit.INTx7 = 1u; /* TINT0 */
    IER |= M_INT1;
    CpuTimer0Regs.TCR.all = 0x4000u;
    EINT;
    ERTM;
    for (;;) {
        hil_c2000_poll();
    }
}
#endif
