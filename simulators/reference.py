"""The same joint model run as a plain-Python loop, for the benchmark and a consistency test.

Honestly the same code: `python_version(f)` takes a numba dispatcher's own Python function and
rebinds, recursively, every compiled function it calls to that function's plain Python version
(down to the shared terms of core.terms and core.effects). Nothing is re-implemented; the result
just runs in the interpreter instead of as machine code.
"""

from __future__ import annotations

import types
from typing import Callable

from numba.core.registry import CPUDispatcher

from simulators import kernel as K


def python_version(func: Callable, _memo: dict | None = None) -> Callable:
    """Plain-Python twin of a numba-compiled function (and of everything compiled it calls)."""
    memo = {} if _memo is None else _memo
    py = getattr(func, "py_func", func)
    if id(py) in memo:
        return memo[id(py)]
    glb = dict(py.__globals__)
    twin = types.FunctionType(py.__code__, glb, py.__name__, py.__defaults__, py.__closure__)
    twin.__qualname__ = py.__qualname__
    twin.__doc__ = py.__doc__
    memo[id(py)] = twin
    for name in py.__code__.co_names:
        obj = glb.get(name)
        if isinstance(obj, CPUDispatcher):
            glb[name] = python_version(obj, memo)
    return twin


advance = python_version(K.advance)
"""kernel.advance as a plain-Python loop (same signature and semantics)."""

snapshot = python_version(K.snapshot)
