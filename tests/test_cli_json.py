"""`--json` on every command that has a result (README, "JSON output"): each prints ONE JSON
document on stdout that parses and carries its documented keys; messages go elsewhere."""

import json

import pytest

from commands.cli import main


def rig(capsys, *argv: str):
    code = main(list(argv))
    out = capsys.readouterr().out
    assert code == 0, (argv, out)
    return json.loads(out)        # the whole stdout is one document


@pytest.fixture
def db(tmp_path, monkeypatch):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    monkeypatch.setenv("RIG_DB_URL", url)
    return url


def test_db_simulate_import_runs_show_export_json(db, tmp_path, capsys):
    up = rig(capsys, "db", "upgrade", "--json")
    assert set(up) == {"url", "revision", "head"} and up["revision"] == up["head"]
    cur = rig(capsys, "db", "current", "--json")
    assert cur == up

    out = tmp_path / "s3.csv"
    sim = rig(capsys, "simulate", "scheme3", "--sample-rate", "10", "--seed", "2",
              "--out", str(out), "--json")
    assert sim["scheme"] == 3 and sim["seed"] == 2 and sim["sample_rate_hz"] == 10.0
    assert sim["samples"] > 100 and sim["duration_s"] > 0 and sim["peak_torque_nm"] > 0
    assert sim["files"] == [str(out), str(out.with_suffix(".json"))]
    assert sim["effects"] == [] and sim["hysteresis"] is True

    imp = rig(capsys, "import", str(out), "--json")
    assert [r["samples"] for r in imp] == [sim["samples"]]
    run_id = imp[0]["run_id"]

    runs = rig(capsys, "runs", "--json")
    assert [r["id"] for r in runs] == [run_id]
    shown = rig(capsys, "show", str(run_id), "--json")
    assert shown["id"] == run_id and shown["n_samples"] == sim["samples"]

    exp = rig(capsys, "export", str(run_id), "--out", str(tmp_path / "x"), "--json")
    assert exp["run"] == run_id and exp["format"] == "csv"
    assert [p.rsplit("/", 1)[1] for p in exp["files"]] == [f"run-{run_id}.csv",
                                                          f"run-{run_id}.json"]


def test_token_json(db, capsys):
    made = rig(capsys, "token", "create", "--role", "viewer", "--name", "ci", "--json")
    assert set(made) == {"token", "name", "scopes", "expires_in_s"}
    assert made["scopes"] == ["viewer"] and made["name"] == "ci" and len(made["token"]) > 20
    rig(capsys, "token", "create", "--role", "operator", "--expires-in", "1h", "--json")
    rows = rig(capsys, "token", "list", "--json")
    assert [r["scopes"] for r in rows] == [["viewer"], ["operator"]]
    assert rows[0]["prefix"] == made["token"][:len(rows[0]["prefix"])]
    assert rows[0]["state"] == "live" and rows[0]["expires_at"] is None
    assert rows[1]["expires_at"].startswith("20")
    assert rig(capsys, "token", "revoke", str(rows[0]["id"]), "--json") == {"revoked": rows[0]["id"]}
    assert rig(capsys, "token", "list", "--json")[0]["state"] == "revoked"
