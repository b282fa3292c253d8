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


# --- the parameters, defined once: the schemes check them; the API and the CLI derive ------------

def test_every_settable_parameter_is_bounded_by_the_scheme_itself():
    from core.schemes import SCHEMES, scheme_params

    for number, cls in SCHEMES.items():
        for p in scheme_params(number):
            b = p.bounds
            kw = {"motor_speed_rpm": 300.0} if number != 3 else {}   # travel inside ±180°
            bad = [float("nan"), "3", True]
            if b.choices is not None:
                bad.append(0)
            if b.le is not None:
                bad.append(b.le * 1.5 + 1)
            if b.ge is not None:
                bad.append(b.ge - 1)
            if b.gt is not None:
                bad.append(b.gt)
            if p.type is int:
                bad.append(float(p.default))
            for v in bad:
                if p.name in kw and v == kw[p.name]:
                    continue
                with pytest.raises(ValueError, match=p.name):
                    cls(**{**kw, p.name: v})
            cls(**{**kw, p.name: p.default})


def test_the_api_schema_and_the_cli_flags_derive_from_the_schemes():
    import argparse

    from api.routers.schemes import PARAMS
    from commands import cmd_run
    from core.schemes import scheme_options, scheme_params

    parser = argparse.ArgumentParser()
    cmd_run.add_arguments(parser)
    helps = {a.dest: a.help for a in parser._actions}
    for number in (1, 2, 3):
        params = scheme_params(number)
        schema = PARAMS[number].model_json_schema()["properties"]
        assert list(schema) == [p.name for p in params]
        for p in params:
            b, s = p.bounds, schema[p.name]
            assert s["default"] == p.default
            assert s.get("minimum") == b.ge and s.get("exclusiveMinimum") == b.gt
            assert s.get("maximum") == b.le and s.get("enum") == (list(b.choices) if b.choices
                                                                 else None)
            assert b.doc in s["description"] and b.unit in s["description"]
            assert b.doc in helps[b.option] and b.unit in helps[b.option]
            value = p.default if b.choices is None else b.choices[-1]
            args = parser.parse_args([f"scheme{number}", f"--{b.option.replace('_', '-')}",
                                      str(value)])
            assert cmd_run.scheme_params(args, number) == {p.name: value}
    assert set(helps) >= set(scheme_options())


def test_run_spec_reads_back_and_refuses_what_is_not_a_run():
    from core.schemes import RunSpec

    spec = RunSpec(2, {"step": 5e3, "direction": -1, "motor_speed_rpm": 300.0},
                   operator="ann", notes="n", effects={"stribeck": {"f_s": 900.0}},
                   source="emulator")
    assert RunSpec.from_json(spec.to_json()) == spec
    assert spec.make_scheme().step == 5e3
    for text, why in (('{"scheme": 4}', "scheme must be"),
                      ('{"params": {}}', "needs scheme"),
                      ('{"scheme": 1, "db": "x"}', "unknown run spec key"),
                      ('{"scheme": 1, "params": {"step": 1}}', "no parameter step"),
                      ('{"scheme": 1, "params": {"load_target": NaN}}', "NaN"),
                      ('{"scheme": 1, "source": "moon"}', "source"),
                      ('{"scheme": 1, "effects": {"nope": {}}}', "unknown effect"),
                      ("[1]", "JSON object"), ("{", "not JSON")):
        with pytest.raises(ValueError, match=why):
            RunSpec.from_json(text)


def test_rig_run_spec_is_the_same_run_as_the_flags(tmp_path, monkeypatch):
    import argparse
    import io
    import json
    import sys

    from commands import cmd_run
    from core.schemes import RunSpec

    parser = argparse.ArgumentParser()
    cmd_run.add_arguments(parser)
    flags = cmd_run.run_spec(parser.parse_args(
        ["scheme2", "--speed", "300", "--direction", "-1", "--pause", "1", "--operator", "ann",
         "--effect", "stribeck:f_s=900", "--source", "emulator"]))
    assert flags == RunSpec(2, {"motor_speed_rpm": 300.0, "direction": -1, "pause": 1.0},
                            operator="ann", effects={"stribeck": {"f_s": 900.0}},
                            source="emulator")
    f = tmp_path / "run.json"
    f.write_text(json.dumps(flags.to_dict(), indent=2))
    assert cmd_run.run_spec(parser.parse_args(["--spec", str(f)])) == flags
    for mixed in (["scheme2", "--spec", str(f)], ["--spec", str(f), "--speed", "300"],
                  ["--spec", str(f), "--operator", "bob"], []):
        with pytest.raises(ValueError, match="--spec|give the scheme"):
            cmd_run.run_spec(parser.parse_args(mixed))
    # `--spec -` with --control-stdin: the first line is the run, the commands follow
    stdin = io.StringIO(flags.to_json() + "\nstop\n")
    monkeypatch.setattr(sys, "stdin", stdin)
    assert cmd_run.run_spec(parser.parse_args(["--spec", "-", "--control-stdin"])) == flags
    assert stdin.read() == "stop\n"


@pytest.mark.parametrize("number,params", [
    (1, {"motor_speed_rpm": 1.0, "ramp_rate": 1e-9}),      # a ramp of millennia
    (2, {"motor_speed_rpm": 1.0, "ramp_rate": 1e-9}),
])
def test_a_run_longer_than_an_hour_is_refused_before_anything_is_allocated(number, params):
    """A schema-valid request for a run of days (found by the API fuzz: it made the acquisition
    allocate ~24 GB) is refused with the reason, by the scheme itself."""
    from core.schemes import MAX_RUN_TIME, SCHEMES
    with pytest.raises(ValueError, match="longest run"):
        SCHEMES[number](**params)
    assert SCHEMES[number]().duration() < MAX_RUN_TIME       # the paper's runs fit
