"""Stochastic-gradient Hamiltonian Monte Carlo (the paper's Section III-B; Chen, Fox & Guestrin
2014) with its step size, friction, mass matrix and batch size chosen automatically, and the
injected noise set so that the discretised dynamics keep the posterior's variance.

The update is the paper's, with a mass matrix M (preconditioner M⁻¹ = L·Lᵀ) and velocities v in
whitened units:

    sample a mini-batch B (|B| = b rows, drawn with replacement), g = ∇Ũ(θ; B)  (full-data scale)
    v ← (1 − α)·v − ε·Lᵀg + ξ,   ξ ~ N(0, Q)
    θ ← θ + L·v

with learning rate ε and friction α. The paper's noise is Q = 2αε·I (its "η ~ N(0, 2αεM)" in
whitened form), which ignores two things: the time discretisation and the mini-batch gradient
noise ε²·LᵀVL/b (V = covariance of a one-row gradient estimate), which adds to Q. That is why
plain SGHMC inflates the posterior sd (measured here: 10–16 % with 10 % mini-batches).

What the automatic settings do (all in whitened coordinates, where the target is ≈ N(0, I)):
1. Mass matrix: the Laplace approximation. Newton's method with a finite-difference Hessian of
   the full-data gradient finds the mode θ̂ and H = ∇²U(θ̂); M = H, so M⁻¹ ≈ posterior covariance.
2. Gradient noise: V is measured, not assumed, by `gradient_noise`: at each of the 2d sigma
   points θ̂ ± √d·L·e_j of the Laplace approximation, from a random partition of all N rows
   into disjoint batches. Every row counts (a few high-leverage rows can carry most of the
   information in one direction; an estimate from a fixed number of random rows — 16 000 in
   an earlier version — misses them more often the larger N is, and their noise then goes
   uncorrected: the sd came out 1.3x too wide at N = 200 000), and the state-dependent part of
   the noise (the mini-batch Hessian is random) is averaged over the posterior instead of
   being taken at the mode, where it is smallest.
3. Friction: for a unit Gaussian the update is a linear AR(2) process whose stationary covariance
   (discrete Lyapunov equation) and autocorrelations are exact; α minimises the larger of the
   integrated autocorrelation times of θ and θ² (mean and variance estimation) — ≈ 0.7·√ε.
4. Noise: the total velocity noise that makes the stationary Var(θ) exactly 1 is
   q*(ε, α) = 1/P₁(ε, α) (P₁ = Var θ per unit noise, from the Lyapunov equation); the injected
   noise is Q = q*·I − ε²·LᵀVL/b, i.e. the measured mini-batch noise is subtracted (a
   discretisation-exact version of Chen et al.'s B̂ correction). For a Gaussian target with a
   random mini-batch Hessian this keeps Var θ = I exactly when V is the posterior average of
   the noise covariance (the dynamics are linear; only second moments enter).
5. Step size and batch: for a batch of b rows, ε is the largest value ≤ 0.05 (0.22 posterior
   sd per step) at which the mini-batch noise is at most `max_noise_share` (default 0.8) of q*,
   so an error δ in the measured V biases the variance by at most 0.8·δ. b starts at 10 % of
   the rows (the paper's mini-batch regime); of the batches 10 %, 20 %, 40 %, 80 % and all rows,
   the one with the least work per effective draw, (b + ITERATION_OVERHEAD_ROWS)·τ (τ the larger
   IACT of θ and θ² at the resulting ε, α), is used. On data whose per-row gradients scatter
   widely (a few high-leverage rows) a 10 % batch forces a tiny ε and chains that barely move
   (measured: ε = 2.5e-5, τ ≈ 400 on a 3 940-row scheme-3 run); in that noise-limited regime
   ε grows as b² and τ falls as 1/b, so only the per-iteration overhead and the cap on ε
   separate the batches. With b ≥ N the
   full gradient is used (no noise). A given batch_size is used as given.
Remaining bias: non-Gaussianity of the target and the error of V; both are measured against the
exact posterior in the tests.
"""

from __future__ import annotations

import time
from typing import Callable

import numpy as np
from scipy.linalg import solve_discrete_lyapunov
from scipy.optimize import minimize_scalar

from estimator import sampler_progress, stopping
from estimator.mh import SamplerOutput

MAX_STEP = 0.05
"""Largest learning rate ε (whitened units: ε = h², h = 0.22 posterior sd per step)."""
DEFAULT_BATCH_FRACTION = 0.1
"""Smallest automatic mini-batch size as a fraction of the data (the paper's regime)."""
ITERATION_OVERHEAD_ROWS = 2000
"""Fixed cost of one SGHMC iteration in rows of gradient work (measured on the 2-core Xeon: a
linear-model gradient call costs ≈ 10 µs + 9 ns per row, the update ≈ 10 µs more)."""


# --- exact analysis of the discretised dynamics on a unit Gaussian ---------------------------

def _transition(eps: float, alpha: float) -> np.ndarray:
    """(θ, v) -> (θ', v') for U = θ²/2: v' = (1−α)v − εθ + ξ, θ' = θ + v'."""
    a = 1.0 - alpha
    return np.array([[1.0 - eps, a], [-eps, a]])


def stationary_cov(eps: float, alpha: float, q: float = 1.0) -> np.ndarray:
    """Stationary covariance of (θ, v) for a unit Gaussian target, velocity noise variance q."""
    A = _transition(eps, alpha)
    return solve_discrete_lyapunov(A, q * np.ones((2, 2)))


def exact_noise(eps: float, alpha: float) -> float:
    """q*(ε, α): the velocity-noise variance that makes the stationary Var(θ) exactly 1."""
    return 1.0 / stationary_cov(eps, alpha, 1.0)[0, 0]


def iact(eps: float, alpha: float) -> tuple[float, float]:
    """Integrated autocorrelation times of θ and of θ² at stationarity (unit Gaussian):
    τ(θ) = 1 + 2Σρ_k, τ(θ²) = 1 + 2Σρ_k² (Gaussian process), both in closed form."""
    A = _transition(eps, alpha)
    S = stationary_cov(eps, alpha, 1.0)
    s = S[:, 0] / S[0, 0]                      # Cov(x_t, θ_t)/Var θ
    e = np.array([1.0, 0.0])
    I2 = np.eye(2)
    sum1 = e @ A @ np.linalg.solve(I2 - A, s)  # Σ_{k≥1} ρ_k
    AA = np.kron(A, A)
    ss = np.kron(s, s)
    ee = np.kron(e, e)
    sum2 = ee @ AA @ np.linalg.solve(np.eye(4) - AA, ss)
    return float(1.0 + 2.0 * sum1), float(1.0 + 2.0 * sum2)


def auto_friction(eps: float) -> float:
    """Friction α minimising max(τ(θ), τ(θ²)) at learning rate ε."""
    r = np.sqrt(eps)

    def cost(logc):
        a = min(np.exp(logc) * r, 0.99)
        return max(iact(eps, a))
    res = minimize_scalar(cost, bounds=(np.log(0.05), np.log(min(20.0, 0.99 / r))),
                          method="bounded", options={"xatol": 1e-3})
    return float(min(np.exp(res.x) * r, 0.99))


# --- Laplace approximation: mode and Hessian from the gradient alone --------------------------

def _fd_hessian(grad: Callable[[np.ndarray], np.ndarray], x: np.ndarray, h: np.ndarray
                ) -> np.ndarray:
    d = x.size
    H = np.empty((d, d))
    for j in range(d):
        e = np.zeros(d)
        e[j] = h[j]
        H[:, j] = (grad(x + e) - grad(x - e)) / (2.0 * h[j])
    return 0.5 * (H + H.T)


def _make_pd(H: np.ndarray) -> tuple[np.ndarray, bool]:
    w, V = np.linalg.eigh(H)
    floor = max(w.max(), 1e-300) * 1e-10
    if np.all(w > floor):
        return H, True
    return (V * np.maximum(np.abs(w), floor)) @ V.T, False


def laplace(grad: Callable[[np.ndarray], np.ndarray], x: np.ndarray, max_iter: int = 50
            ) -> tuple[np.ndarray, np.ndarray, dict]:
    """Mode and Hessian of U by Newton's method on the full-data gradient, with central
    finite-difference Hessians whose steps are 1 % of the current posterior-sd estimate.
    Returns (mode, H, info)."""
    x = np.asarray(x, dtype=float).copy()
    h = 1e-4 * np.maximum(np.abs(x), 1e-2)
    H, _ = _make_pd(_fd_hessian(grad, x, h))
    h = 0.01 * np.sqrt(np.diag(np.linalg.inv(H)))
    H, pd = _make_pd(_fd_hessian(grad, x, h))
    n_grad = 4 * x.size
    g = grad(x)
    n_grad += 1
    dec = np.inf
    it = 0
    for it in range(1, max_iter + 1):
        step = np.linalg.solve(H, g)
        dec = float(g @ step)              # Newton decrement² (≈ squared distance in sd units)
        if dec < 1e-12 * x.size:
            break
        t = 1.0
        for _ in range(30):                 # halve until the Newton decrement shrinks
            xn = x - t * step
            gn = grad(xn)
            n_grad += 1
            if np.all(np.isfinite(gn)) and float(gn @ np.linalg.solve(H, gn)) < dec:
                break
            t *= 0.5
        x, g = xn, gn
        if it % 5 == 0:                     # refresh the curvature on long searches
            H, pd = _make_pd(_fd_hessian(grad, x, h))
            n_grad += 2 * x.size
    h = 0.01 * np.sqrt(np.diag(np.linalg.inv(H)))
    H, pd = _make_pd(_fd_hessian(grad, x, h))
    n_grad += 2 * x.size
    return x, H, {"newton_iterations": it, "newton_decrement": dec, "hessian_pd": pd,
                  "full_gradients": n_grad}


# --- gradient-noise estimate ------------------------------------------------------------------

def gradient_noise(grad_u: Callable[[np.ndarray, np.ndarray], np.ndarray], x: np.ndarray,
                   n_data: int, rng: np.random.Generator, chol: np.ndarray | None = None,
                   calls: int = 2000) -> tuple[np.ndarray, dict]:
    """Covariance V of a one-row gradient estimate (full-data scale; a b-row batch drawn with
    replacement has covariance V/b), averaged over the Laplace approximation N(x, chol·cholᵀ).

    Why both: (1) every row must be seen — a few high-leverage rows (a spike in one regressor)
    can carry most of the information in one direction, and a random subsample of a fixed
    number of rows misses them more often the larger N is; so each evaluation point uses a
    random partition of all rows into K disjoint batches, whose batch means give V without
    bias: V = (N−1)/N · Σ_k m_k (g_k − ḡ)(g_k − ḡ)ᵀ/(K − 1). (2) the noise depends on the state
    (the mini-batch Hessian is random), and the sampler needs its average over the posterior,
    not its value at the mode; the average over the 2d sigma points x ± √d·chol[:, j] is exact
    for a noise covariance quadratic in θ (a linear model at fixed noise level). Without chol,
    x alone. About `calls` gradient calls in all (one pass over the data per point).
    Returns V and {points, batches_per_point, rows_per_batch}."""
    x = np.asarray(x, dtype=float)
    d = x.size
    pts = [x]
    if chol is not None:
        r = np.sqrt(d)
        pts = [x + sg * r * chol[:, j] for j in range(d) for sg in (1.0, -1.0)]
    k = int(max(2, min(n_data, calls // len(pts))))
    acc = np.zeros((d, d))
    used = 0
    for pt in pts:
        parts = np.array_split(rng.permutation(n_data), k)
        G = np.array([grad_u(pt, idx) for idx in parts])
        if not np.all(np.isfinite(G)):
            continue                        # a sigma point outside the support: skip it
        m = np.array([len(idx) for idx in parts], dtype=float)
        gbar = (m @ G) / n_data
        D = G - gbar
        acc += (n_data - 1) / n_data * (D.T * m) @ D / (k - 1)
        used += 1
    if used == 0:
        raise FloatingPointError("gradient noise: non-finite gradients at every point")
    V = acc / used
    info = {"points": used, "batches_per_point": k, "rows_per_batch": n_data / k}
    return 0.5 * (V + V.T), info


# --- the sampler ------------------------------------------------------------------------------

def sghmc(grad_u: Callable[[np.ndarray, np.ndarray], np.ndarray], n_data: int, x0: np.ndarray,
          n_draws: int, n_warmup: int, seed: int, batch_size: int | None = None,
          step_size: float | None = None, friction: float | None = None,
          mass: np.ndarray | None = None, correct_noise: bool = True,
          max_noise_share: float = 0.8) -> SamplerOutput:
    """SGHMC with `chains = x0.shape[0]` chains. grad_u(θ, idx) is the estimate of ∇U (U = −log
    posterior) from the rows idx, at full-data scale. None = automatic for batch_size,
    step_size (the learning rate ε in whitened units), friction (α per step) and mass (the
    Laplace Hessian). correct_noise=False runs the paper's literal noise 2αε (for measuring its
    bias). See the module docstring for the rules. Reports each chain's iterations (one chain
    after the other) to the installed estimator.sampler_progress callback."""
    t_start = time.perf_counter()
    x0 = np.atleast_2d(np.asarray(x0, dtype=float))
    chains, d = x0.shape
    rng = np.random.default_rng(seed)
    all_rows = np.arange(n_data)

    def full(x):
        return grad_u(x, all_rows)

    info: dict = {}
    if mass is None:
        x_ref, H, linfo = laplace(full, x0.mean(axis=0))
        info.update(linfo)
        Minv = np.linalg.inv(H)
    else:
        M = np.asarray(mass, dtype=float)
        M = np.diag(M) if M.ndim == 1 else M
        Minv = np.linalg.inv(M)
        x_ref = x0.mean(axis=0)
    L = np.linalg.cholesky(0.5 * (Minv + Minv.T))
    t_laplace = time.perf_counter() - t_start

    # Gradient noise per row, whitened (not needed when the full gradient is used).
    b0 = int(batch_size) if batch_size is not None else int(np.ceil(DEFAULT_BATCH_FRACTION * n_data))
    b0 = max(1, min(b0, n_data))
    t1 = time.perf_counter()
    if b0 >= n_data:
        V1w, ninfo = np.zeros((d, d)), {}
    else:
        V1, ninfo = gradient_noise(grad_u, x_ref, n_data, rng, chol=L)
        V1w = L.T @ V1 @ L
    lam_v = float(np.linalg.eigvalsh(0.5 * (V1w + V1w.T)).max())
    t_noise = time.perf_counter() - t1

    def settings_for(b: int) -> tuple[float, float]:
        """(ε, α) for batch size b by the rules of the module docstring."""
        if step_size is not None:
            eps = float(step_size)
        elif b >= n_data or eps_ok(MAX_STEP, b):
            eps = MAX_STEP
        else:
            lo, hi = np.log(1e-8), np.log(MAX_STEP)
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if eps_ok(np.exp(mid), b) else (lo, mid)
            eps = float(np.exp(lo))
        return eps, float(friction) if friction is not None else auto_friction(eps)

    def eps_ok(eps: float, b: int) -> bool:
        a = friction if friction is not None else auto_friction(eps)
        return eps * eps * lam_v / b / exact_noise(eps, a) <= max_noise_share

    b = b0
    eps, alpha = settings_for(b)
    batch_search = []
    if batch_size is None and step_size is None:
        sizes = sorted({min(n_data, int(np.ceil(f * n_data)))
                        for f in (DEFAULT_BATCH_FRACTION, 0.2, 0.4, 0.8, 1.0)})
        for bb in sizes:
            e, a = settings_for(bb)
            batch_search.append({"batch_size": bb, "learning_rate": e, "friction": a,
                                 "work_per_draw": (bb + ITERATION_OVERHEAD_ROWS) * max(iact(e, a))})
        best = min(batch_search, key=lambda r: r["work_per_draw"])
        b, eps, alpha = best["batch_size"], best["learning_rate"], best["friction"]
    full_batch = b >= n_data
    if not (0 < alpha < 2) or not (0 < eps):
        raise ValueError(f"need 0 < friction < 2 and step_size > 0 (got {alpha}, {eps})")

    q_star = exact_noise(eps, alpha) if correct_noise else 2.0 * alpha * eps
    grad_noise_w = np.zeros((d, d)) if full_batch else eps * eps * V1w / b
    if correct_noise:
        Q = q_star * np.eye(d) - grad_noise_w
        w, U = np.linalg.eigh(0.5 * (Q + Q.T))
        clipped = bool(np.any(w < 0))
        Lq = U * np.sqrt(np.clip(w, 0.0, None))
    else:
        clipped = False
        Lq = np.sqrt(q_star) * np.eye(d)
    noise_share = 0.0 if full_batch else float(lam_v * eps * eps / b / q_star)

    # Sampling.
    t2 = time.perf_counter()
    total = n_warmup + n_draws
    draws = np.empty((chains, n_draws, d))
    LT = L.T
    stop = stopping.current()
    progress = sampler_progress.current()
    for c in range(chains):
        rep = sampler_progress.ChainReporter(progress, [c], n_warmup, n_draws)
        rep.start()
        th = x0[c].copy()
        v = np.sqrt(eps) * rng.standard_normal(d)
        xi = rng.standard_normal((total, d)) @ Lq.T
        for t in range(total):
            stop()
            idx = all_rows if full_batch else rng.integers(0, n_data, b)
            g = grad_u(th, idx)
            v = (1.0 - alpha) * v - eps * (LT @ g) + xi[t]
            th = th + L @ v
            if t >= n_warmup:
                draws[c, t - n_warmup] = th
            rep.step(t + 1)
        if not np.all(np.isfinite(th)):
            raise FloatingPointError("SGHMC diverged (non-finite state); check the target and "
                                     "the mass matrix")
    t_sample = time.perf_counter() - t2
    seconds = time.perf_counter() - t_start
    info.update({
        "learning_rate": eps, "friction": alpha, "batch_size": b, "full_batch": full_batch,
        "mass_inverse": Minv, "mode": x_ref, "noise_variance_target": q_star,
        "gradient_noise_share": noise_share, "noise_clipped": clipped,
        "correct_noise": bool(correct_noise),
        "iact_theta": iact(eps, alpha)[0], "iact_theta2": iact(eps, alpha)[1],
        "gradient_evaluations": chains * total, "data_passes": chains * total * b / n_data,
        "seconds_laplace": t_laplace, "seconds_noise_estimate": t_noise,
        "seconds_sampling": t_sample,
        "noise_estimate": ninfo, "batch_search": batch_search,
    })
    return SamplerOutput(draws=draws, accept_rate=np.full(chains, np.nan), seconds=seconds,
                         extra=info)
