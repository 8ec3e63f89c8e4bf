"""The plant against independent models: a scipy ``solve_ivp`` reference of the same circuit,
open-loop drives for it, gym-electric-motor's PMSM, and the studies that measure the plant's
numerical error and Hou's saturation polarity (python -m hil_bench.plant_rt.verify.<study>)."""
