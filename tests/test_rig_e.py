"""Validation rig E: nominal runs, effect injection, determinism, sampling and metadata."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from validation_rigs import rig_e

VOCABULARY = {"stribeck", "temperature_friction", "load_dependent_friction",
              "asymmetric_friction", "gear_ripple", "backlash", "hysteresis", "torque_offset",
              "time_delay"}
SAMPLE_COLUMNS = {"t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "phase",
                  "i_m1", "i_m2", "i_m3", "w_m1", "w_m2", "w_m3"}
TRUTH_COLUMNS = {"t", "q", "qd", "u", "ud", "twist", "torque", "torque_load", "torque_joint"}
FAST = rig_e.SensorSpec(sample_rate_hz=50.0)


def _s1(effects: dict, **kw) -> rig_e.RigRun:
    return rig_e.simulate_run(1, 300.0, 1, 25.0, effects, seed=kw.pop("seed", 11), sensors=FAST,
                              **kw)


def _s3(effects: dict, **kw) -> rig_e.RigRun:
    return rig_e.simulate_run(3, None, -1, 35.0, effects, seed=kw.pop("seed", 11), sensors=FAST,
                              periods=1, **kw)


def test_vocabulary_and_out_of_vocabulary_names() -> None:
    assert VOCABULARY <= set(rig_e.EFFECT_FORMS)
    assert len(rig_e.OUT_OF_VOCABULARY) >= 4
    assert set(rig_e.OUT_OF_VOCABULARY) <= set(rig_e.EFFECT_FORMS)
    assert not set(rig_e.OUT_OF_VOCABULARY) & VOCABULARY
    assert set(rig_e.EFFECT_FORMS) == VOCABULARY | set(rig_e.OUT_OF_VOCABULARY)
    for name in VOCABULARY:
        forms = rig_e.EFFECT_FORMS[name]
        assert 2 <= len(forms) <= 4 and len(set(forms)) == len(forms), name


def test_columns_phases_and_nominal_physics() -> None:
    run = _s1({})
    assert SAMPLE_COLUMNS <= set(run.samples.columns)
    assert TRUTH_COLUMNS <= set(run.truth.columns)
    assert set(run.samples["phase"]) == {"idle", "load", "unload"}
    assert set(_s3({}).samples["phase"]) == {"idle", "excite"}
    tr = run.truth
    # the dynamometer reaches the rated load within the platform's ±2 kN·m, and the twist at
    # the rated load is about half a degree
    assert abs(tr["torque_load"].max() - 120e3) < 2e3
    assert 0.3 < np.degrees(tr["twist"].max()) < 0.7
    np.testing.assert_allclose(tr["twist"], tr["u"] - tr["q"], atol=1e-15)
    # the encoder reading is the truth rounded to its step
    step = np.radians(FAST.encoder_res_deg)
    assert np.max(np.abs(run.samples["q"] - tr["q"])) <= step / 2 + 1e-12


def test_zero_scale_is_bit_identical_to_nominal() -> None:
    nominal = _s3({}, run=2)
    zero = {name: {"form": forms[-1], "scale": 0.0} for name, forms in rig_e.EFFECT_FORMS.items()}
    again = _s3(zero, run=2)
    pd.testing.assert_frame_equal(nominal.samples, again.samples, check_exact=True)
    pd.testing.assert_frame_equal(nominal.truth, again.truth, check_exact=True)


@pytest.mark.parametrize("name,form", [(n, f) for n, forms in rig_e.EFFECT_FORMS.items()
                                       for f in forms])
def test_each_effect_form_changes_a_reading(name: str, form: str) -> None:
    changed = []
    for make in (_s1, _s3):
        nominal = make({}).truth
        hit = make({name: {"form": form, "scale": 1.0}}).truth
        changed.append(max(np.max(np.abs(hit["torque"] - nominal["torque"])) / 50.0,
                           np.max(np.abs(hit["torque_load"] - nominal["torque_load"])) / 50.0,
                           np.max(np.abs(hit["twist"] - nominal["twist"])) / 5e-6))
    assert max(changed) > 1.0, (name, form, changed)


def test_effect_size_grows_with_scale() -> None:
    nominal = _s1({}).truth["torque"]
    sizes = [np.sqrt(np.mean((_s1({"torque_offset": {"form": "linear_drift", "scale": s}})
                              .truth["torque"] - nominal) ** 2)) for s in (0.5, 1.0, 2.0)]
    np.testing.assert_allclose(np.array(sizes) / sizes[0], [1.0, 2.0, 4.0], rtol=1e-9)
    fr = [np.sqrt(np.mean((_s1({"load_dependent_friction": {"form": "coulomb_linear", "scale": s}})
                           .truth["torque"] - nominal) ** 2)) for s in (0.5, 1.0)]
    assert 1.7 < fr[1] / fr[0] < 2.3


def test_deterministic_by_seed_and_run() -> None:
    a = _s3({"backlash": {"form": "sharp", "scale": 1.0}}, seed=5, run=1)
    b = _s3({"backlash": {"form": "sharp", "scale": 1.0}}, seed=5, run=1)
    pd.testing.assert_frame_equal(a.samples, b.samples, check_exact=True)
    c = _s3({"backlash": {"form": "sharp", "scale": 1.0}}, seed=5, run=2)
    assert not np.array_equal(a.samples["torque"].to_numpy(), c.samples["torque"].to_numpy())


def _stiffness_fit(run: rig_e.RigRun) -> np.ndarray:
    tr = run.truth
    sel = (run.samples["phase"] == "load").to_numpy() & (tr["twist"].to_numpy() > 1e-3)
    d = tr["twist"].to_numpy()[sel]
    A = np.column_stack([d, d ** 3])
    coef, *_ = np.linalg.lstsq(A, tr["torque_joint"].to_numpy()[sel], rcond=None)
    return coef


def test_same_campaign_same_rig_other_campaign_other_rig() -> None:
    k_a0 = _stiffness_fit(_s1({}, seed=21, run=0))
    k_a1 = _stiffness_fit(_s1({}, seed=21, run=1))
    k_b0 = _stiffness_fit(_s1({}, seed=22, run=0))
    assert abs(k_a1[0] / k_a0[0] - 1.0) < 1e-3
    assert abs(k_b0[0] / k_a0[0] - 1.0) > 2e-3
    # the runs of one campaign differ only by their noise and the dynamometer's load error
    r0, r1 = _s1({}, seed=21, run=0), _s1({}, seed=21, run=1)
    assert not np.array_equal(r0.samples["torque"].to_numpy(), r1.samples["torque"].to_numpy())


@pytest.mark.parametrize("fs", [10.0, 1000.0])
def test_sample_counts(fs: float) -> None:
    sensors = rig_e.SensorSpec(sample_rate_hz=fs)
    run = rig_e.simulate_run(3, None, 1, 20.0, {}, seed=1, sensors=sensors, periods=1)
    duration = run.meta["duration_s"]
    assert duration == pytest.approx(26.0)
    assert len(run.samples) == len(run.truth) == int(round(duration * fs))
    np.testing.assert_allclose(np.diff(run.samples["t"]), 1.0 / fs, rtol=1e-9)
    assert run.samples["t"].iloc[0] == 0.0
    s2 = rig_e.simulate_run(2, 3000.0, 1, 20.0, {}, seed=1, sensors=sensors)
    assert len(s2.samples) == int(round(60.0 * fs))


def test_meta_and_sensor_statement() -> None:
    sensors = rig_e.SensorSpec(sample_rate_hz=200.0, encoder_res_deg=0.01, torque_noise=300.0,
                               torque_lag_s=0.01)
    run = rig_e.simulate_run(2, 300.0, -1, 40.0, {}, seed=3, sensors=sensors)
    meta = run.meta
    for key, value in {"scheme": 2, "motor_speed_rpm": 300.0, "direction": -1,
                       "reduction": 11000, "rig": "validation-rig-E", "source": "emulator",
                       "sample_rate_hz": 200.0, "duration_s": 60.0,
                       "temp_joint_c": 40.0}.items():
        assert meta[key] == value, key
    sens = meta["sensors"]
    assert sens["q"]["resolution"] == pytest.approx(np.radians(0.01))
    assert 0.0 < sens["u"]["resolution"] < 1e-7
    assert sens["torque"]["noise_sd"] == 300.0
    assert sens["torque"]["lag_s"] == pytest.approx(0.01 + 0.002)
    assert sens["torque_load"]["noise_sd"] > 0.0
    assert sens["temp_joint"]["resolution"] > 0.0
    # the stated noise is the noise the reading carries
    resid = run.samples["torque"] - run.truth["torque"]
    assert 270.0 < resid.std() < 330.0
    assert rig_e.simulate_run(3, None, 1, 20.0, {}, seed=3, sensors=sensors,
                              periods=1).meta["motor_speed_rpm"] is None


def test_unknown_effect_or_form_raises() -> None:
    with pytest.raises(ValueError):
        _s3({"no_such_effect": {"form": "x", "scale": 1.0}})
    with pytest.raises(ValueError):
        _s3({"stribeck": {"form": "no_such_form", "scale": 1.0}})
    with pytest.raises(ValueError):
        rig_e.simulate_run(4, 300.0, 1, 20.0, {}, seed=1, sensors=FAST)
