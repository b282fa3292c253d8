"""Contract and physics tests of validation rig Q (validation_rigs/rig_q.py): the interface the
validation harness calls, argument checks, determinism, run-format validity, stated sensors,
the physics against the paper (Eq. 4 friction, twist = torque / stiffness, the schemes' loads),
every effect form and its scale, and stability at SCALE_MAX at 10 Hz and 1 kHz."""

from __future__ import annotations

import dataclasses
import json
import math
from functools import cache

import numpy as np
import pandas as pd
import pytest

from core.runfile import validate_meta, validate_samples
from validation_rigs import rig_q as R

VOCABULARY = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
              "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction")
OUT_OF_VOCABULARY = ("periodic_disturbance", "position_stiffness", "sensor_drift",
                     "second_resonance")
PHASES = {"idle", "load", "hold", "unload", "excite"}
PAPER = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.660}
ALL_FORMS = [(n, f) for n, forms in R.EFFECT_FORMS.items() for f in forms]


@cache
def _run(scheme: int, rpm: float | None, direction: int, *, eff: tuple = (), fs: float = 20.0,
         temp: float = 30.0, periods: int = 1, seed: int = 7, run: int = 1,
         torque_noise: float = 150.0, lag: float = 0.0) -> R.RigRun:
    effects = {name: {"form": form, "scale": scale} for name, form, scale in eff}
    sensors = R.SensorSpec(sample_rate_hz=fs, torque_noise=torque_noise, torque_lag_s=lag)
    return R.simulate_run(scheme, rpm, direction, temp, effects, sensors=sensors,
                          periods=periods, seed=seed, run=run)


def _size(r: R.RigRun, base: R.RigRun, k: float) -> float:
    """Largest rms change, in N m, of truth twist (times the stiffness), truth torque and the
    readings' torque - torque_load: what the harness rescales with."""
    def rms(x) -> float:
        return float(np.sqrt(np.mean(np.square(np.asarray(x, float)))))
    d_meas = (r.samples.torque - r.samples.torque_load) - (base.samples.torque - base.samples.torque_load)
    return max(k * rms(r.truth.twist - base.truth.twist), rms(r.truth.torque - base.truth.torque),
               rms(d_meas))


# --- interface -------------------------------------------------------------------------------

def test_interface_constants():
    assert R.RIG_NAME == "rig_q"
    assert R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True
    assert isinstance(R.SCALE_MAX, float) and R.SCALE_MAX >= 1.0
    assert set(R.EFFECT_FORMS) == set(VOCABULARY) | set(OUT_OF_VOCABULARY)
    assert tuple(sorted(R.OUT_OF_VOCABULARY)) == tuple(sorted(OUT_OF_VOCABULARY))
    for name in VOCABULARY:
        forms = R.EFFECT_FORMS[name]
        assert 3 <= len(forms) <= 4 and len(set(forms)) == len(forms), name
    for name in OUT_OF_VOCABULARY:
        forms = R.EFFECT_FORMS[name]
        assert 2 <= len(forms) <= 3 and len(set(forms)) == len(forms), name


def test_sensor_spec_and_run_types():
    names = {f.name for f in dataclasses.fields(R.SensorSpec)}
    assert {"sample_rate_hz", "encoder_res_deg", "torque_noise", "torque_lag_s"} <= names
    spec = R.SensorSpec()
    assert spec.torque_lag_s == 0.0
    assert 10.0 <= spec.sample_rate_hz <= 1000.0 and 0.001 <= spec.encoder_res_deg <= 0.02
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.torque_noise = 1.0  # type: ignore[misc]
    assert {f.name for f in dataclasses.fields(R.RigRun)} == {"samples", "meta", "truth", "params"}


_GOOD = {"scheme": 1, "motor_speed_rpm": 300.0, "direction": 1, "temp_joint_c": 25.0,
         "effects": None, "sensors": R.SensorSpec(), "periods": 3, "seed": 1, "run": 0}


@pytest.mark.parametrize("change, word", [
    ({"scheme": 4}, "scheme"),
    ({"scheme": True}, "scheme"),
    ({"scheme": "1"}, "scheme"),
    ({"motor_speed_rpm": None}, "motor_speed_rpm"),
    ({"motor_speed_rpm": 0.0}, "motor_speed_rpm"),
    ({"motor_speed_rpm": 3000.5}, "motor_speed_rpm"),
    ({"motor_speed_rpm": float("nan")}, "motor_speed_rpm"),
    ({"scheme": 3, "motor_speed_rpm": 300.0}, "motor_speed_rpm"),
    ({"direction": 0}, "direction"),
    ({"direction": 2}, "direction"),
    ({"temp_joint_c": float("nan")}, "temp_joint_c"),
    ({"temp_joint_c": "warm"}, "temp_joint_c"),
    ({"effects": "stribeck"}, "effects"),
    ({"effects": {"wear": {"form": "x", "scale": 1.0}}}, "wear"),
    ({"effects": {"stribeck": 1.0}}, "stribeck"),
    ({"effects": {"stribeck": {"form": "cubic", "scale": 1.0}}}, "cubic"),
    ({"effects": {"stribeck": {"scale": 1.0}}}, "form"),
    ({"effects": {"stribeck": {"form": "gaussian", "scale": -0.5}}}, "scale"),
    ({"effects": {"stribeck": {"form": "gaussian", "scale": float("nan")}}}, "scale"),
    ({"effects": {"stribeck": {"form": "gaussian", "scale": float("inf")}}}, "scale"),
    ({"effects": {"stribeck": {"form": "gaussian", "scale": R.SCALE_MAX + 0.1}}}, "scale"),
    ({"sensors": "fast"}, "sensors"),
    ({"sensors": R.SensorSpec(sample_rate_hz=0.0)}, "sample_rate_hz"),
    ({"sensors": R.SensorSpec(encoder_res_deg=0.0)}, "encoder_res_deg"),
    ({"sensors": R.SensorSpec(torque_noise=-1.0)}, "torque_noise"),
    ({"sensors": R.SensorSpec(torque_lag_s=-0.01)}, "torque_lag_s"),
    ({"periods": 0}, "periods"),
    ({"seed": -1}, "seed"),
    ({"seed": 1.5}, "seed"),
    ({"run": -1}, "run"),
])
def test_bad_arguments_raise_naming_the_argument(change, word):
    kwargs = {**_GOOD, **change}
    with pytest.raises(ValueError, match=word):
        R.simulate_run(kwargs.pop("scheme"), kwargs.pop("motor_speed_rpm"), kwargs.pop("direction"),
                       kwargs.pop("temp_joint_c"), kwargs.pop("effects"), **kwargs)


def test_deterministic_campaign_and_run_noise():
    eff = {"hysteresis": {"form": "dahl", "scale": 1.0}}
    a = R.simulate_run(3, None, 1, 30.0, eff, sensors=R.SensorSpec(sample_rate_hz=20.0), periods=1,
                       seed=5, run=2)
    b = R.simulate_run(3, None, 1, 30.0, eff, sensors=R.SensorSpec(sample_rate_hz=20.0), periods=1,
                       seed=5, run=2)
    pd.testing.assert_frame_equal(a.samples, b.samples)
    pd.testing.assert_frame_equal(a.truth, b.truth)
    assert a.meta == b.meta and a.params == b.params
    c = R.simulate_run(3, None, 1, 30.0, eff, sensors=R.SensorSpec(sample_rate_hz=20.0), periods=1,
                       seed=5, run=3)
    same = ("I", "f_c", "f_v", "k1", "k2", "hardening", "unstated")
    assert all(a.params[k] == c.params[k] for k in same)          # one campaign, one machine
    assert not np.allclose(a.samples.torque, c.samples.torque)     # the run's own noise
    d = R.simulate_run(3, None, 1, 30.0, eff, sensors=R.SensorSpec(sample_rate_hz=20.0), periods=1,
                       seed=6, run=2)
    assert d.params["f_c"] != a.params["f_c"] and d.params["unstated"] != a.params["unstated"]


# --- run format and sensors ------------------------------------------------------------------

@pytest.mark.parametrize("scheme, rpm, direction", [(1, 3000.0, 1), (2, 300.0, -1), (3, None, -1)])
def test_samples_and_meta_pass_the_run_format(scheme, rpm, direction):
    r = _run(scheme, rpm, direction)
    checked = validate_samples(r.samples, "rig_q.csv")
    assert list(checked.columns) == list(r.samples.columns)
    validate_meta(r.meta, "rig_q.json")
    json.dumps(r.meta, allow_nan=False)
    for col in ("t", "q", "qd", "qdd", "u", "ud", "torsion", "torque", "torque_load", "torque_cmd",
                "i_m1", "i_m2", "i_m3", "w_m1", "temp_m1", "temp_joint", "p_hyd", "m_bend",
                "f_shear", "phase"):
        assert col in r.samples.columns, col
    assert set(r.samples.phase) <= PHASES
    assert np.allclose(np.diff(r.samples.t), 1.0 / 20.0)
    assert {"twist", "torque"} <= set(r.truth.columns) and len(r.truth) == len(r.samples)
    assert np.allclose(r.truth.t, r.samples.t)
    assert np.allclose(r.truth.twist, r.truth.u - r.truth.q)
    m = r.meta
    assert (m["scheme"], m["motor_speed_rpm"], m["direction"]) == (scheme, rpm, direction)
    assert m["reduction"] == 11000 and m["source"] == "emulator" and m["sample_rate_hz"] == 20.0


def test_sensors_are_stated_and_unstated_imperfections_are_not():
    r = _run(1, 300.0, 1)
    spec = R.SensorSpec(sample_rate_hz=20.0)
    sens = r.meta["sensors"]
    res = math.radians(spec.encoder_res_deg)
    assert sens["q"]["resolution"] == pytest.approx(res)
    assert sens["torque"]["noise_sd"] == spec.torque_noise and sens["torque"]["lag_s"] == 0.0
    assert sens["torque_load"]["noise_sd"] == spec.load_noise
    steps = r.samples.q.to_numpy() / res
    assert np.allclose(steps, np.round(steps), atol=1e-6)        # on the encoder's grid
    text = json.dumps(r.meta)
    for word in ("unstated", "gain_error", "eccentricity", "crosstalk", "hysteresis", "effects"):
        assert word not in text
    un = r.params["unstated"]
    assert abs(un["torque_gain_error"]) <= 0.0025 and abs(un["load_cell_gain_error"]) <= 0.002
    assert abs(un["torque_zero_nm"]) <= 100 and abs(un["encoder_eccentricity_rad"]) <= 5e-5
    # modest: the readings' torque - torque_load stays close to the truth's on average
    gap = (r.samples.torque - r.samples.torque_load) - (r.truth.torque - r.truth.torque_load)
    assert abs(float(gap.mean())) < 300.0


def test_torque_noise_and_stated_lag_act_as_stated():
    quiet = _run(1, 3000.0, 1, torque_noise=0.0)
    noisy = _run(1, 3000.0, 1)
    extra = (noisy.samples.torque - quiet.samples.torque).std()
    assert extra == pytest.approx(150.0, rel=0.12)
    lagged = _run(1, 3000.0, 1, torque_noise=0.0, lag=0.2)
    assert lagged.meta["sensors"]["torque"]["lag_s"] == 0.2
    k = 4                                                           # 0.2 s at 20 Hz
    assert np.allclose(lagged.samples.torque[k:].to_numpy(), quiet.samples.torque[:-k].to_numpy(),
                       atol=2 * R.ADC_LSB)
    pd.testing.assert_frame_equal(lagged.truth, quiet.truth)


def test_every_sample_instant_is_a_step_instant():
    for fs, steps in ((10.0, 50), (1000.0, 1), (300.0, 2)):
        r = _run(3, None, 1, fs=fs)
        p = r.params
        assert p["steps_per_sample"] == steps and p["internal_step_s"] <= 2e-3 + 1e-15
        assert p["steps_per_sample"] * p["internal_step_s"] == pytest.approx(1.0 / fs)
        assert np.allclose(r.samples.t, np.arange(len(r.samples)) / fs)


# --- physics against the paper ---------------------------------------------------------------

@pytest.mark.parametrize("rpm, direction", [(3000.0, 1), (3000.0, -1), (300.0, 1), (300.0, -1)])
def test_steady_sliding_friction_is_eq4(rpm, direction):
    r = _run(1, rpm, direction)
    p, tr = r.params, r.truth
    for k, v in PAPER.items():
        assert p[k] == pytest.approx(v, rel=0.15), k
    moving = r.samples.phase.isin(["load", "hold", "unload"]).to_numpy()
    friction = (tr.torque - tr.torque_load - tr.gravity - p["I"] * tr.qdd)[moving]
    eq4 = direction * p["f_c"] + p["f_v"] * tr.qd[moving]
    assert float(friction.mean()) == pytest.approx(float(eq4.mean()), rel=0.01)
    assert float(tr.qd[moving].mean()) == pytest.approx(direction * rpm / R.RPM_MAX * R.V_TOP, rel=0.02)
    # what the readings show: torque - load - gravity ~ Eq. 4's friction
    s = r.samples
    g = 9.80665 * (p["mr_x"] * np.sin(s.q) + p["mr_y"] * np.cos(s.q))
    seen = (s.torque - s.torque_load - g)[moving]
    assert float(seen.mean()) == pytest.approx(float(eq4.mean()), rel=0.15)


def test_twist_is_torque_over_stiffness():
    r = _run(1, 3000.0, 1)
    k = r.params["k_total_small_load"]
    assert math.degrees(120e3 / k) == pytest.approx(0.5, abs=0.1)   # about half a degree
    tr = r.truth
    high = (tr.torque > 100e3).to_numpy()
    ratio = (tr.twist[high] / (tr.torque[high] / k)).mean()
    assert 0.95 < ratio < 1.0                                       # mild hardening
    low = ((tr.torque > 20e3) & (tr.torque < 40e3)).to_numpy()
    assert (tr.twist[low] / (tr.torque[low] / k)).mean() == pytest.approx(1.0, abs=0.03)
    s = r.samples
    seen = float((-s.torsion[high]).mean() / s.torque[high].mean() * k)
    assert seen == pytest.approx(ratio, rel=0.05)


@pytest.mark.parametrize("scheme", [1, 2])
def test_schemes_load_to_rated_torque(scheme):
    r = _run(scheme, 3000.0, 1)
    s, tr = r.samples, r.truth
    assert s.torque_cmd.max() == 120e3
    assert 118e3 <= tr.torque_load.max() <= 124e3
    assert tr.torque.max() >= 119e3 and s.torque.max() >= 118e3
    hold = (s.phase == "hold").to_numpy()
    assert np.abs(tr.torque_load - s.torque_cmd)[hold].max() < 2000.0   # Table 11: +-2 kN m
    phases = [p for i, p in enumerate(s.phase) if i == 0 or p != s.phase[i - 1]]
    if scheme == 1:
        assert phases == ["idle", "load", "hold", "unload", "idle"]
    else:
        plateaus = sorted(set(s.torque_cmd[hold]))
        assert plateaus == [10e3 * k for k in range(1, 13)]
        assert phases[:3] == ["idle", "load", "hold"] and phases[-2:] == ["unload", "idle"]


def test_scheme3_fourier_excitation():
    one = _run(3, None, 1)
    two = _run(3, None, 1, periods=2)
    assert two.samples.t.iloc[-1] - one.samples.t.iloc[-1] == pytest.approx(25.0)
    ex = (one.samples.phase == "excite").to_numpy()
    assert ex.sum() / 20.0 == pytest.approx(25.0, abs=0.1)
    assert np.abs(one.truth.q).max() < math.pi
    assert np.abs(one.truth.ud).max() <= R.V_TOP * 1.02
    assert one.samples.torque_cmd.abs().max() == 0.0 and one.meta["motor_speed_rpm"] is None
    mirror = _run(3, None, -1)
    assert np.corrcoef(one.truth.q, mirror.truth.q)[0, 1] < -0.99


# --- effects ---------------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(R.EFFECT_FORMS))
def test_scale_zero_is_the_nominal(name):
    base = _run(1, 3000.0, 1, fs=10.0)
    zero = _run(1, 3000.0, 1, fs=10.0, eff=((name, R.EFFECT_FORMS[name][-1], 0.0),))
    pd.testing.assert_frame_equal(zero.samples, base.samples)
    pd.testing.assert_frame_equal(zero.truth, base.truth)


@pytest.mark.parametrize("name, form", ALL_FORMS)
def test_every_form_changes_the_run_and_grows_with_scale(name, form):
    base = _run(1, 3000.0, 1, fs=10.0)
    k = base.params["k_total_small_load"]
    one = _run(1, 3000.0, 1, fs=10.0, eff=((name, form, 1.0),))
    top = _run(1, 3000.0, 1, fs=10.0, eff=((name, form, R.SCALE_MAX),))
    for r in (one, top):
        assert np.isfinite(r.samples.drop(columns="phase").to_numpy()).all()
        assert np.isfinite(r.truth.to_numpy()).all()
    s1, s_top = _size(one, base, k), _size(top, base, k)
    assert s1 > 20.0, (name, form, s1)            # clearly there at scale 1 (N m)
    assert s_top > 1.5 * s1, (name, form, s1, s_top)


@pytest.mark.parametrize("fs", [10.0, 1000.0])
@pytest.mark.parametrize("k", range(4))
def test_all_effects_at_scale_max_stay_stable(fs, k):
    eff = tuple((n, forms[k % len(forms)], R.SCALE_MAX) for n, forms in R.EFFECT_FORMS.items())
    for case in ((1, 300.0, -1), (2, 3000.0, 1), (3, None, 1)):
        r = _run(*case, eff=eff, fs=fs, seed=11 + k, run=k)
        assert np.isfinite(r.samples.drop(columns="phase").to_numpy()).all(), case
        assert np.isfinite(r.truth.to_numpy()).all(), case
        assert np.abs(r.truth.torque).max() < 5e5 and np.abs(r.truth.twist).max() < 0.1, case
        assert np.abs(r.truth.qd).max() < 0.25, case      # inside the integrator's stated range
        validate_samples(r.samples, "rig_q.csv")
