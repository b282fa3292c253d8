"""The DAQ settings object (daq/settings.py): defaults, file, environment, validation."""

import json
from dataclasses import fields

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


# --- every setting has a type, a unit and a range; bad values stop start-up by name ----------

FLOAT_FIELDS = [f.name for f in fields(Settings) if f.type == "float"]


def test_every_setting_has_a_unit_and_every_number_a_range():
    for name, info in Settings.__pydantic_fields__.items():
        assert info.json_schema_extra and info.json_schema_extra.get("unit"), name
        assert info.description, name
        if info.annotation in (int, float):
            bounds = {attr for m in info.metadata for attr in ("ge", "gt", "le", "lt")
                      if getattr(m, attr, None) is not None}
            assert bounds & {"ge", "gt"} and bounds & {"le", "lt"}, (name, bounds)


@pytest.mark.parametrize("name", FLOAT_FIELDS)
@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "NaN", "Infinity"])
def test_nan_and_inf_stop_start_up_naming_the_variable(name, value):
    var = f"RIG_{name.upper()}"
    with pytest.raises(ValueError, match=var):
        Settings.load(env={var: value})
    with pytest.raises(ValueError, match=name):
        Settings(**{name: float(value)})


@pytest.mark.parametrize("var,value", [
    ("RIG_TORQUE_LIMIT", "nan"),                 # would switch the torque trip off
    ("RIG_DRIVE_HEARTBEAT_TIMEOUT", "nan"),      # would switch the drive watchdog off
    ("RIG_PLC_LINK_TIMEOUT", "inf"),             # would switch the PLC link watchdog off
    ("RIG_PLC_LINK_TIMEOUT", "0"), ("RIG_PLC_LINK_TIMEOUT", "-1"), ("RIG_SDO_TIMEOUT", "0"),
    ("RIG_TORQUE_LIMIT", "1e9"), ("RIG_TORQUE_LIMIT", "-5"), ("RIG_PRESSURE_LIMIT", "3e7"),
    ("RIG_MOTOR_TEMP_LIMIT", "400"), ("RIG_HEARTBEAT_PERIOD", "2"), ("RIG_PLC_PORT", "70000"),
    ("RIG_PLC_HOST", ""), ("RIG_TORQUE_LIMIT", ""), ("RIG_NODE_IDS", "1,200"),
    ("RIG_PLC_POLL_HZ", "0"), ("RIG_CAN_BITRATE", "1.5"),
])
def test_out_of_range_or_empty_values_stop_start_up_naming_the_variable(var, value):
    with pytest.raises(ValueError, match=var) as e:
        Settings.load(env={var: value})
    assert str(e.value).count("\n") == 0            # one line


def test_a_bad_value_in_the_file_names_the_file_and_key(tmp_path):
    toml = tmp_path / "rig.toml"
    toml.write_text("[daq]\ntorque_limit = nan\n")      # TOML has nan and inf literals
    with pytest.raises(ValueError, match=r"rig\.toml: torque_limit.*finite"):
        Settings.load(toml, env={})
    js = tmp_path / "rig.json"
    js.write_text('{"plc_link_timeout": Infinity}')     # Python's json reads it
    with pytest.raises(ValueError, match="plc_link_timeout"):
        Settings.load(js, env={})


def test_limits_in_range_are_taken(tmp_path):
    s = Settings.load(env={"RIG_TORQUE_LIMIT": "180e3", "RIG_PLC_LINK_TIMEOUT": "2",
                           "RIG_SAFE_PRESSURE": "1e6", "RIG_NODE_IDS": "3;4;5"})
    assert (s.torque_limit, s.plc_link_timeout, s.safe_pressure, s.node_ids) == \
        (180e3, 2.0, 1e6, (3, 4, 5))
    assert Settings.load(env={"RIG_NODE_IDS": ""}).node_ids == ()


def test_rig_run_stops_with_one_line_naming_the_variable(monkeypatch, capsys, tmp_path):
    import argparse

    from commands import cmd_run

    monkeypatch.delenv("RIG_CONFIG", raising=False)
    monkeypatch.setenv("RIG_TORQUE_LIMIT", "nan")
    p = argparse.ArgumentParser()
    cmd_run.add_arguments(p)
    args = p.parse_args(["scheme1", "--db", f"sqlite:///{tmp_path / 'x.sqlite'}"])
    assert cmd_run.run(args) == 2
    err = capsys.readouterr().err.strip()
    assert "RIG_TORQUE_LIMIT" in err and "finite" in err and "\n" not in err
    assert not (tmp_path / "x.sqlite").exists()
