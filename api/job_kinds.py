"""The job kinds: what a job of each kind accepts (a pydantic model, checked at submission) and
the function a worker runs for it. Adding a kind (e.g. sim-to-real diagnosis) is one entry in
KINDS. A kind's `run(store, params, progress)` returns the results to store (one per fit)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated, Any, Callable, Literal

from pydantic import BaseModel, ConfigDict, Field

MODEL_PATTERN = r"^(eq4|eq5|eq9|eq11)(\+[a-z][a-z0-9_]*)*$"
"""A model by name (estimator.models), optionally with effect terms: 'eq4+backlash'."""

RunId = Annotated[int, Field(ge=1, le=2**31 - 1)]
Progress = Callable[[float], None]
"""Reports a job's progress in [0, 1]; raises JobCancelled when the job was cancelled."""


class JobCancelled(Exception):
    """The job was cancelled while it ran: its results are discarded."""


@dataclass
class StoredResult:
    """One fit to store in `results`, linked to its runs by role ('train', 'test')."""
    fit: Any
    """estimator.result.Fit"""
    runs: dict[int, str] = field(default_factory=dict)


class SamplerOptions(BaseModel):
    """Options passed to estimator.identify (bounded so a request cannot ask for days of work)."""
    model_config = ConfigDict(extra="forbid")
    chains: int = Field(4, ge=1, le=16)
    draws: int | None = Field(None, ge=10, le=200_000, description="draws per chain")
    warmup: int | None = Field(None, ge=0, le=200_000)
    seed: int = Field(0, ge=0, le=2**32 - 1)
    level: float = Field(0.95, gt=0.0, lt=1.0)

    def as_opts(self) -> dict[str, Any]:
        return {k: v for k, v in self.model_dump().items() if v is not None}


class IdentificationParams(BaseModel):
    """Identify `model` by `method` on the training runs; RMSE also on the test runs."""
    model_config = ConfigDict(extra="forbid")
    run_ids: list[RunId] = Field(min_length=1, max_length=50)
    test_run_ids: list[RunId] = Field(default_factory=list, max_length=50)
    model: str = Field(pattern=MODEL_PATTERN, max_length=200)
    method: Literal["ls", "exact", "mh", "sghmc"]
    options: SamplerOptions = Field(default_factory=SamplerOptions)


class SensitivityParams(BaseModel):
    """Sobol indices (Eqs. 18–19) of a linear model's predicted output over the posterior
    marginals of a Bayesian fit on the runs (as `rig identify --sobol`)."""
    model_config = ConfigDict(extra="forbid")
    run_ids: list[RunId] = Field(min_length=1, max_length=50)
    model: Literal["eq4", "eq5"] = "eq4"
    method: Literal["exact", "mh", "sghmc"] = "exact"
    n_base: int = Field(256, ge=16, le=8192)
    max_rows: int = Field(2000, ge=10, le=20_000)
    options: SamplerOptions = Field(default_factory=SamplerOptions)


def _load(store, ids: list[int]):
    return [store.load_run(i) for i in ids]


def run_identification(store, params: IdentificationParams, progress: Progress
                       ) -> list[StoredResult]:
    from estimator.identify import identify

    train = _load(store, params.run_ids)
    test = _load(store, params.test_run_ids) or None
    progress(0.2)
    fit = identify(train, params.model, params.method, test, **params.options.as_opts())
    progress(0.9)
    roles = {i: "train" for i in params.run_ids} | {i: "test" for i in params.test_run_ids}
    return [StoredResult(fit=fit, runs=roles)]


def run_sensitivity(store, params: SensitivityParams, progress: Progress) -> list[StoredResult]:
    import numpy as np

    from estimator.identify import identify_detailed
    from estimator.sobol import sobol_indices

    train = _load(store, params.run_ids)
    progress(0.1)
    fit, ds = identify_detailed(train, params.model, params.method, None,
                                **params.options.as_opts())
    progress(0.5)
    rows = np.linspace(0, ds.X.shape[0] - 1, min(params.max_rows, ds.X.shape[0])).astype(int)
    X = ds.X[rows]
    res = sobol_indices(lambda th: np.asarray(th) @ X.T, fit.param_names, fit.mean, fit.sd,
                        n_base=params.n_base, seed=params.options.seed)
    fit.extra["sobol"] = res.table.to_dict(orient="list")
    progress(0.9)
    return [StoredResult(fit=fit, runs={i: "train" for i in params.run_ids})]


@dataclass(frozen=True)
class JobKind:
    name: str
    params: type[BaseModel]
    run: Callable[[Any, Any, Progress], list[StoredResult]]
    description: str


KINDS: dict[str, JobKind] = {k.name: k for k in (
    JobKind("identification", IdentificationParams, run_identification,
            "identify a joint model (eq4, eq5, eq9, eq11 [+effects]) by ls, exact, mh or sghmc"),
    JobKind("sensitivity", SensitivityParams, run_sensitivity,
            "Sobol indices of a linear model's output over its posterior"),
)}


def run_ids_of(params: BaseModel) -> list[int]:
    """Every run id a job's parameters name (to check they exist at submission)."""
    return list(getattr(params, "run_ids", [])) + list(getattr(params, "test_run_ids", []))
