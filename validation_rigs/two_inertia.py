"""Validation rig "two-inertia": the J4 joint as two inertias joined by a compliant transmission,
integrated by semi-implicit Euler at 4 kHz, with Karnopp stiction on the output bearing.

Written for scoring the gap diagnosis on a model it was never tuned on: it imports nothing of
this repository and shares no functional form with the emulator beyond the rigid-body balance
every model of the joint has.

Physics (SI units; q output angle, u motor angle referred to the output, Δ = u − q):
- motor side, referred to the output: J·ü = τ_m − T − b_m·u̇, J = 3.6e6 kg·m² (three motors'
  rotors through the 11 000:1 reduction); τ_m from a PI speed loop tracking the scheme's speed
  (scheme 3: plus a position loop on u), saturating at ±200 kN·m;
- transmission: T = k·Δ_e + d·Δ̇ (+ the hysteretic deviation s·k_h·(z − Δ)), k = 1.375e7 N·m/rad
  (0.5° at 120 kN·m), d = 1.2e5 N·m·s/rad, Δ_e the twist through a dead zone when backlash is on;
- output: I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − F + D_ext, I = 6685 kg·m²; F the
  bearing friction: Karnopp stiction — inside |q̇| < 2e-5 rad/s the joint sticks while the net
  torque stays below the break-away level 1.2·f_c — else f_c·sgn q̇ + f_v·q̇ plus the injected
  friction effects;
- dynamometer: τ_L follows its set point with a 0.15 s lag plus a slow ±250 N·m wander;
- gearbox temperature: the run's initial value, warmed by the friction loss (C = 2e5 J/K).
The nominal values are perturbed by a few % per campaign seed (a real rig is not at its
catalogue values), the same for every run of a seed.

Sensors (SensorSpec): samples are taken every 1/sample_rate_hz (point sampling, as a DAQ reads a
PLC data block); q from an output encoder quantised at encoder_res_deg; u from a 2^20-count motor
encoder / N; the drive's speeds qd, ud: the motor speed referred to the output (what an S120
reports) with 2e-6 rad/s noise — so qd is u̇, not q̇; torque from a strain gauge with white noise
torque_noise and an optional declared lag torque_lag_s; torque_load with load_noise; temp_joint
rounded to 0.1 °C; torsion = q − u of the two readings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
import pandas as pd

N_RED = 11000.0
G = 9.81
DT = 1.0 / 4000.0
T_RATED = 120e3

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exp", "gauss", "lorentz"),
    "temperature_friction": ("mult_both", "mult_viscous", "add_coulomb", "add_viscous"),
    "load_dependent_friction": ("coulomb", "both"),
    "asymmetric_friction": ("viscous", "both"),
    "gear_ripple": ("harmonics", "load_modulated"),
    "backlash": ("sharp", "smooth"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl"),
    "torque_offset": ("constant", "drift"),
    "time_delay": ("torque",),
    "periodic_disturbance": ("sine",),
    "position_stiffness": ("cubic",),
    "sensor_drift": ("load_gain",),
    "second_resonance": ("shaft",),
}
"""Every effect this rig can inject, with its forms."""

OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_stiffness",
                                      "sensor_drift", "second_resonance")


@dataclass(frozen=True)
class SensorSpec:
    sample_rate_hz: float = 20.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0
    load_noise: float = 100.0
    torque_lag_s: float = 0.0


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


# --- effect parameter vector ---------------------------------------------------------------------
(E_STR, E_STR_VS, E_STR_FORM, E_TMP, E_TMP_FORM, E_LD, E_LD_FORM, E_AS, E_AS_FORM, E_RIP,
 E_RIP_FORM, E_BL, E_BL_FORM, E_HY, E_HY_FORM, E_PER, E_POS, E_RES, N_E) = range(19)
(P_I, P_MRX, P_MRY, P_FV, P_FC, P_K, P_D, P_J, P_BM, P_KP, P_KI, P_KPOS, P_TREF, P_Q0, N_P) = \
    range(15)


def _effect_vector(effects: dict[str, dict]) -> tuple[np.ndarray, dict]:
    """The kernel's effect parameters and the sensor-side ones, from {name: {form, scale}}."""
    e = np.zeros(N_E)
    post: dict = {}
    for name, spec in (effects or {}).items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; this rig has {sorted(EFFECT_FORMS)}")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effect {name!r} has no form {form!r}; forms: {EFFECT_FORMS[name]}")
        s = float(spec.get("scale", 1.0))
        code = EFFECT_FORMS[name].index(form) + 1
        if name == "stribeck":
            e[E_STR], e[E_STR_VS], e[E_STR_FORM] = 1500.0 * s, 0.004, code
        elif name == "temperature_friction":
            e[E_TMP], e[E_TMP_FORM] = s, code
        elif name == "load_dependent_friction":
            e[E_LD], e[E_LD_FORM] = s, code
        elif name == "asymmetric_friction":
            e[E_AS], e[E_AS_FORM] = s, code
        elif name == "gear_ripple":
            e[E_RIP], e[E_RIP_FORM] = 600.0 * s, code
        elif name == "backlash":
            e[E_BL], e[E_BL_FORM] = 8.7e-4 * s, code
        elif name == "hysteresis":
            e[E_HY], e[E_HY_FORM] = s, code
        elif name == "periodic_disturbance":
            e[E_PER] = 700.0 * s
        elif name == "position_stiffness":
            e[E_POS] = 1500.0 * s
        elif name == "second_resonance":
            e[E_RES] = s
        else:                                   # sensor-side effects
            post[name] = (form, s)
    return e, post


@numba.njit(cache=True)
def _friction(v, T, temp, p, e):
    """Sliding friction of the output bearing [N·m] at speed v, torque T, temperature temp."""
    sg = 1.0 if v > 0 else -1.0
    fc, fv = p[P_FC], p[P_FV]
    f = fc * sg + fv * v
    if e[E_STR] != 0.0:
        x = abs(v) / e[E_STR_VS]
        if e[E_STR_FORM] == 1:
            c = np.exp(-x)
        elif e[E_STR_FORM] == 2:
            c = np.exp(-x * x)
        else:
            c = 1.0 / (1.0 + x * x)
        f += e[E_STR] * c * sg
    if e[E_TMP] != 0.0:
        dT = temp - p[P_TREF]
        form = e[E_TMP_FORM]
        if form == 1:
            f += (fc * sg + fv * v) * (np.exp(-0.012 * dT) - 1.0) * e[E_TMP]
        elif form == 2:
            f += fv * v * (np.exp(-0.03 * dT) - 1.0) * e[E_TMP]
        elif form == 3:
            f += -30.0 * dT * sg * e[E_TMP]
        else:
            f += -350.0 * dT * v * e[E_TMP]
    if e[E_LD] != 0.0:
        if e[E_LD_FORM] == 1:
            f += 0.015 * abs(T) * sg * e[E_LD]
        else:
            f += (fc * sg + fv * v) * 0.6 * abs(T) / T_RATED * e[E_LD]
    if e[E_AS] != 0.0 and v > 0:
        f += 12000.0 * v * e[E_AS]
        if e[E_AS_FORM] == 2:
            f += 400.0 * e[E_AS]
    return f


@numba.njit(cache=True)
def _simulate(p, e, w_ref, q_ref, use_pos, tau_set, temp0, seed, rec_every):
    n = w_ref.size
    np.random.seed(seed)
    nrec = n // rec_every
    out = np.empty((nrec, 8))
    tq_full = np.empty(n)
    q = p[P_Q0]
    qd = 0.0
    u = q + 0.0
    ud = 0.0
    integ = 0.0
    tl = 0.0
    z = 0.0
    temp = temp0
    q2 = q
    qd2 = 0.0
    wander = 0.0
    stuck = True
    k, d, I = p[P_K], p[P_D], p[P_I]
    kh = 0.3 * k
    yld = 8.7e-4
    j2 = 300.0 * e[E_RES]
    k2 = j2 * (2 * np.pi * 3.0) ** 2
    c2 = 2 * 0.03 * np.sqrt(k2 * j2) if j2 > 0 else 0.0
    r = 0
    for i in range(n):
        t = i * DT
        # dynamometer with lag and a slow wander
        wander += DT * (-wander / 20.0) + np.sqrt(DT) * 40.0 * np.random.randn()
        tl += DT / 0.15 * (tau_set[i] + wander - tl)
        # transmission
        dl = u - q
        dld = ud - qd
        de = dl
        if e[E_BL] > 0.0:
            b = e[E_BL]
            a = abs(dl) - b
            sg = 1.0 if dl > 0 else -1.0
            if e[E_BL_FORM] == 1:
                de = sg * a if a > 0 else 0.0
            else:
                w = 0.25 * b
                x = a / w
                de = sg * w * (x if x > 30 else np.log1p(np.exp(x)))
        T = k * de + d * dld
        if e[E_HY] != 0.0:
            form = e[E_HY_FORM]
            if form == 1:
                zd = dld - 0.6 / yld * abs(dld) * z - 0.4 / yld * dld * abs(z)
            elif form == 2:
                zd = dld - (0.6 * abs(dld) * z * abs(z) + 0.4 * dld * z * z) / (yld * yld)
            else:
                zd = dld - abs(dld) * z / yld
            z += DT * zd
            T += e[E_HY] * kh * (z - dl)
        # motor side: PI speed loop (+ position loop on u for scheme 3)
        wc = w_ref[i]
        if use_pos:
            wc += 3.0 * (q_ref[i] - u)
        err = wc - ud
        tm = p[P_KP] * err + integ + p[P_KI] * err * DT
        if tm > 2e5:            # torque limit, with the integrator held (anti-windup)
            tm = 2e5
        elif tm < -2e5:
            tm = -2e5
        else:
            integ += p[P_KI] * err * DT
        ud += DT * (tm - T - p[P_BM] * ud) / p[P_J]
        u += DT * ud
        # output side
        grav = G * (p[P_MRX] * np.sin(q) + p[P_MRY] * np.cos(q))
        ext = T - tl - grav
        if e[E_RIP] != 0.0:
            zq = 40.0 * q
            if e[E_RIP_FORM] == 1:
                ext -= e[E_RIP] * (np.sin(zq) + 0.4 * np.sin(2.0 * zq + 0.7))
            else:
                ext -= e[E_RIP] * (0.3 + abs(T) / T_RATED) * np.sin(zq)
        if e[E_PER] != 0.0:
            ext -= e[E_PER] * np.sin(2 * np.pi * 0.8 * t)
        if e[E_POS] != 0.0:
            dq = q - p[P_Q0]
            ext -= e[E_POS] * dq * dq * dq
        if j2 > 0.0:
            fr = k2 * (q - q2) + c2 * (qd - qd2)
            ext -= fr
            qd2 += DT * fr / j2
            q2 += DT * qd2
        fstat = 1.2 * p[P_FC]
        if stuck or abs(qd) < 2e-5:
            if abs(ext) <= fstat:
                qd = 0.0
                stuck = True
                f = ext
            else:
                stuck = False
                f = fstat * (1.0 if ext > 0 else -1.0)
                qd += DT * (ext - f) / I
        else:
            f = _friction(qd, T, temp, p, e)
            qn = qd + DT * (ext - f) / I
            if qn * qd < 0:       # a reversal within the step: stop there
                qn = 0.0
                stuck = True
            qd = qn
        q += DT * qd
        temp += DT * (abs(f * qd) / 2e5 - (temp - temp0) / 5000.0)
        tq_full[i] = T
        if i % rec_every == 0 and r < nrec:
            out[r, 0] = t
            out[r, 1] = q
            out[r, 2] = qd
            out[r, 3] = u
            out[r, 4] = ud
            out[r, 5] = T
            out[r, 6] = tl
            out[r, 7] = temp
            r += 1
    return out[:r], tq_full


# --- schemes ---------------------------------------------------------------------------------

def _profiles(scheme: int, rpm: float | None, direction: int, rng: np.random.Generator,
              periods: int):
    """(ω_ref, q_ref, uses position loop, τ_set, phase labels) at the internal rate."""
    if scheme in (1, 2):
        w = direction * float(rpm) * 2 * np.pi / 60.0 / N_RED
        if scheme == 1:
            t_end = 2.0 + 2 * T_RATED / 2.4e3
            t = np.arange(0, t_end, DT)
            tau = np.clip(np.minimum(t - 2.0, t_end - t) * 2.4e3, 0, T_RATED)
            phase = np.where(t < 2.0, "idle", np.where(t < 2.0 + T_RATED / 2.4e3, "load",
                                                       "unload"))
        else:
            levels = np.concatenate([np.arange(1, 13), np.arange(11, -1, -1)]) * 10e3
            t_end = 2.0 + levels.size * 2.5
            t = np.arange(0, t_end, DT)
            idx = np.clip(((t - 2.0) // 2.5).astype(int), 0, levels.size - 1)
            target = np.where(t < 2.0, 0.0, levels[idx])
            frac = np.clip(((t - 2.0) % 2.5) / 0.5, 0, 1)
            prev = np.where(idx > 0, levels[np.maximum(idx - 1, 0)], 0.0)
            tau = np.where(t < 2.0, 0.0, prev + (target - prev) * frac)
            phase = np.where(t < 2.0, "idle", np.where(frac < 1, "load", "hold"))
        w_ref = w * np.clip(t / 1.0, 0, 1)
        return w_ref, np.zeros_like(t), False, tau, phase
    # scheme 3: fifth-order Fourier trajectory, 20 s period
    wf = 2 * np.pi / 20.0
    a, b = rng.normal(0, 1, 5), rng.normal(0, 1, 5)
    t = np.arange(0, 2.0 + periods * 20.0 + 2.0, DT)
    tt = np.clip(t - 2.0, 0, periods * 20.0)
    kk = np.arange(1, 6)[:, None]
    vel = (a[:, None] * np.cos(kk * wf * tt) + b[:, None] * np.sin(kk * wf * tt)).sum(0)
    pos = (a[:, None] / (kk * wf) * np.sin(kk * wf * tt)
           - b[:, None] / (kk * wf) * np.cos(kk * wf * tt)).sum(0)
    pos -= pos[0]
    scale = min(0.028 / np.max(np.abs(vel)), np.deg2rad(150) / max(np.max(np.abs(pos)), 1e-9))
    vel, pos = direction * vel * scale, direction * pos * scale
    vel[(t < 2.0) | (t > 2.0 + periods * 20.0)] = 0.0
    # the drive reaches the trajectory's first speed along a 1 s ramp, then follows it
    ramp = np.clip(t - 1.0, 0.0, 1.0)
    start = (t < 2.0)
    vel[start] = ramp[start] * vel[np.searchsorted(t, 2.0)]
    pos = pos + np.cumsum(np.where(start, vel, 0.0)) * DT
    pos[~start] += 0.0
    phase = np.where((t >= 2.0) & (t <= 2.0 + periods * 20.0), "excite", "idle")
    return vel, pos, True, np.zeros_like(t), phase


def _params(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed // 10_000 if seed >= 10_000 else seed)
    p = np.zeros(N_P)
    jit = 1.0 + 0.04 * rng.uniform(-1, 1, N_P)
    p[P_I], p[P_MRX], p[P_MRY] = 6685.0 * jit[0], 20.8 * jit[1], -34.5 * jit[2]
    p[P_FV], p[P_FC] = 8683.0 * jit[3], 2353.0 * jit[4]
    p[P_K], p[P_D] = 1.375e7 * jit[5], 1.2e5
    p[P_J], p[P_BM] = 3.6e6, 2.0e4
    p[P_KP], p[P_KI] = 3.6e6 * 20.0, 3.6e6 * 20.0 * 5.0
    p[P_KPOS], p[P_TREF] = 3.0, 40.0
    return p


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, seed: int = 0,
                 sensors: SensorSpec = SensorSpec(), periods: int = 6) -> RigRun:
    """One run of `scheme` on this rig with `effects` ({name: {"form", "scale"}}) injected;
    the same seed gives the same rig, trajectory and noise whatever the effects."""
    if scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    e, post = _effect_vector(effects or {})
    p = _params(seed)
    rng = np.random.default_rng(seed)
    p[P_Q0] = rng.uniform(-0.3, 0.3)
    w_ref, q_ref, use_pos, tau, phase = _profiles(scheme, motor_speed_rpm, direction,
                                                  np.random.default_rng(seed // 10_000 + 7),
                                                  periods)
    q_ref = q_ref + p[P_Q0]
    every = max(1, int(round(1.0 / (sensors.sample_rate_hz * DT))))
    rec, tq_full = _simulate(p, e, w_ref, q_ref, use_pos, tau, float(temp_joint_c),
                             int(seed % (2 ** 31)), every)
    t, q, qd, u, ud, T, tl, temp = rec.T
    idx = np.arange(t.size) * every
    noise = np.random.default_rng(seed + 1)
    res_q = np.deg2rad(sensors.encoder_res_deg)
    res_u = 2 * np.pi / 2 ** 20 / N_RED
    q_m = np.round(q / res_q) * res_q
    u_m = np.round(u / res_u) * res_u
    speed = ud + noise.normal(0, 2e-6, t.size)
    lag = sensors.torque_lag_s
    if "time_delay" in post:
        lag += 0.04 * post["time_delay"][1]
    tq = tq_full[np.clip(idx - int(round(lag / DT)), 0, None)]
    tq = tq + noise.normal(0, sensors.torque_noise, t.size)
    tl_m = tl + noise.normal(0, sensors.load_noise, t.size)
    if "torque_offset" in post:
        form, s = post["torque_offset"]
        tq = tq + (800.0 * s if form == "constant" else 1500.0 * s * (1 - np.exp(-t / 60.0)))
    if "sensor_drift" in post:
        tl_m = tl_m * (1.0 + 0.03 * post["sensor_drift"][1] * np.sin(np.pi * t / t[-1]))
    samples = pd.DataFrame({
        "t": t, "q": q_m, "qd": speed, "u": u_m, "ud": speed, "torsion": q_m - u_m,
        "torque": tq, "torque_load": tl_m, "temp_joint": np.round(temp, 1),
        "phase": phase[idx]})
    meta = {"scheme": scheme, "motor_speed_rpm": motor_speed_rpm if scheme != 3 else None,
            "direction": direction, "reduction": N_RED, "rig": "validation-rig-two-inertia",
            "source": "emulator", "sample_rate_hz": sensors.sample_rate_hz,
            "sensors": {"q": {"resolution": res_q}, "u": {"resolution": res_u},
                        "torque": {"noise_sd": sensors.torque_noise,
                                   "lag_s": sensors.torque_lag_s},
                        "torque_load": {"noise_sd": sensors.load_noise}}}
    truth = pd.DataFrame({"t": t, "q": q, "qd": qd, "u": u, "torque": T, "torque_load": tl,
                          "twist": u - q})
    return RigRun(samples=samples, meta=meta, truth=truth)
