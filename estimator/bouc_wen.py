"""Identification of the Bouc–Wen transmission (Eq. 9 inside Eq. 11) on the target of
estimator.bouc_wen_target: the fitting workflow.

The recursion's sub-step counts are fixed from the data for the whole fit (after a first
least-squares pass, at the stiffness of its estimate: substep_stiffness),
so the log density is smooth in (β, γ): with the shared step's own rule the count flips with
β + γ and the density jumps where its gradient sees nothing (HMC's step size then sat at its
floor and R-hat stayed at 1.02–1.05 on a 300 + 3000 r/min pair at 20 Hz).

Methods: 'ls' (nonlinear least squares in (w, θ) with the analytic Jacobian from a
variable-projection grid start, standard errors σ̂²(JᵀJ)⁻¹ carried to (β, γ) by the delta
method), 'hmc' (estimator.hmc on the collapsed target — exact in the limit), 'mh'
(estimator.mh on the collapsed target), 'sghmc' (estimator.sghmc on the joint (w, θ_s, log τ_s²)
target with mini-batch likelihood gradients; the recursion itself runs over the whole record each
step, so mini-batches save only the likelihood's share of the cost).
"""

from __future__ import annotations

import math
import os
import time
from typing import Any, Mapping

import numpy as np

from estimator import stopping
from estimator.bouc_wen_kernel import _state, _state_sens, bw_state, stiffness_bound
from estimator.priors import conjugate_prior
from estimator.result import Fit
from core.terms import eq11_regressor

LINEAR_NAMES: tuple[str, ...] = ("k_u", "k_h", "f_v", "D+f_c", "C")
"""Eq. 11's linear parameters in the order of core.terms.eq11_regressor's columns."""
LINEAR_UNITS: tuple[str, ...] = ("N·m/rad", "N·m/rad", "N·m", "N·m·s/rad", "N·m")
from estimator.bouc_wen_target import (X_COLUMN, BoucWenTarget, _signals_arrays, build_target,
                                       nonlinear_units)

METHODS: tuple[str, ...] = ("ls", "hmc", "mh", "sghmc")
"""The fitting methods of fit_bouc_wen."""


# --- least squares -----------------------------------------------------------------------------

def _profile_grid(tgt: BoucWenTarget) -> np.ndarray:
    """Variable-projection grid start: the w with the smallest linear-LS residual among yield
    twists (α/(β+γ))^(1/n) from range/300 to 3·range and β/(β+γ) ∈ [0.1, 1.9]."""
    rng_d = float(np.ptp(tgt.delta))
    best, best_w = np.inf, None
    a = tgt.alpha
    for dy in np.geomspace(rng_d / 300.0, 3.0 * rng_d, 18):
        ssum = a / dy ** tgt.n
        for ratio in np.linspace(0.1, 1.9, 9):
            stopping.poll()
            w = np.array(([0.0] if tgt.free_alpha else []) + [math.log(ssum), math.log(ratio)])
            if not tgt._guard(*tgt.physical(w)):
                continue
            X = tgt.scaled_regressor(tgt.state(w))
            coef, *_ = np.linalg.lstsq(X, tgt.ys, rcond=None)
            r = tgt.ys - X @ coef
            rss = float(r @ r)
            if rss < best:
                best, best_w = rss, w
    if best_w is None:
        raise ValueError("no Bouc–Wen start within the numerical guard: the twist steps are "
                         "too large for the integrator")
    return best_w


def least_squares_fit(tgt: BoucWenTarget, start: Mapping[str, Any] | None = None
                      ) -> dict[str, Any]:
    """Nonlinear LS over (w, θ_s) with the analytic Jacobian (sensitivities), from the
    variable-projection grid start (or from `start`, a previous result's 'w' and 'theta_s').
    Returns the estimate and covariance σ̂²(JᵀJ)⁻¹ in physical units (nonlinear block by the
    delta method), the same in sampler coordinates, σ̂ and fit statistics."""
    from scipy.optimize import least_squares

    k = tgt.k
    if start is None:
        w0 = _profile_grid(tgt)
        X0 = tgt.scaled_regressor(tgt.state(w0))
        th0, *_ = np.linalg.lstsq(X0, tgt.ys, rcond=None)
    else:
        w0, th0 = np.asarray(start["w"], float), np.asarray(start["theta_s"], float)
    big = 1e6 * (1.0 + np.abs(tgt.ys).max())

    def fun(v):
        stopping.poll()
        a, b, g = tgt.physical(v[:k])
        if not tgt._guard(a, b, g):
            return np.full(tgt.n_data, big)
        X = tgt.scaled_regressor(_state(tgt.delta, tgt.x0, a, b, g, tgt.n, tgt.restart,
                                        tgt.msub))
        return X @ v[k:] - tgt.ys

    def jac(v):
        stopping.poll()
        a, b, g = tgt.physical(v[:k])
        J = np.zeros((tgt.n_data, k + 5))
        if not tgt._guard(a, b, g):
            return J
        x, S = _state_sens(tgt.delta, tgt.x0, a, b, g, tgt.n, tgt.restart, tgt.msub)
        X = tgt.scaled_regressor(x)
        J[:, :k] = v[k + X_COLUMN] * (S[:, tgt._cols] @ tgt.nl_jacobian(v[:k])) / tgt.cx
        J[:, k:] = X
        return J

    res = least_squares(fun, np.r_[w0, th0], jac=jac, method="trf", x_scale="jac",
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=500)
    v = res.x
    J = jac(v)
    r = fun(v)
    dof = max(tgt.n_data - (k + 5), 1)
    s2 = float(r @ r) / dof
    JtJ = J.T @ J
    cov_v = s2 * np.linalg.pinv(JtJ)
    G = np.zeros((k + 5, k + 5))
    G[:k, :k] = tgt.nl_jacobian(v[:k])
    G[k:, k:] = np.diag(tgt.sc.y / tgt.sc.col)
    cov = G @ cov_v @ G.T
    a, b, g = tgt.physical(v[:k])
    nl = np.array([a, b, g])[tgt._cols]
    est = np.r_[nl, tgt.sc.theta_to_physical(v[k:])]
    return {"estimate": est, "cov": cov, "w": v[:k], "cov_w": cov_v[:k, :k],
            "theta_s": v[k:], "sigma": math.sqrt(s2) * tgt.sc.y, "dof": dof,
            "nfev": int(res.nfev), "cond_jtj": float(np.linalg.cond(JtJ)),
            "status": int(res.status), "message": str(res.message)}


def substep_stiffness(tgt: BoucWenTarget, ls: Mapping[str, Any]) -> float:
    """The stiffness bound K* [rad^-1] the fit fixes its sub-step counts at
    (BoucWenTarget.fix_substeps): the shared step's own scale at the least-squares estimate, so
    that at the estimate the fixed counts are the ones the rule gives (the recursion is the
    emulator's step bit for bit there) and stay the same wherever the chains go. Away from the
    estimate a sub-step is K·h ≤ 0.05·K/K*, accurate to the step's own tolerance over the
    posterior's width; the target's guard bounds it (MAX_FIXED_SUBSTEP). A margin above the
    estimate (tried: 2×) makes the fit's integrator finer than that of data made with the
    rule, and shifted the LS z-scores of γ and k_h by 0.7 sd over 40 synthetic records."""
    return float(stiffness_bound(*tgt.physical(np.asarray(ls["w"], dtype=float)), tgt.n))


# --- the public entry point ---------------------------------------------------------------------

def posterior_mode(tgt: BoucWenTarget, w0: np.ndarray) -> dict[str, Any]:
    """Mode of the collapsed posterior (BFGS on −log p(w | y) with the analytic gradient, from
    w0) and its Laplace covariance: the inverse of the negative Hessian, by central differences
    of the analytic gradient (BFGS's inverse-Hessian estimate, then the identity, when that is
    not positive definite). Samplers start around it and take it as their starting metric; the
    prior keeps it finite where least squares runs to an extreme (e.g. no visible hysteresis)."""
    from scipy.optimize import minimize

    def f(w):
        stopping.poll()
        lp, g = tgt.logp_grad(w)
        if not np.isfinite(lp):
            return 1e300, np.zeros_like(w)
        return -lp, -g

    w0 = np.asarray(w0, dtype=float)
    if not np.isfinite(tgt.logp(w0)):
        w0 = tgt.to_w(np.r_[[1.0] if tgt.free_alpha else [], tgt.nl_sd[-2:]])
    res = minimize(f, w0, jac=True, method="BFGS", options={"gtol": 1e-6, "maxiter": 500})
    w = res.x
    cov = None
    hinv = np.asarray(getattr(res, "hess_inv", np.eye(tgt.k)), dtype=float)
    h = 1e-3 * np.sqrt(np.clip(np.diag(hinv), 1e-12, 1e4))
    H = np.empty((tgt.k, tgt.k))
    for j in range(tgt.k):
        e = np.zeros(tgt.k)
        e[j] = h[j]
        H[:, j] = (f(w + e)[1] - f(w - e)[1]) / (2.0 * h[j])
    for cand in (0.5 * (H + H.T), None):
        try:
            c = np.linalg.inv(cand) if cand is not None else hinv
            c = 0.5 * (c + c.T)
            if np.all(np.isfinite(c)):
                np.linalg.cholesky(c)
                cov = c
                break
        except np.linalg.LinAlgError:
            continue
    if cov is None:
        cov = np.eye(tgt.k)
    return {"w": w, "cov_w": cov, "logp": -float(res.fun), "nit": int(res.nit),
            "success": bool(res.success)}


def _starts(tgt: BoucWenTarget, mode: dict, chains: int, rng: np.random.Generator,
            spread: float = 2.0) -> np.ndarray:
    """Over-dispersed starting points: the posterior mode plus `spread` × its Laplace
    standard deviations (redrawn if outside the guard)."""
    k = tgt.k
    L = np.linalg.cholesky(mode["cov_w"])
    out = np.empty((chains, k))
    for c in range(chains):
        for _ in range(100):
            w = mode["w"] + spread * (L @ rng.standard_normal(k))
            if np.isfinite(tgt.logp(w)):
                break
        else:
            w = mode["w"]
        out[c] = w
    return out


def fit_bouc_wen(signals: Mapping[str, Any], method: str, n: int = 1, seed: int = 0,
                 **options: Any) -> Fit:
    """Identify Eq. 9 inside Eq. 11 on prepared signals; see the module docstring.

    options: model (Fit.model, default 'eq9'), alpha (fixed α, 1.0), free_alpha (False —
    α·k_h is not identifiable; freeing α leaves it to its prior), prior (BoucWenPrior, used as
    given), tau2_prior ((a0, b0) of the scaled noise variance), v_eps [rad/s], chains (4),
    n_draws, n_warmup, test_signals (held-out signals for rmse_test), level (of the credible or
    confidence intervals, 0.95), and per sampler: hmc —
    target_accept, dense_metric, threads (chains run in that many threads; default one per
    chain up to the CPU count — results do not depend on it); sghmc — batch_size, step_size,
    friction.
    The Fit lists the free nonlinear parameters then k_u, k_h, f_v, D+f_c, C (physical units),
    with draws (chains, draws, p) for the Bayesian methods; timings separate the LS start,
    sampling and the exact linear draws.
    The recursion's sub-step counts are fixed after the first least-squares pass
    (substep_stiffness; extra 'substep_stiffness', 'substeps_per_sample'), so the polished
    least squares, the mode and every sampler see one smooth target; HMC fits report
    diagnostics['warmup_at_step_floor'] per chain (0 on a smooth target)."""
    if method not in METHODS:
        raise ValueError(f"unknown Bouc–Wen method {method!r}; choose one of {METHODS}")
    t_total = time.perf_counter()
    model = str(options.pop("model", "eq9"))
    free_alpha = bool(options.pop("free_alpha", False))
    user_prior = options.pop("prior", None)
    tau2_prior = options.pop("tau2_prior", None)
    tgt = build_target(signals, n=n, alpha=float(options.pop("alpha", 1.0)),
                       free_alpha=free_alpha, prior=user_prior,
                       v_eps=options.pop("v_eps", None),
                       tau2_prior=(1e-3, 1e-3) if tau2_prior is None else tuple(tau2_prior))
    test_signals = options.pop("test_signals", None)
    chains = int(options.pop("chains", 4))
    n_draws = int(options.pop("n_draws", 1000 if method == "hmc" else 4000))
    n_warmup = int(options.pop("n_warmup", 500 if method == "hmc" else 2000))
    threads = int(options.pop("threads", min(chains, os.cpu_count() or 1)))
    level = float(options.pop("level", 0.95))
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), not {level}")
    sampler_opts = {key: options.pop(key) for key in
                    ("target_accept", "dense_metric", "batch_size", "step_size", "friction")
                    if key in options}
    if options:
        raise TypeError(f"unknown options for fit_bouc_wen: {sorted(options)}")
    rng = np.random.default_rng(seed)
    names = tgt.names + list(LINEAR_NAMES)
    units = nonlinear_units(n, free_alpha) + list(LINEAR_UNITS)
    k = tgt.k

    t0 = time.perf_counter()
    ls = least_squares_fit(tgt)          # the shared step's own sub-step rule: the grid start
    k_star = substep_stiffness(tgt, ls)
    tgt.fix_substeps(k_star)             # fixed for the rest of the fit: a smooth target
    ls = least_squares_fit(tgt, start=ls)
    t_ls = time.perf_counter() - t0
    if user_prior is None:
        # g = 1/τ̂_s² and a vague noise prior centred at τ̂_s² (module docstring)
        t2_hat = (ls["sigma"] / tgt.sc.y) ** 2
        a0, b0 = (1e-3, 1e-3 * t2_hat) if tau2_prior is None else tau2_prior
        tgt.set_linear_prior(conjugate_prior(5, a0=a0, b0=b0, g=1.0 / t2_hat))

    def rmse_of(nl, theta, sig):
        if sig is None:
            return None
        d, dd, y = _signals_arrays(sig)
        a, b, g = (nl[0], nl[1], nl[2]) if free_alpha else (tgt.alpha, nl[0], nl[1])
        x = bw_state(d, a, b, g, n, tgt.x0, run=sig.get("run"))
        yh = eq11_regressor(d, dd, x, tgt.v_eps) @ theta
        return float(np.sqrt(np.mean((y - yh) ** 2)))

    base_extra = {"n": n, "alpha_fixed": None if free_alpha else tgt.alpha,
                  "substep_stiffness": k_star,
                  "substeps_per_sample": float(tgt.msub[~tgt.restart].mean()),
                  "sampler_coordinates": (["log alpha"] if free_alpha else [])
                  + ["log(beta+gamma)", "log(beta/(beta+gamma))"]}
    if method == "ls":
        from scipy import stats
        est = ls["estimate"]
        se = np.sqrt(np.clip(np.diag(ls["cov"]), 0, None))
        tq = stats.t.ppf(0.5 + level / 2, ls["dof"])
        return Fit(model=model, method="ls", param_names=names, units=units, mean=est, sd=se,
                   ci_low=est - tq * se, ci_high=est + tq * se, sigma=ls["sigma"],
                   rmse_train=rmse_of(est[:k], est[k:], signals),
                   rmse_test=rmse_of(est[:k], est[k:], test_signals),
                   diagnostics={"cond_jtj": ls["cond_jtj"], "nfev": ls["nfev"],
                                "status": ls["status"], "message": ls["message"]},
                   timings={"sample": t_ls, "total": time.perf_counter() - t_total},
                   extra={**base_extra, "cov": ls["cov"]})

    t0 = time.perf_counter()
    mode = posterior_mode(tgt, ls["w"])
    t_mode = time.perf_counter() - t0
    x0 = _starts(tgt, mode, chains, rng)
    extra: dict[str, Any] = {**base_extra, "ls_estimate": ls["estimate"],
                             "mode_nonlinear": tgt.nl_physical_draws(mode["w"])}
    divergences = None
    t0 = time.perf_counter()
    if method == "hmc":
        from estimator.hmc import hmc
        out = hmc(tgt.logp_grad, x0, n_draws=n_draws, n_warmup=n_warmup, seed=seed,
                  target_accept=float(sampler_opts.get("target_accept", 0.65)),
                  dense_metric=bool(sampler_opts.get("dense_metric", True)),
                  init_metric=mode["cov_w"], threads=threads)
        w_draws = out.draws
        divergences = out.extra["divergences"]
        extra.update({key: out.extra[key] for key in
                      ("step_size", "leapfrog_per_draw", "n_grad", "warmup_divergences",
                       "warmup_seconds", "sampling_seconds", "threads")})
        extra["hmc_wall_seconds"] = out.seconds
    elif method == "mh":
        from estimator.mh import metropolis_hastings
        out = metropolis_hastings(tgt.logp, x0, n_draws=n_draws, n_warmup=n_warmup, seed=seed,
                                  proposal_cov=mode["cov_w"])
        w_draws = out.draws
    else:  # sghmc on the joint target
        from estimator.sghmc import sghmc
        phi0 = np.empty((chains, tgt.joint_dim))
        phi0[:, :k] = x0
        phi0[:, k:k + 5] = ls["theta_s"]
        phi0[:, -1] = 2.0 * math.log(ls["sigma"] / tgt.sc.y)
        out = sghmc(tgt.joint_grad_u, tgt.n_data, phi0, n_draws=n_draws, n_warmup=n_warmup,
                    seed=seed, batch_size=sampler_opts.get("batch_size"),
                    step_size=sampler_opts.get("step_size"),
                    friction=sampler_opts.get("friction"))
        w_draws = out.draws[:, :, :k]
        extra.update({key: out.extra[key] for key in ("learning_rate", "friction",
                                                      "batch_size", "gradient_noise_share")})
    t_sample = time.perf_counter() - t0

    t0 = time.perf_counter()
    C, D = w_draws.shape[:2]
    nl_phys = tgt.nl_physical_draws(w_draws)
    if method == "sghmc":
        theta = tgt.sc.theta_to_physical(out.draws[:, :, k:k + 5])
        tau2 = np.exp(out.draws[:, :, -1]) * tgt.sc.y ** 2
    else:
        th, t2 = tgt.draw_linear(w_draws.reshape(C * D, k), rng)
        theta, tau2 = th.reshape(C, D, 5), t2.reshape(C, D)
    t_linear = time.perf_counter() - t0
    draws = np.concatenate([nl_phys, theta], axis=2)
    mean = draws.reshape(-1, draws.shape[2]).mean(axis=0)
    extra["seconds_linear_draws"] = t_linear
    from estimator.convergence import fit_from_draws
    fit = fit_from_draws(model, method, names, units, draws, np.sqrt(tau2),
                         rmse_train=rmse_of(mean[:k], mean[k:], signals),
                         rmse_test=rmse_of(mean[:k], mean[k:], test_signals),
                         seconds=out.seconds + t_linear, accept_rate=out.accept_rate,
                         extra=extra, level=level,
                         timings={"least_squares_start": t_ls, "mode": t_mode,
                                  "sample": t_sample,
                                  "linear_draws": t_linear,
                                  "total": time.perf_counter() - t_total})
    if divergences is not None:
        fit.diagnostics["divergences"] = np.asarray(divergences)
    if method == "hmc":
        # warm-up iterations whose step size the floor raised (estimator.hmc): 0 on a smooth
        # target; non-zero says the log density jumps where the chains went
        fit.diagnostics["warmup_at_step_floor"] = np.asarray(out.extra["warmup_at_step_floor"])
    return fit
