"""The diagnosis validation harness (simulators.validate_diagnosis): its scoring arithmetic, its
report, and the out-of-vocabulary post-processing of the torque channel."""

from __future__ import annotations

import numpy as np
import pandas as pd

from rig.run import RunData
from simulators.validate_diagnosis import (CLASSES, apply_oov, format_report, oov_torque,
                                           score)


def _cell(kind, truth, status, effects, enr=1.0, regions=(), shrink=(0.3, 0.31)):
    return {"kind": kind, "truth": list(truth), "enr": enr, "seed": 1, "status": status,
            "effects": list(effects), "top": effects[0] if effects else None,
            "regions": list(regions), "shrinkage": shrink[0], "shrinkage_predicted": shrink[1],
            "seconds": 1.0}


def test_score_counts_each_figure():
    cells = [_cell("single", [k], "explained", [k], regions=[("speed", "low speed")])
             for k in CLASSES]
    cells[0] = _cell("single", ["stribeck"], "none", [])                     # a miss
    cells.append(_cell("single", ["gear_ripple"], "explained", ["gear_ripple"], enr=0.5,
                       shrink=(0.2, 0.3)))
    cells += [_cell("none", [], "none", []), _cell("none", [], "explained", ["torque_offset"])]
    cells += [_cell("oov", ["direction_viscous"], "unexplained", ["torque_offset"], enr=2.0,
                    regions=[("power", "braking")]),
              _cell("oov", ["position_stiffness"], "explained", ["gear_ripple"], enr=2.0)]
    cells += [_cell("pair", ["stribeck", "gear_ripple"], "explained", ["gear_ripple", "stribeck"],
                    enr=2.0)]
    s = score(cells)
    assert s["top1"]["1.0"] == 5 / 6 and s["top1"]["0.5"] == 1.0
    assert s["diagonal"]["1.0"]["stribeck"] == 0.0 and s["diagonal"]["1.0"]["gear_ripple"] == 1.0
    assert s["confusion_enr_ge_1"]["stribeck"]["none"] == 1
    assert s["false_alarm"] == 0.5 and s["none_verdict"] == 0.5
    assert s["oov_unexplained"] == 0.5
    assert s["pairs_both"] == 1.0
    # overlap: the singles flagged 'speed' count only where 'speed' is the effect's family
    # (stribeck's; its cell here flagged nothing), direction_viscous's 'power' region counts
    assert s["region_overlap"] == 1 / 8
    assert s["shrinkage_within_0.05"] < 1.0
    text = format_report({"scores": s, "cells": cells, "seeds_per_cell": 1, "emps": None})
    assert "top-1 at ENR 1" in text and "NO" in text and "cells missed" in text


def test_oov_post_processing_adds_exactly_the_documented_term():
    t = np.arange(100) * 0.1
    q = 0.5 * np.sin(t)
    qd = 0.5 * np.cos(t)
    run = RunData(samples=pd.DataFrame({"t": t, "q": q, "qd": qd, "torque": np.ones(100)}),
                  meta={"notes": ""})
    out = apply_oov(run, {"direction_viscous": 100.0})
    np.testing.assert_allclose(out.samples["torque"] - 1.0, 100.0 * qd * (qd > 0))
    dq = q - q.mean()
    np.testing.assert_allclose(oov_torque(run, "position_stiffness", 2.0), 2.0 * dq * np.abs(dq))
    assert "post-processed" in out.meta["notes"]
    assert (run.samples["torque"] == 1.0).all()  # the input run is left alone
