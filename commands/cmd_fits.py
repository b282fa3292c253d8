"""`rig fits [--run RUN] [--model MODEL] [--method METHOD] [--json]`: the stored identification
results (db.fits), newest first — those `rig identify` made on stored runs and those of the API's
jobs: id, job, when, model, method, the runs with their role, noise sd and RMSE (Eq. 17) on the
training and held-out runs. `rig export --fit ID` writes one as JSON."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--run", type=int, default=None, metavar="RUN",
                        help="only the fits that used this stored run")
    parser.add_argument("--model", default=None,
                        help="only this model (eq4 also matches eq4+EFFECT)")
    parser.add_argument("--method", default=None, help="only this method (ls, exact, mh, ...)")
    parser.add_argument("--limit", type=int, default=100, help="at most this many (100)")
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument("--db", metavar="URL",
                        help="database URL (default: $RIG_DB_URL or ./rig-data/rig.sqlite)")


def _runs_text(runs: list[dict]) -> str:
    by_role: dict[str, list[str]] = {}
    for r in runs:
        by_role.setdefault(r["role"], []).append(str(r["run_id"]))
    return " ".join(f"{role}:{','.join(ids)}" for role, ids in sorted(by_role.items(),
                                                                     key=lambda kv: kv[0] != "train"))


def _num(v) -> str:
    return "—" if v is None else f"{v:.5g}"


def format_table(fits: list[dict], role: bool = False) -> str:
    """Stored fits (db.fits.list_fits rows) as a text table; `role` adds the column of the run
    they were listed for (cmd_show.fits_on_run)."""
    head = (f"{'fit':>5}  {'job':>5}  {'created (UTC)':<19}  {'model':<16}{'method':<8}"
            f"{'role  ' if role else ''}{'sigma':>10}{'rmse_train':>12}{'rmse_test':>11}  runs")
    lines = [head]
    for f in fits:
        when = f["created_at"].strftime("%Y-%m-%d %H:%M:%S") if f["created_at"] else "—"
        job = "—" if f["job_id"] is None else str(f["job_id"])
        lines.append(f"{f['id']:>5}  {job:>5}  {when:<19}  {f['model'][:15]:<16}"
                     f"{f['method']:<8}{(f.get('role') or '—')[:5] + ' ' if role else ''}"
                     f"{_num(f['sigma']):>10}{_num(f['rmse_train']):>12}"
                     f"{_num(f['rmse_test']):>11}  {_runs_text(f['runs'])}")
    return "\n".join(lines)


def json_default(o):
    """JSON for what json cannot write itself: datetimes in ISO 8601, anything else as text."""
    return o.isoformat() if hasattr(o, "isoformat") else str(o)


def run(args: argparse.Namespace) -> int:
    import json

    from db.fits import list_fits
    from db.store import Store

    with Store(args.db) as store:
        fits = list_fits(store, run_id=args.run, model=args.model, method=args.method,
                         limit=args.limit)
    if args.json:
        print(json.dumps(fits, indent=2, default=json_default))
        return 0
    if not fits:
        print("no stored fits")
        return 0
    print(format_table(fits))
    print("(job — : made by `rig identify`; `rig export --fit ID` writes one as JSON)")
    return 0
