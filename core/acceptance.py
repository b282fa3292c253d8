"""The platform's acceptance indicators for a loading run (rig.md, Table 11).

- torque loading error: `torque_load − torque_cmd`, tolerance ±2 kN·m;
- bending-moment load error: `m_bend` − its set point, tolerance ±2 kN·m;
- shear loading error: `f_shear` − its set point, tolerance ±2 kN.

Set points of the hydraulics come from the run's metadata: `shear_setpoint_n` [N] (default the
scheme's 90 kN) and `bend_setpoint_nm` [N·m] (default shear set point × the cylinder's lever
JointParams.arm_bend, 90 kN × 2.5 m = 225 kN·m). The torque set point is the run's own
`torque_cmd` channel.

Which samples are judged: those of the loading phases (load, hold, unload) when the run has a
`phase` channel, else all; minus the settling after a set point jump, which measures the
actuator's response, not its loading error: `acceptance_settle_s` [s] (metadata) after the
start of each loading segment and after each torque set-point step larger than half the
tolerance between two samples; default five time constants, 5 × dyno_tau for the torque and
5 × p_tau for the hydraulics (JointParams). Missing samples are not judged and are counted.
An indicator passes when max |error| over the judged samples is within the tolerance; it is
None (not judged) when the channel is absent or no sample is judged.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from core.params import JointParams
from core.run import RunData

LOADING_PHASES = ("load", "hold", "unload")
TORQUE_TOL = 2e3
"""Torque and bending-moment loading error tolerance [N·m] (Table 11)."""
SHEAR_TOL = 2e3
"""Shear loading error tolerance [N] (Table 11)."""
SHEAR_SETPOINT = 90e3
"""Shear loading value of the schemes [N] (Table 11)."""


@dataclass
class Indicator:
    """One acceptance indicator of a run. Errors in the channel's SI unit."""
    name: str
    channel: str
    unit: str
    setpoint: str
    tolerance: float
    judged: int
    missing: int
    max_abs: float | None
    mean: float | None
    rms: float | None
    passed: bool | None
    note: str = ""

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def is_loading_run(run: RunData) -> bool:
    """A run that loads the joint: scheme 1 or 2, or (no scheme) one with a torque set point."""
    scheme = run.meta.get("scheme")
    if scheme in (1, 2):
        return True
    return scheme is None and "torque_cmd" in run.samples.columns


def _loading_mask(run: RunData) -> np.ndarray:
    if "phase" in run.samples.columns:
        return run.samples["phase"].isin(LOADING_PHASES).to_numpy()
    return np.ones(len(run), dtype=bool)


def _settling(t: np.ndarray, starts: np.ndarray, settle_s: float) -> np.ndarray:
    """Samples within settle_s after any of the times t[starts]."""
    if len(starts) == 0:
        return np.zeros(len(t), dtype=bool)
    ts = np.sort(t[starts])
    k = np.searchsorted(ts, t, side="right") - 1   # latest start at or before each sample
    return (k >= 0) & (t - ts[np.maximum(k, 0)] < settle_s)


def _segment_starts(mask: np.ndarray) -> np.ndarray:
    return np.flatnonzero(mask & ~np.concatenate([[False], mask[:-1]]))


def _indicator(name: str, channel: str, unit: str, setpoint_text: str, tol: float,
               err: np.ndarray | None, judge: np.ndarray, note: str = "") -> Indicator:
    if err is None:
        return Indicator(name, channel, unit, setpoint_text, tol, 0, 0, None, None, None, None,
                         note or f"no {channel} channel")
    ok = judge & ~np.isnan(err)
    missing = int(np.sum(judge & np.isnan(err)))
    if not ok.any():
        return Indicator(name, channel, unit, setpoint_text, tol, 0, missing, None, None, None,
                         None, note or "no sample to judge")
    e = err[ok]
    max_abs = float(np.max(np.abs(e)))
    return Indicator(name, channel, unit, setpoint_text, tol, int(ok.sum()), missing, max_abs,
                     float(np.mean(e)), float(np.sqrt(np.mean(e * e))), bool(max_abs <= tol), note)


def acceptance(run: RunData, params: JointParams | None = None) -> list[Indicator]:
    """The three Table 11 indicators of a run (see the module doc); for a run that does not
    load the joint every indicator is None with the note 'not a loading run'."""
    params = params or JointParams()
    meta = run.meta
    names = ("torque loading error", "bending moment load error", "shear loading error")
    chans = ("torque_load", "m_bend", "f_shear")
    units = ("N·m", "N·m", "N")
    if not is_loading_run(run):
        return [Indicator(n, c, u, "", tol, 0, 0, None, None, None, None, "not a loading run")
                for n, c, u, tol in zip(names, chans, units, (TORQUE_TOL, TORQUE_TOL, SHEAR_TOL))]
    cols = run.samples.columns
    t = run.t
    loading = _loading_mask(run)
    starts = _segment_starts(loading)
    settle_meta = meta.get("acceptance_settle_s")

    # torque: measured load vs its set point channel
    settle_q = settle_meta if settle_meta is not None else 5.0 * params.dyno_tau
    if "torque_load" in cols and "torque_cmd" in cols:
        cmd = run.channel("torque_cmd")
        step = np.concatenate([[False], np.abs(np.diff(cmd)) > TORQUE_TOL / 2])
        judge = loading & ~_settling(t, np.concatenate([starts, np.flatnonzero(step)]), settle_q)
        torque = _indicator(names[0], chans[0], units[0], "torque_cmd", TORQUE_TOL,
                            run.channel("torque_load") - cmd, judge)
    else:
        absent = "torque_load" if "torque_load" not in cols else "torque_cmd"
        torque = _indicator(names[0], chans[0], units[0], "torque_cmd", TORQUE_TOL, None, loading,
                            f"no {absent} channel")

    # hydraulics: constant set points from the metadata
    shear_sp = meta.get("shear_setpoint_n")
    shear_sp = SHEAR_SETPOINT if shear_sp is None else float(shear_sp)
    bend_sp = meta.get("bend_setpoint_nm")
    bend_sp = shear_sp * params.arm_bend if bend_sp is None else float(bend_sp)
    settle_h = settle_meta if settle_meta is not None else 5.0 * params.p_tau
    judge_h = loading & ~_settling(t, starts, settle_h)
    bend = _indicator(names[1], chans[1], units[1], f"{bend_sp:g} N·m", TORQUE_TOL,
                      run.channel("m_bend") - bend_sp if "m_bend" in cols else None, judge_h)
    shear = _indicator(names[2], chans[2], units[2], f"{shear_sp:g} N", SHEAR_TOL,
                       run.channel("f_shear") - shear_sp if "f_shear" in cols else None, judge_h)
    return [torque, bend, shear]


def format_table(indicators: list[Indicator]) -> str:
    """The indicators as a text table in kN·m / kN."""
    lines = [f"{'indicator':<28}{'max |err|':>12}{'mean':>10}{'rms':>10}{'tol':>8}  "
             f"{'judged':>8}{'missing':>8}  result"]
    for ind in indicators:
        k = "kN·m" if ind.unit == "N·m" else "kN"

        def f(v: float | None) -> str:
            return "—" if v is None else f"{v / 1e3:.3f}"
        result = {True: "PASS", False: "FAIL", None: "n/a"}[ind.passed]
        if ind.note:
            result += f" ({ind.note})"
        lines.append(f"{ind.name:<28}{f(ind.max_abs):>12}{f(ind.mean):>10}{f(ind.rms):>10}"
                     f"{ind.tolerance / 1e3:>5.0f} {k:<3}{ind.judged:>8}{ind.missing:>8}  {result}")
    return "\n".join(lines)
