"""`rig runs`: list stored runs, newest first, with status, exit status and size."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--status", choices=("running", "finished", "interrupted"))
    parser.add_argument("--scheme", type=int, choices=(1, 2, 3))
    parser.add_argument("--source", choices=("rig", "emulator", "import"))
    parser.add_argument("--rig", metavar="NAME")
    parser.add_argument("--limit", type=int, default=50, help="at most this many (default 50)")
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument("--db", metavar="URL",
                        help="database URL (default: $RIG_DB_URL or ./rig-data/rig.sqlite)")


def run(args: argparse.Namespace) -> int:
    import json

    from db.store import Store

    with Store(args.db) as store:
        runs = store.list_runs(status=args.status, scheme=args.scheme, source=args.source,
                               rig=args.rig, limit=args.limit)
    if args.json:
        print(json.dumps(runs, indent=2, default=str, ensure_ascii=False))
        return 0
    if not runs:
        print("no runs")
        return 0
    print(f"{'id':>5}  {'status':<12}{'exit':<8}{'scheme':>6}  {'source':<9}{'rig':<12}"
          f"{'samples':>9}{'span s':>10}  {'started':<20}note")
    for r in runs:
        started = r["started_at"].strftime("%Y-%m-%d %H:%M:%S") if r["started_at"] else "—"
        note = r["reason"] or (r["imported_from"] or "")
        span = "—" if r["t_last"] is None else f"{r['t_last']:.1f}"
        print(f"{r['id']:>5}  {r['status']:<12}{r['exit_status'] or '—':<8}"
              f"{r['scheme'] if r['scheme'] is not None else '—':>6}  {r['source'] or '—':<9}"
              f"{(r['rig'] or '—')[:11]:<12}{r['n_samples']:>9}{span:>10}  {started:<20}"
              f"{note[:60]}")
    return 0
