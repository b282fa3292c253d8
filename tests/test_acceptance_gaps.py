"""Table 11 indicators (core/acceptance.py) on runs the acquisition did not fully capture: grid
slots missed, set points read as missing, and a hydraulic load switched on later than the plan
said (a starved service delivers its set point late; the PLC records when it applied it). The
verdict must come from the samples acquired, gaps counted and never filled, and must not move
with how many samples were missed or how late the set point went out — without widening the
±2 kN·m / ±2 kN tolerance."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from core.acceptance import APPLIED_PRESSURE, acceptance
from core.params import JointParams
from core.run import RunData

P = JointParams()
RATE = 10.0                                    # Hz: the loading schemes' grid
LOAD_START, LOAD_END, END = 2.0, 90.0, 95.0    # s
SHEAR = 90e3                                   # N: the schemes' shear set point
BEND = SHEAR * P.arm_bend                      # 225 kN·m


def hydraulic_run(delay: float, drop: float = 0.0, seed: int = 0, bend_err: float = 0.0,
                  noise: float = 100.0, applied_channel: bool = True) -> RunData:
    """A 10 Hz loading run (scheme 2) whose hydraulic set point the PLC applied `delay` s after
    the loading phase began; the cylinder force follows it with the regulator's lag p_tau.
    Each sample sits at a random instant of its grid slot (the first PLC snapshot in it);
    a fraction `drop` of the slots is missed (no row), at random. `bend_err` [N·m]: a steady
    bending error after the response has settled (a miscalibrated regulator)."""
    rng = np.random.default_rng(seed)
    n = int(END * RATE) + 1
    t = (np.arange(n) + rng.uniform(0.0, 0.3, n)) / RATE
    t[0] = 0.0
    loading = (t >= LOAD_START) & (t < LOAD_END)
    t_on = LOAD_START + delay
    on = loading & (t >= t_on)
    p_set = np.where(on, SHEAR / P.cyl_area, 0.0)
    force = np.where(on, SHEAR * (1.0 - np.exp(-(t - t_on) / P.p_tau)), 0.0)
    df = pd.DataFrame({
        "t": t,
        "torque_cmd": np.zeros(n), "torque_load": rng.normal(0.0, noise, n),
        "f_shear": force + rng.normal(0.0, noise, n),
        "m_bend": force * P.arm_bend + np.where(on, bend_err, 0.0) + rng.normal(0.0, noise, n),
        "phase": pd.Series(np.where(loading, "load", "idle"), dtype=object),
    })
    if applied_channel:
        df[APPLIED_PRESSURE] = p_set
    keep = np.ones(n, dtype=bool)
    keep[1:] = rng.random(n - 1) >= drop
    df = df[keep].reset_index(drop=True)
    return RunData(samples=df, meta={"scheme": 2, "sample_rate_hz": RATE})


def hydraulics(run: RunData) -> dict[str, object]:
    return {i.channel: i for i in acceptance(run) if i.channel in ("m_bend", "f_shear")
            and i.kind == "error"}


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("drop", [0.0, 0.15, 0.5])
@pytest.mark.parametrize("delay", [0.0, 0.15, 0.4, 1.0])
def test_bending_verdict_holds_whatever_the_set_point_delay_and_the_missed_samples(
        delay, drop, seed):
    """The settling is timed from when the PLC applied the set point, not from when the plan
    asked for it: a late set point (the 2.30 kN·m FAIL of a loaded demo run: 5 p_tau after
    the phase start, a 225 kN·m step delayed 0.2 s still lacks 2.3 kN·m) is the actuator's
    response, not a loading error, however many samples were missed around it."""
    ind = hydraulics(hydraulic_run(delay, drop, seed))
    assert ind["m_bend"].passed is True, (ind["m_bend"].max_abs, ind["m_bend"].note)
    assert ind["f_shear"].passed is True
    assert ind["m_bend"].max_abs < BEND * np.exp(-5.0) + 4 * 100.0   # what 5 p_tau leave, + noise


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("drop", [0.0, 0.15, 0.5])
def test_a_real_bending_error_still_fails_with_missed_samples(drop, seed):
    """The tolerance is not widened: 2.3 kN·m of steady error fails, late set point or not."""
    for delay in (0.0, 0.4):
        ind = hydraulics(hydraulic_run(delay, drop, seed, bend_err=2.3e3))
        assert ind["m_bend"].passed is False
        assert ind["f_shear"].passed is True


def test_without_the_applied_set_point_the_phase_start_still_anchors_the_settling():
    """A run that does not record the applied set point (an import, the offline emulator)
    is timed from the loading phase's start, as before."""
    run = hydraulic_run(0.0, applied_channel=False)
    ind = hydraulics(run)
    assert ind["m_bend"].passed is True
    judged = run.samples["t"].between(LOAD_START + 5 * P.p_tau, LOAD_END, inclusive="left")
    assert ind["m_bend"].judged == int(judged.sum())


def test_a_set_point_step_inside_a_gap_is_timed_from_the_first_sample_after_it():
    """The step's instant is unknown inside a gap: the settling runs from the first sample
    that shows it (the latest instant it can have happened), never from an interpolation."""
    run = hydraulic_run(0.4, seed=1)
    s = run.samples
    gap = (s["t"] > LOAD_START + 0.05) & (s["t"] < LOAD_START + 1.2)     # the step is in here
    run.samples = s[~gap].reset_index(drop=True)
    ind = hydraulics(run)["m_bend"]
    assert ind.passed is True
    t = run.samples["t"].to_numpy()
    first_after = t[t >= LOAD_START + 1.2][0]
    loading = (t >= LOAD_START) & (t < LOAD_END)
    assert ind.judged == int(np.sum(loading & (t >= first_after + 5 * P.p_tau)))


def test_missed_grid_slots_inside_the_judged_stretch_are_counted_as_missing():
    """Missed samples are not judged, not filled, and counted: a NaN value and a grid slot
    with no row alike."""
    run = hydraulic_run(0.0, seed=2)
    s = run.samples
    slot = np.floor(s["t"].to_numpy() * RATE + 1e-6).astype(int)
    absent = (slot >= 300) & (slot < 340)                 # 4 s missed in the middle of the load
    s = s[~absent].reset_index(drop=True)
    s.loc[500:504, "m_bend"] = np.nan                     # 5 readings lost
    run.samples = s
    ind = hydraulics(run)
    assert ind["m_bend"].missing == 40 + 5
    assert ind["f_shear"].missing == 40
    assert ind["m_bend"].passed is True
    items = {i.item: i for i in acceptance(run)}          # items 1-3 count every missed slot
    assert (items[1].missing, items[2].missing, items[3].missing) == (40, 45, 40)


def step_run(nan_before_step: bool) -> RunData:
    """A torque run with 10 kN·m set-point steps every 2 s that the dynamometer follows one
    sample late (a 10 kN·m transient at each step, which the settling excludes)."""
    t = np.arange(2000) * 0.01
    cmd = np.where(t < 2, 0.0, np.floor((t - 2) / 2) * 10e3)
    lagged = cmd.copy()
    lagged[1:] = cmd[:-1]
    cmd_read = cmd.copy()
    if nan_before_step:                                   # the reading just before each step lost
        steps = np.flatnonzero(np.diff(cmd) != 0) + 1
        cmd_read[steps - 1] = np.nan
    df = pd.DataFrame({"t": t, "torque_cmd": cmd_read, "torque_load": lagged + 300.0 * np.sin(t),
                       "phase": pd.Series(np.where(t >= 2, "load", "idle"), dtype=object)})
    return RunData(samples=df, meta={"scheme": 1})


def test_a_torque_step_next_to_a_missing_set_point_reading_is_still_a_step():
    """A step is a change between the set point's last known value and its next one: a NaN
    reading before it must not hide it (the step's transient would be judged as error)."""
    clean, holed = (next(i for i in acceptance(step_run(nan)) if i.item == 5)
                    for nan in (False, True))
    assert clean.passed is True
    assert holed.passed is True, holed.max_abs
    assert holed.max_abs == pytest.approx(clean.max_abs, abs=50.0)
