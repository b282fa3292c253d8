"""Which torque reading drifts (estimator.diagnosis_channel): the output balance's target is
T − τ_L, so a drift of the torque channel T and one of the load reading τ_L look alike there;
the twist–torque law reads T only. The same drift added to one channel or the other of one
emulator campaign: on T it is the vocabulary's torque_offset; on τ_L it is outside the
vocabulary and must not be named torque_offset. (The emulator's Bouc–Wen twist law fits a
drift of its own on this campaign, about 2 N·m/s with no channel drifting, so the share found
on T is 1.5 and −0.5 here rather than 1 and 0; the decision weighs it by its block-robust
standard error.)"""

from __future__ import annotations

import numpy as np
import pytest

from commands.diagnosis_harness import simulate_campaign, world
from core.run import RunData
from estimator.diagnosis import diagnose
from estimator.diagnosis_stats import block_ids, block_robust_cov

SEED = 5
DRIFT = 3.0
"""Drift [N·m/s] added to one channel: about 270 N·m over a 90 s run, the size of the
emulator harness's torque_offset at ENR 2 (c0 271 N·m)."""


def _drifting(run: RunData, channel: str) -> RunData:
    df = run.samples.copy()
    df[channel] = df[channel] + DRIFT * df["t"]
    return RunData(samples=df, meta=run.meta)


@pytest.fixture(scope="module")
def campaign():
    effects, tx = world({})
    train, test = simulate_campaign(effects, SEED)
    return train, test, tx


def _diagnosed(campaign, channel: str, transmission=True):
    train, test, tx = campaign
    return diagnose([_drifting(r, channel) for r in train], [_drifting(r, channel) for r in test],
                    "eq4", transmission=tx if transmission else None)


def test_a_drift_of_the_torque_channel_is_torque_offset(campaign):
    rep = _diagnosed(campaign, "torque")
    v = rep["verdict"]
    assert "torque_offset" in v["effects"], v["summary"]
    assert v["offset_channel"]["channel"] == "torque", v["offset_channel"]
    assert v["offset_channel"]["share_on_torque_channel"] > 0.5
    assert not v.get("outside_vocabulary")


def test_a_drift_of_the_load_reading_is_outside_the_vocabulary(campaign):
    rep = _diagnosed(campaign, "torque_load")
    v = rep["verdict"]
    assert "torque_offset" not in v["effects"], v["summary"]
    assert v["status"] in ("unexplained", "partly_explained")
    assert v["offset_channel"]["channel"] == "torque_load", v["offset_channel"]
    assert v["offset_channel"]["share_on_torque_channel"] < 0.5
    assert v["outside_vocabulary"] and "load reading" in v["summary"]
    assert v["laws"][rep["baseline"]["model"]]["effects"] == []


def test_without_the_twist_law_the_two_cannot_be_told_apart(campaign):
    rep = _diagnosed(campaign, "torque_load", transmission=False)
    assert rep["verdict"]["effects"][:1] == ["torque_offset"]
    assert "offset_channel" not in rep["verdict"]


def test_block_robust_covariance_widens_on_a_correlated_residual():
    rng = np.random.default_rng(0)
    n, phi = 20000, 0.9
    t = np.linspace(0.0, 1.0, n)
    X = np.column_stack([np.ones(n), t])
    white = rng.standard_normal(n)
    ar = np.empty(n)
    ar[0] = white[0]
    for i in range(1, n):
        ar[i] = phi * ar[i - 1] + np.sqrt(1 - phi ** 2) * white[i]
    blocks = block_ids(np.zeros(n, dtype=int), 200)

    def ratio(e):
        ols = np.linalg.inv(X.T @ X) * np.var(e)
        return np.sqrt(block_robust_cov(X, e, blocks)[1, 1] / ols[1, 1])
    # white: the sandwich agrees with least squares; AR(1) at 0.9: √((1+φ)/(1−φ)) ≈ 4.4 wider
    assert 0.7 < ratio(white) < 1.4
    assert 3.0 < ratio(ar) < 6.0


def test_no_claim_without_a_finite_covariance():
    """Fewer than 3 batch-means blocks give an infinite covariance: no reading is claimed."""
    from estimator.diagnosis_channel import offset_channel
    from estimator.models import model_from_spec
    model = model_from_spec("eq4").with_effect("torque_offset")
    n = len(model.param_names)
    theta = np.zeros(n)
    theta[model.param_names.index("drift")] = 2.0
    t = np.linspace(0.0, 90.0, 901)
    run = np.zeros(t.size, dtype=int)
    finite = np.eye(n) * 1e-6
    names = ["c0", "drift"]
    ok = offset_channel(model, theta, finite, names, np.array([0.0, 0.0]), np.eye(2) * 1e-6,
                        {"t": t}, run, 3.0)
    assert ok is not None and ok["channel"] == "torque_load"
    assert offset_channel(model, theta, np.full((n, n), np.inf), names, np.array([0.0, 0.0]),
                          np.eye(2) * 1e-6, {"t": t}, run, 3.0) is None
