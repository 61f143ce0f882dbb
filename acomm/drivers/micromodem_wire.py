# The WHOI Micro-Modem on the wire, as both ends see it. Shared by the driver
# (acomm.drivers.micromodem) and the emulator (ports/sim), so both agree on
# the bytes and on the time they take:
#   NMEA 0183 sentences: building them, checking their checksums, cutting a
#   byte stream into sentences, and reading their fields;
#   the packet rates and an airtime model;
#   node-discovery adverts carried as mini-packets.
#
# Sentences:
#
#   $ TALKER SENTENCE , field , field ... * HH CR LF
#
# HH is the XOR of every byte between '$' and '*', two uppercase hex digits.
# Some MM2 firmware sends 8 hex digits instead: the PyPI `acomms` 3.1.0
# library checks those with a table-driven CRC-32 whose table is that of the
# reflected polynomial 0xD663B05D (0xBA0DC66B unreflected), initial value
# 0xFFFFFFFF, final inversion. That is NOT the common (zip/Ethernet) CRC-32,
# and no WHOI document confirming it was available: the line reader can verify
# it (the default), accept it unchecked, or refuse such lines (docs say how).
# Lines from the modem end in CR, LF or both; the host writes CR LF.


from ..compat import const
from ..codec.crc import nmea_xor
from ..errors import AcommError
from ..frame import ADVERT
from .base import SyncLines

_HEX = b"0123456789ABCDEF"

CSUM32_VERIFY = const(0)
CSUM32_ACCEPT = const(1)  # trust the line without checking the 8 digits
CSUM32_REJECT = const(2)

MAX_LINE = const(600)  # a 256-byte rate-5 frame is 512 hex digits + fields


def _hex_values():
    # 0..15 for hex digits (either case), 0xFF for anything else
    t = bytearray(b"\xff" * 256)
    for i in range(16):
        t[_HEX[i]] = i
    for i in range(6):
        t[0x61 + i] = 10 + i
    return t


HEXVAL = _hex_values()


def crc32(data):
    # The 8-digit checksum of acomms 3.1.0 (see the header comment). Bitwise:
    # slow but small, and 8-digit lines are rare.
    c = 0xFFFFFFFF
    for b in data:
        c ^= b
        for _ in range(8):
            c = (c >> 1) ^ 0xD663B05D if c & 1 else c >> 1
    return c ^ 0xFFFFFFFF


def hexlify(data):
    # uppercase hex string of bytes (the modem's data fields)
    out = bytearray(2 * len(data))
    j = 0
    for b in data:
        out[j] = _HEX[b >> 4]
        out[j + 1] = _HEX[b & 15]
        j += 2
    return out.decode()


def sentence(name, *fields):
    # One line: sentence("CCCYC", 0, 1, 2, 1, 1, 1) -> b"$CCCYC,0,1,2,1,1,1*5B\r\n".
    # Fields may be str, int or bytes (taken as text).
    parts = [name]
    for f in fields:
        if isinstance(f, (bytes, bytearray)):
            f = bytes(f).decode()
        parts.append(str(f))
    body = ",".join(parts).encode()
    return b"$" + body + ("*%02X\r\n" % nmea_xor(body)).encode()


def sentence32(name, *fields):
    # As sentence(), with the 8-digit checksum (the emulator can speak it).
    line = sentence(name, *fields)
    body = line[1 : line.index(b"*")]
    return b"$" + body + ("*%08X\r\n" % crc32(body)).encode()


def _hexnum(buf, i, j):
    v = 0
    for k in range(i, j):
        d = HEXVAL[buf[k]]
        if d == 0xFF:
            return -1
        v = (v << 4) | d
    return v


# Kinds of damaged input the LineReader counts (keys of its junk dict).
JUNK_TEXT = "text"  # characters outside a sentence (noise, boot text)
JUNK_TRUNCATED = "truncated"  # a new '$' before the line ended
JUNK_OVERLONG = "overlong"  # longer than the buffer: dropped
JUNK_CHECKSUM = "checksum"  # the checksum does not match
JUNK_FORMAT = "format"  # no checksum, or not 2/8 hex digits, or no name


class LineReader(SyncLines):
    # Cuts the stream into '$' sentences (the framing is base.SyncLines); each
    # good one goes to sink.on_sentence(buf, n) with buf[:n] the text between '$' and '*'
    # (valid until the next feed). Damaged lines are dropped, counted in
    # self.junk and reported to sink.on_junk(kind). One preallocated buffer;
    # nothing is allocated per byte.
    _k_text = JUNK_TEXT
    _k_cut = JUNK_TRUNCATED
    _k_long = JUNK_OVERLONG

    def __init__(self, sink, cap=MAX_LINE, csum32=CSUM32_VERIFY, need_checksum=True):
        SyncLines.__init__(self, 0x24, sink, cap)
        self.csum32 = csum32
        self.need_checksum = need_checksum
        self.sentences = 0

    def _end_line(self, n):
        buf = self._line
        star = -1
        for i in range(n - 1, -1, -1):
            if buf[i] == 0x2A:  # '*'
                star = i
                break
        if star < 0:
            if self.need_checksum or n == 0:
                self._junk(JUNK_FORMAT)
                return
            star = n
        else:
            digits = n - star - 1
            if digits == 2:
                want = _hexnum(buf, star + 1, n)
                if want < 0:
                    self._junk(JUNK_FORMAT)
                    return
                if want != nmea_xor(memoryview(buf)[:star]):
                    self._junk(JUNK_CHECKSUM)
                    return
            elif digits == 8:
                if self.csum32 == CSUM32_REJECT:
                    self._junk(JUNK_FORMAT)
                    return
                want = _hexnum(buf, star + 1, n)
                if want < 0:
                    self._junk(JUNK_FORMAT)
                    return
                if self.csum32 == CSUM32_VERIFY and want != crc32(memoryview(buf)[:star]):
                    self._junk(JUNK_CHECKSUM)
                    return
            else:
                self._junk(JUNK_FORMAT)
                return
        if star < 5:  # not even a talker and a sentence name
            self._junk(JUNK_FORMAT)
            return
        self.sentences += 1
        self._sink.on_sentence(buf, star)


# -- fields --------------------------------------------------------------------
def fields(buf, n):
    # [b"CACYC", b"0", b"1", ...] for the text of one sentence
    return bytes(memoryview(buf)[:n]).split(b",")


def num(f, lo=None, hi=None):
    # A decimal integer field, or None when it is not one (or out of range).
    n = len(f)
    if n == 0 or n > 9:
        return None
    i = 1 if f[0] == 0x2D else 0  # '-'
    if i == n:
        return None
    v = 0
    for k in range(i, n):
        d = f[k] - 0x30
        if not 0 <= d <= 9:
            return None
        v = v * 10 + d
    if i:
        v = -v
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        return None
    return v


def real(f):
    # A decimal number field as a float, or None.
    if not 0 < len(f) <= 20:
        return None
    for b in f:
        if not (0x30 <= b <= 0x39 or b in b"+-.eE"):
            return None
    try:
        return float(f.decode())
    except ValueError:
        return None


def text(f):
    # A text field as str. A sentence whose checksum matches may still hold
    # bytes that are not UTF-8 (line noise with a lucky XOR): those become
    # "?" instead of a UnicodeError out of the driver.
    try:
        return bytes(f).decode()
    except ValueError:  # UnicodeError (UnicodeDecodeError on CPython)
        return "".join(chr(b) if b < 0x80 else "?" for b in f)


def unhex(f):
    # The bytes of a hex data field, or None when it is not even-length hex.
    n = len(f)
    if n & 1:
        return None
    out = bytearray(n >> 1)
    for i in range(0, n, 2):
        hi = HEXVAL[f[i]]
        lo = HEXVAL[f[i + 1]]
        if hi == 0xFF or lo == 0xFF:
            return None
        out[i >> 1] = (hi << 4) | lo
    return bytes(out)


def hhmmss(ms):
    # Time of day in the modem's HHMMSS form from milliseconds since midnight.
    s = (ms // 1000) % 86400
    return "%02d%02d%02d" % (s // 3600, (s // 60) % 60, s % 60)


# -- packet rates and airtime -------------------------------------------------
# The driver's capabilities and watchdogs and the emulator's packet ends.
#
# Rates 0-5 (ref/modem-protocols.md 3.3; goby3 PACKET_SIZE): the largest
# frame in bytes and the bit rate (from a WHOI header whose repository was not
# identified, so unconfirmed). acomm sends one frame per cycle.
#
# Airtime, an ESTIMATE (nothing was measured):
#   mini-packet (and each leg of a ping, and a frame's acknowledgement):
#       mini_ms, 700 ms by default (seed 000: "about 0.7 s")
#   rate 0 (FH-FSK): the cycle header travels as its own mini-packet first,
#       then the data packet: mini_ms + fsk_gap_ms + 8 bits x n / 80 bit/s;
#       with the defaults a 32-byte frame takes 0.7 + 4.0 s (seed 000: "about
#       4 s more" than a mini-packet)
#   rates 1-5 (PSK): header and data in one packet: psk_ms (preamble, probe
#       and header) + 8 bits x n / bit rate
# Every figure is multiplied by `scale` so tests on real time can run fast.

FRAME_BYTES = (32, 64, 64, 256, 256, 256)
BITRATE = (80, 250, 500, 1200, 1300, 5300)
FRAMES_PER_PACKET = (1, 3, 3, 2, 2, 8)  # what the modem could carry; acomm uses 1


class Airtime:
    def __init__(self, mini_ms=700, fsk_gap_ms=800, psk_ms=1000, scale=1.0):
        self.mini_ms_ = mini_ms
        self.fsk_gap_ms = fsk_gap_ms
        self.psk_ms = psk_ms
        self.scale = scale

    def mini_ms(self):
        return int(self.mini_ms_ * self.scale)

    def packet_ms(self, rate, nbytes):
        bits_ms = nbytes * 8000 // BITRATE[rate]
        if rate == 0:
            t = self.mini_ms_ + self.fsk_gap_ms + bits_ms
        else:
            t = self.psk_ms + bits_ms
        return int(t * self.scale)

    def travel_ms(self, metres, sound_speed):
        # propagation is physics: never scaled
        return int(metres * 1000 / sound_speed)


def check_rate(rate):
    if not isinstance(rate, int) or not 0 <= rate <= 5:
        raise AcommError("Micro-Modem rate %r outside 0..5" % (rate,))
    return rate


# -- adverts as mini-packets --------------------------------------------------
# Node-discovery adverts as Micro-Modem mini-packets (seed 000: "This active
# advertisement takes the form of a mini-packet destined to the broadcast
# address"). A mini-packet carries 13 bits and takes about 0.7 s of air; a
# full packet at rate 0 takes about 4.7 s.
#
# The Link hands the driver an elided acomm ADVERT frame (acomm.frame,
# acomm.link.discovery): 3 bytes
#     0 TTT SSSS   type ADVERT (2), no flags byte, 4-bit sequence
#     node id
#     advert period in units of 4 s (1..255)
# When the node id equals the modem's own address (the Link's default
# identity address map), the node id is implied by the mini-packet's source
# address, and the rest fits in 13 bits:
#
#     bit 12      1: "this is an acomm advert" (the marker)
#     bits 11..8  the frame's sequence
#     bits 7..0   the period in 4 s units
#
# The receiver rebuilds the identical 3-byte frame with node id = the
# mini-packet's source address. Values with bit 12 clear, or a zero period,
# are not ours (someone else's use of mini-packets): counted and ignored.

MARKER = const(0x1000)
MASK = const(0x1FFF)
_ADVERT_BYTE = ADVERT << 4  # the elided header byte (acomm.frame): no flags byte, sequence 0


def advert_to_mini(frame, own_addr):
    # The 13-bit value for this frame, or None when it must go as a normal
    # packet (not a plain advert, or not for our own address).
    if own_addr is None or len(frame) != 3:
        return None
    b0 = frame[0]
    if b0 & 0xF0 != _ADVERT_BYTE or frame[1] != own_addr or frame[2] == 0:
        return None
    return MARKER | ((b0 & 0x0F) << 8) | frame[2]


def mini_to_advert(value, src_addr):
    # The elided ADVERT frame a mini-packet from src_addr stands for, or None.
    value &= MASK
    if not value & MARKER or not value & 0xFF or not 0 <= src_addr <= 254:
        return None
    return bytes((_ADVERT_BYTE | ((value >> 8) & 0x0F), src_addr, value & 0xFF))
