"""Rig AC (validation_rigs/rig_ac.py): interface, argument checks, run format, the nominal
physics of its data sheet (written again here) and the size/sign of every effect form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.run import RunData
from core.runfile import read_run, validate_meta, validate_samples, write_run
from validation_rigs import rig_ac as R

N = 11000.0
F_C, F_V = 2352.660, 8683.272          # data sheet nominal friction
TWIST_RATED = math.radians(0.5)        # data sheet rated twist at 120 kN·m
SEED = 7


def w_out(rpm):
    return rpm * 2 * math.pi / 60 / N


_cache: dict = {}


def sim(scheme=1, rpm=300, direction=1, temp=35.0, effects=None, periods=1, **kw):
    key = (scheme, rpm, direction, temp, repr(effects), periods, repr(kw))
    if key not in _cache:
        _cache[key] = R.simulate_run(scheme, None if scheme == 3 else rpm, direction, temp,
                                     effects, periods=periods, seed=SEED, run=0, **kw)
    return _cache[key]


def eff(name, form, scale=1.0):
    return {name: {"form": form, "scale": scale}}


def mask(r, phase):
    return (r.samples["phase"] == phase).to_numpy()


# --- interface ------------------------------------------------------------------------------------

def test_interface_constants():
    assert R.RIG_NAME == "rig_ac" and R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True and R.SCALE_MAX == 10.0
    need = {"stribeck": 3, "load_dependent_friction": 2, "temperature_friction": 3,
            "gear_ripple": 3, "torque_offset": 2, "time_delay": 2, "hysteresis": 3,
            "backlash": 2, "asymmetric_friction": 2, "periodic_disturbance": 2,
            "position_dependent_stiffness": 2, "encoder_drift": 2, "second_resonance": 2}
    assert set(R.EFFECT_FORMS) == set(need)
    for k, n in need.items():
        assert len(R.EFFECT_FORMS[k]) >= n and len(set(R.EFFECT_FORMS[k])) == len(R.EFFECT_FORMS[k])
    assert R.OUT_OF_VOCABULARY == ("periodic_disturbance", "position_dependent_stiffness",
                                   "encoder_drift", "second_resonance")
    first_nine = [k for k in R.EFFECT_FORMS if k not in R.OUT_OF_VOCABULARY]
    assert len(R.UNSTATED_VOCABULARY) <= 2
    assert all(k in first_nine and isinstance(v, str) and v for k, v in R.UNSTATED_VOCABULARY.items())
    assert "torque_latency" in R.EFFECT_FORMS["time_delay"]
    assert "q_encoder_latency" in R.EFFECT_FORMS["time_delay"]


@pytest.mark.parametrize("field,value", [
    ("sample_rate_hz", float("nan")), ("sample_rate_hz", 5.0), ("encoder_res_deg", float("inf")),
    ("torque_noise", -1.0), ("torque_lag_s", "0.1"), ("torque_filter_s", 0.5),
    ("motor_encoder_res", True), ("temp_noise", 11.0)])
def test_sensorspec_checks(field, value):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})


def test_sensorspec_defaults():
    s = R.SensorSpec()
    assert s.sample_rate_hz == 1000.0 and s.encoder_res_deg == 0.01
    assert isinstance(R.SensorSpec(sample_rate_hz=100).sample_rate_hz, float)


@pytest.mark.parametrize("args,field", [
    (dict(scheme=4), "scheme"), (dict(scheme=True), "scheme"),
    (dict(motor_speed_rpm=1000), "motor_speed_rpm"), (dict(scheme=3), "motor_speed_rpm"),
    (dict(direction=0), "direction"), (dict(temp_joint_c=float("nan")), "temp_joint_c"),
    (dict(temp_joint_c=70.0), "temp_joint_c"), (dict(sensors={}), "sensors"),
    (dict(periods=0), "periods"), (dict(periods=2.0), "periods"), (dict(seed=-1), "seed"),
    (dict(run=1.5), "run"), (dict(effects={"nope": {}}), "nope"),
    (dict(effects=eff("stribeck", "bogus")), "bogus"),
    (dict(effects=eff("stribeck", "gaussian", 10.5)), "SCALE_MAX"),
    (dict(effects=eff("stribeck", "gaussian", -1)), "scale"),
    (dict(effects={"stribeck": {"form": "gaussian", "size": 1}}), "size"),
    (dict(scheme=2, periods=4, motor_speed_rpm=3000), "periods")])
def test_argument_checks(args, field):
    a = dict(scheme=1, motor_speed_rpm=300, direction=1, temp_joint_c=30.0, effects=None)
    kw = dict(seed=1, run=0)
    for k in ("sensors", "periods", "seed", "run"):
        if k in args:
            kw[k] = args.pop(k)
    a.update(args)
    with pytest.raises(ValueError, match=field):
        R.simulate_run(a["scheme"], a["motor_speed_rpm"], a["direction"], a["temp_joint_c"],
                       a["effects"], **kw)


def test_periods_three_accepted_everywhere():
    for scheme, rpm in ((1, 300), (1, 3000), (2, 300), (2, 3000), (3, None)):
        r = R.simulate_run(scheme, rpm, -1, 30.0, periods=3, seed=2, run=1,
                           sensors=R.SensorSpec(sample_rate_hz=10))
        assert np.isfinite(r.truth.to_numpy(dtype=float)).all()
        assert abs(r.truth["q"]).max() < math.pi


def test_determinism_and_seed_roles():
    a = R.simulate_run(3, None, 1, 30.0, seed=3, run=2, periods=1)
    b = R.simulate_run(3, None, 1, 30.0, seed=3, run=2, periods=1)
    c = R.simulate_run(3, None, 1, 30.0, seed=3, run=5, periods=1)
    d = R.simulate_run(3, None, 1, 30.0, seed=4, run=2, periods=1)
    assert a.samples.equals(b.samples) and a.truth.equals(b.truth)
    assert a.params["f_c"] == c.params["f_c"] != d.params["f_c"]   # seed = campaign = machine
    assert not np.array_equal(a.samples["torque"], c.samples["torque"])  # run = noise


def test_format_validates_and_round_trips(tmp_path):
    r = sim(scheme=2, rpm=3000, effects=eff("hysteresis", "iwan_stops"),
            sensors=R.SensorSpec(sample_rate_hz=50))
    validate_samples(r.samples, "x.csv")
    validate_meta(r.meta, "x.json")
    assert r.meta["rig"] == "rig_ac" and r.meta["source"] == "emulator"
    assert r.meta["sensors"]["torque"]["lag_s"] == pytest.approx(5e-4)
    assert r.meta["sensors"]["q"]["resolution"] == pytest.approx(math.radians(0.01))
    for col in ("t", "twist", "torque"):
        assert col in r.truth
    write_run(RunData(samples=r.samples, meta=r.meta), tmp_path / "run")
    back = read_run(tmp_path / "run")
    assert back.meta == r.meta
    for c in r.samples.columns:
        if c == "phase":
            assert list(back.samples[c]) == list(r.samples[c])
        else:
            np.testing.assert_array_equal(back.samples[c].to_numpy(float),
                                          r.samples[c].to_numpy(float))
    r3 = sim(scheme=3, sensors=R.SensorSpec(sample_rate_hz=20))
    assert r3.meta["motor_speed_rpm"] is None
    validate_meta(r3.meta, "y.json")


# --- nominal physics (data sheet) ---------------------------------------------------------------

@pytest.mark.parametrize("rpm,direction", [(300, 1), (3000, 1), (3000, -1)])
def test_steady_friction_level_scheme1(rpm, direction):
    r = sim(rpm=rpm, direction=direction)
    m = mask(r, "load")
    tr = r.truth
    expect = direction * (r.params["f_c"] + r.params["f_v"] * abs(tr["qd"][m].mean()))
    assert tr["friction"][m].mean() == pytest.approx(expect, rel=0.01)
    bal = (tr["torque"] - tr["torque_load"] - tr["gravity"])[m].mean()
    assert bal == pytest.approx(expect, rel=0.03)
    # measured channels tell the same story (torque − dynamometer − gravity)
    s = r.samples
    g = 9.81 * (r.params["mr_x"] * np.sin(s["q"]) + r.params["mr_y"] * np.cos(s["q"]))
    assert (s["torque"] - s["torque_load"] - g)[m].mean() == pytest.approx(expect, rel=0.08)
    # nominal machine near the data sheet values
    assert r.params["f_c"] == pytest.approx(F_C, rel=0.07)
    assert r.params["f_v"] == pytest.approx(F_V, rel=0.09)
    # the motor holds its speed; the output lags while the twist winds up (load) and catches
    # up while it unwinds (unload)
    assert abs(tr["ud"][m].mean()) == pytest.approx(w_out(rpm), rel=0.01)
    both = m | mask(r, "unload")
    assert abs(tr["qd"][both].mean()) == pytest.approx(w_out(rpm), rel=0.03)
    # positive loading winds the twist Δ = u − q up: the output falls behind a forward motor,
    # and runs ahead of a reversing one (the dynamometer back-drives it)
    lo, hi = abs(tr["qd"][m].mean()), abs(tr["qd"][mask(r, "unload")].mean())
    assert (lo < w_out(rpm) < hi) if direction > 0 else (hi < w_out(rpm) < lo)


def test_twist_torque_law_and_rated_twist():
    r = sim(rpm=3000)
    tr, p = r.truth, r.params
    # T = k2·Δ − (k2 − k1)·Δs·ξ/√(1+ξ²) + D·Δ̇,  ξ = Δ/Δs
    d = tr["twist"].to_numpy()
    xi = d / p["twist_soft_rad"]
    K = p["k2"] * d - (p["k2"] - p["k1"]) * p["twist_soft_rad"] * xi / np.sqrt(1 + xi * xi)
    res = tr["torque"] - K - p["D"] * tr["twist_rate"]
    assert np.abs(res).max() < 1.0
    assert p["k1"] / p["k2"] == pytest.approx(0.5, rel=0.17)
    xr = p["twist_rated_rad"] / p["twist_soft_rad"]
    assert p["k2"] * p["twist_rated_rad"] - (p["k2"] - p["k1"]) * p["twist_soft_rad"] * xr \
        / math.sqrt(1 + xr * xr) == pytest.approx(120_000.0)
    assert p["twist_rated_rad"] == pytest.approx(TWIST_RATED, rel=0.09)
    # the run itself: twist at the peak load ≈ rated twist, torsion = −twist
    i = int(np.argmax(tr["torque"]))
    assert tr["torque"][i] == pytest.approx(120_000.0, rel=0.05)
    assert tr["twist"][i] == pytest.approx(TWIST_RATED, rel=0.12)
    assert r.samples["torsion"][i] == pytest.approx(-tr["twist"][i], abs=3e-4)
    assert np.allclose(R.compliance_torque(d, p), K)


def test_sensor_spec_honoured():
    spec = R.SensorSpec(sample_rate_hz=200, encoder_res_deg=0.05, torque_noise=0.0,
                        torque_res=0.0, torque_filter_s=0.0)
    r = sim(rpm=3000, sensors=spec)
    t = r.samples["t"].to_numpy()
    assert np.allclose(np.diff(t), 1 / 200)
    step = math.radians(0.05)
    k = r.samples["q"].to_numpy() / step
    assert np.allclose(k, np.round(k), atol=1e-6)
    assert np.abs(r.samples["q"] - r.truth["q"]).max() <= step / 2 + 1e-12
    assert np.allclose(r.samples["torque"], r.truth["torque"])   # no noise, filter or steps
    assert r.meta["sample_rate_hz"] == 200
    assert r.meta["sensors"]["q"]["resolution"] == pytest.approx(step)


# --- effects: every form changes the run as the data sheet says ---------------------------------

def _load_mean(r, col, phase="load"):
    return r.truth[col][mask(r, phase)].mean()


@pytest.mark.parametrize("form,phi", [("exponential", lambda x: np.exp(-x)),
                                      ("gaussian", lambda x: np.exp(-x * x)),
                                      ("lorentzian", lambda x: 1 / (1 + x * x))])
def test_stribeck(form, phi):
    base, r = sim(), sim(effects=eff("stribeck", form))
    m = mask(r, "load")
    v = np.abs(r.truth["qd"].to_numpy()[m])
    extra = _load_mean(r, "friction") - _load_mean(base, "friction")
    assert extra == pytest.approx(0.25 * r.params["f_c"] * phi(v / 5e-3).mean(), rel=0.1)
    assert extra > 300
    assert r.truth["qd"][m].min() > 0          # scale 1: steady sliding, no stick-slip
    fast, fast0 = sim(rpm=3000, effects=eff("stribeck", form)), sim(rpm=3000)
    assert -1 < _load_mean(fast, "friction") - _load_mean(fast0, "friction") < 30


@pytest.mark.parametrize("form", R.EFFECT_FORMS["load_dependent_friction"])
def test_load_dependent_friction(form):
    base, r = sim(rpm=3000), sim(rpm=3000, effects=eff("load_dependent_friction", form))
    dF = (r.truth["friction"] - base.truth["friction"]).to_numpy()
    m = mask(r, "load")
    hi = m & (r.truth["torque"].to_numpy() > 100_000)
    lo = m & (r.truth["torque"].to_numpy() < 20_000)
    assert dF[hi].mean() > 600 and dF[hi].mean() > 3 * max(dF[lo].mean(), 1.0)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["temperature_friction"])
def test_temperature_friction(form):
    for temp, sign in ((20.0, 1), (50.0, -1)):
        base = sim(rpm=3000, temp=temp)
        r = sim(rpm=3000, temp=temp, effects=eff("temperature_friction", form))
        d = _load_mean(r, "friction") - _load_mean(base, "friction")
        assert sign * d > 60


@pytest.mark.parametrize("form", R.EFFECT_FORMS["gear_ripple"])
def test_gear_ripple(form):
    base, r = sim(rpm=3000), sim(rpm=3000, effects=eff("gear_ripple", form))
    q = r.truth["q"].to_numpy()
    if form == "output_mesh":
        np.testing.assert_allclose(r.truth["disturbance"], 300 * np.sin(96 * q + 0.7), atol=1e-6)
    elif form == "mesh_harmonics":
        np.testing.assert_allclose(r.truth["disturbance"], 250 * (
            np.sin(61 * q + 0.3) + 0.5 * np.sin(122 * q + 1.9)), atol=1e-6)
    else:
        # 2 cycles per motor revolution: 100 Hz at 3000 r/min in the transmitted torque
        m = mask(r, "load")
        d = (r.truth["torque"] - base.truth["torque"]).to_numpy()[m]
        spec = np.abs(np.fft.rfft(d - d.mean()))
        f = np.fft.rfftfreq(len(d), 1e-3)
        assert abs(f[np.argmax(spec)] - 100.0) < 3.0
        assert 150 < d.std() * math.sqrt(2) < 600


@pytest.mark.parametrize("form", R.EFFECT_FORMS["torque_offset"])
def test_torque_offset(form):
    base, r = sim(), sim(effects=eff("torque_offset", form))
    t = r.samples["t"].to_numpy()
    d = (r.samples["torque"] - base.samples["torque"]).to_numpy()
    law = {"constant_bias": 400 + 0 * t, "linear_drift": 8 * t,
           "saturating_creep": 600 * (1 - np.exp(-t / 20))}[form]
    assert np.abs(d - law).max() <= 2.0 + 1e-9        # one torque step
    assert np.array_equal(r.truth["torque"], base.truth["torque"])


def test_time_delay_torque():
    quiet = R.SensorSpec(torque_noise=0.0, torque_res=0.0)
    base = sim(scheme=2, sensors=quiet)
    r = sim(scheme=2, effects=eff("time_delay", "torque_latency"), sensors=quiet)
    a, b = base.samples["torque"].to_numpy(), r.samples["torque"].to_numpy()
    errs = {k: np.mean((b[k:] - a[:len(a) - k]) ** 2) for k in range(0, 30)}
    assert min(errs, key=errs.get) == 12


def test_time_delay_q_encoder():
    base, r = sim(rpm=3000), sim(rpm=3000, effects=eff("time_delay", "q_encoder_latency"))
    m = mask(r, "load")
    d = (base.samples["q"] - r.samples["q"])[m].mean()
    assert d == pytest.approx(0.012 * abs(_load_mean(r, "qd")), rel=0.2)
    assert np.array_equal(r.samples["torque"], base.samples["torque"])


@pytest.mark.parametrize("form", R.EFFECT_FORMS["hysteresis"])
def test_hysteresis(form):
    r = sim(effects=eff("hysteresis", form))
    p, tr = r.params, r.truth
    res = tr["torque"] - R.compliance_torque(tr["twist"], p) - p["D"] * tr["twist_rate"]
    up, down = res[mask(r, "load")].mean(), res[mask(r, "unload")].mean()
    assert 0.6 * 1500 < up < 1.05 * 1500 and -1.05 * 1500 < down < -0.6 * 1500


@pytest.mark.parametrize("form", R.EFFECT_FORMS["backlash"])
def test_backlash(form):
    base, r = sim(), sim(effects=eff("backlash", form))
    m = mask(r, "load") & (r.truth["torque"].to_numpy() > 30_000)
    d = (r.truth["twist"] - base.truth["twist"])[m].mean()
    assert d == pytest.approx(2e-4, rel=0.1)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["asymmetric_friction"])
def test_asymmetric_friction(form):
    gaps = []
    for direction in (1, -1):
        base = sim(rpm=3000, direction=direction)
        r = sim(rpm=3000, direction=direction, effects=eff("asymmetric_friction", form))
        gaps.append(abs(_load_mean(r, "friction")) - abs(_load_mean(base, "friction")))
    assert gaps[0] > 150 and gaps[1] < -150


@pytest.mark.parametrize("form", R.EFFECT_FORMS["periodic_disturbance"])
def test_periodic_disturbance(form):
    r = sim(scheme=3, effects=eff("periodic_disturbance", form))
    t = r.truth["t"].to_numpy()
    law = (400 * 2 / np.pi * np.arctan(6 * np.sin(2 * np.pi * 1.3 * t)) if form == "pump_square"
           else 300 * (np.sin(2 * np.pi * 4.7 * t) + 0.6 * np.sin(2 * np.pi * 9.4 * t + 1)))
    np.testing.assert_allclose(r.truth["disturbance"], law, atol=1e-6)
    assert np.abs(sim(scheme=3).truth["disturbance"]).max() == 0.0


@pytest.mark.parametrize("form", R.EFFECT_FORMS["position_dependent_stiffness"])
def test_position_dependent_stiffness(form):
    base, r = sim(rpm=3000), sim(rpm=3000, effects=eff("position_dependent_stiffness", form))
    m = mask(r, "load") & (r.truth["torque"].to_numpy() > 60_000)
    q = r.truth["q"].to_numpy()[m]
    f = 1 + 0.2 * q if form == "linear_gradient" else 1 + 0.1 * np.sin(2 * q + 0.4)
    ratio = (base.truth["twist"].to_numpy()[m] / r.truth["twist"].to_numpy()[m]).mean()
    assert abs(f.mean() - 1) > 0.02
    assert ratio == pytest.approx(f.mean(), rel=0.02)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["encoder_drift"])
def test_encoder_drift(form):
    base, r = sim(), sim(effects=eff("encoder_drift", form))
    t = r.samples["t"].to_numpy()
    col = "q" if form == "q_linear" else "u"
    d = (r.samples[col] - base.samples[col]).to_numpy()
    law = 6e-6 * t if form == "q_linear" else 3e-4 * (1 - np.exp(-t / 15))
    step = math.radians(0.01) if col == "q" else R.SensorSpec().motor_encoder_res
    assert np.abs(d - law).max() <= step + 1e-12
    assert np.array_equal(r.truth["q"], base.truth["q"])


@pytest.mark.parametrize("form,f0", [("output_tuned_mass", 11.0), ("loading_shaft", 8.0)])
def test_second_resonance(form, f0):
    base, r = sim(scheme=2), sim(scheme=2, effects=eff("second_resonance", form))
    d = (r.truth["qdd"] - base.truth["qdd"]).to_numpy()
    spec = np.abs(np.fft.rfft(d - d.mean()))
    f = np.fft.rfftfreq(len(d), 1e-3)
    band = f > 2.0
    fpk = f[band][np.argmax(spec[band])]
    assert 0.5 * f0 < fpk < 1.5 * f0
    assert np.abs(d).max() > 1e-3                       # rad/s², clearly above nothing


def test_every_form_runs_at_scale_max():
    for name, forms in R.EFFECT_FORMS.items():
        for form in forms:
            r = R.simulate_run(3, None, 1, 30.0, eff(name, form, R.SCALE_MAX), periods=1,
                               seed=1, run=0, sensors=R.SensorSpec(sample_rate_hz=10))
            assert np.isfinite(r.truth.to_numpy(float)).all(), (name, form)
