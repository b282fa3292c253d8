"""Predicted vs measured output of an identification result, for its job report: the fit's
point estimate replayed on the runs it used (training and held-out), evenly decimated per run
and stored in the Fit's extra['series'] by the job kind; and the figure drawn from it.

Linear models (estimator.models: eq4, eq5, eq11 with x known, with effects) predict X·θ̂. A
Bouc–Wen fit (eq9, eq11 by estimator.bouc_wen) predicts with the plug-in Bouc–Wen state of
its point estimate (α fixed or fitted, β, γ, n) through Eq. 11's regressor
(estimator.models.eq11)."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

MAX_POINTS_PER_RUN = 400
"""Samples per run kept in a stored series (evenly decimated)."""


def _model_and_theta(fit) -> tuple[Any, np.ndarray]:
    from estimator.models import model_from_spec

    names = list(fit.param_names)
    mean = dict(zip(names, np.asarray(fit.mean, dtype=float)))
    if "beta" in mean and "gamma" in mean:              # a Bouc–Wen fit (estimator.bouc_wen)
        alpha = fit.extra.get("alpha_fixed")
        alpha = float(mean["alpha"] if alpha is None else alpha)
        lm = model_from_spec("eq11", alpha=alpha, beta=mean["beta"], gamma=mean["gamma"],
                             n=int(fit.extra.get("n", 1)))
    else:
        lm = model_from_spec(fit.model)
    missing = [n for n in lm.param_names if n not in mean]
    if missing:
        raise ValueError(f"fit of {fit.model!r} lacks parameters {missing}")
    return lm, np.array([mean[n] for n in lm.param_names])


def prediction_series(fit, runs: Sequence[tuple[int, str, Any]],
                      max_points: int = MAX_POINTS_PER_RUN) -> dict[str, Any]:
    """{label, unit, run_id, role, t, measured, predicted} (lists, evenly decimated to at most
    max_points per run) of `fit` replayed on runs = [(run id, role, RunData)]."""
    from estimator.preprocess import prepare

    lm, theta = _model_and_theta(fit)
    out: dict[str, Any] = {"label": lm.target_label, "unit": lm.target_unit, "run_id": [],
                           "role": [], "t": [], "measured": [], "predicted": []}
    for rid, role, run in runs:
        sig = prepare(run, lm.requires)
        y, yh = lm.target(sig), lm.design(sig) @ theta
        k = max(1, int(np.ceil(y.size / max_points)))
        sl = slice(None, None, k)
        n = y[sl].size
        out["run_id"] += [int(rid)] * n
        out["role"] += [role] * n
        for key, a in (("t", sig["t"]), ("measured", y), ("predicted", yh)):
            out[key] += [float(f"{v:.6g}") for v in np.asarray(a, dtype=float)[sl]]
    return out


def predicted_vs_measured(series: dict[str, Any], title: str) -> bytes | None:
    """Measured and predicted output against time (runs side by side, training then held-out)
    and predicted against measured (scatter with the identity line)."""
    from api.run_plots import _svg, subplots

    if not series or not series.get("measured"):
        return None
    rid = np.asarray(series["run_id"])
    role = np.asarray(series["role"])
    t = np.asarray(series["t"], dtype=float)
    y = np.asarray(series["measured"], dtype=float)
    yh = np.asarray(series["predicted"], dtype=float)
    unit = f"[{series.get('unit', '')}]"
    fig, (ax, axs) = subplots(1, 2, figsize=(12, 4.2), gridspec_kw={"width_ratios": [3, 1.3]})
    off = 0.0
    for r in dict.fromkeys(rid.tolist()):
        m = rid == r
        tt = t[m] - t[m][0] + off
        ax.plot(tt, y[m], color="0.25", lw=0.8, label="measured" if off == 0 else None)
        ax.plot(tt, yh[m], color="tab:orange" if role[m][0] == "train" else "tab:purple",
                lw=0.9, label=None)
        ax.axvline(off, color="0.7", lw=0.6)
        ax.text(off, 1.0, f" run {r} ({role[m][0]})", transform=ax.get_xaxis_transform(),
                fontsize=7, va="top")
        off = tt[-1] + max((tt[-1] - tt[0]) * 0.02, 1e-6)
    ax.plot([], [], color="tab:orange", label="predicted (training run)")
    ax.plot([], [], color="tab:purple", label="predicted (held-out run)")
    ax.set_xlabel("time, runs side by side [s]")
    ax.set_ylabel(f"{series.get('label', 'output')} {unit}")
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title(title, fontsize=10)
    for r, c in (("train", "tab:orange"), ("test", "tab:purple")):
        m = role == r
        if m.any():
            axs.plot(y[m], yh[m], ".", ms=2, color=c, alpha=0.5, rasterized=True,
                     label="training" if r == "train" else "held-out")
    lo, hi = float(np.nanmin([y.min(), yh.min()])), float(np.nanmax([y.max(), yh.max()]))
    axs.plot([lo, hi], [lo, hi], "k-", lw=0.7)
    axs.set_xlabel(f"measured {unit}")
    axs.set_ylabel(f"predicted {unit}")
    axs.set_title("Predicted vs measured", fontsize=10)
    axs.legend(fontsize=8, markerscale=4)
    fig.tight_layout()
    return _svg(fig)
