"""Rig AD (validation_rigs/rig_ad.py): interface, argument checks, run format, the nominal
physics of its data sheet (derived again here from the data sheet's formulas, not from the rig's
code) and the sign and size of every effect form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.run import RunData
from core.runfile import read_run, validate_meta, validate_samples, write_run
from validation_rigs import rig_ad as R

N = 11000.0
F_C, F_V = 2352.660, 8683.272          # data sheet nominal friction (paper Table 3)
TWIST_RATED = math.radians(0.5)        # data sheet rated twist at 120 kN·m
T_RATED = 120_000.0
SEED = 7


def w_out(rpm):
    return rpm * 2 * math.pi / 60 / N


_cache: dict = {}


def sim(scheme=1, rpm=300, direction=1, temp=25.0, effects=None, periods=1, **kw):
    key = (scheme, rpm, direction, temp, repr(effects), periods, repr(kw))
    if key not in _cache:
        _cache[key] = R.simulate_run(scheme, None if scheme == 3 else rpm, direction, temp,
                                     effects, periods=periods, seed=SEED, run=0, **kw)
    return _cache[key]


def eff(name, form, scale=1.0):
    return {name: {"form": form, "scale": scale}}


def mask(r, *phases):
    return r.samples["phase"].isin(phases).to_numpy()


def settled(r, margin=1.0):
    """Load/unload/hold samples at least `margin` s after the phase last changed."""
    ph = r.samples["phase"].to_numpy()
    t = r.samples["t"].to_numpy()
    change = np.r_[True, ph[1:] != ph[:-1]]
    last = np.maximum.accumulate(np.where(change, t, -np.inf))
    return np.isin(ph, ("load", "unload", "hold")) & (t - last >= margin)


def col(r, name):
    return r.truth[name].to_numpy()


def gravity(params, q):
    return 9.81 * (params["mr_x"] * np.sin(q) + params["mr_y"] * np.cos(q))


def cubic(params):
    """k1, k3 from the data sheet's definition: K(Δ_r) = 120 kN·m, K'(Δ_r) = ρ·K'(0)."""
    dr, rho = params["twist_rated"], params["stiff_ratio"]
    k1 = T_RATED / (dr * (1 + (rho - 1) / 3))
    k3 = (rho - 1) * k1 / (3 * dr ** 2)
    return k1, k3


def law(params, twist, rate, temp):
    """The data sheet's transmission law κ(θ)·(K(Δ) + β·K'(Δ)·Δ̇) [N·m]."""
    k1, k3 = cubic(params)
    kap = 1 - params["kappa_T"] * (temp - 25.0)
    return kap * (k1 * twist + k3 * twist ** 3 + params["beta"] * (k1 + 3 * k3 * twist ** 2) * rate)


def hold_means(r, values, skip=0.5):
    """Mean of `values` over each hold of a scheme-2 run, leaving the first `skip` s out."""
    ph = r.samples["phase"].to_numpy()
    t = r.samples["t"].to_numpy()
    idx = np.flatnonzero(ph == "hold")
    segs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    return np.array([values[s[t[s] >= t[s[0]] + skip]].mean() for s in segs])


# --- interface ------------------------------------------------------------------------------------

def test_interface_constants():
    assert R.RIG_NAME == "rig_ad" and R.REDUCTION == 11000.0
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
    assert len(first_nine) == 9
    assert len(R.UNSTATED_VOCABULARY) <= 2
    assert all(k in first_nine and isinstance(v, str) and v
               for k, v in R.UNSTATED_VOCABULARY.items())
    assert "torque_latency" in R.EFFECT_FORMS["time_delay"]
    assert "q_encoder_latency" in R.EFFECT_FORMS["time_delay"]
    for name in ("SensorSpec", "RigRun", "simulate_run", "draw_machine", "compliance_torque",
                 "run_duration"):
        assert callable(getattr(R, name))


def test_own_integrator_and_substep():
    assert R.H_STEP <= 2e-4
    assert R.DAHL_EXP != 1.0


@pytest.mark.parametrize("field,value", [
    ("sample_rate_hz", float("nan")), ("sample_rate_hz", 5.0), ("encoder_res_deg", float("inf")),
    ("torque_noise", -1.0), ("torque_lag_s", "0.1"), ("torque_filter_s", 0.5),
    ("motor_encoder_res", True), ("temp_noise", 11.0), ("torque_res", 2e4)])
def test_sensorspec_checks(field, value):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})


def test_sensorspec_defaults():
    s = R.SensorSpec()
    assert s.sample_rate_hz == 1000.0 and s.encoder_res_deg == 0.01
    assert s.torque_res == pytest.approx(400_000.0 / 2 ** 16)      # 16 bits over ±200 kN·m
    assert s.temp_res == 0.1
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
    (dict(effects=eff("stribeck", "gaussian", float("nan"))), "scale"),
    (dict(effects={"stribeck": {"form": "gaussian", "size": 1}}), "size"),
    (dict(effects=[("stribeck", "gaussian")]), "effects"),
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


def test_zero_scale_is_no_effect():
    a = sim(scheme=3, sensors=R.SensorSpec(sample_rate_hz=100))
    b = sim(scheme=3, effects=eff("hysteresis", "masing_tanh", 0.0),
            sensors=R.SensorSpec(sample_rate_hz=100))
    assert a.samples.equals(b.samples) and b.params["effects"] == {}


def test_periods_three_accepted_everywhere():
    for scheme, rpm in ((1, 300), (1, 3000), (2, 300), (2, 3000), (3, None)):
        r = R.simulate_run(scheme, rpm, -1, 30.0, periods=3, seed=2, run=1,
                           sensors=R.SensorSpec(sample_rate_hz=10))
        assert np.isfinite(r.truth.to_numpy(dtype=float)).all()
        assert abs(r.truth["q"]).max() < math.pi
        assert r.samples["t"].iloc[-1] == pytest.approx(R.run_duration(scheme, 3), abs=0.11)


def test_determinism_and_seed_roles():
    a = R.simulate_run(3, None, 1, 30.0, seed=3, run=2, periods=1)
    b = R.simulate_run(3, None, 1, 30.0, seed=3, run=2, periods=1)
    c = R.simulate_run(3, None, 1, 30.0, seed=3, run=5, periods=1)
    d = R.simulate_run(3, None, 1, 30.0, seed=4, run=2, periods=1)
    assert a.samples.equals(b.samples) and a.truth.equals(b.truth)
    assert a.params["f_c"] == c.params["f_c"] != d.params["f_c"]   # seed = campaign = machine
    assert not np.array_equal(a.samples["torque"], c.samples["torque"])  # run = noise


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_format_validates_and_round_trips(tmp_path, fmt):
    r = sim(scheme=2, rpm=3000, effects=eff("hysteresis", "bouc_wen_n3"),
            sensors=R.SensorSpec(sample_rate_hz=50))
    validate_samples(r.samples, "x.csv")
    validate_meta(r.meta, "x.json")
    assert r.samples.columns[0] == "t"
    assert set(r.samples["phase"]) <= {"idle", "load", "hold", "unload", "excite"}
    assert {"idle", "load", "hold", "unload"} <= set(r.samples["phase"])
    m = r.meta
    assert m["scheme"] == 2 and m["motor_speed_rpm"] == 3000.0 and m["direction"] == 1
    assert m["reduction"] == 11000.0 and m["rig"] == "rig_ad" and m["source"] == "emulator"
    assert m["sample_rate_hz"] == 50.0
    assert m["sensors"]["torque"]["lag_s"] == pytest.approx(1e-3)
    paths = write_run(RunData(r.samples, r.meta), tmp_path / "ad", fmt=fmt)
    back = read_run(paths[0])
    assert back.meta == r.meta
    for c in r.samples.columns:
        if c == "phase":
            assert list(back.samples[c]) == list(r.samples[c])
        else:
            np.testing.assert_array_equal(back.samples[c].to_numpy(float),
                                          r.samples[c].to_numpy(float))


def test_scheme_programmes():
    r1 = sim(scheme=1, rpm=3000, sensors=R.SensorSpec(sample_rate_hz=100))
    t, cmd = col(r1, "t"), col(r1, "torque_cmd")
    assert cmd.max() == pytest.approx(T_RATED, rel=1e-3) and cmd.min() == 0.0
    assert t[np.argmax(cmd)] == pytest.approx(1.5 + 7.0, abs=0.02)
    r2 = sim(scheme=2, rpm=300, sensors=R.SensorSpec(sample_rate_hz=100))
    holds = hold_means(r2, col(r2, "torque_cmd"), skip=0.0)
    np.testing.assert_allclose(holds, np.arange(1, 13) * 10_000.0)
    r3 = sim(scheme=3, direction=-1, sensors=R.SensorSpec(sample_rate_hz=100))
    assert set(r3.samples["phase"]) == {"idle", "excite"}
    assert np.abs(col(r3, "qd")).max() == pytest.approx(0.025, rel=0.05)
    assert np.all(col(r3, "torque_cmd") == 0.0)


# --- nominal physics ------------------------------------------------------------------------------

@pytest.mark.parametrize("rpm,direction", [(300, 1), (300, -1), (3000, 1)])
def test_steady_friction_scheme1_from_readings(rpm, direction):
    """T − τ_L − G(q) on the readings is Eq. 4's f_c·sgn q̇ + f_v·q̇ while sliding (Dahl at ±c)."""
    r = sim(scheme=1, rpm=rpm, direction=direction)
    s, p = r.samples, r.params
    m = settled(r)
    est = (s["torque"] - s["torque_load"]).to_numpy()[m] - gravity(p, s["q"].to_numpy()[m])
    v = direction * w_out(rpm)
    expect = p["f_c"] * direction + p["f_v"] * v
    assert est.mean() == pytest.approx(expect, rel=0.03)
    # and the drawn machine is the paper's to within its stated spread
    assert abs(p["f_c"] / F_C - 1) < 0.025 * 2.5 + 1e-9
    assert abs(p["f_v"] / F_V - 1) < 0.035 * 2.5 + 1e-9


def test_dahl_element_reverses_within_its_presliding_length():
    """Dahl, exponent i = 0.75: from −0.9·c to +0.9·c in ℓ_d·(1.9^(1−i) − 0.1^(1−i))/(1−i) of
    output motion (≈ 2.45·ℓ_d); the whole turn from −c to +c takes ℓ_d·2^(1−i)/(1−i)."""
    r = sim(scheme=3, sensors=R.SensorSpec(sample_rate_hz=1000))
    p = r.params
    q, qd, t = col(r, "q"), col(r, "qd"), col(r, "t")
    fd = col(r, "friction") - p["f_v"] * qd
    c = p["f_c"]
    i = R.DAHL_EXP
    assert i == 0.75
    expect = p["dahl_len"] * (1.9 ** (1 - i) - 0.1 ** (1 - i)) / (1 - i)
    turns = 0
    for sign in (1.0, -1.0):
        x = sign * fd
        for k in np.flatnonzero((x[:-1] < 0.0) & (x[1:] >= 0.0)):
            before = np.flatnonzero(x[:k] <= -0.9 * c)
            if not len(before) or t[k] - t[before[-1]] > 1.0:
                continue                        # the start from rest, not a reversal
            a, b = before[-1], k + np.flatnonzero(x[k:] >= 0.9 * c)[0]
            assert sign * (q[b] - q[a]) == pytest.approx(expect, rel=0.25)
            turns += 1
    assert turns >= 4
    # far from reversals it slides at ±c exactly
    sl = np.abs(qd) > 0.01
    np.testing.assert_allclose(np.abs(fd[sl]), c, rtol=1e-6)


def test_transmission_law_is_the_cubic_with_rayleigh_damper():
    r = sim(scheme=2, rpm=300)
    p = r.params
    k1, k3 = cubic(p)
    assert k1 == pytest.approx(p["k1"], rel=1e-12) and k3 == pytest.approx(p["k3"], rel=1e-12)
    # stiffness at the rated twist ≈ 1.4 × the stiffness at zero; 120 kN·m at 0.5°
    dr = p["twist_rated"]
    assert (k1 + 3 * k3 * dr ** 2) / k1 == pytest.approx(1.4, rel=0.1)
    assert k1 * dr + k3 * dr ** 3 == pytest.approx(T_RATED)
    assert abs(dr / TWIST_RATED - 1) < 0.03 * 2.5 + 1e-9
    np.testing.assert_allclose(col(r, "torque"),
                               law(p, col(r, "twist"), col(r, "twist_rate"), col(r, "temp_joint")),
                               rtol=1e-9, atol=1e-4)
    # the readings: mean twist −torsion at each hold against the mean torque reading
    tw = hold_means(r, -r.samples["torsion"].to_numpy())
    tq = hold_means(r, r.samples["torque"].to_numpy())
    pred = k1 * tw + k3 * tw ** 3
    np.testing.assert_allclose(pred, tq, atol=0.01 * T_RATED)
    np.testing.assert_allclose(tq, np.arange(1, 13) * 10_000.0 + p["f_c"], atol=2500.0)


def test_stiffness_falls_slightly_with_gearbox_temperature():
    cold, warm = sim(scheme=2, rpm=300, temp=25.0), sim(scheme=2, rpm=300, temp=45.0)
    p = cold.params
    assert 0 < p["kappa_T"] <= 1e-3
    tw_c = hold_means(cold, col(cold, "twist"))
    tw_w = hold_means(warm, col(warm, "twist"))
    th_w = hold_means(warm, col(warm, "temp_joint"))
    th_c = hold_means(cold, col(cold, "temp_joint"))
    # the same torque in the holds: the warm joint twists further, by κ_T·Δθ through the cubic
    k1, k3 = cubic(p)
    kc, kw = 1 - p["kappa_T"] * (th_c - 25), 1 - p["kappa_T"] * (th_w - 25)
    expect = np.array([_twist_of(k1, k3, kc_ * (k1 * x + k3 * x ** 3) / kw_)
                       for x, kc_, kw_ in zip(tw_c, kc, kw)])
    assert np.all(tw_w > tw_c)
    np.testing.assert_allclose((tw_w / tw_c - 1)[3:], (expect / tw_c - 1)[3:], rtol=0.1)
    assert np.all((tw_w / tw_c - 1)[3:] < 0.02)          # small: ≤ 0.1 %/°C


def test_readings_are_quantised_to_their_stated_steps():
    sens = R.SensorSpec(encoder_res_deg=0.005, sample_rate_hz=200)
    r = sim(scheme=3, sensors=sens)
    s, sn = r.samples, r.meta["sensors"]
    assert sn["q"]["resolution"] == pytest.approx(math.radians(0.005))
    for ch in ("q", "u", "torque", "torque_load", "temp_joint", "temp_m1"):
        k = s[ch].to_numpy() / sn[ch]["resolution"]
        np.testing.assert_allclose(k, np.round(k), atol=1e-6, err_msg=ch)
    # the 16-bit torque ADC clips at ±2^15 codes
    assert R._adc(np.array([3e5, -3e5]), sens.torque_res).tolist() == \
        [(2 ** 15 - 1) * sens.torque_res, -(2 ** 15) * sens.torque_res]
    assert np.array_equal(s["torsion"], s["q"] - s["u"])
    # the motor speeds are the referred motor speed times N
    np.testing.assert_allclose(s["w_m1"] / N, col(r, "ud"), atol=6 * sens.ud_noise)


@pytest.mark.parametrize("noise", [90.0, 300.0])
def test_stated_torque_noise_is_true(noise):
    sens = R.SensorSpec(torque_noise=noise)
    r = sim(scheme=2, rpm=300, sensors=sens)
    stated = r.meta["sensors"]["torque"]["noise_sd"]
    assert stated == noise
    y = r.samples["torque"].to_numpy()
    direct = np.std(y - col(r, "torque_sensor"))
    second = np.std(np.diff(y, 2)) / math.sqrt(6.0)     # white noise: var of Δ² is 6σ²
    for measured in (direct, second):
        assert measured == pytest.approx(stated, rel=0.1)
    assert direct == pytest.approx(math.hypot(noise, sens.torque_res / math.sqrt(12)), rel=0.03)


def test_stated_noise_of_the_other_channels_is_true():
    r = sim(scheme=2, rpm=300)
    s, sn = r.samples, r.meta["sensors"]
    assert np.std(s["qd"] - col(r, "qd")) == pytest.approx(sn["qd"]["noise_sd"], rel=0.1)
    assert np.std(s["ud"] - col(r, "ud")) == pytest.approx(sn["ud"]["noise_sd"], rel=0.1)
    assert np.std(s["torque_load"] - col(r, "torque_load")) == \
        pytest.approx(math.hypot(sn["torque_load"]["noise_sd"], 4.0 / math.sqrt(12)), rel=0.1)


def test_stated_torque_lag_is_true():
    """The Butterworth's DC group delay is torque_filter_s; torque_lag_s adds to it."""
    sens = R.SensorSpec(torque_noise=0.0, torque_res=0.0, torque_filter_s=0.02, torque_lag_s=0.01)
    r = sim(scheme=1, rpm=300, sensors=sens)
    assert r.meta["sensors"]["torque"]["lag_s"] == pytest.approx(0.03)
    m = settled(r)
    t, y, true = col(r, "t"), r.samples["torque"].to_numpy(), col(r, "torque")
    rate = np.gradient(true, t)
    lag = np.sum((true - y)[m] * rate[m]) / np.sum(rate[m] ** 2)
    assert lag == pytest.approx(0.03, rel=0.05)


def test_servo_follows_the_scheme_and_the_motors_share_the_torque():
    r = sim(scheme=1, rpm=3000)
    m = settled(r)
    assert np.abs(col(r, "qd")[m] - w_out(3000)).max() < 0.05 * w_out(3000)
    i = r.samples[["i_m1", "i_m2", "i_m3"]].to_numpy()[m]
    p = r.params
    tm = col(r, "motor_torque")[m]
    np.testing.assert_allclose(i[:, 0], p["share1"] * tm / (N * p["kt1"]), atol=0.1)
    assert np.abs(col(r, "motor_torque")).max() <= 1.9e5
    # the gearbox warms with the friction's heat (time constant R_g·C_g = 1400 s)
    tg = col(r, "temp_joint")
    assert 0.02 < tg[-1] - tg[0] < 0.5


# --- effects ---------------------------------------------------------------------------------

def friction_change(r):
    """Friction minus the nominal Eq. 4 level at the same velocity, on settled sliding samples."""
    p = r.params
    qd = col(r, "qd")
    base = p["f_c"] * np.sign(qd) + p["f_v"] * qd
    return col(r, "friction") - base


def sliding(r, rpm):
    return settled(r) & (np.abs(col(r, "qd")) > 0.5 * w_out(rpm))


def hp(qd):
    return 0.5 * (1 + np.tanh(qd / 1e-4))


def _check_friction(scheme_kw, predicted):
    """Each run's friction change on sliding samples equals the data sheet's law (10 %)."""
    def check(form_eff):
        r = sim(effects=form_eff, **scheme_kw)
        m = sliding(r, scheme_kw["rpm"])
        meas = friction_change(r)[m]
        pred = predicted(r)[m]
        assert abs(pred.mean()) > 50.0          # a visible size at scale 1
        assert np.sign(meas.mean()) == np.sign(pred.mean())
        assert meas.mean() == pytest.approx(pred.mean(), rel=0.1)
        n = sim(**scheme_kw)
        assert np.abs(friction_change(n)[sliding(n, scheme_kw["rpm"])]).max() < 5.0
    return check


def _stribeck(phi):
    return lambda r: (0.2 * r.params["f_c"] * phi(np.abs(col(r, "qd")) / 4e-3)
                      * np.sign(col(r, "qd")))


def _mc_change(factor):
    return lambda r: (factor(r) - 1) * r.params["f_c"] * np.sign(col(r, "qd"))


def _vogel(r):
    th = col(r, "temp_joint")
    g = np.exp(700 / (th + 100) - 700 / 130) - 1
    return g * r.params["f_v"] * col(r, "qd")


def _quad_both(r):
    qd = col(r, "qd")
    g = 0.3 * (col(r, "torque") / T_RATED) ** 2
    return g * (r.params["f_c"] * np.sign(qd) + r.params["f_v"] * qd)


def _power_flow(r):
    T, qd = col(r, "torque"), col(r, "qd")
    return np.abs(T) * (0.006 + 0.003 * np.tanh(T * qd / 30.0)) * np.sign(qd)


def _additive_both(r):
    d = 30.0 - col(r, "temp_joint")
    return 18 * d * np.sign(col(r, "qd")) + 320 * d * col(r, "qd")


def _negative_both(r):
    qd = col(r, "qd")
    h = 1 - hp(qd)
    return (0.08 * h * r.params["f_c"] * np.sign(qd) + 0.25 * h * r.params["f_v"] * qd)


S300 = dict(scheme=1, rpm=300, direction=1)
S300N = dict(scheme=1, rpm=300, direction=-1)
S3000 = dict(scheme=1, rpm=3000, direction=1)
S3000N = dict(scheme=1, rpm=3000, direction=-1)

FRICTION_CHECKS = {
    ("stribeck", "exponential"): (S300, _stribeck(lambda x: np.exp(-x))),
    ("stribeck", "gaussian"): (S300, _stribeck(lambda x: np.exp(-x * x))),
    ("stribeck", "lorentzian"): (S300, _stribeck(lambda x: 1 / (1 + x * x))),
    ("stribeck", "root_exponential"): (S300, _stribeck(lambda x: np.exp(-np.sqrt(x)))),
    ("load_dependent_friction", "coulomb_linear"):
        (S300, lambda r: 0.006 * np.abs(col(r, "torque")) * np.sign(col(r, "qd"))),
    ("load_dependent_friction", "quadratic_both"): (S3000, _quad_both),
    ("load_dependent_friction", "power_flow"): (S300, _power_flow),
    ("load_dependent_friction", "power_flow", "back-driven"): (S300N, _power_flow),
    ("temperature_friction", "viscous_vogel"): (dict(S3000, temp=20.0), _vogel),
    ("temperature_friction", "viscous_vogel", "warm"): (dict(S3000, temp=45.0), _vogel),
    ("temperature_friction", "coulomb_multiplicative"):
        (dict(S300, temp=20.0), _mc_change(lambda r: 1 + 0.01 * (30 - col(r, "temp_joint")))),
    ("temperature_friction", "additive_both"): (dict(S3000N, temp=20.0), _additive_both),
    ("asymmetric_friction", "coulomb_positive"):
        (S300, _mc_change(lambda r: 1 + 0.12 * hp(col(r, "qd")))),
    ("asymmetric_friction", "viscous_split"):
        (S3000, lambda r: 0.3 * np.tanh(col(r, "qd") / 1e-4) * r.params["f_v"] * col(r, "qd")),
    ("asymmetric_friction", "viscous_split", "negative"):
        (S3000N, lambda r: 0.3 * np.tanh(col(r, "qd") / 1e-4) * r.params["f_v"] * col(r, "qd")),
    ("asymmetric_friction", "negative_both"): (S3000N, _negative_both),
}


@pytest.mark.parametrize("key", list(FRICTION_CHECKS), ids=lambda k: "-".join(k))
def test_friction_effect_forms(key):
    kw, pred = FRICTION_CHECKS[key]
    _check_friction(kw, pred)(eff(key[0], key[1]))


def test_friction_effects_that_spare_a_direction():
    for name, form, kw in (("asymmetric_friction", "coulomb_positive", S300N),
                           ("asymmetric_friction", "negative_both", S300),
                           ("load_dependent_friction", "power_flow", S300)):
        r = sim(effects=eff(name, form), **kw)
        change = friction_change(r)[sliding(r, 300)]
        if form == "power_flow":   # driving: 0.009·|T| ≫ back-driven 0.003·|T| (other test)
            assert change.mean() > 0.008 * np.abs(col(r, "torque")[sliding(r, 300)]).mean()
        else:
            assert np.abs(change).max() < 5.0
    # Stribeck is a low-speed effect: at 3000 r/min it almost vanishes (lorentzian: +9 N·m)
    r = sim(effects=eff("stribeck", "lorentzian"), **S3000)
    assert 3.0 < friction_change(r)[sliding(r, 3000)].mean() < 15.0


def _ripple_fit(r, n, shapes):
    """Least-squares coefficients of the torque change (effect − nominal, truth) on `shapes`."""
    d = col(r, "torque") - col(n, "torque")
    m = settled(r)
    x = np.column_stack(shapes + [np.ones_like(d), col(r, "t")])[m]
    return np.linalg.lstsq(x, d[m], rcond=None)[0]


def test_gear_ripple_output_harmonics():
    kw = dict(S3000, sensors=R.SensorSpec(sample_rate_hz=500))
    r, n = sim(effects=eff("gear_ripple", "output_harmonics"), **kw), sim(**kw)
    q = col(r, "q")
    s1, s2 = np.sin(84 * q + 0.9), np.sin(168 * q + 2.1)
    np.testing.assert_allclose(col(r, "disturbance"), 200 * s1 + 90 * s2, atol=1e-6)
    a = _ripple_fit(r, n, [s1, s2, np.cos(84 * q + 0.9), np.cos(168 * q + 2.1)])
    # quasi-static: the transmission carries −τ_x
    assert a[0] == pytest.approx(-200, rel=0.15) and a[1] == pytest.approx(-90, rel=0.2)
    assert abs(a[2]) < 30 and abs(a[3]) < 30


def test_gear_ripple_motor_kinematic():
    r, n = sim(effects=eff("gear_ripple", "motor_kinematic"), **S3000), sim(**S3000)
    p = r.params
    k1, k3 = cubic(p)
    nu = N * col(r, "u")
    ktan = (k1 + 3 * k3 * col(r, "twist") ** 2) * (1 - p["kappa_T"] * (col(r, "temp_joint") - 25))
    a = _ripple_fit(r, n, [ktan * np.sin(2 * nu + 0.4), ktan * np.sin(4 * nu + 1.3),
                           ktan * np.cos(2 * nu + 0.4), ktan * np.cos(4 * nu + 1.3)])
    assert a[0] == pytest.approx(1.5e-5, rel=0.15)
    assert a[1] == pytest.approx(0.35 * 1.5e-5, rel=0.2)
    assert abs(a[2]) < 0.3e-5


def test_gear_ripple_load_modulated():
    kw = dict(S3000, sensors=R.SensorSpec(sample_rate_hz=500))
    r, n = sim(effects=eff("gear_ripple", "load_modulated"), **kw), sim(**kw)
    q, T = col(r, "q"), np.abs(col(r, "torque"))
    sn, cs = np.sin(52 * q + 0.2), np.cos(52 * q + 0.2)
    np.testing.assert_allclose(col(r, "disturbance"), (60 + 1.25 * np.sqrt(T)) * sn,
                               rtol=1e-9, atol=1e-6)
    a = _ripple_fit(r, n, [sn, np.sqrt(T) * sn, cs, np.sqrt(T) * cs])
    assert a[0] == pytest.approx(-60, abs=25) and a[1] == pytest.approx(-1.25, rel=0.15)


@pytest.mark.parametrize("form,expect", [
    ("constant", lambda r: 350.0 + 0 * col(r, "t")),
    ("settling", lambda r: 500.0 * (1 - np.exp(-col(r, "t") / 25.0))),
    ("peak_load_shift", lambda r: 0.004 * np.maximum.accumulate(np.abs(col(r, "torque"))))])
def test_torque_offset(form, expect):
    kw = dict(scheme=2, rpm=300, sensors=R.SensorSpec(sample_rate_hz=100))
    r, n = sim(effects=eff("torque_offset", form), **kw), sim(**kw)
    d = r.samples["torque"].to_numpy() - n.samples["torque"].to_numpy()
    e = expect(r)
    assert e.mean() > 100.0
    np.testing.assert_allclose(d, e, atol=R.SensorSpec().torque_res + 2.0)
    assert r.truth.equals(n.truth)     # a reading effect: the machine is untouched


QUIET = dict(torque_noise=0.0, torque_res=0.0, qd_noise=0.0, encoder_res_deg=1e-5)


def _best_shift(y, ref, t, shifts):
    err = [np.mean((y - np.interp(t - s, t, ref)) ** 2) for s in shifts]
    return shifts[int(np.argmin(err))]


def test_time_delay_torque_latency():
    kw = dict(scheme=3, sensors=R.SensorSpec(**QUIET))
    r, n = sim(effects=eff("time_delay", "torque_latency"), **kw), sim(**kw)
    t = col(r, "t")
    shift = _best_shift(r.samples["torque"].to_numpy(), n.samples["torque"].to_numpy(), t,
                        np.arange(0.0, 0.0201, 0.0005))
    assert shift == pytest.approx(0.010, abs=6e-4)
    assert r.meta == n.meta      # the lag is not stated


def test_time_delay_q_encoder_latency():
    kw = dict(S300, sensors=R.SensorSpec(**QUIET))
    r, n = sim(effects=eff("time_delay", "q_encoder_latency"), **kw), sim(**kw)
    m = settled(r)
    dq = (n.samples["q"] - r.samples["q"]).to_numpy()[m]
    assert np.median(dq / col(r, "qd")[m]) == pytest.approx(0.010, rel=0.05)
    t = col(r, "t")
    assert _best_shift(r.samples["qd"].to_numpy(), n.samples["qd"].to_numpy(), t,
                       np.arange(0.0, 0.0201, 0.001)) == pytest.approx(0.010, abs=1.1e-3)


def test_time_delay_torque_sample_hold():
    kw = dict(S300, sensors=R.SensorSpec(**QUIET))
    r, n = sim(effects=eff("time_delay", "torque_sample_hold"), **kw), sim(**kw)
    t = col(r, "t")
    y, ref = r.samples["torque"].to_numpy(), n.samples["torque"].to_numpy()
    held = np.floor(t / 0.008 + 1e-9) * 0.008
    np.testing.assert_allclose(y, np.interp(held, t, ref), atol=1e-6)
    assert len(np.unique(y[(t > 5) & (t < 5.0799)])) <= 11     # refreshed every 8 ms
    m = settled(r)
    rate = np.gradient(ref, t)
    lag = np.sum((ref - y)[m] * rate[m]) / np.sum(rate[m] ** 2)
    assert lag == pytest.approx(np.mean(t - held), rel=0.1)


@pytest.mark.parametrize("form", ["bouc_wen_n3", "masing_tanh", "dahl_quadratic"])
def test_hysteresis(form):
    r = sim(effects=eff("hysteresis", form), **S300)
    p = r.params
    tw = col(r, "twist")
    resid = col(r, "torque") - law(p, tw, col(r, "twist_rate"), col(r, "temp_joint"))
    np.testing.assert_allclose(resid, col(r, "hysteresis"), atol=1e-3)
    mid = (tw > 0.35 * p["twist_rated"]) & (tw < 0.75 * p["twist_rated"])
    up = mid & mask(r, "load") & settled(r)
    down = mid & mask(r, "unload") & settled(r)
    assert up.sum() > 100 and down.sum() > 100
    assert resid[up].mean() == pytest.approx(1200.0, rel=0.05)     # +H while the twist grows
    assert resid[down].mean() == pytest.approx(-1200.0, rel=0.05)  # −H while it falls
    # the loop on the readings: torque against twist, loading above unloading by ≈ 2H
    n = sim(**S300)
    k1, k3 = cubic(p)

    def width(run):
        s = run.samples
        twr = -s["torsion"].to_numpy()
        res = s["torque"].to_numpy() - (k1 * twr + k3 * twr ** 3)
        return res[up].mean() - res[down].mean()
    assert width(r) - width(n) == pytest.approx(2400.0, rel=0.1)


@pytest.mark.parametrize("form,factor", [
    ("sharp", lambda tl: 1.0 + 0 * tl), ("tanh_smoothed", lambda tl: 1.0 + 0 * tl),
    ("load_closing", lambda tl: 1 - 0.7 * np.minimum(1, np.abs(tl) / T_RATED))])
def test_backlash(form, factor):
    kw = dict(scheme=2, rpm=300, sensors=R.SensorSpec(sample_rate_hz=200))
    r, n = sim(effects=eff("backlash", form), **kw), sim(**kw)
    d = hold_means(r, col(r, "twist")) - hold_means(n, col(n, "twist"))
    expect = 2.5e-4 * factor(hold_means(r, col(r, "torque_load")))
    np.testing.assert_allclose(d, expect, rtol=0.06)
    # on the readings too (encoder steps average out over a hold)
    dr = (hold_means(r, -r.samples["torsion"].to_numpy())
          - hold_means(n, -n.samples["torsion"].to_numpy()))
    np.testing.assert_allclose(dr, expect, atol=4e-5)


def test_backlash_forms_differ_near_zero_twist():
    """The smoothed dead zone transmits where the sharp one does not (same half-width)."""
    b = 2.5e-4
    d = np.array([0.5 * b, b, 2 * b])
    sharp = np.where(np.abs(d) > b, d - b * np.sign(d), 0.0)
    smooth = d - b * np.tanh(d / b)
    assert np.all(smooth[:2] > sharp[:2]) and smooth[2] > sharp[2] > 0


def _amp_at(x, t, f, envelope=None):
    env = np.ones_like(t) if envelope is None else envelope
    X = np.column_stack([env * np.sin(2 * np.pi * f * t), env * np.cos(2 * np.pi * f * t),
                         np.ones_like(t), t])
    c = np.linalg.lstsq(X, x, rcond=None)[0]
    return c[0], c[1]


@pytest.mark.parametrize("form", ["pump_rectified", "fan_modulated"])
def test_periodic_disturbance(form):
    kw = dict(S3000, sensors=R.SensorSpec(sample_rate_hz=200))
    r, n = sim(effects=eff("periodic_disturbance", form), **kw), sim(**kw)
    t = col(r, "t")
    p = r.params
    if form == "pump_rectified":
        tau = 380 * (np.abs(np.sin(np.pi * 2.2 * t)) - 2 / np.pi)
        f, env, amp = 2.2, None, 4 / (3 * np.pi) * 380
        # |sin(πft)| − 2/π: fundamental −(4/3π)·cos(2πft)
        ph_sin, ph_cos = 0.0, -1.0
    else:
        env = 1 + 0.5 * np.sin(2 * np.pi * 0.37 * t)
        tau = 240 * np.sin(2 * np.pi * 3.7 * t) * env
        f, amp = 3.7, 240.0
        ph_sin, ph_cos = 1.0, 0.0
    np.testing.assert_allclose(col(r, "disturbance"), tau, atol=1e-6)
    d = col(r, "torque") - col(n, "torque")
    a, b = _amp_at(d, t, f, env)
    # sliding steadily, the output mass on the transmission (the heavy motor side held): T
    # carries −τ_x times (k + iωD)/(k − I·ω² + iωD), at the run's mean tangent stiffness
    k1, k3 = cubic(p)
    k = k1 + 3 * k3 * np.mean(col(r, "twist")) ** 2
    w = 2 * np.pi * f
    gain = abs((k + 1j * w * p["beta"] * k) / (k - p["I"] * w * w + 1j * w * p["beta"] * k))
    assert gain > 1.05
    proj = -(a * ph_sin + b * ph_cos)
    assert proj > 0.9 * math.hypot(a, b)
    assert math.hypot(a, b) == pytest.approx(amp * gain, rel=0.15)


@pytest.mark.parametrize("form", ["gaussian_bump", "thrice_per_rev"])
def test_position_dependent_stiffness(form):
    kw = dict(S3000, sensors=R.SensorSpec(sample_rate_hz=200))
    r, n = sim(effects=eff("position_dependent_stiffness", form), **kw), sim(**kw)
    p = r.params
    q = col(r, "q")
    if form == "gaussian_bump":
        f = 1 + 0.3 * np.exp(-((q - 0.35) / 0.12) ** 2 / 2)
    else:
        f = 1 + 0.08 * np.cos(3 * q + 0.2)
    base = law(p, col(r, "twist"), col(r, "twist_rate"), col(r, "temp_joint"))
    np.testing.assert_allclose(col(r, "torque"), f * base, rtol=1e-9, atol=1e-3)
    # the twist at the same torque is smaller where the factor is above 1
    m = settled(r) & (np.abs(col(r, "torque")) > 30_000)
    at = m & (np.abs(f - f[m].max()) < 0.01)
    ratio = col(n, "twist")[at] / col(r, "twist")[at]
    k1, k3 = cubic(p)
    tw = col(r, "twist")[at]
    expect = np.array([_twist_of(k1, k3, fi * (k1 * x + k3 * x ** 3))
                       for fi, x in zip(f[at], tw)]) / tw
    assert ratio.mean() == pytest.approx(expect.mean(), rel=0.02)
    assert ratio.mean() > 1.05


def _twist_of(k1, k3, torque):
    d = torque / k1
    for _ in range(40):
        d -= (k1 * d + k3 * d ** 3 - torque) / (k1 + 3 * k3 * d * d)
    return d


@pytest.mark.parametrize("form", ["q_quadratic", "u_linear"])
def test_encoder_drift(form):
    kw = dict(scheme=2, rpm=300, sensors=R.SensorSpec(sample_rate_hz=100, encoder_res_deg=1e-5))
    r, n = sim(effects=eff("encoder_drift", form), **kw), sim(**kw)
    t = col(r, "t")
    ch, expect, step = (("q", 1.5e-7 * t ** 2, math.radians(1e-5)) if form == "q_quadratic"
                        else ("u", 5e-6 * t, R.SensorSpec().motor_encoder_res))
    d = (r.samples[ch] - n.samples[ch]).to_numpy()
    np.testing.assert_allclose(d, expect, atol=1.01 * step)
    assert expect[-1] > 5 * math.radians(0.01) / 10     # a visible fraction of a 0.01° step
    assert r.truth.equals(n.truth)


def test_second_resonance_output_absorber():
    kw = dict(scheme=3, sensors=R.SensorSpec(sample_rate_hz=200))
    r, n = sim(effects=eff("second_resonance", "output_absorber"), **kw), sim(**kw)
    p = r.params
    # below 13 Hz the absorber adds I_a = 0.12·I to the output's inertia: T grows by I_a·q̈
    d = col(r, "torque") - col(n, "torque")
    k = np.ones(41) / 41                                       # 0.2 s moving average
    ds, qdd = np.convolve(d, k, "same"), np.convolve(col(r, "qdd"), k, "same")
    m = mask(r, "excite")
    slope = np.sum(ds[m] * qdd[m]) / np.sum(qdd[m] ** 2)
    assert slope == pytest.approx(0.12 * p["I"], rel=0.2)
    # and its own mode rings at ≈ 13 Hz (its reaction on the output, truth 'disturbance')
    tx = col(r, "disturbance")[m]
    spec = np.abs(np.fft.rfft(tx - tx.mean()))
    fr = np.fft.rfftfreq(m.sum(), 1 / 200)
    band = (fr > 9) & (fr < 30)
    assert 12.0 < fr[band][np.argmax(spec[band])] < 16.0
    assert np.all(col(n, "disturbance") == 0.0)


def test_second_resonance_motor_coupling():
    kw = dict(scheme=2, rpm=300, sensors=R.SensorSpec(sample_rate_hz=200))
    r, n = sim(effects=eff("second_resonance", "motor_coupling"), **kw), sim(**kw)
    p = r.params
    kc = 0.15 * p["J_M"] * (2 * np.pi * 16.0) ** 2
    d = hold_means(r, col(r, "twist")) - hold_means(n, col(n, "twist"))
    np.testing.assert_allclose(d, hold_means(r, col(r, "torque")) / kc, rtol=0.05)
    assert d[-1] > 1.5e-4
    # the deflection grows in proportion to the scale (k_c = J_g·(2π·16 Hz)²/s)
    half = sim(effects=eff("second_resonance", "motor_coupling", 0.5), **kw)
    d2 = hold_means(half, col(half, "twist")) - hold_means(n, col(n, "twist"))
    np.testing.assert_allclose(d2, 0.5 * hold_means(half, col(half, "torque")) / kc, rtol=0.05)


def test_every_effect_form_is_checked():
    checked = {k[:2] for k in FRICTION_CHECKS}
    checked |= {("gear_ripple", f)
                for f in ("output_harmonics", "motor_kinematic", "load_modulated")}
    checked |= {("torque_offset", f) for f in ("constant", "settling", "peak_load_shift")}
    checked |= {("time_delay", f) for f in ("torque_latency", "q_encoder_latency",
                                            "torque_sample_hold")}
    checked |= {("hysteresis", f) for f in ("bouc_wen_n3", "masing_tanh", "dahl_quadratic")}
    checked |= {("backlash", f) for f in ("sharp", "tanh_smoothed", "load_closing")}
    checked |= {("periodic_disturbance", f) for f in ("pump_rectified", "fan_modulated")}
    checked |= {("position_dependent_stiffness", f) for f in ("gaussian_bump", "thrice_per_rev")}
    checked |= {("encoder_drift", f) for f in ("q_quadratic", "u_linear")}
    checked |= {("second_resonance", f) for f in ("output_absorber", "motor_coupling")}
    every = {(k, f) for k, forms in R.EFFECT_FORMS.items() for f in forms}
    assert every == checked


def test_noise_does_not_depend_on_the_effects():
    kw = dict(scheme=3, sensors=R.SensorSpec(sample_rate_hz=100))
    a = sim(**kw)
    b = sim(effects=eff("encoder_drift", "u_linear"), **kw)
    assert np.array_equal(a.samples["torque"], b.samples["torque"])
    assert np.array_equal(a.samples["i_m2"], b.samples["i_m2"])


def test_every_form_at_scale_max_stays_finite():
    for name, forms in R.EFFECT_FORMS.items():
        for form in forms:
            r = R.simulate_run(1, 300, 1, 20.0, eff(name, form, R.SCALE_MAX), periods=1, seed=5,
                               run=0, sensors=R.SensorSpec(sample_rate_hz=20))
            assert np.isfinite(r.truth.to_numpy(dtype=float)).all(), (name, form)
            assert np.abs(r.truth["q"]).max() < math.pi
