"""cffi API-mode builder for the C plant: module ``plant_rt._plant_c``.

Run ``python tools/build_native.py`` (or ``make build``), which compiles ``ffibuilder`` and
places the extension next to this file. The cdef below mirrors ``plant_rt/c/plant.h`` (and the
parts' headers for their stand-alone functions); the structs are declared field by field, so cffi checks their layout against the real header
when it compiles the module (a field added to the header without updating this file fails
the build).
"""
from __future__ import annotations

from pathlib import Path

from cffi import FFI

C_DIR = Path(__file__).resolve().parent / "c"
SOURCES = ("pmsm_machine.c", "inverter.c", "mechanics.c", "sensor.c", "plant.c", "plant_fault.c")

CDEF = """
#define MECH_LOAD_TABLE_MAX 32

typedef struct plant_inverter_params {
    int inverter_nonlinear;
    double dead_time_s, v_switch_drop_v, r_switch_ohm, v_diode_drop_v, r_diode_ohm, i_cap_band_a;
} plant_inverter_params_t;

typedef struct plant_magnetics_params {
    int saturation;
    double sat_l_inf_ratio, sat_i_scale_a, sat_i_knee_a;
} plant_magnetics_params_t;

typedef struct plant_sensor_params {
    int adc_model;
    int adc_bits;
    double adc_full_scale_a;
    double adc_gain_err_ia, adc_gain_err_ib, adc_gain_err_ic;
    double adc_offset_ia_a, adc_offset_ib_a, adc_offset_ic_a;
    double adc_noise_a_rms;
    double adc_vdc_full_scale_v;
    double adc_vdc_gain_err, adc_vdc_offset_v, adc_vdc_noise_v_rms;
    uint64_t adc_seed;
    int dual_sampling;
} plant_sensor_params_t;

typedef struct plant_mechanics_params {
    double coulomb_nm, coulomb_band_rad_s;
    int load_profile;
    double load_t0_s, load_t1_s, load_torque0_nm, load_torque1_nm;
    int load_table_n;
    double load_table_t_s[32];
    double load_table_nm[32];
    int dyno;
    double dyno_speed_rad_s, dyno_accel_rad_s2;
} plant_mechanics_params_t;

typedef struct plant_params {
    double rs_ohm, ld_h, lq_h, psi_f_wb; int pole_pairs;
    double j_kgm2, b_nms;
    double v_dc_v;
    double ts_s;
    double t_delay_s;
    int substeps;
    int full_period_delay;
    plant_inverter_params_t inverter;
    plant_magnetics_params_t magnetics;
    plant_sensor_params_t sensors;
    plant_mechanics_params_t mechanics;
} plant_params_t;

typedef struct plant_snapshot {
    double t_s;
    double i_a_a, i_b_a, i_c_a, i_alpha_a, i_beta_a, i_d_a, i_q_a;
    double omega_m_rad_s, omega_e_rad_s, theta_e_rad, theta_m_rad;
    double torque_e_nm, torque_load_nm;
    double e_alpha_v, e_beta_v;
    double v_dc_v;
    double v_a_v, v_b_v, v_c_v, v_alpha_v, v_beta_v, v_d_v, v_q_v;
    double duty_a, duty_b, duty_c;
    double psi_alpha_wb, psi_beta_wb;
    double torque_friction_nm;
} plant_snapshot_t;

typedef struct plant_sample {
    double t_s;
    double i_a_a, i_b_a, i_c_a;
    double v_dc_v;
    double t2_s;
    double i2_a_a, i2_b_a, i2_c_a;
    int code_a, code_b, code_c, code_vdc;
    int code2_a, code2_b, code2_c;
    int dual_valid;
    double theta_enc_rad;
    int enc_valid;
} plant_sample_t;

typedef struct plant_energy {
    double electrical_in_j, copper_loss_j, viscous_loss_j, load_work_j, magnetic_j, kinetic_j;
    double coulomb_loss_j, inverter_loss_j, dc_bus_in_j;
    double short_loss_j, fault_absorbed_j;
} plant_energy_t;

typedef struct plant_fault {
    int kind; int phase; int phase2; int level; double value;
} plant_fault_t;
typedef struct plant_fault_status {
    unsigned active;
    double i_short_a;
    double i_leg_a_a, i_leg_b_a, i_leg_c_a;
    double v_dc_v;
    double absorbed_j;
    unsigned long short_fallbacks;
} plant_fault_status_t;

typedef struct plant { double t_s; unsigned long events; ...; } plant_t;  /* read-only: time, diode events */

const char *plant_params_check(const plant_params_t *p);
int  plant_init(plant_t *pl, const plant_params_t *p);
void plant_reset(plant_t *pl);
void plant_set_initial(plant_t *pl, double theta_e_rad, double omega_m_rad_s);
void plant_set_load_torque(plant_t *pl, double torque_nm);
void plant_step(plant_t *pl, const double duty_abc[3]);
void plant_snapshot(const plant_t *pl, plant_snapshot_t *out);
void plant_step_abc(plant_t *pl, double duty_a, double duty_b, double duty_c);
void plant_run(plant_t *pl, const double *duties_abc, size_t n, plant_snapshot_t *out);
void plant_energy(const plant_t *pl, plant_energy_t *out);
void plant_sample(const plant_t *pl, plant_sample_t *out);
void plant_set_dyno_speed(plant_t *pl, double omega_m_rad_s);
double plant_load_torque_at(const plant_t *pl, double t_s);
const char *plant_fault_check(const plant_t *pl, const plant_fault_t *f);
int plant_set_fault(plant_t *pl, const plant_fault_t *f);
void plant_clear_fault(plant_t *pl, int kind, int phase);
void plant_clear_faults(plant_t *pl);
unsigned plant_faults_active(const plant_t *pl);
void plant_fault_status(const plant_t *pl, plant_fault_status_t *out);

/* parts, for tests of each part alone */
typedef struct sensor_rng { uint64_t s[4]; double cached_normal; int has_cached; } sensor_rng_t;
void sensor_rng_seed(sensor_rng_t *rng, uint64_t seed);
uint64_t sensor_rng_next_u64(sensor_rng_t *rng);
double sensor_rng_uniform(sensor_rng_t *rng);
double sensor_rng_normal(sensor_rng_t *rng);
typedef struct sensor_adc_config {
    int bits; int bipolar; double full_scale; double gain_err; double offset; double noise_rms;
} sensor_adc_config_t;
double sensor_adc_convert(const sensor_adc_config_t *cfg, sensor_rng_t *rng, double x_true,
                          int *code_out);

typedef struct inverter_config { double v_dc_v; } inverter_config_t;
typedef struct inverter_nl_config {
    double dead_time_s, ts_s, v_switch_drop_v, r_switch_ohm, v_diode_drop_v, r_diode_ohm,
           i_cap_band_a;
} inverter_nl_config_t;
typedef struct inverter { ...; } inverter_t;
int inverter_init(inverter_t *inv, const inverter_config_t *cfg);
int inverter_set_nonlinear(inverter_t *inv, const inverter_nl_config_t *cfg);
double inverter_smooth_sign(const inverter_t *inv, double i_a);
double inverter_leg_voltage(const inverter_t *inv, double duty, double i_a, double *f_hi);

typedef struct pmsm_machine_config {
    double rs_ohm, ld_h, lq_h, psi_f_wb; int pole_pairs;
} pmsm_machine_config_t;
typedef struct pmsm_saturation_config { double l_inf_ratio, i_scale_a, i_knee_a; } pmsm_saturation_config_t;
typedef struct pmsm_machine { ...; } pmsm_machine_t;
int pmsm_machine_init(pmsm_machine_t *m, const pmsm_machine_config_t *cfg);
int pmsm_machine_set_saturation(pmsm_machine_t *m, const pmsm_saturation_config_t *sat);
double pmsm_machine_psi_d(const pmsm_machine_t *m, double i_d_a);
double pmsm_machine_ld_inc(const pmsm_machine_t *m, double i_d_a);
double pmsm_machine_stored_energy(const pmsm_machine_t *m, double i_d_a, double i_q_a);
double pmsm_machine_torque(const pmsm_machine_t *m, double i_d_a, double i_q_a);

typedef struct mechanics_load_profile {
    int kind; double t0_s, t1_s, torque0_nm, torque1_nm; int table_n;
    double table_t_s[32]; double table_nm[32];
} mechanics_load_profile_t;
const char *mechanics_load_profile_check(const mechanics_load_profile_t *lp);
double mechanics_load_profile_at(const mechanics_load_profile_t *lp, double t_s);
double mechanics_load_profile_mean(const mechanics_load_profile_t *lp, double t_a_s, double t_b_s);
"""

ffibuilder = FFI()
ffibuilder.cdef(CDEF)
ffibuilder.set_source(
    "plant_rt._plant_c",
    '#include "plant.h"\n',
    sources=[str(C_DIR / name) for name in SOURCES],
    include_dirs=[str(C_DIR)],
    # ISO C (-std=c99): no FMA contraction, so -O3 and LTO give the same results as -O2
    extra_compile_args=["-O3", "-std=c99", "-flto"],
    extra_link_args=["-O3", "-flto"],
    libraries=["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
