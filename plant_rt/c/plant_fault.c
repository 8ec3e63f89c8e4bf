/**
 * @file plant_fault.c
 * @brief Run-time plant faults (see plant_fault.h for the physics of each).
 */
#include "plant_fault_internal.h"

#include <math.h>
#include <string.h>

#define PF_SQRT3 1.7320508075688772935
#define PF_INV_SQRT3 0.57735026918962576451
#define PF_TWO_PI 6.283185307179586477
/* |i_z| up to this is taken as "no current" when a leg-mode combination holds i_z at zero (the
 * state is then projected onto i_z = 0); well above the event location's residue (~1e-12 A),
 * far below anything the bench resolves */
#define PF_CONSTRAINT_TOL_A 1e-6

enum { F_ID = 0, F_IQ = 1, F_WM = 2, F_TH = 3 };

static const double k_ux[3] = {1.0, -0.5, -0.5};
static const double k_uy[3] = {0.0, 0.5 * PF_SQRT3, -0.5 * PF_SQRT3};

static int phase_ok(int k)
{
    return k >= 0 && k <= 2;
}

static void currents_abc_at(const double *s, double sn, double cs, double i[3])
{
    const double ia = s[F_ID] * cs - s[F_IQ] * sn;
    const double ib = s[F_ID] * sn + s[F_IQ] * cs;
    i[0] = ia;
    i[1] = -0.5 * ia + 0.5 * PF_SQRT3 * ib;
    i[2] = -0.5 * ia - 0.5 * PF_SQRT3 * ib;
}

/** Orthogonal projection removing phase k's current (drift after a step on i_k = 0). */
static void clamp_phase(double *s, int k)
{
    const double sn = sin(s[F_TH]);
    const double cs = cos(s[F_TH]);
    double ia = s[F_ID] * cs - s[F_IQ] * sn;
    double ib = s[F_ID] * sn + s[F_IQ] * cs;
    const double ik = k_ux[k] * ia + k_uy[k] * ib;
    ia -= ik * k_ux[k];
    ib -= ik * k_uy[k];
    s[F_ID] = ia * cs + ib * sn;
    s[F_IQ] = -ia * sn + ib * cs;
}

/* ------------------------------------------------------------------------------------------ */
/* set / clear                                                                                */

const char *plant_fault_check(const plant_t *pl, const plant_fault_t *f)
{
    if (pl == NULL || f == NULL) return "fault: NULL";
    switch (f->kind) {
    case PLANT_FAULT_OPEN_PHASE:
        if (!phase_ok(f->phase)) return "phase: must be 0, 1 or 2";
        if (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_PHASE_SHORT)) {
            return "kind: open_phase cannot be combined with phase_short";
        }
        return NULL;
    case PLANT_FAULT_LEG_STUCK:
        if (!phase_ok(f->phase)) return "phase: must be 0, 1 or 2";
        if (f->level != 0 && f->level != 1) return "level: must be 0 (lower switch) or 1 (upper switch)";
        return NULL;
    case PLANT_FAULT_PHASE_SHORT:
        if (!phase_ok(f->phase)) return "phase: must be 0, 1 or 2";
        if (!phase_ok(f->phase2) || f->phase2 == f->phase) return "phase2: must be 0, 1 or 2 and != phase";
        if (!isfinite(f->value) || !(f->value > 0.0)) return "value: short resistance must be finite and > 0";
        if (pl->params.inverter.inverter_nonlinear) {
            return "kind: phase_short needs the ideal inverter (inverter_nonlinear = 0)";
        }
        if (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_OPEN_PHASE)) {
            return "kind: phase_short cannot be combined with open_phase";
        }
        return NULL;
    case PLANT_FAULT_SENSOR_STUCK:
    case PLANT_FAULT_SENSOR_OFFSET:
        if (!phase_ok(f->phase)) return "phase: must be 0, 1 or 2";
        if (!isfinite(f->value)) return "value: must be finite";
        return NULL;
    case PLANT_FAULT_SENSOR_GAIN:
        if (!phase_ok(f->phase)) return "phase: must be 0, 1 or 2";
        if (!isfinite(f->value) || !(f->value > -1.0)) return "value: gain error must be finite and > -1";
        return NULL;
    case PLANT_FAULT_SENSOR_DROPOUT:
        if (!phase_ok(f->phase)) return "phase: must be 0, 1 or 2";
        return NULL;
    case PLANT_FAULT_VDC:
        if (!isfinite(f->value) || !(f->value > 0.0)) return "value: bus voltage must be finite and > 0";
        if (pl->params.inverter.inverter_nonlinear) {
            /* the inverter's RK4 stability rule depends on V_dc */
            plant_params_t q = pl->params;
            const char *msg;
            q.v_dc_v = f->value;
            if ((msg = plant_params_check_nonideal(&q)) != NULL) return msg;
        }
        return NULL;
    case PLANT_FAULT_ENCODER_LOSS:
    case PLANT_FAULT_ENCODER_STUCK:
    case PLANT_FAULT_LOCKED_ROTOR:
        return NULL;
    case PLANT_FAULT_LOAD_TORQUE:
        if (!isfinite(f->value)) return "value: load torque must be finite";
        return NULL;
    default:
        return "kind: unknown fault kind";
    }
}

/** Interrupt phase x's current keeping the flux linkage of the loop through the two other
 *  phases: psi . n constant, n = J u_x (the only direction the remaining circuit allows). */
static void interrupt_phase(plant_t *pl, int x)
{
    const pmsm_machine_t *m = &pl->machine;
    const double th = pl->y[F_TH];
    /* n in alpha-beta, then in dq */
    const double nal = -k_uy[x];
    const double nbe = k_ux[x];
    const double nd = nal * cos(th) + nbe * sin(th);
    const double nq = -nal * sin(th) + nbe * cos(th);
    const double id0 = pl->y[F_ID];
    const double iq0 = pl->y[F_IQ];
    const double lq = m->cfg.lq_h;
    const double target = nd * pmsm_machine_psi_d(m, id0) + nq * lq * iq0;
    const double w_before = pmsm_machine_stored_energy(m, id0, iq0);
    double a = nd * id0 + nq * iq0; /* orthogonal projection as the start */
    int it;
    for (it = 0; it < 50; ++it) {
        double psi_d, l_inc, f, df, step;
        pmsm_machine_flux_d(m, a * nd, &psi_d, &l_inc);
        f = nd * psi_d + nq * lq * a * nq - target;
        df = nd * nd * l_inc + nq * nq * lq;
        step = f / df;
        a -= step;
        if (fabs(step) <= 1e-15 * (1.0 + fabs(a))) break;
    }
    pl->y[F_ID] = a * nd;
    pl->y[F_IQ] = a * nq;
    clamp_phase(pl->y, x); /* rounding residue of i_x */
    pl->machine.i_d_a = pl->y[F_ID];
    pl->machine.i_q_a = pl->y[F_IQ];
    pl->faults.absorbed_j += w_before - pmsm_machine_stored_energy(m, pl->y[F_ID], pl->y[F_IQ]);
}

static int is_sensor_kind(int kind)
{
    return kind >= PLANT_FAULT_SENSOR_STUCK && kind <= PLANT_FAULT_SENSOR_DROPOUT;
}

static void refresh_sensor_bits(plant_fault_state_t *fs)
{
    int kind, k;
    for (kind = PLANT_FAULT_SENSOR_STUCK; kind <= PLANT_FAULT_SENSOR_DROPOUT; ++kind) {
        fs->active &= ~PLANT_FAULT_BIT(kind);
    }
    for (k = 0; k < 3; ++k) {
        if (fs->sensor[k].kind != 0) fs->active |= PLANT_FAULT_BIT(fs->sensor[k].kind);
    }
}

static void set_bus(plant_t *pl, double v_dc_v)
{
    pl->params.v_dc_v = v_dc_v;
    pl->inverter.cfg.v_dc_v = v_dc_v;
    pl->inverter.v_tol_v = 1e-9 * v_dc_v;
}

int plant_set_fault(plant_t *pl, const plant_fault_t *f)
{
    plant_fault_state_t *fs;
    if (plant_fault_check(pl, f) != NULL) return -1;
    fs = &pl->faults;
    switch (f->kind) {
    case PLANT_FAULT_OPEN_PHASE:
        if ((fs->active & PLANT_FAULT_BIT(PLANT_FAULT_OPEN_PHASE)) && fs->open_phase == f->phase) {
            return 0;
        }
        fs->open_phase = f->phase;
        interrupt_phase(pl, f->phase);
        break;
    case PLANT_FAULT_LEG_STUCK: {
        int k, any = 0;
        for (k = 0; k < 3; ++k) any |= (fs->active & PLANT_FAULT_BIT(PLANT_FAULT_LEG_STUCK)) && fs->stuck[k] >= 0;
        if (!any) {
            for (k = 0; k < 3; ++k) {
                fs->stuck[k] = -1;
                fs->cmd_prev[k] = pl->duty_prev[k];
            }
        }
        fs->stuck[f->phase] = f->level;
        /* the duties in effect now (until the next actuation instant) follow at once */
        pl->duty_prev[f->phase] = (double)f->level;
        break;
    }
    case PLANT_FAULT_PHASE_SHORT:
        fs->short_x = f->phase;
        fs->short_y = f->phase2;
        fs->short_z = 3 - f->phase - f->phase2;
        fs->short_r_ohm = f->value;
        fs->short_used = 1;
        break;
    case PLANT_FAULT_SENSOR_STUCK:
    case PLANT_FAULT_SENSOR_OFFSET:
    case PLANT_FAULT_SENSOR_GAIN:
    case PLANT_FAULT_SENSOR_DROPOUT:
        fs->sensor[f->phase].kind = f->kind;
        fs->sensor[f->phase].value = f->value;
        refresh_sensor_bits(fs);
        fs->resample = 1;
        return 0;
    case PLANT_FAULT_VDC:
        if (!(fs->active & PLANT_FAULT_BIT(PLANT_FAULT_VDC))) fs->v_dc_nominal_v = pl->params.v_dc_v;
        set_bus(pl, f->value);
        fs->resample = 1;
        break;
    case PLANT_FAULT_ENCODER_LOSS:
        fs->active &= ~PLANT_FAULT_BIT(PLANT_FAULT_ENCODER_STUCK);
        break;
    case PLANT_FAULT_ENCODER_STUCK:
        if (!(fs->active & PLANT_FAULT_BIT(PLANT_FAULT_ENCODER_STUCK))) fs->enc_hold_rad = pl->y[F_TH];
        fs->active &= ~PLANT_FAULT_BIT(PLANT_FAULT_ENCODER_LOSS);
        break;
    case PLANT_FAULT_LOCKED_ROTOR:
        if (fs->active & PLANT_FAULT_BIT(PLANT_FAULT_LOCKED_ROTOR)) return 0;
        /* the lock is a dynamometer holding zero speed: the speed steps to 0 at the next
         * period start and the kinetic energy is booked as work on the lock */
        fs->lock_saved_dyno = pl->params.mechanics.dyno;
        fs->lock_saved_accel_rad_s2 = pl->params.mechanics.dyno_accel_rad_s2;
        fs->lock_saved_target_rad_s = pl->dyno_target_rad_s;
        pl->params.mechanics.dyno = 1;
        pl->params.mechanics.dyno_accel_rad_s2 = 0.0;
        pl->dyno_target_rad_s = 0.0;
        break;
    case PLANT_FAULT_LOAD_TORQUE:
        fs->load_extra_nm = f->value;
        break;
    default:
        return -1;
    }
    fs->active |= PLANT_FAULT_BIT(f->kind);
    fs->resample = 1;
    return 0;
}

void plant_clear_fault(plant_t *pl, int kind, int phase)
{
    plant_fault_state_t *fs = &pl->faults;
    int k;
    if (kind <= PLANT_FAULT_NONE || kind >= PLANT_FAULT_KIND_COUNT) return;
    if (is_sensor_kind(kind)) {
        for (k = 0; k < 3; ++k) {
            if ((phase < 0 || phase == k) && fs->sensor[k].kind == kind) {
                fs->sensor[k].kind = 0;
                fs->sensor[k].value = 0.0;
            }
        }
        refresh_sensor_bits(fs);
        fs->resample = 1;
        return;
    }
    if (!(fs->active & PLANT_FAULT_BIT(kind))) return;
    switch (kind) {
    case PLANT_FAULT_LEG_STUCK: {
        int left = 0;
        for (k = 0; k < 3; ++k) {
            if ((phase < 0 || phase == k) && fs->stuck[k] >= 0) {
                fs->stuck[k] = -1;
                pl->duty_prev[k] = fs->cmd_prev[k]; /* the command of the last period acts again */
            }
            left |= fs->stuck[k] >= 0;
        }
        if (left) return;
        break;
    }
    case PLANT_FAULT_VDC:
        set_bus(pl, fs->v_dc_nominal_v);
        break;
    case PLANT_FAULT_LOCKED_ROTOR:
        pl->params.mechanics.dyno = fs->lock_saved_dyno;
        pl->params.mechanics.dyno_accel_rad_s2 = fs->lock_saved_accel_rad_s2;
        pl->dyno_target_rad_s = fs->lock_saved_target_rad_s;
        pl->dyno_accel_now_rad_s2 = 0.0;
        break;
    case PLANT_FAULT_LOAD_TORQUE:
        fs->load_extra_nm = 0.0;
        break;
    default:
        break;
    }
    fs->active &= ~PLANT_FAULT_BIT(kind);
    fs->resample = 1;
}

void plant_clear_faults(plant_t *pl)
{
    int kind;
    for (kind = 1; kind < PLANT_FAULT_KIND_COUNT; ++kind) {
        plant_clear_fault(pl, kind, -1);
    }
}

void plant_fault_reset(plant_t *pl)
{
    plant_clear_faults(pl);
    memset(&pl->faults, 0, sizeof pl->faults);
}

unsigned plant_faults_active(const plant_t *pl)
{
    return pl->faults.active;
}

/* ------------------------------------------------------------------------------------------ */
/* hooks of plant_step / plant_sample                                                         */

void plant_fault_apply_stuck(plant_t *pl, double duty[3])
{
    int k;
    for (k = 0; k < 3; ++k) {
        pl->faults.cmd_prev[k] = duty[k];
        if (pl->faults.stuck[k] >= 0) duty[k] = (double)pl->faults.stuck[k];
    }
}

void plant_fault_apply_sensors(const plant_t *pl, double i_abc[3])
{
    int k;
    for (k = 0; k < 3; ++k) {
        const plant_sensor_fault_t *sf = &pl->faults.sensor[k];
        switch (sf->kind) {
        case PLANT_FAULT_SENSOR_STUCK: i_abc[k] = sf->value; break;
        case PLANT_FAULT_SENSOR_OFFSET: i_abc[k] += sf->value; break;
        case PLANT_FAULT_SENSOR_GAIN: i_abc[k] *= 1.0 + sf->value; break;
        case PLANT_FAULT_SENSOR_DROPOUT: i_abc[k] = 0.0; break;
        default: break;
        }
    }
}

void plant_fault_sensed_currents(const plant_t *pl, const double duty[3], const double *s,
                                 double i_abc[3])
{
    currents_abc_at(s, sin(s[F_TH]), cos(s[F_TH]), i_abc);
    if (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_PHASE_SHORT)) {
        /* at the sampling instant (zero vector of centre-aligned PWM) a PWM leg sits at the
         * - rail, or at the + rail with duty 1 (a stuck-high leg included) */
        double d0[3], st[4];
        plant_short_mode_t m;
        plant_short_out_t o;
        int k;
        for (k = 0; k < 3; ++k) {
            d0[k] = inverter_leg_disabled(duty[k]) ? -1.0 : ((duty[k] >= 1.0) ? 1.0 : 0.0);
        }
        memcpy(st, s, sizeof st);
        plant_short_resolve((plant_t *)(void *)pl /* resolve only counts fallbacks */, d0, st, &m);
        plant_short_solve(pl, &m, st, sin(st[F_TH]), cos(st[F_TH]), &o);
        for (k = 0; k < 3; ++k) i_abc[k] = o.l_a[k];
    }
    if (pl->faults.active & PLANT_FAULT_SENSE_BITS) {
        plant_fault_apply_sensors(pl, i_abc);
    }
}

void plant_fault_sample(const plant_t *pl, plant_sample_t *out)
{
    const plant_fault_state_t *fs = &pl->faults;
    if (fs->active & PLANT_FAULT_SENSE_BITS) {
        double i[3];
        plant_fault_sensed_currents(pl, pl->duty_prev, pl->y, i);
        if (pl->params.sensors.adc_model) {
            out->i_a_a = sensor_adc_convert_noise(&pl->adc_i[0], i[0], pl->sample_noise[0], &out->code_a);
            out->i_b_a = sensor_adc_convert_noise(&pl->adc_i[1], i[1], pl->sample_noise[1], &out->code_b);
            out->i_c_a = sensor_adc_convert_noise(&pl->adc_i[2], i[2], pl->sample_noise[2], &out->code_c);
        } else {
            out->i_a_a = i[0];
            out->i_b_a = i[1];
            out->i_c_a = i[2];
        }
    } else if (pl->params.sensors.adc_model) {
        /* a sensor fault cleared since t_k: the healthy conversion of t_k with its deviates */
        double i[3];
        currents_abc_at(pl->y, sin(pl->y[F_TH]), cos(pl->y[F_TH]), i);
        out->i_a_a = sensor_adc_convert_noise(&pl->adc_i[0], i[0], pl->sample_noise[0], &out->code_a);
        out->i_b_a = sensor_adc_convert_noise(&pl->adc_i[1], i[1], pl->sample_noise[1], &out->code_b);
        out->i_c_a = sensor_adc_convert_noise(&pl->adc_i[2], i[2], pl->sample_noise[2], &out->code_c);
    }
    if (pl->params.sensors.adc_model) {
        out->v_dc_v = sensor_adc_convert_noise(&pl->adc_vdc, pl->params.v_dc_v, pl->sample_noise[3],
                                               &out->code_vdc);
    }
    if (fs->active & PLANT_FAULT_BIT(PLANT_FAULT_ENCODER_LOSS)) {
        out->theta_enc_rad = 0.0;
        out->enc_valid = 0;
    } else if (fs->active & PLANT_FAULT_BIT(PLANT_FAULT_ENCODER_STUCK)) {
        out->theta_enc_rad = fs->enc_hold_rad;
    }
}

/* ------------------------------------------------------------------------------------------ */
/* phase-to-phase short: the network                                                          */

void plant_short_solve(const plant_t *pl, const plant_short_mode_t *m, const double *s, double sn,
                       double cs, plant_short_out_t *o)
{
    const int x = m->x, y = m->y, z = m->z;
    const double r = m->r_ohm;
    const double we = (double)pl->params.pole_pairs * s[F_WM];
    double i[3], u[3], v[3], valpha, vbeta, vd, vq;
    int k;
    currents_abc_at(s, sn, cs, i);
    if (!m->constrained) {
        double cm;
        for (k = 0; k < 3; ++k) u[k] = m->u_src_v[k];
        if (m->open[x]) {
            u[x] = u[y] - r * i[x];           /* leg x carries nothing: i_f = -i_x */
            o->i_f_a = -i[x];
        } else if (m->open[y]) {
            u[y] = u[x] - r * i[y];           /* leg y carries nothing: i_f = i_y */
            o->i_f_a = i[y];
        } else {
            o->i_f_a = (u[x] - u[y]) / r;
        }
        cm = (u[0] + u[1] + u[2]) / 3.0;
        for (k = 0; k < 3; ++k) v[k] = u[k] - cm;
        valpha = v[0];
        vbeta = (v[0] + 2.0 * v[1]) * PF_INV_SQRT3;
        vd = valpha * cs + vbeta * sn;
        vq = -valpha * sn + vbeta * cs;
        pmsm_machine_derivs(&pl->machine, s[F_ID], s[F_IQ], vd, vq, we, &o->did, &o->diq);
    } else {
        /* i_z = 0: the machine is one circuit through phases x and y, driven by v_xy */
        double vxy, lam, vn;
        int src = -1;
        if (!m->open[x] && !m->open[y]) {
            vxy = m->u_src_v[x] - m->u_src_v[y];
            o->i_f_a = vxy / r;
        } else {
            vxy = -r * i[x];
            o->i_f_a = -i[x];
        }
        pmsm_machine_derivs_open_phase(&pl->machine, s[F_ID], s[F_IQ], s[F_TH], we, z,
                                       ((z + 1) % 3 == x) ? vxy : -vxy, &o->did, &o->diq, &lam);
        v[z] = lam;
        v[x] = 0.5 * (vxy - lam);
        v[y] = 0.5 * (-vxy - lam);
        if (!m->open[x]) src = x;
        else if (!m->open[y]) src = y;
        else if (!m->open[z]) src = z;
        if (src >= 0) {
            vn = m->u_src_v[src] - v[src];
        } else { /* floating: centred between the rails (only differences matter) */
            const double vmax = fmax(v[0], fmax(v[1], v[2]));
            const double vmin = fmin(v[0], fmin(v[1], v[2]));
            vn = 0.5 * pl->params.v_dc_v - 0.5 * (vmax + vmin);
        }
        for (k = 0; k < 3; ++k) u[k] = vn + v[k];
    }
    for (k = 0; k < 3; ++k) {
        o->v_phase_v[k] = v[k];
        o->u_term_v[k] = u[k];
        o->l_a[k] = i[k];
    }
    o->l_a[x] += o->i_f_a;
    o->l_a[y] -= o->i_f_a;
    if (m->open[x]) o->l_a[x] = 0.0;
    if (m->open[y]) o->l_a[y] = 0.0;
}

/** Smallest guard margin of the mode for a solved network (>= 0: consistent). */
static double short_margin_of(const plant_t *pl, const plant_short_mode_t *m, const plant_short_out_t *o)
{
    const inverter_t *inv = &pl->inverter;
    double margin = HUGE_VAL;
    int k, n_open = 0;
    for (k = 0; k < 3; ++k) {
        if (m->leg[k] == INV_LEG_DIODE_LOW) margin = fmin(margin, o->l_a[k] + inv->i_zero_a);
        if (m->leg[k] == INV_LEG_DIODE_HIGH) margin = fmin(margin, -o->l_a[k] + inv->i_zero_a);
        n_open += m->open[k];
    }
    if (n_open == 3) {
        const double umax = fmax(o->u_term_v[0], fmax(o->u_term_v[1], o->u_term_v[2]));
        const double umin = fmin(o->u_term_v[0], fmin(o->u_term_v[1], o->u_term_v[2]));
        margin = fmin(margin, inv->cfg.v_dc_v + inv->v_tol_v - (umax - umin));
    } else {
        for (k = 0; k < 3; ++k) {
            if (m->open[k]) margin = fmin(margin, inverter_open_margin(inv, o->u_term_v[k]));
        }
    }
    return margin;
}

double plant_short_margin(const plant_t *pl, const plant_short_mode_t *m, const double *s)
{
    plant_short_out_t o;
    plant_short_solve(pl, m, s, sin(s[F_TH]), cos(s[F_TH]), &o);
    return short_margin_of(pl, m, &o);
}

void plant_short_enforce(const plant_short_mode_t *m, double *s)
{
    if (m->constrained) clamp_phase(s, m->z);
}

/** Fill a mode from leg modes (ideal inverter). */
static void short_mode_make(const plant_t *pl, const double duty[3], const int leg[3],
                            plant_short_mode_t *m)
{
    const double vdc = pl->params.v_dc_v;
    int k;
    m->x = pl->faults.short_x;
    m->y = pl->faults.short_y;
    m->z = pl->faults.short_z;
    m->r_ohm = pl->faults.short_r_ohm;
    for (k = 0; k < 3; ++k) {
        m->leg[k] = leg[k];
        m->open[k] = (leg[k] == INV_LEG_OPEN);
        m->u_src_v[k] = (leg[k] == INV_LEG_PWM) ? inverter_sanitize_duty(duty[k]) * vdc
                        : ((leg[k] == INV_LEG_DIODE_HIGH) ? vdc : 0.0);
    }
    m->constrained = m->open[m->z] || (m->open[m->x] && m->open[m->y]);
}

void plant_short_resolve(plant_t *pl, const double duty[3], double *s, plant_short_mode_t *m)
{
    /* Enumerate the modes of the disabled legs (open, lower diode, upper diode) and keep the
     * consistent one with the most open legs. With an ideal diode and a passive resistive
     * network the consistent mode is unique except on a guard boundary, where preferring the
     * open leg turns a diode off once its current has crossed zero. */
    int dis[3], n_dis = 0, combos = 1, c, k;
    int best_open = -1;
    double best_fallback = -HUGE_VAL;
    plant_short_mode_t fallback;
    int have_best = 0;
    for (k = 0; k < 3; ++k) {
        dis[k] = inverter_leg_disabled(duty[k]);
        if (dis[k]) {
            ++n_dis;
            combos *= 3;
        }
    }
    memset(&fallback, 0, sizeof fallback);
    for (c = 0; c < combos; ++c) {
        plant_short_mode_t t;
        plant_short_out_t o;
        int leg[3], rest = c, n_open = 0;
        double st[4], margin, iz;
        for (k = 0; k < 3; ++k) {
            if (!dis[k]) {
                leg[k] = INV_LEG_PWM;
            } else {
                const int pick = rest % 3;
                rest /= 3;
                leg[k] = (pick == 0) ? INV_LEG_OPEN : ((pick == 1) ? INV_LEG_DIODE_LOW : INV_LEG_DIODE_HIGH);
                n_open += (pick == 0);
            }
        }
        short_mode_make(pl, duty, leg, &t);
        memcpy(st, s, sizeof st);
        if (t.constrained) {
            double i[3];
            currents_abc_at(st, sin(st[F_TH]), cos(st[F_TH]), i);
            iz = i[t.z];
            clamp_phase(st, t.z);
        } else {
            iz = 0.0;
        }
        plant_short_solve(pl, &t, st, sin(st[F_TH]), cos(st[F_TH]), &o);
        margin = short_margin_of(pl, &t, &o);
        if (fabs(iz) <= PF_CONSTRAINT_TOL_A && margin >= 0.0) {
            if (n_open > best_open) {
                best_open = n_open;
                *m = t;
                have_best = 1;
            }
        } else if (!have_best) {
            /* no consistent mode yet: remember the least inconsistent one */
            const double score = (fabs(iz) <= PF_CONSTRAINT_TOL_A) ? margin : -HUGE_VAL / 4.0 - fabs(iz);
            if (score > best_fallback || c == 0) {
                best_fallback = score;
                fallback = t;
            }
        }
    }
    if (!have_best) {
        *m = fallback;
        ++pl->faults.short_fallbacks;
    }
    if (m->constrained) clamp_phase(s, m->z);
}

/* ------------------------------------------------------------------------------------------ */
/* status                                                                                     */

void plant_fault_status(const plant_t *pl, plant_fault_status_t *out)
{
    double i[3];
    int k;
    memset(out, 0, sizeof *out);
    out->active = pl->faults.active;
    out->v_dc_v = pl->params.v_dc_v;
    out->absorbed_j = pl->faults.absorbed_j;
    out->short_fallbacks = pl->faults.short_fallbacks;
    currents_abc_at(pl->y, sin(pl->y[F_TH]), cos(pl->y[F_TH]), i);
    if (pl->faults.active & PLANT_FAULT_BIT(PLANT_FAULT_PHASE_SHORT)) {
        plant_short_mode_t m;
        plant_short_out_t o;
        double st[4];
        memcpy(st, pl->y, sizeof st);
        plant_short_resolve((plant_t *)(void *)pl, pl->duty_prev, st, &m);
        plant_short_solve(pl, &m, st, sin(st[F_TH]), cos(st[F_TH]), &o);
        out->i_short_a = o.i_f_a;
        for (k = 0; k < 3; ++k) i[k] = o.l_a[k];
    }
    out->i_leg_a_a = i[0];
    out->i_leg_b_a = i[1];
    out->i_leg_c_a = i[2];
}
