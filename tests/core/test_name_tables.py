# The name tables of statuses, availabilities, refusals and modem status
# codes are constants, tuples or packed strings (they stay in flash when
# frozen, where a dict would be built on the heap): each name sits at its
# code.
from acomm import events as ev
from acomm.transport import segment as sg
from acomm.drivers import iridium_wire, seatrac_wire


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
    assert iridium_wire.mo_status_name(35) == "transceiver busy" and iridium_wire.mo_status_name(1).startswith("MO sent, MT")
    assert iridium_wire.mo_status_name(31) == "reserved failure"


def test_the_seatrac_hex_table_is_uppercase_hex_and_nothing_else():
    # written out as a constant (it stays in flash): 0..15 at '0'-'9' and
    # 'A'-'F', 0xFF everywhere else (lowercase included)
    hv = seatrac_wire.HEXVAL
    assert len(hv) == 256
    digits = b"0123456789ABCDEF"
    for c in range(256):
        assert hv[c] == (digits.index(bytes((c,))) if bytes((c,)) in digits else 0xFF), c
