"""`rig diagnose --train RUN... --test RUN... [--model eq4] [--json]`: the sim-to-real gap
diagnosis of issue 7 (estimator.diagnosis) on run files or stored runs.

RUN is a run file (<stem>.csv/.parquet with <stem>.json beside it, or an EMPS .mat record) or the
integer id of a run in the database (db.store.Store). --rename maps other rigs' channel names onto
the joint's (e.g. EMPS: qm=q,force=torque, with --model emps). --json prints the report object
(baseline, regions, candidates, verdict, tests, shrinkage, ...); without it, a text summary.

While the diagnosis works, stderr shows its stage with a count (commands.progress.StageBar:
`output law: candidates 4/9`, `output law: greedy round 2`, `twist–torque law: candidates
1/2`): one bar on a terminal, plain lines every few seconds otherwise; stdout keeps the
report alone."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--train", nargs="+", required=True, metavar="RUN",
                   help="training runs: run files or stored run ids")
    p.add_argument("--test", nargs="+", required=True, metavar="RUN",
                   help="held-out runs: run files or stored run ids")
    p.add_argument("--model", default="eq4",
                   help="nominal model: eq4 (default), eq5, eq11 (estimator.models specs, "
                        "e.g. eq4+stribeck) or emps")
    p.add_argument("--transmission", default="auto",
                   help="twist–torque law diagnosed beside the torque balance when every run has "
                        "twist and torque channels: auto (Eq. 11, Bouc–Wen shape fitted on the "
                        "training runs; default), eq5 (elastic), or none")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--rename", default=None, metavar="OLD=NEW,...",
                   help="rename channels before the diagnosis (e.g. qm=q,force=torque)")
    p.add_argument("--cutoff", type=float, default=None, metavar="HZ",
                   help="zero-phase low-pass of the kinematic channels [Hz]")
    p.add_argument("--decimate", type=int, default=1, help="keep every k-th sample (1)")
    p.add_argument("--effects", default=None, metavar="NAME,...",
                   help="candidate effects to try (default: the whole vocabulary)")
    p.add_argument("--db", default=None, metavar="URL", help="database URL for run ids")


def load(spec: str, db_url: str | None = None, rename: dict[str, str] | None = None):
    """A RunData from a run file path, an EMPS .mat record or a stored run id."""
    from core.run import RunData
    if spec.isdigit():
        from db.store import Store
        run = Store(db_url).load_run(int(spec))
    elif spec.lower().endswith(".mat"):
        from core.emps import load_emps
        run = load_emps(spec)
    else:
        from core.runfile import read_run
        run = read_run(spec)
    if rename:
        run = RunData(samples=run.samples.rename(columns=rename), meta=dict(run.meta))
    return run


def _parse_rename(text: str | None) -> dict[str, str]:
    if not text:
        return {}
    out = {}
    for kv in text.split(","):
        old, sep, new = kv.partition("=")
        if not sep or not old.strip() or not new.strip():
            raise ValueError(f"--rename wants OLD=NEW pairs, got {kv!r}")
        out[old.strip()] = new.strip()
    return out


def format_text(rep: dict) -> str:
    """A short human-readable summary of a diagnosis report."""
    from estimator.diagnosis_coverage import coverage_line
    b, v = rep["baseline"], rep["verdict"]
    lines = [f"nominal model {b['model']}: RMSE train {b['rmse_train']:.4g}, held-out "
             f"{b['rmse_test']:.4g}",
             f"residual tests: {', '.join(rep['tests']['reasons']) or 'nothing structured'}",
             "where it lies (flagged regions, largest share of residual energy first):"]
    for r in rep["regions"][:10]:
        lines.append(f"  {r['where']:<42} share {r['share']:.3f}  rmse {r['rmse']:.4g}  "
                     f"mean {r['mean']:+.4g} ± {r['mean_se']:.2g}")
    if not rep["regions"]:
        lines.append("  (none flagged)")
    tx = rep.get("transmission")
    if tx:
        tb = tx["baseline"]
        lines.append(f"twist–torque law {tb['model']}: RMSE train {tb['rmse_train']:.4g}, "
                     f"held-out {tb['rmse_test']:.4g}")
    cov = v.get("held_out_coverage") or {}
    if cov:
        lines.append(f"held-out runs' share of the training runs' range: {coverage_line(cov)}")
    lines.append("candidates (largest held-out shrinkage first; the law each was added to):")
    for c in rep["candidates"]:
        shape = ",".join(f"{k}={v:.4g}" for k, v in c["shape"].items())
        amb = (" aliases " + ",".join(c["aliases"])) if c["aliases"] else ""
        amb += (" ambiguous with " + ",".join(c["ambiguous_with"])) if c["ambiguous_with"] else ""
        lines.append(f"  {c['effect']:<24}{('[' + shape + ']') if shape else '':<18} "
                     f"on {c.get('model', b['model']):<6} rmse_test "
                     f"{c['rmse_test']:.4g}  shrinkage {c['shrinkage']:+.3f} (predicted "
                     f"{c['shrinkage_predicted']:+.3f})  z {c['z']:.1f}  "
                     f"{'SIGNIFICANT' if c['significant'] else ''}{amb}")
    for name, why in rep["skipped"].items():
        lines.append(f"  {name:<24} not tried: {why}")
    sh = rep["shrinkage"]["overall"]
    lines.append(f"verdict: {v['summary']}")
    lines.append(f"held-out RMSE {sh['rmse_before']:.4g} -> {sh['rmse_after']:.4g} (shrinkage "
                 f"{sh['shrinkage']:.3f}, 95 % CI {sh['ci95'][0]:.3f}..{sh['ci95'][1]:.3f}; "
                 f"predicted from training {sh['predicted_from_training']:.3f})")
    for r in rep["shrinkage"]["regions"]:
        lines.append(f"  {r['where']:<42} {r['rmse_before']:.4g} -> {r['rmse_after']:.4g} "
                     f"(shrinkage {r['shrinkage']:.3f}, CI {r['ci95'][0]:.3f}..{r['ci95'][1]:.3f})")
    moved = rep["shrinkage"]["parameters_moved"]
    if moved:
        lines.append("nominal parameters moved:")
        for n, m in moved.items():
            lines.append(f"  {n:<6} {m['before']:.5g} -> {m['after']:.5g} {m['unit']} "
                         f"({m['shift_in_se']:+.1f} SE)")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    import json
    import sys
    from dataclasses import replace
    from commands.progress import StageBar
    from estimator.diagnosis import DiagnosisOptions, diagnose
    from estimator.diagnosis_progress import reporting
    from estimator.preprocess import PrepOptions
    try:
        ren = _parse_rename(args.rename)
        train = [load(s, args.db, ren) for s in args.train]
        test = [load(s, args.db, ren) for s in args.test]
        opt = DiagnosisOptions()
        if args.effects:
            opt = replace(opt, candidates=tuple(e.strip() for e in args.effects.split(",")))
        prep = PrepOptions(cutoff_hz=args.cutoff, decimate=args.decimate)
        tx = None if args.transmission.lower() == "none" else args.transmission
        with StageBar("diagnosis") as bar, reporting(bar):
            rep = diagnose(train, test, args.model, prep=prep, options=opt, transmission=tx)
    except (OSError, KeyError, ValueError) as exc:
        print(f"rig diagnose: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(rep, indent=1, default=_json_default))
    else:
        print(format_text(rep))
    return 0


def _json_default(o):
    import numpy as np
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)
