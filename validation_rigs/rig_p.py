"""Validation rig P: an independent physics-level simulation of the CMOR J4 joint test bench.

This module is the rig's data sheet. It is written from shared/docs (rig.md, run-format.md,
effects-in-the-wild.md) and the paper only; it shares no code with the software it scores.

PLANT (all angles and torques referred to the joint output unless said otherwise)
================================================================================
Three servo motors (S120 drives) drive the joint through two elastic stages, total reduction
N = 11000 (precision reducer N1 = 110, differential planetary N2 = 100):

    motor side   J_u ü  = τ_m − T1 − F_m(u̇, T1)                  J_u = 3·J_m·N²  (J_m ≈ 1.6e-3 kg·m²)
    intermediate J_i θ̈  = T1 − T2                                 J_i ≈ 800 kg·m² (reducer output / sun)
    output       I q̈    = T2 − τ_L − g(mr_x sin q + mr_y cos q) − F_o(q̇, …)

    stage 1 (reducer):    T1 = k1·δ1 + c1·δ̇1,   δ1 = u − θ          (backlash lives here)
    stage 2 (planetary):  T2 = k2·δ2 + c2·δ̇2,   δ2 = θ − q          (hysteresis lives here)

k1, k2 are drawn so that the series stiffness k = k1·k2/(k1+k2) ≈ 1.375e7 N·m/rad (half a
degree of twist at 120 kN·m), with equal time constants c_i/k_i, so the quasi-static law over the
whole transmission is exactly T2 = k·Δ + D·Δ̇ (Δ = u − q, D = 2·ζ_t·sqrt(k·I)) up to the
intermediate inertia's J_i·θ̈ term (ζ_t ≈ 0.12 drawn per campaign). The strain-gauge torque flange sits between stage 2 and the
output link, so the true `torque` is T2. Output-side friction F_o is the main bearing /
final mesh behind the flange: a 4-element generalized Maxwell-slip (elasto-plastic) model whose
breakaway levels sum to f_c (presliding deflections 4e-6 … 1.2e-4 rad, LuGre-like micro-damping
of the stuck elements), plus f_v·q̇. In steady sliding F_o = f_c·sgn(q̇) + f_v·q̇ exactly (Eq. 4);
at reversals the friction builds up over ~1e-4 rad of travel (tens of ms at 300 r/min).
Motor-side losses F_m (1500 N·m Coulomb, smooth, 4.0e4 N·m·s/rad, 4 % of |T1|) show only in the
motor currents. Default values, each drawn per campaign (`seed`) a few % around them:
I = 6685 kg·m², mr_x = 20.8, mr_y = −34.5 kg·m, f_v = 8683 N·m·s/rad, f_c = 2353 N·m.

Drives: per-motor current loops (first order, 1 ms), one PI speed loop (≈40 rad/s crossover,
output-referred gains from J_u) whose torque demand is split equally between the three current
commands; each motor has its own torque constant k_t ≈ 1.35 N·m/A. Scheme 3 adds a motor-angle
position loop (5 1/s) with speed feed-forward.

Dynamometer: torque source on the output, τ_L = first-order lag (0.12 s) of the set point plus
its own loop error (slow sine, 150 N·m + 0.4 % of |set point|, inside Table 11's ±2 kN·m) plus
broadband torque noise (≈80 N·m rms, 5 ms correlation). The load cell measures τ_L.
Hydraulics hold a bending moment of 50 kN·m and a shear of 90 kN (channels m_bend, f_shear,
p_hyd). Thermal: gearbox (25 kJ/K, 0.05 K/W to 22 °C ambient) heated by all friction losses;
windings (2 kJ/K, 0.4 K/W to the gearbox) heated by R·i² and iron losses.

Integration: semi-implicit (symplectic) Euler, fixed internal step dt = 1/(fs·m) ≤ 0.5 ms with
m an integer, so every sample instant is a step instant (numba kernel, cache=True).

SCHEMES (direction d = ±1 is the sense of motion; the dynamometer always resists motion:
torque_cmd = d·profile)
1. 55 s: idle 0–3 s (accelerate 1–2 s to the commanded motor speed), `load` 3–27 s ramp to
   120 kN·m, `hold` 27–28 s, `unload` 28–52 s, `idle` 52–55 s (stop 53–54 s).
2. 55 s: idle 0–3 s, twelve 10 kN·m steps (1 s ramp `load` + 2 s `hold`) to 120 kN·m, `unload`
   39–51 s, `idle` 51–55 s.
3. Fifth-order Fourier trajectory (paper Eq. 12), period 25 s, `periods` periods, coefficients
   optimised offline for the log condition number of Eq. 4's regressor, peak speed 0.026 rad/s,
   q(0) = 0, q̇(0) = q̈(0) = 0, range about −0.06 … 0.16 rad (times d); 2 s `idle` before and after;
   set point 0 (only the dynamometer's own error acts). `motor_speed_rpm` must be None.
   `periods` is used by scheme 3 only.

SENSORS (SensorSpec; meta["sensors"] states them)
q: output encoder, quantised at `encoder_res_deg` (no noise).  qd: type-2 tracking observer on
the quantised encoder (bandwidth `qd_observer_hz`, zero lag at constant speed).  u: motor
encoders, 2**bits counts per motor revolution, /N.  ud, w_m1..3: drive speed (noise).
torque: strain-gauge flange, first-order amplifier `torque_bandwidth_hz` (delay 1/(2π·fc)),
fieldbus delay `torque_lag_s`, white noise `torque_noise`, ADC step `torque_res`; the stated lag
is torque_lag_s + amplifier delay.  torque_load: load cell, noise `load_noise`.
i_m1..3: current sensors.  temp_*: PT100, 0.1 °C.  torque_cmd: the set point as sent.

UNSTATED IMPERFECTIONS (drawn per campaign, recorded in params["unstated"])
- flange gain error ±0.05 % (1σ 0.02 %) and load-cell gain error (same size): at 120 kN·m
  ≤ ~60 N·m of T − τ_L mismatch;
- bending-moment cross-talk into the flange, 2e-4·m_bend (≈10 N·m, constant);
- output-encoder eccentricity, once per revolution, ≈5e-6 rad (1 arcsec) amplitude;
- motor torque-constant mismatch ±2 % (current sharing; currents only);
- dynamometer loop error and broadband torque noise (above; measured by the load cell);
- initial position within ±2e-3 rad of zero and winding temperatures 0–2 K above the gearbox.

EFFECTS ({name: {"form", "scale"}}, scale 0…10, contribution linear in scale; sizes at scale 1)
Friction effects act in F_o (Eq. 4 departs; the twist law does not):
- stribeck: Coulomb level f_c + s·300·φ(|q̇|/v_s), v_s = 0.006 rad/s (about twice the output
  speed at 300 r/min; 21 % of top speed): "exponential" φ = exp(−x), "gaussian" exp(−x²),
  "lorentzian" 1/(1+x²), "exp_1p5" exp(−x^1.5). It also raises the breakaway (stiction) level,
  since the GMS elements hold up to it at rest. Seen at 300 r/min (≈190–245 N·m at scale 1),
  at starts/stops and at scheme-3 reversals; ≈0–12 N·m at 3000 r/min. Physics limit: the
  falling slope (≤ 300·s/v_s N·m·s/rad) fights the transmission damping (≈8e4 N·m·s/rad); from
  scale ≈2 at low speed the joint stick-slips at reversals (and at 300 r/min from scale ≈3):
  no longer linear there.
- load_dependent_friction (|T| = flange torque, T_r = 120 kN·m):
  "coulomb_linear" f_c + s·0.0025·|T| (300 N·m at rated);
  "coulomb_viscous" (f_c, f_v)·(1 + s·0.115·|T|/T_r);
  "power_flow" f_c + s·μ·|T|, μ = 0.0025 when driving (T·q̇ > 0), 0.001 when back-driven;
  "quadratic" f_c + s·300·(T/T_r)².
- temperature_friction (θ = true gearbox temperature, θ_r = 35 °C; levels clipped ≥ 10 %):
  "viscous_exponential" f_v·(1 + s·(exp(−0.046(θ−θ_r)) − 1)) (+150 %/−68 % at 15/60 °C);
  "coulomb_linear" f_c − s·12·(θ−θ_r) N·m;
  "both_linear" (f_c, f_v)·(1 − s·0.005·(θ−θ_r));
  "viscous_vogel" f_v·(1 + s·(exp(700/(θ+95) − 700/(θ_r+95)) − 1)).
- asymmetric_friction (one-sided so friction stays positive at any scale):
  "coulomb_positive" +s·250 N·m Coulomb when sliding q̇ > 0; "coulomb_negative" the same for
  q̇ < 0; "viscous_positive" f_v·(1 + 0.5·s) for q̇ > 0; "both_positive" +s·150 N·m and
  f_v·(1 + 0.3·s) for q̇ > 0.
- gear_ripple (phase φ drawn per campaign; z = 96 output-mesh cycles per output revolution):
  "output_torque" torque s·250·sin(z·q + φ) on the output (Eq. 4 departs);
  "load_modulated" s·250·(0.25 + |T|/T_r)·sin(z·q + φ) on the output (Eq. 4 departs);
  "output_kinematic" transmission error s·2e-5·(sin(z q+φ) + 0.3 sin(2z q+φ')) rad in stage 2
  (twist law departs by ≈ k·ε, ≈275 N·m);
  "input_kinematic" s·2e-5·sin(2·N2·θ + φ) rad in stage 1: two cycles per revolution of the
  reducer output shaft, i.e. 200 per output revolution (twist law departs).
- torque_offset (flange channel only; both laws see it): "constant" s·300 N·m;
  "linear_drift" s·5 N·m/s·t; "warmup" s·400·(1 − exp(−t/15 s)); "thermal" s·12·(θ − 35) N·m.
- time_delay: "torque_transport" torque channel s·20 ms later; "torque_lowpass" extra first-order
  lag s·15 ms on the torque channel; "encoder" q and qd s·3 ms later; "load_cell" torque_load
  s·20 ms later. (Delays are linear in scale; their effect is linear for small delays.)
- hysteresis (stage 2, T2 += s·300·(k2/k)·x, so that the whole-transmission law T vs Δ sees a
  hysteretic torque ±300 N·m: loop width 600 N·m or ≈4.4e-5 rad of twist; x dimensionless,
  δh = 2e-5 rad of stage-2 deflection): "bouc_wen" n = 1, β = γ = 0.5:
  dx = dδ2/δh·(1 − (β·sgn(dδ2·x) + γ)|x|);
  "bouc_wen_n2" the same with |x|²; "dahl" dx = dδ2/δh·(1 − x·sgn(dδ2)); "play" three
  Prandtl–Ishlinskii play operators (radii 0.5, 1.5, 3 δh, weights 0.5, 0.3, 0.2).
- backlash (stage 1, half-gap b = s·3e-5 rad): "sharp" dead zone; "smooth" δ − b·tanh(δ/b);
  "preloaded" δ − 0.9·clip(δ, −b, b) (an anti-backlash spring keeps 10 % stiffness in the gap).
  Shows as a twist offset b·sgn(T) and a flat spot at torque reversals (twist law departs).
OUT OF VOCABULARY:
- periodic_disturbance: "output_sine" s·300·sin(2π·2.3 t + φ) N·m on the output (Eq. 4
  departs); "pump_harmonics" s·250·(sin ωt + 0.5 sin(2ωt+φ2) + 0.25 sin(3ωt+φ3)), ω = 2π·1.3
  on the output; "mains_pickup" s·300·sin(2π·50 t + φ) N·m added to the torque channel (aliases
  below 600 Hz sampling: to 4 Hz at 18 Hz).
- position_stiffness: both stages' stiffness × (1 + s·0.004·ψ(q)): "once_per_rev"
  ψ = cos(q − φ), "twice_per_rev" ψ = cos(2q − φ), "linear" ψ = q/(1 rad). At rated load
  ≈3.5e-5 rad of twist per 0.4 % (twist law departs, position-dependent).
- sensor_drift: "load_cell_linear" torque_load + s·6 N·m/s·t; "load_cell_warmup" torque_load
  + s·350·(1 − exp(−t/20 s)) (Eq. 4 departs, twist law does not); "encoder_linear" q + s·1e-6
  rad/s·t (twist law departs, ≈5.5e-5 rad after 55 s).
- second_resonance (lightly damped modes, excited by the dynamometer's broadband torque noise, the
  load steps and reversals; each contribution exactly linear in scale; a spectral line, aliased
  at low sample rates):
  "loading_shaft" a 9 Hz, ζ = 0.04 torsional mode of the loading shaft between the load cell and
  the output flange: the output feels τ_L + s·(y − τ_L), y the mode's response to τ_L, while the
  load cell reads τ_L (Eq. 4 departs, ≈130 N·m rms at scale 1 in scheme 2, peak near 8–9 Hz);
  "transmission_mode" a 17 Hz, ζ = 0.04 ringing of the motor couplings (between the motor
  encoders and the gearbox input) under the transmitted torque: the motor-side angle reads an
  extra φ = s·3·(y17 − T)/k, y17 the mode's response to T (the twist law departs, ≈110 N·m rms
  at scale 1 in scheme 2; the output dynamics are untouched).

Scale 0 reproduces the nominal run bit for bit (zero-scale effects are dropped), and the random
draws (campaign and run) never depend on which effects are on.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from datetime import datetime, timedelta, timezone

import numpy as np
import pandas as pd
from numba import njit

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "rig_p"
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "exp_1p5"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_viscous", "power_flow", "quadratic"),
    "temperature_friction": ("viscous_exponential", "coulomb_linear", "both_linear",
                             "viscous_vogel"),
    "gear_ripple": ("output_torque", "load_modulated", "output_kinematic", "input_kinematic"),
    "torque_offset": ("constant", "linear_drift", "warmup", "thermal"),
    "time_delay": ("torque_transport", "torque_lowpass", "encoder", "load_cell"),
    "hysteresis": ("bouc_wen", "bouc_wen_n2", "dahl", "play"),
    "backlash": ("sharp", "smooth", "preloaded"),
    "asymmetric_friction": ("coulomb_positive", "coulomb_negative", "viscous_positive",
                            "both_positive"),
    # outside the vocabulary of rig.md
    "periodic_disturbance": ("output_sine", "pump_harmonics", "mains_pickup"),
    "position_stiffness": ("once_per_rev", "twice_per_rev", "linear"),
    "sensor_drift": ("load_cell_linear", "load_cell_warmup", "encoder_linear"),
    "second_resonance": ("loading_shaft", "transmission_mode"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_stiffness",
                                      "sensor_drift", "second_resonance")

# --- fixed design values ------------------------------------------------------------------------
G_ACC = 9.81
T_RATED = 120000.0
N1, N2 = 110.0, 100.0
MAX_RPM = 3000.0
TOP_SPEED = MAX_RPM * 2.0 * math.pi / 60.0 / REDUCTION    # 0.02856 rad/s at the output
THETA_REF = 35.0
FOURIER_PERIOD = 25.0
FOURIER_A = np.array([0.01851401, -0.00541476, 0.00044473, -0.00597297, -0.00757101])
FOURIER_B = np.array([0.01390304, -0.00125545, -0.00751281, -0.00035114, 0.00251017])
GMS_FRAC = np.array([0.3, 0.3, 0.25, 0.15])          # share of f_c per Maxwell-slip element
GMS_DEFL = np.array([4e-6, 1.5e-5, 4.5e-5, 1.2e-4])   # presliding deflection of each [rad]
HYST_H, HYST_DH = 300.0, 2e-5
STRIBECK_VS = 0.006
PLAY_R = np.array([0.5, 1.5, 3.0])
PLAY_W = np.array([0.5, 0.3, 0.2])
BACKLASH_B = 3e-5
RIPPLE_Z = 96.0
TM_GAIN = 3.0
MAX_SAMPLE_RATE = 10000.0
DT_MAX = 5e-4

# --- kernel parameter vector indices ---------------------------------------------------------------
(I_IO, I_MRX, I_MRY, I_FC, I_FV, I_K1, I_K2, I_C1, I_C2, I_JI, I_JU, I_FCM, I_FVM, I_ETAL,
 I_KT1, I_KT2, I_KT3, I_KTN, I_TAUI, I_IMAX, I_KP, I_KI, I_KPOS, I_TAUD, I_DYNA, I_DYNB,
 I_DYNF, I_DYNPH, I_CJ, I_RJ, I_TAMB, I_CM, I_RM, I_RW, I_KFE, I_ECC, I_ECCPH, I_QRES,
 I_OBSW, I_TFILT, I_RIPPH, I_RIPPH2, I_DISTPH, I_DISTPH2, I_DISTPH3, I_STIFPH, I_KSUM,
 I_DT, I_THETA0, I_TM0, I_Q0, I_CF) = range(52)
N_P = 56

# effect slots in the kernel's code/scale arrays
(E_STRIB, E_LOAD, E_TEMP, E_RIPPLE, E_HYST, E_BACK, E_ASYM, E_DIST, E_STIFF, E_RES) = range(10)
N_E = 10

# per-sample record columns of the kernel
REC = ("t", "q", "qd", "qdd", "u", "ud", "theta", "T1", "torque", "torque_load", "tau_m",
       "i1", "i2", "i3", "friction", "gravity", "temp_joint", "temp_m1", "temp_m2", "temp_m3",
       "ripple_torque", "disturbance", "hyst_torque", "kin_error", "motor_friction",
       "secondary_torque", "coulomb_level", "viscous_coef")
R = {name: i for i, name in enumerate(REC)}
N_REC = len(REC)
# per-step record columns (for channel delays and filters)
S_TF, S_Q, S_QD, S_TL, S_T2 = range(5)


@dataclass
class SensorSpec:
    """What the bench's data sheet states of its sensors (see the module docstring)."""
    sample_rate_hz: float = 1000.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0
    torque_lag_s: float = 0.0
    load_noise: float = 100.0
    torque_res: float = 1.0
    load_res: float = 1.0
    torque_bandwidth_hz: float = 500.0
    motor_encoder_bits: int = 20
    qd_observer_hz: float = 3.0
    current_noise: float = 0.02
    current_res: float = 0.001
    speed_noise: float = 0.05
    temp_noise: float = 0.05
    temp_res: float = 0.1
    bend_noise: float = 300.0
    shear_noise: float = 200.0
    pressure_noise: float = 2.0e4


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict = field(default_factory=dict)


# =================================================================================================
# numba kernel
# =================================================================================================

@njit(cache=True)
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def _backlash(d, code, b):
    """Stage-1 spring law f(δ) (twist-equivalent) and its slope, per backlash form."""
    if code == 0 or b <= 0.0:
        return d, 1.0
    if code == 1:  # sharp dead zone
        if d > b:
            return d - b, 1.0
        if d < -b:
            return d + b, 1.0
        return 0.0, 0.0
    if code == 2:  # smooth
        th = math.tanh(d / b)
        return d - b * th, 1.0 - (1.0 - th * th)
    # preloaded
    if d > b:
        return d - 0.9 * b, 1.0
    if d < -b:
        return d + 0.9 * b, 1.0
    return 0.1 * d, 0.1


@njit(cache=True)
def _stribeck_shape(code, x):
    if code == 1:
        return math.exp(-x)
    if code == 2:
        return math.exp(-x * x)
    if code == 3:
        return 1.0 / (1.0 + x * x)
    return math.exp(-x * math.sqrt(x))


@njit(cache=True)
def _friction_levels(p, ec, es, v, T, theta):
    """Coulomb levels (sliding +, sliding −) and viscous coefficients (v>0, v<0)."""
    fc = p[I_FC]
    fv = p[I_FV]
    cp = fc
    cn = fc
    vp = fv
    vn = fv
    av = abs(v)
    # stribeck
    if ec[E_STRIB] != 0:
        d = es[E_STRIB] * 300.0 * _stribeck_shape(ec[E_STRIB], av / STRIBECK_VS)
        cp += d
        cn += d
    # load-dependent
    if ec[E_LOAD] != 0:
        s = es[E_LOAD]
        aT = abs(T)
        c = ec[E_LOAD]
        if c == 1:
            cp += s * 0.0025 * aT
            cn += s * 0.0025 * aT
        elif c == 2:
            m = s * 0.115 * aT / T_RATED
            cp += fc * m
            cn += fc * m
            vp += fv * m
            vn += fv * m
        elif c == 3:
            mu = 0.0025 if T * v >= 0.0 else 0.001
            cp += s * mu * aT
            cn += s * mu * aT
        else:
            d = s * 300.0 * (T / T_RATED) ** 2
            cp += d
            cn += d
    # temperature
    if ec[E_TEMP] != 0:
        s = es[E_TEMP]
        dth = theta - THETA_REF
        c = ec[E_TEMP]
        if c == 1:
            m = max(1.0 + s * (math.exp(-0.046 * dth) - 1.0), 0.1)
            vp *= m
            vn *= m
        elif c == 2:
            cp = max(cp - s * 12.0 * dth, 0.1 * cp)
            cn = max(cn - s * 12.0 * dth, 0.1 * cn)
        elif c == 3:
            m = max(1.0 - s * 0.005 * dth, 0.1)
            cp *= m
            cn *= m
            vp *= m
            vn *= m
        else:
            m = max(1.0 + s * (math.exp(700.0 / (theta + 95.0) - 700.0 / (THETA_REF + 95.0))
                               - 1.0), 0.1)
            vp *= m
            vn *= m
    # asymmetric
    if ec[E_ASYM] != 0:
        s = es[E_ASYM]
        c = ec[E_ASYM]
        if c == 1:
            cp += s * 250.0
        elif c == 2:
            cn += s * 250.0
        elif c == 3:
            vp += fv * 0.5 * s
        else:
            cp += s * 150.0
            vp += fv * 0.3 * s
    return cp, cn, vp, vn


@njit(cache=True)
def _stage_forces(p, ec, es, u, ud, th, thd, q, qd, xh_t):
    """Stage torques T1, T2 (T2 includes the hysteretic torque xh_t), and the kinematic error."""
    kmul = 1.0
    if ec[E_STIFF] != 0:
        c = ec[E_STIFF]
        if c == 1:
            psi = math.cos(q - p[I_STIFPH])
        elif c == 2:
            psi = math.cos(2.0 * q - p[I_STIFPH])
        else:
            psi = q
        kmul = 1.0 + es[E_STIFF] * 0.004 * psi
    eps1 = 0.0
    eps2 = 0.0
    if ec[E_RIPPLE] == 3:
        eps2 = es[E_RIPPLE] * 2e-5 * (math.sin(RIPPLE_Z * q + p[I_RIPPH])
                                      + 0.3 * math.sin(2.0 * RIPPLE_Z * q + p[I_RIPPH2]))
    elif ec[E_RIPPLE] == 4:
        eps1 = es[E_RIPPLE] * 2e-5 * math.sin(2.0 * N2 * th + p[I_RIPPH])
    d1 = u - th - eps1
    fb, fbp = _backlash(d1, ec[E_BACK], es[E_BACK] * BACKLASH_B)
    T1 = p[I_K1] * kmul * fb + p[I_C1] * fbp * (ud - thd)
    d2 = th - q - eps2
    T2 = p[I_K2] * kmul * d2 + p[I_C2] * (thd - qd) + xh_t
    return T1, T2, eps1 + eps2, d2


@njit(cache=True)
def _static_stage1(p, ec, es, T, th, q):
    """δ1 such that the stage-1 spring carries T at rest (bisection on the monotone law)."""
    lo = -0.05
    hi = 0.05
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        T1, T2, e, d2 = _stage_forces(p, ec, es, th + mid, 0.0, th, 0.0, q, 0.0, 0.0)
        if T1 < T:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@njit(cache=True)
def _quant(x, res):
    return math.floor(x / res + 0.5) * res


@njit(cache=True)
def _kernel(p, ec, es, n_steps, m, u_ref, ud_ref, tau_cmd, dyn_noise, rec, steprec):
    dt = p[I_DT]
    Io = p[I_IO]
    Ji = p[I_JI]
    Ju = p[I_JU]
    kt1 = p[I_KT1]
    kt2 = p[I_KT2]
    kt3 = p[I_KT3]
    ai = 1.0 - math.exp(-dt / p[I_TAUI])
    ad = 1.0 - math.exp(-dt / p[I_TAUD])
    af = 1.0 - math.exp(-dt * 2.0 * math.pi * p[I_TFILT])
    obs_w = 2.0 * math.pi * p[I_OBSW]
    ngms = GMS_FRAC.shape[0]
    kf = np.empty(ngms)
    cf = np.empty(ngms)
    for j in range(ngms):
        kf[j] = p[I_FC] * GMS_FRAC[j] / GMS_DEFL[j]
        cf[j] = p[I_CF] * 2.0 * math.sqrt(kf[j] * Io)
    z = np.zeros(ngms)
    zd = np.zeros(ngms)
    # secondary modes
    # loading-shaft resonance (second_resonance "loading_shaft"): a 9 Hz, ζ = 0.04 mode between
    # the load cell and the output flange; the output feels τ_L + s·(y − τ_L)
    s_res = es[E_RES] if ec[E_RES] == 1 else 0.0
    w_ls = 2.0 * math.pi * 9.0
    z_ls = 0.04
    # hysteresis
    hcode = ec[E_HYST]
    hs = es[E_HYST] * HYST_H * p[I_K2] / p[I_KSUM]   # apparent ±HYST_H in T vs Δ
    xh = np.zeros(3)
    # ---- initial state: at rest, gravity held by the transmission ----
    q = p[I_Q0]
    G0 = G_ACC * (p[I_MRX] * math.sin(q) + p[I_MRY] * math.cos(q))
    tauL = dyn_noise[0]
    T0 = G0 + tauL
    kmul0 = 1.0
    if ec[E_STIFF] != 0:
        c = ec[E_STIFF]
        if c == 1:
            kmul0 = 1.0 + es[E_STIFF] * 0.004 * math.cos(q - p[I_STIFPH])
        elif c == 2:
            kmul0 = 1.0 + es[E_STIFF] * 0.004 * math.cos(2.0 * q - p[I_STIFPH])
        else:
            kmul0 = 1.0 + es[E_STIFF] * 0.004 * q
    eps2_0 = 0.0
    if ec[E_RIPPLE] == 3:
        eps2_0 = es[E_RIPPLE] * 2e-5 * (math.sin(RIPPLE_Z * q + p[I_RIPPH])
                                        + 0.3 * math.sin(2.0 * RIPPLE_Z * q + p[I_RIPPH2]))
    th = q + eps2_0 + T0 / (p[I_K2] * kmul0)
    d1 = _static_stage1(p, ec, es, T0, th, q)
    u = th + d1
    qd = 0.0
    thd = 0.0
    ud = 0.0
    y_ls = tauL
    yd_ls = 0.0
    theta = p[I_THETA0]
    tm1 = p[I_TM0]
    tm2 = p[I_TM0 + 1]
    tm3 = p[I_TM0 + 2]
    i1 = 0.0
    i2 = 0.0
    i3 = 0.0
    # drive enabled at rest: the speed-loop integrator holds the initial torque
    ktsum = kt1 + kt2 + kt3
    integ = T0 * 3.0 * p[I_KTN] / ktsum
    ist = integ / (3.0 * p[I_KTN] * REDUCTION)
    i1 = ist
    i2 = ist
    i3 = ist
    tau_m = REDUCTION * (kt1 * i1 + kt2 * i2 + kt3 * i3)
    d1 = _static_stage1(p, ec, es, tau_m, th, q)
    u = th + d1
    u0 = u
    # torque flange filter, observer
    Tf = T0
    qm0 = _quant(q + p[I_ECC] * math.sin(q - p[I_ECCPH]), p[I_QRES])
    obs_q = qm0
    obs_v = 0.0
    qdd = 0.0
    F = 0.0
    Gq = G0
    T1 = tau_m
    T2 = T0
    eps = 0.0
    ripple = 0.0
    dist = 0.0
    Fm = 0.0
    sec = 0.0
    cp = p[I_FC]
    vp = p[I_FV]
    d2_prev = th - q
    k = 0
    for n in range(n_steps + 1):
        t = n * dt
        # ---------------- forces at the current state ----------------
        T1, T2, eps, d2 = _stage_forces(p, ec, es, u, ud, th, thd, q, qd, hs * (
            xh[0] if hcode != 4 else (0.5 * xh[0] + 0.3 * xh[1] + 0.2 * xh[2])))
        Gq = G_ACC * (p[I_MRX] * math.sin(q) + p[I_MRY] * math.cos(q))
        cp, cn, vp, vn = _friction_levels(p, ec, es, qd, T2, theta)
        Fgms = 0.0
        for j in range(ngms):
            Fgms += kf[j] * z[j] + cf[j] * zd[j]
        F = Fgms + (vp if qd > 0.0 else vn) * qd
        ripple = 0.0
        if ec[E_RIPPLE] == 1:
            ripple = es[E_RIPPLE] * 250.0 * math.sin(RIPPLE_Z * q + p[I_RIPPH])
        elif ec[E_RIPPLE] == 2:
            ripple = es[E_RIPPLE] * 250.0 * (0.25 + abs(T2) / T_RATED) * math.sin(
                RIPPLE_Z * q + p[I_RIPPH])
        dist = 0.0
        if ec[E_DIST] == 1:
            dist = es[E_DIST] * 300.0 * math.sin(2.0 * math.pi * 2.3 * t + p[I_DISTPH])
        elif ec[E_DIST] == 2:
            wp = 2.0 * math.pi * 1.3 * t
            dist = es[E_DIST] * 250.0 * (math.sin(wp + p[I_DISTPH])
                                         + 0.5 * math.sin(2.0 * wp + p[I_DISTPH2])
                                         + 0.25 * math.sin(3.0 * wp + p[I_DISTPH3]))
        sec_o = 0.0
        if s_res > 0.0:
            sec_o = -s_res * (y_ls - tauL)
        sec_i = 0.0
        sec = sec_o + sec_i
        # motor side
        Fm = p[I_FCM] * math.tanh(ud / 2e-5) + p[I_FVM] * ud + p[I_ETAL] * abs(T1) * math.tanh(
            ud / 2e-5)
        tau_m = REDUCTION * (kt1 * i1 + kt2 * i2 + kt3 * i3)
        # ---------------- record ----------------
        steprec[n, S_TF] = Tf
        steprec[n, S_Q] = q
        steprec[n, S_QD] = obs_v
        steprec[n, S_TL] = tauL
        steprec[n, S_T2] = T2
        qdd = (T2 - tauL - Gq - F - ripple - dist + sec_o) / Io
        if n % m == 0:
            rec[k, 0] = t
            rec[k, 1] = q
            rec[k, 2] = qd
            rec[k, 3] = qdd
            rec[k, 4] = u
            rec[k, 5] = ud
            rec[k, 6] = th
            rec[k, 7] = T1
            rec[k, 8] = T2
            rec[k, 9] = tauL
            rec[k, 10] = tau_m
            rec[k, 11] = i1
            rec[k, 12] = i2
            rec[k, 13] = i3
            rec[k, 14] = F
            rec[k, 15] = Gq
            rec[k, 16] = theta
            rec[k, 17] = tm1
            rec[k, 18] = tm2
            rec[k, 19] = tm3
            rec[k, 20] = ripple
            rec[k, 21] = dist
            rec[k, 22] = hs * (xh[0] if hcode != 4 else (0.5 * xh[0] + 0.3 * xh[1] + 0.2 * xh[2]))
            rec[k, 23] = eps
            rec[k, 24] = Fm
            rec[k, 25] = sec
            rec[k, 26] = cp if qd >= 0.0 else cn
            rec[k, 27] = vp if qd >= 0.0 else vn
            k += 1
        if n == n_steps:
            break
        # ---------------- drive control ----------------
        w_err = ud_ref[n] + p[I_KPOS] * (u0 + u_ref[n] - u) - ud
        integ += p[I_KI] * w_err * dt
        tdem = p[I_KP] * w_err + integ
        istar = tdem / (3.0 * p[I_KTN] * REDUCTION)
        if istar > p[I_IMAX]:
            istar = p[I_IMAX]
        elif istar < -p[I_IMAX]:
            istar = -p[I_IMAX]
        i1 += (istar - i1) * ai
        i2 += (istar - i2) * ai
        i3 += (istar - i3) * ai
        # ---------------- dynamometer ----------------
        cmd = tau_cmd[n]
        target = cmd + (p[I_DYNA] + p[I_DYNB] * abs(cmd)) * math.sin(
            2.0 * math.pi * p[I_DYNF] * t + p[I_DYNPH])
        tauL_lag = tauL - dyn_noise[n]
        tauL_lag += (target - tauL_lag) * ad
        # ---------------- integrate (semi-implicit Euler) ----------------
        udd = (tau_m - T1 - Fm) / Ju
        thdd = (T1 - T2) / Ji
        ud += udd * dt
        thd += thdd * dt
        qd += qdd * dt
        u += ud * dt
        th += thd * dt
        q_old = q
        q += qd * dt
        if s_res > 0.0:
            yd_ls += (w_ls * w_ls * (tauL - y_ls) - 2.0 * z_ls * w_ls * yd_ls) * dt
            y_ls += yd_ls * dt
        tauL = tauL_lag + dyn_noise[n + 1]
        # friction elements (elasto-plastic Maxwell slip), with the new velocity's levels
        dq = q - q_old
        for j in range(ngms):
            zo = z[j]
            zn = zo + dq
            up = cp * GMS_FRAC[j] / kf[j]
            lo = -cn * GMS_FRAC[j] / kf[j]
            if zn > up:
                zn = up
            elif zn < lo:
                zn = lo
            z[j] = zn
            zd[j] = (zn - zo) / dt
        # hysteresis state, driven by the stage-2 deflection
        d2n = th - q
        if hcode != 0:
            dd = d2n - d2_prev
            if hcode == 1:
                x = xh[0]
                xh[0] = x + dd / HYST_DH * (1.0 - (0.5 * _sgn(dd * x) + 0.5) * abs(x))
            elif hcode == 2:
                x = xh[0]
                xh[0] = x + dd / HYST_DH * (1.0 - (0.5 * _sgn(dd * x) + 0.5) * x * x)
            elif hcode == 3:
                x = xh[0]
                xh[0] = x + dd / HYST_DH * (1.0 - x * _sgn(dd))
            else:
                # Prandtl-Ishlinskii play operators; xh[j] = (δ2 − P_j)/r_j in [−1, 1]
                for j in range(3):
                    r = HYST_DH * PLAY_R[j]
                    pj = d2_prev - xh[j] * r
                    if d2n - pj > r:
                        pj = d2n - r
                    elif d2n - pj < -r:
                        pj = d2n + r
                    xh[j] = (d2n - pj) / r
            if hcode != 4:
                if xh[0] > 1.2:
                    xh[0] = 1.2
                elif xh[0] < -1.2:
                    xh[0] = -1.2
        d2_prev = d2n
        # thermal
        Ploss = abs(F * qd) + abs(Fm * ud)
        theta += dt * (Ploss - (theta - p[I_TAMB]) / p[I_RJ]) / p[I_CJ]
        wm = REDUCTION * ud
        pfe = p[I_KFE] * wm * wm
        tm1 += dt * (p[I_RW] * i1 * i1 + pfe - (tm1 - theta) / p[I_RM]) / p[I_CM]
        tm2 += dt * (p[I_RW] * i2 * i2 + pfe - (tm2 - theta) / p[I_RM]) / p[I_CM]
        tm3 += dt * (p[I_RW] * i3 * i3 + pfe - (tm3 - theta) / p[I_RM]) / p[I_CM]
        # flange amplifier and the velocity observer (both run at the internal rate)
        Tf += (T2 - Tf) * af
        qm = _quant(q + p[I_ECC] * math.sin(q - p[I_ECCPH]), p[I_QRES])
        e = qm - obs_q
        obs_q += (obs_v + 2.0 * 0.9 * obs_w * e) * dt
        obs_v += obs_w * obs_w * e * dt
    return k


# =================================================================================================
# scheme references
# =================================================================================================

def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _duration(scheme: int, periods: int) -> float:
    return 55.0 if scheme in (1, 2) else 4.0 + FOURIER_PERIOD * periods


def _fourier(t):
    """Eq. 12 trajectory (q, q̇) for t ≥ 0, q(0) = 0."""
    wf = 2.0 * math.pi / FOURIER_PERIOD
    L = np.arange(1, 6, dtype=float)
    ph = wf * np.outer(t, L)
    a, b = FOURIER_A, FOURIER_B
    q = (np.sin(ph) * (a / (wf * L)) - np.cos(ph) * (b / (wf * L))).sum(1) + (b / (wf * L)).sum()
    qd = (np.cos(ph) * a + np.sin(ph) * b).sum(1)
    return q, qd


def _references(scheme, rpm, direction, periods, t):
    """Per-step references: motor speed ud_ref and position u_ref (output-referred), the
    dynamometer set point and the phase of each instant."""
    n = len(t)
    phase = np.full(n, "idle", dtype=object)
    cmd = np.zeros(n)
    u_ref = np.zeros(n)
    if scheme in (1, 2):
        v = direction * rpm * 2.0 * math.pi / 60.0 / REDUCTION
        ud_ref = v * (_smoothstep(t - 1.0) - _smoothstep(t - 53.0))
        if scheme == 1:
            up = (t >= 3.0) & (t < 27.0)
            hold = (t >= 27.0) & (t < 28.0)
            down = (t >= 28.0) & (t < 52.0)
            cmd[up] = T_RATED * (t[up] - 3.0) / 24.0
            cmd[hold] = T_RATED
            cmd[down] = T_RATED * (1.0 - (t[down] - 28.0) / 24.0)
            phase[up] = "load"
            phase[hold] = "hold"
            phase[down] = "unload"
        else:
            for j in range(12):
                t0 = 3.0 + 3.0 * j
                ramp = (t >= t0) & (t < t0 + 1.0)
                hold = (t >= t0 + 1.0) & (t < t0 + 3.0)
                cmd[ramp] = 10000.0 * (j + (t[ramp] - t0))
                cmd[hold] = 10000.0 * (j + 1)
                phase[ramp] = "load"
                phase[hold] = "hold"
            down = (t >= 39.0) & (t < 51.0)
            cmd[down] = T_RATED * (1.0 - (t[down] - 39.0) / 12.0)
            phase[down] = "unload"
        cmd *= direction
        kpos = 0.0
    else:
        te = t - 2.0
        exc = (te >= 0.0) & (te < FOURIER_PERIOD * periods)
        q, qd = _fourier(np.where(exc, te, 0.0))
        u_ref = np.where(exc, direction * q, 0.0)
        ud_ref = np.where(exc, direction * qd, 0.0)
        phase[exc] = "excite"
        kpos = 5.0
    return ud_ref, u_ref, cmd, phase, kpos


# =================================================================================================
# parameters
# =================================================================================================

def _campaign(seed: int) -> dict:
    """The physical rig of one campaign: every value drawn in a fixed order from the seed."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x52494750]))

    def d(nom, rel):
        return float(nom * (1.0 + rel * np.clip(rng.standard_normal(), -2.5, 2.5)))

    r = {}
    r["I"] = d(6685.0, 0.02)
    r["mr_x"] = d(20.8, 0.05)
    r["mr_y"] = d(-34.5, 0.05)
    r["f_c"] = d(2353.0, 0.04)
    r["f_v"] = d(8683.0, 0.04)
    r["k"] = d(1.375e7, 0.03)
    r["stage_ratio"] = d(0.8, 0.05)            # k1/k2
    r["zeta_t"] = d(0.12, 0.1)
    r["J_i"] = d(800.0, 0.05)
    r["J_m"] = d(1.6e-3, 0.03)
    r["f_cm"] = d(1500.0, 0.08)
    r["f_vm"] = d(4.0e4, 0.08)
    r["eta_loss"] = d(0.04, 0.1)
    r["k_t_nominal"] = 1.35
    r["k_t"] = [d(1.35, 0.02) for _ in range(3)]
    r["tau_current"] = 1e-3
    r["i_max"] = 10.0
    r["speed_loop_crossover"] = 40.0
    r["dyn_tau"] = d(0.12, 0.05)
    r["dyn_err_a"] = d(150.0, 0.2)
    r["dyn_err_b"] = d(0.004, 0.2)
    r["dyn_err_f"] = d(0.23, 0.1)
    r["dyn_err_phase"] = float(rng.uniform(0, 2 * math.pi))
    r["dyn_noise_rms"] = d(80.0, 0.1)
    r["C_joint"] = d(25000.0, 0.05)
    r["R_joint"] = d(0.05, 0.05)
    r["T_ambient"] = float(22.0 + rng.uniform(-1.0, 1.0))
    r["C_motor"] = d(2000.0, 0.05)
    r["R_motor"] = d(0.4, 0.05)
    r["R_winding"] = d(1.8, 0.05)
    r["k_iron"] = d(2e-4, 0.1)
    r["presliding_damping_ratio"] = 0.3
    r["bend_setpoint"] = 50000.0
    r["shear_setpoint"] = 90000.0
    r["bend_actual"] = d(50000.0, 0.002)
    r["shear_actual"] = d(90000.0, 0.002)
    u = {}
    u["encoder_eccentricity_rad"] = d(5e-6, 0.3)
    u["encoder_eccentricity_phase"] = float(rng.uniform(0, 2 * math.pi))
    u["torque_gain_error"] = float(np.clip(rng.normal(0.0, 2e-4), -5e-4, 5e-4))
    u["load_gain_error"] = float(np.clip(rng.normal(0.0, 2e-4), -5e-4, 5e-4))
    u["bending_crosstalk"] = d(2e-4, 0.3)
    u["motor_kt_mismatch"] = [kt / 1.35 - 1.0 for kt in r["k_t"]]
    u["dynamometer_loop_error_nm"] = "a + b*|set point|, sine at dyn_err_f (see rig)"
    u["dynamometer_noise_rms_nm"] = r["dyn_noise_rms"]
    ph = {f"phase_{i}": float(rng.uniform(0, 2 * math.pi)) for i in range(7)}
    r["effect_phases"] = ph
    r["k1"] = r["k"] * (1.0 + r["stage_ratio"])
    r["k2"] = r["k"] * (1.0 + r["stage_ratio"]) / r["stage_ratio"]
    r["D"] = 2.0 * r["zeta_t"] * math.sqrt(r["k"] * r["I"])
    r["c1"] = r["D"] * r["k1"] / r["k"]
    r["c2"] = r["D"] * r["k2"] / r["k"]
    r["J_u"] = 3.0 * r["J_m"] * REDUCTION ** 2
    r["unstated"] = u
    return r


def _validate_sensors(sensors) -> None:
    if not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {type(sensors).__name__}")
    for f, v in asdict(sensors).items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"sensors.{f} must be a finite number, got {v!r}")
    s = sensors
    if not 0.0 < s.sample_rate_hz <= MAX_SAMPLE_RATE:
        raise ValueError(f"sensors.sample_rate_hz must be in (0, {MAX_SAMPLE_RATE}], "
                         f"got {s.sample_rate_hz!r}")
    if not 0.0 < s.encoder_res_deg <= 1.0:
        raise ValueError(f"sensors.encoder_res_deg must be in (0, 1], got {s.encoder_res_deg!r}")
    if not 0.0 <= s.torque_lag_s <= 0.5:
        raise ValueError(f"sensors.torque_lag_s must be in [0, 0.5], got {s.torque_lag_s!r}")
    for f in ("torque_noise", "load_noise", "current_noise", "speed_noise", "temp_noise",
              "bend_noise", "shear_noise", "pressure_noise"):
        if getattr(s, f) < 0.0:
            raise ValueError(f"sensors.{f} must be >= 0, got {getattr(s, f)!r}")
    for f in ("torque_res", "load_res", "current_res", "temp_res", "torque_bandwidth_hz",
              "qd_observer_hz"):
        if not getattr(s, f) > 0.0:
            raise ValueError(f"sensors.{f} must be > 0, got {getattr(s, f)!r}")
    if not (float(s.motor_encoder_bits).is_integer() and 8 <= s.motor_encoder_bits <= 32):
        raise ValueError(f"sensors.motor_encoder_bits must be an integer in 8..32, "
                         f"got {s.motor_encoder_bits!r}")
    if s.qd_observer_hz > 50.0:
        raise ValueError(f"sensors.qd_observer_hz must be <= 50, got {s.qd_observer_hz!r}")


def _is_int(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool)


def _is_real(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def _parse_effects(effects) -> dict[str, tuple[str, float]]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict {{name: {{'form', 'scale'}}}}, "
                         f"got {type(effects).__name__}")
    out = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effects[{name!r}] must be a dict with 'form' and 'scale'")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effects[{name!r}]: unknown keys {sorted(extra)}")
        if "form" not in spec or "scale" not in spec:
            raise ValueError(f"effects[{name!r}] needs both 'form' and 'scale'")
        form = spec["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}]: unknown form {form!r}; "
                             f"known: {EFFECT_FORMS[name]}")
        sc = spec["scale"]
        if not _is_real(sc) or not math.isfinite(float(sc)):
            raise ValueError(f"effects[{name!r}]: scale must be a finite number, got {sc!r}")
        sc = float(sc)
        if not 0.0 <= sc <= SCALE_MAX:
            raise ValueError(f"effects[{name!r}]: scale must be in [0, {SCALE_MAX}], got {sc!r}")
        if sc > 0.0:
            out[name] = (form, sc)
    return out


def _validate(scheme, motor_speed_rpm, direction, temp_joint_c, periods, seed, run):
    if not _is_int(scheme) or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
        rpm = None
    else:
        if not _is_real(motor_speed_rpm) or not math.isfinite(float(motor_speed_rpm)):
            raise ValueError(f"motor_speed_rpm must be a finite number for scheme {scheme}, "
                             f"got {motor_speed_rpm!r}")
        rpm = float(motor_speed_rpm)
        if not 0.0 < rpm <= MAX_RPM:
            raise ValueError(f"motor_speed_rpm must be in (0, {MAX_RPM}], got {rpm!r}")
    if not _is_real(direction) or float(direction) not in (1.0, -1.0):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if not _is_real(temp_joint_c) or not math.isfinite(float(temp_joint_c)):
        raise ValueError(f"temp_joint_c must be a finite number, got {temp_joint_c!r}")
    if not -20.0 <= float(temp_joint_c) <= 80.0:
        raise ValueError(f"temp_joint_c must be in [-20, 80] °C, got {temp_joint_c!r}")
    if not _is_int(periods) or not 1 <= int(periods) <= 20:
        raise ValueError(f"periods must be an integer in 1..20, got {periods!r}")
    if not _is_int(seed) or int(seed) < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if not _is_int(run) or int(run) < 0:
        raise ValueError(f"run must be a non-negative integer, got {run!r}")
    return scheme, rpm, int(float(direction)), float(temp_joint_c), int(periods)


# =================================================================================================
# the run
# =================================================================================================

def _delayed(x_step, t_s, dt, d):
    """x (recorded every internal step) read at t − d, linear interpolation, held before 0."""
    if d == 0.0:
        return x_step[np.rint(t_s / dt).astype(np.int64)]
    pos = np.clip((t_s - d) / dt, 0.0, len(x_step) - 1.0)
    i0 = np.floor(pos).astype(np.int64)
    i1 = np.minimum(i0 + 1, len(x_step) - 1)
    f = pos - i0
    return x_step[i0] * (1.0 - f) + x_step[i1] * f


def _first_order(x, dt, tau):
    a = 1.0 - math.exp(-dt / tau)
    from scipy.signal import lfilter
    y, _ = lfilter([a], [1.0, -(1.0 - a)], x, zi=[(1.0 - a) * x[0]])
    return y


def _quantise(x, res):
    return np.floor(x / res + 0.5) * res


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int,
                 temp_joint_c: float, effects: dict[str, dict] | None = None, *,
                 sensors: SensorSpec = SensorSpec(), periods: int = 3, seed: int,
                 run: int) -> RigRun:
    """Simulate one run of campaign `seed` (the rig) number `run` (see the module docstring)."""
    scheme, rpm, direction, temp0, periods = _validate(scheme, motor_speed_rpm, direction,
                                                       temp_joint_c, periods, seed, run)
    fx = _parse_effects(effects)
    _validate_sensors(sensors)
    rig = _campaign(seed)
    un = rig["unstated"]
    fs = float(sensors.sample_rate_hz)
    m = max(1, int(math.ceil(1.0 / (fs * DT_MAX) - 1e-9)))
    dt = 1.0 / (fs * m)
    T_run = _duration(scheme, periods)
    n_samp = int(math.floor(T_run * fs + 1e-9)) + 1
    n_steps = (n_samp - 1) * m
    t_step = np.arange(n_steps + 1) * dt
    t_s = np.arange(n_samp) / fs

    # ---- run draws (fixed order, independent of effects) ----
    rr = np.random.default_rng(np.random.SeedSequence([int(seed), 0x52554E, int(run)]))
    q0 = float(rr.uniform(-2e-3, 2e-3))
    tm_off = rr.uniform(0.0, 2.0, 3)
    a_ou = math.exp(-dt / 5e-3)
    w = rr.standard_normal(n_steps + 1) * (rig["dyn_noise_rms"] * math.sqrt(1.0 - a_ou * a_ou))
    from scipy.signal import lfilter
    dyn_noise, _ = lfilter([1.0], [1.0, -a_ou], w, zi=[a_ou * w[0] / math.sqrt(1 - a_ou ** 2)])
    nz = {k: rr.standard_normal(n_samp) for k in
          ("torque", "load", "i1", "i2", "i3", "w1", "w2", "w3", "ud", "tj", "tm1", "tm2", "tm3",
           "bend", "shear", "p")}
    started = datetime(2026, 3, 2, 8, 0, tzinfo=timezone.utc) + timedelta(
        days=int(seed) % 997, minutes=20 * int(run))

    # ---- kernel parameters ----
    ph = rig["effect_phases"]
    p = np.zeros(N_P)
    p[I_IO], p[I_MRX], p[I_MRY] = rig["I"], rig["mr_x"], rig["mr_y"]
    p[I_FC], p[I_FV] = rig["f_c"], rig["f_v"]
    p[I_K1], p[I_K2], p[I_C1], p[I_C2] = rig["k1"], rig["k2"], rig["c1"], rig["c2"]
    p[I_JI], p[I_JU] = rig["J_i"], rig["J_u"]
    p[I_FCM], p[I_FVM], p[I_ETAL] = rig["f_cm"], rig["f_vm"], rig["eta_loss"]
    p[I_KT1], p[I_KT2], p[I_KT3] = rig["k_t"]
    p[I_KTN], p[I_TAUI], p[I_IMAX] = rig["k_t_nominal"], rig["tau_current"], rig["i_max"]
    wc = rig["speed_loop_crossover"]
    p[I_KP] = rig["J_u"] * wc
    p[I_KI] = p[I_KP] * wc / 5.0
    p[I_TAUD], p[I_DYNA], p[I_DYNB] = rig["dyn_tau"], rig["dyn_err_a"], rig["dyn_err_b"]
    p[I_DYNF], p[I_DYNPH] = rig["dyn_err_f"], rig["dyn_err_phase"]
    p[I_CJ], p[I_RJ], p[I_TAMB] = rig["C_joint"], rig["R_joint"], rig["T_ambient"]
    p[I_CM], p[I_RM], p[I_RW], p[I_KFE] = rig["C_motor"], rig["R_motor"], rig["R_winding"], \
        rig["k_iron"]
    p[I_ECC], p[I_ECCPH] = un["encoder_eccentricity_rad"], un["encoder_eccentricity_phase"]
    q_res = math.radians(sensors.encoder_res_deg)
    p[I_QRES] = q_res
    p[I_OBSW], p[I_TFILT] = sensors.qd_observer_hz, sensors.torque_bandwidth_hz
    p[I_RIPPH], p[I_RIPPH2] = ph["phase_0"], ph["phase_1"]
    p[I_DISTPH], p[I_DISTPH2], p[I_DISTPH3] = ph["phase_2"], ph["phase_3"], ph["phase_4"]
    p[I_STIFPH] = ph["phase_5"]
    p[I_DT] = dt
    p[I_KSUM] = rig["k"]
    p[I_THETA0] = temp0
    p[I_TM0:I_TM0 + 3] = temp0 + tm_off
    p[I_Q0] = q0
    p[I_CF] = rig["presliding_damping_ratio"]

    slot = {"stribeck": E_STRIB, "load_dependent_friction": E_LOAD,
            "temperature_friction": E_TEMP, "gear_ripple": E_RIPPLE, "hysteresis": E_HYST,
            "backlash": E_BACK, "asymmetric_friction": E_ASYM, "periodic_disturbance": E_DIST,
            "position_stiffness": E_STIFF, "second_resonance": E_RES}
    ec = np.zeros(N_E, dtype=np.int64)
    es = np.zeros(N_E)
    for name, (form, sc) in fx.items():
        if name in slot:
            ec[slot[name]] = EFFECT_FORMS[name].index(form) + 1
            es[slot[name]] = sc

    ud_ref, u_ref, cmd, phase_step, kpos = _references(scheme, rpm, direction, periods, t_step)
    p[I_KPOS] = kpos
    rec = np.zeros((n_samp, N_REC))
    steprec = np.zeros((n_steps + 1, 5))
    _kernel(p, ec, es, n_steps, m, u_ref, ud_ref, cmd, dyn_noise, rec, steprec)

    # ---- sensor chains ----
    def sc_of(name, form):
        return fx[name][1] if name in fx and fx[name][0] == form else 0.0

    col = {name: rec[:, i] for i, name in enumerate(REC)}
    t = t_s
    idx = np.arange(n_samp) * m
    # torque flange
    tf = steprec[:, S_TF]
    s_lp = sc_of("time_delay", "torque_lowpass")
    if s_lp > 0.0:
        tf = _first_order(tf, dt, 0.015 * s_lp)
    d_T = sensors.torque_lag_s + 0.020 * sc_of("time_delay", "torque_transport")
    T_chan = (1.0 + un["torque_gain_error"]) * _delayed(tf, t, dt, d_T)
    bend_true = np.full(n_samp, rig["bend_actual"])
    T_chan = T_chan + un["bending_crosstalk"] * bend_true
    offset = np.zeros(n_samp)
    if "torque_offset" in fx:
        form, s = fx["torque_offset"]
        if form == "constant":
            offset = s * 300.0 * np.ones(n_samp)
        elif form == "linear_drift":
            offset = s * 5.0 * t
        elif form == "warmup":
            offset = s * 400.0 * (1.0 - np.exp(-t / 15.0))
        else:
            offset = s * 12.0 * (col["temp_joint"] - THETA_REF)
    s_mp = sc_of("periodic_disturbance", "mains_pickup")
    pickup = s_mp * 300.0 * np.sin(2.0 * math.pi * 50.0 * t + ph["phase_6"]) if s_mp > 0 \
        else np.zeros(n_samp)
    torque_meas = _quantise(T_chan + offset + pickup + sensors.torque_noise * nz["torque"],
                            sensors.torque_res)
    # load cell
    d_L = 0.020 * sc_of("time_delay", "load_cell")
    L_chan = (1.0 + un["load_gain_error"]) * _delayed(steprec[:, S_TL], t, dt, d_L)
    drift_L = np.zeros(n_samp)
    if "sensor_drift" in fx:
        form, s = fx["sensor_drift"]
        if form == "load_cell_linear":
            drift_L = s * 6.0 * t
        elif form == "load_cell_warmup":
            drift_L = s * 350.0 * (1.0 - np.exp(-t / 20.0))
    load_meas = _quantise(L_chan + drift_L + sensors.load_noise * nz["load"], sensors.load_res)
    # output encoder and its velocity observer
    d_q = 0.003 * sc_of("time_delay", "encoder")
    q_del = _delayed(steprec[:, S_Q], t, dt, d_q)
    enc_rate = 1e-6 * sc_of("sensor_drift", "encoder_linear")
    q_read = q_del + un["encoder_eccentricity_rad"] * np.sin(q_del -
                                                             un["encoder_eccentricity_phase"])
    if enc_rate > 0.0:
        q_read = q_read + enc_rate * t
    q_meas = _quantise(q_read, q_res)
    qd_meas = _delayed(steprec[:, S_QD], t, dt, d_q)
    if enc_rate > 0.0:
        qd_meas = qd_meas + enc_rate
    # motor side; second_resonance "transmission_mode": the motor coupling (between the motor
    # encoders and the gearbox input) rings at 17 Hz under the transmitted torque
    s_tm = sc_of("second_resonance", "transmission_mode")
    phi = np.zeros(n_samp)
    if s_tm > 0.0:
        from scipy.signal import bilinear
        w_c = 2.0 * math.pi * 17.0
        bz, az = bilinear([w_c * w_c], [1.0, 2.0 * 0.04 * w_c, w_c * w_c], fs=1.0 / dt)
        x = steprec[:, S_T2]
        y = lfilter(bz, az, x - x[0]) + x[0]
        phi = (s_tm * TM_GAIN * (y - x) / rig["k"])[idx]
    u_true = col["u"] + phi
    u_res = 2.0 * math.pi / 2 ** int(sensors.motor_encoder_bits) / REDUCTION
    u_meas = _quantise(u_true, u_res)
    ud_meas = col["ud"] + sensors.speed_noise / REDUCTION * nz["ud"]
    w_true = REDUCTION * col["ud"]
    samples = {
        "t": t,
        "q": q_meas,
        "qd": qd_meas,
        "u": u_meas,
        "ud": ud_meas,
        "torsion": q_meas - u_meas,
        "torque": torque_meas,
        "torque_load": load_meas,
        "torque_cmd": cmd[idx],
    }
    for k in (1, 2, 3):
        samples[f"i_m{k}"] = _quantise(col[f"i{k}"] + sensors.current_noise * nz[f"i{k}"],
                                       sensors.current_res)
    for k in (1, 2, 3):
        samples[f"w_m{k}"] = w_true + sensors.speed_noise * nz[f"w{k}"]
    for k in (1, 2, 3):
        samples[f"temp_m{k}"] = _quantise(col[f"temp_m{k}"] + sensors.temp_noise * nz[f"tm{k}"],
                                          sensors.temp_res)
    samples["temp_joint"] = _quantise(col["temp_joint"] + sensors.temp_noise * nz["tj"],
                                      sensors.temp_res)
    area, arm = 5.0e-3, 1.0
    p_true = (rig["bend_actual"] / arm + rig["shear_actual"]) / (2.0 * area)
    samples["p_hyd"] = p_true + sensors.pressure_noise * nz["p"]
    samples["m_bend"] = bend_true + sensors.bend_noise * nz["bend"]
    samples["f_shear"] = rig["shear_actual"] + sensors.shear_noise * nz["shear"]
    phase = phase_step[idx]
    samples["phase"] = pd.Series(list(phase), dtype=object)
    samples_df = pd.DataFrame(samples)

    truth = {name: col[name] for name in REC}
    truth["u"] = u_true
    truth["twist"] = u_true - col["q"]
    truth["coupling_twist"] = phi
    truth["torque_cmd"] = cmd[idx]
    truth["torque_channel_error"] = offset + pickup
    truth["torque_load_drift"] = drift_L
    truth["q_encoder_drift"] = enc_rate * t
    truth["motor_speed"] = w_true
    truth["phase"] = pd.Series(list(phase), dtype=object)
    truth_df = pd.DataFrame(truth)

    amp_delay = 1.0 / (2.0 * math.pi * sensors.torque_bandwidth_hz)
    sens_meta = {
        "q": {"resolution": q_res, "noise_sd": 0.0, "lag_s": 0.0},
        "u": {"resolution": u_res, "noise_sd": 0.0, "lag_s": 0.0},
        "ud": {"noise_sd": sensors.speed_noise / REDUCTION},
        "torque": {"resolution": float(sensors.torque_res), "noise_sd": float(sensors.torque_noise),
                   "lag_s": float(sensors.torque_lag_s) + amp_delay},
        "torque_load": {"resolution": float(sensors.load_res),
                        "noise_sd": float(sensors.load_noise), "lag_s": 0.0},
        "temp_joint": {"resolution": float(sensors.temp_res),
                       "noise_sd": float(sensors.temp_noise)},
        "m_bend": {"noise_sd": float(sensors.bend_noise)},
        "f_shear": {"noise_sd": float(sensors.shear_noise)},
        "p_hyd": {"noise_sd": float(sensors.pressure_noise)},
    }
    for k in (1, 2, 3):
        sens_meta[f"i_m{k}"] = {"resolution": float(sensors.current_res),
                                "noise_sd": float(sensors.current_noise)}
        sens_meta[f"w_m{k}"] = {"noise_sd": float(sensors.speed_noise)}
        sens_meta[f"temp_m{k}"] = {"resolution": float(sensors.temp_res),
                                   "noise_sd": float(sensors.temp_noise)}
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": rpm,
        "direction": direction,
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": started.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "notes": (f"validation rig P, scheme {scheme}; qd from a type-2 tracking observer "
                  f"({sensors.qd_observer_hz:g} Hz) on the output encoder; torque lag includes "
                  f"the flange amplifier ({sensors.torque_bandwidth_hz:g} Hz)"),
        "shear_setpoint_n": rig["shear_setpoint"],
        "bend_setpoint_nm": rig["bend_setpoint"],
        "periods": periods if scheme == 3 else None,
        "sensors": sens_meta,
    }
    rig_out = {k: v for k, v in rig.items() if k != "unstated"}
    params = {
        "rig": rig_out,
        "run": {"q0": q0, "motor_temp_offsets": [float(x) for x in tm_off],
                "temp_joint_start": temp0, "internal_dt": dt, "steps_per_sample": m,
                "n_steps": n_steps, "duration_s": T_run, "seed": int(seed), "run": int(run)},
        "effects": {name: {"form": form, "scale": sc} for name, (form, sc) in fx.items()},
        "sensors": asdict(sensors),
        "unstated": un,
        "nominal_laws": {"I": rig["I"], "mr_x": rig["mr_x"], "mr_y": rig["mr_y"],
                         "f_c": rig["f_c"], "f_v": rig["f_v"], "k": rig["k"], "D": rig["D"],
                         "g": G_ACC},
    }
    return RigRun(samples=samples_df, meta=meta, truth=truth_df, params=params)
