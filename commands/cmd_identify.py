"""`rig identify RUN... --model eq4|eq5|eq11|eq9[+EFFECT...] --method ls|exact|mh|sghmc|hmc[,...]
[--test RUN...] [--json] [--out DIR] [--db URL] [--no-store]`: identify a joint model from run
files or stored runs and print the paper-layout table (several methods, comma-separated, come out
side by side).

RUN is a run file (<stem>.csv/.parquet with <stem>.json beside it, or an EMPS .mat record) or the
integer id of a stored run, as for `rig diagnose`. When every training and held-out run is a
stored run, each fit is stored with its runs (db.fits: the `results` rows the API's
identification jobs write, linked 'train'/'test', with the predicted-vs-measured series its
report draws) unless --no-store; `rig fits` lists them, `rig show RUN` names those made on a
run, `rig export --fit ID` writes one as JSON.

--json prints Fit.as_dict() (a list when several methods were asked for), with `fit_id` when it
was stored; --out DIR writes fit_<method>.json, report.txt and the figures (predicted vs
measured, posterior histograms, corner plot, autocorrelation, R-hat trace) as SVG.

While the samplers run, stderr shows one bar per chain (commands.progress.ChainBars: count, rate,
time left, warm-up or sampling), or plain lines when stderr is not a terminal; stdout carries
the result alone."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("runs", nargs="+", metavar="RUN",
                   help="training runs: run files (<stem>.csv/.parquet with <stem>.json beside "
                        "it, or an EMPS .mat record) or stored run ids")
    p.add_argument("--model", default="eq4",
                   help="eq4 (rigid body + friction, default), eq5 (elastic joint), eq11 "
                        "(Bouc–Wen output torque), eq9 (Bouc–Wen α, β, γ); add effects of "
                        "rig.md's vocabulary with '+NAME[:k=v,...]', e.g. eq4+stribeck")
    p.add_argument("--method", default="ls",
                   help="ls, exact, mh, sghmc (linear models); ls, mh, sghmc, hmc (eq9 / eq11 "
                        "with fitted Bouc–Wen); several comma-separated are tabulated side by side")
    p.add_argument("--test", nargs="+", default=None, metavar="RUN",
                   help="held-out runs (files or stored run ids): RMSE (Eq. 17) on them")
    p.add_argument("--json", action="store_true", help="print the result as JSON (Fit.as_dict)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="write the result JSON, the report and the figures (SVG) here")
    p.add_argument("--effect", action="append", default=[], metavar="NAME[:k=v,...]",
                   help="add an effect term (repeatable); same as '+NAME' in --model")
    p.add_argument("--bw", default=None, metavar="fit|known|ALPHA,BETA,GAMMA[,N]",
                   help="eq11 only: 'fit' (default) identifies the Bouc–Wen parameters; "
                        "'known' uses core.params' defaults; or give them explicitly")
    p.add_argument("--n", type=int, default=1, help="Bouc–Wen exponent n for eq9/eq11 (1)")
    p.add_argument("--chains", type=int, default=4, help="chains (4)")
    p.add_argument("--draws", type=int, default=None, help="kept draws per chain")
    p.add_argument("--warmup", type=int, default=None, help="warm-up iterations per chain")
    p.add_argument("--seed", type=int, default=0, help="random seed (0)")
    p.add_argument("--prior", default="paper", choices=["paper", "conjugate"],
                   help="paper: Eq. 16 (θ_s ~ N(0,1), τ² ~ IG(2,2)); conjugate: its NIG form")
    p.add_argument("--tau-scale", default="noise", choices=["noise", "signal"],
                   help="units of the IG(2,2) noise prior: the LS noise variance (default) or "
                        "the signal's mean square (the literal reading; inflates τ)")
    p.add_argument("--cutoff", type=float, default=None, metavar="HZ",
                   help="zero-phase low-pass of the kinematic channels before differentiating "
                        "[Hz] (the torque is left as recorded)")
    p.add_argument("--decimate", type=int, default=1,
                   help="decimate the regression equation by k: X and y filtered alike "
                        "(parallel filtering), every k-th row kept (1)")
    p.add_argument("--min-speed", type=float, default=0.0, metavar="RAD_S",
                   help="drop rows with |q̇| below this [rad/s] (stick around velocity "
                        "reversals; e.g. 2e-4 = 10·v_eps) (0)")
    p.add_argument("--sobol", action="store_true",
                   help="first-order and total-effect Sobol indices (Eqs. 18–19) of the predicted "
                        "output over each Bayesian fit's posterior marginals (linear models)")
    p.add_argument("--db", default=None, metavar="URL",
                   help="database URL for run ids (default: $RIG_DB_URL or ./rig-data/rig.sqlite)")
    p.add_argument("--no-store", action="store_true",
                   help="do not store the fits (they are stored when every run is a stored run)")


def _parse_bw(text: str | None, model: str):
    if not model.startswith("eq11") or text in (None, "fit"):
        return None
    from core.params import JointParams
    if text == "known":
        P = JointParams()
        return {"alpha": P.alpha, "beta": P.beta, "gamma": P.gamma, "n": P.n}
    vals = [float(v) for v in text.split(",")]
    if len(vals) not in (3, 4):
        raise ValueError("--bw takes 'fit', 'known' or ALPHA,BETA,GAMMA[,N]")
    out = {"alpha": vals[0], "beta": vals[1], "gamma": vals[2], "n": 1}
    if len(vals) == 4:
        out["n"] = int(vals[3])
    return out


def is_run_id(spec: str) -> bool:
    """A RUN argument naming a stored run (an integer id) rather than a file."""
    return spec.isdigit()


def load_run(spec: str, store=None):
    """A RunData from a run file, an EMPS .mat record or (with `store`) a stored run id."""
    if is_run_id(spec):
        from core.redact import redact_secrets
        from db.store import RunNotFound
        try:
            return store.load_run(int(spec))
        except RunNotFound:
            raise ValueError(f"no stored run {spec} in {redact_secrets(store.url)}") from None
    if spec.lower().endswith(".mat"):
        from core.emps import load_emps
        return load_emps(spec)
    from core.runfile import read_run
    return read_run(spec)


def run(args: argparse.Namespace) -> int:
    specs = list(args.runs) + list(args.test or [])
    if not any(is_run_id(s) for s in specs):
        return _run(args, None)
    from db.store import Store
    with Store(args.db) as store:
        return _run(args, store)


def _run(args: argparse.Namespace, store) -> int:
    import json
    import sys
    from pathlib import Path

    import numpy as np

    from commands.progress import ChainBars
    from estimator.identify import identify_detailed
    from estimator.sampler_progress import reporting
    from estimator.preprocess import PrepOptions
    from estimator.tables import report
    from core.runfile import RunFileError

    methods = [m.strip() for m in args.method.split(",") if m.strip()]
    try:
        train = [load_run(r, store) for r in args.runs]
        test = [load_run(r, store) for r in args.test] if args.test else None
        model = args.model + "".join(f"+{e}" for e in args.effect)
        opts = {"chains": args.chains, "seed": args.seed}
        base = model.split("+")[0]
        bw = _parse_bw(args.bw, model)
        if base in ("eq9",) or (base == "eq11" and bw is None):
            opts["n"] = args.n
            if "+" in model:
                raise ValueError("effects can be added to the linear models (eq4, eq5, eq11 with "
                                 "--bw known or explicit), not to the Bouc–Wen fit")
        else:
            opts.update({"prep": PrepOptions(cutoff_hz=args.cutoff, decimate=args.decimate,
                                             min_speed=args.min_speed),
                         "prior": args.prior, "tau_scale": args.tau_scale})
            if bw is not None:
                opts["bouc_wen"] = bw
        if args.draws is not None:
            opts["draws"] = args.draws
        if args.warmup is not None:
            opts["warmup"] = args.warmup
        results = []
        for m in methods:
            with ChainBars(m) as bars, reporting(bars):
                results.append(identify_detailed(train, model, m, test, **dict(opts)))
    except (RunFileError, OSError, ValueError, KeyError, TypeError) as e:
        print(f"rig identify: {e}", file=sys.stderr)
        return 2
    fits = [f for f, _ in results]
    text = report(fits, title=f"Identification of {fits[0].model} on "
                              f"{len(train)} run(s), {fits[0].extra.get('n_train', '?')} samples")
    ident = fits[0].extra.get("identifiability")
    if ident:
        from estimator.identifiability import report_text
        text += "\n\n" + report_text(ident)
    sobol = {}
    if args.sobol:
        sobol = _sobol(results)
        for f in fits:
            if f.method in sobol:
                f.extra["sobol"] = sobol[f.method].table.to_dict(orient="list")
        from estimator.tables import sobol_table
        text += "".join("\n\n" + sobol_table(sobol[m].table, f"Sobol indices ({m})")
                        for m in sobol)
    out = [f.as_dict() for f in fits]
    stored = _store_fits(args, store, fits, train, test or [])
    for d, fit_id in zip(out, stored):
        d["fit_id"] = fit_id
    if args.json:
        print(json.dumps(out[0] if len(out) == 1 else out, indent=2))
    else:
        print(text)
        if stored:
            print("\nstored: " + ", ".join(f"fit {i} ({f.method})" for i, f in zip(stored, fits))
                  + f" — `rig fits`, `rig export --fit {stored[0]}`")
    if args.out:
        from estimator import plots
        d = Path(args.out)
        d.mkdir(parents=True, exist_ok=True)
        for f, fd in zip(fits, out):
            (d / f"fit_{f.method}.json").write_text(json.dumps(fd, indent=2))
        (d / "report.txt").write_text(text + "\n")
        ds = results[0][1]
        if ds is not None:
            t, off = [], 0.0
            for s in ds.signals:
                t.append(s["t"] + off)
                off = t[-1][-1] + (s["t"][1] - s["t"][0] if s.n > 1 else 1.0)
            preds = {f.method: ds.X @ np.asarray(f.mean) for f in fits}
            plots.predicted_vs_measured(np.concatenate(t), ds.y, preds,
                                        ylabel=f"{ds.model.target_label} [{ds.model.target_unit}]",
                                        title=f"{fits[0].model}: measured and predicted",
                                        path=d / "predicted_vs_measured.svg")
        bayes = [f for f in fits if f.draws is not None]
        for f in bayes:
            plots.posterior_histograms(f, path=d / f"posterior_{f.method}.svg")
            plots.corner_plot(f, path=d / f"corner_{f.method}.svg")
            if np.asarray(f.diagnostics.get("autocorr", [])).ndim == 2:
                plots.autocorr_plot(f, path=d / f"autocorr_{f.method}.svg")
        for m, res in sobol.items():
            plots.sobol_bars_from_table(res.table, title=f"{fits[0].model} — {m}: Sobol indices",
                                        path=d / f"sobol_{m}.svg")
        if any(f.diagnostics.get("rhat_trace") for f in bayes) and \
                any(len(f.diagnostics["rhat_trace"]["iterations"]) for f in bayes):
            plots.rhat_trace_plot(bayes, path=d / "rhat_trace.svg")
        if not args.json:
            print(f"\nwrote {d}/")
    return 0


STORED_OPTIONS = ("model", "method", "effect", "bw", "n", "chains", "draws", "warmup", "seed",
                  "prior", "tau_scale", "cutoff", "decimate", "min_speed", "sobol")
"""The `rig identify` options kept with a stored fit (extra['identify_options']), so that the
fit can be made again."""


def _store_fits(args: argparse.Namespace, store, fits: list, train: list, test: list) -> list[int]:
    """Store each fit with its runs (db.fits.save_fit, the records the API's identification jobs
    write) when every run is a stored run; returns the fit ids (empty when nothing was stored)."""
    import sys

    if store is None or args.no_store:
        return []
    specs = list(args.runs) + list(args.test or [])
    files = [s for s in specs if not is_run_id(s)]
    if files:
        print(f"rig identify: fit not stored: {', '.join(files)} "
              f"{'is a file, not a stored run' if len(files) == 1 else 'are files, not stored runs'}"
              " (`rig import` them first)", file=sys.stderr)
        return []
    from api.fit_series import prediction_series
    from db.fits import save_fit

    train_ids = [int(s) for s in args.runs]
    test_ids = [int(s) for s in args.test or []]
    roles = {i: "train" for i in train_ids} | {i: "test" for i in test_ids}
    if len(roles) < len(train_ids) + len(test_ids):
        print("rig identify: fit not stored: a run is given twice or both as a training and a "
              "held-out run", file=sys.stderr)
        return []
    runs = ([(i, "train", r) for i, r in zip(train_ids, train)]
            + [(i, "test", r) for i, r in zip(test_ids, test)])
    options = {k: getattr(args, k) for k in STORED_OPTIONS if hasattr(args, k)}
    ids = []
    for fit in fits:
        fit.extra["identify_options"] = options
        try:
            fit.extra["series"] = prediction_series(fit, runs)
        except (KeyError, ValueError) as e:     # the fit is stored without its figure
            print(f"rig identify: no predicted-vs-measured series for {fit.method}: {e}",
                  file=sys.stderr)
        ids.append(save_fit(store, fit, roles))
    return ids


def _sobol(results) -> dict:
    """Sobol indices of the predicted output over the posterior marginals of every Bayesian fit
    of a linear model (estimator.sobol on the training rows, at most 2000 of them)."""
    import numpy as np

    from estimator.sobol import sobol_indices
    out = {}
    for fit, ds in results:
        if ds is None or fit.draws is None:
            continue
        rows = np.linspace(0, ds.X.shape[0] - 1, min(2000, ds.X.shape[0])).astype(int)
        X = ds.X[rows]
        out[fit.method] = sobol_indices(lambda th, X=X: np.asarray(th) @ X.T, fit.param_names,
                                        fit.mean, fit.sd, n_base=256, seed=0)
    return out
