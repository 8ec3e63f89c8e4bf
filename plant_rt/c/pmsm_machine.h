/**
 * @file pmsm_machine.h
 * @brief PMSM electrical model in the rotor (dq) frame, Ld != Lq allowed (SPMSM and IPMSM).
 *
 * State: i_d, i_q [A]. With omega_e = p * omega_m [rad/s]:
 *
 *     L_d di_d/dt = v_d - R i_d + omega_e L_q i_q
 *     L_q di_q/dt = v_q - R i_q - omega_e (L_d i_d + psi_f)
 *     T_e         = 1.5 p (psi_f i_q + (L_d - L_q) i_d i_q)          [N m]
 *
 * Transforms (docs/architecture.md): amplitude-invariant Clarke, alpha axis on phase a,
 *     i_alpha = i_a,  i_beta = (i_a + 2 i_b) / sqrt(3),
 * Park with theta_e the electrical angle of the d axis (PM north):
 *     d = alpha cos(theta) + beta sin(theta),  q = -alpha sin(theta) + beta cos(theta).
 * With these, a balanced three-phase set of peak amplitude A has |(alpha, beta)| = A, the
 * instantaneous power is p = 1.5 (v_alpha i_alpha + v_beta i_beta) = 1.5 (v_d i_d + v_q i_q),
 * and the back EMF is e_alpha = -omega_e psi_f sin(theta), e_beta = omega_e psi_f cos(theta).
 *
 * Besides the plain model (pmsm_machine_derivs) the module gives the dynamics with one phase
 * open-circuited (pmsm_machine_derivs_open_phase), used by the plant when a disabled inverter
 * leg carries no current. Double precision, host only, no heap.
 *
 * d-axis saturation (pmsm_machine_set_saturation; off after init). The d-axis flux linkage is
 *     psi_d(i_d) = psi_f + L_s i_d + K I_s [tanh((i_d - i_0)/I_s) + tanh(i_0/I_s)]
 *     L_inc(i_d) = dpsi_d/di_d = L_s + K sech^2((i_d - i_0)/I_s),   K = (L_d - L_s) cosh^2(i_0/I_s)
 * with L_s = l_inf_ratio * L_d (the incremental inductance deep in saturation), I_s the current
 * scale and i_0 <= 0 the knee (where the magnet's bias is cancelled and L_inc peaks at
 * L_s + K). By construction psi_d(0) = psi_f and L_inc(0) = L_d (the small-signal inductance
 * stays the profile value); L_inc falls monotonically for i_d > i_0, i.e. for every positive
 * i_d (current adding to the PM flux, N side) and rises towards the knee for negative i_d.
 * The q axis stays linear (psi_q = L_q i_q, no cross saturation). Then
 *     L_inc(i_d) di_d/dt = v_d - R i_d + omega_e psi_q
 *     L_q di_q/dt        = v_q - R i_q - omega_e psi_d(i_d)
 *     T_e = 1.5 p (psi_d i_q - psi_q i_d)
 *     W   = 1.5 [ int_0^i_d x L_inc(x) dx + L_q i_q^2 / 2 ]    (field energy; closed form)
 * which reduce exactly to the linear model above when saturation is off.
 */
#ifndef PMSM_MACHINE_H
#define PMSM_MACHINE_H

/** Machine constants (SI). */
typedef struct pmsm_machine_config {
    double rs_ohm;   /**< stator phase resistance [ohm] */
    double ld_h;     /**< d-axis inductance [H] */
    double lq_h;     /**< q-axis inductance [H] */
    double psi_f_wb; /**< PM flux linkage, peak per phase [Wb] */
    int pole_pairs;  /**< p [-] */
} pmsm_machine_config_t;

/** d-axis saturation parameters (see the top of this file). */
typedef struct pmsm_saturation_config {
    double l_inf_ratio; /**< L_s / L_d, 0 < ratio <= 1 (1: linear) */
    double i_scale_a;   /**< I_s [A], > 0 */
    double i_knee_a;    /**< i_0 [A], -3 I_s <= i_0 <= 0 */
} pmsm_saturation_config_t;

/** Config, derived coefficients and state (caller owns the memory). */
typedef struct pmsm_machine {
    pmsm_machine_config_t cfg;
    /* saturation (saturated = 0: linear d axis) */
    int saturated;
    double sat_ls_h;   /**< L_s [H] */
    double sat_k_h;    /**< K [H] */
    double sat_is_a;   /**< I_s [A] */
    double sat_i0_a;   /**< i_0 [A] */
    double sat_t0;     /**< tanh(i_0 / I_s) */
    double sat_j0;     /**< energy primitive at i_d = 0 [A^2] */
    /* derived */
    double inv_ld;   /**< 1/L_d [1/H] */
    double inv_lq;   /**< 1/L_q [1/H] */
    double k_torque; /**< 1.5 p [-] */
    /* state (used by the stand-alone pmsm_machine_step) */
    double i_d_a;
    double i_q_a;
} pmsm_machine_t;

/** Returns 0, or -1 if a constant is non-physical (L <= 0, R < 0, psi_f < 0, p < 1, non-finite). */
int pmsm_machine_init(pmsm_machine_t *m, const pmsm_machine_config_t *cfg);
/** Zero currents. */
void pmsm_machine_reset(pmsm_machine_t *m);

/** dq current derivatives [A/s] for currents [A], voltages [V] and electrical speed [rad/s]. */
void pmsm_machine_derivs(const pmsm_machine_t *m, double i_d_a, double i_q_a, double v_d_v,
                         double v_q_v, double omega_e_rad_s, double *di_d, double *di_q);

/**
 * dq current derivatives with phase `open_phase` (0 = a, 1 = b, 2 = c) open-circuited.
 *
 * The other two phases y = open_phase+1, z = open_phase+2 (mod 3) are driven with the line
 * voltage v_yz_v = v_yN - v_zN [V]. The currents must satisfy i_open = 0 (the caller keeps
 * them on that constraint); the returned derivatives keep d(i_open)/dt = 0 exactly. The phase
 * (to-neutral) voltage that appears across the open phase is returned in *v_open_v [V]:
 * the open terminal sits at v_xN = (v_yN + v_zN)/2 + 1.5 * v_open.
 * Derivation: v_alphabeta = a n + lambda u_x with u_x the phase-x axis, n = J u_x,
 * a = v_yz / sqrt(3); lambda follows from d/dt(u_x . i_alphabeta) = 0.
 */
void pmsm_machine_derivs_open_phase(const pmsm_machine_t *m, double i_d_a, double i_q_a,
                                    double theta_e_rad, double omega_e_rad_s, int open_phase,
                                    double v_yz_v, double *di_d, double *di_q, double *v_open_v);

/** Electromagnetic torque [N m]. */
double pmsm_machine_torque(const pmsm_machine_t *m, double i_d_a, double i_q_a);

/**
 * Energy stored in the field by the stator currents [J]: 0.75 (L_d i_d^2 + L_q i_q^2) when
 * linear, 1.5 [int_0^i_d x L_inc dx + L_q i_q^2 / 2] with saturation.
 */
double pmsm_machine_stored_energy(const pmsm_machine_t *m, double i_d_a, double i_q_a);

/**
 * Switch d-axis saturation on (sat != NULL) or off (NULL). Returns 0, or -1 (saturation left
 * off) if a value is out of range.
 */
int pmsm_machine_set_saturation(pmsm_machine_t *m, const pmsm_saturation_config_t *sat);
/** d-axis flux linkage including the PM [Wb] (psi_f + L_d i_d when linear). */
double pmsm_machine_psi_d(const pmsm_machine_t *m, double i_d_a);
/** psi_d and L_inc together (one tanh; sech^2 = 1 - tanh^2) [Wb], [H]. */
void pmsm_machine_flux_d(const pmsm_machine_t *m, double i_d_a, double *psi_d_wb, double *ld_inc_h);
/** Incremental d-axis inductance dpsi_d/di_d [H] (L_d when linear). */
double pmsm_machine_ld_inc(const pmsm_machine_t *m, double i_d_a);

/**
 * Stand-alone use: advance the state by dt_s [s] with constant dq voltages and a constant
 * electrical speed (e.g. locked rotor), one classical RK4 step. Split long intervals yourself.
 */
void pmsm_machine_step(pmsm_machine_t *m, double v_d_v, double v_q_v, double omega_e_rad_s,
                       double dt_s);

/* ---- frame transforms (amplitude-invariant, see top of file) ---- */

/** abc -> alpha-beta; the zero-sequence part of (a, b, c) is discarded. */
void pmsm_clarke(double a, double b, double c, double *alpha, double *beta);
/** alpha-beta -> abc (zero-sequence free). */
void pmsm_inv_clarke(double alpha, double beta, double *a, double *b, double *c);
/** alpha-beta -> dq, theta_e_rad = electrical angle of the d axis. */
void pmsm_park(double alpha, double beta, double theta_e_rad, double *d, double *q);
/** dq -> alpha-beta. */
void pmsm_inv_park(double d, double q, double theta_e_rad, double *alpha, double *beta);

#endif
