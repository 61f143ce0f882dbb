# Pseudo-terminals in place of serial ports, for emulated modems and tests.
#
# set_raw(fd): a tty in raw mode (no echo, no line editing, no CR/LF
#   translation), as a serial port is.
#
# Pty(link): one pseudo-terminal whose slave is an emulated modem's "serial
#   port" (symlinked at `link`); the emulator host holds the master
#   (acomm_cpython.emulate.host).
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
import threading
import termios
import tty

_CHUNK = 4096
_MAX_PENDING = 1 << 16  # relay stops reading a side while this much waits
_MAX_BACKLOG = 1 << 16  # bytes a Pty holds for a reader that does not read


def set_raw(fd):
    # Raw mode: no echo, no line editing, no CR/LF translation on either side.
    tty.setraw(fd, termios.TCSANOW)
    attrs = termios.tcgetattr(fd)
    attrs[1] &= ~(termios.OPOST | termios.ONLCR | termios.OCRNL)  # oflag
    attrs[3] &= ~(termios.ECHO | termios.ECHONL | termios.ICANON | termios.ISIG | termios.IEXTEN)  # lflag
    termios.tcsetattr(fd, termios.TCSANOW, attrs)


class Pty:
    # One pseudo-terminal: the slave is the "serial port" users open (its
    # name is symlinked at `link`); we hold the master. The slave stays open
    # here too, so the master does not read EIO while nobody has the port.
    def __init__(self, link):
        self.master, self.slave = os.openpty()
        set_raw(self.slave)
        os.set_blocking(self.master, False)
        self.device = os.ttyname(self.slave)
        self.link = link
        self.backlog = bytearray()
        if link:
            if os.path.lexists(link):
                if not os.path.islink(link):
                    self.close()
                    raise FileExistsError("%s exists and is not a symlink; not replacing it" % link)
                os.unlink(link)
            os.symlink(self.device, link)

    def read(self):
        try:
            return os.read(self.master, _CHUNK)
        except BlockingIOError:
            return b""
        except OSError:
            return b""

    def write(self, data):
        self.backlog.extend(data)
        self.flush()

    def flush(self):
        if not self.backlog:
            return
        try:
            n = os.write(self.master, self.backlog)
        except (BlockingIOError, OSError):
            n = 0
        del self.backlog[:n]
        if len(self.backlog) > _MAX_BACKLOG:
            # nobody reads the port: like a UART, drop the oldest bytes
            del self.backlog[: len(self.backlog) - _MAX_BACKLOG]

    def close(self):
        if self.link and os.path.islink(self.link) and os.readlink(self.link) == self.device:
            os.unlink(self.link)
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


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
