# The name tables of statuses, availabilities, refusals and modem status
# codes are constants, tuples or packed strings (they stay in flash when
# frozen, where a dict would be built on the heap): each name sits at its
# code.
from acomm import events as ev
from acomm.transport import segment as sg
from acomm.drivers import iridium_wire, seatrac_wire
from acomm.drivers import seatrac_codes as sc


def test_status_and_availability_names_sit_at_their_codes():
    for code, name in ((ev.QUEUED, "queued"), (ev.TRANSMITTING, "transmitting"), (ev.WAITING, "waiting"),
                       (ev.TRANSMITTED, "transmitted"), (ev.DELIVERED, "delivered"), (ev.EXPIRED, "expired"),
                       (ev.CANCELED, "canceled"), (ev.FAILED, "failed")):
        assert ev.STATUS_NAMES[code] == name
    assert ev.AVAIL_NAMES[ev.UNKNOWN] == "unknown" and ev.AVAIL_NAMES[ev.AVAILABLE] == "available"
    assert ev.AVAIL_NAMES[ev.UNAVAILABLE] == "unavailable"


def test_refusal_and_modem_status_names_and_unknown_codes():
    assert sg.refuse_name(sg.REFUSE_FULL) == "receiver full" and sg.refuse_name(sg.REFUSE_NO_ROUTE).startswith("no route")
    assert sg.refuse_name(0) == 0 and sg.refuse_name(99) == 99
    assert seatrac_wire.status_name(0x30) == "XCVR_BUSY" and seatrac_wire.status_name(0x00) == "OK"
    assert seatrac_wire.status_name(0x77) == "CST_0x77"
    assert iridium_wire.mo_status_name(32) == "no network service" and iridium_wire.mo_status_name(0) == "MO sent"
    assert iridium_wire.mo_status_name(20) == "reserved failure"
    # every row of the packed tables, and codes that fall between them
    assert seatrac_wire.status_name(0x3A) == "XCVR_STATE_STOPPED" and seatrac_wire.status_name(0x3F) == "XCVR_STATE_RESP"
    assert seatrac_wire.status_name(0x02) == "CST_0x02"
    assert iridium_wire.mo_status_name(35) == "transceiver busy" and iridium_wire.mo_status_name(1) == "MO sent"
    assert iridium_wire.mo_status_name(31) == "reserved failure"


def test_the_seatrac_reader_takes_uppercase_hex_and_nothing_else():
    # every byte value in a hex position of a good line: the 16 uppercase
    # digits decode (the original passes, the others fail the CRC), any
    # other byte (lowercase included) is not hex; sync and line ends cut
    class Sink:
        def __init__(self):
            self.got = 0
            self.kinds = []

        def on_message(self, b, n):
            self.got += 1

        def on_junk(self, kind):
            self.kinds.append(kind)

    good = b"$4000028015"  # PING status, CRC 0x1580
    digits = b"0123456789ABCDEF"
    for pos in (1, 2, 9, 10):
        for c in range(256):
            if c in (sc.SYNC_RSP, 10, 13):  # the sync byte, line ends
                continue
            line = bytearray(good)
            line[pos] = c
            s = Sink()
            r = seatrac_wire.LineReader(sc.SYNC_RSP, s)
            r.feed(bytes(line) + b"\r\n")
            if c == good[pos]:
                assert s.got == 1 and not s.kinds, (pos, c)
            elif c in digits:
                assert s.got == 0 and s.kinds == [sc.JUNK_CRC], (pos, c, s.kinds)
            else:
                assert s.got == 0 and s.kinds == [sc.JUNK_HEX], (pos, c, s.kinds)
