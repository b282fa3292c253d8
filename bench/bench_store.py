"""Benchmark of the run store (db/) against a plain `sqlite3` baseline, in the same run.

A run of 1 000 000 samples × 20 numeric channels (`t` + 19, 1 % of one channel missing) plus a
`phase` column (idle, load, hold, unload in long segments). Measured, each as the median of
--repeat repetitions, on SQLite files in a temporary directory with the same settings (WAL,
synchronous=FULL):

- write: ours = Store.save_run (pages of binary blocks + statistics, one transaction) and
  RunWriter (streamed in appends of 10 000 samples, background commits); baseline = one row per
  sample (`executemany` in one transaction). Reported in values/s (samples × channels / s).
- load: ours = Store.load_arrays (whole run into numpy arrays); baseline = SELECT of every row
  into a numpy array.
- aggregate: ours = Store.phase_aggregates (count, missing, mean, variance, min, max per
  channel per phase, SQL over the page statistics); baseline = the same statistics by GROUP BY
  phase over the one-row-per-sample table.
- range read (what `GET /runs/{id}/data` does): peak memory allocated (tracemalloc) and time
  (median of 3) of Store.select_range + range_values, page by page, against loading the whole
  run (Store.load_arrays) and cutting it, as the endpoint did before; for one channel over 1 %
  of the run, and for every channel over the whole run decimated to 10 000 points. Measured at
  1 M samples (loaded 2-core machine): 0.4 MiB / 0.05 s against 31 MiB / 0.12 s, and
  4.2 MiB / 1.1 s against 313 MiB / 0.8 s (every block is read either way; page by page trades
  a third more time for 75 times less memory).

Targets (issue 4): load < 0.5 s, aggregate < 0.5 s, write > 500 000 values/s.

    python bench/bench_store.py            # full size, 3 repetitions
    python bench/bench_store.py --samples 100000 --repeat 1   # quick
"""

from __future__ import annotations

import argparse
import os
import platform
import sqlite3
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from machine import cpu_model  # bench/machine.py (run as python bench/NAME.py)
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from db.store import Store  # noqa: E402
from db.writer import RunWriter  # noqa: E402
from core.run import RunData  # noqa: E402

N_CHANNELS = 20
PHASE_ORDER = ("idle", "load", "hold", "unload")


def make_run(n: int, seed: int = 0) -> RunData:
    rng = np.random.default_rng(seed)
    cols = {"t": np.arange(n) * 1e-3}
    for k in range(N_CHANNELS - 1):
        cols[f"c{k:02d}"] = rng.normal(1e3 * k, 1.0 + k, n)
    cols["c00"][rng.random(n) < 0.01] = np.nan
    seg = np.repeat(np.arange(8), -(-n // 8))[:n]            # 8 segments: idle load hold unload ×2
    cols["phase"] = np.array(PHASE_ORDER, dtype=object)[seg % 4]
    return RunData(samples=pd.DataFrame(cols), meta={"scheme": 1, "source": "emulator",
                                                     "rig": "bench"})


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


# --- plain sqlite3 baseline: one row per sample ---------------------------------------------

def baseline_connect(path: Path) -> sqlite3.Connection:
    con = sqlite3.connect(path, isolation_level=None)
    con.execute("PRAGMA journal_mode=WAL")
    con.execute("PRAGMA synchronous=FULL")
    chans = ", ".join(f"x{k} REAL" for k in range(N_CHANNELS))
    con.execute(f"CREATE TABLE IF NOT EXISTS samples (run_id INTEGER, i INTEGER, phase TEXT, "
                f"{chans}, PRIMARY KEY (run_id, i))")
    return con


def baseline_write(con: sqlite3.Connection, run_id: int, run: RunData) -> None:
    df = run.samples
    names = [c for c in df.columns if c != "phase"]
    values = df[names].to_numpy()
    phase = df["phase"].tolist()
    rows = [(run_id, i, phase[i], *[None if v != v else v for v in row])
            for i, row in enumerate(values.tolist())]
    qs = ", ".join("?" * (N_CHANNELS + 3))
    con.execute("BEGIN")
    con.executemany(f"INSERT INTO samples VALUES ({qs})", rows)
    con.execute("COMMIT")


def baseline_load(con: sqlite3.Connection, run_id: int) -> np.ndarray:
    cols = ", ".join(f"x{k}" for k in range(N_CHANNELS))
    rows = con.execute(f"SELECT {cols} FROM samples WHERE run_id = ? ORDER BY i", (run_id,)).fetchall()
    return np.array(rows, dtype=float)


def baseline_aggregate(con: sqlite3.Connection, run_id: int) -> list[tuple]:
    parts = []
    for k in range(N_CHANNELS):
        x = f"x{k}"
        parts.append(f"COUNT({x}), COUNT(*) - COUNT({x}), AVG({x}), "
                     f"(SUM({x}*{x}) - SUM({x})*SUM({x})/COUNT({x})) / (COUNT({x}) - 1), "
                     f"MIN({x}), MAX({x})")
    sql = f"SELECT phase, {', '.join(parts)} FROM samples WHERE run_id = ? GROUP BY phase"
    return con.execute(sql, (run_id,)).fetchall()


# --- ours -------------------------------------------------------------------------------------

def writer_write(store: Store, run: RunData, chunk: int = 10_000) -> int:
    df = run.samples
    cols = {c: df[c].to_numpy() for c in df.columns}
    w = RunWriter(store)
    rid = w.start(run.meta, [c for c in df.columns])
    for a in range(0, len(df), chunk):
        w.append({c: v[a:a + chunk] for c, v in cols.items()})
    w.stop("success")
    return rid


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    n, values = args.samples, args.samples * N_CHANNELS
    print(f"machine: {cpu_model()}, {os.cpu_count()} cores; Python {platform.python_version()}, "
          f"SQLite {sqlite3.sqlite_version}, numpy {np.__version__}, pandas {pd.__version__}; "
          f"load average {os.getloadavg()[0]:.1f} at start")
    print(f"run: {n} samples × {N_CHANNELS} numeric channels + phase = {values} values; "
          f"median of {args.repeat}")
    run = make_run(n)
    res: dict[str, list[float]] = {k: [] for k in (
        "save_run", "writer", "base_write", "load", "load_pandas", "base_load", "agg", "base_agg")}
    with tempfile.TemporaryDirectory(prefix="bench-store-") as tmp:
        store = Store(f"sqlite:///{tmp}/ours.sqlite")
        con = baseline_connect(Path(tmp) / "baseline.sqlite")
        for rep in range(args.repeat):
            dt, rid = timed(lambda: store.save_run(run))
            res["save_run"].append(dt)
            res["writer"].append(timed(lambda: writer_write(store, run))[0])
            res["base_write"].append(timed(lambda: baseline_write(con, rep, run))[0])
            dt, arrays = timed(lambda: store.load_arrays(rid))
            res["load"].append(dt)
            res["load_pandas"].append(timed(lambda: store.load_run(rid))[0])
            dt, base = timed(lambda: baseline_load(con, rep))
            res["base_load"].append(dt)
            dt, agg = timed(lambda: store.phase_aggregates(rid))
            res["agg"].append(dt)
            dt, base_agg = timed(lambda: baseline_aggregate(con, rep))
            res["base_agg"].append(dt)
        # both paths must agree with the data they were given
        x = run.samples["c05"].to_numpy()
        assert np.array_equal(arrays["c05"], x) and np.array_equal(base[:, 6], x)
        row = agg[(agg.channel == "c05") & (agg.phase == "load")].iloc[0]
        sel = x[run.samples["phase"].to_numpy() == "load"]
        assert abs(row["mean"] - sel.mean()) < 1e-9 * abs(sel.mean()) + 1e-12
        assert abs(row["var"] - sel.var(ddof=1)) < 1e-9 * sel.var(ddof=1)
        ranges = range_read_memory(store, rid, float(run.samples["t"].iloc[-1]))
        store.close()
        con.close()
    med = {k: statistics.median(v) for k, v in res.items()}

    def line(what, ours_key, base_key, target, rate=False):
        o, b = med[ours_key], med[base_key]
        if rate:
            ov, bv = values / o, values / b
            ok = "PASS" if ov > target else "FAIL"
            print(f"{what:<34}{ov:>14,.0f} values/s {bv:>14,.0f} values/s {ov / bv:>8.1f}x   "
                  f"target > {target:,.0f}/s: {ok}")
        else:
            ok = "" if target is None else ("PASS" if o < target else "FAIL")
            tgt = "" if target is None else f"target < {target} s: {ok}"
            print(f"{what:<34}{o:>14.3f} s        {b:>14.3f} s        {b / o:>8.1f}x   {tgt}")

    print(f"\n{'':<34}{'ours':>16}{'':9}{'sqlite3 row/sample':>20}{'':3}{'speed-up':>9}")
    line("write (Store.save_run)", "save_run", "base_write", 500_000, rate=True)
    line("write (RunWriter, 10k appends)", "writer", "base_write", 500_000, rate=True)
    line("load whole run -> numpy", "load", "base_load", 0.5)
    line("load whole run -> pandas RunData", "load_pandas", "base_load", None)
    line("per-phase aggregates (SQL)", "agg", "base_agg", 0.5)
    print(f"\n{'range read (GET /runs/{id}/data)':<44}{'page by page':>22}{'whole run, then cut':>24}")
    for what, (ours, whole) in ranges.items():
        print(f"{what:<44}{ours[0] / 2**20:>9.1f} MiB {ours[1]:>7.3f} s {whole[0] / 2**20:>10.1f} MiB "
              f"{whole[1]:>7.3f} s")
    print("\nall timings [s]: " + ", ".join(f"{k}={['%.3f' % v for v in vs]}" for k, vs in res.items()))
    return 0


def range_read_memory(store: Store, rid: int, t_last: float
                      ) -> dict[str, tuple[tuple[int, float], tuple[int, float]]]:
    """Peak bytes allocated and seconds of a range read, page by page and by the whole run."""
    import tracemalloc

    def measured(fn) -> tuple[int, float]:
        dt = statistics.median(timed(fn)[0] for _ in range(3))   # tracemalloc slows, so apart
        tracemalloc.start()
        fn()
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        return peak, dt

    def paged(names, t0, t1, max_points):
        sel = store.select_range(rid, names, t0, t1, 1, max_points)
        for ch in sel.channels:
            for _ in store.range_values(sel, ch):
                pass

    def whole(names, t0, t1, max_points):
        a = store.load_arrays(rid, names)
        idx = np.flatnonzero((a["t"] >= t0) & (a["t"] <= t1))
        idx = idx[::max(1, -(-idx.size // max_points))]
        return {k: v[idx] for k, v in a.items()}

    cases = {"1 channel, 1 % of the run": (["t", "c05"], 0.5 * t_last, 0.51 * t_last, 100_000),
             "all channels, whole run, 10 000 points": (None, 0.0, t_last, 10_000)}
    return {what: (measured(lambda: paged(*c)), measured(lambda: whole(*c)))
            for what, c in cases.items()}


if __name__ == "__main__":
    sys.exit(main())
