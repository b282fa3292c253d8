"""Every emulator effect parameter is bounded in core/effects.py (finite, within its physical
range), and every way of injecting one refuses the rest: the API with 422 naming the parameter,
`rig simulate`, `rig emulate` and `rig run` with a one-line error (`time_delay` with delay = 1e7 s
would make the stand-in allocate ~80 GB; NaN would give NaN physics)."""

from __future__ import annotations

import math

import pytest

from core.effects import VOCABULARY, check_effects, parse_effect, resolve_effects
from simulators.config import EmulatorConfig

BAD = [("time_delay", "delay", 1e7), ("time_delay", "delay", math.nan),
       ("time_delay", "delay", -0.1), ("stribeck", "f_s", math.inf),
       ("stribeck", "v_s", 0.0), ("gear_ripple", "order", -math.inf),
       ("backlash", "b", 1.0), ("torque_offset", "c0", 1e12)]


def test_every_parameter_has_a_finite_range_holding_its_default():
    for effect in VOCABULARY.values():
        for p in effect.params:
            assert math.isfinite(p.lo) and math.isfinite(p.hi), (effect.name, p.name)
            assert p.lo <= p.default <= p.hi, (effect.name, p.name)
            for edge in (p.lo, p.hi):                    # the range is inclusive
                assert check_effects({effect.name: {p.name: edge}})


@pytest.mark.parametrize("name,param,value", BAD)
def test_out_of_range_and_non_finite_values_are_refused_naming_the_parameter(name, param, value):
    for call in (check_effects, resolve_effects, lambda spec: EmulatorConfig(effects=spec)):
        with pytest.raises(ValueError, match=f"{name}.*{param}"):
            call({name: {param: value}})
    with pytest.raises(ValueError, match=param):
        parse_effect(f"{name}:{param}={value!r}")


def _must_not_run(*args, **kwargs):
    raise AssertionError("a refused effect reached the emulator")


@pytest.fixture
def no_emulator(monkeypatch):
    """Stand-ins for what a refused value must never reach (were it reached, delay = 1e7 s
    would try to allocate ~80 GB): the offline simulation, the stand-in, an acquisition."""
    import api.acquisition
    import simulators.offline
    import simulators.standin

    monkeypatch.setattr(simulators.offline, "simulate", _must_not_run)
    monkeypatch.setattr(simulators.standin, "StandIn", _must_not_run)
    monkeypatch.setattr(api.acquisition.AcquisitionManager, "start", _must_not_run)


@pytest.mark.parametrize("argv", [
    ["simulate", "scheme1", "--effect", "time_delay:delay=1e7"],
    ["simulate", "scheme1", "--effect", "time_delay:delay=nan"],
    ["emulate", "--effect", "time_delay:delay=1e7"],
    ["emulate", "--effect", "time_delay:delay=nan"],
    ["run", "scheme1", "--effect", "time_delay:delay=1e7"],
    ["run", "scheme1", "--effect", "time_delay:delay=nan"],
])
def test_the_cli_refuses_them_with_one_line(argv, capsys, tmp_path, monkeypatch,
                                            no_emulator):
    from commands.cli import main

    monkeypatch.chdir(tmp_path)                          # nothing may be written anyway
    try:
        code = main(argv + (["--db", f"sqlite:///{tmp_path / 'x.sqlite'}"]
                            if argv[0] == "run" else []))
    except SystemExit as exc:                            # argparse's type error
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "delay" in ln]
    assert len(lines) == 1 and "time_delay" in lines[0], err
    assert "Traceback" not in err
    assert not list(tmp_path.iterdir())


@pytest.fixture(scope="module")
def api(tmp_path_factory):
    from fastapi.testclient import TestClient

    from api.app import create_app
    from api.settings import Settings
    from db.store import Store
    from db.tokens import create_token

    url = f"sqlite:///{tmp_path_factory.mktemp('effects') / 'rig.sqlite'}"
    store = Store(url)
    token = create_token(store, "test-operator", ["operator"])
    app = create_app(Settings(db_url=url, workers=0))
    with TestClient(app) as client:
        yield client, {"Authorization": f"Bearer {token}", "Content-Type": "application/json"}
    store.close()


@pytest.mark.parametrize("value", ["1e7", "NaN", "Infinity", "-1"])
def test_the_api_refuses_them_with_422_naming_the_parameter(api, value, no_emulator):
    client, headers = api
    raw = ('{"target": "emulator", "operator": "alice", "emulator": {"time_scale": 5, '
           '"effects": {"time_delay": {"delay": %s}}}}' % value)
    r = client.post("/schemes/1/runs", content=raw, headers=headers)
    assert r.status_code == 422, r.text
    assert "delay" in r.text and "time_delay" in r.text
    assert client.get("/acquisitions", headers=headers).json() == []
