"""Figures of a sim-to-real gap diagnosis for its report section (SVG bytes, drawn without
pyplot, see api/run_plots.py), from the stored diagnosis document (estimator.diagnosis report with its `series`):

- `residual_maps`      mean residual ± SE in every region of every family (speed band, direction
                       of power flow, load band, reversals, scheme/phase, angle, temperature,
                       time), flagged regions in red;
- `residual_vs_angle`  residual against the output angle (modulo the gear period when the
                       residual has an angular line), before and after the chosen effects;
- `residual_vs_time`   residual against time within each run, before and after;
- `candidates`         held-out shrinkage of every candidate effect, significant ones marked;
- `region_before_after`  measured target vs the nominal model's prediction vs the prediction
                       with the chosen effects, over the samples of one flagged region.
Each returns None when the document lacks what the figure shows."""

from __future__ import annotations

from typing import Any, Sequence

import matplotlib
import numpy as np

from api.run_plots import _svg, subplots

FAMILY_ORDER = ("speed", "power", "load", "reversal", "scheme", "angle", "temperature", "time")
BEFORE, AFTER, MEASURED = "tab:red", "tab:blue", "0.25"


def _series(doc: dict[str, Any]) -> dict[str, Any] | None:
    s = doc.get("series")
    if not s or not s.get("measured"):
        return None
    out = dict(s)
    for k in ("t", "q", "measured", "baseline", "final", "run"):
        if s.get(k) is not None:
            out[k] = np.asarray(s[k], dtype=float)
    return out


def _ylabel(doc: dict[str, Any], what: str = "residual") -> str:
    s = (doc.get("baseline") or {}).get("target") or doc.get("series") or {}
    return f"{what} {s.get('label', '')} [{s.get('unit', '')}]".strip()


def _has_effects(doc: dict[str, Any]) -> bool:
    return bool(doc.get("verdict", {}).get("effects"))


def residual_maps(doc: dict[str, Any]) -> bytes | None:
    """Mean residual ± SE (batch means) per region, one panel per region family."""
    regions = doc.get("all_regions") or []
    fams = [f for f in FAMILY_ORDER if any(r["family"] == f for r in regions)]
    fams += sorted({r["family"] for r in regions} - set(fams))
    if not fams:
        return None
    ncol = 2
    nrow = (len(fams) + 1) // ncol
    fig, axes = subplots(nrow, ncol, figsize=(11, 2.1 * nrow + 0.6), squeeze=False)
    for ax, fam in zip(axes.flat, fams):
        rows = [r for r in regions if r["family"] == fam]
        rows.sort(key=lambda r: r["where"])
        y = np.arange(len(rows))
        mean = np.array([r["mean"] if r["mean"] is not None else np.nan for r in rows])
        se = np.array([r["mean_se"] if r["mean_se"] is not None else np.nan for r in rows])
        colors = [BEFORE if r["flagged"] else "0.45" for r in rows]
        ax.barh(y, mean, xerr=se, color=colors, alpha=0.75, ecolor="k", capsize=3)
        ax.axvline(0.0, color="k", lw=0.7)
        ax.set_yticks(y, [f"{r['where']} ({100 * r['share']:.0f} %)" for r in rows], fontsize=7)
        ax.set_title(f"{fam}", fontsize=9)
        ax.tick_params(axis="x", labelsize=7)
    for ax in axes.flat[len(fams):]:
        ax.set_visible(False)
    fig.suptitle("Where the residual lies: mean residual ± SE per region "
                 "(red: flagged; % = share of residual energy)", fontsize=10)
    fig.supxlabel(_ylabel(doc, "mean residual"), fontsize=9)
    fig.tight_layout()
    return _svg(fig)


def _binned(x: np.ndarray, e: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    edges = np.linspace(np.min(x), np.max(x), bins + 1)
    k = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, bins - 1)
    cnt = np.bincount(k, minlength=bins)
    m = np.bincount(k, weights=e, minlength=bins) / np.maximum(cnt, 1)
    ok = cnt >= 3
    return 0.5 * (edges[:-1] + edges[1:])[ok], m[ok]


def residual_vs_angle(doc: dict[str, Any]) -> bytes | None:
    """Residual against the output angle: the phase within one period of the residual's angular
    line (order k cycles per revolution) when there is one, else the angle itself; points and
    binned means, before and after the chosen effects."""
    s = _series(doc)
    if s is None or s.get("q") is None:
        return None
    q = s["q"]
    k = s.get("angle_order")
    if k:
        x = np.degrees(np.mod(k * q, 2 * np.pi))
        xlabel = f"output angle phase within 2π/{k} (k = {k} cycles per revolution) [°]"
    else:
        x = np.degrees(q)
        xlabel = "output angle q [°]"
    e0 = s["measured"] - s["baseline"]
    fig, ax = subplots(figsize=(9, 3.8))
    ax.plot(x, e0, ".", ms=2, color=BEFORE, alpha=0.25, rasterized=True)
    ax.plot(*_binned(x, e0, 36), "-", color=BEFORE, lw=2, label="nominal model (binned mean)")
    if _has_effects(doc):
        e1 = s["measured"] - s["final"]
        ax.plot(x, e1, ".", ms=2, color=AFTER, alpha=0.25, rasterized=True)
        ax.plot(*_binned(x, e1, 36), "-", color=AFTER, lw=2,
                label=f"with {' + '.join(doc['verdict']['effects'])} (binned mean)")
    ax.axhline(0.0, color="k", lw=0.7)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(_ylabel(doc))
    ax.set_title("Residual vs output angle")
    ax.legend(fontsize=8)
    return _svg(fig)


def residual_vs_time(doc: dict[str, Any], run_ids: Sequence[int] | None = None) -> bytes | None:
    """Residual against time within each run (one colour per run), before and, when effects
    were chosen, after them."""
    s = _series(doc)
    if s is None:
        return None
    after = _has_effects(doc)
    fig, axes = subplots(2 if after else 1, 1, figsize=(9, 5.6 if after else 3.2),
                         sharex=True, sharey=True, squeeze=False)
    runs = s["run"].astype(int)
    n_train = int(s.get("n_train_runs", 0))
    cmap = matplotlib.colormaps["tab10"]
    panels = [("nominal model", s["measured"] - s["baseline"])]
    if after:
        panels.append((f"with {' + '.join(doc['verdict']['effects'])}",
                       s["measured"] - s["final"]))
    for ax, (title, e) in zip(axes[:, 0], panels):
        for j, r in enumerate(np.unique(runs)):
            m = runs == r
            rid = run_ids[r] if run_ids is not None and r < len(run_ids) else r
            role = "train" if r < n_train else "held-out"
            ax.plot(s["t"][m], e[m], ".", ms=2, color=cmap(j % 10), rasterized=True,
                    label=f"run {rid} ({role})")
        ax.axhline(0.0, color="k", lw=0.7)
        ax.set_ylabel(_ylabel(doc))
        ax.set_title(f"Residual vs time — {title}", fontsize=10)
    axes[0, 0].legend(fontsize=7, markerscale=4, ncol=2)
    axes[-1, 0].set_xlabel("time within the run [s]")
    return _svg(fig)


def candidates(doc: dict[str, Any], law: str | None = None) -> bytes | None:
    """Held-out RMSE shrinkage of each candidate effect (significant ones in green, with z); with
    `law`, only the candidates added to that model (rows name it under 'model')."""
    rows = [r for r in doc.get("candidates") or [] if law is None or r.get("model", law) == law]
    if not rows:
        return None
    rows = list(reversed(rows))                 # best at the top
    y = np.arange(len(rows))
    sh = np.array([r["shrinkage"] if r["shrinkage"] is not None else np.nan for r in rows])
    fig, ax = subplots(figsize=(8, 0.45 * len(rows) + 1.2))
    ax.barh(y, sh, color=["tab:green" if r["significant"] else "0.6" for r in rows])
    ax.set_yticks(y, [f"{r['effect']} (z {r['z']:.1f})" for r in rows], fontsize=8)
    ax.axvline(0.0, color="k", lw=0.7)
    ax.set_xlabel("held-out RMSE shrinkage 1 − after/before")
    ax.set_title(f"Candidate effects{' added to ' + law if law else ''} (green: significant)")
    return _svg(fig)


def region_before_after(doc: dict[str, Any], region: dict[str, Any],
                        run_ids: Sequence[int] | None = None) -> bytes | None:
    """Measured target, the nominal prediction and the prediction with the chosen effects over
    one held-out run (the one holding most samples of the region; a training run when no
    held-out run does), the region's samples marked; residuals before/after underneath."""
    s = _series(doc)
    if s is None:
        return None
    idx = np.asarray(region.get("index") or [], dtype=int)
    if idx.size == 0:
        return None
    runs = s["run"].astype(int)
    n_train = int(s.get("n_train_runs", 0))
    counts = {int(r): int(np.sum(runs[idx] == r)) for r in np.unique(runs[idx])}
    held = {r: c for r, c in counts.items() if r >= n_train}
    r = max(held or counts, key=(held or counts).get)
    in_run = np.flatnonzero(runs == r)
    sel = idx[runs[idx] == r]
    t = s["t"]
    after = _has_effects(doc)
    fx = " + ".join(doc.get("verdict", {}).get("effects") or [])
    fig, (ax, axr) = subplots(2, 1, figsize=(9, 5.4), sharex=True,
                              gridspec_kw={"height_ratios": [3, 2]})
    ax.plot(t[in_run], s["measured"][in_run], "-", color=MEASURED, lw=0.6, alpha=0.35)
    ax.plot(t[in_run], s["baseline"][in_run], "-", color=BEFORE, lw=0.6, alpha=0.35)
    ax.plot(t[sel], s["measured"][sel], ".", ms=3, color=MEASURED, label="measured",
            rasterized=True)
    ax.plot(t[sel], s["baseline"][sel], ".", ms=3, color=BEFORE, label="nominal model",
            rasterized=True)
    if after:
        ax.plot(t[in_run], s["final"][in_run], "-", color=AFTER, lw=0.6, alpha=0.35)
        ax.plot(t[sel], s["final"][sel], ".", ms=3, color=AFTER, label=f"with {fx}",
                rasterized=True)
    ax.set_ylabel(_ylabel(doc, ""))
    rid = run_ids[r] if run_ids is not None and r < len(run_ids) else r
    role = "held-out" if r >= n_train else "training"
    ax.set_title(f"{region['where']} — {role} run {rid} (dots: samples in the region)",
                 fontsize=10)
    ax.legend(fontsize=8, markerscale=3)
    axr.plot(t[sel], (s["measured"] - s["baseline"])[sel], ".", ms=3, color=BEFORE,
             label="residual, nominal", rasterized=True)
    if after:
        axr.plot(t[sel], (s["measured"] - s["final"])[sel], ".", ms=3, color=AFTER,
                 label=f"residual, with {fx}", rasterized=True)
    axr.axhline(0.0, color="k", lw=0.7)
    axr.set_ylabel(_ylabel(doc))
    axr.set_xlabel("time within the run [s]")
    axr.legend(fontsize=8, markerscale=3)
    return _svg(fig)


def diagnosis_figures(doc: dict[str, Any], run_ids: Sequence[int] | None = None,
                      max_regions: int = 4, prefix: str = "diagnosis_") -> dict[str, bytes]:
    """Every figure of one model law's diagnosis by name (prefix + residual_map,
    residual_vs_angle, residual_vs_time, candidates, region_1 ...: those the document supports),
    the before/after plots of the `max_regions` flagged regions with the largest share.
    run_ids: the job's training then held-out run ids (the series' run indices)."""
    law = (doc.get("baseline") or {}).get("model")
    figs = {"residual_map": residual_maps(doc),
            "residual_vs_angle": residual_vs_angle(doc),
            "residual_vs_time": residual_vs_time(doc, run_ids),
            "candidates": candidates(doc, law)}
    regions = (doc.get("series") or {}).get("regions") or []
    for k, reg in enumerate(regions[:max_regions], 1):
        figs[f"region_{k}"] = region_before_after(doc, reg, run_ids)
    return {prefix + k: v for k, v in figs.items() if v is not None}
