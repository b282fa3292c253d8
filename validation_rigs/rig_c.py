"""Validation rig C: an independently written model of the J4 heavy-joint test rig.

Used only to score the sim-to-real diagnosis blind. It imports nothing of this repository and is
modelled in its own way (Maxwell-slip friction, three speed-controlled motors, a motor-side drive
train, a fixed-step RK4 inside one numba loop, a torque transducer with an anti-alias filter).

Data sheet (SI units; angles and rates referred to the joint output; ``N = 11000``)
===================================================================================

State: output angle ``q``, rate ``v = q̇``; motor angle referred to the output ``u`` (the three
motors are rigidly geared to one another), rate ``u̇``; motor currents ``i_k`` and speed-loop
integrators ``ξ_k`` (k = 1..3); dynamometer torque ``τ_L``; joint temperature ``θ`` (°C).

Output side (the torque sensor sits between the gearbox and the output; output friction acts
after it)::

    I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − F_f − τ_ext
    F_f = Σ_j F_j + f_v·v                      (Maxwell-slip friction, 3 elements)
    F_j = κ_j·z_j,  z_j = clip(z_j(t0) + q − q(t0), −α_j·F_c⁻/κ_j, +α_j·F_c⁺/κ_j)
    κ_j = α_j·F_c/δ_j,   α = (0.5, 0.3, 0.2),  δ = (0.4, 1.2, 3.0)·10⁻⁴ rad

Each element is an elasto-plastic spring that slips at its share of the Coulomb level: presliding
hysteresis at reversals (the friction rebuilds over ~3·10⁻⁴ rad) and, in steady sliding, exactly
``F_f = F_c·sgn(v) + f_v·v``. Nominally ``F_c⁺ = F_c⁻ = F_c``; friction effects change the levels.

Transmission (twist ``Δ = u − q``; ``e`` a kinematic error, 0 unless gear_ripple)::

    Δ_s = Δ − e,   T = k·B(Δ_s) + D·Δ̇_s + H          B(x) = x nominally (no backlash), H = 0

Motor side (three motors, each with its own PI speed loop, first-order current loop, torque
constant; motor-side friction and the reducer's load-dependent loss act BEFORE the torque
sensor, so they do not enter the output balance)::

    J_M·ü = N·η·Σ_k K_t,k·i_k − T − F_m
    F_m = (F_cm + μ_m·|T|)·tanh(u̇/ε_m) + f_vm·u̇,     ε_m = 10⁻⁴ rad/s
    e_k = N·(ω_ref − u̇),  i*_k = sat(K_p,k·e_k + ξ_k, ±i_max),  ξ̇_k = K_i,k·e_k (anti-windup)
    τ_i·di_k/dt = i*_k − i_k
    ω_ref = set speed (schemes 1, 2);  ω_ref = q̇_d + K_pos·(q_d − u) (scheme 3)

Dynamometer: ``τ_d·τ̇_L = τ_L* − τ_L`` with ``τ_L*`` the set point plus a per-run error (gain,
bias and a slow wander, inside ±1.9 kN·m, zero when unloaded).
Joint temperature: ``C_θ·θ̇ = |F_f·v| + |F_m·u̇| − (θ − θ_amb)/R_θ`` (starts at the caller's
temperature, relaxes toward a per-run ambient near 22 °C: it drifts within long runs).

Nominal values (each perturbed by a few % per campaign seed, the same rig for all runs of a
campaign): I = 6700 kg·m², mr = (20.8, −34.5) kg·m, f_v = 8683 N·m·s/rad, F_c = 2353 N·m,
k = 120 kN·m / 0.5° = 1.375·10⁷ N·m/rad, D = 3·10⁴ N·m·s/rad, J_M = 5·10⁵ kg·m², η = 0.9,
K_t ≈ 0.9 N·m/A, i_max = 12 A, τ_i = 2 ms, F_cm = 3300 N·m, f_vm = 2·10⁴ N·m·s/rad, μ_m = 0.03,
τ_d = 50 ms, C_θ = 2·10⁵ J/K, R_θ = 0.01 K/W.

Integration: fixed-step RK4, step ``h = 1/(f_s·m) ≤ 1 ms`` (sample times on the grid); the
Maxwell-slip and play-operator states are held at the step start inside a step and committed at
its end (continuous in the state within a step, so RK4 stays 4th order between slips).

Schemes: 1 — constant speed, τ_L ramped 0 → 120 kN·m in 40 s, held 5 s, ramped back in 40 s
(100 s); 2 — constant speed, τ_L in 10 kN·m steps every 2.5 s (0.5 s "load" + 2 s "hold") to
120 kN·m, held 4 s, ramped down in 12 s (60 s); 3 — fifth-order Fourier trajectory (period 20 s,
``q̇_d = Σ a_l cos(lω_f t) + b_l sin(lω_f t)``, peak 0.9·0.02856 rad/s) for ``periods`` periods
with 3 s rests either side, no load. ``direction`` signs the motion.

Sensors (``SensorSpec``): output encoder rounded to ``encoder_res_deg``; motor encoder
``motor_encoder_bits`` per motor revolution; ``qd``/``ud`` are backward differences of the
quantised encoders over ``max(1/f_s, 20 ms)``; torque transducer = 2nd-order Butterworth
anti-alias filter (cut-off ``min(0.3·f_s, 150 Hz)``) after a transport lag ``torque_lag_s``,
then white noise (``torque_noise``) and a 16-bit ADC over ±200 kN·m; load cell = white noise
(``load_noise``) and the same ADC; all channels sample-and-hold at ``f_s``; temperature 0.1 °C;
motor currents ``i_m1..3`` (+ white noise ``current_noise``) and speeds ``w_m1..3 = N·ud``
(+ 0.05 rad/s noise). ``meta["sensors"]`` states it: ``torque.noise_sd = √(sd² + step²/12)``
(ADC folded in), ``torque.lag_s = torque_lag_s + √2/(2π·f_aa)`` (the filter's group delay).

Truth (noise-free, at the sample times): q, qd, qdd, u, ud, torque (the reading chain without
noise or ADC: after offsets, delays and the anti-alias filter), torque_load (reading without
noise), twist (Δ = u − q), twist_rate, torque_joint (T), torque_load_true (τ_L),
friction_output (F_f), friction_motor (F_m), kinematic_error (e), temp_joint (θ).
Friction levels changed by effects are floored at 5 % of the nominal F_c, f_v.

Effects (``effects = {name: {"form": str, "scale": s}}``; every magnitude is ``s`` times the
stated scale-1 size; s = 0 is exactly the nominal run). ``x = (35 °C − θ)``, ``T_r = 120 kN·m``,
``v_s = 0.003 rad/s``:

- stribeck: ``F_c± += s·1900·φ(|v|/v_s)`` with φ = exp(−r) ("exponential"), exp(−r²)
  ("gaussian"), 1/(1+r²) ("lorentzian"), exp(−√r) ("exponent_half").
- temperature_friction: "viscous_exponential" ``f_v·(1 + s·(e^{0.03·x} − 1))``;
  "coulomb_viscous_linear" ``F_c·(1 + s·0.01·x)``, ``f_v·(1 + s·0.02·x)``;
  "additive" ``F_c + s·25·x``, ``f_v + s·150·x``; "viscous_quadratic"
  ``f_v·(1 + s·(0.5·x/25 + 0.5·(x/25)²))``.
- load_dependent_friction: "coulomb" ``F_c + s·0.02·|T|``; "coulomb_viscous" also
  ``f_v·(1 + s·|T|/T_r)``; "power_flow" ``F_c + s·0.02·|T|·(1.3 − 0.6·σ)``,
  ``σ = (1 + tanh(T·v/50 W))/2`` (less when the joint drives, more when back-driven).
- asymmetric_friction: "coulomb" ``F_c± = F_c·(1 ± s·0.25)``; "coulomb_viscous" also
  ``f_v± = f_v·(1 ± s·0.3)`` (± by the sign of v); "offset" a constant drag ``s·600 N·m``.
- gear_ripple (kinematic error in the twist): "output_harmonics"
  ``e = s·1.5·10⁻⁴·Σ_{h=1..3} c_h sin(h·60·q + φ_h)``, c = (1, 0.5, 0.25);
  "motor_angle" ``e = s·1.0·10⁻⁴·(sin(2Nu + 0.3) + 0.3·sin(4Nu + 1.1))`` (2 cycles per motor
  revolution); "load_modulated" the output form with amplitude ×(0.3 + |τ_L|/T_r).
- backlash (width b = s·2·10⁻⁴ rad each side): "sharp" B(x) = x − b·sgn(x) for |x| > b else 0;
  "smoothed" B(x) = x − b·tanh(x/b).
- hysteresis (H = s·2000 N·m·h, δ_y = 3·10⁻⁴ rad): "bouc_wen"
  ``ḣ = Δ̇_s/δ_y·(1 − |h|·(0.5·sgn(Δ̇_s h) + 0.5))``; "bouc_wen_sharp" the same with |h|³;
  "dahl" ``ḣ = Δ̇_s/δ_y·(1 − h·sgn Δ̇_s)²``; "prandtl_ishlinskii" ``h = Σ_j w_j·S_rj(Δ_s)/r_j``,
  stop operators with r = (0.25, 0.5, 1, 2)·δ_y, w = (0.4, 0.3, 0.2, 0.1); "soft_windup"
  ``H = s·2000·(0.5·h_bw + (Δ_s/Δ_r)|Δ_s/Δ_r|)`` with Δ_r = 8.73·10⁻³ rad (stiffening + loss).
- torque_offset (on the reading): "constant" ``s·2000 N·m``; "linear_drift" ``s·20 N·m/s·t``;
  "settling_drift" ``s·2000·(1 − e^{−t/30 s})``.
- time_delay (on the reading): "fixed" latency ``s·20 ms``; "first_order_lag" an extra
  first-order lag of time constant ``s·20 ms``.

Out of vocabulary (also in EFFECT_FORMS):

- periodic_disturbance (external torque τ_ext): "sine" ``s·2500·sin(2π·0.45 t)``; "harmonics"
  ``s·2500·Σ c_h sin(2π·0.23·h·t + φ_h)``, c = (1, 0.5, 0.3).
- position_stiffness: "sinusoidal" ``k·(1 + s·0.06·sin(2q + 0.4))``; "linear" ``k·(1 + s·0.05·q)``.
- sensor_drift: "torque_gain" reading ``×(1 + s·0.03·t/100 s)``; "load_cell" the load reading
  ``+ s·25 N·m/s·t``.
- second_resonance: an auxiliary inertia I₂ on a spring k₂ (ζ = 0.03), reaction ``s·F₂``:
  "output_side" I₂ = 0.25·I at 9 Hz on q; "motor_side" I₂ = 0.1·J_M at 2.5 Hz on u.
- bending_crosstalk (the hydraulic bending moment M_b, 150 kN·m in schemes 1–2, into the torque
  gauge): "static" ``s·0.015·M_b``; "rotating" ``s·0.015·M_b·cos(q + 0.7)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numba import njit
from scipy import signal

SEED_IS_CAMPAIGN = True
"""simulate_run's seed names the campaign (the rig); ``run`` keys the run's own noise."""

REDUCTION = 11000.0
RATED_TORQUE = 120e3
TOP_SPEED = 3000.0 * 2.0 * math.pi / 60.0 / REDUCTION  # rad/s at the output, 3000 r/min motor

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "exponent_half"),
    "temperature_friction": ("viscous_exponential", "coulomb_viscous_linear", "additive",
                             "viscous_quadratic"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow"),
    "asymmetric_friction": ("coulomb", "coulomb_viscous", "offset"),
    "gear_ripple": ("output_harmonics", "motor_angle", "load_modulated"),
    "backlash": ("sharp", "smoothed"),
    "hysteresis": ("bouc_wen", "bouc_wen_sharp", "dahl", "prandtl_ishlinskii", "soft_windup"),
    "torque_offset": ("constant", "linear_drift", "settling_drift"),
    "time_delay": ("fixed", "first_order_lag"),
    "periodic_disturbance": ("sine", "harmonics"),
    "position_stiffness": ("sinusoidal", "linear"),
    "sensor_drift": ("torque_gain", "load_cell"),
    "second_resonance": ("output_side", "motor_side"),
    "bending_crosstalk": ("static", "rotating"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_stiffness",
                                      "sensor_drift", "second_resonance", "bending_crosstalk")

# Effects evaluated inside the dynamics loop: name -> slot in the (code, scale) arrays.
_KERNEL_SLOTS = {
    "stribeck": 0, "temperature_friction": 1, "load_dependent_friction": 2,
    "asymmetric_friction": 3, "gear_ripple": 4, "backlash": 5, "hysteresis": 6,
    "periodic_disturbance": 7, "position_stiffness": 8, "second_resonance": 9,
}
_N_SLOTS = 10

# ---- parameter vector layout (P) ----
P_I, P_MRX, P_MRY, P_G, P_FV, P_FC, P_K, P_D, P_JM, P_ETA = range(10)
P_KT, P_KP, P_KI = 10, 13, 16          # three each
P_IMAX, P_TAUI, P_FCM, P_FVM, P_MUM, P_TAUD = 19, 20, 21, 22, 23, 24
P_ALPHA, P_DELTA = 25, 28               # three each
P_CTH, P_RTH, P_THAMB, P_KPOS, P_USEPOS = 31, 32, 33, 34, 35
N_P = 36

# ---- state layout (y) ----
Y_Q, Y_V, Y_U, Y_UD, Y_I, Y_XI, Y_TL, Y_H, Y_TH, Y_Q2, Y_Q2D = 0, 1, 2, 3, 4, 7, 10, 11, 12, 13, 14
N_Y = 15

# ---- auxiliary outputs of one evaluation (o) ----
O_T, O_FF, O_QDD, O_TWR, O_E, O_Z, O_PLAY, O_FM = 0, 1, 2, 3, 4, 5, 8, 12
N_O = 13

# effect constants (scale-1 sizes)
_N = REDUCTION
_VS = 0.003
_DFS = 1900.0
_THREF = 35.0
_ZOUT = 60.0
_E_OUT = 1.5e-4
_E_MOT = 1.0e-4
_BL = 2e-4
_FH = 2000.0
_DY = 3e-4
_DR = RATED_TORQUE / 1.375e7
_PLAY_R = (0.25 * _DY, 0.5 * _DY, 1.0 * _DY, 2.0 * _DY)
_PLAY_W = (0.4, 0.3, 0.2, 0.1)
_EPSM = 1e-4


@njit(cache=True)
def _eval(y, t, wr, qdes, tl_set, q0, z0, p0, P, E, S, dy, o):
    """Derivatives dy of the state y at time t (inputs held over the step) and outputs o."""
    q = y[Y_Q]
    v = y[Y_V]
    u = y[Y_U]
    ud = y[Y_UD]
    tl = y[Y_TL]
    dtl = (tl_set - tl) / P[P_TAUD]
    # kinematic error of the gear (gear_ripple)
    e = 0.0
    ed = 0.0
    if E[4] == 1 or E[4] == 3:
        a1 = _ZOUT * q
        amp = S[4] * _E_OUT
        damp = 0.0
        if E[4] == 3:
            damp = amp * math.copysign(1.0, tl) * dtl / RATED_TORQUE
            amp = amp * (0.3 + abs(tl) / RATED_TORQUE)
        sh = math.sin(a1 + 0.2) + 0.5 * math.sin(2 * a1 + 1.3) + 0.25 * math.sin(3 * a1 + 2.1)
        ch = math.cos(a1 + 0.2) + 1.0 * math.cos(2 * a1 + 1.3) + 0.75 * math.cos(3 * a1 + 2.1)
        e = amp * sh
        ed = amp * ch * _ZOUT * v + damp * sh
    elif E[4] == 2:
        a2 = 2.0 * _N * u
        e = S[4] * _E_MOT * (math.sin(a2 + 0.3) + 0.3 * math.sin(2 * a2 + 1.1))
        ed = S[4] * _E_MOT * 2.0 * _N * ud * (math.cos(a2 + 0.3) + 0.6 * math.cos(2 * a2 + 1.1))
    ds = u - q - e
    dsd = ud - v - ed
    # stiffness (position_stiffness)
    kq = P[P_K]
    if E[8] == 1:
        kq = P[P_K] * (1.0 + S[8] * 0.06 * math.sin(2.0 * q + 0.4))
    elif E[8] == 2:
        kq = P[P_K] * (1.0 + S[8] * 0.05 * q)
    # backlash
    el = ds
    b = S[5] * _BL
    if E[5] == 1 and b > 0.0:
        if ds > b:
            el = ds - b
        elif ds < -b:
            el = ds + b
        else:
            el = 0.0
    elif E[5] == 2 and b > 0.0:
        el = ds - b * math.tanh(ds / b)
    T = kq * el + P[P_D] * dsd
    # hysteresis of the transmission
    hs = y[Y_H]
    hdot = 0.0
    hf = E[6]
    if hf == 1 or hf == 5:
        sg = 1.0 if dsd * hs >= 0.0 else -1.0
        hdot = dsd / _DY * (1.0 - abs(hs) * (0.5 * sg + 0.5))
    elif hf == 2:
        sg = 1.0 if dsd * hs >= 0.0 else -1.0
        hdot = dsd / _DY * (1.0 - abs(hs) ** 3 * (0.5 * sg + 0.5))
    elif hf == 3:
        sd = 1.0 if dsd >= 0.0 else -1.0
        w = 1.0 - hs * sd
        hdot = dsd / _DY * w * w
    if hf == 1 or hf == 2 or hf == 3:
        T += S[6] * _FH * hs
    elif hf == 4:
        hsum = 0.0
        for j in range(4):
            r = _PLAY_R[j]
            p = max(ds - r, min(ds + r, p0[j]))
            o[O_PLAY + j] = p
            hsum += _PLAY_W[j] * (ds - p) / r
        T += S[6] * _FH * hsum
    elif hf == 5:
        rr = ds / _DR
        T += S[6] * _FH * (0.5 * hs + rr * abs(rr))
    # friction levels of the output bearing/gear
    av = abs(v)
    fc = P[P_FC]
    fv = P[P_FV]
    if E[0] != 0:
        r = av / _VS
        if E[0] == 1:
            phi = math.exp(-r)
        elif E[0] == 2:
            phi = math.exp(-r * r)
        elif E[0] == 3:
            phi = 1.0 / (1.0 + r * r)
        else:
            phi = math.exp(-math.sqrt(r))
        fc += S[0] * _DFS * phi
    x = _THREF - y[Y_TH]
    if E[1] == 1:
        fv *= 1.0 + S[1] * (math.exp(0.03 * x) - 1.0)
    elif E[1] == 2:
        fc *= 1.0 + S[1] * 0.01 * x
        fv *= 1.0 + S[1] * 0.02 * x
    elif E[1] == 3:
        fc += S[1] * 25.0 * x
        fv += S[1] * 150.0 * x
    elif E[1] == 4:
        xx = x / 25.0
        fv *= 1.0 + S[1] * (0.5 * xx + 0.5 * xx * xx)
    aT = abs(T)
    if E[2] == 1:
        fc += S[2] * 0.02 * aT
    elif E[2] == 2:
        fc += S[2] * 0.02 * aT
        fv *= 1.0 + S[2] * aT / RATED_TORQUE
    elif E[2] == 3:
        sig = 0.5 * (1.0 + math.tanh(T * v / 50.0))
        fc += S[2] * 0.02 * aT * (1.3 - 0.6 * sig)
    fcp = fc
    fcn = fc
    fvp = fv
    fvn = fv
    foff = 0.0
    if E[3] == 1 or E[3] == 2:
        fcp = fc * (1.0 + S[3] * 0.25)
        fcn = fc * (1.0 - S[3] * 0.25)
        if E[3] == 2:
            fvp = fv * (1.0 + S[3] * 0.3)
            fvn = fv * (1.0 - S[3] * 0.3)
    elif E[3] == 3:
        foff = S[3] * 600.0
    fcp = max(fcp, 0.05 * P[P_FC])
    fcn = max(fcn, 0.05 * P[P_FC])
    fvp = max(fvp, 0.05 * P[P_FV])
    fvn = max(fvn, 0.05 * P[P_FV])
    # Maxwell-slip elements
    fg = 0.0
    dq = q - q0
    for j in range(3):
        al = P[P_ALPHA + j]
        kap = al * P[P_FC] / P[P_DELTA + j]
        z = z0[j] + dq
        hi = al * fcp / kap
        lo = -al * fcn / kap
        if z > hi:
            z = hi
        elif z < lo:
            z = lo
        o[O_Z + j] = z
        fg += kap * z
    ff = fg + (fvp if v >= 0.0 else fvn) * v + foff
    grav = P[P_G] * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    # external periodic torque
    text = 0.0
    if E[7] == 1:
        text = S[7] * 2500.0 * math.sin(2.0 * math.pi * 0.45 * t)
    elif E[7] == 2:
        w0 = 2.0 * math.pi * 0.23 * t
        text = S[7] * 2500.0 * (math.sin(w0 + 0.5) + 0.5 * math.sin(2 * w0 + 2.0)
                                + 0.3 * math.sin(3 * w0 + 0.9))
    # second resonance (auxiliary inertia)
    f2out = 0.0
    f2mot = 0.0
    if E[9] == 1 or E[9] == 2:
        if E[9] == 1:
            i2 = 0.25 * P[P_I]
            w2 = 2.0 * math.pi * 9.0
            att = q
            attd = v
        else:
            i2 = 0.1 * P[P_JM]
            w2 = 2.0 * math.pi * 2.5
            att = u
            attd = ud
        k2 = i2 * w2 * w2
        c2 = 2.0 * 0.03 * math.sqrt(k2 * i2)
        f2 = k2 * (y[Y_Q2] - att) + c2 * (y[Y_Q2D] - attd)
        dy[Y_Q2] = y[Y_Q2D]
        dy[Y_Q2D] = -f2 / i2
        if E[9] == 1:
            f2out = S[9] * f2
        else:
            f2mot = S[9] * f2
    else:
        dy[Y_Q2] = 0.0
        dy[Y_Q2D] = 0.0
    qdd = (T - tl - grav - ff - text + f2out) / P[P_I]
    # motor side
    tm = math.tanh(ud / _EPSM)
    fm = (P[P_FCM] + P[P_MUM] * aT) * tm + P[P_FVM] * ud
    tmot = 0.0
    for k in range(3):
        tmot += P[P_KT + k] * y[Y_I + k]
    tmot *= _N * P[P_ETA]
    udd = (tmot - T - fm + f2mot) / P[P_JM]
    if P[P_USEPOS] > 0.5:
        wref = wr + P[P_KPOS] * (qdes - u)
    else:
        wref = wr
    err = _N * (wref - ud)
    imax = P[P_IMAX]
    for k in range(3):
        ic = P[P_KP + k] * err + y[Y_XI + k]
        dxi = P[P_KI + k] * err
        if ic > imax:
            ic = imax
            if dxi > 0.0:
                dxi = 0.0
        elif ic < -imax:
            ic = -imax
            if dxi < 0.0:
                dxi = 0.0
        dy[Y_XI + k] = dxi
        dy[Y_I + k] = (ic - y[Y_I + k]) / P[P_TAUI]
    ploss = abs((ff - foff) * v) + abs(fm * ud)
    dy[Y_Q] = v
    dy[Y_V] = qdd
    dy[Y_U] = ud
    dy[Y_UD] = udd
    dy[Y_TL] = dtl
    dy[Y_H] = hdot
    dy[Y_TH] = (ploss - (y[Y_TH] - P[P_THAMB]) / P[P_RTH]) / P[P_CTH]
    o[O_T] = T
    o[O_FF] = ff
    o[O_QDD] = qdd
    o[O_TWR] = ud - v
    o[O_E] = e
    o[O_FM] = fm


@njit(cache=True)
def _integrate(h, n_steps, y0, wr, qdes, tl_set, P, E, S, rec):
    """Fixed-step RK4 over n_steps; rec[:, n] holds the state and outputs at t = n·h."""
    y = y0.copy()
    z0 = np.zeros(3)
    p0 = np.zeros(4)
    k1 = np.zeros(N_Y)
    k2 = np.zeros(N_Y)
    k3 = np.zeros(N_Y)
    k4 = np.zeros(N_Y)
    yt = np.zeros(N_Y)
    o = np.zeros(N_O)
    d = np.zeros(N_Y)
    _eval(y, 0.0, wr[0], qdes[0], tl_set[0], y[Y_Q], z0, p0, P, E, S, d, o)
    _record(rec, 0, y, o)
    for n in range(n_steps):
        t = n * h
        q0 = y[Y_Q]
        _eval(y, t, wr[n], qdes[n], tl_set[n], q0, z0, p0, P, E, S, k1, o)
        for i in range(N_Y):
            yt[i] = y[i] + 0.5 * h * k1[i]
        _eval(yt, t + 0.5 * h, wr[n], qdes[n], tl_set[n], q0, z0, p0, P, E, S, k2, o)
        for i in range(N_Y):
            yt[i] = y[i] + 0.5 * h * k2[i]
        _eval(yt, t + 0.5 * h, wr[n], qdes[n], tl_set[n], q0, z0, p0, P, E, S, k3, o)
        for i in range(N_Y):
            yt[i] = y[i] + h * k3[i]
        _eval(yt, t + h, wr[n], qdes[n], tl_set[n], q0, z0, p0, P, E, S, k4, o)
        for i in range(N_Y):
            y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        # commit the slip states at the step end, and record there
        _eval(y, t + h, wr[n + 1], qdes[n + 1], tl_set[n + 1], q0, z0, p0, P, E, S, d, o)
        for j in range(3):
            z0[j] = o[O_Z + j]
        if E[6] == 4:
            for j in range(4):
                p0[j] = o[O_PLAY + j]
        # (re-evaluating about the committed states would give the same outputs: record these)
        _record(rec, n + 1, y, o)


@njit(cache=True)
def _record(rec, n, y, o):
    for i in range(N_Y):
        rec[i, n] = y[i]
    rec[N_Y + 0, n] = o[O_T]
    rec[N_Y + 1, n] = o[O_FF]
    rec[N_Y + 2, n] = o[O_QDD]
    rec[N_Y + 3, n] = o[O_TWR]
    rec[N_Y + 4, n] = o[O_E]
    rec[N_Y + 5, n] = o[O_FM]


_N_REC = N_Y + 6
_PHASES = np.array(["idle", "load", "hold", "unload", "excite"], dtype=object)


@dataclass(frozen=True)
class SensorSpec:
    """What the rig's sensors resolve.

    sample_rate_hz: logging rate (10 Hz – 1 kHz); encoder_res_deg: output encoder step (deg);
    torque_noise / load_noise: white noise sd added to the torque / load readings (N·m);
    torque_lag_s: transport lag of the torque reading (s) before its anti-alias filter;
    motor_encoder_bits: motor encoder counts per motor revolution = 2**bits;
    adc_range_nm / adc_bits: the torque ADCs' span (±, N·m) and resolution;
    current_noise: white noise on the motor currents (A).
    """

    sample_rate_hz: float = 100.0
    encoder_res_deg: float = 0.001
    torque_noise: float = 150.0
    load_noise: float = 150.0
    torque_lag_s: float = 0.0
    motor_encoder_bits: int = 20
    adc_range_nm: float = 200e3
    adc_bits: int = 16
    current_noise: float = 0.02


@dataclass
class RigRun:
    """One run: the logged samples, the metadata and the noise-free truth at the sample times."""

    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame = field(default_factory=pd.DataFrame)


def rig_parameters(seed: int) -> np.ndarray:
    """The campaign's rig: nominal values perturbed a few % (sd 3 %, clipped at ±8 %) by seed."""
    rng = np.random.default_rng([int(seed), 7001])
    dev = np.clip(rng.normal(0.0, 0.03, N_P), -0.08, 0.08)
    P = np.zeros(N_P)
    P[P_I] = 6700.0
    P[P_MRX] = 20.8
    P[P_MRY] = -34.5
    P[P_G] = 9.81
    P[P_FV] = 8683.0
    P[P_FC] = 2353.0
    P[P_K] = RATED_TORQUE / math.radians(0.5)
    P[P_D] = 3.0e4
    P[P_JM] = 5.0e5
    P[P_ETA] = 0.9
    kt = 0.9
    jm = P[P_JM]
    wb = 25.0  # speed-loop bandwidth, rad/s
    kp_total = jm * wb / (REDUCTION ** 2 * P[P_ETA] * kt)
    for k in range(3):
        P[P_KT + k] = kt
        P[P_KP + k] = kp_total / 3.0 * (1.0 + 0.1 * (k - 1))   # tuned differently
        P[P_KI + k] = P[P_KP + k] * wb / 5.0
    P[P_IMAX] = 12.0
    P[P_TAUI] = 0.002
    P[P_FCM] = 3300.0
    P[P_FVM] = 2.0e4
    P[P_MUM] = 0.03
    P[P_TAUD] = 0.05
    P[P_ALPHA:P_ALPHA + 3] = (0.5, 0.3, 0.2)
    P[P_DELTA:P_DELTA + 3] = (0.4e-4, 1.2e-4, 3.0e-4)
    P[P_CTH] = 2.0e5
    P[P_RTH] = 0.01
    P[P_THAMB] = 22.0
    P[P_KPOS] = 3.0
    perturbed = [P_I, P_MRX, P_MRY, P_FV, P_FC, P_K, P_D, P_JM, P_ETA, P_KT, P_KT + 1, P_KT + 2,
                 P_FCM, P_FVM, P_MUM, P_TAUD, P_DELTA, P_DELTA + 1, P_DELTA + 2, P_CTH, P_RTH]
    for i in perturbed:
        P[i] *= 1.0 + dev[i]
    P[P_ETA] = min(P[P_ETA], 0.97)
    return P


def _fourier_coefficients() -> tuple[np.ndarray, np.ndarray]:
    """Fifth-order excitation (a_l, b_l) with q̇(0) = q̈(0) = 0, peak speed 0.9·TOP_SPEED."""
    a = np.array([0.5, 0.3, -0.2, -0.4, -0.2])
    b = np.array([0.4, -0.5, 0.3, 0.1, -0.1])
    ell = np.arange(1, 6)
    a = a - a.sum() / 5.0
    b = b - ell * (ell @ b) / (ell @ ell)
    wf = 2.0 * math.pi / 20.0
    tt = np.linspace(0.0, 20.0, 4001)
    arg = wf * ell[:, None] * tt
    qd = (a[:, None] * np.cos(arg) + b[:, None] * np.sin(arg)).sum(0)
    gain = 0.9 * TOP_SPEED / np.abs(qd).max()
    return a * gain, b * gain


def _profiles(scheme: int, motor_speed_rpm: float | None, direction: int, periods: int, h: float,
              rng_dyn: np.random.Generator):
    """Set points on the internal grid: speed feed-forward, desired angle, load set point (with
    the dynamometer's error), bending moment and phase labels; and the step count."""
    if scheme == 1:
        dur = 100.0
    elif scheme == 2:
        dur = 60.0
    else:
        dur = 6.0 + 20.0 * periods
    n = int(round(dur / h))
    t = np.arange(n + 1) * h
    wr = np.zeros(n + 1)
    qdes = np.zeros(n + 1)
    tl = np.zeros(n + 1)
    mb = np.zeros(n + 1)
    phase = np.zeros(n + 1, dtype=np.int8)  # index into _PHASES
    if scheme in (1, 2):
        w = direction * float(motor_speed_rpm) * 2.0 * math.pi / 60.0 / REDUCTION
        wr = w * np.clip((t - 1.0) / 2.0, 0.0, 1.0) * np.clip((dur - 1.0 - t) / 2.0, 0.0, 1.0)
        mb = 150e3 * np.clip(t / 3.0, 0.0, 1.0) * (1.0 + 0.01 * np.sin(2 * math.pi * 0.7 * t))
        if scheme == 1:
            tl = RATED_TORQUE * np.interp(t, [0, 8, 48, 53, 93, dur], [0, 0, 1, 1, 0, 0])
            phase[(t >= 8) & (t < 48)] = 1
            phase[(t >= 48) & (t < 53)] = 2
            phase[(t >= 53) & (t < 93)] = 3
        else:
            for s in range(12):
                t0 = 6.0 + 2.5 * s
                tl[t >= t0] = (s + 1) * 10e3
                phase[(t >= t0) & (t < t0 + 0.5)] = 1
                phase[(t >= t0 + 0.5) & (t < t0 + 2.5)] = 2
            phase[(t >= 36) & (t < 40)] = 2
            ramp = (t >= 40)
            tl[ramp] = RATED_TORQUE * np.clip((52.0 - t[ramp]) / 12.0, 0.0, 1.0)
            phase[(t >= 40) & (t < 52)] = 3
    else:
        a, b = _fourier_coefficients()
        wf = 2.0 * math.pi / 20.0
        ell = np.arange(1, 6)
        te = np.clip(t - 3.0, 0.0, 20.0 * periods)
        arg = wf * ell[:, None] * te
        on = (t >= 3.0) & (t <= 3.0 + 20.0 * periods)
        wr = direction * (a[:, None] * np.cos(arg) + b[:, None] * np.sin(arg)).sum(0) * on
        ca = (a / (wf * ell))[:, None]
        cb = (b / (wf * ell))[:, None]
        qpos = (ca * np.sin(arg) - cb * np.cos(arg)).sum(0)
        qdes = direction * (qpos - qpos[0])
        phase[on] = 4
    # the dynamometer's error: gain, bias and a slow wander, zero when unloaded
    gain = rng_dyn.normal(0.0, 0.004)
    bias = float(np.clip(rng_dyn.normal(0.0, 400.0), -1000.0, 1000.0))
    tw = rng_dyn.uniform(15.0, 40.0)
    ph = rng_dyn.uniform(0.0, 2 * math.pi)
    wander = 300.0 * np.sin(2 * math.pi * t / tw + ph)
    err = gain * tl + (bias + wander) * np.clip(tl / 20e3, 0.0, 1.0)
    tl_set = tl + np.clip(err, -1900.0, 1900.0)
    return n, t, wr, qdes, tl_set, mb, phase


def _parse_effects(effects: dict[str, dict] | None) -> tuple[np.ndarray, np.ndarray, dict]:
    """Validate the effects; kernel codes/scales and the reading-chain effects {name: (form, s)}."""
    codes = np.zeros(_N_SLOTS, dtype=np.int64)
    scales = np.zeros(_N_SLOTS)
    post: dict[str, tuple[str, float]] = {}
    for name, spec in (effects or {}).items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or "form" not in spec:
            raise ValueError(f"effect {name!r} needs {{'form': ..., 'scale': ...}}")
        form = spec["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"unknown form {form!r} of {name!r}; known: {EFFECT_FORMS[name]}")
        scale = float(spec.get("scale", 1.0))
        if not math.isfinite(scale):
            raise ValueError(f"effect {name!r}: scale must be finite, got {scale}")
        if name in _KERNEL_SLOTS:
            slot = _KERNEL_SLOTS[name]
            codes[slot] = EFFECT_FORMS[name].index(form) + 1
            scales[slot] = scale
        else:
            post[name] = (form, scale)
    return codes, scales, post


def _delay(t: np.ndarray, x: np.ndarray, lag: float) -> np.ndarray:
    """x(t − lag) by linear interpolation (held at x[0] before the start)."""
    if lag == 0.0:
        return x
    return np.interp(t - lag, t, x, left=x[0])


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, seed: int = 0,
                 sensors: SensorSpec = SensorSpec(), periods: int = 6, run: int = 0) -> RigRun:
    """Simulate one run of rig C.

    scheme 1/2 need motor_speed_rpm (> 0); scheme 3 ignores it. direction is ±1;
    temp_joint_c the joint temperature at the start (°C). seed names the campaign (the rig's
    parameters); run keys the run's noise and dynamometer error. Raises ValueError on an
    unknown effect, form, scheme or a bad argument.
    """
    if scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme}")
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction}")
    if scheme in (1, 2) and (motor_speed_rpm is None or not motor_speed_rpm > 0):
        raise ValueError("schemes 1 and 2 need a positive motor_speed_rpm")
    fs = float(sensors.sample_rate_hz)
    if not 1.0 <= fs <= 2000.0:
        raise ValueError(f"sample_rate_hz {fs} outside 1 Hz – 2 kHz")
    if scheme == 3 and periods < 1:
        raise ValueError("periods must be >= 1")
    codes, scales, post = _parse_effects(effects)

    m = int(math.ceil((1.0 / fs) / 1e-3 - 1e-9))
    h = 1.0 / (fs * m)
    streams = [np.random.default_rng([int(seed), 7002, int(run), k]) for k in range(6)]
    rng_tq, rng_ld, rng_dyn, rng_amb, rng_cur, rng_w = streams

    P = rig_parameters(seed)
    P[P_THAMB] = 22.0 + rng_amb.normal(0.0, 2.0)
    P[P_USEPOS] = 1.0 if scheme == 3 else 0.0
    n, t, wr, qdes, tl_set, mb, phase = _profiles(scheme, motor_speed_rpm, direction, periods, h,
                                                  rng_dyn)

    # initial state: at rest at q = 0, the transmission holding gravity, currents sharing it
    y0 = np.zeros(N_Y)
    t0 = P[P_G] * P[P_MRY]
    y0[Y_U] = t0 / P[P_K]
    ktot = sum(P[P_KT + k] * P[P_KP + k] for k in range(3))
    for k in range(3):
        share = t0 / (REDUCTION * P[P_ETA]) * P[P_KP + k] / ktot
        y0[Y_I + k] = share
        y0[Y_XI + k] = share
    y0[Y_TH] = float(temp_joint_c)
    rec = np.zeros((_N_REC, n + 1))
    _integrate(h, n, y0, wr, qdes, tl_set, P, codes, scales, rec)

    q, v, u, ud = rec[Y_Q], rec[Y_V], rec[Y_U], rec[Y_UD]
    tl_act, theta = rec[Y_TL], rec[Y_TH]
    T = rec[N_Y + 0]
    twist = u - q

    # ---- torque reading chain: gauge effects, delays, anti-alias filter ----
    g = T.copy()
    if "sensor_drift" in post and post["sensor_drift"][0] == "torque_gain":
        g = g * (1.0 + post["sensor_drift"][1] * 0.03 * t / 100.0)
    if "bending_crosstalk" in post:
        form, s = post["bending_crosstalk"]
        g = g + s * 0.015 * mb * (1.0 if form == "static" else np.cos(q + 0.7))
    if "torque_offset" in post:
        form, s = post["torque_offset"]
        if form == "constant":
            g = g + s * 2000.0
        elif form == "linear_drift":
            g = g + s * 20.0 * t
        else:
            g = g + s * 2000.0 * (1.0 - np.exp(-t / 30.0))
    if "time_delay" in post:
        form, s = post["time_delay"]
        if form == "fixed":
            g = _delay(t, g, s * 0.020)
        elif s != 0.0:
            a = math.exp(-h / abs(s * 0.020))
            g, _ = signal.lfilter([1.0 - a], [1.0, -a], g, zi=[a * g[0]])
    g = _delay(t, g, float(sensors.torque_lag_s))
    f_aa = min(0.3 * fs, 150.0)
    bb, aa = signal.butter(2, f_aa, fs=1.0 / h)
    g, _ = signal.lfilter(bb, aa, g, zi=signal.lfilter_zi(bb, aa) * g[0])
    load_read = tl_act.copy()
    if "sensor_drift" in post and post["sensor_drift"][0] == "load_cell":
        load_read = load_read + post["sensor_drift"][1] * 25.0 * t

    # ---- encoders and velocity estimates on the internal grid ----
    res_q = math.radians(sensors.encoder_res_deg)
    res_u = 2.0 * math.pi / (2 ** int(sensors.motor_encoder_bits)) / REDUCTION
    qq = np.round(q / res_q) * res_q
    uq = np.round(u / res_u) * res_u
    win = max(1.0 / fs, 0.02)
    wn = max(1, int(round(win / h)))
    win = wn * h

    def backdiff(x: np.ndarray) -> np.ndarray:
        past = np.concatenate([np.full(wn, x[0]), x[:-wn]])
        return (x - past) / win

    qd_est = backdiff(qq)
    ud_est = backdiff(uq)

    # ---- sample and hold at fs ----
    idx = np.arange(0, n + 1, m)
    ns = idx.size
    step = 2.0 * sensors.adc_range_nm / 2 ** int(sensors.adc_bits)

    def adc(x: np.ndarray) -> np.ndarray:
        """The 16-bit converter: round to its step, clip to its span."""
        return np.clip(np.round(x / step) * step, -sensors.adc_range_nm, sensors.adc_range_nm)

    torque_truth = g[idx]
    load_truth = load_read[idx]
    torque_meas = adc(torque_truth + rng_tq.normal(0.0, sensors.torque_noise, ns))
    load_meas = adc(load_truth + rng_ld.normal(0.0, sensors.load_noise, ns))
    cur_noise = rng_cur.normal(0.0, sensors.current_noise, (3, ns))
    w_noise = rng_w.normal(0.0, 0.05, (3, ns))
    ts = t[idx]
    samples = pd.DataFrame({
        "t": ts, "q": qq[idx], "qd": qd_est[idx], "u": uq[idx], "ud": ud_est[idx],
        "torsion": qq[idx] - uq[idx], "torque": torque_meas, "torque_load": load_meas,
        "temp_joint": np.round(theta[idx] * 10.0) / 10.0, "phase": _PHASES[phase[idx]],
    })
    for k in range(3):
        samples[f"i_m{k + 1}"] = rec[Y_I + k][idx] + cur_noise[k]
        samples[f"w_m{k + 1}"] = ud_est[idx] * REDUCTION + w_noise[k]
    truth = pd.DataFrame({
        "t": ts, "q": q[idx], "qd": v[idx], "qdd": rec[N_Y + 2][idx], "u": u[idx], "ud": ud[idx],
        "torque": torque_truth, "torque_load": load_truth, "twist": twist[idx],
        "twist_rate": rec[N_Y + 3][idx], "torque_joint": T[idx], "torque_load_true": tl_act[idx],
        "friction_output": rec[N_Y + 1][idx], "friction_motor": rec[N_Y + 5][idx],
        "kinematic_error": rec[N_Y + 4][idx], "temp_joint": theta[idx],
    })
    aa_delay = math.sqrt(2.0) / (2.0 * math.pi * f_aa)
    meta = {
        "scheme": int(scheme),
        "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
        "direction": int(direction),
        "reduction": int(REDUCTION),
        "rig": "validation-rig-C",
        "source": "emulator",
        "sample_rate_hz": fs,
        "duration_s": float(n * h),
        "temp_joint_c": float(temp_joint_c),
        "sensors": {
            "q": {"resolution": res_q},
            "u": {"resolution": res_u},
            "qd": {"estimate": "backward difference of q", "window_s": win},
            "ud": {"estimate": "backward difference of u", "window_s": win},
            "torque": {"noise_sd": math.sqrt(sensors.torque_noise ** 2 + step ** 2 / 12.0),
                       "lag_s": float(sensors.torque_lag_s) + aa_delay,
                       "anti_alias": {"order": 2, "cutoff_hz": f_aa}, "adc_step": step},
            "torque_load": {"noise_sd": math.sqrt(sensors.load_noise ** 2 + step ** 2 / 12.0),
                            "adc_step": step},
            "temp_joint": {"resolution": 0.1},
        },
    }
    return RigRun(samples=samples, meta=meta, truth=truth)
