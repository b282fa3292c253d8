"""Options of the sim-to-real gap diagnosis (estimator.diagnosis): significance, materiality and
the shape grids of the candidates. Why each threshold has its value, with the measurements it was
set on, is in docs/diagnosis.md."""

from __future__ import annotations

from dataclasses import dataclass, field

from estimator.diagnosis_regions import RegionOptions


@dataclass(frozen=True)
class DiagnosisOptions:
    z_gain: float = 3.0
    """Held-out gain / SE needed to call a candidate significant."""
    min_shrinkage: float = 0.005
    """Smallest held-out RMSE shrinkage that counts (1 − after/before)."""
    concentrated_min_shrinkage: float = 0.1
    """A candidate whose held-out gain sits in a few blocks (a lag's, at the torque steps) has
    a gain / SE that cannot grow with it; with at least this shrinkage it is significant also
    when more of the held-out blocks improve than chance allows (sign test, z > z_gain);
    docs/diagnosis.md."""
    max_effects: int = 3
    explained_fraction: float = 0.8
    """Share of the structured residual mean square the chosen effects must remove."""
    min_structured: float = 0.05
    """With no effect chosen, the residual is called structured only when the tests flag it and
    its part above the noise floor is at least this share of its mean square (a materiality
    threshold; docs/diagnosis.md)."""
    max_rate_hz: float = 100.0
    """The diagnosis analyses runs sampled faster than this decimated to it (low-passed first):
    see estimator.diagnosis_inputs.working_rate."""
    mode_band_excess: float = 2.0
    """The output balance is analysed below half the drive train's first mode f₁ also when its
    nominal residual holds this many times the power a white residual would put between 0.5·f₁
    and 1.5·f₁ (estimator.diagnosis_inputs.below_drive_train_mode); docs/diagnosis.md."""
    transient_s: float = 0.5
    """The output-side law leaves out the samples within this time [s] of a rest — a start, a
    stop, a reversal: where the mean speed over ±transient_s is near zero — and, alone, the
    samples near zero speed inside a motion (estimator.diagnosis_inputs.transient_mask); 0
    keeps them all."""
    block: int | None = None
    """Samples per batch-means block; None: max(10, √n per run)."""
    ripple_orders: tuple[int, ...] = tuple(range(2, 121))
    """Gear-ripple orders searched on the output angle [cycles per output revolution]."""
    motor_ripple_orders: tuple[int, ...] = (1, 2, 3, 4, 6)
    """Gear-ripple orders searched on the motor angle [cycles per motor revolution] (the motor's
    and first stage's periodic torques), when the runs carry u and their reduction."""
    ripple_harmonics: int = 3
    """Harmonics of a gear ripple searched besides the single sine: the strongest order on
    each angle is also tried with its 2nd … ripple_harmonics-th harmonic (1: none)."""
    ripple_min_periods: float = 2.0
    """Periods of a ripple a run's angle path must sweep for the run to show it: orders are
    searched only where the campaign's travel spans this many, and a gear ripple is kept only
    when its held-out gain on the runs whose path sweeps them is significant and the training
    runs that sweep them, each predicted by a fit on the others, shrink by min_shrinkage
    (estimator.diagnosis_candidates.ripple_shown)."""
    stage_ripple_max_order: int | None = None
    """Highest order [cycles per output revolution] searched on u for an intermediate gear
    stage's transmission error (orders above `ripple_orders` up to this, and below the
    sampled Nyquist order at the runs' median speed), when the runs carry u. None: the runs'
    stated reduction N, the motor's first order (a stage between the output and the motor
    turns slower than the motor; whole motor turns are `motor_ripple_orders`), or 2000 when
    the runs state no reduction."""
    stribeck_vs_rel: tuple[float, ...] = (0.03, 0.06, 0.1, 0.2, 0.35, 0.6)
    """Stribeck speeds searched, as fractions of the training runs' top |q̇|."""
    stribeck_delta: tuple[float, ...] = (0.5, 1.0, 2.0, 0.0)
    """Stribeck curves searched: exponents of exp(−|q̇/v_s|^delta), 0 the Lorentzian."""
    offset_settling_s: tuple[float, ...] = (10.0, 30.0, 100.0)
    """Settling time constants [s] of the torque reading searched besides a constant and a
    linear drift (torque_offset)."""
    driving_load_min_rel: float = 0.1
    """Loaded samples, for telling a load-dependent friction from a gain mismatch of the torque
    readings: |T| above this share of the runs' largest."""
    driving_load_min_share: float = 0.01
    """Share of the loaded samples with T·q̇ < 0 (the load driving the joint) below which the runs
    cannot tell a load-dependent friction from a gain mismatch of the torque readings."""
    torque_gain_min_share: float = 0.2
    """The torque reading's gain against the load reading (estimator.models.with_torque_gain)
    can enter the output law's nominal only when at least this share of the training runs'
    loaded samples has the load driving the joint and at least this share has it resisting:
    only then are that gain and a load-dependent friction different columns."""
    torque_gain: bool | None = None
    """Whether the output law's nominal carries that gain (where it can): None decides from the
    runs — the search runs without it, and again with it when it is significant on the held-out
    runs beside the effects chosen (estimator.diagnosis); True: always; False: never."""
    thermal_min_span_c: float = 5.0
    """Span of the training runs' joint temperature [K] from which a law that follows it is
    tried: torque_offset as a zero that drifts with it (a strain gauge's, N·m per K), and the
    twist–torque nominal's stiffness change with it (stiffness_thermal)."""
    stiffness_thermal: bool | None = None
    """Whether the twist–torque nominal carries a stiffness that follows the joint's temperature
    (estimator.models.with_stiffening): None decides from the training runs
    (estimator.diagnosis_transmission.thermal_stiffness); True: whenever the runs carry
    temp_joint; False: never."""
    temperature_curvatures: tuple[float, ...] = (0.03, 0.06, 0.1, -0.03)
    """Curvatures κ [1/K] of the temperature law searched besides the linear one
    (core.effects.temperature_friction_torque: a drag ∝ exp(κ·(T_ref − temp)) − 1)."""
    backlash_b_rel: tuple[float, ...] = (0.002, 0.004, 0.008, 0.016, 0.032, 0.064, 0.13)
    """Backlash dead-zone half-widths b searched, as fractions of the training runs' top |Δ|
    (99th percentile of the twist)."""
    compliance_knee_rel: tuple[float, ...] = (0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6,
                                              0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95)
    """Knee twists searched for the two stiffness changes of the nominal compliance curve
    (estimator.models.with_stiffening), as fractions of the training runs' top |Δ|; all above
    the widest backlash b searched (backlash_b_rel), so a softening within ±b stays the backlash
    candidate's and a stiffness change beyond it is the curve's."""
    compliance_corner_rel: tuple[float, ...] = (0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.75, 0.9,
                                                1.1, 1.4)
    """Corners δ searched for a stiffness change spread smoothly over the twist (the nominal
    compliance curve's estimator.models.corner_column, kept when the training runs confirm it:
    estimator.diagnosis_transmission.smooth_corner), as fractions of the training runs' top
    |Δ|; all above the widest backlash b searched (backlash_b_rel), as the knees are."""
    soft_centre_min_ratio: float = 0.25
    """Least stiffness inside a soft centre of the compliance curve, as a share of the stiffness
    beyond it, for the centre to be the nominal curve's first segment rather than a dead zone
    (estimator.diagnosis_transmission.centre_knee): a dead zone leaves ≈ 0, a harmonic drive's catalogue
    K1/K2 is 0.5–0.7; docs/diagnosis.md."""
    soft_centre_min_steps: float = 5.0
    """Least half-width of a soft centre, in steps of the twist's measurement (the encoders'
    stated resolution): a dead zone a few steps wide, blurred by the rounding, is a soft centre
    too (estimator.diagnosis_transmission.centre_knee); docs/diagnosis.md."""
    bw_yield_rel: tuple[float, ...] = (0.01, 0.02, 0.04, 0.07, 0.12, 0.2, 0.35)
    """Bouc–Wen yield twists α/(β+γ) searched (α = 1, n = 1; only α·k_h is identifiable), as
    fractions of the training runs' top |Δ| — for the nominal Bouc–Wen law and for the
    hysteresis candidate of an elastic law."""
    lines_veto: bool = True
    """A spectral line left in the residual (in time or in output angle) keeps the verdict from
    `explained`."""
    transmission_min_structured: float = 0.75
    """min_structured of the twist–torque law (no line veto there); docs/diagnosis.md."""
    transmission_min_shrinkage: float = 0.04
    """min_shrinkage of the twist–torque law (a materiality threshold); docs/diagnosis.md."""
    predictor: str = "noise_level"
    """How the held-out shrinkage is predicted from the training runs: 'noise_level' or
    'training_ratio' (see _predicted)."""
    transmission_predictor: str = "training_ratio"
    """predictor of the twist–torque law; docs/diagnosis.md."""
    transmission_decimate: int = 5
    """The twist–torque law is diagnosed on runs low-passed and decimated by this factor
    (estimator.preprocess): the output encoder's step jitters the twist between samples, and the
    Bouc–Wen state would run spurious loops along it; docs/diagnosis.md."""
    twist_zero_per_run: bool = True
    """Each run's zero of the twist is set from its own data, within the encoders' stated steps
    (estimator.diagnosis_transmission.twist_zeros); docs/diagnosis.md."""
    bw_beta_share: tuple[float, ...] = (0.3, 0.6, 0.9)
    """β/(β+γ) searched with each yield twist (sets the unloading branch's shape)."""
    bw_gamma_ratio_generic: tuple[float, ...] = (-1.5, -1.0, -0.5, 0.0, 0.5, 1.0)
    """γ/β searched besides those shares on a law whose displacement is the position (a
    hysteretic system without a twist channel), with β = 1/(yield fraction · top |q − median|)."""
    min_structure_share: float = 0.1
    """A candidate is chosen only when its held-out gain removes at least this share of the
    mean square the current model leaves above the noise floor (materiality relative to the
    gap in hand, not to the signal)."""
    parsimony_alpha: float = 0.05
    """An effect beyond the first is kept only when its per-run gains (held-out runs and
    leave-one-run-out training runs) are positive on more runs than chance would give, by a
    one-sided sign test at this level (estimator.diagnosis_candidates.run_consistency)."""
    diverged_peak_ratio: float = 1e6
    """A run whose peak |reading| of a channel exceeds the campaign's median peak of that channel
    by this factor is refused by name (estimator.diagnosis_data.refuse_diverged): a diverged
    simulation or a corrupted record, not a measurement of the same rig."""
    candidates: tuple[str, ...] | None = None
    """Effects to try (default: the whole vocabulary, those applicable)."""
    regions: RegionOptions = field(default_factory=RegionOptions)
    n_boot: int = 400
    seed: int = 0
    series_points: int = 0
    """With > 0, the report carries `series`: at most this many samples per run (evenly
    decimated) of the measured target, the nominal and the final model's predictions and the
    flagged regions' members, for plots (api reports); 0: no series."""

    def __post_init__(self) -> None:
        if not 1.0 <= self.ripple_min_periods < 100.0:   # NaN fails too
            raise ValueError("ripple_min_periods must be a number of periods in [1, 100), not "
                             f"{self.ripple_min_periods!r}")
        if not 0.0 <= self.concentrated_min_shrinkage <= 1.0:   # NaN fails too
            raise ValueError("concentrated_min_shrinkage must be a shrinkage in [0, 1], not "
                             f"{self.concentrated_min_shrinkage!r}")
