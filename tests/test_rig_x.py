"""Validation rig X (validation_rigs/rig_x.py): the contract the harness relies on, and the
physics against the paper (Eq. 4 with Table 3, the ~0.5° twist at 120 kN·m, gravity, the
reduction) and each effect's size at scale 1 as the module's data sheet states it."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pandas as pd
import pytest

from core.run import RunData
from core.runfile import validate_meta, validate_samples
from validation_rigs import rig_x as R

TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.660}
G = 9.81
W_TOP = 3000 * 2 * math.pi / 60 / R.REDUCTION     # output speed at 3000 r/min [rad/s]


def _freeze(effects):
    if not effects:
        return ()
    return tuple(sorted((k, v["form"], float(v["scale"])) for k, v in effects.items()))


@lru_cache(maxsize=None)
def _run(scheme, rpm, direction, temp, eff, sens, periods, seed, run, unstated):
    effects = {k: {"form": f, "scale": s} for k, f, s in eff}
    return R.simulate_run(scheme, rpm, direction, temp, effects or None,
                          sensors=R.SensorSpec(*sens), periods=periods, seed=seed, run=run,
                          unstated_scale=unstated)


def sim(scheme=1, rpm=3000.0, direction=1, temp=25.0, effects=None, sensors=None, periods=1,
        seed=7, run=0, unstated=1.0):
    if scheme == 3:
        rpm = None
    sens = (sensors or R.SensorSpec(sample_rate_hz=20.0)).key()
    return _run(scheme, rpm, direction, temp, _freeze(effects), sens, periods, seed, run,
                unstated)


def eff(name, form=None, scale=1.0):
    return {name: {"form": form or R.EFFECT_FORMS[name][0], "scale": scale}}


def steady(r, t0, t1):
    t = r.truth.t.to_numpy()
    return (t >= t0) & (t <= t1)


def balance(r):
    """What the output balance leaves for friction and body torques: T − τ_L − I q̈ − gravity
    (drawn machine's rigid-body values)."""
    m = r.params["machine"]
    tr = r.truth
    q = tr.q.to_numpy()
    grav = m["g"] * (m["mr_x"] * np.sin(q) + m["mr_y"] * np.cos(q))
    return tr.torque.to_numpy() - tr.torque_load.to_numpy() - m["I"] * tr.qdd.to_numpy() - grav


# --- contract --------------------------------------------------------------------------------

def test_module_names():
    assert R.RIG_NAME == "rig_x" and R.REDUCTION == 11000.0 and R.SEED_IS_CAMPAIGN is True
    assert isinstance(R.SCALE_MAX, float) and R.SCALE_MAX >= 1
    vocab = {"stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
             "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction"}
    assert vocab <= set(R.EFFECT_FORMS)
    assert set(R.OUT_OF_VOCABULARY) == set(R.EFFECT_FORMS) - vocab
    assert len(R.OUT_OF_VOCABULARY) >= 4
    for name, forms in R.EFFECT_FORMS.items():
        assert len(forms) >= (3 if name in vocab else 2), name
        assert len(set(forms)) == len(forms)
    assert 2 <= len(R.UNSTATED_VOCABULARY) <= 3
    assert set(R.UNSTATED_VOCABULARY) <= vocab
    assert "load_dependent_friction" in R.UNSTATED_VOCABULARY
    assert set(R.UNSTATED_VOCABULARY) != {"asymmetric_friction", "gear_ripple", "torque_offset"}


def test_columns_meta_rundata():
    r = sim()
    for c in ["t", "q", "u", "torsion", "torque", "torque_load", "torque_cmd", "i_m1", "i_m2",
              "i_m3", "w_m1", "w_m2", "w_m3", "temp_m1", "temp_m2", "temp_m3", "temp_joint",
              "phase"]:
        assert c in r.samples.columns, c
    for c in ["t", "twist", "torque", "torque_load", "q"]:
        assert c in r.truth.columns, c
    out = validate_samples(r.samples, "rig_x")
    assert len(out) == len(r.samples)
    assert validate_meta(r.meta, "rig_x") is r.meta
    RunData(samples=r.samples, meta=r.meta)
    assert r.meta["scheme"] == 1 and r.meta["direction"] == 1 and r.meta["reduction"] == 11000.0
    assert r.meta["sample_rate_hz"] == 20.0
    assert set(r.samples.phase.unique()) == {"idle", "load", "unload"}
    np.testing.assert_allclose(np.diff(r.samples.t), 1 / 20.0)
    assert r.samples.t.iloc[-1] == pytest.approx(70.0)
    for k in ("machine", "effects", "unstated"):
        assert k in r.params
    r3 = sim(scheme=3)
    assert r3.meta["motor_speed_rpm"] is None
    assert set(r3.samples.phase.unique()) == {"excite"}
    validate_meta(r3.meta, "x")
    r2 = sim(scheme=2)
    assert {"idle", "load", "hold", "unload"} == set(r2.samples.phase.unique())
    assert 50 <= r2.samples.t.iloc[-1] <= 80


def test_meta_sensors_state_the_data_sheet():
    s = R.SensorSpec(sample_rate_hz=20.0, encoder_res_deg=0.02, torque_noise=80.0,
                     torque_lag_s=0.003)
    r = sim(sensors=s)
    sens = r.meta["sensors"]
    assert sens["q"]["resolution"] == pytest.approx(math.radians(0.02))
    assert sens["torque"]["noise_sd"] == 80.0 and sens["torque"]["lag_s"] == 0.003
    assert sens["u"]["resolution"] == pytest.approx(2 * math.pi / 2 ** 20 / 11000)
    for ch in ("q", "u", "torque", "torque_load"):
        assert set(sens[ch]) == {"resolution", "noise_sd", "lag_s"}, ch
    # the q reading sits on the encoder grid
    k = r.samples.q.to_numpy() / math.radians(0.02)
    np.testing.assert_allclose(k, np.round(k), atol=1e-6)
    ku = r.samples.u.to_numpy() / sens["u"]["resolution"]
    np.testing.assert_allclose(ku, np.round(ku), atol=1e-4)
    # noise as stated (torque reading vs the truth, slow load ramp so the lag is negligible)
    m = steady(r, 8, 32)
    resid = (r.samples.torque - r.truth.torque).to_numpy()[m]
    assert np.std(resid) == pytest.approx(80.0, rel=0.25)
    # nothing of the unstated imperfections in the metadata
    assert "unstated" not in str(r.meta)


def test_determinism_seed_and_run():
    a = R.simulate_run(3, None, 1, 30.0, sensors=R.SensorSpec(sample_rate_hz=20), periods=1,
                       seed=5, run=2)
    b = R.simulate_run(3, None, 1, 30.0, sensors=R.SensorSpec(sample_rate_hz=20), periods=1,
                       seed=5, run=2)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    c = R.simulate_run(3, None, 1, 30.0, sensors=R.SensorSpec(sample_rate_hz=20), periods=1,
                       seed=5, run=3)
    assert c.params["machine"] == a.params["machine"]           # same campaign, same machine
    assert not np.array_equal(c.samples.torque, a.samples.torque)  # its own noise
    d = R.simulate_run(3, None, 1, 30.0, sensors=R.SensorSpec(sample_rate_hz=20), periods=1,
                       seed=6, run=2)
    assert d.params["machine"] != a.params["machine"]
    # the spread is small
    for k, v in TABLE3.items():
        assert d.params["machine"][k] == pytest.approx(v, rel=0.03)


BAD_ARGS = [
    ("scheme", dict(scheme=4)), ("scheme", dict(scheme=True)), ("scheme", dict(scheme="1")),
    ("motor_speed_rpm", dict(motor_speed_rpm=0.0)), ("motor_speed_rpm", dict(motor_speed_rpm=3001)),
    ("motor_speed_rpm", dict(motor_speed_rpm=float("nan"))),
    ("motor_speed_rpm", dict(motor_speed_rpm=float("inf"))),
    ("motor_speed_rpm", dict(motor_speed_rpm=True)), ("motor_speed_rpm", dict(motor_speed_rpm=None)),
    ("motor_speed_rpm", dict(scheme=3, motor_speed_rpm=300.0)),
    ("direction", dict(direction=0)), ("direction", dict(direction=2)),
    ("direction", dict(direction=True)), ("direction", dict(direction=1.5)),
    ("temp_joint_c", dict(temp_joint_c=14.9)), ("temp_joint_c", dict(temp_joint_c=60.1)),
    ("temp_joint_c", dict(temp_joint_c=float("nan"))), ("temp_joint_c", dict(temp_joint_c=False)),
    ("temp_joint_c", dict(temp_joint_c="20")),
    ("effects", dict(effects=[1])), ("effects", dict(effects={"nope": {"form": "x", "scale": 1}})),
    ("effects", dict(effects={"stribeck": {"form": "bogus", "scale": 1.0}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian"}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": -0.1}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": R.SCALE_MAX * 1.01}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": float("nan")}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": float("inf")}})),
    ("effects", dict(effects={"stribeck": {"form": "gaussian", "scale": True}})),
    ("sensors", dict(sensors={"sample_rate_hz": 10})),
    ("periods", dict(periods=0)), ("periods", dict(periods=True)), ("periods", dict(periods=1.5)),
    ("seed", dict(seed=-1)), ("seed", dict(seed=1.5)), ("seed", dict(seed=True)),
    ("seed", dict(seed=None)),
    ("run", dict(run=-1)), ("run", dict(run="0")), ("run", dict(run=False)),
    ("unstated_scale", dict(unstated_scale=float("nan"))),
    ("unstated_scale", dict(unstated_scale=-1.0)),
]


@pytest.mark.parametrize("name,bad", BAD_ARGS)
def test_argument_validation_names_the_argument(name, bad):
    kw = dict(scheme=1, motor_speed_rpm=300.0, direction=1, temp_joint_c=25.0, effects=None,
              sensors=R.SensorSpec(sample_rate_hz=10), periods=1, seed=1, run=0)
    kw.update(bad)
    with pytest.raises(ValueError, match=name):
        R.simulate_run(kw.pop("scheme"), kw.pop("motor_speed_rpm"), kw.pop("direction"),
                       kw.pop("temp_joint_c"), kw.pop("effects"), **kw)


SENSOR_BAD = [(f, v) for f in ("sample_rate_hz", "encoder_res_deg", "torque_noise",
                               "torque_lag_s", "motor_encoder_counts", "load_cell_noise",
                               "current_noise", "speed_noise", "temp_res_c")
              for v in (float("nan"), float("inf"), True, "1", None, -1.0, 1e9)]


@pytest.mark.parametrize("field,value", SENSOR_BAD)
def test_sensor_spec_validation(field, value):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})


def test_sensor_spec_ranges():
    R.SensorSpec(sample_rate_hz=10, encoder_res_deg=1e-6, torque_noise=0, torque_lag_s=0)
    R.SensorSpec(sample_rate_hz=1000, encoder_res_deg=1.0)
    for f, v in (("sample_rate_hz", 9.99), ("sample_rate_hz", 1000.1),
                 ("encoder_res_deg", 0.9e-6), ("encoder_res_deg", 1.01)):
        with pytest.raises(ValueError, match=f):
            R.SensorSpec(**{f: v})


ALL_FORMS = [(n, f) for n, fs in R.EFFECT_FORMS.items() for f in fs]


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_form_runs_and_changes_something(name, form):
    base = sim(scheme=3, temp=16.0)
    r = sim(scheme=3, temp=16.0, effects=eff(name, form))
    assert np.isfinite(r.truth.select_dtypes("number").to_numpy()).all()
    validate_samples(r.samples, "x")
    num = [c for c in r.samples.columns if c != "phase"]
    diff = np.abs(r.samples[num].to_numpy() - base.samples[num].to_numpy()).max()
    assert diff > 0, (name, form)
    assert r.params["effects"] == {name: {"form": form, "scale": 1.0}}


@pytest.mark.parametrize("name", list(R.EFFECT_FORMS))
def test_scale_zero_is_no_effect(name):
    base = sim(scheme=3)
    r = sim(scheme=3, effects=eff(name, scale=0.0))
    pd.testing.assert_frame_equal(r.samples, base.samples)
    pd.testing.assert_frame_equal(r.truth, base.truth)


@pytest.mark.parametrize("name,form", [(n, f) for n in R.SENSOR_ONLY_EFFECTS
                                       for f in R.EFFECT_FORMS[n]])
def test_sensor_only_effects_leave_the_truth_untouched(name, form):
    base = sim(scheme=3)
    r = sim(scheme=3, effects=eff(name, form, 3.0))
    pd.testing.assert_frame_equal(r.truth, base.truth)
    touched = {"torque_offset": {"torque"}, "time_delay": {"torque", "q", "torsion"},
               "encoder_drift": {"q", "torsion"}}[name]
    for c in r.samples.columns:
        if c not in touched:
            pd.testing.assert_series_equal(r.samples[c], base.samples[c])
    assert any(not r.samples[c].equals(base.samples[c]) for c in touched)


FINE = R.SensorSpec(sample_rate_hz=20.0, encoder_res_deg=1e-6, torque_noise=0.0)

LINEAR_SIGNAL = {"stribeck": (1, 300.0, "torque"), "load_dependent_friction": (1, 3000.0, "torque"),
                 "temperature_friction": (1, 3000.0, "torque"), "gear_ripple": (1, 3000.0, "torque"),
                 "torque_offset": (1, 3000.0, "r:torque"), "time_delay": (1, 3000.0, "r:torque"),
                 "hysteresis": (1, 3000.0, "twist"), "backlash": (1, 3000.0, "twist"),
                 "asymmetric_friction": (1, 3000.0, "torque")}


@pytest.mark.parametrize("name", list(LINEAR_SIGNAL))
def test_linear_in_small_scale(name):
    scheme, rpm, col = LINEAR_SIGNAL[name]

    def sig(r):
        return (r.samples[col[2:]] if col.startswith("r:") else r.truth[col]).to_numpy()
    kw = dict(scheme=scheme, rpm=rpm, temp=17.0, sensors=FINE)
    b = sig(sim(**kw))
    d1 = sig(sim(effects=eff(name, scale=0.05), **kw)) - b
    d2 = sig(sim(effects=eff(name, scale=0.1), **kw)) - b
    assert np.linalg.norm(d2) > 0
    assert np.linalg.norm(d2 - 2 * d1) <= 0.12 * np.linalg.norm(d2), name


# --- physics against the paper -----------------------------------------------------------------

@pytest.mark.parametrize("direction", [1, -1])
def test_steady_sliding_follows_eq4_with_table3(direction):
    r = sim(direction=direction, unstated=0.0)
    tr = r.truth
    m = steady(r, 8, 62)
    q, qd, qdd = tr.q.to_numpy(), tr.qd.to_numpy(), tr.qdd.to_numpy()
    rhs = (TABLE3["I"] * qdd + G * (TABLE3["mr_x"] * np.sin(q) + TABLE3["mr_y"] * np.cos(q))
           + TABLE3["f_v"] * qd + TABLE3["f_c"] * np.sign(qd))
    resid = (tr.torque - tr.torque_load).to_numpy() - rhs
    # machine spread (±1 % on f_c, f_v) only: within 60 N·m of Table 3, 2.5 % of f_c
    assert np.abs(resid[m]).max() < 60.0
    # and exactly the drawn machine's Eq. 4 (steady Bliman–Sorine level = f_c)
    mm = r.params["machine"]
    rhs2 = (mm["I"] * qdd + mm["g"] * (mm["mr_x"] * np.sin(q) + mm["mr_y"] * np.cos(q))
            + mm["f_v"] * qd + mm["f_c"] * np.sign(qd))
    resid2 = (tr.torque - tr.torque_load).to_numpy() - rhs2
    assert np.abs(resid2[m]).max() < 2.0
    assert np.all(np.sign(qd[m]) == direction)


def test_twist_at_rated_load_is_about_half_a_degree():
    r = sim(unstated=0.0)
    tr = r.truth
    i = int(np.argmax(tr.torque_load.to_numpy()))
    assert tr.torque_load[i] == pytest.approx(120e3, abs=2e3)     # Table 11: ±2 kN·m
    tw = math.degrees(tr.twist[i])
    assert 0.45 < tw < 0.58
    secant = tr.torque[i] / tr.twist[i]
    assert 1.2e7 < secant < 1.5e7
    # the reading of the twist (q − u) sees the same within the encoder's step
    assert -r.samples.torsion[i] == pytest.approx(tr.twist[i], abs=2 * math.radians(0.01))


def test_transmission_softens_mildly():
    r = sim(scheme=2, unstated=0.0, sensors=R.SensorSpec(sample_rate_hz=20))
    tr = r.truth
    el, tw = tr.torque_elastic.to_numpy(), tr.twist.to_numpy() - 0 * tr.q.to_numpy()
    lo = (np.abs(el - 15e3) < 6e3)
    hi = (np.abs(el - 112e3) < 7e3)
    k_lo = np.polyfit(tw[lo], tr.torque.to_numpy()[lo], 1)[0]
    k_hi = np.polyfit(tw[hi], tr.torque.to_numpy()[hi], 1)[0]
    assert 0.80 < k_hi / k_lo < 0.92
    # first order: T ≈ k·Δ over the whole range, within the softening
    k = np.polyfit(tw, tr.torque.to_numpy(), 1)[0]
    assert 1.2e7 < k < 1.5e7


def test_gravity():
    r = sim(scheme=3, unstated=0.0)
    tr = r.truth
    # at rest at q = 0, before the drive moves: the transmission holds g·mr_y
    assert tr.torque[0] == pytest.approx(G * TABLE3["mr_y"], rel=0.03)
    # everywhere: what the output balance leaves besides friction is gravity of the machine
    m = r.params["machine"]
    q = tr.q.to_numpy()
    grav = m["g"] * (m["mr_x"] * np.sin(q) + m["mr_y"] * np.cos(q))
    est = (tr.torque - tr.torque_load - m["I"] * tr.qdd - tr.friction).to_numpy()
    np.testing.assert_allclose(est, grav, atol=1.0)


def test_reduction_and_speeds():
    r = sim(rpm=3000.0)
    s, tr = r.samples, r.truth
    m = steady(r, 2, 4)
    assert s.w_m1[m].mean() == pytest.approx(3000 * 2 * math.pi / 60, rel=0.01)
    assert tr.qd[m].mean() == pytest.approx(W_TOP, rel=0.01)
    # u is motor 1's angle over N: u − q is the twist
    np.testing.assert_allclose(tr.u - tr.q, tr.twist, atol=1e-12)
    # the slaves share the torque (within their mismatch)
    i1, i2 = s.i_m1[steady(r, 30, 40)].mean(), s.i_m2[steady(r, 30, 40)].mean()
    assert i2 == pytest.approx(i1, rel=0.05)
    # motor current × k_t × N × 3 ≈ the transmitted torque at rated load
    i = int(np.argmax(tr.torque_load.to_numpy()))
    kt = r.params["machine"]["k_t"]
    tot = (s.i_m1[i] + s.i_m2[i] + s.i_m3[i]) * kt * R.REDUCTION
    assert tot == pytest.approx(tr.torque[i], rel=0.03)


def test_stated_torque_lag():
    s = R.SensorSpec(sample_rate_hz=20.0, torque_noise=0.0, torque_lag_s=0.02)
    r = sim(sensors=s, unstated=0.0)
    m = steady(r, 10, 30)        # load ramp of 4 kN·m/s
    d = (r.samples.torque - r.truth.torque).to_numpy()[m]
    assert d.mean() == pytest.approx(-4000 * 0.02, rel=0.1)


def test_unstated_imperfections_are_there_and_small():
    a = sim(unstated=1.0, temp=15.0)
    b = sim(unstated=0.0, temp=15.0)
    m = steady(a, 8, 62)
    d = balance(a)[m] - balance(b)[m]
    assert 20 < np.abs(d).max() < 300
    assert set(a.params["unstated"]) == set(R.UNSTATED_VOCABULARY)


# --- effect sizes at scale 1 (as the data sheet states) ---------------------------------------

def _dbal(name, form, rpm=3000.0, temp=25.0, direction=1, t=(8, 62)):
    b = sim(rpm=rpm, temp=temp, direction=direction)
    r = sim(rpm=rpm, temp=temp, direction=direction, effects=eff(name, form))
    m = steady(r, *t)
    return r, (balance(r) - balance(b))[m], m


@pytest.mark.parametrize("form,g", [("exponential", lambda x: np.exp(-x)),
                                    ("gaussian", lambda x: np.exp(-x * x)),
                                    ("lorentzian", lambda x: 1 / (1 + x * x)),
                                    ("hyperbolic", lambda x: 1 / (1 + x))])
def test_size_stribeck(form, g):
    r, d, m = _dbal("stribeck", form, rpm=300.0)
    tr = r.truth
    x = np.abs(tr.qd.to_numpy()[m]) / R.STRIB_VS
    # Stribeck multiplies the Bliman–Sorine level, which is f_c in steady sliding
    expect = R.STRIB_DF * g(x)
    np.testing.assert_allclose(d, expect, atol=8.0 + 0.03 * expect.max())
    assert expect.max() > 20


def test_size_load_dependent_friction():
    r, d, m = _dbal("load_dependent_friction", "coulomb")
    el = np.abs(r.truth.torque_elastic.to_numpy()[m])
    np.testing.assert_allclose(d, 0.004 * el, atol=10.0)
    assert d.max() == pytest.approx(480, rel=0.05)
    r, d, m = _dbal("load_dependent_friction", "power_flow", direction=-1)
    el = np.abs(r.truth.torque_elastic.to_numpy()[m])
    hi = el > 100e3
    np.testing.assert_allclose(d[hi], -0.002 * el[hi], rtol=0.05)   # back-driven: low μ, sign −


def test_size_temperature_friction():
    r, d, m = _dbal("temperature_friction", "coulomb_additive", temp=15.0)
    dT = r.truth.temp_joint.to_numpy()[m] - 35.0
    np.testing.assert_allclose(d, 15.0 * (-dT), atol=8.0)
    r, d, m = _dbal("temperature_friction", "viscous_multiplicative", temp=15.0)
    tr = r.truth
    dT = tr.temp_joint.to_numpy()[m] - 35.0
    expect = r.params["machine"]["f_v"] * tr.qd.to_numpy()[m] * (np.exp(-0.03 * dT) - 1)
    np.testing.assert_allclose(d, expect, atol=8.0)
    assert expect.mean() > 150


def test_size_asymmetric_friction():
    r, d, m = _dbal("asymmetric_friction", "coulomb_positive", direction=1)
    assert np.median(d) == pytest.approx(300, abs=10)
    r, d, m = _dbal("asymmetric_friction", "coulomb_positive", direction=-1)
    assert np.abs(d).max() < 10
    r, d, m = _dbal("asymmetric_friction", "coulomb_split", direction=-1)
    assert np.median(d) == pytest.approx(200, abs=10)   # an offset that is not gravity


def test_size_gear_ripple():
    r, d, m = _dbal("gear_ripple", "output_harmonics")
    q = r.truth.q.to_numpy()[m]
    z = 144.0
    expect = 250 * (np.sin(z * q) + 0.5 * np.sin(2 * z * q + 0.7) + 0.25 * np.sin(3 * z * q + 1.9))
    # a body torque: it shows in the balance T − τ_L − I q̈ − gravity as friction does
    np.testing.assert_allclose(d, expect, atol=25.0)
    assert np.abs(expect).max() > 250


def test_size_hysteresis():
    b = sim(temp=25.0)
    r = sim(temp=25.0, effects=eff("hysteresis", "bouc_wen_n1"))
    d = (r.truth.torque_elastic - b.truth.torque_elastic).to_numpy()
    load, unload = steady(r, 10, 33), steady(r, 40, 63)
    # the hysteretic torque (+400 while winding up, −400 while unwinding) carries part of T
    assert np.median(d[load]) == pytest.approx(-400, rel=0.06)
    assert np.median(d[unload]) == pytest.approx(400, rel=0.06)


def test_size_backlash():
    b = sim()
    r = sim(effects=eff("backlash", "sharp"))
    d = (r.truth.twist - b.truth.twist).to_numpy()[steady(r, 8, 62)]
    np.testing.assert_allclose(d, 3e-5, rtol=0.05)      # the half gap, T > 0 throughout
    r = sim(effects=eff("backlash", "soft_gap"))
    d = (r.truth.twist - b.truth.twist).to_numpy()[steady(r, 20, 50)]
    np.testing.assert_allclose(d, 0.85 * 3e-5, rtol=0.05)


def test_size_torque_offset_and_delay():
    b = sim(sensors=FINE)
    t = b.samples.t.to_numpy()
    for form, f in (("constant", lambda t: 300 + 0 * t), ("linear_drift", lambda t: 300 * t / 60),
                    ("warmup", lambda t: 300 * (1 - np.exp(-t / 20)))):
        r = sim(sensors=FINE, effects=eff("torque_offset", form))
        np.testing.assert_allclose(r.samples.torque - b.samples.torque, f(t), atol=1e-6)
    m = steady(b, 10, 30)
    r = sim(sensors=FINE, effects=eff("time_delay", "torque_pure_lag"))
    assert np.mean((r.samples.torque - b.samples.torque)[m]) == pytest.approx(-4000 * 0.025,
                                                                              rel=0.1)
    r = sim(sensors=FINE, effects=eff("time_delay", "torque_filter_lag"))
    assert np.mean((r.samples.torque - b.samples.torque)[m]) == pytest.approx(-4000 * 0.025,
                                                                              rel=0.1)
    r = sim(sensors=FINE, effects=eff("time_delay", "encoder_lag"))
    dq = (r.samples.q - b.samples.q).to_numpy()[m]
    qd = b.truth.qd.to_numpy()[m]
    np.testing.assert_allclose(dq, -qd * 0.004, atol=3e-6)


# --- out of vocabulary: each one shows ----------------------------------------------------------

def test_oov_periodic_disturbance_shows():
    r, d, m = _dbal("periodic_disturbance", "sine")
    t = r.truth.t.to_numpy()[m]
    # a body torque s·250·sin(2π·1.3·t) sampled at 20 Hz
    np.testing.assert_allclose(d, 250 * np.sin(2 * np.pi * 1.3 * t), atol=25)


def test_oov_position_dependent_stiffness_shows():
    b = sim()
    r = sim(effects=eff("position_dependent_stiffness", "sinusoidal"))
    m = steady(r, 20, 50)
    q = r.truth.q.to_numpy()[m]
    ratio = (b.truth.twist / r.truth.twist).to_numpy()[m]
    np.testing.assert_allclose(ratio, 1 + 0.01 * np.sin(3 * q + 1), atol=0.002)


def test_oov_encoder_drift_shows():
    b = sim(sensors=FINE)
    r = sim(sensors=FINE, effects=eff("encoder_drift", "linear"))
    t = b.samples.t.to_numpy()
    np.testing.assert_allclose(r.samples.q - b.samples.q, 3e-5 * t / 60, atol=3e-8)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["second_resonance"])
def test_oov_second_resonance_shows(form):
    b = sim(scheme=3, sensors=R.SensorSpec(sample_rate_hz=200))
    r = sim(scheme=3, sensors=R.SensorSpec(sample_rate_hz=200),
            effects=eff("second_resonance", form))
    d = balance(r) - balance(b)
    assert np.abs(d).max() > 30
    # below its frequency the appendage (J2 = 0.5·I) rides with the output: an inertia the
    # rigid Eq. 4 does not have, plus its ringing
    qdd = r.truth.qdd.to_numpy()
    c = np.corrcoef(d, 0.5 * r.params["machine"]["I"] * qdd)[0, 1]
    assert c > 0.8
