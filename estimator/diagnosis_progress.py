"""Progress of the sim-to-real diagnosis (estimator.diagnosis), reported through a plain callback
(drawing is the caller's: commands/progress.py's StageBar).

A caller that wants to show how far a diagnosis is installs a callback with `reporting(fn)`;
estimator.diagnosis calls

    fn(stage, done, total)

with `stage` the step it is in, named with the law it works on — for each law in turn
'<law>: nominal fit', '<law>: candidates' (each candidate's shape searched and fitted on the
training runs), '<law>: scoring' (each candidate scored on the held-out runs), '<law>: greedy
round k' (the candidates left re-fitted on top of the k − 1 effects chosen), '<law>:
shrinkage', with <law> 'output law' or 'twist–torque law' (whose nominal shape is fitted first:
'twist–torque law: nominal shape'); when the output law's search ends with the torque reading's
gain significant, that law is searched again as <law> 'output law with the torque reading's
gain' (estimator.models.with_torque_gain) — `done` the units of that step finished and `total` its
units (candidates; 1 for a single fit). Each stage
reports done = 0 when it starts and done = total when it ends, `done` non-decreasing within a
stage; a stage's name is not reported again after a later stage started. The calls cost
nothing next to the fits between them; without an installed callback `current()` is None and
nothing is reported. The diagnosis's results do not depend on the callback.

The callback lives in a context variable, like estimator.sampler_progress's: each thread starts
without one (the diagnosis runs in the thread that asked for it).

This module imports nothing to draw with."""

from __future__ import annotations

from typing import Callable, ContextManager

from estimator.context_slot import ContextSlot

Progress = Callable[[str, int, int], None]
"""progress(stage, done, total): the diagnosis has finished `done` of the `total` units of
`stage`."""

_PROGRESS: ContextSlot[Progress | None] = ContextSlot("diagnosis_progress", None)


def current() -> Progress | None:
    """The callback installed in this context, or None."""
    return _PROGRESS.get()


def reporting(progress: Progress | None) -> ContextManager[None]:
    """Install `progress` for the diagnoses run inside the `with` block (in this thread/task);
    None installs nothing (the diagnosis then reports nothing)."""
    return _PROGRESS.installed(progress)


def report(stage: str, done: int, total: int) -> None:
    """Call the installed callback, if any, with (stage, done, total)."""
    fn = _PROGRESS.get()
    if fn is not None:
        fn(stage, int(done), int(total))
