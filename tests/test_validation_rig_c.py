"""Validation rig C (validation_rigs/rig_c.py): the interface the scoring harness calls, its
determinism, the exactness of scale 0, that every effect form acts, the nominal physics (Eq. 4
on the output side in steady sliding, the elastic twist law) and that the metadata states what
the sensors really did."""

from __future__ import annotations

import math

import numpy as np
import pytest

from validation_rigs import rig_c as R

FAST = R.SensorSpec(sample_rate_hz=20.0)
SAMPLE_COLUMNS = ["t", "q", "qd", "u", "ud", "torsion", "torque", "torque_load", "temp_joint",
                  "phase"]
TRUTH_COLUMNS = ["t", "q", "qd", "torque", "torque_load", "twist"]


def _run(scheme: int = 3, rpm: float | None = None, effects: dict | None = None, **kw) -> R.RigRun:
    kw.setdefault("sensors", FAST)
    if scheme == 3:
        kw.setdefault("periods", 1)
    return R.simulate_run(scheme, rpm, kw.pop("direction", 1), kw.pop("temp", 40.0),
                          effects=effects, **kw)


def _eq4_regressors(tr) -> np.ndarray:
    return np.column_stack([tr.qdd, np.sin(tr.q), np.cos(tr.q), tr.qd, np.sign(tr.qd)])


def _sliding(tr) -> np.ndarray:
    """Samples in steady sliding: well away from zero speed."""
    return (tr.qd.abs() > 0.5 * tr.qd.abs().max()).to_numpy()


def test_interface_columns_and_meta() -> None:
    assert R.SEED_IS_CAMPAIGN is True
    required = {"stribeck", "temperature_friction", "load_dependent_friction",
                "asymmetric_friction", "gear_ripple", "backlash", "hysteresis", "torque_offset",
                "time_delay", "periodic_disturbance", "position_stiffness", "sensor_drift",
                "second_resonance"}
    assert required <= set(R.EFFECT_FORMS)
    assert set(R.OUT_OF_VOCABULARY) <= set(R.EFFECT_FORMS)
    assert len(R.OUT_OF_VOCABULARY) >= 5
    assert {"exponential", "gaussian", "lorentzian"} <= set(R.EFFECT_FORMS["stribeck"])
    assert len(R.EFFECT_FORMS["stribeck"]) >= 4
    assert len(R.EFFECT_FORMS["hysteresis"]) >= 3
    assert len(R.EFFECT_FORMS["load_dependent_friction"]) >= 3
    for name in ("asymmetric_friction", "gear_ripple", "backlash", "torque_offset", "time_delay"):
        assert len(R.EFFECT_FORMS[name]) >= 2

    for scheme, rpm in ((1, 300.0), (2, 3000.0), (3, None)):
        run = _run(scheme, rpm)
        assert isinstance(run, R.RigRun)
        assert list(run.samples.columns[:len(SAMPLE_COLUMNS)]) == SAMPLE_COLUMNS
        assert {f"i_m{k}" for k in (1, 2, 3)} <= set(run.samples.columns)
        assert set(TRUTH_COLUMNS) <= set(run.truth.columns)
        assert len(run.truth) == len(run.samples)
        t = run.samples.t.to_numpy()
        assert np.all(np.diff(t) > 0)
        np.testing.assert_allclose(np.diff(t), 1.0 / FAST.sample_rate_hz, rtol=1e-9)
        assert set(run.samples.phase) <= {"idle", "load", "hold", "unload", "excite"}
        numeric = run.samples.drop(columns="phase").to_numpy()
        assert np.isfinite(numeric).all() and np.isfinite(run.truth.to_numpy()).all()
        np.testing.assert_allclose(run.samples.torsion, run.samples.q - run.samples.u)
        meta = run.meta
        assert meta["scheme"] == scheme and meta["rig"] == "validation-rig-C"
        assert meta["source"] == "emulator" and meta["reduction"] == 11000
        assert meta["motor_speed_rpm"] == (None if scheme == 3 else rpm)
        assert meta["direction"] == 1 and meta["sample_rate_hz"] == FAST.sample_rate_hz
        assert meta["duration_s"] == pytest.approx(t[-1])
        assert set(meta["sensors"]) >= {"q", "u", "torque", "torque_load", "temp_joint"}
    durations = {s: _run(s, 300.0 if s < 3 else None, periods=2).meta["duration_s"]
                 for s in (1, 2, 3)}
    assert durations[1] == pytest.approx(100.0) and durations[2] == pytest.approx(60.0)
    assert durations[3] == pytest.approx(2 * 20.0 + 6.0)


def test_schemes_load_and_motion() -> None:
    one = _run(1, 3000.0, direction=-1).truth
    assert one.torque_load_true.max() == pytest.approx(120e3, abs=2e3)
    assert one.qd.min() == pytest.approx(-3000 * 2 * math.pi / 60 / 11000, rel=0.05)
    two = _run(2, 300.0)
    levels = two.truth.torque_load_true[two.samples.phase == "hold"].to_numpy()
    assert levels.max() == pytest.approx(120e3, abs=2e3)
    three = _run(3, None)
    assert three.truth.torque_load_true.abs().max() < 1.0
    assert np.ptp(three.truth.qd) > 0.02


@pytest.mark.parametrize("fs", [10.0, 300.0, 1000.0])
def test_sample_rates_on_the_grid(fs: float) -> None:
    run = _run(3, None, sensors=R.SensorSpec(sample_rate_hz=fs))
    t = run.samples.t.to_numpy()
    np.testing.assert_allclose(t, np.arange(t.size) / fs, atol=1e-9)


def test_determinism_and_streams() -> None:
    a = _run(1, 300.0, seed=4, run=2)
    b = _run(1, 300.0, seed=4, run=2)
    assert a.samples.equals(b.samples) and a.truth.equals(b.truth)
    c = _run(1, 300.0, seed=4, run=3)
    assert not np.allclose(a.samples.torque - a.truth.torque, c.samples.torque - c.truth.torque)
    # an effect does not move the noise: the same (seed, run) draws the same noise
    d = _run(1, 300.0, seed=4, run=2, effects={"torque_offset": {"form": "constant", "scale": 1}})
    noise_a = a.samples.torque - a.truth.torque
    noise_d = d.samples.torque - d.truth.torque
    step = a.meta["sensors"]["torque"]["adc_step"]
    assert np.abs(noise_a - noise_d).max() <= step + 1e-9


def test_same_campaign_same_rig_other_campaign_other_rig() -> None:
    """The rig's physics identified from truth (Eq. 4 and the twist law by least squares) is the
    same for two runs of one campaign and differs for another campaign's seed."""
    def identify(run: R.RigRun) -> np.ndarray:
        tr = run.truth
        m = _sliding(tr)
        eq4, *_ = np.linalg.lstsq(_eq4_regressors(tr)[m],
                                  (tr.torque_joint - tr.torque_load_true)[m], rcond=None)
        tw, *_ = np.linalg.lstsq(np.column_stack([tr.twist, tr.twist_rate]), tr.torque_joint,
                                 rcond=None)
        return np.concatenate([eq4, tw])

    p0 = identify(_run(3, None, seed=7, run=0, temp=20.0))
    p1 = identify(_run(3, None, seed=7, run=1, temp=55.0))
    p2 = identify(_run(3, None, seed=8, run=0, temp=20.0))
    np.testing.assert_allclose(p0, p1, rtol=1e-6)
    assert np.max(np.abs(p2 / p0 - 1.0)) > 1e-3
    np.testing.assert_array_equal(R.rig_parameters(7), R.rig_parameters(7))


def test_nominal_obeys_eq4_in_steady_sliding_and_elastic_twist() -> None:
    seed = 2
    P = R.rig_parameters(seed)
    true = np.array([P[R.P_I], P[R.P_G] * P[R.P_MRX], P[R.P_G] * P[R.P_MRY], P[R.P_FV],
                     P[R.P_FC]])
    for scheme, rpm, direction in ((1, 3000.0, 1), (1, 300.0, -1), (2, 3000.0, -1), (3, None, 1)):
        tr = _run(scheme, rpm, seed=seed, direction=direction).truth
        m = _sliding(tr)
        assert m.sum() > 50
        resid = (tr.torque_joint - tr.torque_load_true).to_numpy() - _eq4_regressors(tr) @ true
        assert np.abs(resid[m]).max() < 1.0            # N·m, of ~120 kN·m
        elastic = tr.torque_joint - P[R.P_K] * tr.twist - P[R.P_D] * tr.twist_rate
        assert np.abs(elastic).max() < 1e-3
        # the presliding (Maxwell-slip) departure exists near reversals/starts: not pure Coulomb
    tr3 = _run(3, None, seed=seed).truth
    resid3 = (tr3.torque_joint - tr3.torque_load_true).to_numpy() - _eq4_regressors(tr3) @ true
    assert np.abs(resid3).max() > 100.0


ALL_FORMS = [(name, form) for name, forms in R.EFFECT_FORMS.items() for form in forms]


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_scale_zero_is_exactly_nominal(name: str, form: str) -> None:
    base = _run(3, None, seed=1)
    zero = _run(3, None, seed=1, effects={name: {"form": form, "scale": 0.0}})
    assert zero.samples.equals(base.samples) and zero.truth.equals(base.truth)


_BASE_CACHE: dict[str, R.RigRun] = {}


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_form_changes_the_truth(name: str, form: str) -> None:
    if "base" not in _BASE_CACHE:
        _BASE_CACHE["base"] = _run(1, 3000.0, seed=1, temp=55.0)
    base = _BASE_CACHE["base"].truth
    tr = _run(1, 3000.0, seed=1, temp=55.0, effects={name: {"form": form, "scale": 1.0}}).truth
    changed = max(np.abs(tr.torque - base.torque).max(),
                  R.RATED_TORQUE * np.abs(tr.twist - base.twist).max() / math.radians(0.5),
                  np.abs(tr.torque_load - base.torque_load).max())
    assert changed > 10.0, f"{name}/{form} changes torque/twist/load by only {changed:.3g} N·m"
    assert changed < 0.2 * R.RATED_TORQUE


def test_magnitudes_are_linear_in_scale() -> None:
    base = _run(3, None, seed=1).truth
    for s in (0.5, 2.0):
        offset = {"torque_offset": {"form": "constant", "scale": s}}
        tr = _run(3, None, seed=1, effects=offset).truth
        np.testing.assert_allclose(tr.torque - base.torque, 2000.0 * s, atol=1e-6)
    small = _run(3, None, seed=1, effects={"backlash": {"form": "sharp", "scale": 0.01}}).truth
    big = _run(3, None, seed=1, effects={"backlash": {"form": "sharp", "scale": 1.0}}).truth
    assert np.abs(big.twist - base.twist).max() > 20 * np.abs(small.twist - base.twist).max()


def test_unknown_effect_or_form_raises() -> None:
    with pytest.raises(ValueError, match="unknown effect"):
        _run(3, None, effects={"cogging": {"form": "x", "scale": 1.0}})
    with pytest.raises(ValueError, match="unknown form"):
        _run(3, None, effects={"stribeck": {"form": "cubic", "scale": 1.0}})
    with pytest.raises(ValueError):
        _run(4, None)
    with pytest.raises(ValueError):
        _run(1, None)
    with pytest.raises(ValueError):
        _run(3, None, direction=0)


def test_meta_sensors_state_what_was_simulated() -> None:
    spec = R.SensorSpec(sample_rate_hz=200.0, encoder_res_deg=0.01, torque_noise=300.0,
                        load_noise=80.0, torque_lag_s=0.0)
    run = _run(1, 300.0, sensors=spec, temp=33.0)
    sens = run.meta["sensors"]
    s, tr = run.samples, run.truth
    res = sens["q"]["resolution"]
    assert res == pytest.approx(math.radians(0.01))
    np.testing.assert_allclose(s.q / res, np.round(s.q / res), atol=1e-6)
    assert np.abs(s.q - tr.q).max() <= 0.5 * res + 1e-12
    assert np.abs(s.u - tr.u).max() <= 0.5 * sens["u"]["resolution"] + 1e-15
    assert np.std(s.torque - tr.torque) == pytest.approx(sens["torque"]["noise_sd"], rel=0.05)
    assert sens["torque"]["noise_sd"] >= 300.0
    assert np.std(s.torque_load - tr.torque_load) == pytest.approx(
        sens["torque_load"]["noise_sd"], rel=0.05)
    assert sens["temp_joint"]["resolution"] == 0.1
    np.testing.assert_allclose(s.temp_joint * 10, np.round(s.temp_joint * 10), atol=1e-9)
    assert s.temp_joint.iloc[0] == pytest.approx(33.0, abs=0.05)
    # the stated lag grows by the transport lag asked for, and the truth reading moves with it
    lagged = _run(1, 300.0, sensors=R.SensorSpec(sample_rate_hz=200.0, torque_lag_s=0.05))
    lag = lagged.meta["sensors"]["torque"]["lag_s"]
    assert lag == pytest.approx(sens["torque"]["lag_s"] + 0.05)
    assert not np.allclose(lagged.truth.torque, _run(1, 300.0, sensors=R.SensorSpec(
        sample_rate_hz=200.0)).truth.torque)


def test_temperature_varies_between_and_drifts_within_runs() -> None:
    cold = _run(1, 3000.0, temp=15.0).truth.temp_joint
    hot = _run(1, 3000.0, temp=60.0).truth.temp_joint
    assert cold.iloc[0] == pytest.approx(15.0) and hot.iloc[0] == pytest.approx(60.0)
    assert abs(hot.iloc[-1] - hot.iloc[0]) > 0.3
