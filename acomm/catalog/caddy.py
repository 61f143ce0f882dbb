# CADDY diver / vehicle messages (seed 003 sections 5, 6 and 7).
#
# The three agents are the diver (acoustic modem), the Buddy AUV and the
# PlaDyPos surface vehicle (both with USBL). Every message here has the 4-bit
# id of the seed's tables ("Message ID 4 bits, 16 levels"), and each message
# of the interrogation scheme (section 6.1) is exactly its table's size,
# id included. Where the seed's numbers disagree with each other the choice
# made is written next to the field and in docs/codec.md ("CADDY").
#
# Positions are 2-D offsets in metres to INIT, the local origin whose
# latitude and longitude the ORIGIN message carries.

from ..codec.fields import Enum, Fixed, Nested, Optional, Scalar, UInt, Wide, fail
from ..codec.message import Catalog, Message
from ..codec.text6 import Text6
from ..compat import const
from ..errors import CRCError, DecodeError

ID_BITS = const(4)

# --- navigation quantizations (section 5, first table) ---------------------


def speed(name="speed"):
    # 4 bits over [0, 1] m/s: 16 levels of 1/15 m/s ("~0.06 m/s").
    return Fixed(name, 0.0, 1.0, 1.0 / 15)


def heading(name="heading"):
    # 10 bits over [0, 360] degrees: 1023 steps of 0.352 deg ("~0.35"). A
    # step of exactly 0.35 would need 1029 steps (11 bits); 360 and 0 are
    # both codes, so no caller has to wrap 359.9 to 0.
    return Fixed(name, 0.0, 360.0, 360.0 / 1023)


def depth(name="depth"):
    # 7 bits at 0.5 m: [0, 64] m would need 129 codes, so the top is 63.5 m,
    # and the field saturates: a deeper diver reads 63.5 ("63.5 or more"),
    # and sensor noise above the surface reads 0.
    return Fixed(name, 0.0, 63.5, 0.5, saturate=True)


def offset_axis(name):
    # 10 bits over [-51.1, 51.2] m at 0.1 m (section 5; the 6.1 tables'
    # [-51.2, 51.2] would be 1025 codes).
    return Fixed(name, -51.1, 51.2, 0.1)


OFFSET = Message("offset", 0, (offset_axis("x"), offset_axis("y")))


def offset(name):
    # a 2-D offset to INIT (or to another agent): x then y, 20 bits
    return Nested(name, OFFSET)


def sonar_axis(name):
    # the footnote of "Buddy pings PlaDyPos": 8 bits over [-12.7, 12.8] m
    return Fixed(name, -12.7, 12.8, 0.1)


SONAR_OFFSET = Message("sonar_offset", 0, (sonar_axis("x"), sonar_axis("y")))


def sonar_offset(name):
    # the diver as seen in Buddy's 15 m sonar: 16 bits
    return Nested(name, SONAR_OFFSET)


_ARCSEC = 1.0 / 3600


def lat_init(name="lat"):
    # Latitude in degrees; code = (lat + 90) * 3600 (1''), 20 bits of
    # information written in the table's 22 (the legacy DDDM1M2m1m2 width).
    return Wide(Fixed(name, -90.0, 90.0, _ARCSEC), 22)


def lon_init(name="lon"):
    # Longitude in degrees; code = (lon + 180) * 3600, 21 bits in 22.
    return Wide(Fixed(name, -180.0, 180.0, _ARCSEC), 22)


# --- legacy position encodings (section 5, second table) --------------------
# Each is one binary number counting the table's quantum, in exactly the
# table's width; values are degrees for init and arc-seconds otherwise.


def legacy_init(name):
    # DDDM1M2m1m2: degrees after the +90 (lat) / +180 (lon) shift, 1''.
    # The table prints [0 0'00'', 180 59'59''], which cannot hold lon+180;
    # [0, 360] degrees fits the same 22 bits (21 needed).
    return Wide(Fixed(name, 0.0, 360.0, _ARCSEC), 22)


def legacy_minimum(name):
    # m3m4: [0.00'', 0.99''] at 0.01'', 7 bits
    return Fixed(name, 0.0, 0.99, 0.01)


def legacy_large(name):
    # M2m1m2m3m4: [0'00.00'', 9'59.99''] = [0, 599.99]'' at 0.01'', 16 bits
    # of information in the table's 18
    return Wide(Fixed(name, 0.0, 599.99, 0.01), 18)


def legacy_medium(name):
    # m1m2m3m4: [00.00'', 59.99''] at 0.01'', 13 bits
    return Fixed(name, 0.0, 59.99, 0.01)


def legacy_kml(name):
    # m1m2m3: [00.0'', 59.9''] at 0.1'', 10 bits
    return Fixed(name, 0.0, 59.9, 0.1)


# --- the 6-bit checksum -------------------------------------------------------
# CRC-6/CDMA2000-A (poly 0x27, init 0x3F, MSB first, no reflection, no final
# xor; catalogue check value for b"123456789" is 0x0D). The non-zero init
# makes an all-zero field fail the check, so a run of zero bits is never a
# valid checked field.

_CRC6_POLY = const(0x27)
_CRC6_INIT = const(0x3F)


def crc6(value, nbits, crc=_CRC6_INIT):
    # CRC over the nbits low bits of value, most significant first; pass the
    # result back as crc to continue over more bits.
    i = nbits
    while i:
        i -= 1
        top = (crc >> 5) ^ ((value >> i) & 1)
        crc = (crc << 1) & 0x3F
        if top:
            crc ^= _CRC6_POLY
    return crc


def crc6_bytes(data, crc=_CRC6_INIT):
    for b in data:
        crc = crc6(b, 8, crc)
    return crc


class Checked(Scalar):
    # A scalar field followed by the CRC-6 of its code bits (6 more bits).
    # A mismatch on decode is a CRCError (a DecodeError).

    def __init__(self, field):
        self.field = field
        self.name = field.name
        self.saturate = field.saturate
        self.ncodes = field.ncodes
        self.bits = field.bits
        self.max_bits = self.min_bits = field.bits + 6
        self.limit_bits = field.limit_bits

    def encode(self, w, v):
        c = self.field.code(v)
        w.write(c, self.bits)
        w.write(crc6(c, self.bits), 6)

    def decode(self, r):
        c = r.read(self.bits)
        k = r.read(6)
        if k != crc6(c, self.bits):
            raise fail(CRCError, "checksum %d, expected %d" % (k, crc6(c, self.bits)))
        if c >= self.ncodes:
            raise fail(DecodeError, "code %d past the last %d" % (c, self.ncodes - 1))
        return self.field.value(c)


# --- status, commands, alarms (section 7) ------------------------------------

# The tablet's commands to the vehicles: 16 labels, 4 bits.
COMMANDS = (
    "stop",
    "follow_me",
    "come_here",
    "hold_position",
    "go_up",
    "go_down",
    "take_photo",
    "start_mosaic",
    "stop_mosaic",
    "carry_equipment",
    "light_on",
    "light_off",
    "return_to_boat",
    "go_to_surface",
    "ack",
    "cancel",
)

# The diver's alarms, most urgent first: 16 labels, 4 bits.
ALARMS = (
    "emergency",
    "out_of_air",
    "low_air",
    "emergency_ascent",
    "rapid_ascent",
    "decompression",
    "lost_buddy",
    "lost_vehicle",
    "entangled",
    "cramp",
    "injury",
    "vertigo",
    "cold",
    "high_heart_rate",
    "equipment_failure",
    "low_battery",
)

# Offsets in PLADYPOS_REPLY count steps of QUANT_STEPS_M[quant] metres
# (section 6.1: "range quantization is 0.1-0.5 m - 2 bit flag"). quant 0 is
# the tables' 0.1 m and the field values are metres; with another quant the
# sender puts offset / QUANT_SCALE[quant] into the fields and the receiver
# multiplies back (scaled_offset), widening the range to +-256 m at 0.5 m.
QUANT_STEPS_M = (0.1, 0.2, 0.3, 0.5)
QUANT_SCALE = (1, 2, 3, 5)


def scaled_offset(value, quant):
    # a decoded offset field value -> metres under the message's quant flag
    return value * QUANT_SCALE[quant]


# The longest chat line: 40 characters + a 4-bit id is 244 bits, inside the
# 31-byte payload of the CADDY modem packet (section 4.1).
CHAT_CHARS = const(40)

# --- the messages ---------------------------------------------------------------
# Sizes in comments include the 4-bit id.

# 60: PlaDyPos replies to Buddy's ping with its own offset and kinematics and
# the diver offset it measured (AT4). Id 0 goes to a long message so that
# zero padding can never be read as a message.
PLADYPOS_REPLY = Message(
    "pladypos_reply",
    0,
    (UInt("quant", 0, 3), offset("pladypos"), heading("course"), speed("speed"), offset("diver")),
)
# 21: the diver's modem reply to a USBL ping (AT2, AT6).
DIVER_REPLY = Message("diver_reply", 1, (heading("heading"), depth("depth")))
# 25: Buddy pings PlaDyPos with its kinematics (AT3).
BUDDY_PING = Message("buddy_ping", 2, (depth("depth"), heading("course"), speed("speed")))
# 45: the same when Buddy sees the diver in sonar or camera (the "(45)").
BUDDY_PING_DIVER = Message(
    "buddy_ping_diver", 3, (depth("depth"), heading("course"), speed("speed"), offset("diver"))
)
# 45: Buddy interrogates the diver with its own state (AT5). The table lists
# seven rows (85 bits) for "45 (65)": we read the 20-bit position row as
# Buddy's own position (the text: Buddy "sends its updated position
# estimate"; the diver has no USBL to measure it, and already heard
# PlaDyPos's position in AT4), and the diver offset as the "(65)" extra
# sent when Buddy sees the diver, as in Buddy's ping to PlaDyPos.
BUDDY_TO_DIVER = Message(
    "buddy_to_diver", 4, (depth("depth"), offset("buddy"), heading("course"), speed("speed"))
)
# 65: the same with the diver offset.
BUDDY_TO_DIVER_EXT = Message(
    "buddy_to_diver_ext",
    5,
    (depth("depth"), offset("buddy"), heading("course"), speed("speed"), offset("diver")),
)
# 24: Buddy answers PlaDyPos's ping with the diver position (AT8).
DIVER_POSITION = Message("diver_position", 6, (offset("diver"),))
# 48: the local origin INIT (section 5, "position init"), six whole bytes.
ORIGIN = Message("origin", 7, (lat_init("lat"), lon_init("lon")))
# <= 29: the diver's body measurements, each present only when measured.
DIVER_STATUS = Message(
    "diver_status",
    8,
    (
        Optional(UInt("heart_rate", 30, 220)),  # beats per minute, 8 bits
        Optional(UInt("breathing_rate", 0, 63)),  # breaths per minute, 6 bits
        Optional(Fixed("body_temp", 30.0, 45.0, 0.1)),  # deg C, 8 bits
    ),
)
# 8: a tablet command.
COMMAND = Message("command", 9, (Enum("command", COMMANDS),))
# 8: a diver alarm.
ALARM = Message("alarm", 10, (Enum("alarm", ALARMS),))
# 15: one of 32 predefined messages (5 bits) with its 6-bit checksum.
PREDEFINED = Message("predefined", 11, (Checked(UInt("code", 0, 31)),))
# <= 244: a chat line in the 6-bit alphabet.
CHAT = Message("chat", 12, (Text6("text", CHAT_CHARS),))

MESSAGES = (
    PLADYPOS_REPLY,
    DIVER_REPLY,
    BUDDY_PING,
    BUDDY_PING_DIVER,
    BUDDY_TO_DIVER,
    BUDDY_TO_DIVER_EXT,
    DIVER_POSITION,
    ORIGIN,
    DIVER_STATUS,
    COMMAND,
    ALARM,
    PREDEFINED,
    CHAT,
)

CATALOG = Catalog("caddy", ID_BITS, MESSAGES)
