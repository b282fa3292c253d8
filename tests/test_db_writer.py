"""RunWriter (db/writer.py) on SQLite and PostgreSQL: the run lifecycle, interruptions as data,
commits while the run goes on, and the crash test (SIGKILL mid-run)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from db_fixtures import db_url  # noqa: F401  (fixture)

from db.store import Store
from db.writer import ChannelSpec, RunWriter

ROOT = Path(__file__).resolve().parents[1]
META = {"scheme": 2, "motor_speed_rpm": 3000, "direction": 1, "source": "emulator", "rig": "emu"}


def test_lifecycle_interruptions_and_late_channel(db_url):
    with Store(db_url) as store:
        w = RunWriter(store, commit_interval_s=0.05)
        rid = w.start(META, [ChannelSpec("torque", source="drive1"), "phase",
                             ChannelSpec("msg", kind="text")])
        assert store.run_info(rid)["status"] == "running"
        t = np.arange(100) * 0.1
        w.append({"t": t[:50], "torque": t[:50] * 10, "phase": ["load"] * 50})
        w.interruption("interlock", t_start=4.9, t_end=None, reason="oil pressure low",
                       detail={"p_hyd": 2.1e7})
        w.add_channels([ChannelSpec("temp_m1", source="drive1")])
        w.append({"t": t[50:], "torque": t[50:] * 10, "temp_m1": np.full(50, 31.5),
                  "msg": ["ok"] * 50})
        w.stop("abort", reason="interlock trip: oil pressure low")
        with pytest.raises(RuntimeError, match="already stopped"):
            w.append({"t": [99.0]})
        info = store.run_info(rid)
        assert (info["status"], info["exit_status"]) == ("finished", "abort")
        assert info["reason"] == "interlock trip: oil pressure low" and info["n_samples"] == 100
        [i] = store.interruptions(rid)
        assert (i["kind"], i["t_start"], i["reason"], i["detail"]) == \
            ("interlock", 4.9, "oil pressure low", {"p_hyd": 2.1e7})
        run = store.load_run(rid)
        assert list(run.samples.columns) == ["t", "torque", "phase", "msg", "temp_m1"]
        np.testing.assert_array_equal(run.t, t)
        assert np.isnan(run.channel("temp_m1")[:50]).all() and (run.channel("temp_m1")[50:] == 31.5).all()
        assert run.samples["phase"].tolist() == ["load"] * 50 + [None] * 50
        assert run.samples["msg"].tolist() == [None] * 50 + ["ok"] * 50
        assert {c["name"]: c["source"] for c in store.channels(rid)}["torque"] == "drive1"
        assert run.meta == META


def test_bad_appends_refused(db_url):
    with Store(db_url) as store, RunWriter(store) as w:
        w.start(META, ["q", "phase"])
        w.append({"t": [0.0, 1.0], "q": [1.0, 2.0]})
        with pytest.raises(ValueError, match="strictly increasing"):
            w.append({"t": [1.0], "q": [3.0]})
        with pytest.raises(KeyError, match="undeclared"):
            w.append({"t": [2.0], "torque": [3.0]})
        with pytest.raises(ValueError, match="unknown phase"):
            w.append({"t": [2.0], "phase": ["lunch"]})
        with pytest.raises(ValueError, match="samples where 't' has"):
            w.append({"t": [2.0, 3.0], "q": [1.0]})


def test_context_manager_marks_failure(db_url):
    with Store(db_url) as store:
        with pytest.raises(ZeroDivisionError):
            with RunWriter(store) as w:
                rid = w.start(META, ["q"])
                w.append({"t": [0.0], "q": [1.0]})
                1 / 0
        info = store.run_info(rid)
        assert (info["status"], info["exit_status"]) == ("finished", "fail")
        assert "ZeroDivisionError" in info["reason"] and info["n_samples"] == 1


def test_samples_committed_while_running(db_url):
    with Store(db_url) as store, RunWriter(store, commit_interval_s=0.2) as w:
        rid = w.start(META, ["q"])
        w.append({"t": np.arange(10.0), "q": np.arange(10.0)})
        with Store(db_url) as other:                         # another connection sees them
            deadline = time.monotonic() + 10
            while other.run_info(rid)["n_samples"] < 10 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert other.run_info(rid)["n_samples"] == 10
            assert other.run_info(rid)["status"] == "running"   # live writer: not recovered


CRASH = textwrap.dedent("""
    import os, sys, time
    import numpy as np
    from db.store import Store
    from db.writer import RunWriter
    url, log = sys.argv[1], sys.argv[2]
    store = Store(url)
    w = RunWriter(store)                                      # default commit interval
    rid = w.start({"scheme": 1, "source": "emulator"}, ["q"])
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    os.write(fd, f"run {rid}\\n".encode())
    k = 0
    while True:
        t = np.arange(k, k + 10) * 0.01
        w.append({"t": t, "q": np.sin(t)})
        os.write(fd, f"{k + 9} {time.time()!r}\\n".encode())   # samples ..k+9 acquired now
        k += 10
        time.sleep(0.02)
""")


def test_crash_loses_at_most_the_last_second(db_url, tmp_path):
    with Store(db_url):
        pass                                                  # schema ready before the child
    script, log = tmp_path / "acquire.py", tmp_path / "acquired.log"
    script.write_text(CRASH)
    proc = subprocess.Popen([sys.executable, str(script), db_url, str(log)], cwd=ROOT,
                            stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while (not log.exists() or "run" not in log.read_text()) and time.monotonic() < deadline:
            assert proc.poll() is None, proc.stderr.read()
            time.sleep(0.05)
        rid = int(log.read_text().split()[1])
        with Store(db_url, upgrade=False, recover=False) as watch:
            time.sleep(1.0)                                   # acquire for a while, then
            seen = watch.run_info(rid)["n_samples"]           # wait for a commit to land
            while watch.run_info(rid)["n_samples"] == seen and time.monotonic() < deadline:
                time.sleep(0.01)
        time.sleep(1.4)   # kill 1.4 s after a commit: a writer committing less often loses data
        kill_at = time.time()
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        proc.stderr.close()
    lines = log.read_text().split("\n")
    acquired = [(int(a), float(b)) for a, b in (ln.split() for ln in lines[1:] if ln.strip())]
    must_have = max(k for k, wall in acquired if wall < kill_at - 1.0)
    with Store(db_url) as store:                              # restart: recovery runs on open
        info = store.run_info(rid)
        assert info["status"] == "interrupted" and "ended without stopping" in info["reason"]
        assert store.interruptions(rid)[0]["kind"] == "writer_lost"
        a = store.load_arrays(rid)
    n = len(a["t"])
    assert n >= must_have + 1, f"lost samples acquired >1 s before the kill: have {n}, need {must_have + 1}"
    np.testing.assert_array_equal(a["t"], np.arange(n) * 0.01)         # a gap-free prefix
    np.testing.assert_array_equal(a["q"], np.sin(a["t"]))
