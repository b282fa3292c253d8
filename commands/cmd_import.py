"""`rig import PATH...`: validate run files (run-format.md; EMPS `.mat` records through the EMPS
adapter) and store each as a new run. A refused file is reported with its file, row and column
and nothing of it is stored; the others are imported. Exit status 1 when any file was refused."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("paths", nargs="+", metavar="PATH",
                        help="a run: <stem>.csv or <stem>.parquet (with <stem>.json beside it), "
                             "the .json, the bare stem, or an EMPS .mat record")
    parser.add_argument("--json", action="store_true",
                        help="print a JSON list of {run_id, source_file, samples, channels}")
    parser.add_argument("--db", metavar="URL",
                        help="database URL (default: $RIG_DB_URL or ./rig-data/rig.sqlite)")


def run(args: argparse.Namespace) -> int:
    import json
    import sys
    from pathlib import Path

    from db.store import Store
    from core.emps import load_emps
    from core.runfile import RunFileError, read_run, run_paths

    targets: list[Path] = []
    refused = 0
    for p in args.paths:
        path = Path(p)
        try:
            data = path if path.suffix == ".mat" else run_paths(path)[0]
        except RunFileError as exc:
            print(f"refused: {exc}", file=sys.stderr)
            refused += 1
            continue
        if data.resolve() not in [t.resolve() for t in targets]:
            targets.append(data)
    imported = []
    with Store(args.db) as store:
        for data in targets:
            try:
                run_data = load_emps(data) if data.suffix == ".mat" else read_run(data)
            except RunFileError as exc:
                print(f"refused: {exc}", file=sys.stderr)
                refused += 1
                continue
            rid = store.save_run(run_data, imported_from=str(data.resolve()))
            imported.append({"run_id": rid, "source_file": str(data), "samples": len(run_data),
                             "channels": list(run_data.samples.columns)})
    if args.json:
        print(json.dumps(imported, indent=2, ensure_ascii=False))
    else:
        for r in imported:
            print(f"{r['run_id']}\t{r['source_file']}")
    return 1 if refused else 0
