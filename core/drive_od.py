"""The drives' CANopen object dictionary facts that both sides share: the EDS file
(core/drives.eds — the single source for indices, types, defaults and PDO mappings), the units
of its objects, and the CiA 402 state machine's statusword/controlword coding.

daq/drives.py (the master) and simulators/drives.py (the drive stand-in) both read this
module, so a unit or a state code cannot differ between them.
"""

from __future__ import annotations

import math
from pathlib import Path

from canopen.profiles.p402 import State402

EDS_PATH = Path(__file__).with_name("drives.eds")

# --- object indices (CiA 301 / CiA 402 / manufacturer-specific) ------------------------------
HEARTBEAT_TIME = 0x1017
ERROR_REGISTER = 0x1001
ERROR_FIELD = 0x1003
TPDO_COMM = (0x1800, 0x1801)
TPDO_MAP = (0x1A00, 0x1A01)
RPDO_COMM = (0x1400, 0x1401)
RPDO_MAP = (0x1600, 0x1601)
MOTOR_TEMPERATURE = 0x2010
SAMPLE_STAMP = 0x2011
"""Manufacturer-specific: the drive clock [ms, rig time] when the TPDO values were sampled
(UNSIGNED16, wraps at STAMP_WRAP): a time stamp per sample, and a loss/duplicate detector."""
STAMP_WRAP = 1 << 16
"""The sample stamp counts milliseconds modulo this (an UNSIGNED16)."""


def stamp_of(ms: int) -> int:
    """The sample stamp a drive writes at its clock `ms` [ms]."""
    return ms % STAMP_WRAP


def stamp_delta(new: int, old: int) -> int:
    """Milliseconds from stamp `old` to stamp `new`, across one wrap."""
    return (new - old) % STAMP_WRAP
ERROR_CODE = 0x603F
CONTROLWORD = 0x6040
STATUSWORD = 0x6041
QUICK_STOP_OPTION = 0x605A
MODES_OF_OPERATION = 0x6060
MODES_DISPLAY = 0x6061
VELOCITY_ACTUAL = 0x606C
TARGET_TORQUE = 0x6071
MAX_TORQUE = 0x6072
RATED_CURRENT = 0x6075
RATED_TORQUE = 0x6076
TORQUE_ACTUAL = 0x6077
CURRENT_ACTUAL = 0x6078
MAX_MOTOR_SPEED = 0x6080
QUICK_STOP_DECEL = 0x6085
TARGET_VELOCITY = 0x60FF

FAST_TPDO = 1
"""TPDO1: velocity, current, sample time stamp — the 1 kHz stream."""
STATUS_TPDO = 2
"""TPDO2: statusword, torque, temperature, mode display — slow, and sent on statusword change."""

# --- units of the objects (see the EDS [Comments]) ---------------------------------------------
RPM = 2.0 * math.pi / 60.0
"""1 r/min in rad/s."""
VELOCITY_UNIT = 1e-3 * RPM
"""0x606C / 0x60FF unit: 0.001 r/min at the motor shaft, in rad/s."""
TEMPERATURE_UNIT = 0.1
"""0x2010 unit [°C]."""
PER_MILLE = 1e-3
"""0x6071/0x6072/0x6077 are ‰ of 0x6076 (mN·m); 0x6078 is ‰ of 0x6075 (mA)."""

# --- modes of operation (0x6060) ---------------------------------------------------------------
MODE_PROFILE_VELOCITY = 3
MODE_PROFILE_TORQUE = 4
MODE_CSV = 9
SUPPORTED_MODES = (MODE_PROFILE_VELOCITY, MODE_PROFILE_TORQUE, MODE_CSV)

# --- CiA 402 state machine -----------------------------------------------------------------
# statusword (mask, value) per state, CiA 402 Table 30: canopen's own table, so the drivers,
# the drive stand-in and canopen's profile never disagree
STATE_CODES: dict[str, tuple[int, int]] = dict(State402.SW_MASK)
SW_VOLTAGE_ENABLED = 0x0010
SW_WARNING = 0x0080
SW_REMOTE = 0x0200
SW_TARGET_REACHED = 0x0400

CW_SHUTDOWN = 0x0006
CW_SWITCH_ON = 0x0007
CW_ENABLE_OPERATION = 0x000F
CW_DISABLE_VOLTAGE = 0x0000
CW_QUICK_STOP = 0x0002
CW_FAULT_RESET = 0x0080

EMCY_GENERIC = 0x1000
"""EMCY error code the drive stand-in raises for an injected motor/drive fault."""
EMCY_MOTOR_TEMPERATURE = 0x4310
"""EMCY error code for a drive temperature fault (CiA 301 0x43xx)."""


def state_of(statusword: int) -> str:
    """CiA 402 state named by a statusword ('UNKNOWN' if none matches)."""
    for name, (mask, value) in STATE_CODES.items():
        if statusword & mask == value:
            return name
    return "UNKNOWN"


def statusword_for(state: str, extra: int = 0) -> int:
    """The statusword a drive reports in `state` (value bits | extra flags)."""
    return STATE_CODES[state][1] | extra
