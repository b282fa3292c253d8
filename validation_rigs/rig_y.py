"""Rig Y: an independent validation simulator of the CMOR J4 joint test bench.

Written from the paper (Eq. 4, Table 3, Eq. 5, the three schemes) and the shared docs only; it
shares no code with the company's emulator. Everything below is enough to rebuild the rig.

DATA SHEET (SI units, temperatures in degC; angles output-referred unless "motor" is said)
=========================================================================================

Symbols: q output angle, u = motor angle / N, Delta = u - q the twist (truth column "twist";
the samples' `torsion` = q_read - u_read = -Delta), T the transmitted torque (truth "torque"),
tau_L the dynamometer torque on the output, z the friction's presliding state, x the
hysteresis state, v = dq/dt.

Machine (drawn per campaign seed): every parameter p = p_nom * (1 + 0.02 * xi), xi ~ N(0, 1)
clipped to +-2.5, one xi per parameter (k1 and k3 share one) -> seed spread +-5 %.
  Output side (Table 3):  I = 6685.166 kg m^2, mr_x = 20.779 kg m, mr_y = -34.543 kg m,
                          f_v = 8683.272 N m s/rad, f_c = 2352.660 N m, g = 9.81 m/s^2.
  Reduction N = 11000 (exact, not drawn).
  Transmission: T_el(d) = k1*d + k3*d^3, k1 = 9.6250e6 N m/rad, k3 = 5.4172e10 N m/rad^3
     (70 % linear + 30 % cubic stiffening at the rated point: d = 0.5 deg -> 120 kN m),
     damping D = 8.0e4 N m s/rad (drawn like the rest).   T = T_el(d_eff) + D*g'(d_eff)*dDelta/dt + T_hyst
     with d_eff = deadzone(Delta + e_kin) (identity at nominal), g' its slope (1 at nominal).
  Output friction: "elastic reset integrator" (Haessig-Friedland style, written here):
     z_pred = z + v*h; z = clip(z_pred, -F_minus(v)/s0, +F_plus(v)/s0);
     F_f = s0*z + s1*v*[z not clipped at the last update] + fv_eff(v)*v,   s0 = 1.2e8 N m/rad (presliding
     displacement f_c/s0 ~ 2e-5 rad), s1 = 5.0e5 N m s/rad (damping of presliding only,
     zero while clipped). In steady sliding F_f = f_v*v + f_c*sgn(v) exactly (Eq. 4).
     Coulomb levels F_plus/F_minus = f_c + mu0*|T| + the effects' additions.
  Output balance (Eq. 4 + load): I*qdd = T - tau_L - g*(mr_x sin q + mr_y cos q) - F_f - tau_d
     (tau_d: out-of-vocabulary disturbances, zero at nominal).
  Motor side: 3 motors rigidly coupled to the reducer input, J_m = 3.2e-4 kg m^2 each plus
     2.0e-4 kg m^2 input stage -> J_u = (3*3.2e-4 + 2.0e-4)*N^2 = 1.4036e5 kg m^2 (output-ref).
     J_u*udd = N*sum_k kt_k(Tm_k)*i_k - T - f_mc*tanh(ud/1e-4) - f_mv*ud,
     f_mc = 600 N m, f_mv = 2.0e4 N m s/rad (output-referred motor/bearing/seal drag).
     kt_k = 1.25 N m/A * (1 + 0.015*xi_k) * (1 - 0.0012*(Tm_k - 20)).
  Drive (S120-like cascade, on the motor encoder): w_ref = v_ref + Kx*(q_ref - u),
     tau_dem = Kv*(w_ref - ud) + Integral(Ki*(w_ref - ud)), |tau_dem| <= 1.92e5 N m
     (conditional anti-windup), Kv = J_tot*8 1/s, Ki = Kv*2 1/s, Kx = 2 1/s, J_tot = J_u + I.
     q_ref/v_ref are the scheme's output references; the drive closes them on u (it does not
     compensate the twist). Start: at rest, q = 0, z = 0, u such that T = g*mr_y (gravity held).
     Load sharing: equal current reference for the three motors, i_ref = tau_dem/(N*3*1.25);
     each current loop a first-order lag tau_c = 1.0e-3 s (+-5 % per motor). Motor torques
     differ by their kt.
  Dynamometer (torque servo + reducer, its inertia lumped in I): second-order follower of its
     set point, tau_L'' = w_d^2*(c_d*tau_cmd - tau_L) - 2*0.7*w_d*tau_L', w_d = 25 rad/s,
     gain c_d = 1 + 0.0025*xi (error well inside +-2 kN m).
  Thermal: gearbox C_g dTg/dt = P_loss - (Tg - 22)/R_g, C_g = 3.0e4 J/K, R_g = 0.05 K/W,
     P_loss = |F_f*v| + |(f_mc tanh + f_mv ud)*ud| + D*dDelta^2.  Motors: C_m dTm/dt =
     R_w(1 + 0.0039(Tm-20))*i^2 - (Tm - 22)/R_m, C_m = 250 J/K, R_w = 1.6 ohm, R_m = 0.6 K/W.
     Start: Tg = temp_joint_c, Tm_k = temp_joint_c + 0.5*k.

Bench imperfections of its own (always present, scale-free, listed in UNSTATED_VOCABULARY):
  load_dependent_friction: mu0 = 5.0e-4 -> Coulomb level + mu0*|T| (60 N m at rated).
  gear_ripple: a kinematic error e0 = 2.0e-5 rad * sin(48*q + phi0) (48 cycles per output
     revolution) added to the twist.

Integrator: fixed-step semi-implicit (symplectic) Euler, substep h = 1/(fs*n_sub) with
n_sub = ceil((1/fs)/2.5e-4) so that h <= 2.5e-4 s; the friction state is projected
(implicit clip) every substep; filters use exact exponential updates. Readings are taken on
the sample instants t_j = j/fs.

Schemes (sense of period p (0-based): s_p = direction*(-1)^p, so the joint goes there and
back and stays within +-180 deg; speed ramps to s_p*v in 0.5 s, v = motor_speed_rpm*2pi/60/N):
  1: per period idle 1.0 s (accelerate), load 6 s (tau_cmd 0 -> 120 kN m linearly), unload
     6 s (-> 0), idle 1.0 s (decelerate in its last 0.5 s). 14 s/period.
  2: idle 1.0 s, 12 x [load 0.5 s ramp of +10 kN m, hold 2 s], unload 3 s, idle 1.0 s.
     35 s/period.
  3: idle 1.0 s then excite: q_ref = direction*sum_{l=1..5} [a_l/(w l) sin(w l t) -
     b_l/(w l) cos(w l t)] + q0 (Eq. 12), w = 2pi/30 s, a = c*(1.0, -0.4, 0.6, -0.8, -0.4),
     b = c*(0.8, 0.6, -0.6, 0.2, -0.2), c scaled so max|v_ref| = 0.024 rad/s; q0 such that
     q_ref(0) = 0 (sum a_l = 0 and sum l*b_l = 0: starts at rest). tau_cmd = 0.
     30 s/period.

Sensors (SensorSpec): output encoder q quantised at encoder_res_deg (round to nearest step);
motor encoder (motor 1) motor_counts_per_rev counts/motor rev -> u step 2pi/counts/N;
torque transducer: T through two cascaded first-order lags with tau = torque_lag_s/2 each
(DC group delay = torque_lag_s), then white noise sd torque_noise; load cell: tau_L + white
noise sd load_cell_noise (the dynamometer's tau_L, no lag); currents: i_k + noise current_noise, speeds: N*ud + noise
speed_noise; temperatures: + noise temp_noise, rounded to 0.1 degC. Defaults: 1000 Hz,
0.01 deg, torque_noise 150 N m, torque_lag_s 0.005 s, 65536 counts, load cell 100 N m, currents
0.02 A, speeds 0.2 rad/s, temperatures 0.05 degC. Noise from numpy default_rng([seed, run, 0x5E])
(always drawn in the same order, whatever the effects); the machine (and the effects' phases
phi0..phi6, uniform in [0, 2pi)) from default_rng([seed, 0x4A4]). Truth: t, q, qd, qdd, u, ud,
twist (= u - q), torque (T), torque_load, torque_sensor_filtered, friction (F_f), gravity, z,
x_hyst, disturbance, torque_cmd, temp_joint.

Effects (scale 1 = the "typical" size; contribution linear in scale; scale 0 = nominal):
  stribeck: Coulomb levels + s*0.15*f_c*phi(|v|/vs), vs = 2.0e-3 rad/s,
     phi: exp1 exp(-r), exp2 exp(-r^2), lorentzian 1/(1+r^2), exp_half exp(-sqrt(r)).
  load_dependent_friction (mu = 4e-3 * s): coulomb: + mu|T|; coulomb_viscous: + mu|T| and
     f_v*(1 + 12.5*mu*|T|/1.2e5); power_flow: + 1.5mu|T| if T*v > 0 (driving) else 0.5mu|T|.
  temperature_friction (Tg gearbox temperature, T_ref = 10 degC, dT = Tg - T_ref):
     viscous_exp_mult: f_v*(1 + s*0.4*(exp(-dT/25) - 1)); coulomb_additive: + s*(-4 N m/K)*dT;
     viscous_poly_mult: f_v*(1 + s*(-1e-2*dT + 1e-4*dT^2)); both_additive: f_c + s*(-3)*dT and
     viscous + s*(-12 N m s/rad/K)*dT.
  gear_ripple: output_harmonics: kinematic error s*2e-4*(sin(36q+p1) + 0.4 sin(72q+p2)) rad
     on the twist; motor_angle: s*8e-6*sin(2*N*u + p3) rad (2 per motor rev); load_modulated:
     T_el*(1 + s*4e-3*sin(36q + p1)).
  torque_offset (on the torque reading): constant s*300 N m; linear_drift s*300*t/60 N m;
     settling s*400*(1 - exp(-t/30)) N m.
  time_delay (extra pure delay d = s*0.02 s, linear interpolation of the sampled channel):
     torque, encoder (q), motor_encoder (u).
  hysteresis (transmission, + s*k_h*x, k_h*x_y = 1500 N m, x_y = 2e-4 rad, x driven by dDelta):
     bouc_wen_n1: dx = dDelta*(1 - (0.5 + 0.5 sgn(dDelta x))|x/x_y|); bouc_wen_n3: same with
     |x/x_y|^3; elastoplastic: x = clip(x + dDelta, +-x_y).
  backlash (half gap b = s*1.5e-4 rad): sharp: dz(d) = sgn(d)max(|d|-b, 0); smooth:
     d - b*tanh(d/b); preload_closing: sharp with b*exp(-|tau_cmd|/2e4).
  asymmetric_friction: coulomb: f_c*(1 +- s*0.08) for v >< 0; viscous: f_v*(1 +- s*0.2);
     coulomb_viscous: both.
  OUT OF VOCABULARY:
  periodic_disturbance: sine: tau_d = s*250 sin(2pi 1.7 t + p4); pump: s*180*(sin(wt) +
     0.6 sin(2wt+p5) + 0.3 sin(3wt)), w = 2pi*0.8.
  position_dependent_stiffness: T_el*(1 + s*0.06 cos(6q + p6)) [cosine6]; T_el*(1 + s*0.1*q)
     [linear].
  encoder_drift: q reading + s*3e-4 rad*t/60 [linear]; + s*3e-4 rad*W(t/60) [random_walk,
     W a unit Wiener path from the run's generator].
  second_resonance: appendage J_a = s*0.15*I on the output at 3.5 Hz, zeta 0.03 [appendage];
     a motor-side mass s*0.05*J_u at 25 Hz, zeta 0.05 [motor_side].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from datetime import datetime, timedelta, timezone

import numba
import numpy as np
import pandas as pd

RIG_NAME = "rig_y"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.660}
G = 9.81
SPREAD_SD = 0.02
SPREAD_CLIP = 2.5
RATED_TORQUE = 120e3
RATED_TWIST = math.radians(0.5)
K1_NOM = 0.7 * RATED_TORQUE / RATED_TWIST
K3_NOM = 0.3 * RATED_TORQUE / RATED_TWIST ** 3

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exp1", "exp2", "lorentzian", "exp_half"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow"),
    "temperature_friction": ("viscous_exp_mult", "coulomb_additive", "viscous_poly_mult",
                             "both_additive"),
    "gear_ripple": ("output_harmonics", "motor_angle", "load_modulated"),
    "torque_offset": ("constant", "linear_drift", "settling"),
    "time_delay": ("torque", "encoder", "motor_encoder"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n3", "elastoplastic"),
    "backlash": ("sharp", "smooth", "preload_closing"),
    "asymmetric_friction": ("coulomb", "viscous", "coulomb_viscous"),
    "periodic_disturbance": ("sine", "pump"),
    "position_dependent_stiffness": ("cosine6", "linear"),
    "encoder_drift": ("linear", "random_walk"),
    "second_resonance": ("appendage", "motor_side"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "encoder_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "load_dependent_friction": "output Coulomb level + 5e-4*|T| (about 60 N m at the rated 120 kN m)",
    "gear_ripple": "kinematic error 2e-5 rad * sin(48 q + phi0) on the twist (48 per output rev)",
}

# order of effects in the kernel's code arrays
_EFF = list(EFFECT_FORMS)
_EI = {n: i for i, n in enumerate(_EFF)}


@dataclass
class SensorSpec:
    sample_rate_hz: float = 1000.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0
    torque_lag_s: float = 0.005
    motor_counts_per_rev: float = 65536.0
    load_cell_noise: float = 100.0
    current_noise: float = 0.02
    speed_noise: float = 0.2
    temp_noise: float = 0.05

    _RANGES = {"sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-5, 0.1),
               "torque_noise": (0.0, 5000.0), "torque_lag_s": (0.0, 0.5),
               "motor_counts_per_rev": (64.0, 2.0 ** 24), "load_cell_noise": (0.0, 5000.0),
               "current_noise": (0.0, 1.0), "speed_noise": (0.0, 10.0), "temp_noise": (0.0, 2.0)}

    def __post_init__(self):
        self.validate()

    def validate(self):
        for f in fields(self):
            v = getattr(self, f.name)
            lo, hi = self._RANGES[f.name]
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise ValueError(f"SensorSpec.{f.name}: expected a number, got {v!r}")
            if not math.isfinite(float(v)) or not (lo <= float(v) <= hi):
                raise ValueError(f"SensorSpec.{f.name}: {v!r} outside [{lo}, {hi}]")



@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict = field(default_factory=dict)


# --- machine ----------------------------------------------------------------------------------

def draw_machine(seed: int) -> dict:
    """The campaign's machine: nominal * (1 + 0.02 xi), xi ~ N(0,1) clipped at +-2.5."""
    rng = np.random.default_rng([int(seed), 0x4A4])
    names = ["I", "mr_x", "mr_y", "f_v", "f_c", "k", "D", "s0", "s1", "J_u", "f_mc", "f_mv"]
    xi = np.clip(rng.standard_normal(len(names)), -SPREAD_CLIP, SPREAD_CLIP)
    nom = dict(TABLE3, k=1.0, D=8.0e4, s0=1.2e8, s1=5.0e5,
               J_u=(3 * 3.2e-4 + 2.0e-4) * REDUCTION ** 2, f_mc=600.0, f_mv=2.0e4)
    m = {n: nom[n] * (1.0 + SPREAD_SD * x) for n, x in zip(names, xi)}
    m["k1"] = K1_NOM * m.pop("k")
    m["k3"] = K3_NOM * m["k1"] / K1_NOM
    kt = 1.25 * (1 + 0.015 * np.clip(rng.standard_normal(3), -2.5, 2.5))
    tc = 1.0e-3 * (1 + 0.05 * np.clip(rng.standard_normal(3), -2.5, 2.5))
    m["kt"] = [float(v) for v in kt]
    m["tau_c"] = [float(v) for v in tc]
    m["dyn_gain"] = float(1 + 0.0025 * np.clip(rng.standard_normal(), -2.5, 2.5))
    ph = rng.uniform(0, 2 * np.pi, 8)
    m["phases"] = [float(v) for v in ph]
    m["mu0"] = 5.0e-4
    m["e0"] = 2.0e-5
    return {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in m.items()}


def twist_at(m: dict, torque: float) -> float:
    """Static twist [rad] of the nominal transmission at a torque (solves k1 d + k3 d^3 = T)."""
    d = torque / m["k1"]
    for _ in range(60):
        d -= (m["k1"] * d + m["k3"] * d ** 3 - torque) / (m["k1"] + 3 * m["k3"] * d ** 2)
    return d


# --- references -------------------------------------------------------------------------------

PH_IDLE, PH_LOAD, PH_HOLD, PH_UNLOAD, PH_EXCITE = range(5)
PHASE_NAMES = np.array(["idle", "load", "hold", "unload", "excite"], dtype=object)
_A = np.array([1.0, -0.4, 0.6, -0.8, -0.4])
_B = np.array([0.8, 0.6, -0.6, 0.2, -0.2])
T_F = 30.0


def _segments(scheme: int) -> list[tuple[float, int, float, float]]:
    """One period as (duration, phase, tau_cmd at start, tau_cmd at end)."""
    if scheme == 1:
        return [(1.0, PH_IDLE, 0, 0), (6.0, PH_LOAD, 0, RATED_TORQUE),
                (6.0, PH_UNLOAD, RATED_TORQUE, 0), (1.0, PH_IDLE, 0, 0)]
    seg = [(1.0, PH_IDLE, 0.0, 0.0)]
    for j in range(12):
        seg += [(0.5, PH_LOAD, 1e4 * j, 1e4 * (j + 1)), (2.0, PH_HOLD, 1e4 * (j + 1), 1e4 * (j + 1))]
    seg += [(3.0, PH_UNLOAD, RATED_TORQUE, 0.0), (1.0, PH_IDLE, 0.0, 0.0)]
    return seg


def _references(scheme, speed_rpm, direction, periods, t):
    """q_ref, v_ref, tau_cmd, phase on the time grid t."""
    n = len(t)
    qr, vr, tc = np.zeros(n), np.zeros(n), np.zeros(n)
    ph = np.zeros(n, dtype=np.int64)
    if scheme == 3:
        w = 2 * np.pi / T_F
        l = np.arange(1, 6)
        tt = np.linspace(0, T_F, 6001)
        vv = (_A[:, None] * np.cos(w * l[:, None] * tt) + _B[:, None] * np.sin(w * l[:, None] * tt)).sum(0)
        c = 0.024 / np.abs(vv).max()
        a, b = c * _A, c * _B
        te = np.maximum(t - 1.0, 0.0)
        arg = w * l[:, None] * te[None, :]
        q = ((a / (w * l))[:, None] * np.sin(arg) - (b / (w * l))[:, None] * np.cos(arg)).sum(0)
        q += (b / (w * l)).sum()
        v = (a[:, None] * np.cos(arg) + b[:, None] * np.sin(arg)).sum(0)
        on = t >= 1.0
        qr = direction * np.where(on, q, 0.0)
        vr = direction * np.where(on, v, 0.0)
        ph[:] = np.where(on, PH_EXCITE, PH_IDLE)
        return qr, vr, tc, ph
    vmax = speed_rpm * 2 * np.pi / 60 / REDUCTION
    seg = _segments(scheme)
    per = sum(s[0] for s in seg)
    k = np.minimum((t // per).astype(np.int64), periods - 1)
    tp = t - k * per
    sense = direction * np.where(k % 2 == 0, 1.0, -1.0)
    prof = np.clip(tp / 0.5, 0, 1) * np.clip((per - tp) / 0.5, 0, 1)
    vr = sense * vmax * prof
    start = 0.0
    for dur, p, a0, a1 in seg:
        m = (tp >= start) & (tp < start + dur + (1e-9 if start + dur >= per - 1e-9 else 0))
        tc[m] = a0 + (a1 - a0) * (tp[m] - start) / dur
        ph[m] = p
        start += dur
    dt = np.diff(t, prepend=t[0])
    qr = np.cumsum(0.5 * (vr + np.concatenate([[vr[0]], vr[:-1]])) * dt)
    return qr, vr, tc, ph


def run_duration(scheme: int, periods: int) -> float:
    if scheme == 3:
        return 1.0 + T_F * periods
    return sum(s[0] for s in _segments(scheme)) * periods


# --- the kernel -------------------------------------------------------------------------------

_P = ["I", "mr_x", "mr_y", "f_v", "f_c", "k1", "k3", "D", "s0", "s1", "J_u", "f_mc", "f_mv",
      "kt1", "kt2", "kt3", "tc1", "tc2", "tc3", "dyn_gain", "mu0", "e0", "ph0", "ph1", "ph2",
      "ph3", "ph4", "ph5", "ph6", "lag", "Tg0", "Kv", "Ki", "Kx"]
_PI = {n: i for i, n in enumerate(_P)}
N_TRUTH = 22


@numba.njit(cache=True)
def _kernel(P, code, sc, qref, vref, tcmd, h, nsub, nsamp, out):
    N = 11000.0
    I = P[0]; mrx = P[1]; mry = P[2]; fv = P[3]; fc = P[4]; k1 = P[5]; k3 = P[6]; D = P[7]
    s0 = P[8]; s1 = P[9]; Ju = P[10]; fmc = P[11]; fmv = P[12]
    kt = P[13:16]; tcur = P[16:19]; dg = P[19]; mu0 = P[20]; e0 = P[21]
    ph0 = P[22]; ph1 = P[23]; ph2 = P[24]; ph3 = P[25]; ph4 = P[26]; ph5 = P[27]; ph6 = P[28]
    lag = P[29]; Kv = P[31]; Ki = P[32]; Kx = P[33]
    g = 9.81
    c_str = code[0]; s_str = sc[0]; c_ldf = code[1]; s_ldf = sc[1]; c_tf = code[2]; s_tf = sc[2]
    c_gr = code[3]; s_gr = sc[3]; c_hy = code[6]; s_hy = sc[6]; c_bl = code[7]; s_bl = sc[7]
    c_as = code[8]; s_as = sc[8]; c_pd = code[9]; s_pd = sc[9]; c_ps = code[10]; s_ps = sc[10]
    c_sr = code[12]; s_sr = sc[12]
    # states
    q = 0.0; qd = 0.0; u = 0.0; ud = 0.0; z = 0.0; xh = 0.0
    stuck = True
    Tg = P[30]; Tm = np.empty(3)
    for k in range(3):
        Tm[k] = Tg + 0.5 * (k + 1)
    tL = 0.0; tLd = 0.0
    # initial static equilibrium: T_el(d0) = gravity at q = 0
    Tgrav0 = g * mry
    d = Tgrav0 / k1
    for it in range(50):
        d -= (k1 * d + k3 * d * d * d - Tgrav0) / (k1 + 3 * k3 * d * d)
    u = d - e0 * np.sin(ph0)
    xi = Tgrav0
    cur = np.empty(3)
    ktsum = 3 * 1.25
    for k in range(3):
        cur[k] = Tgrav0 / (N * ktsum)
    f1 = Tgrav0; f2 = Tgrav0
    # appendage / motor-side mode
    Ja = 0.0; ka = 0.0; ca = 0.0; pa = 0.0; pad = 0.0
    if c_sr == 1:
        Ja = s_sr * 0.15 * I; wa = 2 * np.pi * 3.5; ka = Ja * wa * wa; ca = 2 * 0.03 * Ja * wa
    elif c_sr == 2:
        Ja = s_sr * 0.05 * Ju; wa = 2 * np.pi * 25.0; ka = Ja * wa * wa; ca = 2 * 0.05 * Ja * wa
    if c_sr == 1:
        pa = 0.0
    elif c_sr == 2:
        pa = u
    al = 0.0
    if lag > 0:
        al = 1.0 - np.exp(-h / (0.5 * lag))
    wd = 25.0
    Tw = 0.0; Tq = 0.0; F = 0.0; Tgv = 0.0; qdd = 0.0; td = 0.0
    for j in range(nsamp):
        for s in range(nsub):
            idx = j * nsub + s
            t = idx * h
            tc_ = tcmd[idx]
            # drive
            wref = vref[idx] + Kx * (qref[idx] - u)
            ev = wref - ud
            tdem = Kv * ev + xi
            tmax = 1.92e5
            if tdem > tmax:
                tdem = tmax
            elif tdem < -tmax:
                tdem = -tmax
            else:
                xi += Ki * ev * h
            iref = tdem / (N * ktsum)
            tm = 0.0
            for k in range(3):
                cur[k] += (iref - cur[k]) * (1.0 - np.exp(-h / tcur[k]))
                tm += N * kt[k] * (1.0 - 0.0012 * (Tm[k] - 20.0)) * cur[k]
            # transmission
            Dl = u - q
            Dld = ud - qd
            e = e0 * np.sin(48.0 * q + ph0)
            if c_gr == 1:
                e += s_gr * 2e-4 * (np.sin(36.0 * q + ph1) + 0.4 * np.sin(72.0 * q + ph2))
            elif c_gr == 2:
                e += s_gr * 8e-6 * np.sin(2.0 * N * u + ph3)
            de = Dl + e
            slope = 1.0
            if c_bl > 0:
                b = s_bl * 1.5e-4
                if c_bl == 3:
                    b = b * np.exp(-abs(tc_) / 2e4)
                if c_bl == 2:
                    th = np.tanh(de / b)
                    de = de - b * th
                    slope = th * th
                else:
                    if de > b:
                        de = de - b
                    elif de < -b:
                        de = de + b
                    else:
                        de = 0.0
                        slope = 0.0
            Tel = k1 * de + k3 * de * de * de
            if c_gr == 3:
                Tel *= 1.0 + s_gr * 4e-3 * np.sin(36.0 * q + ph1)
            if c_ps == 1:
                Tel *= 1.0 + s_ps * 0.06 * np.cos(6.0 * q + ph6)
            elif c_ps == 2:
                Tel *= 1.0 + s_ps * 0.1 * q
            Th = 0.0
            if c_hy > 0:
                Th = s_hy * 1500.0 * xh / 2e-4
            T = Tel + D * slope * Dld + Th
            # friction levels
            v = qd
            av = abs(v)
            fcp = fc + mu0 * abs(T)
            fcm = fcp
            fvp = fv
            fvm = fv
            if c_str > 0:
                r = av / 2e-3
                if c_str == 1:
                    phi = np.exp(-r)
                elif c_str == 2:
                    phi = np.exp(-r * r)
                elif c_str == 3:
                    phi = 1.0 / (1.0 + r * r)
                else:
                    phi = np.exp(-np.sqrt(r))
                fcp += s_str * 0.15 * fc * phi
                fcm += s_str * 0.15 * fc * phi
            if c_ldf > 0:
                mu = s_ldf * 4e-3
                if c_ldf == 1:
                    fcp += mu * abs(T); fcm += mu * abs(T)
                elif c_ldf == 2:
                    fcp += mu * abs(T); fcm += mu * abs(T)
                    fvp *= 1.0 + 12.5 * mu * abs(T) / 1.2e5
                    fvm *= 1.0 + 12.5 * mu * abs(T) / 1.2e5
                else:
                    if T * v > 0:
                        fcp += 1.5 * mu * abs(T); fcm += 1.5 * mu * abs(T)
                    else:
                        fcp += 0.5 * mu * abs(T); fcm += 0.5 * mu * abs(T)
            if c_tf > 0:
                dT = Tg - 10.0
                if c_tf == 1:
                    m_ = 1.0 + s_tf * 0.4 * (np.exp(-dT / 25.0) - 1.0)
                    fvp *= m_; fvm *= m_
                elif c_tf == 2:
                    fcp += s_tf * (-4.0) * dT; fcm += s_tf * (-4.0) * dT
                elif c_tf == 3:
                    m_ = 1.0 + s_tf * (-1e-2 * dT + 1e-4 * dT * dT)
                    fvp *= m_; fvm *= m_
                else:
                    fcp += s_tf * (-3.0) * dT; fcm += s_tf * (-3.0) * dT
                    fvp += s_tf * (-12.0) * dT; fvm += s_tf * (-12.0) * dT
            if c_as > 0:
                if c_as == 1 or c_as == 3:
                    fcp *= 1.0 + s_as * 0.08; fcm *= 1.0 - s_as * 0.08
                if c_as == 2 or c_as == 3:
                    fvp *= 1.0 + s_as * 0.2; fvm *= 1.0 - s_as * 0.2
            fvv = fvp if v >= 0 else fvm
            zhi = fcp / s0
            zlo = -fcm / s0
            # friction force from current z (elastic damping only inside the band)
            F = s0 * z + fvv * v
            if stuck:
                F += s1 * v
            Tgv = g * (mrx * np.sin(q) + mry * np.cos(q))
            # out-of-vocabulary output torques
            td = 0.0
            if c_pd == 1:
                td = s_pd * 250.0 * np.sin(2 * np.pi * 1.7 * t + ph4)
            elif c_pd == 2:
                w = 2 * np.pi * 0.8
                td = s_pd * 180.0 * (np.sin(w * t) + 0.6 * np.sin(2 * w * t + ph5) + 0.3 * np.sin(3 * w * t))
            Tapp_o = 0.0; Tapp_m = 0.0
            if c_sr == 1:
                Ta = ka * (pa - q) + ca * (pad - qd)
                Tapp_o = Ta
                pad += -Ta / Ja * h
                pa += pad * h
            elif c_sr == 2:
                Ta = ka * (pa - u) + ca * (pad - ud)
                Tapp_m = Ta
                pad += -Ta / Ja * h
                pa += pad * h
            qdd = (T - tL - Tgv - F - td + Tapp_o) / I
            fm = fmc * np.tanh(ud / 1e-4) + fmv * ud
            udd = (tm - T - fm + Tapp_m) / Ju
            # dynamometer
            tLdd = wd * wd * (dg * tc_ - tL) - 2 * 0.7 * wd * tLd
            # gear/motor thermal
            Ploss = abs(F * qd) + abs(fm * ud) + D * Dld * Dld
            Tg += h * (Ploss - (Tg - 22.0) / 0.05) / 3.0e4
            for k in range(3):
                Pcu = 1.6 * (1 + 0.0039 * (Tm[k] - 20.0)) * cur[k] * cur[k]
                Tm[k] += h * (Pcu - (Tm[k] - 22.0) / 0.6) / 250.0
            # transducer filter (two first-order stages)
            if lag > 0:
                f1 += al * (T - f1)
                f2 += al * (f1 - f2)
            else:
                f1 = T; f2 = T
            Tq = T
            if s == 0:
                o = out[j]
                o[0] = t; o[1] = q; o[2] = qd; o[3] = qdd; o[4] = u; o[5] = ud
                o[6] = T; o[7] = tL; o[8] = f2; o[9] = cur[0]; o[10] = cur[1]; o[11] = cur[2]
                o[12] = Tg; o[13] = Tm[0]; o[14] = Tm[1]; o[15] = Tm[2]; o[16] = F
                o[17] = Tgv; o[18] = z; o[19] = xh; o[20] = td - Tapp_o; o[21] = tc_
            # integrate (semi-implicit Euler)
            qd += h * qdd
            ud += h * udd
            q += h * qd
            u += h * ud
            tLd += h * tLdd
            tL += h * tLd
            # friction state: reset integrator with projection
            z += h * qd
            stuck = True
            if z >= zhi:
                z = zhi
                stuck = False
            elif z <= zlo:
                z = zlo
                stuck = False
            # hysteresis state driven by the twist increment
            if c_hy > 0:
                dD = h * (ud - qd)
                xy = 2e-4
                if c_hy == 3:
                    xh += dD
                    if xh > xy:
                        xh = xy
                    elif xh < -xy:
                        xh = -xy
                else:
                    nexp = 1.0 if c_hy == 1 else 3.0
                    if dD * xh > 0:
                        xh += dD * (1.0 - abs(xh / xy) ** nexp)
                    else:
                        xh += dD
    return out


# --- the run ----------------------------------------------------------------------------------

def _check_effects(effects):
    codes = np.zeros(len(_EFF), dtype=np.int64)
    scales = np.zeros(len(_EFF))
    spec = {}
    if effects is None:
        return codes, scales, spec
    if not isinstance(effects, dict):
        raise ValueError(f"effects: expected a dict name -> {{form, scale}}, got {effects!r}")
    for name, e in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(e, dict) or "form" not in e or "scale" not in e:
            raise ValueError(f"effects[{name!r}]: expected {{'form': ..., 'scale': ...}}")
        form = e["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}].form: unknown form {form!r}; "
                             f"known: {EFFECT_FORMS[name]}")
        s = e["scale"]
        if isinstance(s, bool) or not isinstance(s, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(s)) or s < 0 or s > SCALE_MAX:
            raise ValueError(f"effects[{name!r}].scale: must be a finite number in "
                             f"[0, {SCALE_MAX}], got {s!r}")
        spec[name] = {"form": form, "scale": float(s)}
        if float(s) > 0:
            codes[_EI[name]] = EFFECT_FORMS[name].index(form) + 1
            scales[_EI[name]] = float(s)
    return codes, scales, spec


def _num(name, v, lo, hi, integer=False):
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected a number, got {v!r}")
    if not math.isfinite(float(v)) or not lo <= float(v) <= hi:
        raise ValueError(f"{name}: {v!r} outside [{lo}, {hi}]")
    if integer and float(v) != int(v):
        raise ValueError(f"{name}: expected an integer, got {v!r}")


def _delay(t, y, d):
    return np.interp(t - d, t, y) if d > 0 else y


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    if isinstance(scheme, bool) or scheme not in (1, 2, 3):
        raise ValueError(f"scheme: expected 1, 2 or 3, got {scheme!r}")
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm: must be None for scheme 3, got {motor_speed_rpm!r}")
    else:
        _num("motor_speed_rpm", motor_speed_rpm, 10.0, 3000.0)
    if isinstance(direction, bool) or direction not in (1, -1):
        raise ValueError(f"direction: expected +1 or -1, got {direction!r}")
    _num("temp_joint_c", temp_joint_c, 15.0, 60.0)
    _num("periods", periods, 1, 20, integer=True)
    _num("seed", seed, 0, 2 ** 63 - 1, integer=True)
    _num("run", run, 0, 2 ** 31 - 1, integer=True)
    sensors = SensorSpec() if sensors is None else sensors
    if not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors: expected a SensorSpec, got {sensors!r}")
    sensors.validate()
    codes, scales, espec = _check_effects(effects)
    periods = int(periods); seed = int(seed); run = int(run); direction = int(direction)

    m = draw_machine(seed)
    fs = float(sensors.sample_rate_hz)
    nsub = int(math.ceil((1.0 / fs) / 2.5e-4 - 1e-9))
    h = 1.0 / (fs * nsub)
    dur = run_duration(scheme, periods)
    nsamp = int(round(dur * fs))
    tgrid = np.arange(nsamp * nsub + 1) * h
    qr, vr, tc, ph = _references(scheme, motor_speed_rpm, direction, periods, tgrid)
    Jt = m["J_u"] + m["I"]
    Kv = Jt * 8.0
    P = np.zeros(len(_P))
    vals = dict(m, kt1=m["kt"][0], kt2=m["kt"][1], kt3=m["kt"][2], tc1=m["tau_c"][0],
                tc2=m["tau_c"][1], tc3=m["tau_c"][2], lag=float(sensors.torque_lag_s),
                Tg0=float(temp_joint_c), Kv=Kv, Ki=Kv * 2.0, Kx=2.0)
    for i in range(7):
        vals[f"ph{i}"] = m["phases"][i]
    for n_, i in _PI.items():
        P[i] = vals[n_]
    out = np.zeros((nsamp, N_TRUTH))
    _kernel(P, codes, scales, qr, vr, tc, h, nsub, nsamp, out)

    t = out[:, 0].copy()
    t = np.round(np.arange(nsamp) / fs, 9)
    truth = pd.DataFrame({
        "t": t, "q": out[:, 1], "qd": out[:, 2], "qdd": out[:, 3], "u": out[:, 4],
        "ud": out[:, 5], "twist": out[:, 4] - out[:, 1], "torque": out[:, 6],
        "torque_load": out[:, 7], "torque_sensor_filtered": out[:, 8], "friction": out[:, 16],
        "gravity": out[:, 17], "z": out[:, 18], "x_hyst": out[:, 19],
        "disturbance": out[:, 20], "torque_cmd": out[:, 21], "temp_joint": out[:, 12]})

    # --- readings
    rng = np.random.default_rng([seed, run, 0x5E])
    nz = lambda sd: rng.standard_normal(nsamp) * sd  # noqa: E731  always drawn, same order
    n_tq, n_lc = nz(sensors.torque_noise), nz(sensors.load_cell_noise)
    n_i = [nz(sensors.current_noise) for _ in range(3)]
    n_w = [nz(sensors.speed_noise) for _ in range(3)]
    n_T = [nz(sensors.temp_noise) for _ in range(4)]
    walk = np.cumsum(rng.standard_normal(nsamp)) * math.sqrt(1.0 / fs / 60.0)

    d_td = 0.02 * scales[_EI["time_delay"]]
    f_td = codes[_EI["time_delay"]]
    q_true = _delay(t, out[:, 1], d_td if f_td == 2 else 0.0)
    c_ed, s_ed = codes[_EI["encoder_drift"]], scales[_EI["encoder_drift"]]
    if c_ed == 1:
        q_true = q_true + s_ed * 3e-4 * t / 60.0
    elif c_ed == 2:
        q_true = q_true + s_ed * 3e-4 * walk
    qres = math.radians(sensors.encoder_res_deg)
    q_read = np.round(q_true / qres) * qres
    ures = 2 * np.pi / sensors.motor_counts_per_rev / REDUCTION
    u_true = _delay(t, out[:, 4], d_td if f_td == 3 else 0.0)
    u_read = np.round(u_true / ures) * ures
    tq = _delay(t, out[:, 8], d_td if f_td == 1 else 0.0)
    c_to, s_to = codes[_EI["torque_offset"]], scales[_EI["torque_offset"]]
    if c_to == 1:
        tq = tq + s_to * 300.0
    elif c_to == 2:
        tq = tq + s_to * 300.0 * t / 60.0
    elif c_to == 3:
        tq = tq + s_to * 400.0 * (1 - np.exp(-t / 30.0))
    tq = tq + n_tq
    samples = pd.DataFrame({
        "t": t, "q": q_read, "u": u_read, "torsion": q_read - u_read, "torque": tq,
        "torque_load": out[:, 7] + n_lc, "torque_cmd": out[:, 21],
        "i_m1": out[:, 9] + n_i[0], "i_m2": out[:, 10] + n_i[1], "i_m3": out[:, 11] + n_i[2],
        "w_m1": REDUCTION * out[:, 5] + n_w[0], "w_m2": REDUCTION * out[:, 5] + n_w[1],
        "w_m3": REDUCTION * out[:, 5] + n_w[2],
        "temp_joint": np.round((out[:, 12] + n_T[0]) * 10) / 10,
        "temp_m1": np.round((out[:, 13] + n_T[1]) * 10) / 10,
        "temp_m2": np.round((out[:, 14] + n_T[2]) * 10) / 10,
        "temp_m3": np.round((out[:, 15] + n_T[3]) * 10) / 10,
    })
    samples["phase"] = pd.Series(PHASE_NAMES[ph[:nsamp * nsub:nsub]], dtype=object)

    started = datetime(2026, 1, 1, tzinfo=timezone.utc) + timedelta(days=seed % 1000, minutes=10 * run)
    sens = {"q": {"resolution": qres, "noise_sd": 0.0, "lag_s": 0.0},
            "u": {"resolution": ures, "noise_sd": 0.0, "lag_s": 0.0},
            "torque": {"resolution": 0.0, "noise_sd": float(sensors.torque_noise),
                       "lag_s": float(sensors.torque_lag_s)},
            "torque_load": {"resolution": 0.0, "noise_sd": float(sensors.load_cell_noise), "lag_s": 0.0},
            "torque_cmd": {"resolution": 0.0, "noise_sd": 0.0, "lag_s": 0.0}}
    for k in (1, 2, 3):
        sens[f"i_m{k}"] = {"resolution": 0.0, "noise_sd": float(sensors.current_noise), "lag_s": 0.0}
        sens[f"w_m{k}"] = {"resolution": 0.0, "noise_sd": float(sensors.speed_noise), "lag_s": 0.0}
    for c in ("temp_joint", "temp_m1", "temp_m2", "temp_m3"):
        sens[c] = {"resolution": 0.1, "noise_sd": float(sensors.temp_noise), "lag_s": 0.0}
    meta = {"scheme": int(scheme), "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
            "direction": direction, "reduction": REDUCTION, "rig": RIG_NAME, "source": "emulator",
            "sample_rate_hz": fs, "started_at": started.isoformat().replace("+00:00", "Z"),
            "notes": f"rig_y campaign seed {seed} run {run}", "sensors": sens}
    params = {"machine": m, "effects": espec, "sensors": {f.name: getattr(sensors, f.name)
                                                           for f in fields(sensors)},
              "seed": seed, "run": run, "scheme": int(scheme), "motor_speed_rpm": motor_speed_rpm,
              "direction": direction, "temp_joint_c": float(temp_joint_c), "periods": periods,
              "substep_s": h, "unstated": dict(UNSTATED_VOCABULARY)}
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
