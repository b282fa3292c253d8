"""Settings files: one TOML or JSON file may hold a table per program ([daq], [emulate], [api]);
and the helpers both settings objects (daq/settings.py, api/settings.py) use to give every field
a unit and a range (`setting`) and to turn a refused value into one message naming its source
(`build_settings`)."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any, Mapping


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


def setting(default: Any, unit: str, doc: str, **bounds: Any) -> Any:
    """A settings field (pydantic `Field`) with its unit and its range: `bounds` are pydantic's
    ge/gt/le/lt (numbers) or min_length; the unit is kept in the field's schema for tables
    and error messages."""
    from pydantic import Field

    return Field(default, description=doc, json_schema_extra={"unit": unit}, **bounds)


def describe_field(info: Any) -> str:
    """'[unit], lo ≤ value ≤ hi' of one pydantic field (what an error message adds)."""
    extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
    lo = hi = ""
    for m in info.metadata:
        for attr, text in (("ge", "{} ≤ "), ("gt", "{} < ")):
            if getattr(m, attr, None) is not None:
                lo = text.format(getattr(m, attr))
        for attr, text in (("le", " ≤ {}"), ("lt", " < {}")):
            if getattr(m, attr, None) is not None:
                hi = text.format(getattr(m, attr))
    unit = extra.get("unit", "")
    return f"[{unit}]" + (f", {lo}value{hi}" if lo or hi else "")


def build_settings(cls: Any, values: dict[str, Any], origin: Mapping[str, str]) -> Any:
    """cls(**values) — a pydantic dataclass of settings — with every refusal turned into one
    ValueError naming where each bad value came from (`origin[field]`: the environment variable
    such as RIG_TORQUE_LIMIT, or the file and key), the value (not for a field marked secret in
    its schema extra), the reason, the unit and range.
    A bad setting must stop start-up with a message the operator can act on."""
    from pydantic import ValidationError

    try:
        return cls(**values)
    except ValidationError as exc:
        fields_ = getattr(cls, "__pydantic_fields__", {})
        lines = []
        for err in exc.errors():
            name = str(err["loc"][0]) if err["loc"] else ""
            where = origin.get(name, name) or cls.__name__
            extra = getattr(fields_.get(name), "json_schema_extra", None) or {}
            secret = isinstance(extra, dict) and extra.get("secret")
            value = f"={err['input']!r}" if name and not secret \
                and not isinstance(err["input"], dict) else ""
            hint = f" ({name} {describe_field(fields_[name])})" if name in fields_ else ""
            msg = err["msg"].removeprefix("Value error, ")
            lines.append(f"{where}{value}: {msg}{hint}")
        raise ValueError("invalid setting: " + "; ".join(lines)) from None
