"""Global sensitivity of the output torque to each identified parameter over its posterior:
first-order and total-effect Sobol indices (paper Eqs. 18–19, Figs. 21–24), estimated with SALib
(Saltelli sampling on a scrambled Sobol' sequence, Saltelli 2010 / Jansen estimators, bootstrap
confidence intervals).

The work is split so that the expensive part can be spread over workers or a cluster:
`sobol_design` builds the sample matrix once; `evaluate_chunks` (or any map over
`design_chunks`) evaluates a vectorised model on row blocks — each block is independent;
`sobol_analyze` turns the stacked outputs into the table. `sobol_indices` runs the three steps
in-process.

Inputs are the parameters' posterior marginals (normal with the posterior mean and sd),
sampled independently — the classical Sobol decomposition assumes independent inputs, so the
posterior correlations are not represented. For a time-series output (torque at every sample)
the indices are computed per time point and summarised by their output-variance-weighted mean,
which is the generalised (aggregated) Sobol index of Gamboa et al. (2013): Σ_t Var(E[Y_t|X_i]) /
Σ_t Var(Y_t). Its confidence half-width is the same weighted mean of the per-time half-widths
(an approximation, conservative when the per-time errors are not perfectly correlated).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterator, Sequence

import numpy as np
import pandas as pd

from core.terms import eq4_regressor, eq11_regressor
from estimator import stopping

Model = Callable[[np.ndarray], np.ndarray]
"""Vectorised model: parameter rows (M, p) -> outputs (M,) or (M, T)."""


@dataclass
class SobolDesign:
    """The SALib problem and its Saltelli sample matrix (rows = model evaluations)."""
    problem: dict
    X: np.ndarray
    n_base: int
    seed: int


@dataclass
class SobolResult:
    """`table`: one row per parameter (name, S1, S1_conf, ST, ST_conf). For a time-series
    output also the per-time indices (T', p) at the analysed time indices and the output
    variance there (the weights of the aggregated indices)."""
    table: pd.DataFrame
    time_index: np.ndarray | None = None
    S1_t: np.ndarray | None = None
    ST_t: np.ndarray | None = None
    var_t: np.ndarray | None = None
    extra: dict = field(default_factory=dict)


def sobol_design(names: Sequence[str], mean: Sequence[float], sd: Sequence[float],
                 n_base: int = 1024, seed: int = 0, bounds: Sequence[Sequence[float]] | None = None
                 ) -> SobolDesign:
    """Saltelli design over independent inputs: normal(mean, sd) per parameter (the posterior
    marginals), or uniform on `bounds` [(lo, hi), …] when given. `n_base` is rounded up to a
    power of two (the Sobol' sequence's balance); the matrix has n_base·(p + 2) rows."""
    from SALib.sample import sobol as sobol_sample

    p = len(names)
    n2 = 1 << max(int(np.ceil(np.log2(max(n_base, 2)))), 1)
    if bounds is not None:
        problem = {"num_vars": p, "names": list(names),
                   "bounds": [[float(lo), float(hi)] for lo, hi in bounds]}
    else:
        sd = np.asarray(sd, dtype=float)
        if np.any(~(sd > 0)):
            raise ValueError("every posterior sd must be positive for a normal input")
        problem = {"num_vars": p, "names": list(names),
                   "bounds": [[float(m), float(s)] for m, s in zip(mean, sd)],
                   "dists": ["norm"] * p}
    X = sobol_sample.sample(problem, n2, calc_second_order=False, seed=seed)
    return SobolDesign(problem=problem, X=X, n_base=n2, seed=seed)


def design_chunks(design: SobolDesign, chunk_size: int) -> Iterator[tuple[slice, np.ndarray]]:
    """Row blocks (slice, rows) of the sample matrix; evaluate each anywhere and put the
    outputs back at the same rows."""
    m = design.X.shape[0]
    for start in range(0, m, chunk_size):
        sl = slice(start, min(start + chunk_size, m))
        yield sl, design.X[sl]


def evaluate_chunks(model: Model, design: SobolDesign, chunk_size: int = 4096,
                    map_fn: Callable | None = None) -> np.ndarray:
    """Evaluate a vectorised model over the design in row blocks of `chunk_size` (bounded
    memory); returns (M,) or (M, T). map_fn: a `map`-like callable, map_fn(model, blocks) ->
    outputs in order, that evaluates the blocks elsewhere (e.g. on a cluster); default here one
    after another, polling the stop check (estimator.stopping) before each block."""
    chunks = list(design_chunks(design, chunk_size))
    outputs = (map_fn or _polling_map)(model, [rows for _, rows in chunks])
    out = None
    for (sl, _), y in zip(chunks, outputs, strict=True):
        y = np.asarray(y, dtype=float)
        if out is None:
            out = np.empty((design.X.shape[0],) + y.shape[1:])
        out[sl] = y
    return out


def _polling_map(fn: Callable, items: list) -> Iterator:
    """Builtin `map` with the stop check polled before each item."""
    stop = stopping.current()
    for item in items:
        stop()
        yield fn(item)


def sobol_analyze(design: SobolDesign, Y: np.ndarray, num_resamples: int = 100,
                  conf_level: float = 0.95, max_times: int = 30, rel_var_floor: float = 1e-9
                  ) -> SobolResult:
    """First-order and total-effect indices with bootstrap confidence half-widths from the
    model outputs at the design rows. A 2-D output (M, T) is analysed at up to `max_times`
    evenly spaced time indices (SALib's bootstrap costs ~0.1 s per analysed output) whose output variance exceeds `rel_var_floor`·max variance
    (a constant output has no indices), then aggregated with variance weights."""
    from SALib.analyze import sobol as sobol_analyze_

    names = design.problem["names"]
    seed = design.seed + 1  # SALib treats seed 0 as "unseeded"
    Y = np.asarray(Y, dtype=float)
    if Y.shape[0] != design.X.shape[0]:
        raise ValueError(f"{Y.shape[0]} outputs for {design.X.shape[0]} design rows")
    if Y.ndim == 1:
        si = sobol_analyze_.analyze(design.problem, Y, calc_second_order=False,
                                    num_resamples=num_resamples, conf_level=conf_level,
                                    seed=seed)
        table = pd.DataFrame({"name": names, "S1": si["S1"], "S1_conf": si["S1_conf"],
                              "ST": si["ST"], "ST_conf": si["ST_conf"]})
        return SobolResult(table=table)
    var = Y.var(axis=0)
    ok = np.flatnonzero(var > rel_var_floor * var.max()) if var.max() > 0 else np.array([], int)
    if ok.size == 0:
        raise ValueError("the output does not vary over the inputs: no sensitivity to analyse")
    idx = ok[np.unique(np.linspace(0, ok.size - 1, min(max_times, ok.size)).round().astype(int))]
    p = len(names)
    S1 = np.empty((idx.size, p))
    S1c = np.empty((idx.size, p))
    ST = np.empty((idx.size, p))
    STc = np.empty((idx.size, p))
    for k, t in enumerate(idx):
        stopping.poll()
        si = sobol_analyze_.analyze(design.problem, Y[:, t], calc_second_order=False,
                                    num_resamples=num_resamples, conf_level=conf_level,
                                    seed=seed)
        S1[k], S1c[k], ST[k], STc[k] = si["S1"], si["S1_conf"], si["ST"], si["ST_conf"]
    w = var[idx] / var[idx].sum()
    table = pd.DataFrame({"name": names, "S1": w @ S1, "S1_conf": w @ S1c,
                          "ST": w @ ST, "ST_conf": w @ STc})
    return SobolResult(table=table, time_index=idx, S1_t=S1, ST_t=ST, var_t=var[idx])


def sobol_indices(model: Model, names: Sequence[str], mean: Sequence[float],
                  sd: Sequence[float], n_base: int = 1024, seed: int = 0,
                  chunk_size: int = 4096, num_resamples: int = 100,
                  max_times: int = 30, map_fn: Callable | None = None) -> SobolResult:
    """Design, evaluate (chunked; map_fn as in evaluate_chunks) and analyse in one call; see
    the module docstring."""
    design = sobol_design(names, mean, sd, n_base=n_base, seed=seed)
    Y = evaluate_chunks(model, design, chunk_size=chunk_size, map_fn=map_fn)
    return sobol_analyze(design, Y, num_resamples=num_resamples, max_times=max_times)


# --- the paper's torque models, vectorised over parameter rows ---------------------------------

def eq4_torque_model(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, v_eps: float) -> Model:
    """Eq. 4's predicted torque T − τ_L [N·m] along a trajectory, for parameter rows
    (M, 5) = (I_xx, mr_x, mr_y, f_v, f_c): returns (M, T)."""
    Y = eq4_regressor(q, qd, qdd, v_eps)
    return lambda theta: np.asarray(theta, dtype=float) @ Y.T


def eq11_torque_model(delta: np.ndarray, delta_dot: np.ndarray, x: np.ndarray,
                      v_eps: float) -> Model:
    """Eq. 11's predicted torque [N·m] for a fixed Bouc–Wen state x, for parameter rows
    (M, 5) = (k_u, k_h, f_v, D+f_c, C): returns (M, T)."""
    Y = eq11_regressor(delta, delta_dot, x, v_eps)
    return lambda theta: np.asarray(theta, dtype=float) @ Y.T


def eq11_bouc_wen_torque_model(delta: np.ndarray, delta_dot: np.ndarray, v_eps: float,
                               n: int = 1, alpha: float = 1.0) -> Model:
    """Eq. 11 with the Bouc–Wen state recomputed per row (Eq. 9), for parameter rows
    (M, 7) = (β, γ, k_u, k_h, f_v, D+f_c, C) at fixed α: returns (M, T). Rows whose (β, γ)
    leave the stable region (β > 0, β + γ > 0) are evaluated anyway (the recursion stays
    finite for the sub-stepped integrator over a finite twist record)."""
    from estimator.bouc_wen_kernel import bw_state_batch

    fixed = eq11_regressor(delta, delta_dot, np.zeros_like(np.asarray(delta, float)), v_eps)

    def model(rows: np.ndarray) -> np.ndarray:
        rows = np.asarray(rows, dtype=float)
        xs = bw_state_batch(delta, alpha, rows[:, 0], rows[:, 1], n)      # (M, T)
        th = rows[:, 2:]
        return th @ fixed.T + th[:, 1:2] * xs
    return model


def sobol_from_fit(fit, model: Model, n_base: int = 1024, seed: int = 0,
                   chunk_size: int = 4096, num_resamples: int = 100,
                   max_times: int = 30) -> SobolResult:
    """Sobol indices of a vectorised torque model over a Fit's posterior marginals (its
    parameter names, posterior means and sds, in the Fit's parameter order)."""
    return sobol_indices(model, fit.param_names, fit.mean, fit.sd, n_base=n_base, seed=seed,
                         chunk_size=chunk_size, num_resamples=num_resamples,
                         max_times=max_times)
