"""Stopping a long computation from outside: the samplers' cancellation hook.

A caller that may need to stop a fit (the service's job worker, when a job is cancelled or runs
past its wall-clock limit) installs a check with `stop_check(fn)`; `fn()` returns when the work
may go on and raises (any exception) to stop it. The samplers (MH, SGHMC, HMC, the Bouc–Wen
fit, the Sobol evaluation) take the installed check once with `current()` and call it in their
loops, at least once per iteration (per leapfrog step for HMC), so that a check raising reaches
them within a fraction of a second of work; the exception unwinds the fit and nothing of it is
returned. Without an installed check, `current()` is a no-op and costs one function call.

The check lives in a context variable (each thread or task starts without one); a sampler that
runs its chains in threads takes the check in the calling thread and hands it to them."""

from __future__ import annotations

from typing import Callable, ContextManager

from estimator.context_slot import ContextSlot

StopCheck = Callable[[], None]
"""Returns when the work may go on; raises to stop it."""


def _go_on() -> None:
    """The check when none is installed: never stops."""


_CHECK: ContextSlot[StopCheck] = ContextSlot("estimator_stop_check", _go_on)


def current() -> StopCheck:
    """The check installed in this context (a no-op when none is)."""
    return _CHECK.get()


def poll() -> None:
    """Call the installed check once (raises when the work must stop)."""
    _CHECK.get()()


def stop_check(check: StopCheck) -> ContextManager[None]:
    """Install `check` for the samplers run inside the `with` block (in this thread/task)."""
    return _CHECK.installed(check)
