"""bench replay of CAN logs in every format python-can writes, and of damaged captures of every
kind (docs/replay.md "Inputs", "Damaged captures"). The logs are written by python-can's own
``can.Logger`` from the frames of a bench capture (examples/captures/example.log.gz), so that a
replay must give back the recording's reference estimates bit for bit."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

can = pytest.importorskip("can")

from hil_bench.papers.check import check_recording  # noqa: E402
from hil_bench.plant_rt.profile import load_profile  # noqa: E402
from hil_bench.record.recording import load_recording  # noqa: E402
from hil_bench.replay import CaptureError, ReplayOptions, read_capture, run_replay  # noqa: E402
from hil_bench.replay.canlog import read_log  # noqa: E402

EX = Path(__file__).resolve().parents[1] / "examples" / "captures"
REF = {"SMO_SIGN": {"k_v": 25.0, "wc_rad_s": 300.0}}
N_CYCLES = 500
SENSE_ID = 0x100


def _opts(tmp_path, name, **kw):
    kw.setdefault("estimators", list(REF))
    kw.setdefault("est_config", REF)
    kw.setdefault("profile", "gong2020")
    return ReplayOptions(out=tmp_path / f"{name}.mcap", **kw)


def _ref(path):
    return load_recording(path, topics=["/reference/SMO_SIGN"]).topics["/reference/SMO_SIGN"]


def _same_prefix(a, b) -> bool:
    n = len(b["t_s"])
    return n > 0 and all(np.array_equal(a[f][:n], b[f], equal_nan=True)
                         for f in ("t_s", "seq", "theta_hat_rad", "omega_hat_rad_s"))


@pytest.fixture(scope="module")
def msgs():
    return list(can.LogReader(str(EX / "example.log.gz")))


def _write(path: Path, msgs) -> Path:
    with can.Logger(str(path)) as lg:
        for m in msgs:
            lg.on_message_received(m)
    return path


def _lines_of(path: Path) -> dict[int, int]:
    """message index -> line number (as the reader read them)."""
    where: list[str] = []
    read_log(path, lambda _m, w: where.append(w))
    return {i: int(w.split()[1]) for i, w in enumerate(where)}


def _anomalies(cap):
    d = {k: v for k, v in cap.anomalies.as_dict().items() if v}
    d.pop("damaged", None)
    return d


# -- every format python-can writes --------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".asc", ".blf", ".trc", ".csv", ".log", ".asc.gz", ".trc.gz",
                                    ".csv.gz", ".mf4"])
def test_log_written_by_python_can_replays(tmp_path, msgs, suffix):
    """A log of each format, written by python-can's Logger from a bench capture, replays offline
    to the recording's own reference estimates, bit for bit, with nothing reported."""
    if suffix == ".mf4":
        pytest.importorskip("asammdf", reason="python-can reads and writes .mf4 only with its "
                                               "optional dependency asammdf, not installed here")
    p = _write(tmp_path / f"bus{suffix}", msgs)
    cap = read_capture(p)
    assert cap.n == N_CYCLES and not cap.problems, cap.problems
    assert cap.anomalies.summary() == "none"
    res = run_replay(cap, _opts(tmp_path, "o"))
    assert res.ok and res.cycles == N_CYCLES
    a, b = _ref(EX / "example.mcap"), _ref(res.out)
    assert len(b["t_s"]) == len(a["t_s"]) and _same_prefix(a, b)


# -- one bad line costs that line only -----------------------------------------------------------

def _spoil(line: str, suffix: str) -> str:
    """A line python-can's reader raises on: a data octet that is not hex (CSV: the id)."""
    if suffix == ".csv":
        f = line.split(",")
        f[1] = "ZZZ"
        return ",".join(f)
    return line.rstrip()[:-1] + "Z"


@pytest.mark.parametrize("suffix", [".log", ".asc", ".trc", ".csv"])
def test_bad_line_costs_that_line_only(tmp_path, msgs, suffix):
    """A line the reader raises on is reported with its number and left out; a new reader of the
    same class resumes after it with the file's header (TRC: version and columns; CSV: the header
    line), so every other line is read: the anomalies are exactly those of the log without that
    message."""
    j = len(msgs) // 2
    good = _write(tmp_path / f"good{suffix}", msgs)
    line_no = _lines_of(good)[j]
    lines = good.read_bytes().decode().split("\n")
    lines[line_no - 1] = _spoil(lines[line_no - 1], suffix)
    bad = tmp_path / f"bad{suffix}"
    bad.write_bytes("\n".join(lines).encode())
    cap = read_capture(bad)
    assert cap.anomalies.as_dict()["damaged"] == 1
    assert any(f"1 damaged line(s) left out (line {line_no})" in p for p in cap.problems), \
        cap.problems
    without = read_capture(_write(tmp_path / f"without{suffix}", msgs[:j] + msgs[j + 1:]))
    assert cap.n == without.n >= N_CYCLES - 1
    assert _anomalies(cap) == _anomalies(without)


@pytest.mark.parametrize("suffix", [".asc", ".trc"])
def test_line_the_reader_passes_over_is_reported(tmp_path, msgs, suffix):
    """ASCReader skips a line its pattern does not match and TRCReader one it cannot split into
    its columns, without raising: such a line is still found (lines read vs messages) and
    reported as damage with its number."""
    j = len(msgs) // 3
    good = _write(tmp_path / f"good{suffix}", msgs)
    line_no = _lines_of(good)[j]
    lines = good.read_bytes().decode().split("\n")
    s = lines[line_no - 1]
    if suffix == ".asc":      # the time stamp spoiled: "12.345678" -> "12.34x678"
        i = s.index(".") + 3
        lines[line_no - 1] = s[:i] + "x" + s[i + 1:]
    else:                     # a TRC line cut to three columns
        lines[line_no - 1] = " ".join(s.split()[:3])
    bad = tmp_path / f"bad{suffix}"
    bad.write_bytes("\n".join(lines).encode())
    cap = read_capture(bad)
    assert any(f"line {line_no}" in p and "damaged" in p for p in cap.problems), cap.problems
    assert cap.anomalies.as_dict()["damaged"] == 1


# -- truncation is never silent ------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".log", ".asc", ".trc", ".csv"])
def test_text_log_cut_inside_a_line(tmp_path, msgs, suffix):
    """A text log cut in the middle of a line: said with the line and byte, that line left out
    (never read half), the cycles before it replayed as recorded."""
    data = _write(tmp_path / f"full{suffix}", msgs).read_bytes()
    cut = int(len(data) * 0.4)
    while data[cut - 1:cut] == b"\n" or data[cut:cut + 1] in (b"\n", b"\r"):
        cut += 1
    p = tmp_path / f"cut{suffix}"
    p.write_bytes(data[:cut])
    cap = read_capture(p)
    n_line = data[:cut].count(b"\n") + 1
    start = data[:cut].rfind(b"\n") + 1
    assert any(f"file ends inside line {n_line} (byte {start})" in x and "truncated" in x
               for x in cap.problems), cap.problems
    assert 0.3 * N_CYCLES < cap.n < 0.5 * N_CYCLES
    res = run_replay(cap, _opts(tmp_path, "o"))
    assert _same_prefix(_ref(EX / "example.mcap"), _ref(res.out))


def test_blf_cut_in_the_middle(tmp_path, msgs):
    """A BLF cut in the middle: its header's size and object count say so."""
    data = _write(tmp_path / "full.blf", msgs).read_bytes()
    p = tmp_path / "cut.blf"
    p.write_bytes(data[: len(data) // 2])
    cap = read_capture(p)
    assert any("truncated: the BLF header says" in x and str(len(data)) in x
               for x in cap.problems), cap.problems
    assert 0 < cap.n < N_CYCLES
    assert _same_prefix(_ref(EX / "example.mcap"), _ref(run_replay(cap, _opts(tmp_path, "o")).out))


def test_blf_with_a_corrupt_container(tmp_path, msgs):
    data = bytearray(_write(tmp_path / "full.blf", msgs).read_bytes())
    data[len(data) // 2] ^= 0xFF
    p = tmp_path / "bad.blf"
    p.write_bytes(bytes(data))
    with pytest.raises(CaptureError, match=r"bad\.blf: .*byte \d+.*cannot read on after message"):
        read_capture(p)            # the damage is in the first container: nothing before it


@pytest.mark.timeout(60)
def test_cut_gzip_log(tmp_path):
    """A .log.gz cut short ends the capture after the last octets that decompressed (it used to
    hang, re-reading the broken stream forever): said with the compressed byte offset."""
    data = (EX / "example.log.gz").read_bytes()
    p = tmp_path / "cut.log.gz"
    p.write_bytes(data[: int(len(data) * 0.6)])
    cap = read_capture(p)
    assert any("truncated compressed stream" in x and f"compressed byte {int(len(data) * 0.6)}"
               in x for x in cap.problems), cap.problems
    assert 0.4 * N_CYCLES < cap.n < 0.8 * N_CYCLES
    assert _same_prefix(_ref(EX / "example.mcap"), _ref(run_replay(cap, _opts(tmp_path, "o")).out))


@pytest.mark.timeout(60)
def test_corrupt_gzip_log(tmp_path):
    """A flipped octet inside the compressed stream: zlib finds it (often only at the CRC), the
    text decoded after the damage is garbage, so the capture is read up to its first unreadable
    line; the cycles before it replay as recorded."""
    data = bytearray((EX / "example.log.gz").read_bytes())
    data[int(0.4 * len(data))] ^= 0x55     # (where the damage decodes to an unreadable line)
    p = tmp_path / "flip.log.gz"
    p.write_bytes(bytes(data))
    cap = read_capture(p)
    assert any("corrupt compressed stream" in x for x in cap.problems), cap.problems
    assert any("damaged line(s) left out" in x for x in cap.problems), cap.problems
    assert 0 < cap.n < N_CYCLES
    assert _same_prefix(_ref(EX / "example.mcap"), _ref(run_replay(cap, _opts(tmp_path, "o")).out))


def test_corrupt_gzip_log_whose_damage_still_parses(tmp_path):
    """Where the flipped octet changes values that still parse as candump lines (here, in the
    middle of the example's stream), no line can be left out: the capture says its values
    cannot be trusted, and the replay records that as a capture_damage event."""
    data = bytearray((EX / "example.log.gz").read_bytes())
    data[len(data) // 2] ^= 0x55
    p = tmp_path / "flip.log.gz"
    p.write_bytes(bytes(data))
    cap = read_capture(p)
    assert any("the capture's values cannot be trusted" in x for x in cap.problems), cap.problems
    res = run_replay(cap, _opts(tmp_path, "o"))
    ev = load_recording(res.out, topics=["/events"]).topic("/events")
    assert any("cannot be trusted" in str(t) for t in ev["text"]), ev


def test_daq_csv_cut_inside_its_last_field(tmp_path):
    """A DAQ export cut inside its last field would give a wrong value (12.34 of 12.3456): the
    unterminated line is reported and left out."""
    data = (EX / "example_daq.csv").read_bytes()
    cut = len(data) - 3                    # inside the encoder angle of the last line
    p = tmp_path / "cut.csv"
    p.write_bytes(data[:cut])
    prof = load_profile("gong2020")
    cap = read_capture(p, mapping=EX / "example_daq.toml", profile=prof)
    n_line = data[:cut].count(b"\n") + 1
    assert any(f"file ends inside line {n_line}" in x for x in cap.problems), cap.problems
    full = read_capture(EX / "example_daq.csv", mapping=EX / "example_daq.toml", profile=prof)
    assert cap.resampling["samples"] == full.resampling["samples"] - 1


# -- MCAP -----------------------------------------------------------------------------------------

def test_mcap_with_a_damaged_first_chunk(tmp_path):
    """A damaged first chunk: the bench's recorder declares every schema and channel before the
    first chunk (and again in the summary), so every later chunk replays, with or without the
    summary. (A file whose only channel records besides the summary sit in the damaged chunk,
    as other writers make it, is test_mcap_whose_channels_were_in_the_damaged_chunk.)"""
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    src = EX / "example.mcap"
    with open(src, "rb") as f:
        ends = []
        for r in StreamReader(f, emit_chunks=True).records:
            if isinstance(r, Chunk):
                ends.append(f.tell())
    data = bytearray(src.read_bytes())
    data[ends[0] - 2000] ^= 0xFF
    p = tmp_path / "bad.mcap"
    p.write_bytes(bytes(data))
    cap = read_capture(p)
    assert any(f"chunk ending at byte {ends[0]}" in x for x in cap.problems), cap.problems
    assert 0 < cap.n < N_CYCLES
    rec = load_recording(p)
    assert rec.orphan_messages == 0 and rec.unreadable_chunks == 1
    # without the summary too: the channels declared up front still name every message
    p2 = tmp_path / "bad_cut.mcap"
    p2.write_bytes(bytes(data[: ends[-1]]))
    rec2 = load_recording(p2)
    assert rec2.orphan_messages == 0 and rec2.unreadable_chunks == 1 and rec2.messages > 0


def test_mcap_whose_channels_were_in_the_damaged_chunk(tmp_path):
    """mcap's own Writer puts a channel's record in the chunk of its first message: with that
    chunk damaged and no summary, the later messages of the lost channel cannot be decoded; they
    are counted, with the byte offset, never dropped silently."""
    import io

    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader
    from mcap.writer import Writer

    buf = io.BytesIO()
    w = Writer(buf, chunk_size=2000)
    w.start()
    cid = w.register_channel("/a", "json", w.register_schema("s", "jsonschema", b"{}"))
    for i in range(200):
        w.add_message(cid, log_time=i * 1000, data=b'{"x": %d}' % i, publish_time=i * 1000)
    w.finish()
    data = bytearray(buf.getvalue())
    with io.BytesIO(bytes(data)) as f:
        ends = []
        for r in StreamReader(f, emit_chunks=True).records:
            if isinstance(r, Chunk):
                ends.append(f.tell())
    assert len(ends) > 2
    data[ends[0] - 100] ^= 0xFF
    p = tmp_path / "cut.mcap"
    p.write_bytes(bytes(data[: ends[-1]]))
    rec = load_recording(p)
    assert rec.unreadable_chunks == 1 and rec.orphan_messages > 0
    assert any("messages on channel id" in d and "byte" in d for d in rec.damage), rec.damage


# -- time stamps ----------------------------------------------------------------------------------

def test_one_corrupt_time_stamp_is_one_event(tmp_path, msgs):
    """A time stamp 1000 s off: one implausible jump forward (damaged) and one step back
    (out_of_order), not one event for every later frame."""
    m = list(msgs)
    j = len(m) // 2
    m[j] = can.Message(timestamp=m[j].timestamp + 1000.0, arbitration_id=m[j].arbitration_id,
                       data=m[j].data, is_extended_id=False)
    cap = read_capture(_write(tmp_path / "t.log", m))
    an = cap.anomalies.as_dict()
    assert an["out_of_order"] == 1 and an["damaged"] == 1
    assert cap.n == N_CYCLES


# -- bench check reads every replay like a live run -------------------------------------------

@pytest.mark.parametrize("kind", ["can", "csv"])
def test_bench_check_on_offline_replays(tmp_path, kind):
    """An offline replay of a CAN log or of the DAQ CSV carries the plant parameters of its run
    (the profile's, with the capture's period), so bench check reads it as it reads a live run."""
    if kind == "can":
        cap = read_capture(EX / "example.log.gz")
    else:
        cap = read_capture(EX / "example_daq.csv", mapping=EX / "example_daq.toml",
                           profile=load_profile("gong2020"))
    res = run_replay(cap, _opts(tmp_path, kind, window_s=(0.22, 0.3)))
    assert res.ok
    rep = check_recording(res.out)
    assert rep.integrity is not None and rep.integrity.ok, rep.integrity.problems
    assert rep.summary["ref_SMO_SIGN_pee_rms_rad"] == pytest.approx(
        res.metrics["SMO_SIGN"]["pee_rms_rad"], rel=1e-9)
    import json

    params = json.loads(load_recording(res.out, topics=()).run["plant_params"])
    assert params["pole_pairs"] == 4 and params["ts_s"] == pytest.approx(600e-6)
