/* The register instances and start-up functions of the host mock (DSP2833x_Device.h,
 * DSP2833x_Examples.h); TI's headers place the registers with DATA_SECTION pragmas and the linker
 * command file, and TI's common sources implement the functions. */
#include "DSP2833x_Device.h"
#include "DSP2833x_Examples.h"

volatile struct EPWM_REGS EPwm1Regs, EPwm2Regs, EPwm3Regs;
volatile struct ADC_REGS AdcRegs;
volatile struct SCI_REGS SciaRegs;
volatile struct ECAN_REGS ECanaRegs;
volatile struct ECAN_MBOXES ECanaMboxes;
volatile struct PIE_CTRL_REGS PieCtrlRegs;
struct PIE_VECT_TABLE PieVectTable;
volatile struct SYS_CTRL_REGS SysCtrlRegs;
volatile struct CPUTIMER_REGS CpuTimer0Regs;
struct CPUTIMER_VARS CpuTimer0;
volatile Uint16 IER, IFR;
int hil_mock_intm = 1, hil_mock_dbgm = 1;
hil_mock_calls_t hil_mock_calls;

void InitSysCtrl(void) { hil_mock_calls.sys_ctrl++; }
void InitPieCtrl(void) { hil_mock_calls.pie_ctrl++; }
void InitPieVectTable(void) { hil_mock_calls.pie_vect++; }
void InitAdc(void) { hil_mock_calls.adc++; }
void InitCpuTimers(void)
{
    CpuTimer0.RegsAddr = &CpuTimer0Regs;
    hil_mock_calls.cpu_timers++;
}
void ConfigCpuTimer(struct CPUTIMER_VARS *timer, float freq_mhz, float period_us)
{
    timer->CPUFreqInMHz = freq_mhz;
    timer->PeriodInUSec = period_us;
    timer->RegsAddr->PRD.all = (Uint32)(freq_mhz * period_us);
    hil_mock_calls.config_cpu_timer++;
}
void InitSciaGpio(void) { hil_mock_calls.scia_gpio++; }
void InitECanaGpio(void) { hil_mock_calls.ecana_gpio++; }
