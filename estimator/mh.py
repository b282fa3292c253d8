"""Random-walk Metropolis–Hastings (the paper's Section III-A algorithm) with several chains and an
adaptive warm-up.

Warm-up (discarded, then everything frozen so the kept draws are an ordinary MH chain):
- the proposal is N(x, λ·C); λ is tuned by Robbins–Monro on log λ towards the acceptance rate that
  is optimal for a Gaussian target of this dimension (0.44 in 1-D, 0.234 from 5-D on);
- C starts at `proposal_cov` (or the identity) and is replaced by the pooled sample covariance of
  the chains' draws at the end of doubling windows (Stan's windowed adaptation, Haario et al.'s
  estimate), shrunk slightly towards its diagonal; λ restarts at 2.38²/d after each update.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from estimator import sampler_progress, stopping


@dataclass
class SamplerOutput:
    draws: np.ndarray
    """(chains, draws, p) in the sampler's (possibly scaled) coordinates."""
    accept_rate: np.ndarray
    """(chains,) acceptance rate of the kept draws (NaN where it does not apply)."""
    seconds: float
    """Sampling wall time, warm-up included, excluding compile/JIT."""
    extra: dict = field(default_factory=dict)


def target_acceptance(d: int) -> float:
    """Optimal random-walk acceptance for a d-dimensional Gaussian (Roberts, Gelman & Gilks
    1997; Gelman, Roberts & Gilks 1996): 0.44 for d = 1 falling to 0.234 as d grows."""
    return {1: 0.44, 2: 0.35, 3: 0.31, 4: 0.28}.get(int(d), 0.234)


def _windows(n_warmup: int) -> list[int]:
    """Iteration indices (exclusive ends) at which the covariance is re-estimated: an initial
    15 % buffer with scale-only tuning, doubling windows, a final 10 % scale-only buffer."""
    if n_warmup < 60:
        return []
    start = int(0.15 * n_warmup)
    stop = int(0.9 * n_warmup)
    ends, t, w = [], start, max(25, (stop - start) // 15)
    while t + 3 * w <= stop:  # this window and a doubled next one still fit
        t += w
        ends.append(t)
        w *= 2
    ends.append(stop)  # the last window runs to the final buffer
    return sorted(set(e for e in ends if e > start))


def metropolis_hastings(logp: Callable[[np.ndarray], float], x0: np.ndarray, n_draws: int,
                        n_warmup: int, seed: int, proposal_cov: np.ndarray | None = None
                        ) -> SamplerOutput:
    """Sample with `chains = x0.shape[0]` random-walk MH chains (logp: x (p,) -> log density up
    to a constant; -inf or NaN is rejected). Returns the n_draws kept draws of every chain.
    Reports the chains' iterations to the installed estimator.sampler_progress callback."""
    x0 = np.atleast_2d(np.asarray(x0, dtype=float))
    chains, d = x0.shape
    rng = np.random.default_rng(seed)
    C = np.eye(d) if proposal_cov is None else np.array(proposal_cov, dtype=float)
    if C.shape != (d, d):
        raise ValueError(f"proposal_cov must be ({d}, {d}), got {C.shape}")
    chol = _chol(C)
    lam0 = 2.38 ** 2 / d
    log_lam = np.log(lam0)
    target = target_acceptance(d)
    ends = _windows(n_warmup)
    win_start = int(0.15 * n_warmup)

    x = x0.copy()
    lp = np.array([_safe(logp, xi) for xi in x])
    if not np.all(np.isfinite(lp)):
        raise ValueError("a starting point has log density -inf or NaN; start inside the support")
    total = n_warmup + n_draws
    draws = np.empty((chains, n_draws, d))
    warm = np.empty((chains, n_warmup, d))
    accepted = np.zeros(chains)
    n_eval = 0
    stop = stopping.current()
    rep = sampler_progress.ChainReporter(sampler_progress.current(), range(chains), n_warmup,
                                         n_draws)
    rep.start()
    t0 = time.perf_counter()
    for t in range(total):
        stop()
        step = np.sqrt(np.exp(log_lam))
        prop = x + step * (rng.standard_normal((chains, d)) @ chol.T)
        logu = np.log(rng.random(chains))
        acc_now = 0.0
        for c in range(chains):
            lpp = _safe(logp, prop[c])
            n_eval += 1
            if logu[c] < lpp - lp[c]:
                x[c] = prop[c]
                lp[c] = lpp
                acc_now += 1.0
                if t >= n_warmup:
                    accepted[c] += 1
        if t < n_warmup:
            warm[:, t] = x
            # Robbins–Monro on log λ, step decaying within each window.
            k = t - (max([e for e in ends if e <= t], default=0))
            log_lam += (acc_now / chains - target) / (k + 1) ** 0.6
            if t + 1 in ends:
                seg = warm[:, win_start:t + 1].reshape(-1, d)
                if seg.shape[0] > 2 * d + 2:
                    S = np.cov(seg, rowvar=False).reshape(d, d)
                    n = seg.shape[0]
                    S = (n / (n + 5.0)) * S + (5.0 / (n + 5.0)) * np.diag(np.diag(S)) * 1.0
                    try:
                        chol = np.linalg.cholesky(S + 1e-12 * np.trace(S) / d * np.eye(d))
                        C = S
                        log_lam = np.log(lam0)
                    except np.linalg.LinAlgError:
                        pass
                win_start = t + 1
        else:
            draws[:, t - n_warmup] = x
        rep.step(t + 1)
    seconds = time.perf_counter() - t0
    rate = accepted / n_draws if n_draws else np.full(chains, np.nan)
    return SamplerOutput(draws=draws, accept_rate=rate, seconds=seconds,
                         extra={"proposal_cov": C, "proposal_scale": float(np.exp(log_lam)),
                                "target_acceptance": target, "logp_evaluations": n_eval,
                                "adaptation_windows": ends})


def _chol(C: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(0.5 * (C + C.T))
        return V * np.sqrt(np.clip(w, 1e-300, None))


def _safe(logp, x) -> float:
    try:
        v = float(logp(x))
    except (FloatingPointError, OverflowError, ValueError, ZeroDivisionError):
        return -np.inf
    return v if np.isfinite(v) else -np.inf
