"""Validation benchmark of the sim-to-real gap diagnosis: `python bench/bench_diagnosis.py
[--quick] [--seeds N] [--no-emps] [--no-independent] [--no-1khz]`.

Prints, besides the own-emulator figures below: the same diagnosis scored blind on the
independently written validation rigs (commands.independent_harness; never tuned on), both
tables side by side with the gap, every figure against its target; and the wall time and peak
memory of one 12-run campaign sampled at 1 kHz (≈1.3 M samples) diagnosed in a process of its own.

Generates emulator campaigns with effects injected but withheld from the model
(commands.diagnosis_harness), runs estimator.diagnosis blind on each, and prints the confusion
matrix, the issue's figures against their targets, the EMPS result, the machine, and the median
wall time of one diagnosis. There is no open peer tool that diagnoses a joint's sim-to-real gap;
the reference printed next to ours is the naive rule "blame the candidate with the best held-out
RMSE" (no significance test, no verdict `none`/`unexplained`), scored on the same cells.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def machine() -> str:
    cpu = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


def main(argv: list[str] | None = None) -> int:
    import numpy as np
    from commands.diagnosis_harness import format_report, validate
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--seeds", type=int, default=None)
    ap.add_argument("--no-emps", action="store_true")
    ap.add_argument("--first-seed", type=int, default=1,
                    help="first scoring seed (the tuning seeds 101-112 are refused)")
    ap.add_argument("--no-independent", action="store_true")
    ap.add_argument("--no-1khz", action="store_true")
    ap.add_argument("--campaign-1khz", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.campaign_1khz:
        return campaign_1khz()
    t0 = time.perf_counter()
    res = validate(quick=a.quick, seeds=a.seeds, emps=not a.no_emps, first_seed=a.first_seed)
    print(f"machine: {machine()}")
    print(format_report(res))
    cells = res["cells"]
    secs = [c["seconds"] for c in cells]
    print(f"\nmedian wall time of one diagnosis (8 runs, ~19k samples): {np.median(secs):.2f} s "
          f"over {len(secs)} cells; whole harness {time.perf_counter() - t0:.0f} s")
    single = [c for c in cells if c["kind"] == "single"]
    for enr in sorted({c["enr"] for c in single}):
        cs = [c for c in single if c["enr"] == enr]
        ours = np.mean([(c["effects"][:1] == c["truth"]) and c["status"] == "explained" for c in cs])
        naive = np.mean([c["top"] == c["truth"][0] for c in cs])
        print(f"top-1 at ENR {enr}: ours {ours:.3f}, naive best-RMSE rule {naive:.3f}, "
              f"ratio {ours / naive if naive else float('nan'):.2f}")
    none = [c for c in cells if c["kind"] == "none"]
    print(f"false alarms with nothing injected: ours {np.mean([bool(c['effects']) for c in none]):.3f},"
          f" naive rule 1.000 (it always names one)")
    if not a.no_independent:
        from commands.independent_harness import format_side_by_side, validate_independent
        ind = validate_independent(seeds=a.seeds or 1, first_seed=a.first_seed, quick=a.quick)
        print()
        print(format_side_by_side(res, ind))
    if not a.no_1khz:
        import subprocess
        out = subprocess.run([sys.executable, __file__, "--campaign-1khz"], capture_output=True,
                             text=True, check=True).stdout
        print()
        print(out.strip())
    return 0


def campaign_1khz() -> int:
    """One 12-run campaign of the emulator sampled at 1 kHz (stribeck withheld), diagnosed in
    this process; prints samples, wall time and this process's peak memory against the
    targets (30 s, 2 GB)."""
    import resource
    from core.schemes import Scheme1, Scheme2, Scheme3
    from estimator.diagnosis import diagnose
    from simulators.config import EmulatorConfig
    from simulators.offline import simulate
    plans = [(Scheme1(motor_speed_rpm=300), True), (Scheme1(motor_speed_rpm=3000, direction=-1), True),
             (Scheme2(motor_speed_rpm=3000), True), (Scheme3(direction=-1, n_periods=6), True),
             (Scheme1(motor_speed_rpm=300, direction=-1), True),
             (Scheme2(motor_speed_rpm=300), True), (Scheme1(motor_speed_rpm=3000), True),
             (Scheme3(direction=1, n_periods=6), True),
             (Scheme1(motor_speed_rpm=300, direction=-1), False),
             (Scheme1(motor_speed_rpm=3000), False),
             (Scheme2(motor_speed_rpm=300, direction=-1), False),
             (Scheme3(direction=-1, n_periods=6), False)]
    train, test = [], []
    for i, (scheme, is_train) in enumerate(plans):
        run = simulate(scheme, EmulatorConfig(seed=900 + i, sample_rate_hz=1000.0,
                                              effects={"stribeck": {}},
                                              temp_joint_init=15.0 + 4.0 * i))
        (train if is_train else test).append(run)
    n = sum(len(r) for r in train + test)
    t0 = time.perf_counter()
    rep = diagnose(train, test, "eq4")
    secs = time.perf_counter() - t0
    peak_gb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20
    print(f"12-run campaign at 1 kHz, {n} samples (stribeck withheld): diagnosed in {secs:.1f} s "
          f"(target < 30 s), peak memory of the process {peak_gb:.2f} GB (target < 2 GB); "
          f"verdict: {rep['verdict']['summary']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
