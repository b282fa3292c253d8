"""The `rig` command line: every registered command has working --help, and `rig params` prints
every joint parameter and every effect of the vocabulary (docs cannot drift from the code)."""

import json
import subprocess
import sys

import pytest

from commands.cli import COMMANDS, main
from core.effects import EFFECT_NAMES
from core.params import JointParams


def test_top_level_help_lists_every_command(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert name in out


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_each_command_has_help(name, capsys):
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip()


def test_params_json_covers_parameters_and_effects(capsys):
    assert main(["params", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {p["name"] for p in data["params"]} == {p["name"] for p in JointParams.describe()}
    assert [e["name"] for e in data["effects"]] == list(EFFECT_NAMES)
    for p in data["params"]:
        assert p["unit"] and p["source"] and p["doc"]


def test_console_script_runs():
    out = subprocess.run([sys.executable, "-m", "commands.cli", "params"], capture_output=True,
                         text=True, check=True).stdout
    assert "I_xx" in out and "gear_ripple" in out
