"""The result of one identification: what every method returns, what reports render and what
the database stores. Parameters are in physical units (the scaling methods use internally is
undone before a Fit is built)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from core.jsonsafe import json_safe


@dataclass
class Fit:
    model: str
    """e.g. 'eq4', 'eq11', 'eq9', possibly with '+effect' suffixes."""
    method: str
    """e.g. 'ls', 'exact', 'mh', 'sghmc', 'hmc'."""
    param_names: list[str]
    units: list[str]
    mean: np.ndarray
    """Point estimate: LS solution or posterior mean, shape (p,)."""
    sd: np.ndarray
    """Standard error (LS) or posterior sd, shape (p,)."""
    ci_low: np.ndarray
    ci_high: np.ndarray
    """95 % confidence (LS) or credible (Bayesian) interval bounds, shape (p,)."""
    sigma: float
    """Noise standard deviation of the output [output unit]."""
    rmse_train: float
    rmse_test: float | None = None
    draws: np.ndarray | None = None
    """Posterior draws (chains, draws, p) in physical units; None for LS."""
    diagnostics: dict[str, Any] = field(default_factory=dict)
    """rhat, ess_bulk, ess_tail, ess_per_s, autocorr, rhat_trace, accept_rate, divergences…"""
    timings: dict[str, float] = field(default_factory=dict)
    """Seconds: 'compile' (JIT, reported apart), 'sample', 'total'."""
    extra: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no draws)."""
        def f(a):
            return None if a is None else np.asarray(a, dtype=float).tolist()
        return {
            "model": self.model, "method": self.method,
            "params": [
                {"name": n, "unit": u, "mean": float(m), "sd": float(s),
                 "ci_low": float(lo), "ci_high": float(hi)}
                for n, u, m, s, lo, hi in zip(self.param_names, self.units, self.mean, self.sd,
                                              self.ci_low, self.ci_high)],
            "sigma": float(self.sigma), "rmse_train": float(self.rmse_train),
            "rmse_test": None if self.rmse_test is None else float(self.rmse_test),
            "diagnostics": _jsonable(self.diagnostics), "timings": dict(self.timings),
            "extra": _jsonable(self.extra),
        }


_jsonable = json_safe
