"""What a law's residual must keep from the sensors alone (estimator.diagnosis): the noise the
runs' sensor sheets state, the encoders' quantisation as a twist–torque law sees it, and the
white-noise floor under a residual from its first differences."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy import signal

from core.run import RunData
from estimator.diagnosis_data import derived_torsion, stated_resolution
from estimator.models import LinearModel
from estimator.preprocess import PrepOptions, prepare


def sensor_floor(runs: Sequence[RunData], model: LinearModel, params: dict[str, float],
                 prep: PrepOptions | None = None) -> float | None:
    """The mean square the law's residual must keep from the sensors alone, from what the runs
    say of them (metadata `sensors`, docs/run-format.md), or None when a run says nothing: the
    noise variance of each torque channel the law's target reads (the joint torque, and the
    load cell for the output balance T − τ_L) times the share of its band the low-pass keeps,
    plus for a twist–torque law the encoders' quantisation as the law sees it
    (`quantisation_floor`). The quantisation error of a slowly moving encoder is not white, so
    the first-difference floor misses it; it is the floor a twist–torque law cannot go below."""
    total = []
    for run in runs:
        sensors = run.meta.get("sensors")
        if not isinstance(sensors, dict) or "torque" not in sensors:
            return None
        # white noise keeps the share of its band the low-pass before decimation lets through
        fs = float(run.meta.get("sample_rate_hz") or 0.0)
        kept = 1.0
        if prep is not None and fs > 0:
            cutoff = prep.cutoff_hz or (0.4 * fs / prep.decimate if prep.decimate > 1 else None)
            if cutoff is not None and (prep.filter_outputs or prep.decimate > 1):
                kept = min(1.0, cutoff / (0.5 * fs))
        ms = kept * sum(float((sensors.get(ch) or {}).get("noise_sd", 0.0)) ** 2
                        for ch in ("torque", "torque_load") if ch in model.target_requires)
        if model.kind == "transmission":
            ms += quantisation_floor(run, model, params, prep or PrepOptions())
        total.append(ms)
    return float(np.mean(total)) if total else None


QUANTISATION_OFFSETS = 8
"""Grid offsets averaged over in quantisation_floor (where the true angle sits between two
steps is unknown)."""


def quantisation_floor(run: RunData, model: LinearModel, params: dict[str, float],
                       prep: PrepOptions) -> float:
    """Mean square that the output and motor encoders' steps (`sensors[q|u].resolution`) leave
    in a twist–torque law, by surrogate: the run's angles smoothed (a zero-phase low-pass at a
    tenth of the sample rate, at most 2 Hz, which removes the staircase), quantised again on a
    grid shifted by a known fraction of a step, prepared as the law prepares the run (filter,
    decimation) and passed through the fitted law (`params`): the mean square change of its
    prediction against the smooth angles, averaged over QUANTISATION_OFFSETS shifts. So the
    floor follows what the law does with a step — a stiffening curve's local slope, the damping
    of the twist rate, the low-pass that averages the error of an encoder crossing many steps
    and keeps that of one creeping or at rest. A `torsion` channel that is the difference
    q − u of the run's encoder readings (`derived_torsion`) carries their rounding, not one
    of its own: the encoders are smoothed and quantised again and the torsion recomputed from
    them (a twist that barely moves while q crosses many steps is read with a near-white
    error, which the law's low-pass averages). A torsion measured by its own sensor is the
    channel smoothed and quantised again, at its stated step. 0 when no channel the twist is
    read from states its step."""
    cols = run.samples.columns
    derived = derived_torsion(run)
    chans = ("torsion",) if "torsion" in cols and not derived else ("q", "u")
    steps = {ch: stated_resolution(run, ch) for ch in chans if ch in cols}
    steps = {ch: st for ch, st in steps.items() if st > 0}
    if not steps or (chans != ("torsion",) and not {"q", "u"} <= set(cols)):
        return 0.0
    t = run.t
    fs = float(run.meta.get("sample_rate_hz") or 1.0 / np.median(np.diff(t)))
    need = list(dict.fromkeys(model.requires))
    theta = np.array([float(params.get(n, 0.0)) for n in model.param_names])
    sos = signal.butter(2, min(2.0, 0.1 * fs), fs=fs, output="sos")
    smooth = {}
    for ch in steps:
        y = run.channel(ch)
        ok = np.isfinite(y)
        filled = np.interp(t, t[ok], y[ok]) if ok.any() else y
        smooth[ch] = signal.sosfiltfilt(sos, filled)
    base = run.samples.copy()
    for ch in steps:
        base[ch] = np.where(np.isfinite(run.channel(ch)), smooth[ch], np.nan)
    if derived:
        base["torsion"] = base["q"] - base["u"]
    try:
        ref = model.predict(prepare(RunData(base, run.meta), need, prep), theta)
    except (KeyError, ValueError):
        return 0.0
    ms = []
    for j in range(QUANTISATION_OFFSETS):
        shifted = base.copy()
        for ch, st in steps.items():
            o = st * (j + 0.5) / QUANTISATION_OFFSETS
            shifted[ch] = np.round((base[ch].to_numpy() + o) / st) * st - o
        if derived:
            shifted["torsion"] = shifted["q"] - shifted["u"]
        pred = model.predict(prepare(RunData(shifted, run.meta), need, prep), theta)
        d = pred - ref
        ms.append(float(np.mean(d[np.isfinite(d)] ** 2)) if np.isfinite(d).any() else 0.0)
    return float(np.mean(ms))


def _noise_floor(e: np.ndarray, run: np.ndarray) -> float:
    """White-noise mean square under the residual: mean of (e[i+1] − e[i])²/2 within runs (a
    smooth, structured residual barely contributes to first differences)."""
    num, den = 0.0, 0
    for r in np.unique(run):
        d = np.diff(e[run == r])
        num += float(d @ d) / 2.0
        den += d.size
    return num / den if den else 0.0
