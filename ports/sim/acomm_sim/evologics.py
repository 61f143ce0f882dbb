# An emulated EvoLogics S2C modem that speaks the AT command interface, so
# acomm's driver, someone else's software or a terminal program can drive it
# as they would a modem on a serial line or its TCP port. Sans-IO like the
# drivers: feed(now, bytes), poll(now), take_output(); nothing here knows the
# transport. Modems exchange packets through a shared medium
# (acomm_sim.medium); the acoustic side lives in evologics_xcvr.
#
# mode="NET" (default): plain command lines in, plain replies and
# notifications out, no echo. mode="AT": the modem starts in data mode,
# where raw bytes are sent as burst data to the remote address (AT!AR) and
# received burst data comes out raw; commands are escaped as "+++AT...",
# and their replies and all notifications come back in the envelope
# "+++AT<name>:<len>:<body>\r\n" (<name> empty for notifications). ATC
# switches to plain command mode, ATO back to data mode.
#
# Commands: AT@CTRL, AT?MODE, AT?AL/AT!AL, AT?AM/AT!AM, AT?CA/AT!CA,
# AT@ZX0/1, AT!RP0/1, AT?RP, AT!AR, AT?T, AT!L, AT&W, ATI0/ATI1, ATZ0..4,
# ATO, ATC, AT*SENDIM, AT*SENDIMS, AT*SENDPBM, AT*SEND. Anything else gets
# "ERROR WRONG FORMAT". The error and busy texts are this emulator's choice
# (docs/drivers-evologics.md).
#
# Fault modes, for driver tests: noise bytes, a damaged (garbled) or
# truncated output line, a command never answered, and a reboot at any
# moment with its power-up text.

from acomm.compat import ticks_diff
from acomm.drivers import evologics_wire as w
from acomm.drivers.base import SansIO

from .faults import FaultModes, hit
from .evologics_xcvr import P_BURST, P_IM, P_IMS, P_PBM, Transceiver

BANNER = (b"EvoLogics S2C modem (acomm emulator)", b"firmware 1.7 started")

_SENDS = {b"*SENDIM": P_IM, b"*SENDIMS": P_IMS, b"*SENDPBM": P_PBM, b"*SEND": P_BURST}
_FORMAT = b"ERROR WRONG FORMAT"


class EvologicsEmulator(SansIO, FaultModes):
    def __init__(
        self,
        medium,
        address=1,
        now=0,
        mode="NET",
        firmware16=False,
        sound_speed=1500,
        highest_addr=254,
        broadcast_addr=255,
        remote_addr=None,
        packet_ms=150,
        im_bitrate=976,
        burst_bitrate=5000,
        turnaround_ms=100,
        max_range_m=2000,
        burst_max=w.BURST_MAX,
        need_control=False,
        banner=BANNER,
        boot_ms=1000,
        version=b"1.7",
    ):
        SansIO.__init__(self)
        if mode not in ("NET", "AT"):
            raise ValueError("mode is NET or AT, not %r" % (mode,))
        self.medium = medium
        self.mode = mode
        self.firmware16 = firmware16
        self.broadcast_addr = broadcast_addr
        self.burst_max = burst_max
        self.banner = banner
        self.boot_ms = boot_ms
        self.version = version
        self.need_control = need_control
        # settings as saved in the modem (AT&W), and the live ones
        self.saved = {"al": address, "ca": sound_speed, "am": highest_addr, "ar": remote_addr}
        self._load()
        self.ptime_us = 0
        self._now = now
        self._boot_at = now
        self._booting_until = None
        self._reader = w.LineReader(self, w.CMD_SPECS, burst_max)
        self._faults = []  # [kind, prefix or None, count, option]
        self._mute = False
        self._cmd = b""  # name of the command being answered (envelope)
        self._one = bytearray(1)
        self._esc = 0  # characters of "+++AT" matched in data mode
        self._in_cmd = False
        self._eat_lf = False
        self._raw = bytearray()  # data-mode bytes waiting to go out as burst
        self.commands = {}  # command name -> count, for tests
        self.ignored = 0  # damaged lines and unknown commands
        self.xcvr = Transceiver(self, medium, address, packet_ms, im_bitrate, burst_bitrate, turnaround_ms, max_range_m)
        medium.attach(address, self.xcvr)

    def _load(self):
        s = self.saved
        self.address = s["al"]
        self.sound_speed = s["ca"]
        self.highest_addr = s["am"]
        self.remote_addr = s["ar"]
        self.zx = False
        self.promiscuous = False
        self.control = not self.need_control
        self.data_mode = self.mode == "AT"
        self.source_level = 0

    def clock_us(self, t):
        # the modem's own microsecond clock (since power-up), 32 bits
        return (ticks_diff(t, self._boot_at) * 1000) & 0xFFFFFFFF

    # -- the port ------------------------------------------------------------------
    def feed(self, now, data):
        self._now = now
        if self._booting_until is not None:
            return  # nobody listens while the modem restarts
        if not self.data_mode:
            self._reader.feed(data)
            return
        one = self._one
        for b in data:
            if self._eat_lf:
                self._eat_lf = False
                if b == 10:
                    continue  # the LF of a command's CR LF
            if self._in_cmd:
                one[0] = b
                self._reader.feed(one)
                continue
            if b == b"+++AT"[self._esc]:
                self._esc += 1
                if self._esc == 5:
                    self._esc = 0
                    self._in_cmd = True
                    self._reader.feed(b"AT")
                continue
            if self._esc:
                self._raw.extend(b"+++AT"[: self._esc])
                self._esc = 0
                if b == 43:  # '+' may start the escape again
                    self._esc = 1
                    continue
            self._raw.append(b)

    def poll(self, now):
        self._now = now
        self.medium.poll(now)
        if self._still_booting(now):
            return
        self.xcvr.poll(now)
        if self._raw and self.remote_addr is not None and self.xcvr.busy(now, True) is None:
            chunk = bytes(self._raw[: self.burst_max])
            self._raw = self._raw[self.burst_max :]
            self.xcvr.send(now, P_BURST, self.remote_addr, True, chunk)

    # -- output ------------------------------------------------------------------
    def _emit(self, line, name):
        # One line with any output fault that applies; name is the envelope
        # name in data mode (None for notifications).
        f = self._fault(("corrupt", "truncate"), line)
        term = b"\r\n"
        if f is not None and f[0] == "corrupt":
            line = hit(line, 1 if len(line) > 1 else 0)
        elif f is not None:
            line = line[: len(line) // 2]
            term = b"\r\n" if f[3] else b""
        if self.data_mode:
            self._out.extend(b"+++AT%s:%d:" % (name or b"", len(line)))
        self._out.extend(line)
        self._out.extend(term)

    def reply(self, line):
        if self._mute:
            self._mute = False
            return
        self._emit(line, self._cmd)

    def notify(self, line):
        if self._booting_until is None:
            self._emit(line, None)

    def received(self, head, data, burst):
        # RECV* from the transceiver: head ends with the comma before data
        if burst and self.data_mode:
            self._out.extend(data)  # data mode: burst data comes out raw
            return
        self.notify(head + data)

    # -- fault modes -------------------------------------------------------------
    # (corrupt_next, truncate_next, swallow_next: acomm_sim.faults). Keys
    # are line prefixes (b"DELIVEREDIM", b"AT*SENDIM"); corrupt damages one
    # character, since the protocol has no checksum.

    def _fault_matches(self, f, line):
        # faults are keyed by how the line starts
        return f[1] is None or line[: len(f[1])] == f[1]

    def reboot(self, now):
        # Power cycle or watchdog: whatever was in flight is forgotten,
        # unsaved settings are lost, the port is quiet, then the power-up
        # text appears.
        self._start_boot(now)
        self._boot_at = now
        self._reader.reset()
        self._mute = False
        self._esc = 0
        self._in_cmd = False
        self._raw = bytearray()
        self._leave_medium(now)

    def _booted(self, now):
        self._load()
        self._join_medium(self.address)
        self._print_banner()

    def steal_control(self):
        # another client took control: commands get ERROR NO CONTROL until
        # AT@CTRL
        self.control = False

    # -- commands ------------------------------------------------------------------
    def on_junk(self, kind):
        self.ignored += 1
        self._in_cmd = False

    def on_line(self, r):
        if self._in_cmd:
            self._in_cmd = False
            self._eat_lf = True
        if self._booting_until is not None:
            return
        t = r.text()
        if not t.startswith(b"AT"):
            self.ignored += 1
            if self.data_mode:
                return
            self._cmd = b""
            self.reply(_FORMAT)
            return
        name = _name(r)
        self._cmd = name
        self.commands[name] = self.commands.get(name, 0) + 1
        f = self._fault(("swallow",), t)
        if f is not None:
            if not f[3]:
                return
            self._mute = True
        self._command(self._now, r, t, name)
        self._mute = False

    def _command(self, now, r, t, name):
        arg = t[2 + len(name) :]
        if name == b"@CTRL":
            self.control = True
            self.reply(b"OK")
            return
        if not self.control:
            self.reply(b"ERROR NO CONTROL")
            return
        if name in _SENDS:
            self._send(now, r, _SENDS[name], name)
        elif name == b"?MODE":
            self.reply(self.mode.encode())
        elif name == b"?AL":
            self.reply(b"%d" % self.address)
        elif name == b"!AL":
            self._set_address(arg)
        elif name == b"?AM":
            self.reply(b"%d" % self.highest_addr)
        elif name == b"!AM":
            self._set("highest_addr", arg, (2, 6, 14, 30, 62, 126, 254))
        elif name == b"?CA":
            self.reply(b"%d" % self.sound_speed)
        elif name == b"!CA":
            self._set("sound_speed", arg, range(1300, 1701))
        elif name == b"@ZX" and arg in (b"0", b"1"):
            self.zx = arg == b"1"
            self.reply(b"OK")
        elif name == b"!RP" and arg in (b"0", b"1"):
            self.promiscuous = arg == b"1"
            self.reply(b"OK")
        elif name == b"?RP":
            self.reply(b"1" if self.promiscuous else b"0")
        elif name == b"!AR":
            self._set("remote_addr", arg, range(256))
        elif name == b"?T":
            self.reply(b"%d" % self.ptime_us)
        elif name == b"!L" and arg in (b"0", b"1", b"2", b"3"):
            self.source_level = int(arg)
            self.reply(b"OK")
        elif name == b"&W" and not arg:
            self.saved = {"al": self.address, "ca": self.sound_speed, "am": self.highest_addr, "ar": self.remote_addr}
            self.reply(b"OK")
        elif name == b"I" and arg == b"0":
            self.reply(self.version + b" (acomm emulator)")
        elif name == b"I" and arg == b"1":
            self.reply(b"phy:%s mac:%s" % (self.version, self.version))
        elif name == b"Z" and arg in (b"0", b"1", b"2", b"3", b"4"):
            self.reply(b"OK")
            if arg == b"0":
                self.reboot(now)  # a full restart
            else:
                self.xcvr.cancel()
        elif name == b"O" and not arg and self.mode == "AT":
            self.reply(b"OK")
            self.data_mode = True
        elif name == b"C" and not arg and self.mode == "AT":
            self.reply(b"OK")
            self.data_mode = False
        else:
            self.ignored += 1
            self.reply(_FORMAT)

    def _set(self, attr, arg, allowed):
        # a plain numeric setting: OK and taken when allowed, else the
        # format error
        v = _int(arg)
        if v is None or v not in allowed:
            self.reply(_FORMAT)
            return
        setattr(self, attr, v)
        self.reply(b"OK")

    def _set_address(self, arg):
        v = _int(arg)
        if v is None or not 0 <= v <= self.highest_addr:
            self.reply(_FORMAT)
            return
        if v != self.address:
            try:
                self.medium.attach(v, self.xcvr)
            except ValueError:
                self.reply(b"ERROR ADDRESS IN USE")
                return
            self.medium.detach(self.address)
            self.medium.attach(v, self.xcvr)
            self.address = v
            self.xcvr.addr = v
        self.reply(b"OK")

    def _send(self, now, r, kind, name):
        data = r.data()
        li = 2 if r.field(1)[:1] == b"p" else 1
        pid = _int(r.field(1)[1:]) if li == 2 else None
        dst = r.int_field(li + 1)
        if data is None or dst is None or not 0 <= dst <= 255 or (li == 2 and pid is None):
            self.reply(_FORMAT)
            return
        ack = False
        if kind == P_IM:
            flag = r.field(li + 2)
            if flag not in (b"ack", b"noack", b"force"):
                self.reply(_FORMAT)
                return
            ack = flag == b"ack"
        elif kind == P_IMS and r.field(li + 2) and r.int_field(li + 2) is None:
            self.reply(_FORMAT)
            return
        limit = self.burst_max if kind == P_BURST else w.IM_MAX
        if not data or len(data) > limit:
            self.reply(b"ERROR BUFFER OVERFLOW" if data else _FORMAT)
            return
        busy = self.xcvr.busy(now, kind == P_BURST)
        if busy is not None:
            self.reply(busy)
            return
        self.reply(b"OK")
        self.xcvr.send(now, kind, dst, ack, data, pid)


def _name(r):
    # The command's name for the envelope and the dispatch: after "AT", a
    # prefix character (? ! @ & *) and the capital letters that follow, or
    # just the letters ("I", "Z", "O", "C").
    t = r.text()
    end = r.commas[0] if r.nc else r.n
    i = 2
    if i < end and t[i] in b"?!@&*":
        i += 1
    while i < end and 65 <= t[i] <= 90:
        i += 1
    return t[2:i]


def _int(b):
    if not b:
        return None
    return w.parse_int(b, 0, len(b))
