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
