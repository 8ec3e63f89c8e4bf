"""Python API over the C plant (cffi API mode, module ``hil_bench.plant_rt._plant_c``).

    from hil_bench.plant_rt.plant import Plant
    plant = Plant.from_profile("gong2020", t_delay_s=0.0)   # overrides are validated
    s = plant.snapshot()              # live cffi plant_snapshot_t: s.i_a_a, s.theta_e_rad, ...
    plant.step(0.6, 0.4, 0.5)         # one PWM period; duty < 0 disables a leg
    rec = snapshot_array(1000)        # numpy structured array, dtype SNAPSHOT_DTYPE
    buf = snapshot_buffer(rec)        # cffi view of it
    plant.snapshot_to(buf, 0)         # C writes the snapshot straight into rec[0]
    m = plant.sample()                # live cffi plant_sample_t: what the controller's ADC read
                                      # at t_k (m.i_a_a ...) and, with dual sampling, at
                                      # t_{k-1} + t_d (m.i2_a_a ...)

    Plant.from_profile("yuan2020", inverter_nonlinear=True, adc_model=1, adc_seed=7)
                                      # non-idealities: flat keys (plant_rt/profile.py)
    plant.set_fault("open_phase", phase="b")          # run-time faults (plant_rt/c/plant_fault.h)
    plant.set_fault("phase_short", phase="a", phase2="b", value=0.5)
    plant.clear_fault("open_phase"); plant.clear_faults()

Units are SI and named in the fields (see plant_rt/c/plant.h for the timing contract: the
snapshot after step k is taken at t_{k+1}, the next sampling instant).
"""
from __future__ import annotations

from dataclasses import fields, make_dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .profile import (
    PARAM_FIELDS,
    MotorProfile,
    ProfileError,
    c_struct,
    coerce_value,
    display_path,
    load_profile,
    unknown_key_error,
    validate_params,
)

try:
    from ._plant_c import ffi, lib
except ImportError as _exc:  # pragma: no cover - exercised by a subprocess test
    raise ImportError(
        "hil_bench.plant_rt._plant_c (the compiled C plant) is not built: run `make build` "
        "(or `.venv/bin/python tools/build_native.py`)"
    ) from _exc

#: run-time fault kinds (plant_fault_kind_t in plant_rt/c/plant_fault.h) -> C value
FAULT_KINDS: dict[str, int] = {
    "open_phase": 1,       # phase: the wire is disconnected (current 0 through the machine equations)
    "leg_stuck": 2,        # phase, level (1: upper switch shorted -> + rail, 0: lower -> - rail)
    "phase_short": 3,      # phase, phase2, value = R [ohm] between the two machine terminals
    "sensor_stuck": 4,     # phase, value = reading [A]
    "sensor_offset": 5,    # phase, value = offset [A]
    "sensor_gain": 6,      # phase, value = relative gain error (> -1)
    "sensor_dropout": 7,   # phase: reads 0 A
    "vdc": 8,              # value = bus voltage [V] (sag: set then clear; step: set)
    "encoder_loss": 9,     # sample().enc_valid = 0
    "encoder_stuck": 10,   # sample().theta_enc_rad frozen
    "locked_rotor": 11,    # speed held at 0 from the next period
    "load_torque": 12,     # value = extra load torque [N m] (a spike: set then clear)
}
_PHASES = {"a": 0, "b": 1, "c": 2, 0: 0, 1: 1, 2: 2}


def fault_kind(kind: str | int) -> int:
    """C value of a fault kind given by name (FAULT_KINDS) or number."""
    if isinstance(kind, str):
        if kind not in FAULT_KINDS:
            raise ValueError(f"unknown fault kind {kind!r}; known: {', '.join(FAULT_KINDS)}")
        return FAULT_KINDS[kind]
    if int(kind) not in FAULT_KINDS.values():
        raise ValueError(f"unknown fault kind {kind!r}")
    return int(kind)


def _phase(value: str | int, name: str) -> int:
    key = value.lower() if isinstance(value, str) else value
    if key not in _PHASES:
        raise ValueError(f"{name}: must be 'a', 'b', 'c' or 0..2, got {value!r}")
    return _PHASES[key]


#: plant_snapshot_t field names, in struct order (all double)
SNAPSHOT_FIELDS: tuple[str, ...] = tuple(name for name, _ in ffi.typeof("plant_snapshot_t").fields)
SNAPSHOT_SIZE: int = ffi.sizeof("plant_snapshot_t")
#: numpy dtype with the exact memory layout of plant_snapshot_t
SNAPSHOT_DTYPE = np.dtype({
    "names": list(SNAPSHOT_FIELDS),
    "formats": ["<f8"] * len(SNAPSHOT_FIELDS),
    "offsets": [f.offset for _, f in ffi.typeof("plant_snapshot_t").fields],
    "itemsize": SNAPSHOT_SIZE,
})
assert all(f.type is ffi.typeof("double") for _, f in ffi.typeof("plant_snapshot_t").fields)


def snapshot_array(n: int) -> np.ndarray:
    """Zeroed structured array of n snapshots (dtype SNAPSHOT_DTYPE)."""
    return np.zeros(n, dtype=SNAPSHOT_DTYPE)


def snapshot_buffer(array: np.ndarray) -> Any:
    """cffi ``plant_snapshot_t[]`` aliasing a C-contiguous SNAPSHOT_DTYPE array (no copy).

    Use ``buf + k`` as a ``plant_snapshot_t *`` (Plant.snapshot_to, lib.plant_snapshot,
    ffi.memmove(buf + k, plant.snapshot(), SNAPSHOT_SIZE)).
    """
    if array.dtype != SNAPSHOT_DTYPE or not array.flags.c_contiguous:
        raise ValueError("need a C-contiguous array of dtype SNAPSHOT_DTYPE (see snapshot_array)")
    return ffi.from_buffer("plant_snapshot_t[]", array, require_writable=True)


#: plant_sample_t field names, in struct order (doubles and ints)
SAMPLE_FIELDS: tuple[str, ...] = tuple(name for name, _ in ffi.typeof("plant_sample_t").fields)
#: numpy dtype with the exact memory layout of plant_sample_t
SAMPLE_DTYPE = np.dtype({
    "names": list(SAMPLE_FIELDS),
    "formats": ["<f8" if f.type is ffi.typeof("double") else "<i4"
                for _, f in ffi.typeof("plant_sample_t").fields],
    "offsets": [f.offset for _, f in ffi.typeof("plant_sample_t").fields],
    "itemsize": ffi.sizeof("plant_sample_t"),
})
assert all(f.type in (ffi.typeof("double"), ffi.typeof("int"))
           for _, f in ffi.typeof("plant_sample_t").fields)


def _as_dict(self) -> dict[str, Any]:
    return {f.name: getattr(self, f.name) for f in fields(self)}


#: Read-only copy of the parameters the plant was built with (SI; every flat key of
#: hil_bench.plant_rt.profile.PARAM_FIELDS: the 11 plant_params_t base fields, then the non-idealities).
PlantParams = make_dataclass(
    "PlantParams", [(name, Any) for name in PARAM_FIELDS], frozen=True,
    namespace={"as_dict": _as_dict, "__doc__": "Read-only copy of the plant parameters (SI)."})


class Plant:
    """PMSM + inverter + mechanics, one ``step`` per PWM/control period.

    Plant(profile, **overrides): any parameter (flat key, hil_bench.plant_rt.profile.PARAM_FIELDS) can be
    overridden (same validation as profile files; errors are ProfileError naming the profile
    file and the field). Non-idealities are switched on by overrides, e.g.
    ``Plant(prof, inverter_nonlinear=True, dead_time_s=2e-6)``.
    """

    def __init__(self, profile: MotorProfile, **overrides: Any):
        values = profile.plant_params()
        where = f"{display_path(profile.path)} (with overrides)"
        for key, value in overrides.items():
            if key not in PARAM_FIELDS:
                raise unknown_key_error(where, f"overrides.{key}", key, tuple(PARAM_FIELDS))
            section, kind = PARAM_FIELDS[key]
            values[key] = coerce_value(where, f"{section}.{key}", value, kind)
        validate_params(values, where, lambda n: f"{PARAM_FIELDS[n][0]}.{n}" if n in PARAM_FIELDS else n)
        self._profile = profile
        self._params = PlantParams(**values)  # type: ignore[arg-type]
        self._cparams = ffi.new("plant_params_t *", c_struct(values))
        self._pl = ffi.new("plant_t *")
        if lib.plant_init(self._pl, self._cparams) != 0:  # cannot happen after validate_params
            raise ProfileError(f"{where}: plant_init rejected the parameters")
        self._snap = ffi.new("plant_snapshot_t *")
        self._sample = ffi.new("plant_sample_t *")
        self._energy = ffi.new("plant_energy_t *")
        self._step_c = lib.plant_step_abc

    @classmethod
    def from_profile(cls, name_or_path: str | Path, **overrides: float | int) -> "Plant":
        """Load a profile (bare name -> plant_rt/profiles/<name>.toml) and build the plant."""
        return cls(load_profile(name_or_path), **overrides)

    # -- properties --------------------------------------------------------------------------
    @property
    def profile(self) -> MotorProfile:
        return self._profile

    @property
    def params(self) -> PlantParams:
        """Parameters in use (profile + overrides), read-only."""
        return self._params

    @property
    def t_s(self) -> float:
        """Present time [s] (= the next sampling instant)."""
        return self._pl.t_s

    @property
    def actuation_delay_s(self) -> float:
        """From a period's start until the duties commanded for it act [s]: t_delay_s (ts_s with
        full_period_delay); in the switching mode the load instant of the compare values
        (plant_rt/c/pwm.h: the next carrier extremum, the next period, or at once)."""
        return float(lib.plant_actuation_delay(self._pl))

    def step_trace(self, duty_a: float, duty_b: float, duty_c: float, n: int) -> dict[str, np.ndarray] | None:
        """One period, recorded at n equally spaced instants t_k + (j + 1) Ts / n (switching mode):
        ``i_alpha_a, i_beta_a, theta_e_rad`` there and ``v_alpha_v, v_beta_v`` averaged over the
        Ts / n before each. None if the period was not integrated at switch level (averaged
        mode, a disabled leg, a topology fault); the step is taken either way."""
        if n < 1:
            raise ValueError(f"n: must be >= 1, got {n}")
        arrays = {k: np.empty(n) for k in ("i_alpha_a", "i_beta_a", "v_alpha_v", "v_beta_v", "theta_e_rad")}
        tr = ffi.new("plant_trace_t *")
        tr.n = n
        for k, a in arrays.items():
            setattr(tr, k, ffi.from_buffer("double[]", a))
        duty = ffi.new("double[3]", [duty_a, duty_b, duty_c])
        ok = lib.plant_step_trace(self._pl, duty, tr) == 0
        return arrays if ok else None

    @property
    def sw_periods(self) -> int:
        """Periods integrated at switch level since the last reset (0 in the averaged mode; a
        period with a disabled leg or a topology fault takes the averaged path)."""
        return int(self._pl.sw_periods)

    @property
    def events(self) -> int:
        """Diode events located since the last reset (diagnostic)."""
        return self._pl.events

    # -- stepping ------------------------------------------------------------------------------
    @property
    def c_plant(self) -> Any:
        """The cffi ``plant_t *`` (for the C cycle engine, plant_rt/engine.py)."""
        return self._pl

    def step_split(self, duty_a: float, duty_b: float, duty_c: float, t_split_s: float) -> None:
        """One period with the actuation instant given (plant_step_split, plant.h)."""
        d = ffi.new("double[3]", [duty_a, duty_b, duty_c])
        lib.plant_step_split(self._pl, d, t_split_s)

    def step(self, duty_a: float, duty_b: float, duty_c: float) -> None:
        """Advance one period with these duties (high-side on-time fraction, [0, 1]; < 0 or NaN
        disables the leg; > 1 acts as 1). They take effect t_delay_s into the period."""
        self._step_c(self._pl, duty_a, duty_b, duty_c)

    def run(self, duties: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Step len(duties) periods ((n, 3) array); returns the n snapshots taken after each."""
        d = np.ascontiguousarray(duties, dtype=np.float64)
        if d.ndim != 2 or d.shape[1] != 3:
            raise ValueError(f"duties must have shape (n, 3), got {d.shape}")
        n = d.shape[0]
        if out is None:
            out = snapshot_array(n)
        elif out.shape != (n,):
            raise ValueError(f"out must have shape ({n},), got {out.shape}")
        lib.plant_run(self._pl, ffi.cast("const double *", ffi.from_buffer(d)), n,
                      snapshot_buffer(out))
        return out

    # -- observation ---------------------------------------------------------------------------
    def snapshot(self) -> Any:
        """The plant's snapshot as a live cffi ``plant_snapshot_t *`` (read fields directly).

        The same object is refreshed by every call: copy what you keep (snapshot_dict,
        snapshot_to, ffi.memmove).
        """
        lib.plant_snapshot(self._pl, self._snap)
        return self._snap

    def snapshot_to(self, buffer: Any, index: int) -> None:
        """Write the snapshot into element ``index`` of a ``snapshot_buffer`` (no Python copy)."""
        lib.plant_snapshot(self._pl, buffer + index)

    def snapshot_dict(self) -> dict[str, float]:
        """The snapshot as a plain dict {field: value}."""
        s = self.snapshot()
        return {name: getattr(s, name) for name in SNAPSHOT_FIELDS}

    def sample(self) -> Any:
        """What the controller's ADC measured for the period starting now, as a live cffi
        ``plant_sample_t *`` (refreshed by every call; see plant.h "Sampling"):
        i_a_a, i_b_a, i_c_a, v_dc_v at t_k; with dual sampling i2_a_a, i2_b_a, i2_c_a at
        t2_s = t_{k-1} + t_d (dual_valid = 1 from the second period on); raw codes code_*."""
        lib.plant_sample(self._pl, self._sample)
        return self._sample

    def sample_dict(self) -> dict[str, float | int]:
        """The sample as a plain dict {field: value}."""
        m = self.sample()
        return {name: getattr(m, name) for name in SAMPLE_FIELDS}

    def load_torque_at(self, t_s: float) -> float:
        """Load torque the plant applies at time t [N m]: set torque + load profile (not the dyno)."""
        return lib.plant_load_torque_at(self._pl, t_s)

    def energy(self) -> dict[str, float]:
        """Energy bookkeeping since the last reset [J] (see plant_energy_t in plant.h)."""
        lib.plant_energy(self._pl, self._energy)
        e = self._energy
        return {name: getattr(e, name) for name, _ in ffi.typeof("plant_energy_t").fields}

    # -- control -------------------------------------------------------------------------------
    def set_load_torque(self, torque_nm: float) -> None:
        """Load torque [N m] from now on, added to the profile's load_profile; positive opposes
        positive rotation. Ignored in dyno mode (the dynamometer imposes the speed)."""
        lib.plant_set_load_torque(self._pl, torque_nm)

    def set_dyno_speed(self, omega_m_rad_s: float) -> None:
        """Dynamometer set speed [rad/s, mechanical] (dyno mode; the speed slews to it at
        dyno_accel_rad_s2, or steps at the next period start if that is 0)."""
        lib.plant_set_dyno_speed(self._pl, omega_m_rad_s)

    def set_initial(self, theta_e_rad: float, omega_m_rad_s: float) -> None:
        """Rotor electrical angle [rad] (wrapped) and mechanical speed [rad/s]; currents and t kept."""
        lib.plant_set_initial(self._pl, theta_e_rad, omega_m_rad_s)

    def reset(self) -> None:
        """Back to t = 0, zero currents and speed (dyno mode: the dyno's set speed), no load
        torque, previous duties 0.5, noise generator reseeded (the same samples again)."""
        lib.plant_reset(self._pl)

    # -- faults (plant_rt/c/plant_fault.h) ----------------------------------------------------
    def set_fault(self, kind: str | int, *, phase: str | int = 0, phase2: str | int = 1,
                  level: int = 1, value: float = 0.0) -> None:
        """Switch a fault on from now (t_k) on; see FAULT_KINDS for what each field means.
        Raises ValueError (with the C check's reason) if the fault cannot be set."""
        f = ffi.new("plant_fault_t *")
        f.kind = fault_kind(kind)
        f.phase = _phase(phase, "phase")
        f.phase2 = _phase(phase2, "phase2")
        f.level = int(level)
        f.value = float(value)
        msg = lib.plant_fault_check(self._pl, f)
        if msg != ffi.NULL:
            raise ValueError(f"fault {kind!r}: {ffi.string(msg).decode()}")
        if lib.plant_set_fault(self._pl, f) != 0:  # pragma: no cover - checked above
            raise ValueError(f"fault {kind!r}: refused")

    def clear_fault(self, kind: str | int, phase: str | int | None = None) -> None:
        """Switch a fault kind off (phase: only that leg / sensor for leg_stuck and sensor_*)."""
        lib.plant_clear_fault(self._pl, fault_kind(kind), -1 if phase is None else _phase(phase, "phase"))

    def clear_faults(self) -> None:
        """Every fault off (reset() does this too)."""
        lib.plant_clear_faults(self._pl)

    def faults_active(self) -> list[str]:
        """Names of the fault kinds that are on."""
        mask = lib.plant_faults_active(self._pl)
        return [name for name, v in FAULT_KINDS.items() if mask & (1 << v)]

    def fault_status(self) -> dict[str, Any]:
        """What the faults do now: short current (averaged model), leg currents, bus voltage,
        energy absorbed at a phase interruption, diagnostics (plant_fault_status_t)."""
        st = ffi.new("plant_fault_status_t *")
        lib.plant_fault_status(self._pl, st)
        out = {name: getattr(st, name) for name, _ in ffi.typeof("plant_fault_status_t").fields}
        out["active"] = self.faults_active()
        return out

    def step_abc(self, duties: Sequence[float]) -> None:
        """``step`` with a 3-sequence of duties."""
        self._step_c(self._pl, duties[0], duties[1], duties[2])
