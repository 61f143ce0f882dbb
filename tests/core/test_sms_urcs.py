# The SMS driver among the unsolicited lines a SIM800 or a Quectel EC2x
# prints at any time (issue 34): power-up lines (RDY, +CFUN: 1, +CPIN:
# READY, Call Ready, SMS Ready, +QUSIM, +QIND), registration reports
# (+CREG, +CGREG), calls (RING, +CLIP). Fed between and inside the driver's
# exchanges, byte for byte, they change nothing: the same commands go out,
# messages go and come, nothing is taken for an answer. RDY is a restart
# (configure again, once, whatever power-up lines follow); "+CPIN: NOT
# READY" takes the driver down until the SIM is back. Then the driver
# against the emulator restarting with the SIM800 and EC2x power-up lines.
from acomm.drivers import sms_pdu as pdu
from acomm.drivers.sms import SmsDriver
from acomm.events import EV_DRIVER_DOWN, EV_DRIVER_UP, EV_RX, EV_TX_DONE, EV_TX_FAILED
from acomm_sim.gsm import GsmEmulator, default_number
from acomm_sim.gsm_net import GsmNetwork
from surfacenet import Fed, Rig

REF_PDU = b"0001000C9144770009103200040548656C6C6F"
REF_NUMBER = "+447700900123"
NUMBERS = {1: default_number(1), 2: default_number(2), 5: REF_NUMBER}
SEND = object()  # in a script: the driver is given a message
URCS = (b"+CREG: 1", b'+CREG: 1,"0001","0002"', b"+CGREG: 5", b"+CPIN: READY", b"+CFUN: 1", b"Call Ready",
        b"SMS Ready", b"+QUSIM: 1", b"+QIND: SMS DONE", b"RING", b'+CLIP: "+447700900123",145,"",0,"",0')


def script(pdu_mode):
    # the driver's whole life in one mode: (bytes from the modem or None for
    # a poll, what the driver writes then)
    deliver = pdu.encode_deliver(REF_NUMBER, b"frame")
    steps = [
        (None, b"ATE0Q0V1\r"),
        (b"ATE0Q0V1\r\r\nOK\r\n", b"AT+CMEE=1\r"),
        (b"\r\nOK\r\n", b"AT+CPIN?\r"),
        (b"\r\n+CPIN: READY\r\n\r\nOK\r\n", b"AT+CMGF=0\r" if pdu_mode else b"AT+CMGF=1\r"),
    ]
    if not pdu_mode:
        steps.append((b"\r\nOK\r\n", b'AT+CSCS="GSM"\r'))
    steps += [
        (b"\r\nOK\r\n", b"AT+CNMI=2,1,0,0,0\r"),
        (b"\r\nOK\r\n", b"AT+CSQ\r"),
        (b"\r\n+CSQ: 17,99\r\n\r\nOK\r\n", b"AT+CMGL=4\r" if pdu_mode else b'AT+CMGL="ALL"\r'),
        (b"\r\nOK\r\n", b""),
        (SEND, b"AT+CMGS=18\r" if pdu_mode else b'AT+CMGS="+447700900123"\r'),
        (b"\r\n> ", REF_PDU + b"\x1a" if pdu_mode else b"SGVsbG8=\x1a"),
        (b"\r\n+CMGS: 12\r\n\r\nOK\r\n", b""),
        (b'\r\n+CMTI: "SM",3\r\n', b"AT+CMGR=3\r"),
    ]
    if pdu_mode:
        cmgr = b"\r\n+CMGR: 0,,%d\r\n%s\r\n\r\nOK\r\n" % (len(deliver) - 8, pdu.to_hex(deliver))
        steps.append((cmgr, b"AT+CMGD=3\r"))
    else:
        steps.append((b'\r\n+CMGR: "REC UNREAD","+447700900123",,"24/05/01,12:00:00+00"\r\nZnJhbWU=\r\n\r\nOK\r\n',
                      b"AT+CMGD=3\r"))
    steps.append((b"\r\nOK\r\n", b""))
    return steps


def play(pdu_mode, extra=None):
    # the script, with extra(i, chunk) -> chunk with lines put in; returns
    # the driver and its events; asserts every write is the script's
    f = Fed(SmsDriver(1, NUMBERS, pdu_mode=pdu_mode, time_period_ms=0))
    for i, (chunk, want) in enumerate(script(pdu_mode)):
        if chunk is None:
            out = f.poll()
        elif chunk is SEND:
            f.d.send(f.t, 5, b"Hello")
            out = f.d.take_output()
        else:
            out = f.answer(extra(i, chunk) if extra else chunk)
        assert out == want, (i, out, want)
    return f.d, f.take()


def between_lines(chunk, lines):
    # chunk with one of `lines` (CR LF around it) at every line boundary:
    # its start, after each LF, and its end
    out = bytearray()
    k = 0
    for j in range(len(chunk) + 1):
        if j == 0 or chunk[j - 1] == 10 or j == len(chunk):
            out += b"\r\n" + lines[k % len(lines)] + b"\r\n"
            k += 1
        if j < len(chunk):
            out.append(chunk[j])
    return bytes(out)


def test_unsolicited_lines_anywhere_change_nothing():
    for pdu_mode in (True, False):
        d0, clean = play(pdu_mode)
        assert [e[0] for e in clean] == [EV_DRIVER_UP, EV_TX_DONE, EV_RX] and clean[2][3] == b"frame"
        # each line alone at every boundary, then all of them in turn
        for lines in [(u,) for u in URCS] + [URCS]:
            d, evs = play(pdu_mode, lambda i, c: between_lines(c, lines))
            assert evs == clean, (lines, evs)
            assert d.stats["unexpected"] == 0 and d.stats["reboots"] == 0 and d.stats["sim_lost"] == 0, lines
            assert d.stats["received"] == 1 and d.stats["sent"] == 1 and d.junk == {}, lines
            assert d.stats["urcs_other"] > 0 and d.at.stats["urcs"] > d0.at.stats["urcs"]


def up_fed():
    f = Fed(SmsDriver(1, NUMBERS, time_period_ms=0))
    for chunk, want in script(True)[:8]:
        assert (f.poll() if chunk is None else f.answer(chunk)) == want
    f.take()
    return f


def configure(f, echo=b"ATE0Q0V1\r", cpin=b"+CPIN: READY"):
    # the modem configured again (echo on: it restarted); the driver's writes
    assert f.answer(echo + b"\r\nOK\r\n") == b"AT+CMEE=1\r"
    assert f.answer(b"\r\nOK\r\n") == b"AT+CPIN?\r"
    return f.answer(b"\r\n%s\r\n\r\nOK\r\n" % cpin)


def test_rdy_is_one_restart_and_the_power_up_lines_after_it_are_not():
    f = up_fed()
    d = f.d
    h = d.send(f.t, 5, b"Hello")
    assert d.take_output() == b"AT+CMGS=18\r"
    assert f.answer(b"\r\n> ") == REF_PDU + b"\x1a"
    # the modem restarts while sending, then prints the SIM800's lines
    assert f.answer(b"\r\nRDY\r\n") == b"ATE0Q0V1\r"
    assert f.take() == [(EV_DRIVER_DOWN, "modem rebooted"), (EV_TX_FAILED, h, "modem rebooted")]
    assert f.answer(b"\r\n+CFUN: 1\r\n\r\n+CPIN: READY\r\n") == b""
    assert configure(f) == b"AT+CMGF=0\r"
    assert f.answer(b"\r\nOK\r\n\r\nCall Ready\r\n") == b"AT+CNMI=2,1,0,0,0\r"
    assert f.answer(b"\r\nSMS Ready\r\n\r\nOK\r\n") == b"AT+CSQ\r"
    assert f.answer(b"\r\n+CSQ: 17,99\r\n\r\nOK\r\n") == b"AT+CMGL=4\r"
    assert f.answer(b"\r\nOK\r\n") == b"" and f.take() == [(EV_DRIVER_UP,)]
    assert d.stats["reboots"] == 1 and d.stats["unexpected"] == 0
    # and it sends again
    h = d.send(f.t, 5, b"Hello")
    assert d.take_output() == b"AT+CMGS=18\r"
    assert f.answer(b"\r\n> ") == REF_PDU + b"\x1a"
    assert f.answer(b"\r\n+CMGS: 13\r\n\r\nOK\r\n") == b"" and f.take() == [(EV_TX_DONE, h)]


def test_a_sim_that_goes_away_takes_the_driver_down_until_it_is_back():
    f = up_fed()
    d = f.d
    # the SIM fails in the middle of a listing: the listing ends first
    assert f.poll(60000) == b"AT+CSQ\r"
    assert f.answer(b"\r\n+CSQ: 17,99\r\n\r\nOK\r\n") == b""
    assert f.poll(240000) == b"AT+CMGL=4\r"
    assert f.answer(b"\r\n+CPIN: NOT READY\r\n") == b""
    assert f.answer(b"\r\nOK\r\n") == b"ATE0Q0V1\r"
    assert f.take() == [(EV_DRIVER_DOWN, "SIM not ready (+CPIN: NOT READY)")]
    assert d.stats["sim_lost"] == 1 and not d.ready(f.t)
    # still no SIM: the start-up stops at AT+CPIN? and is tried again (the
    # modem did not restart: no echo)
    assert configure(f, b"", b"+CPIN: NOT READY") == b""
    assert d.problem == "AT+CPIN?: no +CPIN: READY" and f.take() == []
    assert f.poll(5000) == b"ATE0Q0V1\r"
    assert configure(f, b"") == b"AT+CMGF=0\r"
    assert f.answer(b"\r\nOK\r\n") == b"AT+CNMI=2,1,0,0,0\r"
    assert f.answer(b"\r\nOK\r\n") == b"AT+CSQ\r"
    assert f.answer(b"\r\n+CSQ: 17,99\r\n\r\nOK\r\n") == b"AT+CMGL=4\r"
    assert f.take() == [(EV_DRIVER_UP,)] and d.ready(f.t)
    assert d.stats["unexpected"] == 0


# -- against the emulator -------------------------------------------------------------------
def test_emulated_units_restart_with_their_power_up_lines_and_registration_reports():
    for unit in ("sim800", "ec2x"):
        opts = {"retry_ms": 1000, "csq_retry_ms": 5000, "list_period_ms": 60000}
        r = Rig([SmsDriver(i + 1, NUMBERS, **opts) for i in range(2)],
                lambda net, a: GsmEmulator(net, a, send_ms=1000, boot_ms=500, power_up=unit), GsmNetwork(delay_ms=2000))
        assert r.up(5000)
        a, b = r.drivers
        ea = r.emus[0]
        ea.reboot(r.now())
        assert r.run(20000, until=lambda: a.stats["reboots"] == 1 and a.ready(r.now()))
        r.run(5000)  # the rest of the power-up lines come in
        assert a.stats["reboots"] == 1 and a.ready(r.now()) and a.stats["urcs_other"] >= 2, unit
        # another host turned registration reports on (and they survive as
        # URCs while the driver works)
        ea.creg = 2
        ea.set_rssi(99)
        ea.set_rssi(18)
        h = a.send(r.now(), 2, b"after the restart")
        assert r.run(30000, until=r.got(1, EV_RX)), unit
        assert r.of(1, EV_RX) == [(EV_RX, 1, 2, b"after the restart")] and (EV_TX_DONE, h) in r.of(0, EV_TX_DONE)
        b.send(r.now(), 1, b"and back")
        assert r.run(30000, until=r.got(0, EV_RX)), unit
        for d in r.drivers:
            assert d.stats["unexpected"] == 0 and d.junk == {}, (unit, d.stats)
        assert a.stats["reboots"] == 1 and b.stats["reboots"] == 0
