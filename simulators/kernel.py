"""The joint's time-stepping kernel (numba), dt = 1 ms by default.

Model (rig.md, "Physics"), symbols as there: q output angle, u motor angle referred to the output
(motor angle / N), Δ = u − q the twist, T the transmitted torque, τ_L the dynamometer torque.

- Output side, Eq. 4 plus the load and the output-side effects:
  I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − f_v·q̇ − f_c·sgn(q̇) − Σ effects(q, q̇, T, θ_joint).
  The friction terms use the smoothed sign tanh(q̇/v_eps); near q̇ = 0 that is stiff
  (f_c/v_eps ≈ 1e8 N·m·s/rad), so there the friction is integrated implicitly (backward Euler in q̇,
  safeguarded Newton); away from zero (|q̇| > 30·v_eps, where tanh is saturated) it is explicit.
- Transmission, Bouc–Wen (Eqs. 7–9): T = D·Δ̇_s + k_u·Δ_s + k_h·x with Δ_s the twist the spring
  sees (= Δ, or Δ through the backlash dead zone) and x advanced by core.terms.bouc_wen_step over
  each step's increment of Δ_s. Hysteresis off: k_u = k, k_h = 0 (purely elastic).
- Motor side: the healthy motors' rotors turn together behind the reduction N:
  n_rot·J_m·N²·ü = Σ_active k_t·i_k·N·η − T − b_m·N²·u̇   (rig.md; core.terms.motor_current_share).
  Each drive runs a PI speed loop (output-referred gains from JointParams.speed_bw) with a current
  limit min(i_max, its torque limit / k_t) and conditional-integration anti-windup. A failed motor
  gives no torque and its holding brake takes its rotor out of the train (the differential stage
  passes on the other motors' torque), so n_rot counts the healthy motors and each healthy active
  motor carries T/(n·k_t·N·η) in steady state; its integrator is reset, the others' integrators take
  up its share. A disabled (not failed) motor gives no torque but still turns with the train.
- Dynamometer: first-order torque lag (dyno_tau) plus a slow bounded error (two sinusoids,
  simulators.config.DYNO_ERR_PERIODS) — both visible in torque_load vs torque_cmd.
- Hydraulics: pump on → pressure follows min(set point, p_max) with time constant p_tau (regulator
  + accumulator); pump off → vents to 0 with the same time constant. Cylinder force F = p·A gives
  shear f_shear = F and bending m_bend = F·arm_bend (they load the shaft bearings, not the joint).
- Temperatures: each winding C·θ̇ = i²·R_w − (θ − θ_amb)/R_th; the gearbox is heated by the output
  friction power |F_fric·q̇| and the transmission loss (1 − η)·|T_drive·u̇|.
- Sensor effect time_delay: every step's T goes into a ring buffer; the strain-gauge channel reads
  the value `delay` seconds (rounded to whole steps) earlier. torque_offset and the noise are added
  outside the kernel (simulators.sensors).

The shared physics (core.terms) and effect terms (core.effects) are compiled here with numba from
their own Python source (`_jit`), never copied. Records are written only at the sample steps, so
the kernel allocates nothing per step.
"""

from __future__ import annotations

import types

import numba
import numpy as np

from core import effects as fx
from core import terms
from core.params import N_MOTORS


def _jit(func, **deps):
    """numba-compile a shared term function from its own code object, with the names in `deps`
    (other shared functions it calls) bound to their compiled versions."""
    glb = dict(func.__globals__)
    glb.update(deps)
    f = types.FunctionType(func.__code__, glb, func.__name__, func.__defaults__, func.__closure__)
    f.__qualname__ = func.__qualname__
    f.__module__ = func.__module__
    f.__doc__ = func.__doc__
    return numba.njit(cache=False)(f)


smooth_sign = _jit(terms.smooth_sign)
gravity_torque = _jit(terms.gravity_torque)
viscous_coulomb_friction = _jit(terms.viscous_coulomb_friction, smooth_sign=smooth_sign)
bouc_wen_step = _jit(terms.bouc_wen_step)
transmission_torque = _jit(terms.transmission_torque)
stribeck_torque = _jit(fx.stribeck_torque, smooth_sign=smooth_sign)
load_dependent_friction_torque = _jit(fx.load_dependent_friction_torque, smooth_sign=smooth_sign)
temperature_friction_torque = _jit(fx.temperature_friction_torque, smooth_sign=smooth_sign)
backlash_twist = _jit(fx.backlash_twist)
gear_ripple_torque = _jit(fx.gear_ripple_torque)
asymmetric_friction_torque = _jit(fx.asymmetric_friction_torque, smooth_sign=smooth_sign)

# --- parameter vector PF (float64) ---------------------------------------------------------
(I_XX, MR_X, MR_Y, F_V, F_C, V_EPS, K_U, K_H, DAMP, ALPHA, BETA, GAMMA, NRED, ETA, K_T, J_M,
 B_M, KP, KI, R_WIND, R_TH_M, C_TH_M, T_AMB, R_TH_J, C_TH_J, DYNO_TAU, P_MAX, P_TAU, DT, KP_POS,
 HYST_ON, STRIB_ON, F_S, V_S, LDF_ON, MU, TF_ON, C_T, T_REF, BL_ON, BL_B, GR_ON, GR_A, GR_ORDER,
 GR_PHASE, DELAY_STEPS, OSC1_C, OSC1_S, OSC2_C, OSC2_S, ERR_A1, ERR_A2, AF_ON, AF_DC, AF_DV,
 STRIB_DELTA, MU_V, C_TV, N_PF) = range(59)

# --- state vector S (float64), advanced in place --------------------------------------------
(S_Q, S_QD, S_U, S_UD, S_X, S_DS, S_INT, _S_INT1, _S_INT2, S_TW, _S_TW1, _S_TW2, S_TJ, S_TAUF,
 S_P, S_OSC1X, S_OSC1Y, S_OSC2X, S_OSC2Y, S_RING, S_STEP, S_QDD, S_UDD, S_MQ, _S_MQ1, _S_MQ2,
 N_S) = range(27)

# --- record columns (one row per sample; true values, before sensor models) -----------------
(R_T, R_Q, R_QD, R_U, R_UD, R_TQ_SG, R_TQ, R_TAUL, R_TAUCMD, R_I, _R_I1, _R_I2, R_W, _R_W1,
 _R_W2, R_TW, _R_TW1, _R_TW2, R_TJ, R_P, R_X, R_TWIST, R_QDD, R_UDD, R_MQ, _R_MQ1, _R_MQ2,
 N_R) = range(28)

DIVERGED = 100.0
"""Output-referred speed [rad/s] (~3500× the rig's top speed) taken as a numerical blow-up."""

IMPLICIT_BAND = 30.0
"""|q̇| below IMPLICIT_BAND·v_eps [-] → friction integrated implicitly (tanh not saturated)."""


@numba.njit(cache=True, inline="always")
def friction_params(PF):
    """Tuple of the friction terms' parameters (a value, so the loop keeps it in registers)."""
    return (PF[F_V], PF[F_C], PF[V_EPS], PF[STRIB_ON], PF[F_S], PF[V_S], PF[LDF_ON], PF[MU],
            PF[TF_ON], PF[C_T], PF[T_REF], PF[AF_ON], PF[AF_DC], PF[AF_DV], PF[STRIB_DELTA],
            PF[MU_V], PF[C_TV])


@numba.njit(cache=True, inline="always")
def friction(v, T, temp_joint, fp):
    """Output-side velocity-dependent friction [N·m] at output speed v: Eq. 4's viscous +
    Coulomb terms plus the injected stribeck, load_dependent_friction, temperature_friction,
    asymmetric_friction. fp = friction_params(PF)."""
    (f_v, f_c, v_eps, strib_on, f_s, v_s, ldf_on, mu, tf_on, c_T, T_ref, af_on, d_c, d_v,
     delta, mu_v, c_Tv) = fp
    f = viscous_coulomb_friction(v, f_v, f_c, v_eps)
    if strib_on != 0.0:
        f += stribeck_torque(v, f_s, v_s, v_eps, delta)
    if ldf_on != 0.0:
        f += load_dependent_friction_torque(v, T, mu, v_eps, mu_v)
    if tf_on != 0.0:
        f += temperature_friction_torque(v, temp_joint, c_T, T_ref, v_eps, c_Tv)
    if af_on != 0.0:
        f += asymmetric_friction_torque(v, d_c, d_v, v_eps)
    return f


@numba.njit(cache=True, inline="always")
def output_velocity(qd, R, T, temp_joint, m, fp):
    """Output speed after one step [rad/s] from m·(q̇' − q̇) = R − F(q̇'), m = I/dt, R the
    non-friction torque. Explicit where tanh(q̇/v_eps) is saturated, backward Euler (safeguarded
    Newton on the increasing g(v) = m·(v − q̇) + F(v) − R) near q̇ = 0. Returns (q̇', F used)."""
    v_eps = fp[2]
    f0 = friction(qd, T, temp_joint, fp)
    v = qd + (R - f0) / m
    band = IMPLICIT_BAND * v_eps
    if (qd > band and v > band) or (qd < -band and v < -band):
        return v, f0
    g = m * (v - qd) + friction(v, T, temp_joint, fp) - R
    if g == 0.0:
        return v, friction(v, T, temp_joint, fp)
    step = v_eps
    if g > 0.0:
        hi = v
        lo = v - step
        while m * (lo - qd) + friction(lo, T, temp_joint, fp) - R > 0.0:
            hi = lo
            step *= 4.0
            lo = v - step
    else:
        lo = v
        hi = v + step
        while m * (hi - qd) + friction(hi, T, temp_joint, fp) - R < 0.0:
            lo = hi
            step *= 4.0
            hi = v + step
    x = 0.5 * (lo + hi)
    h = 1e-6 * v_eps
    tol = 1e-7 * v_eps
    for _ in range(200):
        fx_ = friction(x, T, temp_joint, fp)
        gx = m * (x - qd) + fx_ - R
        if gx > 0.0:
            hi = x
        else:
            lo = x
        dg = m + (friction(x + h, T, temp_joint, fp) - fx_) / h
        xn = x - gx / dg
        if not (lo < xn < hi):
            xn = 0.5 * (lo + hi)
        if abs(xn - x) < tol or hi - lo < tol:
            x = xn
            break
        x = xn
    return x, friction(x, T, temp_joint, fp)


@numba.njit(cache=True, inline="always")
def spring_twist(delta, bl_on, bl_b):
    """Twist the spring sees [rad]: Δ, or Δ through the backlash dead zone."""
    if bl_on != 0.0:
        return backlash_twist(delta, bl_b)
    return delta


@numba.njit(cache=True, inline="always")
def transmission(q, qd, u, ud, x, k_u, k_h, damp, bl_on, bl_b):
    """(T, Δ_s): transmitted torque [N·m] and the twist the spring sees [rad]. The damper acts
    on the twist rate, zero inside the backlash dead zone (no contact)."""
    delta = u - q
    dd = ud - qd
    if bl_on != 0.0 and abs(delta) <= bl_b:
        dd = 0.0
    delta_s = spring_twist(delta, bl_on, bl_b)
    return transmission_torque(delta_s, dd, x, k_u, k_h, damp), delta_s


@numba.njit(cache=True, inline="always")
def drive(w, integ, ud, active, lim, kp, inv_nred):
    """One drive's PI speed loop: (torque command [N·m, output-referred = k_t·i·N·η], speed
    error [rad/s, output-referred], code: −1 off, 0 free, 1 limited in the error's direction).
    w: speed set point [rad/s, motor shaft]; inv_nred = 1/N."""
    if not active:
        return 0.0, 0.0, -1
    e = w * inv_nred - ud
    cmd = kp * e + integ
    if cmd > lim:
        return lim, e, 1 if e > 0.0 else 0
    if cmd < -lim:
        return -lim, e, 1 if e < 0.0 else 0
    return cmd, e, 0


@numba.njit(cache=True, inline="always")
def integrate_pi(integ, e, code, ki, dt):
    """Integrator update with conditional-integration anti-windup; reset while off."""
    if code == -1:
        return 0.0
    if code == 0:
        return integ + ki * e * dt
    return integ


@numba.njit(cache=True, inline="always")
def speed_setpoint(w_set, c, k, pos_on, pos_ref, u, kp_pos, nred):
    """Speed set point of motor k [rad/s, motor shaft]: the command, plus in position mode the
    position loop kp_pos·N·(u_ref − u) on the motor-side angle."""
    w = w_set[c, k]
    if pos_on != 0:
        w += kp_pos * nred * (pos_ref[c] - u)
    return w


@numba.njit(cache=True)
def advance(S, PF, n_bw, ring, w_set, pos_ref, pos_on, tau_cmd, p_set, pump, enabled,
            fail_step, tau_lim, sample_steps, rec, j, n_steps):
    """Advance the state S (in place) by n_steps internal steps.

    Commands are arrays indexed by step within this call (length n_steps), or of length 1 (held
    for the whole call): w_set (·, 3) motor speed set points [rad/s, motor shaft]; pos_ref (·,)
    output-referred position reference [rad], used when pos_on (speed feed-forward in w_set plus
    a proportional position loop on u); tau_cmd dynamometer set point [N·m]; p_set pressure set
    point [Pa]; pump 0/1. enabled (3,) 0/1; fail_step (3,) global step at which motor k fails;
    tau_lim (3,) torque limits [N·m, motor shaft]. Record rows (kernel.R_*) are written from row
    j on at the global steps listed in sample_steps: values at the start of that step, with
    QDD/UDD the accelerations over it. Returns the next free record row.

    Parameters and state are copied into locals for the loop (no aliasing with the output
    arrays, so they stay in registers) and the state is written back at the end."""
    # parameters
    fp = friction_params(PF)
    i_xx, mr_x, mr_y = PF[I_XX], PF[MR_X], PF[MR_Y]
    k_u, k_h, damp = PF[K_U], PF[K_H], PF[DAMP]
    alpha, beta, gamma = PF[ALPHA], PF[BETA], PF[GAMMA]
    nred, eta, k_t, j_m, b_m = PF[NRED], PF[ETA], PF[K_T], PF[J_M], PF[B_M]
    kp, ki, kp_pos = PF[KP], PF[KI], PF[KP_POS]
    r_wind, r_th_m, c_th_m = PF[R_WIND], PF[R_TH_M], PF[C_TH_M]
    t_amb, r_th_j, c_th_j = PF[T_AMB], PF[R_TH_J], PF[C_TH_J]
    dyno_tau, p_max, p_tau, dt = PF[DYNO_TAU], PF[P_MAX], PF[P_TAU], PF[DT]
    hyst_on, bl_on, bl_b = PF[HYST_ON], PF[BL_ON], PF[BL_B]
    gr_on, gr_a, gr_order, gr_phase = PF[GR_ON], PF[GR_A], PF[GR_ORDER], PF[GR_PHASE]
    d = int(PF[DELAY_STEPS])
    o1c, o1s, o2c, o2s, err_a1, err_a2 = (PF[OSC1_C], PF[OSC1_S], PF[OSC2_C], PF[OSC2_S],
                                          PF[ERR_A1], PF[ERR_A2])
    m_out = i_xx / dt
    conv = 1.0 / (eta * nred * k_t)
    # loop-invariant reciprocals (multiplications in the loop instead of divisions)
    inv_dt = 1.0 / dt
    inv_nred = 1.0 / nred
    inv_j_rotor = 1.0 / (j_m * nred * nred)
    k_wind = dt / c_th_m
    g_wind = 1.0 / r_th_m
    k_joint = dt / c_th_j
    g_joint = 1.0 / r_th_j
    k_dyno = dt / dyno_tau
    k_press = dt / p_tau
    lim0 = tau_lim[0] * eta * nred
    lim1 = tau_lim[1] * eta * nred
    lim2 = tau_lim[2] * eta * nred
    en0, en1, en2 = enabled[0] != 0, enabled[1] != 0, enabled[2] != 0
    fs0, fs1, fs2 = fail_step[0], fail_step[1], fail_step[2]
    # state
    q, qd, u, ud, x, ds = S[S_Q], S[S_QD], S[S_U], S[S_UD], S[S_X], S[S_DS]
    in0, in1, in2 = S[S_INT], S[S_INT + 1], S[S_INT + 2]
    tw0, tw1, tw2, tj = S[S_TW], S[S_TW + 1], S[S_TW + 2], S[S_TJ]
    tauf, p = S[S_TAUF], S[S_P]
    o1x, o1y, o2x, o2y = S[S_OSC1X], S[S_OSC1Y], S[S_OSC2X], S[S_OSC2Y]
    mq0, mq1, mq2 = S[S_MQ], S[S_MQ + 1], S[S_MQ + 2]
    qdd, udd = S[S_QDD], S[S_UDD]
    pos = np.int64(S[S_RING])
    step = np.int64(S[S_STEP])

    ncmd = tau_cmd.shape[0]
    n_rec = sample_steps.shape[0]
    L = ring.shape[0]
    next_sample = sample_steps[j] if j < n_rec else -1
    for i in range(n_steps):
        c = i if ncmd > 1 else 0
        T, delta_s = transmission(q, qd, u, ud, x, k_u, k_h, damp, bl_on, bl_b)
        tau_l = tauf + err_a1 * o1y + err_a2 * o2y
        c0 = step < fs0
        c1 = step < fs1
        c2 = step < fs2
        n_rot = int(c0) + int(c1) + int(c2)
        tq0, e0, s0 = drive(speed_setpoint(w_set, c, 0, pos_on, pos_ref, u, kp_pos, nred),
                            in0, ud, c0 and en0, lim0, kp, inv_nred)
        tq1, e1, s1 = drive(speed_setpoint(w_set, c, 1, pos_on, pos_ref, u, kp_pos, nred),
                            in1, ud, c1 and en1, lim1, kp, inv_nred)
        tq2, e2, s2 = drive(speed_setpoint(w_set, c, 2, pos_on, pos_ref, u, kp_pos, nred),
                            in2, ud, c2 and en2, lim2, kp, inv_nred)
        t_drive = tq0 + tq1 + tq2

        # time_delay ring buffer (filled with the first torque at the run's first step)
        if step == 0:
            for r in range(L):
                ring[r] = T
        ring[pos] = T
        back = pos - d
        t_sg = ring[back + L if back < 0 else back]
        pos = pos + 1 if pos + 1 < L else 0

        recorded = step == next_sample
        if recorded:
            row = rec[j]
            row[R_T] = step * dt
            row[R_Q] = q
            row[R_QD] = qd
            row[R_U] = u
            row[R_UD] = ud
            row[R_TQ_SG] = t_sg
            row[R_TQ] = T
            row[R_TAUL] = tau_l
            row[R_TAUCMD] = tau_cmd[c]
            row[R_I] = tq0 * conv
            row[R_I + 1] = tq1 * conv
            row[R_I + 2] = tq2 * conv
            row[R_W] = nred * ud if c0 else 0.0
            row[R_W + 1] = nred * ud if c1 else 0.0
            row[R_W + 2] = nred * ud if c2 else 0.0
            row[R_TW] = tw0
            row[R_TW + 1] = tw1
            row[R_TW + 2] = tw2
            row[R_MQ] = mq0
            row[R_MQ + 1] = mq1
            row[R_MQ + 2] = mq2
            row[R_TJ] = tj
            row[R_P] = p
            row[R_X] = x
            row[R_TWIST] = delta_s

        # drives' integrators
        in0 = integrate_pi(in0, e0, s0, ki, dt)
        in1 = integrate_pi(in1, e1, s1, ki, dt)
        in2 = integrate_pi(in2, e2, s2, ki, dt)

        # motor side (symplectic Euler); all motors braked -> the train stands still
        if n_rot > 0:
            udd = (t_drive - T - b_m * nred * nred * ud) * inv_j_rotor / n_rot
            ud_new = ud + dt * udd
        else:
            ud_new = 0.0
            udd = -ud * inv_dt
        u += dt * ud_new
        dmq = dt * nred * ud_new
        if c0:
            mq0 += dmq
        if c1:
            mq1 += dmq
        if c2:
            mq2 += dmq

        # output side, Eq. 4 + load + effects
        r_tq = T - tau_l - gravity_torque(q, mr_x, mr_y)
        if gr_on != 0.0:
            r_tq -= gear_ripple_torque(q, gr_a, gr_order, gr_phase)
        qd_new, f_used = output_velocity(qd, r_tq, T, tj, m_out, fp)
        if not (abs(qd_new) < DIVERGED and abs(ud_new) < DIVERGED):
            raise FloatingPointError("emulator state diverged (|speed| > 100 rad/s at the output)")
        qdd = (qd_new - qd) * inv_dt
        q += dt * qd_new

        # transmission's Bouc–Wen state over this step's increment of the spring twist
        ds_new = spring_twist(u - q, bl_on, bl_b)
        if hyst_on != 0.0:
            x = bouc_wen_step(ds_new - ds, x, alpha, beta, gamma, n_bw)
        ds = ds_new

        if recorded:
            rec[j, R_QDD] = qdd
            rec[j, R_UDD] = udd
            j += 1
            next_sample = sample_steps[j] if j < n_rec else -1

        # temperatures (heat of this step, before the speeds change)
        i0, i1, i2 = tq0 * conv, tq1 * conv, tq2 * conv
        tw0 += k_wind * (i0 * i0 * r_wind - (tw0 - t_amb) * g_wind)
        tw1 += k_wind * (i1 * i1 * r_wind - (tw1 - t_amb) * g_wind)
        tw2 += k_wind * (i2 * i2 * r_wind - (tw2 - t_amb) * g_wind)
        p_loss = abs(f_used * qd) + (1.0 - eta) * abs(t_drive * ud)
        tj += k_joint * (p_loss - (tj - t_amb) * g_joint)
        ud = ud_new
        qd = qd_new

        # dynamometer lag and its slow error oscillators
        tauf += k_dyno * (tau_cmd[c] - tauf)
        o1x, o1y = o1x * o1c - o1y * o1s, o1x * o1s + o1y * o1c
        o2x, o2y = o2x * o2c - o2y * o2s, o2x * o2s + o2y * o2c

        # hydraulics
        target = min(max(p_set[c], 0.0), p_max) if pump[c] != 0.0 else 0.0
        p += k_press * (target - p)

        step += 1

    S[S_Q], S[S_QD], S[S_U], S[S_UD], S[S_X], S[S_DS] = q, qd, u, ud, x, ds
    S[S_INT], S[S_INT + 1], S[S_INT + 2] = in0, in1, in2
    S[S_TW], S[S_TW + 1], S[S_TW + 2], S[S_TJ] = tw0, tw1, tw2, tj
    S[S_TAUF], S[S_P] = tauf, p
    S[S_OSC1X], S[S_OSC1Y], S[S_OSC2X], S[S_OSC2Y] = o1x, o1y, o2x, o2y
    S[S_MQ], S[S_MQ + 1], S[S_MQ + 2] = mq0, mq1, mq2
    S[S_QDD], S[S_UDD] = qdd, udd
    S[S_RING] = pos
    S[S_STEP] = step
    return j


@numba.njit(cache=True)
def snapshot(S, PF, ring, w_set, pos_ref, pos_on, tau_cmd, enabled, fail_step, tau_lim, row):
    """Fill one record row with the true values at the current state, without stepping: what
    the sensors sample now (the live emulator's read()). Commands as in advance() (row 0 used);
    QDD/UDD are the accelerations over the last step."""
    T, delta_s = transmission(S[S_Q], S[S_QD], S[S_U], S[S_UD], S[S_X], PF[K_U], PF[K_H],
                              PF[DAMP], PF[BL_ON], PF[BL_B])
    step = np.int64(S[S_STEP])
    nred = PF[NRED]
    conv = 1.0 / (PF[ETA] * nred * PF[K_T])
    d = int(PF[DELAY_STEPS])
    L = ring.shape[0]
    t_sg = T if (d == 0 or step == 0) else ring[(np.int64(S[S_RING]) + L - d) % L]
    row[R_T] = step * PF[DT]
    row[R_Q] = S[S_Q]
    row[R_QD] = S[S_QD]
    row[R_U] = S[S_U]
    row[R_UD] = S[S_UD]
    row[R_TQ_SG] = t_sg
    row[R_TQ] = T
    row[R_TAUL] = S[S_TAUF] + PF[ERR_A1] * S[S_OSC1Y] + PF[ERR_A2] * S[S_OSC2Y]
    row[R_TAUCMD] = tau_cmd[0]
    for k in range(N_MOTORS):
        coupled = step < fail_step[k]
        w = speed_setpoint(w_set, 0, k, pos_on, pos_ref, S[S_U], PF[KP_POS], nred)
        tq, e, code = drive(w, S[S_INT + k], S[S_UD], coupled and enabled[k] != 0,
                            tau_lim[k] * PF[ETA] * nred, PF[KP], 1.0 / nred)
        row[R_I + k] = tq * conv
        row[R_W + k] = nred * S[S_UD] if coupled else 0.0
        row[R_TW + k] = S[S_TW + k]
        row[R_MQ + k] = S[S_MQ + k]
    row[R_TJ] = S[S_TJ]
    row[R_P] = S[S_P]
    row[R_X] = S[S_X]
    row[R_TWIST] = delta_s
    row[R_QDD] = S[S_QDD]
    row[R_UDD] = S[S_UDD]
