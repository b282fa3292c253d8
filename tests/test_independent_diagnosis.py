"""The gap diagnosis on campaigns of the independently written validation rigs, which it was never
tuned on (commands.independent_harness): nothing withheld gives `none` (rig F: no effect named,
its nominal holds its load motor's ripple), one form of each effect
family at ENR 2 is named first on the law it acts on, an effect outside the vocabulary is not
explained — on the two-inertia and planned-motion rigs, rigs B, C, F, G, H and I (rigs F's, G's,
H's and I's after their blind scores), rig J's nominal and rig K's nominal and load-cell drift
after their blind scores; rig E's
stiffening transmission and intermediate-stage ripple. Fixed seeds (21, 22), chosen before these
campaigns were ever diagnosed (rig E's nominal: its blind seed, 801; rig J's seed 21 was
diagnosed once, with the twist zeros, before its test was written; rig K's seed 21 was never
diagnosed before its tests were written)."""

from __future__ import annotations

import pytest

from commands.independent_harness import VARIANTS, Variant, run_cell, simulate_campaign

TWO_INERTIA = Variant("two-inertia 20 Hz", "two_inertia",
                      {"sample_rate_hz": 20.0, "encoder_res_deg": 0.01})
PLANNED_FEW = Variant("planned-motion 10 Hz, 4+2 runs", "planned_motion",
                      {"sample_rate_hz": 10.0, "encoder_res_deg": 0.02, "torque_noise": 400.0},
                      few_runs=True)

RIG_B = Variant("rig B 50 Hz", "rig_b", {"sample_rate_hz": 50.0, "encoder_res_deg": 0.005})
RIG_C_FEW = Variant("rig C 25 Hz, 4+2 runs", "rig_c",
                    {"sample_rate_hz": 25.0, "encoder_res_deg": 0.01, "torque_noise": 300.0},
                    few_runs=True)

RIG_F_FEW = Variant("rig F 20 Hz, 0.001°, 10 ms lag, 4+2 runs", "rig_f",
                    {"sample_rate_hz": 20.0, "encoder_res_deg": 0.001, "torque_noise": 100.0,
                     "torque_lag_s": 0.01}, few_runs=True)

RIG_G_FEW = next(v for v in VARIANTS if v.rig == "rig_g" and v.few_runs)

RIG_H_FEW = next(v for v in VARIANTS if v.rig == "rig_h" and v.few_runs)

RIG_I_FEW = next(v for v in VARIANTS if v.rig == "rig_i" and v.few_runs)

RIG_I_500 = next(v for v in VARIANTS if v.rig == "rig_i" and not v.few_runs)

RIG_J_FEW = next(v for v in VARIANTS if v.rig == "rig_j" and v.few_runs)

RIG_K_FEW = next(v for v in VARIANTS if v.rig == "rig_k" and v.few_runs)

RIG_C_200 = Variant("rig C 200 Hz, 10 ms lag", "rig_c",
                    {"sample_rate_hz": 200.0, "encoder_res_deg": 0.002, "torque_lag_s": 0.01})

FAMILIES = [("stribeck", "lorentz"), ("temperature_friction", "mult_both"),
            ("load_dependent_friction", "both"), ("asymmetric_friction", "viscous"),
            ("gear_ripple", "harmonics"), ("backlash", "smooth"), ("hysteresis", "dahl"),
            ("torque_offset", "drift"), ("time_delay", "torque")]


@pytest.mark.slow
@pytest.mark.parametrize("variant", [
    # rig G: a harmonic drive's three-segment compliance, named `backlash` in its blind score
    # until the nominal law took the curve's knees (docs/diagnosis.md, "After rig G")
    # rig H: its torque chain's unstated phase draws a loop run backwards (k_h < 0), named
    # `hysteresis` in its blind score until hysteresis had to be passive
    # rig I: its transmission's soft centre was named `backlash` in its blind score, and its
    # output law kept structure until it read the output angle's derivative instead of the
    # lagging velocity reading (docs/diagnosis.md, "Rig I")
    # rig J: each run's output-encoder zero, somewhere within a step, made its twist law
    # `unexplained` in its blind score until the law set each run's zero from its own data
    # within the encoders' steps (docs/diagnosis.md, "Rig J")
    # rig K: `none` in its blind score (docs/diagnosis.md, "Rig K")
    TWO_INERTIA, PLANNED_FEW, RIG_B, RIG_C_FEW, RIG_G_FEW, RIG_H_FEW,
    # rig I at 25 Hz: since its tanh compliance curve is the nominal's own (smooth_corner), a
    # 40 N·m loop is left that the hysteresis candidate takes at a held-out shrinkage of
    # 0.050 (seeds 21–23 of 21–25 and 1301); a known false alarm (docs/diagnosis.md, "A
    # compliance curve that bends over its whole range")
    pytest.param(RIG_I_FEW, marks=pytest.mark.xfail(
        strict=True, reason="rig I 25 Hz: a false hysteresis once its curve is fitted")),
    RIG_J_FEW, RIG_K_FEW],
    ids=lambda v: v.rig)
def test_nothing_withheld_is_none(variant):
    c = run_cell(variant, 21, None, None, 0.0, "none")
    assert c["status"] == "none" and c["effects"] == [], c


@pytest.mark.slow
def test_rig_fs_load_motor_ripple_names_no_effect():
    """Rig F's nominal holds its load motor's torque ripple (order 1200 of q, 5.5 Hz at
    3000 r/min, inside the 20 Hz variant's band): a real periodic torque the nominal lacks. With
    the lagged torque's noise at its stated sd it shows as structure (`unexplained`, seeds 21
    and 2201); what must hold is that no effect is named for it."""
    c = run_cell(RIG_F_FEW, 21, None, None, 0.0, "none")
    assert c["effects"] == [] and c["status"] in ("none", "unexplained"), c


@pytest.mark.slow
@pytest.mark.parametrize("effect,form", FAMILIES)
def test_each_family_is_named_first_on_its_law(effect, form):
    c = run_cell(TWO_INERTIA, 22, effect, form, 2.0, "single")
    assert c["named_first"] == effect, c
    assert c["status"] in ("explained", "partly_explained")


@pytest.mark.slow
@pytest.mark.parametrize("effect", ("stribeck", "temperature_friction", "load_dependent_friction",
                                    "asymmetric_friction", "gear_ripple", "backlash",
                                    "hysteresis", "torque_offset", "time_delay"))
def test_each_family_of_rig_c_is_named_first_on_its_law(effect):
    """Rig C (written blind to the diagnosis), each family in its first form (the rule fixed
    before any rig-C campaign was diagnosed), ENR 2, the 4 + 2-run 25 Hz campaign. Stribeck
    was a known miss (the curve under the transient mask) until the balance's band was cut
    where its velocity reading cannot carry q̈ (docs/diagnosis.md, "The inertia the velocity
    reading cannot carry")."""
    from validation_rigs import rig_c
    c = run_cell(RIG_C_FEW, 22, effect, rig_c.EFFECT_FORMS[effect][0], 2.0, "single")
    assert c["named_first"] == effect or effect in c["first_alike"], c


@pytest.mark.slow
@pytest.mark.parametrize("variant,effect", [(TWO_INERTIA, "periodic_disturbance"),
                                            (PLANNED_FEW, "position_stiffness"),
                                            (RIG_B, "second_resonance"),
                                            (RIG_C_FEW, "periodic_disturbance"),
                                            (RIG_F_FEW, "periodic_disturbance"),
                                            (RIG_G_FEW, "periodic_disturbance"),
                                            (RIG_H_FEW, "periodic_disturbance"),
                                            (RIG_I_FEW, "position_dependent_stiffness"),
                                            # its load cell's drift: the torque channel's own
                                            # law does not show it (estimator.diagnosis_channel)
                                            (RIG_K_FEW, "sensor_drift")],
                         ids=["two_inertia", "planned_motion", "rig_b", "rig_c", "rig_f",
                              "rig_g", "rig_h", "rig_i", "rig_k"])
def test_an_effect_outside_the_vocabulary_is_not_explained(variant, effect):
    from commands.independent_harness import rig_module
    mod = rig_module(variant.rig)
    c = run_cell(variant, 21, effect, mod.EFFECT_FORMS[effect][0], 2.0, "oov")
    assert c["status"] in ("unexplained", "partly_explained"), c


@pytest.mark.slow
@pytest.mark.parametrize("effect,form", [("gear_ripple", "output_angle"),
                                         ("load_dependent_friction", "coulomb"),
                                         ("time_delay", "pure")])
def test_rig_i_names_its_output_side_and_sensor_effects_first(effect, form):
    """Families rig I's blind score named in every campaign at ENR ≥ 1 (25 Hz, 4 + 2 runs)."""
    c = run_cell(RIG_I_FEW, 22, effect, form, 2.0, "single")
    assert c["named_first"] == effect or effect in c["first_alike"], c


@pytest.mark.slow
def test_a_passive_hysteresis_is_still_named_on_rig_h():
    """The sign rule that keeps rig H's backwards loop out (k_h > 0) keeps a real one in: its
    Bouc–Wen transmission hysteresis at ENR 2, 20 Hz, 0.02° encoder, 4 + 2 runs."""
    c = run_cell(RIG_H_FEW, 22, "hysteresis", "bouc_wen_n1", 2.0, "single")
    assert c["named_first"] == "hysteresis" and c["status"] == "explained", c


def _cell(kind, effect, form, enr, status, effects, first, extra=(), shr=((0.3, 0.32),)):
    return {"variant": "v", "seed": 1, "kind": kind, "effect": effect, "form": form,
            "enr": enr, "enr_realised": enr, "status": status, "effects": list(effects),
            "laws": {}, "named_first": first, "extra": list(extra),
            "shrinkages": [tuple(s) for s in shr], "seconds": 1.0}


def test_independent_scores_and_the_side_by_side_table():
    from commands.independent_harness import format_side_by_side, score
    cells = [_cell("none", None, None, 0.0, "none", [], None, shr=()),
             _cell("none", None, None, 0.0, "explained", ["stribeck"], None, ["stribeck"], ()),
             _cell("single", "stribeck", "gauss", 1.0, "explained", ["stribeck"], "stribeck"),
             _cell("single", "stribeck", "lorentz", 1.0, "explained", ["gear_ripple"], None,
                   ["gear_ripple"], ((0.1, 0.3),)),
             _cell("single", "backlash", "sharp", 0.5, "explained", ["backlash"], "backlash"),
             _cell("oov", "periodic_disturbance", "sine", 2.0, "unexplained", [], None, shr=())]
    cells[3]["coverage_short"] = ["q"]   # the miss's verdict said its split could not test it
    s = score(cells)
    assert s["coverage_noted"] == {"misses": [1, 1], "hits": [0, 1]}
    assert s["none_verdict"] == 0.5 and s["top1"] == {"0.5": 1.0, "1.0": 0.5}
    assert s["top1_by_form_enr_ge_1"] == {"stribeck": {"gauss": 1.0, "lorentz": 0.0}}
    assert s["extra_effect_named"] == pytest.approx(2 / 5) and s["oov_not_explained"] == 1.0
    assert s["shrinkage_abs_error_median"] == pytest.approx(0.02)
    own = {"scores": {"none_verdict": 1.0, "top1": {"0.5": 1.0, "1.0": 1.0, "2.0": 1.0},
                      "false_alarm": 0.0, "oov_unexplained": 1.0,
                      "shrinkage_abs_error_median": 0.01}}
    text = format_side_by_side(own, {"scores": s, "cells": cells, "variants": ["v"],
                                     "seeds": 1, "first_seed": 31, "seconds": 1.0})
    assert "own-emulator minus independent top-1" in text and " 0.500  <= 0.05  NO" in text
    assert "cells missed (2)" in text   # the stribeck miss and the none cell that named one
    assert "range of an input on 1 of 1 misses and 0 of 1 hits at ENR >= 1)" in text
    assert "['gear_ripple'] [held-out coverage short: q]" in text


def test_a_scale_the_rig_cannot_make_is_clamped_and_said():
    """Rig N refuses scales above 10: its blind score lost campaigns that asked for more as
    `error`. The campaign now runs at the rig's largest scale, says so, and reports the ENR it
    realised. Rig R's 11 Hz load-side resonance needs a scale near 7.4 for ENR 2 at 15 Hz, and
    rig R stops at 5."""
    from commands.independent_harness import largest_scale
    assert largest_scale("rig_n") == 10.0 and largest_scale("rig_m") == 3.0
    assert largest_scale("rig_r") == 5.0 and largest_scale("two_inertia") is None
    v = next(v for v in VARIANTS if v.rig == "rig_r" and v.few_runs)
    c = run_cell(v, 5, "second_resonance", "load_side_11hz", 2.0, "oov")
    assert c["status"] != "error" and c["scale_clamped"] is True
    assert 0.0 < c["enr_realised"] < 2.0


def test_an_effect_the_rig_carries_unstated_is_scored_both_ways():
    """Rig M's bending moment leaks into its torque reading as a constant offset it does not
    state: naming `torque_offset` there is a false alarm to the strict figure and right about
    the rig; the score reports both, and the table prints the second only beside the first."""
    from commands.independent_harness import format_side_by_side, score
    from core.effects import VOCABULARY
    from validation_rigs import rig_m
    assert set(rig_m.UNSTATED_VOCABULARY) <= set(VOCABULARY)
    cells = [_cell("none", None, None, 0.0, "explained", ["torque_offset"], None,
                   ["torque_offset"], ()),
             _cell("none", None, None, 0.0, "partly_explained", ["torque_offset"], None,
                   ["torque_offset"], ()),
             _cell("none", None, None, 0.0, "explained", ["stribeck"], None, ["stribeck"], ()),
             _cell("single", "backlash", "sharp", 1.0, "explained",
                   ["backlash", "torque_offset", "stribeck"], "backlash",
                   ["torque_offset", "stribeck"])]
    for c in cells[:2]:
        c["extra_unstated"] = ["torque_offset"]
    cells[3]["extra_unstated"] = ["torque_offset"]
    s = score(cells)
    assert s["extra_effect_named"] == 1.0
    assert s["extra_effect_named_beyond_unstated"] == pytest.approx(2 / 4)
    assert s["none_verdict"] == 0.0 and s["none_or_only_unstated"] == pytest.approx(1 / 3)
    text = format_side_by_side(None, {"scores": s, "cells": cells, "variants": ["v"],
                                      "seeds": 1, "first_seed": 1, "seconds": 1.0})
    strict = next(ln for ln in text.splitlines()
                  if ln.startswith("an effect named that was not withheld"))
    assert " 1.000 " in strict and strict.endswith("NO")
    assert "UNSTATED_VOCABULARY: an effect named that was not withheld 0.500" in text
    assert "only that effect, explained 0.333" in text
    for c in cells:
        c["extra_unstated"] = []
    assert "UNSTATED_VOCABULARY" not in format_side_by_side(
        None, {"scores": score(cells), "cells": cells, "variants": ["v"], "seeds": 1,
               "first_seed": 1, "seconds": 1.0})


def test_top1_passing_over_an_effect_the_rig_carries_unstated_is_reported_beside():
    """Rig Q's load cell lags its torque reading by ~5 ms it does not state: `time_delay`
    named before a withheld Stribeck curve is right about the rig, a miss to the strict
    top-1. The score adds the top-1 that passes over such a name (never over a name the rig
    does not carry, never on the other law), and the table prints it beside the strict one."""
    from commands.independent_harness import first_named, format_side_by_side, score
    laws = {"output": ["time_delay", "stribeck"], "transmission": ["backlash"]}
    assert first_named("stribeck", laws) == "time_delay"
    assert first_named("stribeck", laws, frozenset({"time_delay"})) == "stribeck"
    assert first_named("stribeck", laws, frozenset({"torque_offset"})) == "time_delay"
    assert first_named("time_delay", laws, frozenset({"time_delay"})) == "time_delay"
    assert first_named("hysteresis", laws, frozenset({"backlash"})) is None
    assert first_named(None, laws) is None
    # gear ripple counts on either law, after the passing over
    assert first_named("gear_ripple", {"output": ["torque_offset", "gear_ripple"],
                                       "transmission": []},
                       frozenset({"torque_offset"})) == "gear_ripple"
    cells = [_cell("single", "stribeck", "gauss", 1.0, "partly_explained",
                   ["time_delay", "stribeck"], "time_delay", ["time_delay"]),
             _cell("single", "stribeck", "lorentz", 1.0, "partly_explained",
                   ["asymmetric_friction", "stribeck"], "asymmetric_friction",
                   ["asymmetric_friction"]),
             _cell("single", "backlash", "sharp", 1.0, "explained", ["backlash"], "backlash")]
    cells[0]["laws"] = {"output": ["time_delay", "stribeck"], "transmission": []}
    cells[1]["laws"] = {"output": ["asymmetric_friction", "stribeck"], "transmission": []}
    cells[2]["laws"] = {"output": [], "transmission": ["backlash"]}
    for c in cells:
        c["unstated"] = ["time_delay"]
    s = score(cells)
    assert s["top1_enr_ge_1"] == pytest.approx(1 / 3)
    assert s["top1_enr_ge_1_beyond_unstated"] == pytest.approx(2 / 3)
    text = format_side_by_side(None, {"scores": s, "cells": cells, "variants": ["v"],
                                      "seeds": 1, "first_seed": 1, "seconds": 1.0})
    assert "withheld one: top-1 at ENR >= 1 0.667" in text
    for c in cells:
        c["unstated"] = []
    assert score(cells)["top1_enr_ge_1_beyond_unstated"] == pytest.approx(1 / 3)
    assert "withheld one: top-1" not in format_side_by_side(
        None, {"scores": score(cells), "cells": cells, "variants": ["v"], "seeds": 1,
               "first_seed": 1, "seconds": 1.0})


def test_campaigns_whose_effect_the_rig_could_not_make_are_scored_again_without_them():
    """Rig R's position-dependent stiffness reaches ENR 0.03 at its largest scale, and its
    encoder's drift moves T − τ_L not at all (ENR 0): `none` is right on such a campaign and the
    strict out-of-vocabulary figure counts it a miss. The score keeps the strict figures and adds
    them without the campaigns made below half the ENR asked for, printed only when any is."""
    from commands.independent_harness import format_side_by_side, score
    cells = [_cell("none", None, None, 0.0, "none", [], None, shr=()),
             _cell("single", "backlash", "sharp", 1.0, "explained", ["backlash"], "backlash"),
             _cell("single", "stribeck", "exp", 1.0, "none", [], None, shr=()),
             _cell("single", "stribeck", "exp", 0.5, "none", [], None, shr=()),
             _cell("oov", "position_stiffness", "cosine", 2.0, "none", [], None, shr=()),
             _cell("oov", "periodic_disturbance", "sine", 2.0, "unexplained", [], None, shr=())]
    cells[2]["enr_realised"] = 0.3      # clamped: made 0.3 of the 1.0 asked
    cells[3]["enr_realised"] = 0.26     # made more than half the 0.5 asked: kept
    cells[4]["enr_realised"] = 0.03
    s = score(cells)
    assert s["top1_enr_ge_1"] == 0.5 and s["oov_not_explained"] == 0.5
    assert s["as_made"] == {"campaigns_left_out": 2, "top1_enr_0.5": 0.0, "top1_enr_ge_1": 1.0,
                            "oov_not_explained": 1.0}
    text = format_side_by_side(None, {"scores": s, "cells": cells, "variants": ["v"],
                                      "seeds": 1, "first_seed": 1, "seconds": 1.0})
    assert ("(without the 2 campaigns whose effect the rig made below 0.5 of the ENR asked for: "
            "top-1 at ENR 0.5 0.000, at ENR >= 1 1.000, out of vocabulary -> unexplained/partly "
            "1.000)") in text
    for c in cells:
        c["enr_realised"] = c["enr"]
    assert "as_made" not in score(cells)
    assert "campaigns whose effect the rig made below" not in format_side_by_side(
        None, {"scores": score(cells), "cells": cells, "variants": ["v"], "seeds": 1,
               "first_seed": 1, "seconds": 1.0})


def test_a_campaign_the_diagnosis_fails_on_is_scored_as_a_failure(monkeypatch):
    """One campaign that raises must not end the score (rig G's blind score lost its first
    30 cells that way): it is an `error` cell, a miss in every figure it enters, listed with
    its error."""
    import commands.independent_harness as h

    def boom(variant, seed, effect, form, enr, kind):
        if effect == "backlash":
            raise ValueError("cannot convert float NaN to integer")
        if effect is None:
            return _cell(kind, None, None, 0.0, "none", [], None, shr=())
        return _cell(kind, effect, form, enr, "explained", [effect], effect)

    monkeypatch.setattr(h, "run_cell", boom)
    v = Variant("v", "rig_g", {})
    cells = [h._run((v, 1, "stribeck", "gauss", 1.0, "single")),
             h._run((v, 1, "backlash", "sharp", 1.0, "single")),
             h._run((v, 1, None, None, 0.0, "none"))]
    bad = cells[1]
    assert bad["status"] == "error" and bad["effects"] == [] and "NaN" in bad["error"]
    s = h.score(cells)
    assert s["errors"] == 1 and s["top1_enr_ge_1"] == 0.5
    text = h.format_side_by_side(None, {"scores": s, "cells": cells, "variants": ["v"],
                                        "seeds": 1, "first_seed": 1, "seconds": 1.0})
    assert "1 campaigns raised an error" in text and "cannot convert float NaN" in text


@pytest.mark.slow
def test_the_drive_train_ringing_below_the_encoder_step_is_not_a_gap():
    """Rig C at 200 Hz: the output inertia rings on the transmission stiffness at
    √(k/I)/2π ≈ 7.2 Hz with a motion of the order of the 0.002° encoder step, so I·q̈ is not
    measurable there. The output balance is analysed below half that mode (measured from the
    runs: k from torque vs twist, I below 2 Hz): with nothing withheld the structured share left
    falls from 0.75 (a 7.2 Hz line, I fitted at a tenth of the rig's) to ~0.05, and the inertia
    is the rig's. (0.05 is the constant `min_structured`: this campaign's verdict sits on it,
    docs/diagnosis.md.)"""
    from commands.independent_harness import simulate_campaign
    from estimator.diagnosis import diagnose
    train, test, raw = simulate_campaign(RIG_C_200, 21)
    rep = diagnose(train, test, "eq4", transmission="eq5")
    mode = rep["drive_train_mode"]
    assert mode is not None and 6.0 < mode["mode_hz"] < 8.5, mode
    assert mode["cutoff_hz"] == pytest.approx(0.5 * mode["mode_hz"])
    assert rep["verdict"]["structured_share_before"] < 0.10, rep["verdict"]["summary"]
    assert 5000.0 < rep["baseline"]["params"]["I_xx"]["value"] < 9000.0


RIG_E_FEW = Variant("rig E 50 Hz, 0.02°, 5 ms lag, 4+2 runs", "rig_e",
                    {"sample_rate_hz": 50.0, "encoder_res_deg": 0.02, "torque_lag_s": 0.005},
                    few_runs=True)


@pytest.mark.slow
def test_a_stiffening_transmission_is_part_of_the_nominal_law():
    """Rig E's transmission stiffens with the twist (k₀·(1 + κ(Δ/Δ_r)²)); a law linear in the
    twist named that `backlash` in every campaign of its blind score. The nominal twist–torque
    law carries a cubic stiffness (estimator.models.with_stiffening): nothing withheld → none
    (seed 801, the blind score's: `explained — backlash` without it)."""
    c = run_cell(RIG_E_FEW, 801, None, None, 0.0, "none")
    assert c["status"] == "none" and c["effects"] == [], c


@pytest.mark.slow
def test_an_intermediate_stages_transmission_error_is_a_gear_ripple():
    """Rig E's intermediate-stage transmission error (220 and 440 cycles per turn of u: neither
    an output-angle order of the search nor a whole number of motor turns) was named
    `hysteresis` in its blind score; the stage orders on u and the harmonics name it."""
    from validation_rigs import rig_e
    assert "intermediate_error" in rig_e.EFFECT_FORMS["gear_ripple"]
    c = run_cell(RIG_E_FEW, 22, "gear_ripple", "intermediate_error", 2.0, "single")
    assert c["named_first"] == "gear_ripple", c


def test_validate_diagnosis_rig_selects_the_variants_and_refuses_an_unknown_rig(capsys):
    from commands.cli import main
    assert main(["validate-diagnosis", "--independent", "--rig", "no_such_rig"]) == 2
    err = capsys.readouterr().err
    assert "no_such_rig" in err and "rig_d" in err and len(err.strip().splitlines()) == 1
    assert main(["validate-diagnosis", "--rig", "rig_d"]) == 2      # needs --independent


@pytest.mark.slow
def test_a_two_law_effect_is_scaled_on_the_law_where_it_shows():
    """A gear ripple that is an angle error inside the transmission barely moves T − τ_L; its
    ENR is the twist law's (k·Δ against that law's noise), so ENR 1 asks for a ripple of the
    size that law sees, not one many times the data sheet's."""
    import numpy as np
    from commands.independent_harness import _stiffness, contribution_enr, simulate_campaign
    base = simulate_campaign(RIG_H_FEW, 5)[2]
    kinematic = simulate_campaign(RIG_H_FEW, 5, {"gear_ripple": {
        "form": "output_kinematic_error", "scale": 1.0}})[2]
    spec = base[0].meta["sensors"]
    sig_t, sig_l = spec["torque"]["noise_sd"], spec["torque_load"]["noise_sd"]
    out = np.concatenate([(w.samples["torque"] - w.samples["torque_load"]
                           - b.samples["torque"] + b.samples["torque_load"]).to_numpy()
                          for w, b in zip(kinematic, base)])
    k = _stiffness(base)
    tw = np.concatenate([k * (w.truth["twist"] - b.truth["twist"]).to_numpy()
                         for w, b in zip(kinematic, base)])
    on_output = np.sqrt(np.mean(out ** 2)) / np.hypot(sig_t, sig_l)
    on_twist = np.sqrt(np.mean(tw ** 2)) / np.sqrt(sig_t ** 2
                                                  + (k * spec["q"]["resolution"]) ** 2 / 12)
    enr = contribution_enr(RIG_H_FEW, 5, "gear_ripple", "output_kinematic_error", base)
    assert on_twist > 5 * on_output
    assert enr == pytest.approx(on_twist, rel=1e-9)


@pytest.mark.slow
def test_an_angle_readings_effect_and_an_out_of_vocabulary_one_are_scaled_where_they_show():
    """Rig R's encoder lag leaves T − τ_L and the machine untouched: the blind score ran it at
    the rig's largest scale (ENR 0 asked to be 1). It is measured on the twist the readings
    give. A position-dependent stiffness (outside the vocabulary) is measured on both laws,
    the larger ratio: it was measured on T − τ_L alone and reached ENR 0.03 there."""
    import numpy as np
    from commands.independent_harness import _stiffness, contribution_enr, simulate_campaign
    v = next(v for v in VARIANTS if v.rig == "rig_r" and v.few_runs)
    base = simulate_campaign(v, 5)[2]
    spec = base[0].meta["sensors"]
    k = _stiffness(base)
    noise_twist = np.sqrt(spec["torque"]["noise_sd"] ** 2
                          + (k * spec["q"]["resolution"]) ** 2 / 12)
    lag = simulate_campaign(v, 5, {"time_delay": {"form": "encoder", "scale": 1.0}})[2]
    assert all(np.array_equal(w.truth["twist"], b.truth["twist"]) for w, b in zip(lag, base))
    read = np.concatenate([k * ((w.samples["u"] - w.samples["q"])
                                - (b.samples["u"] - b.samples["q"])).to_numpy()
                           for w, b in zip(lag, base)])
    enr = contribution_enr(v, 5, "time_delay", "encoder", base)
    assert enr > 0.1
    assert enr == pytest.approx(np.sqrt(np.mean(read ** 2)) / noise_twist, rel=1e-9)
    stiff = simulate_campaign(v, 5, {"position_stiffness": {"form": "cosine", "scale": 1.0}})[2]
    tw = np.concatenate([k * (w.truth["twist"] - b.truth["twist"]).to_numpy()
                         for w, b in zip(stiff, base)])
    on_twist = np.sqrt(np.mean(tw ** 2)) / noise_twist
    enr = contribution_enr(v, 5, "position_stiffness", "cosine", base)
    assert enr >= on_twist * (1 - 1e-9)


@pytest.mark.slow
def test_rig_i_500_hz_nominal_output_balance_names_nothing():
    """Rig I at 500 Hz, nothing withheld. Three things the balance could not read as they
    were: its stiffening drive train rings at 5.6–7.6 Hz (the soft centre's stiffness to the
    outer one), below the 0.005° encoder's step, spread over a band where no single line
    stands out; its velocity reading is a 3 Hz tracking loop's; and a load released at speed
    slips the joint forward and stops it for ~0.1 s, which that reading smooths over. The band
    is cut below half the mode on the band's excess power, the velocity is the output angle's
    derivative, and the stop is seen in the angle (the campaign was `unexplained`, structured
    share 0.72, before these; `none` with them, until a stop inside a motion was left out
    alone)."""
    from commands.independent_harness import simulate_campaign
    from estimator.diagnosis import diagnose
    train, test, _ = simulate_campaign(RIG_I_500, 21)
    rep = diagnose(train, test, "eq4", transmission=None)
    mode = rep["drive_train_mode"]
    assert mode is not None and mode["line_hz"] is None and mode["band_excess"] > 2.0, mode
    assert rep["velocity"]["source"] == "output angle", rep["velocity"]
    # a stop inside a motion is left out alone now (a stick of stick–slip, between whose
    # slips a Stribeck curve is seen): the breakaway after it stays in, a friction short of
    # the Coulomb level at low speed, which no effect is named for (a Stribeck curve of
    # negative height has the sign no Stribeck has)
    assert rep["verdict"]["effects"] == [], rep["verdict"]["summary"]
    stribeck = next(c for c in rep["candidates"] if c["effect"] == "stribeck")
    assert not stribeck["significant"], stribeck
    if rep["verdict"]["status"] != "none":
        pytest.xfail("the breakaway after a stop inside a motion leaves structure "
                     "(docs/diagnosis.md, 'A rest is where the motion rests')")


@pytest.mark.slow
@pytest.mark.parametrize("variant,form", [(TWO_INERTIA, "exp"), (RIG_B, "gauss")],
                         ids=["two_inertia", "rig_b"])
def test_a_stribeck_curve_whose_slow_runs_stick_and_slip_is_named(variant, form):
    """At ENR 1 on these rigs the Stribeck curve makes the 300 r/min runs stick and slip. A
    window of 0.5 s around every stick took those runs whole, and with them the curve
    (`none`); the sticks are now left out alone (estimator.diagnosis_inputs.transient_mask)."""
    c = run_cell(variant, 2201, "stribeck", form, 1.0, "single")
    assert c["named_first"] == "stribeck", c


@pytest.mark.slow
def test_rig_i_soft_centre_is_the_nominal_curves_not_backlash():
    """Rig I's transmission keeps 0.55 of its stiffness inside ±1.7 mrad: its blind score named
    `backlash` there in every campaign. The nominal curve takes it as its soft centre now, and a
    hysteresis injected on top is named."""
    c = run_cell(RIG_I_FEW, 21, None, None, 0.0, "none")
    assert "backlash" not in c["effects"], c
    c = run_cell(RIG_I_FEW, 22, "hysteresis", "bouc_wen_n1", 2.0, "single")
    assert c["named_first"] == "hysteresis" and "backlash" not in c["effects"], c


@pytest.mark.slow
@pytest.mark.parametrize("variant", [next(v for v in VARIANTS if v.rig == "rig_m" and v.few_runs),
                                     next(v for v in VARIANTS if v.rig == "rig_o" and v.few_runs)])
def test_a_torque_zero_that_follows_the_temperature_is_a_torque_offset(variant):
    """Rigs M and O carry a strain-gauge zero that follows the joint's temperature (N·m per K):
    each run's offset differs with its temperature, which no constant and drift shared by the
    runs fits. torque_offset's family now holds it (shape `thermal`)."""
    c = run_cell(variant, 22, "torque_offset", "thermal", 2.0, "single")
    assert c["named_first"] == "torque_offset", c


def test_the_harness_workers_run_one_blas_thread_each(monkeypatch):
    """Two workers on two cores, each calling a two-thread OpenBLAS, made a 750 Hz campaign's
    diagnosis 18 times slower (docs/diagnosis.md). The workers start afresh and read one thread
    when they load numpy, unless the environment says otherwise."""
    import os

    from commands.independent_harness import _single_blas_pool
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    with _single_blas_pool(1) as pool:
        assert pool.submit(os.getenv, "OPENBLAS_NUM_THREADS").result() == "1"
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    with _single_blas_pool(1) as pool:
        assert pool.submit(os.getenv, "OPENBLAS_NUM_THREADS").result() == "2"


@pytest.mark.slow
def test_rig_ps_load_cell_gain_error_is_named_with_its_alternative():
    """Rig P's load cell reads 0.026 % low (unstated); its load always resists the motion, so
    the output law's `load_dependent_friction` is that gain error to these runs (seed 2001, the
    blind score's). The verdict names the alternative, with the relative gain μ stands for."""
    from estimator.diagnosis import diagnose
    rig_p = next(v for v in VARIANTS if v.rig == "rig_p" and not v.few_runs)
    train, test, raw = simulate_campaign(rig_p, 2001)
    rep = diagnose(train, test, "eq4", transmission="eq5")
    gain = rep["verdict"]["ambiguity_sets"]["load_dependent_friction"]["gain_mismatch"]
    mismatch = (raw[0].params["unstated"]["torque_gain_error"]
                - raw[0].params["unstated"]["load_gain_error"])
    assert gain["driving_share"] < 0.01
    assert gain["relative_gain_error"] == pytest.approx(mismatch, rel=0.3)
    assert "or a gain mismatch of" in rep["verdict"]["summary"]


def test_rig_qs_torque_reading_gain_is_read_by_the_nominal_where_its_load_also_drives():
    """Rig Q's torque transducer and load cell differ in gain (unstated, 0.18 % on seed 5), and
    its load drives the joint in the runs that turn backwards: the output law's nominal takes
    that gain (g_T) and the nominal campaign is `none`; before, the gain's load-shaped gap left
    the output law `unexplained`."""
    from estimator.diagnosis import diagnose
    rig_q = next(v for v in VARIANTS if v.rig == "rig_q" and v.few_runs)
    train, test, raw = simulate_campaign(rig_q, 5)
    rep = diagnose(train, test, "eq4", transmission="eq5")
    un = raw[0].params["unstated"]
    mismatch = un["torque_gain_error"] - un["load_cell_gain_error"]
    assert rep["baseline"]["model"] == "eq4+torque_gain"
    assert rep["baseline"]["params"]["g_T"]["value"] == pytest.approx(mismatch, abs=5e-4)
    assert rep["verdict"]["status"] == "none", rep["verdict"]["summary"]


@pytest.mark.slow
def test_a_loss_only_while_the_motors_drive_is_named_where_the_load_also_drives():
    """Rig C's `power_flow` load-dependent friction (a gear that loses only while the motors
    drive) on the 4 + 2-run 25 Hz campaign, whose load drives the joint in some runs: a
    coefficient per power flow is μ ± g_T there, and it is tried beside the torque reading's
    gain; a per-power-flow μ below zero beyond its standard errors is that gain, not a gear
    (estimator.models.PHYSICAL_SIGN_BEYOND_NOISE). Before, the shape was not tried on such runs
    and the campaign said `asymmetric_friction`."""
    c = run_cell(RIG_C_FEW, 2209, "load_dependent_friction", "power_flow", 1.0, "single")
    assert c["named_first"] == "load_dependent_friction", c
    assert c["extra"] == [], c


@pytest.mark.slow
def test_rig_qs_torque_lag_whose_gain_sits_at_the_torque_steps_is_named():
    """Rig Q at 1 kHz with its torque reading delayed (ENR 2, seed 2101): the delay's candidate
    shrinks the held-out error by 0.69 but 4 of the 228 held-out blocks carry 69 % of that gain,
    so its gain / SE stays at 2.9; 85 % of the blocks improve, and it is named (before:
    `unexplained` with nothing named)."""
    rig_q = next(v for v in VARIANTS if v.rig == "rig_q" and not v.few_runs)
    c = run_cell(rig_q, 2101, "time_delay", "torque", 2.0, "single")
    assert c["named_first"] == "time_delay", c


@pytest.mark.slow
def test_a_late_encoder_is_named_time_delay_and_a_leftover_under_the_rounding_is_not():
    """Rig R's encoder lag (q and q̇ read late) is a twist error d·q̇ on the twist–torque law:
    named `time_delay` (shape angle); it was `unexplained` before the family had the column.
    Rig J's nominal campaign at 40 Hz leaves a speed-like twist error of ~1e-5 rad RMS, a
    fifth of the 0.01° encoder's rounding: the lag is objected to there, and it stays `none`."""
    rig_r = next(v for v in VARIANTS if v.rig == "rig_r" and not v.few_runs)
    c = run_cell(rig_r, 2209, "time_delay", "encoder", 1.0, "single")
    assert c["named_first"] == "time_delay" and c["laws"]["transmission"] == ["time_delay"], c
    rig_j = next(v for v in VARIANTS if v.rig == "rig_j" and v.few_runs)
    c = run_cell(rig_j, 2209, None, None, 0.0, "none")
    assert c["status"] == "none", c


@pytest.mark.slow
def test_a_stage_ripple_above_order_2000_is_searched_up_to_the_reduction():
    """Rig T's input-shaft transmission error (2 and 4 cycles per turn of the main stage's input
    shaft, which turns N/10 = 1100 times per output turn: orders 2200 and 4400 on u) lay above
    the stage orders searched while they stopped at 2000; rig T's blind score missed it in 4 of
    4 campaigns. Searched up to the runs' reduction N (the motor's first order), it is named on
    the twist–torque law at its order."""
    rig_t = next(v for v in VARIANTS if v.rig == "rig_t" and not v.few_runs)
    c = run_cell(rig_t, 2209, "gear_ripple", "input_shaft_kinematic", 1.0, "single")
    assert "gear_ripple" in c["laws"]["transmission"], c
    import numpy as np
    from estimator.diagnosis_candidates import stage_max_order
    from estimator.diagnosis_options import DiagnosisOptions
    red = np.full(3, 11000.0)
    assert stage_max_order({"reduction": red}, DiagnosisOptions()) == 11000.0
    assert stage_max_order({"reduction": np.zeros(3)}, DiagnosisOptions()) == 2000.0
    assert stage_max_order({"reduction": red},
                           DiagnosisOptions(stage_ripple_max_order=500)) == 500.0


@pytest.mark.slow
def test_a_preloaded_stiffer_centre_is_nominal_and_leaves_the_twist_law_to_its_effects():
    """Rig V's main stage is stiffer at its centre (T_s·tanh(Δ/θ_s): 5 kN·m within 0.2 mrad).
    In its blind score no nominal term took it: the twist–torque law's held-out residual was
    91–99 % structured in every nominal campaign, and hysteresis at 40 Hz and ENR 1 was missed
    in 4 of 4 forms. The stiffer centre is now part of the nominal (centre_knee)."""
    from estimator.diagnosis import diagnose
    rig_v = next(v for v in VARIANTS if v.rig == "rig_v" and v.few_runs)
    train, test, _ = simulate_campaign(rig_v, 4901)
    tx = diagnose(train, test, "eq4", transmission="eq5")["transmission"]
    assert tx["verdict"]["status"] == "none", tx["verdict"]
    assert 1e-4 < tx["baseline"]["shape"]["stiff_centre"] < 4e-4, tx["baseline"]["shape"]
    c = run_cell(rig_v, 4901, "hysteresis", "bouc_wen_n1", 1.0, "single")
    assert "hysteresis" in c["laws"]["transmission"], c


@pytest.mark.slow
def test_rig_w_names_its_twist_law_effects_and_leaves_its_nominal_to_what_it_declares():
    """Rig W at 22 Hz with 4 + 2 runs, its blind seed 5001 (development data since its score,
    docs/diagnosis.md "Rig W: the blind score"): a Hertzian tooth contact in series with a
    linear stage. Its twist–torque nominal is `none`, nothing beyond the effects it declares
    (UNSTATED_VOCABULARY) is named; a backlash and a Jenkins-element hysteresis at ENR 1 are
    named first on the twist law; a position-dependent stiffness is not explained."""
    from commands.independent_harness import rig_module
    from estimator.diagnosis import diagnose
    rig_w = next(v for v in VARIANTS if v.rig == "rig_w" and v.few_runs)
    unstated = set(rig_module("rig_w").UNSTATED_VOCABULARY)
    train, test, _ = simulate_campaign(rig_w, 5001)
    rep = diagnose(train, test, "eq4", transmission="eq5")
    assert rep["transmission"]["verdict"]["status"] == "none", rep["transmission"]["verdict"]
    assert set(rep["verdict"]["effects"]) <= unstated, rep["verdict"]["summary"]
    for effect, form in (("backlash", "soft_zone"), ("hysteresis", "jenkins")):
        c = run_cell(rig_w, 5001, effect, form, 1.0, "single")
        assert c["named_first"] == effect, c
        assert c["laws"]["transmission"][:1] == [effect], c
    mod = rig_module("rig_w")
    c = run_cell(rig_w, 5001, "position_stiffness", mod.EFFECT_FORMS["position_stiffness"][0],
                 2.0, "oov")
    assert c["status"] in ("unexplained", "partly_explained"), c


def test_a_motor_side_ripple_through_the_dynamics_is_a_gear_ripple():
    """Rig AD's kinematic error of 2 and 4 cycles per motor turn reaches the twist–torque law
    through the joint's dynamics and the law's low-pass: at 300 r/min (10 Hz) it passes, at
    3000 r/min (100 Hz) far less and late. One sine and cosine of the motor angle for all runs
    gained 5 % held out, and rig AD's blind score missed it in every campaign at 1 kHz; the
    `dynamic` shape (amplitude and phase following the speed) names it."""
    rig_ad = next(v for v in VARIANTS if v.rig == "rig_ad" and not v.few_runs)
    c = run_cell(rig_ad, 5901, "gear_ripple", "motor_kinematic", 1.0, "single")
    assert c["named_first"] == "gear_ripple" and "gear_ripple" in c["laws"]["transmission"], c


def test_a_stage_order_is_not_given_a_speed_dependent_response():
    """The speed-dependent (`dynamic`) ripple is tried only at whole motor orders. Tried at the
    stage orders too, it fitted 27 % of rig S's nominal twist–torque residual at order 5497 on
    u (none of its effects) and named a gear ripple there."""
    rig_s = next(v for v in VARIANTS if v.rig == "rig_s" and not v.few_runs)
    c = run_cell(rig_s, 7101, None, None, 0.0, "none")
    assert "gear_ripple" not in c["laws"]["transmission"], c


def test_a_stribeck_curve_read_through_jittered_stamps_is_named():
    """Rig AF stamps its samples ±20 µs about the grid. Its torque reading's stated lag was then
    taken out by linear interpolation, which kept 0.77 of the noise, so the output law's
    held-out residual (142 N·m on the nominal) lay under its stated floor (170 N·m) and rig
    AF's blind score said `none` for every Stribeck and temperature-friction campaign at
    160 Hz. Microsecond jitter is now a uniform grid to the lag's band-limited shift."""
    rig_af = next(v for v in VARIANTS if v.rig == "rig_af" and not v.few_runs)
    c = run_cell(rig_af, 6101, "stribeck", "stretched_exp_0p8", 2.0, "single")
    assert c["named_first"] == "stribeck", c


def test_a_compliance_curve_that_bends_over_its_whole_range_is_nominal():
    """Rig AE's tangent stiffness rises smoothly from k0 to 2·k0 about 0.3° (a rational law)
    and rig AC's soft segment is blended into the stiff one by an algebraic sigmoid. The
    cubic and two knees left the twist law a residual swinging with the twist (88 and
    94 N·m held out over floors of 31 and 39 N·m through 0.001° and 0.002° encoders), so
    these nothing-withheld campaigns were `unexplained`; the nominal now takes a stiffness
    change spread about a corner when the runs left out confirm it (smooth_corner)."""
    for rig, seed in (("rig_ae", 6001), ("rig_ac", 5801)):
        v = next(v for v in VARIANTS if v.rig == rig and not v.few_runs)
        c = run_cell(v, seed, None, None, 0.0, "none")
        assert c["status"] == "none", (rig, c)
