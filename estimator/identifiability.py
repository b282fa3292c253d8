"""Identifiability report of a linear(ised) fit: what the data can and cannot separate.

- condition number of the observation matrix as recorded (units as they are: the paper's
  excitation-design criterion) and of the column-equilibrated matrix (units removed);
- Belsley's collinearity diagnostics on the unit-length columns: condition indices
  η_k = s_max/s_k and variance-decomposition proportions; a direction with η_k > 30 (Belsley,
  Kuh & Welsch 1980) is reported as a combination the data cannot separate, written in the
  parameters' names: `combination` is the right singular vector on the unit-length columns
  (dimensionless, what `involved` and `text` use), `direction_physical` the same direction in
  the parameters' own units (changing θ along it barely changes the prediction);
- parameter correlations from (XᵀX)⁻¹ and variance inflation factors.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

WEAK_INDEX = 30.0
"""Belsley's threshold on the condition index for a harmful near-dependency."""


def identifiability_report(X: np.ndarray, names: Sequence[str], weak_index: float = WEAK_INDEX,
                           ) -> dict[str, Any]:
    """Report on the observation matrix X (n, p) with parameter names (see the module
    docstring). Pure linear algebra: valid for any method's fit of a linear model, and for a
    nonlinear model with X its Jacobian."""
    X = np.asarray(X, dtype=float)
    names = list(names)
    n, p = X.shape
    s_raw = np.linalg.svd(X, compute_uv=False)
    norms = np.sqrt(np.sum(X * X, axis=0))
    zero = [names[j] for j in range(p) if not norms[j] > 0]
    Xn = X / np.where(norms > 0, norms, 1.0)
    _, s, Vt = np.linalg.svd(Xn, full_matrices=False)
    with np.errstate(divide="ignore"):
        index = np.where(s > 0, s.max() / s, np.inf)
    # Variance-decomposition proportions: phi_jk = v_jk²/s_k², normalised over k per parameter.
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = (Vt.T ** 2) / np.where(s > 0, s ** 2, np.nan)
        pi = phi / np.nansum(phi, axis=1, keepdims=True)
    weak = []
    for k in np.argsort(-index):
        if not index[k] > weak_index:
            continue
        v = Vt[k]
        v = v * np.sign(v[np.argmax(np.abs(v))])
        involved = [names[j] for j in range(p) if np.abs(v[j]) >= 0.1]
        text = " ".join(f"{'+' if c >= 0 else '−'} {abs(c):.2f}·{names[j]}"
                        for j, c in enumerate(v) if abs(c) >= 0.1).lstrip("+ ")
        phys = v / np.where(norms > 0, norms, 1.0)      # X·phys ≈ 0 in physical units
        phys = phys / np.abs(phys).max()
        weak.append({"condition_index": float(index[k]), "combination": dict(zip(names, v.tolist())),
                     "direction_physical": dict(zip(names, phys.tolist())),
                     "involved": involved, "text": text,
                     "variance_proportions": {names[j]: float(pi[j, k]) for j in range(p)}})
    G = Xn.T @ Xn
    try:
        Ginv = np.linalg.inv(G)
        d = np.sqrt(np.abs(np.diag(Ginv)))
        corr = Ginv / np.outer(d, d)
        vif = np.diag(Ginv) * np.diag(G)
    except np.linalg.LinAlgError:
        corr = np.full((p, p), np.nan)
        vif = np.full(p, np.inf)
    return {
        "n_samples": int(n), "n_params": int(p), "rank": int(np.sum(s > s.max() * max(n, p) * 1e-16)),
        "condition_number": float(s_raw.max() / s_raw.min()) if s_raw.min() > 0 else float("inf"),
        "condition_number_scaled": float(index.max()),
        "condition_indices": index.tolist(), "zero_columns": zero,
        "correlations": corr.tolist(), "vif": dict(zip(names, np.asarray(vif, dtype=float).tolist())),
        "weak_directions": weak, "identifiable": not weak and not zero,
        "param_names": names,
    }


def report_text(rep: dict[str, Any]) -> str:
    """A few lines for the command line."""
    lines = [f"observation matrix: N = {rep['n_samples']}, p = {rep['n_params']}, rank "
             f"{rep['rank']}, condition number {rep['condition_number']:.3g} as recorded, "
             f"{rep['condition_number_scaled']:.3g} with unit-length columns"]
    for z in rep["zero_columns"]:
        lines.append(f"  column of {z} is identically zero: {z} cannot be identified")
    for w in rep["weak_directions"]:
        lines.append(f"  cannot separate (condition index {w['condition_index']:.3g}): {w['text']}")
    names = rep["param_names"]
    corr = np.asarray(rep["correlations"])
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if np.isfinite(corr[i, j]) and abs(corr[i, j]) > 0.9:
                lines.append(f"  strong correlation {names[i]}–{names[j]}: {corr[i, j]:+.3f}")
    if rep["identifiable"]:
        lines.append("  every parameter is separately identifiable from these data")
    return "\n".join(lines)
