/**
 * @file harm_comp.h
 * @brief Inverter-nonlinearity compensation (Yuan et al. 2020, eq. 28-37): extraction of the 5th
 * and 7th current harmonics by GSDFT (or SDFT) and the compensation voltages of eq. 36-37.
 *
 * Harmonic model (eq. 28), in dq (theta_e = the d-axis electrical angle):
 *   i_dq = i_dq1 + I5 e^{j(-6 theta_e + theta5)} + I7 e^{j(6 theta_e + theta7)}
 * i.e. in alpha-beta (complex, i_ab = e^{j theta_e} i_dq) the 5th is I5 e^{j(-5 theta_e + theta5)}
 * (negative sequence) and the 7th I7 e^{j(7 theta_e + theta7)}. Harmonic frames (eq. 32-33):
 *   x_dq5 = x_dq e^{+j 6 theta_e},  x_dq7 = x_dq e^{-j 6 theta_e}
 * where the 5th and 7th are the constants i_dq5 = I5 e^{j theta5}, i_dq7 = I7 e^{j theta7}.
 *
 * Angle-synchronous sampling. The 6h +- 1 harmonics are harmonics of the ELECTRICAL frequency
 * (0.67 Hz at 10 rpm on a p = 4 motor: 15000 control periods per electrical period), so the DFT
 * does not run at the control rate: the alpha-beta current is resampled at M equally spaced
 * electrical angles theta_j = 2 pi j / M, by linear interpolation between the two control samples
 * whose angles bracket theta_j (in angle, i.e. in time at constant speed). One DFT sample per grid
 * crossing; most control periods only test for a crossing. The sample sequence then has exactly M
 * samples per electrical period at any speed, the 5th is bin -5 and the 7th bin +7 of the complex
 * input, and i_dq5 = P_{-5} e^{+j5 theta_j}, i_dq7 = P_{+7} e^{-j7 theta_j} (the phasors of the
 * newest sample j rotated into the harmonic frames).
 *   Works for omega_min <= omega_e <= omega_max (electrical, forward rotation). Below omega_min (or
 *   on reversal) the extraction stops and restarts (empty window) when the speed returns; the window
 *   lasts one electrical period (SDFT) or a third of one (GSDFT), so at 10 rpm the GSDFT needs
 *   0.5 s and the SDFT 1.5 s to fill. omega_max: at most two grid crossings per control period and a
 *   linear-interpolation error below ~1 % on the 7th: (7 omega_e Ts)^2 / 8 < 0.01.
 *   Aliasing: point samples at M per period fold harmonic h onto h mod M; the 5th bin also reads
 *   harmonic M - 5 (M = 96: the 91st), the 7th reads -(M - 7) (the -89th). Hence the default M = 96.
 *
 * Extraction: est_gsdft (default) on the complex alpha-beta samples with bins -5 and +7 and the
 * DC block (sensor offsets), or est_sdft (bins -5, +7) for the comparison; both normalised so the
 * steady-state phasors are equal (claim Y7).
 *
 * Compensation (eq. 31, 34-37, L_s = L_d = L_q). Sign convention: the inverter's voltage error
 * produces the harmonic current through the machine impedance Z_h: for the 5th (dq frequency
 * -6 w_e) Z_5 = R - j 5 w_e L_s, for the 7th (+6 w_e) Z_7 = R + j 7 w_e L_s. Eq. 31 defines the
 * "voltage deviation to be compensated" as du = u* - u = -Z_h i_h; its DC part in the harmonic
 * frame is eq. 36-37:
 *   u5_dq5 = -(R - j5 w_e L_s) I5 e^{j theta5}:  d = -R I5 cos th5 - 5 w_e L_s I5 sin th5,
 *                                                q = -R I5 sin th5 + 5 w_e L_s I5 cos th5   (36)
 *   u7_dq7 = -(R + j7 w_e L_s) I7 e^{j theta7}:  d = -R I7 cos th7 + 7 w_e L_s I7 sin th7,
 *                                                q = -R I7 sin th7 - 7 w_e L_s I7 cos th7   (37)
 * and it is ADDED to the current-loop output: u_dq += u5_dq5 e^{-j6 theta_e} + u7_dq7 e^{+j6 theta_e}
 * (harm_comp_voltage_dq at the angle the voltage will act at). Note: fed back from the measured
 * current this is a loop of gain 1 at the harmonic (without a current loop): it halves the
 * harmonic rather than cancelling it (i = i_err - i  =>  i = i_err / 2). k_comp scales it.
 */
#ifndef HARM_COMP_H
#define HARM_COMP_H

#include "est_gsdft.h"
#include "est_sdft.h"
#include "fw_math.h"

typedef enum { HARM_EXTRACT_GSDFT = 0, HARM_EXTRACT_SDFT = 1 } harm_extractor_t;

typedef struct {
    float rs_ohm;          /**< eq. 36-37 */
    float ls_h;            /**< L_s = L_d = L_q */
    float ts_s;            /**< control period (sets the default omega_max) */
    int m;                 /**< angle-synchronous samples per electrical period (multiple of 6) */
    int extractor;         /**< harm_extractor_t */
    int dc_block;          /**< GSDFT: first difference ahead of the comb (sensor offsets) */
    float omega_min_rad_s; /**< electrical; slower (or reverse): no extraction, no compensation */
    float omega_max_rad_s; /**< electrical; faster: no extraction, no compensation */
    float k_comp;          /**< gain on eq. 36-37: 1 = the paper, 0 = extraction only */
} harm_comp_config_t;

typedef struct {
    int valid;           /**< a full window of grid samples since the last (re)start */
    long n_samples;      /**< grid samples taken since reset */
    float i5_a;          /**< I5 (eq. 28) */
    float theta5_rad;    /**< theta5 (eq. 28), [-pi, pi] */
    float i7_a;          /**< I7 */
    float theta7_rad;    /**< theta7 */
    fw_vec2_t i_dq5_a;   /**< I5 (cos th5, sin th5): the 5th in its frame (eq. 32) */
    fw_vec2_t i_dq7_a;   /**< I7 (cos th7, sin th7) (eq. 33) */
    fw_vec2_t u5_dq5_v;  /**< eq. 36 (times k_comp; 0 when not valid) */
    fw_vec2_t u7_dq7_v;  /**< eq. 37 (times k_comp; 0 when not valid) */
} harm_comp_output_t;

typedef struct {
    harm_comp_config_t cfg;
    float dtheta_grid_rad;         /**< 2 pi / m */
    est_cplx_t tw[EST_DFT_MAX_M];  /**< e^{-j 2 pi i / m} */
    est_gsdft_t gsdft;
    est_sdft_t sdft;
    int have_prev;                 /**< sampling running: theta_prev, i_prev hold the last step */
    float theta_prev_rad;
    fw_vec2_t i_prev_a;
    int grid_next;                 /**< index of the next grid angle to cross */
    harm_comp_output_t out;
} harm_comp_t;

/** Defaults: m = 96, GSDFT with DC block, k_comp = 1, omega_min = 0.5 rad/s, omega_max from ts_s
 *  (interpolation error and two grid crossings per period, see above). */
void harm_comp_default_config(harm_comp_config_t *cfg, float rs_ohm, float ls_h, float ts_s);
/** 0 on success; -1 if m is not a multiple of 6 in range, or R, L, the speed range are not usable. */
int harm_comp_init(harm_comp_t *h, const harm_comp_config_t *cfg);
void harm_comp_reset(harm_comp_t *h);
/** One control period: alpha-beta current at t_k, electrical angle and speed at t_k. */
const harm_comp_output_t *harm_comp_step(harm_comp_t *h, fw_vec2_t i_ab_a, float theta_e_rad,
                                         float omega_e_rad_s);
/** Compensation voltage in dq at electrical angle theta_e_rad (eq. 36-37 rotated out of the
 *  harmonic frames), to be added to the current-loop output. */
fw_vec2_t harm_comp_voltage_dq(const harm_comp_t *h, float theta_e_rad);

#endif
