"""Synthetic runs with known truth for the estimator tests (physics from core.terms only)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from core.excitation import fourier_trajectory
from core.params import JointParams
from core.run import RunData
from core.terms import rigid_body_torque

P = JointParams()
EQ4_TRUTH = np.array([P.I_xx, P.mr_x, P.mr_y, P.f_v, P.f_c])

# A fifth-order Eq. 12 trajectory inside the rig's limits (|q̇| ≲ 0.03 rad/s, |q̈| ≲ 0.05 rad/s²).
A = (0.010, 0.006, -0.004, 0.003, 0.002)
B = (0.004, -0.005, 0.003, -0.002, 0.0015)
OMEGA_F = 2 * np.pi * 0.05


def eq4_run(seed: int, duration: float = 60.0, fs: float = 50.0, noise: float = 150.0,
            load: bool = True, t0: float = 0.0, theta: np.ndarray = EQ4_TRUTH) -> RunData:
    """Scheme-3-like run: Fourier trajectory, torque from Eq. 4 (core.terms.rigid_body_torque)
    plus a slowly varying dynamometer load, Gaussian torque noise of sd `noise` [N·m]. Channels
    t, q, qd, torque, torque_load (q̈ is left to preprocessing)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1.0 / fs)
    q, qd, qdd = fourier_trajectory(t + t0, A, B, OMEGA_F, 0.1)
    body = rigid_body_torque(q, qd, qdd, *theta, P.v_eps)
    tau_l = 5000.0 * np.sin(2 * np.pi * 0.013 * t + seed) if load else np.zeros_like(t)
    torque = body + tau_l + noise * rng.standard_normal(t.size)
    cols = {"t": t, "q": q, "qd": qd, "torque": torque}
    if load:
        cols["torque_load"] = tau_l
    return RunData(pd.DataFrame(cols), {"scheme": 3, "source": "emulator", "sample_rate_hz": fs,
                                        "direction": 1, "reduction": 11000.0})


def eq11_run(seed: int, duration: float = 200.0, fs: float = 20.0, noise: float = 150.0,
             theta=None, bw=(P.alpha, P.beta, P.gamma, P.n)) -> tuple[RunData, np.ndarray]:
    """A loading–unloading twist history and the Eq. 11 torque for θ = (k_u, k_h, f_v, D+f_c, C)
    with x from the shared Bouc–Wen step; channels t, q, u, torque (twist Δ = u − q)."""
    from estimator.bouc_wen_kernel import bw_state
    from core.terms import eq11_regressor
    if theta is None:
        theta = np.array([P.k_u, P.k_h, 300.0, P.D, 200.0])
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1.0 / fs)
    ramp = 1.0 - np.exp(-((t / 5.0) ** 2))  # from rest, so the state starts at x = 0
    delta = ramp * (6e-3 * np.sin(2 * np.pi * t / 80.0) + 2e-3 * np.sin(2 * np.pi * t / 23.0 + seed))
    dd = np.gradient(delta, t)
    x = bw_state(delta, *bw)
    torque = eq11_regressor(delta, dd, x, P.v_eps) @ theta + noise * rng.standard_normal(t.size)
    q = 0.01 * t
    return RunData(pd.DataFrame({"t": t, "q": q, "u": q + delta, "torque": torque}),
                   {"scheme": 1, "source": "emulator", "sample_rate_hz": fs}), np.asarray(theta)


def sbc_coverage(prior, draw_posterior, reps: int, seed: int, n: int = 12):
    """Simulation-based calibration: θ, τ² from the prior, y from the likelihood, the 95 %
    equal-tailed posterior intervals of every parameter (θ and τ²) checked for the truth; also
    the rank of the truth among 99 posterior draws."""
    rng = np.random.default_rng(seed)
    p = prior.p
    X = np.column_stack([np.ones(n), rng.standard_normal((n, p - 1))])
    hits, ranks = [], []
    for _ in range(reps):
        theta, tau2 = prior.draw(rng)
        y = X @ theta + np.sqrt(tau2) * rng.standard_normal(n)
        th, t2 = draw_posterior(X, y, rng)
        d = np.column_stack([th, t2])
        truth = np.append(theta, tau2)
        lo, hi = np.quantile(d, [0.025, 0.975], axis=0)
        hits.append((truth >= lo) & (truth <= hi))
        sub = d[rng.choice(d.shape[0], 99, replace=False)]
        ranks.append((sub < truth).sum(axis=0))
    return np.array(hits), np.array(ranks)


def ranks_uniform(ranks):
    """p-value of rank uniformity: 10 bins over the ranks 0..99, chi-square pooled over
    parameters."""
    # 10 bins over the ranks 0..99, chi-square per parameter (pooled p-value).
    counts = np.array([np.histogram(ranks[:, j], bins=10, range=(0, 100))[0]
                       for j in range(ranks.shape[1])])
    chi2 = ((counts - ranks.shape[0] / 10) ** 2 / (ranks.shape[0] / 10)).sum()
    return stats.chi2.sf(chi2, df=9 * ranks.shape[1])
