# acomm_cpython.emulate.modemtaps: the readers that say, from a serial line's bytes
# alone, what a SeaTrac beacon and an Iridium modem did with them (the
# figures of `acomm bench board` rest on them). Each is checked against the
# emulated modem's own record of the same bytes: acomm's real driver talks
# to the emulator on a virtual clock, every byte passing through the reader,
# with failed sessions, a dropped MO buffer, a ring alert and an MT block.
# And the Bridge between two ptys.

from acomm import frame
from acomm.drivers.iridium import IridiumDriver
from acomm.drivers.seatrac import SeatracDriver
from acomm.events import EV_DRIVER_UP, EV_RX
from acomm.transport import segment as sg
from acomm_cpython.emulate import modemtaps as mt
from acomm_cpython.emulate.pty import PtyPair
from acomm_sim.iridium import IridiumEmulator
from acomm_sim.iridium_net import IridiumNetwork
from acomm_sim.medium import Medium
from acomm_sim.seatrac import SeatracEmulator


def _relay(drv, emu, line, now, others=()):
    drv.poll(now)
    out = drv.take_output()
    if out:
        line.feed(mt.DEVICE, out)
        emu.feed(now, out)
    for e in (emu,) + tuple(others):
        e.poll(now)
    got = emu.take_output()
    if got:
        line.feed(mt.HOST, got)
        drv.feed(now, got)
    return drv.take_events()


def test_iridium_reader_agrees_with_the_modem():
    net = IridiumNetwork(min_latency_ms=500, max_latency_ms=500)
    emu = IridiumEmulator(net, 1, session_ms=300, boot_ms=50)
    far = IridiumEmulator(net, 3, session_ms=300, boot_ms=50)
    drv = IridiumDriver(retry_first_ms=500, retry_max_ms=500, mailbox_check_ms=0)
    line = mt.IridiumLine()
    emu.fail_sessions(32, 2)  # the first message goes on the third session
    todo = [b"first", b"second \r\n AT+SBDIX\r", bytes(range(40))]
    now = 0
    while now < 60000 and (todo or len(line.mt_read) < 1):
        now += 10
        if now == 20000:
            net.queue_mt(now, emu.imei, b"for the buoy")  # a ring alert, then an SBDRB
        for ev in _relay(drv, emu, line, now, (far,)):
            assert ev[0] != EV_DRIVER_UP or now < 5000
        if todo and drv.ready(now):
            drv.send(now, None, todo.pop(0))
        net.poll(now)
    truth = [s[3] for s in emu.sessions if s[3] is not None]
    assert line.mo_sent == truth == [b"first", b"second \r\n AT+SBDIX\r", bytes(range(40))]
    assert [s[0] for s in line.sessions] == [s[2] for s in emu.sessions]
    assert [s[0] for s in line.sessions][:2] == [32, 32]
    assert line.mt_read == [b"for the buoy"]
    # the messages went in the first seconds, the MT message came at 20 s
    assert line.order == [("mo", m) for m in truth] + [("mt", b"for the buoy")]


def test_iridium_reader_a_buffer_cleared_or_refused_is_not_sent():
    line = mt.IridiumLine()
    for to, data in [(mt.DEVICE, b"AT+SBDWB=2\r"), (mt.HOST, b"\r\nREADY\r\n"), (mt.DEVICE, b"hi\x00\xd1"),
                     (mt.HOST, b"\r\n2\r\n\r\nOK\r\n"),  # checksum refused: not loaded
                     (mt.DEVICE, b"AT+SBDIX\r"), (mt.HOST, b"\r\n+SBDIX: 0, 1, 0, 0, 0, 0\r\n\r\nOK\r\n"),
                     (mt.DEVICE, b"AT+SBDWB=2\r"), (mt.HOST, b"\r\nREADY\r\n"), (mt.DEVICE, b"hi\x00\xd1"),
                     (mt.HOST, b"0\r"), (mt.HOST, b"0\r"),  # numeric results: loaded
                     (mt.DEVICE, b"AT+SBDD0\r"), (mt.HOST, b"0\r0\r"),  # and cleared
                     (mt.DEVICE, b"AT+SBDIX\r"), (mt.HOST, b"+SBDIX: 0, 2, 0, 0, 0, 0\r0\r")]:
        line.feed(to, data)
    assert line.sessions == [(0, None), (0, None)] and line.mo_sent == []


def _segment_frame(head, payload):
    return frame.encode_elided(frame.Frame(frame.SEGMENT, 0, 0, head, payload))


def test_seatrac_reader_sees_fragments_in_and_completions_out():
    med = Medium(default_distance=100.0, seed=1)
    emus = [SeatracEmulator(med, 1, boot_ms=50), SeatracEmulator(med, 2, boot_ms=50)]
    drvs = [SeatracDriver(1), SeatracDriver(2)]
    lines = [mt.SeatracLine(1), mt.SeatracLine(2)]
    head, first = sg.frag_header(True, 0, 0, 0)
    frag = _segment_frame(head, first + sg.packet_header(7, 1, relay=(2, 3, 10, 600)) + b"\x80")
    done = _segment_frame(*sg.sack_complete(0, 0, 1, 7))
    # beacon 2's fragment to 1, then (once it arrived: half duplex) 1's completion to 2
    todo = [(1, 1, frag), (0, 2, done)]
    got = []
    now = 0
    while now < 30000 and len(got) < 2:
        now += 10
        for i in (0, 1):
            for ev in _relay(drvs[i], emus[i], lines[i], now):
                if ev[0] == EV_RX:
                    got.append((i, ev[1], ev[3]))
        med.poll(now)
        if todo and len(todo) == 2 - len(got) and drvs[todo[0][0]].ready(now):
            i, to, data = todo.pop(0)
            drvs[i].send(now, to, data)
    assert got == [(0, 2, frag), (1, 1, done)]
    assert lines[0].heard == [(2, 3, 7)] and lines[0].custody == [7]
    assert lines[1].heard == [] and lines[1].custody == [] and lines[0].junk == lines[1].junk == 0
    assert mt.relayed_fragments([]) == [] and mt.completions([]) == []


def test_relayed_fragments_and_completions_of_raw_frames():
    def raw(src, dst, head, payload):
        return frame.encode_raw(frame.Frame(frame.SEGMENT, src, dst, head, payload))

    h0, i0 = sg.frag_header(False, 1, 0, 0)
    h1, i1 = sg.frag_header(True, 1, 0, 1)
    hp, ip = sg.frag_header(True, 1, 0, 1)
    msgs = [raw(1, 3, h0, i0 + sg.packet_header(9, 40, relay=(2, 3, 10, 60)) + b"x" * 20),
            raw(1, 3, h1, i1 + b"y" * 20), raw(1, 3, hp, ip),  # a bare poll carries nothing
            raw(3, 1, *sg.sack_complete(1, 0, 2, 9)), b"\x00junk"]
    assert mt.relayed_fragments(msgs) == [(2, 3, 9, 0), (2, 3, 9, 1)]
    assert mt.completions(msgs) == [9]


def test_bridge_copies_both_ways_and_taps_in_order():
    import serial

    # two null-modem pairs: the test's ends play the board and the modem
    board, modem = PtyPair(), PtyPair()
    seen = []
    br = mt.Bridge(board.path_b, modem.path_a, tap=lambda to, d: seen.append((to, d)))
    a = serial.Serial(board.path_a, timeout=2)
    b = serial.Serial(modem.path_b, timeout=2)
    try:
        a.write(b"to the modem\n")
        assert b.read(13) == b"to the modem\n"
        b.write(b"to the board\n")
        assert a.read(13) == b"to the board\n"
        a.write(b"again\n")
        assert b.read(6) == b"again\n"
    finally:
        a.close()
        b.close()
        br.close()
        board.close()
        modem.close()
    # chunks of one direction joined: a pty may split a write
    joined = []
    for to, d in seen:
        if joined and joined[-1][0] == to:
            joined[-1] = (to, joined[-1][1] + d)
        else:
            joined.append((to, d))
    assert joined == [(mt.DEVICE, b"to the modem\n"), (mt.HOST, b"to the board\n"), (mt.DEVICE, b"again\n")]
