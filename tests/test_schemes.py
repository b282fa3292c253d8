"""The three schemes' plans (core.schemes) and scheme 3's Fourier excitation (core.excitation):
the paper's defaults, profiles that do what rig.md says, limits respected, and an optimised
trajectory better conditioned than random feasible ones."""

import math

import numpy as np
import pytest

from core.excitation import (FourierTrajectory, fourier_trajectory, observation_log_cond,
                            optimize_excitation, rest_to_rest)
from core.params import REDUCTION
from core.schemes import (JOINT_LIMIT, OUTPUT_SPEED_LIMIT, RPM, Scheme1, Scheme2, Scheme3,
                         make_scheme)


def test_paper_defaults():
    s1, s2, s3 = Scheme1(), Scheme2(), Scheme3()
    assert s1.load_target == s2.load_target == 120e3
    assert s1.motor_speed_rpm == 3000 and s1.ramp_rate == 2.4e3 and s1.sample_rate_hz >= 10
    assert s2.step == 10e3 and s2.pause == 2.0
    assert s3.order == 5 and s3.q_max == math.pi
    assert s3.v_max == pytest.approx(3000 * RPM / REDUCTION)
    assert OUTPUT_SPEED_LIMIT == pytest.approx(0.02856, rel=1e-3)
    assert s1.shear_target == 90e3
    assert s3.meta()["motor_speed_rpm"] is None and s1.meta()["scheme"] == 1


@pytest.mark.parametrize("cls", [Scheme1, Scheme2])
@pytest.mark.parametrize("rpm", [300.0, 3000.0])
@pytest.mark.parametrize("direction", [1, -1])
def test_loading_schemes_stay_within_the_joint_range(cls, rpm, direction):
    plan = cls(motor_speed_rpm=rpm, direction=direction)
    t = np.arange(0.0, plan.duration(), 1e-3)
    w = plan.motor_speed(t)
    travel = np.sum(w / REDUCTION) * 1e-3
    assert abs(travel) == pytest.approx(plan.travel(), rel=1e-3)
    assert abs(travel) < JOINT_LIMIT
    assert np.sign(travel) == direction
    assert np.max(np.abs(w)) == pytest.approx(rpm * RPM)


def test_scheme1_ramps_to_rated_load_and_back():
    plan = Scheme1()
    t = np.arange(0.0, plan.duration(), 0.01)
    tau = plan.dyno_torque(t)
    ph = plan.phase(t)
    assert tau.max() == pytest.approx(120e3, rel=1e-3)
    assert tau[0] == 0 and tau[-1] == 0
    rate = np.diff(tau) / 0.01
    assert np.max(np.abs(rate)) == pytest.approx(2.4e3, rel=1e-6)
    assert set(ph) == {"idle", "load", "unload"}
    assert np.all(rate[ph[:-1] == "load"][1:-1] > 0) and np.all(rate[ph[:-1] == "unload"][1:-1] < 0)
    assert np.all(plan.motor_speed(t[ph == "load"]) == pytest.approx(plan.motor_speed_rad_s))
    p = plan.pressure_setpoint(t)
    assert np.all(p[ph == "idle"] == 0) and np.allclose(p[ph == "load"] * 4e-3, 90e3)


def test_scheme2_pauses_two_seconds_every_ten_kNm():
    plan = Scheme2()
    t = np.arange(0.0, plan.duration(), 1e-3)
    tau = plan.dyno_torque(t)
    ph = plan.phase(t)
    hold = ph == "hold"
    starts = np.flatnonzero(np.diff(hold.astype(int)) == 1) + 1
    ends = np.flatnonzero(np.diff(hold.astype(int)) == -1) + 1
    levels = tau[starts]
    assert np.allclose(levels, np.arange(1, 13) * 10e3)
    assert np.allclose((ends - starts) * 1e-3, 2.0, atol=2e-3)
    assert tau.max() == pytest.approx(120e3)


def test_scheme_validation():
    with pytest.raises(ValueError, match="direction"):
        Scheme1(direction=0)
    with pytest.raises(ValueError, match="10 Hz"):
        Scheme2(sample_rate_hz=5)
    with pytest.raises(ValueError, match="180"):
        Scheme1(ramp_rate=1e3)           # 240 s at 3000 r/min would turn the joint > 180°
    with pytest.raises(ValueError):
        make_scheme(4)
    assert isinstance(make_scheme(2, motor_speed_rpm=300), Scheme2)


def test_eq12_derivatives_are_consistent():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=5) * 0.01, rng.normal(size=5) * 0.01
    wf = 2 * math.pi * 0.05
    t = np.linspace(0, 40, 40001)
    q, qd, qdd = fourier_trajectory(t, a, b, wf, 0.3)
    assert np.allclose(np.gradient(q, t)[1:-1], qd[1:-1], atol=1e-6)
    assert np.allclose(np.gradient(qd, t)[1:-1], qdd[1:-1], atol=1e-6)
    assert np.allclose(q[:20000], q[20000:40000], atol=1e-12)    # period 20 s


def test_rest_to_rest_start():
    tr = rest_to_rest(np.arange(1, 9) * 1e-3, 5, 0.3, q_start=0.2)
    q, qd, qdd = tr.evaluate(np.array([0.0, tr.period]))
    assert np.allclose(q, 0.2) and np.allclose(qd, 0, atol=1e-15) and np.allclose(qdd, 0, atol=1e-15)


def test_optimised_excitation_respects_limits_and_beats_random_trajectories():
    res = optimize_excitation(order=5, base_freq_hz=0.05, a_max=0.05)
    qm, vm, am = res.peaks
    assert qm <= math.pi and vm <= OUTPUT_SPEED_LIMIT * (1 + 1e-9) and am <= 0.05 * (1 + 1e-9)
    assert res.cond < min(res.random_conds)
    assert res.cond < 0.7 * res.random_median_cond
    assert len(res.random_conds) == 200
    # the reported number is the condition number of Eq. 4's observation matrix
    assert math.log10(res.cond) == pytest.approx(observation_log_cond(res.trajectory, 2000))
    # deterministic and cached
    assert optimize_excitation(order=5, base_freq_hz=0.05, a_max=0.05) is res


def test_scheme3_position_reference_follows_the_trajectory():
    plan = Scheme3()
    t = np.arange(0.0, plan.duration(), 1e-3)
    q, qd = plan.position_ref(t)
    ph = plan.phase(t)
    assert set(ph) == {"idle", "excite"}
    assert q[0] == pytest.approx(0.0, abs=1e-12) and q[-1] == pytest.approx(0.0, abs=1e-9)
    assert np.allclose(np.gradient(q, t)[1:-1], qd[1:-1], atol=1e-5)
    assert np.max(np.abs(qd)) <= plan.v_max * (1 + 1e-9)
    assert np.allclose(plan.motor_speed(t), REDUCTION * qd)
    assert np.all(plan.dyno_torque(t) == 0) and not np.any(plan.pump_on(t))
    mirrored = Scheme3(direction=-1).position_ref(t)[0]
    assert np.allclose(mirrored, -q)


def test_scheme3_fixed_coefficients_skip_optimisation():
    tr = rest_to_rest(np.full(8, 2e-3), 5, 2 * math.pi * 0.05)
    plan = Scheme3(coefficients=(tr.a, tr.b, tr.q0))
    assert plan.excitation() is None
    assert isinstance(plan.trajectory(), FourierTrajectory)
    assert plan.trajectory().a == tr.a
