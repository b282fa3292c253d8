"""Contract and physics tests of validation rig V (validation_rigs/rig_v.py).

Runs are cached per module and simulated at 20 Hz with one Fourier period where the test allows,
so the file stays well under a minute on two cores."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest

from core.runfile import validate_meta, validate_samples
from validation_rigs import rig_v as R

VOCAB = ("stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
         "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction")
OOV = ("periodic_disturbance", "position_stiffness", "sensor_drift", "second_resonance")
SENSOR_ONLY = {"torque_offset", "time_delay", "sensor_drift"}
FAST = R.SensorSpec(sample_rate_hz=20.0)
QUIET = R.SensorSpec(sample_rate_hz=20.0, torque_noise=0.0, load_noise=0.0)


# SensorSpec is a mutable dataclass (unhashable): key the cache by its fields instead.
def run(scheme, rpm, direction=1, temp=20.0, effects=(), sensors=QUIET, seed=7, run_=0,
        periods=1):
    key = tuple(sorted(vars(sensors).items()))
    return _run_keyed(scheme, rpm, direction, temp, effects, key, seed, run_, periods)


@lru_cache(maxsize=None)
def _run_keyed(scheme, rpm, direction, temp, effects, skey, seed, run_, periods):
    eff = {n: {"form": f, "scale": s} for n, f, s in effects}
    return R.simulate_run(scheme, rpm, direction, temp, eff, sensors=R.SensorSpec(**dict(skey)),
                          periods=periods, seed=seed, run=run_)


def balance(r: R.RigRun) -> np.ndarray:
    return (r.truth["torque"] - r.truth["torque_load"]).to_numpy()


# ----------------------------------------------------------------------------- interface -----

def test_module_constants():
    assert R.RIG_NAME == "rig_v"
    assert R.REDUCTION == 11000.0
    assert R.SEED_IS_CAMPAIGN is True
    assert isinstance(R.SCALE_MAX, float) and 5.0 <= R.SCALE_MAX <= 20.0
    assert set(R.EFFECT_FORMS) == set(VOCAB) | set(OOV) and len(R.EFFECT_FORMS) == 13
    assert R.OUT_OF_VOCABULARY == OOV
    for name, forms in R.EFFECT_FORMS.items():
        assert isinstance(forms, tuple) and len(set(forms)) == len(forms) >= 3, name
    assert {"exponential", "gaussian", "lorentzian"} <= set(R.EFFECT_FORMS["stribeck"])
    assert len(R.EFFECT_FORMS["stribeck"]) >= 4
    assert set(R.UNSTATED_VOCABULARY) <= set(VOCAB)
    assert all(isinstance(v, str) and v for v in R.UNSTATED_VOCABULARY.values())
    assert R.__doc__ and "TR-BDF2" in R.__doc__ and "elasto-plastic" in R.__doc__


def test_sensorspec_defaults_and_range():
    s = R.SensorSpec()
    assert s.sample_rate_hz == 100.0 and s.encoder_res_deg == 0.01 and s.torque_lag_s == 0.0
    assert 100.0 <= s.torque_noise <= 200.0
    R.SensorSpec(sample_rate_hz=10.0)
    R.SensorSpec(sample_rate_hz=1000.0)


@pytest.mark.parametrize("field,bad", [
    ("sample_rate_hz", 9.0), ("sample_rate_hz", 1001.0), ("sample_rate_hz", "100"),
    ("encoder_res_deg", 0.0), ("encoder_res_deg", float("nan")), ("torque_noise", -1.0),
    ("torque_noise", float("inf")), ("torque_lag_s", -0.1), ("torque_lag_s", True),
    ("torque_adc_step", None), ("load_noise", -5.0), ("motor_counts_per_rev", 1.0),
    ("current_noise", -1.0), ("temp_noise", 99.0), ("pressure_noise", "x"),
])
def test_sensorspec_refuses_bad_fields(field, bad):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: bad})


@pytest.mark.parametrize("kwargs,name", [
    ({"scheme": 4}, "scheme"), ({"scheme": True}, "scheme"),
    ({"motor_speed_rpm": 0.0}, "motor_speed_rpm"), ({"motor_speed_rpm": 3001.0}, "motor_speed_rpm"),
    ({"motor_speed_rpm": None}, "motor_speed_rpm"),
    ({"motor_speed_rpm": float("nan")}, "motor_speed_rpm"),
    ({"scheme": 3, "motor_speed_rpm": 300.0}, "motor_speed_rpm"),
    ({"direction": 0}, "direction"), ({"direction": 2}, "direction"),
    ({"temp_joint_c": 14.0}, "temp_joint_c"), ({"temp_joint_c": 61.0}, "temp_joint_c"),
    ({"temp_joint_c": float("nan")}, "temp_joint_c"),
    ({"effects": {"nonsense": {"form": "x", "scale": 1.0}}}, "effects"),
    ({"effects": {"stribeck": {"form": "cubic", "scale": 1.0}}}, "effects"),
    ({"effects": {"stribeck": {"form": "gaussian", "scale": -0.5}}}, "effects"),
    ({"effects": {"stribeck": {"form": "gaussian"}}}, "effects"),
    ({"effects": {"stribeck": {"form": "gaussian", "scale": float("nan")}}}, "effects"),
    ({"effects": {"stribeck": {"form": "gaussian", "scale": R.SCALE_MAX * 1.01}}}, "effects"),
    ({"effects": [("stribeck", 1.0)]}, "effects"),
    ({"periods": 0}, "periods"), ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"),
    ({"run": "a"}, "run"), ({"sensors": {"sample_rate_hz": 20}}, "sensors"),
])
def test_bad_arguments_refused_by_name(kwargs, name):
    args = {"scheme": 1, "motor_speed_rpm": 300.0, "direction": 1, "temp_joint_c": 20.0,
            "effects": None, "sensors": FAST, "periods": 1, "seed": 1, "run": 0}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        R.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                       args.pop("temp_joint_c"), args.pop("effects"), **args)


def test_scale_max_accepted_and_above_refused():
    R._check_effects({"backlash": {"form": "sharp", "scale": R.SCALE_MAX}})
    with pytest.raises(ValueError, match="SCALE_MAX"):
        R._check_effects({"backlash": {"form": "sharp", "scale": R.SCALE_MAX + 1e-9}})


# ----------------------------------------------------------------------- determinism ---------

def test_deterministic_and_seeded():
    a = R.simulate_run(3, None, 1, 25.0, sensors=FAST, periods=1, seed=11, run=2)
    b = R.simulate_run(3, None, 1, 25.0, sensors=FAST, periods=1, seed=11, run=2)
    assert a.samples.equals(b.samples) and a.truth.equals(b.truth) and a.meta == b.meta
    c = R.simulate_run(3, None, 1, 25.0, sensors=FAST, periods=1, seed=11, run=3)
    assert c.params["machine"] == a.params["machine"]  # same campaign, same machine
    assert c.truth.equals(a.truth)                       # the machine is noise-free
    assert not np.array_equal(c.samples["torque"], a.samples["torque"])  # the noise is not
    d = R.simulate_run(3, None, 1, 25.0, sensors=FAST, periods=1, seed=12, run=2)
    assert d.params["machine"] != a.params["machine"]


def test_scale_zero_is_bit_for_bit_nominal():
    nominal = run(3, None, sensors=FAST)
    zero = tuple((n, f[0], 0.0) for n, f in R.EFFECT_FORMS.items())
    z = run(3, None, effects=zero, sensors=FAST)
    assert z.samples.equals(nominal.samples)
    assert z.truth.equals(nominal.truth)
    assert z.meta == nominal.meta


# ------------------------------------------------------------------------- effects -----------

def _case(name: str, form: str):
    """The run on which an effect shows: load-dependent friction and a position-dependent
    stiffness and a torque-gain drift need load (scheme 1); the rest shows on the short Fourier
    run."""
    if name in ("load_dependent_friction", "position_stiffness") or form == "torque_gain_drift":
        return (1, 300.0)
    return (3, None)


ALL_FORMS = [(n, f) for n, forms in R.EFFECT_FORMS.items() for f in forms]


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_each_form_changes_the_run_where_it_should(name, form):
    scheme, rpm = _case(name, form)
    base = run(scheme, rpm)
    r = run(scheme, rpm, effects=((name, form, 1.0),))
    assert r.params["effects"] == {name: {"form": form, "scale": 1.0}}
    if name in SENSOR_ONLY:
        assert r.truth.equals(base.truth), "a sensor effect must not touch the machine"
        if form in ("encoder_q", "encoder_zero_drift"):
            step = math.radians(QUIET.encoder_res_deg)
            assert np.abs(r.samples["q"] - base.samples["q"]).max() >= step * 0.99
            assert np.array_equal(r.samples["torque"], base.samples["torque"])
        elif form == "load_cell_drift":
            assert np.abs(r.samples["torque_load"] - base.samples["torque_load"]).max() > 50.0
            assert np.array_equal(r.samples["torque"], base.samples["torque"])
        else:
            assert np.abs(r.samples["torque"] - base.samples["torque"]).max() > 50.0
            assert np.array_equal(r.samples["q"], base.samples["q"])
    elif name == "position_stiffness":
        # the stiffness law changes: the twist at a given torque moves
        assert np.abs(r.truth["twist"] - base.truth["twist"]).max() > 5e-5
    else:
        # a machine effect: the output body's torque balance moves
        assert np.abs(balance(r) - balance(base)).max() > 20.0
        assert np.abs(r.samples["torque"] - base.samples["torque"]).max() > 20.0


@pytest.mark.parametrize("name,form", ALL_FORMS)
def test_every_form_stable_at_scale_max(name, form):
    r = run(3, None, effects=((name, form, R.SCALE_MAX),))
    num = r.samples.drop(columns=["phase"]).to_numpy(dtype=float)
    assert np.isfinite(num).all() and np.isfinite(r.truth.to_numpy(dtype=float)).all()
    assert np.abs(r.truth["torque"]).max() < 1e5
    assert np.abs(r.truth["q"]).max() < math.pi
    assert np.abs(r.truth["qd"]).max() < 3 * R.OUT_SPEED_MAX


def test_effects_small_scale_roughly_linear():
    base = run(3, None)
    d1 = balance(run(3, None, effects=(("asymmetric_friction", "offset", 0.5),))) - balance(base)
    d2 = balance(run(3, None, effects=(("asymmetric_friction", "offset", 1.0),))) - balance(base)
    assert np.abs(d2).max() == pytest.approx(2 * np.abs(d1).max(), rel=0.25)


def test_effects_combine():
    eff = (("stribeck", "gaussian", 1.0), ("torque_offset", "constant", 1.0),
           ("hysteresis", "bouc_wen_n1", 1.0))
    r = run(3, None, effects=eff)
    assert set(r.params["effects"]) == {"stribeck", "torque_offset", "hysteresis"}
    assert np.isfinite(r.truth.to_numpy(dtype=float)).all()


# -------------------------------------------------------------------- run format ------------

@pytest.mark.parametrize("scheme,rpm,direction", [(1, 3000.0, 1), (2, 300.0, -1), (3, None, 1)])
def test_runs_pass_the_run_format_validators(scheme, rpm, direction):
    r = run(scheme, rpm, direction, sensors=FAST)
    out = validate_samples(r.samples, "rig_v.csv")
    validate_meta(r.meta, "rig_v.json")
    for col in ("q", "u", "torque", "torque_load", "temp_joint", "torque_cmd", "phase"):
        assert col in out.columns
    assert r.meta["scheme"] == scheme and r.meta["direction"] == direction
    assert r.meta["motor_speed_rpm"] == rpm and r.meta["reduction"] == R.REDUCTION
    assert r.meta["sample_rate_hz"] == 20.0
    assert np.allclose(np.diff(r.samples["t"]), 1 / 20.0)
    assert list(r.truth["t"]) == list(r.samples["t"])
    assert {"twist", "torque"} <= set(r.truth.columns)
    assert r.params["newton_failures"] == 0


def test_sensor_metadata_states_the_sensorspec():
    spec = R.SensorSpec(sample_rate_hz=50.0, encoder_res_deg=0.02, torque_noise=80.0,
                        torque_lag_s=0.01, torque_adc_step=2.0)
    r = R.simulate_run(3, None, 1, 20.0, sensors=spec, periods=1, seed=3, run=0)
    sens = r.meta["sensors"]
    assert sens["q"]["resolution"] == pytest.approx(math.radians(0.02))
    assert sens["torque"] == {"resolution": 2.0, "noise_sd": 80.0, "lag_s": 0.01}
    assert sens["u"]["resolution"] == pytest.approx(2 * math.pi / 2 ** 20 / R.REDUCTION)
    validate_meta(r.meta, "x.json")
    q = r.samples["q"].to_numpy()
    assert np.allclose(q / sens["q"]["resolution"], np.round(q / sens["q"]["resolution"]))
    # the torque noise is what is stated (unstated offsets are constant, taken out by diff)
    resid = r.samples["torque"].to_numpy() - np.interp(r.samples["t"] - 0.012, r.truth["t"],
                                                       r.truth["torque"])
    assert np.std(np.diff(resid)) / math.sqrt(2) == pytest.approx(80.0, rel=0.3)
    assert r.meta["sample_rate_hz"] == 50.0


# -------------------------------------------------------------------------- physics ----------

@pytest.mark.parametrize("direction", [1, -1])
def test_steady_sliding_obeys_eq4_with_table3(direction):
    r = run(1, 3000.0, direction, temp=R.T_REF_C)
    m = r.params["machine"]
    tr = r.truth
    t = tr["t"].to_numpy()
    sel = ((t > 2.0) & (t < 3.9)) | ((t > 34.5) & (t < 35.9)) | ((t > 67.0) & (t < 69.9))
    q = tr["q"].to_numpy()[sel]
    qd = tr["qd"].to_numpy()[sel]
    assert np.all(np.sign(qd) == direction)
    eq4 = (R.G * (m["mr_x"] * np.sin(q) + m["mr_y"] * np.cos(q)) + m["f_v"] * qd
           + m["f_c"] * np.sign(qd))
    # the oil cools by < 0.2 K in the run: its viscous share moves by well under 1 N·m
    assert np.abs(balance(r)[sel] - eq4).max() < 15.0
    # and the campaign's machine is Table 3 within the spread
    for k, v in R.TABLE3.items():
        assert m[k] == pytest.approx(v, rel=0.1)
    assert m["f_c"] == pytest.approx(R.TABLE3["f_c"], rel=0.01)
    assert m["f_v"] == pytest.approx(R.TABLE3["f_v"], rel=0.01)


def test_warm_oil_lowers_viscous_friction():
    cold = run(1, 3000.0, temp=15.0)
    warm = run(1, 3000.0, temp=60.0)
    sel = (cold.truth["t"] > 2.0) & (cold.truth["t"] < 3.9)
    assert balance(cold)[sel].mean() - balance(warm)[sel].mean() > 20.0


def test_twist_follows_the_stiffness_law():
    r = run(1, 3000.0, temp=R.T_REF_C)
    m = r.params["machine"]
    tw = r.truth["twist"].to_numpy()
    T = r.truth["torque"].to_numpy()
    law = m["k_lin"] * tw + m["T_s"] * np.tanh(tw / m["theta_s"])
    sel = (r.truth["t"] > 2.0).to_numpy()
    assert np.abs(T[sel] - law[sel]).max() < 0.01 * np.abs(T).max()
    full = np.argmax(T)
    k_secant = T[full] / tw[full]
    assert 1e7 < k_secant < 2e7
    assert 0.3 < math.degrees(tw[full]) < 0.8  # about half a degree at the rated torque


def test_scheme1_loads_to_rated_torque_and_back():
    r = run(1, 300.0, sensors=FAST)
    s = r.samples
    hold = (s["phase"] == "hold").to_numpy()
    assert hold.any()
    assert np.abs(s["torque_load"][hold] - 120e3).max() < 2e3  # Table 11: ±2 kN·m
    assert r.truth["torque"].max() > 120e3
    assert abs(s["torque_load"].iloc[-1]) < 2e3
    assert set(s["phase"]) == {"idle", "load", "hold", "unload"}
    w = r.truth["qd"].to_numpy()[(r.truth["t"] > 3).to_numpy()]
    assert np.all(np.abs(w - 300 * 2 * math.pi / 60 / R.REDUCTION) < 0.2 * 300 * 2 * math.pi / 60
                  / R.REDUCTION)


def test_scheme2_steps_of_ten_knm():
    r = run(2, 3000.0, sensors=FAST)
    s = r.samples
    hold = (s["phase"] == "hold").to_numpy()
    levels = np.unique(np.round(s["torque_cmd"][hold] / 1e4))
    assert list(levels) == list(range(1, 13))
    cur = s[["i_m1", "i_m2", "i_m3"]].to_numpy()
    assert np.all(np.abs(cur) <= 12.0 + 0.2)
    # the slaves follow the master's command within the mismatch
    top = (s["torque_cmd"] == 120e3).to_numpy() & hold
    ratio = cur[top, 1].mean() / cur[top, 0].mean()
    assert ratio == pytest.approx(r.params["machine"]["mismatch_2"], abs=0.01)


def test_scheme3_fourier_trajectory_starts_at_rest():
    r = run(3, None, periods=2)
    tr = r.truth
    assert tr["q"].iloc[0] == 0.0 and tr["qd"].iloc[0] == 0.0
    assert abs(tr["qd"].iloc[1]) < 0.1 * R.OUT_SPEED_MAX  # it starts slowly (q̈(0) = 0)
    assert np.abs(tr["qd"]).max() <= 1.05 * R.OUT_SPEED_MAX
    assert np.abs(tr["q"]).max() < math.pi
    assert len(tr) == 2 * int(R.FOURIER_PERIOD * 20)
    assert r.meta["motor_speed_rpm"] is None
    assert set(r.samples["phase"]) == {"excite"}
    # periodic: the second period repeats the first
    n = int(R.FOURIER_PERIOD * 20)
    assert np.abs(tr["q"].iloc[n:].to_numpy() - tr["q"].iloc[:n].to_numpy()).max() < 2e-3


def test_unstated_imperfections_are_recorded():
    r = run(3, None)
    u = r.params["unstated"]
    assert 0.002 <= u["torque_crosstalk_per_bend"] <= 0.004
    assert u["torque_extra_lag_s"] > 0.0
    # the torque reading carries the crosstalk offset the sensors metadata does not state
    off = (r.samples["torque"] - r.truth["torque"]).iloc[-20:].mean()
    expect = u["torque_crosstalk_per_bend"] * 50e3 + u["torque_zero_offset_nm"]
    assert off == pytest.approx(expect, abs=40.0)
