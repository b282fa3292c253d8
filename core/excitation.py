"""Scheme 3's excitation: the fifth-order Fourier trajectory of Eq. 12 and the optimisation of its
coefficients (paper, section II-B-1; rig.md).

Eq. 12, for harmonics l = 1..L at base angular frequency ω_f:
    q(t)  = Σ a_l/(ω_f·l)·sin(ω_f·l·t) − b_l/(ω_f·l)·cos(ω_f·l·t) + q_0
    q̇(t)  = Σ a_l·cos(ω_f·l·t) + b_l·sin(ω_f·l·t)
    q̈(t)  = Σ −a_l·ω_f·l·sin(ω_f·l·t) + b_l·ω_f·l·cos(ω_f·l·t)

The coefficients minimise the log condition number of Eq. 4's observation matrix
(core.terms.eq4_regressor) over one period, under |q| ≤ q_max, |q̇| ≤ v_max, |q̈| ≤ a_max. We also
impose a rest-to-rest start (q(0) = q_start, q̇(0) = 0, q̈(0) = 0: a_1 = −Σ_{l≥2} a_l,
b_1 = −Σ_{l≥2} l·b_l, q_0 from q(0)), so the joint can enter and leave the periodic trajectory
without a jolt. Pure computation (numpy/scipy, core.terms); no simulator import.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from core.params import JointParams
from core.terms import eq4_regressor


@dataclass(frozen=True)
class FourierTrajectory:
    """Eq. 12 with coefficients a_l, b_l [rad/s], base angular frequency omega_f [rad/s] and
    offset q0 [rad]."""
    a: tuple[float, ...]
    b: tuple[float, ...]
    omega_f: float
    q0: float

    @property
    def order(self) -> int:
        return len(self.a)

    @property
    def period(self) -> float:
        """Period of the trajectory [s]: 2π/ω_f."""
        return 2.0 * math.pi / self.omega_f

    def evaluate(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q [rad], q̇ [rad/s], q̈ [rad/s²]) at times t [s]."""
        return fourier_trajectory(t, self.a, self.b, self.omega_f, self.q0)


def fourier_trajectory(t: ArrayLike, a: ArrayLike, b: ArrayLike, omega_f: float, q0: float = 0.0
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. 12: position [rad], velocity [rad/s] and acceleration [rad/s²] at times t [s]."""
    t = np.asarray(t, dtype=float)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    q = np.full(t.shape, float(q0))
    qd = np.zeros(t.shape)
    qdd = np.zeros(t.shape)
    for l in range(1, len(a) + 1):
        wl = omega_f * l
        s = np.sin(wl * t)
        c = np.cos(wl * t)
        q += a[l - 1] / wl * s - b[l - 1] / wl * c
        qd += a[l - 1] * c + b[l - 1] * s
        qdd += -a[l - 1] * wl * s + b[l - 1] * wl * c
    return q, qd, qdd


def rest_to_rest(free: np.ndarray, order: int, omega_f: float, q_start: float = 0.0
                 ) -> FourierTrajectory:
    """Trajectory from the free coefficients (a_2..a_L, b_2..b_L) [rad/s] with q(0) = q_start,
    q̇(0) = 0 and q̈(0) = 0."""
    free = np.asarray(free, dtype=float)
    a = np.empty(order)
    b = np.empty(order)
    a[1:] = free[:order - 1]
    b[1:] = free[order - 1:]
    l = np.arange(1, order + 1)
    a[0] = -a[1:].sum()
    b[0] = -(l[1:] * b[1:]).sum()
    q0 = q_start + float((b / (omega_f * l)).sum())
    return FourierTrajectory(tuple(a.tolist()), tuple(b.tolist()), float(omega_f), q0)


def observation_log_cond(traj: FourierTrajectory, n_grid: int = 400,
                         v_eps: float = JointParams().v_eps) -> float:
    """log10 of the 2-norm condition number of Eq. 4's observation matrix sampled on n_grid
    points over one period."""
    t = np.arange(n_grid) * traj.period / n_grid
    Y = eq4_regressor(*traj.evaluate(t), v_eps)
    s = np.linalg.svd(Y, compute_uv=False)
    if s[-1] <= 0.0:
        return math.inf
    return float(math.log10(s[0] / s[-1]))


SAFETY = 1e-4
"""Relative margin kept below each limit [-]: peaks are checked on a 20 000-point grid, whose
error near a maximum is ~1e-7 relative."""


def peaks(traj: FourierTrajectory, n_grid: int = 20000) -> tuple[float, float, float]:
    """(max|q|, max|q̇|, max|q̈|) over one period on a fine grid."""
    t = np.arange(n_grid) * traj.period / n_grid
    q, qd, qdd = traj.evaluate(t)
    return float(np.abs(q).max()), float(np.abs(qd).max()), float(np.abs(qdd).max())


def _scale_to_limits(traj: FourierTrajectory, q_max: float, v_max: float, a_max: float,
                     q_start: float, n_grid: int = 2000) -> FourierTrajectory:
    """Scale a rest-to-rest trajectory about q_start so it just meets the tightest limit (less
    the SAFETY margin; a 2000-point grid is within ~1e-5 of the true peaks)."""
    t = np.arange(n_grid) * traj.period / n_grid
    q, qd, qdd = traj.evaluate(t)
    dq = q - q_start
    room = q_max - abs(q_start)
    s = (1.0 - SAFETY) * min(room / max(np.abs(dq).max(), 1e-300),
                             v_max / max(np.abs(qd).max(), 1e-300),
                             a_max / max(np.abs(qdd).max(), 1e-300))
    return FourierTrajectory(tuple(s * x for x in traj.a), tuple(s * x for x in traj.b),
                             traj.omega_f, q_start + s * (traj.q0 - q_start))


@dataclass(frozen=True)
class ExcitationResult:
    """The optimised trajectory, its condition number (2-norm, of Eq. 4's observation matrix
    over one period) and, for comparison, those of random feasible trajectories."""
    trajectory: FourierTrajectory
    cond: float
    random_conds: tuple[float, ...]
    limits: dict
    """q_max [rad], v_max [rad/s], a_max [rad/s²] the trajectory respects."""
    peaks: tuple[float, float, float]
    """Achieved (max|q|, max|q̇|, max|q̈|)."""

    @property
    def random_median_cond(self) -> float:
        return float(np.median(self.random_conds))

    def summary(self) -> dict:
        """JSON-ready summary (coefficients, condition numbers, limits)."""
        tr = self.trajectory
        return {"a": list(tr.a), "b": list(tr.b), "omega_f": tr.omega_f, "q0": tr.q0,
                "cond": self.cond, "random_cond_median": self.random_median_cond,
                "random_cond_best": float(min(self.random_conds)),
                "n_random": len(self.random_conds), "limits": dict(self.limits),
                "peaks": {"q": self.peaks[0], "qd": self.peaks[1], "qdd": self.peaks[2]}}


def optimize_excitation(order: int = 5, base_freq_hz: float = 0.05, q_max: float = math.pi,
                        v_max: float = 3000.0 * 2 * math.pi / 60 / 11000.0, a_max: float = 0.05,
                        q_start: float = 0.0, seed: int = 0, n_random: int = 200,
                        n_starts: int = 4, n_grid: int = 200,
                        v_eps: float = JointParams().v_eps) -> ExcitationResult:
    """Choose Eq. 12's coefficients minimising log10 cond of Eq. 4's observation matrix under
    the position [rad], speed [rad/s] and acceleration [rad/s²] limits (SLSQP from the best of
    n_random random feasible trajectories, n_starts starts). Deterministic for a given seed; the
    result is cached per argument set."""
    return _optimize_cached(int(order), float(base_freq_hz), float(q_max), float(v_max),
                            float(a_max), float(q_start), int(seed), int(n_random),
                            int(n_starts), int(n_grid), float(v_eps))


@functools.lru_cache(maxsize=32)
def _optimize_cached(order, base_freq_hz, q_max, v_max, a_max, q_start, seed, n_random,
                     n_starts, n_grid, v_eps) -> ExcitationResult:
    from scipy.optimize import minimize     # imported here: rig stays light for its importers

    if order < 2:
        raise ValueError("a rest-to-rest Fourier trajectory needs order >= 2")
    if not (q_max > abs(q_start) and v_max > 0 and a_max > 0 and base_freq_hz > 0):
        raise ValueError("limits must be positive and q_start inside ±q_max")
    omega_f = 2.0 * math.pi * base_freq_hz
    rng = np.random.default_rng(seed)
    n_free = 2 * (order - 1)
    t_grid = np.arange(n_grid) * (2 * math.pi / omega_f) / n_grid
    room = q_max - abs(q_start)

    def traj_of(y):
        return rest_to_rest(v_max * np.asarray(y), order, omega_f, q_start)

    # q − q_start, q̇, q̈ on the grid are linear in the free coefficients: precompute the maps
    basis = [traj_of(e).evaluate(t_grid) for e in np.eye(n_free)]
    Bq = np.column_stack([b[0] - q_start for b in basis])
    Bv = np.column_stack([b[1] for b in basis])
    Ba = np.column_stack([b[2] for b in basis])

    def objective(y):
        Y = eq4_regressor(q_start + Bq @ y, Bv @ y, Ba @ y, v_eps)
        s = np.linalg.svd(Y, compute_uv=False)
        return float(np.log10(s[0] / s[-1])) if s[-1] > 0 else 1e6

    def constraints(y):
        return np.concatenate([1.0 - (Bq @ y / room) ** 2, 1.0 - (Bv @ y / v_max) ** 2,
                               1.0 - (Ba @ y / a_max) ** 2])

    def constraints_jac(y):
        return np.vstack([-2.0 * (Bq @ y / room**2)[:, None] * Bq,
                          -2.0 * (Bv @ y / v_max**2)[:, None] * Bv,
                          -2.0 * (Ba @ y / a_max**2)[:, None] * Ba])

    randoms = []
    for _ in range(n_random):
        tr = _scale_to_limits(traj_of(rng.standard_normal(n_free)), q_max, v_max, a_max, q_start)
        randoms.append((observation_log_cond(tr, n_grid, v_eps), tr))
    randoms.sort(key=lambda r: r[0])

    best = randoms[0][1]
    best_val = randoms[0][0]
    for _, start in randoms[:n_starts]:
        y0 = np.array(start.a[1:] + start.b[1:]) / v_max
        res = minimize(objective, y0, method="SLSQP",
                       constraints=[{"type": "ineq", "fun": constraints,
                                     "jac": constraints_jac}],
                       options={"maxiter": 200, "ftol": 1e-9})
        # re-check on a fine grid and shrink onto the limits if the coarse grid missed a peak
        cand = traj_of(res.x)
        qm, vm, am = peaks(cand)
        lim = 1.0 - SAFETY
        if qm > lim * q_max or vm > lim * v_max or am > lim * a_max:
            cand = _scale_to_limits(cand, q_max, v_max, a_max, q_start)
        val = observation_log_cond(cand, n_grid, v_eps)
        if val < best_val:
            best, best_val = cand, val
    return ExcitationResult(
        trajectory=best, cond=float(10.0 ** observation_log_cond(best, 2000, v_eps)),
        random_conds=tuple(float(10.0 ** observation_log_cond(r[1], 2000, v_eps))
                           for r in randoms),
        limits={"q_max": q_max, "v_max": v_max, "a_max": a_max},
        peaks=peaks(best))
