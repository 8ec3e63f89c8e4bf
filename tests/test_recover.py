"""``bench recover`` (issue 9, item 7): every intact chunk of a damaged recording is copied, also those after
the damage, into a file the mcap library reads with CRC checks; real recordings damaged here."""
from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader

from hil_bench.cli import main as cli_main
from hil_bench.loop.runner import run_scenario
from hil_bench.record.recording import load_recording
from hil_bench.record.recover import RecoverError, recover
from hil_bench.scenario import derive_scenario


#: G2's first 0.6 s: 20 chunks of 256 kB (36 000 messages, 2.5 MB). What is recovered is each
#: chunk on its own, so the full run's 54 chunks prove nothing 20 do not: there are chunks on both
#: sides of the damaged middle one, and a cut at 90 % of the file leaves 18 whole chunks, more
#: than the 85 % of the messages asserted below. The controller runs in the engine (--link sil:
#: the same rows as the stub's, tests/test_sil.py): the subject is the file, not the link.
SHORT_G2 = {"scenario.duration_s": 0.6, "metrics.window_s": [0.0, 0.6]}


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("rec") / "g2.mcap"
    result = run_scenario(derive_scenario("gong_g2_500rpm", "g2_short", list(SHORT_G2.items())),
                          link_spec="sil", out_path=out, progress=False)
    assert result.ok, result.error
    assert len(_chunk_offsets(out)) >= 20
    return out


def _valid_mcap(path: Path) -> dict[str, int]:
    """Read every message with CRC validation, the summary included; messages per topic."""
    counts: dict[str, int] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        for _, channel, _ in reader.iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
        assert summary.statistics.message_count == sum(counts.values())
    with open(path, "rb") as f:   # and sequentially, to the footer
        assert sum(1 for _ in StreamReader(f, validate_crcs=True).records) > 0
    return counts


def _chunk_offsets(path: Path) -> list[int]:
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    return sorted(ci.chunk_start_offset for ci in summary.chunk_indexes)


def test_eight_flipped_bytes_at_half_lose_one_chunk_not_the_second_half(recording, tmp_path, capsys):
    original = _valid_mcap(recording)
    data = bytearray(recording.read_bytes())
    at = len(data) // 2
    for i in range(8):
        data[at + i] ^= 0xFF
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    before = load_recording(damaged)
    # the reader skips the damaged chunk, reads on and says so (or stops there if the damage hit
    # a record's framing): either way the check points to `bench recover`
    assert before.damaged and before.messages < sum(original.values())

    fixed = tmp_path / "fixed.mcap"
    assert cli_main(["recover", str(damaged), "-o", str(fixed)]) == 0
    out = capsys.readouterr().out
    assert "1 damaged chunk(s)" in out and "messages recovered" in out
    counts = _valid_mcap(fixed)
    assert set(counts) == set(original)
    lost = sum(original.values()) - sum(counts.values())
    n_chunks = len(_chunk_offsets(recording))
    assert 0 < lost < 2.0 * sum(original.values()) / n_chunks   # about one chunk's messages
    after = load_recording(fixed)
    assert after.truncated is None and after.messages == sum(counts.values())
    assert set(after.metadata) == {"run", "controller", "run_result", "sidecar.serial.bin"}   # written at the end: survive
    assert any(a.startswith("scenario/") for a in after.attachments)
    # encoding-agnostic: the messages are the original octets (the first 1000 of /plant/state, before the damage)
    assert _payloads(fixed, "/plant/state")[:1000] == _payloads(recording, "/plant/state")[:1000]


def _payloads(path: Path, topic: str) -> list[bytes]:
    with open(path, "rb") as f:
        return [m.data for _, _, m in make_reader(f).iter_messages(topics=[topic])]


def test_a_damaged_record_header_is_passed_by_scanning_to_the_next_intact_chunk(recording, tmp_path):
    offsets = _chunk_offsets(recording)
    victim = offsets[len(offsets) // 2]
    data = bytearray(recording.read_bytes())
    data[victim:victim + 9] = b"\xAA" * 9          # opcode and length gone: only a scan finds the next one
    damaged = tmp_path / "header.mcap"
    damaged.write_bytes(bytes(data))
    report = recover(damaged, tmp_path / "header_fixed.mcap")
    assert report.skipped and report.skipped[0][0] == victim
    chunk_record = 9 + int.from_bytes(recording.read_bytes()[victim + 1:victim + 9], "little")
    assert report.skipped[0][1] == chunk_record      # exactly that chunk: the scan resumes right after it
    assert report.chunks_ok == len(offsets) - 1
    _valid_mcap(tmp_path / "header_fixed.mcap")


def test_a_file_cut_at_90_percent_keeps_every_complete_chunk(recording, tmp_path):
    data = recording.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.9)])
    report = recover(cut, tmp_path / "cut_fixed.mcap")
    assert not report.had_footer and report.bytes_skipped > 0
    counts = _valid_mcap(tmp_path / "cut_fixed.mcap")
    complete = [o for o in _chunk_offsets(recording) if o < len(data) * 0.9]
    assert report.chunks_ok >= len(complete) - 1
    assert sum(counts.values()) > 0.85 * sum(_valid_mcap(recording).values())
    assert "run" in load_recording(tmp_path / "cut_fixed.mcap").metadata


def test_an_intact_file_comes_out_whole(recording, tmp_path):
    report = recover(recording, tmp_path / "same.mcap")
    assert report.bytes_skipped == 0 and report.chunks_bad == 0 and report.had_footer
    assert _valid_mcap(tmp_path / "same.mcap") == _valid_mcap(recording)


def test_bad_inputs_are_refused_clearly(tmp_path, recording):
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    with pytest.raises(RecoverError, match="not an MCAP file"):
        recover(junk)
    with pytest.raises(RecoverError, match="cannot open"):
        recover(tmp_path / "missing.mcap")
    with pytest.raises(RecoverError, match="is the damaged file itself"):
        recover(recording, recording)
    assert cli_main(["recover", str(junk)]) == 2


def test_an_existing_output_is_never_replaced_without_force(recording, tmp_path, capsys):
    """-o names an existing recording, or the default <x>.recovered.mcap exists: refused, both
    files untouched; --force replaces it."""
    src = tmp_path / "cut.mcap"
    src.write_bytes(recording.read_bytes()[: int(recording.stat().st_size * 0.9)])
    existing = tmp_path / "existing.mcap"
    existing.write_bytes(b"precious" * 100)
    with pytest.raises(RecoverError, match="-o .*existing.mcap: file exists; refusing to overwrite"):
        recover(src, existing)
    assert cli_main(["recover", str(src), "-o", str(existing)]) == 2
    assert "refusing to overwrite" in " ".join(capsys.readouterr().err.split())
    assert existing.read_bytes() == b"precious" * 100
    # the default name, a second time
    first = recover(src)
    assert first.output == tmp_path / "cut.recovered.mcap"
    before = first.output.read_bytes()
    with pytest.raises(RecoverError, match="cut.recovered.mcap: file exists"):
        recover(src)
    assert first.output.read_bytes() == before
    # --force replaces
    assert cli_main(["recover", str(src), "-o", str(existing), "--force"]) == 0
    assert _valid_mcap(existing) and load_recording(existing).messages == first.messages_total


def test_an_empty_file_is_said_to_be_empty(tmp_path):
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(RecoverError, match="empty file \\(0 octets\\): nothing was recorded"):
        recover(empty)


@pytest.mark.parametrize("damage", ["magic", "magic_and_header"])
def test_a_damaged_magic_is_passed_by_scanning_for_records(recording, tmp_path, damage):
    """Issue 19, point 3/4: the first 4 octets (or the whole magic and the header record) damaged,
    every chunk intact: every message is recovered, the damage is reported where it is."""
    original = _valid_mcap(recording)
    data = bytearray(recording.read_bytes())
    n = 4 if damage == "magic" else 8 + 9 + int.from_bytes(data[9:17], "little")
    for i in range(n):
        data[i] ^= 0x5A
    damaged = tmp_path / f"{damage}.mcap"
    damaged.write_bytes(bytes(data))
    report = recover(damaged, tmp_path / f"{damage}_fixed.mcap")
    assert report.chunks_ok == len(_chunk_offsets(recording)) and report.chunks_bad == 0
    assert report.skipped[0][0] == 0 and "magic" in report.skipped[0][2]
    assert report.bytes_skipped == (8 if damage == "magic" else n)
    assert _valid_mcap(tmp_path / f"{damage}_fixed.mcap") == original
    assert "run" in load_recording(tmp_path / f"{damage}_fixed.mcap").metadata


def test_a_file_without_magic_or_any_record_is_not_an_mcap_file(tmp_path):
    junk = tmp_path / "noise.mcap"
    junk.write_bytes(bytes(range(256)) * 64)
    with pytest.raises(RecoverError, match="not an MCAP file: no MCAP magic at the start and no "
                                           "intact MCAP record anywhere in its 16384 octets"):
        recover(junk)
