"""A stored run as it leaves the store in the interchange format (run-format.md): the samples in
their stored order and the metadata, with the units of channels outside the standard list added
to `units` so that they travel with the run. Used by `rig export` and `GET /runs/{id}/file`."""

from __future__ import annotations

import io
import tempfile
import zipfile
from pathlib import Path

from core.channels import unit_of
from core.run import RunData
from core.runfile import write_run


def exportable_run(store, run_id: int) -> RunData:
    """Run `run_id` with its extra channels' units in its metadata (RunNotFound if none)."""
    run_data = store.load_run(run_id)
    channels = store.channels(run_id)
    meta = dict(run_data.meta)
    units = dict(meta.get("units") or {})
    extra = {c["name"]: c["unit"] for c in channels
             if c["unit"] and c["unit"] != unit_of(c["name"]) and units.get(c["name"]) != c["unit"]}
    if extra:
        meta["units"] = {**units, **extra}
    return RunData(samples=run_data.samples, meta=meta)


def export_run(store, run_id: int, out_dir: Path | str, fmt: str = "csv") -> list[Path]:
    """Write run `run_id` as <out_dir>/run-<id>.csv|.parquet + run-<id>.json; the paths."""
    return write_run(exportable_run(store, run_id), Path(out_dir) / f"run-{run_id}", fmt=fmt)


def run_archive(store, run_id: int, fmt: str = "csv") -> bytes:
    """Run `run_id`'s interchange files (samples + metadata) as one zip archive, in memory."""
    buf = io.BytesIO()
    with tempfile.TemporaryDirectory() as tmp, zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for p in export_run(store, run_id, tmp, fmt):
            z.write(p, arcname=p.name)
    return buf.getvalue()
