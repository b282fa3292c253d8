"""The posterior of a linear-in-parameter model as a sampling target, in sampler coordinates
z = (θ, s) with s = log τ² (so every coordinate is unconstrained).

U(z) = −log p(θ, τ² | y) − s  (the −s is the Jacobian of τ² = e^s):
    U = (N/2 + a0)·s + (RSS(θ)/2 + b0)·e^(−s) + ½(θ−m0)ᵀS0⁻¹(θ−m0)              (paper's prior)
    U = (N/2 + a0 + p/2)·s + (RSS(θ)/2 + b0 + ½(θ−m0)ᵀV0⁻¹(θ−m0))·e^(−s)          (conjugate)

Two evaluations serve two samplers:
- `logp(z)` uses the sufficient statistics (XᵀX, θ̂_LS, RSS_min): RSS(θ) = RSS_min +
  (θ−θ̂)ᵀXᵀX(θ−θ̂) exactly, so Metropolis–Hastings costs O(p²) per step at any N.
- `grad_u(z, idx)` is the paper's mini-batch estimate (Section III-B): the likelihood part from
  the rows idx, scaled by N/|idx|, plus the prior part; idx=None is the full-data gradient.
"""

from __future__ import annotations

import numpy as np

from estimator.priors import Prior


class LinearPosterior:
    def __init__(self, X: np.ndarray, y: np.ndarray, prior: Prior):
        self.X = np.ascontiguousarray(X, dtype=float)
        self.y = np.ascontiguousarray(y, dtype=float)
        self.prior = prior
        self.n, self.p = self.X.shape
        self.G = self.X.T @ self.X
        self.theta_ls, *_ = np.linalg.lstsq(self.X, self.y, rcond=None)
        r = self.y - self.X @ self.theta_ls
        self.rss_min = float(r @ r)
        self.m0 = np.asarray(prior.mean, dtype=float)
        self.P0 = np.linalg.inv(np.asarray(prior.cov, dtype=float))
        self.a0 = float(prior.a0)
        self.b0 = float(prior.b0)
        self.conditional = bool(prior.conditional)

    @property
    def dim(self) -> int:
        """Sampler dimension p + 1 (θ and log τ²)."""
        return self.p + 1

    def rss(self, theta: np.ndarray) -> float:
        d = theta - self.theta_ls
        return self.rss_min + float(d @ self.G @ d)

    def logp(self, z: np.ndarray) -> float:
        """log p(θ, s | y) up to a constant (sufficient statistics, O(p²))."""
        theta = z[:-1]
        s = float(z[-1])
        if not np.isfinite(s) or s > 700 or s < -700:
            return -np.inf
        d0 = theta - self.m0
        q0 = float(d0 @ self.P0 @ d0)
        rss = self.rss(theta)
        if self.conditional:
            return float(-(0.5 * self.n + self.a0 + 0.5 * self.p) * s
                         - (0.5 * rss + self.b0 + 0.5 * q0) * np.exp(-s))
        return float(-(0.5 * self.n + self.a0) * s - (0.5 * rss + self.b0) * np.exp(-s)
                     - 0.5 * q0)

    def grad_u(self, z: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """∇U(z) estimated from the rows idx (with the likelihood scaled by N/|idx|); the full
        gradient for idx=None."""
        theta = z[:-1]
        s = float(z[-1])
        if idx is None:
            Xb, yb, scale = self.X, self.y, 1.0
        else:
            Xb, yb = np.take(self.X, idx, axis=0), np.take(self.y, idx)  # take: ~10x fancy indexing
            scale = self.n / len(idx)
        r = yb - Xb @ theta
        rss = scale * float(r @ r)
        g_rss = -2.0 * scale * (Xb.T @ r)          # ∂RSS/∂θ
        e = np.exp(-s)
        d0 = theta - self.m0
        g0 = self.P0 @ d0
        out = np.empty(self.p + 1)
        if self.conditional:
            q0 = float(d0 @ g0)
            out[:-1] = 0.5 * e * g_rss + e * g0
            out[-1] = (0.5 * self.n + self.a0 + 0.5 * self.p) - (0.5 * rss + self.b0 + 0.5 * q0) * e
        else:
            out[:-1] = 0.5 * e * g_rss + g0
            out[-1] = (0.5 * self.n + self.a0) - (0.5 * rss + self.b0) * e
        return out

    def start(self, chains: int, rng: np.random.Generator, spread: float = 3.0) -> np.ndarray:
        """Over-dispersed starting points (chains, p+1): the least-squares solution and log σ̂²
        perturbed by `spread` times their standard errors, so R-hat can see non-convergence."""
        dof = max(self.n - self.p, 1)
        s2 = max(self.rss_min / dof, 1e-300)
        try:
            cov = s2 * np.linalg.inv(self.G)
            sd = np.sqrt(np.clip(np.diag(cov), 0, None))
        except np.linalg.LinAlgError:
            sd = np.ones(self.p)
        z = np.empty((chains, self.p + 1))
        z[:, :-1] = self.theta_ls + spread * sd * rng.standard_normal((chains, self.p))
        z[:, -1] = np.log(s2) + spread * np.sqrt(2.0 / max(self.n, 1)) * rng.standard_normal(chains)
        return z

    def laplace_cov(self) -> np.ndarray:
        """Cheap covariance guess for the proposal: σ̂²·(XᵀX)⁻¹ for θ and 2/N for s."""
        dof = max(self.n - self.p, 1)
        s2 = max(self.rss_min / dof, 1e-300)
        cov = np.zeros((self.p + 1, self.p + 1))
        cov[:-1, :-1] = np.linalg.pinv(self.G / s2 + (0.0 if self.conditional else self.P0))
        cov[-1, -1] = 2.0 / max(self.n, 1)
        return cov
