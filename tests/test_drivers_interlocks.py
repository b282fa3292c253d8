"""The interlock rules (daq/interlocks.py) on synthetic samples: each trips on its own."""

import math

import pytest

from daq.interlocks import INTERLOCKS, Interlocks
from core.plc_map import REGISTER_MAP
from daq.settings import Settings

SB = REGISTER_MAP.signals["status_bits"]
QUIET = {"torque": 100e3, "m_bend": 200e3, "f_shear": 80e3, "p_hyd": 20e6, "q": 0.5,
         "status_bits": 0}


def names(trips):
    return [t.name for t in trips]


def test_quiet_sample_does_not_trip():
    assert Interlocks(Settings()).check_status(QUIET) == []


@pytest.mark.parametrize("signal,value,name", [
    ("torque", 126.1e3, "torque"), ("torque", -126.1e3, "torque"),
    ("m_bend", 250.5e3, "bending"), ("f_shear", 92.1e3, "shear"), ("f_shear", -92.1e3, "shear"),
    ("p_hyd", 24.1e6, "pressure"),
])
def test_each_limit_trips_alone(signal, value, name):
    il = Interlocks(Settings())
    trips = il.check_status(dict(QUIET, **{signal: value}))
    assert names(trips) == [name]
    assert trips[0].value == value and trips[0].limit < abs(value)
    # just inside the limit: no trip (shear has its tolerance)
    inside = {"torque": 125.9e3, "m_bend": 249.9e3, "f_shear": 91.9e3, "p_hyd": 23.9e6}[signal]
    assert il.check_status(dict(QUIET, **{signal: inside})) == []


def test_limits_come_from_settings():
    il = Interlocks(Settings(torque_limit=50e3, shear_limit=10e3, shear_tolerance=1e3))
    assert names(il.check_status(dict(QUIET, torque=60e3, f_shear=20e3))) == ["torque", "shear"]


@pytest.mark.parametrize("signal,name", [("torque", "torque"), ("m_bend", "bending"),
                                         ("f_shear", "shear"), ("p_hyd", "pressure")])
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_an_unknown_reading_trips(signal, name, value):
    """A NaN (missing) or infinite reading of a limited channel trips: `abs(v) > limit` is
    false for NaN and would let an unknown torque pass."""
    il = Interlocks(Settings())
    trips = il.check_status(dict(QUIET, **{signal: value}))
    assert names(trips) == [name]
    assert signal in trips[0].message
    missing = dict(QUIET)
    del missing[signal]                              # a status without the signal at all
    assert names(il.check_status(missing)) == [name]


def test_an_unknown_motor_temperature_trips():
    il = Interlocks(Settings())
    assert il.check_motor_temperature(1, math.nan).name == "motor_temperature"
    assert il.check_motor_temperature(1, math.inf).name == "motor_temperature"


def test_plc_bits_trip():
    il = Interlocks(Settings())
    assert names(il.check_status(dict(QUIET, status_bits=SB.bit("estop")))) == ["estop"]
    assert names(il.check_status(dict(QUIET, status_bits=SB.bit("watchdog_fault")))) == ["plc_fault"]


def test_motor_temperature_and_links():
    il = Interlocks(Settings(motor_temp_limit=110.0))
    assert il.check_motor_temperature(2, 109.0) is None
    t = il.check_motor_temperature(2, 111.0)
    assert t.name == "motor_temperature" and "motor 2" in t.message
    assert Interlocks.plc_link_lost(0.7, 0.5).name == "plc_link"
    assert Interlocks.drive_link_lost(["a", "b"], 1).name == "drive_link"
    assert Interlocks.operator_estop("test").name == "estop"
    assert set(INTERLOCKS) == {"torque", "bending", "shear", "pressure", "motor_temperature",
                               "estop", "plc_fault", "plc_link", "drive_link", "angle"}
