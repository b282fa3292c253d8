"""The EMPS adapter (core/emps.py) on the real benchmark records in ../shared/data/emps/."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core.emps import load_emps
from core.runfile import RunFileError

EMPS = Path(__file__).resolve().parents[2] / "shared" / "data" / "emps"
if not EMPS.exists():
    EMPS = Path("/work/shared/data/emps")

pytestmark = pytest.mark.skipif(not (EMPS / "DATA_EMPS.mat").exists(),
                                reason=f"EMPS records not found in {EMPS}")


def test_estimation_record():
    from scipy.io import loadmat
    run = load_emps(EMPS / "DATA_EMPS.mat")
    mat = loadmat(EMPS / "DATA_EMPS.mat")
    assert list(run.samples.columns) == ["t", "qm", "qg", "vir", "force"]
    assert len(run) == mat["t"].size == 24841
    np.testing.assert_array_equal(run.channel("qm"), mat["qm"].ravel())
    np.testing.assert_allclose(run.channel("force"), 35.15065188 * mat["vir"].ravel(), rtol=1e-9)
    assert np.all(np.diff(run.t) > 0) and abs(run.t[-1] - 24.84) < 1e-6
    m = run.meta
    assert m["source"] == "import" and m["units"]["force"] == "N" and m["units"]["qm"] == "m"
    assert (m["kp"], m["kv"]) == (160.18, 243.45) and abs(m["gtau"] - 35.15065188) < 1e-8
    assert "Janot" in m["citation"] and abs(m["sample_rate_hz"] - 1000) < 0.1


def test_validation_record_keeps_pulses():
    run = load_emps(EMPS / "DATA_EMPS_PULSES.mat")
    assert "pulses_N" in run.samples.columns
    assert set(np.unique(run.channel("pulses_N"))) == {0.0, 5.0}


def test_not_a_mat_file(tmp_path):
    p = tmp_path / "x.mat"
    p.write_text("hello")
    with pytest.raises(RunFileError, match="x.mat"):
        load_emps(p)
