"""`rig export RUN`: write a stored run in the interchange format (run-format.md) as
run-<id>.csv|.parquet + run-<id>.json. Extra channels' units are added to the metadata's
`units` when it does not already hold them, so they travel with the run."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run_id", type=int, metavar="RUN", help="run id (see `rig runs`)")
    parser.add_argument("--format", choices=("csv", "parquet"), default="csv",
                        help="sample file format (default csv)")
    parser.add_argument("--out", default=".", metavar="DIR", help="output directory (default .)")
    parser.add_argument("--db", metavar="URL",
                        help="database URL (default: $RIG_DB_URL or ./rig-data/rig.sqlite)")


def run(args: argparse.Namespace) -> int:
    import sys
    from pathlib import Path

    from db.store import RunNotFound, Store
    from core.channels import unit_of
    from core.run import RunData
    from core.runfile import write_run

    with Store(args.db) as store:
        try:
            run_data = store.load_run(args.run_id)
        except RunNotFound:
            print(f"no run {args.run_id}", file=sys.stderr)
            return 1
        channels = store.channels(args.run_id)
    meta = dict(run_data.meta)
    units = dict(meta.get("units") or {})
    extra = {c["name"]: c["unit"] for c in channels
             if c["unit"] and c["unit"] != unit_of(c["name"]) and units.get(c["name"]) != c["unit"]}
    if extra:
        meta["units"] = {**units, **extra}
    paths = write_run(RunData(samples=run_data.samples, meta=meta),
                      Path(args.out) / f"run-{args.run_id}", fmt=args.format)
    for p in paths:
        print(p)
    return 0
