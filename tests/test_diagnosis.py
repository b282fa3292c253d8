"""The sim-to-real gap diagnosis (estimator.diagnosis): its statistics, the ambiguity guard, the
verdicts on emulator campaigns with a withheld effect (each effect alone is named; nothing
injected gives `none`; an effect outside the vocabulary gives `unexplained`), and the
`rig diagnose --json` keys."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from estimator.diagnosis import DiagnosisOptions, diagnose
from estimator.diagnosis_stats import (angle_lines, angle_periodogram, block_ids,
                                       bootstrap_shrinkage, mean_se, whiteness)
from estimator.least_squares import leave_one_group_out, ols
from core.run import RunData
from core.terms import eq4_regressor

# Magnitudes giving an effect-to-noise ratio of about 2 on the harness campaign
# (commands.diagnosis_harness.magnitude_for measured ENR 1 at half these values).
ENR2 = {"stribeck": {"f_s": 515.0}, "load_dependent_friction": {"mu": 0.0063},
        "temperature_friction": {"c_T": 16.0}, "gear_ripple": {"A": 435.0},
        "torque_offset": {"c0": 271.0, "drift": 0.68}, "time_delay": {"delay": 0.069}}


# --- statistics ---------------------------------------------------------------------------------

def test_batch_means_se_matches_iid_and_grows_with_correlation():
    rng = np.random.default_rng(0)
    x = rng.normal(size=20000)
    run = np.zeros(x.size, dtype=int)
    m, se = mean_se(x, block_ids(run, 100))
    assert abs(se - 1 / np.sqrt(x.size)) < 0.15 / np.sqrt(x.size)
    ar = np.empty_like(x)  # AR(1), phi = 0.9: the SE of the mean is ~√19 times larger
    ar[0] = x[0]
    for i in range(1, x.size):
        ar[i] = 0.9 * ar[i - 1] + x[i]
    _, se_ar = mean_se(ar, block_ids(run, 200))
    naive = ar.std() / np.sqrt(ar.size)
    assert 3.0 < se_ar / naive < 6.0


def test_whiteness_and_angle_line_detect_structure_only_when_present():
    rng = np.random.default_rng(1)
    e = rng.normal(size=5000)
    run = np.repeat([0, 1], 2500)
    assert whiteness(e, run)["p_value"] > 0.01
    smooth = np.convolve(e, np.ones(5) / 5, mode="same")
    assert whiteness(smooth, run)["p_value"] < 1e-6
    q = np.linspace(0, 3, 5000)
    assert angle_lines(e, q, np.arange(2, 121))["p_value"] > 0.01
    line = angle_lines(e + 0.5 * np.sin(36 * q + 0.3), q, np.arange(2, 121))
    assert line["order"] == 36 and line["p_value"] < 1e-6
    assert abs(line["amplitude"] - 0.5) < 0.1


def test_the_periodogram_screen_finds_a_high_order_line_and_its_strength_order():
    rng = np.random.default_rng(2)
    u = np.linspace(0.0, 2.0, 40000)
    e = rng.normal(size=u.size)
    line = e + 0.4 * np.sin(733 * u + 1.0) + 0.2 * np.sin(1466 * u + 0.5)
    assert angle_periodogram(line, u, 121, 2000) == [733, 1466]
    assert angle_periodogram(line, u, 121, 700) != [733]          # outside the range: not found
    assert angle_periodogram(line, u, 10, 5) == []


def test_leave_one_group_out_errors_equal_refits_on_the_other_groups():
    rng = np.random.default_rng(3)
    n = 4000
    X = np.column_stack([np.ones(n), 1e4 * rng.normal(size=n), 1e-3 * rng.normal(size=n)])
    X = np.column_stack([X, 2e-7 * X[:, 1]])           # rank deficient: the minimum-norm fit
    y = X[:, :3] @ np.array([1.0, 2e-4, 3e3]) + rng.normal(size=n)
    g = np.repeat(np.arange(5), n // 5)
    want = np.empty(n)
    for r in range(5):
        m = g == r
        want[m] = y[m] - X[m] @ ols(X[~m], y[~m]).theta
    np.testing.assert_allclose(leave_one_group_out(X, y, g), want, atol=1e-9)


def test_bootstrap_interval_covers_the_point_and_excludes_zero_for_a_real_gain():
    rng = np.random.default_rng(2)
    e0 = rng.normal(size=4000) + 0.8 * np.sin(np.arange(4000) / 30)
    e1 = e0 - 0.8 * np.sin(np.arange(4000) / 30)
    b = block_ids(np.zeros(4000, dtype=int), 60)
    s, lo, hi = bootstrap_shrinkage(e0, e1, b)
    assert lo <= s <= hi and lo > 0.1


# --- synthetic runs (no emulator): the ambiguity guard -------------------------------------------

def _synthetic(seed: int, extra, q_amp: float = 0.05, n: int = 4000) -> RunData:
    """Eq. 4 data with a measured load (a slow ramp to 60 kN·m, noise 100 N·m):
    θ = (I, mr_x, mr_y, f_v, f_c), torque noise 150 N·m, plus extra(t, q) [N·m] in the torque
    channel. Each seed has its own trajectory phase."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    w = 2 * np.pi * 0.05
    ph = rng.uniform(0, 2 * np.pi, 2)
    q = q_amp * np.sin(w * t + ph[0]) + 0.3 * q_amp * np.sin(3 * w * t + ph[1])
    qd = np.gradient(q, t)
    qdd = np.gradient(qd, t)
    theta = np.array([6685.0, 20.8, -34.5, 8683.0, 2353.0])
    load = 60e3 * np.sin(np.pi * t / t[-1])
    T = (eq4_regressor(q, qd, qdd, 2e-5) @ theta + load + extra(t, q)
         + rng.normal(0, 150, n))
    df = pd.DataFrame({"t": t, "q": q, "qd": qd, "torque": T,
                       "torque_load": load + rng.normal(0, 100, n)})
    return RunData(samples=df, meta={"scheme": 3, "sample_rate_hz": 100.0})


def test_offset_and_cos_q_are_reported_as_an_ambiguity_set():
    """A constant torque offset on runs that barely move (cos q ≈ 1) is indistinguishable from
    mr_y·g·cos q: the torque_offset candidate must name mr_y as the parameter it soaks up."""
    def off(t, q):
        return 600.0 + 0 * t
    train = [_synthetic(s, off) for s in (1, 2)]
    test = [_synthetic(s, off) for s in (3, 4)]
    rep = diagnose(train, test, "eq4", options=DiagnosisOptions(candidates=("torque_offset",)))
    row = {c["effect"]: c for c in rep["candidates"]}["torque_offset"]
    assert "mr_y" in row["aliases"]
    assert abs(row["moved"]["mr_y"]["shift_in_se"]) > 3


def test_synthetic_gear_ripple_is_named_with_its_order_and_parameters_stay_put():
    def ripple(t, q):
        return 400.0 * np.sin(7 * q)
    train = [_synthetic(s, ripple, q_amp=1.5) for s in (1, 2)]
    test = [_synthetic(s, ripple, q_amp=1.5) for s in (3, 4)]
    rep = diagnose(train, test, "eq4")
    assert "transmission" not in rep  # no twist channel: the transmission law is not diagnosed
    assert rep["verdict"]["status"] == "explained"
    assert rep["verdict"]["effects"] == ["gear_ripple"]
    assert rep["verdict"]["shapes"]["gear_ripple"]["order"] == 7.0
    # rmse √(180² + 400²/2) ≈ 335 → 180 N·m (torque and load noise): shrinkage ≈ 0.46
    assert 0.38 < rep["shrinkage"]["overall"]["shrinkage"] < 0.52
    assert rep["shrinkage"]["overall"]["ci95"][0] > 0.3
    # with the right term added, Eq. 4's parameters move back to the truth
    truth = dict(zip(("I_xx", "mr_x", "mr_y", "f_v", "f_c"), (6685.0, 20.8, -34.5, 8683.0, 2353.0)))
    moved = rep["shrinkage"]["parameters_moved"]
    assert all(abs(m["after"] - truth[k]) < 4 * m["se_after"] for k, m in moved.items())
    assert any(abs(m["before"] - truth[k]) > 4 * m["se_before"] for k, m in moved.items())


def test_a_diagnosis_refuses_empty_run_lists():
    with pytest.raises(ValueError):
        diagnose([], [_synthetic(1, lambda t, q: 0 * t)])


# --- emulator campaigns -------------------------------------------------------------------------

@pytest.fixture(scope="module")
def campaigns():
    """Campaigns cached for the module: {label: (train, test)} (commands.diagnosis_harness)."""
    pytest.importorskip("numba")
    from commands.diagnosis_harness import simulate_campaign
    out = {"none-1": simulate_campaign({}, 1), "none-2": simulate_campaign({}, 2)}
    for name, params in ENR2.items():
        out[name] = simulate_campaign({name: params}, 3)
    out["position_stiffness"] = simulate_campaign({}, 4, {"position_stiffness": 620.0})
    return out


@pytest.fixture(scope="module")
def reports(campaigns):
    return {k: diagnose(tr, te) for k, (tr, te) in campaigns.items()}


@pytest.mark.slow
@pytest.mark.parametrize("effect", list(ENR2))
def test_each_withheld_effect_alone_is_named(reports, effect):
    rep = reports[effect]
    v = rep["verdict"]
    assert v["status"] == "explained", (v, rep["tests"]["reasons"])
    assert v["effects"][0] == effect
    assert rep["candidates"][0]["effect"] == effect
    assert rep["candidates"][0]["significant"]
    assert v["rmse_test_after"] < rep["baseline"]["rmse_test"]


@pytest.mark.slow
@pytest.mark.parametrize("label", ["none-1", "none-2"])
def test_nothing_injected_gives_none(reports, label):
    v = reports[label]["verdict"]
    assert v["status"] == "none" and v["effects"] == []
    assert not any(c["significant"] for c in reports[label]["candidates"])


@pytest.mark.slow
def test_out_of_vocabulary_effect_is_unexplained_and_still_located(reports):
    rep = reports["position_stiffness"]
    assert rep["verdict"]["status"] == "unexplained"
    assert rep["regions"], "an unexplained gap must still say where it lies"
    assert rep["tests"]["structured"]


@pytest.mark.slow
def test_gear_ripple_regions_show_the_angle_and_shrinkage_is_predicted(reports):
    rep = reports["gear_ripple"]
    assert rep["tests"]["angle_line"]["order"] == 36
    assert any(r["family"] == "angle" for r in rep["regions"])
    sh = rep["shrinkage"]["overall"]
    assert abs(sh["shrinkage"] - sh["predicted_from_training"]) < 0.05  # the issue's target
    assert sh["ci95"][0] <= sh["shrinkage"] <= sh["ci95"][1]


@pytest.mark.slow
def test_cli_json_has_the_issue_keys(campaigns, tmp_path, capsys):
    from commands.cli import main
    from core.runfile import write_run
    train, test = campaigns["gear_ripple"]
    paths = {"train": [], "test": []}
    for kind, runs in (("train", train), ("test", test)):
        for i, r in enumerate(runs):
            written = write_run(r, tmp_path / f"{kind}{i}", "csv")
            paths[kind].append(str([p for p in written if p.suffix == ".csv"][0]))
    assert main(["diagnose", "--train", *paths["train"], "--test", *paths["test"], "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert {"model", "rmse_train", "rmse_test"} <= set(rep["baseline"])
    assert all({"where", "share", "rmse"} <= set(r) for r in rep["regions"])
    shares = [r["share"] for r in rep["regions"]]
    assert shares == sorted(shares, reverse=True)
    assert all({"effect", "rmse_test", "shrinkage", "significant", "model"} <= set(c)
               for c in rep["candidates"])
    # best first: by held-out shrinkage across both laws (within one law: by held-out RMSE)
    sh = [c["shrinkage"] for c in rep["candidates"]]
    assert sh == sorted(sh, reverse=True)
    for law in ("eq4", rep["transmission"]["baseline"]["model"]):
        rm = [c["rmse_test"] for c in rep["candidates"] if c["model"] == law]
        assert rm == sorted(rm)
    assert {c["model"] for c in rep["candidates"]} == {"eq4", "eq11+stiffening"}
    assert rep["transmission"]["verdict"]["status"] == "none"
    assert rep["verdict"]["status"] in ("explained", "none", "partly_explained", "unexplained")
    assert rep["verdict"]["effects"] == ["gear_ripple"]
    assert "rmse_test_after" in rep["verdict"]
    assert main(["diagnose", "--train", *paths["train"], "--test", *paths["test"]]) == 0
    text = capsys.readouterr().out
    assert "verdict: explained — gear_ripple" in text
    assert "twist–torque law eq11+stiffening" in text and "on eq11+stiffening" in text
    assert "on eq4" in text
    # --transmission none: the torque balance alone
    assert main(["diagnose", "--train", *paths["train"], "--test", *paths["test"], "--json",
                 "--transmission", "none"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert "transmission" not in rep and {c["model"] for c in rep["candidates"]} == {"eq4"}


@pytest.mark.slow
def test_transmission_model_names_hysteresis_and_skips_output_effects(campaigns):
    """The emulator's transmission is Bouc–Wen by default: against the purely elastic Eq. 5,
    hysteresis must come out as the best significant candidate; output-side effects are not
    tried on a transmission law, except those the vocabulary also places there (gear ripple as
    a transmission error), which must not win on a law without it."""
    tr, te = campaigns["none-1"]
    rep = diagnose(tr, te, "eq5")
    assert rep["candidates"][0]["effect"] == "hysteresis"
    assert rep["candidates"][0]["significant"]
    assert rep["verdict"]["effects"][:1] == ["hysteresis"]
    assert "stribeck" in rep["skipped"] and "gear_ripple" not in rep["skipped"]
    assert "gear_ripple" not in rep["verdict"]["effects"]


# --- the transmission law (twist vs torque) ---------------------------------------------------

# Magnitudes at an effect-to-noise ratio of about 1 on the harness campaign (its transmission
# ENR: contribution to the twist–torque law's residual / that law's noise, 662 N·m; measured by
# commands.diagnosis_harness.magnitude_for: b = 4.92e-5 rad, scale = 0.331 — 4.93e-5 on the
# earlier one-direction-per-set campaign).
TX_ENR1 = {"backlash": {"b": 4.93e-5}, "hysteresis": {"scale": 0.331}}


@pytest.fixture(scope="module")
def tx_reports():
    """Backlash in the Bouc–Wen world against the Bouc–Wen law; hysteresis, and nothing, in
    the elastic world against Eq. 5 (commands.diagnosis_harness.world)."""
    pytest.importorskip("numba")
    from commands.diagnosis_harness import ELASTIC, simulate_campaign
    out = {}
    for name, params in TX_ENR1.items():
        tr, te = simulate_campaign({name: params}, 5)
        out[name] = diagnose(tr, te, transmission="eq5" if name == "hysteresis" else "auto")
    tr, te = simulate_campaign(dict(ELASTIC), 5)
    out["none-elastic"] = diagnose(tr, te, transmission="eq5")
    return out


@pytest.mark.slow
@pytest.mark.parametrize("effect", list(TX_ENR1))
def test_each_withheld_transmission_effect_alone_is_named(tx_reports, effect):
    rep = tx_reports[effect]
    v, tx = rep["verdict"], rep["transmission"]
    assert v["status"] == "explained", (v, tx["verdict"])
    assert v["effects"] == [effect]
    assert v["effect_models"][effect] == tx["baseline"]["model"]
    assert tx["baseline"]["model"] == ("eq5+stiffening" if effect == "hysteresis"
                                       else "eq11+stiffening")
    row = next(c for c in rep["candidates"] if c["effect"] == effect)
    assert row["significant"] and row["model"] == tx["baseline"]["model"]
    assert tx["candidates"][0]["effect"] == effect
    assert rep["verdict"]["laws"]["eq4"]["status"] == "none"
    sh = tx["shrinkage"]["overall"]
    assert sh["shrinkage"] > 0.05 and sh["ci95"][0] > 0


@pytest.mark.slow
def test_backlash_shrinkage_predicted_from_training_matches_the_held_out(tx_reports):
    """Backlash's held-out shrinkage on the twist–torque law is predicted from the training runs
    within 0.05 (issue 7). It failed while the harness trained on +1 runs only and held out −1
    runs (this seed: realised 0.233, predicted 0.152): in +1 the dead zone looked like an
    offset. Hysteresis is not asserted here: on this seed one held-out scheme-3 run keeps
    structure that the same run keeps even when fitted in-sample (0.53 realised vs 0.64
    predicted); the harness scores that figure over all its cells."""
    sh = tx_reports["backlash"]["transmission"]["shrinkage"]["overall"]
    assert sh["shrinkage"] > 0.1
    assert abs(sh["shrinkage"] - sh["predicted_from_training"]) <= 0.05, sh


@pytest.mark.slow
def test_the_bouc_wen_law_shape_comes_from_the_data(reports):
    """The nominal Bouc–Wen law's shape is fitted on the training runs (emulator truth:
    β = 600, γ = 400 rad⁻¹, yield twist 1e-3 rad) — not taken from the emulator's values."""
    shape = reports["none-1"]["transmission"]["baseline"]["shape"]
    assert shape["alpha"] == 1.0 and shape["n"] == 1
    assert 0.5e-3 < 1.0 / (shape["beta"] + shape["gamma"]) < 2e-3
    assert (shape["beta"], shape["gamma"]) != (600.0, 400.0)


@pytest.mark.slow
def test_nothing_injected_in_the_elastic_world_gives_none(tx_reports):
    rep = tx_reports["none-elastic"]
    assert rep["verdict"]["status"] == "none" and rep["verdict"]["effects"] == []
    assert not any(c["significant"] for c in rep["candidates"])


def test_the_sensor_floor_of_the_output_balance_counts_the_load_cell_too():
    """T − τ_L carries the noise of both readings: the floor is σ_T² + σ_L², not σ_T² alone
    (which called the load cell's noise structure)."""
    from estimator.diagnosis_floors import sensor_floor
    from estimator.models import eq4, eq5
    t = np.arange(0.0, 10.0, 0.01)
    samples = pd.DataFrame({"t": t, "q": 0.01 * t, "qd": np.full(t.size, 0.01),
                            "u": 0.01 * t, "torque": np.zeros(t.size),
                            "torque_load": np.zeros(t.size)})
    run = RunData(samples=samples, meta={"sample_rate_hz": 100.0, "sensors": {
        "torque": {"noise_sd": 150.0}, "torque_load": {"noise_sd": 200.0}}})
    assert sensor_floor([run], eq4(), {}) == pytest.approx(150.0 ** 2 + 200.0 ** 2)
    # the twist–torque law reads the joint torque only (no encoder steps stated here)
    assert sensor_floor([run], eq5(), {"k": 1e7}) == pytest.approx(150.0 ** 2)


def _with(run: RunData, **cols) -> RunData:
    """`run` with channels added or replaced (functions of its samples)."""
    df = run.samples.copy()
    for k, f in cols.items():
        df[k] = f(df)
    return RunData(samples=df, meta=dict(run.meta))


def test_an_asymmetric_coulomb_level_and_a_constant_offset_are_one_ambiguity_set():
    """Per direction of steady sliding a Coulomb level that differs by direction is a constant
    torque: the output law (rests left out) cannot tell it from a reading offset, and the
    report must say so — the chosen effect's ambiguity set holds the other."""
    def asym(t, q):
        return 400.0 * (np.gradient(q, t) > 0)
    train = [_synthetic(s, asym, q_amp=1.5) for s in (1, 2)]
    test = [_synthetic(s, asym, q_amp=1.5) for s in (3, 4)]
    rep = diagnose(train, test, "eq4", options=DiagnosisOptions(
        candidates=("torque_offset", "asymmetric_friction")))
    first = rep["verdict"]["effects"][0]
    other = ({"torque_offset", "asymmetric_friction"} - {first}).pop()
    assert other in rep["verdict"]["ambiguity_sets"][first]["effects"], rep["verdict"]
    assert f"≡ {other}" in rep["verdict"]["summary"]


def test_a_settling_torque_reading_is_named_with_its_time_constant():
    """torque_offset's family: a constant, a linear drift, or a reading that settles after
    start-up, 1 − exp(−t/τ) (τ searched on opt.offset_settling_s)."""
    def settle(t, q):
        return 600.0 * -np.expm1(-t / 10.0)
    train = [_synthetic(s, settle) for s in (1, 2)]
    test = [_synthetic(s, settle) for s in (3, 4)]
    rep = diagnose(train, test, "eq4", options=DiagnosisOptions(candidates=("torque_offset",)))
    assert rep["verdict"]["effects"] == ["torque_offset"]
    assert rep["verdict"]["shapes"]["torque_offset"] == {"settling": 10.0}


def test_a_viscosity_exponential_in_temperature_is_named_with_its_curvature():
    """temperature_friction's family: the viscous slope ∝ exp(0.06·(40 °C − T)) over runs at
    15–60 °C is named with a curved law (κ > 0), not only the linear one."""
    temps = {1: 15.0, 2: 60.0, 3: 25.0, 5: 50.0, 4: 20.0, 6: 55.0}

    def run(s):
        r = _synthetic(s, lambda t, q: 0 * t)
        qd = np.gradient(r.samples["q"].to_numpy(), r.samples["t"].to_numpy())
        extra = 8683.0 * np.expm1(0.06 * (40.0 - temps[s])) * qd
        return _with(r, temp_joint=lambda df: np.full(len(df), temps[s]),
                     torque=lambda df: df["torque"] + extra)
    train = [run(s) for s in (1, 2, 3, 5)]
    test = [run(s) for s in (4, 6)]
    rep = diagnose(train, test, "eq4",
                   options=DiagnosisOptions(candidates=("temperature_friction",)))
    assert rep["verdict"]["effects"] == ["temperature_friction"]
    assert rep["verdict"]["shapes"]["temperature_friction"].get("curvature", 0.0) > 0.0


def test_a_campaign_with_no_steady_sample_left_is_refused_in_words():
    """One run far faster than the others (rig G's blind score: a kinematic ripple scaled 199×
    by the harness, 0.62 rad/s against 0.03) sets the campaign's top speed, so every sample of
    the other runs lies within the transient window of near-zero speed and none is left. The
    diagnosis said `cannot convert float NaN to integer`; it now says what happened."""
    from commands.independent_harness import VARIANTS, simulate_campaign
    from core.run import RunData
    train, test, _ = simulate_campaign(VARIANTS[0], 7)
    wild = train[0].samples.copy()
    wild["qd"] = wild["qd"] * 1e4
    train = [RunData(samples=wild, meta=dict(train[0].meta))] + list(train[1:])
    with pytest.raises(ValueError, match=r"no (training|held-out) sample left .* near-zero speed"):
        diagnose(train, test, "eq4", transmission=None)


def test_the_encoder_step_floor_of_the_twist_law_follows_the_motion():
    """An output encoder at rest keeps its rounding error whole: (k·step)²/12 through the
    stiffness; one crossing many steps within the low-pass window averages it out. The floor is
    measured by re-quantising the run's smoothed angle and passing it through the law."""
    from estimator.diagnosis_floors import quantisation_floor
    from estimator.models import eq5
    from estimator.preprocess import PrepOptions
    fs, k = 100.0, 1e7
    step = np.deg2rad(0.01)
    t = np.arange(0.0, 60.0, 1.0 / fs)
    whole = (k * step) ** 2 / 12.0

    def floor(q, decimate):
        df = pd.DataFrame({"t": t, "q": np.round(q / step) * step, "u": q + 1e-3,
                           "torque": np.zeros(t.size)})
        run = RunData(df, {"sample_rate_hz": fs, "sensors": {"q": {"resolution": step},
                                                             "torque": {"noise_sd": 1.0}}})
        return quantisation_floor(run, eq5(), {"k": k, "D": 0.0, "C": 0.0},
                                  PrepOptions(decimate=decimate))

    assert floor(np.full(t.size, 0.123), 5) == pytest.approx(whole, rel=0.03)
    assert floor(0.03 * t, 1) == pytest.approx(whole, rel=0.03)      # unfiltered: white, whole
    assert floor(0.03 * t, 5) < 0.05 * whole                          # low-passed: averaged out
