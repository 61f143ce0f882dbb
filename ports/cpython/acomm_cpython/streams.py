# Byte streams for acomm.node.Node on CPython.
#
# SerialStream: a pyserial port with the duck-typed stream API the Node uses
#   (read(n) -> bytes, b"" when nothing is waiting; write(data); close()).
#   Reads never block: the port is opened with timeout=0 and read() takes at
#   most what the driver already holds. Writes block until the OS has taken
#   the bytes (a frame is at most a few hundred bytes; the OS buffer is
#   kilobytes), unless the port was opened with a write_timeout.
#
# TcpStream: a TCP client with the same API that reconnects with back-off.
#
# The pseudo-terminals that stand in for serial ports in tests and emulators
# (PtyPair, set_raw) are in acomm_cpython.emulate.pty.

import errno
import select
import socket
import time

_CHUNK = 4096


class SerialStream:
    def __init__(self, ser):
        # ser: an open serial.Serial (or anything with in_waiting, read,
        # write, close), preferably opened with timeout=0.
        self.ser = ser

    @property
    def port(self):
        return self.ser.port

    def read(self, n=-1):
        k = self.ser.in_waiting
        if not k:
            return b""
        if n is not None and 0 <= n < k:
            k = n
        return self.ser.read(k)

    def any(self):
        return self.ser.in_waiting

    def filenos(self):
        """The descriptors an event loop waits on for bytes to read; None when the port has none
        (a pyserial URL such as rfc2217://): the loop then polls it."""
        try:
            return (self.ser.fileno(),)
        except (AttributeError, OSError, ValueError):
            return None

    def write(self, data):
        return self.ser.write(data)

    def close(self):
        self.ser.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def open_serial(path, baud, **kwargs):
    # Opens a serial port for a Node link: 8N1, non-blocking reads.
    # Extra keyword arguments go to serial.Serial (e.g. write_timeout,
    # rtscts, exclusive).
    import serial

    kwargs.setdefault("timeout", 0)
    return SerialStream(serial.Serial(path, baud, **kwargs))


class TcpStream:
    # A TCP client with the stream API the Node uses, for modems reached over
    # Ethernet (EvoLogics: raw TCP, port 9200). Never blocks: the connection
    # is made in the background of read()/write() calls, and when it drops
    # it is made again after a back-off that doubles from `backoff_s[0]` up
    # to `backoff_s[1]`. Bytes written while disconnected are dropped and
    # counted: the driver above times out and repeats what matters, as it
    # would after line noise. `connects` counts the connections made, so a
    # driver's owner can tell the modem's session was renewed.
    def __init__(self, host, port, backoff_s=(0.5, 10.0), max_pending=1 << 16):
        self.host = host
        self.port = port
        self.backoff_s = backoff_s
        self.max_pending = max_pending
        self.sock = None
        self._connecting = False
        self._pending = bytearray()
        self._wait = backoff_s[0]
        self._next_try = 0.0
        self.connects = 0
        self.dropped = 0
        self._closed = False
        self._try_connect()

    @property
    def connected(self):
        return self.sock is not None and not self._connecting

    def filenos(self):
        """The socket an event loop waits on for bytes to read (none while connecting or down:
        the connection is made by read() and write() calls on the loop's timer)."""
        return (self.sock.fileno(),) if self.connected else ()

    def _try_connect(self):
        if self._closed or time.monotonic() < self._next_try:
            return
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setblocking(False)
        err = s.connect_ex((self.host, self.port))
        if err not in (0, errno.EINPROGRESS, errno.EWOULDBLOCK, errno.EALREADY):
            s.close()
            self._backoff()
            return
        self.sock = s
        self._connecting = True
        self._check_connected()

    def _check_connected(self):
        _, w, _ = select.select([], [self.sock], [], 0)
        if not w:
            return False
        err = self.sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
        if err:
            self._lost()
            return False
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._connecting = False
        self._wait = self.backoff_s[0]
        self.connects += 1
        return True

    def _backoff(self):
        self._next_try = time.monotonic() + self._wait
        self._wait = min(self._wait * 2, self.backoff_s[1])

    def _lost(self):
        if self.sock is not None:
            self.sock.close()
        self.sock = None
        self._connecting = False
        self.dropped += len(self._pending)
        self._pending = bytearray()
        self._backoff()

    def _ready(self):
        if self.sock is None:
            self._try_connect()
            if self.sock is None:
                return False
        if self._connecting and not self._check_connected():
            return False
        return True

    def read(self, n=-1):
        if not self._ready():
            return b""
        self._flush()
        if self.sock is None:
            return b""
        try:
            data = self.sock.recv(_CHUNK if n is None or n < 0 else n)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            data = b""
        if not data:
            self._lost()
        return data

    def write(self, data):
        if not self._ready():
            self.dropped += len(data)
            return len(data)
        self._pending.extend(data)
        if len(self._pending) > self.max_pending:
            k = len(self._pending) - self.max_pending
            del self._pending[:k]
            self.dropped += k
        self._flush()
        return len(data)

    def _flush(self):
        if not self._pending or self.sock is None:
            return
        try:
            n = self.sock.send(self._pending)
        except (BlockingIOError, InterruptedError):
            n = 0
        except OSError:
            self._lost()
            return
        del self._pending[:n]

    @property
    def pending(self):
        # bytes written and not yet taken by the OS
        return len(self._pending)

    def drop(self):
        # Closes the current connection as if it were lost (the peer sent
        # what cannot be ours): reconnects after the back-off.
        if self.sock is not None:
            self._lost()

    def close(self):
        self._closed = True
        if self.sock is not None:
            self.sock.close()
            self.sock = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
