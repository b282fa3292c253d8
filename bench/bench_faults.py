"""Fault bench (issue 13): a scheme runs against the emulator (`rig emulate` + `rig run`, two
processes on loopback, SQLite store) and one fault is injected per row. Each row prints the
samples lost, how long the rig took to be safe (from the PLC stand-in's own trip record), whether
the run's stored record says why it ended, and whether anything is left stuck (a run still
'running'), each next to its target:

  rig safe < 1 s after any loss of control, <= 1 s of samples lost, 0 runs without an end reason,
  0 runs/jobs stuck.

Faults injected: SIGKILL of the acquisition (`rig run`), SIGKILL of the whole stand-in (PLC and
drives), one drive and two drives dead (the stand-in's `silence-drive N` control: the node
leaves the bus, its motor gives no torque; simulators/drives.py), SIGKILL of the service
(`rig serve` with a worker pool, scheme 1 started through POST /schemes/1/runs on its own
stand-in), SIGKILL of the job worker process running a job, the database made unavailable (an
exclusive SQLite lock held for a few seconds by another connection).

Where the rig is made safe is read from the plant's side where the bench can see it: the
stand-in's own lines (a PLC trip, a drive entering QUICK STOP ACTIVE), stamped as they arrive.
The service's stand-in is the acquisition process's child, out of the bench's sight: that row
takes the make-safe time from the run's own record (its end events, wall clock).

Run: `python bench/bench_faults.py` (about 4 minutes). Timings are wall-clock on this machine;
a loaded machine delays every process, so read the figures with its load (printed first).
"""

from __future__ import annotations

import json
import os
import re
import signal
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from db.store import Store  # noqa: E402
from simulators.process import StandinProcess  # noqa: E402

PROGRESS = re.compile(r"t=([\d.]+)/[\d.]+ s phase=\w+ n=(\d+) missed=(\d+)")
SAFE_TARGET_S = 1.0
LOST_TARGET_S = 1.0
RUN_TIMEOUT_S = 90.0
"""Upper bound of every wait in the bench [s] (no loop runs longer)."""


@dataclass
class Row:
    fault: str
    lost_samples: int | None = None
    lost_s: float | None = None
    safe_after_s: float | None = None
    end_reason: str | None = None
    stuck: int | None = None
    note: str = ""


@dataclass
class Acquisition:
    """A `rig run` process and its progress lines with the wall time each arrived."""
    proc: subprocess.Popen
    lines: list[tuple[float, str]] = field(default_factory=list)

    def start_reader(self) -> None:
        def read() -> None:
            assert self.proc.stdout is not None
            for ln in self.proc.stdout:
                self.lines.append((time.monotonic(), ln.rstrip("\n")))
        threading.Thread(target=read, daemon=True).start()

    def samples_seen(self, before: float | None = None) -> int:
        n = 0
        for tw, ln in list(self.lines):
            m = PROGRESS.search(ln)
            if m and (before is None or tw <= before):
                n = int(m.group(2))
        return n


class LineClock:
    """Stamp each line a stand-in prints with the monotonic time the bench saw it (polled every
    5 ms from the process's line list), from construction until `stop()`."""

    def __init__(self, sp: StandinProcess) -> None:
        self.sp = sp
        self.stamped: list[tuple[float, str]] = []
        self._stop = threading.Event()
        self._n = len(sp.lines)
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.005):
            lines = self.sp.lines
            now = time.monotonic()
            while self._n < len(lines):
                self.stamped.append((now, lines[self._n]))
                self._n += 1

    def first(self, after: float, *needles: str, timeout: float = 5.0) -> float | None:
        """Monotonic time of the first line after `after` containing one of `needles`."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for t, ln in list(self.stamped):
                if t >= after and any(n in ln for n in needles):
                    return t
            time.sleep(0.005)
        return None

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)


def plc_trip_time(sp: StandinProcess, after: float, timeout: float = 5.0) -> float | None:
    """Wall time (monotonic) the stand-in reported its first trip after `after`, from its own
    event record on stdout (`rig emulate: PLC trip: ...`), or None if it reported none."""
    seen: dict[int, float] = {}
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        for i, ln in enumerate(list(sp.lines)):
            if "PLC trip" in ln and i not in seen:
                seen[i] = time.monotonic()
        later = [t for t in seen.values() if t >= after]
        if later:
            return min(later)
        time.sleep(0.005)
    return None


def start_run(sp: StandinProcess, url: str) -> Acquisition:
    env = dict(os.environ, PYTHONUNBUFFERED="1", RIG_DB_URL=url,
               RIG_PLC_PORT=str(sp.plc_port), RIG_CAN_PORT=str(sp.can_port))
    env.pop("RIG_CONFIG", None)
    proc = subprocess.Popen([sys.executable, "-m", "commands.cli", "run", "scheme1",
                             "--speed", "3000", "--operator", "fault-bench"],
                            cwd=REPO, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    acq = Acquisition(proc)
    acq.start_reader()
    end = time.monotonic() + RUN_TIMEOUT_S
    while time.monotonic() < end and acq.samples_seen() < 20:
        if proc.poll() is not None:
            time.sleep(0.5)   # let the reader take the last lines
            last = [ln for _, ln in acq.lines if not PROGRESS.search(ln)][-3:]
            raise RuntimeError("rig run ended on its own before the fault: " + " | ".join(last))
        time.sleep(0.05)
    return acq


def with_retries(fault, tmp: Path, attempts: int = 3) -> Row:
    """Run one fault row; a run that ended on its own before the fault was injected (on a
    loaded machine the 0.5 s watchdogs can trip) is retried, and the row says how often."""
    errors = []
    for k in range(attempts):
        sub = tmp / f"{fault.__name__}-{k}"
        sub.mkdir()
        try:
            row = fault(sub)
        except RuntimeError as exc:
            errors.append(str(exc))
            continue
        if errors:
            row.note += f"; {len(errors)} earlier attempt(s) ended before the fault: {errors[-1]}"
        return row
    return Row(fault.__name__, note=f"no attempt reached the fault: {errors[-1]}")


def stored_outcome(url: str) -> tuple[int, float | None, str | None, int]:
    """(stored samples, sample rate [Hz], end reason, runs still 'running') of the one run;
    opening the Store runs its recovery of runs whose writer is gone, as the service does."""
    with Store(url) as store:
        runs = store.list_runs()
        run = runs[-1]
        stuck = sum(1 for r in runs if r["status"] == "running")
        rate = (run.get("meta") or {}).get("sample_rate_hz")
        return int(run["n_samples"] or 0), rate, run.get("reason"), stuck


def finish(acq: Acquisition, timeout: float = 20.0) -> None:
    if acq.proc.poll() is None:
        acq.proc.send_signal(signal.SIGINT)
        try:
            acq.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            acq.proc.kill()
            acq.proc.wait(timeout=10)


def fill(row: Row, url: str, seen: int) -> None:
    n, rate, reason, stuck = stored_outcome(url)
    row.lost_samples = max(0, seen - n)
    row.lost_s = row.lost_samples / rate if rate else None
    row.end_reason = reason
    row.stuck = stuck


def fault_kill_acquisition(tmp: Path) -> Row:
    row = Row("kill -9 acquisition (rig run)")
    url = f"sqlite:///{tmp / 'acq.sqlite'}"
    with StandinProcess([]) as sp:
        acq = start_run(sp, url)
        time.sleep(1.0)
        t_kill = time.monotonic()
        acq.proc.kill()
        acq.proc.wait(timeout=10)
        seen = acq.samples_seen(before=t_kill)
        trip = plc_trip_time(sp, after=t_kill)
        row.safe_after_s = None if trip is None else trip - t_kill
    fill(row, url, seen)
    row.note = "PLC watchdog on the service heartbeat"
    return row


def fault_kill_standin(tmp: Path) -> Row:
    row = Row("kill -9 PLC stand-in (PLC + drives)")
    url = f"sqlite:///{tmp / 'standin.sqlite'}"
    with StandinProcess([]) as sp:
        acq = start_run(sp, url)
        time.sleep(1.0)
        t_kill = time.monotonic()
        sp.kill()
        end = time.monotonic() + RUN_TIMEOUT_S
        while time.monotonic() < end and acq.proc.poll() is None:
            time.sleep(0.01)
        t_end = time.monotonic()
        finish(acq)
        seen = acq.samples_seen(before=t_kill)
    fill(row, url, seen)
    row.note = (f"the plant died with its PLC: no trip record; the acquisition ended its run "
                f"{t_end - t_kill:.2f} s after the kill")
    return row


def fault_database_locked(tmp: Path, hold_s: float = 3.0) -> Row:
    row = Row(f"database unavailable {hold_s:.0f} s (SQLite locked)")
    path = tmp / "locked.sqlite"
    url = f"sqlite:///{path}"
    with StandinProcess([]) as sp:
        acq = start_run(sp, url)
        time.sleep(1.0)
        conn = sqlite3.connect(path, timeout=0.1, isolation_level=None)
        t_lock = time.monotonic()
        conn.execute("BEGIN EXCLUSIVE")
        time.sleep(hold_s)
        conn.execute("ROLLBACK")
        conn.close()
        trip = plc_trip_time(sp, after=t_lock, timeout=0.5)
        time.sleep(3.0)   # let the writer catch up, then stop the run as an operator would
        seen = acq.samples_seen()
        alive = acq.proc.poll() is None
        finish(acq)
        row.safe_after_s = None if trip is None else trip - t_lock
    fill(row, url, seen)
    row.note = ("run kept acquiring through the outage" if alive
                else "the acquisition ended during the outage")
    if trip is None:
        row.note += "; no loss of control, no trip (rig safe figure not applicable)"
    return row


def drive_events(url: str) -> list[dict]:
    """The drive and trip events of the bench's one run (its stored end record)."""
    with Store(url) as store:
        run = store.list_runs()[-1]
        info = store.run_info(run["id"])
    events = ((info.get("meta") or {}).get("end") or {}).get("events") or []
    return [e for e in events if e.get("kind") in ("heartbeat_lost", "dropped", "degraded",
                                                   "trip", "make_safe")]


def fault_one_drive(tmp: Path, node: int = 2, after_s: float = 3.0) -> Row:
    row = Row(f"one drive dead (node {node})")
    url = f"sqlite:///{tmp / 'one-drive.sqlite'}"
    with StandinProcess([], control=True) as sp:
        clock = LineClock(sp)
        acq = start_run(sp, url)
        time.sleep(1.0)
        t_fault = time.monotonic()
        sp.silence_drive(node)
        time.sleep(after_s)
        alive = acq.proc.poll() is None
        trip = clock.first(t_fault, "PLC trip", "QUICK STOP ACTIVE", timeout=0.0)
        seen = acq.samples_seen()
        finish(acq)    # an operator's stop: the run was meant to go on degraded
        clock.stop()
    fill(row, url, seen)
    ev = [e["message"] for e in drive_events(url) if e["kind"] in ("dropped", "degraded")]
    row.safe_after_s = None   # not a loss of control: the joint goes on (daq/rig.py policy)
    row.note = ("rig policy: one lost drive is dropped and the joint continues on the others "
                "(no make-safe, safe figure n/a); "
                + ("run still acquiring " if alive else "run ENDED ")
                + f"{after_s:.0f} s after the fault, then stopped by the bench (SIGINT); "
                + ("stand-in saw a stop before that: UNEXPECTED; " if trip else "")
                + "record: " + (" | ".join(ev) or "NO drive event recorded"))
    return row


def fault_two_drives(tmp: Path, nodes: tuple[int, int] = (2, 3)) -> Row:
    row = Row(f"two drives dead (nodes {nodes[0]}, {nodes[1]})")
    url = f"sqlite:///{tmp / 'two-drives.sqlite'}"
    with StandinProcess([], control=True) as sp:
        clock = LineClock(sp)
        acq = start_run(sp, url)
        time.sleep(1.0)
        sp.silence_drive(nodes[0])
        sp.silence_drive(nodes[1])
        t_fault = time.monotonic()   # control is lost with the second drive
        end = time.monotonic() + RUN_TIMEOUT_S
        while time.monotonic() < end and acq.proc.poll() is None:
            time.sleep(0.01)
        t_end = time.monotonic()
        safe = clock.first(t_fault, "QUICK STOP ACTIVE", "PLC trip")
        plc = clock.first(t_fault, "PLC trip")
        finish(acq)
        seen = acq.samples_seen(before=t_end)
        clock.stop()
        row.safe_after_s = None if safe is None else safe - t_fault
    fill(row, url, seen)
    row.note = (f"safe = the remaining drive's quick stop seen by the stand-in; the run ended "
                f"{t_end - t_fault:.2f} s after the second drive died"
                + (f", PLC watchdog trip {plc - t_fault:.2f} s after (heartbeat gone with "
                   f"`rig run`)" if plc is not None else ", no PLC trip seen"))
    return row


SERVICE_LONG = {"motor_speed_rpm": 3000.0, "load_target": 100e3, "ramp_rate": 2.5e3,
                "accel_time": 0.5, "settle_time": 0.5, "rest_time": 0.5, "sample_rate_hz": 20.0}
"""Scheme 1 of ~82 s of rig time (~16 s of wall time at time scale 5), as the API tests run
it mid-run: the fault comes long before its end."""
SERVICE_SCALE = 5.0


def _free_port() -> int:
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Service:
    """`rig serve --workers N` on loopback on a SQLite store; its log in a file."""

    def __init__(self, url: str, tmp: Path, workers: int, name: str) -> None:
        self.port = _free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        env = dict(os.environ, PYTHONUNBUFFERED="1", RIG_DB_URL=url, RIG_API_HOST="127.0.0.1",
                   RIG_API_PORT=str(self.port))
        env.pop("RIG_CONFIG", None)
        self.log = open(tmp / f"{name}.log", "w")
        self.proc = subprocess.Popen([sys.executable, "-m", "commands.cli", "serve",
                                      "--workers", str(workers)], cwd=REPO, env=env,
                                     stdout=self.log, stderr=subprocess.STDOUT)
        import httpx
        end = time.monotonic() + RUN_TIMEOUT_S
        while True:
            try:
                if httpx.get(f"{self.base}/openapi.json", timeout=2).status_code == 200:
                    return
            except httpx.TransportError:
                pass
            if self.proc.poll() is not None or time.monotonic() > end:
                self.stop()
                raise RuntimeError(f"rig serve did not come up (see {self.log.name})")
            time.sleep(0.1)

    def get(self, path: str, token: str) -> dict:
        import httpx
        r = httpx.get(self.base + path, headers={"Authorization": f"Bearer {token}"}, timeout=10)
        r.raise_for_status()
        return r.json()

    def post(self, path: str, token: str, body: dict | None = None):
        import httpx
        return httpx.post(self.base + path, json=body or {}, timeout=30,
                          headers={"Authorization": f"Bearer {token}"})

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)
        self.log.close()


def _tokens(url: str) -> dict[str, str]:
    from db.tokens import create_token
    with Store(url) as store:
        return {r: create_token(store, f"fault-bench-{r}", [r]) for r in ("viewer", "operator")}


def _pid_gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    # a zombie child of a dead parent is reaped by init soon; /proc tells
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(") ")[1].startswith("Z")
    except (OSError, IndexError):
        return True


def _children(pid: int) -> list[tuple[int, str]]:
    """(pid, command line) of the direct children of `pid` now (Linux /proc)."""
    out = []
    try:
        kids = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    except OSError:
        return out
    for k in kids:
        try:
            cmd = Path(f"/proc/{k}/cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        out.append((int(k), cmd))
    return out


def fault_kill_service(tmp: Path) -> Row:
    row = Row("kill -9 the service (rig serve)")
    url = f"sqlite:///{tmp / 'service.sqlite'}"
    Store(url).close()
    tok = _tokens(url)
    svc = Service(url, tmp, workers=1, name="serve-1")
    try:
        r = svc.post("/schemes/1/runs", tok["operator"], {
            "target": "emulator", "operator": "fault-bench", "params": SERVICE_LONG,
            "emulator": {"time_scale": SERVICE_SCALE, "seed": 3}})
        if r.status_code != 202:
            raise RuntimeError(f"POST /schemes/1/runs answered {r.status_code}: {r.text[:300]}")
        loc = r.headers["location"]
        end = time.monotonic() + RUN_TIMEOUT_S
        while True:
            a = svc.get(loc, tok["viewer"])
            if a["state"] == "running" and (a.get("progress") or {}).get("n_samples", 0) >= 20:
                break
            if a["state"] == "ended" or time.monotonic() > end:
                raise RuntimeError(f"the acquisition ended before the fault: {a.get('reason')}")
            time.sleep(0.05)
        time.sleep(1.0)
        a = svc.get(loc, tok["viewer"])
        seen = int(a["progress"]["n_samples"])
        t_run_kill = a["progress"].get("t")
        children = _children(svc.proc.pid)
        t_kill = time.monotonic()
        svc.proc.kill()
        svc.proc.wait(timeout=10)
    finally:
        svc.stop()
    run_id, standin_pid = a["run_id"], (a.get("standin") or {}).get("pid")
    # the acquisition process lives on: wait for it to end the run and stop its stand-in
    end = time.monotonic() + RUN_TIMEOUT_S
    while time.monotonic() < end:
        with Store(url) as store:
            status = store.run_info(run_id)["status"]
        if status != "running" and (standin_pid is None or _pid_gone(standin_pid)):
            break
        time.sleep(0.1)
    t_settled = time.monotonic()
    orphans = [(pid, cmd) for pid, cmd in children
               if "api.worker" in cmd and not _pid_gone(pid)]
    for pid, _ in orphans:      # the bench cleans up what the killed service left
        os.kill(pid, signal.SIGKILL)
    svc2 = Service(url, tmp, workers=1, name="serve-2")
    try:
        info = svc2.get(f"/runs/{run_id}", tok["viewer"])
    finally:
        svc2.stop()
    events = ((info.get("meta") or {}).get("end") or {}).get("events") or []
    safe = [e for e in events if e.get("kind") == "make_safe" and e.get("t_run") is not None
            and t_run_kill is not None and e["t_run"] >= t_run_kill]
    # run time is rig time: / time scale = wall time; the last progress before the kill is up
    # to one progress period (0.2 s) old, so this over-states the delay by at most that
    row.safe_after_s = (safe[0]["t_run"] - t_run_kill) / SERVICE_SCALE if safe else None
    fill(row, url, seen)
    row.end_reason = f"{info.get('exit_status')}: {info.get('reason')}" \
        if info.get("exit_status") and info.get("reason") else None
    row.note = (f"safe = make-safe in the run's own record, from the last progress before the "
                f"kill (<= 0.2 s early; the stand-in is the acquisition process's child); run {info.get('status')} and stand-in gone "
                f"{t_settled - t_kill:.2f} s after the kill; record read by a new service"
                + ("" if safe else "; NO make-safe after the kill in the record")
                + ("; the reason blames the operator, not the lost service (the acquisition "
                   "process turns end of input into `stop`)"
                   if "operator" in (info.get("reason") or "") else "")
                + (f"; {len(orphans)} job worker process(es) of the killed service still alive "
                   f"{t_settled - t_kill:.1f} s later (orphaned; killed by the bench)"
                   if orphans else ""))
    return row


def fault_kill_job_worker(tmp: Path) -> Row:
    """A job's worker process SIGKILLed mid-job: re-queued, run again by the restarted worker,
    finished; nothing left 'running' or 'queued'. No run, so no samples."""
    row = Row("kill -9 a job worker")
    url = f"sqlite:///{tmp / 'jobs.sqlite'}"
    Store(url).close()
    tok = _tokens(url)
    # a stored run to fit: a short scheme 1 on the emulator, as an operator records one
    with StandinProcess([]) as sp:
        acq = start_run(sp, url)
        time.sleep(1.0)
        finish(acq)
    with Store(url) as store:
        run_id = store.list_runs()[-1]["id"]
    svc = Service(url, tmp, workers=1, name="serve-jobs")
    try:
        r = svc.post("/jobs", tok["operator"], {"kind": "identification", "params": {
            "run_ids": [run_id], "model": "eq4", "method": "mh",
            "options": {"chains": 1, "draws": 30_000, "warmup": 1000, "seed": 1}}})
        if r.status_code != 202:
            raise RuntimeError(f"POST /jobs answered {r.status_code}: {r.text[:300]}")
        jid = r.json()["id"]
        end = time.monotonic() + RUN_TIMEOUT_S
        while True:
            j = svc.get(f"/jobs/{jid}", tok["viewer"])
            if j["state"] == "running" and j.get("worker"):
                break
            if j["state"] in ("succeeded", "failed", "cancelled") or time.monotonic() > end:
                raise RuntimeError(f"the job was {j['state']} before the fault: {j.get('error')}")
            time.sleep(0.05)
        time.sleep(0.5)
        pid = int(j["worker"].split("/")[1])
        t_kill = time.monotonic()
        os.kill(pid, signal.SIGKILL)
        requeued_after = None
        end = time.monotonic() + 4 * RUN_TIMEOUT_S
        while time.monotonic() < end:
            j = svc.get(f"/jobs/{jid}", tok["viewer"])
            if requeued_after is None and (j["state"] == "queued" or j.get("attempts", 0) >= 2
                                           or (j.get("worker") or "").split("/")[1:2] != [str(pid)]):
                requeued_after = time.monotonic() - t_kill
            if j["state"] in ("succeeded", "failed", "cancelled"):
                break
            time.sleep(0.1)
        t_done = time.monotonic()
        health = svc.get("/health", tok["viewer"])
        with Store(url) as store:
            from db import jobs as queue
            counts = queue.queue_counts(store)
    finally:
        svc.stop()
    row.stuck = counts["queued"] + counts["running"]
    row.end_reason = (f"job {j['state']} after {j.get('attempts')} attempts"
                      + (f": {j.get('error')}" if j.get("error") else "")) \
        if j["state"] in ("succeeded", "failed") else None
    workers = (health.get("workers") or {}) if isinstance(health, dict) else {}
    row.note = ("samples n/a (no run); "
                + (f"re-queued/taken again {requeued_after:.2f} s after the kill, "
                   if requeued_after is not None else "NOT seen re-queued, ")
                + f"ended {t_done - t_kill:.1f} s after it; /health workers: "
                + json.dumps({k: workers.get(k) for k in ("alive", "restarts") if k in workers}))
    return row


def fmt(v: float | int | None, unit: str = "") -> str:
    if v is None:
        return "n/a"
    return f"{v:.3f}{unit}" if isinstance(v, float) else f"{v}{unit}"


def main() -> int:
    load = os.getloadavg()
    print(f"fault bench: load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} on "
          f"{os.cpu_count()} cores")
    rows: list[Row] = []
    with tempfile.TemporaryDirectory(prefix="rig-fault-bench-") as d:
        for fault in (fault_kill_acquisition, fault_kill_standin, fault_one_drive,
                      fault_two_drives, fault_kill_service, fault_kill_job_worker,
                      fault_database_locked):
            try:
                rows.append(with_retries(fault, Path(d)))
            except Exception as exc:  # a fault the bench could not inject is a row, not a stop
                rows.append(Row(fault.__name__, note=f"bench error: {exc!r}"[-400:]))
    print()
    print(f"{'fault':40s} {'lost samples':>12s} {'lost [s] (<=1)':>15s} {'safe [s] (<1)':>14s} "
          f"{'end reason (must)':>18s} {'stuck (0)':>9s}")
    fails = 0
    for r in rows:
        ok_lost = r.lost_s is None or r.lost_s <= LOST_TARGET_S
        ok_safe = r.safe_after_s is None or r.safe_after_s < SAFE_TARGET_S
        ok_reason = r.end_reason is not None
        ok_stuck = not r.stuck
        fails += not (ok_lost and ok_safe and ok_reason and ok_stuck)
        print(f"{r.fault:40s} {fmt(r.lost_samples):>12s} {fmt(r.lost_s):>15s} "
              f"{fmt(r.safe_after_s):>14s} {('yes' if r.end_reason else 'NO'):>18s} "
              f"{fmt(r.stuck):>9s}")
        if r.end_reason:
            print(f"{'':40s}   reason: {r.end_reason}")
        if r.note:
            print(f"{'':40s}   {r.note}")
    print()
    print(f"targets: safe < {SAFE_TARGET_S} s, lost <= {LOST_TARGET_S} s, 0 without end reason, "
          f"0 stuck; rows missing a target: {fails}")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
