"""PNG plots of the claims report: per claim, what the paper's figure shows, from the recordings.

Each ``plot_<claim>(rep)`` returns the figures it drew (a claim without a usable recording gets
a figure that says so instead of a blank). matplotlib with the Agg backend (no display needed):
the "report" extra, imported when the report draws (bench/papers/report.py imports this module
then).
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Callable

from hil_bench.installation import require_extra

matplotlib = require_extra("the claims report's plots", "matplotlib")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hil_bench.record import channels as ch  # noqa: E402

from . import metrics  # noqa: E402

DPI = 90


def deciding_id(rep, run_id: str) -> str:
    """The run that decides in place of ``run_id``: its switching twin ``<id>.sw`` where the
    claim's verdict rows read the twin (docs/claims.md, "One inverter policy"), else the run."""
    ids = getattr(rep, "_deciding_runs", None)
    if ids is None:
        ids = {r for c in rep.claims for q in c.quantities if not q.diagnostic for r in q.runs}
        rep._deciding_runs = ids
    return run_id + ".sw" if run_id + ".sw" in ids else run_id


def _values(rep, claim: str) -> dict:
    """A claim's measured values by key, the deciding twin's value under the averaged row's key
    where the switching plant decides (``<key>.sw``)."""
    out = {r.key: r.value for r in rep.rows if r.claim == claim}
    out.update({r.key[:-3]: r.value for r in rep.rows
                if r.claim == claim and r.key.endswith(".sw") and not r.diagnostic})
    return out


def _load(rep, run_id, deciding: bool = True):
    """The recording of a run (of its deciding twin, ``deciding_id``), None if there is none."""
    from hil_bench.record.recording import load_recording
    out = rep.outcomes.get(deciding_id(rep, run_id) if deciding else run_id)
    if out is None or not out.recording.exists():
        return None
    try:
        return load_recording(out.recording)
    except Exception:  # noqa: BLE001 - a broken recording is shown as missing
        return None


def _save(fig, rep, name) -> Path:
    """The figure as plots/<name>.png, written aside and renamed into place."""
    path = rep.out_dir / "plots" / f"{name}.png"
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.png")
    fig.tight_layout()
    fig.savefig(tmp, dpi=DPI)
    plt.close(fig)
    os.replace(tmp, path)
    return path


def _missing(ax, what):
    ax.text(0.5, 0.5, f"no recording: {what}", ha="center", va="center", transform=ax.transAxes)
    ax.set_axis_off()


def _win(rec, topic, t0, t1):
    d = rec.topic(topic)
    t = np.asarray(d["t_s"], float)
    m = (t >= t0) & (t <= t1)
    return {k: np.asarray(v)[m] for k, v in d.items()}


def _speed_panel(ax, rec, t0, t1, title, ref=None):
    if rec is None:
        return _missing(ax, title)
    st = _win(rec, ch.PLANT_STATE, t0, t1)
    te = _win(rec, ch.CONTROLLER_TELEMETRY, t0, t1)
    ax.plot(st["t_s"], st["speed_rpm"], label="true speed n", lw=1)
    ax.plot(te["t_s"], te["speed_hat_rpm"], label="estimated n^", lw=0.8, alpha=0.8)
    if ref is not None:
        ax.plot(st["t_s"], [ref(t) for t in st["t_s"]], "k--", lw=0.8, label="reference")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("speed [rpm]")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)


def _error_panel(ax, rec, t0, t1, title, bands=()):
    if rec is None:
        return _missing(ax, title)
    st = rec.topic(ch.PLANT_STATE)
    te = _win(rec, ch.CONTROLLER_TELEMETRY, t0, t1)
    idx = np.clip(np.searchsorted(st["t_s"], te["t_s"]), 0, len(st["t_s"]) - 1)
    ax.plot(te["t_s"], te["speed_hat_rpm"] - np.asarray(st["speed_rpm"])[idx], lw=0.8,
            label="n^ - n")
    for (a, b), band, lab in bands:
        ax.hlines([band, -band], a, b, colors="r", linestyles="--", lw=1)
        ax.text(a, band, f" paper +-{band:g} ({lab})", color="r", fontsize=7, va="bottom")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("speed error [rpm]")
    ax.grid(alpha=0.3)


def _pee_panel(ax, rec, t0, t1, title, bound=None, source=ch.CONTROLLER_TELEMETRY, label=None):
    if rec is None:
        return _missing(ax, title)
    st = rec.topic(ch.PLANT_STATE)
    te = _win(rec, source, t0, t1)
    idx = np.clip(np.searchsorted(st["t_s"], te["t_s"]), 0, len(st["t_s"]) - 1)
    pee = metrics.wrap_pi(te["theta_hat_rad"] - np.asarray(st["theta_e_rad"])[idx])
    ax.plot(te["t_s"], pee, lw=0.8, label=label or "PEE")
    if bound is not None:
        ax.axhline(bound, color="r", ls="--", lw=1)
        ax.axhline(-bound, color="r", ls="--", lw=1)
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("PEE [rad]")
    ax.grid(alpha=0.3)


def _ref_fn(rec):
    from hil_bench.scenario import RPM_PER_RAD_S, scenario_of, speed_ref_at
    try:
        scn = scenario_of(rec)
    except Exception:  # noqa: BLE001
        return None
    return lambda t: speed_ref_at(scn, t) * RPM_PER_RAD_S


# -- per claim ----------------------------------------------------------------------------------

def _two_method_speed(rep, name, runs, t_range, bands_for, title):
    fig, axes = plt.subplots(2, len(runs), figsize=(6 * len(runs), 6.5), squeeze=False)
    for j, (rid, label) in enumerate(runs):
        rec = _load(rep, rid)
        _speed_panel(axes[0][j], rec, *t_range, f"{label} ({deciding_id(rep, rid)})",
                     _ref_fn(rec) if rec is not None else None)
        _error_panel(axes[1][j], rec, *t_range, f"{label}: speed-estimation error",
                     bands_for(rid))
    fig.suptitle(title, fontsize=10)
    return [_save(fig, rep, name)]


def plot_y1(rep):
    b = {"Y1.improved": (((2.8, 3.3), 1.5, "10 rpm"), ((3.8, 4.3), 3.0, "50 rpm")),
         "Y1.conventional": (((2.8, 3.3), 4.0, "10 rpm"), ((3.8, 4.3), 6.0, "50 rpm"))}
    out = _two_method_speed(rep, "Y1", [("Y1.conventional", "conventional SMO (Fig. 13)"),
                                        ("Y1.improved", "improved SMO (Fig. 14)")], (0, 4.3),
                            lambda r: b.get(r.replace(".nodt", ""), ()),
                            "Y1: full load, 10 -> 50 rpm, dead time on (the paper's hardware)")
    out += _two_method_speed(rep, "Y1_nodt", [("Y1.conventional.nodt", "conventional, no dead time"),
                                              ("Y1.improved.nodt", "improved, no dead time")],
                             (0, 4.3), lambda r: b.get(r.replace(".nodt", ""), ()),
                             "Y1 diagnostic: the same runs without dead time")
    return out


def plot_y2(rep):
    return _two_method_speed(rep, "Y2", [("Y2.conventional", "conventional SMO (Fig. 15)"),
                                         ("Y2.improved", "improved SMO (Fig. 16)"),
                                         ("Y2.improved.nodt", "improved, no dead time")],
                             (0.9, 1.6), lambda r: (),
                             "Y2: 10 rpm, rated load step at 1.2 s")


def plot_y3(rep):
    from hil_bench.firmware_stub.estimators import REFERENCE_ESTIMATORS
    from hil_bench.plant_rt.profile import load_profile

    from .estimator_trace import replay
    rec = _load(rep, "Y3")
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5))
    if rec is None:
        _missing(axes[0], "Y3")
        return [_save(fig, rep, "Y3")]
    prof = load_profile("yuan2020")
    for ax, name, label in ((axes[0], "SMO_SIGN", "conventional (sign) SMO"),
                            (axes[1], "SMO_SIGMOID", "improved (sigmoid) SMO")):
        r = replay(rec, REFERENCE_ESTIMATORS[name](prof, 1e-4), window_s=(0.6, 1.2))
        ax.plot(r.i_hat_alpha_a, r.i_alpha_a, ",", alpha=0.5)
        lo, hi = np.nanmin(r.i_alpha_a), np.nanmax(r.i_alpha_a)
        ax.plot([lo, hi], [lo, hi], "r--", lw=0.8, label="sliding surface i^ = i")
        ax.set_xlabel("estimated i_alpha [A]")
        ax.set_ylabel("measured i_alpha [A]")
        w_e = abs(float(np.mean(_win(rec, ch.PLANT_STATE, 0.6, 1.2)["omega_e_rad_s"])))
        idx = metrics.chattering_index_a(r.i_hat_alpha_a, r.i_hat_beta_a, r.i_alpha_a,
                                         r.i_beta_a, r.t_s, w_e)
        ax.set_title(f"{label}: chattering index {idx:.3g} A", fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Y3 (Fig. 17): estimated vs measured current, same samples, 50 rpm full load",
                 fontsize=10)
    return [_save(fig, rep, "Y3")]


def plot_y4(rep):
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    for row, rpm in enumerate((10, 50)):
        w = (0.9, 4.0) if rpm == 10 else (0.9, 2.1)
        bars = {}
        ax_t = axes[row][0]
        for state in ("off", "on"):
            rec = _load(rep, f"Y4.{rpm}.{state}")
            if rec is None:
                continue
            st = _win(rec, ch.PLANT_STATE, *w)
            s = metrics.locked_spectrum(st["i_a_a"], st["theta_e_rad"], 1e4)
            bars[state] = [100 * s.harmonics.get(h, 0) / s.fundamental_amplitude for h in
                           range(2, 20)]
            ax_t.plot(st["t_s"], st["i_a_a"], lw=0.8,
                      label=f"compensation {state}: THD {s.thd_percent:.2f} %")
        ax_t.set_title(f"{rpm} rpm: phase-a current (Fig. {18 if rpm == 10 else 20}-"
                       f"{19 if rpm == 10 else 21})", fontsize=9)
        ax_t.set_xlabel("t [s]")
        ax_t.set_ylabel("i_a [A]")
        ax_t.legend(fontsize=7)
        ax_t.grid(alpha=0.3)
        ax = axes[row][1]
        h = np.arange(2, 20)
        for k, (state, vals) in enumerate(bars.items()):
            ax.bar(h + (k - 0.5) * 0.4, vals, width=0.4, label=f"bench, compensation {state}")
        paper = {10: ((4.08, 4.11), (2.18, 2.61)), 50: ((4.62, 4.36), (1.71, 1.77))}[rpm]
        ax.plot([5, 7], paper[0], "kx", ms=8, label="paper, without")
        ax.plot([5, 7], paper[1], "k+", ms=10, label="paper, with")
        ax.set_xticks(h)
        ax.set_xlabel("harmonic order")
        ax.set_ylabel("% of fundamental")
        ax.set_title(f"{rpm} rpm: spectrum (least squares on the true angle, whole revolutions)",
                     fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Y4: phase current without / with Yuan's 5th/7th compensation", fontsize=10)
    return [_save(fig, rep, "Y4")]


def plot_y5(rep):
    s = rep.studies.get("Y5")
    fig, ax = plt.subplots(figsize=(9, 4))
    if s is None:
        _missing(ax, "Y5 study")
        return [_save(fig, rep, "Y5")]
    cycles = s["t_s"] * 250.0
    ax.plot(cycles, s["x"], color="0.7", lw=0.6, label="input sin(500 pi t)")
    ax.plot(cycles, s["amp_in"], "k--", lw=0.8, label="input amplitude")
    ax.plot(cycles, s["SDFT.amp"], label=f"SDFT |bin 5| (step: {s['SDFT.step']:.2f} cycles)")
    ax.plot(cycles, s["GSDFT.amp"], label=f"GSDFT |bin 5| (step: {s['GSDFT.step']:.2f} cycles)")
    ax.set_xlabel("time [cycles of 250 Hz]")
    ax.set_ylabel("amplitude [A]")
    ax.set_title("Y5 (Fig. 11-12): M = 24, k = 5, fs = 1200 Hz; amplitude 1 -> 2 at 0.2 s "
                 "(50 cycles)", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return [_save(fig, rep, "Y5")]


def plot_y6(rep):
    s = rep.studies.get("Y6")
    fig, ax = plt.subplots(figsize=(7, 4))
    if s is None:
        _missing(ax, "Y6 study: " + rep.study_errors.get("Y6", ""))
        return [_save(fig, rep, "Y6")]
    labels = ["protected (modulated)", "direct recursion"]
    sd = [s["sdft_57_real_mod"], s["sdft_57_real_direct"]]
    gs = [s["gsdft_57_real_mod"], s["gsdft_57_real_direct"]]
    x = np.arange(2)
    ax.bar(x - 0.2, sd, 0.4, label="SDFT")
    ax.bar(x + 0.2, gs, 0.4, label="GSDFT")
    ax.set_xticks(x, labels)
    ax.set_ylabel("x86-64 instructions per sample (5th + 7th)")
    ax.set_title("Y6 (Table 2): paper says GSDFT 44.82 % less time; bench: "
                 f"{s['saving_protected']:+.1f} % / {s['saving_direct']:+.1f} % saving", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    return [_save(fig, rep, "Y6")]


def plot_y7(rep):
    rows = {r.key: r.value for r in rep.rows if r.claim == "Y7"}
    fig, ax = plt.subplots(figsize=(6, 4))
    x = np.arange(2)
    ax.bar(x - 0.2, [rows.get("Y7.sdft.5", np.nan), rows.get("Y7.sdft.7", np.nan)], 0.4,
           label="SDFT")
    ax.bar(x + 0.2, [rows.get("Y7.gsdft.5", np.nan), rows.get("Y7.gsdft.7", np.nan)], 0.4,
           label="GSDFT")
    ax.set_xticks(x, ["5th", "7th"])
    ax.set_ylabel("% of fundamental")
    ax.set_title("Y7 (Table 3): steady-state extraction, 10 rpm phase current", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    return [_save(fig, rep, "Y7")]


def plot_y8(rep):
    from hil_bench.claims.registry import Y8_SPEEDS
    rows = _values(rep, "Y8")
    fig, ax = plt.subplots(figsize=(8, 4))
    speeds = [s for s, _ in Y8_SPEEDS]
    ax.plot(speeds, [dn for _, dn in Y8_SPEEDS], "ks--", label="paper Table 4 (dn)")
    for sfx, lab in (("", "bench, dead time on"), (".nodt", "bench, dead time off (diagnostic)")):
        ax.plot(speeds, [rows.get(f"Y8.{s:g}rpm{sfx}", np.nan) for s in speeds], "o-", label=lab)
    ax.set_yscale("log")
    ax.set_xlabel("speed [rpm]")
    ax.set_ylabel("max |n^ - n| [rpm]")
    ax.set_title("Y8 (Table 4): improved SMO speed-estimation error vs speed, full load", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return [_save(fig, rep, "Y8")]


def plot_h1(rep):
    b = {"H1.hfi": (((2.0, 2.4), 1.5, "10 rpm"), ((2.8, 3.2), 3.0, "50 rpm")),
         "H1.smo": (((2.9, 3.3), 4.0, "10 rpm"), ((3.7, 4.1), 6.0, "50 rpm"))}
    out = _two_method_speed(rep, "H1", [("H1.smo", "SMO (Fig. 7)"), ("H1.hfi", "HFI + SDFT (Fig. 8)")],
                            (0, 4.1), lambda r: b.get(r.replace(".nodt", ""), ()),
                            "H1: full load, 10 -> 50 rpm, dead time on (the paper's hardware)")
    out += _two_method_speed(rep, "H1_nodt", [("H1.smo.nodt", "SMO, no dead time"),
                                              ("H1.hfi.nodt", "HFI, no dead time")], (0, 4.1),
                             lambda r: b.get(r.replace(".nodt", ""), ()),
                             "H1 diagnostic: without dead time")
    return out


def plot_h2(rep):
    return _two_method_speed(rep, "H2", [("H2.smo", "SMO (Fig. 9)"), ("H2.hfi", "HFI (Fig. 10)"),
                                         ("H2.hfi.nodt", "HFI, no dead time")], (0.5, 1.2),
                             lambda r: (), "H2: 10 rpm, 6.5 N m load step at 0.8 s")


def plot_h3(rep):
    from hil_bench.claims.registry import H3_ANGLES_DEG
    rows = {r.key: r for r in rep.rows if r.claim == "H3"}
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for method, diag, style in (("pure", False, "o-"), ("pure", True, "o:"), ("bias", False, "s-"),
                                ("bias", True, "s:")):
        errs = []
        for a in H3_ANGLES_DEG:
            rid = f"H3.{method}.{a:g}deg" + (".nodt" if diag else "")
            rec = _load(rep, rid)
            v = np.nan
            out = rep.outcomes.get(deciding_id(rep, rid))
            if rec is not None and out is not None and not out.error:   # a fault: no point
                te = rec.topic(ch.CONTROLLER_TELEMETRY)
                e = metrics.wrap_pi(np.asarray(te["pee_rad"])[np.asarray(te["t_s"])
                                                                 >= metrics.window_start_s(rec)])
                if e.size:
                    v = math.degrees(math.atan2(np.mean(np.sin(e)), np.mean(np.cos(e))))
            errs.append(v)
        ax.plot(H3_ANGLES_DEG, errs, style, label=f"{'HF-only' if method == 'pure' else 'd-bias'}"
                f" test{', dead time off' if diag else ''}")
    ax.axhspan(-1, 1, color="g", alpha=0.15, label="paper +-1 deg")
    ax.set_xlabel("actual initial position [deg el.]")
    ax.set_ylabel("estimate - actual [deg] (180: wrong polarity)")
    ax.set_title("H3 (Fig. 12): initial position error; missing points = procedure failed "
                 "(polarity undecided)", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return [_save(fig, rep, "H3")]


def plot_g1(rep):
    rec = _load(rep, "G1")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    if rec is None:
        _missing(axes[0], "G1")
        return [_save(fig, rep, "G1")]
    from hil_bench.claims.registry import G1_MS
    for m, _ in G1_MS:
        d = _win(rec, ch.REFERENCE_PREFIX + f"SMO_TANH:m{m:g}", 1.45, 1.5)
        axes[0].plot(d["t_s"], d["e_alpha_v"], lw=0.8, label=f"m = {m:g}")
    st = _win(rec, ch.PLANT_STATE, 1.45, 1.5)
    axes[0].plot(st["t_s"], st["e_alpha_v"], "k--", lw=1, label="true e_alpha")
    axes[0].set_ylim(-60, 60)
    axes[0].set_xlabel("t [s]")
    axes[0].set_ylabel("estimated e_alpha [V]")
    axes[0].set_title("G1 (Fig. 7a-d): estimated EMF at 500 rpm (clipped to +-60 V)", fontsize=9)
    axes[0].legend(fontsize=7)
    rows = {r.key: r.value for r in rep.rows if r.claim == "G1"}
    ms = [m for m, _ in G1_MS]
    axes[1].loglog(ms, [t for _, t in G1_MS], "ks--", label="paper THD")
    axes[1].loglog(ms, [rows.get(f"G1.m{m:g}.thd", np.nan) for m in ms], "o-",
                   label="bench THD (10 kHz, closed loop)")
    from hil_bench.claims.registry import G1_STEPS_US
    for ts_us in G1_STEPS_US[1:]:
        axes[1].loglog(ms, [max(rows.get(f"G1.step{ts_us:g}us.m{m:g}.thd", np.nan), 1e-5)
                            for m in ms], "x:", label=f"host observer, Ts = {ts_us:g} us")
    axes[1].set_xlabel("m [1/A]")
    axes[1].set_ylabel("THD+N of e_alpha [%] (floored at 1e-5)")
    axes[1].set_title("G1 (Fig. 7e): THD vs m", fontsize=9)
    axes[1].legend(fontsize=7)
    axes[1].grid(alpha=0.3, which="both")
    return [_save(fig, rep, "G1")]


def _steady(rep, name, rid, window, pee_bound, title):
    rec = _load(rep, rid)
    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8))
    if rec is None:
        _missing(axes[0], rid)
        return [_save(fig, rep, name)]
    _speed_panel(axes[0], rec, *window, "speed", _ref_fn(rec))
    te = _win(rec, ch.CONTROLLER_TELEMETRY, window[1] - 0.05, window[1])
    st = _win(rec, ch.PLANT_STATE, window[1] - 0.05, window[1])
    axes[1].plot(te["t_s"], te["e_alpha_v"], lw=0.8, label="e^_alpha")
    axes[1].plot(te["t_s"], te["e_beta_v"], lw=0.8, label="e^_beta")
    axes[1].plot(st["t_s"], st["i_a_a"] * 10, lw=0.8, label="10 x i_a [A]")
    axes[1].set_title("estimated EMF, phase current (last 50 ms)", fontsize=9)
    axes[1].legend(fontsize=7)
    axes[1].grid(alpha=0.3)
    _pee_panel(axes[2], rec, *window, "position-estimation error", pee_bound)
    fig.suptitle(title, fontsize=10)
    return [_save(fig, rep, name)]


def plot_g2(rep):
    return _steady(rep, "G2", "G2", (1.0, 1.5), 0.1, "G2 (Fig. 8): 500 rpm, tanh SMO, ideal plant")


def plot_g3(rep):
    return _steady(rep, "G3", "G3", (2.0, 2.5), 0.05, "G3 (Fig. 9): 2000 rpm, tanh SMO, ideal plant")


def _dynamics(rep, name, rid, window, title, pee_bound):
    rec = _load(rep, rid)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    _speed_panel(axes[0], rec, *window, "speed", _ref_fn(rec) if rec is not None else None)
    _pee_panel(axes[1], rec, *window, "position-estimation error", pee_bound)
    fig.suptitle(title, fontsize=10)
    return [_save(fig, rep, name)]


def plot_g4(rep):
    return _dynamics(rep, "G4", "G4", (1.5, 2.0), "G4 (Fig. 10): load 2 N m at 1.6 s, 1200 rpm at "
                     "1.65 s, unload 1.7 s, 1000 rpm 1.75 s (paper's events + 1.5 s)", 0.25)


def plot_g5(rep):
    from .claim_metrics import dual_samples
    rec = _load(rep, "G5")
    fig, ax = plt.subplots(figsize=(8, 4))
    if rec is None:
        _missing(ax, "G5")
        return [_save(fig, rep, "G5")]
    t, i1, i2 = dual_samples(rec)
    m = (t >= 1.0) & (t <= 1.5)
    est = 1e6 * metrics.delay_estimates_s(i1[m], i2[m], 1e-4)
    est = est[np.isfinite(est)]
    ax.hist(est, bins=60, range=(0, 90), alpha=0.8, label=f"bench eq. 20 per period "
            f"(mean {np.mean(est):.1f} us, n = {est.size})")
    ax.axvspan(33.2, 35.3, color="g", alpha=0.2, label="paper Table II range 33.2..35.3 us")
    ax.axvline(34.1, color="k", ls="--", lw=1, label="plant delay 34.1 us")
    ax.set_xlabel("t_d estimate [us]")
    ax.set_ylabel("periods")
    ax.set_title("G5 (Table II): eq. 20 delay estimates, 500 rpm no load", fontsize=9)
    ax.legend(fontsize=7)
    return [_save(fig, rep, "G5")]


def plot_g6(rep):
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for ax, rpm in zip(axes[:2], (2000, 3000)):
        for state in ("off", "on", "naive"):
            rec = _load(rep, f"G67.{rpm}.{state}")
            if rec is None:
                continue
            w = {2000: (2.1, 2.2), 3000: (2.7, 2.8)}[rpm]
            _pee_panel(ax, rec, *w, f"{rpm} rpm: PEE without / with pre-compensation",
                       label={"off": "compensation off", "on": "compensation on",
                              "naive": "Gong's naive baseline"}[state])
        ax.legend(fontsize=7)
    rows = _values(rep, "G6")
    speeds = [500, 2000, 3000]
    axes[2].bar(np.arange(3) - 0.2, [rows.get(f"G6.{s}.off.iq", np.nan) for s in speeds], 0.4,
                label="controller's i_q without")
    axes[2].bar(np.arange(3) + 0.2, [rows.get(f"G6.{s}.on.iq", np.nan) for s in speeds], 0.4,
                label="controller's i_q with")
    axes[2].plot([-0.2, 0.2, 0.8, 1.2], [0.87, 0.83, 1.15, 1.08], "k*", ms=9,
                 label="paper (Gong V-B)")
    axes[2].set_xticks(np.arange(3), [f"{s} rpm" for s in speeds])
    axes[2].set_ylabel("mean i_q reference of the controller [A]")
    axes[2].set_title("G6: i_q at no load (paper: -4.6 / -6.1 / -7.5 % with compensation)",
                      fontsize=9)
    axes[2].legend(fontsize=7)
    fig.suptitle("G6 (Fig. 15): the lag removed by the pre-compensation", fontsize=10)
    return [_save(fig, rep, "G6")]


def plot_g7(rep):
    rows = _values(rep, "G7")
    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8))
    paper = {"sf": ((35, 33), (54, 51)), "thd": ((1.25, 1.23), (0.64, 0.62)),
             "pee": ((0.2, 0.2), (0.1, 0.1))}
    for ax, m, lab in zip(axes, ("sf", "thd", "pee"), ("SF [rpm]", "EMF THD [%]", "max PEE [rad]")):
        x = np.arange(2)
        for k, state in enumerate(("off", "on")):
            ax.bar(x + (k - 0.5) * 0.4, [rows.get(f"G7.{s}.{state}.{m}", np.nan) for s in (500, 2000)],
                   0.4, label=f"bench, compensation {state}")
            ax.plot(x + (k - 0.5) * 0.4, [paper[m][i][k] for i in range(2)], "kx", ms=8,
                    label="paper" if k == 0 else None)
        ax.set_xticks(x, ["500 rpm", "2000 rpm"])
        ax.set_ylabel(lab)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3, axis="y")
    fig.suptitle("G7 (Table III): experiment, without / with compensation", fontsize=10)
    return [_save(fig, rep, "G7")]


def plot_g8(rep):
    return _dynamics(rep, "G8", "G8", (1.4, 3.6), "G8 (Fig. 16): load 2 N m at 1.6 s, unload 2.0 s, "
                     "1200 rpm 2.4 s, 1000 rpm 2.8 s", 0.15)


PLOTS: dict[str, Callable] = {
    "Y1": plot_y1, "Y2": plot_y2, "Y3": plot_y3, "Y4": plot_y4, "Y5": plot_y5, "Y6": plot_y6,
    "Y7": plot_y7, "Y8": plot_y8, "H1": plot_h1, "H2": plot_h2, "H3": plot_h3, "G1": plot_g1,
    "G2": plot_g2, "G3": plot_g3, "G4": plot_g4, "G5": plot_g5, "G6": plot_g6, "G7": plot_g7,
    "G8": plot_g8,
}


#: the true vs estimated angle plot: at most this many runs of a claim, this many electrical
#: periods at the end of the run's first window
ANGLE_RUNS = 4
ANGLE_PERIODS = 3.0


def _angle_runs(c) -> list:
    """The claim's runs its verdict reads (non-diagnostic rows), in order, at most ANGLE_RUNS."""
    from .claim_variants import base_runs
    return base_runs(c)[:ANGLE_RUNS]


def plot_angle(rep, c) -> Path | None:
    """True vs estimated electrical angle (the controller's telemetry, and the host references
    where they ran) over the last ANGLE_PERIODS electrical periods of each run's first window."""
    from .conditions import windows_of
    runs = _angle_runs(c)
    if not runs:
        return None
    fig, axes = plt.subplots(len(runs), 1, figsize=(9, 2.4 * len(runs)), squeeze=False)
    for ax, run in zip(axes[:, 0], runs):
        rec = _load(rep, run.id)
        if rec is None:
            _missing(ax, run.id)
            continue
        w0, w1 = windows_of(c, run)[0]
        st = _win(rec, ch.PLANT_STATE, w0, w1)
        if not len(st.get("t_s", ())):
            _missing(ax, f"{run.id}: no samples in {w0:g}..{w1:g} s")
            continue
        w_e = float(np.mean(np.abs(st["omega_e_rad_s"]))) if "omega_e_rad_s" in st else 0.0
        span = (w1 - w0) if w_e <= 0 else min(w1 - w0, ANGLE_PERIODS * 2 * math.pi / w_e)
        t0 = w1 - span
        st = _win(rec, ch.PLANT_STATE, t0, w1)
        wrap = lambda x: np.mod(np.asarray(x, float), 2 * math.pi)  # noqa: E731
        ax.plot(st["t_s"], wrap(st["theta_e_rad"]), ".", ms=1.5, color="k", label="true")
        err_ax = ax.twinx()        # the difference, on its own scale (right)
        t_true, th_true = np.asarray(st["t_s"], float), np.asarray(st["theta_e_rad"], float)
        sources = [("controller (telemetry)", _win(rec, ch.CONTROLLER_TELEMETRY, t0, w1))]
        sources += [(f"host {t[len(ch.REFERENCE_PREFIX):]}", _win(rec, t, t0, w1))
                    for t in sorted(t for t in rec.topics if t.startswith(ch.REFERENCE_PREFIX))]
        for j, (label, d) in enumerate(sources):
            if not len(d.get("t_s", ())) or "theta_hat_rad" not in d:
                continue
            ax.plot(d["t_s"], wrap(d["theta_hat_rad"]), ".", ms=1.0, color=f"C{j}", label=label)
            idx = np.clip(np.searchsorted(t_true, d["t_s"]), 0, len(t_true) - 1)
            err_ax.plot(d["t_s"], metrics.wrap_pi(np.asarray(d["theta_hat_rad"], float)
                                                  - th_true[idx]),
                        lw=0.7, color=f"C{j}", alpha=0.6)
        err_ax.set_ylabel("estimated - true [rad] (lines)", fontsize=8)
        ax.set_ylim(-0.2, 2 * math.pi + 0.2)
        ax.set_ylabel("theta_e [rad] (dots)")
        ax.set_title(f"{run.id} ({run.name}): true vs estimated angle, {t0:.3g}..{w1:.3g} s",
                     fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right", markerscale=6)
    axes[-1, 0].set_xlabel("t [s]")
    return _save(fig, rep, f"{c.id}_angle")


# -- spectra locked to the rotor (issue 27, 6) ------------------------------------------------------

SPECTRUM_ORDERS = 13


def _locked(rec, topic: str, field: str, window) -> "metrics.Spectrum | None":
    """The spectrum (orders 1..13) of ``field`` of ``topic`` over ``window``, locked to the
    plant's true electrical angle at the same cycles (metrics.locked_spectrum, as the claims'
    metrics); None where the recording has no such column or the window no revolution."""
    if rec is None or topic not in rec.topics or field not in rec.topics[topic]:
        return None
    cols = rec.topics[topic]
    t = np.asarray(cols["t_s"], float)
    m = (t >= window[0]) & (t <= window[1])
    x = np.asarray(cols[field], float)[m]
    st = rec.topics[ch.PLANT_STATE]
    ts = np.asarray(st["t_s"], float)
    idx = np.clip(np.searchsorted(ts, t[m]), 0, len(ts) - 1)
    th = np.asarray(st["theta_e_rad"], float)[idx]
    ok = np.isfinite(x)
    try:
        return metrics.locked_spectrum(x[ok], th[ok], None, SPECTRUM_ORDERS)
    except ValueError:
        return None


def _window_of(rec, default):
    from hil_bench.scenario import scenario_of
    try:
        return tuple(scenario_of(rec).metrics_window_s)
    except Exception:  # noqa: BLE001
        return default


def _spectrum_panel(ax, items, title, marks=()):
    """Bars of the orders 1..13 in % of each item's fundamental (log scale), one colour per
    item; ``marks``: (label, {order: %}) drawn as markers (the paper's or an extractor's)."""
    orders = np.arange(1, SPECTRUM_ORDERS + 1)
    items = [(lab, sp) for lab, sp in items if sp is not None]
    if not items:
        ax.text(0.5, 0.5, "no spectrum (no recording or no revolution in the window)",
                ha="center", va="center", transform=ax.transAxes, fontsize=8)
    width = 0.8 / max(len(items), 1)
    for k, (lab, sp) in enumerate(items):
        vals = [100.0] + [max(sp.harmonic_percent(int(h)), 1e-6) for h in orders[1:]]
        ax.bar(orders + (k - (len(items) - 1) / 2) * width, vals, width,
               label=f"{lab}: A1 {sp.fundamental_amplitude:.3g}, THD {sp.thd_percent:.3g} %, "
                     f"THD+N {sp.thd_n_percent:.3g} %")
    for (lab, pts), mk in zip(marks, ("kx", "k+", "r^", "bv")):
        ax.plot(list(pts), list(pts.values()), mk, ms=9, label=lab)
    ax.set_yscale("log")
    ax.set_xticks(orders)
    ax.set_xlabel("harmonic order (of the rotor's electrical angle)")
    ax.set_ylabel("% of the fundamental")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=6)
    ax.grid(alpha=0.3, axis="y", which="both")


def _spectra_figure(rep, name, emf, cur, title, emf_marks=(), cur_marks=()):
    fig, axes = plt.subplots(1, 2, figsize=(15, 4.2))
    _spectrum_panel(axes[0], emf, "estimated back EMF e_alpha", emf_marks)
    _spectrum_panel(axes[1], cur, "phase-a current (true)", cur_marks)
    fig.suptitle(title + " - spectra locked to the rotor, orders 1-13", fontsize=10)
    return [_save(fig, rep, f"{name}_spectrum")]


def spectra_g1(rep):
    from hil_bench.claims.registry import G1_MS
    rec = _load(rep, "G1")
    w = _window_of(rec, (1.0, 1.5)) if rec is not None else (1.0, 1.5)
    emf = [(f"m = {m:g}", _locked(rec, ch.REFERENCE_PREFIX + f"SMO_TANH:m{m:g}", "e_alpha_v", w))
           for m, _ in G1_MS]
    return _spectra_figure(rep, "G1", emf, [("G1", _locked(rec, ch.PLANT_STATE, "i_a_a", w))],
                           "G1 (Fig. 7): the four observers at 500 rpm (paper THD 41.5 / 18.6 / "
                           "9.5 / 1.7 %)")


def _spectra_steady(rep, name, paper_thd):
    rec = _load(rep, name)
    w = _window_of(rec, (0.0, 0.0)) if rec is not None else (0.0, 0.0)
    emf = [("host reference (float64)", _locked(rec, ch.REFERENCE_PREFIX + "SMO_TANH",
                                                "e_alpha_v", w)),
           ("controller telemetry (0.01 V)", _locked(rec, ch.CONTROLLER_TELEMETRY, "e_alpha_v", w))]
    return _spectra_figure(rep, name, emf, [(name, _locked(rec, ch.PLANT_STATE, "i_a_a", w))],
                           f"{name}: tanh SMO, ideal plant (paper EMF THD {paper_thd} %)")


def spectra_g2(rep):
    return _spectra_steady(rep, "G2", 1.7)


def spectra_g3(rep):
    return _spectra_steady(rep, "G3", 0.8)


def spectra_g7(rep):
    emf, cur = [], []
    for rpm in (500, 2000):
        for state in ("off", "on"):
            rec = _load(rep, f"G67.{rpm}.{state}")
            w = _window_of(rec, (0.0, 0.0)) if rec is not None else (0.0, 0.0)
            lab = f"{rpm} rpm, compensation {state}"
            emf.append((lab, _locked(rec, ch.CONTROLLER_TELEMETRY, "e_alpha_v", w)))
            cur.append((lab, _locked(rec, ch.PLANT_STATE, "i_a_a", w)))
    return _spectra_figure(rep, "G7", emf, cur, "G7 (Table III): experiment (paper EMF THD 1.25 / "
                           "1.23 % at 500 rpm, 0.64 / 0.62 % at 2000 rpm)")


def spectra_y4(rep):
    out = []
    paper = {10: ({5: 4.08, 7: 4.11}, {5: 2.18, 7: 2.61}), 50: ({5: 4.62, 7: 4.36},
                                                              {5: 1.71, 7: 1.77})}
    for rpm in (10, 50):
        cur = []
        for state in ("off", "on"):
            rec = _load(rep, f"Y4.{rpm}.{state}")
            w = _window_of(rec, (0.0, 0.0)) if rec is not None else (0.0, 0.0)
            cur.append((f"compensation {state}", _locked(rec, ch.PLANT_STATE, "i_a_a", w)))
        fig, ax = plt.subplots(figsize=(9, 4.2))
        _spectrum_panel(ax, cur, f"Y4 (Fig. {18 if rpm == 10 else 20}-{19 if rpm == 10 else 21}): "
                        f"phase-a current at {rpm} rpm; the encoder closes the loop (no EMF "
                        "estimate)", (("paper, without", paper[rpm][0]),
                                      ("paper, with", paper[rpm][1])))
        out.append(_save(fig, rep, f"Y4_{rpm}rpm_spectrum"))
    return out


def spectra_y7(rep):
    rows = _values(rep, "Y7")
    rec = _load(rep, "Y4.10.off")
    cur = [("locked fit", _locked(rec, ch.PLANT_STATE, "i_a_a", (0.9, 4.0)))]
    fig, ax = plt.subplots(figsize=(9, 4.2))
    _spectrum_panel(ax, cur, "Y7 (Table 3): the 10 rpm phase current, and the 5th/7th the "
                    "angle-synchronous extractors read", (
                        ("SDFT (harm_comp)", {5: rows.get("Y7.sdft.5", np.nan),
                                              7: rows.get("Y7.sdft.7", np.nan)}),
                        ("GSDFT (harm_comp)", {5: rows.get("Y7.gsdft.5", np.nan),
                                               7: rows.get("Y7.gsdft.7", np.nan)})))
    return [_save(fig, rep, "Y7_spectrum")]


#: the claims whose papers show spectra (Gong Fig. 7-9, Yuan Fig. 18-21 and Table 3)
SPECTRA: dict[str, Callable] = {"G1": spectra_g1, "G2": spectra_g2, "G3": spectra_g3,
                                "G7": spectra_g7, "Y4": spectra_y4, "Y7": spectra_y7}


def plot_claims(rep) -> dict[str, list[Path]]:
    out: dict[str, list[Path]] = {}
    for c in rep.claims:
        fn = PLOTS.get(c.id)
        sp = SPECTRA.get(c.id)
        for what, draw in (("plot", (lambda c=c, fn=fn: fn(rep)) if fn else None),
                           ("spectrum plot", (lambda sp=sp: sp(rep)) if sp else None),
                           ("angle plot", lambda c=c: [p for p in [plot_angle(rep, c)] if p])):
            if draw is None:
                continue
            try:
                out.setdefault(c.id, []).extend(draw())
            except Exception as exc:  # noqa: BLE001 - a plot must not lose the report
                fig, ax = plt.subplots(figsize=(6, 1.5))
                ax.text(0.01, 0.5, f"{c.id}: {what} failed: {type(exc).__name__}: {exc}",
                        fontsize=8, va="center")
                ax.set_axis_off()
                out.setdefault(c.id, []).append(
                    _save(fig, rep, f"{c.id}_{what.replace(' ', '_')}_error"))
    return out


def plot_residual(rep, claim_id: str, points, holds_up_to, realistic: float) -> Path | None:
    """The inverter-compensation residual study of one claim (bench/papers/residual.py): each
    non-diagnostic quantity as measured / the paper's value against the residual, the claim's
    verdict at each residual on top, the residual the scenarios run at marked."""
    if not points:
        return None
    up_to = "fails at 0 %" if holds_up_to is None else f"holds up to {100 * holds_up_to:g} %"
    fig, ax = _plot_verdict_sweep(
        [100.0 * p.residual for p in points], points, f"{claim_id}: {up_to}",
        "compensation residual [% of the plant's dead time and drops] (100 % = none)",
        (100.0 * realistic, f" scenarios: {100 * realistic:g} %"), "residual")
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlim(-0.3, 130.0)
    return _save(fig, rep, f"residual_{claim_id}")


def plot_bandwidth(rep, name: str, title: str, xlabel: str, points) -> Path | None:
    """One estimator-bandwidth sweep of one claim (bench/papers/bandwidth.py): each
    non-diagnostic quantity as measured / the paper's value against the bandwidth's scale (x the
    value the bench chose), the claim's verdict at each scale on top, the chosen value marked."""
    if not points:
        return None
    fig, ax = _plot_verdict_sweep([p.scale for p in points], points, title, xlabel,
                                  (1.0, " chosen"), "bandwidth")
    ax.set_xscale("log", base=2)
    xs = [p.scale for p in points]
    ax.set_xlim(min(xs) / 1.3, max(xs) * 1.3)
    ax.set_xticks(xs, [f"{x:g}" for x in xs])
    return _save(fig, rep, name)


def _plot_verdict_sweep(xs, points, title: str, xlabel: str, mark: tuple[float, str],
                        what: str):
    """The figure both studies draw: measured / paper's value of each non-diagnostic quantity
    at each point (log y), the paper's value at 1, the claim's verdict above each point, the
    set-up the claims run at marked by a dotted line."""
    fig, ax = plt.subplots(figsize=(8.0, 4.2))
    keys = [r.key for r in points[0].rows if not r.is_relation]
    plotted = not_held = 0
    for key in keys:
        ys = []
        for p in points:
            row = next((r for r in p.rows if r.key == key), None)
            paper = _paper_number(row.paper) if row is not None else math.nan
            v = row.value if row is not None else math.nan
            ys.append(abs(v) / paper if math.isfinite(v) and paper and math.isfinite(paper)
                      else math.nan)
        if any(math.isfinite(y) for y in ys):
            ax.plot(xs, ys, "o-", ms=4, label=key)
            plotted += 1
            # a figure measured where the drive did not hold the paper's operating point
            off = [(x, y) for x, y, p in zip(xs, ys, points) if math.isfinite(y) and any(
                r.key == key and "did not hold" in str(r.note) for r in p.rows)]
            if off:
                ax.scatter(*zip(*off), s=70, facecolors="none", edgecolors="k", lw=0.8,
                           label="operating point not held" if not_held == 0 else None)
                not_held += 1
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.axvline(mark[0], color="tab:gray", lw=1.0, ls=":")
    ax.text(mark[0], 1.02, mark[1], transform=ax.get_xaxis_transform(), fontsize=7,
            color="tab:gray", va="bottom")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("measured / paper's value")
    for x, p in zip(xs, points):
        ax.annotate(p.verdict, (x, 1.0), xycoords=("data", "axes fraction"), xytext=(0, 2),
                    textcoords="offset points", ha="center", va="bottom", fontsize=6, rotation=90,
                    color="tab:green" if p.holds else "tab:red")
    ax.set_title(title, pad=38)
    if plotted:
        ax.legend(fontsize=6, loc="lower right")
    else:
        ax.text(0.5, 0.5, f"no quantity measured at any {what} (every run ended early)",
                ha="center", va="center", transform=ax.transAxes)
    return fig, ax


def _paper_number(text: str) -> float:
    """The first number of a paper-value cell ('1.5 rpm', 'about 3 (4.2); within 3 (5)')."""
    import re
    m = re.search(r"[-+]?\d+(\.\d+)?", str(text))
    return float(m.group(0)) if m else math.nan
