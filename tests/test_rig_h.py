"""Tests of validation rig H (validation_rigs/rig_h.py): contract, physics, effects, sensors."""
from __future__ import annotations

import json
import math
from functools import lru_cache

import numpy as np
import pandas as pd
import pytest

from validation_rigs import rig_h as R

SEED = 3
FAST = R.SensorSpec(sample_rate_hz=100.0)
KHZ = R.SensorSpec(sample_rate_hz=1000.0)
READING_ONLY = ("torque_offset", "time_delay", "sensor_drift")
PLANT_TRUTH = ("q", "qd", "u", "ud", "twist", "twist_rate", "torque_true", "torque_load_true")


def _key(effects):
    return json.dumps(effects, sort_keys=True)


@lru_cache(maxsize=None)
def _run(scheme, rpm, direction, temp, effects_json, sr=100.0, run=0, seed=SEED, periods=1,
         lag=0.0):
    sensors = R.SensorSpec(sample_rate_hz=sr, torque_lag_s=lag)
    return R.simulate_run(scheme, rpm, direction, temp, json.loads(effects_json), seed=seed,
                          sensors=sensors, periods=periods, run=run)


def run(scheme=3, rpm=None, direction=1, temp=25.0, effects=None, **kw):
    return _run(scheme, rpm, direction, temp, _key(effects or {}), **kw)


def grav(p, q):
    return 9.81 * (p["mr_x"] * np.sin(q) + p["mr_y"] * np.cos(q))


P = R.campaign_parameters(SEED)


# ----------------------------------------------------------------------------- contract
def test_module_contract():
    assert R.SEED_IS_CAMPAIGN is True and R.REDUCTION == 11000.0
    assert R.RIG_NAME == "validation-rig-H"
    need = {"stribeck", "temperature_friction", "load_dependent_friction", "asymmetric_friction",
            "gear_ripple", "backlash", "hysteresis", "torque_offset", "time_delay"}
    oov = set(R.OUT_OF_VOCABULARY)
    assert len(oov) >= 4 and oov <= {"periodic_disturbance", "position_dependent_stiffness",
                                     "sensor_drift", "second_resonance"}
    assert set(R.EFFECT_FORMS) == need | oov
    for forms in R.EFFECT_FORMS.values():
        assert 2 <= len(forms) <= 5 and len(set(forms)) == len(forms)
    assert {"exponential", "gaussian", "lorentzian"} <= set(R.EFFECT_FORMS["stribeck"])
    assert set(R.nominal_parameters()) == set(P)
    nom = R.nominal_parameters()
    for k in ("I", "f_v", "f_c", "k0", "J_u"):
        assert abs(P[k] / nom[k] - 1) <= 0.08 + 1e-12
    assert R.campaign_parameters(SEED) == P and R.campaign_parameters(SEED + 1) != P


def test_columns_meta_and_times():
    r = run(1, 3000.0, 1, sr=1000.0)
    cols = ["t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "phase",
            "i_m1", "i_m2", "i_m3", "w_m1", "w_m2", "w_m3"]
    assert set(cols) <= set(r.samples.columns)
    assert set(["t", "q", "qd", "u", "ud", "twist", "twist_rate", "torque",
                "torque_load"]) <= set(r.truth.columns)
    assert np.array_equal(r.samples.t.values, np.arange(len(r.samples)) / 1000.0)
    assert np.array_equal(r.truth.t.values, r.samples.t.values)
    m = r.meta
    for k in ("scheme", "motor_speed_rpm", "direction", "reduction", "rig", "source",
              "sample_rate_hz", "duration_s", "temp_joint_c", "seed", "run", "periods",
              "sensors"):
        assert k in m
    assert m["reduction"] == R.REDUCTION and m["rig"] == R.RIG_NAME
    assert m["source"] == "emulator" and m["scheme"] == 1 and m["motor_speed_rpm"] == 3000.0
    for ch in ("q", "u", "torque", "torque_load", "qd", "ud", "temp_joint", "i_m1", "w_m3"):
        assert ch in m["sensors"]
    text = json.dumps(m["sensors"])
    for name in R.EFFECT_FORMS:
        assert name not in text
    assert np.isfinite(r.samples.drop(columns="phase").values).all()
    assert set(r.samples.phase) == {"idle", "load", "hold", "unload"}


def test_determinism_run_and_seed():
    a = R.simulate_run(3, None, 1, 25.0, {}, seed=SEED, sensors=FAST, periods=1, run=0)
    b = R.simulate_run(3, None, 1, 25.0, {}, seed=SEED, sensors=FAST, periods=1, run=0)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    c = run(3, run=1)
    pd.testing.assert_frame_equal(a.truth, c.truth)
    assert not np.array_equal(a.samples.torque.values, c.samples.torque.values)
    d = run(3, seed=SEED + 1)
    assert not np.array_equal(a.truth.q.values, d.truth.q.values)


@pytest.mark.parametrize("name", ["stribeck", "hysteresis", "torque_offset", "second_resonance"])
def test_scale_zero_is_nominal_bit_for_bit(name):
    nominal = run(3)
    z = run(3, effects={name: {"form": R.EFFECT_FORMS[name][0], "scale": 0.0}})
    pd.testing.assert_frame_equal(nominal.samples, z.samples, check_exact=True)
    pd.testing.assert_frame_equal(nominal.truth, z.truth, check_exact=True)


BAD = [
    (dict(scheme=4), "scheme"),
    (dict(scheme=True), "scheme"),
    (dict(motor_speed_rpm=float("nan")), "motor_speed_rpm"),
    (dict(motor_speed_rpm=float("inf")), "motor_speed_rpm"),
    (dict(motor_speed_rpm=-5.0), "motor_speed_rpm"),
    (dict(scheme=3), "motor_speed_rpm"),
    (dict(direction=0), "direction"),
    (dict(temp_joint_c=float("nan")), "temp_joint_c"),
    (dict(temp_joint_c=float("-inf")), "temp_joint_c"),
    (dict(effects={"wobble": {"form": "x"}}), "effects"),
    (dict(effects={"stribeck": {"form": "cubic"}}), "form"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": float("nan")}}), "scale"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": float("inf")}}), "scale"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": -1.0}}), "scale"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": float("-inf")}}), "scale"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": "5"}}), "scale"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": None}}), "scale"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": True}}), "scale"),
    (dict(effects="stribeck"), "effects"),
    (dict(seed=-1), "seed"),
    (dict(seed=1.5), "seed"),
    (dict(run=-2), "run"),
    (dict(periods=0), "periods"),
    (dict(sensors=R.SensorSpec(sample_rate_hz=float("nan"))), "sample_rate_hz"),
    (dict(sensors=R.SensorSpec(sample_rate_hz=5000.0)), "sample_rate_hz"),
    (dict(sensors=R.SensorSpec(torque_noise=float("inf"))), "torque_noise"),
    (dict(sensors=R.SensorSpec(torque_lag_s=-0.1)), "torque_lag_s"),
    (dict(sensors=R.SensorSpec(load_noise=float("nan"))), "load_noise"),
    (dict(sensors=R.SensorSpec(encoder_res_deg=0.0)), "encoder_res_deg"),
    (dict(sensors="fast"), "sensors"),
]


@pytest.mark.parametrize("kw,word", BAD)
def test_bad_arguments_raise_naming_them(kw, word):
    args = dict(scheme=1, motor_speed_rpm=300.0, direction=1, temp_joint_c=25.0, effects={},
                seed=1, sensors=FAST, run=0)
    args.update(kw)
    with pytest.raises(ValueError, match=word):
        R.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                       args.pop("temp_joint_c"), args.pop("effects"), **args)


# ----------------------------------------------------------------------------- large scales
FAMILIES = list(R.EFFECT_FORMS)


def _finite(r):
    return (np.isfinite(r.samples.drop(columns="phase").values.astype(float)).all()
            and np.isfinite(r.truth.values.astype(float)).all())


@pytest.mark.parametrize("name,form", [(n, f) for n, fs in R.EFFECT_FORMS.items() for f in fs])
def test_large_scale_accepted_and_finite_scheme3(name, form):
    r = run(3, effects={name: {"form": form, "scale": 50.0}})
    assert _finite(r)
    assert np.abs(r.truth.q).max() < 10.0


@pytest.mark.parametrize("name", FAMILIES)
def test_large_scale_finite_under_load(name):
    for s in (50, 200.0):  # integer and float scales
        r = run(1, 3000.0, -1, temp=80.0, effects={name: {"form": R.EFFECT_FORMS[name][-1],
                                                          "scale": s}})
        assert _finite(r)
    r = run(3, temp=-20.0, effects={name: {"form": R.EFFECT_FORMS[name][0], "scale": 5000.0}})
    assert _finite(r)


def test_s_max_is_documentation_only():
    assert set(R.S_MAX) == set(R.EFFECT_FORMS)
    assert all(v > 0 for v in R.S_MAX.values())
    # a scale far beyond the documented linear range is accepted
    r = run(3, effects={"stribeck": {"form": "gaussian", "scale": 99.0}})
    assert _finite(r)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["torque_offset"])
def test_torque_offset_linear_far_beyond_old_limit(form):
    nom = run(3).truth.torque
    a = (run(3, effects={"torque_offset": {"form": form, "scale": 1.0}}).truth.torque - nom)
    b = (run(3, effects={"torque_offset": {"form": form, "scale": 200.0}}).truth.torque - nom)
    assert np.allclose(b.values, 200.0 * a.values, rtol=1e-9, atol=1e-6)


@pytest.mark.parametrize("name,form,s_lo,s_hi", [
    ("hysteresis", "bouc_wen_n1", 10.0, 50.0),      # share s·w capped at HYS_SHARE_MAX
    ("backlash", "tanh_dead_zone", 100.0, 900.0),    # b capped at BL_MAX
    ("second_resonance", "output_tuned_mass", 500.0, 2000.0),
    ("position_dependent_stiffness", "cos_two_per_rev", 1e3, 1e4),
    ("periodic_disturbance", "single_tone", 100.0, 4000.0),
])
def test_saturated_forms_stop_growing(name, form, s_lo, s_hi):
    a = run(3, effects={name: {"form": form, "scale": s_lo}}).truth
    b = run(3, effects={name: {"form": form, "scale": s_hi}}).truth
    for c in PLANT_TRUTH:
        assert np.array_equal(a[c].values, b[c].values)


def test_time_delay_saturates():
    a = run(3, effects={"time_delay": {"form": "pure_delay", "scale": 500.0}}).truth.torque
    b = run(3, effects={"time_delay": {"form": "pure_delay", "scale": 5000.0}}).truth.torque
    assert np.array_equal(a.values, b.values)
    # lag below the one-step floor: still finite, and equal to the floor value
    c = run(3, effects={"time_delay": {"form": "first_order_lag", "scale": 1e-4}})
    d = run(3, effects={"time_delay": {"form": "first_order_lag", "scale": 1e-6}})
    assert _finite(c) and np.array_equal(c.truth.torque.values, d.truth.torque.values)


def test_friction_floors_keep_sign():
    # hot joint, a strongly negative temperature coefficient: the friction level saturates at
    # RHO_MIN·f_c instead of changing sign
    tr = run(1, 3000.0, 1, temp=80.0, sr=1000.0, effects={
        "temperature_friction": {"form": "additive_coulomb_viscous", "scale": 50.0}}).truth
    win = (tr.t > 3.6) & (tr.t < 4.0)
    assert (tr.friction_out[win] > 0).all()
    assert tr.friction_out[win].mean() == pytest.approx(R.RHO_MIN * P["f_c"], rel=0.05)


def test_divergence_raises_runtime_error_naming_effect():
    p = R._draw(SEED).copy()
    p[R._PIDX["I"]] = 1e-3  # absurd output inertia: RK4 at 4 kHz cannot hold it
    fm = -np.ones(13, dtype=np.int64)
    sc = np.zeros(13)
    fm[R.F_HYS] = 2
    sc[R.F_HYS] = 1.0
    with pytest.raises(RuntimeError, match="hysteresis"):
        R._simulate_truth(3, 0.0, 1, 25.0, fm, sc, p, 100.0, duration=2.0)


# ----------------------------------------------------------------------------- physics
def test_static_equilibrium_at_rest():
    tr = run(1, 3000.0, 1, sr=1000.0).truth
    rest = tr[tr.t < 0.95]
    assert np.abs(rest.qd).max() < 1e-7 and np.abs(rest.ud).max() < 1e-7
    assert np.abs(rest.torque_true - grav(P, rest.q)).max() < 1.0
    assert np.abs(rest.torque_load_true).max() < 1e-6
    assert rest.torque_true.iloc[0] == pytest.approx(9.81 * P["mr_y"], rel=1e-9)


def test_transmission_law_and_newton_on_truth():
    tr = run(1, 3000.0, -1, sr=1000.0).truth
    d0 = P["delta0"]
    law = P["k0"] * d0 * np.sinh(tr.twist / d0) + P["D"] * tr.twist_rate
    assert np.abs(tr.torque_true - law).max() < 1e-6 * 120e3
    # stiffening: secant stiffness at rated load higher than k0 (own non-linear law)
    i = tr.torque_true.abs().idxmax()
    assert abs(tr.torque_true[i]) > 115e3 and 0.006 < abs(tr.twist[i]) < 0.0095
    newton = tr.torque_true - tr.torque_load_true - grav(P, tr.q) - tr.friction_out
    assert np.abs(P["I"] * tr.qdd - newton).max() < 1e-6 * 120e3


@pytest.mark.parametrize("rpm,direction", [(300.0, 1), (3000.0, 1), (3000.0, -1)])
def test_steady_state_friction(rpm, direction):
    tr = run(1, rpm, direction, sr=1000.0).truth
    w = direction * rpm * 2 * math.pi / 60 / R.REDUCTION
    win = tr[(tr.t > 3.6) & (tr.t < 4.0)]  # constant speed, no load
    assert np.abs(win.qd - w).max() < 2e-3 * abs(w) + 1e-6
    fric = win.torque_true - grav(P, win.q)
    expect = direction * P["f_c"] + P["f_v"] * win.qd
    assert np.abs(fric - expect).max() < 0.01 * abs(expect).min()
    fm = win.motor_torque - win.torque_true
    expect_m = P["c_vm"] * win.ud + P["c_cm"] * np.tanh(win.ud / 1e-4)
    assert np.abs(fm - expect_m).max() < 0.01 * np.abs(expect_m).min()


def test_energy_balance_scheme1():
    tr = run(1, 3000.0, 1, sr=1000.0).truth
    t = tr.t.values

    def integ(y):
        return float(np.trapezoid(y, t))

    w_in = integ(tr.motor_torque * tr.ud)
    f_m = P["c_vm"] * tr.ud + P["c_cm"] * np.tanh(tr.ud / 1e-4)
    d0 = P["delta0"]
    e_el = P["k0"] * d0 ** 2 * (np.cosh(tr.twist / d0) - 1)
    e_kin = 0.5 * P["I"] * tr.qd ** 2 + 0.5 * P["J_u"] * tr.ud ** 2
    e_pot = 9.81 * (-P["mr_x"] * np.cos(tr.q) + P["mr_y"] * np.sin(tr.q))
    e = e_el + e_kin + e_pot
    out = (integ(tr.torque_load_true * tr.qd) + integ(tr.friction_out * tr.qd)
           + integ(f_m * tr.ud) + integ(P["D"] * tr.twist_rate ** 2) + e.iloc[-1] - e.iloc[0])
    assert w_in > 1e5
    assert out == pytest.approx(w_in, rel=2e-3)


def test_integrator_fourth_order():
    p = R._draw(SEED).copy()
    p[R._PIDX["f_c"]] = 0.0  # smooth sub-case: no Coulomb/presliding on either side
    p[R._PIDX["c_cm"]] = 0.0
    fm = -np.ones(13, dtype=np.int64)
    sc = np.zeros(13)

    def q_at(hz):
        rec = R._simulate_truth(3, 0.0, 1, 25.0, fm, sc, p, 1000.0, internal_hz=hz,
                                duration=3.0)[0]
        step = hz // 250
        return rec[::step, [0, 2, 4]] / np.array([1e-3, 1e-3, 1e3])

    ref = q_at(32000)
    errs = [np.abs(q_at(hz) - ref).max() for hz in (1000, 2000, 4000)]
    orders = [math.log2(errs[i] / errs[i + 1]) for i in range(2)]
    assert all(3.5 < o < 4.6 for o in orders), (errs, orders)


def test_scheme_profiles():
    r1 = run(1, 3000.0, 1, sr=100.0)
    assert r1.meta["duration_s"] == 62.0
    tl = r1.truth.torque_load_true
    assert abs(tl.max() - 120e3) < 2e3
    hold = r1.truth[r1.samples.phase == "hold"]
    assert np.abs(hold.torque_load_true - 120e3).max() < 2e3
    assert np.abs(r1.truth.torque_load_true.iloc[-1]) < 50.0
    r2 = run(2, 300.0, -1, sr=100.0)
    assert r2.meta["duration_s"] == 57.0
    s2, t2 = r2.samples, r2.truth
    plateaus = []
    for k in range(1, 13):
        t_hold = 4 + 3 * (k - 1) + 2.9
        plateaus.append(float(t2.torque_load_true[np.isclose(t2.t, t_hold)].iloc[0]))
        assert s2.phase[np.isclose(s2.t, t_hold)].iloc[0] == "hold"
    assert np.allclose(plateaus, 1e4 * np.arange(1, 13), atol=2e3)
    assert (t2.qd[(t2.t > 5) & (t2.t < 50)] < 0).all()  # direction -1
    r3 = run(3, periods=3)
    assert r3.meta["duration_s"] == 60.0 and set(r3.samples.phase) == {"excite"}
    assert np.abs(r3.truth.qd).max() < R.W_MAX_OUT
    assert np.abs(r3.truth.q).max() < math.pi
    assert np.abs(r3.truth.torque_load_true).max() < 1.0
    # periodic excitation: the second and third periods repeat
    q = r3.truth.q.values
    assert np.abs(q[2000:4000] - q[4000:6000]).max() < 1e-4


# ----------------------------------------------------------------------------- effects
ALL_FORMS = [(n, f) for n, forms in R.EFFECT_FORMS.items() for f in forms]


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_form_acts_where_it_should(name, form):
    nominal = run(3, temp=10.0)
    r = run(3, temp=10.0, effects={name: {"form": form, "scale": 1.0}})
    same_truth = all(np.array_equal(nominal.truth[c], r.truth[c]) for c in PLANT_TRUTH)
    if name in READING_ONLY:
        assert same_truth
        changed = [c for c in ("q", "torque", "torque_load")
                   if not np.array_equal(nominal.samples[c], r.samples[c])]
        expected = {"encoder_drift": ["q"], "load_cell_drift": ["torque_load"]}.get(
            form, ["torque"])
        assert changed == expected
        pd.testing.assert_series_equal(nominal.samples.qd, r.samples.qd)
    else:
        assert not same_truth


@pytest.mark.parametrize("form", R.EFFECT_FORMS["stribeck"])
def test_stribeck_steady_curve(form):
    # small scales: a strong velocity-weakening curve makes the 300 r/min run stick-slip
    incs = []
    for s in (0.25, 0.5):
        r = run(1, 300.0, 1, sr=1000.0, effects={"stribeck": {"form": form, "scale": s}}).truth
        win = (r.t > 3.7) & (r.t < 4.0)
        x = np.abs(r.qd[win]) / P["strib_vs"]
        phi = {"exponential": np.exp(-x), "gaussian": np.exp(-x * x),
               "lorentzian": 1 / (1 + x * x), "root": np.exp(-np.sqrt(x))}[form].mean()
        inc = (r.friction_out[win] - P["f_v"] * r.qd[win]).mean() - P["f_c"]
        assert inc == pytest.approx(s * P["strib_ratio"] * P["f_c"] * phi, rel=0.03)
        incs.append(inc)
    assert incs[1] == pytest.approx(2 * incs[0], rel=0.03)  # size linear in s


def test_temperature_friction_only_with_effect():
    cold, warm = run(3, temp=0.0), run(3, temp=25.0)
    for c in PLANT_TRUTH:
        assert np.array_equal(cold.truth[c], warm.truth[c])  # nominal: no temperature law
    for form in R.EFFECT_FORMS["temperature_friction"]:
        eff = {"temperature_friction": {"form": form, "scale": 1.0}}
        dc = np.abs(run(3, temp=0.0, effects=eff).truth.torque_true - cold.truth.torque_true)
        dw = np.abs(run(3, temp=25.0, effects=eff).truth.torque_true - warm.truth.torque_true)
        assert dc.max() > 50.0 and dw.max() < 0.05 * dc.max()


def test_load_dependent_friction_grows_with_torque():
    nom = run(1, 3000.0, 1, sr=100.0).truth
    r = run(1, 3000.0, 1, sr=100.0,
            effects={"load_dependent_friction": {"form": "coulomb_linear"}}).truth
    hold = (nom.t > 30) & (nom.t < 32)
    idle = (nom.t > 3.6) & (nom.t < 4.0)
    inc_hold = (r.friction_out - nom.friction_out)[hold].mean()
    inc_idle = (r.friction_out - nom.friction_out)[idle].mean()
    te = r.torque_true[hold].mean()
    assert inc_hold == pytest.approx(P["load_mu"] * te, rel=0.03)
    assert abs(inc_idle) < 0.05 * inc_hold


def test_asymmetric_friction_direction():
    res = {}
    for d in (1, -1):
        r = run(1, 3000.0, d, sr=100.0,
                effects={"asymmetric_friction": {"form": "coulomb", "scale": 1.0}}).truth
        win = (r.t > 3.6) & (r.t < 4.0)
        res[d] = np.abs((r.friction_out - P["f_v"] * r.qd)[win]).mean()
    assert res[1] / res[-1] == pytest.approx((1 + P["asym_c"]) / (1 - P["asym_c"]), rel=0.02)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["gear_ripple"])
def test_gear_ripple_periodic_in_angle(form):
    rpm = 300.0
    nom = run(1, rpm, 1, sr=1000.0).truth
    r = run(1, rpm, 1, sr=1000.0, effects={"gear_ripple": {"form": form}}).truth
    sel = (nom.t > 4) & (nom.t < 57)
    if form in ("output_mesh", "output_mesh_harmonics"):
        # a mesh torque on the output body: the transducer carries it at quasi-static speed,
        # while the transmission law itself is untouched
        sig = (r.torque_true - nom.torque_true)[sel]
        basis = np.sin(P["rip_n"] * r.q[sel] + P["rip_ph1"])
        d0 = P["delta0"]
        law = P["k0"] * d0 * np.sinh(r.twist / d0) + P["D"] * r.twist_rate
        assert np.abs(r.torque_true - law).max() < 1e-3
    else:
        # a kinematic error: the twist/torque relation carries it
        d0 = P["delta0"]
        dk = d0 * np.arcsinh((r.torque_true - P["D"] * r.twist_rate) / (P["k0"] * d0))
        sig = (dk - r.twist)[sel]
        if form == "motor_two_per_rev":
            th = R.REDUCTION * r.u[sel]
            basis = np.sin(2 * th + P["rip_phm"]) + 0.3 * np.sin(4 * th + P["rip_phm2"])
            amp = P["rip_em"]
        else:
            basis = np.sin(P["rip_n"] * r.q[sel] + P["rip_ph1"])
            amp = P["rip_eps"]
        assert np.abs(sig - amp * basis).max() < 1e-3 * amp
    assert np.corrcoef(sig, basis)[0, 1] > 0.8


@pytest.mark.parametrize("form", R.EFFECT_FORMS["backlash"])
def test_backlash_dead_zone_law(form):
    tr = run(3, effects={"backlash": {"form": form}}, sr=1000.0).truth
    b = P["bl_b"]
    d = tr.twist.values
    if form == "sharp_dead_zone":
        db = np.sign(d) * np.maximum(np.abs(d) - b, 0)
        g = (np.abs(d) > b).astype(float)
    elif form == "tanh_dead_zone":
        db = d - b * np.tanh(d / b)
        g = np.tanh(d / b) ** 2
    else:
        a = np.abs(d)
        db = np.where(a < 2 * b, np.sign(d) * a * a / (4 * b), d - b * np.sign(d))
        g = np.where(a < 2 * b, a / (2 * b), 1.0)
    d0 = P["delta0"]
    law = P["k0"] * d0 * np.sinh(db / d0) + P["D"] * g * tr.twist_rate
    assert np.abs(tr.torque_true - law).max() < 1e-3
    assert (np.abs(d) < b).mean() > 0.05  # the motion crosses the gap


@pytest.mark.parametrize("form", R.EFFECT_FORMS["hysteresis"])
def test_hysteresis_loop(form):
    nom = run(1, 3000.0, 1, sr=1000.0).truth
    r = run(1, 3000.0, 1, sr=1000.0, effects={"hysteresis": {"form": form}}).truth

    def loop_energy(tr):
        sel = (tr.t > 3.5) & (tr.t < 58)
        return float(np.trapezoid((tr.torque_true - P["D"] * tr.twist_rate)[sel],
                                  tr.twist[sel]))

    assert abs(loop_energy(nom)) < 10.0  # nominal compliance is loss-free (damping removed)
    assert loop_energy(r) > 20.0
    # loading and unloading branches differ at the same transmitted torque
    load = r[(r.t > 5) & (r.t < 28)]
    unload = r[(r.t > 33) & (r.t < 56)]
    tw_l = np.interp(60e3, load.torque_true, load.twist)
    tw_u = np.interp(60e3, unload.torque_true[::-1], unload.twist[::-1])
    assert tw_u - tw_l > 2e-5


@pytest.mark.parametrize("form", R.EFFECT_FORMS["torque_offset"])
def test_torque_offset_linear_in_s(form):
    nom = run(3)
    d1 = run(3, effects={"torque_offset": {"form": form, "scale": 1.0}}).truth.torque
    d2 = run(3, effects={"torque_offset": {"form": form, "scale": 2.5}}).truth.torque
    a = (d1 - nom.truth.torque).values
    b = (d2 - nom.truth.torque).values
    assert np.abs(a).max() > 100.0
    assert np.allclose(b, 2.5 * a, rtol=1e-9, atol=1e-6)
    if form == "constant":
        assert np.allclose(a, P["off_c"], rtol=1e-9)


def _lag_on_ramp(tr):
    sel = (tr.t > 8) & (tr.t < 26)
    slope = np.gradient(tr.torque_true.values, tr.t.values)[sel]
    return float(np.median((tr.torque_true[sel] - tr.torque[sel]) / slope))


@pytest.mark.parametrize("form,expect", [("pure_delay", "del_d"), ("first_order_lag", "del_tau")])
def test_time_delay_adds_lag(form, expect):
    nom = run(1, 3000.0, 1, sr=1000.0).truth
    for s in (1.0, 2.0):
        r = run(1, 3000.0, 1, sr=1000.0, effects={"time_delay": {"form": form, "scale": s}})
        assert _lag_on_ramp(r.truth) - _lag_on_ramp(nom) == pytest.approx(s * P[expect],
                                                                           rel=0.02)


def test_periodic_disturbance_is_time_periodic():
    nom = run(3, sr=1000.0).truth
    r = run(3, sr=1000.0, effects={"periodic_disturbance": {"form": "single_tone"}}).truth
    d = (r.torque_true - nom.torque_true).values
    spec = np.abs(np.fft.rfft(d - d.mean()))
    f = np.fft.rfftfreq(len(d), 1e-3)
    assert abs(f[np.argmax(spec)] - P["pd_f"]) < 0.1


def test_position_dependent_stiffness_law():
    tr = run(3, sr=1000.0,
             effects={"position_dependent_stiffness": {"form": "cos_two_per_rev"}}).truth
    d0 = P["delta0"]
    kq = 1 + P["ps_a"] * np.cos(2 * tr.q + P["ps_ph"])
    law = kq * P["k0"] * d0 * np.sinh(tr.twist / d0) + P["D"] * tr.twist_rate
    assert np.abs(tr.torque_true - law).max() < 1e-3


def test_encoder_drift_reading():
    nom = run(3, sr=1000.0)
    r = run(3, sr=1000.0, effects={"sensor_drift": {"form": "encoder_drift"}})
    d = (r.samples.q - nom.samples.q).values
    step = r.meta["sensors"]["q"]["resolution"]
    assert np.abs(d - P["drift_q"] * r.samples.t.values).max() <= step + 1e-12


def test_second_resonance_adds_a_mode():
    nom = run(3, sr=1000.0).truth
    r = run(3, sr=1000.0,
            effects={"second_resonance": {"form": "loading_shaft_mode"}}).truth
    d = (r.torque_true - nom.torque_true).values
    spec = np.abs(np.fft.rfft(d - d.mean()))
    f = np.fft.rfftfreq(len(d), 1e-3)
    band = (f > 1.0)
    assert abs(f[band][np.argmax(spec[band])] - P["sr_f2"]) < 1.5


# ----------------------------------------------------------------------------- sensors
def test_sensor_sheet_noise_and_step():
    r = run(1, 3000.0, 1, sr=1000.0, run=2)
    s, tr, sheet = r.samples, r.truth, r.meta["sensors"]
    res_t = s.torque - tr.torque
    assert np.std(res_t) == pytest.approx(sheet["torque"]["noise_sd"], rel=0.05)
    res_l = s.torque_load - tr.torque_load
    assert np.std(res_l) == pytest.approx(sheet["torque_load"]["noise_sd"], rel=0.05)
    # speed estimates: the filtered truth is reproduced by the stated first-order lag
    for ch, truth_ch in (("qd", "qd"), ("ud", "ud")):
        lag = sheet[ch]["lag_s"]
        x = tr[truth_ch].values
        y = np.empty_like(x)
        y[0] = x[0]
        a = 1 - math.exp(-1e-3 / lag)
        for k in range(1, len(x)):
            y[k] = y[k - 1] + a * (0.5 * (x[k] + x[k - 1]) - y[k - 1])
        assert np.std(s[ch] - y) == pytest.approx(sheet[ch]["noise_sd"], rel=0.06)
    for k in (1, 2, 3):
        assert np.std(s[f"i_m{k}"] - tr[f"i_m{k}"]) == pytest.approx(
            sheet[f"i_m{k}"]["noise_sd"], rel=0.05)
    step = sheet["q"]["resolution"]
    assert step == pytest.approx(math.radians(0.01))
    n = s.q / step
    assert np.abs(n - np.round(n)).max() < 1e-6
    assert np.abs(s.q - tr.q).max() <= sheet["q"]["accuracy_rad"] + 1e-12
    us = sheet["u"]["resolution"]
    assert np.abs(s.u - tr.u).max() < 1e-9 + us
    assert np.abs(s.temp_joint - tr.temp_joint).max() < 0.2


@pytest.mark.parametrize("sr,lag", [(1000.0, 0.0), (1000.0, 0.02), (20.0, 0.0)])
def test_sensor_sheet_torque_lag(sr, lag):
    r = run(1, 3000.0, 1, sr=sr, lag=lag)
    assert _lag_on_ramp(r.truth) == pytest.approx(r.meta["sensors"]["torque"]["lag_s"],
                                                  rel=0.03, abs=2e-4)
