"""A small stand-in for simulators.live.LiveJoint used by the protocol-layer tests only: it
implements the live API's methods (/work/briefs/live_api.md) with crude first-order dynamics,
so the Modbus/CANopen layers can be tested without the physics. Not used by any product code."""

from __future__ import annotations

from core.channels import NUMERIC_CHANNELS
from core.params import JointParams


class FakeLiveJoint:
    def __init__(self, config=None, params: JointParams | None = None,
                 temps: tuple[float, float, float] = (20.0, 20.0, 20.0)) -> None:
        self.p = params or JointParams()
        self.dt = 1e-3
        self.t = 0.0
        self.enabled = [False] * 3
        self.failed = [False] * 3
        self.w_sp = [0.0] * 3
        self.tau_lim = [1e9] * 3
        self.w = [0.0] * 3
        self.q_m = [0.0] * 3
        self.temp = list(temps)
        self.dyno_sp = 0.0
        self.dyno = 0.0
        self.pump = False
        self.p_sp = 0.0
        self.p_hyd = 0.0
        self.q = 0.0
        self.torque = 0.0

    def advance(self, seconds: float) -> None:
        n = max(1, int(round(seconds / self.dt)))
        for _ in range(n):
            a = self.dt * 25.0
            for k in range(3):
                target = self.w_sp[k] if (self.enabled[k] and not self.failed[k]) else 0.0
                self.w[k] += (target - self.w[k]) * a
                self.q_m[k] += self.w[k] * self.dt
            self.dyno += (self.dyno_sp - self.dyno) * self.dt / self.p.dyno_tau
            target_p = self.p_sp if self.pump else 0.0
            self.p_hyd += (target_p - self.p_hyd) * self.dt / self.p.p_tau
            active = [k for k in range(3) if self.enabled[k] and not self.failed[k]]
            wj = sum(self.w[k] for k in active) / max(1, len(active)) / self.p.N if active else 0.0
            self.q += wj * self.dt
            self.torque = self.dyno + self.p.f_v * wj
            self.t += self.dt

    def enable_motor(self, k: int, on: bool) -> None:
        self.enabled[k] = bool(on)

    def set_motor_speed(self, k: int, w: float) -> None:
        self.w_sp[k] = float(w)

    def set_motor_torque_limit(self, k: int, tau: float) -> None:
        self.tau_lim[k] = float(tau)

    def fail_motor(self, k: int) -> None:
        self.failed[k] = True

    def motor(self, k: int) -> dict[str, float]:
        active = [j for j in range(3) if self.enabled[j] and not self.failed[j]]
        tau = (self.torque / (len(active) * self.p.N * self.p.eta)) if k in active else 0.0
        return {"w": self.w[k], "i": tau / self.p.k_t, "temp": self.temp[k], "tau": tau,
                "q": self.q_m[k]}

    def set_dyno_torque(self, tau: float) -> None:
        self.dyno_sp = float(tau)

    def set_pump(self, on: bool) -> None:
        self.pump = bool(on)

    def set_pressure(self, p: float) -> None:
        self.p_sp = float(p)

    def read(self) -> dict[str, float]:
        out = {name: 0.0 for name in NUMERIC_CHANNELS}
        m = [self.motor(k) for k in range(3)]
        f = self.p_hyd * self.p.cyl_area
        out.update(t=self.t, q=round(self.q / self.p.enc_res) * self.p.enc_res,
                   qd=sum(x["w"] for x in m) / 3 / self.p.N, u=self.q, ud=0.0,
                   torsion=-self.torque / self.p.k, torque=self.torque, torque_load=self.dyno,
                   torque_cmd=self.dyno_sp, p_hyd=self.p_hyd, f_shear=f,
                   m_bend=f * self.p.arm_bend, temp_joint=20.0)
        for k in range(3):
            out[f"i_m{k+1}"] = m[k]["i"]
            out[f"w_m{k+1}"] = m[k]["w"]
            out[f"temp_m{k+1}"] = m[k]["temp"]
        return out
