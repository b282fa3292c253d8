"""Rig AE (validation_rigs/rig_ae.py): interface, argument checks, run format, the nominal
physics of its data sheet (derived again here from the data sheet's formulas, not from the rig's
kernel) and the sign and size of every effect form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.run import RunData
from core.runfile import read_run, validate_meta, validate_samples, write_run
from validation_rigs import rig_ae as R

N = 11000.0
F_C, F_V = 2352.660, 8683.272          # data sheet nominal friction (paper Table 3)
T_R = 120_000.0
SEED = 5
QUIET = dict(torque_noise=0.0, torque_res=0.0, load_noise=0.0, load_res=0.0, qd_noise=0.0,
             ud_noise=0.0, current_noise=0.0, temp_noise=0.0, temp_res=0.0)


def w_out(rpm):
    return rpm * 2 * math.pi / 60 / N


_cache: dict = {}


def sim(scheme=1, rpm=300, direction=1, temp=25.0, effects=None, periods=1, quiet=False,
        run=0, **kw):
    key = (scheme, rpm, direction, temp, repr(effects), periods, quiet, run, repr(kw))
    if key not in _cache:
        if quiet:
            kw = dict(kw, sensors=R.SensorSpec(**QUIET))
        _cache[key] = R.simulate_run(scheme, None if scheme == 3 else rpm, direction, temp,
                                     effects, periods=periods, seed=SEED, run=run, **kw)
    return _cache[key]


def eff(name, form, scale=1.0):
    return {name: {"form": form, "scale": scale}}


def col(r, name):
    return r.truth[name].to_numpy()


def after(r, t0=3.0):
    return col(r, "t") >= t0


def pade_k0(p):
    """k0 from the data sheet's definition K(Δ_r) = 120 kN·m."""
    x, rho = p["twist_rated"] / p["corner"], p["rho_inf"]
    return T_R / (p["corner"] * (rho * x - (rho - 1) * np.arctan(x)))


def K(p, d):
    """The data sheet's K(Δ) = k0·δ_c·(ρ∞x − (ρ∞ − 1)·atan x), x = Δ/δ_c."""
    x, rho = d / p["corner"], p["rho_inf"]
    return pade_k0(p) * p["corner"] * (rho * x - (rho - 1) * np.arctan(x))


def gravity(p, q):
    return 9.81 * (p["mr_x"] * np.sin(q) + p["mr_y"] * np.cos(q))


def sliding(r, vmin=1e-4):
    z, p = col(r, "z"), r.params
    return (np.abs(z) >= p["z0"] * (1 - 1e-9)) & (np.abs(col(r, "qd")) > vmin) & after(r)


def slope(x, y):
    """Least-squares slope of y on x (both centred)."""
    x = x - x.mean()
    return float(np.dot(x, y - y.mean()) / np.dot(x, x))


# --- interface ------------------------------------------------------------------------------------

def test_interface_constants():
    assert R.RIG_NAME == "rig_ae" and R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True and R.SCALE_MAX == 10.0
    names = {"stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
             "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction",
             "periodic_disturbance", "position_dependent_stiffness", "encoder_drift",
             "second_resonance"}
    assert set(R.EFFECT_FORMS) == names
    for forms in R.EFFECT_FORMS.values():
        assert 2 <= len(forms) <= 4 and len(set(forms)) == len(forms)
    assert R.OUT_OF_VOCABULARY == ("periodic_disturbance", "position_dependent_stiffness",
                                   "encoder_drift", "second_resonance")
    in_vocab = [k for k in R.EFFECT_FORMS if k not in R.OUT_OF_VOCABULARY]
    assert all(k in in_vocab and isinstance(v, str) and v for k, v in R.UNSTATED_VOCABULARY.items())
    for name in ("SensorSpec", "RigRun", "simulate_run", "draw_machine", "run_duration",
                 "compliance_torque"):
        assert callable(getattr(R, name))


def test_forms_are_not_rig_ads():
    from validation_rigs import rig_ad
    assert set(rig_ad.EFFECT_FORMS) == set(R.EFFECT_FORMS)
    for k, forms in R.EFFECT_FORMS.items():
        assert not set(forms) & set(rig_ad.EFFECT_FORMS[k]), k


def test_own_integrator_and_substep():
    assert R.H_STEP == 2.5e-4 and R.REC_DT == 5e-4


@pytest.mark.parametrize("field,value", [
    ("sample_rate_hz", float("nan")), ("sample_rate_hz", 5.0), ("sample_rate_hz", 2000.0),
    ("encoder_res_deg", float("inf")), ("torque_noise", -1.0), ("torque_lag_s", "0.1"),
    ("torque_filter_s", 0.5), ("torque_res", True), ("load_noise", None),
    ("motor_encoder_res", 1.0), ("temp_res", -0.1), ("current_noise", float("-inf")),
])
def test_sensor_spec_refuses(field, value):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})


def test_sensor_spec_accepts_numpy_numbers():
    s = R.SensorSpec(sample_rate_hz=np.float32(200.0), torque_noise=np.int64(5))
    assert s.sample_rate_hz == 200.0 and isinstance(s.torque_noise, float)


@pytest.mark.parametrize("args,kw,match", [
    ((4, 300, 1, 25.0), {}, "scheme"),
    ((True, 300, 1, 25.0), {}, "scheme"),
    ((1.0, 300, 1, 25.0), {}, "scheme"),
    ((1, 1000, 1, 25.0), {}, "motor_speed_rpm"),
    ((1, None, 1, 25.0), {}, "motor_speed_rpm"),
    ((1, float("nan"), 1, 25.0), {}, "motor_speed_rpm"),
    ((3, 300, 1, 25.0), {}, "motor_speed_rpm"),
    ((1, 300, 0, 25.0), {}, "direction"),
    ((1, 300, True, 25.0), {}, "direction"),
    ((1, 300, 1, float("nan")), {}, "temp_joint_c"),
    ((1, 300, 1, float("inf")), {}, "temp_joint_c"),
    ((1, 300, 1, 80.0), {}, "temp_joint_c"),
    ((1, 300, 1, "25"), {}, "temp_joint_c"),
    ((1, 300, 1, 25.0), {"periods": 0}, "periods"),
    ((1, 300, 1, 25.0), {"periods": 2.0}, "periods"),
    ((1, 300, 1, 25.0), {"periods": 21}, "periods"),
    ((1, 300, 1, 25.0), {"seed": -1}, "seed"),
    ((1, 300, 1, 25.0), {"seed": True}, "seed"),
    ((1, 300, 1, 25.0), {"run": 1.5}, "run"),
    ((1, 300, 1, 25.0), {"sensors": {"sample_rate_hz": 10}}, "sensors"),
    ((1, 3000, 1, 25.0), {"periods": 5}, "periods"),
    ((2, 3000, 1, 25.0), {"periods": 5}, "periods"),
])
def test_simulate_run_refuses(args, kw, match):
    kw = {"seed": 1, "run": 0, **kw}
    with pytest.raises(ValueError, match=match):
        R.simulate_run(*args, **kw)


@pytest.mark.parametrize("effects,match", [
    ({"friction_wobble": {"form": "x", "scale": 1.0}}, "unknown effect"),
    ({"stribeck": {"form": "gaussian", "scale": 1.0}}, "unknown form"),
    ({"stribeck": {"form": "tent", "scale": float("nan")}}, "scale"),
    ({"stribeck": {"form": "tent", "scale": float("inf")}}, "scale"),
    ({"stribeck": {"form": "tent", "scale": -0.1}}, "scale"),
    ({"stribeck": {"form": "tent", "scale": 10.5}}, "SCALE_MAX"),
    ({"stribeck": {"form": "tent", "scale": True}}, "scale"),
    ({"stribeck": {"form": "tent", "scale": "1"}}, "scale"),
    ({"stribeck": {"form": "tent", "size": 1.0}}, "unknown keys"),
    ({"stribeck": "tent"}, "stribeck"),
    (["stribeck"], "effects"),
])
def test_effects_refused(effects, match):
    with pytest.raises(ValueError, match=match):
        R.simulate_run(1, 300, 1, 25.0, effects, seed=1, run=0)


def test_run_duration_and_machine_draws():
    assert R.run_duration(1, 1) == 2.0 + 24.0 + 1.0
    assert R.run_duration(2, 2) == 2.0 + 2 * 23.0 + 1.0
    assert R.run_duration(3, 3) == 2.0 + 60.0 + 1.0
    a, b = R.draw_machine(1), R.draw_machine(1)
    assert a == b and R.draw_machine(2) != a
    for k, nominal in (("I", 6685.166), ("f_c", F_C), ("f_v", F_V), ("mr_y", -34.543)):
        assert abs(a[k] / nominal - 1) < 0.2
    ms = [R.draw_machine(s) for s in range(30)]
    assert all(math.radians(0.45) < m["twist_rated"] < math.radians(0.55) for m in ms)
    assert all(abs(m["share1"] + m["share2"] + m["share3"] - 1) < 1e-12 for m in ms)


# --- run format ----------------------------------------------------------------------------------

def test_run_format_round_trip(tmp_path):
    r = sim(2, 300, -1, 30.0, sensors=R.SensorSpec(sample_rate_hz=50.0))
    samples = validate_samples(r.samples, "x")
    validate_meta(r.meta, "x")
    assert list(samples.columns)[0] == "t" and len(samples) == len(r.truth)
    assert set(r.samples["phase"]) == {"idle", "load", "hold", "unload"}
    for fmt in ("csv", "parquet"):
        write_run(RunData(r.samples, r.meta), tmp_path / f"run_{fmt}", fmt=fmt)
        back = read_run(tmp_path / f"run_{fmt}.{fmt}")
        assert back.meta == r.meta
        for c in r.samples.columns:
            if c == "phase":
                assert list(back.samples[c]) == list(r.samples[c])
            else:
                np.testing.assert_array_equal(back.samples[c].to_numpy(), r.samples[c].to_numpy())


def test_meta_states_the_true_sensors():
    s = R.SensorSpec(torque_lag_s=0.002, encoder_res_deg=0.005)
    r = sim(1, 300, sensors=s)
    sen = r.meta["sensors"]
    assert sen["q"]["resolution"] == pytest.approx(math.radians(0.005))
    assert sen["u"]["resolution"] == pytest.approx(2 * math.pi / 2 ** 19 / N)
    assert sen["torque"]["noise_sd"] == 80.0
    assert sen["torque"]["lag_s"] == pytest.approx(1.5e-3 + 2e-3)
    assert sen["torque"]["resolution"] == pytest.approx(400_000 / 2 ** 19)
    m = r.meta
    assert (m["scheme"], m["motor_speed_rpm"], m["direction"], m["reduction"], m["rig"],
            m["source"]) == (1, 300.0, 1, 11000.0, "rig_ae", "emulator")
    t = col(r, "t")
    assert t[0] == 0.0 and np.allclose(np.diff(t), 1e-3)
    assert t[-1] == pytest.approx(R.run_duration(1, 1))


def test_seed_draws_machine_run_draws_noise():
    a, b = sim(1, 300, run=0), sim(1, 300, run=1)
    assert a.params["k0"] == b.params["k0"]
    assert not np.array_equal(a.samples["torque"], b.samples["torque"])
    c = R.simulate_run(1, 300, 1, 25.0, periods=1, seed=SEED, run=0)
    np.testing.assert_array_equal(c.samples["torque"], a.samples["torque"])
    np.testing.assert_array_equal(c.truth["torque"], a.truth["torque"])


# --- nominal physics --------------------------------------------------------------------------------

@pytest.mark.parametrize("case", [(1, 300, 1), (1, 3000, -1), (2, 300, -1), (3, None, 1)])
def test_output_balance_eq4(case):
    """I·q̈ = T − τ_L − G − f_c·sgn(q̇) − f_v·q̇ wherever the output slides."""
    r = sim(*case)
    p = r.params
    q, qd = col(r, "q"), col(r, "qd")
    np.testing.assert_allclose(col(r, "gravity"), gravity(p, q), atol=1e-9)
    res = (p["I"] * col(r, "qdd") - col(r, "torque") + col(r, "torque_load") + gravity(p, q)
           + F_C * p["f_c"] / F_C * np.sign(qd) + p["f_v"] * qd)
    m = sliding(r)
    assert m.mean() > 0.7
    assert np.abs(res[m]).max() < 1e-6 * T_R
    assert np.abs(col(r, "disturbance")).max() == 0.0
    # presliding never exceeds the Coulomb level by more than its damping
    pre = np.abs(col(r, "friction") - p["f_v"] * qd)
    assert pre.max() <= p["f_c"] + p["sigma1"] * np.abs(qd).max() + 1e-6


def test_friction_presliding_at_reversals():
    r = sim(3, periods=1)
    p = r.params
    z, qd = col(r, "z"), col(r, "qd")
    assert np.abs(z).max() <= p["z0"] * (1 + 1e-12)
    assert p["z0"] < 0.25 * math.radians(0.01)        # under a quarter of an encoder step
    flips = np.flatnonzero(np.diff(np.sign(z[np.abs(z) > 0.99 * p["z0"]])) != 0)
    assert len(flips) >= 2                            # the excitation reverses several times
    assert np.abs(qd).max() < 0.03


@pytest.mark.parametrize("case", [(1, 300, 1), (2, 3000, -1), (3, None, -1)])
def test_transmission_law(case):
    """T = K(Δ) + D·Δ̇ with the data sheet's Padé stiffening and D = 2ζ_s√(k0·I)."""
    r = sim(*case)
    p = r.params
    tw = col(r, "twist")
    np.testing.assert_allclose(tw, col(r, "u") - col(r, "q"), atol=1e-15)
    d = 2 * p["zeta_s"] * math.sqrt(pade_k0(p) * p["I"])
    law = K(p, tw) + d * col(r, "twist_rate")
    assert np.abs(law - col(r, "torque")).max() < 1e-6
    assert np.abs(R.compliance_torque(tw, p) - K(p, tw)).max() < 1e-6


def test_compliance_stiffens_to_rated_at_half_a_degree():
    p = R.draw_machine(SEED)
    assert K(p, p["twist_rated"]) == pytest.approx(T_R)
    h = 1e-7
    k_c = (K(p, h) - K(p, -h)) / (2 * h)
    k_r = (K(p, p["twist_rated"] + h) - K(p, p["twist_rated"] - h)) / (2 * h)
    assert k_c == pytest.approx(pade_k0(p), rel=1e-6) and 1.5 < k_r / k_c < 1.95
    r = sim(1, 300)
    tw, T = col(r, "twist"), col(r, "torque")
    i = np.argmax(T)
    assert T[i] > 0.98 * T_R and 0.45 < math.degrees(tw[i]) < 0.56


def test_drive_speed_and_load_profile():
    for rpm, d in ((300, 1), (3000, -1)):
        r = sim(1, rpm, d)
        m = after(r, 2.0)
        np.testing.assert_allclose(col(r, "ud")[m], d * w_out(rpm), rtol=0.02)
        t, cmd = col(r, "t"), col(r, "torque_cmd")
        assert cmd[np.argmin(np.abs(t - 14.0))] == pytest.approx(d * T_R, rel=1e-3)
        assert cmd[np.argmin(np.abs(t - 8.0))] == pytest.approx(d * T_R / 2, rel=1e-3)
        err = col(r, "torque_load") - cmd
        assert np.abs(err[m]).max() < 2000.0                 # Table 11: ±2 kN·m
        assert d * col(r, "torque")[m].min() > 0.0            # the joint always drives the load
    r = sim(2, 300)
    t, cmd, ph = col(r, "t"), col(r, "torque_cmd"), r.samples["phase"].to_numpy()
    holds = np.unique(np.round(cmd[ph == "hold"], 6))
    np.testing.assert_allclose(holds, np.arange(1, 13) * 10_000.0)


def test_scheme3_fourier_excitation():
    r = sim(3, periods=2)
    q, qd = col(r, "q"), col(r, "qd")
    assert np.abs(q).max() < 0.2 and 0.02 < np.abs(qd).max() < 0.03
    ph = r.samples["phase"].to_numpy()
    assert set(ph) == {"idle", "excite"}
    assert np.abs(col(r, "torque_cmd")).max() == 0.0
    t = col(r, "t")
    assert abs(qd[t > t[-1] - 0.5]).max() < 2e-3           # ends at rest


def test_torque_transducer_lag_and_noise():
    r = sim(2, 3000, quiet=True)
    t, T, reading = col(r, "t"), col(r, "torque"), r.samples["torque"].to_numpy()
    lags = np.arange(0, 41) * 1e-4
    err = [np.sqrt(np.mean((reading - np.interp(t - L, t, T)) ** 2)[None]) for L in lags]
    assert lags[int(np.argmin(err))] == pytest.approx(1.5e-3, abs=2.5e-4)
    r2 = sim(2, 3000)
    res = r2.samples["torque"].to_numpy() - col(r2, "torque_sensor")
    assert np.std(res) == pytest.approx(80.0, rel=0.05)


def test_encoders_currents_temperatures():
    r = sim(1, 3000, quiet=True)
    p = r.params
    s = r.samples
    step = math.radians(0.01)
    q = s["q"].to_numpy()
    np.testing.assert_allclose(q, np.round(col(r, "q") / step) * step, atol=1e-12)
    assert np.abs(q - col(r, "q")).max() <= step / 2 + 1e-12
    ustep = 2 * math.pi / 2 ** 19 / N
    assert np.abs(s["u"].to_numpy() - col(r, "u")).max() <= ustep / 2 + 1e-12
    np.testing.assert_allclose(s["torsion"], s["q"] - s["u"], atol=1e-15)
    total = sum(p[f"kt{k}"] * s[f"i_m{k}"].to_numpy() for k in (1, 2, 3)) * N * p["eta"]
    np.testing.assert_allclose(total, col(r, "motor_torque"), rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(s["w_m1"], N * col(r, "ud"), rtol=1e-12)
    tj, tm = col(r, "temp_joint"), col(r, "temp_m1")
    assert tj[0] == 25.0 and 0.0 < tj[-1] - 25.0 < 1.0
    assert 0.5 < tm.max() - 25.0 < 30.0


# --- effects ------------------------------------------------------------------------------------------

def sliding_friction_expected(r, mc, mv, bias=0.0):
    p = r.params
    qd = col(r, "qd")
    return p["f_c"] * mc * np.sign(qd) + p["f_v"] * mv * qd + bias


def check_friction(r, mc, mv, bias=0.0, tol=1e-6 * T_R):
    m = sliding(r)
    exp = sliding_friction_expected(r, mc, mv, bias)
    assert np.abs(col(r, "friction")[m] - exp[m]).max() < tol


def lag1(t, x, tau):
    """First-order lag τ·ẏ = x − y from y = 0 (exact for x held over each sample)."""
    a = np.exp(-np.diff(t) / tau)
    y = np.empty_like(x)
    y[0] = 0.0
    for i in range(1, len(x)):
        y[i] = a[i - 1] * y[i - 1] + (1 - a[i - 1]) * 0.5 * (x[i] + x[i - 1])
    return y


def mean_gap(r, r0, name="friction"):
    m = sliding(r) & sliding(r0)
    return float(np.mean(col(r, name)[m] - col(r0, name)[m]))


@pytest.mark.parametrize("form,g", [
    ("exponent_1p5", lambda x: np.exp(-x ** 1.5)),
    ("rational_cubic", lambda x: 1 / (1 + x ** 3)),
    ("tent", lambda x: np.maximum(0, 1 - x / 2)),
])
def test_stribeck(form, g):
    r0 = sim(1, 300)
    gaps = []
    for s in (1.0, 2.0):
        r = sim(1, 300, effects=eff("stribeck", form, s))
        x = np.abs(lag1(col(r, "t"), col(r, "qd"), 0.5)) / 2e-3     # frictional memory
        check_friction(r, 1 + 0.5 * s * g(x), 1.0, tol=0.002 * F_C * s)
        gaps.append(mean_gap(r, r0))
    expect = 0.5 * F_C * g(w_out(300) / 2e-3)
    assert 0.6 * expect < gaps[0] < 1.5 * expect
    assert gaps[1] / gaps[0] == pytest.approx(2.0, rel=0.1)
    fast = sim(1, 3000, effects=eff("stribeck", form, 1.0))
    assert abs(mean_gap(fast, sim(1, 3000))) < 0.02 * gaps[0] + 1.0


@pytest.mark.parametrize("form", ["power_1p5", "saturating_tanh", "quadrant_dependent"])
def test_load_dependent_friction(form):
    r0 = sim(1, 3000)
    gaps = []
    for s in (1.0, 2.0):
        r = sim(1, 3000, effects=eff("load_dependent_friction", form, s))
        a = np.abs(col(r, "torque"))
        if form == "power_1p5":
            dF = 0.015 * T_R * (a / T_R) ** 1.5
        elif form == "saturating_tanh":
            dF = 0.015 * T_R * np.tanh(2 * a / T_R) / np.tanh(2.0)
        else:
            drive = col(r, "torque") * col(r, "z") > 0
            dF = np.where(drive, 0.015, 0.005) * a
        check_friction(r, 1 + s * dF / r.params["f_c"], 1.0)
        gaps.append(mean_gap(r, r0))
        m = sliding(r) & (a > 0.95 * T_R)
        peak = np.mean(col(r, "friction")[m] - sliding_friction_expected(r, 1, 1)[m])
        assert peak == pytest.approx(s * 1800.0, rel=0.08)
    assert gaps[1] / gaps[0] == pytest.approx(2.0, rel=0.1)
    # back-driving (T·z < 0) is rare in these schemes; the driving branch is what shows


@pytest.mark.parametrize("form,size", [
    ("arrhenius_viscous", F_V * w_out(3000) * (math.exp(2500 * (1 / 323.15 - 1 / 298.15)) - 1)),
    ("coulomb_additive", -12.0 * 25.0),
    ("polynomial_viscous", F_V * w_out(3000) * (-0.02 * 25 + 2e-4 * 625)),
])
def test_temperature_friction(form, size):
    r0 = sim(1, 3000, temp=50.0)
    gaps = []
    for s in (1.0, 2.0):
        r = sim(1, 3000, temp=50.0, effects=eff("temperature_friction", form, s))
        th = col(r, "temp_joint")
        mc = np.ones_like(th)
        mv = np.ones_like(th)
        if form == "arrhenius_viscous":
            mv = 1 + s * (np.exp(2500 * (1 / (th + 273.15) - 1 / 298.15)) - 1)
        elif form == "coulomb_additive":
            mc = 1 - s * 12.0 * (th - 25.0) / r.params["f_c"]
        else:
            mv = 1 + s * (-0.02 * (th - 25) + 2e-4 * (th - 25) ** 2)
        check_friction(r, mc, mv)
        gaps.append(mean_gap(r, r0))
    assert gaps[0] == pytest.approx(size, rel=0.1)
    assert gaps[1] / gaps[0] == pytest.approx(2.0, rel=0.1)
    # at the reference temperature the effect is (nearly) absent
    cold = sim(1, 3000, temp=25.0, effects=eff("temperature_friction", form, 1.0))
    assert abs(mean_gap(cold, sim(1, 3000, temp=25.0))) < 0.05 * abs(size)


@pytest.mark.parametrize("form,d", [("coulomb_skew", 1), ("coulomb_skew", -1),
                                    ("viscous_reverse_heavier", 1),
                                    ("viscous_reverse_heavier", -1),
                                    ("constant_bias", 1), ("constant_bias", -1)])
def test_asymmetric_friction(form, d):
    r0 = sim(1, 3000, d)
    gaps = []
    for s in (1.0, 2.0):
        r = sim(1, 3000, d, effects=eff("asymmetric_friction", form, s))
        ones = np.ones(len(r.truth))
        if form == "coulomb_skew":
            check_friction(r, 1 + 0.12 * s * np.sign(col(r, "z")), ones)
            # f_c·(1 ± 0.12·s) for ±q̇: the signed friction rises by 0.12·s·f_c both ways
            expect = 0.12 * s * r.params["f_c"]
        elif form == "viscous_reverse_heavier":
            check_friction(r, ones, 1 + 0.5 * s * (col(r, "qd") < 0))
            expect = (0.5 * s * r.params["f_v"] * -w_out(3000)) if d < 0 else 0.0
        else:
            check_friction(r, ones, ones, 300.0 * s)
            expect = 300.0 * s
        gaps.append(mean_gap(r, r0))
        assert gaps[-1] == pytest.approx(expect, rel=0.05, abs=2.0)


@pytest.mark.parametrize("form", ["mesh_sawtooth", "dual_order"])
def test_gear_ripple_output_side(form):
    r0 = sim(1, 300)
    for s in (1.0, 2.0):
        r = sim(1, 300, effects=eff("gear_ripple", form, s))
        q = col(r, "q")
        if form == "mesh_sawtooth":
            ph = 240 * q / (2 * math.pi)
            tx = s * 350 * 2 * (ph - np.floor(ph + 0.5))
        else:
            tx = s * (250 * np.sin(151 * q) + 120 * np.sin(302 * q + 0.7))
        np.testing.assert_allclose(col(r, "disturbance"), tx, atol=1e-6)
        m = after(r)
        dT = col(r, "torque")[m] - col(r0, "torque")[m]
        assert slope(tx[m], dT) == pytest.approx(1.0, abs=0.15)
        assert np.corrcoef(tx[m], dT)[0, 1] > 0.85
        # the transmission law and the sensors are untouched
        law = K(r.params, col(r, "twist")) + r.params["D"] * col(r, "twist_rate")
        assert np.abs(law - col(r, "torque")).max() < 1e-6


def test_gear_ripple_motor_triangle():
    r0 = sim(1, 300)
    amps = []
    for s in (1.0, 2.0):
        r = sim(1, 300, effects=eff("gear_ripple", "motor_triangle", s))
        p = r.params
        u = col(r, "u")
        e = s * 2.5e-5 * (2 / math.pi) * np.arcsin(np.sin(2 * N * u))
        law = K(p, col(r, "twist") - e) + p["D"] * col(r, "twist_rate")
        assert np.abs(law - col(r, "torque")).max() < 1e-6
        m = after(r)
        amps.append(np.std(col(r, "torque")[m] - col(r0, "torque")[m]))
    # ≈ K'(Δ)·2.5e-5 of triangle ripple (SD = amplitude/√3), raised near the output mode
    assert 150.0 < amps[0] < 800.0
    assert amps[1] / amps[0] == pytest.approx(2.0, rel=0.1)


@pytest.mark.parametrize("form", ["linear_creep", "mid_run_step", "temperature_coefficient"])
def test_torque_offset(form):
    r0 = sim(1, 300, temp=40.0)
    t = col(r0, "t")
    dur = R.run_duration(1, 1)
    for s in (1.0, 3.0):
        r = sim(1, 300, temp=40.0, effects=eff("torque_offset", form, s))
        for c in r0.truth.columns:
            np.testing.assert_array_equal(col(r, c), col(r0, c))
        if form == "linear_creep":
            off = s * 5.0 * t
        elif form == "mid_run_step":
            off = s * 600.0 * (t >= dur / 2)
        else:
            off = s * 20.0 * (col(r, "temp_joint") - 20.0)
        d = r.samples["torque"].to_numpy() - r0.samples["torque"].to_numpy()
        assert np.abs(d - off).max() <= R.SensorSpec().torque_res * 1.01
        for c in ("q", "u", "torque_load", "i_m1"):
            np.testing.assert_array_equal(r.samples[c], r0.samples[c])


@pytest.mark.parametrize("form,chan", [("torque_fieldbus", "torque"),
                                       ("output_encoder_fieldbus", "q"),
                                       ("motor_encoder_fieldbus", "u")])
def test_time_delay(form, chan):
    r0 = sim(2, 3000, quiet=True)
    t = col(r0, "t")
    for s in (1.0, 2.5):
        r = sim(2, 3000, quiet=True, effects=eff("time_delay", form, s))
        for c in r0.truth.columns:
            np.testing.assert_array_equal(col(r, c), col(r0, c))
        lag = 4e-3 * s
        if chan == "torque":
            want = np.interp(t - 1.5e-3 - lag, t, col(r0, "torque"))
            got = r.samples["torque"].to_numpy()
            base = np.interp(t - lag, t, r0.samples["torque"].to_numpy())
            assert np.abs(got - base)[t > 1].max() < 5.0
            assert np.sqrt(np.mean((got - want)[t > 1] ** 2)) < 5.0
        else:
            step = math.radians(0.01) if chan == "q" else 2 * math.pi / 2 ** 19 / N
            want = np.round(np.interp(t - lag, t, col(r0, chan)) / step) * step
            got = r.samples[chan].to_numpy()
            assert np.mean(got[t > 1] != want[t > 1]) < 0.01
            other = "u" if chan == "q" else "q"
            np.testing.assert_array_equal(r.samples[other], r0.samples[other])


def play(x, r, p0):
    out = np.empty_like(x)
    p = p0
    for i, v in enumerate(x):
        p = min(max(p, v - r), v + r)
        out[i] = p
    return out


@pytest.mark.parametrize("form", ["prandtl_stops", "bouc_wen_n2"])
def test_hysteresis(form):
    r0 = sim(1, 300)
    hs = []
    for s in (1.0, 2.0):
        r = sim(1, 300, effects=eff("hysteresis", form, s))
        p = r.params
        tw = col(r, "twist")
        h = col(r, "hysteresis")
        law = K(p, tw) + p["D"] * col(r, "twist_rate") + h
        assert np.abs(law - col(r, "torque")).max() < 1e-6
        if form == "prandtl_stops":
            want = s * sum(400 * (tw - play(tw, ri, tw[0])) / ri
                           for ri in (0.4e-3, 0.8e-3, 1.2e-3, 1.6e-3, 2.0e-3))
            assert np.abs(want - h).max() < 0.01 * 2000 * s
        ph = r.samples["phase"].to_numpy()
        ld = (ph == "load") & (tw > 0.006)
        un = (ph == "unload") & (tw < 0.003) & (tw > 0.001)
        assert h[ld].min() > 0.97 * 2000 * s          # saturated up while loading
        assert h[un].max() < -0.9 * 2000 * s          # and down while unloading
        hs.append(h)
    assert np.sqrt(np.mean((hs[1] - 2 * hs[0]) ** 2)) < 0.05 * 4000
    # at the same torque, unloading twists more than loading (loop of ≈ 2·2000 N·m)
    assert r0.truth["hysteresis"].abs().max() == 0.0


@pytest.mark.parametrize("form", ["dead_zone", "quadratic_rounded", "spring_loaded"])
def test_backlash(form):
    r0 = sim(3, periods=1)
    shifts = []
    for s in (1.0, 2.0):
        r = sim(3, periods=1, effects=eff("backlash", form, s))
        p = r.params
        k0 = pade_k0(p)
        b = 2e-4 * s
        tw = col(r, "twist")
        a = np.abs(tw)
        sg = np.sign(tw)
        if form == "quadratic_rounded":
            w = b / 2
            db = np.where(a <= b - w, 0.0, np.where(a < b + w, sg * (a - b + w) ** 2 / (4 * w),
                                                     sg * (a - b)))
            c = np.where(a <= b - w, 0.0, np.where(a < b + w, (a - b + w) / (2 * w), 1.0))
        else:
            db = np.where(a <= b, 0.0, sg * (a - b))
            c = (a > b).astype(float)
        law = K(p, db) + p["D"] * c * col(r, "twist_rate")
        if form == "spring_loaded":
            law += 0.05 * k0 * np.clip(tw, -b, b)
        assert np.abs(law - col(r, "torque")).max() < 1e-6
        # the twist at a given torque moves out by the half-gap
        T = col(r, "torque")
        hi = T > 1500
        T0 = col(r0, "torque")
        shift = np.mean(tw[hi]) - np.mean(np.interp(T[hi], np.sort(T0), col(r0, "twist")[np.argsort(T0)]))
        shifts.append(shift)
    assert shifts[0] == pytest.approx(2e-4, rel=0.3)
    assert shifts[1] / shifts[0] == pytest.approx(2.0, rel=0.15)


def line_amp(t, x, f):
    """Amplitude of the spectral line of x at f [Hz] (least squares on sin and cos)."""
    a = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t), np.ones_like(t)])
    c = np.linalg.lstsq(a, x, rcond=None)[0]
    return float(np.hypot(c[0], c[1]))


@pytest.mark.parametrize("form", ["hydraulic_ripple", "valve_square"])
def test_periodic_disturbance(form):
    r0 = sim(1, 3000)
    t = col(r0, "t")
    amps = []
    for s in (1.0, 2.0):
        r = sim(1, 3000, effects=eff("periodic_disturbance", form, s))
        if form == "hydraulic_ripple":
            tx = s * 400 * (np.sin(2 * np.pi * 2.3 * t) + 0.5 * np.sin(2 * np.pi * 6.9 * t))
        else:
            tx = s * 300 * np.clip(np.sin(2 * np.pi * 0.4 * t) / 0.05, -1, 1)
        np.testing.assert_allclose(col(r, "disturbance"), tx, atol=1e-6)
        m = after(r)
        dT = col(r, "torque")[m] - col(r0, "torque")[m]
        f0 = 2.3 if form == "hydraulic_ripple" else 0.4
        want = s * (400.0 if form == "hydraulic_ripple" else 300.0 * 4 / np.pi)
        assert line_amp(t[m], dT, f0) == pytest.approx(want, rel=0.3)
        amps.append(line_amp(t[m], dT, f0))
    assert amps[1] / amps[0] == pytest.approx(2.0, rel=0.05)


@pytest.mark.parametrize("form", ["ramp_in_angle", "octo_lobed"])
def test_position_dependent_stiffness(form):
    for s in (1.0, 2.0):
        r = sim(1, 3000, effects=eff("position_dependent_stiffness", form, s))
        p = r.params
        q = col(r, "q")
        mk = np.maximum(0.2, 1 + 0.25 * s * q) if form == "ramp_in_angle" \
            else 1 + 0.12 * s * np.sin(8 * q)
        law = mk * K(p, col(r, "twist")) + p["D"] * col(r, "twist_rate")
        assert np.abs(law - col(r, "torque")).max() < 1e-6
        assert np.ptp(mk) > 0.1 * s


@pytest.mark.parametrize("form,chan", [("q_ramp", "q"), ("u_wander", "u")])
def test_encoder_drift(form, chan):
    r0 = sim(1, 300)
    t = col(r0, "t")
    for s in (1.0, 2.0):
        r = sim(1, 300, effects=eff("encoder_drift", form, s))
        for c in r0.truth.columns:
            np.testing.assert_array_equal(col(r, c), col(r0, c))
        drift = s * 4e-6 * t if form == "q_ramp" else s * 2.5e-4 * np.sin(2 * np.pi * t / 45)
        step = r.meta["sensors"][chan]["resolution"]
        d = r.samples[chan].to_numpy() - r0.samples[chan].to_numpy()
        assert np.abs(d - drift).max() <= step * 1.001
        other = "u" if chan == "q" else "q"
        np.testing.assert_array_equal(r.samples[other], r0.samples[other])


def test_second_resonance_output_link():
    r0 = sim(3, periods=1)
    sl = []
    for s in (1.0, 2.0):
        r = sim(3, periods=1, effects=eff("second_resonance", "output_flex_link", s))
        m = after(r)
        x = r.params["I"] * col(r, "qdd")
        sl.append(slope(np.convolve(x, np.ones(200) / 200, "same")[m],
                        np.convolve(col(r, "disturbance"), np.ones(200) / 200, "same")[m]))
        law = K(r.params, col(r, "twist")) + r.params["D"] * col(r, "twist_rate")
        assert np.abs(law - col(r, "torque")).max() < 1e-6
    # an extra 0.15·s·I rides on the output at low frequency
    assert sl[0] == pytest.approx(0.15, rel=0.25)
    assert sl[1] == pytest.approx(0.30, rel=0.25)
    assert np.abs(col(r0, "disturbance")).max() == 0.0


def test_second_resonance_motor_coupling():
    r0 = sim(3, periods=1)
    t = col(r0, "t")
    sl = []
    for s in (1.0, 2.0):
        r = sim(3, periods=1, effects=eff("second_resonance", "motor_flex_coupling", s))
        m = after(r)
        udd = np.gradient(col(r, "ud"), t)
        jm = r.params["J_M"]
        d_tm = col(r, "motor_torque") - col(r0, "motor_torque")
        k = np.ones(200) / 200
        sl.append(slope(np.convolve(jm * udd, k, "same")[m], np.convolve(d_tm, k, "same")[m]))
        # the output side barely notices it
        assert np.abs(col(r, "torque") - col(r0, "torque"))[m].max() < 0.1 * np.abs(col(r0, "torque")).max()
    assert sl[0] == pytest.approx(0.10, rel=0.3)
    assert sl[1] == pytest.approx(0.20, rel=0.3)


def test_effects_at_scale_max_stay_finite():
    big = {"backlash": {"form": "dead_zone", "scale": 10.0},
           "hysteresis": {"form": "bouc_wen_n2", "scale": 10.0},
           "second_resonance": {"form": "output_flex_link", "scale": 10.0},
           "stribeck": {"form": "tent", "scale": 10.0}}
    r = sim(3, periods=1, effects=big)
    assert np.isfinite(r.truth.to_numpy()).all()
    assert np.abs(col(r, "torque")).max() < 1e5
