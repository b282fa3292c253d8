"""Which torque reading an offset found on the output balance lies in (estimator.diagnosis).

The output balance's target is T − τ_L: an offset or drift of the torque channel T and one of
the load reading τ_L enter it alike (with opposite signs), so that law alone cannot tell them
apart. The vocabulary's torque_offset is the torque channel's (core.effects: "offset of the
torque channel"); a load cell that drifts is outside the vocabulary. The twist–torque law reads
T and not τ_L: it takes the offset's columns found on the output law (the `carried` effects of
transmission_diagnosis) and fits them itself. If the offset is on T, its part that changes
within a run (the drift, the settling) is found there again with the same size; if it is on
τ_L, that law finds none of it.
The part constant within a run is not compared: the twist law sets each run's zero of the
twist, which takes it (estimator.diagnosis_transmission.twist_zeros)."""

from __future__ import annotations

from typing import Any

import numpy as np

from estimator.models import LinearModel

EFFECT = "torque_offset"


def _columns(model: LinearModel, sig: dict[str, np.ndarray], run: np.ndarray
             ) -> tuple[list[str], np.ndarray, np.ndarray] | None:
    """(names, indices into the model's parameters, columns on the samples `sig`) of the
    effect's columns that vary within a run, each with its per-run mean taken off; None when
    the model lacks the term."""
    start = 0
    for term in model.terms:
        if term.label == EFFECT:
            cols = term.columns(sig)
            keep = [j for j in range(cols.shape[1]) if np.ptp(cols[:, j]) > 0]
            cols = cols[:, keep].copy()
            for r in np.unique(run):
                m = run == r
                cols[m] -= cols[m].mean(axis=0)
            return [term.names[j] for j in keep], start + np.asarray(keep, dtype=int), cols
        start += len(term.names)
    return None


def offset_channel(output_model: LinearModel, output_theta: np.ndarray,
                   output_cov: np.ndarray, twist_names: list[str], twist_theta: np.ndarray,
                   twist_cov: np.ndarray, sig: dict[str, np.ndarray], run: np.ndarray,
                   z: float) -> dict[str, Any] | None:
    """Which reading the within-run part of the output law's torque_offset lies in.

    c(t) is that part as the output law fitted it, on the samples the output law read (`sig`:
    t [s], and temp_joint [°C] when the offset follows the temperature; `run`); `share` is how
    much of c the twist–torque law's own fit of the same columns holds (its projection on c,
    1 when the offset is on T, 0 when on τ_L), with its standard error
    from both fits' block-robust covariances. `channel` is 'torque_load' when the output law's
    c is significant (its size > z standard errors), `share` is nearer 0 than 1, and 1 lies
    more than z standard errors from it; 'torque' when 0 lies more than z standard errors from
    `share` and it is nearer 1; else 'undecided' (the default reading stays the vocabulary's).
    The twist law's parameters are found by name (`twist_names`; a model's names are unique,
    estimator.models.LinearModel.with_effect). None when either law lacks the term, the
    offset does not vary within a run, or a covariance is not finite (fewer than 3 blocks):
    no claim is made."""
    found = _columns(output_model, sig, run)
    if found is None or not found[0] or not set(found[0]) <= set(twist_names):
        return None
    names, i_out, G = found
    i_tw = np.asarray([list(twist_names).index(n) for n in names], dtype=int)
    b_out = np.asarray(output_theta, dtype=float)[i_out]
    b_tw = np.asarray(twist_theta, dtype=float)[i_tw]
    s_out = np.asarray(output_cov, dtype=float)[np.ix_(i_out, i_out)]
    s_tw = np.asarray(twist_cov, dtype=float)[np.ix_(i_tw, i_tw)]
    c = G @ b_out
    cc = float(c @ c)
    if not cc > 0:
        return None
    a = G.T @ c / cc                       # share = a·b: 1 for b_out itself
    share = float(a @ b_tw)
    se_out = float(np.sqrt(max(a @ s_out @ a, 0.0)))
    se_tw = float(np.sqrt(max(a @ s_tw @ a, 0.0)))
    if not (np.isfinite(se_out) and np.isfinite(se_tw)):
        return None
    se_diff = float(np.hypot(se_out, se_tw))
    z_drift = 1.0 / se_out if se_out > 0 else float("inf")
    z_not_torque = abs(share - 1.0) / se_diff if se_diff > 0 else float("inf")
    z_not_load = abs(share) / se_tw if se_tw > 0 else float("inf")
    channel = "undecided"
    if z_drift > z:
        if share < 0.5 and z_not_torque > z:
            channel = "torque_load"
        elif share >= 0.5 and z_not_load > z:
            channel = "torque"
    return {"channel": channel, "share_on_torque_channel": share, "share_se": se_tw,
            "output_se": se_out, "within_run_rms": float(np.sqrt(cc / c.size)),
            "z_output": z_drift, "z_not_torque": z_not_torque, "z_not_load": z_not_load}


LOAD_READING_DRIFT = ("the load reading (torque_load) drifts: the output balance's gap changes "
                      "with time within a run, and the twist–torque law, which reads the torque "
                      "channel and not the load cell, does not show it (outside the vocabulary)")
"""What the output balance's drift is when offset_channel puts it on τ_L."""
