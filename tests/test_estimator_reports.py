"""Identifiability report, paper-layout tables, figures and the `rig identify` command."""

import json

import numpy as np
import pytest

from estimator.identifiability import identifiability_report, report_text
from estimator.identify import identify
from estimator.tables import (autocorr_table, efficiency_table, parameter_table, rhat_table,
                              rmse_table)

from estimator_synth import eq4_run


def test_identifiability_names_what_the_data_cannot_separate():
    rng = np.random.default_rng(0)
    n = 500
    a, b = rng.standard_normal(n), rng.standard_normal(n)
    X = np.column_stack([a, b, 2 * a - b + 1e-4 * rng.standard_normal(n), rng.standard_normal(n)])
    rep = identifiability_report(X, ["k_u", "k_h", "c", "d"])
    assert not rep["identifiable"]
    w = rep["weak_directions"][0]
    assert set(w["involved"]) == {"k_u", "k_h", "c"}
    v = np.array([w["direction_physical"][k] for k in ("k_u", "k_h", "c")])
    assert np.allclose(v / v[2], [-2, 1, 1], atol=0.01)     # X·(2, −1, −1) ≈ 0
    assert rep["condition_number_scaled"] > 1000
    assert "cannot separate" in report_text(rep)
    good = identifiability_report(rng.standard_normal((n, 3)), ["x", "y", "z"])
    assert good["identifiable"] and good["condition_number_scaled"] < 2
    z = identifiability_report(np.column_stack([a, np.zeros(n)]), ["a", "nothing"])
    assert z["zero_columns"] == ["nothing"]
    with pytest.raises(ValueError, match="nothing|identically zero"):
        from estimator.identify import fit_linear
        fit_linear("m", ["a", "nothing"], ["", ""], np.column_stack([a, np.zeros(n)]), a, "exact")


@pytest.fixture(scope="module")
def fits():
    runs = [eq4_run(5, duration=30.0)]
    test = [eq4_run(6, duration=20.0, t0=4.0)]
    return [identify(runs, "eq4", m, test, seed=0, chains=2, draws=600, warmup=300)
            for m in ("ls", "mh", "sghmc")]


def test_tables_in_the_paper_layout(fits):
    t = parameter_table(fits, title="TABLE 3. Eq. 4")
    lines = t.splitlines()
    assert lines[0] == "TABLE 3. Eq. 4"
    assert "Least Square" in lines[1] and "MCMC" in lines[1] and "SGHMC" in lines[1]
    for name in ("I_xx", "mr_x", "mr_y", "f_v", "f_c", "RMSE train", "RMSE test"):
        assert name in t
    f_c = next(l for l in lines if " f_c " in f" {l} ")
    assert f"{fits[1].mean[4]:.3f}" in f_c and f"[{fits[1].ci_low[4]:.3f}," in f_c
    assert "1.0" in rhat_table(fits[1:]) and "e-" in autocorr_table(fits[1:])
    assert "SGHMC" in efficiency_table(fits[1:])
    t9 = rmse_table({"(4)": fits})
    assert f"{fits[0].rmse_train:.3f}" in t9


def test_figures(fits, tmp_path):
    from estimator import plots
    f = fits[2]
    svg = plots.posterior_histograms(f, truth=f.mean)
    assert svg.startswith(b"<?xml") and b"<svg" in svg
    png = plots.corner_plot(f, fmt="png")
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert plots.rhat_trace_plot(fits[1:], path=tmp_path / "r.svg").stat().st_size > 1000
    assert plots.autocorr_plot(f, path=tmp_path / "a.png").read_bytes()[:4] == b"\x89PNG"
    t = np.linspace(0, 1, 50)
    assert b"<svg" in plots.predicted_vs_measured(t, np.sin(t), {"ls": np.sin(t) + 0.1})
    assert b"<svg" in plots.sobol_bars(["a", "b"], [0.2, 0.7], [0.25, 0.75], [0.01, 0.02],
                                       [0.01, 0.02])
    import pandas as pd
    table = pd.DataFrame({"name": ["a", "b"], "S1": [0.2, 0.7], "S1_conf": [0.01, 0.02],
                          "ST": [0.25, 0.75], "ST_conf": [0.01, 0.02]})
    assert plots.sobol_bars_from_table(table, path=tmp_path / "s.svg").stat().st_size > 1000
    with pytest.raises(ValueError):
        plots.posterior_histograms(fits[0])  # least squares has no draws


def _cli(argv):
    import argparse
    from commands.cmd_identify import add_arguments, run
    p = argparse.ArgumentParser()
    add_arguments(p)
    return run(p.parse_args(argv))


def test_rig_identify_command(tmp_path, capsys):
    from commands.cli import COMMANDS
    from core.runfile import write_run
    assert COMMANDS["identify"][0] == "commands.cmd_identify"
    write_run(eq4_run(8, duration=20.0), tmp_path / "train")
    write_run(eq4_run(9, duration=10.0, t0=2.0), tmp_path / "test")
    train, test = str(tmp_path / "train.csv"), str(tmp_path / "test.csv")
    assert _cli([train, "--model", "eq4", "--method", "ls,exact", "--test", test]) == 0
    out = capsys.readouterr().out
    assert "Least Square" in out and "Exact NIG" in out and "I_xx" in out and "condition number" in out
    assert _cli([train, "--method", "mh", "--json", "--draws", "300", "--warmup", "200",
                 "--chains", "2", "--sobol", "--out", str(tmp_path / "res")]) == 0
    js = json.loads(capsys.readouterr().out)
    sob = js["extra"]["sobol"]
    assert sob["name"] == ["I_xx", "mr_x", "mr_y", "f_v", "f_c"]
    assert all(0 <= v <= 1.2 for v in sob["ST"]) and sum(sob["S1"]) == pytest.approx(1, abs=0.3)
    assert js["method"] == "mh" and [p["name"] for p in js["params"]][0] == "I_xx"
    assert js["diagnostics"]["rhat"] and js["rmse_train"] > 0
    for f in ("fit_mh.json", "report.txt", "predicted_vs_measured.svg", "posterior_mh.svg",
              "corner_mh.svg", "rhat_trace.svg", "autocorr_mh.svg", "sobol_mh.svg"):
        assert (tmp_path / "res" / f).stat().st_size > 100, f
    assert json.loads((tmp_path / "res" / "fit_mh.json").read_text())["method"] == "mh"
    # errors are reported, not raised
    assert _cli([train, "--model", "eq4+warp"]) == 2
    assert "unknown effect" in capsys.readouterr().err
    assert _cli([str(tmp_path / "missing.csv")]) == 2
