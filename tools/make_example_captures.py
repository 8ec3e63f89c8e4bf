"""Make the example captures of ``bench replay`` (examples/captures/), all from one bench run.

    .venv/bin/python tools/make_example_captures.py [--out examples/captures]

1. ``example.mcap`` + ``example.serial.bin``: ``bench run replay_example.toml`` on the stub
   over a pty (the bench writes the serial byte capture beside every serial recording).
2. ``example.log.gz``: the same scenario over ``stub-socketcand`` (python-can's socketcand
   interface); the bench's CAN link writes the candump log with python-can's ``can.Logger``; it is
   gzip-compressed here (python-can's LogReader reads ``.log.gz``). Lockstep runs are
   deterministic, so both runs carry the same cycles (tests/test_replay.py checks it).
3. ``example_daq.csv`` + ``example_daq.toml``: what a DAQ at 5 kHz, its samples 100 us off the
   control instants, would have logged of the same run: the recorded duties drive the same
   plant (the recording's parameters) open loop on a grid of Ts/6, and every second sub-step is
   a DAQ sample: two phase currents in mA, the bus voltage, the three duties in %, the encoder
   angle in degrees, the time in ms from a trigger 10 ms before cycle 0.
"""
from __future__ import annotations

import argparse
import gzip
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SCENARIO = REPO / "examples" / "captures" / "replay_example.toml"
DAQ_SUBSTEPS = 6          #: plant sub-steps per control period (100 us)
DAQ_EVERY = 2             #: a DAQ sample every 2 sub-steps, on the odd ones: 5 kHz, 100 us
                          #: away from every control instant (a real resampling)
TRIGGER_S = 0.010         #: the DAQ's time 0 is 10 ms before cycle 0

MAPPING = """# Mapping of example_daq.csv (docs/replay.md "CSV mapping"): which column is what, in which unit.
[csv]
delimiter = ","

[time]
column = "Time [ms]"
unit = "ms"

[signals]
i_a = { column = "Ia [mA]", unit = "mA" }
i_b = { column = "Ib [mA]", unit = "mA" }          # i_c = -(i_a + i_b)
v_dc = { column = "Vdc [V]", unit = "V" }
duty_a = { column = "PWM A [%]", unit = "%" }
duty_b = { column = "PWM B [%]", unit = "%" }
duty_c = { column = "PWM C [%]", unit = "%" }
theta = { column = "Encoder [deg]", unit = "deg", frame = "electrical" }

[control]
ts_s = 600.0e-6        # the drive's control period
t0_s = 0.010           # the DAQ time of cycle 0 (its trigger was 10 ms earlier)
delay_s = 34.1e-6      # the drive's computation delay (a duty acts from t_k + delay_s)
"""


def run(cmd: list[str]) -> None:
    print("$", " ".join(cmd))
    subprocess.run(cmd, check=True, cwd=REPO)


def daq_export(recording: Path, csv_path: Path) -> None:
    from hil_bench.plant_rt.plant import Plant
    from hil_bench.plant_rt.profile import PARAM_FIELDS, load_profile
    from hil_bench.record.recording import load_recording

    rec = load_recording(recording)
    params = json.loads(rec.run["plant_params"])
    ts = float(params["ts_s"])
    te = rec.topics["/controller/telemetry"]
    duties = np.stack([te["duty_a"], te["duty_b"], te["duty_c"]], 1)
    fine = {k: v for k, v in params.items() if k in PARAM_FIELDS}
    t_d = float(fine["t_delay_s"])
    fine.update(ts_s=ts / DAQ_SUBSTEPS, t_delay_s=0.0)
    plant = Plant(load_profile(rec.run["profile"]), **fine)
    import tomllib

    scn = tomllib.loads(rec.attachment_text("scenario/")[1])
    plant.set_initial(float(scn["plant"].get("initial_theta_e_rad", 0.0)), 0.0)
    rows = []
    step = 0

    def sample(t_s: float, d) -> None:
        s = plant.snapshot()
        rows.append((t_s + TRIGGER_S, s.i_a_a, s.i_b_a, s.v_dc_v, *d, s.theta_e_rad))

    for k, d in enumerate(duties):
        for j in range(DAQ_SUBSTEPS):
            # DUTY(k) acts from t_k + t_d: the first sub-step splits there (plant_step_split)
            plant.step_split(*d, t_d if j == 0 else 0.0)
            step += 1
            if step % DAQ_EVERY == 1:
                sample(step * ts / DAQ_SUBSTEPS, d)
    with open(csv_path, "w") as f:
        f.write("Time [ms],Ia [mA],Ib [mA],Vdc [V],PWM A [%],PWM B [%],PWM C [%],Encoder [deg]\n")
        for t, ia, ib, vdc, da, db, dc, th in rows:
            f.write(f"{t * 1e3:.4f},{ia * 1e3:.2f},{ib * 1e3:.2f},{vdc:.2f},{da * 100:.4f},"
                    f"{db * 100:.4f},{dc * 100:.4f},{np.degrees(th):.4f}\n")
    print(f"wrote {csv_path}: {len(rows)} samples at {DAQ_SUBSTEPS / DAQ_EVERY / ts:.0f} Hz")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, default=REPO / "examples" / "captures")
    a = p.parse_args(argv)
    out = a.out
    out.mkdir(parents=True, exist_ok=True)
    bench = [sys.executable, "-m", "hil_bench"]
    run(bench + ["run", str(SCENARIO), "--out", str(out / "example.mcap"), "--force",
                 "--no-progress"])
    with tempfile.TemporaryDirectory() as tmp:
        can_rec = Path(tmp) / "example_can.mcap"
        run(bench + ["run", str(SCENARIO), "--link", "stub-socketcand", "--out", str(can_rec),
                     "--no-progress"])
        with open(can_rec.with_suffix(".log"), "rb") as src, \
                gzip.open(out / "example.log.gz", "wb", compresslevel=9) as dst:
            shutil.copyfileobj(src, dst)
    daq_export(out / "example.mcap", out / "example_daq.csv")
    (out / "example_daq.toml").write_text(MAPPING)
    for f in sorted(out.iterdir()):
        print(f"{f.stat().st_size:8d}  {f.relative_to(REPO) if f.is_relative_to(REPO) else f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
