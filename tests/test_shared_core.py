"""The shared core: the effect vocabulary matches rig.md, the channel list matches run-format.md,
and the physics terms behave as the equations say."""

import re
from pathlib import Path

import numpy as np
import pytest

from core.channels import CHANNEL_NAMES
from core.effects import EFFECT_NAMES, VOCABULARY, resolve_effects
from core.params import JointParams
from core.terms import bouc_wen_step, eq4_regressor, rigid_body_torque, transmission_torque

DOCS = Path(__file__).resolve().parents[2] / "shared" / "docs"


def _table_first_column(text: str, header: str) -> list[str]:
    lines = text.split(header, 1)[1].splitlines()
    names, started = [], False
    for line in lines:
        if line.startswith("|"):
            started = True
            m = re.match(r"\|\s*`([^`]+)`", line)
            if m:
                names.append(m.group(1))
        elif started:
            break
    return names


@pytest.mark.skipif(not DOCS.exists(), reason="../shared/docs not beside the checkout")
def test_effect_vocabulary_is_rig_md_table():
    text = (DOCS / "rig.md").read_text()
    assert list(EFFECT_NAMES) == _table_first_column(text, "## Unmodelled effects")


@pytest.mark.skipif(not DOCS.exists(), reason="../shared/docs not beside the checkout")
def test_channels_are_run_format_table():
    text = (DOCS / "run-format.md").read_text()
    table = text.split("## Samples", 1)[1].split("## Metadata", 1)[0]
    names = []
    for line in table.splitlines():
        m = re.match(r"^\|([^|]+)\|", line)
        if m and "`" in m.group(1):
            names += [c.strip(" `") for c in m.group(1).split(",")]
    assert list(CHANNEL_NAMES) == names


def test_unknown_effect_and_parameter_are_refused_by_name():
    with pytest.raises(ValueError, match="vocabulary"):
        resolve_effects({"cogging": {}})
    with pytest.raises(ValueError, match="f_s"):
        resolve_effects({"stribeck": {"fs": 1.0}})
    assert resolve_effects({"stribeck": {"f_s": 10}})["stribeck"] == {"f_s": 10.0, "v_s": 6e-3,
                                                                 "delta": 2.0}
    for e in VOCABULARY.values():
        assert e.magnitude in e.defaults()


def test_bouc_wen_saturates_and_loops():
    p = JointParams()
    x, xs = 0.0, []
    path = np.concatenate([np.linspace(0, 0.01, 3000), np.linspace(0.01, -0.01, 6000),
                           np.linspace(-0.01, 0.01, 6000)])
    for d0, d1 in zip(path[:-1], path[1:]):
        x = bouc_wen_step(d1 - d0, x, p.alpha, p.beta, p.gamma, p.n)
        xs.append(x)
    xs = np.array(xs)
    x_sat = p.alpha / (p.beta + p.gamma)
    assert xs.max() == pytest.approx(x_sat, rel=1e-3)
    assert xs.min() == pytest.approx(-x_sat, rel=1e-3)
    # hysteresis: over the closed cycle (down then up) the torque–twist loop encloses positive
    # area, and just after each reversal x differs between the two branches at the same twist
    d = path[3001:]
    T = p.k_u * d + p.k_h * xs[3000:]
    area = 0.5 * np.sum(d[:-1] * T[1:] - d[1:] * T[:-1])
    assert abs(area) > 0.5 * p.k_h * x_sat * 0.02
    i_down, i_up = 3000 + 150, 9000 + 5850   # Δ ≈ 0.0095 on the way down, on the way up
    assert abs(path[i_down + 1] - path[i_up + 1]) < 2e-5
    assert xs[i_up] - xs[i_down] > 0.5 * x_sat


def test_twist_at_rated_torque_is_about_half_a_degree():
    p = JointParams()
    x_sat = p.alpha / (p.beta + p.gamma)
    twist = (120e3 - p.k_h * x_sat) / p.k_u
    assert 0.4 < np.degrees(twist) < 0.6
    assert transmission_torque(twist, 0.0, x_sat, p.k_u, p.k_h, p.D) == pytest.approx(120e3)


def test_eq4_regressor_reproduces_rigid_body_torque():
    p = JointParams()
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-3, 3, 50), rng.uniform(-0.03, 0.03, 50), rng.uniform(-0.02, 0.02, 50)
    theta = np.array([p.I_xx, p.mr_x, p.mr_y, p.f_v, p.f_c])
    direct = rigid_body_torque(q, qd, qdd, p.I_xx, p.mr_x, p.mr_y, p.f_v, p.f_c, p.v_eps)
    np.testing.assert_allclose(eq4_regressor(q, qd, qdd, p.v_eps) @ theta, direct, rtol=1e-12)


def test_json_safe_leaves_no_nan_tuple_or_numpy_type():
    import json
    import math

    import numpy as np

    from core.jsonsafe import finite_list, json_safe
    doc = {"a": float("nan"), 1: (np.float64(2.0), np.int64(3)), "m": np.array([[1.0, np.inf]]),
           "s": np.array(["x", None], dtype=object)}
    out = json_safe(doc)
    assert out == {"a": None, "1": [2.0, 3], "m": [[1.0, None]], "s": ["x", None]}
    json.dumps(out, allow_nan=False)
    assert finite_list(np.array([1.0, math.nan])) == [1.0, None]


def test_the_effect_syntax_reads_back_what_it_writes():
    from core.effects import format_effect, parse_effect
    assert parse_effect("stribeck") == ("stribeck", {})
    assert parse_effect(" gear_ripple:A=800, order=36 ") == ("gear_ripple",
                                                             {"A": 800.0, "order": 36.0})
    for name, kv in (("torque_offset", {"c0": 500.0, "drift": -1e-3}), ("backlash", {})):
        assert parse_effect(format_effect(name, kv)) == (name, kv)
    for bad in ("stribeck:f_s", "stribeck:f_s=x", ":f_s=1"):
        with pytest.raises(ValueError):
            parse_effect(bad)
