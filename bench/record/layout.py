"""A Foxglove / Lichtblick layout made for one scenario's recording (``bench layout``).

The layout is the classic exported-layout JSON both viewers import (Layout menu, Import from
file): ``configById`` (one config per panel id ``Type!name``), ``layout`` (the mosaic tree),
``globalVariables``, ``userNodes``, ``playbackConfig``. A panel's title is the config key the
viewer reads: ``foxglovePanelTitle`` (Foxglove) and ``lichtblickPanelTitle`` (Lichtblick, its
open fork); both are written, each viewer ignores the other's.

Every series names a topic and a field of the recording (:mod:`.channels`), with the scenario's
own host-reference topics (``/reference/<entry>`` for each ``[reference] estimators`` entry), so
the same file serves a recording opened after the run and ``bench run --live``.
"""
from __future__ import annotations

from . import channels as chans

TITLE_KEYS = ("foxglovePanelTitle", "lichtblickPanelTitle")


def _series(topic: str, field: str, label: str) -> dict:
    return {"value": f"{topic}.{field}", "enabled": True, "timestampMethod": "receiveTime",
            "label": label}


def _plot(title: str, series: list[dict]) -> dict:
    cfg = {key: title for key in TITLE_KEYS}
    cfg.update(paths=series, showXAxisLabels=True, showYAxisLabels=True, showLegend=True,
               legendDisplay="floating", showPlotValuesInLegend=False, isSynced=True,
               xAxisVal="timestamp", sidebarDimension=240)
    return cfg


def _raw(title: str, topic: str) -> dict:
    cfg = {key: title for key in TITLE_KEYS}
    cfg.update(topicPath=topic, diffEnabled=False, diffMethod="custom", diffTopicPath="",
               showFullMessageForDiff=False, expansion="all")
    return cfg


def _mosaic(ids: list[str], direction: str = "row"):
    """A balanced split tree over the panel ids (rows of columns)."""
    if len(ids) == 1:
        return ids[0]
    half = (len(ids) + 1) // 2
    other = "column" if direction == "row" else "row"
    return {"first": _mosaic(ids[:half], other), "second": _mosaic(ids[half:], other),
            "direction": direction, "splitPercentage": 100.0 * half / len(ids)}


def make_layout(references: tuple[str, ...] = (), *, telemetry_emf: bool = True,
                faults: bool = False) -> dict:
    """The layout for a recording with these host-reference entries (``[reference] estimators``,
    e.g. ``SMO_TANH`` or ``SMO_TANH:m0.01``), the controller's EMF on /controller/telemetry
    (``telemetry_emf``) and a /faults channel (``faults``)."""
    refs = [(chans.REFERENCE_PREFIX + entry, entry) for entry in references]
    state, telem = chans.PLANT_STATE, chans.CONTROLLER_TELEMETRY
    panels: dict[str, dict] = {}
    panels["Plot!angle"] = _plot("Electrical angle: true vs estimated [rad]", [
        _series(state, "theta_e_rad", "true"),
        _series(telem, "theta_hat_rad", "controller"),
        *[_series(t, "theta_hat_rad", f"host {name}") for t, name in refs]])
    panels["Plot!pee"] = _plot("Angle error: estimated - true [rad]", [
        _series(telem, "pee_rad", "controller"),
        *[_series(t, "pee_rad", f"host {name}") for t, name in refs]])
    panels["Plot!speed"] = _plot("Speed: true vs estimated [rpm]", [
        _series(state, "speed_rpm", "true"),
        _series(telem, "speed_hat_rpm", "controller"),
        *[_series(t, "speed_hat_rpm", f"host {name}") for t, name in refs]])
    panels["Plot!currents"] = _plot("Currents [A]", [
        _series(state, "i_a_a", "i_a"), _series(state, "i_b_a", "i_b"),
        _series(state, "i_c_a", "i_c"), _series(state, "i_d_a", "i_d"),
        _series(state, "i_q_a", "i_q"), _series(telem, "i_q_ref_a", "i_q ref")])
    emf = [_series(state, "e_alpha_v", "e_alpha true"), _series(state, "e_beta_v", "e_beta true")]
    if telemetry_emf:
        emf += [_series(telem, "e_alpha_v", "e_alpha controller"),
                _series(telem, "e_beta_v", "e_beta controller")]
    for t, name in refs:
        emf += [_series(t, "e_alpha_v", f"e_alpha host {name}")]
    panels["Plot!emf"] = _plot("Back EMF [V]", emf)
    panels["Plot!timing"] = _plot("Link timing [us]", [
        _series(chans.TIMING, "rtt_us", "SENSE -> DUTY"),
        _series(chans.TIMING, "cycle_us", "cycle"),
        _series(chans.TIMING, "start_err_us", "period start error")])
    panels["RawMessages!events"] = _raw("Events", chans.EVENTS)
    if faults:
        panels["RawMessages!faults"] = _raw("Faults", chans.FAULTS)
    return {"configById": panels, "globalVariables": {}, "userNodes": {},
            "playbackConfig": {"speed": 1}, "layout": _mosaic(list(panels))}


def layout_topics(layout: dict) -> set[tuple[str, str]]:
    """(topic, field) of every series, ("/events", "") for a raw-messages panel."""
    out = set()
    for cfg in layout["configById"].values():
        for p in cfg.get("paths", []):
            topic, _, field = p["value"].rpartition(".")
            out.add((topic, field))
        if "topicPath" in cfg:
            out.add((cfg["topicPath"], ""))
    return out
