"""Identification on stored runs through the command line, end to end on a temporary database
(SQLite, and PostgreSQL when RIG_TEST_PG_URL is set): `rig import` run files, `rig identify
ID... --test ID` stores each fit with its runs (the `results` rows the API's identification jobs
write), `rig fits` lists them, `rig show RUN` names those made on a run, `rig export --fit ID`
writes one as JSON."""

from __future__ import annotations

import json

import numpy as np
import pytest
from db_fixtures import db_url  # noqa: F401  (fixture)
from estimator_synth import eq4_run

from commands.cli import COMMANDS, main
from core.runfile import write_run
from db.store import Store


def rig(*argv: str) -> int:
    """Run `rig ARGV...` in-process through commands.cli.main."""
    assert argv[0] in COMMANDS
    return main(list(argv))


@pytest.fixture
def campaign(db_url, tmp_path, monkeypatch, capsys):  # noqa: F811
    """Three synthetic Eq. 4 runs written as run files and imported into a fresh database (a
    SQLite file; a PostgreSQL schema too when RIG_TEST_PG_URL is set) named by RIG_DB_URL, as a
    user would."""
    url = db_url
    monkeypatch.setenv("RIG_DB_URL", url)
    files = []
    for seed in (1, 2, 3):
        stem = tmp_path / f"run{seed}"
        write_run(eq4_run(seed, duration=30.0, t0=30.0 * seed), stem, fmt="csv")
        files.append(str(stem) + ".csv")
    assert rig("import", *files, "--json") == 0
    ids = [r["run_id"] for r in json.loads(capsys.readouterr().out)]
    return {"url": url, "files": files, "ids": [str(i) for i in ids], "tmp": tmp_path}


def _json(capsys):
    return json.loads(capsys.readouterr().out)


def test_identify_stored_runs_stores_fits_listed_shown_and_exported(campaign, capsys):
    a, b, c = campaign["ids"]
    assert rig("identify", a, b, "--test", c, "--model", "eq4", "--method", "ls,exact",
               "--draws", "300", "--json") == 0
    ls, exact = _json(capsys)
    assert ls["method"] == "ls" and exact["method"] == "exact"
    fit_ids = [ls["fit_id"], exact["fit_id"]]
    assert fit_ids[0] != fit_ids[1]

    # the same numbers as on the run files: a stored run is the run it was imported from
    assert rig("identify", *campaign["files"][:2], "--test", campaign["files"][2],
               "--method", "ls", "--json") == 0
    from_files = _json(capsys)
    assert "fit_id" not in from_files                       # files: nothing stored
    np.testing.assert_allclose([p["mean"] for p in ls["params"]],
                               [p["mean"] for p in from_files["params"]], rtol=1e-12)
    assert ls["rmse_test"] == pytest.approx(from_files["rmse_test"], rel=1e-12)

    # rig fits: newest first, with their runs and roles
    assert rig("fits", "--json") == 0
    listed = _json(capsys)
    assert [f["id"] for f in listed] == fit_ids[::-1]
    roles = {(r["run_id"], r["role"]) for r in listed[0]["runs"]}
    assert roles == {(int(a), "train"), (int(b), "train"), (int(c), "test")}
    assert all(f["job_id"] is None for f in listed)
    assert listed[1]["rmse_test"] == pytest.approx(ls["rmse_test"])
    assert rig("fits", "--method", "exact", "--json") == 0
    assert [f["id"] for f in _json(capsys)] == [exact["fit_id"]]
    assert rig("fits", "--model", "eq11", "--json") == 0
    assert _json(capsys) == []
    assert rig("fits") == 0
    text = capsys.readouterr().out
    assert f"train:{a},{b} test:{c}" in text and "exact" in text

    # rig show RUN names the fits made on it, with the run's role
    assert rig("show", c, "--json") == 0
    shown = _json(capsys)["fits"]
    assert [(f["id"], f["role"]) for f in shown] == [(fit_ids[1], "test"), (fit_ids[0], "test")]
    assert rig("show", a) == 0
    out = capsys.readouterr().out
    assert "fits made on this run (2" in out and "train" in out

    # rig export --fit ID: the stored Fit summary, its runs, its draws on request
    out_dir = campaign["tmp"] / "exported"
    assert rig("export", "--fit", str(exact["fit_id"]), "--draws", "--out", str(out_dir)) == 0
    path = capsys.readouterr().out.strip()
    doc = json.loads(open(path).read())
    assert doc["id"] == exact["fit_id"] and doc["job_id"] is None
    assert doc["fit"]["params"] == exact["params"]
    assert np.asarray(doc["draws"]).shape == tuple(doc["draws_shape"]) == (4, 300, 5)
    np.testing.assert_allclose(np.asarray(doc["draws"]).mean(axis=(0, 1)),
                               [p["mean"] for p in exact["params"]], rtol=1e-9)
    assert doc["fit"]["extra"]["identify_options"]["model"] == "eq4"
    series = doc["fit"]["extra"]["series"]                 # what the job report's figure draws
    assert set(series["run_id"]) == {int(a), int(b), int(c)}
    assert rig("export", "--fit", "999", "--out", str(out_dir)) == 1
    assert rig("export", "--out", str(out_dir)) == 2       # neither a run nor a fit


def test_cli_fit_is_the_record_an_identification_job_writes(campaign, capsys):
    """A fit stored by `rig identify` and the same fit stored by an API identification job are
    the same rows: same Fit summary (the job's extra keys too), same run links, found by the
    API's own readers (db.jobs.results_for_run)."""
    from api.job_kinds import IdentificationParams, run_identification
    from db import jobs as queue
    from db.fits import get_fit

    a, b, c = campaign["ids"]
    assert rig("identify", a, b, "--test", c, "--method", "ls", "--json") == 0
    cli_id = _json(capsys)["fit_id"]
    with Store(campaign["url"]) as store:
        params = IdentificationParams(run_ids=[int(a), int(b)], test_run_ids=[int(c)],
                                      model="eq4", method="ls")
        job, _ = queue.submit(store, "identification", params.model_dump())
        claimed = queue.claim(store, worker="test/1/x")
        assert claimed["id"] == job["id"]
        results = run_identification(store, params, lambda p: None)
        assert queue.finish(store, job["id"], "test/1/x", results)
        job_fit = queue.results_of(store, job["id"])[0]
        cli_fit = get_fit(store, cli_id)
        on_c = queue.results_for_run(store, int(c))
    assert {r["result_id"] for r in on_c} == {cli_id, job_fit["id"]}
    assert next(r for r in on_c if r["result_id"] == cli_id)["job_id"] is None
    assert sorted(map(tuple, (r.values() for r in cli_fit["runs"]))) == \
        sorted(map(tuple, (r.values() for r in job_fit["runs"])))
    assert cli_fit["fit"]["params"] == job_fit["fit"]["params"]
    assert set(job_fit["fit"]["extra"]) <= set(cli_fit["fit"]["extra"])
    assert cli_fit["fit"]["extra"]["series"] == job_fit["fit"]["extra"]["series"]
    assert rig("fits", "--run", c, "--json") == 0
    assert [f["job_id"] for f in _json(capsys)] == [job["id"], None]


def test_files_unknown_ids_and_no_store_store_nothing(campaign, capsys):
    a, b, c = campaign["ids"]
    assert rig("identify", a, campaign["files"][1], "--method", "ls") == 0
    captured = capsys.readouterr()
    assert "fit not stored" in captured.err and "is a file" in captured.err
    assert rig("identify", a, b, "--method", "ls", "--no-store", "--json") == 0
    assert "fit_id" not in _json(capsys)
    assert rig("identify", a, "99", "--method", "ls") == 2
    assert "no stored run 99" in capsys.readouterr().err
    assert rig("fits", "--json") == 0
    assert _json(capsys) == []
    assert rig("show", a, "--json") == 0
    assert _json(capsys)["fits"] == []


def test_identify_reads_the_database_given_by_db_over_the_environment(campaign, tmp_path,
                                                                       monkeypatch, capsys):
    monkeypatch.setenv("RIG_DB_URL", f"sqlite:///{tmp_path / 'other.sqlite'}")
    a, b, _ = campaign["ids"]
    assert rig("identify", a, b, "--method", "ls") == 2     # not in the environment's database
    capsys.readouterr()
    assert rig("identify", a, b, "--method", "ls", "--db", campaign["url"], "--json") == 0
    fit_id = _json(capsys)["fit_id"]
    assert rig("fits", "--db", campaign["url"], "--json") == 0
    assert [f["id"] for f in _json(capsys)] == [fit_id]
