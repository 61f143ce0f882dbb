# An emulated GSM modem for SMS (3GPP TS 27.005 over AT, ref section 6),
# byte for byte, so acomm's SMS driver, someone else's software or a
# terminal program can drive it. Sans-IO: feed(now, bytes), poll(now),
# take_output(). Messages travel through a shared acomm_sim.gsm_net
# GsmNetwork, addressed by phone number.
#
# Commands: AT, ATE0/ATE1, ATV0/ATV1, ATQ0/ATQ1 (chained too), AT&F, ATI,
# AT+CGMI/+GMI, AT+CGMM/+GMM, AT+CGMR/+GMR, AT+CGSN/+GSN, AT+CMEE=<n>, AT+CPIN?, AT+CSCS=...,
# AT+CMGF=<0|1>, AT+CMGF?, AT+CNMI=<mode>,<mt>,..., AT+CSQ, AT+CPMS?,
# AT+CMGS (PDU: =<tpdu length>; text: ="<number>"), AT+CMGR=<i>,
# AT+CMGL (PDU: =<stat 0..4>; text: ="REC UNREAD"|"REC READ"|"ALL"),
# AT+CMGD=<i>[,<flag 0..4>]. Anything else: ERROR. Answers are framed as
# V.250 says for the mode the host set (acomm_sim.atmodem; power-up: echo
# on, verbose): `CR LF text CR LF`; the +CMGS prompt is CR LF "> " (no line
# end); the data line of +CMGR / +CMGL follows its header directly.
#
# Power-up state: echo on, PDU mode, no new-message indications until
# AT+CNMI (mt=1: "+CMTI: "SM",<i>" when a message is stored). The message
# storage is the SIM's and survives a restart. A stored message shows in
# PDU mode as an SMS-DELIVER, in text mode as its text (8-bit data as hex,
# as real modems do). Sending takes send_ms.
#
# Fault modes: set_rssi(n) (0 or 99: no network, +CMS ERROR: 331),
# fail_sends(code, count) (+CMS ERROR: <code>), a full storage (`storage`
# slots; the network keeps what does not fit), plus acomm_sim.faults':
# corrupt_next / truncate_next(b"+CMTI") etc., swallow_next(b"AT+CMGS"),
# noise, reboot(now).

from acomm.drivers import sms_pdu as pdu

from .atmodem import AtModem
from .gsm_net import network_of

_STAT_TEXT = (b"REC UNREAD", b"REC READ", b"STO UNSENT", b"STO SENT")


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


class GsmEmulator(AtModem):
    def __init__(self, medium, address=1, now=0, number=None, rssi=20, storage=20, send_ms=2000,
                 data_timeout_ms=60000, boot_ms=2000, banner=(b"RDY",)):
        AtModem.__init__(self, now, banner, boot_ms)
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
        self._fails = []
        self._reset()
        self.net.attach(self)

    def _reset(self):
        self.cmgf = 0
        self.cnmi_mt = 0
        self.cmee = 0

    # -- faults -------------------------------------------------------------------------------
    def set_rssi(self, rssi):
        self.rssi = rssi

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
        for i in range(1, self.capacity + 1):
            if i not in self.store_:
                secs = (now // 1000) & 0x3FFFFFFF
                self.store_[i] = [0, number, dcs, data, (1 + (secs // 86400) % 28, secs % 86400)]
                if self.cnmi_mt == 1:
                    self.notify(b'+CMTI: "SM",%d' % i)
                return True
        return False

    # -- commands --------------------------------------------------------------------------------
    def _command(self, now, text, c):
        if c.startswith(b"I"):
            self.reply(b"acomm GSM modem emulator")
            self.ok()
        elif c in (b"+CGSN", b"+GSN"):
            self.reply(b"35%013d" % self.address)
            self.ok()
        elif c in (b"+CGMI", b"+GMI"):
            self.reply(b"acomm")
            self.ok()
        elif c in (b"+CGMM", b"+GMM"):
            self.reply(b"GSM modem emulator")
            self.ok()
        elif c in (b"+CGMR", b"+GMR"):
            self.reply(b"Revision: acomm-sim 1")
            self.ok()
        elif c in (b"&F", b"&F0"):
            self.echo = True
            self.verbose = True
            self.quiet = False
            self._reset()
            self.ok()
        elif c.startswith(b"+CMEE="):
            self.cmee = 1
            self.ok()
        elif c == b"+CPIN?":
            self.reply(b"+CPIN: READY")
            self.ok()
        elif c.startswith(b"+CSCS="):
            self.ok()
        elif c in (b"+CMGF=0", b"+CMGF=1"):
            self.cmgf = c[-1] - 48
            self.ok()
        elif c == b"+CMGF?":
            self.reply(b"+CMGF: %d" % self.cmgf)
            self.ok()
        elif c.startswith(b"+CNMI="):
            f = c[6:].split(b",")
            self.cnmi_mt = int(f[1]) if len(f) > 1 and f[1].isdigit() else 0
            self.ok()
        elif c == b"+CSQ":
            self.reply(b"+CSQ: %d,99" % self.rssi)
            self.ok()
        elif c == b"+CPMS?":
            n = len(self.store_)
            self.reply(b'+CPMS: "SM",%d,%d,"SM",%d,%d,"SM",%d,%d' % ((n, self.capacity) * 3))
            self.ok()
        elif c.startswith(b"+CMGS="):
            self._cmgs(now, text[8:])
        elif c.startswith(b"+CMGR="):
            i = c[6:]
            e = self.store_.get(int(i)) if i.isdigit() else None
            if e is None:
                self.cms(321)
                return
            self._show(b"+CMGR: ", None, e)
            self.ok()
        elif c.startswith(b"+CMGL"):
            self._cmgl(c[5:])
        elif c.startswith(b"+CMGD="):
            self._cmgd(c[6:])
        else:
            self.error()

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
        if self.rssi == 0 or self.rssi == 99:
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
        day, secs = t
        if self.cmgf == 0:
            scts = bytes((0x42, 0x50, _bcd2(day), _bcd2(secs // 3600), _bcd2(secs // 60 % 60), _bcd2(secs % 60), 0))
            p = pdu.encode_deliver(number, data, dcs, scts)
            lead = b"%d," % index if index is not None else b""
            self.reply(head + lead + b"%d,,%d" % (stat, len(p) - 1 - p[0]), more)
            self.reply(pdu.to_hex(p), True)
        else:
            ts = b"24/05/%02d,%02d:%02d:%02d+00" % (day, secs // 3600, secs // 60 % 60, secs % 60)
            lead = b"%d," % index if index is not None else b""
            self.reply(head + lead + b'"%s","%s",,"%s"' % (_STAT_TEXT[stat], number.encode(), ts), more)
            self.reply(data if pdu.alphabet(dcs) == 0 else pdu.to_hex(data), True)
        if stat == 0:
            e[0] = 1

    def _cmgl(self, arg):
        if self.cmgf == 0:
            want = int(arg[1:]) if arg[:1] == b"=" and arg[1:].isdigit() else 4
        else:
            q = arg.split(b'"')
            name = q[1] if len(q) > 2 else b"ALL"
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
