"""`rig demo --quick` runs end to end on the embedded defaults, as the README promises: the
emulated schemes, the redundancy check, the runs stored in SQL with their acceptance indicators,
the identification table, and the identification jobs of the three schemes with their reports."""

import os
import re
import subprocess
import sys

from db.store import Store


def test_demo_quick_end_to_end(tmp_path):
    url = f"sqlite:///{tmp_path / 'demo.sqlite'}"
    env = dict(os.environ, RIG_DB_URL=url)
    report_dir = tmp_path / "reports"
    proc = subprocess.run([sys.executable, "-m", "commands.cli", "demo", "--quick",
                           "--report-dir", str(report_dir)], env=env,
                          capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = proc.stdout
    for marker in ("== 1.", "== 2.", "== 3.", "== 4.", "Eq. 4 on scheme 3", "== 5.", "verdict:",
                   "== 6.", "demo finished"):
        assert marker in out, out[-3000:]
    # the two loading runs pass Table 11 on the emulator's defaults
    verdicts = [line.split()[-1] for line in out.splitlines()
                if line.strip().split(" ")[0].isdigit() and line.rstrip().endswith(("PASS", "FAIL"))]
    assert verdicts == ["PASS", "PASS"], out
    with Store(url) as store:
        runs = store.list_runs()
    assert len(runs) == 3
    # section 6: one succeeded identification job per scheme, each report a page with its
    # estimates table and SVG plots, linked from the index the demo names
    pages = sorted(report_dir.glob("job-*-scheme*.html"))
    assert [p.name.split("scheme")[1] for p in pages] == ["1.html", "2.html", "3.html"], pages
    for p in pages:
        text = p.read_text(encoding="utf-8")
        assert "Identification tables" in text and "data:image/svg+xml;base64," in text, p
        assert p.name in (report_dir / "index.html").read_text(encoding="utf-8")
    assert str((report_dir / "index.html").resolve()) in out
    assert out.count(": succeeded in ") == 3, out[-3000:]
    # ... and converged: the demo prints each job's worst R-hat and least bulk ESS
    conv = re.findall(r"worst R-hat ([0-9.]+), least bulk ESS ([0-9]+)", out)
    assert len(conv) == 3, out[-3000:]
    assert all(float(r) < 1.05 and int(e) >= 100 for r, e in conv), conv
