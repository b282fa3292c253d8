"""`rig export RUN`: write a stored run in the interchange format (run-format.md) as
run-<id>.csv|.parquet + run-<id>.json. Extra channels' units are added to the metadata's
`units` when it does not already hold them, so they travel with the run.

`rig export --fit ID [--draws]`: write a stored fit (db.fits.get_fit: the Fit.as_dict() summary,
its runs with their role, its job if any, its JSON documents) as fit-<id>.json; --draws adds the
posterior draws as nested lists (chains × draws × parameters, in the order of `fit.params`)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run_id", type=int, nargs="?", metavar="RUN",
                        help="run id (see `rig runs`)")
    parser.add_argument("--fit", type=int, default=None, metavar="ID",
                        help="export this stored fit (see `rig fits`) as JSON instead of a run")
    parser.add_argument("--draws", action="store_true",
                        help="with --fit: include the posterior draws")
    parser.add_argument("--format", choices=("csv", "parquet"), default="csv",
                        help="sample file format (default csv)")
    parser.add_argument("--out", default=".", metavar="DIR", help="output directory (default .)")
    parser.add_argument("--json", action="store_true",
                        help="print JSON {run|fit, files} instead of one path per line")
    parser.add_argument("--db", metavar="URL",
                        help="database URL (default: $RIG_DB_URL or ./rig-data/rig.sqlite)")


def export_fit(store, fit_id: int, out_dir, draws: bool = False):
    """Write stored fit `fit_id` as <out_dir>/fit-<id>.json; returns the path, or None when
    there is no such fit."""
    import json
    from pathlib import Path

    from core.jsonsafe import json_safe
    from db.fits import get_fit

    rec = get_fit(store, fit_id, draws=draws)
    if rec is None:
        return None
    path = Path(out_dir) / f"fit-{fit_id}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    from commands.cmd_fits import json_default
    path.write_text(json.dumps(json_safe(rec), indent=1, default=json_default, allow_nan=False)
                    + "\n")
    return path


def run(args: argparse.Namespace) -> int:
    import json
    import sys

    from db.store import RunNotFound, Store

    if (args.run_id is None) == (args.fit is None):
        print("rig export: give a run id or --fit ID (one of them)", file=sys.stderr)
        return 2
    if args.fit is not None:
        with Store(args.db) as store:
            path = export_fit(store, args.fit, args.out, draws=args.draws)
        if path is None:
            print(f"no fit {args.fit}", file=sys.stderr)
            return 1
        print(json.dumps({"fit": args.fit, "files": [str(path)]}) if args.json else path)
        return 0
    from db.run_export import export_run
    with Store(args.db) as store:
        try:
            paths = export_run(store, args.run_id, args.out, args.format)
        except RunNotFound:
            print(f"no run {args.run_id}", file=sys.stderr)
            return 1
    if args.json:
        print(json.dumps({"run": args.run_id, "format": args.format,
                          "files": [str(p) for p in paths]}))
        return 0
    for p in paths:
        print(p)
    return 0
