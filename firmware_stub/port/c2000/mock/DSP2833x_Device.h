/**
 * @file DSP2833x_Device.h (host mock)
 * @brief A small stand-in for TI's DSP2833x header files (C2000Ware / controlSUITE
 * "DSP2833x_headers"), so that the C2000 port compiles and runs on the host for type checks and
 * tests. Only the registers and fields the port uses, with TI's names; each peripheral is a plain
 * struct the test reads and writes. On the target, TI's own DSP2833x_Device.h is found first on
 * the include path and this file is not used.
 *
 * The C28x has a 16-bit char: there is no 8-bit type on the part. The host build poisons
 * uint8_t and int8_t after this header, so a port that used one fails to compile here too.
 */
#ifndef DSP2833X_DEVICE_H
#define DSP2833X_DEVICE_H

#include <stdint.h>

typedef uint16_t Uint16;
typedef uint32_t Uint32;
typedef int16_t int16;
typedef int32_t int32;

#define EALLOW ((void)0)
#define EDIS ((void)0)

/* ---- ePWM (SPRUG04) ---------------------------------------------------------------------- */
struct TBCTL_BITS { Uint16 CTRMODE, PHSEN, PRDLD, SYNCOSEL, HSPCLKDIV, CLKDIV; };
struct CMPCTL_BITS { Uint16 LOADAMODE, LOADBMODE, SHDWAMODE, SHDWBMODE, SHDWAFULL, SHDWBFULL; };
struct AQCTL_BITS { Uint16 ZRO, PRD, CAU, CAD, CBU, CBD; };
struct ETSEL_BITS { Uint16 INTSEL, INTEN, SOCASEL, SOCAEN, SOCBSEL, SOCBEN; };
struct ETPS_BITS { Uint16 INTPRD, INTCNT, SOCAPRD, SOCACNT, SOCBPRD, SOCBCNT; };
struct CMPA_HALF { Uint16 CMPAHR, CMPA; };
struct AQCSFRC_BITS { Uint16 CSFA, CSFB; };
struct EPWM_REGS {
    union { Uint16 all; struct TBCTL_BITS bit; } TBCTL;
    Uint16 TBPRD;
    Uint16 TBCTR;
    union { Uint16 all; struct CMPCTL_BITS bit; } CMPCTL;
    union { Uint32 all; struct CMPA_HALF half; } CMPA;
    Uint16 CMPB;
    union { Uint16 all; struct AQCTL_BITS bit; } AQCTLA;
    union { Uint16 all; struct AQCSFRC_BITS bit; } AQCSFRC;
    union { Uint16 all; struct ETSEL_BITS bit; } ETSEL;
    union { Uint16 all; struct ETPS_BITS bit; } ETPS;
};
#define TB_COUNT_UPDOWN 2u
#define TB_FREEZE 3u
#define TB_SHADOW 0u
#define TB_IMMEDIATE 1u
#define CC_SHADOW 0u
#define CC_CTR_ZERO 0u
#define AQ_CLEAR 1u
#define AQ_SET 2u
#define ET_CTR_ZERO 1u
#define ET_1ST 1u

/* ---- ADC (SPRU812) ------------------------------------------------------------------------ */
struct ADCTRL2_BITS { Uint16 EPWM_SOCB_SEQ2, INT_MOD_SEQ2, INT_ENA_SEQ2, SOC_SEQ2, RST_SEQ2,
                      EXT_SOC_SEQ1, EPWM_SOCA_SEQ1, INT_MOD_SEQ1, INT_ENA_SEQ1, SOC_SEQ1,
                      RST_SEQ1, EPWM_SOCB_SEQ; };
struct ADCST_BITS { Uint16 INT_SEQ1, INT_SEQ2, SEQ1_BSY, SEQ2_BSY, INT_SEQ1_CLR, INT_SEQ2_CLR; };
struct ADC_REGS {
    union { Uint16 all; struct ADCTRL2_BITS bit; } ADCTRL2;
    union { Uint16 all; struct ADCST_BITS bit; } ADCST;
    union { Uint16 all; } ADCMAXCONV;
    union { Uint16 all; } ADCCHSELSEQ1;
    Uint16 ADCRESULT0, ADCRESULT1, ADCRESULT2;
};

/* ---- SCI (SPRUFZ5) ------------------------------------------------------------------------ */
struct SCIFFTX_BITS { Uint16 TXFFIL, TXFFIENA, TXFFINTCLR, TXFFINT, TXFFST, TXFIFOXRESET,
                      SCIFFENA, SCIRST; };
struct SCIFFRX_BITS { Uint16 RXFFIL, RXFFIENA, RXFFINTCLR, RXFFINT, RXFFST, RXFIFORESET,
                      RXFFOVRCLR, RXFFOVF; };
struct SCIRXBUF_BITS { Uint16 RXDT, SCIFFPE, SCIFFFE; };
struct SCI_REGS {
    union { Uint16 all; } SCICCR;
    union { Uint16 all; } SCICTL1;
    Uint16 SCIHBAUD;
    Uint16 SCILBAUD;
    union { Uint16 all; } SCICTL2;
    union { Uint16 all; } SCIRXST;
    union { Uint16 all; struct SCIRXBUF_BITS bit; } SCIRXBUF;
    Uint16 SCITXBUF;
    union { Uint16 all; struct SCIFFTX_BITS bit; } SCIFFTX;
    union { Uint16 all; struct SCIFFRX_BITS bit; } SCIFFRX;
};

/* ---- eCAN (SPRUEU1) ----------------------------------------------------------------------- */
#define HIL_MOCK_REG32(name) union { Uint32 all; } name
struct ECAN_REGS {
    HIL_MOCK_REG32(CANME);   /* mailbox enable */
    HIL_MOCK_REG32(CANMD);   /* direction: 1 receive */
    HIL_MOCK_REG32(CANTRS);  /* transmit request set */
    HIL_MOCK_REG32(CANTRR);
    HIL_MOCK_REG32(CANTA);   /* transmit acknowledge */
    HIL_MOCK_REG32(CANAA);
    HIL_MOCK_REG32(CANRMP);  /* receive message pending */
    HIL_MOCK_REG32(CANRML);  /* receive message lost */
    HIL_MOCK_REG32(CANRFP);
    HIL_MOCK_REG32(CANGAM);
    HIL_MOCK_REG32(CANMC);
    HIL_MOCK_REG32(CANBTC);
    HIL_MOCK_REG32(CANES);
    HIL_MOCK_REG32(CANOPC);  /* overwrite protection */
};
struct CANMSGID_BITS { Uint32 EXTMSGID_L, EXTMSGID_H, STDMSGID, AAM, AME, IDE; };
struct CANMSGCTRL_BITS { Uint16 DLC, RTR, TPL; };
struct MBOX {
    union { Uint32 all; struct CANMSGID_BITS bit; } MSGID;
    union { Uint32 all; struct CANMSGCTRL_BITS bit; } MSGCTRL;
    union { Uint32 all; } MDL;
    union { Uint32 all; } MDH;
};
/* as TI's: 32 named mailboxes, contiguous (the port indexes them from &MBOX0) */
struct ECAN_MBOXES { struct MBOX MBOX0, MBOX1, MBOX2, MBOX3, MBOX4, MBOX5, MBOX6, MBOX7, MBOX8, MBOX9, MBOX10, MBOX11, MBOX12, MBOX13, MBOX14, MBOX15, MBOX16, MBOX17, MBOX18, MBOX19, MBOX20, MBOX21, MBOX22, MBOX23, MBOX24, MBOX25, MBOX26, MBOX27, MBOX28, MBOX29, MBOX30, MBOX31; };

/* ---- PIE (SPRUFB0), CPU interrupts ----------------------------------------------------------- */
struct PIEIER_BITS { Uint16 INTx1, INTx2, INTx3, INTx4, INTx5, INTx6, INTx7, INTx8; };
struct PIE_CTRL_REGS {
    union { Uint16 all; } PIEACK;
    union { Uint16 all; struct PIEIER_BITS bit; } PIEIER1;
};
#define PIEACK_GROUP1 0x0001u
#define M_INT1 0x0001u
typedef void (*PINT)(void);
struct PIE_VECT_TABLE { PINT ADCINT; PINT TINT0; }; /* the two vectors the port sets */
/* the CPU's interrupt registers and its INTM / DBGM bits (cregister and asm on the C28x) */
extern volatile Uint16 IER, IFR;
extern int hil_mock_intm, hil_mock_dbgm;
#define EINT (hil_mock_intm = 0)
#define DINT (hil_mock_intm = 1)
#define ERTM (hil_mock_dbgm = 0)

/* ---- system control, CPU timer 0 (SPRUFB0) -------------------------------------------------- */
struct SYS_CTRL_REGS { union { Uint16 all; } LOSPCP; };
struct CPUTIMER_REGS { union { Uint32 all; } TIM; union { Uint32 all; } PRD; union { Uint16 all; } TCR; };
struct CPUTIMER_VARS { volatile struct CPUTIMER_REGS *RegsAddr; Uint32 InterruptCount;
                       float CPUFreqInMHz; float PeriodInUSec; };

extern volatile struct EPWM_REGS EPwm1Regs, EPwm2Regs, EPwm3Regs;
extern volatile struct ADC_REGS AdcRegs;
extern volatile struct SCI_REGS SciaRegs;
extern volatile struct ECAN_REGS ECanaRegs;
extern volatile struct ECAN_MBOXES ECanaMboxes;
extern volatile struct PIE_CTRL_REGS PieCtrlRegs;
extern struct PIE_VECT_TABLE PieVectTable;
extern volatile struct SYS_CTRL_REGS SysCtrlRegs;
extern volatile struct CPUTIMER_REGS CpuTimer0Regs;
extern struct CPUTIMER_VARS CpuTimer0;

/* what the eCAN does with a written 1: set (CANTRS) or clear (CANRMP, CANTA) that bit only */
#define HIL_C2000_W1S(reg, bits) ((reg).all |= (bits))
#define HIL_C2000_W1C(reg, bits) ((reg).all &= ~(Uint32)(bits))

#if defined(__GNUC__)
/* no 8-bit type exists on the C28x: any later use fails the host build */
#pragma GCC poison uint8_t int8_t
#endif

#endif
