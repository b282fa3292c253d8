"""The Bouc–Wen fit's sub-step counts are fixed from the data for the whole fit
(estimator.bouc_wen_kernel.substep_counts, BoucWenTarget.fix_substeps): the log density is then
smooth in (β, γ) where the shared step's own rule made it jump, the fixed-count recursion is the
shared step bit for bit when the counts agree, the emulator keeps its own rule, and HMC on a
protocol-rate (20 Hz) pair of emulated loading runs converges without touching its step floor."""

import numpy as np
import pytest

from core.params import JointParams
from core.terms import bouc_wen_step, eq11_regressor
from estimator.bouc_wen import fit_bouc_wen, least_squares_fit, substep_stiffness
from estimator.bouc_wen_kernel import (SUBSTEP_TOL, bw_state, bw_state_sensitivities,
                                       stiffness_bound, substep_counts)
from estimator.bouc_wen_target import build_target

P = JointParams()


def coarse_signals(n_samples: int = 300, seed: int = 0, noise: float = 150.0) -> dict:
    """A loading–unloading twist sampled coarsely (as the PLC does at 20 Hz): twist steps of up
    to ~2e-4 rad per sample, several sub-steps each at the default β + γ."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 100.0, n_samples)
    delta = 8.7e-3 * (0.5 - 0.5 * np.cos(2 * np.pi * t / 50.0)) + 4e-4 * np.sin(2 * np.pi * t / 7)
    dd = np.gradient(delta, t)
    x = bw_state(delta, 1.0, P.beta, P.gamma, 1)
    theta = np.array([P.w * P.k, (1 - P.w) * P.k, 300.0, P.D, 500.0])
    y = eq11_regressor(delta, dd, x, P.v_eps) @ theta + noise * rng.standard_normal(t.size)
    return {"t": t, "torsion": delta, "torsion_rate": dd, "torque": y}


def test_counts_follow_the_shared_steps_rule_and_agree_bit_for_bit():
    sig = coarse_signals()
    d = sig["torsion"]
    for beta, gamma in ((P.beta, P.gamma), (900.0, -300.0), (3000.0, 1000.0)):
        k = stiffness_bound(1.0, beta, gamma, 1)
        m = substep_counts(d, k)
        assert m[0] == 0 and m.max() > 1                 # coarse data: several sub-steps
        rule = (np.abs(np.diff(d)) * (abs(beta) + abs(gamma)) / SUBSTEP_TOL).astype(int) + 1
        np.testing.assert_array_equal(m[1:], rule)
        ref = [0.0]
        for i in range(1, d.size):
            ref.append(bouc_wen_step(d[i] - d[i - 1], ref[-1], 1.0, beta, gamma, 1))
        fixed = bw_state(d, 1.0, beta, gamma, 1, msub=m)
        assert np.array_equal(fixed, bw_state(d, 1.0, beta, gamma, 1))   # the step's own rule
        np.testing.assert_allclose(fixed, ref, rtol=0, atol=1e-17)       # numba vs CPython pow
        assert np.array_equal(bw_state_sensitivities(d, 1.0, beta, gamma, 1, msub=m)[0], fixed)


def test_the_emulator_keeps_the_shared_step():
    """The emulator's kernel compiles core.terms.bouc_wen_step itself (its own sub-step rule,
    unchanged): its state over a twist series is the fit's default (rule-following) state."""
    from simulators import kernel
    d = coarse_signals()["torsion"]
    x, out = 0.0, [0.0]
    for i in range(1, d.size):
        x = kernel.bouc_wen_step(d[i] - d[i - 1], x, 1.0, P.beta, P.gamma, 1)
        out.append(x)
    assert np.array_equal(np.array(out), bw_state(d, 1.0, P.beta, P.gamma, 1))


def test_fixed_counts_make_the_log_density_smooth():
    """Along log(β+γ), the rule-following density jumps wherever a count flips (its second
    differences spike far above the curvature's); with counts fixed it is smooth and its
    analytic gradient matches central differences across the whole line."""
    sig = coarse_signals()
    tgt = build_target(sig)
    w_ls = least_squares_fit(tgt)["w"]
    grid = w_ls[0] + np.linspace(-0.05, 0.05, 201)

    def second_differences():
        lp = np.array([tgt.logp(np.array([g, w_ls[1]])) for g in grid])
        return np.abs(np.diff(lp, 2))

    rough = second_differences()
    tgt.fix_substeps(stiffness_bound(*tgt.physical(w_ls), 1))
    smooth = second_differences()
    assert rough.max() > 20 * np.median(rough)           # jumps the gradient cannot see
    assert smooth.max() < 3 * np.median(smooth)          # only the curvature is left
    for g in grid[::40]:
        w = np.array([g, w_ls[1]])
        _, grad = tgt.logp_grad(w)
        h = 1e-6
        fd = (tgt.logp(w + [h, 0]) - tgt.logp(w - [h, 0])) / (2 * h)
        assert fd == pytest.approx(grad[0], rel=1e-4, abs=1e-3)


def test_counts_are_fixed_at_the_least_squares_estimate():
    """At the LS estimate the fixed counts are the rule's own: the fitted recursion there is the
    emulator's step bit for bit; the guard refuses parameters whose sub-steps would overshoot."""
    sig = coarse_signals()
    tgt = build_target(sig)
    ls = least_squares_fit(tgt)
    x_rule = tgt.state(ls["w"])
    k = substep_stiffness(tgt, ls)
    assert k == stiffness_bound(*tgt.physical(ls["w"]), 1)
    tgt.fix_substeps(k)
    assert tgt.msub[0] == 0 and np.all(tgt.msub[1:] >= 1) and tgt.msub.max() > 1
    assert np.array_equal(tgt.state(ls["w"]), x_rule)
    kh = k * tgt._max_substep                         # the largest K*·h, ≤ SUBSTEP_TOL
    assert kh <= SUBSTEP_TOL
    assert np.isfinite(tgt.logp(ls["w"] + [np.log(0.5 / kh), 0.0]))      # K·h = 0.5: inside
    assert not np.isfinite(tgt.logp(ls["w"] + [np.log(1.05 / kh), 0.0]))  # K·h > 1: outside
    tgt.fix_substeps(None)
    assert not tgt.msub.any()
    with pytest.raises(ValueError, match="positive"):
        substep_counts(sig["torsion"], 0.0)


@pytest.fixture(scope="module")
def protocol_rate_pair():
    """Scheme 1 at 300 and 3000 r/min sampled at 20 Hz, as the demo's PLC polls them."""
    from core.schemes import Scheme1
    from simulators.config import EmulatorConfig
    from simulators.offline import simulate
    return [simulate(Scheme1(motor_speed_rpm=v), EmulatorConfig(seed=7 + i, sample_rate_hz=20.0))
            for i, v in enumerate((300.0, 3000.0))]


def test_hmc_converges_on_a_protocol_rate_pair(protocol_rate_pair):
    """With the counts fixed, HMC never raises its step to the floor and the demo's chains
    (4 × 300 warm-up + 500 draws) reach R-hat < 1.01 and bulk ESS ≥ 400 on every parameter
    (with the shared step's rule: R-hat 1.02–1.05 on such a pair)."""
    from estimator.identify import identify
    fit = identify(protocol_rate_pair, "eq11", "hmc", chains=4, draws=500, warmup=300, seed=0)
    assert np.all(fit.diagnostics["warmup_at_step_floor"] == 0)
    assert np.all(fit.diagnostics["rhat"] < 1.01), fit.diagnostics["rhat"]
    assert np.all(fit.diagnostics["ess_bulk"] >= 400), fit.diagnostics["ess_bulk"]
    assert fit.extra["substeps_per_sample"] >= 1.0 and fit.extra["substep_stiffness"] > 0
