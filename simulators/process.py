"""Start the rig stand-in (`rig emulate`) as a separate process on loopback, learn its ports
from what it prints, and always stop it: used by the demo and by the integration tests.
With `control=True` its stdin is a pipe to its control commands (simulators/standin.py):
`silence_drive(node_id)` kills one drive while the rest of the stand-in runs on."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time


class StandinProcess:
    """A running stand-in: `plc_port`, `can_port`, `lines` (its stdout so far)."""

    def __init__(self, args: list[str], startup_timeout: float = 60.0,
                 plc_port: int = 0, can_port: int = 0, control: bool = False) -> None:
        self.cmd = [sys.executable, "-m", "simulators.standin", "--plc-port", str(plc_port),
                    "--can-port", str(can_port), *(["--control-stdin"] if control else []),
                    *args]
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(self.cmd, stdout=subprocess.PIPE,
                                     stdin=subprocess.PIPE if control else None,
                                     stderr=subprocess.STDOUT, text=True, env=env)
        self.lines: list[str] = []
        self.plc_port: int | None = None
        self.can_port: int | None = None
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        want_plc = "--no-plc" not in args
        want_can = "--no-can" not in args
        deadline = time.monotonic() + startup_timeout
        while time.monotonic() < deadline:
            if (not want_plc or self.plc_port) and (not want_can or self.can_port) \
                    and any("time scale" in ln for ln in self.lines):
                return
            if self.proc.poll() is not None:
                break
            time.sleep(0.02)
        out = "\n".join(self.lines)
        self.stop()
        raise RuntimeError(f"stand-in did not start ({self.cmd}):\n{out}")

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            line = line.rstrip("\n")
            self.lines.append(line)
            m = re.search(r"PLC .* listening on [\d.]+:(\d+)", line)
            if m:
                self.plc_port = int(m.group(1))
            m = re.search(r"CAN .* listening on [\d.]+:(\d+)", line)
            if m:
                self.can_port = int(m.group(1))

    def control(self, command: str, timeout: float = 5.0) -> str:
        """Send one control command (needs control=True) and return the stand-in's answer
        (the text after `rig emulate: control: `); RuntimeError on an error answer or none
        within `timeout` [s]."""
        if self.proc.stdin is None:
            raise RuntimeError("the stand-in was started without control=True")
        n0 = len(self.lines)
        self.proc.stdin.write(command.strip() + "\n")
        self.proc.stdin.flush()
        deadline = time.monotonic() + timeout
        prefix = "rig emulate: control: "
        while time.monotonic() < deadline:
            for line in self.lines[n0:]:
                if line.startswith(prefix):
                    answer = line[len(prefix):]
                    if answer.startswith("error"):
                        raise RuntimeError(f"stand-in refused {command!r}: {answer}")
                    return answer
            if self.proc.poll() is not None:
                break
            time.sleep(0.005)
        raise RuntimeError(f"no answer from the stand-in to {command!r} within {timeout} s")

    def silence_drive(self, node_id: int) -> str:
        """Kill drive node `node_id` (off the bus, its motor without torque); the answer."""
        return self.control(f"silence-drive {int(node_id)}")

    def kill(self) -> None:
        """SIGKILL: the stand-in dies without any clean-up (a crashed PLC)."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=10)

    def stop(self, timeout: float = 10.0) -> int:
        """SIGTERM and wait (SIGKILL if it does not stop); returns the exit code."""
        if self.proc.stdin is not None:
            try:
                self.proc.stdin.close()
            except OSError:
                pass
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)
        self._reader.join(timeout=2.0)
        return self.proc.returncode

    def __enter__(self) -> "StandinProcess":
        return self

    def __exit__(self, *exc) -> None:
        self.stop()
