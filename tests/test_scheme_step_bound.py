"""Scheme 2's load step is bounded below (core.schemes.MIN_LOAD_STEP), so its profile has a few
hundred breakpoints at most. Before, a schema-valid request with a tiny step (the API fuzz drew
step = 5e-324 N·m: `level + step == level`, a loop that never ends) grew the profile's lists in
the web process until the machine ran out of memory (issue 13, the open defect of
tests/test_api_schema.py). The refusals run in a child process with a 1 GB address-space cap
and a time limit, so a regression fails the test instead of exhausting the machine."""

from __future__ import annotations

import subprocess
import sys

import pytest

CHILD = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))
from core.schemes import Scheme2
try:
    Scheme2(motor_speed_rpm=300.0, pause=0.0, step=float(sys.argv[1]))
except ValueError as exc:
    print("refused:", exc)
else:
    print("accepted")
"""


@pytest.mark.parametrize("step", ["5e-324", "1e-3", "999"])
def test_a_tiny_load_step_is_refused_before_the_profile_is_built(step):
    try:
        out = subprocess.run([sys.executable, "-c", CHILD, step], capture_output=True,
                             text=True, timeout=120)
    except subprocess.TimeoutExpired:
        pytest.fail(f"Scheme2(step={step}) still building its profile after 120 s")
    assert out.returncode == 0, out.stderr[-2000:]          # a MemoryError at the cap
    assert out.stdout.startswith("refused: step:"), out.stdout


def test_the_profile_is_short_at_the_corners_of_the_parameter_box():
    from core.schemes import MIN_LOAD_STEP, RANGE_TORQUE, Scheme2

    s = Scheme2(motor_speed_rpm=1.0, step=MIN_LOAD_STEP, load_target=RANGE_TORQUE,
                limit_set="range", pause=0.0)
    times, loads, segs = s.load_profile()
    n_steps = RANGE_TORQUE / MIN_LOAD_STEP
    assert len(times) == len(loads) <= 2 * n_steps + 2 and len(segs) <= 2 * n_steps + 1
    assert n_steps <= 200


def test_the_api_schema_carries_the_step_bound():
    from api.routers.schemes import PARAMS
    from core.schemes import MIN_LOAD_STEP

    s = PARAMS[2].model_json_schema()["properties"]["step"]
    assert s["minimum"] == MIN_LOAD_STEP and "exclusiveMinimum" not in s
