"""Rig L — an independent model of the CMOR joint-4 test platform (data sheet).

Written blind from the public description of the rig (the CFETR CMOR J4 paper and the shared
docs) and from the literature on joint friction and compliance. It imports nothing of this
repository (numpy, pandas, numba only). What sets it apart from a textbook Eq. 4 + Eq. 5 model:

* a **two-inertia drive train under closed-loop control**: the three S120-driven motors
  (a large referred inertia) run a cascaded position/speed PI loop with feed-forward and a torque
  limit; the output link hangs on a **nonlinear (stiffening) transmission**; the output encoder,
  the motor encoder, the joint torque transducer and the load cell are read through modelled
  sensor chains;
* a **dynamic (LuGre-type bristle) friction** at the output: presliding, frictional lag and a
  short stick at every velocity reversal, while its steady-state curve is exactly Eq. 4's
  ``f_c·sgn(q̇) + f_v·q̇`` at scale 0;
* a **dynamometer with its own dynamics** (second-order torque loop, gain error, reducer drag,
  slowly wandering torque error) seen through the load cell;
* a **gearbox temperature state** that warms with the dissipated power and cools to the hall;
* an **integrating ADC** (the torque, load and current channels are averaged over one sample
  period, centred on the sample's time stamp) and a **windowed finite-difference velocity**.

Units: SI, angles in rad, temperatures in °C. ``N = 11000`` (``REDUCTION``). ``u`` is the motor
angle divided by N; the twist is ``Δ = u − q``.

Nominal physics (scale 0) — each campaign ``seed`` draws every value below a few % around it
(truncated normal, sd in brackets; ``params`` of the run returns the drawn values)
---------------------------------------------------------------------------------------------
Output side (Eq. 4 with the load):
    ``I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − F + d``
    I = 6685 kg·m² (3 %), mr_x = 20.8 kg·m (5 %), mr_y = −34.5 kg·m (5 %), g = 9.81 m/s²;
    ``d`` is an external torque on the output (0 at scale 0; see periodic_disturbance and
    second_resonance). ``truth`` holds every term, so the balance holds to rounding.
Friction F (LuGre bristle state z, exact exponential update of z):
    ``ż = q̇ − σ0·|q̇|·z / g(q̇)``, ``F = σ0·z + σ1·ż + f_v·q̇``, nominal ``g = f_c``;
    f_c = 2353 N·m (4 %), f_v = 8683 N·m·s/rad (4 %), σ0 = 2.4e7 N·m/rad (10 %, presliding
    ≈ f_c/σ0 ≈ 1e-4 rad ≈ 0.56 encoder step), σ1 = 3e4 N·m·s/rad (10 %).
    At the start the bristle holds the output in static equilibrium.
Transmission (output-side torque T, what the joint torque transducer measures):
    ``T = T_el(Δ) + D·Δ̇``, ``T_el(δ) = k2·δ − (k2 − k1)·δk·tanh(δ/δk)``:
    k1 = 0.9e7 N·m/rad around zero twist (5 %), k2 = 1.6e7 N·m/rad loaded (5 %), knee
    δk = 2e-3 rad (5 %), D = 3e4 N·m·s/rad (10 %). About 0.0084 rad (0.48°) of twist at
    120 kN·m. First output mode ≈ 5.8 Hz around zero twist (≈ 7.8 Hz loaded).
Motor side (all referred to the output):
    ``J_m·ü = T_m − T − F_m(u̇)``, J_m = 8e5 kg·m² (5 %; three rotors × N²),
    ``F_m = 3000·tanh(u̇/1e-4) + 2e4·u̇`` N·m (10 %), T_m limited to ±1.8e5 N·m.
    Control (S120 cascade): ``ω_cmd = u̇_ref + K_p·(u_ref − u)``,
    ``T_m = K_v·(ω_cmd − u̇) + K_i·∫(ω_cmd − u̇) + J_m·ü_ref`` with K_p = 6 1/s,
    K_v = 2.4e7 N·m·s/rad, K_i = 1.9e8 N·m/rad (anti-wind-up by clamping).
    Currents: ``i_k = s_k·T_m / (3·N·k_t)``, k_t = 1.6 N·m/A (2 %), shares s_k = 1 ± 3 %
    (normalised to a mean of 1).
Dynamometer and load cell:
    ``τ̈_d = ω_d²·(τ_cmd + e_L(t) − τ_d) − 2ζ_d·ω_d·τ̇_d`` with ω_d = 2π·1.2 rad/s, ζ_d = 0.85;
    ``τ_L = (1 + ε_d)·τ_d + c_d·q̇ + F_d·tanh(q̇/1e-4) + r_L(t)``: gain error ε_d ~ U(±0.5 %),
    reducer drag c_d = 2000 N·m·s/rad, F_d = 120 N·m (10 %) — so τ_L is "0-ish" (±~200 N·m) in
    scheme 3. e_L is an Ornstein–Uhlenbeck torque error (sd 60 N·m, correlation 0.3 s) drawn
    from (seed, run) on a fixed 10 ms grid (column ``load_error`` of ``noise``), and r_L a
    broadband torque ripple of the dynamometer (white, sd 40 N·m, on the same 10 ms grid,
    linearly interpolated, added to τ_L directly; column ``load_ripple``): process disturbances,
    both real torques on the output, both measured by the load cell. r_L keeps the drive train's
    modes gently excited.
    Sign: ``τ_cmd = direction × profile``, i.e. the load always resists the motion.
Gearbox temperature θ (the relevant lubricant temperature, truth ``temp_joint``):
    ``C·θ̇ = |F·q̇| + |F_m·u̇| − (θ − θ_hall)/R``, C = 4e4 J/K, R = 0.09 K/W (10 %),
    θ_hall = 20 °C ± 2, θ(0) = ``temp_joint_c``.

Schemes (rig.md)
----------------
1. 100 s: motor speed ramps (0.5–1.5 s, raised cosine) to ``direction·rpm·2π/60/N`` and stays;
   idle to 4 s, load ramp 0 → 120 kN·m to 49 s, hold to 53 s, unload to 98 s, idle to 100 s.
2. 45 s: same motor start; idle to 3 s, 12 × (1 s ramp of +10 kN·m, ``load``; 2 s pause,
   ``hold``), unload 39–43 s, idle to 45 s.
3. ``periods`` × T_f: fifth-order Fourier trajectory (Eq. 12) on the output reference, times
   ``direction``: T_f ~ U(20, 25) s and the coefficients are drawn from ``seed`` (the best of 24
   random draws by the log condition number of Eq. 4's regressor), constrained to start at rest
   (q = q̇ = q̈ = 0) and scaled to a peak speed of 0.025 rad/s. Unloaded (τ_cmd = 0), phase
   ``excite``. ``motor_speed_rpm`` must be None.
Motor speed is limited to 3200 r/min (scheme 1 at that speed travels ≈ 3.1 rad).

Sensors (stated in ``meta['sensors']``: resolution, noise_sd, lag_s per channel)
--------------------------------------------------------------------------------
Samples at ``t = k/fs`` from 0. The model integrates on a fixed step dt = Ts/m ≤ 0.5 ms
(symplectic Euler) so that every sample falls on a step.
* ``q``: output encoder, latched at the sample time, rounded to ``encoder_res_deg`` (0.01°),
  zeroed at the run's start; no noise, no lag.
* ``qd``: ``(q_enc(t) − q_enc(t − W))/W`` over ``qd_window_s`` W = 0.1 s (rounded to whole
  steps) of the quantised output encoder: lag W/2, resolution = encoder step / W, no noise.
* ``u``: motor encoder (``motor_encoder_bits`` = 20 bit per motor turn) divided by N, no noise.
* ``ud``: the drive's speed actual value / N, first-order filtered (``ud_filter_s`` = 2 ms =
  its lag), noise ``ud_noise`` = 2e-7 rad/s, resolution ``ud_res`` = 1e-7 rad/s.
* ``torque``: joint torque transducer: pure delay ``torque_lag_s`` (default 4 ms), then an
  integrating ADC averaging over one sample period centred on the time stamp (zero phase),
  white noise ``torque_noise`` (default 150 N·m), rounding to ``torque_res`` (16 bit over
  ±200 kN·m = 6.1 N·m).
* ``torque_load``: load cell, same ADC, noise ``load_noise`` = 100 N·m, ``load_res`` = 6.1 N·m,
  no lag.
* ``i_m1..3``: ADC-averaged, noise 0.01 A, resolution 0.001 A, no lag.
* ``temp_joint``: PT100 with a first-order lag ``temp_lag_s`` = 5 s, noise 0.05 °C,
  resolution 0.1 °C.
* ``torque_cmd``: the dynamometer set point as sent (exact).
Noise is drawn from (seed, run) before any effect is considered (``RigRun.noise``: the sensor
noises added, per sample, and the dynamometer's process disturbances at the sample times).

Unstated imperfections (present at scale 0, not in ``meta``)
------------------------------------------------------------
* the joint torque transducer's gain is off by ε_T ~ U(−0.05 %, +0.05 %) per campaign (≤ 60 N·m
  at 120 kN·m);
* the output encoder disc is eccentric: its reading carries ``A_e·(sin(q + φ_e) − sin φ_e)``
  with A_e = 0.0005° (8.7e-6 rad, 1/20 of a step), φ_e drawn per campaign.
* the dynamometer's broadband ripple r_L (above) is a real torque, not sensor noise, so it is in
  no ``noise_sd``; it rings the first output mode (≈ 7 Hz) and, above that mode, the output
  inertia rather than the transmission takes it, so an Eq. 4 balance read from the sensors keeps
  ≈ 60 N·m rms of it (mostly 6–20 Hz, q̈ far below the encoder's resolution) at 1 kHz, ≈ 50 N·m
  at 30 Hz.

Run record (``RigRun``)
-----------------------
``samples``: t, q, qd, u, ud, torque, torque_load, temp_joint, i_m1..3, torque_cmd, phase
(idle/load/hold/unload/excite). ``truth`` at the sample times: t, q, qd, qdd, u, ud, twist (u − q),
torque (T), torque_load (τ_L), gravity, friction (F), torque_ext (d), temp_joint (θ), torque_cmd.
``meta``: scheme, reduction, sample_rate_hz, temp_joint_c, direction, motor_speed_rpm (None for
scheme 3), source "emulator", rig "rig_l", sensors, sensor_units (+ periods for scheme 3); no
effect and no rig parameter. ``params``: the drawn rig (floats). ``noise``: see above.
``SEED_IS_CAMPAIGN``: the rig, its effect phases and the trajectory come from ``seed`` only.

Effects (``effects = {name: {"form": str, "scale": float}}``; the first form is the default;
scale absent or 0 → nominal bit for bit; scale > SCALE_MAX is clamped; each contribution is
proportional to the scale). Sizes at scale 1; phases φ are drawn per campaign seed.
--------------------------------------------------------------------------------------------
stribeck — added to the bristle level: ``g += A·φ(|q̇|/v_s)``, A = 0.25·f_c ≈ 590 N·m,
    v_s = 0.003 rad/s. Forms: ``exponential`` φ = e^(−x); ``gaussian`` e^(−x²);
    ``lorentzian`` 1/(1 + x²); ``root`` e^(−√x).
load_dependent_friction — on |T| (transmitted torque). Forms: ``coulomb`` g += 0.003·|T|
    (360 N·m at 120 kN·m); ``coulomb_viscous`` g += 0.0015·|T| and f_v ×(1 + 0.6·|T|/120 kN·m);
    ``quadratic`` g += 2.5e-8·T² (360 N·m at 120 kN·m); ``saturating`` g += 0.006·40 kN·m·
    tanh(|T|/40 kN·m) (an efficiency loss that levels off, 239 N·m at 120 kN·m).
temperature_friction — on the true gearbox temperature θ, θ_ref = 35 °C. Forms:
    ``viscous_exponential`` f_v ×(1 + (e^(−0.025·(θ−35)) − 1)) (Vogel/Arrhenius-like);
    ``coulomb_additive`` g += −8 N·m/K·(θ − 35); ``multiplicative`` g and f_v ×
    (1 − 0.004/K·(θ − 35)); ``viscous_additive`` f_v += −300 N·m·s/rad/K·(θ − 35).
gear_ripple — Forms: ``output_mesh`` torque ripple in T,
    200·sin(87q + φ1) + 80·sin(174q + φ2) N·m; ``output_kinematic`` transmission error on the
    output angle, Δ → Δ − e, e = 1.7e-5·sin(87q + φ1) + 0.7e-5·sin(174q + φ2) rad;
    ``intermediate_shaft`` the same error at 2 and 4 cycles per turn of a shaft turning 121× the
    output (orders 242, 484 of the output, e in terms of u); ``motor_shaft`` 1.7e-5 rad and
    0.7e-5 rad at 2 and 4 cycles per motor turn (orders 22000, 44000).
torque_offset — on the joint torque channel only (after the ADC). Forms: ``constant`` +250 N·m;
    ``drift`` +3 N·m/s·t; ``settling`` +300·(1 − e^(−t/25 s)) N·m.
time_delay — unstated extra delay of the joint torque channel, before the stated lag. Forms:
    ``pure_delay`` 20 ms; ``first_order`` a first-order lag of 20 ms; ``fieldbus_hold`` the
    reading is refreshed every 40 ms (sample-and-hold, mean delay 20 ms, phase per campaign).
hysteresis — in the transmission (state x, explicit Euler, clipped to its bound). Forms:
    ``bouc_wen`` n = 1: ẋ = Δ̇ − β|Δ̇|x − γΔ̇|x|, β = γ = 1/(2·x_s), T += k_h·x;
    ``bouc_wen_n2`` n = 2: ẋ = Δ̇ − β|Δ̇||x|x − γΔ̇x², β = γ = 1/(2·x_s²), T += k_h·x;
    ``dahl`` ẋ = Δ̇·(1 − sgn(Δ̇)·x/x_s)², T += k_h·x; with x_s = 1e-4 rad, k_h = 2.5e6 N·m/rad
    (±250 N·m); ``load_proportional`` T += 0.003·|T_el|·ζ, ζ̇ = Δ̇/1e-4·(1 − sgn(Δ̇)·ζ)
    (a Coulomb-like loss whose level grows with the load, ±360 N·m at 120 kN·m).
backlash — dead zone of half-width b = 2.5e-5 rad (k·b ≈ 300 N·m) on the elastic twist. Forms:
    ``sharp`` δ = sgn(Δ)·max(|Δ| − b, 0); ``smooth`` δ = Δ − b·tanh(Δ/b);
    ``load_closing`` sharp with b/(1 + (T/20 kN·m)²) (the gap closes under load).
asymmetric_friction — per sign of q̇. Forms: ``coulomb`` f_c ×(1 + 0.10) for q̇ > 0 and
    ×(1 − 0.05) for q̇ < 0; ``viscous`` f_v ×(1 + 0.6) / ×(1 − 0.2); ``both`` f_c
    ×(1 + 0.06)/(1 − 0.03) and f_v ×(1 + 0.35)/(1 − 0.12).
periodic_disturbance (outside the vocabulary) — Forms: ``output_sine`` d += 250·sin(2π·2.7 t +
    φ) N·m on the output link (frequency ±5 % per campaign); ``output_two_tone`` d += 180·sin(2π·
    1.3 t + φ) + 120·sin(2π·7.9 t + φ') N·m; ``torque_pickup`` 300·sin(2π·50 t + φ) N·m of
    mains pick-up on the joint torque channel before the ADC (averaged away in part at low rates).
position_dependent_stiffness (outside) — T_el ×(1 + a(q)). Forms: ``once_per_rev``
    a = 0.004·cos(q + φ); ``twice_per_rev`` a = 0.004·cos(2q + φ); ``soft_zone``
    a = −0.01·exp(−((q − 0.06)/0.06)²) (a soft spot of the bearing seat, seen only when q > 0).
sensor_drift (outside) — Forms: ``load_cell_drift`` torque_load += 3 N·m/s·t;
    ``load_cell_settling`` torque_load += 300·(1 − e^(−t/25 s)) N·m; ``encoder_creep`` the output
    encoder's coupling creeps, q reading += 3e-7 rad/s·t.
second_resonance (outside) — a secondary inertia hung on a spring from the output link (e.g. the
    loading flange and coupling); participation ∝ scale (inertia, stiffness and damping all ×
    scale, so the mode frequency stays put); its reaction torque on the output goes into d, kept
    excited by the dynamometer's ripple, reversals and load steps. Forms: ``heavy_branch``
    3000 kg·m², 9 Hz, ζ = 0.015; ``light_branch`` 2000 kg·m², 14 Hz, ζ = 0.01.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import pandas as pd
from numba import njit

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "rig_l"
SCALE_MAX = 3.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "root"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "quadratic", "saturating"),
    "temperature_friction": ("viscous_exponential", "coulomb_additive", "multiplicative",
                             "viscous_additive"),
    "gear_ripple": ("output_mesh", "output_kinematic", "intermediate_shaft", "motor_shaft"),
    "torque_offset": ("constant", "drift", "settling"),
    "time_delay": ("pure_delay", "first_order", "fieldbus_hold"),
    "hysteresis": ("bouc_wen", "bouc_wen_n2", "dahl", "load_proportional"),
    "backlash": ("sharp", "smooth", "load_closing"),
    "asymmetric_friction": ("coulomb", "viscous", "both"),
    "periodic_disturbance": ("output_sine", "output_two_tone", "torque_pickup"),
    "position_dependent_stiffness": ("once_per_rev", "twice_per_rev", "soft_zone"),
    "sensor_drift": ("load_cell_drift", "load_cell_settling", "encoder_creep"),
    "second_resonance": ("heavy_branch", "light_branch"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "sensor_drift", "second_resonance")

_EFFECT_NAMES = tuple(EFFECT_FORMS)
_EI = {name: i for i, name in enumerate(_EFFECT_NAMES)}
# effect indices (module constants, frozen into the numba kernel)
E_STRIB = 0
E_LOAD = 1
E_TEMP = 2
E_RIPPLE = 3
E_OFFSET = 4
E_DELAY = 5
E_HYST = 6
E_BACKLASH = 7
E_ASYM = 8
E_PERIODIC = 9
E_POSSTIFF = 10
E_DRIFT = 11
E_RESON = 12
assert [_EI[k] for k in ("stribeck", "load_dependent_friction", "temperature_friction",
                         "gear_ripple", "torque_offset", "time_delay", "hysteresis", "backlash",
                         "asymmetric_friction", "periodic_disturbance",
                         "position_dependent_stiffness", "sensor_drift",
                         "second_resonance")] == list(range(13))

G_ACC = 9.81
T_RATED = 120_000.0
VMAX_EXCITE = 0.025            # rad/s, peak output speed of the scheme-3 trajectory
RPM_MAX = 3200.0
DT_MAX = 5e-4                  # s, largest integration step
OU_DT = 0.01                   # s, grid of the dynamometer's torque error
OU_SD = 60.0                   # N·m
OU_TAU = 0.3                   # s
RIPPLE_SD = 40.0               # N·m, dynamometer broadband torque ripple (white on the OU grid)
SPEED_RAMP_T0 = 0.5            # s
SPEED_RAMP_T = 1.0             # s
SR_OUT = (3000.0, 9.0, 0.015)  # second resonance, output branch: kg·m², Hz, damping ratio
SR_LIGHT = (2000.0, 14.0, 0.01)  # second resonance, light branch on the output

# --- physical parameter vector (indices) ------------------------------------------------------
P_I, P_MRX, P_MRY, P_FV, P_FC, P_K1, P_K2, P_DK, P_D, P_S0, P_S1, P_JM, P_KP, P_KV, P_KI, \
    P_TMAX, P_FCM, P_FVM, P_DYNW, P_DYNZ, P_DYNG, P_DRAGV, P_DRAGC, P_THC, P_THR, P_THA, \
    P_TH0, P_Q0 = range(28)
NP = 28

# --- effect constants vector (indices) --------------------------------------------------------
(C_STR_A, C_STR_VS,
 C_LD_MU, C_LD_MU_CV, C_LD_FV_REL, C_LD_Q2, C_LD_MU_SAT, C_LD_TSAT,
 C_TF_REF, C_TF_EXP, C_TF_ADD_C, C_TF_MULT, C_TF_ADD_V,
 C_GR_A1, C_GR_A2, C_GR_Z, C_GR_PHI1, C_GR_PHI2, C_GR_E1, C_GR_E2, C_GR_SHAFT,
 C_HY_KH, C_HY_XS, C_HY_ETA, C_HY_ZW,
 C_BL_B, C_BL_TC,
 C_AS_CP, C_AS_CN, C_AS_VP, C_AS_VN, C_AS_BCP, C_AS_BCN, C_AS_BVP, C_AS_BVN,
 C_PD_A, C_PD_F, C_PD_PHI, C_PD_A1, C_PD_F1, C_PD_PHI1, C_PD_A2, C_PD_F2, C_PD_PHI2,
 C_PS_A, C_PS_PHI, C_PS_AZ, C_PS_Q0, C_PS_W,
 C_SR_J, C_SR_K, C_SR_C, C_SR_JM, C_SR_KM, C_SR_CM) = range(55)
NC = 55


@dataclass
class SensorSpec:
    """What the rig's sensor chain does (see the module docstring); every value is stated in
    the run's ``meta['sensors']``."""
    sample_rate_hz: float = 100.0
    encoder_res_deg: float = 0.01          # output encoder step [deg]
    torque_noise: float = 150.0            # joint torque transducer white noise sd [N·m]
    torque_lag_s: float = 0.004            # stated (and applied) pure delay of torque [s]
    torque_res: float = 400_000.0 / 65536  # ADC step of the torque channel [N·m]
    load_noise: float = 100.0              # load cell noise sd [N·m]
    load_res: float = 400_000.0 / 65536    # ADC step of the load cell [N·m]
    motor_encoder_bits: int = 20           # motor encoder, counts per motor turn = 2**bits
    qd_window_s: float = 0.1               # finite-difference window of the qd reading [s]
    ud_filter_s: float = 0.002             # drive speed filter time constant [s]
    ud_noise: float = 2e-7                 # [rad/s] (output-referred)
    ud_res: float = 1e-7                   # [rad/s] (output-referred)
    current_noise: float = 0.01            # [A]
    current_res: float = 0.001             # [A]
    temp_noise: float = 0.05               # [°C]
    temp_res: float = 0.1                  # [°C]
    temp_lag_s: float = 5.0                # PT100 first-order lag [s]


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict
    noise: pd.DataFrame


# =============================================================================================
# numba kernel
# =============================================================================================

@njit(cache=True)
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def _transmission(q, v, u, w, xh, Tprev, form, scale, P, C):
    """Output-side transmitted torque T, the elastic part T_el and the twist rate seen by the
    hysteresis (after any kinematic error)."""
    d = u - q
    dd = w - v
    fg = form[E_RIPPLE]
    sg = scale[E_RIPPLE]
    if fg == 1:      # output kinematic error
        a1 = C[C_GR_Z] * q + C[C_GR_PHI1]
        a2 = 2.0 * C[C_GR_Z] * q + C[C_GR_PHI2]
        d -= sg * (C[C_GR_E1] * math.sin(a1) + C[C_GR_E2] * math.sin(a2))
        dd -= sg * (C[C_GR_E1] * C[C_GR_Z] * math.cos(a1)
                    + C[C_GR_E2] * 2.0 * C[C_GR_Z] * math.cos(a2)) * v
    elif fg == 2 or fg == 3:   # intermediate shaft / motor shaft, 2 and 4 cycles per turn
        ratio = C[C_GR_SHAFT] if fg == 2 else 11000.0
        a1 = 2.0 * ratio * u + C[C_GR_PHI1]
        a2 = 4.0 * ratio * u + C[C_GR_PHI2]
        d -= sg * (C[C_GR_E1] * math.sin(a1) + C[C_GR_E2] * math.sin(a2))
        dd -= sg * (C[C_GR_E1] * 2.0 * ratio * math.cos(a1)
                    + C[C_GR_E2] * 4.0 * ratio * math.cos(a2)) * w
    fb = form[E_BACKLASH]
    if fb >= 0:
        b = scale[E_BACKLASH] * C[C_BL_B]
        if fb == 2:
            r = Tprev / C[C_BL_TC]
            b = b / (1.0 + r * r)
        if fb == 1:
            d = d - b * math.tanh(d / b)
        else:
            ad = abs(d) - b
            d = _sgn(d) * ad if ad > 0.0 else 0.0
    k1 = P[P_K1]
    k2 = P[P_K2]
    dk = P[P_DK]
    tel = k2 * d - (k2 - k1) * dk * math.tanh(d / dk)
    fp = form[E_POSSTIFF]
    if fp >= 0:
        sp = scale[E_POSSTIFF]
        if fp == 0:
            tel *= 1.0 + sp * C[C_PS_A] * math.cos(q + C[C_PS_PHI])
        elif fp == 1:
            tel *= 1.0 + sp * C[C_PS_A] * math.cos(2.0 * q + C[C_PS_PHI])
        else:
            r = (q - C[C_PS_Q0]) / C[C_PS_W]
            tel *= 1.0 - sp * C[C_PS_AZ] * math.exp(-r * r)
    T = tel + P[P_D] * dd
    fh = form[E_HYST]
    if fh >= 0:
        if fh == 3:
            T += scale[E_HYST] * C[C_HY_ETA] * abs(tel) * xh
        else:
            T += scale[E_HYST] * C[C_HY_KH] * xh
    if fg == 0:
        T += sg * (C[C_GR_A1] * math.sin(C[C_GR_Z] * q + C[C_GR_PHI1])
                   + C[C_GR_A2] * math.sin(2.0 * C[C_GR_Z] * q + C[C_GR_PHI2]))
    return T, tel, dd


@njit(cache=True)
def _friction_level(v, T, th, form, scale, P, C):
    """Bristle level g(q̇) (> 0) and the viscous coefficient."""
    fc = P[P_FC]
    fv = P[P_FV]
    sv = _sgn(v)
    fa = form[E_ASYM]
    if fa >= 0:
        sa = scale[E_ASYM]
        if fa == 0 or fa == 2:
            ip = C_AS_CP if fa == 0 else C_AS_BCP
            inn = C_AS_CN if fa == 0 else C_AS_BCN
            if sv > 0.0:
                fc = fc * (1.0 + sa * C[ip])
            elif sv < 0.0:
                fc = fc * (1.0 + sa * C[inn])
        if fa == 1 or fa == 2:
            ip = C_AS_VP if fa == 1 else C_AS_BVP
            inn = C_AS_VN if fa == 1 else C_AS_BVN
            if sv > 0.0:
                fv = fv * (1.0 + sa * C[ip])
            elif sv < 0.0:
                fv = fv * (1.0 + sa * C[inn])
    ft = form[E_TEMP]
    if ft >= 0:
        st = scale[E_TEMP]
        dth = th - C[C_TF_REF]
        if ft == 0:
            fv = fv * (1.0 + st * (math.exp(-C[C_TF_EXP] * dth) - 1.0))
        elif ft == 1:
            fc = fc + st * C[C_TF_ADD_C] * dth
        elif ft == 2:
            fac = 1.0 + st * C[C_TF_MULT] * dth
            fc = fc * fac
            fv = fv * fac
        else:
            fv = fv + st * C[C_TF_ADD_V] * dth
    g = fc
    fl = form[E_LOAD]
    if fl >= 0:
        sl = scale[E_LOAD]
        aT = abs(T)
        if fl == 0:
            g += sl * C[C_LD_MU] * aT
        elif fl == 1:
            g += sl * C[C_LD_MU_CV] * aT
            fv = fv * (1.0 + sl * C[C_LD_FV_REL] * aT / 120000.0)
        elif fl == 2:
            g += sl * C[C_LD_Q2] * T * T
        else:
            g += sl * C[C_LD_MU_SAT] * C[C_LD_TSAT] * math.tanh(aT / C[C_LD_TSAT])
    fs = form[E_STRIB]
    if fs >= 0:
        x = abs(v) / C[C_STR_VS]
        if fs == 0:
            ph = math.exp(-x)
        elif fs == 1:
            ph = math.exp(-x * x)
        elif fs == 2:
            ph = 1.0 / (1.0 + x * x)
        else:
            ph = math.exp(-math.sqrt(x))
        g += scale[E_STRIB] * C[C_STR_A] * ph
    gmin = 0.05 * P[P_FC]
    if g < gmin:
        g = gmin
    if fv < 0.0:
        fv = 0.0
    return g, fv


@njit(cache=True)
def _kernel(J, dt, m, n, scheme, direction, w0, P, C, prof_t, prof_v, fa, fb, wf, ou, rip, ou_dt,
            form, scale,
            fT, fTL, fTM, fq, fw, fth,
            tq, tv, tqdd, tu, tw, tT, tTL, tG, tF, tD, tth, tcmd):
    I = P[P_I]
    s0 = P[P_S0]
    s1 = P[P_S1]
    Jm = P[P_JM]
    kp = P[P_KP]
    kv = P[P_KV]
    ki = P[P_KI]
    tmax = P[P_TMAX]
    wd = P[P_DYNW]
    zd = P[P_DYNZ]
    nou = ou.shape[0]
    npr = prof_t.shape[0]

    q = 0.0
    v = 0.0
    u = 0.0
    w = 0.0
    xh = 0.0
    integ = 0.0
    th = P[P_TH0]
    td = ou[0]
    tdd = 0.0
    y = 0.0
    yd = 0.0
    Tprev = 0.0
    ip = 0

    # static equilibrium of the output at the start: the bristle holds gravity and the load
    T0 = _transmission(q, v, u, w, xh, Tprev, form, scale, P, C)[0]
    G0 = G_ACC * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    TL0 = (1.0 + P[P_DYNG]) * td + rip[0]
    zlim = 0.9 * P[P_FC] / s0
    z = (T0 - TL0 - G0) / s0
    if z > zlim:
        z = zlim
    elif z < -zlim:
        z = -zlim

    two_pi = 2.0 * math.pi
    for j in range(J):
        t = j * dt
        # ---------------- references
        if scheme == 3:
            ur = 0.0
            urd = 0.0
            urdd = 0.0
            for l in range(fa.shape[0]):
                L = l + 1.0
                ph = wf * L * t
                sn = math.sin(ph)
                cs = math.cos(ph)
                ur += fa[l] / (wf * L) * sn - fb[l] / (wf * L) * cs
                urd += fa[l] * cs + fb[l] * sn
                urdd += -fa[l] * wf * L * sn + fb[l] * wf * L * cs
            ur = direction * (ur + P[P_Q0])
            urd = direction * urd
            urdd = direction * urdd
            cmd = 0.0
        else:
            tau = t - SPEED_RAMP_T0
            if tau <= 0.0:
                ur = 0.0
                urd = 0.0
                urdd = 0.0
            elif tau < SPEED_RAMP_T:
                a = math.pi * tau / SPEED_RAMP_T
                ur = w0 * 0.5 * (tau - SPEED_RAMP_T / math.pi * math.sin(a))
                urd = w0 * 0.5 * (1.0 - math.cos(a))
                urdd = w0 * 0.5 * math.pi / SPEED_RAMP_T * math.sin(a)
            else:
                ur = w0 * (0.5 * SPEED_RAMP_T + (tau - SPEED_RAMP_T))
                urd = w0
                urdd = 0.0
            while ip < npr - 2 and t >= prof_t[ip + 1]:
                ip += 1
            if t >= prof_t[npr - 1]:
                cmd = prof_v[npr - 1]
            else:
                fr = (t - prof_t[ip]) / (prof_t[ip + 1] - prof_t[ip])
                if fr < 0.0:
                    fr = 0.0
                cmd = prof_v[ip] + fr * (prof_v[ip + 1] - prof_v[ip])
            cmd = direction * cmd
        # dynamometer torque error (process disturbance), linear on its grid
        xo = t / ou_dt
        io = int(xo)
        if io >= nou - 1:
            eL = ou[nou - 1]
            eR = rip[nou - 1]
        else:
            eL = ou[io] + (xo - io) * (ou[io + 1] - ou[io])
            eR = rip[io] + (xo - io) * (rip[io + 1] - rip[io])

        # ---------------- forces
        T, tel, ddel = _transmission(q, v, u, w, xh, Tprev, form, scale, P, C)
        g, fvis = _friction_level(v, T, th, form, scale, P, C)
        av = abs(v)
        zdot = v - s0 * av * z / g
        F = s0 * z + s1 * zdot + fvis * v
        G = G_ACC * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
        TL = (1.0 + P[P_DYNG]) * td + P[P_DRAGV] * v + P[P_DRAGC] * math.tanh(v / 1e-4) + eR
        dist = 0.0
        fpd = form[E_PERIODIC]
        if fpd == 0:
            dist += scale[E_PERIODIC] * C[C_PD_A] * math.sin(two_pi * C[C_PD_F] * t + C[C_PD_PHI])
        elif fpd == 1:
            dist += scale[E_PERIODIC] * (
                C[C_PD_A1] * math.sin(two_pi * C[C_PD_F1] * t + C[C_PD_PHI1])
                + C[C_PD_A2] * math.sin(two_pi * C[C_PD_F2] * t + C[C_PD_PHI2]))
        fr2 = form[E_RESON]
        tb_out = 0.0
        if fr2 == 0:
            tb_out = C[C_SR_K] * (y - q) + C[C_SR_C] * (yd - v)
            dist += scale[E_RESON] * tb_out
        elif fr2 == 1:
            tb_out = C[C_SR_KM] * (y - q) + C[C_SR_CM] * (yd - v)
            dist += scale[E_RESON] * tb_out
        qdd = (T - TL - G - F + dist) / I

        # motor side control
        wcmd = urd + kp * (ur - u)
        ew = wcmd - w
        tm = kv * ew + ki * integ + Jm * urdd
        sat = False
        if tm > tmax:
            tm = tmax
            sat = True
        elif tm < -tmax:
            tm = -tmax
            sat = True
        fm = P[P_FCM] * math.tanh(w / 1e-4) + P[P_FVM] * w
        udd = (tm - T - fm) / Jm

        # ---------------- record
        fT[j] = T
        fTL[j] = TL
        fTM[j] = tm
        fq[j] = q
        fw[j] = w
        fth[j] = th
        if j % m == 0:
            k = j // m
            if k < n:
                tq[k] = q
                tv[k] = v
                tqdd[k] = qdd
                tu[k] = u
                tw[k] = w
                tT[k] = T
                tTL[k] = TL
                tG[k] = G
                tF[k] = F
                tD[k] = dist
                tth[k] = th
                tcmd[k] = cmd

        # ---------------- state update (symplectic Euler; exact exponential for the bristle)
        if av > 0.0:
            r = s0 * av / g
            zss = _sgn(v) * g / s0
            z = zss + (z - zss) * math.exp(-r * dt)
        fh = form[E_HYST]
        if fh >= 0:
            xs = C[C_HY_XS]
            sd = _sgn(ddel)
            if fh == 0:
                xdot = ddel - (0.5 / xs) * abs(ddel) * xh - (0.5 / xs) * ddel * abs(xh)
            elif fh == 1:
                bb = 0.5 / (xs * xs)
                xdot = ddel - bb * abs(ddel) * abs(xh) * xh - bb * ddel * xh * xh
            elif fh == 2:
                rr = 1.0 - sd * xh / xs
                xdot = ddel * rr * rr
            else:
                xdot = ddel / C[C_HY_ZW] * (1.0 - sd * xh)
            xh += xdot * dt
            lim = xs if fh <= 2 else 1.0
            if xh > lim:
                xh = lim
            elif xh < -lim:
                xh = -lim
        if fr2 >= 0:
            ydd = -tb_out / (C[C_SR_J] if fr2 == 0 else C[C_SR_JM])
            yd += ydd * dt
            y += yd * dt
        if not sat:
            integ += ew * dt
        v += qdd * dt
        q += v * dt
        w += udd * dt
        u += w * dt
        tdd += (wd * wd * (cmd + eL - td) - 2.0 * zd * wd * tdd) * dt
        td += tdd * dt
        pw = abs(F * v) + abs(fm * w)
        th += (pw - (th - P[P_THA]) / P[P_THR]) / P[P_THC] * dt
        Tprev = T


@njit(cache=True)
def _at(x, p):
    """x at the fractional fine-step index p, linear interpolation; x[0] before 0, the last
    sample beyond the end."""
    J = x.shape[0]
    if p <= 0.0:
        return x[0]
    i = int(p)
    if i + 1 < J:
        return x[i] + (p - i) * (x[i + 1] - x[i])
    return x[J - 1]


@njit(cache=True)
def _delay(x, dsteps):
    """x delayed by dsteps (float, ≥ 0) fine steps, linear interpolation, x before 0 = x[0]."""
    J = x.shape[0]
    out = np.empty(J)
    for j in range(J):
        out[j] = _at(x, j - dsteps)
    return out


@njit(cache=True)
def _hold(x, dt, lag_steps, period, phase):
    """Sample-and-hold every `period` s (phase in s), then a delay of lag_steps."""
    J = x.shape[0]
    out = np.empty(J)
    for j in range(J):
        t = j * dt
        th = phase + period * math.floor((t - phase) / period)
        out[j] = _at(x, th / dt - lag_steps)
    return out


@njit(cache=True)
def _pt1(x, a, y0):
    """First-order filter, y += a·(x − y) per step."""
    J = x.shape[0]
    out = np.empty(J)
    y = y0
    for j in range(J):
        y += a * (x[j] - y)
        out[j] = y
    return out


@njit(cache=True)
def _adc(x, m, n):
    """Integrating ADC: mean over one sample period centred on each sample index k·m (trapezoid
    for even m); indices before 0 take x[0]."""
    out = np.empty(n)
    J = x.shape[0]
    for k in range(n):
        c = k * m
        if m == 1:
            out[k] = x[c]
            continue
        if m % 2 == 1:
            h = (m - 1) // 2
            s = 0.0
            for i in range(c - h, c + h + 1):
                s += x[i if i > 0 else 0] if i < J else x[J - 1]
            out[k] = s / m
        else:
            h = m // 2
            s = 0.0
            for i in range(c - h, c + h + 1):
                xi = x[i if i > 0 else 0] if i < J else x[J - 1]
                if i == c - h or i == c + h:
                    s += 0.5 * xi
                else:
                    s += xi
            out[k] = s / m
    return out


# =============================================================================================
# argument checks
# =============================================================================================

def _is_real(x: Any) -> bool:
    return (isinstance(x, (int, float, np.integer, np.floating))
            and not isinstance(x, (bool, np.bool_)))


def _finite(name: str, x: Any, *, positive: bool = False, nonneg: bool = False) -> float:
    if not _is_real(x):
        raise ValueError(f"{name} must be a real number, got {x!r}")
    xf = float(x)
    if not math.isfinite(xf):
        raise ValueError(f"{name} must be finite, got {x!r}")
    if positive and not xf > 0:
        raise ValueError(f"{name} must be > 0, got {x!r}")
    if nonneg and not xf >= 0:
        raise ValueError(f"{name} must be >= 0, got {x!r}")
    return xf


def _int(name: str, x: Any, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {x!r}")
    xi = int(x)
    if (lo is not None and xi < lo) or (hi is not None and xi > hi):
        raise ValueError(f"{name} must be in [{lo}, {hi}], got {x!r}")
    return xi


def _check_sensors(s: Any) -> SensorSpec:
    if not isinstance(s, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {type(s).__name__}")
    fs = _finite("sensors.sample_rate_hz", s.sample_rate_hz, positive=True)
    if not 0.5 <= fs <= 10_000.0:
        raise ValueError(f"sensors.sample_rate_hz must be in [0.5, 10000] Hz, got {fs!r}")
    _finite("sensors.encoder_res_deg", s.encoder_res_deg, positive=True)
    if s.encoder_res_deg > 1.0:
        raise ValueError(f"sensors.encoder_res_deg must be <= 1 deg, got {s.encoder_res_deg!r}")
    for nm in ("torque_noise", "torque_res", "load_noise", "load_res", "ud_noise", "ud_res",
               "current_noise", "current_res", "temp_noise", "temp_res", "torque_lag_s",
               "ud_filter_s", "temp_lag_s"):
        _finite(f"sensors.{nm}", getattr(s, nm), nonneg=True)
    if s.torque_lag_s > 1.0:
        raise ValueError(f"sensors.torque_lag_s must be <= 1 s, got {s.torque_lag_s!r}")
    _finite("sensors.qd_window_s", s.qd_window_s, positive=True)
    if s.qd_window_s > 2.0:
        raise ValueError(f"sensors.qd_window_s must be <= 2 s, got {s.qd_window_s!r}")
    _int("sensors.motor_encoder_bits", s.motor_encoder_bits, 8, 32)
    return s


def _normalise_effects(effects: Any) -> dict[str, tuple[int, float]]:
    """{name: (form index, clamped scale)} for the effects that are on (scale > 0)."""
    if effects is None:
        return {}
    if not isinstance(effects, Mapping):
        raise ValueError(f"effects must be a dict {{name: {{'form', 'scale'}}}}, got "
                         f"{type(effects).__name__}")
    out: dict[str, tuple[int, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {', '.join(EFFECT_FORMS)}")
        if spec is None:
            spec = {}
        if not isinstance(spec, Mapping):
            raise ValueError(f"effect {name!r} must be given as {{'form': str, 'scale': float}}, "
                             f"got {spec!r}")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effect {name!r} has unknown key(s) {sorted(map(str, extra))}; "
                             f"allowed: 'form', 'scale'")
        forms = EFFECT_FORMS[name]
        form = spec.get("form", None)
        if form is None:
            form = forms[0]
        if not isinstance(form, str) or form not in forms:
            raise ValueError(f"unknown form {form!r} of effect {name!r}; known: "
                             f"{', '.join(forms)}")
        scale = spec.get("scale", 0.0)
        if scale is None:
            scale = 0.0
        if not _is_real(scale):
            raise ValueError(f"scale of effect {name!r} must be a real number, got {scale!r}")
        sc = float(scale)
        if not math.isfinite(sc):
            raise ValueError(f"scale of effect {name!r} must be finite, got {scale!r}")
        if sc < 0:
            raise ValueError(f"scale of effect {name!r} must be >= 0, got {scale!r}")
        sc = min(sc, SCALE_MAX)
        if sc > 0:
            out[name] = (forms.index(form), sc)
    return out


# =============================================================================================
# the rig drawn from the campaign seed
# =============================================================================================

def _tn(rng: np.random.Generator, mean: float, rel_sd: float) -> float:
    """Truncated normal (±2.5 sd) around mean, relative sd."""
    z = float(np.clip(rng.standard_normal(), -2.5, 2.5))
    return mean * (1.0 + rel_sd * z)


def _draw_rig(seed: int) -> tuple[dict, np.ndarray, np.ndarray]:
    rng = np.random.default_rng([seed, 0x4C01])
    p = {
        "I": _tn(rng, 6685.0, 0.03),
        "mr_x": _tn(rng, 20.8, 0.05),
        "mr_y": _tn(rng, -34.5, 0.05),
        "f_v": _tn(rng, 8683.0, 0.04),
        "f_c": _tn(rng, 2353.0, 0.04),
        "k1": _tn(rng, 0.9e7, 0.05),
        "k2": _tn(rng, 1.6e7, 0.05),
        "twist_knee": _tn(rng, 2e-3, 0.05),
        "D": _tn(rng, 3e4, 0.10),
        "sigma0": _tn(rng, 2.4e7, 0.10),
        "sigma1": _tn(rng, 3e4, 0.10),
        "J_m": _tn(rng, 8e5, 0.05),
        "K_p": 6.0,
        "K_v": 2.4e7,
        "K_i": 1.9e8,
        "T_m_max": 1.8e5,
        "F_c_motor": _tn(rng, 3000.0, 0.10),
        "f_v_motor": _tn(rng, 2e4, 0.10),
        "dyn_omega": 2 * math.pi * 1.2,
        "dyn_zeta": 0.85,
        "dyn_gain_error": float(rng.uniform(-0.005, 0.005)),
        "dyn_drag_v": _tn(rng, 2000.0, 0.10),
        "dyn_drag_c": _tn(rng, 120.0, 0.10),
        "thermal_C": 4e4,
        "thermal_R": _tn(rng, 0.09, 0.10),
        "temp_hall": 20.0 + float(rng.uniform(-2.0, 2.0)),
        "k_t": _tn(rng, 1.6, 0.02),
        "torque_gain_error": float(rng.uniform(-5e-4, 5e-4)),
        "encoder_ecc_rad": math.radians(0.0005),
        "encoder_ecc_phase": float(rng.uniform(0, 2 * math.pi)),
    }
    sh = 1.0 + 0.03 * np.clip(rng.standard_normal(3), -2.5, 2.5)
    sh = sh / sh.mean()
    for i in range(3):
        p[f"current_share_{i + 1}"] = float(sh[i])
    # effect constants (campaign-fixed phases and frequencies), from their own stream
    re = np.random.default_rng([seed, 0x4C02])
    ph = re.uniform(0, 2 * math.pi, 12)
    c = np.zeros(NC)
    c[C_STR_A] = 0.25 * 2353.0
    c[C_STR_VS] = 0.003
    c[C_LD_MU] = 0.003
    c[C_LD_MU_CV] = 0.0015
    c[C_LD_FV_REL] = 0.6
    c[C_LD_Q2] = 2.5e-8
    c[C_LD_MU_SAT] = 0.006
    c[C_LD_TSAT] = 40_000.0
    c[C_TF_REF] = 35.0
    c[C_TF_EXP] = 0.025
    c[C_TF_ADD_C] = -8.0
    c[C_TF_MULT] = -0.004
    c[C_TF_ADD_V] = -300.0
    c[C_GR_A1] = 200.0
    c[C_GR_A2] = 80.0
    c[C_GR_Z] = 87.0
    c[C_GR_PHI1] = ph[0]
    c[C_GR_PHI2] = ph[1]
    c[C_GR_E1] = 1.7e-5
    c[C_GR_E2] = 0.7e-5
    c[C_GR_SHAFT] = 121.0
    c[C_HY_KH] = 2.5e6
    c[C_HY_XS] = 1e-4
    c[C_HY_ETA] = 0.003
    c[C_HY_ZW] = 1e-4
    c[C_BL_B] = 2.5e-5
    c[C_BL_TC] = 20_000.0
    c[C_AS_CP], c[C_AS_CN] = 0.10, -0.05
    c[C_AS_VP], c[C_AS_VN] = 0.6, -0.2
    c[C_AS_BCP], c[C_AS_BCN] = 0.06, -0.03
    c[C_AS_BVP], c[C_AS_BVN] = 0.35, -0.12
    c[C_PD_A] = 250.0
    c[C_PD_F] = 2.7 * (1.0 + 0.05 * re.uniform(-1, 1))
    c[C_PD_PHI] = ph[2]
    c[C_PD_A1], c[C_PD_F1], c[C_PD_PHI1] = 180.0, 1.3 * (1.0 + 0.05 * re.uniform(-1, 1)), ph[3]
    c[C_PD_A2], c[C_PD_F2], c[C_PD_PHI2] = 120.0, 7.9 * (1.0 + 0.05 * re.uniform(-1, 1)), ph[4]
    c[C_PS_A] = 0.004
    c[C_PS_PHI] = ph[5]
    c[C_PS_AZ] = 0.01
    c[C_PS_Q0] = 0.06
    c[C_PS_W] = 0.06
    c[C_SR_J] = SR_OUT[0]
    c[C_SR_K] = SR_OUT[0] * (2 * math.pi * SR_OUT[1]) ** 2
    c[C_SR_C] = 2 * SR_OUT[2] * math.sqrt(c[C_SR_K] * c[C_SR_J])
    c[C_SR_JM] = SR_LIGHT[0]
    c[C_SR_KM] = SR_LIGHT[0] * (2 * math.pi * SR_LIGHT[1]) ** 2
    c[C_SR_CM] = 2 * SR_LIGHT[2] * math.sqrt(c[C_SR_KM] * c[C_SR_JM])
    post = {"pickup_phase": float(ph[6]), "hold_phase": float(re.uniform(0.0, 0.04))}
    return p, c, post


def _fourier(seed: int) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """Fifth-order Fourier excitation (Eq. 12): a, b [rad/s], ω_f, q0, best of 24 draws by the
    log condition number of Eq. 4's regressor."""
    rng = np.random.default_rng([seed, 0x4C03])
    period = float(rng.uniform(20.0, 25.0))
    wf = 2 * math.pi / period
    L = np.arange(1, 6, dtype=float)
    t = np.linspace(0.0, period, 800, endpoint=False)
    ph = np.outer(t, wf * L)
    sn, cs = np.sin(ph), np.cos(ph)
    best = None
    for _ in range(24):
        a = rng.standard_normal(5) / L
        b = rng.standard_normal(5) / L
        a[0] -= a.sum()                       # q̇(0) = 0
        b[0] = -(L[1:] * b[1:]).sum()         # q̈(0) = 0
        qd = cs @ a + sn @ b
        sc = VMAX_EXCITE / np.abs(qd).max()
        a, b, qd = a * sc, b * sc, qd * sc
        q = sn @ (a / (wf * L)) - cs @ (b / (wf * L))
        q0 = float((b / (wf * L)).sum())
        q = q + q0
        if np.abs(q).max() > 2.5:
            continue
        qdd = -sn @ (a * wf * L) + cs @ (b * wf * L)
        Y = np.column_stack([qdd, G_ACC * np.sin(q), G_ACC * np.cos(q), qd, np.sign(qd)])
        Y = Y / np.linalg.norm(Y, axis=0)
        cn = float(np.log(np.linalg.cond(Y)))
        if best is None or cn < best[0]:
            best = (cn, a.copy(), b.copy(), q0)
    assert best is not None
    return best[1], best[2], wf, best[3], period


def _scheme_profile(scheme: int) -> tuple[float, np.ndarray, np.ndarray, list]:
    """(duration, set-point knots t, values, phase segments [(t_end, phase)])."""
    if scheme == 1:
        kt = np.array([0.0, 4.0, 49.0, 53.0, 98.0, 100.0])
        kv = np.array([0.0, 0.0, T_RATED, T_RATED, 0.0, 0.0])
        seg = [(4.0, "idle"), (49.0, "load"), (53.0, "hold"), (98.0, "unload"), (1e9, "idle")]
        return 100.0, kt, kv, seg
    kt_l, kv_l, seg = [0.0, 3.0], [0.0, 0.0], [(3.0, "idle")]
    t0 = 3.0
    for i in range(12):
        kt_l += [t0 + 1.0, t0 + 3.0]
        kv_l += [(i + 1) * 10_000.0, (i + 1) * 10_000.0]
        seg += [(t0 + 1.0, "load"), (t0 + 3.0, "hold")]
        t0 += 3.0
    kt_l += [43.0, 45.0]
    kv_l += [0.0, 0.0]
    seg += [(43.0, "unload"), (1e9, "idle")]
    return 45.0, np.array(kt_l), np.array(kv_l), seg


SENSOR_UNITS = {"t": "s", "q": "rad", "qd": "rad/s", "u": "rad", "ud": "rad/s", "torque": "N·m",
                "torque_load": "N·m", "torque_cmd": "N·m", "temp_joint": "°C", "i_m1": "A",
                "i_m2": "A", "i_m3": "A", "phase": "text"}


def _quant(x: np.ndarray, res: float) -> np.ndarray:
    if res <= 0:
        return x
    return np.round(x / res) * res


# =============================================================================================
# public entry point
# =============================================================================================

def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None, *, sensors: SensorSpec = SensorSpec(),
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """Simulate one run of Rig L (see the module docstring). The physical rig (and the scheme-3
    trajectory) comes from ``seed``; the noise from (``seed``, ``run``)."""
    # ---- arguments
    if isinstance(scheme, (bool, np.bool_)) or not isinstance(scheme, (int, np.integer)) \
            or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if not _is_real(direction) or float(direction) not in (1.0, -1.0):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    direction = int(direction)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
        rpm = None
    else:
        if motor_speed_rpm is None:
            raise ValueError(f"motor_speed_rpm is required for scheme {scheme}")
        rpm = _finite("motor_speed_rpm", motor_speed_rpm, positive=True)
        if rpm > RPM_MAX:
            raise ValueError(f"motor_speed_rpm must be <= {RPM_MAX:g} r/min (travel past ±180°), "
                             f"got {motor_speed_rpm!r}")
    temp0 = _finite("temp_joint_c", temp_joint_c)
    if not -30.0 <= temp0 <= 100.0:
        raise ValueError(f"temp_joint_c must be in [-30, 100] °C, got {temp_joint_c!r}")
    periods = _int("periods", periods, 1, 50)
    seed = _int("seed", seed, 0)
    run = _int("run", run, 0)
    sensors = _check_sensors(sensors)
    eff = _normalise_effects(effects)

    # ---- the rig, the trajectory, the time grid
    p, C, post = _draw_rig(seed)
    fs = float(sensors.sample_rate_hz)
    Ts = 1.0 / fs
    m = max(1, int(math.ceil(Ts / DT_MAX - 1e-9)))
    dt = Ts / m
    fa, fb, wf, q0, period = _fourier(seed)
    if scheme == 3:
        duration = periods * period
        kt = np.array([0.0, 1.0])
        kv = np.array([0.0, 0.0])
        seg = [(1e9, "excite")]
        w0 = 0.0
    else:
        fa, fb, q0 = np.zeros(5), np.zeros(5), 0.0
        duration, kt, kv, seg = _scheme_profile(scheme)
        w0 = direction * rpm * 2 * math.pi / 60.0 / REDUCTION
    n = int(round(duration * fs))
    if n < 2:
        raise ValueError(f"sensors.sample_rate_hz={fs!r} gives fewer than 2 samples")
    J = (n - 1) * m + m // 2 + 1
    P = np.zeros(NP)
    P[P_I], P[P_MRX], P[P_MRY], P[P_FV], P[P_FC] = p["I"], p["mr_x"], p["mr_y"], p["f_v"], p["f_c"]
    P[P_K1], P[P_K2], P[P_DK], P[P_D] = p["k1"], p["k2"], p["twist_knee"], p["D"]
    P[P_S0], P[P_S1], P[P_JM] = p["sigma0"], p["sigma1"], p["J_m"]
    P[P_KP], P[P_KV], P[P_KI], P[P_TMAX] = p["K_p"], p["K_v"], p["K_i"], p["T_m_max"]
    P[P_FCM], P[P_FVM] = p["F_c_motor"], p["f_v_motor"]
    P[P_DYNW], P[P_DYNZ], P[P_DYNG] = p["dyn_omega"], p["dyn_zeta"], p["dyn_gain_error"]
    P[P_DRAGV], P[P_DRAGC] = p["dyn_drag_v"], p["dyn_drag_c"]
    P[P_THC], P[P_THR], P[P_THA], P[P_TH0] = p["thermal_C"], p["thermal_R"], p["temp_hall"], temp0
    P[P_Q0] = q0

    # ---- noise, drawn from (seed, run) before any effect is looked at
    rn = np.random.default_rng([seed, run, 0x4C04])
    nou = int(math.ceil(duration / OU_DT)) + 3
    a_ou = math.exp(-OU_DT / OU_TAU)
    xi = rn.standard_normal(nou)
    ou = np.empty(nou)
    ou[0] = OU_SD * xi[0]
    for i in range(1, nou):
        ou[i] = a_ou * ou[i - 1] + OU_SD * math.sqrt(1 - a_ou * a_ou) * xi[i]
    rip = RIPPLE_SD * rn.standard_normal(nou)
    zn = rn.standard_normal((7, n))
    t = np.arange(n) * Ts
    noise = pd.DataFrame({
        "t": t,
        "torque": sensors.torque_noise * zn[0],
        "torque_load": sensors.load_noise * zn[1],
        "i_m1": sensors.current_noise * zn[2],
        "i_m2": sensors.current_noise * zn[3],
        "i_m3": sensors.current_noise * zn[4],
        "ud": sensors.ud_noise * zn[5],
        "temp_joint": sensors.temp_noise * zn[6],
        "load_error": np.interp(t, np.arange(nou) * OU_DT, ou),
        "load_ripple": np.interp(t, np.arange(nou) * OU_DT, rip),
    })

    # ---- integrate
    form = np.full(13, -1, dtype=np.int64)
    scale = np.zeros(13)
    for name, (fi, sc) in eff.items():
        form[_EI[name]] = fi
        scale[_EI[name]] = sc
    fine = [np.empty(J) for _ in range(6)]
    tr = [np.empty(n) for _ in range(12)]
    _kernel(J, dt, m, n, scheme, float(direction), w0, P, C, kt, kv, fa, fb, wf, ou, rip, OU_DT,
            form, scale, *fine, *tr)
    fT, fTL, fTM, fq, fw, fth = fine
    tq, tv, tqdd, tu, tw, tT, tTL, tG, tF, tD, tth, tcmd = tr

    # ---- sensor chains
    t_fine = np.arange(J) * dt
    # joint torque transducer
    x = fT * (1.0 + p["torque_gain_error"])
    fd, sd_ = form[E_DELAY], scale[E_DELAY]
    lag_steps = sensors.torque_lag_s / dt
    if fd == 0:
        x = _delay(x, lag_steps + sd_ * 0.020 / dt)
    elif fd == 1:
        x = _pt1(x, 1.0 - math.exp(-dt / (sd_ * 0.020)), x[0])
        x = _delay(x, lag_steps)
    elif fd == 2:
        x = _hold(x, dt, lag_steps, sd_ * 0.040, post["hold_phase"] * sd_)
    else:
        x = _delay(x, lag_steps)
    if form[E_PERIODIC] == 2:
        x = x + scale[E_PERIODIC] * 300.0 * np.sin(2 * math.pi * 50.0 * t_fine
                                                   + post["pickup_phase"])
    torque = _adc(x, m, n)
    fo, so = form[E_OFFSET], scale[E_OFFSET]
    if fo == 0:
        torque = torque + so * 250.0
    elif fo == 1:
        torque = torque + so * 3.0 * t
    elif fo == 2:
        torque = torque + so * 300.0 * (1.0 - np.exp(-t / 25.0))
    torque = _quant(torque + noise["torque"].to_numpy(), sensors.torque_res)
    # load cell
    tload = _adc(fTL, m, n)
    fdr, sdr = form[E_DRIFT], scale[E_DRIFT]
    if fdr == 0:
        tload = tload + sdr * 3.0 * t
    elif fdr == 1:
        tload = tload + sdr * 300.0 * (1.0 - np.exp(-t / 25.0))
    tload = _quant(tload + noise["torque_load"].to_numpy(), sensors.load_res)
    # currents
    tm_adc = _adc(fTM, m, n)
    cur = {}
    for k in range(3):
        ik = p[f"current_share_{k + 1}"] * tm_adc / (3.0 * REDUCTION * p["k_t"])
        cur[f"i_m{k + 1}"] = _quant(ik + noise[f"i_m{k + 1}"].to_numpy(), sensors.current_res)
    # output encoder (eccentric disc, zeroed at the start) and the windowed velocity
    res_q = math.radians(sensors.encoder_res_deg)
    ecc, eph = p["encoder_ecc_rad"], p["encoder_ecc_phase"]
    qm = fq + ecc * (np.sin(fq + eph) - math.sin(eph))
    if fdr == 2:
        qm = qm + sdr * 3e-7 * t_fine
    qq = _quant(qm, res_q)
    idx = np.arange(n) * m
    nw = max(1, int(round(sensors.qd_window_s / dt)))
    win = nw * dt
    q_s = qq[idx]
    qd_s = (q_s - qq[np.maximum(idx - nw, 0)]) / win
    # motor encoder and speed
    res_u = 2 * math.pi / 2 ** int(sensors.motor_encoder_bits) / REDUCTION
    u_s = _quant(tu, res_u)
    if sensors.ud_filter_s > 0:
        wfilt = _pt1(fw, 1.0 - math.exp(-dt / sensors.ud_filter_s), 0.0)
    else:
        wfilt = fw
    ud_s = _quant(wfilt[idx] + noise["ud"].to_numpy(), sensors.ud_res)
    # gearbox temperature sensor
    if sensors.temp_lag_s > 0:
        thf = _pt1(fth, 1.0 - math.exp(-dt / sensors.temp_lag_s), temp0)
    else:
        thf = fth
    temp_s = _quant(thf[idx] + noise["temp_joint"].to_numpy(), sensors.temp_res)
    # phases
    phase = np.empty(n, dtype=object)
    lo = -1.0
    for t_end, name in seg:
        phase[(t > lo - 1e-12) & (t < t_end - 1e-9)] = name
        lo = t_end
    phase[phase == None] = seg[-1][1]  # noqa: E711

    samples = pd.DataFrame({
        "t": t, "q": q_s, "qd": qd_s, "u": u_s, "ud": ud_s, "torque": torque,
        "torque_load": tload, "temp_joint": temp_s, "i_m1": cur["i_m1"], "i_m2": cur["i_m2"],
        "i_m3": cur["i_m3"], "torque_cmd": tcmd.copy(), "phase": phase,
    })
    truth = pd.DataFrame({
        "t": t, "q": tq, "qd": tv, "qdd": tqdd, "u": tu, "ud": tw, "twist": tu - tq,
        "torque": tT, "torque_load": tTL, "gravity": tG, "friction": tF, "torque_ext": tD,
        "temp_joint": tth, "torque_cmd": tcmd,
    })
    sensors_meta = {
        "q": {"resolution": res_q, "noise_sd": 0.0, "lag_s": 0.0},
        "qd": {"resolution": res_q / win, "noise_sd": 0.0, "lag_s": win / 2.0},
        "u": {"resolution": res_u, "noise_sd": 0.0, "lag_s": 0.0},
        "ud": {"resolution": float(sensors.ud_res), "noise_sd": float(sensors.ud_noise),
               "lag_s": float(sensors.ud_filter_s)},
        "torque": {"resolution": float(sensors.torque_res), "noise_sd": float(sensors.torque_noise),
                   "lag_s": float(sensors.torque_lag_s)},
        "torque_load": {"resolution": float(sensors.load_res),
                        "noise_sd": float(sensors.load_noise), "lag_s": 0.0},
        "temp_joint": {"resolution": float(sensors.temp_res), "noise_sd": float(sensors.temp_noise),
                       "lag_s": float(sensors.temp_lag_s)},
    }
    for k in (1, 2, 3):
        sensors_meta[f"i_m{k}"] = {"resolution": float(sensors.current_res),
                                   "noise_sd": float(sensors.current_noise), "lag_s": 0.0}
    meta = {
        "scheme": scheme,
        "reduction": REDUCTION,
        "sample_rate_hz": fs,
        "temp_joint_c": temp0,
        "direction": direction,
        "motor_speed_rpm": rpm,
        "source": "emulator",
        "rig": RIG_NAME,
        "sensors": sensors_meta,
        "sensor_units": dict(SENSOR_UNITS),
    }
    if scheme == 3:
        meta["periods"] = periods
    params = dict(p)
    params["excite_period_s"] = period
    return RigRun(samples=samples, meta=meta, truth=truth, params=params, noise=noise)
