"""The DAQ's interlocks: limits checked on every PLC status sample and drive status, and the
link/e-stop trips. A trip makes the rig safe (daq/rig.py) and is recorded; this module only
decides whether something trips — pure functions of the measured values and the settings.

| name                | trips when                                                          |
|---------------------|---------------------------------------------------------------------|
| `torque`            | |joint torque| > torque_limit (default 105 % of the rated 120 kN·m;   |
|                     | the run's limit set may raise it: "range" 189 kN·m, core/schemes.py)|
| `angle`             | |output angle q| > the limit set's angle_limit (±180°), or q missing|
| `bending`           | |bending moment| > bend_limit (250 kN·m)                             |
| `shear`             | |shear| > shear_limit + shear_tolerance (90 kN + 2 kN)               |
| `pressure`          | hydraulic pressure > pressure_limit                                 |
| `motor_temperature` | a motor winding > motor_temp_limit                                  |
| `estop`             | the PLC reports its e-stop latched, or the operator presses e-stop  |
| `plc_fault`         | the PLC made itself safe (its heartbeat watchdog tripped)           |
| `plc_link`          | no successful status poll for plc_link_timeout                      |
| `drive_link`        | a second drive lost (heartbeat or EMCY), or no drive left           |

A limit trips unless the reading is known to be inside it: a missing or invalid sample (NaN,
±inf) of a limited channel trips like an excess, because an unknown torque is not a safe torque
(a comparison `value > limit` is false for NaN and would let it pass).
The absolute-angle interlock watches the output encoder, which homing zeroes at 0°
(core/plc_map.py), so repeated runs cannot carry the joint past its ±180° travel.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Mapping

from core.plc_map import REGISTER_MAP
from core.schemes import LIMIT_SETS, LimitSet
from daq.settings import Settings

INTERLOCKS = ("torque", "bending", "shear", "pressure", "motor_temperature", "estop",
              "plc_fault", "plc_link", "drive_link", "angle")


@dataclass(frozen=True)
class Trip:
    """One interlock trip: which, why, the measured value and the limit (SI), wall time."""

    name: str
    message: str
    value: float | None = None
    limit: float | None = None
    t: float = field(default_factory=time.time)


class Interlocks:
    """The limits of one settings object under one limit set (default: "default")."""

    def __init__(self, settings: Settings, limit_set: LimitSet | None = None) -> None:
        s = settings
        self.limit_set = limit_set or LIMIT_SETS["default"]
        ls = self.limit_set
        torque_limit = s.torque_limit if ls.torque_limit is None else ls.torque_limit
        self.limits: dict[str, tuple[str, float, str]] = {
            # name: (status signal, limit, unit)
            "torque": ("torque", torque_limit, "N·m"),
            "bending": ("m_bend", s.bend_limit, "N·m"),
            "shear": ("f_shear", s.shear_limit + s.shear_tolerance, "N"),
            "pressure": ("p_hyd", s.pressure_limit, "Pa"),
        }
        self.motor_temp_limit = s.motor_temp_limit
        self.angle_limit = ls.angle_limit
        self._bits = REGISTER_MAP.signals["status_bits"]

    def describe(self) -> dict[str, object]:
        """The limits in force, for the run's record: the limit set's name and purpose and
        every limit [SI]."""
        return {"limit_set": self.limit_set.name, "purpose": self.limit_set.purpose,
                **{f"{name}_limit": limit for name, (_, limit, _) in self.limits.items()},
                "angle_limit": self.angle_limit, "motor_temp_limit": self.motor_temp_limit}

    def check_angle(self, q: float) -> Trip | None:
        """Trip when the output angle q [rad] is beyond ±angle_limit or missing (NaN)."""
        if abs(q) <= self.angle_limit:
            return None
        what = f"{math.degrees(q):.2f}°" if math.isfinite(q) else f"unknown ({q})"
        limit = math.degrees(self.angle_limit)
        return Trip("angle", f"output angle {what} outside ±{limit:.1f}°", float(q),
                    float(self.angle_limit))

    def check_status(self, status: Mapping[str, float]) -> list[Trip]:
        """Trips raised by one decoded PLC status sample."""
        trips = []
        for name, (signal, limit, unit) in self.limits.items():
            v = float(status.get(signal, math.nan))
            if not abs(v) <= limit:  # trips on NaN too
                why = "beyond" if math.isfinite(v) else "unknown, limit"
                trips.append(Trip(name, f"{signal} {v:.6g} {unit} {why} {limit:.6g} {unit}",
                                  v, float(limit)))
        angle = self.check_angle(float(status.get("q", math.nan)))
        if angle is not None:
            trips.append(angle)
        bits = int(status.get("status_bits", 0))
        if bits & self._bits.bit("estop"):
            trips.append(Trip("estop", "e-stop latched at the PLC"))
        if bits & self._bits.bit("watchdog_fault"):
            trips.append(Trip("plc_fault", "the PLC's heartbeat watchdog made the rig safe"))
        return trips

    def check_motor_temperature(self, motor: int, temp: float) -> Trip | None:
        """Trip if motor `motor` (1–3) is over its temperature limit [°C]."""
        if not temp <= self.motor_temp_limit:  # trips on NaN too
            return Trip("motor_temperature",
                        f"motor {motor} at {temp:.1f} °C beyond {self.motor_temp_limit:.1f} °C",
                        float(temp), float(self.motor_temp_limit))
        return None

    @staticmethod
    def plc_link_lost(silent_for: float, limit: float) -> Trip:
        return Trip("plc_link", f"no answer from the PLC for {silent_for:.3f} s", silent_for, limit)

    @staticmethod
    def drive_link_lost(dropped: list[str], active: int) -> Trip:
        return Trip("drive_link", f"{len(dropped)} drives lost ({'; '.join(dropped)}), "
                                  f"{active} left", float(len(dropped)))

    @staticmethod
    def operator_estop(reason: str) -> Trip:
        return Trip("estop", f"operator e-stop: {reason}")
