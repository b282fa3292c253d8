"""Rig K - an independent validation model of the CMOR J4 joint test platform.

DATA SHEET (everything the rig does is stated here; every sensor property is also
written into ``meta["sensors"]`` of each run).

Written from rig.md and the source paper only; it shares no code with ``simulators/``.
Figures in [brackets] are the data-sheet values; each campaign seed draws its own
physical rig around them (the same rig for all runs of a campaign).

1. Structure (all angles and torques referred to the joint output, SI units)
---------------------------------------------------------------------------
Three servo motors on one shaft -> compliant reduction N = 11 000 -> output body
(the J4 link with an offset mass) -> torsion coupling -> dynamometer (schemes 1, 2).

* Motor side: reflected inertia J_r = J_m*N^2 [6.0e-3 kg m^2 at the motor shaft
  (3 rotors + first reducer stage) -> 7.26e5 kg m^2, +-3 %].  Motor-side friction
  (bearings, seals, first stages) referred to the output:
  F_m = Fc_m*tanh(w/2e-4) + fv_m*w, [Fc_m = 0.10 N m at the motor -> 1100 N m;
  fv_m = 1.5e-4 N m s/rad at the motor -> 18 150 N m s/rad], +-5 %.  It sits between
  the motors and the torque transducer, so it shows in the currents only.
  J_r*du'' = tau_m - T - F_m.  The three drives get the same torque set point;
  each motor current is i_k = tau_m/(3*N*kt_k), kt_k = [1.45 N m/A] +-2 % per motor.
* Drive control (S120, modelled in continuous time, current loop ideal):
  speed PI on the motor speed, crossover 40 rad/s (Kp = 40*J_r, Ki = 10*Kp),
  output torque limited to 3*9 N m*N = 297 kN m.  Schemes 1-2: cosine speed ramp
  from 0.5 s to 2.0 s up to direction*rpm, with acceleration feed-forward J_r*w_ref'.
  Scheme 3: position loop on the motor encoder (Kpos = 6 1/s, P) with speed and
  acceleration feed-forward of the Fourier trajectory, feeding the same speed PI.
* Transmission (planetary train, nominally elastic: no backlash, no hysteresis):
  T = k0*D + k3*D^3 + c_t*D',  D = u - q (twist), a stiffening gear-train curve
  [k0 = 1.2e7 N m/rad +-5 %, k3 = 0.15*k0/(8.5e-3)^2 (tangent stiffness +45 % at
  rated twist), c_t = 3.0e4 N m s/rad]; about 0.5 deg of twist at 120 kN m.
  T (positive = driving the output positively) is what the joint torque
  transducer measures.
* Output body (Eq. 4 with the load):
  I*q'' = T - tau_L - g*(mr_x*sin q + mr_y*cos q) - F
  [I = 6700 kg m^2 +-3 %, mr_x = 21.0 kg m, mr_y = -34.0 kg m (+-5 %), g = 9.81].
  On the nominal truth this balance holds to rounding (the truth frame carries
  qdd, torque, torque_load, gravity and friction).
* Output-bearing friction F: an ELASTO-PLASTIC presliding model (Dupont et al. 2002):
  z' = v*(1 - alpha(z,v)*|z|/z_ss(v)),  z_ss = g(v)/sigma0,
  F = sigma0*z + sigma1*exp(-(v/v_d)^2)*z' + f_v*v,
  alpha = 0 while |z| <= 0.7*z_ss or sign(z) != sign(v) (pure elastic stiction, no
  drift at rest), a sine blend to 1 at |z| = z_ss.  Nominally g(v) = Fc (no Stribeck
  dip).  [Fc = 2300 N m +-4 %, f_v = 8800 N m s/rad +-4 %, presliding distance at
  Fc z_ss = 6e-5 rad (+-10 %), sigma1 = 3e5 N m s/rad, v_d = 2e-3 rad/s].  In steady
  sliding F = Fc*sgn(v) + f_v*v; at starts and reversals the joint sticks while
  the transmission winds up (some tens of ms at scheme-3 reversals).
* Dynamometer (schemes 1, 2; declutched in scheme 3 where tau_L = 0 exactly):
  inertia J_d = [900 kg m^2 +-5 %] on a torsion coupling k_c = 3.0e7 N m/rad,
  c_c = 3.0e4 N m s/rad; its load cell measures the coupling torque
  tau_L = k_c*(q - q_d) + c_c*(q' - q_d') (positive = resisting positive motion).
  Its servo produces tau_dm following the PLC set point torque_cmd through a
  first-order lag of 40 ms (open-loop torque control); its reducer friction
  [450 N m Coulomb (tanh, 1e-3 rad/s), 2000 N m s/rad] adds to the load, so tau_L differs from
  torque_cmd by about +-0.5 kN m (inside Table 11's +-2 kN m).  The set point is
  always direction*profile: the load resists the motion.
* Gearbox temperature: C*theta' = |F*v| + |F_m*w| - (theta - theta_amb)/R,
  C = 2.5e4 J/K, R = 0.05 K/W, theta(0) = theta_amb = temp_joint_c; a rated
  3000 r/min scheme-1 run warms it by roughly 0.3-0.5 K.
* Integrator: classic fixed-step RK4 (numba, cached), step h = 1/(fs*n_sub) with
  n_sub = ceil(1/(fs*1 ms)), i.e. h <= 1 ms (h = 1 ms at 10/250/1000 Hz).  The
  fastest mode (dynamometer coupling, ~31 Hz) has omega*h <= 0.2; the frictional
  relaxation rate |v|/z_ss <= 500 1/s gives lambda*h <= 0.5.  Samples are exact
  integrator nodes at t = k/fs; sensor filters and delays run on the h grid.
  Checked: h = 1 ms vs 0.25 ms differ by < 1e-3 N m in T and tau_L, < 1e-11 rad in q.
* The run starts in static equilibrium: q = 0, the twist carries gravity, z = 0.

2. Schemes (profiles of this rig)
---------------------------------
* Scheme 1 (97 s): idle 0-3 s (speed ramp 0.5-2 s), load 3-48 s (0 -> 120 kN m
  linear), hold 48-50 s, unload 50-95 s, idle 95-97 s.  3000 r/min travels ~159 deg.
* Scheme 2 (45 s): idle 0-3 s, then 12 steps: 0.5 s "load" ramp of +10 kN m and a
  2 s "hold"; unload 33-43 s (ramp to 0); idle 43-45 s.
* Scheme 3 (2 + 24*periods s): idle 1 s, "excite": fifth-order Fourier trajectory
  (Eq. 12) of period 24 s, q(0) = q'(0) = q''(0) = 0, peak speed 0.85*0.02856 rad/s
  (0.85 of the 3000 r/min limit), coefficients the lowest condition number of the
  Eq. 4 regressor [q'', g sin q, g cos q, q', sgn q'] among 64 random draws of the
  campaign seed; times direction; idle 1 s.  Dynamometer declutched.
  motor_speed_rpm is None and the PLC set point torque_cmd is 0.

3. Sensor chain and its quirks (all in meta["sensors"]; units in meta["sensor_units"])
--------------------------------------------------------------------------------------
* q: output absolute encoder, rounded to encoder_res_deg (in rad: resolution).
* u: motor encoder 2^22 counts/rev, divided by N: resolution 2*pi/2^22/N rad.
* QUIRK 1 - filtered velocities: qd is the encoder head's speed word (computed from
  its fine internal interpolation, not from the coarse position word) through a
  first-order 10 ms filter, + white noise 2e-5 rad/s, LSB 1e-6 rad/s; ud is the S120
  "speed actual" smoothed by a 4 ms first-order filter, noise 2e-6 rad/s, LSB 1e-7.
  Their lag_s is the filter time constant.
* QUIRK 2 - torque channel: the transducer's value reaches the DAQ with a pure
  transport delay torque_lag_s (fieldbus; stated as lag_s and really applied),
  white noise torque_noise, then a 16-bit ADC over +-250 kN m (LSB 7.63 N m =
  resolution).  torque_load: load-cell amplifier first-order low-pass 3 ms (lag_s),
  noise 60 N m, 20-bit ADC over +-250 kN m (LSB 0.477 N m).
* QUIRK 3 - temp_joint: PT100 in the housing, first-order 15 s time constant (lag_s),
  noise 0.02 degC, 0.1 degC steps.
* i_m1..i_m3: motor currents, noise 0.02 A, 1 mA steps.  torque_cmd: the PLC set
  point (exact).  phase: idle / load / hold / unload / excite.
Noise of every channel is drawn from (seed, run) streams before any effect is
looked at; the same run with and without an effect has the same noise draws.

4. Effects  (effects = {name: {"form": str, "scale": float}})
------------------------------------------------------------
scale 0 or absent = the nominal rig bit for bit; every size below is proportional
to s = min(scale, 3) (SCALE_MAX = 3: larger scales are clamped to 3, negative or
non-finite scales are refused) and carries a +-8 % (2 sigma clip 16 %) spread drawn
from the campaign seed; phases of periodic terms are drawn from the seed too.
Sizes quoted at scale 1.
* stribeck (output bearing; g(v) = Fc*(1 + 0.6*s*phi(|v|/vs)), vs = 1.5e-3 rad/s,
  5 % of top speed, i.e. Fs/Fc = 1.6): gaussian phi = exp(-x^2) (default);
  exponential exp(-x); lorentzian 1/(1+x^2); sqrt_exponential exp(-sqrt x).
  Through z_ss it also raises the break-away torque.
* load_dependent_friction (output bearing, |T| = magnitude of the elastic
  transmitted torque): coulomb Fc += 0.015*s*|T| (+1.8 kN m at 120 kN m);
  coulomb_viscous Fc and f_v times (1 + 0.8*s*|T|/120 kN m);
  power_flow Fc += mu*|T|, mu = 0.02*s driving (T*v > 0), 0.006*s back-driven,
  blended by tanh(T*v / 20 W).
* temperature_friction (theta = the gearbox temperature state, theta_ref = 25 degC:
  at 25 degC only the in-run warming acts): viscous_exponential
  f_v*exp(-0.05*s*(theta-25)) (-53 % at 40 degC); coulomb_viscous_exponential the
  same on f_v and Fc*exp(-0.012*s*(theta-25)); additive Fc += 35*s*(25-theta) N m/K
  and f_v += 150*s*(25-theta) N m s/rad/K; vogel_viscous
  f_v*exp(800*s*(1/(theta+95) - 1/120)).  Fc, f_v never below 20 % of nominal.
* gear_ripple (in the transmission law, so at slow speed it shows mostly as a twist
  ripple against q at a fixed torque): output_harmonics torque
  (1500 N m + 0.01*|T|)*(sin(96q+p1) + 0.35 sin(192q+p2) + 0.15 sin(288q+p3));
  intermediate_shaft torque 1500 N m*(sin(240u+p1) + 0.4 sin(480u+p2)) (a shaft
  turning 240x the output); kinematic_error: the teeth see the twist D - e(q),
  e = 2.5e-4 rad*(sin(48q+p1) + 0.3 sin(96q+p2)) (about 3 kN m through k0).
* torque_offset (torque channel only): constant +1500 N m; drift +20 N m/s * t;
  settling 2000 N m*(1 - exp(-t/25 s)).
* time_delay (torque channel, on top of the stated lag, NOT stated in meta):
  pure_delay 25 ms; first_order lag tau = 25 ms.
* hysteresis (transmission, a hysteretic torque in parallel with the spring):
  T_el -> T_el + h*k0*x, h = 0.25*s, x_sat = 1e-3 rad, so the loop is about
  2*h*k0*x_sat = 6 kN m wide (5e-4 rad = 1.7 arcmin of lost motion) and the
  small-amplitude stiffness is (1+h)*k0:  bouc_wen_n1 x' = D' - beta|D'|x -
  gamma D'|x|, beta = gamma = 1/(2 x_sat); bouc_wen_n2 the same with n = 2,
  beta = gamma = 1/(2 x_sat^2); dahl x' = D'*r|r|, r = 1 - x*sgn(D')/x_sat (Dahl
  exponent 2); play_operator x = mean of 4 stop operators (D - play_r(D)) of
  half-widths r = (0.2, 0.5, 1.0, 1.6)*x_sat (Prandtl-Ishlinskii / Iwan, rate
  independent; width about 5 kN m).
* backlash (transmission, acting on the twist): dead_zone half-width
  b = 4e-4 rad*s (total play 2b = 2.75 arcmin), damping only in contact;
  smoothed: softplus dead zone with rounding eps = 0.5 b.
* asymmetric_friction: coulomb Fc*(1 + 0.15*s*sgn v); viscous f_v*(1 + 0.4*s*sgn v);
  coulomb_viscous both (each factor clamped to +-0.8).
Out of the vocabulary (OUT_OF_VOCABULARY):
* periodic_disturbance (unmeasured torque on the output body): sinusoid
  1200 N m at 0.85 Hz; pump_pulsation 1500 N m*(|sin(pi*2.3 Hz*t)| - 2/pi).
* position_dependent_stiffness (elastic law times a factor of the output angle):
  cosine 1 + 0.12*s*cos(q + p); soft_spot 1 - 0.25*s*exp(-((q-0.05)/0.3)^2).
* sensor_drift: load_cell_zero torque_load += 15 N m/s * t; encoder_drift
  q_read += 3e-6 rad/s * t; encoder_scale q_read = q*(1 + 3e-4*s).
* second_resonance: split_output - a fraction eps = 0.3*s (<= 0.8) of I (the
  loading flange) hangs on a 7.5 Hz, zeta 0.02 spring; the dynamometer acts on it,
  gravity is shared; appended_mass - an extra inertia 0.2*s*I on a 2.6 Hz,
  zeta 0.02 spring on the output body.  Both ring after starts, reversals, steps.

5. Interface
------------
simulate_run(scheme, motor_speed_rpm, direction, temp_joint_c, effects, *,
sensors=SensorSpec(...), periods=3, seed, run) -> RigRun(samples, meta, truth,
params, noise).  SEED_IS_CAMPAIGN: the physical rig and the Fourier coefficients come
from ``seed`` only; the noise from (seed, run).  Bad arguments raise ValueError
naming the culprit.
Measured speed (2-core shared machine, one core via taskset, numba cache warm): a
12-run campaign (4 x scheme 1, 4 x scheme 2, 4 x scheme 3 of 3 periods) takes about
1.6 s at 250 Hz and 2.0 s at 1 kHz; a cold numba compile adds about 5 s once.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numba import njit
from scipy.signal import lfilter, lfilter_zi

__all__ = ["SEED_IS_CAMPAIGN", "REDUCTION", "EFFECT_FORMS", "OUT_OF_VOCABULARY",
           "SCALE_MAX", "SensorSpec", "RigRun", "simulate_run"]

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "rig_k"
SCALE_MAX = 3.0
T_RATED = 120_000.0
G = 9.81
DT_MAX = 1e-3

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("gaussian", "exponential", "lorentzian", "sqrt_exponential"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow"),
    "temperature_friction": ("viscous_exponential", "coulomb_viscous_exponential",
                             "additive", "vogel_viscous"),
    "gear_ripple": ("output_harmonics", "intermediate_shaft", "kinematic_error"),
    "torque_offset": ("constant", "drift", "settling"),
    "time_delay": ("pure_delay", "first_order"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl", "play_operator"),
    "backlash": ("dead_zone", "smoothed"),
    "asymmetric_friction": ("coulomb", "viscous", "coulomb_viscous"),
    "periodic_disturbance": ("sinusoid", "pump_pulsation"),
    "position_dependent_stiffness": ("cosine", "soft_spot"),
    "sensor_drift": ("load_cell_zero", "encoder_drift", "encoder_scale"),
    "second_resonance": ("split_output", "appended_mass"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "sensor_drift", "second_resonance")

# effect slots in the kernel arrays (fixed order = order of EFFECT_FORMS)
_EFFECT_NAMES = tuple(EFFECT_FORMS)
E_STRIB, E_LOADF, E_TEMPF, E_RIPPLE, E_TOFF, E_DELAY, E_HYST, E_BACK, E_ASYM, \
    E_PDIST, E_PSTIFF, E_SDRIFT, E_RES2 = range(13)
N_EFF = 13
N_EP = 12

# parameter vector slots
(P_I, P_MRX, P_MRY, P_G, P_FC, P_FV, P_SIG0, P_SIG1, P_VD, P_ZBA, P_K0, P_K3, P_D,
 P_JR, P_FCM, P_FVM, P_WEPS, P_KP, P_KI, P_KPOS, P_TMAX, P_JD, P_KC, P_CC, P_FCD,
 P_FVD, P_TAUDYN, P_CTH, P_RTH, P_TAMB, P_SCHEME, P_DIR, P_WOUT, P_TACC0, P_TACC,
 P_TEX0, P_TEX1, P_WF, P_Q0F, P_U0, P_TRATED, P_TREF) = range(42)
N_P = 42

# state slots
X_Q, X_V, X_U, X_W, X_Z, X_EI, X_QD, X_VD, X_TDM, X_TH, X_XH, X_Q2, X_V2 = range(13)
N_X = 13
# recorded (truth) columns on the integrator grid
(R_Q, R_V, R_U, R_W, R_QDD, R_T, R_TL, R_F, R_GRAV, R_TM, R_TCMD, R_TH, R_DIST,
 R_Z) = range(14)
N_R = 14


# ----------------------------------------------------------------------------- kernel
@njit(cache=True)
def _interp(t, tt, tv):
    n = tt.shape[0]
    if t <= tt[0]:
        return tv[0]
    if t >= tt[n - 1]:
        return tv[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if tt[mid] <= t:
            lo = mid
        else:
            hi = mid
    f = (t - tt[lo]) / (tt[hi] - tt[lo])
    return tv[lo] + f * (tv[hi] - tv[lo])


@njit(cache=True)
def _play_step(p, db, r):
    """A play (stop) operator's output after its input moves to db: p held within db ± r."""
    if p < db - r:
        return db - r
    if p > db + r:
        return db + r
    return p


@njit(cache=True)
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def _twist_eff(q, v, u, w, EC, ES):
    """Twist seen by the teeth (kinematic error, backlash) and its rate, and the
    contact slope (1 in nominal contact)."""
    de = u - q
    dde = w - v
    if EC[E_RIPPLE] == 3:
        E = ES[E_RIPPLE, 0]
        z = ES[E_RIPPLE, 1]
        c2 = ES[E_RIPPLE, 2]
        a1 = z * q + ES[E_RIPPLE, 3]
        a2 = 2.0 * z * q + ES[E_RIPPLE, 4]
        de -= E * (math.sin(a1) + c2 * math.sin(a2))
        dde -= E * (z * math.cos(a1) + 2.0 * z * c2 * math.cos(a2)) * v
    slope = 1.0
    db = de
    if EC[E_BACK] == 1:
        b = ES[E_BACK, 0]
        if de > b:
            db = de - b
        elif de < -b:
            db = de + b
        else:
            db = 0.0
            slope = 0.0
    elif EC[E_BACK] == 2:
        b = ES[E_BACK, 0]
        eps = ES[E_BACK, 1]
        a = de - b
        c = -de - b
        ra = math.sqrt(a * a + eps * eps)
        rc = math.sqrt(c * c + eps * eps)
        db = 0.5 * (a + ra) - 0.5 * (c + rc)
        slope = 0.5 * (1.0 + a / ra) + 0.5 * (1.0 + c / rc)
    return db, slope * dde, slope


@njit(cache=True)
def _rhs(t, x, P, EC, ES, TT, TV, FA, FB, play, dx, out):
    q = x[X_Q]
    v = x[X_V]
    u = x[X_U]
    w = x[X_W]
    z = x[X_Z]
    ei = x[X_EI]
    th = x[X_TH]
    xh = x[X_XH]
    for i in range(dx.shape[0]):
        dx[i] = 0.0
    scheme = int(P[P_SCHEME])
    d = P[P_DIR]
    # ---------------------------------------------------------------- references
    if scheme == 3:
        qr = 0.0
        vr = 0.0
        ar = 0.0
        if t > P[P_TEX0] and t < P[P_TEX1]:
            tau = t - P[P_TEX0]
            wf = P[P_WF]
            for l in range(FA.shape[0]):
                wl = wf * (l + 1)
                s_ = math.sin(wl * tau)
                c_ = math.cos(wl * tau)
                qr += FA[l] / wl * s_ - FB[l] / wl * c_
                vr += FA[l] * c_ + FB[l] * s_
                ar += -FA[l] * wl * s_ + FB[l] * wl * c_
            qr += P[P_Q0F]
        wref = vr + P[P_KPOS] * (qr + P[P_U0] - u)
        ff = P[P_JR] * ar
        tcmd = 0.0
    else:
        t0 = P[P_TACC0]
        ta = P[P_TACC]
        if t <= t0:
            s = 0.0
            ds = 0.0
        elif t >= t0 + ta:
            s = 1.0
            ds = 0.0
        else:
            ph = math.pi * (t - t0) / ta
            s = 0.5 * (1.0 - math.cos(ph))
            ds = 0.5 * math.pi / ta * math.sin(ph)
        wref = d * P[P_WOUT] * s
        ff = P[P_JR] * d * P[P_WOUT] * ds
        tcmd = d * _interp(t, TT, TV)
    e = wref - w
    tm = P[P_KP] * e + P[P_KI] * ei + ff
    if tm > P[P_TMAX]:
        tm = P[P_TMAX]
    elif tm < -P[P_TMAX]:
        tm = -P[P_TMAX]
    dx[X_EI] = e
    # ---------------------------------------------------------------- transmission
    db, ddb, slope = _twist_eff(q, v, u, w, EC, ES)
    k0 = P[P_K0]
    kfac = 1.0
    if EC[E_PSTIFF] == 1:
        kfac = 1.0 + ES[E_PSTIFF, 0] * math.cos(q + ES[E_PSTIFF, 1])
    elif EC[E_PSTIFF] == 2:
        r = (q - ES[E_PSTIFF, 1]) / ES[E_PSTIFF, 2]
        kfac = 1.0 - ES[E_PSTIFF, 0] * math.exp(-r * r)
    tel = kfac * (k0 * db + P[P_K3] * db * db * db)
    hc = EC[E_HYST]
    if hc != 0:
        h = ES[E_HYST, 0]
        xs = ES[E_HYST, 1]
        if hc == 1:
            beta = 0.5 / xs
            dx[X_XH] = ddb - beta * abs(ddb) * xh - beta * ddb * abs(xh)
            xhy = xh
        elif hc == 2:
            beta = 0.5 / (xs * xs)
            dx[X_XH] = ddb - beta * abs(ddb) * abs(xh) * xh - beta * ddb * xh * xh
            xhy = xh
        elif hc == 3:
            rr = 1.0 - xh * _sgn(ddb) / xs
            dx[X_XH] = ddb * rr * abs(rr)
            xhy = xh
        else:
            # stop operators (elastic-perfectly-plastic elements): S = db - play(db)
            xhy = 0.0
            for i in range(play.shape[0]):
                xhy += ES[E_HYST, 6 + i] * (db - _play_step(play[i], db, ES[E_HYST, 2 + i]))
        ttr = tel + h * kfac * k0 * xhy
    else:
        ttr = tel
    T = ttr + P[P_D] * ddb
    rc = EC[E_RIPPLE]
    if rc == 1:
        zz = ES[E_RIPPLE, 2]
        amp = ES[E_RIPPLE, 0] + ES[E_RIPPLE, 1] * abs(ttr)
        T += amp * (math.sin(zz * q + ES[E_RIPPLE, 5])
                    + ES[E_RIPPLE, 3] * math.sin(2.0 * zz * q + ES[E_RIPPLE, 6])
                    + ES[E_RIPPLE, 4] * math.sin(3.0 * zz * q + ES[E_RIPPLE, 7]))
    elif rc == 2:
        ii = ES[E_RIPPLE, 1]
        T += ES[E_RIPPLE, 0] * (math.sin(ii * u + ES[E_RIPPLE, 3])
                                + ES[E_RIPPLE, 2] * math.sin(2.0 * ii * u + ES[E_RIPPLE, 4]))
    # ---------------------------------------------------------------- bearing friction
    fc = P[P_FC]
    fv = P[P_FV]
    sv = _sgn(v)
    ac = EC[E_ASYM]
    if ac == 1 or ac == 3:
        fc = fc * (1.0 + ES[E_ASYM, 0] * sv)
    if ac == 2 or ac == 3:
        fv = fv * (1.0 + ES[E_ASYM, 1] * sv)
    tc = EC[E_TEMPF]
    if tc != 0:
        dth = th - P[P_TREF]
        if tc == 1:
            fv = fv * math.exp(-ES[E_TEMPF, 0] * dth)
        elif tc == 2:
            fv = fv * math.exp(-ES[E_TEMPF, 0] * dth)
            fc = fc * math.exp(-ES[E_TEMPF, 1] * dth)
        elif tc == 3:
            fc = fc - ES[E_TEMPF, 0] * dth
            fv = fv - ES[E_TEMPF, 1] * dth
        else:
            fv = fv * math.exp(ES[E_TEMPF, 0] * (1.0 / (th - ES[E_TEMPF, 1])
                                                 - 1.0 / (P[P_TREF] - ES[E_TEMPF, 1])))
        if fc < 0.2 * P[P_FC]:
            fc = 0.2 * P[P_FC]
        if fv < 0.2 * P[P_FV]:
            fv = 0.2 * P[P_FV]
    lc = EC[E_LOADF]
    if lc == 1:
        fc = fc + ES[E_LOADF, 0] * abs(ttr)
    elif lc == 2:
        fac = 1.0 + ES[E_LOADF, 0] * abs(ttr) / P[P_TRATED]
        fc = fc * fac
        fv = fv * fac
    elif lc == 3:
        mud = ES[E_LOADF, 0]
        mub = ES[E_LOADF, 1]
        mu = 0.5 * (mud + mub) + 0.5 * (mud - mub) * math.tanh(ttr * v / ES[E_LOADF, 2])
        fc = fc + mu * abs(ttr)
    gv = fc
    scs = EC[E_STRIB]
    if scs != 0:
        xr = abs(v) / ES[E_STRIB, 1]
        if scs == 1:
            phi = math.exp(-xr * xr)
        elif scs == 2:
            phi = math.exp(-xr)
        elif scs == 3:
            phi = 1.0 / (1.0 + xr * xr)
        else:
            phi = math.exp(-math.sqrt(xr))
        gv = fc * (1.0 + ES[E_STRIB, 0] * phi)
    sig0 = P[P_SIG0]
    zss = gv / sig0
    alpha = 0.0
    if z * v > 0.0:
        az = abs(z)
        zba = P[P_ZBA] * zss
        if az >= zss:
            alpha = 1.0
        elif az > zba:
            alpha = 0.5 + 0.5 * math.sin(math.pi * ((az - zba) / (zss - zba) - 0.5))
    dz = v * (1.0 - alpha * abs(z) / zss)
    dx[X_Z] = dz
    vr_ = v / P[P_VD]
    F = sig0 * z + P[P_SIG1] * math.exp(-vr_ * vr_) * dz + fv * v
    # ---------------------------------------------------------------- external torques
    dist = 0.0
    pc = EC[E_PDIST]
    if pc == 1:
        dist = ES[E_PDIST, 0] * math.sin(2.0 * math.pi * ES[E_PDIST, 1] * t + ES[E_PDIST, 2])
    elif pc == 2:
        dist = ES[E_PDIST, 0] * (abs(math.sin(math.pi * ES[E_PDIST, 1] * t + ES[E_PDIST, 2]))
                                 - 2.0 / math.pi)
    grav = P[P_G] * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    I = P[P_I]
    r2 = EC[E_RES2]
    q2 = x[X_Q2]
    v2 = x[X_V2]
    if r2 == 1:
        qL = q2
        vL = v2
    else:
        qL = q
        vL = v
    tauL = 0.0
    if scheme != 3:
        qdn = x[X_QD]
        vdn = x[X_VD]
        tauL = P[P_KC] * (qL - qdn) + P[P_CC] * (vL - vdn)
        Fd = P[P_FCD] * math.tanh(vdn / 1e-3) + P[P_FVD] * vdn
        dx[X_QD] = vdn
        dx[X_VD] = (tauL - x[X_TDM] - Fd) / P[P_JD]
        dx[X_TDM] = (tcmd - x[X_TDM]) / P[P_TAUDYN]
    if r2 == 1:
        eps = ES[E_RES2, 0]
        om = ES[E_RES2, 1]
        I2 = eps * I
        I1 = I - I2
        t12 = I2 * om * om * (q - q2) + 2.0 * ES[E_RES2, 2] * I2 * om * (v - v2)
        grav2 = eps * P[P_G] * (P[P_MRX] * math.sin(q2) + P[P_MRY] * math.cos(q2))
        acc = (T - F - (1.0 - eps) * grav - t12 + dist) / I1
        dx[X_Q2] = v2
        dx[X_V2] = (t12 - grav2 - tauL) / I2
    elif r2 == 2:
        I2 = ES[E_RES2, 0] * I
        om = ES[E_RES2, 1]
        t12 = I2 * om * om * (q - q2) + 2.0 * ES[E_RES2, 2] * I2 * om * (v - v2)
        acc = (T - tauL - grav - F - t12 + dist) / I
        dx[X_Q2] = v2
        dx[X_V2] = t12 / I2
    else:
        acc = (T - tauL - grav - F + dist) / I
    dx[X_Q] = v
    dx[X_V] = acc
    # ---------------------------------------------------------------- motor side, heat
    Fm = P[P_FCM] * math.tanh(w / P[P_WEPS]) + P[P_FVM] * w
    dx[X_U] = w
    dx[X_W] = (tm - T - Fm) / P[P_JR]
    dx[X_TH] = (abs(F * v) + abs(Fm * w) - (th - P[P_TAMB]) / P[P_RTH]) / P[P_CTH]
    out[R_Q] = q
    out[R_V] = v
    out[R_U] = u
    out[R_W] = w
    out[R_QDD] = acc
    out[R_T] = T
    out[R_TL] = tauL
    out[R_F] = F
    out[R_GRAV] = grav
    out[R_TM] = tm
    out[R_TCMD] = tcmd
    out[R_TH] = th
    out[R_DIST] = dist
    out[R_Z] = z


@njit(cache=True)
def _accel(x, P, EC, ES, TT, TV, FA, FB):
    dx = np.zeros(x.shape[0])
    out = np.zeros(N_R)
    play = np.zeros(4)
    _rhs(0.0, x, P, EC, ES, TT, TV, FA, FB, play, dx, out)
    return dx[X_V], out[R_T]


@njit(cache=True)
def _integrate(x0, n_fine, h, P, EC, ES, TT, TV, FA, FB):
    nx = x0.shape[0]
    x = x0.copy()
    xs = np.empty(nx)
    k1 = np.empty(nx)
    k2 = np.empty(nx)
    k3 = np.empty(nx)
    k4 = np.empty(nx)
    out = np.empty(N_R)
    rec = np.empty((n_fine + 1, N_R))
    play = np.zeros(4)
    hplay = EC[E_HYST] == 4
    if hplay:
        db, ddb, sl = _twist_eff(x[X_Q], x[X_V], x[X_U], x[X_W], EC, ES)
        for i in range(4):
            ri = ES[E_HYST, 2 + i]
            play[i] = min(max(0.0, db - ri), db + ri)
    for k in range(n_fine):
        t = k * h
        _rhs(t, x, P, EC, ES, TT, TV, FA, FB, play, k1, out)
        for j in range(N_R):
            rec[k, j] = out[j]
        for i in range(nx):
            xs[i] = x[i] + 0.5 * h * k1[i]
        _rhs(t + 0.5 * h, xs, P, EC, ES, TT, TV, FA, FB, play, k2, out)
        for i in range(nx):
            xs[i] = x[i] + 0.5 * h * k2[i]
        _rhs(t + 0.5 * h, xs, P, EC, ES, TT, TV, FA, FB, play, k3, out)
        for i in range(nx):
            xs[i] = x[i] + h * k3[i]
        _rhs(t + h, xs, P, EC, ES, TT, TV, FA, FB, play, k4, out)
        for i in range(nx):
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        if hplay:
            db, ddb, sl = _twist_eff(x[X_Q], x[X_V], x[X_U], x[X_W], EC, ES)
            for i in range(play.shape[0]):
                play[i] = _play_step(play[i], db, ES[E_HYST, 2 + i])
    _rhs(n_fine * h, x, P, EC, ES, TT, TV, FA, FB, play, k1, out)
    for j in range(N_R):
        rec[n_fine, j] = out[j]
    return rec


# ----------------------------------------------------------------------------- interface
@dataclass
class SensorSpec:
    """What the data sheet / DAQ configuration states (all of it goes into meta)."""
    sample_rate_hz: float = 1000.0     # 10 Hz ... 1 kHz
    encoder_res_deg: float = 0.01      # output absolute encoder step, 0.001 ... 0.02 deg
    torque_noise: float = 150.0        # white noise s.d. of the torque reading [N m]
    torque_lag_s: float = 0.0          # stated pure transport delay of torque [s], <= 0.5
    torque_adc_bits: int = 16          # torque ADC over +-torque_range
    torque_range: float = 250_000.0    # [N m]
    load_noise: float = 60.0           # load cell noise s.d. [N m]
    load_tau_s: float = 0.003          # load-cell amplifier first-order lag [s]
    load_adc_bits: int = 20
    qd_tau_s: float = 0.010            # encoder-head speed filter [s]
    qd_noise: float = 2e-5             # [rad/s]
    qd_res: float = 1e-6               # [rad/s]
    ud_tau_s: float = 0.004            # S120 speed-actual smoothing [s]
    ud_noise: float = 2e-6             # [rad/s] (output-referred)
    ud_res: float = 1e-7               # [rad/s]
    motor_encoder_bits: int = 22       # counts per motor revolution = 2**bits
    temp_tau_s: float = 15.0           # PT100 time constant [s]
    temp_noise: float = 0.02           # [degC]
    temp_res: float = 0.1              # [degC]
    current_noise: float = 0.02        # [A]
    current_res: float = 0.001         # [A]


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict = field(default_factory=dict)     # the drawn physical rig (not in meta)
    noise: pd.DataFrame | None = None              # the unit noise draws of this run


def _bad(culprit: str, msg: str):
    raise ValueError(f"{culprit}: {msg}")


def _finite(x) -> bool:
    try:
        return math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def _check_sensors(s: SensorSpec) -> None:
    if not isinstance(s, SensorSpec):
        _bad("sensors", f"must be a SensorSpec, got {type(s).__name__}")
    if not _finite(s.sample_rate_hz) or not 10.0 <= float(s.sample_rate_hz) <= 1000.0:
        _bad("sensors.sample_rate_hz", f"must be within 10 ... 1000 Hz, got {s.sample_rate_hz!r}")
    if not _finite(s.encoder_res_deg) or not 0.001 - 1e-12 <= float(s.encoder_res_deg) <= 0.02 + 1e-12:
        _bad("sensors.encoder_res_deg", f"must be within 0.001 ... 0.02 deg, got {s.encoder_res_deg!r}")
    if not _finite(s.torque_noise) or float(s.torque_noise) < 0.0:
        _bad("sensors.torque_noise", f"must be a finite number >= 0, got {s.torque_noise!r}")
    if not _finite(s.torque_lag_s) or not 0.0 <= float(s.torque_lag_s) <= 0.5:
        _bad("sensors.torque_lag_s", f"must be within 0 ... 0.5 s, got {s.torque_lag_s!r}")
    for name in ("torque_range", "load_noise", "load_tau_s", "qd_tau_s", "qd_noise", "qd_res",
                 "ud_tau_s", "ud_noise", "ud_res", "temp_tau_s", "temp_noise", "temp_res",
                 "current_noise", "current_res"):
        val = getattr(s, name)
        if not _finite(val) or float(val) < 0.0:
            _bad(f"sensors.{name}", f"must be a finite number >= 0, got {val!r}")
    if float(s.torque_range) <= 0.0:
        _bad("sensors.torque_range", "must be > 0")
    for name in ("torque_adc_bits", "load_adc_bits", "motor_encoder_bits"):
        val = getattr(s, name)
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or not 8 <= int(val) <= 32:
            _bad(f"sensors.{name}", f"must be an integer 8 ... 32, got {val!r}")


def _check_effects(effects) -> dict[str, tuple[int, str, float]]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        _bad("effects", f"must be a dict {{name: {{'form', 'scale'}}}}, got {type(effects).__name__}")
    parsed = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            _bad(f"effects[{name!r}]", f"unknown effect; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            _bad(f"effects[{name!r}]", "must be a dict with 'form' and 'scale'")
        extra = set(spec) - {"form", "scale"}
        if extra:
            _bad(f"effects[{name!r}]", f"unknown key(s) {sorted(extra)}; known: ['form', 'scale']")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if form not in EFFECT_FORMS[name]:
            _bad(f"effects[{name!r}].form", f"unknown form {form!r}; known: {list(EFFECT_FORMS[name])}")
        scale = spec.get("scale", 0.0)
        if isinstance(scale, bool) or not _finite(scale):
            _bad(f"effects[{name!r}].scale", f"must be a finite number, got {scale!r}")
        scale = float(scale)
        if scale < 0.0:
            _bad(f"effects[{name!r}].scale", f"must be >= 0, got {scale!r}")
        if scale > 0.0:
            parsed[name] = (EFFECT_FORMS[name].index(form) + 1, form, min(scale, SCALE_MAX))
    return parsed


# ----------------------------------------------------------------------------- the rig
def _draw_rig(seed: int) -> dict:
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x52494B]))

    def spread(rel):
        return 1.0 + rel * float(np.clip(rng.standard_normal(), -2.0, 2.0))

    N = REDUCTION
    p = {}
    p["I"] = 6700.0 * spread(0.03)
    p["mr_x"] = 21.0 * spread(0.05)
    p["mr_y"] = -34.0 * spread(0.05)
    p["f_c"] = 2300.0 * spread(0.04)
    p["f_v"] = 8800.0 * spread(0.04)
    p["z_ss"] = 6e-5 * spread(0.10)
    p["sigma0"] = p["f_c"] / p["z_ss"]
    p["sigma1"] = 3.0e5
    p["v_d"] = 2e-3
    p["z_ba"] = 0.7
    p["k0"] = 1.2e7 * spread(0.05)
    p["k3"] = 0.15 * p["k0"] / 8.5e-3 ** 2
    p["c_t"] = 3.0e4
    p["J_r"] = 6.0e-3 * N * N * spread(0.03)
    p["Fc_m"] = 0.10 * N * spread(0.05)
    p["fv_m"] = 1.5e-4 * N * N * spread(0.05)
    p["w_eps"] = 2e-4
    p["kt"] = [1.45 * spread(0.02) for _ in range(3)]
    p["J_d"] = 900.0 * spread(0.05)
    p["k_c"] = 3.0e7
    p["c_c"] = 3.0e4
    p["Fc_d"] = 450.0 * spread(0.10)
    p["fv_d"] = 2000.0 * spread(0.10)
    p["tau_dyn"] = 0.04
    p["C_th"] = 2.5e4
    p["R_th"] = 0.05
    # effect spreads (+-8 %) and phases, always drawn in the same order
    p["effect_spread"] = {n: spread(0.08) for n in _EFFECT_NAMES}
    p["effect_phase"] = {n: rng.uniform(0.0, 2.0 * math.pi, 4) for n in _EFFECT_NAMES}
    return p


_FOURIER_CACHE: dict[int, tuple] = {}
T_PERIOD = 24.0
V_LIMIT = 3000.0 * 2.0 * math.pi / 60.0 / REDUCTION


def _fourier(seed: int):
    """Fifth-order Fourier excitation: lowest cond of the Eq. 4 regressor of 64 draws."""
    if seed in _FOURIER_CACHE:
        return _FOURIER_CACHE[seed]
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x54524A]))
    wf = 2.0 * math.pi / T_PERIOD
    L = np.arange(1, 6)
    tg = np.linspace(0.0, T_PERIOD, 1201)[:-1]
    best = None
    for _ in range(64):
        a = rng.normal(0.0, 1.0, 5) / L
        b = rng.normal(0.0, 1.0, 5) / L
        a[0] -= a.sum()                        # q'(0) = 0
        b[0] = -np.sum(L[1:] * b[1:])          # q''(0) = 0
        arg = np.outer(tg, L * wf)
        v = np.cos(arg) @ a + np.sin(arg) @ b
        sc = 0.85 * V_LIMIT / np.max(np.abs(v))
        a, b, v = a * sc, b * sc, v * sc
        q0 = float(np.sum(b / (L * wf)))
        qq = np.sin(arg) @ (a / (L * wf)) - np.cos(arg) @ (b / (L * wf)) + q0
        acc = -np.sin(arg) @ (a * L * wf) + np.cos(arg) @ (b * L * wf)
        Y = np.column_stack([acc * 6700.0, G * np.sin(qq) * 21.0, G * np.cos(qq) * 34.0,
                             v * 8800.0, np.sign(v) * 2300.0])
        c = np.linalg.cond(Y)
        if best is None or c < best[0]:
            best = (c, a.copy(), b.copy(), q0)
    _FOURIER_CACHE[seed] = best[1:]
    return best[1:]


def _effect_params(parsed, rig) -> tuple[np.ndarray, np.ndarray]:
    EC = np.zeros(N_EFF, dtype=np.int64)
    ES = np.zeros((N_EFF, N_EP))
    for name, (code, form, s) in parsed.items():
        i = _EFFECT_NAMES.index(name)
        EC[i] = code
        sp = rig["effect_spread"][name]
        ph = rig["effect_phase"][name]
        ss = s * sp
        e = ES[i]
        if name == "stribeck":
            e[0] = 0.6 * ss
            e[1] = 1.5e-3
        elif name == "load_dependent_friction":
            if code == 1:
                e[0] = 0.015 * ss
            elif code == 2:
                e[0] = 0.8 * ss
            else:
                e[0], e[1], e[2] = 0.02 * ss, 0.006 * ss, 20.0
        elif name == "temperature_friction":
            if code in (1, 2):
                e[0], e[1] = 0.05 * ss, 0.012 * ss
            elif code == 3:
                e[0], e[1] = 35.0 * ss, 150.0 * ss
            else:
                e[0], e[1] = 800.0 * ss, -95.0
        elif name == "gear_ripple":
            if code == 1:
                e[:8] = [1500.0 * ss, 0.01 * ss, 96.0, 0.35, 0.15, ph[0], ph[1], ph[2]]
            elif code == 2:
                e[:5] = [1500.0 * ss, 240.0, 0.4, ph[0], ph[1]]
            else:
                e[:5] = [2.5e-4 * ss, 48.0, 0.3, ph[0], ph[1]]
        elif name == "torque_offset":
            e[0] = {1: 1500.0, 2: 20.0, 3: 2000.0}[code] * ss
            e[1] = 25.0
        elif name == "time_delay":
            e[0] = 0.025 * ss
        elif name == "hysteresis":
            e[0], e[1] = 0.25 * ss, 1e-3
            e[2:6] = np.array([0.2, 0.5, 1.0, 1.6]) * 1e-3
            e[6:10] = 0.25
        elif name == "backlash":
            e[0] = 4e-4 * ss
            e[1] = 0.5 * e[0]
        elif name == "asymmetric_friction":
            e[0] = 0.15 * ss if code in (1, 3) else 0.0
            e[1] = 0.40 * ss if code in (2, 3) else 0.0
            e[0] = min(e[0], 0.8)
            e[1] = min(e[1], 0.8)
        elif name == "periodic_disturbance":
            if code == 1:
                e[:3] = [1200.0 * ss, 0.85, ph[0]]
            else:
                e[:3] = [1500.0 * ss, 2.3, ph[0]]
        elif name == "position_dependent_stiffness":
            if code == 1:
                e[:2] = [min(0.12 * ss, 0.6), ph[0]]
            else:
                e[:3] = [min(0.25 * ss, 0.8), 0.05, 0.3]
        elif name == "sensor_drift":
            e[0] = {1: 15.0, 2: 3e-6, 3: 3e-4}[code] * ss
        elif name == "second_resonance":
            if code == 1:
                e[:3] = [min(0.3 * ss, 0.8), 2.0 * math.pi * 7.5, 0.02]
            else:
                e[:3] = [0.2 * ss, 2.0 * math.pi * 2.6, 0.02]
    return EC, ES


def _schedule(scheme: int, periods: int):
    """Torque set-point table (kN m profile, before the direction sign), duration, phases."""
    if scheme == 1:
        tt = np.array([0.0, 3.0, 48.0, 50.0, 95.0, 97.0])
        tv = np.array([0.0, 0.0, T_RATED, T_RATED, 0.0, 0.0])
        phases = [(3.0, "idle"), (48.0, "load"), (50.0, "hold"), (95.0, "unload"), (97.0, "idle")]
        return tt, tv, 97.0, phases
    if scheme == 2:
        tt = [0.0, 3.0]
        tv = [0.0, 0.0]
        phases = [(3.0, "idle")]
        t = 3.0
        for j in range(1, 13):
            tt += [t + 0.5, t + 2.5]
            tv += [j * 10_000.0, j * 10_000.0]
            phases += [(t + 0.5, "load"), (t + 2.5, "hold")]
            t += 2.5
        tt += [t + 10.0, t + 12.0]
        tv += [0.0, 0.0]
        phases += [(t + 10.0, "unload"), (t + 12.0, "idle")]
        return np.array(tt), np.array(tv), t + 12.0, phases
    dur = 2.0 + T_PERIOD * periods
    return (np.array([0.0, dur]), np.array([0.0, 0.0]), dur,
            [(1.0, "idle"), (1.0 + T_PERIOD * periods, "excite"), (dur, "idle")])


def _lag1(x: np.ndarray, tau: float, h: float) -> np.ndarray:
    """First-order low-pass on the integrator grid (trapezoidal input, exact pole)."""
    if tau <= 0.0:
        return x.copy()
    a = math.exp(-h / tau)
    b = np.array([(1.0 - a) / 2.0, (1.0 - a) / 2.0])
    den = np.array([1.0, -a])
    y, _ = lfilter(b, den, x, zi=lfilter_zi(b, den) * x[0])
    return y


def _delay(x: np.ndarray, tf: np.ndarray, d: float) -> np.ndarray:
    if d <= 0.0:
        return x.copy()
    return np.interp(tf - d, tf, x, left=x[0])


def _quant(x: np.ndarray, step: float) -> np.ndarray:
    if step <= 0.0:
        return x.copy()
    return np.round(x / step) * step


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict], *, sensors: SensorSpec | None = None, periods: int = 3,
                 seed: int, run: int) -> RigRun:
    """Simulate one run of rig K (see the module docstring: the data sheet)."""
    # ------------------------------------------------------------------ arguments
    if isinstance(scheme, bool) or not isinstance(scheme, (int, np.integer)) or int(scheme) not in (1, 2, 3):
        _bad("scheme", f"must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            _bad("motor_speed_rpm", f"must be None for scheme 3, got {motor_speed_rpm!r}")
        if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or not 1 <= int(periods) <= 20:
            _bad("periods", f"must be an integer 1 ... 20, got {periods!r}")
        periods = int(periods)
    else:
        if motor_speed_rpm is None or isinstance(motor_speed_rpm, bool) or not _finite(motor_speed_rpm) \
                or not 0.0 < float(motor_speed_rpm) <= 3000.0:
            _bad("motor_speed_rpm", f"must be a number in (0, 3000] r/min for scheme {scheme}, "
                                    f"got {motor_speed_rpm!r}")
    if isinstance(direction, bool) or direction not in (1, -1):
        _bad("direction", f"must be +1 or -1, got {direction!r}")
    direction = int(direction)
    if isinstance(temp_joint_c, bool) or not _finite(temp_joint_c) or not -30.0 <= float(temp_joint_c) <= 90.0:
        _bad("temp_joint_c", f"must be a finite temperature in -30 ... 90 degC, got {temp_joint_c!r}")
    temp_joint_c = float(temp_joint_c)
    for nm, val in (("seed", seed), ("run", run)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or int(val) < 0:
            _bad(nm, f"must be an integer >= 0, got {val!r}")
    seed, run = int(seed), int(run)
    if sensors is None:
        sensors = SensorSpec()
    _check_sensors(sensors)
    parsed = _check_effects(effects)

    # ------------------------------------------------------------------ noise first
    fs = float(sensors.sample_rate_hz)
    tt, tv, duration, phases = _schedule(scheme, periods)
    n = int(round(duration * fs)) + 1
    nrng = np.random.default_rng(np.random.SeedSequence([seed, run, 0x4E4F4953]))
    noise = {k: nrng.standard_normal(n) for k in
             ("torque", "torque_load", "qd", "ud", "temp_joint", "i_m1", "i_m2", "i_m3")}

    # ------------------------------------------------------------------ rig + kernel inputs
    rig = _draw_rig(seed)
    EC, ES = _effect_params(parsed, rig)
    N = REDUCTION
    P = np.zeros(N_P)
    P[P_I], P[P_MRX], P[P_MRY], P[P_G] = rig["I"], rig["mr_x"], rig["mr_y"], G
    P[P_FC], P[P_FV], P[P_SIG0], P[P_SIG1] = rig["f_c"], rig["f_v"], rig["sigma0"], rig["sigma1"]
    P[P_VD], P[P_ZBA], P[P_K0], P[P_K3], P[P_D] = rig["v_d"], rig["z_ba"], rig["k0"], rig["k3"], rig["c_t"]
    P[P_JR], P[P_FCM], P[P_FVM], P[P_WEPS] = rig["J_r"], rig["Fc_m"], rig["fv_m"], rig["w_eps"]
    P[P_KP] = 40.0 * rig["J_r"]
    P[P_KI] = 10.0 * P[P_KP]
    P[P_KPOS] = 6.0
    P[P_TMAX] = 3 * 9.0 * N
    P[P_JD], P[P_KC], P[P_CC] = rig["J_d"], rig["k_c"], rig["c_c"]
    P[P_FCD], P[P_FVD], P[P_TAUDYN] = rig["Fc_d"], rig["fv_d"], rig["tau_dyn"]
    P[P_CTH], P[P_RTH], P[P_TAMB] = rig["C_th"], rig["R_th"], temp_joint_c
    P[P_SCHEME], P[P_DIR] = scheme, direction
    P[P_WOUT] = 0.0 if scheme == 3 else float(motor_speed_rpm) * 2.0 * math.pi / 60.0 / N
    P[P_TACC0], P[P_TACC] = 0.5, 1.5
    P[P_TRATED], P[P_TREF] = T_RATED, 25.0
    if scheme == 3:
        a, b, q0 = _fourier(seed)
        FA, FB = direction * a, direction * b
        P[P_Q0F] = direction * q0
        P[P_WF] = 2.0 * math.pi / T_PERIOD
        P[P_TEX0], P[P_TEX1] = 1.0, 1.0 + T_PERIOD * periods
    else:
        FA = np.zeros(5)
        FB = np.zeros(5)

    # static equilibrium at t = 0: q = 0, the twist carries gravity, z = 0
    x0 = np.zeros(N_X)
    x0[X_TH] = temp_joint_c
    if EC[E_RES2] == 1:
        eps = ES[E_RES2, 0]
        k2 = eps * rig["I"] * ES[E_RES2, 1] ** 2
        x0[X_Q2] = -eps * G * rig["mr_y"] / k2
        x0[X_QD] = x0[X_Q2]
    lo, hi = -0.05, 0.05
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        x0[X_U] = mid
        acc, _t = _accel(x0, P, EC, ES, tt, tv, FA, FB)
        if acc > 0.0:
            hi = mid
        else:
            lo = mid
    x0[X_U] = 0.5 * (lo + hi)
    acc, T0 = _accel(x0, P, EC, ES, tt, tv, FA, FB)
    x0[X_EI] = T0 / P[P_KI]
    P[P_U0] = x0[X_U]

    n_sub = max(1, int(math.ceil(1.0 / (fs * DT_MAX) - 1e-9)))
    h = 1.0 / (fs * n_sub)
    n_fine = (n - 1) * n_sub
    rec = _integrate(x0, n_fine, h, P, EC, ES, tt, tv, FA, FB)
    tf = np.arange(n_fine + 1) * h
    idx = np.arange(n) * n_sub
    t = np.arange(n) / fs

    # ------------------------------------------------------------------ truth
    truth = pd.DataFrame({
        "t": t,
        "q": rec[idx, R_Q], "qd": rec[idx, R_V], "qdd": rec[idx, R_QDD],
        "u": rec[idx, R_U], "ud": rec[idx, R_W],
        "twist": rec[idx, R_U] - rec[idx, R_Q],
        "torque": rec[idx, R_T], "torque_load": rec[idx, R_TL],
        "friction": rec[idx, R_F], "gravity": rec[idx, R_GRAV],
        "disturbance": rec[idx, R_DIST], "torque_motor": rec[idx, R_TM],
        "torque_cmd": rec[idx, R_TCMD], "temp_joint": rec[idx, R_TH],
    })

    # ------------------------------------------------------------------ sensor chain
    s = sensors
    sd_code = EC[E_SDRIFT]
    sd_val = ES[E_SDRIFT, 0]
    # output encoder
    q_read = rec[idx, R_Q].copy()
    if sd_code == 2:
        q_read = q_read + sd_val * t
    elif sd_code == 3:
        q_read = q_read * (1.0 + sd_val)
    q_res = math.radians(float(s.encoder_res_deg))
    q_meas = _quant(q_read, q_res)
    u_res = 2.0 * math.pi / 2 ** int(s.motor_encoder_bits) / N
    u_meas = _quant(rec[idx, R_U], u_res)
    qd_meas = _quant(_lag1(rec[:, R_V], s.qd_tau_s, h)[idx] + s.qd_noise * noise["qd"], s.qd_res)
    ud_meas = _quant(_lag1(rec[:, R_W], s.ud_tau_s, h)[idx] + s.ud_noise * noise["ud"], s.ud_res)
    # joint torque transducer
    tq = _delay(rec[:, R_T], tf, float(s.torque_lag_s))
    if EC[E_DELAY] == 1:
        tq = _delay(tq, tf, ES[E_DELAY, 0])
    elif EC[E_DELAY] == 2:
        tq = _lag1(tq, ES[E_DELAY, 0], h)
    tq = tq[idx]
    oc = EC[E_TOFF]
    if oc == 1:
        tq = tq + ES[E_TOFF, 0]
    elif oc == 2:
        tq = tq + ES[E_TOFF, 0] * t
    elif oc == 3:
        tq = tq + ES[E_TOFF, 0] * (1.0 - np.exp(-t / ES[E_TOFF, 1]))
    tq_res = 2.0 * float(s.torque_range) / 2 ** int(s.torque_adc_bits)
    tq = np.clip(_quant(tq + float(s.torque_noise) * noise["torque"], tq_res),
                 -s.torque_range, s.torque_range)
    # load cell
    tl = _lag1(rec[:, R_TL], s.load_tau_s, h)[idx]
    if sd_code == 1:
        tl = tl + sd_val * t
    tl_res = 2.0 * float(s.torque_range) / 2 ** int(s.load_adc_bits)
    tl = np.clip(_quant(tl + s.load_noise * noise["torque_load"], tl_res), -s.torque_range, s.torque_range)
    # temperature
    th = _quant(_lag1(rec[:, R_TH], s.temp_tau_s, h)[idx] + s.temp_noise * noise["temp_joint"], s.temp_res)
    # phase labels
    phase = np.empty(n, dtype=object)
    start = -np.inf
    for end, label in phases:
        phase[(t >= start) & (t < end + 1e-9)] = label
        start = end + 1e-9
    phase[t >= start] = phases[-1][1]

    cols = {"t": t, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": ud_meas, "torque": tq,
            "torque_load": tl, "torque_cmd": rec[idx, R_TCMD]}
    for k in range(3):
        i_k = rec[idx, R_TM] / (3.0 * N * rig["kt"][k])
        cols[f"i_m{k + 1}"] = _quant(i_k + s.current_noise * noise[f"i_m{k + 1}"], s.current_res)
    cols["temp_joint"] = th
    cols["phase"] = phase
    samples = pd.DataFrame(cols)

    sensors_meta = {
        "q": {"resolution": q_res},
        "u": {"resolution": u_res},
        "qd": {"resolution": float(s.qd_res), "noise_sd": float(s.qd_noise), "lag_s": float(s.qd_tau_s)},
        "ud": {"resolution": float(s.ud_res), "noise_sd": float(s.ud_noise), "lag_s": float(s.ud_tau_s)},
        "torque": {"resolution": tq_res, "noise_sd": float(s.torque_noise), "lag_s": float(s.torque_lag_s)},
        "torque_load": {"resolution": tl_res, "noise_sd": float(s.load_noise), "lag_s": float(s.load_tau_s)},
        "temp_joint": {"resolution": float(s.temp_res), "noise_sd": float(s.temp_noise),
                       "lag_s": float(s.temp_tau_s)},
    }
    for k in range(3):
        sensors_meta[f"i_m{k + 1}"] = {"resolution": float(s.current_res), "noise_sd": float(s.current_noise)}
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
        "direction": direction,
        "reduction": REDUCTION,
        "rig": "J4-bench rig K (validation model)",
        "source": "emulator",
        "sample_rate_hz": fs,
        "temp_joint_c": temp_joint_c,
        "started_at": "2026-11-10T09:00:00Z",
        "notes": "rig_k validation model; torque_cmd is the dynamometer set point",
        "sensors": sensors_meta,
        "sensor_units": {"q": "rad", "u": "rad", "qd": "rad/s", "ud": "rad/s", "torque": "N*m",
                         "torque_load": "N*m", "temp_joint": "degC", "i_m1": "A", "i_m2": "A",
                         "i_m3": "A"},
    }
    if scheme == 3:
        meta["periods"] = periods
        meta["excitation_period_s"] = T_PERIOD
    params = {k: v for k, v in rig.items() if k not in ("effect_spread", "effect_phase")}
    params["effects_applied"] = {k: {"form": f, "scale": sc} for k, (c, f, sc) in parsed.items()}
    return RigRun(samples=samples, meta=meta, truth=truth, params=params,
                  noise=pd.DataFrame(noise))
