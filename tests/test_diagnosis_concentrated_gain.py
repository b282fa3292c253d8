"""A candidate whose held-out gain sits in a few blocks (a lag of the torque reading gains at the
torque steps): its gain / SE cannot grow with the effect, so it is also significant when its
shrinkage is at least `concentrated_min_shrinkage` and more held-out blocks improve than chance
allows (estimator.diagnosis_candidates._score); such a candidate is chosen only after those
significant by their gain (estimator.diagnosis's greedy search)."""

from __future__ import annotations

import numpy as np
import pytest

from estimator.diagnosis import DiagnosisOptions
from estimator.diagnosis_candidates import _Fit, _score
from estimator.models import eq4

N_BLOCKS, PER_BLOCK = 200, 50


def _fit(e_test: np.ndarray) -> _Fit:
    return _Fit(model=eq4(), shape={}, theta=np.zeros(1), se=np.ones(1), cov=np.eye(1),
                e_train=np.zeros(4), e_test=e_test, rmse_train_dof=1.0)


def _case(step: float, improve_elsewhere: bool, seed: int = 0):
    """Unit noise everywhere; `step` added in 4 blocks (the torque steps), which the new model
    removes; elsewhere the new model's error is 0.98 of the old one's (a consistent small gain)
    or fresh noise of the same size (no gain)."""
    rng = np.random.default_rng(seed)
    blocks = np.repeat(np.arange(N_BLOCKS), PER_BLOCK)
    noise = rng.normal(size=blocks.size)
    steps = np.isin(blocks, [10, 60, 110, 160])
    e0 = noise + np.where(steps, step, 0.0)
    e1 = 0.98 * noise if improve_elsewhere else rng.normal(size=blocks.size)
    return _fit(e0), _fit(e1), blocks


def test_a_gain_in_a_few_blocks_that_the_others_confirm_is_significant():
    cur, new, blocks = _case(30.0, True)
    s = _score(cur, new, blocks, DiagnosisOptions())
    assert s["z"] < 3.0 < s["z_blocks_improved"] and s["shrinkage"] > 0.5
    assert s["significant"] and s["concentrated"]


def test_a_gain_in_a_few_blocks_alone_is_not():
    cur, new, blocks = _case(30.0, False)
    s = _score(cur, new, blocks, DiagnosisOptions())
    assert s["z"] < 3.0 and s["z_blocks_improved"] < 3.0
    assert not s["significant"]


def test_a_small_shrinkage_needs_its_gain_over_its_se():
    cur, new, blocks = _case(2.0, True)
    s = _score(cur, new, blocks, DiagnosisOptions())
    assert s["shrinkage"] < 0.1 and s["z_blocks_improved"] > 3.0
    assert s["significant"] == (s["z"] > 3.0) and not s["concentrated"]


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -0.1, 1.5])
def test_the_threshold_is_refused_out_of_range(bad):
    with pytest.raises(ValueError, match="concentrated_min_shrinkage"):
        DiagnosisOptions(concentrated_min_shrinkage=bad)
