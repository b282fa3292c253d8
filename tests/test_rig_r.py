"""Contract and physics tests of the independent validation rig validation_rigs/rig_r.py."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pandas as pd
import pytest

from core.run import RunData
from core.runfile import read_run, validate_meta, validate_samples, write_run
from validation_rigs import rig_r as R

VOCABULARY = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
              "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction")
SENSOR_EFFECTS = ("torque_offset", "time_delay", "sensor_drift")
TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.660}
SEED = 11


@cache
def _run(scheme: int, speed: float | None, direction: int = 1, effects: tuple = (),
         fs: float = 100.0, res: float = 0.01, noise: float = 150.0, lag: float = 0.0,
         periods: int = 1, seed: int = SEED, run: int = 0, temp: float = 25.0) -> R.RigRun:
    eff = {name: {"form": form, "scale": scale} for name, form, scale in effects} or None
    sensors = R.SensorSpec(sample_rate_hz=fs, encoder_res_deg=res, torque_noise=noise,
                           torque_lag_s=lag)
    return R.simulate_run(scheme, speed, direction, temp, eff, sensors=sensors, periods=periods,
                          seed=seed, run=run)


def _gravity(q, machine=None) -> np.ndarray:
    m = machine or TABLE3
    return 9.81 * (m["mr_x"] * np.sin(q) + m["mr_y"] * np.cos(q))


# --- interface -----------------------------------------------------------------------------

def test_module_names():
    assert R.RIG_NAME == "rig_r"
    assert R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True
    assert R.SCALE_MAX > 1.0
    assert set(R.EFFECT_FORMS) == set(VOCABULARY) | set(R.OUT_OF_VOCABULARY)
    assert R.OUT_OF_VOCABULARY == ("periodic_disturbance", "position_stiffness", "sensor_drift",
                                   "second_resonance")
    for name, forms in R.EFFECT_FORMS.items():
        assert len(forms) >= 3 and len(set(forms)) == len(forms), name
    assert len(R.EFFECT_FORMS["stribeck"]) >= 4
    assert set(R.UNSTATED_VOCABULARY) <= set(VOCABULARY)
    assert all(isinstance(v, str) and v for v in R.UNSTATED_VOCABULARY.values())
    assert R.SensorSpec() == R.SensorSpec(100.0, 0.01, 150.0, 0.0)


@pytest.mark.parametrize("field,value", [
    ("sample_rate_hz", float("nan")), ("sample_rate_hz", 0.0), ("sample_rate_hz", float("inf")),
    ("encoder_res_deg", -0.01), ("encoder_res_deg", float("nan")), ("torque_noise", -1.0),
    ("torque_noise", float("inf")), ("torque_lag_s", -0.1), ("torque_lag_s", float("nan")),
    ("load_noise", -1.0)])
def test_sensor_spec_refuses_bad_fields(field, value):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})


_OK = {"scheme": 1, "motor_speed_rpm": 300.0, "direction": 1, "temp_joint_c": 25.0}


@pytest.mark.parametrize("change,match", [
    ({"scheme": 4}, "scheme"), ({"scheme": True}, "scheme"), ({"scheme": 1.5}, "scheme"),
    ({"motor_speed_rpm": None}, "motor_speed_rpm"), ({"motor_speed_rpm": 0.0}, "motor_speed"),
    ({"motor_speed_rpm": 3001.0}, "motor_speed"), ({"motor_speed_rpm": float("nan")}, "motor"),
    ({"scheme": 3}, "None"), ({"direction": 0}, "direction"), ({"direction": 2}, "direction"),
    ({"temp_joint_c": float("nan")}, "temp_joint_c"), ({"temp_joint_c": 500.0}, "temp_joint"),
    ({"effects": {"nonsense": {"form": "x", "scale": 1.0}}}, "stribeck"),
    ({"effects": {"stribeck": {"form": "cubic", "scale": 1.0}}}, "exp1"),
    ({"effects": {"stribeck": {"form": "exp1", "scale": R.SCALE_MAX * 1.01}}}, "scale"),
    ({"effects": {"stribeck": {"form": "exp1", "scale": -0.1}}}, "scale"),
    ({"effects": {"stribeck": {"form": "exp1", "scale": float("nan")}}}, "scale"),
    ({"effects": {"stribeck": {"form": "exp1"}}}, "stribeck"),
    ({"effects": {"stribeck": "exp1"}}, "stribeck"),
    ({"periods": 0}, "periods"), ({"seed": -1}, "seed"), ({"run": 1.5}, "run"),
    ({"sensors": "fast"}, "SensorSpec"),
])
def test_argument_checks(change, match):
    kwargs = dict(_OK, seed=1, run=0) | change
    with pytest.raises(ValueError, match=match):
        R.simulate_run(**kwargs)


def test_scheme3_refuses_a_speed():
    with pytest.raises(ValueError, match="None"):
        R.simulate_run(3, 300.0, 1, 25.0, seed=1, run=0)


def test_mutated_sensor_spec_is_refused():
    spec = R.SensorSpec()
    spec.torque_noise = float("nan")
    with pytest.raises(ValueError, match="torque_noise"):
        R.simulate_run(3, None, 1, 25.0, sensors=spec, periods=1, seed=1, run=0)


# --- determinism, seeds, noise ---------------------------------------------------------------

def test_deterministic():
    a = _run(3, None)
    b = R.simulate_run(3, None, 1, 25.0, sensors=R.SensorSpec(), periods=1, seed=SEED, run=0)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    assert a.meta == b.meta


def test_seed_is_the_campaign_run_is_the_noise():
    a, b, c = _run(3, None), _run(3, None, run=1), _run(3, None, seed=SEED + 1)
    pd.testing.assert_frame_equal(a.truth, b.truth)          # the same machine
    assert a.params["machine"] == b.params["machine"]
    assert a.params["unstated"] == b.params["unstated"]
    assert not np.array_equal(a.samples.torque, b.samples.torque)   # other noise
    assert a.params["machine"]["f_c"] != c.params["machine"]["f_c"]  # another machine
    assert not np.array_equal(a.truth.torque, c.truth.torque)


def test_runs_differing_by_an_effect_share_their_noise():
    a = _run(1, 300.0)
    b = _run(1, 300.0, effects=(("torque_offset", "constant", 1.0),))
    d = (b.samples.torque - a.samples.torque).to_numpy()
    assert np.all(np.abs(d - 300.0) <= R.ADC_STEP + 1e-9)
    pd.testing.assert_series_equal(a.samples.torque_load, b.samples.torque_load)
    pd.testing.assert_frame_equal(a.truth, b.truth)


# --- run format ----------------------------------------------------------------------------------

@pytest.mark.parametrize("scheme,speed", [(1, 3000.0), (2, 300.0), (3, None)])
def test_run_format_is_valid(scheme, speed, tmp_path):
    r = _run(scheme, speed, direction=-1)
    validate_meta(r.meta, "meta")
    samples = validate_samples(r.samples, "samples")
    assert list(samples.columns[:1]) == ["t"]
    for col in ("t", "q", "qd", "u", "torque", "torque_load", "torque_cmd", "temp_joint",
                "phase", "i_m1", "w_m1", "temp_m1", "torsion", "ud"):
        assert col in r.samples.columns
    for col in ("t", "q", "qd", "twist", "torque", "torque_load"):
        assert col in r.truth.columns
    assert len(r.truth) == len(r.samples)
    np.testing.assert_array_equal(r.truth.t, r.samples.t)
    m = r.meta
    assert m["scheme"] == scheme and m["direction"] == -1 and m["reduction"] == 11000.0
    assert m["rig"] == "rig_r" and m["source"] == "emulator" and m["sample_rate_hz"] == 100.0
    assert m["motor_speed_rpm"] == speed
    assert ("periods" in m) == (scheme == 3)
    assert "effects" not in m
    assert set(r.samples.phase.unique()) <= {"idle", "load", "hold", "unload", "excite"}
    assert np.isfinite(r.samples.drop(columns="phase").to_numpy()).all()
    back = read_run(write_run(RunData(samples=r.samples, meta=r.meta), tmp_path / "run")[0])
    assert len(back.samples) == len(r.samples)


def test_stated_sensors():
    r = _run(2, 3000.0, res=0.005, noise=80.0, lag=0.02)
    s = r.meta["sensors"]
    res = math.radians(0.005)
    assert s["q"]["resolution"] == pytest.approx(res)
    steps = r.samples.q.to_numpy() / res
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    assert s["torque"]["noise_sd"] == 80.0
    assert s["torque"]["lag_s"] == pytest.approx(0.02, abs=1e-3)
    assert s["torque_load"]["lag_s"] < 1e-3
    assert 0.0 < s["qd"]["lag_s"] < 0.05
    for ch in s.values():
        assert set(ch) <= {"resolution", "noise_sd", "lag_s"}
    # the stated noise is what the reading carries (differences remove the smooth part)
    e = (r.samples.torque - r.truth.torque).to_numpy()
    sd = np.std(np.diff(e)) / math.sqrt(2)
    assert sd == pytest.approx(80.0, rel=0.15)


def test_stated_torque_lag_is_a_pure_lag():
    lag = 0.05
    r = _run(2, 300.0, fs=1000.0, lag=lag, noise=0.0)
    u = r.params["unstated"]
    t = r.truth.t.to_numpy()
    true_t = r.truth.torque.to_numpy()
    meas = r.samples.torque.to_numpy()
    td = t - lag
    expected = ((1 + u["torque_gain_error"]) * np.interp(td, t, true_t) + u["torque_zero_nm"]
                + u["torque_zero_drift_nm_per_min"] * np.clip(td, 0, None) / 60.0)
    ok = t > 1.0
    err = np.abs(meas - expected)[ok]
    assert np.percentile(err, 99) < R.ADC_STEP + 10.0      # the amplifier's 0.3 ms aside
    assert np.abs(meas - true_t)[ok].max() > 10 * err.max()


def test_unstated_imperfections_are_small_and_present():
    u = _run(3, None).params["unstated"]
    assert 0 < abs(u["torque_zero_nm"]) <= 75
    assert 3e-3 <= u["load_cell_extra_lag_s"] <= 5e-3
    assert abs(u["torque_gain_error"]) <= 2e-3 and abs(u["load_gain_error"]) <= 2e-3
    assert abs(u["temp_offset_c"]) <= 0.5


# --- physics against the paper ---------------------------------------------------------------

@pytest.mark.parametrize("speed,direction", [(3000.0, 1), (3000.0, -1), (300.0, 1),
                                             (300.0, -1)])
def test_steady_sliding_friction_is_eq4(speed, direction):
    r = _run(1, speed, direction=direction)
    s, tr, m = r.samples, r.truth, r.params["machine"]
    moving = (s.t > 6.0) & (s.t < 57.0)
    qd = tr.qd[moving].mean()
    assert direction * qd > 0
    # measured: torque − load − gravity (the inertia term is nil at constant speed)
    f_meas = (s.torque - s.torque_load - _gravity(s.q))[moving].mean()
    f_table = np.sign(qd) * TABLE3["f_c"] + TABLE3["f_v"] * qd
    assert f_meas == pytest.approx(f_table, rel=0.08)
    f_machine = np.sign(qd) * m["f_c"] + m["f_v"] * qd
    f_true = (tr.torque - tr.torque_load - _gravity(tr.q, m))[moving].mean()
    assert f_true == pytest.approx(f_machine, rel=0.005)
    assert f_meas == pytest.approx(f_machine, rel=0.03)


@pytest.mark.parametrize("speed", [300.0, 3000.0])
def test_constant_speed_is_the_commanded_speed(speed):
    r = _run(1, speed, direction=-1)
    sl = (r.samples.t > 3.6) & (r.samples.t < 4.9)
    expected = -speed * 2 * math.pi / 60 / R.REDUCTION
    assert r.samples.qd[sl].mean() == pytest.approx(expected, rel=0.02)
    assert r.samples.ud[sl].mean() == pytest.approx(expected, rel=0.01)
    assert r.samples.w_m1[sl].mean() == pytest.approx(expected * R.REDUCTION, rel=0.01)


def test_twist_is_torque_over_stiffness():
    r = _run(1, 3000.0)
    s, tr, m = r.samples, r.truth, r.params["machine"]
    hold = (s.phase == "hold").to_numpy()
    twist_meas = -(s.torsion[hold]).mean()          # torsion = q − u
    assert twist_meas == pytest.approx(s.torque[hold].mean() / 1.375e7, rel=0.10)
    assert math.degrees(twist_meas) == pytest.approx(0.5, rel=0.12)
    # the true law: k·Δ·(1 + c3·(Δ/Δ_r)²) (+ damping, nil at constant twist)
    d = tr.twist[hold].to_numpy()
    law = m["k"] * d * (1 + m["c3"] * (d / m["twist_rated"]) ** 2)
    np.testing.assert_allclose(tr.torque[hold], law, rtol=2e-3)
    # at a quarter of the load, the spring is close to linear
    quarter = ((s.phase == "load") & (tr.torque > 29e3) & (tr.torque < 31e3)).to_numpy()
    assert (tr.torque[quarter] / tr.twist[quarter]).mean() == pytest.approx(m["k"], rel=0.01)


def test_scheme1_load_profile():
    r = _run(1, 300.0)
    s = r.samples
    assert 50.0 <= s.t.iloc[-1] <= 80.0
    assert s.torque_cmd.max() == pytest.approx(120e3)
    assert s.torque_load.max() == pytest.approx(120e3, abs=2e3)      # Table 11: ±2 kN·m
    assert abs(s.torque_load.iloc[-1]) < 2e3 and abs(s.torque_load.iloc[0]) < 1e3
    phases = [p for i, p in enumerate(s.phase) if i == 0 or p != s.phase.iloc[i - 1]]
    assert phases == ["idle", "load", "hold", "unload", "idle"]
    load = (s.phase == "load").to_numpy()
    assert np.all(np.diff(s.torque_cmd[load]) >= 0)
    assert np.abs(s.q).max() < math.pi


def test_scheme2_load_steps():
    r = _run(2, 3000.0, direction=-1)
    s = r.samples
    assert 50.0 <= s.t.iloc[-1] <= 80.0
    hold = (s.phase == "hold").to_numpy()
    levels = np.unique(np.round(s.torque_cmd[hold] / 1e3))
    np.testing.assert_array_equal(levels, np.arange(10, 130, 10))
    for lv in levels:
        sl = hold & (np.round(s.torque_cmd / 1e3) == lv).to_numpy()
        assert (s.t[sl].iloc[-1] - s.t[sl].iloc[0]) == pytest.approx(2.0, abs=0.05)
        settled = sl & (s.t > s.t[sl].iloc[0] + 0.5).to_numpy()
        assert s.torque_load[settled].mean() == pytest.approx(lv * 1e3, abs=2e3)
    assert np.abs(s.q).max() < math.pi


def test_scheme3_excitation():
    r = _run(3, None, periods=2)
    s, tr = r.samples, r.truth
    assert s.t.iloc[-1] == pytest.approx(2 * R.FOURIER_PERIOD)
    assert set(s.phase) == {"excite"}
    assert np.all(s.torque_cmd == 0.0)
    assert np.abs(s.torque_load).max() < 2e3
    assert np.abs(tr.qd).max() <= 1.05 * R.OMEGA_MAX
    assert np.abs(tr.q).max() < math.pi
    # it reverses, and the two periods repeat
    assert (tr.qd > 1e-3).any() and (tr.qd < -1e-3).any()
    n = int(R.FOURIER_PERIOD * 100)
    np.testing.assert_allclose(tr.q[n:2 * n].to_numpy(), tr.q[:n].to_numpy(), atol=2e-4)
    mirrored = _run(3, None, direction=-1, periods=2)
    assert np.corrcoef(mirrored.truth.q, tr.q)[0, 1] < -0.99


def test_stiction_at_reversals():
    """At a reversal the body sticks while the motor winds up the transmission: the friction
    passes from one Coulomb level to the other through the bristle spring over tens of ms (Eq. 4's
    sgn would flip at once), and the twist changes by about 2·f_c/k meanwhile."""
    r = _run(3, None, fs=1000.0)
    tr, m = r.truth, r.params["machine"]
    f, tw = tr.friction.to_numpy(), tr.twist.to_numpy()
    crossings = np.flatnonzero(np.diff(np.sign(f)) != 0)
    assert len(crossings) >= 2
    for i in crossings:
        a = i
        while a > 0 and abs(f[a]) < 0.9 * m["f_c"]:
            a -= 1
        b = i
        while b < len(f) - 1 and abs(f[b]) < 0.9 * m["f_c"]:
            b += 1
        assert b - a >= 50
        assert abs(tw[b] - tw[a]) * m["k"] == pytest.approx(1.8 * m["f_c"], rel=0.2)


def test_sample_rate_does_not_change_the_physics():
    a = _run(1, 3000.0, fs=100.0)
    b = _run(1, 3000.0, fs=1000.0)
    c = _run(1, 3000.0, fs=10.0)
    for col in ("q", "twist", "torque", "torque_load"):
        np.testing.assert_array_equal(a.truth[col].to_numpy(), b.truth[col].to_numpy()[::10])
        np.testing.assert_array_equal(c.truth[col].to_numpy(), a.truth[col].to_numpy()[::10])
    d = _run(1, 3000.0, fs=300.0)       # a rate that does not divide the internal step
    assert d.params["internal_step_s"] <= 2e-4
    np.testing.assert_allclose(d.truth.torque.to_numpy()[::3], b.truth.torque.to_numpy()[::10],
                               atol=20.0)


# --- effects -------------------------------------------------------------------------------------

ALL_FORMS = [(n, f) for n, forms in R.EFFECT_FORMS.items() for f in forms]


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_form_changes_the_run(name, form):
    speed = 300.0 if name == "stribeck" else 3000.0      # Stribeck lives at low speed
    base = _run(1, speed, fs=20.0)
    r = _run(1, speed, fs=20.0, effects=((name, form, 1.0),))
    assert r.params["effects"] == {name: {"form": form, "scale": 1.0}}
    num = [c for c in base.samples.columns if c != "phase"]
    d = (r.samples[num] - base.samples[num]).abs()
    assert d.to_numpy().max() > 0
    if name in SENSOR_EFFECTS:
        pd.testing.assert_frame_equal(r.truth, base.truth)      # a reading, not the physics
    else:
        law = (r.truth.torque - r.truth.torque_load) - (base.truth.torque - base.truth.torque_load)
        twist = (r.truth.twist - base.truth.twist) * 1.375e7
        assert max(np.abs(law).max(), np.abs(twist).max()) > 20.0


@pytest.mark.parametrize("name", list(R.EFFECT_FORMS))
def test_scale_zero_is_the_nominal_bit_for_bit(name):
    base = _run(3, None)
    for form in R.EFFECT_FORMS[name]:
        r = R.simulate_run(3, None, 1, 25.0, {name: {"form": form, "scale": 0.0}},
                           sensors=R.SensorSpec(), periods=1, seed=SEED, run=0)
        pd.testing.assert_frame_equal(r.samples, base.samples, check_exact=True)
        pd.testing.assert_frame_equal(r.truth, base.truth, check_exact=True)


def _law(r: R.RigRun) -> np.ndarray:
    tr = r.truth
    return np.concatenate([(tr.torque - tr.torque_load).to_numpy(),
                           tr.twist.to_numpy() * 1.375e7])


def _reading(r: R.RigRun) -> np.ndarray:
    s = r.samples
    return np.concatenate([s.torque, s.torque_load, s.q * 1.375e7, s.qd * 1e7])


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_small_scale_is_linear(name, form):
    if name in SENSOR_EFFECTS:
        kw = {"scheme": 1, "speed": 3000.0, "fs": 100.0, "res": 1e-5, "noise": 0.0}
        scales, metric = (0.25, 0.5), _reading
    else:
        kw = {"scheme": 3, "speed": None, "fs": 50.0}
        scales, metric = (0.05, 0.1), _law
    base = metric(_run(**kw))
    d1, d2 = (np.linalg.norm(metric(_run(**kw, effects=((name, form, s),))) - base)
              for s in scales)
    assert d1 > 0
    assert d2 / d1 == pytest.approx(2.0, rel=0.2)


def _combo(k: int) -> tuple:
    return tuple((n, forms[k % len(forms)], R.SCALE_MAX) for n, forms in R.EFFECT_FORMS.items())


@pytest.mark.parametrize("fs", [10.0, 1000.0])
@pytest.mark.parametrize("k", range(4))
def test_stable_at_scale_max(fs, k):
    for scheme, speed in ((1, 3000.0), (3, None)):
        r = _run(scheme, speed, direction=-1, effects=_combo(k), fs=fs, temp=5.0)
        assert np.isfinite(r.samples.drop(columns="phase").to_numpy()).all()
        tr = r.truth
        assert np.isfinite(tr.to_numpy(dtype=float)).all()
        assert tr.torque.abs().max() < 2.0e5
        assert tr.twist.abs().max() < 0.02
        assert tr.qd.abs().max() < 2.0 * R.OMEGA_MAX


def test_scale_max_is_enforced():
    R.simulate_run(3, None, 1, 25.0, {"backlash": {"form": "sharp", "scale": R.SCALE_MAX}},
                   periods=1, seed=1, run=0)
    with pytest.raises(ValueError, match="scale"):
        R.simulate_run(3, None, 1, 25.0, {"backlash": {"form": "sharp",
                                                       "scale": R.SCALE_MAX + 1e-9}},
                       periods=1, seed=1, run=0)


def test_load_dependent_friction_flips_with_direction():
    gaps = []
    for direction in (1, -1):
        base = _run(1, 3000.0, direction=direction)
        r = _run(1, 3000.0, direction=direction,
                 effects=(("load_dependent_friction", "coulomb", 1.0),))
        hold = (base.samples.phase == "hold").to_numpy()
        gaps.append(((r.truth.torque - r.truth.torque_load)
                     - (base.truth.torque - base.truth.torque_load))[hold].mean())
    assert gaps[0] == pytest.approx(420.0, rel=0.15)
    assert gaps[1] == pytest.approx(-420.0, rel=0.15)


def test_stribeck_raises_low_speed_friction():
    slow = [(_run(1, 300.0, effects=e).truth.friction[600:1000]).mean()
            for e in ((), (("stribeck", "exp1", 1.0),))]
    fast = [(_run(1, 3000.0, effects=e).truth.friction[600:1000]).mean()
            for e in ((), (("stribeck", "exp1", 1.0),))]
    assert 200.0 < slow[1] - slow[0] < 600.0
    assert abs(fast[1] - fast[0]) < 0.2 * (slow[1] - slow[0])
