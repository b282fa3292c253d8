"""The runs as the gap diagnosis reads them (estimator.diagnosis): the nominal model named by
its spec, the signals each run can supply, and the runs prepared and pooled into one table of
samples (with each sample's run, phase, scheme, the reduction and whether the run is loaded)."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from core.run import RunData
from estimator.emps import emps_model
from estimator.models import LinearModel, model_from_spec
from estimator.preprocess import PrepOptions, prepare


OPTIONAL_SIGNALS = ("q", "qd", "qdd", "u", "torque", "torque_load", "torque_rate", "temp_joint",
                    "torsion", "torsion_rate")
"""Signals prepared when a run can supply them (regions and candidate terms use them)."""


def base_model(spec: str | LinearModel) -> LinearModel:
    """A LinearModel, or 'emps', or a model spec of estimator.models.model_from_spec."""
    if isinstance(spec, LinearModel):
        return spec
    return emps_model() if spec == "emps" else model_from_spec(spec)


DIVERGENCE_CHANNELS = ("q", "qd", "qdd", "u", "ud", "torque", "torque_load", "torsion")
"""Channels refuse_diverged checks: those the laws' columns are built from."""


def _run_label(part: str, i: int, n: int, run: RunData) -> str:
    m = run.meta or {}
    what = [f"scheme {m['scheme']}" if m.get("scheme") is not None else "",
            f"{m['motor_speed_rpm']:g} r/min" if m.get("motor_speed_rpm") else "",
            f"direction {int(m['direction']):+d}" if m.get("direction") in (1, -1) else ""]
    what = ", ".join(w for w in what if w)
    return f"{part} run {i + 1} of {n}" + (f" ({what})" if what else "")


def refuse_diverged(train_runs: Sequence[RunData], test_runs: Sequence[RunData],
                    ratio: float) -> None:
    """Raise ValueError naming the run and channel when a run's peak |reading| of a channel
    (finite samples; a non-finite one is a missing sample, left out by preprocess) exceeds
    `ratio` times the median over the campaign's runs of that channel's peak, or its square
    overflows (no least-squares fit can use it). Such a run is a diverged simulation or a
    corrupted record: fitting it fails inside the linear algebra with nothing that says which
    run is at fault, or lets one run dominate every fit."""
    if not (np.isfinite(ratio) and ratio > 1.0):
        raise ValueError(f"diverged_peak_ratio must be a finite number above 1, not {ratio}")
    runs = [("training", i, len(train_runs), r) for i, r in enumerate(train_runs)]
    runs += [("held-out", i, len(test_runs), r) for i, r in enumerate(test_runs)]
    limit = float(np.sqrt(np.finfo(float).max))
    for c in DIVERGENCE_CHANNELS:
        peaks = []
        for part, i, n, run in runs:
            if c not in run.samples.columns:
                continue
            x = np.abs(run.samples[c].to_numpy(dtype=float))
            x = x[np.isfinite(x)]
            peaks.append((float(x.max()) if x.size else 0.0, part, i, n, run))
        if not peaks:
            continue
        med = float(np.median([p[0] for p in peaks]))
        for peak, part, i, n, run in peaks:
            if peak >= limit or (med > 0 and peak > ratio * med):
                raise ValueError(
                    f"{_run_label(part, i, n, run)}: channel {c!r} reaches {peak:.3g}, "
                    f"{peak / med if med > 0 else float('inf'):.2g} times the campaign's median "
                    f"peak of it ({med:.3g}): a diverged simulation or a corrupted record is not "
                    f"a measurement of the rig; leave the run out or repair it")


def stated_resolution(run: RunData, channel: str) -> float:
    """The step [rad, or the channel's unit] the run's sensor sheet states for `channel`
    (`sensors[channel].resolution`, docs/run-format.md); 0 when it states none."""
    s = run.meta.get("sensors") if isinstance(run.meta, dict) else None
    return float(((s or {}).get(channel) or {}).get("resolution", 0.0) or 0.0)


def twist_step(run: RunData) -> float:
    """The step [rad] with which one run measures the twist: its `torsion` channel's stated
    step when a sensor of its own measures the twist and states one (the law reads that
    channel), else the sum of the output and motor encoders' stated steps (a `torsion` that
    is q − u of them, `derived_torsion`, included); 0 when it states neither."""
    if ("torsion" in run.samples.columns and stated_resolution(run, "torsion") > 0
            and not derived_torsion(run)):
        return stated_resolution(run, "torsion")
    if stated_resolution(run, "q") <= 0:
        return 0.0
    return stated_resolution(run, "q") + stated_resolution(run, "u")


def derived_torsion(run: RunData) -> bool:
    """True when the run's `torsion` channel is q − u of its own encoder readings (to within a
    nanoradian, or a hundredth of the finest step the run states for q, u or torsion, on every
    sample where all three are finite): a twist computed from the encoders, not measured."""
    cols = run.samples.columns
    if not {"torsion", "q", "u"} <= set(cols):
        return False
    d = run.channel("torsion") - (run.channel("q") - run.channel("u"))
    d = d[np.isfinite(d)]
    if not d.size:
        return False
    steps = [st for st in (stated_resolution(run, ch) for ch in ("q", "u", "torsion")) if st > 0]
    tol = max(1e-9, 0.01 * min(steps)) if steps else 1e-9
    return float(np.max(np.abs(d))) <= tol


def _available(run: RunData, prep: PrepOptions) -> list[str]:
    ok = []
    for s in OPTIONAL_SIGNALS:
        try:
            prepare(run, ("t", s) if s != "t" else ("t",), prep)
            ok.append(s)
        except (KeyError, ValueError):
            pass
    return ok


def _pool(runs: Sequence[RunData], need: Sequence[str], prep: PrepOptions, run0: int
          ) -> dict[str, np.ndarray]:
    parts = []
    for i, run in enumerate(runs):
        s = prepare(run, need, prep)
        d = dict(s)
        d["run"] = np.full(s.n, run0 + i, dtype=int)
        if "phase" in run.samples.columns:
            d["phase"] = run.samples["phase"].astype(str).to_numpy()[s["index"]]
        if "torque_rate" in d:
            d["torque_rate"] = _smooth_rate(d["torque"], d["t"], d["segment"])
        if "torsion_rate" in d and {"ud", "qd"} <= set(run.samples.columns):
            rate = _measured_twist_rate(run, s["index"])
            # a drive that reports the motor speed as both speeds says nothing of the twist
            # rate: then the differentiated twist of preprocess stays
            if np.any(np.abs(rate) > 0):
                d["torsion_rate"] = rate
        d["scheme"] = np.full(s.n, run.meta.get("scheme", "?"), dtype=object)
        # the reduction turns u (the motor angle referred to the output) into the motor angle,
        # on which a motor-side ripple is periodic (0: the run does not say)
        d["reduction"] = np.full(s.n, float(run.meta.get("reduction") or 0.0))
        d["has_load"] = np.full(s.n, bool(s.info.get("has_torque_load")))
        # the step with which the run measures the twist (0: it does not say)
        d["twist_step"] = np.full(s.n, twist_step(run))
        parts.append(d)
    keys = set(parts[0])
    for p in parts[1:]:
        keys &= set(p)
    pooled = {k: np.concatenate([p[k] for p in parts]) for k in keys}
    if "phase" not in keys:
        pooled.pop("phase", None)
    return pooled


def _measured_twist_rate(run: RunData, index: np.ndarray) -> np.ndarray:
    """Twist rate Δ̇ = u̇ − q̇ [rad/s] from the run's measured velocities at the kept rows: the
    difference of a sampled twist misses the drive train's fast motion between samples (its
    mode lies near the sample rate of the loading schemes) and carries the output encoder's
    quantisation steps; the drives' velocity estimates carry neither."""
    ud = run.samples["ud"].to_numpy(dtype=float)[index]
    qd = run.samples["qd"].to_numpy(dtype=float)[index]
    out = ud - qd
    return np.where(np.isfinite(out), out, 0.0)


def _smooth_rate(x: np.ndarray, t: np.ndarray, segment: np.ndarray) -> np.ndarray:
    """dx/dt of x low-passed (zero-phase Butterworth, order 2, cutoff 0.1 × the sample rate)
    per segment: the time_delay column −Ṫ from a raw difference of a noisy torque would carry
    the differentiated sensor noise (errors in variables) and attenuate the delay estimate."""
    from scipy import signal
    out = np.empty_like(x, dtype=float)
    for g in np.unique(segment):
        m = segment == g
        tt, xx = t[m], x[m].astype(float)
        if xx.size < 16:
            out[m] = np.gradient(xx, tt) if xx.size > 1 else 0.0
            continue
        fs = 1.0 / float(np.median(np.diff(tt)))
        sos = signal.butter(2, 0.1 * fs, fs=fs, output="sos")
        out[m] = np.gradient(signal.sosfiltfilt(sos, xx, padlen=min(15, xx.size - 1)), tt)
    return out


def _slice(d: dict, m: np.ndarray) -> dict:
    return {k: v[m] for k, v in d.items()}
