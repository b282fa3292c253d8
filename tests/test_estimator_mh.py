"""Random-walk Metropolis–Hastings: a known Gaussian target, and simulation-based calibration on
the linear model's posterior (the paper's Eq. 16 prior)."""

import numpy as np
import pytest

from estimator.convergence import ess_bulk, split_rhat
from estimator.linear_posterior import LinearPosterior
from estimator.mh import metropolis_hastings, target_acceptance
from estimator.priors import paper_prior

from estimator_synth import ranks_uniform, sbc_coverage


def test_mh_samples_a_correlated_gaussian():
    mu = np.array([1.0, -2.0, 0.5])
    A = np.array([[1.0, 0.9, 0.0], [0.9, 1.0, 0.3], [0.0, 0.3, 2.0]])
    C = A @ A.T * 0.01
    P = np.linalg.inv(C)

    def logp(x):
        d = x - mu
        return -0.5 * d @ P @ d

    x0 = mu + np.random.default_rng(0).standard_normal((4, 3))  # far: ~10 sd away
    out = metropolis_hastings(logp, x0, n_draws=4000, n_warmup=2000, seed=1)
    d = out.draws.reshape(-1, 3)
    ess = ess_bulk(out.draws)
    assert np.all(split_rhat(out.draws) < 1.01)
    assert np.all(np.abs(d.mean(0) - mu) < 4 * np.sqrt(np.diag(C) / ess))
    assert np.allclose(np.cov(d.T), C, atol=4 * np.sqrt(2 / ess.min()) * np.sqrt(np.outer(np.diag(C), np.diag(C))))
    # warm-up tuned the acceptance rate near the optimum for d = 3
    assert np.all(np.abs(out.accept_rate - target_acceptance(3)) < 0.08)
    assert out.draws.shape == (4, 4000, 3) and out.seconds > 0


def test_mh_rejects_bad_start():
    with pytest.raises(ValueError):
        metropolis_hastings(lambda x: -np.inf, np.zeros((2, 1)), 10, 10, 0)


@pytest.mark.slow
def test_sbc_mh():
    prior = paper_prior(3)

    def draw(X, y, rng):
        lp = LinearPosterior(X, y, prior)
        x0 = lp.start(4, rng)
        out = metropolis_hastings(lp.logp, x0, n_draws=1000, n_warmup=600,
                                  seed=int(rng.integers(1 << 31)), proposal_cov=lp.laplace_cov())
        z = out.draws.reshape(-1, 4)
        return z[:, :3], np.exp(z[:, 3])

    hits, ranks = sbc_coverage(prior, draw, reps=200, seed=21)
    cover = hits.mean()
    assert 0.92 <= cover <= 0.98, cover
    assert ranks_uniform(ranks) > 1e-3
