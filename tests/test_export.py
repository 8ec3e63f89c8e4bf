"""``bench export REC --format parquet|csv`` (issue 30.3, bench/record/export.py): every channel as
a table with its units (Parquet: column and schema metadata; CSV: a sidecar JSON), written aside
and renamed, never over its input; a damaged recording exported up to its damage and said so;
bad input one clear line, nothing written."""
from __future__ import annotations

import json
import sys

import numpy as np
import pandas as pd
import pytest

import hil_bench
from hil_bench.cli import main as cli_main
from hil_bench.record import channels as ch

SHORT = {"scenario.duration_s": 0.2, "metrics.window_s": [0.1, 0.2], "scenario.claims": []}


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "g2.mcap"
    hil_bench.run("gong_g2_500rpm", link="sil", overrides=SHORT, out=out)
    return out


@pytest.fixture(scope="module")
def rec(recording):
    return hil_bench.load_recording(recording)


def bench(*args: str) -> int:
    return cli_main(["export", *map(str, args)])


def leftovers(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_parquet_has_every_channel_with_its_units(recording, rec, tmp_path, capsys):
    import pyarrow.parquet as pq

    out = tmp_path / "tables"
    assert bench(recording, "--out", out) == 0
    said = capsys.readouterr().out
    assert f"exported {len(rec)} channel(s)" in said
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(t.strip("/").replace("/", "_") + ".parquet" for t in rec)
    for topic, df in rec.items():
        path = out / (topic.strip("/").replace("/", "_") + ".parquet")
        schema = pq.read_schema(path)
        units = df.attrs["units"]
        for name in schema.names:
            if name.startswith("__"):
                continue
            assert schema.field(name).metadata[b"unit"].decode() == units[name], (topic, name)
        meta = json.loads(schema.metadata[b"hil_bench"])
        assert meta["topic"] == topic and meta["units"] == units and meta["damage"] == ""
        assert meta["run"]["scenario"] == "gong_g2_500rpm"
        back = pd.read_parquet(path)
        pd.testing.assert_frame_equal(back, df, check_like=False)
        assert back.attrs["units"] == units
    assert schema.field("t_s").metadata[b"unit"] == b"s"
    assert leftovers(out) == []


def test_csv_with_a_sidecar_of_units_and_categories(recording, rec, tmp_path):
    out = tmp_path / "telem.csv"
    assert bench(recording, "--format", "csv", "--channels", ch.CONTROLLER_TELEMETRY,
                 "--out", out) == 0
    side = json.loads((tmp_path / "telem.csv.json").read_text())
    telem = rec[ch.CONTROLLER_TELEMETRY]
    assert side["units"] == telem.attrs["units"] and side["topic"] == ch.CONTROLLER_TELEMETRY
    assert side["categories"]["state"][:4] == ["IDLE", "ALIGN", "OPEN_LOOP", "CLOSED_LOOP"]
    assert out.read_text().splitlines()[0].startswith("t_s,seq,theta_hat_rad,")
    back = pd.read_csv(out, index_col="t_s")
    np.testing.assert_array_equal(back.index.to_numpy(), telem.index.to_numpy())
    np.testing.assert_array_equal(back.theta_hat_rad.to_numpy(), telem.theta_hat_rad.to_numpy())
    assert list(back.state) == list(telem.state.astype(str))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["telem.csv", "telem.csv.json"]


def test_channels_by_list_and_the_reference_wildcard(recording, tmp_path):
    out = tmp_path / "some"
    assert bench(recording, "--channels", f"{ch.PLANT_STATE},/reference/*",
                 "--channels", ch.LINK_FRAMES, "--format", "csv", "--out", out) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "link_frames.csv", "link_frames.csv.json", "plant_state.csv", "plant_state.csv.json",
        "reference_SMO_TANH.csv", "reference_SMO_TANH.csv.json"]
    head = (out / "link_frames.csv").read_text().splitlines()[:2]
    assert head[0].startswith("t_s,seq,direction,message,id,data,HELLO.proto_version")
    assert ",tx,HELLO,32," in head[1]


def test_existing_outputs_are_refused_unless_force(recording, tmp_path, capsys):
    out = tmp_path / "state.parquet"
    assert bench(recording, "--channels", ch.PLANT_STATE, "--out", out) == 0
    before = out.read_bytes()
    capsys.readouterr()
    assert bench(recording, "--channels", ch.PLANT_STATE, "--out", out) == 2
    err = capsys.readouterr().err
    assert "exist; refusing to overwrite (--force replaces them)" in err
    assert len(err.strip().splitlines()) == 1
    assert out.read_bytes() == before
    assert bench(recording, "--channels", ch.PLANT_STATE, "--out", out, "--force") == 0


def test_it_never_writes_over_its_input(recording, tmp_path, capsys):
    size = recording.stat().st_size
    assert bench(recording, "--out", recording) == 2
    assert "is the recording itself; refusing to write over the input" in capsys.readouterr().err
    # a recording named like one of the files the export would write into its folder
    named = tmp_path / "plant_state.parquet"
    named.write_bytes(recording.read_bytes())
    assert bench(named, "--channels", ch.PLANT_STATE, "--out", tmp_path, "--force") == 2
    assert "is the recording itself" in capsys.readouterr().err
    assert named.read_bytes() == recording.read_bytes() and recording.stat().st_size == size


def test_bad_arguments_are_one_line_and_write_nothing(recording, tmp_path, capsys):
    out = tmp_path / "out"
    cases = [
        ((recording, "--channels", "/plant/stat", "--out", out),
         "no channel '/plant/stat' in the recording", "did you mean /plant/state?"),
        ((recording, "--out", tmp_path / "all.parquet"),
         "a file name, but", "channels are chosen"),
        ((recording, "--out", tmp_path / "x.csv"),
         "a .csv file name, but the format is parquet", "--format csv"),
        ((tmp_path / "missing.mcap", "--out", out), "missing.mcap: no such recording", ""),
        ((tmp_path, "--out", out), "is a folder, not a recording", ""),
    ]
    for args, first, second in cases:
        assert bench(*args) == 2, args
        err = capsys.readouterr().err.strip()
        assert first in err and second in err, err
        assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert not out.exists() and not (tmp_path / "all.parquet").exists()
    with pytest.raises(SystemExit):
        bench(recording, "--format", "xlsx", "--out", out)


def test_not_a_recording_is_refused(tmp_path, capsys):
    junk = tmp_path / "junk.mcap"
    junk.write_text("not a recording\n")
    assert bench(junk, "--out", tmp_path / "x") == 2
    err = capsys.readouterr().err
    assert "not an MCAP file" in err and "nothing exported" in err
    assert not (tmp_path / "x").exists()


def test_a_cut_recording_exports_what_is_readable_and_says_what_was_not(recording, tmp_path,
                                                                        capsys):
    import pyarrow.parquet as pq

    cut = tmp_path / "cut.mcap"
    data = recording.read_bytes()
    cut.write_bytes(data[:len(data) // 2])
    out = tmp_path / "cut"
    assert bench(cut, "--out", out) == 1
    err = capsys.readouterr().err
    assert "damaged recording: reading stopped at byte" in err
    assert "exported what was readable" in err
    state = pd.read_parquet(out / "plant_state.parquet")
    assert 0 < len(state) < 2000
    meta = json.loads(pq.read_schema(out / "plant_state.parquet").metadata[b"hil_bench"])
    assert meta["damage"].startswith("reading stopped at byte")


def test_a_failed_export_leaves_nothing_behind(recording, tmp_path, monkeypatch):
    from hil_bench.record import export as ex

    calls = []
    real = ex._write_parquet

    def fail_second(df, path, meta):
        calls.append(path)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        real(df, path, meta)

    monkeypatch.setattr(ex, "_write_parquet", fail_second)
    out = tmp_path / "out"
    assert bench(recording, "--out", out) == 2
    assert list(out.iterdir()) == []      # the first table's temporary is gone, nothing renamed


def test_without_pyarrow_it_says_which_extra_to_install(recording, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "pyarrow", None)       # import pyarrow raises ImportError
    assert bench(recording, "--out", tmp_path / "x") == 2
    err = capsys.readouterr().err
    assert "bench export --format parquet needs pyarrow" in err
    assert "pip install 'hil-bench[data]'" in err
    assert bench(recording, "--format", "csv", "--channels", ch.EVENTS,
                 "--out", tmp_path / "events.csv") == 0
