# An emulated Teledyne Benthos ATM-9xx acoustic modem that speaks its serial
# dialogue (ref/modem-protocols.md section 4), so acomm's driver, goby or a
# person at a terminal can drive it like a modem on a serial port. Sans-IO:
# feed(now, bytes), poll(now), take_output(). Modems exchange packets through
# a shared medium (acomm_sim.medium); the acoustic side is benthos_xcvr and
# the command shell benthos_shell.
#
# Two modes, as the real modem:
#   command  lines ending in CR (or LF) are commands; typed characters are
#            echoed while @P1EchoChar=Ena; answers end in CR LF and the
#            prompt `user:1>` (with @P1Prompt=7) has no line ending.
#   online   every byte is payload. The bytes are sent as one packet once
#            the line has been quiet for @FwdDelay: "Forwarding Delay Up",
#            the packet goes on the air, and when it is over the prompt is
#            printed and the modem is back in command mode. That return is
#            what goby's driver expects; it is inferred, not confirmed.
#            `+++` after at least guard_ms of silence returns to command
#            mode at once (a CR or LF right after it is taken as part of
#            the escape); without the silence it is payload.
# Received packets are reported in any mode as the DATA/Source/CRC/<EOP>
# block (hex with @PrintHex=Ena), packets for others too with @RcvAll=Ena.
#
# Fault modes for driver tests: noise bytes; a damaged line, or a CRC:Fail
# block (shown with @ShowBadData=Ena) instead of a good one; a truncated
# line or block; a command that is never answered (or carried out without
# its answer); a restart at any moment with the power-up banner.

from acomm.compat import ticks_add, ticks_diff
from acomm.drivers import benthos_wire as w
from acomm.drivers.base import SansIO

from .benthos_shell import Shell, defaults
from .faults import FaultModes, cut, hit
from .benthos_xcvr import Transceiver

BANNER = (
    b"Teledyne Benthos ATM-900 series acoustic modem (acomm emulator)",
    b"Power-up complete",
)

M_COMMAND = 0
M_ONLINE = 1

_STATS = "MPD:03.2 SNR:31.3 AGC:91 SPD:+00.0 CCERR:013"  # the reference's figures


class BenthosEmulator(SansIO, FaultModes):
    def __init__(
        self,
        medium,
        address=1,
        now=0,
        tx_rate=8,
        echo=True,
        op_mode=1,
        settings=None,
        guard_ms=1000,
        packet_ms=500,
        turnaround_ms=500,
        boot_ms=1000,
        banner=BANNER,
        prompt_n=1,
        hex_per_line=16,
        max_packet=w.MAX_FRAME,
        rx_stats=_STATS,
        speed=0.0,
        serial=1,
    ):
        SansIO.__init__(self)
        self.medium = medium
        self.factory_rate = tx_rate
        s = defaults(address, tx_rate)
        s["P1EchoChar"] = "Ena" if echo else "Dis"
        s["OpMode"] = str(op_mode)
        s.update(settings or {})
        self.stored = s  # what a restart comes back with
        self.settings = dict(s)
        self.address = address
        self.guard_ms = guard_ms
        self.boot_ms = boot_ms
        self.banner = banner
        self.prompt_n = prompt_n
        self.hex_per_line = hex_per_line
        self.rx_stats = rx_stats
        self.speed = speed
        self.serial = serial
        self.voltage = 24.0
        self.temperature = 12.5
        self.shell = Shell(self)
        self.xcvr = Transceiver(self, medium, packet_ms, turnaround_ms)
        self._line = bytearray()
        self._line_cap = 256
        self._buf = bytearray(max_packet)
        self._faults = []  # [kind, what, count, option]
        self._mute = False
        self._mute_range = False
        self.commands = {}  # first word -> count, for tests
        self.ignored = 0  # commands swallowed by the fault mode
        self.packets = 0
        self._power_up(now)
        medium.attach(address, self)

    def _power_up(self, now):
        self.mode = M_COMMAND if self.settings["OpMode"] == "0" else M_ONLINE
        self._n = 0  # online bytes waiting
        self._last_rx = ticks_add(now, -self.guard_ms)  # quiet since power-up
        self._plus = 0  # '+' of a possible escape, held back
        self._skip = 0  # 13/10: a line end that belongs to the last command
        self._cr = False
        self._booting_until = None

    # -- output and its faults ----------------------------------------------------
    def emit(self, kind, text, end=True):
        # One line (or, for kind "data", a list of lines) to the host.
        if self._mute:
            return
        lines = text if isinstance(text, list) else [text]
        data = "\r\n".join(lines) + ("\r\n" if end else "")
        data = data.encode()
        # (a damaged receive block is a CRC:Fail block: see report())
        f = self._fault(("truncate",) if kind == "data" else ("corrupt", "truncate"), kind)
        if f is not None and f[0] == "corrupt":
            data = hit(data, min(2, len(lines[0]) - 1))  # in the first word
        elif f is not None:
            data = cut(data, f[3])
        self._out.extend(data)

    def prompt(self):
        if self.settings["P1Prompt"] == "7":
            self.emit("prompt", w.prompt_text(self.prompt_n), False)

    # -- fault modes ----------------------------------------------------------------------
    # (corrupt_next, truncate_next, swallow_next: acomm_sim.faults). Keys:
    # for output faults "data" (corrupt: a CRC:Fail block instead of the
    # good one), "reply", "connect", "fwd", "prompt", "range"; for swallow,
    # the start of a command line ("ATO", "@RemoteAddr", "ATR"...).

    def _fault_matches(self, f, what):
        # any (None) is never the echo or the banner; a swallow is keyed by
        # how the command line starts, in any case; the rest by output kind
        if f[1] is None:
            return what not in ("echo", "banner")
        if f[0] == "swallow":
            return what.upper().startswith(f[1].upper())
        return f[1] == what

    def reboot(self, now):
        # Power cycle or watchdog: everything in flight is forgotten, the
        # port is deaf for boot_ms, then the banner.
        self.medium.cancel(self.address, now)
        self.medium.detach(self.address)
        self.xcvr.reset()
        self.settings = dict(self.stored)
        self._line = bytearray()
        self._mute = False
        self._mute_range = False
        self._power_up(now)
        self._start_boot(now)

    def _booted(self, now):
        self.address = int(self.settings["LocalAddr"])
        self.medium.attach(self.address, self)
        self._print_banner()
        if self.mode == M_COMMAND:
            self.prompt()

    def readdress(self, addr):
        # @LocalAddr: the modem answers to its new address from now on
        if addr == self.address:
            return True
        try:
            self.medium.attach(addr, self)
        except ValueError:
            return False
        self.medium.detach(self.address)
        self.address = addr
        return True

    # -- the serial port -----------------------------------------------------------------
    def feed(self, now, data):
        if self._booting_until is not None:
            return
        self._flush(now)
        for c in data:
            if self._booting_until is not None:
                break  # ATES: the rest is lost
            if self.mode == M_COMMAND:
                self._command_byte(now, c)
            else:
                self._online_byte(now, c)

    def poll(self, now):
        self.medium.poll(now)
        if self._still_booting(now):
            return
        self.xcvr.poll(now)
        self._flush(now)

    def _command_byte(self, now, c):
        self._last_rx = now
        if self._skip and c == self._skip:
            self._skip = 10 if c == 13 else 0
            return
        self._skip = 0
        echo = self.settings["P1EchoChar"] == "Ena"
        if c == 13 or c == 10:
            if c == 10 and self._cr:
                self._cr = False
                return
            self._cr = c == 13
            if echo:
                self.emit("echo", "")
            line = _text(self._line)
            self._line = bytearray()
            self._run(now, line)
            return
        self._cr = False
        if echo:
            self._out.append(c)
        if len(self._line) < self._line_cap:
            self._line.append(c)

    def _run(self, now, line):
        line = line.strip()
        key = line.split("=")[0].split(" ")[0] if line else ""
        self.commands[key] = self.commands.get(key, 0) + 1
        f = self._fault(("swallow",), line) if line else None
        if f is not None and not f[3]:
            self.ignored += 1
            return
        self._mute = f is not None
        if self._mute and line.upper().startswith("ATR"):
            self._mute_range = True
        if self.shell.run(now, line) and self.mode == M_COMMAND and self._booting_until is None:
            self.prompt()
        self._mute = False

    def go_online(self, now):
        # ATO / ATD: the line end that sent it is not payload
        rate = w.RATES[int(self.settings["TxRate"])]
        self.emit("connect", "CONNECT %d bps" % rate)
        self.mode = M_ONLINE
        self._skip = 10 if self._cr else 0
        self._last_rx = now

    def _online_byte(self, now, c):
        quiet = ticks_diff(now, self._last_rx)
        self._last_rx = now
        if self._skip:
            skip = self._skip
            self._skip = 0
            if c == skip:
                return
        if self._plus:
            if c == 43:
                self._plus += 1
                if self._plus == 3:
                    self._escape(now)
                return
            self._hold_plus()
        elif c == 43 and quiet >= self.guard_ms:
            self._plus = 1
            return
        self._put(now, c)

    def _hold_plus(self):
        n = self._plus
        self._plus = 0
        for _ in range(n):
            self._put(None, 43)

    def _put(self, now, c):
        if self._n >= len(self._buf):
            self.ignored += 1  # more than one packet holds: lost
            return
        self._buf[self._n] = c
        self._n += 1

    def _escape(self, now):
        self._plus = 0
        self.mode = M_COMMAND
        self._skip = 13  # goby sends "+++\r"
        self._cr = False
        self._line = bytearray()
        self.prompt()

    def _flush(self, now):
        # online bytes go on the air once the line was quiet for FwdDelay
        # (and the transducer is free)
        if not self._n and not self._plus:
            return
        if ticks_diff(now, self._last_rx) < w.milli(self.settings["FwdDelay"]) or self.xcvr.busy(now):
            return
        if self._plus and self.mode == M_ONLINE:
            self._hold_plus()  # "+" without the rest of an escape: payload
        if not self._n:
            return
        data = bytes(self._buf[: self._n])
        self._n = 0
        self.emit("fwd", w.FWD_UP)
        self.packets += 1
        self.xcvr.send_data(now, data)

    def transmitted(self, now):
        # our packet is over: back to the shell, unless more payload came
        if self.mode == M_ONLINE and not self._n and not self._plus:
            self.mode = M_COMMAND
            self._cr = False
            self.prompt()

    # -- the medium -----------------------------------------------------------------------
    def receive(self, t, src, packet, distance_m):
        if self._booting_until is None:
            self.xcvr.receive(t, src, packet, distance_m)

    def report(self, p):
        # the receive block of ref/modem-protocols.md 4.3
        s = self.settings
        bad = self._fault(("corrupt",), "data") is not None
        if bad and s["ShowBadData"] != "Ena":
            return
        data = p.data
        if bad:
            b = bytearray(data)
            b[len(b) // 2] ^= 0x5A
            data = bytes(b)
        step = self.hex_per_line
        if s["PrintHex"] == "Ena":
            parts = [w.hex_text(data[i : i + step]) for i in range(0, len(data), step)] or [""]
        else:
            parts = [_text(data)]
        lines = ["DATA(%04d):%s" % (len(data), parts[0])] + parts[1:]
        lines.append("Source:%03d  Destination:%03d" % (p.src, p.dst))
        lines.append("CRC:%s %s" % ("Fail" if bad else "Pass", self.rx_stats))
        lines.append(w.EOP)
        self.emit("data", lines)

    def range_result(self, t, dst, distance_m):
        # the end of our ATR: the range line or the reply timeout, then the
        # prompt
        mute = self._mute_range
        self._mute_range = False
        self._mute = mute
        if distance_m is None:
            self.emit("range", w.NO_RESPONSE)
        else:
            rt = 2000.0 * distance_m / self.medium.sound_speed
            self.emit("range", w.range_line(self.address, dst, distance_m, rt, self.speed))
        if self.mode == M_COMMAND:
            self.prompt()
        self._mute = False


def _text(b):
    # bytes as a str of the same length, whatever they hold (no decoding
    # that could fail on noise)
    return "".join([chr(c) for c in b])
