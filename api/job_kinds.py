"""The job kinds: what a job of each kind accepts (a pydantic model, checked at submission) and
the function a worker runs for it. Adding a kind (e.g. sim-to-real diagnosis) is one entry in
KINDS. A kind's `run(store, params, progress)` returns the results to store (one per fit).

Each kind has a wall-clock limit (`time_limit_s`): a job running longer is stopped and ends
'failed' with the limit in its reason (api.worker; a job that does not stop by itself is ended
with its worker process). The limits bound what the parameter bounds allow on a busy 2-core
machine with room to spare; `RIG_JOB_TIME_LIMIT_S` (api.settings) overrides them all."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated, Any, Callable, Literal

from pydantic import BaseModel, ConfigDict, Field, StringConstraints

from core.effects import EFFECT_NAMES

MODEL_PATTERN = r"^(eq4|eq5|eq9|eq11)(\+[a-z][a-z0-9_]*)*$"
"""A model by name (estimator.models), optionally with effect terms: 'eq4+backlash'."""

RunId = Annotated[int, Field(ge=1, le=2**31 - 1)]
Progress = Callable[[float], None]
"""Reports a job's progress in [0, 1]; raises JobCancelled when the job was cancelled."""


class JobCancelled(Exception):
    """The job was cancelled while it ran: its results are discarded."""


class JobTimeLimit(Exception):
    """The job ran past its kind's wall-clock limit: it ends 'failed' with this reason."""


@dataclass
class StoredResult:
    """One fit to store in `results`, linked to its runs by role ('train', 'test'), with the
    JSON documents that belong to it (stored as `reports` rows of that kind, e.g. the diagnosis
    report)."""
    fit: Any
    """estimator.result.Fit"""
    runs: dict[int, str] = field(default_factory=dict)
    documents: dict[str, dict[str, Any]] = field(default_factory=dict)
    """{kind: JSON-ready document}, stored as application/json Report rows of the result."""


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
    method: Literal["ls", "exact", "mh", "sghmc", "hmc"] = Field(
        description="ls, mh, sghmc: any model; exact: the linear models (eq4, eq5, eq11 with "
                    "x known); hmc: the Bouc–Wen fit (eq9, eq11)")
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


def run_identification(store, params: IdentificationParams, progress: Progress,
                       map_fn: Callable | None = None) -> list[StoredResult]:
    """map_fn: a `map`-like callable that runs the chains (one task each; api.job_runtime)."""
    from estimator.identify import identify

    train = _load(store, params.run_ids)
    test = _load(store, params.test_run_ids) or None
    progress(0.2)
    fit = identify(train, params.model, params.method, test, chain_map=map_fn,
                   **params.options.as_opts())
    progress(0.9)
    roles = {i: "train" for i in params.run_ids} | {i: "test" for i in params.test_run_ids}
    _add_prediction_series(fit, params, train, test or [])
    return [StoredResult(fit=fit, runs=roles)]


def _add_prediction_series(fit, params: IdentificationParams, train: list, test: list) -> None:
    """fit.extra['series']: the fit replayed on its runs, decimated (api.fit_series), for the
    job report's predicted-vs-measured figure."""
    from api.fit_series import prediction_series

    runs = ([(i, "train", r) for i, r in zip(params.run_ids, train)]
            + [(i, "test", r) for i, r in zip(params.test_run_ids, test)])
    fit.extra["series"] = prediction_series(fit, runs)


def run_sensitivity(store, params: SensitivityParams, progress: Progress,
                    map_fn: Callable | None = None) -> list[StoredResult]:
    """map_fn: a `map`-like callable that runs the chains and the Sobol evaluation blocks of 512
    design rows (one task each; api.job_runtime)."""
    import numpy as np

    from estimator.identify import identify_detailed
    from estimator.sobol import sobol_indices

    train = _load(store, params.run_ids)
    progress(0.1)
    fit, ds = identify_detailed(train, params.model, params.method, None, chain_map=map_fn,
                                **params.options.as_opts())
    progress(0.5)
    rows = np.linspace(0, ds.X.shape[0] - 1, min(params.max_rows, ds.X.shape[0])).astype(int)
    X = ds.X[rows]
    res = sobol_indices(lambda th: np.asarray(th) @ X.T, fit.param_names, fit.mean, fit.sd,
                        n_base=params.n_base, seed=params.options.seed, chunk_size=512,
                        map_fn=map_fn)
    fit.extra["sobol"] = res.table.to_dict(orient="list")
    progress(0.9)
    return [StoredResult(fit=fit, runs={i: "train" for i in params.run_ids})]


DIAGNOSIS_MODEL_PATTERN = r"^(emps|(eq4|eq5|eq11)(\+[a-z][a-z0-9_]*)*)$"
"""A nominal model for a diagnosis: a linear model of estimator.models (eq4, eq5, eq11 with the
default Bouc–Wen shape) optionally with effects already in it, or 'emps'."""
ChannelName = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_]{0,63}$")]


class ChannelRename(BaseModel):
    """A channel renamed before the diagnosis (another rig's name onto the joint's)."""
    model_config = ConfigDict(extra="forbid")
    old: ChannelName
    new: ChannelName


DIAGNOSIS_SERIES_POINTS = 400
"""Samples per run kept (decimated) in a diagnosis report's series for its plots."""


class DiagnosisParams(BaseModel):
    """The sim-to-real gap diagnosis (estimator.diagnosis, as `rig diagnose`): the nominal
    `model` fitted on the training runs (`run_ids`) and scored on the held-out runs
    (`test_run_ids`); where the residual lies, which effect of the vocabulary explains it, how
    far the held-out error shrinks."""
    model_config = ConfigDict(extra="forbid")
    run_ids: list[RunId] = Field(min_length=1, max_length=50, description="training runs")
    test_run_ids: list[RunId] = Field(min_length=1, max_length=50, description="held-out runs")
    model: str = Field("eq4", pattern=DIAGNOSIS_MODEL_PATTERN, max_length=200)
    effects: list[Literal[EFFECT_NAMES]] | None = Field(
        None, max_length=len(EFFECT_NAMES),
        description="candidate effects to try (default: the whole vocabulary, those applicable)")
    rename: list[ChannelRename] = Field(
        default_factory=list, max_length=20,
        description="channel renames before the diagnosis, e.g. EMPS: qm → q, force → torque")
    cutoff_hz: float | None = Field(None, gt=0.0, le=1e4,
                                    description="zero-phase low-pass of the kinematic channels")
    decimate: int = Field(1, ge=1, le=100, description="keep every k-th sample")
    max_effects: int = Field(3, ge=1, le=8, description="effects added greedily at most")
    z_gain: float = Field(3.0, ge=1.0, le=20.0,
                          description="held-out gain / SE needed to call a candidate significant")
    n_boot: int = Field(400, ge=50, le=5000, description="bootstrap resamples of the intervals")
    seed: int = Field(0, ge=0, le=2**32 - 1)


def run_diagnosis(store, params: DiagnosisParams, progress: Progress) -> list[StoredResult]:
    """The diagnosis report stored as a 'diagnosis' document of the nominal model's least-squares
    fit; the fit with the chosen effects (when any) and the transmission law's fits (when the
    diagnosis made them) stored beside it; all linked to the runs by role."""
    from estimator.diagnosis import DiagnosisOptions, diagnose_detailed
    from estimator.preprocess import PrepOptions
    from core.run import RunData

    both = sorted(set(params.run_ids) & set(params.test_run_ids))
    if both:        # (not a schema rule: checked when the job runs, it fails with this reason)
        raise ValueError(f"run(s) {both} are both training and held-out runs: the held-out "
                         "error of a diagnosis must come from runs it was not fitted on")
    names = {r.old: r.new for r in params.rename}

    def load(ids):
        runs = _load(store, ids)
        if names:
            runs = [RunData(samples=r.samples.rename(columns=names), meta=dict(r.meta))
                    for r in runs]
        return runs

    train, test = load(params.run_ids), load(params.test_run_ids)
    progress(0.2)
    opt = DiagnosisOptions(z_gain=params.z_gain, max_effects=params.max_effects,
                           n_boot=params.n_boot, seed=params.seed,
                           candidates=tuple(params.effects) if params.effects else None,
                           series_points=DIAGNOSIS_SERIES_POINTS)
    d = diagnose_detailed(train, test, params.model,
                          PrepOptions(cutoff_hz=params.cutoff_hz, decimate=params.decimate), opt)
    progress(0.9)
    roles = {i: "train" for i in params.run_ids} | {i: "test" for i in params.test_run_ids}
    out = [StoredResult(fit=d.baseline, runs=roles, documents={"diagnosis": d.report})]
    if d.final is not None:
        out.append(StoredResult(fit=d.final, runs=roles))
    tx = d.transmission         # the twist–torque law's own diagnosis, when the runs allow one
    if tx is not None:
        out += [StoredResult(fit=f, runs=roles) for f in (tx.baseline, tx.final) if f is not None]
    return out


class ReproductionParams(BaseModel):
    """The paper reproduced on the emulator (api.paper_reproduction, as `rig reproduce`): its
    campaign simulated in the job, the fits stored as results, the report as their
    'reproduction' document."""
    model_config = ConfigDict(extra="forbid")
    quick: bool = Field(False, description="short campaign and chains: a pipeline check")
    seed: int = Field(1, ge=0, le=2**31 - 1)


def run_reproduction(store, params: ReproductionParams, progress: Progress
                     ) -> list[StoredResult]:
    """Every fit of the reproduction as a result (no stored runs: the campaign is simulated in
    the job), the report stored with the first."""
    from api.paper_reproduction import Settings, reproduce

    report, fits = reproduce(Settings(quick=params.quick, seed=params.seed),
                             progress=lambda x: progress(0.05 + 0.9 * x))
    return [StoredResult(fit=f, documents={"reproduction": report} if k == 0 else {})
            for k, f in enumerate(fits)]


@dataclass(frozen=True)
class JobKind:
    name: str
    params: type[BaseModel]
    run: Callable[[Any, Any, Progress], list[StoredResult]]
    description: str
    time_limit_s: float
    """Wall-clock limit of one attempt of a job of this kind [s]."""


KINDS: dict[str, JobKind] = {k.name: k for k in (
    JobKind("identification", IdentificationParams, run_identification,
            "identify a joint model (eq4, eq5, eq9, eq11 [+effects]) by ls, exact, mh or sghmc",
            time_limit_s=7200.0),
    JobKind("sensitivity", SensitivityParams, run_sensitivity,
            "Sobol indices of a linear model's output over its posterior",
            time_limit_s=7200.0),
    JobKind("diagnosis", DiagnosisParams, run_diagnosis,
            "sim-to-real gap diagnosis: where the nominal model's residual lies, which effect "
            "explains it, how far the held-out error shrinks",
            time_limit_s=3600.0),
    JobKind("reproduction", ReproductionParams, run_reproduction,
            "the paper's tables and figures reproduced on the emulator, next to the paper's "
            "values", time_limit_s=7200.0),
)}


def time_limit_s(kind: str, override_s: float | None = None) -> float | None:
    """The wall-clock limit of a job of `kind` [s]: `override_s` (the RIG_JOB_TIME_LIMIT_S
    setting) when given, else the kind's own; None for a kind not registered here."""
    k = KINDS.get(kind)
    if k is None:
        return None
    return k.time_limit_s if override_s is None else float(override_s)


def run_ids_of(params: BaseModel) -> list[int]:
    """Every run id a job's parameters name (to check they exist at submission)."""
    return list(getattr(params, "run_ids", [])) + list(getattr(params, "test_run_ids", []))
