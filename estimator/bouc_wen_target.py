"""The Bouc–Wen transmission as a target for identification: Eq. 9 (α, β, γ; n fixed) inside Eq. 11
(T = k_u·Δ + k_h·x + f_v·sgn Δ̇ + (D+f_c)·Δ̇ + C), from a measured twist Δ = u − q and torque T.

Model. x is the Bouc–Wen state driven by the measured twist (estimator.bouc_wen_kernel: the
emulator's own step, with forward sensitivities), starting at 0 on the first sample of each run
(within a run it runs through dropout gaps: the state persists physically). Given x,
Eq. 11 is linear in θ = (k_u, k_h, f_v, D+f_c, C) (core.terms.eq11_regressor). For every n the
state scales with α — x(α, β, γ) = α·x(1, β·α^(n−1), γ·α^(n−1)) — so only α·k_h is identified:
α is fixed (1 by default, rig.md) and the free nonlinear parameters are (β, γ). Their support is
β > 0 and β + γ > 0 (the state saturates at (α/(β+γ))^(1/n) when loading and stays bounded when
unloading).

Sampler coordinates (unconstrained). w = (log(β+γ), log(β/(β+γ))) [and log α first when α is
freed]: β = σ·r, γ = σ·(1 − r) with σ = e^(w₁), r = e^(w₂) covers exactly the support, so no
sampler ever proposes an unstable model and the prior's boundary needs no rejections. The
Jacobian |∂(β, γ)/∂w| = σ·β (times α for log α) is part of the target. A numerical guard keeps
the integrator's sub-step count bounded: (|β|+|γ|)·|x|^(n−1)·max|ΔΔ| ≤ 100 (≥ 2000 sub-steps per
sample otherwise), a cap far beyond any plausible value (~100 prior sd for a record of 2000
samples).

Prior. Nonlinear: β, γ ~ N(0, s²) independent, truncated to the support, s = (10/range Δ)^n —
any yield twist from a tenth of the twist range upwards is plausible; α ~ N(1, 0.5²) when free.
Linear block and noise: the conjugate Normal–Inverse-Gamma prior of estimator.priors in its
scaled coordinates (θ_s = θ·c/s_y), θ_s | τ_s² ~ N(0, g·τ_s²·I) with g = 1/τ̂_s² from the
least-squares residual (so θ_s ~ N(0, 1) at the estimated noise level: the paper's "N(0, 1) on
suitably scaled parameters", without the conjugate form's (θ/τ)ᵀθ/τ term inflating τ² when the
noise is small — g = 1 or g = N measurably do), and τ_s² ~ Inv-Gamma(a0, b0) with a vague
default a0 = 1e-3, b0 = a0·τ̂_s² (b0 must be small against ½·RSS_s, itself ~1e-2 at this rig's
signal-to-noise ratio: the paper's IG(2, 2) on the scaled noise variance acts as four
unit-variance pseudo-observations and inflates τ ~5×, and even b0 = 1e-3 inflates it 8 %). An
explicit `prior` / `tau2_prior` is used as given.

Collapsed target. The linear block and the noise are integrated out exactly:
log p(w | y) = log p(w) + log p(y | X(w)) (estimator.exact.nig_posterior's evidence). Its
gradient, with X's x-column the only one depending on w, V_n the posterior cov_unit, m_n the
posterior mean, (a_n, b_n) the noise posterior and r = y − X·m_n:

    ∂ log p(y) / ∂x = −X·V_n[:, j] + (a_n / b_n)·m_n[j]·r,   j = the x column,

chained with the sensitivities ∂x/∂(α, β, γ) and ∂(α, β, γ)/∂w. Samplers run on w only; every
posterior draw of w then gets an exact draw of (θ, τ²) from its conditional NIG posterior.

The fitting workflow (least squares and the samplers on this target): estimator.bouc_wen."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from estimator.bouc_wen_kernel import (SUPPORTED_N, _state, _state_sens, restart_mask,
                                       stiffness_bound, substep_counts)
from estimator.exact import NIGPosterior, nig_draws, nig_posterior
from estimator.priors import Prior, Scaling, conjugate_prior
from core.params import JointParams
from core.terms import eq11_regressor

LINEAR_NAMES: tuple[str, ...] = ("k_u", "k_h", "f_v", "D+f_c", "C")
"""Eq. 11's linear parameters in the order of core.terms.eq11_regressor's columns."""
LINEAR_UNITS: tuple[str, ...] = ("N·m/rad", "N·m/rad", "N·m", "N·m·s/rad", "N·m")
X_COLUMN = 1
"""Index of the Bouc–Wen state x among eq11_regressor's columns."""
MAX_FIXED_SUBSTEP = 1.0
"""Guard with fixed sub-step counts: K·h above this on a sub-step is outside the target (20× the
stiffness the counts were fixed for)."""
MAX_STIFFNESS_STEP = 100.0
"""Guard: (|β|+|γ|)·|x|^(n−1)·max|ΔΔ| above this is outside the target (≳ 2000 sub-steps per
sample)."""


def nonlinear_units(n: int, free_alpha: bool) -> list[str]:
    """Units of (α?, β, γ): α is dimensionless, β and γ are [rad^-n]."""
    u = "1/rad" if n == 1 else f"rad^-{n}"
    return (["-"] if free_alpha else []) + [u, u]


@dataclass
class BoucWenPrior:
    """Prior of the Eq. 9 + Eq. 11 model (see the module docstring): independent normals on the
    free nonlinear parameters (α?, β, γ) in physical units, truncated to the support, and the
    conjugate NIG prior of the linear block in `scaling`'s coordinates."""
    nl_mean: np.ndarray
    nl_sd: np.ndarray
    linear: Prior
    scaling: Scaling


def default_prior(delta: np.ndarray, y: np.ndarray, n: int = 1, free_alpha: bool = False,
                  v_eps: float | None = None, tau2_prior: tuple[float, float] = (1e-3, 1e-3),
                  g: float | None = None, delta_dot: np.ndarray | None = None) -> BoucWenPrior:
    """The default prior for a record (module docstring). The linear block's scaling is
    Scaling.from_data of Eq. 11's regressor with the x column at a tenth of the twist range;
    g = N until fit_bouc_wen replaces it by 1/τ̂_s² after least squares."""
    delta = np.asarray(delta, dtype=float)
    rng_d = float(np.ptp(delta))
    if not rng_d > 0:
        raise ValueError("the twist does not vary: the Bouc–Wen state cannot be identified")
    s = (10.0 / rng_d) ** n
    nl_mean, nl_sd = np.zeros(2), np.array([s, s])
    if free_alpha:
        nl_mean, nl_sd = np.r_[1.0, nl_mean], np.r_[0.5, nl_sd]
    v_eps = JointParams().v_eps if v_eps is None else v_eps
    dd = np.gradient(delta) if delta_dot is None else np.asarray(delta_dot, dtype=float)
    X = eq11_regressor(delta, dd, np.full_like(delta, 0.1 * rng_d), v_eps)
    sc = Scaling.from_data(X, y)
    g = float(len(y)) if g is None else float(g)
    return BoucWenPrior(nl_mean=nl_mean, nl_sd=nl_sd,
                        linear=conjugate_prior(5, a0=tau2_prior[0], b0=tau2_prior[1], g=g),
                        scaling=sc)


class BoucWenTarget:
    """The collapsed posterior of the free nonlinear parameters in the unconstrained sampler
    coordinates w (module docstring), the linear block and the noise integrated out; and the
    joint (w, θ_s, log τ_s²) target for SGHMC."""

    def __init__(self, delta: np.ndarray, delta_dot: np.ndarray, y: np.ndarray,
                 prior: BoucWenPrior, n: int = 1, alpha: float = 1.0,
                 free_alpha: bool = False, v_eps: float | None = None, x0: float = 0.0,
                 run: np.ndarray | None = None):
        if n not in SUPPORTED_N:
            raise ValueError(f"Bouc–Wen exponent n={n!r} not supported; choose one of "
                             f"{SUPPORTED_N}")
        self.delta = np.ascontiguousarray(delta, dtype=float)
        self.delta_dot = np.ascontiguousarray(delta_dot, dtype=float)
        self.y = np.ascontiguousarray(y, dtype=float)
        if self.delta.ndim != 1 or self.delta.size < 8 or not (
                self.delta.shape == self.delta_dot.shape == self.y.shape):
            raise ValueError("twist, twist rate and torque must be 1-D, of one length ≥ 8")
        for name, v in (("twist", self.delta), ("twist rate", self.delta_dot),
                        ("torque", self.y)):
            if not np.all(np.isfinite(v)):
                raise ValueError(f"the {name} holds missing or infinite samples; drop them first")
        self.n = int(n)
        self.alpha = float(alpha)
        self.free_alpha = bool(free_alpha)
        self.x0 = float(x0)
        self.v_eps = JointParams().v_eps if v_eps is None else float(v_eps)
        self.restart = restart_mask(self.delta.size, run)
        steps = np.abs(np.diff(self.delta))
        self.max_step = float(np.max(np.where(self.restart[1:], 0.0, steps)))
        self.msub = np.zeros(self.delta.size, dtype=np.int64)   # the shared step's own rule
        self.substep_stiffness: float | None = None
        self._max_substep = 0.0
        self.k = 3 if free_alpha else 2
        self.prior = prior
        self.nl_mean = np.asarray(prior.nl_mean, dtype=float)
        self.nl_sd = np.asarray(prior.nl_sd, dtype=float)
        if self.nl_mean.shape != (self.k,) or self.nl_sd.shape != (self.k,):
            raise ValueError(f"the nonlinear prior must have {self.k} entries "
                             f"({'α, ' if free_alpha else ''}β, γ)")
        self.sc = prior.scaling
        self.Xs = np.ascontiguousarray(self.sc.x_to_scaled(
            eq11_regressor(self.delta, self.delta_dot, np.zeros_like(self.delta), self.v_eps)))
        self.ys = self.sc.y_to_scaled(self.y)
        self.cx = float(self.sc.col[X_COLUMN])
        self._tls = threading.local()  # per-thread work copy of Xs for logp_grad
        self.set_linear_prior(prior.linear)
        self.n_data = self.y.shape[0]
        self.names = (["alpha"] if free_alpha else []) + ["beta", "gamma"]
        self._cols = [0, 1, 2] if free_alpha else [1, 2]

    def set_linear_prior(self, lp: Prior) -> None:
        """Replace the conjugate prior of (θ_s, τ_s²)."""
        if not lp.conditional:
            raise ValueError("the collapsed Bouc–Wen target needs the conjugate (conditional) "
                             "linear prior")
        self.prior.linear = lp
        self.m0, self.V0 = np.asarray(lp.mean, float), np.asarray(lp.cov, float)
        self.P0 = np.linalg.inv(self.V0)
        self.a0, self.b0 = float(lp.a0), float(lp.b0)

    # --- coordinates ------------------------------------------------------------------------
    def physical(self, w: np.ndarray) -> tuple[float, float, float]:
        """(α, β, γ) at sampler coordinates w."""
        if self.free_alpha:
            a, ls, lr = math.exp(min(w[0], 300.0)), w[1], w[2]
        else:
            a, ls, lr = self.alpha, w[0], w[1]
        sigma, r = math.exp(min(ls, 300.0)), math.exp(min(lr, 300.0))  # beyond: the guard rejects
        return a, sigma * r, sigma * (1.0 - r)

    def to_w(self, nl: np.ndarray) -> np.ndarray:
        """Sampler coordinates of the free nonlinear parameters (α?, β, γ) in physical units
        (β > 0, β + γ > 0, α > 0)."""
        nl = np.asarray(nl, dtype=float)
        b, g = nl[-2], nl[-1]
        if not (b > 0 and b + g > 0) or (self.free_alpha and not nl[0] > 0):
            raise ValueError(f"({nl}) is outside the Bouc–Wen support β > 0, β + γ > 0, α > 0")
        w = [math.log(b + g), math.log(b / (b + g))]
        return np.array(([math.log(nl[0])] if self.free_alpha else []) + w)

    def nl_jacobian(self, w: np.ndarray) -> np.ndarray:
        """∂(free nonlinear parameters)/∂w, (k, k)."""
        a, b, g = self.physical(w)
        J2 = np.array([[b, b], [g, -b]])      # rows β, γ; columns log σ, log r
        if not self.free_alpha:
            return J2
        J = np.zeros((3, 3))
        J[0, 0] = a
        J[1:, 1:] = J2
        return J

    def fix_substeps(self, stiffness: float | None) -> None:
        """Fix the recursion's sub-step count per sample interval for the rest of the fit: the
        shared step's rule at the stiffness bound K* = `stiffness` [rad^-1]
        (estimator.bouc_wen_kernel.substep_counts), so that the state, and the log density, are
        smooth in (α, β, γ); None restores the step's own rule (counts that follow (β, γ))."""
        if stiffness is None:
            self.msub = np.zeros(self.delta.size, dtype=np.int64)
            self.substep_stiffness, self._max_substep = None, 0.0
            return
        self.msub = substep_counts(self.delta, float(stiffness))
        self.msub[self.restart] = 0
        inner = ~self.restart[1:]
        self.substep_stiffness = float(stiffness)
        self._max_substep = float(np.max(np.abs(np.diff(self.delta))[inner]
                                         / self.msub[1:][inner])) if inner.any() else 0.0

    def _guard(self, a: float, b: float, g: float) -> bool:
        """The integrator's sub-step scale (|β|+|γ|)·|x|^(n−1)·max|ΔΔ| (|x| at most the
        saturation (α/(β+γ))^(1/n), floored at 1e-3 as in the step) is at most 100; with fixed
        sub-step counts, also K·h ≤ MAX_FIXED_SUBSTEP on every sub-step (the explicit step stays
        monotone: beyond it x overshoots its saturation)."""
        if not (math.isfinite(a + b + g) and a > 0.0 and b + g > 0.0):
            return False
        kx = stiffness_bound(a, b, g, self.n)
        if self.substep_stiffness is not None and kx * self._max_substep > MAX_FIXED_SUBSTEP:
            return False
        return kx * self.max_step <= MAX_STIFFNESS_STEP

    def log_prior_w(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        """log p(w) (normal priors on the physical parameters + log Jacobian) and gradient."""
        a, b, g = self.physical(w)
        nl = np.array([a, b, g])[self._cols]
        d = (nl - self.nl_mean) / self.nl_sd
        lp = -0.5 * float(d @ d)
        g_nl = -d / self.nl_sd                            # ∂/∂(α?, β, γ)
        grad = g_nl @ self.nl_jacobian(w)
        # log|J| = (log α) + 2·log σ + log r
        lp += float(w[0]) if self.free_alpha else 0.0
        lp += 2.0 * w[-2] + w[-1]
        jg = np.array(([1.0] if self.free_alpha else []) + [2.0, 1.0])
        return lp, grad + jg

    # --- model pieces -----------------------------------------------------------------------
    def state(self, w: np.ndarray) -> np.ndarray:
        a, b, g = self.physical(w)
        return _state(self.delta, self.x0, a, b, g, self.n, self.restart,  # validated in __init__
                      self.msub)

    def scaled_regressor(self, x: np.ndarray) -> np.ndarray:
        X = self.Xs.copy()
        X[:, X_COLUMN] = x / self.cx
        return X

    def regressor(self, w: np.ndarray) -> np.ndarray:
        """Eq. 11's observation matrix (N, 5) in physical units at w."""
        return eq11_regressor(self.delta, self.delta_dot, self.state(w), self.v_eps)

    def linear_posterior(self, w: np.ndarray) -> NIGPosterior:
        """The NIG posterior of (θ_s, τ_s²) given the nonlinear parameters (scaled coords)."""
        return nig_posterior(self.scaled_regressor(self.state(w)), self.ys, self.m0, self.V0,
                             self.a0, self.b0)

    # --- collapsed target -------------------------------------------------------------------
    def logp(self, w: np.ndarray) -> float:
        """log p(w | y) up to a constant (−inf beyond the numerical guard)."""
        w = np.asarray(w, dtype=float)
        if not np.all(np.isfinite(w)) or not self._guard(*self.physical(w)):
            return -np.inf
        return self.linear_posterior(w).log_marginal + self.log_prior_w(w)[0]

    def logp_grad(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        """log p(w | y) and its gradient (sensitivity equations + the NIG evidence gradient)."""
        w = np.asarray(w, dtype=float)
        if not np.all(np.isfinite(w)):
            return -np.inf, np.zeros_like(w)
        a, b, g = self.physical(w)
        if not self._guard(a, b, g):
            return -np.inf, np.zeros_like(w)
        x, S = _state_sens(self.delta, self.x0, a, b, g, self.n, self.restart,
                               self.msub)
        X = getattr(self._tls, "X", None)
        if X is None:   # column-major: the x column is contiguous, X·v and Xᵀy are faster
            X = self._tls.X = np.asfortranarray(self.Xs)
        np.divide(x, self.cx, out=X[:, X_COLUMN])
        post = nig_posterior(X, self.ys, self.m0, self.V0, self.a0, self.b0)
        j = X_COLUMN
        XM = X @ np.column_stack([post.cov_unit[:, j], post.mean])     # one pass over X
        gx = (post.a / post.b) * post.mean[j] * (self.ys - XM[:, 1]) - XM[:, 0]   # ∂/∂x_s
        lp0, gp = self.log_prior_w(w)
        with np.errstate(over="ignore", invalid="ignore"):
            # far in the tails the sensitivities can overflow: an infinite gradient then makes
            # the sampler's energy infinite and the move is rejected, which is what we want
            g_nl = (gx @ (S if self.free_alpha else S[:, 1:])) / self.cx
            return post.log_marginal + lp0, g_nl @ self.nl_jacobian(w) + gp

    # --- joint target for SGHMC: φ = (w, θ_s, s = log τ_s²) ------------------------------------
    @property
    def joint_dim(self) -> int:
        return self.k + 5 + 1

    def joint_grad_u(self, phi: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """∇U of U(φ) = −log p(w, θ_s, τ_s² | y) − s (Jacobian of τ_s² = e^s), with the
        likelihood part from the rows idx scaled by N/|idx| (full data for idx=None)."""
        phi = np.asarray(phi, dtype=float)
        k = self.k
        w, th, s = phi[:k], phi[k:k + 5], float(phi[-1])
        out = np.full_like(phi, np.nan)
        if not np.all(np.isfinite(phi)) or abs(s) > 700:
            return out
        a, b, g = self.physical(w)
        if not self._guard(a, b, g):
            return out
        x, S = _state_sens(self.delta, self.x0, a, b, g, self.n, self.restart,
                               self.msub)
        if idx is None:
            Xb, yb, Sb, scale = self.scaled_regressor(x), self.ys, S, 1.0
        else:
            Xb = self.Xs[idx].copy()
            Xb[:, X_COLUMN] = x[idx] / self.cx
            yb, Sb, scale = self.ys[idx], S[idx], self.n_data / len(idx)
        r = yb - Xb @ th
        e = math.exp(-s)
        d0 = th - self.m0
        g0 = self.P0 @ d0
        rss = scale * float(r @ r)
        # ∂RSS/∂(α?, β, γ) = −2·Σ r_i·θ_x·∂x_i/∂(·) / c_x, then chained to w
        drss = -2.0 * scale * th[X_COLUMN] * (r @ Sb[:, self._cols]) / self.cx
        out[:k] = 0.5 * e * (drss @ self.nl_jacobian(w)) - self.log_prior_w(w)[1]
        out[k:k + 5] = -e * scale * (Xb.T @ r) + e * g0
        q0 = float(d0 @ g0)
        out[-1] = (0.5 * self.n_data + self.a0 + 2.5) - (0.5 * rss + self.b0 + 0.5 * q0) * e
        return out

    def joint_logp(self, phi: np.ndarray) -> float:
        """log p(w, θ_s, s | y) up to a constant (full data); −U of joint_grad_u."""
        phi = np.asarray(phi, dtype=float)
        k = self.k
        w, th, s = phi[:k], phi[k:k + 5], float(phi[-1])
        if not self._guard(*self.physical(w)):
            return -np.inf
        X = self.scaled_regressor(self.state(w))
        r = self.ys - X @ th
        d0 = th - self.m0
        q0 = float(d0 @ self.P0 @ d0)
        return (self.log_prior_w(w)[0] - (0.5 * self.n_data + self.a0 + 2.5) * s
                - (0.5 * float(r @ r) + self.b0 + 0.5 * q0) * math.exp(-s))

    # --- exact linear block given nonlinear draws --------------------------------------------
    def draw_linear(self, w_draws: np.ndarray, rng: np.random.Generator
                    ) -> tuple[np.ndarray, np.ndarray]:
        """One exact draw of (θ, τ²) in physical units from p(θ, τ² | w, y) per row of
        w_draws (M, k); consecutive repeated rows (rejected MH moves) reuse their posterior."""
        w_draws = np.atleast_2d(w_draws)
        M = w_draws.shape[0]
        theta = np.empty((M, 5))
        tau2 = np.empty(M)
        last_key, post = None, None
        for i in range(M):
            key = w_draws[i].tobytes()
            if key != last_key:
                post = self.linear_posterior(w_draws[i])
                last_key = key
            th, t2 = nig_draws(post, 1, rng)
            theta[i] = th[0]
            tau2[i] = t2[0]
        return self.sc.theta_to_physical(theta), tau2 * self.sc.y ** 2

    def nl_physical_draws(self, w_draws: np.ndarray) -> np.ndarray:
        """(…, k) sampler draws -> (…, k) free nonlinear parameters in physical units."""
        w = np.asarray(w_draws, dtype=float)
        out = np.empty_like(w)
        sigma, r = np.exp(w[..., -2]), np.exp(w[..., -1])
        out[..., -2] = sigma * r
        out[..., -1] = sigma * (1.0 - r)
        if self.free_alpha:
            out[..., 0] = np.exp(w[..., 0])
        return out


# --- building a target from signals -------------------------------------------------------------

def _signals_arrays(signals: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    for key in ("torsion", "torque"):
        if key not in signals:
            raise KeyError(f"the Bouc–Wen model needs signal {key!r} (twist Δ = u − q [rad], "
                           f"transmitted torque [N·m]); got {sorted(signals)}")
    delta = np.asarray(signals["torsion"], dtype=float)
    y = np.asarray(signals["torque"], dtype=float)
    if signals.get("torsion_rate") is not None:
        dd = np.asarray(signals["torsion_rate"], dtype=float)
    elif signals.get("t") is not None:
        dd = np.gradient(delta, np.asarray(signals["t"], dtype=float))
    else:
        raise KeyError("the Bouc–Wen model needs 'torsion_rate' or 't' to differentiate the twist")
    return delta, dd, y


def build_target(signals: Mapping[str, Any], n: int = 1, alpha: float = 1.0,
                 free_alpha: bool = False, prior: BoucWenPrior | None = None,
                 v_eps: float | None = None, tau2_prior: tuple[float, float] = (1e-3, 1e-3)
                 ) -> BoucWenTarget:
    """The collapsed/joint target for a prepared-signal mapping (keys 'torsion' = Δ [rad],
    'torsion_rate' [rad/s] (or 't' to differentiate), 'torque' [N·m], optionally 'run': the
    state restarts at 0 at each run's first sample, as estimator.models.bouc_wen_x does)."""
    delta, dd, y = _signals_arrays(signals)
    if prior is None:
        prior = default_prior(delta, y, n=n, free_alpha=free_alpha, v_eps=v_eps,
                              tau2_prior=tau2_prior, delta_dot=dd)
    run = signals.get("run")
    return BoucWenTarget(delta, dd, y, prior, n=n, alpha=alpha, free_alpha=free_alpha,
                         v_eps=v_eps, run=None if run is None else np.asarray(run))
