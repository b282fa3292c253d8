"""One settings object for the DAQ side: where the PLC and the CAN bus are, how hard to try,
which drives, and the interlock limits. The same object points the service at the emulator
(loopback, the defaults) or at the real rig — only settings say which.

Sources, later wins: the defaults below → a TOML or JSON file (`Settings.load(path)` or the
path in $RIG_CONFIG) → environment variables `RIG_<FIELD>` (e.g. RIG_PLC_PORT=5020,
RIG_NODE_IDS=1,2,3, RIG_CAN_INTERFACE=virtual).

Units: seconds, Hz, N·m, N, Pa, °C.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any, Mapping

from core.config_file import read_config_file
from core.params import RATED_TORQUE

CAN_INTERFACES = ("socketcand", "virtual", "socketcan", "udp_multicast")
"""python-can interfaces the DAQ accepts. udp_multicast is always opened with hop_limit=0
(daq/drives.py), so its frames never leave this machine."""
SOCKETCAND_PORT = 29536
"""socketcand's default TCP port."""
OTHER_ENV = frozenset({
    "RIG_CONFIG", "RIG_DB_URL", "RIG_TEST_PG_URL", "RIG_TEST_ARTIFACTS", "RIG_API_HOST",
    "RIG_API_PORT", "RIG_WORKERS", "RIG_MAX_BODY_BYTES", "RIG_JOB_HEARTBEAT_S",
    "RIG_JOB_STALE_S", "RIG_JOB_MAX_ATTEMPTS", "RIG_DASK_SCHEDULER", "RIG_API_CACHE_MB"})
"""RIG_* variables owned by other parts of the service (database, API, tests): not DAQ
settings, so `load` neither reads nor refuses them."""


@dataclass(frozen=True)
class Settings:
    """DAQ-side settings; see the module docstring for how they are loaded."""

    # --- PLC (S7-1500 MB_SERVER over Modbus TCP) ----------------------------------------
    plc_host: str = "127.0.0.1"
    plc_port: int = 5020
    plc_device_id: int = 1
    plc_timeout: float = 0.5
    """Per-request timeout [s]; bounded to 0.5–1 s (pymodbus' 3 s default × retries blocks
    a request racing a dropped connection for 12 s)."""
    plc_retries: int = 0
    """Retries per request, 0–1."""
    plc_reconnect_delay: float = 0.1
    """First reconnect back-off [s]; doubles up to plc_reconnect_delay_max."""
    plc_reconnect_delay_max: float = 1.0
    """Longest reconnect back-off [s], 1–5 (pymodbus' default grows to 300 s)."""
    plc_poll_hz: float = 100.0
    """Status-block poll rate [Hz] (plan 2–10 Hz on the real S7: 100–500 ms per block poll)."""
    plc_word_order: str = "big"
    """Word order of the PLC's 32-bit values: 'big' (S7, high word first) or 'little'."""
    heartbeat_period: float = 0.1
    """Service heartbeat write period [s]; the PLC watchdog trips after ~0.5 s of silence."""
    plc_link_timeout: float = 0.5
    """No successful status poll for this long [s] = PLC link lost → make the rig safe."""

    # --- drives (S120 via CBC10, CANopen CiA 402) ------------------------------------------
    can_interface: str = "socketcand"
    """python-can interface: 'socketcand' (loopback server of `rig emulate`, or a socketcand
    gateway beside a real CAN card), 'virtual' (in-process tests), 'socketcan' (real rig)."""
    can_channel: str = "can0"
    can_host: str = "127.0.0.1"
    """socketcand server host."""
    can_port: int = SOCKETCAND_PORT
    """socketcand server port."""
    can_bitrate: int = 1_000_000
    node_ids: tuple[int, ...] = (1, 2, 3)
    """CANopen node ids of the drives, motor 1 first. Empty = no drives (PLC only)."""
    drive_heartbeat_ms: int = 100
    """Heartbeat producer time the master configures on each drive (0x1017) [ms]."""
    drive_heartbeat_timeout: float = 0.5
    """No heartbeat for this long [s] = drive lost (dropped; a second loss makes the rig safe).
    Five producer periods: a loaded host may delay a heartbeat by a few hundred ms."""
    tpdo_rate_hz: float = 1000.0
    """Rate of the drives' fast TPDO (speed, current, sample counter) [Hz], ≤ 1000."""
    status_tpdo_rate_hz: float = 10.0
    """Rate of the drives' status TPDO (statusword, torque, temperature) [Hz]; it is also
    sent at once when the statusword changes."""
    sdo_timeout: float = 0.5
    """SDO response timeout [s]."""
    drive_enable_timeout: float = 3.0
    """Longest wait for a drive to reach a CiA 402 state [s]."""

    # --- interlocks ----------------------------------------------------------------------
    torque_limit: float = 1.05 * RATED_TORQUE
    """|joint torque| trip [N·m] (105 % of the rated 120 kN·m)."""
    bend_limit: float = 250e3
    """|bending moment| trip [N·m] (Table 11 range 0–250 kN·m)."""
    shear_limit: float = 90e3
    """Nominal shear load [N] (Table 11); trips above shear_limit + shear_tolerance."""
    shear_tolerance: float = 2e3
    """Shear loading tolerance [N] (Table 11: ±2 kN)."""
    pressure_limit: float = 24e6
    """Hydraulic pressure trip [Pa] (below the 25 MPa relief of the pump)."""
    motor_temp_limit: float = 120.0
    """Motor winding over-temperature trip [°C]."""
    safe_pressure: float = 0.0
    """Hydraulic pressure set point when the rig is made safe [Pa]."""

    def __post_init__(self) -> None:
        if not 0.5 <= self.plc_timeout <= 1.0:
            raise ValueError(f"plc_timeout {self.plc_timeout} s outside 0.5–1 s")
        if self.plc_retries not in (0, 1):
            raise ValueError(f"plc_retries {self.plc_retries} must be 0 or 1")
        if not 0.01 <= self.plc_reconnect_delay <= self.plc_reconnect_delay_max:
            raise ValueError("plc_reconnect_delay must be ≥ 0.01 s and ≤ plc_reconnect_delay_max")
        if not 1.0 <= self.plc_reconnect_delay_max <= 5.0:
            raise ValueError(f"plc_reconnect_delay_max {self.plc_reconnect_delay_max} s "
                             "outside 1–5 s")
        if self.plc_word_order not in ("big", "little"):
            raise ValueError("plc_word_order must be 'big' or 'little'")
        if self.can_interface not in CAN_INTERFACES:
            raise ValueError(f"can_interface {self.can_interface!r} not in {CAN_INTERFACES}")
        if not 0 < self.tpdo_rate_hz <= 1000.0 or not 0 < self.status_tpdo_rate_hz <= 1000.0:
            raise ValueError("TPDO rates must be in (0, 1000] Hz")
        if len(set(self.node_ids)) != len(self.node_ids) or any(
                not 1 <= n <= 127 for n in self.node_ids):
            raise ValueError(f"node_ids {self.node_ids} must be distinct CANopen ids 1–127")
        if self.drive_heartbeat_timeout <= self.drive_heartbeat_ms / 1000.0:
            raise ValueError("drive_heartbeat_timeout must exceed the heartbeat period")
        if self.plc_poll_hz <= 0 or self.heartbeat_period <= 0:
            raise ValueError("plc_poll_hz and heartbeat_period must be positive")

    # --- loading -------------------------------------------------------------------------

    def replace(self, **changes: Any) -> "Settings":
        return replace(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["node_ids"] = list(self.node_ids)
        return d

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> "Settings":
        """Settings from a {field: value} mapping; unknown keys are refused by name."""
        known = {f.name: f for f in fields(cls)}
        kwargs = {}
        for key, value in data.items():
            if key not in known:
                raise ValueError(f"unknown setting {key!r}; known: {sorted(known)}")
            kwargs[key] = _coerce(key, known[key].type, value)
        return cls(**kwargs)

    @classmethod
    def load(cls, path: str | Path | None = None,
             env: Mapping[str, str] | None = None) -> "Settings":
        """Defaults ← file (TOML or JSON; `path` or $RIG_CONFIG) ← $RIG_<FIELD> variables."""
        env = os.environ if env is None else env
        data: dict[str, Any] = {}
        path = path or env.get("RIG_CONFIG")
        if path:
            data.update(read_config_file(path, section="daq"))
        known = {f.name for f in fields(cls)}
        for key, value in env.items():
            if key.startswith("RIG_") and key not in OTHER_ENV:
                name = key[4:].lower()
                if name not in known:
                    raise ValueError(f"environment variable {key}: unknown setting {name!r}")
                data[name] = value
        return cls.from_mapping(data)


def _coerce(name: str, type_name: Any, value: Any) -> Any:
    t = str(type_name)
    try:
        if t.startswith("tuple"):
            if isinstance(value, str):
                value = [v for v in value.replace(";", ",").split(",") if v.strip()]
            return tuple(int(v) for v in value)
        if t == "int":
            if isinstance(value, float) and not value.is_integer():
                raise ValueError("not an integer")
            return int(value)
        if t == "float":
            return float(value)
        return str(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"setting {name!r}: cannot use {value!r} as {t}: {exc}") from None
