"""Progress of the samplers' chains, reported through a plain callback (drawing is the caller's).

A caller that wants to show how far the chains are installs a callback with `reporting(fn)`;
the samplers (MH, SGHMC, HMC, and through them the Bouc–Wen fit) take it once with `current()`
and call

    fn(chain, done, total, phase)

with `chain` the chain's index (0-based), `done` the iterations it has finished (warm-up and
sampling together, non-decreasing per chain), `total` = warm-up + kept draws, and `phase`
'warmup' or 'sampling' (the phase the next iteration belongs to: `done == n_warmup` already
says 'sampling'). Each chain reports once at its start (done = 0), then every `stride(total)`
iterations (at most REPORTS_PER_CHAIN times), at the end of its warm-up and at its end
(done = total): the count check costs one modulo per iteration, the call itself a hundred
times per chain at most, whatever the chain's length. Without an installed callback
`current()` is None and nothing is reported.

The callback lives in a context variable, like estimator.stopping's check: each thread starts
without one, so a sampler running its chains in threads takes it in the calling thread and
hands it to them (the callback must then be thread-safe). Chains run in other processes
(a `chain_map` of estimator.identify over a process pool or a cluster) get the callback inside
their task, pickled: install a `QueueProgress` there, whose calls travel back on a queue, and
drain that queue in the caller with `forwarding(fn, queue)`.

This module imports nothing to draw with: commands/progress.py draws the bars."""

from __future__ import annotations

import threading
from contextlib import contextmanager
from typing import Any, Callable, ContextManager, Iterator, Sequence

from estimator.context_slot import ContextSlot

Progress = Callable[[int, int, int, str], None]
"""progress(chain, done, total, phase): chain `chain` has finished `done` of `total` iterations
and is in `phase` ('warmup' or 'sampling')."""

REPORTS_PER_CHAIN = 100
"""Most reports a chain makes between its start and its end (plus the phase boundary)."""

WARMUP, SAMPLING = "warmup", "sampling"

_PROGRESS: ContextSlot[Progress | None] = ContextSlot("estimator_progress", None)


def current() -> Progress | None:
    """The callback installed in this context, or None."""
    return _PROGRESS.get()


def reporting(progress: Progress | None) -> ContextManager[None]:
    """Install `progress` for the samplers run inside the `with` block (in this thread/task);
    None installs nothing (the samplers then report nothing)."""
    return _PROGRESS.installed(progress)


def stride(total: int) -> int:
    """Iterations between two reports of a chain of `total` iterations."""
    return max(1, -(-int(total) // REPORTS_PER_CHAIN))


class ChainReporter:
    """Reports the chains `chains` (indices, all at the same count: MH moves its chains in
    lockstep) to `progress`. `start()` once, then `step(done)` after every iteration: it calls
    the callback only every stride(total) iterations and at the phase boundaries. With
    progress None both are no-ops."""

    def __init__(self, progress: Progress | None, chains: Sequence[int], n_warmup: int,
                 n_draws: int) -> None:
        self.progress = progress
        self.chains = [int(c) for c in chains]
        self.n_warmup = int(n_warmup)
        self.total = int(n_warmup) + int(n_draws)
        self.every = stride(self.total) if progress is not None else 0

    def phase(self, done: int) -> str:
        """The phase of the iteration after `done` finished ones."""
        return WARMUP if done < self.n_warmup else SAMPLING

    def report(self, done: int) -> None:
        """Call the callback for every chain at `done` iterations (unthrottled)."""
        if self.progress is not None:
            ph = self.phase(done)
            for c in self.chains:
                self.progress(c, done, self.total, ph)

    def start(self) -> None:
        self.report(0)

    def step(self, done: int) -> None:
        """After iteration `done` (1-based count of finished iterations)."""
        if self.every and (done % self.every == 0 or done == self.n_warmup
                           or done == self.total):
            self.report(done)


def offset(progress: Progress | None, first: int) -> Progress | None:
    """`progress` with chain indices shifted by `first` (a task running chain `first` alone
    reports it as its chain 0)."""
    if progress is None or first == 0:
        return progress
    return _Offset(progress, int(first))


class _Offset:
    """Picklable when the wrapped callback is (a QueueProgress is)."""

    def __init__(self, progress: Progress, first: int) -> None:
        self.progress, self.first = progress, first

    def __call__(self, chain: int, done: int, total: int, phase: str) -> None:
        self.progress(chain + self.first, done, total, phase)


class QueueProgress:
    """A picklable callback that puts (chain, done, total, phase) on `queue` (e.g. a
    `multiprocessing.Manager().Queue()`, whose proxy travels to pool workers): how chains run
    in other processes report back to the caller, who drains the queue with `forwarding`."""

    def __init__(self, queue: Any) -> None:
        self.queue = queue

    def __call__(self, chain: int, done: int, total: int, phase: str) -> None:
        self.queue.put((int(chain), int(done), int(total), str(phase)))


_END = None


@contextmanager
def forwarding(progress: Progress, queue: Any) -> Iterator[QueueProgress]:
    """Yield a QueueProgress on `queue` while a thread of this process calls `progress` with
    every report put on it; on exit the reports already queued are delivered, then the thread
    ends."""
    def drain() -> None:
        while True:
            item = queue.get()
            if item is _END:
                return
            progress(*item)

    thread = threading.Thread(target=drain, name="sampler-progress", daemon=True)
    thread.start()
    try:
        yield QueueProgress(queue)
    finally:
        queue.put(_END)
        thread.join()
