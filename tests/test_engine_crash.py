"""Crash test of the acquisition: `rig run` as its own process against `rig emulate` (another
process), killed with SIGKILL mid-run. Every sample it had acquired more than one second before
the kill must be in the database, the run must be marked interrupted by the Store's recovery (not
left running), and the PLC's watchdog must have made the rig safe without the service."""

from __future__ import annotations

import asyncio
import os
import re
import signal
import subprocess
import sys
import threading
import time

import numpy as np

from daq.plc import PlcClient
from db.store import Store
from drivers_harness import REPO, SLACK_ENV, SLACK_S, SLACK_STANDIN, StandinProcess, wait_for
from daq.settings import Settings

LINE = re.compile(r"t=([\d.]+)/[\d.]+ s phase=\w+ n=(\d+) missed=(\d+)")


def run_env(sp: StandinProcess, url: str) -> dict[str, str]:
    """The environment of a `rig run` against the stand-in `sp`, storing into `url`."""
    env = dict(os.environ, PYTHONUNBUFFERED="1", RIG_DB_URL=url,
               RIG_PLC_PORT=str(sp.plc_port), RIG_CAN_PORT=str(sp.can_port),
               RIG_PLC_POLL_HZ="200", RIG_TPDO_RATE_HZ="100", **SLACK_ENV)
    env.pop("RIG_CONFIG", None)
    return env


def test_kill_9_mid_run_keeps_what_was_acquired(tmp_path):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    with StandinProcess(["--time-scale", "5", *SLACK_STANDIN]) as sp:
        env = run_env(sp, url)
        proc = subprocess.Popen([sys.executable, "-m", "commands.cli", "run", "scheme1",
                                 "--speed", "3000", "--operator", "crash-test"],
                                cwd=REPO, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
        lines: list[tuple[float, str]] = []    # (wall time received, line)

        def read() -> None:
            for ln in proc.stdout:
                lines.append((time.monotonic(), ln.rstrip("\n")))
        reader = threading.Thread(target=read, daemon=True)
        reader.start()

        def progress() -> list[tuple[float, int]]:
            out = []
            for tw, ln in lines:
                m = LINE.search(ln)
                if m:
                    out.append((tw, int(m.group(2))))
            return out
        # let it acquire for a while (the default scheme 1 lasts 104 s of rig time, ~21 s wall)
        assert wait_for(lambda: any(n >= 60 for _, n in progress()), timeout=60.0), lines
        time.sleep(1.5)
        assert proc.poll() is None, lines
        proc.kill()
        t_kill = time.monotonic()
        proc.wait(timeout=10)
        reader.join(timeout=5)
        acquired = [n for tw, n in progress() if tw <= t_kill - 1.0]
        assert acquired and acquired[-1] >= 60
        n_before = acquired[-1]

        # the PLC's watchdog made the rig safe on its own (the service is gone)
        async def status():
            c = PlcClient(Settings(plc_port=sp.plc_port))
            await c.connect()
            try:
                await asyncio.sleep(SLACK_S + 1.0)
                return await c.read_status()
            finally:
                c.close()
        st = asyncio.run(status())
        assert st["fault_code"] == 1 and st["plc_mode"] == 2
        assert abs(st["torque_cmd"]) < 1.0

    with Store(url) as store:          # opening the store runs the recovery
        runs = store.list_runs()
        assert len(runs) == 1
        r = runs[0]
        assert r["status"] == "interrupted" and r["exit_status"] is None
        assert "ended without stopping the run" in r["reason"]
        assert r["meta"]["operator"] == "crash-test"
        assert r["n_samples"] >= n_before
        d = store.load_arrays(r["id"])
        assert len(d["t"]) == r["n_samples"] and np.all(np.diff(d["t"]) > 0)
        assert np.isfinite(d["torque"][:n_before]).all()
        intr = store.interruptions(r["id"])
        assert [i["kind"] for i in intr] == ["writer_lost"]
        assert intr[0]["t_start"] == r["t_last"]


def test_ctrl_c_aborts_the_run_and_makes_the_rig_safe(tmp_path):
    url = f"sqlite:///{tmp_path / 'rig.sqlite'}"
    with StandinProcess(["--time-scale", "5", *SLACK_STANDIN]) as sp:
        env = run_env(sp, url)
        proc = subprocess.Popen([sys.executable, "-m", "commands.cli", "run", "scheme2",
                                 "--speed", "300", "--effect", "backlash"],
                                cwd=REPO, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
        lines: list[str] = []
        reader = threading.Thread(target=lambda: lines.extend(ln.rstrip("\n") for ln in proc.stdout),
                                  daemon=True)
        reader.start()
        assert wait_for(lambda: any(LINE.search(ln) for ln in lines), timeout=60.0), lines
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 1
        reader.join(timeout=5)
        assert any("aborted by the operator; the rig was made safe" in ln for ln in lines), lines
    with Store(url) as store:
        (r,) = store.list_runs()
        assert (r["status"], r["exit_status"]) == ("finished", "abort")
        assert r["reason"] == "cancelled by the operator"
        assert r["meta"]["effects"] == {"backlash": {}}
        assert r["meta"]["effects_declared_by"] == "operator"
        ev = r["meta"]["end"]["events"]
        assert any(e["kind"] == "make_safe" and "abort" in e["message"] for e in ev)
        assert r["meta"]["end"]["after_make_safe"] == "pump off, valve locked, run request cleared"
