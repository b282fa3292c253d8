"""Load benchmark of the REST service (issue 6): `rig serve` on loopback driven by `wrk`.

Builds a database holding one emulated scheme-1 run of 1 004 001 samples (300 r/min, 1 kHz,
slow ramp: 22 channels, real channel names, so acceptance and plots are the real ones) plus
--small-runs short runs, creates a viewer token, starts `rig serve` (no job workers) on a free
loopback port, then runs `wrk` (Debian package `wrk` 4.1, a real HTTP load generator in C) with
--clients connections for --duration seconds per scenario:

- runs      GET /runs                          (run listing, newest 100)
- aggregates GET /runs/{big}/aggregates        (per-phase statistics of the 1 M-sample run)
- report    GET /reports/runs/{big}            (JSON test report of the 1 M-sample run)
- page      GET /reports/runs/{big}/html       (HTML report page with its SVG plots)
- mixed     the four above in turn on every connection
- agg-nocache  the aggregates scenario against a second `rig serve` with its answer cache off
             (RIG_API_CACHE_MB=0, api/response_cache.py): every request runs the SQL query.
             This is the peer of "aggregates": the same endpoint without the cache, same run.

Per scenario it prints requests/s, p50 and p99 latency (wrk's recorded distribution; median
over --repeat repetitions), errors (non-2xx answers + socket errors and timeouts), and
PASS/FAIL on the targets: aggregates p99 < 1 s, zero errors everywhere. For reference, in the
same run: the store-level cost of one aggregates query (Store.phase_aggregates, in process) and
of one report (api.reports.run_report), and one unloaded HTTP request per endpoint, the first
(cold: nothing cached in the server) and the median of the next ones. There is no natural
outside peer for our own endpoints; the in-process figures are the baseline the HTTP figures
are compared with (ratio printed).

    python bench/bench_api_load.py                         # 60 s per scenario, 50 clients
    python bench/bench_api_load.py --duration 5 --scenarios aggregates   # quick
    python bench/bench_api_load.py --db postgresql+psycopg://user@127.0.0.1:5432/db

`rig serve` runs as one uvicorn process: on this 2-core machine, shared with wrk and other
work, two uvicorn processes (measured with `uvicorn --factory api.app:create_app --workers 2`)
gave no more throughput than one, and wrk itself needs CPU. Answers of finished runs come from
the service's in-process cache (api/response_cache.py); the cold figures below show the cost
of the first request, and "agg-nocache" the aggregates endpoint without the cache.

With --db the runs and token are added to that database (default: a temporary SQLite file).
Exit status 0 when every target passes, 1 otherwise, 2 when `wrk` is not installed.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine import describe  # bench/machine.py (run as python bench/NAME.py)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

AGG_P99_TARGET_S = 1.0
"""Issue 6: aggregates of a 1 000 000-sample run answer within 1 s at the 99th percentile."""

SCENARIOS = ("runs", "aggregates", "report", "page", "mixed", "agg-nocache")

WRK_INSTALL = ("`wrk` (a C HTTP load generator) is not installed. Install it with\n"
               "    sudo apt-get install wrk        # Debian/Ubuntu package wrk 4.1\n"
               "and run this benchmark again.")

# wrk's Lua hooks: the token header, the path(s) to cycle through, strict 2xx counting (wrk's
# own "Non-2xx or 3xx" count lets 3xx pass), and a machine-readable summary from done().
LUA = r"""
local paths = {PATHS}
local threads = {}
local counter = 0
function setup(thread)
  table.insert(threads, thread)
end
function init(args)
  bad = 0
  counter = 0
end
request = function()
  counter = counter + 1
  return wrk.format("GET", paths[(counter - 1) % #paths + 1],
                    {["Authorization"] = "Bearer TOKEN"})
end
function response(status, headers, body)
  if status < 200 or status > 299 then bad = bad + 1 end
end
function done(summary, latency, requests)
  local bad_total = 0
  for _, t in ipairs(threads) do bad_total = bad_total + t:get("bad") end
  local e = summary.errors
  io.write(string.format(
    "BENCH requests=%d duration_us=%d bytes=%d p50_us=%d p90_us=%d p99_us=%d max_us=%d " ..
    "non2xx=%d connect=%d read=%d write=%d timeout=%d\n",
    summary.requests, summary.duration, summary.bytes, latency:percentile(50),
    latency:percentile(90), latency:percentile(99), latency.max, bad_total,
    e.connect, e.read, e.write, e.timeout))
end
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def build_database(url: str, small_runs: int) -> tuple[int, int, str]:
    """Store the 1 M-sample emulated run and `small_runs` short ones; return (big run id,
    its samples, a viewer token)."""
    from db.store import Store
    from db.tokens import create_token
    from core.schemes import Scheme1
    from simulators.config import EmulatorConfig
    from simulators.offline import simulate

    t0 = time.perf_counter()
    big = simulate(Scheme1(motor_speed_rpm=300, direction=1, ramp_rate=240.0),
                   EmulatorConfig(seed=1, sample_rate_hz=1000.0), started_at="2026-03-01T08:00:00Z")
    t_sim = time.perf_counter() - t0
    small = simulate(Scheme1(motor_speed_rpm=3000, direction=-1), EmulatorConfig(seed=2),
                     started_at="2026-03-02T08:00:00Z")
    with Store(url) as store:
        t0 = time.perf_counter()
        rid = store.save_run(big, exit_status="success")
        t_save = time.perf_counter() - t0
        for _ in range(small_runs):
            store.save_run(small, exit_status="success")
        token = create_token(store, "bench-api-load", ["viewer"])
    print(f"database: run {rid} of {len(big.samples):,} samples × {big.samples.shape[1]} "
          f"channels (emulated in {t_sim:.1f} s, stored in {t_save:.1f} s) + {small_runs} runs of "
          f"{len(small.samples):,} samples")
    return rid, len(big.samples), token


def in_process_reference(url: str, run_id: int, n: int) -> dict[str, float]:
    """Median seconds of Store.phase_aggregates and of api.reports.run_report (JSON) in this
    process (no HTTP), over `n` calls."""
    from api.reports import run_report
    from db.store import Store

    with Store(url) as store:
        store.phase_aggregates(run_id)
        agg = [_timed(lambda: store.phase_aggregates(run_id)) for _ in range(n)]
        rep = [_timed(lambda: run_report(store, run_id, with_plots=False)) for _ in range(max(1, n // 4))]
    return {"aggregates": statistics.median(agg), "report": statistics.median(rep)}


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


class Server:
    """`rig serve` in its own process on 127.0.0.1:`port` (output to `log`)."""

    def __init__(self, url: str, port: int, log: Path, cache: bool = True):
        env = {**os.environ, "RIG_DB_URL": url}
        if not cache:
            env["RIG_API_CACHE_MB"] = "0"        # api/response_cache.py off: every answer computed
        cmd = [sys.executable, "-m", "commands.cli", "serve", "--host", "127.0.0.1",
               "--port", str(port), "--workers", "0"]
        self.cmd, self.log = cmd, log
        self.base = f"http://127.0.0.1:{port}"
        self._out = open(log, "w")
        self.proc = subprocess.Popen(cmd, env=env, cwd=ROOT, stdout=self._out,
                                     stderr=subprocess.STDOUT)

    def wait_ready(self, token: str, timeout_s: float = 120.0) -> None:
        import httpx
        deadline = time.monotonic() + timeout_s
        while True:
            if self.proc.poll() is not None:
                raise RuntimeError(f"rig serve exited ({self.proc.returncode}):\n"
                                   + self.log.read_text())
            try:
                r = httpx.get(f"{self.base}/runs?limit=1",
                              headers={"Authorization": f"Bearer {token}"}, timeout=5)
                if r.status_code == 200:
                    return
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline:
                raise RuntimeError("rig serve did not answer in time:\n" + self.log.read_text())
            time.sleep(0.2)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._out.close()


def unloaded(base: str, token: str, paths: dict[str, str], n: int) -> dict[str, tuple[float, float]]:
    """Per endpoint: (first request [s], median of the next `n` [s]), one at a time."""
    import httpx
    out = {}
    with httpx.Client(base_url=base, headers={"Authorization": f"Bearer {token}"},
                      timeout=120) as c:
        for name, path in paths.items():
            times = []
            for _ in range(n + 1):
                t0 = time.perf_counter()
                r = c.get(path)
                times.append(time.perf_counter() - t0)
                if r.status_code != 200:
                    raise RuntimeError(f"GET {path}: {r.status_code} {r.text[:300]}")
            out[name] = (times[0], statistics.median(times[1:]))
    return out


def drain(base: str, token: str, timeout_s: float = 120.0) -> None:
    """Wait until the server answers a small request quickly again: requests wrk left in
    flight when it stopped must not load the next scenario."""
    import httpx
    deadline = time.monotonic() + timeout_s
    with httpx.Client(base_url=base, headers={"Authorization": f"Bearer {token}"},
                      timeout=timeout_s) as c:
        while time.monotonic() < deadline:
            t0 = time.perf_counter()
            c.get("/runs?limit=1")
            if time.perf_counter() - t0 < 0.05:
                return
            time.sleep(0.5)


def run_wrk(base: str, token: str, paths: list[str], clients: int, threads: int,
            duration_s: int, timeout_s: int, tmp: Path) -> dict[str, float]:
    """One wrk run; its done() summary as numbers (latencies in s)."""
    script = tmp / "bench.lua"
    lua_paths = "{" + ", ".join(f'"{p}"' for p in paths) + "}"
    script.write_text(LUA.replace("{PATHS}", lua_paths).replace("TOKEN", token))
    cmd = ["wrk", f"-t{threads}", f"-c{clients}", f"-d{duration_s}s", f"--timeout={timeout_s}s",
           "--latency", "-s", str(script), base + paths[0]]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=duration_s + timeout_s + 120)
    line = next((ln for ln in res.stdout.splitlines() if ln.startswith("BENCH ")), None)
    if res.returncode != 0 or line is None:
        raise RuntimeError(f"wrk failed ({res.returncode}):\n{res.stdout}\n{res.stderr}")
    v = {k: float(x) for k, x in (kv.split("=") for kv in line.split()[1:])}
    secs = v["duration_us"] / 1e6
    return {"rps": v["requests"] / secs, "requests": v["requests"], "mb_s": v["bytes"] / secs / 1e6,
            "p50": v["p50_us"] / 1e6, "p90": v["p90_us"] / 1e6, "p99": v["p99_us"] / 1e6,
            "max": v["max_us"] / 1e6, "non2xx": v["non2xx"],
            "socket": v["connect"] + v["read"] + v["write"] + v["timeout"]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=int, default=60, help="seconds per scenario (default 60)")
    ap.add_argument("--clients", type=int, default=50, help="concurrent connections (default 50)")
    ap.add_argument("--db", help="database URL (default: a temporary SQLite file)")
    ap.add_argument("--scenarios", default=",".join(SCENARIOS),
                    help=f"comma-separated subset of {','.join(SCENARIOS)}")
    ap.add_argument("--repeat", type=int, default=1, help="repetitions per scenario (median)")
    ap.add_argument("--threads", type=int, default=2, help="wrk threads (default 2)")
    ap.add_argument("--small-runs", type=int, default=30, help="short runs besides the big one")
    ap.add_argument("--timeout", type=int, default=30,
                    help="wrk per-request timeout [s] (a slower answer counts as an error)")
    args = ap.parse_args()
    scenarios = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    unknown = set(scenarios) - set(SCENARIOS)
    if unknown:
        ap.error(f"unknown scenario(s) {sorted(unknown)}; choose from {SCENARIOS}")
    if shutil.which("wrk") is None:
        print(WRK_INSTALL, file=sys.stderr)
        return 2
    wrk_version = subprocess.run(["wrk", "--version"], capture_output=True, text=True).stdout
    wrk_version = (wrk_version.splitlines() or ["wrk ?"])[0].split(" Copyright")[0]
    print(f"machine: {describe(wrk_version)}")

    with tempfile.TemporaryDirectory(prefix="bench-api-") as tmpdir:
        tmp = Path(tmpdir)
        url = args.db or f"sqlite:///{tmp / 'rig.sqlite'}"
        rid, n_samples, token = build_database(url, args.small_runs)
        paths = {"runs": "/runs", "aggregates": f"/runs/{rid}/aggregates",
                 "report": f"/reports/runs/{rid}", "page": f"/reports/runs/{rid}/html"}
        ref = in_process_reference(url, rid, 20)

        results: dict[str, list[dict[str, float]]] = {}
        single: dict[str, tuple[float, float]] = {}
        groups = [(True, [sc for sc in scenarios if sc != "agg-nocache"]),
                  (False, [sc for sc in scenarios if sc == "agg-nocache"])]
        for cache, group in groups:
            if not group:
                continue
            server = Server(url, free_port(), tmp / f"serve-{cache}.log", cache)
            try:
                server.wait_ready(token)
                if cache:
                    single = unloaded(server.base, token, paths, 10)
                print(f"server: {' '.join(server.cmd[1:])} (one uvicorn "
                      f"process, no job workers, answer cache {'on' if cache else 'OFF'}), "
                      f"database {url.split('://')[0]}")
                print(f"wrk: {args.threads} threads, {args.clients} connections, {args.duration} s "
                      f"per scenario, timeout {args.timeout} s, {args.repeat} repetition(s)")
                for rep in range(args.repeat):
                    for sc in group:
                        want = (list(paths.values()) if sc == "mixed" else
                                [paths["aggregates"] if sc == "agg-nocache" else paths[sc]])
                        r = run_wrk(server.base, token, want, args.clients, args.threads,
                                    args.duration, args.timeout, tmp)
                        results.setdefault(sc, []).append(r)
                        print(f"  [{rep + 1}/{args.repeat}] {sc:<11} {r['rps']:9.1f} req/s  "
                              f"p50 {r['p50'] * 1e3:8.1f} ms  p99 {r['p99'] * 1e3:8.1f} ms  "
                              f"errors {int(r['non2xx'] + r['socket'])}  "
                              f"load average {os.getloadavg()[0]:.1f}", flush=True)
                        drain(server.base, token)
            finally:
                server.stop()

    print(f"\nin process (no HTTP), median: Store.phase_aggregates {ref['aggregates'] * 1e3:.1f} ms, "
          f"run_report (JSON) {ref['report'] * 1e3:.1f} ms")
    print("one request at a time over HTTP: first (cold) / median of the next 10")
    for name, (first, med) in single.items():
        print(f"  {name:<10} {first * 1e3:9.1f} ms / {med * 1e3:7.1f} ms")

    ok_all = True
    print(f"\n{args.clients} concurrent clients, {args.duration} s, median of {args.repeat}:")
    print(f"{'scenario':<11}{'req/s':>9}{'MB/s':>8}{'p50 ms':>10}{'p99 ms':>10}{'max ms':>10}"
          f"{'requests':>10}{'errors':>8}  verdict")
    for sc in scenarios:
        rs = results[sc]
        m = {k: statistics.median(r[k] for r in rs) for k in rs[0]}
        errors = int(sum(r["non2xx"] + r["socket"] for r in rs))
        none_done = any(r["requests"] == 0 for r in rs)
        verdict = []
        if errors or none_done:
            verdict.append(f"FAIL ({errors} errors" + (", a repetition completed no request)"
                                                       if none_done else ")"))
        else:
            verdict.append("PASS 0 errors")
        if sc in ("aggregates", "agg-nocache"):
            verdict.append(("PASS" if m["p99"] < AGG_P99_TARGET_S else "FAIL")
                           + f" p99 < {AGG_P99_TARGET_S:g} s")
        ok_all &= not errors and not none_done and not (
            sc == "aggregates" and m["p99"] >= AGG_P99_TARGET_S)
        print(f"{sc:<11}{m['rps']:9.1f}{m['mb_s']:8.1f}{m['p50'] * 1e3:10.1f}{m['p99'] * 1e3:10.1f}"
              f"{m['max'] * 1e3:10.1f}{int(m['requests']):10d}{errors:8d}  {', '.join(verdict)}")
    if "aggregates" in results and "agg-nocache" in results:
        c = {k: statistics.median(r[k] for r in results["aggregates"]) for k in ("rps", "p99")}
        u = {k: statistics.median(r[k] for r in results["agg-nocache"]) for k in ("rps", "p99")}
        print(f"aggregates, answer cache on vs off (peer): {c['rps'] / u['rps']:.1f}x the "
              f"throughput, p99 {u['p99'] / c['p99']:.1f}x lower")
    print(f"\n{'ALL PASS' if ok_all else 'SOME TARGET FAILED'} (big run: {n_samples:,} samples); "
          f"load average at the end {os.getloadavg()[0]:.1f}")
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())
