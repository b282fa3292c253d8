"""The service's settings (api/settings.py): every setting has a type, a unit and a range; NaN,
±inf, a value out of range, a tls:// Dask scheduler without its certificates stop start-up with
a message naming the variable; the DAQ side (daq/settings.py) leaves every service variable
alone; the database URL never shows in a repr."""

from __future__ import annotations

from dataclasses import fields

import pytest

from api.settings import ENV, Settings

FLOATS = [f.name for f in fields(Settings) if f.type in ("float", "float | None")]


@pytest.fixture(autouse=True)
def clean_env(monkeypatch):
    for var in ENV.values():
        monkeypatch.delenv(var, raising=False)


def test_every_setting_has_a_variable_a_unit_and_every_number_a_range():
    assert set(ENV) == {f.name for f in fields(Settings)}
    for name, info in Settings.__pydantic_fields__.items():
        assert info.json_schema_extra and info.json_schema_extra.get("unit"), name
        if info.annotation in (int, float, int | None, float | None):
            bounds = {attr for m in info.metadata for attr in ("ge", "gt", "le", "lt")
                      if getattr(m, attr, None) is not None}
            assert bounds & {"ge", "gt"} and bounds & {"le", "lt"}, (name, bounds)


def test_defaults_and_environment(monkeypatch):
    st = Settings.from_env()
    assert (st.host, st.port, st.workers, st.dask_scheduler) == ("127.0.0.1", 8000, 2, None)
    monkeypatch.setenv("RIG_JOB_HEARTBEAT_S", "0.5")
    monkeypatch.setenv("RIG_API_CACHE_MB", "0")
    monkeypatch.setenv("RIG_API_PORT", "")                 # empty = unset
    st = Settings.from_env(workers=0)
    assert (st.job_heartbeat_s, st.api_cache_mb, st.port, st.workers) == (0.5, 0.0, 8000, 0)


@pytest.mark.parametrize("name", FLOATS)
@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_nan_and_inf_stop_start_up_naming_the_variable(monkeypatch, name, value):
    monkeypatch.setenv(ENV[name], value)
    with pytest.raises(ValueError, match=ENV[name]):
        Settings.from_env()


@pytest.mark.parametrize("var,value", [
    ("RIG_API_PORT", "0"), ("RIG_API_PORT", "99999"), ("RIG_API_PORT", "http"),
    ("RIG_WORKERS", "-1"), ("RIG_WORKERS", "1000"), ("RIG_MAX_BODY_BYTES", "10"),
    ("RIG_JOB_HEARTBEAT_S", "0"), ("RIG_JOB_STALE_S", "1"),   # not beyond the 2 s heartbeat
    ("RIG_JOB_MAX_ATTEMPTS", "0"), ("RIG_API_CACHE_MB", "-1"),
    ("RIG_DASK_SCHEDULER", "http://10.0.0.5:8786"), ("RIG_DASK_SCHEDULER", "10.0.0.5:8786"),
])
def test_out_of_range_values_stop_start_up_naming_the_variable(monkeypatch, var, value):
    monkeypatch.setenv(var, value)
    with pytest.raises(ValueError, match=var):
        Settings.from_env()


def test_a_tls_scheduler_needs_its_certificates_and_tcp_takes_none(monkeypatch, tmp_path):
    pem = tmp_path / "x.pem"
    pem.write_text("not checked here")
    monkeypatch.setenv("RIG_DASK_SCHEDULER", "tls://127.0.0.1:8786")
    with pytest.raises(ValueError, match="RIG_DASK_TLS_CA") as e:
        Settings.from_env()
    assert "RIG_DASK_TLS_CERT" in str(e.value) and "RIG_DASK_TLS_KEY" in str(e.value)
    for var in ("RIG_DASK_TLS_CA", "RIG_DASK_TLS_CERT", "RIG_DASK_TLS_KEY"):
        monkeypatch.setenv(var, str(pem))
    st = Settings.from_env()
    assert st.dask_tls_ca == str(pem)
    monkeypatch.setenv("RIG_DASK_TLS_KEY", str(tmp_path / "missing.pem"))
    with pytest.raises(ValueError, match="RIG_DASK_TLS_KEY.*no such file"):
        Settings.from_env()
    monkeypatch.setenv("RIG_DASK_TLS_KEY", str(pem))
    monkeypatch.setenv("RIG_DASK_SCHEDULER", "tcp://127.0.0.1:8786")   # certificates unused
    with pytest.raises(ValueError, match="RIG_DASK_TLS_CA"):
        Settings.from_env()


def test_the_security_object_is_built_for_tls_only(tmp_path):
    pytest.importorskip("distributed")
    pem = tmp_path / "x.pem"
    pem.write_text("-")
    assert Settings(dask_scheduler="tcp://127.0.0.1:8786").dask_security() is None
    assert Settings().dask_security() is None
    sec = Settings(dask_scheduler="tls://127.0.0.1:8786", dask_tls_ca=str(pem),
                   dask_tls_cert=str(pem), dask_tls_key=str(pem)).dask_security()
    assert sec.require_encryption
    assert (sec.tls_ca_file, sec.tls_client_cert, sec.tls_client_key) == (str(pem),) * 3


def test_the_database_url_is_not_in_the_repr():
    st = Settings(db_url="postgresql+psycopg://rig:S3CRET@db.example/rig")
    assert "S3CRET" not in repr(st) and "S3CRET" not in str(st)


def test_the_daq_side_leaves_every_service_variable_alone():
    from daq import settings as daq_settings

    for var in ENV.values():
        daq_settings.Settings.load(env={var: "x"})          # neither read nor refused
    for f in fields(daq_settings.Settings):
        var = f"RIG_{f.name.upper()}"
        assert not var.startswith(daq_settings.OTHER_PREFIXES), var
        assert var not in daq_settings.OTHER_NAMES and var not in ENV.values(), var
