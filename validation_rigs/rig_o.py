"""Validation rig O: an independent physics-level simulation of the CMOR J4 joint test bench.

Written from ../shared/docs/rig.md and the CMOR SGHMC paper only (no code of the service is
imported). One call of `simulate_run` is one run of one bench: `seed` is the campaign (one
physical rig, its parameters drawn a few % around the data-sheet values), `run` the run within
it (its own noise, dropouts, jitter and initial micro-state). Everything below is SI, angles in
rad, torques in N·m, temperatures in °C; every angle of the drive train is referred to the
output (a motor angle divided by the reduction N = 11000).

PLANT
=====
Drive train: 3 servo motors (one summed motor side) -> stage A, the precision reducer ->
intermediate node (planetary input, inertia J_i referred to the output) -> stage B, the
differential planetary stage + torque flange -> output body (inertia I) <- dynamometer torque.
Coordinates: u (motor angle / N), phi (intermediate node), q (output). The physical twist
u - q = (u - phi) + (phi - q) spans both elastic stages.

Drawn parameters (n ~ N(0,1), per campaign):
  I = 6685(1+0.02n) kg·m²; mr_x = 20.8(1+0.05n), mr_y = -34.5(1+0.05n) kg·m;
  f_c = 2353(1+0.03n) N·m; f_v = 8683(1+0.03n) N·m·s/rad;
  k_A = 3.4e7(1+0.04n) N·m/rad; k_B0 = 1.6e7(1+0.04n) N·m/rad; k_B1 chosen so the static twist
  at 120 kN·m is 0.5°(1+0.04n) (k_B1 ~ 1e8 N·m/rad^1.5: stage B's tangent stiffness rises
  ~1.7x from no load to rated); d_A = 6e4(1+0.1n), d_B = 1e5(1+0.1n) N·m·s/rad (output mode
  ~7 Hz, damping ratio ~8 %); J_i = 3.5e3(1+0.05n) kg·m²;
  J_u = 4.0e5(1+0.03n) kg·m² (3 rotors x ~1.1e-3 kg·m² x N²).
Output-referred relations (e_A, e_B kinematic errors, zero unless gear_ripple; DZ the dead
zone, identity unless backlash; s(q) = 1 unless position_dependent_stiffness; H = 0 unless
hysteresis):
  T_A = k_A·(u - phi - e_A) + d_A·d/dt(u - phi - e_A)                         (stage A)
  delta = DZ(phi - q - e_B(q)),  T_B = s(q)·(k_B0·delta + k_B1·sgn(delta)·|delta|^1.5)
          + d_B·d(delta)/dt + H                                               (stage B)
  J_u·u'' = T_m - F_m(u') - T_A,     J_i·phi'' = T_A - T_B
  I·q''   = T_B - tau_L - g·(mr_x sin q + mr_y cos q) - F(q', ...) - D(t, q)     (paper Eq. 4)
The joint torque transducer carries T_B (truth column "torque").
Motor-side drag (motors, seals, first mesh; seen in currents only):
  F_m = C_m·tanh(u'/1e-5) + c_m·u',  C_m = 4950(1+0.1n) N·m, c_m = 7.3e4(1+0.1n) N·m·s/rad.
Output bearing friction (LuGre bristle z + dwell/ageing state psi; presliding 2e-5(1+0.1n) rad):
  g = f_c·(1 + 0.3·r_p(t))·(1 + psi) + [effect terms],   sigma0 = f_c / 2e-5
  z' = q' - sigma0·|q'|·z / g,   F = sigma0·z + sigma1·exp(-(q'/2e-4)²)·z' + f_v'·q'
  psi' = (psi_max - psi)/0.6 s · exp(-(q'/2e-5)²) - psi·|q'|/1.2e-4 rad,
  psi_max = 0.05(1+0.2n), sigma1 = 0.3·sqrt(sigma0·I), f_v' = f_v + [effect terms].
  In steady sliding z' = 0 and psi -> 0 (it e-folds every 0.12 mrad of sliding; its healing
  term exp(-(v/2e-5)^2) underflows at bench speeds), so F = f_c·sgn(q') + f_v·q' (Eq. 4).
  Near rest: presliding spring, frictional lag, and a breakaway up to psi_max above Coulomb
  after a dwell (seen at the start of every run).
  r_p(t) is the relative hydraulic pressure ripple (pump 9 x 1480/60 Hz, 1.2 %; pressure
  regulator hunting 0.31 Hz, 0.4 %): the bending moment presses the slewing bearing, 30 % of
  its Coulomb level comes from it, so the ripple modulates the friction (at most ~11 N·m); it
  never enters the torque reading directly.
Drive (S120, speed PI on the motor speed, output-referred; torque limit 3 x 15 N·m x N):
  T_m = K_p·(w_ref - u') + K_i·∫(w_ref - u'),  K_p = (J_u + J_i + I)·2π·10 Hz, K_i = K_p·2π·2 Hz
  (anti-windup at the limit). Schemes 1-2: w_ref = dir·rpm·2π/60/N·smoothstep(t / 1 s).
  Scheme 3 (position mode on the motor encoder): w_ref = q_ref'(t) + 2π·1.2·(q_ref(t) - u).
Dynamometer (servo + reducer, torque loop on its shaft transducer):
  tau_L' = clip((tau_set - tau_L)/T_d, ±2.5e5 N·m/s),  T_d = 0.03(1+0.1n) s,
  tau_set = (1 + 0.004n)·tau_cmd + D_d·tanh(q'/2e-4), D_d = 120(1+0.3|n|) N·m (its own gear drag,
  resisting). Error vs set point stays within ±2 kN·m (Table 11). tau_L is what the
  loading-shaft transducer measures ("torque_load"); the load resists the motion.
Thermal: lubricant node (9 kJ/K) <- losses |F·q'| + 0.5|F_m·u'| + damper losses, coupled
  20 W/K to the housing (150 kJ/K), housing 10 W/K to ambient 20(±2) °C; windings (2.5 kJ/K,
  1.1 Ω, 1.5 W/K to the housing). Both nodes start at temp_joint_c. Nominal friction does not
  depend on temperature.
Integrator: fixed-step BDF2 (first step backward Euler), step h = 1/(fs·ceil(1000/fs)) <= 1 ms
  (ceil(1000/fs) steps per sample), chord-Newton with a finite-difference Jacobian refreshed when
  the iteration slows; fallbacks for the non-smooth moments (friction reversal, backlash contact):
  full Newton with backtracking, then 8 or 64 backward-Euler sub-steps inside the step. The
  rate-independent stop operators are updated incrementally inside the residual; the thermal
  network is advanced explicitly. |v| and sgn(v) in the friction states are regularised at 1e-7
  and 1e-6 rad/s. Numba-compiled (solver statistics in params["run"]).

SCHEMES (rig.md)
================
1: motor speed rpm·dir (ramped in 1 s); dynamometer set point dir·L(t): 0 until 2 s, ramp to
   120 kN·m at 27 s, hold 2 s, ramp to 0 at 54 s; run 55.5 s.
2: same speed; set point dir·10 kN·m·k: a 10 kN·m step every 2 s from 2 s (each ramped by the
   PLC over 0.5 s) up to 120 kN·m at 24 s, then down in the same steps from 26 s to 0 at 48.5 s;
   run 50.5 s.
3: a fifth-order Fourier trajectory (Eq. 12), period 20 s, `periods` periods; zero start velocity
   and acceleration, peak speed 0.9 x 3000 r/min output equivalent, q(0) = 0; mirrored by dir.
   Load: tau_cmd = 2.6e6 N·m·s/rad · q_ref'(t) (velocity-proportional, ~70 kN·m peak; it
   resists the motion except for the few ms around a reversal where q lags q_ref).

SENSORS (SensorSpec; all stated in meta["sensors"])
===================================================
Every channel is sampled at t_k = k/fs; the actual instants jitter by N(0, jitter_s) (20 µs,
clipped at 3 sd, unstated). Truth columns are at the exact t_k.
- q: absolute output encoder, step = encoder_res_deg, zeroed at the start; an unstated sub-step
  interpolation error 0.2 step·(0.8 sin(2πq/P) + 0.5 sin(4πq/P + 0.7)), P = 512 steps.
- u: motor encoder (2^22 per motor rev) / N; resolution 2π/2^22/N.
- qd: alpha-beta observer (steady-state Kalman, constant-velocity model) on the encoder reading
  at the integration rate, poles of s² + 2ζω s + ω², 8 Hz, ζ = 0.8: stated lag = its exact
  low-frequency group delay (~31 ms), stated noise_sd = the realised sd of its error.
- ud: drive speed actual value (PT1 4 ms) + 1.5e-7 rad/s noise; w_m1..3 = N·ud + 1.5e-3 rad/s.
- torque: T_B -> [time_delay effect] -> DAQ anti-alias filter (2 x first order at
  min(fs/3, aa_max_hz)) -> fieldbus delay torque_lag_s -> [torque_offset effect] -> white noise
  torque_noise -> ADC step 6 N·m -> 0.1 % of samples dropped (NaN). Stated lag = torque_lag_s +
  2·tau_aa (the filter's exact low-frequency delay).
- torque_load: tau_L -> same anti-alias filter -> [sensor_drift] -> noise load_noise -> ADC.
- torque_cmd: the PLC set point (exact). i_m1..3: T_m·share_k/(N·kt_k) (shares 1/3(1±2 %),
  kt = 1.6(1±3 %) N·m/A, unstated gain spread) + 0.02 A. temp_joint: lubricant node through a
  5 s probe lag, 0.02 °C noise, 0.1 °C step. temp_m1..3, p_hyd (16 MPa), m_bend (100 kN·m),
  f_shear (90 kN) follow the pressure ripple through the anti-alias filter.

UNSTATED IMPERFECTIONS (none is a vocabulary effect)
====================================================
encoder interpolation error (0.2 step), timing jitter (20 µs), torque dropouts (0.1 %), the
dynamometer's gain error (0.4 %) and drag (~120-230 N·m, measured by torque_load), current
sharing / torque-constant spread (2 % / 3 %), hydraulic ripple in the bearing friction (<= 11 N·m),
non-linear stiffening of stage B, LuGre presliding / frictional lag and dwell stiction (<= ~6 %
of f_c, only around rest), thermal drift of the lubricant (~1 K per 3000 r/min run).

EFFECTS ({name: {"form", "scale"}} - "form" defaults to the first of EFFECT_FORMS[name];
0 <= scale <= SCALE_MAX = 10; contributions linear in scale up to the clips and the stick-slip
noted below; scale 0 = exactly the nominal run, bit for bit). theta = lubricant temperature, dT = theta - 30 °C, v = q', T = T_B,
T_r = 120 kN·m, v_s = 0.2 x 0.02856 rad/s (twice the output speed at 300 r/min). Phases phi_k
are drawn per campaign.
- stribeck (g += A·s(|v|/v_s), A = a·f_c·scale): exponential s = e^{-x} (a = 0.18); gaussian
  e^{-x²} (0.14); lorentzian 1/(1+x²) (0.17); exp_half e^{-sqrt x} (0.31). Scale 1 raises the
  friction by ~250-370 N·m at 300 r/min and keeps the drive stable; above scale ~1.5 the falling
  friction curve drives the 300 r/min runs into stick-slip (the physical consequence in this
  compliant drive); the mean friction rise stays roughly linear in scale.
- load_dependent_friction: coulomb g += 0.005·sc·|T|; coulomb_viscous g += 0.0035·sc·|T|,
  f_v' += 1.5·sc·f_v·|T|/T_r; power_flow g += sc·|T|·(0.002 + 0.004·(1+tanh(T·v/5 W))/2)
  (driving 0.6 %, back-driven 0.2 %); quadratic g += 0.006·sc·T²/T_r.
- temperature_friction: coulomb_additive g += -18 N·m/K·sc·dT; viscous_vogel
  f_v' += sc·f_v·(exp(1100·(1/(theta+273.15-178) - 1/(303.15-178))) - 1);
  both_multiplicative g += -0.007·sc·f_c·dT, f_v' += -0.025·sc·f_v·dT;
  coulomb_exponential g += sc·f_c·(exp(-0.012·dT) - 1).
- gear_ripple (Z = 84 mesh cycles per output rev, harmonics 1,2,3 weighted 1, 0.45, 0.2):
  output_torque D += 420·sc·Σ w_k sin(kZq + phi_k) [N·m] on the output body; load_modulated the
  same x (0.25 + 0.75|T|/T_r); output_kinematic e_B = 4e-4·sc·Σ w_k sin(kZq + phi_k) [rad];
  motor_kinematic e_A = 1.5e-5·sc·(sin(θ_m + phi_1) + 0.5 sin(2θ_m + phi_2)), θ_m = N·u.
- torque_offset (reading only): constant 350·sc; linear_drift 8·sc·t; exp_settle
  500·sc·(1 - e^{-t/15 s}); thermal 25·sc·(theta_housing - 20 °C).
- time_delay (reading only, beyond the stated lag): pure 25 ms·sc; first_order tau = 25 ms·sc;
  second_order two first-order lags of 12.5 ms·sc; bus_hold: the value refreshes every 40 ms·sc.
- hysteresis (in stage B, on delta; H0 = 8 kN·m·sc, delta_y = 4e-4 rad): bouc_wen_n1
  x' = delta'/delta_y·(1 - (0.5 sgn(delta' x) + 0.5)|x|), H = H0·x; bouc_wen_n2 the same with x²;
  dahl x' = delta'/delta_y·(1 - x·sgn(delta')), H = H0·x; prandtl_ishlinskii
  H = H0·Σ w_j s_j/r_j, stop operators s_j of thresholds r_j = (0.25, 0.5, 1, 2)·delta_y,
  w = (0.2, 0.3, 0.3, 0.2).
- backlash (stage B, half gap b = 2.5e-4 rad·sc): sharp dead zone; smoothed (hyperbolic corners,
  width 0.35 b); asymmetric (gap +1.6 b / -0.4 b); progressive (gap b, then a contact zone of
  width b with the slope rising linearly 0 -> 1).
- asymmetric_friction: coulomb g += 280·sc·sgn(v); viscous f_v' += 1.2·sc·f_v for v > 0;
  both g += 200·sc·sgn(v) and f_v' += 0.6·sc·f_v for v > 0; negative_side g += 350·sc for v < 0.
  (g >= 0.05 f_c and f_v' >= 0.05 f_v always.)
Outside the vocabulary (OUT_OF_VOCABULARY):
- periodic_disturbance (torque on the output body, time-periodic): sine 450·sc·sin(2π·1.7t+phi);
  pump_harmonics 300·sc·(sin w t + 0.6 sin 2wt + 0.3 sin 3wt), w = 2π·2.3 Hz; beating
  500·sc·sin(2π·1.1t)·cos(2π·0.08t).
- position_dependent_stiffness (stage B factor s(q), >= 0.25): once_per_rev 1 + 0.15·sc·cos(q -
  phi); planet_pass 1 + 0.12·sc·cos(3q + phi); gradient 1 + 0.12·sc·q.
- sensor_drift: load_cell_linear torque_load += 7·sc·t; load_cell_exp += 450·sc(1 - e^{-t/12 s});
  encoder_creep q reading += 1e-5 rad/s·sc·t.
- second_resonance: output_appendage, an unmeasured inertia 0.5·sc·I on the output body through
  a spring/damper tuned to 3.8 Hz (ζ = 0.01) against a fixed base; load_side, the dynamometer
  rotor (2·sc·I referred) behind a compliant loading shaft tuned to 6 Hz (ζ = 0.02): tau_L acts
  on the rotor, the joint carries the shaft torque. Coupled with the drive train both ring at
  ~3.5 Hz after load changes and reversals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, asdict

import numba as nb
import numpy as np
import pandas as pd

# =============================================================================================
# public constants
# =============================================================================================

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "rig_o"
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "exp_half"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow", "quadratic"),
    "temperature_friction": ("coulomb_additive", "viscous_vogel", "both_multiplicative",
                             "coulomb_exponential"),
    "gear_ripple": ("output_torque", "load_modulated", "output_kinematic", "motor_kinematic"),
    "torque_offset": ("constant", "linear_drift", "exp_settle", "thermal"),
    "time_delay": ("pure", "first_order", "second_order", "bus_hold"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl", "prandtl_ishlinskii"),
    "backlash": ("sharp", "smoothed", "asymmetric", "progressive"),
    "asymmetric_friction": ("coulomb", "viscous", "both", "negative_side"),
    # outside the vocabulary of rig.md
    "periodic_disturbance": ("sine", "pump_harmonics", "beating"),
    "position_dependent_stiffness": ("once_per_rev", "planet_pass", "gradient"),
    "sensor_drift": ("load_cell_linear", "load_cell_exp", "encoder_creep"),
    "second_resonance": ("output_appendage", "load_side"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "sensor_drift", "second_resonance")

# slot of each effect in the effect array E: E[2*slot] = form code (1-based, 0 = off),
# E[2*slot + 1] = scale
_EFFECT_SLOT = {name: i for i, name in enumerate(EFFECT_FORMS)}
_S_STRIB, _S_LOADF, _S_TEMPF, _S_RIPPLE, _S_OFFSET, _S_DELAY, _S_HYST, _S_BACKL, _S_ASYM, \
    _S_PERIOD, _S_POSK, _S_DRIFT, _S_RESON = range(13)
_NE = 40
_E_J2, _E_K2, _E_C2 = 30, 31, 32        # derived constants of the second-resonance form

# =============================================================================================
# nominal sizes (data-sheet values, the paper / rig.md) and the effect sizes at scale 1
# =============================================================================================

G0 = 9.80665
T_RATED = 120e3                 # rated output torque [N·m]
W_MOTOR_MAX = 3000.0 * 2.0 * math.pi / 60.0            # [rad/s] motor side
W_OUT_MAX = W_MOTOR_MAX / REDUCTION                      # 0.02856 rad/s output
VEPS = 1e-7                     # rad/s, regularisation of |v| in the friction states
THETA_REF = 30.0                # reference lubricant temperature of the friction data [°C]

# effect sizes at scale 1
STRIBECK_RISE = (0.18, 0.14, 0.17, 0.31)   # (F_s - F_c) / f_c per form
STRIBECK_VS = 0.2 * W_OUT_MAX   # Stribeck velocity [rad/s] (2 x the output speed at 300 r/min)
LOADF_MU = 0.005                # coulomb: dC = mu |T|
LOADF_CV_MU, LOADF_CV_V = 0.0035, 1.5
LOADF_PF_DRIVE, LOADF_PF_BACK, LOADF_PF_P0 = 0.006, 0.002, 5.0
LOADF_QUAD = 0.006              # dC = k T^2 / T_rated
TEMPF_C_ADD = -18.0             # N·m per K
TEMPF_VOGEL_B, TEMPF_VOGEL_T0 = 1100.0, 178.0     # Vogel: exp(B/(T - T0)), T in K
TEMPF_MUL_C, TEMPF_MUL_V = -0.007, -0.025        # per K
TEMPF_EXP_K = 0.012             # per K
RIPPLE_Z = 84.0                 # mesh cycles per output revolution
RIPPLE_W = (1.0, 0.45, 0.2)     # harmonic weights 1st, 2nd, 3rd
RIPPLE_T = 420.0                # N·m torque ripple amplitude (fundamental)
RIPPLE_E = 4.0e-4               # rad, output-side kinematic error amplitude
RIPPLE_M = 1.5e-5               # rad (output-referred), motor-angle kinematic error amplitude
OFFSET_CONST, OFFSET_RATE, OFFSET_EXP, OFFSET_EXP_TAU, OFFSET_THERM = 350.0, 8.0, 500.0, 15.0, 25.0
DELAY_S = 0.025                 # s
BUS_HOLD_S = 0.040              # s, bus refresh period at scale 1
HYST_H0, HYST_DY = 8.0e3, 4.0e-4   # N·m saturation torque, rad yield twist
PI_R = (0.25, 0.5, 1.0, 2.0)    # stop-operator thresholds / HYST_DY
PI_W = (0.2, 0.3, 0.3, 0.2)     # their share of HYST_H0
BACKLASH_B = 2.5e-4             # rad half gap
ASYM_C, ASYM_V, ASYM_BOTH_C, ASYM_BOTH_V, ASYM_NEG = 280.0, 1.2, 200.0, 0.6, 350.0
PERIOD_A, PERIOD_F = 450.0, 1.7
PUMP_A, PUMP_F = 300.0, 2.3
BEAT_A, BEAT_F, BEAT_FM = 500.0, 1.1, 0.08
POSK_EPS, POSK_GRAD = 0.15, 0.12
DRIFT_RATE, DRIFT_EXP, DRIFT_EXP_TAU, DRIFT_CREEP = 7.0, 450.0, 12.0, 6.0e-4 / 60.0
RES_OUT = (0.50, 3.8, 0.01)     # J2/I per scale, f [Hz], zeta
RES_LOAD = (2.0, 6.0, 0.02)     # J_d/I per scale, f [Hz] (J_d on the shaft), zeta

# =============================================================================================
# rig parameter vector P (campaign draw) -- indices
# =============================================================================================

(_I, _MRX, _MRY, _FC, _FV, _KA, _KB0, _KB1, _DA, _DB, _JI, _JU,
 _SIG0, _SIG1, _VSIG, _PSIMAX, _TAGE, _DC, _VA,
 _CM, _CVM, _WEPS, _KP, _KI, _KPOS, _TMAX,
 _TDYN, _SLEW, _GD, _DRAG, _CL,
 _XIB, _RP1, _FP1, _RP2, _FP2, _PHP1, _PHP2,
 _WOUT, _TACC,
 _FA1, _FA2, _FA3, _FA4, _FA5, _FB1, _FB2, _FB3, _FB4, _FB5, _WF, _Q0F,
 _PHG1, _PHG2, _PHG3, _PHM1, _PHM2, _PHD1, _PHD2, _PHD3, _PHS,
 _COIL, _GOH, _CH, _GHA, _TAMB, _CW, _GW, _RW,
 _SH1, _SH2, _SH3, _KT1, _KT2, _KT3) = range(75)
_NP = 80

# state vector
_NY = 13
(_Y_U, _Y_WU, _Y_PH, _Y_WPH, _Y_Q, _Y_WQ, _Y_Z, _Y_PSI, _Y_II, _Y_TL, _Y_XH,
 _Y_Q2, _Y_W2) = range(_NY)

# auxiliary outputs of the right-hand side
_NA = 20
(_A_TA, _A_TB, _A_F, _A_TCMD, _A_TM, _A_D, _A_H, _A_GRAV, _A_DE, _A_RP, _A_S1, _A_S2, _A_S3,
 _A_S4, _A_FM, _A_DDA, _A_DDE, _A_DWQ) = range(18)

# recorded internal-grid columns
_NO = 20
(_O_T, _O_U, _O_WU, _O_PH, _O_Q, _O_WQ, _O_TA, _O_TB, _O_F, _O_TL, _O_TCMD, _O_TM, _O_OIL,
 _O_HOUSE, _O_W1, _O_W2, _O_W3, _O_D, _O_RP, _O_ACC) = range(_NO)

SCHEME_DURATION = {1: 55.5, 2: 50.5}
FOURIER_PERIOD = 20.0

# =============================================================================================
# numba kernels
# =============================================================================================


@nb.njit(cache=True)
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@nb.njit(cache=True)
def _smoothstep(x):
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    return x * x * (3.0 - 2.0 * x)


@nb.njit(cache=True)
def _load_profile(t, scheme):
    """Dynamometer set point magnitude [N·m] of schemes 1 and 2."""
    if scheme == 1:
        if t < 2.0:
            return 0.0
        if t < 27.0:
            return T_RATED * (t - 2.0) / 25.0
        if t < 29.0:
            return T_RATED
        if t < 54.0:
            return T_RATED * (1.0 - (t - 29.0) / 25.0)
        return 0.0
    # scheme 2: 10 kN·m steps (each ramped by the PLC over 0.5 s), 2 s apart, up to 120 kN·m,
    # then down again in the same steps
    if t < 2.0:
        return 0.0
    if t < 26.0:
        k = math.floor((t - 2.0) / 2.0)
        frac = min((t - 2.0 - 2.0 * k) / 0.5, 1.0)
        return 10e3 * (k + frac)
    if t < 50.0:
        k = math.floor((t - 26.0) / 2.0)
        frac = min((t - 26.0 - 2.0 * k) / 0.5, 1.0)
        return max(10e3 * (12.0 - k - frac), 0.0)
    return 0.0


@nb.njit(cache=True)
def _fourier(t, P, dirn):
    w = P[_WF]
    q = P[_Q0F]
    qd = 0.0
    for l in range(5):
        a = P[_FA1 + l]
        b = P[_FB1 + l]
        wl = w * (l + 1.0)
        s = math.sin(wl * t)
        c = math.cos(wl * t)
        q += a / wl * s - b / wl * c
        qd += a * c + b * s
    return dirn * q, dirn * qd


@nb.njit(cache=True)
def _deadzone(d, form, b):
    """Effective twist through a dead zone of half width b and its slope."""
    if form == 1:  # sharp
        if d > b:
            return d - b, 1.0
        if d < -b:
            return d + b, 1.0
        return 0.0, 0.0
    if form == 2:  # smoothed (hyperbolic corners, width 0.35 b)
        e = 0.35 * b
        r1 = math.sqrt((d - b) * (d - b) + e * e)
        r2 = math.sqrt((d + b) * (d + b) + e * e)
        val = 0.5 * ((d - b) + r1) - 0.5 * ((-d - b) + r2)
        slope = 0.5 * (1.0 + (d - b) / r1) + 0.5 * (1.0 - (d + b) / r2)
        return val, slope
    if form == 3:  # asymmetric gap: 1.6 b on the positive side, 0.4 b on the negative side
        bp = 1.6 * b
        bn = 0.4 * b
        if d > bp:
            return d - bp, 1.0
        if d < -bn:
            return d + bn, 1.0
        return 0.0, 0.0
    # progressive contact: gap b, then a contact zone of width b with linearly rising slope
    ad = abs(d)
    s = _sgn(d)
    if ad <= b:
        return 0.0, 0.0
    if ad <= 2.0 * b:
        x = ad - b
        return s * x * x / (2.0 * b), x / b
    return s * (ad - 1.5 * b), 1.0


@nb.njit(cache=True)
def _rhs(y, t, P, E, scheme, dirn, ctx, dy, aux):
    """Right-hand side of the plant (all angles referred to the output)."""
    u = y[_Y_U]
    wu = y[_Y_WU]
    ph = y[_Y_PH]
    wph = y[_Y_WPH]
    q = y[_Y_Q]
    wq = y[_Y_WQ]
    z = y[_Y_Z]
    psi = y[_Y_PSI]
    ii = y[_Y_II]
    tl = y[_Y_TL]
    xh = y[_Y_XH]
    q2 = y[_Y_Q2]
    w2 = y[_Y_W2]
    th_oil = ctx[0]

    # ---- references (drive) and dynamometer set point (PLC)
    if scheme == 3:
        qr, qdr = _fourier(t, P, dirn)
        wref = qdr + P[_KPOS] * (qr - u)
        tcmd = P[_CL] * qdr
    else:
        wref = dirn * P[_WOUT] * _smoothstep(t / P[_TACC])
        tcmd = dirn * _load_profile(t, scheme)

    # ---- kinematic errors (gear ripple forms 3 and 4)
    gform = int(E[2 * _S_RIPPLE])
    gsc = E[2 * _S_RIPPLE + 1]
    eb = 0.0
    deb = 0.0
    ea = 0.0
    dea = 0.0
    if gform == 3:
        for k in range(3):
            ang = (k + 1.0) * RIPPLE_Z * q + P[_PHG1 + k]
            eb += gsc * RIPPLE_E * RIPPLE_W[k] * math.sin(ang)
            deb += gsc * RIPPLE_E * RIPPLE_W[k] * (k + 1.0) * RIPPLE_Z * math.cos(ang)
    elif gform == 4:
        thm = REDUCTION * u
        a1 = thm + P[_PHM1]
        a2 = 2.0 * thm + P[_PHM2]
        ea = gsc * RIPPLE_M * (math.sin(a1) + 0.5 * math.sin(a2))
        dea = gsc * RIPPLE_M * REDUCTION * (math.cos(a1) + math.cos(a2))

    # ---- stage A: precision reducer (linear), referred to the output
    da = u - ph - ea
    dda = wu - wph - dea * wu
    ta = P[_KA] * da + P[_DA] * dda

    # ---- stage B: differential planetary + torque flange (stiffening)
    draw = ph - q - eb
    ddraw = wph - wq - deb * wq
    bform = int(E[2 * _S_BACKL])
    if bform > 0:
        de, slope = _deadzone(draw, bform, BACKLASH_B * E[2 * _S_BACKL + 1])
    else:
        de = draw
        slope = 1.0
    dde = slope * ddraw
    sp = 1.0
    kform = int(E[2 * _S_POSK])
    if kform > 0:
        ksc = E[2 * _S_POSK + 1]
        if kform == 1:
            sp = 1.0 + POSK_EPS * ksc * math.cos(q - P[_PHS])
        elif kform == 2:
            sp = 1.0 + POSK_EPS * 0.8 * ksc * math.cos(3.0 * q + P[_PHS])
        else:
            sp = 1.0 + POSK_GRAD * ksc * q
        if sp < 0.25:
            sp = 0.25
    ade = abs(de)
    el = sp * (P[_KB0] * de + P[_KB1] * _sgn(de) * ade * math.sqrt(ade))

    # ---- hysteresis in stage B
    hform = int(E[2 * _S_HYST])
    hsc = E[2 * _S_HYST + 1]
    hyst = 0.0
    dxh = 0.0
    aux[_A_S1] = 0.0
    aux[_A_S2] = 0.0
    aux[_A_S3] = 0.0
    aux[_A_S4] = 0.0
    if hform == 1 or hform == 2 or hform == 3:
        hyst = hsc * HYST_H0 * xh
        rate = dde / HYST_DY
        sx = _sgn(rate * xh)
        ax = abs(xh)
        if hform == 1:
            dxh = rate * (1.0 - (0.5 * sx + 0.5) * ax)
        elif hform == 2:
            dxh = rate * (1.0 - (0.5 * sx + 0.5) * ax * ax)
        else:
            dxh = rate * (1.0 - xh * _sgn(rate))
    elif hform == 4:
        inc = de - ctx[1]
        for j in range(4):
            r = PI_R[j] * HYST_DY
            s = ctx[2 + j] + inc
            if s > r:
                s = r
            elif s < -r:
                s = -r
            aux[_A_S1 + j] = s
            hyst += hsc * HYST_H0 * PI_W[j] * s / r
    tb = el + P[_DB] * dde + hyst

    # ---- output bearing friction: LuGre bristle + dwell (ageing) state; effects act on the
    #      Coulomb level g and the viscous slope
    v = wq
    av = math.sqrt(v * v + VEPS * VEPS)     # |v| regularised at 1e-7 rad/s (Newton-friendly)
    sv = v / math.sqrt(v * v + 1e-12)      # sgn(v) regularised at 1e-6 rad/s
    rp = P[_RP1] * math.sin(2.0 * math.pi * P[_FP1] * t + P[_PHP1]) \
        + P[_RP2] * math.sin(2.0 * math.pi * P[_FP2] * t + P[_PHP2])
    fc = P[_FC]
    fvn = P[_FV]
    cl = fc * (1.0 + P[_XIB] * rp) * (1.0 + psi)
    fv = fvn
    f = int(E[2 * _S_STRIB])
    if f > 0:
        amp = STRIBECK_RISE[f - 1] * fc * E[2 * _S_STRIB + 1]
        x = av / STRIBECK_VS
        if f == 1:
            cl += amp * math.exp(-x)
        elif f == 2:
            cl += amp * math.exp(-x * x)
        elif f == 3:
            cl += amp / (1.0 + x * x)
        else:
            cl += amp * math.exp(-math.sqrt(x))
    f = int(E[2 * _S_LOADF])
    if f > 0:
        sc = E[2 * _S_LOADF + 1]
        atb = abs(tb)
        if f == 1:
            cl += LOADF_MU * sc * atb
        elif f == 2:
            cl += LOADF_CV_MU * sc * atb
            fv += fvn * LOADF_CV_V * sc * atb / T_RATED
        elif f == 3:
            w = 0.5 * (1.0 + math.tanh(tb * v / LOADF_PF_P0))
            cl += sc * atb * (LOADF_PF_BACK + (LOADF_PF_DRIVE - LOADF_PF_BACK) * w)
        else:
            cl += LOADF_QUAD * sc * tb * tb / T_RATED
    f = int(E[2 * _S_TEMPF])
    if f > 0:
        sc = E[2 * _S_TEMPF + 1]
        dth = th_oil - THETA_REF
        if f == 1:
            cl += TEMPF_C_ADD * sc * dth
        elif f == 2:
            tk = th_oil + 273.15
            tr = THETA_REF + 273.15
            fv += fvn * sc * (math.exp(TEMPF_VOGEL_B * (1.0 / (tk - TEMPF_VOGEL_T0)
                                                         - 1.0 / (tr - TEMPF_VOGEL_T0))) - 1.0)
        elif f == 3:
            cl += fc * TEMPF_MUL_C * sc * dth
            fv += fvn * TEMPF_MUL_V * sc * dth
        else:
            cl += fc * sc * (math.exp(-TEMPF_EXP_K * dth) - 1.0)
    f = int(E[2 * _S_ASYM])
    if f > 0:
        sc = E[2 * _S_ASYM + 1]
        pos = 0.5 * (1.0 + sv)      # 1 for v > 0, 0 for v < 0 (regularised at 1e-6 rad/s)
        if f == 1:
            cl += sv * ASYM_C * sc
        elif f == 2:
            fv += pos * fvn * ASYM_V * sc
        elif f == 3:
            cl += sv * ASYM_BOTH_C * sc
            fv += pos * fvn * ASYM_BOTH_V * sc
        else:
            cl += (1.0 - pos) * ASYM_NEG * sc
    if cl < 0.05 * fc:
        cl = 0.05 * fc
    if fv < 0.05 * fvn:
        fv = 0.05 * fvn
    sig0 = P[_SIG0]
    zd = v - sig0 * av * z / cl
    s1 = P[_SIG1] * math.exp(-(v / P[_VSIG]) ** 2)
    fr = sig0 * z + s1 * zd + fv * v

    # ---- disturbance torques on the output body (gear mesh ripple, OOV periodic)
    dist = 0.0
    if gform == 1 or gform == 2:
        rr = 0.0
        for k in range(3):
            rr += RIPPLE_W[k] * math.sin((k + 1.0) * RIPPLE_Z * q + P[_PHG1 + k])
        amp = gsc * RIPPLE_T
        if gform == 2:
            amp *= 0.25 + 0.75 * abs(tb) / T_RATED
        dist += amp * rr
    f = int(E[2 * _S_PERIOD])
    if f > 0:
        sc = E[2 * _S_PERIOD + 1]
        if f == 1:
            dist += sc * PERIOD_A * math.sin(2.0 * math.pi * PERIOD_F * t + P[_PHD1])
        elif f == 2:
            w0 = 2.0 * math.pi * PUMP_F * t
            dist += sc * PUMP_A * (math.sin(w0 + P[_PHD1]) + 0.6 * math.sin(2.0 * w0 + P[_PHD2])
                                   + 0.3 * math.sin(3.0 * w0 + P[_PHD3]))
        else:
            dist += sc * BEAT_A * math.sin(2.0 * math.pi * BEAT_F * t + P[_PHD1]) \
                * math.cos(2.0 * math.pi * BEAT_FM * t)

    # ---- second resonance (OOV): a secondary inertia on the output body, or the dynamometer
    #      rotor behind a compliant loading shaft
    rform = int(E[2 * _S_RESON])
    t2q = 0.0
    dq2 = 0.0
    dw2 = 0.0
    if rform == 1:
        t2 = E[_E_K2] * (q2 - q) + E[_E_C2] * (w2 - wq)
        t2q = t2
        dq2 = w2
        dw2 = -t2 / E[_E_J2]
    elif rform == 2:
        # dynamometer rotor (referred) beyond a compliant loading shaft: the joint output
        # carries the shaft torque, the dynamometer torque tl acts on the rotor
        ts = E[_E_K2] * (q - q2) + E[_E_C2] * (wq - w2)
        t2q = tl - ts
        dq2 = w2
        dw2 = (ts - tl) / E[_E_J2]

    grav = G0 * (P[_MRX] * math.sin(q) + P[_MRY] * math.cos(q))

    # ---- drive: S120 speed PI on the motor speed (referred to the output)
    ew = wref - wu
    tm_raw = P[_KP] * ew + ii
    tm = tm_raw
    dii = P[_KI] * ew
    if tm > P[_TMAX]:
        tm = P[_TMAX]
        if ew > 0.0:
            dii = 0.0
    elif tm < -P[_TMAX]:
        tm = -P[_TMAX]
        if ew < 0.0:
            dii = 0.0
    fm = P[_CM] * math.tanh(wu / P[_WEPS]) + P[_CVM] * wu

    # ---- dynamometer (torque loop closed on its shaft transducer; its own gear drag resists)
    tset = (1.0 + P[_GD]) * tcmd + P[_DRAG] * math.tanh(wq / 2e-4)
    dtl = (tset - tl) / P[_TDYN]
    if dtl > P[_SLEW]:
        dtl = P[_SLEW]
    elif dtl < -P[_SLEW]:
        dtl = -P[_SLEW]

    dwq = (tb - tl - grav - fr - dist + t2q) / P[_I]

    dy[_Y_U] = wu
    dy[_Y_WU] = (tm - fm - ta) / P[_JU]
    dy[_Y_PH] = wph
    dy[_Y_WPH] = (ta - tb) / P[_JI]
    dy[_Y_Q] = wq
    dy[_Y_WQ] = dwq
    dy[_Y_Z] = zd
    dy[_Y_PSI] = (P[_PSIMAX] - psi) / P[_TAGE] * math.exp(-(v / P[_VA]) ** 2) - psi * av / P[_DC]
    dy[_Y_II] = dii
    dy[_Y_TL] = dtl
    dy[_Y_XH] = dxh
    dy[_Y_Q2] = dq2
    dy[_Y_W2] = dw2

    aux[_A_TA] = ta
    aux[_A_TB] = tb
    aux[_A_F] = fr
    aux[_A_TCMD] = tcmd
    aux[_A_TM] = tm
    aux[_A_D] = dist
    aux[_A_H] = hyst
    aux[_A_GRAV] = grav
    aux[_A_DE] = de
    aux[_A_RP] = rp
    aux[_A_FM] = fm
    aux[_A_DDA] = dda
    aux[_A_DDE] = dde
    aux[_A_DWQ] = dwq


@nb.njit(cache=True)
def _lu_factor(a, piv):
    n = a.shape[0]
    for k in range(n):
        p = k
        m = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > m:
                m = abs(a[i, k])
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[p, j]
                a[p, j] = tmp
        d = a[k, k]
        if d == 0.0:
            d = 1e-300
            a[k, k] = d
        for i in range(k + 1, n):
            a[i, k] /= d
            f = a[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]


@nb.njit(cache=True)
def _lu_solve(a, piv, b):
    n = a.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]


@nb.njit(cache=True)
def _init_state(P, E, scheme, dirn, z0, psi0, theta0):
    """Static equilibrium at rest at t = 0 with q = 0 (encoder zeroed)."""
    y = np.zeros(_NY)
    dy = np.zeros(_NY)
    aux = np.zeros(_NA)
    ctx = np.zeros(8)
    ctx[0] = theta0
    y[_Y_Z] = z0
    y[_Y_PSI] = psi0
    # torque the flange must carry at rest: gravity + presliding friction (+ disturbances)
    y[_Y_PH] = 0.0
    for _outer in range(3):
        _rhs(y, 0.0, P, E, scheme, dirn, ctx, dy, aux)
        target = aux[_A_GRAV] + aux[_A_F] + aux[_A_D]
        lo = -0.05
        hi = 0.05
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            y[_Y_PH] = mid
            _rhs(y, 0.0, P, E, scheme, dirn, ctx, dy, aux)
            if aux[_A_TB] > target:
                hi = mid
            else:
                lo = mid
        y[_Y_PH] = 0.5 * (lo + hi)
    _rhs(y, 0.0, P, E, scheme, dirn, ctx, dy, aux)
    tb0 = aux[_A_TB]
    # stage A carries the same torque; the motor kinematic error depends on u itself
    u = y[_Y_PH] + tb0 / P[_KA]
    for _ in range(30):
        y[_Y_U] = u
        _rhs(y, 0.0, P, E, scheme, dirn, ctx, dy, aux)
        u = u - (aux[_A_TA] - tb0) / P[_KA]
    y[_Y_U] = u
    _rhs(y, 0.0, P, E, scheme, dirn, ctx, dy, aux)
    y[_Y_II] = aux[_A_TA]
    y[_Y_Q2] = 0.0
    return y


@nb.njit(cache=True)
def _newton_matrix(ynew, bh, t, P, E, scheme, dirn, ctx, eps, active, f, fj, yp, jac, piv,
                   auxj, ctxj):
    """The Newton matrix I - bh*df/dy at ynew by forward differences (steps eps, only the
    `active` states; f = f(ynew) given), LU-factored in place into jac, piv."""
    n = ynew.shape[0]
    for c in range(n):
        for k in range(n):
            jac[k, c] = 0.0
        jac[c, c] = 1.0
        if active[c]:
            for k in range(n):
                yp[k] = ynew[k]
            yp[c] += eps[c]
            for k in range(8):
                ctxj[k] = ctx[k]
            _rhs(yp, t, P, E, scheme, dirn, ctxj, fj, auxj)
            for k in range(n):
                jac[k, c] -= bh * (fj[k] - f[k]) / eps[c]
    _lu_factor(jac, piv)


@nb.njit(cache=True)
def _solve_full(ynew, base, bh, t, P, E, scheme, dirn, ctx, tol, eps, active,
                f, fj, yp, r, jac, piv, aux, auxj, ctxj):
    """Solve ynew - base - bh*f(ynew) = 0 by Newton with a fresh finite-difference Jacobian at
    every iterate and backtracking on the tolerance-scaled residual. Returns convergence."""
    n = ynew.shape[0]
    for it2 in range(40):
        _rhs(ynew, t, P, E, scheme, dirn, ctx, f, aux)
        nr = 0.0
        for k in range(n):
            r[k] = -(ynew[k] - base[k] - bh * f[k])
            if abs(r[k]) / tol[k] > nr:
                nr = abs(r[k]) / tol[k]
        _newton_matrix(ynew, bh, t, P, E, scheme, dirn, ctx, eps, active, f, fj, yp, jac,
                       piv, auxj, ctxj)
        _lu_solve(jac, piv, r)
        lam = 1.0
        for ls in range(12):
            for k in range(n):
                yp[k] = ynew[k] + lam * r[k]
            for k in range(8):
                ctxj[k] = ctx[k]
            _rhs(yp, t, P, E, scheme, dirn, ctxj, fj, auxj)
            nn = 0.0
            for k in range(n):
                rr = abs(yp[k] - base[k] - bh * fj[k]) / tol[k]
                if rr > nn:
                    nn = rr
            if nn < nr or nn < 1.0:
                break
            lam *= 0.5
        small = True
        for k in range(n):
            ynew[k] = yp[k]
            if abs(lam * r[k]) > tol[k]:
                small = False
        if small and lam == 1.0:
            return True
    return False


@nb.njit(cache=True)
def _integrate(scheme, dirn, nsteps, h, P, E, y0, theta0, tol, eps, active):
    """BDF2 (first step backward Euler) with a chord-Newton solver and a finite-difference
    Jacobian refreshed when the iteration slows down. Thermal states are advanced explicitly
    after each step (time constants >> h)."""
    n = _NY
    out = np.empty((nsteps + 1, _NO))
    y = y0.copy()
    yprev = y0.copy()
    ynew = y0.copy()
    base = np.zeros(n)
    f = np.zeros(n)
    fj = np.zeros(n)
    yp = np.zeros(n)
    r = np.zeros(n)
    jac = np.zeros((n, n))
    piv = np.zeros(n, dtype=np.int64)
    aux = np.zeros(_NA)
    auxj = np.zeros(_NA)
    ctx = np.zeros(8)
    ctxj = np.zeros(8)
    ctx[0] = theta0
    # thermal states
    th_oil = theta0
    th_h = theta0
    tw = np.full(3, theta0 + 0.0)
    nonconv = 0
    nsub = 0
    ys = np.zeros(n)
    bs = np.zeros(n)
    ctxs = np.zeros(8)
    ctx0 = np.zeros(8)
    nc_info = np.zeros((16, 3))
    njac = 0
    niter = 0
    need_jac = True
    bh_jac = -1.0

    _rhs(y, 0.0, P, E, scheme, dirn, ctx, f, aux)
    ctx[1] = aux[_A_DE]
    for j in range(4):
        ctx[2 + j] = 0.0

    for i in range(nsteps + 1):
        t = i * h
        if i > 0:
            if i == 1:
                a1 = 1.0
                a2 = 0.0
                bh = h
            else:
                a1 = 4.0 / 3.0
                a2 = -1.0 / 3.0
                bh = 2.0 / 3.0 * h
            if bh != bh_jac:
                need_jac = True
            for k in range(n):
                base[k] = a1 * y[k] + a2 * yprev[k]
                if i > 1:
                    ynew[k] = 2.0 * y[k] - yprev[k]
                else:
                    ynew[k] = y[k]
            for k in range(8):
                ctx0[k] = ctx[k]
            conv = False
            it = 0
            fresh = False
            while it < 14:
                _rhs(ynew, t, P, E, scheme, dirn, ctx, f, aux)
                for k in range(n):
                    r[k] = -(ynew[k] - base[k] - bh * f[k])
                if need_jac:
                    _newton_matrix(ynew, bh, t, P, E, scheme, dirn, ctx, eps, active, f, fj,
                                   yp, jac, piv, auxj, ctxj)
                    need_jac = False
                    fresh = True
                    bh_jac = bh
                    njac += 1
                _lu_solve(jac, piv, r)
                small = True
                for k in range(n):
                    ynew[k] += r[k]
                    if abs(r[k]) > tol[k]:
                        small = False
                it += 1
                niter += 1
                if small:
                    conv = True
                    break
                if it >= 3 and not fresh:
                    need_jac = True
            if not conv:
                # robust fallback (non-smooth friction / contact): Newton with a fresh Jacobian
                # at every iterate and backtracking on the scaled residual
                conv = _solve_full(ynew, base, bh, t, P, E, scheme, dirn, ctx, tol, eps, active,
                                   f, fj, yp, r, jac, piv, aux, auxj, ctxj)
                need_jac = True
            for nsplit in (8, 64):
                if conv:
                    break
                # last resort: backward-Euler sub-steps across the step (the BDF2 history stays
                # uniform: the sub-steps end exactly at t)
                for k in range(n):
                    ys[k] = y[k]
                for k in range(8):
                    ctxs[k] = ctx0[k]
                ok = True
                for sub in range(nsplit):
                    tsub = t - h + (sub + 1.0) * h / nsplit
                    for k in range(n):
                        bs[k] = ys[k]
                        ynew[k] = ys[k]
                    ok_s = _solve_full(ynew, bs, h / nsplit, tsub, P, E, scheme, dirn, ctxs,
                                       tol, eps, active, f, fj, yp, r, jac, piv, aux, auxj, ctxj)
                    ok = ok and ok_s
                    for k in range(n):
                        ys[k] = ynew[k]
                    _rhs(ys, tsub, P, E, scheme, dirn, ctxs, f, aux)
                    ctxs[1] = aux[_A_DE]
                    for j in range(4):
                        ctxs[2 + j] = aux[_A_S1 + j]
                for k in range(8):
                    ctx[k] = ctxs[k]
                conv = ok
                nsub += 1
            if not conv:
                if nonconv < 16:
                    worst = 0
                    wv = 0.0
                    for k in range(n):
                        if abs(r[k]) / tol[k] > wv:
                            wv = abs(r[k]) / tol[k]
                            worst = k
                    nc_info[nonconv, 0] = t
                    nc_info[nonconv, 1] = worst
                    nc_info[nonconv, 2] = wv
                nonconv += 1
                need_jac = True
            for k in range(n):
                yprev[k] = y[k]
                y[k] = ynew[k]
            _rhs(y, t, P, E, scheme, dirn, ctx, f, aux)
            # rate-independent stop operators: accept their new values
            ctx[1] = aux[_A_DE]
            for j in range(4):
                ctx[2 + j] = aux[_A_S1 + j]
            # ---- thermal network (explicit Euler)
            ploss = abs(aux[_A_F] * y[_Y_WQ]) + 0.5 * abs(aux[_A_FM] * y[_Y_WU]) \
                + P[_DA] * aux[_A_DDA] ** 2 + P[_DB] * aux[_A_DDE] ** 2
            q_oh = P[_GOH] * (th_oil - th_h)
            pcu_tot = 0.0
            for m in range(3):
                im = aux[_A_TM] * P[_SH1 + m] / (REDUCTION * P[_KT1 + m])
                pcu = P[_RW] * im * im
                qw = P[_GW] * (tw[m] - th_h)
                tw[m] += h * (pcu - qw) / P[_CW]
                pcu_tot += qw
            th_oil += h * (ploss - q_oh) / P[_COIL]
            th_h += h * (q_oh + pcu_tot - P[_GHA] * (th_h - P[_TAMB])) / P[_CH]
            ctx[0] = th_oil
        else:
            _rhs(y, t, P, E, scheme, dirn, ctx, f, aux)
        out[i, _O_T] = t
        out[i, _O_U] = y[_Y_U]
        out[i, _O_WU] = y[_Y_WU]
        out[i, _O_PH] = y[_Y_PH]
        out[i, _O_Q] = y[_Y_Q]
        out[i, _O_WQ] = y[_Y_WQ]
        out[i, _O_TA] = aux[_A_TA]
        out[i, _O_TB] = aux[_A_TB]
        out[i, _O_F] = aux[_A_F]
        out[i, _O_TL] = y[_Y_TL]
        out[i, _O_TCMD] = aux[_A_TCMD]
        out[i, _O_TM] = aux[_A_TM]
        out[i, _O_OIL] = th_oil
        out[i, _O_HOUSE] = th_h
        out[i, _O_W1] = tw[0]
        out[i, _O_W2] = tw[1]
        out[i, _O_W3] = tw[2]
        out[i, _O_D] = aux[_A_D]
        out[i, _O_RP] = aux[_A_RP]
        out[i, _O_ACC] = aux[_A_DWQ]
    stats = np.array([float(nonconv), float(njac), float(niter), float(nsub)])
    return out, stats, nc_info


@nb.njit(cache=True)
def _pt1_foh(x, h, tau):
    """First-order lag tau*y' = x - y applied exactly to the piecewise-linear input."""
    y = np.empty_like(x)
    y[0] = x[0]
    if tau <= 0.0:
        for i in range(1, x.shape[0]):
            y[i] = x[i]
        return y
    a = math.exp(-h / tau)
    c = tau / h * (1.0 - a)
    b0 = 1.0 - c
    b1 = c - a
    for i in range(1, x.shape[0]):
        y[i] = a * y[i - 1] + b0 * x[i] + b1 * x[i - 1]
    return y


@nb.njit(cache=True)
def _observer(yq, alpha, beta, h):
    """Alpha-beta (steady-state Kalman, constant-velocity model) velocity observer."""
    n = yq.shape[0]
    v = np.empty(n)
    x = yq[0]
    vv = 0.0
    v[0] = 0.0
    for i in range(1, n):
        xp = x + h * vv
        e = yq[i] - xp
        x = xp + alpha * e
        vv = vv + beta / h * e
        v[i] = vv
    return v


# =============================================================================================
# python side
# =============================================================================================


@dataclass
class SensorSpec:
    """The sensor chain of one run (all defaults are this bench's instruments)."""
    sample_rate_hz: float = 1000.0      # DAQ sample rate of every channel
    encoder_res_deg: float = 0.01       # output encoder step [deg] (Table 10)
    torque_noise: float = 150.0         # joint torque transducer white noise sd [N·m]
    torque_lag_s: float = 0.0           # torque channel's extra (fieldbus) delay [s]
    load_noise: float = 120.0           # loading-shaft torque transducer noise sd [N·m]
    torque_adc_step: float = 6.0        # torque / torque_load quantisation [N·m]
    motor_encoder_bits: int = 22        # motor encoder single-turn resolution [bit]
    observer_hz: float = 8.0            # natural frequency of the output velocity observer [Hz]
    observer_zeta: float = 0.8          # its damping ratio
    aa_max_hz: float = 100.0            # the DAQ anti-alias filters' cut-off cap [Hz]
    dropout_prob: float = 0.001         # probability a torque sample is lost on the fieldbus
    jitter_s: float = 2e-5              # sd of the sampling instants' jitter [s]
    interp_error_steps: float = 0.2     # encoder sub-step interpolation error amplitude [steps]
    temp_res_c: float = 0.1             # temperature channels' quantisation [°C]
    temp_lag_s: float = 5.0             # gearbox temperature probe's thermal lag [s]


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict


# ------------------------------------------------------------------ validation

def _is_real(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))


def _check_int(name, v, allowed=None, minimum=None):
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {v!r}")
    v = int(v)
    if allowed is not None and v not in allowed:
        raise ValueError(f"{name} must be one of {sorted(allowed)}, got {v!r}")
    if minimum is not None and v < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {v!r}")
    return v


def _check_real(name, v, lo=None, hi=None, lo_open=False):
    if not _is_real(v):
        raise ValueError(f"{name} must be a real number, got {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v!r}")
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise ValueError(f"{name} must be {'>' if lo_open else '>='} {lo}, got {v!r}")
    if hi is not None and v > hi:
        raise ValueError(f"{name} must be <= {hi}, got {v!r}")
    return v


def _check_sensors(s) -> SensorSpec:
    if not isinstance(s, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {type(s).__name__}")
    _check_real("sensors.sample_rate_hz", s.sample_rate_hz, 1.0, 2000.0)
    _check_real("sensors.encoder_res_deg", s.encoder_res_deg, 0.0, 1.0, lo_open=True)
    _check_real("sensors.torque_noise", s.torque_noise, 0.0, 1e5)
    _check_real("sensors.torque_lag_s", s.torque_lag_s, 0.0, 1.0)
    _check_real("sensors.load_noise", s.load_noise, 0.0, 1e5)
    _check_real("sensors.torque_adc_step", s.torque_adc_step, 0.0, 1e4)
    _check_int("sensors.motor_encoder_bits", s.motor_encoder_bits, minimum=8)
    if int(s.motor_encoder_bits) > 32:
        raise ValueError(f"sensors.motor_encoder_bits must be <= 32, got {s.motor_encoder_bits!r}")
    _check_real("sensors.observer_hz", s.observer_hz, 0.1, 100.0)
    _check_real("sensors.observer_zeta", s.observer_zeta, 0.3, 2.0)
    _check_real("sensors.aa_max_hz", s.aa_max_hz, 1.0, 1e4)
    _check_real("sensors.dropout_prob", s.dropout_prob, 0.0, 0.5)
    _check_real("sensors.jitter_s", s.jitter_s, 0.0, 1e-3)
    _check_real("sensors.interp_error_steps", s.interp_error_steps, 0.0, 0.49)
    _check_real("sensors.temp_res_c", s.temp_res_c, 0.0, 5.0)
    _check_real("sensors.temp_lag_s", s.temp_lag_s, 0.0, 600.0)
    return s


def _check_effects(effects) -> dict[str, tuple[str, int, float]]:
    """Normalised {name: (form, form_code, scale)}; scale-0 effects are kept (they do nothing)."""
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict of name -> {{'form', 'scale'}}, got "
                         f"{type(effects).__name__}")
    outd = {}
    for name, spec in effects.items():
        if not isinstance(name, str) or name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect name {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effects[{name!r}] must be a dict with 'scale' (and 'form'), got "
                             f"{type(spec).__name__}")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effects[{name!r}] has unknown keys {sorted(map(str, extra))}; "
                             "allowed: 'form', 'scale'")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if not isinstance(form, str) or form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}]['form'] must be one of {EFFECT_FORMS[name]}, "
                             f"got {form!r}")
        if "scale" not in spec:
            raise ValueError(f"effects[{name!r}]['scale'] is required")
        sc = spec["scale"]
        if not _is_real(sc) or not math.isfinite(float(sc)):
            raise ValueError(f"effects[{name!r}]['scale'] must be a finite number, got {sc!r}")
        sc = float(sc)
        if sc < 0.0 or sc > SCALE_MAX:
            raise ValueError(f"effects[{name!r}]['scale'] must be in [0, {SCALE_MAX}], got {sc!r}")
        outd[name] = (form, EFFECT_FORMS[name].index(form) + 1, sc)
    return outd


# ------------------------------------------------------------------ campaign / run draws

_FOURIER_A = np.array([0.62, -0.18, 0.31, -0.52, -0.23])
_FOURIER_B = np.array([0.48, 0.41, -0.27, -0.12, 0.0])


def _fourier_coeffs():
    """Fifth-order Fourier trajectory (Eq. 12): zero start velocity (sum a = 0) and zero start
    acceleration (sum l b_l = 0), scaled to 90 % of the output speed limit."""
    a = _FOURIER_A - _FOURIER_A.mean()
    b = _FOURIER_B.copy()
    ls = np.arange(1, 6)
    b[4] = -np.dot(ls[:4], b[:4]) / 5.0
    wf = 2.0 * math.pi / FOURIER_PERIOD
    tt = np.linspace(0.0, FOURIER_PERIOD, 4001)
    qd = sum(a[l] * np.cos(wf * (l + 1) * tt) + b[l] * np.sin(wf * (l + 1) * tt) for l in range(5))
    s = 0.9 * W_OUT_MAX / np.max(np.abs(qd))
    a, b = a * s, b * s
    q0 = float(np.sum(b / (wf * ls)))
    return a, b, wf, q0


def _draw_campaign(seed: int) -> tuple[np.ndarray, dict]:
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x4F, 0x7269675F6F]))
    n = lambda: float(rng.standard_normal())  # noqa: E731
    P = np.zeros(_NP)
    I = 6685.0 * (1 + 0.02 * n())
    P[_I] = I
    P[_MRX] = 20.8 * (1 + 0.05 * n())
    P[_MRY] = -34.5 * (1 + 0.05 * n())
    fc = 2353.0 * (1 + 0.03 * n())
    fv = 8683.0 * (1 + 0.03 * n())
    P[_FC], P[_FV] = fc, fv
    ka = 3.4e7 * (1 + 0.04 * n())
    kb0 = 1.6e7 * (1 + 0.04 * n())
    twist_rated = math.radians(0.5) * (1 + 0.04 * n())
    db = twist_rated - T_RATED / ka
    kb1 = (T_RATED - kb0 * db) / db ** 1.5
    P[_KA], P[_KB0], P[_KB1] = ka, kb0, kb1
    P[_DA] = 6.0e4 * (1 + 0.1 * n())
    P[_DB] = 1.0e5 * (1 + 0.1 * n())
    P[_JI] = 3.5e3 * (1 + 0.05 * n())
    P[_JU] = 4.0e5 * (1 + 0.03 * n())
    zmax = 2.0e-5 * (1 + 0.1 * n())
    P[_SIG0] = fc / zmax
    P[_SIG1] = 0.3 * math.sqrt(P[_SIG0] * I)
    P[_VSIG] = 2.0e-4
    P[_PSIMAX] = 0.05 * (1 + 0.2 * n())
    P[_TAGE] = 0.6
    P[_DC] = 1.2e-4
    P[_VA] = 2.0e-5
    P[_CM] = 4950.0 * (1 + 0.1 * n())
    P[_CVM] = 7.3e4 * (1 + 0.1 * n())
    P[_WEPS] = 1e-5
    jt = P[_JU] + P[_JI] + I
    P[_KP] = jt * 2 * math.pi * 10.0
    P[_KI] = P[_KP] * 2 * math.pi * 2.0
    P[_KPOS] = 2 * math.pi * 1.2
    P[_TMAX] = 3 * 15.0 * REDUCTION
    P[_TDYN] = 0.03 * (1 + 0.1 * n())
    P[_SLEW] = 2.5e5
    P[_GD] = 0.004 * n()
    P[_DRAG] = 120.0 * (1 + 0.3 * abs(n()))
    P[_CL] = 2.6e6
    P[_XIB] = 0.3
    P[_RP1], P[_FP1] = 0.012, 9 * 1480.0 / 60.0
    P[_RP2], P[_FP2] = 0.004, 0.31 * (1 + 0.05 * n())
    P[_TACC] = 1.0
    a, b, wf, q0 = _fourier_coeffs()
    P[_FA1:_FA1 + 5] = a
    P[_FB1:_FB1 + 5] = b
    P[_WF], P[_Q0F] = wf, q0
    ph = rng.uniform(0, 2 * math.pi, 9)
    P[_PHG1:_PHG1 + 3] = ph[0:3]
    P[_PHM1], P[_PHM2] = ph[3], ph[4]
    P[_PHD1], P[_PHD2], P[_PHD3] = ph[5], ph[6], ph[7]
    P[_PHS] = ph[8]
    P[_COIL], P[_GOH], P[_CH], P[_GHA] = 9e3, 20.0, 1.5e5, 10.0
    P[_CW], P[_GW], P[_RW] = 2.5e3, 1.5, 1.1
    sh = 1 + 0.02 * rng.standard_normal(3)
    P[_SH1:_SH1 + 3] = sh / sh.sum()
    P[_KT1:_KT1 + 3] = 1.6 * (1 + 0.03 * rng.standard_normal(3))
    info = {"I": I, "mr_x": P[_MRX], "mr_y": P[_MRY], "f_c": fc, "f_v": fv,
            "k_a": ka, "k_b0": kb0, "k_b1": kb1, "d_a": P[_DA], "d_b": P[_DB],
            "J_i": P[_JI], "J_u": P[_JU], "sigma0": P[_SIG0], "sigma1": P[_SIG1],
            "presliding_rad": zmax, "psi_max": P[_PSIMAX], "motor_coulomb": P[_CM],
            "motor_viscous": P[_CVM], "speed_kp": P[_KP], "speed_ki": P[_KI], "pos_kp": P[_KPOS],
            "dyn_tau_s": P[_TDYN], "dyn_gain_error": P[_GD], "dyn_drag": P[_DRAG],
            "scheme3_load_gain": P[_CL], "twist_rated_rad": twist_rated,
            "fourier_a": a.tolist(), "fourier_b": b.tolist(), "fourier_wf": wf,
            "motor_share": P[_SH1:_SH1 + 3].tolist(), "motor_kt": P[_KT1:_KT1 + 3].tolist()}
    return P, info


# ------------------------------------------------------------------ helpers

def stage_b_torque(params: dict, d):
    """Nominal elastic torque of stage B at twist d [rad] (for tests/scoring)."""
    d = np.asarray(d, float)
    return params["rig"]["k_b0"] * d + params["rig"]["k_b1"] * np.sign(d) * np.abs(d) ** 1.5


def nominal_twist(params: dict, torque):
    """Nominal static twist u - q [rad] that carries the torque [N·m] (no effects): stage A
    linear plus the inverse of stage B's stiffening law (vectorised Newton)."""
    tq = np.asarray(torque, float)
    kb0, kb1 = params["rig"]["k_b0"], params["rig"]["k_b1"]
    a = np.abs(tq)
    x = a / kb0
    for _ in range(40):
        sx = np.sqrt(np.maximum(x, 0.0))
        x = np.maximum(x - (kb0 * x + kb1 * x * sx - a) / (kb0 + 1.5 * kb1 * sx), 0.0)
    return np.sign(tq) * x + tq / params["rig"]["k_a"]


def _observer_gains(fn, zeta, h):
    wn = 2 * math.pi * fn
    sr = complex(-zeta * wn, wn * math.sqrt(max(1 - zeta * zeta, 0.0)))
    if zeta >= 1.0:
        s1 = -wn * (zeta - math.sqrt(zeta * zeta - 1))
        s2 = -wn * (zeta + math.sqrt(zeta * zeta - 1))
        p1, p2 = math.exp(s1 * h), math.exp(s2 * h)
        prod, ssum = p1 * p2, p1 + p2
    else:
        p = np.exp(sr * h)
        prod, ssum = abs(p) ** 2, 2 * p.real
    alpha = 1 - prod
    beta = 2 - alpha - ssum
    return alpha, beta


def _observer_props(alpha, beta, h, step):
    """Low-frequency lag [s] and quantisation-noise sd of the observer's velocity output."""
    A = np.array([[1 - alpha, (1 - alpha) * h], [-beta / h, 1 - beta]])
    B = np.array([alpha, beta / h])
    w = 1e-3
    z = np.exp(1j * w * h)
    H = np.array([0, 1]) @ np.linalg.solve(np.eye(2) - A / z, B)
    lag = -np.angle(H / (1j * w)) / w
    # impulse response energy
    s = B.copy()
    acc = s[1] ** 2
    for _ in range(200000):
        s = A @ s
        acc += s[1] ** 2
        if s[1] ** 2 < 1e-30 * acc:
            break
    sd = step / math.sqrt(12) * math.sqrt(acc)
    return float(lag), float(sd)


def _phase_labels(t: np.ndarray, scheme: int) -> np.ndarray:
    lab = np.empty(t.shape[0], dtype=object)
    if scheme == 3:
        lab[:] = "excite"
        return lab
    lab[:] = "idle"
    if scheme == 1:
        lab[(t >= 2.0) & (t < 27.0)] = "load"
        lab[(t >= 27.0) & (t < 29.0)] = "hold"
        lab[(t >= 29.0) & (t < 54.0)] = "unload"
        return lab
    up = (t >= 2.0) & (t < 26.0)
    dn = (t >= 26.0) & (t < 48.5)
    lab[up] = "hold"
    lab[dn] = "hold"
    lab[up & (np.mod(t - 2.0, 2.0) < 0.5)] = "load"
    lab[dn & (np.mod(t - 26.0, 2.0) < 0.5)] = "unload"
    return lab


_STATE_TOL = np.array([1e-10, 1e-10, 1e-10, 1e-10, 1e-10, 1e-10, 1e-12, 1e-7, 1e-1, 1e-1,
                       1e-7, 1e-10, 1e-10])
_STATE_EPS = np.array([1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-12, 1e-8, 1e-2, 1e-2,
                       1e-8, 1e-9, 1e-9])


# ------------------------------------------------------------------ main entry point

def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int,
                 temp_joint_c: float, effects: dict[str, dict] | None = None, *,
                 sensors: SensorSpec = SensorSpec(), periods: int = 3,
                 seed: int, run: int) -> RigRun:
    """Simulate one run of the J4 bench (see the module docstring for the plant)."""
    scheme = _check_int("scheme", scheme, allowed={1, 2, 3})
    direction = _check_int("direction", direction, allowed={1, -1})
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3 (the Fourier trajectory "
                             f"sets the speed), got {motor_speed_rpm!r}")
        rpm = None
    else:
        if motor_speed_rpm is None:
            raise ValueError(f"motor_speed_rpm is required for scheme {scheme} (0 < rpm <= 3000)")
        rpm = _check_real("motor_speed_rpm", motor_speed_rpm, 0.0, 3000.0, lo_open=True)
    temp0 = _check_real("temp_joint_c", temp_joint_c, -20.0, 90.0)
    eff = _check_effects(effects)
    sensors = _check_sensors(sensors)
    periods = _check_int("periods", periods, minimum=1)
    if periods > 20:
        raise ValueError(f"periods must be <= 20, got {periods!r}")
    seed = _check_int("seed", seed, minimum=0)
    run = _check_int("run", run, minimum=0)

    fs = float(sensors.sample_rate_hz)
    P, rig = _draw_campaign(seed)
    P[_WOUT] = (rpm or 0.0) * 2 * math.pi / 60.0 / REDUCTION

    # run-level draws (physical) and noise, independent of the effects
    rpm_code = int(round((rpm or 0.0) * 1000))
    ss = np.random.SeedSequence([seed, run, scheme, rpm_code, direction + 2, 0x52756E])
    rng_phys, rng_noise = [np.random.default_rng(s) for s in ss.spawn(2)]
    t_amb = 20.0 + 2.0 * float(rng_phys.standard_normal())
    P[_TAMB] = t_amb
    z0 = float(rng_phys.uniform(-0.5, 0.5)) * P[_FC] / P[_SIG0]
    psi0 = P[_PSIMAX] * float(rng_phys.uniform(0.6, 1.0))
    P[_PHP1], P[_PHP2] = rng_phys.uniform(0, 2 * math.pi, 2)

    # effect array
    E = np.zeros(_NE)
    for name, (form, code, sc) in eff.items():
        if sc == 0.0:
            continue
        k = _EFFECT_SLOT[name]
        E[2 * k] = code
        E[2 * k + 1] = sc
    if E[2 * _S_RESON] > 0:
        sc = E[2 * _S_RESON + 1]
        if int(E[2 * _S_RESON]) == 1:
            rho, f2, zeta = RES_OUT
            j2 = rho * sc * P[_I]
        else:
            rho, f2, zeta = RES_LOAD
            j2 = rho * sc * P[_I]
        w2 = 2 * math.pi * f2
        E[_E_J2], E[_E_K2], E[_E_C2] = j2, j2 * w2 * w2, 2 * zeta * j2 * w2

    # time grids
    duration = FOURIER_PERIOD * periods if scheme == 3 else SCHEME_DURATION[scheme]
    m = max(1, int(math.ceil(1000.0 / fs - 1e-9)))
    h = 1.0 / (fs * m)
    n = int(math.floor(duration * fs + 1e-9)) + 1
    nsteps = (n - 1) * m + m  # one extra sample period for the jittered instants
    active = np.ones(_NY, dtype=np.bool_)
    if not (1 <= E[2 * _S_HYST] <= 3):
        active[_Y_XH] = False
    if E[2 * _S_RESON] == 0:
        active[_Y_Q2] = False
        active[_Y_W2] = False
    y0 = _init_state(P, E, scheme, float(direction), z0, psi0, temp0)
    out, stats, nc_info = _integrate(scheme, float(direction), nsteps, h, P, E, y0, temp0,
                            _STATE_TOL, _STATE_EPS, active)

    tg = out[:, _O_T]
    ks = np.arange(n) * m
    t = ks * h
    # ---------------- sensor chain
    jit = np.clip(rng_noise.standard_normal(n), -3, 3) * sensors.jitter_s
    ts = t + jit
    e_noise = rng_noise.standard_normal(n)
    l_noise = rng_noise.standard_normal(n)
    drop = rng_noise.random(n) < sensors.dropout_prob
    misc_noise = rng_noise.standard_normal((14, n))

    f_aa = min(fs / 3.0, sensors.aa_max_hz)
    tau_aa = 1.0 / (2 * math.pi * f_aa)

    tb = out[:, _O_TB]
    dform = int(E[2 * _S_DELAY])
    dsc = E[2 * _S_DELAY + 1]
    tdel = tb
    if dform == 1:
        tdel = np.interp(tg - DELAY_S * dsc, tg, tb)
    elif dform == 2:
        tdel = _pt1_foh(tb, h, DELAY_S * dsc)
    elif dform == 3:
        tdel = _pt1_foh(_pt1_foh(tb, h, 0.5 * DELAY_S * dsc), h, 0.5 * DELAY_S * dsc)
    elif dform == 4:
        pb = BUS_HOLD_S * dsc
        tdel = np.interp(np.floor(tg / pb) * pb, tg, tb)
    tf = _pt1_foh(_pt1_foh(tdel, h, tau_aa), h, tau_aa)
    torque = np.interp(ts - sensors.torque_lag_s, tg, tf)
    oform = int(E[2 * _S_OFFSET])
    osc = E[2 * _S_OFFSET + 1]
    if oform == 1:
        torque = torque + OFFSET_CONST * osc
    elif oform == 2:
        torque = torque + OFFSET_RATE * osc * t
    elif oform == 3:
        torque = torque + OFFSET_EXP * osc * (1 - np.exp(-t / OFFSET_EXP_TAU))
    elif oform == 4:
        torque = torque + OFFSET_THERM * osc * (out[ks, _O_HOUSE] - 20.0)
    torque = torque + sensors.torque_noise * e_noise
    adc = sensors.torque_adc_step
    if adc > 0:
        torque = np.round(torque / adc) * adc
    torque[drop] = np.nan

    tlf = _pt1_foh(_pt1_foh(out[:, _O_TL], h, tau_aa), h, tau_aa)
    tload = np.interp(ts, tg, tlf)
    sform = int(E[2 * _S_DRIFT])
    ssc = E[2 * _S_DRIFT + 1]
    if sform == 1:
        tload = tload + DRIFT_RATE * ssc * t
    elif sform == 2:
        tload = tload + DRIFT_EXP * ssc * (1 - np.exp(-t / DRIFT_EXP_TAU))
    tload = tload + sensors.load_noise * l_noise
    if adc > 0:
        tload = np.round(tload / adc) * adc

    # output encoder (absolute, zeroed at the start), sub-step interpolation error
    step = math.radians(sensors.encoder_res_deg)
    per = 512.0 * step
    creep = DRIFT_CREEP * ssc if sform == 3 else 0.0

    def encoder(qtrue, tt):
        x = qtrue + creep * tt
        x = x + sensors.interp_error_steps * step * (
            0.8 * np.sin(2 * np.pi * x / per) + 0.5 * np.sin(4 * np.pi * x / per + 0.7))
        return np.round(x / step) * step

    q_read = encoder(np.interp(ts, tg, out[:, _O_Q]), t)
    q_grid = encoder(out[:, _O_Q], tg)
    alpha, beta = _observer_gains(sensors.observer_hz, sensors.observer_zeta, h)
    v_obs = _observer(q_grid, alpha, beta, h)
    qd_read = v_obs[ks]
    obs_lag, obs_sd_white = _observer_props(alpha, beta, h, step)
    # the observer's error is not white at low speed (one encoder step every few samples):
    # state the realised sd of (reading - true velocity delayed by the stated lag)
    settled = t >= min(2.0, 0.5 * t[-1])
    qd_err = qd_read - np.interp(t - obs_lag, tg, out[:, _O_WQ])
    obs_sd = float(np.std(qd_err[settled]))

    ustep = 2 * math.pi / 2 ** int(sensors.motor_encoder_bits) / REDUCTION
    u_read = np.round(np.interp(ts, tg, out[:, _O_U]) / ustep) * ustep
    tau_ud = 0.004
    ud_sd = 1.5e-7
    ud_f = _pt1_foh(out[:, _O_WU], h, tau_ud)
    ud_read = np.interp(ts, tg, ud_f) + ud_sd * misc_noise[0]
    w_read = [REDUCTION * np.interp(ts, tg, ud_f) + 1.5e-3 * misc_noise[1 + k] for k in range(3)]
    tau_i = 0.001
    tm_f = _pt1_foh(out[:, _O_TM], h, tau_i)
    tm_s = np.interp(ts, tg, tm_f)
    i_sd = 0.02
    i_read = [tm_s * P[_SH1 + k] / (REDUCTION * P[_KT1 + k]) + i_sd * misc_noise[4 + k]
              for k in range(3)]
    tr = sensors.temp_res_c

    def tq(x):
        return np.round(x / tr) * tr if tr > 0 else x

    temp_f = _pt1_foh(out[:, _O_OIL], h, sensors.temp_lag_s)
    temp_read = tq(temp_f[ks] + 0.02 * misc_noise[7])
    tw_read = [tq(out[ks, _O_W1 + k] + 0.05 * misc_noise[8 + k]) for k in range(3)]
    rp_f = _pt1_foh(_pt1_foh(out[:, _O_RP], h, tau_aa), h, tau_aa)
    rp_s = np.interp(ts, tg, rp_f)
    p0, mb0, fs0 = 16e6, 100e3, 90e3
    p_read = p0 * (1 + rp_s) + 5e3 * misc_noise[11]
    mb_read = mb0 * (1 + rp_s) + 150.0 * misc_noise[12]
    fsh_read = fs0 * (1 + rp_s) + 120.0 * misc_noise[13]

    samples = pd.DataFrame({
        "t": t, "q": q_read, "qd": qd_read, "u": u_read, "ud": ud_read,
        "torque": torque, "torque_load": tload, "torque_cmd": out[ks, _O_TCMD],
        "i_m1": i_read[0], "i_m2": i_read[1], "i_m3": i_read[2],
        "w_m1": w_read[0], "w_m2": w_read[1], "w_m3": w_read[2],
        "temp_m1": tw_read[0], "temp_m2": tw_read[1], "temp_m3": tw_read[2],
        "temp_joint": temp_read, "p_hyd": p_read, "m_bend": mb_read, "f_shear": fsh_read,
        "phase": _phase_labels(t, scheme),
    })

    truth = pd.DataFrame({
        "t": t, "q": out[ks, _O_Q], "qd": out[ks, _O_WQ], "qdd": out[ks, _O_ACC],
        "u": out[ks, _O_U], "ud": out[ks, _O_WU], "phi": out[ks, _O_PH],
        "twist": out[ks, _O_U] - out[ks, _O_Q],
        "twist_a": out[ks, _O_U] - out[ks, _O_PH], "twist_b": out[ks, _O_PH] - out[ks, _O_Q],
        "torque": out[ks, _O_TB], "torque_a": out[ks, _O_TA],
        "torque_load": out[ks, _O_TL], "torque_cmd": out[ks, _O_TCMD],
        "friction": out[ks, _O_F], "disturbance": out[ks, _O_D],
        "gravity": G0 * (P[_MRX] * np.sin(out[ks, _O_Q]) + P[_MRY] * np.cos(out[ks, _O_Q])),
        "motor_torque": out[ks, _O_TM], "temp_oil": out[ks, _O_OIL],
        "temp_housing": out[ks, _O_HOUSE], "pressure_ripple": out[ks, _O_RP],
    })

    lag_t = 2 * tau_aa
    meta = {
        "scheme": scheme, "motor_speed_rpm": rpm, "direction": direction,
        "reduction": REDUCTION, "rig": RIG_NAME, "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": _started_at(seed, run),
        "notes": f"validation rig O (independent physics model), campaign seed {seed}, run {run}",
        "shear_setpoint_n": fs0, "bend_setpoint_nm": mb0,
        "sensors": {
            "q": {"resolution": step, "noise_sd": 0.0, "lag_s": 0.0},
            "u": {"resolution": ustep, "noise_sd": 0.0, "lag_s": 0.0},
            "qd": {"noise_sd": obs_sd, "lag_s": obs_lag},
            "ud": {"noise_sd": ud_sd, "lag_s": tau_ud},
            "torque": {"resolution": adc, "noise_sd": float(sensors.torque_noise),
                       "lag_s": float(sensors.torque_lag_s) + lag_t},
            "torque_load": {"resolution": adc, "noise_sd": float(sensors.load_noise),
                            "lag_s": lag_t},
            "torque_cmd": {"noise_sd": 0.0, "lag_s": 0.0},
            "w_m1": {"noise_sd": 1.5e-3, "lag_s": tau_ud},
            "w_m2": {"noise_sd": 1.5e-3, "lag_s": tau_ud},
            "w_m3": {"noise_sd": 1.5e-3, "lag_s": tau_ud},
            "i_m1": {"noise_sd": i_sd, "lag_s": tau_i},
            "i_m2": {"noise_sd": i_sd, "lag_s": tau_i},
            "i_m3": {"noise_sd": i_sd, "lag_s": tau_i},
            "temp_joint": {"resolution": tr, "noise_sd": 0.02, "lag_s": float(sensors.temp_lag_s)},
            "p_hyd": {"noise_sd": 5e3, "lag_s": lag_t},
        },
    }
    params = {
        "rig": rig,
        "run": {"ambient_c": t_amb, "z0": z0, "psi0": psi0, "temp_joint_c": temp0,
                "duration_s": duration, "internal_step_s": h, "substeps": m,
                "solver_nonconverged_steps": int(stats[0]), "solver_jacobians": int(stats[1]),
                "solver_iterations": int(stats[2]), "solver_substepped_steps": int(stats[3]),
                "solver_nonconverged_at": [(float(a), int(b), float(c)) for a, b, c in
                                           nc_info[:min(int(stats[0]), 16)]]},
        "effects": {k: {"form": v[0], "scale": v[2]} for k, v in eff.items()},
        "sensors": asdict(sensors),
        "imperfections": {
            "encoder_interp_error_rad": sensors.interp_error_steps * step,
            "encoder_interp_period_rad": per,
            "timing_jitter_sd_s": sensors.jitter_s,
            "torque_dropout_prob": sensors.dropout_prob,
            "torque_dropped_samples": int(drop.sum()),
            "aa_filter": {"type": "2 x first order", "cutoff_hz": f_aa},
            "velocity_observer": {"f_n_hz": sensors.observer_hz, "zeta": sensors.observer_zeta,
                                  "alpha": alpha, "beta": beta, "lag_s": obs_lag,
                                  "white_quantisation_sd": obs_sd_white},
            "dynamometer": {"gain_error": P[_GD], "drag_nm": P[_DRAG], "tau_s": P[_TDYN]},
            "hydraulic_ripple": {"pump_rel": P[_RP1], "pump_hz": P[_FP1], "hunting_rel": P[_RP2],
                                 "hunting_hz": P[_FP2], "friction_share": P[_XIB]},
            "motor_current_share": P[_SH1:_SH1 + 3].tolist(),
            "dwell_stiction_max": P[_PSIMAX],
            "stage_b_stiffening": {"k_b0": P[_KB0], "k_b1": P[_KB1]},
        },
    }
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)


def _started_at(seed: int, run: int) -> str:
    base = np.datetime64("2026-03-02T08:00:00") + np.timedelta64(int(seed % 997), "D") \
        + np.timedelta64(int(run) * 150, "s")
    return str(base) + "Z"
