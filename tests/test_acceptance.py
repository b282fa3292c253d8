"""Acceptance indicators of Table 11 (core/acceptance.py) on synthetic loading runs with known
errors."""

from __future__ import annotations

import numpy as np
import pandas as pd

from core.acceptance import acceptance, format_table, is_loading_run
from core.params import JointParams
from core.run import RunData


def loading_run(n: int = 2000, torque_err: float = 500.0, shear_err: float = 300.0,
                bend_err: float = 800.0, meta: dict | None = None) -> RunData:
    t = np.arange(n) * 0.01                                  # 20 s at 100 Hz
    phase = np.array(["idle"] * 200 + ["load"] * 1400 + ["unload"] * (n - 1600), dtype=object)
    cmd = np.where(t < 2, 0.0, np.floor((t - 2) / 2) * 10e3)  # 10 kN·m steps every 2 s
    lagged = cmd.copy()
    lagged[1:] = cmd[:-1]                                     # a one-sample lag: steps overshoot
    shear_sp = (meta or {}).get("shear_setpoint_n", 90e3)
    bend_sp = (meta or {}).get("bend_setpoint_nm", shear_sp * JointParams().arm_bend)
    df = pd.DataFrame({
        "t": t, "torque_cmd": cmd,
        "torque_load": lagged + torque_err * np.sin(t),
        "f_shear": shear_sp + shear_err * np.cos(t),
        "m_bend": bend_sp + bend_err * np.cos(t),
        "phase": pd.Series(phase, dtype=object),
    })
    df.loc[500:509, "f_shear"] = np.nan                      # dropout inside the loading
    df.loc[0:150, "m_bend"] = 1e6                            # junk while idle: not judged
    return RunData(samples=df, meta={"scheme": 2, **(meta or {})})


def by_name(run):
    return {i.channel: i for i in acceptance(run)}


def test_pass_with_errors_inside_tolerance():
    ind = by_name(loading_run())
    tq, bend, shear = ind["torque_load"], ind["m_bend"], ind["f_shear"]
    assert tq.passed and bend.passed and shear.passed
    assert abs(tq.max_abs - 500.0) < 5.0                      # step transients excluded
    assert abs(bend.max_abs - 800.0) < 1.0 and abs(shear.max_abs - 300.0) < 1.0
    assert shear.missing == 10 and tq.missing == 0
    # judged: loading phases minus settling (1 s after the loading start and each step;
    # 2.5 s after the loading start for the hydraulics)
    loading = 1800
    assert shear.judged == loading - 250 - 10
    assert tq.judged == loading - 100 * 9                     # loading start + 8 steps


def test_fail_beyond_tolerance():
    ind = by_name(loading_run(torque_err=2500.0, shear_err=2100.0, bend_err=1500.0))
    assert ind["torque_load"].passed is False and ind["f_shear"].passed is False
    assert ind["m_bend"].passed is True
    assert "FAIL" in format_table(acceptance(loading_run(torque_err=2500.0)))


def test_step_transient_would_fail_without_settling_exclusion():
    run = loading_run()
    run.meta["acceptance_settle_s"] = 0.0
    assert by_name(run)["torque_load"].passed is False       # the 10 kN·m lag at each step


def test_setpoints_from_metadata():
    meta = {"shear_setpoint_n": 50e3, "bend_setpoint_nm": 100e3}
    ind = by_name(loading_run(meta=meta))
    assert ind["f_shear"].setpoint == "50000 N" and ind["f_shear"].passed
    assert ind["m_bend"].setpoint == "100000 N·m" and ind["m_bend"].passed
    # the same data judged against the default set points fails
    run = loading_run(meta=meta)
    run.meta = {"scheme": 2}
    assert by_name(run)["f_shear"].passed is False


def test_default_bending_setpoint_is_shear_times_lever():
    ind = by_name(loading_run())
    assert ind["m_bend"].setpoint == f"{90e3 * JointParams().arm_bend:g} N·m"


def test_not_a_loading_run_and_absent_channels():
    run = loading_run()
    run.meta["scheme"] = 3
    assert not is_loading_run(run)
    assert all(i.passed is None and i.note == "not a loading run" for i in acceptance(run))
    run = loading_run()
    run.samples = run.samples.drop(columns=["m_bend", "torque_cmd"])
    ind = by_name(run)
    assert ind["m_bend"].passed is None and ind["torque_load"].passed is None
    assert "torque_cmd" in ind["torque_load"].note
    assert ind["f_shear"].passed is True
