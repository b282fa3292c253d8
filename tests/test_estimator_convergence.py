"""R-hat, ESS, autocorrelation and RMSE against cases whose answer is known."""

import numpy as np
import pytest

from estimator.convergence import (autocorr, ess_bulk, ess_mean, ess_tail, fit_from_draws,
                                   mean_autocorr, rhat_trace, rmse, split_rhat, summarize)


def _ar1(rng, phi, chains, n):
    e = rng.standard_normal((chains, n))
    x = np.empty_like(e)
    x[:, 0] = e[:, 0] / np.sqrt(1 - phi ** 2)
    for t in range(1, n):
        x[:, t] = phi * x[:, t - 1] + e[:, t]
    return x[:, :, None]


def test_iid_normal_draws_have_rhat_one_and_ess_n():
    rng = np.random.default_rng(0)
    ess_b, ess_t, rh = [], [], []
    for _ in range(20):
        x = rng.standard_normal((4, 1000, 1))
        ess_b.append(ess_bulk(x)[0])
        ess_t.append(ess_tail(x)[0])
        rh.append(split_rhat(x)[0])
    assert np.mean(ess_b) == pytest.approx(4000, rel=0.05)
    assert np.mean(ess_t) == pytest.approx(4000, rel=0.10)
    assert max(abs(r - 1) for r in rh) < 0.01


def test_ar1_ess_matches_theory():
    # ESS of an AR(1) chain: n·(1−φ)/(1+φ).
    rng = np.random.default_rng(1)
    phi = 0.8
    x = _ar1(rng, phi, 4, 20000)
    expect = 4 * 20000 * (1 - phi) / (1 + phi)
    assert ess_mean(x)[0] == pytest.approx(expect, rel=0.12)
    assert ess_bulk(x)[0] == pytest.approx(expect, rel=0.12)
    acf = autocorr(x, 5)[:, 0]
    assert np.allclose(acf, phi ** np.arange(6), atol=0.02)


def test_stuck_or_separated_chains_have_high_rhat():
    rng = np.random.default_rng(2)
    x = rng.standard_normal((4, 1000, 2))
    x[0, :, 0] += 3.0                    # one chain elsewhere
    x[1, :, 1] = 0.3                     # one chain stuck
    r = split_rhat(x)
    assert r[0] > 1.2 and r[1] > 1.1
    # a chain drifting within itself is caught by splitting
    y = rng.standard_normal((4, 1000, 1)) + np.linspace(0, 4, 1000)[None, :, None]
    assert split_rhat(y)[0] > 1.2


def test_rhat_trace_every_200():
    rng = np.random.default_rng(3)
    its, r = rhat_trace(rng.standard_normal((3, 1000, 2)), every=200)
    assert list(its) == [200, 400, 600, 800, 1000]
    assert r.shape == (5, 2) and np.all(np.abs(r - 1) < 0.05)


def test_mean_autocorr_separates_good_and_poor_mixing():
    rng = np.random.default_rng(4)
    good = rng.standard_normal((4, 2000, 1))
    poor = _ar1(rng, 0.95, 4, 2000)
    assert abs(mean_autocorr(good)[0]) < 0.02
    assert mean_autocorr(poor)[0] > 0.3


def test_rmse_eq17():
    assert rmse([1, 2, 3], [1, 2, 5]) == pytest.approx(np.sqrt(4 / 3))
    assert rmse([1, np.nan, 3], [2, 2, 3]) == pytest.approx(np.sqrt(0.5))


def test_summary_and_fit_from_draws():
    rng = np.random.default_rng(5)
    d = rng.normal([1.0, -2.0], [0.5, 0.1], size=(4, 2000, 2))
    s = summarize(d, ["a", "b"], ["m", "s"], seconds=2.0)
    assert np.allclose(s["mean"], [1, -2], atol=0.03)
    assert np.allclose(s["sd"], [0.5, 0.1], rtol=0.05)
    assert np.allclose(s["ci_low"], [1 - 1.96 * 0.5, -2 - 1.96 * 0.1], atol=0.05)
    assert s["diagnostics"]["min_ess_per_s"] == pytest.approx(np.min(s["diagnostics"]["ess_bulk"]) / 2)
    f = fit_from_draws("m", "mh", ["a", "b"], ["m", "s"], d, np.full((4, 2000), 3.0), 1.5,
                       seconds=2.0, accept_rate=np.full(4, 0.25))
    js = f.as_dict()
    assert js["sigma"] == pytest.approx(3.0) and js["params"][0]["name"] == "a"
    assert js["diagnostics"]["accept_rate"] == [0.25] * 4


def test_autocorr_of_chains_that_never_move_is_nan_without_a_warning():
    # a parameter whose chains all stay put (a fixed or collapsed parameter) has no
    # autocorrelation; one stuck chain among moving ones is left out of the average
    import warnings
    rng = np.random.default_rng(5)
    x = rng.standard_normal((3, 500, 2))
    x[:, :, 1] = 0.7                     # every chain stuck
    x[0, :, 0] = -1.0                    # one chain stuck, two moving
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        acf = autocorr(x, 4)
    assert np.all(np.isnan(acf[:, 1]))
    assert acf[0, 0] == pytest.approx(1.0)
    assert np.allclose(acf[:, 0], autocorr(x[1:, :, :1], 4)[:, 0])
