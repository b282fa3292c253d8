"""The Bouc–Wen recursion over a measured twist series, compiled with numba, with its forward
sensitivities (Eq. 9 of the paper, rig.md's "Flexible transmission").

The state update is `core.terms.bouc_wen_step` — the emulator's own function, compiled here as is —
so the identification integrates the hysteresis exactly as the emulator does. The tangent-linear
kernel below advances the same explicit sub-steps (same sub-step count, same arithmetic for the
state, which a test checks bit for bit against the shared step) and carries dx/dα, dx/dβ, dx/dγ
along: for each sub-step x' = x + f(x; α, β, γ)·h,

    s' = s + (∂f/∂x·s + ∂f/∂θ)·h,   ∂f/∂x = −n·|x|^(n−1)·(β·sgn(dΔ) + γ·sgn(x)),
    ∂f/∂α = 1,  ∂f/∂β = −sgn(dΔ)·|x|^(n−1)·x,  ∂f/∂γ = −|x|^n.

The sub-step count depends on (β, γ, x) through an integer, so x is piecewise smooth in the
parameters; the sensitivities are exact derivatives of each smooth piece (the jumps where the
count changes are of the order of the integrator's local error)."""

from __future__ import annotations

import numba
import numpy as np

from core.terms import bouc_wen_step

SUPPORTED_N: tuple[int, ...] = (1, 2, 3, 4)
"""Bouc–Wen exponents the identification accepts (the paper fixes n = 1)."""

_step = numba.njit(cache=True, nogil=True)(bouc_wen_step)


@numba.njit(cache=True, nogil=True)
def _state(delta, x0, alpha, beta, gamma, n, restart):
    m = delta.shape[0]
    x = np.empty(m)
    xc = x0
    x[0] = xc
    for k in range(1, m):
        if restart[k]:
            xc = x0
        else:
            xc = _step(delta[k] - delta[k - 1], xc, alpha, beta, gamma, n)
        x[k] = xc
    return x


@numba.njit(cache=True, nogil=True)
def _state_sens(delta, x0, alpha, beta, gamma, n, restart):
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
        scale = (abs(beta) + abs(gamma)) * max(abs(xc), 1e-3) ** (n - 1)
        msub = int(abs(d_delta) * scale / 0.05) + 1
        h = d_delta / msub
        for _ in range(msub):
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


def bw_state(delta: np.ndarray, alpha: float, beta: float, gamma: float, n: int = 1,
             x0: float = 0.0, run: np.ndarray | None = None) -> np.ndarray:
    """Bouc–Wen state x [rad] along a twist series Δ [rad] (Eq. 9 integrated in the twist with
    the emulator's step), starting from x0 at the first sample (and at the first sample of
    each run when `run` labels are given). Shape of Δ."""
    d = _check(delta, n)
    return _state(d, float(x0), float(alpha), float(beta), float(gamma), int(n),
                  restart_mask(d.size, run))


def bw_state_sensitivities(delta: np.ndarray, alpha: float, beta: float, gamma: float,
                           n: int = 1, x0: float = 0.0, run: np.ndarray | None = None
                           ) -> tuple[np.ndarray, np.ndarray]:
    """The state x [rad] and its sensitivities ∂x/∂(α, β, γ) as an (N, 3) array [rad, rad², rad²
    for n = 1], propagated alongside the recursion (forward sensitivity equations)."""
    d = _check(delta, n)
    return _state_sens(d, float(x0), float(alpha), float(beta), float(gamma), int(n),
                       restart_mask(d.size, run))


@numba.njit(cache=True, nogil=True)
def _state_batch(delta, x0, alpha, betas, gammas, n, restart):
    out = np.empty((betas.shape[0], delta.shape[0]))
    for i in range(betas.shape[0]):
        out[i] = _state(delta, x0, alpha, betas[i], gammas[i], n, restart)
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
    return _state_batch(d, float(x0), float(alpha), b, g, int(n), restart_mask(d.size, run))
