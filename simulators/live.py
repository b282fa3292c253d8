"""The joint emulator advanced under external commands: what the PLC and drive stand-ins drive.

The PLC and drive stand-ins call `advance(seconds)` in small slices (1–10 ms of simulated time
is typical) and set commands between slices; a caller pacing it against the wall clock applies
its own time_scale (simulated seconds per wall second). It runs the same numba kernel as the
offline simulator (simulators.kernel.advance), with the commands held constant over each slice,
and `read()` samples the sensors now through the same sensor models (simulators.sensors).

Motors start enabled with a speed set point of 0 (the drives hold the joint); a stand-in that
models the drives' power-up state machine disables them first. Failed motors (config or
fail_motor) give no torque and cannot be re-enabled. Every call holds one internal lock, so a
PLC server thread and a CAN thread may share one LiveJoint.
"""

from __future__ import annotations

import functools
import math
import threading
from typing import Callable

import numpy as np

from core.params import N_MOTORS
from simulators import kernel as K
from simulators.config import EmulatorConfig
from simulators.model import setup
from simulators.sensors import motor_encoder_step, noise_sigmas, sense

_NO_SAMPLES = np.zeros(0, dtype=np.int64)
_NO_RECORDS = np.zeros((0, K.N_R))


def _locked(method: Callable) -> Callable:
    """Run a LiveJoint method under its lock."""
    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)
    return wrapper


class LiveJoint:
    """The joint emulator advanced in real or scaled time under external commands."""

    def __init__(self, config: EmulatorConfig | None = None) -> None:
        self.config = config or EmulatorConfig()
        self.rng = np.random.Generator(np.random.PCG64(self.config.seed))
        ks = setup(self.config, self.rng)
        self._pf = ks.pf
        self._state = ks.state
        self._ring = ks.ring
        self._n_bw = ks.n_bw
        self._fail_step = ks.fail_step
        self._tau_lim = ks.tau_lim
        self._enabled = ks.enabled
        self._w_set = np.zeros((1, N_MOTORS))
        self._pos_ref = np.zeros(1)
        self._tau_cmd = np.zeros(1)
        self._p_set = np.zeros(1)
        self._pump = np.zeros(1)
        self._pending = 0.0
        self._lock = threading.RLock()
        self.dt: float = self.config.dt
        """Internal step [s]."""

    # --- time ---------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulated time since start [s] (a whole number of internal steps)."""
        return float(self._state[K.S_STEP]) * self.dt

    @_locked
    def advance(self, seconds: float) -> None:
        """Integrate `seconds` of simulated time with the current commands. Slices that are not
        a whole number of steps carry their remainder to the next call, so many small slices add
        up to the same time as one long one."""
        if not (seconds >= 0.0 and math.isfinite(seconds)):
            raise ValueError(f"advance() needs a finite time >= 0 s, got {seconds!r}")
        total = self._pending + seconds
        n = int(math.floor(total / self.dt + 1e-9))
        self._pending = max(total - n * self.dt, 0.0)
        if n > 0:
            K.advance(self._state, self._pf, self._n_bw, self._ring, self._w_set, self._pos_ref,
                      0, self._tau_cmd, self._p_set, self._pump, self._enabled, self._fail_step,
                      self._tau_lim, _NO_SAMPLES, _NO_RECORDS, 0, n)

    # --- drive side -----------------------------------------------------------------------
    def _check(self, k: int) -> int:
        if k not in range(N_MOTORS):
            raise IndexError(f"motor index {k!r} out of range 0..{N_MOTORS - 1}")
        return int(k)

    @_locked
    def enable_motor(self, k: int, on: bool) -> None:
        """Power stage of motor k on/off (off: no torque, it coasts with the gear train)."""
        self._enabled[self._check(k)] = 1 if on else 0

    @_locked
    def set_motor_speed(self, k: int, w: float) -> None:
        """Speed set point of motor k [rad/s at the motor shaft]."""
        self._w_set[0, self._check(k)] = float(w)

    @_locked
    def set_motor_torque_limit(self, k: int, tau: float) -> None:
        """|torque| limit of motor k [N·m at the motor shaft], capped by k_t·i_max."""
        if not tau >= 0.0:
            raise ValueError(f"torque limit must be >= 0 N·m, got {tau!r}")
        p = self.config.params
        self._tau_lim[self._check(k)] = min(float(tau), p.k_t * p.i_max)

    @_locked
    def fail_motor(self, k: int) -> None:
        """Inject a motor/drive fault now: motor k gives no torque from this step on (its brake
        takes it out of the gear train; the others carry the joint)."""
        k = self._check(k)
        self._fail_step[k] = min(int(self._fail_step[k]), int(self._state[K.S_STEP]))

    @_locked
    def failed(self, k: int) -> bool:
        """True once motor k has failed."""
        return bool(self._fail_step[self._check(k)] <= self._state[K.S_STEP])

    @_locked
    def motor(self, k: int) -> dict[str, float]:
        """Motor k as its drive measures it now: speed w [rad/s], current i [A], winding
        temperature temp [°C], torque tau = k_t·i [N·m], shaft angle q [rad, encoder]."""
        k = self._check(k)
        row = self._snapshot()
        sig = noise_sigmas(self.config)
        z = self.rng.standard_normal(3)
        i = float(row[K.R_I + k] + sig[f"i_m{k + 1}"] * z[0])
        res = motor_encoder_step(self.config)
        return {"w": float(row[K.R_W + k] + sig[f"w_m{k + 1}"] * z[1]),
                "i": i,
                "temp": float(row[K.R_TW + k] + sig[f"temp_m{k + 1}"] * z[2]),
                "tau": self.config.params.k_t * i,
                "q": float(np.round(row[K.R_MQ + k] / res) * res)}

    # --- PLC side -------------------------------------------------------------------------
    @_locked
    def set_dyno_torque(self, tau: float) -> None:
        """Dynamometer torque set point [N·m]."""
        self._tau_cmd[0] = float(tau)

    @_locked
    def set_pump(self, on: bool) -> None:
        """Hydraulic pump on/off."""
        self._pump[0] = 1.0 if on else 0.0

    @_locked
    def set_pressure(self, p: float) -> None:
        """Proportional pressure regulator set point [Pa] (clipped to [0, p_max])."""
        self._p_set[0] = float(p)

    @_locked
    def read(self) -> dict[str, float]:
        """Every numeric run-format channel now, as the sensors read it (noise, quantisation,
        injected sensor effects, dropouts as NaN); keys from core.channels."""
        ch = sense(self._snapshot()[None, :], self.config, self.rng)
        return {name: float(v[0]) for name, v in ch.items()}

    @_locked
    def truth(self) -> dict[str, float]:
        """The true internal values now (no sensor model): for tests and diagnostics."""
        row = self._snapshot()
        out = {"t": row[K.R_T], "q": row[K.R_Q], "qd": row[K.R_QD], "u": row[K.R_U],
                "ud": row[K.R_UD], "torque": row[K.R_TQ], "torque_load": row[K.R_TAUL],
                "x": row[K.R_X], "twist": row[K.R_TWIST],
                **{f"i_m{k + 1}": row[K.R_I + k] for k in range(N_MOTORS)},
                "temp_joint": row[K.R_TJ], "p_hyd": row[K.R_P]}
        return {k: float(v) for k, v in out.items()}

    def _snapshot(self) -> np.ndarray:
        row = np.zeros(K.N_R)
        K.snapshot(self._state, self._pf, self._ring, self._w_set, self._pos_ref, 0,
                   self._tau_cmd, self._enabled, self._fail_step, self._tau_lim, row)
        return row

