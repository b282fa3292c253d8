"""Property-based fuzz of `rig import` (issue 13, "fail safe, not open"): a valid run file
(CSV or Parquet samples + JSON metadata) is corrupted at random — cut short, bytes flipped, a
number made text or infinite, a column dropped, time sent backwards, metadata nested thousands
deep or given the wrong kind — and imported through the command a user types. For every case:
either the run is stored exactly as the file says, or nothing of it is stored and a `refused:`
line names the file (and the row and column where the fault has one). Never a traceback, never
the command's catch-all error line."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from commands.cli import main
from core.run import RunData
from core.runfile import read_run, write_run
from db.store import Store

FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])

_DB_DIR = tempfile.TemporaryDirectory(prefix="rig-fuzz-import-")
DB_PATH = Path(_DB_DIR.name) / "rig.sqlite"
DB_URL = f"sqlite:///{DB_PATH}"
"""One database for the module (creating a schema per example would dominate the run time);
every property compares row counts before and after its import."""


def counts() -> dict[str, int]:
    """Rows of each table that holds a run's parts (read with sqlite3: cheap per example)."""
    import sqlite3

    from db.models import Channel, Run, SampleBlock, SamplePage
    if not DB_PATH.exists():
        with Store(DB_URL):   # create the schema once
            pass
    with sqlite3.connect(DB_PATH) as conn:
        return {m.__tablename__: conn.execute(f"SELECT count(*) FROM {m.__tablename__}").fetchone()[0]
                for m in (Run, Channel, SamplePage, SampleBlock)}


def valid_run(n: int, seed: int) -> RunData:
    """A small valid run: time, two known numeric channels with a dropout, phase, an extra
    numeric channel and an extra text channel."""
    rng = np.random.default_rng(seed)
    q = rng.normal(0.0, 0.1, n)
    q[rng.random(n) < 0.1] = np.nan
    samples = pd.DataFrame({
        "t": np.round(np.arange(n) * 0.01, 2),
        "q": q,
        "torque": rng.normal(1e4, 3e3, n),
        "phase": pd.Series([("idle", "load", "hold")[i % 3] for i in range(n)], dtype=object),
        "strain_x": rng.normal(0.0, 1.0, n),
        "note": pd.Series([f"s{i}" for i in range(n)], dtype=object),
    })
    meta = {"scheme": 1, "motor_speed_rpm": 300, "direction": 1, "source": "rig",
            "rig": "fuzz", "started_at": "2026-11-10T09:00:00Z", "notes": "fuzz",
            "units": {"strain_x": "µm/m"}, "extra": {"a": [1, 2, {"b": "c"}]}}
    return RunData(samples=samples, meta=meta)


def import_files(data: Path) -> tuple[int, str, dict[str, int], dict[str, int], list[dict]]:
    """`rig import DATA --json`: (exit code, stderr, counts before, counts after, printed list)."""
    import contextlib
    import io

    before = counts()
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(["import", str(data), "--json", "--db", DB_URL])
    return rc, err.getvalue(), before, counts(), json.loads(out.getvalue() or "[]")


def check_outcome(data: Path, meta_path: Path, rc: int, err: str, before: dict[str, int],
                  after: dict[str, int], printed: list[dict],
                  row: int | None = None, column: str | None = None,
                  prefix_of: pd.DataFrame | None = None) -> None:
    """The fuzz property: stored exactly as the file reads, or nothing stored and a refusal
    naming the file (and the row/column given)."""
    assert "Traceback" not in err and "rig import: error" not in err, err
    if rc == 0:
        assert len(printed) == 1 and after["runs"] == before["runs"] + 1, (err, printed)
        expected = read_run(data)
        with Store(DB_URL) as store:
            stored = store.load_run(printed[0]["run_id"])
        pd.testing.assert_frame_equal(stored.samples, expected.samples)
        if prefix_of is not None:   # a cut-short file may only lose whole rows at its end
            n = len(stored.samples)
            pd.testing.assert_frame_equal(stored.samples,
                                          prefix_of.iloc[:n].reset_index(drop=True),
                                          check_dtype=False)
        return
    assert rc == 1, (rc, err)
    assert after == before, "a refused file left rows behind"
    assert printed == []
    assert "refused:" in err and (data.name in err or meta_path.name in err), err
    if row is not None:
        assert f"row {row}" in err, err
    if column is not None:
        assert repr(column) in err, err


def written(run: RunData, fmt: str) -> tuple[Path, Path]:
    d = Path(tempfile.mkdtemp(prefix="case-", dir=_DB_DIR.name))
    data, meta = write_run(run, d / "run", fmt=fmt)
    return data, meta


# --- corruptions of the samples file -------------------------------------------------------------

@FUZZ
@given(n=st.integers(2, 40), seed=st.integers(0, 2**16), fmt=st.sampled_from(["csv", "parquet"]),
       cut=st.floats(0.0, 1.0))
def test_truncated_samples_file(n, seed, fmt, cut):
    run = valid_run(n, seed)
    data, meta = written(run, fmt)
    raw = data.read_bytes()
    data.write_bytes(raw[: int(len(raw) * cut)])
    check_outcome(data, meta, *import_files(data), prefix_of=run.samples)


@FUZZ
@given(n=st.integers(2, 30), seed=st.integers(0, 2**16), fmt=st.sampled_from(["csv", "parquet"]),
       flips=st.lists(st.tuples(st.floats(0.0, 0.999), st.integers(0, 255)), min_size=1, max_size=6))
def test_byte_flips_in_samples_file(n, seed, fmt, flips):
    data, meta = written(valid_run(n, seed), fmt)
    raw = bytearray(data.read_bytes())
    for where, byte in flips:
        raw[int(where * len(raw))] = byte
    data.write_bytes(bytes(raw))
    check_outcome(data, meta, *import_files(data))


def test_text_that_is_not_utf8_in_a_parquet_file_is_refused_naming_its_column():
    """Arrow decodes text lazily, so a Parquet file whose text bytes are not UTF-8 reads
    without error and fails only when the values are used; the refusal must still name the
    file and the column (it was the command's catch-all `ArrowException` line)."""
    run = valid_run(12, 7)
    data, meta = written(run, "parquet")
    run.samples.to_parquet(data, index=False, compression=None)
    raw = data.read_bytes()
    assert b"hold" in raw
    data.write_bytes(raw.replace(b"hold", b"\xffold"))
    check_outcome(data, meta, *import_files(data), column="phase")


BAD_CELLS = {"text": "abc", "inf": "inf", "-inf": "-Infinity", "bool": "True", "hex": "0x1F",
             "comma": "1,5", "huge": "1" + "0" * 400}
"""Cell texts a numeric column must refuse (the CSV writer quotes the decimal comma)."""


@FUZZ
@given(n=st.integers(2, 30), seed=st.integers(0, 2**16), fmt=st.sampled_from(["csv", "parquet"]),
       kind=st.sampled_from(sorted(BAD_CELLS) + ["nan"]),
       column=st.sampled_from(["t", "q", "torque", "strain_x"]), at=st.floats(0.0, 0.999))
def test_bad_number_in_numeric_column(n, seed, fmt, kind, column, at):
    run = valid_run(n, seed)
    i = int(at * n)
    samples = run.samples.copy()
    cells = samples[column].astype(object)
    cells[i] = "nan" if kind == "nan" else BAD_CELLS[kind]
    samples[column] = cells
    d = Path(tempfile.mkdtemp(prefix="case-", dir=_DB_DIR.name))
    data, meta = d / f"run.{fmt}", d / "run.json"
    if fmt == "csv":
        samples.to_csv(data, index=False, na_rep="", lineterminator="\n")
    else:
        samples.astype({column: str}).to_parquet(data, index=False)
    meta.write_text(json.dumps(run.meta))
    rc, err, before, after, printed = import_files(data)
    if kind == "nan" and column != "t":
        assert rc == 0, err   # a missing sample, stored as missing
    else:
        assert rc == 1, err
    check_outcome(data, meta, rc, err, before, after, printed,
                  row=None if rc == 0 else i + 1, column=None if rc == 0 else column)


@FUZZ
@given(n=st.integers(3, 30), seed=st.integers(0, 2**16), fmt=st.sampled_from(["csv", "parquet"]),
       at=st.floats(0.0, 0.999), how=st.sampled_from(["swap", "repeat", "missing"]))
def test_time_not_strictly_increasing(n, seed, fmt, at, how):
    run = valid_run(n, seed)
    samples = run.samples.copy()
    i = 1 + int(at * (n - 1))           # 1..n-1: the row (0-based) that breaks the order
    t = samples["t"].to_numpy().copy()
    if how == "swap":
        t[i - 1], t[i] = t[i], t[i - 1]
        bad_row = i + 1
    elif how == "repeat":
        t[i] = t[i - 1]
        bad_row = i + 1
    else:
        t[i] = np.nan
        bad_row = i + 1
    samples["t"] = t
    run = RunData(samples=samples, meta=run.meta)
    d = Path(tempfile.mkdtemp(prefix="case-", dir=_DB_DIR.name))
    data, meta = d / f"run.{fmt}", d / "run.json"
    if fmt == "csv":
        samples.to_csv(data, index=False, na_rep="", lineterminator="\n")
    else:
        samples.to_parquet(data, index=False)
    meta.write_text(json.dumps(run.meta))
    rc, err, before, after, printed = import_files(data)
    assert rc == 1, err
    check_outcome(data, meta, rc, err, before, after, printed, row=bad_row, column="t")


@FUZZ
@given(n=st.integers(2, 20), seed=st.integers(0, 2**16), fmt=st.sampled_from(["csv", "parquet"]),
       drop=st.sets(st.sampled_from(["t", "q", "torque", "phase", "strain_x", "note"]), min_size=1),
       bad_type=st.sampled_from([None, "bool", "datetime", "bad_phase"]))
def test_missing_columns_and_wrong_types(n, seed, fmt, drop, bad_type):
    run = valid_run(n, seed)
    samples = run.samples.drop(columns=sorted(drop))
    column = None
    if bad_type == "bool":
        samples["q"] = np.arange(n) % 2 == 0
        column = "q"
    elif bad_type == "datetime":
        samples["torque"] = pd.date_range("2026-01-01", periods=n, freq="s")
        column = "torque"
    elif bad_type == "bad_phase":
        samples["phase"] = pd.Series(["spin"] * n, dtype=object)
        column = "phase"
    d = Path(tempfile.mkdtemp(prefix="case-", dir=_DB_DIR.name))
    data, meta = d / f"run.{fmt}", d / "run.json"
    if fmt == "csv":
        samples.to_csv(data, index=False, na_rep="", lineterminator="\n")
    else:
        samples.to_parquet(data, index=False)
    meta.write_text(json.dumps(run.meta))
    rc, err, before, after, printed = import_files(data)
    if "t" in drop:   # refused for the missing 't' or for the bad column, whichever is first
        assert rc == 1
        check_outcome(data, meta, rc, err, before, after, printed)
        assert column is None or "'t'" in err or repr(column) in err, err
        return
    if bad_type == "bad_phase" or (bad_type == "bool" and fmt == "parquet") \
            or (bad_type == "datetime" and fmt == "parquet"):
        assert rc == 1, err
        check_outcome(data, meta, rc, err, before, after, printed, column=column)
        return
    # in a CSV a bool/date reads as text in a numeric column: refused at row 1
    if bad_type in ("bool", "datetime"):
        assert rc == 1, err
        check_outcome(data, meta, rc, err, before, after, printed, row=1, column=column)
        return
    assert rc == 0, err     # dropping optional channels leaves a valid, smaller run
    check_outcome(data, meta, rc, err, before, after, printed)


# --- corruptions of the metadata file ----------------------------------------------------------

WRONG_KINDS = {"scheme": [4, "one", 1.5, True], "direction": [0, "forward", 2],
               "motor_speed_rpm": [-1, "fast", [300]], "source": ["lab", 1],
               "started_at": ["yesterday", 20261110], "units": [["m"], {"q": 1}],
               "sample_rate_hz": [0, -10, "10 Hz"], "notes": [1, {"a": 1}]}


@FUZZ
@given(n=st.integers(2, 10), seed=st.integers(0, 2**16), fmt=st.sampled_from(["csv", "parquet"]),
       depth=st.integers(33, 100_000), container=st.sampled_from(["[", "{"]))
def test_deeply_nested_metadata(n, seed, fmt, depth, container):
    data, meta = written(valid_run(n, seed), fmt)
    if container == "[":
        nested = "[" * depth + "]" * depth
    else:
        nested = '{"a":' * depth + "1" + "}" * depth
    meta.write_text('{"scheme": 1, "deep": ' + nested + "}")
    rc, err, before, after, printed = import_files(data)
    assert rc == 1, err
    assert "deep" in err
    check_outcome(data, meta, rc, err, before, after, printed)


@FUZZ
@given(n=st.integers(2, 10), seed=st.integers(0, 2**16), fmt=st.sampled_from(["csv", "parquet"]),
       key_value=st.sampled_from([(k, v) for k, vs in WRONG_KINDS.items() for v in vs]))
def test_metadata_value_of_wrong_kind(n, seed, fmt, key_value):
    key, value = key_value
    run = valid_run(n, seed)
    data, meta = written(run, fmt)
    meta.write_text(json.dumps({**run.meta, key: value}))
    rc, err, before, after, printed = import_files(data)
    assert rc == 1, err
    check_outcome(data, meta, rc, err, before, after, printed, column=key)


@FUZZ
@given(n=st.integers(2, 10), seed=st.integers(0, 2**16), fmt=st.sampled_from(["csv", "parquet"]),
       mutation=st.one_of(
           st.tuples(st.just("cut"), st.floats(0.0, 0.999), st.just(0)),
           st.tuples(st.just("flip"), st.floats(0.0, 0.999), st.integers(0, 255)),
           st.tuples(st.sampled_from(["nan", "inf", "-inf"]), st.just(0.0), st.just(0))))
def test_corrupted_metadata_text(n, seed, fmt, mutation):
    what, where, byte = mutation
    run = valid_run(n, seed)
    data, meta = written(run, fmt)
    raw = bytearray(meta.read_bytes())
    if what == "cut":
        raw = raw[: int(where * len(raw))]
    elif what == "flip":
        raw[int(where * len(raw))] = byte
    else:
        raw = bytearray(json.dumps({**run.meta, "gain": 1.0})
                        .replace("1.0", {"nan": "NaN", "inf": "Infinity", "-inf": "-Infinity"}[what])
                        .encode())
    meta.write_bytes(bytes(raw))
    check_outcome(data, meta, *import_files(data))


# --- several files in one command: each all-or-nothing ---------------------------------------------

@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(good=st.lists(st.booleans(), min_size=2, max_size=5), seed=st.integers(0, 2**16))
def test_several_files_each_all_or_nothing(good, seed):
    import contextlib
    import io

    paths = []
    for k, ok in enumerate(good):
        run = valid_run(5 + k, seed + k)
        data, meta = written(run, "csv")
        if not ok:
            lines = data.read_text().splitlines(keepends=True)
            lines[3] = lines[3].replace(",", ",x", 1)   # text in column 'q', row 3
            data.write_text("".join(lines))
        paths.append(data)
    before = counts()
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(["import", *map(str, paths), "--json", "--db", DB_URL])
    printed = json.loads(out.getvalue())
    assert rc == (0 if all(good) else 1)
    assert [p["source_file"] for p in printed] == [str(p) for p, ok in zip(paths, good) if ok]
    assert counts()["runs"] == before["runs"] + sum(good)
    summary = err.getvalue()
    for p, ok in zip(paths, good):
        assert (str(p) in summary) == (not ok)
        if not ok:
            assert f"{p}, row 3 (line 4), column 'q'" in summary
    if not all(good):
        assert f"{len(good) - sum(good)} refused" in summary


@pytest.mark.parametrize("field", ["t", "gtau"])
def test_emps_record_with_struct_field_is_refused(tmp_path, capsys, field):
    """A .mat whose field is a MATLAB struct is a bad file like any other: a refusal naming the
    file and the field, nothing stored, no traceback."""
    from scipy.io import savemat

    t = np.arange(5) * 1e-3
    record = {"t": t, "qm": t, "qg": t, "vir": t, "gtau": 1.0, "kp": 1.0, "kv": 1.0}
    record[field] = {"inner": t}
    path = tmp_path / "DATA_STRUCT.mat"
    savemat(path, record)
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    rc = main(["import", str(path), "--db", url])
    err = capsys.readouterr().err
    assert rc == 1
    assert "refused:" in err and "DATA_STRUCT.mat" in err and repr(field) in err
    assert "struct" in err and "error:" not in err


def test_metadata_with_nul_escape_stored_or_refused_per_database(tmp_path, capsys):
    """A `\\u0000` in metadata text is valid JSON that PostgreSQL cannot hold: on any database
    the file is stored whole or refused by name, never half stored, never a traceback."""
    from db_fixtures import empty_database

    run = valid_run(5, 1)
    data, meta = write_run(run, tmp_path / "nul", fmt="csv")
    meta.write_text(json.dumps({**run.meta, "notes": "a\u0000b"}))
    for kind in ("sqlite", "postgresql"):
        try:
            with empty_database(kind, tmp_path) as url:
                rc = main(["import", str(data), "--db", url])
                err = capsys.readouterr().err
                with Store(url) as store:
                    n_runs = len(store.list_runs())
                assert "error:" not in err and "Traceback" not in err, err
                assert (rc, n_runs) in ((0, 1), (1, 0)), (rc, n_runs, err)
                if rc == 1:
                    assert "refused:" in err and "nul.csv" in err
        except pytest.skip.Exception:
            continue
