"""Print a pip constraints file pinning every direct dependency of pyproject.toml (core and the
given extras) to its floor: `name>=X` becomes `name==X`. CI installs the project against it to
check that every floor is a version the code works with (.ci/run, the floors step)."""

import re
import sys
import tomllib
from pathlib import Path


def floors(pyproject: Path, extras: list[str]) -> list[str]:
    data = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]
    reqs = list(data["dependencies"])
    for e in extras:
        reqs += data["optional-dependencies"][e]
    out: dict[str, str] = {}
    for r in reqs:
        m = re.match(r"\s*([A-Za-z0-9_.\-]+)(\[[^\]]*\])?\s*([^;]*)", r)
        name, spec = m.group(1).lower(), m.group(3)
        low = re.search(r">=\s*([^,\s]+)", spec)
        if low is None:
            raise SystemExit(f"{r!r} has no floor (>=): every dependency needs one")
        out[name] = low.group(1)
    return [f"{n}=={v}" for n, v in sorted(out.items())]


if __name__ == "__main__":
    root = Path(__file__).resolve().parent.parent
    print("\n".join(floors(root / "pyproject.toml", sys.argv[1:])))
