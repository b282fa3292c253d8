"""Jobs on a real Dask cluster: a `dask scheduler` and two `dask worker` processes on 127.0.0.1
(random free ports), the service (create_app with its worker pool) pointed at them with
RIG_DASK_SCHEDULER. An identification job (MH, 4 chains) and a sensitivity job succeed with the
same numbers the local path gives for the same seed, and their results name the Dask tasks and
workers that ran the job and each chain / Sobol block; progress advances while the chains run on
the cluster and a cancel stops the job there; a Dask worker killed (SIGKILL) while it runs the job
task and a chain does not lose the job: it ends 'succeeded', run by the surviving worker.
A cancel or the wall-clock limit stops the chain tasks already running in the Dask workers'
threads within seconds (the job's stop Event, polled by the samplers' stop check at most every
EVENT_CHECK_S), not only their futures on the scheduler.
The Dask workers name the database in their own environment (RIG_DB_URL): the URL, password and
all, is never a task argument. A tls:// scheduler is reached with the certificates of the
settings (RIG_DASK_TLS_*), and a client without them is refused."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from api_fixtures import database, store_runs

pytest.importorskip("distributed")

DASK = str(Path(sys.executable).with_name("dask"))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """A scheduler and two workers (no nanny: a killed worker stays dead) on loopback."""

    def __init__(self, tmp: Path, db_url: str, tls: dict[str, str] | None = None,
                 n_workers: int = 2):
        from distributed import Client

        self.address = f"{'tls' if tls else 'tcp'}://127.0.0.1:{free_port()}"
        self.env = {**os.environ, "RIG_DB_URL": db_url}     # the workers' database
        tls_args = ["--tls-ca-file", tls["ca"], "--tls-cert", tls["cert"],
                    "--tls-key", tls["key"]] if tls else []
        self.procs: list[subprocess.Popen] = []
        self.logs = []
        self.procs.append(self._start(tmp, "scheduler", [
            "scheduler", "--host", "127.0.0.1", "--port", self.address.rsplit(":", 1)[1],
            "--no-dashboard", *tls_args]))
        for i in range(n_workers):
            self.procs.append(self._start(tmp, f"worker{i}", [
                "worker", self.address, "--host", "127.0.0.1", "--nthreads", "1", "--no-nanny",
                "--no-dashboard", "--name", f"w{i}", "--local-directory", str(tmp / f"w{i}"),
                "--death-timeout", "60", *tls_args]))
        security = None
        if tls:
            from distributed.security import Security
            security = Security(tls_ca_file=tls["ca"], tls_client_cert=tls["cert"],
                                tls_client_key=tls["key"], require_encryption=True)
        self.client = Client(self.address, timeout=30, set_as_default=False, security=security)
        self.client.wait_for_workers(n_workers, timeout=60)
        self.pids = self.client.run(os.getpid)          # worker address -> pid
        assert all(a.startswith(self.address.split("//")[0] + "//127.0.0.1:")
                   for a in self.pids), self.pids       # loopback

    def _start(self, tmp: Path, name: str, args: list[str]) -> subprocess.Popen:
        log = open(tmp / f"{name}.log", "w")
        self.logs.append(log)
        return subprocess.Popen([DASK, *args], stdout=log, stderr=subprocess.STDOUT,
                                cwd=tmp, start_new_session=True, env=self.env)

    def kill_worker(self, address: str) -> None:
        os.kill(self.pids[address], signal.SIGKILL)

    def close(self) -> None:
        self.client.close()
        for p in reversed(self.procs):
            if p.poll() is None:
                p.terminate()
        for p in self.procs:
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        for log in self.logs:
            log.close()


@pytest.fixture(scope="module")
def db_url(tmp_path_factory):
    """The service's database (SQLite), which the Dask workers are told by RIG_DB_URL."""
    with database("sqlite", tmp_path_factory) as url:
        yield url


@pytest.fixture(scope="module")
def cluster(tmp_path_factory, db_url):
    c = Cluster(tmp_path_factory.mktemp("dask"), db_url)
    try:
        yield c
    finally:
        c.close()


@pytest.fixture(scope="module")
def svc(cluster, db_url):
    """The service on a SQLite database with two stored runs, RIG_DASK_SCHEDULER set for its
    worker processes; yields (client, headers, store, runs)."""
    from fastapi.testclient import TestClient

    from api.app import create_app
    from api.settings import Settings
    from db.store import Store
    from db.tokens import create_token

    old = os.environ.get("RIG_DASK_SCHEDULER")
    os.environ["RIG_DASK_SCHEDULER"] = cluster.address
    try:
        store = Store(db_url)
        runs = store_runs(store)
        token = create_token(store, "dask-test", ["operator"])
        st = Settings.from_env(db_url=db_url, workers=2, job_heartbeat_s=0.5)
        assert st.dask_scheduler == cluster.address
        with TestClient(create_app(st)) as client:
            yield client, {"Authorization": f"Bearer {token}"}, store, runs
        store.close()
    finally:
        if old is None:
            os.environ.pop("RIG_DASK_SCHEDULER", None)
        else:
            os.environ["RIG_DASK_SCHEDULER"] = old


def submit(svc, kind: str, params: dict) -> int:
    client, h, _, _ = svc
    r = client.post("/jobs", json={"kind": kind, "params": params}, headers=h)
    assert r.status_code == 202, r.text
    return r.json()["id"]


def job(svc, jid: int) -> dict:
    client, h, _, _ = svc
    r = client.get(f"/jobs/{jid}", headers=h)
    assert r.status_code == 200, r.text
    return r.json()


def wait_final(svc, jid: int, timeout_s: float = 90.0) -> dict:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        j = job(svc, jid)
        if j["state"] in ("succeeded", "failed", "cancelled"):
            return j
        time.sleep(0.1)
    raise AssertionError(f"job {jid} did not end: {j}")


def results(svc, jid: int) -> list[dict]:
    client, h, _, _ = svc
    r = client.get(f"/jobs/{jid}/results", headers=h)
    assert r.status_code == 200, r.text
    return r.json()


def local_reference(svc, kind: str, params: dict):
    """The same job kind run here, chains and blocks through builtin `map` (the local path)."""
    from api.job_kinds import KINDS

    k = KINDS[kind]
    return k.run(svc[2], k.params.model_validate(params), lambda x: None, map_fn=map)[0].fit


def processing(cluster) -> dict[str, list[str]]:
    return {a: [str(k) for k in ks] for a, ks in cluster.client.processing().items()}


def test_an_unreachable_scheduler_leaves_jobs_queued(tmp_path_factory, monkeypatch):
    from api import dask_backend
    from db import jobs as queue
    from api.worker import Worker

    monkeypatch.setattr(dask_backend, "CONNECT_TIMEOUT_S", 1.0)
    with database("sqlite", tmp_path_factory) as url:
        w = Worker(url, dask_scheduler=f"tcp://127.0.0.1:{free_port()}")   # nobody listens
        try:
            j, _ = queue.submit(w.store, "identification",
                                {"run_ids": [], "model": "eq4", "method": "ls"})
            assert w.run_once() is None and w.dask is None
            assert queue.get_job(w.store, j["id"])["state"] == "queued"
        finally:
            w.close()


def test_identification_runs_on_the_cluster_and_matches_the_local_path(svc, cluster):
    params = {"run_ids": [svc[3]["fast"]], "model": "eq4", "method": "mh",
              "options": {"chains": 4, "draws": 2000, "warmup": 500, "seed": 7}}
    jid = submit(svc, "identification", params)
    j = wait_final(svc, jid)
    assert j["state"] == "succeeded", j["error"]
    fit = results(svc, jid)[0]["fit"]
    where = fit["extra"]["dask"]
    workers = set(cluster.pids)
    assert where["scheduler"] == cluster.address
    assert where["job_worker"] in workers and where["job_task"].startswith(f"rig-job{jid}-")
    chains = [t for t in where["tasks"] if "-run_chain-" in t["key"]]
    assert len(chains) == 4 and {t["worker"] for t in chains} <= workers
    assert fit["diagnostics"]["chains"] == 4 and len(fit["diagnostics"]["rhat"]) == 5
    assert fit["extra"]["sampler"]["independent_chains"] == 4

    ref = local_reference(svc, "identification", params)
    np.testing.assert_allclose([p["mean"] for p in fit["params"]], ref.mean, rtol=1e-12)
    np.testing.assert_allclose([p["sd"] for p in fit["params"]], ref.sd, rtol=1e-12)
    np.testing.assert_allclose(fit["diagnostics"]["rhat"], ref.diagnostics["rhat"], rtol=1e-12)


def test_sensitivity_spreads_chains_and_sobol_blocks_and_matches_local(svc, cluster):
    params = {"run_ids": [svc[3]["fast"]], "model": "eq4", "method": "mh", "n_base": 256,
              "max_rows": 500, "options": {"chains": 2, "draws": 1000, "warmup": 500, "seed": 3}}
    jid = submit(svc, "sensitivity", params)
    j = wait_final(svc, jid)
    assert j["state"] == "succeeded", j["error"]
    fit = results(svc, jid)[0]["fit"]
    tasks = fit["extra"]["dask"]["tasks"]
    blocks = [t for t in tasks if "-lambda-" in t["key"]]
    assert len([t for t in tasks if "-run_chain-" in t["key"]]) == 2
    assert len(blocks) == 4            # 256·(5 + 2) = 1792 design rows in blocks of 512
    assert {t["worker"] for t in tasks} <= set(cluster.pids)

    ref = local_reference(svc, "sensitivity", params)
    got = fit["extra"]["sobol"]
    assert got["name"] == ref.extra["sobol"]["name"]
    for col in ("S1", "ST", "S1_conf", "ST_conf"):
        np.testing.assert_allclose(got[col], ref.extra["sobol"][col], rtol=1e-9, atol=1e-12)


def test_a_job_that_raises_on_the_cluster_ends_failed_with_its_error(svc):
    jid = submit(svc, "identification", {"run_ids": [svc[3]["fast"]], "model": "eq4+nosuch",
                                         "method": "ls"})
    j = wait_final(svc, jid)
    assert j["state"] == "failed" and "nosuch" in j["error"] and j["result_ids"] == []


LONG = {"model": "eq4", "method": "mh",
        "options": {"chains": 4, "draws": 2000, "warmup": 40000, "seed": 11}}
"""An MH job whose chains take a second or two each here (a long warm-up: cheap to store)."""


def wait_for_chains(svc, cluster, jid: int, timeout_s: float = 60.0):
    """(job task's worker, progress seen) once a chain of job `jid` runs on the cluster."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        proc = processing(cluster)
        job_at = [a for a, ks in proc.items() if any(k.startswith(f"rig-job{jid}-attempt")
                                                   for k in ks)]
        chains = [k for ks in proc.values() for k in ks
                  if k.startswith(f"rig-job{jid}-run_chain-")]
        if job_at and chains:
            return job_at[0]
        time.sleep(0.05)
    raise AssertionError(f"no chain of job {jid} ran: {processing(cluster)}, {job(svc, jid)}")


def test_progress_and_cancel_while_chains_run_on_the_cluster(svc, cluster):
    client, h, _, runs = svc
    jid = submit(svc, "identification", {"run_ids": [runs["fast"]], **LONG})
    wait_for_chains(svc, cluster, jid)
    seen = set()
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not any(0.2 < p < 0.9 for p in seen):
        seen.add(job(svc, jid)["progress"] or 0.0)      # a chain came back: progress between phases
        time.sleep(0.05)
    assert any(0.2 < p < 0.9 for p in seen), seen
    r = client.post(f"/jobs/{jid}/cancel", headers=h)
    assert r.status_code == 200 and r.json()["state"] == "cancelled"
    deadline = time.monotonic() + 30        # the job's tasks leave the cluster
    while time.monotonic() < deadline and any(
            k.startswith(f"rig-job{jid}-") for ks in processing(cluster).values() for k in ks):
        time.sleep(0.1)
    left = [k for ks in processing(cluster).values() for k in ks if k.startswith(f"rig-job{jid}-")]
    assert left == []
    j = job(svc, jid)
    assert j["state"] == "cancelled" and j["result_ids"] == []


def test_a_killed_dask_worker_does_not_lose_the_job(svc, cluster):
    jid = submit(svc, "identification", {"run_ids": [svc[3]["fast"]], **LONG})
    victim = wait_for_chains(svc, cluster, jid)
    survivor = (set(cluster.pids) - {victim}).pop()
    cluster.kill_worker(victim)                      # SIGKILL mid-job: job task and a chain
    j = wait_final(svc, jid, timeout_s=120)
    assert j["state"] == "succeeded", j["error"]
    assert j["attempts"] == 1                        # Dask re-ran the tasks; SQL never re-queued
    fit = results(svc, jid)[0]["fit"]
    where = fit["extra"]["dask"]
    assert where["job_worker"] == survivor
    chains = [t for t in where["tasks"] if "-run_chain-" in t["key"]]
    assert len(chains) == 4 and {t["worker"] for t in chains} == {survivor}
    assert fit["diagnostics"]["chains"] == 4 and max(fit["diagnostics"]["rhat"]) < 1.05


# --- no database URL in task arguments; TLS -----------------------------------------------------

class _Progress:
    """What DaskJobs.run needs of a JobProgress: the claiming worker's name and a check."""
    worker = "test-claimer"

    def check(self) -> None:
        pass


def test_the_database_url_is_never_a_task_argument(cluster, svc):
    """A service whose URL holds a password submits a job: the task's arguments carry the URL
    masked, never the password; the Dask worker opens its own RIG_DB_URL and, that being
    another database, refuses with both named (masked)."""
    from api.dask_backend import DaskJobs

    secret_url = "postgresql+psycopg://rig:S3CRET-pw@127.0.0.1:1/rig"
    jobs = DaskJobs(cluster.address, secret_url)
    sent = []
    real_submit = jobs.client.submit

    def recording_submit(fn, *args, **kwargs):
        sent.append((fn, args, kwargs))
        return real_submit(fn, *args, **kwargs)
    jobs.client.submit = recording_submit
    try:
        job = {"id": 999_999, "kind": "identification", "attempts": 1,
               "params": {"run_ids": [svc[3]["fast"]], "model": "eq4", "method": "ls"}}
        with pytest.raises(RuntimeError) as err:
            jobs.run(job, _Progress())
    finally:
        jobs.close()
    (fn, args, kwargs), = sent
    import pickle
    assert b"S3CRET" not in pickle.dumps((args, kwargs))
    assert "postgresql+psycopg://rig:***@127.0.0.1:1/rig" in args
    msg = str(err.value)
    assert "RIG_DB_URL" in msg and "***" in msg and "S3CRET" not in msg


def _self_signed(tmp: Path) -> dict[str, str]:
    """A self-signed certificate (its own CA) and key for 127.0.0.1, made with openssl."""
    import shutil

    if shutil.which("openssl") is None:
        pytest.skip("openssl is needed to make the test certificates")
    cert, key = tmp / "cert.pem", tmp / "key.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
                    "-subj", "/CN=rig-test", "-keyout", str(key), "-out", str(cert),
                    "-addext", "basicConstraints=critical,CA:TRUE",
                    "-addext", "subjectAltName=IP:127.0.0.1"],
                   check=True, capture_output=True)
    return {"ca": str(cert), "cert": str(cert), "key": str(key)}


def test_a_tls_scheduler_is_reached_with_the_certificates_of_the_settings(
        tmp_path_factory, db_url, monkeypatch):
    from distributed import Client

    from api.dask_backend import DaskJobs
    from api.settings import Settings

    tmp = tmp_path_factory.mktemp("dask-tls")
    tls = _self_signed(tmp)
    c = Cluster(tmp, db_url, tls=tls, n_workers=1)
    try:
        monkeypatch.setenv("RIG_DASK_TLS_CA", tls["ca"])
        monkeypatch.setenv("RIG_DASK_TLS_CERT", tls["cert"])
        monkeypatch.setenv("RIG_DASK_TLS_KEY", tls["key"])
        sec = Settings.from_env(dask_scheduler=c.address).dask_security()
        assert sec.require_encryption and sec.tls_ca_file == tls["ca"]
        jobs = DaskJobs(c.address, db_url)           # Security from RIG_DASK_TLS_*
        try:
            assert jobs.client.submit(sum, [1, 2], pure=False).result(timeout=30) == 3
            assert jobs.client.scheduler.address.startswith("tls://")
        finally:
            jobs.close()
        with pytest.raises((OSError, TimeoutError)):   # no certificate: refused
            Client(c.address.replace("tls://", "tcp://"), timeout=3, set_as_default=False)
    finally:
        c.close()


VERY_LONG = {"model": "eq4", "method": "mh",
             "options": {"chains": 4, "draws": 200_000, "warmup": 200_000, "seed": 13}}
"""An MH job whose chains take far longer (tens of seconds each here) than a stop may take."""

STOPPED_WITHIN_S = 3.0
"""How soon after a stop no chain of the job may still run in a Dask worker's thread [s]
(the stop takes ~0.5 s: the watchdog's read, the wait loop's look, the tasks' Event check)."""


def chains_running(cluster, jid: int) -> list[str]:
    """The chain tasks of job `jid` that a Dask worker thread is executing now, as the workers
    themselves see it (a task cancelled on the scheduler may still run in its thread)."""
    def executing(dask_worker) -> list[str]:
        with dask_worker.active_threads_lock:
            return [str(k) for k in dask_worker.active_threads.values()]
    return [k for ks in cluster.client.run(executing).values() for k in ks
            if k.startswith(f"rig-job{jid}-run_chain-")]


def wait_until_no_chain_runs(cluster, jid: int, timeout_s: float) -> tuple[float, list[str]]:
    """(seconds waited, chains still running) once no chain of job `jid` runs, or at timeout."""
    t0 = time.monotonic()
    left = chains_running(cluster, jid)
    while left and time.monotonic() - t0 < timeout_s:
        time.sleep(0.05)
        left = chains_running(cluster, jid)
    return time.monotonic() - t0, left


def test_a_cancel_stops_the_chains_running_on_the_dask_workers(svc, cluster):
    """Cancelled while its chains run: the job ends 'cancelled' and every chain task stops in
    its worker's thread within STOPPED_WITHIN_S (it polls the job's stop Event), instead of
    running its chain to the end."""
    client, h, _, runs = svc
    jid = submit(svc, "identification", {"run_ids": [runs["fast"]], **VERY_LONG})
    wait_for_chains(svc, cluster, jid)
    deadline = time.monotonic() + 30
    while not chains_running(cluster, jid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert chains_running(cluster, jid), processing(cluster)
    r = client.post(f"/jobs/{jid}/cancel", headers=h)
    assert r.status_code == 200 and r.json()["state"] == "cancelled"
    waited, left = wait_until_no_chain_runs(cluster, jid, timeout_s=60)
    assert left == [] and waited < STOPPED_WITHIN_S, (waited, left)
    j = job(svc, jid)
    assert j["state"] == "cancelled" and j["result_ids"] == []


def test_a_wall_clock_limit_stops_the_chains_running_on_the_dask_workers(svc, cluster, db_url):
    """The claiming worker's stop flag set for the wall-clock limit while the job's chains run
    on the cluster: DaskJobs.run ends with JobTimeLimit and the chain tasks stop within
    STOPPED_WITHIN_S; the job's stop Event is cleared on the scheduler after STOP_LINGER_S."""
    import threading

    from api import dask_backend
    from api.dask_backend import DaskJobs
    from api.job_kinds import JobTimeLimit
    from api.job_runtime import JobProgress, StopFlag
    from db import jobs as queue
    from db.store import Store

    store = Store(db_url, upgrade=False, recover=False)
    jobs = DaskJobs(cluster.address, db_url)
    try:
        me = queue.worker_name()
        for _ in range(5):          # claimed here, unless the service's pool took it first
            queued, _ = queue.submit(store, "identification",
                                     {"run_ids": [svc[3]["fast"]], **VERY_LONG})
            claimed = queue.claim(store, me)
            if claimed is not None and claimed["id"] == queued["id"]:
                break
            queue.cancel(store, queued["id"])
        assert claimed is not None and claimed["id"] == queued["id"], claimed
        jid = claimed["id"]
        flag = StopFlag()
        progress = JobProgress(store, jid, me, stop=flag)
        out: list = []

        def run() -> None:
            try:
                out.append(jobs.run(claimed, progress))
            except BaseException as e:
                out.append(e)
        t = threading.Thread(target=run, daemon=True)
        t.start()
        deadline = time.monotonic() + 60
        while not chains_running(cluster, jid) and time.monotonic() < deadline:
            queue.heartbeat(store, jid, me)
            time.sleep(0.1)
        assert chains_running(cluster, jid), processing(cluster)
        flag.set(JobTimeLimit("the job ran past its wall-clock limit of 1 s and was stopped"))
        waited, left = wait_until_no_chain_runs(cluster, jid, timeout_s=60)
        t.join(10)
        assert len(out) == 1 and isinstance(out[0], JobTimeLimit), out
        assert left == [] and waited < STOPPED_WITHIN_S, (waited, left)
        stopped = [name for _, name in jobs.stopped]
        assert len(stopped) == 1 and stopped[0].startswith(f"rig-job{jid}-stop-")
        assert cluster.client.sync(cluster.client.scheduler.event_is_set, name=stopped[0])
        jobs.clear_stop_events(time.monotonic() + dask_backend.STOP_LINGER_S + 1)
        assert jobs.stopped == []
        assert not cluster.client.sync(cluster.client.scheduler.event_is_set, name=stopped[0])
        queue.cancel(store, jid)
    finally:
        jobs.close()
        store.close()


def test_the_event_stop_check_asks_the_scheduler_at_most_once_per_interval(monkeypatch):
    """EventStop, called every sampler iteration, asks the scheduler once per interval (not
    once per call), goes on while the Event is not set, and raises JobCancelled (every call)
    once it is seen set."""
    from api.dask_backend import EventStop
    from api.job_kinds import JobCancelled

    asked: list[bool] = []
    answer = [False]

    def is_set(self) -> bool:
        asked.append(answer[0])
        return answer[0]
    monkeypatch.setattr(EventStop, "_is_set", is_set)
    check = EventStop("rig-job1-stop-test", every_s=3600.0)
    for _ in range(10_000):
        check()
    assert asked == [False]
    answer[0] = True
    check._next = 0.0                        # the interval is over
    for _ in range(3):
        with pytest.raises(JobCancelled, match="rig-job1-stop-test"):
            check()
    assert asked == [False, True]
