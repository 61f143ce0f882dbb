# The GPS time reader (acomm.drivers.gps): NMEA 0183 RMC and ZDA sentences
# in, time fixes out; a bad checksum, status V, garbage and lines too long
# give none, and the reader goes on with the next sentence.
from acomm.drivers.gps import UNC_MS, GpsReader, parse
from acomm.errors import DecodeError
from acomm.events import EV_TIME, TIME_AT, TIME_MS, TIME_SECS, TIME_SOURCE, TIME_UNC
from acomm.civil import days2020
from checks import raises

# 2026-11-27 22:10:05 UTC in seconds from 2020-01-01
T = days2020(2026, 11, 27) * 86400 + 22 * 3600 + 10 * 60 + 5


def nmea(body):
    # "$" body "*" checksum CR LF
    x = 0
    for c in body.encode():
        x ^= c
    return b"$%s*%02X\r\n" % (body.encode(), x)


RMC = "GPRMC,221005.00,A,4807.038,N,01131.000,E,0.4,84.4,271126,,,A"
ZDA = "GNZDA,221005.25,27,11,2026,00,00"


def test_rmc_and_zda_give_the_time_and_date():
    assert days2020(2026, 11, 27) == 2522
    g = GpsReader()
    g.feed(1000, nmea(RMC))
    g.feed(2000, nmea(ZDA))
    evs = g.take_times()
    assert evs == [(EV_TIME, "gps", T, 0, UNC_MS, 1000), (EV_TIME, "gps", T, 250, UNC_MS, 2000)]
    e = evs[1]
    assert (e[TIME_SOURCE], e[TIME_SECS], e[TIME_MS], e[TIME_UNC], e[TIME_AT]) == ("gps", T, 250, 1000, 2000)
    assert g.take_times() == [] and g.stats["fixes"] == 2
    # the talker does not matter; the other sentences pass by unread
    g.feed(3000, nmea("GPGGA,221005.00,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,") + nmea(
        "GLRMC,221006,A,,,,,,,271126,,"))
    assert g.take_times() == [(EV_TIME, "gps", T + 1, 0, UNC_MS, 3000)]


def test_bytes_in_any_pieces():
    g = GpsReader()
    data = b"\x00\xff junk" + nmea(RMC) + b"more junk$$" + nmea(ZDA)
    for i in range(len(data)):
        g.feed(i, data[i:i + 1])
    assert [e[TIME_SECS] for e in g.take_times()] == [T, T]


def test_a_bad_checksum_or_none_is_no_source():
    g = GpsReader()
    bad = bytearray(nmea(RMC))
    bad[-4] = ord("0") if bad[-4] != ord("0") else ord("1")
    g.feed(0, bytes(bad))
    g.feed(0, b"$" + RMC.encode() + b"\r\n")  # no checksum at all
    assert g.take_times() == [] and g.stats["bad_checksum"] == 2
    raises(DecodeError, parse, bytearray(b"GPZDA,x*00"), 10)


def test_status_v_is_no_source_and_silences_zda():
    g = GpsReader()
    g.feed(0, nmea(RMC.replace(",A,", ",V,", 1)))
    g.feed(0, nmea(ZDA))  # the receiver's own clock while it has no fix
    assert g.take_times() == [] and g.stats["void"] == 2
    g.feed(0, nmea(RMC) + nmea(ZDA))
    assert len(g.take_times()) == 2
    # a ZDA with empty fields (no time yet) is none either
    g.feed(0, nmea("GPZDA,,,,,,"))
    assert g.take_times() == [] and g.stats["void"] == 3


def test_garbage_and_malformed_fields_resync():
    g = GpsReader()
    g.feed(0, nmea("GPRMC,2210xx.00,A,,,,,,,271126,,") + nmea("GPZDA,221005,27,13,2026,00,00") + nmea("GPRMC,1"))
    assert g.take_times() == [] and g.stats["malformed"] == 3
    # a sentence cut by the next "$" is dropped, the next one read
    g.feed(0, b"$GPRMC,2210" + nmea(RMC))
    assert len(g.take_times()) == 1


def test_a_line_too_long_is_dropped_and_the_buffer_stays_bounded():
    g = GpsReader(line_max=82)
    g.feed(0, b"$GPRMC," + b"9" * 200 + b"\r\n")
    assert g.stats["too_long"] == 1 and len(g._buf) == 82
    g.feed(0, nmea(RMC))
    assert len(g.take_times()) == 1
