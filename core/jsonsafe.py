"""JSON-safe copies of values: JSON has no NaN or infinity (and PostgreSQL's JSON refuses them),
no tuples and no numpy types. One cleaner for every document the platform writes or answers."""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def json_safe(x: Any) -> Any:
    """A copy of x fit for JSON: non-finite floats → None, tuples and arrays → lists, numpy
    scalars → Python numbers, mapping keys → text; recursively."""
    if isinstance(x, dict):
        return {str(k): json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if isinstance(x, np.ndarray):
        return json_safe(x.tolist())
    if isinstance(x, np.generic):
        return json_safe(x.item())
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    return x


def finite_list(a: np.ndarray) -> list:
    """A 1-D array as a list with None where it is not finite (a missing sample)."""
    if a.dtype == object or a.ndim != 1:
        return [json_safe(v) for v in a.tolist()]
    return [float(v) if math.isfinite(v) else None for v in a.tolist()]
