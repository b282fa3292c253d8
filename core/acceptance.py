"""The platform's six acceptance indicators for a loading run (rig.md, Table 11), in this
order (each with its Table 11 `item` number):

- item 5, torque loading error: `torque_load − torque_cmd`, tolerance ±2 kN·m;
- item 4, bending-moment load error: `m_bend` − its set point, tolerance ±2 kN·m;
- item 6, shear loading error: `f_shear` − its set point, tolerance ±2 kN;
- item 1, torque loading range 0–180 kN·m: the measured `torque_load` went from within 2 kN·m
  of 0 to within 2 kN·m of 180 kN·m;
- item 2, bending moment loading range 0–250 kN·m: the same on `m_bend` (2 kN·m);
- item 3, shear loading value 90 kN: the measured `f_shear` reached within 2 kN of 90 kN.

Items 1–3 say what the run showed. One that is met passes. One that is not met fails when the
run aimed at it (its set point reached the target: the largest `torque_cmd`, the bending or
shear set point), and is otherwise "not met" with `passed` None: a run loading to the rated
120 kN·m cannot show the 180 kN·m range (that needs the "range" limit set, core/schemes.py),
nor a 90 kN shear the 250 kN·m bending range (90 kN × 2.5 m = 225 kN·m). Without the channel
an item is "not measured". `status` says which: pass, fail, not met, not measured, not judged.

Set points of the hydraulics come from the run's metadata: `shear_setpoint_n` [N] (else the
scheme's `shear_target` in `scheme_params`, else 90 kN) and `bend_setpoint_nm` [N·m] (default
shear set point × the cylinder's lever JointParams.arm_bend, 90 kN × 2.5 m = 225 kN·m). The
torque set point is the run's own `torque_cmd` channel.

Which samples are judged: those of the loading phases (load, hold, unload) when the run has a
`phase` channel, else all; minus the settling after a set point jump, which measures the
actuator's response, not its loading error: `acceptance_settle_s` [s] (metadata) after the
start of each loading segment, after each step of the torque set point `torque_cmd` larger
than half the tolerance, and — for the hydraulics — after each step of the pressure set point
the PLC applied (`pressure_sp_applied` [Pa], recorded by the DAQ; APPLIED_PRESSURE) that moves
the shear or bending set point by more than half its tolerance; default five time constants,
5 × dyno_tau for the torque and 5 × p_tau for the hydraulics (JointParams). The settling runs
from when the set point was APPLIED, as recorded: a set point that reached the rig late (a
starved service; on the emulator at 10× real time, 20 ms of wall time are 0.2 s of rig time)
moves the actuator's response, not its loading error. A run without the applied pressure
(an import, the offline emulator, whose set points follow the plan to the step) is timed from
its loading phases' starts.

Gaps: a step is the change between the set point's last acquired value and its next one; a
missing reading (NaN) or missed samples between them do not hide it, and its settling runs from
the first sample that shows it (the latest instant it can have happened; nothing is
interpolated). Missing samples are not judged and are counted in `missing`: a NaN value of the
channel, and — for a run with `sample_rate_hz` — each slot k/rate of its grid with no sample
at all (missed by the acquisition) inside a stretch of judged samples.
An error indicator passes when max |error| over the judged samples is within the tolerance; it
is None (not judged) when the channel is absent or no sample is judged. Items 1–3 judge every
sample of the run (and count every missing one, missed grid slots included).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from core.params import JointParams
from core.run import RunData
from core.schemes import RANGE_TORQUE

LOADING_PHASES = ("load", "hold", "unload")
TORQUE_TOL = 2e3
"""Torque and bending-moment loading error tolerance [N·m] (Table 11)."""
SHEAR_TOL = 2e3
"""Shear loading error tolerance [N] (Table 11)."""
SHEAR_SETPOINT = 90e3
"""Shear loading value of the schemes [N] (Table 11 item 3)."""
BEND_RANGE = 250e3
"""Top of the bending moment loading range [N·m] (Table 11 item 2)."""
APPLIED_PRESSURE = "pressure_sp_applied"
"""Channel of the hydraulic pressure set point as the PLC applied it [Pa] (the PLC status
signal of that name, recorded by the DAQ): its steps time the hydraulics' settling."""


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
    item: int = 0
    """Table 11 item number (1–6)."""
    kind: str = "error"
    """'error' (items 4–6: max |error| within the tolerance), 'range' (items 1–2: from 0 to
    `required`) or 'value' (item 3: `required` reached)."""
    required: float | None = None
    """Top of the range or the value to reach (items 1–3) [SI]."""
    reached: float | None = None
    """Largest value measured (items 1–3) [SI]."""
    status: str = ""
    """'pass', 'fail', 'not met' (items 1–3: not shown, not aimed at), 'not measured' (no
    channel or no sample), 'not judged' (not a loading run, no sample to judge)."""

    def __post_init__(self) -> None:
        if not self.status:
            self.status = {True: "pass", False: "fail"}.get(self.passed, "not judged")

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


def _steps(sp: np.ndarray, threshold: float) -> np.ndarray:
    """Indices of the samples at which the set point `sp` shows a change of more than
    `threshold` from its last acquired (finite) value: NaN readings in between are skipped,
    not compared (a NaN would hide the step), and the step is placed at the first sample that
    shows it."""
    ok = np.flatnonzero(np.isfinite(sp))
    if len(ok) < 2:
        return np.zeros(0, dtype=int)
    v = sp[ok]
    return ok[1:][np.abs(np.diff(v)) > threshold]


def _missed_slots(run: RunData, t: np.ndarray) -> np.ndarray:
    """Per sample: the slots of the run's grid (k / sample_rate_hz) with no sample between the
    previous sample and this one — missed by the acquisition (zeros without a sample rate)."""
    rate = run.meta.get("sample_rate_hz")
    out = np.zeros(len(t), dtype=int)
    try:
        rate = float(rate)
    except (TypeError, ValueError):
        return out
    if not (rate > 0 and np.isfinite(rate)) or len(t) < 2 or not np.isfinite(t).all():
        return out
    slot = np.floor(t * rate + 1e-6)
    out[1:] = np.maximum(np.diff(slot) - 1, 0).astype(int)
    return out


def _indicator(name: str, channel: str, unit: str, setpoint_text: str, tol: float,
               err: np.ndarray | None, judge: np.ndarray, note: str = "",
               missed: np.ndarray | None = None) -> Indicator:
    """`missed`: per sample, grid slots missed just before it (_missed_slots); counted as
    missing when the samples on both sides of the gap are judged."""
    if err is None:
        return Indicator(name, channel, unit, setpoint_text, tol, 0, 0, None, None, None, None,
                         note or f"no {channel} channel")
    ok = judge & ~np.isnan(err)
    missing = int(np.sum(judge & np.isnan(err)))
    if missed is not None and len(judge) > 1:
        inside = judge[1:] & judge[:-1]          # the gap before sample i lies in a judged stretch
        missing += int(np.sum(missed[1:][inside]))
    if not ok.any():
        return Indicator(name, channel, unit, setpoint_text, tol, 0, missing, None, None, None,
                         None, note or "no sample to judge")
    e = err[ok]
    max_abs = float(np.max(np.abs(e)))
    return Indicator(name, channel, unit, setpoint_text, tol, int(ok.sum()), missing, max_abs,
                     float(np.mean(e)), float(np.sqrt(np.mean(e * e))), bool(max_abs <= tol), note)


def _reach_indicator(item: int, name: str, channel: str, unit: str, kind: str, required: float,
                     tol: float, values: np.ndarray | None, aimed: bool, aim_text: str,
                     n_missed: int = 0) -> Indicator:
    """Items 1–3: did the measured `values` reach `required` (and, for a range, 0) within
    `tol`? Fails only when the run aimed at it (see the module doc). `n_missed`: grid slots of
    the run with no sample, counted as missing."""
    k = "kN·m" if unit == "N·m" else "kN"
    target = (f"0–{required / 1e3:g} {k}" if kind == "range" else f"{required / 1e3:g} {k}")

    def make(passed: bool | None, status: str, note: str, judged: int = 0, missing: int = 0,
             reached: float | None = None) -> Indicator:
        return Indicator(name, channel, unit, target, tol, judged, missing, None, None, None,
                         passed, note, item, kind, required, reached, status)
    if values is None:
        return make(None, "not measured", f"no {channel} channel")
    ok = np.isfinite(values)
    judged, missing = int(ok.sum()), int((~ok).sum()) + n_missed
    if not judged:
        return make(None, "not measured", f"no {channel} sample", 0, missing)
    reached, low = float(np.max(values[ok])), float(np.min(values[ok]))
    met = reached >= required - tol and (kind != "range" or low <= tol)
    text = f"reached {reached / 1e3:.1f} {k}"
    if kind == "range" and low > tol:
        text += f", never below {low / 1e3:.1f} {k}"
    if met:
        return make(True, "pass", text, judged, missing, reached)
    if aimed:
        return make(False, "fail", f"{text}; {aim_text}", judged, missing, reached)
    return make(None, "not met", f"{text}; {aim_text}: not a test of this item",
                judged, missing, reached)


def acceptance(run: RunData, params: JointParams | None = None) -> list[Indicator]:
    """The six Table 11 indicators of a run (see the module doc for their order and rules);
    for a run that does not load the joint every indicator is None with the note 'not a
    loading run'."""
    params = params or JointParams()
    meta = run.meta
    names = ("torque loading error", "bending moment load error", "shear loading error",
             "torque loading range", "bending moment loading range", "shear loading value")
    chans = ("torque_load", "m_bend", "f_shear") * 2
    units = ("N·m", "N·m", "N") * 2
    items = (5, 4, 6, 1, 2, 3)
    kinds = ("error",) * 3 + ("range", "range", "value")
    tols = (TORQUE_TOL, TORQUE_TOL, SHEAR_TOL) * 2
    if not is_loading_run(run):
        return [Indicator(n, c, u, "", tol, 0, 0, None, None, None, None, "not a loading run",
                          item, kind)
                for n, c, u, tol, item, kind in zip(names, chans, units, tols, items, kinds)]
    cols = run.samples.columns
    t = run.t
    loading = _loading_mask(run)
    starts = _segment_starts(loading)
    missed = _missed_slots(run, t)
    settle_meta = meta.get("acceptance_settle_s")

    # torque: measured load vs its set point channel
    settle_q = settle_meta if settle_meta is not None else 5.0 * params.dyno_tau
    if "torque_load" in cols and "torque_cmd" in cols:
        cmd = run.channel("torque_cmd")
        judge = loading & ~_settling(t, np.concatenate([starts, _steps(cmd, TORQUE_TOL / 2)]),
                                     settle_q)
        torque = _indicator(names[0], chans[0], units[0], "torque_cmd", TORQUE_TOL,
                            run.channel("torque_load") - cmd, judge, missed=missed)
    else:
        absent = "torque_load" if "torque_load" not in cols else "torque_cmd"
        torque = _indicator(names[0], chans[0], units[0], "torque_cmd", TORQUE_TOL, None, loading,
                            f"no {absent} channel")

    # hydraulics: constant set points from the metadata
    shear_sp = meta.get("shear_setpoint_n")
    if shear_sp is None:
        shear_sp = (meta.get("scheme_params") or {}).get("shear_target")
    shear_sp = SHEAR_SETPOINT if shear_sp is None else float(shear_sp)
    bend_sp = meta.get("bend_setpoint_nm")
    bend_sp = shear_sp * params.arm_bend if bend_sp is None else float(bend_sp)
    settle_h = settle_meta if settle_meta is not None else 5.0 * params.p_tau
    starts_h = starts
    if APPLIED_PRESSURE in cols:   # when the PLC switched the hydraulic load (module doc)
        # a step moving the shear set point by half its tolerance, or the bending one by half
        # of its own: the pressure change times the cylinder area (times the lever)
        dp = 0.5 * min(SHEAR_TOL, TORQUE_TOL / params.arm_bend) / params.cyl_area
        starts_h = np.concatenate([starts, _steps(run.channel(APPLIED_PRESSURE), dp)])
    judge_h = loading & ~_settling(t, starts_h, settle_h)
    bend = _indicator(names[1], chans[1], units[1], f"{bend_sp:g} N·m", TORQUE_TOL,
                      run.channel("m_bend") - bend_sp if "m_bend" in cols else None, judge_h,
                      missed=missed)
    shear = _indicator(names[2], chans[2], units[2], f"{shear_sp:g} N", SHEAR_TOL,
                       run.channel("f_shear") - shear_sp if "f_shear" in cols else None, judge_h,
                       missed=missed)
    for ind, item in zip((torque, bend, shear), items):
        ind.item = item

    n_missed = int(missed.sum())

    # items 1-3: what the run showed, and whether it aimed at it
    def channel(name: str) -> np.ndarray | None:
        return run.channel(name) if name in cols else None
    if "torque_cmd" in cols and np.isfinite(run.channel("torque_cmd")).any():
        top_cmd = float(np.nanmax(run.channel("torque_cmd")))
    else:
        top_cmd = float((meta.get("scheme_params") or {}).get("load_target") or 0.0)
    reach = [
        _reach_indicator(1, names[3], chans[3], units[3], "range", RANGE_TORQUE, TORQUE_TOL,
                         channel("torque_load"), top_cmd >= RANGE_TORQUE - TORQUE_TOL,
                         f"torque set point up to {top_cmd / 1e3:g} kN·m", n_missed),
        _reach_indicator(2, names[4], chans[4], units[4], "range", BEND_RANGE, TORQUE_TOL,
                         channel("m_bend"), bend_sp >= BEND_RANGE - TORQUE_TOL,
                         f"bending set point {bend_sp / 1e3:g} kN·m", n_missed),
        _reach_indicator(3, names[5], chans[5], units[5], "value", SHEAR_SETPOINT, SHEAR_TOL,
                         channel("f_shear"), shear_sp >= SHEAR_SETPOINT - SHEAR_TOL,
                         f"shear set point {shear_sp / 1e3:g} kN", n_missed),
    ]
    return [torque, bend, shear, *reach]


def format_table(indicators: list[Indicator]) -> str:
    """The indicators as a text table in kN·m / kN, with their Table 11 item numbers (items
    1–3 show what was reached in their result)."""
    lines = [f"{'#':>2} {'indicator':<30}{'max |err|':>10}{'mean':>10}{'rms':>10}{'tol':>8}  "
             f"{'judged':>8}{'missing':>8}  result"]
    for ind in indicators:
        k = "kN·m" if ind.unit == "N·m" else "kN"

        def f(v: float | None) -> str:
            return "—" if v is None else f"{v / 1e3:.3f}"
        result = ind.status.upper() if ind.status in ("pass", "fail") else ind.status
        if ind.note:
            result += f" ({ind.note})"
        lines.append(f"{ind.item:>2} {ind.name:<30}{f(ind.max_abs):>10}{f(ind.mean):>10}"
                     f"{f(ind.rms):>10}{ind.tolerance / 1e3:>5.0f} {k:<3}{ind.judged:>8}"
                     f"{ind.missing:>8}  {result}")
    return "\n".join(lines)
