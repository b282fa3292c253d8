"""Each injected effect changes the data where rig.md says it shows, and nowhere else.

Every test compares a run with the effect against the same run (same seed, so the same noise)
without it. Channels the effect cannot touch (the dynamometer, the hydraulics, or for sensor
effects everything but the torque channel) must be bit-identical; the change where it shows is
checked against the effect's own term (core.effects) evaluated on the measured channels."""

import math

import numpy as np
import pytest

from core.effects import VOCABULARY, stribeck_torque, torque_offset
from core.params import JointParams
from core.schemes import Scheme1, Scheme2, Scheme3
from simulators import kernel as K
from simulators.config import EmulatorConfig
from simulators.offline import simulate, simulate_records

P = JointParams()
UNTOUCHED_BY_JOINT = ("t", "torque_load", "torque_cmd", "p_hyd", "m_bend", "f_shear", "phase")
"""Channels no joint-side effect can change: the loading equipment and the clock."""


def _pair(plan, effect: dict, **cfg):
    """(run without, run with) the effect, same seed and settings."""
    base = simulate(plan, EmulatorConfig(**cfg))
    withfx = simulate(plan, EmulatorConfig(effects=effect, **cfg))
    return base.samples, withfx.samples


def _joint_torque(s) -> np.ndarray:
    """T − τ_L from the strain gauges and the load transducer [N·m]: Eq. 4's left side."""
    return (s["torque"] - s["torque_load"]).to_numpy()


def _assert_identical(a, b, columns):
    for c in columns:
        assert a[c].equals(b[c]), f"channel {c} changed"


def test_effect_vocabulary_is_fully_injectable_together():
    cfg = EmulatorConfig(effects={name: {} for name in VOCABULARY}, seed=9)
    assert set(cfg.effects) == set(VOCABULARY)
    s_all = simulate(Scheme1(motor_speed_rpm=300), cfg).samples
    no_offset = {name: {} for name in VOCABULARY if name != "torque_offset"}
    s_rest = simulate(Scheme1(motor_speed_rpm=300), EmulatorConfig(effects=no_offset, seed=9)).samples
    assert np.isfinite(s_all.drop(columns="phase").to_numpy()).all()
    # together they compose: removing one sensor effect removes exactly its term
    off = VOCABULARY["torque_offset"].defaults()
    np.testing.assert_allclose(s_all["torque"] - s_rest["torque"],
                               torque_offset(s_all["t"].to_numpy(), off["c0"], off["drift"]),
                               rtol=1e-9, atol=1e-6)
    with pytest.raises(ValueError, match="unknown effect"):
        EmulatorConfig(effects={"cogging": {}})
    with pytest.raises(ValueError, match="no parameter"):
        EmulatorConfig(effects={"stribeck": {"mu": 1.0}})


def test_stribeck_changes_300_rpm_runs_more_than_3000_rpm_runs():
    f = VOCABULARY["stribeck"].defaults()
    change = {}
    for rpm in (300.0, 3000.0):
        base, withfx = _pair(Scheme1(motor_speed_rpm=rpm), {"stribeck": {}}, seed=21)
        _assert_identical(base, withfx, UNTOUCHED_BY_JOINT)
        load = (withfx["phase"] == "load").to_numpy()
        change[rpm] = np.mean(_joint_torque(withfx)[load] - _joint_torque(base)[load])
        if rpm == 300.0:
            qd = withfx["qd"].to_numpy()[load]
            expected = np.mean(stribeck_torque(qd, f["f_s"], f["v_s"], P.v_eps))
            assert change[rpm] == pytest.approx(expected, rel=0.05)
            # the drives hold the speed: the motion itself is unchanged
            assert np.mean(withfx["qd"][load]) == pytest.approx(np.mean(base["qd"][load]), rel=0.01)
    assert change[300.0] > 1000.0                              # ~1.2 kN·m at 2.9e-3 rad/s
    assert abs(change[3000.0]) < 10.0                          # exp(−(q̇/v_s)²) ≈ 1e-10
    assert change[300.0] > 100 * abs(change[3000.0])


def test_load_dependent_friction_grows_with_load_and_flips_with_direction():
    mu = 0.03
    for direction in (1, -1):
        base, withfx = _pair(Scheme1(direction=direction),
                             {"load_dependent_friction": {"mu": mu}}, seed=22)
        _assert_identical(base, withfx, UNTOUCHED_BY_JOINT)
        moving = withfx["phase"].isin(["load", "unload"]).to_numpy()
        d = _joint_torque(withfx)[moving] - _joint_torque(base)[moving]
        T = np.abs(withfx["torque"].to_numpy()[moving])
        slope, intercept = np.polyfit(T, d, 1)
        assert slope == pytest.approx(direction * mu, rel=0.03)
        assert abs(intercept) < 60.0
        assert direction * d[T > 100e3].mean() > 2900           # ≈ μ·|T| at the top
        assert abs(d[T < 10e3].mean()) < 400                    # small at low load


def test_temperature_friction_differs_between_cold_and_warm_runs():
    f = VOCABULARY["temperature_friction"].defaults()
    plan = Scheme1()
    changes, bases = {}, {}
    for temp in (20.0, 60.0):
        base, withfx = _pair(plan, {"temperature_friction": {}}, seed=23, temp_joint_init=temp)
        _assert_identical(base, withfx, UNTOUCHED_BY_JOINT)
        moving = withfx["phase"].isin(["load", "unload"]).to_numpy()
        changes[temp] = np.mean(_joint_torque(withfx)[moving] - _joint_torque(base)[moving])
        bases[temp] = np.mean(_joint_torque(base)[moving])
        expected = f["c_T"] * (f["T_ref"] - withfx["temp_joint"].to_numpy()[moving].mean())
        assert changes[temp] == pytest.approx(expected, rel=0.03)
    assert changes[20.0] > 500 and changes[60.0] < -500        # more drag cold, less warm
    assert abs(bases[20.0] - bases[60.0]) < 30                   # without it, temperature is moot


def _fit_twist(s, min_torque=1500.0):
    """Fit twist = a·T + c·sgn(T) + d on samples with |T| > min_torque; returns c [rad]."""
    T = s["torque"].to_numpy()
    twist = -s["torsion"].to_numpy()
    m = np.abs(T) > min_torque
    A = np.column_stack([T[m], np.sign(T[m]), np.ones(m.sum())])
    coef, *_ = np.linalg.lstsq(A, twist[m], rcond=None)
    return coef[1]


def test_backlash_shows_at_torque_reversals():
    b = VOCABULARY["backlash"].defaults()["b"]
    base, withfx = _pair(Scheme3(n_periods=4), {"backlash": {}}, seed=24, hysteresis=False)
    _assert_identical(base, withfx, ("t", "torque_cmd", "p_hyd", "m_bend", "f_shear", "phase"))
    assert np.sum(np.diff(np.sign(withfx["torque"].to_numpy())) != 0) > 8      # reversals
    assert _fit_twist(withfx) == pytest.approx(b, rel=0.1)    # twist jumps by 2b through T = 0
    assert abs(_fit_twist(base)) < 0.05 * b
    # away from reversals (constant-speed loading) the torque balance is unchanged
    base1, with1 = _pair(Scheme1(), {"backlash": {}}, seed=24)
    load = (with1["phase"] == "load").to_numpy()
    assert np.mean(_joint_torque(with1)[load] - _joint_torque(base1)[load]) == pytest.approx(0, abs=15)


def _angle_spectrum(s, phases=("load", "unload")):
    """Amplitude spectrum [N·m] of T − τ_L against the output angle, in cycles/revolution."""
    m = s["phase"].isin(phases).to_numpy()
    q = s["q"].to_numpy()[m]
    r = _joint_torque(s)[m]
    order = np.argsort(q)
    q, r = q[order], r[order]
    grid = np.linspace(q[0], q[-1], 4096)
    rr = np.interp(grid, q, r)
    rr = rr - np.polyval(np.polyfit(grid, rr, 3), grid)
    win = np.hanning(len(grid))
    n_fft = 8 * len(grid)
    amp = 2 * np.abs(np.fft.rfft(rr * win, n_fft)) / win.sum()
    cycles_per_rev = np.fft.rfftfreq(n_fft, d=grid[1] - grid[0]) * 2 * math.pi
    return cycles_per_rev, amp


@pytest.mark.parametrize("order", [36.0, 20.0])
def test_gear_ripple_puts_a_spectral_line_at_its_order_per_revolution(order):
    A = 600.0
    base, withfx = _pair(Scheme1(motor_speed_rpm=3000), {"gear_ripple": {"A": A, "order": order}},
                         seed=25)
    _assert_identical(base, withfx, UNTOUCHED_BY_JOINT)
    f, amp = _angle_spectrum(withfx)
    band = (f > 5) & (f < 60)
    peak = f[band][np.argmax(amp[band])]
    assert peak == pytest.approx(order, abs=1.5)
    assert amp[band].max() == pytest.approx(A, rel=0.15)
    f0, amp0 = _angle_spectrum(base)
    near = (f0 > order - 3) & (f0 < order + 3)
    assert amp0[near].max() < 0.15 * A                         # no line without the effect


def test_torque_offset_acts_on_the_torque_channel_only_growing_with_time():
    spec = {"c0": 500.0, "drift": 3.0}
    base, withfx = _pair(Scheme2(), {"torque_offset": spec}, seed=26)
    others = [c for c in base.columns if c != "torque"]
    _assert_identical(base, withfx, others)                  # every other channel, bit for bit
    t = withfx["t"].to_numpy()
    diff = (withfx["torque"] - base["torque"]).to_numpy()
    np.testing.assert_allclose(diff, torque_offset(t, spec["c0"], spec["drift"]), rtol=1e-9,
                               atol=1e-6)
    assert diff[-1] > diff[0] + 100


def test_time_delay_makes_the_torque_channel_lag():
    delay = 0.05
    plan = Scheme2()
    cfg = dict(seed=27, sample_rate_hz=1000.0)
    rec0, ch0, _ = simulate_records(plan, EmulatorConfig(**cfg))
    rec1, ch1, _ = simulate_records(plan, EmulatorConfig(effects={"time_delay": {"delay": delay}},
                                                         **cfg))
    lag = int(round(delay * 1000))
    # the strain gauge reads exactly the torque `delay` earlier; the joint itself is unchanged
    np.testing.assert_array_equal(rec1[lag:, K.R_TQ_SG], rec1[:-lag, K.R_TQ])
    np.testing.assert_array_equal(rec1[:, K.R_TQ], rec0[:, K.R_TQ])
    for name in ch0:
        if name != "torque":
            np.testing.assert_array_equal(ch0[name], ch1[name], err_msg=name)
    # it shows where the torque changes fast (the load ramps), not during the holds
    d = ch1["torque"] - ch0["torque"]
    np.testing.assert_allclose(d, rec1[:, K.R_TQ_SG] - rec0[:, K.R_TQ], atol=1e-6)
    ph = plan.phase(ch0["t"])
    dTdt = np.gradient(rec0[:, K.R_TQ], 1e-3)
    ramp = (ph == "load") & (ch0["t"] > plan.load_start + 1.0)
    assert np.mean(d[ramp & (np.abs(dTdt) > 2e3)]) == pytest.approx(
        -delay * np.mean(dTdt[ramp & (np.abs(dTdt) > 2e3)]), rel=0.1)
    # where the torque has settled (the holds, once the dynamometer's lag has died out) the
    # delayed channel reads the same
    settled = (ph == "hold") & (np.abs(dTdt) < 50.0)
    assert settled.sum() > 2000
    assert np.abs(d[settled]).max() < 5.0
    assert np.abs(d[ramp]).mean() > 0.8 * delay * plan.ramp_rate   # ramp rate × delay
