"""Samples as pages of binary blocks with statistics (the layout is described in db/models.py):
splitting a run's samples into pages, encoding blocks, computing each block's statistics in one
vectorised pass per channel, writing pages, and reassembling whole channels on load."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd
from sqlalchemy import Connection, insert, update

from db.models import Channel, SampleBlock, SamplePage
from core.jsonsafe import finite_list

PAGE_SAMPLES = 16384
"""Largest page [samples]: 128 KiB per float channel block (measured: larger blocks load a
1 M-sample run faster than 4096-sample ones, see bench/bench_store.py)."""


@dataclass
class ChannelRef:
    """What page writing needs to know of a stored channel. `kind`: 'float', 'text', 'phase'."""
    name: str
    id: int
    kind: str
    ref: float | None = None


def channel_kind(name: str, values: Any = None) -> str:
    """'phase' for the phase channel, 'text' for an object/string column, else 'float'."""
    if name == "phase":
        return "phase"
    if values is not None:
        dt = getattr(values, "dtype", None)
        if dt is not None and (dt == object or pd.api.types.is_string_dtype(dt)):
            return "text"
    return "float"


def page_starts(n: int, phase: Sequence[Any] | None, max_len: int = PAGE_SAMPLES) -> np.ndarray:
    """First sample index of each page: a new page where the phase changes (missing counts
    as a phase of its own) and at most every max_len samples."""
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    if phase is None:
        seg = np.array([0], dtype=np.int64)
    else:
        codes, _ = pd.factorize(pd.Series(phase, dtype=object), use_na_sentinel=True)
        seg = np.concatenate([[0], np.flatnonzero(codes[1:] != codes[:-1]) + 1]).astype(np.int64)
    ends = np.append(seg[1:], n)
    parts = [np.arange(s, e, max_len, dtype=np.int64) for s, e in zip(seg, ends)]
    return np.concatenate(parts)


def encode_float(x: np.ndarray) -> bytes:
    return np.ascontiguousarray(x, dtype="<f8").tobytes()


def decode_float(blob: bytes) -> np.ndarray:
    return np.frombuffer(blob, dtype="<f8")


def encode_text(values: Sequence[Any]) -> bytes:
    return json.dumps([v if isinstance(v, str) else None for v in values],
                      ensure_ascii=False).encode("utf-8")


def decode_text(blob: bytes) -> list[str | None]:
    return json.loads(bytes(blob).decode("utf-8"))


_none_if_nan = finite_list


def float_block_rows(x: np.ndarray, starts: np.ndarray, ref: float) -> list[dict[str, Any]]:
    """Blocks and statistics of one float channel over the pages starting at `starts`:
    n_valid, s1 = Σ(x−ref), s2 = Σ(x−ref)², vmin, vmax (None where a page has no valid
    sample)."""
    valid = ~np.isnan(x)
    d = np.where(valid, x - ref, 0.0)
    n_valid = np.add.reduceat(valid.astype(np.int64), starts)
    s1 = np.add.reduceat(d, starts)
    s2 = np.add.reduceat(d * d, starts)
    vmin = np.fmin.reduceat(x, starts)
    vmax = np.fmax.reduceat(x, starts)
    empty = n_valid == 0
    s1[empty] = np.nan
    s2[empty] = np.nan
    bounds = np.append(starts, len(x))
    return [{"data": encode_float(x[a:b]), "n_valid": int(nv), "s1": s1_, "s2": s2_,
             "vmin": lo, "vmax": hi}
            for a, b, nv, s1_, s2_, lo, hi in zip(bounds[:-1], bounds[1:], n_valid.tolist(),
                                                  _none_if_nan(s1), _none_if_nan(s2),
                                                  _none_if_nan(vmin), _none_if_nan(vmax))]


def text_block_rows(values: Sequence[Any], starts: np.ndarray) -> list[dict[str, Any]]:
    bounds = np.append(starts, len(values)).tolist()
    out = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        chunk = list(values[a:b])
        out.append({"data": encode_text(chunk), "n_valid": sum(isinstance(v, str) for v in chunk),
                    "s1": None, "s2": None, "vmin": None, "vmax": None})
    return out


def write_pages(conn: Connection, run_id: int, channels: Sequence[ChannelRef],
                cols: Mapping[str, Any], *, seq0: int, i0: int,
                max_len: int = PAGE_SAMPLES) -> int:
    """Insert the samples in `cols` (name -> array, all of one length, `t` required; channels
    absent from cols are stored as missing) as pages seq0, seq0+1, ... starting at sample i0.
    Sets and stores a channel's `ref` at its first valid value. Returns the number of pages."""
    t = np.asarray(cols["t"], dtype=float)
    n = len(t)
    if n == 0:
        return 0
    phase = cols.get("phase")
    starts = page_starts(n, phase, max_len)
    ends = np.append(starts[1:], n)
    pages = [{"run_id": run_id, "seq": seq0 + k, "i0": i0 + int(a), "n": int(b - a),
              "t0": float(t[a]), "t1": float(t[b - 1]),
              "phase": (phase[a] if phase is not None and isinstance(phase[a], str) else None)}
             for k, (a, b) in enumerate(zip(starts.tolist(), ends.tolist()))]
    conn.execute(insert(SamplePage), pages)
    blocks: list[dict[str, Any]] = []
    for ch in channels:
        if ch.kind == "phase":
            continue
        values = cols.get(ch.name)
        if ch.kind == "text":
            rows = text_block_rows(values if values is not None else [None] * n, starts)
        else:
            x = np.full(n, np.nan) if values is None else np.asarray(values, dtype=float)
            if ch.ref is None:
                ok = np.flatnonzero(~np.isnan(x))
                if len(ok):
                    ch.ref = float(x[ok[0]])
                    conn.execute(update(Channel).where(Channel.id == ch.id).values(ref=ch.ref))
            rows = float_block_rows(x, starts, ch.ref if ch.ref is not None else 0.0)
        for k, row in enumerate(rows):
            row.update(run_id=run_id, seq=seq0 + k, channel_id=ch.id)
        blocks.extend(rows)
    if blocks:
        conn.execute(insert(SampleBlock), blocks)
    return len(pages)


def assemble(n: int, pages: Sequence[tuple[int, int, int, str | None]],
             blocks: Sequence[tuple[int, int, bytes]], channels: Sequence[ChannelRef]
             ) -> dict[str, np.ndarray]:
    """Whole channels from stored pages (seq, i0, n, phase) and blocks (channel_id, seq, data):
    float channels as float64 arrays (NaN where missing), text and phase as object arrays
    (None where missing). Each sample is written once: blocks are copied in, and only the
    stretches no block covers are filled with NaN."""
    where = {seq: (i0, m) for seq, i0, m, _ in pages}
    by_channel: dict[int, list[tuple[int, int, bytes]]] = {ch.id: [] for ch in channels}
    for cid, seq, data in blocks:
        if cid in by_channel:
            i0, m = where[seq]
            by_channel[cid].append((i0, m, data))
    out: dict[str, np.ndarray] = {}
    for ch in channels:
        if ch.kind == "float":
            arr = np.empty(n)
            end = 0
            for i0, m, data in sorted(by_channel[ch.id], key=lambda b: b[0]):
                arr[end:i0] = np.nan
                arr[i0:i0 + m] = decode_float(data)
                end = i0 + m
            arr[end:] = np.nan
        else:
            arr = np.full(n, None, dtype=object)
            if ch.kind == "phase":
                for seq, i0, m, ph in pages:
                    if ph is not None:
                        arr[i0:i0 + m] = ph
            else:
                for i0, m, data in by_channel[ch.id]:
                    arr[i0:i0 + m] = np.array(decode_text(data), dtype=object)
        out[ch.name] = arr
    return out


# --- reading a time range page by page -------------------------------------------------------

@dataclass
class PageShare:
    """What a range read takes from one page: the page (seq, n samples, phase) and the
    positions within it [samples from the page's first] of the samples returned."""
    seq: int
    n: int
    phase: str | None
    keep: np.ndarray


def page_coverage(t_min: float | None, t_max: float | None, n_valid: int | None, n: int,
                  t_start: float | None, t_end: float | None) -> str:
    """How a page whose time channel spans [t_min, t_max] (its block statistics; None when the
    page has no valid time) meets the range [t_start, t_end] (None: open): 'all' when every
    sample is in it, 'none' when no sample is, else 'some' (the time block must be read to
    tell). Without any bound every sample is in range, a missing time included (the whole run
    is asked for); with a bound a missing time is out of it."""
    if t_start is None and t_end is None:
        return "all"
    if t_min is None or t_max is None or not n_valid:
        return "none"
    if (t_start is not None and t_max < t_start) or (t_end is not None and t_min > t_end):
        return "none"
    inside = ((t_start is None or t_min >= t_start) and (t_end is None or t_max <= t_end))
    return "all" if inside and n_valid == n else "some"


def in_range_positions(t: np.ndarray, t_start: float | None, t_end: float | None) -> np.ndarray:
    """Positions of the samples of a time block within [t_start, t_end] (None: open)."""
    mask = np.ones(t.shape, dtype=bool)
    if t_start is not None:
        mask &= t >= t_start
    if t_end is not None:
        mask &= t <= t_end
    return np.flatnonzero(mask).astype(np.int32)


def decimation_stride(n_in_range: int, every: int, max_points: int) -> int:
    """The stride over the samples in range that keeps every `every`-th and then, when more
    than `max_points` are left, decimates further evenly to at most `max_points`."""
    left = -(-n_in_range // every)
    return every * max(1, -(-left // max_points))


def block_values(ch: ChannelRef, share: PageShare, data: bytes | None) -> np.ndarray:
    """The kept samples of one channel on one page from its stored block (None: no block, all
    missing): float64 (NaN = missing) or object (None = missing) for text and phase."""
    if ch.kind == "phase":
        return np.full(share.keep.size, share.phase, dtype=object)
    if ch.kind == "float":
        if data is None:
            return np.full(share.keep.size, np.nan)
        return decode_float(data)[share.keep]
    if data is None:
        return np.full(share.keep.size, None, dtype=object)
    return np.array(decode_text(data), dtype=object)[share.keep]
