"""The live emulator's API (/work/briefs/live_api.md), as the PLC and drive stand-ins use it."""

import math

import numpy as np
import pytest

from core.channels import NUMERIC_CHANNELS
from core.params import JointParams
from simulators import kernel as K
from simulators.config import EmulatorConfig
from simulators.live import LiveJoint

P = JointParams()
W3000 = 3000 * 2 * math.pi / 60


def _run_all(joint, w):
    for k in range(3):
        joint.set_motor_speed(k, w)


def test_contract_surface():
    j = LiveJoint(EmulatorConfig())
    assert j.dt == 1e-3 and j.t == 0.0
    j.advance(0.25)
    assert j.t == pytest.approx(0.25)
    r = j.read()
    assert set(NUMERIC_CHANNELS) <= set(r)
    assert all(isinstance(v, float) and math.isfinite(v) for v in r.values())
    assert r["t"] == pytest.approx(0.25)
    m = j.motor(0)
    assert set(m) == {"w", "i", "temp", "tau", "q"}
    assert m["tau"] == pytest.approx(P.k_t * m["i"])
    with pytest.raises(IndexError):
        j.motor(3)
    with pytest.raises(ValueError):
        j.advance(-1.0)


def test_small_slices_add_up_to_one_long_advance():
    cfg = EmulatorConfig(seed=3, effects={"time_delay": {}, "backlash": {}})
    a, b = LiveJoint(cfg), LiveJoint(cfg)
    for j in (a, b):
        _run_all(j, W3000)
        j.set_dyno_torque(40e3)
    a.advance(2.0)
    for _ in range(800):
        b.advance(0.0025)                                  # 2.5 ms slices: not whole steps
    assert a.t == b.t == pytest.approx(2.0)
    np.testing.assert_array_equal(a._state, b._state)
    assert a.read() == b.read()                            # same seed, same draws


def test_speed_set_points_drive_the_joint():
    j = LiveJoint(EmulatorConfig(seed=1))
    _run_all(j, W3000)
    j.advance(3.0)
    r = j.read()
    for k in (1, 2, 3):
        assert r[f"w_m{k}"] == pytest.approx(W3000, rel=0.01)
    assert r["qd"] == pytest.approx(W3000 / P.N, rel=0.02)
    assert j.motor(1)["q"] == pytest.approx(P.N * j.truth()["u"], rel=1e-6)


def test_dynamometer_and_hydraulics_follow_their_set_points():
    j = LiveJoint(EmulatorConfig(seed=2))
    j.set_dyno_torque(50e3)
    j.set_pump(True)
    j.set_pressure(90e3 / P.cyl_area)
    j.advance(0.1)
    assert j.truth()["torque_load"] < 30e3                  # still lagging (τ = 0.2 s)
    j.advance(5.0)
    tr = j.truth()
    assert abs(tr["torque_load"] - 50e3) < 2e3
    assert tr["p_hyd"] == pytest.approx(90e3 / P.cyl_area, rel=1e-3)
    r = j.read()
    assert r["f_shear"] == pytest.approx(90e3, abs=5 * P.force_noise)
    assert r["m_bend"] == pytest.approx(90e3 * P.arm_bend, abs=5 * P.force_noise)
    j.set_pump(False)
    j.advance(5.0)
    assert j.truth()["p_hyd"] < 0.01 * 90e3 / P.cyl_area


def test_disabled_motors_give_no_torque_and_the_joint_coasts():
    j = LiveJoint(EmulatorConfig(seed=4))
    _run_all(j, W3000)
    j.advance(3.0)
    for k in range(3):
        j.enable_motor(k, False)
    j.advance(0.5)
    tr = j.truth()
    assert all(tr[f"i_m{k}"] == 0.0 for k in (1, 2, 3))
    j.advance(10.0)
    assert abs(j.truth()["ud"]) < 0.1 * W3000 / P.N         # friction stopped it


def test_torque_limit_caps_the_current():
    j = LiveJoint(EmulatorConfig(seed=5, params=P.replace(dyno_err=0.0)))
    for k in range(3):
        j.set_motor_torque_limit(k, 1.0)                   # N·m at the motor shaft
    j.set_dyno_torque(60e3)                                 # needs ~2 A per motor: too much
    j.advance(2.0)
    tr = j.truth()
    for k in (1, 2, 3):
        assert tr[f"i_m{k}"] == pytest.approx(1.0 / P.k_t, rel=1e-9)
    assert tr["ud"] < -1e-3                                 # the load back-drives the joint


def test_a_failed_motor_is_carried_by_the_other_two():
    j = LiveJoint(EmulatorConfig(seed=6, params=P.replace(dyno_err=0.0)))
    _run_all(j, W3000)
    j.set_dyno_torque(60e3)
    j.advance(5.0)
    before = j.truth()
    j.fail_motor(1)
    assert j.failed(1) and not j.failed(0)
    j.enable_motor(1, True)                                 # a fault is not cleared by enabling
    j.advance(5.0)
    after = j.truth()
    assert after["i_m2"] == 0.0
    assert after["i_m1"] == pytest.approx(1.5 * before["i_m1"], rel=0.02)
    assert after["i_m3"] == pytest.approx(after["i_m1"], rel=1e-9)
    assert j.read()["w_m2"] == pytest.approx(0.0, abs=5 * P.N * P.speed_noise)
    assert after["ud"] == pytest.approx(W3000 / P.N, rel=0.01)


def test_read_applies_the_sensor_effects():
    delay = 0.1
    quiet = P.replace(torque_noise=0.0)
    j = LiveJoint(EmulatorConfig(seed=7, params=quiet,
                                 effects={"time_delay": {"delay": delay},
                                          "torque_offset": {"c0": 300.0, "drift": 0.0}}))
    j.set_dyno_torque(80e3)
    history = {}
    for _ in range(400):
        j.advance(1e-3)
        history[round(j.t * 1000)] = j.truth()["torque"]
    now = round(j.t * 1000)
    r = j.read()
    assert r["torque"] == pytest.approx(history[now - 100] + 300.0, abs=1e-6)
    assert abs(history[now] - history[now - 100]) > 100        # the torque was still moving
    assert r["q"] / P.enc_res == pytest.approx(round(r["q"] / P.enc_res), abs=1e-6)


def test_dropouts_in_live_reads():
    j = LiveJoint(EmulatorConfig(seed=8, dropout=0.2))
    reads = [j.read() for _ in range(200)]
    lost = np.mean([math.isnan(r["torque"]) for r in reads])
    assert 0.1 < lost < 0.3
    assert not any(math.isnan(r["t"]) for r in reads)


def test_live_and_kernel_share_the_model():
    """The live joint is the offline kernel with held commands: same state after the same steps."""
    from simulators.model import setup
    cfg = EmulatorConfig(seed=9)
    j = LiveJoint(cfg)
    _run_all(j, 300 * 2 * math.pi / 60)
    j.set_dyno_torque(20e3)
    j.advance(1.5)
    ks = setup(cfg, np.random.Generator(np.random.PCG64(cfg.seed)))
    K.advance(ks.state, ks.pf, ks.n_bw, ks.ring, np.full((1, 3), 300 * 2 * math.pi / 60),
              np.zeros(1), 0, np.array([20e3]), np.zeros(1), np.zeros(1), ks.enabled,
              ks.fail_step, ks.tau_lim, np.zeros(0, np.int64), np.zeros((0, K.N_R)), 0, 1500)
    np.testing.assert_array_equal(j._state, ks.state)
