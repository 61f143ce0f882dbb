# The emulated GSM modem against host software written for a SIM800 or a
# Quectel EC2x (issue 34): python-gsmmodem's connect sequence, then what
# Gammu and ModemManager-like tools ask, each answered as those units answer
# (docs/drivers-sms.md, Conformance), never ERROR; a message sent and one
# received in both modes; the power-up lines; registration reports; errors
# as the units give them; new-message indications as AT+CNMI asks.
from acomm.drivers import sms_pdu as pdu
from acomm_sim.gsm import POWER_UP, GsmEmulator, default_number
from acomm_sim.gsm_general import CLAC
from acomm_sim.gsm_net import GsmNetwork

FINALS = (b"OK", b"ERROR")


def final(line):
    return line in FINALS or line.startswith(b"+CME ERROR") or line.startswith(b"+CMS ERROR")


class Host:
    # A host program's AT layer, as python-gsmmodem's: writes one command,
    # reads lines until its final result; lines that come between commands
    # are unsolicited (kept in urcs); the echo of the command is dropped.
    def __init__(self, emu, t=0, gap_ms=100):
        self.e = emu
        self.t = t
        self.gap_ms = gap_ms  # how long the host takes between commands
        self.urcs = []
        self._buf = b""

    def _lines(self):
        self._buf += self.e.take_output()
        out = []
        while b"\r\n" in self._buf:
            line, self._buf = self._buf.split(b"\r\n", 1)
            line = line.strip()  # the echo ends in CR, as the command did
            if line:
                out.append(line)
        return out

    def wait(self, ms):
        end = self.t + ms
        while self.t < end:
            self.t += 10
            self.e.poll(self.t)
            self.urcs += self._lines()

    def cmd(self, text, timeout_ms=5000, data=None):
        # (information lines, final result); data: written after the "> "
        # prompt, then ^Z
        self.wait(self.gap_ms)
        self.e.feed(self.t, text + b"\r")
        self.e.poll(self.t)
        if data is not None:
            assert self._buf + self.e.take_output() in (text + b"\r\r\n> ", b"\r\n> "), text
            self._buf = b""
            self.e.feed(self.t, data + b"\x1a")
        info = []
        end = self.t + timeout_ms
        while True:
            for line in self._lines():
                if line == text:
                    continue
                if info is None:
                    self.urcs.append(line)  # after the final result
                elif final(line):
                    info, got = None, (info, line)
                else:
                    info.append(line)
            if info is None:
                return got
            if self.t >= end:
                self.urcs += info  # no answer: what came was unsolicited
                return [], None
            self.t += 10
            self.e.poll(self.t)

    def ok(self, text, want=()):
        # the command answers OK with exactly these information lines
        info, res = self.cmd(text)
        assert res == b"OK", (text, info, res)
        assert tuple(info) == tuple(want), (text, info, want)


# python-gsmmodem's GsmModem.connect() (PDU mode, no PIN), command by
# command, with what a SIM800 answers in the same form
PYTHON_GSMMODEM = (
    (b"ATZ", ()),
    (b"ATE0", ()),
    (b"AT+CFUN?", (b"+CFUN: 1",)),
    (b"AT+CMEE=1", ()),
    (b"AT+CPIN?", (b"+CPIN: READY",)),
    (b"AT+CLAC", CLAC),
    (b"AT+CGMI", (b"acomm",)),  # manufacturer: not Huawei, so it asks +ZPAS? (ERROR: not ZTE)
    (b"AT+COPS=3,0", ()),
    (b"AT+CMGF=0", ()),
    (b"AT+CSCA?", (b'+CSCA: "+10000000001",145',)),
    (b"AT+CSMP=49,167,0,0", ()),
    (b"AT+CPMS=?", (b'+CPMS: ("SM"),("SM"),("SM")',)),
    (b'AT+CPMS="SM","SM","SM"', (b"+CPMS: 0,20,0,20,0,20",)),
    (b"AT+CNMI=2,1,0,2", ()),
    (b"AT+CLIP=1", ()),
    (b"AT+CRC=1", ()),
    (b"AT+CVHU=0", ()),
)
# what it and other hosts (Gammu, ModemManager-like tools) ask afterwards
OTHERS = (
    (b"AT+CFUN=1", ()),
    (b"AT+CFUN=?", (b"+CFUN: (0,1,4),(0,1)",)),
    (b"AT+COPS?", (b'+COPS: 0,0,"ACOMM SIM"',)),
    (b"AT+COPS=3,2", ()),
    (b"AT+COPS?", (b'+COPS: 0,2,"00101"',)),
    (b"AT+COPS=0", ()),
    (b"AT+COPS=?", (b'+COPS: (2,"ACOMM SIM","ACOMM","00101"),,(0-4),(0-2)',)),
    (b"AT+CNUM", (b'+CNUM: "","+447700900001",145',)),
    (b"AT+CREG?", (b"+CREG: 0,1",)),
    (b"AT+CREG=1", ()),
    (b"AT+CREG?", (b"+CREG: 1,1",)),
    (b"AT+CREG=2", ()),
    (b"AT+CREG?", (b'+CREG: 2,1,"0001","0001"',)),
    (b"AT+CREG=?", (b"+CREG: (0-2)",)),
    (b"AT+CREG=0", ()),
    (b"AT+CGREG?", (b"+CGREG: 0,1",)),
    (b"AT+CGMM", (b"GSM modem emulator",)),
    (b"AT+CGMR", (b"Revision: acomm-sim 1",)),
    (b"AT+CGSN", (b"350000000000001",)),
    (b"AT+GSN", (b"350000000000001",)),
    (b"AT+CIMI", (b"001010000000001",)),
    (b"ATI", (b"acomm GSM modem emulator",)),
    (b"AT+GCAP", (b"+GCAP: +CGSM",)),
    (b"AT+CSQ", (b"+CSQ: 20,99",)),
    (b"AT+CSQ=?", (b"+CSQ: (0-31,99),(0-7,99)",)),
    (b"AT+CMEE?", (b"+CMEE: 1",)),
    (b"AT+CPIN=?", ()),
    (b"AT+CSCS?", (b'+CSCS: "IRA"',)),
    (b"AT+CSCS=?", (b'+CSCS: ("IRA","GSM","UCS2","HEX")',)),
    (b'AT+CSCS="GSM"', ()),
    (b"AT+CSCS?", (b'+CSCS: "GSM"',)),
    (b"AT+CSMP?", (b"+CSMP: 49,167,0,0",)),
    (b"AT+CSMP=17,167,0,0", ()),
    (b'AT+CSCA="+447785016005",145', ()),
    (b"AT+CSCA?", (b'+CSCA: "+447785016005",145',)),
    (b"AT+CPMS?", (b'+CPMS: "SM",0,20,"SM",0,20,"SM",0,20',)),
    (b"AT+CMGF?", (b"+CMGF: 0",)),
    (b"AT+CMGF=?", (b"+CMGF: (0,1)",)),
    (b"AT+CNMI?", (b"+CNMI: 2,1,0,2,0",)),
    (b"AT+CNMI=?", (b"+CNMI: (0-3),(0-3),(0,2),(0-2),(0,1)",)),
    (b"AT+CNMI=2,1,0,0,0", ()),
    (b"AT+CLIP?", (b"+CLIP: 1,1",)),
    (b"AT+CRC?", (b"+CRC: 1",)),
    (b"AT+CVHU?", (b"+CVHU: 0",)),
    (b"AT+CMGL=?", (b"+CMGL: (0-4)",)),
    (b"AT+CMGD=?", (b"+CMGD: (1-20),(0-4)",)),
    (b"AT+CMGL=4", ()),
    (b"AT+CMGD=1,4", ()),
)


def test_a_host_library_connects_sends_and_receives_as_with_a_sim800():
    for mode in (0, 1):
        net = GsmNetwork(delay_ms=1000)
        e = GsmEmulator(net, 1, send_ms=500, boot_ms=1000, power_up="sim800")
        GsmEmulator(net, 2)  # a peer, to send to
        e.reboot(0)  # switched on as the host starts
        h = Host(e)
        # python-gsmmodem's waitingForModemToStartInSeconds: AT until answered
        while True:
            info, res = h.cmd(b"AT", 500)
            if res == b"OK":
                break
        for text, want in PYTHON_GSMMODEM:
            h.ok(text, want)
        assert h.cmd(b"AT+ZPAS?") == ([], b"ERROR")  # not a ZTE: ERROR, as a SIM800 says
        for text, want in OTHERS:
            h.ok(text, want)
        # the power-up lines came in between the commands, in their order
        assert h.urcs == [ln for _, ln in POWER_UP["sim800"]], h.urcs
        # a message out, one in
        h.ok(b"AT+CMGF=%d" % mode)
        if mode == 0:
            p, n = pdu.encode_submit(default_number(2), b"\x00from the host\xff")
            info, res = h.cmd(b"AT+CMGS=%d" % n, data=pdu.to_hex(p))
        else:
            info, res = h.cmd(b'AT+CMGS="%s"' % default_number(2).encode(), data=b"from the host")
        assert res == b"OK" and info == [b"+CMGS: 1"], (info, res)
        e.queue_incoming(h.t, b"to the host", "+447700900123")
        h.wait(100)
        assert h.urcs[-1] == b'+CMTI: "SM",1'
        info, res = h.cmd(b"AT+CMGR=1")
        assert res == b"OK" and len(info) == 2
        if mode == 0:
            assert info[0] == b"+CMGR: 0,,%d" % (len(pdu.from_hex(info[1])) - 8)
            assert pdu.decode_deliver(pdu.from_hex(info[1]))[:3] == ("+447700900123", 4, b"to the host")
        else:
            assert info[0].startswith(b'+CMGR: "REC UNREAD","+447700900123",,"')
            assert info[1] == b"746F2074686520686F7374"  # 8-bit data as hex
        h.ok(b"AT+CMGD=1")
        assert e.store_ == {} and e.sent[-1][0] == default_number(2)


def test_power_up_lines_of_the_sim800_and_the_ec2x():
    for unit in ("sim800", "ec2x"):
        e = GsmEmulator(GsmNetwork(), 1, boot_ms=1000, power_up=unit)
        e.reboot(0)
        out = []
        for t in range(0, 6000, 10):
            e.poll(t)
            o = e.take_output()
            if o:
                out.append((t, o))
        want = [(1000 + ms, b"\r\n" + ln + b"\r\n") for ms, ln in POWER_UP[unit]]
        assert out == want, (unit, out)
        assert out[0][1] == b"\r\nRDY\r\n" and out[2][1] == b"\r\n+CPIN: READY\r\n"
    # without power_up: the banner (RDY) at once
    e = GsmEmulator(GsmNetwork(), 1, boot_ms=1000)
    e.reboot(0)
    e.poll(1000)
    assert e.take_output() == b"\r\nRDY\r\n"


def said(e, text, t=0):
    e.feed(t, text + b"\r")
    e.poll(t)
    return e.take_output()


def test_registration_reports_follow_the_network_and_the_radio():
    e = GsmEmulator(GsmNetwork(), 3, boot_ms=0)
    said(e, b"ATE0")
    e.set_rssi(99)
    assert e.take_output() == b""  # reports are off at power-up
    e.set_rssi(20)
    assert said(e, b"AT+CREG=1") == b"\r\nOK\r\n"
    e.set_rssi(99)
    assert e.take_output() == b"\r\n+CREG: 2\r\n"  # searching
    assert said(e, b"AT+CREG?") == b"\r\n+CREG: 1,2\r\n\r\nOK\r\n"
    assert said(e, b"AT+COPS?") == b"\r\n+COPS: 0\r\n\r\nOK\r\n"
    e.set_rssi(15)
    assert e.take_output() == b"\r\n+CREG: 1\r\n"
    e.set_rssi(16)
    assert e.take_output() == b""  # no change of registration
    said(e, b"AT+CREG=2")
    said(e, b"AT+CGREG=1")
    # the radio off (AT+CFUN=4, 0) and on: OK, then the reports
    assert said(e, b"AT+CFUN=4") == b"\r\nOK\r\n\r\n+CREG: 0\r\n\r\n+CGREG: 0\r\n"
    assert e.reg_stat() == 0 and said(e, b"AT+CFUN?") == b"\r\n+CFUN: 4\r\n\r\nOK\r\n"
    e.set_rssi(20)
    assert said(e, b"AT+CFUN=0") == b"\r\nOK\r\n"
    assert said(e, b"AT+CSQ") == b"\r\n+CSQ: 99,99\r\n\r\nOK\r\n"
    assert said(e, b"AT+CREG?") == b"\r\n+CREG: 2,0\r\n\r\nOK\r\n"
    assert said(e, b"AT+CFUN=1") == b'\r\nOK\r\n\r\n+CREG: 1,"0001","0003"\r\n\r\n+CGREG: 1\r\n'
    assert said(e, b"AT+CREG?") == b'\r\n+CREG: 2,1,"0001","0003"\r\n\r\nOK\r\n'
    # radio off: sending fails as with no network
    said(e, b"AT+CFUN=0")
    p, n = pdu.encode_submit("+447700900001", b"x")
    assert said(e, b"AT+CMGS=%d" % n) == b"\r\n> "
    e.feed(0, pdu.to_hex(p) + b"\x1a")
    e.poll(3000)
    assert e.take_output() == b"\r\n+CMS ERROR: 331\r\n"
    # AT+CFUN=1,1: OK, then a restart (boot_ms 0: RDY at once), in the
    # power-up settings
    assert said(e, b"AT+CFUN=1,1") == b"\r\nOK\r\n\r\nRDY\r\n"
    assert said(e, b"AT+CREG?") == b"AT+CREG?\r\r\n+CREG: 0,1\r\n\r\nOK\r\n"


def test_errors_as_the_units_give_them():
    e = GsmEmulator(GsmNetwork(), 1, boot_ms=0)
    said(e, b"ATE0")
    for cmee, bad in ((0, b"\r\nERROR\r\n"), (1, b"\r\n+CME ERROR: 50\r\n"),
                      (2, b"\r\n+CME ERROR: Incorrect parameters\r\n")):
        assert said(e, b"AT+CMEE=%d" % cmee) == b"\r\nOK\r\n"
        assert said(e, b"AT+WIND?") == b"\r\nERROR\r\n"  # unknown: ERROR whatever CMEE says
        assert said(e, b"AT+CFUN=7") == bad
        assert said(e, b"AT+CREG=3") == bad
        assert said(e, b'AT+CSCS="KOI8"') == bad
    assert said(e, b"AT+CMEE=1") == b"\r\nOK\r\n"
    assert said(e, b'AT+CPIN="1234"') == b"\r\n+CME ERROR: 3\r\n"  # no PIN asked for
    assert said(e, b"AT+COPS=1,2,\"00102\"") == b"\r\n+CME ERROR: 3\r\n"  # manual selection: not modelled
    assert said(e, b"AT+CNMI=2,1,1") == b"\r\n+CMS ERROR: 303\r\n"
    assert said(e, b'AT+CPMS="ME"') == b"\r\n+CMS ERROR: 302\r\n"
    assert said(e, b"AT+CMGR=9") == b"\r\n+CMS ERROR: 321\r\n"
    assert said(e, b"AT+CSQ?") == b"\r\nERROR\r\n" and said(e, b"AT+CREG?1") == b"\r\nERROR\r\n"
    assert said(e, b"ATZ") == b"\r\nOK\r\n"  # typed with the echo off; then the power-up settings
    assert said(e, b"AT+CMEE?") == b"AT+CMEE?\r\r\n+CMEE: 0\r\n\r\nOK\r\n"


def test_new_message_indications_as_cnmi_asks():
    e = GsmEmulator(GsmNetwork(), 1, boot_ms=0)
    said(e, b"ATE0")
    e.store(0, "+447700900123", 4, b"a")
    assert e.take_output() == b""  # power-up: 0,0,0,0,0
    for cnmi, shows in ((b"0,1", False), (b"2,1", True), (b"1,3,0,0,0", True)):
        said(e, b"AT+CNMI=" + cnmi)
        e.store(0, "+447700900123", 4, b"b")
        out = e.take_output()
        assert (out == b'\r\n+CMTI: "SM",%d\r\n' % max(e.store_)) if shows else out == b"", (cnmi, out)
    # AT+CMGL without <stat>: the received unread ones (27.005's default)
    said(e, b"AT+CMGR=1")
    out = said(e, b"AT+CMGL")
    assert out.startswith(b"\r\n+CMGL: 2,0,,") and b"+CMGL: 1," not in out and out.count(b"+CMGL:") == len(e.store_) - 1
    n = len(e.store_)
    said(e, b"AT+CNMI=2,2,0,0,0")  # routed to the host, not stored
    e.store(0, "+447700900123", 4, b"direct")
    out = e.take_output().split(b"\r\n")
    assert out[1].startswith(b"+CMT: ,") and len(e.store_) == n
    raw = pdu.from_hex(out[2])
    assert int(out[1][7:]) == len(raw) - 1 - raw[0] and pdu.decode_deliver(raw)[2] == b"direct"
    said(e, b"AT+CMGF=1")
    e.store(0, "+447700900123", 0, b"plain")
    out = e.take_output()
    assert out.startswith(b'\r\n+CMT: "+447700900123",,"24/05/') and out.endswith(b'"\r\nplain\r\n')
