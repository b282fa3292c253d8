"""Build the kernel's arrays (parameter vector, initial state, motor flags, ring buffer) from an
EmulatorConfig. The offline simulator and the live emulator both start here, so they run the same
model."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.params import N_MOTORS
from simulators import kernel as K
from simulators.config import DYNO_ERR_PERIODS, DYNO_ERR_WEIGHTS, EmulatorConfig

NEVER = np.iinfo(np.int64).max
"""fail_step of a motor that never fails."""


def drive_gains(config: EmulatorConfig) -> tuple[float, float]:
    """Output-referred PI gains of each drive's speed loop (Kp [N·m·s/rad], Ki [N·m/rad]).
    Tuned once for three motors: 3·Kp / J_total = speed_bw with J_total = I_xx + 3·J_m·N² the
    inertia the loop sees at low frequency; the PI zero sits at speed_bw / 4."""
    p = config.params
    j_total = p.I_xx + N_MOTORS * p.J_m * p.N**2
    kp = p.speed_bw * j_total / N_MOTORS
    return kp, kp * p.speed_bw / 4.0


def pack_params(config: EmulatorConfig, kp_pos: float = 0.0) -> np.ndarray:
    """The kernel's parameter vector PF. kp_pos: position-loop gain [1/s] used in position mode."""
    p = config.params
    fx = config.effects
    pf = np.zeros(K.N_PF)
    k_u, k_h = config.stiffness
    kp, ki = drive_gains(config)
    pf[K.I_XX], pf[K.MR_X], pf[K.MR_Y] = p.I_xx, p.mr_x, p.mr_y
    pf[K.F_V], pf[K.F_C], pf[K.V_EPS] = p.f_v, p.f_c, p.v_eps
    pf[K.K_U], pf[K.K_H], pf[K.DAMP] = k_u, k_h, p.D
    pf[K.ALPHA], pf[K.BETA], pf[K.GAMMA] = p.alpha, p.beta, p.gamma
    pf[K.NRED], pf[K.ETA], pf[K.K_T], pf[K.J_M], pf[K.B_M] = p.N, p.eta, p.k_t, p.J_m, p.b_m
    pf[K.KP], pf[K.KI] = kp, ki
    pf[K.R_WIND], pf[K.R_TH_M], pf[K.C_TH_M] = p.R_w, p.R_th_m, p.C_th_m
    pf[K.T_AMB], pf[K.R_TH_J], pf[K.C_TH_J] = p.temp_ambient, p.R_th_j, p.C_th_j
    pf[K.DYNO_TAU], pf[K.P_MAX], pf[K.P_TAU] = p.dyno_tau, p.p_max, p.p_tau
    pf[K.DT], pf[K.KP_POS] = config.dt, kp_pos
    pf[K.HYST_ON] = 1.0 if (config.hysteresis and k_h != 0.0) else 0.0
    if "stribeck" in fx:
        pf[K.STRIB_ON], pf[K.F_S], pf[K.V_S] = 1.0, fx["stribeck"]["f_s"], fx["stribeck"]["v_s"]
        pf[K.STRIB_DELTA] = fx["stribeck"]["delta"]
    if "load_dependent_friction" in fx:
        pf[K.LDF_ON], pf[K.MU] = 1.0, fx["load_dependent_friction"]["mu"]
        pf[K.MU_V] = fx["load_dependent_friction"]["mu_v"]
    if "temperature_friction" in fx:
        e = fx["temperature_friction"]
        pf[K.TF_ON], pf[K.C_T], pf[K.T_REF] = 1.0, e["c_T"], e["T_ref"]
        pf[K.C_TV] = e["c_Tv"]
    if "asymmetric_friction" in fx:
        e = fx["asymmetric_friction"]
        pf[K.AF_ON], pf[K.AF_DC], pf[K.AF_DV] = 1.0, e["d_c"], e["d_v"]
    if "backlash" in fx:
        pf[K.BL_ON], pf[K.BL_B] = 1.0, fx["backlash"]["b"]
    if "gear_ripple" in fx:
        e = fx["gear_ripple"]
        pf[K.GR_ON], pf[K.GR_A], pf[K.GR_ORDER], pf[K.GR_PHASE] = 1.0, e["A"], e["order"], e["phase"]
    pf[K.DELAY_STEPS] = delay_steps(config)
    w1, w2 = (2 * math.pi / T for T in DYNO_ERR_PERIODS)
    pf[K.OSC1_C], pf[K.OSC1_S] = math.cos(w1 * config.dt), math.sin(w1 * config.dt)
    pf[K.OSC2_C], pf[K.OSC2_S] = math.cos(w2 * config.dt), math.sin(w2 * config.dt)
    pf[K.ERR_A1] = DYNO_ERR_WEIGHTS[0] * p.dyno_err
    pf[K.ERR_A2] = DYNO_ERR_WEIGHTS[1] * p.dyno_err
    return pf


def delay_steps(config: EmulatorConfig) -> int:
    """Lag of the torque channel in internal steps (time_delay's `delay` rounded to dt)."""
    if "time_delay" not in config.effects:
        return 0
    d = config.effects["time_delay"]["delay"]
    if d < 0:
        raise ValueError(f"time_delay must be >= 0 s, got {d}")
    return int(round(d / config.dt))


def initial_state(config: EmulatorConfig, rng: np.random.Generator) -> np.ndarray:
    """State at t = 0: joint zeroed (q = u = 0) at rest, transmission relaxed, temperatures as
    configured (ambient by default), dynamometer and pressure at 0. The dynamometer error's two
    phases are the first draws from the run's generator."""
    p = config.params
    s = np.zeros(K.N_S)
    temps = config.temp_motor_init or (p.temp_ambient,) * N_MOTORS
    s[K.S_TW:K.S_TW + N_MOTORS] = temps
    s[K.S_TJ] = p.temp_ambient if config.temp_joint_init is None else config.temp_joint_init
    ph1, ph2 = rng.uniform(0.0, 2 * math.pi, size=2)
    s[K.S_OSC1X], s[K.S_OSC1Y] = math.cos(ph1), math.sin(ph1)
    s[K.S_OSC2X], s[K.S_OSC2Y] = math.cos(ph2), math.sin(ph2)
    return s


def fail_steps(config: EmulatorConfig) -> np.ndarray:
    """Global step at which each motor fails (NEVER when it does not)."""
    out = np.full(N_MOTORS, NEVER, dtype=np.int64)
    for k, t_fail in config.failed_motors.items():
        out[k] = int(math.ceil(t_fail / config.dt - 1e-9))
    return out


def default_torque_limits(config: EmulatorConfig) -> np.ndarray:
    """Each drive's torque limit at the motor shaft [N·m]: k_t·i_max."""
    return np.full(N_MOTORS, config.params.k_t * config.params.i_max)


@dataclass
class KernelSetup:
    """Everything the kernel needs besides the commands and the record buffer."""
    pf: np.ndarray
    state: np.ndarray
    ring: np.ndarray
    n_bw: int
    fail_step: np.ndarray
    tau_lim: np.ndarray
    enabled: np.ndarray


def setup(config: EmulatorConfig, rng: np.random.Generator, kp_pos: float = 0.0) -> KernelSetup:
    """Parameter vector, initial state and motor flags for one run of `config`."""
    pf = pack_params(config, kp_pos)
    return KernelSetup(
        pf=pf, state=initial_state(config, rng),
        ring=np.zeros(int(pf[K.DELAY_STEPS]) + 1), n_bw=int(config.params.n),
        fail_step=fail_steps(config), tau_lim=default_torque_limits(config),
        enabled=np.ones(N_MOTORS, dtype=np.int64))
