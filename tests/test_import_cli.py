"""`rig import`, `rig export`, `rig runs`, `rig show`, `rig db upgrade` end to end: commands found
through commands.cli's registry, files on disk, a real database."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from db_fixtures import db_url  # noqa: F401  (fixture)

from db.store import Store
from db.writer import ChannelSpec, RunWriter
from commands.cli import COMMANDS, main
from core.run import RunData
from core.runfile import read_run, write_run

EMPS = Path("/work/shared/data/emps")
for _up in Path(__file__).resolve().parents:
    if (_up / "shared" / "data" / "emps").exists():
        EMPS = _up / "shared" / "data" / "emps"
        break


def rig(*argv: str) -> int:
    """Run `rig ARGV...` in-process through commands.cli.main."""
    assert argv[0] in COMMANDS
    return main(list(argv))


def count_rows(url: str) -> dict[str, int]:
    from sqlalchemy import func, select

    from db.models import Channel, Run, SampleBlock, SamplePage
    with Store(url) as store, store.engine.connect() as conn:
        return {m.__tablename__: conn.execute(select(func.count()).select_from(m)).scalar()
                for m in (Run, Channel, SamplePage, SampleBlock)}


GOOD_CSV = "t,q,torque_cmd,torque_load,phase\n0,0,0,10,idle\n0.1,0.001,1000,1100,load\n"
GOOD_META = {"scheme": 1, "motor_speed_rpm": 300, "direction": 1, "source": "rig"}

BAD = {
    "no_t": ("q,torque\n1,2\n", GOOD_META, None, "t"),
    "t_back": ("t,q\n0,1\n0.2,2\n0.1,3\n", GOOD_META, 3, "t"),
    "text": ("t,q\n0,1\n0.1,one\n", GOOD_META, 2, "q"),
    "inf": ("t,torque\n0,1\n0.1,2\n0.2,-inf\n", GOOD_META, 3, "torque"),
    "meta": ("t,q\n0,1\n", {**GOOD_META, "direction": "forward"}, None, "direction"),
}


@pytest.mark.parametrize("kind", sorted(BAD))
def test_import_refuses_bad_file_and_stores_nothing(tmp_path, capsys, kind):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    text, meta, row, column = BAD[kind]
    (tmp_path / "bad.csv").write_text(text)
    (tmp_path / "bad.json").write_text(json.dumps(meta))
    assert rig("import", str(tmp_path / "bad.csv"), "--db", url) == 1
    err = capsys.readouterr().err
    assert "bad.csv" in err or "bad.json" in err
    assert repr(column) in err and (row is None or f"row {row}" in err)
    assert count_rows(url) == {"runs": 0, "channels": 0, "sample_pages": 0, "sample_blocks": 0}


def test_import_good_and_bad_together(tmp_path, capsys):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    (tmp_path / "good.csv").write_text(GOOD_CSV)
    (tmp_path / "good.json").write_text(json.dumps(GOOD_META))
    (tmp_path / "bad.csv").write_text(BAD["text"][0])
    (tmp_path / "bad.json").write_text(json.dumps(GOOD_META))
    rc = rig("import", str(tmp_path / "good.csv"), str(tmp_path / "good.json"),
             str(tmp_path / "bad"), "--json", "--db", url)
    out = json.loads(capsys.readouterr().out)
    assert rc == 1
    assert len(out) == 1 and out[0]["source_file"].endswith("good.csv") and out[0]["samples"] == 2
    assert count_rows(url)["runs"] == 1


def _writer_run(url: str) -> int:
    """A run recorded by the writer, with an extra channel whose unit is not in the format."""
    rng = np.random.default_rng(3)
    with Store(url) as store, RunWriter(store) as w:
        rid = w.start({"scheme": 2, "motor_speed_rpm": 3000, "direction": -1, "source": "emulator",
                       "rig": "emu", "started_at": "2026-11-10T09:00:00Z"},
                      ["q", "torque_cmd", "torque_load", "phase", ChannelSpec("strain_x", unit="µm/m")])
        for k in range(3):
            t = (np.arange(400) + 400 * k) * 0.01
            q = rng.standard_normal(400)
            q[rng.random(400) < 0.1] = np.nan
            w.append({"t": t, "q": q, "torque_cmd": np.full(400, 1e4 * k),
                      "torque_load": 1e4 * k + rng.normal(0, 300, 400),
                      "phase": [("load", "hold", "unload")[k]] * 400,
                      "strain_x": rng.standard_normal(400)})
    return rid


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_export_import_round_trip(db_url, tmp_path, capsys, fmt):
    rid = _writer_run(db_url)
    out = tmp_path / "out"
    assert rig("export", str(rid), "--format", fmt, "--out", str(out), "--db", db_url) == 0
    paths = capsys.readouterr().out.split()
    assert [Path(p).name for p in paths] == [f"run-{rid}.{fmt}", f"run-{rid}.json"]
    exported = read_run(paths[0])
    assert exported.meta["units"] == {"strain_x": "µm/m"}
    assert rig("import", paths[0], "--json", "--db", db_url) == 0
    new_id = json.loads(capsys.readouterr().out)[0]["run_id"]
    with Store(db_url) as store:
        original, again = store.load_run(rid), store.load_run(new_id)
        pd.testing.assert_frame_equal(again.samples, original.samples)   # identical data
        assert again.meta == exported.meta
        assert {c["name"]: c["unit"] for c in store.channels(new_id)}["strain_x"] == "µm/m"
    # exporting the re-imported run gives the same files
    assert rig("export", str(new_id), "--format", fmt, "--out", str(tmp_path / "again"),
               "--db", db_url) == 0
    second = capsys.readouterr().out.split()
    assert Path(second[1]).read_text() == Path(paths[1]).read_text()
    if fmt == "csv":
        assert Path(second[0]).read_bytes() == Path(paths[0]).read_bytes()
    else:
        pd.testing.assert_frame_equal(pd.read_parquet(second[0]), pd.read_parquet(paths[0]))


@pytest.mark.skipif(not (EMPS / "DATA_EMPS.mat").exists(), reason="EMPS records not found")
def test_import_emps_record(tmp_path, capsys):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    assert rig("import", str(EMPS / "DATA_EMPS.mat"), "--json", "--db", url) == 0
    [r] = json.loads(capsys.readouterr().out)
    assert r["samples"] == 24841 and r["channels"] == ["t", "qm", "qg", "vir", "force"]
    with Store(url) as store:
        info = store.run_info(r["run_id"])
        assert info["source"] == "import" and info["rig"] == "EMPS"
        units = {c["name"]: c["unit"] for c in store.channels(r["run_id"])}
        assert units == {"t": "s", "qm": "m", "qg": "m", "vir": "V", "force": "N"}
    assert rig("show", str(r["run_id"]), "--db", url) == 0
    out = capsys.readouterr().out
    assert "Janot" in out and "not a loading run" in out


def test_runs_and_show(tmp_path, capsys):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    rid = _writer_run(url)
    assert rig("runs", "--db", url) == 0
    out = capsys.readouterr().out
    assert f"{rid}  finished    success" in out and "emu" in out
    assert rig("runs", "--json", "--scheme", "3", "--db", url) == 0
    assert json.loads(capsys.readouterr().out) == []
    assert rig("show", str(rid), "--db", url) == 0
    out = capsys.readouterr().out
    with Store(url) as store:
        q_missing = int(np.isnan(store.load_arrays(rid, ["q"])["q"]).sum())
    assert q_missing > 0
    q_line = next(ln for ln in out.splitlines() if ln.strip().startswith("q "))
    assert q_line.split()[-2:] == [str(1200 - q_missing), str(q_missing)]
    assert "torque loading error" in out and "PASS" in out
    assert rig("show", str(rid), "--json", "--db", url) == 0
    s = json.loads(capsys.readouterr().out)
    torque = s["acceptance"][0]
    assert torque["passed"] is True and torque["max_abs"] < 2000
    assert s["acceptance"][1]["passed"] is None            # no m_bend channel: not judged
    assert [p["phase"] for p in s["phases"]] == ["load", "hold", "unload"]
    assert rig("show", "999", "--db", url) == 1


def test_db_upgrade_command(tmp_path, capsys):
    url = f"sqlite:///{tmp_path / 'sub' / 'rig.sqlite'}"
    assert rig("db", "current", "--db", url) == 0
    assert "none" in capsys.readouterr().out
    from db.migrate import head_revision
    assert rig("db", "upgrade", "--db", url) == 0
    assert f"at revision {head_revision()}" in capsys.readouterr().out
    assert (tmp_path / "sub" / "rig.sqlite").exists()


def test_default_url_from_env(tmp_path, monkeypatch):
    from db.engine import database_url
    monkeypatch.delenv("RIG_DB_URL", raising=False)
    monkeypatch.chdir(tmp_path)
    assert database_url() == f"sqlite:///{tmp_path / 'rig-data' / 'rig.sqlite'}"
    monkeypatch.setenv("RIG_DB_URL", "sqlite:////x/y.sqlite")
    assert database_url() == "sqlite:////x/y.sqlite" and database_url("sqlite://") == "sqlite://"
    # and a write/read on a written run file via the default location
    monkeypatch.delenv("RIG_DB_URL")
    paths = write_run(RunData(pd.DataFrame({"t": [0.0, 1.0]}), {"source": "rig"}), tmp_path / "r")
    assert rig("import", str(paths[0])) == 0
    assert (tmp_path / "rig-data" / "rig.sqlite").exists()
