"""`identify(train_runs, model, method, test_runs=None, **opts) -> Fit`: runs in, a Fit out.

Linear-in-parameter models (estimator.models: eq4, eq5, eq11 with x known, any of them with
effects, or a LinearModel) are fitted here by
- 'ls'     ordinary least squares, standard errors, t-intervals (estimator.least_squares);
- 'exact'  the exact posterior (estimator.exact): the reference of every sampler;
- 'mh'     random-walk Metropolis–Hastings, several chains (estimator.mh);
- 'sghmc'  stochastic-gradient HMC with automatic settings (estimator.sghmc).
'eq9', and 'eq11' with unknown Bouc–Wen parameters, go to estimator.bouc_wen.fit_bouc_wen.

Priors (all Bayesian methods share them; estimator.priors): prior='paper' is Eq. 16 —
θ_s ~ N(0, 1) on the parameters scaled to their RMS contribution to the output, and
τ² ~ Inv-Gamma(2, 2) in units of the least-squares noise variance σ̂² (Appendix A.B's
data-matched inverse-gamma; stated on the signal's scale instead, `tau_scale='signal'`, the IG(2, 2)
acts as four pseudo-observations of a noise as large as the whole signal and inflates τ many times
at this rig's signal-to-noise ratio). prior='conjugate' is its Normal–Inverse-Gamma counterpart.
Every sampler's fit also reports its distance to the exact posterior (extra['vs_exact']).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from estimator import sampler_progress
from estimator.convergence import fit_from_draws, rmse
from estimator.exact import (nig_draws, nig_posterior, semiconjugate_draws,
                             semiconjugate_posterior)
from estimator.identifiability import identifiability_report
from estimator.least_squares import ols
from estimator.linear_posterior import LinearPosterior
from estimator.mh import SamplerOutput
from estimator.models import LinearModel, model_from_spec
from estimator.preprocess import PrepOptions, Signals, concat_signals, prepare
from estimator.priors import Prior, Scaling, ZeroColumnError, inv_gamma_moment_match
from estimator.result import Fit
from core.run import RunData

LINEAR_METHODS = ("ls", "exact", "mh", "sghmc")
SAMPLER_OPTIONS = {"mh": {"proposal_cov"},
                   "sghmc": {"batch_size", "step_size", "friction", "mass", "correct_noise",
                             "max_noise_share"}}
DEFAULT_DRAWS = {"exact": 2000, "mh": 5000, "sghmc": 4000}
"""Kept draws per chain by method (4 chains): ≥ 500 bulk ESS per parameter in our runs."""

ChainMap = Callable[[Callable[[Any], Any], Iterable[Any]], Iterable[Any]]
"""A `map`-like callable, chain_map(fn, items) -> fn(item) for each item, in order (builtin `map`
runs them here one after another; the API passes one that runs them on a Dask cluster)."""


@dataclass
class Dataset:
    """What a linear fit was computed from (kept for plots and reports; not in the Fit)."""

    model: LinearModel
    X: np.ndarray
    y: np.ndarray
    signals: list[Signals]
    X_test: np.ndarray | None = None
    y_test: np.ndarray | None = None
    test_signals: list[Signals] = field(default_factory=list)


def build_dataset(model: LinearModel, runs: Sequence[RunData], prep: PrepOptions | None = None,
                  test_runs: Sequence[RunData] | None = None) -> Dataset:
    """Prepare every run for the model's signals and stack the observation matrices.

    With prep.decimate = k > 1 the regression equation is decimated, not the signals: X and y
    are computed at the recorded rate, then every column of X and y is low-pass filtered with the
    same zero-phase Butterworth filter (0.8 × the new Nyquist frequency) and every k-th row kept,
    per segment ("parallel filtering", as in the IDIM literature and the EMPS benchmark), so the
    nonlinear columns (sgn q̇, the Bouc–Wen state) are filtered exactly as the torque is.
    prep.min_speed > 0 then drops the rows where |q̇| is below it (see PrepOptions)."""
    prep = prep or PrepOptions()
    k = int(prep.decimate)
    full = replace(prep, decimate=1)

    need = tuple(model.requires) + (("qd",) if prep.min_speed > 0 else ())

    def one(run):
        s = prepare(run, need, full)
        X, y = model.design(s), model.target(s)
        if k > 1:
            X, y, s = _parallel_decimate(X, y, s, k, prep.order)
        if prep.min_speed > 0:
            keep = np.abs(s["qd"]) >= prep.min_speed
            s = Signals({n: v[keep] for n, v in s.items()}, info=dict(s.info))
            s.info["rows_below_min_speed"] = int((~keep).sum())
            s.info["rows_out"] = int(keep.sum())
            X, y = X[keep], y[keep]
        return s, X, y

    parts = [one(r) for r in runs]
    ds = Dataset(model, np.vstack([p[1] for p in parts]), np.concatenate([p[2] for p in parts]),
                 [p[0] for p in parts])
    if test_runs:
        tp = [one(r) for r in test_runs]
        ds.test_signals = [p[0] for p in tp]
        ds.X_test = np.vstack([p[1] for p in tp])
        ds.y_test = np.concatenate([p[2] for p in tp])
    return ds


def _parallel_decimate(X: np.ndarray, y: np.ndarray, s: Signals, k: int, order: int
                       ) -> tuple[np.ndarray, np.ndarray, Signals]:
    from scipy import signal as sps
    fs = float(s.info["sample_rate_hz"])
    sos = sps.butter(order, 0.8 * 0.5 * fs / k, fs=fs, output="sos")
    trim = 2 * k
    keep_rows, Xo, yo = [], [], []
    for seg in np.unique(s["segment"]):
        rows = np.flatnonzero(s["segment"] == seg)
        if rows.size < 2 * trim + 3 * k:
            continue
        pad = min(3 * (2 * sos.shape[0] + 1), rows.size - 1)
        Xf = sps.sosfiltfilt(sos, X[rows], axis=0, padlen=pad)
        yf = sps.sosfiltfilt(sos, y[rows], padlen=pad)
        sel = np.arange(trim, rows.size - trim, k)
        keep_rows.append(rows[sel])
        Xo.append(Xf[sel])
        yo.append(yf[sel])
    if not keep_rows:
        raise ValueError(f"no segment long enough to decimate by {k}")
    rows = np.concatenate(keep_rows)
    out = Signals({n: v[rows] for n, v in s.items()}, info=dict(s.info))
    out.info.update({"regression_decimated_by": k, "sample_rate_out_hz": fs / k,
                     "rows_out": int(rows.size)})
    return np.vstack(Xo), np.concatenate(yo), out


def make_prior(kind: str | Prior, p: int, noise_ratio2: float, tau_scale: str = "noise",
               tau_prior: tuple[float, float] | str = (2.0, 2.0)) -> Prior:
    """The prior in sampler coordinates. noise_ratio2 = (σ̂_LS / s_y)², the least-squares noise
    variance in scaled units. tau_prior (a0, b0) is stated in units of σ̂² (tau_scale='noise')
    or of s_y² ('signal'); 'moment' is Appendix A.B's moment matching with mean σ̂² and
    standard deviation σ̂² (shape 3)."""
    if isinstance(kind, Prior):
        return kind
    if tau_prior == "moment":
        a0, b0 = inv_gamma_moment_match(noise_ratio2, noise_ratio2 ** 2)
    else:
        a0, b0 = (float(v) for v in tau_prior)
        if tau_scale == "noise":
            b0 *= noise_ratio2
        elif tau_scale != "signal":
            raise ValueError("tau_scale must be 'noise' or 'signal'")
    if kind == "paper":
        return Prior(mean=np.zeros(p), cov=np.eye(p), a0=a0, b0=b0, conditional=False)
    if kind == "conjugate":
        # θ_s | τ_s² ~ N(0, τ_s²/E[τ_s²]·I): as wide as N(0, 1) at the prior's mean noise level.
        g = (a0 - 1.0) / b0 if a0 > 1 else 1.0 / max(noise_ratio2, 1e-300)
        return Prior(mean=np.zeros(p), cov=g * np.eye(p), a0=a0, b0=b0, conditional=True)
    raise ValueError(f"unknown prior {kind!r}: 'paper', 'conjugate' or a Prior")


def exact_posterior(Xs: np.ndarray, ys: np.ndarray, prior: Prior):
    """The exact posterior object for this prior (NIG closed form or the semi-conjugate grid)."""
    if prior.conditional:
        return nig_posterior(Xs, ys, prior.mean, prior.cov, prior.a0, prior.b0)
    return semiconjugate_posterior(Xs, ys, prior.mean, prior.cov, prior.a0, prior.b0)


def exact_draws(post, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    if hasattr(post, "cov_unit"):
        return nig_draws(post, n, rng)
    return semiconjugate_draws(post, n, rng)


@dataclass
class ChainTask:
    """One chain of a Bayesian linear fit, self-contained (data and prior in sampler coordinates,
    start, seed) so that `run_chain` can run it in another process or on another machine."""
    method: str
    """'exact', 'mh' or 'sghmc'"""
    draws: int
    warmup: int
    seed: int
    x0: np.ndarray | None = None
    """(1, p + 1) start in sampler coordinates (mh, sghmc)."""
    Xs: np.ndarray | None = None
    ys: np.ndarray | None = None
    prior: Prior | None = None
    post: Any = None
    """The exact posterior (method 'exact': its draws need no data)."""
    options: dict = field(default_factory=dict)
    chain: int = 0
    """This chain's index among the fit's chains (its progress reports carry it)."""
    progress: Any = None
    """The estimator.sampler_progress callback installed where the fit was asked for (None:
    none). It travels with the task: run in another process it must be picklable and report
    back, as a sampler_progress.QueueProgress does."""


def chain_seeds(seed: int, chains: int) -> list[int]:
    """Independent per-chain seeds derived from one seed (numpy SeedSequence.spawn)."""
    return [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(chains)]


def run_chain(task: ChainTask) -> SamplerOutput:
    """Run one chain: draws (1, draws, p + 1) of (θ, log τ²) in sampler coordinates. The
    sampler reports its iterations to task.progress as chain task.chain."""
    if task.method == "exact":
        t0 = time.perf_counter()
        th, t2 = exact_draws(task.post, task.draws, np.random.default_rng(task.seed))
        z = np.column_stack([th, np.log(t2)])[None]
        return SamplerOutput(draws=z, accept_rate=np.full(1, np.nan),
                             seconds=time.perf_counter() - t0)
    lp = LinearPosterior(task.Xs, task.ys, task.prior)
    with sampler_progress.reporting(sampler_progress.offset(task.progress, task.chain)):
        if task.method == "mh":
            from estimator.mh import metropolis_hastings
            return metropolis_hastings(lp.logp, task.x0, task.draws, task.warmup, task.seed,
                                       **task.options)
        if task.method == "sghmc":
            from estimator.sghmc import sghmc
            return sghmc(lp.grad_u, lp.n, task.x0, task.draws, task.warmup, task.seed,
                         **task.options)
    raise ValueError(f"no chains for method {task.method!r}")


def _slim(extra: dict) -> dict:
    return {k: v for k, v in extra.items() if not isinstance(v, np.ndarray) or v.size <= 64}


def fit_linear(model_name: str, names: Sequence[str], units: Sequence[str], X: np.ndarray,
               y: np.ndarray, method: str, X_test: np.ndarray | None = None,
               y_test: np.ndarray | None = None, *, prior: str | Prior = "paper",
               tau_scale: str = "noise", tau_prior: tuple[float, float] | str = (2.0, 2.0),
               chains: int = 4, draws: int | None = None, warmup: int | None = None,
               seed: int = 0, level: float = 0.95, chain_map: ChainMap | None = None,
               **sampler_opts: Any) -> Fit:
    """Fit y = X·θ + e by `method` (arrays in, a Fit out; the array-level core of identify).
    draws/warmup per chain default to DEFAULT_DRAWS[method] and 1000 (the samplers' autocorrelation
    times differ: ~1 for exact, ~20 for MH and SGHMC). sampler_opts go to the sampler (sghmc:
    batch_size, step_size, friction, mass, correct_noise; mh: proposal_cov).

    chain_map (a `map`-like callable, see ChainMap): each chain runs as an independent task
    (ChainTask → run_chain, seeds from chain_seeds) through it, e.g. spread over a cluster; the
    result does not depend on which map runs them. None: all chains in one sampler call (MH then
    pools its warm-up adaptation over the chains). R-hat, ESS and intervals are computed here
    over all chains either way.

    The samplers report every chain's iterations to the estimator.sampler_progress callback
    installed by the caller (through chain_map too: each task carries it; see ChainTask)."""
    draws = int(draws if draws is not None else DEFAULT_DRAWS.get(method, 2000))
    warmup = int(warmup if warmup is not None else 1000)
    if method not in LINEAR_METHODS:
        raise ValueError(f"method {method!r} is not one of {LINEAR_METHODS} for a linear model")
    unknown = set(sampler_opts) - SAMPLER_OPTIONS.get(method, set())
    if unknown:
        raise TypeError(f"unknown options for method {method!r}: {sorted(unknown)}")
    t_total = time.perf_counter()
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    names, units = list(names), list(units)
    p = X.shape[1]
    ident = identifiability_report(X, names)
    try:
        sc = Scaling.from_data(X, y)
    except ZeroColumnError as e:
        raise ValueError(f"parameters {[names[j] for j in e.columns]} cannot be identified: "
                         "their regressor columns are identically zero in these runs") from e
    ls = ols(X, y, level)
    extra: dict[str, Any] = {"identifiability": ident, "n_train": int(y.size),
                             "n_test": None if y_test is None else int(np.size(y_test)),
                             "ls_estimate": ls.theta}

    def rmse_pair(theta):
        tr = rmse(y, X @ theta)
        te = rmse(y_test, np.asarray(X_test) @ theta) if X_test is not None else None
        return tr, te

    if method == "ls":
        tr, te = rmse_pair(ls.theta)
        extra["cov"] = ls.cov
        extra["dof"] = ls.dof
        return Fit(model=model_name, method="ls", param_names=names, units=units,
                   mean=ls.theta, sd=ls.se, ci_low=ls.ci_low, ci_high=ls.ci_high,
                   sigma=ls.sigma, rmse_train=tr, rmse_test=te, draws=None,
                   diagnostics={"rank": ls.rank}, timings={"total": time.perf_counter() - t_total},
                   extra=extra)

    Xs, ys = sc.x_to_scaled(X), sc.y_to_scaled(y)
    noise_ratio2 = (ls.sigma / sc.y) ** 2
    pr = make_prior(prior, p, noise_ratio2, tau_scale, tau_prior)
    extra["prior"] = {"kind": prior if isinstance(prior, str) else "custom",
                      "theta": "independent N(mean, cov)" if not pr.conditional
                      else "N(mean, tau2*cov) given tau2",
                      "a0": pr.a0, "b0": pr.b0, "tau_scale": tau_scale,
                      "scaling_columns": sc.col, "scaling_output": sc.y}
    rng = np.random.default_rng(seed)

    t0 = time.perf_counter()
    post = exact_posterior(Xs, ys, pr)
    t_exact = time.perf_counter() - t0
    exact_mean = np.asarray(post.mean)
    exact_sd = np.sqrt(np.diag(post.theta_cov))

    t0 = time.perf_counter()
    accept = None
    if chain_map is not None:
        progress = sampler_progress.current()
        tasks = [ChainTask(method=method, draws=draws, warmup=warmup, seed=s, chain=c,
                           progress=progress)
                 for c, s in enumerate(chain_seeds(seed, chains))]
        if method == "exact":
            for t in tasks:
                t.post = post
        else:
            lp = LinearPosterior(Xs, ys, pr)
            x0 = lp.start(chains, rng)
            opts = dict(sampler_opts)
            if method == "mh":
                opts["proposal_cov"] = opts.get("proposal_cov", lp.laplace_cov())
            for c, t in enumerate(tasks):
                t.x0, t.Xs, t.ys, t.prior, t.options = x0[c:c + 1], Xs, ys, pr, opts
        outs = list(chain_map(run_chain, tasks))
        if len(outs) != chains:
            raise RuntimeError(f"chain_map returned {len(outs)} chains of {chains}")
        z = np.concatenate([o.draws for o in outs], axis=0)
        accept = np.concatenate([o.accept_rate for o in outs]) if method == "mh" else None
        seconds = sum(o.seconds for o in outs) + (t_exact if method == "exact" else 0.0)
        extra["sampler"] = {"independent_chains": chains,
                            "chain_seconds": [o.seconds for o in outs],
                            "chains": [_slim(o.extra) for o in outs]}
        if method == "exact":
            extra["sampler"]["kind"] = ("NIG closed form" if pr.conditional else
                                        "semi-conjugate: exact grid in log tau2, "
                                        "Gaussian theta | tau2")
            if pr.conditional:
                extra["log_marginal"] = post.log_marginal
    elif method == "exact":
        th, t2 = exact_draws(post, chains * draws, rng)
        z = np.column_stack([th, np.log(t2)]).reshape(chains, draws, p + 1)
        seconds = time.perf_counter() - t0 + t_exact
        extra["sampler"] = {"kind": "NIG closed form" if pr.conditional
                            else "semi-conjugate: exact grid in log tau2, Gaussian theta | tau2"}
        if pr.conditional:
            extra["log_marginal"] = post.log_marginal
    else:
        lp = LinearPosterior(Xs, ys, pr)
        x0 = lp.start(chains, rng)
        if method == "mh":
            from estimator.mh import metropolis_hastings
            out = metropolis_hastings(lp.logp, x0, draws, warmup, seed,
                                      proposal_cov=sampler_opts.pop("proposal_cov",
                                                                    lp.laplace_cov()))
        else:
            from estimator.sghmc import sghmc
            out = sghmc(lp.grad_u, lp.n, x0, draws, warmup, seed, **sampler_opts)
        z = out.draws
        accept = out.accept_rate if method == "mh" else None
        seconds = out.seconds
        extra["sampler"] = _slim(out.extra)
    theta_s = z[:, :, :p]
    flat = theta_s.reshape(-1, p)
    extra["vs_exact"] = {
        "mean_error_in_sd": (flat.mean(axis=0) - exact_mean) / exact_sd,
        "sd_ratio": flat.std(axis=0, ddof=1) / exact_sd,
        "exact_mean": sc.theta_to_physical(exact_mean),
        "exact_sd": exact_sd * sc.y / sc.col,
        "seconds_exact": t_exact,
    }
    theta = sc.theta_to_physical(theta_s)
    sigma = np.sqrt(np.exp(z[:, :, p])) * sc.y
    mean = theta.reshape(-1, p).mean(axis=0)
    tr, te = rmse_pair(mean)
    fit = fit_from_draws(model_name, method, names, units, theta, sigma, tr, te,
                         seconds=seconds, accept_rate=accept, extra=extra, level=level,
                         timings={"exact_reference": t_exact})
    fit.timings["total"] = time.perf_counter() - t_total
    return fit


def identify(train_runs: Sequence[RunData], model: str | LinearModel, method: str,
             test_runs: Sequence[RunData] | None = None, **opts: Any) -> Fit:
    """Identify `model` from the training runs by `method`; RMSE (Eq. 17) on the training runs
    and, when given, on the held-out test runs.

    opts: prep (PrepOptions), prior ('paper' | 'conjugate' | Prior), tau_scale, tau_prior,
    chains (4), draws (per chain, DEFAULT_DRAWS), warmup (1000), seed (0), level (0.95); bouc_wen
    (for 'eq11': None → fitted by estimator.bouc_wen; a dict of alpha, beta, gamma, n → x known);
    effects (list of names or (name, shape) pairs added to a model given by name); sampler
    options (sghmc: batch_size, step_size, friction, mass, correct_noise; mh: proposal_cov);
    chain_map (see fit_linear: run the chains of a linear model through a map-like callable; the
    Bouc–Wen path of eq9/eq11 ignores it and runs where it is called).
    """
    return identify_detailed(train_runs, model, method, test_runs, **opts)[0]


def identify_detailed(train_runs: Sequence[RunData], model: str | LinearModel, method: str,
                      test_runs: Sequence[RunData] | None = None, **opts: Any
                      ) -> tuple[Fit, Dataset | None]:
    """identify() plus the Dataset the fit was computed from (None for the Bouc–Wen path)."""
    if not train_runs:
        raise ValueError("identify needs at least one training run")
    prep = opts.pop("prep", None)
    effects = opts.pop("effects", ())
    bouc_wen = opts.pop("bouc_wen", None)
    if isinstance(model, str):
        base = model.split("+")[0].strip()
        if base == "eq9" or (base == "eq11" and bouc_wen is None):
            if "+" in model or effects:
                raise ValueError("effect terms go on the linear models (eq4, eq5, eq11 with "
                                 "bouc_wen given); the Bouc–Wen fit of eq9/eq11 takes none")
            opts.pop("chain_map", None)
            return _bouc_wen(train_runs, base, method, test_runs, prep, opts), None
        kw = {}
        if base == "eq11":
            kw = {k: (int(v) if k == "n" else float(v)) for k, v in dict(bouc_wen).items()}
        elif bouc_wen is not None:
            raise ValueError("bouc_wen applies to eq11 only")
        lm = model_from_spec(model, **kw)
    else:
        lm = model
    for e in effects:
        name, shape = (e, {}) if isinstance(e, str) else (e[0], dict(e[1]))
        lm = lm.with_effect(name, **shape)
    ds = build_dataset(lm, train_runs, prep, test_runs)
    fit = fit_linear(lm.name, lm.param_names, lm.units, ds.X, ds.y, method, ds.X_test, ds.y_test,
                     **opts)
    fit.extra["preprocessing"] = [_slim_info(s.info) for s in ds.signals]
    fit.extra["target"] = {"label": lm.target_label, "unit": lm.target_unit}
    fit.extra["descriptions"] = dict(lm.descriptions)
    return fit, ds


def _slim_info(info: dict) -> dict:
    return {k: v for k, v in info.items() if k != "meta"} | {
        "scheme": info.get("meta", {}).get("scheme"),
        "source": info.get("meta", {}).get("source")}


def _bouc_wen(train_runs, base, method, test_runs, prep, opts) -> Fit:
    from estimator.bouc_wen import fit_bouc_wen  # E2's estimator, imported only when needed
    sig = concat_signals([prepare(r, bouc_wen_signals(r), prep) for r in train_runs])
    options = dict(opts)
    n = int(options.pop("n", 1))
    seed = int(options.pop("seed", 0))
    if "draws" in options:
        options["n_draws"] = options.pop("draws")
    if "warmup" in options:
        options["n_warmup"] = options.pop("warmup")
    options.setdefault("model", base)
    if test_runs:
        options["test_signals"] = concat_signals(
            [prepare(r, bouc_wen_signals(r), prep) for r in test_runs])
    fit = fit_bouc_wen(sig, method, n=n, seed=seed, **options)
    fit.extra["preprocessing"] = [_slim_info(i) for i in sig.info["runs"]]
    return fit


def bouc_wen_signals(run: RunData) -> tuple[str, ...]:
    """The Bouc–Wen signals a run can supply (the output-side ones only when it records q)."""
    cols = set(run.samples.columns)
    need = ["torsion", "torsion_rate", "torque"]
    if "q" in cols:
        need = ["q", "qd", "qdd"] + need
    if "torque_load" in cols:
        need.append("torque_load")
    return tuple(need)
