"""The exact posteriors (the reference of every sampler): closed forms against brute-force
integration, least squares against the exact posterior, and simulation-based calibration."""

import numpy as np
import pytest
from scipy import stats

from estimator.exact import (nig_draws, nig_posterior, nig_posterior_from_stats,
                             semiconjugate_draws, semiconjugate_posterior)
from estimator.least_squares import ols
from estimator.priors import (conjugate_prior, initial_ratio_of_means, inv_gamma_moment_match,
                              paper_prior)
from estimator_synth import ranks_uniform, sbc_coverage


def _one_param_data(seed=0, n=8):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    y = 0.7 * x + 0.8 * rng.standard_normal(n)
    return x[:, None], y


def _brute(X, y, log_prior, theta_grid, s_grid):
    """Posterior moments of (θ, s = log τ²) on a 2-D grid (p = 1)."""
    T, S = np.meshgrid(theta_grid, s_grid, indexing="ij")
    rss = ((y[None, None, :] - T[..., None] * X[:, 0][None, None, :]) ** 2).sum(-1)
    lp = -0.5 * y.size * S - 0.5 * rss * np.exp(-S) + log_prior(T, S)
    w = np.exp(lp - lp.max())
    w /= w.sum()
    m_t = (w * T).sum()
    m_s = (w * S).sum()
    return m_t, np.sqrt((w * (T - m_t) ** 2).sum()), m_s, np.sqrt((w * (S - m_s) ** 2).sum())


def test_semiconjugate_matches_brute_force_integration():
    X, y = _one_param_data()
    a0, b0 = 2.0, 2.0

    def log_prior(T, S):  # θ ~ N(0, 1), τ² ~ IG(2, 2), density in s includes the Jacobian e^s
        return -0.5 * T ** 2 + (-(a0 + 1) * S - b0 * np.exp(-S)) + S

    mt, st, ms, ss = _brute(X, y, log_prior, np.linspace(-4, 4, 801), np.linspace(-6, 4, 801))
    post = semiconjugate_posterior(X, y, np.zeros(1), np.eye(1), a0, b0)
    assert post.mean[0] == pytest.approx(mt, abs=1e-4)
    assert np.sqrt(post.theta_cov[0, 0]) == pytest.approx(st, rel=1e-3)
    th, t2 = semiconjugate_draws(post, 400_000, np.random.default_rng(1))
    assert th.mean() == pytest.approx(mt, abs=4 * st / np.sqrt(4e5))
    assert np.log(t2).mean() == pytest.approx(ms, abs=4 * ss / np.sqrt(4e5))
    assert np.log(t2).std() == pytest.approx(ss, rel=0.01)


def test_nig_matches_brute_force_and_evidence():
    X, y = _one_param_data(seed=3)
    a0, b0, v0 = 2.0, 2.0, 1.5

    def log_prior(T, S):  # θ | τ² ~ N(0, v0·τ²)
        return -0.5 * T ** 2 / (v0 * np.exp(S)) - 0.5 * S + (-(a0 + 1) * S - b0 * np.exp(-S)) + S

    mt, st, ms, ss = _brute(X, y, log_prior, np.linspace(-5, 5, 801), np.linspace(-6, 4, 801))
    post = nig_posterior(X, y, np.zeros(1), v0 * np.eye(1), a0, b0)
    assert post.mean[0] == pytest.approx(mt, abs=1e-4)
    assert np.sqrt(post.theta_cov[0, 0]) == pytest.approx(st, rel=1e-3)
    # evidence: under the conjugate prior y is multivariate Student-t with 2·a0 d.o.f.,
    # location X·m0 and shape (b0/a0)·(I + X·V0·Xᵀ)
    shape = (b0 / a0) * (np.eye(y.size) + v0 * X @ X.T)
    ev = stats.multivariate_t.logpdf(y, loc=np.zeros(y.size), shape=shape, df=2 * a0)
    assert post.log_marginal == pytest.approx(ev, abs=1e-9)
    th, t2 = nig_draws(post, 200_000, np.random.default_rng(0))
    assert t2.mean() == pytest.approx(post.b / (post.a - 1), rel=0.01)
    assert th.std() == pytest.approx(st, rel=0.01)


def test_least_squares_standard_errors_and_agreement_with_exact():
    rng = np.random.default_rng(7)
    n = 3000
    X = np.column_stack([np.ones(n), rng.standard_normal(n), rng.uniform(-1, 1, n)])
    theta = np.array([2.0, -1.0, 0.5])
    y = X @ theta + 0.3 * rng.standard_normal(n)
    r = ols(X, y)
    # textbook formulas
    G = np.linalg.inv(X.T @ X)
    th = G @ X.T @ y
    s2 = np.sum((y - X @ th) ** 2) / (n - 3)
    assert np.allclose(r.theta, th) and np.allclose(r.se, np.sqrt(s2 * np.diag(G)))
    assert np.allclose(r.ci_high - r.theta, stats.t.ppf(0.975, n - 3) * r.se)
    # with much data the exact posterior (weak prior) agrees with least squares
    post = semiconjugate_posterior(X, y, np.zeros(3), 100.0 * np.eye(3), 2.0, 2.0 * s2)
    sd = np.sqrt(np.diag(post.theta_cov))
    assert np.all(np.abs(post.mean - r.theta) < 0.02 * sd)
    assert np.allclose(sd, r.se, rtol=0.01)


def test_appendix_ab_moment_matching():
    a, b = inv_gamma_moment_match(3.0, 4.0)
    assert stats.invgamma.mean(a, scale=b) == pytest.approx(3.0)
    assert stats.invgamma.var(a, scale=b) == pytest.approx(4.0)
    assert initial_ratio_of_means(np.array([1.0, 3.0]), np.array([5.0, 7.0])) == pytest.approx(3.0)
    with pytest.raises(ValueError):
        inv_gamma_moment_match(-1.0, 1.0)


@pytest.mark.parametrize("kind", ["paper", "conjugate"])
def test_sbc_exact_posterior(kind):
    prior = paper_prior(3) if kind == "paper" else conjugate_prior(3)

    def draw(X, y, rng):
        if kind == "paper":
            return semiconjugate_draws(semiconjugate_posterior(X, y, prior.mean, prior.cov,
                                                               prior.a0, prior.b0, 801), 2000, rng)
        return nig_draws(nig_posterior(X, y, prior.mean, prior.cov, prior.a0, prior.b0), 2000, rng)

    hits, ranks = sbc_coverage(prior, draw, reps=400, seed=11)
    cover = hits.mean()
    assert 0.93 <= cover <= 0.97, cover
    assert np.all((hits.mean(axis=0) > 0.91) & (hits.mean(axis=0) < 0.99))
    assert ranks_uniform(ranks) > 1e-3


def test_nig_from_sufficient_statistics_matches_residual_form():
    """The fast path (BLAS XᵀX, y·X, Cholesky solves) against the textbook update with explicit
    inverses, including a nearly noise-free fit where b_n must come from the residuals (the
    Gram form yᵀy − hᵀΛ⁻¹h would lose it to cancellation); the sufficient-statistics entry point
    agrees on ordinary data."""
    rng = np.random.default_rng(5)
    n, p = 4000, 4
    X = np.column_stack([np.ones(n), rng.standard_normal((n, p - 1))])
    theta = np.array([3.0, -2.0, 1.0, 0.5]) * 1e3
    V0, a0 = np.diag(rng.uniform(0.5, 2.0, p)), 2.0

    def textbook(y):
        V0i = np.linalg.inv(V0)
        Vn = np.linalg.inv(V0i + X.T @ X)
        mn = Vn @ (V0i @ m0 + X.T @ y)
        r, d = y - X @ mn, mn - m0
        return mn, Vn, b0 + 0.5 * (r @ r + d @ V0i @ d)

    # ordinary noise and a vague prior; then a nearly noise-free fit (residual power ~1e-24 of
    # the signal's) with the prior centred on the truth, so that b_n is all residual
    for noise, m0, b0 in ((0.3, rng.standard_normal(p), 0.7), (1e-9, theta, 1e-20)):
        y = X @ theta + noise * rng.standard_normal(n)
        post = nig_posterior(X, y, m0, V0, a0, b0)
        mn, Vn, bn = textbook(y)
        assert np.allclose(post.mean, mn, rtol=1e-10, atol=1e-12)
        assert np.allclose(post.cov_unit, Vn, rtol=1e-10, atol=1e-18)
        assert post.b == pytest.approx(bn, rel=1e-4, abs=0.0)
        assert post.a == a0 + n / 2
    # the from-statistics entry point is the same computation
    y = X @ np.ones(p) + rng.standard_normal(n)
    a = nig_posterior(X, y, np.zeros(p), V0, a0, 0.7)
    b = nig_posterior_from_stats(X.T @ X, X.T @ y, float(y @ y), n, np.zeros(p), V0, a0, 0.7)
    assert np.allclose(a.mean, b.mean) and a.b == pytest.approx(b.b, rel=1e-12)
    assert a.log_marginal == pytest.approx(b.log_marginal, abs=1e-8)
