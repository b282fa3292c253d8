"""The paper's results reproduced end to end on the emulator (`rig reproduce`, the `reproduction`
job kind): one report with each of the paper's tables next to our figures and the ratio.

The campaign: schemes 1 and 2 at the paper's 300 and 3000 r/min in both directions and scheme 3
with its optimised Fourier excitation (core.schemes defaults), simulated by simulators.offline.
The fits (estimator.identify): Eq. 4 by LS/MH/SGHMC on a scheme-3 run (Table 3); Eq. 11 with the
Bouc–Wen state (Eq. 9) by LS/MH/SGHMC on the direction +1 loading runs (Table 4 for the linear
block, Table 8 for α, β, γ, with Fig. 18's twist–torque loop measured vs predicted on a held-out
run); Table 9's RMSE on the held-out runs (a second scheme-3 run, the direction −1 loading runs);
Sobol first-order and total indices over the SGHMC posteriors (Figs. 21–24, estimator.sobol);
R-hat every 200 iterations and autocorrelations (Tables 6–7, Figs. 14–17); the condition number of
scheme 3's optimised trajectory against random feasible ones (Fig. 6, core.excitation); the
Table 11 acceptance indicators of every loading run (core.acceptance).

Every row of every table holds `ours`, `paper` (None where the paper gives no number) and `ratio`
= ours / paper. Where ours differs, `explanations` says why from quantities measured in this run
(noise level, the emulator's truth, the statistic's definition), never from a guess.

The report is JSON-ready apart from nothing: plots are drawn from it (reproduction_figures), so
the stored document and the page agree. The `quick` mode (one loading run per role, a short
scheme-3 run, short chains) checks the whole pipeline in about a minute of CPU."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

PAPER: dict[str, Any] = {
    "table3": {   # Eq. 4: LS, SGHMC and SGHMC's 95 % credible interval
        "I_xx": (6685.166, 6681.266, (6599.640, 6753.321)),
        "mr_x": (20.779, 20.780, (19.302, 22.305)),
        "mr_y": (-34.543, -34.523, (-38.549, -30.420)),
        "f_v": (8683.272, 8682.911, (8663.980, 8702.206)),
        "f_c": (2352.660, 2352.936, (2332.964, 2372.455)),
    },
    "table4": {   # Eq. 11's linear block: LS, SGHMC, SGHMC's 95 % credible interval
        "k_u": (-761.529, -689.076, (-1501.594, 16.680)),
        "k_h": (16909.986, 16987.952, (16027.840, 17666.666)),
        "f_v": (9069.448, 9305.415, (8137.896, 10057.360)),
        "D+f_c": (492.014, 375.168, (-711.280, 1582.123)),
        "C": (-492.237, -412.486, (-1520.071, 631.033)),
    },
    "table5_mcmc": {"k_u": -714.487, "k_h": 16921.728, "f_v": 9051.270, "D+f_c": 475.074,
                    "C": -587.327},
    "table6_mean_autocorr": {"mh": (0.7e-3, -0.8e-3, 3.4e-3, -0.2e-3, 1.9e-3),
                             "sghmc": (-0.599e-3, 0.679e-4, -0.93e-5, 0.293e-3, -0.747e-4)},
    "table7_rhat_avg": {"mh": (0.9982, 0.9982, 0.9984, 0.9983, 0.9984),
                        "sghmc": (0.9983, 0.9981, 0.9982, 0.9981, 0.9983)},
    "table8": {   # Eq. 9: LS, SGHMC, SGHMC's 95 % credible interval
        "alpha": (0.003, 0.040, (-0.028, 0.121)),
        "beta": (0.002, 0.012, (-0.047, 0.072)),
        "gamma": (-0.042, -0.011, (-0.160, 0.149)),
    },
    "fig18_hysteresis_rmse": {"sghmc": 0.234, "ls": 0.545},
    "table9_rmse": {"eq4": {"sghmc": 2227.144, "ls": 2227.144},
                    "eq11": {"sghmc": 1705.926, "ls": 1845.883, "mh": 1741.990}},
    "fig21_22_eq4_total_order": ["mr_x", "f_v", "f_c", "I_xx", "mr_y"],
    "fig23_eq11_first_order": ["f_v", "k_h", "k_u", "D+f_c", "C"],
    "fig24_eq11_total_order": ["k_u", "f_v", "k_h", "C", "D+f_c"],
    "table11": {"torque_error": 2e3, "bending_error": 2e3, "shear_error": 2e3,
                "torque_range": 180e3, "bending_range": 250e3, "shear_value": 90e3},
}
"""The paper's own numbers (Tables 3–9 and 11, the orderings it states for Figs. 21–24)."""

METHODS: tuple[str, ...] = ("ls", "mh", "sghmc")
"""The methods of Tables 3, 4 and 8."""


@dataclass(frozen=True)
class Settings:
    """What the reproduction runs: `quick` shortens the campaign and the chains (a pipeline
    check, not a reproduction); `seed` seeds the emulator and the samplers."""
    quick: bool = False
    seed: int = 1

    @property
    def chains(self) -> dict[str, Any]:
        if self.quick:
            return {"chains": 2, "draws": 400, "warmup": 200}
        return {"chains": 4, "draws": 4000, "warmup": 2000}


def _ratio(ours: float | None, paper: float | None) -> float | None:
    if ours is None or paper is None or paper == 0 or not math.isfinite(float(ours)):
        return None
    return float(ours) / float(paper)


def _row(quantity: str, ours: float | None, paper: float | None, unit: str = "", **more: Any
         ) -> dict[str, Any]:
    ours = None if ours is None else float(ours)
    return {"quantity": quantity, "unit": unit, "ours": ours,
            "paper": None if paper is None else float(paper), "ratio": _ratio(ours, paper),
            **more}


# --- the campaign -----------------------------------------------------------------------------

def simulate_campaign(settings: Settings) -> dict[str, list]:
    """The paper's campaign on the emulator: {'eq4_train', 'eq4_test', 'bw_train', 'bw_test'}
    lists of core.run.RunData. Loading runs (schemes 1, 2): direction +1 trains, −1 is held out;
    scheme 3: one run trains, a second (another seed) is held out."""
    from core.schemes import Scheme1, Scheme2, Scheme3
    from simulators.config import EmulatorConfig
    from simulators.offline import simulate

    cfg = EmulatorConfig(seed=settings.seed)
    speeds = (3000.0,) if settings.quick else (300.0, 3000.0)
    schemes = (Scheme1,) if settings.quick else (Scheme1, Scheme2)
    out: dict[str, list] = {"bw_train": [], "bw_test": [], "eq4_train": [], "eq4_test": []}
    i = 0
    for cls in schemes:
        for speed in speeds:
            for direction, role in ((1, "bw_train"), (-1, "bw_test")):
                out[role].append(simulate(cls(motor_speed_rpm=speed, direction=direction),
                                          cfg.replace(seed=settings.seed + i)))
                i += 1
    s3 = Scheme3(n_periods=2) if settings.quick else Scheme3()
    out["eq4_train"].append(simulate(s3, cfg.replace(seed=settings.seed + i)))
    out["eq4_test"].append(simulate(s3, cfg.replace(seed=settings.seed + i + 1)))
    return out


def _label(run) -> str:
    m = run.meta
    speed = m.get("motor_speed_rpm")
    return (f"scheme {m.get('scheme')}" + (f" {float(speed):.0f} r/min" if speed else " Fourier")
            + (f" dir {m.get('direction'):+d}" if m.get("direction") else ""))


# --- the tables ---------------------------------------------------------------------------------

def _param_table(fits: dict[str, Any], paper: dict[str, tuple], truth: dict[str, float],
                 names: Sequence[str], mh_paper: dict[str, float] | None = None
                 ) -> list[dict[str, Any]]:
    """Rows per parameter: ours by LS / MH / SGHMC, the SGHMC interval, the paper's LS and
    SGHMC values and interval (and its MCMC values, Table 5, when given), ratios ours/paper,
    the emulator's truth where known."""
    rows = []
    for n in names:
        p_ls, p_sg, p_ci = paper.get(n, (None, None, (None, None)))
        for m in METHODS:
            f = fits.get(m)
            if f is None or n not in f.param_names:
                continue
            j = f.param_names.index(n)
            paper_v = {"ls": p_ls, "sghmc": p_sg, "mh": (mh_paper or {}).get(n)}.get(m)
            rows.append(_row(f"{n} ({m})", f.mean[j], paper_v, f.units[j],
                             parameter=n, method=m, ci=[float(f.ci_low[j]), float(f.ci_high[j])],
                             paper_ci=list(p_ci) if m == "sghmc" and p_ci[0] is not None
                             else None, truth=truth.get(n)))
    return rows


def _rmse_diff(y: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(RMSE(b) − RMSE(a)) / RMSE(a) and its standard error, from the paired squared errors
    in blocks of 50 samples (the residuals are correlated in time)."""
    ea, eb = (y - a) ** 2, (y - b) ** 2
    n = (len(y) // 50) * 50
    if n < 100:
        return float("nan"), float("nan")
    da = ea[:n].reshape(-1, 50).mean(axis=1)
    db = eb[:n].reshape(-1, 50).mean(axis=1)
    ra = math.sqrt(ea.mean())
    d = db - da                         # block differences of the mean square
    rel = (math.sqrt(eb.mean()) - ra) / ra
    se = float(d.std(ddof=1) / math.sqrt(d.size)) / (2.0 * ra * ra)
    return float(rel), se


def _bw_predict(fit, sig: dict) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 11's torque and the Bouc–Wen state x of a Bouc–Wen fit along prepared signals."""
    from core.terms import eq11_regressor
    from estimator.bouc_wen_kernel import bw_state
    from core.params import JointParams

    names = list(fit.param_names)
    beta, gamma = fit.mean[names.index("beta")], fit.mean[names.index("gamma")]
    theta = np.array([fit.mean[names.index(n)] for n in ("k_u", "k_h", "f_v", "D+f_c", "C")])
    alpha = fit.extra.get("alpha_fixed") or 1.0
    d = np.asarray(sig["torsion"], float)
    x = bw_state(d, alpha, beta, gamma, int(fit.extra.get("n", 1)), run=sig.get("run"))
    X = eq11_regressor(d, np.asarray(sig["torsion_rate"], float), x, JointParams().v_eps)
    return X @ theta, x


def _decimated(n: int, points: int = 600) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(points, n)).astype(int))


def _sobol(fit, model_fn: Callable, seed: int, n_base: int) -> dict[str, list]:
    from estimator.sobol import sobol_indices
    res = sobol_indices(model_fn, fit.param_names, fit.mean, fit.sd, n_base=n_base, seed=seed)
    return {k: [x if isinstance(x, str) else float(x) for x in res.table[k]]
            for k in ("name", "S1", "S1_conf", "ST", "ST_conf")}


def _order(table: dict[str, list], key: str) -> list[str]:
    return [n for _, n in sorted(zip(table[key], table["name"]), key=lambda t: -t[0])]


def _kendall(a: Sequence[str], b: Sequence[str]) -> float | None:
    common = [n for n in a if n in b]
    if len(common) < 2:
        return None
    from scipy.stats import kendalltau
    return float(kendalltau([a.index(n) for n in common], [b.index(n) for n in common])[0])


def _classic_rhat(draws: np.ndarray) -> np.ndarray:
    """Gelman–Rubin's original (non-split, non-rank-normalised) R-hat: √(((n−1)/n·W + B/n)/W),
    which falls below 1 on well-mixed chains — the paper's Table 7 values are below 1."""
    a = np.asarray(draws, float)
    n = a.shape[1]
    W = a.var(axis=1, ddof=1).mean(axis=0)
    B = n * a.mean(axis=1).var(axis=0, ddof=1)
    return np.sqrt(((n - 1) / n * W + B / n) / W)


def _all_lag_mean_autocorr(draws: np.ndarray) -> np.ndarray:
    from estimator.convergence import autocorr
    a = np.asarray(draws, float)
    return autocorr(a, a.shape[1] - 1)[1:].mean(axis=0)


# --- the reproduction ---------------------------------------------------------------------------

def reproduce(settings: Settings = Settings(),
              progress: Callable[[float], None] | None = None) -> tuple[dict[str, Any], list]:
    """Run the whole reproduction; returns (report, fits) — the JSON-ready report (module
    docstring) and the estimator Fits it was made from (Eq. 4 and Eq. 11 by each method)."""
    from core.acceptance import acceptance, is_loading_run
    from core.params import JointParams
    from core.schemes import Scheme3
    from estimator.identify import bouc_wen_signals, identify
    from estimator.preprocess import PrepOptions, concat_signals, prepare
    from estimator.sobol import eq4_torque_model, eq11_torque_model
    from core.terms import eq4_regressor

    def step(x: float) -> None:
        if progress is not None:
            progress(x)

    t_all = time.perf_counter()
    timings: dict[str, float] = {}
    P = JointParams()
    t0 = time.perf_counter()
    campaign = simulate_campaign(settings)
    timings["campaign"] = time.perf_counter() - t0
    step(0.1)
    opts = dict(settings.chains, seed=settings.seed)

    # Table 3: Eq. 4 on scheme 3 (1 kHz decimated 10x, as the demo does), held-out scheme-3 run
    prep4 = PrepOptions(min_speed=2e-4, decimate=10)
    t0 = time.perf_counter()
    eq4 = {m: identify(campaign["eq4_train"], "eq4", m, campaign["eq4_test"], prep=prep4,
                       **({} if m == "ls" else opts)) for m in METHODS}
    timings["eq4_fits"] = time.perf_counter() - t0
    step(0.35)

    # Tables 4 and 8: Eq. 11 with the Bouc–Wen state, on the direction +1 loading runs
    t0 = time.perf_counter()
    eq11 = {m: identify(campaign["bw_train"], "eq11", m, campaign["bw_test"],
                        **({} if m == "ls" else opts)) for m in METHODS}
    timings["eq11_fits"] = time.perf_counter() - t0
    step(0.7)

    truth4 = {n: float(getattr(P, n)) for n in ("I_xx", "mr_x", "mr_y", "f_v", "f_c")}
    truth11 = {"k_u": P.w * P.k, "k_h": (1 - P.w) * P.k, "alpha": P.alpha, "beta": P.beta,
               "gamma": P.gamma}
    tables: dict[str, Any] = {}
    tables["table3"] = {"title": "Table 3 — Eq. 4 on scheme 3 (LS, MH, SGHMC)",
                        "rows": _param_table(eq4, PAPER["table3"], truth4, list(truth4))}
    tables["table4"] = {"title": "Table 4 — Eq. 11's linear block (LS, MH, SGHMC)",
                        "rows": _param_table(eq11, PAPER["table4"], truth11,
                                             ["k_u", "k_h", "f_v", "D+f_c", "C"],
                                             PAPER["table5_mcmc"])}
    t8 = [_row("alpha (fixed)", eq11["ls"].extra.get("alpha_fixed") or P.alpha,
               PAPER["table8"]["alpha"][1], "-", parameter="alpha", method="all",
               truth=P.alpha)]
    t8 += _param_table(eq11, PAPER["table8"], truth11, ["beta", "gamma"])

    # Fig. 18: the twist–torque loop of a held-out run, measured vs predicted by LS and SGHMC;
    # hysteresis RMSE against the emulator's own hysteresis torque k_h·x (truth β, γ on the
    # same measured twist)
    from estimator.bouc_wen_kernel import bw_state
    test_run = campaign["bw_test"][-1]
    sig = prepare(test_run, bouc_wen_signals(test_run))
    y = np.asarray(sig["torque"], float)
    d = np.asarray(sig["torsion"], float)
    x_true = bw_state(d, P.alpha, P.beta, P.gamma, 1)
    h_true = truth11["k_h"] * x_true
    loop: dict[str, Any] = {"run": _label(test_run)}
    idx = _decimated(d.size)
    loop["twist"] = d[idx].tolist()
    loop["measured"] = y[idx].tolist()
    pred = {}
    for m in ("ls", "sghmc"):
        yh, xh = _bw_predict(eq11[m], sig)
        kh = eq11[m].mean[eq11[m].param_names.index("k_h")]
        pred[m] = yh
        loop[m] = yh[idx].tolist()
        loop[f"rmse_torque_{m}"] = float(np.sqrt(np.mean((y - yh) ** 2)))
        loop[f"rmse_hysteresis_{m}"] = float(np.sqrt(np.mean((h_true - kh * xh) ** 2)))
    for m in ("ls", "sghmc"):
        t8.append(_row(f"hysteresis RMSE ({m})", loop[f"rmse_hysteresis_{m}"],
                       PAPER["fig18_hysteresis_rmse"][m], "N·m", method=m,
                       note="k_h·x against the emulator's own; the paper's unit is not stated"))
    t8.append(_row("hysteresis RMSE ratio LS / SGHMC",
                   loop["rmse_hysteresis_ls"] / loop["rmse_hysteresis_sghmc"],
                   PAPER["fig18_hysteresis_rmse"]["ls"] / PAPER["fig18_hysteresis_rmse"]["sghmc"],
                   "-"))
    tables["table8"] = {"title": "Table 8 — Eq. 9 (α fixed at 1: only α·k_h is identifiable) "
                                 "and Fig. 18's hysteresis RMSE on a held-out run", "rows": t8}

    # Table 9: held-out RMSE
    t9 = []
    for model, fits in (("eq4", eq4), ("eq11", eq11)):
        for m in METHODS:
            t9.append(_row(f"({model[2:]}) {m} held-out RMSE", fits[m].rmse_test,
                           PAPER["table9_rmse"][model].get(m), "N·m", model=model, method=m,
                           rmse_train=fits[m].rmse_train, sigma=fits[m].sigma))
    rel, se = _rmse_diff(y, pred["ls"], pred["sghmc"])
    p9 = PAPER["table9_rmse"]["eq11"]
    t9.append(_row("(11) SGHMC vs LS: relative RMSE change", rel,
                   (p9["sghmc"] - p9["ls"]) / p9["ls"], "-", se=se))
    tables["table9"] = {"title": "Table 9 — RMSE (Eq. 17) on the held-out runs", "rows": t9}

    # Tables 6–7, Figs. 14–17: autocorrelation and R-hat every 200 iterations (Eq. 11)
    conv_rows, traces = [], {}
    for m in ("mh", "sghmc"):
        f = eq11[m]
        lin = [f.param_names.index(n) for n in ("k_u", "k_h", "f_v", "D+f_c", "C")]
        tr = f.diagnostics.get("rhat_trace") or {}
        r = np.asarray(tr.get("rhat", []), float)
        avg = r[:, lin].mean(axis=0) if r.size else np.asarray(f.diagnostics["rhat"])[lin]
        classic = _classic_rhat(f.draws[:, :, lin])
        mac = np.asarray(f.diagnostics["mean_autocorr"])[lin]
        all_lag = _all_lag_mean_autocorr(f.draws[:, :, lin])
        for k, n in enumerate(("k_u", "k_h", "f_v", "D+f_c", "C")):
            conv_rows.append(_row(f"{n} ({m}) R-hat avg of trace", avg[k],
                                  PAPER["table7_rhat_avg"][m][k], "-", method=m, parameter=n,
                                  classic_rhat=float(classic[k])))
            conv_rows.append(_row(f"{n} ({m}) mean autocorr lags 1–50", mac[k],
                                  PAPER["table6_mean_autocorr"][m][k], "-", method=m,
                                  parameter=n, all_lags=float(all_lag[k])))
        traces[m] = {"iterations": np.asarray(tr.get("iterations", []), float).tolist(),
                     "rhat": r.tolist(), "names": list(f.param_names),
                     "autocorr": np.asarray(f.diagnostics["autocorr"]).tolist(),
                     "min_ess_bulk": float(np.nanmin(f.diagnostics["ess_bulk"])),
                     "max_rhat": float(np.nanmax(f.diagnostics["rhat"]))}
    tables["convergence"] = {"title": "Tables 6–7 — Eq. 11: R-hat (every 200 iterations, "
                                      "averaged) and mean autocorrelation", "rows": conv_rows}
    step(0.8)

    # Figs. 21–24: Sobol indices over the SGHMC posteriors
    n_base = 128 if settings.quick else 1024
    s4 = prepare(campaign["eq4_train"][0], ("q", "qd", "qdd", "torque", "torque_load"), prep4)
    rows4 = _decimated(len(s4["q"]), 2000)
    sob4 = _sobol(eq4["sghmc"], eq4_torque_model(np.asarray(s4["q"])[rows4],
                                                 np.asarray(s4["qd"])[rows4],
                                                 np.asarray(s4["qdd"])[rows4], P.v_eps),
                  settings.seed, n_base)
    f11 = eq11["sghmc"]
    lin_fit = _linear_part(f11)
    sig_tr = concat_signals([prepare(r, bouc_wen_signals(r)) for r in campaign["bw_train"]])
    _, x_tr = _bw_predict(f11, sig_tr)
    rows11 = _decimated(len(x_tr), 2000)
    sob11 = _sobol(lin_fit, eq11_torque_model(np.asarray(sig_tr["torsion"])[rows11],
                                              np.asarray(sig_tr["torsion_rate"])[rows11],
                                              x_tr[rows11], P.v_eps), settings.seed, n_base)
    # what sets each index of a linear model: posterior variance × the regressor's spread
    X4 = eq4_regressor(np.asarray(s4["q"])[rows4], np.asarray(s4["qd"])[rows4],
                       np.asarray(s4["qdd"])[rows4], P.v_eps)
    share4 = _variance_share(eq4["sghmc"].sd, X4)
    from core.terms import eq11_regressor
    X11 = eq11_regressor(np.asarray(sig_tr["torsion"])[rows11],
                         np.asarray(sig_tr["torsion_rate"])[rows11], x_tr[rows11], P.v_eps)
    share11 = _variance_share(lin_fit.sd, X11)
    sobol_rows = []
    for label, tab, key, paper_order, share in (
            ("Eq. 4 total effect (Fig. 22)", sob4, "ST", PAPER["fig21_22_eq4_total_order"],
             share4),
            ("Eq. 11 first order (Fig. 23)", sob11, "S1", PAPER["fig23_eq11_first_order"],
             share11),
            ("Eq. 11 total effect (Fig. 24)", sob11, "ST", PAPER["fig24_eq11_total_order"],
             share11)):
        ours = _order(tab, key)
        for n in tab["name"]:
            sobol_rows.append(_row(f"{label}: rank of {n}", ours.index(n) + 1,
                                   paper_order.index(n) + 1 if n in paper_order else None, "-",
                                   index=float(tab[key][tab["name"].index(n)]),
                                   variance_share=float(share[tab["name"].index(n)])))
        sobol_rows.append(_row(f"{label}: Kendall τ of the orderings", _kendall(ours, paper_order),
                               1.0, "-", ours_order=ours, paper_order=paper_order))
    tables["sobol"] = {"title": "Figs. 21–24 — Sobol indices over the SGHMC posteriors: ranks "
                                "(1 = largest) against the orderings the paper states",
                       "rows": sobol_rows}
    step(0.9)

    # Fig. 6: condition number of scheme 3's optimised excitation vs random feasible ones
    ex = Scheme3().excitation()
    tables["excitation"] = {
        "title": "Fig. 6 — scheme 3's excitation: condition number of Eq. 4's observation matrix",
        "rows": [_row("optimised trajectory", ex.cond, None, "-",
                      note="the paper shows the trajectory, not its condition number"),
                 _row("random feasible trajectories (median)", ex.random_median_cond, None, "-"),
                 _row("random feasible trajectories (best)", min(ex.random_conds), None, "-"),
                 _row("median random / optimised", ex.random_median_cond / ex.cond, None, "-")]}
    excitation_fig = _excitation_series(ex)

    # Table 11: acceptance indicators of every loading run
    t11 = []
    for run in campaign["bw_train"] + campaign["bw_test"]:
        if not is_loading_run(run):
            continue
        for ind in acceptance(run):
            if ind.kind == "error" and ind.max_abs is not None:
                t11.append(_row(f"{_label(run)}: {ind.name} max |error|", ind.max_abs,
                                ind.tolerance, ind.unit, status=ind.status, item=ind.item,
                                note=ind.note))
            elif ind.kind in ("range", "value") and ind.reached is not None:
                t11.append(_row(f"{_label(run)}: {ind.name} reached", ind.reached,
                                ind.required, ind.unit, status=ind.status, item=ind.item,
                                note=ind.note))
    tables["table11"] = {"title": "Table 11 — acceptance indicators (ours: worst error or value "
                                  "reached; paper: tolerance or required value)", "rows": t11}

    fits_all = {"eq4": eq4, "eq11": eq11}
    report = {
        "settings": {"quick": settings.quick, "seed": settings.seed, **settings.chains},
        "campaign": {role: [_label(r) + f" ({len(r.samples)} samples)" for r in runs]
                     for role, runs in campaign.items()},
        "tables": tables,
        "explanations": _explanations(fits_all, tables, loop, P, rel, se),
        "figures": {"loop": loop, "traces": traces, "sobol": {"eq4": sob4, "eq11": sob11},
                    "excitation": excitation_fig,
                    "eq4_test": _eq4_series(eq4, campaign["eq4_test"][0], prep4)},
        "timings": {**timings, "total": time.perf_counter() - t_all},
    }
    step(1.0)
    return report, [f for group in fits_all.values() for f in group.values()]


def _linear_part(fit):
    """The Eq. 11 linear block of a Bouc–Wen fit as its own Fit (Sobol over k_u … C)."""
    from estimator.result import Fit
    names = ["k_u", "k_h", "f_v", "D+f_c", "C"]
    j = [fit.param_names.index(n) for n in names]
    return Fit(model=fit.model, method=fit.method, param_names=names,
               units=[fit.units[k] for k in j], mean=fit.mean[j], sd=fit.sd[j],
               ci_low=fit.ci_low[j], ci_high=fit.ci_high[j], sigma=fit.sigma,
               rmse_train=fit.rmse_train)


def _variance_share(sd: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Share of the output variance each parameter carries when the parameters vary
    independently with sd: sd_j²·mean_t(X_tj²) normalised — the first-order index of a linear
    model up to the centring over time."""
    c = np.asarray(sd, float) ** 2 * np.mean(np.asarray(X, float) ** 2, axis=0)
    return c / c.sum()


def _excitation_series(ex) -> dict[str, Any]:
    tr = ex.trajectory
    t = np.linspace(0.0, 2 * math.pi / tr.omega_f, 400)
    q, qd, qdd = tr.evaluate(t)
    return {"t": t.tolist(), "q": np.asarray(q).tolist(), "qd": np.asarray(qd).tolist(),
            "qdd": np.asarray(qdd).tolist(), "cond": float(ex.cond),
            "random_conds": [float(c) for c in ex.random_conds]}


def _eq4_series(fits: dict, run, prep) -> dict[str, Any]:
    """Fig. 9: measured and predicted Eq. 4 torque on the held-out scheme-3 run."""
    from core.params import JointParams
    from core.terms import eq4_regressor
    from estimator.preprocess import prepare
    s = prepare(run, ("q", "qd", "qdd", "torque", "torque_load"), prep)
    X = eq4_regressor(np.asarray(s["q"]), np.asarray(s["qd"]), np.asarray(s["qdd"]),
                      JointParams().v_eps)
    y = np.asarray(s["torque"]) - np.asarray(s["torque_load"])
    idx = _decimated(len(y))
    out = {"t": np.asarray(s["t"])[idx].tolist(), "measured": y[idx].tolist()}
    for m in ("ls", "sghmc"):
        out[m] = (X @ fits[m].mean)[idx].tolist()
    return out


def _explanations(fits: dict, tables: dict, loop: dict, P, rel: float, se: float
                  ) -> list[str]:
    """Why ours differs from the paper, from quantities measured in this reproduction."""
    out = []
    e4, e11 = fits["eq4"], fits["eq11"]
    noise = float(P.torque_noise)
    r4, s4 = e4["ls"].rmse_test, e4["ls"].sigma
    out.append(
        f"Noise level: Eq. 4's held-out RMSE is {r4:.0f} N·m, {r4 / s4:.2f}× the fit's own "
        f"noise sd σ̂ = {s4:.0f} N·m (the strain gauge's {noise:.0f} N·m after the 10× "
        f"anti-aliased decimation): the emulated torque is explained down to its noise. The "
        f"paper's 2227.144 N·m is {2227.144 / r4:.1f}× ours: that much more torque in the "
        f"paper's data was left unexplained by Eq. 4.")
    r11, s11 = e11["ls"].rmse_test, e11["ls"].sigma
    out.append(
        f"Eq. 11's held-out RMSE is {r11:.0f} N·m ({r11 / noise:.2f}× the strain gauge's noise "
        f"sd; training σ̂ {s11:.0f} N·m): above the sensor noise, the residual holds what the "
        f"sampled twist does not show Eq. 9 (next items). The paper's 1845.883 (LS) is "
        f"{1845.883 / r11:.2f}× ours.")
    out.append(
        f"SGHMC vs LS on Eq. 11: on the held-out run SGHMC's posterior mean changes the RMSE by "
        f"{100 * rel:+.3f} % (± {100 * se:.3f} % standard error, blocks of 50 samples); the "
        f"paper reports −8.16 %. On the training runs LS is the minimum-RMSE estimate by "
        f"construction (train RMSE LS {e11['ls'].rmse_train:.1f}, SGHMC "
        f"{e11['sghmc'].rmse_train:.1f} N·m), and SGHMC's posterior mean lies "
        f"{_max_z(e11['ls'], e11['sghmc']):.2f} posterior sd from the LS estimate at most, so "
        f"the two predict alike; a gain of 8 % would need the two estimates far apart.")
    yield_twist = P.alpha / (P.beta + P.gamma)
    out.append(
        f"Eq. 9 against the emulator's truth: β, γ land at "
        f"{_ratio_txt(e11['sghmc'], 'beta', P.beta)} and "
        f"{_ratio_txt(e11['sghmc'], 'gamma', P.gamma)} of the truth. The output encoder's "
        f"0.01° step ({P.enc_res:.2e} rad) is {P.enc_res / yield_twist:.0%} of the yield twist "
        f"α/(β+γ) = {yield_twist:.2e} rad: the measured twist Eq. 9 is driven by is quantised "
        f"at the scale of the hysteresis it must resolve (an errors-in-variables bias no "
        f"sampler removes; tests/test_estimator_boucwen.py recovers the truth with a fine "
        f"encoder).")
    out.append(
        "Parameter values: the emulator's rigid-body constants are Table 3's (core/params.py), "
        "so Table 3's ratios measure the estimator (truth column). Its transmission constants "
        f"are design values (k_u = {P.w * P.k:.3g}, k_h = {(1 - P.w) * P.k:.3g} N·m/rad, "
        f"β = {P.beta:g}, γ = {P.gamma:g} 1/rad), not Table 4's or 8's (k_u = −761.5, "
        "β = 0.002 in unstated units): the ratios in Tables 4 and 8 compare two different "
        "joints, and ours are checked against the emulator's truth instead. α is fixed at 1 "
        "(x scales with α, so only α·k_h is identified).")
    h_ls, h_sg = loop["rmse_hysteresis_ls"], loop["rmse_hysteresis_sghmc"]
    inside = _inside(e11["ls"], e11["sghmc"], ("beta", "gamma"))
    out.append(
        f"Fig. 18: hysteresis torque RMSE against the emulator's own k_h·x: LS {h_ls:.1f}, "
        f"SGHMC {h_sg:.1f} N·m (ratio {h_ls / h_sg:.2f}; the paper's 0.545 / 0.234 = 2.33). "
        f"LS's β, γ {'lie inside' if inside else 'fall outside'} SGHMC's 95 % interval, so the "
        f"two fits {'trace the same loop' if inside else 'trace different loops'}.")
    conv = tables["convergence"]["rows"]
    classic = [r["classic_rhat"] for r in conv if "classic_rhat" in r]
    all_lag = [r["all_lags"] for r in conv if "all_lags" in r]
    if classic:
        below = sum(c < 1.0 for c in classic)
        out.append(
            f"R-hat: ours is the rank-normalised split R-hat, which stays at or above 1 on "
            f"agreeing chains; the original Gelman–Rubin formula on the same draws gives "
            f"{min(classic):.4f}–{max(classic):.4f} ({below} of {len(classic)} below 1). Only "
            "that formula goes below 1, as the paper's Table 7 values (0.998) do.")
    if all_lag:
        out.append(
            f"Autocorrelation: our Table 6 figure is the mean over lags 1–50; averaged over all "
            f"lags (as the paper's ~1e-3 values suggest) the same draws give "
            f"{min(all_lag):.1e} to {max(all_lag):.1e}, the size of the paper's — an all-lag "
            "mean tends to −1/(2n) for any chain and does not discriminate.")
    t11 = tables["table11"]["rows"]
    if t11:
        status = [r["status"] for r in t11]
        errors = [r["ratio"] for r in t11 if r["quantity"].endswith("max |error|")
                  and r["ratio"] is not None]
        unmet = [r for r in t11 if r["status"] == "not met"]
        text = (f"Table 11: {status.count('pass')} of {len(t11)} indicators pass, "
                f"{status.count('fail')} fail")
        if errors:
            text += (f"; every loading error's worst |error| is {min(errors):.2f}–"
                     f"{max(errors):.2f}× its tolerance")
        if unmet:
            items = sorted({r["quantity"].split(": ", 1)[1] for r in unmet})
            ratios = [r["ratio"] for r in unmet if r["ratio"] is not None]
            text += (f". {len(unmet)} are 'not met' rather than failed ({'; '.join(items)}: "
                     f"{min(ratios):.2f}–{max(ratios):.2f}× the paper's required value): the "
                     f"paper's loading schemes aim at the rated load, not at Table 11's ranges "
                     f"(e.g. {unmet[0]['note']}); showing the 0–180 kN·m range needs a run "
                     f"loading to it (core/acceptance.py)")
        out.append(text + ".")
    rows = tables["sobol"]["rows"]
    sob = [r for r in rows if r["quantity"].endswith("orderings")]
    if sob:
        taus = ", ".join(f"{r['quantity'].split(':')[0]} τ = "
                         f"{'—' if r['ours'] is None else format(r['ours'], '.2f')}" for r in sob)
        idx = [r for r in rows if "variance_share" in r and r["quantity"].startswith("Eq. 4")]
        agree = _kendall([r["quantity"] for r in sorted(idx, key=lambda r: -r["index"])],
                         [r["quantity"] for r in sorted(idx, key=lambda r: -r["variance_share"])])
        out.append(
            f"Sobol orderings against the paper's ({taus}): over posterior marginals the index "
            f"of a linear model's parameter is its posterior variance × its regressor's mean "
            f"square (`variance_share`; Kendall τ between that and our Eq. 4 total indices: "
            f"{'—' if agree is None else format(agree, '.2f')}). Posterior widths are set by "
            "the data's noise and excitation, so the paper's campaign, noisier by the ratio "
            "above, orders them its own way.")
    return out


def _max_z(ls, post) -> float:
    """Largest |posterior mean − LS estimate| / posterior sd over the shared parameters."""
    z = [abs(post.mean[post.param_names.index(n)] - ls.mean[j])
         / post.sd[post.param_names.index(n)]
         for j, n in enumerate(ls.param_names) if n in post.param_names
         and post.sd[post.param_names.index(n)] > 0]
    return float(max(z)) if z else float("nan")


def _inside(ls, post, names: Sequence[str]) -> bool:
    """Whether LS's estimates of `names` lie inside the posterior's intervals."""
    return all(post.ci_low[post.param_names.index(n)] <= ls.mean[ls.param_names.index(n)]
               <= post.ci_high[post.param_names.index(n)] for n in names)


def _ratio_txt(fit, name: str, truth: float) -> str:
    j = fit.param_names.index(name)
    return f"{fit.mean[j] / truth:.2f}×"


# --- text rendering -----------------------------------------------------------------------------

def _fmt(x: Any) -> str:
    if x is None:
        return "—"
    if isinstance(x, float):
        if not math.isfinite(x):
            return "—"
        return f"{x:.4g}" if abs(x) >= 1e-3 or x == 0 else f"{x:.2e}"
    return str(x)


def report_text(report: dict[str, Any]) -> str:
    """The report as text: each table (ours | paper | ratio), then the explanations."""
    lines = [f"Reproduction of the paper on the emulator "
             f"({'quick' if report['settings']['quick'] else 'full'} mode, seed "
             f"{report['settings']['seed']}, {report['timings']['total']:.0f} s)"]
    for role, runs in report["campaign"].items():
        lines.append(f"  {role}: " + "; ".join(runs))
    for tab in report["tables"].values():
        lines += ["", tab["title"]]
        w = max([len(r["quantity"]) for r in tab["rows"]] + [8])
        lines.append(f"  {'':<{w}} {'ours':>12} {'paper':>12} {'ratio':>9}  unit / note")
        for r in tab["rows"]:
            extra = r.get("note") or ""
            if r.get("status"):
                extra = f"{r['status']}: {extra}" if extra else r["status"]
            if r.get("truth") is not None:
                extra = f"truth {_fmt(r['truth'])} " + extra
            if r.get("ci"):
                extra = f"CI [{_fmt(r['ci'][0])}, {_fmt(r['ci'][1])}] " + extra
            lines.append(f"  {r['quantity']:<{w}} {_fmt(r['ours']):>12} {_fmt(r['paper']):>12} "
                         f"{_fmt(r['ratio']):>9}  {r.get('unit', '')} {extra}".rstrip())
    lines += ["", "Where ours differs from the paper, and why (measured):"]
    lines += [f"  - {e}" for e in report["explanations"]]
    return "\n".join(lines)
