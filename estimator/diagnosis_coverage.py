"""How much of the training runs' conditions the held-out runs cover.

The diagnosis names an effect only when it improves the held-out error. An effect that a
nominal parameter absorbs over the held-out runs' range cannot do that, however clearly the
training runs show it: a constant torque offset is fitted by the gravity column g·cos q wherever
the joint stays near the zero (cos q ≈ 1), so held-out runs that never travel far cannot test
what training runs that do travel far reveal (docs/diagnosis.md, "Rig K's constant offset at
300 Hz"). The report states, per input the candidate effects depend on, the part of the training
runs' range the held-out runs reach, and the verdict's summary says which inputs fall short, so a
`none` on a split that cannot test an effect is not read as its absence."""

from __future__ import annotations

import math
from typing import Callable, Mapping

import numpy as np

from core.channels import unit_of
from core.documents import CoverageEntry

INPUTS: dict[str, tuple[str, Callable[[np.ndarray], np.ndarray]]] = {
    "q": ("q", np.asarray),
    "qd": ("qd", np.asarray),
    "temp_joint": ("temp_joint", np.asarray),
    "abs_torque_load": ("torque_load", np.abs),
}
"""The inputs effects of the vocabulary depend on, each as (channel, function of it): the angle
(gravity, gear ripple), the speed with its sign (friction, its direction), the joint
temperature, and the load's magnitude |τ_L| (load-dependent friction grows with |T|)."""

LABELS = {"abs_torque_load": "|torque_load|"}
"""How the summary writes an input whose key is not its channel's name."""

QUANTILES = (0.01, 0.99)
"""A range is taken between these quantiles of the samples, so a single spike does not set it."""

SHORT = 0.5
"""The summary names an input whose held-out range covers less than this share of the training
runs' range (a reporting cut: the JSON carries every share)."""


def held_out_coverage(train: Mapping[str, np.ndarray], test: Mapping[str, np.ndarray]
                      ) -> dict[str, CoverageEntry]:
    """Per input of INPUTS whose channel both sample sets hold (the law's kept samples): the
    training and held-out ranges (between QUANTILES) and `fraction`, the share of the training
    range that the held-out range overlaps (0–1). Inputs whose training range has no width, or
    with no finite sample, are left out."""
    out: dict[str, CoverageEntry] = {}
    for name, (channel, fn) in INPUTS.items():
        if channel not in train or channel not in test:
            continue
        a = np.asarray(fn(np.asarray(train[channel], float)), float)
        b = np.asarray(fn(np.asarray(test[channel], float)), float)
        a, b = a[np.isfinite(a)], b[np.isfinite(b)]
        if not a.size or not b.size:
            continue
        lo_a, hi_a = (float(x) for x in np.quantile(a, QUANTILES))
        lo_b, hi_b = (float(x) for x in np.quantile(b, QUANTILES))
        width = hi_a - lo_a
        if not width > 0:
            continue
        overlap = max(0.0, min(hi_a, hi_b) - max(lo_a, lo_b))
        out[name] = {"training": [lo_a, hi_a], "held_out": [lo_b, hi_b],
                     "fraction": overlap / width, "unit": unit_of(channel)}
    return out


def short_coverage(coverage: Mapping[str, CoverageEntry]) -> list[str]:
    """The inputs whose held-out range covers less than SHORT of the training range."""
    return [n for n, c in coverage.items() if c["fraction"] < SHORT]


def percent(fraction: float) -> str:
    """A share as a whole percentage, rounded down: a share under the cut never prints as the
    cut itself (0.4996 is 49 %, not 50 %)."""
    return f"{math.floor(100 * fraction)}%"


def coverage_line(coverage: Mapping[str, CoverageEntry]) -> str:
    """Every input's share on one line, e.g. `q 19%, qd 91%, |torque_load| 100%`."""
    return ", ".join(f"{LABELS.get(n, n)} {percent(c['fraction'])}" for n, c in coverage.items())


def coverage_note(coverage: Mapping[str, CoverageEntry]) -> str:
    """The summary's clause on the inputs short_coverage names; '' when it names none."""
    short = [(n, coverage[n]) for n in short_coverage(coverage)]
    if not short:
        return ""
    parts = [f"{percent(c['fraction'])} of the training runs' range of "
             f"{LABELS.get(n, n)} ({c['held_out'][0]:.3g} to {c['held_out'][1]:.3g} of "
             f"{c['training'][0]:.3g} to {c['training'][1]:.3g} {c['unit']})".replace(" )", ")")
             for n, c in short]
    return ("; the held-out runs cover only " + " and ".join(parts) + ": an effect that a "
            "nominal parameter absorbs over the held-out range cannot show in the held-out test")
