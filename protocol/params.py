"""What each CONFIG parameter means: unit, kind (how it travels in the binary32 CONFIG.value) and meaning.

The DBC's ``Param`` value table is the single source of the ids and names; this table adds what a DBC
cannot say, once, for the spec (``python protocol/gen_docs.py`` writes docs/protocol.md section 6.2 from it),
for the scenario loader (``bench/scenario/scenario.py`` refuses an integer parameter given as 4.5 before anything
starts) and for the conformance kit. A test checks that it names exactly the parameters of the DBC.

Kinds (docs/protocol.md 6.2):

* ``real``: any finite binary32 in the parameter's unit;
* ``integer``: an integral value sent as its binary32 (4 pole pairs = 4.0);
* ``boolean``: 0.0 = off, 1.0 = on, nothing else;
* ``enum``: one of the listed integers, as binary32.

Angles and speeds: "mechanical" = of the rotor shaft, "electrical" = mechanical x pole pairs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

KINDS = ("real", "integer", "boolean", "enum")


@dataclass(frozen=True)
class ParamInfo:
    name: str
    unit: str
    kind: str
    meaning: str
    values: tuple[tuple[int, str], ...] = ()   # enum: (value, meaning)

    def check(self, value: float) -> str | None:
        """None if ``value`` is a valid value of this kind, else why not (names the rule)."""
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            return f"must be a finite number, got {value!r}"
        if abs(value) > 3.4028234663852886e38:
            return f"{value!r} does not fit a binary32 CONFIG value"
        if self.kind == "real":
            return None
        if float(value) != int(value):
            return f"is an {self.kind} parameter: must be a whole number, got {value!r}"
        if self.kind == "boolean" and value not in (0, 1):
            return f"is a boolean parameter: 0 (off) or 1 (on), got {value!r}"
        if self.kind == "enum" and int(value) not in {v for v, _ in self.values}:
            allowed = ", ".join(f"{v} = {m}" for v, m in self.values)
            return f"must be one of {allowed}; got {value!r}"
        return None


def _p(name: str, unit: str, kind: str, meaning: str, values: tuple[tuple[int, str], ...] = ()) -> ParamInfo:
    return ParamInfo(name, unit, kind, meaning, values)


#: Every parameter of the DBC's Param table, in id order.
PARAMS: tuple[ParamInfo, ...] = (
    _p("RS_OHM", "ohm", "real", "stator phase resistance"),
    _p("LD_H", "H", "real", "d-axis inductance"),
    _p("LQ_H", "H", "real", "q-axis inductance"),
    _p("PSI_F_WB", "Wb", "real", "permanent-magnet flux linkage (peak, per phase)"),
    _p("POLE_PAIRS", "-", "integer", "pole pairs (electrical angle = pole pairs x mechanical angle)"),
    _p("J_KGM2", "kg m^2", "real", "rotor inertia"),
    _p("B_NMS", "N m s/rad", "real", "viscous friction (per rad/s mechanical)"),
    _p("V_DC_NOM_V", "V", "real", "nominal DC bus voltage"),
    _p("CUR_KP_V_A", "V/A", "real", "current-loop proportional gain; <= 0: the controller derives it"),
    _p("CUR_KI_V_AS", "V/(A s)", "real", "current-loop integral gain; <= 0: derived"),
    _p("SPD_KP_A_RAD_S", "A/(rad/s)", "real", "speed-loop proportional gain per rad/s mechanical; <= 0: derived"),
    _p("SPD_KI_A_RAD", "A/rad", "real", "speed-loop integral gain per rad mechanical; <= 0: derived"),
    _p("IQ_MAX_A", "A", "real", "speed-loop output (q-current reference) limit"),
    _p("SPEED_LOOP_DIV", "-", "integer", "the speed loop runs every N control periods"),
    _p("I_MAX_TRIP_A", "A", "real", "over-current trip level on any phase"),
    _p("ALIGN_I_A", "A", "real", "start-up: alignment current"),
    _p("ALIGN_TIME_S", "s", "real", "start-up: alignment time"),
    _p("IF_I_A", "A", "real", "start-up: I-f (open-loop) current magnitude"),
    _p("IF_ACCEL_RAD_S2", "rad/s^2", "real", "start-up: open-loop acceleration, mechanical"),
    _p("HANDOVER_SPEED_RAD_S", "rad/s", "real",
       "start-up: open-loop speed at which the estimator takes over, mechanical"),
    _p("HANDOVER_TIME_S", "s", "real", "start-up: d-current ramp-down time after the hand-over"),
    _p("CTRL_DELAY_S", "s", "real", "computation delay t_d the controller assumes: sampling to new duties "
       "(the plant's own t_d, sent by the host)"),
    _p("SMO_K_V", "V", "real", "SMO switching gain; <= 0: derived"),
    _p("SMO_WC_RAD_S", "rad/s", "real", "SMO back-EMF low-pass cut-off (a filter frequency)"),
    _p("SMO_M_PER_A", "1/A", "real", "tanh SMO slope m"),
    _p("SMO_SIGMOID_A_PER_A", "1/A", "real", "sigmoid SMO slope a; <= 0: deadbeat slope"),
    _p("PLL_KP", "1/s", "real", "angle-tracking PLL proportional gain (electrical); <= 0: derived"),
    _p("PLL_KI", "1/s^2", "real", "angle-tracking PLL integral gain (electrical); <= 0: derived"),
    _p("SPEED_LPF_RAD_S", "rad/s", "real", "estimated-speed low-pass cut-off (a filter frequency); <= 0: none"),
    _p("SMO_K_FACTOR", "-", "real", "SMO gain as a multiple of the largest back EMF, when SMO_K_V is derived"),
    _p("SMO_K_MIN_V", "V", "real", "lower bound of a derived SMO gain"),
    _p("SMO_LAG_COMP", "-", "enum", "sigmoid SMO phase compensation",
       ((0, "none"), (1, "Yuan eq. 15"), (2, "effective"))),
    _p("HFI_U_V", "V", "real", "HF injection voltage amplitude"),
    _p("HFI_F_HZ", "Hz", "real", "HF injection frequency"),
    _p("HFI_BW_RAD_S", "rad/s", "real", "HFI tracking-loop bandwidth (a filter frequency)"),
    _p("HFI_PI_KP", "1/s", "real", "HFI tracking PI proportional gain (electrical); <= 0: from HFI_BW_RAD_S"),
    _p("HFI_PI_KI", "1/s^2", "real", "HFI tracking PI integral gain (electrical); <= 0: from HFI_BW_RAD_S"),
    _p("IPD_TIME_S", "s", "real", "initial-position detection time-out"),
    _p("HFI_POL_BIAS_A", "A", "real", "polarity test d-current bias; 0: HF current alone"),
    _p("HFI_LOCK_TOL_RAD", "rad", "real", "initial-position lock tolerance, electrical"),
    _p("DELAY_COMP_ENABLE", "-", "enum", "computation-delay pre-compensation (Gong eq. 20-22)",
       ((0, "off"), (1, "with DELAY_COMP_TD_S"), (2, "t_d estimated from the dual samples"))),
    _p("DELAY_COMP_TD_S", "s", "real", "the delay DELAY_COMP_ENABLE = 1 compensates"),
    _p("HARM_COMP_ENABLE", "-", "boolean", "5th/7th harmonic compensation (Yuan eq. 28-37)"),
    _p("HARM_GSDFT_M", "-", "integer", "GSDFT window length (samples)"),
    _p("HARM_COMP_GAIN", "-", "real", "harmonic compensation gain"),
    _p("HARM_EXTRACTOR", "-", "enum", "harmonic extractor", ((0, "GSDFT"), (1, "SDFT"))),
    # protection (firmware_stub/src/ctrl_protect.h, docs/faults.md); 0 switches a check off
    _p("PROT_OPEN_I_MIN_A", "A", "real", "open phase: a phase reference at least this large must "
       "show current"),
    _p("PROT_OPEN_RATIO", "-", "real", "open phase: measured below this fraction of the reference "
       "magnitude counts as open"),
    _p("PROT_OPEN_TIME_S", "s", "real", "open phase: for this long"),
    _p("PROT_SUM_MAX_A", "A", "real", "sensor plausibility: |i_a + i_b + i_c| low-passed above this"),
    _p("PROT_SUM_TAU_S", "s", "real", "sensor plausibility: time constant of that low-pass"),
    _p("PROT_STUCK_TIME_S", "s", "real", "stuck sensor: a reading that moves less than "
       "PROT_STUCK_DELTA_A for this long while the loop asks for current"),
    _p("PROT_STUCK_DELTA_A", "A", "real", "stuck sensor: the movement that counts as alive"),
    _p("PROT_VDC_UV_RATIO", "-", "real", "bus under-voltage below this fraction of V_DC_NOM_V"),
    _p("PROT_VDC_OV_RATIO", "-", "real", "bus over-voltage above this multiple of V_DC_NOM_V"),
    _p("PROT_VDC_TIME_S", "s", "real", "bus faults: for this long"),
    _p("PROT_LINK_TIMEOUT_PERIODS", "periods", "integer", "free-running ISR: no SENSE for this many "
       "periods is a LINK_TIMEOUT"),
    _p("PROT_ENC_LOST_TIME_S", "s", "real", "encoder (ENCODER estimator): no valid reading for this "
       "long is a SENSOR_FAULT"),
    _p("PROT_ENC_EMF_RATIO", "-", "real", "frozen encoder: back-EMF of the voltage balance above this "
       "fraction of V_DC_NOM_V / sqrt(3) while the reading stands still"),
    _p("PROT_ENC_FROZEN_TIME_S", "s", "real", "frozen encoder: for this long"),
    _p("PROT_STALL_TIME_S", "s", "real", "stall: the speed loop at IQ_MAX_A, that current delivered, "
       "for this long with less progress than PROT_STALL_SPEED_RAD_S is a STALL"),
    _p("PROT_STALL_SPEED_RAD_S", "rad/s", "real", "stall: the least the speed error must shrink over "
       "PROT_STALL_TIME_S at the limit, mechanical"),
    # super-twisting SMO (SMO_STA, firmware_stub/src/est_smo_sta.h: Hou's comparator)
    _p("SMO_STA_K1_V", "V/A^0.5", "real", "super-twisting SMO proportional gain k1; <= 0: from the speed "
       "estimate by the algorithm's convergence condition"),
    _p("SMO_STA_K2_V_S", "V/s", "real", "super-twisting SMO integral gain k2; <= 0: from the speed estimate"),
    # inverter-error feed-forward (firmware_stub/src/inv_comp.h, docs/inverter_comp.md)
    _p("INV_COMP_ENABLE", "-", "enum", "inverter dead-time and device-drop feed-forward on the duties and "
       "the observers' voltage",
       ((0, "off"), (1, "on, currents extrapolated to the middle of the interval the duties act on"),
        (2, "on, sampled currents"), (3, "on, the current loop's reference currents"),
        (4, "on, current-vector method: the measured vector low-passed in the rotating frame (with HF "
            "injection plus the injection's current, predicted at its frequency)"))),
    _p("INV_COMP_DEAD_TIME_S", "s", "real", "the drive's estimate of the inverter's effective dead time "
       "(below half the PWM period)"),
    _p("INV_COMP_V_SWITCH_V", "V", "real", "estimate of the switch on-state threshold drop"),
    _p("INV_COMP_R_SWITCH_OHM", "ohm", "real", "estimate of the switch on-state slope resistance"),
    _p("INV_COMP_V_DIODE_V", "V", "real", "estimate of the diode forward threshold drop"),
    _p("INV_COMP_R_DIODE_OHM", "ohm", "real", "estimate of the diode slope resistance"),
    _p("INV_COMP_BAND_A", "A", "real", "zero-crossing current: i_c = C_node V_dc / t_dt (capacitive shape) "
       "or the half-width of the linear band; > 0"),
    _p("INV_COMP_SHAPE", "-", "enum", "zero-crossing shape of the compensation",
       ((0, "linear band"), (1, "capacitive commutation (the plant's model)"))),
    _p("INV_COMP_I_BW_RAD_S", "rad/s", "real", "current-vector method (INV_COMP_ENABLE = 4): bandwidth of the "
       "low-pass on the measured current vector in the rotating frame (a filter frequency)"),
)

BY_NAME: dict[str, ParamInfo] = {p.name: p for p in PARAMS}


def markdown_table() -> str:
    """The parameter table of docs/protocol.md section 6.2 (written by protocol/gen_docs.py)."""
    from .messages import Param

    out = ["| id | parameter | unit | kind | meaning |", "|---|---|---|---|---|"]
    for p in PARAMS:
        kind = p.kind
        if p.values:
            kind += ": " + ", ".join(f"{v} = {m}" for v, m in p.values)
        out.append(f"| {int(Param[p.name])} | {p.name} | {p.unit} | {kind} | {p.meaning} |")
    return "\n".join(out) + "\n"
