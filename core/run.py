"""A run in memory: samples in the interchange format's columns plus its metadata.
The emulator produces it, the DAQ records it, the database stores and loads it, import/export
reads and writes it, the estimator consumes it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd


@dataclass
class RunData:
    """`samples`: one row per sample, column `t` [s] first, other columns named as in
    core.channels (unknown extra columns allowed), NaN = a missing sample (dropout).
    `meta`: the run-format metadata (scheme, motor_speed_rpm, direction, reduction, rig,
    source, sample_rate_hz, started_at, notes, ... unknown keys kept)."""

    samples: pd.DataFrame
    meta: dict[str, Any] = field(default_factory=dict)

    def channel(self, name: str) -> np.ndarray:
        """One numeric channel as a float array (NaN where missing); KeyError names the run's
        channels when it is absent."""
        if name not in self.samples.columns:
            raise KeyError(f"run has no channel {name!r}; it has {list(self.samples.columns)}")
        return self.samples[name].to_numpy(dtype=float)

    @property
    def t(self) -> np.ndarray:
        return self.channel("t")

    def __len__(self) -> int:
        return len(self.samples)
