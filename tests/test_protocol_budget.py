"""hil_bench.protocol.budget: serial and CAN bandwidth per control cycle (numbers checked by hand)."""
from __future__ import annotations

import pytest

from hil_bench.protocol import budget
from hil_bench.protocol.budget import (
    DUAL_SAMPLING,
    TELEM_EMF,
    can_frame_bits,
    can_max_rate_hz,
    cycle_messages,
    fd_payload_size,
    serial_bytes_per_cycle,
    serial_frame_bytes,
    serial_max_rate_hz,
)


def test_cycle_messages_follow_the_hello_flags():
    assert cycle_messages(0) == (("SENSE_AUX", "SENSE"), ("TELEM", "DUTY"))
    assert cycle_messages(DUAL_SAMPLING | TELEM_EMF) == (("SENSE_AUX", "SENSE_DUAL", "SENSE"),
                                                          ("TELEM", "TELEM_EMF", "DUTY"))
    assert (DUAL_SAMPLING, TELEM_EMF) == (1, 2)


def test_serial_budget():
    assert serial_frame_bytes(8) == 15  # 2 id + 1 dlc + 8 data + 2 crc + 1 COBS + 1 delimiter
    assert serial_frame_bytes(0) == 7 and serial_frame_bytes(64) == 71
    assert [serial_bytes_per_cycle(f) for f in (0, 1, 2, 3)] == [60, 75, 75, 90]
    assert serial_max_rate_hz(115_200, 0) == pytest.approx(192.0)
    assert serial_max_rate_hz(3_000_000, 0) == pytest.approx(5000.0)
    assert serial_max_rate_hz(921_600, 3) == pytest.approx(1024.0)


def test_classic_can_worst_case_frame_bits():
    # 8n + 47 + floor((34 + 8n - 1) / 4): 55 bits empty, 135 bits with 8 octets (Davis et al. 2007)
    assert can_frame_bits(0) == 55
    assert can_frame_bits(8) == 135
    assert can_max_rate_hz(1_000_000, 0) == pytest.approx(1e6 / 540)
    assert can_max_rate_hz(500_000, 3) == pytest.approx(5e5 / 810)
    with pytest.raises(ValueError):
        can_frame_bits(9)
    with pytest.raises(ValueError):
        can_frame_bits(8, brs_bitrate=5e6)


def test_can_fd_frame_bits():
    # n = 0: nominal 17 + 4 stuff + 13 = 34; data: ESI 1 + DLC 4 + stuff (floor(21/4) - 4 = 1)
    #        + stuff count 4 + CRC17 + 6 fixed stuff bits = 33
    assert can_frame_bits(0, fd=True) == 34 + 33
    # n = 64: data = 5 + 512 + (floor(533/4) - 4 = 129) + 4 + 21 + 7 = 678
    assert can_frame_bits(64, fd=True) == 34 + 678
    assert can_frame_bits(64, fd=True, brs_bitrate=5e6, bitrate=1e6) == pytest.approx(34 + 678 / 5)
    assert can_frame_bits(9, fd=True) == can_frame_bits(12, fd=True)
    assert fd_payload_size(9) == 12 and fd_payload_size(17) == 20 and fd_payload_size(64) == 64
    with pytest.raises(ValueError):
        fd_payload_size(65)


def test_can_fd_rates():
    per_msg = can_max_rate_hz(1e6, 0, fd=True, data_bitrate=5e6)
    bundled = can_max_rate_hz(1e6, 0, fd=True, data_bitrate=5e6, bundle=True)
    assert per_msg == pytest.approx(1e6 / (4 * can_frame_bits(8, True, 5e6, 1e6)))
    assert bundled == pytest.approx(1e6 / (2 * can_frame_bits(16, True, 5e6, 1e6)))
    assert bundled > per_msg > can_max_rate_hz(1e6, 0)
    with pytest.raises(ValueError):
        can_max_rate_hz(1e6, 0, bundle=True)


def test_more_frames_never_increase_the_rate():
    for rate in (lambda f: serial_max_rate_hz(2e6, f), lambda f: can_max_rate_hz(5e5, f),
                 lambda f: can_max_rate_hz(1e6, f, fd=True, data_bitrate=5e6, bundle=True)):
        assert rate(0) >= rate(DUAL_SAMPLING) >= rate(DUAL_SAMPLING | TELEM_EMF)
        assert rate(0) >= rate(TELEM_EMF) >= rate(DUAL_SAMPLING | TELEM_EMF)


def test_markdown_tables_mention_every_combination():
    text = budget.markdown_tables()
    for f in budget.FLAG_COMBINATIONS:
        assert budget.flags_name(f) in text
    assert "192 Hz" in text and "135 bits" in text
