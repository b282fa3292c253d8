"""Candidates of the gap diagnosis: each effect of the vocabulary as extra column(s) of the
nominal model, its shape searched on the training runs, fitted by least squares, and scored on
the held-out runs (gain per sample with its batch-means standard error, shrinkage, the shrinkage
predicted from the training runs, parameters moved, ambiguity with nominal parameters)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from core import effects as fx
from estimator.diagnosis_options import DiagnosisOptions
from estimator.diagnosis_stats import (angle_lines, angle_periodogram, blocks_improved_z,
                                       covering_runs, mean_se)
from estimator.least_squares import OLSResult, leave_one_group_out, ols
from estimator.models import V_EPS, LinearModel, Term, physical_objection


def _shape_grid(name: str, sig: dict, opt: DiagnosisOptions, e_train: np.ndarray,
                disp: str = "torsion", kind: str = "output", with_gain: bool = False
                ) -> list[dict]:
    """Shapes to search for effect `name`, scaled by the training signals; `disp` is the
    displacement a transmission effect acts on (the twist, or q on a law without one), `kind`
    the law's (estimator.models.LinearModel.kind); `with_gain`: the law carries the torque
    reading's gain against the load reading (estimator.models.with_torque_gain)."""
    if name == "stribeck":
        top = float(np.quantile(np.abs(sig["qd"]), 0.99)) or 1.0
        return [{"v_s": r * top, "delta": d} for d in opt.stribeck_delta
                for r in opt.stribeck_vs_rel]
    if name == "gear_ripple":
        # only orders whose ripple period the runs' travel covers opt.ripple_min_periods times:
        # below that a sine of the angle is a smooth function of it (a stiffness, a gravity-like
        # term) and not a ripple (a ripple is also kept only where it shows on the runs whose
        # angle path sweeps them, ripple_shown); then screen by the nominal residual's angular
        # lines, fit the strongest
        travel = float(np.ptp(sig["q"]))
        orders = np.asarray([k for k in opt.ripple_orders
                             if k * travel >= 2.0 * np.pi * opt.ripple_min_periods])
        groups, motor_group = [], []
        if orders.size:
            top = angle_lines(e_train, sig["q"], orders).get("top_orders")
            groups.append([{"order": float(k)} for k in (top or orders)])
        # a ripple of the motor side (its bearings, the first gear stage): periodic in the
        # motor angle N·u, opt.motor_ripple_orders cycles per motor revolution, when the runs
        # carry u and say their reduction N (the order on u is then k·N)
        n_red = float(sig["reduction"][0]) if "reduction" in sig and sig["reduction"].size else 0.0
        if ("u" in sig and n_red > 0
                and np.ptp(sig["u"]) * n_red >= 2.0 * np.pi * opt.ripple_min_periods):
            m_orders = np.asarray(opt.motor_ripple_orders, dtype=float) * n_red
            top = angle_lines(e_train, sig["u"], m_orders).get("top_orders") or []
            motor_group = [{"order": float(k), "motor": 1.0} for k in top[:2]]
            groups.append(motor_group)
        # an intermediate stage's transmission error: periodic in u at an order between the
        # output's and the motor's (its shaft turns a whole number of times per turn of u only
        # by chance, so not a motor order either)
        if "u" in sig:
            groups.append([{"order": k, "motor": 1.0} for k in _stage_orders(sig, e_train, opt)])
        groups = [g for g in groups if g]
        if not groups:
            raise ValueError("the runs' travel covers no ripple period of the orders searched")
        # a mesh's ripple is rarely one sine: each group's strongest order is also tried with
        # its harmonics (chosen over the single sine by leave-one-run-out, _best_shape)
        shapes = [sh for g in groups for sh in g]
        if opt.ripple_harmonics > 1:
            shapes += [{**g[0], "harmonics": float(opt.ripple_harmonics)} for g in groups]
        # and a mesh whose ripple grows with the torque it carries (the same sine plus that
        # sine times |T|), when the law has the torque reading
        if "torque" in sig:
            shapes += [{**g[0], "load": 1.0} for g in groups]
        # a ripple of the motor side turns fast (100 Hz at 3000 r/min and 2 cycles per motor
        # revolution): it reaches the reading through the joint's dynamics and the law's
        # low-pass, its amplitude and phase following its frequency (the runs' speeds)
        w_ref = float(np.median(np.abs(sig["qd"]))) if "qd" in sig else 0.0
        if w_ref > 0 and motor_group:
            shapes.append({**motor_group[0], "dynamic": w_ref})
            if opt.ripple_harmonics > 1:
                shapes.append({**motor_group[0], "harmonics": float(opt.ripple_harmonics),
                               "dynamic": w_ref})
        return shapes
    if name == "backlash":
        # the dead-zone half-width b shapes the column, k_bl is fitted (estimator.models)
        top = float(np.quantile(np.abs(sig[disp]), 0.99)) or 1e-3
        return [{"b": r * top} for r in opt.backlash_b_rel]
    if name == "hysteresis":
        return bouc_wen_grid(sig, opt, disp)
    if name == "torque_offset":
        # a constant and a linear drift, or a reading that also settles after start-up, or one
        # whose zero follows the joint's temperature (when the runs' temperatures differ)
        thermal = ([{"thermal": 1.0}] if "temp_joint" in sig
                   and np.ptp(sig["temp_joint"]) >= opt.thermal_min_span_c else [])
        return [{}] + [{"settling": float(tau)} for tau in opt.offset_settling_s] + thermal
    if name == "temperature_friction":
        # the linear law, and curved (exponential) ones: a lubricant's viscosity is not linear
        # in the temperature over a 15–60 °C campaign
        return [{}] + [{"curvature": float(k)} for k in opt.temperature_curvatures]
    if name == "time_delay" and kind == "transmission":
        # an angle reading's lag: an encoder whose position arrives later than the other's
        # reads the twist off in proportion to the speed (the torque reading's lag is found on
        # the output law and carried here)
        return [{"angle": 1.0}]
    if name == "load_dependent_friction" and kind == "output":
        # a gear's: one law for both power-flow directions, or one coefficient per direction
        # (driving or back-driven; on a system without a gear the split column is only an
        # energy loss per cycle, which hysteresis also is); a coefficient per power-flow sign
        # is μ ± g_T where the load also drives the joint, so beside the torque reading's gain
        # (estimator.models.with_torque_gain) only the plain law is tried, and without it a
        # per-power-flow μ clearly below zero is that gain (PHYSICAL_SIGN_BEYOND_NOISE)
        return [{}] if with_gain else [{}, {"power_flow": 1.0}]
    return [{}]


def _stage_orders(sig: dict, e_train: np.ndarray, opt: DiagnosisOptions) -> list[float]:
    """The two strongest orders of the training residual on u [cycles per output revolution]
    above opt.ripple_orders, up to opt.stage_ripple_max_order (None: the runs' reduction N,
    the motor's first order) and 0.8 × the Nyquist order of the sampling at the runs' median
    speed |q̇| (faster samples alias those orders: they add
    noise to the screen and the fit, not a line). Long campaigns are screened
    on every s-th sample (about 2·10⁵ kept, s no larger than that Nyquist order allows), by
    the periodogram (diagnosis_stats.angle_periodogram)."""
    lo = max(opt.ripple_orders) + 1 if opt.ripple_orders else 2
    t, run = sig["t"], sig.get("run")
    dt = np.diff(t)
    if run is not None:
        dt = dt[np.diff(run) == 0]
    dt = dt[dt > 0]
    ud = sig["qd"] if "qd" in sig else np.gradient(sig["u"], t)    # u̇ ≈ q̇ at this scale
    w = float(np.median(np.abs(ud))) if ud.size else 0.0
    if not dt.size or w <= 0:
        return []
    fs = 1.0 / float(np.median(dt))
    k_nyq = np.pi * fs / w            # k·w/2π = fs/2
    hi = int(min(stage_max_order(sig, opt), 0.8 * k_nyq))
    if hi < lo:
        return []
    stride = min(max(1, int(0.8 * k_nyq / hi)), max(1, int(np.ceil(e_train.size / 200_000))))
    e = e_train[::stride] - np.mean(e_train[::stride])
    return [float(k) for k in angle_periodogram(e, sig["u"][::stride], lo, hi)]


def stage_max_order(sig: dict, opt: DiagnosisOptions) -> float:
    """The highest intermediate-stage order [cycles per output revolution] searched on u:
    opt.stage_ripple_max_order, or when it is None the runs' stated reduction N (2000 when they
    state none)."""
    if opt.stage_ripple_max_order is not None:
        return float(opt.stage_ripple_max_order)
    red = sig.get("reduction")
    n_red = float(np.max(red)) if red is not None and red.size else 0.0
    return n_red if n_red > 0 else 2000.0


def bouc_wen_grid(sig: dict, opt: DiagnosisOptions, disp: str = "torsion") -> list[dict]:
    """Bouc–Wen shapes (α = 1, n = 1, β, γ) to search, scaled by the training twist: yield
    twist 1/(β+γ) = a fraction of the 99th percentile of |Δ| (opt.bw_yield_rel), β/(β+γ) from
    opt.bw_beta_share. From the data, never from the emulator's parameter values."""
    ref = float(np.median(sig[disp])) if disp == "q" else 0.0   # a position has no natural zero
    top = float(np.quantile(np.abs(sig[disp] - ref), 0.99)) or 1e-3
    out = []
    for r in opt.bw_yield_rel:
        ssum = 1.0 / (r * top)
        for share in opt.bw_beta_share:
            out.append({"alpha": 1.0, "beta": share * ssum, "gamma": (1.0 - share) * ssum,
                        "n": 1})
    if disp == "q":   # any hysteretic system: hardening loading branches (β + γ < 0) too
        for r in opt.bw_yield_rel + (1.0, 3.0):
            for ratio in opt.bw_gamma_ratio_generic:
                out.append({"alpha": 1.0, "beta": 1.0 / (r * top),
                            "gamma": ratio / (r * top), "n": 1})
    return out


def _candidate_models(model: LinearModel, sig: dict, opt: DiagnosisOptions, e_train: np.ndarray
                      ) -> tuple[dict[str, list[tuple[dict, LinearModel]]], dict[str, str]]:
    """Each effect's models over its shape grid."""
    names = opt.candidates or fx.EFFECT_NAMES
    out, skipped = {}, {}
    for name in names:
        if name in model.effects:
            continue
        acts = fx.VOCABULARY[name].acts_on if name in fx.VOCABULARY else "?"
        also = fx.VOCABULARY[name].also_on if name in fx.VOCABULARY else ()
        if model.kind == "transmission" and acts == "output" and "transmission" not in also:
            skipped[name] = "acts on the output-side balance, not on the transmission law"
            continue
        disp = "torsion" if model.kind == "transmission" else "q"
        if acts == "transmission" and model.kind != "transmission" and "torsion" in sig:
            skipped[name] = "diagnosed on the twist–torque law (the runs carry the twist)"
            continue
        try:
            grid = _shape_grid(name, sig, opt, e_train, disp, model.kind,
                               "g_T" in model.param_names)
            models = [(shape, model.with_effect(name, **shape)) for shape in grid]
            models[0][1].design({k: v[:8] for k, v in sig.items()})
        except KeyError as exc:
            skipped[name] = f"the runs lack signal {exc}"
            continue
        except ValueError as exc:
            skipped[name] = str(exc)
            continue
        out[name] = models
    return out, skipped


@dataclass
class _Fit:
    model: LinearModel
    shape: dict
    theta: np.ndarray
    se: np.ndarray
    cov: np.ndarray
    e_train: np.ndarray
    e_test: np.ndarray
    rmse_train_dof: float
    ols: OLSResult | None = None
    objection: str | None = None
    """Why the fitted effect is not physical (estimator.models.physical_objection): such a
    fit is never significant."""


def _fit(model: LinearModel, shape: dict, tr: dict, te: dict) -> _Fit:
    X, y = model.design(tr), model.target(tr)
    res = ols(X, y)
    e_tr = y - X @ res.theta
    e_te = model.target(te) - model.design(te) @ res.theta
    return _Fit(model, shape, res.theta, res.se, res.cov, e_tr, e_te,
                float(np.sqrt(res.rss / max(res.dof, 1))), res)


def _best_shape(models: list[tuple[dict, LinearModel]], tr: dict, te: dict) -> _Fit:
    """The grid's shape of least training RSS (of least leave-one-run-out RSS when the shapes
    differ in their number of columns); a Bouc–Wen shape on a law whose displacement is
    the position (no twist channel: any hysteretic system, whose shape is not the J4
    transmission's) is then refined by profile least squares over (β, γ/β)."""
    def loro(m: LinearModel) -> float:
        # each training run predicted by the fit on the others (leave-one-run-out): a shape
        # with more columns (torque_offset's settling term) must earn them across runs
        e = leave_one_group_out(m.design(tr), m.target(tr), tr["run"])
        return float(e @ e)
    fitted: dict[int, OLSResult] = {}

    def fit_of(i: int) -> OLSResult:
        if i not in fitted:
            _, mm = models[i]
            fitted[i] = ols(mm.design(tr), mm.target(tr))
        return fitted[i]
    cols = {len(m.param_names) for _, m in models}
    if len(cols) > 1 and np.unique(tr["run"]).size > 1:
        ranked = sorted((loro(m), i) for i, (_, m) in enumerate(models))
    else:
        ranked = sorted((fit_of(i).rss, i) for i in range(len(models)))
    # the best shape whose fitted effect has its physics' sign (a dead zone that stiffens the
    # centre is no backlash); none: the best one, with its objection
    pick = next((i for _, i in ranked
                 if physical_objection(models[i][1], fit_of(i).theta, fit_of(i).se) is None),
                ranked[0][1])
    shape, m = models[pick]
    objection = physical_objection(m, fit_of(pick).theta, fit_of(pick).se)
    if "beta" in shape and m.kind != "transmission":
        # the profile RSS over Bouc–Wen shapes has several basins: refine the three best
        # grid points and keep the best result (unless only the grid's has its physics' sign)
        tries = [_refined_bouc_wen(*models[i], tr) for _, i in ranked[:3]]
        refined = [(ols(mm.design(tr), mm.target(tr)), sh, mm) for sh, mm in tries]
        r, s2, m2 = min(refined, key=lambda f: (physical_objection(f[2], f[0].theta) is not None,
                                                 f[0].rss))
        if objection is not None or physical_objection(m2, r.theta) is None:
            shape, m = s2, m2
    f = _fit(m, shape, tr, te)
    return replace(f, objection=(physical_objection(f.model, f.theta, f.se)
                                 or angle_lag_objection(f.model, f.theta, tr)))


def ls_stiffness(sig: dict) -> float:
    """|least-squares slope| [N·m/rad] of the torque on the twist, both centred, on the
    signals `sig` (torsion, torque); 0 when the twist does not move."""
    tw = np.asarray(sig["torsion"], dtype=float)
    tq = np.asarray(sig["torque"], dtype=float)
    tw, tq = tw - tw.mean(), tq - tq.mean()
    return abs(float(tw @ tq / (tw @ tw))) if tw @ tw > 0 else 0.0


def angle_lag_objection(model: LinearModel, theta: np.ndarray, tr: dict) -> str | None:
    """Why an angle reading's lag fitted on a twist–torque law (time_delay, shape angle: the
    column −q̇, coefficient k_lag = k·d) is not one, or None. A lag d reads the twist off by
    d·q̇, in proportion to the speed. Two things draw a column like it and are not a lag:
    - an error smaller than the encoders resolve: a twist error whose RMS, |k_lag|·rms(q̇)/k
      (k the training runs' least-squares stiffness), is under the rounding error of the
      twist's stated step s, s/√12 (the runs' `twist_step`), cannot be told from the rounding,
      which is no white noise on a slow joint (it holds while the encoder sits on a step);
    - a twist offset that follows only the direction of motion (the side of a dead zone that
      the motion drags a gear to, a friction between the two encoders): in each constant-speed
      run it is the same column; the runs tell the two apart where the speed differs between
      or within them, so the lag is objected to when the direction's column, sgn q̇, predicts
      the training runs each from the others (leave-one-run-out) at least as well."""
    if (not model.effects or model.effects[-1] != "time_delay"
            or model.terms[-1].names != ("k_lag",)):
        return None
    qd = np.asarray(tr["qd"], dtype=float)
    k = ls_stiffness(tr)
    steps = tr.get("twist_step")
    step = float(np.max(steps)) if steps is not None and steps.size else 0.0
    if k > 0 and step > 0:
        error = abs(float(theta[-1])) * float(np.sqrt(np.mean(qd ** 2))) / k
        if error < step / np.sqrt(12.0):
            return (f"the twist error it reads, {error:.2g} rad RMS, is under the rounding of the "
                    f"twist's stated step ({step / np.sqrt(12.0):.2g} rad RMS)")
    if np.unique(tr["run"]).size < 2:
        return None
    side = Term("direction of motion", ("c_dir",), ("N·m",),
                lambda s: np.tanh(s["qd"] / V_EPS), ("qd",))
    alt = replace(model, terms=model.terms[:-1] + (side,))
    e_lag = leave_one_group_out(model.design(tr), model.target(tr), tr["run"])
    e_dir = leave_one_group_out(alt.design(tr), alt.target(tr), tr["run"])
    if float(e_dir @ e_dir) <= float(e_lag @ e_lag):
        return ("the twist's error follows the direction of motion, not the speed: a column "
                "sgn q̇ predicts the training runs as well as a lag's q̇")
    return None


def _refined_bouc_wen(shape: dict, m: LinearModel, tr: dict) -> tuple[dict, LinearModel]:
    """Refine a Bouc–Wen candidate's shape (α = 1, n = 1) by Nelder–Mead on the training RSS
    over (log β, γ/β), γ/β in [−2, 2]: the hysteretic families of the literature (softening
    β + γ > 0, hardening β + γ < 0 loading branches) lie there."""
    from scipy.optimize import minimize
    base = replace(m, name=m.name.rsplit("+", 1)[0], terms=m.terms[:-1], effects=m.effects[:-1])
    q = tr["q"]
    top = float(np.quantile(np.abs(q - np.median(q)), 0.99)) or 1e-3
    # β between 1/(10·top) and 1/(0.002·top): beyond, the state follows the displacement
    # (a spring, no loop) or switches at once (a dry friction)
    lo, hi = np.log(0.1 / top), np.log(500.0 / top)

    def make(v):
        beta = float(np.exp(np.clip(v[0], lo, hi)))
        sh = {"alpha": 1.0, "beta": beta, "gamma": beta * float(np.clip(v[1], -2.0, 2.0)),
              "n": 1}
        return sh, base.with_effect("hysteresis", **sh)

    def rss(v):
        _, mm = make(v)
        return ols(mm.design(tr), mm.target(tr)).rss

    v0 = np.array([np.log(shape["beta"]), shape["gamma"] / shape["beta"]])
    r0 = rss(v0)
    res = minimize(rss, v0, method="Nelder-Mead",
                   options={"maxfev": 80, "xatol": 0.01, "fatol": 1e-6 * r0})
    return make(res.x) if res.fun < r0 else (shape, m)


def _loro_errors(model: LinearModel, tr: dict) -> np.ndarray:
    """Leave-one-run-out errors on the training runs: each training run predicted by the model
    fitted on the other training runs (one run alone: its in-sample errors, dof-corrected)."""
    X, y = model.design(tr), model.target(tr)
    run = tr["run"]
    runs = np.unique(run)
    if runs.size < 2:
        res = ols(X, y)
        return (y - X @ res.theta) * np.sqrt(X.shape[0] / max(res.dof, 1))
    return leave_one_group_out(X, y, run)


def predicted_shrinkage(cur: LinearModel, new: LinearModel, tr: dict,
                        where: np.ndarray | None = None) -> float:
    """Shrinkage predicted from the training runs alone: 1 − rmse_new/rmse_cur of the
    leave-one-run-out errors (each run predicted as a held-out run would be), on the samples
    `where` (a mask; None: all)."""
    e0, e1 = _loro_errors(cur, tr), _loro_errors(new, tr)
    if where is not None:
        e0, e1 = e0[where], e1[where]
    r0, r1 = _rmse(e0), _rmse(e1)
    return 1.0 - r1 / r0 if r0 > 0 else 0.0


def _rmse(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(e ** 2))) if e.size else float("nan")


def _held_out_gain(e_cur: np.ndarray, e_new: np.ndarray, blocks: np.ndarray,
                   opt: DiagnosisOptions, objection: str | None = None) -> dict:
    """The held-out gain of a fit whose residual is e_new over one whose residual is e_cur
    (blocks: the batch-means block of each sample), and whether it is significant: a shrinkage
    of at least opt.min_shrinkage, no physical objection, and z > opt.z_gain, or — a gain that
    sits in a few blocks (a lag's, at the torque steps), whose z stays near √(those blocks) —
    a shrinkage of at least opt.concentrated_min_shrinkage with more blocks improved than
    chance gives by opt.z_gain (whether they improve does not depend on where it sits)."""
    d = e_cur ** 2 - e_new ** 2
    gain, se = mean_se(d, blocks)
    r0, r1 = _rmse(e_cur), _rmse(e_new)
    shrink = 1.0 - r1 / r0 if r0 > 0 else 0.0
    z = gain / se if np.isfinite(se) and se > 0 else 0.0
    z_sign = blocks_improved_z(d, blocks)
    ok = objection is None and shrink >= opt.min_shrinkage
    by_gain = ok and z > opt.z_gain
    by_blocks = ok and shrink >= opt.concentrated_min_shrinkage and z_sign > opt.z_gain
    return {"rmse_before": r0, "rmse_test": r1, "shrinkage": shrink, "gain": float(gain),
            "gain_se": float(se), "z": float(z), "z_blocks_improved": float(z_sign),
            "by_gain": bool(by_gain), "by_blocks": bool(by_blocks)}


def _score(cur: _Fit, new: _Fit, te_blocks: np.ndarray, opt: DiagnosisOptions,
           tr: dict | None = None) -> dict:
    g = _held_out_gain(cur.e_test, new.e_test, te_blocks, opt, new.objection)
    return {"rmse_test": g["rmse_test"], "shrinkage": g["shrinkage"],
            "shrinkage_predicted": _predicted(cur, new, g["rmse_before"], opt),
            "shrinkage_loro": (predicted_shrinkage(cur.model, new.model, tr) if tr is not None
                               else None),
            "gain": g["gain"], "gain_se": g["gain_se"], "z": g["z"],
            "z_blocks_improved": g["z_blocks_improved"],
            "significant": g["by_gain"] or g["by_blocks"],
            "concentrated": g["by_blocks"] and not g["by_gain"],
            **({"objection": new.objection} if new.objection else {})}


def ripple_shown(cur: _Fit, new: _Fit, te: dict, te_blocks: np.ndarray,
                 opt: DiagnosisOptions, tr: dict | None = None) -> dict:
    """A gear ripple's held-out evidence on the runs whose angle path sweeps
    opt.ripple_min_periods of its periods (covering_runs, on u for a motor-side or stage ripple,
    else q): the score's significance test (_held_out_gain) on those runs' samples alone. On a
    slow run that sweeps less, a sine of the angle is a smooth function of it and fits whatever
    drifts in time over that run; a ripple shows where it repeats. With the training runs `tr`,
    it must repeat in them too: the training runs covering it, each predicted by the fit on the
    other training runs (leave-one-run-out), must shrink by opt.min_shrinkage (the law's
    materiality). The search spans hundreds of orders on two angles, and an order whose sine
    follows a misfit the held-out runs share with the training runs' paths can pass the
    held-out test alone. Returns angle, order, runs (held-out runs covering it), shrinkage, z,
    z_blocks_improved (None without such a run), training_runs, shrinkage_training (None
    without `tr` or such a run) and shown."""
    shape = new.shape
    ang = "u" if shape.get("motor", 0.0) else "q"
    order = float(shape["order"])
    cv = covering_runs(te["run"], te["t"], te[ang], order, opt.ripple_min_periods)
    out = {"angle": ang, "order": order, "runs": int(np.unique(te["run"][cv]).size),
           "shrinkage": None, "z": None, "z_blocks_improved": None, "training_runs": None,
           "shrinkage_training": None, "shown": False}
    if not cv.any():
        return out
    g = _held_out_gain(cur.e_test[cv], new.e_test[cv], te_blocks[cv], opt)
    out.update(shrinkage=float(g["shrinkage"]), z=g["z"],
               z_blocks_improved=g["z_blocks_improved"], shown=g["by_gain"] or g["by_blocks"])
    if tr is not None:
        cvt = covering_runs(tr["run"], tr["t"], tr[ang], order, opt.ripple_min_periods)
        out["training_runs"] = int(np.unique(tr["run"][cvt]).size)
        if cvt.any():
            out["shrinkage_training"] = predicted_shrinkage(cur.model, new.model, tr, cvt)
        out["shown"] = bool(out["shown"] and out["shrinkage_training"] is not None
                            and out["shrinkage_training"] >= opt.min_shrinkage)
    return out


def _predicted(cur: _Fit, new: _Fit, rmse_before_test: float, opt: DiagnosisOptions) -> float:
    """Held-out shrinkage predicted from the training runs (opt.predictor):
    'noise_level' 1 − σ̂_new/rmse_before (σ̂ the new model's dof-corrected training residual sd,
    rmse_before the current model's held-out RMSE: the held-out error falls to the training
    noise level); 'training_ratio' 1 − σ̂_new/σ̂_cur (the held-out error shrinks as the training
    error does — robust when training and held-out runs differ in noise level)."""
    if opt.predictor == "training_ratio":
        return 1.0 - new.rmse_train_dof / cur.rmse_train_dof if cur.rmse_train_dof > 0 else 0.0
    return 1.0 - new.rmse_train_dof / rmse_before_test if rmse_before_test > 0 else 0.0


def _effect_params(f: _Fit, n_base: int) -> dict:
    names = f.model.param_names[n_base:]
    units = f.model.units[n_base:]
    return {n: {"value": float(v), "se": float(s), "unit": u}
            for n, v, s, u in zip(names, f.theta[n_base:], f.se[n_base:], units)}


def _moved(base: _Fit, f: _Fit, n_base: int) -> tuple[dict, list[str]]:
    moved, aliases = {}, []
    sd = np.sqrt(np.clip(np.diag(f.cov), 0, np.inf))
    for j, name in enumerate(base.model.param_names[:n_base]):
        shift = (f.theta[j] - base.theta[j]) / base.se[j] if base.se[j] > 0 else 0.0
        moved[name] = {"before": float(base.theta[j]), "after": float(f.theta[j]),
                       "se_before": float(base.se[j]), "se_after": float(f.se[j]),
                       "shift_in_se": float(shift), "unit": base.model.units[j]}
        rho = 0.0
        for k in range(n_base, f.theta.size):
            if sd[j] > 0 and sd[k] > 0 and np.isfinite(f.cov[j, k]):
                rho = max(rho, abs(f.cov[j, k] / (sd[j] * sd[k])))
        if abs(shift) > 3 and rho > 0.9:
            aliases.append(name)
    return moved, aliases


def _contribution(base: _Fit, f: _Fit, tr: dict) -> np.ndarray:
    """The candidate's fitted contribution on the training runs, orthogonalised against the
    nominal columns."""
    n_base = base.theta.size
    X = f.model.design(tr)
    c = X[:, n_base:] @ f.theta[n_base:]
    Xb = X[:, :n_base]
    coef, *_ = np.linalg.lstsq(Xb, c, rcond=None)
    return c - Xb @ coef



def run_consistency(cur: _Fit, new: _Fit, tr: dict, te: dict) -> dict:
    """How consistently the candidate helps across runs: its mean-square gain per run — on
    each held-out run, and on each training run predicted by the fit on the other training
    runs (leave-one-run-out) — and the one-sided sign-test p-value that it helps on more runs
    than chance would (robust to one run whose gain is large either way). A real effect helps
    on most runs; a column that fits one run's peculiarity helps some and hurts others. The
    test's null comes from the campaign's own runs, not from a constant set on one emulator."""
    from scipy.stats import binomtest
    gains = []
    e0, e1 = _loro_errors(cur.model, tr), _loro_errors(new.model, tr)
    for r in np.unique(tr["run"]):
        m = tr["run"] == r
        gains.append(float(np.mean(e0[m] ** 2 - e1[m] ** 2)))
    for r in np.unique(te["run"]):
        m = te["run"] == r
        gains.append(float(np.mean(cur.e_test[m] ** 2 - new.e_test[m] ** 2)))
    g = np.asarray(gains)
    p = float(binomtest(int((g > 0).sum()), g.size, 0.5, alternative="greater").pvalue)
    return {"run_gains": g.tolist(), "p_runs": p, "runs_helped": int((g > 0).sum()),
            "runs": int(g.size)}
