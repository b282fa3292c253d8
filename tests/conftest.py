"""The suite's processes run a single-threaded OpenBLAS unless the environment says otherwise:
the suite runs on two worker processes (pytest-xdist, pyproject.toml), and on two cores a
threaded BLAS call in one worker waits for a helper thread the other worker holds the core
from (docs/diagnosis.md, "The harness's workers and their BLAS threads"). Set before any test
module loads numpy; the workers inherit it from the controller."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
