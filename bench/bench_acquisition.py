"""Acquisition benchmark: the DAQ (daq.rig.Rig) against `rig emulate` over loopback.

    python bench/bench_acquisition.py                      # 10 min of rig time at time scale 1
    python bench/bench_acquisition.py --rig-seconds 30     # a short run while developing

What it does, in one run:
1. starts the stand-in (`python -m simulators.standin`, the physics emulator behind the PLC and
   the three CiA 402 drives) on free loopback ports;
2. acquires for --rig-seconds of rig time with the PLC status block polled at --poll-hz and the
   three drives' fast TPDOs at 1 kHz (rig time) each, the motors turning;
3. checks: zero failed polls, no PLC snapshot recorded twice (repeats are counted and dropped),
   strictly increasing PLC time stamps; per drive zero lost and zero duplicated TPDO samples,
   drive time stamps exactly one period apart (strictly increasing), non-decreasing receive
   time stamps;
4. measures, alternating in the same run against the same stand-in, the status-block
   round-trip rate of our PlcClient.read_status (request + decode + scale) and of the raw
   pymodbus AsyncModbusTcpClient.read_holding_registers (the peer): short windows alternate
   so both see the same load, medians over --reps windows each;
5. prints achieved rates (wall and rig time), poll latency p50/p99, both round-trip rates and
   their ratio, and the machine. Exit code 1 if a check fails.

With --time-scale > 1 the stand-in runs faster than wall time: TPDO rates are then 1 kHz of
rig time (scale × 1 kHz of wall time), while the PLC poll rate stays in wall time; both are
printed.
"""

from __future__ import annotations

import argparse
import asyncio
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from machine import describe  # noqa: E402  (bench/machine.py: run as python bench/NAME.py)
from daq.plc import PlcClient  # noqa: E402
from daq.rig import Rig  # noqa: E402
from daq.settings import Settings  # noqa: E402


def machine() -> str:
    import pymodbus
    return describe(f"pymodbus {pymodbus.__version__}")


def start_standin(time_scale: float) -> tuple[subprocess.Popen, int, int]:
    proc = subprocess.Popen([sys.executable, "-m", "simulators.standin", "--plc-port", "0",
                             "--can-port", "0", "--time-scale", str(time_scale)],
                            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    plc = can = None
    assert proc.stdout is not None
    for line in proc.stdout:
        if m := re.search(r"PLC .* on [\d.]+:(\d+)", line):
            plc = int(m.group(1))
        if m := re.search(r"CAN .* on [\d.]+:(\d+)", line):
            can = int(m.group(1))
        if "time scale" in line:
            break
    if plc is None or can is None:
        proc.kill()
        raise RuntimeError("stand-in did not start")
    return proc, plc, can


def pct(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))]


async def acquire(s: Settings, rig_seconds: float, time_scale: float) -> dict:
    rig = Rig(s)
    async with rig.session():
        await rig.set_motor_speed(150.0)
        t_rig0 = rig.plc["rig_time"][-1] if len(rig.plc) else 0.0
        wall0 = time.monotonic()
        n0 = len(rig.plc)
        while True:
            await asyncio.sleep(0.5)
            if len(rig.plc) and rig.plc["rig_time"][-1] - t_rig0 >= rig_seconds:
                break
            if time.monotonic() - wall0 > 3 * rig_seconds / time_scale + 30:
                break
        wall = time.monotonic() - wall0
        rig_time = rig.plc["rig_time"][-1] - t_rig0
        await rig.set_motor_speed(0.0)
    out = {"wall": wall, "rig_time": rig_time, "rig": rig, "plc_new": len(rig.plc) - n0}
    return out


def check(rig: Rig) -> tuple[list[str], dict]:
    fails, stats = [], {}
    rig_time = list(rig.plc["rig_time"])
    t_rx = list(rig.plc["t_rx"])
    if rig.poll_errors:
        fails.append(f"{rig.poll_errors} failed PLC polls")
    if any(b <= a for a, b in zip(rig_time, rig_time[1:])):
        fails.append("PLC time stamps not strictly increasing")
    if any(b < a for a, b in zip(t_rx, t_rx[1:])):
        fails.append("PLC receive times not monotonic")
    stats["plc"] = {"samples": len(rig_time), "repeats": rig.repeats, "overruns": rig.overruns,
                    "errors": rig.poll_errors}
    for d in rig.drives.drives:
        st = d.stream
        n, t = list(st.stamp), list(st.t)
        p = st.period_ms
        consecutive = len(n) > 1 and all(b - a == p for a, b in zip(n, n[1:]))
        if st.lost or st.duplicated or st.irregular or not consecutive:
            fails.append(f"drive {d.node_id}: lost {st.lost}, duplicated {st.duplicated}, "
                         f"irregular {st.irregular}, consecutive stamps {consecutive}")
        if any(b < a for a, b in zip(t, t[1:])):
            fails.append(f"drive {d.node_id}: receive time stamps not monotonic")
        if not d.active:
            fails.append(f"drive {d.node_id} dropped: {d.dropped_reason}")
        stats[f"drive{d.node_id}"] = {"samples": len(n), "lost": st.lost,
                                       "duplicated": st.duplicated,
                                       "wall_s": (t[-1] - t[0]) if len(t) > 1 else 0.0,
                                       "rig_s": (n[-1] - n[0]) * 1e-3 if n else 0.0}
    if rig.trips:
        fails.append(f"trips during the run: {[t.message for t in rig.trips]}")
    return fails, stats


async def round_trips(port: int, seconds: float, reps: int) -> tuple[list[float], list[float]]:
    """Alternating tight loops reading the status block: our PlcClient vs raw pymodbus."""
    from pymodbus.client import AsyncModbusTcpClient
    s = Settings(plc_port=port)
    ours = PlcClient(s)
    await ours.connect()
    count = ours.map.status.count
    raw = AsyncModbusTcpClient("127.0.0.1", port=port, timeout=s.plc_timeout,
                               retries=s.plc_retries, reconnect_delay_max=1.0)
    await raw.connect()
    r_ours, r_raw = [], []
    try:
        for _ in range(reps):
            n, t0 = 0, time.perf_counter()
            while time.perf_counter() - t0 < seconds:
                await ours.read_status()
                n += 1
            r_ours.append(n / (time.perf_counter() - t0))
            n, t0 = 0, time.perf_counter()
            while time.perf_counter() - t0 < seconds:
                rr = await raw.read_holding_registers(0, count=count, device_id=1)
                assert not rr.isError()
                n += 1
            r_raw.append(n / (time.perf_counter() - t0))
    finally:
        ours.close()
        raw.close()
    return r_ours, r_raw


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rig-seconds", type=float, default=600.0,
                    help="rig time to acquire [s] (default 600 = 10 min)")
    ap.add_argument("--time-scale", type=float, default=1.0,
                    help="stand-in rig seconds per wall second (default 1)")
    ap.add_argument("--poll-hz", type=float, default=150.0, help="PLC poll rate [Hz] (≥ 100)")
    ap.add_argument("--peer-seconds", type=float, default=0.25,
                    help="length of each round-trip window [s]; ours and the peer alternate "
                         "window by window so both see the same machine load")
    ap.add_argument("--reps", type=int, default=40, help="round-trip windows each (medians)")
    a = ap.parse_args(argv)

    print(f"machine: {machine()}")
    proc, plc_port, can_port = start_standin(a.time_scale)
    try:
        s = Settings(plc_port=plc_port, can_port=can_port, plc_poll_hz=a.poll_hz,
                     tpdo_rate_hz=1000.0)
        res = asyncio.run(acquire(s, a.rig_seconds, a.time_scale))
        rig = res["rig"]
        fails, stats = check(rig)
        r_ours, r_raw = asyncio.run(round_trips(plc_port, a.peer_seconds, a.reps))
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()

    wall, rig_time = res["wall"], res["rig_time"]
    lat = [x * 1e3 for x in rig.plc["latency"]]
    t_rx = list(rig.plc["t_rx"])
    plc_wall_rate = (len(t_rx) - 1) / (t_rx[-1] - t_rx[0])
    print(f"acquired {rig_time:.1f} s of rig time in {wall:.1f} s wall "
          f"(time scale {a.time_scale:g})")
    print(f"PLC status block: {stats['plc']['samples']} samples, {plc_wall_rate:.1f} Hz wall "
          f"({plc_wall_rate * wall / max(rig_time, 1e-9):.1f} Hz of rig time), "
          f"repeats dropped {rig.repeats}, failed polls {rig.poll_errors}, overruns {rig.overruns}")
    print(f"poll latency: p50 {statistics.median(lat):.3f} ms, p99 {pct(lat, 0.99):.3f} ms, "
          f"max {max(lat):.3f} ms")
    for d in rig.drives.drives:
        st = stats[f"drive{d.node_id}"]
        wall_rate = (st["samples"] - 1) / st["wall_s"] if st["wall_s"] else 0.0
        rig_rate = (st["samples"] - 1) / st["rig_s"] if st["rig_s"] else 0.0
        print(f"drive {d.node_id} fast TPDO: {st['samples']} samples, {rig_rate:.1f} Hz of rig "
              f"time (drive time stamps), {wall_rate:.1f} Hz wall, lost {st['lost']}, "
              f"duplicated {st['duplicated']}")
    mo, mr = statistics.median(r_ours), statistics.median(r_raw)
    print(f"status-block round trips ({rig.plc_client.map.status.count} registers), medians of "
          f"{a.reps} × {a.peer_seconds:g} s: ours (PlcClient.read_status) {mo:.0f}/s, "
          f"peer (raw pymodbus read_holding_registers) {mr:.0f}/s, ratio ours/peer {mo / mr:.3f}")
    if plc_wall_rate < 100.0:
        fails.append(f"PLC poll rate {plc_wall_rate:.1f} Hz < 100 Hz")
    for f in fails:
        print(f"FAIL: {f}")
    print("checks: " + ("all passed" if not fails else f"{len(fails)} failed"))
    return 1 if fails else 0


if __name__ == "__main__":
    raise SystemExit(main())
