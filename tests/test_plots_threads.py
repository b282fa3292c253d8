"""Report figures are drawn on their own matplotlib Figure objects, never through pyplot (whose
process-wide figure registry request threads would share), and so render correctly from
several threads at once."""

from __future__ import annotations

import ast
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
PLOT_MODULES = ["api/run_plots.py", "api/diagnosis_plots.py", "api/fit_series.py",
                "estimator/plots.py"]


def _pyplot_imports(path: Path) -> list[str]:
    """Every import of matplotlib.pyplot (module-level or inside a function) in a file."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [f"{path.name}:{node.lineno} import {a.name}" for a in node.names
                      if a.name == "matplotlib.pyplot" or a.name.startswith("matplotlib.pyplot.")]
        elif isinstance(node, ast.ImportFrom) and node.module:
            if node.module.startswith("matplotlib.pyplot") or (
                    node.module == "matplotlib" and any(a.name == "pyplot" for a in node.names)):
                found.append(f"{path.name}:{node.lineno} from {node.module} import ...")
    return found


@pytest.mark.parametrize("rel", PLOT_MODULES)
def test_no_pyplot_in_plot_modules(rel):
    assert _pyplot_imports(ROOT / rel) == []


def test_the_ast_check_sees_pyplot(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("def g():\n    from matplotlib import pyplot as p\nimport matplotlib.pyplot as plt\n")
    assert len(_pyplot_imports(f)) == 2


def _run_arrays(seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 10.0, 2000)
    torque = 1e4 * np.sin(t + seed) + rng.normal(0, 100, t.size)
    return {"t": t, "torque_cmd": 1e4 * np.sin(t + seed), "torque_load": torque,
            "torque": torque, "torsion": 1e-4 * np.sin(t + seed + 0.1),
            "i_m1": torque / 1e3, "temp_m1": 40 + t}


def _render(seed: int) -> tuple[bytes, bytes, bytes]:
    """A run figure (SVG), the hysteresis loop (SVG) and Sobol bars (PNG) for one seed."""
    from api import run_plots
    from estimator import plots

    a = _run_arrays(seed)
    png = plots.sobol_bars(["a", "b", "c"], [0.1 * (seed % 5), 0.3, 0.2], [0.4, 0.5, 0.3],
                           title=f"seed {seed}", fmt="png")
    return run_plots.following(a), run_plots.hysteresis(a), png


def test_plots_render_from_many_threads_at_once():
    seeds = list(range(12))
    alone = {s: _render(s)[2] for s in seeds[:4]}   # PNG from Agg is deterministic
    with ThreadPoolExecutor(max_workers=6) as pool:
        results = list(pool.map(_render, seeds * 2))
    for s, (svg1, svg2, png) in zip(seeds * 2, results):
        for svg in (svg1, svg2):
            root = ET.fromstring(svg)          # well-formed XML
            assert root.tag.endswith("svg") and len(root) > 0
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and png[12:16] == b"IHDR"
        assert png[-8:-4] == b"IEND"
        if s in alone:                         # each thread drew its own figure only
            assert png == alone[s]
