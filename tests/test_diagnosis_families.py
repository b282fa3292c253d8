"""The diagnosis on data it was not tuned on (issue 11): a hysteretic system whose only
displacement is the position (the public Bouc–Wen benchmark's mass–spring, written out here
from its published equations), direction-dependent friction on the real EMPS records, the
run format's `sensors` metadata, and the verdict's statuses."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from core.run import RunData
from core.runfile import RunFileError, read_run, write_run
from estimator.diagnosis import diagnose
from estimator.diagnosis_verdict import combined_status, verdict_summary
from estimator.models import linear_model

EMPS = Path(__file__).resolve().parents[2] / "shared" / "data" / "emps"


def hysteretic_mass_spring(seed: int, duration: float = 8.0, fs: float = 750.0,
                           noise: float = 5e-7, scale: float = 1.0, f_max: float = 60.0
                           ) -> RunData:
    """m·ÿ + c·ẏ + k·y + z = F, ż = α·ẏ − β·(γ·|ẏ|·z + δ·ẏ·|z|) with Noël & Schoukens's values
    (m 2 kg, c 10 N·s/m, k 5e4 N/m, α 5e4 N/m, β 1e3 1/m, γ 0.8, δ −1.1); F a random-phase
    multisine from 5 Hz to f_max (the benchmark's 150 Hz is a fifth of its sample rate, where a
    difference-quotient acceleration is 12 % short; 60 Hz keeps the resonance at ~35 Hz
    inside), 50 N RMS; semi-implicit Euler at 20 × fs; y with white noise. Run as the
    joint's channels: q = y [m], torque = F [N]. No code of the repository's emulator."""
    rng = np.random.default_rng(seed)
    m, c, k, a, b, g, d = 2.0, 10.0, 5e4, 5e4, 1e3, 0.8, -1.1
    sub = 20
    dt = 1.0 / fs / sub
    n = int(duration / dt)
    t = np.arange(n) * dt
    freqs = np.arange(5.0, f_max, 0.5)
    phases = rng.uniform(0, 2 * np.pi, freqs.size)
    F = np.zeros(n)
    for f, p in zip(freqs, phases):
        F += np.sin(2 * np.pi * f * t + p)
    F *= 50.0 / F.std()
    y = v = z = 0.0
    Y = np.empty(n)
    for i in range(n):
        v += (F[i] - c * v - k * y - scale * z) / m * dt
        y += v * dt
        z += (a * v - b * (g * abs(v) * z + d * v * abs(z))) * dt
        Y[i] = y
    keep = slice(None, None, sub)
    q = Y[keep] + rng.normal(0.0, noise, Y[keep].size)
    return RunData(pd.DataFrame({"t": t[keep], "q": q, "torque": F[keep]}),
                   {"sample_rate_hz": fs, "source": "import"})


def mass_spring_model():
    return linear_model("mass_spring", "torque", {"m": ("qdd", "kg"), "c": ("qd", "N·s/m"),
                                                  "k": ("q", "N/m"), "C": ("1", "N")},
                        target_unit="N")


@pytest.mark.slow
def test_hysteretic_mass_spring_is_diagnosed_as_hysteresis():
    train = [hysteretic_mass_spring(1), hysteretic_mass_spring(2)]
    test = [hysteretic_mass_spring(3)]
    rep = diagnose(train, test, mass_spring_model())
    v = rep["verdict"]
    assert v["effects"][:1] == ["hysteresis"], v
    assert v["status"] in ("explained", "partly_explained")
    assert rep["shrinkage"]["overall"]["shrinkage"] > 0.5
    # a sine of a displacement that never covers a ripple period is no ripple candidate
    assert "gear_ripple" in rep["skipped"]


@pytest.mark.slow
def test_linear_mass_spring_names_no_effect():
    """Without hysteresis nothing is named. (The verdict is `unexplained`, not `none`: the
    difference-quotient acceleration leaves a residual correlated with the input — a gap of the
    pipeline, not of the system; noted in docs/diagnosis.md.)"""
    train = [hysteretic_mass_spring(4, scale=0.0), hysteretic_mass_spring(5, scale=0.0)]
    test = [hysteretic_mass_spring(6, scale=0.0)]
    v = diagnose(train, test, mass_spring_model())["verdict"]
    assert v["effects"] == [] and v["status"] in ("none", "unexplained")


@pytest.mark.skipif(not EMPS.exists(), reason="../shared/data/emps not beside the checkout")
def test_emps_names_direction_dependent_friction():
    from commands.diagnosis_harness import run_emps
    r = run_emps()
    assert r["effects"][:1] == ["asymmetric_friction"]
    row = next(c for c in r["report"]["candidates"] if c["effect"] == "asymmetric_friction")
    assert row["significant"] and row["shrinkage"] > 0.03
    assert r["status"] in ("explained", "partly_explained")


def test_sensors_metadata_round_trips_and_is_checked(tmp_path):
    sensors = {"q": {"resolution": 1.745e-4}, "u": {"resolution": 1e-7},
               "torque": {"noise_sd": 150.0, "lag_s": 0.0}}
    run = RunData(pd.DataFrame({"t": [0.0, 0.1, 0.2], "q": [0.0, 1e-3, 2e-3]}),
                  {"sample_rate_hz": 10, "sensors": sensors})
    write_run(run, tmp_path / "r.csv")
    assert read_run(tmp_path / "r.csv").meta["sensors"] == sensors
    for bad in ({"q": {"resolution": -1}}, {"q": {"step": 1e-3}}, {"q": 3}, [1]):
        meta = {"sample_rate_hz": 10, "sensors": bad}
        (tmp_path / "b.csv").write_text("t,q\n0,0\n0.1,0\n")
        (tmp_path / "b.json").write_text(json.dumps(meta))
        with pytest.raises(RunFileError, match="sensors"):
            read_run(tmp_path / "b.csv")


def test_emulated_runs_carry_their_sensors():
    from core.schemes import Scheme1
    from simulators.offline import simulate
    from simulators.config import EmulatorConfig
    run = simulate(Scheme1(motor_speed_rpm=3000, direction=1, ramp_rate=60e3),
                   EmulatorConfig(seed=1, sample_rate_hz=20))
    s = run.meta["sensors"]
    assert s["q"]["resolution"] == pytest.approx(np.deg2rad(0.01))
    assert s["torque"]["noise_sd"] > 0


def test_combined_status_never_reads_as_a_cause_when_structure_remains():
    assert combined_status(["none", "none"]) == "none"
    assert combined_status(["explained", "none"]) == "explained"
    assert combined_status(["explained", "unexplained"]) == "partly_explained"
    assert combined_status(["partly_explained", "none"]) == "partly_explained"
    assert combined_status(["unexplained", "none"]) == "unexplained"


def test_an_unexplained_summary_gives_each_laws_share_above_the_floor():
    """Rig L at 750 Hz (seed 1601, nothing withheld) was `unexplained` on its twist–torque law
    alone, 80 % of that law's held-out residual above its floor, and the summary said `0 % of
    the held-out residual lies above the noise floor`: the output law's share."""
    report = {"verdict": {"status": "unexplained", "effects": [],
                          "structured_share_before": 0.0},
              "baseline": {"model": "eq4"},
              "transmission": {"verdict": {"status": "unexplained", "effects": [],
                                           "structured_share_before": 0.804},
                               "baseline": {"model": "eq5+stiffening"}}}
    text = verdict_summary(report)
    assert text.startswith("unexplained — no effect of the vocabulary explains the gap"), text
    assert "0% on eq4, 80% on eq5+stiffening" in text, text
    del report["transmission"]
    assert "0% on eq4)" in verdict_summary(report)


def test_a_lag_taken_out_leaves_the_noise_at_the_sd_its_sheet_states():
    """A shift by a fraction of the sample period must not filter the noise: linear
    interpolation at 0.4 of a period keeps 0.72 of a white noise's sd (and correlates
    neighbours), so the stated sd would floor the law above its true noise."""
    from estimator.diagnosis_inputs import advanced
    rng = np.random.default_rng(3)
    t = np.arange(100_000) * 0.01
    noise = rng.normal(0.0, 1.0, t.size)
    out = advanced(noise, t, 0.004)
    ok = np.isfinite(out)
    assert (~ok).sum() == 1                          # the last lag's sample is missing
    assert np.std(out[ok]) == pytest.approx(1.0, abs=0.01)
    assert abs(np.corrcoef(out[ok][1:], out[ok][:-1])[0, 1]) < 0.02
    slow = 3.0 * np.exp(-t / 50.0) + 0.2 * t + np.sin(0.3 * t)      # a slow signal, not periodic
    shifted = advanced(slow, t, 0.0237)
    ok = np.isfinite(shifted)
    assert (~ok).sum() == 3
    assert np.max(np.abs(shifted[ok] - (3.0 * np.exp(-(t[ok] + 0.0237) / 50.0)
                                         + 0.2 * (t[ok] + 0.0237) + np.sin(0.3 * (t[ok] + 0.0237)))
                         )) < 1e-4
    jitter = t + rng.uniform(-1e-4, 1e-4, t.size)    # jittered stamps: linear interpolation
    assert np.isfinite(advanced(slow, jitter, 0.0237)[:-3]).all()


def test_stamps_that_jitter_by_microseconds_keep_the_noise_at_its_stated_sd():
    """Rig AF's acquisition stamps its samples ±20 µs about a 160 Hz grid. Linear interpolation
    there (the path for irregular stamps) kept 0.77 of the torque noise's sd at its 4.5 ms lag,
    the stated sd floored the output law above its true noise, and rig AF's blind score said
    `none` for Stribeck and temperature friction. Jitter that moves the reading by less than a
    tenth of its noise is a uniform grid to the band-limited shift; larger jitter, or no stated
    noise, still interpolates."""
    from estimator.diagnosis_inputs import advanced
    rng = np.random.default_rng(5)
    n, period, lag = 40_000, 1.0 / 160.0, 0.0045
    t = np.arange(n) * period + rng.uniform(-2e-5, 2e-5, n)
    slow = 1000.0 * np.sin(0.5 * t)
    noisy = slow + rng.normal(0.0, 150.0, n)
    out = advanced(noisy, t, lag, noise_sd=150.0)
    ok = np.isfinite(out)
    assert np.std(out[ok] - 1000.0 * np.sin(0.5 * (t[ok] + lag))) == pytest.approx(150.0, rel=0.02)
    linear = advanced(noisy, t, lag)                       # no stated noise: interpolated
    assert np.std(linear[ok] - 1000.0 * np.sin(0.5 * (t[ok] + lag))) < 0.8 * 150.0
    fast = 1e5 * np.sin(400.0 * t) + rng.normal(0.0, 150.0, n)   # jitter × slope ≈ 0.8·sd
    assert np.array_equal(advanced(fast, t, lag, noise_sd=150.0),
                          np.interp(t + lag, t, fast, right=np.nan), equal_nan=True)


def test_a_known_sensor_lag_is_taken_out_before_the_diagnosis():
    from estimator.diagnosis_inputs import lag_corrected
    t = np.arange(0, 10, 0.01)
    true = np.sin(t)
    lagged = np.sin(t - 0.05)                        # the torque arrives 50 ms late
    run = RunData(pd.DataFrame({"t": t, "q": true, "torque": lagged}),
                  {"sensors": {"torque": {"noise_sd": 1.0, "lag_s": 0.05}}})
    out = lag_corrected(run)
    ok = np.isfinite(out.samples["torque"])
    assert np.max(np.abs(out.samples["torque"][ok] - true[ok])) < 1e-3
    assert out.meta["sensors"]["torque"]["lag_s"] == 0.0 and run.samples["torque"][5] == lagged[5]
    assert lag_corrected(out) is out                 # nothing left to take out


def test_a_load_that_never_drives_says_load_friction_may_be_a_gain_mismatch():
    """Where the load always resists the motion (T·q̇ > 0 on every loaded sample), T − τ_L read
    with a relative gain error ε is ε·|T|·sgn q̇: the column of load-dependent friction. The
    verdict names the friction with that alternative; a run whose load drives the joint takes
    the alternative away."""
    from types import SimpleNamespace

    from estimator.diagnosis import _note_resisting_load
    from estimator.diagnosis_options import DiagnosisOptions
    t = np.linspace(0.0, 50.0, 2001)
    qd = 0.02 * np.sign(np.sin(0.3 * t) + 1e-9)
    T = 60e3 * np.abs(np.sin(0.1 * t)) * np.sign(qd)          # the motor drives: T·q̇ ≥ 0
    fit = SimpleNamespace(model=SimpleNamespace(param_names=("I", "f_c", "mu", "mu_v")),
                          theta=np.array([6685.0, 2353.0, 3.2e-4, 0.0]))
    verdict = {"effects": ["load_dependent_friction"], "ambiguity_sets": {}}
    _note_resisting_load(verdict, fit, {"torque": T, "qd": qd}, DiagnosisOptions())
    gain = verdict["ambiguity_sets"]["load_dependent_friction"]["gain_mismatch"]
    assert gain == {"relative_gain_error": pytest.approx(3.2e-4), "driving_share": 0.0}
    report = {"verdict": {**verdict, "status": "explained", "effect_models": {}},
              "baseline": {"model": "eq4"},
              "shrinkage": {"overall": {"rmse_before": 24.6, "rmse_after": 23.3,
                                        "shrinkage": 0.054, "predicted_from_training": 0.063}}}
    assert "or a gain mismatch of 0.032 % between the torque and load readings" in \
        verdict_summary(report)
    # a fifth of the loaded samples with the load driving the joint: no such note
    driving = T.copy()
    driving[:400] *= -1.0
    verdict = {"effects": ["load_dependent_friction"], "ambiguity_sets": {}}
    _note_resisting_load(verdict, fit, {"torque": driving, "qd": qd}, DiagnosisOptions())
    assert verdict["ambiguity_sets"] == {}
    # nothing to say when the friction is not named
    verdict = {"effects": ["stribeck"], "ambiguity_sets": {}}
    _note_resisting_load(verdict, fit, {"torque": T, "qd": qd}, DiagnosisOptions())
    assert verdict["ambiguity_sets"] == {}
