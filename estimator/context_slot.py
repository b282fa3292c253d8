"""One value installed for the code run inside a `with` block, in this thread or asyncio task
(a context variable): how a caller hands the samplers and the diagnosis a stop check or a
progress callback without threading it through every signature. A thread starts without the
caller's value: code that runs work in threads takes it in the calling thread and passes it on."""

from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar
from typing import Generic, Iterator, TypeVar

T = TypeVar("T")


class ContextSlot(Generic[T]):
    """A named slot holding `default` until a value is installed with `installed(value)`."""

    def __init__(self, name: str, default: T) -> None:
        self._var: ContextVar[T] = ContextVar(name, default=default)

    def get(self) -> T:
        """The value installed in this context, else the default."""
        return self._var.get()

    @contextmanager
    def installed(self, value: T) -> Iterator[None]:
        """`value` in the slot for the `with` block; the previous one afterwards."""
        token = self._var.set(value)
        try:
            yield
        finally:
            self._var.reset(token)
