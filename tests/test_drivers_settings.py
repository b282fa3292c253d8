"""The DAQ settings object (daq/settings.py): defaults, file, environment, validation."""

import json

import pytest

from core.config_file import read_config_file
from daq.settings import Settings


def test_defaults_are_loopback_and_bounded():
    s = Settings()
    assert s.plc_host == "127.0.0.1" and s.can_host == "127.0.0.1"
    assert s.can_interface == "socketcand" and s.node_ids == (1, 2, 3)
    assert 0.5 <= s.plc_timeout <= 1.0 and s.plc_retries in (0, 1)
    assert 1.0 <= s.plc_reconnect_delay_max <= 5.0
    assert s.torque_limit == pytest.approx(126e3)
    assert s.shear_limit + s.shear_tolerance == pytest.approx(92e3)


def test_file_then_environment(tmp_path):
    toml = tmp_path / "rig.toml"
    toml.write_text('[daq]\nplc_port = 6000\nnode_ids = [4, 5, 6]\ncan_interface = "virtual"\n'
                    '[emulate]\nplc_port = 6000\n')
    s = Settings.load(toml, env={})
    assert (s.plc_port, s.node_ids, s.can_interface) == (6000, (4, 5, 6), "virtual")
    s = Settings.load(toml, env={"RIG_PLC_PORT": "7000", "RIG_NODE_IDS": "1,2,3",
                                 "RIG_TORQUE_LIMIT": "1e5"})
    assert (s.plc_port, s.node_ids, s.torque_limit) == (7000, (1, 2, 3), 1e5)
    js = tmp_path / "rig.json"
    js.write_text(json.dumps({"plc_host": "10.0.0.5", "node_ids": []}))
    s = Settings.load(env={"RIG_CONFIG": str(js)})
    assert s.plc_host == "10.0.0.5" and s.node_ids == ()
    assert read_config_file(toml, "emulate") == {"plc_port": 6000}


@pytest.mark.parametrize("bad", [
    {"plc_timeout": 3.0}, {"plc_timeout": 0.1}, {"plc_retries": 3}, {"plc_reconnect_delay_max": 300.0},
    {"can_interface": "pcan"}, {"node_ids": (1, 1, 2)}, {"tpdo_rate_hz": 2000.0},
    {"drive_heartbeat_timeout": 0.05}, {"plc_word_order": "middle"},
])
def test_dangerous_values_are_refused(bad):
    with pytest.raises(ValueError):
        Settings(**bad)


def test_unknown_keys_are_refused_by_name(tmp_path):
    with pytest.raises(ValueError, match="plc_prot"):
        Settings.from_mapping({"plc_prot": 1})
    with pytest.raises(ValueError, match="RIG_NOPE"):
        Settings.load(env={"RIG_NOPE": "1"})
    with pytest.raises(ValueError, match="plc_port"):
        Settings.from_mapping({"plc_port": "abc"})
    bad = tmp_path / "bad.toml"
    bad.write_text("plc_port = ")
    with pytest.raises(ValueError, match="TOML"):
        Settings.load(bad, env={})
