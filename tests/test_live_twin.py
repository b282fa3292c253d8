"""The live twin: a fit marked as the rig's model predicts the joint torque from the measured
motion and load. The prediction is checked against Eq. 4 written out here from the paper (not
the estimator's own terms); a law that cannot predict the torque from motion is refused; the
marking goes through the API (operator marks, viewer reads, a transmission law is refused)."""

from __future__ import annotations

import math

import numpy as np
import pytest

G = 9.81


def eq4_by_hand(q, qd, qdd, tau_l, I, mrx, mry, fv, fc):
    """Eq. 4: T = I·q̈ + g·(mr_x·sin q + mr_y·cos q) + f_v·q̇ + f_c·sgn q̇ + τ_L."""
    return I * qdd + G * (mrx * math.sin(q) + mry * math.cos(q)) + fv * qd \
        + fc * math.copysign(1.0, qd) + tau_l


def test_twin_predicts_eq4_from_motion_and_load():
    from estimator.twin import Twin

    p = {"I_xx": 1.7e3, "mr_x": 2.1e3, "mr_y": -3.3e2, "f_v": 4.0e5, "f_c": 2.2e3}
    twin = Twin("eq4", p)
    rng = np.random.default_rng(4)
    t, qd_prev = 0.0, None
    for k in range(50):
        t += 0.25
        q = rng.uniform(-1.5, 1.5)
        qd = rng.choice([-1, 1]) * rng.uniform(0.01, 0.05)   # well outside the sign's smoothing
        tau_l = rng.uniform(-1e5, 1e5)
        out = twin.update(t, {"q": q, "qd": qd, "torque_load": tau_l, "torque": 1.0e4,
                              "p_hyd": 1e6})
        qdd = 0.0 if qd_prev is None else (qd - qd_prev) / 0.25
        qd_prev = qd
        want = eq4_by_hand(q, qd, qdd, tau_l, p["I_xx"], p["mr_x"], p["mr_y"], p["f_v"],
                           p["f_c"])
        assert out["predicted"] == pytest.approx(want, rel=1e-6, abs=1e-3)
        assert out["residual"] == pytest.approx(1.0e4 - want, rel=1e-6, abs=1e-3)
    assert twin.update(t + 1, {"q": 0.1, "torque": 3.0}) is None      # no speed, no load
    assert twin.update(t + 2, {"q": float("nan"), "qd": 0.1, "torque_load": 0.0}) is None


def test_a_transmission_law_or_an_incomplete_fit_cannot_be_the_twin():
    from estimator.twin import Twin, TwinUnavailable

    with pytest.raises(TwinUnavailable, match="transmission"):
        Twin("eq5", {"k": 1.0, "D": 1.0, "C": 0.0})
    with pytest.raises(TwinUnavailable, match="lacks"):
        Twin("eq4", {"I_xx": 1.0})


def test_marking_the_rig_model_through_the_api(api):
    from db.fits import save_fit
    from estimator.identify import identify

    run_id = api.runs["fast"]
    fit = identify([api.store.load_run(run_id)], "eq4", "ls")
    fit_id = save_fit(api.store, fit, {run_id: "train"})
    tx = identify([api.store.load_run(run_id)], "eq5", "ls")
    tx_id = save_fit(api.store, tx, {run_id: "train"})

    c, h = api.client, api.h
    assert c.get("/rig-model", headers=h("viewer")).status_code == 404
    assert c.put("/rig-model", json={"fit_id": fit_id}, headers=h("viewer")).status_code == 403
    r = c.put("/rig-model", json={"fit_id": tx_id}, headers=h("operator"))
    assert r.status_code == 422 and "transmission" in r.json()["detail"]
    assert c.put("/rig-model", json={"fit_id": 10 ** 6}, headers=h("operator")).status_code == 404
    r = c.put("/rig-model", json={"fit_id": fit_id}, headers=h("operator"))
    assert r.status_code == 200, r.text
    got = c.get("/rig-model", headers=h("viewer")).json()
    assert got["fit_id"] == fit_id and got["model"] == "eq4" and got["marked_by"] == "test-operator"
    assert set(got["params"]) == {"I_xx", "mr_x", "mr_y", "f_v", "f_c"}
    assert got["training_run_ids"] == [run_id]


@pytest.mark.slow
def test_a_run_streams_the_twin_prediction_beside_the_measurement(api):
    """Scheme 1 on the emulator with the rig model marked: its progress events carry the
    twin's prediction, and the residual is small beside the torque (the model fits the joint)."""
    import json
    from drivers_harness import SLACK_S

    r = api.client.post("/schemes/1/runs", headers=api.h("operator"), json={
        "target": "emulator", "operator": "alice",
        "params": {"motor_speed_rpm": 3000.0, "load_target": 20e3, "ramp_rate": 10e3,
                   "accel_time": 0.5, "settle_time": 0.5, "rest_time": 0.5,
                   "sample_rate_hz": 20.0},
        "emulator": {"time_scale": 5.0, "seed": 3, "watchdog_s": SLACK_S}})
    assert r.status_code == 202, r.text
    twins, ev = [], None
    with api.client.stream("GET", r.headers["location"] + "/events",
                           headers=api.h("viewer")) as s:
        for line in s.iter_lines():
            if line.startswith("event: "):
                ev = line[7:]
            elif line.startswith("data: ") and ev == "progress":
                d = json.loads(line[6:])
                assert d["sent_at"] > 0
                if d.get("twin"):
                    twins.append(d["twin"])
    fit_id = api.client.get("/rig-model", headers=api.h("viewer")).json()["fit_id"]
    assert len(twins) >= 3 and all(t["fit_id"] == fit_id for t in twins)
    meas = np.array([t["measured"] for t in twins])
    res = np.array([t["residual"] for t in twins])
    assert np.allclose(meas - res, [t["predicted"] for t in twins])
    assert np.max(np.abs(meas)) > 1e4                        # the joint was loaded
    assert np.median(np.abs(res)) < 0.1 * np.max(np.abs(meas)), (res, meas)


@pytest.fixture(scope="module")
def api(tmp_path_factory):
    from api_fixtures import _api, database
    from drivers_harness import SLACK_ENV
    with pytest.MonkeyPatch.context() as mp, database("sqlite", tmp_path_factory) as url:
        for k, v in SLACK_ENV.items():
            mp.setenv(k, v)
        yield from _api(url)
