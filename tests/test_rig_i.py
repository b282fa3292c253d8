"""Contract tests of validation rig I (validation_rigs/rig_i.py): short runs, low rates."""

import math

import numpy as np
import pandas as pd
import pytest

from validation_rigs import rig_i as R

SEED = 3
LOW = R.SensorSpec(sample_rate_hz=10.0)


def _run3(effects=None, *, seed=SEED, run=0, sensors=LOW, temp=40.0):
    return R.simulate_run(3, None, 1, temp, effects or {}, seed=seed, sensors=sensors,
                          periods=1, run=run)


@pytest.fixture(scope="module")
def base3():
    return _run3()


@pytest.fixture(scope="module")
def base2():
    return R.simulate_run(2, 3000.0, 1, 40.0, {}, seed=SEED, sensors=LOW)


def test_contract_constants():
    assert R.SEED_IS_CAMPAIGN is True
    assert R.REDUCTION == 11000.0
    assert R.RIG_NAME == "validation-rig-I"
    required = {"stribeck", "temperature_friction", "load_dependent_friction",
                "asymmetric_friction", "gear_ripple", "backlash", "hysteresis",
                "torque_offset", "time_delay"}
    oov = {"periodic_disturbance", "position_dependent_stiffness", "sensor_drift",
           "second_resonance"}
    assert required | oov <= set(R.EFFECT_FORMS)
    assert oov <= set(R.OUT_OF_VOCABULARY)
    assert not required & set(R.OUT_OF_VOCABULARY)
    assert all(len(forms) >= 2 for forms in R.EFFECT_FORMS.values())
    assert len(R.EFFECT_FORMS["stribeck"]) >= 4
    assert len(R.EFFECT_FORMS["temperature_friction"]) >= 3
    assert len(R.EFFECT_FORMS["hysteresis"]) >= 3
    spec = R.SensorSpec()
    assert (spec.sample_rate_hz, spec.encoder_res_deg, spec.torque_noise, spec.torque_lag_s) == \
        (1000.0, 0.01, 150.0, 0.0)


def test_columns_meta_and_phases(base3, base2):
    for r, scheme in ((base3, 3), (base2, 2)):
        for c in ("t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "phase",
                  "i_m1", "i_m2", "i_m3", "w_m1", "w_m2", "w_m3"):
            assert c in r.samples.columns
        for c in ("t", "q", "qd", "u", "ud", "twist", "twist_rate", "torque", "torque_load",
                  "torque_true", "torque_load_true", "temp_joint"):
            assert c in r.truth.columns
        np.testing.assert_allclose(r.truth.twist, r.truth.u - r.truth.q)
        m = r.meta
        assert m["scheme"] == scheme and m["rig"] == R.RIG_NAME and m["source"] == "emulator"
        assert m["reduction"] == R.REDUCTION and m["seed"] == SEED and m["run"] == 0
        for k in ("motor_speed_rpm", "direction", "sample_rate_hz", "duration_s", "temp_joint_c",
                  "periods", "sensors"):
            assert k in m
        assert set(r.samples.phase.unique()) <= {"rest", "accelerate", "hold", "load", "unload",
                                                  "decelerate", "excite"}
    assert "excite" in set(base3.samples.phase)
    assert {"load", "hold", "unload"} <= set(base2.samples.phase)
    assert base3.meta["motor_speed_rpm"] is None
    assert base3.meta["duration_s"] == pytest.approx(22.0)
    assert 40.0 <= base2.meta["duration_s"] <= 70.0
    assert base3.samples.torque_load.abs().max() < 400.0  # dynamometer declutched: noise only


def test_deterministic_and_seed_run_roles(base3):
    again = _run3()
    pd.testing.assert_frame_equal(again.samples, base3.samples)
    pd.testing.assert_frame_equal(again.truth, base3.truth)
    assert again.meta == base3.meta
    other_run = _run3(run=1)
    pd.testing.assert_frame_equal(other_run.truth, base3.truth)  # noise only from (seed, run)
    assert not np.array_equal(other_run.samples.torque, base3.samples.torque)
    other_seed = _run3(seed=SEED + 1)
    assert not np.allclose(other_seed.truth.torque_true, base3.truth.torque_true)


def test_scale_zero_is_nominal_bit_for_bit(base3):
    zero = {name: {"form": forms[-1], "scale": 0.0} for name, forms in R.EFFECT_FORMS.items()}
    r = _run3(zero)
    pd.testing.assert_frame_equal(r.samples, base3.samples, check_exact=True)
    pd.testing.assert_frame_equal(r.truth, base3.truth, check_exact=True)


def _changed(a, b):
    for c in a.samples.columns:
        if c == "phase":
            continue
        if not np.array_equal(a.samples[c].to_numpy(), b.samples[c].to_numpy()):
            return True
    return False


def test_every_form_changes_the_output(base3, base2):
    for name, forms in R.EFFECT_FORMS.items():
        for form in forms:
            eff = {name: {"form": form, "scale": 1.0}}
            if (name, form) == ("second_resonance", "dyno_mode"):  # behind the load cell
                r = R.simulate_run(2, 3000.0, 1, 40.0, eff, seed=SEED, sensors=LOW)
                assert _changed(r, base2), (name, form)
            else:
                assert _changed(_run3(eff), base3), (name, form)


@pytest.mark.parametrize("bad, culprit", [
    (-1.0, "-1.0"), (float("nan"), "nan"), (float("inf"), "inf"), ("1", "'1'"), (None, "None"),
    (True, "True"), ([1.0], "[1.0]"),
])
def test_bad_scale_raises_naming_it(bad, culprit):
    with pytest.raises(ValueError) as err:
        _run3({"backlash": {"form": "sharp", "scale": bad}})
    assert "backlash" in str(err.value) and culprit in str(err.value)


def test_bad_name_form_key_raise_naming_them():
    with pytest.raises(ValueError, match="coulomb_drag"):
        _run3({"coulomb_drag": {"form": "x", "scale": 1.0}})
    with pytest.raises(ValueError, match="cubic"):
        _run3({"stribeck": {"form": "cubic", "scale": 1.0}})
    with pytest.raises(ValueError, match="amplitude"):
        _run3({"stribeck": {"form": "gaussian", "scale": 1.0, "amplitude": 2}})
    with pytest.raises(ValueError, match="scale"):
        _run3({"stribeck": {"form": "gaussian"}})
    with pytest.raises(ValueError, match="stribeck"):
        _run3({"stribeck": 1.0})
    with pytest.raises(ValueError, match="motor_speed_rpm"):
        R.simulate_run(3, 300.0, 1, 25.0, {}, seed=1, sensors=LOW, periods=1)
    with pytest.raises(ValueError, match="motor_speed_rpm"):
        R.simulate_run(1, None, 1, 25.0, {}, seed=1, sensors=LOW)
    with pytest.raises(ValueError, match="motor_speed_rpm"):
        R.simulate_run(1, 4000.0, 1, 25.0, {}, seed=1, sensors=LOW)
    with pytest.raises(ValueError, match="direction"):
        R.simulate_run(1, 300.0, 0, 25.0, {}, seed=1, sensors=LOW)
    with pytest.raises(ValueError, match="sample_rate_hz"):
        R.simulate_run(3, None, 1, 25.0, {}, seed=1, sensors=R.SensorSpec(sample_rate_hz=5.0),
                       periods=1)


def test_large_scale_is_clamped_and_finite():
    r = _run3({"backlash": {"form": "smooth", "scale": 1e9},
               "stribeck": {"form": "lorentzian", "scale": 1e9}})
    assert np.isfinite(r.samples.drop(columns="phase").to_numpy()).all()
    r2 = _run3({"backlash": {"form": "smooth", "scale": 1e3},
                "stribeck": {"form": "lorentzian", "scale": 1e3}})
    pd.testing.assert_frame_equal(r.samples, r2.samples)


def test_non_finite_integration_raises_runtime_error(monkeypatch):
    orig = R.nominal_parameters

    def broken(seed):
        p = orig(seed)
        p["I"] = float("nan")
        return p

    monkeypatch.setattr(R, "nominal_parameters", broken)
    with pytest.raises(RuntimeError, match="gear_ripple.*0.5"):
        _run3({"gear_ripple": {"form": "output_angle", "scale": 0.5}})


def test_encoder_quantised_at_the_given_step():
    spec = R.SensorSpec(sample_rate_hz=10.0, encoder_res_deg=0.02)
    r = _run3(sensors=spec)
    step = math.radians(0.02)
    k = r.samples.q.to_numpy() / step
    assert np.abs(k - np.round(k)).max() < 1e-6
    assert len(np.unique(np.round(k))) > 20
    assert r.meta["sensors"]["q"]["resolution"] == pytest.approx(step)
    assert np.abs(r.samples.q - r.truth.q).max() <= step / 2 + 1e-12
    ku = r.samples.u.to_numpy() / r.meta["sensors"]["u"]["resolution"]
    assert np.abs(ku - np.round(ku)).max() < 1e-3


@pytest.mark.parametrize("fs", [10.0, 37.0])
def test_sample_rate_honoured(fs):
    r = _run3(sensors=R.SensorSpec(sample_rate_hz=fs))
    t = r.samples.t.to_numpy()
    np.testing.assert_allclose(np.diff(t), 1.0 / fs, rtol=1e-9)
    assert t[0] == 0.0 and len(t) == int(math.floor(22.0 * fs + 1e-9)) + 1
    assert r.meta["sample_rate_hz"] == fs


def test_output_torque_balance_on_truth_while_sliding():
    r = R.simulate_run(1, 300.0, 1, 25.0, {}, seed=SEED, sensors=R.SensorSpec(sample_rate_hz=20.0))
    p = R.nominal_parameters(SEED)
    tr = r.truth
    grav = R.G_ACC * (p["mr_x"] * np.sin(tr.q) + p["mr_y"] * np.cos(tr.q))
    # exact identity of the model: I*qdd = T - tau_L - G - F
    ident = tr.torque_true - tr.torque_load_true - grav - tr.friction_true - p["I"] * tr.qdd
    assert np.abs(ident).max() < 1e-6 * 120e3
    # steady sliding: the LuGre force is F_c*sgn(v) + f_v*v (Eq. 4's friction)
    t = r.samples.t.to_numpy()
    sl = r.samples.phase.isin(["hold", "load", "unload"]).to_numpy() & (t > 4.0)
    sl = sl & ~((t > 5.8) & (t < 7.0))  # the load ramp's corner transient
    res = (tr.torque_true - tr.torque_load_true - grav - p["I"] * tr.qdd
           - p["F_c"] * np.sign(tr.qd) - p["f_v"] * tr.qd)[sl]
    assert sl.sum() > 500
    assert np.abs(res).max() < 0.01 * p["F_c"]
    # and the loading reaches the rated torque, resisting the motion
    assert tr.torque_load_true.max() == pytest.approx(120e3, abs=2e3)


def test_meta_sensors_consistent():
    spec = R.SensorSpec(sample_rate_hz=50.0, torque_noise=200.0, torque_lag_s=0.01)
    r = _run3(sensors=spec)
    s = r.meta["sensors"]
    for ch in ("q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "i_m1", "w_m1"):
        assert set(s[ch]) >= {"resolution", "noise_sd", "lag_s", "unit"}
        assert all(isinstance(s[ch][k], float) for k in ("resolution", "noise_sd", "lag_s"))
    assert s["torque"]["noise_sd"] == 200.0
    filt = math.sqrt(2.0) / (2.0 * math.pi * R.TORQUE_FILTER_HZ)
    assert s["torque"]["lag_s"] == pytest.approx(filt + 0.01)
    noise = (r.samples.torque - r.truth.torque).to_numpy()
    assert np.std(noise) == pytest.approx(200.0, rel=0.1)
    k = r.samples.torque.to_numpy() / s["torque"]["resolution"]
    assert np.abs(k - np.round(k)).max() < 1e-6
    # the stated lag is what the reading does: the noise-free reading is the true torque,
    # filtered and delayed by lag_s (a 10 ms pure lag here)
    t = r.truth.t.to_numpy()
    shifted = np.interp(t - s["torque"]["lag_s"], t, r.truth.torque_true.to_numpy())
    lagged = np.abs(r.truth.torque - shifted)[t > 2.0].mean()
    unlagged = np.abs(r.truth.torque - r.truth.torque_true)[t > 2.0].mean()
    assert lagged < unlagged
