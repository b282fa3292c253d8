"""Validation rig "B": an independently written, trajectory-driven model of the J4 joint test rig.

Why: the repository's sim-to-real diagnosis is tuned on the repository's own emulator. To score
it honestly it must also be run on rig models written without its code. This module imports only
numpy, scipy and pandas (plus the standard library) and shares nothing with the repository.

How model B differs from a "two-inertia + PI speed loop + Euler" emulator: here the output MOTION
is the input. A planner produces the output angle q_p(t) (cycloidal, jerk-limited velocity
profiles for schemes 1-2, a 5th-order Fourier trajectory for scheme 3); a stiff position servo
(PID with velocity/acceleration feed-forward, closed-loop poles at -w_s triple, w_s = 2*pi*3 Hz)
tracks it, and its tracking error is the response of the error dynamics

    I_s*(e''' + 3*w_s*e'' + 3*w_s^2*e' + w_s^3*e) = -d'(t)      (e = q - q_p)

(I_s = I + the motors' inertia reflected through N, ~2.2e5 kg*m^2) to the torque d(t) that the
feed-forward (nominal I*q_p'' + f_v*q_p') does not cover (friction, load, gravity, ripple...). It
is solved exactly (ZOH) with scipy.signal.lfilter, giving e, e', e'' consistently. The joint
torque T then FOLLOWS from the output-side balance (rig.md's Eq. 4 with the load):

    T = I*q'' + g*(mr_x*sin q + mr_y*cos q) + F_f + tau_ext              [N*m]

where F_f is a LuGre dynamic friction (bristle state, presliding at reversals):

    z' = v - sigma0*|v|*z/L(v, t),   F_f = sigma0*z + sigma1*z' + f_v(t)*v,
    L = Coulomb level (+ Stribeck, temperature, load, direction terms when injected),
    sigma0 = f_c / 4e-5 rad (presliding displacement 40 urad), sigma1 = 0.3*f_v,

stepped with the exact exponential solution for piecewise-constant v (a plain loop over the
internal grid: the only recursion in the nominal model). The twist Delta = u - q then follows
from the transmission law SOLVED FOR Delta given T:

    nominal:      D*Delta' + k*Delta = T  (backward Euler, lfilter),  k = 120 kN*m / 0.5 deg,
                  D = k * 2 ms,
    hysteresis:   T = T_el(Delta) + k_h*x + D*Delta' with a hysteretic state x (loop, one
                  piecewise-linear solve per step),
    backlash:     Delta += c, c the position inside the gap,

and u = q + Delta. The joint temperature follows a first-order thermal model driven by the
friction power |F_f*v| and a copper-loss term P_cu*(T/120 kN*m)^2.

Internal step: the sample period divided by ceil(1000 Hz / f_s), i.e. 1-2 kHz, so every sample
time is an internal grid point. Where friction depends on T or on temperature the balance is
closed by fixed-point passes (3 passes; the change of the last pass is far below 1 N*m).

Effects (s = the effect's "scale"; every magnitude is linear in s; defaults at s = 1; k, f_c,
f_v are the campaign's stiffness and friction; w_top = 3000 r/min at the output = 0.0286 rad/s):
  stribeck            L += s*0.9*f_c*S(|v|/v_s), v_s = 0.08*w_top; S = exp(-r) ("exp"),
                      exp(-r^2) ("gauss"), 1/(1+r^2) ("lorentz"), exp(-sqrt r) ("exp_half").
  temperature_friction  dT = T_joint - 30 degC: "mult_both" f_c*(1+s*(exp(-0.015 dT)-1)),
                      f_v*(1+s*(exp(-0.04 dT)-1)); "mult_viscous" f_v*(1+s*(p-1)),
                      p = max(1-0.05 dT+8e-4 dT^2, 0.2); "add_coulomb" f_c - s*100*dT;
                      "add_viscous" f_v - s*1500*dT.  T_joint: C*dT/dt = P - (T-T_amb)/R,
                      C = 2e4 J/K, R = 0.05 K/W, P = |F_f*v| + 300 W*(T/120 kN*m)^2.
  load_dependent_friction  "coulomb" L += s*0.02*|T|; "both" L += s*0.01*|T| and
                      f_v *= 1+s*|T|/60 kN*m; "power_flow" L += s*mu*|T|, mu = 0.025 when
                      driving (T*v > 0), 0.008 when back-driven (tanh blend over 50 W).
  asymmetric_friction "coulomb" L *= 1+s*0.3*sgn v; "both" L *= 1+s*0.2*sgn v and
                      f_v *= 1-s*0.3*sgn v.
  gear_ripple         T += s*A*wave: "output" A = 1.2 kN*m, wave = sin(64q+p1)
                      + 0.35 sin(128q+p2) + 0.12 sin(192q+p3); "motor" A = 1 kN*m,
                      wave = sin(2N*u+p1) + 0.3 sin(4N*u+p2) (100 Hz at 3000 r/min: it aliases
                      at low sample rates, as an unfiltered DAQ would); "load_modulated" the output
                      wave with A = 2 kN*m*(0.15 + |T|/120 kN*m).
  backlash            Delta += c: "sharp" c moves to +-b (b = s*1.5e-4 rad, k*b ~ 2 kN*m) with
                      sgn T at 0.01 rad/s (a state); "smooth" c = b*tanh(T/1 kN*m); "preload"
                      c = b/(1+|tau_L|/5 kN*m)*tanh(T/300 N*m) (the dynamometer closes the gap).
  hysteresis          T = k*(1-f)*Delta + k*f*x + D*Delta', f = s*0.04, x_y = 1 mrad:
                      "bouc_wen_n1"/"bouc_wen_n2" dx/dDelta = 1-|x|^n*(beta*sgn(Delta'x)+gamma),
                      beta = 0.6/x_y^n, gamma = 0.4/x_y^n; "dahl" dx/dDelta = 1 - sgn(Delta')*x/x_y;
                      "softening" f = s*0.03, x_y = 0.5 mrad Dahl loss plus a soft wind-up
                      k*(1-f)*(Delta - s*0.1*1 mrad*tanh(Delta/1 mrad)).
  torque_offset       reading += s*(+-1.5 kN*m) ("constant") or s*(+-25 N*m/s)*t ("drift").
  time_delay          reading(t) = T(t - s*50 ms) ("fixed"); "jitter" adds s*U(-15, 15) ms
                      redrawn every 100 ms.
  periodic_disturbance  tau_ext += s*1.5 kN*m*(sin(2*pi*1.3 Hz*t+p1) + 0.3 sin(2*pi*2.6 Hz*t+p2))
                      (a hydraulic pump; not seen by the load gauge).
  position_stiffness  k(q) = k*(1 + s*0.05*sin(2q+p)).
  sensor_drift        load reading = tau_L*(1 +- s*3e-4/s * t) (gauge gain drift).
  second_resonance    T += s*1.0*(G(s)T - T), G a 4 Hz, zeta 0.03 mode in the load path.
  lugre_stick_slip    at each start and reversal of the plan the output sticks 0.12 s (fraction
                      min(s,1) of the planned motion is lost) while the friction reaction rises by
                      s*5 kN*m, then slips: a 5 Hz, zeta 0.25 damped catch-up of motion and torque.
Random phases and signs (p1, p2, ...) are fixed per seed.

Units: SI throughout (s, rad, rad/s, N*m, degC); rpm only for the commanded motor speed.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import signal

__all__ = ["SensorSpec", "RigRun", "EFFECT_FORMS", "OUT_OF_VOCABULARY", "SEED_IS_CAMPAIGN",
           "simulate_run"]

SEED_IS_CAMPAIGN = True
"""simulate_run's `seed` is the campaign's (one rig for every run of it); `run` keys the run."""

G = 9.81                                   # m/s^2
REDUCTION = 11000                          # motor angle / output angle
RATED_TORQUE = 120e3                       # N*m
OMEGA_TOP = 3000.0 * 2.0 * math.pi / 60.0 / REDUCTION   # output speed at 3000 r/min, rad/s
MOTOR_COUNTS_PER_REV = 2 ** 20             # motor encoder; u resolution = 2*pi/2^20/N rad

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exp", "gauss", "lorentz", "exp_half"),
    "temperature_friction": ("mult_both", "mult_viscous", "add_coulomb", "add_viscous"),
    "load_dependent_friction": ("coulomb", "both", "power_flow"),
    "asymmetric_friction": ("coulomb", "both"),
    "gear_ripple": ("output", "motor", "load_modulated"),
    "backlash": ("sharp", "smooth", "preload"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "softening", "dahl"),
    "torque_offset": ("constant", "drift"),
    "time_delay": ("fixed", "jitter"),
    # out of the diagnosis' vocabulary
    "periodic_disturbance": ("default",),
    "position_stiffness": ("default",),
    "sensor_drift": ("default",),
    "second_resonance": ("default",),
    "lugre_stick_slip": ("default",),
}

OUT_OF_VOCABULARY: tuple[str, ...] = (
    "periodic_disturbance", "position_stiffness", "sensor_drift", "second_resonance",
    "lugre_stick_slip",
)

# Default parameters of each form at scale 1 (SI units). Any of them may be overridden by
# passing it by name in the effect's dict; "scale" multiplies the magnitude (see _scaled keys).
_FORM_PARAMS: dict[str, dict[str, dict[str, float]]] = {
    "stribeck": {f: {"ds_ratio": 0.9, "vs_frac": 0.08}
                 for f in EFFECT_FORMS["stribeck"]},
    "temperature_friction": {
        "mult_both": {"kc": 0.015, "kv": 0.04, "t_ref": 30.0},
        "mult_viscous": {"a1": 0.05, "a2": 8e-4, "t_ref": 30.0},
        "add_coulomb": {"cc": 100.0, "t_ref": 30.0},
        "add_viscous": {"cv": 1500.0, "t_ref": 30.0},
    },
    "load_dependent_friction": {
        "coulomb": {"mu": 0.02},
        "both": {"mu": 0.01, "tv": 60e3},
        "power_flow": {"mu_drive": 0.025, "mu_back": 0.008, "p0": 50.0},
    },
    "asymmetric_friction": {
        "coulomb": {"a": 0.3},
        "both": {"a": 0.2, "av": 0.3},
    },
    "gear_ripple": {
        "output": {"amp": 1200.0, "order": 64.0},
        "motor": {"amp": 1000.0},
        "load_modulated": {"amp": 2000.0, "order": 64.0, "base": 0.15},
    },
    "backlash": {
        "sharp": {"b": 1.5e-4, "v_cross": 0.01},
        "smooth": {"b": 1.5e-4, "t_b": 1000.0},
        "preload": {"b": 1.5e-4, "t_b": 300.0, "tau_p": 5e3},
    },
    "hysteresis": {
        "bouc_wen_n1": {"frac": 0.04, "x_y": 1e-3},
        "bouc_wen_n2": {"frac": 0.04, "x_y": 1e-3},
        "softening": {"soft": 0.1, "d_r": 1e-3, "frac": 0.03, "x_y": 5e-4},
        "dahl": {"frac": 0.04, "x_y": 1e-3},
    },
    "torque_offset": {
        "constant": {"c": 1500.0},
        "drift": {"rate": 25.0},
    },
    "time_delay": {
        "fixed": {"delay_s": 0.05},
        "jitter": {"delay_s": 0.05, "jitter_s": 0.015, "cycle_s": 0.1},
    },
    "periodic_disturbance": {"default": {"amp": 1500.0, "freq_hz": 1.3}},
    "position_stiffness": {"default": {"eps": 0.05, "cycles": 2.0}},
    "sensor_drift": {"default": {"gain_per_s": 3e-4}},
    "second_resonance": {"default": {"kappa": 1.0, "f_hz": 4.0, "zeta": 0.03}},
    "lugre_stick_slip": {"default": {"d_f": 5000.0, "t_stick": 0.12, "f_hz": 5.0,
                                     "zeta": 0.25}},
}


@dataclass(frozen=True)
class SensorSpec:
    """Measurement chain: sample rate [Hz], output-encoder step [deg], white noise sd of the
    joint-torque and load-torque channels [N*m], first-order lag time constant of the torque
    transducer [s] and the fraction of torque samples lost (NaN)."""

    sample_rate_hz: float = 100.0
    encoder_res_deg: float = 0.001
    torque_noise: float = 250.0
    load_noise: float = 100.0
    torque_lag_s: float = 0.0
    dropout_rate: float = 0.0


@dataclass
class RigRun:
    """One run: measured `samples`, `meta` (what a real run record would carry) and the
    noise-free `truth` at the sample times (for scoring; never shown to the diagnosis)."""

    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


# ----------------------------------------------------------------------------------------------
# random streams: every consumer has its own, so effects never shift the noise
# ----------------------------------------------------------------------------------------------

def _rng(*key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(k) % (2 ** 63) for k in key]))


def _name_key(name: str) -> int:
    return zlib.crc32(name.encode())


def _campaign_params(seed: int) -> dict[str, float]:
    """Rig parameters of one campaign: nominal values perturbed by a few % (seed only)."""
    rng = _rng(seed, 1)

    def pert(value: float, sd: float) -> float:
        return value * (1.0 + sd * float(np.clip(rng.standard_normal(), -2.0, 2.0)))

    k_nom = RATED_TORQUE / math.radians(0.5)
    p = {
        "I": pert(6685.0, 0.03),            # kg*m^2
        "mrx": pert(20.8, 0.04),            # kg*m
        "mry": pert(-34.5, 0.04),           # kg*m
        "fv": pert(8683.0, 0.03),           # N*m*s/rad
        "fc": pert(2353.0, 0.03),           # N*m
        "k": pert(k_nom, 0.03),             # N*m/rad
        "tau_d": pert(0.002, 0.10),         # s, D = k*tau_d
        "z_pre": pert(4e-5, 0.10),          # rad, presliding displacement f_c/sigma0
        "servo_hz": pert(3.0, 0.05),        # Hz, position-servo bandwidth
        "dyno_hz": pert(2.5, 0.05),         # Hz, dynamometer torque-loop natural frequency
        "dyno_zeta": pert(0.8, 0.05),
        "c_th": pert(2.0e4, 0.05),          # J/K, thermal capacity of the gear/lubricant
        "r_th": pert(0.05, 0.05),           # K/W, thermal resistance to ambient
        "p_cu": pert(300.0, 0.05),          # W at rated torque
        "t_amb": 20.0 + float(np.clip(rng.standard_normal(), -2, 2)),   # degC
    }
    # motor inertia reflected to the output (3 motors x 0.6e-3 kg*m^2 x N^2): the inertia the
    # position servo fights disturbances with, so tracking errors stay small
    p["J_refl"] = pert(3 * 6e-4 * REDUCTION ** 2, 0.05)
    p["D"] = p["k"] * p["tau_d"]
    p["sigma0"] = p["fc"] / p["z_pre"]
    p["sigma1"] = 0.3 * p["fv"]
    return p


# ----------------------------------------------------------------------------------------------
# effects: parsing
# ----------------------------------------------------------------------------------------------

def _parse_effects(effects: dict[str, dict] | None) -> dict[str, dict]:
    """Validate `effects`; return {name: {"form", "scale", **params}} for scales != 0."""
    out: dict[str, dict] = {}
    if not effects:
        return out
    if not isinstance(effects, dict):
        raise ValueError("effects must be a dict {name: {'form': ..., 'scale': ...}}")
    unknown = [n for n in effects if n not in EFFECT_FORMS]
    if unknown:
        raise ValueError(f"unknown effect(s) {unknown}; known: {sorted(EFFECT_FORMS)}")
    for name, spec in effects.items():
        spec = dict(spec or {})
        form = spec.pop("form", EFFECT_FORMS[name][0])
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"unknown form {form!r} of effect {name!r}; "
                             f"known: {EFFECT_FORMS[name]}")
        scale = float(spec.pop("scale", 1.0))
        if not math.isfinite(scale):
            raise ValueError(f"scale of effect {name!r} must be finite, got {scale}")
        params = dict(_FORM_PARAMS[name][form])
        bad = [key for key in spec if key not in params]
        if bad:
            raise ValueError(f"unknown parameter(s) {bad} of effect {name!r} form {form!r}; "
                             f"known: {sorted(params)}")
        params.update({key: float(val) for key, val in spec.items()})
        if scale == 0.0:
            continue
        if name == "hysteresis" and (abs(scale * params["frac"]) >= 0.9
                                     or abs(scale * params.get("soft", 0.0)) >= 0.9):
            raise ValueError("hysteresis: scale too large (hysteretic fraction must stay < 0.9)")
        out[name] = {"form": form, "scale": scale, **params}
    return out


# ----------------------------------------------------------------------------------------------
# planning (what the rig's motion controller and dynamometer are told to do)
# ----------------------------------------------------------------------------------------------

_PHASES = ("idle", "load", "hold", "unload", "excite")


def _cyclo(t: np.ndarray, t0: float, tr: float):
    """Cycloidal smooth step of duration tr from t0: value s in [0, 1], its rate and
    acceleration, and its time integral. Bounded jerk: a jerk-limited S-curve."""
    x = np.clip((t - t0) / tr, 0.0, 1.0)
    tw = 2.0 * math.pi
    s = x - np.sin(tw * x) / tw
    ds = (1.0 - np.cos(tw * x)) / tr
    dds = np.where((x > 0) & (x < 1), tw * np.sin(tw * x) / tr ** 2, 0.0)
    integ = tr * (x ** 2 / 2 + (np.cos(tw * x) - 1.0) / tw ** 2) + np.maximum(t - t0 - tr, 0.0)
    return s, ds, dds, integ


def _constant_speed_plan(t, w, t_acc, t_dec, tr=2.0):
    s1, ds1, dds1, i1 = _cyclo(t, t_acc, tr)
    s2, ds2, dds2, i2 = _cyclo(t, t_dec, tr)
    return w * (i1 - i2), w * (s1 - s2), w * (ds1 - ds2)


def _fourier_coefficients(seed: int, omega_f: float, v_max: float = 0.028):
    """5th-order Fourier coefficients (a_l, b_l) of qdot = sum a_l cos + b_l sin, random per
    seed, with qdot(0) = qddot(0) = 0 and max |qdot| = v_max [rad/s]."""
    rng = _rng(seed, 6)
    l = np.arange(1, 6, dtype=float)
    a = rng.standard_normal(5) / l
    b = rng.standard_normal(5) / l
    a -= a.mean()                                   # sum a_l = 0      -> qdot(0) = 0
    b -= l * (l @ b) / (l @ l)                      # sum l*b_l = 0    -> qddot(0) = 0
    tau = np.linspace(0.0, 2 * math.pi / omega_f, 4001)
    ph = np.outer(tau, l * omega_f)
    vmax = np.abs(np.cos(ph) @ a + np.sin(ph) @ b).max()
    return a * v_max / vmax, b * v_max / vmax


def _plan(scheme, rpm, direction, periods, seed, t):
    """Planned output motion (q, qdot, qddot), load set point [N*m] and phase codes."""
    n = t.size
    phase = np.zeros(n, dtype=np.int8)
    if scheme in (1, 2):
        w = direction * rpm * 2 * math.pi / 60.0 / REDUCTION
        if scheme == 1:
            qp, vp, ap = _constant_speed_plan(t, w, 2.0, 98.0)
            bp_t = [0.0, 6.0, 50.0, 52.0, 96.0, 102.0]
            bp_v = [0.0, 0.0, RATED_TORQUE, RATED_TORQUE, 0.0, 0.0]
            sp = np.interp(t, bp_t, bp_v)
            phase[(t >= 6) & (t < 50)] = 1
            phase[(t >= 50) & (t < 52)] = 2
            phase[(t >= 52) & (t < 96)] = 3
        else:
            qp, vp, ap = _constant_speed_plan(t, w, 1.0, 59.0)
            levels = [10e3 * j for j in range(1, 13)] + [10e3 * j for j in range(11, -1, -1)]
            bp_t, bp_v = [0.0, 4.0], [0.0, 0.0]
            prev = 0.0
            for j, lev in enumerate(levels):
                t0 = 4.0 + 2.25 * j
                bp_t += [t0 + 0.25, t0 + 2.25]
                bp_v += [lev, lev]
                ramp = (t >= t0) & (t < t0 + 0.25)
                held = (t >= t0 + 0.25) & (t < t0 + 2.25)
                phase[ramp] = 1 if lev > prev else 3
                phase[held] = 2 if lev > 0 else 0
                prev = lev
            bp_t.append(62.0)
            bp_v.append(0.0)
            sp = np.interp(t, bp_t, bp_v)
    else:
        omega_f = 2 * math.pi / 20.0
        a, b = _fourier_coefficients(seed, omega_f)
        l = np.arange(1, 6, dtype=float)
        tau = t - 2.0
        active = (tau >= 0) & (tau <= 20.0 * periods)
        ph = np.outer(np.where(active, tau, 0.0), l * omega_f)
        c, s = np.cos(ph), np.sin(ph)
        lw = l * omega_f
        qp = s @ (a / lw) - c @ (b / lw) + np.sum(b / lw)
        vp = c @ a + s @ b
        ap = -s @ (a * lw) + c @ (b * lw)
        vp = np.where(active, vp, 0.0)
        ap = np.where(active, ap, 0.0)
        qp = np.where(active, qp, 0.0)    # periodic: it returns to 0 at the end
        qp, vp, ap = direction * qp, direction * vp, direction * ap
        sp = np.zeros(n)
        phase[active] = 4
    return qp, vp, ap, sp, phase


def _duration(scheme: int, periods: int) -> float:
    return {1: 102.0, 2: 62.0}.get(scheme, 4.0 + 20.0 * periods)


# ----------------------------------------------------------------------------------------------
# linear-system helpers
# ----------------------------------------------------------------------------------------------

def _zoh(num, den, dt):
    numd, dend, _ = signal.cont2discrete((num, den), dt, method="zoh")
    return np.atleast_1d(np.squeeze(numd)), np.asarray(dend, dtype=float)


def _lowpass1(x: np.ndarray, tau: float, dt: float) -> np.ndarray:
    """First-order low-pass (ZOH exact), starting in steady state at x[0]."""
    if tau <= 0:
        return x.copy()
    a = math.exp(-dt / tau)
    y, _ = signal.lfilter([1 - a], [1, -a], x, zi=[a * x[0]])
    return y


def _second_order(x, f_hz, zeta, dt):
    """Unit-DC-gain second-order low-pass response to x, starting at rest at x[0]."""
    w = 2 * math.pi * f_hz
    b, a = _zoh([w * w], [1.0, 2 * zeta * w, w * w], dt)
    return signal.lfilter(b, a, x - x[0]) + x[0]


# ----------------------------------------------------------------------------------------------
# friction (LuGre bristle state; all friction effects act on its level and on the viscous slope)
# ----------------------------------------------------------------------------------------------

def _lugre_states(phi: np.ndarray, zinf: np.ndarray) -> np.ndarray:
    """z_k = zinf_k + (z_{k-1} - zinf_k)*phi_k, z_{-1} = 0: exact LuGre step for constant v."""
    out = []
    append = out.append
    z = 0.0
    for p, zi in zip(phi.tolist(), zinf.tolist()):
        z = zi + (z - zi) * p
        append(z)
    return np.asarray(out)


def _friction(v, T_prev, temp, P, E, dt):
    """Friction torque F_f [N*m] opposing the output motion v [rad/s].

    T_prev is the joint torque of the previous fixed-point pass (load-dependent friction),
    temp the joint temperature [degC] (temperature-dependent friction)."""
    sgn = np.sign(v)
    fc = np.full(v.shape, P["fc"])
    fv = np.full(v.shape, P["fv"])
    eff = E.get("temperature_friction")
    if eff is not None:
        s, dT = eff["scale"], temp - eff["t_ref"]
        if eff["form"] == "mult_both":
            fc = fc * (1 + s * (np.exp(-eff["kc"] * dT) - 1))
            fv = fv * (1 + s * (np.exp(-eff["kv"] * dT) - 1))
        elif eff["form"] == "mult_viscous":
            poly = np.maximum(1 - eff["a1"] * dT + eff["a2"] * dT ** 2, 0.2)
            fv = fv * (1 + s * (poly - 1))
        elif eff["form"] == "add_coulomb":
            fc = fc + s * eff["cc"] * (-dT)
        else:  # add_viscous
            fv = fv + s * eff["cv"] * (-dT)
    eff = E.get("asymmetric_friction")
    if eff is not None:
        fc = fc * (1 + eff["scale"] * eff["a"] * sgn)
        if eff["form"] == "both":
            fv = fv * (1 - eff["scale"] * eff["av"] * sgn)
    eff = E.get("load_dependent_friction")
    if eff is not None:
        aT, s = np.abs(T_prev), eff["scale"]
        if eff["form"] == "coulomb":
            fc = fc + s * eff["mu"] * aT
        elif eff["form"] == "both":
            fc = fc + s * eff["mu"] * aT
            fv = fv * (1 + s * aT / eff["tv"])
        else:  # power_flow: driving when T*v > 0, back-driven when < 0 (smooth blend)
            drive = 0.5 * (1 + np.tanh(T_prev * v / eff["p0"]))
            fc = fc + s * (eff["mu_back"] + (eff["mu_drive"] - eff["mu_back"]) * drive) * aT
    level = fc
    eff = E.get("stribeck")
    if eff is not None:
        r = np.abs(v) / (eff["vs_frac"] * OMEGA_TOP)
        shape = {"exp": lambda: np.exp(-r), "gauss": lambda: np.exp(-r * r),
                 "lorentz": lambda: 1.0 / (1.0 + r * r),
                 "exp_half": lambda: np.exp(-np.sqrt(r))}[eff["form"]]()
        level = level + eff["scale"] * eff["ds_ratio"] * P["fc"] * shape
    level = np.maximum(level, 1.0)
    sig0 = P["sigma0"]
    phi = np.exp(-sig0 * np.abs(v) * dt / level)
    z = _lugre_states(phi, sgn * level / sig0)
    zdot = np.diff(z, prepend=0.0) / dt
    return sig0 * z + P["sigma1"] * zdot + fv * v


# ----------------------------------------------------------------------------------------------
# transmission: twist given torque
# ----------------------------------------------------------------------------------------------

def _hysteretic_twist(T, dt, P, eff):
    """Solve T = T_el(Delta) + k_h*x + D*Delta' for Delta, step by step (backward Euler).

    x is the hysteretic state with dx/dDelta = s(x, sign(dDelta)):
      bouc_wen_n: s = 1 - |x|^n*(beta*sgn(dDelta*x) + gamma), beta = 0.6/x_y^n,
                  gamma = 0.4/x_y^n (x saturates at x_y);
      dahl / softening: s = 1 - sgn(dDelta)*x/x_y.
    T_el = k_e*Delta with k_e = k*(1 - frac), k_h = k*frac; softening adds a soft wind-up
    T_el = k_e*(Delta - soft*d_r*tanh(Delta/d_r)) (stiffness rising with twist).
    The sign of dDelta is the sign of the torque residual (the law is monotonic), so each step is
    one exact piecewise-linear solve (two Newton steps for the wind-up)."""
    k, D = P["k"], P["D"]
    s_ = eff["scale"]
    frac = s_ * eff["frac"]
    ke, kh = k * (1 - frac), k * frac
    xy = eff["x_y"]
    form = eff["form"]
    n_bw = {"bouc_wen_n1": 1.0, "bouc_wen_n2": 2.0}.get(form, 0.0)
    beta = 0.6 / xy ** n_bw if n_bw else 0.0
    gamma = 0.4 / xy ** n_bw if n_bw else 0.0
    soft = s_ * eff.get("soft", 0.0)
    dr = eff.get("d_r", 1.0)
    c_d = D / dt
    tanh, cosh = math.tanh, math.cosh

    def t_el(d):
        return ke * (d - soft * dr * tanh(d / dr)) if soft else ke * d

    def t_el_slope(d):
        return ke * (1 - soft / cosh(d / dr) ** 2) if soft else ke

    delta = float(T[0]) / k
    x = 0.0
    out = []
    for Tk in T.tolist():
        r0 = t_el(delta) + kh * x - Tk
        sg = -1.0 if r0 > 0 else 1.0
        if n_bw:
            ax = abs(x) ** n_bw
            sx = 1.0 if x * sg >= 0 else -1.0
            slope = 1.0 - ax * (beta * sx + gamma)
        else:
            slope = 1.0 - sg * x / xy
        slope = max(slope, 0.0)
        dd = -r0 / (t_el_slope(delta) + kh * slope + c_d)
        if soft:      # second Newton step on the nonlinear wind-up
            r1 = t_el(delta + dd) + kh * (x + slope * dd) + c_d * dd - Tk
            dd -= r1 / (t_el_slope(delta + dd) + kh * slope + c_d)
        x += slope * dd
        x = min(max(x, -xy), xy)
        delta += dd
        out.append(delta)
    return np.asarray(out)


def _twist(T, q, tau_dyno, t, dt, P, E, erng):
    """Twist Delta = u - q [rad] from the transmission law given the joint torque T."""
    k, D = P["k"], P["D"]
    T_eff = T
    eff = E.get("position_stiffness")
    if eff is not None:   # k(q) = k*(1 + eps*sin(cycles*q + phi)): same law, stiffness by angle
        phi0 = erng["position_stiffness"].uniform(0, 2 * math.pi)
        T_eff = T / (1 + eff["scale"] * eff["eps"] * np.sin(eff["cycles"] * q + phi0))
    eff = E.get("hysteresis")
    if eff is not None:
        delta = _hysteretic_twist(T_eff, dt, P, eff)
    else:   # D*Delta' + k*Delta = T, backward Euler (the hysteretic solver with frac = 0)
        c_d = D / dt
        den = k + c_d
        delta, _ = signal.lfilter([1 / den], [1, -c_d / den], T_eff,
                                  zi=[c_d / den * T_eff[0] / k])
    eff = E.get("backlash")
    if eff is not None:
        b = eff["scale"] * eff["b"]
        if eff["form"] == "sharp":
            # gap position c moves to +-b with the sign of T at the crossing speed v_cross
            step = eff["v_cross"] * dt
            c, out = 0.0, []
            for Tk in T.tolist():
                target = b if Tk > 0 else (-b if Tk < 0 else c)
                c += min(max(target - c, -step), step)
                out.append(c)
            gap = np.asarray(out)
        elif eff["form"] == "smooth":
            gap = b * np.tanh(T / eff["t_b"])
        else:   # preload: the gap closes as the dynamometer torque grows
            gap = b / (1 + np.abs(tau_dyno) / eff["tau_p"]) * np.tanh(T / eff["t_b"])
        delta = delta + gap
    return delta


# ----------------------------------------------------------------------------------------------
# stick-slip episodes (out of vocabulary)
# ----------------------------------------------------------------------------------------------

def _stick_slip(t, qp, vp, ap, eff):
    """Motion error (e, e', e'') and extra torque [N*m] of stick-slip episodes at every start
    and reversal of the planned motion: the output sticks for t_stick (it stays where it was
    while the friction reaction builds up d_f, linearly), then slips and catches up with a
    damped oscillation at f_hz."""
    n = t.size
    e = np.zeros(n)
    ed = np.zeros(n)
    edd = np.zeros(n)
    tq = np.zeros(n)
    scale = eff["scale"]
    frac = min(abs(scale), 1.0) * (1.0 if scale >= 0 else -1.0)
    ts = eff["t_stick"]
    wn = 2 * math.pi * eff["f_hz"]
    zeta = eff["zeta"]
    sig, wd = zeta * wn, wn * math.sqrt(1 - zeta ** 2)
    eps_v = 1e-9
    s = np.where(np.abs(vp) > eps_v, np.sign(vp), 0.0)
    nz = np.flatnonzero(s != 0)
    if nz.size == 0:
        return e, ed, edd, tq
    sn = s[nz]
    # the first motion from rest and every sign change of the planned velocity
    events = nz[np.r_[True, sn[1:] != sn[:-1]]].tolist()
    dt = t[1] - t[0]
    for i0 in events:
        tr = t[i0]
        direction = s[i0]
        i1 = min(int(round((tr + ts) / dt)), n - 1)
        i2 = min(int(round((tr + ts + 6.0 / sig) / dt)), n - 1)
        win = slice(i0, i1)
        e[win] += -frac * (qp[win] - qp[i0])
        ed[win] += -frac * vp[win]
        edd[win] += -frac * ap[win]
        tq[win] += scale * eff["d_f"] * direction * (t[win] - tr) / ts
        A = -frac * (qp[i1] - qp[i0])
        B = (-frac * vp[i1] + sig * A) / wd
        tau = t[i1:i2] - t[i1]
        ex, c, sn = np.exp(-sig * tau), np.cos(wd * tau), np.sin(wd * tau)
        e[i1:i2] += ex * (A * c + B * sn)
        ed[i1:i2] += ex * ((B * wd - sig * A) * c - (A * wd + sig * B) * sn)
        edd[i1:i2] += ex * (((sig ** 2 - wd ** 2) * A - 2 * sig * wd * B) * c
                            + ((sig ** 2 - wd ** 2) * B + 2 * sig * wd * A) * sn)
        tq[i1:i2] += scale * eff["d_f"] * direction * ex * c
    return e, ed, edd, tq


# ----------------------------------------------------------------------------------------------
# main entry point
# ----------------------------------------------------------------------------------------------

def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, seed: int = 0,
                 sensors: SensorSpec = SensorSpec(), periods: int = 6, run: int = 0) -> RigRun:
    """Simulate one run of scheme 1, 2 or 3 on rig B.

    scheme 1: constant output speed rpm*2*pi/60/N * direction after a cycloidal (jerk-limited)
      2 s start; the dynamometer set point ramps 0 -> 120 kN*m (44 s), holds 2 s, ramps back
      (44 s); 102 s in all at both speeds.
    scheme 2: constant speed; load steps of 10 kN*m (0.25 s ramps) held 2 s each up to
      120 kN*m and back down to 0; 62 s.
    scheme 3: 5th-order Fourier trajectory (period 20 s, `periods` periods, |qdot| <= 0.028
      rad/s, qdot = qddot = 0 at both ends, coefficients random but fixed per seed, mirrored by
      `direction`), 2 s of rest before and after, no load (the dynamometer holds 0 N*m).
    temp_joint_c: joint temperature at the start [degC].
    effects: {name: {"form": ..., "scale": ..., optional parameter overrides}}; see
      EFFECT_FORMS. Scale 0 is exactly the run without the effect.
    seed: fixes the campaign's parameter perturbations (seed only), the Fourier coefficients,
      the effect parameters (random phases, signs) and the run's noise (seed and run
      identity); none of them depends on which effects are present.
    run: the run's number within the campaign; it keys the run's noise and dynamometer error
      with the scheme, direction and speed, so that two runs of the same scheme, direction and
      speed in one campaign (a repeat) carry their own noise.
    """
    if scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if scheme in (1, 2):
        if motor_speed_rpm is None or not motor_speed_rpm > 0 or motor_speed_rpm > 3500:
            raise ValueError("schemes 1-2 need a motor speed in (0, 3500] r/min")
        rpm = float(motor_speed_rpm)
    else:
        rpm = None
        if int(periods) < 1:
            raise ValueError("periods must be >= 1")
        periods = int(periods)
    fs = float(sensors.sample_rate_hz)
    if not 10.0 <= fs <= 1000.0:
        raise ValueError("sample_rate_hz must lie in [10, 1000] Hz")
    if not 0.0 <= sensors.dropout_rate < 1.0:
        raise ValueError("dropout_rate must lie in [0, 1)")
    E = _parse_effects(effects)
    P = _campaign_params(seed)

    # ---- time grid: the sample times are internal grid points --------------------------------
    m = math.ceil(1000.0 / fs - 1e-9)
    dt = 1.0 / (m * fs)
    duration = _duration(scheme, periods)
    n = int(round(duration / dt)) + 1
    t = np.arange(n) * dt
    run_key = (scheme, 0 if direction > 0 else 1, int(round((rpm or 0.0) * 1000)), int(run))
    erng = {name: _rng(seed, 5, _name_key(name)) for name in EFFECT_FORMS}

    qp, vp, ap, sp, phase = _plan(scheme, rpm, direction, periods, seed, t)

    # ---- dynamometer: second-order torque loop + bounded slowly varying error -----------------
    tau_dyno = _second_order(sp, P["dyno_hz"], P["dyno_zeta"], dt)
    r_dy = _rng(seed, 3, *run_key)
    a_ou = math.exp(-dt / 2.0)
    white = r_dy.standard_normal(n) * math.sqrt(1 - a_ou * a_ou)
    ou, _ = signal.lfilter([1.0], [1.0, -a_ou], white, zi=[a_ou * r_dy.standard_normal()])
    err_amp = 150.0 if scheme == 3 else 500.0        # N*m, inside the +-2 kN*m tolerance
    tau_dyno = tau_dyno + err_amp * np.tanh(0.8 * ou)

    tau_ext = tau_dyno.copy()   # external torque on the output
    eff = E.get("periodic_disturbance")
    if eff is not None:          # e.g. hydraulic pump pulsation through the loading shaft
        ph1, ph2 = erng["periodic_disturbance"].uniform(0, 2 * math.pi, 2)
        wp = 2 * math.pi * eff["freq_hz"]
        tau_ext = tau_ext + eff["scale"] * eff["amp"] * (np.sin(wp * t + ph1)
                                                         + 0.3 * np.sin(2 * wp * t + ph2))

    # ---- stick-slip motion/torque modification ------------------------------------------------
    e_ss = ed_ss = edd_ss = tq_ss = 0.0
    if "lugre_stick_slip" in E:
        e_ss, ed_ss, edd_ss, tq_ss = _stick_slip(t, qp, vp, ap, E["lugre_stick_slip"])

    # ---- effect randomness (drawn whether or not used later in the run) -----------------------
    rip = None
    eff = E.get("gear_ripple")
    if eff is not None:
        rip = erng["gear_ripple"].uniform(0, 2 * math.pi, 3)

    def torque_terms(q, v, a, temp, T_prev):
        F = _friction(v, T_prev, temp, P, E, dt)
        grav = G * (P["mrx"] * np.sin(q) + P["mry"] * np.cos(q))
        T_base = P["I"] * a + grav + F + tau_ext + tq_ss
        T = T_base
        eff_r = E.get("gear_ripple")
        if eff_r is not None:
            amp = eff_r["scale"] * eff_r["amp"]
            if eff_r["form"] == "motor":     # 2 cycles per motor revolution (+ 2nd harmonic)
                ang = 2.0 * REDUCTION * (q + T_base / P["k"])
                T = T + amp * (np.sin(ang + rip[0]) + 0.3 * np.sin(2 * ang + rip[1]))
            else:                             # mesh order on the output angle, 3 harmonics
                ang = eff_r["order"] * q
                wave = (np.sin(ang + rip[0]) + 0.35 * np.sin(2 * ang + rip[1])
                        + 0.12 * np.sin(3 * ang + rip[2]))
                if eff_r["form"] == "load_modulated":
                    amp = amp * (eff_r["base"] + np.abs(T_base) / RATED_TORQUE)
                T = T + amp * wave
        eff_s = E.get("second_resonance")
        if eff_s is not None:   # lightly damped mode in the load path, high-pass excited
            T = T + eff_s["scale"] * eff_s["kappa"] * (
                _second_order(T, eff_s["f_hz"], eff_s["zeta"], dt) - T)
        return T, F

    def thermal(F, v, T):
        power = np.abs(F * v) + P["p_cu"] * (T / RATED_TORQUE) ** 2
        tau_th = P["r_th"] * P["c_th"]
        a_th = math.exp(-dt / tau_th)
        x = P["t_amb"] + P["r_th"] * power
        y, _ = signal.lfilter([1 - a_th], [1, -a_th], x, zi=[a_th * temp_joint_c])
        return y

    # ---- fixed-point passes: plan -> servo error -> actual motion -> torque -------------------
    temp = np.full(n, float(temp_joint_c))
    n_pass = 3 if ("load_dependent_friction" in E or "temperature_friction" in E) else 2
    q, v, a = qp + e_ss, vp + ed_ss, ap + edd_ss
    T_prev = P["I"] * a + tau_ext
    for it in range(n_pass):
        T, F = torque_terms(q, v, a, temp, T_prev)
        if it == 0:
            # torque the servo's feed-forward (nominal inertia and viscous) does not cover
            d = T - (6685.0 * ap + 8683.0 * vp)
            d = d - d[0]
            ws = 2 * math.pi * P["servo_hz"]
            i_s = P["I"] + P["J_refl"]
            den = [i_s, 3 * ws * i_s, 3 * ws * ws * i_s, ws ** 3 * i_s]
            e = signal.lfilter(*_zoh([-1.0, 0.0], den, dt), d)
            ed = signal.lfilter(*_zoh([-1.0, 0.0, 0.0], den, dt), d)
            edd = signal.lfilter(*_zoh([-1.0, 0.0, 0.0, 0.0], den, dt), d)
            q, v, a = q + e, v + ed, a + edd
        if "temperature_friction" in E:
            temp = thermal(F, v, T)
        T_prev = T
    temp = thermal(F, v, T)
    T_joint = T

    # ---- transmission: twist and motor angle --------------------------------------------------
    delta = _twist(T_joint, q, tau_dyno, t, dt, P, E, erng)
    u = q + delta

    # ---- the torque and load readings (noise-free) -------------------------------------------
    T_read = _lowpass1(T_joint, sensors.torque_lag_s, dt)
    eff = E.get("time_delay")
    if eff is not None:
        lag = eff["scale"] * eff["delay_s"] * np.ones(n)
        if eff["form"] == "jitter":   # latency redrawn every fieldbus cycle_s
            n_cyc = int(duration / eff["cycle_s"]) + 2
            jit = erng["time_delay"].uniform(-1, 1, n_cyc)
            lag = lag + eff["scale"] * eff["jitter_s"] * jit[(t / eff["cycle_s"]).astype(int)]
        T_read = np.interp(t - lag, t, T_read)
    eff = E.get("torque_offset")
    if eff is not None:
        sign = 1.0 if erng["torque_offset"].uniform() < 0.5 else -1.0
        if eff["form"] == "constant":
            T_read = T_read + eff["scale"] * sign * eff["c"]
        else:
            T_read = T_read + eff["scale"] * sign * eff["rate"] * t
    load_read = tau_dyno
    eff = E.get("sensor_drift")
    if eff is not None:     # the load gauge's gain drifts slowly (sign per seed)
        sign = 1.0 if erng["sensor_drift"].uniform() < 0.5 else -1.0
        load_read = tau_dyno * (1 + eff["scale"] * sign * eff["gain_per_s"] * t)

    # ---- sensors: encoders, velocity estimates, noise, dropout -------------------------------
    q_res = math.radians(sensors.encoder_res_deg)
    u_res = 2 * math.pi / MOTOR_COUNTS_PER_REV / REDUCTION
    q_meas_int = np.round(q / q_res) * q_res if q_res > 0 else q
    u_meas_int = np.round(u / u_res) * u_res

    def drive_speed(x):   # backward difference + two cascaded 8 ms first-order low-passes
        raw = np.diff(x, prepend=x[0]) / dt
        return _lowpass1(_lowpass1(raw, 0.008, dt), 0.008, dt)

    qd_meas = drive_speed(q_meas_int)
    ud_meas = drive_speed(u_meas_int)

    idx = np.arange(0, n, m)
    ns = idx.size
    r_noise = _rng(seed, 2, *run_key)
    n_torque = r_noise.standard_normal(ns)
    n_load = r_noise.standard_normal(ns)
    r_drop = _rng(seed, 4, *run_key)
    order = r_drop.permutation(ns)
    torque_meas = T_read[idx] + sensors.torque_noise * n_torque
    n_drop = int(round(sensors.dropout_rate * ns))
    if n_drop:
        torque_meas[order[:n_drop]] = np.nan
    load_meas = load_read[idx] + sensors.load_noise * n_load
    q_s, u_s = q_meas_int[idx], u_meas_int[idx]
    phase_names = np.asarray(_PHASES, dtype=object)[phase[idx]]

    samples = pd.DataFrame({
        "t": t[idx], "q": q_s, "qd": qd_meas[idx], "u": u_s, "ud": ud_meas[idx],
        "torsion": q_s - u_s, "torque": torque_meas, "torque_load": load_meas,
        "temp_joint": np.round(temp[idx], 1), "phase": phase_names,
    })
    truth = pd.DataFrame({
        "t": t[idx], "q": q[idx], "qd": v[idx], "u": u[idx], "torque": T_read[idx],
        "torque_load": load_read[idx], "twist": delta[idx],
        # extra truth: the physical joint torque (before the sensor chain), the total external
        # torque on the output, the output acceleration and the joint temperature
        "torque_joint": T_joint[idx], "torque_ext": tau_ext[idx], "qdd": a[idx],
        "temp_joint": temp[idx],
    })
    truth.attrs["params"] = dict(P)
    truth.attrs["effects"] = {k: dict(v_) for k, v_ in E.items()}
    meta = {
        "scheme": scheme, "motor_speed_rpm": rpm, "direction": direction,
        "reduction": REDUCTION, "rig": "validation-rig-B", "source": "emulator",
        "sample_rate_hz": fs, "duration_s": float(t[idx][-1]), "temp_joint_start_c":
        float(temp_joint_c),
        "sensors": {
            "q": {"resolution": q_res},
            "u": {"resolution": u_res},
            "qd": {"estimate": "backward difference of the quantised output encoder at "
                               f"{m * fs:g} Hz, two cascaded 8 ms first-order low-passes"},
            "torque": {"noise_sd": float(sensors.torque_noise),
                       "lag_s": float(sensors.torque_lag_s)},
            "torque_load": {"noise_sd": float(sensors.load_noise)},
            "temp_joint": {"resolution": 0.1},
        },
    }
    if scheme == 3:
        meta["periods"] = periods
    return RigRun(samples=samples, meta=meta, truth=truth)
