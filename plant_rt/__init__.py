"""plant_rt: the HIL bench's plant (PMSM + inverter + mechanics) and its motor profiles.

Modules (import what you need; only ``plant`` needs the compiled C module):
  profile      MotorProfile, load_profile, ProfileError (plant_rt/profiles/*.toml)
  plant        Plant (cffi over plant_rt/c), snapshot helpers
  reference    independent solve_ivp model, for tests
  openloop     open-loop duty sequences (V/f ramp, rotor-synchronous voltage)
  error_study  RK4 error vs substeps (python -m plant_rt.error_study)
  bench_step   per-call cost of Plant.step (python -m plant_rt.bench_step)
  bench_vs_gem steps/s against gym-electric-motor (python -m plant_rt.bench_vs_gem)
  gem_compare  the same PMSM in gym-electric-motor and in the plant (tests, benchmark)
  calibrate_deadtime  closed-loop THD calibration of the Yuan profile (python -m ...)
  saturation_study    HF current towards N vs S, Hou's polarity (python -m ...)
See plant_rt/README.md.
"""
