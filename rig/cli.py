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
    "simulate": ("simulators.cli", "simulate one scheme on the emulator and write the run file"),
    "params": ("rig.params_cli", "list the joint parameters and effects with units and sources"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rig",
        description="J4 joint test platform: emulate the rig, acquire runs, identify the joint "
                    "model, diagnose the sim-to-real gap. `rig COMMAND --help` explains each.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(_module=module)
        _lazy_arguments(module, p)
    return parser


def _lazy_arguments(module: str, parser: argparse.ArgumentParser) -> None:
    # Arguments are defined by the owning module; importing it here keeps one definition.
    mod = importlib.import_module(module)
    mod.add_arguments(parser)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
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
