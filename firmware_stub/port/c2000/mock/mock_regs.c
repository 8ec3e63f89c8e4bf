/* The register instances of the host mock (DSP2833x_Device.h); TI's headers place them with
 * DATA_SECTION pragmas and the linker command file. */
#include "DSP2833x_Device.h"

volatile struct EPWM_REGS EPwm1Regs, EPwm2Regs, EPwm3Regs;
volatile struct ADC_REGS AdcRegs;
volatile struct SCI_REGS SciaRegs;
volatile struct ECAN_REGS ECanaRegs;
volatile struct ECAN_MBOXES ECanaMboxes;
volatile struct PIE_CTRL_REGS PieCtrlRegs;
