"""The samplers' cancellation hook (estimator.stopping): every sampler polls the installed stop
check at least once per iteration (per leapfrog step for HMC, per block for the Sobol
evaluation), chains run in threads included, and a check that raises ends the fit with that
exception; without a check nothing changes."""

from __future__ import annotations

import numpy as np
import pytest

from estimator import stopping


class Stop(Exception):
    pass


class Counter:
    """A stop check that counts its calls and raises Stop from call `raise_at` on."""

    def __init__(self, raise_at: int | None = None):
        self.calls, self.raise_at = 0, raise_at

    def __call__(self) -> None:
        self.calls += 1
        if self.raise_at is not None and self.calls >= self.raise_at:
            raise Stop(f"stopped at call {self.calls}")


def gaussian_logp(x):
    return -0.5 * float(x @ x)


def gaussian_logp_grad(x):
    return -0.5 * float(x @ x), -x


def test_no_check_installed_is_a_no_op():
    assert stopping.current() is stopping.current()
    stopping.poll()
    c = Counter(raise_at=1)
    with stopping.stop_check(c):
        with pytest.raises(Stop):
            stopping.poll()
    stopping.poll()                     # uninstalled again on leaving the block
    assert c.calls == 1


def test_mh_polls_every_iteration_and_stops():
    from estimator.mh import metropolis_hastings

    c = Counter()
    with stopping.stop_check(c):
        metropolis_hastings(gaussian_logp, np.zeros((2, 3)), n_draws=50, n_warmup=30, seed=0)
    assert c.calls >= 80
    c = Counter(raise_at=40)
    with stopping.stop_check(c), pytest.raises(Stop):
        metropolis_hastings(gaussian_logp, np.zeros((2, 3)), n_draws=10**6, n_warmup=10, seed=0)
    assert c.calls == 40


def test_sghmc_polls_every_iteration_and_stops():
    from estimator.sghmc import sghmc

    def grad_u(th, idx):
        return th * (1000 / 1000)

    c = Counter()
    kw = dict(batch_size=1000, step_size=0.1, friction=0.5)
    with stopping.stop_check(c):
        sghmc(grad_u, 1000, np.zeros((2, 2)), 40, 20, 0, **kw)
    assert c.calls >= 2 * 60
    c = Counter(raise_at=25)
    with stopping.stop_check(c), pytest.raises(Stop):
        sghmc(grad_u, 1000, np.zeros((1, 2)), 10**6, 10, 0, **kw)
    assert c.calls == 25


@pytest.mark.parametrize("threads", [0, 2])
def test_hmc_polls_every_leapfrog_step_in_chain_threads_too(threads):
    from estimator.hmc import hmc

    c = Counter()
    with stopping.stop_check(c):
        out = hmc(gaussian_logp_grad, np.zeros((2, 2)), n_draws=30, n_warmup=30, seed=0,
                  threads=threads)
    assert c.calls >= out.extra["n_grad"].sum() - 2 * 200   # all but the step-size searches
    c = Counter(raise_at=50)
    with stopping.stop_check(c), pytest.raises(Stop):
        hmc(gaussian_logp_grad, np.zeros((2, 2)), n_draws=10**6, n_warmup=10, seed=0,
            threads=threads)


def test_sobol_evaluation_polls_per_block_and_stops():
    from estimator.sobol import evaluate_chunks, sobol_design

    design = sobol_design(["a", "b"], [1.0, 2.0], [0.1, 0.2], n_base=64, seed=0)
    c = Counter()
    with stopping.stop_check(c):
        y = evaluate_chunks(lambda rows: rows.sum(axis=1), design, chunk_size=32)
    np.testing.assert_allclose(y, design.X.sum(axis=1))
    assert c.calls == -(-design.X.shape[0] // 32)
    with stopping.stop_check(Counter(raise_at=2)), pytest.raises(Stop):
        evaluate_chunks(lambda rows: rows.sum(axis=1), design, chunk_size=32)


def test_bouc_wen_fit_stops_in_its_least_squares_start():
    from estimator.bouc_wen import fit_bouc_wen
    from estimator.identify import bouc_wen_signals
    from estimator.preprocess import prepare
    from estimator_synth import eq11_run

    run, _ = eq11_run(seed=1, duration=60.0)
    sig = prepare(run, bouc_wen_signals(run))
    c = Counter(raise_at=5)
    with stopping.stop_check(c), pytest.raises(Stop):
        fit_bouc_wen(sig, "ls")
    assert c.calls == 5
