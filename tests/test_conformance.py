"""``bench conformance`` (issue 9, item 12): the stub passes; controllers that break a rule fail the item of
docs/protocol.md that states it."""
from __future__ import annotations

import re

import pytest

from hil_bench.cli import main as cli_main
from hil_bench.conformance import run_conformance
from tests.kit_items import passes_its_rules, rule_failures

DOC_SECTIONS = {"2.4", "6.1", "6.2", "6.3", "6.4", "6.5", "6.6", "6.7", "6.8"}


def test_the_stub_passes_every_item(capsys):
    assert cli_main(["conformance", "--link", "stub"]) == 0
    out = capsys.readouterr().out
    items = re.findall(r"^  (PASS|FAIL|n/a )  (\d\.\d)", out, re.M)
    assert len(items) >= 20 and all(v == "PASS" for v, _ in items), out
    assert {s for _, s in items} == DOC_SECTIONS       # every rule is tied to a section of the spec
    flat = " ".join(out.split())
    assert "SENSE 150 sent again while the outputs change (state OPEN_LOOP): the same TELEM, TELEM_EMF, DUTY" in flat
    assert "the 8 cycles after the repeated SENSE answer exactly as in a session without the repeat" in flat
    assert "cycles 151..158 identical" in flat
    assert "a SENSE with a bad CRC is dropped" in out
    from hil_bench.protocol.params import PARAMS
    assert f"CONFIG of every parameter of the table ({len(PARAMS)}, protocol 1.1): each acknowledged" in flat


def test_over_can_the_crc_item_does_not_apply():
    result = run_conformance("stub-slcan", cycles=200)
    assert passes_its_rules(result), result.text()
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
    assert "the serial port /dev/nonexistent-hil-port does not exist" in capsys.readouterr().out


def _rerunning_controller():
    """The stub behind a proxy that makes it a controller breaking 6.5 in the way bytes cannot show: a
    repeated SENSE is passed on under a new seq (the stub runs its ISR again) while the host gets the
    first answer's frames again, byte for byte, as from a cache."""
    from hil_bench.protocol.messages import MESSAGES as M
    from tests.pty_proxy import PtyProxy, decode, encode

    st = {"offset": 0, "last_sense": None, "bumped": None, "replay": None, "cache_seq": None, "cache": []}

    def reseq(fid: int, payload: bytes, seq: int) -> bytes:
        return encode(fid, (seq & 0xFFFF).to_bytes(2, "little") + payload[2:])

    def to_controller(chunk: bytes) -> list[bytes]:
        frame = decode(chunk)
        if frame is None:
            return [chunk]
        fid, payload = frame
        if fid == M["HELLO"].frame_id:
            st.update(offset=0, last_sense=None, bumped=None, replay=None)
            return [chunk]
        if fid not in (M["SENSE_AUX"].frame_id, M["SENSE"].frame_id, M["SENSE_DUAL"].frame_id):
            return [chunk]
        seq = int.from_bytes(payload[:2], "little")
        if fid == M["SENSE_AUX"].frame_id and seq == st["last_sense"] and st["bumped"] != seq:
            st["offset"] += 1          # the repeat: the stub will see a new seq
            st["bumped"] = seq
        if fid == M["SENSE"].frame_id:
            if seq == st["bumped"] and seq == st["last_sense"]:
                st["replay"] = seq
            st["last_sense"] = seq
        return [reseq(fid, payload, seq + st["offset"])]

    def to_host(chunk: bytes) -> list[bytes]:
        frame = decode(chunk)
        if frame is None or frame[0] not in (M["TELEM"].frame_id, M["TELEM_EMF"].frame_id, M["DUTY"].frame_id):
            return [chunk]
        fid, payload = frame
        seq = (int.from_bytes(payload[:2], "little") - st["offset"]) & 0xFFFF
        if st["replay"] is not None and seq == st["replay"]:
            if fid != M["DUTY"].frame_id:
                return []                               # the ISR's fresh answer is dropped ...
            st["replay"] = None
            return list(st["cache"])                    # ... and the first one sent again
        out = reseq(fid, payload, seq)
        if seq != st["cache_seq"]:
            st["cache_seq"], st["cache"] = seq, []
        st["cache"].append(out)
        return [out]

    return PtyProxy(to_controller=to_controller, to_host=to_host)


def test_a_controller_that_reruns_its_isr_on_a_repeat_fails_though_its_bytes_match():
    proxy = _rerunning_controller()
    try:
        result = run_conformance(f"serial:{proxy.path}")
    finally:
        proxy.close()
    by_text = {i.text.split(" (")[0].split(":")[0]: i for i in result.items if i.section == "6.5"}
    cached = next(i for t, i in by_text.items() if t.startswith("SENSE 150 sent again while the outputs change"))
    assert cached.ok, result.text()                     # the bytes of the repeat are the cached ones
    after = next(i for t, i in by_text.items() if t.startswith("the 8 cycles after the repeated SENSE"))
    assert after.ok is False and "cycle 151 differs from the session without the repeat" in after.detail, \
        result.text()
    assert not result.passed


def test_an_encoder_drive_can_pass_the_kit():
    """Issue 19, point 8: ``--estimator ENCODER`` asks with ENCODER_VALID in HELLO and sends the
    plant's encoder angle with THETA_ENC_VALID in every SENSE_AUX (6.8), so a drive closing its
    loop on the encoder (the stub asked for ENCODER) passes every item."""
    result = run_conformance("stub", cycles=300, estimator="ENCODER")
    failed = [f"{i.section} {i.text}: {i.detail}" for i in rule_failures(result)]
    assert result.aborted is None and not failed, (result.aborted, failed)
    assert any("TELEM.estimator = ENCODER" in i.text and i.ok for i in result.items)


def _proxy_dropping_duty(nth: int, delay_s: float = 0.0):
    """The stub behind a proxy that loses its nth DUTY on the way to the host (``delay_s`` = 0), or
    holds it back that long (the pump waits: everything behind it is as late)."""
    import time

    from hil_bench.protocol.messages import MESSAGES as M
    from tests.pty_proxy import PtyProxy, decode

    seen = {"duties": 0}

    def to_host(chunk: bytes) -> list[bytes]:
        frame = decode(chunk)
        if frame is not None and frame[0] == M["DUTY"].frame_id:
            seen["duties"] += 1
            if seen["duties"] == nth:
                if not delay_s:
                    return []
                time.sleep(delay_s)
        return [chunk]

    return PtyProxy(to_host=to_host)


def test_after_the_cycles_stop_the_stop_probe_is_a_new_cycle_and_what_was_never_reached_is_na():
    """Issue 19, point 8: one DUTY lost for good (the kit does not retry) stops the session's cycles at
    that seq. The STOP probe then sends the next seq (the same one again would be a retry, answered
    from the cache: a controller that did stop looked as if it had not), and the items the session
    never got to (the repeat, the bad CRC, the reference session) are n/a, not a FAIL each: the one
    FAIL is the item whose rule broke."""
    proxy = _proxy_dropping_duty(100)
    try:
        result = run_conformance(f"serial:{proxy.path}")
    finally:
        proxy.close()
    by = {i.text.split(":")[0]: i for i in result.items}
    assert by["every SENSE answered with a DUTY of its seq"].ok is False
    assert by["after CMD STOP"].ok, result.text()
    na = [i for i in result.items if i.ok is None]
    assert {i.section for i in na} == {"2.4", "6.5"} and len(na) == 3, result.text()
    assert all("not reached: no answer since cycle 99" in i.detail for i in na), result.text()
    assert [i.text for i in rule_failures(result)] == ["every SENSE answered with a DUTY of its seq"]


def _time_item(result):
    items = [i for i in result.items if i.text.startswith("answer time:")]
    assert len(items) == 1, result.text()
    return items[0]


def test_one_late_answer_is_named_but_the_drive_is_judged_on_its_typical_answers():
    """Issue 26, item 4: the answer-time item holds the median and the p90 of the session's answer times
    (less the host's own loopback) to KIT_ANSWER_LIMIT_S; one answer held back 125 ms (a host stall looks
    the same) is named with its time and moves neither: PASS."""
    from hil_bench.protocol.timing import KIT_ANSWER_LIMIT_S

    proxy = _proxy_dropping_duty(50, delay_s=2.5 * KIT_ANSWER_LIMIT_S)
    try:
        result = run_conformance(f"serial:{proxy.path}")
    finally:
        proxy.close()
    item = _time_item(result)
    assert item.ok is True, result.text()
    # seq 49 named with its time (about 125 ms); a busy host may hold back others too, each named
    assert re.search(r"\d+ late \(beyond 50 ms\): .*seq 49 1\d\d ms", item.detail), item.detail
    assert "median" in item.detail and "p90" in item.detail
    assert any(i.text.startswith("every SENSE answered") and i.ok for i in result.items)
    assert not rule_failures(result), result.text()


def test_a_drive_that_answers_slowly_every_cycle_fails_the_answer_time_item():
    """Every DUTY held back beyond the limit: the median is, the item fails with the figures."""
    from hil_bench.protocol.timing import KIT_ANSWER_LIMIT_S

    proxy = _proxy_delaying_every_duty(1.3 * KIT_ANSWER_LIMIT_S)
    try:
        result = run_conformance(f"serial:{proxy.path}", cycles=60)
    finally:
        proxy.close()
    item = _time_item(result)
    assert item.ok is False, result.text()
    assert "60 answers: median 6" in item.detail, item.detail
    assert [i.text for i in rule_failures(result)] == [item.text], result.text()


def _proxy_delaying_every_duty(delay_s: float):
    import time

    from hil_bench.protocol.messages import MESSAGES as M
    from tests.pty_proxy import PtyProxy, decode

    def to_host(chunk: bytes) -> list[bytes]:
        frame = decode(chunk)
        if frame is not None and frame[0] == M["DUTY"].frame_id:
            time.sleep(delay_s)
        return [chunk]

    return PtyProxy(to_host=to_host)


def _proxy_changing_duty(nth: int, how: str):
    """The stub behind a proxy that spoils its nth DUTY on the way to the host: ``crc`` flips an octet
    (the frame fails its CRC), ``seq+1`` sends it with the next seq."""
    from hil_bench.protocol.messages import MESSAGES as M
    from tests.pty_proxy import PtyProxy, decode, encode

    seen = {"duties": 0}

    def to_host(chunk: bytes) -> list[bytes]:
        frame = decode(chunk)
        if frame is None or frame[0] != M["DUTY"].frame_id:
            return [chunk]
        seen["duties"] += 1
        if seen["duties"] != nth:
            return [chunk]
        if how == "crc":   # the same frame with its CRC off by one bit
            from hil_bench.protocol.framing import cobs_encode, crc16

            body = bytes((frame[0] & 0xFF, frame[0] >> 8, len(frame[1]))) + frame[1]
            crc = crc16(body) ^ 0x0001
            return [cobs_encode(body + bytes((crc & 0xFF, crc >> 8)))]
        payload = frame[1]
        seq = (int.from_bytes(payload[:2], "little") + 1) & 0xFFFF
        return [encode(frame[0], seq.to_bytes(2, "little") + payload[2:])]

    return PtyProxy(to_host=to_host)


@pytest.mark.parametrize("how, words", [
    ("crc", "no DUTY for seq 99: 1 frame(s) failed the CRC check (section 2.4): an answer damaged on the way; "
            "frames that came: TELEM seq 99, TELEM_EMF seq 99"),
    ("drop", "no DUTY for seq 99: its DUTY never came (lost: nothing was rejected); frames that came: "
             "TELEM seq 99, TELEM_EMF seq 99"),
    ("seq+1", "no DUTY for seq 99: a DUTY came with seq 100, expected 99; frames that came: TELEM seq 99, "
              "TELEM_EMF seq 99, DUTY seq 100"),
])
def test_a_missing_duty_is_diagnosed_by_what_came_instead(how, words):
    """Issue 29, item 6: one line per cause: a DUTY that failed its CRC, one that never came, one with
    another seq (named, with the frames that came) read differently."""
    proxy = _proxy_dropping_duty(100) if how == "drop" else _proxy_changing_duty(100, how)
    try:
        result = run_conformance(f"serial:{proxy.path}")
    finally:
        proxy.close()
    item = next(i for i in result.items if i.text == "every SENSE answered with a DUTY of its seq")
    assert item.ok is False and words in " ".join(item.detail.split()), item.detail


def test_when_no_cycle_is_answered_the_items_about_answers_are_na_not_fail():
    """Issue 29, item 6: the first DUTY comes with seq 1: 'every SENSE answered' fails, naming it; the
    items that judge the answers (order, duties, estimator, states, answer time) had none: n/a, never
    FAIL '0/0'."""
    proxy = _proxy_changing_duty(1, "seq+1")
    try:
        result = run_conformance(f"serial:{proxy.path}")
    finally:
        proxy.close()
    by = {i.text.split(":")[0]: i for i in result.items}
    assert by["every SENSE answered with a DUTY of its seq"].ok is False
    assert "a DUTY came with seq 1, expected 0" in by["every SENSE answered with a DUTY of its seq"].detail
    for text in ("TELEM, then TELEM_EMF (asked for), then DUTY, nothing else, seq echoed",
                 "duties in 0..1 (raw 0..32768) or OFF (65535)", "TELEM.state in the State table; no FAULT_CTRL",
                 "answer time"):
        assert by[text].ok is None and "no cycle was answered" in by[text].detail, (text, by[text])
    assert not any("0/0" in i.detail for i in result.items), result.text()


def test_a_correct_drive_gets_the_same_verdict_on_a_busy_host():
    """Issue 26, item 4: the stub with CPU hogs beside it (two per core) passes every item, answer time and
    heartbeat included: the kit judges the drive, not the host's scheduler."""
    import multiprocessing as mp
    import os

    hogs = [mp.get_context("fork").Process(target=_spin, daemon=True) for _ in range(2 * (os.cpu_count() or 1))]
    for h in hogs:
        h.start()
    try:
        result = run_conformance("stub")
    finally:
        for h in hogs:
            h.terminate()
            h.join()
    assert result.passed, result.text()


def _spin() -> None:
    while True:
        pass


def test_too_few_cycles_to_reach_the_repeat_is_refused(capsys):
    from hil_bench.conformance import MIN_CYCLES

    assert cli_main(["conformance", "--link", "stub", "--cycles", str(MIN_CYCLES - 1)]) == 2
    assert f"at least {MIN_CYCLES} cycles" in capsys.readouterr().out


def _proxy(to_controller=None, to_host=None):
    from tests.pty_proxy import PtyProxy

    return PtyProxy(to_controller=to_controller, to_host=to_host)


def test_a_drive_silent_after_fault_plant_fails_the_fault_plant_items():
    """Issue 19, point 8: the old 6.4 sentence ("sends nothing after FAULT_PLANT until a new HELLO")
    contradicted 6.0/6.7 (idle heartbeats). The spec now says: stop as on CMD STOP, keep answering
    SENSE, keep the heartbeat. A drive that follows the old sentence (the stub behind a proxy that
    swallows everything it sends from FAULT_PLANT until the next HELLO) fails both 6.7 items that
    state it, and only those."""
    from hil_bench.protocol.messages import MESSAGES as M
    from tests.pty_proxy import decode

    st = {"mute": False}

    def to_controller(chunk: bytes) -> list[bytes]:
        frame = decode(chunk)
        if frame is not None and frame[0] == M["FAULT_PLANT"].frame_id:
            st["mute"] = True
        elif frame is not None and frame[0] == M["HELLO"].frame_id:
            st["mute"] = False
        return [chunk]

    proxy = _proxy(to_controller, lambda chunk: [] if st["mute"] else [chunk])
    try:
        result = run_conformance(f"serial:{proxy.path}")
    finally:
        proxy.close()
    failed = [i.text for i in rule_failures(result)]
    assert len(failed) == 2, result.text()
    assert failed[0].startswith("FAULT_PLANT: the controller stops as on CMD STOP"), failed
    assert failed[1].startswith("HEARTBEAT_CTRL again once cycles stop"), failed


def test_a_drive_whose_run_clears_a_fault_fails_the_fault_item():
    """Issue 19, point 8 (the state after CLEAR_FAULT was unstated): 6.3 says a controller stays in
    FAULT, RUN ignored, until CLEAR_FAULT, which returns it to IDLE with its configuration kept. A drive
    whose RUN clears a fault by itself (the stub behind a proxy that puts a CLEAR_FAULT before every
    RUN) fails that item; the incomplete-configuration item before it still passes."""
    from hil_bench.protocol.messages import MESSAGES as M
    from hil_bench.protocol.messages import Command
    from tests.pty_proxy import decode, encode

    cmd = M["CMD"]

    def to_controller(chunk: bytes) -> list[bytes]:
        frame = decode(chunk)
        if frame is not None and frame[0] == cmd.frame_id and cmd.unpack(frame[1])["command"] == Command.RUN:
            seq = int(cmd.unpack(frame[1])["seq"])
            return [encode(cmd.frame_id, cmd.pack(command=int(Command.CLEAR_FAULT), seq=seq, value=0.0)), chunk]
        return [chunk]

    proxy = _proxy(to_controller)
    try:
        result = run_conformance(f"serial:{proxy.path}")
    finally:
        proxy.close()
    by = {i.text.split(":")[0].split(" (")[0]: i for i in result.items if i.section == "6.3"}
    assert by["RUN with an incomplete configuration"].ok, result.text()
    stays = by["in FAULT, CONFIG is accepted and RUN ignored"]
    assert stays.ok is False and "state FAULT" not in stays.detail, result.text()
    assert not result.passed
