"""Rig AG (validation_rigs/rig_ag.py): interface, argument checks, determinism, the run format
and its metadata, the sensors and the clock, the nominal physics of its data sheet (derived
again here from the data sheet's formulas, not from the rig's kernel) and the sign and size of
every effect form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.run import RunData
from core.runfile import read_run, validate_meta, validate_samples, write_run
from validation_rigs import rig_ag as R

N = 11000.0
T_RATED = 120_000.0
SEED = 7


def w_out(rpm: float) -> float:
    """Output speed [rad/s] at a motor speed [r/min]."""
    return rpm * 2 * math.pi / 60 / N


_cache: dict = {}


def sim(scheme=1, rpm=300, direction=1, temp=25.0, effects=None, periods=1, seed=SEED, run=0,
        **kw):
    key = (scheme, rpm, direction, temp, repr(effects), periods, seed, run, repr(kw))
    if key not in _cache:
        _cache[key] = R.simulate_run(scheme, None if scheme == 3 else rpm, direction, temp,
                                     effects, periods=periods, seed=seed, run=run, **kw)
    return _cache[key]


def eff(name, form, scale=1.0):
    return {name: {"form": form, "scale": scale}}


def col(r, name):
    return r.truth[name].to_numpy()


def rd(r, name):
    return r.samples[name].to_numpy(dtype=float)


def settled(r, phases=("load", "unload", "hold"), margin=0.5):
    """Samples in `phases` at least `margin` s after the phase last changed."""
    ph = r.samples["phase"].to_numpy()
    t = col(r, "t")
    change = np.r_[True, ph[1:] != ph[:-1]]
    last = np.maximum.accumulate(np.where(change, t, -np.inf))
    return np.isin(ph, phases) & (t - last >= margin)


def hold_means(r, values, skip=0.5):
    """Mean of `values` over each hold of a scheme-2 run, leaving the first `skip` s out."""
    ph = r.samples["phase"].to_numpy()
    t = col(r, "t")
    idx = np.flatnonzero(ph == "hold")
    segs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    return np.array([values[s[t[s] >= t[s[0]] + skip]].mean() for s in segs])


def spring(params, d):
    """The data sheet's two-slope, quadratic-blend law K(δ), written again from its formula."""
    ka, kb = params["k_a"], params["k_b"]
    d1, d2 = params["blend_lo"], params["blend_hi"]
    a = np.abs(np.asarray(d, dtype=float))
    t = np.where(a <= d1, ka * a,
                 np.where(a <= d2, ka * a + (kb - ka) * (a - d1) ** 2 / (2 * (d2 - d1)),
                          ka * a + (kb - ka) * ((d2 - d1) / 2 + a - d2)))
    return np.sign(d) * t


def gravity(params, q):
    return 9.81 * (params["mr_x"] * np.sin(q) + params["mr_y"] * np.cos(q))


# --- interface ------------------------------------------------------------------------------------

def test_interface_constants():
    assert R.RIG_NAME == "rig_ag" and R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True and R.SCALE_MAX == 10.0
    order = ["stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
             "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction",
             "periodic_disturbance", "position_dependent_stiffness", "encoder_drift",
             "second_resonance"]
    assert list(R.EFFECT_FORMS) == order
    for k, forms in R.EFFECT_FORMS.items():
        want = 2 if k in R.OUT_OF_VOCABULARY else 3
        assert len(forms) == want and len(set(forms)) == len(forms), k
    assert R.OUT_OF_VOCABULARY == ("periodic_disturbance", "position_dependent_stiffness",
                                   "encoder_drift", "second_resonance")
    first_nine = order[:9]
    assert 1 <= len(R.UNSTATED_VOCABULARY) <= 2
    assert all(k in first_nine and isinstance(v, str) and v
               for k, v in R.UNSTATED_VOCABULARY.items())
    for name in ("SensorSpec", "RigRun", "simulate_run", "draw_machine", "compliance_torque",
                 "run_duration"):
        assert callable(getattr(R, name))
    assert R.H_STEP <= 5e-4


def test_form_names_differ_from_the_other_rigs():
    from validation_rigs import rig_ae, rig_af
    for other in (rig_ae.EFFECT_FORMS, rig_af.EFFECT_FORMS):
        for k, forms in R.EFFECT_FORMS.items():
            assert not set(forms) & set(other.get(k, ())), k


def test_run_duration_and_travel_refusal():
    assert R.run_duration(1, 3) == 2.0 + 3 * 24.0 + 2.0
    assert R.run_duration(2, 1) == pytest.approx(2.0 + 28.4 + 2.0)
    assert R.run_duration(3, 2) == 2.0 + 20.0 + 2.0
    with pytest.raises(ValueError, match="travel"):
        R.simulate_run(2, 3000, 1, 25.0, periods=4, seed=1, run=0)


# --- argument checks --------------------------------------------------------------------------------

@pytest.mark.parametrize("field,value", [
    ("sample_rate_hz", float("nan")), ("sample_rate_hz", 5.0), ("sample_rate_hz", 2000.0),
    ("encoder_res_deg", float("inf")), ("torque_noise", -1.0), ("torque_lag_s", "0.1"),
    ("torque_filter_s", 0.5), ("motor_encoder_res", True), ("temp_res", None)])
def test_sensor_spec_refuses(field, value):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})


@pytest.mark.parametrize("kw,match", [
    (dict(scheme=4), "scheme"), (dict(scheme=1.0), "scheme"), (dict(scheme=True), "scheme"),
    (dict(motor_speed_rpm=1000), "motor_speed_rpm"), (dict(motor_speed_rpm=None), "motor_speed_rpm"),
    (dict(scheme=3, motor_speed_rpm=300), "motor_speed_rpm"), (dict(direction=0), "direction"),
    (dict(temp_joint_c=70.0), "temp_joint_c"), (dict(temp_joint_c=float("nan")), "temp_joint_c"),
    (dict(sensors={"sample_rate_hz": 10}), "sensors"), (dict(periods=0), "periods"),
    (dict(periods=21), "periods"), (dict(periods=2.0), "periods"), (dict(seed=-1), "seed"),
    (dict(seed="1"), "seed"), (dict(run=-2), "run"), (dict(run=None), "run"),
    (dict(effects=[]), "effects"), (dict(effects={"friction": {"form": "x"}}), "unknown effect"),
    (dict(effects={"stribeck": {"form": "exponential"}}), "unknown form"),
    (dict(effects={"stribeck": "gauss_bell"}), "must be a dict"),
    (dict(effects={"stribeck": {"form": "gauss_bell", "size": 1}}), "unknown keys"),
    (dict(effects={"stribeck": {"form": "gauss_bell", "scale": -0.1}}), ">= 0"),
    (dict(effects={"stribeck": {"form": "gauss_bell", "scale": 10.5}}), "SCALE_MAX"),
    (dict(effects={"stribeck": {"form": "gauss_bell", "scale": "1"}}), "finite number"),
    (dict(effects={"stribeck": {"form": "gauss_bell", "scale": float("inf")}}), "finite number"),
])
def test_simulate_run_refuses(kw, match):
    args = dict(scheme=1, motor_speed_rpm=300, direction=1, temp_joint_c=25.0, effects=None,
                sensors=None, periods=1, seed=0, run=0)
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        R.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                       args.pop("temp_joint_c"), args.pop("effects"), **args)


# --- determinism ------------------------------------------------------------------------------------

def test_determinism_by_seed_and_run():
    a = R.simulate_run(3, None, 1, 30.0, periods=1, seed=11, run=2)
    b = R.simulate_run(3, None, 1, 30.0, periods=1, seed=11, run=2)
    assert a.samples.equals(b.samples) and a.truth.equals(b.truth) and a.meta == b.meta
    c = R.simulate_run(3, None, 1, 30.0, periods=1, seed=11, run=3)
    d = R.simulate_run(3, None, 1, 30.0, periods=1, seed=12, run=2)
    # a new run of the campaign: same machine, new noise, wander and clock
    assert {k: v for k, v in c.params.items() if k in R.draw_machine(11)} == R.draw_machine(11)
    assert not np.array_equal(rd(a, "torque"), rd(c, "torque"))
    assert not np.array_equal(rd(a, "t"), rd(c, "t"))
    # a new campaign: another machine
    assert d.params["k_a"] != a.params["k_a"] and d.params["f_c"] != a.params["f_c"]
    # a zero scale is no effect at all
    e = R.simulate_run(3, None, 1, 30.0, eff("backlash", "contact_gap", 0.0), periods=1,
                       seed=11, run=2)
    assert e.samples.equals(a.samples)


# --- run format, metadata, sensors, clock -----------------------------------------------------------

def test_run_format_and_metadata(tmp_path):
    sens = R.SensorSpec(sample_rate_hz=100.0)
    r = sim(scheme=2, rpm=3000, direction=-1, sensors=sens)
    s = r.samples
    assert len(s) == int(R.run_duration(2, 1) * 100) + 1
    for c in ("t", "q", "qd", "u", "ud", "torsion", "torque", "torque_load", "torque_cmd",
              "i_m1", "i_m2", "i_m3", "w_m1", "w_m2", "w_m3", "temp_m1", "temp_m2", "temp_m3",
              "temp_joint", "phase"):
        assert c in s.columns
    assert set(s["phase"]) == {"idle", "load", "hold", "unload"}
    validate_samples(s, "rig_ag.csv")
    validate_meta(r.meta, "rig_ag.json")
    m = r.meta
    assert (m["scheme"], m["motor_speed_rpm"], m["direction"], m["reduction"], m["rig"],
            m["source"], m["sample_rate_hz"]) == (2, 3000.0, -1, 11000.0, "rig_ag", "emulator",
                                                  100.0)
    sn = m["sensors"]
    assert sn["q"]["resolution"] == pytest.approx(math.radians(0.01))
    assert sn["u"]["resolution"] == pytest.approx(2 * math.pi / 2 ** 20 / N)
    assert sn["torque"] == {"resolution": pytest.approx(400_000 / 2 ** 16), "noise_sd": 120.0,
                            "lag_s": pytest.approx(1e-3)}
    assert sn["torque_load"]["noise_sd"] == 60.0 and sn["qd"]["noise_sd"] == 1.5e-5
    written = write_run(RunData(samples=s, meta=r.meta), tmp_path / "ag")
    back = read_run(written[0])
    assert back.meta == r.meta
    assert np.allclose(back.channel("torque"), rd(r, "torque"))
    assert list(back.samples["phase"]) == list(s["phase"])
    s3 = sim(scheme=3)
    assert s3.meta["motor_speed_rpm"] is None and set(s3.samples["phase"]) == {"idle", "excite"}


def test_clock_stamps():
    for run in (0, 1, 5):
        r = sim(scheme=3, run=run)
        t, tt = rd(r, "t"), col(r, "t")
        assert t[0] == 0.0 and np.all(np.diff(t) > 0)
        assert np.allclose(tt, np.arange(len(tt)) / 1000.0)
        dev = np.abs(t - tt)
        assert dev.max() <= 50e-6 and dev.max() > 5e-6
        # the host clock's 10 µs tick
        assert np.allclose(np.round(t / 1e-5) * 1e-5, t, atol=1e-9)
        assert abs(r.params["clock_eps"]) <= 3e-6


def test_sensor_quantisation_and_noise():
    r = sim()
    res = math.radians(0.01)
    q, qt = rd(r, "q"), col(r, "q")
    assert np.allclose(q / res, np.round(q / res), atol=1e-6)
    assert np.abs(q - qt).max() <= res / 2 + 1e-12
    u, ut = rd(r, "u"), col(r, "u")
    ures = r.meta["sensors"]["u"]["resolution"]
    assert np.abs(u - ut).max() <= ures / 2 + 1e-15
    assert np.allclose(rd(r, "torsion"), q - u)
    noise = rd(r, "torque") - col(r, "torque_sensor")
    assert np.std(noise) == pytest.approx(120.0, rel=0.03) and abs(noise.mean()) < 5.0
    assert np.std(rd(r, "qd") - col(r, "qd")) == pytest.approx(1.5e-5, rel=0.05)
    assert np.array_equal(rd(r, "torque_cmd"), col(r, "torque_cmd"))
    # currents carry the motor torque: Σ kt_k·i_k·N = T_m (shares sum to one)
    p = r.params
    tm = sum(p[f"kt{k}"] * rd(r, f"i_m{k}") for k in (1, 2, 3)) * N
    resid = tm - col(r, "motor_torque")
    sd = math.sqrt(sum((p[f"kt{k}"] * 0.015 * N) ** 2 for k in (1, 2, 3)))
    assert abs(resid.mean()) < 10.0 and np.std(resid) == pytest.approx(sd, rel=0.05)
    assert np.allclose(rd(r, "w_m1"), N * col(r, "ud"), atol=6 * 3e-6 * N)


def test_torque_transducer_is_a_boxcar_with_the_stated_lag():
    quiet = dict(torque_noise=0.0, torque_res=0.0)
    r = sim(sensors=R.SensorSpec(**quiet))
    T, t = col(r, "torque"), col(r, "t")
    meas = rd(r, "torque")
    assert np.array_equal(meas, col(r, "torque_sensor"))
    # the mean of T over the last 2 ms, at 1 kHz: (T(t−2ms)/2 + T(t−1ms) + T(t)/2)/2 on the
    # piecewise-linear record is close to T(t − 1 ms) wherever T bends slowly
    lagged = np.interp(t - 1e-3, t, T)
    sel = settled(r, ("load", "unload"), margin=1.0)
    assert np.abs(meas - lagged)[sel].max() < 40.0
    assert r.meta["sensors"]["torque"]["lag_s"] == pytest.approx(1e-3)
    r2 = sim(sensors=R.SensorSpec(torque_lag_s=0.05, **quiet))
    assert np.allclose(rd(r2, "torque")[sel], np.interp(t - 0.05, t, meas)[sel], atol=1.0)
    assert r2.meta["sensors"]["torque"]["lag_s"] == pytest.approx(0.051)
    r3 = sim(sensors=R.SensorSpec(torque_filter_s=0.0, **quiet))
    assert np.array_equal(rd(r3, "torque"), T) and r3.meta["sensors"]["torque"]["lag_s"] == 0.0


# --- nominal physics --------------------------------------------------------------------------------

def test_compliance_law_from_the_data_sheet():
    p = R.draw_machine(SEED)
    d = np.linspace(-0.012, 0.012, 2401)
    assert np.allclose(R.compliance_torque(d, p), spring(p, d), rtol=1e-12, atol=1e-6)
    assert R.compliance_torque(p["twist_rated"], p) == pytest.approx(T_RATED, rel=1e-12)
    assert np.allclose(R.compliance_torque(-d, p), -R.compliance_torque(d, p))
    slope = np.gradient(R.compliance_torque(d, p), d)
    assert slope[1200] == pytest.approx(p["k_a"], rel=1e-6)
    assert slope[-1] == pytest.approx(p["k_b"], rel=1e-6)
    assert np.all(np.abs(np.diff(slope)) < 0.01 * p["k_a"])        # C¹: no jump in the slope
    assert 0.45 < math.degrees(p["twist_rated"]) < 0.55
    assert 0.9e7 < p["k_a"] < 1.25e7 and p["k_b"] == pytest.approx(p["stiff_ratio"] * p["k_a"])


@pytest.mark.parametrize("direction", [1, -1])
def test_balance_and_transmission_law(direction):
    r = sim(scheme=2, rpm=300, direction=direction)
    p = r.params
    res = p["I"] * col(r, "qdd") - (col(r, "torque") - col(r, "torque_load") - col(r, "gravity")
                                     - col(r, "friction") + col(r, "disturbance"))
    assert np.abs(res).max() < 1e-6
    law = spring(p, col(r, "twist")) + p["D_tr"] * col(r, "twist_rate")
    assert np.abs(col(r, "torque") - law).max() < 1e-6
    assert np.allclose(col(r, "gravity"), gravity(p, col(r, "q")), atol=1e-9)


@pytest.mark.parametrize("direction", [1, -1])
def test_steady_state_torque_on_the_holds(direction):
    r = sim(scheme=2, rpm=300, direction=direction)
    p = r.params
    w = w_out(300)
    lhs = col(r, "torque") - col(r, "torque_load") - col(r, "gravity")
    held = hold_means(r, lhs)
    assert len(held) == 12
    assert np.allclose(held, direction * (p["f_c"] + p["f_v"] * w), atol=40.0)
    # the same from the readings (the transducer's 1 ms lag is nothing on a hold)
    meas = hold_means(r, rd(r, "torque") - rd(r, "torque_load") - col(r, "gravity"))
    assert np.allclose(meas, direction * (p["f_c"] + p["f_v"] * w), atol=80.0)
    # the dynamometer holds each step within Table 11's ±2 kN·m
    err = hold_means(r, col(r, "torque_load") - col(r, "torque_cmd"))
    assert np.abs(err).max() < 2000.0
    assert np.allclose(hold_means(r, col(r, "torque_cmd")), np.arange(1, 13) * 10_000.0)


def test_twist_at_rated_load():
    r = sim(scheme=2, rpm=3000)
    p = r.params
    top = hold_means(r, col(r, "torque"))[-1]
    tw = hold_means(r, col(r, "twist"))[-1]
    assert top == pytest.approx(T_RATED + p["f_c"] + p["f_v"] * w_out(3000)
                                + gravity(p, hold_means(r, col(r, "q"))[-1]), abs=100.0)
    assert spring(p, tw) == pytest.approx(top, abs=5.0)
    # about half a degree, a little more than twist_rated (the friction and gravity on top)
    assert p["twist_rated"] < tw < p["twist_rated"] * 1.03
    # the encoders see it within their step (torsion = q − u = −twist)
    meas = hold_means(r, -rd(r, "torsion"))[-1]
    assert meas == pytest.approx(tw, abs=math.radians(0.01))


def test_motion_travel_and_temperatures():
    for scheme, rpm, travel in ((1, 3000, 2.106), (2, 3000, 2.483), (1, 300, 0.2106)):
        r = sim(scheme=scheme, rpm=rpm, direction=-1, periods=3)
        q = col(r, "q")
        assert -q.min() == pytest.approx(travel, rel=0.01) and q.max() < 1e-3
        assert np.abs(q).max() < R.TRAVEL_LIMIT
        sel = settled(r, ("load", "unload", "hold"))
        # the drive holds the motors' speed; the output's differs by the twist rate (q̇ = u̇ − Δ̇)
        assert np.allclose(col(r, "ud")[sel], -w_out(rpm), rtol=0.01)
        assert np.allclose(col(r, "qd")[sel], col(r, "ud")[sel] - col(r, "twist_rate")[sel])
    r3 = sim(scheme=3, periods=3)
    assert 0.02 < col(r3, "q").max() < 0.04 and col(r3, "q").min() > -1e-3
    assert np.abs(col(r3, "qd")).max() < w_out(3000)
    assert np.abs(col(r3, "qd")[-50:]).max() < 1e-4
    r = sim(temp=42.0)
    assert col(r, "temp_joint")[0] == 42.0 and col(r, "temp_m1")[0] == 44.0
    assert 42.0 < col(r, "temp_joint")[-1] < 42.2


def test_friction_and_transmission_dissipate():
    """Over a scheme-1 cycle the output friction and the transmission take energy out; every
    hysteresis form makes the transmission's loop dissipate more."""
    def loop_work(r):
        return np.trapezoid(col(r, "torque"), col(r, "twist"))
    base = sim(rpm=3000)
    q = col(base, "q")
    assert np.trapezoid(col(base, "friction"), q) > 0.9 * base.params["f_c"] * (q[-1] - q[0])
    w0 = loop_work(base)
    assert w0 > 0.0
    for form in R.EFFECT_FORMS["hysteresis"]:
        r = sim(rpm=3000, effects=eff("hysteresis", form))
        assert loop_work(r) > w0 + 0.5, form          # > 0.5 J per cycle more


# --- effects ----------------------------------------------------------------------------------------

_WHERE = {   # conditions under which a form shows (default: scheme 1, 300 r/min, +1)
    "neg_low_speed_hump": dict(direction=-1),
    "viscous_kelvin_power": dict(rpm=3000), "u_ratio_creep": dict(rpm=3000),
    "u_transport": dict(rpm=3000), "q_frame_hold": dict(rpm=3000),
    "motor_shaft_2x_4x": dict(rpm=3000),
    "carrier_split_mode": dict(scheme=2, rpm=3000), "housing_rocking": dict(scheme=2, rpm=3000),
}


@pytest.mark.parametrize("family,form", [(f, x) for f, xs in R.EFFECT_FORMS.items() for x in xs])
def test_every_form_changes_the_readings(family, form):
    where = _WHERE.get(form, {})
    base = sim(**where)
    r = sim(effects=eff(family, form), **where)
    assert r.params["newton_failures"] == 0
    d_t = np.sqrt(np.mean((rd(r, "torque") - rd(base, "torque")) ** 2))
    d_tw = np.sqrt(np.mean((rd(r, "torsion") - rd(base, "torsion")) ** 2))
    assert d_t > 50.0 or d_tw > 1.5e-5, (d_t, d_tw)
    # a real rig's size, not a caricature
    assert d_t < 5000.0 and d_tw < 1e-3
    for c in ("q", "u", "torque", "torque_load"):
        assert np.isfinite(rd(r, c)).all()


def test_friction_effects_sign_and_size():
    base = sim()
    p = base.params
    sel = settled(base, ("load", "unload"))
    f0 = col(base, "friction")
    v = w_out(300)
    r = sim(effects=eff("stribeck", "first_power_exp"))
    extra = (col(r, "friction") - f0)[sel].mean()
    assert extra == pytest.approx(0.4 * p["f_c"] * math.exp(-v / 3e-3), rel=0.05)
    fast = sim(rpm=3000, effects=eff("stribeck", "gauss_bell"))
    sel_f = settled(fast, ("load", "unload"))
    assert np.abs((col(fast, "friction") - col(sim(rpm=3000), "friction"))[sel_f]).mean() < 5.0
    r = sim(effects=eff("load_dependent_friction", "mu_abs_torque"))
    slope = np.polyfit(np.abs(col(r, "torque"))[sel], (col(r, "friction") - f0)[sel], 1)[0]
    assert slope == pytest.approx(0.02, rel=0.05)
    cold = sim(temp=15.0, effects=eff("temperature_friction", "coulomb_hyperbolic"))
    warm = sim(temp=60.0, effects=eff("temperature_friction", "coulomb_hyperbolic"))
    d_cold = (col(cold, "friction") - col(sim(temp=15.0), "friction"))[sel].mean()
    d_warm = (col(warm, "friction") - col(sim(temp=60.0), "friction"))[sel].mean()
    assert d_cold == pytest.approx(0.6 * p["f_c"], rel=0.05) and -0.2 * p["f_c"] < d_warm < 0
    up = sim(effects=eff("asymmetric_friction", "pos_coulomb_boost"))
    assert (col(up, "friction") - f0)[sel].mean() == pytest.approx(0.3 * p["f_c"], rel=0.03)
    down = sim(direction=-1, effects=eff("asymmetric_friction", "pos_coulomb_boost"))
    assert np.abs(col(down, "friction") - col(sim(direction=-1), "friction")).max() < 1e-6


def test_sensor_effects_sign_and_size():
    base = sim()
    r = sim(effects=eff("torque_offset", "bridge_unbalance", 2.0))
    assert np.abs(rd(r, "torque") - rd(base, "torque") - 1800.0).max() <= 7.0
    r = sim(effects=eff("encoder_drift", "q_lost_counts"))
    t = col(r, "t")
    assert np.allclose(rd(r, "q") - rd(base, "q"), -math.radians(0.01) * np.floor(t / 12.0))
    r = sim(effects=eff("time_delay", "torque_transport"), sensors=R.SensorSpec(
        torque_noise=0.0, torque_res=0.0))
    quiet = sim(sensors=R.SensorSpec(torque_noise=0.0, torque_res=0.0))
    sel = settled(r, ("load", "unload"), 1.0)
    assert np.allclose(rd(r, "torque")[sel], np.interp(t - 8e-3, t, rd(quiet, "torque"))[sel],
                       atol=1.0)
    r = sim(rpm=3000, effects=eff("encoder_drift", "u_ratio_creep"))
    assert np.allclose(rd(r, "u"), col(r, "u") * (1 + 2e-4), atol=1e-9)


def test_transmission_effects_sign_and_size():
    p = sim().params
    r = sim(scheme=2, rpm=3000, effects=eff("backlash", "contact_gap"))
    base = sim(scheme=2, rpm=3000)
    gap = hold_means(r, col(r, "twist")) - hold_means(base, col(base, "twist"))
    assert np.allclose(gap, 2e-4, atol=1.5e-5)
    r = sim(scheme=2, rpm=3000, effects=eff("backlash", "offset_gap"))
    gap = hold_means(r, col(r, "twist")) - hold_means(base, col(base, "twist"))
    assert np.allclose(gap, 3e-4, atol=1.5e-5)
    r = sim(effects=eff("gear_ripple", "output_mesh_pair"))
    law = spring(p, col(r, "twist")) + p["D_tr"] * col(r, "twist_rate")
    ripple = col(r, "torque") - law
    assert 800.0 < np.ptp(ripple) < 2 * (700 + 280) + 1.0
    r = sim(effects=eff("position_dependent_stiffness", "raised_cosine_notch"))
    q = col(r, "q")
    kap = np.where(np.abs(np.abs(q) - 0.06) < 0.05,
                   1 - 0.2 * 0.5 * (1 + np.cos(math.pi * (np.abs(q) - 0.06) / 0.05)), 1.0)
    law = kap * spring(p, col(r, "twist")) + p["D_tr"] * col(r, "twist_rate")
    assert np.abs(col(r, "torque") - law).max() < 1e-6
    assert kap.min() < 0.81


def test_out_of_vocabulary_disturbance_and_modes():
    r = sim(effects=eff("periodic_disturbance", "two_tone_hydraulic"))
    d = col(r, "disturbance")
    assert 700.0 < d.max() <= 800.0 + 1e-9 and np.abs(d.mean()) < 60.0
    base = sim(scheme=2, rpm=3000)
    for form in R.EFFECT_FORMS["second_resonance"]:
        r = sim(scheme=2, rpm=3000, effects=eff("second_resonance", form))
        ring = col(r, "torque") - col(base, "torque")
        assert np.abs(ring).max() > 300.0, form
