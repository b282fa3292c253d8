"""The run store (db/store.py) on SQLite and PostgreSQL: lossless save/load, SQL aggregates equal
numpy's, missing samples counted, listing, migrations matching the models, concurrent
read-modify-write updates."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from db_fixtures import db_url  # noqa: F401  (fixture)

from db.store import RunNotFound, Store
from core.run import RunData

ROOT = Path(__file__).resolve().parents[1]


def sample_run(n: int = 3000, seed: int = 1) -> RunData:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 0.02, n))
    phase = np.array(["idle"] * (n // 5) + ["load"] * (n // 5) + ["hold"] * (n // 5)
                     + ["unload"] * (n // 5) + ["load"] * (n - 4 * (n // 5)), dtype=object)
    phase[10:15] = None                                       # samples without a phase
    df = pd.DataFrame({
        "t": t,
        "q": rng.normal(0.3, 0.01, n),
        "torque": 1e9 + rng.normal(0, 1.0, n),                # large offset, small spread
        "p_hyd": rng.normal(2e7, 2e4, n),
        "phase": pd.Series(phase, dtype=object),
        "strain_7": rng.standard_normal(n),                   # an extra channel
        "note": pd.Series(rng.choice(np.array(["a", "b"], dtype=object), n), dtype=object),
    })
    df.loc[rng.random(n) < 0.05, "q"] = np.nan
    df.loc[100:400, "p_hyd"] = np.nan                         # a dropout
    df["note"] = df["note"].astype(object)
    df.loc[rng.random(n) < 0.1, "note"] = None
    return RunData(samples=df, meta={"scheme": 1, "motor_speed_rpm": 300, "direction": -1,
                                     "rig": "J4-bench", "source": "rig",
                                     "started_at": "2026-11-10T09:00:00Z",
                                     "units": {"strain_7": "µm/m"}, "free": [1, {"a": None}]})


def test_save_load_round_trip(db_url):
    run = sample_run()
    with Store(db_url) as store:
        rid = store.save_run(run, max_page=257)               # many pages, split at phases too
        back = store.load_run(rid)
        pd.testing.assert_frame_equal(back.samples, run.samples)
        assert back.meta == run.meta
        arrays = store.load_arrays(rid, ["q", "phase"])
        assert set(arrays) == {"q", "phase"}
        np.testing.assert_array_equal(arrays["q"], run.channel("q"))
        info = store.run_info(rid)
        assert info["status"] == "finished" and info["n_samples"] == len(run)
        assert info["rig"] == "J4-bench" and info["scheme"] == 1
        assert info["started_at"].isoformat() == "2026-11-10T09:00:00+00:00"
        units = {c["name"]: c["unit"] for c in store.channels(rid)}
        assert units["q"] == "rad" and units["strain_7"] == "µm/m" and units["p_hyd"] == "Pa"
        with pytest.raises(RunNotFound):
            store.load_run(rid + 1000)


def test_phase_aggregates_equal_numpy(db_url):
    run = sample_run()
    df = run.samples
    with Store(db_url) as store:
        rid = store.save_run(run, max_page=300)
        agg = store.phase_aggregates(rid)
        whole = store.phase_aggregates(rid, by_phase=False)
    assert set(agg["channel"]) == {"t", "q", "torque", "p_hyd", "strain_7"}   # numeric only
    phases = df["phase"].to_numpy()
    assert agg["phase"].tolist()[:6] == ["idle", "load", "hold", "unload", None, "idle"]
    for row in agg.to_dict("records"):
        ch, ph = row["channel"], row["phase"]
        sel = np.array([p == ph for p in phases]) if ph is not None else \
            np.array([p is None for p in phases])
        x = df[ch].to_numpy()[sel]
        ok = x[~np.isnan(x)]
        assert row["count"] == len(ok) and row["missing"] == len(x) - len(ok), (ch, ph)
        if len(ok) == 0:
            assert np.isnan(row["mean"])
            continue
        assert row["mean"] == pytest.approx(ok.mean(), rel=1e-12, abs=1e-12)
        assert row["min"] == ok.min() and row["max"] == ok.max()
        if len(ok) > 1:
            assert row["var"] == pytest.approx(ok.var(ddof=1), rel=1e-8), (ch, ph)
    p = whole.set_index("channel").loc["p_hyd"]
    assert p["missing"] == 301 and p["count"] == len(df) - 301
    assert p["var"] == pytest.approx(np.nanvar(df["p_hyd"], ddof=1), rel=1e-8)


def test_list_runs_filters(db_url):
    with Store(db_url) as store:
        a = store.save_run(sample_run(50))
        b_run = sample_run(50)
        b_run.meta.update(scheme=3, source="emulator", rig="emu", motor_speed_rpm=None)
        b = store.save_run(b_run, exit_status="abort", reason="interlock")
        assert [r["id"] for r in store.list_runs()] == [b, a]
        assert [r["id"] for r in store.list_runs(scheme=3)] == [b]
        assert [r["id"] for r in store.list_runs(source="rig")] == [a]
        assert [r["id"] for r in store.list_runs(rig="emu")] == [b]
        assert store.list_runs(limit=1)[0]["exit_status"] == "abort"


def test_migrated_schema_matches_models(db_url):
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    from db.migrate import current, head_revision, upgrade
    from db.models import Base

    assert current(db_url) is None
    assert upgrade(db_url) == head_revision()
    assert upgrade(db_url) == head_revision()                 # idempotent
    with Store(db_url, upgrade=False) as store, store.engine.connect() as conn:
        diff = compare_metadata(MigrationContext.configure(conn), Base.metadata)
    assert diff == []


CONCURRENT = textwrap.dedent("""
    import sys
    import numpy as np
    from db.store import Store
    from db.writer import RunWriter
    url, shared, me = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    store = Store(url)
    w = RunWriter(store, commit_interval_s=0.05)
    w.start({"source": "emulator", "rig": "emu"}, ["q"])
    for j in range(20):
        t = np.arange(j * 100, (j + 1) * 100) * 0.01
        w.append({"t": t, "q": t * 2})
        store.update_run_meta(shared, {f"{me}_{j}": j})      # read-modify-write, contended
    w.stop("success")
    print(w.run_id)
""")


def test_concurrent_writers_lose_nothing(db_url, tmp_path):
    with Store(db_url) as store:
        shared = store.save_run(sample_run(10))
    script = tmp_path / "worker.py"
    script.write_text(CONCURRENT)
    procs = [subprocess.Popen([sys.executable, str(script), db_url, str(shared), f"p{k}"],
                              cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for k in range(3)]
    outs = [p.communicate(timeout=180) for p in procs]
    for p, (out, err) in zip(procs, outs):
        assert p.returncode == 0, err
    with Store(db_url) as store:
        meta = store.run_info(shared)["meta"]
        assert {k for k in meta if k[:1] == "p" and "_" in k} == \
            {f"p{k}_{j}" for k in range(3) for j in range(20)}
        for out, _ in outs:
            rid = int(out.split()[-1])
            info = store.run_info(rid)
            assert (info["status"], info["exit_status"], info["n_samples"]) == ("finished", "success", 2000)
            q = store.load_arrays(rid, ["t", "q"])
            np.testing.assert_array_equal(q["t"], np.arange(2000) * 0.01)
            np.testing.assert_array_equal(q["q"], q["t"] * 2)
        assert len(store.list_runs(rig="emu")) == 3           # one rig row, created concurrently


def test_tokens_stored_hashed(db_url):
    from sqlalchemy import select

    from db.models import ApiToken
    from db.tokens import create_token, hash_token, revoke_token, verify_token

    with Store(db_url) as store:
        token = create_token(store, "ci", ["runs:read"])
        with store.engine.connect() as conn:
            [(stored_hash, prefix)] = conn.execute(select(ApiToken.token_hash, ApiToken.prefix)).all()
        assert stored_hash == hash_token(token) and token not in stored_hash and len(prefix) == 8
        row = verify_token(store, token)
        assert row is not None and row.scopes == ["runs:read"] and row.last_used_at is not None
        assert verify_token(store, token + "x") is None
        assert revoke_token(store, row.id) and not revoke_token(store, row.id)
        assert verify_token(store, token) is None


def test_jobs_results_reports_link_to_runs(db_url):
    from sqlalchemy import select

    from db.models import Job, Report, Result, ResultRun, utcnow
    from estimator.result import Fit

    fit = Fit(model="eq4", method="ls", param_names=["I_xx"], units=["kg·m²"],
              mean=np.array([6685.0]), sd=np.array([10.0]), ci_low=np.array([6665.0]),
              ci_high=np.array([6705.0]), sigma=120.0, rmse_train=119.0)
    with Store(db_url) as store:
        train, test = store.save_run(sample_run(20)), store.save_run(sample_run(20, seed=2))
        with store.Session.begin() as s:
            job = Job(kind="identify", status="done", params={"model": "eq4"}, run_id=train,
                      created_at=utcnow())
            s.add(job)
            s.flush()
            res = Result(job_id=job.id, model=fit.model, method=fit.method, fit=fit.as_dict(),
                         created_at=utcnow())
            s.add(res)
            s.flush()
            s.add_all([ResultRun(result_id=res.id, run_id=train, role="train"),
                       ResultRun(result_id=res.id, run_id=test, role="test"),
                       Report(kind="fit", title="Eq. 4 LS", result_id=res.id, run_id=train,
                              media_type="application/json", content=b"{}", created_at=utcnow())])
            rid = res.id
        with store.ReadSession() as s:
            links = s.execute(select(ResultRun.run_id, ResultRun.role)
                              .where(ResultRun.result_id == rid).order_by(ResultRun.role)).all()
            assert [tuple(x) for x in links] == [(test, "test"), (train, "train")]
            assert s.get(Result, rid).fit["params"][0]["mean"] == 6685.0


def test_save_run_refuses_invalid_run_and_stores_nothing(db_url):
    from core.runfile import RunFileError

    bad = RunData(samples=pd.DataFrame({"t": [0.0, 2.0, 1.0], "q": [1.0, 2.0, 3.0]}),
                  meta={"source": "rig"})
    with Store(db_url) as store:
        with pytest.raises(RunFileError, match="row 3.*'t'"):
            store.save_run(bad)
        with pytest.raises(RunFileError, match="'direction'"):
            store.save_run(RunData(samples=pd.DataFrame({"t": [0.0]}), meta={"direction": 2}))
        assert store.list_runs() == []
