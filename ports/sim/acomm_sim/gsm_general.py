# The 27.007 half of the emulated GSM modem (acomm_sim.gsm): what the
# mobile equipment answers whatever it is used for, the identification,
# the settings of one number (AT+CMEE, +CREG, +CLIP ...), the radio
# (AT+CFUN), the SIM (AT+CPIN), the signal (AT+CSQ), the operator
# (AT+COPS), the own number (AT+CNUM), the character set (AT+CSCS), the
# registration and its reports, the clock (AT+CCLK), and +CME ERROR as
# AT+CMEE says. A mixin of
# GsmEmulator, which holds the state these read (rssi, cfun, creg, ...)
# and the network; the SMS commands (27.005) are its own.

_CHARSETS = (b"IRA", b"GSM", b"UCS2", b"HEX")
# AT+CLAC: the commands answered here, one a line without "AT", as SIM800
# and EC2x list theirs
CLAC = (b"&F", b"E", b"I", b"Q", b"V", b"Z", b"+CFUN", b"+CGMI", b"+CGMM", b"+CGMR", b"+CGREG", b"+CGSN", b"+CIMI",
        b"+CCLK", b"+CLAC", b"+CLIP", b"+CMEE", b"+CMGD", b"+CMGF", b"+CMGL", b"+CMGR", b"+CMGS", b"+CNMI", b"+CNUM", b"+COPS",
        b"+CPIN", b"+CPMS", b"+CRC", b"+CREG", b"+CSCA", b"+CSCS", b"+CSMP", b"+CSQ", b"+CVHU", b"+GCAP", b"+GMI",
        b"+GMM", b"+GMR", b"+GSN")
# settings of one number: name -> highest value (the attribute is the name
# in lower case without "+")
SETTINGS = {b"+CMEE": 2, b"+CREG": 2, b"+CGREG": 2, b"+CLIP": 1, b"+CRC": 1, b"+CVHU": 1, b"+CMGF": 1}
_CME_TEXT = {3: b"operation not allowed", 4: b"operation not supported", 50: b"Incorrect parameters"}


class GeneralCommands:
    """The 27.007 commands of GsmEmulator (a mixin: the state is the emulator's)."""

    def reg_stat(self):
        # 27.007 <stat>: 1 registered (home network), 2 searching (rssi 0
        # or 99: no network here), 0 not searching (radio off, AT+CFUN=0/4)
        if self.cfun != 1:
            return 0
        return 2 if self.rssi in (0, 99) else 1

    def _reg(self, n, stat):
        # "<stat>" or, with n=2 and registered, "<stat>,"<lac>","<ci>""
        if n == 2 and stat == 1:
            return b'%d,"%04X","%04X"' % (stat, 1, self.address & 0xFFFF)
        return b"%d" % stat

    def _reg_moved(self, before):
        # +CREG / +CGREG reports, where turned on, when the registration changed
        stat = self.reg_stat()
        if stat != before:
            for name, n in ((b"+CREG", self.creg), (b"+CGREG", self.cgreg)):
                if n:
                    self.notify(name + b": " + self._reg(n, stat))

    def _ident(self, name):
        # the identification commands' text, or None
        if name in (b"+CGMI", b"+GMI"):
            return b"acomm"
        if name in (b"+CGMM", b"+GMM"):
            return b"GSM modem emulator"
        if name in (b"+CGMR", b"+GMR"):
            return b"Revision: acomm-sim 1"
        if name in (b"+CGSN", b"+GSN"):
            return b"35%013d" % self.address
        if name == b"+CIMI":
            return b"00101%010d" % self.address  # MCC 001 MNC 01: the test network
        if name == b"+GCAP":
            return b"+GCAP: +CGSM"
        return None

    def _setting(self, name, op, arg):
        attr = name[1:].decode().lower()
        if op == b"=":
            v = nums(arg, 1, 1)
            if v is None or v[0] > SETTINGS[name]:
                self.cme(50)
                return
            setattr(self, attr, v[0])
        elif op == b"?":
            n = getattr(self, attr)
            if name in (b"+CREG", b"+CGREG"):
                self.reply(name + b": %d," % n + self._reg(n, self.reg_stat()))
            elif name == b"+CLIP":
                self.reply(b"+CLIP: %d,1" % n)  # 1: CLIP provisioned
            else:
                self.reply(name + b": %d" % n)
        elif op == b"=?":
            self.reply(name + (b": (0-2)" if SETTINGS[name] == 2 else b": (0,1)"))
        else:
            self.error()
            return
        self.ok()

    def _cfun(self, now, op, arg):
        if op == b"?":
            self.reply(b"+CFUN: %d" % self.cfun)
        elif op == b"=?":
            self.reply(b"+CFUN: (0,1,4),(0,1)")
        elif op == b"=":
            v = nums(arg, 1, 2)
            if v is None or v[0] not in (0, 1, 4) or (len(v) == 2 and v[1] > 1):
                self.cme(50)
                return
            before = self.reg_stat()
            self.cfun = v[0]
            self.ok()
            if len(v) == 2 and v[1] == 1:
                self.reboot(now)  # <rst> 1: a restart after OK
            else:
                self._reg_moved(before)
            return
        else:
            self.error()
            return
        self.ok()

    def _cpin(self, now, op, arg):
        if op == b"?":
            self.reply(b"+CPIN: READY")
        elif op == b"=":
            self.cme(3)  # no PIN is asked for
            return
        elif op != b"=?":
            self.error()
            return
        self.ok()

    def _csq(self, now, op, arg):
        if op == b"":
            self.reply(b"+CSQ: %d,99" % (self.rssi if self.cfun == 1 else 99))
        elif op == b"=?":
            self.reply(b"+CSQ: (0-31,99),(0-7,99)")
        else:
            self.error()
            return
        self.ok()

    def _cops(self, now, op, arg):
        names = self.net.operator  # long, short, numeric
        if op == b"?":
            if self.reg_stat() == 1:
                self.reply(b'+COPS: 0,%d,"%s"' % (self.cops_format, names[self.cops_format]))
            else:
                self.reply(b"+COPS: 0")
        elif op == b"=?":
            self.reply(b'+COPS: (2,"%s","%s","%s"),,(0-4),(0-2)' % names)
        elif op == b"=":
            # 0: automatic (optionally with the format), 3: set the format;
            # manual selection and deregistration are not modelled
            f = arg.split(b",")
            mode = nums(f[0], 1, 1)
            if mode is not None and mode[0] in (1, 2, 4):
                self.cme(3)
                return
            v = nums(arg, 1, 2)
            if v is None or v[0] not in (0, 3) or (v[0] == 3 and len(v) < 2) or (len(v) == 2 and v[1] > 2):
                self.cme(50)
                return
            if len(v) == 2:
                self.cops_format = v[1]
        else:
            self.error()
            return
        self.ok()

    def _cnum(self, now, op, arg):
        if op == b"":
            self.reply(b'+CNUM: "","%s",%d' % (self.number.encode(), toa(self.number)))
        elif op != b"=?":
            self.error()
            return
        self.ok()

    def _cscs(self, now, op, arg):
        if op == b"?":
            self.reply(b'+CSCS: "%s"' % self.cscs)
        elif op == b"=?":
            self.reply(b'+CSCS: ("' + b'","'.join(_CHARSETS) + b'")')
        elif op == b"=":
            q = arg.strip(b'"')
            if q not in _CHARSETS:
                self.cme(50)
                return
            self.cscs = q
        else:
            self.error()
            return
        self.ok()

    def cme(self, code):
        # an error of the ME: +CME ERROR as AT+CMEE says (0: ERROR)
        if self.cmee == 0:
            self.error()
        elif self.cmee == 1:
            self.reply(b"+CME ERROR: %d" % code)
        else:
            self.reply(b"+CME ERROR: " + _CME_TEXT.get(code, b"unknown"))

# The clock, AT+CCLK (27.007 8.15): +CCLK: "yy/MM/dd,hh:mm:ss±zz", local
# time in zone zz (quarter hours). While registered with network_time the
# network has set it (NITZ): the simulated world's time (wall0_s + now, in
# seconds from 2020-01-01 UTC), shown in zone `tz`; it keeps that time
# after the registration is lost. Without network time, the unit's own RTC
# from power-up at 1980-01-06 00:00:00 (as Quectel units start), or what
# the host set with AT+CCLK="...". Power-up forgets all but the network's
# next setting.
RTC_POWER_UP_S = -14605 * 86400  # 1980-01-06 from 2020-01-01


class Clock:
    """The +CCLK half of GsmEmulator (a mixin: wall0_s, network_time, tz are the emulator's)."""

    def _reset_clock(self, now):
        self._nitz = False
        self._rtc = (now, RTC_POWER_UP_S, 0)  # (at, secs then, zone)

    def clock_secs(self, now):
        # (secs from 2020-01-01 UTC, zone) the unit's clock shows now
        if self.network_time and self.reg_stat() == 1:
            self._nitz = True
        if self._nitz:
            return self.wall0_s + now // 1000, self.tz
        at, secs, tz = self._rtc
        return secs + (now - at) // 1000, tz

    def _cclk(self, now, op, arg):
        if op == b"?":
            secs, tz = self.clock_secs(now)
            self.reply(cclk_text(secs, tz))
        elif op == b"=?":
            pass
        elif op == b"=":
            from acomm.drivers.sms_wire import parse_cclk
            from acomm.errors import DecodeError

            try:
                r = parse_cclk(b"+CCLK: " + arg)
            except DecodeError:
                self.cme(50)
                return
            if r is None:  # a date before 2024, taken as set all the same
                r = (_raw_cclk(arg), 0)
            tz = _zone(arg)
            self._nitz = False
            self._rtc = (now, r[0], tz)
        else:
            self.error()
            return
        self.ok()


def _zone(arg):
    q = arg.strip(b'"')
    for i in range(len(q) - 1, 0, -1):
        if q[i] in (43, 45):
            return int(q[i + 1:]) * (-1 if q[i] == 45 else 1)
        if q[i] == 58:  # ":"
            break
    return 0


def _raw_cclk(arg):
    # secs from 2020-01-01 UTC of a time the host set, any year
    from acomm.civil import days2020

    q = arg.strip(b'"')
    date, hms = q.split(b",")
    y, mo, d = [int(x) for x in date.split(b"/")]
    h, m, s = [int(x) for x in hms[:8].split(b":")]
    return days2020(2000 + y if y < 70 else 1900 + y, mo, d) * 86400 + h * 3600 + m * 60 + s - _zone(arg) * 900


def civil(days):
    """(year, month, day) of `days` from 2020-01-01 (the inverse of acomm.wallclock.days2020)."""
    z = days + 737730  # days from 0000-03-01
    era = z // 146097
    doe = z - era * 146097
    yoe = (doe - doe // 1460 + doe // 36524 - doe // 146096) // 365
    doy = doe - (365 * yoe + yoe // 4 - yoe // 100)
    mp = (5 * doy + 2) // 153
    d = doy - (153 * mp + 2) // 5 + 1
    m = mp + 3 if mp < 10 else mp - 9
    return yoe + era * 400 + (1 if m <= 2 else 0), m, d


def cclk_text(secs, tz=0):
    """The +CCLK answer for secs from 2020-01-01 UTC, shown in zone tz (quarter hours)."""
    local = secs + tz * 900
    y, mo, d = civil(local // 86400)
    t = local % 86400
    return b'+CCLK: "%02d/%02d/%02d,%02d:%02d:%02d%s%02d"' % (
        y % 100, mo, d, t // 3600, t // 60 % 60, t % 60, b"-" if tz < 0 else b"+", abs(tz))


def split(c):
    # b"+CREG=1" -> (b"+CREG", b"=", b"1"); b"+CREG?" -> (.., b"?", b"");
    # b"+CREG=?" -> (.., b"=?", b""); b"+CSQ" -> (b"+CSQ", b"", b"")
    i = 0
    while i < len(c) and c[i] != 61 and c[i] != 63:
        i += 1
    rest = c[i:]
    if rest[:2] == b"=?":
        return c[:i], b"=?", rest[2:]
    return c[:i], rest[:1], rest[1:]


def nums(arg, lo, hi):
    # b"2,1,0,0,0" -> [2, 1, 0, 0, 0]; None unless lo..hi decimal fields
    f = arg.split(b",")
    if not lo <= len(f) <= hi:
        return None
    out = []
    for x in f:
        x = x.strip()
        if not x.isdigit() or len(x) > 5:
            return None
        out.append(int(x))
    return out


def toa(number):
    # type of address: 145 international ("+"), 129 national
    return 145 if number.startswith("+") else 129
