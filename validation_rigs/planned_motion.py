"""Validation rig "planned-motion": the output follows a planned trajectory through a stiff
position servo, the joint torque follows from the output-side balance with LuGre dynamic
friction, and the twist from the transmission's compliance solved for the torque.

Written for scoring the gap diagnosis on a model it was never tuned on: it imports nothing of
this repository, and its structure differs from the emulator's and from the two-inertia rig's
(motion imposed, torque computed; friction with a bristle state; twist from a compliance law).

Physics (SI units):
- motion: the plan (jerk-limited start to constant speed for schemes 1 and 2, a five-harmonic
  Fourier trajectory for scheme 3) passed through the servo's tracking response, a critically
  damped second-order filter with ω = 12 rad/s;
- friction: LuGre, ż = v − σ0·|v|·z/g(v), F = σ0·z + σ1·ż + f_v·v, g(v) = f_c plus the injected
  Stribeck rise; σ0 = f_c/1e-4 rad (presliding within 0.006°), the bristle state integrated
  exactly over each 1 ms step;
- torque: T = I·q̈ + g·(mr_x·sin q + mr_y·cos q) + F + τ_L + injected torques;
- dynamometer: τ_L its set point through a second-order response (ω 8 rad/s, ζ 0.8) plus a
  bounded tracking error of two slow sines (±300 N·m);
- transmission: the twist Δ = T/k (k = 1.4e7 N·m/rad) plus the injected backlash or hysteretic
  compliance; u = q + Δ;
- gearbox temperature: first-order thermal model (C = 1.5e5 J/K, τ = 3000 s) heated by the
  friction loss, from the run's initial temperature.
Nominal values are perturbed by a few % per campaign seed.

Sensors: samples every 1/sample_rate_hz, each the average of the 1 ms values over the sample
period (an integrating DAQ); q quantised at encoder_res_deg; u from an 18-bit motor encoder / N;
qd and ud the drives' speed estimates, a first-order filter (τ 20 ms) of the motor speed;
torque with white noise, optional declared lag and dropouts (NaN = missing); torque_load with
noise; temp_joint rounded to 0.1 °C.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
import pandas as pd
from scipy import signal

N_RED = 11000.0
DT = 1e-3
T_RATED = 120e3

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exp", "gauss", "lorentz", "exp_half"),
    "temperature_friction": ("mult_both", "mult_viscous", "add_coulomb", "add_viscous"),
    "load_dependent_friction": ("coulomb", "both", "power_flow"),
    "asymmetric_friction": ("viscous", "both"),
    "gear_ripple": ("output", "load_modulated"),
    "backlash": ("sharp", "smooth", "preload"),
    "hysteresis": ("dahl", "bouc_wen_n1", "softening"),
    "torque_offset": ("constant", "drift"),
    "time_delay": ("torque",),
    "periodic_disturbance": ("sine",),
    "position_stiffness": ("quadratic",),
    "sensor_drift": ("load_gain",),
    "second_resonance": ("base",),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_stiffness",
                                      "sensor_drift", "second_resonance")


@dataclass(frozen=True)
class SensorSpec:
    sample_rate_hz: float = 100.0
    encoder_res_deg: float = 0.001
    torque_noise: float = 250.0
    load_noise: float = 100.0
    torque_lag_s: float = 0.0
    dropout_rate: float = 0.0


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


def _forms(effects: dict[str, dict]) -> dict[str, tuple[str, float]]:
    out = {}
    for name, spec in (effects or {}).items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; this rig has {sorted(EFFECT_FORMS)}")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effect {name!r} has no form {form!r}; forms: {EFFECT_FORMS[name]}")
        out[name] = (form, float(spec.get("scale", 1.0)))
    return out


def _plan(scheme: int, rpm: float | None, direction: int, rng: np.random.Generator,
          periods: int):
    """Planned output angle [rad] (relative), load set point [N·m] and phase at 1 kHz."""
    if scheme in (1, 2):
        w = direction * float(rpm) * 2 * np.pi / 60.0 / N_RED
        if scheme == 1:
            ramp = 2.5e3
            t = np.arange(0.0, 3.0 + 2 * T_RATED / ramp, DT)
            tau = np.clip(np.minimum(t - 3.0, t[-1] - t) * ramp, 0, T_RATED)
            phase = np.where(t < 3.0, "idle", np.where(t < 3.0 + T_RATED / ramp, "load", "unload"))
        else:
            levels = np.concatenate([np.arange(1, 13), np.arange(11, -1, -1)]) * 10e3
            t = np.arange(0.0, 3.0 + levels.size * 2.4, DT)
            k = np.clip(((t - 3.0) // 2.4).astype(int), 0, levels.size - 1)
            tau = np.where(t < 3.0, 0.0, levels[k])
            phase = np.where(t < 3.0, "idle", "hold")
        # jerk-limited start: speed follows a raised cosine over 1.5 s
        s = np.clip((t - 0.5) / 1.5, 0, 1)
        vel = w * 0.5 * (1 - np.cos(np.pi * s))
        return np.cumsum(vel) * DT, tau, phase
    wf = 2 * np.pi / 20.0
    a, b = rng.normal(0, 1, 5), rng.normal(0, 1, 5)
    t = np.arange(0.0, 3.0 + periods * 20.0 + 2.0, DT)
    tt = np.clip(t - 3.0, 0, periods * 20.0)
    k = np.arange(1, 6)[:, None]
    # a window that brings the trajectory in and out smoothly over the first and last 2 s
    win = np.clip(tt / 2.0, 0, 1) * np.clip((periods * 20.0 - tt) / 2.0, 0, 1)
    pos = ((a[:, None] * np.sin(k * wf * tt) + b[:, None] * (1 - np.cos(k * wf * tt)))
           / (k * wf)).sum(0) * win
    vel = np.gradient(pos, DT)
    scale = min(0.027 / np.max(np.abs(vel)), np.deg2rad(150) / np.max(np.abs(pos)))
    phase = np.where((t >= 3.0) & (t <= 3.0 + periods * 20.0), "excite", "idle")
    return direction * scale * pos, np.zeros_like(t), phase


@numba.njit(cache=True)
def _lugre(v, fc, fv, s0, s1, strib, vs, form, temp, tcoef, tform, t_ref, T_load_dep, ld, ldform,
           asym, asform):
    """Friction [N·m] along the speed v (1 kHz) with LuGre's bristle state."""
    n = v.size
    f = np.empty(n)
    z = 0.0
    for i in range(n):
        vi = v[i]
        fci, fvi = fc, fv
        if tcoef != 0.0:
            d = temp[i] - t_ref
            if tform == 1:
                m = (1.0 - 0.01 * d) ** 2
                fci, fvi = fc * (1 + (m - 1) * tcoef), fv * (1 + (m - 1) * tcoef)
            elif tform == 2:
                fvi = fv * (1 + (np.exp(-0.025 * d) - 1) * tcoef)
            elif tform == 3:
                fci = fc - 25.0 * d * tcoef
            else:
                fvi = fv - 300.0 * d * tcoef
        if ld != 0.0:
            T = abs(T_load_dep[i])
            if ldform == 1:
                fci = fci + 0.012 * T * ld
            elif ldform == 2:
                fci = fci * (1 + 0.5 * T / T_RATED * ld)
                fvi = fvi * (1 + 0.5 * T / T_RATED * ld)
            else:
                mu = 0.02 if T_load_dep[i] * vi > 0 else 0.005
                fci = fci + mu * T * ld
        if asym != 0.0 and vi > 0:
            fvi = fvi + 10000.0 * asym
            if asform == 2:
                fci = fci + 300.0 * asym
        g = max(fci, 1.0)
        if strib != 0.0:
            x = abs(vi) / vs
            if form == 1:
                c = np.exp(-x)
            elif form == 2:
                c = np.exp(-x * x)
            elif form == 3:
                c = 1.0 / (1.0 + x * x)
            else:
                c = np.exp(-np.sqrt(x))
            g += strib * c
        zss = g / s0 * (1.0 if vi > 0 else -1.0 if vi < 0 else 0.0)
        rate = s0 * abs(vi) / g
        z_new = zss + (z - zss) * np.exp(-rate * DT) if rate > 0 else z
        zd = (z_new - z) / DT
        z = z_new
        f[i] = s0 * z + s1 * zd + fvi * vi
    return f


@numba.njit(cache=True)
def _compliance(T, form, scale, k):
    """Hysteretic part of the twist [rad] along the torque T (1 kHz)."""
    n = T.size
    h = np.empty(n)
    x = 0.0
    c = 0.35 / k            # hysteretic compliance
    ty = 8e3                # torque scale of the loop
    for i in range(n):
        dT = T[i] - T[i - 1] if i > 0 else 0.0
        if form == 1:       # Dahl in torque
            x += c * dT - abs(dT) / ty * x
        elif form == 2:     # Bouc–Wen, n = 1
            x += c * dT - (0.7 * abs(dT) * x + 0.3 * dT * abs(x)) / ty
        else:               # softening: compliance falling with |T|, with a Dahl loss
            x += c * dT * (1.0 / (1.0 + abs(T[i]) / 40e3)) - abs(dT) / (2 * ty) * x
        h[i] = scale * x
    return h


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, seed: int = 0,
                 sensors: SensorSpec = SensorSpec(), periods: int = 6) -> RigRun:
    """One run of `scheme` with `effects` ({name: {"form", "scale"}}); the same seed gives the
    same rig, plan and noise whatever the effects."""
    if scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    fx = _forms(effects or {})
    camp = np.random.default_rng(seed // 10_000 if seed >= 10_000 else seed)
    jit = 1.0 + 0.04 * camp.uniform(-1, 1, 8)
    I, mrx, mry = 6685.0 * jit[0], 20.8 * jit[1], -34.5 * jit[2]
    fv, fc, k = 8683.0 * jit[3], 2353.0 * jit[4], 1.4e7 * jit[5]
    rng = np.random.default_rng(seed)
    q0 = rng.uniform(-0.4, 0.4)
    plan, tau_set, phase = _plan(scheme, motor_speed_rpm, direction,
                                 np.random.default_rng(seed // 10_000 + 3), periods)
    t = np.arange(plan.size) * DT
    # the servo's tracking response: critically damped, ω = 12 rad/s (exact discretisation)
    wn = 12.0
    sys_d = signal.cont2discrete(([wn ** 2], [1, 2 * wn, wn ** 2]), DT, method="zoh")
    q = q0 + signal.lfilter(np.ravel(sys_d[0]), sys_d[1], plan)
    v = np.gradient(q, DT)
    acc = np.gradient(v, DT)
    # dynamometer
    sys_l = signal.cont2discrete(([64.0], [1, 2 * 0.8 * 8.0, 64.0]), DT, method="zoh")
    tl = signal.lfilter(np.ravel(sys_l[0]), sys_l[1], tau_set)
    tl = tl + 200 * np.sin(2 * np.pi * t / 37.0 + rng.uniform(0, 6)) \
        + 100 * np.sin(2 * np.pi * t / 11.0 + rng.uniform(0, 6))
    grav = 9.81 * (mrx * np.sin(q) + mry * np.cos(q))
    # temperature: first-order model heated by the (nominal) friction loss
    p_loss = np.abs((fc * np.sign(v) + fv * v) * v)
    temp = temp_joint_c + signal.lfilter([DT / 1.5e5], [1, -(1 - DT / 3000.0)], p_loss)
    base_T = I * acc + grav + tl
    e = {n: fx.get(n, ("", 0.0)) for n in EFFECT_FORMS}
    codes = {n: (EFFECT_FORMS[n].index(f) + 1 if f else 0) for n, (f, _) in e.items()}
    fr = _lugre(v, fc, fv, fc / 1e-4, 2 * np.sqrt(fc / 1e-4 * I) * 0.05,
                1200.0 * e["stribeck"][1], 0.005, codes["stribeck"], temp,
                e["temperature_friction"][1], codes["temperature_friction"], 40.0,
                base_T + fc * np.sign(v), e["load_dependent_friction"][1],
                codes["load_dependent_friction"], e["asymmetric_friction"][1],
                codes["asymmetric_friction"])
    T = base_T + fr
    if "gear_ripple" in fx:
        form, s = fx["gear_ripple"]
        zq = 38.0 * q
        if form == "output":
            T += 500 * s * (np.sin(zq + 0.3) + 0.5 * np.sin(2 * zq + 1.1) + 0.25 * np.sin(3 * zq))
        else:
            T += 500 * s * (0.4 + 0.8 * np.abs(T) / T_RATED) * np.sin(zq)
    if "periodic_disturbance" in fx:
        T += 600 * fx["periodic_disturbance"][1] * np.sin(2 * np.pi * 1.7 * t)
    if "position_stiffness" in fx:
        dq = q - q0
        T += 2500 * fx["position_stiffness"][1] * dq * np.abs(dq)
    if "second_resonance" in fx:   # the rig's base ringing at 2.2 Hz, excited by the motion
        sys_r = signal.cont2discrete(([1.0], [1, 2 * 0.02 * 13.8, 13.8 ** 2]), DT, method="zoh")
        T += 400 * fx["second_resonance"][1] * signal.lfilter(np.ravel(sys_r[0]), sys_r[1],
                                                               acc * 1e4)
    twist = T / k
    if "backlash" in fx:
        form, s = fx["backlash"]
        b = 9e-4 * s
        if form == "sharp":
            twist += b * np.clip(T / 300.0, -1, 1)
        elif form == "smooth":
            twist += b * np.tanh(T / 3000.0)
        else:
            twist += b * np.clip(T / 300.0, -1, 1) / (1 + np.abs(T) / 30e3)
    if "hysteresis" in fx:
        form, s = fx["hysteresis"]
        twist += _compliance(T, codes["hysteresis"], s, k)
    u = q + twist
    ud = np.gradient(u, DT)
    # sensors: integrating DAQ over each sample period
    m = max(1, int(round(1.0 / (sensors.sample_rate_hz * DT))))
    n = t.size // m

    def avg(x):
        return x[:n * m].reshape(n, m).mean(axis=1)
    noise = np.random.default_rng(seed + 11)
    res_q = np.deg2rad(sensors.encoder_res_deg)
    res_u = 2 * np.pi / 2 ** 18 / N_RED
    lag = sensors.torque_lag_s + (0.03 * fx["time_delay"][1] if "time_delay" in fx else 0.0)
    Tm = np.interp(t - lag, t, T)
    if "torque_offset" in fx:
        form, s = fx["torque_offset"]
        Tm = Tm + (600.0 * s if form == "constant" else 4.0 * s * t)
    tlm = tl.copy()
    if "sensor_drift" in fx:
        tlm = tlm * (1 + 0.04 * fx["sensor_drift"][1] * t / t[-1])
    alpha = DT / 0.02
    speed = signal.lfilter([alpha], [1, alpha - 1], ud)
    ts = avg(t)
    q_s = np.round(avg(q) / res_q) * res_q
    u_s = np.round(avg(u) / res_u) * res_u
    sp = avg(speed) + noise.normal(0, 3e-6, n)
    tq = avg(Tm) + noise.normal(0, sensors.torque_noise, n)
    if sensors.dropout_rate > 0:
        tq[noise.uniform(size=n) < sensors.dropout_rate] = np.nan
    samples = pd.DataFrame({"t": ts - ts[0], "q": q_s, "qd": sp, "u": u_s, "ud": sp,
                            "torsion": q_s - u_s, "torque": tq,
                            "torque_load": avg(tlm) + noise.normal(0, sensors.load_noise, n),
                            "temp_joint": np.round(avg(temp), 1),
                            "phase": phase[:n * m:m]})
    meta = {"scheme": scheme, "motor_speed_rpm": motor_speed_rpm if scheme != 3 else None,
            "direction": direction, "reduction": N_RED, "rig": "validation-rig-planned-motion",
            "source": "emulator", "sample_rate_hz": sensors.sample_rate_hz,
            "sensors": {"q": {"resolution": res_q}, "u": {"resolution": res_u},
                        "torque": {"noise_sd": sensors.torque_noise,
                                   "lag_s": sensors.torque_lag_s},
                        "torque_load": {"noise_sd": sensors.load_noise}}}
    truth = pd.DataFrame({"t": ts - ts[0], "q": avg(q), "qd": avg(v), "u": avg(u),
                          "torque": avg(T), "torque_load": avg(tl), "twist": avg(twist)})
    return RigRun(samples=samples, meta=meta, truth=truth)
