"""Tests of validation rig D (independent J4 rig emulator): determinism, nominal identity,
effect visibility, sampling and metadata."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from validation_rigs.rig_d import (
    EFFECT_FORMS,
    OUT_OF_VOCABULARY,
    REDUCTION,
    SEED_IS_CAMPAIGN,
    SensorSpec,
    simulate_run,
)

VOCABULARY = ("stribeck", "temperature_friction", "load_dependent_friction", "asymmetric_friction",
              "gear_ripple", "backlash", "hysteresis", "torque_offset", "time_delay")
SENS = SensorSpec(sample_rate_hz=20.0, torque_noise=150.0)
# runs on which every form must show: a loaded back-driven slow run and a Fourier run
CASES = ((1, 300.0, -1, 15.0), (3, None, 1, 15.0))


def _run(scheme, speed, direction, temp, effects, seed=3, run=0, sensors=SENS, periods=1):
    return simulate_run(scheme, speed, direction, temp, effects, seed=seed, sensors=sensors,
                        periods=periods, run=run)


def test_interface_constants() -> None:
    assert SEED_IS_CAMPAIGN is True
    assert REDUCTION == 11000.0
    for name in VOCABULARY:
        assert 2 <= len(EFFECT_FORMS[name]) <= 4
    assert len(OUT_OF_VOCABULARY) >= 4
    assert set(OUT_OF_VOCABULARY) <= set(EFFECT_FORMS)
    assert not set(OUT_OF_VOCABULARY) & set(VOCABULARY)
    assert set(EFFECT_FORMS) == set(VOCABULARY) | set(OUT_OF_VOCABULARY)


@pytest.mark.parametrize("scheme,speed", [(1, 3000.0), (3, None)])
def test_zero_scale_is_bit_identical_to_nominal(scheme, speed) -> None:
    nominal = _run(scheme, speed, 1, 30.0, {})
    zero = {name: {"form": forms[0], "scale": 0.0} for name, forms in EFFECT_FORMS.items()}
    other = _run(scheme, speed, 1, 30.0, zero)
    pd.testing.assert_frame_equal(nominal.samples, other.samples, check_exact=True)
    pd.testing.assert_frame_equal(nominal.truth, other.truth, check_exact=True)


@pytest.mark.parametrize("name,form", [(n, f) for n, fs in EFFECT_FORMS.items() for f in fs])
def test_each_form_changes_torque_or_twist_reading(name, form) -> None:
    changed = []
    for scheme, speed, direction, temp in CASES:
        base = _run(scheme, speed, direction, temp, {})
        eff = _run(scheme, speed, direction, temp, {name: {"form": form, "scale": 1.0}})
        d_torque = np.abs(eff.samples["torque"] - base.samples["torque"]).max()
        twist_b = base.samples["u"] - base.samples["q"]
        twist_e = eff.samples["u"] - eff.samples["q"]
        d_twist = np.abs(twist_e - twist_b).max()
        # visible: above the torque noise sd, or above two output-encoder steps
        changed.append(d_torque > SENS.torque_noise or d_twist > 2 * np.radians(SENS.encoder_res_deg))
    assert any(changed), (name, form)


def test_effect_roughly_linear_in_scale() -> None:
    base = _run(3, None, 1, 18.0, {})
    d = []
    for s in (0.5, 1.0):
        eff = _run(3, None, 1, 18.0, {"torque_offset": {"form": "constant", "scale": s}})
        d.append(float((eff.truth["torque"] - base.truth["torque"]).mean()))
    assert d[1] == pytest.approx(2.0 * d[0], rel=1e-6)
    assert d[1] != 0.0


def test_determinism_by_seed_and_run() -> None:
    a = _run(2, 3000.0, 1, 25.0, {"stribeck": {"form": "gaussian", "scale": 1.0}}, seed=5, run=2)
    b = _run(2, 3000.0, 1, 25.0, {"stribeck": {"form": "gaussian", "scale": 1.0}}, seed=5, run=2)
    pd.testing.assert_frame_equal(a.samples, b.samples, check_exact=True)
    c = _run(2, 3000.0, 1, 25.0, {"stribeck": {"form": "gaussian", "scale": 1.0}}, seed=5, run=3)
    assert not np.array_equal(a.samples["torque"].to_numpy(), c.samples["torque"].to_numpy())


def test_same_seed_different_run_keeps_rig_parameters() -> None:
    # T − τ_L of an unloaded Fourier run is set by the rig's parameters (friction, inertia,
    # gravity); subtracting the actual load removes the dynamometer's random error
    def net(seed: int, run: int) -> pd.Series:
        r = _run(3, None, 1, 25.0, {}, seed=seed, run=run)
        return (r.truth["torque_joint"] - r.truth["torque_load"])[r.samples["phase"] == "excite"]

    a, b = net(11, 0), net(11, 1)
    same = float(np.abs(a - b).median())
    assert same < 5.0
    for other_seed in (12, 13):
        assert float(np.abs(a - net(other_seed, 0)).median()) > 5.0 * same
    ra = _run(3, None, 1, 25.0, {}, seed=11, run=0)
    rb = _run(3, None, 1, 25.0, {}, seed=11, run=1)
    assert not np.array_equal(ra.samples["torque"].to_numpy(), rb.samples["torque"].to_numpy())


@pytest.mark.parametrize("fs", [10.0, 1000.0])
def test_sample_counts_and_columns(fs) -> None:
    r = _run(2, 3000.0, -1, 40.0, {}, sensors=SensorSpec(sample_rate_hz=fs))
    assert len(r.samples) == int(round(60.0 * fs))
    assert len(r.truth) == len(r.samples)
    assert np.allclose(np.diff(r.samples["t"]), 1.0 / fs)
    for col in ("t", "q", "qd", "u", "ud", "torque", "torque_load", "temp_joint", "phase",
                "i_m1", "i_m2", "i_m3", "w_m1", "w_m2", "w_m3"):
        assert col in r.samples.columns
    for col in ("t", "q", "qd", "u", "ud", "twist", "torque", "torque_load", "torque_joint"):
        assert col in r.truth.columns
    assert set(r.samples["phase"]) == {"idle", "load", "hold", "unload"}
    assert np.all(np.isfinite(r.samples.drop(columns="phase").to_numpy()))
    assert r.meta["duration_s"] == pytest.approx(60.0)
    # direction -1 moves the output negative; load reaches the rated 120 kN·m
    assert r.truth["q"].iloc[-1] < -1.0
    assert r.truth["torque_load"].max() == pytest.approx(120000.0, abs=2500.0)


def test_scheme3_periods_and_encoder_quantisation() -> None:
    spec = SensorSpec(sample_rate_hz=50.0, encoder_res_deg=0.01)
    r = _run(3, None, 1, 25.0, {}, sensors=spec, periods=2)
    assert len(r.samples) == int(round((4.0 + 40.0) * 50.0))
    steps = r.samples["q"] / np.radians(0.01)
    assert np.allclose(steps, np.round(steps), atol=1e-6)
    assert set(r.samples["phase"]) == {"idle", "excite"}


def test_meta_sensors_present() -> None:
    spec = SensorSpec(sample_rate_hz=100.0, encoder_res_deg=0.005, torque_noise=200.0, torque_lag_s=0.01)
    r = _run(1, 300.0, 1, 20.0, {"time_delay": {"form": "transport", "scale": 1.0}}, sensors=spec)
    m = r.meta
    assert m["rig"] == "validation-rig-D" and m["source"] == "emulator" and m["reduction"] == 11000
    assert m["scheme"] == 1 and m["motor_speed_rpm"] == 300.0 and m["direction"] == 1
    s = m["sensors"]
    assert s["q"]["resolution"] == pytest.approx(np.radians(0.005))
    assert s["u"]["resolution"] > 0
    assert s["torque"]["noise_sd"] == 200.0
    # the data sheet states the sensor's own lag, not the injected delay
    assert 0.01 <= s["torque"]["lag_s"] < 0.02
    assert s["torque_load"]["noise_sd"] > 0
    assert s["temp_joint"]["resolution"] > 0


@pytest.mark.parametrize("effects", [
    {"friction_wear": {"form": "x", "scale": 1.0}},
    {"stribeck": {"form": "cubic", "scale": 1.0}},
])
def test_unknown_effect_or_form_raises(effects) -> None:
    with pytest.raises(ValueError):
        _run(3, None, 1, 25.0, effects)
