"""`rig demo --quick` runs end to end on the embedded defaults, as the README promises: the
emulated schemes, the redundancy check, the runs stored in SQL with their acceptance indicators,
and the identification table."""

import os
import subprocess
import sys

from db.store import Store


def test_demo_quick_end_to_end(tmp_path):
    url = f"sqlite:///{tmp_path / 'demo.sqlite'}"
    env = dict(os.environ, RIG_DB_URL=url)
    proc = subprocess.run([sys.executable, "-m", "rig.cli", "demo", "--quick"], env=env,
                          capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = proc.stdout
    for marker in ("== 1.", "== 2.", "== 3.", "== 4.", "Eq. 4 on scheme 3", "demo finished"):
        assert marker in out, out[-3000:]
    # the two loading runs pass Table 11 on the emulator's defaults
    verdicts = [line.split()[-1] for line in out.splitlines()
                if line.strip().split(" ")[0].isdigit() and line.rstrip().endswith(("PASS", "FAIL"))]
    assert verdicts == ["PASS", "PASS"], out
    with Store(url) as store:
        runs = store.list_runs()
    assert len(runs) == 3
