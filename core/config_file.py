"""Settings files: one TOML or JSON file may hold a table per program ([daq], [emulate], [api])."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any


def read_config_file(path: str | Path, section: str | None = None) -> dict[str, Any]:
    """A TOML (.toml) or JSON file as a dict; with `section`, that table if the file has it
    (so one file can hold a [daq] and an [emulate] table), else the whole file."""
    p = Path(path)
    text = p.read_text(encoding="utf-8")
    try:
        data = tomllib.loads(text) if p.suffix.lower() == ".toml" else json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{p}: not valid {'TOML' if p.suffix == '.toml' else 'JSON'}: {exc}")
    if not isinstance(data, dict):
        raise ValueError(f"{p}: the top level must be a table/object")
    if section is not None and isinstance(data.get(section), dict):
        return dict(data[section])
    return {k: v for k, v in data.items() if not isinstance(v, dict)}
