"""A gear ripple is named only where it repeats (estimator.diagnosis_candidates.ripple_shown):
its held-out gain must be significant on the runs that each span at least
DiagnosisOptions.ripple_min_periods of its periods. On a run covering less, a sine of the angle
is a smooth function of it, and whatever drifts in time over a slow run fits it as well as a
ripple would: rig U at 250 Hz, nothing withheld, named a ripple of order 19 on the output law
beside 72 of its 208 blind campaigns; its slow runs cover 0.08–0.2 rad, under one period."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from commands.independent_harness import VARIANTS, simulate_campaign
from estimator.diagnosis import diagnose
from estimator.diagnosis_candidates import ripple_shown
from estimator.diagnosis_options import DiagnosisOptions
from estimator.diagnosis_stats import block_ids, covering_runs

TRAVEL = (0.2, 1.9, 0.13, 1.3, 1.9, 0.13, 0.08, 0.08, 0.2, 1.9, 1.3, 0.09)
"""Travel [rad] of each of 12 runs, as in a campaign of slow, fast and trajectory runs; the
last four are held out."""


def _held_out(residual, fitted, seed: int = 0) -> tuple[dict, np.ndarray, np.ndarray,
                                                         np.ndarray]:
    """The 4 held-out runs (2000 samples each, 70 s), started from the home position q = 0 in
    alternating directions, travelling TRAVEL[8:] (steadily, or back and forth on a 20 s
    trajectory below 0.1 rad): signals (q, run), the current model's residual residual(q, t)
    [N·m] plus white noise of 20 N·m, the residual after a candidate whose fit is fitted(q, t),
    and the held-out blocks."""
    rng = np.random.default_rng(seed)
    a, e, f, run, ts = [], [], [], [], []
    for r, span in enumerate(TRAVEL[8:], start=8):
        t = np.linspace(0.0, 70.0, 2000)
        d = 1.0 if r % 2 == 0 else -1.0
        q = (d * span * 0.5 * (1.0 - np.cos(2.0 * np.pi * t / 20.0)) if span < 0.1
             else d * span * t / 70.0)
        a.append(q)
        e.append(residual(q, t) + 20.0 * rng.standard_normal(t.size))
        f.append(fitted(q, t))
        run.append(np.full(t.size, r))
        ts.append(t)
    a, e, f, run, tt = map(np.concatenate, (a, e, f, run, ts))
    return {"q": a, "t": tt, "run": run}, e, e - f, block_ids(run, 45)


def _shown(residual, fitted, order: float) -> dict:
    te, e_cur, e_new, blocks = _held_out(residual, fitted)
    cur = SimpleNamespace(e_test=e_cur)
    new = SimpleNamespace(e_test=e_new, shape={"order": order})
    return ripple_shown(cur, new, te, blocks, DiagnosisOptions())


def test_a_run_covers_a_ripple_when_its_own_travel_spans_the_periods() -> None:
    te, _, _, _ = _held_out(lambda q, t: 0.0 * q, lambda q, t: 0.0 * q)
    keep = covering_runs(te["run"], te["t"], te["q"], 19.0, 2.0)
    # order 19: two periods are 0.66 rad; of the held-out runs only the two fast ones sweep
    # that; the trajectory run sweeps its 0.09 rad seven times (0.63 rad: 4 periods of order
    # 40, 1.9 of order 19)
    assert sorted(np.unique(te["run"][keep])) == [9, 10]
    assert sorted(np.unique(te["run"][covering_runs(te["run"], te["t"], te["q"], 40.0,
                                                    2.0)])) == [9, 10, 11]
    assert not covering_runs(te["run"], te["t"], te["q"], 2.0, 2.0).any()
    assert covering_runs(te["run"], te["t"], te["q"], 500.0, 2.0).all()


def test_an_encoder_dithering_at_rest_sweeps_no_path() -> None:
    t = np.arange(0.0, 60.0, 0.01)
    step = np.deg2rad(0.02)
    q = step * (np.random.default_rng(1).random(t.size) < 0.5)     # toggles between two steps
    run = np.zeros(t.size, dtype=int)
    # sample to sample it sweeps 3000 steps (1 rad); its half-second means barely move
    assert np.abs(np.diff(q)).sum() > 0.9
    assert not covering_runs(run, t, q, 20.0, 2.0).any()


def test_a_mesh_ripple_shows_on_the_runs_that_repeat_it() -> None:
    ripple = lambda q, t: 60.0 * np.sin(48.0 * q + 0.4)          # noqa: E731
    ev = _shown(ripple, ripple, 48.0)
    assert ev["shown"] and ev["runs"] == 3 and ev["angle"] == "q"
    assert ev["shrinkage"] > 0.5 and ev["z"] > 10.0


def test_what_drifts_in_time_over_slow_runs_is_no_ripple() -> None:
    # the current residual settles in time within each run; a fit of order 19 took that
    # settling from the slow runs (over 0.1–0.2 rad it is smooth in q) and carries a sine of
    # 19·q to the fast runs, where the settling is not a sine of the angle
    drift = lambda q, t: 80.0 * np.tanh((t - 35.0) / 15.0)       # noqa: E731
    fitted = lambda q, t: 80.0 * np.sin(19.0 * q - 1.9)          # noqa: E731
    ev = _shown(drift, fitted, 19.0)
    assert ev["runs"] == 2 and not ev["shown"] and ev["z"] < 3.0
    # on the slow held-out run alone (0.2 rad in 70 s) the fit does help: there the sine is a
    # smooth function of q, and q a linear function of time
    te, e_cur, e_new, _ = _held_out(drift, fitted)
    slow = te["run"] == 8
    assert np.mean(e_new[slow] ** 2) < 0.8 * np.mean(e_cur[slow] ** 2)
    # an order no held-out run spans twice has no evidence at all
    ev = _shown(drift, lambda q, t: 30.0 * np.sin(2.0 * q), 2.0)
    assert ev["runs"] == 0 and ev["z"] is None and not ev["shown"]


def _training(ripple_in_training: bool, seed: int = 3) -> tuple[dict, SimpleNamespace,
                                                                    SimpleNamespace]:
    """8 training runs (1500 samples each, 60 s) sweeping the motor angle u over 40 rad at
    alternating directions; their torque is a slow misfit that differs from run to run, plus
    white noise of 20 N·m, plus (ripple_in_training) a ripple of 458 per revolution of u. The
    current model is a constant; the candidate adds the sine and cosine of 458·u."""
    rng = np.random.default_rng(seed)
    u, y, run, ts = [], [], [], []
    for r in range(8):
        t = np.linspace(0.0, 60.0, 1500)
        d = 1.0 if r % 2 == 0 else -1.0
        uu = d * 40.0 * t / 60.0
        yy = 50.0 * rng.standard_normal() * np.tanh((t - 30.0) / 10.0)
        yy = yy + 20.0 * rng.standard_normal(t.size)
        if ripple_in_training:
            yy = yy + 30.0 * np.sin(458.0 * uu + 0.7)
        u.append(uu), y.append(yy), run.append(np.full(t.size, r)), ts.append(t)
    u, y, run, tt = map(np.concatenate, (u, y, run, ts))
    tr = {"u": u, "t": tt, "run": run, "y": y}
    one = lambda d: np.ones((d["u"].size, 1))                    # noqa: E731
    sines = lambda d: np.column_stack([one(d), np.sin(458.0 * d["u"]),   # noqa: E731
                                       np.cos(458.0 * d["u"])])
    cur = SimpleNamespace(model=SimpleNamespace(design=one, target=lambda d: d["y"]))
    new = SimpleNamespace(model=SimpleNamespace(design=sines, target=lambda d: d["y"]),
                          shape={"order": 458.0, "motor": 1.0})
    return tr, cur, new


def test_a_ripple_the_held_out_runs_show_must_repeat_in_the_training_runs() -> None:
    # the held-out runs (4 × 2000 samples, u over 40 rad) show a gain of order 458 on u: a
    # ripple there, or an order whose sine followed a misfit those runs share
    t = np.linspace(0.0, 70.0, 2000)
    te = {"u": np.concatenate([(1.0 if r % 2 else -1.0) * 40.0 * t / 70.0 for r in range(4)]),
          "t": np.tile(t, 4), "run": np.repeat(np.arange(8, 12), t.size)}
    rng = np.random.default_rng(5)
    e_new = 20.0 * rng.standard_normal(te["u"].size)
    e_cur = e_new + 30.0 * np.sin(458.0 * te["u"] + 0.7)
    blocks = block_ids(te["run"], 45)
    opt = DiagnosisOptions(min_shrinkage=0.04)
    for in_training, shown in ((True, True), (False, False)):
        tr, cur, new = _training(in_training)
        cur.e_test, new.e_test = e_cur, e_new
        ev = ripple_shown(cur, new, te, blocks, opt, tr)
        assert ev["angle"] == "u" and ev["runs"] == 4 and ev["training_runs"] == 8
        assert ev["shrinkage"] > 0.3 and ev["z"] > 10.0          # the held-out evidence alone
        assert (ev["shrinkage_training"] >= 0.04) is shown and ev["shown"] is shown
    # without the training runs the held-out evidence decides, as before
    ev = ripple_shown(cur, new, te, blocks, opt)
    assert ev["shown"] and ev["shrinkage_training"] is None


@pytest.mark.slow
@pytest.mark.parametrize("seed", [5101, 5102])
def test_own_emulator_elastic_nominal_names_no_ripple_its_training_runs_do_not_show(
        seed: int) -> None:
    """The own emulator's elastic world, nothing injected, scoring seeds 5101–5102 (rig X's
    quick score, docs/diagnosis.md): the twist–torque law's best ripple, of order 458 (150)
    on u, shrank the held-out runs by 0.048 (0.043) at z 3.2 (3.0), over the law's 0.04, and
    was named; the training runs, each predicted from the others, shrank by 0.005 (0.009)."""
    from commands import diagnosis_harness as own
    effects, tx = own.world(dict(own.ELASTIC))
    train, test = own.simulate_campaign(effects, seed)
    rep = diagnose(train, test, "eq4", transmission=tx)
    assert rep["verdict"]["status"] == "none" and not rep["verdict"]["effects"]
    ev = [r["ripple"] for r in rep["transmission"]["rejected"]
          if r["effect"] == "gear_ripple" and "ripple" in r]
    assert ev and ev[0]["angle"] == "u" and not ev[0]["shown"]
    assert ev[0]["shrinkage"] >= 0.04 > ev[0]["shrinkage_training"]


def test_the_periods_a_run_must_span_are_checked() -> None:
    for bad in (0.5, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="ripple_min_periods"):
            DiagnosisOptions(ripple_min_periods=bad)


@pytest.mark.slow
def test_rig_u_nominal_names_no_ripple_its_fast_runs_do_not_show() -> None:
    """Rig U at 250 Hz, nothing withheld, seed 4801 (scored blind before this rule): the output
    law's best ripple, order 19, had a held-out shrinkage of 0.068 (z 4.8) over all runs, none
    on the runs that span two of its periods; it was named, and is now rejected."""
    v = next(v for v in VARIANTS if v.rig == "rig_u" and not v.few_runs)
    train, test, _ = simulate_campaign(v, 4801, {})
    rep = diagnose(train, test, "eq4", transmission="eq5")
    assert "gear_ripple" not in rep["verdict"]["effects"]
    ev = [r["ripple"] for r in rep["rejected"] if r["effect"] == "gear_ripple" and "ripple" in r]
    assert ev and ev[0]["order"] == 19.0 and not ev[0]["shown"]
