"""The `rig` command line. Each subcommand is a module `commands/cmd_<name>.py` exposing
`add_arguments(parser)` and `run(args) -> int`; this file only registers them, importing each
module when its command runs so `rig --help` stays fast."""

from __future__ import annotations

import argparse
import importlib
import sys

# name -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("commands.cmd_demo", "run the end-to-end demonstration on the embedded defaults"),
    "run": ("commands.cmd_run", "run scheme 1, 2 or 3 against the emulator or the rig into the database"),
    "simulate": ("commands.cmd_simulate", "simulate one scheme on the emulator and write the run file"),
    "params": ("commands.cmd_params", "list the joint parameters and effects with units and sources"),
    "identify": ("commands.cmd_identify", "identify a joint model from run files: LS, exact posterior, MH, SGHMC"),
    "emulate": ("commands.cmd_emulate", "run the rig stand-in (PLC on Modbus TCP, drives on CAN) on loopback"),
    "import": ("commands.cmd_import", "import run files (CSV/Parquet + JSON, EMPS .mat) into the database"),
    "export": ("commands.cmd_export", "export a stored run as CSV or Parquet + JSON metadata"),
    "runs": ("commands.cmd_runs", "list the stored runs"),
    "show": ("commands.cmd_show", "summarise one run: channels, missing samples, acceptance indicators"),
    "db": ("commands.cmd_db", "database schema: `rig db upgrade` migrates to the newest revision"),
    "diagnose": ("commands.cmd_diagnose", "diagnose the sim-to-real gap: where, which unmodelled effect, how far it shrinks"),
    "validate-diagnosis": ("commands.cmd_validate_diagnosis", "score the gap diagnosis on emulator campaigns with withheld effects"),
    "serve": ("commands.cmd_serve", "serve the REST API (runs, jobs, reports) with its job workers"),
    "token": ("commands.cmd_token", "API tokens: `rig token create --role viewer|operator|admin`"),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser; only `command`'s module is imported to define its arguments, so one command's
    heavy (or broken) imports never slow or break another."""
    parser = argparse.ArgumentParser(
        prog="rig",
        description="J4 joint test platform: emulate the rig, acquire runs, identify the joint "
                    "model, diagnose the sim-to-real gap. `rig COMMAND --help` explains each.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(_module=module)
        if name == command:
            importlib.import_module(module).add_arguments(p)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(command if command in COMMANDS else None)
    args = parser.parse_args(argv)
    if not getattr(args, "_module", None):
        parser.print_help()
        return 2
    mod = importlib.import_module(args._module)
    try:
        return int(mod.run(args) or 0)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
