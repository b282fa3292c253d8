"""The hysteretic mass-spring benchmark (Noel & Schoukens' Bouc-Wen benchmark), written anew.

Why: the diagnosis must recognise hysteresis that sits on the only displacement measured (no
twist channel). This public benchmark system is the standard case: a single mass on a linear
spring-damper plus a Bouc-Wen hysteretic restoring force,

    m*y'' + c*y' + k*y + z = F(t)                                           [N]
    z' = alpha*y' - beta*(gamma*|y'|*|z|^(nu-1)*z + delta*y'*|z|^nu)      [N/s]

with the benchmark's published values m = 2 kg, c = 10 N*s/m, k = 5e4 N/m, alpha = 5e4 N/m,
beta = 1e3 1/m, gamma = 0.8, delta = -1.1, nu = 1. The input F is a random-phase multisine
(flat amplitude spectrum, 5-150 Hz, period = the record length, RMS `force_rms`); the output y
is sampled at 750 Hz with additive white noise of sd `noise_sd` [m]; the force is noise-free.

Integration: classical RK4 at 15 kHz (20 steps per sample); the multisine is synthesised exactly
on the 30 kHz grid of RK4's half steps by an inverse FFT. One full period is simulated first and
discarded, so the record is (nearly) the periodic steady state, as in the benchmark's data.
`hysteresis_scale` multiplies alpha: 0 gives the linear mass-spring-damper (z = 0 exactly).

Imports only numpy and pandas; it defines its own RigRun (same fields as rig_b's) so that each
module stands alone. SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = ["RigRun", "PARAMS", "FS_HZ", "simulate"]

FS_HZ = 750.0               # sample rate of the benchmark's records
_SUBSTEPS = 20              # RK4 steps per sample -> 15 kHz
PARAMS: dict[str, float] = {
    "m": 2.0, "c": 10.0, "k": 5e4,                       # kg, N*s/m, N/m
    "alpha": 5e4, "beta": 1e3, "gamma": 0.8, "delta": -1.1, "nu": 1.0,
}
BAND_HZ = (5.0, 150.0)


@dataclass
class RigRun:
    """One record: measured `samples`, `meta` and the noise-free `truth` (same fields as
    validation_rigs.rig_b.RigRun)."""

    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


def _multisine(rng: np.random.Generator, n_fine: int, fs_fine: float, period_s: float,
               force_rms: float) -> np.ndarray:
    """Random-phase multisine with lines k/period_s in BAND_HZ, exact RMS force_rms [N]."""
    f0 = 1.0 / period_s
    k_lo = max(1, math.ceil(BAND_HZ[0] / f0 - 1e-9))
    k_hi = math.floor(BAND_HZ[1] / f0 + 1e-9)
    lines = np.arange(k_lo, k_hi + 1)
    amp = force_rms * math.sqrt(2.0 / lines.size)         # per-line cosine amplitude
    spec = np.zeros(n_fine // 2 + 1, dtype=complex)
    spec[lines] = amp * n_fine / 2.0 * np.exp(1j * rng.uniform(0, 2 * math.pi, lines.size))
    return np.fft.irfft(spec, n=n_fine)


def _rk4(force_fine: np.ndarray, h: float, n_steps: int, p: dict[str, float], state0,
         substeps: int):
    """RK4 of (y, v, z) with force sampled every h/2; returns states every `substeps` steps."""
    m, c, k = p["m"], p["c"], p["k"]
    al, be, ga, de, nu = p["alpha"], p["beta"], p["gamma"], p["delta"], p["nu"]
    inv_m = 1.0 / m
    linear_nu = nu == 1.0

    def zdot(v, z):
        if linear_nu:
            return al * v - be * (ga * abs(v) * z + de * v * abs(z))
        az = abs(z)
        return al * v - be * (ga * abs(v) * az ** (nu - 1.0) * z + de * v * az ** nu)

    y, v, z = state0
    fl = force_fine.tolist()
    ys, vs, zs = [], [], []
    h2, h6 = 0.5 * h, h / 6.0
    for i in range(n_steps):
        if i % substeps == 0:
            ys.append(y)
            vs.append(v)
            zs.append(z)
        f0, f1, f2 = fl[2 * i], fl[2 * i + 1], fl[2 * i + 2]
        a1 = (f0 - c * v - k * y - z) * inv_m
        z1 = zdot(v, z)
        yb, vb, zb = y + h2 * v, v + h2 * a1, z + h2 * z1
        a2 = (f1 - c * vb - k * yb - zb) * inv_m
        z2 = zdot(vb, zb)
        yc, vc, zc = y + h2 * vb, v + h2 * a2, z + h2 * z2
        a3 = (f1 - c * vc - k * yc - zc) * inv_m
        z3 = zdot(vc, zc)
        yd, vd, zd = y + h * vc, v + h * a3, z + h * z3
        a4 = (f2 - c * vd - k * yd - zd) * inv_m
        z4 = zdot(vd, zd)
        y += h6 * (v + 2 * vb + 2 * vc + vd)
        v += h6 * (a1 + 2 * a2 + 2 * a3 + a4)
        z += h6 * (z1 + 2 * z2 + 2 * z3 + z4)
    return np.asarray(ys), np.asarray(vs), np.asarray(zs), (y, v, z)


def simulate(seed: int, duration_s: float = 10.0, force_rms: float = 50.0,
             noise_sd: float = 8e-6, hysteresis_scale: float = 1.0) -> RigRun:
    """Simulate one record of the hysteretic benchmark.

    seed: fixes the multisine phases and the output noise (independent streams, so records with
      different hysteresis_scale share input and noise). duration_s: record length [s] = the
      multisine period (rounded to whole samples). force_rms [N], noise_sd [m].
    Returns samples (t [s], q = measured y [m], torque = F [N]) and truth (t, q, qd [m/s],
    qdd [m/s^2], torque, z [N]).
    """
    if duration_s <= 0 or not math.isfinite(duration_s):
        raise ValueError("duration_s must be positive")
    if not math.isfinite(hysteresis_scale) or hysteresis_scale < 0:
        raise ValueError("hysteresis_scale must be >= 0")
    n = int(round(duration_s * FS_HZ))
    if n < 8:
        raise ValueError("duration_s too short")
    period = n / FS_HZ
    p = dict(PARAMS)
    p["alpha"] *= hysteresis_scale
    seeds = np.random.SeedSequence([int(seed) % (2 ** 63), 0xB0C])
    rng_in, rng_noise = (np.random.default_rng(s) for s in seeds.spawn(2))

    n_steps = n * _SUBSTEPS
    h = 1.0 / (FS_HZ * _SUBSTEPS)
    n_fine = 2 * n_steps                                   # half-step grid over one period
    f_period = _multisine(rng_in, n_fine, 2.0 / h, period, force_rms)
    f_ext = np.concatenate([f_period, f_period[:1]])       # periodic: closes the last step

    # one period of lead-in, then the recorded period (same input: periodic steady state)
    _, _, _, state = _rk4(f_ext, h, n_steps, p, (0.0, 0.0, 0.0), _SUBSTEPS)
    y, v, z, _ = _rk4(f_ext, h, n_steps, p, state, _SUBSTEPS)
    force = f_period[:: 2 * _SUBSTEPS]
    acc = (force - p["c"] * v - p["k"] * y - z) / p["m"]
    t = np.arange(n) / FS_HZ
    noise = rng_noise.standard_normal(n) * noise_sd

    samples = pd.DataFrame({"t": t, "q": y + noise, "torque": force})
    truth = pd.DataFrame({"t": t, "q": y, "qd": v, "qdd": acc, "torque": force, "z": z})
    truth.attrs["params"] = dict(p)
    meta = {
        "rig": "bouc-wen-oscillator", "source": "emulator", "sample_rate_hz": FS_HZ,
        "duration_s": period, "excitation": {"type": "random-phase multisine",
                                             "band_hz": list(BAND_HZ),
                                             "rms": float(force_rms)},
        "sensors": {"q": {"noise_sd": float(noise_sd)}},
    }
    return RigRun(samples=samples, meta=meta, truth=truth)
