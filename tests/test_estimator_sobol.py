"""estimator.sobol: first-order and total-effect Sobol indices (paper Eqs. 18–19) by SALib,
checked against functions whose indices are known in closed form."""

import numpy as np
import pytest

from estimator.sobol import (design_chunks, eq4_torque_model, eq11_bouc_wen_torque_model,
                             evaluate_chunks, sobol_analyze, sobol_design, sobol_from_fit,
                             sobol_indices)
from core.params import JointParams
from core.terms import eq4_regressor, eq11_regressor

P = JointParams()


def ishigami(X, a=7.0, b=0.1):
    return np.sin(X[:, 0]) + a * np.sin(X[:, 1]) ** 2 + b * X[:, 2] ** 4 * np.sin(X[:, 0])


def test_ishigami_indices_match_the_closed_form():
    a, b = 7.0, 0.1
    V = a ** 2 / 8 + b * np.pi ** 4 / 5 + b ** 2 * np.pi ** 8 / 18 + 0.5
    V1 = 0.5 * (1 + b * np.pi ** 4 / 5) ** 2
    V2 = a ** 2 / 8
    V13 = b ** 2 * np.pi ** 8 * (1 / 18 - 1 / 50)
    S1 = np.array([V1 / V, V2 / V, 0.0])
    ST = np.array([(V1 + V13) / V, V2 / V, V13 / V])
    d = sobol_design(["x1", "x2", "x3"], None, None, n_base=4096, seed=3,
                     bounds=[(-np.pi, np.pi)] * 3)
    res = sobol_analyze(d, evaluate_chunks(ishigami, d, chunk_size=5000))
    t = res.table
    assert list(t.columns) == ["name", "S1", "S1_conf", "ST", "ST_conf"]
    assert list(t["name"]) == ["x1", "x2", "x3"]
    assert np.all(np.abs(t["S1"] - S1) < np.maximum(2.5 * t["S1_conf"], 0.01))
    assert np.all(np.abs(t["ST"] - ST) < np.maximum(2.5 * t["ST_conf"], 0.01))
    assert np.all(t["S1_conf"] > 0) and np.all(t["S1_conf"] < 0.05)


def eq4_signals(n=400):
    t = np.linspace(0.0, 40.0, n)
    q = 0.8 * np.sin(2 * np.pi * t / 20.0)
    qd = np.gradient(q, t)
    qdd = np.gradient(qd, t)
    return q, qd, qdd


def eq4_analytic(Y, sd, rows):
    """A linear model with independent inputs: per time S1 = ST = Y_ti²·sd_i²/Σ_j Y_tj²·sd_j²;
    the aggregated index weights each analysed time by its output variance."""
    contrib = (Y[rows] ** 2) * (sd ** 2)          # (T', p)
    return contrib.sum(axis=0) / contrib.sum()


def test_eq4_indices_over_a_posterior_match_the_linear_closed_form():
    q, qd, qdd = eq4_signals()
    mean = np.array([P.I_xx, P.mr_x, P.mr_y, P.f_v, P.f_c])
    sd = np.array([40.0, 0.8, 2.0, 10.0, 10.0])
    model = eq4_torque_model(q, qd, qdd, P.v_eps)
    res = sobol_indices(model, ["I_xx", "mr_x", "mr_y", "f_v", "f_c"], mean, sd, n_base=2048,
                        seed=1, chunk_size=3000, max_times=25, num_resamples=50)
    exact = eq4_analytic(eq4_regressor(q, qd, qdd, P.v_eps), sd, res.time_index)
    assert res.time_index.size == 25
    t = res.table
    assert np.all(np.abs(t["S1"] - exact) < 0.02), (t["S1"].to_numpy(), exact)
    assert np.all(np.abs(t["ST"] - exact) < 0.02), (t["ST"].to_numpy(), exact)
    # the per-time indices are there, one row per analysed sample
    assert res.S1_t.shape == (res.time_index.size, 5) and res.var_t.shape == res.time_index.shape
    assert res.table["ST"].sum() == pytest.approx(1.0, abs=0.05)   # no interactions


def test_chunked_evaluation_is_the_same_as_one_block():
    q, qd, qdd = eq4_signals(50)
    model = eq4_torque_model(q, qd, qdd, P.v_eps)
    d = sobol_design(["a", "b", "c", "d", "e"], np.ones(5), np.ones(5), n_base=256, seed=0)
    whole = model(d.X)
    np.testing.assert_array_equal(evaluate_chunks(model, d, chunk_size=97), whole)
    rows = sorted(r for sl, _ in design_chunks(d, 97) for r in range(*sl.indices(len(d.X))))
    assert rows == list(range(len(d.X)))
    assert d.X.shape == (256 * 7, 5)


def test_bouc_wen_model_rows_are_eq11_with_their_own_state():
    from estimator.bouc_wen_kernel import bw_state
    t = np.linspace(0, 50, 300)
    delta = 8e-3 * np.sin(2 * np.pi * t / 25)
    dd = np.gradient(delta, t)
    rows = np.array([[600.0, 400.0, P.k_u, P.k_h, 300.0, 2e5, 50.0],
                     [900.0, -100.0, 1e7, 5e6, 0.0, 1e5, -20.0]])
    out = eq11_bouc_wen_torque_model(delta, dd, P.v_eps)(rows)
    for r, row in enumerate(rows):
        x = bw_state(delta, 1.0, row[0], row[1], 1)
        np.testing.assert_allclose(out[r], eq11_regressor(delta, dd, x, P.v_eps) @ row[2:],
                                   rtol=1e-12)


def test_sobol_from_an_exact_eq4_fit():
    """End to end: an Eq. 4 fit (estimator.identify, exact posterior) → Sobol indices of the
    torque over its posterior, equal to the linear closed form for those sds."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).parent))
    from estimator_synth import eq4_run
    from estimator.identify import identify
    run = eq4_run(0, duration=60.0)
    fit = identify([run], "eq4", "exact", seed=0)
    s = run.samples
    t = s["t"].to_numpy()
    q, qd = s["q"].to_numpy(), s["qd"].to_numpy()
    qdd = np.gradient(qd, t)
    res = sobol_from_fit(fit, eq4_torque_model(q, qd, qdd, P.v_eps), n_base=2048, seed=2,
                         max_times=20, num_resamples=50)
    exact = eq4_analytic(eq4_regressor(q, qd, qdd, P.v_eps), fit.sd, res.time_index)
    assert list(res.table["name"]) == fit.param_names
    assert np.all(np.abs(res.table["S1"] - exact) < 0.03), (res.table, exact)


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError, match="positive"):
        sobol_design(["a"], [0.0], [0.0])
    d = sobol_design(["a", "b"], [0.0, 0.0], [1.0, 1.0], n_base=64)
    with pytest.raises(ValueError, match="design rows"):
        sobol_analyze(d, np.zeros(10))
    with pytest.raises(ValueError, match="does not vary"):
        sobol_analyze(d, np.zeros((d.X.shape[0], 3)))
