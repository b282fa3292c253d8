"""Rig AA — an independent validation simulator of the CMOR J4 joint test bench.

Written only from the paper (shared/seeds/cmor-sghmc-paper.txt), shared/docs/*.md and the run
format (core/channels.py, core/runfile.py). It shares no code with `simulators/` or any other
validation rig. All quantities are SI (angles rad, torques N·m, times s) except temperatures
(°C). "Referred" means referred to the joint output through the reduction N.

DATA SHEET
==========

Machine (nominal values; every campaign `seed` draws its own machine, each value spread by the
relative standard deviation in brackets, clipped at ±3 SD)
----------------------------------------------------------------------------------------------
Output side (paper Eq. 4, Table 3), with the rig.md sign convention

    I·q̈ = T − τ_out − g·(mr_x·sin q + mr_y·cos q) − F_f + τ_dist

  I = 6685.166 kg·m² (2 %), mr_x = 20.779 kg·m (4 %), mr_y = −34.543 kg·m (4 %), g = 9.81 m/s²,
  f_v = 8683.272 N·m·s/rad (3 %), f_c = 2352.660 N·m (3 %). τ_out is the load torque acting on
  the output (the dynamometer torque, positive = the paper's positive loading), τ_dist the sum of
  any other output torque an effect adds (zero on the nominal machine).

Output friction F_f: a LuGre dynamic friction law (own choice), bristle state z [rad]

    ż = q̇ − σ0·|q̇|·z / g(q̇),   F_f = σ0·z + σ1·ż + f_v(T_j)·q̇,   g(v) = f_c (+ effects)

  σ0 = f_c / 1e-5 rad (presliding displacement 1e-5 rad = 0.00057°, far below the encoder step),
  σ1 = sqrt(σ0·I) (bristle damping ratio 0.5). In steady sliding F_f = f_c·sgn(q̇) + f_v·q̇,
  i.e. Eq. 4 exactly; at each velocity reversal the joint sticks (presliding) until the motor has
  wound the transmission up by ≈ 2·f_c/k — tens to hundreds of ms on the Fourier trajectory.
  The Stribeck, load, temperature and asymmetry effects below act through g(v), f_v and an
  additive term, so they keep this dynamic behaviour.

Flexible transmission (Eq. 5 with N = 11000, own law): a three-slope progressive compliance curve
(stiffness rising with twist, as harmonic-drive and multi-stage planetary trains show), plus a
viscous structural damper on the twist. Twist Δ = u − q (paper's torsion q − u = −Δ).

    T = K(Δ) + D·Δ̇,   K odd, piecewise linear in |Δ|:
      slope k1 for |Δ| ≤ θ1 = 0.06°, k2 = 1.6·k1 for θ1 < |Δ| ≤ θ2 = 0.20°, k3 = 2.4·k1 beyond
    k1 is set so that K(Δ_rated) = 120 kN·m (the rated torque) at Δ_rated = 0.50° (3 %)
    (k1 ≈ 6.85e6, k3 ≈ 1.64e7 N·m/rad), D = 1.8e5 N·m·s/rad (10 %).
  No hysteresis, no backlash on the nominal machine. Output-side resonance ≈ 7 Hz (ζ ≈ 0.3).
  With effects: T = f(q)·K(Δ_e) + T_h + D·(dΔ_e/dΔ)·Δ̇, Δ_e the twist after the kinematic
  errors and the dead zone, f(q) the stiffness factor, T_h the hysteretic torque (see Effects).

Motor side: three servo motors on one shaft (equal current command, torque shared), referred

    J_eq·ü = τ_m − T − F_m,   F_m = (F_mc + (1 − η)·|K(Δ)+T_h|)·tanh(u̇/v_ε) + f_mv·u̇

  J_eq = 3·0.0045 kg·m²·N² = 1.6335e6 kg·m² (3 %); F_mc = 3·0.25 N·m·N = 8250 N·m (5 %);
  f_mv = 3·2e-4 N·m·s/rad·N² = 7.26e4 N·m·s/rad (5 %); v_ε = 2e-4 rad/s; η = 0.92 (gear train
  efficiency: a loss growing with the transmitted torque — see UNSTATED_VOCABULARY).
  τ_m follows the speed controller's command through a first-order current loop (1 ms).
  Motor constants k_t,k = 1.45 N·m/A (2 % each), winding R = 1.1 Ω, current sensor offsets
  N(0, 0.01 A); motor current i = τ_m/(N·Σk_t), the same for the three motors.
Controller (the S120 cascade, own tuning): position loop on the motor encoder (gain 5 1/s) with
  speed and torque feed-forward, PI speed loop (crossover 25 rad/s on J_eq, Ki = Kp·25/4,
  anti-windup by clamping), torque limit 3·20 N·m·N. Scheme 1/2: the motors accelerate with a
  raised-cosine ramp (0.5 s → 1.5 s) to the scheme's motor speed (300 or 3000 r/min, i.e.
  0.002856 or 0.02856 rad/s at the output) in the sense `direction` and keep it.
Dynamometer (load): torque-controlled servo; its torque follows `gain·τ_cmd + bias` through a
  first-order lag of 35 ms, gain 1 (0.4 %), bias N(0, 120 N·m) — inside the ±2 kN·m of Table 11 —
  plus a servo torque ripple: an AR(1) process on a 1 kHz grid, correlation time 5 ms, SD 25 N·m
  (process noise, drawn per run). Its rotor inertia belongs to I.
Thermal: gearbox temperature T_j (starts at `temp_joint_c`), C_j·Ṫ_j = P_loss − (T_j − T_a)/R_j,
  C_j = 1.6e5 J/K, R_j = 0.035 K/W, ambient T_a = 22 °C (1.5 K, absolute), P_loss = |F_f·q̇| +
  |F_m·u̇| + D·Δ̇². Windings: C_m = 1800 J/K, R_th = 0.45 K/W, heated by R·i², start at
  `temp_joint_c`. Output viscous friction follows T_j: f_v(T_j) = f_v·exp(−0.008·(T_j − 35)).
Integrator (own choice): semi-implicit (symplectic) Euler on a fixed substep h = 1/(fs·m),
  m = ceil(1/(fs·1e-4)), so that h ≤ 1e-4 s and every sample instant is a substep boundary; the
  first-order states (LuGre z, current loop, dynamometer, transducer filter) are advanced with
  their exact exponential solution over h; hysteresis and thermal states by explicit Euler.
  Samples are the state at t_k = k/fs (forces evaluated at that state, so the truth obeys the
  output balance exactly at every sample). Start: at rest at q = 0, LuGre z = 0, the motor angle
  solved so that the transmission (with the run's transmission effects) carries gravity plus the
  dynamometer bias.

Schemes (section II-B) — phases of core.channels
------------------------------------------------
1 (`motor_speed_rpm` 300 or 3000): idle 3 s (motors start), then `periods` × [load: τ_cmd ramps
  0 → 120 kN·m in 12 s; unload: 120 kN·m → 0 in 12 s], idle 1.5 s. Joint moving throughout.
2 (300 or 3000): idle 3 s, then `periods` × [12 × (load: +10 kN·m in 0.3 s; hold: 2 s);
  unload: 120 kN·m → 0 in 4 s], idle 1.5 s.
  Schemes 1/2 refuse a `periods` that would carry the joint beyond ±180°.
3 (`motor_speed_rpm` None): idle 2 s at rest, excite: `periods` × the fifth-order Fourier
  trajectory of Eq. 12 (base period 30 s, coefficients optimised here for the smallest condition
  number of the column-normalised Eq. 4 observation matrix [q̈, g sin q, g cos q, q̇, sgn q̇],
  ≈ 2.2, under |q̇| ≤ 0.0277 rad/s; it starts and ends each period at rest at q = 0), times
  `direction`, idle 1 s. Dynamometer set point 0 (torque-following, "transparent").

Sensors (SensorSpec; what meta["sensors"] states)
-------------------------------------------------
q: output encoder, mid-tread quantisation at `encoder_res_deg` (0.01°), no noise.
qd: output velocity estimate = true q̇ + white noise `qd_noise` (2e-5 rad/s).
u: motor encoder / N, quantised at `motor_encoder_res` (2π/2^20/N rad). ud: + `ud_noise`.
torsion: q − u of these readings (the encoders' twist, paper Eq. 6 sign).
torque: strain-gauge transducer on the transmitted torque T: first-order amplifier low-pass
  `torque_filter_s` (0.5 ms), a pure lag `torque_lag_s` (0), white noise `torque_noise`
  (120 N·m SD), ADC step `torque_res` (2 N·m). Stated lag = torque_filter_s + torque_lag_s.
torque_load: the dynamometer's torque + noise `load_noise` (80 N·m), step `load_res` (5 N·m).
torque_cmd: the dynamometer set point (exact). i_m1..3 [A]: current + offset + `current_noise`.
w_m1..3: motor speed N·u̇ + noise (N·ud_noise). temp_joint, temp_m1..3: step `temp_res` (0.1 °C)
  + noise `temp_noise` (0.03 °C). All channels sampled at `sample_rate_hz` (1000 Hz).

Effects (`effects` = {name: {"form": f, "scale": s}}, 0 ≤ s ≤ SCALE_MAX; s = 0 is exactly no
effect; s = 1 is a typical real size, ~2–3× the torque noise where it shows in torque)
--------------------------------------------------------------------------------------
Sizes below are at scale s; φ1, φ2 are phases drawn per campaign (seed) and effect; v = q̇.
stribeck — g(v) += ΔF·S(|v|/v_s), ΔF = 0.25·f_c·s, v_s = 3.0e-3 rad/s (≈ 10 % of top speed;
  above s ≈ 1 the falling friction can out-weigh the damping at 300 r/min: stick–slip):
  exponential S = exp(−x); gaussian S = exp(−x²); lorentzian S = 1/(1 + x²);
  sqrt_exponential S = exp(−√x).
load_dependent_friction (|T_e| = |K(Δ) + T_h|, T_r = 120 kN·m):
  coulomb: g += μ·|T_e|, μ = 0.005·s;
  coulomb_viscous: g ×= 1 + 0.25·s·|T_e|/T_r and f_v ×= 1 + 0.5·s·|T_e|/T_r;
  power_flow: g += μ·|T_e| with μ = 0.003·s when T_e·v ≥ 0 (the motors drive the output) and
  μ = 0.008·s when the output is back-driven.
temperature_friction (x = 35 °C − T_j, T_j the gearbox temperature along the run):
  viscous_exponential: f_v ×= exp(clip(0.03·s·x, −3, 3));
  coulomb_linear: g ×= max(0.1, 1 + 0.006·s·x);
  coulomb_viscous_linear: g ×= max(0.1, 1 + 0.004·s·x), f_v ×= max(0.1, 1 + 0.02·s·x);
  viscous_polynomial: f_v ×= max(0.1, 1 + s·(0.5·y + 0.3·y²)), y = x/25.
gear_ripple (Z = 96 mesh cycles per output revolution):
  output_mesh: a mesh torque R(q) = A·[sin(Z·q + φ1) + 0.35·sin(2Z·q + φ2)], A = 300·s N·m,
    resists the output (τ_dist −= R): the transmitted torque gains +R(q);
  motor_stage: a kinematic error of the first stage, 2 and 4 cycles per motor revolution,
    e = E·[sin(2·N·u + φ1) + 0.3·sin(4·N·u + φ2)], E = 300·s/k1 rad, added to the twist the
    stiffness sees (K(Δ + e)): a torque ripple ≈ k·e at 2·N·u̇/2π Hz (100 Hz at 3000 r/min);
  load_modulated: output_mesh whose amplitude is A·(0.2 + 0.8·min(|K(Δ)|/T_r, 1.5));
  twist_error: a transmission error in the twist, K(Δ − e_q), e_q = E_q·[sin(Z·q + φ1) +
    0.3·sin(2Z·q + φ2)], E_q = 1e-4·s rad: at a given torque the twist gains +e_q(q).
torque_offset (torque reading only): constant B = 300·s·σ (σ = ±1 per campaign);
  linear_drift B = 3·s·σ·t N·m; exponential_drift B = 300·s·σ·(1 − exp(−t/30 s)).
time_delay (readings only, pure delay d = 0.010·s s): torque: the torque reading;
  output_encoder: q and qd; motor_encoder: u, ud (and w_m1..3).
hysteresis (a hysteretic torque T_h added to T, driven by the elastic twist Δ_e, amplitude
  H = 600·s N·m, characteristic twist x_m = 2.5e-4 rad):
  bouc_wen_n1: T_h = (H/x_m)·x, ẋ = Δ̇_e − β|Δ̇_e|x − γΔ̇_e|x|, β = 0.6/x_m, γ = 0.4/x_m;
  bouc_wen_n2: same with n = 2, β = 0.6/x_m², γ = 0.4/x_m²;
  dahl: T_h = H·x/x_m, ẋ = 1.5·Δ̇_e·w·|w|, w = 1 − sgn(Δ̇_e)·x/x_m;
  iwan: six elastic–perfectly-plastic (Jenkins) elements in parallel, slip twists
    x_m·(0.25, 0.5, 0.75, 1, 1.5, 2), each saturating at H/6: a Masing/Preisach-type loop.
  Loading and unloading branches differ by ≈ 2H in torque at equal twist.
backlash (dead zone in the twist seen by the stiffness and damper, half-width b = 1.2e-4·s rad):
  sharp: Δ_e = Δ − b·sgn(Δ) outside ±b, 0 inside (no damping inside);
  smooth: softplus dead zone, Δ_e = ε·[sp((Δ − b)/ε) − sp((−Δ − b)/ε)], ε = 0.25·b;
  preloaded: an anti-backlash spring takes 8 % of the slope inside the gap.
asymmetric_friction (σ_v = sgn v): coulomb: g ×= exp(0.13·s·σ_v);
  coulomb_viscous: g ×= exp(0.10·s·σ_v), f_v ×= exp(0.30·s·σ_v);
  offset: F_f += 300·s (a constant torque opposing positive motion — cable-carrier drag —
  at rest too).
Out of vocabulary:
periodic_disturbance: pump_torque: τ_dist += A·[sin(2π·2.35·t + φ1) + 0.4·sin(2π·4.7·t + φ2)],
  A = 300·s (a hydraulic pump pulsation on the output); mains_pickup: the torque reading
  gains 300·s·sin(2π·50·t + φ1) (electrical pick-up; aliased below 100 Hz sampling).
position_dependent_stiffness: K(Δ) ×= f(q): once_per_rev f = 1 + 0.04·s·cos(q + φ1);
  twice_per_rev f = 1 + 0.04·s·cos(2q + φ1); linear f = max(0.1, 1 + 0.04·s·q).
encoder_drift (readings only): output_linear: q += 1.5e-6·s·t; output_random_walk: q += a
  Brownian path of 1.5e-5·s rad/√s (per run); motor_linear: u += 1.5e-6·s·t.
second_resonance (an auxiliary inertia I_2 on a spring k_2 = I_2·ω_2², damping ratio ζ_2):
  link_mode: I_2 = 0.3·s·I, 9 Hz, ζ_2 = 0.03, hung on the output (τ_dist −= coupling torque):
    a tuned-mass pair — the transmitted torque shows an antiresonance (notch) at 9 Hz and a new
    peak below it, next to the ≈ 7 Hz main mode;
  loading_shaft: the dynamometer rotor I_2 = 0.15·s·I on a compliant loading shaft of fixed
    stiffness k_2 = 0.15·I·(2π·12 Hz)² (so 12/√s Hz, ζ_2 = 0.04): the dynamometer torque acts
    on I_2 and the output feels the shaft torque (τ_out ≠ torque_load in transients; the
    rotor is integrated by backward Euler, quasi-static as s → 0).

Truth (RigRun.truth, same instants): q, qd, qdd, u, ud, twist = u − q, torque = T (true
transmitted torque incl. hysteresis, ripple, damping), torque_elastic, torque_hysteresis,
torque_load (dynamometer torque), load_on_output (τ_out), friction (F_f), gravity, disturbance
(τ_dist), temp_joint, torque_motor (τ_m), lugre_z.

Determinism: the machine from `seed` (SEED_IS_CAMPAIGN), the run's noise (sensor noise,
dynamometer ripple, random-walk drift) from (seed, run); effect phases from (seed, effect).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from typing import Any

import numba
import numpy as np
import pandas as pd

RIG_NAME = "rig_aa"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "sqrt_exponential"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow"),
    "temperature_friction": ("viscous_exponential", "coulomb_linear", "coulomb_viscous_linear",
                             "viscous_polynomial"),
    "gear_ripple": ("output_mesh", "motor_stage", "load_modulated", "twist_error"),
    "torque_offset": ("constant", "linear_drift", "exponential_drift"),
    "time_delay": ("torque", "output_encoder", "motor_encoder"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl", "iwan"),
    "backlash": ("sharp", "smooth", "preloaded"),
    "asymmetric_friction": ("coulomb", "coulomb_viscous", "offset"),
    "periodic_disturbance": ("pump_torque", "mains_pickup"),
    "position_dependent_stiffness": ("once_per_rev", "twice_per_rev", "linear"),
    "encoder_drift": ("output_linear", "output_random_walk", "motor_linear"),
    "second_resonance": ("link_mode", "loading_shaft"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "encoder_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "temperature_friction": (
        "The output viscous coefficient follows the gearbox temperature, f_v(T_j) = "
        "f_v·exp(−0.008/K·(T_j − 35 °C)) (about +17 % at 15 °C, −18 % at 60 °C), and the gearbox "
        "warms or cools slowly along each run."),
    "load_dependent_friction": (
        "The motor-side gear train loses (1 − η)·|T| with η = 0.92 as a Coulomb-like drag on the "
        "motor shaft: it grows with the transmitted torque and flips with the direction of "
        "motion, but shows only in the motor currents, not in the torque transducer or the "
        "output balance."),
    "time_delay": (
        "The torque transducer's amplifier is a first-order low-pass (SensorSpec.torque_filter_s, "
        "0.5 ms by default): the torque reading lags by about that much; meta "
        "sensors.torque.lag_s states it (plus SensorSpec.torque_lag_s)."),
}

# --- nominal machine -------------------------------------------------------------------------
G_ACC = 9.81
T_RATED = 120_000.0
TWIST_RATED_DEG = 0.5
T_REF_C = 35.0
OMEGA_TOP = 3000.0 * 2.0 * math.pi / 60.0 / REDUCTION  # output rad/s at 3000 r/min
H_MAX = 1e-4  # largest integration substep [s]
FOURIER_PERIOD_S = 30.0
# Eq. 12 coefficients (rad/s), optimised offline for this rig (see the data sheet); the last a
# and b are re-derived so that q̇(0) = 0 and q̈(0) = 0 hold exactly.
FOURIER_A = (-0.00489948, -0.00749563, 0.0014536, 0.00749794)
FOURIER_B = (-0.00202703, 0.0035504, 0.00663644, -0.00129924)
MESH_Z = 96.0

_NOMINAL = {  # value, relative SD
    "I": (6685.166, 0.02), "mr_x": (20.779, 0.04), "mr_y": (-34.543, 0.04),
    "f_v": (8683.272, 0.03), "f_c": (2352.660, 0.03),
    "twist_rated_rad": (math.radians(TWIST_RATED_DEG), 0.03),
    "D": (1.8e5, 0.10), "J_eq": (3 * 0.0045 * REDUCTION ** 2, 0.03),
    "F_mc": (3 * 0.25 * REDUCTION, 0.05), "f_mv": (3 * 2e-4 * REDUCTION ** 2, 0.05),
}

_EFFECT_INDEX = {name: i for i, name in enumerate(EFFECT_FORMS)}
(EF_STRIBECK, EF_LOADF, EF_TEMPF, EF_RIPPLE, EF_OFFSET, EF_DELAY, EF_HYST, EF_BACKLASH, EF_ASYM,
 EF_PERIODIC, EF_POSSTIFF, EF_ENCDRIFT, EF_RES2) = range(13)

# parameter vector layout
(P_I, P_MRX, P_MRY, P_FV, P_FC, P_FVTC, P_TREF, P_SIG0, P_SIG1, P_K1, P_K2, P_K3, P_TH1, P_TH2,
 P_D, P_JEQ, P_KPOS, P_KP, P_KI, P_TAUMAX, P_TAUI, P_FMC, P_FMV, P_VEPS, P_ETA, P_DYNTAU,
 P_DYNGAIN, P_DYNBIAS, P_FILT, P_CJ, P_RJ, P_TAMB, P_TJ0, P_U0, P_SCHEME, P_DIR, P_VOUT,
 P_TA0, P_TA, P_WF, P_TEX0, P_TEX1, P_Q2_0, P_TAU0) = range(44)
N_P = 44

# output columns of the kernel
(O_Q, O_QD, O_QDD, O_U, O_UD, O_T, O_TEL, O_TDYN, O_LOUT, O_F, O_G, O_DIST, O_TJ, O_TAUM,
 O_Z, O_TH, O_TFD, O_QDEL, O_QDDEL, O_UDEL, O_UDDEL, O_TCMD, O_FM) = range(23)
N_OUT = 23


# --- sensors ---------------------------------------------------------------------------------

_SENSOR_RANGES = {
    "sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-5, 1.0),
    "torque_noise": (0.0, 1e5), "torque_lag_s": (0.0, 1.0), "torque_filter_s": (0.0, 0.1),
    "torque_res": (0.0, 1e4), "load_noise": (0.0, 1e5), "load_res": (0.0, 1e4),
    "qd_noise": (0.0, 1.0), "motor_encoder_res": (0.0, 1e-2), "ud_noise": (0.0, 1.0),
    "current_noise": (0.0, 100.0), "temp_res": (0.0, 10.0), "temp_noise": (0.0, 10.0),
}


@dataclass
class SensorSpec:
    """What the bench's sensors resolve (see the data sheet). Ranges in _SENSOR_RANGES."""

    sample_rate_hz: float = 1000.0      # [Hz], 10..1000
    encoder_res_deg: float = 0.01       # output encoder step [deg], 1e-5..1
    torque_noise: float = 120.0         # torque reading noise SD [N·m]
    torque_lag_s: float = 0.0           # pure lag of the torque reading [s], 0..1
    torque_filter_s: float = 5e-4       # transducer amplifier low-pass time constant [s]
    torque_res: float = 2.0             # torque ADC step [N·m] (0: none)
    load_noise: float = 80.0            # dynamometer torque reading noise SD [N·m]
    load_res: float = 5.0               # its step [N·m]
    qd_noise: float = 2e-5              # output velocity noise SD [rad/s]
    motor_encoder_res: float = 2 * math.pi / 2 ** 20 / REDUCTION  # referred step [rad]
    ud_noise: float = 2e-6              # referred motor velocity noise SD [rad/s]
    current_noise: float = 0.02         # motor current noise SD [A]
    temp_res: float = 0.1               # temperature step [°C]
    temp_noise: float = 0.03            # temperature noise SD [°C]

    def __post_init__(self) -> None:
        for name, (lo, hi) in _SENSOR_RANGES.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise ValueError(f"SensorSpec.{name} must be a number, got {v!r}")
            v = float(v)
            if not math.isfinite(v):
                raise ValueError(f"SensorSpec.{name} must be finite, got {v!r}")
            if not lo <= v <= hi:
                raise ValueError(f"SensorSpec.{name} must lie in [{lo:g}, {hi:g}], got {v!r}")
            setattr(self, name, v)


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict = field(default_factory=dict)


# --- argument checks -------------------------------------------------------------------------

def _is_int(v: Any) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _check_effects(effects: Any) -> dict[str, tuple[str, float]]:
    """{name: (form, scale)} with scale > 0 only (scale 0 is no effect)."""
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict {{name: {{'form', 'scale'}}}} or None, got "
                         f"{type(effects).__name__}")
    out: dict[str, tuple[str, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effects[{name!r}] must be a dict with 'form' and 'scale', got {spec!r}")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effects[{name!r}] has unknown keys {sorted(extra)}")
        if "scale" not in spec:
            raise ValueError(f"effects[{name!r}]['scale'] is missing")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}]['form'] must be one of {EFFECT_FORMS[name]}, got {form!r}")
        s = spec["scale"]
        if not _is_num(s) or not math.isfinite(float(s)):
            raise ValueError(f"effects[{name!r}]['scale'] must be a finite number, got {s!r}")
        s = float(s)
        if not 0.0 <= s <= SCALE_MAX:
            raise ValueError(f"effects[{name!r}]['scale'] must lie in [0, {SCALE_MAX}], got {s!r}")
        if s > 0.0:
            out[name] = (form, s)
    return out


# --- schedules -------------------------------------------------------------------------------

def _schedule(scheme: int, periods: int) -> tuple[np.ndarray, np.ndarray, list[tuple[float, float, str]], float]:
    """(knot times, knot torques of τ_cmd, phase segments [(t0, t1, phase)], duration)."""
    tk, vk, seg = [0.0], [0.0], []
    if scheme == 1:
        t = 3.0
        seg.append((0.0, t, "idle"))
        for _ in range(periods):
            tk += [t, t + 12.0, t + 24.0]
            vk += [0.0, T_RATED, 0.0]
            seg += [(t, t + 12.0, "load"), (t + 12.0, t + 24.0, "unload")]
            t += 24.0
        end = t + 1.5
    elif scheme == 2:
        t = 3.0
        seg.append((0.0, t, "idle"))
        for _ in range(periods):
            tk.append(t)
            vk.append(0.0)
            for k in range(1, 13):
                tk += [t + 0.3, t + 2.3]
                vk += [k * 10_000.0, k * 10_000.0]
                seg += [(t, t + 0.3, "load"), (t + 0.3, t + 2.3, "hold")]
                t += 2.3
            tk.append(t + 4.0)
            vk.append(0.0)
            seg.append((t, t + 4.0, "unload"))
            t += 4.0
        end = t + 1.5
    else:
        t = 2.0
        seg.append((0.0, t, "idle"))
        seg.append((t, t + periods * FOURIER_PERIOD_S, "excite"))
        t += periods * FOURIER_PERIOD_S
        end = t + 1.0
    seg.append((seg[-1][1], end + 1.0, "idle"))
    tk.append(end + 1.0)
    vk.append(0.0)
    return np.asarray(tk, float), np.asarray(vk, float), seg, end


def fourier_coefficients() -> tuple[np.ndarray, np.ndarray, float]:
    """(a_l, b_l, ω_f) of the scheme-3 trajectory (Eq. 12), l = 1..5, with q̇(0) = q̈(0) = 0."""
    a = np.zeros(5)
    b = np.zeros(5)
    a[:4] = FOURIER_A
    b[:4] = FOURIER_B
    a[4] = -a[:4].sum()
    b[4] = -(np.arange(1, 5) * b[:4]).sum() / 5.0
    return a, b, 2.0 * math.pi / FOURIER_PERIOD_S


def fourier_trajectory(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. 12 position, velocity, acceleration (direction +1) at times t since excite start."""
    a, b, w = fourier_coefficients()
    t = np.asarray(t, float)
    q = np.zeros_like(t)
    qd = np.zeros_like(t)
    qdd = np.zeros_like(t)
    q0 = 0.0
    for i in range(5):
        l = i + 1
        s, c = np.sin(w * l * t), np.cos(w * l * t)
        q += a[i] / (w * l) * s - b[i] / (w * l) * c
        q0 += b[i] / (w * l)
        qd += a[i] * c + b[i] * s
        qdd += -a[i] * w * l * s + b[i] * w * l * c
    return q + q0, qd, qdd


# --- the kernel ------------------------------------------------------------------------------

@numba.njit(cache=True, inline="always")
def _kcurve(d, k1, k2, k3, th1, th2):
    a = abs(d)
    if a <= th1:
        f = k1 * a
    elif a <= th2:
        f = k1 * th1 + k2 * (a - th1)
    else:
        f = k1 * th1 + k2 * (th2 - th1) + k3 * (a - th2)
    return f if d >= 0.0 else -f


@numba.njit(cache=True, inline="always")
def _softplus(x):
    return max(x, 0.0) + math.log1p(math.exp(-abs(x)))


@numba.njit(cache=True, inline="always")
def _sigmoid(x):
    if x >= 0.0:
        return 1.0 / (1.0 + math.exp(-x))
    e = math.exp(x)
    return e / (1.0 + e)


@numba.njit(cache=True)
def _elastic(u, q, P, E, EP):
    """Elastic transmission torque K(Δ_e)·f(q) and the slope dΔ_e/dΔ, for motor angle u and
    output angle q: kinematic errors (gear_ripple), dead zone (backlash), f(q) (stiffness)."""
    eR = E[EF_RIPPLE]
    eB = E[EF_BACKLASH]
    eK = E[EF_POSSTIFF]
    din = u - q
    if eR == 2:
        thm = REDUCTION_C * u
        din += EP[EF_RIPPLE, 0] * (math.sin(2.0 * thm + EP[EF_RIPPLE, 2])
                                   + 0.3 * math.sin(4.0 * thm + EP[EF_RIPPLE, 3]))
    elif eR == 4:
        din -= EP[EF_RIPPLE, 0] * (math.sin(MESH_Z_C * q + EP[EF_RIPPLE, 2])
                                   + 0.3 * math.sin(2.0 * MESH_Z_C * q + EP[EF_RIPPLE, 3]))
    slope = 1.0
    de = din
    if eB == 1:
        b = EP[EF_BACKLASH, 0]
        if din > b:
            de = din - b
        elif din < -b:
            de = din + b
        else:
            de = 0.0
            slope = 0.0
    elif eB == 2:
        b = EP[EF_BACKLASH, 0]
        eps = EP[EF_BACKLASH, 1]
        de = eps * (_softplus((din - b) / eps) - _softplus((-din - b) / eps))
        slope = _sigmoid((din - b) / eps) + _sigmoid((-din - b) / eps)
    elif eB == 3:
        b = EP[EF_BACKLASH, 0]
        kap = EP[EF_BACKLASH, 1]
        if din > b:
            de = din - (1.0 - kap) * b
        elif din < -b:
            de = din + (1.0 - kap) * b
        else:
            de = kap * din
            slope = kap
    fpos = 1.0
    if eK == 1:
        fpos = 1.0 + EP[EF_POSSTIFF, 0] * math.cos(q + EP[EF_POSSTIFF, 1])
    elif eK == 2:
        fpos = 1.0 + EP[EF_POSSTIFF, 0] * math.cos(2.0 * q + EP[EF_POSSTIFF, 1])
    elif eK == 3:
        fpos = max(0.1, 1.0 + EP[EF_POSSTIFF, 0] * q)
    return fpos * _kcurve(de, P[P_K1], P[P_K2], P[P_K3], P[P_TH1], P[P_TH2]), slope


@numba.njit(cache=True)
def _kernel(P, E, EP, TK, VK, FA, FB, NZ, DL, n, m, h):
    out = np.empty((n, N_OUT))
    I = P[P_I]
    k1 = P[P_K1]
    k2 = P[P_K2]
    k3 = P[P_K3]
    th1 = P[P_TH1]
    th2 = P[P_TH2]
    Dd_c = P[P_D]
    sig0 = P[P_SIG0]
    sig1 = P[P_SIG1]
    jeq = P[P_JEQ]
    scheme = int(P[P_SCHEME])
    dirn = P[P_DIR]
    vout = P[P_VOUT]
    ta0 = P[P_TA0]
    ta = P[P_TA]
    wf = P[P_WF]
    tex0 = P[P_TEX0]
    tex1 = P[P_TEX1]
    u0 = P[P_U0]
    ci = 1.0 - math.exp(-h / P[P_TAUI])
    cd = 1.0 - math.exp(-h / P[P_DYNTAU])
    cf = 1.0 - math.exp(-h / P[P_FILT]) if P[P_FILT] > 0.0 else 1.0
    eS = E[EF_STRIBECK]
    eL = E[EF_LOADF]
    eT = E[EF_TEMPF]
    eR = E[EF_RIPPLE]
    eH = E[EF_HYST]
    eA = E[EF_ASYM]
    eP = E[EF_PERIODIC]
    e2 = E[EF_RES2]
    FA0 = 0.0
    for i in range(5):
        FA0 += FB[i] / (wf * (i + 1))
    # ring buffer of delayed channels: Tf, q, qd, u, ud
    dmax = 0.0
    for c in range(5):
        dmax = max(dmax, DL[c])
    R = int(dmax / h) + 4
    ring = np.empty((5, R))
    # state
    q = 0.0
    qd = 0.0
    u = u0
    ud = 0.0
    z = 0.0
    xh = 0.0
    yi = np.zeros(6)
    q2 = P[P_Q2_0]
    qd2 = 0.0
    taum = P[P_TAU0]
    integ = P[P_TAU0]
    tdyn = P[P_DYNGAIN] * 0.0 + P[P_DYNBIAS]
    Tj = P[P_TJ0]
    Tf = P[P_TAU0]
    kk = 0  # knot pointer
    nz_len = NZ.shape[0]
    islip = np.array([0.25, 0.5, 0.75, 1.0, 1.5, 2.0])
    Tf_init = Tf
    for k in range(n):
        for j in range(m):
            step = k * m + j
            t = step * h
            # --- references
            if scheme == 3:
                tt = t - tex0
                qr = 0.0
                wr = 0.0
                ar = 0.0
                if tt > 0.0 and t < tex1:
                    for i in range(5):
                        l = i + 1.0
                        s_ = math.sin(wf * l * tt)
                        c_ = math.cos(wf * l * tt)
                        qr += FA[i] / (wf * l) * s_ - FB[i] / (wf * l) * c_
                        wr += FA[i] * c_ + FB[i] * s_
                        ar += -FA[i] * wf * l * s_ + FB[i] * wf * l * c_
                    qr += FA0
                ur = u0 + dirn * qr
                wr = dirn * wr
                ar = dirn * ar
            else:
                if t <= ta0:
                    ur = u0
                    wr = 0.0
                    ar = 0.0
                elif t < ta0 + ta:
                    x_ = (t - ta0) / ta
                    wr = vout * 0.5 * (1.0 - math.cos(math.pi * x_))
                    ar = vout * 0.5 * math.pi / ta * math.sin(math.pi * x_)
                    ur = u0 + vout * (0.5 * (t - ta0) - ta / (2.0 * math.pi) * math.sin(math.pi * x_))
                else:
                    wr = vout
                    ar = 0.0
                    ur = u0 + vout * ((t - ta0) - 0.5 * ta)
            while kk < TK.shape[0] - 2 and t >= TK[kk + 1]:
                kk += 1
            t0k = TK[kk]
            t1k = TK[kk + 1]
            if t1k > t0k:
                fr = (t - t0k) / (t1k - t0k)
                if fr > 1.0:
                    fr = 1.0
                tcmd = VK[kk] + (VK[kk + 1] - VK[kk]) * fr
            else:
                tcmd = VK[kk + 1]
            inz = int(t * 1000.0)
            if inz >= nz_len:
                inz = nz_len - 1
            tdyn_app = tdyn + NZ[inz]
            # --- transmission
            dld = ud - qd
            tel, slope = _elastic(u, q, P, E, EP)
            ded = slope * dld
            th = 0.0
            if eH == 1 or eH == 2:
                th = EP[EF_HYST, 0] / EP[EF_HYST, 1] * xh
            elif eH == 3:
                th = EP[EF_HYST, 0] * xh / EP[EF_HYST, 1]
            elif eH == 4:
                for i in range(6):
                    th += EP[EF_HYST, 0] / (6.0 * islip[i] * EP[EF_HYST, 1]) * yi[i]
            te = tel + th
            T = te + Dd_c * ded
            # --- output-side torques
            dist = 0.0
            if eR == 1 or eR == 3:
                rr = EP[EF_RIPPLE, 0] * (math.sin(MESH_Z_C * q + EP[EF_RIPPLE, 2])
                                         + 0.35 * math.sin(2.0 * MESH_Z_C * q + EP[EF_RIPPLE, 3]))
                if eR == 3:
                    rr *= 0.2 + 0.8 * min(abs(tel) / T_RATED_C, 1.5)
                dist -= rr
            if eP == 1:
                wp = 2.0 * math.pi * EP[EF_PERIODIC, 1] * t
                dist += EP[EF_PERIODIC, 0] * (math.sin(wp + EP[EF_PERIODIC, 2])
                                              + 0.4 * math.sin(2.0 * wp + EP[EF_PERIODIC, 3]))
            # friction (LuGre)
            v = qd
            sv = 1.0 if v >= 0.0 else -1.0
            fc = P[P_FC]
            fv = P[P_FV] * math.exp(-P[P_FVTC] * (Tj - P[P_TREF]))
            xT = P[P_TREF] - Tj
            if eT == 1:
                ex = EP[EF_TEMPF, 0] * xT
                ex = min(3.0, max(-3.0, ex))
                fv *= math.exp(ex)
            elif eT == 2:
                fc *= max(0.1, 1.0 + EP[EF_TEMPF, 0] * xT)
            elif eT == 3:
                fc *= max(0.1, 1.0 + EP[EF_TEMPF, 0] * xT)
                fv *= max(0.1, 1.0 + EP[EF_TEMPF, 1] * xT)
            elif eT == 4:
                y_ = xT / 25.0
                fv *= max(0.1, 1.0 + EP[EF_TEMPF, 0] * (0.5 * y_ + 0.3 * y_ * y_))
            if eA == 1:
                fc *= math.exp(EP[EF_ASYM, 0] * sv)
            elif eA == 2:
                fc *= math.exp(EP[EF_ASYM, 0] * sv)
                fv *= math.exp(EP[EF_ASYM, 1] * sv)
            if eL == 1:
                fc += EP[EF_LOADF, 0] * abs(te)
            elif eL == 2:
                fc *= 1.0 + EP[EF_LOADF, 0] * abs(te) / T_RATED_C
                fv *= 1.0 + EP[EF_LOADF, 1] * abs(te) / T_RATED_C
            elif eL == 3:
                if te * v >= 0.0:
                    fc += EP[EF_LOADF, 0] * abs(te)
                else:
                    fc += EP[EF_LOADF, 1] * abs(te)
            gv = fc
            if eS > 0:
                xs = abs(v) / EP[EF_STRIBECK, 1]
                if eS == 1:
                    sS = math.exp(-xs)
                elif eS == 2:
                    sS = math.exp(-xs * xs)
                elif eS == 3:
                    sS = 1.0 / (1.0 + xs * xs)
                else:
                    sS = math.exp(-math.sqrt(xs))
                gv += EP[EF_STRIBECK, 0] * sS
            arate = sig0 * abs(v) / gv
            zdot = v - arate * z
            F = sig0 * z + sig1 * zdot + fv * v
            if eA == 3:
                F += EP[EF_ASYM, 2]
            G = G_ACC_C * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
            lout = tdyn_app
            tc2 = 0.0
            if e2 == 1:
                tc2 = EP[EF_RES2, 1] * (q - q2) + EP[EF_RES2, 2] * (qd - qd2)
                dist -= tc2
            elif e2 == 2:
                # the dynamometer rotor: backward Euler against the current output state (stable
                # and quasi-static for a vanishing rotor inertia), then the shaft torque
                I2_ = EP[EF_RES2, 0]
                k2_ = EP[EF_RES2, 1]
                c2_ = EP[EF_RES2, 2]
                qd2 = (I2_ * qd2 / h + k2_ * (q - q2) + c2_ * qd - tdyn_app) / (I2_ / h + c2_ + k2_ * h)
                q2 += h * qd2
                tc2 = k2_ * (q - q2) + c2_ * (qd - qd2)
                lout = tc2
            qdd = (T - lout - G - F + dist) / I
            # --- motor side
            wcmd = wr + P[P_KPOS] * (ur - u)
            err = wcmd - ud
            tc = P[P_KP] * err + integ + (jeq + I) * ar
            if tc > P[P_TAUMAX]:
                tc = P[P_TAUMAX]
            elif tc < -P[P_TAUMAX]:
                tc = -P[P_TAUMAX]
            else:
                integ += P[P_KI] * err * h
            th_ = math.tanh(ud / P[P_VEPS])
            Fm = (P[P_FMC] + (1.0 - P[P_ETA]) * abs(te)) * th_ + P[P_FMV] * ud
            udd = (taum - T - Fm) / jeq
            # --- ring buffer (values at time t)
            ri = step % R
            ring[0, ri] = Tf
            ring[1, ri] = q
            ring[2, ri] = qd
            ring[3, ri] = u
            ring[4, ri] = ud
            if j == 0:
                o = out[k]
                o[O_Q] = q
                o[O_QD] = qd
                o[O_QDD] = qdd
                o[O_U] = u
                o[O_UD] = ud
                o[O_T] = T
                o[O_TEL] = te
                o[O_TDYN] = tdyn_app
                o[O_LOUT] = lout
                o[O_F] = F
                o[O_G] = G
                o[O_DIST] = dist
                o[O_TJ] = Tj
                o[O_TAUM] = taum
                o[O_Z] = z
                o[O_TH] = th
                o[O_TCMD] = tcmd
                o[O_FM] = Fm
                for c in range(5):
                    p = step - DL[c] / h
                    if p <= 0.0:
                        if c == 0:
                            val = Tf_init
                        elif c == 1:
                            val = 0.0
                        elif c == 2:
                            val = 0.0
                        elif c == 3:
                            val = u0
                        else:
                            val = 0.0
                        if p > -1.0:  # between t=0 and the first substep
                            w1 = p + 1.0
                            val = (1.0 - w1) * val + w1 * ring[c, 0]
                    else:
                        i0 = int(math.floor(p))
                        w1 = p - i0
                        if w1 > 0.0:
                            val = (1.0 - w1) * ring[c, i0 % R] + w1 * ring[c, (i0 + 1) % R]
                        else:
                            val = ring[c, i0 % R]
                    o[O_TFD + c] = val
            # --- integrate (semi-implicit Euler; exact exponentials for first-order states)
            qd += qdd * h
            ud += udd * h
            if e2 == 1:
                qd2 += tc2 / EP[EF_RES2, 0] * h
                q2 += qd2 * h
            q += qd * h
            u += ud * h
            # LuGre bristle: exact solution for the new velocity held over h
            vn = qd
            an = sig0 * abs(vn) / gv
            if an > 0.0:
                zss = vn / an
                z = zss + (z - zss) * math.exp(-an * h)
            # hysteresis
            dde = ded * h
            if eH == 1:
                bb = EP[EF_HYST, 2]
                gg = EP[EF_HYST, 3]
                xh += dde - bb * abs(dde) * xh - gg * dde * abs(xh)
            elif eH == 2:
                bb = EP[EF_HYST, 2]
                gg = EP[EF_HYST, 3]
                xh += dde - bb * abs(dde) * abs(xh) * xh - gg * dde * xh * xh
            elif eH == 3:
                xm = EP[EF_HYST, 1]
                sg = 1.0 if dde >= 0.0 else -1.0
                w_ = 1.0 - sg * xh / xm
                xh += 1.5 * dde * w_ * abs(w_)
            elif eH == 4:
                for i in range(6):
                    lim = islip[i] * EP[EF_HYST, 1]
                    yv = yi[i] + dde
                    if yv > lim:
                        yv = lim
                    elif yv < -lim:
                        yv = -lim
                    yi[i] = yv
            taum += (tc - taum) * ci
            tdyn += (P[P_DYNGAIN] * tcmd + P[P_DYNBIAS] - tdyn) * cd
            Tf += (T - Tf) * cf
            ploss = abs(F * v) + abs(Fm * ud) + Dd_c * ded * ded
            Tj += h * (ploss - (Tj - P[P_TAMB]) / P[P_RJ]) / P[P_CJ]
    return out


REDUCTION_C = REDUCTION
MESH_Z_C = MESH_Z
T_RATED_C = T_RATED
G_ACC_C = G_ACC


@numba.njit(cache=True)
def _first_order(x0, drive, a):
    """y[0] = x0, y[k+1] = a·y[k] + (1 − a)·drive[k] (exact ZOH discretisation)."""
    y = np.empty(drive.shape[0])
    y[0] = x0
    for k in range(drive.shape[0] - 1):
        y[k + 1] = a * y[k] + (1.0 - a) * drive[k]
    return y


# --- parameters ------------------------------------------------------------------------------

def machine_params(seed: int) -> dict[str, float]:
    """The campaign's machine (drawn from `seed`), with derived stiffness values."""
    rng = np.random.default_rng(np.random.SeedSequence([0xAA, int(seed), 1]))
    p: dict[str, float] = {}
    for name, (nom, rsd) in _NOMINAL.items():
        p[name] = float(nom * (1.0 + rsd * np.clip(rng.standard_normal(), -3, 3)))
    th1, th2 = math.radians(0.06), math.radians(0.20)
    tr = p["twist_rated_rad"]
    k1 = T_RATED / (th1 + 1.6 * (th2 - th1) + 2.4 * (tr - th2))
    p.update(theta1=th1, theta2=th2, k1=k1, k2=1.6 * k1, k3=2.4 * k1)
    p["sigma0"] = p["f_c"] / 1e-5
    p["sigma1"] = math.sqrt(p["sigma0"] * p["I"])
    p["fv_temp_coef"] = 0.008
    p["T_ref_c"] = T_REF_C
    p["eta"] = 0.92
    p["k_t"] = [float(1.45 * (1 + 0.02 * np.clip(rng.standard_normal(), -3, 3))) for _ in range(3)]
    p["R_winding"] = 1.1
    p["current_offset"] = [float(0.01 * np.clip(rng.standard_normal(), -3, 3)) for _ in range(3)]
    p["dyn_tau"] = 0.035
    p["dyn_gain"] = float(1 + 0.004 * np.clip(rng.standard_normal(), -3, 3))
    p["dyn_bias"] = float(120.0 * np.clip(rng.standard_normal(), -3, 3))
    p["dyn_ripple_sd"] = 25.0
    p["T_amb_c"] = float(22.0 + 1.5 * np.clip(rng.standard_normal(), -3, 3))
    p["C_j"], p["R_j"] = 1.6e5, 0.035
    p["C_m"], p["R_th_m"] = 1800.0, 0.45
    wc = 25.0
    p["Kp"] = p["J_eq"] * wc
    p["Ki"] = p["Kp"] * wc / 4.0
    p["Kpos"] = 5.0
    p["tau_max"] = 3 * 20.0 * REDUCTION
    p["tau_i"] = 1e-3
    p["v_eps"] = 2e-4
    p["offset_sign"] = float(1.0 if rng.random() < 0.5 else -1.0)
    return p


def _effect_params(name: str, form: str, s: float, seed: int, mp: dict) -> dict[str, float]:
    rng = np.random.default_rng(np.random.SeedSequence([0xAA, int(seed), 7, zlib.crc32(name.encode())]))
    ph1, ph2 = (float(x) for x in rng.uniform(0, 2 * math.pi, 2))
    if name == "stribeck":
        return {"dFs": 0.25 * mp["f_c"] * s, "v_s": 3.0e-3}
    if name == "load_dependent_friction":
        if form == "coulomb":
            return {"mu": 0.005 * s}
        if form == "coulomb_viscous":
            return {"c_coulomb": 0.25 * s, "c_viscous": 0.5 * s}
        return {"mu_drive": 0.003 * s, "mu_back": 0.008 * s}
    if name == "temperature_friction":
        return {"viscous_exponential": {"b": 0.03 * s}, "coulomb_linear": {"c": 0.006 * s},
                "coulomb_viscous_linear": {"c_coulomb": 0.004 * s, "c_viscous": 0.02 * s},
                "viscous_polynomial": {"c": s}}[form]
    if name == "gear_ripple":
        if form in ("output_mesh", "load_modulated"):
            return {"A": 300.0 * s, "Z": MESH_Z, "phi1": ph1, "phi2": ph2}
        if form == "motor_stage":
            return {"E": 300.0 * s / mp["k1"], "phi1": ph1, "phi2": ph2}
        return {"E": 1e-4 * s, "Z": MESH_Z, "phi1": ph1, "phi2": ph2}
    if name == "torque_offset":
        sg = mp["offset_sign"]
        return {"constant": {"B": 300.0 * s * sg}, "linear_drift": {"rate": 3.0 * s * sg},
                "exponential_drift": {"B": 300.0 * s * sg, "tau": 30.0}}[form]
    if name == "time_delay":
        return {"delay_s": 0.010 * s}
    if name == "hysteresis":
        xm = 2.5e-4
        d = {"H": 600.0 * s, "x_m": xm}
        if form == "bouc_wen_n1":
            d.update(beta=0.6 / xm, gamma=0.4 / xm)
        elif form == "bouc_wen_n2":
            d.update(beta=0.6 / xm ** 2, gamma=0.4 / xm ** 2)
        return d
    if name == "backlash":
        b = 1.2e-4 * s
        return {"b": b, "aux": 0.25 * b if form == "smooth" else 0.08}
    if name == "asymmetric_friction":
        return {"coulomb": {"a_c": 0.13 * s}, "coulomb_viscous": {"a_c": 0.10 * s, "a_v": 0.30 * s},
                "offset": {"F0": 300.0 * s}}[form]
    if name == "periodic_disturbance":
        if form == "pump_torque":
            return {"A": 300.0 * s, "f": 2.35, "phi1": ph1, "phi2": ph2}
        return {"A": 300.0 * s, "f": 50.0, "phi1": ph1}
    if name == "position_dependent_stiffness":
        return {"amp": 0.04 * s, "phi": ph1}
    if name == "encoder_drift":
        return {"output_linear": {"rate": 1.5e-6 * s}, "output_random_walk": {"sigma": 1.5e-5 * s},
                "motor_linear": {"rate": 1.5e-6 * s}}[form]
    if name == "second_resonance":
        if form == "link_mode":  # fixed frequency, the hung inertia grows with s
            I2, zeta = 0.3 * s * mp["I"], 0.03
            k2 = I2 * (2 * math.pi * 9.0) ** 2
        else:  # fixed shaft stiffness, the rotor inertia grows with s: 12 Hz at s = 1
            I2, zeta = 0.15 * s * mp["I"], 0.04
            k2 = 0.15 * mp["I"] * (2 * math.pi * 12.0) ** 2
        w2 = math.sqrt(k2 / I2)
        return {"I2": I2, "f": w2 / (2 * math.pi), "zeta": zeta, "k2": k2, "c2": 2 * zeta * I2 * w2}
    raise AssertionError(name)


def _ep_row(name: str, form: str, ep: dict) -> list[float]:
    if name == "stribeck":
        return [ep["dFs"], ep["v_s"]]
    if name == "load_dependent_friction":
        if form == "coulomb":
            return [ep["mu"]]
        if form == "coulomb_viscous":
            return [ep["c_coulomb"], ep["c_viscous"]]
        return [ep["mu_drive"], ep["mu_back"]]
    if name == "temperature_friction":
        if form == "coulomb_viscous_linear":
            return [ep["c_coulomb"], ep["c_viscous"]]
        return [next(iter(ep.values()))]
    if name == "gear_ripple":
        return [ep.get("A", ep.get("E")), ep.get("Z", 0.0), ep["phi1"], ep["phi2"]]
    if name == "hysteresis":
        return [ep["H"], ep["x_m"], ep.get("beta", 0.0), ep.get("gamma", 0.0)]
    if name == "backlash":
        return [ep["b"], ep["aux"]]
    if name == "asymmetric_friction":
        return [ep.get("a_c", 0.0), ep.get("a_v", 0.0), ep.get("F0", 0.0)]
    if name == "periodic_disturbance":
        return [ep["A"], ep["f"], ep["phi1"], ep.get("phi2", 0.0)]
    if name == "position_dependent_stiffness":
        return [ep["amp"], ep["phi"]]
    if name == "second_resonance":
        return [ep["I2"], ep["k2"], ep["c2"]]
    return []


# --- the run ---------------------------------------------------------------------------------

def _check_args(scheme, motor_speed_rpm, direction, temp_joint_c, sensors, periods, seed, run):
    if not _is_int(scheme) or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
    else:
        if not _is_num(motor_speed_rpm) or float(motor_speed_rpm) not in (300.0, 3000.0):
            raise ValueError(f"motor_speed_rpm must be 300 or 3000 for scheme {scheme}, got "
                             f"{motor_speed_rpm!r}")
    if not _is_num(direction) or float(direction) not in (1.0, -1.0):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if not _is_num(temp_joint_c) or not math.isfinite(float(temp_joint_c)) \
            or not 15.0 <= float(temp_joint_c) <= 60.0:
        raise ValueError(f"temp_joint_c must be a number in [15, 60] °C, got {temp_joint_c!r}")
    if sensors is not None and not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec or None, got {type(sensors).__name__}")
    if not _is_int(periods) or not 1 <= int(periods) <= 20:
        raise ValueError(f"periods must be an integer in [1, 20], got {periods!r}")
    if not _is_int(seed) or int(seed) < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    if not _is_int(run) or int(run) < 0:
        raise ValueError(f"run must be an integer >= 0, got {run!r}")


def _quant(x: np.ndarray, step: float) -> np.ndarray:
    return x if step <= 0 else step * np.round(x / step)


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """One bench run of rig AA (see the module data sheet)."""
    _check_args(scheme, motor_speed_rpm, direction, temp_joint_c, sensors, periods, seed, run)
    eff = _check_effects(effects)
    scheme, periods, seed, run = int(scheme), int(periods), int(seed), int(run)
    dirn = float(direction)
    temp0 = float(temp_joint_c)
    sens = sensors if sensors is not None else SensorSpec()
    fs = sens.sample_rate_hz
    mp = machine_params(seed)

    tk, vk, segs, t_end = _schedule(scheme, periods)
    vout = 0.0
    if scheme != 3:
        vout = dirn * float(motor_speed_rpm) * 2 * math.pi / 60.0 / REDUCTION
        travel = abs(vout) * (t_end - 0.5 - 0.5)
        if travel > math.pi - 0.02:
            raise ValueError(f"periods={periods} carries the joint {math.degrees(travel):.0f}° from 0 "
                             f"at {motor_speed_rpm} r/min, beyond its ±180° range")

    m = int(math.ceil((1.0 / fs) / H_MAX - 1e-9))
    h = (1.0 / fs) / m
    n = int(math.floor(t_end * fs + 1e-9)) + 1

    # effects
    E = np.zeros(13, np.int64)
    EP = np.zeros((13, 8))
    eparams: dict[str, dict] = {}
    for name, (form, s) in eff.items():
        ep = _effect_params(name, form, s, seed, mp)
        eparams[name] = {"form": form, "scale": s, **ep}
        i = _EFFECT_INDEX[name]
        E[i] = EFFECT_FORMS[name].index(form) + 1
        row = _ep_row(name, form, ep)
        EP[i, :len(row)] = row
    # delays of (Tf, q, qd, u, ud)
    DL = np.zeros(5)
    DL[0] = sens.torque_lag_s
    if "time_delay" in eff:
        d = eparams["time_delay"]["delay_s"]
        form = eff["time_delay"][0]
        if form == "torque":
            DL[0] += d
        elif form == "output_encoder":
            DL[1] += d
            DL[2] += d
        else:
            DL[3] += d
            DL[4] += d

    # initial state: output at rest at q = 0, transmission carrying gravity + dynamometer bias
    G0 = G_ACC * mp["mr_y"]
    tau0 = G0 + mp["dyn_bias"]
    u0 = tau0 / mp["k1"]  # replaced below by the root with the effects' transmission law
    q2_0 = 0.0
    if eff.get("second_resonance", ("",))[0] == "loading_shaft":
        q2_0 = -mp["dyn_bias"] / eparams["second_resonance"]["k2"]

    P = np.zeros(N_P)
    P[P_I], P[P_MRX], P[P_MRY], P[P_FV], P[P_FC] = mp["I"], mp["mr_x"], mp["mr_y"], mp["f_v"], mp["f_c"]
    P[P_FVTC], P[P_TREF], P[P_SIG0], P[P_SIG1] = mp["fv_temp_coef"], T_REF_C, mp["sigma0"], mp["sigma1"]
    P[P_K1], P[P_K2], P[P_K3], P[P_TH1], P[P_TH2] = mp["k1"], mp["k2"], mp["k3"], mp["theta1"], mp["theta2"]
    P[P_D], P[P_JEQ], P[P_KPOS], P[P_KP], P[P_KI] = mp["D"], mp["J_eq"], mp["Kpos"], mp["Kp"], mp["Ki"]
    P[P_TAUMAX], P[P_TAUI], P[P_FMC], P[P_FMV] = mp["tau_max"], mp["tau_i"], mp["F_mc"], mp["f_mv"]
    P[P_VEPS], P[P_ETA], P[P_DYNTAU], P[P_DYNGAIN] = mp["v_eps"], mp["eta"], mp["dyn_tau"], mp["dyn_gain"]
    P[P_DYNBIAS], P[P_FILT], P[P_CJ], P[P_RJ] = mp["dyn_bias"], sens.torque_filter_s, mp["C_j"], mp["R_j"]
    P[P_TAMB], P[P_TJ0], P[P_U0], P[P_SCHEME], P[P_DIR] = mp["T_amb_c"], temp0, u0, scheme, dirn
    P[P_VOUT], P[P_TA0], P[P_TA] = vout, 0.5, 1.0
    a_f, b_f, wf = fourier_coefficients()
    P[P_WF], P[P_TEX0], P[P_TEX1] = wf, 2.0, 2.0 + periods * FOURIER_PERIOD_S
    P[P_Q2_0], P[P_TAU0] = q2_0, tau0

    # the motor angle at which the transmission (with its effects) carries tau0 at q = 0
    lo, hi = u0 - 2e-2, u0 + 2e-2
    for _ in range(200 if eff else 0):
        mid = 0.5 * (lo + hi)
        if _elastic(mid, 0.0, P, E, EP)[0] < tau0:
            lo = mid
        else:
            hi = mid
    shapes_law = ("backlash" in eff or "position_dependent_stiffness" in eff
                  or eff.get("gear_ripple", ("",))[0] in ("motor_stage", "twist_error"))
    if shapes_law:
        u0 = 0.5 * (lo + hi)
    P[P_U0] = u0

    # the run's own random streams
    rng = np.random.default_rng(np.random.SeedSequence([0xAA, seed, 2, run]))
    n_nz = int(math.ceil(t_end * 1000.0)) + 3
    rho = math.exp(-1.0 / 5.0)
    w = rng.standard_normal(n_nz) * mp["dyn_ripple_sd"] * math.sqrt(1 - rho * rho)
    w[0] = rng.standard_normal() * mp["dyn_ripple_sd"]
    NZ = _first_order(w[0], w[1:] / (1 - rho), rho) if n_nz > 1 else w
    NZ = np.ascontiguousarray(NZ)

    out = _kernel(P, E, EP, tk, vk, a_f, b_f, NZ, DL, n, m, h)
    t = np.arange(n) / fs

    # --- sensor readings
    noise = {c: rng.standard_normal(n) for c in
             ("qd", "ud", "torque", "load", "i1", "i2", "i3", "w1", "w2", "w3", "tj", "tm1", "tm2", "tm3")}
    q_true_read = out[:, O_QDEL].copy()
    u_read_raw = out[:, O_UDEL].copy()
    if "encoder_drift" in eff:
        form = eff["encoder_drift"][0]
        ep = eparams["encoder_drift"]
        if form == "output_linear":
            q_true_read += ep["rate"] * t
        elif form == "motor_linear":
            u_read_raw += ep["rate"] * t
        else:
            rw_rng = np.random.default_rng(np.random.SeedSequence([0xAA, seed, 3, run, zlib.crc32(b"encoder_drift")]))
            steps = rw_rng.standard_normal(n) * ep["sigma"] * math.sqrt(1.0 / fs)
            steps[0] = 0.0
            q_true_read += np.cumsum(steps)
    enc = math.radians(sens.encoder_res_deg)
    q_read = _quant(q_true_read, enc)
    u_read = _quant(u_read_raw, sens.motor_encoder_res)
    qd_read = out[:, O_QDDEL] + sens.qd_noise * noise["qd"]
    ud_read = out[:, O_UDDEL] + sens.ud_noise * noise["ud"]
    torque_raw = out[:, O_TFD] + sens.torque_noise * noise["torque"]
    if "torque_offset" in eff:
        form = eff["torque_offset"][0]
        ep = eparams["torque_offset"]
        if form == "constant":
            torque_raw = torque_raw + ep["B"]
        elif form == "linear_drift":
            torque_raw = torque_raw + ep["rate"] * t
        else:
            torque_raw = torque_raw + ep["B"] * (1.0 - np.exp(-t / ep["tau"]))
    if eff.get("periodic_disturbance", ("",))[0] == "mains_pickup":
        ep = eparams["periodic_disturbance"]
        torque_raw = torque_raw + ep["A"] * np.sin(2 * math.pi * ep["f"] * t + ep["phi1"])
    torque_read = _quant(torque_raw, sens.torque_res)
    load_read = _quant(out[:, O_TDYN] + sens.load_noise * noise["load"], sens.load_res)

    kt = mp["k_t"]
    i_common = out[:, O_TAUM] / (REDUCTION * sum(kt))
    dt = 1.0 / fs
    a_m = math.exp(-dt / (mp["C_m"] * mp["R_th_m"]))
    cols: dict[str, Any] = {"t": t, "q": q_read, "qd": qd_read, "u": u_read, "ud": ud_read,
                            "torsion": q_read - u_read, "torque": torque_read,
                            "torque_load": load_read, "torque_cmd": out[:, O_TCMD].copy()}
    for k in range(3):
        cols[f"i_m{k + 1}"] = i_common + mp["current_offset"][k] + sens.current_noise * noise[f"i{k + 1}"]
    for k in range(3):
        cols[f"w_m{k + 1}"] = REDUCTION * ud_read + REDUCTION * sens.ud_noise * noise[f"w{k + 1}"]
    for k in range(3):
        p_cu = mp["R_winding"] * i_common ** 2
        tm = _first_order(temp0, mp["T_amb_c"] + mp["R_th_m"] * p_cu, a_m)
        cols[f"temp_m{k + 1}"] = _quant(tm + sens.temp_noise * noise[f"tm{k + 1}"], sens.temp_res)
    cols["temp_joint"] = _quant(out[:, O_TJ] + sens.temp_noise * noise["tj"], sens.temp_res)
    phase = np.empty(n, dtype=object)
    for t0, t1, name in segs:
        phase[(t >= t0 - 1e-9) & (t < t1 - 1e-9)] = name
    phase[phase == None] = "idle"  # noqa: E711
    cols["phase"] = phase
    samples = pd.DataFrame(cols)

    truth = pd.DataFrame({
        "t": t, "q": out[:, O_Q], "qd": out[:, O_QD], "qdd": out[:, O_QDD], "u": out[:, O_U],
        "ud": out[:, O_UD], "twist": out[:, O_U] - out[:, O_Q], "torque": out[:, O_T],
        "torque_elastic": out[:, O_TEL] - out[:, O_TH], "torque_hysteresis": out[:, O_TH],
        "torque_load": out[:, O_TDYN], "load_on_output": out[:, O_LOUT], "friction": out[:, O_F],
        "gravity": out[:, O_G], "disturbance": out[:, O_DIST], "temp_joint": out[:, O_TJ],
        "torque_motor": out[:, O_TAUM], "motor_friction": out[:, O_FM], "lugre_z": out[:, O_Z],
    })

    res_T = sens.torque_res
    lag_T = sens.torque_lag_s + sens.torque_filter_s
    sens_meta = {
        "q": {"resolution": enc, "noise_sd": 0.0, "lag_s": 0.0},
        "qd": {"noise_sd": sens.qd_noise, "lag_s": 0.0},
        "u": {"resolution": sens.motor_encoder_res, "noise_sd": 0.0, "lag_s": 0.0},
        "ud": {"noise_sd": sens.ud_noise, "lag_s": 0.0},
        "torsion": {"resolution": enc},
        "torque": {"resolution": res_T, "noise_sd": sens.torque_noise, "lag_s": lag_T},
        "torque_load": {"resolution": sens.load_res, "noise_sd": sens.load_noise, "lag_s": 0.0},
        "temp_joint": {"resolution": sens.temp_res, "noise_sd": sens.temp_noise},
    }
    for k in range(1, 4):
        sens_meta[f"i_m{k}"] = {"noise_sd": sens.current_noise}
        sens_meta[f"w_m{k}"] = {"noise_sd": REDUCTION * sens.ud_noise * math.sqrt(2.0)}
        sens_meta[f"temp_m{k}"] = {"resolution": sens.temp_res, "noise_sd": sens.temp_noise}
    started = datetime(2026, 3, 2, 8, 0, tzinfo=timezone.utc) + timedelta(days=seed % 997, minutes=15 * run)
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
        "direction": int(dirn),
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": started.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "notes": f"{RIG_NAME}: independent validation simulator of the J4 bench, scheme {scheme}, "
                 f"{periods} period(s)",
        "sensors": sens_meta,
        "temp_joint_start_c": temp0,
        "periods": periods,
    }
    params = dict(mp)
    params.update(scheme=scheme, direction=int(dirn), temp_joint_start_c=temp0, periods=periods,
                  seed=seed, run=run, substep_s=h, substeps_per_sample=m, duration_s=t_end,
                  v_out=vout, u0=u0, phases=[list(s) for s in segs],
                  torque_cmd_knots=[tk.tolist(), vk.tolist()], effects=eparams,
                  sensors={k: getattr(sens, k) for k in _SENSOR_RANGES},
                  fourier={"a": a_f.tolist(), "b": b_f.tolist(), "omega_f": wf,
                           "t_start": 2.0, "period_s": FOURIER_PERIOD_S})
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
