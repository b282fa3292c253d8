"""The twist–torque law's noise floor is capped by what a fit reaches on the held-out runs
(estimator.diagnosis._search). That floor is the encoders' rounding as a surrogate models it
(estimator.diagnosis_floors.quantisation_floor), and no model beats the sensors on runs it was
not fitted on: a held-out mean square clearly under the floor shows the surrogate overstates
the rounding. Without the cap, an overstated floor hides every effect on that law: it lies
above the nominal's whole residual, no structure is left to remove, and each candidate fails
the materiality test however clear its held-out gain (rig B's hysteresis at ENR 1, once the
encoders' rounding was counted in its recorded twist)."""

from __future__ import annotations

import copy

import pytest

from core.run import RunData
from estimator.diagnosis import diagnose

INJECTED = {"hysteresis": {"scale": 0.331}}
"""The emulator's hysteresis at an effect-to-noise ratio of about 1 in the elastic world
(tests/test_diagnosis.py, TX_ENR1)."""


def _overstated(run: RunData, factor: float) -> RunData:
    """The run with its output encoder's step stated `factor` times too coarse."""
    meta = copy.deepcopy(run.meta)
    meta["sensors"]["q"]["resolution"] = factor * float(meta["sensors"]["q"]["resolution"])
    return RunData(samples=run.samples, meta=meta)


@pytest.fixture(scope="module")
def verdicts():
    pytest.importorskip("numba")
    from commands.diagnosis_harness import simulate_campaign
    train, test = simulate_campaign(copy.deepcopy(INJECTED), 5)
    assert train[0].meta["sensors"]["q"]["resolution"] > 0
    true = diagnose(train, test, "eq4", transmission="eq5")["transmission"]
    over = diagnose([_overstated(r, 3.0) for r in train], [_overstated(r, 3.0) for r in test],
                    "eq4", transmission="eq5")["transmission"]
    return true, over


def test_an_encoder_step_stated_too_coarse_does_not_hide_an_effect(verdicts):
    true, over = verdicts
    v = over["verdict"]
    assert v["effects"] == ["hysteresis"], v["summary"]
    assert v["noise_floor_source"] == "held-out residual"
    # the floor is a held-out error a fit reached: never above the nominal's
    assert v["noise_floor_rms"] <= over["baseline"]["rmse_test"] + 1e-9


def test_the_verdict_is_the_one_the_true_sheet_gives(verdicts):
    true, over = verdicts
    assert true["verdict"]["effects"] == ["hysteresis"]
    assert true["verdict"]["noise_floor_source"] != "held-out residual"
    assert (over["verdict"]["status"], over["verdict"]["effects"]) == (
        true["verdict"]["status"], true["verdict"]["effects"])
