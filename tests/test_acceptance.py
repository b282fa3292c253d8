"""Acceptance indicators of Table 11 (core/acceptance.py) on synthetic loading runs with known
errors."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

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
    """The error indicators (items 4-6) by channel."""
    return {i.channel: i for i in acceptance(run) if i.kind == "error"}


def by_item(run):
    return {i.item: i for i in acceptance(run)}


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


def ramp_run(top_cmd: float, top_load: float | None = None, meta: dict | None = None) -> RunData:
    """A loading run whose torque set point ramps 0 → top_cmd → 0 [N·m] and whose measured
    load follows it up to top_load (a dynamometer that saturates there)."""
    t = np.arange(3000) * 0.1
    cmd = np.interp(t, [0, 10, 150, 290, 300], [0, 0, top_cmd, 0, 0])
    load = np.minimum(cmd, top_cmd if top_load is None else top_load) + 300.0 * np.sin(t)
    phase = np.where((t >= 10) & (t < 290), "load", "idle").astype(object)
    df = pd.DataFrame({"t": t, "torque_cmd": cmd, "torque_load": load,
                       "f_shear": np.where(phase == "load", 90e3, 0.0) + 200.0 * np.cos(t),
                       "m_bend": np.where(phase == "load", 225e3, 0.0) + 200.0 * np.cos(t),
                       "phase": pd.Series(phase, dtype=object)})
    return RunData(samples=df, meta={"scheme": 1, **(meta or {})})


def test_all_six_table_11_items_in_order():
    inds = acceptance(loading_run())
    assert [i.item for i in inds] == [5, 4, 6, 1, 2, 3]
    assert [i.kind for i in inds] == ["error"] * 3 + ["range", "range", "value"]
    assert [i.name for i in inds[3:]] == ["torque loading range", "bending moment loading range",
                                          "shear loading value"]
    table = format_table(inds)
    for i in inds:
        assert i.name in table
    run = loading_run()
    run.meta["scheme"] = 3
    assert [i.status for i in acceptance(run)] == ["not judged"] * 6


def test_a_rated_load_run_does_not_show_the_ranges_and_says_so():
    ind = by_item(ramp_run(120e3))
    torque_range, bend_range, shear_value = ind[1], ind[2], ind[3]
    assert torque_range.status == "not met" and torque_range.passed is None
    assert torque_range.reached == pytest.approx(120e3, abs=400.0)
    assert torque_range.note.startswith("reached 1") and "not a test" in torque_range.note
    assert bend_range.status == "not met" and bend_range.reached == pytest.approx(225e3, abs=300)
    assert shear_value.passed is True and shear_value.status == "pass"
    assert ind[5].passed is True                          # its loading error is fine


def test_a_range_test_shows_the_torque_range_or_fails_it():
    ind = by_item(ramp_run(180e3))
    assert ind[1].passed is True and ind[1].status == "pass"
    assert ind[1].reached == pytest.approx(180e3, abs=400.0)
    assert "PASS (reached 1" in format_table(acceptance(ramp_run(180e3))).splitlines()[4]
    # aimed at 180 kN·m, the load stopped at 170: item 1 fails (and so does the error)
    short = by_item(ramp_run(180e3, top_load=170e3))
    assert short[1].passed is False and short[1].status == "fail"
    assert "torque set point up to 180" in short[1].note
    assert short[5].passed is False


def test_unmeasured_items_are_not_invented():
    run = ramp_run(180e3)
    run.samples = run.samples.drop(columns=["m_bend"])
    ind = by_item(run)
    assert ind[2].status == "not measured" and ind[2].passed is None and ind[2].reached is None
    assert "no m_bend channel" in ind[2].note
    run.samples["f_shear"] = np.nan
    assert by_item(run)[3].status == "not measured"


def test_shear_set_point_from_the_scheme_parameters():
    run = ramp_run(120e3, meta={"scheme_params": {"shear_target": 50e3}})
    run.samples["f_shear"] = np.where(run.samples["phase"] == "load", 50e3, 0.0)
    ind = by_item(run)
    assert ind[6].setpoint == "50000 N" and ind[6].passed is True
    assert ind[3].status == "not met" and "shear set point 50 kN" in ind[3].note
