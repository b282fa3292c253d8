"""Priors of the linear-in-parameter models and the scaling they are stated in (paper Eq. 16 and
Appendix A).

The paper puts θ_j ~ N(0, 1) on "suitably scaled" parameters and τ² ~ Inv-Gamma(2, 2) on the noise
variance. We make the scaling explicit and physical: with the observation matrix X (columns in
their own units) and the target y [N·m], the sampler coordinates are

    θ_s,j = θ_j · c_j / s_y,   y_s = y / s_y,   τ_s² = τ² / s_y²,

where c_j = rms(X[:, j]) and s_y = rms(y). θ_s,j is then the RMS contribution of term j to the
output in units of the output's RMS, so N(0, 1) says "each term contributes at most a few times
the signal" — weakly informative for every model, whatever its units. Inv-Gamma(2, 2) is on τ_s².

The prior is a fact stated in the sampler coordinates, so a test can build it with scales that do
not depend on y (simulation-based calibration needs that); `Scaling.from_data` is what
identification uses.

Appendix A.B's rule (choose the inverse-gamma shape and scale so that its variance equals a known
m²; with the mean fixed too this is moment matching) is `inv_gamma_moment_match`; its initial
value for y = a·x is the ratio of the means, `initial_ratio_of_means`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import gammaln


@dataclass(frozen=True)
class Scaling:
    """Column scales c (p,) [unit of column j] and output scale s_y [output unit]."""

    col: np.ndarray
    y: float

    @classmethod
    def from_data(cls, X: np.ndarray, y: np.ndarray) -> "Scaling":
        """c_j = rms of column j, s_y = rms of y. A column that is identically zero cannot
        identify its parameter: refused by index (the caller names it)."""
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        col = np.sqrt(np.mean(X * X, axis=0))
        bad = np.flatnonzero(~(col > 0))
        if bad.size:
            raise ZeroColumnError(bad.tolist())
        sy = float(np.sqrt(np.mean(y * y)))
        if not sy > 0:
            raise ValueError("the target is identically zero: nothing to identify")
        return cls(col=col, y=sy)

    @classmethod
    def identity(cls, p: int) -> "Scaling":
        return cls(col=np.ones(p), y=1.0)

    def x_to_scaled(self, X: np.ndarray) -> np.ndarray:
        return np.asarray(X, dtype=float) / self.col

    def y_to_scaled(self, y: np.ndarray) -> np.ndarray:
        return np.asarray(y, dtype=float) / self.y

    def theta_to_physical(self, theta_s: np.ndarray) -> np.ndarray:
        """θ = θ_s · s_y / c (works on any array whose last axis is p)."""
        return np.asarray(theta_s) * (self.y / self.col)

    def theta_to_scaled(self, theta: np.ndarray) -> np.ndarray:
        return np.asarray(theta) * (self.col / self.y)

    def cov_to_physical(self, cov_s: np.ndarray) -> np.ndarray:
        f = self.y / self.col
        return np.asarray(cov_s) * np.outer(f, f)


class ZeroColumnError(ValueError):
    """Columns of the observation matrix that are identically zero (indices in `.columns`)."""

    def __init__(self, columns: list[int]):
        self.columns = columns
        super().__init__(f"observation-matrix columns {columns} are identically zero: their "
                         "parameters cannot be identified from these data")


@dataclass(frozen=True)
class Prior:
    """Prior in sampler (scaled) coordinates.

    conditional=False (the paper's Eq. 16): θ ~ N(mean, cov) independent of τ² ~ IG(a0, b0).
    conditional=True (conjugate Normal–Inverse-Gamma): θ | τ² ~ N(mean, τ²·cov), τ² ~ IG(a0, b0).
    """

    mean: np.ndarray
    cov: np.ndarray
    a0: float
    b0: float
    conditional: bool = False

    @property
    def p(self) -> int:
        return int(np.asarray(self.mean).shape[0])

    def logpdf(self, theta: np.ndarray, tau2: float) -> float:
        """log p(θ, τ²) (normalised), density with respect to (θ, τ²)."""
        theta = np.asarray(theta, dtype=float)
        d = theta - self.mean
        scale = tau2 if self.conditional else 1.0
        sign, logdet = np.linalg.slogdet(self.cov * scale)
        quad = float(d @ np.linalg.solve(self.cov, d)) / scale
        log_n = -0.5 * (self.p * np.log(2 * np.pi) + logdet + quad)
        return log_n + log_inv_gamma(tau2, self.a0, self.b0)

    def draw(self, rng: np.random.Generator) -> tuple[np.ndarray, float]:
        """One draw (θ, τ²) from the prior."""
        tau2 = float(self.b0 / rng.gamma(self.a0))
        scale = tau2 if self.conditional else 1.0
        theta = rng.multivariate_normal(self.mean, self.cov * scale)
        return theta, tau2


def paper_prior(p: int, a0: float = 2.0, b0: float = 2.0) -> Prior:
    """Eq. 16: θ_j ~ N(0, 1) on the scaled parameters, τ_s² ~ Inv-Gamma(2, 2), independent."""
    return Prior(mean=np.zeros(p), cov=np.eye(p), a0=float(a0), b0=float(b0), conditional=False)


def conjugate_prior(p: int, a0: float = 2.0, b0: float = 2.0, g: float = 1.0) -> Prior:
    """Conjugate NIG counterpart: θ | τ² ~ N(0, g·τ²·I), τ² ~ IG(a0, b0). g = 1/E[τ²] = (a0−1)/b0
    makes the prior of θ about as wide as the paper's N(0, 1) at the prior's mean noise level;
    the default g = 1 with IG(2, 2) gives θ's marginal prior a Student-t with 4 d.o.f. and
    scale 1."""
    return Prior(mean=np.zeros(p), cov=g * np.eye(p), a0=float(a0), b0=float(b0),
                 conditional=True)


def log_inv_gamma(x: float | np.ndarray, a: float, b: float):
    """log density of Inv-Gamma(a, b) at x > 0: a·log b − lnΓ(a) − (a+1)·log x − b/x."""
    x = np.asarray(x, dtype=float)
    return a * np.log(b) - gammaln(a) - (a + 1.0) * np.log(x) - b / x


def inv_gamma_moment_match(mean: float, var: float) -> tuple[float, float]:
    """Appendix A.B: shape α and scale β of an Inv-Gamma with the given mean and variance m²
    (Eq. 23: E = β/(α−1), Var = β²/((α−1)²(α−2))) → α = 2 + mean²/var, β = mean·(α−1)."""
    if not (mean > 0 and var > 0):
        raise ValueError("inverse-gamma moment matching needs a positive mean and variance")
    a = 2.0 + mean * mean / var
    return a, mean * (a - 1.0)


def initial_ratio_of_means(x: np.ndarray, y: np.ndarray) -> float:
    """Appendix A.B's initial value for y = a·x: a₀ = mean(y) / mean(x)."""
    mx = float(np.mean(x))
    if mx == 0:
        raise ValueError("mean of x is zero: the ratio-of-means initial value is undefined")
    return float(np.mean(y)) / mx
