"""The named expansion rules of the claims registry: where a claim is a family of rows (speeds,
angles, compensation states, the diagnostic variants of a run), the TOML gives the paper's
numbers, words and rules once and one rule here writes the rows, so no row is copied by hand.

Two kinds:

* **variants** (``VARIANTS``): a diagnostic copy of a run - the same scenario with one thing of
  the bench changed (dead time off, the sign SMO's gain floor by eq. 5, a dynamometer's inertia,
  the controller's own current loop). A claim lists the ones it runs (``variants = [...]``); each
  of its runs is run again with each, and each row on such a run is measured on the copy too
  (``vary_quantity``: key and label say which copy, the row is diagnostic, it keeps the paper's
  value and rule but not the paper row's ``not_reproducible`` / ``calibration``);
* **tables** (``TABLES``): a claim's table named after the rule (``[Y8.speed_table]``) expands to
  runs, quantities and relations, appended after the claim's plain ones;
* **the switching inverter** (``switching``): a claim's ``[ID.switching]`` table names the runs
  (plain or from a table) that run again on the plant's switching inverter; each such run, each
  row on it and each relation over such rows gets a twin (``<id>.sw``, ``<key>.sw``, marked
  [switching inverter]), appended after everything else.

Every rule's output is pinned by tests/golden/claims_registry.json (``python -m
hil_bench.claims.registry --dump``): a change of a rule shows up as a reviewed diff of that file.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Callable

from .model import Quantity, Relation, Rule, Run, at_most, compared, within

# -- the diagnostic variants of a run ------------------------------------------------------------

#: the sign SMO's gain by Yuan's eq. 5 (Lyapunov: k > |E|) instead of the library's 5 V floor:
#: the adaptive k = 1.5 |w^| psi_f, floored at 1.5 x the back EMF of the lowest speed the claim
#: runs (10 rpm): yuan2020 1.5 x 0.32 V (Table 4), hou2021 1.5 x 3 x 1.047 x 0.303 = 1.43 V
K_EQ5_MIN_V = {"yuan2020": 0.48, "hou2021": 1.43}

#: Hou H2, a coupled dynamometer's inertia: the total inertia 6.5 N m needs for Hou's 1.2 rpm drop
#: with his 4.1 ms response: J >= T_L t_r / (2 dn) = 6.5 x 4.1e-3 / (2 x 0.1257 rad/s)
#: = 0.106 kg m^2 (docs/claims.md, 3)
H2_DYNO_J_KGM2 = 0.106
#: the speed loop at that inertia: the H2 scenarios' rule (kp = J w / Kt, ki = kp w / 4) at
#: w = 40 rad/s. At their 126 rad/s the 99x larger kp turns the HFI speed estimate's noise (tens of
#: rpm at 10 rpm) into i_q swings that reach the over-current trip (measured: a trip at 1.05 s).
_H2_DYNO_SPD_W = 40.0
_HOU_KT = 1.5 * 3 * 0.303

#: the controller's own current-loop rule (500 Hz: CUR_KP/KI = 0 select L w_c, R w_c) instead of
#: Y4's calibration loop
_STUB_LOOP = (("controller.params.CUR_KP_V_A", 0.0), ("controller.params.CUR_KI_V_AS", 0.0))


def _then(run: Run, suffix: str, overrides: tuple, label: str) -> Run:
    return Run(run.id + suffix, run.scenario, run.overrides + overrides,
               (run.label + ", " if run.label else "") + label)


def _nodt(run: Run, sign_smo: str) -> Run:
    """The same run with the inverter's dead time and drops off (a diagnostic, not the paper)."""
    return _then(run, ".nodt", (("plant.inverter_nonlinear", False),),
                 "dead time off (diagnostic)")


def _keq5(run: Run, sign_smo: str) -> Run:
    """The same sign-SMO run with the gain floor of eq. 5 (a diagnostic of the method)."""
    k = K_EQ5_MIN_V[sign_smo]
    return _then(run, ".keq5", (("controller.params.SMO_K_MIN_V", k),),
                 f"sign SMO gain floor {k:g} V by eq. 5 (diagnostic)")


def _dyno(run: Run, sign_smo: str) -> Run:
    """The same run with a coupled dynamometer's inertia and the speed loop retuned to it."""
    kp = H2_DYNO_J_KGM2 * _H2_DYNO_SPD_W / _HOU_KT
    return _then(run, ".dyno", (("plant.j_kgm2", H2_DYNO_J_KGM2),
                                ("controller.params.J_KGM2", H2_DYNO_J_KGM2),
                                ("controller.params.SPD_KP_A_RAD_S", round(kp, 4)),
                                ("controller.params.SPD_KI_A_RAD", round(kp * _H2_DYNO_SPD_W / 4, 3))),
                 f"motor + dynamometer J = {H2_DYNO_J_KGM2:g} kg m^2, speed loop "
                 f"{_H2_DYNO_SPD_W:g} rad/s (diagnostic)")


def _stubloop(run: Run, sign_smo: str) -> Run:
    """The same run with the controller's own 500 Hz current-loop rule (Y4's diagnostic)."""
    return _then(run, ".stubloop", _STUB_LOOP,
                 "the controller's own 500 Hz current loop (diagnostic)")


#: one change each, applied in the order of a variant's name (``nodt.keq5``: dead time off, then
#: the eq. 5 floor); the flag: only on a run where the sign SMO closes the loop (``sign_smo``)
_STEPS: dict[str, tuple[Callable[[Run, str], Run], bool]] = {
    "nodt": (_nodt, False), "keq5": (_keq5, True), "dyno": (_dyno, False),
    "stubloop": (_stubloop, False),
}

#: the variants a claim can list, and what a row measured on one adds to its label
VARIANTS: dict[str, str] = {
    "nodt": " [dead time off: diagnostic]",
    "keq5": " [k floor by eq. 5: diagnostic]",
    "nodt.keq5": " [k floor by eq. 5, dead time off: diagnostic]",
    "nodt.dyno": f" [dead time off, J = {H2_DYNO_J_KGM2:g} kg m^2 (motor + dynamometer): "
                 "diagnostic]",
    "stubloop": " [controller's own 500 Hz loop: diagnostic]",
}


def applies(variant: str, sign_smo: str) -> bool:
    """Whether a variant can run on a run (the eq. 5 floor needs the sign SMO in the loop)."""
    return all(bool(sign_smo) or not _STEPS[s][1] for s in variant.split("."))


def vary_run(run: Run, variant: str, sign_smo: str = "") -> Run:
    """The variant's copy of a run (id ``<run>.<variant>``)."""
    for step in variant.split("."):
        run = _STEPS[step][0](run, sign_smo)
    return run


def vary_quantity(q: Quantity, base_run: str, variant: str) -> Quantity:
    """A row of ``base_run`` measured on the variant's copy: key ``<run>.<variant>.<rest>``."""
    rid = f"{base_run}.{variant}"
    return dataclasses.replace(q, key=rid + q.key[len(base_run):], what=q.what + VARIANTS[variant],
                               run=rid, diagnostic=True, not_reproducible="", calibration="")


# -- rules as the TOML states them ---------------------------------------------------------------

#: the words-table entry of an ordering without a size (common.toml [[words]])
ORDERING = "better / faster / less / falls"

RULE_FIELDS = ("rule", "bound", "range", "inclusive", "rule_source", "words")


def rule_of(spec: dict[str, Any], paper_value: Any, where: str) -> Rule:
    """A rule from its TOML fields: ``rule = "at_most"`` (``bound``, default the paper's value),
    ``"within"`` (``range = [lo, hi]``, lo <= x < hi; ``inclusive = true``: hi too, to 1e-9) or
    ``"compared"``; ``rule_source``: the paper's words, section, table."""
    kind, source, words = spec.get("rule"), spec.get("rule_source"), spec.get("words", "")
    if not isinstance(source, str) or not source:
        raise ValueError(f"{where}: rule_source missing (the paper's words, section, table)")
    if not isinstance(words, str):
        raise ValueError(f"{where}: words must be an entry of the words table (common.toml)")
    extra = [k for k in ("bound", "range", "inclusive") if k in spec]
    if kind == "at_most":
        bound = spec.get("bound", paper_value)
        if isinstance(bound, bool) or not isinstance(bound, (int, float)):
            raise ValueError(f"{where}: rule at_most needs a number (bound, or a numeric paper_value)")
        if set(extra) - {"bound"}:
            raise ValueError(f"{where}: rule at_most takes bound only, not {extra}")
        return at_most(bound, source, words)
    if kind == "within":
        lo, hi = spec.get("range", (None, None))
        if not all(isinstance(v, (int, float)) for v in (lo, hi)) or set(extra) - {"range", "inclusive"}:
            raise ValueError(f"{where}: rule within needs range = [lo, hi] (and inclusive = true)")
        return within(lo, hi + 1e-9 if spec.get("inclusive") else hi, source, words)
    if kind == "compared":
        if extra:
            raise ValueError(f"{where}: rule compared takes no {', '.join(extra)}")
        return compared(source, words)
    raise ValueError(f"{where}: rule must be at_most, within or compared, got {kind!r}")


# -- tables ----------------------------------------------------------------------------------------

@dataclass
class Spec:
    """A claim's expansion table, read field by field; what is left over is an error."""

    table: dict[str, Any]
    where: str
    variants: tuple[str, ...]     # the claim's variants

    def get(self, name: str, default: Any = ...) -> Any:
        if name in self.table:
            return self.table[name]
        if default is ...:
            raise ValueError(f"{self.where}: {name} missing")
        return default

    def rule(self, name: str, paper_value: Any) -> Rule:
        return rule_of(self.get(name), paper_value, f"{self.where}.{name}")

    def unknown(self, known: tuple[str, ...]) -> None:
        left = sorted(set(self.table) - set(known))
        if left:
            raise ValueError(f"{self.where}: unknown field(s) {', '.join(left)}")


Expansion = tuple[list[Run], list[Quantity], list[Relation]]


def _copies(spec: Spec) -> list[str]:
    """The paper's setup ('') and the claim's variants, in order."""
    return [""] + list(spec.variants)


def _vary(run: Run, variant: str) -> Run:
    return vary_run(run, variant) if variant else run


def _smallest_fall(rows: list[dict], harmonics: list) -> tuple[float, str]:
    """The smallest relative fall (off - on) / off over a compensation table's values, and where
    it is (Yuan IV.C calls every one of them a significant decrease)."""
    falls = [((off - on) / off, f"{name} at {row['rpm']} rpm {off:g} -> {on:g} %")
             for row in rows for (name, _), off, on in zip(harmonics, row["off"], row["on"])]
    return min(falls)


def compensation_table(spec: Spec) -> Expansion:
    """Yuan Y4: per speed, the phase current's THD, 5th and 7th without and with compensation
    (runs ``Y4.<rpm>.off`` / ``.on``, the claim's plain runs), then the same on each variant run;
    one relation per harmonic and copy: it falls with the compensation. A relation with
    ``words`` "significantly decrease from a to b" is sized: the measured relative fall must
    reach the smallest relative fall the paper calls significant in its table (min_fall)."""
    spec.unknown(("harmonics", "rows", "rule", "rule_source", "calibration", "relation", "words"))
    harmonics = spec.get("harmonics")          # [[name, metric], ...]
    calib = spec.get("calibration", {})
    rel = spec.get("relation")
    rows = spec.get("rows")
    min_fall, fall_src = 0.0, ""
    if rel.get("words") == "significantly decrease from a to b":
        min_fall, where = _smallest_fall(rows, harmonics)
        fall_src = (f"the smallest relative fall the paper calls significant in the same sentence: "
                    f"{where} ({100 * min_fall:.1f} %); each relation's own fall is shown beside")
    qs, rels = [], []
    for row in rows:
        rpm = row["rpm"]
        for v in _copies(spec):
            loop = f".{v}" if v else ""
            sfx = VARIANTS[v] if v else ""
            for state in ("off", "on"):
                for (name, metric), val in zip(harmonics, row[state]):
                    key = f"Y4.{rpm}.{state}{loop}.{name}"
                    qs.append(Quantity(key, f"{rpm} rpm {name} "
                                            f"{'with' if state == 'on' else 'without'} compensation{sfx}",
                                       metric, val, rule_of(spec.table, val, spec.where),
                                       f"Y4.{rpm}.{state}{loop}", diagnostic=bool(v),
                                       calibration=calib.get("text", "") if key == calib.get("key") else ""))
            for (name, _), off, on in zip(harmonics, row["off"], row["on"]):
                paper = (f"{off:g} -> {on:g} % (-{100 * (off - on) / off:.1f} %)" if min_fall
                         else rel["paper"])
                rels.append(Relation(f"Y4.{rpm}{loop}.{name}",
                                     f"{rpm} rpm: {name} falls with the compensation{sfx}"
                                     + (f" by at least {100 * min_fall:.1f} %" if min_fall else ""),
                                     (f"Y4.{rpm}.on{loop}.{name}", f"Y4.{rpm}.off{loop}.{name}"), "<",
                                     paper, rel["source"], bool(v), words=rel.get("words", ""),
                                     min_fall=min_fall, min_fall_source=fall_src))
    return [], qs, rels


def y8_run(rpm: float) -> Run:
    """Yuan Y8: one constant speed per run of yuan_y8_speeds, the sensorless handover at
    min(rpm, 10) rpm, reached on the scenario's 0.5 rad/s^2 ramp after 0.2 s, then 2 s (1.5 s at
    10 rpm and below) of which the last 1 s is the window."""
    handover_rpm = min(rpm, 10.0)
    t_handover = 0.2 + handover_rpm * 2 * math.pi / 60 / 0.5
    dur = round(t_handover + (2.0 if rpm > 10 else 1.5), 2)
    ov: tuple = (("controller.speed_ref_rpm", rpm),
                 ("controller.params.HANDOVER_SPEED_RAD_S", handover_rpm * 2 * math.pi / 60),
                 ("scenario.duration_s", dur), ("metrics.window_s", [dur - 1.0, dur]))
    return Run(f"Y8.{rpm:g}rpm", "yuan_y8_speeds", ov, f"improved SMO at {rpm:g} rpm")


def speed_table(spec: Spec) -> Expansion:
    """Yuan Y8 (Table 4): per speed a run (``y8_run``) and its variants, the speed-estimation
    error against the paper's dn."""
    spec.unknown(("rows", "rule", "rule_source", "words"))
    runs, qs = [], []
    for row in spec.get("rows"):
        rpm, dn = row["rpm"], row["paper_value"]
        for v in _copies(spec):
            run = _vary(y8_run(rpm), v)
            runs.append(run)
            qs.append(Quantity(run.id, f"improved SMO: speed-estimation error at {rpm:g} rpm"
                               + (VARIANTS[v] if v else ""), "speed_est_error_rpm", dn,
                               rule_of(spec.table, dn, spec.where), run.id, at_speed_rpm=rpm,
                               diagnostic=bool(v)))
    return runs, qs, []


#: Hou H3's two polarity tests: Hou's own (HF only) and the d-bias option (a d-axis current bias
#: during the test: first order in the bias, not Hou's): (method, run label, row label)
_H3_METHODS = (("pure", "HF-only", "Hou's HF-only polarity test"),
               ("bias", "d-bias", "d-bias polarity test [option, not Hou's]"))
#: the row label of a method's dead-time-off copy
_H3_NODT = {"pure": "HF-only test, dead time off [diagnostic]",
            "bias": "d-bias test, dead time off [diagnostic]"}


def angle_table(spec: Spec) -> Expansion:
    """Hou H3 (Fig. 12): one run per initial angle, per polarity test and copy; per test and copy
    two rows over its runs: the largest |error| and the trials with the wrong polarity."""
    spec.unknown(("angles_deg", "bias_a", "error", "polarity"))
    angles = spec.get("angles_deg")
    runs, qs = [], []
    for method, run_label, tag in _H3_METHODS:
        for v in _copies(spec):
            ids = []
            for a in angles:
                ov: tuple = (("plant.initial_theta_e_rad", math.radians(a)),)
                if method == "bias":
                    ov += (("controller.params.HFI_POL_BIAS_A", spec.get("bias_a")),)
                run = _vary(Run(f"H3.{method}.{a:g}deg", "hou_h3_ipd", ov,
                                f"{a:g} deg, {run_label} polarity test"), v)
                runs.append(run)
                ids.append(run.id)
            label = _H3_NODT[method] if v == "nodt" else tag + (VARIANTS[v] if v else "")
            diag = bool(v) or method == "bias"
            err, pol = spec.get("error"), spec.get("polarity")
            qs.append(Quantity(f"H3.{method}{'.' + v if v else ''}.error",
                               f"{label}: largest |error| over 0..180 deg (trials with the right "
                               "polarity)", "ipd_error_deg", err["paper_value"],
                               spec.rule("error", err["paper_value"]), tuple(ids),
                               aggregate="max_abs", diagnostic=diag))
            qs.append(Quantity(f"H3.{method}{'.' + v if v else ''}.polarity",
                               f"{label}: trials with the wrong or no N/S polarity (of "
                               f"{len(angles)})", "ipd_error_deg", pol["paper_value"],
                               spec.rule("polarity", pol["paper_value"]), tuple(ids),
                               aggregate="polarity_failures", diagnostic=diag))
    return runs, qs, []


#: the rows of the G1 study on the switching trajectory: (label, unit, the paper's value's field)
_G1_SW_ROWS = {"thd": ("THD+N of the estimated EMF", "%"),
               "thd_h50": ("THD (harmonics 2-50) of the estimated EMF", "%"),
               "amp": ("EMF amplitude", "V")}
_G1_SW_VOLTAGE = {"cmd": "commanded voltage", "sw": "switched voltage"}


def _g1_switching_study(spec: Spec, rows: list[dict]) -> tuple[list[Quantity], list[Relation]]:
    """G1 on the switching plant's ripple (study G1.sw, bench/papers/studies.py g1_switching):
    per entry of ``switching_study`` (step_us, voltage: cmd | sw, rows: thd | thd_h50 | amp,
    diagnostic) a row per m, and per thd / amp entry the relation 'falls as m falls'."""
    amp, rel = spec.get("amp"), spec.get("switching_relation")
    qs, rels = [], []
    for i, e in enumerate(spec.get("switching_study")):
        where = f"{spec.where}.switching_study[{i}]"
        left = sorted(set(e) - {"step_us", "voltage", "rows", "diagnostic"})
        if left or e.get("voltage") not in _G1_SW_VOLTAGE or set(e.get("rows", ())) - set(_G1_SW_ROWS):
            raise ValueError(f"{where}: needs step_us, voltage ({' | '.join(_G1_SW_VOLTAGE)}), rows "
                             f"({' | '.join(_G1_SW_ROWS)}), optional diagnostic")
        step_us, volt, d = e["step_us"], e["voltage"], bool(e.get("diagnostic", False))
        tag = (f"host observer at {step_us:g} us on the switching plant's 500 rpm trajectory, "
               f"{_G1_SW_VOLTAGE[volt]}" + (" [diagnostic]" if d else ""))
        base = f"G1.sw{step_us:g}us.{volt}"
        for what in e["rows"]:
            label, unit = _G1_SW_ROWS[what]
            for r in rows:
                m = r["m"]
                paper = amp["paper_value"] if what == "amp" else r["thd_percent"]
                qs.append(Quantity(f"{base}.m{m:g}.{what}", f"m = {m:g}: {label}, {tag}", "study",
                                   paper, spec.rule("amp" if what == "amp" else "thd", paper),
                                   study="G1.sw", diagnostic=d,
                                   params=(("key", f"sw{step_us:g}.{volt}.m{m:g}.{what}"),
                                           ("unit", unit))))
            if what == "thd":
                rels.append(Relation(f"G1.thd.sw{step_us:g}us.{volt}", f"THD falls as m falls, {tag}",
                                     tuple(f"{base}.m{r['m']:g}.thd" for r in rows), ">",
                                     " > ".join(f"{r['thd_percent']:g}" for r in rows) + " %",
                                     rel["source"], d, words=ORDERING))
            if what == "amp":
                rels.append(Relation(f"G1.amp.sw{step_us:g}us.{volt}",
                                     f"EMF amplitude falls as m falls, {tag}",
                                     tuple(f"{base}.m{r['m']:g}.amp" for r in rows), ">",
                                     rel["amp_paper"], rel["source"], d, words=ORDERING))
    return qs, rels


def boundary_layer_table(spec: Spec) -> Expansion:
    """Gong G1 (Fig. 7): per boundary layer m the THD and the amplitude of the estimated EMF of
    the host reference observer ``SMO_TANH:m<m>`` in run G1, then the same observers at finer
    steps on the host (study G1), per step and m; then (``switching_study``) the same observers
    on the switching plant's trajectory (study G1.sw)."""
    spec.unknown(("rows", "thd", "amp", "study_steps_us", "switching_study", "switching_relation"))
    amp = spec.get("amp")
    rows = spec.get("rows")
    qs = []
    for r in rows:
        m = r["m"]
        qs.append(Quantity(f"G1.m{m:g}.thd", f"m = {m:g}: THD of the estimated EMF",
                           "emf_thd_percent", r["thd_percent"], spec.rule("thd", r["thd_percent"]),
                           "G1", source=f"reference:SMO_TANH:m{m:g}",
                           not_reproducible=r.get("not_reproducible", "")))
    for r in rows:
        m = r["m"]
        qs.append(Quantity(f"G1.m{m:g}.amp", f"m = {m:g}: amplitude of the estimated EMF",
                           "emf_amplitude_v", amp["paper_value"], spec.rule("amp", amp["paper_value"]),
                           "G1", source=f"reference:SMO_TANH:m{m:g}",
                           not_reproducible=r.get("not_reproducible", "")))
    for ts_us in spec.get("study_steps_us"):
        for r in rows:
            m = r["m"]
            qs.append(Quantity(f"G1.step{ts_us:g}us.m{m:g}.thd",
                               f"m = {m:g}: THD of the estimated EMF, host observer at Ts = "
                               f"{ts_us:g} us on an exact 500 rpm trajectory [diagnostic]",
                               "study", r["thd_percent"], spec.rule("thd", r["thd_percent"]),
                               study="G1", params=(("key", f"ts{ts_us:g}.m{m:g}.thd"), ("unit", "%")),
                               diagnostic=True))
            qs.append(Quantity(f"G1.step{ts_us:g}us.m{m:g}.amp",
                               f"m = {m:g}: EMF amplitude, Ts = {ts_us:g} us [diagnostic]",
                               "study", amp["paper_value"], spec.rule("amp", amp["paper_value"]),
                               study="G1", params=(("key", f"ts{ts_us:g}.m{m:g}.amp"), ("unit", "V")),
                               diagnostic=True))
    rels: list[Relation] = []
    if "switching_study" in spec.table:
        more_qs, rels = _g1_switching_study(spec, rows)
        qs += more_qs
    return [], qs, rels


#: Gong G6/G7: each speed's run length (s), its last 0.5 s the window (gong_g67_delay_comp)
G67_DURATION_S = {500.0: 1.5, 2000.0: 2.2, 3000.0: 2.8}


def g67_run(rpm: float, comp: bool | str) -> Run:
    """comp: False (the bench's delay-aware controller), True (Gong's pre-compensation) or
    "naive" (a DSP that ignores the delay: CTRL_DELAY_S = 0, its observer takes the command of
    k-1 as the voltage of [t_k-1, t_k] and its PWM angle is advanced by Ts/2 only)."""
    dur = G67_DURATION_S[rpm]
    ov: tuple = (("controller.speed_ref_rpm", rpm),
                 ("controller.params.DELAY_COMP_ENABLE", 2 if comp is True else 0),
                 ("scenario.duration_s", dur), ("metrics.window_s", [dur - 0.5, dur]))
    if comp == "naive":
        ov += (("controller.params.CTRL_DELAY_S", 0.0),)
        return Run(f"G67.{rpm:g}.naive", "gong_g67_delay_comp", ov,
                   f"{rpm:g} rpm, Gong's naive baseline: the controller ignores the delay "
                   "(diagnostic)")
    return Run(f"G67.{rpm:g}.{'on' if comp else 'off'}", "gong_g67_delay_comp", ov,
               f"{rpm:g} rpm, pre-compensation {'on' if comp else 'off'}")


def g67_window(rpm: float) -> tuple[float, float]:
    dur = G67_DURATION_S[rpm]
    return (dur - 0.5, dur)


def delay_comp_runs(spec: Spec) -> Expansion:
    """Gong G6/G7: per speed the runs without and with pre-compensation, then Gong's naive
    baseline per speed (diagnostic)."""
    spec.unknown(("speeds_rpm",))
    speeds = spec.get("speeds_rpm")
    return ([g67_run(rpm, c) for rpm in speeds for c in (False, True)]
            + [g67_run(rpm, "naive") for rpm in speeds], [], [])


#: a compensation state of the G6/G7 runs: (state, row label, diagnostic)
_G67_STATES = (("off", "compensation off", False), ("on", "compensation on", False),
               ("naive", "Gong's naive baseline [diagnostic]", True))
_NAIVE_SFX = " [against Gong's naive baseline: diagnostic]"


def lag_and_iq_table(spec: Spec) -> Expansion:
    """Gong G6 (Fig. 12-15): per speed and state the mean angle error and the controller's i_q
    (and the true i_q, diagnostic), one relation per speed (i_q falls with the compensation); then
    the lag removed and the i_q change, against 'without' and against the naive baseline."""
    spec.unknown(("rows", "pee_mean", "iq", "iq_true", "lag", "iq_change", "delay_s"))
    rows = spec.get("rows")
    pee, iq_true = spec.get("pee_mean"), spec.get("iq_true")
    qs, rels = [], []
    for r in rows:
        rpm, w = r["rpm"], tuple(r["window_s"])
        for state, tag, diag in _G67_STATES:
            run = f"G67.{rpm:g}.{state}"
            qs.append(Quantity(f"G6.{rpm:g}.{state}.pee_mean", f"{rpm:g} rpm mean angle error, {tag}",
                               "pee_mean_rad", pee["paper_value"],
                               spec.rule("pee_mean", pee["paper_value"]), run, window_s=w,
                               at_speed_rpm=rpm, diagnostic=diag))
            iq_paper = r["iq_on"] if state == "on" else r["iq_off"]
            qs.append(Quantity(f"G6.{rpm:g}.{state}.iq", f"{rpm:g} rpm mean i_q of the controller "
                               f"(its i_q reference), {tag}", "iq_ctrl_mean_a", iq_paper,
                               spec.rule("iq", iq_paper), run, window_s=w, at_speed_rpm=rpm,
                               diagnostic=diag))
            if state != "naive":
                qs.append(Quantity(f"G6.{rpm:g}.{state}.iq_true", f"{rpm:g} rpm mean true i_q (the "
                                   f"plant's frame), {tag} [diagnostic]", "iq_mean_a",
                                   iq_true["paper_value"], spec.rule("iq_true", iq_true["paper_value"]),
                                   run, window_s=w, at_speed_rpm=rpm, diagnostic=True))
        iq_rule = spec.rule("iq", r["iq_on"])
        rels.append(Relation(f"G6.iq{rpm:g}", f"{rpm:g} rpm: the controller's i_q falls with the "
                             "compensation", (f"G6.{rpm:g}.on.iq", f"G6.{rpm:g}.off.iq"), "<",
                             r["iq_relation"], iq_rule.source, words=ORDERING))
    td_s = spec.get("delay_s")
    for r in rows:
        if "lag_rad" not in r:
            continue
        rpm, lag = r["rpm"], r["lag_rad"]
        wtd = rpm / 60 * 2 * math.pi * 4 * td_s
        for base, diag in (("off", False), ("naive", True)):
            qs.append(Quantity(f"G6.{rpm:g}.lag" + ("" if base == "off" else ".naive"),
                               f"{rpm:g} rpm: lag removed (mean PEE with - without; w t_d = "
                               f"{wtd:.4f} rad){_NAIVE_SFX if diag else ''}", "derived", lag,
                               spec.rule("lag", lag),
                               params=(("op", "diff"), ("a", f"G6.{rpm:g}.on.pee_mean"),
                                       ("b", f"G6.{rpm:g}.{base}.pee_mean"), ("unit", "rad")),
                               diagnostic=diag))
    for r in rows:
        rpm, pct = r["rpm"], r["iq_change_percent"]
        for base, diag in (("off", False), ("naive", True)):
            qs.append(Quantity(f"G6.{rpm:g}.iq_change" + ("" if base == "off" else ".naive"),
                               f"{rpm:g} rpm: change of the controller's i_q with compensation"
                               f"{_NAIVE_SFX if diag else ''}", "derived", pct,
                               spec.rule("iq_change", pct),
                               params=(("op", "pct"), ("a", f"G6.{rpm:g}.on.iq"),
                                       ("b", f"G6.{rpm:g}.{base}.iq"), ("unit", "%")),
                               diagnostic=diag))
    return [], qs, rels


def table_iii(spec: Spec) -> Expansion:
    """Gong G7 (Table III): per speed and state the speed fluctuation, the EMF THD and the PEE
    (the naive baseline, diagnostic, against the paper's 'without' values); per speed and metric
    the relations 'with < without' and 'with < naive' (diagnostic)."""
    spec.unknown(("rows", "sf", "thd", "pee", "relation"))
    rel = spec.get("relation")
    qs, rels = [], []
    for r in spec.get("rows"):
        rpm, w = r["rpm"], g67_window(r["rpm"])
        for state, tag, diag in _G67_STATES:
            i = 1 if state == "on" else 0
            sf, thd = r["sf_rpm"][i], r["thd_percent"][i]
            pee = r["pee_rad"]
            run = f"G67.{rpm:g}.{state}"
            qs += [Quantity(f"G7.{rpm:g}.{state}.sf", f"{rpm:g} rpm SF, {tag}", "speed_band_hat_rpm",
                            sf, spec.rule("sf", sf), run, window_s=w, at_speed_rpm=rpm,
                            diagnostic=diag),
                   Quantity(f"G7.{rpm:g}.{state}.thd", f"{rpm:g} rpm EMF THD, {tag}",
                            "emf_thd_percent", thd, spec.rule("thd", thd), run, window_s=w,
                            diagnostic=diag),
                   Quantity(f"G7.{rpm:g}.{state}.pee", f"{rpm:g} rpm PEE, {tag}", "pee_max_rad", pee,
                            rule_of({**spec.get("pee"), "rule_source": r["pee_rule_source"]}, pee,
                                    f"{spec.where}.pee"), run, window_s=w, diagnostic=diag)]
        for m in ("sf", "thd"):
            rels.append(Relation(f"G7.{rpm:g}.{m}", f"{rpm:g} rpm: {m.upper()} with < without",
                                 (f"G7.{rpm:g}.on.{m}", f"G7.{rpm:g}.off.{m}"), "<", rel["paper"],
                                 rel["source"], compared=bool(rel.get("compared", False)),
                                 words=rel.get("words", "")))
            rels.append(Relation(f"G7.{rpm:g}.{m}.naive", f"{rpm:g} rpm: {m.upper()} with < "
                                 "Gong's naive baseline [diagnostic]",
                                 (f"G7.{rpm:g}.on.{m}", f"G7.{rpm:g}.naive.{m}"), "<", rel["paper"],
                                 rel["source"], True, compared=bool(rel.get("compared", False)),
                                 words=rel.get("words", "")))
    return [], qs, rels


#: the expansion tables a claim can hold, by name
TABLES: dict[str, Callable[[Spec], Expansion]] = {
    "compensation_table": compensation_table, "speed_table": speed_table,
    "angle_table": angle_table, "boundary_layer_table": boundary_layer_table,
    "delay_comp_runs": delay_comp_runs, "lag_and_iq_table": lag_and_iq_table,
    "table_iii": table_iii,
}


# -- the switching inverter: the same runs on the switching plant ---------------------------------

#: the overrides of a run's switching twin. pwm_load = immediate: the duties act at t_k + t_d, as in
#: the averaged runs and in Gong's premise (IV, Fig. 1: "the real actuation moment will always lag
#: behind the measurement (sampling) point by t_d"); only the ripple and the sample timing change
SWITCHING_OVERRIDES: tuple = (("plant.inverter", "switching"), ("plant.pwm_load", "immediate"))
SWITCHING_TAG = " [switching inverter]"
#: the averaged plant's rows of a claim its switching twins decide
AVERAGED_TAG = " [averaged plant: diagnostic]"
SWITCHING_SETUP = ("switching inverter (centre-aligned PWM, carrier valley at the sampling instant, "
                   "dead time and drops at each edge by the current's sign, duties acting at "
                   "t_k + t_d)")
#: a shadow twin: the compare values loaded at the next carrier extremum (the C2000's
#: CTR_ZERO_PRD shadow load), so the duties act at Ts/2 instead of t_k + t_d
SHADOW_OVERRIDES: tuple = (("plant.inverter", "switching"), ("plant.pwm_load", "extremum"))
SHADOW_LABEL = ("switching inverter, compare values shadow-loaded at the next carrier extremum "
                "(C2000 CTR_ZERO_PRD): the duties act at Ts/2 (diagnostic)")
SHADOW_TAG = (" [switching inverter, duties shadow-loaded at Ts/2 (the second sample still at "
              "t_k + t_d): diagnostic]")


def _twin_runs(q: Quantity, suffix: str) -> str | tuple[str, ...]:
    return tuple(r + suffix for r in q.runs) if len(q.runs) > 1 else q.runs[0] + suffix


def switching(spec: Spec, runs: list[Run], quantities: list[Quantity],
              relations: list[Relation]) -> tuple[Expansion, str]:
    """``[ID.switching]``: ``runs`` (ids of the claim's runs, plain or from its tables) run again
    on the switching inverter (run ``<id>.sw``, SWITCHING_OVERRIDES after the run's own); every
    row whose runs are all among them (no study row) is measured on the twins too (key
    ``<key>.sw``, label + " [switching inverter]", the same metric, value, rule, window and
    source); every derived row whose inputs all have twins is derived from the twins; every
    relation whose rows all have twins holds between the twins too.
    ``decides``: the twins decide the claim and the averaged rows (and their relations) become
    diagnostic, marked [averaged plant]: the claim's quantity depends on the PWM ripple or the
    sample instants (docs/claims.md, "One inverter policy"). ``diagnostic``: the twins are shown
    beside the averaged rows, which decide. Neither: both decide.
    ``lifts``: keys of rows whose ``not_reproducible`` reason is the averaged plant's and does not
    hold on the switching plant (their twins are judged). ``shadow``: runs among ``runs`` that
    also run with the duties shadow-loaded at the next carrier extremum (run ``<id>.sw.shadow``,
    rows ``<key>.sw.shadow``, diagnostic). Returns the added runs, rows and relations (the
    claim's rows and relations with the averaged ones re-marked when ``decides``), and the
    setup's addition."""
    spec.unknown(("runs", "diagnostic", "lifts", "shadow", "decides"))
    ids = list(spec.get("runs"))
    decides = spec.get("decides", False)
    diagnostic = spec.get("diagnostic", not decides)
    lifts, shadow = list(spec.get("lifts", [])), list(spec.get("shadow", []))
    if not isinstance(diagnostic, bool) or not isinstance(decides, bool):
        raise ValueError(f"{spec.where}.diagnostic / decides: true or false")
    if decides and diagnostic:
        raise ValueError(f"{spec.where}: decides = true and diagnostic = true contradict")
    by_id = {r.id: r for r in runs}
    missing = [r for r in ids if r not in by_id]
    if missing:
        raise ValueError(f"{spec.where}.runs: no run {', '.join(missing)} in the claim")
    if set(shadow) - set(ids):
        raise ValueError(f"{spec.where}.shadow: {', '.join(sorted(set(shadow) - set(ids)))} "
                         "not among its runs")

    def rows_on(run_ids: list[str]) -> list[Quantity]:
        return [q for q in quantities if not q.study and q.runs and set(q.runs) <= set(run_ids)]

    twinned = rows_on(ids)
    reasons = {q.key: q.not_reproducible for q in twinned}
    bad = [k for k in lifts if not reasons.get(k)]
    if bad:
        raise ValueError(f"{spec.where}.lifts: {', '.join(bad)} is no not-reproducible row on "
                         "the switching runs")

    def twin(q: Quantity, suffix: str, tag: str, diag: bool) -> Quantity:
        # the plant was fitted on the averaged inverter: a twin of a calibration row is a check
        return dataclasses.replace(q, key=q.key + suffix, what=q.what + tag,
                                   run=_twin_runs(q, suffix), diagnostic=q.diagnostic or diag,
                                   not_reproducible="" if q.key in lifts else q.not_reproducible,
                                   calibration="")

    out_runs = [_then(by_id[r], ".sw", SWITCHING_OVERRIDES, "switching inverter") for r in ids]
    out_qs = [twin(q, ".sw", SWITCHING_TAG, diagnostic) for q in twinned]
    keys = {q.key for q in twinned}
    for q in quantities:                     # derived rows whose inputs all have twins
        p = dict(q.params)
        if q.metric == "derived" and p.get("a") in keys and p.get("b") in keys:
            p = {**p, "a": p["a"] + ".sw", "b": p["b"] + ".sw"}
            out_qs.append(dataclasses.replace(q, key=q.key + ".sw", what=q.what + SWITCHING_TAG,
                                              params=tuple(p.items()),
                                              diagnostic=q.diagnostic or diagnostic))
            keys.add(q.key)
    out_rels = [dataclasses.replace(rel, key=rel.key + ".sw", what=rel.what + SWITCHING_TAG,
                                    keys=tuple(k if k.startswith("#") else k + ".sw"
                                               for k in rel.keys),
                                    diagnostic=rel.diagnostic or diagnostic)
                for rel in relations
                if all(k in keys for k in rel.keys if not k.startswith("#"))]
    out_runs += [_then(by_id[r], ".sw.shadow", SHADOW_OVERRIDES, SHADOW_LABEL) for r in shadow]
    out_qs += [twin(q, ".sw.shadow", SHADOW_TAG, True) for q in rows_on(shadow)]
    if decides:                              # the averaged rows and relations: diagnostic now
        moved = {k for k in keys}
        quantities[:] = [dataclasses.replace(q, what=q.what + AVERAGED_TAG, diagnostic=True,
                                             not_reproducible=q.not_reproducible)
                         if q.key in moved and not q.diagnostic else q for q in quantities]
        twinned_rels = {rel.key for rel in relations
                        if all(k in keys for k in rel.keys if not k.startswith("#"))}
        relations[:] = [dataclasses.replace(rel, what=rel.what + AVERAGED_TAG, diagnostic=True)
                        if rel.key in twinned_rels and not rel.diagnostic else rel
                        for rel in relations]
    setup = ("rows marked [switching inverter]: the same runs on the " + SWITCHING_SETUP
             + ("; they decide the claim, the averaged plant's rows are diagnostic" if decides
                else ""))
    return (out_runs, out_qs, out_rels), setup
