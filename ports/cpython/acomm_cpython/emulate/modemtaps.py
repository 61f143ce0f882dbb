# Serial lines between an emulated board and an emulated modem, and what
# went over them in acomm's terms. CPython only (acomm_cpython.bench.picobuoy).
#
#   Bridge(board_tty, modem_tty, tap=None)   a null-modem cable between two
#       serial devices (pty slaves), copying bytes both ways in a thread;
#       tap(to, data) sees every chunk just before it is passed on, "device"
#       (board -> modem) or "host" (modem -> board), the names of a capture
#       file (acomm_cpython.emulate.capture).
#   SeatracLine(own)    the transport's segments in a SeaTrac beacon's
#       serial traffic: DAT_SEND commands and DAT_RECEIVE answers, their
#       elided frames, fragments and SACKs; .custody: the packet ids whose
#       completion SACK the board sent (it took custody of them).
#   Console(board, marker)   an emulated Pico's USB REPL (a PicoBoard),
#       its lines and the board's simulated time at each marked one.
#   IridiumLine()       an Iridium SBD modem's AT traffic: the MO buffer
#       (AT+SBDWB and its result), the sessions (+SBDIX) and the MT blocks
#       read (AT+SBDRB); .mo_sent: every MO message a session delivered to
#       the gateway, .mt_read: every MT message the board read, .order: both
#       as ("mo" | "mt", bytes) in the order they happened.
#
# Both readers take feed(to, data) in the order the bytes crossed the line,
# so the same reader follows a live line (Bridge's tap) and a capture
# written by `acomm emulate --log` afterwards (feed_capture). They read
# what a modem would: the modem's state (the MO buffer, a session's result)
# follows from the bytes alone, so a count made here is the modem's count.

import os
import select
import threading
import time

from acomm import frame
from acomm.drivers import seatrac_wire as sw
from acomm.errors import AcommError
from acomm.transport import segment as sg

from .pty import set_raw

DEVICE = "device"  # board -> modem
HOST = "host"  # modem -> board


class Bridge:
    def __init__(self, board_tty, modem_tty, tap=None):
        self.tap = tap
        self._fds = []
        for path in (board_tty, modem_tty):
            fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
            self._fds.append(fd)
            set_raw(fd)
        self._stop = False
        self._thread = threading.Thread(target=self._run, name="acomm-bridge", daemon=True)
        self._thread.start()

    def _write(self, fd, data):
        # False once that side hung up (its board or emulator stopped)
        while data and not self._stop:
            try:
                n = os.write(fd, data)
                data = data[n:]
            except BlockingIOError:
                select.select([], [fd], [], 0.05)
            except OSError:
                return False
        return True

    def _run(self):
        board, modem = self._fds
        while not self._stop:
            try:
                r, _, _ = select.select([board, modem], [], [], 0.1)
            except (OSError, ValueError):
                return
            for fd in r:
                try:
                    data = os.read(fd, 4096)
                except BlockingIOError:
                    continue
                except OSError:
                    return  # a side hung up
                if not data:
                    continue
                if fd == board:
                    if self.tap:
                        self.tap(DEVICE, data)
                    if not self._write(modem, data):
                        return
                else:
                    if self.tap:
                        self.tap(HOST, data)
                    if not self._write(board, data):
                        return

    def close(self):
        self._stop = True
        self._thread.join(2)
        for fd in self._fds:
            try:
                os.close(fd)
            except OSError:
                pass
        self._fds = []


class Console:
    """A PicoBoard's USB REPL read in a thread: its lines, and the simulated
    time at which each line with `marker` was seen (the runner's clock, read
    at once: 3 to 20 ms after the board printed it)."""

    def __init__(self, board, marker, timeout=60):
        import serial

        self.board = board
        self.marker = marker
        self.timeout = timeout
        self.lines = []
        self.ready_ms = []
        self._buf = b""
        self._stop = False
        self.ser = serial.Serial(board.usb, 115200, timeout=0.02)
        self._t = threading.Thread(target=self._run, daemon=True)
        self._t.start()

    def _run(self):
        while not self._stop:
            try:
                data = self.ser.read(4096)
            except Exception:  # noqa: BLE001 - the pty went away with the board
                return
            if not data:
                continue
            self._buf += data
            while b"\n" in self._buf:
                line, self._buf = self._buf.split(b"\n", 1)
                if self.marker in line:
                    try:
                        self.ready_ms.append(self.board.sim_ms())
                    except Exception:  # noqa: BLE001 - the board stopped meanwhile
                        pass
                self.lines.append(line.decode(errors="replace").rstrip("\r"))

    def wait_ready(self, count):
        """The simulated ms of the count-th marked line; waits for it (RuntimeError past the timeout)."""
        if wait_for(lambda: len(self.ready_ms) >= count, self.timeout) is None:
            raise RuntimeError("no line %r number %d from the board within %d s; its console: %r"
                               % (self.marker, count, self.timeout, self.lines[-5:]))
        return self.ready_ms[count - 1]

    def close(self):
        self._stop = True
        self._t.join(2)
        self.ser.close()


def feed_capture(reader, records):
    """Feeds a capture's records ((t, to, data), acomm_cpython.emulate.capture.read_capture) to a reader."""
    for _t, to, data in records:
        if to in (DEVICE, HOST):
            reader.feed(to, data)
    return reader


def _segment_of(f):
    # the transport segment a frame carries, or None
    if f.ftype != frame.SEGMENT:
        return None
    try:
        return sg.decode(f.seq, f.payload)
    except AcommError:
        return None


def _first_fragment(s):
    # (origin or None, final or None, pid) of a fragment 0's packet header, or None
    if s is None or s.is_sack or s.index != 0 or not s.payload:
        return None
    try:
        h = sg.decode_packet_header(s.payload)
    except AcommError:
        return None
    origin, final = (h.relay[0], h.relay[1]) if h.relay else (None, None)
    return origin, final, h.pid


class SeatracLine:
    """The board's side of a SeaTrac beacon: `own` is its beacon id."""

    def __init__(self, own):
        self.own = own
        self._buf = {DEVICE: bytearray(), HOST: bytearray()}
        self.frames = []  # (to, src, dst, Frame)
        self.custody = []  # packet ids the board acknowledged whole, in order (repeats kept)
        self.heard = []  # (origin, final, pid) of the fragments 0 the board received
        self.junk = 0

    def feed(self, to, data):
        buf = self._buf[to]
        buf.extend(data)
        while True:
            i = buf.find(b"\n")
            if i < 0:
                if len(buf) > 1024:  # no line end: noise, not a message
                    self.junk += len(buf)
                    del buf[:]
                return
            line = bytes(buf[:i]).strip()
            del buf[: i + 1]
            if line:
                self._line(to, line)

    def _line(self, to, line):
        sync = b"#" if to == DEVICE else b"$"
        j = line.find(sync)
        try:
            msg = bytes.fromhex(line[j + 1:].decode()) if j >= 0 else b""
        except ValueError:
            msg = b""
        if len(msg) < 3 or sw.crc16(msg[:-2]) != msg[-2] | (msg[-1] << 8):
            self.junk += 1
            return
        msg = msg[:-2]
        if to == DEVICE and msg[0] == 0x60 and len(msg) >= 4:  # DAT_SEND: dest, type, length, data
            self._frame(to, self.own, msg[1], msg[4:4 + msg[3]])
        elif to == HOST and msg[0] == 0x61:  # DAT_RECEIVE: ACOFIX, ack flag, length, data
            k = 1 + sw.fix_len(msg, 1, len(msg))
            if k > 0 and k + 2 <= len(msg) and msg[k + 1]:
                self._frame(to, msg[2], msg[1], msg[k + 2:k + 2 + msg[k + 1]])

    def _frame(self, to, src, dst, data):
        try:
            f = frame.decode_elided(data, src, dst)
        except AcommError:
            self.junk += 1
            return
        self.frames.append((to, src, dst, f))
        s = _segment_of(f)
        if to == DEVICE and s is not None and s.is_sack and s.complete and s.pid is not None:
            self.custody.append(s.pid)
        head = _first_fragment(s)
        if to == HOST and head is not None:
            self.heard.append(head)


class IridiumLine:
    """The board's side of an Iridium 9602/9603 (numeric or verbose results, echo on or off)."""

    def __init__(self):
        self._dev = bytearray()
        self._host = bytearray()
        self._wb_need = None  # bytes of SBDWB data still to come from the board
        self._wb_data = None  # the data written, until the modem's result
        self._block = False  # an SBDRB block is the next thing the modem sends
        self.mo = None  # the modem's MO buffer
        self.sessions = []  # (+SBDIX MO status, MO bytes the session carried or None)
        self.mo_sent = []  # MO messages delivered to the gateway, in order
        self.mt_read = []  # MT messages the board read
        self.order = []  # ("mo", bytes) and ("mt", bytes), as they happened
        self.commands = 0

    def feed(self, to, data):
        if to == DEVICE:
            self._dev.extend(data)
            self._device()
        else:
            self._host.extend(data)
            self._modem()

    def _device(self):
        buf = self._dev
        while buf:
            if self._wb_need is not None:
                if len(buf) < self._wb_need:
                    return
                n = self._wb_need - 2
                self._wb_data = bytes(buf[:n])
                del buf[: n + 2]
                self._wb_need = None
                continue
            i = buf.find(b"\r")
            if i < 0:
                return
            cmd = bytes(buf[:i]).strip().upper()
            del buf[: i + 1]
            if not cmd:
                continue
            self.commands += 1
            if cmd.startswith(b"AT+SBDWB="):
                n = cmd[9:]
                if n.isdigit():
                    self._wb_need = int(n) + 2
            elif cmd in (b"AT+SBDD0", b"AT+SBDD2"):
                self.mo = None
            elif cmd == b"AT+SBDRB":
                self._block = True

    def _modem(self):
        buf = self._host
        while buf:
            if self._block:
                while buf and buf[0] in (10, 13):
                    del buf[0]
                if not buf:
                    return
                if buf[0] <= 1:  # a length (at most 1890): the block, then its checksum
                    if len(buf) < 2:
                        return
                    n = (buf[0] << 8) | buf[1]
                    if len(buf) < n + 4:
                        return
                    self.mt_read.append(bytes(buf[2:2 + n]))
                    self.order.append(("mt", self.mt_read[-1]))
                    del buf[: n + 4]
                    self._block = False
                    continue
                # else a line (a ring alert) came first; the block follows it
            i = -1
            for j, b in enumerate(buf):
                if b in (10, 13):
                    i = j
                    break
            if i < 0:
                return
            line = bytes(buf[:i]).strip()
            del buf[: i + 1]
            if line:
                self._result(line)

    def _result(self, line):
        if line.startswith(b"+SBDIX:"):
            try:
                code = int(line[7:].split(b",")[0])
            except ValueError:
                return
            sent = self.mo if code <= 4 else None
            self.sessions.append((code, sent))
            if sent is not None:
                self.mo_sent.append(sent)
                self.order.append(("mo", sent))
        elif self._wb_data is not None and line in (b"0", b"1", b"2", b"3"):
            # the SBDWB result: 0 loads the buffer
            if line == b"0":
                self.mo = self._wb_data
            self._wb_data = None


def frame_segment(data):
    """(Frame, segment or None) of a raw frame (Iridium carries raw frames), or (None, None)."""
    try:
        f = frame.decode_raw(data)
    except AcommError:
        return None, None
    return f, _segment_of(f)


def relayed_fragments(messages):
    """[(origin, final, pid, index)] of the fragments with bytes in raw-frame messages.

    A fragment after the first belongs to the packet whose fragment 0 last
    went on its lane and generation (the same transfer)."""
    out = []
    lanes = {}
    for m in messages:
        f, s = frame_segment(m)
        if s is None or s.is_sack or not s.payload:
            continue  # not a fragment, or a bare poll
        head = _first_fragment(s)
        key = (f.src, f.dst, s.lane, s.gen)
        if head is not None:
            lanes[key] = head
        else:
            head = lanes.get(key)
        if head is not None:
            out.append(head + (s.index,))
    return out


def completions(messages):
    """The packet ids of the completion SACKs in raw-frame messages."""
    out = []
    for m in messages:
        _, s = frame_segment(m)
        if s is not None and s.is_sack and s.complete and s.pid is not None:
            out.append(s.pid)
    return out


def wait_for(pred, timeout, step=0.1):
    """pred()'s first true value within timeout seconds, else None."""
    end = time.monotonic() + timeout
    while True:
        v = pred()
        if v:
            return v
        if time.monotonic() >= end:
            return None
        time.sleep(step)
