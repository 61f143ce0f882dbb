# SMS PDUs (3GPP TS 23.040 as summarised in ref/modem-protocols.md 6.2):
# SMS-SUBMIT, which the driver writes after AT+CMGS in PDU mode, and
# SMS-DELIVER, which AT+CMGR / AT+CMGL show for a received message. The
# emulator (acomm_sim.gsm) uses the other two directions. Bytes here are the
# PDU itself; the modem sees them as uppercase hex (to_hex / from_hex).
#
# Addresses: a digit count (or, for the SMSC, an octet count), the type of
# number (0x91 international, shown with a leading "+"; 0x81 otherwise;
# 0xD0 alphanumeric sender names, decoded as 7-bit text) and the digits in
# BCD, two per octet, low nibble first, padded with F.
# User data: 8-bit (DCS 0x04, up to 140 octets) is what acomm sends; 7-bit
# GSM text (DCS 0x00, up to 160 septets) is packed and unpacked too, with
# characters taken as their code (the GSM alphabet matches ASCII on letters,
# digits and "+/=", which is all base64 needs); UCS2 is passed through as
# bytes. A user data header (UDHI) is split off and returned apart.

from binascii import hexlify, unhexlify

from ..compat import const
from ..errors import DecodeError, EncodeError

UD_MAX = const(140)
SEPTETS_MAX = const(160)
DCS_7BIT = const(0x00)
DCS_8BIT = const(0x04)
DCS_UCS2 = const(0x08)
TON_INTERNATIONAL = const(0x91)
TON_NATIONAL = const(0x81)

_DIGITS = b"0123456789*#abc"


def to_hex(b):
    return hexlify(b).upper()


def from_hex(s):
    if len(s) % 2:
        raise DecodeError("odd number of hex digits")
    try:
        return unhexlify(s)
    except ValueError:
        raise DecodeError("not hex")


def alphabet(dcs):
    # 0: GSM 7-bit, 1: 8-bit data, 2: UCS2
    if dcs & 0xF0 == 0xF0:
        return 1 if dcs & 0x04 else 0
    if dcs & 0x80 == 0:  # general data coding (and its auto-deletion group)
        a = (dcs >> 2) & 3
        return 0 if a == 3 else a
    return 2 if dcs & 0xF0 == 0xE0 else 0  # message waiting groups


# -- septets ------------------------------------------------------------------------------
def pack_septets(text):
    n = len(text)
    if n > SEPTETS_MAX:
        raise EncodeError("%d characters do not fit one SMS (160)" % n)
    out = bytearray((n * 7 + 7) // 8)
    bit = 0
    for c in text:
        if c > 127:
            raise EncodeError("character %d is not in the GSM 7-bit alphabet" % c)
        i = bit >> 3
        s = bit & 7
        out[i] |= (c << s) & 0xFF
        if s > 1 and i + 1 < len(out):
            out[i + 1] |= c >> (8 - s)
        bit += 7
    return bytes(out)


def unpack_septets(data, count, skip_bits=0):
    if (count * 7 + skip_bits + 7) // 8 > len(data):
        raise DecodeError("7-bit user data shorter than its length")
    out = bytearray(count)
    bit = skip_bits
    for k in range(count):
        i = bit >> 3
        s = bit & 7
        v = data[i] >> s
        if s > 1:
            v |= data[i + 1] << (8 - s)
        out[k] = v & 0x7F
        bit += 7
    return bytes(out)


# -- addresses -------------------------------------------------------------------------------
def _bcd(digits):
    out = bytearray((len(digits) + 1) // 2)
    for i in range(len(digits)):
        v = _DIGITS.find(bytes((digits[i],)))
        if v < 0:
            raise EncodeError("%r is not a phone number digit" % chr(digits[i]))
        if i & 1:
            out[i >> 1] = (out[i >> 1] & 0x0F) | (v << 4)
        else:
            out[i >> 1] = v | 0xF0
    return bytes(out)


def _split_number(number):
    n = number.encode() if isinstance(number, str) else bytes(number)
    if n[:1] == b"+":
        return n[1:], TON_INTERNATIONAL
    return n, TON_NATIONAL


def encode_address(number):
    # TP-DA / TP-OA: digit count, type, BCD
    digits, ton = _split_number(number)
    if not 1 <= len(digits) <= 20:
        raise EncodeError("a phone number has 1..20 digits")
    return bytes((len(digits), ton)) + _bcd(digits)


def encode_smsc(number):
    # the SCA: 00 for "the SMSC stored in the modem", else octet count first
    if not number:
        return b"\x00"
    digits, ton = _split_number(number)
    b = _bcd(digits)
    return bytes((len(b) + 1, ton)) + b


def _decode_address(pdu, i, semi):
    # -> (number as str, index after it); semi: the length counts digits
    if i + 2 > len(pdu):
        raise DecodeError("PDU ends inside an address")
    n = pdu[i]
    ton = pdu[i + 1]
    octets = (n + 1) // 2 if semi else n - 1
    if octets < 0 or i + 2 + octets > len(pdu):
        raise DecodeError("address longer than the PDU")
    body = pdu[i + 2 : i + 2 + octets]
    if ton & 0x70 == 0x50:
        return unpack_septets(body, n * 4 // 7).decode(), i + 2 + octets
    out = bytearray()
    for b in body:
        for v in (b & 0x0F, b >> 4):
            if v == 0x0F:
                break
            out.append(_DIGITS[v])
    if semi:
        out = out[:n]
    s = out.decode()
    return ("+" + s if ton & 0x70 == 0x10 else s), i + 2 + octets


# -- user data ---------------------------------------------------------------------------------
def _encode_ud(dcs, data):
    if alphabet(dcs) == 0:
        return bytes((len(data),)) + pack_septets(data)
    if len(data) > UD_MAX:
        raise EncodeError("%d bytes exceed the 140 of one SMS" % len(data))
    return bytes((len(data),)) + bytes(data)


def _decode_ud(pdu, i, dcs, udhi):
    # -> (data, header or None)
    if i >= len(pdu):
        raise DecodeError("PDU ends before its user data length")
    udl = pdu[i]
    ud = pdu[i + 1 :]
    seven = alphabet(dcs) == 0
    if seven:
        if udl > SEPTETS_MAX:
            raise DecodeError("7-bit user data length %d over 160" % udl)
        need = (udl * 7 + 7) // 8
    else:
        if udl > UD_MAX:
            raise DecodeError("user data length %d over 140" % udl)
        need = udl
    if len(ud) < need:
        raise DecodeError("user data shorter than its length")
    hdr = None
    if udhi:
        h = ud[0] + 1 if ud else 0
        if not ud or h > need:
            raise DecodeError("bad user data header")
        hdr = bytes(ud[1:h])
        if seven:
            bits = h * 8
            skip = (7 - bits % 7) % 7
            count = udl - (bits + skip) // 7
            return unpack_septets(ud[h:], count, skip), hdr
        return bytes(ud[h:need]), hdr
    if seven:
        return unpack_septets(ud, udl), None
    return bytes(ud[:need]), None


# -- the two PDUs, both ways ---------------------------------------------------------------------
def encode_submit(number, data, dcs=DCS_8BIT, vp=None, smsc=None):
    # -> (PDU bytes with the SCA first, the TPDU length AT+CMGS wants).
    # vp: relative validity period octet (None: no TP-VP)
    if vp is not None and not 0 <= vp <= 255:
        raise EncodeError("a relative validity period is one octet")
    sca = encode_smsc(smsc)
    t = bytearray((0x11 if vp is not None else 0x01, 0x00))
    t.extend(encode_address(number))
    t.extend(bytes((0x00, dcs)))
    if vp is not None:
        t.append(vp)
    t.extend(_encode_ud(dcs, data))
    return sca + bytes(t), len(t)


def _skip_sca(pdu):
    if not pdu:
        raise DecodeError("empty PDU")
    i = 1 + pdu[0]
    if i >= len(pdu):
        raise DecodeError("PDU ends inside its SMSC address")
    return i


def decode_submit(pdu):
    # -> (destination number, dcs, data, vp octet or None, header or None)
    i = _skip_sca(pdu)
    fo = pdu[i]
    if fo & 3 != 1:
        raise DecodeError("not an SMS-SUBMIT (first octet %02X)" % fo)
    number, i = _decode_address(pdu, i + 2, True)
    if i + 2 > len(pdu):
        raise DecodeError("PDU ends before its DCS")
    dcs = pdu[i + 1]
    i += 2
    vpf = (fo >> 3) & 3
    vp = None
    if vpf == 2:
        if i >= len(pdu):
            raise DecodeError("PDU ends before its validity period")
        vp = pdu[i]
        i += 1
    elif vpf:
        i += 7
    data, hdr = _decode_ud(pdu, i, dcs, fo & 0x40)
    return number, dcs, data, vp, hdr


def encode_deliver(number, data, dcs=DCS_8BIT, scts=b"\x42\x50\x10\x21\x00\x00\x00", smsc="+447785016005"):
    # an SMS-DELIVER as a modem shows it (with its SMSC's address)
    return encode_smsc(smsc) + bytes((0x04,)) + encode_address(number) + bytes((0x00, dcs)) + bytes(scts) + _encode_ud(dcs, data)


def decode_deliver(pdu):
    # -> (originating number, dcs, data, service centre time stamp, header
    # or None); raises DecodeError
    i = _skip_sca(pdu)
    fo = pdu[i]
    if fo & 3 != 0:
        raise DecodeError("not an SMS-DELIVER (first octet %02X)" % fo)
    number, i = _decode_address(pdu, i + 1, True)
    if i + 9 > len(pdu):
        raise DecodeError("PDU ends before its time stamp")
    dcs = pdu[i + 1]
    scts = bytes(pdu[i + 2 : i + 9])
    data, hdr = _decode_ud(pdu, i + 9, dcs, fo & 0x40)
    return number, dcs, data, scts, hdr
