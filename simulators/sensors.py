"""Sensor models: from the kernel's true values at the sample instants to what the rig's sensors
read (channels of core.channels, units of run-format.md). All randomness comes from the run's
numpy.random.Generator(PCG64(seed)), drawn here outside the kernel in a fixed order, so one seed
reproduces a run bit for bit and a sensor-only effect (torque_offset, time_delay) leaves every
other channel bit-identical.

What each channel models (σ values from core.params.JointParams):
- q: output encoder, rounded to its 0.01° resolution (enc_res).
- qd: the output velocity as the drives' observer estimates it — true q̇ plus white noise
  (speed_noise). Differencing the 0.01° output encoder directly would give 0.17 rad/s steps at
  1 kHz; the observer instead follows the fine motor encoders and corrects for the twist.
- qdd (live reads only): that velocity estimate differenced over ACCEL_WINDOW, i.e. true q̈ plus
  white noise √2·speed_noise/ACCEL_WINDOW. Offline runs leave qdd out (run-format derives it).
- u: motor encoder (motor_enc_counts per motor revolution) divided by N; ud = u̇ + speed_noise;
  w_m1..3: each motor's speed, N·u̇ (0 for a failed, braked motor) + N·speed_noise.
- torsion: q − u of the two encoder readings (run-format's definition).
- torque: strain gauges — transmitted torque (time_delay: as it was `delay` earlier, from the
  kernel's ring buffer) + torque_noise + torque_offset(t) when injected.
- torque_load: dynamometer transducer, actual dyno torque + load_noise; torque_cmd: the set point.
- i_m1..3 (+current_noise), temp_m1..3, temp_joint (+temp_noise), p_hyd (+pressure_noise),
  f_shear = p·A, m_bend = p·A·arm (+force_noise in N resp. N·m).
- dropouts: each numeric sample except t is missing (NaN) with probability config.dropout.
"""

from __future__ import annotations

import math

import numpy as np

from core.channels import NUMERIC_CHANNELS
from core.effects import torque_offset
from core.params import N_MOTORS
from simulators import kernel as K
from simulators.config import EmulatorConfig

ACCEL_WINDOW = 0.01
"""Differencing window [s] of the live qdd estimate (design: 10 samples of the 1 kHz observer)."""

SENSED = NUMERIC_CHANNELS
"""Channels the sensor model produces, in core.channels order (qdd only for live reads)."""

_NOISY = ("qd", "qdd", "ud", "torque", "torque_load", "i_m1", "i_m2", "i_m3", "w_m1", "w_m2",
          "w_m3", "temp_m1", "temp_m2", "temp_m3", "temp_joint", "p_hyd", "m_bend", "f_shear")
"""Channels with additive white noise, in the fixed order of the generator's draws."""


def noise_sigmas(config: EmulatorConfig) -> dict[str, float]:
    """1σ of each noisy channel, in its unit."""
    p = config.params
    s = {"qd": p.speed_noise, "qdd": math.sqrt(2.0) * p.speed_noise / ACCEL_WINDOW,
         "ud": p.speed_noise, "torque": p.torque_noise, "torque_load": p.load_noise,
         "temp_joint": p.temp_noise, "p_hyd": p.pressure_noise, "m_bend": p.force_noise,
         "f_shear": p.force_noise}
    for k in range(1, N_MOTORS + 1):
        s[f"i_m{k}"] = p.current_noise
        s[f"w_m{k}"] = p.N * p.speed_noise
        s[f"temp_m{k}"] = p.temp_noise
    return s


def sensor_meta(config: EmulatorConfig) -> dict[str, dict[str, float]]:
    """The run format's `sensors` metadata of the emulated sensors: encoder steps [rad] and
    noise levels in each channel's unit."""
    p = config.params
    return {"q": {"resolution": float(p.enc_res)},
            "u": {"resolution": float(motor_encoder_step(config) / p.N)},
            "torque": {"noise_sd": float(p.torque_noise)},
            "torque_load": {"noise_sd": float(p.load_noise)}}


def motor_encoder_step(config: EmulatorConfig) -> float:
    """Resolution of a motor encoder at the motor shaft [rad/count]."""
    return 2.0 * math.pi / config.params.motor_enc_counts


def sense(rec: np.ndarray, config: EmulatorConfig, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Sensor readings for the record rows `rec` (shape (n, kernel.N_R)): {channel: array (n,)}
    for every channel of SENSED."""
    p = config.params
    n = rec.shape[0]
    sig = noise_sigmas(config)
    z = rng.standard_normal((n, len(_NOISY)))
    noise = {name: sig[name] * z[:, i] for i, name in enumerate(_NOISY)}

    t = rec[:, K.R_T].copy()
    q = np.round(rec[:, K.R_Q] / p.enc_res) * p.enc_res
    res_u = motor_encoder_step(config) / p.N
    u = np.round(rec[:, K.R_U] / res_u) * res_u
    torque = rec[:, K.R_TQ_SG] + noise["torque"]
    if "torque_offset" in config.effects:
        e = config.effects["torque_offset"]
        torque = torque + torque_offset(t, e["c0"], e["drift"])
    force = p.cyl_area * rec[:, K.R_P]
    out = {
        "t": t,
        "q": q,
        "qd": rec[:, K.R_QD] + noise["qd"],
        "qdd": rec[:, K.R_QDD] + noise["qdd"],
        "u": u,
        "ud": rec[:, K.R_UD] + noise["ud"],
        "torsion": q - u,
        "torque": torque,
        "torque_load": rec[:, K.R_TAUL] + noise["torque_load"],
        "torque_cmd": rec[:, K.R_TAUCMD].copy(),
    }
    for k in range(N_MOTORS):
        out[f"i_m{k + 1}"] = rec[:, K.R_I + k] + noise[f"i_m{k + 1}"]
    for k in range(N_MOTORS):
        out[f"w_m{k + 1}"] = rec[:, K.R_W + k] + noise[f"w_m{k + 1}"]
    for k in range(N_MOTORS):
        out[f"temp_m{k + 1}"] = rec[:, K.R_TW + k] + noise[f"temp_m{k + 1}"]
    out["temp_joint"] = rec[:, K.R_TJ] + noise["temp_joint"]
    out["p_hyd"] = rec[:, K.R_P] + noise["p_hyd"]
    out["m_bend"] = force * p.arm_bend + noise["m_bend"]
    out["f_shear"] = force + noise["f_shear"]
    if config.dropout > 0.0:
        names = [c for c in SENSED if c != "t"]
        lost = rng.random((n, len(names))) < config.dropout
        for i, name in enumerate(names):
            col = out[name]
            col[lost[:, i]] = np.nan
        out["torsion"][np.isnan(out["q"]) | np.isnan(out["u"])] = np.nan
    return out
