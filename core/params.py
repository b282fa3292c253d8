"""Nominal parameters of the J4 joint and its test rig, with units and where each default comes
from. One source of truth: the emulator's truth defaults and the identification models' parameter
names both come from here.

Sources: "T3" = Table 3 of the paper (least-squares Eq. 4 fit), "T10"/"T11" = Tables 10/11,
"rig.md" = ../shared/docs/rig.md, "design" = our engineering choice, justified in the comment.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field, fields

G = 9.81
"""Gravitational acceleration [m/s²]."""

REDUCTION = 11000.0
"""Total reduction N from motor to joint output [-] (rig.md)."""

RATED_TORQUE = 120e3
"""Rated joint output torque [N·m] (rig.md, T10/T11)."""

N_MOTORS = 3
"""Motors driving the joint through the reduction (rig.md)."""


def _p(default: float, unit: str, source: str, doc: str):
    return field(default=default, metadata={"unit": unit, "source": source, "doc": doc})


@dataclass(frozen=True)
class JointParams:
    """Physical parameters of the joint, transmission, motors and loading equipment (SI units,
    temperatures in °C). Frozen: derive variants with `dataclasses.replace`."""

    # --- output side, Eq. 4 -------------------------------------------------------------
    I_xx: float = _p(6685.0, "kg·m²", "T3", "output-side moment of inertia about the joint axis")
    mr_x: float = _p(20.8, "kg·m", "T3", "first mass moment, x (gravity torque g·mr_x·sin q)")
    mr_y: float = _p(-34.5, "kg·m", "T3", "first mass moment, y (gravity torque g·mr_y·cos q)")
    f_v: float = _p(8683.0, "N·m·s/rad", "T3", "output viscous friction coefficient")
    f_c: float = _p(2353.0, "N·m", "T3", "output Coulomb friction torque")
    v_eps: float = _p(2e-5, "rad/s", "design",
                      "speed scale of the smoothed sign tanh(v/v_eps) used for friction; "
                      "below the 300 r/min output speed (2.9e-3 rad/s) by >100x")

    # --- flexible transmission, Bouc–Wen, Eqs. 7–9 ----------------------------------------
    k: float = _p(1.6e7, "N·m/rad", "design (rig.md)",
                  "total transmission stiffness; with w, alpha, beta, gamma below the joint "
                  "twists ~0.5° (8.7e-3 rad) at the rated 120 kN·m")
    w: float = _p(0.8, "-", "design", "elastic share of the stiffness: k_u = w·k, k_h = (1−w)·k")
    D: float = _p(2.0e5, "N·m·s/rad", "design",
                  "transmission damping; damps the ~8 Hz drive-train mode to ζ≈0.25")
    alpha: float = _p(1.0, "-", "rig.md", "Bouc–Wen α; fixed at 1 (only α·k_h is identifiable)")
    beta: float = _p(600.0, "1/rad", "design", "Bouc–Wen β; with γ sets the yield twist α/(β+γ)")
    gamma: float = _p(400.0, "1/rad", "design",
                      "Bouc–Wen γ; yield twist α/(β+γ)=1e-3 rad (0.057°) so the joint yields "
                      "well before the rated load")
    n: int = _p(1, "-", "paper", "Bouc–Wen exponent (the paper fixes n = 1)")

    # --- motors and drives (S120), motor side ------------------------------------------
    N: float = _p(REDUCTION, "-", "rig.md", "total reduction")
    eta: float = _p(0.9, "-", "design", "nominal transmission efficiency in Σ k_t·i·N·η = T")
    k_t: float = _p(1.9, "N·m/A", "design",
                    "motor torque constant (S120-class 1FK7 servo); ~2.4 A per motor at 120 kN·m")
    J_m: float = _p(2.0e-4, "kg·m²", "design", "rotor + first gear stage inertia of one motor")
    b_m: float = _p(0.0, "N·m·s/rad", "design", "motor-side viscous friction, referred to the motor")
    speed_bw: float = _p(25.0, "rad/s", "design", "closed-loop bandwidth of the drives' speed loop")
    i_max: float = _p(20.0, "A", "design", "drive current limit per motor")
    R_th_m: float = _p(0.8, "K/W", "design", "motor winding-to-ambient thermal resistance")
    C_th_m: float = _p(4000.0, "J/K", "design", "motor winding thermal capacity (τ ≈ 53 min)")
    R_w: float = _p(1.2, "Ω", "design", "motor winding resistance (copper losses i²·R)")

    # --- joint / gearbox thermal ---------------------------------------------------------
    temp_ambient: float = _p(20.0, "°C", "design", "ambient and initial temperature")
    R_th_j: float = _p(0.05, "K/W", "design", "gearbox-to-ambient thermal resistance")
    C_th_j: float = _p(2.0e5, "J/K", "design", "gearbox thermal capacity (τ ≈ 2.8 h)")

    # --- dynamometer ---------------------------------------------------------------------
    dyno_tau: float = _p(0.2, "s", "design", "dynamometer torque-loop lag (first order)")
    dyno_err: float = _p(600.0, "N·m", "design (T11)",
                         "amplitude of the dynamometer's slow tracking error, inside ±2 kN·m")

    # --- hydraulics (pump, proportional pressure regulator, accumulator, cylinder) ---------
    p_max: float = _p(25e6, "Pa", "design", "pump/relief pressure")
    p_tau: float = _p(0.5, "s", "design", "pressure regulator + accumulator time constant")
    cyl_area: float = _p(4.0e-3, "m²", "design", "cylinder piston area (90 kN at 22.5 MPa)")
    arm_bend: float = _p(2.5, "m", "design", "lever of the cylinder force on the loading shaft")

    # --- sensors ---------------------------------------------------------------------------
    enc_res: float = _p(0.01 * 3.141592653589793 / 180.0, "rad", "T10",
                        "output encoder resolution (0.01°)")
    motor_enc_counts: float = _p(2.0**20, "counts/rev", "design", "motor encoder resolution")
    torque_noise: float = _p(150.0, "N·m", "design", "strain-gauge torque noise (1σ)")
    load_noise: float = _p(100.0, "N·m", "design", "dynamometer torque transducer noise (1σ)")
    current_noise: float = _p(0.01, "A", "design", "current measurement noise (1σ)")
    temp_noise: float = _p(0.05, "K", "design", "temperature measurement noise (1σ)")
    pressure_noise: float = _p(2e4, "Pa", "design", "pressure transmitter noise (1σ)")
    force_noise: float = _p(200.0, "N", "design", "shear / bending load-cell noise (1σ, N or N·m)")
    speed_noise: float = _p(2e-6, "rad/s", "design",
                            "noise of the output speed estimate (motor encoders / N, 1σ)")

    @property
    def k_u(self) -> float:
        """Elastic stiffness w·k [N·m/rad]."""
        return self.w * self.k

    @property
    def k_h(self) -> float:
        """Hysteretic stiffness (1−w)·k [N·m/rad]."""
        return (1.0 - self.w) * self.k

    def replace(self, **changes) -> "JointParams":
        return dataclasses.replace(self, **changes)

    @classmethod
    def describe(cls) -> list[dict]:
        """Every parameter with its default, unit, source and meaning (for docs and `--help`)."""
        return [
            {"name": f.name, "default": f.default, "unit": f.metadata["unit"],
             "source": f.metadata["source"], "doc": f.metadata["doc"]}
            for f in fields(cls)
        ]


RIGID_BODY_PARAMS = ("I_xx", "mr_x", "mr_y", "f_v", "f_c")
"""Eq. 4's identifiable parameters in the paper's order (Table 3)."""
