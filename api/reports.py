"""Test reports per run and per job: a JSON-ready dict and an HTML page with SVG plots
(embedded as data URIs so a page is one self-contained file)."""

from __future__ import annotations

import base64
import html
import math
from typing import Any, Callable

from db.store import Store


def json_clean(x: Any) -> Any:
    """NaN/inf → None, recursively (JSON has neither)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: json_clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_clean(v) for v in x]
    return x


def _try_plot(fn: Callable[[], bytes | None]) -> bytes | None:
    try:
        return fn()
    except ValueError:          # the fit or run lacks what this figure shows
        return None


# --- runs ------------------------------------------------------------------------------------

def run_report(store: Store, run_id: int, with_plots: bool = True) -> dict[str, Any]:
    """A run's report: summary, channels, interruptions, acceptance indicators (Table 11),
    per-phase aggregates (SQL) and, with_plots, the figures as SVG bytes under 'plots'."""
    from api import queue
    from api.run_plots import RUN_PLOTS
    from rig.acceptance import acceptance

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
    tables (estimator.tables) and, with_plots, posterior histograms, corner plot, R-hat trace,
    autocorrelation and Sobol bars as SVG bytes under 'plots'."""
    from api import queue

    job = queue.get_job(store, job_id)
    if job is None:
        return None
    results = queue.results_of(store, job_id)
    rep: dict[str, Any] = {"job": job, "results": results, "tables": None}
    fits = queue.fits_of(store, job_id) if results else []
    if fits:
        from estimator.tables import report as tables_report, sobol_table
        title = f"{fits[0].model}: estimates, 95 % intervals and RMSE"
        text = tables_report(fits, title)
        for f in fits:
            if f.extra.get("sobol"):
                text += "\n\n" + sobol_table(f.extra["sobol"], f"Sobol indices ({f.method})")
        rep["tables"] = text
    if with_plots:
        from estimator import plots
        figs: dict[str, bytes] = {}
        for k, f in enumerate(fits):
            sfx = f"_{k}" if len(fits) > 1 else ""
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
        rep["plots"] = figs
    return json_clean(rep)


# --- HTML --------------------------------------------------------------------------------------

STYLE = """body{font-family:sans-serif;margin:2em;max-width:70em}
table{border-collapse:collapse;font-size:90%}td,th{border:1px solid #bbb;padding:2px 6px}
.pass{background:#d7f5d7}.fail{background:#f7d4d4}img{max-width:100%;display:block;margin:1em 0}
pre{background:#f6f6f6;padding:1em;overflow-x:auto}"""


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
             "<h3>Parameters</h3>", f"<pre>{_e(j['params'])}</pre>"]
    if j.get("error"):
        parts.append(f"<h3>Error</h3><pre>{_e(j['error'])}</pre>")
    for res in rep["results"]:
        runs = ", ".join(f"run {x['run_id']} ({x['role']})" for x in res["runs"])
        parts.append(f"<h2>Result {res['id']}: {_e(res['model'])} by {_e(res['method'])}</h2>"
                     f"<p>Runs: {_e(runs)}</p>")
    if rep.get("tables"):
        parts += ["<h2>Identification tables</h2>", f"<pre>{_e(rep['tables'])}</pre>"]
    if rep.get("plots"):
        parts.append("<h2>Plots</h2>")
        parts += [_img(n, s) for n, s in rep["plots"].items()]
    return _page(f"Job {j['id']} — {j['kind']} report", "".join(parts))
