"""Physics terms shared by the emulator and the identification models (rig.md, Eqs. 4 and 7–11).

Every function here is plain NumPy arithmetic on scalars or arrays, so the same source serves
three callers: the estimator calls it on whole arrays, the emulator compiles it with numba into
its time-stepping kernel, and tests call it directly. Units are SI; angles in rad.
"""

from __future__ import annotations

import numpy as np

from core.params import G


def smooth_sign(v, v_eps):
    """sgn(v) smoothed over |v| ≲ v_eps [rad/s]: tanh(v / v_eps). Used for every friction term
    so that the emulator's stiff stick–slip stays integrable at 1 kHz."""
    return np.tanh(v / v_eps)


def gravity_torque(q, mr_x, mr_y):
    """Gravity torque on the output [N·m]: g·(mr_x·sin q + mr_y·cos q) (Eq. 4)."""
    return G * (mr_x * np.sin(q) + mr_y * np.cos(q))


def viscous_coulomb_friction(qd, f_v, f_c, v_eps):
    """Output friction [N·m]: f_v·q̇ + f_c·sgn(q̇) (Eq. 4)."""
    return f_v * qd + f_c * smooth_sign(qd, v_eps)


def rigid_body_torque(q, qd, qdd, I_xx, mr_x, mr_y, f_v, f_c, v_eps):
    """Torque the joint must transmit beyond the load, Eq. 4:
    I·q̈ + g·(mr_x·sin q + mr_y·cos q) + f_v·q̇ + f_c·sgn(q̇) = T − τ_L  [N·m]."""
    return I_xx * qdd + gravity_torque(q, mr_x, mr_y) + viscous_coulomb_friction(qd, f_v, f_c, v_eps)


def eq4_regressor(q, qd, qdd, v_eps):
    """Observation matrix of Eq. 4 for θ = (I_xx, mr_x, mr_y, f_v, f_c): columns
    [q̈, g·sin q, g·cos q, q̇, sgn q̇]; y = T − τ_L = Y·θ. Shape (n, 5)."""
    q = np.asarray(q, dtype=float)
    return np.column_stack([
        np.asarray(qdd, dtype=float),
        G * np.sin(q),
        G * np.cos(q),
        np.asarray(qd, dtype=float),
        smooth_sign(np.asarray(qd, dtype=float), v_eps),
    ])


def bouc_wen_rate(dd, x, alpha, beta, gamma, n):
    """Bouc–Wen latent-state rate, Eq. 9 [rad/s]:
    ẋ = α·Δ̇ − β·|Δ̇|·|x|^(n−1)·x − γ·Δ̇·|x|^n, with Δ̇ = dd the twist rate."""
    ax = np.abs(x)
    if n == 1:
        return alpha * dd - beta * np.abs(dd) * x - gamma * dd * ax
    return alpha * dd - beta * np.abs(dd) * ax ** (n - 1) * x - gamma * dd * ax ** n


def bouc_wen_step(d_delta, x, alpha, beta, gamma, n):
    """Advance the Bouc–Wen state x over a twist increment d_delta [rad]: Eq. 9 written in the
    twist, dx/dΔ = α − β·sgn(Δ̇)·|x|^(n−1)·x − γ·|x|^n, integrated with explicit sub-steps small
    enough that |(β+γ)·|x|^(n−1)·dΔ| ≤ 0.05. The emulator and the identification's recursion both
    call this, so they integrate the hysteresis identically (and its derivative is simple)."""
    s = 1.0 if d_delta >= 0.0 else -1.0
    scale = (abs(beta) + abs(gamma)) * max(abs(x), 1e-3) ** (n - 1)
    m = int(abs(d_delta) * scale / 0.05) + 1
    h = d_delta / m
    for _ in range(m):
        ax = abs(x)
        x = x + (alpha - beta * s * ax ** (n - 1) * x - gamma * ax ** n) * h
    return x


def transmission_torque(delta, delta_dot, x, k_u, k_h, D):
    """Transmitted torque of the flexible joint, Eqs. 7–8 with k_u = w·k, k_h = (1−w)·k [N·m]:
    T = D·Δ̇ + k_u·Δ + k_h·x."""
    return D * delta_dot + k_u * delta + k_h * x


def eq11_regressor(delta, delta_dot, x, v_eps):
    """Observation matrix of Eq. 11 as the paper fits it, θ = (k_u, k_h, f_v, D+f_c, C):
    T = (D+f_c)·u̇ + k_u·u + k_h·x + f_v·sgn(u̇) + C, with the paper's u = our twist Δ.
    Columns [Δ, x, sgn Δ̇, Δ̇, 1] in the order of θ. Shape (n, 5)."""
    delta = np.asarray(delta, dtype=float)
    dd = np.asarray(delta_dot, dtype=float)
    return np.column_stack([
        delta, np.asarray(x, dtype=float), smooth_sign(dd, v_eps), dd, np.ones_like(delta)
    ])


def motor_current_share(T, ud_dot_dot, n_active, k_t, N, eta, J_m):
    """Current each active motor carries [A] so that Σ k_t·i·N·η = T + n·J_m·N²·ü (rig.md):
    the transmitted torque T [N·m] plus the reflected rotor inertia, shared equally."""
    return (T + n_active * J_m * N * N * ud_dot_dot) / (n_active * k_t * N * eta)
