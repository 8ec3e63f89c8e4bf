"""docs/protocol.md 1.0 and the code agree on what the spec says in words (issue 9, item 10)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from protocol import dbc, params
from protocol.messages import HelloStatus, Param

DOC = (Path(__file__).resolve().parents[1] / "docs" / "protocol.md").read_text()


def test_parameter_table_names_exactly_the_dbc_parameters():
    assert [p.name for p in params.PARAMS] == [p.name for p in sorted(Param, key=int)]
    assert all(p.kind in params.KINDS for p in params.PARAMS)
    assert all(p.values for p in params.PARAMS if p.kind == "enum")


def test_mechanical_start_up_parameters_say_so():
    """controller.c: w_mech += IF_ACCEL_RAD_S2 * Ts and compares it with HANDOVER_SPEED_RAD_S."""
    c_source = (Path(__file__).resolve().parents[1] / "firmware_stub/src/controller.c").read_text()
    assert "float w_mech = c->omega_ol_rad_s / k->pole_pairs + k->if_accel_rad_s2 * k->ts_s;" in c_source
    assert "float w_target = k->handover_speed_rad_s;" in c_source
    for name in ("IF_ACCEL_RAD_S2", "HANDOVER_SPEED_RAD_S"):
        assert "mechanical" in params.BY_NAME[name].meaning
        assert re.search(rf"\| {name} \| [^|]+ \| real \| [^|]*mechanical", DOC), name


@pytest.mark.parametrize("name, value, ok", [
    ("POLE_PAIRS", 4.0, True), ("POLE_PAIRS", 4.5, False), ("HARM_COMP_ENABLE", 1.0, True),
    ("HARM_COMP_ENABLE", 0.5, False), ("HARM_COMP_ENABLE", 2.0, False), ("DELAY_COMP_ENABLE", 2.0, True),
    ("DELAY_COMP_ENABLE", 3.0, False), ("RS_OHM", 0.123, True), ("RS_OHM", float("nan"), False),
    ("RS_OHM", 1e39, False), ("SPEED_LOOP_DIV", 10, True),
])
def test_parameter_kinds(name, value, ok):
    assert (params.BY_NAME[name].check(value) is None) == ok


def test_spec_sections_exist_for_every_rule_the_conformance_kit_cites():
    for section in ("6.0", "6.1", "6.2", "6.3", "6.4", "6.5", "6.6", "6.7", "6.8", "6.9", "2.4"):
        assert re.search(rf"^###? {re.escape(section)} ", DOC, re.M), section


def test_hello_status_mode_unsupported_is_specified():
    assert HelloStatus.MODE_UNSUPPORTED == 5
    assert "MODE_UNSUPPORTED" in DOC.split("### 6.1")[1].split("### 6.2")[0]


def test_the_spec_says_when_duties_act_as_the_plant_does():
    plant_h = (Path(__file__).resolve().parents[1] / "plant_rt/c/plant.h").read_text()
    assert "The duties commanded for period k\n * take effect at t_k + t_delay_s" in plant_h
    section = " ".join(DOC.split("### 6.4")[1].split("### 6.5")[0].split())
    assert "The plant applies the duties of DUTY(k) from t_k + t_d to the end of period k" in section
    assert "period k + 1" not in section
    assert "inside period seq" in dbc.message_spec("DUTY").comment
