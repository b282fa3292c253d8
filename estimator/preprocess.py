"""From a recorded run to the signals the identification models need.

`prepare(run, need, options)` returns a `Signals` dict of equal-length float arrays:

- 't' [s], and every signal of `need` that the run can supply, among
  'q' [rad], 'qd' [rad/s], 'qdd' [rad/s²], 'u' [rad], 'ud' [rad/s],
  'torsion' [rad] — the twist Δ = u − q of rig.md (the run format's `torsion` channel is q − u,
  so it is negated; without it Δ is computed as u − q),
  'torsion_rate' [rad/s] (dΔ/dt), 'torque', 'torque_load' [N·m] (zeros when the run has no load
  channel: `info['has_torque_load']` says so), 'torque_rate' [N·m/s], and any other numeric channel
  by its name (e.g. 'temp_joint');
- 'segment' (int): which contiguous stretch of valid samples each sample belongs to, and
  'index' (int): the sample's row in the run. Every output sample is a recorded sample.

Processing, in order (each option documented on `PrepOptions`):
1. Dropouts: rows where any source channel of `need` is missing (NaN) are removed and the valid
   rows split into contiguous segments; nothing is interpolated across a gap. Segments shorter
   than `min_segment` are dropped. All of it is counted in `info`.
2. Low-pass: a zero-phase Butterworth filter (forward–backward, scipy `sosfiltfilt`) per segment,
   when `cutoff_hz` is set, on the kinematic channels (q, q̇, q̈, u, u̇, torsion) — the ones that
   are differentiated or enter the models' nonlinear columns. The torque and the other channels
   are left as recorded unless `filter_outputs`: a filtered Coulomb step in the torque cannot be
   matched by the sign of a filtered velocity (measured on emulated scheme-3 data: a 5 Hz
   filter on every channel raised Eq. 4's residual sd from 195 to 550 N·m and biased f_c by
   20 sd). When decimating, every channel is filtered at 0.8 × the new Nyquist frequency first
   (anti-aliasing); linear models instead decimate their regression equation
   (estimator.identify.build_dataset: parallel filtering of X and y).
3. Derivatives: central differences (`numpy.gradient` with the sample times) of the filtered
   signals, per segment: q̇ from q unless a velocity channel is measured (measured `qd` is used,
   filtered, unless `derive_velocity`), q̈ from q̇ unless `qdd` is measured, Δ̇ from Δ, Ṫ from T.
4. Trimming: `trim` samples at each segment end (filter transients, one-sided differences).
5. Decimation: every `decimate`-th sample of each segment is kept.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Iterable

import numpy as np
from scipy import signal

from core.run import RunData

DERIVED = ("qd", "qdd", "torsion", "torsion_rate", "torque_load", "torque_rate", "ud")


@dataclass(frozen=True)
class PrepOptions:
    cutoff_hz: float | None = None
    """Low-pass cutoff [Hz] of the zero-phase Butterworth filter; None: no filter unless
    decimating, when it is 0.8 × the decimated Nyquist frequency."""
    order: int = 4
    """Butterworth order (applied forward and backward: the magnitude response is squared)."""
    decimate: int = 1
    """Keep every k-th sample after filtering (k ≥ 1)."""
    trim: int | None = None
    """Samples dropped at each segment end; None: 2 without a filter, else max(2, fs/cutoff)."""
    min_segment: int = 16
    """Shorter valid stretches (after a dropout) are dropped, not filtered."""
    derive_velocity: bool = False
    """True: q̇ from central differences of q even when a velocity channel is recorded."""
    filter_outputs: bool = False
    """True: cutoff_hz also filters the torque and the other non-kinematic channels."""
    min_speed: float = 0.0
    """[rad/s] Linear models drop the rows where |q̇| < min_speed (estimator.identify): around
    velocity reversals the joint sticks, q̇ sits inside the friction's tanh band (v_eps) and the
    sign of a measured speed is unreliable (errors in variables). 0 keeps every row."""


KINEMATIC = ("q", "qd", "qdd", "u", "ud", "torsion")
"""Channels filtered by cutoff_hz (differentiated, or inside nonlinear model columns)."""


class Signals(dict):
    """dict of name -> array (all the same length), plus `info` (what preprocessing did)."""

    def __init__(self, *args, info: dict | None = None, **kw):
        super().__init__(*args, **kw)
        self.info = dict(info or {})

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(len(self["t"])) if "t" in self else 0


def _sources(run: RunData, name: str, opt: PrepOptions) -> list[str]:
    """Run channels a signal is computed from."""
    cols = set(run.samples.columns)
    if name == "q":
        return ["q"]
    if name == "qd":
        return ["qd"] if ("qd" in cols and not opt.derive_velocity) else ["q"]
    if name == "qdd":
        return ["qdd"] if "qdd" in cols else _sources(run, "qd", opt)
    if name == "ud":
        return ["ud"] if "ud" in cols else ["u"]
    if name in ("torsion", "torsion_rate"):
        return ["torsion"] if "torsion" in cols else ["u", "q"]
    if name == "torque_rate":
        return ["torque"]
    if name == "torque_load":
        return ["torque_load"] if "torque_load" in cols else []
    return [name]


def prepare(run: RunData, need: Iterable[str] = ("q", "qd", "qdd", "torque", "torque_load"),
            options: PrepOptions | None = None) -> Signals:
    """Prepared signals for `need` (see the module docstring). Raises KeyError naming the
    missing channel when the run cannot supply a needed signal."""
    opt = options or PrepOptions()
    need = list(dict.fromkeys(need))
    cols = list(run.samples.columns)
    src: list[str] = []
    for name in need:
        for c in _sources(run, name, opt):
            if c not in cols:
                raise KeyError(f"signal {name!r} needs channel {c!r}, which the run lacks "
                               f"(it has {cols})")
            src.append(c)
    src = list(dict.fromkeys(src))
    t_all = run.channel("t")
    raw = {c: run.channel(c) for c in src}
    n_in = t_all.size
    valid = np.ones(n_in, dtype=bool)
    for c in src:
        valid &= np.isfinite(raw[c])
    fs = _sample_rate(run, t_all)
    if opt.decimate < 1:
        raise ValueError("decimate must be ≥ 1")
    cutoff = opt.cutoff_hz
    if cutoff is None and opt.decimate > 1:
        cutoff = 0.8 * 0.5 * fs / opt.decimate
    if cutoff is not None and not (0 < cutoff < 0.5 * fs):
        raise ValueError(f"cutoff {cutoff} Hz must lie in (0, {0.5 * fs}) (half the sample rate)")
    sos = signal.butter(opt.order, cutoff, fs=fs, output="sos") if cutoff else None
    trim = opt.trim if opt.trim is not None else (
        2 if cutoff is None else max(2, int(np.ceil(fs / cutoff))))

    starts, ends = _segments(valid)
    out: dict[str, list[np.ndarray]] = {}
    kept_segments = 0
    dropped_short = 0
    for i0, i1 in zip(starts, ends):
        if i1 - i0 < max(opt.min_segment, 2 * trim + 3):
            dropped_short += i1 - i0
            continue
        t = t_all[i0:i1]
        seg = {c: raw[c][i0:i1] for c in src}
        filt = {c: _lowpass(sos if (c in KINEMATIC or opt.filter_outputs or opt.decimate > 1)
                            else None, x) for c, x in seg.items()}
        sig = _derive(need, filt, t, run, opt)
        sl = slice(trim, (i1 - i0) - trim, opt.decimate)
        sig = {k: v[sl] for k, v in sig.items()}
        sig["t"] = t[sl]
        sig["index"] = np.arange(i0, i1)[sl]
        sig["segment"] = np.full(sig["t"].size, kept_segments, dtype=int)
        kept_segments += 1
        for k, v in sig.items():
            out.setdefault(k, []).append(v)
    if kept_segments == 0:
        raise ValueError("no stretch of valid samples long enough to use: the run is empty or "
                         "its needed channels are mostly missing")
    arrays = {k: np.concatenate(v) for k, v in out.items()}
    info = {
        "sample_rate_hz": fs, "sample_rate_out_hz": fs / opt.decimate, "cutoff_hz": cutoff,
        "trim": trim, "rows_in": int(n_in), "rows_out": int(arrays["t"].size),
        "rows_missing": int((~valid).sum()), "rows_in_short_segments": int(dropped_short),
        "segments": kept_segments, "has_torque_load": "torque_load" in cols,
        "sources": src, "options": asdict(opt), "meta": dict(run.meta),
    }
    return Signals(arrays, info=info)


def _sample_rate(run: RunData, t: np.ndarray) -> float:
    fs = run.meta.get("sample_rate_hz") if run.meta else None
    if fs:
        return float(fs)
    if t.size < 2:
        raise ValueError("a run needs at least two samples")
    return float(1.0 / np.median(np.diff(t)))


def _segments(valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    v = np.concatenate([[False], valid, [False]]).astype(np.int8)
    d = np.diff(v)
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def _lowpass(sos, x: np.ndarray) -> np.ndarray:
    if sos is None:
        return x.astype(float)
    padlen = min(3 * (2 * sos.shape[0] + 1), x.size - 1)
    return signal.sosfiltfilt(sos, x, padlen=padlen)


def _derive(need: list[str], f: dict[str, np.ndarray], t: np.ndarray, run: RunData,
            opt: PrepOptions) -> dict[str, np.ndarray]:
    cols = set(run.samples.columns)
    sig: dict[str, np.ndarray] = {}

    def qd():
        if "qd" not in sig:
            sig["qd"] = f["qd"] if ("qd" in cols and not opt.derive_velocity) \
                else np.gradient(f["q"], t)
        return sig["qd"]

    def twist():
        if "torsion" not in sig:
            sig["torsion"] = -f["torsion"] if "torsion" in cols else f["u"] - f["q"]
        return sig["torsion"]

    for name in need:
        if name == "qd":
            qd()
        elif name == "qdd":
            sig["qdd"] = f["qdd"] if "qdd" in cols else np.gradient(qd(), t)
        elif name == "ud":
            sig["ud"] = f["ud"] if "ud" in cols else np.gradient(f["u"], t)
        elif name == "torsion":
            twist()
        elif name == "torsion_rate":
            sig["torsion_rate"] = np.gradient(twist(), t)
        elif name == "torque_rate":
            sig["torque_rate"] = np.gradient(f["torque"], t)
        elif name == "torque_load":
            sig["torque_load"] = f["torque_load"] if "torque_load" in cols else np.zeros(t.size)
        else:
            sig[name] = f[name]
    return sig


def concat_signals(parts: list[Signals]) -> Signals:
    """Several prepared runs as one Signals: arrays concatenated, 'run' (int) added, 'segment'
    renumbered so segments stay distinct; info['runs'] keeps each part's info."""
    keys = set(parts[0])
    for p in parts[1:]:
        keys &= set(p)
    arrays: dict[str, list[np.ndarray]] = {k: [] for k in keys}
    arrays["run"] = []
    offset = 0
    for r, p in enumerate(parts):
        for k in keys:
            v = p[k]
            arrays[k].append(v + offset if k == "segment" else v)
        arrays["run"].append(np.full(p.n, r, dtype=int))
        offset += int(p["segment"].max()) + 1 if "segment" in p and p.n else 0
    return Signals({k: np.concatenate(v) for k, v in arrays.items()},
                   info={"runs": [p.info for p in parts]})
