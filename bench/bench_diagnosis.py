"""Validation benchmark of the sim-to-real gap diagnosis (issue 7): `python bench/bench_diagnosis.py
[--quick] [--seeds N] [--no-emps]`.

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
    a = ap.parse_args(argv)
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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
