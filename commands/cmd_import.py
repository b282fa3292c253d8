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


def counted(items, bar):
    """`items`, one `bar.update(1)` after each is done (whether the loop body finished it or
    skipped it with `continue`)."""
    for x in items:
        yield x
        bar.update(1)


def run(args: argparse.Namespace) -> int:
    import json
    import sys
    from pathlib import Path

    from sqlalchemy.exc import SQLAlchemyError

    from commands.progress import progress
    from db.store import Store
    from core.emps import load_emps
    from core.runfile import RunFileError, read_run, run_paths

    failures: list[str] = []

    def refuse(problem: str) -> None:
        print(f"refused: {problem}", file=sys.stderr)
        failures.append(problem)

    targets: list[Path] = []
    for p in args.paths:
        path = Path(p)
        try:
            data = path if path.suffix == ".mat" else run_paths(path)[0]
        except RunFileError as exc:
            refuse(str(exc))
            continue
        if data.resolve() not in [t.resolve() for t in targets]:
            targets.append(data)
    imported = []
    with Store(args.db) as store, progress(len(targets), "import", "file",
                                           disable=len(targets) < 2) as bar:
        for data in counted(targets, bar):
            # each file alone: read and validated whole, then stored in one transaction, so a
            # file that fails leaves nothing of itself and the others still go in
            try:
                run_data = load_emps(data) if data.suffix == ".mat" else read_run(data)
                rid = store.save_run(run_data, imported_from=str(data.resolve()))
            except RunFileError as exc:
                refuse(str(exc))
                continue
            except SQLAlchemyError as exc:  # e.g. a value this database cannot hold
                refuse(f"{data}: the database refused it, nothing stored: "
                       f"{str(getattr(exc, 'orig', None) or exc).splitlines()[0]}")
                continue
            imported.append({"run_id": rid, "source_file": str(data), "samples": len(run_data),
                             "channels": list(run_data.samples.columns)})
    if args.json:
        print(json.dumps(imported, indent=2, ensure_ascii=False))
    else:
        for r in imported:
            print(f"{r['run_id']}\t{r['source_file']}")
    if failures:
        print(f"imported {len(imported)} file(s); {len(failures)} refused, nothing stored of them:",
              file=sys.stderr)
        for problem in failures:
            print(f"  {problem}", file=sys.stderr)
    return 1 if failures else 0
