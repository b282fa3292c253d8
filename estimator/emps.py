"""The EMPS benchmark's standard identification on real data (Janot, Gautier & Brunot, "Data Set
and Reference Models of EMPS", Workshop on Nonlinear System Identification Benchmarks, 2019).

Inverse dynamic model of the prismatic drive: force = M·q̈ + Fv·q̇ + Fc·sgn(q̇) + offset, fitted by
the benchmark's IDIM-LS procedure, reproduced step by step from its reference script:

1. q̂ = zero-phase (forward–backward) 4th-order Butterworth low-pass of the measured position at
   5·20 = 100 Hz (1 kHz sampling), with MATLAB filtfilt's edge padding (3·(order) samples,
   odd reflection);
2. q̇, q̈ by central differences (one-sided at the ends: MATLAB diffcent ≡ numpy.gradient);
3. the first 49 samples dropped (the script's n_border = 50, MATLAB 1-based);
4. every column of the observation matrix [q̈, q̇, sgn q̇, 1] and the force decimated ("parallel
   decimation") by round(0.8·500/40) = 10: an order-8 Chebyshev-I low-pass (0.05 dB ripple,
   cut-off 0.8/10 of Nyquist), zero-phase, then every 10th sample aligned on the record's end as
   MATLAB's `decimate` does;
5. ordinary least squares; relative error 100·‖y − Xθ‖/‖y‖.

The held-out error applies the estimate to the validation record (DATA_EMPS_PULSES, which adds
external force pulses the model does not contain) processed the same way. The exact
Normal–Inverse-Gamma posterior (estimator.exact) is offered alongside LS.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from estimator.result import Fit

EMPS_PARAMS: tuple[str, ...] = ("M", "Fv", "Fc", "offset")
EMPS_UNITS: tuple[str, ...] = ("kg", "N·s/m", "N", "N")
EMPS_REFERENCE: dict[str, float] = {"M": 95.1089, "Fv": 203.5034, "Fc": 20.3935,
                                    "offset": -3.1648}
"""IDIM-LS values of the benchmark document on the estimation record."""
EMPS_REFERENCE_REL_ERROR_PCT = 4.08
"""Relative error [%] of the reference IDIM-LS fit on the estimation record."""


@dataclass
class EmpsData:
    """Filtered, differentiated and decimated record: observation matrix X (n, 4) with columns
    [q̈ (m/s²), q̇ (m/s), sgn q̇, 1] and the force y (n,) [N], at times t (n,) [s]."""
    t: np.ndarray
    X: np.ndarray
    y: np.ndarray
    decimation: int


def _matlab_filtfilt(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    from scipy import signal
    return signal.filtfilt(b, a, x, padlen=3 * (max(len(a), len(b)) - 1))


def _matlab_decimate(x: np.ndarray, r: int) -> np.ndarray:
    """MATLAB decimate(x, r): Chebyshev-I order 8, 0.05 dB, cut-off 0.8/r, zero-phase, then
    samples nbeg:r:end (1-based) with nbeg = r − (r·ceil(n/r) − n), i.e. aligned on the end."""
    from scipy import signal
    b, a = signal.cheby1(8, 0.05, 0.8 / r)
    xf = _matlab_filtfilt(b, a, x)
    n = x.shape[0]
    nbeg = r - (r * int(np.ceil(n / r)) - n)
    return xf[nbeg - 1::r]


def emps_prepare(t: np.ndarray, qm: np.ndarray, force: np.ndarray, cutoff_hz: float = 100.0,
                 order: int = 4, decimation_band_hz: float = 40.0, n_border: int = 49
                 ) -> EmpsData:
    """Steps 1–4 of the module docstring on raw 1 kHz signals: time t [s], position qm [m],
    force [N]."""
    from scipy import signal

    t = np.asarray(t, dtype=float)
    qm = np.asarray(qm, dtype=float)
    force = np.asarray(force, dtype=float)
    for name, v in (("t", t), ("qm", qm), ("force", force)):
        if not np.all(np.isfinite(v)):
            raise ValueError(f"EMPS channel {name!r} has missing or infinite samples")
    dt = float(np.median(np.diff(t)))
    fs = 1.0 / dt
    fnyq = fs / 2.0
    b, a = signal.butter(order, cutoff_hz / fnyq)
    q_f = _matlab_filtfilt(b, a, qm)
    dq = np.gradient(q_f, dt)
    ddq = np.gradient(dq, dt)
    sl = slice(n_border, None)
    X0 = np.column_stack([ddq[sl], dq[sl], np.sign(dq[sl]), np.ones(q_f.shape[0] - n_border)])
    r = int(round(0.8 * fnyq / decimation_band_hz))
    X = np.column_stack([_matlab_decimate(X0[:, j], r) for j in range(X0.shape[1])])
    y = _matlab_decimate(force[sl], r)
    td = _matlab_decimate(t[sl], r)
    return EmpsData(t=td, X=X, y=y, decimation=r)


def emps_prepare_run(run) -> EmpsData:
    """`emps_prepare` on a run loaded by core.emps.load_emps (channels t, qm, force)."""
    return emps_prepare(run.channel("t"), run.channel("qm"), run.channel("force"))


def relative_error_pct(y: np.ndarray, y_hat: np.ndarray) -> float:
    """The benchmark's relative error [%]: 100·‖y − ŷ‖/‖y‖."""
    y = np.asarray(y, dtype=float)
    return float(100.0 * np.linalg.norm(y - np.asarray(y_hat, dtype=float)) / np.linalg.norm(y))


def identify_emps(estimation, validation=None, method: str = "ls", seed: int = 0,
                  n_draws: int = 4000, tau2_prior: tuple[float, float] = (1e-3, 1e-3)) -> Fit:
    """Identify M, Fv, Fc, offset on the estimation record and evaluate on the validation record.

    `estimation` / `validation`: a path to a benchmark .mat file or a RunData from
    core.emps.load_emps. method 'ls' (the benchmark's IDIM-LS: standard errors
    std(e)·√diag((XᵀX)⁻¹) as its script computes them, 95 % t intervals) or 'exact' (conjugate
    Normal–Inverse-Gamma posterior in the scaled coordinates of estimator.priors — θ_s | τ_s² ~
    N(0, N·τ_s²·I) (prior precision 1/N of the data's: a unit-information width, so the prior
    neither shrinks θ nor inflates τ² through the (θ/τ)ᵀθ/τ term of the conjugate form),
    τ_s² ~ Inv-Gamma(`tau2_prior`), vague by default: the paper's IG(2, 2) on the scaled noise
    variance would act as 4 pseudo-observations of unit variance and, on a record this well
    explained (τ_s² ≈ 0.002), double the noise estimate — with `n_draws` exact draws). rmse_train / rmse_test are Eq. 17 on the decimated force [N];
    extra holds the relative errors [%], the reference values and each parameter's deviation
    from them [%]."""
    from scipy import stats

    from estimator.least_squares import ols

    est = _as_data(estimation)
    val = _as_data(validation) if validation is not None else None
    names, units = list(EMPS_PARAMS), list(EMPS_UNITS)
    extra: dict = {"n_estimation": int(est.y.size), "decimation": est.decimation,
                   "reference": dict(EMPS_REFERENCE),
                   "reference_rel_error_pct": EMPS_REFERENCE_REL_ERROR_PCT}
    if method == "ls":
        res = ols(est.X, est.y)
        theta = res.theta
        e = est.y - est.X @ theta
        # the benchmark script's standard errors: std(e)·sqrt(diag(inv(XᵀX)))
        se = np.std(e, ddof=1) * np.sqrt(np.diag(np.linalg.inv(est.X.T @ est.X)))
        tq = stats.t.ppf(0.975, res.dof)
        fit = Fit(model="emps", method="ls", param_names=names, units=units, mean=theta, sd=se,
                  ci_low=theta - tq * se, ci_high=theta + tq * se, sigma=res.sigma,
                  rmse_train=_rmse(est.y, est.X @ theta))
    elif method == "exact":
        from estimator.exact import nig_draws, nig_posterior
        from estimator.priors import Scaling, conjugate_prior

        sc = Scaling.from_data(est.X, est.y)
        prior = conjugate_prior(len(names), a0=tau2_prior[0], b0=tau2_prior[1],
                                g=float(est.y.size))
        post = nig_posterior(sc.x_to_scaled(est.X), sc.y_to_scaled(est.y), prior.mean,
                             prior.cov, prior.a0, prior.b0)
        theta = sc.theta_to_physical(post.mean)
        cov = sc.cov_to_physical(post.theta_cov)
        sd = np.sqrt(np.diag(cov))
        # marginals are Student-t with 2a degrees of freedom and scale √(b/a·V_jj)
        scale = np.sqrt(np.diag(sc.cov_to_physical(post.cov_unit * (post.b / post.a))))
        tq = stats.t.ppf(0.975, 2.0 * post.a)
        rng = np.random.default_rng(seed)
        th_s, tau2_s = nig_draws(post, n_draws, rng)
        fit = Fit(model="emps", method="exact", param_names=names, units=units, mean=theta,
                  sd=sd, ci_low=theta - tq * scale, ci_high=theta + tq * scale,
                  sigma=float(np.mean(np.sqrt(tau2_s)) * sc.y),
                  rmse_train=_rmse(est.y, est.X @ theta),
                  draws=sc.theta_to_physical(th_s)[None, :, :])
        extra["log_marginal_scaled"] = post.log_marginal
    else:
        raise ValueError(f"unknown EMPS method {method!r}; use 'ls' or 'exact'")
    extra["rel_error_train_pct"] = relative_error_pct(est.y, est.X @ fit.mean)
    extra["deviation_from_reference_pct"] = {
        n: float(100.0 * (fit.mean[i] - EMPS_REFERENCE[n]) / abs(EMPS_REFERENCE[n]))
        for i, n in enumerate(names)}
    if val is not None:
        fit.rmse_test = _rmse(val.y, val.X @ fit.mean)
        extra["rel_error_test_pct"] = relative_error_pct(val.y, val.X @ fit.mean)
        extra["n_validation"] = int(val.y.size)
    fit.extra.update(extra)
    return fit


def _as_data(src) -> EmpsData:
    if isinstance(src, EmpsData):
        return src
    if isinstance(src, (str, Path)):
        from core.emps import load_emps
        return emps_prepare_run(load_emps(src))
    return emps_prepare_run(src)


def _rmse(y: np.ndarray, y_hat: np.ndarray) -> float:
    from estimator.convergence import rmse
    return rmse(y, y_hat)


def emps_model():
    """The EMPS inverse dynamic model as a LinearModel on the joint channel names (q = qm,
    torque = force) for the gap diagnosis: force = M·q̈ + Fv·q̇ + Fc·sgn q̇ + offset, with the
    names and units above (the smoothed sign of estimator.models; identify_emps keeps the
    benchmark's own sign and regressor)."""
    from estimator.models import linear_model
    cols = dict(zip(EMPS_PARAMS, ("qdd", "qd", "sgn(qd)", "1")))
    return linear_model("emps", "torque", {n: (cols[n], u) for n, u in zip(EMPS_PARAMS, EMPS_UNITS)},
                        target_unit="N")
