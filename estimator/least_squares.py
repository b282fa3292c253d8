"""Ordinary least squares with standard errors and 95 % confidence intervals (the paper's "Least
Square" column of Tables 3, 4 and 8)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats


@dataclass
class OLSResult:
    theta: np.ndarray
    """(p,) least-squares estimate."""
    cov: np.ndarray
    """(p, p) covariance σ̂²·(XᵀX)⁻¹."""
    se: np.ndarray
    ci_low: np.ndarray
    ci_high: np.ndarray
    """95 % confidence interval θ ± t_{0.975, N−p}·se."""
    sigma: float
    """σ̂ = √(RSS/(N−p)), the residual standard deviation [output unit]."""
    rss: float
    dof: int
    rank: int


def ols(X: np.ndarray, y: np.ndarray, level: float = 0.95) -> OLSResult:
    """Least squares via the SVD of the column-normalised X (well conditioned whatever the units).
    Rank-deficient X gives the minimum-norm solution and infinite standard errors along the
    directions the data cannot see (reported by identifiability, not hidden)."""
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    n, p = X.shape
    if n <= p:
        raise ValueError(f"least squares needs more samples than parameters (N={n}, p={p})")
    c = np.sqrt(np.sum(X * X, axis=0))
    c = np.where(c > 0, c, 1.0)
    Xn = X / c
    U, s, Vt = np.linalg.svd(Xn, full_matrices=False)
    tol = s.max() * max(n, p) * np.finfo(float).eps
    keep = s > tol
    rank = int(keep.sum())
    coef = Vt[keep].T @ ((U[:, keep].T @ y) / s[keep])
    theta = coef / c
    r = y - X @ theta
    rss = float(r @ r)
    dof = n - rank
    sigma2 = rss / dof
    inv_s2 = np.where(keep, 1.0 / np.where(keep, s, 1.0) ** 2, np.inf)
    cov_n = (Vt.T * inv_s2) @ Vt if rank == p else _cov_rank_deficient(Vt, s, keep)
    cov = sigma2 * cov_n / np.outer(c, c)
    se = np.sqrt(np.diag(cov))
    tq = stats.t.ppf(0.5 + level / 2.0, dof)
    return OLSResult(theta=theta, cov=cov, se=se, ci_low=theta - tq * se, ci_high=theta + tq * se,
                     sigma=float(np.sqrt(sigma2)), rss=rss, dof=dof, rank=rank)


def _cov_rank_deficient(Vt, s, keep):
    # Directions with zero singular value have unbounded variance: mark every parameter that
    # loads on them as infinite, keep the rest finite.
    cov = (Vt[keep].T / s[keep] ** 2) @ Vt[keep]
    null = Vt[~keep]
    touched = np.any(np.abs(null) > 1e-12, axis=0)
    cov[touched, :] = np.inf
    cov[:, touched] = np.inf
    return cov


def leave_one_group_out(X: np.ndarray, y: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Each group's errors y − X·θ with θ fitted on the other groups (leave-one-run-out
    prediction errors). Every group's block is reduced once to its QR factor R_g and Q_gᵀy_g,
    so each left-out fit is a small least-squares problem on the other groups' stacked factors:
    the same minimum-norm solution as `ols` on the other groups' samples, without refitting
    them (no normal equations: the conditioning is X's, not its square)."""
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    groups = np.asarray(groups)
    n, p = X.shape
    c = np.sqrt(np.sum(X * X, axis=0))
    c = np.where(c > 0, c, 1.0)
    Xn = X / c
    labels = np.unique(groups)
    blocks = []
    for g in labels:
        m = groups == g
        Q, R = np.linalg.qr(Xn[m], mode="reduced")
        blocks.append((m, R, Q.T @ y[m]))
    e = np.empty_like(y)
    for i, (m, _, _) in enumerate(blocks):
        A = np.vstack([R for j, (_, R, _) in enumerate(blocks) if j != i])
        b = np.concatenate([z for j, (_, _, z) in enumerate(blocks) if j != i])
        coef = np.linalg.lstsq(A, b, rcond=max(n, p) * np.finfo(float).eps)[0]
        e[m] = y[m] - Xn[m] @ coef
    return e
