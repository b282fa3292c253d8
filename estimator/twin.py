"""The live twin: a stored fit of an output-side model (Eq. 4 with the measured load, with any
effects of the vocabulary) predicts the joint torque from the measured motion and load, sample
by sample, while a run goes on. Its residual (measured − predicted) is the sim-to-real gap as it
happens; estimator.diagnosis explains it afterwards."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from estimator.models import LinearModel, model_from_spec


class TwinUnavailable(ValueError):
    """The fit cannot predict the joint torque from motion and load."""


class Twin:
    """Predicts T [N·m] = τ_L + X(q, q̇, q̈, …)·θ with the fit's posterior means θ.

    `update(t, channels)` takes one live sample (run time [s]; the channels by name, SI units)
    and returns {predicted, measured, residual} [N·m], or None while a signal is missing. The
    acceleration q̈ is the difference quotient of the measured q̇ between successive updates (the
    rig's inertia term is small beside its loads; a first update uses q̈ = 0)."""

    def __init__(self, model_spec: str, params: Mapping[str, float]) -> None:
        try:
            self.model: LinearModel = model_from_spec(model_spec)
        except (ValueError, KeyError) as e:
            raise TwinUnavailable(f"model {model_spec!r}: {e}") from None
        if self.model.kind != "output":
            raise TwinUnavailable(f"model {model_spec!r} is a {self.model.kind} law: the twin "
                                  "needs an output-side model (Eq. 4 with effects)")
        missing = [n for n in self.model.param_names if n not in params]
        if missing:
            raise TwinUnavailable(f"the fit lacks parameter(s) {missing} of {model_spec!r}")
        self.theta = np.array([float(params[n]) for n in self.model.param_names])
        self._prev: tuple[float, float] | None = None

    def update(self, t: float, channels: Mapping[str, float | None]) -> dict[str, float] | None:
        sig: dict[str, np.ndarray] = {}
        for k, v in channels.items():
            if isinstance(v, (int, float)) and v is not None and np.isfinite(v):
                sig[k] = np.array([float(v)])
        if "qd" not in sig or "q" not in sig or "torque_load" not in sig:
            return None
        qd = float(sig["qd"][0])
        qdd = 0.0
        if self._prev is not None and t > self._prev[0]:
            qdd = (qd - self._prev[1]) / (t - self._prev[0])
        self._prev = (t, qd)
        sig["qdd"] = np.array([qdd])
        try:
            predicted = float(sig["torque_load"][0] + self.model.predict(sig, self.theta)[0])
        except KeyError:                    # an effect's signal (e.g. temp_joint) not live
            return None
        out = {"predicted": predicted}
        if "torque" in sig:
            out["measured"] = float(sig["torque"][0])
            out["residual"] = out["measured"] - predicted
        return out
