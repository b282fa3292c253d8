"""Figures of one run for its report (SVG bytes): load and torque following, the twist–torque
hysteresis loop, current vs torque per motor, temperatures. Each returns None when the run lacks
the channels it needs.

Figures are `matplotlib.figure.Figure` objects from `estimator.plots.subplots`, never drawn
through `pyplot` (whose process-wide figure registry request threads drawing at the same time
would share; see estimator/plots.py)."""

from __future__ import annotations

import io
from typing import Mapping

import numpy as np
from matplotlib.figure import Figure

from core.channels import unit_of
from estimator.plots import subplots

MAX_POINTS = 4000
"""Points per curve in a report plot (decimated evenly; keeps the SVG light)."""


def _svg(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="svg", bbox_inches="tight")
    return buf.getvalue()


def _have(a: Mapping[str, np.ndarray], *names: str) -> bool:
    return all(n in a and np.isfinite(np.asarray(a[n], dtype=float)).any() for n in names)


def _step(a: Mapping[str, np.ndarray]) -> int:
    return max(1, len(a["t"]) // MAX_POINTS)


def following(a: Mapping[str, np.ndarray]) -> bytes | None:
    """Dynamometer torque set point vs measured load torque, and the joint torque, against time;
    hydraulic bending moment and shear force underneath when present."""
    if not _have(a, "t", "torque_load", "torque_cmd"):
        return None
    k = _step(a)
    hyd = _have(a, "m_bend") or _have(a, "f_shear")
    fig, axes = subplots(2 if hyd else 1, 1, figsize=(9, 6 if hyd else 3.6), sharex=True,
                             squeeze=False)
    ax = axes[0, 0]
    t = a["t"][::k]
    ax.plot(t, a["torque_cmd"][::k] / 1e3, "k--", lw=1, label="set point torque_cmd")
    ax.plot(t, a["torque_load"][::k] / 1e3, lw=1, label="measured torque_load")
    if _have(a, "torque"):
        ax.plot(t, a["torque"][::k] / 1e3, lw=0.8, alpha=0.8, label="joint torque")
    ax.set_ylabel("torque [kN·m]")
    ax.set_title("Load and torque following")
    ax.legend(fontsize=8)
    if hyd:
        ax2 = axes[1, 0]
        if _have(a, "m_bend"):
            ax2.plot(t, a["m_bend"][::k] / 1e3, lw=1, label="bending moment m_bend [kN·m]")
        if _have(a, "f_shear"):
            ax2.plot(t, a["f_shear"][::k] / 1e3, lw=1, label="shear force f_shear [kN]")
        ax2.set_ylabel("hydraulic load [kN·m | kN]")
        ax2.legend(fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    return _svg(fig)


def hysteresis(a: Mapping[str, np.ndarray]) -> bytes | None:
    """Joint torque against twist (torsion q − u): the hysteresis loop."""
    if not _have(a, "torsion", "torque"):
        return None
    k = _step(a)
    fig, ax = subplots(figsize=(5.5, 4.2))
    ax.plot(np.asarray(a["torsion"])[::k] * 1e3, np.asarray(a["torque"])[::k] / 1e3, lw=0.8)
    ax.set_xlabel("twist q − u [mrad]")
    ax.set_ylabel("joint torque [kN·m]")
    ax.set_title("Twist–torque hysteresis loop")
    return _svg(fig)


def current_vs_torque(a: Mapping[str, np.ndarray]) -> bytes | None:
    """Each motor's current against the joint torque."""
    motors = [m for m in ("i_m1", "i_m2", "i_m3") if _have(a, m)]
    if not motors or not _have(a, "torque"):
        return None
    k = _step(a)
    fig, ax = subplots(figsize=(5.5, 4.2))
    for m in motors:
        ax.plot(np.asarray(a["torque"])[::k] / 1e3, np.asarray(a[m])[::k], ".", ms=1.5, label=m)
    ax.set_xlabel("joint torque [kN·m]")
    ax.set_ylabel(f"motor current [{unit_of('i_m1')}]")
    ax.set_title("Current vs torque per motor")
    ax.legend(fontsize=8, markerscale=5)
    return _svg(fig)


def temperatures(a: Mapping[str, np.ndarray]) -> bytes | None:
    """Motor winding and joint temperatures against time."""
    names = [n for n in ("temp_m1", "temp_m2", "temp_m3", "temp_joint") if _have(a, n)]
    if not names or not _have(a, "t"):
        return None
    k = _step(a)
    fig, ax = subplots(figsize=(9, 3.2))
    for n in names:
        ax.plot(a["t"][::k], np.asarray(a[n])[::k], lw=1, label=n)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"temperature [{unit_of('temp_m1')}]")
    ax.set_title("Temperatures")
    ax.legend(fontsize=8)
    return _svg(fig)


RUN_PLOTS = {
    "following": following,
    "hysteresis": hysteresis,
    "current_vs_torque": current_vs_torque,
    "temperatures": temperatures,
}
