/**
 * @file DSP2833x_Examples.h (host mock)
 * @brief The start-up functions of TI's DSP2833x common sources (C2000Ware
 * device_support/f2833x/common: DSP2833x_SysCtrl.c, _PieCtrl.c, _PieVect.c, _Adc.c, _CpuTimers.c,
 * _Sci.c, _ECan.c) that the port's main.c calls, as the host build sees them: each mock only counts
 * its calls (mock_regs.c), so that the test can check which ones the start-up made. On the target
 * TI's own DSP2833x_Examples.h is found first and TI's sources are linked.
 */
#ifndef DSP2833X_EXAMPLES_H
#define DSP2833X_EXAMPLES_H

#include "DSP2833x_Device.h"

void InitSysCtrl(void);
void InitPieCtrl(void);
void InitPieVectTable(void);
void InitAdc(void);
void InitCpuTimers(void);
void ConfigCpuTimer(struct CPUTIMER_VARS *timer, float freq_mhz, float period_us);
void InitSciaGpio(void);
void InitECanaGpio(void);

/** Calls of each mock, in the order above. */
typedef struct {
    int sys_ctrl, pie_ctrl, pie_vect, adc, cpu_timers, config_cpu_timer, scia_gpio, ecana_gpio;
} hil_mock_calls_t;
extern hil_mock_calls_t hil_mock_calls;

#endif
