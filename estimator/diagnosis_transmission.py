"""The nominal twist–torque law of the diagnosis's transmission check (estimator.diagnosis): the
elastic law with a cubic stiffening, the two knees of its compliance curve, a soft or stiff
centre and a stiffness change spread about a corner, all found from the training runs, and the
encoders' step as the twist sees it."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from core.run import RunData
from estimator.diagnosis_candidates import _Fit, angle_lag_objection, bouc_wen_grid, ls_stiffness
from estimator.diagnosis_data import (_pool, base_model, derived_torsion, stated_resolution,
                                      twist_step)
from estimator.diagnosis_options import DiagnosisOptions
from estimator.diagnosis_stats import block_ids, block_robust_cov, block_size, blocks_improved_z
from estimator.least_squares import OLSResult, leave_one_group_out, ols
from estimator.models import (LinearModel, bouc_wen_x, corner_column, eq11, knee_column,
                              thermal_stiffness_column, with_stiffening)
from estimator.preprocess import PrepOptions


TRANSMISSION_SIGNALS = ("torsion", "torsion_rate", "torque")


def _elastic_basis(tr: dict, knees: Sequence[float] = (), corner: float | None = None
                   ) -> tuple[float, np.ndarray, np.ndarray]:
    """The training twist's top |Δ| [rad] (its 99th percentile), the columns of the elastic law
    T = k·Δ + D·Δ̇ + C + k3·Δ³ (+ a stiffness change beyond each of `knees`, + one spread
    smoothly about `corner`: corner_column), and an orthonormal
    basis of them (column-normalised first): the profile least squares of compliance_knees
    and soft_centre project a trial column and the torque on it."""
    d = np.asarray(tr["torsion"], dtype=float)
    top = float(np.quantile(np.abs(d), 0.99)) or 1e-3
    base = np.column_stack([d, np.asarray(tr["torsion_rate"], dtype=float), np.ones_like(d),
                            d ** 3, *(knee_column(k)(tr) for k in knees),
                            *([corner_column(corner)(tr)] if corner is not None else [])])
    return top, base, _orthonormal(base)


def _orthonormal(cols: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the columns `cols` (each scaled to its largest |value| first, so
    the units do not matter): profile least squares projects a trial column and the torque on
    it."""
    q, _ = np.linalg.qr(cols / np.where(np.any(cols != 0, axis=0), np.abs(cols).max(axis=0),
                                        1.0))
    return q


def compliance_knees(tr: dict, opt: DiagnosisOptions, corner: float | None = None
                     ) -> tuple[float, float]:
    """The two knee twists [rad] of the nominal compliance curve: the pair of
    `opt.compliance_knee_rel` (fractions of the training twist's top |Δ|, its 99th
    percentile) whose elastic law — T = k·Δ + D·Δ̇ + C + k3·Δ³ + the two stiffness changes
    (+ the smooth one about `corner`, smooth_corner) — has the smallest training RSS (profile
    least squares over the knees)."""
    if min(opt.compliance_knee_rel) <= max(opt.backlash_b_rel):
        raise ValueError("compliance_knee_rel must lie above backlash_b_rel (a knee inside the "
                         "dead zones searched would take backlash's place)")
    # the knee columns and the torque with the rest of the law projected out: each pair's RSS
    # is then a 2 × 2 solve
    top, _, q = _elastic_basis(tr, corner=corner)
    y = np.asarray(tr["torque"], dtype=float)
    y = y - q @ (q.T @ y)

    def best_pair(knees: list[float], allowed) -> tuple[float, tuple[float, float]]:
        h = np.column_stack([knee_column(k)(tr) for k in knees])
        h = h - q @ (q.T @ h)
        gram, hy = h.T @ h, h.T @ y
        best, pair = np.inf, (knees[0], knees[-1])
        for i in range(len(knees)):
            for j in range(i + 1, len(knees)):
                if not allowed(knees[i], knees[j]):
                    continue
                ij = [i, j]
                coef = np.linalg.lstsq(gram[np.ix_(ij, ij)], hy[ij], rcond=None)[0]
                rss = float(y @ y - hy[ij] @ coef)
                if rss < best:
                    best, pair = rss, (knees[i], knees[j])
        return best, pair

    rel = sorted(set(opt.compliance_knee_rel))
    _, pair = best_pair([r * top for r in rel], lambda a, b: True)
    # then each knee to a fifth of the grid's step, within half a step of the grid's choice
    step = min(np.diff(rel)) * top if len(rel) > 1 else 0.05 * top
    lo = rel[0] * top
    fine = sorted({max(lo, k + f * step) for k in pair for f in np.linspace(-0.5, 0.5, 6)})
    _, pair = best_pair(fine, lambda a, b: (abs(a - pair[0]) <= 0.51 * step
                                            and abs(b - pair[1]) <= 0.51 * step))
    return float(pair[0]), float(pair[1])


SOFT_CENTRE_GRID = 48
"""Half-widths tried for a soft centre (soft_centre), log-spaced over the dead zones searched:
fine enough (4 % apart over the backlash grid's range) that a dead zone's own half-width is
among them."""


def twist_resolution(runs: Sequence[RunData]) -> float | None:
    """The coarsest step [rad] with which the runs measure the twist u − q (`twist_step`),
    the largest over the runs; None when a run states none."""
    steps = [twist_step(r) for r in runs]
    return max(steps) if steps and min(steps) > 0 else None


def _runs(tr: dict, n: int) -> np.ndarray:
    """Each sample's run of the training signals `tr` (all one run when they do not say)."""
    return np.asarray(tr["run"]) if "run" in tr else np.zeros(n, dtype=np.int64)


def _run_zeros(run: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each sample's run index (0 … runs − 1) and a column per run, 1 on its samples: each
    run's own zero in a law (an encoder zeroed within its step)."""
    _, idx = np.unique(run, return_inverse=True)
    return idx, (idx[:, None] == np.arange(idx.max() + 1)[None, :]).astype(float)


def _less_run_means(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """x with each run's mean taken off (`idx`: each sample's run index, _run_zeros)."""
    return x - (np.bincount(idx, weights=x) / np.bincount(idx))[idx]


def _fit_last_se(X: np.ndarray, y: np.ndarray, tr: dict, opt: DiagnosisOptions
                 ) -> tuple[OLSResult, float]:
    """The least-squares fit of y on X and the standard error of its last coefficient, robust
    to the residual's correlation within the batch-means blocks of the runs of `tr`
    (block_robust_cov)."""
    fit = ols(X, y)
    run = _runs(tr, y.size)
    blocks = block_ids(run, block_size(run, opt.block))
    return fit, float(np.sqrt(max(block_robust_cov(X, y - X @ fit.theta, blocks)[-1, -1], 0.0)))


def centre_knee(tr: dict, knees: tuple[float, float], opt: DiagnosisOptions,
                resolution: float | None, corner: float | None = None
                ) -> tuple[str, float] | None:
    """A centre of the compliance curve that differs from the rest: ("soft", θ₀), ("stiff", θ₀)
    or None; θ₀ [rad] is its half-width. θ₀ is the half-width, over the dead zones the backlash
    candidate searches (`opt.backlash_b_rel` of the training twist's top |Δ|, SOFT_CENTRE_GRID
    values), of the stiffness change that fits the elastic law best with the curve's two knees.
    Either is kept only when the stiffness change is nonzero by `opt.z_gain` of its standard
    error robust to the residual's correlation within the batch-means blocks
    (block_robust_cov): the curve's other terms leave a residual that is far from white when
    they miss it, and a linear law's noise must not buy the nominal a free column.
    - A softer centre (the stiffness beyond θ₀ is higher): a gear train whose teeth take up the
      load progressively; a harmonic drive's catalogue K1 is 0.5–0.7 of K2. It is kept only when
      the stiffness it leaves inside, k_in (k, plus the smooth change about `corner` when the
      law has one: smooth_corner), is above `opt.soft_centre_min_ratio` of the
      stiffness beyond it by `opt.z_gain` standard errors of the fit. A dead zone takes the
      stiffness away inside its gap (k_in ≈ 0): that is backlash, left to its candidate. The
      data tell the two apart only when the centre spans `opt.soft_centre_min_steps` of the
      twist's `resolution` [rad]: a narrower dead zone seen through the encoders' rounding is a
      centre of reduced stiffness too. None when the runs do not state their encoders' steps.
    - A stiffer centre (the stiffness beyond θ₀ is lower): a preloaded stage, whose preload
      holds the teeth on both flanks until the torque exceeds it; no dead zone makes one. The
      preload it makes, |dk₀|·θ₀, must exceed the torque of half the twist's `resolution`
      through the stiffness beyond it: the rounding of the twist reading makes a narrower,
      smaller one (a centre a tenth of a step wide on a law with no preload). And it must fit
      better than every passive loop of the hysteresis candidate's grid (bouc_wen_grid, k_h > 0):
      a loop jumps at each reversal of the twist's rate, and where the runs reverse near zero
      twist that jump is a stiffer centre too; taken into the nominal, it hides the loop."""
    top, base, q = _elastic_basis(tr, knees, corner)
    y = np.asarray(tr["torque"], dtype=float)
    y_left = y - q @ (q.T @ y)

    def added(col: np.ndarray) -> tuple[float, float]:
        """RSS and coefficient of the law with the column `col` added (profile least squares:
        the column with the law's columns projected out); (inf, 0) for a column they span."""
        h = col - q @ (q.T @ col)
        hh = float(h @ h)
        if hh <= 0:
            return np.inf, 0.0
        hy = float(h @ y_left)
        return float(y_left @ y_left) - hy ** 2 / hh, hy / hh

    best, best_rss = None, np.inf
    for theta in np.geomspace(min(opt.backlash_b_rel) * top, max(opt.backlash_b_rel) * top,
                              SOFT_CENTRE_GRID):
        rss = added(knee_column(theta)(tr))[0]
        if rss < best_rss:
            best, best_rss = theta, rss
    if best is None:
        return None
    X = np.column_stack([base, knee_column(best)(tr)])
    fit, se_dk = _fit_last_se(X, y, tr, opt)
    if not (np.isfinite(se_dk) and abs(fit.theta[-1]) > opt.z_gain * se_dk):
        return None
    # the law's stiffness at the centre: k, plus the smooth change about the corner (whose
    # column's slope is 1 at zero twist), the column before the centre's
    at_centre = np.zeros(fit.theta.size)
    at_centre[0] = 1.0
    if corner is not None:
        at_centre[-2] = 1.0
    k_in = float(at_centre @ fit.theta)
    if fit.theta[-1] < 0:
        # the preload it makes beyond its half-width against the torque of half a twist-step
        # through the stiffness beyond: a smaller one is the reading's rounding
        preload = -fit.theta[-1] * best
        rounding = (k_in + fit.theta[-1]) * resolution / 2.0 if resolution else 0.0
        if preload <= rounding:
            return None
        # a passive loop (hysteresis, k_h > 0) jumps at each reversal of the twist's rate; where
        # the runs reverse near zero twist that is a stiffer centre too: the centre must fit
        # better than the best loop of the hysteresis candidate's grid
        for sh in bouc_wen_grid(tr, opt):
            rss, k_h = added(bouc_wen_x(tr, sh["alpha"], sh["beta"], sh["gamma"], int(sh["n"])))
            if k_h > 0 and rss < best_rss:
                return None
        return ("stiff", float(best))
    if resolution is None or resolution <= 0:
        return None
    r = opt.soft_centre_min_ratio
    c = (1.0 - r) * at_centre
    c[-1] = -r                         # k_in − r·(k_in + dk)
    margin = float(c @ fit.theta)
    se = float(np.sqrt(max(c @ fit.cov @ c, 0.0)))
    if (fit.theta[-1] > 0 and np.isfinite(se) and margin > opt.z_gain * se
            and best >= opt.soft_centre_min_steps * resolution):
        return ("soft", float(best))
    return None


def _confirmed_column(tr: dict, law: np.ndarray, col: np.ndarray,
                      opt: DiagnosisOptions) -> bool:
    """Whether the column `col` belongs in the elastic law whose columns are `law` (the third,
    index 2, its constant) on the training signals `tr` (with run). Two tests:
    - its coefficient is nonzero by `opt.z_gain` of its standard error robust to the residual's
      correlation within the batch-means blocks (block_robust_cov), as centre_knee's is;
    - it predicts runs it was not fitted on: each training run left out in turn, the law with
      and without the column fitted on the others and replayed on it, with every run's own
      zero (a constant per run) and the left-out run's mean error taken off. The pooled squared
      error must fall, and more of the left-out runs' batch-means blocks must improve than
      chance allows (sign test, z > `opt.z_gain`).
    Why each run's own zero: runs each carry their own constant error (an encoder zeroed within
    its step, twist_zeros), and a column nearly constant within a run, or of one sign there,
    is one more constant per run: the block test alone calls such chance correlations
    significant (a few hundred N·m on a law that lacks nothing). With the zeros taken out, only
    what changes with the twist within the runs is left to the column."""
    y = np.asarray(tr["torque"], dtype=float)
    fit, se = _fit_last_se(np.column_stack([law, col]), y, tr, opt)
    if not (np.isfinite(se) and abs(fit.theta[-1]) > opt.z_gain * se):
        return False
    run = _runs(tr, y.size)
    idx, zeros = _run_zeros(run)
    if zeros.shape[1] < 3:
        return False
    # each run's own zero; left out, a run's zero column is zero on the others, so its
    # minimum-norm coefficient is 0 and its mean error is taken off instead
    without = np.column_stack([np.delete(law, 2, axis=1), zeros])
    errs = [_less_run_means(leave_one_group_out(A, y, run), idx)
            for A in (without, np.column_stack([without, col]))]
    gain = errs[0] ** 2 - errs[1] ** 2
    blocks = block_ids(run, block_size(run, opt.block))
    return bool(gain.sum() > 0 and blocks_improved_z(gain, blocks) > opt.z_gain)


def lost_motion_objection(f: _Fit, tr: dict, opt: DiagnosisOptions) -> str | None:
    """Why a dead zone fitted on a twist–torque law (backlash: the column
    backlash_twist(Δ, b) − Δ, coefficient k_bl) is not one, or None.
    A dead zone is lost motion: where the torque reverses, the twist crosses the gap, so the
    twist read as a function of the torque, Δ(T), steps by ±b₀ at T = 0. The law T(Δ) is read
    through a twist the encoders round to a step, and there a gap of a step or two and a
    stiffness that merely rises from a softer centre (a smooth compliance curve, a break a few
    steps out) draw the same points: the dead zone's column takes both, with k_bl below the
    stiffness beyond it. Its fit says how much lost motion it needs, b₀ = k_bl·b/k_loc [rad]
    (k_loc: the slope of the fitted law without the dead zone's column over b < |Δ| < 3b).
    The inverse law looks for it where the rounding is noise in the regressand, not a smear of
    the regressor: the twist regressed on the torque and sgn T, whose coefficient j is the
    lost motion the runs show where the torque changes sign within a run; T, T·|T| and T³ are
    the curve's shape (T·|T| the softer centre of a hardening curve), Δ̇ the damping, and each
    run has its own zero (its encoders'). Samples whose torque lies within the fitted law's
    residual RMS of zero are left out: whether the gear rests on one flank or crosses the gap
    there, their torque does not say. Of the others, only the lower half of the torques (up to
    their median |T|) is used: over half its range a smooth compliance curve (one that hardens
    threefold, a soft centre blended into a stiffer line) is close to that cubic, while over the
    whole range the cubic's misfit leaks into sgn T; a gap's step sits at T = 0 whatever the
    range (docs/diagnosis.md). Objected to when j lies below the midpoint between no
    lost motion and b₀ by `opt.z_gain` of its standard error robust to the residual's
    correlation within the batch-means blocks (block_robust_cov): the twist then says "no gap"
    more than "this gap". None when the runs cannot tell (no run reverses the torque, too few
    samples beyond b, or the fit needs no lost motion)."""
    m = f.model
    if (not m.effects or m.effects[-1] != "backlash" or m.kind != "transmission"
            or "b" not in f.shape):
        return None
    names = list(m.param_names)
    i = names.index("k_bl")
    d = np.asarray(tr["torsion"], dtype=float)
    torque = np.asarray(tr["torque"], dtype=float)
    b = float(f.shape["b"])
    rest = [c for c in range(len(names)) if c != i]
    law = m.design(tr)[:, rest] @ f.theta[rest]
    beyond = (np.abs(d) > b) & (np.abs(d) < 3.0 * b)
    if beyond.sum() <= 2 or np.ptp(d[beyond]) <= 0:
        return None
    k_loc = float(np.polyfit(d[beyond], law[beyond], 1)[0])
    gap = float(f.theta[i]) * b / k_loc if k_loc > 0 else 0.0
    if not gap > 0:
        return None
    keep = np.abs(torque) > f.rmse_train_dof
    if not keep.any():
        return None
    # the curve's shape is fitted over the lower half of the torques
    keep &= np.abs(torque) <= float(np.median(np.abs(torque[keep])))
    sub = {k: np.asarray(v)[keep] for k, v in tr.items()
           if isinstance(v, np.ndarray) and v.shape[:1] == d.shape}
    d, torque = d[keep], torque[keep]
    idx, zeros = _run_zeros(_runs(sub, d.size))
    step = np.sign(torque)
    # sgn T within the runs: a run whose torque keeps one sign shows no reversal
    within = _less_run_means(step, idx)
    if not within @ within > 0:
        return None
    tn = torque / (float(np.max(np.abs(torque))) or 1.0)
    X = np.column_stack([tn, tn * np.abs(tn), tn ** 3, sub["torsion_rate"], zeros, step])
    if d.size <= 2 * X.shape[1]:
        return None
    fit, se = _fit_last_se(X, d, sub, opt)
    j = float(fit.theta[-1])
    if fit.rank < X.shape[1] or not (np.isfinite(se) and se > 0):
        return None
    if gap / 2.0 - j > opt.z_gain * se:
        return (f"a dead zone needs {gap:.2g} rad of lost motion; the twist steps by "
                f"{j:.2g} ± {se:.2g} rad where the torque reverses")
    return None


def _law(tr: dict, knees: tuple[float, float], centre: float | None,
         corner: float | None = None) -> np.ndarray:
    """The columns of the elastic law with the curve's `knees`, `centre` and `corner`
    (_elastic_basis, corner_column)."""
    _, base, _ = _elastic_basis(tr, knees, corner)
    return np.column_stack([base] + ([knee_column(centre)(tr)] if centre is not None else []))


def smooth_corner(tr: dict, knees: tuple[float, float], centre: float | None,
                  opt: DiagnosisOptions) -> float | None:
    """The corner δ [rad] of a stiffness change spread smoothly over the twist
    (estimator.models.corner_column) that the elastic law with the curve's `knees` and
    `centre` lacks, or None. δ is the one of `opt.compliance_corner_rel` (fractions of the
    training twist's top |Δ|) whose column fits best (profile least squares), kept only when
    _confirmed_column confirms it (its coefficient nonzero by `opt.z_gain` robust standard
    errors, and the runs left out predicted better).
    Why: knees bend the curve at a twist each, so a curve that bends over the whole range — a
    rational or saturating tangent stiffness, a soft segment blended into the stiff one — is
    left with a residual that swings with the twist by more than a fine encoder resolves, and
    a campaign that lacks nothing reads `unexplained`. Every corner lies beyond the widest
    dead zone searched, so a softening inside it stays backlash's (or the soft centre's)."""
    if min(opt.compliance_corner_rel) <= max(opt.backlash_b_rel):
        raise ValueError("compliance_corner_rel must lie above backlash_b_rel (a corner inside "
                         "the dead zones searched would take backlash's place)")
    top = _elastic_basis(tr)[0]
    law = _law(tr, knees, centre)
    qb = _orthonormal(law)
    y = np.asarray(tr["torque"], dtype=float)
    y = y - qb @ (qb.T @ y)
    best, best_gain = None, 0.0
    for rel in opt.compliance_corner_rel:
        h = corner_column(rel * top)(tr)
        h = h - qb @ (qb.T @ h)
        hh = float(h @ h)
        if hh > 0 and float(h @ y) ** 2 / hh > best_gain:
            best, best_gain = rel * top, float(h @ y) ** 2 / hh
    if best is None or not _confirmed_column(tr, law, corner_column(best)(tr), opt):
        return None
    return float(best)


def thermal_stiffness(tr: dict, knees: tuple[float, float], centre: float | None,
                      opt: DiagnosisOptions, corner: float | None = None) -> bool:
    """Whether the elastic law with the curve's `knees`, `centre` (as centre_knee found it)
    and `corner` (smooth_corner) needs a stiffness that follows the joint's temperature (the
    column k_T·Δ·(temp_joint − T_ref) of estimator.models.with_stiffening), on the training
    signals `tr` (with temp_joint and run): a gearbox softens as it warms, and a campaign's runs
    span tens of kelvin. Needed when the temperature spans `opt.thermal_min_span_c` and the column
    passes _confirmed_column's two tests (`opt.stiffness_thermal` True: whenever it spans, False:
    never). The temperature is nearly constant within a run, so over runs that each carry
    their own zero this column is mostly one more constant per run: only with the zeros taken
    out is a stiffness that differs from run to run with the temperature left to it."""
    if opt.stiffness_thermal is False or "temp_joint" not in tr:
        return False
    temp = np.asarray(tr["temp_joint"], dtype=float)
    if not np.ptp(temp) >= opt.thermal_min_span_c:
        return False
    if opt.stiffness_thermal:
        return True
    return _confirmed_column(tr, _law(tr, knees, centre, corner), thermal_stiffness_column(tr),
                             opt)


def transmission_model(spec: str | LinearModel, tr: dict, opt: DiagnosisOptions,
                       resolution: float | None = None) -> tuple[LinearModel, dict]:
    """The nominal twist–torque law and the shape chosen for it on the training signals `tr`:
    'auto' or 'bouc_wen' — issue 7's nominal, the Bouc–Wen law as Eq. 11 with its state x for
    the shape (α = 1, n = 1, β, γ) of bouc_wen_grid with the smallest training RSS (profile least
    squares); 'eq5' — the elastic law (then hysteresis is a candidate); or any transmission
    model / spec of estimator.models; each with a stiffness that changes with the twist
    (estimator.models.with_stiffening: a real compliance curve is part of the nominal elastic
    law, identified like k, not a gap; its knees from compliance_knees, reported in the
    shape as knee_1, knee_2 [rad], the half-width of a softer or stiffer centre from
    centre_knee as soft_centre or stiff_centre [rad] when the curve has one, and
    stiffness_thermal 1.0 when the stiffness follows the joint's temperature (thermal_stiffness;
    `tr` then carries temp_joint))."""
    knees = compliance_knees(tr, opt)
    found = centre_knee(tr, knees, opt, resolution)
    centre = found[1] if found else None
    corner = smooth_corner(tr, knees, centre, opt)
    if corner is not None:
        # the knees and the centre chosen again beside the smooth change, kept when the law
        # then fits the training runs better (each is chosen without the other, so a curve
        # with a strong soft centre can lose by it)
        knees2 = compliance_knees(tr, opt, corner)
        found2 = centre_knee(tr, knees2, opt, resolution, corner)
        centre2 = found2[1] if found2 else None
        y = np.asarray(tr["torque"], dtype=float)
        if (ols(_law(tr, knees2, centre2, corner), y).rss
                < ols(_law(tr, knees, centre, corner), y).rss):
            knees, found, centre = knees2, found2, centre2
    knee_shape = {"knee_1": knees[0], "knee_2": knees[1]}
    if corner is not None:
        knee_shape["corner"] = corner
    if found:
        knee_shape[f"{found[0]}_centre"] = found[1]
    thermal = thermal_stiffness(tr, knees, centre, opt, corner)
    if thermal:
        knee_shape["stiffness_thermal"] = 1.0
    if isinstance(spec, str) and spec in ("auto", "bouc_wen"):
        from scipy.optimize import minimize

        def shape(v):   # v = (log(β+γ), logit(β/(β+γ)))
            ssum, share = float(np.exp(v[0])), float(1.0 / (1.0 + np.exp(-v[1])))
            return {"alpha": 1.0, "beta": share * ssum, "gamma": (1.0 - share) * ssum, "n": 1}

        def rss(v):
            sh = shape(v)
            m = eq11(sh["alpha"], sh["beta"], sh["gamma"], sh["n"])
            return ols(m.design(tr), m.target(tr)).rss

        starts = [np.array([np.log(sh["beta"] + sh["gamma"]),
                            np.log(sh["beta"] / sh["gamma"])]) for sh in bouc_wen_grid(tr, opt)]
        v0 = min(starts, key=rss)
        # refine the grid's best (profile least squares over the two shape coordinates)
        res = minimize(rss, v0, method="Nelder-Mead",
                       options={"maxfev": 80, "xatol": 0.01, "fatol": 1e-6 * rss(v0)})
        sh = shape(res.x if res.fun <= rss(v0) else v0)
        return (with_stiffening(eq11(sh["alpha"], sh["beta"], sh["gamma"], sh["n"]), knees,
                                centre, thermal, corner), {**sh, **knee_shape})
    m = base_model(spec)
    if m.kind != "transmission":
        raise ValueError(f"{m.name!r} is not a transmission (twist–torque) model")
    return with_stiffening(m, knees, centre, thermal, corner), knee_shape


def twist_zeros(train_runs: Sequence[RunData], test_runs: Sequence[RunData],
                model: LinearModel, prep: PrepOptions, resolution: float | None
                ) -> tuple[list[RunData], list[RunData], dict | None]:
    """The runs with each run's zero of the twist set from its own data, within what the
    encoders resolve, and what was done (None when nothing was). An encoder zeroed at the start
    of a run (a homing, a preset) knows the twist u − q there only to within the encoders'
    steps (`resolution` [rad], twist_resolution): each run then carries its own constant twist
    error, up to a step, which the law's stiffness turns into a constant torque per run — k·r is
    2.4 kN·m for a 0.01° encoder on a 1.4e7 N·m/rad transmission. One intercept for every run
    cannot take that, and the residual would look structured though the law lacks nothing.
    The nominal law fitted on the training runs is replayed on each run; the run's mean residual,
    clipped to ± k·resolution (k: the least-squares slope of the torque on the twist), is taken
    off its torque. Bounded by the step, it cannot take away more than a zero error can be;
    a dead zone under a load that keeps one sign is a constant too, and within a step the two
    are the same thing to these runs. A lagging angle reading is not: it reads the twist off by
    d·q̇, a constant in each constant-speed run that follows the speed from run to run, so the
    law replayed carries the angle lag's column (time_delay, shape angle) when the runs carry
    q̇ and the candidate would take the lag (estimator.diagnosis_candidates.
    angle_lag_objection) — otherwise the zeros take up to a step of it in every run and leave
    the lag's column a remainder that no longer follows the speed. A recorded twist
    (`torsion`) that is q − u of the encoders (estimator.diagnosis_data.derived_torsion) is
    their twist; one measured by its own sensor is zeroed the same way within the step its
    channel states, and not at all when it states none."""
    runs = list(train_runs) + list(test_runs)
    # a recorded twist whose own step is not stated: its zero is not known to be an encoder's
    unstated = any("torsion" in r.samples.columns and not derived_torsion(r)
                   and stated_resolution(r, "torsion") <= 0 for r in runs)
    if not resolution or resolution <= 0 or unstated:
        return list(train_runs), list(test_runs), None
    n = len(train_runs)
    lagged = (model.with_effect("time_delay", angle=1.0) if "time_delay" not in model.effects
              else None)
    pooled = None
    for m in ((lagged, model) if lagged is not None else (model,)):
        need = list(dict.fromkeys(("t",) + TRANSMISSION_SIGNALS + tuple(m.requires)))
        try:
            pooled = _pool(runs, need, prep, 0)
            break
        except (KeyError, ValueError):   # the law's own pooling says why, with the run's name
            continue
    if pooled is None:
        return list(train_runs), list(test_runs), None
    tr = {k: v[pooled["run"] < n] for k, v in pooled.items()}
    k = ls_stiffness(tr)
    if not k > 0:
        return list(train_runs), list(test_runs), None
    replay, theta = model, None
    if lagged is not None and "qd" in tr:
        theta = ols(lagged.design(tr), lagged.target(tr)).theta
        # a lag the candidate would be refused (under the rounding, or only the direction's):
        # the zeros take what a zero can
        if angle_lag_objection(lagged, theta, tr) is None:
            replay = lagged
    if replay is model:
        theta = ols(model.design(tr), model.target(tr)).theta
    bound = k * resolution
    e = replay.target(pooled) - replay.design(pooled) @ theta
    ok = np.isfinite(e)
    count = np.bincount(pooled["run"][ok], minlength=len(runs))
    total = np.bincount(pooled["run"][ok], weights=e[ok], minlength=len(runs))
    shifts = [float(np.clip(s / c, -bound, bound)) if c else 0.0 for s, c in zip(total, count)]
    out = []
    for r, m in zip(runs, shifts):
        df = r.samples.copy()
        df["torque"] = df["torque"].to_numpy(dtype=float) - m
        out.append(RunData(samples=df, meta=r.meta))
    return out[:n], out[n:], {"bound_nm": bound, "stiffness": k, "resolution": resolution,
                              "shift_nm": shifts}
