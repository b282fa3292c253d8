"""`rig simulate`: run one scheme on the emulated joint and write the run in the interchange
format (core.runfile.write_run: <stem>.csv|.parquet + <stem>.json).

Examples:
  rig simulate scheme1 --speed 300 --direction -1 --out runs/s1_300_neg.csv
  rig simulate scheme3 --no-hysteresis --seed 7 --out runs/s3.parquet
  rig simulate scheme2 --effect stribeck --effect gear_ripple:A=800,order=36 --fail-motor 0@30
"""

from __future__ import annotations

import argparse

from core.effects import parse_effect as _parse_effect

_SCHEMES = {"scheme1": 1, "scheme2": 2, "scheme3": 3, "1": 1, "2": 2, "3": 3}


def parse_effect(text: str) -> tuple[str, dict[str, float]]:
    """--effect's argparse type: core.effects.parse_effect with argparse's error."""
    try:
        return _parse_effect(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def parse_failure(text: str) -> tuple[int, float]:
    """'K' or 'K@T' → (motor index 0..2, failure time [s])."""
    k, _, t = text.partition("@")
    try:
        return int(k), float(t) if t else 0.0
    except ValueError:
        raise argparse.ArgumentTypeError(f"--fail-motor wants K or K@SECONDS, got {text!r}")


def parse_param(text: str) -> tuple[str, float]:
    """'NAME=VALUE' for a core.params.JointParams field."""
    key, eq, value = text.partition("=")
    try:
        if not eq:
            raise ValueError
        return key.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--param wants NAME=NUMBER, got {text!r}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = __doc__.split("\n\n", 1)[1]
    parser.add_argument("scheme", choices=sorted(_SCHEMES, key=lambda s: (len(s), s)),
                        metavar="SCHEME", help="scheme1, scheme2 or scheme3 (or 1, 2, 3)")
    parser.add_argument("--speed", type=float, default=3000.0, metavar="RPM",
                        help="motor speed [r/min] for schemes 1 and 2 (paper: 300 or 3000; "
                             "default 3000)")
    parser.add_argument("--direction", type=int, choices=(1, -1), default=1,
                        help="sense of motion, +1 or -1 (default +1)")
    parser.add_argument("--effect", action="append", type=parse_effect, default=[],
                        metavar="NAME[:k=v,...]",
                        help="inject an effect of the vocabulary (`rig params` lists them), "
                             "repeatable; unnamed parameters take their defaults")
    parser.add_argument("--no-hysteresis", action="store_true",
                        help="purely elastic transmission (stiffness k) instead of Bouc–Wen")
    parser.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    parser.add_argument("--sample-rate", type=float, default=None, metavar="HZ",
                        help="sensor sample rate [Hz] (default: the scheme's, 10 Hz for "
                             "schemes 1-2, 1000 Hz for scheme 3)")
    parser.add_argument("--dropout", type=float, default=0.0, metavar="P",
                        help="probability of a missing sample per channel (default 0)")
    parser.add_argument("--fail-motor", action="append", type=parse_failure, default=[],
                        metavar="K[@T]", help="motor K (0-2) fails at T seconds (default 0)")
    parser.add_argument("--param", action="append", type=parse_param, default=[],
                        metavar="NAME=VALUE",
                        help="override a joint parameter of core.params (e.g. k=2e7)")
    parser.add_argument("--out", default=None, metavar="PATH",
                        help="output file (.csv or .parquet; a .json with the metadata is "
                             "written beside it). Default: scheme<N>_seed<S>.csv")
    parser.add_argument("--json", action="store_true",
                        help="print JSON (README, \"JSON output\") instead of the summary")


def run(args: argparse.Namespace) -> int:
    import dataclasses
    import math
    import sys
    from pathlib import Path

    import numpy as np

    from core.params import JointParams
    from core.runfile import write_run
    from core.schemes import make_scheme
    from simulators.config import EmulatorConfig
    from simulators.offline import simulate

    number = _SCHEMES[args.scheme]
    plan_kw = {"direction": args.direction}
    if number in (1, 2):
        plan_kw["motor_speed_rpm"] = args.speed
    params = JointParams()
    known = {f.name for f in dataclasses.fields(JointParams)}
    for key, value in args.param:
        if key not in known:
            print(f"rig simulate: unknown parameter {key!r}; `rig params` lists them",
                  file=sys.stderr)
            return 2
        params = params.replace(**{key: int(value) if key == "n" else value})
    try:
        plan = make_scheme(number, **plan_kw)
        config = EmulatorConfig(params=params, effects=dict(args.effect),
                                hysteresis=not args.no_hysteresis, seed=args.seed,
                                sample_rate_hz=args.sample_rate, dropout=args.dropout,
                                failed_motors=dict(args.fail_motor))
    except ValueError as exc:
        print(f"rig simulate: {exc}", file=sys.stderr)
        return 2
    run_data = simulate(plan, config)
    out = Path(args.out) if args.out else Path(f"scheme{number}_seed{args.seed}.csv")
    fmt = "parquet" if out.suffix == ".parquet" else "csv"
    paths = write_run(run_data, out, fmt=fmt)
    s = run_data.samples
    q = s["q"].to_numpy()
    torque = s["torque"].to_numpy()
    if args.json:
        import json
        from core.jsonsafe import json_safe
        print(json.dumps(json_safe({
            "scheme": number, "samples": len(s), "duration_s": float(s["t"].iloc[-1]),
            "sample_rate_hz": float(run_data.meta["sample_rate_hz"]),
            "travel_rad": float(np.nanmax(q) - np.nanmin(q)),
            "peak_torque_nm": float(np.nanmax(np.abs(torque))),
            "effects": list(config.effects), "hysteresis": bool(config.hysteresis),
            "seed": args.seed, "files": [str(p) for p in paths]}), allow_nan=False))
        return 0
    print(f"scheme {number}: {len(s)} samples over {s['t'].iloc[-1]:.1f} s at "
          f"{run_data.meta['sample_rate_hz']:g} Hz, travel {math.degrees(np.nanmax(q) - np.nanmin(q)):.1f}°, "
          f"peak torque {np.nanmax(np.abs(torque)) / 1e3:.1f} kN·m")
    if "excitation" in run_data.meta:
        ex = run_data.meta["excitation"]
        print(f"excitation: cond {ex['cond']:.0f} (random feasible median "
              f"{ex['random_cond_median']:.0f}, best {ex['random_cond_best']:.0f})")
    effects = ", ".join(config.effects) or "none"
    print(f"effects: {effects}; hysteresis {'on' if config.hysteresis else 'off'}; seed {args.seed}")
    for p in paths:
        print(f"wrote {p}")
    return 0
