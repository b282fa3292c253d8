"""`rig reproduce`: the paper's results reproduced end to end on the emulator — its campaign, the
fits of Tables 3, 4, 8 and 9, Sobol indices (Figs. 21–24), R-hat traces and autocorrelations,
scheme 3's condition number (Fig. 6) and the Table 11 indicators — printed as one report with
each table next to the paper's values and the ratio, and written as a page with its figures and
as JSON (api.paper_reproduction; the `reproduction` job kind stores the same report). While the
samplers run, stderr shows one bar per chain of each fit in turn (commands.progress.ChainBars)."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quick", action="store_true",
                   help="one loading run per role, a short scheme-3 run and short chains: checks "
                        "the pipeline in about a minute, reproduces nothing")
    p.add_argument("--seed", type=int, default=1, help="emulator and sampler seed (default 1)")
    p.add_argument("--report-dir", default="rig-reproduce-report",
                   help="folder the report page (index.html) and report.json are written to "
                        "(default ./rig-reproduce-report)")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--db", default=None,
                   help="database URL the fits and the report are stored in (default: the "
                        "settings', RIG_DB_URL)")
    p.add_argument("--no-store", action="store_true",
                   help="do not store the fits and the report in the database")


BLAS_THREADS = "1"
"""OpenBLAS threads for the reproduction's fits unless the environment sets OPENBLAS_NUM_THREADS:
every product in them is small (Eq. 11's regressor ~4 000 × 5), so threads gain nothing, and on
busy cores each threaded call waits for its helper thread (the figures are in the README's
reproduction paragraph)."""


def run(args: argparse.Namespace) -> int:
    import os
    # read by OpenBLAS when numpy and scipy load it, which is below (`rig` loads neither before)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", BLAS_THREADS)
    import json
    from pathlib import Path

    from api.paper_reproduction import Settings, report_text, reproduce
    from api.reports import reproduction_html
    from api.reproduction_plots import reproduction_figures
    from commands.progress import ChainBars
    from core.jsonsafe import json_safe
    from estimator.sampler_progress import reporting

    with ChainBars("fit", numbered=True) as bars, reporting(bars):   # stderr: a bar per chain
        report, fits = reproduce(Settings(quick=args.quick, seed=args.seed))
    report = json_safe(report)
    stored: list[int] = []
    if not args.no_store:       # as the reproduction job stores them: the report with the first fit
        from db.fits import save_fit
        from db.store import Store
        with Store(args.db) as store:
            stored = [save_fit(store, f, {}, {"reproduction": report} if k == 0 else None)
                      for k, f in enumerate(fits)]
    out = Path(args.report_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    (out / "index.html").write_text(reproduction_html(report, reproduction_figures(report)),
                                    encoding="utf-8")
    print(json.dumps(report, indent=1) if args.json else report_text(report))
    if not args.json:
        print(f"\nreport written to {(out / 'index.html').resolve()} and report.json"
              + (f"; fits stored as results {stored[0]}–{stored[-1]} (the report with result "
                 f"{stored[0]}; `rig fits`)" if stored else ""))
    return 0
