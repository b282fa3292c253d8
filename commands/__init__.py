"""The programs that drive everything: the `rig` command line (`cli.py`, one `cmd_*.py` module
per command), the demonstration (`cmd_demo.py`) and the diagnosis validation harness
(`diagnosis_harness.py`). They sit above every layer and may import any package; no package
imports them (docs/architecture.md)."""
