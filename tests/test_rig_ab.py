"""Rig AB (validation_rigs/rig_ab.py): interface, argument checks, determinism, run format, the
nominal physics against its data sheet (restated here, not imported), every effect form against
its law, and the sensor spec. Runs are short (one period) and sampled slowly to stay fast."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pandas as pd
import pytest

from core.runfile import read_run, validate_meta, validate_samples, write_run
from core.run import RunData
from validation_rigs import rig_ab as R

# --- the data sheet, restated ----------------------------------------------------------------
N = 11000.0
G = 9.81
T_RATED = 120_000.0
V_C = 1.5e-4
P_HARD = 1.5
OMEGA = {300: 300 * 2 * math.pi / 60 / N, 3000: 3000 * 2 * math.pi / 60 / N}
VOCABULARY = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
              "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction")
MIN_FORMS = {"stribeck": 3, "load_dependent_friction": 2, "temperature_friction": 3,
             "gear_ripple": 3, "torque_offset": 2, "time_delay": 2, "hysteresis": 3,
             "backlash": 2, "asymmetric_friction": 2, "periodic_disturbance": 2,
             "position_dependent_stiffness": 2, "encoder_drift": 2, "second_resonance": 2}

SEED = 5
SLOW = R.SensorSpec(sample_rate_hz=20.0)
EXACT = R.SensorSpec(sample_rate_hz=100.0, torque_noise=0.0, torque_res=0.0, qd_noise=0.0,
                     ud_noise=0.0, encoder_res_deg=1e-5, motor_encoder_res=0.0,
                     current_noise=0.0)
SENSORS = {"slow": SLOW, "exact": EXACT}


@lru_cache(maxsize=None)
def _run(scheme, rpm, direction, temp, effect=None, sensors="slow", seed=SEED, run=0, periods=1):
    eff = None if effect is None else {effect[0]: {"form": effect[1], "scale": effect[2]}}
    return R.simulate_run(scheme, rpm, direction, temp, eff, sensors=SENSORS[sensors],
                          periods=periods, seed=seed, run=run)


def S3(effect=None, **kw):
    return _run(3, None, 1, 30.0, effect, **kw)


def S1(effect=None, rpm=3000, direction=1, temp=30.0, **kw):
    return _run(1, rpm, direction, temp, effect, **kw)


def machine(r):
    return r.params["machine"]


def K(m, d):
    return m["k0"] * d * (1.0 + m["a_hard"] * np.abs(d / m["twist_rated_rad"]) ** P_HARD)


def k_tan(m, d):
    return m["k0"] * (1.0 + m["a_hard"] * (1.0 + P_HARD) * np.abs(d / m["twist_rated_rad"])
                      ** P_HARD)


def F_nom(m, v):
    return m["f_c"] * np.tanh(v / V_C) + m["f_v"] * v


def draws(r, family):
    d = r.params["effect_draws"][family]
    return d["phases"], d["sign_or_centre"]


def col(r, name):
    return r.truth[name].to_numpy()


# --- interface -------------------------------------------------------------------------------

def test_interface_constants():
    assert R.RIG_NAME == "rig_ab"
    assert R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True
    assert R.SCALE_MAX >= 1.0
    assert list(R.EFFECT_FORMS) == list(MIN_FORMS)
    for name, n in MIN_FORMS.items():
        forms = R.EFFECT_FORMS[name]
        assert len(forms) >= n and len(set(forms)) == len(forms), name
    assert R.OUT_OF_VOCABULARY == ("periodic_disturbance", "position_dependent_stiffness",
                                   "encoder_drift", "second_resonance")
    assert len(R.UNSTATED_VOCABULARY) <= 2
    assert set(R.UNSTATED_VOCABULARY) <= set(VOCABULARY)
    assert all(isinstance(v, str) and v for v in R.UNSTATED_VOCABULARY.values())
    assert "DATA SHEET" in R.__doc__
    for forms in R.EFFECT_FORMS.values():
        for f in forms:
            assert f in R.__doc__, f


FIELDS = ["sample_rate_hz", "encoder_res_deg", "torque_noise", "torque_lag_s", "torque_filter_s",
          "torque_res", "load_noise", "load_res", "qd_noise", "motor_encoder_res", "ud_noise",
          "current_noise", "temp_res", "temp_noise"]


@pytest.mark.parametrize("name", FIELDS)
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf"), 1e9, -1.0, "1",
                                 True, None])
def test_sensorspec_rejects(name, bad):
    if name == "encoder_res_deg" and bad == 1e9:
        bad = 2.0
    with pytest.raises(ValueError, match=name):
        R.SensorSpec(**{name: bad})


def test_sensorspec_accepts_bounds():
    s = R.SensorSpec(sample_rate_hz=10, encoder_res_deg=1e-5, torque_noise=0, torque_res=0)
    assert s.sample_rate_hz == 10.0 and isinstance(s.sample_rate_hz, float)
    R.SensorSpec(sample_rate_hz=1000.0, encoder_res_deg=1.0)
    with pytest.raises(ValueError, match="sample_rate_hz"):
        R.SensorSpec(sample_rate_hz=9.99)


BAD_CALLS = [
    dict(scheme=4), dict(scheme=1.0), dict(scheme="1"), dict(scheme=True),
    dict(scheme=1, motor_speed_rpm=1000), dict(scheme=1, motor_speed_rpm=None),
    dict(scheme=3, motor_speed_rpm=300), dict(direction=0), dict(direction=2),
    dict(temp_joint_c=14.9), dict(temp_joint_c=60.5), dict(temp_joint_c=float("nan")),
    dict(periods=0), dict(periods=21), dict(periods=1.5), dict(seed=-1), dict(seed=1.0),
    dict(run=-1), dict(run="0"), dict(sensors={"sample_rate_hz": 10}),
    dict(effects=[("stribeck", "lorentzian")]), dict(effects={"nope": {"form": "x", "scale": 1}}),
    dict(effects={"stribeck": {"form": "nope", "scale": 1}}),
    dict(effects={"stribeck": {"form": "lorentzian", "scale": -0.1}}),
    dict(effects={"stribeck": {"form": "lorentzian", "scale": float("nan")}}),
    dict(effects={"stribeck": {"form": "lorentzian", "scale": float("inf")}}),
    dict(effects={"stribeck": {"form": "lorentzian", "scale": R.SCALE_MAX * 1.01}}),
    dict(effects={"stribeck": {"form": "lorentzian", "scale": "1"}}),
    dict(effects={"stribeck": {"form": "lorentzian", "scale": 1, "extra": 2}}),
    dict(effects={"stribeck": "lorentzian"}),
    # scheme 2 at 3000 r/min: 4 periods would travel past ±180°
    dict(scheme=2, motor_speed_rpm=3000, periods=4),
    dict(scheme=1, motor_speed_rpm=3000, periods=6),
]


@pytest.mark.parametrize("bad", BAD_CALLS)
def test_argument_checks(bad):
    args = dict(scheme=3, motor_speed_rpm=None, direction=1, temp_joint_c=30.0, effects=None,
                sensors=None, periods=1, seed=0, run=0)
    if bad.get("scheme") in (1, 2) and "motor_speed_rpm" not in bad:
        args["motor_speed_rpm"] = 300
    args.update(bad)
    with pytest.raises(ValueError):
        R.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                       args.pop("temp_joint_c"), args.pop("effects"), **args)


# --- determinism, run format, sensors ----------------------------------------------------------

def test_determinism_and_campaign():
    a = S3()
    b = R.simulate_run(3, None, 1, 30.0, None, sensors=SLOW, periods=1, seed=SEED, run=0)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    c = S3(run=1)
    assert machine(c) == machine(a)                       # the campaign draws the machine
    assert not np.allclose(a.samples["torque"], c.samples["torque"])   # the run draws noise
    d = S3(seed=SEED + 1)
    assert machine(d)["k0"] != machine(a)["k0"]
    # an effect with scale 0 is exactly no effect
    z = R.simulate_run(3, None, 1, 30.0, {"backlash": {"form": "sharp", "scale": 0.0}},
                       sensors=SLOW, periods=1, seed=SEED, run=0)
    pd.testing.assert_frame_equal(a.samples, z.samples)


def test_run_format_round_trip(tmp_path):
    for r in (S3(), S1(rpm=300, direction=-1)):
        samples = validate_samples(r.samples, "mem")
        meta = validate_meta(r.meta, "mem")
        assert list(samples.columns) == list(r.samples.columns)
        for ch in ("t", "q", "qd", "u", "ud", "torsion", "torque", "torque_load", "torque_cmd",
                   "i_m1", "i_m2", "i_m3", "w_m1", "w_m2", "w_m3", "temp_m1", "temp_m2",
                   "temp_m3", "temp_joint", "phase"):
            assert ch in samples.columns, ch
        for key in ("scheme", "motor_speed_rpm", "direction", "reduction", "rig", "source",
                    "sample_rate_hz", "started_at", "notes", "sensors"):
            assert key in meta, key
        assert meta["reduction"] == N and meta["source"] == "emulator"
        for fmt in ("csv", "parquet"):
            paths = write_run(RunData(samples=r.samples, meta=r.meta), tmp_path / f"r{fmt}", fmt)
            back = read_run(paths[0])
            pd.testing.assert_frame_equal(back.samples, samples)
            assert back.meta == r.meta
        assert len(r.truth) == len(r.samples)
        np.testing.assert_array_equal(r.truth["t"], r.samples["t"])
        for c in ("t", "twist", "torque"):
            assert c in r.truth.columns


def test_meta_states_the_sensors():
    spec = R.SensorSpec(sample_rate_hz=20.0, encoder_res_deg=0.05, torque_noise=50.0,
                        torque_lag_s=0.002, torque_filter_s=0.001, torque_res=10.0, temp_res=0.5)
    r = R.simulate_run(3, None, -1, 45.0, sensors=spec, periods=1, seed=1, run=2)
    s, sens = r.samples, r.meta["sensors"]
    assert r.meta["sample_rate_hz"] == 20.0 and r.meta["direction"] == -1
    assert r.meta["motor_speed_rpm"] is None and r.meta["scheme"] == 3
    np.testing.assert_allclose(np.diff(s["t"]), 0.05)
    step = math.radians(0.05)
    assert sens["q"]["resolution"] == pytest.approx(step)
    assert sens["torque"] == {"resolution": 10.0, "noise_sd": 50.0, "lag_s": pytest.approx(0.003)}
    assert sens["u"]["resolution"] == spec.motor_encoder_res
    assert sens["temp_joint"]["resolution"] == 0.5
    # the quantisation steps are visible in the readings
    k = s["q"] / step
    np.testing.assert_allclose(k, np.round(k), atol=1e-6)
    assert len(np.unique(np.round(k))) > 5
    np.testing.assert_allclose(s["torque"] / 10.0, np.round(s["torque"] / 10.0), atol=1e-9)
    np.testing.assert_allclose(s["temp_joint"] / 0.5, np.round(s["temp_joint"] / 0.5), atol=1e-9)
    np.testing.assert_allclose(s["torsion"], s["q"] - s["u"])
    # noise as stated: the torque reading scatters about the (slowly varying) truth by ~50 N·m
    resid = s["torque"] - r.truth["torque"]
    assert 35.0 < np.std(resid - np.convolve(resid, np.ones(5) / 5, "same")) < 60.0


def test_stated_torque_lag_is_the_readings_lag():
    spec = R.SensorSpec(sample_rate_hz=100.0, torque_noise=0.0, torque_res=0.0,
                        torque_filter_s=0.02, torque_lag_s=0.01)
    r = R.simulate_run(1, 3000, 1, 30.0, sensors=spec, periods=1, seed=SEED, run=0)
    assert r.meta["sensors"]["torque"]["lag_s"] == pytest.approx(0.03)
    T = col(r, "torque")
    dT = np.gradient(T, col(r, "t"))
    ramp = (col(r, "t") > 4.0) & (np.abs(dT) > 5000.0)
    err = (r.samples["torque"].to_numpy() - T)[ramp]
    lag = -np.sum(err * dT[ramp]) / np.sum(dT[ramp] ** 2)
    assert lag == pytest.approx(0.03, rel=0.1)


# --- nominal physics against the data sheet --------------------------------------------------

def test_rated_twist_and_compliance_law():
    r = S1()
    m = machine(r)
    assert K(m, m["twist_rated_rad"]) == pytest.approx(T_RATED, rel=1e-12)
    assert 0.40 < math.degrees(m["twist_rated_rad"]) < 0.50
    assert 7.5e6 < m["k0"] < 9.5e6
    tw = col(r, "twist")
    np.testing.assert_allclose(col(r, "torque_elastic"), K(m, tw), rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(col(r, "torque_damping"),
                               m["beta_s"] * k_tan(m, tw) * (col(r, "ud") - col(r, "qd")),
                               rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(col(r, "torque"), col(r, "torque_elastic")
                               + col(r, "torque_damping"), rtol=1e-9, atol=1e-6)
    assert np.all(col(r, "torque_hysteresis") == 0.0)
    # hardening: at the peak of the load the secant stiffness is above k0·(1 + 0.5·a)
    i = np.argmax(col(r, "torque"))
    assert col(r, "torque")[i] > T_RATED
    assert col(r, "torque")[i] / tw[i] > m["k0"] * (1 + 0.5 * m["a_hard"])
    # at several twists the law is the data sheet's
    for frac in (0.1, 0.3, 0.6, 0.9):
        d = frac * m["twist_rated_rad"]
        assert K(m, d) == pytest.approx(m["k0"] * d * (1 + m["a_hard"] * frac ** 1.5))


@pytest.mark.parametrize("rpm,direction", [(3000, 1), (300, -1)])
def test_steady_friction_level_scheme1(rpm, direction):
    r = S1(rpm=rpm, direction=direction)
    m, tr, s = machine(r), r.truth, r.samples
    win = ((tr["t"] > 5.0) & (tr["t"] < 20.0)).to_numpy()
    level = direction * (m["f_c"] + m["f_v"] * OMEGA[rpm])
    # the truth: output balance and the friction law
    grav = G * (m["mr_x"] * np.sin(col(r, "q")) + m["mr_y"] * np.cos(col(r, "q")))
    np.testing.assert_allclose(col(r, "gravity"), grav, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(col(r, "friction"), F_nom(m, col(r, "qd")), rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(m["I"] * col(r, "qdd"), col(r, "torque") - col(r, "load_on_output")
                               - grav - col(r, "friction"), rtol=1e-6, atol=1e-3)
    bal = (col(r, "torque") - col(r, "load_on_output") - grav)[win]
    assert np.mean(bal) == pytest.approx(level, rel=0.01)
    # the same level from the readings (torque, load, encoder)
    q = s["q"].to_numpy()
    gread = G * (m["mr_x"] * np.sin(q) + m["mr_y"] * np.cos(q))
    bal_read = (s["torque"] - s["torque_load"]).to_numpy() - gread
    assert np.mean(bal_read[win]) == pytest.approx(level, abs=80.0)
    assert np.mean(s["qd"][win]) == pytest.approx(direction * OMEGA[rpm], rel=0.02)


def test_scheme_programmes_and_dynamometer():
    r1, r3 = S1(), S3()
    s1, s3 = r1.samples, r3.samples
    assert s1["torque_cmd"].max() == pytest.approx(T_RATED, rel=1e-3)
    assert (s1["torque_cmd"] >= 0).all()
    assert set(s1["phase"]) == {"idle", "load", "unload"}
    assert set(s3["phase"]) == {"idle", "excite"} and (s3["torque_cmd"] == 0).all()
    # the dynamometer: inside Table 11's ±2 kN·m of its set point
    assert np.max(np.abs(col(r1, "torque_load") - col(r1, "torque_cmd"))) < 2000.0
    # scheme 2: holds at multiples of 10 kN·m
    r2 = _run(2, 300, 1, 30.0)
    hold = r2.samples["phase"] == "hold"
    cmd = r2.samples["torque_cmd"][hold]
    np.testing.assert_allclose(cmd / 10_000.0, np.round(cmd / 10_000.0), atol=1e-9)
    assert set(np.round(cmd / 10_000.0).astype(int)) == set(range(1, 13))
    # scheme 3: the output follows Eq. 12 (data sheet coefficients) within the twist
    a = np.array([-0.0045843, -0.0047006, 0.0029539, 0.0055513, 0.0])
    b = np.array([-0.0023227, 0.0042895, 0.0054060, -0.0013715, 0.0])
    a[4] = -a[:4].sum()
    b[4] = -(np.arange(1, 5) * b[:4]).sum() / 5.0
    wf = 2 * np.pi / 24.0
    tau = np.clip(col(r3, "t") - 1.5, 0.0, 24.0)
    lw = wf * np.arange(1, 6)
    qf = (np.sin(np.outer(tau, lw)) @ (a / lw) - np.cos(np.outer(tau, lw)) @ (b / lw)
          + (b / lw).sum())
    assert np.max(np.abs(qf)) > 0.04
    m = machine(r3)
    assert np.max(np.abs(col(r3, "q") - (qf + r3.params["u0"]))) < 1e-3
    assert np.max(np.abs(col(r3, "qd"))) < 0.0286
    # motor currents: Σ N·k_t·(i − offset) is the motor torque (noise-free readings)
    e = _run(3, None, 1, 30.0, sensors="exact")
    me = machine(e)
    tm = sum(N * me[f"k_t{k}"] * (e.samples[f"i_m{k}"] - me[f"i_offset{k}"]) for k in (1, 2, 3))
    np.testing.assert_allclose(tm, col(e, "torque_motor"), rtol=1e-9, atol=1e-6)
    assert m["ambient_c"] == pytest.approx(22.0, abs=4.0)


def test_thermal_nodes():
    hot = S1(temp=30.0)           # 3000 r/min: friction heats the oil
    tj = col(hot, "temp_joint")
    assert tj[0] == 30.0 and tj[-1] > tj[0] + 0.05
    cold = _run(3, None, 1, 60.0)  # slow excitation at 60 °C: the gearbox cools
    assert col(cold, "temp_housing")[-1] < 60.0
    assert col(cold, "temp_m1")[-1] < 60.0


# --- effects ---------------------------------------------------------------------------------

def _assert_changed(r, base, channel="torque", atol=1.0):
    diff = np.abs(r.samples[channel].to_numpy() - base.samples[channel].to_numpy())
    assert np.max(diff) > atol, channel


STRIBECK_S = {"exponential_d1": lambda x: np.exp(-x), "gaussian_d2": lambda x: np.exp(-x * x),
              "lorentzian": lambda x: 1 / (1 + x * x), "power_d06": lambda x: np.exp(-x ** 0.6)}


@pytest.mark.parametrize("form", R.EFFECT_FORMS["stribeck"])
def test_stribeck(form):
    r = S3(("stribeck", form, 1.0))
    m, v = machine(r), col(r, "qd")
    extra = col(r, "friction") - F_nom(m, v)
    law = 0.30 * m["f_c"] * STRIBECK_S[form](np.abs(v) / 1.6e-3) * np.tanh(v / V_C)
    np.testing.assert_allclose(extra, law, rtol=1e-6, atol=1e-6)
    slow = (np.abs(v) > 2e-4) & (np.abs(v) < 1e-3)
    assert np.mean(np.abs(extra[slow])) > 0.1 * m["f_c"]          # a rise at low speed ...
    fast = np.abs(v) > 0.015
    assert np.mean(np.abs(extra[fast])) < 0.05 * np.mean(np.abs(extra[slow]))   # ... falling
    _assert_changed(r, S3())


@pytest.mark.parametrize("form", R.EFFECT_FORMS["load_dependent_friction"])
def test_load_dependent_friction(form):
    r = S1(("load_dependent_friction", form, 1.0))
    m, v, ts = machine(r), col(r, "qd"), col(r, "torque_elastic")
    x = np.abs(ts) / T_RATED
    if form == "coulomb_linear":
        law = (m["f_c"] + 0.006 * np.abs(ts)) * np.tanh(v / V_C) + m["f_v"] * v
    elif form == "coulomb_viscous_scaled":
        law = m["f_c"] * (1 + 0.25 * x) * np.tanh(v / V_C) + m["f_v"] * (1 + 0.6 * x) * v
    else:
        w = 0.5 * (1 + np.tanh(ts * v / 10.0))
        c = 0.005 * w + 0.010 * (1 - w)
        law = (m["f_c"] + c * T_RATED * x ** 2) * np.tanh(v / V_C) + m["f_v"] * v
    np.testing.assert_allclose(col(r, "friction"), law, rtol=1e-6, atol=1e-6)
    high = col(r, "torque_cmd") > 100_000.0
    extra = col(r, "friction") - F_nom(m, v)
    assert np.all(extra[high] > 300.0) and np.all(extra[high] < 1500.0)
    _assert_changed(r, S1())
    if form == "quadratic_power_flow":   # back-driven: twice the coefficient
        rb = S1(("load_dependent_friction", form, 1.0), rpm=300, direction=-1)
        mb = machine(rb)
        hb = col(rb, "torque_cmd") > 100_000.0
        eb = -(col(rb, "friction") - F_nom(mb, col(rb, "qd")))[hb]
        xb = col(rb, "torque_elastic")[hb] / T_RATED
        np.testing.assert_allclose(eb, 0.010 * T_RATED * xb ** 2, rtol=0.02)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["temperature_friction"])
def test_temperature_friction(form):
    r = S1(("temperature_friction", form, 1.0), temp=15.0)
    m, v, th = machine(r), col(r, "qd"), col(r, "temp_joint")
    fc, fv = m["f_c"], m["f_v"]
    if form == "viscous_arrhenius":
        fv = fv * np.exp(np.clip(2600 * (1 / (th + 273.15) - 1 / 303.15), -3, 3))
    elif form == "coulomb_additive":
        fc = np.maximum(0.2 * fc, fc + 28.0 * (30.0 - th))
    else:
        mm = np.exp(np.clip(320 * (1 / (th + 95) - 1 / 125), -3, 3))
        fv, fc = fv * mm, fc * mm ** 0.35
    np.testing.assert_allclose(col(r, "friction"), fc * np.tanh(v / V_C) + fv * v,
                               rtol=1e-6, atol=1e-6)
    moving = col(r, "t") > 3.0
    assert np.all((col(r, "friction") - F_nom(m, v))[moving] > 50.0)    # cold: more friction
    _assert_changed(r, S1(temp=15.0))
    if form == "vogel_mixed":        # warm: less friction
        w = S1(("temperature_friction", form, 1.0), temp=60.0)
        assert np.all((col(w, "friction") - F_nom(machine(w), col(w, "qd")))[moving] < -200.0)


def test_gear_ripple_output_mesh_torque():
    r = S1(("gear_ripple", "output_mesh_torque", 1.0))
    (p1, p2, p3), _ = draws(r, "gear_ripple")
    zq = 73.0 * col(r, "q")
    rip = 320.0 * (np.sin(zq + p1) + 0.5 * np.sin(2 * zq + p2) + 0.25 * np.sin(3 * zq + p3))
    np.testing.assert_allclose(col(r, "disturbance"), -rip, rtol=1e-9, atol=1e-6)
    diff = col(r, "torque") - col(S1(), "torque")
    assert np.corrcoef(diff, rip)[0, 1] > 0.9           # the transmitted torque gains +R(q)
    assert 150.0 < np.std(diff) < 400.0


@pytest.mark.parametrize("form", ["intermediate_stage_error", "load_scaled_mesh_error"])
def test_gear_ripple_kinematic_errors(form):
    r = S1(("gear_ripple", form, 1.0))
    m = machine(r)
    (p1, p2, _), _ = draws(r, "gear_ripple")
    tw = col(r, "twist")
    if form == "intermediate_stage_error":
        zu = 6200.0 * col(r, "u")
        e = 200.0 / m["k0"] * (np.sin(zu + p1) + 0.4 * np.sin(2 * zu + p2))
    else:
        amp = 320.0 / m["k0"] * (0.2 + 0.8 * np.minimum(np.abs(K(m, tw)) / T_RATED, 1.5))
        e = amp * np.sin(73.0 * col(r, "q") + p1)
    np.testing.assert_allclose(col(r, "twist_engaged"), tw - e, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(col(r, "torque_elastic"), K(m, tw - e), rtol=1e-9, atol=1e-6)
    gap = K(m, tw) - col(r, "torque_elastic")       # the twist–torque law is off by ≈ k·e
    load = col(r, "torque_cmd")
    lo, hi = (load < 20_000) & (col(r, "t") > 3.0), load > 100_000
    assert np.std(gap[hi]) > 1.5 * np.std(gap[lo]) > 50.0
    if form == "intermediate_stage_error":   # 28 Hz, above the output mode: torque ripples
        assert np.std(col(r, "torque") - col(S1(), "torque")) > 100.0


@pytest.mark.parametrize("form", R.EFFECT_FORMS["torque_offset"])
def test_torque_offset(form):
    r, base = S3(("torque_offset", form, 1.0)), S3()
    _, sig = draws(r, "torque_offset")
    t = r.samples["t"].to_numpy()
    b = {"bias": 350.0 * sig + 0 * t, "linear_creep": 5.0 * sig * t,
         "sqrt_creep": 55.0 * sig * np.sqrt(t)}[form]
    diff = (r.samples["torque"] - base.samples["torque"]).to_numpy()
    np.testing.assert_allclose(diff, b, atol=2.0 + 1e-9)            # torque_res = 2 N·m
    pd.testing.assert_frame_equal(r.truth, base.truth)               # a reading effect only


@pytest.mark.parametrize("form,channels", [("torque_fieldbus", ["torque"]),
                                           ("q_encoder_latency", ["q", "qd"]),
                                           ("u_encoder_latency", ["u", "ud", "w_m1"])])
def test_time_delay(form, channels):
    r = S3(("time_delay", form, 1.0), sensors="exact")       # 100 Hz: 10 ms = one sample
    base = S3(sensors="exact")
    for ch in channels:
        a, b = r.samples[ch].to_numpy(), base.samples[ch].to_numpy()
        scale = np.max(np.abs(b))
        np.testing.assert_allclose(a[1:], b[:-1], atol=1e-6 * scale)
        assert np.max(np.abs(a - b)) > 1e-3 * scale
    others = {"torque", "q", "u"} - set(channels)
    for ch in others:
        np.testing.assert_array_equal(r.samples[ch], base.samples[ch])
    assert r.meta["sensors"] == base.meta["sensors"]            # the injected lag is not stated


@pytest.mark.parametrize("form", R.EFFECT_FORMS["hysteresis"])
def test_hysteresis(form):
    H = 500.0
    r = S3(("hysteresis", form, 1.0)) if form != "windup_loss" else S1(("hysteresis", form, 1.0))
    th = col(r, "torque_hysteresis")
    np.testing.assert_allclose(col(r, "torque"), col(r, "torque_elastic")
                               + col(r, "torque_damping") + th, rtol=1e-9, atol=1e-6)
    if form != "windup_loss":
        assert np.max(np.abs(th)) <= H * 1.001
        assert np.max(th) > 0.7 * H and np.min(th) < -0.7 * H
        # loading (twist grown by > 1e-4 rad over the last second) vs unloading branches
        tw = col(r, "twist_engaged")
        grown = tw[20:] - tw[:-20]
        up, down = grown > 1e-4, grown < -1e-4
        assert up.sum() > 10 and down.sum() > 10
        assert np.mean(th[20:][up]) > 0.4 * H and np.mean(th[20:][down]) < -0.4 * H
    else:   # the loop's width grows with the wind-up: ±2H at the rated twist
        cmd, ph = col(r, "torque_cmd"), r.samples["phase"].to_numpy()
        top_load = (cmd > 100_000) & (ph == "load")
        unload = (cmd > 60_000) & (cmd < 100_000) & (ph == "unload")   # z has flipped by then
        assert np.mean(th[top_load]) > 1.6 * H and np.mean(th[unload]) < -1.3 * H
        low = (cmd < 10_000) & (col(r, "t") > 3.0)
        assert np.max(np.abs(th[low])) < 1.0 * H
    base = S3() if form != "windup_loss" else S1()
    _assert_changed(r, base, "torsion", atol=1e-5)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["backlash"])
def test_backlash(form):
    b = 1.5e-4
    r = S3(("backlash", form, 1.0)) if form != "load_closing" \
        else S1(("backlash", form, 1.0))
    m, tw = machine(r), col(r, "twist")
    if form == "sharp":
        de = np.sign(tw) * np.maximum(np.abs(tw) - b, 0.0)
    elif form == "hyperbolic":
        eps = 0.35 * b
        c0 = 0.5 * (np.sqrt(b * b + eps * eps) - b)
        x = np.abs(tw) - b
        de = np.sign(tw) * (0.5 * (x + np.sqrt(x * x + eps * eps)) - c0)
    else:
        bb = b * np.exp(-np.abs(col(r, "torque_load")) / 30_000.0)
        de = np.sign(tw) * np.maximum(np.abs(tw) - bb, 0.0)
        # the offset of the twist at a given torque shrinks with the load
        gap = tw - col(r, "twist_engaged")
        cmd = col(r, "torque_cmd")
        assert np.mean(gap[(cmd < 5_000) & (col(r, "t") > 3)]) > 0.8 * b
        assert np.mean(gap[cmd > 100_000]) < 0.05 * b
    np.testing.assert_allclose(col(r, "twist_engaged"), de, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(col(r, "torque_elastic"), K(m, de), rtol=1e-9, atol=1e-6)
    if form != "load_closing":
        # at a given torque the encoders' twist is larger by about b (output winds further)
        base = S3()
        pos = col(r, "torque") > 1000
        assert np.mean((tw - col(base, "twist"))[pos]) == pytest.approx(b, rel=0.35)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["asymmetric_friction"])
def test_asymmetric_friction(form):
    r = S3(("asymmetric_friction", form, 1.0))
    m, v = machine(r), col(r, "qd")
    sg = np.tanh(v / V_C)
    cfc, cfv = {"coulomb_split": (0.11, 0.0), "coulomb_viscous_split": (0.07, 0.3),
                "viscous_split": (0.0, 0.6)}[form]
    law = m["f_c"] * (1 + cfc * sg) * sg + m["f_v"] * (1 + cfv * sg) * v
    np.testing.assert_allclose(col(r, "friction"), law, rtol=1e-6, atol=1e-6)
    extra = col(r, "friction") - F_nom(m, v)
    fast_pos, fast_neg = v > 0.01, v < -0.01
    # positive motion meets more friction, negative motion less: extra > 0 on both sides
    assert np.mean(extra[fast_pos]) > 50.0 and np.mean(extra[fast_neg]) > 50.0
    mag = np.abs(col(r, "friction")) - np.abs(F_nom(m, v))
    assert np.mean(mag[fast_pos]) > 50.0 and np.mean(mag[fast_neg]) < -50.0
    _assert_changed(r, S3())


@pytest.mark.parametrize("form", R.EFFECT_FORMS["periodic_disturbance"])
def test_periodic_disturbance(form):
    r, base = S3(("periodic_disturbance", form, 1.0)), S3()
    (p1, p2, _), _ = draws(r, "periodic_disturbance")
    t = col(r, "t")
    if form == "gauge_pickup":
        diff = (r.samples["torque"] - base.samples["torque"]).to_numpy()
        np.testing.assert_allclose(diff, 300.0 * np.sin(2 * np.pi * 16.7 * t + p1), atol=2.0)
        pd.testing.assert_frame_equal(r.truth, base.truth)
        return
    if form == "fan_sine":
        law = 320.0 * (np.sin(2 * np.pi * 3.1 * t + p1) + 0.3 * np.sin(2 * np.pi * 6.2 * t + p2))
    else:
        law = 320.0 * np.pi / 2 * (np.abs(np.sin(2 * np.pi * 0.9 * t + p1)) - 2 / np.pi)
    np.testing.assert_allclose(col(r, "disturbance"), law, rtol=1e-9, atol=1e-6)
    assert np.std(col(r, "torque") - col(base, "torque")) > 50.0


@pytest.mark.parametrize("form", R.EFFECT_FORMS["position_dependent_stiffness"])
def test_position_dependent_stiffness(form):
    r = S1(("position_dependent_stiffness", form, 1.0))
    m, q, tw = machine(r), col(r, "q"), col(r, "twist")
    (p1, _, _), qc = draws(r, "position_dependent_stiffness")
    f = {"soft_zone": lambda: np.maximum(0.1, 1 - 0.1 * np.exp(-((q - qc) / 0.04) ** 2)),
         "exp_gradient": lambda: np.exp(np.clip(0.15 * q, -2, 2)),
         "thrice_per_rev": lambda: np.maximum(0.1, 1 + 0.06 * np.sin(3 * q + p1))}[form]()
    np.testing.assert_allclose(col(r, "torque_elastic"), f * K(m, tw), rtol=1e-9, atol=1e-6)
    assert np.max(np.abs(f - 1)) > 0.02
    _assert_changed(r, S1(), "torsion", atol=1e-5)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["encoder_drift"])
def test_encoder_drift(form):
    r, base = S3(("encoder_drift", form, 1.0), sensors="exact"), S3(sensors="exact")
    _, sig = draws(r, "encoder_drift")
    t = r.samples["t"].to_numpy()
    ch = "u" if form == "u_linear" else "q"
    drift = 2.5e-6 * sig * t if form != "q_exponential" else 2.5e-4 * sig * (1 - np.exp(-t / 30))
    np.testing.assert_allclose((r.samples[ch] - base.samples[ch]).to_numpy(), drift,
                               atol=math.radians(1e-5))
    pd.testing.assert_frame_equal(r.truth, base.truth)


def test_second_resonance_bearing_mode():
    r, base = S1(("second_resonance", "bearing_mode", 1.0)), S1()
    m = machine(r)
    np.testing.assert_allclose(m["I"] * col(r, "qdd"),
                               col(r, "torque") - col(r, "load_on_output") - col(r, "gravity")
                               - col(r, "friction") + col(r, "coupling"), rtol=1e-6, atol=1e-3)
    i2 = 0.3 * m["I"]
    k2 = i2 * (2 * np.pi * 8.0) ** 2
    c2 = 2 * 0.02 * np.sqrt(k2 * i2)
    rel = col(r, "q_aux") - col(r, "q")
    reld = col(r, "qd_aux") - col(r, "qd")
    np.testing.assert_allclose(col(r, "coupling"), k2 * rel + c2 * reld, rtol=1e-9, atol=1e-6)
    assert np.std(col(r, "coupling")) > 20.0
    assert np.std(col(r, "torque") - col(base, "torque")) > 5.0
    assert np.all(col(base, "coupling") == 0.0)


def test_second_resonance_motor_shaft():
    r = S1(("second_resonance", "motor_shaft", 1.0))
    m = machine(r)
    rho = 0.3
    mu = (1 - rho) * rho * m["J_eq"]
    k2 = mu * (2 * np.pi * 10.0) ** 2
    # the encoders' twist includes the shaft's wind-up T/k2
    shaft = col(r, "u") - col(r, "u_gear")
    high = col(r, "torque_cmd") > 100_000
    np.testing.assert_allclose(shaft[high], col(r, "torque")[high] / k2, rtol=0.03)
    assert np.mean(shaft[high]) > 8e-5
    np.testing.assert_allclose(col(r, "torque_elastic"), K(m, col(r, "u_gear") - col(r, "q")),
                               rtol=1e-9, atol=1e-6)


def test_every_form_at_scale_max_is_finite():
    # one run per family at the largest scale, each in its most demanding form
    worst = {"stribeck": "lorentzian", "load_dependent_friction": "quadratic_power_flow",
             "hysteresis": "bouc_wen_n1", "backlash": "sharp",
             "second_resonance": "motor_shaft", "gear_ripple": "intermediate_stage_error"}
    r = R.simulate_run(1, 300, -1, 15.0, {k: {"form": f, "scale": R.SCALE_MAX}
                                          for k, f in worst.items()},
                       sensors=SLOW, periods=1, seed=SEED, run=0)
    assert np.isfinite(r.truth.to_numpy()).all()
    assert np.isfinite(r.samples.drop(columns="phase").to_numpy()).all()
    assert np.max(np.abs(col(r, "qd"))) < 0.2
