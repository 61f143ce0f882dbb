# MAVLink connections for `acomm bridge mavlink`, named as pymavlink names
# them, opened without blocking and read when the event loop says so:
#
#   udpin:HOST:PORT      listen; answer whoever sent last (QGroundControl's
#                        own default is to listen on 14550: a bridge on its
#                        laptop uses udpout:127.0.0.1:14550 instead)
#   udpout:HOST:PORT     send there, from a socket connected to it: only
#                        that address and port can talk back
#   tcp:HOST:PORT        a client, reconnecting every second when it drops
#   tcpin:HOST:PORT      a server taking one client at a time
#   serial:DEVICE[:BAUD] or a bare /dev path (pyserial URLs too): 115200 baud
#
# Each is a MavConnection: fileno() (None while a TCP client is between
# attempts), read() -> bytes (b"" when nothing), write(bytes) (dropped, and
# counted, while there is nobody to write to), close(), and `peer` (a text
# for the user, or None). Writes never block: a peer that cannot keep up
# loses datagrams, as over a radio.

from __future__ import annotations

import errno
import socket
import time
from typing import Any, Optional, Tuple

LOOPBACK = ("127.0.0.1", "localhost", "::1")


def parse_url(url: str) -> Tuple[str, str, int]:
    """-> (kind, host or device, port or baud). ValueError for anything else."""
    if url.startswith("/") or url.startswith("serial:") or "://" in url:
        rest = url[len("serial:"):] if url.startswith("serial:") else url
        dev, baud = rest, 115200
        if "://" not in rest and rest.count(":") == 1:
            dev, b = rest.rsplit(":", 1)
            baud = int(b)
        return "serial", dev, baud
    kind, sep, rest = url.partition(":")
    if kind not in ("udpin", "udpout", "tcp", "tcpin") or not sep:
        raise ValueError("MAVLink connection %r: udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, "
                         "tcpin:HOST:PORT or serial:DEVICE[:BAUD]" % url)
    host, sep, port = rest.rpartition(":")
    if not sep or not port.isdigit():
        raise ValueError("MAVLink connection %r: no port" % url)
    # checked here, not left to bind or connect: their OverflowError is no
    # ValueError, and the CLI would end in a traceback instead of a message
    if int(port) > 65535:
        raise ValueError("MAVLink connection %r: port beyond 65535" % url)
    return kind, host or "0.0.0.0", int(port)


def open_connection(url: str) -> "MavConnection":
    kind, where, n = parse_url(url)
    if kind == "serial":
        return SerialConnection(url, where, n)
    if kind in ("udpin", "udpout"):
        return UdpConnection(url, kind, where, n)
    return TcpConnection(url, kind, where, n)


class MavConnection:
    url = ""
    peer: Optional[str] = None
    dropped = 0  # writes with nobody to take them

    def fileno(self) -> Optional[int]:
        raise NotImplementedError

    def read(self) -> bytes:
        raise NotImplementedError

    def write(self, data: bytes) -> None:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError

    def listens_beyond_loopback(self) -> bool:
        return False


class UdpConnection(MavConnection):
    def __init__(self, url: str, kind: str, host: str, port: int) -> None:
        self.url = url
        self.kind = kind
        self.host = host
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        self._to: Optional[Tuple[str, int]] = None
        if kind == "udpin":
            self.sock.bind((host, port))
        else:
            self.sock.connect((host, port))  # the kernel drops datagrams from anyone else
            self._to = (host, port)
            self.peer = "%s:%d" % (host, port)

    @property
    def port(self) -> int:
        return int(self.sock.getsockname()[1])

    def listens_beyond_loopback(self) -> bool:
        return self.kind == "udpin" and self.host not in LOOPBACK

    def fileno(self) -> Optional[int]:
        return self.sock.fileno()

    def read(self) -> bytes:
        out = b""
        while True:
            try:
                data, addr = self.sock.recvfrom(65535)
            except (BlockingIOError, InterruptedError):
                return out
            except OSError:  # ICMP port unreachable from a peer not (yet) listening
                return out
            out += data
            if self.kind == "udpin":
                self._to = addr
                self.peer = "%s:%d" % addr

    def write(self, data: bytes) -> None:
        try:
            if self.kind == "udpout":
                self.sock.send(data)
            elif self._to is not None:
                self.sock.sendto(data, self._to)
            else:
                self.dropped += 1
        except OSError:
            self.dropped += 1

    def close(self) -> None:
        self.sock.close()


class TcpConnection(MavConnection):
    RETRY_S = 1.0

    def __init__(self, url: str, kind: str, host: str, port: int) -> None:
        self.url = url
        self.kind = kind
        self.addr = (host, port)
        self.sock: Optional[socket.socket] = None
        self.server: Optional[socket.socket] = None
        self._next_try = 0.0
        if kind == "tcpin":
            self.server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self.server.bind(self.addr)
            self.server.listen(1)
            self.server.setblocking(False)
        else:
            self._connect()

    def listens_beyond_loopback(self) -> bool:
        return self.kind == "tcpin" and self.addr[0] not in LOOPBACK

    def _connect(self) -> None:
        # a non-blocking connect: the socket is readable (EOF or data) once it is settled
        self._next_try = time.monotonic() + self.RETRY_S
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setblocking(False)
        err = s.connect_ex(self.addr)
        if err not in (0, errno.EINPROGRESS):
            s.close()
            return
        self.sock = s

    def fileno(self) -> Optional[int]:
        if self.sock is None and self.kind == "tcp" and time.monotonic() >= self._next_try:
            self._connect()
        s = self.sock if self.sock is not None else self.server
        return s.fileno() if s is not None else None

    def read(self) -> bytes:
        if self.server is not None and self.sock is None:
            try:
                c, addr = self.server.accept()
            except (BlockingIOError, InterruptedError):
                return b""
            c.setblocking(False)
            self.sock = c
            self.peer = "%s:%d" % addr
            return b""
        if self.sock is None:
            return b""
        try:
            data = self.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            data = b""
        if not data:
            self._drop()
            return b""
        if self.peer is None:
            self.peer = "%s:%d" % self.addr
        return data

    def _drop(self) -> None:
        if self.sock is not None:
            self.sock.close()
        self.sock = None
        self.peer = None

    def write(self, data: bytes) -> None:
        if self.sock is None:
            self.dropped += 1
            return
        try:
            self.sock.send(data)
        except (BlockingIOError, InterruptedError):
            self.dropped += 1
        except OSError:
            self.dropped += 1
            self._drop()

    def close(self) -> None:
        self._drop()
        if self.server is not None:
            self.server.close()


class SerialConnection(MavConnection):
    def __init__(self, url: str, device: str, baud: int) -> None:
        import serial

        self.url = url
        self.port: Any = serial.serial_for_url(device, baudrate=baud, timeout=0, write_timeout=0)
        self.peer = device

    def fileno(self) -> Optional[int]:
        return int(self.port.fileno())

    def read(self) -> bytes:
        n = self.port.in_waiting
        return bytes(self.port.read(n)) if n else b""

    def write(self, data: bytes) -> None:
        import serial

        try:
            self.port.write(data)
        except serial.SerialTimeoutException:
            self.dropped += 1

    def close(self) -> None:
        self.port.close()
