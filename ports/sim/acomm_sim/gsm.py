# An emulated GSM modem for SMS (3GPP TS 27.005 over AT, ref section 6),
# byte for byte, so acomm's SMS driver, someone else's software or a
# terminal program can drive it. Sans-IO: feed(now, bytes), poll(now),
# take_output(). Messages travel through a shared acomm_sim.gsm_net
# GsmNetwork, addressed by phone number.
#
# Commands: what a SIM800 or a Quectel EC2x answers at power-up and in SMS
# work (3GPP TS 27.007 / 27.005), in their formats, so that host software
# written for those units (python-gsmmodem, Gammu, ModemManager) connects:
# AT, ATE/ATV/ATQ (chained too), AT&F, ATZ, ATI, AT+CGMI/+GMI, AT+CGMM/+GMM,
# AT+CGMR/+GMR, AT+CGSN/+GSN, AT+CIMI, AT+GCAP, AT+CLAC, AT+CFUN, AT+CMEE,
# AT+CPIN, AT+CSQ, AT+CREG, AT+CGREG, AT+COPS, AT+CNUM, AT+CSCA, AT+CSCS,
# AT+CSMP, AT+CMGF, AT+CNMI, AT+CPMS, AT+CLIP, AT+CRC, AT+CVHU, with their
# read (?), test (=?) and set (=) forms, and AT+CMGS (PDU: =<tpdu length>;
# text: ="<number>"), AT+CMGR=<i>, AT+CMGL[=<stat>], AT+CMGD=<i>[,<flag>].
# An unknown command: ERROR (as both units answer, whatever AT+CMEE says);
# a bad parameter: ERROR, or +CME ERROR: <n> after AT+CMEE=1 (=2: its
# text), +CMS ERROR: <n> for the SMS commands. docs/drivers-sms.md has the
# conformance table. Answers are framed as V.250 says for the mode the host
# set (acomm_sim.atmodem; power-up: echo on, verbose): `CR LF text CR LF`;
# the +CMGS prompt is CR LF "> " (no line end); the data line of +CMGR /
# +CMGL / +CMT follows its header directly.
#
# Power-up state: echo on, PDU mode, no new-message indications until
# AT+CNMI (mt=1 or 3: "+CMTI: "SM",<i>" when a message is stored; mt=2: the
# message itself as +CMT, not stored; mode 0: nothing shown), registration
# reports off (AT+CREG=1/2: "+CREG: <stat>[,<lac>,<ci>]" when the
# registration changes: set_rssi to or from 0/99, AT+CFUN). The message
# storage and the SMSC number are the SIM's and survive a restart. A stored
# message shows in PDU mode as an SMS-DELIVER, in text mode as its text
# (8-bit data as hex, as real modems do). Sending takes send_ms. After a
# restart the unit prints `banner`, or with power_up="sim800" / "ec2x" (or
# ((ms, line), ...)) the lines those units print as they come up (RDY,
# +CFUN: 1, +CPIN: READY, Call Ready, SMS Ready ...), spread over seconds.
#
# Fault modes: set_rssi(n) (0 or 99: no network, +CMS ERROR: 331),
# fail_sends(code, count) (+CMS ERROR: <code>), a full storage (`storage`
# slots; the network keeps what does not fit), plus acomm_sim.faults':
# corrupt_next / truncate_next(b"+CMTI") etc., swallow_next(b"AT+CMGS"),
# noise, reboot(now).
#
# The clock (AT+CCLK?, acomm_sim.gsm_general.Clock): the world's time from
# wall0_s (seconds from 2020-01-01 UTC at now=0; default 2026-01-01) in
# zone `tz` once registered, with network_time=True (default); with
# network_time=False, the unit's RTC from 1980-01-06 at power-up.

from acomm.compat import ticks_add, ticks_diff
from acomm.drivers import sms_pdu as pdu

from .atmodem import AtModem
from .gsm_general import CLAC, SETTINGS, Clock, GeneralCommands, nums, split, toa
from .gsm_net import network_of

_STAT_TEXT = (b"REC UNREAD", b"REC READ", b"STO UNSENT", b"STO SENT")
# what a unit prints as it comes up, (ms after the restart, line): SIM800
# at a fixed baud rate (SIM800 AT manual V1.09 19.3: RDY, +CPIN, Call Ready,
# SMS Ready) and Quectel EC2x
POWER_UP = {
    "sim800": ((0, b"RDY"), (200, b"+CFUN: 1"), (400, b"+CPIN: READY"), (3000, b"Call Ready"), (3500, b"SMS Ready")),
    "ec2x": ((0, b"RDY"), (200, b"+CFUN: 1"), (400, b"+CPIN: READY"), (500, b"+QUSIM: 1"), (3000, b"+QIND: SMS DONE"),
             (3500, b"+QIND: PB DONE")),
}


def default_number(address):
    # the number an emulated modem has unless it is given one
    return "+4477009%05d" % address


def sms_driver(address, opts):
    # acomm_sim.world's factory: an SmsDriver that knows every node's
    # default number (node id = modem address there) unless given numbers
    from acomm.drivers.sms import SmsDriver

    if "numbers" not in opts:
        opts["numbers"] = dict((i, default_number(i)) for i in range(255))
    return SmsDriver(address, **opts)


def _bcd2(v):
    return ((v % 10) << 4) | (v // 10)


WALL0_S = 189388800  # 2026-01-01 00:00 UTC from 2020-01-01: the simulated world's time at now=0


class GsmEmulator(GeneralCommands, Clock, AtModem):
    def __init__(self, medium, address=1, now=0, number=None, rssi=20, storage=20, send_ms=2000,
                 data_timeout_ms=60000, boot_ms=2000, banner=(b"RDY",), power_up=None, wall0_s=WALL0_S,
                 network_time=True, tz=0):
        self.wall0_s = wall0_s
        self.network_time = network_time
        self.tz = tz
        AtModem.__init__(self, now, banner, boot_ms)
        self.power_up = POWER_UP[power_up] if isinstance(power_up, str) else power_up
        self._urc_q = []  # [when, line]: power-up lines still to come
        self.net = network_of(medium)
        self.address = address
        self.number = number or default_number(address)
        self.rssi = rssi
        self.capacity = storage
        self.send_ms = send_ms
        self.data_timeout_ms = data_timeout_ms
        self.store_ = {}  # index -> [stat, number, dcs, data, (day, secs)]
        self.sent = []  # (number, dcs, data), for tests
        self.mr = 0
        self.smsc = self.net.smsc  # the SIM's
        self._fails = []
        self._reset()
        self.net.attach(self)

    def _reset(self):
        # the power-up settings (27.007 / 27.005 defaults)
        self.cmgf = 0
        self.cnmi = [0, 0, 0, 0, 0]
        self.cmee = 0
        self.cfun = 1
        self.creg = 0
        self.cgreg = 0
        self.clip = 0
        self.crc = 0
        self.cvhu = 0
        self.cscs = b"IRA"
        self.cops_format = 0
        self.csmp = [17, 167, 0, 0]
        self._reset_clock(self._now)

    def poll(self, now):
        AtModem.poll(self, now)
        q = self._urc_q
        while q and self._booting_until is None and ticks_diff(now, q[0][0]) >= 0:
            self.notify(q.pop(0)[1])

    def _booted(self, now):
        if self.power_up is None:
            AtModem._booted(self, now)
        else:
            self._urc_q = [[ticks_add(now, ms), line] for ms, line in self.power_up]
            self.poll(now)

    # -- faults -------------------------------------------------------------------------------
    def set_rssi(self, rssi):
        before = self.reg_stat()
        self.rssi = rssi
        self._reg_moved(before)

    def fail_sends(self, code, count=1):
        self._fails.extend([code] * count)

    def queue_incoming(self, now, data, src="+10000000000"):
        # an SMS with 8-bit data for this modem from outside (a shore phone)
        self.net.queue_sms(now, self.number, data, src)

    # -- the network -------------------------------------------------------------------------
    def store(self, now, number, dcs, data):
        # a message arrives; False when it cannot be taken now
        if self._booting_until is not None:
            return False
        secs = (now // 1000) & 0x3FFFFFFF
        t = (1 + (secs // 86400) % 28, secs % 86400)
        mode, mt = self.cnmi[0], self.cnmi[1]
        if mode and mt == 2:
            # routed to the host at once, not stored (27.005 3.4.1; with
            # AT+CSMS=0 no acknowledgement is wanted)
            a, body = self._parts(number, dcs, data, t)
            self.notify(b"+CMT: ,%s" % a if self.cmgf == 0 else b'+CMT: "%s",,%s' % (number.encode(), a))
            self.notify(body, more=True)
            return True
        for i in range(1, self.capacity + 1):
            if i not in self.store_:
                self.store_[i] = [0, number, dcs, data, t]
                if mode and mt in (1, 3):
                    self.notify(b'+CMTI: "SM",%d' % i)
                return True
        return False

    # -- commands (the 27.007 ones are acomm_sim.gsm_general's) -----------------------------

    def _command(self, now, text, c):
        name, op, arg = split(c)
        if name[:1] != b"+":
            if c in (b"I", b"I0"):
                self.reply(b"acomm GSM modem emulator")
                self.ok()
            elif c in (b"&F", b"&F0", b"Z", b"Z0"):
                # no stored profile: ATZ gives the factory settings too
                self.echo = True
                self.verbose = True
                self.quiet = False
                self._reset()
                self.ok()
            else:
                self.error()
            return
        if op in (b"?", b"=?") and arg:
            self.error()
            return
        t = self._ident(name)
        if t is not None or name == b"+CLAC":
            if op == b"":
                for i, line in enumerate((t,) if t is not None else CLAC):
                    self.reply(line, i > 0)
            elif op != b"=?":
                self.error()
                return
            self.ok()
        elif name in SETTINGS:
            self._setting(name, op, arg)
        elif name in (b"+CMGS", b"+CMGR", b"+CMGL", b"+CMGD"):
            self._sms_command(now, text, name, op, arg)
        else:
            f = _OTHERS.get(name)
            if f is None:
                self.error()
            else:
                f(self, now, op, arg)

    def _csca(self, now, op, arg):
        if op == b"?":
            self.reply(b'+CSCA: "%s",%d' % (self.smsc.encode(), toa(self.smsc)))
        elif op == b"=":
            q = arg.split(b'"')
            if len(q) < 3 or not q[1].lstrip(b"+").isdigit():
                self.cms(304 if self.cmgf == 0 else 305)
                return
            self.smsc = q[1].decode()
        elif op != b"=?":
            self.error()
            return
        self.ok()

    def _csmp(self, now, op, arg):
        if op == b"?":
            self.reply(b"+CSMP: %d,%d,%d,%d" % tuple(self.csmp))
        elif op == b"=":
            v = nums(arg, 1, 4)
            if v is None or max(v) > 255:
                self.cms(305)
                return
            self.csmp[: len(v)] = v
        elif op != b"=?":
            self.error()
            return
        self.ok()

    def _cnmi(self, now, op, arg):
        if op == b"?":
            self.reply(b"+CNMI: %d,%d,%d,%d,%d" % tuple(self.cnmi))
        elif op == b"=?":
            self.reply(b"+CNMI: (0-3),(0-3),(0,2),(0-2),(0,1)")
        elif op == b"=":
            v = nums(arg, 1, 5)
            if v is None or [1 for x, top in zip(v, (3, 3, 2, 2, 1)) if x > top] or (len(v) > 2 and v[2] == 1):
                self.cms(303)
                return
            self.cnmi[: len(v)] = v
        else:
            self.error()
            return
        self.ok()

    def _cpms(self, now, op, arg):
        n = len(self.store_)
        if op == b"?":
            self.reply(b'+CPMS: "SM",%d,%d,"SM",%d,%d,"SM",%d,%d' % ((n, self.capacity) * 3))
        elif op == b"=?":
            self.reply(b'+CPMS: ("SM"),("SM"),("SM")')
        elif op == b"=":
            # only the SIM's storage here; a real unit has "ME" etc. too
            f = arg.split(b",")
            if len(f) > 3 or [1 for m in f if m.strip() != b'"SM"']:
                self.cms(302)
                return
            self.reply(b"+CPMS: %d,%d,%d,%d,%d,%d" % ((n, self.capacity) * 3))
        else:
            self.error()
            return
        self.ok()

    def _sms_command(self, now, text, name, op, arg):
        if op == b"=?":
            if name == b"+CMGD":
                self.reply(b"+CMGD: (1-%d),(0-4)" % self.capacity)
            elif name == b"+CMGL":
                self.reply(b"+CMGL: (0-4)" if self.cmgf == 0 else b'+CMGL: ("' + b'","'.join(_STAT_TEXT) + b'","ALL")')
            self.ok()
        elif name == b"+CMGL" and op in (b"", b"="):
            self._cmgl(arg if op else None)
        elif op != b"=":
            self.error()
        elif name == b"+CMGS":
            self._cmgs(now, text[8:])
        elif name == b"+CMGR":
            e = self.store_.get(int(arg)) if arg.isdigit() else None
            if e is None:
                self.cms(321)
                return
            self._show(b"+CMGR: ", None, e)
            self.ok()
        else:
            self._cmgd(arg)

    def cms(self, code):
        self.reply(b"+CMS ERROR: %d" % code)

    # -- sending ---------------------------------------------------------------------------------
    def _cmgs(self, now, arg):
        if self.cmgf == 0:
            if not arg.isdigit() or not 7 <= int(arg) <= 164:
                self.cms(304)
                return
            n = int(arg)
            dest = None
        else:
            q = arg.split(b'"')
            if len(q) < 3 or not q[1].lstrip(b"+").isdigit():
                self.cms(304)
                return
            n = None
            dest = q[1].decode()
        self.prompt(b"> ")
        self.begin_data(now, None, self.data_timeout_ms, lambda t, d: self._typed(t, d, n, dest))

    def _typed(self, now, data, n, dest):
        if data is None:
            self.ok()  # ESC (or silence): nothing sent
            return
        try:
            if self.cmgf == 0:
                raw = pdu.from_hex(data)
                if len(raw) - 1 - raw[0] != n:
                    raise ValueError
                dest, dcs, ud, _, _ = pdu.decode_submit(raw)
            else:
                if not data or len(data) > pdu.SEPTETS_MAX:
                    raise ValueError
                dcs, ud = pdu.DCS_7BIT, data
        except (ValueError, IndexError, pdu.DecodeError):
            self.cms(304)
            return
        self.later(now, self.send_ms, lambda t: self._sent(t, dest, dcs, ud))

    def _sent(self, now, dest, dcs, ud):
        if self._fails:
            self.cms(self._fails.pop(0))
            return
        if self.reg_stat() != 1:
            self.cms(331)  # no network service
            return
        self.net.submit(now, self.number, dest, dcs, ud)
        self.sent.append((dest, dcs, ud))
        self.mr = (self.mr + 1) & 0xFF
        self.reply(b"+CMGS: %d" % self.mr)
        self.ok()

    # -- reading ----------------------------------------------------------------------------------
    def _show(self, head, index, e, more=False):
        # +CMGR / +CMGL lines for one stored message; a received one
        # becomes "read". The data line follows its header with no blank
        # line (27.005 3.4.2/3.4.3: header CR LF data); so does the next
        # +CMGL entry (more=True)
        stat, number, dcs, data, t = e
        a, body = self._parts(number, dcs, data, t)
        lead = b"%d," % index if index is not None else b""
        if self.cmgf == 0:
            self.reply(head + lead + b"%d,,%s" % (stat, a), more)
        else:
            self.reply(head + lead + b'"%s","%s",,%s' % (_STAT_TEXT[stat], number.encode(), a), more)
        self.reply(body, True)
        if stat == 0:
            e[0] = 1

    def _parts(self, number, dcs, data, t):
        # a received message as the host sees it: PDU mode (its TPDU
        # length, the SMS-DELIVER in hex); text mode (its time stamp,
        # quoted, and the text, 8-bit data as hex)
        day, secs = t
        if self.cmgf == 0:
            scts = bytes((0x42, 0x50, _bcd2(day), _bcd2(secs // 3600), _bcd2(secs // 60 % 60), _bcd2(secs % 60), 0))
            p = pdu.encode_deliver(number, data, dcs, scts)
            return b"%d" % (len(p) - 1 - p[0]), pdu.to_hex(p)
        ts = b'"24/05/%02d,%02d:%02d:%02d+00"' % (day, secs // 3600, secs // 60 % 60, secs % 60)
        return ts, data if pdu.alphabet(dcs) == 0 else pdu.to_hex(data)

    def _cmgl(self, arg):
        # arg: the <stat> (None: 27.005's default, received unread)
        if self.cmgf == 0:
            want = 0 if arg is None else (int(arg) if arg.isdigit() else -1)
        else:
            q = arg.split(b'"') if arg is not None else (b"", b"REC UNREAD", b"")
            name = q[1] if len(q) > 2 else b""
            want = 4 if name == b"ALL" else (_STAT_TEXT.index(name) if name in _STAT_TEXT else -1)
        if not 0 <= want <= 4:
            self.cms(302)
            return
        more = False
        for i in sorted(self.store_):
            e = self.store_[i]
            if want == 4 or e[0] == want:
                self._show(b"+CMGL: ", i, e, more)
                more = True
        self.ok()

    def _cmgd(self, arg):
        f = arg.split(b",")
        if not f[0].isdigit() or (len(f) > 1 and not f[1].isdigit()):
            self.cms(302)
            return
        flag = int(f[1]) if len(f) > 1 else 0
        if flag == 0:
            self.store_.pop(int(f[0]), None)
        else:
            # 1: read; 2: and sent; 3: and unsent; 4: all
            drop = {1: (1,), 2: (1, 3), 3: (1, 2, 3), 4: (0, 1, 2, 3)}.get(flag, ())
            for i in [k for k in self.store_ if self.store_[k][0] in drop]:
                del self.store_[i]
        self.ok()


_OTHERS = {b"+CFUN": GsmEmulator._cfun, b"+CPIN": GsmEmulator._cpin, b"+CSQ": GsmEmulator._csq,
           b"+COPS": GsmEmulator._cops, b"+CNUM": GsmEmulator._cnum, b"+CSCA": GsmEmulator._csca,
           b"+CSCS": GsmEmulator._cscs, b"+CSMP": GsmEmulator._csmp, b"+CNMI": GsmEmulator._cnmi,
           b"+CPMS": GsmEmulator._cpms, b"+CCLK": GsmEmulator._cclk}
