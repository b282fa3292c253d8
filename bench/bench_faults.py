"""Fault bench (issue 13): a scheme runs against the emulator (`rig emulate` + `rig run`, two
processes on loopback, SQLite store) and one fault is injected per row. Each row prints the
samples lost, how long the rig took to be safe (from the PLC stand-in's own trip record), whether
the run's stored record says why it ended, and whether anything is left stuck (a run still
'running'), each next to its target:

  rig safe < 1 s after any loss of control, <= 1 s of samples lost, 0 runs without an end reason,
  0 runs/jobs stuck.

Faults injected: SIGKILL of the acquisition (`rig run`), SIGKILL of the whole stand-in (PLC and
drives), the database made unavailable (an exclusive SQLite lock held for a few seconds by
another connection). Rows that this bench cannot inject are printed with the reason.

Run: `python bench/bench_faults.py` (about 2 minutes). Timings are wall-clock on this machine;
a loaded machine delays every process, so read the figures with its load (printed first).
"""

from __future__ import annotations

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


NOT_INJECTED = [
    ("kill one drive (CAN node)", "the stand-in serves all drives from one process and one "
     "emulator; it has no way to stop one node alone"),
    ("kill two drives", "same reason"),
    ("kill -9 the service (uvicorn)", "not injected by this bench yet"),
    ("kill -9 a job worker", "not injected by this bench yet"),
]


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
        for fault in (fault_kill_acquisition, fault_kill_standin, fault_database_locked):
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
    for name, why in NOT_INJECTED:
        print(f"{name:40s} not measured: {why}")
    print()
    print(f"targets: safe < {SAFE_TARGET_S} s, lost <= {LOST_TARGET_S} s, 0 without end reason, "
          f"0 stuck; rows missing a target: {fails}")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
