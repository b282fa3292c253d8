"""The figures of the paper reproduction (api.paper_reproduction), drawn from the report's own
data so the stored document and its page agree: Fig. 6 (excitation, condition numbers), Fig. 9
(Eq. 4 measured vs predicted), Fig. 18 (twist–torque loop measured vs predicted), Figs. 14–17
(R-hat every 200 iterations, autocorrelation), Figs. 21–24 (Sobol bars). SVG bytes."""

from __future__ import annotations

from typing import Any

import numpy as np

from estimator.plots import _emit, draw_rhat_trace, sobol_bars, subplots


def _loop(d: dict[str, Any]) -> bytes:
    fig, ax = subplots(figsize=(6, 4))
    tw = np.degrees(np.asarray(d["twist"], float))
    ax.plot(tw, np.asarray(d["measured"]) / 1e3, ".", ms=2, color="0.5", label="measured")
    for m, c in (("ls", "C1"), ("sghmc", "C0")):
        ax.plot(tw, np.asarray(d[m]) / 1e3, lw=1, color=c,
                label=f"{m.upper()} (torque RMSE {d[f'rmse_torque_{m}']:.0f} N·m)")
    ax.set_xlabel("twist Δ [°]")
    ax.set_ylabel("transmitted torque [kN·m]")
    ax.set_title(f"Fig. 18 — twist–torque loop, held-out {d['run']}", fontsize=10)
    ax.legend(fontsize=7)
    return _emit(fig, None, "svg")


def _traces(traces: dict[str, Any]) -> bytes:
    fig, axes = subplots(2, len(traces), figsize=(5 * len(traces), 6.4), squeeze=False)
    for k, (m, tr) in enumerate(traces.items()):
        draw_rhat_trace(axes[0, k], tr["iterations"], tr["rhat"], tr["names"],
                        f"Eq. 11 — {m.upper()}: R-hat every 200 iterations", legend_size=6)
        acf = np.asarray(tr["autocorr"], float)
        ax = axes[1, k]
        for j, n in enumerate(tr["names"]):
            ax.plot(np.arange(acf.shape[0]), acf[:, j], lw=1, label=n)
        ax.axhline(0, color="0.5", lw=0.8)
        ax.set_xlabel("lag")
        ax.set_ylabel("autocorrelation")
        ax.set_title(f"Eq. 11 — {m.upper()}: autocorrelation", fontsize=10)
    fig.tight_layout()
    return _emit(fig, None, "svg")


def _excitation(d: dict[str, Any]) -> bytes:
    fig, axes = subplots(1, 2, figsize=(10, 3.6))
    t = np.asarray(d["t"])
    for key, lab in (("q", "q [rad]"), ("qd", "q̇ [rad/s]"), ("qdd", "q̈ [rad/s²]")):
        v = np.asarray(d[key], float)
        axes[0].plot(t, v / (np.abs(v).max() or 1.0), lw=1, label=f"{lab} (normalised)")
    axes[0].set_xlabel("time [s]")
    axes[0].set_title("Fig. 6 — optimised excitation (one period)", fontsize=10)
    axes[0].legend(fontsize=7)
    rc = np.asarray(d["random_conds"], float)
    axes[1].hist(np.log10(rc), bins=30, color="0.6", label="random feasible")
    axes[1].axvline(np.log10(d["cond"]), color="C3", label=f"optimised ({d['cond']:.0f})")
    axes[1].set_xlabel("log10 condition number of Eq. 4's observation matrix")
    axes[1].legend(fontsize=7)
    fig.tight_layout()
    return _emit(fig, None, "svg")


def _eq4(d: dict[str, Any]) -> bytes:
    fig, ax = subplots(figsize=(8, 3.6))
    t = np.asarray(d["t"])
    ax.plot(t, np.asarray(d["measured"]) / 1e3, color="0.5", lw=1, label="measured")
    ax.plot(t, np.asarray(d["ls"]) / 1e3, color="C1", lw=1, label="LS")
    ax.plot(t, np.asarray(d["sghmc"]) / 1e3, color="C0", lw=1, ls="--", label="SGHMC")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("T − τ_L [kN·m]")
    ax.set_title("Fig. 9 — Eq. 4 on the held-out scheme-3 run", fontsize=10)
    ax.legend(fontsize=7)
    return _emit(fig, None, "svg")


def reproduction_figures(report: dict[str, Any]) -> dict[str, bytes]:
    """{name: SVG bytes} of the reproduction report's figures."""
    f = report["figures"]
    out = {"fig6_excitation": _excitation(f["excitation"]),
           "fig9_eq4_heldout": _eq4(f["eq4_test"]),
           "fig18_loop": _loop(f["loop"]),
           "fig14_17_rhat_autocorr": _traces(f["traces"])}
    for model, figs in (("eq4", "fig21_22"), ("eq11", "fig23_24")):
        t = f["sobol"][model]
        out[f"{figs}_sobol_{model}"] = sobol_bars(
            t["name"], t["S1"], t["ST"], t["S1_conf"], t["ST_conf"],
            title=f"{'Figs. 21–22' if model == 'eq4' else 'Figs. 23–24'} — Sobol indices of "
                  f"{model} over the SGHMC posterior")
    return out
