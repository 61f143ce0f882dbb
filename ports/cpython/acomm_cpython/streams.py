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
# PtyPair: two pseudo-terminals joined like two USB-serial adapters with a
#   null-modem cable between them. A pty on its own is not a cable: its slave
#   (/dev/pts/N) is one end and its master fd the other, and only the slave
#   behaves like a serial port. So PtyPair makes two ptys, puts both slaves in
#   raw mode, and a relay thread copies bytes master A <-> master B. Both
#   slave paths then open with pyserial like real ports. inject() puts bytes
#   (line noise) on one end's receive side. close() stops the thread and
#   closes every fd it opened.

import errno
import os
import select
import socket
import threading
import time
import termios
import tty

_CHUNK = 4096
_MAX_PENDING = 1 << 16  # relay stops reading a side while this much waits


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


def set_raw(fd):
    # Raw mode: no echo, no line editing, no CR/LF translation on either side.
    tty.setraw(fd, termios.TCSANOW)
    attrs = termios.tcgetattr(fd)
    attrs[1] &= ~(termios.OPOST | termios.ONLCR | termios.OCRNL)  # oflag
    attrs[3] &= ~(termios.ECHO | termios.ECHONL | termios.ICANON | termios.ISIG | termios.IEXTEN)  # lflag
    termios.tcsetattr(fd, termios.TCSANOW, attrs)


class PtyPair:
    # ends: 0 (path_a) and 1 (path_b). Optional `links`: two paths at which
    # symlinks to the slave devices are made (and removed on close), so a
    # configuration can name stable ports such as /tmp/acomm-buoy.
    def __init__(self, links=None):
        self._fds = []
        self._links = []
        self._thread = None
        self._lock = threading.Lock()
        self._closed = False
        try:
            m1, s1 = os.openpty()
            self._fds += [m1, s1]
            m2, s2 = os.openpty()
            self._fds += [m2, s2]
            for s in (s1, s2):
                set_raw(s)
            for m in (m1, m2):
                os.set_blocking(m, False)
            # The slaves stay open here as well: on Linux a master whose slave
            # nobody holds open reads EIO; ours keep the relay running while
            # the ports are opened, closed and reopened.
            self._masters = (m1, m2)
            self.paths = (os.ttyname(s1), os.ttyname(s2))
            self._wake_r, self._wake_w = os.pipe()
            self._fds += [self._wake_r, self._wake_w]
            os.set_blocking(self._wake_w, False)
            if links is not None:
                for path, target in zip(links, self.paths):
                    if os.path.lexists(path):
                        os.unlink(path)
                    os.symlink(target, path)
                    self._links.append(path)
                self.paths = tuple(links)
        except BaseException:
            self._closed = True
            self._release()
            raise
        # pending[i]: bytes waiting to be written to master i (so that the
        # slave of end i receives them)
        self._pending = (bytearray(), bytearray())
        self.relayed = [0, 0]  # bytes delivered to end 0 and end 1
        self._thread = threading.Thread(target=self._relay, name="acomm-pty-relay", daemon=True)
        self._thread.start()

    @property
    def path_a(self):
        return self.paths[0]

    @property
    def path_b(self):
        return self.paths[1]

    def inject(self, end, data):
        # Bytes appear on end `end`'s receive side (after what the relay
        # already holds for it), as if noise hit the line.
        if self._closed:
            raise ValueError("PtyPair is closed")
        with self._lock:
            self._pending[end].extend(data)
        self._wake()

    def _wake(self):
        try:
            os.write(self._wake_w, b"x")
        except (BlockingIOError, OSError):
            pass  # a wake-up is already pending, or we are closing

    def _relay(self):
        masters = self._masters
        pending = self._pending
        wake = self._wake_r
        while not self._closed:
            rd = [wake]
            wr = []
            with self._lock:
                for i in (0, 1):
                    # master i is read when the other side has room
                    if len(pending[1 - i]) < _MAX_PENDING:
                        rd.append(masters[i])
                    if pending[i]:
                        wr.append(masters[i])
            try:
                r, w, _ = select.select(rd, wr, [], 0.5)
            except (OSError, ValueError):
                return  # fds closed under us
            if self._closed:
                return
            if wake in r:
                try:
                    os.read(wake, 512)
                except OSError:
                    pass
            for i in (0, 1):
                m = masters[i]
                if m in r:
                    try:
                        data = os.read(m, _CHUNK)
                    except BlockingIOError:
                        data = b""
                    except OSError as e:
                        if e.errno == errno.EIO:
                            data = b""  # no slave open: nothing to read
                        else:
                            return
                    if data:
                        with self._lock:
                            pending[1 - i].extend(data)
                if m in w:
                    with self._lock:
                        buf = pending[i]
                        try:
                            n = os.write(m, buf)
                        except BlockingIOError:
                            n = 0
                        except OSError:
                            return
                        del buf[:n]
                        self.relayed[i] += n

    def close(self):
        if self._closed:
            return
        self._closed = True
        self._wake()
        if self._thread is not None:
            self._thread.join(2.0)
        self._release()

    def _release(self):
        for fd in self._fds:
            try:
                os.close(fd)
            except OSError:
                pass
        self._fds = []
        for path in self._links:
            try:
                os.unlink(path)
            except OSError:
                pass
        self._links = []

    @property
    def running(self):
        return self._thread is not None and self._thread.is_alive()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass


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
