"""Contract tests of validation_rigs/rig_m.py (an independent emulation of the CMOR J4 rig)."""

from __future__ import annotations

import dataclasses
import inspect
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from validation_rigs import rig_m as rm

VOCAB = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
         "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction")
OOV = ("periodic_disturbance", "position_dependent_stiffness", "sensor_drift", "second_resonance")
HARNESS_400 = rm.SensorSpec(sample_rate_hz=400.0, encoder_res_deg=0.004, torque_noise=220.0,
                            torque_lag_s=0.006)
HARNESS_60 = rm.SensorSpec(sample_rate_hz=60.0, encoder_res_deg=0.008, torque_noise=280.0)
FAST = rm.SensorSpec(sample_rate_hz=100.0, encoder_res_deg=0.004, torque_noise=220.0)
FINE = rm.SensorSpec(sample_rate_hz=100.0, encoder_res_deg=1e-7, torque_noise=0.0,
                     torque_adc_step=0.0, load_noise=0.0, load_adc_step=0.0)
ALL_FORMS = [(n, f) for n, forms in rm.EFFECT_FORMS.items() for f in forms]


def sim(scheme=3, rpm=None, direction=1, temp=20.0, effects=None, sensors=FAST, periods=1,
        seed=11, run=0):
    return rm.simulate_run(scheme, rpm, direction, temp, effects, sensors=sensors,
                           periods=periods, seed=seed, run=run)


@pytest.fixture(scope="module")
def nominal3():
    return sim()


@pytest.fixture(scope="module")
def campaign400():
    runs = []
    k = 0
    for scheme in (1, 2):
        for rpm in (300.0, 3000.0):
            for d in (1, -1):
                runs.append(rm.simulate_run(scheme, rpm, d, 15.0 + 4 * k, None,
                                            sensors=HARNESS_400, seed=7, run=k))
                k += 1
    for d in (1, -1):
        runs.append(rm.simulate_run(3, None, d, 30.0 + 5 * k, None, sensors=HARNESS_400,
                                    seed=7, run=k))
        k += 1
    return runs


# --- interface -------------------------------------------------------------------------------

def test_module_interface():
    assert rm.SEED_IS_CAMPAIGN is True
    assert rm.REDUCTION == 11000.0
    assert rm.RIG_NAME == "rig_m"
    assert isinstance(rm.SCALE_MAX, float) and rm.SCALE_MAX > 1.0
    assert set(rm.EFFECT_FORMS) == set(VOCAB) | set(OOV)
    assert set(rm.OUT_OF_VOCABULARY) == set(OOV) and isinstance(rm.OUT_OF_VOCABULARY, tuple)
    for name, forms in rm.EFFECT_FORMS.items():
        assert isinstance(forms, tuple) and len(forms) >= 2, name
        assert len(set(forms)) == len(forms)
    fields = {f.name: f for f in dataclasses.fields(rm.SensorSpec)}
    for k in ("sample_rate_hz", "encoder_res_deg", "torque_noise", "torque_lag_s"):
        assert k in fields
    rr = {f.name for f in dataclasses.fields(rm.RigRun)}
    assert {"samples", "meta", "truth", "params", "noise"} <= rr
    sig = inspect.signature(rm.simulate_run)
    assert list(sig.parameters)[:5] == ["scheme", "motor_speed_rpm", "direction", "temp_joint_c",
                                        "effects"]
    for k in ("sensors", "periods", "seed", "run"):
        assert sig.parameters[k].kind is inspect.Parameter.KEYWORD_ONLY
    imports = [line.split()[1].split(".")[0]
               for line in Path(rm.__file__).read_text().splitlines()
               if line.startswith(("import ", "from "))]
    assert set(imports) <= {"__future__", "math", "dataclasses", "numpy", "pandas",
                            "numba", "scipy"}, imports


def test_run_shapes(campaign400):
    for r in campaign400:
        s, tr = r.samples, r.truth
        for c in ("t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint"):
            assert c in s.columns
        for c in ("t", "q", "qd", "qdd", "u", "ud", "twist", "torque", "torque_load", "gravity",
                  "friction", "temp_joint"):
            assert c in tr.columns
        assert len(s) == len(tr) == len(r.noise)
        np.testing.assert_array_equal(s.t.to_numpy(), tr.t.to_numpy())
        assert np.allclose(np.diff(s.t), 1 / 400.0)
        assert np.isfinite(s.drop(columns="phase").to_numpy(dtype=float)).all()
        np.testing.assert_allclose(tr.twist, tr.u - tr.q)


# --- run format --------------------------------------------------------------------------------

def test_meta_and_samples_pass_validators(campaign400):
    from core.runfile import validate_meta, validate_samples
    runs = list(campaign400[:1]) + list(campaign400[4:5]) + list(campaign400[-1:])
    runs.append(sim(1, 300.0, -1, 45.0, sensors=HARNESS_60))
    for r in runs:
        validate_meta(r.meta, "rig_m.json")
        out = validate_samples(r.samples, "rig_m.csv")
        assert len(out) == len(r.samples)
        m = r.meta
        assert m["source"] == "emulator" and m["rig"] == "rig_m"
        assert m["reduction"] == 11000.0
        assert m["sample_rate_hz"] == r.samples.t.diff().median() ** -1 or math.isclose(
            m["sample_rate_hz"], 1 / r.samples.t.diff().median(), rel_tol=1e-9)
        for ch in ("q", "qd", "u", "ud", "torque", "torque_load", "temp_joint"):
            assert set(m["sensors"][ch]) == {"resolution", "noise_sd", "lag_s"}
        assert "temp_joint_c" in m and "direction" in m and "motor_speed_rpm" in m
        assert isinstance(m["sensor_units"], dict)
    assert campaign400[-1].meta["motor_speed_rpm"] is None
    assert campaign400[0].meta["motor_speed_rpm"] == 300.0


def test_phases_and_load_sign(campaign400):
    for r in campaign400:
        s, tr, m = r.samples, r.truth, r.meta
        d = m["direction"]
        ph = s.phase.to_numpy()
        seq = [ph[0]] + [p for a, p in zip(ph[:-1], ph[1:]) if p != a]
        if m["scheme"] == 1:
            assert seq == ["idle", "load", "unload", "idle"]
        elif m["scheme"] == 2:
            assert seq[:3] == ["idle", "load", "hold"] and seq[-2:] == ["unload", "idle"]
            assert seq.count("hold") == 12
            holds = np.diff(np.flatnonzero(np.diff((ph == "hold").astype(int)) != 0))[::2]
            assert np.allclose(holds / m["sample_rate_hz"], 2.0, atol=0.01)
        else:
            assert seq == ["idle", "excite", "idle"]
        loaded = np.abs(s.torque_cmd) > 20e3
        assert loaded.sum() > 100
        if m["scheme"] in (1, 2):
            # the dynamometer resists the motion; the output moves in `direction`
            assert np.all(np.sign(s.torque_load[loaded]) == d)
            assert np.all(np.sign(s.torque[loaded]) == d)
            assert np.sign(tr.q.iloc[-1]) == d
            assert np.abs(s.torque_cmd).max() == pytest.approx(120e3)
            top = np.abs(tr.torque_load).max()
            assert 118e3 < top < 122.5e3
        else:
            assert np.mean(np.sign(tr.torque_load[loaded]) == np.sign(tr.qd[loaded])) > 0.97
            assert np.abs(tr.q).max() < math.pi
            assert np.abs(tr.qd).max() < 1.05 * rm.V_TOP


# --- sensors ---------------------------------------------------------------------------------

def test_stated_torque_noise_is_real(campaign400):
    for r in campaign400[:3] + campaign400[-1:]:
        s, tr = r.samples, r.truth
        lag = r.meta["sensors"]["torque"]["lag_s"]
        assert lag == 0.006
        ref = np.interp(s.t - lag, tr.t, tr.torque)
        resid = s.torque - ref
        sd = r.meta["sensors"]["torque"]["noise_sd"]
        assert sd == 220.0
        assert np.std(resid) == pytest.approx(sd, rel=0.04)
        assert abs(np.mean(resid)) < 100.0        # only a small unstated offset
        assert np.std(r.noise.torque) == pytest.approx(sd, rel=0.04)
    r = sim(1, 300.0, 1, 30.0, sensors=HARNESS_60)
    resid = r.samples.torque - r.truth.torque
    assert np.std(resid) == pytest.approx(280.0, rel=0.06)
    assert r.meta["sensors"]["torque"]["noise_sd"] == 280.0


def test_stated_torque_lag_is_applied():
    spec = dataclasses.replace(FAST, sample_rate_hz=400.0, torque_noise=20.0, torque_lag_s=0.015)
    r = sim(sensors=spec)
    s, tr = r.samples, r.truth
    assert r.meta["sensors"]["torque"]["lag_s"] == 0.015
    lags = np.arange(0.0, 0.0301, 0.0025)
    err = [np.std(s.torque - np.interp(s.t - L, tr.t, tr.torque)) for L in lags]
    assert lags[int(np.argmin(err))] == pytest.approx(0.015)
    assert min(err) == pytest.approx(20.0, rel=0.1)
    assert err[0] > 3 * min(err)
    # the harness's 400 Hz variant
    r = sim(sensors=HARNESS_400)
    err = [np.std(r.samples.torque - np.interp(r.samples.t - L, r.truth.t, r.truth.torque))
           for L in (0.0, 0.006)]
    assert err[1] < err[0]


def test_stated_encoder_step_is_real(campaign400):
    for r, deg in ((campaign400[2], 0.004), (campaign400[-1], 0.004),
                   (sim(1, 3000.0, -1, 30.0, sensors=HARNESS_60), 0.008)):
        step = r.meta["sensors"]["q"]["resolution"]
        assert step == pytest.approx(math.radians(deg))
        k = r.samples.q.to_numpy() / step
        assert np.allclose(k, np.round(k), atol=1e-6)
        dk = np.unique(np.round(np.diff(k)))
        assert 1.0 in np.abs(dk)
        # the reading is the truth seen through the step (plus a sub-step imperfection)
        assert np.abs(r.samples.q - r.truth.q).max() < 1.6 * step
        # qd is the encoder difference over the stated window: multiples of its resolution
        kd = r.samples.qd.to_numpy() / r.meta["sensors"]["qd"]["resolution"]
        assert np.allclose(kd, np.round(kd), atol=1e-6)
        su = r.meta["sensors"]["u"]["resolution"]
        ku = r.samples.u.to_numpy() / su
        assert np.allclose(ku, np.round(ku), atol=1e-3)


def test_torque_reading_follows_truth(campaign400):
    for r in campaign400:
        s, tr = r.samples, r.truth
        c = np.corrcoef(s.torque, tr.torque)[0, 1]
        assert c > 0.999
        cl = np.corrcoef(s.torque_load, tr.torque_load)[0, 1]
        assert cl > 0.999
        assert np.abs(s.temp_joint - tr.temp_joint).max() < 0.5
        lag_l = r.meta["sensors"]["torque_load"]["lag_s"]
        resid = s.torque_load - np.interp(s.t - lag_l, tr.t, tr.torque_load)
        sd_l = r.meta["sensors"]["torque_load"]["noise_sd"]
        assert np.std(resid) == pytest.approx(sd_l, rel=0.06)
        # velocities follow the truth within their stated windows
        assert np.corrcoef(s.ud, tr.ud)[0, 1] > 0.99


# --- reproducibility ------------------------------------------------------------------------

def test_deterministic():
    a, b = sim(seed=5, run=2), sim(seed=5, run=2)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    pd.testing.assert_frame_equal(a.noise, b.noise)
    assert a.meta == b.meta


def test_same_seed_other_run_is_same_rig_other_noise():
    a, b = sim(seed=5, run=0), sim(seed=5, run=1)
    assert a.params["rig"] == b.params["rig"]
    assert not np.allclose(a.noise.torque, b.noise.torque)
    assert not np.allclose(a.samples.torque, b.samples.torque)
    c = sim(seed=6, run=0)
    assert c.params["rig"]["I"] != a.params["rig"]["I"]


def test_params_drawn_near_the_data_sheet():
    for seed in range(6):
        rig = sim(1, 3000.0, 1, 30.0, seed=seed).params["rig"] if seed == 0 else \
            rm._draw_rig(seed)
        for k, v in rm.DATASHEET.items():
            assert rig[k] == pytest.approx(v, rel=0.1), k
            assert np.sign(rig[k]) == np.sign(v)
    a, b = rm._draw_rig(1), rm._draw_rig(2)
    assert any(a[k] != b[k] for k in rm.DATASHEET)


# --- effects ---------------------------------------------------------------------------------

def test_scale_zero_is_nominal_bit_for_bit(nominal3):
    for name, form in ALL_FORMS:
        r = sim(effects={name: {"form": form, "scale": 0.0}})
        pd.testing.assert_frame_equal(r.samples, nominal3.samples, check_exact=True)
        pd.testing.assert_frame_equal(r.truth, nominal3.truth, check_exact=True)
    several = {n: {"form": fs[-1], "scale": 0.0} for n, fs in rm.EFFECT_FORMS.items()}
    r = sim(effects=several)
    pd.testing.assert_frame_equal(r.samples, nominal3.samples, check_exact=True)
    r = sim(effects={})
    pd.testing.assert_frame_equal(r.samples, nominal3.samples, check_exact=True)


def test_noise_independent_of_effects(nominal3):
    everything = {n: {"form": fs[0], "scale": 1.0} for n, fs in rm.EFFECT_FORMS.items()}
    r = sim(effects=everything)
    pd.testing.assert_frame_equal(r.noise, nominal3.noise, check_exact=True)
    assert not r.samples.torque.equals(nominal3.samples.torque)


def test_scale_clamped(nominal3):
    eff = lambda s: {"stribeck": {"form": "gaussian", "scale": s}}  # noqa: E731
    hi = sim(effects=eff(10.0))
    mx = sim(effects=eff(rm.SCALE_MAX))
    pd.testing.assert_frame_equal(hi.samples, mx.samples, check_exact=True)
    assert hi.params["effects"]["stribeck"]["scale"] == rm.SCALE_MAX
    lo = sim(effects=eff(-2.0))
    pd.testing.assert_frame_equal(lo.samples, nominal3.samples, check_exact=True)


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_form_changes_the_samples(name, form, nominal3):
    r = sim(effects={name: {"form": form, "scale": 1.0}})
    cols = ["q", "qd", "u", "ud", "torque", "torque_load"]
    changed = [c for c in cols if not np.array_equal(r.samples[c], nominal3.samples[c])]
    assert changed, (name, form)
    # forms of one effect differ from each other
    if form != rm.EFFECT_FORMS[name][0]:
        r0 = sim(effects={name: {"form": rm.EFFECT_FORMS[name][0], "scale": 1.0}})
        assert not r0.samples[cols].equals(r.samples[cols])


def test_contributions_scale_linearly():
    cols = ["q", "qd", "u", "ud", "torque", "torque_load"]
    base = sim(sensors=FINE).samples
    spread = {c: np.std(base[c]) for c in cols}
    bad = []
    for name, form in ALL_FORMS:
        c = {}
        for s in (0.5, 1.0):
            r = sim(sensors=FINE, effects={name: {"form": form, "scale": s}}).samples
            c[s] = {k: np.sqrt(np.mean((r[k] - base[k]) ** 2)) for k in cols}
        k = max(cols, key=lambda k: c[1.0][k] / spread[k])
        ratio = c[1.0][k] / c[0.5][k]
        if not 1.5 < ratio < 2.5:
            bad.append((name, form, k, ratio))
    assert not bad, bad


def test_scale_one_is_visible_in_the_torque_or_twist():
    """Scale 1 is a clearly visible effect: against the torque noise on the torque channels, or
    against the encoder step on the twist / angle."""
    base = sim(temp=15.0, sensors=HARNESS_400)
    step = math.radians(0.004)
    for name, forms in rm.EFFECT_FORMS.items():
        if name == "second_resonance":
            continue   # visible as a line in the spectrum rather than in RMS
        seen = []
        for form in forms:
            r = sim(temp=15.0, sensors=HARNESS_400, effects={name: {"form": form, "scale": 1.0}})
            dT = np.sqrt(np.mean((r.samples.torque - base.samples.torque) ** 2))
            dL = np.sqrt(np.mean((r.samples.torque_load - base.samples.torque_load) ** 2))
            dq = np.sqrt(np.mean((r.samples.q - base.samples.q) ** 2))
            seen.append(max(dT / 220.0, dL / 150.0, dq / step))
        assert max(seen) > 0.6, (name, seen)
        assert min(seen) > 0.1, (name, seen)


# --- physics ---------------------------------------------------------------------------------

def test_eq4_balance_holds_on_nominal_truth(campaign400):
    for r in campaign400:
        tr, p = r.truth, r.params["rig"]
        lhs = p["I"] * tr.qdd
        rhs = tr.torque - tr.torque_load - tr.gravity - tr.friction
        assert np.abs(lhs - rhs).max() < 1e-6 * np.abs(tr.torque).max()
        np.testing.assert_allclose(
            tr.gravity, 9.81 * (p["mr_x"] * np.sin(tr.q) + p["mr_y"] * np.cos(tr.q)), rtol=1e-12)
        assert np.all(r.truth.other_torque == 0.0)


def test_friction_is_coulomb_plus_viscous_in_steady_sliding(campaign400):
    for r in campaign400[:8]:
        tr, p = r.truth, r.params["rig"]
        v = r.meta["direction"] * r.meta["motor_speed_rpm"] * 2 * math.pi / 60 / 11000
        steady = (tr.t > 5.0) & (np.abs(tr.qd - v) < 0.5 * abs(v)) & (np.abs(tr.qdd) < 0.05)
        assert steady.sum() > 0.5 * len(tr)
        model = p["f_c"] * np.sign(tr.qd) + p["f_v"] * tr.qd
        err = (tr.friction - model)[steady]
        assert np.abs(err).max() < 0.02 * p["f_c"]
        assert np.abs(err).mean() < 0.005 * p["f_c"]


def test_presliding_at_reversals(nominal3):
    """Velocity reversals pass through a presliding regime: the friction changes sign over a
    finite time, not as a jump."""
    tr = nominal3.truth
    f = tr.friction.to_numpy()
    fc = nominal3.params["rig"]["f_c"]
    crossing = np.flatnonzero(np.diff(np.sign(tr.qd.to_numpy())) != 0)
    crossing = crossing[(tr.t.to_numpy()[crossing] > 1.5)]
    assert len(crossing) >= 2
    for i in crossing[:4]:
        assert abs(f[i]) < 1.05 * fc
        assert np.abs(np.diff(f[i - 3:i + 4])).max() < 1.5 * fc


def test_twist_torque_law_is_elastic_and_stiffening(campaign400):
    r = campaign400[2]           # scheme 1, 3000 r/min
    tr, p = r.truth, r.params["rig"]
    d = tr.twist.to_numpy()
    model = p["k0"] * d + p["k2"] * d * np.abs(d)
    dyn = tr.torque - model
    assert np.abs(dyn).max() < 0.02 * np.abs(tr.torque).max()
    top = np.abs(tr.torque) > 115e3
    assert 0.4 < np.degrees(np.abs(d[top])).mean() < 0.6


# --- arguments -------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs,culprit", [
    (dict(scheme=4), "scheme"),
    (dict(scheme=0), "scheme"),
    (dict(scheme="1"), "scheme"),
    (dict(direction=0), "direction"),
    (dict(direction=2), "direction"),
    (dict(motor_speed_rpm=300.0), "motor_speed_rpm"),       # scheme 3 takes None
    (dict(scheme=1, motor_speed_rpm=None), "motor_speed_rpm"),
    (dict(scheme=1, motor_speed_rpm=float("nan")), "motor_speed_rpm"),
    (dict(scheme=1, motor_speed_rpm=float("inf")), "motor_speed_rpm"),
    (dict(scheme=2, motor_speed_rpm=-300.0), "motor_speed_rpm"),
    (dict(temp_joint_c=float("nan")), "temp_joint_c"),
    (dict(periods=0), "periods"),
    (dict(seed=-1), "seed"),
    (dict(run=1.5), "run"),
    (dict(sensors=rm.SensorSpec(sample_rate_hz=float("nan"))), "sample_rate_hz"),
    (dict(sensors=rm.SensorSpec(sample_rate_hz=-10.0)), "sample_rate_hz"),
    (dict(sensors=rm.SensorSpec(sample_rate_hz=float("inf"))), "sample_rate_hz"),
    (dict(sensors=rm.SensorSpec(encoder_res_deg=0.0)), "encoder_res_deg"),
    (dict(sensors=rm.SensorSpec(torque_noise=-1.0)), "torque_noise"),
    (dict(sensors=rm.SensorSpec(torque_lag_s=float("nan"))), "torque_lag_s"),
    (dict(sensors=rm.SensorSpec(torque_lag_s=-0.1)), "torque_lag_s"),
    (dict(effects={"friction_wobble": {"form": "x", "scale": 1.0}}), "friction_wobble"),
    (dict(effects={"stribeck": {"form": "cubic", "scale": 1.0}}), "cubic"),
    (dict(effects={"stribeck": {"form": "gaussian", "scale": float("nan")}}), "scale"),
])
def test_bad_arguments_raise_naming_the_culprit(kwargs, culprit):
    args = dict(scheme=3, motor_speed_rpm=None, direction=1, temp_joint_c=25.0, effects=None,
                sensors=FAST, periods=1, seed=1, run=0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=culprit):
        rm.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                        args.pop("temp_joint_c"), args.pop("effects"), **args)


# --- the harness's variants ----------------------------------------------------------

def test_sixty_hertz_variant():
    runs = [sim(s, rpm, d, 20.0 + 8 * i, sensors=HARNESS_60, seed=3, run=i, periods=3)
            for i, (s, rpm, d) in enumerate([(1, 300.0, 1), (1, 3000.0, -1), (2, 300.0, -1),
                                             (2, 3000.0, 1), (3, None, 1), (3, None, -1)])]
    for r in runs:
        assert np.allclose(np.diff(r.samples.t), 1 / 60.0)
        assert r.meta["sample_rate_hz"] == 60.0
        assert r.meta["sensors"]["torque"]["lag_s"] == 0.0
        assert r.meta["sensors"]["q"]["resolution"] == pytest.approx(math.radians(0.008))
        tr, p = r.truth, r.params["rig"]
        rhs = tr.torque - tr.torque_load - tr.gravity - tr.friction
        assert np.abs(p["I"] * tr.qdd - rhs).max() < 1e-6 * np.abs(tr.torque).max()
