"""Notebook-ready data (issue 30.3): ``hil_bench.load_recording`` gives each channel indexed by
time (``t_s``), units in ``df.attrs["units"]``, enumerations as categoricals named by the DBC's
value tables, ``/link/frames`` decoded by the DBC through cantools, and a ``RecordingData`` that
iterates like a mapping of its channels (bench/record/tables.py)."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import hil_bench
from hil_bench.protocol.messages import MESSAGES, Estimator, Fault, State
from hil_bench.record import channels as ch
from hil_bench.record.recording import load_recording as read_columns
from hil_bench.record.tables import categorical, channel_frame

#: G2 through its alignment (0.2 s) into the I-f start: two controller states in 3000 cycles
SHORT = {"scenario.duration_s": 0.3, "metrics.window_s": [0.1, 0.3], "scenario.claims": []}


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("tables") / "g2.mcap"
    hil_bench.run("gong_g2_500rpm", link="sil", overrides=SHORT, out=out)
    return out


@pytest.fixture(scope="module")
def rec(recording):
    return hil_bench.load_recording(recording)


def test_every_channel_is_indexed_by_its_recorded_time(rec, recording):
    cols = read_columns(recording)
    assert set(rec) == set(cols.topics)
    for topic, fields in cols.topics.items():
        df = rec[topic]
        assert df.index.name == "t_s", topic
        assert "t_s" not in df.columns, topic
        if topic != ch.LINK_FRAMES:          # one row per frame there: the test below
            np.testing.assert_array_equal(df.index.to_numpy(), fields["t_s"])
    state = rec[ch.PLANT_STATE]
    assert len(state) == 3000 and state.index.is_monotonic_increasing
    # time slicing the notebook way: the last 0.1 s
    assert len(state.loc[0.2:]) == 1000


def test_units_are_in_attrs_for_every_column(rec):
    for topic, df in rec.items():
        units = df.attrs["units"]
        assert set(units) == {"t_s", *df.columns}, topic
        assert units["t_s"] == "s"
    state = rec[ch.PLANT_STATE].attrs["units"]
    assert (state["i_a_a"], state["v_dc_v"], state["omega_m_rad_s"], state["theta_e_rad"],
            state["torque_load_nm"], state["speed_rpm"]) == ("A", "V", "rad/s", "rad", "N m", "rpm")
    telem = rec[ch.CONTROLLER_TELEMETRY].attrs["units"]
    assert telem["duty_a"] == "" and telem["i_q_ref_a"] == "A" and telem["seq"] == ""
    assert rec[ch.TIMING].attrs["units"]["rtt_us"] == "us"
    assert rec[ch.PLANT_STATE].attrs["topic"] == ch.PLANT_STATE


def test_every_recorded_field_gets_its_unit_from_its_name():
    """One source: the names of plant_rt/c/rec_schema.h. A new field whose name ends in no known
    unit must be a count or a name (listed here), or get a suffix."""
    no_unit = {"seq", "state", "estimator", "state_rec", "estimator_rec", "duty_a", "duty_b",
               "duty_c", "duty_a_rec", "duty_b_rec", "duty_c_rec", "tx", "rx", "kind", "text",
               "value", "missed", "retries", "late_total", "missed_total", "overrun", "index",
               "target", "direction", "action", *ch.LINK_STATS_COUNTERS}
    for lay in ch.LAYOUTS.values():
        for name in lay.names:
            unit = ch.field_unit(name)
            assert bool(unit) != (name in no_unit), (lay.kind, name, unit)


def test_state_and_estimator_are_categoricals_named_by_the_dbc(rec, recording):
    telem = rec[ch.CONTROLLER_TELEMETRY]
    raw = read_columns(recording, topics=[ch.CONTROLLER_TELEMETRY]).topics[
        ch.CONTROLLER_TELEMETRY]
    for name, table in (("state", State), ("estimator", Estimator)):
        col = telem[name]
        assert isinstance(col.dtype, pd.CategoricalDtype), name
        assert list(col.cat.categories) == [v.name for v in sorted(table)]
        # codes are the raw values (the tables are numbered 0..n-1)
        np.testing.assert_array_equal(col.cat.codes.to_numpy(), raw[name])
    assert telem.state.iloc[0] == "ALIGN" and telem.state.iloc[-1] == "OPEN_LOOP"
    assert set(telem.estimator) == {"SMO_TANH"}
    assert (telem.state == "OPEN_LOOP").sum() == (raw["state"] == int(State.OPEN_LOOP)).sum()


def test_missing_and_unknown_enum_values():
    cat = categorical(np.array([3, -1, 9, 0]), {int(v): v.name for v in Estimator})
    assert cat[0] == "SMO_TANH" and pd.isna(cat[1]) and cat[2] == "9" and cat[3] == "NONE"
    assert list(cat.categories)[-1] == "9"
    # a recording of an earlier version (JSON channels) has them as floats, missing as NaN
    old = categorical(np.array([1.0, np.nan, -1.0]), {int(v): v.name for v in State})
    assert old[0] == "ALIGN" and pd.isna(old[1]) and pd.isna(old[2])


def test_a_controller_trip_names_its_fault_code():
    cols = {"t_s": np.array([0.1, 0.2, 0.3]), "seq": np.array([1000, 2000, 3000]),
            "index": np.array([0, -1, 0]),
            "target": np.array(["plant", "controller", "plant"], dtype=object),
            "kind": np.array(["open_phase", "fault_ctrl", "open_phase"], dtype=object),
            "direction": np.array(["", "", ""], dtype=object),
            "action": np.array(["on", "trip", "trace"], dtype=object),
            "text": np.array(["", "FAULT_CTRL code 14 seq 2000 detail 0", ""], dtype=object),
            "value": np.array([np.nan, float(Fault.OPEN_PHASE), 0.0125])}
    df = channel_frame(ch.FAULTS, cols)
    assert pd.isna(df.fault_code.iloc[0]) and pd.isna(df.fault_code.iloc[2])
    assert df.fault_code.iloc[1] == "OPEN_PHASE"
    assert list(df.fault_code.cat.categories) == [v.name for v in sorted(Fault)]
    events = channel_frame(ch.EVENTS, {
        "t_s": np.array([0.2, 0.3]), "kind": np.array(["controller_fault", "scenario"], object),
        "text": np.array(["FAULT_CTRL code 4", "load step"], object),
        "value": np.array([float(Fault.OVERCURRENT), 4.0])})
    assert events.fault_code.iloc[0] == "OVERCURRENT" and pd.isna(events.fault_code.iloc[1])


def test_link_frames_are_decoded_one_row_per_frame(rec, recording):
    raw = read_columns(recording, topics=[ch.LINK_FRAMES]).topics[ch.LINK_FRAMES]
    tokens = sum(len(str(t).split()) for col in ("tx", "rx") for t in raw[col])
    frames = rec[ch.LINK_FRAMES]
    assert len(frames) == tokens
    assert list(frames.columns[:5]) == ["seq", "direction", "message", "id", "data"]
    assert frames.message.notna().all()          # every frame of the run is a DBC message
    first = frames.iloc[0]
    assert (first.message, first.direction, first.seq) == ("HELLO", "tx", -1)
    assert first["HELLO.estimator"] == "SMO_TANH" and first["HELLO.mode"] == "LOCKSTEP"
    assert frames.attrs["units"]["SENSE.i_a"] == "A"
    assert frames.attrs["units"]["TELEM.omega_hat"] == "rad/s"
    config = frames[frames.message == "CONFIG"]
    assert "POLE_PAIRS" in set(config["CONFIG.param_id"])
    assert frames["DUTY.seq"].dtype == "Int64" and pd.isna(first["DUTY.seq"])
    # cantools' decoding of every frame agrees with what the engine recorded it had sent and got
    duty, telem_f, sense = rec.frames("DUTY"), rec.frames("TELEM"), rec.frames("SENSE")
    telem, sent = rec[ch.CONTROLLER_TELEMETRY], rec[ch.PLANT_SENSE]
    assert len(duty) == len(telem) == 3000
    np.testing.assert_array_equal(duty.d_a.to_numpy(), telem.duty_a.to_numpy())
    np.testing.assert_array_equal(duty.cycle.to_numpy(), telem.seq.to_numpy())
    np.testing.assert_array_equal(telem_f.theta_hat.to_numpy(), telem.theta_hat_rad.to_numpy())
    assert (telem_f.state.astype(str).to_numpy() == telem.state.astype(str).to_numpy()).all()
    np.testing.assert_array_equal(sense.i_a.to_numpy(), sent.i_a_a.to_numpy())
    np.testing.assert_array_equal(sense.index.to_numpy(), sent.index.to_numpy())


def test_frames_of_one_message_have_plain_signal_names(rec):
    duty = rec.frames("DUTY")
    assert list(duty.columns) == ["cycle", "direction", "seq", "d_a", "d_b", "d_c"]
    assert set(duty.direction) == {"rx"}
    assert duty.attrs["units"]["d_a"] == "" and duty.attrs["message"] == "DUTY"
    with pytest.raises(KeyError, match="no 'DUTTY' frame.*did you mean 'DUTY'"):
        rec.frames("DUTTY")


def test_a_leg_off_reads_nan_and_an_unknown_frame_keeps_its_bytes():
    duty = MESSAGES["DUTY"]
    off = bytes(duty.pack_values((7, 0.5, 0.25, 0.0)))[:6] + b"\xff\xff"   # d_c raw 65535 = OFF
    cols = {"t_s": np.array([0.0, 0.0001]), "seq": np.array([7, 8]),
            "tx": np.array(["", "7FF#0102"], dtype=object),
            "rx": np.array([f"180#{off.hex().upper()}", "180#00 ..."], dtype=object)}
    df = channel_frame(ch.LINK_FRAMES, cols)
    assert list(df.message.astype(object).fillna("?")) == ["DUTY", "?", "?"]
    row = df.iloc[0]
    assert (row["DUTY.seq"], row["DUTY.d_a"], row["DUTY.d_b"]) == (7, 0.5, 0.25)
    assert np.isnan(row["DUTY.d_c"])
    assert (df.id.iloc[1], df.data.iloc[1]) == (0x7FF, "0102")       # not in the DBC
    assert (df.id.iloc[2], df.data.iloc[2]) == (0x180, "00")         # DUTY of the wrong length
    assert "1 cycle(s) had more frames" in df.attrs["elided"]


def test_recording_data_iterates_like_a_mapping_of_its_channels(rec):
    assert list(rec) == rec.topics == sorted(rec.topics) == list(rec.keys())
    assert len(rec) == len(rec.topics) >= 8
    assert ch.PLANT_STATE in rec and "/nope" not in rec
    assert dict(rec.items())[ch.PLANT_STATE] is rec[ch.PLANT_STATE]
    assert [t for t, _ in rec.items()] == list(rec)
    assert rec.get("/nope") is None
    with pytest.raises(KeyError, match="no channel '/nope'"):
        rec["/nope"]


def test_an_empty_channel_has_its_fields_and_units():
    df = channel_frame(ch.FAULTS, {})
    assert len(df) == 0 and df.index.name == "t_s"
    assert {"seq", "action", "value", "fault_code"} <= set(df.columns)


def test_an_empty_frames_channel_is_an_empty_table():
    df = channel_frame(ch.LINK_FRAMES, {})
    assert len(df) == 0 and list(df.columns) == ["seq", "direction", "message", "id", "data"]
