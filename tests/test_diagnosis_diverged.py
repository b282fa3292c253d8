"""A run that is not a measurement of the rig (a diverged simulation, a corrupted record) is
refused by name before the diagnosis fits anything (estimator.diagnosis_data.refuse_diverged):
fitting it failed inside the linear algebra ("SVD did not converge") with nothing that said
which run was at fault."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from core.run import RunData
from estimator.diagnosis import DiagnosisOptions, diagnose
from estimator.diagnosis_data import refuse_diverged


def _run(seed: int, direction: int = 1) -> RunData:
    """A small run of the output balance I q̈ = T − T_L − f_c sgn q̇ − f_v q̇ at 100 Hz."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 40.0, 0.01)
    q = direction * 0.05 * np.sin(0.3 * t)
    qd = direction * 0.015 * np.cos(0.3 * t)
    qdd = -direction * 0.0045 * np.sin(0.3 * t)
    load = direction * 6e4 * (1 - np.cos(0.1 * t))
    torque = 6685.0 * qdd + load + 2353.0 * np.tanh(qd / 1e-3) + 8683.0 * qd
    df = pd.DataFrame({"t": t, "q": q, "qd": qd, "qdd": qdd,
                       "torque": torque + rng.normal(0, 100.0, t.size),
                       "torque_load": load + rng.normal(0, 100.0, t.size)})
    return RunData(samples=df, meta={"scheme": 1, "motor_speed_rpm": 300.0,
                                     "direction": direction, "sample_rate_hz": 100.0})


def _diverged(run: RunData, channel: str, peak: float) -> RunData:
    s = run.samples.copy()
    s.loc[len(s) // 2:, channel] = np.geomspace(1.0, peak, len(s) - len(s) // 2)
    return RunData(samples=s, meta=dict(run.meta))


def test_a_diverged_held_out_run_is_refused_by_name():
    train = [_run(1), _run(2, -1), _run(3)]
    test = [_run(4, -1), _diverged(_run(5), "q", 1e178)]
    with pytest.raises(ValueError, match=r"held-out run 2 of 2 \(scheme 1, 300 r/min, "
                                         r"direction \+1\): channel 'q' reaches 1e\+178"):
        diagnose(train, test, "eq4", transmission=None)


def test_a_reading_a_million_times_the_others_is_refused_below_overflow():
    train = [_run(1), _diverged(_run(2, -1), "torque", 1e12), _run(3)]
    with pytest.raises(ValueError, match=r"training run 2 of 3 .*channel 'torque'"):
        refuse_diverged(train, [_run(4)], DiagnosisOptions().diverged_peak_ratio)


def test_ordinary_runs_and_missing_samples_pass():
    runs = [_run(i, (-1) ** i) for i in range(4)]
    s = runs[0].samples.copy()
    s.loc[100:200, "q"] = np.nan                 # a missing stretch is a gap, not a divergence
    s.loc[300, "torque"] = np.inf
    runs[0] = RunData(samples=s, meta=dict(runs[0].meta))
    refuse_diverged(runs[:3], runs[3:], 1e6)
    # a scheme-3 run's torque is ~40 times below a loaded run's: far from the ratio
    quiet = RunData(samples=runs[1].samples.assign(torque_load=lambda d: d.torque_load / 40),
                    meta=dict(runs[1].meta))
    refuse_diverged(runs[:2] + [quiet], runs[3:], 1e6)


@pytest.mark.parametrize("ratio", [float("nan"), float("inf"), 1.0, -5.0])
def test_the_ratio_itself_fails_closed(ratio):
    with pytest.raises(ValueError, match="diverged_peak_ratio"):
        refuse_diverged([_run(1)], [_run(2)], ratio)


def test_the_command_line_names_the_run_instead_of_a_traceback(tmp_path, capsys):
    from commands.cli import main
    from core.runfile import write_run
    paths = {"train": [], "test": []}
    runs = {"train": [_run(1), _run(2, -1)], "test": [_diverged(_run(3), "qd", 1e200)]}
    for kind, rs in runs.items():
        for i, r in enumerate(rs):
            written = write_run(r, tmp_path / f"{kind}{i}", "csv")
            paths[kind].append(str([p for p in written if p.suffix == ".csv"][0]))
    assert main(["diagnose", "--train", *paths["train"], "--test", *paths["test"],
                 "--transmission", "none"]) == 2
    err = capsys.readouterr().err
    assert "rig diagnose: held-out run 1 of 1" in err and "channel 'qd'" in err
    assert "Traceback" not in err
