"""The database URL's password never leaves the service: not on a process command line (the
acquisition process and `rig run` get the run on stdin and the database by environment), not
in `rig run`'s printed lines, not in an acquisition's `log_tail` or reason, not in any API
answer. The end-to-end test runs a real acquisition against the PostgreSQL test server with a
password in the URL (the server's trust authentication ignores it); the rest needs nothing."""

from __future__ import annotations

import json
import socket
import time
from pathlib import Path

import pytest
from db_fixtures import empty_database
from drivers_harness import SLACK_ENV

PASSWORD = "Pw-s3cret-7f2c"


def test_redact_secrets_masks_url_passwords_and_password_items():
    from core.redact import redact_secrets

    assert redact_secrets(f"postgresql+psycopg://rig:{PASSWORD}@db:5432/rig?sslmode=require") \
        == "postgresql+psycopg://rig:***@db:5432/rig?sslmode=require"
    line = f"rig run: ... database postgresql://u:{PASSWORD}@h/db, retry " \
           f"(host=h password={PASSWORD} user=u) dsn?password={PASSWORD}&x=1"
    out = redact_secrets(line)
    assert PASSWORD not in out and out.count("***") == 3
    for clean in ("sqlite:////tmp/rig-data/rig.sqlite", "postgresql+psycopg://u@h/db",
                  "http://127.0.0.1:5020/x", "no url here: a=b"):
        assert redact_secrets(clean) == clean


def test_command_lines_carry_neither_the_run_nor_the_database():
    from api.acquisition import process_command
    from api.acquisition_process import AcquisitionSpec, run_command
    from core.schemes import RunSpec

    spec = AcquisitionSpec(run=RunSpec(1, {"load_target": 2e4}, operator="alice"),
                           target="emulator", time_scale=5.0)
    for argv in (process_command(), run_command()):
        text = " ".join(argv)
        assert "://" not in text and "alice" not in text and "load" not in text, argv
    assert AcquisitionSpec.from_json(spec.to_json()) == spec
    assert "://" not in spec.to_json()


def _cmdline(pid: int) -> str:
    return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()


def _environ(pid: int) -> str:
    return Path(f"/proc/{pid}/environ").read_bytes().replace(b"\0", b"\n").decode()


def test_a_password_in_the_database_url_reaches_no_command_line_log_or_answer(tmp_path):
    """Target 'rig' at a PLC that accepts connections and never answers: `rig run` prints its
    header (with the database URL), waits on the PLC, and fails; meanwhile the command lines
    of both processes are read from /proc."""
    from fastapi.testclient import TestClient
    from sqlalchemy.engine import make_url

    from api.app import create_app
    from api.settings import Settings
    from db.store import Store
    from db.tokens import create_token

    with empty_database("postgresql", tmp_path) as base, socket.socket() as mute_plc, \
            pytest.MonkeyPatch.context() as mp:
        url = make_url(base).set(password=PASSWORD).render_as_string(hide_password=False)
        assert PASSWORD in url
        mute_plc.bind(("127.0.0.1", 0))
        mute_plc.listen(8)                           # connects, never answers a request
        for k, v in {**SLACK_ENV, "RIG_PLC_HOST": "127.0.0.1",
                     "RIG_PLC_PORT": str(mute_plc.getsockname()[1])}.items():
            mp.setenv(k, v)
        mp.delenv("RIG_CONFIG", raising=False)
        mp.delenv("RIG_DB_URL", raising=False)
        store = Store(url)
        token = create_token(store, "test-rig-operator", ["rig-operator"])
        h = {"Authorization": f"Bearer {token}"}
        app = create_app(Settings(db_url=url, workers=0))
        try:
            with TestClient(app) as client:
                r = client.post("/schemes/1/runs", headers=h, json={
                    "target": "rig", "operator": "alice",
                    "params": {"load_target": 20e3, "ramp_rate": 10e3}})
                assert r.status_code == 202, r.text
                answers = [r.text]
                loc = r.headers["location"]
                acq = app.state.acquisitions.get(r.json()["id"])
                # the acquisition process: the database by environment, not on its command line
                assert PASSWORD not in _cmdline(acq.proc.pid)
                assert f"RIG_DB_URL={url}" in _environ(acq.proc.pid).splitlines()
                deadline = time.monotonic() + 60
                while acq.rig_run_pid is None and acq.state != "ended":
                    assert time.monotonic() < deadline, acq.snapshot()
                    time.sleep(0.01)
                assert acq.rig_run_pid is not None, acq.snapshot()
                cmd = _cmdline(acq.rig_run_pid)         # still importing: alive for seconds
                assert "--spec -" in cmd and PASSWORD not in cmd and "://" not in cmd, cmd
                while (a := client.get(loc, headers=h).json())["state"] != "ended":
                    assert time.monotonic() < deadline, a
                    answers.append(json.dumps(a))
                    time.sleep(0.1)
                answers += [client.get(loc, headers=h).text,
                            client.get("/acquisitions", headers=h).text]
                with client.stream("GET", loc + "/events", headers=h) as ev:
                    answers.append("".join(ev.iter_text()))
        finally:
            store.close()
    # `rig run` printed its header with the URL masked, and the relay kept it masked
    assert any(ln.startswith("rig run: scheme1") and "postgres:***@" in ln
               for ln in a["log_tail"]), a["log_tail"]
    assert a["run_id"] is None and a["reason"].startswith("failed before the run started"), a
    for text in answers:
        assert PASSWORD not in text
    assert PASSWORD not in json.dumps(acq.snapshot()) and PASSWORD not in "".join(acq.log)


def test_rig_run_json_events_report_a_refused_spec_as_one_event(tmp_path, capsys):
    """`rig run --json-events` with a refused spec: one `run_failed` event on stdout (nothing
    else: the service reads events, never text), the human line on stderr, exit 2, no
    database touched."""
    import argparse

    from commands import cmd_run

    p = argparse.ArgumentParser()
    cmd_run.add_arguments(p)
    spec = tmp_path / "run.json"
    spec.write_text(json.dumps({"scheme": 1, "params": {"motor_speed_rpm": 5000.0}}))
    args = p.parse_args(["--spec", str(spec), "--json-events",
                         "--db", f"sqlite:///{tmp_path / 'x.sqlite'}"])
    assert cmd_run.run(args) == 2
    out, err = capsys.readouterr()
    events = [json.loads(ln) for ln in out.splitlines()]
    assert [e["event"] for e in events] == ["run_failed"]
    assert "motor speed must be in" in events[0]["reason"] and events[0]["run_id"] is None
    assert "motor speed must be in" in err
    assert not (tmp_path / "x.sqlite").exists()


def test_job_workers_get_the_database_url_by_environment_not_argv(tmp_path):
    """The service's worker pool passes the database URL (a PostgreSQL URL holds its password)
    in the workers' environment only: /proc/<pid>/cmdline, which any local user can read, never
    holds it."""
    import sys
    import time

    from api.worker import WorkerPool

    url = f"sqlite:///{tmp_path / 'marker-s3cret.sqlite'}"
    pool = WorkerPool(url, 1, command=[sys.executable, "-c", "import time; time.sleep(60)"])
    pool.start()
    try:
        deadline = time.monotonic() + 30
        while not pool.procs and time.monotonic() < deadline:
            time.sleep(0.05)
        pid = pool.procs[0].pid
        cmdline = open(f"/proc/{pid}/cmdline", "rb").read()
        environ = open(f"/proc/{pid}/environ", "rb").read()
        assert b"marker-s3cret" not in cmdline, cmdline
        assert b"RIG_DB_URL=" + url.encode() in environ.split(b"\0")
    finally:
        pool.stop(timeout_s=5)
