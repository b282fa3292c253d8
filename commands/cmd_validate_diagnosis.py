"""`rig validate-diagnosis`: the gap diagnosis scored blind on emulated campaigns with withheld
effects (commands.diagnosis_harness, where its thresholds were tuned), and with `--independent`
on the independently written rig models it was never tuned on (commands.independent_harness),
the two tables side by side with the gap between them."""

from __future__ import annotations

import argparse

from commands.diagnosis_harness import format_report, format_tuning, tuning, validate


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quick", action="store_true",
                   help="fewer seeds and cells (a few minutes on 2 cores)")
    p.add_argument("--seeds", type=int, default=None, help="seeds per cell (default 3, quick 2)")
    p.add_argument("--first-seed", type=int, default=1,
                   help="the scoring campaigns use seeds FIRST.. (default 1; they must not "
                        "overlap the tuning seeds 101-112)")
    p.add_argument("--json", action="store_true", help="print the scores as JSON")
    p.add_argument("--no-emps", action="store_true", help="skip the EMPS records")
    p.add_argument("--independent", action="store_true",
                   help="also score on the independent validation rigs (validation_rigs/) and "
                        "print both tables side by side with the gap")
    p.add_argument("--rig", action="append", default=None, metavar="NAME",
                   help="with --independent: only this validation rig's variants (e.g. rig_d; "
                        "repeatable; default every rig)")
    p.add_argument("--workers", type=int, default=2,
                   help="processes for the independent campaigns (default 2)")
    p.add_argument("--tuning", action="store_true",
                   help="only the tuning campaigns (seeds 101-104) of the transmission law's "
                        "threshold: print what the diagnosis measures there")


def run(args: argparse.Namespace) -> int:
    import json

    from commands.progress import Counter
    if args.tuning:
        res = tuning()
        print(json.dumps(res, indent=2, default=float) if args.json else format_tuning(res))
        return 0
    variants = None
    if args.rig:
        from commands.independent_harness import VARIANTS
        known = sorted({v.rig for v in VARIANTS})
        bad = [r for r in args.rig if r not in known]
        if bad or not args.independent:
            import sys
            print(f"rig validate-diagnosis: error: --rig needs --independent and one of {known}"
                  + (f", not {bad}" if bad else ""), file=sys.stderr)
            return 2
        variants = tuple(v for v in VARIANTS if v.rig in args.rig)
    try:
        res = validate(quick=args.quick, seeds=args.seeds, emps=not args.no_emps,
                       first_seed=args.first_seed,
                       progress=Counter("diagnosis cells", "cell"))
    except ValueError as exc:
        import sys
        print(f"rig validate-diagnosis: {exc}", file=sys.stderr)
        return 2
    ind = None
    if args.independent:
        from commands.independent_harness import validate_independent
        ind = validate_independent(seeds=args.seeds or 1, first_seed=args.first_seed,
                                   quick=args.quick, workers=args.workers, variants=variants,
                                   progress=Counter("independent campaigns", "cell"))
    if args.json:
        print(json.dumps({**res, "independent": ind} if ind else res, indent=2, default=float))
    else:
        print(format_report(res))
        if ind:
            from commands.independent_harness import format_side_by_side
            print()
            print(format_side_by_side(res, ind))
    return 0

