"""`rig token create --role ROLE [--name NAME]`: make an API token and print it once;
`rig token list`; `rig token revoke ID`."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    from api.auth import ROLES

    sub = p.add_subparsers(dest="action", required=True)
    c = sub.add_parser("create", help="create a token and print its secret (shown only once)")
    c.add_argument("--role", required=True, choices=ROLES)
    c.add_argument("--name", default="cli", help="a label for the token")
    sub.add_parser("list", help="list tokens (prefixes only)")
    r = sub.add_parser("revoke", help="revoke a token by id")
    r.add_argument("id", type=int)
    for sp in sub.choices.values():
        sp.add_argument("--db", help="database URL (default env RIG_DB_URL)")


def run(args: argparse.Namespace) -> int:
    import sys

    from db.store import Store
    from db.tokens import create_token, revoke_token

    with Store(args.db) as store:
        if args.action == "create":
            print(create_token(store, args.name, [args.role]))
            return 0
        if args.action == "revoke":
            if not revoke_token(store, args.id):
                print(f"no live token {args.id}", file=sys.stderr)
                return 1
            print(f"revoked token {args.id}")
            return 0
        from sqlalchemy import select

        from db.models import ApiToken
        with store.ReadSession() as s:
            for t in s.execute(select(ApiToken).order_by(ApiToken.id)).scalars():
                state = "revoked" if t.revoked_at else "live"
                print(f"{t.id:4d}  {t.prefix}…  {','.join(t.scopes):10s} {state:8s} {t.name}")
    return 0
