"""An independent OSC 1.0 decoder (struct only, not python-osc) and a loopback UDP receiver, for the engine tests."""
from __future__ import annotations

import socket
import struct
import threading
import time


def _string(data: bytes, i: int) -> tuple[str, int]:
    end = data.index(b"\0", i)
    s = data[i:end].decode("utf-8")
    return s, i + ((end - i) // 4 + 1) * 4


def decode_message(data: bytes) -> tuple[str, list]:
    address, i = _string(data, 0)
    tags, i = _string(data, i)
    assert tags.startswith(","), tags
    args = []
    for t in tags[1:]:
        if t == "f":
            args.append(struct.unpack(">f", data[i:i + 4])[0])
            i += 4
        elif t == "i":
            args.append(struct.unpack(">i", data[i:i + 4])[0])
            i += 4
        elif t == "s":
            s, i = _string(data, i)
            args.append(s)
        else:
            raise AssertionError(f"unexpected OSC type tag {t!r}")
    assert i == len(data), "trailing bytes in an OSC message"
    return address, args


def decode_bundle(data: bytes) -> list[tuple[str, list]]:
    """An OSC bundle -> its messages in order (nested bundles flattened)."""
    assert data[:8] == b"#bundle\0", data[:8]
    i, out = 16, []                          # '#bundle\0' + 8-byte time tag
    while i < len(data):
        (n,) = struct.unpack(">i", data[i:i + 4])
        part = data[i + 4:i + 4 + n]
        out += decode_bundle(part) if part.startswith(b"#bundle") else [decode_message(part)]
        i += 4 + n
    assert i == len(data)
    return out


class Receiver:
    """A UDP socket on 127.0.0.1 (a free port) collecting (arrival time, datagram) in a thread."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.port = self.sock.getsockname()[1]
        self.packets: list[tuple[float, bytes]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    @property
    def address(self) -> str:
        return f"127.0.0.1:{self.port}"

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data = self.sock.recv(65536)
            except socket.timeout:
                continue
            except OSError:
                return
            self.packets.append((time.perf_counter(), data))

    def wait_for(self, n: int, timeout: float = 60.0) -> None:
        """Until n datagrams arrived (or the timeout: the caller's asserts say what is missing)."""
        end = time.perf_counter() + timeout
        while len(self.packets) < n and time.perf_counter() < end:
            time.sleep(0.01)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.sock.close()
