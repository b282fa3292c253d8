"""Convergence and accuracy diagnostics of posterior draws, and the summary every Bayesian method
turns into a `Fit`.

- R-hat: rank-normalised split R-hat (Vehtari, Gelman, Simpson, Carpenter & Bürkner 2021): the
  maximum of the bulk R-hat (rank-normalised split chains) and the tail R-hat (the same on the
  folded draws |θ − median|).
- ESS: bulk ESS (rank-normalised split chains) and tail ESS (minimum over the 5 % and 95 %
  quantile indicators), each with Geyer's initial-monotone-sequence estimator of the
  autocorrelation sum, as in Stan's `posterior` and ArviZ.
- The paper's Table 6 "mean autocorrelation" and Figs. 16–17's R-hat every 200 iterations.
- RMSE, Eq. 17.
Draws are (chains, draws, p) arrays throughout.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from scipy import stats

from estimator.result import Fit


def _as3d(draws) -> np.ndarray:
    a = np.asarray(draws, dtype=float)
    if a.ndim == 1:
        a = a[None, :, None]
    elif a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3:
        raise ValueError("draws must be (chains, draws, p)")
    return a


def _split(x: np.ndarray) -> np.ndarray:
    """(m, n) -> (2m, n//2): each chain cut in halves (the middle draw dropped when n is odd)."""
    m, n = x.shape
    h = n // 2
    return np.concatenate([x[:, :h], x[:, n - h:]], axis=0)


def _rank_normalize(x: np.ndarray) -> np.ndarray:
    """Φ⁻¹((rank − 3/8)/(S + 1/4)) over all draws of all chains, ties averaged."""
    r = stats.rankdata(x, method="average").reshape(x.shape)
    return stats.norm.ppf((r - 0.375) / (x.size + 0.25))


def _rhat_basic(x: np.ndarray) -> float:
    m, n = x.shape
    if n < 2:
        return np.nan
    w = np.mean(np.var(x, axis=1, ddof=1))
    b = n * np.var(np.mean(x, axis=1), ddof=1) if m > 1 else 0.0
    if w <= 0:
        return 1.0 if b == 0 else np.inf
    var_hat = (n - 1) / n * w + b / n
    return float(np.sqrt(var_hat / w))


def _autocov(x: np.ndarray) -> np.ndarray:
    """Per-chain autocovariance (biased, /n) of x (m, n), by FFT."""
    m, n = x.shape
    xc = x - x.mean(axis=1, keepdims=True)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    f = np.fft.rfft(xc, n=size, axis=1)
    return np.fft.irfft(f * np.conj(f), n=size, axis=1)[:, :n] / n


def _ess_basic(x: np.ndarray) -> float:
    """ESS of x (m, n) with Geyer's initial positive and monotone sequences."""
    m, n = x.shape
    if n < 4:
        return np.nan
    if np.all(x == x.flat[0]):
        return np.nan
    acov = _autocov(x)
    chain_mean = x.mean(axis=1)
    mean_var = np.mean(acov[:, 0]) * n / (n - 1.0)
    var_plus = mean_var * (n - 1.0) / n
    if m > 1:
        var_plus += np.var(chain_mean, ddof=1)
    if var_plus <= 0:
        return np.nan
    rho = np.zeros(n)
    rho[0] = 1.0
    rho_even = 1.0
    rho_odd = 1.0 - (mean_var - np.mean(acov[:, 1])) / var_plus
    rho[1] = rho_odd
    t = 1
    while t < n - 3 and (rho_even + rho_odd) > 0:
        rho_even = 1.0 - (mean_var - np.mean(acov[:, t + 1])) / var_plus
        rho_odd = 1.0 - (mean_var - np.mean(acov[:, t + 2])) / var_plus
        if rho_even + rho_odd >= 0:
            rho[t + 1] = rho_even
            rho[t + 2] = rho_odd
        t += 2
    max_t = t - 2
    if rho_even > 0:
        rho[max_t + 1] = rho_even
    t = 1
    while t <= max_t - 2:
        if rho[t + 1] + rho[t + 2] > rho[t - 1] + rho[t]:
            rho[t + 1] = (rho[t - 1] + rho[t]) / 2.0
            rho[t + 2] = rho[t + 1]
        t += 2
    tau = -1.0 + 2.0 * np.sum(rho[:max_t + 1]) + np.sum(rho[max_t + 1:max_t + 2])
    tau = max(tau, 1.0 / np.log10(m * n))
    return float(m * n / tau)


def split_rhat(draws: np.ndarray) -> np.ndarray:
    """Rank-normalised split R-hat per parameter, (chains, draws, p) -> (p,): max of bulk and
    tail (folded) R-hat. ≈ 1 for converged chains; > 1.01 deserves a look."""
    a = _as3d(draws)
    out = np.empty(a.shape[2])
    for j in range(a.shape[2]):
        x = _split(a[:, :, j])
        if x.shape[1] < 2 or np.all(x == x.flat[0]):
            out[j] = np.nan
            continue
        bulk = _rhat_basic(_rank_normalize(x))
        fold = np.abs(x - np.median(x))
        tail = _rhat_basic(_rank_normalize(fold))
        out[j] = max(bulk, tail)
    return out


def ess_bulk(draws: np.ndarray) -> np.ndarray:
    """Bulk effective sample size per parameter (rank-normalised split chains)."""
    a = _as3d(draws)
    return np.array([_ess_basic(_rank_normalize(_split(a[:, :, j]))) for j in range(a.shape[2])])


def ess_tail(draws: np.ndarray) -> np.ndarray:
    """Tail effective sample size per parameter: min ESS of the indicators θ ≤ q05, θ ≤ q95."""
    a = _as3d(draws)
    out = np.empty(a.shape[2])
    for j in range(a.shape[2]):
        x = _split(a[:, :, j])
        # quantiles of all the draws (Stan's posterior, ArviZ): with an odd draw count the
        # split drops each chain's middle draw, which must not move the thresholds
        q05, q95 = np.quantile(a[:, :, j], [0.05, 0.95])
        e = [_ess_basic((x <= q05).astype(float)), _ess_basic((x <= q95).astype(float))]
        out[j] = np.nanmin(e) if not np.all(np.isnan(e)) else np.nan
    return out


def ess_mean(draws: np.ndarray) -> np.ndarray:
    """ESS of the posterior mean (split chains, no rank normalisation): MCSE = sd/√ESS."""
    a = _as3d(draws)
    return np.array([_ess_basic(_split(a[:, :, j])) for j in range(a.shape[2])])


def autocorr(draws: np.ndarray, max_lag: int) -> np.ndarray:
    """Autocorrelation function at lags 0..max_lag, averaged over chains: (max_lag+1, p)."""
    a = _as3d(draws)
    n = a.shape[1]
    L = int(min(max_lag, n - 1))
    out = np.empty((L + 1, a.shape[2]))
    for j in range(a.shape[2]):
        ac = _autocov(a[:, :, j])
        with np.errstate(invalid="ignore", divide="ignore"):
            rho = ac[:, :L + 1] / ac[:, :1]
        # a chain that never moves has no autocorrelation (0/0): averaged over the chains that
        # do, NaN when none does (without numpy's empty-slice warning in the log)
        ok = np.isfinite(rho)
        n_ok = ok.sum(axis=0)
        total = np.where(ok, rho, 0.0).sum(axis=0)
        out[:, j] = np.where(n_ok > 0, total / np.maximum(n_ok, 1), np.nan)
    return out


def mean_autocorr(draws: np.ndarray, max_lag: int = 50) -> np.ndarray:
    """The paper's Table 6 statistic, made well defined: the mean of the autocorrelation function
    over lags 1..max_lag (averaged over chains), per parameter. Near 0 for a well-mixing chain;
    the paper does not state its lags (its values ~1e-3 suggest all lags, whose mean tends to
    −1/(2n) for any chain), so we fix a lag window that does discriminate."""
    return autocorr(draws, max_lag)[1:].mean(axis=0)


def rhat_trace(draws: np.ndarray, every: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Split R-hat on the first k·every draws of each chain, k = 1, 2, ... (Figs. 16–17).
    Returns (iterations (k,), rhat (k, p))."""
    a = _as3d(draws)
    its = np.arange(every, a.shape[1] + 1, every)
    if its.size == 0:
        return its, np.empty((0, a.shape[2]))
    return its, np.array([split_rhat(a[:, :k]) for k in its])


def rmse(y: np.ndarray, y_hat: np.ndarray) -> float:
    """Eq. 17: √(mean((y − ŷ)²)), NaN pairs skipped."""
    y = np.asarray(y, dtype=float)
    y_hat = np.asarray(y_hat, dtype=float)
    ok = np.isfinite(y) & np.isfinite(y_hat)
    return float(np.sqrt(np.mean((y[ok] - y_hat[ok]) ** 2)))


def summarize(draws_physical: np.ndarray, names: Sequence[str], units: Sequence[str],
              seconds: float | None = None, level: float = 0.95, rhat_every: int = 200,
              max_lag: int = 50) -> dict[str, Any]:
    """Point estimates and diagnostics of draws (chains, draws, p) in physical units.

    Returns {"names", "units", "mean", "sd", "median", "ci_low", "ci_high" (equal-tailed
    `level` interval), "diagnostics": {"rhat", "ess_bulk", "ess_tail", "ess_mean", "mcse_mean",
    "ess_per_s" (bulk ESS per second of sampling, None without `seconds`), "min_ess_per_s",
    "mean_autocorr", "autocorr" (lags 0..max_lag), "rhat_trace": {"iterations", "rhat"},
    "chains", "draws_per_chain"}}."""
    a = _as3d(draws_physical)
    flat = a.reshape(-1, a.shape[2])
    lo_q, hi_q = (1 - level) / 2, 1 - (1 - level) / 2
    mean = flat.mean(axis=0)
    sd = flat.std(axis=0, ddof=1) if flat.shape[0] > 1 else np.zeros(a.shape[2])
    eb, et, em = ess_bulk(a), ess_tail(a), ess_mean(a)
    its, rt = rhat_trace(a, rhat_every)
    diag: dict[str, Any] = {
        "rhat": split_rhat(a), "ess_bulk": eb, "ess_tail": et, "ess_mean": em,
        "mcse_mean": sd / np.sqrt(em),
        "mean_autocorr": mean_autocorr(a, max_lag), "autocorr": autocorr(a, max_lag),
        "rhat_trace": {"iterations": its, "rhat": rt},
        "chains": int(a.shape[0]), "draws_per_chain": int(a.shape[1]),
        "ess_per_s": None, "min_ess_per_s": None,
    }
    if seconds and seconds > 0:
        diag["ess_per_s"] = eb / seconds
        diag["min_ess_per_s"] = float(np.nanmin(eb) / seconds)
    return {"names": list(names), "units": list(units), "mean": mean, "sd": sd,
            "median": np.median(flat, axis=0), "ci_low": np.quantile(flat, lo_q, axis=0),
            "ci_high": np.quantile(flat, hi_q, axis=0), "diagnostics": diag}


def fit_from_draws(model: str, method: str, names: Sequence[str], units: Sequence[str],
                   draws_physical: np.ndarray, sigma_draws: np.ndarray, rmse_train: float,
                   rmse_test: float | None = None, seconds: float | None = None,
                   accept_rate: np.ndarray | None = None, extra: dict | None = None,
                   timings: dict | None = None, level: float = 0.95) -> Fit:
    """Build a Fit from posterior draws in physical units: posterior mean as the point estimate,
    equal-tailed 95 % credible intervals, the posterior mean of the noise sd as `sigma`
    (its sd and interval in extra['sigma']), and `summarize`'s diagnostics."""
    s = summarize(draws_physical, names, units, seconds=seconds, level=level)
    sig = np.asarray(sigma_draws, dtype=float).ravel()
    diag = s["diagnostics"]
    if accept_rate is not None:
        diag["accept_rate"] = np.asarray(accept_rate, dtype=float)
    ex = dict(extra or {})
    ex["sigma"] = {"mean": float(sig.mean()), "sd": float(sig.std(ddof=1)) if sig.size > 1 else 0.0,
                   "ci_low": float(np.quantile(sig, (1 - level) / 2)),
                   "ci_high": float(np.quantile(sig, 1 - (1 - level) / 2))}
    tm = dict(timings or {})
    if seconds is not None:
        tm.setdefault("sample", float(seconds))
    return Fit(model=model, method=method, param_names=list(names), units=list(units),
               mean=s["mean"], sd=s["sd"], ci_low=s["ci_low"], ci_high=s["ci_high"],
               sigma=float(sig.mean()), rmse_train=float(rmse_train),
               rmse_test=None if rmse_test is None else float(rmse_test),
               draws=np.asarray(draws_physical, dtype=float), diagnostics=diag, timings=tm,
               extra=ex)
