"""Where the residual lies (issue 7, step 1): labels every sample with the regions it belongs to
and tests each region's residual.

Region families (each a partition of the samples, so the shares within a family sum to 1):
- `scheme`   scheme number and phase (run metadata `scheme`, the `phase` channel);
- `speed`    near zero speed (|q̇| < 5 % of the campaign's top speed), low (< 30 %: the
             300 r/min runs on the J4 joint), high;
- `load`     |τ_L| in thirds of its largest value (runs with a load channel);
- `power`    motoring (T·q̇ > 0) vs braking;
- `reversal` within `reversal_s` seconds of a velocity reversal, of a torque reversal, or neither;
- `angle`    the output angle modulo 2π/k in 4 bins, k the order of the residual's strongest
             angular line (estimator.diagnosis_stats.angle_lines);
- `temperature` joint temperature in thirds of its range (runs with temp_joint, range > 1 K);
- `time`     first, middle and last third of each run.

A region is flagged when its mean residual is significant (|mean|/SE > z, batch-means SE) and
not negligible (|mean| > min_mean × the residual RMS), or when its mean squared residual exceeds
the overall one significantly (z) and by more than `min_excess` (relative).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimator.diagnosis_stats import mean_se


@dataclass(frozen=True)
class RegionOptions:
    z: float = 3.0
    min_mean: float = 0.1
    """|mean residual| must exceed this fraction of the residual RMS to flag."""
    min_excess: float = 0.25
    """Mean squared residual must exceed the overall one by this fraction to flag."""
    reversal_s: float = 1.0
    near_zero: float = 0.05
    low_speed: float = 0.3


def label_regions(sig: dict, angle_order: int | None, opt: RegionOptions) -> dict[str, np.ndarray]:
    """{family: (n,) object array of region names} for pooled signals (keys t, q, qd, torque,
    run, and optionally torque_load, temp_joint, phase, scheme)."""
    n = sig["t"].size
    fam: dict[str, np.ndarray] = {}
    if "scheme" in sig:
        ph = sig.get("phase")
        fam["scheme"] = np.array([f"scheme {s}" + (f" / {p}" if ph is not None else "")
                                  for s, p in zip(sig["scheme"], ph if ph is not None else [None] * n)],
                                 dtype=object)
    aqd = np.abs(sig["qd"])
    top = float(np.quantile(aqd, 0.99)) or 1.0
    fam["speed"] = np.where(aqd < opt.near_zero * top, "near zero speed",
                            np.where(aqd < opt.low_speed * top, "low speed", "high speed")).astype(object)
    if "torque_load" in sig and np.any(sig.get("has_load", False)):
        al = np.abs(sig["torque_load"])
        mx = float(np.quantile(al, 0.99)) or 1.0
        fam["load"] = np.where(al < mx / 3, "load < 1/3 of max",
                               np.where(al < 2 * mx / 3, "load 1/3–2/3 of max",
                                        "load > 2/3 of max")).astype(object)
    fam["power"] = np.where(sig["torque"] * sig["qd"] >= 0, "motoring (T·q̇ ≥ 0)",
                            "braking (T·q̇ < 0)").astype(object)
    fam["reversal"] = _reversals(sig, opt.reversal_s)
    if angle_order:
        k = int(angle_order)
        ph = np.mod(k * sig["q"], 2 * np.pi)
        b = np.minimum((ph / (np.pi / 2)).astype(int), 3)
        fam["angle"] = np.array([f"output angle mod 2π/{k}, quarter {i + 1}" for i in b], dtype=object)
    if "temp_joint" in sig:
        tj = sig["temp_joint"]
        lo, hi = float(np.min(tj)), float(np.max(tj))
        if hi - lo > 1.0:
            c1, c2 = lo + (hi - lo) / 3, lo + 2 * (hi - lo) / 3
            fam["temperature"] = np.where(tj < c1, f"joint below {c1:.1f} °C",
                                          np.where(tj < c2, f"joint {c1:.1f}–{c2:.1f} °C",
                                                   f"joint above {c2:.1f} °C")).astype(object)
    frac = np.empty(n)
    for r in np.unique(sig["run"]):
        m = sig["run"] == r
        tt = sig["t"][m]
        frac[m] = (tt - tt[0]) / max(tt[-1] - tt[0], 1e-12)
    fam["time"] = np.where(frac < 1 / 3, "first third of the run",
                           np.where(frac < 2 / 3, "middle third of the run",
                                    "last third of the run")).astype(object)
    return fam


def _reversals(sig: dict, window_s: float) -> np.ndarray:
    n = sig["t"].size
    out = np.full(n, "away from reversals", dtype=object)
    for key, label in (("torque", "torque reversal"), ("qd", "velocity reversal")):
        for r in np.unique(sig["run"]):
            idx = np.flatnonzero(sig["run"] == r)
            x = sig[key][idx]
            t = sig["t"][idx]
            s = np.sign(x)
            # a reversal: sign change between samples whose |x| is above 2 % of the run's range
            big = np.abs(x) > 0.02 * (np.max(np.abs(x)) or 1.0)
            kk = np.flatnonzero(big)
            if kk.size < 2:
                continue
            flips = kk[1:][s[kk[1:]] != s[kk[:-1]]]
            for f in flips:
                near = np.abs(t - t[f]) <= window_s
                out[idx[near]] = f"near a {label}"
    return out


def region_table(residual: np.ndarray, families: dict[str, np.ndarray], blocks: np.ndarray,
                 opt: RegionOptions) -> list[dict]:
    """Every region with its share of the residual energy, RMSE, mean ± SE and whether it is
    flagged; sorted by share, largest first."""
    total = float(np.sum(residual ** 2)) or 1.0
    ms_all = float(np.mean(residual ** 2))
    rms_all = np.sqrt(ms_all)
    out = []
    for family, labels in families.items():
        for name in sorted(set(labels.tolist())):
            m = labels == name
            if m.sum() < 10:
                continue
            e = residual[m]
            mean, se = mean_se(e, blocks[m])
            ms, se2 = mean_se(e ** 2 - ms_all, blocks[m])
            z_mean = abs(mean) / se if se > 0 else 0.0
            z_energy = ms / se2 if se2 > 0 else 0.0
            flagged = bool((z_mean > opt.z and abs(mean) > opt.min_mean * rms_all)
                           or (z_energy > opt.z and ms > opt.min_excess * ms_all))
            out.append({"where": name, "family": family, "share": float(np.sum(e ** 2) / total),
                        "samples": float(m.mean()), "rmse": float(np.sqrt(np.mean(e ** 2))),
                        "mean": mean, "mean_se": se, "z_mean": float(z_mean),
                        "z_energy": float(z_energy), "flagged": flagged})
    out.sort(key=lambda d: -d["share"])
    return out
