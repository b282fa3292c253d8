"""Fixtures for the API tests: a database holding two emulated scheme-1 runs
(simulators.offline.simulate + Store.save_run), one token per role, and a TestClient on the app
without its worker pool (the job tests start real worker processes themselves). The database is
a SQLite file, and a fresh PostgreSQL schema too when env RIG_TEST_PG_URL names a server
(skipped with the reason otherwise; see db_fixtures). Import: `from api_fixtures import api`."""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import pytest
from db_fixtures import empty_database


@dataclass
class Api:
    client: object
    url: str
    store: object
    runs: dict[str, int]
    tokens: dict[str, str]

    def h(self, role: str | None) -> dict[str, str]:
        """Authorization header of the token of `role` (none for None)."""
        return {"Authorization": f"Bearer {self.tokens[role]}"} if role else {}


def store_runs(store) -> dict[str, int]:
    from core.schemes import Scheme1
    from simulators.config import EmulatorConfig
    from simulators.offline import simulate

    fast = simulate(Scheme1(motor_speed_rpm=3000, direction=1), EmulatorConfig(seed=1),
                    started_at="2026-01-10T08:00:00Z")
    slow = simulate(Scheme1(motor_speed_rpm=300, direction=-1), EmulatorConfig(seed=2),
                    started_at="2026-02-10T08:00:00Z")
    return {"fast": store.save_run(fast, exit_status="success"),
            "slow": store.save_run(slow, exit_status="success")}


@contextmanager
def database(kind: str, tmp_path_factory):
    """URL of an empty database of `kind` ('sqlite' or 'postgresql'), removed afterwards."""
    with empty_database(kind, tmp_path_factory.mktemp("api")) as url:
        yield url


@pytest.fixture(scope="module", params=["sqlite", "postgresql"])
def api(request, tmp_path_factory):
    with database(request.param, tmp_path_factory) as url:
        yield from _api(url)


def _api(url: str):
    from fastapi.testclient import TestClient

    from api.app import create_app
    from api.settings import Settings
    from db.store import Store
    from db.tokens import create_token

    store = Store(url)
    runs = store_runs(store)
    tokens = {r: create_token(store, f"test-{r}", [r]) for r in ("viewer", "operator", "admin")}
    app = create_app(Settings(db_url=url, workers=0, max_body_bytes=64 * 1024))
    with TestClient(app) as client:
        yield Api(client=client, url=url, store=store, runs=runs, tokens=tokens)
    store.close()


def get(api: Api, path: str):
    """GET `path` as a viewer; asserts 200 and returns the JSON body."""
    r = api.client.get(path, headers=api.h("viewer"))
    assert r.status_code == 200, r.text
    return r.json()


def drain(api: Api) -> None:
    """Run every queued job in this process's Worker (the same code the worker process runs)."""
    from api.worker import Worker
    w = Worker(api.url)
    while w.run_once() is not None:
        pass
    w.store.close()


def wait_until_serving(base: str, proc, timeout_s: float = 60.0) -> None:
    """Wait until the `rig serve` process `proc` answers /openapi.json at `base`."""
    import time

    import httpx
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            if httpx.get(f"{base}/openapi.json", timeout=1).status_code == 200:
                return
        except httpx.TransportError:
            pass
        assert proc.poll() is None and time.monotonic() < deadline, "rig serve did not come up"
        time.sleep(0.1)
