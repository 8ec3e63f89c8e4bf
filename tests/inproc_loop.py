"""The C plant (plant_rt) and the firmware's control ISR (firmware_stub/src/controller.c, through
hil_bench.firmware_stub._fw_c) closing the loop in one process, without a link: each step samples
the plant, runs ``ctrl_step`` on that sample and applies its duties. Shared by the tests that
drive the controller in-process (tests/test_fault_detection.py, tests/test_loop_angle.py); import
it after ``pytest.importorskip("hil_bench.firmware_stub._fw_c")``."""
from __future__ import annotations

from hil_bench.firmware_stub._fw_c import ffi, lib


class InProcessLoop:
    """``prof``: the motor profile the controller is configured from (the motor's parameters, its
    computation delay); ``plant``: the plant it drives; ``params``: CONFIG values (Param -> value)
    set through ``ctrl_param_set`` before the start."""

    def __init__(self, prof, plant, estimator: float, iq_max_a: float, speed_ref_rad_s: float,
                 params: dict | None = None):
        self.prof, self.plant = prof, plant
        self.c = ffi.new("controller_t *")
        lib.ctrl_init(self.c)
        cfg = self.c.cfg
        for name in ("rs_ohm", "ld_h", "lq_h", "psi_f_wb", "j_kgm2", "b_nms", "ts_s"):
            setattr(cfg, name, getattr(prof, name))
        cfg.pole_pairs = prof.pole_pairs
        cfg.v_dc_nom_v = prof.v_dc_v
        cfg.t_act_delay_s = prof.t_delay_s
        cfg.estimator = estimator
        cfg.iq_max_a = iq_max_a
        for pid, value in (params or {}).items():
            assert lib.ctrl_param_set(ffi.addressof(cfg), int(pid), float(value)) == 0, pid
        assert lib.ctrl_start(self.c) == 0
        lib.ctrl_set_speed_ref(self.c, speed_ref_rad_s)
        self.smp = ffi.new("ctrl_sample_t *")
        self.k = 0
        self.m = None
        self.out = None

    def step(self):
        m = self.plant.sample()
        s = self.smp
        s.i_a_a, s.i_b_a, s.i_c_a = m.i_a_a, m.i_b_a, m.i_c_a
        s.v_dc_v = m.v_dc_v
        s.v_dc_valid = 1                                     # measured from the first period
        s.theta_enc_rad = m.theta_enc_rad
        s.theta_enc_valid = m.enc_valid
        self.m = m
        self.out = lib.ctrl_step(self.c, s)
        self.plant.step(*self.out.duty_abc)
        self.k += 1
        return self.out

    def run_until(self, t_s: float) -> None:
        while self.k * self.prof.ts_s < t_s - 1e-12:
            self.step()
