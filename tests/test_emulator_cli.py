"""`rig simulate` end to end: options become the run's configuration, the files it writes read
back through core.runfile (validated as run-format.md says) with the same data."""

import json
import subprocess
import sys

import numpy as np
import pytest

from commands.cli import main
from core.runfile import read_run
from core.schemes import Scheme1
from simulators.config import EmulatorConfig
from simulators.offline import simulate


def test_simulate_writes_a_valid_run_with_the_requested_configuration(tmp_path, capsys):
    out = tmp_path / "s1.csv"
    rc = main(["simulate", "scheme1", "--speed", "300", "--direction", "-1", "--seed", "5",
               "--effect", "stribeck", "--effect", "gear_ripple:A=800,order=30",
               "--no-hysteresis", "--fail-motor", "2@40", "--sample-rate", "20",
               "--out", str(out)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "wrote" in text and str(out) in text
    run = read_run(out)
    meta = json.loads((tmp_path / "s1.json").read_text())
    assert meta["scheme"] == 1 and meta["motor_speed_rpm"] == 300 and meta["direction"] == -1
    assert meta["sample_rate_hz"] == 20 and meta["source"] == "emulator"
    emu = meta["emulator"]
    assert emu["seed"] == 5 and emu["hysteresis"] is False
    assert emu["effects"]["gear_ripple"] == {"A": 800.0, "order": 30.0, "phase": 0.0}
    assert emu["effects"]["stribeck"] == {"f_s": 1500.0, "v_s": 0.006, "delta": 2.0}
    assert emu["failed_motors"] == {"2": 40.0}
    # the same configuration through the Python API gives the same samples
    cfg = EmulatorConfig(seed=5, hysteresis=False, sample_rate_hz=20.0, failed_motors={2: 40.0},
                         effects={"stribeck": {}, "gear_ripple": {"A": 800, "order": 30}})
    direct = simulate(Scheme1(motor_speed_rpm=300, direction=-1), cfg)
    for col in direct.samples.columns:
        if col == "phase":
            assert list(run.samples[col]) == list(direct.samples[col])
        else:
            np.testing.assert_array_equal(run.channel(col), direct.channel(col))
    assert np.nanmean(run.channel("qd")) < 0                    # direction −1


def test_simulate_scheme3_parquet_and_bad_options(tmp_path, capsys):
    out = tmp_path / "s3.parquet"
    assert main(["simulate", "scheme3", "--sample-rate", "50", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "excitation: cond" in text
    run = read_run(out)
    assert run.meta["scheme"] == 3 and run.meta["motor_speed_rpm"] is None
    assert run.meta["excitation"]["cond"] < run.meta["excitation"]["random_cond_median"]
    assert set(run.samples["phase"]) == {"idle", "excite"}
    with pytest.raises(SystemExit) as refused:        # a usage error: exit 2, said on stderr
        main(["simulate", "scheme2", "--effect", "cogging", "--out", str(tmp_path / "x.csv")])
    assert refused.value.code == 2
    assert "unknown effect" in capsys.readouterr().err
    assert main(["simulate", "scheme2", "--param", "nope=1", "--out",
                 str(tmp_path / "x.csv")]) == 2
    with pytest.raises(SystemExit):
        main(["simulate", "scheme1", "--effect", "stribeck:f_s"])


def test_rig_simulate_console_command(tmp_path):
    out = tmp_path / "run.csv"
    proc = subprocess.run([sys.executable, "-m", "commands.cli", "simulate", "2", "--speed", "3000",
                           "--param", "k=2e7", "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    run = read_run(out)
    assert run.meta["emulator"]["params"] == {"k": 2e7}
    assert run.samples["torque"].max() > 115e3
