"""Studies beyond the papers, in the claims report (rows no paper has):

1. **Error against speed**, 5 .. 3000 rpm, every back-EMF estimator (sign, sigmoid, tanh SMO:
   host references on an encoder loop, gong2020) and HF injection (closing the loop, hou2021),
   each with the non-idealities on (dead time, drops, ADC, delay) and off (ideal inverter),
   on one plot.
2. **Initial position over 0 .. 360 deg** in 5 deg steps with both polarity tests (Hou's
   HF-only, the d-bias), dead time on and off: error and polarity success rate.
3. **Parameter sensitivity**: each estimator closing the loop with the controller told a wrong
   Rs (+-30 %), Ld and Lq (+-20 %, both), psi_f (+-10 %) - SMOs at 500 rpm on gong2020, HFI at
   50 rpm on hou2021; ideal inverter, ADC and delay on (the parameter effect alone).
4. **Speed reversal** +500 -> -500 rpm through zero with each SMO closing the loop (the SMOs'
   direction handling, est_common est_emf_angle_step), and HFI +50 -> -50 rpm.

``plan()`` lists the runs, ``evaluate(plan, rep)`` measures them after the report ran them,
``markdown`` / ``html_section`` write the section; plots go to ``<out>/plots/beyond_*.png``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hil_bench.claims.model import Run
from hil_bench.record import channels as ch

from . import metrics


def _savefig(fig, path) -> None:
    """The figure written aside (a temporary name beside it) and renamed into place."""
    import os
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.png")
    fig.savefig(tmp, dpi=90)
    os.replace(tmp, path)

SPEEDS_RPM = (5, 10, 20, 50, 100, 200, 500, 1000, 2000, 3000)
SPEEDS_QUICK = (10, 100, 1000, 3000)
SMOS = ("SMO_SIGN", "SMO_SIGMOID", "SMO_TANH")
#: reversal runs: each SMO with the library's settings, the sign SMO also with a fixed gain, HFI
REVERSALS = SMOS + ("SMO_SIGN.k25", "HFI_SDFT")
MISMATCH = (("nominal", ()), ("Rs -30%", (("RS_OHM", 0.7),)), ("Rs +30%", (("RS_OHM", 1.3),)),
            ("Ld,Lq -20%", (("LD_H", 0.8), ("LQ_H", 0.8))),
            ("Ld,Lq +20%", (("LD_H", 1.2), ("LQ_H", 1.2))),
            ("psi_f -10%", (("PSI_F_WB", 0.9),)), ("psi_f +10%", (("PSI_F_WB", 1.1),)))


def case_id(name: str) -> str:
    """A mismatch case as a run id: a scenario name allows letters, digits, '_', '-', '@' and
    '.' only ("Rs +30%" -> "Rs_plus30pct", "Ld,Lq -20%" -> "LdLq_minus20pct")."""
    return (name.replace(",", "").replace(" +", "_plus").replace(" -", "_minus")
            .replace("%", "pct").replace(" ", "_"))


@dataclass
class Plan:
    runs: list[Run] = field(default_factory=list)
    speeds: tuple = SPEEDS_RPM
    ipd_step_deg: int = 5
    quick: bool = False


def _speed_window(rpm: float, p: int) -> tuple[float, float]:
    """Settle 0.3 s, then at least one electrical period (and 0.3 s)."""
    period = 60.0 / (rpm * p)
    return 0.3, 0.3 + max(0.3, period)


def plan(quick: bool = False) -> Plan:
    from hil_bench.plant_rt.profile import load_profile
    pl = Plan(speeds=SPEEDS_QUICK if quick else SPEEDS_RPM, ipd_step_deg=30 if quick else 5,
              quick=quick)
    gong, hou = load_profile("gong2020"), load_profile("hou2021")
    for rpm in pl.speeds:
        for dt in (True, False):
            tag = "" if dt else ".ideal"
            w0, w1 = _speed_window(rpm, gong.pole_pairs)
            pl.runs.append(Run(f"B.smo.{rpm}rpm{tag}", "beyond_smo_speed",
                               (("plant.initial_speed_rpm", float(rpm)),
                                ("controller.speed_ref_rpm", float(rpm)),
                                ("plant.inverter_nonlinear", dt),
                                ("scenario.duration_s", round(w1, 3)),
                                ("metrics.window_s", [w0, round(w1, 3)])),
                               f"SMOs as references at {rpm} rpm" + ("" if dt else ", ideal inverter")))
            # HFI from standstill: the initial-position procedure, the speed loop, then the window
            t_up = 0.25 + rpm * 2 * math.pi / 60 * hou.j_kgm2 / 4.0   # ~4 N m to accelerate
            period = 60.0 / (rpm * hou.pole_pairs)
            hw0 = round(0.6 + t_up, 3)
            hw1 = round(hw0 + max(0.3, period), 3)
            pl.runs.append(Run(f"B.hfi.{rpm}rpm{tag}", "beyond_hfi_speed",
                               (("controller.speed_ref_rpm", float(rpm)),
                                ("plant.inverter_nonlinear", dt),
                                ("scenario.duration_s", hw1), ("metrics.window_s", [hw0, hw1])),
                               f"HFI closes the loop at {rpm} rpm" + ("" if dt else ", ideal inverter")))
    for method in ("pure", "bias"):
        for dt in (True, False):
            for a in range(0, 360, pl.ipd_step_deg):
                ov = (("plant.initial_theta_e_rad", math.radians(a)),
                      ("plant.inverter_nonlinear", dt))
                if method == "bias":
                    ov += (("controller.params.HFI_POL_BIAS_A", 2.4),)
                pl.runs.append(Run(f"B.ipd.{method}.{a}{'' if dt else '.ideal'}", "hou_h3_ipd", ov))
    for est in SMOS + ("HFI_SDFT",):
        prof = hou if est == "HFI_SDFT" else gong
        for name, scale in MISMATCH:
            ov = tuple((f"controller.params.{p}", getattr(prof, {"RS_OHM": "rs_ohm", "LD_H": "ld_h",
                                                                  "LQ_H": "lq_h",
                                                                  "PSI_F_WB": "psi_f_wb"}[p]) * f)
                       for p, f in scale) + (("plant.inverter_nonlinear", False),)
            if est == "HFI_SDFT":
                base = "beyond_hfi_speed"
                ov += (("scenario.duration_s", 1.2), ("metrics.window_s", [0.8, 1.2]))
            else:
                base = "beyond_reversal"
                ov += (("controller.estimator", est), ("plant.adc_model", True),
                       ("plant.t_delay_s", 34.1e-6), ("events", []),
                       ("scenario.duration_s", 1.5), ("metrics.window_s", [1.0, 1.5]))
            pl.runs.append(Run(f"B.sens.{est}.{case_id(name)}", base, ov,
                               f"{est}, controller told {name}"))
    for est in SMOS:
        pl.runs.append(Run(f"B.rev.{est}", "beyond_reversal", (("controller.estimator", est),),
                           f"{est}: +500 -> -500 rpm"))
    # the sign SMO with gong_g2_500rpm's fixed gain instead of the library's adaptive one
    pl.runs.append(Run("B.rev.SMO_SIGN.k25", "beyond_reversal",
                       (("controller.estimator", "SMO_SIGN"),
                        ("controller.params.SMO_K_V", 25.0), ("controller.params.SMO_WC_RAD_S", 300.0)),
                       "SMO_SIGN, k = 25 V, wc = 300 rad/s: +500 -> -500 rpm"))
    pl.runs.append(Run("B.rev.HFI_SDFT", "beyond_hfi_speed",
                       (("plant.inverter_nonlinear", False), ("scenario.duration_s", 1.6),
                        ("metrics.window_s", [1.2, 1.6]),
                        ("events", [{"t_s": 0.8, "speed_ref_rpm": -50.0,
                                     "label": "+50 -> -50 rpm"}])),
                       "HFI: +50 -> -50 rpm, ideal inverter"))
    return pl


# -- measuring ---------------------------------------------------------------------------------------

def _rec(rep, rid):
    from hil_bench.record.recording import load_recording
    o = rep.outcomes.get(rid)
    if o is None or not o.recording.exists():
        return None
    try:
        return load_recording(o.recording)
    except Exception:  # noqa: BLE001
        return None


def _errors(rec, topic, window):
    """(max |PEE| rad, mean PEE rad, max |n^ - n| rpm, mean true speed) in the window: the
    claims' metrics (hil_bench.papers.metrics.angle_error, speed_error_band_rpm) on the estimate of
    ``topic`` and the plant truth at the same cycles."""
    st = rec.topic(ch.PLANT_STATE)
    if topic not in rec.topics:
        return (math.nan,) * 4
    te = rec.topic(topic)
    t = np.asarray(te["t_s"], float)
    m = metrics.window_mask(t, window)
    if not np.any(m):
        return (math.nan,) * 4
    idx = np.clip(np.searchsorted(st["t_s"], t[m]), 0, len(st["t_s"]) - 1)
    pee = metrics.angle_error(np.asarray(te["theta_hat_rad"])[m],
                              np.asarray(st["theta_e_rad"])[idx])
    if not math.isfinite(pee.max_abs_rad):
        return (math.nan,) * 4
    n = np.asarray(st["speed_rpm"])[idx]
    return (pee.max_abs_rad, pee.mean_rad,
            metrics.speed_error_band_rpm(np.asarray(te["speed_hat_rpm"])[m], n),
            float(np.mean(n)))


def _window(rep, rid):
    return dict(rep.outcomes[rid].run.overrides).get("metrics.window_s")


def evaluate(pl: Plan, rep) -> dict:
    out: dict = {"plan": pl, "speed": [], "ipd": [], "sens": [], "rev": [], "plots": []}
    for rpm in pl.speeds:
        for tag in ("", ".ideal"):
            rid = f"B.smo.{rpm}rpm{tag}"
            rec = _rec(rep, rid)
            w = _window(rep, rid) if rid in rep.outcomes else None
            for est in SMOS:
                e = _errors(rec, ch.REFERENCE_PREFIX + est, w) if rec is not None else (math.nan,) * 4
                out["speed"].append(dict(est=est, rpm=rpm, ideal=bool(tag), pee_max=e[0],
                                         pee_mean=e[1], n_err=e[2], n_mean=e[3]))
            rid = f"B.hfi.{rpm}rpm{tag}"
            rec = _rec(rep, rid)
            w = _window(rep, rid) if rid in rep.outcomes else None
            e = _errors(rec, ch.CONTROLLER_TELEMETRY, w) if rec is not None else (math.nan,) * 4
            fail = rep.outcomes[rid].error.splitlines()[0] if rid in rep.outcomes and \
                rep.outcomes[rid].error else ""
            held = metrics.holds_speed(e[3], rpm)
            out["speed"].append(dict(est="HFI_SDFT", rpm=rpm, ideal=bool(tag), pee_max=e[0],
                                     pee_mean=e[1], n_err=e[2], n_mean=e[3], held=held,
                                     error=fail))
    for method in ("pure", "bias"):
        for tag in ("", ".ideal"):
            for a in range(0, 360, pl.ipd_step_deg):
                rid = f"B.ipd.{method}.{a}{tag}"
                rec = _rec(rep, rid)
                err = math.nan
                if rec is not None:
                    te = rec.topic(ch.CONTROLLER_TELEMETRY)
                    t = np.asarray(te["t_s"], float)
                    m = t >= metrics.window_start_s(rec)
                    if np.any(m) and not rep.outcomes[rid].error:
                        # the claims' initial-position error (H3): the circular mean of PEE
                        err = math.degrees(metrics.mean_angle_rad(np.asarray(te["pee_rad"])[m]))
                out["ipd"].append(dict(method=method, ideal=bool(tag), angle=a, err_deg=err))
    for est in SMOS + ("HFI_SDFT",):
        for name, _ in MISMATCH:
            rid = f"B.sens.{est}.{case_id(name)}"
            rec = _rec(rep, rid)
            w = _window(rep, rid) if rid in rep.outcomes else None
            e = _errors(rec, ch.CONTROLLER_TELEMETRY, w) if rec is not None else (math.nan,) * 4
            fail = rep.outcomes[rid].error.splitlines()[0] if rid in rep.outcomes and \
                rep.outcomes[rid].error else ""
            ref = 50.0 if est == "HFI_SDFT" else 500.0
            out["sens"].append(dict(est=est, case=name, pee_max=e[0], pee_mean=e[1], n_err=e[2],
                                    n_mean=e[3], held=metrics.holds_speed(e[3], ref),
                                    error=fail))
    for est in REVERSALS:
        rid = f"B.rev.{est}"
        rec = _rec(rep, rid)
        final = -50.0 if est == "HFI_SDFT" else -500.0
        row = dict(est=est, done=False, n_final=math.nan, pee_final=math.nan,
                   pee_cross=math.nan)
        if rec is not None:
            st = rec.topic(ch.PLANT_STATE)
            te = rec.topic(ch.CONTROLLER_TELEMETRY)
            t = np.asarray(st["t_s"], float)
            n = np.asarray(st["speed_rpm"], float)
            late = t >= t[-1] - 0.3
            row["n_final"] = float(np.mean(n[late])) if np.any(late) else math.nan
            row["done"] = bool(abs(row["n_final"] - final) <= 0.05 * abs(final))
            pee = np.asarray(te["pee_rad"], float)      # wrap(theta^ - theta), per cycle
            row["pee_final"] = (metrics.angle_error(pee[late], 0.0 * pee[late]).max_abs_rad
                                if np.any(late) else math.nan)
            t_ev = 0.8 if est == "HFI_SDFT" else 1.5
            after = t >= t_ev
            cross = np.nonzero(after & (n <= 0))[0]
            if cross.size:
                tc = t[cross[0]]
                mm = (t >= tc - 0.05) & (t <= tc + 0.1)
                row["pee_cross"] = metrics.angle_error(pee[mm], 0.0 * pee[mm]).max_abs_rad
                row["t_cross"] = float(tc)
        out["rev"].append(row)
    out["plots"] = _plots(out, rep)
    return out


# -- plots ------------------------------------------------------------------------------------------

def _plots(out, rep):
    from hil_bench.installation import require_extra

    matplotlib = require_extra("the claims report's plots", "matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.8))
    for est, color in zip(SMOS + ("HFI_SDFT",), ("C0", "C1", "C2", "C3")):
        for ideal, style in ((False, "o-"), (True, "s--")):
            rows = [r for r in out["speed"] if r["est"] == est and r["ideal"] == ideal]
            xs = [r["rpm"] for r in rows]
            lab = f"{est}{' (HFI closes the loop, hou2021)' if est == 'HFI_SDFT' else ''}" \
                  f"{', ideal inverter' if ideal else ', dead time + ADC'}"
            axes[0].loglog(xs, [max(r["pee_max"], 1e-4) for r in rows], style, color=color,
                           label=lab, ms=4)
            axes[1].loglog(xs, [max(r["n_err"], 1e-2) for r in rows], style, color=color, ms=4)
    axes[0].axhline(math.pi / 2, color="k", lw=0.6, ls=":")
    axes[0].set_xlabel("speed [rpm]")
    axes[0].set_ylabel("max |PEE| in the window [rad]")
    axes[0].set_title("position-estimation error vs speed (SMOs: references on an encoder loop, "
                      "gong2020)", fontsize=8)
    axes[0].legend(fontsize=6)
    axes[1].set_xlabel("speed [rpm]")
    axes[1].set_ylabel("max |n^ - n| [rpm]")
    axes[1].set_title("speed-estimation error vs speed", fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
    fig.suptitle("Beyond the papers: every estimator from 5 to 3000 rpm", fontsize=10)
    fig.tight_layout()
    p = rep.out_dir / "plots" / "beyond_error_vs_speed.png"
    _savefig(fig, p)
    plt.close(fig)
    paths.append(p)

    fig, ax = plt.subplots(figsize=(11, 4.5))
    for (method, ideal), style in zip(((m, i) for m in ("pure", "bias") for i in (False, True)),
                                      ("o", "x", "s", "+")):
        rows = [r for r in out["ipd"] if r["method"] == method and r["ideal"] == ideal]
        ok = [r for r in rows if math.isfinite(r["err_deg"])]
        rate = sum(1 for r in ok if abs(r["err_deg"]) < 90) / max(len(rows), 1)
        undecided = sum(1 for r in rows if not math.isfinite(r["err_deg"]))
        ax.plot([r["angle"] for r in rows], [r["err_deg"] for r in rows], style, ms=5,
                mfc="none", label=f"{'HF-only (Hou)' if method == 'pure' else 'd-bias'}"
                f"{', ideal inverter' if ideal else ', dead time'}: polarity right "
                f"{100 * rate:.0f} %, undecided {undecided}")
    ax.axhspan(-1, 1, color="g", alpha=0.15)
    ax.set_xlabel("actual initial position [deg el.]")
    ax.set_ylabel("estimate - actual [deg]")
    ax.set_title("Beyond: initial position over 0..360 deg, both polarity tests (+-180: wrong "
                 "polarity; no marker: undecided, the procedure faulted)", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    p = rep.out_dir / "plots" / "beyond_initial_position.png"
    _savefig(fig, p)
    plt.close(fig)
    paths.append(p)

    fig, axes = plt.subplots(1, 2, figsize=(13, 4.5))
    cases = [n for n, _ in MISMATCH]
    x = np.arange(len(cases))
    for k, est in enumerate(SMOS + ("HFI_SDFT",)):
        rows = {r["case"]: r for r in out["sens"] if r["est"] == est}
        axes[0].bar(x + (k - 1.5) * 0.2, [rows[c]["pee_mean"] if c in rows else np.nan
                                          for c in cases], 0.2, label=est)
        axes[1].bar(x + (k - 1.5) * 0.2, [rows[c]["pee_max"] if c in rows else np.nan
                                          for c in cases], 0.2, label=est)
    for ax, lab in zip(axes, ("mean PEE (bias) [rad]", "max |PEE| [rad]")):
        ax.set_xticks(x, cases, rotation=20, fontsize=8)
        ax.set_ylabel(lab)
        ax.grid(alpha=0.3, axis="y")
        ax.legend(fontsize=7)
    fig.suptitle("Beyond: parameter mismatch (the controller told a wrong value); SMOs 500 rpm "
                 "gong2020, HFI 50 rpm hou2021", fontsize=10)
    fig.tight_layout()
    p = rep.out_dir / "plots" / "beyond_sensitivity.png"
    _savefig(fig, p)
    plt.close(fig)
    paths.append(p)

    fig, axes = plt.subplots(2, len(REVERSALS), figsize=(4 * len(REVERSALS), 6))
    for j, est in enumerate(REVERSALS):
        rec = _rec(rep, f"B.rev.{est}")
        if rec is None:
            continue
        st, te = rec.topic(ch.PLANT_STATE), rec.topic(ch.CONTROLLER_TELEMETRY)
        t0 = 1.3 if est != "HFI_SDFT" else 0.6
        axes[0][j].set_ylabel("speed [rpm]")
        m = np.asarray(st["t_s"]) >= t0
        mt = np.asarray(te["t_s"]) >= t0
        axes[0][j].plot(np.asarray(st["t_s"])[m], np.asarray(st["speed_rpm"])[m], label="n")
        axes[0][j].plot(np.asarray(te["t_s"])[mt], np.asarray(te["speed_hat_rpm"])[mt], lw=0.8,
                        label="n^")
        axes[0][j].set_title(f"{est}: reversal", fontsize=9)
        axes[0][j].legend(fontsize=7)
        axes[1][j].plot(np.asarray(te["t_s"])[mt], np.asarray(te["pee_rad"])[mt], lw=0.8)
        axes[1][j].set_ylabel("PEE [rad]")
        axes[1][j].set_xlabel("t [s]")
        for ax in axes[:, j]:
            ax.grid(alpha=0.3)
    fig.suptitle("Beyond: speed reversal through zero (SMOs +-500 rpm gong2020 ideal, library "
                 "settings; SMO_SIGN.k25: fixed k = 25 V; HFI +-50 rpm hou2021)", fontsize=10)
    fig.tight_layout()
    p = rep.out_dir / "plots" / "beyond_reversal.png"
    _savefig(fig, p)
    plt.close(fig)
    paths.append(p)
    return paths


# -- writing --------------------------------------------------------------------------------------

def _f(v, fmt=".3g"):
    return "n/a" if v is None or not math.isfinite(v) else format(v, fmt)


def _tables(out) -> list[tuple[str, list[str], list[list[str]]]]:
    t = []
    speeds = sorted({r["rpm"] for r in out["speed"]})
    rows = []
    for est in SMOS + ("HFI_SDFT",):
        for ideal in (False, True):
            rs = {r["rpm"]: r for r in out["speed"] if r["est"] == est and r["ideal"] == ideal}
            rows.append([est + (" ideal" if ideal else "")]
                        + [f"{_f(rs[s]['pee_max'])} / {_f(rs[s]['n_err'])}" if s in rs else "-"
                           for s in speeds])
    t.append(("Error against speed: max |PEE| [rad] / max |n^ - n| [rpm] in the window "
              "(SMOs: references on an encoder loop; HFI: closes the loop)",
              ["estimator"] + [f"{s} rpm" for s in speeds], rows))
    rows = []
    for method in ("pure", "bias"):
        for ideal in (False, True):
            rs = [r for r in out["ipd"] if r["method"] == method and r["ideal"] == ideal]
            ok = [r for r in rs if math.isfinite(r["err_deg"]) and abs(r["err_deg"]) < 90]
            worst = max((abs(r["err_deg"]) for r in ok), default=math.nan)
            rows.append([f"{'HF-only (Hou)' if method == 'pure' else 'd-bias'}"
                         f"{', ideal inverter' if ideal else ', dead time'}",
                         str(len(rs)), f"{100 * len(ok) / max(len(rs), 1):.0f} %",
                         _f(worst), str(sum(1 for r in rs if not math.isfinite(r["err_deg"])))])
    t.append(("Initial position over 0..360 deg", ["polarity test", "trials", "polarity right",
                                                   "max |error| of those [deg]",
                                                   "procedure failed (undecided)"], rows))
    rows = []
    for r in out["sens"]:
        rows.append([r["est"], r["case"], _f(r["pee_mean"]), _f(r["pee_max"]), _f(r["n_err"]),
                     "yes" if r["held"] else ("no: " + r["error"] if r["error"] else "no")])
    t.append(("Parameter mismatch (controller told a wrong value; SMOs 500 rpm, HFI 50 rpm)",
              ["estimator", "mismatch", "mean PEE [rad]", "max |PEE| [rad]",
               "max |n^ - n| [rpm]", "speed held"], rows))
    rows = [[r["est"], "yes" if r["done"] else "no", _f(r["n_final"]), _f(r["pee_cross"]),
             _f(r["pee_final"])] for r in out["rev"]]
    t.append(("Speed reversal through zero", ["estimator", "reversed", "final speed [rpm]",
                                              "max |PEE| around the crossing [rad]",
                                              "max |PEE| at the end [rad]"], rows))
    return t


def markdown(rep) -> list[str]:
    out = rep.beyond
    L = ["## Beyond the papers", "",
         "Rows no paper has; no verdicts (see bench/papers/beyond.py for the set-up of each)."
         + (" Quick grid (--quick)." if out["plan"].quick else ""), ""]
    for title, head, rows in _tables(out):
        head_md = [c.replace("|", "\\|") for c in head]
        L += [f"### {title}", "", "| " + " | ".join(head_md) + " |", "|" + "---|" * len(head)]
        L += ["| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |" for r in rows]
        L.append("")
    for p in out["plots"]:
        L += [f"![{p.stem}]({p.relative_to(rep.out_dir)})", ""]
    return L


def html_section(rep, img) -> list[str]:
    import html as h
    out = rep.beyond
    H = ["<h2 id='beyond'>Beyond the papers</h2><p>Rows no paper has; no verdicts.</p>"]
    for title, head, rows in _tables(out):
        H.append(f"<h3>{h.escape(title)}</h3><table><tr>"
                 + "".join(f"<th>{h.escape(c)}</th>" for c in head) + "</tr>")
        for r in rows:
            H.append("<tr>" + "".join(f"<td>{h.escape(str(c))}</td>" for c in r) + "</tr>")
        H.append("</table>")
    for p in out["plots"]:
        H.append(img(p))
    return H
