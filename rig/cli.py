"""The `rig` command line. Each subcommand lives in the module that owns the work and exposes
`add_arguments(parser)` and `run(args) -> int`; this file only registers them, importing each
module when its command runs so `rig --help` stays fast."""

from __future__ import annotations

import argparse
import importlib
import sys

# name -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("rig.demo", "run the end-to-end demonstration on the embedded defaults"),
    "run": ("daq.cmd_run", "run scheme 1, 2 or 3 against the emulator or the rig into the database"),
    "simulate": ("simulators.cli", "simulate one scheme on the emulator and write the run file"),
    "params": ("rig.params_cli", "list the joint parameters and effects with units and sources"),
    "identify": ("estimator.cli", "identify a joint model from run files: LS, exact posterior, MH, SGHMC"),
    "emulate": ("simulators.standin", "run the rig stand-in (PLC on Modbus TCP, drives on CAN) on loopback"),
    "import": ("db.cmd_import", "import run files (CSV/Parquet + JSON, EMPS .mat) into the database"),
    "export": ("db.cmd_export", "export a stored run as CSV or Parquet + JSON metadata"),
    "runs": ("db.cmd_runs", "list the stored runs"),
    "show": ("db.cmd_show", "summarise one run: channels, missing samples, acceptance indicators"),
    "db": ("db.cmd_db", "database schema: `rig db upgrade` migrates to the newest revision"),
    "diagnose": ("estimator.diagnose_cli", "diagnose the sim-to-real gap: where, which unmodelled effect, how far it shrinks"),
    "validate-diagnosis": ("simulators.validate_diagnosis", "score the gap diagnosis on emulator campaigns with withheld effects"),
    "serve": ("api.cmd_serve", "serve the REST API (runs, jobs, reports) with its job workers"),
    "token": ("api.cmd_token", "API tokens: `rig token create --role viewer|operator|admin`"),
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
