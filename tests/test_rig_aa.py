"""Rig AA (validation_rigs/rig_aa.py): the interface contract, the run format, the physics of the
paper (Eq. 4 balance, Eq. 5 transmission at the rated torque, the three schemes) and every effect
form against the law its data sheet states. Reference laws here are written again from the data
sheet, not imported from the rig."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pandas as pd
import pytest
from scipy.signal import welch

from core.channels import CHANNELS, PHASES
from core.run import RunData
from core.runfile import read_run, validate_meta, validate_samples, write_run
from validation_rigs import rig_aa as R

SEED = 11
VOCAB = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
         "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction")
OOV = ("periodic_disturbance", "position_dependent_stiffness", "encoder_drift", "second_resonance")
MIN_FORMS = {"stribeck": 3, "temperature_friction": 3, "load_dependent_friction": 2,
             "gear_ripple": 3, "torque_offset": 2, "time_delay": 2, "hysteresis": 3, "backlash": 2,
             "asymmetric_friction": 2, "periodic_disturbance": 2,
             "position_dependent_stiffness": 2, "encoder_drift": 2, "second_resonance": 2}
ALL_FORMS = [(n, f) for n, fs in R.EFFECT_FORMS.items() for f in fs]


def _freeze(effects):
    return None if effects is None else tuple(sorted((k, v["form"], v["scale"]) for k, v in effects.items()))


@lru_cache(maxsize=None)
def _cached(scheme, speed, direction, temp, frozen, sensors_items, run, periods):
    effects = None if frozen is None else {k: {"form": f, "scale": s} for k, f, s in frozen}
    sensors = None if sensors_items is None else R.SensorSpec(**dict(sensors_items))
    return R.simulate_run(scheme, speed, direction, temp, effects, sensors=sensors,
                          periods=periods, seed=SEED, run=run)


def sim(scheme, speed, direction=1, temp=25.0, effects=None, sensors=None, run=0, periods=1):
    s_items = None if sensors is None else tuple(sorted(sensors.items()))
    return _cached(scheme, speed, direction, temp, _freeze(effects), s_items, run, periods)


def eff(name, form, scale=1.0):
    return {name: {"form": form, "scale": scale}}


def K(d, p):
    """The data sheet's three-slope compliance curve."""
    a = np.abs(d)
    k1, k2, k3, t1, t2 = p["k1"], p["k2"], p["k3"], p["theta1"], p["theta2"]
    f = np.where(a <= t1, k1 * a, np.where(a <= t2, k1 * t1 + k2 * (a - t1),
                                         k1 * t1 + k2 * (t2 - t1) + k3 * (a - t2)))
    return np.sign(d) * f


def harmonic_amp(y, phase, phase2=None):
    """Amplitude of the line at `phase` (least squares, with an optional second line)."""
    cols = [np.sin(phase), np.cos(phase), np.ones_like(phase)]
    if phase2 is not None:
        cols += [np.sin(phase2), np.cos(phase2)]
    c = np.linalg.lstsq(np.column_stack(cols), y, rcond=None)[0]
    return math.hypot(c[0], c[1])


def steady(run, frac=0.6, t0=4.0):
    """Samples of steady sliding: after the start, |q̇| above frac of the scheme speed."""
    tr = run.truth
    v = abs(run.params["v_out"])
    return ((tr.t > t0) & (np.abs(tr.qd) > frac * v)).to_numpy()


def friction_law(run, form_of):
    """Steady-state friction of the data sheet: sgn(v)·g(v) + f_v·v (+ offset), from truth."""
    p, tr = run.params, run.truth
    v = tr.qd.to_numpy()
    Tj = tr.temp_joint.to_numpy()
    te = (tr.torque_elastic + tr.torque_hysteresis).to_numpy()
    sv = np.where(v >= 0, 1.0, -1.0)
    fc = np.full_like(v, p["f_c"])
    fv = p["f_v"] * np.exp(-0.008 * (Tj - 35.0))
    x = 35.0 - Tj
    e = run.params["effects"]
    f = form_of.get("temperature_friction")
    if f == "viscous_exponential":
        fv = fv * np.exp(np.clip(e["temperature_friction"]["b"] * x, -3, 3))
    elif f == "coulomb_linear":
        fc = fc * np.maximum(0.1, 1 + e["temperature_friction"]["c"] * x)
    elif f == "coulomb_viscous_linear":
        fc = fc * np.maximum(0.1, 1 + e["temperature_friction"]["c_coulomb"] * x)
        fv = fv * np.maximum(0.1, 1 + e["temperature_friction"]["c_viscous"] * x)
    elif f == "viscous_polynomial":
        y = x / 25.0
        fv = fv * np.maximum(0.1, 1 + e["temperature_friction"]["c"] * (0.5 * y + 0.3 * y * y))
    f = form_of.get("asymmetric_friction")
    off = 0.0
    if f == "coulomb":
        fc = fc * np.exp(e["asymmetric_friction"]["a_c"] * sv)
    elif f == "coulomb_viscous":
        fc = fc * np.exp(e["asymmetric_friction"]["a_c"] * sv)
        fv = fv * np.exp(e["asymmetric_friction"]["a_v"] * sv)
    elif f == "offset":
        off = e["asymmetric_friction"]["F0"]
    f = form_of.get("load_dependent_friction")
    if f == "coulomb":
        fc = fc + e["load_dependent_friction"]["mu"] * np.abs(te)
    elif f == "coulomb_viscous":
        fc = fc * (1 + e["load_dependent_friction"]["c_coulomb"] * np.abs(te) / 120e3)
        fv = fv * (1 + e["load_dependent_friction"]["c_viscous"] * np.abs(te) / 120e3)
    elif f == "power_flow":
        mu = np.where(te * v >= 0, e["load_dependent_friction"]["mu_drive"],
                      e["load_dependent_friction"]["mu_back"])
        fc = fc + mu * np.abs(te)
    g = fc
    f = form_of.get("stribeck")
    if f:
        xs = np.abs(v) / e["stribeck"]["v_s"]
        S = {"exponential": np.exp(-xs), "gaussian": np.exp(-xs ** 2),
             "lorentzian": 1 / (1 + xs ** 2), "sqrt_exponential": np.exp(-np.sqrt(xs))}[f]
        g = g + e["stribeck"]["dFs"] * S
    return sv * g + fv * v + off


# --- interface contract ----------------------------------------------------------------------

def test_constants_and_forms():
    assert R.RIG_NAME == "rig_aa"
    assert R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True
    assert isinstance(R.SCALE_MAX, float) and R.SCALE_MAX >= 10
    assert set(R.EFFECT_FORMS) == set(VOCAB) | set(OOV) and len(R.EFFECT_FORMS) == 13
    for name, n in MIN_FORMS.items():
        forms = R.EFFECT_FORMS[name]
        assert isinstance(forms, tuple) and len(forms) >= n, name
        assert len(set(forms)) == len(forms) and all(isinstance(f, str) for f in forms)
    assert tuple(sorted(R.OUT_OF_VOCABULARY)) == tuple(sorted(OOV)) and len(R.OUT_OF_VOCABULARY) == 4
    assert isinstance(R.UNSTATED_VOCABULARY, dict)
    for k, v in R.UNSTATED_VOCABULARY.items():
        assert k in VOCAB and isinstance(v, str) and len(v) > 20


def test_sensorspec_defaults_and_refusals():
    s = R.SensorSpec()
    assert s.sample_rate_hz == 1000.0 and s.encoder_res_deg == 0.01
    assert s.torque_noise >= 0 and s.torque_lag_s >= 0
    bad = {"sample_rate_hz": [5.0, 2000.0, float("nan"), float("inf"), "fast", True],
           "encoder_res_deg": [0.0, 2.0, float("nan"), -float("inf")],
           "torque_noise": [-1.0, float("nan"), float("inf"), None],
           "torque_lag_s": [-0.001, float("nan"), float("inf"), 5.0],
           "torque_filter_s": [-1.0], "qd_noise": [float("nan")], "load_res": [-2.0]}
    for field, values in bad.items():
        for v in values:
            with pytest.raises(ValueError, match=field):
                R.SensorSpec(**{field: v})


@pytest.mark.parametrize("kwargs,name", [
    (dict(scheme=4), "scheme"), (dict(scheme="1"), "scheme"), (dict(scheme=1.5), "scheme"),
    (dict(motor_speed_rpm=1000), "motor_speed_rpm"), (dict(motor_speed_rpm=None), "motor_speed_rpm"),
    (dict(scheme=3, motor_speed_rpm=300), "motor_speed_rpm"),
    (dict(direction=0), "direction"), (dict(direction=2), "direction"), (dict(direction=True), "direction"),
    (dict(temp_joint_c=10.0), "temp_joint_c"), (dict(temp_joint_c=61.0), "temp_joint_c"),
    (dict(temp_joint_c=float("nan")), "temp_joint_c"), (dict(temp_joint_c="20"), "temp_joint_c"),
    (dict(periods=0), "periods"), (dict(periods=2.5), "periods"), (dict(periods=True), "periods"),
    (dict(periods=5, motor_speed_rpm=3000), "periods"),
    (dict(seed=-1), "seed"), (dict(seed=1.5), "seed"), (dict(run=-2), "run"), (dict(run="0"), "run"),
    (dict(sensors="fast"), "sensors"),
    (dict(effects=["stribeck"]), "effects"), (dict(effects={"magic": {"form": "x", "scale": 1}}), "effects"),
    (dict(effects={"stribeck": {"form": "cubic", "scale": 1.0}}), "effects"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": -0.1}}), "effects"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": 10.5}}), "effects"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": float("nan")}}), "effects"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": True}}), "effects"),
    (dict(effects={"stribeck": {"form": "gaussian"}}), "effects"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": 1.0, "size": 2}}), "effects"),
    (dict(effects={"stribeck": 1.0}), "effects"),
])
def test_bad_arguments_name_the_argument(kwargs, name):
    args = dict(scheme=1, motor_speed_rpm=300, direction=1, temp_joint_c=25.0, effects=None,
                sensors=None, periods=1, seed=0, run=0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        R.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                       args.pop("temp_joint_c"), args.pop("effects"), **args)


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_scale_zero_is_no_effect_and_small_scale_is_small(name, form):
    sens = {"sample_rate_hz": 100.0}
    base = sim(3, None, 1, 20.0, None, sens)
    zero = R.simulate_run(3, None, 1, 20.0, eff(name, form, 0.0), sensors=R.SensorSpec(**sens),
                          periods=1, seed=SEED, run=0)
    pd.testing.assert_frame_equal(zero.samples, base.samples)
    pd.testing.assert_frame_equal(zero.truth, base.truth)
    one = sim(3, None, 1, 20.0, eff(name, form, 1.0), sens)
    tiny = R.simulate_run(3, None, 1, 20.0, eff(name, form, 1e-6), sensors=R.SensorSpec(**sens),
                          periods=1, seed=SEED, run=0)
    cols = ["torque", "twist", "q", "u"]
    d1 = np.abs(one.truth[cols].to_numpy() - base.truth[cols].to_numpy()).max(axis=0)
    dt = np.abs(tiny.truth[cols].to_numpy() - base.truth[cols].to_numpy()).max(axis=0)
    assert np.all(dt <= 1e-3 * d1 + 1e-9), (name, form, dt, d1)


def test_determinism_runs_and_seeds():
    a = R.simulate_run(1, 3000, -1, 30.0, eff("hysteresis", "dahl"), periods=1, seed=5, run=2)
    b = R.simulate_run(1, 3000, -1, 30.0, eff("hysteresis", "dahl"), periods=1, seed=5, run=2)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    assert a.meta == b.meta
    c = R.simulate_run(1, 3000, -1, 30.0, eff("hysteresis", "dahl"), periods=1, seed=5, run=3)
    assert not np.array_equal(a.samples.torque, c.samples.torque)
    assert a.params["I"] == c.params["I"] and a.params["k1"] == c.params["k1"]  # same machine
    d = R.simulate_run(1, 3000, -1, 30.0, eff("hysteresis", "dahl"), periods=1, seed=6, run=2)
    assert d.params["I"] != a.params["I"]
    for key, nom in (("I", 6685.166), ("mr_x", 20.779), ("mr_y", -34.543), ("f_v", 8683.272),
                     ("f_c", 2352.660), ("twist_rated_rad", math.radians(0.5))):
        for r in (a, d):
            assert abs(r.params[key] / nom - 1) < 0.15, key


# --- run format ------------------------------------------------------------------------------

@pytest.mark.parametrize("scheme,speed", [(1, 300), (2, 3000), (3, None)])
def test_samples_and_meta_validate(scheme, speed, tmp_path):
    r = sim(scheme, speed, -1, 40.0)
    s = validate_samples(r.samples, "rig_aa")
    m = validate_meta(r.meta, "rig_aa")
    for c in ("t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "phase", "torsion",
              "i_m1", "i_m2", "i_m3"):
        assert c in s.columns and c in CHANNELS
    assert set(s.phase.unique()) <= set(PHASES)
    assert m["scheme"] == scheme and m["direction"] == -1 and m["reduction"] == 11000.0
    assert m["motor_speed_rpm"] == (None if speed is None else float(speed))
    assert m["sensors"]["torque"]["noise_sd"] == 120.0
    assert m["sensors"]["q"]["resolution"] == pytest.approx(math.radians(0.01))
    dt = np.diff(r.samples.t.to_numpy())
    assert np.allclose(dt, 1e-3)
    assert list(r.truth.t) == list(r.samples.t)
    for c in ("twist", "torque"):
        assert c in r.truth.columns
    np.testing.assert_allclose(r.truth.twist, r.truth.u - r.truth.q)
    np.testing.assert_allclose(r.samples.torsion, r.samples.q - r.samples.u)
    written = write_run(RunData(samples=r.samples, meta=r.meta), tmp_path / "run", fmt="parquet")
    back = read_run(written[0])
    assert back.meta == r.meta and len(back.samples) == len(r.samples)


def test_sensor_statements_hold():
    r = sim(1, 3000, 1, 25.0)
    tr, s = r.truth, r.samples
    enc = r.meta["sensors"]["q"]["resolution"]
    assert np.abs(s.q - tr.q).max() <= enc / 2 + 1e-12
    assert np.allclose(np.round(s.q / enc) * enc, s.q)
    err = s.torque - tr.torque
    assert abs(err.std() / 120.0 - 1) < 0.05  # the stated noise SD (filter lag: a few N·m here)
    slow = R.simulate_run(1, 3000, 1, 25.0, sensors=R.SensorSpec(sample_rate_hz=100.0,
                                                                  encoder_res_deg=0.001),
                          periods=1, seed=SEED, run=0)
    assert np.allclose(np.diff(slow.samples.t), 0.01) and slow.meta["sample_rate_hz"] == 100.0
    assert slow.meta["sensors"]["q"]["resolution"] == pytest.approx(math.radians(0.001))
    # the machine does not depend on the sample rate (to integration accuracy)
    np.testing.assert_allclose(slow.truth.torque.to_numpy()[::5][:500],
                               tr.torque.to_numpy()[::50][:500], atol=60.0)


# --- physics against the paper ---------------------------------------------------------------

@pytest.mark.parametrize("direction", [1, -1])
def test_output_balance_eq4(direction):
    r = sim(1, 3000, direction, 25.0)
    p, tr = r.params, r.truth
    # the truth obeys I·q̈ = T − τ_out − gravity − F_f + τ_dist at every sample
    res = p["I"] * tr.qdd - (tr.torque - tr.load_on_output - tr.gravity - tr.friction + tr.disturbance)
    assert np.abs(res).max() < 1e-6 * 120e3
    # gravity and friction have Eq. 4's form: g(mr_x sin q + mr_y cos q), f_c sgn q̇ + f_v q̇
    np.testing.assert_allclose(tr.gravity, 9.81 * (p["mr_x"] * np.sin(tr.q) + p["mr_y"] * np.cos(tr.q)))
    m = steady(r)
    assert m.sum() > 20000
    fv = p["f_v"] * np.exp(-0.008 * (tr.temp_joint - 35.0))
    qdd = np.gradient(tr.qd.to_numpy(), tr.t.to_numpy())
    eq4 = tr.torque - tr.load_on_output - (p["I"] * qdd + tr.gravity + fv * tr.qd + p["f_c"] * np.sign(tr.qd))
    assert np.sqrt(np.mean(eq4[m] ** 2)) < 30.0  # vs f_c ≈ 2353 N·m
    # measured data: T ≈ torque_load + Eq. 4 terms within the noise
    d = r.samples.torque - r.samples.torque_load - (tr.gravity + fv * tr.qd + p["f_c"] * np.sign(tr.qd))
    assert abs(np.mean(d[m])) < 30.0


def test_eq4_holds_on_the_fourier_trajectory():
    r = sim(3, None, -1, 25.0)
    p, tr = r.params, r.truth
    qdd = np.gradient(tr.qd.to_numpy(), tr.t.to_numpy())
    fv = p["f_v"] * np.exp(-0.008 * (tr.temp_joint - 35.0))
    eq4 = tr.torque - tr.load_on_output - (p["I"] * qdd + tr.gravity + fv * tr.qd + p["f_c"] * np.sign(tr.qd))
    m = (np.abs(tr.qd) > 0.004).to_numpy()
    assert m.sum() > 10000
    assert np.sqrt(np.mean(eq4[m] ** 2)) < 30.0


def test_transmission_reaches_rated_torque_at_half_a_degree():
    r = sim(1, 300, 1, 25.0)
    p, tr = r.params, r.truth
    assert 0.45 < math.degrees(p["twist_rated_rad"]) < 0.55
    assert K(np.array([p["twist_rated_rad"]]), p)[0] == pytest.approx(120e3, rel=1e-12)
    np.testing.assert_allclose(tr.torque_elastic, K(tr.twist.to_numpy(), p), rtol=1e-10, atol=1e-6)
    load = (r.samples.phase == "load").to_numpy()
    tw, te = tr.twist.to_numpy()[load], tr.torque_elastic.to_numpy()[load]
    i = np.argmax(te >= 120e3)
    assert te[i] >= 120e3
    assert abs(tw[i] / p["twist_rated_rad"] - 1) < 0.002
    assert tr.torque.max() > 120e3 and r.samples.torque.max() > 119e3
    # progressive stiffness: the top slope is 2.4 × the first
    lo = (np.abs(te) < 5e3)
    hi = te > 100e3
    s_lo = np.polyfit(tw[lo], te[lo], 1)[0]
    s_hi = np.polyfit(tw[hi], te[hi], 1)[0]
    assert s_hi / s_lo == pytest.approx(2.4, rel=0.02)
    # the paper's torsion q − u is negative under positive load
    assert r.samples.torsion[load].iloc[-1] < -math.radians(0.4)


def _runs(phase):
    ph = list(phase)
    out = []
    for p in ph:
        if not out or out[-1][0] != p:
            out.append([p, 0])
        out[-1][1] += 1
    return out


def test_scheme1_phases_speed_and_load():
    r = sim(1, 3000, -1, 25.0, periods=2)
    s, tr = r.samples, r.truth
    assert [p for p, _ in _runs(s.phase)] == ["idle", "load", "unload", "load", "unload", "idle"]
    v = -3000 * 2 * math.pi / 60 / 11000
    assert r.params["v_out"] == pytest.approx(v)
    idle = (s.t > 2.0) & (s.t < 3.0)
    assert tr.ud[idle].mean() == pytest.approx(v, rel=0.01)
    assert tr.qd[idle].mean() == pytest.approx(v, rel=0.02)
    assert np.abs(s.q).max() < math.pi
    cmd = s.torque_cmd.to_numpy()
    assert cmd.max() == pytest.approx(120e3) and cmd.min() == 0.0
    load = (s.phase == "load").to_numpy()
    assert np.all(np.diff(cmd[load][:12000]) >= -1e-9)
    # the dynamometer follows within Table 11's ±2 kN·m
    assert np.abs(s.torque_load - s.torque_cmd)[s.t > 0.5].max() < 2000.0
    # joint torque at the peak: the load plus friction (back-driven: minus friction)
    peak = np.argmax(cmd)
    assert tr.torque[peak] == pytest.approx(tr.torque_load[peak] + tr.gravity[peak] - r.params["f_c"]
                                            + r.params["f_v"] * v, abs=200.0)


def test_scheme2_steps_holds_and_currents():
    r = sim(2, 300, 1, 25.0)
    s, tr = r.samples, r.truth
    runs = _runs(s.phase)
    assert [p for p, _ in runs] == ["idle"] + ["load", "hold"] * 12 + ["unload", "idle"]
    holds = [n for p, n in runs if p == "hold"]
    assert all(abs(n - 2000) <= 1 for n in holds)
    levels, torques, currents = [], [], []
    for k in range(12):
        start = 3.0 + 2.3 * k + 0.3
        m = ((s.t > start + 0.5) & (s.t < start + 1.9)).to_numpy()
        assert set(s.phase[m]) == {"hold"}
        levels.append(s.torque_cmd[m].mean())
        torques.append(s.torque[m].mean())
        currents.append(s[["i_m1", "i_m2", "i_m3"]][m].mean().mean())
    np.testing.assert_allclose(levels, 10e3 * np.arange(1, 13))
    assert np.all(np.diff(torques) > 8e3)
    # motor current follows the torque: i = τ_m/(N·Σk_t), τ_m ≈ T·(1 + (1 − η)) + motor drag
    slope = np.polyfit(torques, currents, 1)[0]
    expect = (1 + (1 - r.params["eta"])) / (11000 * sum(r.params["k_t"]))
    assert slope == pytest.approx(expect, rel=0.05)
    assert np.corrcoef(torques, currents)[0, 1] > 0.999


def test_scheme3_fourier_trajectory():
    r = sim(3, None, -1, 25.0, periods=2)
    s, tr = r.samples, r.truth
    assert [p for p, _ in _runs(s.phase)] == ["idle", "excite", "idle"]
    ex = (s.phase == "excite").to_numpy()
    assert ex.sum() == 60000
    assert (s.torque_cmd == 0).all()
    qF, qdF, qddF = R.fourier_trajectory(tr.t.to_numpy() - 2.0)
    # Eq. 12 with five harmonics, mirrored by direction; the joint lags the motor by the twist
    assert np.abs(tr.u[ex] - r.params["u0"] + qF[ex]).max() < math.radians(0.02)
    assert np.abs(tr.q[ex] + qF[ex]).max() < math.radians(0.05)
    assert np.abs(tr.qd).max() <= 3000 * 2 * math.pi / 60 / 11000
    assert np.abs(s.q).max() < math.pi
    a, b, w = R.fourier_coefficients()
    assert len(a) == len(b) == 5
    assert abs(a.sum()) < 1e-15 and abs((np.arange(1, 6) * b).sum()) < 1e-15
    t = np.arange(0, 30, 0.01)
    q, qd, qdd = R.fourier_trajectory(t)
    Y = np.column_stack([qdd, 9.81 * np.sin(q), 9.81 * np.cos(q), qd, np.sign(qd)])
    assert np.linalg.cond(Y / np.linalg.norm(Y, axis=0)) < 3.0
    # reversals: the joint sticks (LuGre) while the motor winds the transmission up
    assert tr.torque.max() > r.params["f_c"] and tr.torque.min() < -r.params["f_c"]


def test_gearbox_temperature_drifts():
    cold = sim(1, 3000, 1, 15.0)
    hot = sim(1, 3000, 1, 60.0)
    assert cold.truth.temp_joint.iloc[-1] > 15.0
    assert hot.truth.temp_joint.iloc[-1] < 60.0
    assert abs(hot.samples.temp_joint.iloc[0] - 60.0) < 0.3
    # the declared nominal temperature law of viscous friction
    m = steady(cold)
    fr_c = (cold.truth.friction[m] - cold.params["f_c"]) / cold.truth.qd[m]
    m = steady(hot)
    fr_h = (hot.truth.friction[m] - hot.params["f_c"]) / hot.truth.qd[m]
    assert fr_c.mean() / fr_h.mean() == pytest.approx(math.exp(0.008 * 45), rel=0.02)


# --- effects ---------------------------------------------------------------------------------

def _assert_friction_law(run, form_of, tol):
    m = steady(run)
    law = friction_law(run, form_of)
    err = (run.truth.friction.to_numpy() - law)[m]
    assert np.sqrt(np.mean(err ** 2)) < tol, np.abs(err).max()


@pytest.mark.parametrize("form", R.EFFECT_FORMS["stribeck"])
def test_stribeck(form):
    b = sim(1, 300, 1)
    e = sim(1, 300, 1, effects=eff("stribeck", form))
    _assert_friction_law(e, {"stribeck": form}, 15.0)
    ep = e.params["effects"]["stribeck"]
    assert ep["dFs"] == pytest.approx(0.25 * e.params["f_c"]) and ep["v_s"] == 3e-3
    m = steady(e)
    d = (e.samples.torque - b.samples.torque).to_numpy()[m]
    assert 150.0 < d.mean() < 0.6 * ep["dFs"]  # friction above Coulomb at 300 r/min
    fast_b, fast_e = sim(1, 3000, 1), sim(1, 3000, 1, effects=eff("stribeck", form))
    dfast = (fast_e.samples.torque - fast_b.samples.torque).to_numpy()[steady(fast_e)]
    assert abs(dfast.mean()) < 0.15 * d.mean()  # falling with speed


@pytest.mark.parametrize("form", R.EFFECT_FORMS["load_dependent_friction"])
def test_load_dependent_friction(form):
    slopes = {}
    for d in (1, -1):
        b = sim(1, 3000, d)
        e = sim(1, 3000, d, effects=eff("load_dependent_friction", form))
        _assert_friction_law(e, {"load_dependent_friction": form}, 10.0)
        m = steady(e)
        T = np.abs(e.truth.torque_elastic.to_numpy()[m])
        dT = (e.samples.torque - b.samples.torque).to_numpy()[m]
        slopes[d] = np.polyfit(T, dT, 1)[0]
    ep = sim(1, 3000, 1, effects=eff("load_dependent_friction", form)).params["effects"]["load_dependent_friction"]
    p = sim(1, 3000, 1).params
    v = abs(p["v_out"])
    if form == "coulomb":
        exp_p, exp_m = ep["mu"], -ep["mu"]
    elif form == "coulomb_viscous":
        k = (ep["c_coulomb"] * p["f_c"] + ep["c_viscous"] * p["f_v"] * v) / 120e3
        exp_p, exp_m = k, -k
    else:  # driving when moving with the load's resistance (+), back-driven when reversed (−)
        exp_p, exp_m = ep["mu_drive"], -ep["mu_back"]
    assert slopes[1] == pytest.approx(exp_p, rel=0.12)
    assert slopes[-1] == pytest.approx(exp_m, rel=0.12)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["temperature_friction"])
def test_temperature_friction(form):
    means = {}
    for temp in (15.0, 55.0):
        b = sim(1, 3000, 1, temp)
        e = sim(1, 3000, 1, temp, effects=eff("temperature_friction", form))
        _assert_friction_law(e, {"temperature_friction": form}, 10.0)
        m = steady(e)
        means[temp] = (e.samples.torque - b.samples.torque).to_numpy()[m].mean()
    assert means[15.0] > 40.0 and means[55.0] < -20.0  # more drag cold, less warm
    # and nothing at the reference temperature
    b, e = sim(1, 3000, 1, 35.0), sim(1, 3000, 1, 35.0, effects=eff("temperature_friction", form))
    assert abs((e.samples.torque - b.samples.torque).to_numpy()[steady(e)].mean()) < 15.0


@pytest.mark.parametrize("form", R.EFFECT_FORMS["gear_ripple"])
def test_gear_ripple(form):
    speed = 300 if form == "output_mesh" else 3000
    b = sim(1, speed, 1)
    e = sim(1, speed, 1, effects=eff("gear_ripple", form))
    p, tr, ep = e.params, e.truth, e.params["effects"]["gear_ripple"]
    q, u = tr.q.to_numpy(), tr.u.to_numpy()
    m = (tr.t > 4.0).to_numpy()
    if form in ("output_mesh", "load_modulated"):
        R_q = ep["A"] * (np.sin(96 * q + ep["phi1"]) + 0.35 * np.sin(192 * q + ep["phi2"]))
        if form == "load_modulated":
            R_q = R_q * (0.2 + 0.8 * np.minimum(np.abs(tr.torque_elastic) / 120e3, 1.5))
        np.testing.assert_allclose(tr.disturbance, -R_q, atol=1e-9)
        dT = (e.samples.torque - b.samples.torque).to_numpy()
        if form == "output_mesh":  # a line at 96 cycles per output revolution, amplitude A
            assert harmonic_amp(dT[m], 96 * q[m] + ep["phi1"]) == pytest.approx(ep["A"], rel=0.1)
        else:
            te = np.abs(tr.torque_elastic.to_numpy())
            lo, hi = m & (te < 25e3), m & (te > 95e3)
            a_lo = harmonic_amp(dT[lo], 96 * q[lo], 192 * q[lo])
            a_hi = harmonic_amp(dT[hi], 96 * q[hi], 192 * q[hi])
            assert a_hi > 2.5 * a_lo and a_hi == pytest.approx(ep["A"] * 0.95, rel=0.2)
    elif form == "motor_stage":
        e_m = ep["E"] * (np.sin(2 * 11000 * u + ep["phi1"]) + 0.3 * np.sin(4 * 11000 * u + ep["phi2"]))
        np.testing.assert_allclose(tr.torque_elastic, K(tr.twist.to_numpy() + e_m, p), rtol=1e-9, atol=1e-5)
        dT = (tr.torque - b.truth.torque).to_numpy()
        low = m & (np.abs(tr.torque_elastic.to_numpy()) < 6e3)
        # 2 cycles per motor revolution: 100 Hz at 3000 r/min, k1·E in the first slope
        assert harmonic_amp(dT[low], 2 * 11000 * u[low] + ep["phi1"]) == pytest.approx(p["k1"] * ep["E"], rel=0.1)
        f, P = welch(e.samples.torque.to_numpy(), fs=1000.0, nperseg=4096)
        fb, Pb = welch(b.samples.torque.to_numpy(), fs=1000.0, nperseg=4096)
        band = (f > 98) & (f < 102)
        assert P[band].sum() > 20 * Pb[band].sum()
    else:
        e_q = ep["E"] * (np.sin(96 * q + ep["phi1"]) + 0.3 * np.sin(192 * q + ep["phi2"]))
        np.testing.assert_allclose(tr.torque_elastic, K(tr.twist.to_numpy() - e_q, p), rtol=1e-9, atol=1e-5)
        dtw = (tr.twist - b.truth.twist).to_numpy()
        assert harmonic_amp(dtw[m], 96 * q[m] + ep["phi1"]) == pytest.approx(ep["E"], rel=0.1)
        assert np.sqrt(np.mean((tr.torque - b.truth.torque) ** 2)) < 0.1 * p["k1"] * ep["E"]


@pytest.mark.parametrize("form", R.EFFECT_FORMS["torque_offset"])
def test_torque_offset(form):
    b = sim(3, None, 1)
    e = sim(3, None, 1, effects=eff("torque_offset", form))
    ep, t = e.params["effects"]["torque_offset"], e.samples.t.to_numpy()
    expect = {"constant": lambda: np.full_like(t, ep.get("B", 0.0)),
              "linear_drift": lambda: ep.get("rate", 0.0) * t,
              "exponential_drift": lambda: ep.get("B", 0.0) * (1 - np.exp(-t / 30.0))}[form]()
    assert np.abs(expect).max() > 80.0
    d = (e.samples.torque - b.samples.torque).to_numpy()
    assert np.abs(d - expect).max() <= 2.0 + 1e-9  # the ADC step
    pd.testing.assert_frame_equal(e.truth, b.truth)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["time_delay"])
def test_time_delay(form):
    quiet = {"torque_noise": 0.0, "torque_res": 0.0, "qd_noise": 0.0, "ud_noise": 0.0,
             "encoder_res_deg": 1e-5, "motor_encoder_res": 0.0}
    b = sim(3, None, 1, sensors=quiet)
    e = sim(3, None, 1, effects=eff("time_delay", form, 2.0), sensors=quiet)
    assert e.params["effects"]["time_delay"]["delay_s"] == pytest.approx(0.020)
    pd.testing.assert_frame_equal(e.truth, b.truth)
    k = 20  # samples at 1 kHz
    cols = {"torque": ["torque"], "output_encoder": ["q", "qd"], "motor_encoder": ["u", "ud", "w_m1"]}[form]
    for c in cols:
        x, y = e.samples[c].to_numpy(), b.samples[c].to_numpy()
        tol = 2 * math.radians(1e-5) if c == "q" else 1e-9 * (np.abs(y).max() + 1)
        assert np.abs(x[k:] - y[:-k]).max() <= tol, c
        assert np.abs(x - y).max() > 100 * tol, c
    others = [c for c in ("torque", "q", "u") if c not in cols]
    for c in others:
        np.testing.assert_array_equal(e.samples[c], b.samples[c])


@pytest.mark.parametrize("form", R.EFFECT_FORMS["hysteresis"])
def test_hysteresis(form):
    def gap(r):
        out = []
        for ph in ("load", "unload"):
            m = (r.samples.phase == ph).to_numpy()
            tw, T = r.truth.twist.to_numpy()[m], r.truth.torque.to_numpy()[m]
            o = np.argsort(tw)
            out.append((tw[o], T[o]))
        grid = np.linspace(math.radians(0.1), math.radians(0.4), 60)
        return float(np.mean(np.interp(grid, *out[0]) - np.interp(grid, *out[1])))
    b = sim(1, 300, 1)
    e = sim(1, 300, 1, effects=eff("hysteresis", form))
    H = e.params["effects"]["hysteresis"]["H"]
    assert H == 600.0
    assert np.abs(e.truth.torque_hysteresis).max() <= 1.001 * H
    assert np.abs(b.truth.torque_hysteresis).max() == 0.0
    # loading and unloading branches part by ≈ 2H at equal twist
    assert gap(e) - gap(b) == pytest.approx(2 * H, rel=0.1)
    # and the loops appear at the small reversals of scheme 3 too
    b3, e3 = sim(3, None, 1), sim(3, None, 1, effects=eff("hysteresis", form))
    assert np.sqrt(np.mean((e3.truth.torque_hysteresis) ** 2)) > 0.25 * H


def _dead(d, b, form, aux):
    if form == "sharp":
        return np.where(d > b, d - b, np.where(d < -b, d + b, 0.0))
    if form == "smooth":
        sp = lambda x: np.maximum(x, 0) + np.log1p(np.exp(-np.abs(x)))  # noqa: E731
        return aux * (sp((d - b) / aux) - sp((-d - b) / aux))
    return np.where(d > b, d - (1 - aux) * b, np.where(d < -b, d + (1 - aux) * b, aux * d))


@pytest.mark.parametrize("form", R.EFFECT_FORMS["backlash"])
def test_backlash(form):
    def intercept_gap(r):
        T, tw = r.truth.torque.to_numpy(), r.truth.twist.to_numpy()
        mp, mn = (T > 800) & (T < 2000), (T < -800) & (T > -2000)
        return np.polyfit(T[mp], tw[mp], 1)[1] - np.polyfit(T[mn], tw[mn], 1)[1]
    b = sim(3, None, 1)
    e = sim(3, None, 1, effects=eff("backlash", form))
    ep, p, tr = e.params["effects"]["backlash"], e.params, e.truth
    np.testing.assert_allclose(tr.torque_elastic, K(_dead(tr.twist.to_numpy(), ep["b"], form, ep["aux"]), p),
                               rtol=1e-9, atol=1e-5)
    play = 2 * ep["b"] * (1 - ep["aux"] if form == "preloaded" else 1.0)
    assert intercept_gap(e) - intercept_gap(b) == pytest.approx(play, rel=0.12)
    # the encoders see it: the twist reading jumps at torque reversals
    assert intercept_gap(e) > 1.2 * R.SensorSpec().encoder_res_deg * math.pi / 180


@pytest.mark.parametrize("form", R.EFFECT_FORMS["asymmetric_friction"])
def test_asymmetric_friction(form):
    d_mean = {}
    for d in (1, -1):
        b = sim(1, 3000, d)
        e = sim(1, 3000, d, effects=eff("asymmetric_friction", form))
        _assert_friction_law(e, {"asymmetric_friction": form}, 10.0)
        m = steady(e)
        d_mean[d] = (e.samples.torque - b.samples.torque).to_numpy()[m].mean()
    ep = e.params["effects"]["asymmetric_friction"]
    fc = e.params["f_c"]
    fvv = e.params["f_v"] * math.exp(-0.008 * (25.0 - 35.0)) * abs(e.params["v_out"])
    if form == "offset":
        assert d_mean[1] == pytest.approx(ep["F0"], rel=0.05)
        assert d_mean[-1] == pytest.approx(ep["F0"], rel=0.05)
    else:
        # the levels rise for positive motion and fall for negative motion
        a_c, a_v = ep["a_c"], ep.get("a_v", 0.0)
        assert d_mean[1] == pytest.approx(fc * math.expm1(a_c) + fvv * math.expm1(a_v), rel=0.05)
        assert d_mean[-1] == pytest.approx(-fc * math.expm1(-a_c) - fvv * math.expm1(-a_v), rel=0.05)
        assert d_mean[1] > d_mean[-1] > 0


@pytest.mark.parametrize("form", R.EFFECT_FORMS["periodic_disturbance"])
def test_periodic_disturbance(form):
    b = sim(1, 300, 1)
    e = sim(1, 300, 1, effects=eff("periodic_disturbance", form))
    ep, t = e.params["effects"]["periodic_disturbance"], e.truth.t.to_numpy()
    d = (e.samples.torque - b.samples.torque).to_numpy()
    if form == "pump_torque":
        wp = 2 * np.pi * ep["f"] * t
        law = ep["A"] * (np.sin(wp + ep["phi1"]) + 0.4 * np.sin(2 * wp + ep["phi2"]))
        np.testing.assert_allclose(e.truth.disturbance, law, atol=1e-9)
        a = harmonic_amp(d, 2 * np.pi * ep["f"] * t + ep["phi1"])
        assert 0.8 * ep["A"] < a < 1.6 * ep["A"]
    else:
        pd.testing.assert_frame_equal(e.truth, b.truth)
        assert np.abs(d - ep["A"] * np.sin(2 * np.pi * 50.0 * t + ep["phi1"])).max() <= 2.0 + 1e-9


@pytest.mark.parametrize("form", R.EFFECT_FORMS["position_dependent_stiffness"])
def test_position_dependent_stiffness(form):
    b = sim(1, 3000, 1)
    e = sim(1, 3000, 1, effects=eff("position_dependent_stiffness", form))
    ep, p, tr = e.params["effects"]["position_dependent_stiffness"], e.params, e.truth
    q = tr.q.to_numpy()
    f = {"once_per_rev": 1 + ep["amp"] * np.cos(q + ep["phi"]),
         "twice_per_rev": 1 + ep["amp"] * np.cos(2 * q + ep["phi"]),
         "linear": np.maximum(0.1, 1 + ep["amp"] * q)}[form]
    np.testing.assert_allclose(tr.torque_elastic, f * K(tr.twist.to_numpy(), p), rtol=1e-9, atol=1e-5)
    # at high load the twist changes by 1/f while the torque does not
    hi = (tr.torque_elastic > 60e3).to_numpy()
    ratio = tr.twist.to_numpy()[hi] / b.truth.twist.to_numpy()[hi]
    assert np.abs(ratio * f[hi] - 1).max() < 0.01
    assert np.abs(f[hi] - 1).max() > 0.01


@pytest.mark.parametrize("form", R.EFFECT_FORMS["encoder_drift"])
def test_encoder_drift(form):
    fine = {"encoder_res_deg": 1e-5}
    b = sim(1, 3000, 1, sensors=fine)
    e = sim(1, 3000, 1, effects=eff("encoder_drift", form), sensors=fine)
    pd.testing.assert_frame_equal(e.truth, b.truth)
    ep, t = e.params["effects"]["encoder_drift"], e.samples.t.to_numpy()
    step = math.radians(1e-5)
    dq = (e.samples.q - b.samples.q).to_numpy()
    du = (e.samples.u - b.samples.u).to_numpy()
    if form == "output_linear":
        assert np.abs(dq - ep["rate"] * t).max() <= step * 1.01
        assert np.array_equal(e.samples.u, b.samples.u)
    elif form == "motor_linear":
        res = R.SensorSpec().motor_encoder_res
        assert np.abs(du - ep["rate"] * t).max() <= res * 1.01
        assert np.array_equal(e.samples.q, b.samples.q)
    else:
        inc = np.diff(dq)
        assert inc.std() == pytest.approx(ep["sigma"] * math.sqrt(1e-3), rel=0.1)
        assert np.abs(dq).max() > 20 * step
    assert np.abs(e.samples.torsion - b.samples.torsion).max() > 30 * step


@pytest.mark.parametrize("form", R.EFFECT_FORMS["second_resonance"])
def test_second_resonance(form):
    b = sim(2, 3000, 1)
    e = sim(2, 3000, 1, effects=eff("second_resonance", form))
    ep = e.params["effects"]["second_resonance"]
    f2 = ep["f"]
    assert ep["k2"] == pytest.approx(ep["I2"] * (2 * np.pi * f2) ** 2)
    f, Pe = welch(e.samples.torque.to_numpy(), fs=1000.0, nperseg=8192)
    _, Pb = welch(b.samples.torque.to_numpy(), fs=1000.0, nperseg=8192)
    far = (f > 30) & (f < 45)
    assert Pe[far].sum() / Pb[far].sum() == pytest.approx(1.0, abs=0.05)
    if form == "link_mode":  # a tuned-mass pair: a notch at f2 in the transmitted torque
        band = (f > f2 - 1.5) & (f < f2 + 0.5)
        assert Pe[band].sum() / Pb[band].sum() < 0.6
    else:  # a resonance peak at f2; the output feels the shaft, the dynamometer reads its own torque
        band = (f > f2 - 1.0) & (f < f2 + 1.0)
        assert Pe[band].sum() / Pb[band].sum() > 2.0
        np.testing.assert_array_equal(e.samples.torque_load, b.samples.torque_load)
        gap = (e.truth.load_on_output - e.truth.torque_load).to_numpy()
        assert np.abs(gap).max() > 150.0


def test_unstated_vocabulary_is_what_the_machine_does():
    """The declared nominal imperfections are present at zero effects."""
    assert set(R.UNSTATED_VOCABULARY) == {"temperature_friction", "load_dependent_friction", "time_delay"}
    r = sim(1, 3000, 1)
    assert r.meta["sensors"]["torque"]["lag_s"] == pytest.approx(5e-4)
    m = steady(r)
    tr = r.truth
    te = np.abs(tr.torque_elastic.to_numpy()[m])
    # motor-side drag grows with |T| by (1 − η) (currents only), the torque transducer is unaffected
    drag = tr.motor_friction.to_numpy()[m] - r.params["f_mv"] * tr.ud.to_numpy()[m]
    assert np.polyfit(te, drag, 1)[0] == pytest.approx(1 - r.params["eta"], rel=0.02)
