"""Contract tests of validation rig L (validation_rigs/rig_l.py): run format, stated sensor
properties, determinism, seed/run semantics, effects and their scaling, Eq. 4 balance on the
truth, argument checks. Low sample rates and one excitation period keep the file fast."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pandas as pd
import pytest

from core.runfile import validate_meta, validate_samples
from validation_rigs import rig_l as R

FS = 10.0
S_LOW = R.SensorSpec(sample_rate_hz=FS)
NUMERIC = ["q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "i_m1", "i_m2", "i_m3",
           "torque_cmd"]


def run(scheme=3, rpm=None, direction=1, temp=30.0, effects=None, sensors=S_LOW, periods=1,
        seed=11, run_=0):
    return R.simulate_run(scheme, rpm, direction, temp, effects or {}, sensors=sensors,
                          periods=periods, seed=seed, run=run_)


_CACHE: dict = {}


def nominal(key):
    if key not in _CACHE:
        scheme, rpm, direction = key
        _CACHE[key] = run(scheme, rpm, direction)
    return _CACHE[key]


CASES = [(1, 300.0, 1), (2, 3000.0, -1), (3, None, 1)]


# --- interface ---------------------------------------------------------------------------------

def test_module_interface():
    assert R.SEED_IS_CAMPAIGN is True
    assert R.REDUCTION == 11000.0
    assert R.RIG_NAME == "rig_l"
    assert R.SCALE_MAX >= 1.0
    need = {"stribeck": 4, "load_dependent_friction": 2, "temperature_friction": 3,
            "gear_ripple": 3, "torque_offset": 2, "time_delay": 2, "hysteresis": 3,
            "backlash": 2, "asymmetric_friction": 2, "periodic_disturbance": 2,
            "position_dependent_stiffness": 2, "sensor_drift": 2, "second_resonance": 2}
    assert set(R.EFFECT_FORMS) == set(need)
    for name, k in need.items():
        forms = R.EFFECT_FORMS[name]
        assert isinstance(forms, tuple) and len(forms) >= k, name
        assert len(set(forms)) == len(forms)
    assert R.OUT_OF_VOCABULARY == ("periodic_disturbance", "position_dependent_stiffness",
                                   "sensor_drift", "second_resonance")
    fields = {f.name for f in dataclasses.fields(R.SensorSpec)}
    assert {"sample_rate_hz", "encoder_res_deg", "torque_noise", "torque_lag_s"} <= fields
    assert {f.name for f in dataclasses.fields(R.RigRun)} == {"samples", "meta", "truth",
                                                             "params", "noise"}
    assert R.__doc__ and "data sheet" in R.__doc__
    for name, forms in R.EFFECT_FORMS.items():      # the data sheet names every form
        for f in forms:
            assert f"``{f}``" in R.__doc__, (name, f)


# --- run format --------------------------------------------------------------------------------

@pytest.mark.parametrize("case", CASES)
def test_format_is_accepted(case):
    r = nominal(case)
    s = validate_samples(r.samples, R.RIG_NAME)
    assert list(s.columns)[0] == "t"
    validate_meta(r.meta, R.RIG_NAME)
    json.dumps(r.meta)
    for c in ["t", "phase"] + NUMERIC:
        assert c in r.samples.columns, c
    num = r.samples[["t"] + NUMERIC].to_numpy(dtype=float)
    assert np.isfinite(num).all()
    t = r.samples["t"].to_numpy()
    assert t[0] == 0.0 and np.allclose(np.diff(t), 1.0 / FS)
    m = r.meta
    assert m["scheme"] == case[0] and m["direction"] == case[2]
    assert m["reduction"] == 11000.0 and m["sample_rate_hz"] == FS
    assert m["source"] == "emulator" and m["rig"] == "rig_l" and m["temp_joint_c"] == 30.0
    assert m["motor_speed_rpm"] == case[1]
    for ch in ("q", "u", "qd", "torque", "torque_load", "temp_joint"):
        assert set(m["sensors"][ch]) == {"resolution", "noise_sd", "lag_s"}, ch
    assert set(m["sensor_units"]) >= set(NUMERIC)
    text = json.dumps(m)
    for name in R.EFFECT_FORMS:                      # blind: no effect or rig parameter names
        assert name not in text
    for key in r.params:
        assert f'"{key}"' not in text
    for frame in (r.truth, r.noise):
        assert len(frame) == len(r.samples)
        assert np.isfinite(frame.select_dtypes("number").to_numpy()).all()
    for c in ("twist", "torque", "q", "qd", "qdd", "torque_load", "gravity", "friction"):
        assert c in r.truth.columns, c
    assert np.allclose(r.truth["twist"], r.truth["u"] - r.truth["q"], rtol=0, atol=1e-15)
    for k in ("I", "k1", "k2", "f_c", "f_v", "mr_x", "mr_y"):
        assert isinstance(r.params[k], float)


def test_phases_and_load_sign():
    p1 = set(nominal((1, 300.0, 1)).samples["phase"])
    assert p1 == {"idle", "load", "hold", "unload"}
    p2 = nominal((2, 3000.0, -1)).samples["phase"]
    assert {"load", "hold"} <= set(p2)
    assert set(nominal((3, None, 1)).samples["phase"]) == {"excite"}
    # the load resists the motion: negative direction, negative load and torque
    r = nominal((2, 3000.0, -1))
    top = r.samples["t"].between(37.2, 38.8)
    assert r.samples.loc[top, "torque_cmd"].eq(-120_000.0).all()
    assert r.samples.loc[top, "torque_load"].mean() < -115_000
    assert r.samples["q"].iloc[-1] < -1.0
    r1 = nominal((1, 300.0, 1))
    assert r1.samples["torque_load"].max() > 115_000 and r1.samples["q"].iloc[-1] > 0.2
    # scheme 3 is unloaded ("0-ish" load) and the direction mirrors the trajectory
    r3 = nominal((3, None, 1))
    assert r3.samples["torque_load"].abs().max() < 2_000
    m3 = run(3, None, -1)
    assert np.corrcoef(m3.truth["q"], r3.truth["q"])[0, 1] < -0.99


# --- stated sensor properties ------------------------------------------------------------------

def test_stated_torque_noise_is_the_real_noise():
    spec = R.SensorSpec(sample_rate_hz=50.0, torque_noise=150.0)
    noisy = run(3, sensors=spec)
    clean = run(3, sensors=dataclasses.replace(spec, torque_noise=0.0))
    stated = noisy.meta["sensors"]["torque"]["noise_sd"]
    assert stated == 150.0
    added = noisy.samples["torque"] - clean.samples["torque"]
    res = noisy.meta["sensors"]["torque"]["resolution"]
    assert np.abs(added - noisy.noise["torque"]).max() <= res + 1e-9
    assert abs(added.std() / stated - 1.0) < 0.06
    assert abs(noisy.noise["torque"].std() / stated - 1.0) < 0.06
    # the load cell likewise
    assert abs(noisy.noise["torque_load"].std() / noisy.meta["sensors"]["torque_load"]["noise_sd"]
               - 1.0) < 0.06


def _best_lag(meas, t, ref, lags):
    err = [np.mean((meas - np.interp(t - L, t, ref)) ** 2) for L in lags]
    return lags[int(np.argmin(err))]


@pytest.mark.parametrize("lag", [0.0, 0.05])
def test_stated_torque_lag_is_applied(lag):
    spec = R.SensorSpec(sample_rate_hz=200.0, torque_noise=0.0, torque_lag_s=lag)
    r = run(3, sensors=spec)
    assert r.meta["sensors"]["torque"]["lag_s"] == lag
    t = r.samples["t"].to_numpy()
    lags = np.arange(0.0, 0.1, 0.0005)
    est = _best_lag(r.samples["torque"].to_numpy(), t, r.truth["torque"].to_numpy(), lags)
    assert abs(est - lag) <= 0.0015


def test_stated_velocity_lags():
    spec = R.SensorSpec(sample_rate_hz=200.0)
    r = run(3, sensors=spec)
    t = r.samples["t"].to_numpy()
    lags = np.arange(0.0, 0.15, 0.0005)
    st = r.meta["sensors"]
    est_qd = _best_lag(r.samples["qd"].to_numpy(), t, r.truth["qd"].to_numpy(), lags)
    assert abs(est_qd - st["qd"]["lag_s"]) <= 0.006
    est_ud = _best_lag(r.samples["ud"].to_numpy(), t, r.truth["ud"].to_numpy(), lags)
    assert abs(est_ud - st["ud"]["lag_s"]) <= 0.0015
    # qd is the windowed difference of the encoder: a multiple of its stated resolution
    k = r.samples["qd"] / st["qd"]["resolution"]
    assert np.allclose(k, np.round(k), atol=1e-6)


@pytest.mark.parametrize("res_deg", [0.01, 0.005])
def test_stated_encoder_step_is_the_real_step(res_deg):
    r = run(1, 300.0, 1, sensors=R.SensorSpec(sample_rate_hz=FS, encoder_res_deg=res_deg))
    step = r.meta["sensors"]["q"]["resolution"]
    assert step == pytest.approx(math.radians(res_deg), rel=1e-12)
    k = r.samples["q"].to_numpy() / step
    assert np.allclose(k, np.round(k), atol=1e-9)
    d = np.abs(np.diff(r.samples["q"].to_numpy()))
    assert d[d > 0].min() == pytest.approx(step, rel=1e-9)
    # the reading is the true angle to within one step (sub-step eccentricity included)
    bound = 0.5 * step + 2.0 * r.params["encoder_ecc_rad"] + 1e-12
    assert np.abs(r.samples["q"] - r.truth["q"]).max() <= bound
    ustep = r.meta["sensors"]["u"]["resolution"]
    ku = r.samples["u"].to_numpy() / ustep
    assert np.allclose(ku, np.round(ku), atol=1e-6)


def test_torque_reading_follows_the_truth():
    r = run(3, sensors=R.SensorSpec(sample_rate_hz=FS, torque_noise=0.0, torque_lag_s=0.0))
    d = r.samples["torque"] - r.truth["torque"]
    assert np.sqrt(np.mean(d ** 2)) < 120.0     # ADC averaging + process ripple only


# --- determinism and the seed/run semantics --------------------------------------------------

def _frames_equal(a, b):
    for x, y in ((a.samples, b.samples), (a.truth, b.truth), (a.noise, b.noise)):
        pd.testing.assert_frame_equal(x, y, check_exact=True)


def test_deterministic():
    a = run(2, 300.0, 1, effects={"stribeck": {"scale": 1.0}})
    b = run(2, 300.0, 1, effects={"stribeck": {"scale": 1.0}})
    _frames_equal(a, b)
    assert a.params == b.params and a.meta == b.meta


def test_same_seed_other_run_same_rig_other_noise():
    a = run(3, seed=5, run_=0)
    b = run(3, seed=5, run_=1)
    assert a.params == b.params
    assert not np.allclose(a.noise["torque"], b.noise["torque"])
    assert not a.samples["torque"].equals(b.samples["torque"])
    # same rig: the trajectories agree closely (only the process disturbances differ)
    assert np.abs(a.truth["q"] - b.truth["q"]).max() < 1e-4
    c = run(3, seed=6, run_=0)
    assert c.params != a.params
    for k in ("I", "f_c", "k1"):
        assert c.params[k] != a.params[k]


def test_params_are_drawn_near_the_data_sheet():
    for seed in range(6):
        p = run(3, seed=seed).params
        assert abs(p["I"] / 6685 - 1) < 0.1
        assert abs(p["f_c"] / 2353 - 1) < 0.12
        assert abs(p["f_v"] / 8683 - 1) < 0.12
        assert 0.7e7 < p["k1"] < 1.1e7 and 1.3e7 < p["k2"] < 1.9e7


# --- effects -----------------------------------------------------------------------------------

def test_scale_zero_is_nominal_bit_for_bit():
    zero = {n: {"form": f[-1], "scale": 0.0} for n, f in R.EFFECT_FORMS.items()}
    for case in CASES:
        _frames_equal(run(*case, effects=zero), nominal(case))
    no_scale = {n: {"form": f[0]} for n, f in R.EFFECT_FORMS.items()}
    _frames_equal(run(3, effects=no_scale), nominal((3, None, 1)))


def test_noise_is_independent_of_effects():
    everything = {n: {"form": f[1], "scale": 1.0} for n, f in R.EFFECT_FORMS.items()}
    for case in CASES:
        a = run(*case, effects=everything)
        pd.testing.assert_frame_equal(a.noise, nominal(case).noise, check_exact=True)
        assert not a.samples["torque"].equals(nominal(case).samples["torque"])


def test_scale_is_clamped():
    def e(s):
        return {"stribeck": {"form": "gaussian", "scale": s}, "torque_offset": {"scale": s}}
    big = run(3, effects=e(10.0 * R.SCALE_MAX))
    top = run(3, effects=e(R.SCALE_MAX))
    _frames_equal(big, top)
    assert not run(3, effects=e(R.SCALE_MAX / 2)).samples.equals(top.samples)


SENSOR_ONLY = {("torque_offset", None), ("time_delay", None), ("sensor_drift", None),
               ("periodic_disturbance", "torque_pickup")}


@pytest.mark.parametrize("name", list(R.EFFECT_FORMS))
def test_every_form_changes_the_samples(name):
    for form in R.EFFECT_FORMS[name]:
        changed_samples = False
        changed_truth = 0.0
        for case in (CASES[0], CASES[2]):
            r = run(*case, effects={name: {"form": form, "scale": 1.0}})
            b = nominal(case)
            d = (r.samples[NUMERIC] - b.samples[NUMERIC]).abs().to_numpy()
            changed_samples |= bool((d > 0).any())
            changed_truth = max(changed_truth,
                                float((r.truth["torque"] - b.truth["torque"]).abs().max()),
                                1e7 * float((r.truth["twist"] - b.truth["twist"]).abs().max()))
            pd.testing.assert_frame_equal(r.noise, b.noise, check_exact=True)
        assert changed_samples, (name, form)
        if (name, None) in SENSOR_ONLY or (name, form) in SENSOR_ONLY:
            assert changed_truth == 0.0, (name, form)     # a sensor effect leaves the physics
        else:
            assert changed_truth > 5.0, (name, form)     # N·m (or N·m-equivalent twist)


def test_contributions_scale_linearly():
    b = nominal((1, 300.0, 1))

    def delta(name, form, s, col="torque", frame="samples"):
        r = run(1, 300.0, 1, effects={name: {"form": form, "scale": s}},
                sensors=dataclasses.replace(S_LOW, torque_noise=0.0, load_noise=0.0))
        c = run(1, 300.0, 1, sensors=dataclasses.replace(S_LOW, torque_noise=0.0, load_noise=0.0))
        return getattr(r, frame)[col] - getattr(c, frame)[col]

    d1, d2 = delta("torque_offset", "drift", 1.0), delta("torque_offset", "drift", 2.0)
    assert np.abs(d2 - 2 * d1).max() <= 2 * b.meta["sensors"]["torque"]["resolution"] + 1e-9
    f1 = delta("stribeck", "exponential", 1.0, "friction", "truth")
    f2 = delta("stribeck", "exponential", 2.0, "friction", "truth")
    late = b.truth["t"] > 10
    ratio = f2[late].mean() / f1[late].mean()
    assert 1.8 < ratio < 2.2
    l1 = delta("load_dependent_friction", "coulomb", 1.0, "friction", "truth")
    l3 = delta("load_dependent_friction", "coulomb", 3.0, "friction", "truth")
    assert 2.7 < l3[late].mean() / l1[late].mean() < 3.3


# --- physics -----------------------------------------------------------------------------------

@pytest.mark.parametrize("case", CASES)
def test_eq4_balance_on_the_nominal_truth(case):
    tr = nominal(case).truth
    I = nominal(case).params["I"]
    lhs = I * tr["qdd"]
    rhs = tr["torque"] - tr["torque_load"] - tr["gravity"] - tr["friction"]
    scale = max(1.0, float(tr["torque"].abs().max()))
    assert np.abs(lhs - rhs).max() <= 1e-12 * scale * 100
    assert (tr["torque_ext"] == 0.0).all()
    g = 9.81 * (nominal(case).params["mr_x"] * np.sin(tr["q"])
                + nominal(case).params["mr_y"] * np.cos(tr["q"]))
    assert np.allclose(tr["gravity"], g, rtol=1e-12, atol=1e-9)


def test_balance_holds_with_external_effects():
    for name, form in (("periodic_disturbance", "output_sine"),
                       ("second_resonance", "heavy_branch")):
        r = run(3, effects={name: {"form": form, "scale": 1.0}})
        tr = r.truth
        gap = tr["torque"] - tr["torque_load"] - tr["gravity"] - tr["friction"] \
            + tr["torque_ext"] - r.params["I"] * tr["qdd"]
        assert np.abs(gap).max() < 1e-8
        assert tr["torque_ext"].abs().max() > 20.0


def test_friction_is_coulomb_viscous_in_steady_sliding():
    r = nominal((1, 300.0, 1))
    tr, p = r.truth, r.params
    steady = (tr["t"] > 5) & (tr["qd"].abs() > 1e-3)
    model = p["f_c"] * np.sign(tr["qd"]) + p["f_v"] * tr["qd"]
    assert np.abs(tr["friction"][steady] - model[steady]).max() < 60.0
    # twist at the rated load: about half a degree
    top = tr["torque"] > 119_000
    assert 0.3 < math.degrees(tr["twist"][top].mean()) < 0.7


# --- argument checks ---------------------------------------------------------------------------

def _spec(**kw):
    return dataclasses.replace(S_LOW, **kw)


BAD = [
    (dict(sensors=_spec(sample_rate_hz=float("nan"))), "sample_rate_hz"),
    (dict(sensors=_spec(sample_rate_hz=float("inf"))), "sample_rate_hz"),
    (dict(sensors=_spec(sample_rate_hz=-10.0)), "sample_rate_hz"),
    (dict(sensors=_spec(sample_rate_hz=0.0)), "sample_rate_hz"),
    (dict(sensors=_spec(torque_noise=-1.0)), "torque_noise"),
    (dict(sensors=_spec(torque_noise=float("nan"))), "torque_noise"),
    (dict(sensors=_spec(torque_lag_s=-0.01)), "torque_lag_s"),
    (dict(sensors=_spec(torque_lag_s=float("inf"))), "torque_lag_s"),
    (dict(sensors=_spec(encoder_res_deg=0.0)), "encoder_res_deg"),
    (dict(sensors=_spec(encoder_res_deg=float("nan"))), "encoder_res_deg"),
    (dict(sensors="fast"), "sensors"),
    (dict(effects={"coulomb_slip": {"scale": 1.0}}), "coulomb_slip"),
    (dict(effects={"stribeck": {"form": "cubic", "scale": 1.0}}), "cubic"),
    (dict(effects={"stribeck": {"scale": -0.5}}), "scale"),
    (dict(effects={"stribeck": {"scale": float("nan")}}), "scale"),
    (dict(effects={"backlash": {"scale": float("inf")}}), "scale"),
    (dict(effects={"backlash": {"scale": "1"}}), "scale"),
    (dict(effects={"backlash": {"scale": 1.0, "gain": 2}}), "gain"),
    (dict(effects={"backlash": 1.0}), "backlash"),
    (dict(effects=["stribeck"]), "effects"),
    (dict(scheme=4), "scheme"),
    (dict(scheme=0), "scheme"),
    (dict(scheme="1"), "scheme"),
    (dict(scheme=True), "scheme"),
    (dict(scheme=1, rpm=None), "motor_speed_rpm"),
    (dict(scheme=1, rpm=float("nan")), "motor_speed_rpm"),
    (dict(scheme=1, rpm=-300.0), "motor_speed_rpm"),
    (dict(scheme=2, rpm=9000.0), "motor_speed_rpm"),
    (dict(scheme=3, rpm=300.0), "motor_speed_rpm"),
    (dict(direction=0), "direction"),
    (dict(direction=2), "direction"),
    (dict(temp=float("nan")), "temp_joint_c"),
    (dict(temp=500.0), "temp_joint_c"),
    (dict(periods=0), "periods"),
    (dict(periods=1.5), "periods"),
    (dict(seed=-1), "seed"),
    (dict(seed=1.0), "seed"),
    (dict(run_=-1), "run"),
]


@pytest.mark.parametrize("kw,culprit", BAD, ids=[c + str(i) for i, (_, c) in enumerate(BAD)])
def test_bad_arguments_raise_naming_the_culprit(kw, culprit):
    args = dict(scheme=3, rpm=None, direction=1, temp=30.0, effects=None, sensors=S_LOW,
                periods=1, seed=1, run_=0)
    args.update(kw)
    if args["scheme"] in (1, 2) and "rpm" not in kw:
        args["rpm"] = 300.0
    with pytest.raises(ValueError, match=culprit):
        R.simulate_run(args["scheme"], args["rpm"], args["direction"], args["temp"],
                       args["effects"], sensors=args["sensors"], periods=args["periods"],
                       seed=args["seed"], run=args["run_"])
