"""Statistics of the sim-to-real diagnosis (estimator.diagnosis): batch-means standard errors,
block bootstrap intervals, and the residual structure tests (whiteness, residual–input
cross-correlation, spectral lines in time and in output angle).

Residuals are autocorrelated when the model lacks something, so every standard error here is a
batch-means one: per run, consecutive samples are grouped into blocks of `block` samples and the
spread of the block sums gives the standard error of a mean (valid for weakly dependent series
whose correlation length is shorter than a block).
"""

from __future__ import annotations

import numpy as np
from scipy import stats


def block_ids(run: np.ndarray, block: int) -> np.ndarray:
    """Block index of each sample: consecutive `block`-sample stretches within each run
    (run: (n,) int run index, samples of a run contiguous and in time order)."""
    run = np.asarray(run)
    out = np.empty(run.size, dtype=np.int64)
    nxt = 0
    for r in np.unique(run):
        idx = np.flatnonzero(run == r)
        b = np.arange(idx.size) // max(1, int(block))
        out[idx] = b + nxt
        nxt += int(b.max()) + 1 if b.size else 0
    return out


def block_size(run: np.ndarray, block: int | None = None) -> int:
    """Samples per batch-means block: `block`, or max(10, √(median samples per run))."""
    n_per_run = np.bincount(run)
    return block or max(10, int(np.sqrt(np.median(n_per_run[n_per_run > 0]))))


def mean_se(v: np.ndarray, blocks: np.ndarray) -> tuple[float, float]:
    """Mean of v and its batch-means standard error (blocks: block index of each sample).
    Fewer than 3 blocks: the SE is +inf (no claim is made)."""
    v = np.asarray(v, dtype=float)
    if v.size == 0:
        return 0.0, float("inf")
    m = float(v.mean())
    ub, inv = np.unique(blocks, return_inverse=True)
    if ub.size < 3:
        return m, float("inf")
    sums = np.bincount(inv, weights=v - m)
    se = float(np.sqrt(np.sum(sums ** 2) * ub.size / (ub.size - 1))) / v.size
    return m, se


def blocks_improved_z(gain: np.ndarray, blocks: np.ndarray) -> float:
    """Sign test over the blocks: (blocks whose summed `gain` is positive − half the blocks) /
    its binomial SD under chance, √(blocks)/2. Unlike mean_se's gain / SE it does not depend on
    where the gain sits, so a gain carried by a few blocks (a lag's, at the torque steps) that
    the other blocks confirm still scores high. Fewer than 3 blocks: 0 (no claim is made)."""
    ub, inv = np.unique(blocks, return_inverse=True)
    if ub.size < 3:
        return 0.0
    n_up = int(np.sum(np.bincount(inv, weights=np.asarray(gain, dtype=float)) > 0))
    return float((n_up - ub.size / 2) / np.sqrt(ub.size / 4))


def bootstrap_shrinkage(e0: np.ndarray, e1: np.ndarray, blocks: np.ndarray, n_boot: int = 400,
                        seed: int = 0, level: float = 0.95) -> tuple[float, float, float]:
    """Shrinkage 1 − rmse(e1)/rmse(e0) and its block-bootstrap percentile interval (blocks of
    consecutive samples resampled with replacement, so autocorrelation is kept)."""
    e0 = np.asarray(e0, dtype=float)
    e1 = np.asarray(e1, dtype=float)
    if e0.size == 0:
        return float("nan"), float("nan"), float("nan")
    point = 1.0 - float(np.sqrt(np.sum(e1 ** 2) / np.sum(e0 ** 2)))
    ub, inv = np.unique(blocks, return_inverse=True)
    if ub.size < 3:
        return point, float("nan"), float("nan")
    s0 = np.bincount(inv, weights=e0 ** 2)
    s1 = np.bincount(inv, weights=e1 ** 2)
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, ub.size, size=(n_boot, ub.size))
    b = 1.0 - np.sqrt(s1[pick].sum(axis=1) / np.maximum(s0[pick].sum(axis=1), 1e-300))
    a = (1.0 - level) / 2.0
    return point, float(np.quantile(b, a)), float(np.quantile(b, 1.0 - a))


def acf(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation at lags 1..max_lag."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    d = float(x @ x)
    if d <= 0 or x.size <= max_lag + 1:
        return np.zeros(max_lag)
    return np.array([float(x[:-k] @ x[k:]) / d for k in range(1, max_lag + 1)])


def whiteness(residual: np.ndarray, run: np.ndarray, max_lag: int = 10) -> dict:
    """Ljung–Box test per run on the first `max_lag` autocorrelations; reports the smallest
    p-value (Bonferroni over runs) and the largest |autocorrelation| (the effect size)."""
    ps, worst = [], 0.0
    for r in np.unique(run):
        x = residual[run == r]
        n = x.size
        if n <= 4 * max_lag:
            continue
        rho = acf(x, max_lag)
        q = n * (n + 2) * np.sum(rho ** 2 / (n - np.arange(1, max_lag + 1)))
        ps.append(float(stats.chi2.sf(q, max_lag)))
        worst = max(worst, float(np.max(np.abs(rho))))
    p = min(1.0, min(ps) * len(ps)) if ps else 1.0
    return {"test": "Ljung–Box", "lags": max_lag, "p_value": p, "max_abs_acf": worst}


def cross_correlation(residual: np.ndarray, inputs: dict[str, np.ndarray], run: np.ndarray,
                      max_lag: int = 10) -> dict:
    """Largest normalised residual–input cross-correlation over lags −max_lag..max_lag, per input,
    pooled over runs (each run's series centred), with the white-noise 99.9 % bound."""
    out = {}
    n_total = residual.size
    for name, u in inputs.items():
        best, best_lag = 0.0, 0
        for lag in range(-max_lag, max_lag + 1):
            num, d1, d2 = 0.0, 0.0, 0.0
            for r in np.unique(run):
                m = run == r
                e = residual[m] - residual[m].mean()
                x = u[m] - u[m].mean()
                if e.size <= abs(lag) + 2:
                    continue
                if lag >= 0:
                    a, b = e[lag:], x[:e.size - lag]
                else:
                    a, b = e[:lag], x[-lag:]
                num += float(a @ b)
                d1 += float(a @ a)
                d2 += float(b @ b)
            rho = num / np.sqrt(d1 * d2) if d1 > 0 and d2 > 0 else 0.0
            if abs(rho) > abs(best):
                best, best_lag = rho, lag
        out[name] = {"max_corr": float(best), "lag": int(best_lag)}
    bound = float(stats.norm.isf(0.0005 / max(1, 2 * max_lag + 1)) / np.sqrt(max(n_total, 1)))
    return {"inputs": out, "bound": bound}


def run_periodograms(residual: np.ndarray, t: np.ndarray, run: np.ndarray
                     ) -> list[tuple[np.ndarray, np.ndarray]]:
    """(frequencies [Hz], periodogram) of each run's residual, detrended (a straight line taken
    out), without the zero-frequency bin and, for an even length, the Nyquist one; runs shorter
    than 64 samples are left out."""
    out = []
    for r in np.unique(run):
        m = run == r
        x = residual[m]
        if x.size < 64:
            continue
        dt = float(np.median(np.diff(t[m])))
        x = x - np.polyval(np.polyfit(np.arange(x.size), x, 1), np.arange(x.size))
        spec = np.abs(np.fft.rfft(x)) ** 2
        spec = spec[1:-1] if x.size % 2 == 0 else spec[1:]
        out.append((np.arange(1, spec.size + 1) / (x.size * dt), spec))
    return out


def spectral_line(residual: np.ndarray, t: np.ndarray, run: np.ndarray) -> dict:
    """Fisher's g test for one dominant line in each run's residual periodogram (detrended);
    the smallest Bonferroni p-value, its frequency [Hz] and the line's share of the variance."""
    best = {"p_value": 1.0, "freq_hz": None, "share": 0.0}
    n_runs = np.unique(run).size
    for f, spec in run_periodograms(residual, t, run):
        if spec.size < 8 or spec.sum() <= 0:
            continue
        k = int(np.argmax(spec))
        g = float(spec[k] / spec.sum())
        mm = spec.size
        p = min(1.0, mm * (1.0 - g) ** (mm - 1)) * n_runs
        if p < best["p_value"]:
            best = {"p_value": float(min(1.0, p)), "freq_hz": float(f[k]), "share": g}
    return best


def band_excess(residual: np.ndarray, t: np.ndarray, run: np.ndarray, lo_hz: float,
                hi_hz: float) -> float:
    """The residual's power between lo_hz and hi_hz [Hz] over the power a white residual of
    the same variance would put there (1: white; each run's detrended periodogram, summed over
    the runs). A stiffening drive train rings at a frequency that moves with the load, so its
    ringing spreads over a band where a single spectral line may not stand out."""
    inside = white = 0.0
    for f, spec in run_periodograms(residual, t, run):
        sel = (f >= lo_hz) & (f <= hi_hz)
        inside += float(spec[sel].sum())
        white += float(spec.sum()) * float(sel.mean())
    return inside / white if white > 0 else 0.0


def angle_periodogram(residual: np.ndarray, angle: np.ndarray, lo: int, hi: int,
                      top: int = 2) -> list[int]:
    """The `top` integer orders k in lo..hi [cycles per revolution of `angle`] at the largest
    peaks of |Σ e·exp(−i·k·angle)|², strongest first: a screen of many orders (thousands) at
    the cost of two complex vector operations per order (exp(i·k·angle) by recurrence), where
    angle_lines' two-column least squares per order would cost a hundred times more."""
    e = np.asarray(residual, dtype=float)
    a = np.asarray(angle, dtype=float)
    if hi < lo or e.size < 20:
        return []
    step = np.exp(-1j * a)
    w = np.exp(-1j * lo * a)
    power = np.empty(hi - lo + 1)
    for i in range(power.size):
        if i and i % 256 == 0:          # restart the recurrence: no drift over thousands
            w = np.exp(-1j * (lo + i) * a)
        power[i] = abs(complex(e @ w)) ** 2
        w *= step
    # distinct lines: local maxima only (a line leaks into its neighbouring orders when the
    # travel is short)
    left = np.r_[-np.inf, power[:-1]]
    right = np.r_[power[1:], -np.inf]
    peaks = np.flatnonzero((power >= left) & (power >= right))
    return [int(lo + i) for i in peaks[np.argsort(-power[peaks])][:top]]


def angle_lines(residual: np.ndarray, q: np.ndarray, orders: np.ndarray) -> dict:
    """Amplitude of the residual's projection on sin/cos(k·q) for each order k [cycles/rev]
    (least squares on the two columns), the peak order, its amplitude [residual unit] and its
    F statistic against the residual variance (whether q covers enough angle is up to the
    data: with little angle travel every order looks alike and F stays small)."""
    n = residual.size
    var = float(np.var(residual))
    best = {"order": None, "amplitude": 0.0, "F": 0.0, "p_value": 1.0}
    if n < 20 or var <= 0:
        return best
    ee = float(residual @ residual)
    orders = np.asarray(orders, dtype=float)
    F = np.zeros(orders.size)
    amp = np.zeros(orders.size)
    for i0 in range(0, orders.size, 32):  # 32 orders at a time: bounded memory
        k = orders[i0:i0 + 32, None]
        S, C = np.sin(k * q[None, :]), np.cos(k * q[None, :])
        ss, sc, cc = np.einsum("ij,ij->i", S, S), np.einsum("ij,ij->i", S, C), \
            np.einsum("ij,ij->i", C, C)
        bs, bc = S @ residual, C @ residual
        det = ss * cc - sc ** 2
        ok = det > 1e-9 * np.maximum(ss * cc, 1e-300)
        a_s = np.where(ok, (cc * bs - sc * bc) / np.where(ok, det, 1.0), 0.0)
        a_c = np.where(ok, (ss * bc - sc * bs) / np.where(ok, det, 1.0), 0.0)
        fit = a_s * bs + a_c * bc
        F[i0:i0 + 32] = (fit / 2.0) / np.maximum((ee - fit) / (n - 2), 1e-300)
        amp[i0:i0 + 32] = np.hypot(a_s, a_c)
    j = int(np.argmax(F))
    if F[j] > 0:
        best = {"order": int(orders[j]), "amplitude": float(amp[j]), "F": float(F[j])}
    best["top_orders"] = [int(orders[i]) for i in np.argsort(-F)[:5]]
    best["p_value"] = float(min(1.0, stats.f.sf(best["F"], 2, n - 2) * len(orders))) \
        if best["order"] is not None else 1.0
    return best


def block_robust_cov(X: np.ndarray, e: np.ndarray, blocks: np.ndarray) -> np.ndarray:
    """Covariance of least-squares coefficients fitted on X (n, p) with residual e, robust to
    correlation within the batch-means blocks (the cluster sandwich
    (XᵀX)⁺·Σ_b (X_bᵀe_b)(X_bᵀe_b)ᵀ·(XᵀX)⁺·G/(G−1), G blocks): an ordinary least-squares
    covariance assumes white errors and is too narrow on a residual that drifts."""
    X = np.asarray(X, dtype=float)
    e = np.asarray(e, dtype=float)
    ub, inv = np.unique(blocks, return_inverse=True)
    g = ub.size
    if g < 3:
        return np.full((X.shape[1], X.shape[1]), np.inf)
    sums = np.zeros((g, X.shape[1]))
    np.add.at(sums, inv, X * e[:, None])
    bread = np.linalg.pinv(X.T @ X)
    return bread @ (sums.T @ sums) @ bread * (g / (g - 1))


def covering_runs(run: np.ndarray, t: np.ndarray, angle: np.ndarray, order: float,
                  periods: float, window_s: float = 0.5) -> np.ndarray:
    """Mask of the samples of the runs whose angle path spans at least `periods` periods of a
    ripple of `order` [cycles per revolution]: the path is the angle [rad] swept counting every
    pass (a trajectory that runs back and forth over a range sweeps it each time), read on the
    angle's means over `window_s` [s] so that an encoder dithering between two steps at rest
    adds no path. On a run that sweeps less, a sine of the angle is a smooth function of it
    and anything slow over the run (a drift in time, a settling) fits it as well as a ripple
    would; revisiting the same angles at other times is what tells the two apart."""
    run = np.asarray(run)
    t = np.asarray(t, dtype=float)
    angle = np.asarray(angle, dtype=float)
    keep = np.zeros(run.size, dtype=bool)
    for r in np.unique(run):
        m = run == r
        ok = np.isfinite(angle[m]) & np.isfinite(t[m])
        a, tt = angle[m][ok], t[m][ok]
        if a.size < 2:
            continue
        w = np.floor((tt - tt[0]) / window_s).astype(np.int64)
        means = np.bincount(w, weights=a) / np.maximum(np.bincount(w), 1)
        means = means[np.bincount(w) > 0]
        path = float(np.abs(np.diff(means)).sum())
        if order * path >= 2.0 * np.pi * periods:
            keep |= m
    return keep
