"""A dead zone on the twist–torque law must show as lost motion
(estimator.diagnosis_transmission.lost_motion_objection): the twist read as a function of the
torque steps where the torque reverses. Through a twist rounded to the encoder's step, a smooth
compliance curve's softer centre fits the dead zone's column too; the inverse law tells the
two apart. Synthetic campaigns, then end to end on validation rigs Z (an exponential curve) and
AA (a break 4 encoder steps from zero) and on the own emulator's sub-step dead zone."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from commands import diagnosis_harness as own
from commands.independent_harness import VARIANTS, simulate_campaign
from estimator.diagnosis import diagnose
from estimator.diagnosis_candidates import _best_shape, _candidate_models
from estimator.diagnosis_options import DiagnosisOptions
from estimator.diagnosis_transmission import compliance_knees, lost_motion_objection
from estimator.models import eq5, with_stiffening

STEP = np.radians(0.01)                      # output encoder step [rad]
K = 1.2e7                                    # N·m/rad
D = 4e4                                      # N·m·s/rad


def dead_zone(d: np.ndarray, b0: float = 2.0 * STEP) -> np.ndarray:
    """A sharp dead zone of half-width b0 [rad] on a linear stiffness K [N·m]."""
    return K * np.sign(d) * np.maximum(np.abs(d) - b0, 0.0)


def smooth_corner(d: np.ndarray) -> np.ndarray:
    """An exponential compliance curve [N·m] like rig Z's: stiffness 8e6 N·m/rad at zero
    twist, 1.6 times that at 9 mrad, no gap."""
    c = np.log(1.6) / 9e-3
    return 8e6 / c * (np.exp(c * np.abs(d)) - 1.0) * np.sign(d)


def hardening_threefold(d: np.ndarray) -> np.ndarray:
    """A hardening power law [N·m]: stiffness 6e6 N·m/rad at zero twist, three times that at
    9 mrad (T = k0·Δ·(1 + 0.8·|Δ/9 mrad|^1.5)), no gap."""
    return 6e6 * d * (1.0 + 0.8 * np.abs(d / 9e-3) ** 1.5)


def campaign(law, seed: int = 0) -> dict:
    """Six runs pooled (100 Hz, 40 s each): three loaded (the twist ramps between 1 and 9 mrad,
    the torque keeps its sign) and three that reverse it (the twist swings ±4 to ±8 mrad); the
    twist read through a 0.01° encoder zeroed within its step, the torque law(Δ) + D·Δ̇ + 60 N·m
    of white noise."""
    rng = np.random.default_rng(seed)
    parts = []
    for r in range(6):
        t = np.arange(0.0, 40.0, 0.01)
        if r < 3:
            d = 5e-3 + 4e-3 * np.sin(2 * np.pi * t / 13.0 + r)
        else:
            d = (4e-3 + 2e-3 * (r - 3)) * np.sin(2 * np.pi * t / (7.0 + r) + r)
        dd = np.gradient(d, t)
        torque = law(d) + D * dd + 60.0 * rng.standard_normal(t.size)
        read = STEP * np.round((d + rng.uniform(-0.5, 0.5) * STEP) / STEP)
        parts.append({"t": t, "torsion": read, "torsion_rate": np.gradient(read, t),
                      "torque": torque, "run": np.full(t.size, r)})
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def dead_zone_fit(sig: dict, opt: DiagnosisOptions):
    """The backlash candidate's best fit on the nominal elastic law with its knees, as the
    diagnosis searches it."""
    nominal = with_stiffening(eq5(), compliance_knees(sig, opt))
    cands, _ = _candidate_models(nominal, sig, replace(opt, candidates=("backlash",)),
                                 np.zeros(sig["t"].size))
    return _best_shape(cands["backlash"], sig, sig)


def test_a_dead_zone_two_steps_wide_shows_its_lost_motion():
    opt = DiagnosisOptions()
    sig = campaign(dead_zone)
    f = dead_zone_fit(sig, opt)
    assert f.objection is None
    assert f.theta[list(f.model.param_names).index("k_bl")] > 0
    assert lost_motion_objection(f, sig, opt) is None


def test_a_smooth_corner_is_no_dead_zone():
    """The dead zone's column fits the exponential curve's softer centre with a physical
    k_bl > 0 (what the diagnosis would name without the objection); the twist shows no step
    where the torque reverses, and the objection says so."""
    opt = DiagnosisOptions()
    sig = campaign(smooth_corner)
    f = dead_zone_fit(sig, opt)
    assert f.objection is None                       # no other objection would stop it
    assert f.theta[list(f.model.param_names).index("k_bl")] > 0
    why = lost_motion_objection(f, sig, opt)
    assert why is not None and "lost motion" in why


def test_a_curve_that_hardens_threefold_is_no_dead_zone():
    """Over the whole torque range the inverse law's cubic misses this curve's top, and the
    misfit leaked into sgn T (j about half the gap the fit needs: not objected, and rig AB's
    30 Hz nominal was named `backlash`); over the lower half of the torques the cubic holds."""
    opt = DiagnosisOptions()
    sig = campaign(hardening_threefold)
    f = dead_zone_fit(sig, opt)
    assert f.objection is None
    assert f.theta[list(f.model.param_names).index("k_bl")] > 0
    why = lost_motion_objection(f, sig, opt)
    assert why is not None and "lost motion" in why


def test_no_objection_where_no_run_reverses_the_torque():
    """Loaded runs alone: sgn T is one more constant per run, and the twist cannot show the
    lost motion; the objection stays silent rather than guess."""
    opt = DiagnosisOptions()
    sig = campaign(smooth_corner)
    keep = sig["run"] < 3
    loaded = {k: v[keep] for k, v in sig.items()}
    f = dead_zone_fit(loaded, opt)
    assert lost_motion_objection(f, loaded, opt) is None


@pytest.mark.parametrize("name, seed, why", [("rig Z 120 Hz", 5501, "objection"),
                                             ("rig AA 15 Hz", 5601, "objection"),
                                             ("rig AB 30 Hz", 5701, "corner")])
def test_a_compliance_curve_near_zero_twist_is_not_named_backlash(name, seed, why):
    """Rig Z's exponential curve and rig AA's first break (4 encoder steps from zero) were
    named `backlash` on the twist law of their nominal campaigns before the objection; rig AB's
    curve, which hardens threefold, before the inverse law kept to the lower half of the
    torques. Rig AB's curve is now the nominal's own (a stiffness change spread about a
    corner, smooth_corner), which leaves the dead zone nothing to take."""
    v = next(v for v in VARIANTS if v.name.startswith(name))
    train, test, _ = simulate_campaign(v, seed)
    rep = diagnose(train, test, "eq4", transmission="eq5")
    assert "backlash" not in rep["verdict"]["effects"]
    row = next(r for r in rep["transmission"]["candidates"] if r["effect"] == "backlash")
    if why == "objection":
        assert "lost motion" in row.get("objection", ""), row
    else:
        assert "corner" in rep["transmission"]["baseline"]["shape"]
        assert not row["significant"] and row["shrinkage"] < 0.01, row


def test_the_own_emulators_sub_step_dead_zone_is_still_named():
    """The own emulator's dead zone at ENR 0.5 is 0.14 of the 0.01° encoder's step: the inverse
    law cannot resolve it (its standard error exceeds the gap), so the objection stays silent."""
    effects, tx = own.world({"backlash": own.magnitude_for("backlash", 0.5)})
    train, test = own.simulate_campaign(effects, 5601)
    rep = diagnose(train, test, "eq4", transmission=tx)
    assert rep["verdict"]["effects"] == ["backlash"]
