"""Contract tests of validation rig N (validation_rigs/rig_n.py): interface, argument checks,
determinism, shared noise, metadata, stated sensors, physics against the paper, and what every
effect form does (and does not do)."""

from __future__ import annotations

import dataclasses
import inspect
import json
import math
import numpy as np
import pandas as pd
import pytest

from core.runfile import validate_meta, validate_samples
from validation_rigs import rig_n as R

VOCABULARY = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
              "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction")
OOV = ("periodic_disturbance", "position_dependent_stiffness", "sensor_drift", "second_resonance")
SEED = 7
S100 = R.SensorSpec(sample_rate_hz=100.0)
S1K = R.SensorSpec(sample_rate_hz=1000.0)

_CACHE: dict = {}


def run(scheme, speed, direction, temp=25.0, effects=None, sensors=S100, periods=3, seed=SEED,
        run_=0):
    key = (scheme, speed, direction, temp, json.dumps(effects, sort_keys=True), sensors, periods,
           seed, run_)
    if key not in _CACHE:
        _CACHE[key] = R.simulate_run(scheme, speed, direction, temp, effects, sensors=sensors,
                                     periods=periods, seed=seed, run=run_)
    return _CACHE[key]


def rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x * x)))


def eff(name, form, scale=1.0):
    return {name: {"form": form, "scale": scale}}


# ---------------------------------------------------------------------------------------------
# interface
# ---------------------------------------------------------------------------------------------

def test_interface_constants_and_vocabulary():
    assert R.SEED_IS_CAMPAIGN is True
    assert R.REDUCTION == 11000.0
    assert R.RIG_NAME == "rig_n"
    assert set(R.EFFECT_FORMS) == set(VOCABULARY) | set(OOV)
    assert set(R.OUT_OF_VOCABULARY) == set(OOV)
    for name, forms in R.EFFECT_FORMS.items():
        assert isinstance(forms, tuple) and len(set(forms)) == len(forms)
        assert len(forms) >= (2 if name in OOV else 3), name
    st = R.EFFECT_FORMS["stribeck"]
    assert {"exponential", "gaussian", "lorentzian"} <= set(st) and len(st) >= 4
    assert R.EFFECT_FORMS["stribeck"][0] == "exponential"


def test_interface_signature_and_dataclasses():
    sig = inspect.signature(R.simulate_run)
    names = list(sig.parameters)
    assert names[:5] == ["scheme", "motor_speed_rpm", "direction", "temp_joint_c", "effects"]
    for kw in ("sensors", "periods", "seed", "run"):
        assert sig.parameters[kw].kind is inspect.Parameter.KEYWORD_ONLY
    assert sig.parameters["seed"].default is inspect.Parameter.empty
    assert sig.parameters["run"].default is inspect.Parameter.empty
    assert sig.parameters["periods"].default == 3
    fields = {f.name: f for f in dataclasses.fields(R.SensorSpec)}
    for f in ("sample_rate_hz", "encoder_res_deg", "torque_noise", "torque_lag_s"):
        assert f in fields
    assert R.SensorSpec().torque_lag_s == 0.0
    for f in dataclasses.fields(R.SensorSpec):
        assert f.default is not dataclasses.MISSING, f.name
    assert {f.name for f in dataclasses.fields(R.RigRun)} == {"samples", "meta", "truth", "params"}


def test_outputs_columns():
    r = run(1, 3000.0, 1)
    for c in ("t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "torque_cmd",
              "i_m1", "i_m2", "i_m3", "phase"):
        assert c in r.samples.columns, c
    for c in ("t", "twist", "torque", "torque_load", "friction", "q", "qd", "u"):
        assert c in r.truth.columns, c
    assert len(r.truth) == len(r.samples)
    assert np.array_equal(r.truth.t.to_numpy(), r.samples.t.to_numpy())
    assert np.allclose(r.truth.twist, r.truth.u - r.truth.q, atol=1e-15)
    assert np.all(np.diff(r.samples.t) > 0)
    assert np.all(np.abs(r.truth.t_sample - r.truth.t) <= 3 * 3e-5 + 1e-12)
    validate_samples(r.samples, "x")
    assert set(r.samples.phase.unique()) <= {"idle", "load", "hold", "unload", "excite"}


# ---------------------------------------------------------------------------------------------
# argument validation
# ---------------------------------------------------------------------------------------------

GOOD = dict(scheme=1, motor_speed_rpm=300.0, direction=1, temp_joint_c=25.0, effects=None)

BAD = [
    ("scheme", dict(scheme=4)), ("scheme", dict(scheme=0)), ("scheme", dict(scheme="1")),
    ("scheme", dict(scheme=True)), ("scheme", dict(scheme=1.5)),
    ("motor_speed_rpm", dict(motor_speed_rpm=None)), ("motor_speed_rpm", dict(motor_speed_rpm=-300)),
    ("motor_speed_rpm", dict(motor_speed_rpm=0.0)), ("motor_speed_rpm", dict(motor_speed_rpm=5000)),
    ("motor_speed_rpm", dict(motor_speed_rpm=float("nan"))),
    ("motor_speed_rpm", dict(motor_speed_rpm="300")),
    ("motor_speed_rpm", dict(scheme=3, motor_speed_rpm=300.0)),
    ("direction", dict(direction=0)), ("direction", dict(direction=2)),
    ("direction", dict(direction=True)), ("direction", dict(direction="1")),
    ("temp_joint_c", dict(temp_joint_c=float("nan"))), ("temp_joint_c", dict(temp_joint_c=200.0)),
    ("temp_joint_c", dict(temp_joint_c="25")), ("temp_joint_c", dict(temp_joint_c=float("inf"))),
    ("effects", dict(effects=["stribeck"])), ("effects", dict(effects={"nope": {"scale": 1.0}})),
    ("effects", dict(effects={"stribeck": {"form": "cubic", "scale": 1.0}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": -1.0}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": float("nan")}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": float("inf")}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": "1"}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian"}})),
    ("effects", dict(effects={"stribeck": 1.0})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": 1.0, "x": 2}})),
]


@pytest.mark.parametrize("argname,override", BAD)
def test_bad_arguments_raise_value_error_naming_them(argname, override):
    kw = dict(GOOD)
    kw.update(override)
    with pytest.raises(ValueError, match=argname):
        R.simulate_run(kw["scheme"], kw["motor_speed_rpm"], kw["direction"], kw["temp_joint_c"],
                       kw["effects"], seed=1, run=0)


@pytest.mark.parametrize("argname,kw", [
    ("periods", dict(periods=0)), ("periods", dict(periods=2.5)), ("periods", dict(periods=None)),
    ("seed", dict(seed=-1)), ("seed", dict(seed=1.5)), ("seed", dict(seed=None)),
    ("run", dict(run=-2)), ("run", dict(run="0")),
    ("sensors", dict(sensors="fast")),
    ("sensors.sample_rate_hz", dict(sensors=R.SensorSpec(sample_rate_hz=0.0))),
    ("sensors.encoder_res_deg", dict(sensors=R.SensorSpec(encoder_res_deg=0.0))),
    ("sensors.torque_noise", dict(sensors=R.SensorSpec(torque_noise=-1.0))),
    ("sensors.torque_lag_s", dict(sensors=R.SensorSpec(torque_lag_s=float("nan")))),
    ("sensors.aa_fraction", dict(sensors=R.SensorSpec(aa_fraction=0.9))),
])
def test_bad_keyword_arguments(argname, kw):
    full = dict(sensors=S100, periods=3, seed=1, run=0)
    full.update(kw)
    with pytest.raises(ValueError, match=argname.replace(".", r"\.")):
        R.simulate_run(3, None, 1, 25.0, None, **full)


# ---------------------------------------------------------------------------------------------
# determinism, campaigns, shared noise
# ---------------------------------------------------------------------------------------------

def test_bit_identical_repeat():
    a = R.simulate_run(3, None, -1, 30.0, eff("hysteresis", "dahl"), sensors=S100, seed=3, run=2)
    b = R.simulate_run(3, None, -1, 30.0, eff("hysteresis", "dahl"), sensors=S100, seed=3, run=2)
    pd.testing.assert_frame_equal(a.samples, b.samples, check_exact=True)
    pd.testing.assert_frame_equal(a.truth, b.truth, check_exact=True)
    assert a.meta == b.meta


def test_seed_is_campaign_run_is_noise():
    a = run(1, 300.0, 1, run_=0)
    b = run(1, 300.0, 1, run_=1)
    c = run(1, 300.0, 1, seed=SEED + 1)
    assert a.params["rig"] == b.params["rig"]
    assert a.params["rig"] != c.params["rig"]
    assert not np.array_equal(a.samples.torque, b.samples.torque)
    # the same physical rig: the noise-free physics is the same up to the sampling jitter
    assert rms(a.truth.torque - b.truth.torque) < 50.0
    # the rig's parameters sit a few % around the data sheet
    assert abs(a.params["rig"]["f_c"] / 2352.66 - 1) < 0.08
    assert abs(c.params["rig"]["I"] / 6685.166 - 1) < 0.06


def test_same_noise_realisation_across_effects():
    nom = run(1, 300.0, 1)
    other = run(1, 300.0, 1, effects=eff("stribeck", "gaussian"))
    assert np.array_equal(nom.truth.t_sample, other.truth.t_sample)
    assert rms(other.truth.torque - nom.truth.torque) > 100.0
    for meas, clean, step in (("torque", "torque_reading_clean", S100.torque_res),
                              ("torque_load", "torque_load_reading_clean", S100.torque_load_res),
                              ("qd", "qd_reading_clean", S100.tacho_res)):
        na = nom.samples[meas] - nom.truth[clean]
        nb = other.samples[meas] - other.truth[clean]
        assert np.max(np.abs(na - nb)) <= step * (1 + 1e-6) + 1e-9, meas


# ---------------------------------------------------------------------------------------------
# metadata and stated sensors
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("case", [(1, 3000.0, 1), (2, 300.0, -1), (3, None, 1)])
def test_meta_passes_validation_and_is_blind(case):
    r = run(*case, effects=eff("backlash", "smooth"))
    assert validate_meta(r.meta, "x") is r.meta
    assert r.meta["scheme"] == case[0] and r.meta["direction"] == case[2]
    assert r.meta["motor_speed_rpm"] == case[1]
    assert r.meta["reduction"] == 11000.0 and r.meta["source"] == "emulator"
    assert r.meta["sample_rate_hz"] == 100.0
    text = json.dumps(r.meta)
    for name in R.EFFECT_FORMS:
        assert name not in text
    assert "smooth" not in text
    for ch in ("q", "u", "torque", "torque_load", "qd"):
        assert set(r.meta["sensors"][ch]) == {"resolution", "noise_sd", "lag_s"}


def test_stated_torque_lag():
    s = R.SensorSpec(sample_rate_hz=200.0, torque_lag_s=0.02)
    r = run(1, 3000.0, 1, sensors=s)
    tau_aa = 1.3617 / (2 * math.pi * 0.25 * 200.0)
    assert r.meta["sensors"]["torque"]["lag_s"] == pytest.approx(tau_aa + 0.02, rel=1e-9)
    assert r.meta["sensors"]["torque_load"]["lag_s"] == pytest.approx(tau_aa, rel=1e-9)
    s0 = R.SensorSpec(sample_rate_hz=200.0, torque_lag_s=0.015, aa_fraction=0.0)
    r0 = run(1, 3000.0, 1, sensors=s0)
    assert r0.meta["sensors"]["torque"]["lag_s"] == 0.015


@pytest.mark.parametrize("fs,lag", [(100.0, 0.05), (1000.0, 0.0), (20.0, 0.01)])
def test_stated_torque_lag_is_true(fs, lag):
    """On the slow load ramp, the clean torque reading is the true torque delayed by the stated
    lag (estimated from the difference over the ramp's slope)."""
    s = R.SensorSpec(sample_rate_hz=fs, torque_lag_s=lag)
    r = run(1, 3000.0, 1, sensors=s)
    tr = r.truth
    m = ((tr.phase == "load") & (tr.t > tr.t[tr.phase == "load"].min() + 2.0)
         & (tr.t < tr.t[tr.phase == "load"].max() - 2.0)).to_numpy()
    slope = 120e3 / 40.0
    p = r.params["rig"]   # the transducer's (unstated) gain and non-linearity, known to the test
    x = tr.torque[m] / p["torque_fs"]
    ideal = (tr.torque[m] * (1 + p["torque_gain_tempco"] * (tr.temp_joint[m] - 20.0))
             + p["torque_inl"] * p["torque_fs"] * (x ** 3 - x))
    est = np.median((ideal - tr.torque_reading_clean[m]) / slope)
    stated = r.meta["sensors"]["torque"]["lag_s"]
    assert abs(est - stated) < 0.02 * stated + 3e-4


@pytest.mark.parametrize("step_deg", [0.001, 0.01, 0.02])
def test_encoder_step_visible_in_q(step_deg):
    s = R.SensorSpec(sample_rate_hz=100.0, encoder_res_deg=step_deg)
    r = run(1, 3000.0, 1, sensors=s)
    step = math.radians(step_deg)
    assert r.meta["sensors"]["q"]["resolution"] == pytest.approx(step, rel=1e-12)
    k = r.samples.q.to_numpy() / step
    assert np.max(np.abs(k - np.round(k))) < 1e-6
    d = np.abs(np.diff(r.samples.q.to_numpy()))
    assert np.min(d[d > 0]) == pytest.approx(step, rel=1e-6)
    # the reading stays within one step of the true angle
    assert np.max(np.abs(r.samples.q - r.truth.q)) < step * 1.05 + 1e-5
    ku = r.samples.u.to_numpy() / r.meta["sensors"]["u"]["resolution"]
    assert np.max(np.abs(ku - np.round(ku))) < 1e-3


@pytest.mark.parametrize("sd", [100.0, 400.0])
def test_torque_noise_matches_stated(sd):
    s = R.SensorSpec(sample_rate_hz=100.0, torque_noise=sd)
    r = run(2, 300.0, -1, sensors=s)
    stated = r.meta["sensors"]["torque"]
    assert stated["noise_sd"] == sd
    noise = r.samples.torque - r.truth.torque_reading_clean
    expect = math.sqrt(sd ** 2 + stated["resolution"] ** 2 / 12)
    assert np.std(noise) == pytest.approx(expect, rel=0.05)
    assert abs(np.mean(noise)) < 5 * expect / math.sqrt(len(noise))
    ln = r.samples.torque_load - r.truth.torque_load_reading_clean
    assert np.std(ln) == pytest.approx(r.meta["sensors"]["torque_load"]["noise_sd"], rel=0.05)
    tq = r.samples.qd - r.truth.qd_reading_clean
    assert np.std(tq) == pytest.approx(r.meta["sensors"]["qd"]["noise_sd"], rel=0.05)


# ---------------------------------------------------------------------------------------------
# physics against the paper
# ---------------------------------------------------------------------------------------------

def _gravity(p, q):
    return 9.81 * (p["mr_x"] * np.sin(q) + p["mr_y"] * np.cos(q))


@pytest.mark.parametrize("speed,direction", [(3000.0, 1), (3000.0, -1), (300.0, 1), (300.0, -1)])
def test_steady_sliding_friction_is_coulomb_plus_viscous(speed, direction):
    r = run(1, speed, direction)
    p = r.params["rig"]
    tr, sm = r.truth, r.samples
    w = direction * speed * 2 * math.pi / 60 / 11000
    # truth, idle at constant speed before loading
    m = ((tr.t > 2.8) & (tr.t < 3.5)).to_numpy()
    pred = p["f_c"] * np.sign(tr.qd[m]) + p["f_v"] * tr.qd[m]
    assert np.max(np.abs(tr.friction[m] - pred)) < 0.01 * p["f_c"]
    assert np.median(tr.qd[m]) == pytest.approx(w, rel=0.01)
    # measured: T - tau_L - gravity along the whole load ramp = f_c sgn + f_v v within a few %
    for phase in ("load", "unload"):
        mm = (sm.phase == phase).to_numpy()
        f_meas = np.mean(sm.torque[mm] - sm.torque_load[mm] - _gravity(p, sm.q[mm]))
        f_pred = np.mean(p["f_c"] * np.sign(sm.qd[mm]) + p["f_v"] * sm.qd[mm])
        assert f_meas == pytest.approx(f_pred, rel=0.03), phase
        assert abs(f_meas) > 2000.0


def test_output_equation_balances_on_truth():
    for case in [(1, 3000.0, -1), (3, None, 1)]:
        r = run(*case)
        p, tr = r.params["rig"], r.truth
        res = (tr.torque - tr.torque_load - tr.gravity - tr.friction - tr.ripple_torque
               - tr.disturbance_torque + tr.appendage_torque - p["I"] * tr.qdd)
        assert rms(res) < 5.0
        assert np.allclose(tr.gravity, _gravity(p, tr.q), atol=1e-6)


@pytest.mark.parametrize("scheme", [1, 2])
def test_torque_reaches_rated_and_twist_size(scheme):
    r = run(scheme, 3000.0, 1)
    p, tr, sm = r.params["rig"], r.truth, r.samples
    assert tr.torque_cmd.max() == pytest.approx(120e3)
    assert 118e3 < tr.torque.max() < 126e3
    assert 118e3 < sm.torque.max() < 127e3
    i = int(np.argmax(tr.torque.to_numpy()))
    tw = tr.twist.iloc[i]
    assert 0.38 < math.degrees(tw) < 0.56   # "about half a degree at 120 kN m"
    # twist follows the three-segment stiffness: the torque / stiffness sizes
    d1 = p["T1"] / p["K1"]
    d2 = d1 + (p["T2"] - p["T1"]) / p["K2"]
    expect = d2 + (tr.torque_elastic.iloc[i] - p["T2"]) / p["K3"]
    assert tw == pytest.approx(expect, rel=1e-3)
    # measured twist agrees within two encoder steps at the hold
    m = (sm.phase == "hold").to_numpy() & (tr.torque > 115e3).to_numpy()
    step = math.radians(S100.encoder_res_deg)
    assert abs(np.median(sm.u[m] - sm.q[m]) - np.median(tr.twist[m])) < 2 * step
    # order of magnitude against Eq. 5 with one secant stiffness ~1.4e7 N m/rad
    assert 1.0e7 < tr.torque.iloc[i] / tw < 2.0e7


@pytest.mark.parametrize("case", [(1, 3000.0, 1), (1, 300.0, -1), (2, 3000.0, -1),
                                  (2, 300.0, 1)])
def test_load_resists_the_motion(case):
    r = run(*case)
    tr, sm = r.truth, r.samples
    m = (sm.phase.isin(["load", "hold", "unload"]) & (sm.torque_cmd.abs() > 5e3)).to_numpy()
    assert m.sum() > 100
    assert np.all(np.sign(sm.torque_load[m]) == case[2])
    assert np.all(np.sign(tr.qd[m]) == case[2])
    assert np.all(np.sign(sm.torque[m]) == case[2])
    # the dynamometer follows its set point within Table 11's +-2 kN m
    assert np.max(np.abs(tr.torque_load[m] - tr.torque_cmd[m])) < 2e3


@pytest.mark.parametrize("direction", [1, -1])
def test_scheme3_fourier_motion_with_velocity_load(direction):
    r = run(3, None, direction, periods=2)
    tr, sm = r.truth, r.samples
    assert sm.t.iloc[-1] == pytest.approx(2 * 20.0 + 2.0, abs=0.02)
    assert set(sm.phase.unique()) == {"idle", "excite"}
    assert np.max(np.abs(tr.qd)) < 3000 * 2 * math.pi / 60 / 11000 * 1.02
    assert np.max(np.abs(tr.q)) < math.pi
    assert np.sum(np.diff(np.sign(tr.qd[tr.phase == "excite"])) != 0) >= 4  # reversals
    m = (tr.qd.abs() > 0.005).to_numpy()
    assert np.all(np.sign(tr.torque_load[m]) == np.sign(tr.qd[m]))
    assert 40e3 < tr.torque_load.abs().max() < 120e3
    # the direction mirrors the trajectory
    other = run(3, None, -direction, periods=2)
    assert np.corrcoef(tr.q, other.truth.q)[0, 1] < -0.99


def test_temperature_starts_at_argument_and_evolves_physically():
    hot = run(1, 300.0, 1, temp=60.0)
    cold = run(1, 300.0, 1, temp=15.0)
    for r, t0 in ((hot, 60.0), (cold, 15.0)):
        assert r.truth.temp_joint.iloc[0] == pytest.approx(t0)
        assert abs(r.samples.temp_joint.iloc[0] - t0) < 0.2
    amb = hot.params["rig"]["T_amb"]
    assert hot.truth.temp_joint.iloc[-1] < 60.0 - 0.05          # cools towards ambient
    if amb > 15.5:
        assert cold.truth.temp_joint.iloc[-1] > 15.0                 # warms towards ambient
    assert np.all(np.abs(np.diff(hot.truth.temp_joint)) < 0.01)  # slowly
    # nominal friction does not depend on temperature
    for r in (hot, cold):
        p, tr = r.params["rig"], r.truth
        m = ((tr.t > 2.8) & (tr.t < 3.5)).to_numpy()
        assert np.max(np.abs(tr.friction[m] - p["f_c"] - p["f_v"] * tr.qd[m])) < 0.01 * p["f_c"]


# ---------------------------------------------------------------------------------------------
# effects
# ---------------------------------------------------------------------------------------------

ALL_FORMS = [(n, f) for n, forms in R.EFFECT_FORMS.items() for f in forms]
READING_ONLY = {"torque_offset", "time_delay", "sensor_drift"}


@pytest.mark.parametrize("name", list(R.EFFECT_FORMS))
def test_scale_zero_is_nominal(name):
    nom = run(3, None, 1)
    for form in R.EFFECT_FORMS[name][:2]:
        r = run(3, None, 1, effects=eff(name, form, 0.0))
        pd.testing.assert_frame_equal(r.samples, nom.samples, check_exact=True)
        pd.testing.assert_frame_equal(r.truth, nom.truth, check_exact=True)


CASE_FOR = {
    "stribeck": (1, 300.0, 1, 25.0),
    "load_dependent_friction": (1, 3000.0, 1, 25.0),
    "temperature_friction": (1, 3000.0, -1, 60.0),
    "asymmetric_friction": (1, 3000.0, 1, 25.0),
}


@pytest.mark.parametrize("name,form", [(n, f) for n, f in ALL_FORMS if n in CASE_FOR])
def test_friction_effects_change_friction_and_torque_not_load(name, form):
    case = CASE_FOR[name]
    nom = run(*case)
    r = run(*case, effects=eff(name, form))
    d_fr = r.truth.friction - nom.truth.friction
    d_t = r.truth.torque - nom.truth.torque
    d_rd = r.truth.torque_reading_clean - nom.truth.torque_reading_clean
    assert rms(d_fr) > 100.0
    assert rms(d_t) > 100.0 and rms(d_rd) > 100.0
    assert rms(r.truth.torque_load - nom.truth.torque_load) < 0.2 * rms(d_t)
    assert rms(r.truth.twist - nom.truth.twist) < 1e-4       # only through T/K
    # nothing else: no hysteresis, ripple or disturbance appears
    for c in ("torque_hysteresis", "ripple_torque", "disturbance_torque", "appendage_torque"):
        assert np.all(r.truth[c] == 0.0)
    # the steady-sliding level changes (the effect is in the friction law, not a transient)
    m = (r.truth.phase.isin(["load", "hold", "unload"])).to_numpy()
    assert abs(np.mean(d_fr[m])) > 50.0 or rms(d_fr[m]) > 100.0


def test_friction_effect_shapes():
    # stribeck: larger at 300 r/min than at 3000 r/min
    lo = run(1, 300.0, 1, effects=eff("stribeck", "exponential"))
    hi = run(1, 3000.0, 1, effects=eff("stribeck", "exponential"))
    d_lo = np.mean((lo.truth.friction - run(1, 300.0, 1).truth.friction)[lo.truth.phase == "load"])
    d_hi = np.mean((hi.truth.friction - run(1, 3000.0, 1).truth.friction)[hi.truth.phase == "load"])
    assert d_lo > 200.0 and d_hi < 0.25 * d_lo
    # load-dependent Coulomb: grows with |T|, sign follows the motion
    for d in (1, -1):
        r = run(1, 3000.0, d, effects=eff("load_dependent_friction", "coulomb"))
        df = (r.truth.friction - run(1, 3000.0, d).truth.friction).to_numpy()
        big = (r.truth.torque.abs() > 100e3).to_numpy()
        small = ((r.truth.torque.abs() < 10e3) & (r.truth.qd.abs() > 0.02)).to_numpy()
        assert np.sign(np.mean(df[big])) == d
        assert abs(np.mean(df[big])) > 400.0 and abs(np.mean(df[small])) < 100.0
    # temperature: cold adds, warm removes friction (reference 35 degC)
    cold = run(1, 3000.0, 1, 15.0, effects=eff("temperature_friction", "coulomb_linear"))
    warm = run(1, 3000.0, 1, 55.0, effects=eff("temperature_friction", "coulomb_linear"))
    dc = np.mean(cold.truth.friction - run(1, 3000.0, 1, 15.0).truth.friction)
    dw = np.mean(warm.truth.friction - run(1, 3000.0, 1, 55.0).truth.friction)
    assert dc > 150.0 and dw < -150.0
    # asymmetric Coulomb: opposite signs of the change in the two directions, same magnitude sign
    ap = run(1, 3000.0, 1, effects=eff("asymmetric_friction", "coulomb"))
    an = run(1, 3000.0, -1, effects=eff("asymmetric_friction", "coulomb"))
    dp = np.mean(ap.truth.friction - run(1, 3000.0, 1).truth.friction)
    dn = np.mean(an.truth.friction - run(1, 3000.0, -1).truth.friction)
    assert dp > 200.0 and dn > 200.0   # |F| larger for +, smaller for - : F(-) = -(fc - a)
    assert np.mean(an.truth.friction) > np.mean(run(1, 3000.0, -1).truth.friction)


@pytest.mark.parametrize("name,form", [(n, f) for n, f in ALL_FORMS if n in READING_ONLY])
def test_reading_only_effects_leave_the_physics_alone(name, form):
    case = (2, 3000.0, 1, 40.0)
    s = S1K if name == "time_delay" else S100
    nom = run(*case, sensors=s)
    r = run(*case, effects=eff(name, form), sensors=s)
    phys = [c for c in nom.truth.columns if not c.endswith("_reading_clean")]
    pd.testing.assert_frame_equal(r.truth[phys], nom.truth[phys], check_exact=True)
    changed = {"torque_offset": "torque", "time_delay": "torque"}.get(name)
    if name == "sensor_drift":
        changed = {"torque_load": "torque_load", "q_encoder": "q", "tacho": "qd"}[form]
    untouched = [c for c in nom.samples.columns if c not in (changed, "torsion")]
    pd.testing.assert_frame_equal(r.samples[untouched], nom.samples[untouched], check_exact=True)
    d = (r.samples[changed] - nom.samples[changed]).to_numpy()
    size = {"torque": 50.0, "torque_load": 50.0, "q": 1.0e-4, "qd": 3e-4}[changed]
    assert rms(d) > size
    if name == "time_delay":
        # an extra lag of ~30 ms beyond the stated one, on the clean reading
        a = r.truth.torque_reading_clean.to_numpy()
        b = nom.truth.torque_reading_clean.to_numpy()
        dbdt = np.gradient(b, r.truth.t.to_numpy())
        m = np.abs(dbdt) > 5e3
        lag = np.sum((b - a)[m] * dbdt[m]) / np.sum(dbdt[m] ** 2)
        assert 0.02 < lag < 0.04
        assert r.meta["sensors"]["torque"] == nom.meta["sensors"]["torque"]
    if name == "torque_offset" and form == "constant":
        assert np.median(d) == pytest.approx(400.0, abs=5.0)
    if name == "torque_offset" and form == "drift":
        assert abs(np.mean(d[:200])) < 30.0 and np.mean(d[-200:]) > 300.0


@pytest.mark.parametrize("form", R.EFFECT_FORMS["hysteresis"])
def test_hysteresis_changes_twist_with_a_loop(form):
    nom = run(1, 300.0, 1)
    r = run(1, 300.0, 1, effects=eff("hysteresis", form))
    assert np.any(r.truth.torque_hysteresis != 0.0)
    assert rms(r.truth.twist - nom.truth.twist) > 5e-5
    assert np.all(r.truth.friction == r.truth.friction)  # defined

    def loop_width(x):
        tr = x.truth
        widths = []
        for level in (40e3, 60e3, 80e3):
            up = tr[(tr.phase == "load")].sort_values("torque")
            dn = tr[(tr.phase == "unload")].sort_values("torque")
            tw_up = np.interp(level, up.torque, up.twist)
            tw_dn = np.interp(level, dn.torque, dn.twist)
            widths.append(tw_dn - tw_up)
        return np.mean(widths)

    assert loop_width(r) > 1.5e-4               # ~2 H / K, a few encoder steps of 0.01 deg
    assert abs(loop_width(nom)) < 3e-5          # only the mesh damping D*Delta'
    # the friction law is untouched
    m = ((nom.truth.t > 2.8) & (nom.truth.t < 3.5)).to_numpy()
    assert np.allclose(r.truth.friction[m], nom.truth.friction[m], rtol=0, atol=20.0)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["backlash"])
def test_backlash_is_a_dead_zone_in_the_twist(form):
    b = 1.2e-4
    shift = {"sharp": (b, -b), "smooth": (b, -b), "offcentre": (1.5 * b, -0.5 * b)}[form]
    for d, expect in zip((1, -1), shift):
        nom = run(1, 3000.0, d)
        r = run(1, 3000.0, d, effects=eff("backlash", form))
        m = (r.truth.phase == "load").to_numpy()
        dtw = np.median((r.truth.twist - nom.truth.twist)[m])
        assert dtw == pytest.approx(expect, rel=0.1)
        assert rms(r.truth.torque_load - nom.truth.torque_load) < 300.0
    # reversals in scheme 3: the torque passes zero while the twist crosses the gap
    r3 = run(3, None, 1, effects=eff("backlash", form))
    nom3 = run(3, None, 1)
    assert rms(r3.truth.twist - nom3.truth.twist) > 5e-5
    if form == "sharp":
        gap = (r3.truth.spring_deflection == 0.0).to_numpy()
        assert gap.sum() > 0
        assert np.all(np.abs(r3.truth.torque_elastic[gap]) == 0.0)


def test_gear_ripple_forms():
    nom = run(1, 3000.0, 1)
    # output-angle torque ripple: 96 cycles per output revolution, in the torque, not the twist
    r = run(1, 3000.0, 1, effects=eff("gear_ripple", "output_torque"))
    d = (r.truth.torque - nom.truth.torque).to_numpy()
    assert rms(d) > 150.0
    assert rms(r.truth.twist - nom.truth.twist) < 5e-5
    q = r.truth.q.to_numpy()
    m = (r.truth.phase == "load").to_numpy()
    c = np.abs(np.mean(d[m] * np.exp(-1j * 96.0 * q[m])))
    c_off = np.abs(np.mean(d[m] * np.exp(-1j * 83.0 * q[m])))
    assert c > 100.0 and c_off < 0.2 * c
    # output kinematic error: in the twist, 72 cycles per revolution, barely in the torque
    nom300 = run(1, 300.0, 1)
    r = run(1, 300.0, 1, effects=eff("gear_ripple", "output_kinematic"))
    dt = (r.truth.twist - nom300.truth.twist).to_numpy()
    assert rms(dt) > 1e-4
    assert rms(r.truth.torque - nom300.truth.torque) < 50.0
    # motor angle: 2 cycles per motor revolution = 100 Hz at 3000 r/min, in the torque
    nomk = run(1, 3000.0, 1, sensors=S1K)
    r = run(1, 3000.0, 1, effects=eff("gear_ripple", "motor_angle"), sensors=S1K)
    d = (r.truth.torque - nomk.truth.torque).to_numpy()
    m = (r.truth.phase == "load").to_numpy()
    spec = np.abs(np.fft.rfft(d[m] - d[m].mean()))
    f = np.fft.rfftfreq(m.sum(), 1e-3)
    assert abs(f[np.argmax(spec)] - 100.0) < 2.0
    assert rms(d) > 150.0
    # load-modulated: larger at high load
    r = run(1, 3000.0, 1, effects=eff("gear_ripple", "load_modulated"))
    d = (r.truth.ripple_torque).to_numpy()
    hi = (r.truth.torque > 100e3).to_numpy()
    lo = (r.truth.torque.abs() < 10e3).to_numpy() & (r.truth.qd > 0.02).to_numpy()
    assert rms(d[hi]) > 2.0 * rms(d[lo])


def test_periodic_disturbance_is_time_periodic():
    nom = run(1, 300.0, 1)
    r = run(1, 300.0, 1, effects=eff("periodic_disturbance", "hydraulic_cycle"))
    d = (r.truth.torque - nom.truth.torque).to_numpy()
    assert rms(d) > 150.0
    t = r.truth.t.to_numpy()
    assert np.abs(np.mean(d * np.exp(-2j * np.pi * 0.37 * t))) > 100.0
    cyc = run(1, 300.0, 1, effects=eff("periodic_disturbance", "cooler_cycle"))
    pd.testing.assert_frame_equal(cyc.truth.drop(columns=["torque_reading_clean"]),
                                  nom.truth.drop(columns=["torque_reading_clean"]))
    d = (cyc.truth.torque_reading_clean - nom.truth.torque_reading_clean).to_numpy()
    assert rms(d) > 150.0
    assert np.abs(np.mean(d * np.exp(-2j * np.pi * t / 14.0))) > 100.0
    pump = run(1, 300.0, 1, effects=eff("periodic_disturbance", "pump"), sensors=S1K)
    assert rms(pump.truth.disturbance_torque) > 200.0


@pytest.mark.parametrize("form", R.EFFECT_FORMS["position_dependent_stiffness"])
def test_position_dependent_stiffness_changes_twist_with_load(form):
    case = (1, 3000.0, 1) if form != "soft_spots" else (1, 300.0, 1)
    nom = run(*case)
    r = run(*case, effects=eff("position_dependent_stiffness", form))
    dt = (r.truth.twist - nom.truth.twist).abs().to_numpy()
    hi = (nom.truth.torque > 60e3).to_numpy()
    lo = (nom.truth.torque.abs() < 5e3).to_numpy()
    assert np.mean(dt[hi]) > 5e-5
    assert np.mean(dt[hi]) > 5.0 * np.mean(dt[lo])
    assert rms(r.truth.torque - nom.truth.torque) < 150.0


@pytest.mark.parametrize("form,f_hz", [("fixture", 9.5), ("arm", 5.2)])
def test_second_resonance_adds_a_mode(form, f_hz):
    nom = run(1, 3000.0, 1, sensors=S1K)
    r = run(1, 3000.0, 1, effects=eff("second_resonance", form), sensors=S1K)
    d = (r.truth.torque - nom.truth.torque).to_numpy()
    assert rms(d) > 150.0
    assert rms(r.truth.appendage_torque) > 150.0
    m = (r.truth.phase == "load").to_numpy()
    x = r.truth.appendage_torque.to_numpy()[m]
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(len(x))))
    f = np.fft.rfftfreq(len(x), 1e-3)
    band = (f > 2.0) & (f < 40.0)
    fpk = f[band][np.argmax(spec[band])]
    assert abs(fpk - f_hz) < 1.5


@pytest.mark.parametrize("name,form", [("torque_offset", "constant"),
                                       ("load_dependent_friction", "coulomb"),
                                       ("gear_ripple", "output_torque"),
                                       ("stribeck", "exponential"),
                                       ("asymmetric_friction", "coulomb")])
def test_contribution_roughly_linear_in_scale(name, form):
    case = (1, 300.0, 1)
    nom = run(*case)
    d1 = run(*case, effects=eff(name, form, 1.0)).truth.torque_reading_clean - \
        nom.truth.torque_reading_clean
    d2 = run(*case, effects=eff(name, form, 2.0)).truth.torque_reading_clean - \
        nom.truth.torque_reading_clean
    assert rms(d1) > 100.0
    assert rms(d2) / rms(d1) == pytest.approx(2.0, rel=0.15)


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_form_is_visible_at_scale_one(name, form):
    """At scale 1 each form moves the measured torque by ~100+ N m RMS somewhere in a small
    campaign, or (transmission effects) the twist by at least half a 0.01 deg step."""
    best_t, best_w = 0.0, 0.0
    for case in ((1, 300.0, 1, 15.0), (1, 3000.0, 1, 60.0), (3, None, 1, 25.0)):
        nom = run(*case)
        r = run(*case, effects=eff(name, form))
        best_t = max(best_t, rms(r.truth.torque_reading_clean - nom.truth.torque_reading_clean),
                     rms(r.truth.torque_load_reading_clean - nom.truth.torque_load_reading_clean))
        best_w = max(best_w, rms(r.truth.twist - nom.truth.twist),
                     rms(r.truth.q_reading_clean - nom.truth.q_reading_clean))
        if name == "sensor_drift" and form == "tacho":
            best_t = max(best_t, 1e6 * rms(r.truth.qd_reading_clean - nom.truth.qd_reading_clean))
    assert best_t > 100.0 or best_w > math.radians(0.005), (best_t, best_w)
    assert best_t < 3000.0
