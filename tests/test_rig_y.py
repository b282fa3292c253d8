"""Rig Y (validation_rigs/rig_y.py): its contract and its physics against the paper."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from core.runfile import validate_meta, validate_samples
from validation_rigs import rig_y as R

FAST = R.SensorSpec(sample_rate_hz=200.0)
TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.660}
COLUMNS = ["t", "q", "u", "torsion", "torque", "torque_load", "torque_cmd", "i_m1", "i_m2", "i_m3",
           "w_m1", "w_m2", "w_m3", "temp_joint", "temp_m1", "temp_m2", "temp_m3", "phase"]


def _frames_equal(a: pd.DataFrame, b: pd.DataFrame) -> bool:
    return list(a.columns) == list(b.columns) and all(
        a[c].equals(b[c]) for c in a.columns)


@pytest.fixture(scope="module")
def nominal_s1():
    return R.simulate_run(1, 3000, 1, 25.0, sensors=FAST, periods=1, seed=11, run=0)


@pytest.fixture(scope="module")
def excite_1k():
    return R.simulate_run(3, None, 1, 30.0, periods=3, seed=5, run=2)


# --- contract ---------------------------------------------------------------------------------

def test_interface_constants():
    assert R.RIG_NAME == "rig_y" and R.REDUCTION == 11000.0 and R.SEED_IS_CAMPAIGN is True
    assert R.SCALE_MAX > 1
    vocab = {"stribeck", "load_dependent_friction", "temperature_friction", "gear_ripple",
             "torque_offset", "time_delay", "hysteresis", "backlash", "asymmetric_friction"}
    oov = {"periodic_disturbance", "position_dependent_stiffness", "encoder_drift",
           "second_resonance"}
    assert set(R.EFFECT_FORMS) == vocab | oov
    assert set(R.OUT_OF_VOCABULARY) == oov
    assert set(R.UNSTATED_VOCABULARY) <= vocab and R.UNSTATED_VOCABULARY
    minimum = {"stribeck": 4, "load_dependent_friction": 3, "temperature_friction": 3,
               "gear_ripple": 3, "torque_offset": 2, "time_delay": 2, "hysteresis": 3,
               "backlash": 3, "asymmetric_friction": 3}
    for name, forms in R.EFFECT_FORMS.items():
        assert len(set(forms)) == len(forms) >= minimum.get(name, 2), name


@pytest.mark.parametrize("field,value", [
    ("sample_rate_hz", 5.0), ("sample_rate_hz", 2000.0), ("sample_rate_hz", float("nan")),
    ("encoder_res_deg", 0.0), ("encoder_res_deg", float("inf")), ("torque_noise", -1.0),
    ("torque_noise", float("nan")), ("torque_lag_s", -0.01), ("torque_lag_s", 10.0),
    ("motor_counts_per_rev", 1.0), ("load_cell_noise", float("-inf")), ("current_noise", 5.0),
    ("speed_noise", float("nan")), ("temp_noise", 9.0), ("torque_noise", "a"),
])
def test_sensor_spec_range_checked(field, value):
    with pytest.raises(ValueError, match=field):
        R.SensorSpec(**{field: value})
    spec = R.SensorSpec()
    setattr(spec, field, value)          # mutated after construction: simulate_run re-checks
    with pytest.raises(ValueError, match=field):
        R.simulate_run(1, 3000, 1, 25.0, sensors=spec, periods=1, seed=1, run=0)


@pytest.mark.parametrize("kwargs,name", [
    (dict(scheme=4), "scheme"), (dict(motor_speed_rpm=float("nan")), "motor_speed_rpm"),
    (dict(motor_speed_rpm=5000.0), "motor_speed_rpm"), (dict(direction=0), "direction"),
    (dict(temp_joint_c=80.0), "temp_joint_c"), (dict(temp_joint_c=float("nan")), "temp_joint_c"),
    (dict(periods=0), "periods"), (dict(periods=21), "periods"), (dict(periods=2.5), "periods"),
    (dict(effects={"nope": {"form": "x", "scale": 1.0}}), "nope"),
    (dict(effects={"stribeck": {"form": "cubic", "scale": 1.0}}), "form"),
    (dict(effects={"stribeck": {"form": "exp1", "scale": -1.0}}), "scale"),
    (dict(effects={"stribeck": {"form": "exp1", "scale": float("nan")}}), "scale"),
    (dict(effects={"stribeck": {"form": "exp1", "scale": R.SCALE_MAX * 1.01}}), "scale"),
    (dict(scheme=3, motor_speed_rpm=3000.0), "motor_speed_rpm"),
])
def test_simulate_run_arguments_checked(kwargs, name):
    args = dict(scheme=1, motor_speed_rpm=3000.0, direction=1, temp_joint_c=25.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        R.simulate_run(args.pop("scheme"), args.pop("motor_speed_rpm"), args.pop("direction"),
                       args.pop("temp_joint_c"), sensors=FAST, seed=1, run=0, **args)


def test_scale_zero_is_exactly_nominal(nominal_s1):
    zero = {n: {"form": f[0], "scale": 0.0} for n, f in R.EFFECT_FORMS.items()}
    r0 = R.simulate_run(1, 3000, 1, 25.0, zero, sensors=FAST, periods=1, seed=11, run=0)
    assert _frames_equal(r0.samples, nominal_s1.samples)
    assert _frames_equal(r0.truth, nominal_s1.truth)
    one = dict(zero, stribeck={"form": "exp1", "scale": 1.0})
    r1 = R.simulate_run(1, 3000, 1, 25.0, one, sensors=FAST, periods=1, seed=11, run=0)
    assert not r1.samples["torque"].equals(nominal_s1.samples["torque"])


def test_deterministic_per_seed_and_run(nominal_s1):
    again = R.simulate_run(1, 3000, 1, 25.0, sensors=FAST, periods=1, seed=11, run=0)
    assert _frames_equal(again.samples, nominal_s1.samples)
    other_run = R.simulate_run(1, 3000, 1, 25.0, sensors=FAST, periods=1, seed=11, run=1)
    assert other_run.params["machine"] == nominal_s1.params["machine"]       # same campaign
    assert not other_run.samples["torque"].equals(nominal_s1.samples["torque"])  # own noise
    other_seed = R.simulate_run(1, 3000, 1, 25.0, sensors=FAST, periods=1, seed=12, run=0)
    m0, m1 = nominal_s1.params["machine"], other_seed.params["machine"]
    assert m0["I"] != m1["I"] and m0["f_c"] != m1["f_c"]


def _scheme_for(name: str, form: str) -> tuple[int, float | None]:
    if name in ("backlash", "hysteresis", "asymmetric_friction", "second_resonance") \
            or (name == "stribeck"):
        return 3, None
    if name == "gear_ripple" and form == "motor_angle":
        return 1, 300.0
    return 1, 3000.0


@pytest.mark.parametrize("name,form", [(n, f) for n, fs in R.EFFECT_FORMS.items() for f in fs])
def test_every_form_runs_and_grows_with_scale(name, form):
    scheme, speed = _scheme_for(name, form)
    kw = dict(sensors=FAST, periods=1, seed=3, run=0)
    base = R.simulate_run(scheme, speed, 1, 25.0, **kw)
    chans = ["q", "u", "torque", "torque_load", "i_m1"]
    sd = {"q": math.radians(0.01), "u": 1e-8, "torque": 150.0, "torque_load": 100.0,
          "i_m1": 0.02}
    size = []
    for s in (1.0, 2.0):
        r = R.simulate_run(scheme, speed, 1, 25.0, {name: {"form": form, "scale": s}}, **kw)
        validate_samples(r.samples, "x")
        assert r.params["effects"] == {name: {"form": form, "scale": s}}
        # the same noise draws: the difference is the effect alone, in units of each channel's
        # noise or step
        size.append(max(np.sqrt(np.mean((r.samples[c] - base.samples[c]) ** 2)) / sd[c]
                        for c in chans))
    assert size[0] > 0.1, f"{name}/{form} barely changes the readings ({size[0]:.3g})"
    assert size[1] > 1.3 * size[0], f"{name}/{form} does not grow with scale {size}"


def test_run_format_and_sensor_metadata(nominal_s1):
    r = nominal_s1
    s = validate_samples(r.samples, "rig_y.csv")
    validate_meta(r.meta, "rig_y.json")
    assert list(s.columns) == COLUMNS
    assert r.meta["source"] == "emulator" and r.meta["rig"] == "rig_y"
    assert r.meta["reduction"] == 11000 and r.meta["scheme"] == 1 and r.meta["direction"] == 1
    assert r.meta["sample_rate_hz"] == 200.0
    assert set(s["phase"]) <= {"idle", "load", "hold", "unload", "excite"}
    assert np.array_equal(s["torsion"], s["q"] - s["u"])
    qres = r.meta["sensors"]["q"]["resolution"]
    assert qres == pytest.approx(math.radians(0.01))
    assert np.allclose(s["q"] / qres, np.round(s["q"] / qres), atol=1e-6)
    ures = r.meta["sensors"]["u"]["resolution"]
    assert np.allclose(s["u"] / ures, np.round(s["u"] / ures), atol=1e-5)
    assert r.meta["sensors"]["torque"] == {"resolution": 0.0, "noise_sd": 150.0, "lag_s": 0.005}
    assert len(r.truth) == len(s) and {"twist", "torque"} <= set(r.truth.columns)
    assert np.allclose(r.truth["t"], s["t"])
    # the reading's noise is what the metadata says (residual to the lagged truth, hold phase
    # excluded from nothing: the lag is 5 ms, far below the ramps' time scale)
    resid = s["torque"] - r.truth["torque_sensor_filtered"]
    assert np.std(resid) == pytest.approx(150.0, rel=0.1)


def test_run_lengths():
    for scheme, speed in ((1, 300.0), (2, 3000.0), (3, None)):
        d = R.run_duration(scheme, 3)
        assert 20.0 <= d <= 120.0
    r = R.simulate_run(2, 300, -1, 40.0, sensors=R.SensorSpec(sample_rate_hz=10.0), seed=2, run=3)
    assert r.samples["t"].iloc[-1] == pytest.approx(R.run_duration(2, 3) - 0.1)
    assert {"load", "hold", "unload", "idle"} <= set(r.samples["phase"])
    hold = r.samples["phase"] == "hold"
    assert set(np.round(r.samples["torque_cmd"][hold] / 1e4)) == set(range(1, 13))


# --- physics against the paper -----------------------------------------------------------------

def _eq4_fit(truth: pd.DataFrame) -> dict:
    qd, q = truth["qd"].to_numpy(), truth["q"].to_numpy()
    ok = np.abs(qd) > 3e-3                     # outside the presliding of the reversals
    Y = np.c_[truth["qdd"], 9.81 * np.sin(q), 9.81 * np.cos(q), qd, np.sign(qd)][ok]
    y = (truth["torque"] - truth["torque_load"]).to_numpy()[ok]
    p = np.linalg.lstsq(Y, y, rcond=None)[0]
    return dict(zip(["I", "mr_x", "mr_y", "f_v", "f_c"], p))


def test_eq4_balance_on_truth(excite_1k):
    fit = _eq4_fit(excite_1k.truth)
    m = excite_1k.params["machine"]
    for k, nom in TABLE3.items():
        # the drawn machine is within the stated seed spread of Table 3 ...
        assert abs(m[k] / nom - 1) <= R.SPREAD_SD * R.SPREAD_CLIP + 1e-12, k
        # ... and the output balance of the truth is Eq. 4 with the drawn machine's values
        tol = {"I": 0.02, "mr_x": 0.05, "mr_y": 0.03, "f_v": 0.01, "f_c": 0.01}[k]
        assert fit[k] == pytest.approx(m[k], rel=tol), (k, fit[k], m[k])
        assert abs(fit[k] / nom - 1) <= R.SPREAD_SD * R.SPREAD_CLIP + tol, (k, fit[k], nom)


def test_eq4_fit_detects_a_wrong_balance(excite_1k):
    """The fit is sensitive: a truth whose inertia term were missing would fail the check."""
    t = excite_1k.truth.copy()
    t["torque"] = t["torque"] - 0.2 * TABLE3["I"] * t["qdd"]
    assert _eq4_fit(t)["I"] == pytest.approx(0.8 * excite_1k.params["machine"]["I"], rel=0.03)


def test_gravity_torque(excite_1k):
    t, m = excite_1k.truth, excite_1k.params["machine"]
    want = 9.81 * (m["mr_x"] * np.sin(t["q"]) + m["mr_y"] * np.cos(t["q"]))
    assert np.allclose(t["gravity"], want, rtol=1e-9, atol=1e-9)
    # the joint starts at rest holding its gravity torque (q = 0: g*mr_y) ...
    assert t["torque"].iloc[0] == pytest.approx(9.81 * m["mr_y"], abs=1.0)
    assert t["torque"].iloc[0] == pytest.approx(-34.543 * 9.81, rel=0.06)
    # ... and while it stands still (before the excitation) friction holds the rest, within the
    # presliding band, and the balance T - tau_L - gravity - friction = I*qdd holds
    still = (t["t"] < 0.9).to_numpy()
    assert np.abs(t["qd"][still]).max() < 1e-3
    resid = t["torque"] - t["torque_load"] - t["gravity"] - t["friction"] - m["I"] * t["qdd"]
    assert np.abs(resid[still]).max() < 1e-6 * 1e3
    assert np.abs(t["friction"][still]).max() < m["f_c"]


def test_twist_half_degree_at_rated_torque():
    r = R.simulate_run(1, 300, 1, 25.0, seed=21, run=0, periods=1)
    t = r.truth
    near = (np.abs(t["torque"] - 120e3) < 2e3).to_numpy()
    assert near.sum() > 10
    twist_deg = np.degrees(t["twist"][near]).mean()
    assert twist_deg == pytest.approx(0.5, rel=0.07)
    assert math.degrees(R.twist_at(r.params["machine"], 120e3)) == pytest.approx(0.5, rel=0.06)
    # the encoders' torsion (q - u) reads the same twist with the opposite sign, to a few steps
    s = r.samples
    assert np.degrees(-s["torsion"][near]).mean() == pytest.approx(twist_deg, abs=0.03)
    # stiffening: the secant stiffness at rated is above the one at 30 kN m
    low = (np.abs(t["torque"] - 30e3) < 2e3).to_numpy()
    assert 30e3 / t["twist"][low].mean() < 120e3 / t["twist"][near].mean()


def test_reduction_motor_speed_and_currents(nominal_s1):
    s, t = nominal_s1.samples, nominal_s1.truth
    steady = (s["phase"] == "load").to_numpy()
    w = s[["w_m1", "w_m2", "w_m3"]].to_numpy()[steady].mean()
    assert w == pytest.approx(3000 * 2 * np.pi / 60, rel=0.03)
    # over a load-unload cycle (the twist returns) the motors turn N times the output
    cyc = s["phase"].isin(["load", "unload"]).to_numpy()
    i0, i1 = np.flatnonzero(cyc)[[0, -1]]
    motor_turn = np.trapezoid(s["w_m1"][i0:i1 + 1], s["t"][i0:i1 + 1])
    assert motor_turn / (s["q"][i1] - s["q"][i0]) == pytest.approx(11000, rel=0.01)
    assert (s["u"][i1] - s["u"][i0]) * 11000 == pytest.approx(motor_turn, rel=0.002)
    # motor torque balance: three motors' currents carry the transmitted torque through N
    i = s[["i_m1", "i_m2", "i_m3"]].to_numpy().sum(1)
    slope = np.polyfit(t["torque"][steady], i[steady], 1)[0]
    assert slope == pytest.approx(1 / (11000 * 1.25), rel=0.08)
    # the output moves in the commanded sense during the loaded phases, and load follows the cmd
    assert (t["qd"][steady] > 0).all()
    assert np.abs(t["torque_load"] - t["torque_cmd"])[steady].max() < 2e3


def test_direction_sets_the_sense():
    kw = dict(sensors=FAST, periods=1, seed=4, run=0)
    neg = R.simulate_run(1, 3000, -1, 25.0, **kw)
    load = (neg.samples["phase"] == "load").to_numpy()
    assert (neg.truth["qd"][load] < 0).all() and neg.samples["torque_cmd"].max() > 1.1e5
    ex = R.simulate_run(3, None, -1, 25.0, **kw)
    ex_p = R.simulate_run(3, None, 1, 25.0, **kw)
    assert np.corrcoef(ex.truth["q"], ex_p.truth["q"])[0, 1] < -0.99


def test_temperature_drifts_and_sets_friction():
    kw = dict(sensors=FAST, periods=1, seed=4, run=0)
    eff = {"temperature_friction": {"form": "viscous_exp_mult", "scale": 1.0}}
    cold = R.simulate_run(1, 3000, 1, 15.0, eff, **kw)
    warm = R.simulate_run(1, 3000, 1, 60.0, eff, **kw)
    assert warm.truth["temp_joint"].iloc[-1] < 60.0          # cools toward the 22 degC hall
    assert cold.samples["temp_joint"].iloc[0] == pytest.approx(15.0, abs=0.3)
    load = (cold.samples["phase"] == "load").to_numpy()
    assert cold.truth["friction"][load].mean() > warm.truth["friction"][load].mean() + 50


def test_one_khz_run_is_fast():
    import time
    R.simulate_run(1, 3000, 1, 25.0, sensors=FAST, periods=1, seed=1, run=0)   # compiled
    t0 = time.perf_counter()
    R.simulate_run(2, 3000, 1, 25.0, periods=3, seed=1, run=0)
    assert time.perf_counter() - t0 < 5.0
