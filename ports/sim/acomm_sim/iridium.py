# An emulated Iridium 9602/9603 SBD transceiver (RockBLOCK) that speaks the
# AT interface of ref/modem-protocols.md section 5 byte for byte, so that
# acomm's driver, someone else's software or a terminal program can drive
# it. Sans-IO: feed(now, bytes), poll(now), take_output(). Sessions go
# through a shared acomm_sim.iridium_net.IridiumNetwork (the gateway).
#
# Commands: AT, ATE0/ATE1, ATV0/ATV1, ATQ0/ATQ1 (chained too: ATE0V1),
# AT&K0/AT&K3, AT&W0, AT&F0, AT*R1, ATI<n>, AT+CGMI/+GMI, AT+CGMM/+GMM,
# AT+CGMR/+GMR, AT+CGSN/+GSN, AT+CSQ, AT+CSQF, AT+CRIS, AT+CIER=..., AT+SBDAREG=<n>,
# AT+SBDMTA=<0|1>, AT+SBDMTA?, AT+SBDWB=<n>, AT+SBDWT=<text>, AT+SBDRB,
# AT+SBDRT, AT+SBDIX, AT+SBDIXA, AT+SBDD0/1/2, AT+SBDS, AT+SBDTC, AT-MSSTM. Anything
# else: ERROR. Answers are framed as V.250 says for the mode the host set
# (acomm_sim.atmodem; power-up: echo on, verbose): after the echo
# "AT+SBDWB=5\r" comes "\r\nREADY\r\n"; after the data "\r\n0\r\n" and
# "\r\nOK\r\n". SBDRB's binary block follows the echo at once, as on the
# real unit. SBDRING is a result code (126 in numeric mode).
#
# A session takes session_ms, during which the modem takes no command. Its
# MO status: the next armed failure (fail_sessions), else 32 (no network
# service) while bars is 0, else 0. On success the MO buffer (if any) goes
# to the gateway (it stays in the buffer until AT+SBDD0/2, as on the real
# modem) and the oldest MT message waiting there comes into the MT buffer.
#
# Fault modes: fail_sessions(code, count) (e.g. 32 no network, 18 RF drop,
# 11 MO queue full), set_bars(n) (0: no signal), the gateway's MT queue
# (network.queue_mt), plus acomm_sim.faults': corrupt_next(b"SBDRB") damages
# the block's checksum, corrupt_next / truncate_next(b"+SBDIX") the report,
# swallow_next(b"AT+SBDIX") a command never answered, noise, reboot(now).
#
# AT-MSSTM: "-MSSTM: <hex>", the count of 90 ms frames since the era's
# epoch (epoch_s, from 2020-01-01 UTC; default era 3's) at the simulated
# world's time (wall0_s + now, seconds from 2020-01-01 UTC), in lower-case
# hex without leading zeros; "-MSSTM: no network service" until the unit
# has been registered (bars above 0 since power-up), as the real unit
# before it has heard the network.

from acomm.drivers import iridium_wire as w

from .atmodem import AtModem
from .iridium_net import network_of

WALL0_S = 189388800  # 2026-01-01 00:00 UTC from 2020-01-01: the simulated world's time at now=0
ERA3_S = 161720057  # 2025-02-14 18:14:17 UTC, era 3's epoch (acomm.drivers.iridium_wire)


# what a 9602 answers to +CGMM, and (the first lines of) +CGMR; the hardware
# line is one a 9602 printed (docs.embeddedts.com, TS-IRIDIUM page)
MODEL = b"IRIDIUM 9600 Family SBD Transceiver"
REVISION = (b"Call Processor Version: TA19002", b"Hardware Version: BOOT07d2/9602NrvA-D/04/RAW0d")


class IridiumEmulator(AtModem):
    def __init__(self, medium, address=1, now=0, imei=None, serial=None, bars=5, session_ms=8000,
                 mo_max=w.MO_MAX, mt_max=w.MT_MAX, wb_timeout_ms=60000, csq_ms=0, boot_ms=2000, banner=(),
                 wall0_s=WALL0_S, epoch_s=ERA3_S):
        self.wall0_s = wall0_s
        self.epoch_s = epoch_s
        AtModem.__init__(self, now, banner, boot_ms)
        self.net = network_of(medium)
        self.address = address
        self.imei = imei or "3002340100%05d" % address
        self.serial = serial or "%07d" % address
        self.bars = bars
        self.session_ms = session_ms
        self.mo_max = mo_max
        self.mt_max = mt_max
        self.wb_timeout_ms = wb_timeout_ms
        self.csq_ms = csq_ms
        self.momsn = 0
        self.mtmsn = 0
        self.mt_too_big = 0  # MT messages lost: longer than mt_max
        self.sessions = []  # (end, command, MO status, MO bytes or None), for tests
        self._fails = []
        self._reset()
        self.net.attach(self)

    def _reset(self):
        # power-up values: nothing survives a restart on the 9602
        self.mta = False
        self.mo = None
        self.mt = b""
        self.ring = False  # an SBD ring alert since the last session (+CRIS sri)
        self._ring_due = False
        self.registered = False  # has heard the network since power-up (-MSSTM)

    # -- faults ------------------------------------------------------------------------------
    def fail_sessions(self, code, count=1):
        self._fails.extend([code] * count)

    def set_bars(self, bars):
        self.bars = bars

    # -- the gateway -----------------------------------------------------------------------------
    def ring_alert(self, now):
        if self.mta and self._booting_until is None:
            self.ring = True
            if self._later is None and self._data is None:
                self.notify(b"SBDRING", b"126")
            else:
                self._ring_due = True  # when the modem is back in command mode

    def queue_incoming(self, now, data):
        # an MT message for this modem at the gateway (from a shore
        # application)
        self.net.queue_mt(now, self.imei, data)

    def poll(self, now):
        AtModem.poll(self, now)
        if self._ring_due and self._later is None and self._data is None and self._booting_until is None:
            self._ring_due = False
            self.notify(b"SBDRING", b"126")

    # -- commands ----------------------------------------------------------------------------------
    def _command(self, now, text, c):
        if c in (b"&K0", b"&K3", b"&W0", b"*R1", b"*R0") or c.startswith(b"+CIER=") or c.startswith(b"+SBDAREG="):
            self.ok()
        elif c == b"&F0":
            self.echo = True
            self.verbose = True
            self.quiet = False
            self.mta = False
            self.ok()
        elif c.startswith(b"I"):
            self.reply(b"IRIDIUM 9600 Family SBD Transceiver (acomm emulator)")
            self.ok()
        elif c in (b"+CGMI", b"+GMI"):
            self.reply(b"Iridium")
            self.ok()
        elif c in (b"+CGMM", b"+GMM"):
            self.reply(MODEL)
            self.ok()
        elif c in (b"+CGMR", b"+GMR"):
            for i, ln in enumerate(REVISION):
                self.reply(ln, i > 0)
            self.ok()
        elif c in (b"+CGSN", b"+GSN"):
            self.reply(self.imei.encode())
            self.ok()
        elif c == b"+CSQ" or c == b"+CSQF":
            if c == b"+CSQ" and self.csq_ms:
                self.later(now, self.csq_ms, self._csq)
            else:
                self._csq(now)
        elif c == b"+CRIS":
            self.reply(b"+CRIS:000,00%d" % (1 if self.ring else 0))
            self.ok()
        elif c in (b"+SBDMTA=0", b"+SBDMTA=1"):
            self.mta = c[-1:] == b"1"
            self.ok()
        elif c == b"+SBDMTA?":
            self.reply(b"+SBDMTA:%d" % (1 if self.mta else 0))
            self.ok()
        elif c.startswith(b"+SBDWB="):
            self._write_binary(now, c[7:])
        elif c.startswith(b"+SBDWT="):
            self.mo = text[9:]
            self.ok()
        elif c == b"+SBDRB":
            self._read_binary()
        elif c == b"+SBDRT":
            self.reply(b"+SBDRT:")
            self.reply(self.mt, True)
            self.ok()
        elif c == b"+SBDIX" or c == b"+SBDIXA":
            self.later(now, self.session_ms, lambda t: self._session_end(t, c))
        elif c in (b"+SBDD0", b"+SBDD1", b"+SBDD2"):
            if c != b"+SBDD1":
                self.mo = None
            if c != b"+SBDD0":
                self.mt = b""
            self.reply(b"0")
            self.ok()
        elif c == b"+SBDS":
            self.reply(b"+SBDS: %d, %d, %d, %d" % (self.mo is not None, self.momsn, bool(self.mt),
                                                    self.mtmsn if self.mt else -1))
            self.ok()
        elif c == b"-MSSTM":
            if self.bars > 0:
                self.registered = True
            if self.registered:
                ms = (self.wall0_s - self.epoch_s) * 1000 + now
                self.reply(b"-MSSTM: %x" % ((ms // 90) & 0xFFFFFFFF))
            else:
                self.reply(b"-MSSTM: no network service")
            self.ok()
        elif c == b"+SBDTC":
            self.mt = self.mo or b""
            self.reply(b"SBDTC: Outbound SBD Copied to Inbound SBD: size = %d" % len(self.mt))
            self.ok()
        else:
            self.error()

    def _csq(self, now):
        self.reply(b"+CSQ:%d" % self.bars)
        self.ok()

    def _write_binary(self, now, arg):
        n = int(arg) if arg.isdigit() and len(arg) <= 5 else -1
        if not 1 <= n <= self.mo_max:
            self.reply(b"3")
            self.ok()
            return
        self.reply(b"READY")
        self.begin_data(now, n + 2, self.wb_timeout_ms, lambda t, d: self._written(d, n))

    def _written(self, data, n):
        if data is None:
            self.reply(b"1")  # timed out: no OK follows
            return
        if not w.block_ok(data, n):
            self.reply(b"2")
        else:
            self.mo = data[:n]
            self.reply(b"0")
        self.ok()

    def _read_binary(self):
        block = bytearray(w.sbdrb_block(self.mt))
        if self._fault(("corrupt",), b"SBDRB") is not None:
            block[-1] ^= 0x55
        self.raw(block)
        self.ok()

    def _session_end(self, now, cmd):
        code = self._fails.pop(0) if self._fails else (32 if self.bars == 0 else 0)
        sent = None
        mt_status = 2
        mt_len = 0
        queued = 0
        if code <= w.MO_SUCCESS_MAX:
            if self.mo is not None:
                sent = self.mo
                # the session's MOMSN is counted first: the gateway (and a shore behind it) reads it
                self.momsn = (self.momsn + 1) & 0xFFFF
                self.net.mo(now, self, self.mo)
            self.ring = False
            data, queued = self.net.take_mt(self.imei)
            mt_status = 0
            if data is not None and len(data) > self.mt_max:
                mt_status = 2  # lost: bigger than the MT buffer
                self.mt_too_big += 1
            elif data is not None:
                self.mt = data
                self.mtmsn = (self.mtmsn + 1) & 0xFFFF
                mt_status = 1
                mt_len = len(data)
        self.sessions.append((now, cmd, code, sent))
        self.reply(b"+SBDIX: %d, %d, %d, %d, %d, %d" % (code, self.momsn, mt_status, self.mtmsn, mt_len, queued))
        self.ok()
