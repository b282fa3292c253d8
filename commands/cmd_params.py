"""`rig params`: print every joint parameter and every effect of the vocabulary with its unit,
default and source, so the documentation and the code cannot disagree."""

from __future__ import annotations

import argparse
import json

from core.effects import VOCABULARY
from core.params import JointParams


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")


def run(args: argparse.Namespace) -> int:
    params = JointParams.describe()
    effects = [{"name": e.name, "what": e.what, "where": e.where, "acts_on": e.acts_on,
                "magnitude": e.magnitude,
                "params": [vars(p) for p in e.params]} for e in VOCABULARY.values()]
    if args.json:
        print(json.dumps({"params": params, "effects": effects}, indent=2, ensure_ascii=False))
        return 0
    print(f"{'parameter':<18}{'default':>14}  {'unit':<12}{'source':<16}meaning")
    for p in params:
        print(f"{p['name']:<18}{p['default']:>14.6g}  {p['unit']:<12}{p['source']:<16}{p['doc']}")
    print("\neffects (inject with --effect NAME[:param=value,...]):")
    for e in effects:
        ps = ", ".join(f"{p['name']}={p['default']:g} {p['unit']}" for p in e["params"])
        print(f"  {e['name']:<25}{e['what']} — shows in: {e['where']}  [{ps}]")
    return 0
