"""The `rig` command line. Each subcommand is a module `commands/cmd_<name>.py` exposing
`add_arguments(parser)` and `run(args) -> int`; this file only registers them, importing each
module when its command runs so `rig --help` stays fast.

It also owns what every command shares: the global options (`--version`, `--debug`,
`--log-level`, `--log-json`, accepted before or after the command name), logging configured
once (core/logging_setup.py), and the error contract — an error is one line on stderr naming
the cause and what to do, with the exit codes of EXIT_CODES; `--debug` adds the stack.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import traceback

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
EXIT_CODES = {
    EXIT_OK: "success",
    EXIT_FAILED: "the command failed (the one-line message on stderr says why)",
    EXIT_USAGE: "usage error: bad option, argument or input refused before any work",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C / SIGINT)",
}
"""The documented exit codes of every `rig` command (README, "Command line")."""

# name -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("commands.cmd_demo", "run the end-to-end demonstration on the embedded defaults"),
    "run": ("commands.cmd_run", "run scheme 1, 2 or 3 against the emulator or the rig into the database"),
    "simulate": ("commands.cmd_simulate", "simulate one scheme on the emulator and write the run file"),
    "params": ("commands.cmd_params", "list the joint parameters and effects with units and sources"),
    "identify": ("commands.cmd_identify", "identify a joint model from run files or stored runs: LS, exact posterior, MH, SGHMC"),
    "emulate": ("commands.cmd_emulate", "run the rig stand-in (PLC on Modbus TCP, drives on CAN) on loopback"),
    "import": ("commands.cmd_import", "import run files (CSV/Parquet + JSON, EMPS .mat) into the database"),
    "export": ("commands.cmd_export", "export a stored run as CSV or Parquet + JSON metadata, or a stored fit as JSON"),
    "runs": ("commands.cmd_runs", "list the stored runs"),
    "show": ("commands.cmd_show", "summarise one run: channels, missing samples, acceptance indicators"),
    "fits": ("commands.cmd_fits", "list the stored identification results (fits) and the runs they used"),
    "db": ("commands.cmd_db", "database schema: `rig db upgrade` migrates to the newest revision"),
    "diagnose": ("commands.cmd_diagnose", "diagnose the sim-to-real gap: where, which unmodelled effect, how far it shrinks"),
    "reproduce": ("commands.cmd_reproduce", "reproduce the paper's tables and figures on the emulator, next to the paper's values"),
    "validate-diagnosis": ("commands.cmd_validate_diagnosis", "score the gap diagnosis on emulator campaigns with withheld effects"),
    "serve": ("commands.cmd_serve", "serve the REST API (runs, jobs, reports) with its job workers"),
    "token": ("commands.cmd_token", "API tokens: `rig token create --role viewer|operator|admin`"),
    "completion": ("commands.cmd_completion", "print a bash or zsh completion script: `source <(rig completion bash)`"),
}

_EPILOG = ("global options may also follow the command name. exit codes: "
           + "; ".join(f"{k} {v}" for k, v in EXIT_CODES.items()) + ".")


def version() -> str:
    """The installed package's version (pyproject.toml)."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as _v
    try:
        return _v("j4-test-platform")
    except PackageNotFoundError:
        return "unknown (not installed)"


def _add_global_options(parser: argparse.ArgumentParser) -> None:
    from core.logging_setup import LEVELS
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    parser.add_argument("--debug", action="store_true",
                        help="on an error, print the full stack after the one-line message")
    parser.add_argument("--log-level", type=str.upper, choices=LEVELS, default=None,
                        help="log level on stderr (default: env RIG_LOG_LEVEL or WARNING); "
                             "protocol frames (pymodbus, python-can) appear only at DEBUG")
    parser.add_argument("--log-json", action="store_true",
                        help="log one JSON object per line (also: env RIG_LOG_FORMAT=json)")


def split_global_options(argv: list[str]) -> tuple[argparse.Namespace, list[str]]:
    """The global options wherever they stand in `argv`, and the rest (the command line the
    command parser sees). Raises SystemExit(2) on a bad global option value."""
    pre = argparse.ArgumentParser(prog="rig", add_help=False, allow_abbrev=False)
    _add_global_options(pre)
    if "--" in argv:
        i = argv.index("--")
        opts, rest = pre.parse_known_args(argv[:i])
        return opts, rest + argv[i:]
    return pre.parse_known_args(argv)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser; only `command`'s module is imported to define its arguments, so one command's
    heavy (or broken) imports never slow or break another."""
    parser = argparse.ArgumentParser(
        prog="rig",
        description="J4 joint test platform: emulate the rig, acquire runs, identify the joint "
                    "model, diagnose the sim-to-real gap. `rig COMMAND --help` explains each.",
        epilog=_EPILOG)
    _add_global_options(parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text, epilog=_EPILOG)
        p.set_defaults(_module=module)
        if name == command:
            importlib.import_module(module).add_arguments(p)
    return parser


def describe_error(exc: BaseException) -> str:
    """One line for an unexpected error: its cause and what to do. Never the stack (that is
    `--debug`'s); secrets in the text (a database URL's password) are masked."""
    from core.redact import redact_secrets
    kind = type(exc)
    module = kind.__module__ or ""
    if isinstance(exc, RecursionError):
        text = ("input nested too deeply to process (metadata or JSON nested beyond Python's "
                "recursion limit); flatten the input and try again")
    elif module.startswith("sqlalchemy"):
        orig = getattr(exc, "orig", None)
        cause = str(orig if orig is not None else exc).strip().splitlines()
        cause_line = cause[0] if cause else kind.__name__
        text = (f"database error: {cause_line}; check RIG_DB_URL, that the database server is "
                f"reachable, and that the schema is current (`rig db upgrade`)")
    elif isinstance(exc, MemoryError):
        text = "out of memory; use a smaller input (fewer samples, a shorter run) or more memory"
    elif isinstance(exc, (FileNotFoundError, PermissionError, IsADirectoryError)):
        name = exc.filename if exc.filename is not None else ""
        text = f"{exc.strerror or kind.__name__}: {name}; check the path and its permissions"
    elif isinstance(exc, OSError):
        text = f"{kind.__name__}: {exc}; check the file, device or network address"
    else:
        msg = " ".join(str(exc).split()) or "(no message)"
        text = f"{kind.__name__}: {msg}; check the input, or rerun with --debug for the stack"
    return redact_secrets(" ".join(text.split()))


def main(argv: list[str] | None = None) -> int:
    """Parse, configure logging, run the command; map every outcome to an exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    opts, rest = split_global_options(argv)
    if opts.version:
        print(f"rig {version()}")
        return EXIT_OK
    command = next((a for a in rest if not a.startswith("-")), None)
    name = command if command in COMMANDS else None
    try:
        from core.logging_setup import configure_logging
        configure_logging(opts.log_level, json_logs=opts.log_json)
        parser = build_parser(name)
        args = parser.parse_args(rest)
        for key in ("debug", "log_level", "log_json"):
            setattr(args, key, getattr(opts, key))
        if not getattr(args, "_module", None):
            parser.print_help()
            return EXIT_USAGE
        mod = importlib.import_module(args._module)
        return int(mod.run(args) or 0)
    except KeyboardInterrupt:
        print("rig: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except SystemExit:
        raise
    except BrokenPipeError:
        # the reader of our stdout went away (`rig runs | head`): nothing left to tell it
        try:
            sys.stdout = open("/dev/null", "w")  # noqa: SIM115 - silence the final flush
        except OSError:
            pass
        return EXIT_FAILED
    except BaseException as exc:  # noqa: BLE001 - the one place that turns any error into one line
        if opts.debug:
            traceback.print_exc(file=sys.stderr)
        prefix = f"rig {name}" if name else "rig"
        print(f"{prefix}: error: {describe_error(exc)}", file=sys.stderr)
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())
