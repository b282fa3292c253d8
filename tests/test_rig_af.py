"""Rig AF (validation_rigs/rig_af.py): interface, argument checks, run format, the nominal
physics of its data sheet (derived again here from the data sheet's formulas, not from the rig's
code) and the sign and size of every effect form (each changes what it should, about linearly in
its scale, and nothing else)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.run import RunData
from core.runfile import read_run, validate_meta, validate_samples, write_run
from validation_rigs import rig_af as R

N = 11000.0
F_C, F_V = 2352.660, 8683.272          # data sheet nominal friction (paper Table 3)
T_RATED = 120_000.0
SEED = 5
W_TOP = 3000 * 2 * math.pi / 60 / N

_cache: dict = {}


def sim(scheme=1, rpm=300, direction=1, temp=25.0, effects=None, periods=1, **kw):
    key = (scheme, rpm, direction, temp, repr(effects), periods, repr(kw))
    if key not in _cache:
        _cache[key] = R.simulate_run(scheme, None if scheme == 3 else rpm, direction, temp,
                                     effects, periods=periods, seed=SEED, run=0, **kw)
    return _cache[key]


def eff(name, form, scale=1.0):
    return {name: {"form": form, "scale": scale}}


def col(r, name):
    return r.truth[name].to_numpy()


def scol(r, name):
    return r.samples[name].to_numpy(dtype=float)


def settled(r, margin=0.5):
    """Load/unload/hold samples at least `margin` s after the phase last changed."""
    ph = r.samples["phase"].to_numpy()
    t = r.samples["t"].to_numpy()
    change = np.r_[True, ph[1:] != ph[:-1]]
    last = np.maximum.accumulate(np.where(change, t, -np.inf))
    return np.isin(ph, ("load", "unload", "hold")) & (t - last >= margin)


def K(m, d):
    """Data sheet 2: K(Δ) = k0·Δ + k_h·sgn(Δ)·|Δ|^1.5, k0, k_h from twist_rated and ρ."""
    dr, rho = m["twist_rated"], m["stiff_ratio"]
    k0 = T_RATED / (dr * (1 + (rho - 1) / 1.5))
    kh = (rho - 1) * k0 / (1.5 * math.sqrt(dr))
    return k0 * d + kh * np.sign(d) * np.abs(d) ** 1.5


def damper(m, d, rate):
    dr, rho = m["twist_rated"], m["stiff_ratio"]
    k0 = T_RATED / (dr * (1 + (rho - 1) / 1.5))
    c0 = 2 * m["zeta_t"] * math.sqrt(k0 * m["I"])
    return c0 * (1 + np.abs(d) / dr) * rate


def law(m, d, rate):
    return K(m, d) + damper(m, d, rate)


def gravity(m, q):
    return 9.81 * (m["mr_x"] * np.sin(q) + m["mr_y"] * np.cos(q))


def balance(r):
    """T − τ_L − gravity − I·q̈ − friction − disturbance (zero for the nominal bench)."""
    m = r.params
    return (col(r, "torque") - col(r, "torque_load") - gravity(m, col(r, "q"))
            - m["I"] * col(r, "qdd") - col(r, "friction") - col(r, "disturbance"))


# --- interface ------------------------------------------------------------------------------------

def test_interface_constants():
    assert R.RIG_NAME == "rig_af" and R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True and R.SCALE_MAX == 10.0
    names = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
             "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction",
             "periodic_disturbance", "position_dependent_stiffness", "encoder_drift",
             "second_resonance")
    assert tuple(R.EFFECT_FORMS) == names
    for k, forms in R.EFFECT_FORMS.items():
        assert 2 <= len(forms) <= 4 and len(set(forms)) == len(forms)
    assert R.OUT_OF_VOCABULARY == ("periodic_disturbance", "position_dependent_stiffness",
                                   "encoder_drift", "second_resonance")
    assert set(R.UNSTATED_VOCABULARY) <= set(names[:9]) and len(R.UNSTATED_VOCABULARY) <= 2
    assert all(isinstance(v, str) and len(v) > 80 for v in R.UNSTATED_VOCABULARY.values())
    for name in ("SensorSpec", "RigRun", "simulate_run", "draw_machine", "run_duration",
                 "compliance_torque"):
        assert callable(getattr(R, name))
    assert R.H_STEP <= 2e-4


def test_form_names_are_own():
    ad = {"exponential", "gaussian", "lorentzian", "root_exponential", "coulomb_linear",
          "quadratic_both", "power_flow", "viscous_vogel", "coulomb_multiplicative",
          "additive_both", "output_harmonics", "motor_kinematic", "load_modulated", "constant",
          "settling", "peak_load_shift", "torque_latency", "q_encoder_latency",
          "torque_sample_hold", "bouc_wen_n3", "masing_tanh", "dahl_quadratic", "sharp",
          "tanh_smoothed", "load_closing", "coulomb_positive", "viscous_split",
          "negative_both", "pump_rectified", "fan_modulated", "gaussian_bump",
          "thrice_per_rev", "q_quadratic", "u_linear", "output_absorber", "motor_coupling"}
    ae = {"exponent_1p5", "rational_cubic", "tent", "power_1p5", "saturating_tanh",
          "quadrant_dependent", "arrhenius_viscous", "coulomb_additive", "polynomial_viscous",
          "mesh_sawtooth", "motor_triangle", "dual_order", "linear_creep", "mid_run_step",
          "temperature_coefficient", "torque_fieldbus", "output_encoder_fieldbus",
          "motor_encoder_fieldbus", "prandtl_stops", "bouc_wen_n2", "dead_zone",
          "quadratic_rounded", "spring_loaded", "coulomb_skew", "viscous_reverse_heavier",
          "constant_bias", "hydraulic_ripple", "valve_square", "ramp_in_angle", "octo_lobed",
          "q_ramp", "u_wander", "output_flex_link", "motor_flex_coupling"}
    ours = {f for forms in R.EFFECT_FORMS.values() for f in forms}
    assert not ours & (ad | ae)


@pytest.mark.parametrize("field,value", [
    ("sample_rate_hz", float("nan")), ("sample_rate_hz", 5.0), ("sample_rate_hz", 2000.0),
    ("encoder_res_deg", float("inf")), ("torque_noise", -1.0), ("torque_lag_s", "0.1"),
    ("torque_filter_s", 0.5), ("timing_jitter_s", 0.01), ("qd_noise", True),
    ("motor_encoder_res", None)])
def test_sensor_spec_checks(field, value):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})


def test_sensor_spec_accepts_ints_and_range_ends():
    s = R.SensorSpec(sample_rate_hz=10, torque_noise=0, torque_filter_s=0.0)
    assert isinstance(s.sample_rate_hz, float) and s.sample_rate_hz == 10.0


@pytest.mark.parametrize("kwargs,word", [
    (dict(scheme=4), "scheme"), (dict(scheme=True), "scheme"), (dict(scheme=1.0), "scheme"),
    (dict(motor_speed_rpm=1000), "motor_speed_rpm"),
    (dict(motor_speed_rpm=float("nan")), "motor_speed_rpm"),
    (dict(motor_speed_rpm=None), "motor_speed_rpm"),
    (dict(scheme=3, motor_speed_rpm=300), "motor_speed_rpm"),
    (dict(direction=0), "direction"), (dict(direction=True), "direction"),
    (dict(temp_joint_c=float("nan")), "temp_joint_c"),
    (dict(temp_joint_c=float("inf")), "temp_joint_c"), (dict(temp_joint_c=80.0), "temp_joint_c"),
    (dict(temp_joint_c="25"), "temp_joint_c"),
    (dict(periods=0), "periods"), (dict(periods=2.0), "periods"), (dict(periods=False), "periods"),
    (dict(scheme=2, periods=4, motor_speed_rpm=3000), "periods"),
    (dict(seed=-1), "seed"), (dict(seed=1.5), "seed"), (dict(seed=True), "seed"),
    (dict(run=-2), "run"), (dict(run=None), "run"),
    (dict(sensors={"sample_rate_hz": 10}), "sensors"),
    (dict(effects=[1]), "effects"), (dict(effects={"nope": {"form": "x", "scale": 1}}), "nope"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": 1}}), "form"),
    (dict(effects={"stribeck": {"form": "sech_decay", "scale": float("nan")}}), "scale"),
    (dict(effects={"stribeck": {"form": "sech_decay", "scale": float("inf")}}), "scale"),
    (dict(effects={"stribeck": {"form": "sech_decay", "scale": -0.1}}), "scale"),
    (dict(effects={"stribeck": {"form": "sech_decay", "scale": 10.5}}), "scale"),
    (dict(effects={"stribeck": {"form": "sech_decay", "scale": True}}), "scale"),
    (dict(effects={"stribeck": {"form": "sech_decay", "size": 1}}), "size"),
    (dict(effects={"stribeck": "sech_decay"}), "stribeck"),
])
def test_argument_checks(kwargs, word):
    args = dict(scheme=1, motor_speed_rpm=300, direction=1, temp_joint_c=25.0, seed=1, run=0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=word):
        R.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                       args.pop("temp_joint_c"), args.pop("effects", None), **args)


def test_draw_machine_is_the_campaign():
    a, b, c = R.draw_machine(3), R.draw_machine(3), R.draw_machine(4)
    assert a == b and a != c
    for m in (a, c):
        assert 0.45 <= math.degrees(m["twist_rated"]) <= 0.55
        assert abs(m["share1"] + m["share2"] + m["share3"] - 1) < 1e-12
        assert abs(m["f_c"] / F_C - 1) < 0.06 and abs(m["f_v"] / F_V - 1) < 0.08
    with pytest.raises(ValueError, match="seed"):
        R.draw_machine(-1)


# --- schemes and the run format -------------------------------------------------------------------

ALL_SCHEMES = [(1, 300, 1), (1, 300, -1), (1, 3000, 1), (1, 3000, -1), (2, 300, 1), (2, 300, -1),
               (2, 3000, 1), (2, 3000, -1), (3, None, 1)]


@pytest.mark.parametrize("scheme,rpm,direction", ALL_SCHEMES)
def test_every_scheme_runs_three_periods(scheme, rpm, direction):
    r = sim(scheme, rpm, direction, periods=3, sensors=R.SensorSpec(sample_rate_hz=100.0))
    validate_samples(r.samples, "x.csv")
    validate_meta(r.meta, "x.json")
    t = scol(r, "t")
    assert abs(t[-1] - R.run_duration(scheme, 3)) < 0.02
    q = col(r, "q")
    assert np.abs(q).max() < math.pi - 0.1
    assert np.isfinite(r.samples.drop(columns="phase").to_numpy(dtype=float)).all()
    assert {"twist", "torque"} <= set(r.truth.columns)
    ph = set(r.samples["phase"])
    if scheme == 3:
        assert ph == {"idle", "excite"} and np.all(scol(r, "torque_cmd") == 0)
        assert np.abs(col(r, "torque_load")).max() == 0.0
    else:
        qd = col(r, "qd")[settled(r)]
        w = rpm * 2 * math.pi / 60 / N
        assert np.all(np.sign(qd) == direction)
        u = col(r, "u")
        mean_speed = (u[-1] - u[0]) / (t[-1] - 0.5 * (R.START_T0 + R.START_T1))
        assert mean_speed / (direction * w) == pytest.approx(1.0, abs=0.01)
        assert scol(r, "torque_cmd").max() == pytest.approx(T_RATED)
        assert ("hold" in ph) == (scheme == 2)
        # transmitted torque reaches the rated load (the dynamometer loads positively)
        assert col(r, "torque").max() > 0.97 * T_RATED


def test_run_format_round_trip(tmp_path):
    r = sim(2, 3000, -1, periods=1, sensors=R.SensorSpec(sample_rate_hz=50.0))
    rd = RunData(samples=r.samples, meta=r.meta)
    write_run(rd, tmp_path / "af")
    back = read_run(tmp_path / "af")
    assert list(back.samples.columns) == list(r.samples.columns)
    num = [c for c in r.samples.columns if c != "phase"]
    np.testing.assert_array_equal(back.samples[num].to_numpy(float),
                                  r.samples[num].to_numpy(float))
    assert list(back.samples["phase"]) == list(r.samples["phase"])
    assert back.meta == r.meta
    s = r.meta["sensors"]
    assert s["q"]["resolution"] == pytest.approx(math.radians(0.01))
    assert s["torque"]["lag_s"] == pytest.approx(1.5e-3) and s["torque"]["noise_sd"] == 110.0
    assert r.meta["source"] == "emulator" and r.meta["rig"] == "rig_af"


def test_seed_draws_machine_and_run_draws_noise():
    a = R.simulate_run(3, None, 1, 25.0, periods=1, seed=SEED, run=1,
                       sensors=R.SensorSpec(sample_rate_hz=20.0))
    b = R.simulate_run(3, None, 1, 25.0, periods=1, seed=SEED, run=1,
                       sensors=R.SensorSpec(sample_rate_hz=20.0))
    c = R.simulate_run(3, None, 1, 25.0, periods=1, seed=SEED, run=2,
                       sensors=R.SensorSpec(sample_rate_hz=20.0))
    assert a.samples.equals(b.samples)
    assert a.params["k0"] == c.params["k0"]
    assert not np.allclose(scol(a, "torque"), scol(c, "torque"))


# --- nominal physics, re-derived from the data sheet -----------------------------------------------

def test_compliance_law_from_data_sheet():
    m = R.draw_machine(SEED)
    dr, rho = m["twist_rated"], m["stiff_ratio"]
    assert K(m, dr) == pytest.approx(T_RATED, rel=1e-12)
    h = 1e-9
    slope = lambda d: (K(m, d + h) - K(m, d - h)) / (2 * h)      # noqa: E731
    assert slope(dr) / slope(1e-7) == pytest.approx(rho, rel=2e-3)
    d = np.linspace(-1.2 * dr, 1.2 * dr, 11)
    np.testing.assert_allclose(R.compliance_torque(d, m), K(m, d), rtol=1e-12)


@pytest.mark.parametrize("scheme,rpm,direction", [(1, 300, 1), (2, 3000, -1), (3, None, 1)])
def test_nominal_transmission_and_output_balance(scheme, rpm, direction):
    r = sim(scheme, rpm, direction)
    m = r.params
    tw, rate, T = col(r, "twist"), col(r, "twist_rate"), col(r, "torque")
    assert np.abs(T - law(m, tw, rate)).max() < 2.0
    assert np.abs(balance(r)).max() < 1.0
    assert np.abs(col(r, "disturbance")).max() == 0 and np.abs(col(r, "hysteresis")).max() == 0


@pytest.mark.parametrize("scheme,rpm,direction", [(1, 300, 1), (1, 300, -1), (2, 3000, -1)])
def test_steady_sliding_friction_is_eq4(scheme, rpm, direction):
    r = sim(scheme, rpm, direction)
    m = r.params
    qd = col(r, "qd")
    sel = settled(r)
    expect = m["f_c"] * np.sign(qd) + m["f_v"] * qd
    assert np.abs(col(r, "friction")[sel] - expect[sel]).max() < 5.0


def test_presliding_at_reversals_is_bounded_bliman_sorine():
    """Scheme 3: F − f_v·q̇ never leaves ±(1+ρ)·f_c (the Bliman–Sorine envelope) and equals
    ±f_c once the output has slid far past its last reversal."""
    r = sim(3, None, 1)
    m = r.params
    qd, q = col(r, "qd"), col(r, "q")
    coul = col(r, "friction") - m["f_v"] * qd
    assert np.abs(coul).max() <= (1 + m["bs_rho"]) * m["f_c"] * 1.02
    # path since the last velocity reversal
    rev = np.r_[True, np.sign(qd[1:]) != np.sign(qd[:-1])]
    last_q = q[np.maximum.accumulate(np.where(rev, np.arange(len(q)), 0))]
    far = np.abs(q - last_q) > 20 * m["bs_eps"]
    assert far.sum() > 1000
    np.testing.assert_allclose(coul[far], m["f_c"] * np.sign(qd[far]), atol=0.02 * m["f_c"])


def test_scheme3_follows_the_fourier_reference():
    r = sim(3, None, -1)
    t = scol(r, "t")
    pos, vel, _ = R.fourier_reference(t - R.LEAD_S)
    vel0 = R.fourier_reference(0.0)[1]
    ex = r.samples["phase"].to_numpy() == "excite"
    u = col(r, "u")
    ref = u[0] - pos
    assert np.abs(u[ex] - ref[ex]).max() < 2e-4
    assert np.abs(col(r, "qd")).max() < 1.02 * W_TOP
    assert abs(vel0) < 1e-12


def test_scheme2_holds_and_dynamometer():
    r = sim(2, 3000, 1)
    ph = r.samples["phase"].to_numpy()
    idx = np.flatnonzero(ph == "hold")
    segs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    assert len(segs) == 12
    t = scol(r, "t")
    for k, s in enumerate(segs):
        assert t[s[-1]] - t[s[0]] == pytest.approx(2.0, abs=0.03)
        late = s[t[s] > t[s[0]] + 0.6]
        # Table 11: the loading error inside ±2 kN·m
        assert abs(col(r, "torque_load")[late].mean() - 10_000 * (k + 1)) < 2000.0


def test_sensors_as_stated():
    r = sim(1, 300, 1)
    m, s, meta = r.params, R.SensorSpec(), r.meta
    step = math.radians(0.01)
    q = scol(r, "q")
    np.testing.assert_allclose(q / step, np.round(q / step), atol=1e-6)
    assert np.abs(q - col(r, "q")).max() <= step / 2 + 1e-12
    np.testing.assert_allclose(scol(r, "torsion"), q - scol(r, "u"), atol=1e-15)
    # the sample instants: k/fs plus a jitter within its stated bound
    t = scol(r, "t")
    k = np.arange(len(t))
    assert np.abs(t - k / 1000.0).max() <= meta["timing_jitter_s"] + 1e-12
    assert np.abs(t - k / 1000.0).max() > 0.5 * meta["timing_jitter_s"]
    # torque: truth through a lag of 1.5 ms (the Bessel group delay) plus white noise
    sel = settled(r)
    T = col(r, "torque")
    lagged = np.interp(t - meta["sensors"]["torque"]["lag_s"], t, T)
    resid = scol(r, "torque") - lagged
    assert abs(resid[sel].std() / s.torque_noise - 1) < 0.05
    assert abs(resid[sel].mean()) < 10.0
    assert np.abs(col(r, "torque_sensor") - lagged)[sel].max() < 5.0
    # currents: Σ kt·i·N·η = τ_m
    i_sum = sum(m[f"kt{j}"] * scol(r, f"i_m{j}") for j in (1, 2, 3)) * N * 0.9
    assert np.abs(i_sum - col(r, "motor_torque")).mean() < 3 * 1.25 * 0.02 * N * 0.9
    np.testing.assert_allclose(scol(r, "w_m1") / N, col(r, "ud"), atol=6 * s.ud_noise)
    assert np.abs(scol(r, "temp_joint") - 25.0).max() < 0.3


# --- effects --------------------------------------------------------------------------------------
# Each form runs at scales 1 and 2 on a configuration where it shows; `metric` measures its
# contribution (against the nominal run, same seed/run: same noise); the sign is checked, the
# ratio must be ≈ 2, and `exact` re-derives the effect from the data sheet's formula.

A = dict(scheme=1, rpm=300, direction=1)
B = dict(scheme=1, rpm=300, direction=-1)
C = dict(scheme=1, rpm=3000, direction=-1)
D = dict(scheme=3, rpm=None, direction=1)
E = dict(scheme=1, rpm=3000, direction=-1, temp=50.0)
G = dict(scheme=1, rpm=3000, direction=1)
F = dict(scheme=2, rpm=3000, direction=1)


def walther(theta):
    a_, b_ = R.WALTHER_A, R.WALTHER_B
    return 10 ** (10 ** (a_ - b_ * np.log10(theta + 273.15))) - 0.7


def friction_model(r, name=None, form=None, s=0.0):
    """The data sheet's steady-sliding friction with one effect (section 5)."""
    m = r.params
    fc, fv = m["f_c"], m["f_v"]
    v, T, th = col(r, "qd"), col(r, "torque"), col(r, "temp_joint")
    av = np.abs(v)
    L = np.full_like(v, fc)
    fvel = np.full_like(v, fv)
    dvis = np.zeros_like(v)
    if form == "stretched_exp_0p8":
        L += s * 0.2 * fc * np.exp(-(av / 3.0e-3) ** 0.8)
    elif form == "plateau_ramp":
        L += s * 0.2 * fc * np.clip((8.0e-3 - av) / 6.5e-3, 0, 1)
    elif form == "sech_decay":
        L += s * 0.2 * fc / np.cosh(av / 3.0e-3)
    elif form == "dead_band_coulomb":
        L += s * 0.02 * np.maximum(np.abs(T) - 30_000, 0)
    elif form == "load_scaled_viscous":
        dvis += s * 3.0 * np.abs(T) / T_RATED * fv
    elif form == "backdrive_coulomb":
        P = T * v
        L += s * 0.015 * np.abs(T) * 0.5 * (1 - P / np.sqrt(P ** 2 + 400.0))
    elif form == "walther_viscous":
        dvis += s * (np.sqrt(walther(th) / walther(25.0)) - 1) * fv
    elif form == "coulomb_thermal_slope":
        L += -s * 0.006 * (th - 25) * fc
    elif form == "exp_decay_both":
        e = np.exp(-0.012 * (th - 25)) - 1
        L += s * e * fc
        dvis += s * e * fv
    elif form == "heavier_negative_coulomb":
        L = np.where(v < 0, L * (1 + 0.25 * s), L)
    elif form == "steeper_positive_viscous":
        fvel = np.where(v > 0, fvel * (1 + 0.35 * s), fvel)
    elif form == "mirror_skew":
        L = np.where(v > 0, L * (1 + 0.12 * s), L * (1 - 0.12 * s))
        fvel = np.where(v > 0, fvel * (1 - 0.15 * s), fvel * (1 + 0.15 * s))
    return L * np.sign(v) + (fvel + dvis) * v


FRICTION_CASES = [
    ("stribeck", "stretched_exp_0p8", A, 1), ("stribeck", "plateau_ramp", A, 1),
    ("stribeck", "sech_decay", B, -1),
    ("load_dependent_friction", "dead_band_coulomb", A, 1),
    ("load_dependent_friction", "load_scaled_viscous", C, -1),
    ("load_dependent_friction", "backdrive_coulomb", C, -1),
    ("temperature_friction", "walther_viscous", E, 1),
    ("temperature_friction", "coulomb_thermal_slope", E, 1),
    ("temperature_friction", "exp_decay_both", E, 1),
    ("asymmetric_friction", "heavier_negative_coulomb", B, -1),
    ("asymmetric_friction", "steeper_positive_viscous", G, 1),
    ("asymmetric_friction", "mirror_skew", A, 1),
]


def _run(cfg, effects=None):
    c = dict(cfg)
    return sim(c.pop("scheme"), c.pop("rpm"), c.pop("direction"), c.pop("temp", 25.0),
               effects=effects)


@pytest.mark.parametrize("name,form,cfg,sign", FRICTION_CASES)
def test_friction_effects(name, form, cfg, sign):
    nom = _run(cfg)
    sel = settled(nom)
    base = np.abs(col(nom, "torque") - law(nom.params, col(nom, "twist"),
                                           col(nom, "twist_rate"))).max()
    size = []
    for s in (1.0, 2.0):
        r = _run(cfg, eff(name, form, s))
        m = r.params
        fr = col(r, "friction")
        excess = fr - friction_model(r)
        expect = friction_model(r, name, form, s) - friction_model(r)
        assert np.abs(excess - expect)[sel].max() < 0.01 * np.abs(expect[sel]).max() + 20.0
        size.append(excess[sel].mean())
        # nothing else: the transmission law and the output balance stay as they were
        assert np.abs(col(r, "torque") - law(m, col(r, "twist"),
                                             col(r, "twist_rate"))).max() < base + 2.0
        assert np.abs(balance(r)).max() < 1.0
    assert np.sign(size[0]) == sign and abs(size[0]) > 40.0
    assert size[1] / size[0] == pytest.approx(2.0, rel=0.1)


def test_direction_bound_friction_forms_leave_the_other_direction():
    for form, cfg in (("heavier_negative_coulomb", A), ("steeper_positive_viscous", B)):
        nom = _run(cfg)
        r = _run(cfg, eff("asymmetric_friction", form, 2.0))
        sel = settled(nom)
        assert np.abs(col(r, "friction") - col(nom, "friction"))[sel].max() < 5.0
    nom = _run(A)
    r = _run(A, eff("load_dependent_friction", "backdrive_coulomb", 2.0))
    sel = settled(nom)
    assert np.abs(col(r, "friction") - col(nom, "friction"))[sel].max() < 60.0
    # a temperature law is zero at the reference 25 °C
    r = _run(A, eff("temperature_friction", "exp_decay_both", 2.0))
    assert np.abs(col(r, "friction") - col(nom, "friction"))[sel].max() < 5.0


def _ripple_E(q):
    return 5e-5 * (np.sin(72 * q) + 0.35 * np.sin(71 * q + 0.4) + 0.35 * np.sin(73 * q + 1.1))


def transmission_model(r, form, s):
    """The data sheet's transmitted torque with one transmission-side effect (section 5)."""
    m = r.params
    d, rate, q, u = col(r, "twist"), col(r, "twist_rate"), col(r, "q"), col(r, "u")
    dr, th = m["twist_rated"], col(r, "temp_joint")
    if form == "mesh_kinematic_sidebands":
        de = d - s * _ripple_E(q)
        return law(m, de, rate)
    if form == "motor_1x_3x":
        de = d - s * 1.2e-5 * (np.sin(N * u + 0.3) + 0.6 * np.sin(3 * N * u + 1.2))
        return law(m, de, rate)
    if form == "load_growing_mesh":
        return law(m, d, rate) + s * 700 * (0.25 + np.abs(K(m, d)) / T_RATED) * np.sin(48 * q + 0.5)
    if form in ("crisp_gap", "thermal_gap"):
        b = s * 3e-4 * (1 if form == "crisp_gap" else np.maximum(1 + 0.025 * (th - 25), 0))
        dz = np.where(d > b, d - b, np.where(d < -b, d + b, 0.0))
        return K(m, dz) + damper(m, dz, rate) * (np.abs(d) > b)
    if form == "hyperbolic_soft_gap":
        b = s * 3e-4
        e = 0.6 * b
        a1, a2 = d - b, d + b
        s1, s2 = np.sqrt(a1 ** 2 + e ** 2), np.sqrt(a2 ** 2 + e ** 2)
        dz = 0.5 * (a1 + s1) + 0.5 * (a2 - s2)
        dzp = 0.5 * (1 + a1 / s1) + 0.5 * (1 - a2 / s2)
        return K(m, dz) + damper(m, dz, rate) * dzp
    if form == "elliptic_2x":
        return np.maximum(1 + 0.08 * s * np.cos(2 * q + 0.3), 0.2) * K(m, d) + damper(m, d, rate)
    if form == "sector_sigmoid":
        mult = np.maximum(1 + 0.07 * s * q / np.sqrt(q ** 2 + 0.25 ** 2), 0.2)
        return mult * K(m, d) + damper(m, d, rate)
    raise AssertionError(form)


TRANSMISSION_CASES = [
    ("gear_ripple", "mesh_kinematic_sidebands", A, 2.0),
    ("gear_ripple", "motor_1x_3x", C, 8.0),
    ("gear_ripple", "load_growing_mesh", A, 2.0),
    ("backlash", "crisp_gap", A, 10.0),
    ("backlash", "hyperbolic_soft_gap", A, 10.0),
    ("backlash", "thermal_gap", E, 10.0),
    ("position_dependent_stiffness", "elliptic_2x", C, 2.0),
    ("position_dependent_stiffness", "sector_sigmoid", C, 2.0),
]


@pytest.mark.parametrize("name,form,cfg,tol", TRANSMISSION_CASES)
def test_transmission_effects(name, form, cfg, tol):
    nom = _run(cfg)
    sel = settled(nom)
    size = []
    for s in (1.0, 2.0):
        r = _run(cfg, eff(name, form, s))
        m = r.params
        T = col(r, "torque")
        model = transmission_model(r, form, s)
        assert np.abs(T - model)[sel].max() < tol
        dev = T - law(m, col(r, "twist"), col(r, "twist_rate"))
        size.append(dev[sel])
        # nothing else: friction and the output balance as nominal
        assert np.abs(balance(r)).max() < 1.0
        # (away from a gap crossing, where a back-driven output may turn round)
        firm = sel & (np.abs(col(nom, "torque")) > 5000.0)
        assert np.abs(col(r, "friction") - friction_model(r))[firm].max() < 5.0
    rms = [np.sqrt(np.mean(x ** 2)) for x in size]
    assert rms[0] > 60.0
    assert rms[1] / rms[0] == pytest.approx(2.0, rel=0.2)
    if name == "backlash":   # a gap: more twist for the same torque, i.e. T below the law
        assert np.mean(size[0]) < 0


def _hyst_replay(r, form, s):
    """The data sheet's hysteretic torque replayed on the sampled twist."""
    m = r.params
    d = col(r, "twist")
    dr = m["twist_rated"]
    h = np.zeros_like(d)
    if form == "preisach_relays":
        c, w = np.meshgrid(np.linspace(-0.9, 0.9, 8) * dr, np.linspace(0.04, 0.5, 8) * dr,
                           indexing="ij")
        c, w = c.ravel(), w.ravel()
        rel = np.where(d[0] >= c, 1.0, -1.0)
        for i, x in enumerate(d):
            rel = np.where(x >= c + w, 1.0, np.where(x <= c - w, -1.0, rel))
            h[i] = -s * 1500 * rel.mean()
        return h
    z = 0.0
    for i in range(1, len(d)):
        dd = d[i] - d[i - 1]
        if form == "duhem_envelope":
            target = s * 1200 * np.sign(dd) / (1 + (d[i] / dr) ** 2)
            z = target + (z - target) * math.exp(-abs(dd) / (0.12 * dr))
            h[i] = z
        else:   # n = 1, β = γ = ½: linear while z opposes the motion, exponential after
            a = abs(dd) / (0.1 * dr)
            tgt = 1.0 if dd > 0 else -1.0
            if z * tgt < 0:
                used = min(a, abs(z))
                z += tgt * used
                a -= used
            z = tgt + (z - tgt) * math.exp(-a)
            h[i] = s * 1000 * z
    return h


@pytest.mark.parametrize("form", R.EFFECT_FORMS["hysteresis"])
def test_hysteresis_effects(form):
    nom = _run(A)
    sel = settled(nom)
    loops = []
    for s in (1.0, 2.0):
        r = _run(A, eff("hysteresis", form, s))
        m = r.params
        d, T = col(r, "twist"), col(r, "torque")
        h = T - law(m, d, col(r, "twist_rate"))
        np.testing.assert_allclose(h, col(r, "hysteresis"), atol=2.0)
        top = {"preisach_relays": 1500, "duhem_envelope": 1200}.get(form, 1000)
        assert np.abs(h).max() <= s * top * 1.001
        rep = _hyst_replay(r, form, s)
        assert np.mean(np.abs(rep - h)[sel]) < 0.03 * s * top
        # dissipative: ∮ h dΔ > 0 over the load cycle
        loops.append(np.sum(0.5 * (h[1:] + h[:-1]) * np.diff(d)))
        assert np.abs(balance(r)).max() < 1.0
        assert np.abs(col(r, "friction") - friction_model(r))[sel].max() < 5.0
    assert loops[0] > 0.0
    assert loops[1] / loops[0] == pytest.approx(2.0, rel=0.1)


# sensor-side effects: compare the readings with the nominal run's (same noise)

def _lag_estimate(dx, rate):
    """Least-squares lag d of dx ≈ −rate·d."""
    return -np.sum(dx * rate) / np.sum(rate * rate)


@pytest.mark.parametrize("form,chan,cfg,lag", [
    ("torque_bus_latency", "torque", A, 5e-3),
    ("q_channel_lag", "q", C, 8e-3),
    ("u_channel_lag", "u", C, 6e-3)])
def test_time_delay_forms(form, chan, cfg, lag):
    nom = _run(cfg)
    t = scol(nom, "t")
    others = {"torque", "q", "u", "qd", "ud", "torsion", "w_m1", "w_m2", "w_m3"}
    moved = {"torque": {"torque"}, "q": {"q", "qd", "torsion"},
             "u": {"u", "ud", "torsion", "w_m1", "w_m2", "w_m3"}}[chan]
    for s in (1.0, 2.0):
        r = _run(cfg, eff("time_delay", form, s))
        sel = settled(nom)
        rate = {"torque": np.gradient(col(nom, "torque_sensor"), t), "q": col(nom, "qd"),
                "u": col(nom, "ud")}[chan]
        est = _lag_estimate((scol(r, chan) - scol(nom, chan))[sel], rate[sel])
        assert est == pytest.approx(s * lag, rel=0.1)
        for c in others - moved:
            np.testing.assert_array_equal(scol(r, c), scol(nom, c))
        assert r.truth.equals(nom.truth)


@pytest.mark.parametrize("form", R.EFFECT_FORMS["torque_offset"])
def test_torque_offset_forms(form):
    nom = _run(A)
    t = scol(nom, "t")
    res = R.SensorSpec().torque_res
    for s in (1.0, 2.0):
        r = _run(A, eff("torque_offset", form, s))
        diff = scol(r, "torque") - scol(nom, "torque")
        if form == "jump_after_unload":
            T = col(nom, "torque")
            t_on = t[np.flatnonzero(np.maximum.accumulate(T) - T >= 5000)[0]]
            t_jump = t[np.flatnonzero(diff > 350 * s)[0]]
            assert abs(t_jump - t_on) <= 2e-3
            expect = s * 700 * (t >= t_jump)
            assert R.S1_HALF + R.LEAD_S < t_on < R.S1_HALF + R.LEAD_S + 1.0
        elif form == "log_creep":
            expect = s * 150 * np.log1p(t / 5.0)
        else:
            expect = s * 450 * np.sin(2 * math.pi * t / 150.0)
        assert np.abs(diff - expect).max() <= res * 1.01 + 1e-9 + (3.0 if form == "jump_after_unload" else 0)
        assert np.abs(expect).max() > 250 * s
        for c in ("q", "u", "qd", "ud", "torque_load", "i_m1"):
            np.testing.assert_array_equal(scol(r, c), scol(nom, c))
        assert r.truth.equals(nom.truth)
    r = _run(D, eff("torque_offset", "jump_after_unload", 1.0))
    np.testing.assert_array_equal(scol(r, "torque"), scol(_run(D), "torque"))


@pytest.mark.parametrize("form,chan", [("q_saturating_creep", "q"), ("u_root_creep", "u")])
def test_encoder_drift_forms(form, chan):
    nom = _run(A)
    t = scol(nom, "t")
    step = math.radians(0.01) if chan == "q" else R.SensorSpec().motor_encoder_res
    for s in (1.0, 2.0):
        r = _run(A, eff("encoder_drift", form, s))
        drift = (s * 2.5e-3 * (1 - np.exp(-t / 60)) if chan == "q"
                 else s * 2.0e-3 * np.sqrt(t / 100))
        truth = col(nom, chan) + drift
        assert np.abs(scol(r, chan) - truth).max() <= step / 2 + 1e-12
        assert drift.max() > 4 * step
        other = "u" if chan == "q" else "q"
        np.testing.assert_array_equal(scol(r, other), scol(nom, other))
        np.testing.assert_array_equal(scol(r, "torque"), scol(nom, "torque"))
        assert r.truth.equals(nom.truth)


@pytest.mark.parametrize("form,f0", [("pump_pulsation", 1.7), ("beating_fan", 0.9)])
def test_periodic_disturbance_forms(form, f0):
    nom = _run(D)
    t = scol(nom, "t")
    amps = []
    for s in (1.0, 2.0):
        r = _run(D, eff("periodic_disturbance", form, s))
        if form == "pump_pulsation":
            d = s * 450 * (np.sin(2 * np.pi * 1.7 * t) + 0.4 * np.sin(2 * np.pi * 3.4 * t + 1))
        else:
            d = s * 350 * np.sin(2 * np.pi * 0.9 * t) * (1 + 0.6 * np.sin(2 * np.pi * 0.04 * t))
        np.testing.assert_allclose(col(r, "disturbance"), d, atol=0.5 * s)
        assert np.abs(balance(r)).max() < 1.0
        m = r.params
        assert np.abs(col(r, "torque") - law(m, col(r, "twist"), col(r, "twist_rate"))).max() < 2
        # the measured torque carries the line at f0 (the transmission passes it through)
        dt = scol(r, "torque") - scol(nom, "torque")
        c = np.exp(-2j * np.pi * f0 * t)
        amps.append(2 * abs(np.mean(dt * c)))
    assert amps[0] > 150.0
    assert amps[1] / amps[0] == pytest.approx(2.0, rel=0.15)


@pytest.mark.parametrize("form,f0", [("tip_mass_mode", 14.0), ("dyno_shaft_mode", 20.0)])
def test_second_resonance_forms(form, f0):
    nom = _run(F)
    t = scol(nom, "t")
    sizes = []
    for s in (1.0, 2.0):
        r = _run(F, eff("second_resonance", form, s))
        m = r.params
        assert np.abs(col(r, "torque") - law(m, col(r, "twist"), col(r, "twist_rate"))).max() < 2
        if form == "tip_mass_mode":
            x = balance(r)          # the coupling torque of the extra inertia
        else:
            assert np.abs(balance(r)).max() < 1.0
            x = col(r, "torque_load") - col(nom, "torque_load")
        sizes.append(np.sqrt(np.mean(x ** 2)))
        x = x - np.convolve(x, np.ones(101) / 101, mode="same")
        spec = np.abs(np.fft.rfft(x * np.hanning(len(x))))
        fr = np.fft.rfftfreq(len(x), d=np.median(np.diff(t)))
        band = (fr > 12.0) & (fr < 32.0)      # above the output mode and the step harmonics
        peak = fr[band][np.argmax(spec[band])]
        assert peak == pytest.approx(f0, rel=0.2)
    assert sizes[1] / sizes[0] == pytest.approx(2.0, rel=0.35)


def test_every_form_is_covered():
    covered = {(n, f) for n, f, _, _ in FRICTION_CASES} | {(n, f) for n, f, _, _ in
                                                           TRANSMISSION_CASES}
    covered |= {("hysteresis", f) for f in R.EFFECT_FORMS["hysteresis"]}
    covered |= {("time_delay", f) for f in R.EFFECT_FORMS["time_delay"]}
    covered |= {("torque_offset", f) for f in R.EFFECT_FORMS["torque_offset"]}
    covered |= {("encoder_drift", f) for f in R.EFFECT_FORMS["encoder_drift"]}
    covered |= {("periodic_disturbance", f) for f in R.EFFECT_FORMS["periodic_disturbance"]}
    covered |= {("second_resonance", f) for f in R.EFFECT_FORMS["second_resonance"]}
    assert covered == {(n, f) for n, fs in R.EFFECT_FORMS.items() for f in fs}
