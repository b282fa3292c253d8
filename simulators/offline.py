"""Run a whole scheme through the kernel in one call: `simulate(scheme_params, config) -> RunData`.

The scheme's set-point profiles (core.schemes) are sampled at the internal rate (1 kHz) into
arrays, the kernel advances the joint over the whole run recording true values only at the sample
instants, and the sensor models (simulators.sensors) turn those into the run-format channels.
"""

from __future__ import annotations

import math
from datetime import datetime, timezone
from typing import Any

import numpy as np
import pandas as pd

from core.params import N_MOTORS
from core.run import RunData
from simulators import kernel as K
from simulators.config import EmulatorConfig
from simulators.model import setup
from simulators.sensors import SENSED, sense, sensor_meta

OFFLINE_CHANNELS = tuple(c for c in SENSED if c != "qdd") + ("phase",)
"""Columns of an offline run (qdd is left for the consumer to derive, as run-format says)."""


def profiles(scheme: Any, dt: float, cyl_area: float) -> dict[str, Any]:
    """The scheme's set points sampled at every internal step: arrays of length n_steps."""
    n_steps = int(round(scheme.duration() / dt)) + 1
    t = np.arange(n_steps) * dt
    w = np.asarray(scheme.motor_speed(t), dtype=float)
    ref = scheme.position_ref(t)
    return {
        "t": t,
        "w_set": np.repeat(w[:, None], N_MOTORS, axis=1),
        "pos_ref": np.zeros(1) if ref is None else np.ascontiguousarray(ref[0], dtype=float),
        "pos_on": 0 if ref is None else 1,
        "tau_cmd": np.asarray(scheme.dyno_torque(t), dtype=float),
        "p_set": np.asarray(scheme.pressure_setpoint(t, cyl_area), dtype=float),
        "pump": np.asarray(scheme.pump_on(t), dtype=float),
    }


def sample_steps(duration: float, dt: float, rate_hz: float) -> np.ndarray:
    """Internal step index of each sample: the step nearest to j/rate_hz, for every sample time
    inside the run (strictly increasing)."""
    n = int(math.floor(duration * rate_hz + 1e-9)) + 1
    steps = np.round(np.arange(n) / rate_hz / dt).astype(np.int64)
    return np.unique(steps)


def simulate_records(scheme: Any, config: EmulatorConfig | None = None
                     ) -> tuple[np.ndarray, dict[str, np.ndarray], dict[str, Any]]:
    """Run the scheme; return (true records (n, kernel.N_R), sensor channels, profiles).
    For tests and diagnostics that need the truth next to the measurement."""
    cfg = config or EmulatorConfig()
    rng = np.random.Generator(np.random.PCG64(cfg.seed))
    kp_pos = float(getattr(scheme, "position_gain", 0.0))
    ks = setup(cfg, rng, kp_pos=kp_pos)
    prof = profiles(scheme, cfg.dt, cfg.params.cyl_area)
    n_steps = len(prof["t"])
    rate = cfg.sample_rate_hz or scheme.sample_rate_hz
    steps = sample_steps((n_steps - 1) * cfg.dt, cfg.dt, rate)
    rec = np.zeros((len(steps), K.N_R))
    n_rec = K.advance(ks.state, ks.pf, ks.n_bw, ks.ring, prof["w_set"], prof["pos_ref"],
                      prof["pos_on"], prof["tau_cmd"], prof["p_set"], prof["pump"], ks.enabled,
                      ks.fail_step, ks.tau_lim, steps, rec, 0, n_steps)
    if n_rec != len(steps):
        raise RuntimeError(f"kernel recorded {n_rec} of {len(steps)} samples")
    channels = sense(rec, cfg, rng)
    return rec, channels, prof


def simulate(scheme: Any, config: EmulatorConfig | None = None, *, started_at: str | None = None,
             notes: str = "") -> RunData:
    """Simulate one scheme (core.schemes.Scheme1/2/3) on the emulated joint and return the run
    in the interchange format's columns (core.channels) with its metadata (run-format.md plus
    "emulator": seed, effects, hysteresis, non-default parameters)."""
    cfg = config or EmulatorConfig()
    rec, ch, _ = simulate_records(scheme, cfg)
    df = pd.DataFrame({name: ch[name] for name in OFFLINE_CHANNELS if name != "phase"})
    df["phase"] = scheme.phase(df["t"].to_numpy())
    meta = scheme.meta()
    meta.update({
        "rig": "J4-emulator",
        "source": "emulator",
        "sample_rate_hz": float(cfg.sample_rate_hz or scheme.sample_rate_hz),
        "started_at": started_at or datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "notes": notes,
        "emulator": cfg.describe(),
        "sensors": sensor_meta(cfg),
    })
    return RunData(samples=df, meta=meta)
