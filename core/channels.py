"""Channel names and units of the run interchange format (../shared/docs/run-format.md).
The single list every package uses for column names: emulator outputs, DAQ streams, database
channels, import/export and model inputs."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Channel:
    name: str
    unit: str
    meaning: str


CHANNELS: dict[str, Channel] = {c.name: c for c in (
    Channel("t", "s", "time since the run started, strictly increasing"),
    Channel("q", "rad", "output (load-side) joint angle, output encoder"),
    Channel("qd", "rad/s", "output joint velocity"),
    Channel("qdd", "rad/s²", "output joint acceleration"),
    Channel("u", "rad", "motor angle referred to the output (motor angle / reduction)"),
    Channel("ud", "rad/s", "motor velocity referred to the output"),
    Channel("torsion", "rad", "q − u, the paper's Eq. 6 torsion"),
    Channel("torque", "N·m", "joint (transmitted) output torque, strain gauges"),
    Channel("torque_load", "N·m", "dynamometer torque measured at the loading shaft"),
    Channel("torque_cmd", "N·m", "dynamometer torque set point"),
    Channel("i_m1", "A", "motor 1 current"),
    Channel("i_m2", "A", "motor 2 current"),
    Channel("i_m3", "A", "motor 3 current"),
    Channel("w_m1", "rad/s", "motor 1 speed"),
    Channel("w_m2", "rad/s", "motor 2 speed"),
    Channel("w_m3", "rad/s", "motor 3 speed"),
    Channel("temp_m1", "°C", "motor 1 winding temperature"),
    Channel("temp_m2", "°C", "motor 2 winding temperature"),
    Channel("temp_m3", "°C", "motor 3 winding temperature"),
    Channel("temp_joint", "°C", "gearbox / joint temperature"),
    Channel("p_hyd", "Pa", "hydraulic pressure"),
    Channel("m_bend", "N·m", "bending moment from the hydraulic cylinder"),
    Channel("f_shear", "N", "shear force"),
    Channel("phase", "", "idle, load, hold, unload, excite"),
)}

CHANNEL_NAMES: tuple[str, ...] = tuple(CHANNELS)
NUMERIC_CHANNELS: tuple[str, ...] = tuple(n for n in CHANNEL_NAMES if n != "phase")
PHASES: tuple[str, ...] = ("idle", "load", "hold", "unload", "excite")


def unit_of(name: str) -> str:
    """Unit of a known channel; '' for an unknown (extra) channel."""
    ch = CHANNELS.get(name)
    return ch.unit if ch else ""
