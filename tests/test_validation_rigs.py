"""The independently written validation rigs (validation_rigs/): they import nothing of this
repository, keep their physics, quantise and sample as their sensors say, inject every form of
every effect they list (scale 0 = off), refuse unknown names, and repeat bit for bit per seed."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from validation_rigs import planned_motion, two_inertia

RIGS = {"two_inertia": two_inertia, "planned_motion": planned_motion}
OURS = {"core", "commands", "simulators", "estimator", "daq", "db", "api", "rig"}
ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", sorted(RIGS))
def test_a_rig_imports_nothing_of_the_repository(name):
    tree = ast.parse((ROOT / "validation_rigs" / f"{name}.py").read_text())
    mods = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import)
            for a in n.names}
    mods |= {n.module.split(".")[0] for n in ast.walk(tree)
             if isinstance(n, ast.ImportFrom) and n.module}
    assert not mods & (OURS | {"validation_rigs"}), mods


@pytest.mark.parametrize("name", sorted(RIGS))
def test_the_output_balance_holds_on_the_truth_while_sliding(name):
    """T − τ_L − g·(mr_x sin q + mr_y cos q) − I·q̈ = friction: at constant speed away from the
    start it is the steady friction f_c + f_v·|q̇| (within a few %), the same both ways."""
    mod = RIGS[name]
    out = []
    for d in (1, -1):
        r = mod.simulate_run(1, 3000, d, 40.0, {}, seed=5, sensors=mod.SensorSpec(
            sample_rate_hz=100.0))
        tr = r.truth
        m = (tr["t"] > 10) & (tr["t"] < tr["t"].iloc[-1] - 10)
        q, qd, T, tl = (tr[k].to_numpy()[m] for k in ("q", "qd", "torque", "torque_load"))
        grav = 9.81 * (20.8 * np.sin(q) - 34.5 * np.cos(q))
        out.append(np.median((T - tl - grav) * np.sign(qd)))
    nominal = 2353.0 + 8683.0 * 3000 * 2 * np.pi / 60 / 11000
    assert out[0] == pytest.approx(nominal, rel=0.12) and out[1] == pytest.approx(nominal, rel=0.12)


@pytest.mark.parametrize("name", sorted(RIGS))
def test_sensors_quantise_and_sample_as_specified(name):
    mod = RIGS[name]
    spec = mod.SensorSpec(sample_rate_hz=50.0, encoder_res_deg=0.02)
    r = mod.simulate_run(2, 300, -1, 30.0, {}, seed=3, sensors=spec)
    step = np.deg2rad(0.02)
    q = r.samples["q"].to_numpy()
    assert np.allclose(q / step, np.round(q / step))
    assert np.median(np.diff(r.samples["t"])) == pytest.approx(0.02)
    assert r.meta["sensors"]["q"]["resolution"] == pytest.approx(step)
    assert r.meta["sample_rate_hz"] == 50.0
    assert set(r.samples.columns) >= {"t", "q", "qd", "u", "ud", "torsion", "torque",
                                      "torque_load", "temp_joint", "phase"}


@pytest.mark.parametrize("name", sorted(RIGS))
def test_every_form_acts_and_scale_zero_is_no_effect(name):
    mod = RIGS[name]
    spec = mod.SensorSpec(sample_rate_hz=20.0)
    base = {s: mod.simulate_run(s, 3000 if s != 3 else None, 1, 20.0, {}, seed=9,
                                sensors=spec, periods=2) for s in (1, 3)}
    for eff, forms in mod.EFFECT_FORMS.items():
        for form in forms:
            moved = 0.0
            for s, b in base.items():
                r = mod.simulate_run(s, 3000 if s != 3 else None, 1, 20.0,
                                     {eff: {"form": form, "scale": 1.0}}, seed=9,
                                     sensors=spec, periods=2)
                for ch in ("torque", "torque_load", "torsion"):
                    moved = max(moved, float(np.nanmax(np.abs(r.samples[ch] - b.samples[ch]))))
            assert moved > 1e-6, (eff, form)
            off = mod.simulate_run(1, 3000, 1, 20.0, {eff: {"form": form, "scale": 0.0}},
                                   seed=9, sensors=spec, periods=2)
            assert np.allclose(off.samples["torque"], base[1].samples["torque"], equal_nan=True)


@pytest.mark.parametrize("name", sorted(RIGS))
def test_same_seed_same_run_and_unknown_names_refused(name):
    mod = RIGS[name]
    a = mod.simulate_run(3, None, -1, 25.0, {}, seed=4, periods=2)
    b = mod.simulate_run(3, None, -1, 25.0, {}, seed=4, periods=2)
    assert a.samples.equals(b.samples)
    with pytest.raises(ValueError, match="cogging"):
        mod.simulate_run(1, 300, 1, 25.0, {"cogging": {}}, seed=4)
    with pytest.raises(ValueError, match="form"):
        mod.simulate_run(1, 300, 1, 25.0, {"stribeck": {"form": "cubic"}}, seed=4)
