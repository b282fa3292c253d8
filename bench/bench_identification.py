"""Identification benchmark: our samplers next to NumPyro's NUTS on the same posteriors, in one run.

    python bench/bench_identification.py            # the full benchmark (several minutes)
    python bench/bench_identification.py --quick    # small sizes, to check it runs

(a) Eq. 11 with x known (linear, conjugate Normal–Inverse-Gamma posterior) at N = 20 000 and
    200 000: our exact sampler (estimator.exact: nig_posterior + nig_draws) against NumPyro NUTS
    on (θ_s, log τ_s²) — once with the full-data likelihood (the usual way to write the model),
    once with sufficient statistics (XᵀX, Xᵀy, yᵀy: cost independent of N, the peer's best).
    Our time is the whole path from the data: the fixed cost (one BLAS pass for XᵀX, Xᵀy, yᵀy
    and an O(p³) update) plus one vectorised block of independent draws; both are reported
    separately, and ESS/s is given at NUTS's number of draws and at AMORTISED_DRAWS.
(b) Eq. 11 with the Bouc–Wen β, γ unknown (α fixed at 1: only α·k_h is identifiable) at
    N = 20 000: our HMC on the collapsed posterior (estimator.bouc_wen, analytic sensitivities)
    against NumPyro NUTS on the same collapsed target written in JAX (linear block and noise
    integrated out, the recursion in lax.scan with the same sub-stepping, forward-mode AD,
    dense mass matrix, same unconstrained coordinates and starting point). The reference is an
    exact quadrature of the collapsed posterior on a fine grid, independent of both samplers.
(c) SGHMC at N = 200 000 (Eq. 11, x known; the synthetic twist has a step at 0.1·T, so two
    rows carry ~90 % of the information on D+f_c — the case that broke the earlier
    gradient-noise estimate from 16 000 random rows): wall time until the pooled draws' mean is within
    0.1 posterior sd of the exact mean and their sd within 10 % of the exact sd, for every
    coordinate, next to full-batch Metropolis–Hastings (E1's MH on sufficient statistics, and a
    plain MH evaluating the full-data likelihood each step).

(d) The Bouc–Wen fit on a two-run pair at the PLC's 20 Hz (emulated scheme 1 at 300 and 3000
    r/min, the state restarting at each run): our HMC through fit_bouc_wen next to NumPyro NUTS
    on the same collapsed posterior (the fit's fixed sub-step counts, restarts and prior),
    the two alternated --repeats times with seed 0 (same draws each time) and their median wall
    times compared: a single pair of runs moved the ratio from 6.3× to 2.7× with the load.
(e) The whole `rig reproduce` (`--quick` with --quick): wall and CPU seconds.
    `--only d|e|de` runs just those; without NumPyro (the `bench` extra) (d) runs without its
    peer and (e) alone follows.

ESS is the bulk ESS (rank-normalised split R-hat machinery of estimator.convergence, the same
for every sampler), minimum over parameters; ESS/s divides by the sampler's wall time warm-up
included and compilation excluded (JIT/compile time is reported in its own column). NumPyro
runs its chains in parallel on the host devices; our samplers run their chains one after the
other on one core (single-threaded BLAS), except the HMC of (b) and (d), whose chains run in
threads. Timings are medians over --repeats runs where stated.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from pathlib import Path

CHAINS = 2
"""Chains in (a) and (c)."""
CHAINS_B = 4
"""Chains in (b), where split R-hat < 1.01 is part of the target (more chains, more margin)."""
os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "")
                           + f" --xla_force_host_platform_device_count={CHAINS_B}").strip()
# Our code runs single-threaded BLAS (set before numpy loads): on this shared 2-core machine
# OpenBLAS's thread hand-offs under load cost milliseconds per small product. An explicit
# setting in the environment wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
AMORTISED_DRAWS = 200_000
"""(a) also reports our exact sampler at this many draws, where the per-draw cost dominates."""

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from estimator.bouc_wen import (fit_bouc_wen, least_squares_fit, posterior_mode,  # noqa: E402
                                substep_stiffness)
from estimator.bouc_wen_target import build_target  # noqa: E402
from estimator.bouc_wen_kernel import bw_state  # noqa: E402
from estimator.convergence import ess_bulk, split_rhat  # noqa: E402
from estimator.exact import nig_draws, nig_posterior  # noqa: E402
from estimator.priors import Scaling, conjugate_prior  # noqa: E402
from core.params import JointParams  # noqa: E402
from core.terms import eq11_regressor  # noqa: E402

P = JointParams()
THETA = np.array([P.k_u, P.k_h, 300.0, P.D + P.f_c, 500.0])


# --- machine and helpers ------------------------------------------------------------------------

def machine() -> str:
    model = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (f"{model}; {os.cpu_count()} logical cores; load average at start {load:.1f}; "
            f"Python {platform.python_version()}")


def synthetic(n: int, seed: int = 0, noise: float = 150.0) -> dict:
    """Eq. 11 torque from the shared terms on a loading–unloading twist with minor loops."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 100.0 * n / 1500.0, n)
    T = t[-1]
    env = 0.6 + 0.4 * np.sin(2 * np.pi * t / (2.3 * T / 1.0) + seed)
    delta = 8.7e-3 * (0.5 - 0.5 * np.cos(2 * np.pi * t / (T / 2.0))) * env
    delta += 4e-4 * np.sin(2 * np.pi * t / (T / 14.0)) * (t > 0.1 * T)
    dd = np.gradient(delta, t)
    x = bw_state(delta, 1.0, P.beta, P.gamma, 1)
    y = eq11_regressor(delta, dd, x, P.v_eps) @ THETA + noise * rng.standard_normal(n)
    return {"t": t, "torsion": delta, "torsion_rate": dd, "torque": y, "x": x}


def median(xs):
    return float(np.median(np.asarray(xs, dtype=float)))


def fmt(v, nd=3):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    if abs(v) >= 1e4 or (abs(v) < 1e-2 and v != 0):
        return f"{v:.3g}"
    return f"{v:.{nd}g}"


def rfmt(v):
    return "—" if v is None or not math.isfinite(v) else f"{v:.4f}"


ROWS: list[dict] = []


def row(section, sampler, N, ess_s=None, compile_s=None, run_s=None, ess=None, rhat=None,
        mean_err=None, sd_ratio=None, note=""):
    r = dict(section=section, sampler=sampler, N=N, ess_s=ess_s, compile_s=compile_s,
             run_s=run_s, ess=ess, rhat=rhat, mean_err=mean_err, sd_ratio=sd_ratio, note=note)
    ROWS.append(r)
    print(f"  {sampler:<34} N={N:<7} ESS/s={fmt(ess_s):>9} compile={fmt(compile_s):>6}s "
          f"run={fmt(run_s):>7}s minESS={fmt(ess):>7} R-hat={rfmt(rhat):>6} "
          f"|mean err|/sd={fmt(mean_err):>6} sd ratio={fmt(sd_ratio):>6} {note}", flush=True)
    return r


def accuracy(draws: np.ndarray, mean: np.ndarray, sd: np.ndarray) -> tuple[float, float]:
    """max over coordinates of |mean − exact mean|/exact sd, and the sd ratio furthest from 1."""
    flat = draws.reshape(-1, draws.shape[-1])
    err = np.abs(flat.mean(axis=0) - mean) / sd
    ratio = flat.std(axis=0, ddof=1) / sd
    return float(err.max()), float(ratio[np.argmax(np.abs(ratio - 1))])


_COMPILE_SECONDS = [0.0]


def _compile_listener(name: str, duration: float, **_kw) -> None:
    # JAX reports tracing, lowering and XLA compilation durations as monitoring events
    if name.startswith("/jax/core/compile/"):
        _COMPILE_SECONDS[0] += duration


def run_numpyro(make_mcmc, init, seed, n_warmup, n_samples, extra_seconds=0.0):
    """Time a NumPyro run without its compilation. With chain_method='parallel' NumPyro
    traces and compiles again on every run, so the compile time is measured inside the run
    itself, as the sum of JAX's '/jax/core/compile/*' monitoring events (trace, lowering, XLA
    backend compile), and subtracted from the run's wall time. Returns (draws (chains, draws,
    d), seconds without compilation, compile seconds)."""
    import jax
    import jax.numpy as jnp
    m = make_mcmc(n_warmup, n_samples)
    _COMPILE_SECONDS[0] = 0.0
    t0 = time.perf_counter()
    m.run(jax.random.PRNGKey(seed), init_params=jnp.asarray(init))
    draws = np.asarray(m.get_samples(group_by_chain=True))
    total = time.perf_counter() - t0
    compile_s = _COMPILE_SECONDS[0]
    return draws, max(total - compile_s, 1e-9) + extra_seconds, compile_s


# --- the conjugate linear posterior (a), (c) -----------------------------------------------------

class LinearProblem:
    """Eq. 11 with x known: scaled X, y, the conjugate prior of estimator.bouc_wen's rule and
    the exact posterior (θ_s marginals Student-t, s = log τ_s² marginal log-Inv-Gamma)."""

    def __init__(self, n: int, seed: int = 0):
        from scipy.special import digamma, polygamma
        d = synthetic(n, seed)
        X = eq11_regressor(d["torsion"], d["torsion_rate"], d["x"], P.v_eps)
        self.sc = Scaling.from_data(X, d["torque"])
        self.X = np.ascontiguousarray(self.sc.x_to_scaled(X))
        self.y = self.sc.y_to_scaled(d["torque"])
        coef, *_ = np.linalg.lstsq(self.X, self.y, rcond=None)
        r = self.y - self.X @ coef
        t2 = float(r @ r) / (n - 5)
        self.prior = conjugate_prior(5, a0=1e-3, b0=1e-3 * t2, g=1.0 / t2)
        self.post = nig_posterior(self.X, self.y, self.prior.mean, self.prior.cov,
                                  self.prior.a0, self.prior.b0)
        a, b = self.post.a, self.post.b
        self.mean = np.r_[self.post.mean, math.log(b) - digamma(a)]
        self.sd = np.r_[np.sqrt(np.diag(self.post.theta_cov)), math.sqrt(polygamma(1, a))]
        self.n = n

    def exact_draws(self, m: int, seed: int) -> tuple[np.ndarray, float, float]:
        """m independent draws of (θ_s, s) from the data: the posterior (one BLAS pass for
        XᵀX, Xᵀy, yᵀy, then O(p³)) and one vectorised block of draws. Returns the draws, the
        fixed seconds (posterior) and the draw seconds."""
        t0 = time.perf_counter()
        post = nig_posterior(self.X, self.y, self.prior.mean, self.prior.cov, self.prior.a0,
                             self.prior.b0)
        t1 = time.perf_counter()
        th, t2 = nig_draws(post, m, np.random.default_rng(seed))
        t2_ = time.perf_counter()
        return np.concatenate([th, np.log(t2)[:, None]], axis=1), t1 - t0, t2_ - t1


def numpyro_linear(prob: LinearProblem, sufficient: bool, n_warmup: int, n_samples: int,
                   seed: int):
    """NumPyro NUTS on φ = (θ_s, s = log τ_s²) of the conjugate model (potential written in
    JAX; dense mass matrix), rescaled to the posterior's scale: φ = φ̂ + se ⊙ u with the
    least-squares estimate φ̂ and its standard errors, started near u = 0. The sufficient
    statistics' computation counts in its time (ours counts its own pass over the data)."""
    import jax
    import jax.numpy as jnp
    from numpyro.infer import MCMC, NUTS

    X, y = jnp.asarray(prob.X), jnp.asarray(prob.y)
    t0 = time.perf_counter()
    G, Xty, yty = X.T @ X, X.T @ y, float(prob.y @ prob.y)
    jax.block_until_ready(G)
    t_stats = time.perf_counter() - t0 if sufficient else 0.0
    n, p = prob.X.shape
    a0, b0 = prob.prior.a0, prob.prior.b0
    P0 = jnp.asarray(np.linalg.inv(prob.prior.cov))
    m0 = jnp.asarray(prob.prior.mean)
    coef, *_ = np.linalg.lstsq(prob.X, prob.y, rcond=None)
    res = prob.y - prob.X @ coef
    s2 = float(res @ res) / (n - p)
    center = np.r_[coef, math.log(s2)]
    scale = np.r_[np.sqrt(s2 * np.diag(np.linalg.inv(prob.X.T @ prob.X))), math.sqrt(2.0 / n)]
    c_j, s_j = jnp.asarray(center), jnp.asarray(scale)

    def potential(u):
        phi = c_j + s_j * u
        th, s = phi[:p], phi[p]
        if sufficient:
            rss = yty - 2.0 * th @ Xty + th @ G @ th
        else:
            r = y - X @ th
            rss = r @ r
        d = th - m0
        return (0.5 * n + a0 + 0.5 * p) * s + (0.5 * rss + b0 + 0.5 * d @ P0 @ d) * jnp.exp(-s)

    def make(nw, ns):
        return MCMC(NUTS(potential_fn=potential, dense_mass=True, target_accept_prob=0.8),
                    num_warmup=nw, num_samples=ns, num_chains=CHAINS, chain_method="parallel",
                    progress_bar=False)
    init = 0.5 * np.random.default_rng(seed).standard_normal((CHAINS, p + 1))
    draws, sec, comp = run_numpyro(make, init, seed, n_warmup, n_samples, extra_seconds=t_stats)
    return center + scale * draws, sec, comp


def section_a(sizes, repeats, nuts_warmup, nuts_samples):
    print("\n(a) Eq. 11 with x known — exact posterior vs NumPyro NUTS (NUTS keeps "
          f"{CHAINS}×{nuts_samples} draws; ours at the same number and at {AMORTISED_DRAWS})",
          flush=True)
    out = {}
    for n in sizes:
        prob = LinearProblem(n)
        ours = {}
        for m in (CHAINS * nuts_samples, AMORTISED_DRAWS):
            res = []
            for r in range(repeats):
                d, fixed, per = prob.exact_draws(m, seed=r)
                draws = d.reshape(CHAINS, m // CHAINS, -1)
                ess = float(np.nanmin(ess_bulk(draws)))
                res.append((ess / (fixed + per), fixed, per, ess, draws))
            k = int(np.argsort([x[0] for x in res])[len(res) // 2])
            draws = res[k][4]
            fixed, draw_s = median([x[1] for x in res]), median([x[2] for x in res])
            err, ratio = accuracy(draws, prob.mean, prob.sd)
            ours[m] = row("a", f"ours: exact NIG, {m} draws", n, ess_s=median([x[0] for x in res]),
                          compile_s=0.0, run_s=fixed + draw_s, ess=res[k][3],
                          rhat=float(np.nanmax(split_rhat(draws))), mean_err=err,
                          sd_ratio=ratio,
                          note=(f"median of {repeats}; fixed (posterior from data) "
                                f"{fixed * 1e3:.2f} ms + draws {draw_s * 1e3:.2f} ms = "
                                f"{draw_s / m * 1e9:.0f} ns/draw"))
        peers = []
        for suff in (False, True):
            draws, sec, comp = numpyro_linear(prob, suff, nuts_warmup, nuts_samples, seed=0)
            ess = float(np.nanmin(ess_bulk(draws)))
            err, ratio = accuracy(draws, prob.mean, prob.sd)
            r = row("a", "NumPyro NUTS " + ("(sufficient stats)" if suff else "(full data)"), n,
                    ess_s=ess / sec, compile_s=comp, run_s=sec, ess=ess,
                    rhat=float(np.nanmax(split_rhat(draws))), mean_err=err, sd_ratio=ratio,
                    note="warm-up+sampling, compile excluded")
            peers.append(r)
        out[n] = (ours, peers)
    return out


# --- (b) the Bouc–Wen posterior ------------------------------------------------------------------

def grid_reference(tgt, mode, half_width=7.0, points=161):
    """Exact moments of (β, γ) by quadrature of the collapsed posterior on a grid of the
    sampler coordinates, ±half_width Laplace sd around the mode."""
    sd = np.sqrt(np.diag(mode["cov_w"]))
    L = np.linalg.cholesky(mode["cov_w"])
    u = np.linspace(-half_width, half_width, points)
    U1, U2 = np.meshgrid(u, u, indexing="ij")
    W = mode["w"][None, None, :] + np.einsum("ij,abj->abi", L, np.stack([U1, U2], axis=-1))
    lp = np.array([[tgt.logp(W[i, j]) for j in range(points)] for i in range(points)])
    lp -= np.nanmax(lp)
    w8 = np.exp(lp)
    w8 /= w8.sum()
    nl = tgt.nl_physical_draws(W)
    mean = np.einsum("ab,abk->k", w8, nl)
    var = np.einsum("ab,abk->k", w8, (nl - mean) ** 2)
    edge = max(w8[0].sum(), w8[-1].sum(), w8[:, 0].sum(), w8[:, -1].sum())
    del sd
    return mean, np.sqrt(var), edge


def numpyro_bouc_wen(tgt, mode, n_warmup, n_samples, seed):
    """NumPyro NUTS on the collapsed Bouc–Wen posterior: the same target as tgt.logp, in JAX,
    rescaled to the posterior's scale (w = ŵ + L·u with our posterior mode ŵ and the Cholesky
    factor L of its Laplace covariance), started near u = 0 like our chains."""
    import jax
    import jax.numpy as jnp
    from jax import lax
    from jax.scipy.special import gammaln
    from numpyro.infer import MCMC, NUTS

    dinc = jnp.asarray(np.diff(tgt.delta))
    # the target's own sub-step counts (fixed for a fit: 0 = the shared step's rule) and its
    # restarts at the first sample of each run of a concatenated record
    mfix = jnp.asarray(tgt.msub[1:].astype(np.int32))
    rst = jnp.asarray(tgt.restart[1:])
    Xs, ys = jnp.asarray(tgt.Xs), jnp.asarray(tgt.ys)
    cx, n_bw = tgt.cx, tgt.n
    m0, V0 = jnp.asarray(tgt.m0), jnp.asarray(tgt.V0)
    V0inv = jnp.linalg.inv(V0)
    ld0 = float(np.linalg.slogdet(tgt.V0)[1])
    a0, b0 = tgt.a0, tgt.b0
    nlm, nls = jnp.asarray(tgt.nl_mean), jnp.asarray(tgt.nl_sd)
    n = tgt.n_data

    def bw_x(beta, gamma):
        def sub(x, s, h):
            ax = jnp.abs(x)
            return x + (1.0 - beta * s * ax ** (n_bw - 1) * x - gamma * ax ** n_bw) * h

        def step(x, inp):   # core.terms.bouc_wen_step, sub-steps and all
            d, mf, restart = inp
            s = jnp.where(d >= 0.0, 1.0, -1.0)
            scale = (jnp.abs(beta) + jnp.abs(gamma)) * jnp.maximum(jnp.abs(x), 1e-3) ** (n_bw - 1)
            m = jnp.where(mf > 0, mf, jnp.floor(jnp.abs(d) * scale / 0.05).astype(jnp.int32) + 1)
            h = d / m
            x = lax.cond(m == 1, lambda x: sub(x, s, h),
                         lambda x: lax.fori_loop(0, m, lambda i, x: sub(x, s, h), x), x)
            x = jnp.where(restart, 0.0, x)
            return x, x
        _, xs = lax.scan(step, 0.0, (dinc, mfix, rst))
        return jnp.concatenate([jnp.zeros(1), xs])

    w_hat, Lc = jnp.asarray(mode["w"]), jnp.asarray(np.linalg.cholesky(mode["cov_w"]))

    def potential(u):
        w = w_hat + Lc @ u
        sig, r_ = jnp.exp(w[0]), jnp.exp(w[1])
        beta, gamma = sig * r_, sig * (1.0 - r_)
        X = Xs.at[:, 1].set(bw_x(beta, gamma) / cx)
        prec = V0inv + X.T @ X
        L = jnp.linalg.cholesky(prec)
        mn = jax.scipy.linalg.cho_solve((L, True), V0inv @ m0 + X.T @ ys)
        r = ys - X @ mn
        d = mn - m0
        an = a0 + 0.5 * n
        bn = b0 + 0.5 * (r @ r + d @ V0inv @ d)
        ldn = -2.0 * jnp.sum(jnp.log(jnp.diag(L)))
        lm = (-0.5 * n * jnp.log(2 * jnp.pi) + 0.5 * (ldn - ld0) + a0 * jnp.log(b0)
              - an * jnp.log(bn) + gammaln(an) - gammaln(a0))
        z = (jnp.array([beta, gamma]) - nlm) / nls
        return -(lm - 0.5 * z @ z + 2.0 * w[0] + w[1])

    u0 = np.random.default_rng(seed).standard_normal((CHAINS_B, 2))
    w0 = mode["w"] + u0 @ np.linalg.cholesky(mode["cov_w"]).T
    # same target, up to the constant log|L| of the linear change of variables
    check = -float(potential(jnp.asarray(u0[0])))
    if not np.isclose(check, tgt.logp(w0[0]), rtol=1e-9, atol=1e-6):
        raise RuntimeError(f"the JAX target differs from ours: {check} vs {tgt.logp(w0[0])}")
    def make(nw, ns):
        return MCMC(NUTS(potential_fn=potential, dense_mass=True, target_accept_prob=0.8,
                         forward_mode_differentiation=True),
                    num_warmup=nw, num_samples=ns, num_chains=CHAINS_B, chain_method="parallel",
                    progress_bar=False)
    draws, sec, comp = run_numpyro(make, u0, seed, n_warmup, n_samples)
    w = mode["w"] + draws @ np.linalg.cholesky(mode["cov_w"]).T
    return w, sec, comp


def fit_target(sig):
    """The collapsed target exactly as fit_bouc_wen builds it (sub-step counts fixed after a
    first least-squares pass, the prior centred on the LS noise level) and its mode."""
    tgt = build_target(sig)
    ls = least_squares_fit(tgt)
    tgt.fix_substeps(substep_stiffness(tgt, ls))
    ls = least_squares_fit(tgt, start=ls)
    t2 = (ls["sigma"] / tgt.sc.y) ** 2
    tgt.set_linear_prior(conjugate_prior(5, a0=1e-3, b0=1e-3 * t2, g=1.0 / t2))
    return tgt, posterior_mode(tgt, ls["w"])


def section_b(n, repeats, hmc_warmup, hmc_draws, nuts_warmup, nuts_samples):
    print(f"\n(b) Eq. 11 with β, γ unknown (α fixed = 1) — our HMC vs NumPyro NUTS, N={n}; "
          f"both {CHAINS_B} chains × ({hmc_warmup} warm-up + {hmc_draws} draws)", flush=True)
    sig = synthetic(n, seed=0)
    # JIT warm-up of our numba kernels (reported as our compile time)
    t0 = time.perf_counter()
    small = synthetic(300, seed=9)
    fit_bouc_wen(small, "hmc", chains=1, n_warmup=20, n_draws=20)
    compile_ours = time.perf_counter() - t0
    tgt, mode = fit_target(sig)
    t0 = time.perf_counter()
    ref_mean, ref_sd, edge = grid_reference(tgt, mode)
    t_ref = time.perf_counter() - t0
    print(f"  reference: grid quadrature (161², ±7 Laplace sd, edge mass {edge:.1e}, "
          f"{t_ref:.1f} s): β = {ref_mean[0]:.2f} ± {ref_sd[0]:.2f}, "
          f"γ = {ref_mean[1]:.2f} ± {ref_sd[1]:.2f} (truth {P.beta:g}, {P.gamma:g})", flush=True)
    res = []
    for r in range(repeats):
        fit = fit_bouc_wen(sig, "hmc", seed=r, chains=CHAINS_B, n_warmup=hmc_warmup,
                           n_draws=hmc_draws, threads=min(CHAINS_B, os.cpu_count() or 1))
        sec = fit.extra["hmc_wall_seconds"]
        d = fit.draws[:, :, :2]
        res.append((float(np.nanmin(ess_bulk(d))) / sec, sec, fit))
    k = int(np.argsort([x[0] for x in res])[len(res) // 2])
    fit = res[k][2]
    d = fit.draws[:, :, :2]
    err, ratio = accuracy(d, ref_mean, ref_sd)
    ours = row("b", "ours: HMC (collapsed, analytic grad)", n,
               ess_s=median([x[0] for x in res]), compile_s=compile_ours,
               run_s=median([x[1] for x in res]), ess=float(np.nanmin(ess_bulk(d))),
               rhat=float(np.nanmax(split_rhat(d))), mean_err=err, sd_ratio=ratio,
               note=(f"median of {repeats}; warm-up+sampling, {CHAINS_B} chains in threads; "
                     f"not counted: LS start {fit.timings['least_squares_start']:.2f} s, "
                     f"mode {fit.timings['mode']:.2f} s (NumPyro gets the mode and its Laplace "
                     f"scale for free), exact linear draws {fit.timings['linear_draws']:.2f} s"))
    draws_w, sec, comp = numpyro_bouc_wen(tgt, mode, nuts_warmup, nuts_samples, seed=0)
    nl = tgt.nl_physical_draws(draws_w)
    err, ratio = accuracy(nl, ref_mean, ref_sd)
    ess = float(np.nanmin(ess_bulk(nl)))
    peer = row("b", "NumPyro NUTS (collapsed, fwd-mode)", n, ess_s=ess / sec, compile_s=comp,
               run_s=sec, ess=ess, rhat=float(np.nanmax(split_rhat(nl))), mean_err=err,
               sd_ratio=ratio, note="warm-up+sampling, compiled")
    return ours, peer


# --- (c) SGHMC vs full-batch MH -------------------------------------------------------------------

def time_to_accuracy(draws, mean, sd, t_of_k, every=50):
    """Smallest k (draws kept per chain) from which on, at every checkpoint, the pooled draws'
    mean is within 0.1 sd and their sd within 10 % on every coordinate; its wall time."""
    C, D, _ = draws.shape
    ks = list(range(every, D + 1, every))
    ok = []
    for k in ks:
        flat = draws[:, :k].reshape(-1, draws.shape[2])
        e = np.abs(flat.mean(axis=0) - mean) / sd
        s = flat.std(axis=0, ddof=1) / sd
        ok.append(bool(np.all(e <= 0.1) and np.all(np.abs(s - 1) <= 0.1)))
    for i in range(len(ks)):
        if all(ok[i:]):
            return ks[i], t_of_k(ks[i])
    return None, None


def section_c(n, sg_warmup, sg_draws, mh_warmup, mh_draws, seed=0):
    from estimator.linear_posterior import LinearPosterior
    from estimator.mh import metropolis_hastings
    from estimator.sghmc import sghmc
    print(f"\n(c) SGHMC at N={n} (Eq. 11, x known): time to |mean err| ≤ 0.1 sd and sd within "
          "10 %", flush=True)
    prob = LinearProblem(n, seed=1)
    lp = LinearPosterior(prob.X, prob.y, prob.prior)
    rng = np.random.default_rng(seed)
    x0 = lp.start(CHAINS, rng)
    out = sghmc(lp.grad_u, lp.n, x0, n_draws=sg_draws, n_warmup=sg_warmup, seed=seed)
    ex = out.extra
    setup = ex["seconds_laplace"] + ex["seconds_noise_estimate"]
    per_it = ex["seconds_sampling"] / (CHAINS * (sg_warmup + sg_draws))
    k, t = time_to_accuracy(out.draws, prob.mean, prob.sd,
                            lambda k: setup + CHAINS * (sg_warmup + k) * per_it)
    err, ratio = accuracy(out.draws, prob.mean, prob.sd)
    rows = [row("c", "SGHMC (auto, 10 % batches)", n, ess_s=float(np.nanmin(ess_bulk(out.draws)))
                / out.seconds, run_s=t, ess=float(np.nanmin(ess_bulk(out.draws))),
                rhat=float(np.nanmax(split_rhat(out.draws))), mean_err=err, sd_ratio=ratio,
                note=(f"time-to-accuracy {fmt(t)} s at {k} draws/chain (setup {setup:.2f} s: "
                      f"Laplace {ex['seconds_laplace']:.2f} s, gradient noise "
                      f"{ex['seconds_noise_estimate']:.2f} s over "
                      f"{ex['noise_estimate'].get('points')} points × "
                      f"{ex['noise_estimate'].get('batches_per_point')} batches covering all rows; "
                      f"ε={ex['learning_rate']:.3g}, α={ex['friction']:.3g}, "
                      f"b={ex['batch_size']}, noise share {ex['gradient_noise_share']:.2f})"))]

    def mh_run(logp, label):
        o = metropolis_hastings(logp, x0, n_draws=mh_draws, n_warmup=mh_warmup, seed=seed,
                                proposal_cov=lp.laplace_cov())
        per = o.seconds / (mh_warmup + mh_draws)
        kk, tt = time_to_accuracy(o.draws, prob.mean, prob.sd, lambda k: (mh_warmup + k) * per)
        e, s = accuracy(o.draws, prob.mean, prob.sd)
        ess = float(np.nanmin(ess_bulk(o.draws)))
        return row("c", label, n, ess_s=ess / o.seconds, run_s=tt, ess=ess,
                   rhat=float(np.nanmax(split_rhat(o.draws))), mean_err=e, sd_ratio=s,
                   note=f"time-to-accuracy {fmt(tt)} s at {kk} draws/chain")

    rows.append(mh_run(lp.logp, "MH full-batch (sufficient stats)"))

    def logp_full(z):
        theta, s = z[:-1], float(z[-1])
        if abs(s) > 700:
            return -np.inf
        r = lp.y - lp.X @ theta
        d0 = theta - lp.m0
        return float(-(0.5 * lp.n + lp.a0 + 0.5 * lp.p) * s
                     - (0.5 * float(r @ r) + lp.b0 + 0.5 * float(d0 @ lp.P0 @ d0)) * math.exp(-s))
    rows.append(mh_run(logp_full, "MH full-batch (full-data likelihood)"))
    return rows


# --- (d) the Bouc–Wen fit on a protocol-rate pair, (e) the whole `rig reproduce` -------------------

def protocol_pair(seed: int = 7) -> dict:
    """Scheme 1 at 300 and 3000 r/min sampled at 20 Hz (the demo's PLC rate), prepared and
    concatenated as `rig identify` does (the state restarts at each run)."""
    from core.schemes import Scheme1
    from estimator.identify import bouc_wen_signals
    from estimator.preprocess import concat_signals, prepare
    from simulators.config import EmulatorConfig
    from simulators.offline import simulate
    runs = [simulate(Scheme1(motor_speed_rpm=v), EmulatorConfig(seed=seed + i, sample_rate_hz=20.0))
            for i, v in enumerate((300.0, 3000.0))]
    return concat_signals([prepare(r, bouc_wen_signals(r)) for r in runs])


def section_d(hmc_warmup, hmc_draws, nuts_warmup, nuts_samples, numpyro_ok, repeats=1):
    """Our HMC and NumPyro NUTS on the pair, alternated `repeats` times with the same seed (the
    draws, hence ESS and R-hat, are the same each time; only the wall time varies with the
    machine's load, so the two are timed side by side and the medians compared)."""
    sig = protocol_pair()
    n = len(sig["torque"])
    print(f"\n(d) the Bouc–Wen fit on a protocol-rate pair (scheme 1 at 300 + 3000 r/min, 20 Hz, "
          f"N={n}): our HMC vs NumPyro NUTS on the same collapsed posterior (same sub-step "
          f"counts, restarts and prior); both {CHAINS_B} chains × ({hmc_warmup} warm-up + "
          f"{hmc_draws} draws), seed 0, timed {repeats}× alternately (medians)", flush=True)
    tgt, mode = fit_target(sig) if numpyro_ok else (None, None)
    ours_s, peer_s, comp_s = [], [], []
    fit = nl = None
    for _ in range(repeats):
        fit = fit_bouc_wen(sig, "hmc", seed=0, chains=CHAINS_B, n_warmup=hmc_warmup,
                           n_draws=hmc_draws, threads=min(CHAINS_B, os.cpu_count() or 1))
        ours_s.append(fit.extra["hmc_wall_seconds"])
        if numpyro_ok:
            draws_w, sec, comp = numpyro_bouc_wen(tgt, mode, nuts_warmup, nuts_samples, seed=0)
            nl = tgt.nl_physical_draws(draws_w)
            peer_s.append(sec)
            comp_s.append(comp)
    sec = median(ours_s)
    d = fit.draws[:, :, :2]
    ess = float(np.nanmin(ess_bulk(d)))
    times = ", ".join(f"{t:.2f}" for t in ours_s)
    ours = row("d", "ours: HMC (collapsed, analytic grad)", n, ess_s=ess / sec, run_s=sec,
               ess=ess, rhat=float(np.nanmax(split_rhat(d))),
               note=(f"run times {times} s; all 7 parameters: max R-hat "
                     f"{np.nanmax(fit.diagnostics['rhat']):.4f}, "
                     f"min bulk ESS {np.nanmin(fit.diagnostics['ess_bulk']):.0f}; warm-up "
                     f"iterations at the step floor "
                     f"{int(np.sum(fit.diagnostics['warmup_at_step_floor']))}; "
                     f"{fit.extra['substeps_per_sample']:.2f} sub-steps per sample"))
    if not numpyro_ok:
        print("    NumPyro not installed (`pip install -e '.[bench]'`): no peer measured")
        return ours, None
    sec = median(peer_s)
    ess = float(np.nanmin(ess_bulk(nl)))
    times = ", ".join(f"{t:.2f}" for t in peer_s)
    peer = row("d", "NumPyro NUTS (collapsed, fwd-mode)", n, ess_s=ess / sec,
               compile_s=median(comp_s), run_s=sec, ess=ess,
               rhat=float(np.nanmax(split_rhat(nl))),
               note=f"warm-up+sampling, compiled; run times {times} s")
    return ours, peer


def section_e(quick):
    """The whole `rig reproduce` (campaign, every fit, Sobol, figures' data): wall and CPU."""
    from api.paper_reproduction import Settings, reproduce
    print(f"\n(e) the whole `rig reproduce{' --quick' if quick else ''}`", flush=True)
    t0, c0 = time.perf_counter(), time.process_time()
    rep, _ = reproduce(Settings(quick=quick))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    parts = ", ".join(f"{k} {v:.1f} s" for k, v in rep["timings"].items() if k != "total")
    print(f"    wall {wall:.1f} s, CPU {cpu:.1f} s ({parts}); load average before/after: see "
          f"the header and {os.getloadavg()[0]:.1f}")
    return {"wall_s": wall, "cpu_s": cpu}


# --- main -----------------------------------------------------------------------------------------

def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (checks the script runs)")
    ap.add_argument("--repeats", type=int, default=3,
                    help="repeats of our HMC runs in (b), of both samplers in (d) (median)")
    ap.add_argument("--exact-repeats", type=int, default=11,
                    help="repeats of our exact sampler in (a) (milliseconds each; median)")
    ap.add_argument("--only", choices=("d", "e", "de"), default=None,
                    help="only section (d) the Bouc–Wen pair, (e) `rig reproduce`, or both")
    args = ap.parse_args(argv)
    print("Identification benchmark —", machine())
    q = args.quick
    try:
        import numpyro
    except ImportError:
        numpyro = None
    if numpyro is None:
        print("NumPyro is not installed (`pip install -e '.[bench]'`): sections (a)–(c) need it; "
              "(d) runs without its peer, (e) needs none")
        section_d(200 if q else 300, 300 if q else 500, 0, 0, numpyro_ok=False,
                  repeats=args.repeats)
        section_e(q)
        return 0
    numpyro.set_host_device_count(CHAINS_B)
    numpyro.enable_x64()
    import jax
    jax.monitoring.register_event_duration_secs_listener(_compile_listener)
    print(f"NumPyro {numpyro.__version__}, JAX {jax.__version__} ({len(jax.devices())} host "
          f"devices, float64); chains = {CHAINS} in (a), (c), {CHAINS_B} in (b), (d); our BLAS "
          f"threads = {os.environ.get('OPENBLAS_NUM_THREADS')}")
    if args.only:
        if "d" in args.only:
            print_pair(section_d(200 if q else 300, 300 if q else 500, 200 if q else 300,
                                 300 if q else 500, numpyro_ok=True, repeats=args.repeats))
        if "e" in args.only:
            section_e(q)
        return 0
    a = section_a([2000, 20000] if q else [20000, 200000], args.exact_repeats,
                  200 if q else 500, 300 if q else 1000)
    b = section_b(2000 if q else 20000, args.repeats, 200 if q else 500, 300 if q else 1000,
                  200 if q else 500, 300 if q else 1000)
    c = section_c(20000 if q else 200000, 500, 1000 if q else 6000, 1000,
                  2000 if q else 6000)

    print("\nSummary (ESS/s = min bulk ESS over parameters per second of sampling, warm-up "
          "included, compilation excluded)")
    print(f"{'case':<62}{'ours ESS/s':>12}{'NumPyro ESS/s':>15}{'ratio':>10}{'≥1000×?':>9}")
    for n, (ours, peers) in a.items():
        for peer in peers:
            for m, o in ours.items():
                ratio = o["ess_s"] / peer["ess_s"]
                label = f"(a) N={n}, ours {m} draws vs {peer['sampler'][13:]}"
                print(f"{label:<62}{fmt(o['ess_s']):>12}{fmt(peer['ess_s']):>15}{fmt(ratio):>10}"
                      f"{'yes' if ratio >= 1000 else 'NO':>9}")
        comp = ", ".join(f"{p['sampler'][13:]} {fmt(p['compile_s'])} s" for p in peers)
        print(f"    N={n}: NumPyro compile/JIT (excluded above): {comp}; ours: none")
    ours, peer = b
    print(f"{'(b) Eq.11 β,γ unknown, N=' + str(ours['N']):<46}{fmt(ours['ess_s']):>12}"
          f"{fmt(peer['ess_s']):>15}{fmt(ours['ess_s'] / peer['ess_s']):>10}{'≥5':>9}")
    print(f"    R-hat ours {rfmt(ours['rhat'])} / NumPyro {rfmt(peer['rhat'])} (target < 1.01);"
          f" vs grid reference: |mean err|/sd ours {fmt(ours['mean_err'])} / NumPyro "
          f"{fmt(peer['mean_err'])}, sd ratio ours {fmt(ours['sd_ratio'])} / NumPyro "
          f"{fmt(peer['sd_ratio'])}")
    print(f"    compile/JIT: ours {fmt(ours['compile_s'])} s (numba), NumPyro "
          f"{fmt(peer['compile_s'])} s (XLA)")
    print("(c) time to |mean err| ≤ 0.1 sd and sd within 10 % (s):")
    for r in c:
        print(f"    {r['sampler']:<40} {fmt(r['run_s']):>8}  ({r['note']})")
    print_pair(section_d(200 if q else 300, 300 if q else 500, 200 if q else 300,
                         300 if q else 500, numpyro_ok=True, repeats=args.repeats))
    section_e(q)
    return 0


def print_pair(pair) -> None:
    ours, peer = pair
    if peer is None:
        return
    print(f"{'(d) Bouc–Wen pair at 20 Hz, N=' + str(ours['N']):<46}{fmt(ours['ess_s']):>12}"
          f"{fmt(peer['ess_s']):>15}{fmt(ours['ess_s'] / peer['ess_s']):>10}{'≥5':>9}")
    print(f"    R-hat (β, γ) ours {rfmt(ours['rhat'])} / NumPyro {rfmt(peer['rhat'])} "
          f"(target < 1.01)")


if __name__ == "__main__":
    sys.exit(main())
