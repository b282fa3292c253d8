"""Progress of long commands on stderr (stdout stays for results and `--json`).

On a terminal: a tqdm bar with count, rate and time left, redrawn in place and sized to the
terminal's width at every redraw (`dynamic_ncols`), so a narrow or resized window never makes
it wrap. Not a terminal (a log file, a pipe, the service's job log): plain lines, at most one
every PLAIN_INTERVAL_S and a last one when done — only for work that lasted that long, so a
short command leaves its log alone.

    with progress(total=len(files), desc="import", unit="file") as bar:
        for f in files:
            ...
            bar.update(1)

The samplers' chains (estimator.sampler_progress's callback) are drawn by ChainBars, one bar per
chain:

    with ChainBars("mh") as bars, reporting(bars):
        fit = identify(...)

The diagnosis's stages (estimator.diagnosis_progress's callback) are drawn by StageBar, one bar
whose description follows the stage:

    with StageBar() as bar, diagnosis_progress.reporting(bar):
        rep = diagnose(...)
"""

from __future__ import annotations

import sys
import threading
import time
from typing import IO, Any

PLAIN_INTERVAL_S = 5.0
"""Least time between two plain progress lines when stderr is not a terminal [s]."""


def _fmt_s(seconds: float) -> str:
    seconds = max(0.0, seconds)
    m, s = divmod(int(round(seconds)), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m:02d}:{s:02d}"


class PlainProgress:
    """Throttled plain lines: `desc: n/total (pct) rate unit/s, elapsed, left`."""

    def __init__(self, total: int | None, desc: str, unit: str, stream: IO[str],
                 interval_s: float = PLAIN_INTERVAL_S, clock=time.monotonic) -> None:
        self.total, self.desc, self.unit, self.stream = total, desc, unit, stream
        self.interval_s = interval_s
        self.clock = clock
        self.n = 0
        self.t0 = clock()
        self.last = self.t0
        self.printed = False

    def line(self) -> str:
        el = self.clock() - self.t0
        rate = self.n / el if el > 0 else 0.0
        if self.total:
            left = (self.total - self.n) / rate if rate > 0 else float("nan")
            head = f"{self.n}/{self.total} ({100.0 * self.n / self.total:.0f}%)"
            tail = f", left {_fmt_s(left)}" if left == left else ""
        else:
            head, tail = f"{self.n}", ""
        return f"{self.desc}: {head} {rate:.3g} {self.unit}/s, elapsed {_fmt_s(el)}{tail}"

    def update(self, n: int = 1) -> None:
        self.n += n
        now = self.clock()
        if now - self.last >= self.interval_s:
            self.last = now
            self.printed = True
            print(self.line(), file=self.stream, flush=True)

    def set_postfix_str(self, text: str) -> None:  # tqdm's API; nothing to show between lines
        pass

    def close(self) -> None:
        if self.printed or self.clock() - self.t0 >= self.interval_s:
            print(self.line() + " done", file=self.stream, flush=True)

    def __enter__(self) -> "PlainProgress":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def progress(total: int | None, desc: str, unit: str = "it", stream: IO[str] | None = None,
             disable: bool = False) -> Any:
    """A progress object with `update(n)`, `set_postfix_str(text)`, `close()` (and a context
    manager): a tqdm bar on a terminal, PlainProgress otherwise; `disable` shows nothing."""
    stream = stream if stream is not None else sys.stderr
    isatty = getattr(stream, "isatty", lambda: False)
    if disable:
        return PlainProgress(total, desc, unit, stream, interval_s=float("inf"))
    if isatty():
        from tqdm import tqdm
        return tqdm(total=total, desc=desc, unit=unit, file=stream, dynamic_ncols=True,
                    mininterval=0.2, leave=True)
    return PlainProgress(total, desc, unit, stream)


class Counter:
    """A `progress(done, total)` callback (the harnesses' hook) drawing one bar."""

    def __init__(self, desc: str, unit: str = "cell", stream: IO[str] | None = None) -> None:
        self.desc, self.unit, self.stream = desc, unit, stream
        self.bar: Any = None
        self.done = 0

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            self.bar = progress(total, self.desc, self.unit, self.stream)
        self.bar.update(done - self.done)
        self.done = done
        if done >= total:
            self.close()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


PHASE_NAMES = {"warmup": "warm-up", "sampling": "sampling"}
"""The samplers' phases (estimator.sampler_progress) as the bars name them."""


class ChainBars:
    """The estimator.sampler_progress callback of a command: one bar per chain, each with its
    count over warm-up and sampling together, its rate and time left, and the phase it is in
    (`mh chain 1 warm-up`). On a terminal, tqdm bars stacked one per line (position = chain),
    each sized to the terminal's width; otherwise throttled plain lines per chain
    (PlainProgress, `interval_s` apart). Thread-safe: HMC's chains report from their threads.
    `close()` (or the `with` block's end) finishes every bar in chain order.

    Several fits in a row (`rig reproduce`): a chain that starts again (a count below its last
    one) finishes the bars of the fit before and starts a new set; with `numbered` the fits are
    told apart in the bars' names (`fit 2 chain 1 warm-up`)."""

    def __init__(self, label: str, stream: IO[str] | None = None,
                 interval_s: float = PLAIN_INTERVAL_S, numbered: bool = False) -> None:
        self.label = label
        self.numbered = numbered
        self.fit = 1
        self.stream = stream if stream is not None else sys.stderr
        self.interval_s = interval_s
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.bars: dict[int, Any] = {}
        self.done: dict[int, int] = {}
        self.phase: dict[int, str] = {}
        self.lock = threading.Lock()

    def desc(self, chain: int, phase: str) -> str:
        label = f"{self.label} {self.fit}" if self.numbered else self.label
        return f"{label} chain {chain + 1} {PHASE_NAMES.get(phase, phase)}"

    def _bar(self, chain: int, total: int, phase: str) -> Any:
        desc = self.desc(chain, phase)
        if self.tty:
            from tqdm import tqdm
            return tqdm(total=total, desc=desc, unit="it", file=self.stream,
                        dynamic_ncols=True, mininterval=0.2, leave=True, position=chain)
        return PlainProgress(total, desc, "it", self.stream, interval_s=self.interval_s)

    def __call__(self, chain: int, done: int, total: int, phase: str) -> None:
        with self.lock:
            if chain in self.bars and done < self.done[chain]:    # the next fit's chains
                self._close_all()
                self.fit += 1
            bar = self.bars.get(chain)
            if bar is None:
                bar = self.bars[chain] = self._bar(chain, total, phase)
                self.done[chain], self.phase[chain] = 0, phase
            if phase != self.phase[chain]:
                self.phase[chain] = phase
                if self.tty:
                    bar.set_description_str(self.desc(chain, phase), refresh=False)
                else:
                    bar.desc = self.desc(chain, phase)
            if done > self.done[chain]:
                bar.update(done - self.done[chain])
                self.done[chain] = done

    def _close_all(self) -> None:
        for chain in sorted(self.bars):
            self.bars[chain].close()
        self.bars.clear()
        self.done.clear()
        self.phase.clear()

    def close(self) -> None:
        with self.lock:
            self._close_all()

    def __enter__(self) -> "ChainBars":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class StageBar:
    """The estimator.diagnosis_progress callback of a command: one bar whose description follows
    the diagnosis's stage (`output law: candidates 4/9`, `output law: greedy round 2`, ...), its
    count and total the stage's. On a terminal, one tqdm bar reset at every new stage and sized
    to the terminal's width at every redraw (it never wraps); otherwise throttled plain lines
    (`diagnosis: output law: candidates 4/9, elapsed 00:12`), at most one every `interval_s`
    and a last one when done — only for a diagnosis that lasted that long. `close()` (or the
    `with` block's end) finishes the bar."""

    def __init__(self, label: str = "diagnosis", stream: IO[str] | None = None,
                 interval_s: float = PLAIN_INTERVAL_S, clock=time.monotonic) -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.interval_s = interval_s
        self.clock = clock
        self.bar: Any = None
        self.stage: str | None = None
        self.done = 0
        self.total = 0
        self.t0 = clock()
        self.last = self.t0
        self.printed = False

    def line(self) -> str:
        """The plain line of the current stage."""
        return (f"{self.label}: {self.stage} {self.done}/{self.total}, "
                f"elapsed {_fmt_s(self.clock() - self.t0)}")

    def __call__(self, stage: str, done: int, total: int) -> None:
        new = stage != self.stage
        self.stage, self.total = stage, total
        if self.tty:
            if self.bar is None:
                from tqdm import tqdm
                self.bar = tqdm(total=total, desc=stage, unit="fit", file=self.stream,
                                dynamic_ncols=True, mininterval=0.2, leave=True)
            elif new:
                self.bar.set_description_str(stage, refresh=False)
                self.bar.reset(total=total)
            if done > self.bar.n:
                self.bar.update(done - self.bar.n)
            self.done = done
            return
        self.done = done
        now = self.clock()
        if now - self.last >= self.interval_s:
            self.last = now
            self.printed = True
            print(self.line(), file=self.stream, flush=True)

    def close(self) -> None:
        if self.tty:
            if self.bar is not None:
                self.bar.close()
                self.bar = None
        elif self.stage is not None and (self.printed
                                         or self.clock() - self.t0 >= self.interval_s):
            print(self.line() + " done", file=self.stream, flush=True)
            self.printed = False
        self.stage = None

    def __enter__(self) -> "StageBar":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
