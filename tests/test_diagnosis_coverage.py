"""The held-out runs' coverage of the training runs' conditions (estimator.diagnosis_coverage):
the ranges and shares, the verdict's summary clause, and a campaign of an independent rig whose
split the verdict flags, against the same runs split so that the held-out runs cover them."""

from __future__ import annotations

import numpy as np
import pytest

from commands.cmd_diagnose import format_text
from commands.independent_harness import VARIANTS, simulate_campaign
from estimator.diagnosis import diagnose
from estimator.diagnosis_coverage import coverage_note, held_out_coverage, short_coverage

RIG_K_FEW = next(v for v in VARIANTS if v.rig == "rig_k" and v.few_runs)


def test_ranges_and_shares_of_the_training_range():
    x = np.linspace(-2.0, 2.0, 1001)
    train = {"q": x, "qd": x, "torque_load": 1e5 * x, "temp_joint": np.full(x.size, 30.0)}
    test = {"q": 0.25 * x, "qd": np.r_[x[::2], np.nan], "torque_load": -1e5 * np.abs(x)}
    cov = held_out_coverage(train, test)
    assert cov["q"]["fraction"] == pytest.approx(0.25, abs=1e-9)
    assert cov["q"]["training"] == pytest.approx([-1.96, 1.96])
    assert cov["q"]["unit"] == "rad"
    assert cov["qd"]["fraction"] == pytest.approx(1.0, abs=0.01)    # a NaN is not a range
    # the load enters as its magnitude: one sign of the load covers |τ_L| whole
    assert cov["abs_torque_load"]["fraction"] == pytest.approx(1.0, abs=0.01)
    assert cov["abs_torque_load"]["unit"] == "N·m"
    # a constant temperature has no range to cover; a channel only one set holds is left out
    assert "temp_joint" not in cov
    assert set(held_out_coverage({"q": x}, {"qd": x})) == set()
    # held-out runs outside the training range cover none of it
    assert held_out_coverage({"q": x}, {"q": x + 10.0})["q"]["fraction"] == 0.0


def test_the_summary_clause_names_only_the_inputs_short_of_half():
    cov = {"q": {"training": [-2.2, 2.2], "held_out": [-0.8, 0.1], "fraction": 0.2045,
                 "unit": "rad"},
           "qd": {"training": [-0.03, 0.03], "held_out": [-0.03, 0.03], "fraction": 1.0,
                  "unit": "rad/s"},
           "abs_torque_load": {"training": [0.0, 1.2e5], "held_out": [0.0, 5.9e4],
                               "fraction": 0.4996, "unit": "N·m"}}
    assert short_coverage(cov) == ["q", "abs_torque_load"]
    note = coverage_note(cov)
    assert "20% of the training runs' range of q (-0.8 to 0.1 of -2.2 to 2.2 rad)" in note
    # rounded down: a share under the cut never prints as the cut
    assert "49% of the training runs' range of |torque_load|" in note
    assert "qd" not in note and "cannot show in the held-out test" in note
    assert coverage_note({k: cov[k] for k in ("qd",)}) == ""


def test_a_split_whose_held_out_runs_stay_near_the_zero_is_flagged():
    """Rig K's 4 + 2 campaign as the harness splits it: the held-out runs never reach the
    angles of the training run at 3000 r/min; the verdict's summary says so, in the JSON's
    terms. Split the same six runs so that the held-out runs are the two that travel furthest,
    and nothing is flagged on the angle."""
    train, test, _ = simulate_campaign(RIG_K_FEW, 21)
    rep = diagnose(train, test, "eq4", transmission="eq5")
    v = rep["verdict"]
    cov = v["held_out_coverage"]
    assert {"q", "qd", "abs_torque_load"} <= set(cov)
    assert cov["q"]["fraction"] < 0.5
    assert "range of q" in v["summary"] and "q" in short_coverage(cov)
    text = format_text(rep)           # `rig diagnose` without --json: every share, one line
    assert (f"held-out runs' share of the training runs' range: q "
            f"{int(100 * cov['q']['fraction'])}%, qd ") in text
    assert f"verdict: {v['summary']}" in text

    runs = train + test
    travel = [float(np.ptp(r.samples["q"].to_numpy())) for r in runs]
    far = sorted(range(len(runs)), key=lambda i: -travel[i])[:2]
    rep2 = diagnose([r for i, r in enumerate(runs) if i not in far],
                    [runs[i] for i in far], "eq4", transmission="eq5")
    cov2 = rep2["verdict"]["held_out_coverage"]
    assert cov2["q"]["fraction"] >= 0.5
    assert "range of q" not in rep2["verdict"]["summary"]
