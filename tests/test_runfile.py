"""Run interchange files (core/runfile.py): validation as run-format.md says, lossless round trip."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from core.run import RunData
from core.runfile import RunFileError, read_run, write_run

META = {"scheme": 1, "motor_speed_rpm": 3000, "direction": 1, "reduction": 11000, "rig": "J4-bench",
        "source": "rig", "sample_rate_hz": 10, "started_at": "2026-11-10T09:00:00Z",
        "notes": "free text", "operator_badge": {"id": 7}}


def _write(tmp_path: Path, csv_text: str, meta: dict | str = META, stem: str = "run") -> Path:
    (tmp_path / f"{stem}.csv").write_text(csv_text, encoding="utf-8")
    (tmp_path / f"{stem}.json").write_text(meta if isinstance(meta, str) else json.dumps(meta),
                                           encoding="utf-8")
    return tmp_path / f"{stem}.csv"


GOOD = "t,q,torque,phase,strain_x,label\n0,0.1,5,idle,1,a\n0.1,,6,load,,b\n0.2,0.3,,,3,\n"


def test_good_file_keeps_missing_extra_columns_and_unknown_meta(tmp_path):
    run = read_run(_write(tmp_path, GOOD))
    s = run.samples
    assert list(s.columns) == ["t", "q", "torque", "phase", "strain_x", "label"]
    assert np.isnan(s["q"][1]) and np.isnan(s["torque"][2]) and np.isnan(s["strain_x"][1])
    assert s["phase"].tolist() == ["idle", "load", None]
    assert s["label"].tolist() == ["a", "b", None]          # unknown text column kept as text
    assert s["strain_x"].dtype == np.float64                  # unknown numeric column kept
    assert run.meta == META                                   # unknown key kept verbatim


def test_t_moved_first(tmp_path):
    run = read_run(_write(tmp_path, "q,t\n1,0\n2,1\n"))
    assert list(run.samples.columns) == ["t", "q"]


@pytest.mark.parametrize("csv_text, row, line, column, words", [
    ("q,torque\n1,2\n", None, None, "t", "missing"),
    ("t,q\n0,1\n0.1,2\n0.1,3\n", 3, 4, "t", "not strictly increasing"),
    ("t,q\n0,1\n0.2,2\n0.1,3\n", 3, 4, "t", "not strictly increasing"),
    ("t,q\n0,1\n,2\n", 2, 3, "t", "missing time"),
    ("t,q\n0,1\n0.1,abc\n", 2, 3, "q", "text 'abc'"),
    ("t,q\n0,1\n0.1,2\n0.2,inf\n", 3, 4, "q", "infinite"),
    ("t,torque\n0,-Infinity\n", 1, 2, "torque", "infinite"),
    ("t,q\n0,1\n0.1,1e400\n", 2, 3, "q", "infinite"),
    ("t,strain\n0,1\n0.1,oops\n", 2, 3, "strain", "text 'oops'"),    # unknown numeric column
    ("t,phase\n0,idle\n0.1,lunch\n", 2, 3, "phase", "unknown phase"),
    ("t,q,q\n0,1,2\n", None, 1, "q", "more than once"),
])
def test_bad_samples_refused_naming_file_row_column(tmp_path, csv_text, row, line, column, words):
    path = _write(tmp_path, csv_text)
    with pytest.raises(RunFileError) as ei:
        read_run(path)
    e = ei.value
    assert (e.row, e.column) == (row, column)
    msg = str(e)
    assert str(path) in msg and words in msg and repr(column) in msg
    if row is not None:
        assert f"row {row}" in msg and f"line {line}" in msg


@pytest.mark.parametrize("key, value", [
    ("scheme", "one"), ("scheme", 4), ("motor_speed_rpm", "fast"), ("direction", 0),
    ("direction", "up"), ("reduction", -3), ("rig", 5), ("source", "lab"),
    ("sample_rate_hz", True), ("started_at", "yesterday"), ("notes", ["a"]),
    ("units", {"q": 1}), ("shear_setpoint_n", "90 kN"),
])
def test_bad_metadata_refused_naming_key(tmp_path, key, value):
    path = _write(tmp_path, "t,q\n0,1\n", {**META, key: value})
    with pytest.raises(RunFileError) as ei:
        read_run(path)
    assert ei.value.column == key
    assert str(tmp_path / "run.json") in str(ei.value) and repr(key) in str(ei.value)


def test_null_meta_values_allowed(tmp_path):
    meta = {**META, "scheme": 3, "motor_speed_rpm": None}
    assert read_run(_write(tmp_path, "t\n0\n", meta)).meta == meta


@pytest.mark.parametrize("meta_text", ["[1, 2]", "{\"scheme\": NaN}", "{not json"])
def test_bad_metadata_file_refused(tmp_path, meta_text):
    with pytest.raises(RunFileError) as ei:
        read_run(_write(tmp_path, "t\n0\n", meta_text))
    assert "run.json" in str(ei.value)


def test_missing_metadata_file_refused(tmp_path):
    (tmp_path / "lone.csv").write_text("t\n0\n")
    with pytest.raises(RunFileError, match="metadata file not found"):
        read_run(tmp_path / "lone.csv")


def _random_run(n: int = 500, seed: int = 0) -> RunData:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(1e-3, 0.2, n))
    df = pd.DataFrame({
        "t": t,
        "q": rng.standard_normal(n) * 10.0 ** rng.integers(-200, 200, n),   # awkward floats
        "torque": rng.normal(5e4, 1e3, n),
        "phase": np.array(["idle", "load", "hold", "unload", "excite"], dtype=object)[rng.integers(0, 5, n)],
        "my_extra": rng.standard_normal(n),
        "tag": np.array(["α,β", "say \"hi\"", "x"], dtype=object)[rng.integers(0, 3, n)],
    })
    df.loc[rng.random(n) < 0.1, "q"] = np.nan
    df.loc[rng.random(n) < 0.1, "torque"] = np.nan
    df["phase"] = df["phase"].astype(object)
    df.loc[rng.random(n) < 0.05, "phase"] = None
    df["tag"] = df["tag"].astype(object)
    df.loc[rng.random(n) < 0.05, "tag"] = None
    return RunData(samples=df, meta={**META, "units": {"my_extra": "V"}, "gain": 1.0 / 3.0})


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_round_trip_is_lossless(tmp_path, fmt):
    run = _random_run()
    paths = write_run(run, tmp_path / "out" / "r1", fmt=fmt)
    assert [p.name for p in paths] == [f"r1.{fmt}", "r1.json"]
    back = read_run(paths[0])
    pd.testing.assert_frame_equal(back.samples, read_run(paths[1]).samples)
    assert back.meta == run.meta
    for c in run.samples.columns:
        a, b = run.samples[c].to_numpy(), back.samples[c].to_numpy()
        if c in ("phase", "tag"):
            assert [x if isinstance(x, str) else None for x in a] == list(b)
        else:
            np.testing.assert_array_equal(a.astype(float), b)        # bit-exact, NaN where NaN
    # and a second trip gives the identical frame
    again = read_run(write_run(back, tmp_path / "r2", fmt=fmt)[0])
    pd.testing.assert_frame_equal(again.samples, back.samples)


def test_parquet_text_in_numeric_column_refused(tmp_path):
    pd.DataFrame({"t": [0.0, 1.0], "q": ["1.0", "x"]}).to_parquet(tmp_path / "p.parquet")
    (tmp_path / "p.json").write_text("{}")
    with pytest.raises(RunFileError) as ei:
        read_run(tmp_path / "p.parquet")
    assert (ei.value.row, ei.value.column) == (2, "q")


def test_write_refuses_invalid_run(tmp_path):
    bad = RunData(samples=pd.DataFrame({"t": [0.0, 0.0]}), meta={})
    with pytest.raises(RunFileError, match="strictly increasing"):
        write_run(bad, tmp_path / "bad")
    assert not list(tmp_path.iterdir())


def test_byte_order_mark_tolerated(tmp_path):
    (tmp_path / "bom.csv").write_bytes("\ufefft,q\n0,1\n".encode("utf-8"))
    (tmp_path / "bom.json").write_text("{}")
    assert list(read_run(tmp_path / "bom.csv").samples.columns) == ["t", "q"]
