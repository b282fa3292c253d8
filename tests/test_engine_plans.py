"""Plans (daq/plans.py) against the schemes' own profiles, the `rig run` argument handling, and
the settings loader leaving other components' RIG_* variables alone. No processes, no network."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from commands import cmd_run
from daq.plans import Plan
from core.params import REDUCTION
from core.schemes import RPM, Scheme1, Scheme2, Scheme3
from daq.settings import Settings

S3 = dict(n_periods=1, base_freq_hz=0.1, sample_rate_hz=10.0, rest_time=1.0)


@pytest.mark.parametrize("scheme", [Scheme1(motor_speed_rpm=300.0, direction=-1),
                                    Scheme2(load_target=30e3, pause=1.5)])
def test_loading_plan_follows_the_scheme_profiles(scheme):
    plan = Plan(scheme)
    rng = np.random.default_rng(1)
    t = np.concatenate([rng.uniform(0, plan.duration, 300), [0.0, plan.duration]])
    for x in t:
        sp = plan.setpoints(x)
        a = np.array([x])
        assert sp.motor_speed == pytest.approx(scheme.motor_speed(a)[0], abs=1e-6 * 314)
        assert sp.dyno_torque == pytest.approx(scheme.dyno_torque(a)[0], abs=1e-6 * 120e3)
        assert sp.pump_on and sp.q_ref is None
        # the pressure table is a step function: equal away from its edges
        if min(abs(x - scheme.load_start), abs(x - scheme.load_end)) > 2e-3:
            assert sp.pressure == pytest.approx(scheme.pressure_setpoint(a)[0])
        assert sp.phase == scheme.phase(a)[0]
    assert plan.uses_hydraulics and not plan.position_control
    assert plan.n_samples() == int(np.floor(scheme.duration() * 10 + 1e-9)) + 1
    assert plan.slot(0.0) == 0 and plan.slot(0.0999) == 0 and plan.slot(0.1) == 1
    assert plan.meta()["plan"]["n_samples_planned"] == plan.n_samples()


def test_scheme3_plan_is_feed_forward_plus_position_correction():
    scheme = Scheme3(**S3)
    plan = Plan(scheme)
    assert plan.position_control and not plan.uses_hydraulics
    x = scheme.rest_time + 3.3
    q_ref, qd_ref = (v[0] for v in scheme.position_ref(np.array([x])))
    ff = plan.setpoints(x)
    assert ff.q_ref == pytest.approx(q_ref, abs=1e-6)
    assert ff.motor_speed == pytest.approx(REDUCTION * qd_ref, rel=1e-3)
    assert ff.dyno_torque == 0.0 and not ff.pump_on and ff.phase == "excite"
    err = 1e-3   # 1 mrad behind: the correction adds N·k_p·err
    fb = plan.setpoints(x, q=q_ref - err)
    assert fb.motor_speed - ff.motor_speed == pytest.approx(REDUCTION * scheme.position_gain * err,
                                                            rel=1e-6)
    far = plan.setpoints(x, q=q_ref - 1.0)           # a large error saturates at the limit
    assert far.motor_speed == pytest.approx(scheme.motor_speed_limit_rpm * RPM)


def parse(argv):
    p = argparse.ArgumentParser()
    cmd_run.add_arguments(p)
    return p.parse_args(argv)


def test_run_arguments_map_onto_the_scheme_and_refuse_the_others():
    args = parse(["scheme2", "--speed", "300", "--direction", "-1", "--step", "5000",
                  "--pause", "1", "--operator", "ann"])
    assert cmd_run.scheme_params(args, 2) == {"motor_speed_rpm": 300.0, "direction": -1,
                                             "step": 5000.0, "pause": 1.0}
    with pytest.raises(ValueError, match="--step does not apply to scheme 1"):
        cmd_run.scheme_params(parse(["scheme1", "--step", "5000"]), 1)
    with pytest.raises(ValueError, match="--speed does not apply to scheme 3"):
        cmd_run.scheme_params(parse(["scheme3", "--speed", "300"]), 3)
    assert cmd_run.parse_effects(["stribeck:f_s=1200,v_s=0.01", "backlash"]) == {
        "stribeck": {"f_s": 1200.0, "v_s": 0.01}, "backlash": {}}


def test_run_refuses_a_bad_scheme_parameter_before_touching_anything(capsys, tmp_path):
    args = parse(["scheme1", "--speed", "5000", "--db", f"sqlite:///{tmp_path / 'x.sqlite'}"])
    assert cmd_run.run(args) == 2
    assert "motor speed must be in" in capsys.readouterr().err
    assert not (tmp_path / "x.sqlite").exists()


def test_settings_ignore_other_components_variables_but_refuse_typos():
    s = Settings.load(env={"RIG_DB_URL": "sqlite:///x", "RIG_API_PORT": "1",
                           "RIG_PLC_POLL_HZ": "250"})
    assert s.plc_poll_hz == 250.0
    with pytest.raises(ValueError, match="RIG_PLC_POL_HZ"):
        Settings.load(env={"RIG_PLC_POL_HZ": "250"})
