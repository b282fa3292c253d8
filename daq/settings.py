"""One settings object for the DAQ side: where the PLC and the CAN bus are, how hard to try,
which drives, and the interlock limits. The same object points the service at the emulator
(loopback, the defaults) or at the real rig — only settings say which.

Sources, later wins: the defaults below → a TOML or JSON file (`Settings.load(path)` or the
path in $RIG_CONFIG, its [daq] table if it has one) → environment variables `RIG_<FIELD>`
(e.g. RIG_PLC_PORT=5020, RIG_NODE_IDS=1,2,3, RIG_CAN_INTERFACE=virtual).

Every setting has a type, a unit and a range (pydantic validates them); NaN, ±inf, an empty
value or one out of range stops start-up with a message naming the variable (or the file and
key), the value, the unit and the range: a limit of NaN would switch its interlock off, an
infinite timeout its watchdog. Units: seconds, Hz, N·m, N, Pa, °C.
"""

from __future__ import annotations

import os
from dataclasses import asdict, fields, replace
from pathlib import Path
from typing import Any, Literal, Mapping, get_args

from pydantic import ConfigDict, ValidationInfo, field_validator
from pydantic.dataclasses import dataclass

from core.config_file import build_settings, read_config_file, setting
from core.params import RATED_TORQUE

CanInterface = Literal["socketcand", "virtual", "socketcan", "udp_multicast"]
CAN_INTERFACES: tuple[str, ...] = get_args(CanInterface)
"""python-can interfaces the DAQ accepts. udp_multicast is always opened with hop_limit=0
(daq/drives.py), so its frames never leave this machine."""
SOCKETCAND_PORT = 29536
"""socketcand's default TCP port."""
ENV_PREFIX = "RIG_"
"""The DAQ side's environment prefix: RIG_<FIELD>."""
OTHER_PREFIXES = ("RIG_API_", "RIG_DB_", "RIG_DASK_", "RIG_JOB_", "RIG_TEST_")
OTHER_NAMES = frozenset({"RIG_CONFIG", "RIG_WORKERS", "RIG_MAX_BODY_BYTES"})
"""RIG_* variables owned by other parts of the service (the settings file, the database, the
API and its jobs, the tests): not DAQ settings, so `load` neither reads nor refuses them. Any
other RIG_* variable that is no DAQ setting is refused as a typo (a misspelt limit must not
leave the default in force unnoticed). No DAQ field starts with one of these prefixes."""



@dataclass(frozen=True, config=ConfigDict(allow_inf_nan=False, extra="forbid"))
class Settings:
    """DAQ-side settings; see the module docstring for how they are loaded."""

    # --- PLC (S7-1500 MB_SERVER over Modbus TCP) ----------------------------------------
    plc_host: str = setting("127.0.0.1", "-", "PLC address (host name or IP)", min_length=1)
    plc_port: int = setting(5020, "-", "PLC Modbus TCP port", ge=1, le=65535)
    plc_device_id: int = setting(1, "-", "Modbus unit id of the PLC", ge=0, le=255)
    plc_timeout: float = setting(
        0.5, "s", "Per-request timeout; bounded to 0.5–1 s (pymodbus' 3 s default × retries "
        "blocks a request racing a dropped connection for 12 s).", ge=0.5, le=1.0)
    plc_retries: int = setting(0, "-", "Retries per request.", ge=0, le=1)
    plc_reconnect_delay: float = setting(
        0.1, "s", "First reconnect back-off; doubles up to plc_reconnect_delay_max.",
        ge=0.01, le=5.0)
    plc_reconnect_delay_max: float = setting(
        1.0, "s", "Longest reconnect back-off (pymodbus' default grows to 300 s).",
        ge=1.0, le=5.0)
    plc_poll_hz: float = setting(
        100.0, "Hz", "Status-block poll rate (plan 2–10 Hz on the real S7: 100–500 ms per "
        "block poll).", ge=0.5, le=1000.0)
    plc_word_order: Literal["big", "little"] = setting(
        "big", "-", "Word order of the PLC's 32-bit values: 'big' (S7, high word first) or "
        "'little'.")
    heartbeat_period: float = setting(
        0.1, "s", "Service heartbeat write period; the PLC watchdog trips after ~0.5 s of "
        "silence, so a slower heartbeat could never keep it alive.", ge=0.01, le=0.5)
    plc_link_timeout: float = setting(
        0.5, "s", "No successful status poll for this long = PLC link lost → make the rig "
        "safe.", ge=0.05, le=10.0)

    # --- drives (S120 via CBC10, CANopen CiA 402) ------------------------------------------
    can_interface: CanInterface = setting(
        "socketcand", "-", "python-can interface: 'socketcand' (loopback server of `rig "
        "emulate`, or a socketcand gateway beside a real CAN card), 'virtual' (in-process "
        "tests), 'socketcan' (real rig), 'udp_multicast' (this machine only).")
    can_channel: str = setting("can0", "-", "CAN channel name", min_length=1)
    can_host: str = setting("127.0.0.1", "-", "socketcand server host.", min_length=1)
    can_port: int = setting(SOCKETCAND_PORT, "-", "socketcand server port.", ge=1, le=65535)
    can_bitrate: int = setting(1_000_000, "bit/s", "CAN bit rate", ge=10_000, le=1_000_000)
    node_ids: tuple[int, ...] = setting(
        (1, 2, 3), "-", "CANopen node ids of the drives, motor 1 first, distinct, each 1–127 "
        "(env: comma-separated). Empty = no drives (PLC only).")
    drive_heartbeat_ms: int = setting(
        100, "ms", "Heartbeat producer time the master configures on each drive (0x1017).",
        ge=10, le=1000)
    drive_heartbeat_timeout: float = setting(
        0.5, "s", "No heartbeat for this long = drive lost (dropped; a second loss makes the "
        "rig safe); must exceed the heartbeat period. Five producer periods: a loaded host "
        "may delay a heartbeat by a few hundred ms.", gt=0.0, le=10.0)
    tpdo_rate_hz: float = setting(
        1000.0, "Hz", "Rate of the drives' fast TPDO (speed, current, sample counter).",
        gt=0.0, le=1000.0)
    status_tpdo_rate_hz: float = setting(
        10.0, "Hz", "Rate of the drives' status TPDO (statusword, torque, temperature); it is "
        "also sent at once when the statusword changes.", gt=0.0, le=1000.0)
    sdo_timeout: float = setting(0.5, "s", "SDO response timeout.", ge=0.05, le=5.0)
    drive_enable_timeout: float = setting(
        3.0, "s", "Longest wait for a drive to reach a CiA 402 state.", ge=0.1, le=30.0)

    # --- interlocks ----------------------------------------------------------------------
    torque_limit: float = setting(
        1.05 * RATED_TORQUE, "N·m", "|joint torque| trip (default 105 % of the rated "
        "120 kN·m; at most the rig's 180 kN·m loading range (Table 11) plus margin).",
        gt=0.0, le=200e3)
    bend_limit: float = setting(
        250e3, "N·m", "|bending moment| trip (Table 11 range 0–250 kN·m).", gt=0.0, le=275e3)
    shear_limit: float = setting(
        90e3, "N", "Nominal shear load (Table 11); trips above shear_limit + shear_tolerance.",
        gt=0.0, le=100e3)
    shear_tolerance: float = setting(
        2e3, "N", "Shear loading tolerance (Table 11: ±2 kN).", ge=0.0, le=10e3)
    pressure_limit: float = setting(
        24e6, "Pa", "Hydraulic pressure trip (at most the 25 MPa relief of the pump).",
        gt=0.0, le=25e6)
    motor_temp_limit: float = setting(
        120.0, "°C", "Motor winding over-temperature trip (at most insulation class F, "
        "155 °C).", gt=0.0, le=155.0)
    safe_pressure: float = setting(
        0.0, "Pa", "Hydraulic pressure set point when the rig is made safe (≤ pressure_limit).",
        ge=0.0, le=25e6)

    # --- the checks between fields (each reported on the later field) -------------------

    @field_validator("node_ids", mode="before")
    @classmethod
    def _split_node_ids(cls, value: Any) -> Any:
        if isinstance(value, str):
            return [v.strip() for v in value.replace(";", ",").split(",") if v.strip()]
        return value

    @field_validator("node_ids")
    @classmethod
    def _distinct_node_ids(cls, value: tuple[int, ...]) -> tuple[int, ...]:
        if len(set(value)) != len(value) or any(not 1 <= n <= 127 for n in value):
            raise ValueError(f"node ids {value} must be distinct CANopen ids 1–127")
        return value

    @field_validator("plc_reconnect_delay_max")
    @classmethod
    def _delay_order(cls, value: float, info: ValidationInfo) -> float:
        first = info.data.get("plc_reconnect_delay")
        if first is not None and first > value:
            raise ValueError(f"must be ≥ plc_reconnect_delay ({first} s)")
        return value

    @field_validator("drive_heartbeat_timeout")
    @classmethod
    def _timeout_beyond_period(cls, value: float, info: ValidationInfo) -> float:
        period_ms = info.data.get("drive_heartbeat_ms")
        if period_ms is not None and value <= period_ms / 1000.0:
            raise ValueError(f"must exceed the drives' heartbeat period "
                             f"(drive_heartbeat_ms = {period_ms} ms)")
        return value

    @field_validator("safe_pressure")
    @classmethod
    def _safe_below_limit(cls, value: float, info: ValidationInfo) -> float:
        limit = info.data.get("pressure_limit")
        if limit is not None and value > limit:
            raise ValueError(f"must not exceed pressure_limit ({limit} Pa)")
        return value

    # --- loading -------------------------------------------------------------------------

    def replace(self, **changes: Any) -> "Settings":
        return replace(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["node_ids"] = list(self.node_ids)
        return d

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any],
                     origin: Mapping[str, str] | None = None) -> "Settings":
        """Settings from a {field: value} mapping; unknown keys are refused by name, bad values
        with the name `origin` gives their source (default: the field name)."""
        known = {f.name for f in fields(cls)}
        for key in data:
            if key not in known:
                raise ValueError(f"unknown setting {key!r}; known: {sorted(known)}")
        return build_settings(cls, dict(data), origin or {})

    @classmethod
    def load(cls, path: str | Path | None = None,
             env: Mapping[str, str] | None = None) -> "Settings":
        """Defaults ← file (TOML or JSON; `path` or $RIG_CONFIG) ← $RIG_<FIELD> variables."""
        env = os.environ if env is None else env
        data: dict[str, Any] = {}
        origin: dict[str, str] = {}
        path = path or env.get("RIG_CONFIG")
        if path:
            for key, value in read_config_file(path, section="daq").items():
                data[key], origin[key] = value, f"{path}: {key}"
        known = {f.name for f in fields(cls)}
        for key, value in env.items():
            if not key.startswith(ENV_PREFIX) or key in OTHER_NAMES \
                    or key.startswith(OTHER_PREFIXES):
                continue
            name = key[len(ENV_PREFIX):].lower()
            if name not in known:
                raise ValueError(f"environment variable {key}: unknown DAQ setting {name!r}")
            data[name], origin[name] = value, key
        return cls.from_mapping(data, origin)
