"""Motion sent live to engines over UDP: VMC bundles (vmc.py) and Live Link Face packets (live_link.py), one of each
per frame, on a steady clock at the motion's frame rate (docs/ENGINES.md).

    stream = EngineStream(vmc=parse_address("127.0.0.1:39539"), livelink=parse_address("127.0.0.1:11111"))
    stream.play(seq)                      # a take in real time (`gesturelsm stream`); returns a PlayReport
    stream.start(); stream.push(chunk); stream.close()   # a live stream: chunks' frames on the steady clock

The sockets never block: a datagram the system cannot take at once, or an address nobody listens on, is counted
as not sent and the stream goes on. The clock never catches up in a burst: frame k is due at start + k / fps, and a
frame found more than one frame late (the machine stalled) is dropped, counted and said once per stall. A live
stream whose chunks run dry waits for the next and restarts its clock there.
"""
from __future__ import annotations

import ipaddress
import queue
import socket
import threading
import time
from dataclasses import dataclass, field
from typing import Callable

from ..errors import UserError
from ..motion.sequence import MotionSequence
from .arkit import arkit_face
from .alive import Blinker
from .live_link import live_link_packet
from .vmc import VmcMaker, vmc_bundle

VMC_PORT, LIVE_LINK_PORT = 39539, 11111


@dataclass(frozen=True)
class Address:
    host: str
    port: int
    family: int
    sockaddr: tuple

    def __str__(self) -> str:
        return f"[{self.host}]:{self.port}" if ":" in self.host else f"{self.host}:{self.port}"


def parse_address(text: str, flag: str = "--vmc") -> Address:
    """`HOST:PORT` (an IPv6 host in brackets: `[::1]:39539`) -> Address, the host resolved once, here. A bad one is a
    UserError naming the flag, in one line."""
    text = str(text).strip()
    host, sep, port = text.rpartition(":")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    if not sep or not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        example = LIVE_LINK_PORT if flag == "--livelink" else VMC_PORT
        raise UserError(f"{flag} {text!r}: give HOST:PORT, e.g. 127.0.0.1:{example} (a port from 1 to 65535)")
    try:
        ipaddress.ip_address(host)
        flags = socket.AI_NUMERICHOST
    except ValueError:
        flags = 0
    try:
        info = socket.getaddrinfo(host, int(port), type=socket.SOCK_DGRAM, flags=flags)
    except (socket.gaierror, UnicodeError) as exc:
        raise UserError(f"{flag} {text!r}: cannot resolve the host {host!r} ({exc})") from None
    family, _, _, _, sockaddr = info[0]
    return Address(host, int(port), family, sockaddr)


class UdpSender:
    """Non-blocking UDP datagrams to fixed addresses; what the system refuses at once is counted, never waited on."""

    def __init__(self) -> None:
        self._sockets: dict[int, socket.socket] = {}
        self.sent = 0
        self.failed = 0

    def send(self, data: bytes, address: Address) -> bool:
        s = self._sockets.get(address.family)
        if s is None:
            s = socket.socket(address.family, socket.SOCK_DGRAM)
            s.setblocking(False)
            self._sockets[address.family] = s
        try:
            s.sendto(data, address.sockaddr)
        except OSError:                       # BlockingIOError, unreachable, refused: drop this datagram
            self.failed += 1
            return False
        self.sent += 1
        return True

    def close(self) -> None:
        for s in self._sockets.values():
            s.close()
        self._sockets.clear()


@dataclass
class PlayReport:
    frames: int = 0              # frames due
    sent: int = 0                # frames sent
    dropped: int = 0             # frames dropped as late (stalls)
    stalls: list[float] = field(default_factory=list)   # seconds into the stream where a stall dropped frames
    failed: int = 0              # datagrams the system refused (no route, buffer full)
    seconds: float = 0.0


class EngineStream:
    """VMC and / or Live Link Face to fixed addresses (module docstring). `say`: where the one-line notes go."""

    def __init__(self, vmc: Address | None = None, livelink: Address | None = None, perfect_sync: bool = False,
                 body=None, fps: int = 30, say: Callable[[str], None] = print, seed: int = 0) -> None:
        if vmc is None and livelink is None:
            raise UserError("nothing to stream to: give --vmc HOST:PORT and / or --livelink HOST:PORT")
        self.vmc, self.livelink, self.fps, self.say = vmc, livelink, int(fps), say
        self.maker = VmcMaker(body, perfect_sync, seed) if vmc is not None else None
        self.body = self.maker.body if self.maker is not None else body
        self.face_blinker = Blinker(self.fps, seed)
        self.udp = UdpSender()
        self.report = PlayReport()
        self._frame_number = 0
        self._queue: queue.Queue = queue.Queue()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    # -- making the datagrams -------------------------------------------------------------------------------
    def prepare(self, seq: MotionSequence) -> list[Callable[[float], list[tuple[bytes, Address]]]]:
        """Per frame of `seq`, a function of the stream's clock (seconds) giving its datagrams."""
        vmc = self.maker.frames(seq) if self.maker is not None else None
        face = arkit_face(seq, self.body, blinker=self.face_blinker) if self.livelink is not None else None

        def frame(t: int) -> Callable[[float], list[tuple[bytes, Address]]]:
            def datagrams(seconds: float) -> list[tuple[bytes, Address]]:
                out = []
                if vmc is not None:
                    out.append((vmc_bundle(vmc, t, seconds), self.vmc))
                if face is not None:
                    out.append((live_link_packet(face, t, self._frame_number), self.livelink))
                return out
            return datagrams
        return [frame(t) for t in range(seq.num_frames)]

    def _send(self, datagrams, seconds: float) -> None:
        for data, address in datagrams(seconds):
            if not self.udp.send(data, address):
                self.report.failed += 1
        self._frame_number += 1
        self.report.sent += 1

    # -- a take in real time ----------------------------------------------------------------------------------
    def play(self, seq: MotionSequence, loop: bool = False, started: Callable[[], None] | None = None,
             clock: Callable[[], float] = time.perf_counter) -> PlayReport:
        """Send `seq` at its frame rate (again and again with `loop`, until interrupted); `started` is called as
        the first frame leaves (speech playback starts there)."""
        frames = self.prepare(seq)
        step = 1.0 / max(int(seq.fps), 1)
        t0 = clock()
        k = 0
        stall_at = None
        if started is not None:
            started()
        while frames:
            for datagrams in frames:
                due = t0 + k * step
                now = clock()
                self.report.frames += 1
                if now > due + step:                   # more than a frame late: drop, never catch up in a burst
                    self.report.dropped += 1
                    if stall_at is None:
                        stall_at = due - t0
                    k += 1
                    continue
                if stall_at is not None:
                    self._stalled(stall_at, now - t0)
                    stall_at = None
                if due > now:
                    time.sleep(due - now)
                self._send(datagrams, due - t0)
                k += 1
            if not loop:
                break
        if stall_at is not None:
            self._stalled(stall_at, clock() - t0)
        self.report.seconds = clock() - t0
        return self.report

    def _stalled(self, since: float, until: float) -> None:
        self.report.stalls.append(since)
        self.say(f"stalled at {since:.2f} s: dropped the frames due until {until:.2f} s (no catch-up burst); "
                 f"{self.report.dropped} dropped so far")

    # -- a live stream ----------------------------------------------------------------------------------------
    def start(self) -> "EngineStream":
        """Start the sending thread; `push` chunks to it, `close` when done."""
        self._thread = threading.Thread(target=self._run, name="engine-stream", daemon=True)
        self._thread.start()
        return self

    def push(self, seq: MotionSequence) -> None:
        """Queue a committed chunk's frames (made here, in the caller's thread; sent on the steady clock)."""
        if seq.num_frames:
            for datagrams in self.prepare(seq):
                self._queue.put(datagrams)

    def _run(self) -> None:
        step = 1.0 / self.fps
        base, k = None, 0
        while not self._stop.is_set():
            try:
                datagrams = self._queue.get_nowait()
            except queue.Empty:
                base = None                                  # ran dry: the clock restarts with the next frame
                try:
                    datagrams = self._queue.get(timeout=0.1)
                except queue.Empty:
                    continue
            if datagrams is None:
                break
            now = time.perf_counter()
            if base is None:
                base, k = now, 0
            due = base + k * step
            k += 1
            self.report.frames += 1
            if now > due + step:
                self.report.dropped += 1
                continue
            if due > now:
                time.sleep(due - now)
            self._send(datagrams, due - base)

    def close(self, drain: bool = True) -> PlayReport:
        """Stop the live thread (after the queued frames when `drain`) and the sockets."""
        if self._thread is not None:
            if not drain:
                self._stop.set()
            self._queue.put(None)
            self._thread.join()
            self._thread = None
        self.udp.close()
        return self.report
