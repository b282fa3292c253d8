"""Contract tests of validation rig J (validation_rigs/rig_j.py).

Short runs only (scheme 3 with one period at 10 Hz, a few scheme-1/2 runs at 10 Hz)."""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from validation_rigs import rig_j as R

FS = 10.0
SEED = 11
TEMP = 40.0

SAMPLE_COLUMNS = ["t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "phase",
                  "i_m1", "i_m2", "i_m3", "w_m1", "w_m2", "w_m3"]
TRUTH_COLUMNS = ["t", "q", "qd", "u", "ud", "twist", "twist_rate", "torque", "torque_load",
                 "torque_true", "torque_load_true", "temp_joint"]
META_KEYS = ["scheme", "rig", "source", "reduction", "seed", "run", "motor_speed_rpm", "direction",
             "sample_rate_hz", "duration_s", "temp_joint_c", "periods", "sensors"]
ALL_FORMS = [(name, form) for name, forms in R.EFFECT_FORMS.items() for form in forms]


def sens(**kw) -> R.SensorSpec:
    kw.setdefault("sample_rate_hz", FS)
    return R.SensorSpec(**kw)


def run3(effects=None, *, seed=SEED, run=0, direction=1, sensors=None, periods=1):
    return R.simulate_run(3, None, direction, TEMP, effects or {}, seed=seed,
                          sensors=sensors or sens(), periods=periods, run=run)


@pytest.fixture(scope="module")
def nominal3():
    return run3()


@pytest.fixture(scope="module")
def nominal1():
    return R.simulate_run(1, 300, 1, TEMP, {}, seed=SEED, sensors=sens())


@pytest.fixture(scope="module")
def nominal2():
    return R.simulate_run(2, 3000, -1, TEMP, {}, seed=SEED, sensors=sens())


# ------------------------------------------------------------------ constants
def test_constants_and_forms():
    assert R.SEED_IS_CAMPAIGN is True
    assert R.REDUCTION == 11000.0
    assert R.RIG_NAME == "validation-rig-J"
    minimum = {"stribeck": 4, "temperature_friction": 3, "load_dependent_friction": 2,
               "asymmetric_friction": 3, "gear_ripple": 3, "backlash": 2, "hysteresis": 3,
               "torque_offset": 2, "time_delay": 2}
    for name, n in minimum.items():
        assert len(R.EFFECT_FORMS[name]) >= n, name
    assert set(R.OUT_OF_VOCABULARY) == {"periodic_disturbance", "position_dependent_stiffness",
                                        "sensor_drift", "second_resonance"}
    assert len(R.OUT_OF_VOCABULARY) == 4
    for name in R.OUT_OF_VOCABULARY:
        assert len(R.EFFECT_FORMS[name]) >= 2
    assert set(R.EFFECT_FORMS) == set(minimum) | set(R.OUT_OF_VOCABULARY)
    for forms in R.EFFECT_FORMS.values():
        assert isinstance(forms, tuple) and len(set(forms)) == len(forms)
        assert all(isinstance(f, str) for f in forms)
    st = R.EFFECT_FORMS["stribeck"]
    assert {"exponential", "gaussian", "lorentzian"} <= set(st)
    spec = R.SensorSpec()
    assert (spec.sample_rate_hz, spec.encoder_res_deg, spec.torque_noise, spec.torque_lag_s) == \
        (1000.0, 0.01, 150.0, 0.0)


# ------------------------------------------------------------------ shapes, meta, phases
@pytest.mark.parametrize("fixture", ["nominal1", "nominal2", "nominal3"])
def test_columns_meta_phases(fixture, request):
    r = request.getfixturevalue(fixture)
    assert isinstance(r, R.RigRun)
    assert list(r.samples.columns[:len(SAMPLE_COLUMNS)]) == SAMPLE_COLUMNS
    for c in TRUTH_COLUMNS:
        assert c in r.truth.columns
    n = len(r.samples)
    assert len(r.truth) == n
    assert np.array_equal(r.samples.t.to_numpy(), np.arange(n) / FS)
    assert np.array_equal(r.truth.t.to_numpy(), r.samples.t.to_numpy())
    numeric = [c for c in SAMPLE_COLUMNS if c != "phase"]
    assert np.isfinite(r.samples[numeric].to_numpy()).all()
    assert np.isfinite(r.truth.to_numpy(dtype=float)).all()
    assert set(r.samples.phase.unique()) <= set(R.PHASES)
    meta = r.meta
    for k in META_KEYS:
        assert k in meta, k
    assert meta["rig"] == R.RIG_NAME and meta["source"] == "emulator"
    assert meta["reduction"] == 11000.0 and meta["seed"] == SEED and meta["run"] == 0
    assert meta["sample_rate_hz"] == FS
    assert meta["duration_s"] == pytest.approx(r.samples.t.iloc[-1])
    json.dumps(meta)
    for ch in ("q", "u", "qd", "ud", "torque", "torque_load", "temp_joint"):
        d = meta["sensors"][ch]
        assert set(d) >= {"resolution", "noise_sd", "lag_s", "unit"}
        assert all(isinstance(d[k], float) for k in ("resolution", "noise_sd", "lag_s"))
    assert meta["sensors"]["torque"]["noise_sd"] == 150.0


def test_phase_sequences(nominal1, nominal2, nominal3):
    def runs(r):
        ph = r.samples.phase.to_list()
        return [p for i, p in enumerate(ph) if i == 0 or ph[i - 1] != p]
    assert runs(nominal3) == ["rest", "excite", "rest"]
    assert runs(nominal1) == ["rest", "accelerate", "hold", "load", "unload", "hold",
                              "decelerate", "rest"]
    s2 = runs(nominal2)
    assert s2[:3] == ["rest", "accelerate", "hold"] and s2[-4:] == ["unload", "hold",
                                                                      "decelerate", "rest"]
    assert s2.count("load") == 12
    assert nominal1.meta["motor_speed_rpm"] == 300.0 and nominal3.meta["motor_speed_rpm"] is None
    assert nominal2.meta["direction"] == -1
    # loading device declutched in scheme 3; rated load reached in schemes 1, 2
    assert abs(nominal3.truth.torque_load).max() == 0.0
    assert abs(nominal3.samples.torque_load).mean() < 3 * 200.0
    for r in (nominal1, nominal2):
        assert r.truth.torque_load.max() == pytest.approx(120e3, abs=2e3)
    # direction and speed: 300 r/min motor speed -> output speed
    w = 300 * 2 * math.pi / 60 / 11000
    hold = nominal1.truth[nominal1.samples.phase == "hold"]
    assert hold.ud.median() == pytest.approx(w, rel=1e-3)
    assert nominal2.truth.q.iloc[-1] < -0.5


@pytest.mark.parametrize("res", [0.001, 0.01, 0.02])
def test_metadata_states_encoder_step(res):
    r = run3(sensors=sens(encoder_res_deg=res))
    step = math.radians(res)
    assert r.meta["sensors"]["q"]["resolution"] == pytest.approx(step, rel=1e-12)
    q = r.samples.q.to_numpy()
    assert np.allclose(q / step, np.round(q / step), atol=1e-6)
    assert r.meta["sensors"]["qd"]["resolution"] == pytest.approx(step / 0.1)


def test_sample_rates_extremes():
    r = run3(sensors=sens(sample_rate_hz=1000.0))
    assert len(r.samples) == int(r.meta["duration_s"] * 1000) + 1
    r = run3(sensors=sens(sample_rate_hz=33.3))
    assert np.allclose(np.diff(r.samples.t), 1 / 33.3)


def test_stated_torque_lag_is_in_metadata():
    r0 = run3()
    r1 = run3(sensors=sens(torque_lag_s=0.05))
    assert r1.meta["sensors"]["torque"]["lag_s"] == pytest.approx(
        r0.meta["sensors"]["torque"]["lag_s"] + 0.05)
    assert r1.truth.equals(r0.truth)
    assert not np.array_equal(r1.samples.torque, r0.samples.torque)


# ------------------------------------------------------------------ determinism, seed, run
def test_determinism_and_seed_run_roles(nominal3):
    again = run3()
    pd.testing.assert_frame_equal(again.samples, nominal3.samples)
    pd.testing.assert_frame_equal(again.truth, nominal3.truth)
    other_run = run3(run=1)
    pd.testing.assert_frame_equal(other_run.truth, nominal3.truth)
    assert not np.array_equal(other_run.samples.torque, nominal3.samples.torque)
    assert other_run.meta["run"] == 1
    other_seed = run3(seed=SEED + 1)
    assert not np.array_equal(other_seed.truth.torque, nominal3.truth.torque)
    # effect constants come from the seed only
    assert R.effect_constants(SEED) == R.effect_constants(SEED)
    assert R.campaign_parameters(SEED) != R.campaign_parameters(SEED + 1)


# ------------------------------------------------------------------ effects
@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_scale_zero_is_nominal_bit_for_bit(name, form, nominal3):
    r = run3({name: {"form": form, "scale": 0.0}})
    pd.testing.assert_frame_equal(r.samples, nominal3.samples, check_exact=True)
    pd.testing.assert_frame_equal(r.truth, nominal3.truth, check_exact=True)


def test_all_effects_at_zero_scale_together(nominal3):
    eff = {name: {"scale": 0} for name in R.EFFECT_FORMS}
    r = run3(eff)
    pd.testing.assert_frame_equal(r.samples, nominal3.samples, check_exact=True)


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_form_changes_samples_at_scale_one(name, form, nominal3):
    r = run3({name: {"form": form, "scale": 1.0}})
    cols = [c for c in SAMPLE_COLUMNS if c not in ("t", "phase")]
    assert not r.samples[cols].equals(nominal3.samples[cols])
    assert np.isfinite(r.samples[cols].to_numpy()).all()


def test_missing_form_is_first_form():
    for name, forms in R.EFFECT_FORMS.items():
        if name in ("hysteresis", "backlash", "gear_ripple", "torque_offset"):
            a = run3({name: {"scale": 1.0}})
            b = run3({name: {"form": forms[0], "scale": 1.0}})
            pd.testing.assert_frame_equal(a.samples, b.samples)


def test_effects_combine():
    eff = {"stribeck": {"form": "gaussian", "scale": 1}, "backlash": {"scale": 1},
           "hysteresis": {"form": "dahl", "scale": 1}, "torque_offset": {"scale": 1},
           "time_delay": {"form": "first_order", "scale": 1},
           "second_resonance": {"scale": 1}, "gear_ripple": {"form": "kinematic", "scale": 1}}
    r = run3(eff)
    assert np.isfinite(r.samples.drop(columns="phase").to_numpy()).all()


def _lin_ratio(make, col, where="truth"):
    base = getattr(make(0.0), where)[col].to_numpy()
    d1 = getattr(make(0.05), where)[col].to_numpy() - base
    d2 = getattr(make(0.10), where)[col].to_numpy() - base
    return np.linalg.norm(d2) / np.linalg.norm(d1), np.linalg.norm(d2 - 2 * d1) / np.linalg.norm(d2)


@pytest.mark.parametrize("name,form,col,where", [
    ("stribeck", "exponential", "torque", "truth"),
    ("gear_ripple", "output_harmonics", "torque", "truth"),
    ("asymmetric_friction", "both", "torque", "truth"),
    ("periodic_disturbance", "sine", "twist", "truth"),
    ("torque_offset", "constant", "torque", "samples"),
])
def test_small_scale_linearity_scheme3(name, form, col, where):
    ratio, nonlin = _lin_ratio(lambda s: run3({name: {"form": form, "scale": s}}), col, where)
    assert ratio == pytest.approx(2.0, rel=0.06)
    assert nonlin < 0.15


def test_small_scale_linearity_hysteresis_scheme1():
    def make(s):
        return R.simulate_run(1, 3000, 1, TEMP, {"hysteresis": {"form": "bouc_wen_n1", "scale": s}},
                              seed=SEED, sensors=sens())
    ratio, nonlin = _lin_ratio(make, "twist")
    assert ratio == pytest.approx(2.0, rel=0.03)
    assert nonlin < 0.03


def test_scale_clamp():
    name = "hysteresis"
    cap = R.EFFECT_SCALE_CLAMP[name]
    a = run3({name: {"scale": cap}})
    b = run3({name: {"scale": cap * 3}})
    pd.testing.assert_frame_equal(a.samples, b.samples)


# ------------------------------------------------------------------ bad arguments
GOOD = dict(scheme=3, motor_speed_rpm=None, direction=1, temp_joint_c=25.0, effects={})


def call(**over):
    kw = dict(GOOD)
    kw.update(over)
    seed = kw.pop("seed", 1)
    sensors = kw.pop("sensors", sens())
    periods = kw.pop("periods", 1)
    run = kw.pop("run", 0)
    return R.simulate_run(kw["scheme"], kw["motor_speed_rpm"], kw["direction"], kw["temp_joint_c"],
                          kw["effects"], seed=seed, sensors=sensors, periods=periods, run=run)


@pytest.mark.parametrize("over,culprit", [
    ({"effects": {"friction_of_doom": {"scale": 1}}}, "friction_of_doom"),
    ({"effects": {"stribeck": {"form": "cubic", "scale": 1}}}, "cubic"),
    ({"effects": {"stribeck": {"form": "gaussian", "scale": 1, "size": 2}}}, "size"),
    ({"effects": {"stribeck": {"scale": -1.0}}}, "scale"),
    ({"effects": {"stribeck": {"scale": float("nan")}}}, "scale"),
    ({"effects": {"stribeck": {"scale": float("inf")}}}, "scale"),
    ({"effects": {"stribeck": {"scale": "1"}}}, "scale"),
    ({"effects": {"stribeck": {"scale": None}}}, "scale"),
    ({"effects": {"stribeck": {"scale": True}}}, "scale"),
    ({"effects": {"stribeck": {"scale": [1.0]}}}, "scale"),
    ({"effects": {"stribeck": 1.0}}, "stribeck"),
    ({"effects": [("stribeck", 1)]}, "effects"),
    ({"scheme": 4}, "scheme"),
    ({"scheme": "3"}, "scheme"),
    ({"scheme": 1, "motor_speed_rpm": None}, "motor_speed_rpm"),
    ({"scheme": 1, "motor_speed_rpm": -300}, "motor_speed_rpm"),
    ({"scheme": 2, "motor_speed_rpm": 1e6}, "motor_speed_rpm"),
    ({"scheme": 1, "motor_speed_rpm": float("nan")}, "motor_speed_rpm"),
    ({"motor_speed_rpm": 300}, "motor_speed_rpm"),
    ({"direction": 0}, "direction"),
    ({"direction": 2}, "direction"),
    ({"direction": True}, "direction"),
    ({"temp_joint_c": 500.0}, "temp_joint_c"),
    ({"temp_joint_c": float("nan")}, "temp_joint_c"),
    ({"temp_joint_c": "warm"}, "temp_joint_c"),
    ({"seed": -1}, "seed"),
    ({"seed": 1.5}, "seed"),
    ({"seed": True}, "seed"),
    ({"periods": 0}, "periods"),
    ({"periods": 1.5}, "periods"),
    ({"run": -2}, "run"),
    ({"sensors": None}, "sensors"),
    ({"sensors": sens(sample_rate_hz=0.0)}, "sample_rate_hz"),
    ({"sensors": sens(sample_rate_hz=float("nan"))}, "sample_rate_hz"),
    ({"sensors": sens(encoder_res_deg=-0.01)}, "encoder_res_deg"),
    ({"sensors": sens(torque_noise=-1.0)}, "torque_noise"),
    ({"sensors": sens(torque_lag_s=float("inf"))}, "torque_lag_s"),
])
def test_bad_arguments_raise_naming_culprit(over, culprit):
    with pytest.raises(ValueError, match=culprit):
        call(**over)


def test_non_finite_integration_names_effects():
    with pytest.raises(RuntimeError, match="stribeck"):
        R._simulate(3, None, 1, 25.0, {"stribeck": {"scale": 1}}, seed=1, sensors=sens(),
                    periods=1, h_max=0.05)


# ------------------------------------------------------------------ physics on the truth
@pytest.mark.parametrize("fixture", ["nominal1", "nominal2", "nominal3"])
def test_twist_is_u_minus_q(fixture, request):
    tr = request.getfixturevalue(fixture).truth
    assert np.array_equal(tr.twist.to_numpy(), tr.u.to_numpy() - tr.q.to_numpy())
    assert np.array_equal(tr.twist_rate.to_numpy(), tr.ud.to_numpy() - tr.qd.to_numpy())
    assert np.array_equal(tr.torque_true.to_numpy(), tr.torque.to_numpy())
    assert np.array_equal(tr.torque_load_true.to_numpy(), tr.torque_load.to_numpy())


@pytest.mark.parametrize("fixture", ["nominal1", "nominal2", "nominal3"])
def test_eq4_balance_on_nominal_truth(fixture, request):
    r = request.getfixturevalue(fixture)
    tr = r.truth
    p = R.campaign_parameters(SEED)
    grav = 9.81 * (p["mr_x"] * np.sin(tr.q) + p["mr_y"] * np.cos(tr.q))
    # exact balance with the bearing friction the rig applied
    res = p["I"] * tr.qdd - (tr.torque - tr.torque_load - grav - tr.friction)
    assert np.abs(res).max() < 1e-6
    # the friction is the paper's f_v qd + f_c sgn(qd) while sliding (presliding only
    # within a few tens of microradians after a reversal)
    qv = tr.q.to_numpy()
    qdv = tr.qd.to_numpy()
    travel = np.zeros_like(qv)   # travel since the last stop or reversal
    anchor = qv[0]
    for i in range(1, qv.size):
        if abs(qdv[i]) < 1e-4 or np.sign(qdv[i]) != np.sign(qdv[i - 1]):
            anchor = qv[i]
        travel[i] = abs(qv[i] - anchor)
    sliding = (np.abs(tr.qd) > 1.5e-3) & (travel > 1e-3)
    classical = p["f_v"] * tr.qd + p["f_c"] * np.sign(tr.qd)
    dev = (tr.friction - classical)[sliding]
    assert np.abs(dev).max() < 5.0  # N m, against 2353 N m Coulomb
    # and with a finite-difference acceleration of the sampled truth (10 Hz)
    qdd_fd = np.gradient(tr.qd.to_numpy(), tr.t.to_numpy())
    res_fd = p["I"] * qdd_fd - (tr.torque - tr.torque_load - grav - classical)
    steady = sliding & (np.abs(tr.qdd) < 0.05)
    assert np.median(np.abs(res_fd[steady])) < 25.0  # sampled ringing aliases at 10 Hz
    assert np.sqrt(np.mean(res_fd[steady] ** 2)) < 100.0


def test_integrator_convergence():
    d = R.convergence_check(3, None, 1, {}, seed=SEED, periods=1, sample_rate_hz=10.0)
    assert d["torque"] < 1.0 and d["twist"] < 1e-8 and d["q"] < 1e-8


def test_sensor_idiosyncrasies(nominal1):
    s = nominal1.samples
    tr = nominal1.truth
    step = math.radians(0.01)
    # floor quantiser with an unknown sub-step zero: error within one step
    assert np.abs(s.q - tr.q).max() < 1.01 * step + 3e-5
    # torque reading: stated noise level around the truth (lag small at 10 Hz ramps)
    resid = (s.torque - tr.torque)[s.phase == "hold"]
    assert 100.0 < resid.std() < 250.0
    # motor speeds on the N2 grid
    wstep = nominal1.meta["sensors"]["w_m1"]["resolution"]
    assert np.allclose(s.w_m1 / wstep, np.round(s.w_m1 / wstep), atol=1e-6)
    assert np.allclose(s.ud, s.w_m1 / 11000.0)
