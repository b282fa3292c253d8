"""A loopback TCP server speaking the socketcand protocol (raw mode), so that python-can's stock
`socketcand` client — the DAQ's CANopen master, `can_logger`, or any socketcand tool — reaches
the in-process drive stand-ins across processes without SocketCAN.

Protocol (linux-can/socketcand, the subset python-can uses):
    server: `< hi >`                       on connect
    client: `< open CHANNEL >`    server: `< ok >`
    client: `< rawmode >`         server: `< ok >`
    client: `< send ID DLC B0 B1 ... >`    a frame to the bus (hex)
    server: `< frame ID SEC.USEC HEXDATA >` a frame from the bus

Every frame one client sends reaches every other client and every in-process node (as on a
CAN bus with SocketCAN's default loopback, a sender does not receive its own frame). In-process
nodes attach through `local_bus()`, a python-can bus object (canopen's Network takes it).

python-can's client reads its `< ok >` answers with one recv() and compares them exactly, so a
frame must not follow an `< ok >` in the same TCP segment: frames for a client that just
entered raw mode are held back for `grace_s` (default 50 ms) and then delivered in order.

Threads: one acceptor, one reader per client; sends happen on the caller's thread under a
per-client lock. Loopback only by default; the server never crashes on a malformed command
(it answers `< error ... >` and carries on).
"""

from __future__ import annotations

import logging
import queue
import socket
import threading
import time
from typing import Any

import can

log = logging.getLogger(__name__)


def format_frame(msg: can.Message) -> bytes:
    """A frame as socketcand sends it: `< frame 123 1700000000.000123 0102AB >`."""
    ts = msg.timestamp or time.time()
    cid = f"{msg.arbitration_id:08X}" if msg.is_extended_id else f"{msg.arbitration_id:03X}"
    return f"< frame {cid} {ts:.6f} {bytes(msg.data[:msg.dlc]).hex().upper()} >".encode("ascii")


def _clean(text: str) -> str:
    return text.replace("<", "(").replace(">", ")")


def parse_send(body: str) -> can.Message:
    """The payload of `< send ID DLC B0 ... >` (without the brackets) → can.Message.
    Raises ValueError on anything malformed."""
    parts = body.split()
    if len(parts) < 3 or parts[0] != "send":
        raise ValueError(f"not a send command: {body!r}")
    cid_s, dlc = parts[1], int(parts[2], 16)
    data = bytes(int(b, 16) for b in parts[3:])
    if not 0 <= dlc <= 8 or len(data) != dlc:
        raise ValueError(f"DLC {dlc} does not match {len(data)} data bytes")
    cid = int(cid_s, 16)
    extended = len(cid_s) > 3
    if cid > (0x1FFFFFFF if extended else 0x7FF):
        raise ValueError(f"CAN id {cid_s} out of range")
    return can.Message(arbitration_id=cid, is_extended_id=extended, data=data,
                       timestamp=time.time())


class _Client:
    def __init__(self, sock: socket.socket, addr: Any) -> None:
        self.sock = sock
        self.addr = addr
        self.lock = threading.Lock()
        self.raw = False
        self.ready_at = float("inf")
        self.pending: list[bytes] = []
        self.alive = True


class LocalBus(can.BusABC):
    """An in-process node's view of the server's bus (python-can API)."""

    def __init__(self, server: "SocketcandServer", channel: str) -> None:
        self._server = server
        self._queue: queue.SimpleQueue[can.Message] = queue.SimpleQueue()
        self.channel_info = f"socketcand-server local bus {channel}"
        super().__init__(channel=channel)

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        if msg.timestamp == 0.0:
            msg.timestamp = time.time()
        self._server.broadcast(msg, source=self)

    def _deliver(self, msg: can.Message) -> None:
        self._queue.put(msg)

    def _recv_internal(self, timeout: float | None):
        try:
            return self._queue.get(timeout=timeout), False
        except queue.Empty:
            return None, False

    def shutdown(self) -> None:
        self._server.detach(self)
        super().shutdown()


class SocketcandServer:
    """socketcand-protocol server bridging TCP clients and in-process nodes on one channel."""

    def __init__(self, host: str = "127.0.0.1", port: int = 29536, channel: str = "can0",
                 *, grace_s: float = 0.05, send_timeout: float = 1.0) -> None:
        self.host = host
        self.port = port
        self.channel = channel
        self.grace_s = grace_s
        self.send_timeout = send_timeout
        self._clients: list[_Client] = []
        self._locals: list[LocalBus] = []
        self._lock = threading.Lock()
        self._sock: socket.socket | None = None
        self._threads: list[threading.Thread] = []
        self._stop = threading.Event()
        self.frames_in = 0
        self.frames_out = 0
        self.errors = 0

    # --- life cycle ---------------------------------------------------------------------

    def start(self) -> int:
        """Listen; returns the bound port (useful with port 0)."""
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((self.host, self.port))
        s.listen(16)
        s.settimeout(0.2)
        self._sock = s
        self.port = s.getsockname()[1]
        t = threading.Thread(target=self._accept_loop, name="socketcand-accept", daemon=True)
        t.start()
        self._threads.append(t)
        return self.port

    def stop(self) -> None:
        self._stop.set()
        if self._sock is not None:
            self._sock.close()
        with self._lock:
            clients = list(self._clients)
        for c in clients:
            self._drop(c)
        for t in self._threads:
            t.join(timeout=2.0)

    def local_bus(self) -> LocalBus:
        """A python-can bus for in-process nodes on this server's channel."""
        bus = LocalBus(self, self.channel)
        with self._lock:
            self._locals.append(bus)
        return bus

    def detach(self, bus: LocalBus) -> None:
        with self._lock:
            if bus in self._locals:
                self._locals.remove(bus)

    @property
    def client_count(self) -> int:
        with self._lock:
            return sum(1 for c in self._clients if c.raw and c.alive)

    # --- frames -------------------------------------------------------------------------

    def broadcast(self, msg: can.Message, source: Any = None) -> None:
        """Deliver a frame to every client and local node except its source."""
        with self._lock:
            clients = [c for c in self._clients if c is not source and c.raw]
            locals_ = [b for b in self._locals if b is not source]
        for b in locals_:
            b._deliver(msg)
        if not clients:
            return
        line = format_frame(msg)
        now = time.monotonic()
        for c in clients:
            with c.lock:
                if not c.alive:
                    continue
                if now < c.ready_at:
                    c.pending.append(line)
                    continue
                try:
                    if c.pending:
                        c.sock.sendall(b"".join(c.pending))
                        c.pending.clear()
                    c.sock.sendall(line)
                    self.frames_out += 1
                except OSError:
                    c.alive = False
        for c in clients:
            if not c.alive:
                self._drop(c)

    # --- client handling ------------------------------------------------------------------

    def _accept_loop(self) -> None:
        while not self._stop.is_set():
            try:
                sock, addr = self._sock.accept()  # type: ignore[union-attr]
            except socket.timeout:
                continue
            except OSError:
                return
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            c = _Client(sock, addr)
            with self._lock:
                self._clients.append(c)
            t = threading.Thread(target=self._client_loop, args=(c,), daemon=True,
                                 name=f"socketcand-client-{addr[1]}")
            t.start()

    def _reply(self, c: _Client, text: str) -> None:
        with c.lock:
            c.sock.sendall(text.encode("ascii"))

    def _client_loop(self, c: _Client) -> None:
        buf = ""
        try:
            # one timeout for both directions: a client that stops reading is dropped after
            # send_timeout instead of stalling the bus; the reader just polls again
            c.sock.settimeout(self.send_timeout)
            self._reply(c, "< hi >")
            while not self._stop.is_set():
                try:
                    chunk = c.sock.recv(4096)
                except socket.timeout:
                    continue
                if not chunk:
                    break
                buf += chunk.decode("ascii", errors="replace")
                while True:
                    start = buf.find("<")
                    end = buf.find(">", start + 1) if start >= 0 else -1
                    if start < 0:
                        buf = ""
                        break
                    if end < 0:
                        buf = buf[start:]
                        if len(buf) > 256:  # no '>' in sight: garbage, drop it
                            self.errors += 1
                            buf = ""
                        break
                    self._command(c, buf[start + 1:end].strip())
                    buf = buf[end + 1:]
        except OSError:
            pass
        finally:
            self._drop(c)

    def _command(self, c: _Client, body: str) -> None:
        if body.startswith("send "):
            if not c.raw:
                self._reply(c, "< error not in raw mode >")
                return
            try:
                msg = parse_send(body)
            except ValueError as exc:
                self.errors += 1
                self._reply(c, f"< error {_clean(str(exc))} >")
                return
            self.frames_in += 1
            self.broadcast(msg, source=c)
        elif body.startswith("open "):
            name = body[5:].strip()
            if name != self.channel:
                self._reply(c, f"< error could not open bus {_clean(name)} >")
                return
            self._reply(c, "< ok >")
        elif body == "rawmode":
            self._reply(c, "< ok >")
            with c.lock:
                c.ready_at = time.monotonic() + self.grace_s
                c.raw = True
            threading.Timer(self.grace_s, self._flush, args=(c,)).start()
        elif body in ("echo",):
            self._reply(c, "< echo >")
        else:
            self.errors += 1
            self._reply(c, "< error unknown command >")

    def _flush(self, c: _Client) -> None:
        with c.lock:
            if c.alive and c.pending:
                try:
                    c.sock.sendall(b"".join(c.pending))
                    self.frames_out += len(c.pending)
                except OSError:
                    c.alive = False
                c.pending.clear()

    def _drop(self, c: _Client) -> None:
        with self._lock:
            if c in self._clients:
                self._clients.remove(c)
        with c.lock:
            c.alive = False
            try:
                c.sock.close()
            except OSError:
                pass
