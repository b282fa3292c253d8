"""Preprocessing (dropouts, filtering, derivatives, twist sign, decimation) and the models as
compositions of shared terms, effects included."""

import numpy as np
import pandas as pd
import pytest

from estimator.identify import build_dataset, identify
from estimator.models import eq4, eq5, eq11, linear_model, model_from_spec
from estimator.preprocess import PrepOptions, concat_signals, prepare
from core import effects as fx
from core.params import JointParams
from core.run import RunData
from core.terms import eq4_regressor

from estimator_synth import EQ4_TRUTH, eq4_run, eq11_run

P = JointParams()


def _sine_run(fs=100.0, n=2000, nan_rows=()):
    t = np.arange(n) / fs
    q = 0.3 * np.sin(0.5 * t)
    df = pd.DataFrame({"t": t, "q": q, "u": q + 1e-3 * np.cos(0.2 * t),
                       "torque": 1000 * np.sin(0.5 * t), "temp_m1": 20.0})
    df.loc[list(nan_rows), "q"] = np.nan
    df.loc[5, "temp_m1"] = np.nan  # a dropout in a channel the model does not use
    return RunData(df, {"sample_rate_hz": fs})


def test_derivatives_twist_and_load_defaults():
    s = prepare(_sine_run(), ["q", "qd", "qdd", "torsion", "torsion_rate", "torque_load"])
    t = s["t"]
    assert np.allclose(s["qd"], 0.15 * np.cos(0.5 * t), atol=1e-5)
    assert np.allclose(s["qdd"], -0.075 * np.sin(0.5 * t), atol=1e-5)
    # twist Δ = u − q (rig.md), its rate by central differences
    assert np.allclose(s["torsion"], 1e-3 * np.cos(0.2 * t))
    assert np.allclose(s["torsion_rate"], -2e-4 * np.sin(0.2 * t), atol=1e-8)
    assert np.all(s["torque_load"] == 0) and s.info["has_torque_load"] is False
    # the run format's torsion channel is q − u: it is negated
    r = _sine_run()
    r.samples["torsion"] = r.samples["q"] - r.samples["u"]
    s2 = prepare(r, ["torsion"])
    assert np.allclose(s2["torsion"], (r.samples["u"] - r.samples["q"]).to_numpy()[s2["index"]])


def test_dropouts_are_never_filled():
    run = _sine_run(nan_rows=range(700, 705))
    s = prepare(run, ["q", "qd", "qdd"], PrepOptions(cutoff_hz=5.0))
    idx = s["index"]
    assert not np.any((idx >= 700) & (idx < 705))            # no invented samples in the gap
    assert np.all(np.diff(idx) > 0)
    assert np.array_equal(s["t"], run.samples["t"].to_numpy()[idx])  # every output is a recorded time
    assert s.info["segments"] == 2 and s.info["rows_missing"] == 5
    assert len(np.unique(s["segment"])) == 2
    # the unused channel's dropout does not remove rows when it is not needed
    assert 5 in prepare(run, ["q"])["index"]
    assert 5 not in prepare(run, ["q", "temp_m1"])["index"]


def test_filter_and_decimation():
    rng = np.random.default_rng(0)
    run = _sine_run(n=4000)
    clean = run.samples["q"].to_numpy().copy()
    run.samples["q"] = clean + 1e-3 * rng.standard_normal(clean.size)
    raw = prepare(run, ["q", "qd"])
    filt = prepare(run, ["q", "qd"], PrepOptions(cutoff_hz=2.0))
    truth = 0.15 * np.cos(0.5 * filt["t"])
    assert np.std(filt["qd"] - truth) < 0.1 * np.std(raw["qd"] - 0.15 * np.cos(0.5 * raw["t"]))
    dec = prepare(run, ["q"], PrepOptions(decimate=10))
    assert dec.info["sample_rate_out_hz"] == 10.0 and dec.info["cutoff_hz"] == pytest.approx(4.0)
    assert np.all(np.diff(dec["index"]) == 10)
    with pytest.raises(ValueError):
        prepare(run, ["q"], PrepOptions(cutoff_hz=80.0))   # above Nyquist
    with pytest.raises(KeyError, match="torque_load|qx"):
        prepare(run, ["qx"])


def test_concat_keeps_runs_and_segments_apart():
    a, b = prepare(_sine_run(), ["q"]), prepare(_sine_run(nan_rows=[100]), ["q"])
    c = concat_signals([a, b])
    assert c.n == a.n + b.n and set(np.unique(c["run"])) == {0, 1}
    assert len(np.unique(c["segment"])) == 1 + 2


def test_eq4_design_is_the_shared_regressor_and_target_subtracts_the_load():
    run = eq4_run(0, duration=10.0)
    m = eq4()
    s = prepare(run, m.requires)
    assert np.array_equal(m.design(s), eq4_regressor(s["q"], s["qd"], s["qdd"], P.v_eps))
    assert np.array_equal(m.target(s), s["torque"] - s["torque_load"])
    assert m.param_names == ["I_xx", "mr_x", "mr_y", "f_v", "f_c"]


def test_effect_columns_are_the_vocabulary_terms_at_unit_magnitude():
    run = eq4_run(0, duration=10.0)
    run.samples["temp_joint"] = 30.0
    m = (eq4().with_effect("stribeck", v_s=0.01).with_effect("gear_ripple", order=12)
         .with_effect("torque_offset").with_effect("temperature_friction")
         .with_effect("load_dependent_friction").with_effect("time_delay")
         .with_effect("asymmetric_friction"))
    assert m.name == "eq4+stribeck+gear_ripple+torque_offset+temperature_friction+" \
                     "load_dependent_friction+time_delay+asymmetric_friction"
    s = prepare(run, m.requires)
    X = m.design(s)
    names = m.param_names
    col = dict(zip(names, X.T))
    assert np.allclose(col["f_s"], fx.stribeck_torque(s["qd"], 1.0, 0.01, P.v_eps))
    assert np.allclose(col["A_sin"], np.sin(12 * s["q"]))
    assert np.allclose(col["A_cos"], np.cos(12 * s["q"]))
    assert np.allclose(col["drift"], s["t"]) and np.allclose(col["c0"], 1.0)
    assert np.allclose(col["c_T"], fx.temperature_friction_torque(s["qd"], 30.0, 1.0, 40.0, P.v_eps))
    assert np.allclose(col["c_Tv"], (40.0 - 30.0) * s["qd"])
    assert np.allclose(col["mu_v"], np.abs(s["torque"]) * s["qd"])
    assert np.allclose(col["mu"], fx.load_dependent_friction_torque(s["qd"], s["torque"], 1.0, P.v_eps))
    assert np.allclose(col["delay"], -s["torque_rate"])
    assert np.allclose(col["d_v"], fx.asymmetric_friction_torque(s["qd"], 0.0, 1.0, P.v_eps))
    # a transmission effect on a law without a twist acts on the position itself
    bl = eq4().with_effect("backlash", b=0.01)
    assert "q" in bl.requires and "torsion" not in bl.requires
    with pytest.raises(ValueError, match="unknown effect"):
        eq4().with_effect("warp_drive")
    with pytest.raises(ValueError, match="magnitude"):
        eq4().with_effect("stribeck", f_s=3.0)
    with pytest.raises(ValueError, match="already"):
        eq11().with_effect("hysteresis")
    assert eq5().with_effect("hysteresis").param_names == ["k", "D", "C", "k_h"]
    assert model_from_spec("eq4+gear_ripple:order=36,phase=0.5").param_names[-1] == "A"


def test_injected_effect_is_recovered_or_reported_inseparable():
    """Data with a gear ripple of unknown phase: eq4+gear_ripple recovers its amplitude and phase
    and the rigid-body parameters when the trajectory spans several ripple periods; when it spans
    less than one (order 36 over 0.08 rad), the identifiability report names the combination of
    ripple and gravity terms the data cannot separate."""
    run = eq4_run(3, duration=120.0)
    s = run.samples
    q = s["q"].to_numpy()
    amp, phase = 400.0, 0.7
    fast = RunData(s.assign(torque=s["torque"] + fx.gear_ripple_torque(q, amp, 400.0, phase)),
                   run.meta)
    fit = identify([fast], "eq4+gear_ripple:order=400", "exact", seed=0)
    j = fit.param_names.index("A_sin")
    a_sin, a_cos = fit.mean[j], fit.mean[j + 1]
    assert np.hypot(a_sin, a_cos) == pytest.approx(amp, rel=0.03)
    assert np.arctan2(a_cos, a_sin) == pytest.approx(phase, abs=0.03)
    z = (fit.mean[:5] - EQ4_TRUTH) / fit.sd[:5]
    assert np.all(np.abs(z) < 2.0), z
    assert fit.extra["identifiability"]["identifiable"]
    slow = RunData(s.assign(torque=s["torque"] + fx.gear_ripple_torque(q, amp, 36.0, phase)),
                   run.meta)
    rep = identify([slow], "eq4+gear_ripple:order=36", "ls").extra["identifiability"]
    assert not rep["identifiable"]
    involved = set(rep["weak_directions"][0]["involved"])
    assert {"mr_x", "mr_y"} <= involved and involved & {"A_sin", "A_cos"}


def test_generic_linear_model_from_named_columns():
    rng = np.random.default_rng(1)
    t = np.arange(3000) * 1e-3
    q = 0.1 * np.sin(7 * t) + 0.02 * np.sin(23 * t)
    qd, qdd = np.gradient(q, t), np.gradient(np.gradient(q, t), t)
    force = 95.0 * qdd + 200.0 * qd + 20.0 * np.sign(qd) - 3.0 + 0.5 * rng.standard_normal(t.size)
    run = RunData(pd.DataFrame({"t": t, "q": q, "force": force}), {"sample_rate_hz": 1000.0})
    m = linear_model("emps", "force", {"M": ("qdd", "kg"), "Fv": ("qd", "N·s/m"),
                                       "Fc": ("sgn(qd)", "N"), "offset": ("1", "N")}, v_eps=1e-9)
    ds = build_dataset(m, [run], PrepOptions(derive_velocity=True))
    theta, *_ = np.linalg.lstsq(ds.X, ds.y, rcond=None)
    assert np.allclose(theta, [95, 200, 20, -3], rtol=0.02, atol=0.1)


def test_eq11_with_known_state_recovers_truth():
    run, theta = eq11_run(0)
    fit = identify([run], "eq11", "exact", bouc_wen={"alpha": P.alpha, "beta": P.beta,
                                                     "gamma": P.gamma, "n": 1})
    z = (fit.mean - theta) / fit.sd
    assert np.all(np.abs(z) < 2.5), z


def test_bouc_wen_models_are_dispatched_to_the_bouc_wen_estimator():
    """eq9, and eq11 without known Bouc–Wen parameters, go to estimator.bouc_wen (E2) with the
    prepared signals and the held-out runs; effects on them are refused."""
    run, theta = eq11_run(1)
    test, _ = eq11_run(2)
    f = identify([run], "eq9", "ls", [test])
    assert f.model == "eq9" and f.param_names[:2] == ["beta", "gamma"]
    assert f.rmse_test == pytest.approx(150.0, rel=0.1)
    assert np.allclose(f.mean[2:], theta, atol=3 * f.sd[2:])
    g = identify([run], "eq11", "ls")
    assert g.model == "eq11" and "beta" in g.param_names
    with pytest.raises(ValueError, match="effect"):
        identify([run], "eq11+torque_offset", "ls")


def test_regression_decimation_filters_x_and_y_alike():
    """decimate=k filters every column of X and y with the same zero-phase low-pass and keeps
    every k-th row: the truth still fits, and white torque noise keeps only the filter's share of
    its variance (0.8/k of the band)."""
    run = eq4_run(7, duration=120.0, fs=200.0)
    full = build_dataset(eq4(), [run])
    dec = build_dataset(eq4(), [run], PrepOptions(decimate=4))
    assert dec.X.shape[0] == pytest.approx(full.X.shape[0] / 4, rel=0.01)
    assert dec.signals[0].info["regression_decimated_by"] == 4
    r = dec.y - dec.X @ EQ4_TRUTH
    assert np.std(r) == pytest.approx(150.0 * np.sqrt(0.8 / 4), rel=0.05)
    fit = identify([run], "eq4", "ls", prep=PrepOptions(decimate=4))
    assert np.all(np.abs((fit.mean - EQ4_TRUTH) / fit.sd) < 2.5)


def test_min_speed_drops_the_stick_rows_only():
    run = eq4_run(7, duration=60.0)
    ds = build_dataset(eq4(), [run], PrepOptions(min_speed=2e-3))
    qd = ds.signals[0]["qd"]
    assert np.all(np.abs(qd) >= 2e-3) and ds.X.shape[0] == qd.size
    full = build_dataset(eq4(), [run])
    dropped = ds.signals[0].info["rows_below_min_speed"]
    assert dropped == np.sum(np.abs(full.signals[0]["qd"]) < 2e-3) and dropped > 0


def test_backlash_dead_zone_is_a_shape_and_k_bl_is_fitted_on_twist_data():
    """Synthetic twist data through a dead zone, T = k·bt(Δ, b) + D·Δ̇ + C + noise: eq5+backlash
    with the true b recovers k and k_bl ≈ k (k·bt(Δ) = k·Δ + k·(bt(Δ) − Δ)), the true b has the
    smallest residual on a grid of b, and b = 0 or a magnitude k_bl given as a shape is refused."""
    from estimator.least_squares import ols
    rng = np.random.default_rng(5)
    t = np.arange(6000) * 0.01
    delta = 4e-3 * np.sin(2 * np.pi * 0.1 * t) + 1e-3 * np.sin(2 * np.pi * 0.37 * t)
    dd = np.gradient(delta, t)
    k, b, D, C = 1.6e7, 6e-4, 2e5, 300.0
    T = k * fx.backlash_twist(delta, b) + D * dd + C + rng.normal(0, 150.0, t.size)
    sig = {"t": t, "torsion": delta, "torsion_rate": dd, "torque": T}
    m = model_from_spec(f"eq5+backlash:b={b}")
    assert m.param_names == ["k", "D", "C", "k_bl"]
    res = ols(m.design(sig), m.target(sig))
    est = dict(zip(m.param_names, res.theta))
    se = dict(zip(m.param_names, res.se))
    for name, truth in (("k", k), ("k_bl", k), ("D", D), ("C", C)):
        assert abs(est[name] - truth) < 4 * se[name], (name, est[name], truth, se[name])
    assert abs(res.sigma - 150.0) < 10.0
    rss = {bb: ols(eq5().with_effect("backlash", b=bb).design(sig), T).rss
           for bb in (2e-4, 4e-4, 6e-4, 8e-4, 1.2e-3)}
    assert min(rss, key=rss.get) == b
    assert eq11().with_effect("backlash", b=b).param_names[-1] == "k_bl"
    with pytest.raises(ValueError, match="b"):
        eq5().with_effect("backlash", b=0.0)
    with pytest.raises(ValueError):
        eq5().with_effect("backlash", k_bl=1.0)


def test_a_motor_ripple_seen_through_the_dynamics_is_fitted_by_its_dynamic_shape():
    """A motor-side ripple (2 cycles per motor turn) reaching the reading through a first-order
    low-pass: at 300 r/min (10 Hz) it passes, at 3000 r/min (100 Hz) it comes through at a
    fifth of its size and late, in either direction. One sine and cosine of the motor angle
    cannot follow that; the `dynamic` shape (the same times |q̇|, q̇ and q̇·|q̇|) fits it
    exactly at the two speeds."""
    n_red, order = 11000.0, 2.0 * 11000.0
    w_lp = 2.0 * np.pi * 20.0                          # the low-pass corner [rad/s]
    parts = []
    for rpm, d in ((300, 1), (3000, -1), (3000, 1), (300, -1)):
        w = d * rpm * 2.0 * np.pi / 60.0 / n_red      # q̇ [rad/s]
        t = np.arange(0.0, 4.0, 1e-3)
        u = w * t + 0.3
        om = order * w                                 # the ripple's frequency [rad/s]
        h = 1.0 / (1.0 + 1j * om / w_lp)
        y = 100.0 * np.imag(h * np.exp(1j * (order * u + 0.4)))
        parts.append({"u": u, "qd": np.full_like(t, w), "y": y})
    s = {k: np.concatenate([p[k] for p in parts]) for k in ("u", "qd", "y")}
    w_ref = float(np.median(np.abs(s["qd"])))
    plain = eq5().with_effect("gear_ripple", order=order, motor=1.0)
    dyn = eq5().with_effect("gear_ripple", order=order, motor=1.0, dynamic=w_ref)
    assert dyn.param_names[-8:] == ["A_sin", "A_cos", "Ca_A_sin", "Ca_A_cos", "Cs_A_sin",
                                    "Cs_A_cos", "Cq_A_sin", "Cq_A_cos"]
    assert len(dyn.param_names) - len(plain.param_names) == 6

    def misfit(m):
        X = m.terms[-1].columns(s)
        coef, *_ = np.linalg.lstsq(X, s["y"], rcond=None)
        return float(np.sqrt(np.mean((s["y"] - X @ coef) ** 2)))
    assert misfit(plain) > 30.0
    assert misfit(dyn) < 1e-6 * misfit(plain)
