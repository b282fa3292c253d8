"""The diagnosis's progress callback (estimator.diagnosis_progress): called at every stage with
counts that never go back, each stage reported as one contiguous span from 0 to its total, and
the report bit-identical with and without a callback installed (the calls only observe)."""

import json

import pytest

from commands.cmd_diagnose import _json_default
from commands.independent_harness import VARIANTS, simulate_campaign
from estimator import diagnosis_progress
from estimator.diagnosis import diagnose


@pytest.fixture(scope="module")
def campaign():
    train, test, _ = simulate_campaign(VARIANTS[0], 7)
    return train, test


def test_no_callback_is_installed_by_default_and_reporting_restores_it():
    assert diagnosis_progress.current() is None
    calls = []
    with diagnosis_progress.reporting(lambda *a: calls.append(a)):
        diagnosis_progress.report("output law: candidates", 1, 3)
        with diagnosis_progress.reporting(None):
            diagnosis_progress.report("output law: candidates", 2, 3)
    diagnosis_progress.report("output law: candidates", 3, 3)
    assert calls == [("output law: candidates", 1, 3)]
    assert diagnosis_progress.current() is None


def test_stages_have_monotone_counts_and_the_report_is_identical(campaign):
    train, test = campaign
    plain = diagnose(train, test, "eq4", transmission="eq5")
    calls: list[tuple[str, int, int]] = []
    with diagnosis_progress.reporting(lambda s, d, t: calls.append((s, d, t))):
        watched = diagnose(train, test, "eq4", transmission="eq5")
    assert (json.dumps(plain, sort_keys=True, default=_json_default)
            == json.dumps(watched, sort_keys=True, default=_json_default))

    stages = list(dict.fromkeys(s for s, _, _ in calls))
    # each stage one contiguous span of calls (never reported again once a later one began)
    spans = [s for k, (s, _, _) in enumerate(calls) if k == 0 or calls[k - 1][0] != s]
    assert spans == stages
    for stage in stages:
        mine = [(d, t) for s, d, t in calls if s == stage]
        totals = {t for _, t in mine}
        assert len(totals) == 1, (stage, mine)
        done = [d for d, _ in mine]
        assert done == sorted(done) and done[0] == 0 and done[-1] == mine[0][1], (stage, mine)
    assert stages[:4] == ["output law: nominal fit", "output law: candidates",
                          "output law: scoring", "output law: greedy round 1"]
    assert "twist–torque law: nominal fit" in stages
    assert "twist–torque law: candidates" in stages
    assert stages[-1] == "twist–torque law: shrinkage"
    # the candidates stage counts the output law's candidates the report lists
    n_out = sum(1 for c in plain["candidates"] if c.get("model", "eq4") == "eq4")
    cand = [t for s, _, t in calls if s == "output law: candidates"]
    assert cand[0] == n_out > 1
    # every greedy round but the first re-fits the candidates left, one at a time
    rounds = [s for s in stages if s.startswith("output law: greedy round ")]
    assert rounds == [f"output law: greedy round {k}" for k in range(1, len(rounds) + 1)]
