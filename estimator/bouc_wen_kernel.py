"""The Bouc–Wen recursion over a measured twist series, compiled with numba, with its forward
sensitivities (Eq. 9 of the paper, rig.md's "Flexible transmission").

The state update is `core.terms.bouc_wen_step` — the emulator's own function, compiled here as is —
so the identification integrates the hysteresis exactly as the emulator does. The tangent-linear
kernel below advances the same explicit sub-steps (same sub-step count, same arithmetic for the
state, which a test checks bit for bit against the shared step) and carries dx/dα, dx/dβ, dx/dγ
along: for each sub-step x' = x + f(x; α, β, γ)·h,

    s' = s + (∂f/∂x·s + ∂f/∂θ)·h,   ∂f/∂x = −n·|x|^(n−1)·(β·sgn(dΔ) + γ·sgn(x)),
    ∂f/∂α = 1,  ∂f/∂β = −sgn(dΔ)·|x|^(n−1)·x,  ∂f/∂γ = −|x|^n.

With the shared step's own rule the sub-step count depends on (β, γ, x) through an integer, so x
is only piecewise smooth in the parameters: where the count flips, x (and the log density of a fit
on thousands of samples) jumps by the integrator's local error, which no gradient sees. A fit
therefore fixes the counts once from the data (`substep_counts`: the shared step's rule at one
stiffness bound K*, per sample interval) and passes them to the kernels as `msub`; x is then a
smooth function of (α, β, γ) and the sensitivities are its exact derivatives. A count of 0 in
`msub` means the shared step's own rule (the emulator's behaviour, bit for bit); with the counts
the rule gives at (α, β, γ), the fixed-count recursion is the shared step bit for bit (tested)."""

from __future__ import annotations

import math

import numba
import numpy as np

from core.terms import bouc_wen_step

SUPPORTED_N: tuple[int, ...] = (1, 2, 3, 4)
"""Bouc–Wen exponents the identification accepts (the paper fixes n = 1)."""

SUBSTEP_TOL = 0.05
"""The shared step's bound on |(β+γ)·|x|^(n−1)·h| per sub-step (core.terms.bouc_wen_step); the
fixed counts of `substep_counts` follow the same rule (a test holds the two equal)."""

_step = numba.njit(cache=True, nogil=True)(bouc_wen_step)


@numba.njit(cache=True, nogil=True)
def _step_m(d_delta, x, alpha, beta, gamma, n, msub):
    """core.terms.bouc_wen_step's arithmetic with the sub-step count given."""
    s = 1.0 if d_delta >= 0.0 else -1.0
    h = d_delta / msub
    for _ in range(msub):
        ax = abs(x)
        x = x + (alpha - beta * s * ax ** (n - 1) * x - gamma * ax ** n) * h
    return x


@numba.njit(cache=True, nogil=True)
def _state(delta, x0, alpha, beta, gamma, n, restart, msub):
    m = delta.shape[0]
    x = np.empty(m)
    xc = x0
    x[0] = xc
    for k in range(1, m):
        if restart[k]:
            xc = x0
        elif msub[k] > 0:
            xc = _step_m(delta[k] - delta[k - 1], xc, alpha, beta, gamma, n, msub[k])
        else:
            xc = _step(delta[k] - delta[k - 1], xc, alpha, beta, gamma, n)
        x[k] = xc
    return x


@numba.njit(cache=True, nogil=True)
def _state_sens(delta, x0, alpha, beta, gamma, n, restart, msub):
    m = delta.shape[0]
    x = np.empty(m)
    sens = np.zeros((m, 3))
    xc = x0
    sa = 0.0
    sb = 0.0
    sg = 0.0
    x[0] = xc
    for k in range(1, m):
        if restart[k]:
            xc = x0
            sa = 0.0
            sb = 0.0
            sg = 0.0
            x[k] = xc
            continue
        d_delta = delta[k] - delta[k - 1]
        # --- identical to core.terms.bouc_wen_step (tests check the state bit for bit) ---
        s = 1.0 if d_delta >= 0.0 else -1.0
        if msub[k] > 0:
            mk = msub[k]
        else:
            scale = (abs(beta) + abs(gamma)) * max(abs(xc), 1e-3) ** (n - 1)
            mk = int(abs(d_delta) * scale / 0.05) + 1
        h = d_delta / mk
        for _ in range(mk):
            ax = abs(xc)
            pn1 = ax ** (n - 1)
            sx = 1.0 if xc > 0.0 else (-1.0 if xc < 0.0 else 0.0)
            dfdx = -n * pn1 * (beta * s + gamma * sx)
            na = sa + (dfdx * sa + 1.0) * h
            nb = sb + (dfdx * sb - s * pn1 * xc) * h
            ng = sg + (dfdx * sg - ax ** n) * h
            xc = xc + (alpha - beta * s * ax ** (n - 1) * xc - gamma * ax ** n) * h
            sa = na
            sb = nb
            sg = ng
        x[k] = xc
        sens[k, 0] = sa
        sens[k, 1] = sb
        sens[k, 2] = sg
    return x, sens


def _check(delta, n) -> np.ndarray:
    if int(n) != n or int(n) not in SUPPORTED_N:
        raise ValueError(f"Bouc–Wen exponent n={n!r} not supported; choose one of {SUPPORTED_N}")
    d = np.ascontiguousarray(delta, dtype=float)
    if d.ndim != 1 or d.size < 2:
        raise ValueError("the twist series must be a 1-D array of at least 2 samples")
    if not np.all(np.isfinite(d)):
        raise ValueError("the twist series holds NaN or infinite samples; drop or fill them first")
    return d


def restart_mask(size: int, run: np.ndarray | None = None) -> np.ndarray:
    """Samples where the state restarts at x0: the first one, and the first of each run when
    several runs are concatenated (`run` labels, e.g. estimator.preprocess.concat_signals')."""
    mask = np.zeros(size, dtype=np.bool_)
    mask[0] = True
    if run is not None:
        r = np.asarray(run)
        if r.shape != (size,):
            raise ValueError("run labels must have one entry per sample")
        mask[1:] = r[1:] != r[:-1]
    return mask


def stiffness_bound(alpha: float, beta: float, gamma: float, n: int = 1) -> float:
    """K = (|β|+|γ|)·|x|^(n−1) with |x| at its bound, the saturation (α/(β+γ))^(1/n) (floored
    at 1e-3 as in the step) [rad^-1]: the largest per-twist stiffness of Eq. 9 the shared step
    sizes its sub-steps by (for n = 1 exactly |β|+|γ|, the step's own scale)."""
    if int(n) == 1:
        return abs(beta) + abs(gamma)
    xmag = max((alpha / (beta + gamma)) ** (1.0 / n), 1e-3) if beta + gamma > 0 else 1.0
    return (abs(beta) + abs(gamma)) * xmag ** (n - 1)


def substep_counts(delta: np.ndarray, stiffness: float, run: np.ndarray | None = None
                   ) -> np.ndarray:
    """Sub-step count per sample interval for a stiffness bound K [rad^-1]: the shared step's rule
    int(|ΔΔ_k|·K / SUBSTEP_TOL) + 1 at that K (0 where the state restarts). Fixed for a whole
    fit, they make the state a smooth function of (α, β, γ) (module docstring)."""
    d = np.ascontiguousarray(delta, dtype=float)
    if not (math.isfinite(stiffness) and stiffness > 0.0):
        raise ValueError(f"the stiffness bound must be positive and finite, not {stiffness}")
    out = np.zeros(d.size, dtype=np.int64)
    out[1:] = (np.abs(np.diff(d)) * stiffness / SUBSTEP_TOL).astype(np.int64) + 1
    out[restart_mask(d.size, run)] = 0
    return out


def _msub(size: int, msub: np.ndarray | None) -> np.ndarray:
    if msub is None:
        return np.zeros(size, dtype=np.int64)
    m = np.ascontiguousarray(msub, dtype=np.int64)
    if m.shape != (size,) or np.any(m < 0):
        raise ValueError("sub-step counts must be one non-negative integer per sample")
    return m


def bw_state(delta: np.ndarray, alpha: float, beta: float, gamma: float, n: int = 1,
             x0: float = 0.0, run: np.ndarray | None = None,
             msub: np.ndarray | None = None) -> np.ndarray:
    """Bouc–Wen state x [rad] along a twist series Δ [rad] (Eq. 9 integrated in the twist with
    the emulator's step), starting from x0 at the first sample (and at the first sample of
    each run when `run` labels are given). Shape of Δ. `msub`: sub-step counts per sample
    (`substep_counts`; 0 or None: the shared step's own rule)."""
    d = _check(delta, n)
    return _state(d, float(x0), float(alpha), float(beta), float(gamma), int(n),
                  restart_mask(d.size, run), _msub(d.size, msub))


def bw_state_sensitivities(delta: np.ndarray, alpha: float, beta: float, gamma: float,
                           n: int = 1, x0: float = 0.0, run: np.ndarray | None = None,
                           msub: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The state x [rad] and its sensitivities ∂x/∂(α, β, γ) as an (N, 3) array [rad, rad², rad²
    for n = 1], propagated alongside the recursion (forward sensitivity equations); `msub` as
    in bw_state."""
    d = _check(delta, n)
    return _state_sens(d, float(x0), float(alpha), float(beta), float(gamma), int(n),
                       restart_mask(d.size, run), _msub(d.size, msub))


@numba.njit(cache=True, nogil=True)
def _state_batch(delta, x0, alpha, betas, gammas, n, restart, msub):
    out = np.empty((betas.shape[0], delta.shape[0]))
    for i in range(betas.shape[0]):
        out[i] = _state(delta, x0, alpha, betas[i], gammas[i], n, restart, msub)
    return out


def bw_state_batch(delta: np.ndarray, alpha: float, betas: np.ndarray, gammas: np.ndarray,
                   n: int = 1, x0: float = 0.0, run: np.ndarray | None = None) -> np.ndarray:
    """Bouc–Wen states for many (β, γ) pairs at once: (M, N) [rad] (one compiled loop, used by
    the Sobol analysis and by posterior predictive checks)."""
    d = _check(delta, n)
    b = np.ascontiguousarray(betas, dtype=float).ravel()
    g = np.ascontiguousarray(gammas, dtype=float).ravel()
    if b.shape != g.shape:
        raise ValueError("betas and gammas must have the same length")
    return _state_batch(d, float(x0), float(alpha), b, g, int(n), restart_mask(d.size, run),
                        np.zeros(d.size, dtype=np.int64))
