"""cffi API-mode builder for the C plant: module ``plant_rt._plant_c``.

Run ``python tools/build_native.py`` (or ``make build``), which compiles ``ffibuilder`` and
places the extension next to this file. The cdef below mirrors ``plant_rt/c/plant.h``; the
structs are declared field by field, so cffi checks their layout against the real header
when it compiles the module (a field added to the header without updating this file fails
the build).
"""
from __future__ import annotations

from pathlib import Path

from cffi import FFI

C_DIR = Path(__file__).resolve().parent / "c"
SOURCES = ("pmsm_machine.c", "inverter.c", "mechanics.c", "plant.c")

CDEF = """
typedef struct plant_params {
    double rs_ohm, ld_h, lq_h, psi_f_wb; int pole_pairs;
    double j_kgm2, b_nms;
    double v_dc_v;
    double ts_s;
    double t_delay_s;
    int substeps;
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
} plant_snapshot_t;

typedef struct plant_energy {
    double electrical_in_j, copper_loss_j, viscous_loss_j, load_work_j, magnetic_j, kinetic_j;
} plant_energy_t;

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
"""

ffibuilder = FFI()
ffibuilder.cdef(CDEF)
ffibuilder.set_source(
    "plant_rt._plant_c",
    '#include "plant.h"\n',
    sources=[str(C_DIR / name) for name in SOURCES],
    include_dirs=[str(C_DIR)],
    extra_compile_args=["-O2", "-std=c99"],
    libraries=["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
