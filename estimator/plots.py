"""Figures of the paper's Section V (no display needed): predicted vs
measured output (Figs. 9, 11, 13), posterior histograms (Figs. 12, 20), corner plots (Figs. 10, 19),
R-hat every 200 iterations (Figs. 16–17), autocorrelation (Figs. 14–15) and Sobol index bars
(Figs. 21–24, data from estimator.sobol).

Every function returns the figure as bytes in `fmt` ('svg' or 'png'), or writes it to `path`
(format from the suffix) and returns the path.

Figures are `matplotlib.figure.Figure` objects made by `subplots` here, never drawn through
`pyplot`: pyplot keeps a process-wide registry of open figures and a current figure, shared by
every thread, and the service draws report figures from request threads at the same time. A
Figure owned by one call needs no closing and no backend selection."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from estimator.result import Fit


def subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float],
             **kw: Any) -> tuple[Figure, Any]:
    """A new figure [inches] and its axes (`Figure.subplots` keywords: sharex, squeeze,
    gridspec_kw, ...), owned by the caller alone: no pyplot state."""
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kw)


def _emit(fig: Figure, path: str | Path | None, fmt: str) -> bytes | Path:
    if path is not None:
        path = Path(path)
        fig.savefig(path, format=path.suffix.lstrip(".") or fmt, bbox_inches="tight")
        return path
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, bbox_inches="tight")
    return buf.getvalue()


def predicted_vs_measured(t: np.ndarray, y: np.ndarray, predictions: Mapping[str, np.ndarray],
                          ylabel: str = "output torque [N·m]", title: str | None = None,
                          path: str | Path | None = None, fmt: str = "svg",
                          max_points: int = 20000) -> bytes | Path:
    """Measured output and each method's prediction against time, residuals underneath."""
    t = np.asarray(t, dtype=float)
    step = max(1, t.size // max_points)
    fig, (ax, axr) = subplots(2, 1, figsize=(9, 5.5), sharex=True,
                              gridspec_kw={"height_ratios": [3, 1]})
    ax.plot(t[::step], np.asarray(y)[::step], color="0.2", lw=0.8, label="measured")
    for label, yh in predictions.items():
        ax.plot(t[::step], np.asarray(yh)[::step], lw=0.9, label=label)
        axr.plot(t[::step], (np.asarray(y) - np.asarray(yh))[::step], lw=0.6, label=label)
    ax.set_ylabel(ylabel)
    ax.legend(loc="best", fontsize=8)
    axr.set_ylabel("residual")
    axr.set_xlabel("time [s]")
    if title:
        ax.set_title(title)
    return _emit(fig, path, fmt)


def _draws_of(fit: Fit) -> np.ndarray:
    if fit.draws is None:
        raise ValueError(f"the {fit.method!r} fit has no posterior draws to plot")
    return np.asarray(fit.draws).reshape(-1, len(fit.param_names))


def posterior_histograms(fit: Fit, truth: Sequence[float] | None = None, bins: int = 50,
                         path: str | Path | None = None, fmt: str = "svg") -> bytes | Path:
    """One histogram per parameter with the posterior mean, the 95 % interval and (optionally)
    the true value."""
    d = _draws_of(fit)
    p = d.shape[1]
    cols = min(p, 3)
    rows = int(np.ceil(p / cols))
    fig, axes = subplots(rows, cols, figsize=(3.3 * cols, 2.6 * rows), squeeze=False)
    for j in range(rows * cols):
        ax = axes.flat[j]
        if j >= p:
            ax.axis("off")
            continue
        ax.hist(d[:, j], bins=bins, color="C0", alpha=0.75, density=True)
        ax.axvline(fit.mean[j], color="k", lw=1)
        ax.axvspan(fit.ci_low[j], fit.ci_high[j], color="C1", alpha=0.15)
        if truth is not None:
            ax.axvline(truth[j], color="C3", ls="--", lw=1)
        ax.set_title(f"{fit.param_names[j]} [{fit.units[j]}]", fontsize=9)
        ax.tick_params(labelsize=7)
    fig.suptitle(f"{fit.model} — {fit.method}: posterior", fontsize=10)
    fig.tight_layout()
    return _emit(fig, path, fmt)


def corner_plot(fit: Fit, bins: int = 40, max_points: int = 2000, path: str | Path | None = None,
                fmt: str = "svg") -> bytes | Path:
    """Pairwise scatter of the draws under the diagonal (rasterised), marginal histograms on it."""
    d = _draws_of(fit)
    p = d.shape[1]
    rng = np.random.default_rng(0)
    sub = d[rng.choice(d.shape[0], size=min(max_points, d.shape[0]), replace=False)]
    fig, axes = subplots(p, p, figsize=(1.9 * p + 1, 1.9 * p + 1), squeeze=False)
    for i in range(p):
        for j in range(p):
            ax = axes[i, j]
            if j > i:
                ax.axis("off")
                continue
            if i == j:
                ax.hist(d[:, j], bins=bins, color="C0", alpha=0.8)
            else:
                ax.plot(sub[:, j], sub[:, i], ".", ms=1.0, alpha=0.4, color="C0",
                        rasterized=True)  # keeps the SVG small
            ax.tick_params(labelsize=6)
            if i == p - 1:
                ax.set_xlabel(fit.param_names[j], fontsize=8)
            else:
                ax.set_xticklabels([])
            if j == 0 and i > 0:
                ax.set_ylabel(fit.param_names[i], fontsize=8)
            elif j > 0:
                ax.set_yticklabels([])
    fig.suptitle(f"{fit.model} — {fit.method}: corner plot", fontsize=10)
    return _emit(fig, path, fmt)


def draw_rhat_trace(ax, iterations, rhat, names, title: str, legend_size: int = 7) -> None:
    """One axes of split R-hat against iterations per chain (Figs. 16–17), one line per
    parameter, with the 1.01 convergence line."""
    its, r = np.asarray(iterations), np.asarray(rhat, dtype=float)
    if r.size:
        for j, n in enumerate(names):
            ax.plot(its, r[:, j], marker=".", lw=1, label=n)
    ax.axhline(1.01, color="0.5", ls=":", lw=1)
    ax.set_xlabel("iterations per chain")
    ax.set_ylabel("split R-hat")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=legend_size)


def rhat_trace_plot(fits: Sequence[Fit], path: str | Path | None = None, fmt: str = "svg"
                    ) -> bytes | Path:
    """Split R-hat computed every 200 iterations, one line per parameter, one panel per fit."""
    fits = [f for f in fits if f.diagnostics.get("rhat_trace")]
    if not fits:
        raise ValueError("no fit with an R-hat trace")
    fig, axes = subplots(1, len(fits), figsize=(5 * len(fits), 3.4), squeeze=False)
    for ax, f in zip(axes.flat, fits):
        tr = f.diagnostics["rhat_trace"]
        draw_rhat_trace(ax, tr["iterations"], tr["rhat"], f.param_names,
                        f"{f.model} — {f.method}", legend_size=7)
    fig.tight_layout()
    return _emit(fig, path, fmt)


def autocorr_plot(fit: Fit, path: str | Path | None = None, fmt: str = "svg") -> bytes | Path:
    """Autocorrelation function per parameter (mean over chains)."""
    acf = np.asarray(fit.diagnostics.get("autocorr"))
    if acf.ndim != 2:
        raise ValueError(f"the {fit.method!r} fit has no autocorrelation to plot")
    fig, ax = subplots(figsize=(6, 3.4))
    for j, n in enumerate(fit.param_names):
        ax.plot(np.arange(acf.shape[0]), acf[:, j], lw=1, label=n)
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel("lag")
    ax.set_ylabel("autocorrelation")
    ax.set_title(f"{fit.model} — {fit.method}", fontsize=10)
    ax.legend(fontsize=7)
    return _emit(fig, path, fmt)


def sobol_bars(names: Sequence[str], S1: Sequence[float], ST: Sequence[float],
               S1_conf: Sequence[float] | None = None, ST_conf: Sequence[float] | None = None,
               title: str | None = None, path: str | Path | None = None, fmt: str = "svg"
               ) -> bytes | Path:
    """First-order (Eq. 18) and total-effect (Eq. 19) Sobol indices as grouped bars with their
    confidence half-widths."""
    x = np.arange(len(names))
    w = 0.38
    fig, ax = subplots(figsize=(max(5, 1.1 * len(names) + 2), 3.6))
    ax.bar(x - w / 2, S1, w, yerr=S1_conf, capsize=3, label="first order $S_1$")
    ax.bar(x + w / 2, ST, w, yerr=ST_conf, capsize=3, label="total effect $S_T$")
    ax.set_xticks(x, list(names))
    ax.set_ylabel("Sobol index")
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    return _emit(fig, path, fmt)


def sobol_bars_from_table(table, title: str | None = None, path: str | Path | None = None,
                          fmt: str = "svg") -> bytes | Path:
    """sobol_bars from estimator.sobol's result table (columns name, S1, S1_conf, ST, ST_conf)."""
    return sobol_bars(list(table["name"]), table["S1"], table["ST"],
                      table.get("S1_conf"), table.get("ST_conf"), title, path, fmt)
