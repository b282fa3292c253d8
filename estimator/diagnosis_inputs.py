"""What the output balance reads (estimator.diagnosis), each decided on the campaign itself: the
samples left out around rests and reversals (transient_mask), the runs with their stated sensor
lags taken out (lag_corrected), the rate the runs are analysed at (working_rate), a band cut
below the drive train's first mode when the residual rings there (below_drive_train_mode), and
the velocity read, measured or differentiated from the output angle (velocity_source)."""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np

from core.run import RunData
from estimator.diagnosis_candidates import _fit, _rmse
from estimator.diagnosis_data import _pool, _slice, stated_resolution
from estimator.diagnosis_options import DiagnosisOptions
from estimator.diagnosis_stats import band_excess, block_ids, block_size, mean_se, spectral_line
from estimator.models import LinearModel
from estimator.preprocess import PrepOptions


def transient_mask(sig: dict, window_s: float, angle_step: float = 0.0) -> np.ndarray:
    """True on the samples the output law leaves out around rests: a start, a stop, a reversal.
    There a real joint sticks, presslides and breaks away (dynamic friction), its friction at
    rest is whatever holds it, and no static friction form of the vocabulary models that — it
    would otherwise pass for a Stribeck rise, or leave structure no candidate can explain.
    The band is the regions' "near zero speed": 5 % of the campaign's top speed |q̇|.
    - A rest is where the motion rests: the output's mean speed over ±window_s [s] (the angle
      it travels; the speed reading's mean when the runs carry no angle) lies in the band. The
      samples within window_s of a rest are left out.
    - Inside a motion, a sample whose own speed lies in the band is left out alone, without
      the window: a joint driven at a steady speed on a friction curve that falls with speed
      (Stribeck) sticks and slips, and the slips between its sticks are the sliding the curve
      defines. Leaving a window around every stick would take the whole run, and with it the
      evidence of the curve.
    - With the output encoder's step `angle_step` [rad] > 0, a sample is also at rest when the
      angle moves less than the band over a window of 2·angle_step/band (the time the encoder
      needs to resolve it; at least two samples) around it: a velocity reading that lags or is
      smoothed (a drive's observer) can pass a short stop by while the angle shows it. Such a
      stop inside a motion is left out alone, like a stick."""
    out = np.zeros(sig["t"].size, dtype=bool)
    band = 0.05 * float(np.quantile(np.abs(sig["qd"]), 0.99))
    for r in np.unique(sig["run"]):
        idx = np.flatnonzero(sig["run"] == r)
        v, t = sig["qd"][idx], sig["t"][idx]
        slow = np.abs(v) <= band
        if t.size < 3:
            out[idx] = slow
            continue
        dt = float(np.median(np.diff(t)))
        lo_t, hi_t = np.maximum(t - window_s, t[0]), np.minimum(t + window_s, t[-1])
        span = np.maximum(hi_t - lo_t, dt)
        if "q" in sig:
            q = sig["q"][idx]
            mean_speed = (np.interp(hi_t, t, q) - np.interp(lo_t, t, q)) / span
            if angle_step > 0 and band > 0:
                half = 0.5 * max(2.0 * angle_step / band, 2.0 * dt)
                moved = np.interp(t + half, t, q) - np.interp(t - half, t, q)
                inside = (t - half >= t[0]) & (t + half <= t[-1])
                slow |= inside & (np.abs(moved) <= band * 2.0 * half)
        else:
            c = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
            mean_speed = (np.interp(hi_t, t, c) - np.interp(lo_t, t, c)) / span
        rest = np.abs(mean_speed) <= band
        out[idx] = slow
        if rest.any():
            # dilate the rests by window_s on both sides
            ts = t[rest]
            lo = np.searchsorted(ts, t - window_s, side="left")
            hi = np.searchsorted(ts, t + window_s, side="right")
            out[idx] |= hi > lo
    return out


def output_encoder_step(runs: Sequence[RunData]) -> float:
    """The coarsest output-encoder step [rad] the runs state; 0 when a run states none."""
    steps = [stated_resolution(r, "q") for r in runs]
    return max(steps) if steps and min(steps) > 0 else 0.0


def advanced(y: np.ndarray, t: np.ndarray, lag_s: float, noise_sd: float = 0.0) -> np.ndarray:
    """y read lag_s [s] earlier: y(t + lag_s) at the samples t; the last lag's samples are NaN.
    On a uniformly sampled channel with every sample finite the shift is band-limited (the
    spectrum of y's even extension turned by e^{iω·lag_s}): an all-pass, so white sensor noise
    stays white at the sd its sheet states. Linear interpolation would not: a shift by a
    fraction f of the sample period leaves √((1 − f)² + f²) of the noise sd, correlated between
    neighbours, and the sensor floor (sensor_floor) would then stand above the true noise.
    Stamps that jitter about a uniform grid count as uniform when the jitter moves the reading
    by less than a tenth of its noise sd `noise_sd` (the RMS of jitter × dy/dt): a real
    acquisition's clock jitters by microseconds. Otherwise (larger jitter, missing samples, no
    stated noise) linear interpolation over the finite ones."""
    y = np.asarray(y, dtype=float)
    n = y.size
    ok = np.isfinite(y)
    dt = np.diff(t)
    complete = n >= 4 and bool(ok.all())
    uniform = complete and float(np.ptp(dt)) <= 1e-6 * float(np.median(dt))
    if complete and not uniform and noise_sd > 0 and np.all(dt > 0):
        i = np.arange(n, dtype=float)
        grid = np.polyval(np.polyfit(i, t, 1), i)
        moved = (t - grid) * np.gradient(y, t)
        uniform = float(np.sqrt(np.mean(moved ** 2))) <= 0.1 * noise_sd
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
        df[ch] = advanced(df[ch].to_numpy(dtype=float), t, d,
                          float(sensors[ch].get("noise_sd", 0.0) or 0.0))
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
                           transient_s: float, mode_band_excess: float = 2.0, z: float = 3.0
                           ) -> tuple[PrepOptions, dict | None]:
    """For an output balance with an inertia term: `prep` low-passed (every channel) where the
    balance cannot measure I·q̈ over its band, and what was measured (None when nothing was
    changed). I is the law fitted below 2 Hz (where the encoder resolves the motion) on the
    steady samples (`transient_mask`: a low-passed sgn q̇ is wrong around reversals).
    - At the drive train's first mode f₁ = √(k/I)/2π the output inertia rings on the
      transmission stiffness with a motion of the order of the output encoder's step, so I·q̈
      cannot be measured there: the ringing would be left in the residual as structure (and
      pull the fitted I down) though the model lacks nothing. The band is cut at f₁/2 when that
      lies inside it and the nominal residual shows the ringing: a dominant spectral line
      within 25 % of f₁, or at least `mode_band_excess` times a white residual's power between
      0.5·f₁ and 1.5·f₁ (`band_excess`: on a stiffening transmission the mode moves with the
      load). k is the least-squares slope of the torque on the twist u − q over the runs.
    - Nor can the velocity reading always carry q̈ over the band left: when the law fitted
      over it puts I below half the 2 Hz fit's, by more than `z` standard errors, the band is
      cut at 2 Hz. q̈ is differentiated from the velocity reading, and a reading that steps by
      its resolution (a windowed encoder difference steps by the encoder step over the window)
      makes it mostly noise above a few hertz: least squares shrinks I by the share of q̈'s
      variance that is motion, and below one half the reading's q̈ is more noise than motion.
      The real I·q̈ is then left in the residual, where it passes for a lag or a transient.
    Runs without a twist (no motor angle) are left as they are."""
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
    i_xx = model.param_names.index("I_xx")

    def steady_fit(p: PrepOptions):
        pooled = _pool(list(runs), list(model.requires), p, 0)
        if transient_s > 0:
            pooled = _slice(pooled, ~transient_mask(pooled, transient_s,
                                                    output_encoder_step(runs)))
        if pooled["t"].size <= 2 * len(model.param_names):   # nothing steady to fit on
            return None, None
        return pooled, _fit(model, {}, pooled, pooled)

    _, lo_fit = steady_fit(replace(prep, cutoff_hz=low, filter_outputs=True))
    if lo_fit is None or not lo_fit.theta[i_xx] > 0:
        return prep, None
    inertia = float(lo_fit.theta[i_xx])
    f1 = float(np.sqrt(k / inertia) / (2.0 * np.pi))
    full, fit = steady_fit(prep)
    if fit is None:
        return prep, None
    found = {"stiffness": k, "inertia": inertia, "mode_hz": f1, "line_hz": None,
             "band_excess": None, "band_hz": band}
    out = prep
    if 0.5 * f1 < band and 0.5 * f1 > low:
        # only when the nominal residual in the full band rings at that mode (a dominant line
        # within 25 % of f₁, the test of `_structure`): where the encoder resolves the
        # ringing, or the drive train does not ring, the band and its sensitivity stay whole
        e = fit.e_train
        line = spectral_line(e, full["t"], full["run"])
        at_line = bool(line["p_value"] < 1e-3 and line["share"] > 0.05 and line["freq_hz"]
                       and abs(line["freq_hz"] - f1) < 0.25 * f1)
        excess = band_excess(e, full["t"], full["run"], 0.5 * f1, 1.5 * f1)
        if at_line or excess >= mode_band_excess:
            out = replace(prep, cutoff_hz=0.5 * f1, filter_outputs=True)
            found.update(line_hz=float(line["freq_hz"]) if at_line else None,
                         band_excess=excess, cutoff_hz=0.5 * f1, reason="mode")
            fit = steady_fit(out)[1]
    if fit is not None:
        found["inertia_in_band"] = float(fit.theta[i_xx])
        if (fit.theta[i_xx] < 0.5 * inertia
                and inertia - fit.theta[i_xx] > z * float(np.hypot(lo_fit.se[i_xx],
                                                                    fit.se[i_xx]))):
            out = replace(prep, cutoff_hz=low, filter_outputs=True)
            found.update(cutoff_hz=low, reason="inertia")
    return (out, found) if out is not prep else (prep, None)


def _common_samples(a: dict, b: dict) -> dict[bool, dict] | None:
    """The two pools restricted to the samples (run, t) both hold, in their order, keyed as
    velocity_source keys them (False: measured, True: derived); None when they share none."""
    ka = np.rec.fromarrays([a["run"], a["t"]], names="run,t")
    kb = np.rec.fromarrays([b["run"], b["t"]], names="run,t")
    both = np.intersect1d(ka, kb)
    if not both.size:
        return None
    return {False: _slice(a, np.isin(ka, both)), True: _slice(b, np.isin(kb, both))}


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
    # the samples both readings have: a stated lag taken out of q̇ leaves its last samples
    # missing, which the velocity derived from the angle still has
    pooled = _common_samples(pooled[False], pooled[True])
    if pooled is None:
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
