"""The same PMSM in gym-electric-motor (GEM, PyPI ``gym-electric-motor``) and in this plant.

GEM's ``SynchronousMotorSystem`` with a continuous B6 bridge (action a -> duty (a + 1)/2, the
same averaged inverter), an ideal supply at the profile's V_dc, the profile's PMSM (r_s, l_d,
l_q, p, psi_p, j_rotor) and a ``PolynomialStaticLoad`` with the viscous coefficient b = B (no
Coulomb term, negligible load inertia). GEM converts the bridge voltage to dq with the angle at
the start of each step and holds u_dq constant over the step (in the rotor frame).

Feeding "the same dq voltages": GEM gets its ``control_space="dq"`` action a_dq = 2 u_dq / V_dc
each step. The plant holds its alpha-beta voltage constant over a period, so for each period it
gets the vector that has the requested u_dq as its AVERAGE in the rotor frame over the period:
placed at the rotor angle of the middle of the period (the plant's true angle and speed at t_k
extrapolated by Ts/2) and scaled by 1 / sinc(w_e Ts / 2). t_delay = 0 on the plant (GEM has no
computation delay). Both are then the same ODE driven by the same average voltage; what remains
is the within-period shape of u_dq (second order in w_e Ts) and GEM's solver tolerance.
"""
from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from hil_bench.plant_rt.plant import Plant
from hil_bench.plant_rt.profile import MotorProfile

from .openloop import duties_from_alphabeta

GEM_LIMITS = dict(i=1000.0, u=1000.0, omega=5000.0, torque=1000.0)


def gem_system(prof: MotorProfile, *, solver: str = "dopri5", control_space: str = "dq"):
    """GEM's physical system for a profile (ideal inverter, viscous load)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from gym_electric_motor import physical_systems as ps  # noqa: PLC0415

    mp = dict(p=prof.pole_pairs, l_d=prof.ld_h, l_q=prof.lq_h, j_rotor=prof.j_kgm2,
              r_s=prof.rs_ohm, psi_p=prof.psi_f_wb)
    ode = ps.EulerSolver() if solver == "euler" else ps.ScipyOdeSolver(integrator=solver)
    system = ps.SynchronousMotorSystem(
        supply=ps.IdealVoltageSupply(u_nominal=prof.v_dc_v),
        converter=ps.ContB6BridgeConverter(tau=prof.ts_s),
        motor=ps.PermanentMagnetSynchronousMotor(motor_parameter=mp, limit_values=GEM_LIMITS,
                                                 nominal_values=GEM_LIMITS),
        load=ps.PolynomialStaticLoad(load_parameter=dict(a=0.0, b=prof.b_nms, c=0.0, j_load=1e-12)),
        ode_solver=ode, tau=prof.ts_s, control_space=control_space)
    system.reset()
    return system


def gem_env(prof: MotorProfile, *, solver: str | None = None):
    """A full GEM environment (gym API, reward, references...) with the profile's motor, as a
    GEM user steps it: Cont-CC-PMSM-v0, tau = Ts, no visualisation, no constraint stops."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import gym_electric_motor as gem  # noqa: PLC0415
        from gym_electric_motor import physical_systems as ps  # noqa: PLC0415

    mp = dict(p=prof.pole_pairs, l_d=prof.ld_h, l_q=prof.lq_h, j_rotor=prof.j_kgm2,
              r_s=prof.rs_ohm, psi_p=prof.psi_f_wb)
    kw: dict[str, Any] = {}
    if solver == "euler":
        kw["ode_solver"] = ps.EulerSolver()
    env = gem.make("Cont-CC-PMSM-v0", visualization=None, constraints=(),
                   motor=dict(motor_parameter=mp, limit_values=GEM_LIMITS, nominal_values=GEM_LIMITS),
                   supply=dict(u_nominal=prof.v_dc_v),
                   load=ps.PolynomialStaticLoad(load_parameter=dict(a=0.0, b=prof.b_nms, c=0.0, j_load=1e-12)),
                   tau=prof.ts_s, **kw)
    env.reset()
    return env


def run_gem(prof: MotorProfile, u_dq: np.ndarray, *, solver: str = "dopri5") -> dict[str, np.ndarray]:
    """GEM driven by u_dq (n, 2) [V] per step from standstill; states after each step."""
    system = gem_system(prof, solver=solver)
    names = list(system.state_names)
    lim = np.asarray(system.limits, dtype=float)
    out = np.empty((len(u_dq), len(names)))
    for k, (ud, uq) in enumerate(u_dq):
        out[k] = np.asarray(system.simulate(np.array([2.0 * ud / prof.v_dc_v, 2.0 * uq / prof.v_dc_v]))) * lim
    return {"i_d_a": out[:, names.index("i_sd")], "i_q_a": out[:, names.index("i_sq")],
            "omega_m_rad_s": out[:, names.index("omega")], "torque_e_nm": out[:, names.index("torque")],
            "u_d_v": out[:, names.index("u_sd")], "u_q_v": out[:, names.index("u_sq")]}


def plant_for_gem(prof: MotorProfile) -> Plant:
    return Plant(prof, t_delay_s=0.0)


def run_plant(prof: MotorProfile, u_dq: np.ndarray) -> dict[str, np.ndarray]:
    """The plant driven by the same u_dq (period averages in the rotor frame, module doc)."""
    plant = plant_for_gem(prof)
    ts = prof.ts_s
    out = np.empty((len(u_dq), 5))
    for k, (ud, uq) in enumerate(u_dq):
        s = plant.snapshot()
        we = s.omega_e_rad_s
        x = 0.5 * we * ts
        gain = 1.0 if abs(x) < 1e-12 else x / math.sin(x)
        th = s.theta_e_rad + 0.5 * we * ts
        va = gain * (ud * math.cos(th) - uq * math.sin(th))
        vb = gain * (ud * math.sin(th) + uq * math.cos(th))
        plant.step(*duties_from_alphabeta(np.array([va]), np.array([vb]), prof.v_dc_v)[0])
        s = plant.snapshot()
        out[k] = (s.i_d_a, s.i_q_a, s.omega_m_rad_s, s.torque_e_nm, s.v_q_v)
    return {"i_d_a": out[:, 0], "i_q_a": out[:, 1], "omega_m_rad_s": out[:, 2], "torque_e_nm": out[:, 3],
            "u_q_v": out[:, 4]}


def voltage_program(prof: MotorProfile, n: int) -> np.ndarray:
    """A dq-voltage program that moves current and speed over the motor's range: a q step
    (start-up), a negative d step (field weakening direction, IPMSM reluctance torque) and a
    q reduction (regeneration)."""
    u = np.zeros((n, 2))
    v_rated = prof.rated["current_a"] * prof.rs_ohm
    u[:, 1] = 2.0 * v_rated + 0.6 * prof.psi_f_wb * prof.pole_pairs * prof.rated["speed_rad_s"] * np.minimum(
        np.arange(n) / (0.5 * n), 1.0)
    u[n // 3:, 0] = -1.5 * v_rated
    u[2 * n // 3:, 1] *= 0.7
    return u
