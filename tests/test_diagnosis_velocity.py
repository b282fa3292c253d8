"""The output balance's motion readings: which velocity it reads (estimator.diagnosis_inputs.
velocity_source), the stops the transient mask sees in the angle when the velocity reading
smooths them over (transient_mask), and the drive-train ringing seen as band power
(band_excess)."""

from __future__ import annotations

import numpy as np
import pytest

from core.run import RunData
from estimator.diagnosis import diagnose
from estimator.diagnosis_inputs import output_encoder_step, transient_mask
from estimator.diagnosis_stats import band_excess


@pytest.fixture(scope="module")
def nominal():
    from commands.diagnosis_harness import simulate_campaign
    return simulate_campaign({}, 1)


def test_a_velocity_reading_that_agrees_with_the_angle_is_kept(nominal):
    rep = diagnose(*nominal, "eq4")
    assert rep["velocity"]["source"] == "measured", rep["velocity"]
    assert rep["verdict"]["status"] == "none", rep["verdict"]["summary"]


@pytest.fixture(scope="module")
def rig_i_few():
    """Rig I's 4 + 2-run campaign at 25 Hz, nothing withheld: its `qd` is a tracking loop's
    estimate on the output encoder, which lags the motion by ~0.1 s below 1 Hz while its sheet
    states no lag."""
    from commands.independent_harness import VARIANTS, simulate_campaign
    v = next(v for v in VARIANTS if v.rig == "rig_i" and v.few_runs)
    return simulate_campaign(v, 21)[:2]


def test_a_lagging_velocity_reading_is_replaced_by_the_angles_derivative(rig_i_few,
                                                                         monkeypatch):
    """Read as it is over the whole band, the lagging velocity leaves the nominal balance
    structured (`unexplained`); the law fitted on the output angle's derivative leaves the
    smaller training residual by more than 3 SE, so that one is read and the campaign is
    `none`."""
    import estimator.diagnosis as diagnosis
    rep = diagnose(*rig_i_few, "eq4")
    v = rep["velocity"]
    assert v["source"] == "output angle" and v["rmse_derived"] < v["rmse_measured"], v
    assert v["gain_z"] > 3.0, v
    assert rep["verdict"]["status"] == "none" and rep["verdict"]["effects"] == [], \
        rep["verdict"]["summary"]
    monkeypatch.setattr(diagnosis, "velocity_source", lambda runs, prep, *a, **k: (prep, None))
    monkeypatch.setattr(diagnosis, "below_drive_train_mode",
                        lambda runs, prep, *a, **k: (prep, None))
    as_read = diagnose(*rig_i_few, "eq4")
    assert as_read["verdict"]["status"] == "unexplained", as_read["verdict"]["summary"]


def _stall_sig(step: float) -> dict:
    """100 Hz, 10 s at 0.01 rad/s with a 0.15 s stop at 5 s, the angle rounded to `step`; the
    velocity reading never shows the stop (it is smoothed over, as an observer does)."""
    t = np.arange(0.0, 10.0, 0.01)
    q = 0.01 * np.where(t < 5.0, t, np.where(t < 5.15, 5.0, t - 0.15))
    q = step * np.round(q / step) if step > 0 else q
    return {"t": t, "q": q, "qd": np.full(t.size, 0.01), "run": np.zeros(t.size, dtype=int)}


def test_the_transient_mask_sees_a_stop_in_the_angle_that_the_velocity_misses():
    """The stop lies inside a motion (the mean speed over ±0.5 s stays at 85 % of the run's),
    so it is left out alone, like a stick of stick–slip."""
    sig = _stall_sig(1e-5)
    assert not transient_mask(sig, 0.5).any()
    m = transient_mask(sig, 0.5, angle_step=1e-5)
    t = sig["t"]
    assert m[(t > 5.02) & (t < 5.13)].all()
    assert not m[(t < 4.9) | (t > 5.25)].any()


def _stick_slip_sig() -> dict:
    """100 Hz, 30 s: at rest for 1 s, a ramp to 0.01 rad/s by 2 s, then steady sliding with a
    0.05 s stick every second from 4 to 10 s (the speed reading at 0 there), and from 16 s a
    reversal: the speed falls linearly through zero at 20 s to −0.01 rad/s at 24 s."""
    t = np.arange(0.0, 30.0, 0.01)
    v = np.clip(t - 1.0, 0.0, 1.0) * 0.01
    v = np.where(t >= 16.0, np.clip(0.01 * (20.0 - t) / 4.0, -0.01, 0.01), v)
    stick = (t >= 4.0) & (t < 10.0) & ((t % 1.0) < 0.05)
    v = np.where(stick, 0.0, v)
    q = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    return {"t": t, "q": q, "qd": v, "run": np.zeros(t.size, dtype=int)}


def test_the_transient_mask_leaves_a_stick_inside_a_motion_out_alone_and_a_rest_with_its_window():
    """A joint driven at a steady speed on a friction curve that falls with speed sticks and
    slips; the slips are the sliding a Stribeck curve is seen on. Leaving 0.5 s around every
    stick (the rule before) would take every sample between 3.5 and 10.5 s."""
    sig = _stick_slip_sig()
    t = sig["t"]
    m = transient_mask(sig, 0.5)
    stick = (t >= 4.0) & (t < 10.0) & ((t % 1.0) < 0.05)
    assert m[stick].all()
    between = (t >= 4.0) & (t < 10.0) & ((t % 1.0) > 0.15) & ((t % 1.0) < 0.9)
    assert not m[between].any()
    # the start from rest: the mean speed over ±0.5 s stays in the band until 0.81 s, and
    # 0.5 s more
    assert m[t < 1.3].all() and not m[(t > 1.35) & (t < 3.95)].any()
    # the reversal: the mean speed is in the band within 0.2 s of 20 s, and 0.5 s more
    assert m[(t > 19.32) & (t < 20.68)].all()
    assert not m[(t > 16.0) & (t < 19.28)].any() and not m[(t > 20.72) & (t < 24.0)].any()


def test_the_angle_criterion_does_not_call_steady_motion_a_stop():
    """Steady motion at 4 and 20 times the near-zero band (5 % of the top speed), read by a
    coarse encoder: its rounding alone must not read as a stop."""
    t = np.arange(0.0, 10.0, 0.01)
    for speed in (0.01, 0.002):
        q = 1e-4 * np.round(speed * t / 1e-4)
        sig = {"t": t, "q": q, "qd": np.full(t.size, 0.01), "run": np.zeros(t.size, dtype=int)}
        sig["qd"][:10] = 0.01              # top speed 0.01: the band is 5e-4 rad/s
        assert not transient_mask(sig, 0.5, angle_step=1e-4).any(), speed


def test_band_excess_is_one_for_white_noise_and_large_for_a_ringing():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 60.0, 0.01)
    run = np.repeat(np.arange(3), t.size // 3)
    white = rng.normal(0.0, 1.0, t.size)
    assert 0.8 < band_excess(white, t, run, 3.5, 10.5) < 1.25
    ringing = white + 2.0 * np.sin(2 * np.pi * (6.0 + 0.02 * t) * t)
    assert band_excess(ringing, t, run, 3.5, 10.5) > 2.0


def test_the_output_encoder_step_is_the_coarsest_stated_one(nominal):
    runs = list(nominal[0])
    assert output_encoder_step(runs) == pytest.approx(np.radians(0.01))
    bare = RunData(samples=runs[0].samples, meta={k: v for k, v in runs[0].meta.items()
                                                  if k != "sensors"})
    assert output_encoder_step(runs + [bare]) == 0.0


def test_the_velocity_choice_leaves_an_unreadable_velocity_to_the_laws_own_error(nominal):
    """A velocity channel with no finite sample: the choice steps aside (the law's own pooling
    then names the run and the channel), rather than raising from inside the choice."""
    from estimator.diagnosis_data import base_model
    from estimator.diagnosis_inputs import velocity_source
    from estimator.preprocess import PrepOptions
    runs = []
    for r in nominal[0]:
        s = r.samples.copy()
        s["qd"] = np.nan
        runs.append(RunData(samples=s, meta=dict(r.meta)))
    prep = PrepOptions()
    assert velocity_source(runs, prep, base_model("eq4"), 0.5, 3.0) == (prep, None)


@pytest.fixture(scope="module")
def rig_m_few():
    """Rig M's 4 + 2-run campaign at 60 Hz, nothing withheld: its `qd` is the output encoder's
    difference over 50 ms (stated: lag 25 ms, resolution the 0.008° step over the window,
    2.8·10⁻³ rad/s, a tenth of the top speed)."""
    from commands.independent_harness import VARIANTS, simulate_campaign
    v = next(v for v in VARIANTS if v.rig == "rig_m" and v.few_runs)
    return simulate_campaign(v, 2701)


def test_a_velocity_reading_with_a_stated_lag_is_compared_with_the_angle(rig_m_few):
    """The stated lag taken out of q̇ leaves its last samples missing; the comparison with the
    angle's derivative runs on the samples both have (it gave up when the two pools differed
    in length, on every run whose velocity reading states a lag)."""
    from estimator.diagnosis_data import base_model
    from estimator.diagnosis_inputs import lag_corrected, velocity_source
    from estimator.preprocess import PrepOptions
    train = [lag_corrected(r) for r in rig_m_few[0]]
    prep, found = velocity_source(train, PrepOptions(), base_model("eq4"), 0.5, 3.0)
    assert found is not None and found["source"] == "measured", found
    assert found["rmse_derived"] > found["rmse_measured"] > 0, found
    assert not prep.derive_velocity


def test_a_velocity_reading_that_cannot_carry_the_acceleration_cuts_the_band(rig_m_few,
                                                                           monkeypatch):
    """Over the whole band, q̈ differentiated from the stepping reading is mostly noise: the
    balance fits I at under a hundredth of the rig's, leaves the real I·q̈ in the residual, and
    names `time_delay` with nothing withheld. The inertia fitted over the band falls below the
    2 Hz fit's by far more than 3 SE, so the band is cut at 2 Hz: I is the rig's and the
    campaign is `none`."""
    import estimator.diagnosis as diagnosis
    train, test, raw = rig_m_few
    rep = diagnose(train, test, "eq4")
    mode = rep["drive_train_mode"]
    assert mode is not None and mode["reason"] == "inertia" and mode["cutoff_hz"] == 2.0, mode
    assert mode["inertia_in_band"] < 0.05 * mode["inertia"], mode
    rig_inertia = raw[0].params["I"]
    assert abs(rep["baseline"]["params"]["I_xx"]["value"] / rig_inertia - 1.0) < 0.2
    assert rep["verdict"]["status"] == "none", rep["verdict"]["summary"]
    monkeypatch.setattr(diagnosis, "below_drive_train_mode",
                        lambda runs, prep, *a, **k: (prep, None))
    whole_band = diagnose(train, test, "eq4")
    assert "time_delay" in whole_band["verdict"]["effects"], whole_band["verdict"]["summary"]
    assert whole_band["baseline"]["params"]["I_xx"]["value"] < 0.05 * rig_inertia
