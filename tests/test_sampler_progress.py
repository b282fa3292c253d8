"""The samplers' progress callback (estimator.sampler_progress): every chain reports from 0 to
warm-up + draws with non-decreasing counts, the phase it is in, at most REPORTS_PER_CHAIN
times plus its boundaries; the draws do not change when a callback is installed; chains run in
threads (HMC), through a chain_map, and in other processes (a QueueProgress drained by
`forwarding`) all report back under their own chain index."""

from __future__ import annotations

import multiprocessing
import threading

import numpy as np
import pytest
from estimator_synth import eq4_run

from estimator import sampler_progress as sp
from estimator.hmc import hmc
from estimator.identify import identify
from estimator.mh import metropolis_hastings
from estimator.sghmc import sghmc

COV = np.array([[1.0, 0.3], [0.3, 0.5]])
PREC = np.linalg.inv(COV)


def logp(x):
    return -0.5 * x @ PREC @ x


def logp_grad(x):
    return -0.5 * x @ PREC @ x, -PREC @ x


class Recorder:
    """A thread-safe callback keeping every call."""

    def __init__(self) -> None:
        self.calls: list[tuple[int, int, int, str]] = []
        self.lock = threading.Lock()

    def __call__(self, chain: int, done: int, total: int, phase: str) -> None:
        with self.lock:
            self.calls.append((chain, done, total, phase))

    def per_chain(self) -> dict[int, list[tuple[int, int, str]]]:
        out: dict[int, list] = {}
        for c, d, t, ph in self.calls:
            out.setdefault(c, []).append((d, t, ph))
        return out


def check_chain(reports: list[tuple[int, int, str]], n_warmup: int, n_draws: int) -> None:
    total = n_warmup + n_draws
    done = [d for d, _, _ in reports]
    assert done[0] == 0 and done[-1] == total
    assert all(b >= a for a, b in zip(done, done[1:])), done
    assert {t for _, t, _ in reports} == {total}
    for d, _, ph in reports:
        assert ph == ("warmup" if d < n_warmup else "sampling"), (d, ph)
    if n_warmup:
        assert (n_warmup, total, "sampling") in reports        # the phase change is reported
    assert len(reports) <= sp.REPORTS_PER_CHAIN + 3


def test_metropolis_hastings_reports_every_chain_and_draws_the_same():
    x0 = np.zeros((3, 2))
    rec = Recorder()
    with sp.reporting(rec):
        out = metropolis_hastings(logp, x0, 700, 300, seed=4)
    by_chain = rec.per_chain()
    assert sorted(by_chain) == [0, 1, 2]
    for reports in by_chain.values():
        check_chain(reports, 300, 700)
    plain = metropolis_hastings(logp, x0, 700, 300, seed=4)
    np.testing.assert_array_equal(out.draws, plain.draws)
    assert sp.current() is None                     # uninstalled after the block


def test_sghmc_reports_its_chains_one_after_the_other():
    rng = np.random.default_rng(0)
    X = rng.standard_normal((200, 2))
    y = X @ np.array([1.0, -0.5]) + 0.3 * rng.standard_normal(200)

    def grad_u(th, idx):
        r = y[idx] - X[idx] @ th
        return -(200.0 / len(idx)) * (X[idx].T @ r) / 0.09 + th

    rec = Recorder()
    with sp.reporting(rec):
        sghmc(grad_u, 200, np.zeros((2, 2)), 250, 50, seed=1, batch_size=200)
    by_chain = rec.per_chain()
    assert sorted(by_chain) == [0, 1]
    for reports in by_chain.values():
        check_chain(reports, 50, 250)
    last_of_0 = max(i for i, c in enumerate(rec.calls) if c[0] == 0)
    first_of_1 = min(i for i, c in enumerate(rec.calls) if c[0] == 1)
    assert last_of_0 < first_of_1


@pytest.mark.parametrize("threads", [0, 2])
def test_hmc_chains_report_from_their_threads(threads):
    rec = Recorder()
    with sp.reporting(rec):
        hmc(logp_grad, np.zeros((2, 2)), 150, 100, seed=2, threads=threads)
    by_chain = rec.per_chain()
    assert sorted(by_chain) == [0, 1]
    for reports in by_chain.values():
        check_chain(reports, 100, 150)


def test_chain_reporter_throttles_and_reports_nothing_without_a_callback():
    rec = Recorder()
    rep = sp.ChainReporter(rec, [5], n_warmup=7, n_draws=1000)
    rep.start()
    for i in range(1, 1008):
        rep.step(i)
    assert rec.calls[0] == (5, 0, 1007, "warmup") and rec.calls[-1] == (5, 1007, 1007, "sampling")
    assert (5, 7, 1007, "sampling") in rec.calls
    assert len(rec.calls) == 1 + 1 + 1007 // sp.stride(1007) + 1
    silent = sp.ChainReporter(None, [0], 10, 10)
    silent.start()
    silent.step(10)                                  # no callback: nothing to call, no error
    assert silent.every == 0


def test_chains_through_a_chain_map_report_under_their_own_index():
    run = eq4_run(1, duration=20.0)
    rec = Recorder()
    with sp.reporting(rec):
        identify([run], "eq4", "mh", chains=3, draws=200, warmup=100, chain_map=map)
    by_chain = rec.per_chain()
    assert sorted(by_chain) == [0, 1, 2]
    for reports in by_chain.values():
        check_chain(reports, 100, 200)


def test_chains_in_other_processes_report_back_through_a_queue():
    run = eq4_run(2, duration=20.0)
    rec = Recorder()
    ctx = multiprocessing.get_context("spawn")
    with ctx.Manager() as manager, ctx.Pool(2) as pool:
        with sp.forwarding(rec, manager.Queue()) as back, sp.reporting(back):
            fit = identify([run], "eq4", "sghmc", chains=2, draws=150, warmup=50,
                           chain_map=pool.map)
    assert fit.draws is not None
    by_chain = rec.per_chain()
    assert sorted(by_chain) == [0, 1]
    for reports in by_chain.values():
        check_chain(reports, 50, 150)
