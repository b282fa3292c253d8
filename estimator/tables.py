"""Tables (plain text, or HTML for the report pages) in the layout of the paper's Section V: parameter tables (Tables 3, 4, 5 and 8: one
row per parameter, the methods side by side with their intervals, RMSE underneath), mean
autocorrelation (Table 6), average R-hat (Table 7), RMSE comparison (Table 9) and a sampling
efficiency table (ours: ESS, ESS/s, acceptance)."""

from __future__ import annotations

import html as _html
from typing import Mapping, Sequence

import numpy as np

from estimator.result import Fit

METHOD_LABELS = {"ls": "Least Square", "exact": "Exact NIG", "mh": "MCMC", "sghmc": "SGHMC",
                 "hmc": "HMC", "nuts": "NUTS"}


def num(x: float | None) -> str:
    """Numbers as the paper prints them (3 decimals), switching to scientific notation for
    very large or very small magnitudes."""
    if x is None or (isinstance(x, float) and np.isnan(x)):
        return "—"
    x = float(x)
    if np.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x != 0 and (abs(x) >= 1e6 or abs(x) < 1e-3):
        return f"{x:.4e}"
    return f"{x:.3f}"


def _label(fit: Fit) -> str:
    return METHOD_LABELS.get(fit.method, fit.method.upper())


def _grid(header: Sequence[str], rows: Sequence[Sequence[str]], title: str | None,
          html: bool = False) -> str:
    """The table as aligned plain text, or (html) as an HTML table with its title as caption."""
    if html:
        esc = _html.escape
        cap = f"<caption>{esc(title)}</caption>" if title else ""
        head = "".join(f"<th>{esc(str(h))}</th>" for h in header)
        body = "".join("<tr>" + "".join(f"<td>{esc(str(c))}</td>" for c in r) + "</tr>"
                       for r in rows)
        return f'<table class="paper">{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'
    cols = list(zip(header, *rows)) if rows else [(h,) for h in header]
    widths = [max(len(str(c)) for c in col) for col in cols]
    line = lambda cells: "  ".join(str(c).ljust(w) for c, w in zip(cells, widths)).rstrip()
    out = [title] if title else []
    out.append(line(header))
    out.append("  ".join("-" * w for w in widths))
    out.extend(line(r) for r in rows)
    return "\n".join(out)


def parameter_table(fits: Sequence[Fit], title: str | None = None,
                    descriptions: Mapping[str, str] | None = None, units: bool = True,
                    html: bool = False) -> str:
    """Tables 3/4/5/8: No. | Parameter | [Description] | Unit | per method: estimate and its
    95 % interval (confidence for LS, credible otherwise); then σ and the RMSE (Eq. 17) on the
    training and held-out data. Fits must share parameter names (a fit lacking one shows —)."""
    if not fits:
        raise ValueError("no fits to tabulate")
    names = list(fits[0].param_names)
    for f in fits[1:]:
        names += [n for n in f.param_names if n not in names]
    unit_of = {}
    for f in fits:
        unit_of.update({n: u for n, u in zip(f.param_names, f.units) if n not in unit_of})
    header = ["No.", "Parameter"] + (["Description"] if descriptions else []) \
        + (["Unit"] if units else [])
    for f in fits:
        kind = "95% CI" if f.method == "ls" else "95% Credible Interval"
        header += [_label(f), kind]
    rows = []
    for i, n in enumerate(names, 1):
        row = [str(i), n] + ([descriptions.get(n, "")] if descriptions else []) \
            + ([unit_of.get(n, "")] if units else [])
        for f in fits:
            if n in f.param_names:
                j = f.param_names.index(n)
                row += [num(f.mean[j]), f"[{num(f.ci_low[j])}, {num(f.ci_high[j])}]"]
            else:
                row += ["—", ""]
        rows.append(row)
    pad = [""] * (len(header) - 2 * len(fits) - 1)
    extra_rows = [["σ (noise sd)"] + pad + sum([[num(f.sigma), ""] for f in fits], []),
                  ["RMSE train"] + pad + sum([[num(f.rmse_train), ""] for f in fits], [])]
    if any(f.rmse_test is not None for f in fits):
        extra_rows.append(["RMSE test"] + pad + sum([[num(f.rmse_test), ""] for f in fits], []))
    return _grid(header, rows + extra_rows, title, html)


def autocorr_table(fits: Sequence[Fit], title: str = "Mean autocorrelation (lags 1–50)",
                   html: bool = False) -> str:
    """Table 6: one row per sampler, one column per parameter number."""
    fits = [f for f in fits if "mean_autocorr" in f.diagnostics]
    if not fits:
        return ""
    p = len(fits[0].param_names)
    header = ["No."] + [str(i) for i in range(1, p + 1)]
    rows = [[_label(f)] + [f"{v:.3e}" for v in np.asarray(f.diagnostics["mean_autocorr"])[:p]]
            for f in fits]
    return _grid(header, rows, title, html)


def rhat_table(fits: Sequence[Fit], title: str = "R-hat (average over the every-200 trace; final)",
               html: bool = False) -> str:
    """Table 7: average of the R-hat trace (Figs. 16–17) per parameter, and the final value."""
    fits = [f for f in fits if "rhat" in f.diagnostics]
    if not fits:
        return ""
    p = len(fits[0].param_names)
    header = ["Parameter"] + [str(i) for i in range(1, p + 1)]
    rows = []
    for f in fits:
        tr = f.diagnostics.get("rhat_trace", {})
        r = np.asarray(tr.get("rhat", []), dtype=float)
        avg = np.nanmean(r, axis=0) if r.size else np.asarray(f.diagnostics["rhat"])
        rows.append([f"{_label(f)} (avg)"] + [f"{v:.4f}" for v in avg[:p]])
        rows.append([f"{_label(f)} (final)"] + [f"{v:.4f}" for v in
                                                np.asarray(f.diagnostics["rhat"])[:p]])
    return _grid(header, rows, title, html)


def rmse_table(fits_by_model: Mapping[str, Sequence[Fit]],
               title: str = "RMSE (Eq. 17) comparison", html: bool = False) -> str:
    """Table 9: one row per model, one column per method (train RMSE; test in parentheses)."""
    methods: list[str] = []
    for fits in fits_by_model.values():
        methods += [f.method for f in fits if f.method not in methods]
    header = ["Equation"] + [METHOD_LABELS.get(m, m) for m in methods]
    rows = []
    for model, fits in fits_by_model.items():
        by = {f.method: f for f in fits}
        row = [model]
        for m in methods:
            f = by.get(m)
            if f is None:
                row.append("—")
            else:
                row.append(num(f.rmse_train) + ("" if f.rmse_test is None
                                                 else f" ({num(f.rmse_test)})"))
        rows.append(row)
    return _grid(header, rows, title, html)


def efficiency_table(fits: Sequence[Fit], title: str = "Sampling efficiency",
                     html: bool = False) -> str:
    """Per Bayesian fit: min bulk/tail ESS, max R-hat, seconds, min ESS/s, acceptance rate and,
    for linear models, the largest distance to the exact posterior."""
    header = ["Method", "min ESS bulk", "min ESS tail", "max R-hat", "seconds", "min ESS/s",
              "accept", "max |Δmean|/sd", "sd ratio range"]
    rows = []
    for f in fits:
        d = f.diagnostics
        if "ess_bulk" not in d:
            continue
        acc = d.get("accept_rate")
        acc_s = "—" if acc is None or np.all(np.isnan(np.asarray(acc, dtype=float))) \
            else f"{np.nanmean(np.asarray(acc, dtype=float)):.3f}"
        vs = f.extra.get("vs_exact")
        if vs:
            me = f"{np.max(np.abs(vs['mean_error_in_sd'])):.3f}"
            sr = np.asarray(vs["sd_ratio"])
            srs = f"{sr.min():.3f}–{sr.max():.3f}"
        else:
            me = srs = "—"
        rows.append([_label(f), f"{np.nanmin(d['ess_bulk']):.0f}", f"{np.nanmin(d['ess_tail']):.0f}",
                     f"{np.nanmax(d['rhat']):.4f}", f"{f.timings.get('sample', float('nan')):.3f}",
                     num(d.get("min_ess_per_s")), acc_s, me, srs])
    return _grid(header, rows, title, html) if rows else ""


def sobol_table(table, title: str = "Sobol indices", html: bool = False) -> str:
    """First-order and total-effect indices (Eqs. 18–19) with their confidence half-widths, from
    estimator.sobol's result table (columns name, S1, S1_conf, ST, ST_conf)."""
    rows = [[str(n), f"{s1:.4f}", f"±{c1:.4f}", f"{st:.4f}", f"±{ct:.4f}"]
            for n, s1, c1, st, ct in zip(table["name"], table["S1"], table["S1_conf"],
                                         table["ST"], table["ST_conf"])]
    return _grid(["Parameter", "First order", "", "Total effect", ""], rows, title, html)


def report(fits: Sequence[Fit], title: str | None = None, html: bool = False) -> str:
    """The full report of one model fitted by several methods, as text or (html) HTML tables."""
    descriptions = fits[0].extra.get("descriptions") if fits else None
    parts = [parameter_table(fits, title, descriptions, html=html)]
    bayes = [f for f in fits if f.method != "ls"]
    for t in (efficiency_table(bayes, html=html), autocorr_table(bayes, html=html),
              rhat_table(bayes, html=html)):
        if t:
            parts.append(t)
    return ("" if html else "\n\n").join(parts)
