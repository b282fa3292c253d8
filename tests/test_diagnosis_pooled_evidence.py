"""A candidate the held-out runs show only weakly (held-out z between z_held_out_agrees and z_gain)
is significant when the campaign's pooled evidence — the held-out runs and each training run
predicted by a fit on the other training runs, the candidate's shape chosen without it — reaches
z_gain (estimator.diagnosis_candidates.with_pooled_evidence). A held-out loss is never outvoted.

The toy law: y = 2·x + a·tanh(x/0.1) + unit noise, four training runs of 400 samples and two
held-out runs of 60: the held-out runs hold a tenth of the evidence (a campaign whose two
held-out runs sweep a friction rise at low speed little, as a 4 + 2 campaign's do)."""

from __future__ import annotations

import numpy as np
import pytest

from estimator.diagnosis_candidates import (_best_shape, _fit, _score, pooled_evidence,
                                            with_pooled_evidence)
from estimator.diagnosis_options import DiagnosisOptions
from estimator.diagnosis_stats import block_ids
from estimator.models import LinearModel, Term

WIDTHS = (0.05, 0.1, 0.2, 0.4)


def _model(width: float | None = None) -> LinearModel:
    terms = [Term("offset", ("c",), ("N·m",), lambda s: np.ones(s["x"].size), ("x",)),
             Term("slope", ("b",), ("N·m",), lambda s: s["x"], ("x",))]
    if width is not None:
        terms.append(Term("rise", ("a",), ("N·m",), lambda s: np.tanh(s["x"] / width), ("x",)))
    return LinearModel("toy" if width is None else f"toy+rise{width}", tuple(terms),
                       lambda s: s["y"], "y", "N·m", ("y",),
                       effects=() if width is None else ("rise",))


def _case(a: float, seed: int):
    rng = np.random.default_rng(seed)
    parts = {"x": [], "y": [], "run": []}
    for r in range(6):
        n = 400 if r < 4 else 60
        x = rng.uniform(-1.0, 1.0, n)
        parts["x"].append(x)
        parts["y"].append(2.0 * x + a * np.tanh(x / 0.1) + rng.normal(size=n))
        parts["run"].append(np.full(n, r))
    sig = {k: np.concatenate(v) for k, v in parts.items()}
    is_train = sig["run"] < 4
    tr = {k: v[is_train] for k, v in sig.items()}
    te = {k: v[~is_train] for k, v in sig.items()}
    blocks = block_ids(sig["run"], 20)
    grid = [({"width": w}, _model(w)) for w in WIDTHS]
    base = _fit(_model(), {}, tr, te)
    new = _best_shape(grid, tr, te)
    return base, new, grid, tr, blocks[is_train], blocks[~is_train]


@pytest.mark.parametrize("seed", [0, 2])
def test_a_gain_the_held_out_runs_hold_little_of_is_significant_by_the_pooled_evidence(seed):
    base, new, grid, tr, tr_b, te_b = _case(0.8, seed)
    opt = DiagnosisOptions()
    row = _score(base, new, te_b, opt)
    assert opt.z_held_out_agrees < row["z"] < opt.z_gain and not row["significant"], row
    out = with_pooled_evidence(row, base, new, grid, tr, tr_b, te_b, opt)
    assert out["significant"] and out["by_pooled"] and not out["concentrated"], out
    assert out["z_pooled"] > opt.z_gain


def test_a_held_out_loss_is_not_outvoted_by_the_training_runs():
    base, new, grid, tr, tr_b, te_b = _case(0.8, 4)
    opt = DiagnosisOptions()
    row = _score(base, new, te_b, opt)
    assert row["z"] < 0 and not row["significant"], row
    # the training runs alone show it strongly: only the held-out agreement keeps it out
    assert pooled_evidence(base, new, grid, tr, tr_b, te_b, opt)["z_pooled"] > opt.z_gain
    out = with_pooled_evidence(row, base, new, grid, tr, tr_b, te_b, opt)
    assert not out["significant"] and "z_pooled" not in out, out


@pytest.mark.parametrize("seed", range(4))
def test_no_rise_is_not_made_significant(seed):
    base, new, grid, tr, tr_b, te_b = _case(0.0, seed)
    opt = DiagnosisOptions()
    out = with_pooled_evidence(_score(base, new, te_b, opt), base, new, grid, tr, tr_b, te_b,
                               opt)
    assert not out["significant"], out


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -0.5, 3.5])
def test_the_agreement_threshold_is_refused_out_of_range(bad):
    with pytest.raises(ValueError, match="z_held_out_agrees"):
        DiagnosisOptions(z_held_out_agrees=bad)
