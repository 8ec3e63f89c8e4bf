"""``bench conformance`` (issue 9, item 12): the stub passes; controllers that break a rule fail the item of
docs/protocol.md that states it."""
from __future__ import annotations

import re

import pytest

from bench.cli import main as cli_main
from bench.conformance import run_conformance

DOC_SECTIONS = {"2.4", "6.1", "6.2", "6.3", "6.4", "6.5", "6.6", "6.7", "6.8"}


def test_the_stub_passes_every_item(capsys):
    assert cli_main(["conformance", "--link", "stub"]) == 0
    out = capsys.readouterr().out
    items = re.findall(r"^  (PASS|FAIL|n/a )  (\d\.\d)", out, re.M)
    assert len(items) >= 20 and all(v == "PASS" for v, _ in items), out
    assert {s for _, s in items} == DOC_SECTIONS       # every rule is tied to a section of the spec
    assert "SENSE 150 sent again: the same TELEM, TELEM_EMF, DUTY byte for byte" in out
    assert "a SENSE with a bad CRC is dropped" in out


def test_over_can_the_crc_item_does_not_apply():
    result = run_conformance("stub-slcan", cycles=200)
    assert result.passed, result.text()
    crc = [i for i in result.items if i.section == "2.4"]
    assert len(crc) == 1 and crc[0].ok is None and "CAN" in crc[0].detail


@pytest.mark.parametrize("inject, section, words", [
    ("bad-duty@50", "6.6", "duties in 0..1"),
    ("wrong-dlc@60", "6.4", "TELEM, then TELEM_EMF"),
    ("silent@100", "6.4", "every SENSE answered"),
])
def test_a_controller_that_breaks_a_rule_fails_that_item(inject, section, words):
    result = run_conformance("stub", ("--inject", inject))
    assert not result.passed
    failed = [i for i in result.items if i.ok is False]
    assert any(i.section == section and words in i.text for i in failed), result.text()
    # and the items it did not break still pass
    assert any(i.ok for i in result.items if i.section == "6.1")


def test_a_link_that_does_not_open_is_reported_not_raised(capsys):
    assert cli_main(["conformance", "--link", "serial:/dev/nonexistent-hil-port"]) == 2
    assert "cannot open serial port" in capsys.readouterr().out
