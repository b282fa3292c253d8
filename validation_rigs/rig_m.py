"""Rig M: an independent simulation of the CMOR joint-4 test platform (blind validation data).

Written from the physics of ../shared/docs/rig.md, ../shared/docs/effects-in-the-wild.md and the
CMOR paper only, without reading the service's emulator or estimator; it imports nothing of the
repository.

Plant (all torques referred to the joint output, angles in rad at the output)
---------------------------------------------------------------------------
* Output side (paper's Eq. 4 plus the measured load):
      I*q'' = T - tau_L - g*(mr_x*sin q + mr_y*cos q) - F_fric - other
  `other` is zero at scale 0 (it carries the output-mesh ripple, a periodic disturbance and the
  reaction of a second resonant mass when those effects are injected).
* Friction: a Dahl-type bristle law with a velocity-dependent level (LuGre without sigma1),
      F_fric = sigma0*z + f_v*q',   z' = q' - sigma0*|q'|*z / g(q'),
  with g = f_c at scale 0, so that steady sliding gives exactly f_c*sgn(q') + f_v*q' (Eq. 4), and
  velocity reversals show presliding (a bristle deflection of ~5e-5 rad) instead of a jump.
  Stribeck, load, temperature and direction effects act on g and f_v.
* Transmission: elastic with damping (Eq. 5) and a nominal *quadratic stiffening* of the gear
  train,   T = k0*d + k2*d*|d| + D*d',   d = twist (u - q) after backlash / kinematic error,
  sized so that the twist is ~0.5 deg at 120 kN*m (the k2 term gives ~25 % of the torque there).
* Motor side: the three servo motors (and the first gear stages) as one inertia J_u = 3*J_m*N^2,
      J_u*u'' = tau_m - T - (F_mc*tanh(u'/eps) + F_mv*u')   (motor-side bearing/seal friction),
  tau_m follows the drive's torque command through a first-order current loop (1.5 ms).
* Drive control (S120-like, executed at every integration step, zero-order hold): schemes 1-2 a
  PI speed controller on the motor speed following a 1 s ramp to +-motor_speed_rpm; scheme 3 a
  P position loop on the motor encoder (semi-closed loop, Kv = 20 1/s) with speed feed-forward
  around the same PI speed loop.  Torque limit 3 x 12 N*m at the motor shafts, anti-windup.
* Dynamometer: tau_L' = (tau_set + e_d(t) - tau_L)/tau_d, tau_d ~ 40 ms, with e_d a slow random
  tracking error (Ornstein-Uhlenbeck, sd 300 N*m, 1.5 s, smoothed by a 0.4 s pole, clipped at
  +-1.8 kN*m: inside Table 11's +-2 kN*m).  The load always *resists* the motion: tau_set has
  the sign of the direction (schemes 1-2) or of the reference velocity (scheme 3, where the
  dynamometer acts as a 60 kN*m velocity-proportional brake, so that the torque reverses at
  every velocity reversal).  The e_d process is part of the run's noise (seed, run).
* Gearbox temperature: first-order thermal node heated by the friction power of both sides.
* Integrator: classical RK4 on a fixed step <= 0.25 ms (an integer fraction of the sample period),
  numba-compiled.

Schemes: 1 = idle 3 s, load ramp 0 -> 120 kN*m in 25 s, unload ramp 25 s, idle 2 s, all at
constant motor speed; 2 = idle 3 s, twelve 10 kN*m steps (0.5 s ramp + 2 s hold), unload 5 s,
idle 2 s;
3 = 1 s idle, `periods` periods (12 s each) of a fifth-order Fourier trajectory (Eq. 12) with
zero start velocity and acceleration, peak speed 90 % of the 3000 r/min speed, 1 s idle.

Sensor chain (stated truthfully in meta["sensors"])
--------------------------------------------------
* q: output encoder, step `encoder_res_deg`, incremental (floor) with a random sub-count zero.
* qd: (q_enc(t) - q_enc(t - 50 ms)) / 50 ms  -> quantised at step/0.05 s, lag 25 ms.
* u: motor encoder 22 bit/motor rev, divided by N;  ud: same difference over 8 ms (lag 4 ms).
* torque: joint torque transducer: pure delay `torque_lag_s`, white noise `torque_noise`,
  16-bit ADC over +-200 kN*m.
* torque_load: load cell: pure delay 4 ms, white noise 150 N*m, 16-bit ADC over +-200 kN*m.
* temp_joint: PT100, first-order 3 s, noise 0.03 degC, 0.1 degC step.
* i_m1..3: motor currents, noise 0.02 A, 1 mA step;  torque_cmd: the dynamometer set point.

Unstated imperfections (present at scale 0, not in the metadata)
----------------------------------------------------------------
1. Output encoder eccentricity: the encoder disc is mounted 4 arcsec off-centre, so the reading
   carries 1.94e-5 rad * sin(q + phi) (one cycle per output revolution) before quantisation.
2. Bending-moment cross-talk into the torque transducer: the hydraulics hold a bending moment of
   ~80 kN*m during every run and 0.07 % of it (~+-56 N*m, sign drawn per rig) leaks into the
   torque reading as a constant offset.

Effects (`effects={name: {"form", "scale"}}`, scale clamped to [0, SCALE_MAX], scale 1 = clearly
visible but realistic; contributions are linear in scale to first order)
----------------------------------------------------------------------------------------------
stribeck (g += s*450 N*m*shape(|v|/v_s), v_s = 8e-3 rad/s, 28 % of the top speed; its falling
    slope is kept below the transmission damping so that it does not turn into stick-slip):
    gaussian exp(-x^2), exponential exp(-x), lorentzian 1/(1+x^2), root exp(-sqrt x).
    (The Coulomb level g is floored at 0.2*f_c under every combination of effects.)
load_dependent_friction: coulomb_linear g += s*0.012*|T|; coulomb_viscous g, f_v *= 1 +
    s*0.5*|T|/120 kN*m; power_flow g += s*mu*|T| with mu = 0.016 driving / 0.005 back-driving;
    quadratic g += s*0.012*T^2/120 kN*m.
temperature_friction (theta_ref = 35 degC, gearbox temperature theta(t)): viscous_exponential
    f_v *= 1 + s*(exp(-0.04*(theta-35)) - 1) (oil viscosity halving every ~17 K);
    coulomb_linear g += s*0.01*f_c*(35 - theta); both_exponential f_c and f_v *= 1 +
    s*0.4*(exp(-0.025*(theta-35)) - 1); viscous_polynomial f_v *= 1 + s*(0.8*x + 0.4*x^2),
    x = (35 - theta)/25.  Factors are floored at 0.1 (reached only by large scales when hot).
gear_ripple (torque on the output, 84 mesh cycles per output revolution, 450 N*m): output_mesh
    (one harmonic); output_harmonics (1, 1/2, 1/3 of the 1st-3rd harmonics); output_load_modulated
    (amplitude (0.25 + |T|/120 kN*m)); motor_side (a kinematic transmission error of 3e-5 rad at
    3 and 6 cycles per motor revolution, inside the elastic twist: 150 Hz at 3000 r/min).
torque_offset (torque reading only): constant 600 N*m; linear_drift 600 N*m/min; warmup
    600*(1 - exp(-t/20 s)); thermal 40 N*m/K*(theta - 25 degC).
time_delay (torque reading only, on top of the stated lag): pure 10 ms; first_order tau = 10 ms;
    hold (sample-and-hold refreshed every 20 ms on the transducer's own clock, which runs
    0.37 % fast and starts at a drawn phase).
hysteresis (in the transmission, T += s*0.4*k0*x, x0 = 4e-4 rad, x driven by the elastic
    deformation rate): bouc_wen_n1 (alpha 1, beta 0.6/x0, gamma 0.4/x0); bouc_wen_n2 (n = 2,
    beta 0.6/x0^2, gamma 0.4/x0^2); dahl (n = 1, beta 1/x0, gamma 0); maxwell (rate-dependent
    visco-elastic Maxwell element x' = d' - x/2 s, T += s*0.15*k0*x).
backlash (half width s*1.5e-4 rad in the twist): sharp dead zone; smooth (softplus corners of
    5e-5 rad); preload (sharp, closing under load: b/(1 + |tau_L|/25 kN*m)).
asymmetric_friction: coulomb g *= 1 + s*0.25*sgn v; viscous f_v *= 1 + s*0.4*sgn v; both
    (0.2 and 0.3).
Out of the vocabulary:
periodic_disturbance (torque on the output, 500 N*m): sine 1.7 Hz; harmonics 1.45 Hz + 2nd + 3rd;
    beating 1.3 Hz modulated at 0.07 Hz; slow 0.23 Hz.
position_dependent_stiffness (the compliance varies with the output angle: the elastic law
    sees d/(1 + s*a*shape(q))): once_per_rev a = 0.12 sin(q + phi); twice_per_rev a = 0.12
    cos(2q + phi); linear a = 0.15, shape q/(pi/2); local_bump a = 0.25 (a soft spot), Gaussian
    of 0.2 rad around a drawn angle.
sensor_drift (not the torque transducer): load_cell_offset 12 N*m/s; load_cell_gain 1.2e-4/s;
    encoder_creep 4e-6 rad/s on the output encoder reading.
second_resonance (a second inertia on a spring, mass proportional to s, fixed frequency):
    s*0.25*I hung on the output by a spring tuned to a fixed frequency (a flexible appendage of
    the output link / loading arm, unseen by the load cell): output_high 9.5 Hz (zeta 0.02),
    output_low 2.7 Hz (zeta 0.03), output_mid 4.2 Hz (zeta 0.02, below the joint's own ~6 Hz
    transmission mode).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numba import njit

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "rig_m"
SCALE_MAX = 3.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("gaussian", "exponential", "lorentzian", "root"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_viscous", "power_flow", "quadratic"),
    "temperature_friction": ("viscous_exponential", "coulomb_linear", "both_exponential",
                             "viscous_polynomial"),
    "gear_ripple": ("output_mesh", "output_harmonics", "output_load_modulated", "motor_side"),
    "torque_offset": ("constant", "linear_drift", "warmup", "thermal"),
    "time_delay": ("pure", "first_order", "hold"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl", "maxwell"),
    "backlash": ("sharp", "smooth", "preload"),
    "asymmetric_friction": ("coulomb", "viscous", "both"),
    "periodic_disturbance": ("sine", "harmonics", "beating", "slow"),
    "position_dependent_stiffness": ("once_per_rev", "twice_per_rev", "linear", "local_bump"),
    "sensor_drift": ("load_cell_offset", "load_cell_gain", "encoder_creep"),
    "second_resonance": ("output_high", "output_low", "output_mid"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "sensor_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "torque_offset": "imperfection 2, the bending moment's cross-talk into the torque "
                     "transducer: a constant offset of the torque reading, about +-56 N*m"}
"""Effects of the vocabulary that the rig carries at scale 0 without saying so in its metadata
(declared for the harness's score, after rig M's blind score; the rig's behaviour is
unchanged)."""

# --- data sheet (nominal values; each rig draws a few % around them) -------------------------
DATASHEET: dict[str, float] = {
    "I": 6685.0,          # output inertia [kg m^2] (Table 3)
    "mr_x": 20.8,         # [kg m]
    "mr_y": -34.5,        # [kg m]
    "f_v": 8683.0,        # viscous friction [N m s/rad]
    "f_c": 2353.0,        # Coulomb friction [N m]
    "k0": 1.03e7,         # initial transmission stiffness [N m/rad]
    "k2": 3.9e8,          # quadratic stiffening [N m/rad^2]
    "D": 1.3e5,           # transmission damping [N m s/rad] (damping ratio ~0.25)
    "J_m": 0.004,         # rotor + first stage inertia per motor [kg m^2]
    "F_mc": 0.15,         # motor-side Coulomb friction per motor [N m at the motor shaft]
    "F_mv": 1.0e-4,       # motor-side viscous friction per motor [N m s/rad at the motor]
    "z_ss": 5.0e-5,       # presliding (bristle) deflection at the Coulomb level [rad]
    "tau_dyn": 0.04,      # dynamometer torque-loop time constant [s]
    "tau_i": 0.0015,      # drive current-loop time constant [s]
    "k_t": 1.5,           # motor torque constant [N m/A]
    "C_th": 4.0e4,        # gearbox thermal capacity [J/K]
    "R_th": 0.1,          # gearbox thermal resistance to ambient [K/W]
}
PARAM_SPREAD = 0.03       # relative sd of the per-rig draw (clipped at 2.5 sd)
G0 = 9.81
RATED_TORQUE = 120.0e3
MOTOR_TORQUE_MAX = 12.0   # per motor [N m]
V_TOP = 3000.0 * 2.0 * math.pi / 60.0 / REDUCTION   # output speed at 3000 r/min [rad/s]
DT_MAX = 2.5e-4

# --- state / parameter / effect indices (numba arrays) ---------------------------------------
NS = 12   # q, qd, u, ud, z, xh, xm, tm, tl, th, qs, qds
(P_I, P_MRX, P_MRY, P_FV, P_FC, P_K0, P_K2, P_D, P_JU, P_FMC, P_FMV, P_SIG0, P_TAUI, P_TAUD,
 P_CTH, P_RTH, P_THAMB, P_N, P_EPSM) = range(19)
NP = 19
(E_STRIB_F, E_STRIB_A, E_STRIB_VS,
 E_LOAD_F, E_LOAD_C,
 E_TEMP_F, E_TEMP_C,
 E_RIP_F, E_RIP_A, E_RIP_Z, E_RIP_P1, E_RIP_P2, E_RIP_P3,
 E_HYS_F, E_HYS_C, E_HYS_B, E_HYS_G, E_HYS_TAU,
 E_BACK_F, E_BACK_B,
 E_ASYM_F, E_ASYM_C,
 E_PD_F, E_PD_A, E_PD_P1, E_PD_P2, E_PD_P3,
 E_PS_F, E_PS_C, E_PS_P, E_PS_QC,
 E_R2_F, E_R2_I, E_R2_W, E_R2_Z) = range(35)
NE = 35

# numba-side form codes are the 1-based position in EFFECT_FORMS[name]


@dataclass
class SensorSpec:
    """The rig's measurement chain (the stated figures go to meta["sensors"])."""
    sample_rate_hz: float = 400.0
    encoder_res_deg: float = 0.01          # output encoder step (Table 10)
    torque_noise: float = 200.0            # joint torque transducer white noise sd [N m]
    torque_lag_s: float = 0.0              # pure delay of the torque channel [s]
    torque_adc_step: float = 400.0e3 / 65536.0   # 16 bit over +-200 kN m
    load_noise: float = 150.0              # load cell white noise sd [N m]
    load_lag_s: float = 0.004              # load cell pure delay (dynamometer bus) [s]
    load_adc_step: float = 400.0e3 / 65536.0
    motor_encoder_bits: int = 22           # counts per motor revolution = 2**bits
    qd_window_s: float = 0.05              # output speed: encoder difference window [s]
    ud_window_s: float = 0.008             # motor speed: encoder difference window [s]
    temp_res: float = 0.1                  # [degC]
    temp_noise: float = 0.03               # [degC]
    temp_tau_s: float = 3.0                # PT100 first-order time constant [s]
    current_noise: float = 0.02            # [A]
    current_res: float = 0.001             # [A]


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict
    noise: pd.DataFrame = field(default_factory=pd.DataFrame)


# ============================================================================================
# numba core
# ============================================================================================

@njit(cache=True)
def _sgn(v):
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def _transmission(q, u, ud_minus_qd, ud, xh, xm, tl, P, E):
    """Transmitted torque T and the deformation rate seen by the hysteretic elements."""
    delta = u - q
    ddelta = ud_minus_qd
    if E[E_RIP_F] == 4.0:
        # kinematic error of the motor-side mesh: it shifts the tooth contact (the elastic path),
        # not the rate seen by the structural damping
        thm = P[P_N] * u
        delta -= E[E_RIP_A] * (math.sin(3.0 * thm + E[E_RIP_P1])
                               + 0.4 * math.sin(6.0 * thm + E[E_RIP_P2]))
    bf = E[E_BACK_F]
    b = E[E_BACK_B]
    if bf == 3.0:
        b = b / (1.0 + abs(tl) / 25.0e3)
    if bf == 0.0 or b <= 0.0:
        d = delta
        dd = 1.0
    elif bf == 2.0:
        # smoothed dead zone: difference of two softplus ramps of fixed width (monotone, and the
        # identity when b -> 0)
        eps = 5.0e-5
        xa = (delta - b) / eps
        xb = (-delta - b) / eps
        d = eps * ((max(xa, 0.0) + math.log1p(math.exp(-abs(xa))))
                   - (max(xb, 0.0) + math.log1p(math.exp(-abs(xb)))))
        dd = 0.5 * (1.0 + math.tanh(0.5 * xa)) + 0.5 * (1.0 + math.tanh(0.5 * xb))
    else:
        if delta > b:
            d = delta - b
            dd = 1.0
        elif delta < -b:
            d = delta + b
            dd = 1.0
        else:
            d = 0.0
            dd = 0.0
    pf = E[E_PS_F]
    if pf != 0.0:
        # the compliance (not the stiffness) varies with the output angle
        if pf == 1.0:
            sh = math.sin(q + E[E_PS_P])
        elif pf == 2.0:
            sh = math.cos(2.0 * q + E[E_PS_P])
        elif pf == 3.0:
            sh = q / (0.5 * math.pi)
        else:
            r = (q - E[E_PS_QC]) / 0.2
            sh = math.exp(-r * r)
        d = d / max(0.2, 1.0 + E[E_PS_C] * sh)
    tel = P[P_K0] * d + P[P_K2] * d * abs(d)
    rate = dd * ddelta
    T = tel + P[P_D] * rate
    hf = E[E_HYS_F]
    if hf == 4.0:
        T += E[E_HYS_C] * xm
    elif hf != 0.0:
        T += E[E_HYS_C] * xh
    return T, rate


@njit(cache=True)
def _deriv(t, y, P, E, tau_c, tl_set, dy, aux):
    q = y[0]
    qd = y[1]
    u = y[2]
    ud = y[3]
    z = y[4]
    xh = y[5]
    xm = y[6]
    tm = y[7]
    tl = y[8]
    th = y[9]
    qs = y[10]
    qds = y[11]

    T, rate = _transmission(q, u, ud - qd, ud, xh, xm, tl, P, E)

    # hysteretic element states
    hf = E[E_HYS_F]
    dxh = 0.0
    dxm = 0.0
    if hf == 1.0 or hf == 3.0:
        dxh = rate - E[E_HYS_B] * abs(rate) * xh - E[E_HYS_G] * rate * abs(xh)
    elif hf == 2.0:
        dxh = rate - E[E_HYS_B] * abs(rate) * abs(xh) * xh - E[E_HYS_G] * rate * xh * xh
    elif hf == 4.0:
        dxm = rate - xm / E[E_HYS_TAU]

    # ---- output friction: Dahl bristle with level g(v) ----
    v = qd
    fc = P[P_FC]
    fv = P[P_FV]
    g = fc
    tf = E[E_TEMP_F]
    if tf != 0.0:
        dth = th - 35.0
        c = E[E_TEMP_C]
        if tf == 1.0:
            fv = fv * max(0.1, 1.0 + c * (math.exp(-0.04 * dth) - 1.0))
        elif tf == 2.0:
            g = g + c * 0.01 * fc * (-dth)
        elif tf == 3.0:
            fac = max(0.1, 1.0 + c * 0.4 * (math.exp(-0.025 * dth) - 1.0))
            g = g * fac
            fv = fv * fac
        else:
            x = -dth / 25.0
            fv = fv * max(0.1, 1.0 + c * (0.8 * x + 0.4 * x * x))
    lf = E[E_LOAD_F]
    if lf != 0.0:
        c = E[E_LOAD_C]
        aT = abs(T)
        if lf == 1.0:
            g = g + c * 0.012 * aT
        elif lf == 2.0:
            fac = 1.0 + c * 0.5 * aT / 120.0e3
            g = g * fac
            fv = fv * fac
        elif lf == 3.0:
            mu = 0.016 if T * v > 0.0 else 0.005
            g = g + c * mu * aT
        else:
            g = g + c * 0.012 * T * T / 120.0e3
    sf = E[E_STRIB_F]
    if sf != 0.0:
        xv = abs(v) / E[E_STRIB_VS]
        if sf == 1.0:
            sh = math.exp(-xv * xv)
        elif sf == 2.0:
            sh = math.exp(-xv)
        elif sf == 3.0:
            sh = 1.0 / (1.0 + xv * xv)
        else:
            sh = math.exp(-math.sqrt(xv))
        g = g + E[E_STRIB_A] * sh
    af = E[E_ASYM_F]
    if af != 0.0:
        sg = _sgn(v)
        c = E[E_ASYM_C]
        if af == 1.0:
            g = g * (1.0 + c * 0.25 * sg)
        elif af == 2.0:
            fv = fv * (1.0 + c * 0.4 * sg)
        else:
            g = g * (1.0 + c * 0.2 * sg)
            fv = fv * (1.0 + c * 0.3 * sg)
    if g < 0.2 * fc:
        g = 0.2 * fc
    sig0 = P[P_SIG0]
    F = sig0 * z + fv * v
    dz = v - sig0 * abs(v) * z / g

    grav = G0 * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))

    # ---- other output torques (effects only) ----
    other = 0.0
    rf = E[E_RIP_F]
    if rf == 1.0 or rf == 2.0 or rf == 3.0:
        ph = E[E_RIP_Z] * q
        r = math.sin(ph + E[E_RIP_P1])
        if rf == 2.0:
            r += (0.5 * math.sin(2.0 * ph + E[E_RIP_P2])
                  + (1.0 / 3.0) * math.sin(3.0 * ph + E[E_RIP_P3]))
        elif rf == 3.0:
            r *= 0.25 + abs(T) / 120.0e3
        other += E[E_RIP_A] * r
    pdf = E[E_PD_F]
    if pdf != 0.0:
        A = E[E_PD_A]
        if pdf == 1.0:
            other += A * math.sin(2.0 * math.pi * 1.7 * t + E[E_PD_P1])
        elif pdf == 2.0:
            w = 2.0 * math.pi * 1.45 * t
            other += A * (math.sin(w + E[E_PD_P1]) + 0.5 * math.sin(2.0 * w + E[E_PD_P2])
                          + 0.25 * math.sin(3.0 * w + E[E_PD_P3]))
        elif pdf == 3.0:
            other += A * math.sin(2.0 * math.pi * 1.3 * t + E[E_PD_P1]) * (
                0.6 + 0.4 * math.sin(2.0 * math.pi * 0.07 * t + E[E_PD_P2]))
        else:
            other += A * math.sin(2.0 * math.pi * 0.23 * t + E[E_PD_P1])
    r2 = E[E_R2_F]
    tl_shaft = tl
    dqs = qds
    dqds = 0.0
    if r2 != 0.0 and E[E_R2_I] > 0.0:
        Is = E[E_R2_I]
        ks = Is * E[E_R2_W] * E[E_R2_W]
        cs = 2.0 * E[E_R2_Z] * Is * E[E_R2_W]
        fr = ks * (q - qs) + cs * (qd - qds)
        other += fr
        dqds = fr / Is

    qdd = (T - tl_shaft - grav - F - other) / P[P_I]
    fm = P[P_FMC] * math.tanh(ud / P[P_EPSM]) + P[P_FMV] * ud
    udd = (tm - T - fm) / P[P_JU]

    ploss = abs(F * v) + abs(fm * ud)
    dy[0] = qd
    dy[1] = qdd
    dy[2] = ud
    dy[3] = udd
    dy[4] = dz
    dy[5] = dxh
    dy[6] = dxm
    dy[7] = (tau_c - tm) / P[P_TAUI]
    dy[8] = (tl_set - tl) / P[P_TAUD]
    dy[9] = (ploss - (th - P[P_THAMB]) / P[P_RTH]) / P[P_CTH]
    dy[10] = dqs
    dy[11] = dqds
    aux[0] = T
    aux[1] = F
    aux[2] = grav
    aux[3] = other
    aux[4] = qdd
    aux[5] = tl_shaft


@njit(cache=True)
def _static_twist(q, u_guess, tl, target, P, E):
    """Twist d0 (u = q + d0) at which the static transmitted torque equals `target`."""
    lo = -0.05
    hi = 0.05
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        T, _r = _transmission(q, q + mid, 0.0, 0.0, 0.0, 0.0, tl, P, E)
        if T > target:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


@njit(cache=True)
def _simulate(n, dt, P, E, y0, vref, uref, pos_loop, tl_set, ctrl):
    """RK4 on a fixed step; the drive's controller runs once per step (zero-order hold).

    Records at every step: q, qd, qdd, u, ud, T, tau_L, theta, F, grav, other, tau_m."""
    kp = ctrl[0]
    ti = ctrl[1]
    kv = ctrl[2]
    tmax = ctrl[3]
    integ = ctrl[4]
    rec = np.empty((n, 12))
    y = y0.copy()
    yt = np.empty(NS)
    k1 = np.empty(NS)
    k2 = np.empty(NS)
    k3 = np.empty(NS)
    k4 = np.empty(NS)
    aux = np.empty(6)
    auxd = np.empty(6)
    for i in range(n):
        t = i * dt
        # drive controller (sampled at the step start)
        if pos_loop:
            wref = vref[i] + kv * (uref[i] - y[2])
        else:
            wref = vref[i]
        err = wref - y[3]
        integ_new = integ + err * dt
        tc = kp * (err + integ_new / ti)
        if tc > tmax:
            tc = tmax
        elif tc < -tmax:
            tc = -tmax
        else:
            integ = integ_new
        ts = tl_set[i]
        _deriv(t, y, P, E, tc, ts, k1, aux)
        rec[i, 0] = y[0]
        rec[i, 1] = y[1]
        rec[i, 2] = aux[4]
        rec[i, 3] = y[2]
        rec[i, 4] = y[3]
        rec[i, 5] = aux[0]
        rec[i, 6] = aux[5]
        rec[i, 7] = y[9]
        rec[i, 8] = aux[1]
        rec[i, 9] = aux[2]
        rec[i, 10] = aux[3]
        rec[i, 11] = y[7]
        if i == n - 1:
            break
        for j in range(NS):
            yt[j] = y[j] + 0.5 * dt * k1[j]
        _deriv(t + 0.5 * dt, yt, P, E, tc, ts, k2, auxd)
        for j in range(NS):
            yt[j] = y[j] + 0.5 * dt * k2[j]
        _deriv(t + 0.5 * dt, yt, P, E, tc, ts, k3, auxd)
        for j in range(NS):
            yt[j] = y[j] + dt * k3[j]
        _deriv(t + dt, yt, P, E, tc, ts, k4, auxd)
        for j in range(NS):
            y[j] = y[j] + dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
    return rec


@njit(cache=True)
def _first_order(x, dt, tau):
    """Exact first-order lag of a piecewise-linear signal on a uniform grid, starting at rest."""
    out = np.empty_like(x)
    a = math.exp(-dt / tau)
    b = 1.0 - a
    out[0] = x[0]
    for i in range(1, x.size):
        out[i] = a * out[i - 1] + b * x[i]
    return out


# ============================================================================================
# argument checks
# ============================================================================================

def _finite_number(name, v, *, positive=False, nonneg=False):
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v!r}")
    if positive and not v > 0:
        raise ValueError(f"{name} must be > 0, got {v!r}")
    if nonneg and not v >= 0:
        raise ValueError(f"{name} must be >= 0, got {v!r}")
    return v


def _int_arg(name, v, minimum=0):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {v!r}")
    if v < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {v!r}")
    return int(v)


def _check_sensors(s: SensorSpec) -> None:
    if not isinstance(s, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {type(s).__name__}")
    fs = _finite_number("sensors.sample_rate_hz", s.sample_rate_hz, positive=True)
    if fs > 20000.0:
        raise ValueError(f"sensors.sample_rate_hz must be <= 20000, got {fs!r}")
    for name in ("encoder_res_deg", "qd_window_s", "ud_window_s", "temp_tau_s"):
        _finite_number(f"sensors.{name}", getattr(s, name), positive=True)
    for name in ("torque_noise", "torque_lag_s", "torque_adc_step", "load_noise", "load_lag_s",
                 "load_adc_step", "temp_res", "temp_noise", "current_noise", "current_res"):
        _finite_number(f"sensors.{name}", getattr(s, name), nonneg=True)
    if s.torque_lag_s > 1.0 or s.load_lag_s > 1.0:
        raise ValueError("sensors.torque_lag_s / sensors.load_lag_s must be <= 1 s")
    _int_arg("sensors.motor_encoder_bits", s.motor_encoder_bits, minimum=8)


def _check_effects(effects) -> dict[str, tuple[str, float]]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict or None, got {type(effects).__name__}")
    out = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effects[{name!r}] must be a dict with 'form' and 'scale'")
        unknown = set(spec) - {"form", "scale"}
        if unknown:
            raise ValueError(f"effects[{name!r}]: unknown keys {sorted(unknown)}")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}]: unknown form {form!r} of {name!r}; "
                             f"known: {EFFECT_FORMS[name]}")
        scale = _finite_number(f"effects[{name!r}]['scale']", spec.get("scale", 1.0))
        scale = min(max(scale, 0.0), SCALE_MAX)
        out[name] = (form, scale)
    return out


# ============================================================================================
# the rig (parameters from the seed) and the programme of each scheme
# ============================================================================================

FOURIER_A = np.array([0.55, -0.25, 0.20, -0.30, -0.20])
FOURIER_B = np.array([0.45, 0.30, -0.35, 0.10, -0.08])
FOURIER_PERIOD = 12.0


def _draw_rig(seed: int) -> dict:
    rng = np.random.default_rng([seed, 0x4D4D])
    params = {}
    for k, v in DATASHEET.items():
        params[k] = v * (1.0 + PARAM_SPREAD * float(np.clip(rng.standard_normal(), -2.5, 2.5)))
    params["k_t_motors"] = [DATASHEET["k_t"] * (1.0 + 0.015 * float(np.clip(rng.standard_normal(),
                                                                             -2.5, 2.5)))
                            for _ in range(3)]
    # hidden/per-rig quantities (always drawn in the same order)
    params["encoder_phase"] = float(rng.uniform())
    params["motor_encoder_phase"] = float(rng.uniform())
    params["eccentricity_rad"] = 4.0 / 3600.0 * math.pi / 180.0
    params["eccentricity_phase"] = float(rng.uniform(0, 2 * math.pi))
    params["bending_moment"] = 80.0e3 * (1.0 + 0.05 * float(rng.standard_normal()))
    params["crosstalk"] = 7.0e-4 * float(rng.choice([-1.0, 1.0]))
    params["phases"] = [float(x) for x in rng.uniform(0, 2 * math.pi, size=8)]
    params["bump_center"] = float(rng.uniform(-0.3, 0.3))
    params["hold_phase"] = float(rng.uniform())
    return params


def _effect_vector(eff: dict[str, tuple[str, float]], rig: dict) -> np.ndarray:
    E = np.zeros(NE)
    ph = rig["phases"]
    E[E_STRIB_VS] = 8.0e-3
    E[E_RIP_Z] = 84.0
    E[E_RIP_P1], E[E_RIP_P2], E[E_RIP_P3] = ph[0], ph[1], ph[2]
    E[E_PD_P1], E[E_PD_P2], E[E_PD_P3] = ph[3], ph[4], ph[5]
    E[E_PS_P] = ph[6]
    E[E_PS_QC] = rig["bump_center"]
    E[E_HYS_TAU] = 2.0
    for name, (form, s) in eff.items():
        if s <= 0.0:
            continue
        code = float(EFFECT_FORMS[name].index(form) + 1)
        if name == "stribeck":
            E[E_STRIB_F] = code
            E[E_STRIB_A] = s * 450.0
        elif name == "load_dependent_friction":
            E[E_LOAD_F], E[E_LOAD_C] = code, s
        elif name == "temperature_friction":
            E[E_TEMP_F], E[E_TEMP_C] = code, s
        elif name == "gear_ripple":
            E[E_RIP_F] = code
            E[E_RIP_A] = s * (3.0e-5 if form == "motor_side" else 450.0)
        elif name == "hysteresis":
            x0 = 4.0e-4
            E[E_HYS_F] = code
            E[E_HYS_C] = s * 0.4 * rig["k0"]
            if form == "bouc_wen_n1":
                E[E_HYS_B], E[E_HYS_G] = 0.6 / x0, 0.4 / x0
            elif form == "bouc_wen_n2":
                E[E_HYS_B], E[E_HYS_G] = 0.6 / x0 ** 2, 0.4 / x0 ** 2
            elif form == "dahl":
                E[E_HYS_B], E[E_HYS_G] = 1.0 / x0, 0.0
            else:
                E[E_HYS_C] = s * 0.15 * rig["k0"]
        elif name == "backlash":
            E[E_BACK_F], E[E_BACK_B] = code, s * 1.5e-4
        elif name == "asymmetric_friction":
            E[E_ASYM_F], E[E_ASYM_C] = code, s
        elif name == "periodic_disturbance":
            E[E_PD_F], E[E_PD_A] = code, s * 500.0
        elif name == "position_dependent_stiffness":
            E[E_PS_F] = code
            E[E_PS_C] = s * {"once_per_rev": 0.12, "twice_per_rev": 0.12, "linear": 0.15,
                             "local_bump": 0.25}[form]
        elif name == "second_resonance":
            E[E_R2_F] = code
            if form == "output_high":
                E[E_R2_I], E[E_R2_W], E[E_R2_Z] = s * 0.25 * rig["I"], 2 * math.pi * 9.5, 0.02
            elif form == "output_low":
                E[E_R2_I], E[E_R2_W], E[E_R2_Z] = s * 0.25 * rig["I"], 2 * math.pi * 2.7, 0.03
            else:
                E[E_R2_I], E[E_R2_W], E[E_R2_Z] = s * 0.25 * rig["I"], 2 * math.pi * 4.2, 0.02
    return E


def _programme(scheme: int, motor_speed_rpm, direction: int, periods: int):
    """Piecewise programme: duration, functions of time for the speed reference, the position
    reference (scheme 3), the dynamometer set point and the phase labels."""
    if scheme in (1, 2):
        w = direction * motor_speed_rpm * 2.0 * math.pi / 60.0 / REDUCTION
        if scheme == 1:
            t_idle, t_ramp = 3.0, 25.0
            duration = t_idle + 2 * t_ramp + 2.0

            def load(t):
                return RATED_TORQUE * np.clip(np.minimum((t - t_idle) / t_ramp,
                                                         (t_idle + 2 * t_ramp - t) / t_ramp), 0, 1)

            def phase(t):
                p = np.full(t.shape, "idle", dtype=object)
                p[(t >= t_idle) & (t < t_idle + t_ramp)] = "load"
                p[(t >= t_idle + t_ramp) & (t < t_idle + 2 * t_ramp)] = "unload"
                return p
        else:
            t_idle, t_step, t_hold, n_steps, t_unl = 3.0, 0.5, 2.0, 12, 5.0
            t_top = t_idle + n_steps * (t_step + t_hold)
            duration = t_top + t_unl + 2.0

            def load(t):
                tt = np.clip(t - t_idle, 0.0, None)
                k = np.minimum(np.floor(tt / (t_step + t_hold)), n_steps - 1)
                r = tt - k * (t_step + t_hold)
                level = 10.0e3 * (k + np.clip(r / t_step, 0, 1))
                level = np.where(t < t_idle, 0.0, level)
                down = RATED_TORQUE * np.clip(1.0 - (t - t_top) / t_unl, 0, 1)
                return np.where(t >= t_top, down, level)

            def phase(t):
                p = np.full(t.shape, "idle", dtype=object)
                tt = t - t_idle
                inside = (t >= t_idle) & (t < t_top)
                r = np.mod(np.clip(tt, 0, None), t_step + t_hold)
                p[inside & (r < t_step)] = "load"
                p[inside & (r >= t_step)] = "hold"
                p[(t >= t_top) & (t < t_top + t_unl)] = "unload"
                return p

        def vref(t):
            return w * np.clip(t / 1.0, 0.0, 1.0)

        def uref(t):
            return np.zeros_like(t)

        def tl_set(t):
            return direction * load(t) + 0.0   # no negative zeros

        return duration, vref, uref, tl_set, phase, False

    # scheme 3: fifth-order Fourier trajectory (Eq. 12)
    wf = 2.0 * math.pi / FOURIER_PERIOD
    ls = np.arange(1, 6)
    tt = np.linspace(0, FOURIER_PERIOD, 4001)
    qd_shape = (FOURIER_A[:, None] * np.cos(wf * ls[:, None] * tt)
                + FOURIER_B[:, None] * np.sin(wf * ls[:, None] * tt)).sum(0)
    gain = 0.9 * V_TOP / np.abs(qd_shape).max()
    a = FOURIER_A * gain * direction
    b = FOURIER_B * gain * direction
    q0 = float(np.sum(b / (wf * ls)))
    t0 = 1.0
    t_end = t0 + periods * FOURIER_PERIOD
    duration = t_end + 1.0

    def active(t):
        return (t >= t0) & (t <= t_end)

    def vref(t):
        s = np.clip(t, t0, t_end) - t0
        v = (a[:, None] * np.cos(wf * ls[:, None] * s)
             + b[:, None] * np.sin(wf * ls[:, None] * s)).sum(0)
        return np.where(active(t), v, 0.0)

    def uref(t):
        s = np.clip(t, t0, t_end) - t0
        return (a[:, None] / (wf * ls[:, None]) * np.sin(wf * ls[:, None] * s)
                - b[:, None] / (wf * ls[:, None]) * np.cos(wf * ls[:, None] * s)).sum(0) + q0

    def tl_set(t):
        return 60.0e3 * vref(t) / V_TOP

    def phase(t):
        p = np.full(t.shape, "idle", dtype=object)
        p[(t >= t0) & (t < t_end)] = "excite"
        return p

    return duration, vref, uref, tl_set, phase, True


def _quantise_floor(x, step, phase):
    return step * np.floor(x / step + phase)


def _quantise_round(x, step):
    if step <= 0:
        return x
    return step * np.round(x / step)


# ============================================================================================
# public entry point
# ============================================================================================

def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None, *, sensors: SensorSpec = SensorSpec(),
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """Simulate one run of rig M (see the module docstring)."""
    # ---- arguments ----
    if isinstance(scheme, bool) or not isinstance(scheme, (int, np.integer)) \
            or scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if isinstance(direction, bool) \
            or not isinstance(direction, (int, float, np.integer, np.floating)) \
            or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    direction = int(direction)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
    else:
        motor_speed_rpm = _finite_number("motor_speed_rpm", motor_speed_rpm, positive=True)
        if motor_speed_rpm > 3500.0:
            raise ValueError(f"motor_speed_rpm must be <= 3500 r/min, got {motor_speed_rpm!r}")
    temp_joint_c = _finite_number("temp_joint_c", temp_joint_c)
    if not -30.0 <= temp_joint_c <= 120.0:
        raise ValueError(f"temp_joint_c must be within -30..120 degC, got {temp_joint_c!r}")
    periods = _int_arg("periods", periods, minimum=1)
    if periods > 50:
        raise ValueError(f"periods must be <= 50, got {periods!r}")
    seed = _int_arg("seed", seed)
    run = _int_arg("run", run)
    _check_sensors(sensors)
    eff = _check_effects(effects)
    active = {k: v for k, v in eff.items() if v[1] > 0.0}

    # ---- rig ----
    rig = _draw_rig(seed)
    N = REDUCTION
    rig["J_u"] = 3.0 * rig["J_m"] * N * N
    P = np.zeros(NP)
    P[P_I], P[P_MRX], P[P_MRY] = rig["I"], rig["mr_x"], rig["mr_y"]
    P[P_FV], P[P_FC] = rig["f_v"], rig["f_c"]
    P[P_K0], P[P_K2], P[P_D] = rig["k0"], rig["k2"], rig["D"]
    P[P_JU] = rig["J_u"]
    P[P_FMC] = 3.0 * rig["F_mc"] * N
    P[P_FMV] = 3.0 * rig["F_mv"] * N * N
    P[P_SIG0] = rig["f_c"] / rig["z_ss"]
    P[P_TAUI], P[P_TAUD] = rig["tau_i"], rig["tau_dyn"]
    P[P_CTH], P[P_RTH], P[P_THAMB] = rig["C_th"], rig["R_th"], temp_joint_c
    P[P_N] = N
    P[P_EPSM] = 1.0e-3 / N * 10.0     # motor-side friction smoothing (0.01 rad/s at the motor)
    E = _effect_vector(active, rig)

    # ---- time grids ----
    fs = float(sensors.sample_rate_hz)
    duration, f_vref, f_uref, f_tlset, f_phase, pos_loop = _programme(
        scheme, motor_speed_rpm, direction, periods)
    n = int(math.floor(duration * fs + 1e-9)) + 1
    m = max(1, int(math.ceil((1.0 / fs) / DT_MAX - 1e-9)))
    dt = 1.0 / (fs * m)
    nf = (n - 1) * m + 1
    tf = np.arange(nf) * dt
    ts = np.arange(n) / fs

    # ---- noise (from seed and run only; never from the effects) ----
    nrng = np.random.default_rng([seed, run, 0x6E6F])
    dyn_grid = 0.01
    nd = int(math.ceil(duration / dyn_grid)) + 2
    ou = np.empty(nd)
    a_ou = math.exp(-dyn_grid / 1.5)
    w = nrng.standard_normal(nd)
    ou[0] = 300.0 * w[0]
    for i in range(1, nd):
        ou[i] = a_ou * ou[i - 1] + 300.0 * math.sqrt(1 - a_ou * a_ou) * w[i]
    # smoothed by the dynamometer's own speed loop (second pole, 0.4 s)
    a_sm = math.exp(-dyn_grid / 0.4)
    sm = np.empty(nd)
    sm[0] = ou[0]
    for i in range(1, nd):
        sm[i] = a_sm * sm[i - 1] + (1.0 - a_sm) * ou[i]
    ou = np.clip(sm, -1800.0, 1800.0)
    e_dyn = np.interp(tf, np.arange(nd) * dyn_grid, ou)
    z_torque = nrng.standard_normal(n)
    z_load = nrng.standard_normal(n)
    z_temp = nrng.standard_normal(n)
    z_cur = nrng.standard_normal((3, n))

    # ---- programme on the fine grid ----
    vref = f_vref(tf)
    uref = f_uref(tf)
    tl_cmd = f_tlset(tf)
    tl_set = tl_cmd + e_dyn

    # ---- initial state: at rest, twist balancing gravity ----
    y0 = np.zeros(NS)
    grav0 = G0 * rig["mr_y"]
    d0 = _static_twist(0.0, 0.0, 0.0, grav0, P, E)
    y0[2] = d0
    y0[9] = temp_joint_c
    if pos_loop:
        # the position loop holds the motor where it is at the start
        uref = uref + d0 - uref[0]
    T0, _ = _transmission(0.0, d0, 0.0, 0.0, 0.0, 0.0, 0.0, P, E)
    kp = rig["J_u"] * 60.0          # speed loop: ~60 rad/s on the motor-side inertia
    ti = 0.05
    tmax = 3.0 * MOTOR_TORQUE_MAX * N
    y0[7] = T0                      # the drive holds the motor against the gravity twist
    ctrl = np.array([kp, ti, 20.0, tmax, T0 * ti / kp])

    rec = _simulate(nf, dt, P, E, y0, vref, uref, pos_loop, tl_set, ctrl)
    (c_q, c_qd, c_qdd, c_u, c_ud, c_T, c_tl, c_th, c_F, c_G, c_O, c_tm) = range(12)
    idx = np.arange(n) * m

    # ---- sensors ----
    s = sensors
    step_q = math.radians(s.encoder_res_deg)
    ecc_a, ecc_p = rig["eccentricity_rad"], rig["eccentricity_phase"]
    drift = active.get("sensor_drift")
    creep = 4.0e-6 * drift[1] if (drift and drift[0] == "encoder_creep") else 0.0

    def q_reading(tq):
        qt = np.interp(tq, tf, rec[:, c_q])
        x = qt + ecc_a * (np.sin(qt + ecc_p) - math.sin(ecc_p))
        if creep:
            x = x + creep * np.clip(tq, 0, None)
        return _quantise_floor(x, step_q, rig["encoder_phase"])

    q_meas = q_reading(ts)
    q_back = q_reading(np.clip(ts - s.qd_window_s, 0.0, None))
    qd_meas = (q_meas - q_back) / s.qd_window_s

    step_m = 2.0 * math.pi / (2 ** s.motor_encoder_bits)

    def u_reading(tq):
        ut = np.interp(tq, tf, rec[:, c_u])
        return _quantise_floor(ut * N, step_m, rig["motor_encoder_phase"]) / N

    u_meas = u_reading(ts)
    ud_meas = (u_meas - u_reading(np.clip(ts - s.ud_window_s, 0.0, None))) / s.ud_window_s

    # torque transducer
    T_f = rec[:, c_T]
    td = active.get("time_delay")
    extra_lag = 0.0
    if td is not None:
        form, sc = td
        if form == "pure":
            extra_lag = 0.010 * sc
        elif form == "first_order":
            T_f = _first_order(T_f, dt, 0.010 * sc)
    t_read = ts - s.torque_lag_s - extra_lag
    if td is not None and td[0] == "hold":
        h = 0.020 * td[1]
        clk = np.clip(t_read, 0, None) * 1.0037 + rig["hold_phase"] * h
        t_read = (np.floor(clk / h) * h - rig["hold_phase"] * h) / 1.0037
        t_read = np.clip(t_read, 0, None)
    T_read = np.interp(t_read, tf, T_f)
    T_read = T_read + rig["crosstalk"] * rig["bending_moment"]
    th_true = rec[idx, c_th]
    to = active.get("torque_offset")
    if to is not None:
        form, sc = to
        if form == "constant":
            T_read = T_read + sc * 600.0
        elif form == "linear_drift":
            T_read = T_read + sc * 600.0 * ts / 60.0
        elif form == "warmup":
            T_read = T_read + sc * 600.0 * (1.0 - np.exp(-ts / 20.0))
        else:
            T_read = T_read + sc * 40.0 * (th_true - 25.0)
    n_torque = s.torque_noise * z_torque
    torque_meas = _quantise_round(T_read + n_torque, s.torque_adc_step)

    # load cell
    tl_read = np.interp(ts - s.load_lag_s, tf, rec[:, c_tl])
    if drift and drift[0] == "load_cell_offset":
        tl_read = tl_read + 12.0 * drift[1] * ts
    elif drift and drift[0] == "load_cell_gain":
        tl_read = tl_read * (1.0 + 1.2e-4 * drift[1] * ts)
    n_load = s.load_noise * z_load
    load_meas = _quantise_round(tl_read + n_load, s.load_adc_step)

    # temperature
    th_f = _first_order(rec[:, c_th], dt, s.temp_tau_s)
    n_temp = s.temp_noise * z_temp
    temp_meas = _quantise_round(th_f[idx] + n_temp, s.temp_res)

    # motor currents: one current set point for the three drives
    kt = rig["k_t_motors"]
    i_true = rec[idx, c_tm] / (N * sum(kt))
    n_cur = s.current_noise * z_cur
    cur = [_quantise_round(i_true + n_cur[k], s.current_res) for k in range(3)]

    samples = pd.DataFrame({
        "t": ts, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": ud_meas,
        "torque": torque_meas, "torque_load": load_meas, "temp_joint": temp_meas,
        "i_m1": cur[0], "i_m2": cur[1], "i_m3": cur[2],
        "torque_cmd": tl_cmd[idx],
        "phase": pd.Series(f_phase(ts), dtype=object),
    })
    truth = pd.DataFrame({
        "t": ts, "q": rec[idx, c_q], "qd": rec[idx, c_qd], "qdd": rec[idx, c_qdd],
        "u": rec[idx, c_u], "ud": rec[idx, c_ud], "twist": rec[idx, c_u] - rec[idx, c_q],
        "torque": rec[idx, c_T], "torque_load": rec[idx, c_tl], "gravity": rec[idx, c_G],
        "friction": rec[idx, c_F], "other_torque": rec[idx, c_O], "temp_joint": th_true,
        "motor_torque": rec[idx, c_tm], "dyn_error": e_dyn[idx],
    })
    noise = pd.DataFrame({
        "t": ts, "torque": n_torque, "torque_load": n_load, "temp_joint": n_temp,
        "i_m1": n_cur[0], "i_m2": n_cur[1], "i_m3": n_cur[2], "dyn_error": e_dyn[idx],
    })

    sensors_meta = {
        "q": {"resolution": step_q, "noise_sd": 0.0, "lag_s": 0.0},
        "qd": {"resolution": step_q / s.qd_window_s, "noise_sd": 0.0, "lag_s": s.qd_window_s / 2},
        "u": {"resolution": step_m / N, "noise_sd": 0.0, "lag_s": 0.0},
        "ud": {"resolution": step_m / N / s.ud_window_s, "noise_sd": 0.0,
               "lag_s": s.ud_window_s / 2},
        "torque": {"resolution": float(s.torque_adc_step), "noise_sd": float(s.torque_noise),
                   "lag_s": float(s.torque_lag_s)},
        "torque_load": {"resolution": float(s.load_adc_step), "noise_sd": float(s.load_noise),
                        "lag_s": float(s.load_lag_s)},
        "temp_joint": {"resolution": float(s.temp_res), "noise_sd": float(s.temp_noise),
                       "lag_s": float(s.temp_tau_s)},
    }
    for k in range(3):
        sensors_meta[f"i_m{k + 1}"] = {"resolution": float(s.current_res),
                                        "noise_sd": float(s.current_noise), "lag_s": 0.0}
    meta = {
        "scheme": scheme,
        "reduction": REDUCTION,
        "sample_rate_hz": fs,
        "temp_joint_c": temp_joint_c,
        "direction": direction,
        "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
        "source": "emulator",
        "rig": RIG_NAME,
        "sensors": sensors_meta,
        "sensor_units": {"q": "rad", "qd": "rad/s", "u": "rad", "ud": "rad/s", "torque": "N*m",
                         "torque_load": "N*m", "temp_joint": "degC", "i_m1": "A", "i_m2": "A",
                         "i_m3": "A"},
        "notes": f"rig_m emulation, scheme {scheme}, encoder step {s.encoder_res_deg} deg",
    }
    if scheme == 3:
        meta["periods"] = periods

    params = {
        **{k: rig[k] for k in DATASHEET},      # the drawn physical values, flat
        "J_u": rig["J_u"],
        "datasheet": dict(DATASHEET),
        "rig": {k: (list(v) if isinstance(v, list) else v) for k, v in rig.items()},
        "sigma0": float(P[P_SIG0]),
        "effects": {k: {"form": f, "scale": sc} for k, (f, sc) in eff.items()},
        "effect_vector": E.copy(),
        "integration_step_s": dt,
        "controller": {"kp": kp, "ti": ti, "kv": 20.0, "tau_max": tmax},
        "imperfections": {
            "encoder_eccentricity_rad": rig["eccentricity_rad"],
            "encoder_eccentricity_phase": rig["eccentricity_phase"],
            "torque_crosstalk_offset": rig["crosstalk"] * rig["bending_moment"],
        },
        "duration_s": duration,
    }
    return RigRun(samples=samples, meta=meta, truth=truth, params=params, noise=noise)
