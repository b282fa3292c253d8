"""The run and job report pages opened in a real headless browser (Debian `chromium`): they render
with their plots (the plots' colours are on the screenshot) and log no console message.
Screenshots are saved in env RIG_TEST_ARTIFACTS (default: the test's tmp dir).
Skipped with the reason when chromium is not installed (`apt-get install chromium`)."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium "
                                                         "(apt-get install chromium)")


@pytest.fixture(scope="module")
def sqlite_api(tmp_path_factory):
    from api_fixtures import _api, database
    with database("sqlite", tmp_path_factory) as url:
        yield from _api(url)


def screenshot(html: str, out: Path, height: int) -> tuple[np.ndarray, str]:
    """Open `html` (a self-contained page) in headless chromium; returns the screenshot as an
    RGB array and chromium's log (console messages appear as ':INFO:CONSOLE')."""
    page = out.with_suffix(".html")
    page.write_text(html, encoding="utf-8")
    proc = subprocess.run(
        [CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
         "--no-first-run", "--disable-extensions", "--enable-logging=stderr", "--v=0",
         f"--window-size=1280,{height}", f"--screenshot={out}", page.as_uri()],
        capture_output=True, text=True, timeout=120)
    assert out.exists(), proc.stderr[-3000:]
    import matplotlib.image as mpimg
    return mpimg.imread(out)[..., :3], proc.stderr


def plot_pixels(img: np.ndarray) -> int:
    """Strongly coloured pixels (max − min channel > 0.15): only the plots' lines, bars and
    points; text, tables and the pass/fail row tints are grey or pale."""
    return int(((img.max(axis=-1) - img.min(axis=-1)) > 0.15).sum())


def _artifacts(tmp_path: Path) -> Path:
    d = Path(os.environ.get("RIG_TEST_ARTIFACTS") or tmp_path)
    d.mkdir(parents=True, exist_ok=True)
    return d


@pytest.mark.slow
def test_run_and_job_reports_render_in_chromium(sqlite_api, tmp_path):
    from api.worker import Worker

    api = sqlite_api
    h = api.h("viewer")
    r = api.client.post("/jobs", headers=api.h("operator"), json={
        "kind": "identification",
        "params": {"run_ids": [api.runs["fast"]], "model": "eq4", "method": "exact",
                   "options": {"draws": 400}}})
    w = Worker(api.url)
    assert w.run_once() == r.json()["id"]
    w.store.close()
    d = _artifacts(tmp_path)
    pages = {"run": api.client.get(f"/reports/runs/{api.runs['fast']}/html", headers=h).text,
             "job": api.client.get(f"/reports/jobs/{r.json()['id']}/html", headers=h).text}
    for name, html in pages.items():
        img, log = screenshot(html, d / f"report_{name}.png", height=5000)
        console = [line for line in log.splitlines() if ":CONSOLE" in line]
        assert console == [], console
        assert img.shape[0] == 5000 and plot_pixels(img) > 20_000, name
    # the check can fail: a page whose figures do not load has no plot colour
    broken = pages["run"].replace("data:image/svg+xml;base64,", "data:image/svg+xml;base64,AAAA")
    img, _ = screenshot(broken, d / "report_broken.png", height=5000)
    assert plot_pixels(img) < 2_000


@pytest.mark.slow
def test_diagnosis_report_renders_in_chromium(sqlite_api, tmp_path):
    """A diagnosis job on a stored campaign with a withheld effect: its report page, with the
    sim-to-real gap section and its figures, renders without console messages."""
    pytest.importorskip("numba")
    from api.worker import Worker
    from diagnosis_fixtures import diagnosis_body, store_campaign

    api = sqlite_api
    train, test = store_campaign(api.store)
    r = api.client.post("/jobs", headers=api.h("operator"),
                        json=diagnosis_body(train, test, n_boot=100))
    w = Worker(api.url)
    assert w.run_once() == r.json()["id"]
    w.store.close()
    html = api.client.get(f"/reports/jobs/{r.json()['id']}/html", headers=api.h("viewer")).text
    assert "Sim-to-real gap" in html and html.count('alt="diagnosis_') >= 5
    img, log = screenshot(html, _artifacts(tmp_path) / "report_diagnosis.png", height=9000)
    console = [line for line in log.splitlines() if ":CONSOLE" in line]
    assert console == [], console
    # the figures are on the page: the section's residual maps, candidate bars and before/after
    # plots put far more plot colour on it than the identification report's four figures
    assert img.shape[0] == 9000 and plot_pixels(img) > 100_000
