"""`rig emulate` as a user runs it: options and config file, where it listens, clean stop."""

import argparse
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from drivers_harness import REPO, StandinProcess, free_port
from commands.cli import COMMANDS
from simulators.standin import add_arguments, emulator_config, options_from_args


def parse(*argv):
    p = argparse.ArgumentParser()
    add_arguments(p)
    return options_from_args(p.parse_args(list(argv)))


def test_options_and_config_file(tmp_path):
    cfg = tmp_path / "rig.toml"
    cfg.write_text('[emulate]\nplc_port = 6100\ntime_scale = 2.0\nnode_ids = [5, 6, 7]\n'
                   '[emulate.emulator]\nseed = 4\nfailed_motors = [3]\n'
                   '[emulate.emulator.effects.stribeck]\nf_s = 900.0\n')
    o = parse("--config", str(cfg), "--can-port", "6200", "--effect", "torque_offset:c0=500",
              "--param", "arm_bend=3.0", "--temp-motor", "20,30,40")
    assert (o.plc_port, o.can_port, o.time_scale, o.node_ids) == (6100, 6200, 2.0, (5, 6, 7))
    assert o.emulator["effects"] == {"stribeck": {"f_s": 900.0}, "torque_offset": {"c0": 500.0}}
    ec = emulator_config(o.emulator)
    assert ec.seed == 4 and ec.failed_motors == {2: 0.0}          # motor 3 = index 2
    assert ec.params.arm_bend == 3.0 and ec.temp_motor_init == (20.0, 30.0, 40.0)
    assert ec.effects["torque_offset"]["c0"] == 500.0 and ec.effects["stribeck"]["f_s"] == 900.0
    assert parse("--no-can").can is False
    with pytest.raises(ValueError):
        parse("--no-can", "--no-plc")
    with pytest.raises(ValueError):
        parse("--node-ids", "1,2")
    bad = tmp_path / "bad.toml"
    bad.write_text("[emulate]\nplc_prot = 1\n")
    with pytest.raises(ValueError, match="plc_prot"):
        parse("--config", str(bad))


def test_registered_in_the_rig_cli():
    assert COMMANDS["emulate"][0] == "commands.cmd_emulate"


def test_prints_where_it_listens_and_stops_cleanly_on_ctrl_c(tmp_path):
    plc, can = free_port(), free_port()
    cfg = tmp_path / "rig.toml"
    cfg.write_text(f"[emulate]\nplc_port = {plc}\ncan_port = {can}\n"
                   f"[emulate.emulator.effects.stribeck]\nf_s = 1200.0\n")
    proc = subprocess.Popen([sys.executable, "-m", "simulators.standin", "--config", str(cfg)],
                            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = []
    try:
        for line in proc.stdout:
            lines.append(line)
            if "time scale" in line:
                break
        text = "".join(lines)
        assert f"127.0.0.1:{plc}" in text and f"127.0.0.1:{can}" in text, text
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, out
    assert "stopped after" in out


def test_sigterm_and_bad_options():
    sp = StandinProcess([])
    assert sp.stop() == 0
    assert any("stopped after" in ln for ln in sp.lines)
    r = subprocess.run([sys.executable, "-m", "simulators.standin", "--plc-port", "0",
                        "--can-port", "0", "--effect", "no_such_effect"],
                       cwd=REPO, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "no_such_effect" in r.stderr


def test_port_in_use_is_reported():
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen(1)
        port = s.getsockname()[1]
        r = subprocess.run([sys.executable, "-m", "simulators.standin", "--no-can",
                            "--plc-port", str(port)], cwd=REPO, capture_output=True, text=True,
                           timeout=60)
    assert r.returncode == 1 and "rig emulate:" in r.stderr


def test_rig_emulate_help_through_the_console_script():
    rig = Path(sys.executable).with_name("rig")
    r = subprocess.run([str(rig), "emulate", "--help"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "--time-scale" in r.stdout and "--effect" in r.stdout
