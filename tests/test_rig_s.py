"""Validation rig S (validation_rigs/rig_s.py): its contract (arguments, determinism, run format,
stated sensors, effects) and its physics against the paper (Eq. 4 sliding friction with Table 3,
twist = torque / stiffness, the schemes' loads, stability at SCALE_MAX)."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pandas as pd
import pytest

from core.runfile import validate_meta, validate_samples
from validation_rigs import rig_s as R

VOCABULARY = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
              "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction")
ALL_FORMS = [(name, form) for name, forms in R.EFFECT_FORMS.items() for form in forms]
TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.66}
TOP_SPEED = 3000 * 2 * math.pi / 60 / R.REDUCTION


def _key(effects: dict | None) -> tuple:
    return tuple(sorted((k, v["form"], float(v["scale"])) for k, v in (effects or {}).items()))


@cache
def _run_cached(scheme, speed, direction, temp, eff_key, fs, periods, seed, run, quiet):
    effects = {k: {"form": f, "scale": s} for k, f, s in eff_key}
    kw = dict(sample_rate_hz=fs)
    if quiet:
        kw.update(torque_noise=0.0, load_noise=0.0, torque_res=0.0, load_res=0.0)
    return R.simulate_run(scheme, speed, direction, temp, effects or None,
                          sensors=R.SensorSpec(**kw), periods=periods, seed=seed, run=run)


def run(scheme=1, speed=300.0, direction=1, temp=25.0, effects=None, fs=20.0, periods=1,
        seed=11, run=0, quiet=False) -> R.RigRun:
    return _run_cached(scheme, speed if scheme != 3 else None, direction, temp, _key(effects),
                       fs, periods, seed, run, quiet)


# --- module interface -------------------------------------------------------------------------

def test_module_interface():
    assert R.RIG_NAME == "rig_s"
    assert R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True
    assert 10.0 <= R.SCALE_MAX <= 20.0
    assert set(R.EFFECT_FORMS) == set(VOCABULARY) | set(R.OUT_OF_VOCABULARY)
    assert R.OUT_OF_VOCABULARY == ("periodic_disturbance", "position_stiffness", "sensor_drift",
                                   "second_resonance")
    for name, forms in R.EFFECT_FORMS.items():
        assert len(forms) >= 3 and len(set(forms)) == len(forms), name
    assert {"exp1", "exp2", "lorentz"} <= set(R.EFFECT_FORMS["stribeck"])
    assert len(R.EFFECT_FORMS["stribeck"]) >= 4
    assert set(R.UNSTATED_VOCABULARY) <= set(VOCABULARY)
    assert all(isinstance(v, str) and v for v in R.UNSTATED_VOCABULARY.values())
    spec = R.SensorSpec()
    assert (spec.sample_rate_hz, spec.encoder_res_deg, spec.torque_noise, spec.torque_lag_s) == \
        (100.0, 0.01, 150.0, 0.0)


# --- argument checks --------------------------------------------------------------------------

@pytest.mark.parametrize("field,value", [
    ("sample_rate_hz", 0.0), ("sample_rate_hz", -5.0), ("sample_rate_hz", float("nan")),
    ("sample_rate_hz", float("inf")), ("sample_rate_hz", 1e6), ("encoder_res_deg", 0.0),
    ("encoder_res_deg", float("nan")), ("torque_noise", -1.0), ("torque_noise", float("inf")),
    ("torque_lag_s", -0.1), ("torque_lag_s", float("nan")), ("torque_noise", "150"),
    ("load_noise", -2.0), ("torque_res", float("nan")), ("qd_noise", True),
])
def test_sensor_spec_rejects_bad_values(field, value):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})


@pytest.mark.parametrize("kwargs,match", [
    (dict(scheme=4), "scheme"),
    (dict(scheme=True), "scheme"),
    (dict(motor_speed_rpm=None), "motor_speed_rpm"),
    (dict(motor_speed_rpm=0.0), "motor_speed_rpm"),
    (dict(motor_speed_rpm=3500.0), "motor_speed_rpm"),
    (dict(motor_speed_rpm=float("nan")), "motor_speed_rpm"),
    (dict(scheme=3, motor_speed_rpm=300.0), "motor_speed_rpm"),
    (dict(direction=0), "direction"),
    (dict(direction=2), "direction"),
    (dict(temp_joint_c=10.0), "temp_joint_c"),
    (dict(temp_joint_c=float("nan")), "temp_joint_c"),
    (dict(periods=0), "periods"),
    (dict(seed=-1), "seed"),
    (dict(run=1.5), "run"),
    (dict(effects={"friction_wobble": {"form": "x", "scale": 1.0}}), "known"),
    (dict(effects={"stribeck": {"form": "cubic", "scale": 1.0}}), "exp1"),
    (dict(effects={"stribeck": {"form": "exp1", "scale": R.SCALE_MAX * 1.01}}), "scale"),
    (dict(effects={"stribeck": {"form": "exp1", "scale": -0.1}}), "scale"),
    (dict(effects={"stribeck": {"form": "exp1", "scale": float("nan")}}), "scale"),
    (dict(effects={"stribeck": {"form": "exp1"}}), "stribeck"),
    (dict(effects=["stribeck"]), "effects"),
    (dict(sensors="fast"), "sensors"),
])
def test_simulate_run_rejects_bad_arguments(kwargs, match):
    args = dict(scheme=1, motor_speed_rpm=300.0, direction=1, temp_joint_c=25.0, effects=None,
                seed=1, run=0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        R.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                       args.pop("temp_joint_c"), args.pop("effects"), **args)


def test_unknown_effect_message_lists_the_known_ones():
    with pytest.raises(ValueError) as exc:
        R.simulate_run(1, 300.0, 1, 25.0, {"wobble": {"form": "a", "scale": 1}}, seed=1, run=0)
    for name in R.EFFECT_FORMS:
        assert name in str(exc.value)


# --- determinism, noise, run format -----------------------------------------------------------

def test_deterministic_and_seeded():
    a = R.simulate_run(3, None, 1, 25.0, sensors=R.SensorSpec(sample_rate_hz=20), periods=1,
                       seed=4, run=2)
    b = R.simulate_run(3, None, 1, 25.0, sensors=R.SensorSpec(sample_rate_hz=20), periods=1,
                       seed=4, run=2)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    assert a.meta == b.meta
    other_run = run(scheme=3, seed=4, run=3)
    assert not np.array_equal(a.samples.torque, other_run.samples.torque)
    pd.testing.assert_frame_equal(a.truth, other_run.truth)   # same machine, other noise
    other_seed = run(scheme=3, seed=5, run=2)
    assert other_seed.params["machine"] != a.params["machine"]


def test_runs_differing_only_by_an_effect_share_their_noise():
    base = run(scheme=1, quiet=False, fs=50.0)
    eff = run(scheme=1, quiet=False, fs=50.0,
              effects={"sensor_drift": {"form": "load_linear", "scale": 1.0}})
    pd.testing.assert_series_equal(base.samples.torque, eff.samples.torque)
    pd.testing.assert_series_equal(base.samples.q, eff.samples.q)
    d = (eff.samples.torque_load - base.samples.torque_load).to_numpy()
    expected = R.SD_RATE * base.samples.t.to_numpy()
    assert np.max(np.abs(d - expected)) <= R.SensorSpec().load_res + 1e-9


@pytest.mark.parametrize("scheme", [1, 2, 3])
def test_run_format_is_valid(scheme):
    r = run(scheme=scheme, speed=3000.0, direction=-1, periods=2)
    validate_meta(r.meta, "rig_s.json")
    validate_samples(r.samples, "rig_s.csv")
    for col in ("t", "q", "qd", "u", "torque", "torque_load", "torque_cmd", "temp_joint", "phase"):
        assert col in r.samples.columns
    for col in ("t", "q", "qd", "twist", "torque", "torque_load"):
        assert col in r.truth.columns
    assert np.all(np.diff(r.samples.t) > 0)
    assert r.meta["scheme"] == scheme and r.meta["rig"] == "rig_s"
    assert r.meta["source"] == "emulator" and r.meta["reduction"] == 11000.0
    assert r.meta["direction"] == -1 and r.meta["sample_rate_hz"] == 20.0
    if scheme == 3:
        assert r.meta["motor_speed_rpm"] is None and r.meta["periods"] == 2
    else:
        assert r.meta["motor_speed_rpm"] == 3000.0
    assert "unstated" in r.params and "machine" in r.params and "effects" in r.params
    assert set(r.samples.phase.dropna()) <= {"idle", "load", "hold", "unload", "excite"}


def test_odd_sample_rate_stays_on_steps_and_increasing():
    r = R.simulate_run(3, None, 1, 25.0, sensors=R.SensorSpec(sample_rate_hz=300.0), periods=1,
                       seed=1, run=0)
    t = r.samples.t.to_numpy()
    assert np.all(np.diff(t) > 0)
    assert np.allclose(t * R.STEP_HZ, np.round(t * R.STEP_HZ), atol=1e-6)
    validate_samples(r.samples, "x.csv")


def test_physics_does_not_depend_on_the_sample_rate():
    slow = run(scheme=1, fs=10.0)
    fast = run(scheme=1, fs=1000.0)
    thin = fast.truth.iloc[::100].reset_index(drop=True)
    assert len(thin) == len(slow.truth)
    np.testing.assert_array_equal(slow.truth.to_numpy(), thin.to_numpy())


# --- stated sensors ---------------------------------------------------------------------------

@pytest.mark.parametrize("res_deg", [0.001, 0.01, 0.02])
def test_encoder_quantisation_is_as_stated(res_deg):
    r = R.simulate_run(1, 3000.0, 1, 25.0, sensors=R.SensorSpec(sample_rate_hz=10,
                                                               encoder_res_deg=res_deg),
                       seed=2, run=0)
    res = math.radians(res_deg)
    assert r.meta["sensors"]["q"]["resolution"] == pytest.approx(res)
    steps = r.samples.q.to_numpy() / res
    assert np.allclose(steps, np.round(steps), atol=1e-6)
    err = r.samples.q.to_numpy() - r.truth.q.to_numpy()
    assert np.max(np.abs(err)) <= 0.5 * res + 2e-5


def test_torque_noise_and_sensors_are_stated():
    r = run(scheme=1, fs=50.0)
    s = r.meta["sensors"]
    assert s["torque"]["noise_sd"] == 150.0 and s["torque"]["lag_s"] == 0.0
    assert s["torque_load"]["noise_sd"] == 120.0
    assert s["u"]["resolution"] == pytest.approx(2 * math.pi / 2 ** 17 / 11000)
    hold = (r.samples.phase == "hold").to_numpy()
    e = (r.samples.torque - r.truth.torque).to_numpy()[hold]
    assert 120.0 < np.std(e) < 185.0
    un = r.params["unstated"]
    th = r.truth.temp_housing.to_numpy()[hold]
    expected_offset = un["torque_zero_offset_nm"] + un["torque_zero_tc_nm_per_k"] * (th.mean() - 20)
    assert abs(np.mean(e) - expected_offset) < 60.0


def test_stated_torque_lag_delays_the_reading():
    spec = R.SensorSpec(sample_rate_hz=200.0, torque_noise=0.0, torque_res=0.0, torque_lag_s=0.25)
    r = R.simulate_run(3, None, 1, 25.0, sensors=spec, periods=1, seed=3, run=0)
    assert r.meta["sensors"]["torque"]["lag_s"] == 0.25
    tq, true = r.samples.torque.to_numpy(), r.truth.torque.to_numpy()
    lag = 50  # 0.25 s at 200 Hz
    err_shift = np.std(tq[lag:] - true[:-lag] - np.mean(tq[lag:] - true[:-lag]))
    err_now = np.std(tq - true - np.mean(tq - true))
    assert err_shift < 0.2 * err_now


# --- physics against the paper ----------------------------------------------------------------

@pytest.mark.parametrize("speed,direction", [(300.0, 1), (300.0, -1), (3000.0, 1), (3000.0, -1)])
def test_steady_sliding_friction_follows_eq4_with_table3(speed, direction):
    r = run(scheme=1, speed=speed, direction=direction, fs=20.0, seed=11)
    tr = r.truth
    m = ((tr.t > 8) & (tr.t < 30)).to_numpy()
    qd = tr.qd.to_numpy()[m]
    grav = 9.80665 * (TABLE3["mr_x"] * np.sin(tr.q) + TABLE3["mr_y"] * np.cos(tr.q)).to_numpy()[m]
    measured = (tr.torque - tr.torque_load).to_numpy()[m] - grav - TABLE3["I"] * tr.qdd.to_numpy()[m]
    eq4 = TABLE3["f_c"] * np.sign(qd) + TABLE3["f_v"] * qd
    assert np.all(np.sign(qd) == direction)
    assert np.mean(measured) == pytest.approx(np.mean(eq4), rel=0.06)
    # the same from the readings (noise averages out over a few hundred samples)
    s = r.samples
    meas = (s.torque - s.torque_load).to_numpy()[m] - grav
    assert np.mean(meas) == pytest.approx(np.mean(eq4), rel=0.10, abs=150.0)


def test_twist_is_torque_over_stiffness():
    tr = run(scheme=1, speed=3000.0, fs=20.0).truth
    T, tw = tr.torque.to_numpy(), tr.twist.to_numpy()
    small = (np.abs(T) > 5e3) & (np.abs(T) < 2e4)
    k_small = np.median(T[small] / tw[small])
    assert 1.1e7 < k_small < 1.45e7
    big = np.argmax(T)
    assert T[big] > 119e3
    assert 0.4 < math.degrees(tw[big]) < 0.6


def test_scheme_1_loads_up_to_rated_and_back():
    r = run(scheme=1, speed=3000.0, fs=10.0)
    s = r.samples
    assert 65.0 <= s.t.iloc[-1] <= 80.0
    assert s.torque_load.max() == pytest.approx(120e3, abs=1.5e3)
    assert abs(s.torque_load.iloc[-1]) < 1e3 and abs(s.torque_load.iloc[0]) < 1e3
    order = [p for i, p in enumerate(s.phase) if i == 0 or p != s.phase.iloc[i - 1]]
    assert order == ["idle", "load", "hold", "unload", "idle"]
    err = (r.truth.torque_load - r.truth.torque_cmd).to_numpy()
    assert np.max(np.abs(err[(s.t > 5).to_numpy()])) < 2e3   # Table 11: +-2 kN m
    # output moves at 3000 r/min / N while loaded
    mid = ((s.t > 10) & (s.t < 60)).to_numpy()
    assert np.mean(r.truth.qd.to_numpy()[mid]) == pytest.approx(TOP_SPEED, rel=0.03)


def test_scheme_2_holds_ten_knm_steps():
    r = run(scheme=2, speed=300.0, fs=10.0)
    s, tr = r.samples, r.truth
    assert 65.0 <= s.t.iloc[-1] <= 80.0
    hold = (s.phase == "hold").to_numpy()
    levels = np.round(tr.torque_cmd.to_numpy()[hold] / 1e4)
    assert sorted(set(levels)) == list(range(1, 13))
    for lv in range(1, 13):
        sel = hold & (np.round(tr.torque_cmd.to_numpy() / 1e4) == lv)
        assert np.mean(tr.torque_load.to_numpy()[sel]) == pytest.approx(lv * 1e4, abs=600.0)


def test_scheme_3_is_an_unloaded_fourier_excitation():
    r = run(scheme=3, periods=3, fs=10.0)
    s, tr = r.samples, r.truth
    assert s.t.iloc[-1] == pytest.approx(3 * R.FOURIER_PERIOD_S + 2.0)
    assert np.all(tr.torque_load == 0.0)
    assert abs(s.torque_load.mean()) < 50.0
    assert tr.qd.abs().max() <= TOP_SPEED
    assert tr.q.abs().max() < math.pi
    assert (s.phase == "excite").mean() > 0.9
    # periodic: the same pose one period apart
    step = int(R.FOURIER_PERIOD_S * 10)
    i0 = int(5.0 * 10)
    assert tr.q.iloc[i0 + step] == pytest.approx(tr.q.iloc[i0], abs=2e-3)
    # both senses of motion are visited
    assert tr.qd.max() > 0.01 and tr.qd.min() < -0.01


# --- effects ----------------------------------------------------------------------------------

@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_effect_form_changes_the_run(name, form):
    base = run(scheme=3, fs=20.0)
    eff = run(scheme=3, fs=20.0, effects={name: {"form": form, "scale": 1.0}})
    cols = ["torque", "torque_load", "u", "q"]
    assert not eff.samples[cols].equals(base.samples[cols])
    assert eff.params["effects"] == {name: {"form": form, "scale": 1.0}}


def test_scale_zero_reproduces_the_nominal_run_bit_for_bit():
    for scheme in (1, 3):
        base = run(scheme=scheme, fs=20.0)
        zero = {name: {"form": forms[-1], "scale": 0.0} for name, forms in R.EFFECT_FORMS.items()}
        z = run(scheme=scheme, fs=20.0, effects=zero)
        pd.testing.assert_frame_equal(base.samples, z.samples, check_exact=True)
        pd.testing.assert_frame_equal(base.truth, z.truth, check_exact=True)


def _effect_size(name, form, scale, scheme=1, speed=300.0):
    base = run(scheme=scheme, speed=speed, fs=20.0, quiet=True)
    eff = run(scheme=scheme, speed=speed, fs=20.0, quiet=True,
              effects={name: {"form": form, "scale": scale}})
    d_law = (eff.samples.torque - eff.samples.torque_load) - (base.samples.torque - base.samples.torque_load)
    d_tw = (eff.truth.twist - base.truth.twist) * 1.25e7
    return float(np.sqrt(np.mean(d_law ** 2) + np.mean(d_tw ** 2)))


@pytest.mark.parametrize("name,form", [
    ("stribeck", "exp2"), ("load_dependent_friction", "power_flow"),
    ("temperature_friction", "coulomb_multiplicative"), ("gear_ripple", "output_torque"),
    ("torque_offset", "time_linear"), ("time_delay", "first_order"),
    ("hysteresis", "bouc_wen_n1"), ("backlash", "sharp"), ("asymmetric_friction", "coulomb_split"),
    ("periodic_disturbance", "sine"), ("position_stiffness", "once_per_rev"),
    ("sensor_drift", "torque_span"), ("second_resonance", "slow"),
])
def test_effects_are_linear_for_small_scale_and_visible_at_one(name, form):
    a, b = _effect_size(name, form, 0.1), _effect_size(name, form, 0.2)
    assert b / a == pytest.approx(2.0, rel=0.12)
    one = _effect_size(name, form, 1.0)
    assert 15.0 < one < 6000.0


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_stable_at_scale_max(name, form):
    for scheme, speed, direction, temp in ((1, 300.0, 1, 15.0), (3, None, -1, 60.0)):
        r = run(scheme=scheme, speed=speed, direction=direction, temp=temp, fs=10.0,
                effects={name: {"form": form, "scale": R.SCALE_MAX}})
        num = r.samples.drop(columns="phase").to_numpy(dtype=float)
        assert np.isfinite(num).all() and np.isfinite(r.truth.to_numpy(dtype=float)).all()
        assert r.truth.qd.abs().max() < 0.2
        assert r.truth.torque.abs().max() < 2.5e5


def test_stable_at_scale_max_at_one_khz_all_effects_together():
    effects = {name: {"form": forms[0], "scale": R.SCALE_MAX}
               for name, forms in R.EFFECT_FORMS.items()}
    for scheme in (1, 3):
        r = run(scheme=scheme, speed=3000.0, fs=1000.0, effects=effects)
        validate_samples(r.samples, "max.csv")
        assert np.isfinite(r.truth.to_numpy(dtype=float)).all()
        assert r.truth.qd.abs().max() < 0.2
        assert r.truth.torque.abs().max() < 2.5e5


def test_unstated_vocabulary_is_carried_at_scale_zero():
    r = run(scheme=3, fs=20.0)
    un = r.params["unstated"]
    assert "torque_offset" in R.UNSTATED_VOCABULARY and "time_delay" in R.UNSTATED_VOCABULARY
    assert un["torque_amp_filter_tau_s"][0] > 0 and un["load_cell_plc_cycle_s"] > 0
    # none of it is stated
    assert r.meta["sensors"]["torque"]["lag_s"] == 0.0
    assert r.meta["sensors"]["torque_load"]["lag_s"] == 0.0
    assert "offset" not in str(r.meta).lower()
