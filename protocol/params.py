"""What each CONFIG parameter means: unit, kind (how it travels in the binary32 CONFIG.value), the enum's
values, the default, and the meaning with its formula where the controller derives or uses it by one.

The DBC's ``Param`` value table is the single source of the ids and names (its comment on CONFIG.param_id
points here); this table is the single source of everything else about a parameter, once, for the spec
(``python protocol/gen_docs.py`` writes docs/protocol.md section 6.2 from it), for the scenario loader
(``bench/scenario/scenario.py`` refuses an integer parameter given as 4.5 before anything starts) and for
the conformance kit. Tests check that it names exactly the parameters of the DBC, and that the C stub's
defaults, kinds and enum ranges (``firmware_stub/src/ctrl_params.c``, ``controller.c``) are these.

Defaults are the values a controller starts every session with (an accepted HELLO returns to them:
docs/protocol.md 6.1), the stub's. ``REQUIRED`` parameters have none: RUN before the session has set them
is an incomplete configuration (FAULT_CTRL CONFIG_INVALID, 6.3).

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

#: the default of a parameter that has none: the session must set it before RUN
REQUIRED = None


@dataclass(frozen=True)
class ParamInfo:
    name: str
    unit: str
    kind: str
    meaning: str
    values: tuple[tuple[int, str], ...] = ()   # enum: (value, meaning)
    default: float | None = REQUIRED          # REQUIRED (None): no default

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

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


def _p(name: str, unit: str, kind: str, meaning: str, values: tuple[tuple[int, str], ...] = (), *,
       default: float | None) -> ParamInfo:
    return ParamInfo(name, unit, kind, meaning, values, default)


#: Every parameter of the DBC's Param table, in id order.
PARAMS: tuple[ParamInfo, ...] = (
    _p("RS_OHM", "ohm", "real", "stator phase resistance", default=REQUIRED),
    _p("LD_H", "H", "real", "d-axis inductance", default=REQUIRED),
    _p("LQ_H", "H", "real", "q-axis inductance", default=REQUIRED),
    _p("PSI_F_WB", "Wb", "real", "permanent-magnet flux linkage (peak, per phase)", default=REQUIRED),
    _p("POLE_PAIRS", "-", "integer", "pole pairs (electrical angle = pole pairs x mechanical angle)", default=REQUIRED),
    _p("J_KGM2", "kg m^2", "real", "rotor inertia", default=REQUIRED),
    _p("B_NMS", "N m s/rad", "real", "viscous friction (per rad/s mechanical)", default=0),
    _p("V_DC_NOM_V", "V", "real", "nominal DC bus voltage", default=REQUIRED),
    _p("CUR_KP_V_A", "V/A", "real", "current-loop proportional gain, q axis (d axis: x LD_H / LQ_H); <= 0: the controller "
       "derives it, LQ_H w_i with w_i = 2 pi / (20 Ts), Ts = HELLO.period_us", default=0),
    _p("CUR_KI_V_AS", "V/(A s)", "real", "current-loop integral gain; <= 0: derived, RS_OHM w_i", default=0),
    _p("SPD_KP_A_RAD_S", "A/(rad/s)", "real", "speed-loop proportional gain per rad/s mechanical; <= 0: derived, J_KGM2 w_s / k_t with "
       "w_s = 62.83 rad/s and k_t = 1.5 POLE_PAIRS PSI_F_WB", default=0),
    _p("SPD_KI_A_RAD", "A/rad", "real", "speed-loop integral gain per rad mechanical; <= 0: derived, SPD_KP_A_RAD_S w_s / 4", default=0),
    _p("IQ_MAX_A", "A", "real", "speed-loop output (q-current reference) limit", default=5),
    _p("SPEED_LOOP_DIV", "-", "integer", "the speed loop runs every N control periods", default=1),
    _p("I_MAX_TRIP_A", "A", "real", "over-current trip level on any phase", default=30),
    _p("ALIGN_I_A", "A", "real", "start-up: alignment current", default=2),
    _p("ALIGN_TIME_S", "s", "real", "start-up: alignment time", default=0.2),
    _p("IF_I_A", "A", "real", "start-up: I-f (open-loop) current magnitude", default=2),
    _p("IF_ACCEL_RAD_S2", "rad/s^2", "real", "start-up: open-loop acceleration, mechanical", default=50),
    _p("HANDOVER_SPEED_RAD_S", "rad/s", "real",
       "start-up: open-loop speed at which the estimator takes over, mechanical", default=20),
    _p("HANDOVER_TIME_S", "s", "real", "start-up: d-current ramp-down time after the hand-over", default=0.05),
    _p("CTRL_DELAY_S", "s", "real", "computation delay t_d the controller assumes: sampling to new duties "
       "(the plant's own t_d, sent by the host)", default=0),
    _p("LOOP_ANGLE", "-", "enum", "the angle the closed loop's Park transforms use when an SMO closes it "
       "(HF injection and the encoder have one angle); also the angle TELEMETRY reports",
       ((0, "the observer's EMF angle (atan2 of the estimated EMF, lag-compensated)"),
        (1, "the PLL's angle that tracks it (type 2; the EMF angle's noise filtered at the PLL's bandwidth)")),
       default=0),
    _p("SMO_K_V", "V", "real", "SMO switching gain k; SMO_SIGN: <= 0 adapts it every step, k = max(SMO_K_MIN_V, SMO_K_FACTOR "
       "min(|w^| PSI_F_WB, 2 |E^| sqrt(1 + (w^ / SMO_WC_RAD_S)^2))); SMO_SIGMOID, SMO_TANH: **required** "
       "(> 0; the host sends Yuan eq. 18 / Gong eq. 17)", default=0),
    _p("SMO_WC_RAD_S", "rad/s", "real", "SMO back-EMF low-pass cut-off wc (a filter frequency): E^ = wc / (s + wc) {k F(i^ - i)}", default=1000),
    _p("SMO_M_PER_A", "1/A", "real", "tanh SMO slope m: the switching function is F(x) = tanh(m x) of the current error x = i^ - i "
       "in A (Gong eq. 8; boundary layer atanh(0.99) / m)", default=0.01),
    _p("SMO_SIGMOID_A_PER_A", "1/A", "real", "sigmoid SMO slope a: F(x) = 2 / (1 + exp(-a x)) - 1 (Yuan eq. 11); <= 0: the deadbeat slope "
       "2 f / (g k), f = exp(-RS_OHM Ts / LQ_H), g = (1 - f) / RS_OHM", default=0),
    _p("PLL_KP", "1/s", "real", "angle-tracking PLL proportional gain (electrical); <= 0: derived, 2 w_n with w_n = 150 rad/s", default=0),
    _p("PLL_KI", "1/s^2", "real", "angle-tracking PLL integral gain (electrical); <= 0: derived, w_n^2", default=0),
    _p("SPEED_LPF_RAD_S", "rad/s", "real", "estimated-speed first-order low-pass cut-off (a filter frequency); <= 0: none", default=0),
    _p("SMO_K_FACTOR", "-", "real", "SMO_SIGN's adaptive gain: k as a multiple of the back EMF (SMO_K_V <= 0, formula there)", default=1.5),
    _p("SMO_K_MIN_V", "V", "real", "SMO_SIGN's adaptive gain: its lower bound", default=5),
    _p("SMO_LAG_COMP", "-", "enum", "sigmoid SMO phase compensation",
       ((0, "none"), (1, "Yuan eq. 15"), (2, "effective")), default=1),
    _p("HFI_U_V", "V", "real", "HF injection voltage amplitude", default=6),
    _p("HFI_F_HZ", "Hz", "real", "HF injection frequency", default=1250),
    _p("HFI_BW_RAD_S", "rad/s", "real", "HFI tracking-loop bandwidth (a filter frequency)", default=150),
    _p("HFI_PI_KP", "1/s", "real", "HFI tracking PI proportional gain (electrical); <= 0: from HFI_BW_RAD_S, 2 w_n / s_e with "
       "w_n = HFI_BW_RAD_S and s_e the demodulated error's slope per rad (from HFI_U_V, HFI_F_HZ, LD_H, LQ_H)", default=0),
    _p("HFI_PI_KI", "1/s^2", "real", "HFI tracking PI integral gain (electrical); <= 0: from HFI_BW_RAD_S, w_n^2 / s_e", default=0),
    _p("IPD_TIME_S", "s", "real", "initial-position detection time-out", default=0.5),
    _p("HFI_POL_BIAS_A", "A", "real", "polarity test d-current bias; 0: HF current alone", default=0),
    _p("HFI_LOCK_TOL_RAD", "rad", "real", "initial-position lock tolerance, electrical", default=0.05),
    _p("DELAY_COMP_ENABLE", "-", "enum", "computation-delay pre-compensation (Gong eq. 20-22)",
       ((0, "off"), (1, "with DELAY_COMP_TD_S"), (2, "t_d estimated from the dual samples")), default=0),
    _p("DELAY_COMP_TD_S", "s", "real", "the delay DELAY_COMP_ENABLE = 1 compensates", default=0),
    _p("HARM_COMP_ENABLE", "-", "boolean", "5th/7th harmonic compensation (Yuan eq. 28-37)", default=0),
    _p("HARM_GSDFT_M", "-", "integer", "GSDFT window length (samples)", default=96),
    _p("HARM_COMP_GAIN", "-", "real", "harmonic compensation gain", default=1),
    _p("HARM_EXTRACTOR", "-", "enum", "harmonic extractor", ((0, "GSDFT"), (1, "SDFT")), default=0),
    # protection (firmware_stub/src/ctrl_protect.h, docs/faults.md); 0 switches a check off
    _p("PROT_OPEN_I_MIN_A", "A", "real", "open phase: a phase reference at least this large must "
       "show current", default=1),
    _p("PROT_OPEN_RATIO", "-", "real", "open phase: measured below this fraction of the reference "
       "magnitude counts as open", default=0.2),
    _p("PROT_OPEN_TIME_S", "s", "real", "open phase: for this long", default=0.02),
    _p("PROT_SUM_MAX_A", "A", "real", "sensor plausibility: |i_a + i_b + i_c| low-passed above this", default=1),
    _p("PROT_SUM_TAU_S", "s", "real", "sensor plausibility: time constant of that low-pass", default=0.005),
    _p("PROT_STUCK_TIME_S", "s", "real", "stuck sensor: a reading that moves less than "
       "PROT_STUCK_DELTA_A for this long while the loop asks for current", default=0.1),
    _p("PROT_STUCK_DELTA_A", "A", "real", "stuck sensor: the movement that counts as alive", default=0.5),
    _p("PROT_VDC_UV_RATIO", "-", "real", "bus under-voltage below this fraction of V_DC_NOM_V", default=0.7),
    _p("PROT_VDC_OV_RATIO", "-", "real", "bus over-voltage above this multiple of V_DC_NOM_V", default=1.25),
    _p("PROT_VDC_TIME_S", "s", "real", "bus faults: for this long", default=0.001),
    _p("PROT_LINK_TIMEOUT_PERIODS", "periods", "integer", "free-running ISR: no SENSE for this many "
       "periods is a LINK_TIMEOUT", default=10),
    _p("PROT_ENC_LOST_TIME_S", "s", "real", "encoder (ENCODER estimator): no valid reading for this "
       "long is a SENSOR_FAULT", default=0.001),
    _p("PROT_ENC_EMF_RATIO", "-", "real", "frozen encoder: back-EMF of the voltage balance above this "
       "fraction of V_DC_NOM_V / sqrt(3) while the reading stands still", default=0.1),
    _p("PROT_ENC_FROZEN_TIME_S", "s", "real", "frozen encoder: for this long", default=0.002),
    _p("PROT_STALL_TIME_S", "s", "real", "stall: the speed loop at IQ_MAX_A, that current delivered, "
       "for this long with less progress than PROT_STALL_SPEED_RAD_S is a STALL; with a back-EMF observer "
       "closing the loop also its EMF below 0.1 of |w^_e| PSI_F_WB (both low-passed over a quarter of this "
       "time, where |w^_e| PSI_F_WB >= 5 % of V_DC_NOM_V / sqrt(3)) once that has held for this long "
       "(docs/faults.md)", default=0.1),
    _p("PROT_STALL_SPEED_RAD_S", "rad/s", "real", "stall: the least the speed error must shrink over "
       "PROT_STALL_TIME_S at the limit, mechanical", default=1),
    # super-twisting SMO (SMO_STA, firmware_stub/src/est_smo_sta.h: Hou's comparator)
    _p("SMO_STA_K1_V", "V/A^0.5", "real", "super-twisting SMO proportional gain k1; <= 0: from the speed "
       "estimate by the algorithm's convergence condition", default=0),
    _p("SMO_STA_K2_V_S", "V/s", "real", "super-twisting SMO integral gain k2; <= 0: from the speed estimate", default=0),
    # inverter-error feed-forward (firmware_stub/src/inv_comp.h, docs/inverter_comp.md)
    _p("INV_COMP_ENABLE", "-", "enum", "inverter dead-time and device-drop feed-forward on the duties and "
       "the observers' voltage",
       ((0, "off"), (1, "on, currents extrapolated to the middle of the interval the duties act on"),
        (2, "on, sampled currents"), (3, "on, the current loop's reference currents"),
        (4, "on, current-vector method: the measured vector low-passed in the rotating frame (with HF "
            "injection plus the injection's current, predicted at its frequency)")), default=0),
    _p("INV_COMP_DEAD_TIME_S", "s", "real", "the drive's estimate of the inverter's effective dead time "
       "(below half the PWM period)", default=0),
    _p("INV_COMP_V_SWITCH_V", "V", "real", "estimate of the switch on-state threshold drop", default=0),
    _p("INV_COMP_R_SWITCH_OHM", "ohm", "real", "estimate of the switch on-state slope resistance", default=0),
    _p("INV_COMP_V_DIODE_V", "V", "real", "estimate of the diode forward threshold drop", default=0),
    _p("INV_COMP_R_DIODE_OHM", "ohm", "real", "estimate of the diode slope resistance", default=0),
    _p("INV_COMP_BAND_A", "A", "real", "zero-crossing current: i_c = C_node V_dc / t_dt (capacitive shape) "
       "or the half-width of the linear band; > 0", default=0.1),
    _p("INV_COMP_SHAPE", "-", "enum", "zero-crossing shape of the compensation",
       ((0, "linear band"), (1, "capacitive commutation (the plant's model)")), default=1),
    _p("INV_COMP_I_BW_RAD_S", "rad/s", "real", "current-vector method (INV_COMP_ENABLE = 4): bandwidth of the "
       "low-pass on the measured current vector in the rotating frame (a filter frequency)", default=628.3),
)

BY_NAME: dict[str, ParamInfo] = {p.name: p for p in PARAMS}

#: the motor's parameters: required (no default), the host always sends them (docs/protocol.md 6.2)
MOTOR: tuple[str, ...] = tuple(p.name for p in PARAMS if p.required)


def markdown_table() -> str:
    """The parameter table of docs/protocol.md section 6.2 (written by protocol/gen_docs.py)."""
    from .messages import Param

    out = ["| id | parameter | unit | kind | default | meaning |", "|---|---|---|---|---|---|"]
    for p in PARAMS:
        kind = p.kind
        if p.values:
            kind += ": " + ", ".join(f"{v} = {m}" for v, m in p.values)
        default = "**required**" if p.required else f"{p.default:g}"
        out.append(f"| {int(Param[p.name])} | {p.name} | {p.unit} | {kind} | {default} | {p.meaning} |")
    return "\n".join(out) + "\n"
