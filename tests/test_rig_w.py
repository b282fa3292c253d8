"""Validation rig W (validation_rigs/rig_w.py): the contract the harness relies on, and the
physics of the bench against the paper (Eq. 4 with Table 3, Eq. 5, the twist at 120 kN m) and
against the data sheet in the module docstring (each effect's size at scale 1).

Runs are cached (keyed on every argument, the sensors by their fields); most use one period of
scheme 3 or a 20 Hz scheme-1 run, so the file runs in well under a minute on two cores."""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pandas as pd
import pytest

from core.run import RunData
from core.runfile import validate_meta, validate_samples
from validation_rigs import rig_w as R

N = 11000.0
VOCAB = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
         "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction")
PHASES = {"idle", "load", "hold", "unload", "excite"}
SENSOR_FIELDS = tuple(f.name for f in dataclasses.fields(R.SensorSpec))
FAST = R.SensorSpec(sample_rate_hz=20.0)
CLEAN = R.SensorSpec(sample_rate_hz=20.0, torque_noise=0.0, load_noise=0.0,
                     torque_adc_step=0.0, load_adc_step=0.0, encoder_res_deg=1e-6,
                     current_noise=0.0)
CLEAN200 = dataclasses.replace(CLEAN, sample_rate_hz=200.0)
W_TOP = 3000 * 2 * math.pi / 60 / N          # top output speed [rad/s]
ALL_FORMS = [(n, f) for n, fs in R.EFFECT_FORMS.items() for f in fs]


def _key(s: R.SensorSpec) -> tuple:
    return tuple(getattr(s, f) for f in SENSOR_FIELDS)


@functools.lru_cache(maxsize=None)
def _cached(scheme, rpm, direction, temp, items, skey, periods, seed, run, unstated):
    sensors = R.SensorSpec(**dict(zip(SENSOR_FIELDS, skey)))
    effects = {n: {"form": f, "scale": s} for n, f, s in items} or None
    return R.simulate_run(scheme, rpm, direction, temp, effects, sensors=sensors,
                          periods=periods, seed=seed, run=run, unstated=unstated)


def sim(scheme=3, rpm=None, direction=1, temp=25.0, effects=None, sensors=FAST, periods=1,
        seed=11, run=0, unstated=True) -> R.RigRun:
    items = tuple(sorted((n, d["form"], float(d["scale"])) for n, d in (effects or {}).items()))
    return _cached(scheme, rpm, direction, temp, items, _key(sensors), periods, seed, run,
                   unstated)


def eff(name, form, scale=1.0):
    return {name: {"form": form, "scale": scale}}


def eq4_residual(r: R.RigRun) -> np.ndarray:
    """T - tau_L - (I qdd + g(mr_x sin q + mr_y cos q) + f_v qd + f_c sgn qd), from the truth
    and the campaign's machine values (paper Eq. 4 with the load)."""
    m, tr = r.params["machine"], r.truth
    grav = m["g"] * (m["mr_x"] * np.sin(tr.q) + m["mr_y"] * np.cos(tr.q))
    return (tr.torque - tr.torque_load - m["I"] * tr.qdd - grav - m["f_v"] * tr.qd
            - m["f_c"] * np.sign(tr.qd)).to_numpy()


def sliding(r: R.RigRun, phases=("load", "hold", "unload")) -> np.ndarray:
    return (r.truth.gms_sticking.to_numpy() == 0) & r.samples.phase.isin(phases).to_numpy()


def law_delta(T, m):
    """The data sheet's transmission law Delta(T)."""
    T = np.asarray(T, dtype=float)
    a = np.abs(T)
    return np.sign(T) * (a / m["k1"] + m["c_h"] * (np.cbrt(a + m["T_p"]) ** 2
                                                   - np.cbrt(m["T_p"]) ** 2))


def tangent_k(T, m):
    return 1.0 / (1.0 / m["k1"] + (2.0 / 3.0) * m["c_h"] / np.cbrt(np.abs(T) + m["T_p"]))


# ============================================================================================
# contract
# ============================================================================================

def test_module_constants_and_vocabulary():
    assert R.RIG_NAME == "rig_w" and R.REDUCTION == 11000.0 and R.SEED_IS_CAMPAIGN is True
    assert isinstance(R.SCALE_MAX, float) and R.SCALE_MAX >= 1.0
    for name in VOCAB:
        forms = R.EFFECT_FORMS[name]
        assert len(forms) >= 3 and len(set(forms)) == len(forms), name
    assert set(R.OUT_OF_VOCABULARY) == set(R.EFFECT_FORMS) - set(VOCAB)
    assert len(R.OUT_OF_VOCABULARY) >= 4
    for name in R.OUT_OF_VOCABULARY:
        assert len(R.EFFECT_FORMS[name]) >= 2
    assert 2 <= len(R.UNSTATED_VOCABULARY) <= 3
    for name, text in R.UNSTATED_VOCABULARY.items():
        assert name in VOCAB and isinstance(text, str) and text
    # the module docstring documents every form
    for name, form in ALL_FORMS:
        assert f"``{form}``" in R.__doc__ and f"``{name}``" in R.__doc__, (name, form)


REQUIRED = ("t", "q", "u", "torsion", "torque", "torque_load", "torque_cmd", "i_m1", "i_m2",
            "i_m3", "w_m1", "w_m2", "w_m3", "temp_m1", "temp_m2", "temp_m3", "temp_joint",
            "p_hyd", "m_bend", "f_shear", "phase")


@pytest.mark.parametrize("scheme,rpm,direction", [(1, 3000, 1), (2, 300, -1), (3, None, -1)])
def test_run_validates_as_a_run_file(scheme, rpm, direction):
    r = sim(scheme, rpm, direction, 33.0, periods=2)
    s = validate_samples(r.samples, "rig_w")
    meta = validate_meta(r.meta, "rig_w")
    run = RunData(samples=s, meta=meta)
    assert len(run) == len(r.samples) == len(r.truth)
    for c in REQUIRED:
        assert c in r.samples.columns, c
    t = r.samples.t.to_numpy()
    assert t[0] == 0.0 and np.allclose(np.diff(t), 1 / 20.0)
    assert t[-1] == pytest.approx(70.0 if scheme in (1, 2) else 40.0)
    assert set(r.samples.phase) <= PHASES
    if scheme == 3:
        assert set(r.samples.phase) == {"excite"}
    else:
        assert {"idle", "load", "hold", "unload"} == set(r.samples.phase)
    assert meta["scheme"] == scheme and meta["motor_speed_rpm"] == rpm
    assert meta["direction"] == direction and meta["reduction"] == 11000.0
    assert meta["source"] == "emulator" and meta["sample_rate_hz"] == 20.0
    np.testing.assert_array_equal(r.samples.torsion, r.samples.q - r.samples.u)
    for c in ("t", "twist", "torque", "torque_load", "q", "u"):
        assert c in r.truth.columns
    np.testing.assert_allclose(r.truth.twist, r.truth.u - r.truth.q, atol=1e-15)
    for k in ("machine", "effects", "unstated"):
        assert k in r.params
    assert np.isfinite(r.samples.drop(columns="phase").to_numpy()).all()


def test_meta_states_the_sensors_and_nothing_unstated():
    spec = R.SensorSpec(sample_rate_hz=50.0, encoder_res_deg=0.002, torque_noise=90.0,
                        torque_lag_s=0.02, load_noise=40.0, load_lag_s=0.01, motor_encoder_bits=18)
    r = sim(3, sensors=spec)
    sens = r.meta["sensors"]
    assert sens["q"]["resolution"] == pytest.approx(math.radians(0.002))
    assert sens["u"]["resolution"] == pytest.approx(2 * math.pi / 2 ** 18 / N)
    assert sens["torque"] == {"resolution": 5.0, "noise_sd": 90.0, "lag_s": 0.02}
    assert sens["torque_load"] == {"resolution": 5.0, "noise_sd": 40.0, "lag_s": 0.01}
    text = repr(r.meta)
    for word in ("offset", "asym", "ripple", "unstated"):
        assert word not in text
    # readings sit on their stated steps
    q = r.samples.q.to_numpy() / sens["q"]["resolution"]
    np.testing.assert_allclose(q, np.round(q), atol=1e-6)
    u = r.samples.u.to_numpy() / sens["u"]["resolution"]
    np.testing.assert_allclose(u, np.round(u), atol=1e-3)
    tq = r.samples.torque.to_numpy() / 5.0
    np.testing.assert_allclose(tq, np.round(tq), atol=1e-6)


@pytest.mark.parametrize("channel,lag", [("torque", 0.01), ("torque_load", 0.005)])
def test_stated_lags_are_the_readings_lags(channel, lag):
    r = sim(3, sensors=CLEAN200, seed=15, unstated=False)
    t = r.samples.t.to_numpy()
    x, truth = r.samples[channel].to_numpy(), r.truth[channel].to_numpy()
    lags = np.arange(0, 0.0301, 0.0005)
    err = [np.abs(x[20:] - np.interp(t[20:] - d, t, truth)).mean() for d in lags]
    assert lags[int(np.argmin(err))] == pytest.approx(lag, abs=0.001)
    assert r.meta["sensors"][channel]["lag_s"] == lag


def test_determinism_campaign_and_noise():
    kw = dict(sensors=FAST, periods=1, seed=5)
    R._KERNEL_CACHE.clear()
    a = R.simulate_run(3, None, 1, 30.0, run=2, **kw)
    R._KERNEL_CACHE.clear()
    b = R.simulate_run(3, None, 1, 30.0, run=2, **kw)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    # another run of the same campaign: same machine and motion, fresh noise
    c = R.simulate_run(3, None, 1, 30.0, run=3, **kw)
    assert c.params["machine"] == a.params["machine"]
    hyd = ["p_hyd", "m_bend", "f_shear"]        # the hydraulics settle anew in every run
    pd.testing.assert_frame_equal(a.truth.drop(columns=hyd), c.truth.drop(columns=hyd))
    assert a.truth.p_hyd.iloc[0] != c.truth.p_hyd.iloc[0]
    assert not np.array_equal(a.samples.torque, c.samples.torque)
    # another seed: another machine
    d = R.simulate_run(3, None, 1, 30.0, run=2, sensors=FAST, periods=1, seed=6)
    assert d.params["machine"]["f_c"] != a.params["machine"]["f_c"]
    assert not np.array_equal(a.truth.torque, d.truth.torque)


def test_machine_spread_is_small_around_table3():
    for seed in range(25):
        m = R._machine(seed, True)
        for k, v in R.TABLE3.items():
            tol = 0.08 if k.startswith("mr") else 0.026
            assert abs(m[k] / v - 1) <= tol, (seed, k)
        un = m["unstated"]
        assert 0.02 * m["f_c"] <= un["asymmetric_friction"]["extra_coulomb_negative_nm"] \
            <= 0.035 * m["f_c"]
        assert 25 <= un["gear_ripple"]["amplitude_nm"] <= 45
        assert 40 <= abs(un["torque_offset"]["offset_nm"]) <= 90
    assert R._machine(3, True) == R._machine(3, True)


BASE = dict(scheme=3, motor_speed_rpm=None, direction=1, temp_joint_c=25.0, effects=None,
            sensors=FAST, periods=1, seed=1, run=0)
BAD_ARGS = [
    ({"scheme": 0}, "scheme"), ({"scheme": 4}, "scheme"), ({"scheme": True}, "scheme"),
    ({"scheme": 1.5}, "scheme"), ({"scheme": "1"}, "scheme"), ({"scheme": float("nan")}, "scheme"),
    ({"motor_speed_rpm": 300.0}, "motor_speed_rpm"),
    ({"scheme": 1, "motor_speed_rpm": None}, "motor_speed_rpm"),
    ({"scheme": 1, "motor_speed_rpm": 0.0}, "motor_speed_rpm"),
    ({"scheme": 1, "motor_speed_rpm": -300}, "motor_speed_rpm"),
    ({"scheme": 2, "motor_speed_rpm": 3000.5}, "motor_speed_rpm"),
    ({"scheme": 1, "motor_speed_rpm": float("nan")}, "motor_speed_rpm"),
    ({"scheme": 1, "motor_speed_rpm": float("inf")}, "motor_speed_rpm"),
    ({"scheme": 1, "motor_speed_rpm": True}, "motor_speed_rpm"),
    ({"scheme": 1, "motor_speed_rpm": "300"}, "motor_speed_rpm"),
    ({"direction": 0}, "direction"), ({"direction": 2}, "direction"),
    ({"direction": True}, "direction"), ({"direction": float("nan")}, "direction"),
    ({"direction": "1"}, "direction"),
    ({"temp_joint_c": 14.9}, "temp_joint_c"), ({"temp_joint_c": 60.1}, "temp_joint_c"),
    ({"temp_joint_c": float("nan")}, "temp_joint_c"),
    ({"temp_joint_c": float("inf")}, "temp_joint_c"), ({"temp_joint_c": True}, "temp_joint_c"),
    ({"temp_joint_c": None}, "temp_joint_c"),
    ({"effects": "stribeck"}, "effects"),
    ({"effects": {"nope": {"form": "x", "scale": 1}}}, "effects"),
    ({"effects": eff("stribeck", "nope")}, "effects"),
    ({"effects": eff("stribeck", "exp1", -0.1)}, "effects"),
    ({"effects": eff("stribeck", "exp1", R.SCALE_MAX + 0.1)}, "effects"),
    ({"effects": eff("stribeck", "exp1", float("nan"))}, "effects"),
    ({"effects": eff("stribeck", "exp1", float("inf"))}, "effects"),
    ({"effects": eff("stribeck", "exp1", True)}, "effects"),
    ({"effects": eff("stribeck", "exp1", "1")}, "effects"),
    ({"effects": {"stribeck": {"form": "exp1"}}}, "effects"),
    ({"effects": {"stribeck": {"form": "exp1", "scale": 1, "x": 2}}}, "effects"),
    ({"effects": {"stribeck": "exp1"}}, "effects"),
    ({"sensors": "fast"}, "sensors"), ({"sensors": {"sample_rate_hz": 20}}, "sensors"),
    ({"periods": 0}, "periods"), ({"periods": True}, "periods"), ({"periods": 1.5}, "periods"),
    ({"periods": 21}, "periods"),
    ({"seed": -1}, "seed"), ({"seed": True}, "seed"), ({"seed": 1.5}, "seed"),
    ({"seed": None}, "seed"), ({"seed": "1"}, "seed"),
    ({"run": -1}, "run"), ({"run": False}, "run"), ({"run": 2.0}, "run"),
]


@pytest.mark.parametrize("change,name", BAD_ARGS)
def test_bad_arguments_are_refused_by_name(change, name):
    kw = {**BASE, **change}
    args = [kw.pop(k) for k in ("scheme", "motor_speed_rpm", "direction", "temp_joint_c",
                                "effects")]
    with pytest.raises(ValueError, match=name):
        R.simulate_run(*args, **kw)


def test_missing_seed_or_run_is_an_error():
    with pytest.raises(TypeError):
        R.simulate_run(3, None, 1, 25.0, periods=1)  # type: ignore[call-arg]


SPEC_FLOATS = ("sample_rate_hz", "encoder_res_deg", "torque_noise", "torque_lag_s",
               "torque_adc_step", "load_noise", "load_lag_s", "load_adc_step", "current_noise")
OUT_OF_RANGE = {"sample_rate_hz": (9.9, 1000.1), "encoder_res_deg": (9e-7, 1.01),
                "torque_noise": (-1.0, 1e4 + 1), "torque_lag_s": (-0.001, 0.51),
                "torque_adc_step": (-1.0, 1001.0), "load_noise": (-1.0, 1e4 + 1),
                "load_lag_s": (-0.001, 0.51), "load_adc_step": (-1.0, 1001.0),
                "current_noise": (-0.1, 10.1)}


@pytest.mark.parametrize("field", SPEC_FLOATS)
@pytest.mark.parametrize("kind", ["nan", "inf", "-inf", "bool", "text", "none", "low", "high"])
def test_sensorspec_refuses_bad_fields_by_name(field, kind):
    value = {"nan": float("nan"), "inf": float("inf"), "-inf": float("-inf"), "bool": True,
             "text": "1", "none": None, "low": OUT_OF_RANGE[field][0],
             "high": OUT_OF_RANGE[field][1]}[kind]
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})


@pytest.mark.parametrize("value", [7, 33, 20.0, True, "20", float("nan")])
def test_sensorspec_refuses_bad_encoder_bits(value):
    with pytest.raises(ValueError, match="motor_encoder_bits"):
        R.SensorSpec(motor_encoder_bits=value)


def test_sensorspec_accepts_its_range_ends():
    R.SensorSpec(sample_rate_hz=10, encoder_res_deg=1e-6, torque_noise=0, torque_lag_s=0)
    R.SensorSpec(sample_rate_hz=1000, encoder_res_deg=1, torque_noise=1e4, torque_lag_s=0.5)


# ----------------------------------------------------------------- every effect and form ---

@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_effect_form_runs_and_shows(name, form):
    base = sim(3)
    r = sim(3, effects=eff(name, form))
    validate_samples(r.samples, "x")
    assert np.isfinite(r.truth.to_numpy(dtype=float)).all()
    assert r.params["effects"] == {name: {"form": form, "scale": 1.0,
                                          "sensor_only": name in R.SENSOR_ONLY,
                                          "out_of_vocabulary": name in R.OUT_OF_VOCABULARY}}
    d_truth = max(np.abs(r.truth.torque - base.truth.torque).max(),
                  1e6 * np.abs(r.truth.twist - base.truth.twist).max(),
                  1e3 * np.abs(r.truth.i_m1 - base.truth.i_m1).max())
    d_read = max(np.abs(r.samples.torque - base.samples.torque).max(),
                 np.abs(r.samples.torque_load - base.samples.torque_load).max(),
                 1e6 * np.abs(r.samples.q - base.samples.q).max())
    if name in R.SENSOR_ONLY:
        pd.testing.assert_frame_equal(r.truth, base.truth)
        assert d_read > 0
    else:
        assert d_truth > 1.0


@pytest.mark.parametrize("name,form", [("stribeck", "gauss"), ("hysteresis", "jenkins"),
                                       ("backlash", "sharp"), ("gear_ripple", "motor_angle"),
                                       ("second_resonance", "output"),
                                       ("temperature_friction", "both_linear")])
def test_largest_scale_stays_finite(name, form):
    r = sim(3, temp=60.0, effects=eff(name, form, R.SCALE_MAX))
    assert np.isfinite(r.truth.to_numpy(dtype=float)).all()
    assert np.abs(r.truth.torque).max() < 2e5


@pytest.mark.parametrize("name,form", [("stribeck", "exp1"), ("hysteresis", "jenkins"),
                                       ("torque_offset", "constant"),
                                       ("second_resonance", "output"),
                                       ("encoder_eccentricity", "once_per_rev")])
def test_scale_zero_is_no_effect(name, form):
    base = sim(3, seed=12)
    r = sim(3, seed=12, effects=eff(name, form, 0.0))
    pd.testing.assert_frame_equal(r.samples, base.samples)
    pd.testing.assert_frame_equal(r.truth, base.truth)
    assert r.params["effects"] == {}


AFFECTS = {"torque_offset": ("torque",), "time_delay": ("torque",),
           "encoder_eccentricity": ("q", "torsion"), "loadcell_drift": ("torque_load",)}


@pytest.mark.parametrize("name,form", [(n, f) for n, f in ALL_FORMS if n in R.SENSOR_ONLY])
@pytest.mark.parametrize("scale", [0.3, 5.0])
def test_sensor_only_effects_leave_the_truth_untouched(name, form, scale):
    base = sim(3, seed=13)
    r = sim(3, seed=13, effects=eff(name, form, scale))
    pd.testing.assert_frame_equal(r.truth, base.truth)
    touched = AFFECTS[name] if form != "encoder_lag" else ("q", "torsion")
    if form in ("torque_lag", "torque_filter"):
        touched = ("torque",)
    for c in r.samples.columns:
        if c not in touched:
            pd.testing.assert_series_equal(r.samples[c], base.samples[c])
    assert any(not np.array_equal(r.samples[c], base.samples[c]) for c in touched)


LINEAR = [("stribeck", "exp1", "torque"), ("stribeck", "lorentz", "torque"),
          ("hysteresis", "bouc_wen_n1", "torque"), ("backlash", "smooth", "torque"),
          ("gear_ripple", "output_harmonics", "torque"), ("asymmetric_friction", "both", "torque"),
          ("load_dependent_friction", "power_flow", "torque"),
          ("temperature_friction", "viscous_vogel", "torque"),
          ("time_delay", "torque_lag", "samples_torque"),
          ("position_stiffness", "once_per_rev", "twist")]


@pytest.mark.parametrize("name,form,channel", LINEAR)
def test_effects_are_linear_in_small_scale(name, form, channel):
    sens = CLEAN

    def get(r):
        if channel == "samples_torque":
            return r.samples.torque.to_numpy()
        return r.truth[channel].to_numpy()

    scheme, rpm = (1, 3000) if name == "position_stiffness" else (3, None)
    base = get(sim(scheme, rpm, temp=20.0, sensors=sens))
    d1 = get(sim(scheme, rpm, temp=20.0, sensors=sens, effects=eff(name, form, 0.1))) - base
    d2 = get(sim(scheme, rpm, temp=20.0, sensors=sens, effects=eff(name, form, 0.2))) - base
    n1, n2 = np.linalg.norm(d1), np.linalg.norm(d2)
    assert n1 > 0
    assert 1.75 < n2 / n1 < 2.25, n2 / n1
    assert np.dot(d1, d2) / (n1 * n2) > 0.9


# ============================================================================================
# physics against the paper
# ============================================================================================

NOMINAL_S1 = [(300, 1), (300, -1), (3000, 1), (3000, -1)]


def nominal_s1(rpm, direction, sensors=CLEAN, **kw):
    return sim(1, rpm, direction, 25.0, sensors=sensors, unstated=False, **kw)


@pytest.mark.parametrize("rpm,direction", NOMINAL_S1)
def test_steady_sliding_follows_eq4_with_table3(rpm, direction):
    """Stated tolerance: 1 N m on T - tau_L against Eq. 4 whenever the output slides."""
    r = nominal_s1(rpm, direction)
    sl = sliding(r)
    assert sl.sum() > 0.8 * r.samples.phase.isin(["load", "hold", "unload"]).sum()
    res = eq4_residual(r)[sl]
    assert np.abs(res).max() < 1.0
    qd = r.truth.qd.to_numpy()[sl]
    assert np.all(np.sign(qd) == direction)
    assert np.abs(qd).mean() == pytest.approx(rpm * 2 * math.pi / 60 / N, rel=0.02)


def test_eq4_fitted_from_the_readings_recovers_table3():
    xs, ys = [], []
    for rpm, d in NOMINAL_S1:
        r = nominal_s1(rpm, d, sensors=FAST)
        s = r.samples
        ph = s.phase.isin(["load", "hold", "unload"]).to_numpy()
        qd = (s.w_m1 + s.w_m2 + s.w_m3).to_numpy() / 3 / N
        q = s.q.to_numpy()
        xs.append(np.column_stack([qd, np.sign(qd), 9.81 * np.sin(q), 9.81 * np.cos(q)])[ph])
        ys.append((s.torque - s.torque_load).to_numpy()[ph])
    x, y = np.vstack(xs), np.concatenate(ys)
    th, *_ = np.linalg.lstsq(x, y, rcond=None)
    m = r.params["machine"]
    assert th[0] == pytest.approx(m["f_v"], rel=0.03)
    assert th[1] == pytest.approx(m["f_c"], rel=0.01)
    assert th[2] == pytest.approx(m["mr_x"], rel=0.25)
    assert th[3] == pytest.approx(m["mr_y"], rel=0.15)
    assert th[0] == pytest.approx(8683.272, rel=0.05) and th[1] == pytest.approx(2352.66, rel=0.04)
    assert np.sqrt(np.mean((y - x @ th) ** 2)) < 2 * 150.0


def test_gravity_term_is_the_papers():
    r = nominal_s1(3000, 1)
    m = r.params["machine"]
    sl = sliding(r)
    tr = r.truth
    other = (tr.torque - tr.torque_load - m["I"] * tr.qdd - m["f_v"] * tr.qd
             - m["f_c"] * np.sign(tr.qd)).to_numpy()[sl]
    grav = (9.81 * (m["mr_x"] * np.sin(tr.q) + m["mr_y"] * np.cos(tr.q))).to_numpy()[sl]
    assert np.ptp(grav) > 200.0             # the run sweeps ~1.9 rad of the gravity curve
    np.testing.assert_allclose(other, grav, atol=1.0)
    np.testing.assert_allclose(tr.gravity.to_numpy()[sl], grav, atol=1e-9)


def test_twist_at_rated_torque_and_the_transmission_law():
    r = nominal_s1(300, 1)
    m, tr = r.params["machine"], r.truth
    hold = r.samples.phase.eq("hold").to_numpy() & (r.samples.t > 34).to_numpy()
    twist = tr.twist.to_numpy()[hold]
    # "twist about half a degree at 120 kN m" (rig.md); ours: 0.509 deg nominal
    assert math.degrees(twist.mean()) == pytest.approx(0.5, rel=0.1)
    assert 1.2e7 <= m["k_secant_120knm"] <= 1.5e7
    # the stated law, T_e(Delta) inverted exactly, plus D dDelta/dt (Eq. 5 to first order)
    te = tr.torque_elastic.to_numpy()
    np.testing.assert_allclose(law_delta(te, m), tr.twist_effective, atol=1e-12)
    np.testing.assert_allclose(tr.twist_effective, tr.twist, atol=1e-15)
    ks = te[hold] / twist
    assert np.all(np.abs(ks / m["k_secant_120knm"] - 1) < 0.05)
    kt = tangent_k(np.linspace(-150e3, 150e3, 301), m)
    assert np.all(np.abs(kt / m["k_secant_120knm"] - 1) < 0.16)
    assert kt[150] < kt[-1]                     # Hertzian contact: stiffer under load
    # the readings' torsion (q - u) is the encoders' twist
    s = sim(1, 300, 1, 25.0, sensors=dataclasses.replace(CLEAN, encoder_res_deg=1e-5),
            unstated=False).samples
    np.testing.assert_allclose(-s.torsion.to_numpy()[hold], twist, atol=2e-7)


def test_reduction_and_drive_torque_sharing():
    r = nominal_s1(3000, 1, sensors=FAST)
    tr, s, m = r.truth, r.samples, r.params["machine"]
    np.testing.assert_allclose(tr.w_m, tr.ud * N, rtol=1e-12)
    dt = 1 / 20.0
    du = np.diff(s.u.to_numpy())
    w_avg = 0.5 * (s.w_m1.to_numpy()[1:] + s.w_m1.to_numpy()[:-1])
    steady = (s.t.to_numpy()[1:] > 5) & (s.t.to_numpy()[1:] < 65)
    np.testing.assert_allclose(du[steady] / dt * N, w_avg[steady], rtol=0.005)
    hold = s.phase.eq("hold").to_numpy()
    wm = tr.w_m.to_numpy()[hold]
    tfm = 0.12 * np.tanh(wm / 0.5) + 1.5e-4 * wm
    drive = N * (tr.motor_torque.to_numpy()[hold] - tfm)
    np.testing.assert_allclose(drive, tr.torque.to_numpy()[hold], rtol=0.003)
    # three motors share it equally in current (each k_t off by its own spread)
    cur = s[["i_m1", "i_m2", "i_m3"]].to_numpy()[hold]
    assert np.allclose(cur, cur.mean(axis=1, keepdims=True), atol=0.05)
    np.testing.assert_allclose(N * 1.4 * cur.sum(axis=1), tr.torque.to_numpy()[hold]
                               + N * tfm, rtol=0.06)


def test_loader_follows_its_set_point_within_table11():
    for scheme in (1, 2):
        r = sim(scheme, 3000, -1, 25.0, sensors=FAST)
        hold = r.samples.phase.eq("hold").to_numpy()
        settled = hold & np.concatenate([[False] * 10, hold[:-10]])   # 0.5 s into a hold
        err = (r.truth.torque_load - r.truth.torque_cmd).to_numpy()[settled]
        assert np.abs(err).max() < 2000.0
    cmd = r.samples.torque_cmd.to_numpy()
    levels = np.unique(np.round(cmd[r.samples.phase.eq("hold").to_numpy()], 6))
    np.testing.assert_allclose(levels, np.arange(0, 130e3, 10e3))


def test_scheme3_excitation():
    a, b = sim(3, direction=1, periods=2), sim(3, direction=-1, periods=2)
    np.testing.assert_allclose(b.truth.q_ref, -a.truth.q_ref, atol=1e-15)
    for r in (a, b):
        tr = r.truth
        assert tr.q_ref.iloc[0] == pytest.approx(0.0, abs=1e-15)
        assert tr.qd.iloc[0] == 0.0
        assert np.abs(tr.qd).max() <= W_TOP
        assert np.abs(tr.qd).max() > 0.8 * W_TOP
        assert np.abs(tr.q - tr.q_ref).max() < 2e-3
        assert np.abs(tr.q).max() < math.pi
    # the trajectory repeats every 20 s
    np.testing.assert_allclose(a.truth.q_ref.iloc[:400], a.truth.q_ref.iloc[400:800], atol=1e-12)
    # reversals: the GMS blocks stick at each
    assert (a.truth.gms_sticking > 0).sum() > 10


def test_thermal_drift_along_a_run():
    r = sim(1, 3000, 1, 20.0, sensors=FAST)
    tj = r.truth.temp_joint.to_numpy()
    assert tj[0] == 20.0 and 0.01 < tj[-1] - tj[0] < 1.0
    assert np.all(np.diff(tj[r.samples.phase.ne("idle").to_numpy()]) > 0)
    assert r.samples.temp_joint.iloc[0] == pytest.approx(20.0, abs=0.25)
    assert r.truth.temp_m1.iloc[-1] > r.truth.temp_m1.iloc[0]


# ============================================================================================
# each effect's size at scale 1, as the data sheet's formula says (nominal machine)
# ============================================================================================

def s1(rpm, direction, effects=None, temp=25.0, sensors=CLEAN):
    return sim(1, rpm, direction, temp, effects=effects, sensors=sensors, unstated=False)


STRIBECK_PHI = {"exp1": lambda r: np.exp(-r), "gauss": lambda r: np.exp(-r ** 2),
                "lorentz": lambda r: 1 / (1 + r ** 2), "exp_half": lambda r: np.exp(-np.sqrt(r))}


@pytest.mark.parametrize("form", list(STRIBECK_PHI))
def test_stribeck_size(form):
    r = s1(300, 1, eff("stribeck", form))
    sl = sliding(r, ("load", "unload"))
    qd = r.truth.qd.to_numpy()[sl]
    extra = eq4_residual(r)[sl] * np.sign(qd)
    # within 1 %: the GMS blocks follow a changing sliding level with a few ms of lag
    np.testing.assert_allclose(extra, 400 * STRIBECK_PHI[form](np.abs(qd) / 5e-3), rtol=0.01,
                               atol=0.5)
    assert extra.mean() > 150


@pytest.mark.parametrize("form,direction,mu", [("coulomb", 1, 0.003), ("coulomb", -1, 0.003),
                                               ("power_flow", 1, 0.004),
                                               ("power_flow", -1, 0.001)])
def test_load_dependent_friction_size(form, direction, mu):
    r = s1(300, direction, eff("load_dependent_friction", form))
    sl = sliding(r) & (r.truth.torque > 10e3).to_numpy()
    extra = eq4_residual(r)[sl] * direction
    np.testing.assert_allclose(extra, mu * np.abs(r.truth.torque.to_numpy()[sl]), rtol=0.01,
                               atol=2.0)


def test_load_dependent_coulomb_viscous_size():
    r = s1(3000, 1, eff("load_dependent_friction", "coulomb_viscous"))
    sl = sliding(r) & (r.truth.torque > 10e3).to_numpy()
    T, qd = r.truth.torque.to_numpy()[sl], r.truth.qd.to_numpy()[sl]
    expect = 0.002 * T + r.params["machine"]["f_v"] * 0.6 * T / 120e3 * qd
    np.testing.assert_allclose(eq4_residual(r)[sl], expect, rtol=0.01, atol=2.0)


def test_temperature_friction_sizes():
    r = s1(300, 1, eff("temperature_friction", "coulomb_additive"), temp=15.0)
    sl = sliding(r)
    th = r.truth.temp_joint.to_numpy()[sl]
    np.testing.assert_allclose(eq4_residual(r)[sl], 12 * (35 - th), atol=1.0)
    r = s1(3000, -1, eff("temperature_friction", "viscous_exp"), temp=15.0)
    sl = sliding(r)
    th, qd = r.truth.temp_joint.to_numpy()[sl], r.truth.qd.to_numpy()[sl]
    expect = r.params["machine"]["f_v"] * qd * (np.exp(-0.03 * (th - 35)) - 1)
    np.testing.assert_allclose(eq4_residual(r)[sl], expect, atol=1.0)
    assert np.abs(expect).mean() > 150


def test_gear_ripple_sizes():
    r = s1(3000, 1, eff("gear_ripple", "output_harmonics"))
    sl = sliding(r)
    q = r.truth.q.to_numpy()[sl]
    x = np.column_stack([np.sin(96 * q), np.cos(96 * q), np.sin(192 * q), np.cos(192 * q)])
    c, *_ = np.linalg.lstsq(x, eq4_residual(r)[sl], rcond=None)
    assert math.hypot(c[0], c[1]) == pytest.approx(250, rel=0.01)
    assert math.hypot(c[2], c[3]) == pytest.approx(100, rel=0.01)
    r = sim(3, effects=eff("gear_ripple", "motor_angle"), sensors=CLEAN, unstated=False)
    th = N * r.truth.u.to_numpy()
    e = 2e-5 * (np.sin(2 * th + 0.3) + 0.3 * np.sin(4 * th + 2.2))
    np.testing.assert_allclose(r.truth.twist - r.truth.twist_effective, e, atol=1e-12)


@pytest.mark.parametrize("form", ["constant", "linear_drift", "settling", "thermal"])
def test_torque_offset_size(form):
    base = sim(3, sensors=CLEAN, seed=14)
    r = sim(3, sensors=CLEAN, seed=14, effects=eff("torque_offset", form))
    t, th = r.samples.t.to_numpy(), r.truth.temp_joint.to_numpy()
    expect = {"constant": 250 + 0 * t, "linear_drift": 4 * t,
              "settling": 300 * (1 - np.exp(-t / 12)), "thermal": 12 * (th - 35)}[form]
    np.testing.assert_allclose(r.samples.torque - base.samples.torque, expect, atol=1e-6)


@pytest.mark.parametrize("form,channel,lag", [("torque_lag", "torque", 0.020),
                                              ("encoder_lag", "q", 0.005)])
def test_time_delay_size(form, channel, lag):
    base = sim(3, sensors=CLEAN200, seed=15)
    r = sim(3, sensors=CLEAN200, seed=15, effects=eff("time_delay", form))
    t = base.samples.t.to_numpy()
    x0, x1 = base.samples[channel].to_numpy(), r.samples[channel].to_numpy()
    lags = np.arange(0, 0.0401, 0.0005)
    err = [np.abs(x1[20:] - np.interp(t[20:] - d, t, x0)).mean() for d in lags]
    assert lags[int(np.argmin(err))] == pytest.approx(lag, abs=0.0015)


def test_time_delay_filter_size():
    base = sim(3, sensors=CLEAN200, seed=15)
    r = sim(3, sensors=CLEAN200, seed=15, effects=eff("time_delay", "torque_filter"))
    x0, x1 = base.samples.torque.to_numpy(), r.samples.torque.to_numpy()
    taus = np.arange(0.005, 0.0401, 0.0025)
    err = [np.abs(x1 - R._lowpass1(x0, 1 / 200.0, tau)).mean() for tau in taus]
    assert taus[int(np.argmin(err))] == pytest.approx(0.020, abs=0.003)


@pytest.mark.parametrize("form", ["bouc_wen_n1", "bouc_wen_n3", "dahl_r2", "jenkins"])
def test_hysteresis_size(form):
    r = s1(300, 1, eff("hysteresis", form))
    base = s1(300, 1)
    ph, t = r.samples.phase.to_numpy(), r.samples.t.to_numpy()
    h = r.truth.torque_hysteresis.to_numpy()
    up = (ph == "load") & (t > 8)
    down = (ph == "unload") & (t > 42)
    if form == "dahl_r2":
        # dx/dDelta = (1 - x)^2/3e-4 while the twist only grows: 1/(1-x) rises as Delta/3e-4
        tw = r.truth.twist.to_numpy()
        i0 = int(np.searchsorted(t, 5.0))
        assert np.all(np.diff(tw[i0:int(np.searchsorted(t, 33.0))]) > 0)
        x = 1 - 1 / (1 / (1 - h[i0] / 400) + (tw - tw[i0]) / 3e-4)
        np.testing.assert_allclose(h[up], 400 * x[up], rtol=0.002)
        assert h[up].min() > 0.8 * 400 and h[down][-1] < -0.9 * 400
    else:
        np.testing.assert_allclose(h[up], 400, rtol=0.03)
        np.testing.assert_allclose(h[down], -400, rtol=0.03)
    # in the twist: -h over the tangent stiffness of the transmission law
    m = r.params["machine"]
    dtw = (r.truth.twist - base.truth.twist).to_numpy()
    kt = tangent_k(r.truth.torque.to_numpy(), m)
    np.testing.assert_allclose(dtw[up], -h[up] / kt[up], rtol=0.06)
    np.testing.assert_allclose(dtw[down], -h[down] / kt[down], rtol=0.06)
    assert np.abs(dtw[up]).min() > 2e-5


@pytest.mark.parametrize("form,lost", [("sharp", 2.5e-5), ("smooth", 2.5e-5),
                                       ("soft_zone", 0.85 * 2.5e-5)])
def test_backlash_size(form, lost):
    r = s1(3000, -1, eff("backlash", form))
    base = s1(3000, -1)
    hold = r.samples.phase.eq("hold").to_numpy()
    dtw = (r.truth.twist - base.truth.twist).to_numpy()[hold]
    np.testing.assert_allclose(dtw, lost, rtol=0.03)


@pytest.mark.parametrize("form,direction,extra", [("coulomb_neg", -1, 300.0),
                                                  ("coulomb_neg", 1, 0.0),
                                                  ("offset", 1, 250.0), ("offset", -1, -250.0)])
def test_asymmetric_friction_size(form, direction, extra):
    r = s1(300, direction, eff("asymmetric_friction", form))
    sl = sliding(r)
    np.testing.assert_allclose(eq4_residual(r)[sl] * direction, extra, atol=1.0)


def test_asymmetric_viscous_size():
    for direction, factor in ((1, 0.8), (-1, 0.0)):
        r = s1(3000, direction, eff("asymmetric_friction", "viscous_pos"))
        sl = sliding(r)
        qd = r.truth.qd.to_numpy()[sl]
        np.testing.assert_allclose(eq4_residual(r)[sl], factor * r.params["machine"]["f_v"] * qd,
                                   atol=1.0)


# ============================================================================================
# out of vocabulary, and the unstated imperfections
# ============================================================================================

@pytest.mark.parametrize("form", ["sine", "pulse", "beat"])
def test_periodic_disturbance_shows(form):
    r = sim(3, sensors=CLEAN, effects=eff("periodic_disturbance", form), unstated=False)
    t = r.truth.t.to_numpy()
    ph = np.mod(t, 3.0)
    expect = {"sine": 300 * np.sin(2 * np.pi * 0.9 * t),
              "pulse": np.where(ph < 0.5, 150 * (1 - np.cos(2 * np.pi * ph / 0.5)), 0.0),
              "beat": 300 * np.sin(2 * np.pi * 1.3 * t) * np.sin(2 * np.pi * 0.11 * t)}[form]
    np.testing.assert_allclose(r.truth.disturbance, expect, atol=1e-9)
    base = sim(3, sensors=CLEAN, unstated=False)
    assert np.abs(r.samples.torque - base.samples.torque).max() > 100


@pytest.mark.parametrize("form", ["once_per_rev", "twice_per_rev", "sector"])
def test_position_stiffness_shows(form):
    r = s1(300, 1, eff("position_stiffness", form))
    base = s1(300, 1)
    m, tr = r.params["machine"], r.truth
    q = tr.q.to_numpy()
    shape = {"once_per_rev": np.cos(q - 0.3), "twice_per_rev": np.cos(2 * q + 0.7),
             "sector": -np.exp(-((q - 0.06) / 0.05) ** 2)}[form]
    te0 = tr.torque_elastic.to_numpy() / (1 + 0.006 * shape)
    np.testing.assert_allclose(law_delta(te0, m), tr.twist_effective, atol=1e-12)
    assert np.abs(tr.twist - base.truth.twist).max() > 2e-5


@pytest.mark.parametrize("form,channel", [("output", "torque"), ("loader", "torque_load")])
def test_second_resonance_shows(form, channel):
    sens = dataclasses.replace(CLEAN, sample_rate_hz=100.0)
    r = sim(3, sensors=sens, effects=eff("second_resonance", form), unstated=False)
    base = sim(3, sensors=sens, unstated=False)

    def high_pass(x):                        # minus a 0.25 s running mean: above ~4 Hz
        return x - np.convolve(x, np.ones(25) / 25, mode="same")

    # the hung body rings about its 11 Hz (split by the bench's own 7-8 Hz modes into a pair)
    a = high_pass(r.truth.absorber_torque.to_numpy())
    spec = np.abs(np.fft.rfft(a * np.hanning(len(a)))) ** 2
    f = np.fft.rfftfreq(len(a), 1 / 100.0)
    assert spec[(f >= 5) & (f <= 15)].sum() > 0.7 * spec[f >= 4].sum()
    assert a.std() > 10.0
    # and the bench's torques carry it
    d = high_pass((r.truth[channel] - base.truth[channel]).to_numpy())
    assert d.std() > 5.0
    assert np.abs(r.truth.torque - base.truth.torque).max() > 100.0


def test_encoder_and_loadcell_oov_sizes():
    base = sim(3, sensors=CLEAN, seed=16)
    r = sim(3, sensors=CLEAN, seed=16, effects=eff("encoder_eccentricity", "once_per_rev"))
    q = base.truth.q.to_numpy()
    np.testing.assert_allclose(r.samples.q - base.samples.q, 4e-5 * np.sin(q + 0.5), atol=5e-8)
    r = sim(3, sensors=CLEAN, seed=16, effects=eff("encoder_eccentricity", "scale_error"))
    np.testing.assert_allclose(r.samples.q - base.samples.q, 2e-4 * q, atol=5e-8)
    r = sim(3, sensors=CLEAN, seed=16, effects=eff("loadcell_drift", "linear"))
    np.testing.assert_allclose(r.samples.torque_load - base.samples.torque_load,
                               4 * r.samples.t, atol=1e-6)
    r = sim(3, sensors=CLEAN, seed=16, effects=eff("loadcell_drift", "settling"))
    np.testing.assert_allclose(r.samples.torque_load - base.samples.torque_load,
                               300 * (1 - np.exp(-r.samples.t / 15)), atol=1e-6)


@pytest.mark.parametrize("direction", [1, -1])
def test_unstated_imperfections_are_real_and_recorded(direction):
    r = sim(1, 3000, direction, 25.0, sensors=CLEAN, unstated=True)
    nominal = sim(1, 3000, direction, 25.0, sensors=CLEAN, unstated=False)
    un = r.params["unstated"]
    assert set(un) == set(R.UNSTATED_VOCABULARY)
    assert r.params["machine"] == nominal.params["machine"]
    sl = sliding(r)
    res = eq4_residual(r)[sl]
    q = r.truth.q.to_numpy()[sl]
    rip = un["gear_ripple"]
    ripple = rip["amplitude_nm"] * np.sin(96 * q + rip["phase_rad"])
    asym = un["asymmetric_friction"]["extra_coulomb_negative_nm"] if direction < 0 else 0.0
    np.testing.assert_allclose(res, ripple + direction * asym, atol=1.0)
    assert 25 <= rip["amplitude_nm"] <= 45
    # the torque transducer's zero: reading - truth, on the hold plateau
    hold = r.samples.phase.eq("hold").to_numpy() & (r.samples.t > 34).to_numpy()
    off = (r.samples.torque - r.truth.torque).to_numpy()[hold].mean()
    assert off == pytest.approx(un["torque_offset"]["offset_nm"], abs=3.0)
    off0 = (nominal.samples.torque - nominal.truth.torque).to_numpy()[hold].mean()
    assert abs(off0) < 3.0
