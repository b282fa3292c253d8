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


def run(args: argparse.Namespace) -> int:
    from sqlalchemy.engine import make_url

    from db.engine import database_url
    from db.migrate import current, head_revision, upgrade

    url = database_url(args.db)
    shown = make_url(url).render_as_string(hide_password=True)
    if args.db_command == "upgrade":
        rev = upgrade(url)
        print(f"{shown}: at revision {rev} (head {head_revision()})")
    else:
        print(f"{shown}: at revision {current(url) or '(none: run `rig db upgrade`)'}")
    return 0
