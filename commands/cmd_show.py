"""`rig show RUN`: one run's summary — status, exit status and reason, metadata, channels with
units and missing-sample counts, phases, interruptions, the acceptance indicators of
Table 11 (core/acceptance.py) for a loading run, and the fits made on it (db.fits: by
`rig identify` or by the API's jobs, with the run's role in each)."""

from __future__ import annotations

import argparse
from core.jsonsafe import json_safe


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run_id", type=int, metavar="RUN", help="run id (see `rig runs`)")
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument("--db", metavar="URL",
                        help="database URL (default: $RIG_DB_URL or ./rig-data/rig.sqlite)")


ACCEPTANCE_CHANNELS = ("t", "phase", "torque_load", "torque_cmd", "m_bend", "f_shear")


def summarise(store, run_id: int) -> dict:
    """Everything `rig show` prints, as a dict (JSON-ready apart from datetimes)."""
    import pandas as pd

    from core.acceptance import acceptance, is_loading_run
    from core.run import RunData

    info = store.run_info(run_id)
    channels = store.channels(run_id)
    n = info["n_samples"]
    stats = store.phase_aggregates(run_id, by_phase=False).set_index("channel")
    names = [c["name"] for c in channels]
    text = [c["name"] for c in channels if c["kind"] != "float"]
    arrays = store.load_arrays(run_id, [c for c in names if c in ACCEPTANCE_CHANNELS or c in text])
    for c in channels:
        if c["name"] in stats.index:
            c["valid"] = int(stats.loc[c["name"], "count"])
            c["missing"] = int(stats.loc[c["name"], "missing"])
        else:
            c["valid"] = int(sum(v is not None for v in arrays[c["name"]]))
            c["missing"] = n - c["valid"]
    probe = RunData(samples=pd.DataFrame({k: v for k, v in arrays.items()
                                          if k in ACCEPTANCE_CHANNELS}), meta=info["meta"])
    indicators = acceptance(probe) if is_loading_run(probe) and n else []
    phases = store.phase_durations(run_id)
    return {**info, "channels": channels,
            "phases": json_safe(phases.to_dict("records")),
            "interruptions": store.interruptions(run_id),
            "acceptance": [i.as_dict() for i in indicators],
            "fits": fits_on_run(store, run_id)}


def fits_on_run(store, run_id: int) -> list[dict]:
    """The stored fits that used the run, newest first (db.fits.list_fits), each with `role`:
    how this run served it ('train', 'test')."""
    from db.fits import list_fits

    out = []
    for f in list_fits(store, run_id=run_id, limit=1000):
        f["role"] = ",".join(sorted({r["role"] for r in f["runs"] if r["run_id"] == run_id}))
        out.append(f)
    return out


def run(args: argparse.Namespace) -> int:
    import json
    import sys

    from db.store import RunNotFound, Store
    from core.acceptance import Indicator, format_table

    with Store(args.db) as store:
        try:
            s = summarise(store, args.run_id)
        except RunNotFound:
            print(f"no run {args.run_id}", file=sys.stderr)
            return 1
    if args.json:
        print(json.dumps(s, indent=2, default=str, ensure_ascii=False))
        return 0
    exit_txt = f" ({s['exit_status']})" if s["exit_status"] else ""
    print(f"run {s['id']}: {s['status']}{exit_txt}   scheme {s['scheme'] or '—'}   "
          f"source {s['source'] or '—'}   rig {s['rig'] or '—'}")
    span = "—" if s["t_last"] is None else f"{s['t_last']:.3f} s"
    def when(dt) -> str:
        return dt.strftime("%Y-%m-%d %H:%M:%S UTC") if dt else "—"
    print(f"started {when(s['started_at'])}   stopped {when(s['stopped_at'])}   "
          f"samples {s['n_samples']} up to t = {span} in {s['n_pages']} pages")
    if s["reason"]:
        print(f"reason: {s['reason']}")
    if s["imported_from"]:
        print(f"imported from {s['imported_from']}")
    print("metadata:")
    for k, v in s["meta"].items():
        print(f"  {k}: {json.dumps(v, ensure_ascii=False)}")
    print(f"channels ({len(s['channels'])}):")
    print(f"  {'name':<14}{'unit':<9}{'source':<22}{'valid':>9}{'missing':>9}")
    for c in s["channels"]:
        print(f"  {c['name']:<14}{c['unit'] or '—':<9}{(c['source'] or '—')[:21]:<22}"
              f"{c['valid']:>9}{c['missing']:>9}")
    if s["phases"] and any(p["phase"] for p in s["phases"]):
        print("phases:")
        for p in s["phases"]:
            print(f"  {p['phase'] or '(none)':<10}{p['samples']:>9} samples {p['span_s']:>10.2f} s")
    print(f"interruptions: {len(s['interruptions']) or 'none'}")
    for i in s["interruptions"]:
        end = "open" if i["t_end"] is None else f"{i['t_end']:.3f}"
        start = "—" if i["t_start"] is None else f"{i['t_start']:.3f}"
        print(f"  {i['kind']:<14} t = {start} .. {end} s  {i['reason'] or ''}")
    if s["acceptance"]:
        print("acceptance indicators (Table 11):")
        table = format_table([Indicator(**a) for a in s["acceptance"]])
        print("\n".join("  " + line for line in table.splitlines()))
    else:
        print("acceptance indicators: not a loading run")
    if s["fits"]:
        from commands.cmd_fits import format_table
        print(f"fits made on this run ({len(s['fits'])}; `rig export --fit ID` writes one):")
        print("\n".join("  " + line for line in format_table(s["fits"], role=True).splitlines()))
    else:
        print("fits made on this run: none")
    return 0
