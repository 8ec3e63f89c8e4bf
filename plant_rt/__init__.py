"""hil_bench.plant_rt: the plant (PMSM + inverter + sensors + mechanics, in C) and the cycle
engine that steps it against the controller, with the motor profiles of the three papers.

Modules (only ``plant`` and ``engine`` need the compiled C module):
  profile   MotorProfile, load_profile, ProfileError (plant_rt/profiles/*.toml)
  plant     Plant (cffi over plant_rt/c), snapshot helpers
  engine    the cycle engine (plant_rt/c/engine.c): link I/O, plant, references, recording ring
  verify/   the plant checked against independent models: ``reference`` (solve_ivp), ``openloop``
            (open-loop duty sequences), ``gem_compare`` (gym-electric-motor), and the studies
            ``error_study`` (RK4 error vs sub-steps) and ``saturation_study`` (Hou's polarity)
Benchmarks of the plant are hil_bench.perf.plant_step and .plant_vs_gem; the Yuan dead-time
calibration (it uses the bench's metrics) is hil_bench.papers.calibrate_deadtime.
Nothing here imports the bench above it (tools/import_graph.py). See plant_rt/README.md.
"""
