"""The nominal twist–torque law's compliance curve (estimator.models.with_stiffening with the knees
of estimator.diagnosis_transmission.compliance_knees): a three-slope curve, as a harmonic drive's catalogue
gives it, is part of the nominal law — its knees are found from the data — while a dead zone
(backlash) stays outside it, because the knees searched lie beyond the widest dead zone
searched. And the physical sign of a fitted effect (estimator.models.physical_objection): a dead
zone that stiffens the centre, or a hysteresis loop run backwards, is never significant."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from core.effects import backlash_twist
from estimator.diagnosis_transmission import compliance_knees
from estimator.diagnosis_options import DiagnosisOptions
from estimator.least_squares import ols
from estimator.models import eq5, with_stiffening

K1, K2, K3 = 0.7e7, 1.2e7, 1.7e7       # N·m/rad, the slopes of a harmonic drive's catalogue
T1, T2 = 15e3, 50e3                     # N·m, the knee torques


def three_slope(d: np.ndarray) -> np.ndarray:
    """T(Δ) of the three-slope curve [N·m]: slope K1 up to T1, K2 up to T2, K3 above."""
    th1 = T1 / K1
    th2 = th1 + (T2 - T1) / K2
    a = np.abs(d)
    t = np.where(a <= th1, K1 * a,
                 np.where(a <= th2, T1 + K2 * (a - th1), T2 + K3 * (a - th2)))
    return np.sign(d) * t


def signals(curve, n: int = 6000, seed: int = 0, noise: float = 100.0) -> dict:
    """Twist swept back and forth over ±9.5 mrad (ramps, as the load schemes do) and the torque
    `curve(Δ)` + D·Δ̇ + white noise."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 120.0, n)
    d = 9.5e-3 * np.sin(2 * np.pi * t / 40.0) ** 3
    dd = np.gradient(d, t)
    torque = curve(d) + 5e4 * dd + noise * rng.standard_normal(n)
    return {"t": t, "torsion": d, "torsion_rate": dd, "torque": torque}


def output_balance(effect, seed: int, load: float = 0.0) -> dict:
    """A joint swung ±0.3 rad with a 24 s period (Eq. 4 with 100 N·m of white noise), a load up
    to `load` [N·m] that resists the motion, and `effect(qd, base)` added to the torque (base:
    the nominal torque)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 240.0, 12000)
    w = 2 * np.pi / 24.0
    q, qd, qdd = 0.3 * np.sin(w * t), 0.3 * w * np.cos(w * t), -0.3 * w * w * np.sin(w * t)
    tau_l = load * np.abs(np.sin(2 * np.pi * t / 40.0)) * np.sign(qd)
    base = (tau_l + 6700.0 * qdd + 9.81 * (21.0 * np.sin(q) - 34.0 * np.cos(q)) + 8800.0 * qd
            + 2300.0 * np.sign(qd))
    torque = base + effect(qd, base) + 100.0 * rng.standard_normal(t.size)
    return {"t": t, "q": q, "qd": qd, "qdd": qdd, "torque": torque, "torque_load": tau_l,
            "run": np.full(t.size, seed, dtype=int)}


def _assert_the_sign_decides(models, m, tr, te, param: str, sign: int) -> None:
    """The best shape's `param` has the sign of `sign`, and the candidate is significant exactly
    when that is its physics' sign (else it carries an objection)."""
    from estimator.diagnosis_candidates import _best_shape, _fit, _score
    f = _best_shape(models, tr, te)
    value = f.theta[list(f.model.param_names).index(param)]
    row = _score(_fit(m, {}, tr, te), f, np.arange(te["t"].size) // 200, DiagnosisOptions())
    assert np.sign(value) == sign, value
    assert row["significant"] == (sign > 0) and (("objection" in row) == (sign < 0)), row


def test_the_knees_of_a_three_slope_curve_are_found_and_the_curve_is_nominal():
    sig = signals(three_slope)
    knees = compliance_knees(sig, DiagnosisOptions())
    th1 = T1 / K1
    th2 = th1 + (T2 - T1) / K2
    top = float(np.quantile(np.abs(sig["torsion"]), 0.99))
    # the grid's step is 0.05 of the top twist
    assert abs(knees[0] - th1) <= 0.05 * top and abs(knees[1] - th2) <= 0.05 * top, knees
    rmse = {}
    for name, m in (("cubic", with_stiffening(eq5())), ("knees", with_stiffening(eq5(), knees))):
        f = ols(m.design(sig), m.target(sig))
        rmse[name] = float(np.sqrt(f.rss / sig["torque"].size))
    # with its knees the law is near the noise (100 N·m); the cubic alone is not
    assert rmse["knees"] < 250.0 < rmse["cubic"], rmse


def test_a_dead_zone_is_not_taken_into_the_compliance_curve():
    """Backlash of half-width b = 0.1 mrad on a linear spring: its column still explains most of
    what the nominal law (with its knees) leaves."""
    b = 1e-4

    def dead_zone(d):
        return 1.3e7 * backlash_twist(d, b)
    sig = signals(dead_zone)
    m = with_stiffening(eq5(), compliance_knees(sig, DiagnosisOptions()))
    f0 = ols(m.design(sig), m.target(sig))
    col = backlash_twist(sig["torsion"], b) - sig["torsion"]
    f1 = ols(np.column_stack([m.design(sig), col]), m.target(sig))
    assert f1.rss < 0.2 * f0.rss, (f0.rss, f1.rss)


def test_knees_inside_the_dead_zones_searched_are_refused():
    opt = replace(DiagnosisOptions(), compliance_knee_rel=(0.1, 0.5))
    with pytest.raises(ValueError, match="backlash_b_rel"):
        compliance_knees(signals(three_slope), opt)


def test_the_curve_is_reported_with_its_knees_and_its_stiffness_changes():
    sig = signals(three_slope)
    knees = compliance_knees(sig, DiagnosisOptions())
    m = with_stiffening(eq5(), knees)
    assert m.name == "eq5+stiffening"
    assert list(m.param_names[-3:]) == ["k3", "dk_1", "dk_2"]
    theta = ols(m.design(sig), m.target(sig)).theta
    p = dict(zip(m.param_names, theta))
    # the slope beyond the second knee is K3 (± a grid step's worth of misplacement)
    assert p["k"] + p["dk_1"] + p["dk_2"] == pytest.approx(K3, rel=0.1)
    assert with_stiffening(m, knees) is m


def test_a_dead_zone_fitted_with_a_stiffer_centre_is_not_backlash():
    """A transmission whose centre is stiffer than the rest (a softening curve, which the
    nominal's stiffening knees cannot take): the backlash column fits it with k_bl < 0, a dead
    zone that adds stiffness inside its gap — no backlash does, so the candidate is never
    significant; a real dead zone's k_bl > 0 is."""
    def soft(d):
        return 1.3e7 * d + 0.6e7 * np.clip(d, -1e-3, 1e-3)     # stiffer within ±1 mrad

    def dead(d):
        return 1.3e7 * backlash_twist(d, 1e-4)
    opt = DiagnosisOptions()
    for curve, sign in ((soft, -1), (dead, 1)):
        tr, te = signals(curve, seed=1), signals(curve, seed=2)
        tr["run"], te["run"] = np.zeros(tr["t"].size, int), np.ones(te["t"].size, int)
        m = with_stiffening(eq5(), compliance_knees(tr, opt))
        models = [({"b": b}, m.with_effect("backlash", b=b)) for b in (2e-4, 5e-4, 1e-3)]
        _assert_the_sign_decides(models, m, tr, te, "k_bl", sign)


def test_a_loop_run_backwards_is_not_hysteresis():
    """A passive hysteretic element dissipates: its torque is higher on loading than on
    unloading (k_h > 0). A loop the other way round (k_h < 0: what a torque reading whose lag
    is not all stated draws) is never a significant hysteresis; the same loop the right way
    round is."""
    opt = DiagnosisOptions()

    def spring(d):
        return 1.3e7 * d
    for sign in (-1, 1):
        tr, te = signals(spring, seed=3), signals(spring, seed=4)
        for s in (tr, te):
            # a loop of ±3 kN·m that switches with the twist's direction over ~0.2 mrad
            s["torque"] = s["torque"] + sign * 3e3 * np.tanh(s["torsion_rate"] / 2e-5)
            s["run"] = np.zeros(s["t"].size, int) + (s is te)
        m = with_stiffening(eq5(), compliance_knees(tr, opt))
        models = [({"alpha": 1.0, "beta": b, "gamma": b, "n": 1},
                   m.with_effect("hysteresis", alpha=1.0, beta=b, gamma=b, n=1))
                  for b in (2e3, 5e3, 1e4)]
        _assert_the_sign_decides(models, m, tr, te, "k_h", sign)


def test_a_soft_centre_is_the_curves_first_segment_and_a_dead_zone_is_not():
    """A transmission softer near zero twist (its teeth taking up the load progressively:
    stiffness K_in inside ±θ, K beyond, K_in/K = 0.55) is nominal; a dead zone (no stiffness
    inside its gap) is left to the backlash candidate, and so is a smoothed one."""
    from estimator.diagnosis_transmission import centre_knee
    k, theta = 1.5e7, 0.8e-3
    opt = DiagnosisOptions()

    def soft(d):
        return k * d - 0.45 * k * np.clip(d, -theta, theta)

    def dead(d):
        return k * backlash_twist(d, theta)

    def smoothed_dead(d):
        eps = 0.3 * theta
        sp = lambda x: eps * np.logaddexp(0.0, x / eps)      # noqa: E731
        return k * (sp(d - theta) - sp(-d - theta))

    found = {}
    for name, curve in (("soft", soft), ("dead", dead), ("smoothed dead", smoothed_dead)):
        sig = signals(curve)
        found[name] = centre_knee(sig, compliance_knees(sig, opt), opt, 1e-5)
    top = float(np.quantile(np.abs(signals(soft)["torsion"]), 0.99))
    assert found["soft"] is not None and found["soft"][0] == "soft", found
    assert abs(found["soft"][1] - theta) < 0.5 * theta, found
    assert found["dead"] is None and found["smoothed dead"] is None, found
    assert found["soft"][1] <= max(opt.backlash_b_rel) * top
    sig = signals(soft)
    knees = compliance_knees(sig, opt)
    # a centre a few encoder steps wide cannot be told from a dead zone blurred by the rounding,
    # and without the steps stated there is no telling at all
    assert centre_knee(sig, knees, opt, theta / 3.0) is None
    assert centre_knee(sig, knees, opt, None) is None


def test_a_stiffer_centre_is_the_curves_first_segment():
    """A preloaded stage is stiffer near zero twist (a step of torque across zero, the preload:
    rig V's T = k·Δ + T_s·tanh(Δ/θ_s)). No dead zone makes one, so it needs no encoder step to
    be told from backlash; a linear law has none."""
    from estimator.diagnosis_transmission import centre_knee
    opt = DiagnosisOptions()
    k, t_s, theta = 1.3e7, 5e3, 2e-4

    def preloaded(d):
        return k * d + t_s * np.tanh(d / theta)

    def two_slope(d):
        return k * d + 0.6 * k * np.clip(d, -1e-3, 1e-3)     # stiffer within ±1 mrad

    for curve, width in ((preloaded, theta), (two_slope, 1e-3)):
        sig = signals(curve)
        found = centre_knee(sig, compliance_knees(sig, opt), opt, None)
        assert found is not None and found[0] == "stiff", found
        assert width / 3.0 < found[1] < 3.0 * width, found


def test_a_twist_read_through_its_rounding_makes_no_stiffer_centre():
    """A linear law whose twist dwells within a step or two of zero (an unloaded run: the
    friction's torque moves while the reading sits at 0 or ±1 step) looks stiffer at its centre
    through the rounding. The preload a stiffer centre makes must exceed the torque of half a
    step through the stiffness beyond it. Before, each seed here kept one a tenth to a third of
    a step wide, as the own emulator's nominal twist law did on every seed (and named backlash
    on seed 5002 to undo it); rig V's 5 kN·m preload is 3.6-8 times that torque."""
    from estimator.diagnosis_transmission import centre_knee
    opt = DiagnosisOptions()
    step = 1.745e-4
    t = np.linspace(0.0, 240.0, 12000)
    d = np.where(t < 120.0, 9.5e-3 * np.sin(2 * np.pi * t / 40.0) ** 3,
                 2.5e-4 * np.sin(2 * np.pi * t / 20.0))
    read = np.round(d / step) * step
    for seed in range(4):
        rng = np.random.default_rng(seed)
        sig = {"t": t, "torsion": read, "torsion_rate": np.gradient(read, t),
               "torque": 1.3e7 * d + 5e4 * np.gradient(d, t) + 100.0 * rng.standard_normal(t.size),
               "run": (t >= 120.0).astype(int)}
        assert centre_knee(sig, compliance_knees(sig, opt), opt, step) is None, seed
    # the same law with a 5 kN·m preload within ±0.2 mrad keeps its stiffer centre
    sig["torque"] = sig["torque"] + 5e3 * np.tanh(d / 2e-4)
    found = centre_knee(sig, compliance_knees(sig, opt), opt, step)
    assert found is not None and found[0] == "stiff", found

def test_a_linear_laws_noise_makes_no_centre():
    """A linear law's noise makes neither a stiffer nor a softer centre: either needs its
    stiffness change beyond z_gain of its block-robust standard error. Before, a softer centre
    was kept whenever the change came out positive (about every other seed) and spanned five
    encoder steps."""
    from estimator.diagnosis_transmission import centre_knee
    opt = DiagnosisOptions()
    for seed in range(8):
        sig = signals(lambda d: 1.3e7 * d, seed=seed)
        knees = compliance_knees(sig, opt)
        for resolution in (None, 1e-6):
            found = centre_knee(sig, knees, opt, resolution)
            assert found is None, (seed, resolution, found)


def _in_runs(sig: dict, runs: int = 6) -> dict:
    """`sig` cut into `runs` runs of equal length (the column `run`)."""
    n = sig["t"].size
    return {**sig, "run": np.arange(n) * runs // n}


def rational_tangent(d: np.ndarray) -> np.ndarray:
    """T(Δ) [N·m] of a curve that bends over the whole range: a tangent stiffness
    k0·(1 + 2x²)/(1 + x²), x = Δ/3 mrad (k0 at the centre, 2·k0 far out)."""
    k0, dc = 1e7, 3e-3
    return k0 * dc * (2.0 * d / dc - np.arctan(d / dc))


def test_a_curve_that_bends_over_the_whole_range_takes_a_smooth_corner():
    """Knees bend the curve at a twist each; a curve whose tangent stiffness rises smoothly over
    the whole range (rig AE's rational tangent) is left by the cubic and two knees with a
    residual that swings with the twist, several times the noise. A stiffness change spread
    about a corner (corner_column) takes it, with its corner found near the curve's own."""
    from estimator.diagnosis_transmission import smooth_corner
    opt = DiagnosisOptions()
    sig = _in_runs(signals(rational_tangent, noise=30.0))
    knees = compliance_knees(sig, opt)
    corner = smooth_corner(sig, knees, None, opt)
    assert corner is not None and 1.5e-3 < corner < 6e-3, corner
    rmse = {}
    for name, m in (("knees", with_stiffening(eq5(), knees)),
                    ("corner", with_stiffening(eq5(), compliance_knees(sig, opt, corner),
                                               corner=corner))):
        f = ols(m.design(sig), m.target(sig))
        rmse[name] = float(np.sqrt(f.rss / sig["torque"].size))
    assert rmse["corner"] < 45.0 < 2.0 * 45.0 < rmse["knees"], rmse
    m = with_stiffening(eq5(), knees, corner=corner)
    assert m.param_names[-1] == "dk_c" and "dk_c" in m.descriptions


def test_a_law_that_lacks_nothing_takes_no_smooth_corner():
    """A linear law and a three-slope curve (its knees found) leave only noise: the corner's
    column is then not confirmed on the runs left out, whatever the seed."""
    from estimator.diagnosis_transmission import smooth_corner
    opt = DiagnosisOptions()
    for seed in range(4):
        for curve in (lambda d: 1.3e7 * d, three_slope):
            sig = _in_runs(signals(curve, seed=seed))
            assert smooth_corner(sig, compliance_knees(sig, opt), None, opt) is None, seed


def test_a_dead_zone_is_not_taken_by_a_smooth_corner():
    """Backlash of half-width 0.1 mrad on a linear spring: with whatever corner the law takes,
    the dead zone's column still explains most of what the nominal law leaves. And a corner
    inside the dead zones searched is refused."""
    from estimator.diagnosis_transmission import smooth_corner
    b = 1e-4
    opt = DiagnosisOptions()
    sig = _in_runs(signals(lambda d: 1.3e7 * backlash_twist(d, b)))
    knees = compliance_knees(sig, opt)
    corner = smooth_corner(sig, knees, None, opt)
    m = with_stiffening(eq5(), knees, corner=corner)
    f0 = ols(m.design(sig), m.target(sig))
    col = backlash_twist(sig["torsion"], b) - sig["torsion"]
    f1 = ols(np.column_stack([m.design(sig), col]), m.target(sig))
    assert f1.rss < 0.2 * f0.rss, (corner, f0.rss, f1.rss)
    with pytest.raises(ValueError, match="backlash_b_rel"):
        smooth_corner(sig, knees, None, replace(opt, compliance_corner_rel=(0.1, 0.5)))


def test_friction_that_falls_short_of_coulomb_at_low_speed_is_not_stribeck():
    """A Stribeck curve is friction that rises above the Coulomb level toward rest (f_s > 0).
    Friction short of it at low speed (f_s < 0: a presliding bearing rebuilding its friction
    after a stop) is never a significant Stribeck candidate; the same curve the right way up
    is."""
    from core.effects import stribeck_torque
    from estimator.models import eq4
    for sign in (-1, 1):
        def curve(qd, base, sign=sign):
            return stribeck_torque(qd, sign * 1500.0, 0.01, 1e-6)
        tr, te = output_balance(curve, 0), output_balance(curve, 1)
        m = eq4()
        models = [({"v_s": v}, m.with_effect("stribeck", v_s=v, delta=2.0))
                  for v in (0.005, 0.01, 0.02)]
        _assert_the_sign_decides(models, m, tr, te, "f_s", sign)


def test_friction_that_falls_with_the_load_is_not_load_dependent_friction():
    """Friction that grows with the transmitted load has μ > 0. μ < 0, an efficiency that rises
    with the load, is what a torque transducer's gain error draws when the load resists the
    motion (rig L's nominal at 750 Hz): never a significant candidate; μ > 0 is."""
    from estimator.models import eq4
    for sign in (-1, 1):
        def efficiency(qd, base, sign=sign):
            return sign * 0.01 * np.abs(base) * np.sign(qd)
        tr, te = output_balance(efficiency, 0, load=6e4), output_balance(efficiency, 1, load=6e4)
        m = eq4()
        _assert_the_sign_decides([({}, m.with_effect("load_dependent_friction"))], m, tr, te,
                                 "mu", sign)

