# V.250 framing of the AT surface modems, emulators and drivers
# on both runtimes. The emulators answer as ISU AT Command Reference table
# 3-1 and 27.007 say for the mode the host set (verbose: CR LF text CR LF;
# numeric: text CR LF and result "0" CR; ATQ1: no result codes), and the
# Iridium and SMS drivers come up whatever mode a unit was left in (echo
# on/off, verbose/numeric, quiet) and leave it in theirs (ATE0Q0V1).
from acomm.drivers.iridium import IridiumDriver
from acomm.drivers.sms import SmsDriver
from acomm.events import EV_DRIVER_UP, EV_RX, EV_TX_DONE
from acomm_sim.gsm import GsmEmulator, default_number
from acomm_sim.iridium import MODEL, IridiumEmulator
from acomm_sim.medium import Medium


def said(emu, t, text):
    emu.feed(t, text)
    emu.poll(t)
    return emu.take_output()


def test_iridium_emulator_frames_each_mode():
    e = IridiumEmulator(Medium(), 1, boot_ms=0)
    assert said(e, 0, b"AT\r") == b"AT\r\r\nOK\r\n"  # factory defaults: echo, verbose
    assert said(e, 0, b"AT+CGMM\r") == b"AT+CGMM\r\r\n" + MODEL + b"\r\n\r\nOK\r\n"
    assert said(e, 0, b"AT+GMM\r") == b"AT+GMM\r\r\n" + MODEL + b"\r\n\r\nOK\r\n"
    assert said(e, 0, b"AT+GMI\r") == b"AT+GMI\r\r\nIridium\r\n\r\nOK\r\n"
    assert said(e, 0, b"AT+GSN\r") == b"AT+GSN\r\r\n300234010000001\r\n\r\nOK\r\n"
    assert said(e, 0, b"AT+CGMR\r").startswith(b"AT+CGMR\r\r\nCall Processor Version: ")
    assert said(e, 0, b"AT+SBDWB=2\r") == b"AT+SBDWB=2\r\r\nREADY\r\n"
    assert said(e, 0, b"hi\x00\xd1") == b"\r\n0\r\n\r\nOK\r\n"
    assert said(e, 0, b"AT+BOGUS\r") == b"AT+BOGUS\r\r\nERROR\r\n"
    assert said(e, 0, b"ATE0\r") == b"ATE0\r\r\nOK\r\n"  # echoed before it is carried out
    assert said(e, 0, b"ATV0\r") == b"0\r"
    assert said(e, 0, b"AT+CSQ\r") == b"+CSQ:5\r\n0\r"
    assert said(e, 0, b"AT+SBDWB=2\r") == b"READY\r\n"
    assert said(e, 0, b"hi\x00\xd1") == b"0\r\n0\r"
    assert said(e, 0, b"AT+BOGUS\r") == b"4\r"
    assert said(e, 0, b"ATQ1\r") == b""
    assert said(e, 0, b"AT+CSQ\r") == b"+CSQ:5\r\n"  # information text still comes
    assert said(e, 0, b"ATE1Q0V1\r") == b"\r\nOK\r\n"  # typed while the echo was off
    assert said(e, 0, b"ATV2\r") == b"ATV2\r\r\nERROR\r\n"
    assert said(e, 0, b"AT&F0\r") == b"AT&F0\r\r\nOK\r\n"


def test_iridium_ring_alert_is_a_result_code():
    m = Medium()
    e = IridiumEmulator(m, 1, boot_ms=0)
    said(e, 0, b"AT+SBDMTA=1\r")
    e.ring_alert(0)
    assert e.take_output() == b"\r\nSBDRING\r\n"
    said(e, 0, b"ATV0\r")
    e.ring_alert(0)
    assert e.take_output() == b"126\r"


def test_gsm_emulator_frames_each_mode():
    e = GsmEmulator(Medium(), 1, boot_ms=0)
    assert said(e, 0, b"AT+CMGF=1\r") == b"AT+CMGF=1\r\r\nOK\r\n"
    assert said(e, 0, b"AT+GMM\r") == b"AT+GMM\r\r\nGSM modem emulator\r\n\r\nOK\r\n"
    assert said(e, 0, b'AT+CMGS="+10000000000"\r') == b'AT+CMGS="+10000000000"\r\r\n> '
    assert said(e, 0, b"\x1b") == b"\r\nOK\r\n"  # ESC: nothing sent
    assert said(e, 0, b"ATE0V0\r") == b"ATE0V0\r0\r"
    assert said(e, 0, b"AT+CPIN?\r") == b"+CPIN: READY\r\n0\r"
    assert said(e, 0, b"AT+CMGR=7\r") == b"+CMS ERROR: 321\r\n"
    assert said(e, 0, b"ATV1\r") == b"\r\nOK\r\n"


def test_gsm_stored_messages_put_the_text_under_the_header():
    m = Medium()
    e = GsmEmulator(m, 1, boot_ms=0)
    said(e, 0, b"ATE0\r")
    said(e, 0, b"AT+CMGF=1\r")
    e.store(0, "+447700900123", 0, b"one")
    e.store(0, "+447700900123", 0, b"two")
    out = said(e, 0, b'AT+CMGL="ALL"\r')
    lines = out.split(b"\r\n")
    assert lines[0] == b"" and lines[1].startswith(b'+CMGL: 1,"REC UNREAD","+447700900123",,"')
    assert lines[2] == b"one" and lines[3].startswith(b"+CMGL: 2,") and lines[4] == b"two"
    assert out.endswith(b"two\r\n\r\nOK\r\n")
    out = said(e, 0, b"AT+CMGR=2\r")
    assert out.startswith(b'\r\n+CMGR: "REC READ","+447700900123",,"') and out.endswith(b"\r\ntwo\r\n\r\nOK\r\n")


def run(emus, drivers, until, t_end=120000, step=10):
    # drivers[i] on emus[i]; until(events) over each driver's events
    evs = [[] for _ in drivers]
    t = 0
    while t < t_end:
        for i in range(len(drivers)):
            e, d = emus[i], drivers[i]
            e.feed(t, d.take_output())
            e.poll(t)
            d.feed(t, e.take_output())
            d.poll(t)
            evs[i].extend(d.take_events())
        if until(evs, t):
            return evs, t
        t += step
    return evs, None


MODES = ((True, True, False), (False, True, False), (True, False, False), (False, False, False), (True, True, True),
         (False, False, True))


def left_in(e, mode):
    e.echo, e.verbose, e.quiet = mode


def test_iridium_driver_comes_up_from_any_mode_and_sends():
    for mode in MODES:
        e = IridiumEmulator(Medium(), 1, boot_ms=0, session_ms=1000)
        left_in(e, mode)
        d = IridiumDriver()
        sent = []

        def until(evs, t):
            if not sent and EV_DRIVER_UP in [x[0] for x in evs[0]]:
                sent.append(d.send(t, None, b"mode test", False))
            return sent and (EV_TX_DONE, sent[0]) in evs[0]

        evs, t = run([e], [d], until)
        assert t is not None, (mode, evs, d.problem)
        assert (e.echo, e.verbose, e.quiet) == (False, True, False), mode
        assert e.sessions[-1][3] == b"mode test" and d.stats["unexpected"] == 0, mode


def test_sms_driver_comes_up_from_any_mode_and_receives():
    numbers = {1: default_number(1), 2: default_number(2)}
    for mode in MODES:
        m = Medium()
        e = GsmEmulator(m, 1, boot_ms=0, send_ms=200)
        left_in(e, mode)
        d = SmsDriver(1, numbers)
        e.queue_incoming(0, b"mode test", default_number(2))

        def until(evs, t):
            return (EV_RX, 2, 1, b"mode test") in evs[0]

        evs, t = run([e], [d], until)
        assert t is not None, (mode, evs, d.problem)
        assert (e.echo, e.verbose, e.quiet) == (False, True, False), mode


def _garbage(rng, n):
    # random bytes, with command-like pieces mixed in so that the parsers
    # past the "AT" get their share
    pieces = (b"AT", b"AT+", b"\r", b"\n", b"=", b"?", b",", b"\x1a", b"\x1b", b"+SBDWB=", b"+CMGS=", b"+CMGR=",
              b"E", b"V", b"Q", b"0", b"1", b'"')
    out = bytearray()
    while len(out) < n:
        if rng.chance(0.5):
            out.extend(pieces[rng.below(len(pieces))])
        else:
            out.extend(rng.bytes(1 + rng.below(4)))
    return bytes(out)


def test_emulators_take_garbage_and_still_answer():
    from acomm.prng import Prng

    rng = Prng(22)
    for make in (lambda m: IridiumEmulator(m, 1, boot_ms=0, session_ms=100, wb_timeout_ms=500),
                 lambda m: GsmEmulator(m, 1, boot_ms=0, send_ms=100, data_timeout_ms=500)):
        e = make(Medium())
        t = 0
        for _ in range(300):
            e.feed(t, _garbage(rng, 1 + rng.below(40)))
            e.poll(t)
            e.take_output()
            t += 20
        # whatever state the garbage left: data phases and sessions time
        # out, and a plain command line is answered again
        e.poll(t + 60000)
        e.take_output()
        e.feed(t + 60000, b"\rATE1Q0V1\r")
        assert e.take_output().endswith(b"\r\nOK\r\n")
        assert said(e, t + 60000, b"AT+NOSUCH\r") == b"AT+NOSUCH\r\r\nERROR\r\n"
