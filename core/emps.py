"""Adapter for the EMPS benchmark records (../shared/data/emps/, MATLAB v5 files): the example of
bringing another rig's data in as a run with its own channel names and units.

EMPS is a real prismatic drive (DC motor + ball screw, 1 kHz) published by A. Janot, M. Gautier
and M. Brunot, "Data Set and Reference Models of EMPS", Workshop on Nonlinear System
Identification Benchmarks, 2019. Channels: `t` [s], `qm` measured position [m], `qg` reference
position [m], `vir` controller output [V], `force` = gtau·vir drive force [N], and in the
validation record `pulses_N` (the external force pulse signal, kept as recorded; the benchmark
gives no unit for it).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from core.run import RunData
from core.runfile import RunFileError, validate_meta, validate_samples

CITATION = ("A. Janot, M. Gautier, M. Brunot, \"Data Set and Reference Models of EMPS\", "
            "Workshop on Nonlinear System Identification Benchmarks, 2019")

UNITS: dict[str, str] = {"t": "s", "qm": "m", "qg": "m", "vir": "V", "force": "N", "pulses_N": ""}
"""Units of the EMPS channels (README of ../shared/data/emps/)."""


def _vector(mat: dict[str, Any], key: str, path: Path) -> np.ndarray:
    """Field `key` as a 1-D float array; a struct, cell, text or complex field is refused."""
    if key not in mat:
        raise RunFileError(path, None, key, "field missing from the EMPS record")
    raw = np.asarray(mat[key])
    if raw.dtype.kind not in "biuf":  # struct/cell (object, void), text, complex
        raise RunFileError(path, None, key, f"expected a real numeric array, got MATLAB "
                           f"{'struct' if raw.dtype.names else 'cell, text or complex'} data")
    return raw.astype(float).ravel()


def _scalar(mat: dict[str, Any], key: str, path: Path) -> float:
    v = _vector(mat, key, path)
    if v.size != 1:
        raise RunFileError(path, None, key, f"expected one number, got {v.size}")
    return float(v[0])


def load_emps(path: Path | str) -> RunData:
    """One EMPS .mat record as a RunData: channels t, qm, qg, vir, force = gtau·vir (plus
    pulses_N when present), metadata with source 'import', the record's gtau [N/V], kp, kv,
    the channel units and the citation. Validated like any imported run."""
    from scipy.io import loadmat

    path = Path(path)
    try:
        mat = loadmat(path)
    except Exception as exc:  # scipy raises several types for a non-MAT file
        raise RunFileError(path, None, None, f"not a readable MATLAB file: {exc}") from None
    cols: dict[str, np.ndarray] = {}
    for key in ("t", "qm", "qg", "vir"):
        cols[key] = _vector(mat, key, path)
    gtau = _scalar(mat, "gtau", path)
    cols["force"] = gtau * cols["vir"]
    if "pulses_N" in mat:
        cols["pulses_N"] = _vector(mat, "pulses_N", path)
    n = len(cols["t"])
    for key, v in cols.items():
        if len(v) != n:
            raise RunFileError(path, None, key, f"{len(v)} samples where 't' has {n}")
    samples = validate_samples(pd.DataFrame(cols), path)  # first: 't' increasing before dt
    dt = np.diff(cols["t"])
    meta: dict[str, Any] = {
        "source": "import",
        "rig": "EMPS",
        "sample_rate_hz": float(round(1.0 / float(np.median(dt)), 6)) if n > 1 else None,
        "notes": f"EMPS benchmark record {path.name} (real measurements, prismatic drive)",
        "imported_from": path.name,
        "gtau": gtau,
        "kp": _scalar(mat, "kp", path),
        "kv": _scalar(mat, "kv", path),
        "units": {k: UNITS[k] for k in cols},
        "citation": CITATION,
    }
    return RunData(samples=samples, meta=validate_meta(meta, path))
