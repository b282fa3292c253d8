"""Sample alignment: which PLC status snapshots become a run's samples, and the drives' fast
samples joined to them on the rig's clock.

The plan's grid is in RIG time (the PLC's `rig_time`): the first snapshot of each grid slot is
the slot's sample, a slot without one is counted as missed and never filled. Each drive's
TPDO samples carry the drive's sample stamp (0x2011, ms, wrapping at 2^16); the stamp is turned
into rig time by one offset per drive, estimated from the receive times the first time the
drive is seen, and snapped to a multiple of the wrap when the drives count the PLC's rig time
(true of the stand-in). A sample waits up to `drive_wait` s of wall time for the drives'
samples at or after its rig time; the drive value joined is the latest at or before it, or
missing (NaN) when that is older than two TPDO periods.

The acquisition engine (daq/engine.py) owns one SampleAligner per run.
"""

from __future__ import annotations

import bisect
import math
import time

from core.drive_od import STAMP_WRAP
from daq.drives import Drive
from daq.plans import Plan
from daq.rig import Rig
from daq.run_record import PLC_CHANNELS

DRIVE_WRAP_MS = STAMP_WRAP
"""The drives' sample stamp (0x2011) wraps at 2^16 ms."""


class SampleAligner:
    """Chooses a run's samples among `rig`'s PLC snapshots on `plan`'s grid and joins the
    drives' samples to them (see the module doc).

    `time_scale`: rig seconds per wall second; `drive_wait` [s of wall time]: how long a
    sample waits for the drives' TPDOs; `shared_drive_clock`: the drives' stamps count the
    PLC's rig time modulo 2^16 ms, otherwise they are aligned by receive time.
    """

    def __init__(self, rig: Rig, plan: Plan, time_scale: float, *, drive_wait: float = 0.2,
                 shared_drive_clock: bool = True) -> None:
        self.rig = rig
        self.plan = plan
        self.time_scale = time_scale
        self.drive_wait = drive_wait
        self.shared_drive_clock = shared_drive_clock
        self.t0: float | None = None          # rig_time at plan time 0 [s]
        self.missed = 0
        """Grid slots that had no PLC snapshot."""
        self.done = False
        """True once the last slot of the grid is decided."""
        self.drive_offset: dict[int, float] = {}
        """Per motor: drive stamp → rig time offset [ms]."""
        self.drive_clock_mode: str | None = None
        self._i_plc = 0                       # next PLC row to look at
        self._next_slot = 0
        self._pending: list[int] = []         # PLC rows chosen as samples, waiting for drives

    def start_now(self) -> None:
        """Plan time 0 is the first PLC snapshot received from now on."""
        self._i_plc = len(self.rig.plc)

    def now(self) -> float | None:
        """Plan time now [s], from the latest snapshot extrapolated by the time scale."""
        plc = self.rig.plc
        if self.t0 is None or len(plc) == 0:
            return None
        i = len(plc) - 1
        return plc["rig_time"][i] - self.t0 + (time.time() - plc["t_rx"][i]) * self.time_scale

    def run_time(self, wall: float) -> float | None:
        """Plan time [s] of a wall-clock instant, through the PLC snapshots' receive times."""
        plc = self.rig.plc
        if self.t0 is None or not len(plc):
            return None
        rx = plc["t_rx"]
        j = max(0, bisect.bisect_right(rx, wall) - 1)
        return plc["rig_time"][j] - self.t0 + (wall - rx[j]) * self.time_scale

    def collect(self, final: bool = False) -> dict[str, list] | None:
        """Choose new PLC snapshots as samples (the first of each grid slot) and return the
        columns of those whose drive samples are in (or waited for long enough; all of them
        when final), or None when none is ready."""
        plan = self.plan
        plc = self.rig.plc
        n = len(plc)
        rt = plc["rig_time"]
        n_slots = plan.n_samples()
        while self._i_plc < n and not self.done:
            i = self._i_plc
            self._i_plc += 1
            if self.t0 is None:
                self.t0 = rt[i]
            k = plan.slot(rt[i] - self.t0)
            if k >= n_slots:
                self.missed += n_slots - self._next_slot
                self._next_slot = n_slots
                self.done = True
                break
            if k >= self._next_slot:
                self.missed += k - self._next_slot
                self._next_slot = k + 1
                self._pending.append(i)
                if self._next_slot == n_slots:
                    self.done = True
        ready = []
        while self._pending:
            i = self._pending[0]
            if not (final or self._drives_in(rt[i], plc["t_rx"][i])):
                break
            ready.append(self._pending.pop(0))
        return self._columns(ready) if ready else None

    def _drives_in(self, rig_time: float, t_rx: float) -> bool:
        """True when every active drive has a sample at or after `rig_time`, or the sample
        has waited `drive_wait` s."""
        d = self.rig.drives
        if d is None or time.time() - t_rx > self.drive_wait:
            return True
        for dr in d.active:
            st = dr.stream
            if not len(st):
                return False
            off = self._offset(dr)
            if off is None or st.stamp[-1] + off < rig_time * 1000.0:
                return False
        return True

    def _offset(self, dr: Drive) -> float | None:
        """Drive stamp → rig time [ms] offset of one drive (estimated once)."""
        if dr.motor in self.drive_offset:
            return self.drive_offset[dr.motor]
        plc, st = self.rig.plc, dr.stream
        if not len(st) or not len(plc):
            return None
        i = len(plc) - 1
        est = plc["rig_time"][i] * 1000.0 + (st.t[-1] - plc["t_rx"][i]) * self.time_scale * 1000.0 \
            - st.stamp[-1]
        mode = "receive time"
        if self.shared_drive_clock:
            snapped = round(est / DRIVE_WRAP_MS) * DRIVE_WRAP_MS
            if abs(est - snapped) < 1000.0:
                est, mode = float(snapped), "shared with the PLC (stamp modulo 2^16 ms)"
        self.drive_offset[dr.motor] = est
        self.drive_clock_mode = mode
        return est

    def _drive_value(self, dr: Drive, rig_ms: float) -> tuple[float, float]:
        """(speed, current) of the drive's latest sample at or before rig_ms; NaN when that
        sample is older than two TPDO periods (lost, dropped) or there is none."""
        st = dr.stream
        off = self._offset(dr)
        if off is None:
            return math.nan, math.nan
        j = bisect.bisect_right(st.stamp, rig_ms - off) - 1
        if j < 0 or rig_ms - off - st.stamp[j] > 2 * st.period_ms + 1:
            return math.nan, math.nan
        return st.w[j], st.i[j]

    def _columns(self, rows: list[int]) -> dict[str, list]:
        """The samples of PLC rows `rows`: plan time, the PLC channels, each drive's speed,
        current and temperature, and the plan's phase and set points at that time."""
        plan = self.plan
        plc = self.rig.plc
        cols: dict[str, list] = {"t": []}
        for sig, ch in PLC_CHANNELS:
            cols[ch] = []
        drives = self.rig.drives.drives if self.rig.drives is not None else []
        for d in drives:
            for c in (f"w_m{d.motor}", f"i_m{d.motor}", f"temp_m{d.motor}"):
                cols[c] = []
        cols["phase"], cols["w_cmd"] = [], []
        if plan.position_control:
            cols["q_ref"] = []
        for i in rows:
            rig_time = plc["rig_time"][i]
            tau = rig_time - self.t0
            cols["t"].append(tau)
            for sig, ch in PLC_CHANNELS:
                cols[ch].append(plc[sig][i])
            for d in drives:
                w, cur = self._drive_value(d, rig_time * 1000.0)
                cols[f"w_m{d.motor}"].append(w)
                cols[f"i_m{d.motor}"].append(cur)
                cols[f"temp_m{d.motor}"].append(d.temperature)
            sp = plan.setpoints(tau, plc["q"][i])
            cols["phase"].append(sp.phase)
            cols["w_cmd"].append(sp.motor_speed)
            if plan.position_control:
                cols["q_ref"].append(sp.q_ref)
        return cols
