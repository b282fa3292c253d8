"""The layers of docs/architecture.md, checked on the code: every import of one of our packages
(at module level or inside a function) must point to the same package or to one the importer's
layer may use. Fails naming the file, the line and the import that runs back up."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

ALLOWED: dict[str, set[str]] = {
    "core": set(),
    "validation_rigs": set(),
    "simulators": {"core"},
    "db": {"core"},
    "estimator": {"core"},
    "daq": {"core", "db"},
    "api": {"core", "db", "estimator", "daq", "simulators"},
    "commands": {"core", "db", "estimator", "daq", "simulators", "api", "validation_rigs"},
}
"""Package -> the packages of ours it may import (besides itself)."""

OURS = set(ALLOWED)


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(), filename=str(path))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.append((node.lineno, node.module))
    return out


def layer_violations() -> list[str]:
    bad = []
    for pkg, allowed in ALLOWED.items():
        for path in sorted((ROOT / pkg).rglob("*.py")):
            for line, name in _imports(path):
                top = name.split(".")[0]
                if top in OURS and top != pkg and top not in allowed:
                    bad.append(f"{path.relative_to(ROOT)}:{line} imports {name} "
                               f"({pkg} may import {sorted(allowed) or 'nothing of ours'})")
    return bad


def test_every_package_is_in_a_layer():
    pkgs = {p.parent.name for p in ROOT.glob("*/__init__.py")}
    assert pkgs <= OURS | {"tests", "bench"}, sorted(pkgs - OURS)


def test_no_layer_imports_one_above_it():
    assert layer_violations() == []


def test_the_check_sees_an_upward_import(tmp_path, monkeypatch):
    """The check itself fails on an upward import (core importing db)."""
    (tmp_path / "core").mkdir()
    (tmp_path / "core" / "x.py").write_text("def f():\n    from db.store import Store\n")
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    assert any("core/x.py:2 imports db.store" in v for v in layer_violations())
