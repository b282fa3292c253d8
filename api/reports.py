"""Test reports per run and per job: a JSON-ready dict and an HTML page with SVG plots
(embedded as data URIs so a page is one self-contained file)."""

from __future__ import annotations

import base64
import html
from typing import Any, Callable

from core.jsonsafe import json_safe
from db.store import Store


json_clean = json_safe
"""NaN/inf → None, recursively (core.jsonsafe)."""


def _try_plot(fn: Callable[[], bytes | None]) -> bytes | None:
    try:
        return fn()
    except ValueError:          # the fit or run lacks what this figure shows
        return None


# --- runs ------------------------------------------------------------------------------------

def run_report(store: Store, run_id: int, with_plots: bool = True) -> dict[str, Any]:
    """A run's report: summary, channels, interruptions, acceptance indicators (Table 11),
    per-phase aggregates (SQL) and, with_plots, the figures as SVG bytes under 'plots'."""
    from db import jobs as queue
    from api.run_plots import RUN_PLOTS
    from core.acceptance import acceptance

    info = store.run_info(run_id)
    run = store.load_run(run_id)
    indicators = [i.as_dict() for i in acceptance(run)]
    aggregates = store.phase_aggregates(run_id).to_dict(orient="records")
    rep = {
        "run": info,
        "channels": store.channels(run_id),
        "interruptions": store.interruptions(run_id),
        "acceptance": indicators,
        "acceptance_passed": (all(i["passed"] for i in indicators if i["passed"] is not None)
                              if any(i["passed"] is not None for i in indicators) else None),
        "aggregates": aggregates,
        "results": queue.results_for_run(store, run_id),
    }
    if with_plots:
        arrays = {c: run.samples[c].to_numpy() for c in run.samples.columns if c != "phase"}
        rep["plots"] = {name: svg for name, fn in RUN_PLOTS.items()
                        if (svg := _try_plot(lambda fn=fn: fn(arrays))) is not None}
    return json_clean(rep)


# --- jobs ------------------------------------------------------------------------------------

def job_report(store: Store, job_id: int, with_plots: bool = True) -> dict[str, Any] | None:
    """A job's report: the job, its results (Fit.as_dict per result, runs used), the paper-layout
    tables (estimator.tables, one per model), for a diagnosis job its report under 'diagnosis'
    (the stored document) and, with_plots, predicted vs measured, posterior histograms, corner
    plot, R-hat trace, autocorrelation, Sobol bars and the diagnosis figures
    (api.diagnosis_plots) as SVG bytes under 'plots'."""
    from db import jobs as queue

    job = queue.get_job(store, job_id)
    if job is None:
        return None
    results = queue.results_of(store, job_id)
    diagnosis = reproduction = None
    for res in results:
        docs = res.pop("documents", {})
        diagnosis = diagnosis or docs.get("diagnosis")
        reproduction = reproduction or docs.get("reproduction")
        res["documents"] = sorted(docs)
    rep: dict[str, Any] = {"job": job, "results": results, "tables": None}
    if diagnosis is not None:
        rep["diagnosis"] = diagnosis
    if reproduction is not None:
        rep["reproduction"] = reproduction
    fits = fits_of(store, job_id) if results else []
    if fits:
        from estimator.tables import report as tables_report, sobol_table
        by_model: dict[str, list] = {}
        for f in fits:
            by_model.setdefault(f.model, []).append(f)
        def tables(html: bool) -> str:
            parts = [tables_report(group, f"{m}"
                                   + (f" ({group[0].extra['diagnosis']} model of the diagnosis)"
                                      if group[0].extra.get("diagnosis") else "")
                                   + ": estimates, 95 % intervals and RMSE", html=html)
                     for m, group in by_model.items()]
            parts += [sobol_table(f.extra["sobol"], f"Sobol indices ({f.method})", html=html)
                      for f in fits if f.extra.get("sobol")]
            return ("" if html else "\n\n").join(parts)
        rep["tables"] = tables(html=False)
        if with_plots:                                   # the page shows them as HTML tables
            rep["tables_html"] = tables(html=True)
    if with_plots and reproduction is not None:
        from api.reproduction_plots import reproduction_figures
        rep["plots"] = {"reproduction_" + k: v
                        for k, v in reproduction_figures(reproduction).items()}
        return json_clean(rep)      # the reproduction's own figures; its fits are in its tables
    if with_plots:
        from api.fit_series import predicted_vs_measured
        from estimator import plots
        figs: dict[str, bytes] = {}
        for k, f in enumerate(fits):
            sfx = f"_{k}" if len(fits) > 1 else ""
            if f.extra.get("series"):
                svg = _try_plot(lambda f=f: predicted_vs_measured(
                    f.extra["series"], f"{f.model} by {f.method}: measured and predicted"))
                if svg is not None:
                    figs["predicted_vs_measured" + sfx] = svg
            for name, fn in (("posterior", lambda f=f: plots.posterior_histograms(f)),
                             ("corner", lambda f=f: plots.corner_plot(f)),
                             ("rhat_trace", lambda f=f: plots.rhat_trace_plot([f])),
                             ("autocorr", lambda f=f: plots.autocorr_plot(f))):
                svg = _try_plot(fn) if f.draws is not None else None
                if svg is not None:
                    figs[name + sfx] = svg
            if f.extra.get("sobol"):
                figs["sobol" + sfx] = plots.sobol_bars_from_table(
                    f.extra["sobol"], title=f"{f.model} — {f.method}: Sobol indices")
        if diagnosis is not None:
            from api.diagnosis_plots import diagnosis_figures
            p = job["params"]
            ids = list(p.get("run_ids", [])) + list(p.get("test_run_ids", []))
            figs.update(diagnosis_figures(diagnosis, ids))
            if diagnosis.get("transmission"):
                figs.update(diagnosis_figures(diagnosis["transmission"], ids,
                                              prefix="diagnosis_transmission_"))
        rep["plots"] = figs
    return json_clean(rep)


# --- HTML --------------------------------------------------------------------------------------

STYLE = """body{font-family:system-ui,-apple-system,"Segoe UI","DejaVu Sans",sans-serif;
margin:2em;max-width:70em;color:#1d2330}
table{border-collapse:collapse;font-size:90%}td,th{border:1px solid #bbb;padding:2px 6px}
.pass{background:#d7f5d7}.fail{background:#f7d4d4}img{max-width:100%;display:block;margin:1em 0}
pre{background:#f6f6f6;padding:1em;overflow-x:auto}
table.paper{margin:1em 0}table.paper caption{text-align:left;font-weight:bold;padding:4px 0}
th{background:#eef0f4}"""


def _e(x: Any) -> str:
    if isinstance(x, float):
        return f"{x:.6g}"
    return html.escape("" if x is None else str(x))


def _table(rows: list[dict[str, Any]], cols: list[str], cls: Callable[[dict], str] | None = None
           ) -> str:
    head = "".join(f"<th>{_e(c)}</th>" for c in cols)
    body = "".join(
        f"<tr class=\"{cls(r) if cls else ''}\">" + "".join(f"<td>{_e(r.get(c))}</td>" for c in cols)
        + "</tr>" for r in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _flat(params: dict[str, Any], prefix: str = "") -> list[dict[str, Any]]:
    """A job's parameters as rows {parameter, value}; nested options as `options.draws`."""
    rows: list[dict[str, Any]] = []
    for k, v in params.items():
        if isinstance(v, dict) and v:
            rows += _flat(v, f"{prefix}{k}.")
        else:
            rows.append({"parameter": f"{prefix}{k}",
                         "value": ", ".join(map(str, v)) if isinstance(v, list) else v})
    return rows


def _img(name: str, svg: bytes) -> str:
    b64 = base64.b64encode(svg).decode("ascii")
    return f'<figure><img alt="{_e(name)}" src="data:image/svg+xml;base64,{b64}"></figure>'


def _page(title: str, body: str) -> str:
    return (f"<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>{_e(title)}"
            f"</title><style>{STYLE}</style></head><body><h1>{_e(title)}</h1>{body}</body></html>")


def run_report_html(rep: dict[str, Any]) -> str:
    r = rep["run"]
    summary = {k: r.get(k) for k in ("id", "rig", "scheme", "source", "status", "exit_status",
                                     "reason", "started_at", "stopped_at", "n_samples", "t_last")}
    meta = r.get("meta") or {}
    summary.update({k: meta.get(k) for k in ("motor_speed_rpm", "direction", "sample_rate_hz")})
    parts = ["<h2>Summary</h2>", _table([summary], list(summary))]
    ok = rep["acceptance_passed"]
    parts.append(f"<h2>Acceptance indicators (Table 11): "
                 f"{'PASS' if ok else 'FAIL' if ok is False else 'not judged'}</h2>")
    parts.append(_table(rep["acceptance"], ["name", "channel", "unit", "setpoint", "tolerance",
                                            "judged", "missing", "max_abs", "mean", "rms",
                                            "passed", "note"],
                        lambda i: "pass" if i["passed"] else "fail" if i["passed"] is False else ""))
    if rep["results"]:
        parts += ["<h2>Identification results using this run</h2>",
                  _table(rep["results"], ["result_id", "job_id", "model", "method", "role"])]
    if rep["interruptions"]:
        parts += ["<h2>Interruptions</h2>",
                  _table(rep["interruptions"], ["kind", "t_start", "t_end", "reason"])]
    parts.append("<h2>Plots</h2>")
    parts += [_img(n, s) for n, s in rep.get("plots", {}).items()]
    parts += ["<h2>Per-phase aggregates</h2>",
              _table(rep["aggregates"], ["channel", "phase", "count", "missing", "mean", "var",
                                         "min", "max"])]
    return _page(f"Run {r['id']} — scheme {r.get('scheme')} test report", "".join(parts))


def job_report_html(rep: dict[str, Any]) -> str:
    j = rep["job"]
    summary = {k: j.get(k) for k in ("id", "kind", "state", "progress", "attempts", "created_at",
                                     "started_at", "finished_at")}
    summary["running_s"] = j["timings"]["running_s"]
    parts = ["<h2>Job</h2>", _table([summary], list(summary)),
             "<h3>Parameters</h3>", _table(_flat(j["params"]), ["parameter", "value"])]
    if j.get("error"):
        parts.append(f"<h3>Error</h3><pre>{_e(j['error'])}</pre>")
    for res in rep["results"]:
        runs = ", ".join(f"run {x['run_id']} ({x['role']})" for x in res["runs"])
        parts.append(f"<h2>Result {res['id']}: {_e(res['model'])} by {_e(res['method'])}</h2>"
                     f"<p>Runs: {_e(runs)}</p>")
    plots = dict(rep.get("plots") or {})
    if rep.get("reproduction"):
        figs = {n[len("reproduction_"):]: plots.pop(n) for n in list(plots)
                if n.startswith("reproduction_")}
        parts.append(reproduction_section(rep["reproduction"], figs))
    if rep.get("diagnosis"):
        gap = {n: plots.pop(n) for n in list(plots) if n.startswith("diagnosis_")}
        parts.append(diagnosis_html(rep["diagnosis"], gap))
    if rep.get("tables_html"):
        parts += ["<h2>Identification tables</h2>", rep["tables_html"]]
    elif rep.get("tables"):
        parts += ["<h2>Identification tables</h2>", f"<pre>{_e(rep['tables'])}</pre>"]
    if plots:
        parts.append("<h2>Plots</h2>")
        parts += [_img(n, s) for n, s in plots.items()]
    return _page(f"Job {j['id']} — {j['kind']} report", "".join(parts))


def reproduction_section(rep: dict[str, Any], plots: dict[str, bytes]) -> str:
    """The paper reproduction (api.paper_reproduction): each table with ours, the paper's value
    and the ratio, the measured explanations, then the figures."""
    s = rep["settings"]
    parts = [f"<h2>Paper reproduction ({'quick' if s['quick'] else 'full'} mode, seed "
             f"{_e(s['seed'])}, {_e(rep['timings'].get('total'))} s)</h2>",
             _table([{"role": k, "runs": "; ".join(v)} for k, v in rep["campaign"].items()],
                    ["role", "runs"])]
    for tab in rep["tables"].values():
        rows = [{**r, "CI": (f"[{_num(r['ci'][0])}, {_num(r['ci'][1])}]" if r.get("ci") else ""),
                 "paper CI": (f"[{_num(r['paper_ci'][0])}, {_num(r['paper_ci'][1])}]"
                              if r.get("paper_ci") else "")} for r in tab["rows"]]
        cols = ["quantity", "unit", "ours", "paper", "ratio"]
        cols += [c for c in ("CI", "paper CI", "truth", "status", "note")
                 if any(r.get(c) not in (None, "") for r in rows)]
        parts += [f"<h3>{_e(tab['title'])}</h3>", _table(rows, cols)]
    parts.append("<h3>Where ours differs from the paper, and why (measured)</h3><ul>"
                 + "".join(f"<li>{_e(x)}</li>" for x in rep["explanations"]) + "</ul>")
    parts += [_img(n, v) for n, v in plots.items()]
    return "".join(parts)


def reproduction_html(rep: dict[str, Any], plots: dict[str, bytes]) -> str:
    """The reproduction as its own page (`rig reproduce`)."""
    return _page("Reproduction of the paper on the emulator", reproduction_section(rep, plots))


def _pct(x: float | None) -> str:
    return "—" if x is None else f"{100 * x:.1f} %"


def _num(x: float | None, digits: int = 4) -> str:
    return "—" if x is None else f"{x:.{digits}g}"


def diagnosis_html(d: dict[str, Any], plots: dict[str, bytes]) -> str:
    """The "Sim-to-real gap" section of a diagnosis job's report: the verdict, then per model law
    diagnosed (the output-side torque balance, and the twist–torque law when the diagnosis
    covered it under `transmission`) its held-out RMSE before/after with intervals, flagged
    regions, residual maps, candidate table, parameters moved and before/after plots of the
    flagged regions (`plots`: api.diagnosis_plots.diagnosis_figures, by name)."""
    v = d["verdict"]
    status = v["status"]
    effects = " + ".join(v.get("effects") or [])
    cls = {"explained": "pass", "partly_explained": "warn", "unexplained": "fail"}.get(status, "")
    parts = ["<section id=\"sim-to-real-gap\"><h2>Sim-to-real gap</h2>",
             f"<h3 class=\"{cls}\">Verdict: {_e(status)}"
             + (f" — {_e(effects)}" if effects else "") + "</h3>"]
    if v.get("summary"):
        parts.append(f"<p>{_e(v['summary'])}</p>")
    laws = v.get("laws") or {}
    if laws:
        rows = [{"model law": law, "status": x.get("status"),
                 "effects": " + ".join(x.get("effects") or []) or "—",
                 "held-out RMSE after": _num(x.get("rmse_test_after")),
                 "final model": x.get("model")} for law, x in laws.items()]
        parts.append(_table(rows, list(rows[0]), lambda r: {"explained": "pass",
                                                           "unexplained": "fail"}
                            .get(r["status"], "")))
    parts.append(_law_html(d, plots, "diagnosis_", laws.get(d["baseline"]["model"]), bool(laws)))
    tx = d.get("transmission")
    if tx:
        parts.append(_law_html(tx, plots, "diagnosis_transmission_", None, True))
    parts.append("</section>")
    return "".join(parts)


def _law_html(d: dict[str, Any], plots: dict[str, bytes], prefix: str,
              law_verdict: dict[str, Any] | None, heading: bool) -> str:
    """One model law's part of the sim-to-real gap section (see diagnosis_html)."""
    v, b = d["verdict"], d["baseline"]
    law = b.get("model")
    lv = law_verdict or v
    sh = d.get("shrinkage", {}).get("overall", {})
    ci = sh.get("ci95") or [None, None]
    before = sh.get("rmse_before", b.get("rmse_test"))
    rmse_ci = ([before * (1 - ci[1]), before * (1 - ci[0])]
               if before is not None and None not in ci else [None, None])
    target = b.get("target") or d.get("series") or {}
    unit = target.get("unit", "")
    metrics = {
        "status": lv.get("status"),
        "effects": " + ".join(lv.get("effects") or []) or "—",
        "nominal model": law,
        f"held-out RMSE before [{unit}]": _num(before),
        f"held-out RMSE after [{unit}]": _num(lv.get("rmse_test_after")),
        f"RMSE after, 95 % interval [{unit}]": f"{_num(rmse_ci[0])} … {_num(rmse_ci[1])}",
        "shrinkage (95 % interval)": f"{_pct(sh.get('shrinkage'))} "
                                     f"({_pct(ci[0])} … {_pct(ci[1])})",
        "shrinkage predicted from training": _pct(sh.get("predicted_from_training")),
        "structured share removed": _pct(v.get("structured_share_removed")),
    }
    cls = {"explained": "pass", "partly_explained": "warn", "unexplained": "fail"}.get(lv.get("status"), "")
    nothing = "nothing structured"
    reasons_before = ", ".join(d.get("tests", {}).get("reasons") or []) or nothing
    reasons_after = ", ".join(v.get("residual_after", {}).get("reasons") or []) or nothing
    h = "h4" if heading else "h3"
    label = target.get("label", "")
    parts = [f"<h3>Nominal model {_e(law)}: {_e(label)} [{_e(unit)}]</h3>" if heading else "",
             _table([metrics], list(metrics), lambda r: cls),
             f"<p>Residual tests ({_e(law)} on all runs): {_e(reasons_before)}. "
             f"After the chosen effects: {_e(reasons_after)}.</p>"]
    amb = v.get("ambiguity_sets") or {}
    if amb or d.get("ambiguities"):
        rows = [{"effect": k, "ambiguous with effects": ", ".join(a.get("effects") or []),
                 "soaks up nominal parameters": ", ".join(a.get("nominal_parameters") or [])}
                for k, a in amb.items()]
        rows += [{"effect": " / ".join(a), "ambiguous with effects": "(candidate pair)",
                  "soaks up nominal parameters": ""} for a in d.get("ambiguities") or []]
        parts += [f"<{h}>Ambiguity sets</{h}>",
                  _table(rows, ["effect", "ambiguous with effects",
                                "soaks up nominal parameters"])]
    reg_after = {r["where"]: r for r in d.get("shrinkage", {}).get("regions") or []}
    rows = []
    for r in d.get("regions") or []:
        a = reg_after.get(r["where"], {})
        rows.append({"where": r["where"], "family": r["family"], "share": _pct(r["share"]),
                     "samples": _pct(r.get("samples")), f"rmse [{unit}]": _num(r["rmse"]),
                     "mean ± SE": f"{_num(r['mean'])} ± {_num(r['mean_se'], 2)}",
                     "z (mean)": _num(r.get("z_mean"), 3),
                     "z (energy)": _num(r.get("z_energy"), 3),
                     "held-out rmse before → after": (f"{_num(a['rmse_before'])} → "
                                                      f"{_num(a['rmse_after'])}" if a else "—"),
                     "shrinkage (95 % interval)": (f"{_pct(a['shrinkage'])} ({_pct(a['ci95'][0])}"
                                                   f" … {_pct(a['ci95'][1])})" if a else "—")})
    parts.append(f"<{h}>Where it lies: flagged regions (largest share of the residual energy "
                 f"first)</{h}>")
    parts.append(_table(rows, list(rows[0])) if rows else "<p>No region is flagged.</p>")
    maps = [prefix + n for n in ("residual_map", "residual_vs_angle", "residual_vs_time")]
    if any(n in plots for n in maps):
        parts.append(f"<{h}>Residual maps</{h}>")
        parts += [_img(n, plots[n]) for n in maps if n in plots]
    cands = []
    for c in d.get("candidates") or []:
        if c.get("model", law) != law:
            continue
        shape = ", ".join(f"{k}={_num(x)}" for k, x in (c.get("shape") or {}).items())
        amb = c.get("ambiguous_with") or []
        ali = c.get("aliases") or []
        cands.append({"effect": c["effect"], "added to": c.get("model", law),
                      "shape": shape or "—",
                      f"rmse_test [{unit}]": _num(c["rmse_test"]),
                      "shrinkage": _pct(c["shrinkage"]),
                      "predicted": _pct(c.get("shrinkage_predicted")),
                      "gain / SE (z)": _num(c.get("z"), 3),
                      "significant": "yes" if c["significant"] else "no",
                      "ambiguity": "; ".join(filter(None, [
                          ("with effects " + ", ".join(amb)) if amb else "",
                          ("soaks up " + ", ".join(ali)) if ali else ""])) or "—"})
    parts.append(f"<{h}>Which effect: candidates (best held-out RMSE first)</{h}>")
    parts.append(_table(cands, list(cands[0]), lambda r: "pass" if r["significant"] == "yes"
                        else "") if cands else "<p>No candidate could be tried.</p>")
    if prefix + "candidates" in plots:
        parts.append(_img(prefix + "candidates", plots[prefix + "candidates"]))
    if d.get("skipped"):
        parts.append("<p>Not tried: " + "; ".join(f"{_e(k)} ({_e(w)})"
                                                 for k, w in d["skipped"].items()) + "</p>")
    moved = d.get("shrinkage", {}).get("parameters_moved") or {}
    if moved:
        rows = [{"parameter": n, "unit": m.get("unit"), "before": _num(m["before"], 6),
                 "SE before": _num(m["se_before"], 2), "after": _num(m["after"], 6),
                 "SE after": _num(m["se_after"], 2),
                 "shift [SE before]": _num(m["shift_in_se"], 3)}
                for n, m in moved.items()]
        parts += [f"<{h}>How the nominal parameters moved with the chosen effects</{h}>",
                  _table(rows, list(rows[0]))]
    regs = [n for n in plots if n.startswith(prefix + "region_")]
    if regs:
        parts.append(f"<{h}>Before and after in the flagged regions</{h}>")
        parts += [_img(n, plots[n]) for n in regs]
    return "".join(parts)


def fits_of(store: Store, job_id: int) -> list:
    """A job's results rebuilt as estimator.result.Fit objects (with their draws) for plots
    and tables."""
    import numpy as np
    from sqlalchemy import select

    from db.models import Result
    from estimator.result import Fit

    with store.ReadSession() as s:
        rows = s.execute(select(Result).where(Result.job_id == job_id)
                         .order_by(Result.id)).scalars().all()
        fits = []
        for r in rows:
            d = r.fit
            p = d["params"]
            draws = None
            if r.draws is not None and r.draws_shape:
                draws = np.frombuffer(r.draws, dtype="<f8").reshape(r.draws_shape)
            fits.append(Fit(
                model=d["model"], method=d["method"], param_names=[x["name"] for x in p],
                units=[x["unit"] for x in p], mean=np.array([x["mean"] for x in p]),
                sd=np.array([x["sd"] for x in p]), ci_low=np.array([x["ci_low"] for x in p]),
                ci_high=np.array([x["ci_high"] for x in p]), sigma=d["sigma"],
                rmse_train=d["rmse_train"], rmse_test=d["rmse_test"], draws=draws,
                diagnostics=d.get("diagnostics") or {}, timings=d.get("timings") or {},
                extra=d.get("extra") or {}))
        return fits
