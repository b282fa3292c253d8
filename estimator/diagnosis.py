"""The sim-to-real gap diagnosis (issue 7): where the residual of the nominal model lies, which
unmodelled effect of rig.md's vocabulary explains it, and how far the held-out error shrinks.

`diagnose(train_runs, test_runs, base="eq4") -> dict` (JSON-ready), in three steps:

1. Where it lies. The nominal model (estimator.models, default Eq. 4 with the measured load) is
   fitted by least squares on the training runs only and replayed on every run; the residual is
   localised by region (estimator.diagnosis_regions), and tested for whiteness, residual–input
   cross-correlation, a spectral line in time and a line in output angle
   (estimator.diagnosis_stats).
2. Which effect. Every effect of core.effects.VOCABULARY that applies to the model and whose
   signals the runs carry is added as its term (LinearModel.with_effect), its shape parameters
   chosen on the training runs by a grid search (stribeck v_s, gear_ripple order — the orders
   screened by the nominal residual's angular lines, the five strongest fitted;
   temperature_friction's T_ref is not searched: c_T·(T_ref − T)·sgn q̇ = c_T·T_ref·sgn q̇ −
   c_T·T·sgn q̇ and the first part is the Coulomb column, so every T_ref fits identically), the
   magnitude fitted on the training runs, and the candidate scored on the held-out runs: gain =
   mean over held-out samples of e_before² − e_after², with its batch-means standard error;
   significant when gain/SE > z_gain and the held-out RMSE drops by at least min_shrinkage.
   Ambiguity guard: a candidate whose magnitude is strongly correlated (|ρ| > 0.9 in the
   least-squares covariance) with a nominal parameter that it shifts by > 3 SE is reported with
   that parameter as an ambiguity set (`aliases`), and two candidates whose contributions,
   orthogonalised against the nominal columns, correlate above 0.9 on the training runs are
   reported as an ambiguity set of effects. Effects are added greedily (best held-out gain
   first, the gain re-scored against the current model) while the gain stays significant.
3. How far it shrinks. Held-out RMSE before and after, overall and per flagged region, with
   block-bootstrap 95 % intervals; how the nominal parameters moved; and the shrinkage
   predicted before the held-out errors of the new model are looked at: 1 − σ̂/rmse_before,
   σ̂ the new model's residual sd on the training runs (dof-corrected) and rmse_before the
   nominal model's held-out RMSE — "the held-out error falls to the training noise level if
   the effect is right and extrapolates". A training-only figure, leave-one-run-out shrinkage
   on the training runs, is reported beside it (`loro_from_training`); it cannot know how much
   of the gap the held-out runs hold (e.g. a drift grows with run length). The transmission
   law predicts with the training ratio 1 − σ̂_new/σ̂_nominal instead (options.predictor).

The transmission law (twist vs torque). When every run carries the twist (torsion, or u and
q) and the torque, `diagnose(..., transmission="auto")` diagnoses that law too, with the same
steps (transmission_diagnosis): its nominal is issue 7's Bouc–Wen law — Eq. 11 with the state x
for the shape (α = 1, n = 1; β, γ) fitted on the training runs by profile least squares
(a grid scaled by the training twist, refined by Nelder–Mead) — or, with transmission="eq5",
the elastic law; its candidates are the vocabulary's transmission effects (backlash, the
dead-zone half-width b searched on a grid scaled by the training twist; hysteresis when the
nominal lacks it). It runs on the runs low-passed and decimated by
options.transmission_decimate (see there), with the twist rate from the measured velocities
u̇ − q̇ when the runs have them, its materiality threshold transmission_min_structured and no
line veto. The two laws' diagnoses are merged (merge_transmission): `candidates` of both, each
naming its `model`; the verdict's effects of both (`effect_models`, `laws`);
`transmission` the law's whole report.

Verdict: `none` when no candidate is significant and the residual is unstructured (tests pass,
or its structured share — the part of its mean square above the white-noise floor, estimated
from first differences as mean(Δe²)/2 within each run — is below `min_structured`);
`explained` when effects were chosen, they remove at least `explained_fraction` of the
structured part of the held-out mean square (or leave less than `min_structured` of it), and
no spectral line is left in the residual (in time or in output angle);
`unexplained` otherwise (structure remains that no candidate removes) — the regions still say
where the gap lies.
Where each part lives: the runs prepared and pooled, estimator.diagnosis_data; what the
output balance reads (rests and reversals left out, stated sensor lags taken out, the
working rate, the band below the drive train's mode, the velocity), estimator.diagnosis_inputs;
the sensors' floors, estimator.diagnosis_floors; the nominal twist–torque law,
estimator.diagnosis_transmission; which torque reading a torque_offset lies in (the torque
channel, or the load cell, which is outside the vocabulary), estimator.diagnosis_channel;
candidates, statistics, regions and the verdict, their
diagnosis_* modules. Estimator code: imports core/ and estimator/ only.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from estimator.diagnosis_candidates import (_candidate_models, _contribution, _effect_params,
                                            _best_shape, _Fit, _fit, _moved, _predicted, _rmse,
                                            _score, ls_stiffness, predicted_shrinkage,
                                            ripple_shown, run_consistency)
from estimator.diagnosis_channel import EFFECT as OFFSET, LOAD_READING_DRIFT, offset_channel
from estimator.diagnosis_coverage import held_out_coverage
from estimator.diagnosis_data import (OPTIONAL_SIGNALS, _available, _pool, _slice, base_model,
                                      refuse_diverged)
from estimator.diagnosis_floors import _noise_floor, sensor_floor
from estimator.diagnosis_inputs import (below_drive_train_mode, lag_corrected,
                                        output_encoder_step, transient_mask, velocity_source,
                                        working_rate)
from estimator.diagnosis_options import DiagnosisOptions
from estimator.diagnosis_progress import report as progress
from estimator.diagnosis_regions import label_regions, region_table
from estimator.diagnosis_stats import (angle_lines, block_ids, block_robust_cov, block_size,
                                       bootstrap_shrinkage, covering_runs, cross_correlation,
                                       mean_se, spectral_line, whiteness)
from estimator.diagnosis_transmission import (TRANSMISSION_SIGNALS, lost_motion_objection,
                                              transmission_model, twist_resolution, twist_zeros)
from estimator.diagnosis_verdict import merge_transmission, outside_vocabulary, verdict_summary
from estimator.models import LinearModel, with_torque_gain
from estimator.preprocess import PrepOptions, prepare
from estimator.result import Fit
from core import effects as fx
from core.documents import DiagnosisReport
from core.run import RunData


# --- residual structure -------------------------------------------------------------------------

def _structure(e: np.ndarray, pooled: dict, blocks: np.ndarray, angle_order: int | None,
               opt: DiagnosisOptions) -> dict:
    fams = label_regions(pooled, angle_order, opt.regions)
    regions = region_table(e, fams, blocks, opt.regions)
    run = pooled["run"]
    inputs = {k: pooled[k] for k in ("q", "qd", "qdd", "torque_load") if k in pooled
              and np.ptp(pooled[k]) > 0}
    white = whiteness(e, run)
    xc = cross_correlation(e, inputs, run)
    line = spectral_line(e, pooled["t"], run)
    ang = angle_lines(e, pooled["q"], np.asarray(opt.ripple_orders)) if "q" in pooled else {}
    rms = _rmse(e)
    reasons = []
    if any(r["flagged"] for r in regions):
        reasons.append("flagged regions")
    if white["p_value"] < 1e-3 and white["max_abs_acf"] > 0.2:
        reasons.append("residual not white")
    if any(abs(v["max_corr"]) > max(xc["bound"], 0.1) for v in xc["inputs"].values()):
        reasons.append("residual correlated with an input")
    if line["p_value"] < 1e-3 and line["share"] > 0.05:
        reasons.append(f"spectral line at {line['freq_hz']:.3g} Hz")
    if ang and ang["p_value"] < 1e-3 and ang["amplitude"] > 0.2 * rms:
        # a line in the angle counts where it repeats: on the runs whose angle path sweeps
        # opt.ripple_min_periods of its periods (the ripple rule's; over less, a sine of the
        # angle fits anything slow)
        cv = covering_runs(run, pooled["t"], pooled["q"], float(ang["order"]),
                           opt.ripple_min_periods)
        shown = (angle_lines(e[cv], pooled["q"][cv], np.asarray([float(ang["order"])]))
                 if cv.sum() >= 20 else {"p_value": 1.0})
        if shown["p_value"] < 1e-3:
            reasons.append(f"line at {ang['order']} cycles per output revolution")
    return {"regions": regions, "whiteness": white, "cross_correlation": xc,
            "spectral_line": line, "angle_line": ang, "structured": bool(reasons),
            "reasons": reasons}


_OFFSET_ALIKE = ("torque_offset", "asymmetric_friction")
"""One ambiguity set when the offset's fitted part is a constant (`_is_constant`)."""


def _own_part(f, n_base: int, tr: dict) -> np.ndarray:
    """What a candidate fit's own columns add on the training runs (not orthogonalised)."""
    return f.model.design(tr)[:, n_base:] @ f.theta[n_base:]


def _is_constant(c: np.ndarray) -> bool:
    """True when the contribution `c` is a constant to 90 % of its mean square. A torque
    offset that is a constant is alike to an asymmetric Coulomb level: per direction of steady
    sliding that level is a constant torque (its column is the offset's, estimator.models), and
    the output law leaves out the rests where the two would differ (`transient_mask`)."""
    ms = float(np.mean(c ** 2)) if c.size else 0.0
    return ms > 0 and float(np.mean(c)) ** 2 >= 0.9 * ms


# --- the diagnosis ------------------------------------------------------------------------------

def diagnose(train_runs: Sequence[RunData], test_runs: Sequence[RunData],
             base: str | LinearModel = "eq4", prep: PrepOptions | None = None,
             options: DiagnosisOptions | None = None,
             transmission: str | LinearModel | None = "auto") -> DiagnosisReport:
    """Diagnose the gap between the nominal model `base` and the runs (see the module
    docstring); returns the JSON-ready report (core.documents.DiagnosisReport) with keys
    baseline, regions, candidates, verdict (and tests, shrinkage, skipped, ambiguities;
    `series` with options.series_points > 0)."""
    return diagnose_detailed(train_runs, test_runs, base, prep, options, transmission).report


@dataclass
class Diagnosis:
    """A diagnosis: its JSON-ready report, and the least-squares fits it made on the training
    runs — the nominal model, and the model with the chosen effects (None when none was
    chosen) — as estimator.result.Fit (to store and tabulate like any identification)."""
    report: DiagnosisReport
    baseline: Fit
    final: Fit | None
    transmission: "Diagnosis | None" = None
    """The twist–torque law's own diagnosis (see transmission_diagnosis), when one was made."""


def _as_fit(f: _Fit, role: str, shapes: dict, tr: dict, tr_blocks: np.ndarray) -> Fit:
    """The fit as estimator.result.Fit; extra["cov_blocks"] is its coefficients' covariance
    robust to the residual's correlation within the batch-means blocks (block_robust_cov)."""
    r = f.ols
    return Fit(model=f.model.name, method="ls", param_names=list(f.model.param_names),
               units=list(f.model.units), mean=f.theta, sd=f.se, ci_low=r.ci_low,
               ci_high=r.ci_high, sigma=r.sigma, rmse_train=_rmse(f.e_train),
               rmse_test=_rmse(f.e_test), diagnostics={"rank": r.rank},
               extra={"diagnosis": role, "shapes": shapes, "cov": f.cov, "dof": r.dof,
                      "cov_blocks": block_robust_cov(f.model.design(tr), f.e_train, tr_blocks),
                      "n_train": int(f.e_train.size), "n_test": int(f.e_test.size),
                      "target": {"label": f.model.target_label, "unit": f.model.target_unit},
                      "descriptions": dict(f.model.descriptions)})


def _series(pooled: dict, n_train: int, model: LinearModel, e0: np.ndarray, e1: np.ndarray,
            angle_order: int | None, flagged: list[dict], opt: DiagnosisOptions) -> dict:
    """Decimated series for plots: per run at most opt.series_points samples (evenly spaced)
    of t, q, the measured target and the nominal / final predictions (target − residual), and
    for each flagged region the indices (into the series) of its samples."""
    run = pooled["run"]
    keep = []
    for r in np.unique(run):
        idx = np.flatnonzero(run == r)
        k = max(1, int(np.ceil(idx.size / opt.series_points)))
        keep.append(idx[::k])
    keep = np.concatenate(keep)
    y = model.target(pooled)[keep]
    fams = {k: v[keep] for k, v in label_regions(pooled, angle_order, opt.regions).items()}

    def c(a):
        return [float(f"{v:.6g}") for v in np.asarray(a, dtype=float)]
    return {"label": model.target_label, "unit": model.target_unit,
            "n_train_runs": int(n_train), "angle_order": angle_order,
            "run": run[keep].astype(int).tolist(), "t": c(pooled["t"][keep]),
            "q": c(pooled["q"][keep]) if "q" in pooled else None,
            "measured": c(y), "baseline": c(y - e0[keep]), "final": c(y - e1[keep]),
            "regions": [{"where": r["where"], "family": r["family"],
                         "index": np.flatnonzero(fams[r["family"]] == r["where"]).tolist()}
                        for r in flagged if r["family"] in fams]}


@dataclass
class _Search:
    """One law's search on prepared samples: the nominal fit, each candidate scored alone on
    top of it, and the effects the greedy search chose."""
    base_fit: _Fit
    e_all: np.ndarray
    """The nominal's residual on every pooled sample (training and held-out)."""
    angle_order: int | None
    where: dict
    """The nominal residual's structure (_structure)."""
    table: list[dict]
    skipped: dict[str, str]
    steps: list[dict]
    rejected: list[dict]
    chosen: list[str]
    cur: _Fit
    """The nominal with the chosen effects."""
    floor: float
    floor_white: float
    floor_sensor: float | None
    floor_capped: bool
    """The twist–torque law's floor is the lowest held-out mean square a fit reached, clearly
    under the sensors' (whose surrogate overstated the encoders' rounding)."""


def _objected(f: _Fit, tr: dict, opt: DiagnosisOptions) -> _Fit:
    """The candidate's fit with the objections that need the options (a dead zone's lost
    motion, estimator.diagnosis_transmission.lost_motion_objection) added to those its shape
    search found: an objected fit is never significant."""
    if f.objection is None:
        why = lost_motion_objection(f, tr, opt)
        if why is not None:
            return replace(f, objection=why)
    return f


def _search(model: LinearModel, law: str, tr: dict, te: dict, pooled: dict,
            is_train: np.ndarray, blocks: np.ndarray, test_runs: Sequence[RunData],
            law_prep: PrepOptions, opt: DiagnosisOptions) -> _Search:
    """Fit `model` (the nominal), score every candidate effect on top of it and add effects
    greedily while the held-out gain stays significant; progress stages are named `law`."""
    te_blocks = blocks[~is_train]
    progress(f"{law}: nominal fit", 0, 1)
    base_fit = _fit(model, {}, tr, te)
    n_base = base_fit.theta.size
    e_all = np.empty(pooled["run"].size)
    e_all[is_train], e_all[~is_train] = base_fit.e_train, base_fit.e_test
    ang0 = angle_lines(e_all, pooled["q"], np.asarray(opt.ripple_orders)) if "q" in pooled else {}
    angle_order = ang0.get("order") if ang0.get("p_value", 1.0) < 1e-3 else None
    where = _structure(e_all, pooled, blocks, angle_order, opt)
    progress(f"{law}: nominal fit", 1, 1)

    cands, skipped = _candidate_models(model, tr, opt, base_fit.e_train)
    fits = {}
    progress(f"{law}: candidates", 0, len(cands))
    for name, ms in cands.items():
        fits[name] = _objected(_best_shape(ms, tr, te), tr, opt)
        progress(f"{law}: candidates", len(fits), len(cands))
    table = []
    contrib = {name: _contribution(base_fit, f, tr) for name, f in fits.items()}
    offset_alike = (set(_OFFSET_ALIKE) <= set(fits)
                    and _is_constant(_own_part(fits["torque_offset"], n_base, tr)))
    progress(f"{law}: scoring", 0, len(fits))
    for name, f in fits.items():
        row = {"effect": name, "model": model.name, "shape": f.shape,
               **_score(base_fit, f, te_blocks, opt, tr)}
        row["params"] = _effect_params(f, n_base)
        row["moved"], row["aliases"] = _moved(base_fit, f, n_base)
        row["ambiguous_with"] = []
        for other, c2 in contrib.items():
            c1 = contrib[name]
            if other != name and c1 @ c1 > 0 and c2 @ c2 > 0:
                rho = abs(float(c1 @ c2) / np.sqrt(float(c1 @ c1) * float(c2 @ c2)))
                if rho > 0.9:
                    row["ambiguous_with"].append(other)
        if offset_alike and name in _OFFSET_ALIKE:
            other = _OFFSET_ALIKE[1 - _OFFSET_ALIKE.index(name)]
            if other not in row["ambiguous_with"]:
                row["ambiguous_with"].append(other)
        table.append(row)
        progress(f"{law}: scoring", len(table), len(fits))
    table.sort(key=lambda r: r["rmse_test"])

    # greedy addition while the held-out gain stays significant: every round re-fits every
    # remaining candidate on top of the current model (its shape searched again: the first
    # round's search saw the other effects' residual too) and re-scores it against that model
    floor_white = _noise_floor(e_all[~is_train], pooled["run"][~is_train])
    floor_sensor = sensor_floor(list(test_runs), model, dict(zip(model.param_names,
                                                                 base_fit.theta)), law_prep)
    floor = max(floor_white, floor_sensor or 0.0)
    # no model beats the sensors on held-out runs: on a twist–torque law, whose floor is the
    # encoders' rounding modelled by a surrogate (sensor_floor), a held-out mean square under
    # it by more than opt.z_gain of its batch-means standard error (the nominal's, or a
    # candidate's) shows the surrogate overstates the rounding, and caps the floor there
    shown = ([m for m, se in (mean_se(f.e_test ** 2, te_blocks)
                              for f in [base_fit, *fits.values()])
              if m + opt.z_gain * se < floor]
             if model.kind == "transmission" else [])
    floor_capped = bool(shown)
    floor = min([floor, *shown])
    chosen, steps, cur, rejected = [], [], base_fit, []
    remaining = list(fits)
    first = True
    while remaining and len(chosen) < opt.max_effects:
        stage = f"{law}: greedy round {len(chosen) + 1}"
        if first:
            trial = {n: fits[n] for n in remaining}
            progress(stage, 0, len(trial))
        else:
            grids, _ = _candidate_models(cur.model, tr, replace(opt, candidates=tuple(remaining)),
                                         cur.e_train)
            trial = {}
            progress(stage, 0, len(grids))
            for n, ms in grids.items():
                trial[n] = _objected(_best_shape(ms, tr, te), tr, opt)
                progress(stage, len(trial), len(grids))
        first = False
        scored = {n: _score(cur, f, te_blocks, opt) for n, f in trial.items()}
        progress(stage, len(trial), len(trial))
        if not scored:
            break
        # the largest held-out gain among the significant candidates (a larger gain that is not
        # significant is noise, and must not end the search before a significant one is added),
        # those significant by their gain before those significant only by the blocks improved
        significant = sorted((n for n in scored if scored[n]["significant"]),
                             key=lambda n: (scored[n]["concentrated"], -scored[n]["gain"]))
        # parsimony: an effect beyond the first must also help consistently across the runs
        # (held-out, and training runs left out one at a time): a one-sided sign test of its
        # per-run gains at opt.parsimony_alpha
        # materiality: it must remove at least opt.min_structure_share of the structure the
        # current model leaves above the noise floor (a detail is not the cause of a gap)
        left = max(float(np.mean(cur.e_test ** 2)) - floor, 0.0)
        best = None
        for n in significant:
            scored[n]["structure_removed"] = scored[n]["gain"] / left if left > 0 else 0.0
            if scored[n]["structure_removed"] < opt.min_structure_share:
                rejected.append({"effect": n, "round": len(chosen) + 1, **scored[n]})
                continue
            # a gear ripple must show where it repeats: on the held-out runs whose angle path
            # sweeps opt.ripple_min_periods of its periods, not only on slow runs it is smooth
            # over, and on the training runs that sweep them, each predicted from the others
            if n == "gear_ripple":
                scored[n]["ripple"] = ripple_shown(cur, trial[n], te, te_blocks, opt, tr)
                if not scored[n]["ripple"]["shown"]:
                    rejected.append({"effect": n, "round": len(chosen) + 1, **scored[n]})
                    continue
            if not chosen:
                best = n
                break
            cons = run_consistency(cur, trial[n], tr, te)
            scored[n].update(cons)
            if cons["p_runs"] < opt.parsimony_alpha:
                best = n
                break
            rejected.append({"effect": n, "round": len(chosen) + 1, **scored[n]})
        if best is None:
            break
        steps.append({"effect": best, "shape": trial[best].shape, **scored[best]})
        chosen.append(best)
        cur = trial[best]
        remaining.remove(best)
    return _Search(base_fit=base_fit, e_all=e_all, angle_order=angle_order, where=where,
                   table=table, skipped=skipped, steps=steps, rejected=rejected, chosen=chosen,
                   cur=cur, floor=floor, floor_white=floor_white, floor_sensor=floor_sensor,
                   floor_capped=floor_capped)


def diagnose_detailed(train_runs: Sequence[RunData], test_runs: Sequence[RunData],
                      base: str | LinearModel = "eq4", prep: PrepOptions | None = None,
                      options: DiagnosisOptions | None = None,
                      transmission: str | LinearModel | None = "auto") -> Diagnosis:
    """diagnose() plus the fits it made (see Diagnosis)."""
    if not train_runs or not test_runs:
        raise ValueError("a diagnosis needs at least one training run and one held-out run")
    opt = options or DiagnosisOptions()
    refuse_diverged(train_runs, test_runs, opt.diverged_peak_ratio)
    train_runs = [lag_corrected(r) for r in train_runs]
    test_runs = [lag_corrected(r) for r in test_runs]
    prep = working_rate(list(train_runs) + list(test_runs), prep or PrepOptions(), opt)
    model = base_model(base)
    law = "twist–torque law" if model.kind == "transmission" else "output law"
    progress(f"{law}: nominal fit", 0, 1)
    avail = set(_available(train_runs[0], prep))
    for r in list(train_runs[1:]) + list(test_runs):
        avail &= set(_available(r, prep))
    need = list(dict.fromkeys(list(model.requires) + [s for s in OPTIONAL_SIGNALS if s in avail]))
    law_prep, mode = below_drive_train_mode(list(train_runs) + list(test_runs), prep, model,
                                            opt.transient_s, opt.mode_band_excess, opt.z_gain)
    law_prep, velocity = velocity_source(train_runs, law_prep, model, opt.transient_s,
                                         opt.z_gain, opt.block)
    pooled = _pool(list(train_runs) + list(test_runs), need, law_prep, 0)
    n_transient = 0
    if model.kind == "output" and opt.transient_s > 0 and "qd" in pooled:
        steady = ~transient_mask(pooled, opt.transient_s,
                                 output_encoder_step(list(train_runs) + list(test_runs)))
        n_transient = int((~steady).sum())
        pooled = _slice(pooled, steady)
    is_train = pooled["run"] < len(train_runs)
    tr, te = _slice(pooled, is_train), _slice(pooled, ~is_train)
    if "qd" not in pooled or "torque" not in pooled:
        raise ValueError("the diagnosis needs a velocity (or position) and a torque channel")
    for part, sig in (("training", tr), ("held-out", te)):
        if not sig["t"].size:
            why = (f"{n_transient} samples lie at or within {opt.transient_s:g} s of a rest, "
                   "near-zero speed (|q̇|, or the mean speed over that time, below 5 % of the "
                   "campaign's top speed: one run much faster than the others makes that every "
                   "other run's) and are left out"
                   if n_transient else f"every {part} sample misses a channel the law needs")
            raise ValueError(f"the {law} has no {part} sample left to diagnose on: {why}")
    driven = driving_share(tr, opt.driving_load_min_rel)
    gain_possible = (model.kind == "output" and "torque_load" in model.target_requires
                     and bool(np.all(tr.get("has_load", False))) and driven is not None
                     and min(driven, 1.0 - driven) >= opt.torque_gain_min_share)
    block = block_size(pooled["run"], opt.block)
    blocks = block_ids(pooled["run"], block)
    te_blocks = blocks[~is_train]
    if gain_possible and opt.torque_gain:
        model = with_torque_gain(model)
    found = _search(model, law, tr, te, pooled, is_train, blocks, test_runs, law_prep, opt)
    if gain_possible and opt.torque_gain is None:
        # the gain of the torque reading is a calibration, tried beside the effects chosen: its
        # column shares the load ramp with a load-dependent friction (driving and resisting
        # runs apart) and with a drifting offset, so in the nominal from the start it would take
        # their part before they are tried; significant here, the search runs again with it
        # (on the same prepared samples, its stages named for the gain)
        gain_fit = _fit(with_torque_gain(found.cur.model), {}, tr, te)
        if _score(found.cur, gain_fit, te_blocks, opt, tr)["significant"]:
            model, law = with_torque_gain(model), f"{law} with the torque reading's gain"
            found = _search(model, law, tr, te, pooled, is_train, blocks, test_runs, law_prep,
                            opt)
    base_fit, cur, chosen, steps = found.base_fit, found.cur, found.chosen, found.steps
    e_all, angle_order, where, table = found.e_all, found.angle_order, found.where, found.table
    floor, floor_white, floor_sensor = found.floor, found.floor_white, found.floor_sensor
    n_base = base_fit.theta.size

    e_fin = np.empty_like(e_all)
    e_fin[is_train], e_fin[~is_train] = cur.e_train, cur.e_test
    after = _structure(e_fin, pooled, blocks, angle_order, opt) if chosen else where
    ms0, ms1 = float(np.mean(base_fit.e_test ** 2)), float(np.mean(cur.e_test ** 2))
    structured_ms = max(ms0 - floor, 0.0)
    removed = (ms0 - ms1) / structured_ms if structured_ms > 0 else 0.0
    structured_share = structured_ms / ms0 if ms0 > 0 else 0.0
    share_after = max(ms1 - floor, 0.0) / ms1 if ms1 > 0 else 0.0
    if not chosen:
        status = ("unexplained" if where["structured"] and structured_share >= opt.min_structured
                  else "none")
    else:
        # regions stay flagged after a right answer too (e.g. stick–slip near zero speed), and
        # a linearised term (time_delay) leaves a slightly coloured residual; a spectral line
        # left (in time or in angle) is periodic structure no chosen effect covers
        lines_left = [r for r in after["reasons"] if "line" in r] if opt.lines_veto else []
        status = ("explained" if (removed >= opt.explained_fraction
                                  or share_after < opt.min_structured) and not lines_left
                  else "partly_explained")

    # how far it shrinks: overall and per flagged region, held-out, with intervals
    progress(f"{law}: shrinkage", 0, 1)
    fam_te = label_regions(te, angle_order, opt.regions)
    shrink_regions = []
    overall = bootstrap_shrinkage(base_fit.e_test, cur.e_test, te_blocks, opt.n_boot, opt.seed)
    for reg in where["regions"]:
        if not reg["flagged"]:
            continue
        lab = fam_te.get(reg["family"])
        if lab is None:
            continue
        m = lab == reg["where"]
        if m.sum() < 10:
            continue
        s, lo, hi = bootstrap_shrinkage(base_fit.e_test[m], cur.e_test[m], te_blocks[m],
                                        opt.n_boot, opt.seed)
        reg["rmse_test_before"] = _rmse(base_fit.e_test[m])
        reg["rmse_test_after"] = _rmse(cur.e_test[m])
        reg["shrinkage"], reg["shrinkage_ci95"] = s, [lo, hi]
        shrink_regions.append({"where": reg["where"], "rmse_before": reg["rmse_test_before"],
                               "rmse_after": reg["rmse_test_after"], "shrinkage": s,
                               "ci95": [lo, hi]})
    moved = _moved(base_fit, cur, n_base)[0] if chosen else {}
    progress(f"{law}: shrinkage", 1, 1)
    ambiguities = sorted({tuple(sorted([r["effect"], o])) for r in table
                          for o in r["ambiguous_with"]})
    report: DiagnosisReport = {
        "baseline": {"model": model.name, "rmse_train": _rmse(base_fit.e_train),
                     "rmse_test": _rmse(base_fit.e_test),
                     "target": {"label": model.target_label, "unit": model.target_unit},
                     "params": {n: {"value": float(v), "se": float(s), "unit": u} for n, v, s, u
                                in zip(model.param_names, base_fit.theta, base_fit.se, model.units)},
                     "n_train": int(is_train.sum()), "n_test": int((~is_train).sum())},
        "regions": [r for r in where["regions"] if r["flagged"]],
        "all_regions": where["regions"],
        "tests": {k: where[k] for k in ("whiteness", "cross_correlation", "spectral_line",
                                        "angle_line", "structured", "reasons")},
        "candidates": table,
        "skipped": found.skipped,
        "ambiguities": [list(a) for a in ambiguities],
        "steps": steps,
        "rejected": found.rejected,
        "transient_samples_left_out": n_transient,
        "drive_train_mode": mode,
        "velocity": velocity,
        "verdict": {"status": status, "effects": chosen, "rmse_test_after": _rmse(cur.e_test),
                    "model": cur.model.name,
                    "shapes": {st["effect"]: st["shape"] for st in steps},
                    "ambiguity_sets": {r["effect"]: {"effects": r["ambiguous_with"],
                                                     "nominal_parameters": r["aliases"]}
                                       for r in table if r["effect"] in chosen
                                       and (r["ambiguous_with"] or r["aliases"])},
                    "structured_share_removed": float(removed),
                    "structured_share_before": float(structured_share),
                    "structured_share_after": float(share_after),
                    "noise_floor_rms": float(np.sqrt(floor)),
                    "noise_floor_source": ("held-out residual" if found.floor_capped
                                           else "sensors" if floor_sensor
                                           and floor_sensor > floor_white
                                           else "first differences"),
                    "residual_after": {k: after[k] for k in ("structured", "reasons")},
                    "held_out_coverage": held_out_coverage(tr, te)},
        "shrinkage": {"overall": {"rmse_before": _rmse(base_fit.e_test),
                                  "rmse_after": _rmse(cur.e_test), "shrinkage": overall[0],
                                  "ci95": [overall[1], overall[2]],
                                  "predicted_from_training":
                                      _predicted(base_fit, cur, _rmse(base_fit.e_test), opt)
                                      if chosen else 0.0,
                                  "predictor": opt.predictor,
                                  "loro_from_training":
                                      predicted_shrinkage(model, cur.model, tr) if chosen else 0.0},
                      "regions": shrink_regions, "parameters_moved": moved},
        "options": {"block": block, **{k: v for k, v in asdict(opt).items()
                                       if k not in ("ripple_orders", "regions")},
                    "ripple_orders": [min(opt.ripple_orders), max(opt.ripple_orders)]},
    }
    _note_resisting_load(report["verdict"], cur, tr, opt)
    if opt.series_points > 0:
        report["series"] = _series(pooled, len(train_runs), model, e_all, e_fin, angle_order,
                                   report["regions"], opt)
    shapes = {st["effect"]: st["shape"] for st in steps}
    # what the output law found on the torque channel (an offset, a lag) is in the reading
    # that the twist–torque law fits too: that law starts from it, so a sensor's fault is not
    # diagnosed a second time as a transmission effect (a lag draws a loop, a drift a state)
    on_channel = {e: shapes.get(e, {}) for e in chosen if fx.VOCABULARY[e].acts_on == "sensor"}
    tx = (transmission_diagnosis(train_runs, test_runs, transmission, prep, opt,
                                 carried=on_channel)
          if transmission is not None and model.kind != "transmission" else None)
    tr_blocks = blocks[is_train]
    final = _as_fit(cur, "final", shapes, tr, tr_blocks) if chosen else None
    if tx is not None and final is not None and OFFSET in chosen:
        check = offset_channel(cur.model, cur.theta, final.extra["cov_blocks"],
                               tx.baseline.param_names, tx.baseline.mean,
                               tx.baseline.extra["cov_blocks"], pooled, pooled["run"],
                               opt.z_gain)
        if check is not None:
            report["verdict"]["offset_channel"] = check
            if check["channel"] == "torque_load":
                outside_vocabulary(report["verdict"], OFFSET, LOAD_READING_DRIFT)
    if tx is not None:
        merge_transmission(report, tx.report)
    report["verdict"]["summary"] = verdict_summary(report)
    return Diagnosis(report=report, baseline=_as_fit(base_fit, "baseline", {}, tr, tr_blocks),
                     final=final, transmission=tx)


def _note_resisting_load(verdict: dict, fit, tr: dict, opt: DiagnosisOptions) -> None:
    """A chosen load_dependent_friction on runs whose load never drove the joint (no training
    sample with |T| above `opt.driving_load_min_rel` of its largest where T·q̇ < 0) is, to these
    runs, the same column as a gain mismatch between the torque and the load readings: T − τ_L
    read with a relative gain error ε is ε·T = ε·|T|·sgn q̇ wherever the motor drives. Its
    ambiguity set says so (`gain_mismatch`: the relative gain error μ stands for, the share of
    loaded samples where the load drove), and so does the verdict's text; a run whose load
    drives the joint tells the two apart (docs/diagnosis.md, rig L's and rig P's)."""
    if "load_dependent_friction" not in verdict["effects"]:
        return
    names = list(fit.model.param_names)
    mu = next((float(fit.theta[names.index(n)]) for n in ("mu", "mu_drive") if n in names), None)
    driven = driving_share(tr, opt.driving_load_min_rel)
    if mu is None or driven is None:
        return
    if driven < opt.driving_load_min_share:
        _note_alternative(verdict, "load_dependent_friction", "gain_mismatch",
                          {"relative_gain_error": mu, "driving_share": driven})


def driving_share(sig: Mapping[str, np.ndarray], min_rel: float) -> float | None:
    """Share of the loaded samples (|T| above `min_rel` of the largest) where the load drives
    the joint (T·q̇ < 0: the motors brake); None without a torque, a velocity or a loaded
    sample."""
    if "torque" not in sig or "qd" not in sig:
        return None
    T, v = np.asarray(sig["torque"], dtype=float), np.asarray(sig["qd"], dtype=float)
    ok = np.isfinite(T) & np.isfinite(v)
    if not ok.any():
        return None
    loaded = ok & (np.abs(T) > min_rel * float(np.max(np.abs(T[ok]))))
    if not loaded.any():
        return None
    return float(np.mean(T[loaded] * v[loaded] < 0.0))


def _note_alternative(verdict: dict, effect: str, key: str, what: dict) -> None:
    """Record in the chosen `effect`'s ambiguity set a cause outside the vocabulary that these
    runs cannot tell from it (`key`: what the verdict's text names it by, `what`: its sizes)."""
    entry = verdict["ambiguity_sets"].setdefault(effect, {"effects": [], "nominal_parameters": []})
    entry[key] = what


# --- the transmission law (twist vs torque) ------------------------------------------------------

def _note_narrow_dead_zone(verdict: dict, resolution: float | None,
                           opt: DiagnosisOptions) -> None:
    """A chosen backlash whose half-width b [rad] is under `opt.soft_centre_min_steps` of the
    twist's stated step is, through the encoders' rounding, the same thing to these runs as a
    softer centre of the compliance curve (estimator.diagnosis_transmission.centre_knee, which
    takes a centre into the nominal only from that width): its ambiguity set says so
    (`soft_centre`: b in steps, the steps needed), and so does the verdict's text."""
    b = (verdict.get("shapes") or {}).get("backlash", {}).get("b")
    if "backlash" not in verdict["effects"] or not resolution or b is None:
        return
    if b < opt.soft_centre_min_steps * resolution:
        _note_alternative(verdict, "backlash", "soft_centre",
                          {"half_width_steps": float(b / resolution),
                           "steps_needed": float(opt.soft_centre_min_steps)})


def _note_angle_lag(verdict: dict, final: Fit | None, stiffness: float) -> bool:
    """A chosen angle reading's lag (time_delay, shape angle) in seconds and which reading is
    late, from its fitted k_lag = k·d and the training runs' least-squares `stiffness` k
    [N·m/rad]: `verdict.angle_lag` = {reading: 'q' (the output angle is read after the motor
    angle, k_lag > 0) or 'u', lag_s}. True when it was set."""
    if final is None or "k_lag" not in final.param_names or not stiffness > 0:
        return False
    k_lag = float(final.mean[final.param_names.index("k_lag")])
    verdict["angle_lag"] = {"reading": "q" if k_lag > 0 else "u",
                            "lag_s": abs(k_lag) / stiffness}
    return True


def transmission_diagnosis(train_runs: Sequence[RunData], test_runs: Sequence[RunData],
                           spec: str | LinearModel = "auto", prep: PrepOptions | None = None,
                           options: DiagnosisOptions | None = None,
                           carried: Mapping[str, Mapping[str, float]] | None = None
                           ) -> Diagnosis | None:
    """The same diagnosis (regions, candidates, greedy held-out selection, verdict) of the
    twist-vs-torque law: nominal transmission_model(spec), candidates the vocabulary's
    transmission effects (backlash; hysteresis when the nominal law lacks it) and those tried
    there too (`also_on`: gear ripple as a transmission error). `carried`: effects
    of the torque channel (acts_on 'sensor') already found on the output law, with the shape
    chosen there; the nominal law takes their columns (fitted on this law) and they are not
    candidates here (report
    `baseline.carried`). None when a run lacks the twist (torsion, or u and q) or the torque
    channel."""
    opt = options or DiagnosisOptions()
    prep = prep or PrepOptions()
    runs = list(train_runs) + list(test_runs)
    for r in runs:
        try:
            prepare(r, ("t",) + TRANSMISSION_SIGNALS, prep)
        except (KeyError, ValueError):
            return None
    # the nominal law's shape is chosen on low-passed twists (cutoff a tenth of the slowest
    # training sample rate): the Bouc–Wen state integrated along a twist that jitters by an
    # encoder step between samples carries spurious small loops that bias the shape
    tprep = replace(prep, decimate=prep.decimate * opt.transmission_decimate)
    # the joint's temperature when every run has it: the nominal's stiffness may follow it
    # (a sample whose temperature is missing is then left out of the nominal's shape too)
    need = TRANSMISSION_SIGNALS
    if opt.stiffness_thermal is not False:
        try:
            for r in runs:
                prepare(r, ("t", "temp_joint"), tprep)
            need = need + ("temp_joint",)
        except (KeyError, ValueError):
            pass
    tr = _pool(train_runs, need, tprep, 0)
    progress("twist–torque law: nominal shape", 0, 1)
    model, shape = transmission_model(spec, tr, opt, twist_resolution(runs))
    progress("twist–torque law: nominal shape", 1, 1)
    carried = dict(carried or {})
    for name, shp in carried.items():
        if fx.VOCABULARY[name].acts_on != "sensor":
            raise ValueError(f"only effects of the torque channel carry over, not {name!r}")
        model = model.with_effect(name, **shp)
    cands = tuple(n for n in (opt.candidates or fx.EFFECT_NAMES)
                  if n in fx.VOCABULARY and "transmission" in (fx.VOCABULARY[n].acts_on,
                                                               *fx.VOCABULARY[n].also_on))
    if not cands:
        return None
    topt = replace(opt, candidates=cands, series_points=0, lines_veto=False,
                   min_structured=opt.transmission_min_structured,
                   min_shrinkage=opt.transmission_min_shrinkage,
                   predictor=opt.transmission_predictor)
    zero = None
    if opt.twist_zero_per_run:
        train_runs, test_runs, zero = twist_zeros(train_runs, test_runs, model, tprep,
                                                  twist_resolution(runs))
    d = diagnose_detailed(train_runs, test_runs, model, tprep, topt, transmission=None)
    _note_narrow_dead_zone(d.report["verdict"], twist_resolution(runs), opt)
    if _note_angle_lag(d.report["verdict"], d.final, ls_stiffness(tr)):
        d.report["verdict"]["summary"] = verdict_summary(d.report)
    d.report["baseline"]["shape"] = shape
    d.report["baseline"]["twist_zero"] = zero
    d.report["baseline"]["carried"] = list(carried)
    return d
