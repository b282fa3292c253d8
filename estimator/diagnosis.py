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
Estimator code: imports rig/ and estimator/ only.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Mapping, Sequence

import numpy as np
from scipy import signal

from estimator.diagnosis_candidates import (_candidate_models, _contribution, _effect_params,
                                            _best_shape, _Fit, _fit, _moved, _predicted, _rmse,
                                            _score, bouc_wen_grid, predicted_shrinkage,
                                            run_consistency)
from estimator.diagnosis_options import DiagnosisOptions
from estimator.diagnosis_progress import report as progress
from estimator.diagnosis_regions import label_regions, region_table
from estimator.diagnosis_stats import (angle_lines, band_excess, block_ids,
                                       bootstrap_shrinkage, cross_correlation, mean_se,
                                       spectral_line, whiteness)
from estimator.diagnosis_verdict import merge_transmission, verdict_summary
from estimator.least_squares import ols
from estimator.emps import emps_model
from estimator.models import (LinearModel, eq11, knee_column, model_from_spec,
                              with_stiffening)
from estimator.preprocess import PrepOptions, prepare
from estimator.result import Fit
from core import effects as fx
from core.documents import DiagnosisReport
from core.run import RunData

OPTIONAL_SIGNALS = ("q", "qd", "qdd", "u", "torque", "torque_load", "torque_rate", "temp_joint",
                    "torsion", "torsion_rate")
"""Signals prepared when a run can supply them (regions and candidate terms use them)."""


def base_model(spec: str | LinearModel) -> LinearModel:
    """A LinearModel, or 'emps', or a model spec of estimator.models.model_from_spec."""
    if isinstance(spec, LinearModel):
        return spec
    return emps_model() if spec == "emps" else model_from_spec(spec)


# --- data ---------------------------------------------------------------------------------------

def _available(run: RunData, prep: PrepOptions) -> list[str]:
    ok = []
    for s in OPTIONAL_SIGNALS:
        try:
            prepare(run, ("t", s) if s != "t" else ("t",), prep)
            ok.append(s)
        except (KeyError, ValueError):
            pass
    return ok


def _pool(runs: Sequence[RunData], need: Sequence[str], prep: PrepOptions, run0: int
          ) -> dict[str, np.ndarray]:
    parts = []
    for i, run in enumerate(runs):
        s = prepare(run, need, prep)
        d = dict(s)
        d["run"] = np.full(s.n, run0 + i, dtype=int)
        if "phase" in run.samples.columns:
            d["phase"] = run.samples["phase"].astype(str).to_numpy()[s["index"]]
        if "torque_rate" in d:
            d["torque_rate"] = _smooth_rate(d["torque"], d["t"], d["segment"])
        if "torsion_rate" in d and {"ud", "qd"} <= set(run.samples.columns):
            rate = _measured_twist_rate(run, s["index"])
            # a drive that reports the motor speed as both speeds says nothing of the twist
            # rate: then the differentiated twist of preprocess stays
            if np.any(np.abs(rate) > 0):
                d["torsion_rate"] = rate
        d["scheme"] = np.full(s.n, run.meta.get("scheme", "?"), dtype=object)
        # the reduction turns u (the motor angle referred to the output) into the motor angle,
        # on which a motor-side ripple is periodic (0: the run does not say)
        d["reduction"] = np.full(s.n, float(run.meta.get("reduction") or 0.0))
        d["has_load"] = np.full(s.n, bool(s.info.get("has_torque_load")))
        parts.append(d)
    keys = set(parts[0])
    for p in parts[1:]:
        keys &= set(p)
    pooled = {k: np.concatenate([p[k] for p in parts]) for k in keys}
    if "phase" not in keys:
        pooled.pop("phase", None)
    return pooled


def _measured_twist_rate(run: RunData, index: np.ndarray) -> np.ndarray:
    """Twist rate Δ̇ = u̇ − q̇ [rad/s] from the run's measured velocities at the kept rows: the
    difference of a sampled twist misses the drive train's fast motion between samples (its
    mode lies near the sample rate of the loading schemes) and carries the output encoder's
    quantisation steps; the drives' velocity estimates carry neither."""
    ud = run.samples["ud"].to_numpy(dtype=float)[index]
    qd = run.samples["qd"].to_numpy(dtype=float)[index]
    out = ud - qd
    return np.where(np.isfinite(out), out, 0.0)


def _smooth_rate(x: np.ndarray, t: np.ndarray, segment: np.ndarray) -> np.ndarray:
    """dx/dt of x low-passed (zero-phase Butterworth, order 2, cutoff 0.1 × the sample rate)
    per segment: the time_delay column −Ṫ from a raw difference of a noisy torque would carry
    the differentiated sensor noise (errors in variables) and attenuate the delay estimate."""
    from scipy import signal
    out = np.empty_like(x, dtype=float)
    for g in np.unique(segment):
        m = segment == g
        tt, xx = t[m], x[m].astype(float)
        if xx.size < 16:
            out[m] = np.gradient(xx, tt) if xx.size > 1 else 0.0
            continue
        fs = 1.0 / float(np.median(np.diff(tt)))
        sos = signal.butter(2, 0.1 * fs, fs=fs, output="sos")
        out[m] = np.gradient(signal.sosfiltfilt(sos, xx, padlen=min(15, xx.size - 1)), tt)
    return out


def _slice(d: dict, m: np.ndarray) -> dict:
    return {k: v[m] for k, v in d.items()}


# --- candidates ---------------------------------------------------------------------------------

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
        reasons.append(f"line at {ang['order']} cycles per output revolution")
    return {"regions": regions, "whiteness": white, "cross_correlation": xc,
            "spectral_line": line, "angle_line": ang, "structured": bool(reasons),
            "reasons": reasons}


def sensor_floor(runs: Sequence[RunData], model: LinearModel, params: dict[str, float],
                 prep: PrepOptions | None = None) -> float | None:
    """The mean square the law's residual must keep from the sensors alone, from what the runs
    say of them (metadata `sensors`, docs/run-format.md), or None when a run says nothing: the
    noise variance of each torque channel the law's target reads (the joint torque, and the
    load cell for the output balance T − τ_L) times the share of its band the low-pass keeps,
    plus for a twist–torque law the encoders' quantisation as the law sees it
    (`quantisation_floor`). The quantisation error of a slowly moving encoder is not white, so
    the first-difference floor misses it; it is the floor a twist–torque law cannot go below."""
    total = []
    for run in runs:
        sensors = run.meta.get("sensors")
        if not isinstance(sensors, dict) or "torque" not in sensors:
            return None
        # white noise keeps the share of its band the low-pass before decimation lets through
        fs = float(run.meta.get("sample_rate_hz") or 0.0)
        kept = 1.0
        if prep is not None and fs > 0:
            cutoff = prep.cutoff_hz or (0.4 * fs / prep.decimate if prep.decimate > 1 else None)
            if cutoff is not None and (prep.filter_outputs or prep.decimate > 1):
                kept = min(1.0, cutoff / (0.5 * fs))
        ms = kept * sum(float((sensors.get(ch) or {}).get("noise_sd", 0.0)) ** 2
                        for ch in ("torque", "torque_load") if ch in model.target_requires)
        if model.kind == "transmission":
            ms += quantisation_floor(run, model, params, prep or PrepOptions())
        total.append(ms)
    return float(np.mean(total)) if total else None


QUANTISATION_OFFSETS = 8
"""Grid offsets averaged over in quantisation_floor (where the true angle sits between two
steps is unknown)."""


def quantisation_floor(run: RunData, model: LinearModel, params: dict[str, float],
                       prep: PrepOptions) -> float:
    """Mean square that the output and motor encoders' steps (`sensors[q|u].resolution`) leave
    in a twist–torque law, by surrogate: the run's angles smoothed (a zero-phase low-pass at a
    tenth of the sample rate, at most 2 Hz, which removes the staircase), quantised again on a
    grid shifted by a known fraction of a step, prepared as the law prepares the run (filter,
    decimation) and passed through the fitted law (`params`): the mean square change of its
    prediction against the smooth angles, averaged over QUANTISATION_OFFSETS shifts. So the
    floor follows what the law does with a step — a stiffening curve's local slope, the damping
    of the twist rate, the low-pass that averages the error of an encoder crossing many steps
    and keeps that of one creeping or at rest. 0 when no encoder states its step or the run
    records the twist itself (`torsion`)."""
    sensors = run.meta.get("sensors") or {}
    cols = run.samples.columns
    steps = {ch: float((sensors.get(ch) or {}).get("resolution", 0.0)) for ch in ("q", "u")}
    steps = {ch: st for ch, st in steps.items() if st > 0 and ch in cols}
    if not steps or "torsion" in cols or not {"q", "u"} <= set(cols):
        return 0.0
    t = run.t
    fs = float(run.meta.get("sample_rate_hz") or 1.0 / np.median(np.diff(t)))
    need = list(dict.fromkeys(model.requires))
    theta = np.array([float(params.get(n, 0.0)) for n in model.param_names])
    sos = signal.butter(2, min(2.0, 0.1 * fs), fs=fs, output="sos")
    smooth = {}
    for ch in steps:
        y = run.channel(ch)
        ok = np.isfinite(y)
        filled = np.interp(t, t[ok], y[ok]) if ok.any() else y
        smooth[ch] = signal.sosfiltfilt(sos, filled)
    base = run.samples.copy()
    for ch in steps:
        base[ch] = np.where(np.isfinite(run.channel(ch)), smooth[ch], np.nan)
    try:
        ref = model.predict(prepare(RunData(base, run.meta), need, prep), theta)
    except (KeyError, ValueError):
        return 0.0
    ms = []
    for j in range(QUANTISATION_OFFSETS):
        shifted = base.copy()
        for ch, st in steps.items():
            o = st * (j + 0.5) / QUANTISATION_OFFSETS
            shifted[ch] = np.round((base[ch].to_numpy() + o) / st) * st - o
        pred = model.predict(prepare(RunData(shifted, run.meta), need, prep), theta)
        d = pred - ref
        ms.append(float(np.mean(d[np.isfinite(d)] ** 2)) if np.isfinite(d).any() else 0.0)
    return float(np.mean(ms))


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


def _noise_floor(e: np.ndarray, run: np.ndarray) -> float:
    """White-noise mean square under the residual: mean of (e[i+1] − e[i])²/2 within runs (a
    smooth, structured residual barely contributes to first differences)."""
    num, den = 0.0, 0
    for r in np.unique(run):
        d = np.diff(e[run == r])
        num += float(d @ d) / 2.0
        den += d.size
    return num / den if den else 0.0


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


def _as_fit(f: _Fit, role: str, shapes: dict) -> Fit:
    r = f.ols
    return Fit(model=f.model.name, method="ls", param_names=list(f.model.param_names),
               units=list(f.model.units), mean=f.theta, sd=f.se, ci_low=r.ci_low,
               ci_high=r.ci_high, sigma=r.sigma, rmse_train=_rmse(f.e_train),
               rmse_test=_rmse(f.e_test), diagnostics={"rank": r.rank},
               extra={"diagnosis": role, "shapes": shapes, "cov": f.cov, "dof": r.dof,
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


def transient_mask(sig: dict, window_s: float, angle_step: float = 0.0) -> np.ndarray:
    """True on the samples within window_s [s] of one where the joint is at rest or passing
    through zero speed (|q̇| below 5 % of the campaign's top speed, the regions' "near zero
    speed"): a start, a stop, a reversal.
    There a real joint sticks, presslides and breaks away (dynamic friction), its friction at
    rest is whatever holds it, and no static friction form of the vocabulary models that — it
    would otherwise pass for a Stribeck rise, or leave structure no candidate can explain.
    With the output encoder's step `angle_step` [rad] > 0, a sample is also at rest when the
    angle moves less than that band over a window of 2·angle_step/band (the time the encoder
    needs to resolve it; at least two samples) around it: a velocity reading that lags or is
    smoothed (a drive's observer) can pass a short stop by — a load released at speed slips the
    joint forward, stops it for a tenth of a second and lets it go on — while the angle shows it."""
    out = np.zeros(sig["t"].size, dtype=bool)
    band = 0.05 * float(np.quantile(np.abs(sig["qd"]), 0.99))
    for r in np.unique(sig["run"]):
        idx = np.flatnonzero(sig["run"] == r)
        v, t = sig["qd"][idx], sig["t"][idx]
        slow = np.abs(v) <= band
        if angle_step > 0 and band > 0 and "q" in sig and t.size > 2:
            q = sig["q"][idx]
            half = 0.5 * max(2.0 * angle_step / band, 2.0 * float(np.median(np.diff(t))))
            moved = np.interp(t + half, t, q) - np.interp(t - half, t, q)
            inside = (t - half >= t[0]) & (t + half <= t[-1])
            slow |= inside & (np.abs(moved) <= band * 2.0 * half)
        if not slow.any():
            continue
        # dilate the slow samples by window_s on both sides
        ts = t[slow]
        lo = np.searchsorted(ts, t - window_s, side="left")
        hi = np.searchsorted(ts, t + window_s, side="right")
        out[idx] = hi > lo
    return out


def stated_resolution(run: RunData, channel: str) -> float:
    """The step [rad, or the channel's unit] the run's sensor sheet states for `channel`
    (`sensors[channel].resolution`, docs/run-format.md); 0 when it states none."""
    s = run.meta.get("sensors") if isinstance(run.meta, dict) else None
    return float(((s or {}).get(channel) or {}).get("resolution", 0.0) or 0.0)


def output_encoder_step(runs: Sequence[RunData]) -> float:
    """The coarsest output-encoder step [rad] the runs state; 0 when a run states none."""
    steps = [stated_resolution(r, "q") for r in runs]
    return max(steps) if steps and min(steps) > 0 else 0.0


def advanced(y: np.ndarray, t: np.ndarray, lag_s: float) -> np.ndarray:
    """y read lag_s [s] earlier: y(t + lag_s) at the samples t; the last lag's samples are NaN.
    On a uniformly sampled channel with every sample finite the shift is band-limited (the
    spectrum of y's even extension turned by e^{iω·lag_s}): an all-pass, so white sensor noise
    stays white at the sd its sheet states. Linear interpolation would not: a shift by a
    fraction f of the sample period leaves √((1 − f)² + f²) of the noise sd, correlated between
    neighbours, and the sensor floor (sensor_floor) would then stand above the true noise.
    Otherwise (jittered stamps, missing samples) linear interpolation over the finite ones."""
    y = np.asarray(y, dtype=float)
    n = y.size
    ok = np.isfinite(y)
    dt = np.diff(t)
    uniform = n >= 4 and ok.all() and float(np.ptp(dt)) <= 1e-6 * float(np.median(dt))
    if not uniform:
        return np.interp(t + lag_s, t[ok], y[ok], right=np.nan)
    shift = lag_s / float(np.median(dt))                 # in samples
    # the line through the end samples is shifted exactly; what is left is zero at both ends
    # and extended odd about them, so the periodic signal the FFT sees has no jump and no kink
    ramp = y[0] + (y[-1] - y[0]) * np.arange(n) / (n - 1)
    z = y - ramp
    ext = np.concatenate([z, -z[-2:0:-1]])
    turn = np.exp(2j * np.pi * np.fft.rfftfreq(ext.size) * shift)
    if ext.size % 2 == 0:
        turn[-1] = np.cos(np.pi * shift)                 # the Nyquist bin stays real
    out = np.fft.irfft(np.fft.rfft(ext) * turn, ext.size)[:n]
    out += ramp + (y[-1] - y[0]) / (n - 1) * shift
    out[max(n - int(np.ceil(shift - 1e-9)), 0):] = np.nan
    return out


def lag_corrected(run: RunData) -> RunData:
    """The run with every channel whose sensor the metadata says lags (`sensors[ch].lag_s`,
    docs/run-format.md) moved back by that lag (`advanced`; the last lag's samples become
    missing): a known fieldbus latency or filter delay is a property of the sensor, not a gap
    of the model. The run itself is left alone."""
    sensors = run.meta.get("sensors") if isinstance(run.meta, dict) else None
    lags = {ch: float(spec.get("lag_s", 0.0)) for ch, spec in (sensors or {}).items()
            if isinstance(spec, dict) and ch in run.samples.columns and ch != "t"}
    lags = {ch: d for ch, d in lags.items() if d > 0}
    if not lags:
        return run
    df = run.samples.copy()
    t = run.t
    for ch, d in lags.items():
        df[ch] = advanced(df[ch].to_numpy(dtype=float), t, d)
    meta = dict(run.meta)
    meta["sensors"] = {ch: ({**spec, "lag_s": 0.0} if ch in lags else spec)
                       for ch, spec in sensors.items()}
    return RunData(samples=df, meta=meta)


def working_rate(runs: Sequence[RunData], prep: PrepOptions, opt: DiagnosisOptions
                 ) -> PrepOptions:
    """`prep` with its decimation raised so that the runs are analysed at no more than
    max(opt.max_rate_hz, 5 × their torque's bandwidth) (low-passed first,
    estimator.preprocess): a heavy joint's motion, friction and candidate terms live far below
    a 1 kHz acquisition's band, and the diagnosis's cost and memory grow with the samples it
    pools; a system driven faster keeps the rate its signal needs. The bandwidth is measured:
    the frequency below which 99 % of the detrended torque's power above its white floor
    lies (the floor: the median of the spectrum's top quarter), the widest over the runs."""
    rates, bands = [], []
    for r in runs:
        t = r.t
        if t.size < 16:
            return prep
        fs = 1.0 / float(np.median(np.diff(t)))
        rates.append(fs)
        if "torque" in r.samples.columns:
            y = r.channel("torque")
            y = y[np.isfinite(y)]
            if y.size >= 16:
                y = y - np.polyval(np.polyfit(np.arange(y.size), y, 1), np.arange(y.size))
                p = np.abs(np.fft.rfft(y))[1:] ** 2
                # the power above the white floor (the median of the top quarter's spectrum)
                p = np.clip(p - np.median(p[3 * p.size // 4:]), 0.0, None)
                c = np.cumsum(p)
                if c[-1] > 0:
                    k = int(np.searchsorted(c, 0.99 * c[-1])) + 1
                    bands.append(k * fs / y.size)
    if not rates:
        return prep
    effective = min(rates) / prep.decimate
    target = max(opt.max_rate_hz, 5.0 * max(bands)) if bands else opt.max_rate_hz
    factor = int(effective // target)
    return replace(prep, decimate=prep.decimate * factor) if factor > 1 else prep


def below_drive_train_mode(runs: Sequence[RunData], prep: PrepOptions, model: LinearModel,
                           transient_s: float, mode_band_excess: float = 2.0
                           ) -> tuple[PrepOptions, dict | None]:
    """For an output balance with an inertia term: `prep` low-passed (every channel) at half
    the drive train's first mode f₁ = √(k/I)/2π when f₁/2 lies inside the analysed band, and
    what was measured (None when nothing was changed). At f₁ the output inertia rings on the
    transmission stiffness with a motion of the order of the output encoder's step, so the
    balance's I·q̈ cannot be measured there: the ringing would be left in the residual as
    structure (and pull the fitted I down) though the model lacks nothing. Done only when the
    nominal residual shows that ringing: a dominant spectral line within 25 % of f₁, or at
    least `mode_band_excess` times a white residual's power between 0.5·f₁ and 1.5·f₁
    (`band_excess`: on a stiffening transmission the mode moves with the load). k is the
    least-squares slope of the torque on the twist u − q over the runs; I the law fitted below
    2 Hz (where the encoder resolves the motion) on the steady samples (`transient_mask`: a
    low-passed sgn q̇ is wrong around reversals). Runs without a twist (no motor angle) are
    left as they are."""
    if model.kind != "output" or "I_xx" not in model.param_names:
        return prep, None
    num = den = 0.0
    fs = []
    for r in runs:
        cols = r.samples.columns
        if "torque" not in cols or not ({"u", "q"} <= set(cols) or "torsion" in cols):
            return prep, None
        tw = -r.channel("torsion") if "torsion" in cols else r.channel("u") - r.channel("q")
        tq = r.channel("torque")
        ok = np.isfinite(tw) & np.isfinite(tq)
        tw, tq = tw[ok] - tw[ok].mean(), tq[ok] - tq[ok].mean()
        num, den = num + float(tw @ tq), den + float(tw @ tw)
        fs.append(float(r.meta.get("sample_rate_hz") or 1.0 / np.median(np.diff(r.t))))
    k = num / den if den > 0 else 0.0
    band = (prep.cutoff_hz if prep.cutoff_hz else
            0.4 * min(fs) / prep.decimate if prep.decimate > 1 else 0.5 * min(fs))
    low = 2.0
    if k <= 0 or not low < band:
        return prep, None
    lo_prep = replace(prep, cutoff_hz=low, filter_outputs=True)
    pooled = _pool(list(runs), list(model.requires), lo_prep, 0)
    if transient_s > 0:
        pooled = _slice(pooled, ~transient_mask(pooled, transient_s, output_encoder_step(runs)))
    if pooled["t"].size <= 2 * len(model.param_names):   # nothing steady to measure I on
        return prep, None
    fit = _fit(model, {}, pooled, pooled)
    inertia = float(fit.theta[model.param_names.index("I_xx")])
    if not inertia > 0:
        return prep, None
    f1 = float(np.sqrt(k / inertia) / (2.0 * np.pi))
    if not 0.5 * f1 < band or 0.5 * f1 <= low:
        return prep, None
    # only when the nominal residual in the full band rings at that mode (a dominant line within
    # 25 % of f₁, the test of `_structure`): where the encoder resolves the ringing, or the
    # drive train does not ring, the band and its sensitivity stay whole
    full = _pool(list(runs), list(model.requires), prep, 0)
    if transient_s > 0:
        full = _slice(full, ~transient_mask(full, transient_s, output_encoder_step(runs)))
    if full["t"].size <= 2 * len(model.param_names):
        return prep, None
    e = _fit(model, {}, full, full).e_train
    line = spectral_line(e, full["t"], full["run"])
    at_line = bool(line["p_value"] < 1e-3 and line["share"] > 0.05 and line["freq_hz"]
                   and abs(line["freq_hz"] - f1) < 0.25 * f1)
    excess = band_excess(e, full["t"], full["run"], 0.5 * f1, 1.5 * f1)
    if not (at_line or excess >= mode_band_excess):
        return prep, None
    return replace(prep, cutoff_hz=0.5 * f1, filter_outputs=True), {
        "stiffness": k, "inertia": inertia, "mode_hz": f1,
        "line_hz": float(line["freq_hz"]) if at_line else None, "band_excess": excess,
        "band_hz": band, "cutoff_hz": 0.5 * f1}


def velocity_source(runs: Sequence[RunData], prep: PrepOptions, model: LinearModel,
                    transient_s: float, z: float, block: int | None = None
                    ) -> tuple[PrepOptions, dict | None]:
    """For an output balance on runs that carry a measured velocity: `prep` with q̇ derived
    from the output angle instead (PrepOptions.derive_velocity) when the nominal law fitted
    that way leaves a smaller residual on the training `runs`, by more than z standard errors
    of the per-block difference of squared residuals; and what was compared (None when the
    law reads no velocity). A drive's velocity estimate (an observer, a tracking loop) can lag
    and smooth the motion it reports while its sheet states no lag; q̈ is differentiated from
    it, so I·q̈ carries the error into the law as structure. Both fits share every sample,
    every column and the band, so the smaller residual is the velocity that agrees with the
    torque: a decision made on the campaign, not on a constant."""
    if (model.kind != "output" or prep.derive_velocity or not runs
            or not all({"q", "qd"} <= set(r.samples.columns) for r in runs)):
        return prep, None
    need = list(model.requires)
    try:
        pooled = {dv: _pool(list(runs), need, replace(prep, derive_velocity=dv), 0)
                  for dv in (False, True)}
    except (KeyError, ValueError):       # the law's own pooling says why, with the run's name
        return prep, None
    if not np.array_equal(pooled[False]["t"], pooled[True]["t"]):
        return prep, None
    keep = (~transient_mask(pooled[False], transient_s, output_encoder_step(runs))
            if transient_s > 0 else np.ones(pooled[False]["t"].size, dtype=bool))
    if keep.sum() <= 2 * len(model.param_names):
        return prep, None
    e = {dv: _fit(model, {}, _slice(p, keep), _slice(p, keep)).e_train
         for dv, p in pooled.items()}
    run = pooled[False]["run"][keep]
    gain, se = mean_se(e[False] ** 2 - e[True] ** 2, block_ids(run, block_size(run, block)))
    gain_z = gain / se if np.isfinite(se) and se > 0 else 0.0
    derived = bool(gain_z > z)
    return (replace(prep, derive_velocity=True) if derived else prep), {
        "source": "output angle" if derived else "measured",
        "rmse_measured": _rmse(e[False]), "rmse_derived": _rmse(e[True]), "gain_z": gain_z}


def block_size(run: np.ndarray, block: int | None = None) -> int:
    """Samples per batch-means block: `block`, or max(10, √(median samples per run))."""
    n_per_run = np.bincount(run)
    return block or max(10, int(np.sqrt(np.median(n_per_run[n_per_run > 0]))))


def diagnose_detailed(train_runs: Sequence[RunData], test_runs: Sequence[RunData],
                      base: str | LinearModel = "eq4", prep: PrepOptions | None = None,
                      options: DiagnosisOptions | None = None,
                      transmission: str | LinearModel | None = "auto") -> Diagnosis:
    """diagnose() plus the fits it made (see Diagnosis)."""
    if not train_runs or not test_runs:
        raise ValueError("a diagnosis needs at least one training run and one held-out run")
    opt = options or DiagnosisOptions()
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
                                            opt.transient_s, opt.mode_band_excess)
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
            why = (f"{n_transient} samples lie within {opt.transient_s:g} s of near-zero speed "
                   "(|q̇| below 5 % of the campaign's top speed: one run much faster than the "
                   "others makes that every other run's) and are left out"
                   if n_transient else f"every {part} sample misses a channel the law needs")
            raise ValueError(f"the {law} has no {part} sample left to diagnose on: {why}")

    block = block_size(pooled["run"], opt.block)
    blocks = block_ids(pooled["run"], block)
    te_blocks = blocks[~is_train]

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
        fits[name] = _best_shape(ms, tr, te)
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
                trial[n] = _best_shape(ms, tr, te)
                progress(stage, len(trial), len(grids))
        first = False
        scored = {n: _score(cur, f, te_blocks, opt) for n, f in trial.items()}
        progress(stage, len(trial), len(trial))
        if not scored:
            break
        # the largest held-out gain among the significant candidates (a larger gain that is not
        # significant is noise, and must not end the search before a significant one is added)
        significant = sorted((n for n in scored if scored[n]["significant"]),
                             key=lambda n: -scored[n]["gain"])
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
        "skipped": skipped,
        "ambiguities": [list(a) for a in ambiguities],
        "steps": steps,
        "rejected": rejected,
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
                    "noise_floor_source": ("sensors" if floor_sensor and floor_sensor > floor_white
                                           else "first differences"),
                    "residual_after": {k: after[k] for k in ("structured", "reasons")}},
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
    if tx is not None:
        merge_transmission(report, tx.report)
    report["verdict"]["summary"] = verdict_summary(report)
    return Diagnosis(report=report, baseline=_as_fit(base_fit, "baseline", {}),
                     final=_as_fit(cur, "final", shapes) if chosen else None, transmission=tx)


# --- the transmission law (twist vs torque) ------------------------------------------------------

TRANSMISSION_SIGNALS = ("torsion", "torsion_rate", "torque")


def _elastic_basis(tr: dict, knees: Sequence[float] = ()
                   ) -> tuple[float, np.ndarray, np.ndarray]:
    """The training twist's top |Δ| [rad] (its 99th percentile), the columns of the elastic law
    T = k·Δ + D·Δ̇ + C + k3·Δ³ (+ a stiffness change beyond each of `knees`), and an orthonormal
    basis of them (column-normalised first): the profile least squares of compliance_knees
    and soft_centre project a trial column and the torque on it."""
    d = np.asarray(tr["torsion"], dtype=float)
    top = float(np.quantile(np.abs(d), 0.99)) or 1e-3
    base = np.column_stack([d, np.asarray(tr["torsion_rate"], dtype=float), np.ones_like(d),
                            d ** 3, *(knee_column(k)(tr) for k in knees)])
    q, _ = np.linalg.qr(base / np.where(np.any(base != 0, axis=0), np.abs(base).max(axis=0),
                                        1.0))
    return top, base, q


def compliance_knees(tr: dict, opt: DiagnosisOptions) -> tuple[float, float]:
    """The two knee twists [rad] of the nominal compliance curve: the pair of
    `opt.compliance_knee_rel` (fractions of the training twist's top |Δ|, its 99th
    percentile) whose elastic law — T = k·Δ + D·Δ̇ + C + k3·Δ³ + the two stiffness changes —
    has the smallest training RSS (profile least squares over the knees)."""
    if min(opt.compliance_knee_rel) <= max(opt.backlash_b_rel):
        raise ValueError("compliance_knee_rel must lie above backlash_b_rel (a knee inside the "
                         "dead zones searched would take backlash's place)")
    # the knee columns and the torque with the rest of the law projected out: each pair's RSS
    # is then a 2 × 2 solve
    top, _, q = _elastic_basis(tr)
    y = np.asarray(tr["torque"], dtype=float)
    y = y - q @ (q.T @ y)

    def best_pair(knees: list[float], allowed) -> tuple[float, tuple[float, float]]:
        h = np.column_stack([knee_column(k)(tr) for k in knees])
        h = h - q @ (q.T @ h)
        gram, hy = h.T @ h, h.T @ y
        best, pair = np.inf, (knees[0], knees[-1])
        for i in range(len(knees)):
            for j in range(i + 1, len(knees)):
                if not allowed(knees[i], knees[j]):
                    continue
                ij = [i, j]
                coef = np.linalg.lstsq(gram[np.ix_(ij, ij)], hy[ij], rcond=None)[0]
                rss = float(y @ y - hy[ij] @ coef)
                if rss < best:
                    best, pair = rss, (knees[i], knees[j])
        return best, pair

    rel = sorted(set(opt.compliance_knee_rel))
    _, pair = best_pair([r * top for r in rel], lambda a, b: True)
    # then each knee to a fifth of the grid's step, within half a step of the grid's choice
    step = min(np.diff(rel)) * top if len(rel) > 1 else 0.05 * top
    lo = rel[0] * top
    fine = sorted({max(lo, k + f * step) for k in pair for f in np.linspace(-0.5, 0.5, 6)})
    _, pair = best_pair(fine, lambda a, b: (abs(a - pair[0]) <= 0.51 * step
                                            and abs(b - pair[1]) <= 0.51 * step))
    return float(pair[0]), float(pair[1])


SOFT_CENTRE_GRID = 48
"""Half-widths tried for a soft centre (soft_centre), log-spaced over the dead zones searched:
fine enough (4 % apart over the backlash grid's range) that a dead zone's own half-width is
among them."""


def twist_resolution(runs: Sequence[RunData]) -> float | None:
    """The coarsest step [rad] with which the runs measure the twist u − q: the sum of the
    output and motor encoders' stated steps (`stated_resolution`), the largest over the runs;
    None when a run states no output-encoder step."""
    if not runs or output_encoder_step(runs) <= 0:
        return None
    return max(stated_resolution(r, "q") + stated_resolution(r, "u") for r in runs)


def soft_centre(tr: dict, knees: tuple[float, float], opt: DiagnosisOptions,
                resolution: float | None) -> float | None:
    """The half-width θ₀ [rad] of a soft centre of the compliance curve, or None. θ₀ is the
    half-width, over the dead zones the backlash candidate searches (`opt.backlash_b_rel` of
    the training twist's top |Δ|, SOFT_CENTRE_GRID values), of the stiffness change that fits
    the elastic law best with the curve's two knees. It is kept only when the stiffness it
    leaves inside, k_in, is above `opt.soft_centre_min_ratio` of the stiffness beyond it by
    `opt.z_gain` standard errors of the fit. A gear train whose teeth take up the load
    progressively is softer near zero twist: a harmonic drive's catalogue K1 is 0.5–0.7 of K2,
    the nominal curve's first segment. A dead zone takes the stiffness away inside its gap
    (k_in ≈ 0): that is backlash, left to its candidate. The data tell the two apart only when
    the centre spans `opt.soft_centre_min_steps` of the twist's `resolution` [rad]: a narrower
    dead zone seen through the encoders' rounding is a centre of reduced stiffness too. None
    when the runs do not state their encoders' steps."""
    if resolution is None or resolution <= 0:
        return None
    top, base, q = _elastic_basis(tr, knees)
    y = np.asarray(tr["torque"], dtype=float)
    y_left = y - q @ (q.T @ y)
    best, best_rss = None, np.inf
    for theta in np.geomspace(min(opt.backlash_b_rel) * top, max(opt.backlash_b_rel) * top,
                              SOFT_CENTRE_GRID):
        h = knee_column(theta)(tr)
        h = h - q @ (q.T @ h)
        hh = float(h @ h)
        if hh <= 0:
            continue
        rss = float(y_left @ y_left) - float(h @ y_left) ** 2 / hh
        if rss < best_rss:
            best, best_rss = theta, rss
    if best is None:
        return None
    fit = ols(np.column_stack([base, knee_column(best)(tr)]), y)
    r = opt.soft_centre_min_ratio
    c = np.zeros(fit.theta.size)
    c[0], c[-1] = 1.0 - r, -r          # k_in − r·(k_in + dk)
    margin = float(c @ fit.theta)
    se = float(np.sqrt(max(c @ fit.cov @ c, 0.0)))
    if (fit.theta[-1] > 0 and np.isfinite(se) and margin > opt.z_gain * se
            and best >= opt.soft_centre_min_steps * resolution):
        return float(best)
    return None


def transmission_model(spec: str | LinearModel, tr: dict, opt: DiagnosisOptions,
                       resolution: float | None = None) -> tuple[LinearModel, dict]:
    """The nominal twist–torque law and the shape chosen for it on the training signals `tr`:
    'auto' or 'bouc_wen' — issue 7's nominal, the Bouc–Wen law as Eq. 11 with its state x for
    the shape (α = 1, n = 1, β, γ) of bouc_wen_grid with the smallest training RSS (profile least
    squares); 'eq5' — the elastic law (then hysteresis is a candidate); or any transmission
    model / spec of estimator.models; each with a stiffness that changes with the twist
    (estimator.models.with_stiffening: a real compliance curve is part of the nominal elastic
    law, identified like k, not a gap; its knees from compliance_knees, reported in the
    shape as knee_1, knee_2 [rad], and a soft centre's half-width from soft_centre as
    soft_centre [rad] when the curve has one)."""
    knees = compliance_knees(tr, opt)
    knee_shape = {"knee_1": knees[0], "knee_2": knees[1]}
    centre = soft_centre(tr, knees, opt, resolution)
    if centre is not None:
        knee_shape["soft_centre"] = centre
    if isinstance(spec, str) and spec in ("auto", "bouc_wen"):
        from scipy.optimize import minimize

        def shape(v):   # v = (log(β+γ), logit(β/(β+γ)))
            ssum, share = float(np.exp(v[0])), float(1.0 / (1.0 + np.exp(-v[1])))
            return {"alpha": 1.0, "beta": share * ssum, "gamma": (1.0 - share) * ssum, "n": 1}

        def rss(v):
            sh = shape(v)
            m = eq11(sh["alpha"], sh["beta"], sh["gamma"], sh["n"])
            return ols(m.design(tr), m.target(tr)).rss

        starts = [np.array([np.log(sh["beta"] + sh["gamma"]),
                            np.log(sh["beta"] / sh["gamma"])]) for sh in bouc_wen_grid(tr, opt)]
        v0 = min(starts, key=rss)
        # refine the grid's best (profile least squares over the two shape coordinates)
        res = minimize(rss, v0, method="Nelder-Mead",
                       options={"maxfev": 80, "xatol": 0.01, "fatol": 1e-6 * rss(v0)})
        sh = shape(res.x if res.fun <= rss(v0) else v0)
        return (with_stiffening(eq11(sh["alpha"], sh["beta"], sh["gamma"], sh["n"]), knees,
                                centre), {**sh, **knee_shape})
    m = base_model(spec)
    if m.kind != "transmission":
        raise ValueError(f"{m.name!r} is not a transmission (twist–torque) model")
    return with_stiffening(m, knees, centre), knee_shape


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
    tr = _pool(train_runs, TRANSMISSION_SIGNALS, tprep, 0)
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
    d = diagnose_detailed(train_runs, test_runs, model, tprep, topt, transmission=None)
    d.report["baseline"]["shape"] = shape
    d.report["baseline"]["carried"] = list(carried)
    return d
