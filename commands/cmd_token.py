"""`rig token create --role ROLE [--name NAME] [--expires-in 7d]`: make an API token and print
it once (with a lifetime, refused with 401 once it has passed); `rig token list`;
`rig token revoke ID`."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    from api.auth import ROLES

    sub = p.add_subparsers(dest="action", required=True)
    c = sub.add_parser("create", help="create a token and print its secret (shown only once)")
    c.add_argument("--role", required=True, choices=ROLES)
    c.add_argument("--name", default="cli", help="a label for the token")
    c.add_argument("--expires-in", metavar="DURATION", default=None,
                   help="lifetime, e.g. 90s, 30m, 12h, 7d, 2w (default: never expires)")
    sub.add_parser("list", help="list tokens (prefixes only)")
    r = sub.add_parser("revoke", help="revoke a token by id")
    r.add_argument("id", type=int)
    for sp in sub.choices.values():
        sp.add_argument("--db", help="database URL (default env RIG_DB_URL)")
        sp.add_argument("--json", action="store_true",
                        help="print JSON (README, \"JSON output\", has the schema)")


def run(args: argparse.Namespace) -> int:
    import json
    import sys

    from db.store import Store
    from db.tokens import create_token, parse_duration, revoke_token

    lifetime = None
    if args.action == "create" and args.expires_in is not None:
        try:
            lifetime = parse_duration(args.expires_in)
        except ValueError as e:
            print(f"rig token create: --expires-in: {e}", file=sys.stderr)
            return 2
    with Store(args.db) as store:
        if args.action == "create":
            secret = create_token(store, args.name, [args.role], expires_in_s=lifetime)
            if args.json:
                print(json.dumps({"token": secret, "name": args.name, "scopes": [args.role],
                                  "expires_in_s": lifetime}))
            else:
                print(secret)
            return 0
        if args.action == "revoke":
            if not revoke_token(store, args.id):
                print(f"no live token {args.id}", file=sys.stderr)
                return 1
            print(json.dumps({"revoked": args.id}) if args.json else f"revoked token {args.id}")
            return 0
        from sqlalchemy import select

        from db.jobs import aware_utc
        from db.models import ApiToken, utcnow
        now = utcnow()
        rows = []
        with store.ReadSession() as s:
            for t in s.execute(select(ApiToken).order_by(ApiToken.id)).scalars():
                expires = aware_utc(t.expires_at)
                state = ("revoked" if t.revoked_at else
                         "expired" if expires is not None and expires <= now else "live")
                rows.append({"id": t.id, "prefix": t.prefix, "name": t.name,
                             "scopes": list(t.scopes), "state": state,
                             "expires_at": expires.isoformat() if expires is not None else None})
                if args.json:
                    continue
                until = f"  expires {expires:%Y-%m-%d %H:%M}Z" if expires is not None else ""
                print(f"{t.id:4d}  {t.prefix}…  {','.join(t.scopes):10s} {state:8s} {t.name}"
                      f"{until}")
        if args.json:
            print(json.dumps(rows))
    return 0
