"""Contract tests of validation rig K (validation_rigs/rig_k.py).

Fast on purpose: low sample rates (10-20 Hz, the integrator still steps at 1 ms),
scheme 3 with one period; one 1 kHz run for the Eq. 4 check.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pandas as pd
import pytest

from core.runfile import validate_meta, validate_samples
from validation_rigs import rig_k as R

VOCABULARY = ("hysteresis", "stribeck", "load_dependent_friction", "temperature_friction",
              "backlash", "gear_ripple", "torque_offset", "time_delay", "asymmetric_friction")
MIN_FORMS = {"stribeck": 4, "load_dependent_friction": 2, "temperature_friction": 3,
             "gear_ripple": 3, "torque_offset": 2, "time_delay": 2, "hysteresis": 3,
             "backlash": 2, "asymmetric_friction": 2, "periodic_disturbance": 2,
             "position_dependent_stiffness": 2, "sensor_drift": 2, "second_resonance": 2}
SEED = 11


def _key(effects):
    return tuple(sorted((k, v.get("form"), v.get("scale")) for k, v in (effects or {}).items()))


@lru_cache(maxsize=None)
def _sim_cached(scheme, rpm, direction, temp, ekey, fs, seed, run, lag=0.0, noise=150.0):
    effects = {k: {"form": f, "scale": s} for k, f, s in ekey}
    return R.simulate_run(scheme, rpm, direction, temp, effects,
                          sensors=R.SensorSpec(sample_rate_hz=fs, torque_lag_s=lag, torque_noise=noise),
                          periods=1, seed=seed, run=run)


def sim(scheme=3, rpm=None, direction=1, temp=30.0, effects=None, fs=20.0, seed=SEED, run=0, **kw):
    return _sim_cached(scheme, rpm, direction, temp, _key(effects), fs, seed, run, **kw)


def numeric(df):
    return df.drop(columns=["phase"], errors="ignore")


# --------------------------------------------------------------------- format and metadata
@pytest.mark.parametrize("scheme,rpm", [(1, 300.0), (2, 3000.0), (3, None)])
def test_columns_and_metadata_accepted_by_run_format(scheme, rpm):
    r = sim(scheme, rpm, fs=10.0)
    s, m = r.samples, r.meta
    for c in ("t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "phase"):
        assert c in s.columns, c
    validate_samples(s, "rig_k")
    validate_meta(m, "rig_k")
    assert m["scheme"] == scheme and m["reduction"] == R.REDUCTION == 11000.0
    assert m["sample_rate_hz"] == 10.0 and m["temp_joint_c"] == 30.0 and m["direction"] == 1
    assert m["source"] == "emulator" and m["rig"]
    assert (m["motor_speed_rpm"] is None) == (scheme == 3)
    np.testing.assert_allclose(s["t"].to_numpy(), np.arange(len(s)) / 10.0, rtol=0, atol=1e-12)
    assert set(s["phase"]) <= {"idle", "load", "hold", "unload", "excite"}
    assert ("excite" in set(s["phase"])) == (scheme == 3)
    assert {"twist", "torque"} <= set(r.truth.columns)
    assert len(r.truth) == len(s)
    assert np.isfinite(numeric(s).to_numpy(dtype=float)).all()
    # blind scoring: neither effects nor rig parameters leak into the metadata
    assert "effects" not in m and "params" not in m


def test_stated_sensor_properties_are_in_meta():
    spec = R.SensorSpec(sample_rate_hz=50.0, encoder_res_deg=0.005, torque_noise=90.0, torque_lag_s=0.02)
    r = R.simulate_run(3, None, 1, 25.0, {}, sensors=spec, periods=1, seed=SEED, run=0)
    sen = r.meta["sensors"]
    assert sen["q"]["resolution"] == pytest.approx(math.radians(0.005))
    assert sen["u"]["resolution"] == pytest.approx(2 * math.pi / 2 ** 22 / 11000.0)
    assert sen["torque"]["noise_sd"] == 90.0 and sen["torque"]["lag_s"] == 0.02
    assert sen["torque"]["resolution"] == pytest.approx(500_000.0 / 2 ** 16)
    assert set(sen["torque_load"]) == {"resolution", "noise_sd", "lag_s"}
    assert sen["qd"]["lag_s"] == spec.qd_tau_s and sen["temp_joint"]["lag_s"] == spec.temp_tau_s
    # the encoder step is the step the q channel really has
    q = r.samples["q"].to_numpy() / sen["q"]["resolution"]
    np.testing.assert_allclose(q, np.round(q), atol=1e-6)


def test_stated_torque_lag_is_really_applied():
    fs, lag = 100.0, 0.1
    r = sim(fs=fs, lag=lag, noise=0.0)
    k = int(round(lag * fs))
    meas = r.samples["torque"].to_numpy()
    true = r.truth["torque"].to_numpy()
    lsb = r.meta["sensors"]["torque"]["resolution"]
    assert np.abs(meas[k:] - true[:-k]).max() <= 0.5 * lsb + 1e-6
    # and it is a real lag: without the shift the difference is far bigger
    assert np.abs(meas - true).max() > 20 * lsb


def test_stated_torque_noise_is_the_real_noise():
    r = sim(fs=100.0)          # torque_noise 150, lag 0
    resid = r.samples["torque"] - r.truth["torque"]
    assert resid.std() == pytest.approx(150.0, rel=0.08)   # n = 2601: sd of the estimate ~1.4 %
    assert abs(resid.mean()) < 15.0


# --------------------------------------------------------------------- randomness contract
def test_deterministic():
    a = R.simulate_run(3, None, -1, 20.0, {"stribeck": {"form": "lorentzian", "scale": 1.0}},
                       sensors=R.SensorSpec(sample_rate_hz=20.0), periods=1, seed=5, run=3)
    b = R.simulate_run(3, None, -1, 20.0, {"stribeck": {"form": "lorentzian", "scale": 1.0}},
                       sensors=R.SensorSpec(sample_rate_hz=20.0), periods=1, seed=5, run=3)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    assert a.meta == b.meta


def test_same_seed_other_run_same_rig_other_noise():
    a, b = sim(run=0), sim(run=1)
    assert a.params == b.params
    pd.testing.assert_frame_equal(a.truth, b.truth)          # same physics
    assert not np.allclose(a.samples["torque"], b.samples["torque"])
    assert not np.allclose(a.noise.to_numpy(), b.noise.to_numpy())
    c = sim(seed=SEED + 1)
    assert c.params["I"] != a.params["I"] and c.params["k0"] != a.params["k0"]
    assert abs(c.params["I"] / a.params["I"] - 1) < 0.15     # a few % around the data sheet


def test_scale_zero_is_nominal_bit_for_bit():
    nom = sim(scheme=2, rpm=300.0, fs=10.0)
    zero = {name: {"form": forms[-1], "scale": 0.0} for name, forms in R.EFFECT_FORMS.items()}
    r = R.simulate_run(2, 300.0, 1, 30.0, zero, sensors=R.SensorSpec(sample_rate_hz=10.0),
                       periods=1, seed=SEED, run=0)
    pd.testing.assert_frame_equal(r.samples, nom.samples, check_exact=True)
    pd.testing.assert_frame_equal(r.truth, nom.truth, check_exact=True)
    absent = R.simulate_run(2, 300.0, 1, 30.0, {"backlash": {"form": "dead_zone"}},
                            sensors=R.SensorSpec(sample_rate_hz=10.0), periods=1, seed=SEED, run=0)
    pd.testing.assert_frame_equal(absent.samples, nom.samples, check_exact=True)


def test_noise_does_not_depend_on_effects():
    nom = sim()
    r = sim(effects={"stribeck": {"form": "gaussian", "scale": 2.0},
                     "hysteresis": {"form": "dahl", "scale": 1.0}})
    pd.testing.assert_frame_equal(r.noise, nom.noise)
    # a torque-channel effect leaves every other channel bit-identical and shifts
    # torque by the offset (within one ADC step: same noise draws underneath)
    off = sim(effects={"torque_offset": {"form": "constant", "scale": 1.0}})
    others = [c for c in nom.samples.columns if c != "torque"]
    pd.testing.assert_frame_equal(off.samples[others], nom.samples[others], check_exact=True)
    d = off.samples["torque"] - nom.samples["torque"]
    lsb = nom.meta["sensors"]["torque"]["resolution"]
    assert d.max() - d.min() <= lsb + 1e-6
    assert 1000.0 < d.mean() < 2000.0
    drift = sim(effects={"sensor_drift": {"form": "load_cell_zero", "scale": 1.0}}, scheme=2, rpm=300.0)
    base = sim(scheme=2, rpm=300.0)
    others = [c for c in base.samples.columns if c != "torque_load"]
    pd.testing.assert_frame_equal(drift.samples[others], base.samples[others], check_exact=True)


def test_scale_is_clamped_as_documented():
    e3 = sim(effects={"backlash": {"form": "smoothed", "scale": R.SCALE_MAX}})
    e9 = sim(effects={"backlash": {"form": "smoothed", "scale": 9.0 * R.SCALE_MAX}})
    pd.testing.assert_frame_equal(e3.samples, e9.samples, check_exact=True)
    e1 = sim(effects={"backlash": {"form": "smoothed", "scale": 1.0}})
    assert not e1.samples.equals(e3.samples)


# --------------------------------------------------------------------- effects change the samples
SENSOR_SIDE = {"torque_offset": "torque", "time_delay": "torque"}
ALL_FORMS = [(n, f) for n, forms in R.EFFECT_FORMS.items() for f in forms]


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_form_changes_the_samples_at_scale_1(name, form):
    # scheme 1 at 3000 r/min, 40 degC: high load, long travel, warm (temperature laws act)
    kw = dict(scheme=1, rpm=3000.0, temp=40.0, fs=10.0)
    nom = sim(**kw)
    r = sim(effects={name: {"form": form, "scale": 1.0}}, **kw)
    assert not r.samples.equals(nom.samples)
    ds = numeric(r.samples) - numeric(nom.samples)
    if name in SENSOR_SIDE:
        pd.testing.assert_frame_equal(r.truth, nom.truth, check_exact=True)
        assert ds["torque"].abs().max() > 300.0
    elif name == "sensor_drift":
        pd.testing.assert_frame_equal(r.truth, nom.truth, check_exact=True)
        if form == "load_cell_zero":
            assert ds["torque_load"].abs().max() > 300.0
        else:
            assert ds["q"].abs().max() >= 2 * r.meta["sensors"]["q"]["resolution"] - 1e-12
    else:
        dT = (r.truth["torque"] - nom.truth["torque"]).abs().max()
        dtw = (r.truth["twist"] - nom.truth["twist"]).abs().max()
        # at least ~1/3 of the torque noise, or ~1/3 of an output encoder step of twist
        assert dT > 50.0 or dtw > 5e-5, (dT, dtw)


# --------------------------------------------------------------------- physics of the truth
@pytest.mark.parametrize("scheme,rpm,direction", [(1, 3000.0, -1), (3, None, 1)])
def test_eq4_balance_on_nominal_truth(scheme, rpm, direction):
    r = R.simulate_run(scheme, rpm, direction, 25.0, {}, sensors=R.SensorSpec(sample_rate_hz=1000.0),
                       periods=1, seed=SEED, run=0)
    tr, p = r.truth, r.params
    grav = 9.81 * (p["mr_x"] * np.sin(tr["q"]) + p["mr_y"] * np.cos(tr["q"]))
    resid = p["I"] * tr["qdd"] - (tr["torque"] - tr["torque_load"] - grav - tr["friction"])
    # an identity up to float rounding of ~1e5 N m terms (1e-11 N m); 1e-3 N m is generous
    assert resid.abs().max() < 1e-3
    # ... and qdd is the real acceleration of the trajectory: trapezoidal integration on
    # the 1 kHz grid reproduces qd within 2e-6 rad/s (observed <= 3e-7); a 1 N m bias in
    # any Eq. 4 term would drift qd by 1/I = 1.5e-4 rad/s per second of run.
    h = 1e-3
    qdd = tr["qdd"].to_numpy()
    integ = np.concatenate([[0.0], np.cumsum(0.5 * (qdd[1:] + qdd[:-1]) * h)])
    drift = tr["qd"].to_numpy() - tr["qd"].iloc[0] - integ
    assert np.abs(drift).max() < 2e-6
    # the run moves in the commanded sense and friction opposes the motion
    moving = tr["qd"].abs() > 5e-3
    assert (np.sign(tr["friction"][moving]) == np.sign(tr["qd"][moving])).all()
    if scheme == 1:
        assert np.sign(tr["q"].iloc[-1]) == direction


def test_twist_and_nominal_elastic_transmission():
    r = sim(scheme=1, rpm=300.0, fs=10.0)
    tr, p = r.truth, r.params
    np.testing.assert_array_equal(tr["twist"].to_numpy(), (tr["u"] - tr["q"]).to_numpy())
    # measured u - q is the true twist up to the two encoders' rounding
    res = r.meta["sensors"]["q"]["resolution"] + r.meta["sensors"]["u"]["resolution"]
    err = (r.samples["u"] - r.samples["q"]) - tr["twist"]
    assert err.abs().max() <= 0.5 * res + 1e-12
    # nominal transmission: stiffening spring + damping, no backlash and no hysteresis
    law = p["k0"] * tr["twist"] + p["k3"] * tr["twist"] ** 3 + p["c_t"] * (tr["ud"] - tr["qd"])
    assert (tr["torque"] - law).abs().max() < 1e-6 * tr["torque"].abs().max()
    # about half a degree of twist at the rated 120 kN m
    assert 0.3 < math.degrees(tr["twist"].max()) < 0.8


@pytest.mark.parametrize("direction", [1, -1])
def test_load_resists_motion_and_follows_set_point(direction):
    r = sim(scheme=2, rpm=3000.0, direction=direction, fs=10.0)
    tr, s = r.truth, r.samples
    hold = s["phase"] == "hold"
    assert (np.sign(tr["torque_load"][hold]) == direction).all()
    assert (np.sign(tr["torque"][hold]) == direction).all()
    assert np.sign(tr["q"].iloc[-1]) == direction
    # Table 11: the load follows its set point within +-2 kN m once settled
    settled = hold & (s["phase"].shift(-1) == "hold")
    assert (tr["torque_load"][settled] - tr["torque_cmd"][settled]).abs().max() < 2000.0
    assert abs(tr["torque_load"]).max() == pytest.approx(120_000.0, abs=2000.0)
    # 3000 r/min at the motor is ~0.0286 rad/s at the output
    assert s["ud"][s["t"] > 5].abs().mean() == pytest.approx(3000 * 2 * math.pi / 60 / 11000, rel=0.01)


def test_scheme3_stays_in_range_without_load():
    r = sim(scheme=3)
    assert r.truth["q"].abs().max() < math.pi
    assert r.truth["qd"].abs().max() <= 3000 * 2 * math.pi / 60 / 11000
    assert (r.truth["torque_load"] == 0.0).all()
    assert r.samples["torque_load"].abs().max() < 6 * r.meta["sensors"]["torque_load"]["noise_sd"]


# --------------------------------------------------------------------- vocabulary, arguments
def test_effect_vocabulary_and_out_of_vocabulary():
    assert R.SEED_IS_CAMPAIGN is True and R.REDUCTION == 11000.0
    assert set(R.OUT_OF_VOCABULARY) == {"periodic_disturbance", "position_dependent_stiffness",
                                        "sensor_drift", "second_resonance"}
    assert set(R.EFFECT_FORMS) == set(VOCABULARY) | set(R.OUT_OF_VOCABULARY)
    for name, n in MIN_FORMS.items():
        forms = R.EFFECT_FORMS[name]
        assert len(forms) >= n and len(set(forms)) == len(forms), name


def _call(**over):
    kw = dict(scheme=3, motor_speed_rpm=None, direction=1, temp_joint_c=25.0, effects={},
              sensors=R.SensorSpec(sample_rate_hz=20.0), periods=1, seed=1, run=0)
    kw.update(over)
    pos = [kw.pop(k) for k in ("scheme", "motor_speed_rpm", "direction", "temp_joint_c", "effects")]
    return R.simulate_run(*pos, **kw)


@pytest.mark.parametrize("over,culprit", [
    (dict(effects={"friction_wobble": {"form": "x", "scale": 1.0}}), "friction_wobble"),
    (dict(effects={"stribeck": {"form": "cubic", "scale": 1.0}}), "cubic"),
    (dict(effects={"backlash": {"form": "dead_zone", "scale": float("nan")}}), "backlash"),
    (dict(effects={"backlash": {"form": "dead_zone", "scale": float("inf")}}), "scale"),
    (dict(effects={"backlash": {"form": "dead_zone", "scale": -1.0}}), "scale"),
    (dict(effects={"backlash": {"form": "dead_zone", "scale": 1.0, "size": 2}}), "size"),
    (dict(scheme=4), "scheme"),
    (dict(scheme=1, motor_speed_rpm=None), "motor_speed_rpm"),
    (dict(scheme=1, motor_speed_rpm=5000.0), "motor_speed_rpm"),
    (dict(motor_speed_rpm=300.0), "motor_speed_rpm"),
    (dict(direction=0), "direction"),
    (dict(temp_joint_c=float("nan")), "temp_joint_c"),
    (dict(periods=0), "periods"),
    (dict(sensors=R.SensorSpec(sample_rate_hz=5.0)), "sample_rate_hz"),
    (dict(sensors=R.SensorSpec(sample_rate_hz=2000.0)), "sample_rate_hz"),
    (dict(sensors=R.SensorSpec(sample_rate_hz=20.0, encoder_res_deg=0.1)), "encoder_res_deg"),
    (dict(sensors=R.SensorSpec(sample_rate_hz=20.0, torque_noise=-1.0)), "torque_noise"),
    (dict(sensors=R.SensorSpec(sample_rate_hz=20.0, torque_lag_s=float("nan"))), "torque_lag_s"),
    (dict(seed=-3), "seed"),
])
def test_bad_arguments_raise_naming_the_culprit(over, culprit):
    with pytest.raises(ValueError, match=culprit):
        _call(**over)
