"""The `rig` error contract (README, "Command line"): an error is ONE line on stderr naming the
cause and what to do, exit codes 0 ok / 1 failed / 2 usage / 130 interrupted, `--debug` adds
the stack; global options work before or after the command; `rig --version`; the bash
completion script generated from the parser completes commands, options and choices."""

import shutil
import subprocess
import sys

import pytest

import commands.cmd_params as cmd_params
from commands.cli import EXIT_CODES, main


def _one_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def test_exit_codes_documented_in_readme():
    readme = open("README.md", encoding="utf-8").read()
    assert set(EXIT_CODES) == {0, 1, 2, 130}
    for code in EXIT_CODES:
        assert f"| {code} |" in readme


def test_version(capsys):
    assert main(["--version"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("rig ") and out.split()[1][0].isdigit()


def test_unknown_command_and_bad_option_are_usage_errors(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["no-such-command"])
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        main(["--log-level", "chatty", "params"])
    assert exc.value.code == 2


def test_unreachable_database_is_one_line_with_secret_masked(monkeypatch, capsys):
    monkeypatch.setenv("RIG_DB_URL", "postgresql+psycopg://rig:s3cret@127.0.0.1:1/rig")
    assert main(["runs"]) == 1
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("rig runs: error: database error:")
    assert "RIG_DB_URL" in line and "s3cret" not in line


@pytest.mark.parametrize("exc, words", [
    (RecursionError("maximum recursion depth exceeded"), "nested too deeply"),
    (FileNotFoundError(2, "No such file or directory", "/nowhere/run.mat"), "/nowhere/run.mat"),
    (ValueError("Mat file appears to be truncated\nmore detail"), "Mat file appears to be truncated more"),
])
def test_unexpected_errors_are_one_line_and_debug_shows_the_stack(monkeypatch, capsys, exc, words):
    def boom(args):
        raise exc
    monkeypatch.setattr(cmd_params, "run", boom)
    assert main(["params"]) == 1
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("rig params: error:") and words in line
    assert main(["params", "--debug"]) == 1     # global option after the command
    err = capsys.readouterr().err
    assert "Traceback" in err and "boom" in err and err.rstrip().splitlines()[-1].startswith("rig params: error:")


def test_interrupt_exits_130(monkeypatch, capsys):
    def interrupted(args):
        raise KeyboardInterrupt
    monkeypatch.setattr(cmd_params, "run", interrupted)
    assert main(["params"]) == 130
    assert _one_line(capsys.readouterr().err) == "rig: interrupted"


def test_console_script_error_exit_code(tmp_path):
    env = {"PATH": "/usr/bin:/bin", "RIG_DB_URL": "postgresql+psycopg://u@127.0.0.1:1/x"}
    p = subprocess.run([sys.executable, "-m", "commands.cli", "show", "1"], capture_output=True,
                       text=True, env=env)
    assert p.returncode == 1
    _one_line(p.stderr)


@pytest.mark.skipif(shutil.which("bash") is None, reason="bash not installed")
def test_bash_completion_completes_commands_options_and_choices(capsys):
    assert main(["completion", "bash"]) == 0
    script = capsys.readouterr().out

    def complete(*words: str) -> list[str]:
        arr = " ".join(f"'{w}'" for w in ("rig",) + words)
        prog = (script + f"\nCOMP_WORDS=({arr}); COMP_CWORD={len(words)}; _rig_complete; "
                "printf '%s\\n' \"${COMPREPLY[@]}\"\n")
        out = subprocess.run(["bash", "--norc", "-c", prog], capture_output=True, text=True,
                             check=True).stdout
        return out.split()

    assert complete("to") == ["token"]
    assert "validate-diagnosis" in complete("va")
    assert set(complete("token", "")) >= {"create", "list"}
    assert "--source" in complete("run", "--sou")
    assert complete("run", "--source", "") == ["emulator", "rig"]
    assert "--log-level" in complete("--lo")
    assert complete("export", "--format", "p") == ["parquet"]


def test_zsh_completion_script_loads_through_bashcompinit(capsys):
    assert main(["completion", "zsh"]) == 0
    out = capsys.readouterr().out
    assert "bashcompinit" in out and "complete -o filenames -F _rig_complete rig" in out
