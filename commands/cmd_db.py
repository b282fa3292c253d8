"""`rig db upgrade`: migrate the database named by --db / $RIG_DB_URL to the newest schema;
`rig db current`: print the revision it is at."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="db_command", metavar="SUBCOMMAND", required=True)
    for name, text in (("upgrade", "migrate the database to the newest schema revision"),
                       ("current", "print the database's schema revision")):
        p = sub.add_parser(name, help=text, description=text)
        p.add_argument("--db", metavar="URL",
                       help="database URL (default: $RIG_DB_URL or ./rig-data/rig.sqlite)")
        p.add_argument("--json", action="store_true",
                       help="print JSON {url, revision, head} (password masked)")


def run(args: argparse.Namespace) -> int:
    from core.redact import redact_secrets
    from db.engine import database_url
    from db.migrate import current, head_revision, upgrade

    url = database_url(args.db)
    shown = redact_secrets(url)
    rev = upgrade(url) if args.db_command == "upgrade" else current(url)
    if args.json:
        import json
        print(json.dumps({"url": shown, "revision": rev, "head": head_revision()}))
    elif args.db_command == "upgrade":
        print(f"{shown}: at revision {rev} (head {head_revision()})")
    else:
        print(f"{shown}: at revision {rev or '(none: run `rig db upgrade`)'}")
    return 0
