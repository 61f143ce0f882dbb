# An emulated WHOI Micro-Modem that speaks its NMEA 0183 serial interface, so
# acomm's driver, a terminal program or goby/pyacomms can drive it as they
# would a modem on a serial port. Sans-IO like the drivers: feed(now, bytes),
# poll(now), take_output(). Modems exchange packets through a shared medium
# (acomm_sim.medium); the acoustic side lives in micromodem_xcvr.
#
# Host sentences: $CCCYC (SRC = this modem; the DRQ-driven cycle CYC ->
# $CACYC -> $CADRQ per frame -> $CCTXD -> $CATXD ... -> $CATXP / $CATXF;
# at rate 0 the cycle-init mini-packet, $CATXP,0 and $CATXF,0, comes between
# $CACYC and the first $CADRQ),
# $CCMUC (mini-packet), $CCMPC (ping), $CCCFG / $CCCFQ (NVRAM), $CCCLK (the
# clock), $CCMSC to itself with argument 0 (restart). Checksums are checked
# when present ($CAERR,...,NMEA,... on a bad one); an unknown sentence also
# gets $CAERR,...,NMEA,...; a data request the host leaves unanswered for
# data_timeout_ms ends the cycle with $CAERR,...,DATA_TIMEOUT,... .
# Every $CA line carries the time of day (HHMMSS) where the modem prints one,
# from the emulator's own clock (12:00:00 at construction unless told).
# At power-up: $CAREV,HHMMSS,INIT,<version> then $CAREV,HHMMSS,AUV,<version>.
#
# Fault modes, for driver tests: noise bytes, a wrong checksum or a
# truncated line on the next output sentence(s), a host sentence never
# answered, and a reboot at any moment (mid-cycle included), with its
# $CAREV INIT banner.

from acomm.compat import ticks_add, ticks_diff
from acomm.drivers import micromodem_wire as nm
from acomm.drivers.base import SansIO
from acomm.drivers.micromodem_wire import FRAME_BYTES, FRAMES_PER_PACKET, Airtime

from .faults import FaultModes, cut, digit_off
from .micromodem_xcvr import Transceiver

VERSION = "0.94.0.00"


def _kind(name):
    # faults are keyed by the 3-letter sentence type: "CYC" matches both
    # $CCCYC and $CACYC
    return None if name is None else name[-3:]


class MicroModemEmulator(SansIO, FaultModes):
    def __init__(
        self,
        medium,
        address,
        now=0,
        rate=1,
        broadcast_addr=0,
        tod_ms=12 * 3600 * 1000,
        version=VERSION,
        mini_ms=700,
        fsk_gap_ms=800,
        psk_ms=1000,
        air_scale=1.0,
        turnaround_ms=250,
        max_range_m=2000,
        data_timeout_ms=3000,
        boot_ms=1000,
        banner=True,
        hear_all=False,
        csum32=False,
    ):
        SansIO.__init__(self)
        self.medium = medium
        self.address = address
        self.rate = rate  # the NVRAM default rate (what a host may query)
        self.broadcast = broadcast_addr
        self.version = version
        self.max_range_m = max_range_m
        self.data_timeout_ms = data_timeout_ms
        self.boot_ms = boot_ms
        self.banner = banner
        self.csum32 = csum32  # answer with 8-digit checksums (some MM2 firmware)
        self.nvram = {"SRC": address, "RXD": 1, "XST": 0, "CST": 0, "DTO": data_timeout_ms // 1000}
        self._tod0 = tod_ms
        self._t0 = now
        self._now = now
        self._booting_until = None
        self._rd = nm.LineReader(self, need_checksum=False)
        self._faults = []  # [kind, sentence type or None, count, flag]
        self._mute = None  # the sentence type whose echo is swallowed
        self._cycle = None  # [dst, rate, ack, nframes, frames, deadline, src]
        self.sentences = {}  # host sentence name -> count, for tests
        self.ignored = 0
        air = Airtime(mini_ms, fsk_gap_ms, psk_ms, air_scale)
        turn = int(turnaround_ms * air_scale)
        window = 2 * air.travel_ms(max_range_m, medium.sound_speed) + turn + air.mini_ms() + 1000
        self.xcvr = Transceiver(self, medium, air, turn, window, hear_all)
        medium.attach(address, self.xcvr)
        if banner:
            self._announce()

    # -- time ------------------------------------------------------------------
    def tod(self, now=None):
        return nm.hhmmss(self._tod0 + ticks_diff(self._now if now is None else now, self._t0))

    def max_travel_ms(self):
        return self.xcvr.air.travel_ms(self.max_range_m, self.medium.sound_speed)

    # -- the serial port -----------------------------------------------------------
    def feed(self, now, data):
        self._now = now
        if self._booting_until is not None:
            return  # nobody listens while it restarts
        self._rd.feed(data)

    def poll(self, now):
        self._now = now
        self.medium.poll(now)
        if self._still_booting(now):
            return
        self.xcvr.poll(now)
        c = self._cycle
        if c is not None and c[5] is not None and ticks_diff(now, c[5]) >= 0:
            self._cycle = None
            self.emit("CAERR", self.tod(), "DATA_TIMEOUT", 1, "no data from the host")

    def emit(self, name, *fields):
        # One $CA line, with any output fault that applies to it.
        kind = _kind(name)
        if self._mute is not None and kind == self._mute:
            self._mute = None
            return
        line = (nm.sentence32 if self.csum32 else nm.sentence)(name, *fields)
        f = self._fault(("corrupt", "truncate"), kind)
        if f is not None and f[0] == "corrupt":
            line = bytearray(line)
            k = line.index(b"*") + 2
            digit_off(line, k)
            line = bytes(line)
        elif f is not None:
            line = cut(line, f[3])
        self._out.extend(line)

    # -- fault modes -----------------------------------------------------------------
    # (corrupt_next, truncate_next, swallow_next: acomm_sim.faults). Keys
    # are sentence types ("CAACK", "CCCYC"); corrupt gives a wrong checksum.
    def _fault_key(self, key):
        return _kind(key)

    def reboot(self, now):
        # Power cycle or watchdog: everything in flight is forgotten, the port
        # goes quiet, then the $CAREV INIT banner appears.
        self._start_boot(now)
        self._rd.reset()
        self._mute = None
        self._cycle = None
        self._leave_medium(now)

    def _booted(self, now):
        self.address = self.nvram["SRC"]
        self._join_medium(self.address)
        self._announce()

    def _announce(self):
        self.emit("CAREV", self.tod(), "INIT", self.version)
        self.emit("CAREV", self.tod(), "AUV", self.version)

    # -- host sentences ------------------------------------------------------------------
    def on_junk(self, kind):
        self.ignored += 1
        if kind != nm.JUNK_TEXT:
            self.emit("CAERR", self.tod(), "NMEA", 2, "bad sentence (%s)" % kind)

    def on_sentence(self, buf, n):
        if self._booting_until is not None:
            return
        f = nm.fields(buf, n)
        name = f[0].decode()
        self.sentences[name] = self.sentences.get(name, 0) + 1
        h = _COMMANDS.get(name)
        if h is None:
            self.ignored += 1
            self.emit("CAERR", self.tod(), "NMEA", 1, "unknown sentence %s" % name)
            return
        sw = self._fault(("swallow",), _kind(name))
        if sw is not None:
            if not sw[3]:
                return
            self._mute = _kind(name)
        h(self, self._now, f)
        if self._mute == _kind(name):
            self._mute = None  # only the immediate echo is swallowed

    def _bad(self, module, what):
        self.emit("CAERR", self.tod(), module, 3, what)

    def _busy(self, now):
        return self._cycle is not None or self.xcvr.busy(now)

    def _cyc(self, now, f):
        # $CCCYC,CMD,SRC,DEST,RATE,ACK,NFRAMES
        v = [nm.num(x) for x in f[1:7]] if len(f) == 7 else [None]
        if None in v:
            return self._bad("CYC", "bad CCCYC fields")
        cmd, src, dst, rate, ack, nframes = v
        if not 0 <= rate <= 5 or not 1 <= nframes <= FRAMES_PER_PACKET[rate] or not 0 <= dst <= 254:
            return self._bad("CYC", "bad rate or frame count")
        if self._busy(now):
            return self._bad("CYC", "BUSY")
        self.emit("CACYC", cmd, src, dst, rate, ack, nframes)
        if src != self.address:
            return self._bad("CYC", "uplink cycles not emulated")
        self._cycle = [dst, rate, ack, nframes, [], None, src]
        if rate == 0:
            # FSK: the cycle header goes out first as its own mini-packet,
            # reported by $CATXF; only then the data request (pyacomms'
            # WaitingForCiTxf state waits for that $CATXF)
            self.xcvr.send_cycle_init(now, self._drq)
        else:
            self._drq(now)

    def _drq(self, now, _=None):
        c = self._cycle
        if c is None:
            return  # restarted while the cycle init was on the air
        self.emit("CADRQ", self.tod(), c[6], c[0], c[2], FRAME_BYTES[c[1]], len(c[4]) + 1)
        c[5] = ticks_add(now, self.data_timeout_ms)

    def _txd(self, now, f):
        # $CCTXD,SRC,DEST,ACK,HEX
        c = self._cycle
        if c is None or c[5] is None:
            return self._bad("TXD", "no data request pending")
        data = nm.unhex(f[4]) if len(f) == 5 else None
        if data is None or len(data) > FRAME_BYTES[c[1]]:
            self._cycle = None
            return self._bad("TXD", "bad CCTXD data")
        c[5] = None
        self.emit("CATXD", c[6], c[0], c[2], len(data))
        if data:
            c[4].append(data)
        if data and len(c[4]) < c[3]:
            self._drq(now)
            return
        self._cycle = None
        if c[4]:
            self.xcvr.send_cycle(now, c[0], c[1], c[2], c[4])

    def _muc(self, now, f):
        # $CCMUC,SRC,DEST,HHHH (13 bits)
        dst = nm.num(f[2], 0, 254) if len(f) == 4 else None
        v = nm.unhex(f[3]) if dst is not None and len(f[3]) == 4 else None
        if v is None or (v[0] << 8 | v[1]) > 0x1FFF:
            return self._bad("MUC", "bad CCMUC fields")
        if self._busy(now):
            return self._bad("MUC", "BUSY")
        self.emit("CAMUC", self.address, dst, f[3].decode())
        self.xcvr.send_mini(now, dst, (v[0] << 8) | v[1])

    def _mpc(self, now, f):
        # $CCMPC,SRC,DEST
        dst = nm.num(f[2], 0, 254) if len(f) == 3 else None
        if dst is None:
            return self._bad("MPC", "bad CCMPC fields")
        if self._busy(now):
            return self._bad("MPC", "BUSY")
        self.emit("CAMPC", self.address, dst)
        self.xcvr.send_ping(now, dst)

    def _cfg(self, now, f):
        # $CCCFG,KEY,VALUE: set NVRAM (SRC takes effect at once)
        val = nm.num(f[2]) if len(f) == 3 else None
        if val is None:
            return self._bad("CFG", "bad CCCFG fields")
        key = f[1].decode()
        if key == "SRC":
            if not 0 <= val <= 254:
                return self._bad("CFG", "bad SRC")
            if val != self.address:
                self.medium.detach(self.address)
                self.address = val
                self.xcvr.addr = val
                self.medium.attach(val, self.xcvr)
        self.nvram[key] = val
        self.emit("CACFG", key, val)

    def _cfq(self, now, f):
        # $CCCFQ,KEY or ALL
        key = f[1].decode() if len(f) == 2 else ""
        if key == "ALL":
            for k in self.nvram:
                self.emit("CACFG", k, self.nvram[k])
        elif key in self.nvram:
            self.emit("CACFG", key, self.nvram[key])
        else:
            self._bad("CFQ", "unknown parameter")

    def _clk(self, now, f):
        # $CCCLK,YYYY,MM,DD,HH,MM,SS: only the time of day matters here
        v = [nm.num(x) for x in f[1:7]] if len(f) == 7 else [None]
        if None in v or not (0 <= v[3] < 24 and 0 <= v[4] < 60 and 0 <= v[5] < 60):
            return self._bad("CLK", "bad CCCLK fields")
        self._tod0 = ((v[3] * 60 + v[4]) * 60 + v[5]) * 1000
        self._t0 = now
        self.emit("CACLK", *[x.decode() for x in f[1:7]])

    def _msc(self, now, f):
        # $CCMSC,SRC,DEST,ARG: ARG 0 to the local address restarts the modem
        v = [nm.num(x) for x in f[1:4]] if len(f) == 4 else [None]
        if None in v:
            return self._bad("MSC", "bad CCMSC fields")
        self.emit("CAMSC", v[0], v[1], v[2])
        if v[1] == self.address and v[2] == 0:
            self.reboot(now)


_COMMANDS = {
    "CCCYC": MicroModemEmulator._cyc,
    "CCTXD": MicroModemEmulator._txd,
    "CCMUC": MicroModemEmulator._muc,
    "CCMPC": MicroModemEmulator._mpc,
    "CCCFG": MicroModemEmulator._cfg,
    "CCCFQ": MicroModemEmulator._cfq,
    "CCCLK": MicroModemEmulator._clk,
    "CCMSC": MicroModemEmulator._msc,
}
