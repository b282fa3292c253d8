"""Run files: the interchange format of ../shared/docs/run-format.md, read and written.

A run travels as two files with one stem: `<stem>.csv` (or `<stem>.parquet`), one row per
sample, and `<stem>.json`, its metadata. `read_run` validates exactly as run-format.md says and
refuses a bad file whole with a `RunFileError` naming the file, the row and the column;
`write_run` writes what `read_run` reads back identically (floats in shortest round-trip form,
missing samples as empty cells).

Rules applied when reading (documented here so the code and the page cannot disagree):
- `t` is required, numeric, finite, never missing and strictly increasing.
- Known channels other than `phase` (core.channels) are numeric: a cell that is not a number,
  or an infinite one, refuses the file. Empty cells (and the literal `nan`/`NaN`) are missing
  samples and stay NaN.
- `phase` is text, one of core.channels.PHASES, or empty (missing).
- Unknown columns are kept as extra channels: numeric when any non-empty cell is a number (and
  then every non-empty cell must be a finite number), text when none is.
- Column names must be non-empty and unique.
- Metadata must be a JSON object; the keys of run-format.md (and the acceptance set points of
  core.acceptance) must have the documented kind; unknown keys are kept as they are; numbers
  must be finite, and it may nest at most META_MAX_DEPTH levels deep. Rows are counted from 1 at
  the first sample (the header is not a row); for a CSV the line number is given too.
- A CSV is UTF-8 text; every row has exactly as many cells as the header, and the last line ends
  with a line end (a file cut short mid-line would otherwise store a truncated number as data).
- Any file that cannot be read (bad encoding, nesting too deep for the parser, a corrupt
  Parquet file) is refused with a RunFileError naming it, like any other broken rule.
"""

from __future__ import annotations

import csv
import json
import math
from datetime import datetime
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pandas as pd

from core.channels import CHANNELS, PHASES
from core.documents import RunMeta
from core.run import RunData

DATA_SUFFIXES = (".csv", ".parquet")
MISSING_TEXT = ("", "nan", "NaN", "NAN")
"""Cell texts read as a missing sample."""


class RunFileError(ValueError):
    """A run file that breaks run-format.md. `file`, `row` (1-based sample row, None for the
    header or the metadata) and `column` (column name or metadata key) locate the fault."""

    def __init__(self, file: Path | str, row: int | None, column: str | None, problem: str,
                 line: int | None = None):
        self.file = str(file)
        self.row = row
        self.column = column
        self.problem = problem
        where = [self.file]
        if row is not None:
            where.append(f"row {row}" + (f" (line {line})" if line is not None else ""))
        elif line is not None:
            where.append(f"line {line}")
        if column is not None:
            where.append(f"column {column!r}")
        super().__init__(", ".join(where) + f": {problem}")


# --- metadata --------------------------------------------------------------------------------

def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _number(positive: bool = False, nonneg: bool = False) -> Callable[[Any], str | None]:
    def check(v: Any) -> str | None:
        if not _is_number(v):
            return f"expected a number, got {v!r}"
        if positive and not v > 0:
            return f"expected a positive number, got {v!r}"
        if nonneg and not v >= 0:
            return f"expected a number >= 0, got {v!r}"
        return None
    return check


def _text(v: Any) -> str | None:
    return None if isinstance(v, str) else f"expected text, got {v!r}"


def _scheme(v: Any) -> str | None:
    return None if (_is_number(v) and v in (1, 2, 3) and float(v).is_integer()) \
        else f"expected 1, 2 or 3, got {v!r}"


def _direction(v: Any) -> str | None:
    return None if (_is_number(v) and v in (1, -1)) else f"expected +1 or -1, got {v!r}"


def _source(v: Any) -> str | None:
    return None if v in ("rig", "emulator", "import") \
        else f"expected 'rig', 'emulator' or 'import', got {v!r}"


def _timestamp(v: Any) -> str | None:
    if not isinstance(v, str):
        return f"expected an ISO 8601 date-time text, got {v!r}"
    try:
        datetime.fromisoformat(v.replace("Z", "+00:00"))
    except ValueError:
        return f"expected an ISO 8601 date-time, got {v!r}"
    return None


def _units(v: Any) -> str | None:
    if isinstance(v, dict) and all(isinstance(u, str) for u in v.values()):
        return None
    return f"expected an object of channel name -> unit text, got {v!r}"


SENSOR_KEYS = {"resolution": "the channel's quantisation step, in the channel's unit",
               "noise_sd": "standard deviation of the channel's measurement noise, channel unit",
               "lag_s": "how far the channel lags the others [s]"}
"""What a run may say of each channel's sensor (metadata key `sensors`, docs/run-format.md)."""


def _sensors(v: Any) -> str | None:
    if not isinstance(v, dict):
        return "must be an object {channel: {resolution, noise_sd, lag_s}}"
    for ch, spec in v.items():
        if not isinstance(spec, dict):
            return f"sensors[{ch!r}] must be an object with keys among {sorted(SENSOR_KEYS)}"
        for k, x in spec.items():
            if k not in SENSOR_KEYS:
                return f"sensors[{ch!r}] has unknown key {k!r}; known: {sorted(SENSOR_KEYS)}"
            if isinstance(x, bool) or not isinstance(x, (int, float)) or x < 0:
                return f"sensors[{ch!r}][{k!r}] must be a number >= 0, got {x!r}"
    return None


META_KEYS: dict[str, Callable[[Any], str | None]] = {
    "scheme": _scheme,
    "motor_speed_rpm": _number(nonneg=True),
    "direction": _direction,
    "reduction": _number(positive=True),
    "rig": _text,
    "source": _source,
    "sample_rate_hz": _number(positive=True),
    "started_at": _timestamp,
    "notes": _text,
    # units of channels the format does not list (extra channels), or of another rig's record
    "units": _units,
    # acceptance set points (core.acceptance): hydraulic shear force [N], bending moment [N·m],
    # and the settling time after a dynamometer set-point step excluded from the error [s]
    "shear_setpoint_n": _number(nonneg=True),
    "bend_setpoint_nm": _number(nonneg=True),
    "acceptance_settle_s": _number(nonneg=True),
    # what each channel's sensor resolves and how noisy it is (docs/run-format.md)
    "sensors": _sensors,
}
"""Known metadata keys and their checks; null is allowed for every key (e.g. the speed of a
scheme-3 run, or the scheme of a record from another rig). Unknown keys are kept unchecked."""


META_MAX_DEPTH = 32
"""Deepest nesting of objects/lists allowed in metadata (the top-level object is depth 1): deep
enough for any real record, shallow enough that no recursive reader or JSON encoder on the way
to the database can overflow its stack."""


def _meta_depth(meta: Any) -> int:
    """Nesting depth of a JSON value (iterative, so any depth is measured without recursion)."""
    deepest, stack = 0, [(meta, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, (dict, list)):
            deepest = max(deepest, d)
            if d > META_MAX_DEPTH:
                return d
            stack.extend((x, d + 1) for x in (v.values() if isinstance(v, dict) else v))
    return deepest


def validate_meta(meta: Any, file: Path | str) -> RunMeta:
    """Check metadata against META_KEYS; returns it unchanged or raises RunFileError."""
    if not isinstance(meta, dict):
        raise RunFileError(file, None, None, f"metadata must be a JSON object, got {type(meta).__name__}")
    if _meta_depth(meta) > META_MAX_DEPTH:
        raise RunFileError(file, None, None, f"metadata nested more than {META_MAX_DEPTH} levels deep")
    for key, value in meta.items():
        if not isinstance(key, str):
            raise RunFileError(file, None, repr(key), "metadata keys must be text")
        bad = _non_finite(value)
        if bad:
            raise RunFileError(file, None, key, f"non-finite number {bad} in metadata")
        check = META_KEYS.get(key)
        if check is not None and value is not None:
            problem = check(value)
            if problem:
                raise RunFileError(file, None, key, problem)
    return meta


def _non_finite(v: Any) -> str | None:
    if isinstance(v, float) and not math.isfinite(v):
        return repr(v)
    if isinstance(v, dict):
        v = list(v.values())
    if isinstance(v, list):
        for x in v:
            bad = _non_finite(x)
            if bad:
                return bad
    return None


def _reject_constant(name: str) -> Any:
    raise ValueError(name)


def read_meta(path: Path) -> RunMeta:
    """Read and validate a `<stem>.json` metadata file."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise RunFileError(path, None, None, "metadata file not found (a run is <stem>.csv or "
                           "<stem>.parquet plus <stem>.json)") from None
    except UnicodeDecodeError as exc:
        raise RunFileError(path, None, None, f"not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise RunFileError(path, None, None, f"cannot read the file: {exc.strerror or exc}") from None
    try:
        meta = json.loads(text, parse_constant=_reject_constant)
    except ValueError as exc:
        line = getattr(exc, "lineno", None)
        raise RunFileError(path, None, None, f"not valid JSON: {exc}", line=line) from None
    except RecursionError:
        raise RunFileError(path, None, None, "not valid metadata: JSON nested too deep to read "
                           f"(at most {META_MAX_DEPTH} levels)") from None
    return validate_meta(meta, path)


# --- samples ---------------------------------------------------------------------------------

def is_numeric_channel(name: str) -> bool | None:
    """True for known numeric channels, False for `phase`, None for an unknown column."""
    if name == "phase":
        return False
    return True if name in CHANNELS else None


def _text_series(values: pd.Series) -> pd.Series:
    """Text channel in the house form: object dtype, str values, None where missing."""
    arr = values.to_numpy(dtype=object, na_value=None)
    miss = pd.isna(values).to_numpy() | np.isin(arr, MISSING_TEXT)
    arr = np.array([v if isinstance(v, str) else str(v) for v in arr], dtype=object)
    arr[miss] = None
    return pd.Series(arr, dtype=object)


def _first(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


def validate_samples(df: pd.DataFrame, file: Path | str,
                     line_offset: int | None = None) -> pd.DataFrame:
    """Check and normalise a samples frame (numeric channels float64, text channels object with
    None for missing, `t` first); `line_offset` maps sample row r to file line r + offset."""
    def err(row_idx: int | None, col: str | None, problem: str) -> RunFileError:
        row = None if row_idx is None else row_idx + 1
        line = None if (row is None or line_offset is None) else row + line_offset
        return RunFileError(file, row, col, problem, line=line)

    cols = [str(c) for c in df.columns]
    for c in cols:
        if not c.strip():
            raise RunFileError(file, None, c, "empty column name")
    if len(set(cols)) != len(cols):
        dup = next(c for c in cols if cols.count(c) > 1)
        raise RunFileError(file, None, dup, "column appears more than once")
    if "t" not in cols:
        raise RunFileError(file, None, "t", "required column 't' (time [s]) is missing")

    out: dict[str, pd.Series] = {}
    for name in ["t"] + [c for c in cols if c != "t"]:
        col = df[name]
        kind = is_numeric_channel(name)
        numeric_dtype = (pd.api.types.is_numeric_dtype(col.dtype)
                         and not pd.api.types.is_bool_dtype(col.dtype))
        if kind is None:  # unknown column: numeric if any non-empty cell is a number
            if numeric_dtype:
                kind = True
            else:
                txt = _text_series(col)
                parsed = pd.to_numeric(txt, errors="coerce")
                kind = bool(parsed.notna().any())
        if kind:
            if numeric_dtype:
                values = col.to_numpy(dtype=float)
            else:
                txt = _text_series(col)
                parsed = pd.to_numeric(txt, errors="coerce").to_numpy(dtype=float)
                bad = np.asarray(txt.notna()) & np.isnan(parsed)
                if bad.any():
                    i = _first(bad)
                    raise err(i, name, f"text {txt.iloc[i]!r} in a numeric column")
                values = parsed
            inf = np.isinf(values)
            if inf.any():
                i = _first(inf)
                raise err(i, name, f"infinite value {float(values[i])!r} in a numeric column")
            out[name] = pd.Series(values, dtype=np.float64)
        else:
            txt = _text_series(col)
            if name == "phase":
                bad = np.asarray(txt.notna() & ~txt.isin(PHASES))
                if bad.any():
                    i = _first(bad)
                    raise err(i, name, f"unknown phase {txt.iloc[i]!r} (expected one of "
                                       f"{', '.join(PHASES)} or empty)")
            out[name] = txt.reset_index(drop=True)

    t = out["t"].to_numpy()
    if len(t):
        miss = np.isnan(t)
        if miss.any():
            raise err(_first(miss), "t", "missing time: 't' is required in every row")
        back = np.diff(t) <= 0
        if back.any():
            i = _first(back) + 1
            raise err(i, "t", f"'t' not strictly increasing "
                              f"({float(t[i])!r} after {float(t[i - 1])!r})")
    return pd.DataFrame(out)


def _check_csv_shape(path: Path) -> list[str]:
    """The header of a CSV, after checking the file's shape as written: a header with non-empty,
    unique names, as many cells in every row as in the header (pandas would silently turn extra
    cells into an index or pad short rows), and a line end after the last line."""
    with path.open("rb") as fb:
        size = fb.seek(0, 2)
        if size:
            fb.seek(size - 1)
            last = fb.read(1)
    with path.open(newline="", encoding="utf-8-sig") as fh:  # -sig: tolerate a BOM (Excel)
        reader = csv.reader(fh, strict=True)
        header = next(reader, None)
        if not header:
            raise RunFileError(path, None, None, "empty file: no header line", line=1)
        for c in header:
            if not c.strip():
                raise RunFileError(path, None, c, "empty column name", line=1)
            if header.count(c) > 1:
                raise RunFileError(path, None, c, "column appears more than once", line=1)
        row = 0
        for cells in reader:
            if not cells:
                continue  # a blank line, skipped as pandas does
            row += 1
            if len(cells) != len(header):
                raise RunFileError(path, row, None, f"{len(cells)} cells where the header has "
                                   f"{len(header)}", line=reader.line_num)
    if last not in (b"\n", b"\r"):
        raise RunFileError(path, None, None, "the last line has no line end: the file looks cut "
                           "short (truncated)")
    return header


def _read_csv(path: Path) -> tuple[pd.DataFrame, int]:
    """Samples of a CSV, with the header checked as written (pandas would rename duplicates)."""
    try:
        header = _check_csv_shape(path)
    except UnicodeDecodeError as exc:
        raise RunFileError(path, None, None, f"not UTF-8 text: {exc}") from None
    except csv.Error as exc:
        raise RunFileError(path, None, None, f"malformed CSV: {exc}") from None
    except OSError as exc:
        raise RunFileError(path, None, None, f"cannot read the file: {exc.strerror or exc}") from None
    kwargs: dict[str, Any] = {}
    if int(pd.__version__.split(".")[0]) < 3:
        kwargs["float_precision"] = "round_trip"  # pandas 3 parses round-trip by default
    try:
        df = pd.read_csv(path, keep_default_na=False, na_values=list(MISSING_TEXT),
                         dtype={"phase": object}, encoding="utf-8-sig", **kwargs)
    except pd.errors.ParserError as exc:
        raise RunFileError(path, None, None, f"malformed CSV: {exc}") from None
    except UnicodeDecodeError as exc:
        raise RunFileError(path, None, None, f"not UTF-8 text: {exc}") from None
    df.columns = header  # read_csv would mangle nothing here (no duplicates), keep exact names
    return df, 1


def _read_parquet(path: Path) -> pd.DataFrame:
    try:
        df = pd.read_parquet(path)
    except Exception as exc:  # pyarrow raises several types for a corrupt file
        raise RunFileError(path, None, None, f"not a readable Parquet file: {exc}") from None
    for c in df.columns:
        dt = df[c].dtype
        if not (pd.api.types.is_numeric_dtype(dt) or pd.api.types.is_string_dtype(dt)
                or dt == object):
            raise RunFileError(path, None, str(c), f"unsupported column type {dt}")
        if pd.api.types.is_bool_dtype(dt):
            raise RunFileError(path, None, str(c), "boolean column: expected numbers or text")
        if pd.api.types.is_string_dtype(dt):
            # Arrow-backed text is decoded lazily: bytes that are not UTF-8 fail only when the
            # values are read, so read them here, where the fault can still name its column.
            try:
                df[c].to_numpy(dtype=object, na_value=None)
            except Exception as exc:  # pyarrow's ArrowException family
                raise RunFileError(path, None, str(c), f"unreadable text: {exc}") from None
    return df.reset_index(drop=True)


def run_paths(path: Path | str) -> tuple[Path, Path]:
    """(data file, metadata file) of a run given either file or the bare stem."""
    p = Path(path)
    if p.suffix == ".json":
        cands = [p.with_suffix(s) for s in DATA_SUFFIXES if p.with_suffix(s).exists()]
        if not cands:
            raise RunFileError(p, None, None, "no <stem>.csv or <stem>.parquet beside the metadata")
        if len(cands) > 1:
            raise RunFileError(p, None, None, "both a .csv and a .parquet share this stem; "
                               "name the data file to import")
        return cands[0], p
    if p.suffix in DATA_SUFFIXES:
        return p, p.with_suffix(".json")
    cands = [Path(f"{p}{s}") for s in DATA_SUFFIXES if Path(f"{p}{s}").exists()]
    if len(cands) != 1:
        raise RunFileError(p, None, None, "expected exactly one of <stem>.csv, <stem>.parquet")
    return cands[0], Path(f"{p}.json")


def read_run(path: Path | str) -> RunData:
    """Read one run (path to its .csv, .parquet, .json or bare stem), validated as
    run-format.md says. Raises RunFileError naming file, row and column on any fault."""
    data_path, meta_path = run_paths(path)
    if not data_path.exists():
        raise RunFileError(data_path, None, None, "file not found")
    meta = read_meta(meta_path)
    if data_path.suffix == ".csv":
        df, header_lines = _read_csv(data_path)
        samples = validate_samples(df, data_path, line_offset=header_lines)
    else:
        samples = validate_samples(_read_parquet(data_path), data_path)
    return RunData(samples=samples, meta=meta)


def write_run(run: RunData, path: Path | str, fmt: str = "csv") -> list[Path]:
    """Write a run as `<stem>.csv|.parquet` + `<stem>.json` (path: the stem, or a file whose
    suffix is replaced). Validates first, so a written file always reads back; returns both
    paths [data, metadata]."""
    if fmt not in ("csv", "parquet"):
        raise ValueError(f"fmt must be 'csv' or 'parquet', got {fmt!r}")
    p = Path(path)
    stem = p.with_suffix("") if p.suffix in DATA_SUFFIXES + (".json",) else p
    data_path = Path(f"{stem}.{fmt}")
    meta_path = Path(f"{stem}.json")
    samples = validate_samples(run.samples, data_path)
    validate_meta(run.meta, meta_path)
    data_path.parent.mkdir(parents=True, exist_ok=True)
    if fmt == "csv":
        samples.to_csv(data_path, index=False, na_rep="", lineterminator="\n")
    else:
        samples.to_parquet(data_path, index=False)
    meta_path.write_text(json.dumps(run.meta, indent=2, ensure_ascii=False, allow_nan=False) + "\n",
                         encoding="utf-8")
    return [data_path, meta_path]
