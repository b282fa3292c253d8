"""Benchmark: the emulator's numba kernel vs the same model as a plain-Python loop.

Simulates a scheme-1 run (3000 r/min, load to 120 kN·m and back: 104 s of rig time, 104 001
internal steps at 1 kHz) with EVERY effect of the vocabulary switched on, and prints the kernel's
simulation rate in steps/s (median of several repeats; compile / cache-load time reported
separately), the plain-Python loop of the same code (simulators.reference) measured in the same
run, their ratio and the machine. Rates are given per wall-clock second and per CPU second of the
process (the latter is what a shared machine's other load does not change). Target:
>= 5 000 000 steps/s on one core.

Run: python bench/bench_emulator.py [--repeats N] [--python-repeats M]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import numpy as np

from machine import cpu_model  # bench/machine.py (run as python bench/NAME.py)

TARGET = 5_000_000


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=9, help="kernel repeats (median reported)")
    ap.add_argument("--python-repeats", type=int, default=3,
                    help="plain-Python repeats (median reported)")
    args = ap.parse_args()

    import numba

    from core.effects import VOCABULARY
    from core.schemes import Scheme1
    from simulators import kernel as K
    from simulators import reference as R
    from simulators.config import EmulatorConfig
    from simulators.model import setup
    from simulators.offline import profiles, sample_steps, simulate

    config = EmulatorConfig(effects={name: {} for name in VOCABULARY}, seed=1)
    plan = Scheme1(motor_speed_rpm=3000.0)
    prof = profiles(plan, config.dt, config.params.cyl_area)
    n_steps = len(prof["t"])
    steps = sample_steps((n_steps - 1) * config.dt, config.dt, plan.sample_rate_hz)

    cpu_times: dict = {}

    def run_once(fn) -> float:
        """Wall-clock seconds of one run; its process CPU seconds go to cpu_times[fn]."""
        ks = setup(config, np.random.Generator(np.random.PCG64(config.seed)))
        rec = np.zeros((len(steps), K.N_R))
        c0 = time.process_time()
        t0 = time.perf_counter()
        n = fn(ks.state, ks.pf, ks.n_bw, ks.ring, prof["w_set"], prof["pos_ref"],
               prof["pos_on"], prof["tau_cmd"], prof["p_set"], prof["pump"], ks.enabled,
               ks.fail_step, ks.tau_lim, steps, rec, 0, n_steps)
        elapsed = time.perf_counter() - t0
        cpu_times.setdefault(fn, []).append(time.process_time() - c0)
        assert n == len(steps)
        return elapsed

    print(f"machine: {cpu_model()}, {os.cpu_count()} logical cores, {platform.system()} "
          f"{platform.release()}; Python {platform.python_version()}, numba {numba.__version__}, "
          f"numpy {np.__version__}")
    print(f"run: scheme 1 at 3000 r/min, {plan.duration():.0f} s of rig time = {n_steps} steps "
          f"at dt = {config.dt * 1e3:g} ms, effects: {', '.join(config.effects)} (hysteresis on)")

    t_first = run_once(K.advance)
    fresh = numba.njit(cache=False)(K.advance.py_func)
    t0 = time.perf_counter()
    fresh.compile(K.advance.signatures[0])
    t_compile = time.perf_counter() - t0
    print(f"numba: first call {t_first:.2f} s (loads the on-disk cache when present), "
          f"fresh compile without cache {t_compile:.2f} s — both excluded from the rates")

    cpu_times.clear()
    times = [run_once(K.advance) for _ in range(args.repeats)]
    med = statistics.median(times)
    rate = n_steps / med
    cpu_rate = n_steps / statistics.median(cpu_times[K.advance])
    print(f"numba kernel : median {med * 1e3:8.2f} ms over {args.repeats} repeats "
          f"(min {min(times) * 1e3:.2f}, max {max(times) * 1e3:.2f}) -> {rate:,.0f} steps/s "
          f"= {rate * config.dt:,.0f}x real time; per CPU second {cpu_rate:,.0f} steps/s")

    py_times = [run_once(R.advance) for _ in range(args.python_repeats)]
    py_med = statistics.median(py_times)
    py_rate = n_steps / py_med
    py_cpu_rate = n_steps / statistics.median(cpu_times[R.advance])
    print(f"plain Python : median {py_med:8.2f} s  over {args.python_repeats} repeats "
          f"-> {py_rate:,.0f} steps/s; per CPU second {py_cpu_rate:,.0f} steps/s")
    print(f"ratio        : numba / plain Python = {rate / py_rate:,.0f}x wall clock, "
          f"{cpu_rate / py_cpu_rate:,.0f}x CPU time")

    sims = []
    for _ in range(3):
        t0 = time.perf_counter()
        simulate(plan, config)
        sims.append(time.perf_counter() - t0)
    print(f"whole simulate() incl. profiles, sensors and DataFrame: median "
          f"{statistics.median(sims) * 1e3:.1f} ms")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    verdict = "meets" if rate >= TARGET else "MISSES"
    print(f"target {TARGET:,} steps/s on one core (wall-clock median): {verdict} "
          f"({rate / TARGET:.2f}x target); load average during the run {load:.1f} on "
          f"{os.cpu_count()} cores — CPU-time rates are the ones other processes do not bend")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
