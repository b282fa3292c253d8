"""Tests of validation rig F (independent J4 platform emulator): interface, physics, effects."""
from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np
import pandas as pd
import pytest

from validation_rigs import rig_f as R

FS = 50.0
SPEC = R.SensorSpec(sample_rate_hz=FS)
K_SERIES = 1.4e7  # N m/rad, nominal series stiffness of the two stages
SAMPLE_COLS = ["t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "phase",
               "i_m1", "i_m2", "i_m3", "w_m1", "w_m2", "w_m3"]
TRUTH_COLS = ["t", "q", "qd", "u", "ud", "twist", "torque", "torque_load", "torque_joint", "temp_joint"]

TRANSMISSION = {"gear_ripple", "backlash", "hysteresis", "position_dependent_stiffness"}
OUTPUT_SIDE = {"stribeck", "temperature_friction", "load_dependent_friction", "asymmetric_friction",
               "periodic_disturbance"}
TORQUE_READING = {"torque_offset", "time_delay"}
NEEDS_LOAD = {"load_dependent_friction", "position_dependent_stiffness", "load_cell_drift", "encoder_scale_error"}


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(np.asarray(x, dtype=float)))))


def _run(scheme: int, effects: dict | None = None, *, seed: int = 5, run: int = 0,
         temp: float = 10.0, direction: int = 1, spec: R.SensorSpec = SPEC) -> R.RigRun:
    rpm = None if scheme == 3 else 3000.0
    return R.simulate_run(scheme, rpm, direction, temp, effects or {}, seed=seed, sensors=spec,
                          periods=1, run=run)


_CACHE: dict = {}


def _nominal(scheme: int) -> R.RigRun:
    if scheme not in _CACHE:
        _CACHE[scheme] = _run(scheme)
    return _CACHE[scheme]


def _assert_same(a: R.RigRun, b: R.RigRun) -> None:
    pd.testing.assert_frame_equal(a.samples, b.samples, check_exact=True)
    pd.testing.assert_frame_equal(a.truth, b.truth, check_exact=True)


def test_columns_phases_and_meta():
    for scheme, phases in ((1, {"idle", "load", "unload"}), (2, {"idle", "load", "hold", "unload"}),
                           (3, {"idle", "excite"})):
        r = _nominal(scheme)
        assert list(r.samples.columns) == SAMPLE_COLS
        assert list(r.truth.columns) == TRUTH_COLS
        assert set(r.samples["phase"]) == phases
        assert np.all(np.diff(r.samples["t"].to_numpy()) > 0)
        np.testing.assert_array_equal(r.samples["t"].to_numpy(), r.truth["t"].to_numpy())
        assert r.samples.drop(columns="phase").notna().all().all()
        m = r.meta
        assert m["scheme"] == scheme and m["reduction"] == 11000 and m["rig"] == R.RIG_NAME
        assert m["source"] == "emulator" and m["direction"] == 1 and m["sample_rate_hz"] == FS
        assert m["temp_joint_c"] == 10.0
        assert (m["motor_speed_rpm"] is None) == (scheme == 3)
        assert ("periods" in m) == (scheme == 3)
        assert m["duration_s"] == pytest.approx(r.samples["t"].iloc[-1])
    assert _nominal(1).meta["duration_s"] == pytest.approx(100.0)
    assert _nominal(2).meta["duration_s"] == pytest.approx(60.0)
    assert _nominal(3).meta["duration_s"] == pytest.approx(24.0)
    assert R.REDUCTION == 11000.0 and R.SEED_IS_CAMPAIGN is True


def test_nominal_physics_scheme1():
    r = _nominal(1)
    tr = r.truth
    i = int(np.argmax(tr["torque_load"].to_numpy()))
    assert abs(tr["torque_load"].iloc[i] - 120000.0) < 2000.0
    twist_deg = math.degrees(tr["twist"].iloc[i])
    assert 0.3 < twist_deg < 0.7
    np.testing.assert_array_equal(tr["twist"].to_numpy(), tr["u"].to_numpy() - tr["q"].to_numpy())
    res = math.radians(SPEC.encoder_res_deg)
    assert np.max(np.abs(r.samples["q"] - tr["q"])) <= 0.5 * res * (1 + 1e-9)
    # output speed at 3000 r/min during the load ramp
    w_out = 3000.0 * 2 * math.pi / 60 / 11000
    load = r.samples["phase"] == "load"
    assert tr["qd"][load].mean() == pytest.approx(w_out, rel=0.05)
    # the joint torque exceeds the load by friction (+ gravity) while moving forward
    assert (tr["torque_joint"] - tr["torque_load"])[load].mean() > 1000.0
    # the three motors share the torque; their speeds are N times the output-referred speed
    assert r.samples["i_m1"].max() > 1.0
    assert r.samples["w_m1"][load].mean() == pytest.approx(w_out * 11000, rel=0.05)
    # noise levels as stated
    assert np.std(r.samples["torque"] - tr["torque"]) == pytest.approx(SPEC.torque_noise, rel=0.15)
    assert np.std(r.samples["torque_load"] - tr["torque_load"]) == pytest.approx(SPEC.load_noise, rel=0.15)


def test_direction_signs_motion_and_load():
    r = _run(1, direction=-1)
    tr = r.truth
    assert tr["q"].iloc[-1] < -1.0
    assert tr["torque_load"].min() == pytest.approx(-120000.0, abs=2000.0)
    assert math.degrees(-tr["twist"].iloc[int(np.argmin(tr["torque_load"]))]) > 0.3


def test_scheme2_steps_and_scheme3_speed():
    tr = _nominal(2).truth
    hold = _nominal(2).samples["phase"] == "hold"
    levels = np.round(tr["torque_load"][hold] / 1e4)
    assert set(levels.astype(int)) == set(range(1, 13))
    r3 = _nominal(3)
    ex = r3.samples["phase"] == "excite"
    assert 0.02 < r3.truth["qd"][ex].abs().max() < 0.03
    assert abs(r3.truth["torque_load"]).max() < 2000.0


ALL_CASES = [(name, form) for name, forms in R.EFFECT_FORMS.items() for form in forms]


@pytest.mark.parametrize("name,form", ALL_CASES)
def test_scale_zero_is_bit_identical(name, form):
    _assert_same(_run(3, {name: {"form": form, "scale": 0.0}}), _nominal(3))


@pytest.mark.parametrize("name,form", ALL_CASES)
def test_effect_at_scale_one_changes_the_right_quantity(name, form):
    scheme = 2 if name in NEEDS_LOAD else 3
    nom = _nominal(scheme)
    r = _run(scheme, {name: {"form": form, "scale": 1.0}})
    n_tr, tr = nom.truth, r.truth
    if name in TRANSMISSION:
        assert _rms(K_SERIES * (tr["twist"] - n_tr["twist"])) > 150.0
    elif name in OUTPUT_SIDE:
        d = (tr["torque_joint"] - tr["torque_load"]) - (n_tr["torque_joint"] - n_tr["torque_load"])
        assert _rms(d) > 50.0
    elif name in TORQUE_READING:
        np.testing.assert_array_equal(tr["torque_joint"], n_tr["torque_joint"])
        np.testing.assert_array_equal(tr["twist"], n_tr["twist"])
        assert _rms(tr["torque"] - n_tr["torque"]) > 150.0
    elif name == "load_cell_drift":
        np.testing.assert_array_equal(tr["torque_joint"], n_tr["torque_joint"])
        np.testing.assert_array_equal(tr["torque"], n_tr["torque"])
        assert _rms(tr["torque_load"] - n_tr["torque_load"]) > 150.0
    elif name == "encoder_scale_error":
        pd.testing.assert_frame_equal(tr, n_tr, check_exact=True)
        assert np.max(np.abs(r.samples["q"] - nom.samples["q"])) > 0.0
    else:
        pytest.fail(f"effect {name} has no category in this test")


def test_categories_cover_vocabulary_and_oov():
    cats = TRANSMISSION | OUTPUT_SIDE | TORQUE_READING | {"load_cell_drift", "encoder_scale_error"}
    assert cats == set(R.EFFECT_FORMS)
    assert len(R.OUT_OF_VOCABULARY) >= 4
    vocab = {"stribeck", "temperature_friction", "load_dependent_friction", "asymmetric_friction",
             "gear_ripple", "backlash", "hysteresis", "torque_offset", "time_delay"}
    assert vocab <= set(R.EFFECT_FORMS)
    assert not vocab & set(R.OUT_OF_VOCABULARY)
    assert set(R.OUT_OF_VOCABULARY) <= set(R.EFFECT_FORMS)
    for name in vocab:
        assert 2 <= len(R.EFFECT_FORMS[name]) <= 4


def test_linear_scaling():
    nom = _nominal(3)
    d = {}
    for s in (1.0, 2.0):
        r = _run(3, {"torque_offset": {"form": "constant", "scale": s}})
        d[s] = (r.truth["torque"] - nom.truth["torque"]).to_numpy()
    np.testing.assert_allclose(d[2.0], 2.0 * d[1.0], rtol=1e-9)
    nom2 = _nominal(2)
    kd = {}
    for s in (1.0, 2.0):
        r = _run(2, {"backlash": {"form": "sharp", "scale": s}})
        kd[s] = _rms(r.truth["twist"] - nom2.truth["twist"])
    assert kd[2.0] / kd[1.0] == pytest.approx(2.0, rel=0.15)


def test_determinism_runs_and_seeds():
    a = _run(3, seed=11, run=2)
    b = _run(3, seed=11, run=2)
    _assert_same(a, b)
    c = _run(3, seed=11, run=3)
    assert not np.array_equal(a.samples["torque"], c.samples["torque"])
    d = _run(3, seed=12, run=2)
    assert not np.allclose(a.truth["torque_joint"], d.truth["torque_joint"])
    assert not np.allclose(a.truth["twist"], d.truth["twist"])


@pytest.mark.parametrize("kwargs", [
    {"scheme": 4},
    {"scheme": 1, "motor_speed_rpm": None},
    {"scheme": 1, "motor_speed_rpm": -300.0},
    {"scheme": 3, "motor_speed_rpm": 3000.0},
    {"direction": 0},
    {"temp_joint_c": float("nan")},
    {"effects": {"no_such_effect": {"form": "x", "scale": 1.0}}},
    {"effects": {"backlash": {"form": "no_such_form", "scale": 1.0}}},
    {"effects": {"backlash": {"form": "sharp", "scale": -1.0}}},
    {"effects": {"backlash": {"form": "sharp"}}},
    {"sensors": "not a spec"},
    {"sensors": R.SensorSpec(sample_rate_hz=2000.0)},
    {"sensors": R.SensorSpec(encoder_res_deg=0.0)},
    {"periods": 0},
    {"seed": -1},
    {"run": 1.5},
])
def test_invalid_arguments_raise(kwargs):
    args = {"scheme": 3, "motor_speed_rpm": None, "direction": 1, "temp_joint_c": 20.0, "effects": {},
            "seed": 1, "sensors": SPEC, "periods": 1, "run": 0}
    args.update(kwargs)
    with pytest.raises(ValueError):
        R.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                       args.pop("temp_joint_c"), args.pop("effects"), **args)


def test_sensor_metadata_consistent_with_spec():
    spec = R.SensorSpec(sample_rate_hz=FS, encoder_res_deg=0.01, torque_noise=300.0, torque_lag_s=0.05,
                        load_noise=100.0, current_noise=0.02, temp_resolution_c=0.5)
    r = _run(3, spec=spec)
    m = r.meta
    assert m["sensor_spec"] == asdict(spec)
    s = m["sensors"]
    assert s["q"]["resolution"] == pytest.approx(math.radians(0.01))
    assert s["u"]["resolution"] == pytest.approx(2 * math.pi / (65536 * 11000))
    assert s["qd"]["window_s"] > 0 and s["ud"]["window_s"] > 0
    assert s["torque"]["noise_sd"] == 300.0
    assert s["torque"]["lag_s"] >= 0.05
    assert s["torque_load"]["noise_sd"] == 100.0 and s["torque_load"]["lag_s"] > 0
    assert s["temp_joint"]["resolution"] == 0.5
    for k in (1, 2, 3):
        assert s[f"i_m{k}"]["noise_sd"] == 0.02
    res = math.radians(0.01)
    steps = r.samples["q"].to_numpy() / res
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    temps = r.samples["temp_joint"].to_numpy() / 0.5
    np.testing.assert_allclose(temps, np.round(temps), atol=1e-6)
    # the stated extra lag delays the torque reading
    lagged = r.truth["torque"].to_numpy()
    plain = _nominal(3).truth
    assert not np.array_equal(lagged, plain["torque"].to_numpy())


@pytest.mark.parametrize("fs", [10.0, 1000.0])
def test_sample_rates(fs):
    r = _run(3, spec=R.SensorSpec(sample_rate_hz=fs))
    t = r.samples["t"].to_numpy()
    np.testing.assert_allclose(np.diff(t), 1.0 / fs, rtol=1e-9, atol=1e-12)
    assert len(t) == int(round(24.0 * fs)) + 1
    assert r.samples.drop(columns="phase").notna().all().all()
    assert np.isfinite(r.truth.drop(columns="t").to_numpy()).all()
