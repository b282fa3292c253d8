"""Store.select_range / range_values: a time range of some channels is read page by page, only
the pages holding samples of the range, and returns exactly what cutting the whole run would
(every n-th sample in range, decimated further to at most max_points)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from db_fixtures import db_url  # noqa: F401  (fixture)

import db.store as store_module
from core.run import RunData
from db.store import RunNotFound, Store

N = 6000
PAGE = 250


def _run(seed: int = 0) -> RunData:
    rng = np.random.default_rng(seed)
    t = np.arange(N) * 1e-3
    q = rng.normal(size=N)
    q[rng.random(N) < 0.05] = np.nan
    phase = np.array(["load"] * 1000 + ["hold"] * 3500 + ["unload"] * 1500, dtype=object)
    note = np.array([None if k % 7 else f"n{k}" for k in range(N)], dtype=object)
    df = pd.DataFrame({"t": t, "q": q, "torque": rng.normal(size=N) * 1e3, "phase": phase,
                       "note": note})
    return RunData(samples=df, meta={"scheme": 1, "source": "emulator"})


def _expected(arrays, names, t_start, t_end, every, max_points):
    t = arrays["t"]
    mask = np.ones(t.shape, dtype=bool)
    if t_start is not None:
        mask &= t >= t_start
    if t_end is not None:
        mask &= t <= t_end
    idx = np.flatnonzero(mask)[::every]
    step = max(1, int(np.ceil(idx.size / max_points)))
    return idx[::step], every * step, int(mask.sum())


def _read(store, rid, names, *args):
    sel = store.select_range(rid, names, *args)
    return sel, {ch.name: (np.concatenate(list(store.range_values(sel, ch, pages_per_read=3)))
                           if sel.pages else np.zeros(0)) for ch in sel.channels}


@pytest.fixture
def counted(monkeypatch):
    """Every (channel_id, seq) block the store fetches for a range read."""
    seen: list[tuple[int, int]] = []
    real = store_module.fetch_page_blocks

    def counting(conn, run_id, channel_ids, seqs):
        rows = real(conn, run_id, channel_ids, seqs)
        seen.extend((r[0], r[1]) for r in rows)
        return rows
    monkeypatch.setattr(store_module, "fetch_page_blocks", counting)
    return seen


def test_range_read_equals_cutting_the_whole_run(db_url):
    with Store(db_url) as store:
        for seed in (0, 1):
            rid = store.save_run(_run(seed), max_page=PAGE)
            full = store.load_arrays(rid)
            cases = [(None, None, 1, 10**6), (None, None, 7, 100), (1.0, 2.0, 1, 10**6),
                     (0.9995, 3.2504, 3, 50), (-5.0, 0.0005, 1, 10**6), (2.6, 2.6005, 1, 1),
                     (5.99, None, 2, 10**6), (None, 0.3, 1, 7), (10.0, 20.0, 1, 5),
                     (2.0, 1.0, 1, 5)]
            for names in (None, ["t", "q"], ["t", "phase", "note", "torque"]):
                for t_start, t_end, every, max_points in cases:
                    sel, got = _read(store, rid, names, t_start, t_end, every, max_points)
                    idx, stride, in_range = _expected(full, names, t_start, t_end, every,
                                                      max_points)
                    want = list(full) if names is None else names
                    assert [ch.name for ch in sel.channels] == want
                    assert sel.n == idx.size and sel.every == stride
                    assert sel.n_in_range == in_range
                    for name in want:
                        if full[name].dtype == object:
                            assert list(got[name]) == list(full[name][idx]), name
                        else:
                            np.testing.assert_array_equal(got[name], full[name][idx])


def test_narrow_range_of_one_channel_reads_only_its_pages(db_url, counted):
    with Store(db_url) as store:
        rid = store.save_run(_run(), max_page=PAGE)
        n_pages = store.run_info(rid)["n_pages"]
        n_channels = len(store.channels(rid))
        assert n_pages >= N // PAGE
        counted.clear()
        sel, got = _read(store, rid, ["t", "q"], 3.1, 3.3, 1, 10**6)
        assert got["t"].size == 200 and got["t"][0] == 3.1 and got["t"][-1] < 3.3
        seqs = {seq for _, seq in counted}
        assert len(seqs) <= 2 and len(counted) <= 2 * 3     # t to cut the range, then t and q
        # the whole run of every channel would have been n_pages * (n_channels - phase)
        assert len(counted) < n_pages * (n_channels - 1) / 10


def test_errors(db_url):
    with Store(db_url) as store:
        rid = store.save_run(_run(), max_page=PAGE)
        with pytest.raises(RunNotFound):
            store.select_range(rid + 1)
        with pytest.raises(KeyError, match="nope"):
            store.select_range(rid, ["t", "nope"])
        with pytest.raises(ValueError):
            store.select_range(rid, every=0)
